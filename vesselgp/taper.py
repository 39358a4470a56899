"""The taper's coupling of a section's centre to the axis's tilt: a Newton step for Eq. 3's fixed point.

Eq. 3 moves each axis node to the centre of the wall's section normal to the current axis. On a tube
of constant radius a section tilted by a small angle ``delta`` off the true normal plane is an ellipse
centred on the true axis, so the iteration's error at a node is the node's own offset, removed in one
step. On a tapering tube (radius ``r(s)``, slope ``r' = dr/ds``) the tilted section is not centred:
on the side it tilts towards smaller ``s`` it meets the wall where the tube is wider when ``r' < 0``,
and its centre lies ``-r r' delta`` off the true axis (first order in ``delta``). The axis's tilt at
node ``j`` is the difference of its neighbours' offsets, ``delta_j = (x_{j+1} - x_{j-1}) / 2h`` on
nodes ``h`` apart, so the plain update ``x <- x + m(x)`` maps an offset ``x`` to ``-r r' D1 x``: a
first-difference operator whose gain on the mode of four nodes per wavelength is ``r |r'| / h``.
Past 1 the fixed point oscillates rather than settles (issue #48: the 4D-flow arch's supra-aortic
trunk, a cone narrowing threefold in nine of its radii, ``r |r'| / h`` up to 1.3, never converged and
stayed 1.4 % r off its exact line; closer nodes, with a larger gain, were refused as bending
tighter than the radius).

:func:`taper_step` solves the linearised fixed point instead, ``(I + A) Delta = m`` with
``(A Delta)_j = (r_j r'_j / 2h) P_j (Delta_{j+1} - Delta_{j-1})`` (``P_j`` the projection onto node
``j``'s normal plane): a Newton step whose fixed point is Eq. 3's (``Delta = 0`` exactly where the
correction ``m`` is), reached where the plain step's is not.
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import solve_banded

from . import tolerances as tol
from .errors import NotTubularError

__all__ = ["taper_step", "radius_slope"]

#: Offsets of the three components of a node's block from its neighbours' (banded storage: 5 each way).
_BAND = 5


def radius_slope(radii, h, window=None):
    """The radius's slope ``dr/ds`` at each node, a least-squares line through the nodes within
    ``window`` local radii of it (at least its two neighbours), (K,) float64.

    Parameters
    ----------
    radii : (K,) float64
        Radii at nodes ``h`` apart along the axis (mesh units).
    h : float
        Node spacing (mesh units).
    window : float, optional
        Half width in local radii; default ``tolerances.GC_TAPER_WINDOW``; at least 1.5 node spacings.
        Over one radius the fitted radii's scatter between nodes averages out (read from the neighbours
        alone, a cylinder fitted on nodes a tenth of its radius apart took it for slopes and was refused),
        and a taper's slope (the real arch trunk's changes over ten radii) does not.

    Examples
    --------
    >>> float(np.round(radius_slope(np.array([5.0, 4.5, 4.0, 3.5, 3.0]), 2.0)[2], 12))
    -0.25
    """
    radii = np.asarray(radii, dtype=np.float64)
    K = len(radii)
    x = h * np.arange(K)
    half = np.maximum((tol.GC_TAPER_WINDOW if window is None else window) * radii, 1.5 * h)  # neighbours, not theirs
    lo = np.searchsorted(x, x - half, side="left")
    hi = np.searchsorted(x, x + half, side="right")
    c = [np.concatenate([[0.0], np.cumsum(v)]) for v in (np.ones(K), x, radii, x * x, x * radii)]
    n, sx, sr, sxx, sxr = (v[hi] - v[lo] for v in c)
    return (n * sxr - sx * sr) / (n * sxx - sx * sx)


def taper_step(corr, radii, frames, length):
    """Eq. 3's circle-fit corrections ``corr`` turned into the Newton step of a tapering tube's fixed point.

    Parameters
    ----------
    corr : (K, 3) float64
        Each node's move to the centre of its section (Eq. 3, :func:`vesselgp.axis.circle_fit_solve`), ``m``.
    radii : (K,) float64
        The radii at the nodes (Eq. 5).
    frames : (K, 3, 3) float64
        The nodes' frames (rows T, U, V).
    length : float
        The axis's arc length; the nodes are ``length / (K - 1)`` apart.

    Returns
    -------
    (K, 3) float64
        ``Delta`` solving ``Delta_j + a_j P_j (Delta_{j+1} - Delta_{j-1}) = m_j`` at the interior nodes
        (``a_j = r_j r'_j / 2h``, ``r'`` from :func:`radius_slope`) and ``Delta_j = m_j`` at the end nodes
        (a pinned end's correction is zero). On a tube of constant radius ``Delta = m``.

    Raises
    ------
    NotTubularError
        Where the system is singular: the radius changes sign of slope between neighbouring nodes
        by a full node spacing's worth of radius (``a_j a_{j+1} = -1``), not a tube.

    Examples
    --------
    On a cylinder the step is the correction itself:

    >>> fr = np.tile(np.eye(3), (5, 1, 1))
    >>> m = np.array([[0, 0, 0], [0, 0.1, 0], [0, 0, 0.2], [0, 0.1, 0], [0, 0, 0]], float)
    >>> bool(np.allclose(taper_step(m, np.full(5, 2.0), fr, 4.0), m))
    True
    """
    K = len(corr)
    if K < 3:
        return corr
    h = length / (K - 1)
    a = radii * radius_slope(radii, h) / (2.0 * h)
    T = frames[1:-1, 0]
    P = np.eye(3)[None] - T[:, :, None] * T[:, None, :]  # (K - 2, 3, 3) projections onto the normal planes
    n = 3 * K
    ab = np.zeros((2 * _BAND + 1, n))
    ab[_BAND] = 1.0
    j = np.arange(1, K - 1)
    rows = 3 * j[:, None, None] + np.arange(3)[None, :, None]  # (K - 2, 3, 1)
    comp = np.arange(3)[None, None, :]
    for side in (1, -1):  # the neighbour j + side: +a_j P_j for j + 1, -a_j P_j for j - 1
        cols = 3 * (j + side)[:, None, None] + comp  # (K - 2, 1, 3)
        ab[(_BAND + rows - cols).ravel(), np.broadcast_to(cols, P.shape).ravel()] = \
            (side * a[1:-1, None, None] * P).ravel()
    try:
        out = solve_banded((_BAND, _BAND), ab, corr.reshape(-1), check_finite=False)
    except np.linalg.LinAlgError as err:
        raise NotTubularError(
            "mesh is not tubular: its radius turns from widening to narrowing within a node spacing (the "
            "taper's Newton step of the generalized-cylinder fit is singular); check the mesh, e.g. with "
            "vesselgp.clean_mesh") from err
    return out.reshape(K, 3)
