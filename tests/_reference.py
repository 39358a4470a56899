"""Ground truth for the tests that does not use vesselgp's own code (issue #12, section 6).

Everything here is numpy/scipy only, so a bug in :mod:`vesselgp` cannot hide
in the truth it is checked against:

* :func:`helix` -- a helix with its exact rotation-minimizing frame (RMF) in
  closed form (the Frenet normal turned by minus the integrated torsion);
* :func:`rmf_ode` / :func:`rmf_of_points` -- the RMF of any smooth curve by
  integrating the transport ODE ``dU/dt = -(U . T'(t)) T(t)`` with
  :func:`scipy.integrate.solve_ivp` (the definition of the RMF, Bishop 1975),
  on an analytic curve or on a quintic spline through sampled points;
* :func:`signed_angle` -- the angle about ``T`` from ``A`` to ``B``;
* :func:`polyline_distance` -- exact distance from points to a polyline;
* :func:`material_twist` -- an independent torsion meter for a deformed mesh
  whose rest arc length per vertex is known: bin centroids, a smooth axis
  through them, its ODE RMF, the circular mean of each vertex's angle change.
"""
from __future__ import annotations

import numpy as np
from numpy.polynomial import Chebyshev
from scipy.integrate import solve_ivp
from scipy.interpolate import make_interp_spline
from scipy.spatial import cKDTree


def arc_length(P):
    """Cumulative chord length (k,) of the polyline ``P`` (k, 3), 0 at its first point."""
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])


def unit(X):
    X = np.asarray(X, float)
    return X / np.linalg.norm(X, axis=-1, keepdims=True)


def wrap(a):
    """Angles wrapped to (-pi, pi]."""
    return np.angle(np.exp(1j * np.asarray(a, float)))


def signed_angle(T, A, B):
    """Angle (radians) about unit ``T`` from ``A`` to ``B`` (rows), both projected onto the normal plane."""
    T, A, B = (np.atleast_2d(np.asarray(x, float)) for x in (T, A, B))
    A = A - np.sum(A * T, axis=1)[:, None] * T
    return np.arctan2(np.sum(np.cross(A, B) * T, axis=1), np.sum(A * B, axis=1))


# ----------------------------------------------------------------------------- closed forms


def helix(t, a=1.0, c=0.5):
    """Helix ``(a cos t, a sin t, c t)``: points, exact unit tangents and exact RMF normals.

    The Frenet frame turns about T at the torsion ``tau = c / (a^2 + c^2)`` per unit
    length; the RMF normal is the Frenet normal turned by ``-tau s`` (``s = t sqrt(a^2 + c^2)``),
    which is zero at ``t = 0``.
    """
    t = np.asarray(t, float)
    w = np.hypot(a, c)
    P = np.c_[a * np.cos(t), a * np.sin(t), c * t]
    T = np.c_[-a * np.sin(t), a * np.cos(t), np.full_like(t, c)] / w
    N = np.c_[-np.cos(t), -np.sin(t), 0 * t]
    B = np.cross(T, N)
    phi = -c / w * t  # -tau * s
    U = np.cos(phi)[:, None] * N + np.sin(phi)[:, None] * B
    return P, T, U


# ----------------------------------------------------------------------------- RMF by the transport ODE


def rmf_ode(t, d1, d2, U0, rtol=1e-11, atol=1e-12):
    """RMF normals at parameters ``t`` of a curve given by its derivatives.

    Parameters
    ----------
    t : (k,) increasing parameters (any parameterisation: the ODE is invariant).
    d1, d2 : callables t -> (3,), first and second derivative of the curve.
    U0 : (3,) the normal at ``t[0]`` (projected onto the normal plane).

    Returns
    -------
    T, U : (k, 3) unit tangents and RMF normals.
    """
    def tangent_and_rate(x):
        a, b = np.asarray(d1(x), float), np.asarray(d2(x), float)
        n = np.linalg.norm(a)
        T = a / n
        return T, (b - (b @ T) * T) / n  # dT/dt

    def rhs(x, U):
        T, dT = tangent_and_rate(x)
        return -(U @ dT) * T

    T0, _ = tangent_and_rate(t[0])
    U0 = np.asarray(U0, float)
    U0 = unit(U0 - (U0 @ T0) * T0)
    sol = solve_ivp(rhs, (t[0], t[-1]), U0, method="DOP853", t_eval=t, rtol=rtol, atol=atol)
    assert sol.success, sol.message
    U = sol.y.T
    T = np.array([tangent_and_rate(x)[0] for x in t])
    U = unit(U - np.sum(U * T, axis=1)[:, None] * T)
    return T, U


def curve_spline(P):
    """Quintic interpolating spline of points over chord length: (u, spline)."""
    P = np.asarray(P, float)
    u = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
    return u, make_interp_spline(u, P, k=5)


def rmf_of_points(P, U0, at=None):
    """Reference RMF of the smooth curve through samples ``P`` (quintic spline, ODE transport).

    ``at``: chord-length parameters where the frame is wanted (default: at the samples).
    Returns ``(T, U)``.
    """
    u, sp = curve_spline(P)
    d1, d2 = sp.derivative(1), sp.derivative(2)
    return rmf_ode(u if at is None else np.asarray(at, float), d1, d2, U0)


# ----------------------------------------------------------------------------- distances


def polyline_distance(Q, P):
    """Distance from each row of Q to the polyline P (exact, segment-wise)."""
    Q, P = np.asarray(Q, float), np.asarray(P, float)
    _, j = cKDTree(P).query(Q)
    best = np.full(len(Q), np.inf)
    for jj in (np.clip(j - 1, 0, len(P) - 2), np.clip(j, 0, len(P) - 2)):
        A, B = P[jj], P[jj + 1]
        ab = B - A
        t = np.clip(np.sum((Q - A) * ab, 1) / np.sum(ab * ab, 1), 0, 1)
        best = np.minimum(best, np.linalg.norm(Q - (A + t[:, None] * ab), axis=1))
    return best


# ----------------------------------------------------------------------------- independent torsion meter


def _smooth_axis(s, centroids, degree):
    """Least-squares Chebyshev polynomials of the bin centroids: derivative callables in s."""
    fits = [Chebyshev.fit(s, centroids[:, k], degree, domain=[0.0, 1.0]) for k in range(3)]
    der = [[f.deriv(m) for f in fits] for m in (1, 2)]

    def point(x):
        return np.stack([f(x) for f in fits], axis=-1)

    def d(m):
        return lambda x: np.array([g(x) for g in der[m - 1]])

    return point, d(1), d(2)


def _section_centres(X, b, n_bins, sb, degree):
    """Axis points per bin: the centroid, corrected by a circle fit in the normal plane.

    The centroid of a bin's vertices sits off the centre of a bent tube (by about
    ``kappa r^2 / 2``) and off it wherever the vertices are unevenly spread around;
    an algebraic (Kasa) circle fit of the vertices projected onto the plane normal
    to the centroid curve is exact for points on a circle, however they are spread.
    """
    cnt = np.bincount(b, minlength=n_bins)
    cen = np.stack([np.bincount(b, X[:, k], n_bins) for k in range(3)], 1) / cnt[:, None]
    _, d1, _ = _smooth_axis(sb, cen, degree)
    out = cen.copy()
    for k in range(n_bins):
        Y = X[b == k] - cen[k]
        t = unit(d1(sb[k]))
        e1 = unit(np.cross(t, [1.0, 0, 0] if abs(t[0]) < 0.9 else [0, 1.0, 0]))
        e2 = np.cross(t, e1)
        y = np.c_[Y @ e1, Y @ e2]
        A = np.c_[2 * y, np.ones(len(y))]
        c = np.linalg.lstsq(A, np.sum(y * y, axis=1), rcond=None)[0]
        out[k] = cen[k] + c[0] * e1 + c[1] * e2
    return out


def material_twist(V_rest, V_def, s, *, n_bins=30, degree=9, U0=None):
    """Material twist alpha(s) of a deformation, measured without vesselgp.

    Each vertex keeps its rest arc length ``s`` (in [0, 1], known exactly for
    synthetic vessels and kept by vesselgp's deformations, which move whole
    sections). Per bin of ``s``, a circle fit of the vertices gives a point of the
    axis; a Chebyshev least-squares curve through these points is the axis, its
    RMF is integrated (ODE) from the same ``U0`` at s = 0 in both states, and
    alpha is the circular mean, per bin, of the change of each vertex's angle
    about the axis from the RMF normal, unwrapped along s. The two states must
    share the s = 0 end (it is held in place).

    Returns
    -------
    sb : (n_bins,) bin centres (mean s of the bin's vertices)
    alpha : (n_bins,) radians, unwrapped; subtract ``alpha[0]`` for the twist from the first bin
    """
    s = np.asarray(s, float)
    b = np.minimum((s * n_bins).astype(int), n_bins - 1)
    cnt = np.bincount(b, minlength=n_bins)
    assert cnt.min() >= 6, "every bin needs vertices"
    sb = np.bincount(b, s, n_bins) / cnt
    grid = np.linspace(0.0, 1.0, 401)
    theta = []
    for X in (np.asarray(V_rest, float), np.asarray(V_def, float)):
        centres = _section_centres(X, b, n_bins, sb, degree)
        point, d1, d2 = _smooth_axis(sb, centres, degree)
        if U0 is None:
            t0 = unit(d1(0.0))
            U0 = np.cross(t0, [1.0, 0, 0] if abs(t0[0]) < 0.9 else [0, 1.0, 0])
        Tg, Ug = rmf_ode(grid, d1, d2, U0)
        # frames at each vertex's s: linear interpolation of the dense frames, re-orthonormalised
        T = unit(np.stack([np.interp(s, grid, Tg[:, k]) for k in range(3)], 1))
        U = np.stack([np.interp(s, grid, Ug[:, k]) for k in range(3)], 1)
        U = unit(U - np.sum(U * T, axis=1)[:, None] * T)
        theta.append(signed_angle(T, U, X - point(s)))
    d = wrap(theta[1] - theta[0])
    z = np.bincount(b, np.cos(d), n_bins) + 1j * np.bincount(b, np.sin(d), n_bins)
    return sb, np.unwrap(np.angle(z))


def swept_axis_errors(ves, gc, edge=2.0):
    """A swept synthetic vessel's exact centre line -> fitted axis polyline ``gc.dense_points``, in % of the local
    radius, ``edge`` radii from each end cut (the swept spline is the truth, never the fit)."""
    t = ves.truth
    st = t.s * t.length
    inner = (st > edge * t.radii[0]) & (st < t.length - edge * t.radii[-1])
    return 100 * polyline_distance(t.centers[inner], gc.dense_points) / t.radii[inner]


#: A uniform twist of 1.2 rad and a ramp of pi over s in [0.3, 0.7] (a raised cosine), each with its derivative
#: in normalised arc length: the imposed twists of the swept real shapes (docs/accuracy.md).
SWEPT_TWISTS = {
    "uniform": (lambda s: 1.2 * np.asarray(s, float), lambda s: np.full_like(np.asarray(s, float), 1.2)),
    "ramp": (lambda s: np.pi * 0.5 * (1 - np.cos(np.pi * np.clip((np.asarray(s, float) - 0.3) / 0.4, 0, 1))),
             lambda s: np.where((np.asarray(s) > 0.3) & (np.asarray(s) < 0.7),
                                np.pi * 0.5 * np.pi / 0.4 * np.sin(np.pi * (np.asarray(s, float) - 0.3) / 0.4), 0.0)),
}


def imposed_twist_errors(prof, gc, truth, alpha, dalpha):
    """A measured torsion profile ``prof`` against the twist ``alpha`` (of the exact centre line's normalised arc
    length, derivative ``dalpha``) imposed on a swept tube whose fit ``gc`` may run from either end: the worst
    alpha error in degrees over the interior 90 % of s, and the Eq. 8 energy's error in % of the exact
    ``int alpha'^2 ds`` (None for a twist without energy, whose relative error is undefined)."""
    reverse = np.linalg.norm(gc.centers[0] - truth.centers[0]) > np.linalg.norm(gc.centers[0] - truth.centers[-1])
    s_true = 1 - prof.s if reverse else prof.s
    a_true = alpha(s_true) - alpha(s_true[0])
    if reverse:
        a_true = -a_true  # T points the other way, so the rotation about it changes sign
    inner = (prof.s > 0.05) & (prof.s < 0.95)
    err = float(np.degrees(np.abs(prof.alpha - a_true)[inner].max()))
    s = np.linspace(0, 1, 20001)
    e_true = float(np.trapezoid(dalpha(s) ** 2, s))
    return err, (100.0 * (prof.energy - e_true) / e_true if e_true > 0 else None)


def free_stage_at_edge(ves, side, monkeypatch, caplog):
    """A swept vessel's default fit with ``GC_FREE_PULL`` (the limit of Eq. 2's pull above which a clean wall's fit
    is freed of it, vesselgp.fit.freed) at ``side`` times that fit's own pull, read with the stage off: the fit
    with the stage off, the one at the edge, whether the latter was freed (its INFO) and both fits'
    ``swept_axis_errors``."""
    import logging

    import vesselgp
    from vesselgp import tolerances as tol
    from vesselgp.fit import _second_difference_pull

    monkeypatch.setattr(tol, "GC_FREE_PULL", np.inf)
    first = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    ends = vesselgp.vessel_ends(ves.V, ves.F)
    rscale = 0.5 * (ends[first.ends[0]].radius + ends[first.ends[1]].radius)
    pull = first.final_lam * _second_difference_pull(first.centers, (True, True), rscale)
    monkeypatch.setattr(tol, "GC_FREE_PULL", side * pull)
    with caplog.at_level(logging.INFO, logger="vesselgp.fit"):
        gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    freed = any("fitted again with the weight on the step only" in r.getMessage() for r in caplog.records)
    return first, gc, freed, swept_axis_errors(ves, first), swept_axis_errors(ves, gc)
