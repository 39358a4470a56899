"""Blind sacs are not vessel ends (issue #34, item 3), on synthetic meshes whose truth is known.

Each surface is the zero set of a smooth union of signed distances (scikit-image's marching cubes,
cleaned by vesselgp.clean_mesh): a tube cut open by the grid's faces, with a side branch or a sac.
The truth is the construction: the side branch's radius, the tube's centre line.
"""
from __future__ import annotations

import logging

import numpy as np
import pytest

import vesselgp
from vesselgp import tolerances as tol

R = 1.5  # the tube's radius
H = 0.2  # voxel


def _smooth_union(a, b, k=0.5):
    t = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b * (1 - t) + a * t - k * t * (1 - t)


def _surface(field, axes):
    from skimage.measure import marching_cubes

    V, F, _, _ = marching_cubes(field, 0.0, spacing=(H, H, H))
    V = V + [a[0] for a in axes]
    return vesselgp.clean_mesh(V.astype(np.float64), F.astype(np.int64)[:, ::-1].copy())[:2]


def _tee(rho, length=9.0, half=14.0):
    """A straight tube of radius R along x, open at x = +-half, with a side branch of radius ``rho`` along y
    ending in a hemisphere at y = length (a capsule)."""
    x = np.arange(-half, half + H / 2, H)
    y = np.arange(-R - 1.0, length + rho + 1.0, H)
    z = np.arange(-max(R, rho) - 1.0, max(R, rho) + 1.0 + H / 2, H)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    side = np.sqrt(X**2 + (Y - np.clip(Y, 0.0, length)) ** 2 + Z**2) - rho
    return _surface(_smooth_union(np.hypot(Y, Z) - R, side), (x, y, z))


@pytest.mark.parametrize("ratio, is_end", [(1.05, True), (1.15, False)])
def test_a_dome_wider_than_every_cut_end_is_a_sac_at_its_edge(ratio, is_end, caplog):
    """A rounded end whose radius is ``ratio`` times the two open ends' (the side branch of a tee): an end
    up to ENDS_SAC_RATIO (1.1) times the widest cut end, a blind sac beyond (logged, not an end). The
    hemisphere test measures the dome's radius 2.5 % above the construction's, well inside the +-5 %."""
    V, F = _tee(ratio * R)
    with caplog.at_level(logging.INFO, logger="vesselgp.mesh.ends"):
        ends = vesselgp.vessel_ends(V, F)
    open_ends = [e for e in ends if e.kind == "open"]
    assert len(open_ends) == 2 and all(abs(e.radius - R) < 0.01 * R for e in open_ends)
    rounded = [e for e in ends if e.kind == "rounded"]
    assert len(rounded) == int(is_end)
    if is_end:
        assert abs(rounded[0].radius - ratio * R) < 0.04 * ratio * R
    else:
        assert any("blind sac" in r.getMessage() for r in caplog.records)
    assert tol.ENDS_SAC_RATIO == pytest.approx(1.1)  # the edge these ratios straddle


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
    return _surface(_smooth_union(tube, ball, 0.6), (x, y, z)), (bend, length, sac)


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
