"""Blind sacs are not vessel ends (issue #34, item 3), on synthetic meshes whose truth is known.

Each surface is the zero set of a smooth union of signed distances (scikit-image's marching cubes,
cleaned by vesselgp.clean_mesh): a tube cut open by the grid's faces, with a side branch or a sac.
The truth is the construction: the side branch's radius, the tube's centre line.
"""
from __future__ import annotations

import logging
from types import SimpleNamespace as NS

import numpy as np
import pytest

import vesselgp
from vesselgp import tolerances as tol

from _data import level_surface, smooth_union

R = 1.5  # the tube's radius
H = 0.2  # voxel


def _tee(rho, length=9.0, half=14.0):
    """A straight tube of radius R along x, open at x = +-half, with a side branch of radius ``rho`` along y
    ending in a hemisphere at y = length (a capsule)."""
    x = np.arange(-half, half + H / 2, H)
    y = np.arange(-R - 1.0, length + rho + 1.0, H)
    z = np.arange(-max(R, rho) - 1.0, max(R, rho) + 1.0 + H / 2, H)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    side = np.sqrt(X**2 + (Y - np.clip(Y, 0.0, length)) ** 2 + Z**2) - rho
    return level_surface(smooth_union(np.hypot(Y, Z) - R, side, 0.5), (x[0], y[0], z[0]), H)


@pytest.mark.parametrize("ratio, is_end", [(1.02, True), (1.08, False)])
def test_a_dome_wider_than_every_cut_end_is_a_sac_at_its_edge(ratio, is_end, caplog):
    """A rounded end whose radius is ``ratio`` times the two open ends' (a short side stub of a tee, 3 long
    from the tube's axis: its own tube is 0.87 of its radii, measured 1.2-1.3, below ENDS_SAC_TUBE_RADII): an
    end up to ENDS_SAC_RATIO (1.1) times the widest cut end, a blind sac beyond (logged, not an end). The
    hemisphere test measures the stub's dome 4-5 % wider than built: 1.059 and 1.131 times the cut ends here,
    within 4 % of the edge on either side."""
    V, F = _tee(ratio * R, length=3.0)
    with caplog.at_level(logging.INFO, logger="vesselgp.mesh.ends"):
        ends = vesselgp.vessel_ends(V, F)
    open_ends = [e for e in ends if e.kind == "open"]
    assert len(open_ends) == 2 and all(abs(e.radius - R) < 0.01 * R for e in open_ends)
    rounded = [e for e in ends if e.kind == "rounded"]
    assert len(rounded) == int(is_end)
    if is_end:
        measured = rounded[0].radius / R
    else:
        said = [r.getMessage() for r in caplog.records if "blind sac" in r.getMessage()]
        assert len(said) == 1
        measured = float(said[0].split("radius ")[1].split()[0]) / R
    assert abs(measured / tol.ENDS_SAC_RATIO - 1.0) < 0.04 and (measured <= tol.ENDS_SAC_RATIO) == is_end


def _capsule_on_neck(rho, ell, neck=0.45, gap=1.0, half=12.0):
    """A tube of radius R along x (open at x = +-half) and, on a neck of radius ``neck`` rho rising along y from
    it, a closed capsule of radius ``rho``: two hemispheres about y0 = R + gap + rho and y1 = y0 + ``ell``."""
    y0 = R + gap + rho
    y1 = y0 + ell
    x = np.arange(-half, half + H / 2, H)
    y = np.arange(-R - 1.0, y1 + rho + 1.0, H)
    z = np.arange(-rho - 1.0, rho + 1.0 + H / 2, H)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    capsule = np.sqrt(X**2 + (Y - np.clip(Y, y0, y1)) ** 2 + Z**2) - rho
    stalk = np.maximum(np.hypot(X, Z) - neck * rho, np.maximum(Y - y0, -Y))  # from the tube axis up to the sphere
    body = smooth_union(np.hypot(Y, Z) - R, stalk, 0.3)
    return level_surface(smooth_union(body, capsule, 0.3), (x[0], y[0], z[0]), H)


@pytest.mark.parametrize("factor", [0.95, 1.05])
def test_a_wide_dome_on_a_tube_of_its_own_is_an_end_at_its_edge(factor, caplog):
    """Issue #44: a dome wider than every cut end closes a vessel, not a sac, when it goes on as a tube of its
    own for ENDS_SAC_TUBE_RADII (2) of its radii past its equator: its rings past the equator round and no
    narrower than 1 - ENDS_SAC_TUBE_NARROWING (0.75) of its radius. A capsule of radius 1.2 R on a narrow neck:
    its tube runs ``ell`` past the upper dome's equator, then its lower hemisphere narrows to 0.75 of its
    radius ``rho arccos(0.75)`` further on (the truth: ell + 0.723 rho). At 0.95 and 1.05 times the limit
    it is a sac (the mesh has its two cut ends) and a vessel end (a third, rounded, of the capsule's radius)."""
    rho = 1.2 * R
    ell = factor * tol.ENDS_SAC_TUBE_RADII * rho - rho * np.arccos(1.0 - tol.ENDS_SAC_TUBE_NARROWING)
    V, F = _capsule_on_neck(rho, ell)
    with caplog.at_level(logging.INFO, logger="vesselgp.mesh.ends"):
        ends = vesselgp.vessel_ends(V, F)
    rounded = [e for e in ends if e.kind == "rounded"]
    assert len(ends) == 2 + (factor > 1) and len(rounded) == int(factor > 1)
    said = " ".join(r.getMessage() for r in caplog.records)
    if factor > 1:
        assert abs(rounded[0].radius - rho) < 0.05 * rho and "closes a tube of its own" in said
    else:
        assert "blind sac" in said


def test_a_vessel_ending_in_a_dome_wider_than_the_cut_ends_is_fitted_to_its_end():
    """Issue #44: a Y whose wider daughter (radius 2.8 at its rounded tip) is wider than the trunk's open root
    (2.4): it closes a long tube of its own, so it is an end, not a sac (it was taken for one, and the fit of
    the two ends left, through the Y, came within 0.14 radii of the wall). The tree reaches all three ends."""
    from vesselgp.synthetic_anatomy import bezier_between
    from vesselgp.synthetic_tree import tree_surface

    J = np.array([0.0, 0.0, 30.0])
    control = [bezier_between([0, 0, 0], [0, 0, 1], J, [0, 0, 1], 10, 10),
               bezier_between(J, [0.7, 0, 1], J + [16, 0, 22], [0.3, 0, 1], 8, 8),
               bezier_between(J, [-0.7, 0, 1], J + [-16, 2, 20], [-0.4, 0, 1], 8, 8)]
    t = tree_surface([-1, 0, 0], control, [[2.4, 2.4], [2.6, 2.8], [1.6, 1.5]], voxel=0.45, blend=0.5)
    tree = vesselgp.fit_vessel_tree(t.V, t.F)
    assert len(tree.ends) == 3 and not tree.bulges
    for e in t.truth.ends:  # each true end found, of its kind and radius
        f = min(tree.ends, key=lambda x: np.linalg.norm(x.center - e.center))
        assert f.kind == e.kind and np.linalg.norm(f.center - e.center) < 0.2 * e.radius
        assert abs(f.radius - e.radius) < 0.05 * e.radius
    assert tree.checks.worst_end_gap < 0.05 and tree.checks.covered_fraction > 0.999


def _side_sac(sac=2.5, bend=3.0, length=30.0):
    """A tube of radius R bent in its plane (centre line y = bend sin(pi x / length), z = 0), open at x = 0 and
    x = length, with a spherical sac of radius ``sac`` on its outer side at mid-length, reaching 0.5 into it."""
    x = np.arange(0.0, length + H / 2, H)
    y = np.arange(-6.0, bend + R + 2 * sac + 1.0, H)
    z = np.arange(-6.0, 6.0 + H / 2, H)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    tube = np.hypot(Y - bend * np.sin(np.pi * X / length), Z) - R
    c = np.array([length / 2, bend + R + 0.6 * sac, 0.0])
    ball = np.sqrt((X - c[0]) ** 2 + (Y - c[1]) ** 2 + (Z - c[2]) ** 2) - sac
    return level_surface(smooth_union(tube, ball, 0.6), (x[0], y[0], z[0]), H), (bend, length, sac)


def test_a_side_wall_sac_is_passed_by_not_taken_for_an_end():
    """A saccular aneurysm (radius 2.5, 1.67 times the tube's) on the side of a bent tube: its dome passes the
    hemisphere test, but it is wider than both cut ends, so the mesh has two ends and the fit's axis follows
    the tube's true centre line past it (measured 0.001 R away from the sac, 0.02 R beside it). The sac is
    reported as a bulge of the path at its nearest point, the centre line's point (15, bend, 0): its dome's
    radius 2.36 (the sphere's 2.5 less the tube it merges into: within 10 %) over the tube's 1.52."""
    (V, F), (bend, length, sac) = _side_sac()
    ends = vesselgp.vessel_ends(V, F)
    assert [e.kind for e in ends] == ["open", "open"]
    tree = vesselgp.fit_vessel_tree(V, F)
    P = tree.paths[0].dense_points
    off = np.hypot(P[:, 1] - bend * np.sin(np.pi * P[:, 0] / length), P[:, 2]) / R
    beside = np.abs(P[:, 0] - length / 2) < sac + 2 * R
    assert off[~beside].max() < 0.01 and off[beside].max() < 0.05
    assert len(tree.bulges) == 1
    b = tree.bulges[0]
    assert np.linalg.norm(b.peak - [length / 2, bend, 0.0]) < 0.1 * R
    assert abs(b.neighbour_radius - R) < 0.03 * R and abs(b.peak_radius - sac) < 0.1 * sac
    assert b.s_range[0] < b.s_peak < b.s_range[1]


def _segment_distance(X, a, b):
    ab = b - a
    t = np.clip(((X - a) @ ab) / (ab @ ab), 0.0, 1.0)
    return np.linalg.norm(X - (a + t[..., None] * ab), axis=-1)


def _leaning_sac(rs=2.0, neck=10.0, rise=4.5, lean=8.0, flat=0.7, length=30.0):
    """A straight tube of radius R along x (open at x = 0 and ``length``) and a sac of radius ``rs``
    (``flat`` times that across, in z) swept from the tube's axis at x = ``neck`` up by ``rise`` and then
    leaning along the tube by ``lean`` to its dome: its neck is at x = neck, its dome above x = neck + lean."""
    x = np.arange(0.0, length + H / 2, H)
    y = np.arange(-R - 1.0, rise + 2 * rs + 2.5, H)
    z = np.arange(-rs - 1.5, rs + 1.5 + H / 2, H)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    P = np.stack([X, Y, Z / flat], axis=-1)
    a, b, c = np.array([neck, 0.0, 0.0]), np.array([neck, rise, 0.0]), np.array([neck + lean, rise + 1.5, 0.0])
    sac = np.minimum(_segment_distance(P, a, b), _segment_distance(P, b, c)) - rs
    return level_surface(smooth_union(np.hypot(Y, Z) - R, sac, 0.6), (x[0], y[0], z[0]), H)


def test_a_leaning_sac_is_placed_at_its_neck_and_its_wall_is_the_sacs():
    """Issue #44: a sac rising from a tube at x = 10 and leaning along it to its dome above x = 18 (as the gmsh
    intracranial aneurysm's lies along its daughter): it is found as a sac (wider than the cut ends, no tube of
    its own); against the tube's true axis its wall beyond the tube (sac_wall, from the dome's pole) is every
    vertex farther than 1 + CHECK_COVER_TOLERANCE radii from the axis, and its neck lies within 0.3 R of
    x = 10, where the sac's bulge is reported (the axis point nearest to the dome's centre, where it was
    placed before, is 8 away)."""
    from vesselgp.bulges import sac_wall, tree_bulges
    from vesselgp.prepared import PreparedMesh

    V, F = _leaning_sac()
    pm = PreparedMesh(V, F)
    assert [e.kind for e in pm.ends] == ["open", "open"] and len(pm.sacs) == 1
    c, out, rs = pm.sacs[0]
    x = np.linspace(0.0, 30.0, 601)
    axis = NS(dense_points=np.c_[x, np.zeros((len(x), 2))], dense_s=x / 30.0, length=30.0,
              radius_at=lambda s: np.full(len(np.atleast_1d(s)), R))
    pole = int(np.argmin(np.linalg.norm(V - (c + rs * out), axis=1)))
    wall, neck = sac_wall(V, pm.topology.adjacency, pole, [axis])
    beyond = np.flatnonzero(np.hypot(V[:, 1], V[:, 2]) > (1 + tol.CHECK_COVER_TOLERANCE) * R)
    assert np.array_equal(np.sort(wall), beyond)
    assert abs(neck[0] - 10.0) < 0.3 * R
    (b,) = tree_bulges([axis], pm.sacs, (V, pm.topology.adjacency), wall=False)
    assert abs(b.peak[0] - 10.0) < 0.3 * R and np.array_equal(np.sort(b.wall), beyond)
    assert abs(c[0] - 10.0) > 5 * R  # the dome lies far along the tube from its neck


def _closed_side_sac(sac=2.5, bend=3.0, length=30.0, margin=2.0):
    """:func:`_side_sac` closed: its tube cut flat at x = margin and x = length - margin (two caps), as a
    segmentation clipped by its field of view and meshed by marching cubes is."""
    x = np.arange(-1.0, length + 1.0 + H / 2, H)
    y = np.arange(-6.0, bend + R + 2 * sac + 1.0, H)
    z = np.arange(-6.0, 6.0 + H / 2, H)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    tube = np.maximum(np.hypot(Y - bend * np.sin(np.pi * X / length), Z) - R,
                      np.abs(X - length / 2) - (length / 2 - margin))
    c = np.array([length / 2, bend + R + 0.6 * sac, 0.0])
    ball = np.sqrt((X - c[0]) ** 2 + (Y - c[1]) ** 2 + (Z - c[2]) ** 2) - sac
    return level_surface(smooth_union(tube, ball, 0.6), (x[0], y[0], z[0]), H), (bend, length, sac)


def test_a_sac_on_a_closed_tube_is_not_found_again_as_a_missed_end(caplog):
    """The side-wall sac on the tube closed by two flat caps: the end tests find the two caps and leave the sac
    out; the search for missed ends (vesselgp.missed_ends), which finds the lumen running on past the centre line
    into it, took its dome for a vessel's end (the widest: the tree's root, the sac reported as a 1.15x bulge of
    its own path). Now the dome of a sac the end tests found is no end: two ends, one path along the tube's true
    centre line, and the sac reported at its neck as on the open tube (2.36 over 1.52, within 10 %)."""
    (V, F), (bend, length, sac) = _closed_side_sac()
    with caplog.at_level(logging.INFO, logger="vesselgp.missed_ends"):
        tree = vesselgp.fit_vessel_tree(V, F)
    assert [e.kind for e in tree.ends] == ["cap", "cap"]
    assert any("the blind sac the end tests found" in r.getMessage() for r in caplog.records)
    P = tree.paths[0].dense_points
    off = np.hypot(P[:, 1] - bend * np.sin(np.pi * P[:, 0] / length), P[:, 2]) / R
    beside = np.abs(P[:, 0] - length / 2) < sac + 2 * R
    assert off[~beside].max() < 0.02
    assert len(tree.bulges) == 1
    b = tree.bulges[0]
    assert np.linalg.norm(b.peak - [length / 2, bend, 0.0]) < 0.1 * R
    assert abs(b.ratio - 2.36 / 1.52) < 0.1 * 2.36 / 1.52


@pytest.mark.parametrize("ratio, tube, sac", [(1.01, 1.9, True), (0.99, 1.9, False), (1.01, 2.1, False)])
def test_a_missed_dome_is_a_sac_by_the_end_tests_rule_at_its_edges(ratio, tube, sac):
    """The end tests' rule, applied to a dome the lumen leads to that they did not find: wider than
    ENDS_SAC_RATIO times every open or capped end (here 1 % above or below it) on a tube shorter than
    ENDS_SAC_TUBE_RADII (1.9 or 2.1 of its radii) is a sac."""
    from vesselgp.missed_ends import _a_known_sac

    cut = NS(kind="cap", radius=2.0)
    pm = NS(sacs=(), ends=(cut, NS(kind="cap", radius=1.5), NS(kind="rounded", radius=9.0)))
    rec = {"center": np.zeros(3), "radius": ratio * tol.ENDS_SAC_RATIO * cut.radius}
    assert bool(_a_known_sac(pm, rec, tube * tol.ENDS_SAC_TUBE_RADII / 2.0)) == sac


def _capsule_with_sac(sac=2.5, length=30.0, margin=2.0):
    """A straight tube of radius R along x closed by hemispheres at x = margin and length - margin (a capsule: a
    closed mesh with no cut end) with a spherical sac of radius ``sac`` (or none, 0) on its side at mid-length."""
    x = np.arange(-1.0, length + 1.0 + H / 2, H)
    y = np.arange(-R - 1.0, R + 2 * sac + 1.5, H)
    z = np.arange(-max(R, sac) - 1.0, max(R, sac) + 1.0 + H / 2, H)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    tube = np.sqrt((X - np.clip(X, margin, length - margin)) ** 2 + Y**2 + Z**2) - R
    if not sac:
        return level_surface(tube, (x[0], y[0], z[0]), H), None
    c = np.array([length / 2, R + 0.6 * sac, 0.0])
    ball = np.sqrt((X - c[0]) ** 2 + (Y - c[1]) ** 2 + (Z - c[2]) ** 2) - sac
    return level_surface(smooth_union(tube, ball, 0.6), (x[0], y[0], z[0]), H), c


def _root_warnings(caplog):
    return [r.getMessage() for r in caplog.records if "the tree's root, is a dome" in r.getMessage()]


def test_a_sac_taken_for_the_root_of_a_closed_mesh_is_named(caplog):
    """On a closed mesh (no cut end) the end tests cannot tell a sac's dome from a vessel's rounded end: the sac
    on the capsule's side, wider than its two rounded ends, is the widest end and the tree's root. The fit names it
    in a WARNING (its centre within the sac's radius of the sphere's, its own tube 0.99 of its radii, under
    ENDS_SAC_TUBE_RADII) with the ends to fit without it. Fitted so (the ends given: the dome the lumen runs on to
    past them is a sac), the axis follows the tube within 0.02 R away from the sac and the sac is its bulge, its
    peak on the path 0.12 R from the tube's axis point under the sac (measured), its radius the sphere's within
    10 %; before, that fit was refused with the sac's wall left without an axis."""
    (V, F), c = _capsule_with_sac()
    with caplog.at_level(logging.WARNING, logger="vesselgp.tree"):
        tree = vesselgp.fit_vessel_tree(V, F)
    said = _root_warnings(caplog)
    assert len(said) == 1
    assert np.linalg.norm(tree.ends[tree.root].center - c) < 2.5
    others = [int(k) for k in said[0].split("with the ends ")[1].split(" (ends=)")[0].split()]
    assert sorted(others + [tree.root]) == list(range(len(tree.ends)))
    again = vesselgp.fit_vessel_tree(V, F, ends=[tree.ends[k] for k in others])
    P = again.paths[0].dense_points
    beside = np.abs(P[:, 0] - 15.0) < 2.5 + 2 * R
    assert np.hypot(P[~beside, 1], P[~beside, 2]).max() < 0.02 * R
    assert len(again.bulges) == 1 and np.linalg.norm(again.bulges[0].peak - [15.0, 0.0, 0.0]) < 0.15 * R
    assert abs(again.bulges[0].peak_radius - 2.5) < 0.1 * 2.5


def test_a_closed_vessel_without_a_sac_is_not_named(caplog):
    """The same capsule without its sac: its widest end goes on as a tube for more than ENDS_SAC_TUBE_RADII; no
    warning."""
    (V, F), _ = _capsule_with_sac(sac=0)
    with caplog.at_level(logging.WARNING, logger="vesselgp.tree"):
        vesselgp.fit_vessel_tree(V, F)
    assert not _root_warnings(caplog)


@pytest.mark.parametrize("factor, named", [(1.01, True), (0.99, False)])
def test_the_root_sac_warning_at_the_tube_limit(factor, named, caplog, monkeypatch):
    """ENDS_SAC_TUBE_RADII at its edge for the root's warning: set 1 % above the sac's own tube (read from the
    warning) it is named, 1 % below it is not."""
    (V, F), _ = _capsule_with_sac()
    with caplog.at_level(logging.WARNING, logger="vesselgp.tree"):
        vesselgp.fit_vessel_tree(V, F)
    tube = float(_root_warnings(caplog)[0].split("for ")[1].split(" radii")[0])
    caplog.clear()
    monkeypatch.setattr(tol, "ENDS_SAC_TUBE_RADII", tube * factor)
    with caplog.at_level(logging.WARNING, logger="vesselgp.tree"):
        try:
            vesselgp.fit_vessel_tree(V, F)
        except vesselgp.VesselError:
            pass  # (the limit moved far from its value may refuse the fit elsewhere; only the warning is judged)
    assert bool(_root_warnings(caplog)) == named


@pytest.mark.parametrize("factor, sac", [(1.01, True), (0.99, False)])
def test_a_dome_past_the_given_ends_is_a_sac_at_the_tube_limit(factor, sac, caplog, monkeypatch):
    """With the ends given (the capsule's two), the dome the lumen runs on to is a sac only on a tube shorter than
    ENDS_SAC_TUBE_RADII (set 1 % above or below its tube, read from the root's warning): a sac, reported as the
    bulge and the fit returned; else a vessel the caller left out, and its wall left without an axis is refused
    as before."""
    (V, F), _ = _capsule_with_sac()
    with caplog.at_level(logging.WARNING, logger="vesselgp.tree"):
        tree = vesselgp.fit_vessel_tree(V, F)
    said = _root_warnings(caplog)[0]
    tube = float(said.split("for ")[1].split(" radii")[0])
    given = [tree.ends[int(k)] for k in said.split("with the ends ")[1].split(" (ends=)")[0].split()]
    monkeypatch.setattr(tol, "ENDS_SAC_TUBE_RADII", tube * factor)
    if sac:
        assert len(vesselgp.fit_vessel_tree(V, F, ends=given).bulges) == 1
    else:
        with pytest.raises(vesselgp.NotTubularError, match="without an axis"):
            vesselgp.fit_vessel_tree(V, F, ends=given)


def test_the_command_line_names_a_sac_root_and_fits_one_path_past_it(tmp_path, caplog):
    """`vesselgp fit` on the capsule with its sac: the tree's root is the sac's dome, named in a warning; `vesselgp
    fit --ends 0 1`, as the warning says, fits the one path between the capsule's ends with the sac as its bulge in
    axis.json (its peak radius the sphere's within 10 %, its place on the path under the sac within 0.15 R), the
    wall all described (before: refused, the sac's wall without an axis)."""
    import json

    from vesselgp.cli import main

    (V, F), c = _capsule_with_sac()
    vesselgp.write_mesh(tmp_path / "capsule.ply", V, F)
    with caplog.at_level(logging.WARNING, logger="vesselgp"):
        assert main(["fit", str(tmp_path / "capsule.ply"), "-o", str(tmp_path / "tree")]) in (0, None)
    said = _root_warnings(caplog)
    assert len(said) == 1
    d = json.loads((tmp_path / "tree" / "tree.json").read_text())
    assert np.linalg.norm(np.array(d["ends"][d["root"]]["center"]) - c) < 2.5
    ends = [int(k) for k in said[0].split("with the ends ")[1].split(" (ends=)")[0].split()]
    assert main(["fit", str(tmp_path / "capsule.ply"), "-o", str(tmp_path / "one"), "--ends",
                 *map(str, ends)]) in (0, None)
    a = json.loads((tmp_path / "one" / "axis.json").read_text())
    assert len(a["bulges"]) == 1
    b = a["bulges"][0]
    assert abs(b["peak_radius"] - 2.5) < 0.25 and np.linalg.norm(np.array(b["peak"]) - [15.0, 0.0, 0.0]) < 0.15 * R
    assert a["checks"]["covered_fraction"] > 0.99
