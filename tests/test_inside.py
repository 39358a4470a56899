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


@pytest.mark.parametrize("clear, refused", [(0.25, False), (0.15, True)])
def test_the_wall_clearance_at_its_edge(tube, clear, refused):
    """Issue #35: an axis inside the lumen must keep 0.2 local radii from the wall. The centre line moved towards
    the wall to leave 0.25 radii passes, to leave 0.15 is refused (the 24-gon's wall is at most 0.9 % of a radius
    nearer than the circle's)."""
    s, P, r = _axis(tube, 1.5 * (1.0 - clear))
    if refused:
        with pytest.raises(vesselgp.NotTubularError, match="radii of the wall"):
            check_axis_inside(tube.V, tube.F, s, P, r)
    else:
        check_axis_inside(tube.V, tube.F, s, P, r)


@pytest.mark.parametrize("leaves_at, refused", [(0.8, False), (1.2, True)])
def test_the_ends_margin_at_its_edge(tube, leaves_at, refused):
    """Issue #35: the axis is not checked within one mean radius (1.5) of either end. An axis that runs out
    through the wall (three radii off the centre line) over its last 0.8 radii passes; over its last 1.2 radii it
    leaves the surface inside the checked part and is refused (a margin tripled would accept it)."""
    t = tube.truth
    s = np.linspace(0, 1, 2001)
    pts, fr = t.axis_at(s)
    arc = s * t.length
    out = t.length - arc < leaves_at * 1.5
    P = pts + np.where(out, 3.0 * 1.5, 0.0)[:, None] * fr[:, 1]
    r = np.full(len(s), 1.5)
    if refused:
        with pytest.raises(vesselgp.NotTubularError, match="leaves the surface"):
            check_axis_inside(tube.V, tube.F, s, P, r)
    else:
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


def _corner(n=3001, L=30.0):
    """An axis 30 long whose tangent turns by 0.5 rad within 0.2 of arc at s = 0.6 (arc 17.9-18.1: kappa 2.5
    there, 0 elsewhere): its samples' s, its length and the unit tangents."""
    s = np.linspace(0, 1, n)
    phi = 0.5 * np.clip((s * L - 18.0) / 0.2 + 0.5, 0, 1)
    return s, L, np.c_[np.sin(phi), np.zeros(n), np.cos(phi)]


def test_bend_check_finds_a_local_kink_and_passes_a_straight_axis():
    """A straight axis (no Frenet normal: the documented degenerate case) passes at any radius; a
    corner rounded over 0.2 of a radius at s = 0.6 is named there; the ends' margin is not checked."""
    from vesselgp.inside import check_axis_bend

    s, L, T = _corner()
    n = len(s)
    straight = np.tile([0.0, 0.0, 1.0], (n, 1))
    check_axis_bend(s, L, straight, np.full(n, 5.0))
    check_axis_bend(s, L, T, np.full(n, 0.35))  # kappa r 0.875
    with pytest.raises(vesselgp.NotTubularError, match=r"at s = 0\.59\d: curvature x radius = 1\.2"):
        check_axis_bend(s, L, T, np.full(n, 0.5))
    check_axis_bend(s, L, T, np.full(n, 0.5), ends_margin=12.5)  # the corner lies within 12.5 of the end


def test_bend_check_skips_a_junction_zone_up_to_its_edge():
    """A tree branch's led-in junction zone (``skip_start``) is not held to the bend limit: the same
    corner (kappa 2.5 over arc 17.9-18.1, kappa r 1.25) passes when the zone ends just past it and is
    named when the zone ends just before it."""
    from vesselgp.inside import check_axis_bend

    s, L, T = _corner()
    r = np.full(len(s), 0.5)
    check_axis_bend(s, L, T, r, ends_margin=0.0, skip_start=18.15)
    with pytest.raises(vesselgp.NotTubularError, match="bends tighter than its radius"):
        check_axis_bend(s, L, T, r, ends_margin=0.0, skip_start=18.0)


def test_bend_check_skips_a_medial_zone_up_to_its_edges():
    """A medial zone (``skip``, intervals of s where a tree branch's axis is the lumen's centre line) is not
    held to the bend limit either: the corner at arc 17.9-18.1 (s 0.5967-0.6033) passes inside the zone
    s 0.59-0.61 and is named when the zone stops short of it on either side."""
    from vesselgp.inside import check_axis_bend

    s, L, T = _corner()
    r = np.full(len(s), 0.5)
    check_axis_bend(s, L, T, r, skip=[[0.2, 0.3], [0.59, 0.61]])
    for zone in ([0.59, 0.598], [0.602, 0.61]):
        with pytest.raises(vesselgp.NotTubularError, match="bends tighter than its radius"):
            check_axis_bend(s, L, T, r, skip=[zone])


def _thin_tube(n_around=8, radius=0.4, spacing=0.8, rings=50):
    """An open prism tube along x (regular ``n_around``-gon sections), rings ``spacing`` apart."""
    t = 2 * np.pi * np.arange(n_around) / n_around
    V = np.vstack([np.c_[np.full(n_around, k * spacing), radius * np.cos(t), radius * np.sin(t)] for k in range(rings)])
    F = []
    for k in range(rings - 1):
        for j in range(n_around):
            a, b = k * n_around + j, k * n_around + (j + 1) % n_around
            F += [[a, b, b + n_around], [a, b + n_around, a + n_around]]
    return V, np.array(F, np.int64)


def test_winding_and_wall_distance_are_exact_on_a_thin_coarse_branch():
    """A thin coarse tube (an 8-gon of radius 0.4, rings 2 radii apart: the XCAT tree's leaves) beside
    a finely meshed sphere (10k vertices) in one mesh: every point of the tube's centre line is inside
    (winding 1) at its exact distance to the faces, the apothem r cos(pi / 8); points 0.2 beyond the
    tube's widest part are outside. Until issue #34 the sum ran over 3000 thinned vertices, of which
    the tube kept a handful, and put such centre lines outside."""
    from vesselgp.inside import SurfaceWinding

    Vt, Ft = _thin_tube()
    Vs, Fs = _icosphere(5)
    V = np.vstack([Vt, 5.0 * Vs + [20.0, 12.0, 0.0]])
    F = np.vstack([Ft, Fs + len(Vt)])
    assert len(V) > 10000
    x = np.linspace(2.0, 37.0, 200)
    Q = np.c_[x, 0 * x, 0 * x]
    sw = SurfaceWinding(V, F)
    w, d = sw(Q)
    np.testing.assert_allclose(np.abs(w), 1.0, atol=0.05)  # libigl's tree sum, to about 1 % (the old sum: 0.78)
    np.testing.assert_allclose(d, 0.4 * np.cos(np.pi / 8), atol=1e-9)
    w, d = sw(Q + [0.0, 0.6, 0.0])
    assert np.abs(w).max() < 0.05
    np.testing.assert_allclose(d, 0.2, atol=1e-9)


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


# --- issue #47: exact winding numbers and distances at a cost that follows the query points ---------------


def _torus(R=3.0, r=1.0, n=48, m=24):
    """A closed torus (major R, minor r) of n x m quads split in two, normals outwards."""
    u, v = np.meshgrid(np.arange(n) * 2 * np.pi / n, np.arange(m) * 2 * np.pi / m, indexing="ij")
    V = np.c_[((R + r * np.cos(v)) * np.cos(u)).ravel(), ((R + r * np.cos(v)) * np.sin(u)).ravel(),
              (r * np.sin(v)).ravel()]
    i, j = np.meshgrid(np.arange(n), np.arange(m), indexing="ij")
    a, b = (i * m + j).ravel(), (((i + 1) % n) * m + j).ravel()
    c, d = (((i + 1) % n) * m + (j + 1) % m).ravel(), (i * m + (j + 1) % m).ravel()
    return V, np.r_[np.c_[a, b, c], np.c_[a, c, d]].astype(np.int64)


def test_ray_winding_is_libigls_exact_sum_on_a_closed_torus_and_on_an_open_surface():
    """The ray count equals libigl's direct sum (exact) everywhere: 1 in the torus's tube, 0 in its hole and
    outside, -1 with the faces turned in; on an OPEN surface (the torus less a band) the direct sum, not an
    integer, because the line there does not cross as often in as out."""
    import igl
    from vesselgp.inside import ray_winding
    from vesselgp.synthetic import signed_volume

    V, F = _torus()
    assert signed_volume(V, F) > 0
    rng = np.random.default_rng(3)
    Q = rng.uniform(-4.5, 4.5, (400, 3)) * [1, 1, 0.4]
    Q = np.vstack([Q, [[3.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 3.0, 0.5]]])  # in the tube, in the hole, in the tube
    exact = np.asarray(igl.winding_number(V, F, Q))
    w = ray_winding(V, F, Q)
    np.testing.assert_allclose(w, exact, atol=1e-9)
    assert set(np.round(w).astype(int)) == {0, 1} and w[-3] == 1 and w[-2] == 0 and w[-1] == 1
    np.testing.assert_allclose(ray_winding(V, F[:, ::-1], Q), -exact, atol=1e-9)
    keep = np.ones(len(F), bool)
    keep[::7] = False  # holes all round: an open surface
    w_open = ray_winding(V, F[keep], Q)
    np.testing.assert_allclose(w_open, igl.winding_number(V, F[keep], Q), atol=1e-9)
    assert np.any(np.abs(w_open - np.round(w_open)) > 0.01)


def test_ray_winding_is_exact_where_the_rays_meet_edges_and_corners():
    """Points placed so that the ray passes through a mesh vertex or along an edge in projection (the degenerate
    cases of a crossing count) get the exact value: each vertex pushed 0.3 along its inward and outward normal."""
    import igl
    from vesselgp.inside import ray_winding, _RAY_FRAME

    V, F = _torus()
    N = igl.per_vertex_normals(V, F)
    d = _RAY_FRAME[0]
    k = np.arange(0, len(V), 5)
    Q = np.vstack([V[k] - 0.3 * N[k], V[k] + 0.3 * N[k]])
    # and the vertices themselves moved back along the ray: their rays pass exactly through a corner
    Q = np.vstack([Q, V[k] - 1e-3 * d])
    w = ray_winding(V, F, Q)
    np.testing.assert_allclose(w, igl.winding_number(V, F, Q), atol=1e-9)
    assert np.all(np.round(w[:len(k)]) == 1) and np.all(np.round(w[len(k):2 * len(k)]) == 0)


def test_distance_is_exact_on_a_coarse_tube_axis_and_beside_long_cap_triangles():
    """On the axis of a 12-gon tube every corner of a ring is equally far (the worst case of a nearest-vertex
    bound) and the true distance is the apothem r cos(pi / 12); the caps' long fan triangles make the bound
    wide. Few points (the k-d tree route) and many points (the AABB route) both give libigl's exact
    distances; nearer_than decides at the apothem to 1e-9 either side."""
    import igl
    from vesselgp import tolerances as tol
    from vesselgp.inside import SurfaceWinding

    n, r = 12, 2.0
    th = np.arange(n) * 2 * np.pi / n
    rings = [np.c_[np.full(n, x), r * np.cos(th), r * np.sin(th)] for x in np.arange(0, 20.1, 1.5)]
    V = np.vstack(rings + [[[0.0, 0.0, 0.0], [rings[-1][0, 0], 0.0, 0.0]]])
    F = []
    for k in range(len(rings) - 1):
        for j in range(n):
            a, b = k * n + j, k * n + (j + 1) % n
            F += [[a, a + n, b + n], [a, b + n, b]]
    c0, c1 = len(V) - 2, len(V) - 1
    last = (len(rings) - 1) * n
    F += [[c0, j, (j + 1) % n] for j in range(n)] + [[c1, last + (j + 1) % n, last + j] for j in range(n)]
    F = np.array(F, np.int64)
    sw = SurfaceWinding(V, F)
    x = np.linspace(3.0, 17.0, 30)
    few = np.c_[x, 0 * x, 0 * x]
    many = np.vstack([few + [0, 0.3 * np.cos(a), 0.3 * np.sin(a)] for a in np.linspace(0, 6, 4)])
    assert len(few) <= tol.INSIDE_FEW_POINTS < len(many)
    for Q in (few, many, np.array([[0.5, 0.2, 0.1], [19.9, -0.3, 0.4]])):  # the last beside the cap fans
        exact = np.sqrt(igl.point_mesh_squared_distance(Q, V, F)[0])
        np.testing.assert_allclose(sw.distance(Q), exact, rtol=0, atol=1e-12)
    apothem = r * np.cos(np.pi / n)
    np.testing.assert_allclose(sw.distance(few), apothem, atol=1e-12)
    assert sw.nearer_than(few, apothem + 1e-9).all() and not sw.nearer_than(few, apothem - 1e-9).any()
    np.testing.assert_allclose(np.abs(sw.winding(few)), 1.0, atol=1e-12)


def test_the_inside_check_builds_no_structure_over_the_whole_surface_for_a_few_samples():
    """Checking a few hundred axis samples of a large tube neither builds libigl's AABB tree of all faces nor
    its fast-winding-number tree (the cost issue #47 removed), and gives the exact answers."""
    import igl
    from vesselgp.inside import SurfaceWinding, check_axis_inside

    V, F = _torus(n=400, m=60)  # 24k vertices
    sw = SurfaceWinding(V, F)
    t = np.linspace(0, 2 * np.pi, 300, endpoint=False)
    P = np.c_[3.0 * np.cos(t), 3.0 * np.sin(t), 0 * t]
    s = t / t[-1]
    check_axis_inside(V, F, s, P, np.full(len(t), 1.0), winding=sw, ends_margin=0.0)
    assert "_aabb" not in sw.__dict__
    with pytest.raises(vesselgp.NotTubularError, match="comes within"):
        check_axis_inside(V, F, s, P + [0.0, 0.0, 0.85], np.full(len(t), 1.0), winding=sw, ends_margin=0.0)
    assert "_aabb" not in sw.__dict__
    w = sw.winding(P + [0.0, 0.0, 1.2])
    np.testing.assert_allclose(w, 0.0, atol=1e-12)


def test_distance_finds_a_large_face_whose_corners_are_farther_than_another_faces_corner():
    """A point 1 above the middle of a large triangle (corners 10 away) and 5 from a small triangle's corner: the
    nearest vertex is the small one's, the nearest face the large one (distance 1), found through the ball of
    radius sqrt(d_v^2 + delta^2), not d_v."""
    from vesselgp.inside import SurfaceWinding

    big = 10.0 * np.array([[1.0, 0, 0], [-0.5, 0.866, 0], [-0.5, -0.866, 0]])
    small = np.array([[0.0, 0.0, 6.0], [0.3, 0.0, 6.2], [0.0, 0.3, 6.2]])
    V = np.vstack([big, small])
    F = np.array([[0, 1, 2], [3, 4, 5]], np.int64)
    sw = SurfaceWinding(V, F)
    Q = np.array([[0.0, 0.0, 1.0]])
    np.testing.assert_allclose(sw.distance(Q), [1.0], atol=1e-12)
    assert sw.nearer_than(Q, [1.0 + 1e-9])[0] and not sw.nearer_than(Q, [1.0 - 1e-9])[0]
