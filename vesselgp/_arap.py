"""libigl's spokes-and-rims ARAP, assembled from libigl's pieces with whole-array sparse constructors.

``igl.arap_precomputation`` builds its covariance-scatter and right-hand-side
matrices entry by entry (``arap_linear_block``): at 31k vertices that is 0.4 of
its 0.55 s, beside 0.17 s for the factorisation itself. :class:`ArapSolver`
builds the same two matrices from ``igl.cotmatrix_entries`` in a few array
operations and keeps libigl's own local step (``igl.fit_rotations``, single
precision after libigl's normalisation) and global step
(``igl.min_quad_with_fixed``), so each iteration is libigl's ``arap_solve``
iteration (tests/test_deform.py compares the two to 1e-9 of the mesh size).

The energy (Chao et al. 2010, libigl ``ARAP_ENERGY_TYPE_SPOKES_AND_RIMS``, the
default for triangles in 3-D) is

    E(X, R) = 1/3 sum_f sum_{e in f} c_fe sum_{k in f} |(x_i - x_j) - R_k (v_i - v_j)|^2

over the edges ``e = (i, j)`` of each face with weights ``c_fe`` = half the
cotangent of the opposite angle. With ``h_fs = sum_e c_fe (v_i - v_j)
(delta(s = i) - delta(s = j))``, the weighted rest edges leaving corner ``s``:

* local step: ``R_k`` is the rotation closest to ``S_k = sum_{f ni k} sum_s
  h_fs x_s^T``, i.e. ``S = M X`` with ``M[a n + k, v] = sum_{f ni k, v} h_fv[a]``;
* global step: ``-L X = K R`` with ``K[i, 3k + c] = M[c n + k, i] / 3`` and the
  handles fixed (``L`` the cotangent Laplacian).

``M`` is kept as the product of two matrices with three entries per row or
column (per-face covariances, then the sum over each vertex's faces), which are
written straight into compressed form.
"""
from __future__ import annotations

import igl
import numpy as np
import scipy.sparse as sp

__all__ = ["ArapSolver"]


class ArapSolver:
    """Precomputed ARAP (spokes and rims) of a triangle mesh with fixed handles.

    Parameters
    ----------
    V : (n, 3) float64
        Rest vertices.
    F : (m, 3) int64
        Triangles.
    b : (h,) int64
        Handle vertex ids (their positions are given to :meth:`solve`).
    """

    def __init__(self, V, F, b):
        n, m = len(V), len(F)
        self.b = np.asarray(b, dtype=np.int64)
        C = igl.cotmatrix_entries(V, F)  # (m, 3): half cotangents; column e is the edge (e+1, e+2)
        w = C[:, :, None] * (V[F[:, [1, 2, 0]]] - V[F[:, [2, 0, 1]]])  # (m, 3 edges, 3) weighted rest edges
        # corner s starts edge s+2 (s = i) and ends edge s+1 (s = j)
        h = w[:, [2, 0, 1]] - w[:, [1, 2, 0]]  # (m, 3 corners, 3)
        # M = G H: H[3 f + a, v] = h[f, slot v, a] (per-face covariance rows, 3 entries each) and G sums
        # face f's rows into those of its corners, G[a n + k, 3 f + a] = 1; both built straight into CSR
        # and CSC (no sort). K R is then (M^T Y) / 3 with Y[c n + k] = R_k[:, c].
        cols = np.repeat(F, 3, axis=0).ravel()  # row 3 f + a lists F[f, 0..2]
        vals = h.transpose(0, 2, 1).ravel()  # h[f, s, a] at row 3 f + a, slot s
        step = 3 * np.arange(3 * m + 1)
        self.H = sp.csr_matrix((vals, cols, step), shape=(3 * m, n))
        grows = (np.arange(3)[None, :, None] * n + F[:, None, :]).ravel()  # column 3 f + a: a n + F[f, 0..2]
        self.G = sp.csc_matrix((np.ones(9 * m), grows, step), shape=(3 * n, 3 * m))
        self.n = n
        self._eq = np.zeros((0, 3))
        self._mqwf = igl.min_quad_with_fixed_data()
        igl.min_quad_with_fixed_precompute((-igl.cotmatrix(V, F)).tocsc(), self.b, sp.csc_matrix((0, n)), True,
                                           self._mqwf)

    def solve(self, X, bc, iterations):
        """``iterations`` local-global ARAP iterations from ``X`` with the handles at ``bc``.

        Parameters
        ----------
        X : (n, 3) float64
            Start positions (not modified).
        bc : (h, 3) float64
            Handle positions.
        iterations : int

        Returns
        -------
        (n, 3) float64
        """
        X = np.array(X, dtype=np.float64, order="C")
        bc = np.ascontiguousarray(bc, dtype=np.float64)
        for _ in range(int(iterations)):
            X[self.b] = bc
            S = self.G @ (self.H @ X)  # stacked covariances, S[a n + k, c] = S_k[a, c] (fit_rotations' layout)
            scale = np.abs(S).max()
            if scale > 0.0:  # libigl's normalisation for its single-precision SVD
                S /= scale
            R = igl.fit_rotations(S, True)  # (3, 3n): R_k in columns 3k .. 3k+2
            Y = R.reshape(3, self.n, 3).transpose(2, 1, 0).reshape(3 * self.n, 3)  # Y[c n + k] = R_k[:, c]
            B = self.H.T @ (self.G.T @ Y)
            X = igl.min_quad_with_fixed_solve(self._mqwf, B / -3.0, bc, self._eq)
        return X
