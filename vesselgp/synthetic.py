"""Synthetic vessels with known medial axis, radius and twist (issue #3).

A vessel is swept along a 3D curve with the curve's rotation-minimizing frame
(RMF, paper Section 1), never with the Frenet frame (which turns by the
integral of the Frenet torsion) nor with sweeps that add spurious twist along
curved paths. The surface is

    X(s, theta) = m(s) + rho(s, theta) [cos(theta + alpha(s)) U(s) + sin(theta + alpha(s)) V(s)]

with ``m`` the axis parameterized by normalized arc length ``s`` in [0, 1],
``{T, U, V}`` its RMF, ``theta`` the *material* angle of a surface point (its
angle about T from U before twisting), ``alpha(s)`` the imposed material twist
(the angle of paper Fig. 1 / Eq. 7) and ``rho`` the section in polar form.

Radius convention: the ``radius`` argument r(s) (times the axisymmetric
bulge factors) is the **mean distance from the centre along the perimeter** of
the cross-section, the quantity that paper Eq. 4 estimates from the vertices
(isotropic meshes have vertices spread evenly along the perimeter). An elliptic
section ``x = a cos(phi), y = b sin(phi)`` with ``b / a = ellipticity`` is scaled
so that this mean equals r(s). Angular bulges (the aortic sinuses) are added on
top; :attr:`GroundTruth.radii` always holds the perimeter-mean distance of the
final section, computed by quadrature.

The ground-truth RMF does not come from :mod:`vesselgp.curves` (issue #12: a
bug there must not be shared by the truth and the code it checks). It is the
solution of the RMF (Bishop, parallel transport) equation

    dU/ds = -(U . T'(s)) T(s)

on the exact quintic spline of the axis, integrated by
:func:`scipy.integrate.solve_ivp` (DOP853) over each sample interval, where
the spline is one polynomial, and re-orthonormalised against the exact
tangent. It agrees with the closed forms (helix, twisted cubic, planar
curves, straight line: tests/test_truth.py) to about 1e-14 rad at the samples
and 1e-11 rad between them (cubic interpolation of U).

After optional isotropic remeshing every vertex is projected onto the exact
surface, so the ground truth ``(s, theta)`` of every vertex is exact, not an
approximation of the remeshed surface.

Examples
--------
>>> v = synthetic_vessel("arc", radius=1.5, n_around=16, remesh=False)
>>> v.V.shape[1], v.F.dtype, v.truth.units
(3, dtype('int64'), 'unit')
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Callable, NamedTuple

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import make_interp_spline
from scipy.spatial import cKDTree

from . import tolerances as tol
from ._validate import as_points, as_vector
from .curves import chord_length
from .errors import FrameError, InvalidMeshError, VesselError
from .rotations import (
    minimal_rotation,
    perpendicular,
    rotate,
    rotation_matrix,
    unit,
    wrap_angle,
)

from .synthetic_scans import ScanPair, twist_pair  # noqa: E402
from .synthetic_tree import (THREE_TIP_PARENTS, SyntheticTree, TreeBranch, TreeEnd, TreePath, TreeTruth,  # noqa: E402
                             synthetic_arterial_tree, synthetic_tree, tree_parents)

__all__ = [
    "named_curve",
    "CURVE_NAMES",
    "synthetic_vessel",
    "deform_synthetic",
    "SyntheticVessel",
    "GroundTruth",
    "paper_case",
    "JoinCase",
    "signed_volume",
    # vessel trees (vesselgp.synthetic_tree), re-exported here
    "synthetic_tree",
    "synthetic_arterial_tree",
    # two scans with side branches and a known twist (vesselgp.synthetic_scans)
    "twist_pair",
    "ScanPair",
    "tree_parents",
    "THREE_TIP_PARENTS",
    "SyntheticTree",
    "TreeTruth",
    "TreeBranch",
    "TreeEnd",
    "TreePath",
]

log = logging.getLogger(__name__)

#: Names accepted by :func:`named_curve`, with their length unit.
CURVE_NAMES = {
    "straight": "unit",
    "arc": "unit",
    "helix": "unit",
    "s_curve": "unit",
    "aortic_arch": "mm",
    "aortic_root": "mm",
}


# ---------------------------------------------------------------------------
# Named centre lines
# ---------------------------------------------------------------------------


def named_curve(name, n=None, **params):
    """Dense samples of a named centre line.

    All curves start at the origin. Defaults are chosen so that a radius-1.5
    tube does not self-intersect (bend radius >= 6 tube radii).

    ``"straight"`` (``length=30``)
        Segment along +z.
    ``"arc"`` (``bend_radius=10``, ``angle=pi``)
        Circular arc in the xz-plane starting along +z; a half circle by default.
    ``"helix"`` (``radius=8``, ``pitch=20``, ``turns=1.5``)
        Right-handed helix about z, ``(a cos t - a, a sin t, c t)``, ``c = pitch / 2 pi``;
        curvature ``a / (a^2 + c^2)`` (bend radius 9.3) and Frenet torsion
        ``c / (a^2 + c^2)`` per unit length.
    ``"s_curve"`` (``length=40``, ``amplitude=4``)
        Planar ``(A sin(2 pi z / L), 0, z)``, one full period: an S with an
        inflection at its middle (where the Frenet frame flips, paper Section 1).
    ``"aortic_arch"`` (mm: ``ascending=50``, ``arch_radius=32``, ``out_of_plane=15``, ``descending=100``)
        Ascending aorta rising along +z from the root, a half-turn arch of radius
        ``arch_radius`` towards +x that drifts ``out_of_plane`` mm along -y
        (the arch is not planar), and the descending aorta going down along -z.
    ``"aortic_root"`` (mm: ``length=30``, ``bow=2``)
        Short, slightly bowed segment ``(bow (z / L)^2, 0, z)`` from the annulus
        (s = 0) to the sinotubular junction (s = 1); give its radius profile
        three sinus bulges with ``bulges=[{"s0": .., "lobes": 3, ..}]``.

    Parameters
    ----------
    name : str
        One of :data:`CURVE_NAMES`.
    n : int, optional
        Number of samples (default :data:`vesselgp.tolerances.SYNTH_CURVE_SAMPLES`).
    **params
        Shape parameters listed above.

    Returns
    -------
    P : (n, 3) float64
        Samples, not uniformly spaced in arc length (reparameterized by
        :func:`synthetic_vessel`).

    Raises
    ------
    VesselError
        Unknown name or parameter, or a non-positive size.

    Examples
    --------
    >>> P = named_curve("arc", n=101, bend_radius=10.0)
    >>> P.shape, bool(np.allclose(np.linalg.norm(P - [10, 0, 0], axis=1), 10))
    ((101, 3), True)
    """
    n = tol.SYNTH_CURVE_SAMPLES if n is None else int(n)
    if n < 8:
        raise InvalidMeshError(f"named_curve needs n >= 8 samples, got {n}")
    p = _curve_params(name, params)
    if name == "aortic_arch":
        return _aortic_arch(n, p)
    return _simple_curve(name, np.linspace(0.0, 1.0, n), p)


#: Shape parameters of each named curve and their defaults (see :func:`named_curve`).
_CURVE_DEFAULTS = {
    "straight": {"length": 30.0},
    "arc": {"bend_radius": 10.0, "angle": math.pi},
    "helix": {"radius": 8.0, "pitch": 20.0, "turns": 1.5},
    "s_curve": {"length": 40.0, "amplitude": 4.0},
    "aortic_arch": {"ascending": 50.0, "arch_radius": 32.0, "out_of_plane": 15.0, "descending": 100.0},
    "aortic_root": {"length": 30.0, "bow": 2.0},
}

#: Parameters that may be zero or negative (offsets, not sizes).
_SIGNED_CURVE_PARAMS = ("amplitude", "bow", "out_of_plane")


def _curve_params(name, params):
    """The defaults of curve ``name`` updated by ``params`` (floats), validated.

    Raises
    ------
    VesselError
        Unknown name or parameter, or a non-positive or non-finite size.
    """
    if name not in _CURVE_DEFAULTS:
        raise VesselError(f"unknown curve name {name!r}; use one of {sorted(_CURVE_DEFAULTS)}")
    defaults = _CURVE_DEFAULTS[name]
    unknown = set(params) - set(defaults)
    if unknown:
        raise VesselError(f"curve {name!r} has no parameter(s) {sorted(unknown)}; use {sorted(defaults)}")
    p = {**defaults, **{k: float(v) for k, v in params.items()}}
    positive = {k: v for k, v in p.items() if k not in _SIGNED_CURVE_PARAMS}
    if any(not (v > 0 and np.isfinite(v)) for v in positive.values()):
        raise VesselError(f"curve {name!r} needs positive finite sizes, got {positive}")
    return p


def _simple_curve(name, t, p):
    """Samples of a one-piece named curve at parameters ``t`` (k,) in [0, 1]; (k, 3) float64."""
    z0 = np.zeros_like(t)
    if name == "straight":
        return np.c_[z0, z0, p["length"] * t]
    if name == "arc":
        R, a = p["bend_radius"], p["angle"] * t
        return np.c_[R * (1 - np.cos(a)), z0, R * np.sin(a)]
    if name == "helix":
        a, c = p["radius"], p["pitch"] / (2 * math.pi)
        u = 2 * math.pi * p["turns"] * t
        return np.c_[a * np.cos(u) - a, a * np.sin(u), c * u]
    if name == "s_curve":
        z = p["length"] * t
        return np.c_[p["amplitude"] * np.sin(2 * math.pi * z / p["length"]), z0, z]
    # aortic root
    return np.c_[p["bow"] * t**2, z0, p["length"] * t]


def _aortic_arch(n, p):
    """``n`` samples of the aortic arch: three C1-joined pieces, samples shared out by length."""
    A, R, h, D = p["ascending"], p["arch_radius"], p["out_of_plane"], p["descending"]
    la = math.pi * R
    w = np.array([A, la, D]) / (A + la + D)
    na, nb = max(2, int(round(n * w[0]))), max(2, int(round(n * w[1])))
    nd = max(2, n - na - nb + 2)
    ta = np.linspace(0, 1, na)
    asc = np.c_[0 * ta, 0 * ta, A * ta]
    u = np.linspace(0, math.pi, nb)[1:]
    arch = np.c_[R * (1 - np.cos(u)), -0.5 * h * (1 - np.cos(u)), A + R * np.sin(u)]
    td = np.linspace(0, 1, nd)[1:]
    desc = np.c_[np.full_like(td, 2 * R), np.full_like(td, -h), A - D * td]
    return np.concatenate([asc, arch, desc])


# ---------------------------------------------------------------------------
# The true axis: spline over normalized arc length + RMF
# ---------------------------------------------------------------------------




class _Axis:
    """Axis curve m(s), s in [0, 1] normalized arc length, with its RMF.

    Defined by K samples (uniform in s): quintic spline of the centres, cubic
    spline of the RMF normals (:func:`_integrated_rmf` at the samples)
    re-orthogonalized against the exact tangent.
    """

    def __init__(self, s, centers, U):
        self.s = s
        self.centers = centers
        self._m = make_interp_spline(s, centers, k=5)
        self._dm = self._m.derivative(1)
        self._ddm = self._m.derivative(2)
        self._U = make_interp_spline(s, U, k=3)
        self.length = _polyline_length(centers)

    def point(self, s):
        return self._m(s)

    def frames(self, s):
        """T, U, V at ``s`` (any shape), each ``s.shape + (3,)``."""
        d = self._dm(s)
        T = d / np.linalg.norm(d, axis=-1, keepdims=True)
        U = self._U(s)
        U = U - np.sum(U * T, axis=-1, keepdims=True) * T
        U /= np.linalg.norm(U, axis=-1, keepdims=True)
        return T, U, np.cross(T, U)

    def curvature(self, s):
        d1, d2 = self._dm(s), self._ddm(s)
        return np.linalg.norm(np.cross(d1, d2), axis=-1) / np.linalg.norm(d1, axis=-1) ** 3

    def project(self, X):
        """Normalized arc length of the foot of each point on the axis (unclipped Newton).

        The foot point is where ``(x - m(s)) . m'(s) = 0``: the cross-section
        plane through the point. Started from the nearest dense sample, refined
        by Newton steps on the exact spline.
        """
        _, idx = cKDTree(self.centers).query(X)
        s = self.s[idx].astype(float)
        for _ in range(tol.SYNTH_NEWTON_STEPS):
            d = X - self._m(s)
            d1, d2 = self._dm(s), self._ddm(s)
            g = np.sum(d * d1, axis=1)
            dg = -np.sum(d1 * d1, axis=1) + np.sum(d * d2, axis=1)
            s = np.clip(s - g / dg, -0.5, 1.5)
        return s


def _polyline_length(P):
    """Length of the polyline through ``P`` (k, 3); float."""
    return float(np.sum(np.linalg.norm(np.diff(P, axis=0), axis=1)))


def _arc_length_samples(P, K=None):
    """``K`` points uniform in arc length along the quintic chord-length spline of ``P``.

    Parameters
    ----------
    P : (k, 3) float64
        Curve points, k >= 4.
    K : int, optional
        Default :data:`vesselgp.tolerances.SYNTH_AXIS_SAMPLES`.

    Returns
    -------
    centers : (K, 3) float64

    Raises
    ------
    FrameError
        Repeated consecutive points, or a vanishing tangent (a cusp: the
        curve doubles back on itself).
    """
    P = as_points(P, "curve", min_rows=4)
    K = tol.SYNTH_AXIS_SAMPLES if K is None else int(K)
    u = chord_length(P)
    if np.any(np.diff(u) <= 0):
        raise FrameError("curve has repeated consecutive points; remove duplicates")
    sp = make_interp_spline(u, P, k=5 if len(P) > 5 else 3)
    ug = np.linspace(0.0, u[-1], tol.SYNTH_ARCLENGTH_QUADRATURE)
    d = sp.derivative(1)(ug)
    speed = np.linalg.norm(d, axis=1)
    # a zero of the speed between two grid points shows as a reversed tangent
    if np.any(speed <= 0) or np.any(np.einsum("ij,ij->i", d[1:], d[:-1]) <= 0):
        raise FrameError("curve tangent vanishes; the curve doubles back on itself")
    arc = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(ug))])
    target = np.linspace(0.0, arc[-1], K)
    return sp(np.interp(target, arc, ug))


def _arc_length_axis(P, initial_normal, K=None):
    """Resample a curve uniformly in arc length and build its RMF axis (:class:`_Axis`)."""
    return _axis_from_centers(_arc_length_samples(P, K), initial_normal)


def _axis_from_centers(centers, initial_normal):
    """The :class:`_Axis` through ``centers`` (K, 3), uniform in s, with U(0) from ``initial_normal``."""
    s = np.linspace(0.0, 1.0, len(centers))
    _, U = _integrated_rmf(s, centers, initial_normal)
    return _Axis(s, centers, U)


def _unit_tangents(spline, s):
    """Unit tangents ``m'(s) / |m'(s)|`` of a spline at ``s`` (k,); (k, 3) float64."""
    d = spline.derivative(1)(s)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _start_normal(T0, initial_normal):
    """U(0): ``initial_normal`` projected across the unit tangent ``T0``, or :func:`perpendicular` of ``T0``.

    Parameters
    ----------
    T0 : (3,) float64
        Unit tangent at s = 0.
    initial_normal : (3,) float64 or None

    Returns
    -------
    (3,) float64
        Unit, perpendicular to ``T0``.

    Raises
    ------
    FrameError
        Zero ``initial_normal``, or one parallel to ``T0``.
    """
    if initial_normal is None:
        return perpendicular(T0)
    r = unit(as_vector(initial_normal, "initial_normal"), "initial_normal")
    r = r - (r @ T0) * T0
    nr = float(np.linalg.norm(r))
    if not nr > tol.FRAME_ORTHONORMAL:
        raise FrameError("initial_normal is parallel to the first tangent; give a direction across the curve")
    return r / nr


def _transport_maps(spline, s, T):
    """Solution maps of the RMF equation over each sample interval: ``U(s[i+1]) = Phi[i] @ U(s[i])``.

    The RMF (Bishop frame, parallel transport) equation ``dU/ds = -(U . T'(s)) T(s)``
    keeps ``U . T`` and ``|U|`` constant, and two solutions keep their dot
    product: it carries the plane across ``T(s[i])`` onto the plane across
    ``T(s[i+1])`` by a rotation that keeps the orientation about T. So one
    unit normal ``W`` per interval, integrated to ``X``, gives the whole map:
    ``W -> X`` and ``T x W -> T x X``, i.e.
    ``Phi[i] = X W^T + (T[i+1] x X)(T[i] x W)^T`` on vectors across ``T[i]``.

    The spline's knots are among the samples, so on each interval the
    right-hand side is smooth (one polynomial piece) and DOP853's error
    estimate holds; all intervals are integrated at once, in the local variable
    ``tau`` in [0, 1] (``s = s[i] + tau (s[i+1] - s[i])``). One trajectory
    across all the pieces instead lets the steps straddle hundreds of knots,
    and its error stalls near 1e-9 whatever the tolerance.

    Parameters
    ----------
    spline : scipy.interpolate.BSpline
        The axis m(s), at least C2.
    s : (K,) float64
        Increasing samples; the knots of ``spline`` must be among them.
    T : (K, 3) float64
        Unit tangents of ``spline`` at ``s``.

    Returns
    -------
    Phi : (K - 1, 3, 3) float64

    Raises
    ------
    FrameError
        The tangent vanishes between samples, or the integration fails.
    """
    dm, ddm = spline.derivative(1), spline.derivative(2)
    s0, h = s[:-1], np.diff(s)

    def rhs(tau, y):
        x = s0 + tau * h
        d1, d2 = dm(x), ddm(x)
        speed = np.sqrt(np.einsum("ij,ij->i", d1, d1))
        if not np.all(speed > 0):
            raise FrameError("axis tangent vanishes between samples; the curve doubles back on itself")
        Tx = d1 / speed[:, None]
        dT = (d2 - np.einsum("ij,ij->i", d2, Tx)[:, None] * Tx) / speed[:, None]  # T'(s)
        U = y.reshape(-1, 3)
        return (-(h * np.einsum("ij,ij->i", U, dT))[:, None] * Tx).ravel()  # d/dtau = h d/ds

    W = perpendicular(T[:-1])
    sol = solve_ivp(rhs, (0.0, 1.0), W.ravel(), method="DOP853", rtol=tol.SYNTH_RMF_RTOL, atol=tol.SYNTH_RMF_ATOL,
                    t_eval=[1.0])
    if not sol.success:
        raise FrameError(f"integration of the axis's rotation-minimizing frame failed: {sol.message}")
    X = sol.y[:, -1].reshape(-1, 3)
    drift = max(float(np.max(np.abs(np.einsum("ij,ij->i", X, T[1:])))),
                float(np.max(np.abs(np.linalg.norm(X, axis=1) - 1.0))))
    if not drift <= tol.SYNTH_RMF_DRIFT:  # the exact solution stays a unit normal
        raise FrameError(f"the integrated rotation-minimizing frame drifted by {drift:.2g} from "
                         "orthonormal; the axis is not smooth enough (check the curve points)")
    return (np.einsum("ki,kj->kij", X, W)
            + np.einsum("ki,kj->kij", np.cross(T[1:], X), np.cross(T[:-1], W)))


def _integrated_rmf(s, centers, initial_normal):
    """Ground-truth RMF of the quintic spline through ``centers`` at ``s`` (no vesselgp.curves code).

    Parameters
    ----------
    s : (K,) float64
        Uniform in [0, 1].
    centers : (K, 3) float64
        Axis samples at ``s``.
    initial_normal : (3,) float64 or None
        See :func:`_start_normal`.

    Returns
    -------
    T, U : (K, 3) float64 each
        Exact unit tangents of the spline and the RMF normals (solution of
        :func:`_transport_maps` from U(0), re-orthonormalised against T).

    Raises
    ------
    FrameError
        Bad ``initial_normal``, a vanishing tangent or a failed integration.
    """
    m = make_interp_spline(s, centers, k=5)
    T = _unit_tangents(m, s)
    U = np.empty_like(T)
    U[0] = _start_normal(T[0], initial_normal)
    for i, Phi in enumerate(_transport_maps(m, s, T)):
        U[i + 1] = Phi @ U[i]
    U = U - np.einsum("ij,ij->i", U, T)[:, None] * T  # round-off only (checked in _transport_maps)
    return T, U / np.linalg.norm(U, axis=1)[:, None]


# ---------------------------------------------------------------------------
# Cross-sections
# ---------------------------------------------------------------------------


def _fn_of_s(x, name, positive=False):
    """A float, callable of s, or (k,) samples at uniform s -> vectorised callable."""
    if callable(x):
        return lambda s: np.broadcast_to(np.asarray(x(s), dtype=float), np.shape(s))
    a = np.asarray(x, dtype=float)
    if a.ndim == 0:
        if not np.isfinite(a) or (positive and a <= 0):
            raise InvalidMeshError(f"{name} must be a {'positive ' if positive else ''}finite number, got {x}")
        v = float(a)
        return lambda s: np.full(np.shape(s), v)
    if a.ndim != 1 or len(a) < 2 or not np.all(np.isfinite(a)):
        raise InvalidMeshError(f"{name} must be a number, a callable of s or a finite (k,) array with k >= 2")
    sp = make_interp_spline(np.linspace(0, 1, len(a)), a, k=min(3, len(a) - 1))
    return lambda s: sp(np.clip(s, 0.0, 1.0))


def _parse_bulges(bulges):
    out = []
    for b in bulges:
        if isinstance(b, dict):
            unknown = set(b) - {"s0", "width", "amplitude", "lobes", "phase"}
            if unknown or not {"s0", "width", "amplitude"} <= set(b):
                raise InvalidMeshError(
                    "a bulge dict needs keys s0, width, amplitude (optional lobes, phase), "
                    f"got {sorted(b)}"
                )
            d = {"lobes": 0, "phase": 0.0, **b}
        else:
            try:
                s0, width, amp = b
            except (TypeError, ValueError):
                raise InvalidMeshError(f"a bulge must be (s0, width, amplitude) or a dict, got {b!r}") from None
            d = {"s0": s0, "width": width, "amplitude": amp, "lobes": 0, "phase": 0.0}
        d = {k: float(v) for k, v in d.items()}
        if not (d["width"] > 0) or not (d["amplitude"] > -1) or not np.all(np.isfinite(list(d.values()))):
            raise InvalidMeshError(f"bulge needs width > 0 and amplitude > -1, got {d}")
        d["lobes"] = int(d["lobes"])
        out.append(d)
    return out


def _perimeter_mean(rho, theta):
    """Mean of ``rho`` along the perimeter of the closed polar curve (last axis)."""
    x, y = rho * np.cos(theta), rho * np.sin(theta)
    seg = np.hypot(np.roll(x, -1, axis=-1) - x, np.roll(y, -1, axis=-1) - y)
    w = 0.5 * (seg + np.roll(seg, 1, axis=-1))
    return np.sum(w * rho, axis=-1) / np.sum(w, axis=-1)


class _Section:
    """rho(s, theta): polar cross-section in material coordinates (vectorised)."""

    def __init__(self, radius, ellipticity, ellipse_angle, bulges):
        self.r = _fn_of_s(radius, "radius", positive=True)
        self.beta = _fn_of_s(ellipse_angle, "ellipse_angle")
        self.e = _fn_of_s(ellipticity, "ellipticity", positive=True)
        grid = np.linspace(0.0, 1.0, tol.SYNTH_ELLIPTICITY_SAMPLES)
        e = self.e(grid)
        if not np.all(np.isfinite(e) & (e > 0) & (e <= 1e3)):
            raise InvalidMeshError(f"ellipticity must be a positive axis ratio b/a, got {ellipticity}")
        th = self.theta_grid()
        if callable(ellipticity):  # the unit ellipse's perimeter-mean radius along s (smooth: interpolated)
            means = _perimeter_mean(self._ellipse(th[None, :], e[:, None]), th)
            self._m_e = lambda s: np.interp(s, grid, means)
        else:
            m = float(_perimeter_mean(self._ellipse(th, float(e[0])), th))
            self._m_e = lambda s: m
        self.bulges = _parse_bulges(bulges)

    @staticmethod
    def theta_grid():
        return np.linspace(0, 2 * np.pi, tol.SYNTH_SECTION_SAMPLES, endpoint=False)

    @staticmethod
    def _ellipse(phi, e):
        # polar radius of x = cos(p), y = e sin(p): a b / sqrt((b cos)^2 + (a sin)^2), a = 1
        return e / np.hypot(e * np.cos(phi), np.sin(phi))

    def nominal(self, s):
        """r(s) times the axisymmetric bulge factors: perimeter-mean radius without sinuses."""
        s = np.asarray(s, dtype=float)
        r = self.r(s)
        for b in self.bulges:
            if b["lobes"] == 0:
                r = r * (1.0 + b["amplitude"] * np.exp(-0.5 * ((s - b["s0"]) / b["width"]) ** 2))
        return r

    def __call__(self, s, theta):
        s, theta = np.broadcast_arrays(np.asarray(s, float), np.asarray(theta, float))
        rho = self.nominal(s) / self._m_e(s) * self._ellipse(theta - self.beta(s), self.e(s))
        ang = np.ones_like(rho)
        for b in self.bulges:
            if b["lobes"] > 0:
                g = np.exp(-0.5 * ((s - b["s0"]) / b["width"]) ** 2)
                lobe = np.maximum(0.0, np.cos(b["lobes"] * (theta - b["phase"]))) ** 2
                ang = ang + b["amplitude"] * g * lobe
        return rho * ang

    def mean_radius(self, s):
        th = self.theta_grid()
        s = np.asarray(s, float)
        return _perimeter_mean(self(s[:, None], th[None, :]), th)

    def max_radius(self, s):
        th = self.theta_grid()
        return np.max(self(np.asarray(s, float)[:, None], th[None, :]), axis=1)


# ---------------------------------------------------------------------------
# Ground truth and the vessel container
# ---------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class GroundTruth:
    """Exact geometry of a synthetic vessel.

    Attributes
    ----------
    s : (K,) float64
        Normalized arc length of the axis samples, uniform in [0, 1].
    length : float
        Axis length (mesh units).
    centers : (K, 3) float64
        True axis points m(s).
    radii : (K,) float64
        True perimeter-mean distance of the section to the centre (what paper
        Eq. 4 estimates).
    frames : (K, 3, 3) float64
        Rows T, U, V of the RMF of the true axis: the solution of
        ``dU/ds = -(U . T') T`` on its quintic spline (module docstring).
    alpha : (K,) float64
        Imposed material twist alpha(s) (radians, paper Fig. 1); 0 without twist.
    vertex_s : (n,) float64
        True normalized arc length of each vertex's section plane.
    vertex_theta : (n,) float64
        Material angle: angle about T from U at ``vertex_s`` minus alpha, in (-pi, pi].
    vertex_offset : (n, 2) float64
        In-plane coordinates of the clean vertex in the untwisted frame (U, V).
    vertex_on_cap : (n,) bool
        True for vertices strictly inside a flat cap (not on the rim).
    vertex_noise : (n, 3) float64
        Noise displacement in local material coordinates (along T, U', V'
        with U', V' the frame turned by alpha); zeros without noise.
    name : str
        Curve name, or ``"custom"``.
    units : str
        ``"mm"`` for the aortic curves, ``"unit"`` otherwise (or as given).
    """

    s: np.ndarray
    length: float
    centers: np.ndarray
    radii: np.ndarray
    frames: np.ndarray
    alpha: np.ndarray
    vertex_s: np.ndarray
    vertex_theta: np.ndarray
    vertex_offset: np.ndarray
    vertex_on_cap: np.ndarray
    vertex_noise: np.ndarray
    name: str = "custom"
    units: str = "unit"
    _section: Callable = field(default=None, repr=False)
    _alpha_fn: Callable = field(default=None, repr=False)

    def axis_at(self, s):
        """Interpolated axis points and RMF frames at normalized arc length ``s``.

        Parameters
        ----------
        s : (m,) float64
            Values in [0, 1].

        Returns
        -------
        centers : (m, 3) float64
        frames : (m, 3, 3) float64
            Rows T, U, V.

        Examples
        --------
        >>> t = synthetic_vessel("straight", n_around=8, remesh=False).truth
        >>> c, fr = t.axis_at([0.5])
        >>> bool(np.allclose(c, [[0, 0, 15]])), bool(np.allclose(fr[0, 0], [0, 0, 1]))
        (True, True)
        """
        s = np.atleast_1d(np.asarray(s, dtype=float))
        ax = _Axis(self.s, self.centers, self.frames[:, 1])
        T, U, V = ax.frames(s)
        return ax.point(s), np.stack([T, U, V], axis=1)

    def section_radius(self, s, theta):
        """Analytic section radius rho(s, theta) at material angle ``theta`` (broadcast).

        Examples
        --------
        >>> t = synthetic_vessel("straight", radius=2.0, n_around=8, remesh=False).truth
        >>> float(t.section_radius(0.3, 1.0))
        2.0
        """
        return self._section(s, theta)

    def twist(self, s):
        """Imposed twist alpha(s) (radians) at any ``s`` (broadcast).

        Examples
        --------
        >>> t = synthetic_vessel("straight", twist=1.0, n_around=8, remesh=False).truth
        >>> float(t.twist(0.25))
        0.25
        """
        return self._alpha_fn(np.asarray(s, dtype=float))


@dataclass(frozen=True, eq=False)
class SyntheticVessel:
    """A synthetic vessel mesh and its ground truth.

    Attributes
    ----------
    V : (n, 3) float64
        Vertices.
    F : (m, 3) int64
        Triangles, consistently oriented with outward normals.
    truth : GroundTruth
    """

    V: np.ndarray
    F: np.ndarray
    truth: GroundTruth


def signed_volume(V, F):
    """Signed volume enclosed by a closed triangle mesh (positive for outward normals).

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> round(float(signed_volume(V, F)), 6)
    0.166667
    """
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return float(np.sum(np.einsum("ij,ij->i", a, np.cross(b, c))) / 6.0)


# ---------------------------------------------------------------------------
# Sweeping
# ---------------------------------------------------------------------------


def _place(axis, section, alpha_fn, s, theta, offset=None, noise=None):
    """Surface points for material coordinates (vectorised).

    ``offset`` (n, 2) overrides the section radius (cap vertices); ``noise``
    (n, 3) is added in the local material frame (T, U', V').
    """
    T, U, V = axis.frames(s)
    a = alpha_fn(s)
    if offset is None:
        rho = section(s, theta)
        offset = np.c_[rho * np.cos(theta), rho * np.sin(theta)]
    c, sn = np.cos(a), np.sin(a)
    Ut = c[:, None] * U + sn[:, None] * V  # material frame: RMF turned by alpha
    Vt = -sn[:, None] * U + c[:, None] * V
    X = axis.point(s) + offset[:, :1] * Ut + offset[:, 1:] * Vt
    if noise is not None:
        X = X + noise[:, :1] * T + noise[:, 1:2] * Ut + noise[:, 2:] * Vt
    return X


def _ring_mesh(n_rings, n_around, capped):
    """Faces of a structured tube: ring k, point j has index k * n_around + j.

    With theta increasing counter-clockwise about T, (k,j),(k,j+1),(k+1,j+1)
    has normal e_theta x T = outward radial. Caps are fans around two extra
    vertices (indices n_rings * n_around and + 1), oriented -T and +T.
    """
    k, j = np.meshgrid(np.arange(n_rings - 1), np.arange(n_around), indexing="ij")
    k, j = k.ravel(), j.ravel()
    j1 = (j + 1) % n_around
    a, b, c, d = k * n_around + j, k * n_around + j1, (k + 1) * n_around + j1, (k + 1) * n_around + j
    F = [np.c_[a, b, c], np.c_[a, c, d]]
    if capped:
        c0, c1 = n_rings * n_around, n_rings * n_around + 1
        jj = np.arange(n_around)
        jn = (jj + 1) % n_around
        last = (n_rings - 1) * n_around
        F.append(np.c_[np.full(n_around, c0), jn, jj])
        F.append(np.c_[np.full(n_around, c1), last + jj, last + jn])
    return np.ascontiguousarray(np.concatenate(F), dtype=np.int64)


def _pure_value(x):
    """An absolute length for pymeshlab: ``PureValue`` (<= 2022.2) or ``AbsoluteValue`` (2023+)."""
    import pymeshlab

    cls = getattr(pymeshlab, "PureValue", None) or getattr(pymeshlab, "AbsoluteValue")
    return cls(float(x))


def _remesh(V, F, target_edge):
    """pymeshlab isotropic explicit remeshing; boundary loops and cap rims are
    kept as feature lines by the filter (and snapped back exactly afterwards)."""
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=V, face_matrix=F.astype(np.int32)))
    ms.meshing_isotropic_explicit_remeshing(
        targetlen=_pure_value(target_edge),
        iterations=tol.SYNTH_REMESH_ITERATIONS,
        featuredeg=tol.SYNTH_REMESH_FEATURE_DEG,
        checksurfdist=False,  # vertices are projected onto the exact surface afterwards
    )
    ms.meshing_remove_unreferenced_vertices()
    m = ms.current_mesh()
    return (np.ascontiguousarray(m.vertex_matrix(), dtype=np.float64),
            np.ascontiguousarray(m.face_matrix(), dtype=np.int64))


def _check_topology(V, F, capped):
    import igl

    ncomp = len(np.unique(igl.vertex_components(F)))
    manifold = bool(igl.is_edge_manifold(F)[0])
    loops = igl.boundary_loop_all(F)
    want = 0 if capped else 2
    if ncomp != 1 or not manifold or len(loops) != want or len(np.unique(F)) != len(V):
        raise InvalidMeshError(
            f"synthetic mesh is broken ({ncomp} components, edge-manifold={manifold}, "
            f"{len(loops)} boundary loops, want {want}); try a larger target_edge or n_around"
        )
    return loops


def _as_alpha(twist):
    """alpha(s) as a vectorised callable from None, a total twist Phi (alpha = Phi s) or a callable.

    A callable's values are checked on every call: a non-finite twist raises
    :class:`InvalidMeshError` instead of giving NaN vertices.
    """
    if twist is None:
        return lambda s: np.zeros(np.shape(s))
    if callable(twist):
        def alpha(s):
            a = np.broadcast_to(np.asarray(twist(s), dtype=float), np.shape(s)).astype(float)
            if not np.all(np.isfinite(a)):
                raise InvalidMeshError("twist(s) must be finite for every s in [0, 1]")
            return a

        return alpha
    phi = float(twist)
    if not np.isfinite(phi):
        raise InvalidMeshError(f"twist must be finite, got {twist}")
    return lambda s: phi * np.asarray(s, dtype=float)


def _resolve_curve(curve, initial_normal):
    if isinstance(curve, str):
        P, name, units = named_curve(curve), curve, CURVE_NAMES[curve]
    else:
        P, name, units = as_points(curve, "curve", min_rows=4), "custom", "unit"
    if initial_normal is not None:
        initial_normal = as_vector(initial_normal, "initial_normal")
    return _arc_length_axis(P, initial_normal), name, units


def synthetic_vessel(curve, radius=1.5, *, ellipticity=1.0, ellipse_angle=0.0, bulges=(), twist=None,
                     ends="open", n_around=48, spacing=None, remesh=True, target_edge=None, noise=0.0,
                     seed=0, initial_normal=None, units=None):
    """Sweep a cross-section along a 3D curve with its rotation-minimizing frame.

    Parameters
    ----------
    curve : str or (k, 3) float64
        A name of :func:`named_curve` (default parameters) or curve points; the
        curve is re-parameterized by arc length (quintic spline), s in [0, 1].
    radius : float, callable or (k,) float64
        Perimeter-mean section radius r(s) (see module docstring), a function
        of normalized arc length, or samples at uniform s (cubic spline).
    ellipticity : float or callable
        Axis ratio b / a of the elliptic section (1 = circle), or a function of s (a vein flattened
        in its middle).
    ellipse_angle : float or callable
        Angle (radians) of the ellipse's a-axis from the material U axis, or a function of s.
    bulges : sequence of (s0, width, amplitude) or dict
        Gaussian bulges multiplying the radius by ``1 + amplitude exp(-(s - s0)^2 / 2 width^2)``
        (aneurysm amplitude > 0, stenosis < 0). A dict may add ``lobes`` (int)
        and ``phase``: then the factor is ``1 + amplitude g(s) max(0, cos(lobes (theta - phase)))^2``
        (``lobes=3``: the three aortic sinuses); such angular bulges change the
        true mean radius, which :attr:`GroundTruth.radii` reports.
    twist : None, float or callable
        Material twist: None (alpha = 0), Phi (alpha(s) = Phi s) or alpha(s).
        The material point of rest angle theta sits at theta + alpha(s) about T from U.
    ends : {"open", "capped"}
        Two open boundary loops at s = 0 and 1, or flat caps (closed mesh).
    n_around : int
        Points per ring of the structured mesh (before remeshing).
    spacing : float, optional
        Ring spacing; default the around spacing ``2 pi mean(radii) / n_around``.
    remesh : bool
        Isotropic remeshing (pymeshlab) so vertices no longer sit on rings.
    target_edge : float, optional
        Remeshing edge length; default the around spacing.
    noise : float
        Gaussian displacement along the vertex normal, sigma = noise * r(s)
        (kept in the end plane for vertices on an end).
    seed : int
        Seed of the noise.
    initial_normal : (3,) float64, optional
        U at s = 0, projected across the first tangent (default: the coordinate
        axis least aligned with it, projected: :func:`vesselgp.rotations.perpendicular`).
    units : str, optional
        Overrides the unit label (``"mm"`` for aortic curves, else ``"unit"``).

    Returns
    -------
    SyntheticVessel

    Raises
    ------
    VesselError
        Bad curve, initial normal, radius, twist, bulge, ``ends`` or sizes; a section wider than the
        local bend radius (the tube would fold over itself).

    Examples
    --------
    >>> v = synthetic_vessel("helix", radius=1.5, twist=0.5, n_around=12, remesh=False)
    >>> t = v.truth
    >>> c, fr = t.axis_at(t.vertex_s)
    >>> d = np.linalg.norm(v.V - c, axis=1)
    >>> bool(np.allclose(d, t.section_radius(t.vertex_s, t.vertex_theta)))
    True
    """
    capped, n_around = _check_tube_options(ends, n_around)
    axis, name, auto_units = _resolve_curve(curve, initial_normal)
    units = auto_units if units is None else str(units)
    section = _Section(radius, ellipticity, ellipse_angle, bulges)
    alpha_fn = _as_alpha(twist)
    radii = _true_radii(axis, section)
    r_scale = float(np.mean(radii))
    h = 2 * np.pi * r_scale / n_around  # the around spacing of the structured rings
    spacing = h if spacing is None else float(spacing)
    X, F, rings = _structured_tube(axis, section, alpha_fn, n_around, spacing, remesh, seed, capped)
    log.debug("structured %s tube: %d rings x %d, length %.3g", name, len(rings.s) // n_around, n_around,
              axis.length)
    if remesh:
        te = h if target_edge is None else float(target_edge)
        X, F, vt = _remeshed_truth(axis, section, alpha_fn, X, F, te, capped, r_scale)
    else:
        vt = _ring_truth(section, rings, capped)
    loops = _check_topology(X, F, capped)
    if not capped:  # open ends: the boundary loops lie exactly on s = 0 and 1
        for lp in loops:
            vt.s[lp] = np.round(np.mean(vt.s[lp]))
    X, noise_local = _surface_vertices(axis, section, alpha_fn, vt, F, radii, noise, seed)
    T, U, V = axis.frames(axis.s)
    truth = GroundTruth(
        s=axis.s, length=axis.length, centers=axis.centers, radii=radii, frames=np.stack([T, U, V], axis=1),
        alpha=alpha_fn(axis.s), vertex_s=vt.s, vertex_theta=wrap_angle(vt.theta), vertex_offset=vt.offset,
        vertex_on_cap=vt.on_cap, vertex_noise=noise_local, name=name, units=units,
        _section=section, _alpha_fn=alpha_fn,
    )
    return SyntheticVessel(V=np.ascontiguousarray(X), F=F, truth=truth)


class _VertexTruth(NamedTuple):
    """Material coordinates of the mesh vertices (the fields of :class:`GroundTruth` named ``vertex_*``).

    Attributes
    ----------
    s : (n,) float64
    theta : (n,) float64
        Not yet wrapped.
    on_cap : (n,) bool
    offset : (n, 2) float64
    """

    s: np.ndarray
    theta: np.ndarray
    on_cap: np.ndarray
    offset: np.ndarray


def _check_tube_options(ends, n_around):
    """``(capped, n_around)`` from :func:`synthetic_vessel`'s ``ends`` and ``n_around``, validated."""
    if ends not in ("open", "capped"):
        raise VesselError(f"ends must be 'open' or 'capped', got {ends!r}")
    n_around = int(n_around)
    if n_around < 6:
        raise InvalidMeshError(f"n_around must be >= 6, got {n_around}")
    return ends == "capped", n_around


def _true_radii(axis, section):
    """Perimeter-mean radius of the section at the axis samples, (K,) float64.

    Raises
    ------
    InvalidMeshError
        A non-positive or non-finite radius, or a section wider than
        :data:`vesselgp.tolerances.SYNTH_MAX_FOLD` bend radii (the tube folds).
    """
    radii = section.mean_radius(axis.s)
    if not np.all(np.isfinite(radii)) or np.any(radii <= 0):
        raise InvalidMeshError("radius must be positive and finite along the whole curve")
    fold = section.max_radius(axis.s) * axis.curvature(axis.s)
    if np.max(fold) >= tol.SYNTH_MAX_FOLD:
        raise InvalidMeshError(
            f"section radius reaches {np.max(fold):.2f} x the bend radius: the tube folds over itself; "
            "use a smaller radius or a gentler curve"
        )
    return radii


class _Rings(NamedTuple):
    """Material coordinates of the structured ring vertices: ring k, point j at index k n_around + j."""

    s: np.ndarray
    theta: np.ndarray


def _structured_tube(axis, section, alpha_fn, n_around, spacing, remesh, seed, capped):
    """The ring mesh of the tube (before any remeshing).

    Parameters
    ----------
    spacing : float
        Ring spacing (mesh units); rings at uniform s, both ends included.
    remesh : bool
        Jitter the inner rings (seeded) so the remesher cannot settle on a
        ring lattice; the vertices then are not at ``rings``.

    Returns
    -------
    X : (n, 3) float64
        Ring vertices, then the two cap centres when ``capped``.
    F : (m, 3) int64
    rings : _Rings
        Un-jittered (s, theta) of the ring vertices, (n_rings n_around,) each.

    Raises
    ------
    InvalidMeshError
        Non-positive ``spacing``.
    """
    if not spacing > 0:
        raise InvalidMeshError(f"spacing must be positive, got {spacing}")
    n_rings = max(2, int(np.ceil(axis.length / spacing)) + 1)
    sr = np.repeat(np.linspace(0, 1, n_rings), n_around)
    th = np.tile(2 * np.pi * np.arange(n_around) / n_around, n_rings)
    if remesh:
        rng = np.random.default_rng([int(seed), 7])
        inner = (sr > 0) & (sr < 1)
        js = rng.uniform(-1, 1, (2, len(sr))) * tol.SYNTH_REMESH_JITTER
        sj = np.where(inner, sr + js[0] / (n_rings - 1), sr)
        tj = np.where(inner, th + js[1] * 2 * np.pi / n_around, th)
        X = _place(axis, section, alpha_fn, sj, tj)
    else:
        X = _place(axis, section, alpha_fn, sr, th)
    F = _ring_mesh(n_rings, n_around, capped)
    if capped:
        X = np.concatenate([X, axis.point(np.array([0.0, 1.0]))])
    return X, F, _Rings(sr, th)


def _ring_truth(section, rings, capped):
    """:class:`_VertexTruth` of the un-remeshed ring mesh (cap centres last, offset 0)."""
    s = np.concatenate([rings.s, [0.0, 1.0]]) if capped else rings.s
    theta = np.concatenate([rings.theta, [0.0, 0.0]]) if capped else rings.theta
    on_cap = np.zeros(len(s), bool)
    on_cap[len(rings.s):] = True
    rho = section(s, theta)
    offset = np.c_[rho * np.cos(theta), rho * np.sin(theta)]
    offset[on_cap] = 0.0
    return _VertexTruth(s, theta, on_cap, offset)


def _remeshed_truth(axis, section, alpha_fn, X, F, target_edge, capped, r_scale):
    """Isotropic remeshing of the ring mesh and the :class:`_VertexTruth` of the new vertices.

    Returns
    -------
    X : (n, 3) float64
        Remeshed vertices (not yet on the exact surface).
    F : (m, 3) int64
    truth : _VertexTruth

    Raises
    ------
    InvalidMeshError
        Non-positive ``target_edge``.
    """
    if not target_edge > 0:
        raise InvalidMeshError(f"target_edge must be positive, got {target_edge}")
    X, F = _remesh(X, F, target_edge)
    return X, F, _truth_from_positions(axis, section, alpha_fn, X, capped, r_scale)


def _surface_vertices(axis, section, alpha_fn, vt, F, radii, noise, seed):
    """Vertices placed exactly on the surface at ``vt``, then moved by seeded normal noise.

    Returns
    -------
    X : (n, 3) float64
    noise_local : (n, 3) float64
        The noise in local material coordinates (zeros without noise).
    """
    X = _place(axis, section, alpha_fn, vt.s, vt.theta, offset=vt.offset)
    noise_local = np.zeros((len(X), 3))
    if noise:
        noise_local = _noise(X, F, vt.s, radii, axis, alpha_fn, float(noise), seed)
        X = _place(axis, section, alpha_fn, vt.s, vt.theta, offset=vt.offset, noise=noise_local)
    return X, noise_local


def _truth_from_positions(axis, section, alpha_fn, X, capped, r_scale):
    """Exact :class:`_VertexTruth` of remeshed vertices by projection onto the true axis."""
    s = axis.project(X)
    m0, m1 = axis.point(np.array([0.0, 1.0]))
    T01 = axis.frames(np.array([0.0, 1.0]))[0]
    d0 = (X - m0) @ T01[0]
    d1 = (X - m1) @ T01[1]
    eps = tol.SYNTH_END_PLANE * r_scale
    # the end half-spaces are only meaningful next to the end (a helix re-enters them)
    reach = 2.0 * section.max_radius(np.array([0.0, 1.0]))
    near0 = np.linalg.norm(X - m0, axis=1) < reach[0]
    near1 = np.linalg.norm(X - m1, axis=1) < reach[1]
    end0 = near0 & ((d0 <= eps) | (s <= 0))
    end1 = near1 & ((d1 >= -eps) | (s >= 1))
    s = np.clip(s, 0.0, 1.0)
    s[end0] = 0.0
    s[end1] = 1.0
    T, U, V = axis.frames(s)
    D = X - axis.point(s)
    theta = np.arctan2(np.sum(D * V, axis=1), np.sum(D * U, axis=1)) - alpha_fn(s)  # angle about T from U
    rho = section(s, theta)
    offset = np.c_[rho * np.cos(theta), rho * np.sin(theta)]
    on_cap = np.zeros(len(X), bool)
    if capped:
        radial = np.linalg.norm(D - np.sum(D * T, axis=1)[:, None] * T, axis=1)
        on_cap = (end0 | end1) & (radial < tol.SYNTH_RIM_FRACTION * rho)
        offset[on_cap] = radial[on_cap, None] * np.c_[np.cos(theta[on_cap]), np.sin(theta[on_cap])]
    return _VertexTruth(s, theta, on_cap, offset)


def _noise(X, F, s, radii, axis, alpha_fn, noise, seed):
    """Gaussian normal displacement expressed in local material coordinates."""
    import igl

    N = igl.per_vertex_normals(X, F)
    sigma = noise * np.interp(s, axis.s, radii)
    disp = N * (sigma * np.random.default_rng(seed).standard_normal(len(X)))[:, None]
    T, U, V = axis.frames(s)
    a = alpha_fn(s)
    Ut = np.cos(a)[:, None] * U + np.sin(a)[:, None] * V
    Vt = np.cross(T, Ut)
    local = np.c_[np.sum(disp * T, 1), np.sum(disp * Ut, 1), np.sum(disp * Vt, 1)]
    on_end = (s <= 0) | (s >= 1)
    local[on_end, 0] = 0.0  # ends stay exactly planar
    return local


# ---------------------------------------------------------------------------
# Analytic deformation
# ---------------------------------------------------------------------------


def deform_synthetic(vessel, curve=None, twist=None, *, initial_normal=None):
    """Move a synthetic vessel onto a new centre line with a known twist.

    Each vertex keeps its normalized arc length ``s`` and its untwisted
    in-plane offset (:attr:`GroundTruth.vertex_offset`, plus its noise) and is
    placed in the new curve's RMF turned by ``alpha(s)``. The section shape is
    therefore unchanged; the original twist of ``vessel`` is replaced (not
    added), so against the rest configuration the material turns by
    ``alpha(s) - vessel.truth.alpha(s)`` (paper Eq. 7).

    Parameters
    ----------
    vessel : SyntheticVessel
    curve : str or (k, 3) float64, optional
        New centre line (default: the vessel's own axis). It is resampled by
        arc length and scaled uniformly about its first point to the vessel's
        length, so the deformation does not stretch the axis.
    twist : None, float or callable
        alpha(s) as in :func:`synthetic_vessel` (None: zero twist).
    initial_normal : (3,) float64, optional
        U of the new RMF at s = 0. Default: the rest U(0) carried by the
        minimal rotation taking the rest tangent T(0) to the new one, so the
        first section does not spin: with ``twist=None`` the material frame
        *is* the new RMF (zero twist by construction), and if the new curve
        starts like the old one the s = 0 end does not move.

    Returns
    -------
    V_def : (n, 3) float64
        Deformed vertices; the faces are ``vessel.F``.

    Examples
    --------
    >>> rest = synthetic_vessel("straight", n_around=12, remesh=False)
    >>> Vd = deform_synthetic(rest, "arc", twist=1.0)
    >>> Vd.shape == rest.V.shape, bool(np.allclose(Vd[:12], rest.V[:12]))
    (True, True)
    """
    if not isinstance(vessel, SyntheticVessel):
        raise VesselError("deform_synthetic needs a SyntheticVessel from synthetic_vessel()")
    t = vessel.truth
    if curve is None:
        P = t.centers
    elif isinstance(curve, str):
        P = named_curve(curve)
    else:
        P = as_points(curve, "curve", min_rows=4)
    c = _arc_length_samples(P)
    c = c[0] + t.length / _polyline_length(c) * (c - c[0])  # scaled to the rest length
    if initial_normal is None:
        T0 = _unit_tangents(make_interp_spline(np.linspace(0.0, 1.0, len(c)), c, k=5), 0.0)
        initial_normal = minimal_rotation(t.frames[0, 0], T0).apply(t.frames[0, 1])
    else:
        initial_normal = as_vector(initial_normal, "initial_normal")
    axis = _axis_from_centers(c, initial_normal)
    return _place(axis, t._section, _as_alpha(twist), t.vertex_s, t.vertex_theta,
                  offset=t.vertex_offset, noise=t.vertex_noise)


# ---------------------------------------------------------------------------
# The paper's joining cases (Section 3, Figs. 2-3)
# ---------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class JoinCase:
    """A joining problem of paper Section 3.

    Attributes
    ----------
    V : (n, 3) float64
        The vessel that is deformed (rest configuration).
    F : (m, 3) int64
    fixed : (p,) int64
        Vertex ids held in place.
    moving : (q,) int64
        Vertex ids of the end loop that is joined (in boundary-loop order).
    moving_at : float
        Normalized arc length (0 or 1) of the moving end in :attr:`truth`.
    target_origin : (3,) float64
        Where the moving end's centre goes (the other vessel's end centre).
    target_tangent : (3,) float64
        Unit direction the axis must have at the moving end, pointing out of
        the deformed vessel (into the other vessel).
    target_normal : (3,) float64
        Unit, perpendicular to ``target_tangent``: where the moving end's rest
        anchor :attr:`moving_normal` goes at rotation angle 0 (the other
        vessel's material U, turned by ``pre_rotation`` about ``target_tangent``).
    other_V : (n2, 3) float64
    other_F : (m2, 3) int64
        The vessel joined to (not deformed).
    other_end : (r,) int64
        Vertex ids of its end loop at the join.
    units : str
    name : str
    truth : GroundTruth
        Ground truth of the deformed vessel at rest.
    other_truth : GroundTruth
    pre_rotation : float
    seed : int
    moving_normal : (3,) float64
        The anchor at the moving end: the deformed vessel's material U there
        (its true RMF normal turned by its true twist). With it, an
        untwisted join of case 1 is at angle ``-pre_rotation`` give or take the
        small twist-free roll of the bend.
    """

    V: np.ndarray
    F: np.ndarray
    fixed: np.ndarray
    moving: np.ndarray
    moving_at: float
    target_origin: np.ndarray
    target_tangent: np.ndarray
    target_normal: np.ndarray
    other_V: np.ndarray
    other_F: np.ndarray
    other_end: np.ndarray
    units: str
    name: str
    truth: GroundTruth
    other_truth: GroundTruth
    pre_rotation: float = 0.0
    seed: int = 0
    moving_normal: np.ndarray | None = None


def _end_loop(vessel, at):
    import igl

    loops = [np.asarray(lp, dtype=np.int64) for lp in igl.boundary_loop_all(vessel.F)]
    return min(loops, key=lambda lp: abs(np.mean(vessel.truth.vertex_s[lp]) - at))


def paper_case(n, *, pre_rotation=0.0, resolution=1.0, seed=0, noise=0.0):
    """One of the paper's two joining test cases (Section 3, Figs. 2-3).

    Case 1 (units: mm): two relatively straight vessels of radius 1.5 and
    length 30, gently bowed, side by side along +x with a gap of 4 radii, the
    right one offset laterally by 1.5 radii and turned by 10 degrees. The left
    vessel is deformed: its first 10 % (s < 0.1) is fixed, its right end
    (s = 1) joins the left end of the right vessel.

    Case 2 (mm): an aortic arch (ascending radius 15 tapering to 12 in the
    descending aorta) whose descending part (s > 0.6) is fixed; the end of the
    ascending aorta (s = 0) joins the top of an aortic root (radius 13-14.5,
    three sinus bulges) placed 13 mm away and tilted by 14 degrees (with the
    root's bow, about 20 degrees between the two end axes).

    Parameters
    ----------
    n : {1, 2}
        Case number.
    pre_rotation : float
        Turns ``target_normal`` about ``target_tangent`` (radians): a badly
        chosen anchor.
    resolution : float
        Multiplies the points per ring (48 for case 1, 64 for case 2).
    seed : int
        Noise seed (stored in the case).
    noise : float
        Relative normal noise (see :func:`synthetic_vessel`).

    Returns
    -------
    JoinCase

    Examples
    --------
    >>> c = paper_case(1, resolution=0.25)
    >>> c.units, bool(abs(np.linalg.norm(c.target_tangent) - 1) < 1e-12)
    ('mm', True)
    """
    if n not in (1, 2):
        raise VesselError(f"paper case must be 1 or 2, got {n!r}")
    resolution = float(resolution)
    if not resolution > 0:
        raise VesselError(f"resolution must be positive, got {resolution}")
    if n == 1:
        r, L = 1.5, 30.0
        x = np.linspace(0, L, 400)
        bow = 0.8 * np.sin(np.pi * x / L)
        left = np.c_[x, np.zeros_like(x), bow]
        R = rotation_matrix([0, 0, 1], np.deg2rad(10.0))
        right = (np.c_[x, np.zeros_like(x), -bow] @ R.T) + [L + 4 * r, 1.5 * r, 0.0]
        na = max(12, int(round(48 * resolution)))
        kw = dict(radius=r, n_around=na, noise=noise, seed=seed, units="mm")
        vessel = synthetic_vessel(left, initial_normal=[0, 0, 1], **kw)
        other = synthetic_vessel(right, initial_normal=[0, 0, 1], **{**kw, "seed": seed + 1})
        fixed = np.flatnonzero(vessel.truth.vertex_s < 0.1)
        moving_at, other_at = 1.0, 0.0
        name = "case1_straight_vessels"
    else:
        na = max(16, int(round(64 * resolution)))
        aorta_r = lambda s: 15.0 - 3.0 * np.clip((s - 0.2) / 0.35, 0.0, 1.0)  # noqa: E731
        vessel = synthetic_vessel("aortic_arch", radius=aorta_r, n_around=na, noise=noise, seed=seed,
                                  initial_normal=[1, 0, 0])
        Rt = rotation_matrix([1, 1, 0], np.deg2rad(14.0))
        root = named_curve("aortic_root")
        root = root - root[-1]  # top (sinotubular junction) at the origin
        root = root @ Rt.T + [6.0, -6.0, -10.0]
        sinuses = [{"s0": 0.4, "width": 0.15, "amplitude": 0.3, "lobes": 3, "phase": 0.0}]
        other = synthetic_vessel(root, radius=lambda s: 13.0 + 1.5 * s, bulges=sinuses, n_around=na,
                                 noise=noise, seed=seed + 1, initial_normal=Rt @ [1, 0, 0], units="mm")
        fixed = np.flatnonzero(vessel.truth.vertex_s > 0.6)
        moving_at, other_at = 0.0, 1.0
        name = "case2_aorta_root"
    moving = _end_loop(vessel, moving_at)
    other_end = _end_loop(other, other_at)
    c, fr = other.truth.axis_at([other_at])
    # pointing out of the deformed vessel = into the other vessel at its end
    tangent = fr[0, 0] if other_at == 0.0 else -fr[0, 0]
    a = float(other.truth.twist(other_at))
    normal = np.cos(a) * fr[0, 1] + np.sin(a) * fr[0, 2]  # the other vessel's material U
    normal = rotate(normal, tangent, float(pre_rotation))
    normal -= (normal @ tangent) * tangent
    normal /= np.linalg.norm(normal)
    _, fm = vessel.truth.axis_at([moving_at])
    am = float(vessel.truth.twist(moving_at))
    moving_normal = np.cos(am) * fm[0, 1] + np.sin(am) * fm[0, 2]  # the moving vessel's material U
    if np.intersect1d(fixed, moving).size:
        raise InvalidMeshError("fixed and moving vertex sets overlap; increase the resolution")
    return JoinCase(
        V=vessel.V, F=vessel.F, fixed=fixed.astype(np.int64), moving=moving, moving_at=moving_at,
        target_origin=c[0], target_tangent=tangent, target_normal=normal,
        other_V=other.V, other_F=other.F, other_end=other_end, units="mm", name=name,
        truth=vessel.truth, other_truth=other.truth, pre_rotation=float(pre_rotation), seed=int(seed),
        moving_normal=moving_normal,
    )
