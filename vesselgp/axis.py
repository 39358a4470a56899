"""The axis machinery shared by the fit (Eq. 1-5) and the torsion measurement (Eq. 6-8).

* :class:`Axis`: an axis through node points, resampled densely at equal arc
  length with its rotation-minimizing frame (double reflection, paper
  Section 1), its curvature vector, linear interpolation of points and
  frames, and the closest-point projection of vertices (``s_i``).
* :func:`hat_matrix`, :func:`difference_matrix`: piecewise-linear (hat)
  functions of ``s`` on uniform nodes and their difference operators: the
  discretisation of Eq. 2-5.
* :func:`circle_fit_correction`: one linear solve of the area-weighted circle
  fit that replaces Eq. 1's centroid (no bend bias), with Eq. 2's ``lambda``
  regulariser on the second difference of the axis.
* :func:`local_coords`: coordinates of vertices in the frame at their ``s``.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.linalg.lapack import dpbsv as _pbsv
from scipy.spatial import cKDTree

from . import tolerances as tol
from ._arrays import chunks
from .curves import chord_length, resample_arclength, rotation_minimizing_frames
from .errors import NotTubularError
from .rotations import perpendicular

__all__ = ["Axis", "AxisStack", "interp_frames", "hat", "hat_matrix", "difference_matrix", "circle_fit_correction",
           "circle_fit_sums", "circle_fit_solve", "checked_solution", "solve_banded_spd", "banded_spd_or_none",
           "local_coords"]


def _segment_table(dp, dfr, kvec=None):
    """Per-segment table, one row per component: [p, dp, T, dT, (k,) U, dU], (c, M - 1).

    Rows 0-11 hold points and tangents, 12-14 the curvature vector when given,
    then U and its difference. Component-major: a gather of the segments of n
    parameters is (c, n) with every row contiguous, and the interpolation runs
    on whole rows (numpy loops over an (n, 3) array three elements at a time
    when its rows are strided: about 3x slower at 100k rows).
    """
    T, U = dfr[:, 0], dfr[:, 1]
    pieces = [dp[:-1], np.diff(dp, axis=0), T[:-1], np.diff(T, axis=0)]
    if kvec is not None:
        pieces.append(0.5 * (kvec[:-1] + kvec[1:]))
    pieces += [U[:-1], np.diff(U, axis=0)]
    table = np.empty((3 * len(pieces), len(dp) - 1))
    for r, piece in enumerate(pieces):  # written row block by row block: no hstack and transposed copy
        table[3 * r:3 * r + 3] = piece.T
    return table


def _dot3(a, b):
    """Per-column dot product of two (3, n) arrays: (n,)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _interp(table, s, frames=True, m1=None, segoff=None):
    """Linear interpolation of a :func:`_segment_table` at ``s`` (clipped to [0, 1]), component-major.

    Returns ``pts, T, k`` ((3, n) each; ``k`` None without curvature rows) and, with
    ``frames``, ``U, W`` too: T unit, U re-orthonormalised against it, W = T x U.

    ``table`` may be several axes' tables side by side (:class:`AxisStack`): then ``m1``
    (each row's axis's segment count) and ``segoff`` (its first column) are per-row arrays;
    without them the table is one axis's.
    """
    s = np.clip(np.asarray(s, float), 0.0, 1.0)
    if m1 is None:
        m1 = table.shape[1]
    x = s * m1
    j = np.minimum(x.astype(np.int64), m1 - 1)
    t = x - j
    u0 = table.shape[0] - 6  # U rows start here (after the optional curvature)
    # without frames only the point, tangent and curvature rows are gathered
    G = (table if frames else table[:u0]).take(j if segoff is None else j + segoff, axis=1)
    pts = G[0:3] + t * G[3:6]
    T = G[6:9] + t * G[9:12]
    T /= np.sqrt(_dot3(T, T))
    k = G[12:15] if u0 > 12 else None
    if not frames:
        return pts, T, k
    U = G[u0 : u0 + 3] + t * G[u0 + 3 : u0 + 6]
    U -= _dot3(U, T) * T
    U /= np.sqrt(_dot3(U, U))
    W = np.empty_like(U)
    W[0] = T[1] * U[2] - T[2] * U[1]
    W[1] = T[2] * U[0] - T[0] * U[2]
    W[2] = T[0] * U[1] - T[1] * U[0]
    return pts, T, k, U, W


def interp_frames(ds, dp, dfr, s, frames=True, table=None):
    """Linear interpolation of dense axis samples and frames at ``s`` (re-orthonormalised).

    ``ds`` must be uniform (equal arc-length samples). With ``frames=False``
    only the points, unit tangents and (when the table has them) curvature vectors
    are returned. ``table`` is :func:`_segment_table` of ``dp, dfr``.

    Returns ``pts`` (n, 3) and ``frames`` (n, 3, 3) with rows T, U, V; or, with
    ``frames=False``, ``pts, T, k`` ((n, 3) each, ``k`` None without curvature).
    """
    if table is None:
        table = _segment_table(dp, dfr)
    if len(ds) != table.shape[1] + 1:
        raise ValueError(f"interp_frames: {len(ds)} samples but a table of {table.shape[1]} segments")
    if not frames:
        pts, T, k = _interp(table, s, frames=False)
        return pts.T.copy(), T.T.copy(), (None if k is None else k.T.copy())
    pts, T, _, U, W = _interp(table, s)
    fr = np.empty((pts.shape[1], 3, 3))
    fr[:, 0], fr[:, 1], fr[:, 2] = T.T, U.T, W.T
    return pts.T.copy(), fr


class Axis:
    """An axis through node points, resampled densely at equal arc length with its RMF.

    Parameters
    ----------
    nodes : (K, 3) float64
        Axis nodes; a cubic spline through them (over chord length) is the axis.
    initial_normal : (3,) float64, optional
        U at ``s = 0``. Default: towards the way the axis bends (rigid-covariant);
        a fixed coordinate direction for a straight axis (documented degenerate case).
    samples_per_node : int, optional
        Dense samples per node spacing (default ``tolerances.GC_SAMPLES_PER_NODE``).
    carry : Axis, optional
        An axis with as many dense samples (the fixed point's previous iteration; ignored
        when the counts differ): its U
        at each sample, projected onto the new normal plane, is the frame instead of the
        RMF. Any smooth frame serves the inner iterations of the fit (Eq. 3 is solved in
        it, not about it), and the projection costs a few vector operations where the
        double reflection costs a prefix product; the fit's final axis always has its RMF.
        Where the tangent has turned by more than ``tolerances.FRAME_CARRY_MAX_TURN``
        since, the RMF is computed after all.

    Attributes
    ----------
    s : (M,) float64
        Uniform normalised arc length of the dense samples.
    points : (M, 3) float64
    frames : (M, 3, 3) float64
        RMF, rows ``T, U, V`` (double reflection, paper Section 1); the carried
        frame instead when ``carry`` is given and usable.
    kvec : (M, 3) float64
        Curvature vector ``dT/ds`` per mesh unit.
    length : float
        Arc length, mesh units.

    Raises
    ------
    NotTubularError
        When the nodes collapse to a point.
    """

    def __init__(self, nodes, initial_normal=None, samples_per_node=None, carry=None):
        spn = tol.GC_SAMPLES_PER_NODE if samples_per_node is None else int(samples_per_node)
        M = spn * (len(nodes) - 1) + 1
        over = -(-tol.GC_ARCLENGTH_CHORDS_PER_NODE * (len(nodes) - 1) // M)  # ceil
        self.points, T, self.length = resample_arclength(nodes, M, with_tangents=True, oversample=max(over, 1))
        self.s = np.linspace(0.0, 1.0, M)
        self.frames = _carried_frames(carry, T) if carry is not None and len(carry.s) == M else None
        if self.frames is None:
            if initial_normal is None:
                initial_normal = _default_normal(self.points, T[0])
            T, U, V = rotation_minimizing_frames(self.points, T, initial_normal=initial_normal)
            self.frames = np.stack([T, U, V], axis=1)
        T = self.frames[:, 0]
        # curvature vector dT/ds (per mesh unit) at the dense samples
        self.kvec = _uniform_gradient(T, self.length / (M - 1))
        self.table = _segment_table(self.points, self.frames, self.kvec)
        self.kvec_t = np.ascontiguousarray(self.kvec.T)
        self._tree = None
        self._per_node = spn

    def stretch(self, s, d):
        """Jacobian 1 - k(s) . d of the tube map at offset ``d`` from the axis point at ``s``.

        The wall's area per unit axis length and unit angle grows by this
        factor towards the outside of a bend; dividing the vertex areas by it
        gives every direction about the axis equal weight (removes the bend bias
        of Eq. 1).
        """
        return 1.0 - np.einsum("ij,ij->i", self.kvec[self.nearest_sample(s)], d)

    def nearest_sample(self, s):
        """Index of the dense sample nearest each ``s`` (clipped to the axis), (n,) int64."""
        return _nearest_sample(s, len(self.s) - 1)

    def at(self, s):
        return interp_frames(self.s, self.points, self.frames, s, table=self.table)

    def tangential_offset(self, P, s):
        """Component along the tangent of each row of ``P`` minus its axis point at ``s``: (n,) float64.

        Zero at a closest point (the foot); rows are handled ``tolerances.AXIS_ROW_CHUNK`` at a time.
        """
        out = np.empty(len(P))
        for rows in _row_chunks(len(P)):
            pts, T, _ = _interp(self.table, s[rows], frames=False)
            out[rows] = _dot3(np.ascontiguousarray(P[rows].T) - pts, T)
        return out

    def node_frames(self):
        """Frames at the nodes, ``s = k / (K - 1)`` ((K, 3, 3), rows T, U, V; a read-only view).

        The nodes are dense samples (every ``samples_per_node``-th), so this is what
        ``at(np.linspace(0, 1, K))[1]`` interpolates there, without interpolating.
        """
        fr = self.frames[::self._per_node]
        fr.flags.writeable = False
        return fr

    def _nearest_in_window(self, P, s_prev, window):
        """Parameter of the closest dense sample within ``window`` of ``s_prev`` (exhaustive).

        For the few points whose k nearest samples all lie outside their window
        (a vessel folded close to itself): every sample in the window is tried.
        """
        out = np.empty(len(P))
        chunk = max(1, tol.PROJECTION_CHUNK // len(self.s))
        for a in range(0, len(P), chunk):
            Pc, sc = P[a:a + chunk], s_prev[a:a + chunk]
            d2 = np.einsum("ij,ij->i", Pc, Pc)[:, None] - 2 * Pc @ self.points.T \
                + np.einsum("ij,ij->i", self.points, self.points)[None]
            d2[np.abs(self.s[None] - sc[:, None]) > window] = np.inf
            out[a:a + chunk] = self.s[np.argmin(d2, axis=1)]
        # a window always holds the sample nearest s_prev: it is never empty
        return out

    def project(self, P, s_prev, window=None, newton_steps=None):
        """Closest-point parameter of each row of ``P`` near its previous parameter.

        With a ``window``, candidates are the dense samples nearest to each
        point (k-d tree); among those within ``window`` of ``s_prev`` the
        closest wins, which keeps a vertex on its own stretch of axis where the
        vessel comes close to itself. Without one, ``s_prev`` is trusted as the
        start (the axis moved little since). Newton steps (``newton_steps``, default
        ``tolerances.GC_NEWTON_STEPS``) then refine ``s`` on the interpolated axis.
        Rows are handled ``tolerances.AXIS_ROW_CHUNK`` at a time (bounded temporaries).

        Returns ``s`` (unclipped, may leave [0, 1] beyond the ends).
        """
        steps = tol.GC_NEWTON_STEPS if newton_steps is None else newton_steps
        s_prev = np.asarray(s_prev, float)
        if window is not None and self._tree is None:
            self._tree = cKDTree(self.points)
        out = np.empty(len(P))
        for rows in _row_chunks(len(P)):
            out[rows] = self._project_rows(P[rows], s_prev[rows], window, steps)
        return out

    def _project_rows(self, P, s_prev, window, steps):
        """:meth:`project` of one chunk of rows."""
        if window is None:
            s = s_prev.copy()
        else:
            # the nearest sample wins when it lies in the window (nearly every point of a tube); only
            # the rest query their k nearest, then every sample of the window (k = 1 costs 0.6x k = 8)
            s = self.s[self._tree.query(P, k=1)[1]]
            far = np.flatnonzero(np.abs(s - s_prev) > window)
            if far.size:
                s[far] = self._nearest_candidates(P[far], s_prev[far], window)
        return _newton(self.table, np.ascontiguousarray(P.T) if steps else None, s, self.length, steps)

    def _nearest_candidates(self, P, s_prev, window):
        """Parameter of the nearest of the ``k`` nearest dense samples within ``window`` of ``s_prev``,
        or of the whole window (:meth:`_nearest_in_window`) when none of them is in it."""
        kq = min(tol.PROJECTION_CANDIDATES, len(self.s))
        dist, idx = self._tree.query(P, k=kq)
        sc = self.s[idx.reshape(len(P), kq)]
        d = np.where(np.abs(sc - s_prev[:, None]) > window, np.inf, dist.reshape(len(P), kq))
        best = np.argmin(d, axis=1)
        s = sc[np.arange(len(P)), best]
        none = np.flatnonzero(~np.isfinite(d[np.arange(len(P)), best]))
        if none.size:
            s[none] = self._nearest_in_window(P[none], s_prev[none], window)
        return s


def _nearest_sample(s, m1):
    """Index of the sample nearest each ``s`` among ``m1 + 1`` uniform ones on [0, 1] (clipped), int64."""
    return np.clip(np.rint(np.clip(s, 0, 1) * m1).astype(np.int64), 0, m1)


def _newton(table, PT, s, length, steps, m1=None, segoff=None):
    """``steps`` Newton steps of the closest-point parameters ``s`` of the points ``PT`` ((3, n)).

    ``length``, ``m1`` and ``segoff`` are scalars for one axis, per-row arrays for an
    :class:`AxisStack` (see :func:`_interp`).
    """
    for _ in range(steps):
        s = np.clip(s, 0, 1)
        pts, T, k = _interp(table, s, frames=False, m1=m1, segoff=segoff)
        d = PT - pts
        # d/ds of (p - m(s)) . T(s) is -(1 - k . d) times the length
        jac = np.maximum(1.0 - _dot3(k, d), tol.GC_MIN_STRETCH)
        s = s + _dot3(d, T) / (length * jac)
    return s


def _local_rows(table, kvec_t, PT, s, m1=None, segoff=None, smpoff=None):
    """:func:`local_coords` of the points ``PT`` ((3, n)): the three coordinates and the stretch.

    ``m1``, ``segoff`` and ``smpoff`` (first dense sample of each row's axis) as for
    :func:`_newton`.
    """
    pts, T, _, U, W = _interp(table, s, m1=m1, segoff=segoff)
    d = PT - pts
    near = _nearest_sample(s, table.shape[1] if m1 is None else m1)
    near = near if smpoff is None else near + smpoff
    return (_dot3(T, d), _dot3(U, d), _dot3(W, d)), 1.0 - _dot3(kvec_t.take(near, axis=1), d)


class AxisStack:
    """Several axes side by side, each with its own rows of points: one vectorised pass over all.

    The fixed points of a tree's branches run in lock step on one stack
    (:func:`vesselgp.fit.fixed_points`): much of a small branch's iteration is per-call
    overhead, paid once per pass instead of once per branch. The first ``counts[0]`` rows
    belong to ``axes[0]``, the next ``counts[1]`` to ``axes[1]``, and so on; each row gets
    exactly the numbers its own axis's :meth:`Axis.project` (without a window) and
    :func:`local_coords` would give it.

    Parameters
    ----------
    axes : list of Axis
    PT : (3, n) float64
        The points, component-major (rows of ``axes[0]`` first).
    counts : sequence of int
        Rows of each axis.
    """

    def __init__(self, axes, PT, counts):
        self.PT = PT
        if len(axes) == 1:
            a = axes[0]
            self.table, self.kvec_t, self.length = a.table, a.kvec_t, a.length
            self.m1, self.segoff, self.smpoff = len(a.s) - 1, None, None
            return
        M = np.array([len(a.s) for a in axes])
        counts = np.asarray(counts)
        self.table = np.concatenate([a.table for a in axes], axis=1)
        self.kvec_t = np.concatenate([a.kvec_t for a in axes], axis=1)
        self.length = np.repeat([a.length for a in axes], counts)
        self.m1 = np.repeat(M - 1, counts)
        self.segoff = np.repeat(np.concatenate([[0], np.cumsum(M - 1)[:-1]]), counts)
        self.smpoff = np.repeat(np.concatenate([[0], np.cumsum(M)[:-1]]), counts)

    @staticmethod
    def _at(x, rows):
        """Rows ``rows`` of a per-row array; a scalar or None (one axis) as it is."""
        return x if x is None or np.isscalar(x) else x[rows]

    def project(self, s_prev, steps):
        """Newton steps from ``s_prev`` (n,) on each row's axis, as :meth:`Axis.project` without a window."""
        out = np.empty(len(s_prev))
        for rows in _row_chunks(len(s_prev)):
            out[rows] = _newton(self.table, self.PT[:, rows], s_prev[rows].copy(), self._at(self.length, rows),
                                steps, self._at(self.m1, rows), self._at(self.segoff, rows))
        return out

    def local_coords(self, s):
        """:func:`local_coords` of every row on its own axis: (n, 3) and (n,)."""
        local, jac = np.empty((len(s), 3)), np.empty(len(s))
        for rows in _row_chunks(len(s)):
            (local[rows, 0], local[rows, 1], local[rows, 2]), jac[rows] = _local_rows(
                self.table, self.kvec_t, self.PT[:, rows], s[rows], self._at(self.m1, rows),
                self._at(self.segoff, rows), self._at(self.smpoff, rows))
        return local, jac


def _uniform_gradient(X, h):
    """``np.gradient(X, h, axis=0)`` of rows at uniform spacing ``h``: central differences inside,
    one-sided at the ends (first order, numpy's default), (M, c) for (M, c) ``X``."""
    G = np.empty_like(X)
    np.subtract(X[2:], X[:-2], out=G[1:-1])
    G[1:-1] *= 0.5 / h
    G[0] = (X[1] - X[0]) / h
    G[-1] = (X[-1] - X[-2]) / h
    return G


def _row_chunks(n):
    """Slices of at most ``tolerances.AXIS_ROW_CHUNK`` consecutive rows covering ``range(n)``."""
    return chunks(n, tol.AXIS_ROW_CHUNK)


def _carried_frames(carry, T):
    """Frames (M, 3, 3) from ``carry``'s U projected onto the planes normal to ``T``, or None
    where the tangent turned by more than ``tolerances.FRAME_CARRY_MAX_TURN`` (see :class:`Axis`)."""
    U = carry.frames[:, 1]
    U = U - np.einsum("ij,ij->i", U, T)[:, None] * T
    n = np.sqrt(np.einsum("ij,ij->i", U, U))
    if not np.all(n > np.cos(tol.FRAME_CARRY_MAX_TURN)):
        return None
    U /= n[:, None]
    fr = np.empty((len(T), 3, 3))
    fr[:, 0], fr[:, 1] = T, U
    fr[:, 2] = np.cross(T, U)
    return fr


def _default_normal(points, t0):
    """Rigid-covariant choice of U at s = 0: towards the axis point farthest from the
    line through the first point along the first tangent (the way the vessel bends).
    Falls back to a fixed coordinate direction for a straight axis (documented)."""
    d = points - points[0]
    d -= np.outer(d @ t0, t0)
    n = np.linalg.norm(d, axis=1)
    j = int(np.argmax(n))
    scale = chord_length(points)[-1]
    if n[j] > tol.STRAIGHT_AXIS_DEVIATION * scale:
        return d[j] / n[j]
    return perpendicular(t0)


def hat(s, K):
    """Piecewise-linear basis on K uniform nodes over [0, 1]: left index and weight of the right node."""
    x = np.clip(s, 0.0, 1.0) * (K - 1)
    j = np.minimum(np.floor(x).astype(np.int64), K - 2)
    return j, x - j


def hat_matrix(s, K):
    j, t = hat(s, K)
    n = len(s)
    rows = np.repeat(np.arange(n), 2)
    cols = np.stack([j, j + 1], axis=1).ravel()
    vals = np.stack([1 - t, t], axis=1).ravel()
    return sp.csr_matrix((vals, (rows, cols)), shape=(n, K))


def difference_matrix(K, order):
    D = sp.eye(K, format="csr")
    for _ in range(order):
        D = (D[1:] - D[:-1]).tocsr()
    return D


#: Lower-triangle pairs (a >= b) of the six unknowns one residual or one second difference touches.
_PAIR_A, _PAIR_B = np.tril_indices(6)
_PAIR_00, _PAIR_33 = 0, 9  # positions of the pairs (0, 0) and (3, 3) among them


def _segment_sums(j, cols, K):
    """Sums of each weight column into the ``K - 1`` segments ``j``: (K - 1, c).

    One ``bincount`` per column: a single bincount over an (n, c) index table moves c times
    more memory and is slower from about 5k vertices on.
    """
    return np.stack([np.bincount(j, c, minlength=K - 1) for c in cols], axis=1)


def circle_fit_sums(s, local, w, K, rscale, nodeoff=None, total=None, elliptic=None):
    """The data part of :func:`circle_fit_correction`: its 21 products and 6 right-hand sides
    summed per segment, ``S`` (N - 1, 21) and ``R`` (N - 1, 6) with ``N = K``.

    For an :class:`AxisStack`, ``K``, ``rscale`` and ``nodeoff`` (the first node of each
    row's axis) are per-row arrays and ``total`` the stack's node count ``N``: axis ``b``'s
    rows are ``nodeoff_b : nodeoff_b + K_b - 1``, the same sums it would have alone.

    ``elliptic`` (a bool, or one per row) gives the rows of an elliptic wall's residual the section's
    second harmonic, ``- e_1 (x^2 - y^2) - e_2 (2 x y)`` with ``e_1, e_2`` constant over each segment
    (:mod:`vesselgp.sections`), eliminated per segment (Schur's complement of their 2 x 2 block): the
    sums keep their shape and the solve is unchanged; rows without it give the same sums, bit for bit.
    """
    j, t = hat(s, K)
    if nodeoff is not None:
        j = j + nodeoff
    x, y = local[:, 1], local[:, 2]
    sw = np.sqrt(w) / (2.0 * rscale)
    c = (2 * x * sw, 2 * y * sw, sw)  # coefficients of cx, cy, d in each residual
    u = 1.0 - t
    G = [ck * u for ck in c] + [ck * t for ck in c]  # the six, at nodes j and j + 1 (contiguous columns)
    b = (x * x + y * y) * sw
    N = K if total is None else total
    S = _segment_sums(j, (G[a] * G[c] for a, c in zip(_PAIR_A, _PAIR_B)), N)
    R = _segment_sums(j, (g * b for g in G), N)
    if elliptic is None or not np.any(elliptic):
        return S, R
    return _without_second_harmonic(S, R, j, G, b, np.where(elliptic, sw, 0.0), x, y, N)


def _without_second_harmonic(S, R, j, G, b, sw, x, y, N):
    """The circle fit's segment sums ``S``, ``R`` with each segment's second harmonic ``e_1, e_2`` (coefficients
    ``(x^2 - y^2) sw`` and ``2 x y sw``, zero on rows without it) eliminated: ``S - B^T C^-1 B``, ``R - B^T C^-1
    r`` with ``B`` (2, 6), ``C`` (2, 2) and ``r`` (2,) the segment's sums of their products with the six
    unknowns', their own and the right-hand side's. A segment with none of those rows is unchanged."""
    H = ((x * x - y * y) * sw, 2.0 * x * y * sw)
    B = _segment_sums(j, (h * g for h in H for g in G), N).reshape(-1, 2, 6)
    C = _segment_sums(j, (H[0] * H[0], H[0] * H[1], H[1] * H[1]), N)
    r = _segment_sums(j, (h * b for h in H), N)
    on = np.flatnonzero(C[:, 0] + C[:, 2] > 0)  # segments with rows that carry the harmonic (B = 0 elsewhere)
    C, B, r = C[on], B[on], r[on]
    ridge = tol.GC_HARMONIC_RIDGE * (C[:, 0] + C[:, 2])  # a segment whose rows do not determine both terms
    c00, c01, c11 = C[:, 0] + ridge, C[:, 1], C[:, 2] + ridge
    det = c00 * c11 - c01 * c01
    Ci = np.stack([np.stack([c11, -c01], axis=1), np.stack([-c01, c00], axis=1)], axis=1) / det[:, None, None]
    CiB = Ci @ B  # (n_on, 2, 6)
    S[on] -= np.einsum("kmi,kmj->kij", B, CiB)[:, _PAIR_A, _PAIR_B]
    R[on] -= np.einsum("kmi,km->ki", CiB, r)
    return S, R


def circle_fit_correction(axis_frames_nodes, centers, s, local, w, lam, rscale, pin_ends=True, elliptic=None):
    """One linear solve of the area-weighted Kasa circle fit with hat functions in s.

    Unknowns per node: centre correction ``(cx, cy)`` in the node frame (U, V)
    and ``d = R^2 - |c|^2``. Residual per vertex (divided by ``2 rscale``):
    ``(x^2 + y^2 - 2 cx x - 2 cy y - d)``. Regulariser: ``lam`` times the second
    difference of the corrected 3-D axis (Eq. 2's lambda term, second order).

    The normal equations are assembled straight into banded form (unknowns
    interleaved per node, bandwidth 7) and solved by banded Cholesky: O(n + K)
    with no sparse-matrix algebra. Each residual touches six unknowns (three at
    each node of its segment), so the data term is the 21 lower-triangle products
    of six coefficients, each summed per segment by a ``bincount``; the regulariser
    is one batched Gram product over the second differences.

    :func:`circle_fit_sums` of the data, then :func:`circle_fit_solve`.

    ``elliptic``: the sections' second harmonic in the residual (:func:`circle_fit_sums`).

    Returns the corrections as 3-D vectors, (K, 3).
    """
    S, R = circle_fit_sums(s, local, w, len(centers), rscale, elliptic=elliptic)
    return circle_fit_solve(axis_frames_nodes, centers, S, R, lam, rscale, pin_ends)


def circle_fit_solve(axis_frames_nodes, centers, S, R, lam, rscale, pin_ends=True, mirror_ends=False,
                     singular="raise", pull=True):
    """The regularised normal equations of :func:`circle_fit_correction` from its data sums
    ``S`` (K - 1, 21) and ``R`` (K - 1, 6) (:func:`circle_fit_sums`), solved: (K, 3) corrections.

    ``pin_ends`` holds the end nodes where they are (no correction): a bool for both, or a pair
    (first, last). A tree's branch pins only the ends that sit at a mesh end's centre; its
    junction sides are free (:func:`vesselgp.fit.fixed_points`).

    ``mirror_ends`` (a bool for both, or a pair; only at a pinned end) continues Eq. 2's second
    differences one node past the end, to the mirror image of the next node across the end's
    normal plane (a ghost node, taken from the current axis). Without it the second differences
    stop at the end, and their normal equations there are a second difference instead of the
    interior's fourth: the first free node is pulled towards the chord by about lambda x
    curvature x spacing^2 (0.11 % r at a tree's open root). With the mirror row the pull is of
    fourth order as inside (curvature is even about the end). The mirror plane is normal to the
    tangent at the end of the cubic through the first four nodes, and the ghost and the plane
    are taken from the corrected nodes by ``tolerances.GC_MIRROR_SOLVES`` solves of the same
    banded system: from the uncorrected axis and its frame's tangent instead, the lag contracted
    by 0.4 an iteration and a tree's open root branch took 5-6 iterations instead of 3, stopping
    1.6e-4 radii short. At the fixed point the correction is zero and the ghost the mirror of the
    axis itself.

    ``singular="none"`` returns None where the system is singular (a stretch with no wall
    around it) instead of raising :class:`NotTubularError`.

    ``pull=False`` puts Eq. 2's weight on the second difference of the correction alone, ``sum_m |D2
    Delta|^2``, not of the corrected axis: it smooths and damps the step but no longer pulls the axis
    towards its chord, so the fixed point is the data's own (a correction of zero leaves it). Used on a
    sparse wall (:func:`vesselgp.fit.fit_generalized_cylinder`), whose rings, fewer than the nodes, leave
    corrections between them that no data resists: there Eq. 2's pull moved the nodes of an exact axis by
    5 % of the radius in one step (issue #48). No ghost rows (``mirror_ends`` is ignored)."""
    K = len(centers)
    n3 = 3 * K
    rhs = np.zeros(n3)
    rhs[: 3 * (K - 1)] += R[:, :3].ravel()
    rhs[3:] += R[:, 3:].ravel()
    seg = 3 * np.arange(K - 1)[:, None]
    rows, cols, vals = [(seg + _PAIR_A).ravel()], [(seg + _PAIR_B).ravel()], [S.ravel()]
    Wbar = float(S[:, _PAIR_00].sum() + S[:, _PAIR_33].sum()) / K  # mean data weight on a node's cx
    # Eq. 2's lambda on the second difference of the corrected axis, sum_m |D2 (C + Delta)|^2
    # with Delta_k = cx_k U_k + cy_k V_k: second difference m touches cx, cy of nodes m, m+1, m+2
    E = axis_frames_nodes[:, 1:3]  # (K, 2, 3): U and V at each node
    d2c = centers[:-2] - 2 * centers[1:-1] + centers[2:]
    Q = np.concatenate([E[:-2], -2.0 * E[1:-1], E[2:]], axis=1)  # (K - 2, 6, 3)
    lw = lam * Wbar
    gram = np.einsum("mai,mbi->mab", Q, Q)[:, _PAIR_A, _PAIR_B]
    red = 3 * np.arange(K - 2)[:, None] + np.array([0, 1, 3, 4, 6, 7])  # unknown index of each of the six
    if pull:
        np.add.at(rhs, red.ravel(), (-lw * np.einsum("mai,mi->ma", Q, d2c)).ravel())
    rows.append(red[:, _PAIR_A].ravel())
    cols.append(red[:, _PAIR_B].ravel())
    vals.append(lw * gram.ravel())
    pin, mirror = _pair(pin_ends), _pair(mirror_ends)
    ghosts = [(i0, i1) for i0, i1, on in ((0, 1, pin[0] and mirror[0]), (K - 1, K - 2, pin[1] and mirror[1]))
              if on and pull]
    for i0, i1 in ghosts:  # the ghost row g - 2 C_i0 + (C_i1 + Delta_i1): its matrix part
        ids = np.array([3 * i1, 3 * i1 + 1, 3 * i1 + 1])
        G = E[i1] @ E[i1].T
        rows.append(ids)
        cols.append(ids[[0, 1, 0]])
        vals.append(lw * np.array([G[0, 0], G[1, 1], G[1, 0]]))
    # keep d well posed where a node has no data (d is an area: its weight is
    # divided by rscale^2 so that the fit is the same in any length unit)
    ed = tol.GC_AREA_RIDGE * Wbar / rscale**2
    k1 = np.arange(K - 1)
    rows += [3 * k1 + 2, 3 * k1 + 5, 3 * k1 + 5]
    cols += [3 * k1 + 2, 3 * k1 + 5, 3 * k1 + 2]
    vals += [np.full(K - 1, ed), np.full(K - 1, ed), np.full(K - 1, -ed)]
    rows, cols, vals = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
    if any(pin):  # the first and / or the last node's cx, cy held at 0
        pinned = np.array(([0, 1] if pin[0] else []) + ([3 * (K - 1), 3 * (K - 1) + 1] if pin[1] else []),
                          dtype=np.int64)
        is_pinned = np.zeros(n3, dtype=bool)
        is_pinned[pinned] = True
        keep = ~(is_pinned[rows] | is_pinned[cols])
        rows, cols, vals = (np.concatenate([v[keep], e]) for v, e in zip((rows, cols, vals), (pinned, pinned, np.ones(len(pinned)))))
        rhs[pinned] = 0.0
    bw = int((rows - cols).max())
    ab = np.bincount((rows - cols) * n3 + cols, vals, minlength=(bw + 1) * n3).reshape(bw + 1, n3)
    corr = np.zeros((K, 3))
    for _ in range(tol.GC_MIRROR_SOLVES if ghosts else 1):
        # the ghost, the mirror image of the next node as last corrected across the normal plane
        # of the end (of the cubic through the corrected first four nodes), enters the right-hand
        # side; re-solving with it updated (the matrix is the same) leaves the iteration no lag
        b = rhs.copy()
        for i0, i1 in ghosts:
            step = 1 if i1 > i0 else -1
            C = centers[i0:i0 + 4 * step:step] + corr[i0:i0 + 4 * step:step]
            T0 = -11.0 * C[0] + 18.0 * C[1] - 9.0 * C[2] + 2.0 * C[3]  # the cubic's tangent at the end
            T0 /= np.linalg.norm(T0)  # (its sense does not matter to a mirror)
            v, g = centers[i1] - centers[i0], centers[i1] + corr[i1] - centers[i0]
            b[[3 * i1, 3 * i1 + 1]] -= lw * (E[i1] @ (g - 2.0 * (g @ T0) * T0 + v))
        sol = banded_spd_or_none(ab, b)
        if sol is None:
            return None if singular == "none" else checked_solution(None)
        corr = sol[0::3, None] * E[:, 0] + sol[1::3, None] * E[:, 1]
    return corr


def _pair(flag):
    """A per-end option as a (first, last) pair: a bool for both ends, or a pair already."""
    return (flag, flag) if isinstance(flag, (bool, np.bool_)) else tuple(flag)


def checked_solution(x):
    """``x`` when finite; None or a non-finite solve means the surface does not surround an axis."""
    if x is None or not np.all(np.isfinite(x)):
        raise NotTubularError(
            "mesh is not tubular: the generalized-cylinder fit is singular (the surface does not "
            "surround an axis: flat, collapsed or torn); check the mesh, e.g. with vesselgp.clean_mesh"
        )
    return x


def solve_banded_spd(ab, rhs):
    """Banded Cholesky solve (lower form, LAPACK ``pbsv``, as ``scipy.linalg.solveh_banded``
    without its input checks); failure means the surface does not surround an axis.

    A matrix that is not positive definite (``info > 0``), or a non-finite solution, raises
    :class:`NotTubularError` through :func:`checked_solution`.
    """
    return checked_solution(banded_spd_or_none(ab, rhs))


def banded_spd_or_none(ab, rhs):
    """:func:`solve_banded_spd`'s solution, or None where it would raise (singular or non-finite)."""
    _, x, info = _pbsv(ab, rhs, lower=1)
    return x if info == 0 and np.all(np.isfinite(x)) else None


def local_coords(axis, P, s):
    """Coordinates (n, 3) of ``P`` in the frame at its ``s`` (along T, U, V), and the stretch (n,).

    The stretch is :meth:`Axis.stretch` of the offset. Rows are handled
    ``tolerances.AXIS_ROW_CHUNK`` at a time (bounded temporaries).
    """
    s = np.asarray(s, float)
    local, jac = np.empty((len(P), 3)), np.empty(len(P))
    for rows in _row_chunks(len(P)):
        (local[rows, 0], local[rows, 1], local[rows, 2]), jac[rows] = _local_rows(
            axis.table, axis.kvec_t, np.ascontiguousarray(P[rows].T), s[rows])
    return local, jac
