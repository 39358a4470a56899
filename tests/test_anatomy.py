"""Synthetic anatomy with exact truth, for the shapes real meshes show (issue #44, item 2).

A capped aortic arch (``vesselgp.synthetic_anatomy.capped_arch``): five flat caps of very different sizes (the
ascending aorta's 13.8 mm, 2.6-3.3 times the arch branches'), the widest behind the sinuses of its root. The real
4D-flow arch of this shape had its widest cap missed: the descending aorta became the root and the whole
ascending aorta was reported as a bulge of 1.77x, with exit 0. The truth is the generator's: its tubes' exact
centre lines and radii, and the caps it cut.
"""
from __future__ import annotations

import logging

import numpy as np
import pytest

import vesselgp
from vesselgp.prepared import PreparedMesh
from vesselgp.synthetic_anatomy import capped_arch

#: every true cap found within this many of its radii of its true centre, its radius within this fraction
CENTER_RADII, RADIUS_REL = 0.1, 0.05


def _decimated(V, F, fraction):
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(V, F))
    ms.meshing_decimation_quadric_edge_collapse(targetperc=fraction, preservetopology=True, preserveboundary=True)
    m = ms.current_mesh()
    return m.vertex_matrix().astype(np.float64), m.face_matrix().astype(np.int64)


@pytest.fixture(scope="module")
def arches():
    """The arch with a sinus of 0.45 (1.3 times its annulus, a normal root), at the generator's resolution and
    decimated to 30 % (its root cap then about 60 faces, a rim edge of them folded); with a sinus of 0.7 (1.5
    times), its wall leaving the cap at up to 38 degrees; and with a sinus of 1.5, whose root flares too fast
    behind its valve plane for its cap's rim to be the wall's all round."""
    V, F, truth, caps = capped_arch(sinus=0.45)
    Vd, Fd = _decimated(V, F, 0.3)
    return {"fine": (V, F, truth, caps), "decimated": (Vd, Fd, truth, caps), "steep": capped_arch(sinus=0.7),
            "flared": capped_arch(sinus=1.5)}


def _matched(ends, caps):
    """The found end nearest to each true cap (centre, direction, radius), asserted to be that cap."""
    out = []
    for c, d, r in caps:
        e = min(ends, key=lambda x: np.linalg.norm(x.center - c))
        assert e.kind == "cap" and np.linalg.norm(e.center - c) < CENTER_RADII * r, (e.describe(), c)
        assert abs(e.radius - r) < RADIUS_REL * r and e.direction @ d > np.cos(np.radians(10))
        out.append(e)
    return out


@pytest.mark.parametrize("which", ["fine", "decimated", "steep"])
def test_a_capped_arch_has_every_cap_and_its_widest_as_root(arches, which):
    """Every cap found (the root's rim leaving its plane at up to 38 degrees on the steep sinus, a 1 rad crease
    was asked before), the widest (the ascending aorta's, behind its sinuses) the root; no bulge reported (the
    sinus is the root's own, 1.3-1.5 times the annulus over 8 mm: under the bulge ratio beside it); every path
    from the root's centre to its tip's; the whole wall covered."""
    V, F, truth, caps = arches[which]
    tree = vesselgp.fit_vessel_tree(V, F)
    found = _matched(tree.ends, caps)
    assert len(tree.ends) == 5 and tree.ends[tree.root] is found[0]  # the ascending aorta's cap
    assert not tree.bulges
    assert tree.checks.worst_end_gap < 0.05 and tree.checks.largest_uncovered < 0.5
    if which != "steep":
        _on_the_true_centre_lines(tree, truth, caps)


def _on_the_true_centre_lines(tree, truth, caps):
    """The axes within 5 % of the radius of the true centre lines away from the arch's junctions and the caps (2
    radii), and the ascending aorta's from 2 radii off its junction to 1 radius from its cap, its sinus included
    (1 % measured on the fine arch, its sinus 1.3 times its annulus; on the steep one, 1.5 times, its trunk's fit does not settle and the lumen's centre line it takes
    strays 25 % of the radius into the sinus)."""
    t = truth.truth
    forks = [(t.branches[b].centers[0], t.branches[t.branches[b].parent].radii[-1]) for b in (2, 4, 6)]  # the arch's
    kept, total = 0, 0
    for p in tree.paths:
        X = p.dense_points
        keep = np.all([np.linalg.norm(X - c, axis=1) > 2.0 * r for c, _, r in caps] +
                      [np.linalg.norm(X - c, axis=1) > 2.0 * r for c, r in forks], axis=0)
        d, r, _, _ = t.nearest(X[keep])
        assert np.max(d / r, initial=0.0) < 0.05, (p.ends, np.max(d / r))
        kept, total = kept + keep.sum(), total + len(X)
    assert kept > 0.1 * total
    # the ascending aorta, the vessel a missed root cap left without an axis, has one along its length
    import igl

    asc = t.branches[7]
    inner = (asc.s > 2 * asc.radii[0]) & (asc.s < asc.length - asc.radii[-1])  # from its junction to its cap
    L = tree.paths[0].dense_points
    d = np.sqrt(igl.point_mesh_squared_distance(asc.centers[inner], L, np.c_[np.arange(len(L) - 1),
                                                                             np.arange(1, len(L))])[0])
    assert inner.sum() > 40 and np.max(d / asc.radii[inner]) < 0.05

def test_a_flat_patch_no_axis_reaches_is_taken_for_the_missed_vessels_cap(arches, caplog):
    """The arch whose root flares at 40-50 degrees into its sinuses (1.5 amplitude): the wall meets that cap's
    rim along 74 % of it only, so vessel_ends does not take it for a cap; it reports it (a flat patch that is
    not a cap, 132 faces, radius 13.9) instead of dropping it. No centre line from the ends found reaches it, so
    the tree fit takes it for the cap of the vessel whose end was missed (a WARNING names it) and fits the arch
    as it is: five ends, the root that cap, no bulge (without it, the ascending aorta was a bulge of 1.57x on the
    path from the descending aorta, exit 0)."""
    V, F, truth, caps = arches["flared"]
    pm = PreparedMesh(V, F)
    with caplog.at_level(logging.INFO, logger="vesselgp"):
        assert len(pm.ends) == 4 and len(pm.flat_patches) == 1
        tree = vesselgp.fit_vessel_tree(pm)
    said = " ".join(r.getMessage() for r in caplog.records)
    assert "is not a cap: its rim is met by the wall" in said and "no centre line reaches the flat patch" in said
    assert np.linalg.norm(pm.flat_patches[0].end.center - caps[0][0]) < CENTER_RADII * caps[0][2]
    found = _matched(tree.ends, caps)
    assert len(tree.ends) == 5 and tree.ends[tree.root] is found[0] and not tree.bulges
    assert tree.checks.largest_uncovered < 0.5


def test_the_command_line_lists_what_is_not_an_end_and_fits_the_missed_cap(arches, tmp_path, capsys, caplog):
    """`vesselgp ends` lists the flat patch it did not take for a cap (its size, place and why) and ends.json
    holds it (`not_caps`); `vesselgp fit` warns that it takes it for a missed vessel's cap and writes the tree
    of five ends rooted there."""
    import json

    from vesselgp.cli import main

    V, F, truth, caps = arches["flared"]
    vesselgp.write_mesh(tmp_path / "arch.ply", V, F)
    assert main(["ends", str(tmp_path / "arch.ply"), "-o", str(tmp_path / "e")]) == 0
    out = capsys.readouterr().out
    assert "not an end: a flat patch of 132 faces, radius 13.9" in out and "met by the wall on 74 %" in out
    d = json.loads((tmp_path / "e" / "ends.json").read_text())
    assert d["n_ends"] == 4 and len(d["not_caps"]) == 1 and d["sacs"] == []
    assert np.linalg.norm(np.array(d["not_caps"][0]["center"]) - caps[0][0]) < CENTER_RADII * caps[0][2]
    with caplog.at_level(logging.WARNING, logger="vesselgp"):
        assert main(["fit", str(tmp_path / "arch.ply"), "-o", str(tmp_path / "f"), "--no-png"]) == 0
    assert any("no centre line reaches the flat patch" in r.getMessage() for r in caplog.records)
    d = json.loads((tmp_path / "f" / "tree.json").read_text())
    assert d["n_ends"] == 5 and d["root"] == 4 and d["bulges"] == []
