"""Space curves: high-order tangents, rotation-minimizing frames, Frenet quantities.

The medial axis of a vessel is a curve ``P`` of shape (k, 3), one point per row.
Its director frame (paper Section 1) starts as the rotation-minimizing frame
(RMF), computed here by the double reflection method of Wang, Juttler, Zheng and
Liu (ACM ToG 27, 2008), the method the paper adopts (Section 1, ref. [3]). The
projection method (Klok 1986, ref. [4]) and the rotation method (Bloomenthal
1990, ref. [5]) are available for comparison.

Accuracy is limited by the tangents, not by the reflections: when tangents are
not given they are taken from a quintic interpolating spline over chord length,
whose derivative error is O(h^5).
"""
from __future__ import annotations

from dataclasses import dataclass

import igl
import numpy as np
from scipy.interpolate import PPoly, make_interp_spline, make_smoothing_spline
from scipy.linalg.lapack import dgtsv

from . import tolerances as tol
from ._validate import as_points, as_vector
from .errors import FrameError, NotTubularError
from .rotations import minimal_rotation, perpendicular, unit_rows

__all__ = [
    "rotation_minimizing_frames",
    "curve_tangents",
    "chord_length",
    "polyline_feet",
    "resample_arclength",
    "frenet",
    "FrenetResult",
    "transport_angle",
]


def polyline_feet(X, L, aL=None):
    """Each point's foot on the polyline ``L``: its arc length, position and distance.

    libigl's point-to-mesh distance (``igl.point_mesh_squared_distance``) with the polyline's segments as
    the elements. A point beyond an end has that end point as its foot.

    Parameters
    ----------
    X : (q, 3) float64
    L : (k, 3) float64
        The polyline, k >= 2.
    aL : (k,) float64, optional
        Its arc lengths (default :func:`chord_length` of ``L``).

    Returns
    -------
    a : (q,) float64
    foot : (q, 3) float64
    d : (q,) float64

    Examples
    --------
    >>> a, foot, d = polyline_feet(np.array([[1.0, 2.0, 0.0], [5.0, 0.0, 0.0]]), np.array([[0.0, 0, 0], [3.0, 0, 0]]))
    >>> a.tolist(), d.tolist()
    ([1.0, 3.0], [2.0, 2.0])
    """
    if aL is None:
        aL = _chords(L)
    E = np.c_[np.arange(len(L) - 1), np.arange(1, len(L))]
    d2, seg, foot = igl.point_mesh_squared_distance(X, L, E)
    return aL[seg] + np.linalg.norm(foot - L[seg], axis=1), foot, np.sqrt(d2)


def chord_length(P):
    """Cumulative chord length of a polyline.

    Parameters
    ----------
    P : (k, 3) float64
        Curve points.

    Returns
    -------
    u : (k,) float64
        ``u[0] = 0`` and ``u[i]`` the length of the polyline up to point ``i``.

    Examples
    --------
    >>> chord_length([[0, 0, 0], [3, 4, 0], [3, 4, 1]])
    array([0., 5., 6.])
    """
    return _chords(as_points(P, "P", min_rows=1))


def resample_arclength(P, k, *, with_tangents=False, oversample=16):
    """``k`` points at equal arc length along the cubic interpolating spline of ``P``.

    The spline (:func:`interpolating_cubic`) runs over chord length
    (consecutive repeated points are dropped); its arc length is measured on
    chords about ``oversample`` times finer than the output, the same number
    in each of its segments (at least one).

    Parameters
    ----------
    P : (m, 3) float64
        Curve points, at least two distinct.
    k : int
        Number of output points (the first and last are the curve's ends).
    with_tangents : bool
        Also return the unit tangents of the spline and its length.

    Returns
    -------
    Q : (k, 3) float64
    T : (k, 3) float64
        Unit tangents (only with ``with_tangents``).
    length : float
        Arc length of the spline (only with ``with_tangents``).

    Raises
    ------
    NotTubularError
        When all points coincide (the curve has no length).

    Examples
    --------
    >>> Q = resample_arclength([[0, 0, 0], [1, 0, 0], [3, 0, 0]], 4)
    >>> np.round(Q[:, 0], 9).tolist()
    [0.0, 1.0, 2.0, 3.0]
    """
    return _resample_arclength(as_points(P, "P", min_rows=1), k, with_tangents, oversample)


def _resample_arclength(P, k, with_tangents=False, oversample=16):
    """:func:`resample_arclength` of an already validated (m, 3) float64 array (the fit's inner loops)."""
    u = _chords(P)
    apart = np.diff(u) > tol.REPEATED_POINT * u[-1]
    if not apart.all():
        keep = np.concatenate([[True], apart])
        P, u = P[keep], u[keep]
    if len(P) < 2:
        raise NotTubularError(
            "mesh is not tubular: its axis collapsed to a point (all vertices coincide); "
            "check the (deformed) vertex positions"
        )
    spl = interpolating_cubic(u, P)
    uf, X = _segment_grid(spl, max(1, -(-int(oversample) * int(k) // (len(u) - 1))))
    arc = _chords_by_component(X)
    ud = np.interp(np.linspace(0.0, arc[-1], int(k)), arc, uf)
    Q = spl(ud)
    if not with_tangents:
        return Q
    return Q, unit_rows(spl(ud, 1)), float(arc[-1])


def _chords(P):
    """:func:`chord_length` of an already validated (k, 3) float64 array."""
    d = np.diff(P, axis=0)
    u = np.empty(len(P))
    u[0] = 0.0
    np.cumsum(np.sqrt(np.einsum("ij,ij->i", d, d)), out=u[1:])
    return u


def _segment_grid(spl, q):
    """Parameters and points of ``q`` equal steps in each segment of a cubic ``PPoly``, and its end.

    Horner's rule on the segments' local polynomials, one component at a time on
    (n - 1, q) blocks (numpy is several times slower on rows of three). Returns
    ``((n - 1) q + 1,)`` parameters and the points component-major, ``(d, (n - 1) q + 1)``.
    """
    c, x = spl.c, spl.x
    h = np.diff(x)[:, None] * (np.arange(q) / q)  # (n - 1, q) offsets into each segment
    d = c.shape[2]
    X = np.empty((d, (len(x) - 1) * q + 1))
    dx = x[-1] - x[-2]
    for j in range(d):
        Xj = X[j, :-1].reshape(len(x) - 1, q)
        np.multiply(h, c[0, :, j, None], out=Xj)
        Xj += c[1, :, j, None]
        Xj *= h
        Xj += c[2, :, j, None]
        Xj *= h
        Xj += c[3, :, j, None]
        X[j, -1] = ((c[0, -1, j] * dx + c[1, -1, j]) * dx + c[2, -1, j]) * dx + c[3, -1, j]
    return np.concatenate([(x[:-1, None] + h).reshape(-1), x[-1:]]), X


def _chords_by_component(X):
    """:func:`chord_length` of points stored component-major, ``X`` (d, k): (k,) float64."""
    D = np.diff(X, axis=1)
    l2 = D[0] * D[0]
    for j in range(1, len(D)):
        l2 += D[j] * D[j]
    u = np.empty(X.shape[1])
    u[0] = 0.0
    np.cumsum(np.sqrt(l2), out=u[1:])
    return u


def interpolating_cubic(u, P):
    """The not-a-knot cubic spline through ``P`` at increasing parameters ``u``, as a scipy ``PPoly``.

    The same curve as ``scipy.interpolate.make_interp_spline(u, P, k=3)`` or
    ``CubicSpline(u, P)`` (the interpolant is unique), built with less overhead:
    the slopes at the nodes solve one tridiagonal system (LAPACK ``dgtsv``),
    whose first and last rows are the not-a-knot conditions (the third
    derivative continuous across the second and the last-but-one node), and
    each segment is the cubic Hermite polynomial of its end values and slopes.
    Two points give the line, three the parabola (``make_interp_spline`` with
    ``k = 1, 2``).

    Parameters
    ----------
    u : (m,) float64
        Strictly increasing parameters.
    P : (m, d) float64
        Points.

    Returns
    -------
    scipy.interpolate.PPoly
        Cubic pieces ``c`` (4, m - 1, d) on the breakpoints ``u``; callable as
        ``spl(x)`` and ``spl(x, nu)`` for the ``nu``-th derivative.

    Examples
    --------
    A cubic is reproduced exactly:

    >>> u = np.array([0.0, 0.5, 1.5, 2.0, 3.5])
    >>> spl = interpolating_cubic(u, (u**3 - u)[:, None])
    >>> float(np.round(spl(np.array([2.5]))[0, 0], 12)), float(np.round(spl(np.array([2.5]), 1)[0, 0], 12))
    (13.125, 17.75)
    """
    n = len(u)
    dx = np.diff(u)
    slope = np.diff(P, axis=0)
    slope /= dx[:, None]
    c = np.zeros((4, n - 1, P.shape[1]))
    c[3] = P[:-1]
    if n == 2:  # the line
        c[2] = slope
        return PPoly.construct_fast(c, u)
    if n == 3:  # the parabola P0 + s0 (x - u0) + a (x - u0)(x - u1), in each segment's local x
        a = (slope[1] - slope[0]) / (u[2] - u[0])
        c[1] = a
        c[2, 0], c[2, 1] = slope[0] - a * dx[0], slope[0] + a * dx[0]
        return PPoly.construct_fast(c, u)
    lower, diag, upper = np.empty(n - 1), np.empty(n), np.empty(n - 1)
    b = np.empty((n, P.shape[1]))
    diag[1:-1] = 2.0 * (dx[:-1] + dx[1:])
    upper[1:] = dx[:-1]
    lower[:-1] = dx[1:]
    b[1:-1] = 3.0 * (dx[1:, None] * slope[:-1] + dx[:-1, None] * slope[1:])
    e = u[2] - u[0]
    diag[0], upper[0] = dx[1], e
    b[0] = ((dx[0] + 2.0 * e) * dx[1] * slope[0] + dx[0] ** 2 * slope[1]) / e
    e = u[-1] - u[-3]
    diag[-1], lower[-1] = dx[-2], e
    b[-1] = (dx[-1] ** 2 * slope[-2] + (2.0 * e + dx[-1]) * dx[-2] * slope[-1]) / e
    *_, m, info = dgtsv(lower, diag, upper, b, overwrite_dl=1, overwrite_d=1, overwrite_du=1, overwrite_b=1)
    if info != 0:
        raise FrameError(f"interpolating_cubic: the slope system is singular (LAPACK info {info}); "
                         "are the parameters strictly increasing?")
    t = (m[:-1] + m[1:] - 2.0 * slope) / dx[:, None]
    c[0] = t / dx[:, None]
    c[1] = (slope - m[:-1]) / dx[:, None] - t
    c[2] = m[:-1]
    return PPoly.construct_fast(c, u)


def _spline(P):
    """Interpolating spline of the curve over chord length (degree <= 5)."""
    u = chord_length(P)
    if np.any(np.diff(u) <= 0):
        raise FrameError(
            "curve has repeated consecutive points; remove duplicates before computing frames"
        )
    k = min(5, len(P) - 1)
    if k % 2 == 0:  # odd degrees give the symmetric not-a-knot end conditions
        k -= 1
    return u, make_interp_spline(u, P, k=k)


def curve_tangents(P):
    """Unit tangents of a curve from a quintic spline over chord length.

    Parameters
    ----------
    P : (k, 3) float64
        Curve points, k >= 2, no two consecutive points equal.

    Returns
    -------
    T : (k, 3) float64
        Unit tangents, pointing in the direction of increasing index.

    Examples
    --------
    >>> t = np.linspace(0, np.pi, 50)
    >>> T = curve_tangents(np.c_[np.cos(t), np.sin(t), 0 * t])
    >>> bool(np.allclose(T[0], [0, 1, 0], atol=1e-6))
    True
    """
    P = as_points(P, "P", min_rows=2)
    u, sp = _spline(P)
    D = sp.derivative(1)(u)
    n = np.linalg.norm(D, axis=1)
    if np.any(n <= 0):
        raise FrameError("curve tangent vanishes; the curve doubles back on itself")
    return D / n[:, None]


def _double_reflection_maps(P, T):
    """Products ``M_i ... M_0`` of the double-reflection steps of Wang et al. (2008), (k-1, 3, 3).

    Step ``i`` reflects in the plane normal to ``v1 = P[i+1] - P[i]`` and then in
    the plane normal to ``v2 = T[i+1] - R1 T[i]``; neither depends on the frame
    being carried, so each step is a fixed orthogonal map ``M_i = R2 R1`` and the
    frames follow from prefix products, computed by doubling (log2 k vectorised
    matrix products instead of a Python loop over the samples).
    """
    v1 = np.diff(P, axis=0)
    c1 = np.einsum("ij,ij->i", v1, v1)
    if np.any(~(c1 > 0)):
        raise FrameError("curve has repeated consecutive points; remove duplicates")
    eye = np.eye(3)
    R1 = eye - (2.0 / c1)[:, None, None] * v1[:, :, None] * v1[:, None, :]
    v2 = T[1:] - np.einsum("nij,nj->ni", R1, T[:-1])
    c2 = np.einsum("ij,ij->i", v2, v2)
    # no second reflection where the reflected tangent already is the next one
    f2 = np.divide(2.0, c2, out=np.zeros_like(c2), where=c2 > tol.ZERO_VECTOR)
    R2 = eye - f2[:, None, None] * v2[:, :, None] * v2[:, None, :]
    C = R2 @ R1
    d = 1
    while d < len(C):
        C[d:] = C[d:] @ C[:-d]  # right side read before the write: old values (copy made by @)
        d *= 2
    return C


def rotation_minimizing_frames(P, tangents=None, initial_normal=None, method="double_reflection"):
    """Rotation-minimizing frame along a curve.

    Parameters
    ----------
    P : (k, 3) float64
        Curve points, one per row, k >= 2.
    tangents : (k, 3) float64, optional
        Unit tangents at the points. Estimated by :func:`curve_tangents` when
        omitted; exact tangents give fourth-order accuracy (Wang et al. 2008).
    initial_normal : (3,) float64, optional
        Direction of U at the first point; projected onto the plane normal to
        the first tangent. Default: the coordinate axis least aligned with the
        first tangent, projected (a fixed choice, not invariant under rotations).
    method : {"double_reflection", "rotation", "projection"}
        Double reflection (paper Section 1, ref. [3]) is fourth-order accurate;
        rotation (ref. [5]) and projection (ref. [4]) are second order.

    Returns
    -------
    T, U, V : (k, 3) float64 each
        Orthonormal frames: T the tangent, U the rotation-minimizing normal,
        ``V = T x U``.

    Raises
    ------
    FrameError
        If the initial normal is parallel to the first tangent, the curve has
        repeated points, or the method is unknown.

    Examples
    --------
    A planar curve started with the plane normal keeps it (no torsion):

    >>> t = np.linspace(0, 2 * np.pi, 40)
    >>> T, U, V = rotation_minimizing_frames(np.c_[t, np.sin(t), 0 * t],
    ...                                      initial_normal=[0, 0, 1])
    >>> float(np.abs(U - [0, 0, 1]).max()) < 1e-12
    True
    """
    P = as_points(P, "P", min_rows=2)
    k = len(P)
    if tangents is None:
        T = curve_tangents(P)
    else:
        T = as_points(tangents, "tangents", rows=k)
        n = np.linalg.norm(T, axis=1)
        # relative to the longest tangent, so that tangents in any unit work
        if np.any(~(n > np.sqrt(tol.ZERO_VECTOR) * n.max())):
            raise FrameError("a tangent is zero; give non-zero tangents or omit them")
        T = T / n[:, None]
    if initial_normal is None:
        r = perpendicular(T[0])
    else:
        r = as_vector(initial_normal, "initial_normal")
        m = float(np.abs(r).max())
        if not m > 0:
            raise FrameError("initial_normal is the zero vector; give a direction across the curve")
        r = r / m
        nr0 = np.linalg.norm(r)
        r = r - (r @ T[0]) * T[0]
        nr = np.linalg.norm(r)
        if not nr > tol.FRAME_ORTHONORMAL * nr0:  # relative: any unit works
            raise FrameError(
                "initial_normal is parallel to the first tangent; give a direction across the curve"
            )
        r = r / nr
    U = np.empty_like(T)
    U[0] = r
    if method == "double_reflection":
        U[1:] = _double_reflection_maps(P, T) @ r
    elif method == "rotation":
        for i in range(k - 1):
            U[i + 1] = minimal_rotation(T[i], T[i + 1]).apply(U[i])
    elif method == "projection":
        for i in range(k - 1):
            r = U[i] - (U[i] @ T[i + 1]) * T[i + 1]
            nr = np.linalg.norm(r)
            if nr < np.sqrt(tol.ZERO_VECTOR):
                raise FrameError("projection RMF breaks down: tangent turns by 90 degrees between samples")
            U[i + 1] = r / nr
    else:
        raise FrameError(
            f"unknown RMF method {method!r}; use 'double_reflection', 'rotation' or 'projection'"
        )
    # Re-orthonormalise against round-off (the reflections preserve it to ~1e-16 per step).
    U = U - np.sum(U * T, axis=1)[:, None] * T
    U /= np.linalg.norm(U, axis=1)[:, None]
    V = np.cross(T, U)
    return T, U, V


def transport_angle(T, U, W):
    """Signed angle about ``T`` from ``U`` to ``W`` (rows), in (-pi, pi].

    Parameters
    ----------
    T, U, W : (k, 3) float64
        Unit tangents, reference normals and the vectors to measure; ``W`` is
        projected onto the plane normal to ``T`` first.

    Returns
    -------
    angle : (k,) float64
        Radians, positive for a right-handed turn about ``T``.

    Examples
    --------
    >>> float(transport_angle([[0, 0, 1]], [[1, 0, 0]], [[0, 1, 0]])[0]) == np.pi / 2
    True
    """
    T = np.atleast_2d(np.asarray(T, float))
    U = np.atleast_2d(np.asarray(U, float))
    W = np.atleast_2d(np.asarray(W, float))
    x = np.sum(W * U, axis=1)
    y = np.sum(W * np.cross(T, U), axis=1)
    return np.arctan2(y, x)


@dataclass(frozen=True)
class FrenetResult:
    """Frenet quantities of a curve (the *Frenet torsion* of paper Section 1).

    Attributes
    ----------
    curvature : (k,) float64
        kappa = |m' x m''| / |m'|^3, per mesh unit.
    torsion : (k,) float64
        tau = (m' x m'') . m''' / |m' x m''|^2, per mesh unit; NaN where the
        curve is straight (``defined`` is False): the Frenet frame does not
        exist there, so neither does its torsion.
    normal : (k, 3) float64
        Principal normal; NaN where undefined.
    defined : (k,) bool
        False on straight stretches (``curvature * length_scale`` below
        :data:`vesselgp.tolerances.STRAIGHT_KAPPA_R`).
    """

    curvature: np.ndarray
    torsion: np.ndarray
    normal: np.ndarray
    defined: np.ndarray


def frenet(P, length_scale=None, *, smooth=False):
    """Frenet curvature, torsion and normal of a curve, from a quintic spline.

    Parameters
    ----------
    P : (k, 3) float64
        Curve points, k >= 4.
    length_scale : float, optional
        Scale (e.g. the vessel radius) below whose reciprocal the curvature
        counts as zero. Default: 1 % of the curve length.
    smooth : bool
        For noisy curves (a fitted axis): take derivatives of cubic smoothing
        splines with a smoothing length of a few ``length_scale``, and
        the torsion as the rate at which the curvature vector turns about the
        tangent relative to the RMF (tau = d phi / ds), which needs one
        derivative fewer than the triple-product formula.

    Returns
    -------
    FrenetResult

    Examples
    --------
    Helix (cos t, sin t, t/2): curvature 0.8, torsion 0.4.

    >>> t = np.linspace(0, 4 * np.pi, 200)
    >>> fr = frenet(np.c_[np.cos(t), np.sin(t), 0.5 * t])
    >>> bool(np.allclose(fr.curvature[5:-5], 0.8, atol=1e-4)), bool(np.allclose(fr.torsion[5:-5], 0.4, atol=1e-4))
    (True, True)
    """
    P = as_points(P, "P", min_rows=4)
    if smooth:
        return _frenet_smooth(P, length_scale)
    u, sp = _spline(P)
    d1, d2, d3 = (sp.derivative(j)(u) for j in (1, 2, 3))
    c = np.cross(d1, d2)
    nc = np.linalg.norm(c, axis=1)
    n1 = np.linalg.norm(d1, axis=1)
    kappa = nc / n1**3
    if length_scale is None:
        length_scale = 0.01 * u[-1]
    defined = kappa * float(length_scale) > tol.STRAIGHT_KAPPA_R
    tau = np.full(len(P), np.nan)
    tau[defined] = np.sum(c[defined] * d3[defined], axis=1) / nc[defined] ** 2
    T = d1 / n1[:, None]
    B = np.full_like(c, np.nan)
    B[defined] = c[defined] / nc[defined, None]
    N = np.cross(B, T)
    return FrenetResult(curvature=kappa, torsion=tau, normal=N, defined=defined)


def _frenet_smooth(P, length_scale):
    """Frenet quantities of a noisy curve (see :func:`frenet`, ``smooth=True``)."""
    u = chord_length(P)
    if length_scale is None:
        length_scale = 0.01 * u[-1]
    # smoothing length: a few length scales (curvature below a vessel radius is noise)
    h = u[-1] / (len(P) - 1)
    lam = (tol.FRENET_SMOOTHING_SCALES * float(length_scale)) ** 4 / h
    sps = [make_smoothing_spline(u, P[:, d], lam=lam) for d in range(3)]
    d1 = np.stack([sp.derivative(1)(u) for sp in sps], axis=1)
    d2 = np.stack([sp.derivative(2)(u) for sp in sps], axis=1)
    c = np.cross(d1, d2)
    nc = np.linalg.norm(c, axis=1)
    n1 = np.linalg.norm(d1, axis=1)
    kappa = nc / n1**3
    defined = kappa * float(length_scale) > tol.STRAIGHT_KAPPA_R_FITTED
    T = d1 / n1[:, None]
    T, U, V = rotation_minimizing_frames(P, T)
    kvec = d2 - np.sum(d2 * T, axis=1)[:, None] * T  # curvature direction, normal to T
    phi = np.arctan2(np.sum(kvec * V, axis=1), np.sum(kvec * U, axis=1))
    tau = np.full(len(P), np.nan)
    # each maximal run of defined samples gets its own smoothed phi(s)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], defined.astype(int), [0]])))
    for a, b in zip(edges[::2], edges[1::2]):
        if b - a >= tol.FRENET_MIN_RUN:
            # phi is smoothed like the points (the same smoothing length): the rate at
            # which the curvature direction turns is then free of the points' noise
            ph = make_smoothing_spline(u[a:b], np.unwrap(phi[a:b]), lam=lam)
            tau[a:b] = ph.derivative()(u[a:b])
    defined = defined & np.isfinite(tau)
    B = np.full_like(c, np.nan)
    B[defined] = c[defined] / nc[defined, None]
    N = np.cross(B, T)
    return FrenetResult(curvature=kappa, torsion=tau, normal=N, defined=defined)
