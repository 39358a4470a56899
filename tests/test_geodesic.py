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


def test_distance_from_an_end_ring_is_the_height_along_a_tube_in_any_pose():
    ves = synthetic_vessel(np.c_[np.zeros(5), np.zeros(5), np.linspace(0.0, 12.0, 5)], radius=1.0)
    z = ves.V[:, 2]
    ring = np.flatnonzero(z < z.min() + 1e-9)
    d = GeodesicDistances(ves.V, ves.F)(ring)
    h = z - z.min()
    far = h > 2.0
    assert np.abs(d[far] / h[far] - 1).max() < 0.03
    # rigid motion: the same distances (the heat method sees only lengths and angles)
    Q = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))[0]
    d2 = GeodesicDistances(ves.V @ Q.T + [5.0, -2.0, 1.0], ves.F)(ring)
    assert np.abs(d2 - d).max() < 1e-9 * d.max()


def test_a_solver_of_another_mesh_is_refused():
    V, F = _random_sphere(200, 1.0)
    geo = GeodesicDistances(V, F)
    assert geo.check(V, F) is geo
    with pytest.raises(OptionError, match="precomputed for a mesh"):
        geo.check(V[:-1], F[:-2])
