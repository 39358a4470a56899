"""The surface points the Voronoi centre lines are built on (issue #47): spread by the lumen's local radius."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from vesselgp import tolerances as tol
from vesselgp.centerlines import _lumen_radius, _medial_sample
from vesselgp.errors import NotTubularError
from vesselgp.mesh._geometry import closed_by_fans
from vesselgp.synthetic import synthetic_tree, synthetic_vessel



@pytest.fixture(autouse=True)
def _thin_every_mesh(monkeypatch):
    """These meshes are small: thin them as a large one is (MEDIAL_ALL_POINTS would keep them whole)."""
    monkeypatch.setattr(tol, "MEDIAL_ALL_POINTS", 0)


def _sample(V, F):
    import igl

    Vc, Fc = closed_by_fans(V, F, igl.boundary_loop_all(F))
    return _medial_sample(V, F, Vc, Fc), (Vc, Fc)


def test_the_lumen_radius_of_a_circular_tube_is_its_radius():
    """On a straight tube of exact circular rings the circle through a vertex's ring neighbour, tangent to the
    wall, is the ring itself: the estimate is the radius (2.5) at every vertex a few rings from the open ends,
    turned inside out or not."""
    import igl

    ves = synthetic_vessel("straight", radius=2.5, n_around=32, remesh=False)
    V, F = ves.V, ves.F
    Vc, Fc = closed_by_fans(V, F, igl.boundary_loop_all(F))
    s = ves.truth.vertex_s
    mid = (s > 0.2) & (s < 0.8)
    for faces, closed in ((F, Fc), (F[:, ::-1], Fc[:, ::-1])):
        r = _lumen_radius(V, faces, Vc, closed, igl.edges(faces))
        np.testing.assert_allclose(r[mid], 2.5, rtol=1e-3)


def test_the_sample_spacing_follows_the_true_radius_not_the_mesh():
    """A two-tip tree whose trunk (radius 3-2.4) is over twice as wide as its tips (1.3-1.1), meshed at 0.3: on
    the wide parts the kept points lie 0.1-0.45 true radii apart (their six nearest), so the trunk keeps under
    70 % as large a share of its vertices as the tips, which keep most (the cells there are about one voxel)."""
    t = synthetic_tree(levels=1, voxel=0.3, taper=0.55, tube_taper=0.8)
    ids, _ = _sample(t.V, t.F)
    P = t.V[ids]
    _, r, _, _ = t.truth.nearest(P)
    gap = cKDTree(P).query(P, k=7)[0][:, 1:].mean(axis=1) / r  # to the six nearest kept points
    wide = r > np.percentile(r, 80)
    assert 0.1 < np.median(gap[wide]) < 0.45, np.median(gap[wide])
    _, rv, _, _ = t.truth.nearest(t.V)
    kept = np.zeros(len(t.V), bool)
    kept[ids] = True
    big, small = rv > np.percentile(rv, 80), rv < np.percentile(rv, 20)
    assert rv[big].mean() > 1.8 * rv[small].mean()
    assert kept[big].mean() < 0.7 * kept[small].mean() and kept[small].mean() > 0.6  # measured 52 % and 85 %


def test_the_sample_is_the_same_after_a_rigid_motion():
    """The grid lies in the surface's principal axes: a rotated and moved copy keeps the same vertices (a few of
    the grid's ties may fall the other way)."""
    from scipy.spatial.transform import Rotation

    t = synthetic_tree(levels=1, voxel=0.45)
    ids, _ = _sample(t.V, t.F)
    R = Rotation.from_rotvec([0.4, -1.1, 0.7]).as_matrix()
    moved, _ = _sample(t.V @ R.T + [30.0, -7.0, 12.0], t.F)
    assert len(np.setxor1d(ids, moved)) <= 0.01 * len(ids)


def test_a_surface_that_bends_into_no_lumen_is_refused_and_a_shallow_bowl_is_not():
    """A flat square has no edge curving inwards: refused. A bowl of sagitta 0.5 % of its width (just curved)
    is sampled."""
    import igl

    n = 20
    x, y = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n), indexing="ij")
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    F = np.r_[np.c_[a, a + n, a + n + 1], np.c_[a, a + n + 1, a + 1]].astype(np.int64)
    flat = np.c_[x.ravel(), y.ravel(), 0 * x.ravel()]
    with pytest.raises(NotTubularError, match="bends into no lumen"):
        _sample(flat, F)
    bowl = flat + np.c_[0 * x.ravel(), 0 * x.ravel(), 0.01 * (x.ravel() ** 2 + y.ravel() ** 2)]
    for faces in (F, F[:, ::-1]):  # either side of the bowl may face the "lumen" of its fans' closure
        ids, _ = _sample(bowl, faces)
        assert len(ids) >= 1


def test_a_mesh_of_at_most_medial_all_points_vertices_is_tessellated_whole(monkeypatch):
    """The limit's edge on a tree of n used vertices: with MEDIAL_ALL_POINTS = n every vertex is kept; with
    n - 1 the mesh is thinned (fewer than 80 % kept on this tree, whose trunk is 7 voxels across)."""
    t = synthetic_tree(levels=1, voxel=0.4)
    n = len(np.unique(t.F))
    monkeypatch.setattr(tol, "MEDIAL_ALL_POINTS", n)
    assert len(_sample(t.V, t.F)[0]) == n
    monkeypatch.setattr(tol, "MEDIAL_ALL_POINTS", n - 1)
    assert len(_sample(t.V, t.F)[0]) < 0.8 * n
