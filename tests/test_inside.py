"""The axis check: an axis outside the surface, or grazing its wall, raises (issue #13, item 3)."""
from __future__ import annotations

import numpy as np
import pytest

import vesselgp
from vesselgp.inside import axis_winding, check_axis_inside
from vesselgp.synthetic import synthetic_vessel


@pytest.fixture(scope="module", params=["open", "capped"])
def tube(request):
    return synthetic_vessel("arc", radius=1.5, n_around=24, remesh=False, ends=request.param)


def _axis(tube, offset):
    t = tube.truth
    s = np.linspace(0, 1, 60)
    pts, fr = t.axis_at(s)
    return s, pts + offset * fr[:, 1], np.full(len(s), 1.5)


def test_true_axis_is_inside(tube):
    s, P, r = _axis(tube, 0.0)
    w, d = axis_winding(tube.V, tube.F, P[5:-5])
    assert np.all(np.abs(np.abs(w) - 1) < 0.05)  # the closed surface winds once around the axis
    assert np.all(np.abs(d - 1.5) < 0.2)
    check_axis_inside(tube.V, tube.F, s, P, r)


def test_axis_outside_raises_with_where_and_why(tube):
    s, P, r = _axis(tube, 3.0)  # two radii off the centre line: outside the wall
    w, _ = axis_winding(tube.V, tube.F, P[5:-5])
    assert np.all(np.abs(w) < 0.1)
    with pytest.raises(vesselgp.NotTubularError, match=r"leaves the surface at s = 0\.\d+ \(point \(.*\)\).*not detected.*staircase.*U-turn"):
        check_axis_inside(tube.V, tube.F, s, P, r)


def test_axis_grazing_the_wall_raises(tube):
    s, P, r = _axis(tube, 1.35)  # inside, 0.1 radius from the wall
    with pytest.raises(vesselgp.NotTubularError, match="radii of the wall"):
        check_axis_inside(tube.V, tube.F, s, P, r)


def test_one_winding_checks_several_axes_and_refuses_another_mesh(tube):
    """A SurfaceWinding built once checks the true axis (inside) and an offset one (outside) as the
    one-off check does; a winding of another mesh is refused."""
    from vesselgp.errors import OptionError
    from vesselgp.inside import SurfaceWinding

    wind = SurfaceWinding(tube.V, tube.F)
    s, P, r = _axis(tube, 0.0)
    w, d = wind(P[5:-5])
    assert np.all(np.abs(np.abs(w) - 1) < 0.05) and np.all(np.abs(d - 1.5) < 0.2)
    check_axis_inside(tube.V, tube.F, s, P, r, winding=wind)
    s, P, r = _axis(tube, 3.0)
    with pytest.raises(vesselgp.NotTubularError, match="leaves the surface"):
        check_axis_inside(tube.V, tube.F, s, P, r, winding=wind)
    with pytest.raises(OptionError, match="another|not this one"):
        check_axis_inside(tube.V[:-1], tube.F[:-1], s, P, r, winding=wind)


def _helix(a, b, n=2000, turns=2.0):
    """Helix (a cos t, a sin t, b t): its analytic unit tangents, arc length and curvature a / (a^2 + b^2)."""
    t = np.linspace(0, 2 * np.pi * turns, n)
    c = np.hypot(a, b)
    T = np.c_[-a * np.sin(t), a * np.cos(t), np.full(n, b)] / c
    P = np.c_[a * np.cos(t), a * np.sin(t), b * t]
    return t / t[-1], c * t[-1], T, P, a / c**2


@pytest.mark.parametrize("a, b", [(4.0, 1.0), (2.0, 3.0)])
def test_bend_check_holds_a_tube_to_curvature_times_radius_below_one(a, b):
    """kappa r < 1 passes and kappa r > 1 raises, on analytic helices (the truth is a / (a^2 + b^2))."""
    from vesselgp.inside import check_axis_bend

    s, L, T, P, kappa = _helix(a, b)
    check_axis_bend(s, L, T, np.full(len(s), 0.95 / kappa), points=P)
    with pytest.raises(vesselgp.NotTubularError, match=r"bends tighter than its radius at s = 0\.\d+ \(point \(.*\)\): "
                       r"curvature x radius = 1\.05 .*remesh finer.*lam=.*U-turn"):
        check_axis_bend(s, L, T, np.full(len(s), 1.05 / kappa), points=P)


def test_bend_check_finds_a_local_kink_and_passes_a_straight_axis():
    """A straight axis (no Frenet normal: the documented degenerate case) passes at any radius; a
    corner rounded over 0.2 of a radius at s = 0.6 is named there; the ends' margin is not checked."""
    from vesselgp.inside import check_axis_bend

    n = 3001
    s = np.linspace(0, 1, n)
    L = 30.0
    straight = np.tile([0.0, 0.0, 1.0], (n, 1))
    check_axis_bend(s, L, straight, np.full(n, 5.0))
    # the tangent turns by 0.5 rad within 0.2 length units at s = 0.6 (kappa 2.5 there, 0 elsewhere)
    phi = 0.5 * np.clip((s * L - 18.0) / 0.2 + 0.5, 0, 1)
    T = np.c_[np.sin(phi), np.zeros(n), np.cos(phi)]
    check_axis_bend(s, L, T, np.full(n, 0.35))  # kappa r 0.875
    with pytest.raises(vesselgp.NotTubularError, match=r"at s = 0\.59\d: curvature x radius = 1\.2"):
        check_axis_bend(s, L, T, np.full(n, 0.5))
    check_axis_bend(s, L, T, np.full(n, 0.5), ends_margin=12.5)  # the corner lies within 12.5 of the end


@pytest.mark.parametrize("step", [1, 3, 7])
def test_sampled_vertex_normals_are_libigls(step):
    """The axis check's surface samples carry libigl's default (area-weighted) vertex normals, computed
    only at the sampled vertices. Truth: igl.per_vertex_normals of the whole mesh, on an irregular
    remeshed tube with one face collapsed to zero area (a degenerate face adds nothing)."""
    import igl

    from vesselgp.inside import _vertex_normals

    ves = synthetic_vessel("arc", radius=1.0, n_around=16, seed=2)
    V, F = ves.V.copy(), ves.F.copy()
    V[F[5, 2]] = 0.5 * (V[F[5, 0]] + V[F[5, 1]])  # face 5 now has no area
    sub = slice(0, len(V), step)
    N = _vertex_normals(V, F, sub)
    ref = igl.per_vertex_normals(V, F)[sub]
    assert N.shape == ref.shape
    np.testing.assert_allclose(N, ref, atol=1e-12)
