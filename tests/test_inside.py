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


def test_bend_check_skips_a_junction_zone_up_to_its_edge():
    """A tree branch's led-in junction zone (``skip_start``) is not held to the bend limit: the same
    corner (kappa 2.5 over arc 17.9-18.1, kappa r 1.25) passes when the zone ends just past it and is
    named when the zone ends just before it."""
    from vesselgp.inside import check_axis_bend

    n, L = 3001, 30.0
    s = np.linspace(0, 1, n)
    phi = 0.5 * np.clip((s * L - 18.0) / 0.2 + 0.5, 0, 1)
    T = np.c_[np.sin(phi), np.zeros(n), np.cos(phi)]
    r = np.full(n, 0.5)
    check_axis_bend(s, L, T, r, ends_margin=0.0, skip_start=18.15)
    with pytest.raises(vesselgp.NotTubularError, match="bends tighter than its radius"):
        check_axis_bend(s, L, T, r, ends_margin=0.0, skip_start=18.0)


@pytest.mark.parametrize("step", [5, 7, 12])
def test_sampled_vertex_normals_are_libigls(step):
    """The axis check's surface samples carry libigl's default (area-weighted) vertex normals, computed
    only at the sampled vertices (strides above tolerances.INSIDE_FULL_NORMALS_STEP, where libigl's
    whole-mesh normals are not taken). Truth: igl.per_vertex_normals of the whole mesh, on an irregular
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


def test_point_cloud_winding_is_barills_sum_and_libigls_winding_number():
    """The winding sum in matrix-product form (about the samples' centroid) against Barill et al.'s
    Eq. 5 summed term by term here, at points near and far from a sphere of radius 2 centred far from
    the origin (cancellation in |p|^2 + |q|^2 - 2 p.q); and against libigl's exact winding number of
    the triangle mesh: inside 1, outside 0, to the point cloud's discretisation."""
    import igl

    from vesselgp.inside import _point_cloud_winding
    from vesselgp.mesh._geometry import voronoi_areas

    V, F = _icosphere(3)
    V = 2.0 * V + [300.0, -120.0, 45.0]
    N = igl.per_vertex_normals(V, F)
    A = voronoi_areas(V, F)
    rng = np.random.default_rng(1)
    Q = [300.0, -120.0, 45.0] + rng.normal(size=(40, 3)) * [1.0, 2.0, 3.0]
    D = V[None] - Q[:, None]
    r = np.linalg.norm(D, axis=2)
    truth = (np.einsum("qij,ij->qi", D, N) * A / r**3).sum(axis=1) / (4 * np.pi)
    w = _point_cloud_winding(V, N, A, Q)
    np.testing.assert_allclose(w, truth, rtol=0, atol=1e-9)
    exact = igl.winding_number(V, F, Q)
    far = np.abs(np.linalg.norm(Q - [300.0, -120.0, 45.0], axis=1) - 2.0) > 0.3
    assert far.sum() >= 20
    np.testing.assert_allclose(w[far], exact[far], atol=0.05)


def _icosphere(k):
    """Unit icosphere subdivided ``k`` times (loop subdivision, projected to the sphere)."""
    import igl

    t = (1 + 5 ** 0.5) / 2
    V = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t],
                  [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    F = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                  [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
                  [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], np.int64)
    for _ in range(k):
        V, F = igl.upsample(V, F)
    return V / np.linalg.norm(V, axis=1, keepdims=True), F


def test_coincident_samples_merge_as_numpy_unique_rows():
    """Duplicated vertices give coincident winding samples, merged with their areas summed: the same
    rows, first occurrences and inverse as numpy's unique rows (the truth), on repeated grid points."""
    from vesselgp.inside import _unique_points

    rng = np.random.default_rng(0)
    P = rng.integers(0, 4, (500, 3)).astype(float) * 0.5 + [10.0, -3.0, 0.25]
    P[::7] = P[3]
    rows, first, inv = _unique_points(P)
    ref_rows, ref_first, ref_inv = np.unique(P, axis=0, return_index=True, return_inverse=True)
    np.testing.assert_array_equal(rows, ref_rows)
    np.testing.assert_array_equal(first, ref_first)
    np.testing.assert_array_equal(inv, ref_inv.ravel())
    assert len(rows) < len(P)
