"""Bridge two vessels' end rings into one mesh: :func:`stitch`."""
from __future__ import annotations

import logging

import numpy as np

from .. import tolerances as tol
from .._validate import as_mesh
from ..errors import EndsError
from ._geometry import vector_area
from .topology import MeshTopology

__all__ = ["stitch"]

log = logging.getLogger(__name__)


def _ordered_loop(F, n, ids, name):
    """The boundary loop of ``F`` (``n`` vertices) made of ``ids``, (k,) int64.

    Ordered along the faces' boundary half-edges, as every loop of
    :attr:`MeshTopology.boundary_loops` is: ``(loop[i], loop[i + 1])`` is a
    directed edge of a face.
    """
    want = np.unique(np.asarray(ids, np.int64).reshape(-1))
    for lp in MeshTopology(F, n).boundary_loops:
        if np.array_equal(np.unique(lp), want):
            return lp
    raise EndsError(f"{name} ids are not one boundary loop of their mesh; give the ids of an open end ring")


def _loop_normal(P, name):
    """Unit normal (3,) float64 of the closed loop ``P`` (k, 3), from its vector area.

    Raises
    ------
    EndsError
        The loop encloses no area (``tolerances.DEGENERATE_AREA`` times its
        perimeter squared).
    """
    a = vector_area(P)
    per = float(np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1).sum())
    size = float(np.linalg.norm(a))
    if not size > tol.DEGENERATE_AREA * per**2:
        raise EndsError(f"{name} ring encloses no area (its vertices coincide or are collinear); "
                        "give the ids of an open end ring")
    return a / size


def _arc_param(P):
    """Normalised arc length (k,) float64 at each vertex of the closed polyline ``P`` (k, 3), from 0."""
    seg = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)
    c = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
    return c / seg.sum()


def stitch(V, F, moving_loop_ids, other_V, other_F, other_loop_ids):
    """Bridge the joined end ring to the other vessel's end ring: one mesh for export.

    Both loops are parameterised by normalised arc length from aligned starts
    (the other loop's start is the vertex at the angle, about the moving loop's
    axis, closest to the moving loop's first vertex) and zipped into a triangle
    strip that advances on whichever loop is behind, so loops of different
    vertex counts are joined without new vertices or T-junctions. The strip is
    oriented consistently with ``F``; ``other_F`` is flipped if its
    orientation disagrees.

    Parameters
    ----------
    V : (n, 3) float64
        Deformed vessel (e.g. :attr:`JoinResult.V`).
    F : (m, 3) int64
    moving_loop_ids : (q,) int
        Its joined end ring (a boundary loop of ``F``).
    other_V : (n2, 3) float64
    other_F : (m2, 3) int64
    other_loop_ids : (r,) int
        The other vessel's end ring (a boundary loop of ``other_F``).

    Returns
    -------
    V : (n + n2, 3) float64
    F : (m + m2 + q + r, 3) int64
        ``F``, then ``other_F`` (offset by n), then the strip.

    Raises
    ------
    EndsError
        When the ids are not boundary loops, or a loop encloses no area.
    InvalidMeshError
        A mesh has non-manifold edges or inconsistently oriented faces (its
        boundary loops are undefined; see :attr:`MeshTopology.boundary_loops`).

    Examples
    --------
    >>> from vesselgp.synthetic import synthetic_vessel
    >>> a = synthetic_vessel("straight", n_around=8, remesh=False)
    >>> b = synthetic_vessel([[0, 0, 31], [0, 0, 41], [0, 0, 51], [0, 0, 61]], n_around=12, remesh=False)
    >>> Vj, Fj = stitch(a.V, a.F, np.arange(len(a.V) - 8, len(a.V)), b.V, b.F, np.arange(12))
    >>> len(Fj) == len(a.F) + len(b.F) + 20, len(MeshTopology.from_faces(Fj).boundary_loops)
    (True, 2)
    """
    V, F = as_mesh(V, F)
    W, G = as_mesh(other_V, other_F)
    G = G.copy()
    A = _ordered_loop(F, len(V), moving_loop_ids, "moving_loop_ids")
    B = _ordered_loop(G, len(W), other_loop_ids, "other_loop_ids")
    PA, PB = V[A], W[B]
    ca = PA.mean(axis=0)
    nA = _loop_normal(PA, "moving_loop_ids")
    nB = _loop_normal(PB, "other_loop_ids")
    # a consistently oriented joined tube has the two boundary loops turning opposite ways about the axis
    if nB @ nA > 0:
        log.warning("other_F is oriented opposite to F; flipping it for a consistent joined mesh")
        G = G[:, ::-1].copy()
        B = B[::-1]
        PB = W[B]
    B = B[::-1]  # traverse B in A's rotational sense
    PB = W[B]
    e1 = PA[0] - ca
    e1 -= (e1 @ nA) * nA
    if not np.linalg.norm(e1) > 0:
        raise EndsError("moving_loop_ids ring starts at its own centre; it is not the ring of a tube's end")
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(nA, e1)
    dB = PB - ca
    angB = np.arctan2(dB @ e2, dB @ e1)
    k = int(np.argmin(np.abs(angB)))
    B = np.roll(B, -k)
    PB = W[B]
    ta, tb = _arc_param(PA), _arc_param(PB)
    na, nb = len(A), len(B)
    ia = ib = 0
    tri = []
    off = len(V)
    while ia < na or ib < nb:
        ta_next = ta[ia + 1] if ia + 1 < na else 1.0
        tb_next = tb[ib + 1] if ib + 1 < nb else 1.0
        a, a1 = A[ia % na], A[(ia + 1) % na]
        b, b1 = B[ib % nb] + off, B[(ib + 1) % nb] + off
        if ib >= nb or (ia < na and ta_next <= tb_next):
            tri.append((a1, a, b))  # uses A's edge reversed
            ia += 1
        else:
            tri.append((a, b, b1))
            ib += 1
    S = np.array(tri, np.int64)
    return np.concatenate([V, W]), np.concatenate([F, G + off, S])
