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
from vesselgp import tolerances as tol
from vesselgp.prepared import PreparedMesh
from vesselgp.synthetic_anatomy import capped_arch

from _data import decimated

#: every true cap found within this many of its radii of its true centre, its radius within this fraction
CENTER_RADII, RADIUS_REL = 0.1, 0.05


@pytest.fixture(scope="module")
def arches():
    """The arch with a sinus of 0.45 (1.3 times its annulus, a normal root), at the generator's resolution and
    decimated to 30 % (its root cap then about 60 faces, a rim edge of them folded); with a sinus of 0.7 (1.5
    times), its wall leaving the cap at up to 38 degrees; and with a sinus of 1.5, whose root flares too fast
    behind its valve plane for its cap's rim to be the wall's all round."""
    V, F, truth, caps = capped_arch(sinus=0.45)
    Vd, Fd = decimated(V, F, 0.3)
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

def test_a_flat_patch_no_axis_reaches_is_taken_for_the_missed_vessels_cap(arches, caplog, monkeypatch):
    """The arch whose root flares at 40-50 degrees into its sinuses (1.5 amplitude): the wall meets that cap's
    rim along 74 % of it only, so vessel_ends does not take it for a cap; it reports it (a flat patch that is
    not a cap, 132 faces, radius 13.9) instead of dropping it. No centre line from the ends found reaches it, so
    the tree fit takes it for the cap of the vessel whose end was missed (a WARNING names it) and fits the arch
    as it is: five ends, the root that cap, no bulge (without it, the ascending aorta was a bulge of 1.57x on the
    path from the descending aorta, exit 0). The centre lines are drawn twice (the ends found, then with that
    cap) on one tessellation (issue #47)."""
    import vesselgp.centerlines as cl

    V, F, truth, caps = arches["flared"]
    pm = PreparedMesh(V, F)
    tessellated = []
    inside_voronoi = cl._inside_voronoi
    monkeypatch.setattr(cl, "_inside_voronoi", lambda *a: tessellated.append(1) or inside_voronoi(*a))
    drawn = []
    draw = cl._drawn  # the lines drawn on the diagram (asked again for the same ends, they are not drawn again)
    monkeypatch.setattr(cl, "_drawn", lambda *a, **k: drawn.append(1) or draw(*a, **k))
    with caplog.at_level(logging.INFO, logger="vesselgp"):
        assert len(pm.ends) == 4 and len(pm.flat_patches) == 1
        tree = vesselgp.fit_vessel_tree(pm)
    assert len(drawn) == 2 and len(tessellated) == 1
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


@pytest.fixture(scope="module")
def vein():
    from vesselgp.synthetic_anatomy import vein_tree

    return vein_tree(voxel=0.35)


def test_a_closed_vein_tree_has_every_small_blind_end(vein):
    """A closed vein tree of 32 rounded blind ends 3 voxels across over five generations (the portal vein
    that lost all but 6 of its ~40 ends): every tip found within a fifth of its radius of the true centre
    of its dome, and the root's cap; the tree fitted from the cap (the widest end) to each tip, every path
    reaching its tip, the axes within 5 % of their radius of the true centre lines away from junctions and
    tips (the generator's interior), the wall covered."""
    V, F, truth, cap = vein
    tree = vesselgp.fit_vessel_tree(V, F)
    t = truth.truth
    assert len(tree.ends) == 33 and len(t.tips) == 32
    for e in t.tips:
        f = min(tree.ends, key=lambda x: np.linalg.norm(x.center - e.center))
        assert np.linalg.norm(f.center - e.center) < 0.2 * e.radius + 0.5 * truth.voxel, e.center
    root = tree.ends[tree.root]
    assert root.kind == "cap" and np.linalg.norm(root.center - cap[0]) < 0.05 * cap[2]
    assert len(tree.paths) == 32 and tree.checks.worst_end_gap < 0.05 and tree.checks.largest_uncovered < 0.5
    for p in tree.paths:
        X = p.dense_points
        keep = t.interior_mask(X) & (np.linalg.norm(X - cap[0], axis=1) > 2 * cap[2])
        d, r, _, _ = t.nearest(X[keep])
        assert np.max(d / r, initial=0.0) < 0.05, (p.ends, np.max(d / r))


def test_a_vein_tree_with_tips_two_voxels_across_is_refused_where_a_tip_is_missed():
    """The same tree meshed with its tips 2 voxels across: some of the 32 tips are not found (two: their rings,
    about six vertices round, point off the tube's axis); the fit is refused, not returned without those
    vessels, and names a point on the wall of a vessel whose tip was missed (or of its parent)."""
    from vesselgp.errors import NotTubularError
    from vesselgp.synthetic_anatomy import vein_tree

    V, F, truth, cap = vein_tree(voxel=0.5)
    pm = PreparedMesh(V, F)
    missed = [e for e in truth.truth.tips if min(np.linalg.norm(f.center - e.center) for f in pm.ends) > e.radius]
    assert 1 <= len(missed) <= 3
    with pytest.raises(NotTubularError, match=r"without an axis at \(") as ei:
        vesselgp.fit_vessel_tree(pm)
    point = np.array([float(x) for x in str(ei.value).split("without an axis at (")[1].split(")")[0].split(",")])
    _, _, branch, _ = truth.truth.nearest(point[None])
    assert any(branch[0] in (m.branch, truth.truth.branches[m.branch].parent) for m in missed)


def test_a_vein_flattened_two_and_a_half_to_one_is_a_tube():
    """A capped vein 150 mm long, round (mean radius 13 mm) at its ends and flattened to 2.5:1 in its middle (a
    vena cava's 37 x 15 mm; its ellipse's axes 1 - 0.6 exp(-(s - 0.5)^2 / 2 0.18^2)), 48 vertices round: it is
    fitted as a tube, its axis within 2 % of the radius of the true centre line (0.6 % measured), the wall
    covered but for the ends of the flat section's long axis (its fitted radius, 11.3 there, drops them as
    outliers: two pieces of 0.24-0.30 radii of wall, 3.4 % of it, under the warning's 0.5)."""
    import igl

    from vesselgp.synthetic import synthetic_vessel

    u = np.linspace(0.0, 1.0, 50)
    P = np.c_[150 * u, 12 * np.sin(np.pi * u), 6 * np.sin(2 * np.pi * u)]
    v = synthetic_vessel(P, radius=13.0, ellipticity=lambda s: 1 - 0.6 * np.exp(-0.5 * ((s - 0.5) / 0.18) ** 2),
                         ends="capped", n_around=48, units="mm", seed=1)
    gc = vesselgp.fit_generalized_cylinder(v.V, v.F)
    T = v.truth.centers
    d = np.sqrt(igl.point_mesh_squared_distance(gc.dense_points, T, np.c_[np.arange(len(T) - 1),
                                                                          np.arange(1, len(T))])[0])
    assert np.max(d) / 13.0 < 0.02
    assert gc.checks.covered_fraction > 0.95 and gc.checks.largest_uncovered < tol.CHECK_WARN_UNCOVERED and gc.checks.worst_end_gap < 1e-9


def test_a_voxel_thoracic_aorta_smoothed_as_the_message_says_fits(tmp_path, capsys):
    """A thoracic aorta (radius 12.5 to 11 mm, its arch a half turn of 28 mm radius) as a raw voxel staircase
    at 1 mm voxels: `vesselgp fit` refuses it and names `vesselgp clean --smooth N`; smoothed so (N = 20),
    it fits, every point of its axis within 3 % of the radius of the true centre line away from its ends."""
    from vesselgp.cli import main
    from vesselgp.mesh import clean_mesh
    from vesselgp.synthetic_anatomy import bezier_between as bz
    from vesselgp.synthetic_tree import tree_surface

    A, B = np.array([0.0, 0, 60]), np.array([-56.0, 0, 60])
    control = [bz([0, 0, 0], [0, 0, 1], A, [0, 0, 1], 20, 20), bz(A, [0, 0, 1], B, [0, 0, -1], 37, 37),
               bz(B, [0, 0, -1], B + [0, 10, -40], [0, 0.2, -1], 15, 15)]
    t = tree_surface([-1, 0, 1], control, [[12.5, 12.2], [12.2, 11.5], [11.5, 11.0]], voxel=1.0, blend=1.0,
                     staircase=True)
    vesselgp.write_mesh(tmp_path / "aorta.ply", t.V, t.F)
    assert main(["fit", str(tmp_path / "aorta.ply"), "-o", str(tmp_path / "f"), "--no-png"]) == 2
    assert "vesselgp clean --smooth N" in capsys.readouterr().err
    V, F, _ = clean_mesh(t.V, t.F, smooth=20)
    gc = vesselgp.fit_vessel_tree(V, F).paths[0]
    X = gc.dense_points
    keep = np.all([np.linalg.norm(X - e.center, axis=1) > 2 * e.radius for e in t.truth.ends], axis=0)
    d, r, _, _ = t.truth.nearest(X[keep])
    assert keep.mean() > 0.5 and np.max(d / r) < 0.03, np.max(d / r)
