"""Elliptic sections (``vesselgp.sections``, issue #48): a wall whose sections are ellipses carries their second
harmonic in Eq. 2's circle fit, and an elliptic wall's fit is freed of Eq. 2's pull.

Truth: exact ellipses (their amplitude ``(a^2 - b^2) / (a^2 + b^2)``, their centres), tubes swept with ellipses
along analytic curves and along the real X-ray coronary's line (``synthetic_vessel``'s swept spline), twists
imposed on their rings. The figures are measured; the bounds 1.5x.
"""
from __future__ import annotations


import numpy as np
import pytest

from _data import needs_real, repo_module
from _reference import SWEPT_TWISTS, free_stage_at_edge, imposed_twist_errors, polyline_distance, swept_axis_errors

import vesselgp
from vesselgp import tolerances as tol
from vesselgp.axis import circle_fit_correction, circle_fit_sums
from vesselgp.sections import conic_residual, section_shape
from vesselgp.synthetic import deform_synthetic, named_curve, synthetic_vessel

FACTOR = 1.5
rs = repo_module("real_shapes")


def _tube(ratio, n_around=32, offset=(0.0, 0.0), z=np.arange(0.0, 10.01, 0.1), ripple=0.0):
    """A straight tube's offsets from an axis along z, its sections ellipses of axes 1 and ``ratio`` centred at
    ``offset`` (each radius times ``1 + ripple sin(3 theta) cos(7 theta)`` where given): s, local, weights."""
    t = np.linspace(0, 2 * np.pi, n_around + 1)[:-1]
    T, Z = np.meshgrid(t, z)
    T, Z = T.ravel(), Z.ravel()
    g = 1.0 + ripple * np.sin(3 * T) * np.cos(7 * T + Z)
    local = np.c_[0 * Z, offset[0] + g * np.cos(T), offset[1] + g * ratio * np.sin(T)]
    return Z / z[-1], local, np.ones(len(Z))


def _reference_explained(s, local, w, K):
    """The rms residual about each segment's conic over that about its circle, both with a free centre, by
    ``numpy.linalg.lstsq`` per segment in units of its rms offset (the definition, written independently)."""
    j = np.minimum((np.clip(s, 0, 1) * (K - 1)).astype(int), K - 2)
    num = den = 0.0
    for k in range(K - 1):
        m = j == k
        x, y = local[m, 1], local[m, 2]
        sc = np.sqrt(np.mean(x * x + y * y))
        x, y = x / sc, y / sc
        q = x * x + y * y
        for cols, acc in (((np.ones_like(x), x, y, x * x - y * y, 2 * x * y), "num"),
                          ((np.ones_like(x), x, y), "den")):
            A = np.stack(cols, axis=1)
            r = q - A @ np.linalg.lstsq(A, q, rcond=None)[0]
            if acc == "num":
                num += float(r @ r)
            else:
                den += float(r @ r)
    return np.sqrt(num / den)


@pytest.mark.parametrize("ratio", [1.0, 0.9, 0.5, 0.4])
def test_the_amplitude_of_exact_ellipses(ratio):
    """(a^2 - b^2) / (a^2 + b^2) of ellipses of axes 1 and ``ratio`` about an axis 0.3 off their centre (a first
    axis), their departure from circles all explained (a circle has none to explain)."""
    shape = section_shape(*_tube(ratio, offset=(0.3, -0.1)), 21)
    assert shape.amplitude == pytest.approx((1 - ratio**2) / (1 + ratio**2), abs=1e-5)
    assert shape.explained < 1e-3 or ratio == 1.0


@pytest.mark.parametrize("n_around", [7, 8])
def test_segments_with_too_few_vertices_are_not_counted(n_around):
    """One ring of a 2:1 ellipse per segment: ``n_around`` vertices each, GC_ELLIPTIC_MIN_VERTICES (8) counted, 7 not
    (no segment counted: amplitude 0, nothing explained, not elliptic)."""
    assert tol.GC_ELLIPTIC_MIN_VERTICES == 8
    shape = section_shape(*_tube(0.5, n_around=n_around, z=np.arange(0.25, 10.0, 0.5)), 21)
    counted = n_around >= tol.GC_ELLIPTIC_MIN_VERTICES
    assert shape.elliptic == counted and (shape.amplitude == pytest.approx(0.6, abs=1e-5)) == counted


@pytest.mark.parametrize("side", [0.99, 1.01])
def test_the_amplitude_limit_at_its_edge(side):
    """GC_ELLIPTIC at 0.99 / 1.01 of an exact ellipse's amplitude: elliptic just above it, not just below."""
    a = tol.GC_ELLIPTIC / side  # the amplitude of the ellipse: 1.01 / 0.99 of the limit
    ratio = np.sqrt((1 - a) / (1 + a))
    assert section_shape(*_tube(ratio), 21).elliptic == (side < 1)


def test_the_explained_share_against_its_definition_and_at_its_edge():
    """An ellipse (2:1) with a non-elliptic ripple, off the axis: the share of its departure from circles left about
    its ellipses is the definition's (an independent per-segment least squares) and grows with the ripple; GC_ELLIPTIC_RESIDUAL
    at 0.99 / 1.01 of the share: elliptic just under it, not just over."""
    shares = []
    for ripple in (0.01, 0.03, 0.1):
        data = _tube(0.5, n_around=48, ripple=ripple, offset=(0.2, -0.1))  # about an axis off the centre
        shape = section_shape(*data, 21)
        assert shape.explained == pytest.approx(_reference_explained(*data, 21), rel=1e-3)
        shares.append(shape.explained)
    assert shares[0] < shares[1] < shares[2]
    data = _tube(0.5, n_around=48, ripple=0.03)
    share = section_shape(*data, 21).explained
    for side in (0.99, 1.01):
        with pytest.MonkeyPatch.context() as m:
            m.setattr(tol, "GC_ELLIPTIC_RESIDUAL", side * share)
            assert section_shape(*data, 21).elliptic == (side > 1)


def test_the_conic_residual_of_an_ellipse_is_zero_and_of_a_ripple_is_the_ripple():
    """About each segment's ellipse the relative residual of exact ellipses is zero; a small ripple on a circle
    (radius times 1 + 0.01 sin(3 theta) cos(7 theta)) is left as it is (its harmonics are not the second)."""
    s, local, w = _tube(0.5, n_around=48)
    radii = np.full(21, np.sqrt(0.5 * (1 + 0.25)))
    assert np.abs(conic_residual(s, local, w, radii)).max() < 1e-6
    s, local, w = _tube(1.0, n_around=48, ripple=0.01)
    t = np.arctan2(local[:, 2], local[:, 1])
    g = np.hypot(local[:, 1], local[:, 2]) - 1.0
    e = conic_residual(s, local, w, np.ones(21))
    assert np.abs(e - g).max() < 2e-3 and np.abs(g).max() > 5e-3
    assert t.size == e.size


def _third_of_a_wall_correction(elliptic, centre):
    """Circle-fit corrections (no lam) of an ellipse tube (axes 1 and 0.4) centred at ``centre`` off a straight
    axis along z, with only the vertices at theta in [0.3, 2.2] about their centre kept (an uneven weighting round
    the axis: an end's tilt, a bend's stretch)."""
    s, local, w = _tube(0.4, n_around=64, offset=centre)
    t = np.arctan2((local[:, 2] - centre[1]) / 0.4, local[:, 1] - centre[0]) % (2 * np.pi)
    w = np.where((t > 0.3) & (t < 2.2), 1.0, 0.0)
    K = 11
    nodes = np.c_[np.zeros(K), np.zeros(K), np.linspace(0, 10, K)]
    frames = np.tile(np.array([[0.0, 0, 1], [1, 0, 0], [0, 1, 0]]), (K, 1, 1))
    return circle_fit_correction(frames, nodes, s, local, w, 0.0, 1.0, pin_ends=False, elliptic=elliptic)


def test_an_unevenly_weighted_ellipse_keeps_its_centre_only_with_its_harmonic():
    """A third of an ellipse's wall about an axis through its centre: with the second harmonic no correction (the
    fixed point is the centre); the circle fit moves the axis a tenth of a radius off. From 0.3 radii off, the
    corrections with the harmonic, applied in turn (Eq. 3), come to the centre."""
    assert np.abs(_third_of_a_wall_correction(True, (0.0, 0.0))).max() < 1e-5
    assert np.abs(_third_of_a_wall_correction(False, (0.0, 0.0))).max() > 0.1
    for elliptic in (True, False):
        c = np.array([0.3, -0.1])
        for _ in range(80):
            c = c - _third_of_a_wall_correction(elliptic, tuple(c))[:, :2].mean(axis=0)
        assert (np.abs(c).max() < 1e-6) == elliptic, c


def test_rows_without_the_harmonic_keep_their_sums_bit_for_bit():
    """Two axes stacked (the tree's fixed points): the rows of one carry the harmonic, the other's segments are
    those it has alone, bit for bit and finite (an empty harmonic block once turned them into NaN)."""
    s1, l1, w1 = _tube(0.4)
    s2, l2, w2 = _tube(1.0, z=np.arange(0.0, 5.01, 0.1))
    K1, K2 = 21, 11
    s, local, w = np.r_[s1, s2], np.r_[l1, l2], np.r_[w1, w2]
    K = np.r_[np.full(len(s1), K1), np.full(len(s2), K2)]
    off = np.r_[np.zeros(len(s1), int), np.full(len(s2), K1)]
    S, R = circle_fit_sums(s, local, w, K, np.ones(len(s)), off, K1 + K2,
                           elliptic=np.r_[np.ones(len(s1), bool), np.zeros(len(s2), bool)])
    S2, R2 = circle_fit_sums(s2, l2, w2, K2, 1.0)
    assert np.array_equal(S[K1:K1 + K2 - 1], S2) and np.array_equal(R[K1:K1 + K2 - 1], R2)
    assert np.isfinite(S).all() and np.isfinite(R).all()
    Sa, Ra = circle_fit_sums(s2, l2, w2, K2, 1.0, elliptic=False)
    assert np.array_equal(Sa, S2) and np.array_equal(Ra, R2)


def _vein_helix():
    """A helix swept with 2.5:1 ellipses, 48 points around (tests/test_coarse_to_fine.py's vein)."""
    return synthetic_vessel("helix", radius=1.5, ellipticity=0.4, ellipse_angle=0.3, n_around=48, remesh=False)


def test_a_flattened_vein_converges_from_its_first_axis():
    """The 2.5:1 helix, which with the circle fit kinked from its first axis and needed a second try from coarser
    nodes (0.035 % r mean, 0.06 worst), converges from its first axis: 0.0029 % r mean, 0.0065 worst."""
    ves = _vein_helix()
    with pytest.MonkeyPatch.context() as m:
        records = []
        m.setattr(vesselgp.fit.log, "info", lambda msg, *a: records.append(msg % a))
        gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    said = [r for r in records if "sections are ellipses" in r]
    assert len(said) == 1 and "second harmonic 0.72" in said[0], said  # (2.5^2 - 1) / (2.5^2 + 1)
    e = swept_axis_errors(ves, gc)
    assert gc.converged and e.mean() <= FACTOR * 0.0029 and e.max() <= FACTOR * 0.0065, (e.mean(), e.max())


def test_a_noisy_flattened_vein_keeps_eq2s_pull():
    """The vein helix remeshed, with normal noise of 1 % r: its sections still read as ellipses (the noise is not
    elliptic but small), its scatter keeps Eq. 2's weight above the refinement's limit, and its fit is not freed of
    the pull, which would follow the noise: 0.10 % r mean and 0.26 worst (freed, 0.15 / 0.40; bounds 1.3x)."""
    ves = synthetic_vessel("helix", radius=1.5, ellipticity=0.4, ellipse_angle=0.3, n_around=48, remesh=True,
                           noise=0.01, seed=1)
    gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    e = swept_axis_errors(ves, gc)
    assert gc.final_lam > tol.GC_REFINE_LAMBDA * gc.lam
    assert e.mean() <= 1.3 * 0.103 and e.max() <= 1.3 * 0.26, (e.mean(), e.max())


@pytest.mark.parametrize("kr, angle, mid, ends", [(0.3, 1.57, 0.032, 0.69), (0.5, 1.57, 0.063, 0.96),
                                                  (0.5, 0.785, 0.042, 0.71)])
def test_a_flattened_arc_is_followed_to_its_ends(kr, angle, mid, ends):
    """Arcs of 0.8 pi (curvature x radius 0.3 and 0.5) swept with 2.5:1 ellipses, their major axis out of the bend's
    plane or across it: with the circle fit each is refused (its axis bends tighter than its radius near an end);
    now within ``mid`` % r two radii from the ends and ``ends`` % r nearer them (measured)."""
    ves = synthetic_vessel(named_curve("arc", bend_radius=1 / kr, angle=np.pi * 0.8), radius=1.0, ellipticity=0.4,
                           ellipse_angle=angle, n_around=48, remesh=False)
    gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    t = ves.truth
    st = t.s * t.length
    e = 100 * polyline_distance(t.centers, gc.dense_points) / t.radii
    inner = (st > 2) & (st < t.length - 2)
    assert e[inner].max() <= FACTOR * mid and e[~inner].max() <= FACTOR * ends, (e[inner].max(), e[~inner].max())
    with pytest.MonkeyPatch.context() as m:
        m.setattr(tol, "GC_ELLIPTIC", np.inf)
        with pytest.raises(vesselgp.NotTubularError):
            vesselgp.fit_generalized_cylinder(ves.V, ves.F)


@needs_real(rs.CASES["coronary_vein"].mesh)
@pytest.mark.parametrize("side", [0.99, 1.01])
def test_an_elliptic_walls_pull_is_fitted_away_at_its_edge(side, monkeypatch, caplog):
    """The real coronary's line swept with 2.5:1 ellipses (docs/accuracy.md's ``coronary_vein``): with Eq. 2's pull
    0.060 % r mean and 0.95 worst, fitted once more without it 0.0031 / 0.065. GC_FREE_PULL at 0.99 / 1.01 of
    the fit's own pull (read with the stage off): fitted once more just under it, not just over."""
    first, gc, freed, e0, e = free_stage_at_edge(rs.case_vessel("coronary_vein"), side, monkeypatch, caplog)
    assert e0.mean() > 0.04 and e0.max() > 0.6, (e0.mean(), e0.max())  # the pull's own error: the test can fail
    assert freed == (side < 1)
    if side < 1:
        assert e.mean() <= FACTOR * 0.0031 and e.max() <= FACTOR * 0.065, (e.mean(), e.max())
        assert gc.iterations > first.iterations  # both fits' iterations


@needs_real(rs.CASES["coronary_vein"].mesh)
def test_the_flattened_veins_twist_is_measured():
    """With the circle fit the meter's recovery of the vein ran 0.046 radii off and was refused
    (tests/test_torsion_recovery.py); with the harmonic, the uniform 1.2 rad and the 180-degree ramp imposed on its
    rings are read within 0.050 and 0.31 degrees (energy 0.09 and 0.15 %), with no WARNING of a damped twist."""
    ves = rs.case_vessel("coronary_vein")
    gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    meter = vesselgp.TorsionMeter(ves.V, ves.F, gc)
    for name, bound, energy in (("uniform", 0.050, 0.09), ("ramp", 0.31, 0.15)):
        alpha, dalpha = SWEPT_TWISTS[name]
        prof = meter(deform_synthetic(ves, twist=alpha))
        err, de = imposed_twist_errors(prof, gc, ves.truth, alpha, dalpha)
        assert err <= FACTOR * bound and abs(de) <= FACTOR * energy, (name, err, de)
        assert prof.smoothing_residual < tol.TORSION_DAMPED
