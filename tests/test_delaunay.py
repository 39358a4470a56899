"""The Delaunay tetrahedra the Voronoi centre lines are drawn on (issue #47): TetGen through libigl, checked
against qhull's (scipy) on points in general position and on a real surface, and its refusals at their edge."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import Delaunay

import vesselgp
from vesselgp import tolerances as tol
from vesselgp.centerlines import _delaunay
from vesselgp.errors import NotTubularError

from _data import REAL, needs_real


def _faces(T):
    return {tuple(sorted(t)) for t in T}


def _pairs(nb):
    i = np.repeat(np.arange(len(nb)), 4)
    j = nb.ravel()
    m = j > i
    return set(zip(i[m].tolist(), j[m].tolist()))


def _same_as_qhull(P):
    ours, theirs = _delaunay(P), Delaunay(P)
    assert _faces(ours.simplices) == _faces(theirs.simplices)
    # the same tetrahedra in another order: compare the neighbour pairs through the corner sets
    key = {tuple(sorted(t)): k for k, t in enumerate(theirs.simplices.tolist())}
    perm = np.array([key[tuple(sorted(t))] for t in ours.simplices.tolist()])
    mapped = {tuple(sorted((int(perm[a]), int(perm[b])))) for a, b in _pairs(ours.neighbors)}
    assert mapped == _pairs(theirs.neighbors)
    # each neighbour lies across the face opposite its corner: it shares the other three
    for t in range(0, len(ours.simplices), 97):
        for k in range(4):
            n = ours.neighbors[t, k]
            if n >= 0:
                assert set(ours.simplices[t]) - {ours.simplices[t, k]} <= set(ours.simplices[n])
                assert ours.simplices[t, k] not in set(ours.simplices[n])


def test_the_tetrahedra_and_their_neighbours_are_qhulls_on_points_in_general_position():
    _same_as_qhull(np.random.default_rng(4).random((3000, 3)))


@needs_real("cardiopinns_aortic-arch-4dflow_capped.stl")
def test_the_tetrahedra_of_a_real_surface_are_qhulls():
    """10,150 vertices of a segmented arch: every tetrahedron as qhull makes it (84k)."""
    V, F = vesselgp.read_mesh(REAL / "cardiopinns_aortic-arch-4dflow_capped.stl")[:2]
    _same_as_qhull(V[np.unique(F)])


def _with_singular_values(s, n=400, seed=2):
    """n points whose centred coordinates have exactly the singular values ``s``."""
    X = np.random.default_rng(seed).standard_normal((n, 3))
    X -= X.mean(axis=0)
    U, _, Vt = np.linalg.svd(X, full_matrices=False)
    return 5.0 + (U * np.asarray(s)) @ Vt


def test_points_that_span_a_volume_are_tessellated_and_flat_ones_refused_at_the_edge():
    """MEDIAL_FLAT_POINTS is the least over the largest singular value of the centred points: 1.05x it
    is tessellated (every point kept), 0.95x it is refused; so are three points, and four are one tetrahedron."""
    f = tol.MEDIAL_FLAT_POINTS
    P = _with_singular_values([1.0, 0.7, 1.05 * f])
    tri = _delaunay(P)
    assert len(tri.simplices) and len(np.unique(tri.simplices)) == len(P)
    with pytest.raises(NotTubularError, match="span no volume"):
        _delaunay(_with_singular_values([1.0, 0.7, 0.95 * f]))
    with pytest.raises(NotTubularError, match="span no volume"):
        _delaunay(np.eye(3))
    tet = np.vstack([np.zeros(3), np.eye(3)])
    assert _faces(_delaunay(tet).simplices) == {(0, 1, 2, 3)}


def test_a_repeated_point_is_refused_not_renumbered():
    """TetGen drops a repeated point and renumbers the rest; the caller keeps each place once, and a
    repeat that reaches the tessellation is an error, not tetrahedra on the wrong points."""
    P = np.random.default_rng(1).random((50, 3))
    with pytest.raises(NotTubularError, match="51 vertices kept 50 of them"):
        _delaunay(np.vstack([P[:10], P[3:4], P[10:]]))


def test_circumcentres_are_equidistant_from_the_corners_and_a_flat_tetrahedron_has_none():
    from vesselgp.centerlines import _circumspheres

    P = np.random.default_rng(7).random((200, 3)) * 10.0
    tri = _delaunay(P)
    c, R = _circumspheres(P, tri.simplices)
    d = np.linalg.norm(P[tri.simplices] - c[:, None], axis=2)
    np.testing.assert_allclose(d, R[:, None] * np.ones(4), rtol=1e-9)
    flat = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    assert np.isinf(_circumspheres(flat, np.array([[0, 1, 2, 3]]))[1][0])
