"""Heat-method geodesic distances (vesselgp.mesh.geodesic) against analytic distances."""
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from vesselgp.errors import OptionError
from vesselgp.mesh.geodesic import GeodesicDistances
from vesselgp.synthetic import synthetic_vessel


def _random_sphere(n, R, seed=0):
    """A Delaunay (convex hull) triangulation of n random points on a sphere of radius R, a pole first."""
    P = np.random.default_rng(seed).normal(size=(n, 3))
    P[0] = [0, 0, 1]
    P = R * P / np.linalg.norm(P, axis=1)[:, None]
    return P, ConvexHull(P).simplices.astype(np.int64)


def test_distances_on_a_sphere_follow_the_great_circles():
    R = 3.0
    V, F = _random_sphere(4000, R)
    d = GeodesicDistances(V, F)([0])
    truth = R * np.arccos(np.clip(V[:, 2] / R, -1, 1))
    far = truth > 0.5 * R
    # an irregular triangulation (random points, slivers): within 5 % of the great circle
    # everywhere and 2 % typically (the heat method's smoothing, not an edge path's zigzag)
    rel = np.abs(d[far] / truth[far] - 1)
    assert rel.max() < 0.05 and np.median(rel) < 0.02
    assert abs(d[0]) < 1e-9 * R


@pytest.mark.parametrize("length", [12.0, 60.0])
def test_distance_from_an_end_ring_is_the_height_along_a_tube_in_any_pose(length):
    """From one end ring of a tube of radius 1, the distance is the height within 3 % past two radii; on a tube
    60 radii long (about 230 edges) too: the default heat time scales with the mesh's extent, so the heat
    still reaches the far end (with t = h^2 it underflows past about 50 edges). A rigid motion changes
    nothing (the heat method sees only lengths and angles)."""
    ves = synthetic_vessel(np.c_[np.zeros(5), np.zeros(5), np.linspace(0.0, length, 5)], radius=1.0)
    z = ves.V[:, 2]
    ring = np.flatnonzero(z < z.min() + 1e-9)
    d = GeodesicDistances(ves.V, ves.F)(ring)
    h = z - z.min()
    far = h > 2.0
    assert np.all(np.isfinite(d)) and np.abs(d[far] / h[far] - 1).max() < 0.03
    Q = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))[0]
    d2 = GeodesicDistances(ves.V @ Q.T + [5.0, -2.0, 1.0], ves.F)(ring)
    assert np.abs(d2 - d).max() < 1e-9 * d.max()


def test_a_solver_of_another_mesh_is_refused():
    V, F = _random_sphere(200, 1.0)
    geo = GeodesicDistances(V, F)
    assert geo.check(V, F) is geo
    with pytest.raises(OptionError, match="precomputed for a mesh"):
        geo.check(V[:-1], F[:-2])


def _libigl_distances(V, F, t, sources):
    """libigl's own heat method (its zero-mean Poisson solve by LU), on the same closed mesh and time."""
    import igl
    from vesselgp.mesh.geodesic import _closed
    from vesselgp.mesh.topology import mesh_topology
    data = igl.HeatGeodesicsData()
    igl.heat_geodesics_precompute(*_closed(V, F, mesh_topology(F, len(V)).boundary_loops), t, data)
    return igl.heat_geodesics_solve(data, np.asarray(sources, np.int64))[: len(V)]


def test_distances_equal_libigls_heat_method_from_each_source_set_at_once():
    """Pinned Cholesky Poisson solve and batched columns against libigl's heat_geodesics (two open ends)."""
    ves = synthetic_vessel("arc", radius=1.0)
    V, F = ves.V, ves.F
    geo = GeodesicDistances(V, F)
    z = V @ np.array([0.3, -0.2, 0.9])
    sets = [np.flatnonzero(z < np.quantile(z, 0.01)), [17], np.arange(300, 340)]
    D = geo.from_each(sets)
    assert D.shape == (len(V), 3)
    for c, s in enumerate(sets):
        ref = _libigl_distances(V, F, geo.t, s)
        assert np.abs(D[:, c] - ref).max() < 1.5e-12 * ref.max()
        assert np.abs(geo(s) - D[:, c]).max() < 1e-12 * ref.max()
    # a closed surface (no fans), more sets than one solve takes (tolerances.GEODESIC_SOLVE_COLUMNS)
    Vs, Fs = _random_sphere(1000, 2.0, seed=5)
    geo = GeodesicDistances(Vs, Fs)
    sets = [[i, i + 1] for i in range(0, 200, 20)]
    D = geo.from_each(sets)
    for c, s in enumerate(sets):
        ref = _libigl_distances(Vs, Fs, geo.t, s)
        assert np.abs(D[:, c] - ref).max() < 1.5e-12 * ref.max()


@pytest.mark.parametrize("bad", [[[]], [[-1, 3]], [[0, 10**6]], [7], [[0.5, 1.5]]])
def test_bad_source_sets_are_refused(bad):
    V, F = _random_sphere(200, 1.0)
    with pytest.raises(OptionError, match="source"):
        GeodesicDistances(V, F).from_each(bad)


def test_several_components_are_refused():
    from vesselgp.errors import InvalidMeshError
    V, F = _random_sphere(200, 1.0)
    V2, F2 = np.vstack([V, V + 5.0]), np.vstack([F, F + len(V)])
    with pytest.raises(InvalidMeshError, match="2 connected components"):
        GeodesicDistances(V2, F2)


def test_a_given_topology_gives_the_same_distances_and_a_wrong_one_is_refused():
    from vesselgp.mesh.topology import mesh_topology
    ves = synthetic_vessel("arc", radius=1.0)
    V, F = ves.V, ves.F
    topo = mesh_topology(F, len(V))
    a, b = GeodesicDistances(V, F), GeodesicDistances(V, F, topo)
    assert a.t == b.t
    assert np.array_equal(a([0, 1, 2]), b([0, 1, 2]))
    with pytest.raises(OptionError, match="topology given"):
        GeodesicDistances(V, F[:-1], topo)
    with pytest.raises(OptionError, match="topology given"):  # the same counts, other faces
        GeodesicDistances(V, np.roll(F, 1, axis=0), topo)


def test_given_areas_give_the_same_distances_and_a_wrong_shape_is_refused():
    """A fit passes the wall's Voronoi areas it has already: the closed mesh's mass matrix is them
    plus the fans' shares, the same distances as computing it whole; areas of another mesh are refused."""
    from vesselgp.mesh._geometry import voronoi_areas
    ves = synthetic_vessel("arc", radius=1.0)  # open at both ends: two fans
    V, F = ves.V, ves.F
    a, b = GeodesicDistances(V, F), GeodesicDistances(V, F, areas=voronoi_areas(V, F))
    ring = np.flatnonzero(V[:, 2] == V[:, 2].min())
    np.testing.assert_allclose(b(ring), a(ring), rtol=0, atol=1e-12 * np.ptp(a(ring)))
    c = GeodesicDistances(V, F, areas=2.0 * voronoi_areas(V, F))  # a wrong mass matrix is felt
    assert np.abs(c(ring) - a(ring)).max() > 1e-6 * np.ptp(a(ring))
    with pytest.raises(OptionError, match="one entry per vertex"):
        GeodesicDistances(V, F, areas=np.ones(len(V) - 1))


def test_a_checked_mesh_shares_its_topology_only_when_no_face_was_dropped():
    from vesselgp.fit import checked_mesh
    ves = synthetic_vessel("arc", radius=1.0)
    V, F = ves.V, ves.F
    c = checked_mesh(V, F)
    assert c.faces_topology is c.topology
    # a zero-area face (a repeated corner) on a vertex that keeps other faces: dropped from faces
    F2 = np.vstack([F, [[F[0, 0], F[0, 1], F[0, 1]]]])
    c2 = checked_mesh(V, F2)
    assert len(c2.faces) == len(F) and c2.faces_topology is None


def test_cotangent_operators_are_libigls_cotmatrix_grad_and_areas():
    """The heat method's Laplacian and gradient (numpy) against libigl's own, on an irregular
    triangulation (random points on a sphere: slivers, obtuse corners, faces of either
    orientation), and the gradient of a linear function, which is exact per face."""
    import igl
    from vesselgp.mesh._geometry import cotangent_operators

    V, F = _random_sphere(3000, 2.0, seed=3)
    F[::2] = F[::2, ::-1]  # mixed orientations: the gradient is the same either way
    L, G, area = cotangent_operators(V, F)
    L0, G0 = igl.cotmatrix(V, F), igl.grad(V, F)
    assert abs(L - L0).max() <= 1e-12 * abs(L0).max()
    assert abs(G - G0).max() <= 1e-12 * abs(G0).max()
    np.testing.assert_allclose(area, 0.5 * igl.doublearea(V, F), rtol=1e-12)
    a = np.array([0.3, -1.2, 0.7])
    g = (G @ (V @ a)).reshape(3, -1).T  # a's component in each face's plane
    N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    N /= np.linalg.norm(N, axis=1)[:, None]
    np.testing.assert_allclose(g, a - (N @ a)[:, None] * N, atol=1e-9)
    np.testing.assert_allclose(np.asarray(L.sum(axis=1)).ravel(), 0.0, atol=1e-12 * abs(L0).max())

