"""Vessels cut obliquely and capped flat (a segmentation clipped by its field of view; data_gen/clipped.py): the
cap's rim meets the wall at 90 degrees minus the cut's obliquity on one side, and past 46 degrees the cap was not
taken for one (a single artery clipped at 55 degrees and capped by a fan was answered with a rim vertex as its end
and refused). Such a cap is judged across the axis of the tube behind it (vesselgp.mesh._ends_caps._oblique_axes)."""
from __future__ import annotations

import logging

import numpy as np
import pytest
from scipy.spatial import cKDTree

from _data import REAL, needs_real, repo_module, vmtk_lines
import vesselgp
from vesselgp import tolerances as tol

LENGTH = 8.0


def _tube(theta, n_around=48, spacing=0.1, radius=1.0):
    """A straight tube of ``radius`` along z, square at z = 0, its top cut by the plane through (0, 0, LENGTH)
    whose normal leans ``theta`` from the axis towards x; both ends capped by fans (data_gen/clipped.py). The exact
    cut is an ellipse about (0, 0, LENGTH), its outward normal (sin theta, 0, cos theta)."""
    z = np.arange(0.0, LENGTH + 2.0 + radius * np.tan(theta), spacing)
    phi = 2 * np.pi * np.arange(n_around) / n_around
    V = np.stack([np.tile(radius * np.cos(phi), len(z)), np.tile(radius * np.sin(phi), len(z)),
                  np.repeat(z, n_around)], axis=1)
    i, j = np.meshgrid(np.arange(len(z) - 1), np.arange(n_around), indexing="ij")
    a, b = i * n_around + j, i * n_around + (j + 1) % n_around
    c, d = a + n_around, b + n_around
    F = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)])
    normal = np.array([np.sin(theta), 0.0, np.cos(theta)])
    return repo_module("clipped").clipped(V, F, -normal, [0.0, 0.0, LENGTH]), normal


@pytest.mark.parametrize("theta", [0.6, 0.95, 1.1])
def test_a_tube_cut_obliquely_ends_in_a_cap_at_its_ellipse(theta):
    """At 34, 54 and 63 degrees: both ends are caps; the oblique one is centred on the axis where the plane meets
    it (the ellipse's centre), its direction the plane's normal, its rim the whole ellipse; the fit's axis runs
    down the z axis to that centre."""
    (V, F), normal = _tube(theta)
    ends = vesselgp.vessel_ends(V, F)
    assert [e.kind for e in ends] == ["cap", "cap"]
    top = max(ends, key=lambda e: e.center[2])
    assert np.linalg.norm(top.center - [0.0, 0.0, LENGTH]) < 0.01
    assert np.degrees(np.arccos(top.direction @ normal)) < 0.5
    rim = V[top.loop] - top.center
    assert np.abs(rim @ normal).max() < 2e-4 and np.allclose(np.hypot(*rim[:, :2].T), 1.0, atol=0.01)
    gc = vesselgp.fit_generalized_cylinder(V, F)
    P = gc.dense_points
    assert np.abs(P[:, :2]).max() < 0.01  # on the z axis, in radii
    assert min(np.linalg.norm(P[[0, -1]] - [0.0, 0.0, LENGTH], axis=1)) < 0.01


@pytest.mark.parametrize("delta, cap", [(-0.02, True), (0.02, False)])
def test_the_obliquity_limit_at_its_edge(delta, cap, caplog):
    """CAP_MAX_OBLIQUITY at its edge, on tubes whose obliquity is known exactly: a cut 0.02 rad inside it is a
    cap; 0.02 rad past it is a flat patch that is no cap, its obliquity named."""
    theta = tol.CAP_MAX_OBLIQUITY + delta
    (V, F), _ = _tube(theta)
    with caplog.at_level(logging.INFO, logger="vesselgp.mesh.ends"):
        ends = vesselgp.vessel_ends(V, F)
    at_top = [e for e in ends if e.kind == "cap" and np.linalg.norm(e.center - [0, 0, LENGTH]) < 0.05]
    assert bool(at_top) == cap
    if not cap:
        said = [r.getMessage() for r in caplog.records if "degrees off its normal" in r.getMessage()]
        assert said and f"runs {np.degrees(theta):.0f} degrees off" in said[0]


@needs_real("dfemtoolz_artery_segment_lumen_capped.stl")
def test_a_real_artery_clipped_obliquely_and_capped_fits_to_its_cut():
    """The real capped artery segment (dfemtoolz) clipped by a plane leaning 55 degrees from VMTK's line, at 60 %
    of its length, and capped by a fan: the cut is a cap centred within 0.2 radii of where VMTK's line crosses the
    plane (before: a rim vertex taken for a rounded end and the fit refused); the fit reaches it, and VMTK's line
    away from the cut is within 0.1 radii of the axis on average (0.15 at worst)."""
    name = "dfemtoolz_artery_segment_lumen_capped.stl"
    V, F = vesselgp.read_mesh(REAL / name)[:2]
    (P, Rv), = vmtk_lines(name)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
    k = int(np.searchsorted(s, 0.6 * s[-1]))
    t = P[k + 3] - P[k - 3]
    t /= np.linalg.norm(t)
    side = np.cross(t, [0.3, 0.5, 0.8])
    side /= np.linalg.norm(side)
    lean = np.radians(55)
    normal = np.cos(lean) * t + np.sin(lean) * side  # the cut's normal, 55 degrees off the line
    W, G = repo_module("clipped").clipped(V, F, -normal, P[k])
    sd = (P - P[k]) @ normal
    j = int(np.flatnonzero(np.diff(np.sign(sd)))[0])  # VMTK's line crosses the plane between j and j + 1
    cross = P[j] + sd[j] / (sd[j] - sd[j + 1]) * (P[j + 1] - P[j])
    tree = vesselgp.fit_vessel_tree(W, G)
    cut = min(tree.ends, key=lambda e: np.linalg.norm(e.center - cross))
    assert cut.kind == "cap" and np.linalg.norm(cut.center - cross) < 0.2 * Rv[k]
    assert tree.checks.worst_end_gap < 0.05
    away = sd < -2.0 * Rv
    d = cKDTree(np.vstack([p.dense_points for p in tree.paths])).query(P[away])[0] / Rv[away]
    assert d.mean() < 0.1 and d.max() < 0.15


def _cone(theta, phi, n_around=48, spacing=0.1):
    """A cone of half-angle ``phi`` along z, radius 1 at z = LENGTH and wider below, its top cut as :func:`_tube`'s;
    both ends capped by fans."""
    z = np.arange(0.0, LENGTH + 2.0 + 3.0 * np.tan(theta), spacing)
    r = 1.0 + (LENGTH - z) * np.tan(phi)
    z, r = z[r > 0.2], r[r > 0.2]
    phis = 2 * np.pi * np.arange(n_around) / n_around
    V = np.stack([np.outer(r, np.cos(phis)).ravel(), np.outer(r, np.sin(phis)).ravel(), np.repeat(z, n_around)], 1)
    i, j = np.meshgrid(np.arange(len(z) - 1), np.arange(n_around), indexing="ij")
    a, b = i * n_around + j, i * n_around + (j + 1) % n_around
    F = np.concatenate([np.stack([a, b, b + n_around], -1).reshape(-1, 3),
                        np.stack([a, b + n_around, a + n_around], -1).reshape(-1, 3)])
    normal = np.array([np.sin(theta), 0.0, np.cos(theta)])
    return repo_module("clipped").clipped(V, F, -normal, [0.0, 0.0, LENGTH])


def test_the_tube_behind_an_oblique_cap_must_be_one_tube_at_the_spreads_edge(caplog, monkeypatch):
    """ENDS_TIP_AXIS_SPREAD at its edge for the wall behind an oblique cap: a cone of half-angle 15 degrees cut at
    54 degrees (its normals' spread read from the log) ends in a cap with the limit 1 % above that spread, and in
    no cap 1 % below it (the rim test about the cap's normal fails at that obliquity). The axis found is the cone's
    within 2.5 degrees (the sectors weighted alike; 4 degrees off without)."""
    theta, phi = 0.95, np.radians(15.0)
    V, F = _cone(theta, phi)
    with caplog.at_level(logging.DEBUG, logger="vesselgp.mesh._ends_caps"):
        vesselgp.vessel_ends(V, F)
    said = [r.getMessage() for r in caplog.records if "normals' spread" in r.getMessage()]
    top = [m for m in said if "degrees off its normal" in m and float(m.split("axis ")[1].split(" degrees")[0]) > 10]
    assert len(top) == 1
    angle = float(top[0].split("axis ")[1].split(" degrees")[0])
    assert abs(angle - np.degrees(theta)) < 2.5
    spread = float(top[0].rsplit(" ", 1)[1])
    for factor, cap in ((1.01, True), (0.99, False)):
        monkeypatch.setattr(tol, "ENDS_TIP_AXIS_SPREAD", spread * factor)
        ends = vesselgp.vessel_ends(V, F)
        assert any(e.kind == "cap" and e.center[2] > LENGTH - 1.0 for e in ends) == cap
