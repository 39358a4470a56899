"""The rays' face grid of the inside check looks faces up by the queries' cells (issue #47), exactly.

Sorting every face's cells and counting every edge for closedness was 2 s of a 5 s fit of a 1M-vertex tube to
check 300 axis points; the grid now lists each face's cells unsorted and finds those of the queries' cells, and a
coherent mesh (its topology known) is closed once its loops are fanned. Truth: brute force over every face and
libigl's direct winding-number sum, never the grid itself.
"""
from __future__ import annotations

import igl
import numpy as np
import pytest

from vesselgp.inside import _RAY_FRAME, SurfaceWinding, _ColumnGrid, ray_winding
from vesselgp.mesh import mesh_topology
from vesselgp.mesh._geometry import closed_by_fans
from vesselgp.synthetic import synthetic_vessel


@pytest.fixture(scope="module")
def tube():
    ves = synthetic_vessel("helix", radius=1.0, n_around=16)
    topo = mesh_topology(ves.F, len(ves.V))
    Vc, Fc = closed_by_fans(ves.V, ves.F, topo.boundary_loops)
    rng = np.random.default_rng(3)
    lo, hi = ves.V.min(0), ves.V.max(0)
    Q = np.vstack([lo + (hi - lo) * rng.random((400, 3)), ves.truth.centers[::7]])
    return ves, Vc, Fc, Q


def test_pairs_are_every_face_whose_cells_hold_a_query(tube):
    """Every (face, query) pair whose query's cell lies in the face's rectangle of cells, found by brute force over
    all faces, and no other."""
    _, Vc, Fc, Q = tube
    g = _ColumnGrid(Vc, Fc)
    Qp = (Q @ _RAY_FRAME.T)[:, 1:]
    pf, pq = g.pairs(Qp)
    W = Vc @ _RAY_FRAME.T
    T = W[Fc][:, :, 1:]
    lo, hi = g._cell(T.min(axis=1)), g._cell(T.max(axis=1))
    c = g._cell(Qp)
    inside = np.all((c[None] >= lo[:, None]) & (c[None] <= hi[:, None]), axis=2)  # (faces, queries)
    want = set(zip(*np.nonzero(inside)))
    assert set(zip(pf.tolist(), pq.tolist())) == {(int(f), int(q)) for f, q in want}
    assert len(pf) == len(want)  # no pair twice


def test_winding_numbers_are_libigls_direct_sum(tube):
    """The ray counts on the fanned helix equal libigl's direct sum at every query (inside 1, outside 0)."""
    _, Vc, Fc, Q = tube
    w = ray_winding(Vc, Fc, Q, _ColumnGrid(Vc, Fc, True))
    ref = np.asarray(igl.winding_number(Vc, Fc, Q), np.float64)
    assert np.array_equal(w, np.round(ref)) and np.abs(ref - np.round(ref)).max() < 1e-6
    assert w.min() == 0 and w.max() == 1


def test_a_coherent_mesh_is_closed_once_fanned_and_an_incoherent_one_is_counted(tube):
    """A coherent mesh (its topology's word) needs no edge count: the fanned surface is closed, as the count says.
    One face turned over: the topology is not coherent, the count runs and finds the surface open, and the winding
    numbers are libigl's direct sum."""
    ves, Vc, Fc, Q = tube
    sw = SurfaceWinding(ves.V, ves.F)
    assert sw._closed is True and _ColumnGrid(Vc, Fc).closed
    F = ves.F.copy()
    F[10] = F[10, ::-1]
    topo = mesh_topology(F, len(ves.V))
    assert not topo.is_coherent
    Vc2, Fc2 = closed_by_fans(ves.V, F, ())
    g = _ColumnGrid(Vc2, Fc2, None)
    assert not g.closed
    ref = np.asarray(igl.winding_number(Vc2, Fc2, Q[:50]), np.float64)
    assert np.allclose(ray_winding(Vc2, Fc2, Q[:50], g), ref)
