"""Generalized-cylinder fit: medial axis and radius of a vessel mesh (paper Section 2.1-2.2).

The paper fits the medial axis ``m(s)`` by gradient descent on Eq. 2 (data term:
weighted centroids of the surface points that project near ``m(s)``, Eq. 1;
regulariser ``lambda``), and the radius ``r(s)`` by descent on Eq. 4 (mean
distance of those points to the axis; regulariser ``mu``). We solve the same
fixed points directly, with three changes a geometry-processing user expects:

* **Initialisation that holds on strongly curved vessels.** A harmonic field
  between the two ends (libigl ``harmonic``, cotangent Laplacian) orders the
  surface along the vessel; area-weighted centroids of its level bands (Eq. 1
  with indicator weights, libigl ``massmatrix`` areas) give the first axis.
* **No bend bias.** Eq. 1's centroid lies outside the true centre of a bent tube
  by about ``kappa r^2 / 2`` (the outer wall has more area per unit axis
  length). Instead of the centroid, each cross-section's centre comes from an
  area-weighted algebraic circle fit (Kasa) of the vertices' in-plane
  coordinates ``(x_i, y_i)`` in the frame at their own projection ``s_i``. The
  fit is linear in the centre correction and the node values, solved in one
  sparse least-squares system per iteration with piecewise-linear (hat)
  functions of ``s`` (this is Eq. 3's fixed point with the unbiased data term).
  For elliptic sections the area-weighted fit is centred by symmetry.
* **Regulariser.** Eq. 2's ``lambda`` term is applied to the second difference of
  the axis (bending), not the first: the first-order term pulls an arc of
  curvature ``kappa`` inwards by ``lambda kappa``, the second-order one leaves
  arcs and helices unbiased. Eq. 4's ``mu`` term is used as written.

Vertices that are not on the tubular wall (cap faces, side branches, the far
side of a bifurcation) are removed from the data by robust reweighting against
the fitted radius.
"""
from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass, field

import igl
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.interpolate import make_interp_spline
from scipy.linalg import solveh_banded
from scipy.spatial import cKDTree

from . import tolerances as tol
from ._arrays import unique_rows
from ._validate import as_mesh, as_vector
from .curves import _perpendicular, chord_length, rotation_minimizing_frames
from .errors import InvalidMeshError, NotTubularError, VesselError

log = logging.getLogger(__name__)

__all__ = ["GeneralizedCylinder", "fit_generalized_cylinder"]


@dataclass(frozen=True)
class GeneralizedCylinder:
    """A fitted generalized cylinder: axis, radius, RMF and vertex parameters.

    Attributes
    ----------
    s : (K,) float64
        Normalised arc length of the axis nodes, ``s[0] = 0``, ``s[-1] = 1``.
    length : float
        Arc length of the axis in mesh units.
    centers : (K, 3) float64
        Axis points ``m(s)``.
    radii : (K,) float64
        Radius ``r(s)``: area-weighted mean distance of the wall to the axis (Eq. 4).
    frames : (K, 3, 3) float64
        Rotation-minimizing frames; ``frames[k]`` has rows ``T, U, V`` (Section 2.2).
    vertex_s : (n,) float64
        Normalised arc length of each vertex's projection on the axis.
    vertex_theta : (n,) float64
        Angle of ``p_i - m(s_i)`` about ``T(s_i)`` measured from ``U(s_i)``, in (-pi, pi].
    vertex_local : (n, 3) float64
        Coordinates of ``p_i - m(s_i)`` in the frame ``(T, U, V)`` at ``s_i``;
        the first is non-zero only for vertices beyond the axis ends (caps).
    vertex_weight : (n,) float64
        Weight each vertex had in the final fit: its Voronoi area divided by the
        tube-map stretch ``1 - kappa . offset`` (so every direction about the
        axis counts equally), 0 when it was rejected as not belonging to the
        tubular wall (caps, side branches).
    vertex_area : (n,) float64
        Voronoi area of each vertex where ``vertex_weight > 0``, else 0 (Eq. 1's weights).
    ends : tuple of int
        Indices (into :func:`vesselgp.vessel_ends`) of the ends at ``s = 0`` and
        ``s = 1``; ``(-1, -1)`` when the caller passed the ends themselves.
    dense_s, dense_points, dense_frames : arrays
        The axis sampled densely at equal arc length with its RMF, used by
        :meth:`at` for interpolation.
    iterations : int
        Outer iterations the fit used.
    """

    s: np.ndarray
    length: float
    centers: np.ndarray
    radii: np.ndarray
    frames: np.ndarray
    vertex_s: np.ndarray
    vertex_theta: np.ndarray
    vertex_local: np.ndarray
    vertex_weight: np.ndarray
    vertex_area: np.ndarray
    ends: tuple
    dense_s: np.ndarray = field(repr=False)
    dense_points: np.ndarray = field(repr=False)
    dense_frames: np.ndarray = field(repr=False)
    iterations: int = 0

    def at(self, s):
        """Axis point and frame at normalised arc lengths ``s``.

        Parameters
        ----------
        s : (q,) float64
            Values in [0, 1] (clipped).

        Returns
        -------
        points : (q, 3) float64
        frames : (q, 3, 3) float64
            Rows ``T, U, V`` at each ``s``.
        """
        return _interp_frames(self.dense_s, self.dense_points, self.dense_frames, np.atleast_1d(s))

    def radius_at(self, s):
        """Radius ``r(s)`` at normalised arc lengths ``s`` (linear interpolation)."""
        return np.interp(np.atleast_1d(np.asarray(s, float)), self.s, self.radii)

    @property
    def mean_radius(self):
        """Length-weighted mean radius."""
        return float(np.trapezoid(self.radii, self.s))


# ----------------------------------------------------------------------------- axis machinery


def _segment_table(dp, dfr, kvec=None):
    """Per-segment table [p, dp, T, dT, (k,) U, dU] for one-gather interpolation.

    Columns 0-11 hold points and tangents, 12-14 the curvature vector when
    given, then U and its difference (so the Newton projection gathers one
    contiguous block).
    """
    cols = [dp[:-1], np.diff(dp, axis=0), dfr[:-1, 0], np.diff(dfr[:, 0], axis=0)]
    if kvec is not None:
        cols.append(0.5 * (kvec[:-1] + kvec[1:]))
    cols += [dfr[:-1, 1], np.diff(dfr[:, 1], axis=0)]
    return np.ascontiguousarray(np.hstack(cols))


def _interp_frames(ds, dp, dfr, s, frames=True, table=None):
    """Linear interpolation of dense axis samples and frames at ``s`` (re-orthonormalised).

    ``ds`` must be uniform (equal arc-length samples). With ``frames=False``
    only the points and unit tangents are returned (the Newton projection
    needs no more). ``table`` is :func:`_segment_table` of ``dp, dfr``.
    """
    s = np.clip(np.asarray(s, float), 0.0, 1.0)
    M = len(ds)
    x = s * (M - 1)
    j = np.minimum(x.astype(np.int64), M - 2)
    t = (x - j)[:, None]
    if table is None:
        table = _segment_table(dp, dfr)
    u0 = table.shape[1] - 6  # U columns start here (after the optional curvature)
    G = table[j] if frames else table[j, :u0]
    pts = G[:, 0:3] + t * G[:, 3:6]
    T = G[:, 6:9] + t * G[:, 9:12]
    T /= np.sqrt(np.einsum("ij,ij->i", T, T))[:, None]
    if not frames:
        return pts, T, (G[:, 12:15] if u0 > 12 else None)
    U = G[:, u0 : u0 + 3] + t * G[:, u0 + 3 : u0 + 6]
    U -= np.einsum("ij,ij->i", U, T)[:, None] * T
    U /= np.sqrt(np.einsum("ij,ij->i", U, U))[:, None]
    return pts, np.stack([T, U, np.cross(T, U)], axis=1)


class _Axis:
    """An axis through node points, resampled densely at equal arc length with its RMF."""

    def __init__(self, nodes, initial_normal=None, samples_per_node=tol.GC_SAMPLES_PER_NODE):
        u = chord_length(nodes)
        keep = np.concatenate([[True], np.diff(u) > 0])
        nodes, u = nodes[keep], u[keep]
        if len(nodes) < 2:
            raise NotTubularError(
                "mesh is not tubular: its axis collapsed to a point (all vertices coincide); "
                "check the (deformed) vertex positions"
            )
        k = min(3, len(nodes) - 1)
        self.spline = make_interp_spline(u, nodes, k=k)
        # arc-length reparameterisation on a fine grid
        uf = np.linspace(0, u[-1], 16 * samples_per_node * len(nodes))
        Pf = self.spline(uf)
        arc = chord_length(Pf)
        self.length = float(arc[-1])
        M = samples_per_node * (len(nodes) - 1) + 1
        self.s = np.linspace(0.0, 1.0, M)
        ud = np.interp(self.s * self.length, arc, uf)
        self.points = self.spline(ud)
        T = self.spline.derivative(1)(ud)
        T /= np.linalg.norm(T, axis=1)[:, None]
        if initial_normal is None:
            initial_normal = _default_normal(self.points, T[0])
        T, U, V = rotation_minimizing_frames(self.points, T, initial_normal=initial_normal)
        self.frames = np.stack([T, U, V], axis=1)
        # curvature vector dT/ds (per mesh unit) at the dense samples
        self.kvec = np.gradient(T, self.s * self.length, axis=0)
        self.table = _segment_table(self.points, self.frames, self.kvec)
        self._tree = None

    def stretch(self, s, d):
        """Jacobian 1 - k(s) . d of the tube map at offset ``d`` from the axis point at ``s``.

        The wall's area per unit axis length and unit angle grows by this
        factor towards the outside of a bend; dividing the vertex areas by it
        gives every direction about the axis equal weight (removes the bend bias
        of Eq. 1).
        """
        j = np.clip(np.rint(np.clip(s, 0, 1) * (len(self.s) - 1)).astype(np.int64), 0, len(self.s) - 1)
        return 1.0 - np.einsum("ij,ij->i", self.kvec[j], d)

    def at(self, s):
        return _interp_frames(self.s, self.points, self.frames, s, table=self.table)

    def project(self, P, s_prev, window=None):
        """Closest-point parameter of each row of ``P`` near its previous parameter.

        With a ``window``, candidates are the dense samples nearest to each
        point (k-d tree); among those within ``window`` of ``s_prev`` the
        closest wins, which keeps a vertex on its own stretch of axis where the
        vessel comes close to itself. Without one, ``s_prev`` is trusted as the
        start (the axis moved little since). Newton steps then refine ``s`` on
        the interpolated axis.

        Returns ``s`` (unclipped, may leave [0, 1] beyond the ends).
        """
        if window is None:
            s = np.asarray(s_prev, float).copy()
        else:
            if self._tree is None:
                self._tree = cKDTree(self.points)
            kq = min(8, len(self.s))
            dist, idx = self._tree.query(P, k=kq)
            sc = self.s[idx]
            far = np.abs(sc - s_prev[:, None]) > window
            d = np.where(far, np.inf, dist)
            best = np.argmin(d, axis=1)
            none = ~np.isfinite(d[np.arange(len(P)), best])
            best[none] = 0
            s = sc[np.arange(len(P)), best]
        for _ in range(tol.GC_NEWTON_STEPS):
            s = np.clip(s, 0, 1)
            pts, T, k = _interp_frames(self.s, self.points, self.frames, s, frames=False, table=self.table)
            d = P - pts
            # d/ds of (p - m(s)) . T(s) is -(1 - k . d) times the length
            jac = np.maximum(1.0 - np.einsum("ij,ij->i", k, d), tol.GC_MIN_STRETCH)
            s = s + np.einsum("ij,ij->i", d, T) / (self.length * jac)
        return s


def _default_normal(points, t0):
    """Rigid-covariant choice of U at s = 0: towards the axis point farthest from the
    line through the first point along the first tangent (the way the vessel bends).
    Falls back to a fixed coordinate direction for a straight axis (documented)."""
    d = points - points[0]
    d -= np.outer(d @ t0, t0)
    n = np.linalg.norm(d, axis=1)
    j = int(np.argmax(n))
    scale = chord_length(points)[-1]
    if n[j] > 1e-3 * scale:
        return d[j] / n[j]
    return _perpendicular(t0)


def _subset(n, most=tol.GC_MAX_FIT_VERTICES):
    """Evenly thinned vertex subset (a slice) of at most about ``most`` vertices."""
    step = max(1, int(np.ceil(n / most)))
    return slice(0, n, step)


def _hat(s, K):
    """Piecewise-linear basis on K uniform nodes over [0, 1]: left index and weight of the right node."""
    x = np.clip(s, 0.0, 1.0) * (K - 1)
    j = np.minimum(np.floor(x).astype(np.int64), K - 2)
    return j, x - j


def _basis_matrix(s, K):
    j, t = _hat(s, K)
    n = len(s)
    rows = np.repeat(np.arange(n), 2)
    cols = np.stack([j, j + 1], axis=1).ravel()
    vals = np.stack([1 - t, t], axis=1).ravel()
    return sp.csr_matrix((vals, (rows, cols)), shape=(n, K))


def _diff(K, order):
    D = sp.eye(K, format="csr")
    for _ in range(order):
        D = (D[1:] - D[:-1]).tocsr()
    return D


def _circle_update(axis_frames_nodes, centers, s, local, w, lam, rscale, pin_ends=True):
    """One linear solve of the area-weighted Kasa circle fit with hat functions in s.

    Unknowns per node: centre correction ``(cx, cy)`` in the node frame (U, V)
    and ``d = R^2 - |c|^2``. Residual per vertex (divided by ``2 rscale``):
    ``(x^2 + y^2 - 2 cx x - 2 cy y - d)``. Regulariser: ``lam`` times the second
    difference of the corrected 3-D axis (Eq. 2's lambda term, second order).

    The normal equations are assembled straight into banded form (unknowns
    interleaved per node, bandwidth 7) and solved by banded Cholesky: O(n + K)
    with no sparse-matrix algebra.

    Returns the corrections as 3-D vectors, (K, 3).
    """
    K = len(centers)
    n3 = 3 * K
    j, t = _hat(s, K)
    x, y = local[:, 1], local[:, 2]
    sw = np.sqrt(w) / (2.0 * rscale)
    c = (2 * x * sw, 2 * y * sw, sw)  # coefficients of cx, cy, d in each residual
    b = (x * x + y * y) * sw
    phi = (1.0 - t, t)  # hat weights of nodes j and j + 1
    rows, cols, vals = [], [], []
    rhs = np.zeros(n3)
    jj = np.arange(K - 1)
    for p in range(2):
        for a in range(3):
            rhs[3 * (jj + p) + a] += np.bincount(j, c[a] * phi[p] * b, minlength=K - 1)
            for q in range(2):
                for bb in range(3):
                    if 3 * p + a < 3 * q + bb:
                        continue  # lower triangle only
                    rows.append(3 * (jj + p) + a)
                    cols.append(3 * (jj + q) + bb)
                    vals.append(np.bincount(j, c[a] * c[bb] * phi[p] * phi[q], minlength=K - 1))
    Wbar = float(_node_diagonal(j, c[0], phi, K).mean())
    # Eq. 2's lambda on the second difference of the corrected axis, sum_m |D2 (C + Delta)|^2
    # with Delta_k = cx_k U_k + cy_k V_k
    E = (axis_frames_nodes[:, 1], axis_frames_nodes[:, 2])
    d2c = centers[:-2] - 2 * centers[1:-1] + centers[2:]
    m = np.arange(K - 2)
    wts = (1.0, -2.0, 1.0)
    lw = lam * Wbar
    for p in range(3):
        for a in range(2):
            rhs[3 * (m + p) + a] -= lw * wts[p] * np.einsum("ij,ij->i", E[a][m + p], d2c)
            for q in range(3):
                for bb in range(2):
                    if 3 * p + a < 3 * q + bb:
                        continue
                    rows.append(3 * (m + p) + a)
                    cols.append(3 * (m + q) + bb)
                    vals.append(lw * wts[p] * wts[q] * np.einsum("ij,ij->i", E[a][m + p], E[bb][m + q]))
    # keep d well posed where a node has no data (d is an area: its weight is
    # divided by rscale^2 so that the fit is the same in any length unit)
    ed = 1e-6 * Wbar / rscale**2
    k1 = np.arange(K - 1)
    rows += [3 * k1 + 2, 3 * k1 + 5, 3 * k1 + 5]
    cols += [3 * k1 + 2, 3 * k1 + 5, 3 * k1 + 2]
    vals += [np.full(K - 1, ed), np.full(K - 1, ed), np.full(K - 1, -ed)]
    rows, cols, vals = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
    if pin_ends:
        pinned = np.array([0, 1, 3 * (K - 1), 3 * (K - 1) + 1])
        keep = ~(np.isin(rows, pinned) | np.isin(cols, pinned))
        rows, cols, vals = (np.concatenate([v[keep], e]) for v, e in zip((rows, cols, vals), (pinned, pinned, np.ones(4))))
        rhs[pinned] = 0.0
    bw = int((rows - cols).max())
    ab = np.bincount((rows - cols) * n3 + cols, vals, minlength=(bw + 1) * n3).reshape(bw + 1, n3)
    sol = _solve_banded(ab, rhs)
    return sol[0::3, None] * E[0] + sol[1::3, None] * E[1]


def _node_diagonal(j, c0, phi, K):
    """Diagonal of the cx block of the data term: sum of (c0 phi)^2 onto each node."""
    d = np.zeros(K)
    d[:-1] += np.bincount(j, (c0 * phi[0]) ** 2, minlength=K - 1)
    d[1:] += np.bincount(j, (c0 * phi[1]) ** 2, minlength=K - 1)
    return d


def _checked_solution(x):
    """``x`` when finite; None or a non-finite solve means the surface does not surround an axis."""
    if x is None or not np.all(np.isfinite(x)):
        raise NotTubularError(
            "mesh is not tubular: the generalized-cylinder fit is singular (the surface does not "
            "surround an axis: flat, collapsed or torn); check the mesh, e.g. with vesselgp.clean_mesh"
        )
    return x


def _solve_banded(ab, rhs):
    """Banded Cholesky solve (lower form); failure means the surface does not surround an axis."""
    try:
        x = solveh_banded(ab, rhs, lower=True)
    except (np.linalg.LinAlgError, ValueError):
        x = None
    return _checked_solution(x)


def _radius_fit(s, rho, w, K, mu):
    """Eq. 4: r(s) minimising sum w (r(s_i) - rho_i)^2 + mu * int r'^2, hat functions in s."""
    B = _basis_matrix(s, K)
    Bw = B.multiply(w[:, None]).tocsr()
    N = (B.T @ Bw).tocsr()
    rhs = Bw.T @ rho
    Wbar = float(N.diagonal().mean())
    D1 = _diff(K, 1)
    N = N + mu * Wbar * (D1.T @ D1) + 1e-9 * Wbar * sp.eye(K)
    return _solve(N, rhs)


def _solve(N, rhs):
    """Sparse solve; a singular or non-finite system means the surface does not surround an axis."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", spla.MatrixRankWarning)
        try:
            x = spla.spsolve(N.tocsc(), rhs)
        except (spla.MatrixRankWarning, RuntimeError):
            x = None
    return _checked_solution(x)


def _local_coords(axis, P, s):
    pts, fr = axis.at(s)
    d = P - pts
    return np.einsum("nij,nj->ni", fr, d), axis.stretch(s, d)


def _robust_weights(s, local, jac, area, radii, inside):
    """Area weights divided by the tube-map Jacobian, zeroed outside the axis range
    and for vertices far from the fitted wall."""
    rho = np.hypot(local[:, 1], local[:, 2])
    ok = inside & (jac > tol.GC_MIN_STRETCH)
    w = np.where(ok, area / np.where(ok, jac, 1.0), 0.0)
    if radii is None:
        return w
    r = np.interp(s, np.linspace(0, 1, len(radii)), radii)
    e = rho - r
    sel = w > 0
    if not np.any(sel):
        return w
    mad = np.median(np.abs(e[sel]))
    sigma = max(1.4826 * mad, 0.01 * float(np.median(radii)))
    w[np.abs(e) > tol.GC_OUTLIER_SIGMAS * sigma] = 0.0
    return w


# ----------------------------------------------------------------------------- initialisation


def _resolve_ends(V, F, ends):
    """The two ends to fit between, their indices, and how many ends the mesh has."""
    if ends is not None and len(ends) == 2 and all(hasattr(e, "center") for e in ends):
        return ends[0], ends[1], (-1, -1), 2
    from .mesh import select_ends, vessel_ends

    all_ends = vessel_ends(V, F)
    e0, e1 = select_ends(all_ends, ends)
    i0 = next(i for i, e in enumerate(all_ends) if e is e0)
    i1 = next(i for i, e in enumerate(all_ends) if e is e1)
    return e0, e1, (i0, i1), len(all_ends)


def _path_mask(V, F, e0, e1, rscale):
    """Vertices on the path between the two ends (excess geodesic length <= 2 radii).

    Used when the mesh has other ends (branches): vertices deeper than about a
    radius into a side branch have d0 + d1 well above the shortest d0 + d1.
    """
    data = igl.HeatGeodesicsData()
    igl.heat_geodesics_precompute(V, F, data)
    d0 = igl.heat_geodesics_solve(data, np.asarray(e0.vertices, np.int64))
    d1 = igl.heat_geodesics_solve(data, np.asarray(e1.vertices, np.int64))
    ex = d0 + d1
    ex -= np.min(ex)
    return ex <= 2.0 * rscale


def _harmonic_between(V, F, b, bc, rscale):
    """Harmonic field with values ``bc`` at vertices ``b`` (cotangent Laplacian, libigl).

    Meshes above :data:`tolerances.GC_COARSE_INIT_VERTICES` vertices get the
    field of a vertex-clustered copy (cells a fraction of the radius wide, graph
    Laplacian): it only seeds the fit, and a million-row factorisation would
    cost far more than the whole fit.
    """
    if len(V) <= tol.GC_COARSE_INIT_VERTICES:
        return igl.harmonic(V, F, b, np.ascontiguousarray(bc[:, None]), 1).ravel()
    area = float(igl.doublearea(V, F).sum()) / 2
    h = min(np.sqrt(area / tol.GC_COARSE_INIT_VERTICES), tol.GC_COARSE_CELL_RADII * rscale)
    key = np.floor((V - V.min(axis=0)) / h).astype(np.int64)
    _, cell = unique_rows(key, return_inverse=True)
    nc = int(cell.max()) + 1
    E = igl.edges(F)
    ce = cell[E]
    ce = ce[ce[:, 0] != ce[:, 1]]
    A = sp.coo_matrix((np.ones(len(ce)), (ce[:, 0], ce[:, 1])), shape=(nc, nc)).tocsr()
    A = ((A + A.T) > 0).astype(float)
    L = (sp.diags(np.asarray(A.sum(axis=1)).ravel()) - A).tocsr()
    cb = cell[b]
    cval = np.bincount(cb, weights=bc, minlength=nc) / np.maximum(np.bincount(cb, minlength=nc), 1)
    known = np.unique(cb)
    free = np.setdiff1d(np.arange(nc), known)
    x = np.zeros(nc)
    x[known] = cval[known]
    x[free] = spla.spsolve(L[free][:, free].tocsc(), -L[free][:, known] @ x[known])
    return x[cell]


def _initial_axis(V, F, e0, e1, area, K0, rscale):
    """Harmonic field between the ends, then area-weighted centroids of its level bands (Eq. 1)."""
    b = np.concatenate([np.asarray(e0.vertices, np.int64), np.asarray(e1.vertices, np.int64)])
    bc = np.concatenate([np.zeros(len(e0.vertices)), np.ones(len(e1.vertices))])
    b, first = np.unique(b, return_index=True)
    phi = _harmonic_between(V, F, b, bc[first], rscale)
    phi = np.clip(phi, 0.0, 1.0)
    band = np.minimum((phi * K0).astype(np.int64), K0 - 1)
    wsum = np.bincount(band, weights=area, minlength=K0)
    cen = np.stack([np.bincount(band, weights=area * V[:, d], minlength=K0) for d in range(3)], 1)
    phim = np.bincount(band, weights=area * phi, minlength=K0)
    ok = wsum > 0
    cen = cen[ok] / wsum[ok, None]
    phim = phim[ok] / wsum[ok]
    pts = np.vstack([e0.center, cen, e1.center])
    ph = np.concatenate([[0.0], phim, [1.0]])
    arc = chord_length(pts)
    if arc[-1] <= 0:
        raise NotTubularError("mesh is not tubular: its two ends coincide")
    s0 = np.interp(phi, ph, arc / arc[-1])
    return pts, s0


def _resample_nodes(pts, K):
    """K nodes at equal arc length along an interpolating spline of ``pts``."""
    u = chord_length(pts)
    keep = np.concatenate([[True], np.diff(u) > 1e-12 * u[-1]])
    pts, u = pts[keep], u[keep]
    spl = make_interp_spline(u, pts, k=min(3, len(pts) - 1))
    uf = np.linspace(0, u[-1], 20 * K)
    arc = chord_length(spl(uf))
    return spl(np.interp(np.linspace(0, arc[-1], K), arc, uf))


def _check_aspect(length, radius):
    if length < tol.MIN_ASPECT * 2 * radius:
        raise NotTubularError(
            f"vessel is shorter than its diameter (axis {length:.3g}, diameter {2 * radius:.3g}); "
            "it cannot be modelled as a generalized cylinder"
        )


def _check_connected(V, F):
    """Raise :class:`InvalidMeshError` when the mesh has several connected pieces."""
    from scipy.sparse.csgraph import connected_components

    n = len(V)
    E = F[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    G = sp.coo_matrix((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(n, n))
    ncomp = connected_components(G, directed=False)[0]
    if ncomp > 1:
        raise InvalidMeshError(
            f"mesh has {ncomp} connected components; run vesselgp.clean_mesh (keeps the largest) "
            "or fit each vessel separately"
        )


def _nondegenerate_faces(V, F):
    """Faces whose area is well defined: above ``DEGENERATE_AREA`` times their longest edge squared.

    Zero-area faces (collinear or repeated corners) have no cotangent weights;
    they are left out of the area weights and the harmonic field (they carry no
    surface). A vertex used only by such faces has no area and no field value:
    that raises :class:`InvalidMeshError` suggesting :func:`vesselgp.clean_mesh`.
    """
    dbl = igl.doublearea(V, F)
    e2 = igl.edge_lengths(V, F).max(axis=1) ** 2
    bad = ~(dbl > 2.0 * tol.DEGENERATE_AREA * e2)
    if not bad.any():
        return F
    Fg = F[~bad]
    lost = len(V) - len(np.unique(Fg)) if len(Fg) else len(V)
    if lost:
        raise InvalidMeshError(
            f"mesh has {int(bad.sum())} zero-area faces and {lost} vertices used only by them; "
            "run vesselgp.clean_mesh first"
        )
    log.info("fit ignores %d zero-area faces (vesselgp.clean_mesh removes exactly degenerate ones)",
             int(bad.sum()))
    return Fg


def _log_scale(V, F, e0, e1):
    """Log the mesh's scale; warn when its units look like metres or centimetres (or micrometres)."""
    from .mesh import mesh_scale

    sc = mesh_scale(V, F, ends=(e0, e1))
    r0, r1 = sc.radius_range
    report = (f"median edge {sc.median_edge:.3g}, end radii {r0:.3g} to {r1:.3g}, "
              f"bounding-box diagonal {sc.bbox_diagonal:.3g}")
    if sc.warning:
        log.warning("mesh scale: %s; %s", report, sc.warning)
    else:
        log.info("mesh scale: %s (units look like %s)", report, sc.units_guess)


# ----------------------------------------------------------------------------- public entry


def fit_generalized_cylinder(
    V,
    F,
    ends=None,
    *,
    n_nodes=None,
    lam=tol.GC_LAMBDA,
    mu=tol.GC_MU,
    max_iter=tol.GC_MAX_ITER,
    initial_normal=None,
):
    """Fit a generalized cylinder (medial axis, radius, RMF) to a vessel mesh.

    Implements paper Section 2.2: the medial-axis fixed point of Eq. 3 (with an
    unbiased circle-fit centre in place of Eq. 1's centroid, see the module
    notes), the radius fixed point of Eq. 5 (mean distance, Eq. 4, with the
    ``mu`` regulariser), the RMF by double reflection, and the vertex
    parameterisation ``(s_i, theta_i)``.

    The mesh's scale (median edge, end radii) is logged at INFO level, and at
    WARNING level when it looks like metres, centimetres or micrometres rather
    than millimetres (:func:`vesselgp.mesh_scale`); the fit itself does not
    depend on the unit.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, 3) int64
        Triangles.
    ends : None, (int, int) or (VesselEnd, VesselEnd), optional
        The two ends the vessel runs between (``s = 0`` at the first). ``None``
        takes the two ends of :func:`vesselgp.vessel_ends` when there are
        exactly two; pass indices into that tuple for a branching mesh.
    n_nodes : int, optional
        Number of axis nodes K. Default: one per half mean radius of length.
    lam : float
        Eq. 2's regularisation weight (dimensionless; on the axis's second difference).
    mu : float
        Eq. 4's regularisation weight (dimensionless; on the radius's first difference).
    max_iter : int
        Maximum outer iterations (projection, circle fit, radius fit).
    initial_normal : (3,) float64, optional
        Direction of U at ``s = 0``. Default: towards the way the axis bends
        (rigid-covariant); a fixed coordinate direction for a straight axis.

    Returns
    -------
    GeneralizedCylinder

    Raises
    ------
    InvalidMeshError
        Malformed arrays, unreferenced vertices, several connected components,
        vertices used only by zero-area faces, or (through
        :func:`vesselgp.vessel_ends`) other defects: run :func:`vesselgp.clean_mesh`.
        Zero-area faces themselves are left out of the area weights.
    NotTubularError, EndsError
        No two ends, ambiguous ends on a branching mesh, or a vessel shorter
        than its diameter.

    Examples
    --------
    >>> from vesselgp.synthetic import synthetic_vessel
    >>> ves = synthetic_vessel("arc", radius=1.5, n_around=24, remesh=False)
    >>> gc = fit_generalized_cylinder(ves.V, ves.F)
    >>> bool(abs(gc.mean_radius - 1.5) < 0.02)
    True
    """
    V, F = as_mesh(V, F)
    n = len(V)
    used = np.zeros(n, bool)
    used[F.ravel()] = True
    if not used.all():
        raise InvalidMeshError(
            f"mesh has {int((~used).sum())} unreferenced vertices; run vesselgp.clean_mesh first"
        )
    if n_nodes is not None and (isinstance(n_nodes, bool) or not isinstance(n_nodes, (int, np.integer))
                                or n_nodes < 4):
        raise VesselError(f"n_nodes must be an integer of at least 4, got {n_nodes!r}; or None for the default")
    _check_connected(V, F)
    Fg = _nondegenerate_faces(V, F)
    e0, e1, end_ids, n_ends = _resolve_ends(V, F, ends)
    if initial_normal is not None:
        initial_normal = as_vector(initial_normal, "initial_normal")
    _log_scale(V, F, e0, e1)

    # Voronoi areas and the harmonic field use the faces with a well-defined
    # area (zero-area faces have infinite cotangent weights)
    area = igl.massmatrix(V, Fg, igl.MASSMATRIX_TYPE_VORONOI).diagonal().copy()
    end_region = np.zeros(n, bool)
    for e in (e0, e1):
        if getattr(e, "kind", "open") != "open":
            end_region[np.asarray(e.vertices, np.int64)] = True
    rscale = 0.5 * (float(e0.radius) + float(e1.radius))
    if not np.isfinite(rscale) or rscale <= 0:
        raise NotTubularError("mesh is not tubular: the ends have no positive radius")
    if n_ends > 2:
        area = np.where(_path_mask(V, Fg, e0, e1, rscale), area, 0.0)

    # Shorter than its diameter: judged by the distance between the end centres
    # (the initial axis of such a stub is not reliable).
    chord = float(np.linalg.norm(np.asarray(e1.center) - np.asarray(e0.center)))
    _check_aspect(chord, rscale)

    # -- initialisation: harmonic field + level-band centroids
    K0 = int(np.clip(chord / (tol.GC_NODE_SPACING * rscale), tol.GC_MIN_NODES, tol.GC_MAX_NODES))
    pts, s_prev = _initial_axis(V, Fg, e0, e1, np.where(end_region, 0.0, area), K0, rscale)
    L0 = chord_length(pts)[-1]
    K = int(n_nodes or np.clip(L0 / (tol.GC_NODE_SPACING * rscale), tol.GC_MIN_NODES, tol.GC_MAX_NODES))
    nodes = _resample_nodes(pts, K)
    nodes[0], nodes[-1] = e0.center, e1.center

    radii = None
    window = 4.0 / (K - 1) + 2.0 * rscale / L0
    # large meshes iterate on an evenly thinned subset; the final pass uses all vertices
    sub = _subset(n)
    Vs, areas, ends_s, s_sub = V[sub], area[sub], end_region[sub], s_prev[sub]
    it = 0
    for it in range(1, max_iter + 1):
        axis = _Axis(nodes, initial_normal)
        s_raw = axis.project(Vs, s_sub, window)
        inside = (s_raw > 0) & (s_raw < 1) & ~ends_s
        s = np.clip(s_raw, 0, 1)
        local, jac = _local_coords(axis, Vs, s)
        w = _robust_weights(s, local, jac, areas, radii, inside)
        _, fr_nodes = axis.at(np.linspace(0, 1, K))
        corr = _circle_update(fr_nodes, nodes, s, local, w, lam, rscale)
        nodes = nodes + corr
        radii = _radius_fit(s, np.hypot(local[:, 1], local[:, 2]), w, K, mu)
        step = float(np.abs(corr).max())
        # parameters on the corrected axis, for the next projection's start
        old_s = np.linspace(0, 1, K)
        new_arc = chord_length(nodes)
        s_sub = np.interp(s, old_s, new_arc / new_arc[-1])
        window = None
        nodes = _resample_nodes(nodes, K)
        log.debug("GC iteration %d: axis moved %.3g (radius %.3g)", it, step, rscale)
        if step < tol.GC_CONVERGENCE * rscale:
            break
    else:
        log.warning("generalized-cylinder fit did not converge in %d iterations", max_iter)

    # final parameterisation on the converged axis, all vertices
    axis = _Axis(nodes, initial_normal)
    if sub.stop == n and sub.step == 1:
        s_raw = axis.project(V, s_sub, None)
    else:
        s_raw = axis.project(V, s_prev, 3.0 / (K - 1) + 2.0 * rscale / L0)
    inside = (s_raw > 0) & (s_raw < 1) & ~end_region
    s = np.clip(s_raw, 0, 1)
    local, jac = _local_coords(axis, V, s)
    w = _robust_weights(s, local, jac, area, radii, inside)
    radii = _radius_fit(s, np.hypot(local[:, 1], local[:, 2]), w, K, mu)
    sK = np.linspace(0, 1, K)
    centers, frames = axis.at(sK)
    return GeneralizedCylinder(
        s=sK,
        length=axis.length,
        centers=centers,
        radii=radii,
        frames=frames,
        vertex_s=s,
        vertex_theta=np.arctan2(local[:, 2], local[:, 1]),
        vertex_local=local,
        vertex_weight=w,
        vertex_area=np.where(w > 0, area, 0.0),
        ends=tuple(end_ids),
        dense_s=axis.s,
        dense_points=axis.points,
        dense_frames=axis.frames,
        iterations=it,
    )
