"""The wall's own circles along an axis, fitted with no smoothing (Eq. 2's circle fit without its lam term).

Used twice: by the fit's outlier test, which keeps a vertex that lies on the circle its neighbours along the axis
lie on however far that circle is from the smoothed fit (a stenosis the smoothed radius lags behind, a sparse
bend that Eq. 2's weight pulls the axis across; issue #48), and by the checks of a fit against its mesh, which
measure how far the axis runs from its wall's centre (:func:`vesselgp.checks.off_centre`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import tolerances as tol

__all__ = ["WallCircles", "wall_circles"]


@dataclass(frozen=True)
class WallCircles:
    """Circles fitted to the wall in windows along an axis (see :func:`wall_circles`).

    Attributes
    ----------
    s0 : (k,) float64
        The windows' centres, arc length in mesh units.
    centre : (k, 2) float64
        The circle's centre in the frame ``(U, V)`` about the axis, mesh units.
    radius : (k,) float64
        Its radius at ``s0``.
    slope : (k,) float64
        ``d(rho^2 - |c|^2) / ds``: how the circle's power changes along the window ...
    drift : (k, 2) float64
        ... and ``dc / ds``, how its centre moves.
    se : (k,) float64
        The standard error of ``centre`` (its larger principal value), mesh units.
    n : (k,) float64
        The vertices in each window.
    """

    s0: np.ndarray
    centre: np.ndarray
    radius: np.ndarray
    slope: np.ndarray
    drift: np.ndarray
    se: np.ndarray
    n: np.ndarray

    def residual(self, s, local, within):
        """How far vertices at ``s`` (mesh units) with offsets ``local`` ((q, 2)) lie outside (> 0) or inside the
        nearest window's circle, to first order (the power over twice the radius), and that circle's radius;
        both NaN where no window's centre is ``within`` ((q,) mesh units)."""
        if len(self.s0) > 1:
            k = np.clip(np.searchsorted(self.s0, s), 1, len(self.s0) - 1)
            k -= (s - self.s0[k - 1] < self.s0[k] - s)
        else:
            k = np.zeros(len(s), np.int64)
        t = s - self.s0[k]
        c, r = self.centre[k] + self.drift[k] * t[:, None], self.radius[k]
        power = ((local - c) ** 2).sum(axis=1) - r * r - self.slope[k] * t + (c * c).sum(axis=1) - (
            self.centre[k] ** 2).sum(axis=1)
        near = np.abs(s - self.s0[k]) <= within
        return np.where(near, power / (2.0 * r), np.nan), np.where(near, r, np.nan)


def wall_circles(s, local, use, radius, reach, step):
    """Least-squares circles of the wall in windows along an axis (Kasa's algebraic fit).

    In a window of ``reach`` radii either side of ``s0``, the used vertices' offsets ``p`` from their feet on the
    axis, in the feet's frames, are fitted as ``|p|^2 = 2 (c + c' t) . p + k + k' t``, ``t = s - s0``: a
    circle centred ``c`` from the axis, of radius ``sqrt(k + |c|^2)`` at ``s0``, its centre and its power
    changing linearly along the window (a bend the axis cuts, a taper). Exact for vertices on circles however far from the axis; an ellipse's and a regular polygon's
    sections have no first harmonic about their centre, so only an axis off the centre gives ``c``. Each
    window's normal equations come from running sums over the vertices in order of ``s`` (one pass). A window is
    kept when it has at least ``CHECK_CENTRE_MIN_VERTICES`` vertices spread round the axis (the smaller
    principal variance of ``p`` over the mean ``|p|^2`` at least ``CHECK_CENTRE_MIN_SPREAD``; a whole ring has
    0.5, half of one 0.095).

    Parameters
    ----------
    s : (q,) float64
        Each vertex's arc length at its foot (mesh units), non-decreasing.
    local : (q, 2) float64
        Its offset from its foot in the foot's frame ``(U, V)``.
    use : (q,) bool
        The vertices to fit.
    radius : callable
        The radius at arc lengths (mesh units), vectorised: windows' lengths and spacing are counted in it.
    reach : float
        The window's half-length, in radii.
    step : float
        The windows' spacing, in the smallest radius along the axis.

    Returns
    -------
    WallCircles

    Examples
    --------
    A unit tube's wall, 16 points around and every 0.1 along, its centre 0.3 from an axis along z: the 21
    windows, one every half radius, find it and its radius, with nothing left to scatter.

    >>> t, z = np.linspace(0, 2 * np.pi, 17)[:-1], np.arange(0.0, 10.01, 0.1)
    >>> T, Z = np.meshgrid(t, z)
    >>> local = np.c_[np.cos(T.ravel()) + 0.3, np.sin(T.ravel())]
    >>> c = wall_circles(Z.ravel(), local, np.ones(T.size, bool), lambda s: np.ones_like(s), 1.0, 0.5)
    >>> len(c.s0), np.round(c.centre[[0, -1]], 6).tolist(), np.round(c.radius[[0, -1]], 6).tolist()
    (21, [[0.3, 0.0], [0.3, 0.0]], [1.0, 1.0])
    >>> float(c.se.max()) < 1e-6
    True
    """
    ok = use
    s = s[ok]
    none = WallCircles(np.zeros(0), np.zeros((0, 2)), np.zeros(0), np.zeros(0), np.zeros((0, 2)), np.zeros(0),
                       np.zeros(0))
    if len(s) < tol.CHECK_CENTRE_MIN_VERTICES:
        return none
    p = local[ok]
    shift = 0.5 * (s[0] + s[-1])  # running sums about the middle: no cancellation in s^2 on long vessels
    t = s - shift
    X = (np.ones(len(s)), t, p[:, 0], p[:, 1], t * p[:, 0], t * p[:, 1], (p * p).sum(axis=1))
    rmin = float(np.min(radius(s)))
    s0 = np.arange(s[0], s[-1] + 0.5 * step * rmin, step * rmin)
    h = reach * radius(s0)
    lo, hi = np.searchsorted(s, s0 - h), np.searchsorted(s, s0 + h, side="right")
    S = _window_sums(X, lo, hi)
    Tr = np.broadcast_to(np.eye(7), S.shape).copy()  # the sums in (1, s - s0, p, (s - s0) p, |p|^2) from those
    Tr[:, 1, 0] = Tr[:, 4, 2] = Tr[:, 5, 3] = shift - s0  # in s - shift
    S = Tr @ S @ Tr.transpose(0, 2, 1)
    n = S[:, 0, 0]
    nn = np.maximum(n, 1.0)
    mu = S[:, 0, 2:4] / nn[:, None]
    cov_p = S[:, 2:4, 2:4] / nn[:, None, None] - mu[:, :, None] * mu[:, None, :]
    mean_sq = np.maximum(S[:, 0, 6] / nn, np.finfo(float).tiny)
    keep = (n >= tol.CHECK_CENTRE_MIN_VERTICES) & (
        np.linalg.eigvalsh(cov_p)[:, 0] >= tol.CHECK_CENTRE_MIN_SPREAD * mean_sq)
    if not keep.any():
        return none
    S, n, s0, h = S[keep], n[keep], s0[keep], h[keep]
    M, b = S[:, :6, :6].copy(), S[:, :6, 6]
    ridge = tol.WALL_CIRCLE_RIDGE * n * h * h  # the changes along a window that holds one ring: none
    M[:, 1, 1] += ridge
    M[:, 4, 4] += ridge * mean_sq[keep]
    M[:, 5, 5] += ridge * mean_sq[keep]
    Minv = np.linalg.inv(M)
    coef = np.einsum("kij,kj->ki", Minv, b)  # k, k', 2 c, 2 c'
    rss = np.maximum(S[:, 6, 6] - np.einsum("ki,ki->k", b, coef), 0.0)
    c = 0.5 * coef[:, 2:4]
    var_c = 0.25 * np.linalg.eigvalsh(Minv[:, 2:4, 2:4])[:, 1] * rss / np.maximum(n - 6.0, 1.0)
    r = np.sqrt(np.maximum(coef[:, 0] + (c * c).sum(axis=1), 0.0))
    ok = r > 0  # a window whose points fit no circle (power <= 0: not a wall about its axis) is not kept
    return WallCircles(s0[ok], c[ok], r[ok], coef[ok, 1], 0.5 * coef[ok, 4:6], np.sqrt(var_c[ok]), n[ok])


def _window_sums(X, lo, hi):
    """``sum_{lo <= i < hi} X[a][i] X[b][i]`` for every window (k,) and pair of columns ``X`` (m arrays of n): (k,
    m, m), from the sums over the pieces between the windows' bounds (each product summed once over the rows;
    a running sum per row took a 534k-vertex tube's check 1 s)."""
    n, m = len(X[0]), len(X)
    bounds = np.unique(np.r_[0, lo, hi, n])
    starts = bounds[:-1]
    i0, i1 = np.searchsorted(bounds, lo), np.searchsorted(bounds, hi)
    S = np.empty((len(lo), m, m))
    for a in range(m):
        for b in range(a, m):
            cum = np.r_[0.0, np.cumsum(np.add.reduceat(X[a] * X[b], starts))]
            S[:, a, b] = S[:, b, a] = cum[i1] - cum[i0]
    return S
