"""Small vectorised geometric helpers of the mesh stage (no connectivity: see :mod:`.topology`)."""
from __future__ import annotations

import igl
import numpy as np
import scipy.sparse as sp

from .. import tolerances as tol
from .._arrays import chunks


def face_vectors(V, F):
    """Unnormalised face normals (twice the area vectors): (m, 3) float64."""
    return np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])


def voronoi_areas(V, F):
    """Voronoi (mixed) area of each vertex: (n,) float64, libigl's Voronoi mass matrix diagonal.

    libigl's ``massmatrix_intrinsic`` (``MASSMATRIX_TYPE_VORONOI``, Meyer et al. 2003)
    evaluated in numpy: each corner gets its share of the face cut at the circumcentre
    (barycentric weights ``l_k cos_k``, normalised); in an obtuse face the obtuse corner
    gets half of its area and the others a quarter each. The corner shares are computed
    ``tolerances.AREA_FACE_CHUNK`` faces at a time (temporaries bounded, issue #16's
    peak memory) and summed per vertex once. ``tests/test_mesh.py`` checks the result
    against ``igl.massmatrix`` on the whole mesh. As there, a face with a zero-length edge
    gives its corners NaN (a documented case: callers pass faces with an area, as
    :func:`vesselgp.fit.checked_mesh` returns them).
    """
    m = len(F)
    q = np.empty((3, m))
    with np.errstate(divide="ignore", invalid="ignore"):  # NaN for faces without area, as libigl
        for c in chunks(m, tol.AREA_FACE_CHUNK):
            q[:, c] = _corner_voronoi(V, F[c])
    return np.bincount(F.T.ravel(), weights=q.ravel(), minlength=len(V))


def _corner_voronoi(V, F):
    """Each corner's Voronoi share of its face (libigl's Voronoi mass matrix entries): (3, m) float64."""
    P = [np.ascontiguousarray(V.take(F[:, k], axis=0).T) for k in range(3)]  # component-major corners
    e = [P[2] - P[1], P[0] - P[2], P[1] - P[0]]  # the edge opposite each corner
    sq = [(x * x).sum(axis=0) for x in e]
    cr = [e[2][1] * e[1][2] - e[2][2] * e[1][1], e[2][2] * e[1][0] - e[2][0] * e[1][2],
          e[2][0] * e[1][1] - e[2][1] * e[1][0]]
    dblA = np.sqrt(cr[0] ** 2 + cr[1] ** 2 + cr[2] ** 2)
    # law of cosines: 2 |a| |b| cos(corner k) = |a|^2 + |b|^2 - |opposite|^2
    c = [sq[1] + sq[2] - sq[0], sq[2] + sq[0] - sq[1], sq[0] + sq[1] - sq[2]]
    ln = [np.sqrt(x) for x in sq]
    bary = [c[0] * ln[0] / (ln[1] * ln[2]), c[1] * ln[1] / (ln[2] * ln[0]), c[2] * ln[2] / (ln[0] * ln[1])]
    half = 0.5 * dblA / (bary[0] + bary[1] + bary[2])
    part = [b * half for b in bary]
    quads = np.stack([0.5 * (part[1] + part[2]), 0.5 * (part[2] + part[0]), 0.5 * (part[0] + part[1])])
    for k in range(3):  # an obtuse corner k: half the face's area to it, a quarter to each other (of dblA: 1/4, 1/8)
        obtuse = c[k] < 0
        share = np.full((3, 1), 0.125)
        share[k] = 0.25
        quads[:, obtuse] = share * dblA[obtuse]
    return quads


def cotangent_operators(V, F):
    """libigl's ``cotmatrix`` and ``grad`` of ``V, F`` and the face areas, evaluated in numpy.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        Faces with an area (as :func:`vesselgp.fit.checked_mesh` returns them).

    Returns
    -------
    L : (n, n) scipy.sparse.csc_matrix
        The cotangent Laplacian, ``L_ij = (cot alpha_ij + cot beta_ij) / 2`` off the diagonal
        and minus the row sum on it (negative semi-definite, as ``igl.cotmatrix``).
    G : (3 m, n) scipy.sparse.csr_matrix
        The per-face gradient of a vertex function, component ``d`` of face ``f`` in row
        ``d m + f`` (as ``igl.grad``): the gradient of corner ``k``'s hat function is
        ``N x e_k / (2 A)``, ``e_k`` the edge opposite it, counter-clockwise about the unit
        normal ``N``.
    area : (m,) float64
        The face areas.

    Both matrices agree with libigl's to 1e-14 of their largest entry
    (``tests/test_geodesic.py``); the heat method's set-up needs them both, and this takes
    about half of the two libigl calls' time (16 against 31 ms on a 27k tree), sharing the
    edge vectors and the areas.
    """
    n, m = len(V), len(F)
    P = [np.ascontiguousarray(V.take(F[:, k], axis=0).T) for k in range(3)]  # component-major corners
    e = [P[2] - P[1], P[0] - P[2], P[1] - P[0]]  # the edge opposite each corner
    cr = np.stack([e[1][1] * e[2][2] - e[1][2] * e[2][1], e[1][2] * e[2][0] - e[1][0] * e[2][2],
                   e[1][0] * e[2][1] - e[1][1] * e[2][0]])  # e_1 x e_2 = 2 A N
    dblA = np.sqrt((cr * cr).sum(axis=0))
    N = cr / dblA
    B = np.empty((3, m, 3))  # (component, face, corner)
    for k, ek in enumerate(e):
        B[0, :, k] = (N[1] * ek[2] - N[2] * ek[1]) / dblA
        B[1, :, k] = (N[2] * ek[0] - N[0] * ek[2]) / dblA
        B[2, :, k] = (N[0] * ek[1] - N[1] * ek[0]) / dblA
    G = sp.csr_matrix((B.ravel(), np.tile(F.ravel(), 3), np.arange(0, 9 * m + 1, 3)), shape=(3 * m, n))
    # cot of corner k = -(e_{k+1} . e_{k+2}) / (2 A), on the edge opposite k (vertices k+1, k+2)
    w = np.concatenate([-0.5 * (e[(k + 1) % 3] * e[(k + 2) % 3]).sum(axis=0) / dblA for k in range(3)])
    i = np.concatenate([F[:, (k + 1) % 3] for k in range(3)])
    j = np.concatenate([F[:, (k + 2) % 3] for k in range(3)])
    diag = -np.bincount(i, w, n) - np.bincount(j, w, n)
    ids = np.arange(n)
    L = sp.csc_matrix((np.concatenate([w, w, diag]), (np.concatenate([i, j, ids]), np.concatenate([j, i, ids]))),
                      shape=(n, n))
    return L, G, 0.5 * dblA


def median_edge(V, F):
    """Median length of the face corners' edges (float).

    Over face corners, interior edges count twice and boundary edges once;
    on a vessel mesh the boundary edges are too few to move the median.
    """
    return float(np.median(igl.edge_lengths(V, F)))


def signed_volume(V, F):
    """Signed volume enclosed by a closed surface (float; positive when oriented outward)."""
    return float(np.einsum("ij,ij->", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])) / 6.0)


def closed_by_fans(V, F, loops):
    """``V, F`` with each boundary loop of three or more vertices closed by a fan about its mean.

    The loops follow the faces (a -> b is a half-edge of ``F``), so the fan's faces run b -> a and
    keep a coherent orientation coherent. Returns (n + l, 3) float64 and (m + sum of loop sizes, 3)
    int64: a closed surface for a winding number or a volume.
    """
    Vs, Fs, n = [V], [F], len(V)
    for lp in loops:
        lp = np.asarray(lp, np.int64)
        if len(lp) < 3:
            continue
        Vs.append(V[lp].mean(axis=0)[None])
        Fs.append(np.stack([np.roll(lp, -1), lp, np.full(len(lp), n)], axis=1))
        n += 1
    return np.vstack(Vs), np.vstack(Fs)


def vector_area(P):
    """Vector area of a closed polygon (rows of P in order): (3,) float64."""
    c = P.mean(0)
    return 0.5 * np.cross(P - c, np.roll(P, -1, axis=0) - c).sum(0)


def loop_centroid(P):
    """Centroid of a closed polyline (k, 3) weighted by the length around each vertex: (3,) float64."""
    seg = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)
    w = 0.5 * (seg + np.roll(seg, 1))
    return (w[:, None] * P).sum(0) / w.sum()
