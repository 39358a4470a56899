"""Elliptic sections: the second harmonic of a wall's sections about its axis (issue #48).

Eq. 2's data term is Kasa's algebraic circle fit, ``|p|^2 = 2 c . p + d`` for the offsets ``p`` of the wall from
the axis in its normal planes. An ellipse's section has no first harmonic about its centre, so a whole section,
evenly weighted, still gives the centre. But an ellipse leaves a second harmonic in the residual, ``|p|^2 - d =
e_1 (x^2 - y^2) + e_2 (2 x y)`` about its centre, and anything that weighs the section unevenly round the axis
turns it into a first harmonic, a pull on the centre: Eq. 1's bend correction (the stretch ``1 - k . d``, a first
harmonic itself), a section cut by the axis's end where the end's tangent tilts (half of its vertices project past
the end and leave the data), the hat functions across a tilted section. The 2.5:1 vein swept along the real
coronary's line read 0.81 % r off in its bends of curvature x radius 0.4-0.7 (0.09 % r for circles on the same
line), and a circular arc swept with 2.5:1 ellipses turned 30 degrees at its end, its first radius 12 % r off, and
was refused (issue #48's flattened vein).

On a wall whose sections are elliptic (:attr:`SectionShape.elliptic`) the circle fit carries
each segment's second harmonic as two more unknowns, ``e_1`` and ``e_2``, constant over the segment and eliminated
there (:func:`vesselgp.axis.circle_fit_sums`): the fit is then exact for an ellipse about its centre however the
section is weighted, and its centre corrections are zero on the ellipse's own axis. The scatter that sets Eq. 2's
weight (:func:`vesselgp.fit.data_lambda`) is then the wall's about those ellipses (:func:`conic_residual`).
Walls as round as the real meshes' (their branches' median amplitude 0-0.22) keep the circle fit of the paper.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import tolerances as tol
from .axis import hat

__all__ = ["SectionShape", "section_shape", "conic_residual"]


def _segment_conics(j, x, y, w, K, centred, circle=False):
    """Each segment's weighted algebraic conic ``q = m (+ a x + b y) + e_1 (x^2 - y^2) + e_2 (2 x y)`` of the
    offsets ``(x, y)`` (``q = x^2 + y^2``) of rows in segments ``j`` of ``K`` nodes: the coefficients (K - 1, n),
    the residual of ``q`` at each row and the segments' row counts; with ``circle``, also the residual of the
    segments' circles (the leading columns alone, from the same sums)."""
    cols = (np.ones_like(x),) + ((x, y) if centred else ()) + (x * x - y * y, 2.0 * x * y)
    q = x * x + y * y
    n = len(cols)
    M, rhs = np.empty((K - 1, n, n)), np.empty((K - 1, n))
    for u in range(n):
        rhs[:, u] = np.bincount(j, w * cols[u] * q, K - 1)
        for v in range(u, n):
            M[:, u, v] = M[:, v, u] = np.bincount(j, w * cols[u] * cols[v], K - 1)
    # a segment with no data, or a ring that does not determine its conic, keeps a defined solve
    M += tol.GC_HARMONIC_RIDGE * np.maximum(M[:, :1, :1], np.finfo(float).tiny) * np.eye(n)

    def residual(k):
        coef = np.linalg.solve(M[:, :k, :k], rhs[:, :k, None])[..., 0]
        return coef, q - sum(coef[j, u] * cols[u] for u in range(k))

    coef, e = residual(n)
    count = np.bincount(j, None, K - 1)
    return (coef, e, count, residual(n - 2)[1]) if circle else (coef, e, count)


@dataclass(frozen=True)
class SectionShape:
    """How elliptic a wall's sections are about an axis (:func:`section_shape`).

    Attributes
    ----------
    amplitude : float
        The median over the axis's segments of their sections' second harmonic, ``(a^2 - b^2) / (a^2 + b^2)``
        for an ellipse of axes ``a >= b`` (0 for a circle, 0.72 for 2.5:1).
    explained : float
        The rms residual of the wall about its segments' ellipses over that about their circles: near 0 where
        the sections are ellipses, near 1 where the wall's departure from its circles is not elliptic (a
        segmented wall's staircase, noise, a branch's mouth).
    """

    amplitude: float
    explained: float

    @property
    def elliptic(self):
        """Whether the circle fit carries the sections' second harmonic: an amplitude over ``GC_ELLIPTIC`` that
        explains the wall's departure from its circles (``explained`` at most ``GC_ELLIPTIC_RESIDUAL``)."""
        return self.amplitude > tol.GC_ELLIPTIC and self.explained <= tol.GC_ELLIPTIC_RESIDUAL


def section_shape(s, local, w, K):
    """How elliptic a wall's sections are about an axis of ``K`` nodes (:class:`SectionShape`).

    Each segment of the axis gets its data vertices' circle (``q = m + a x + b y``, ``q = x^2 + y^2``) and
    conic (``+ e_1 (x^2 - y^2) + e_2 (2 x y)``), both with a free centre and in units of the segment's rms offset
    (an axis off the centre, as a first axis is, changes neither); segments with fewer than
    ``tolerances.GC_ELLIPTIC_MIN_VERTICES`` data vertices are not counted.

    Parameters
    ----------
    s : (q,) float64
        Normalised arc length of each vertex's foot.
    local : (q, 3) float64
        Its offset from the foot in the foot's frame (T, U, V).
    w : (q,) float64
        Data weights (0 leaves a vertex out).
    K : int
        Axis nodes.

    Returns
    -------
    SectionShape
        Amplitude 0 and ``explained`` 1 where no segment is counted.

    Examples
    --------
    A straight 2:1 elliptic tube, 32 points around and every 0.1 along, off its axis: (4 - 1) / (4 + 1), and
    all of its departure from circles explained.

    >>> t, z = np.linspace(0, 2 * np.pi, 33)[:-1], np.arange(0.0, 10.01, 0.1)
    >>> T, Z = np.meshgrid(t, z)
    >>> local = np.c_[0 * Z.ravel(), 2 * np.cos(T.ravel()) + 0.3, np.sin(T.ravel())]
    >>> shape = section_shape(Z.ravel() / 10, local, np.ones(T.size), 21)
    >>> round(shape.amplitude, 5), shape.explained < 1e-3, shape.elliptic
    (0.6, True, True)
    """
    sel = w > 0
    j, _ = hat(s[sel], K)
    x, y, ww = local[sel, 1], local[sel, 2], w[sel]
    n = np.bincount(j, ww, K - 1)
    rms = np.sqrt(np.bincount(j, ww * (x * x + y * y), K - 1) / np.maximum(n, np.finfo(float).tiny))
    scale = np.where(rms > 0, rms, 1.0)[j]
    x, y = x / scale, y / scale
    coef, e_conic, count, e_circle = _segment_conics(j, x, y, ww, K, centred=True, circle=True)
    ok = count >= tol.GC_ELLIPTIC_MIN_VERTICES
    if not ok.any():
        return SectionShape(0.0, 1.0)
    rows = ok[j]
    amp, wt = np.hypot(coef[ok, 3], coef[ok, 4]), n[ok]
    o = np.argsort(amp)
    c = np.cumsum(wt[o])
    circle = float(np.sum(ww[rows] * e_circle[rows] ** 2))
    explained = float(np.sqrt(np.sum(ww[rows] * e_conic[rows] ** 2) / circle)) if circle > 0 else 1.0
    return SectionShape(float(amp[o][np.searchsorted(c, 0.5 * c[-1])]), explained)


def conic_residual(s, local, w, radii):
    """``(rho - r) / r`` of the data vertices (weight > 0) about each segment's ellipse instead of its circle, to
    first order: half the residual of ``rho^2 / r^2`` after each segment's conic about the axis (``m + e_1 (x^2 -
    y^2) + e_2 (2 x y)``, :func:`vesselgp.fit.data_lambda`'s scatter for an elliptic wall), (q,) float64.

    ``radii`` (K,) are the fit's radii at its nodes (none before the first: an empty array is returned)."""
    if radii is None:
        return np.zeros(0)
    K = len(radii)
    sel = w > 0
    r = np.interp(s[sel], np.linspace(0, 1, K), radii)
    j, _ = hat(s[sel], K)
    x, y = local[sel, 1] / r, local[sel, 2] / r
    return 0.5 * _segment_conics(j, x, y, w[sel], K, centred=False)[1]
