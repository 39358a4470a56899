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
