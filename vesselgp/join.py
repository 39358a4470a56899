"""Minimum-torsion joining of a vessel end to another vessel (paper Section 2.3 and 3).

A :class:`JoinProblem` holds a vessel, the vertices held in place, the end that
is joined and the :class:`Frame` where that end must go. ``problem.deform(angle)``
turns the joined end by ``angle`` about the target tangent (``angle = 0`` maps
the end's rest normal U onto the target normal: the anchor-point
correspondence a user would otherwise pick, Section 2.3) and
``problem.energy(angle)`` is the torsion energy of Eq. 8 measured on the
deformed mesh by :class:`vesselgp.TorsionMeter` (Eq. 6-7).
:func:`minimize_torsion` finds the angle of least energy without user-chosen
anchor points, and :func:`stitch` bridges the joined end to the other vessel's
end ring so the result can be exported.

The search uses what is known about the energy (Fig. 4: close to quadratic in
the angle, because the deformation distributes ``alpha_end = alpha_0 + angle``
along the free part without wrapping): three probes around the rod's
zero-twist angle ``-alpha_0`` give a parabola whose vertex is bracketed, then
NLopt's BOBYQA (a quadratic trust-region model, derivative-free) polishes the
angle inside the bracket.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field

import igl
import nlopt
import numpy as np

from . import tolerances as tol
from ._validate import as_mesh, as_vector
from .deform import RodDeformer, as_vertex_ids
from .errors import EndsError, FrameError, OptimizationError
from .torsion import TorsionMeter, TorsionProfile

log = logging.getLogger(__name__)

__all__ = ["Frame", "JoinProblem", "JoinResult", "minimize_torsion", "stitch"]

_NLOPT_NAMES = {
    1: "SUCCESS", 2: "STOPVAL_REACHED", 3: "FTOL_REACHED", 4: "XTOL_REACHED", 5: "MAXEVAL_REACHED",
    6: "MAXTIME_REACHED", -1: "FAILURE", -2: "INVALID_ARGS", -3: "OUT_OF_MEMORY", -4: "ROUNDOFF_LIMITED",
    -5: "FORCED_STOP",
}


@dataclass(frozen=True)
class Frame:
    """Where the joined end goes: its centre, axis direction and reference normal.

    Validated at construction: ``tangent`` is normalised, ``normal`` is made
    perpendicular to it and normalised.

    Attributes
    ----------
    origin : (3,) float64
        New centre of the moving end.
    tangent : (3,) float64
        Unit direction of the vessel's axis at the end, pointing *out of* the
        deformed vessel (for a join: minus the other vessel's outward end
        direction from :func:`vesselgp.vessel_ends`).
    normal : (3,) float64
        Unit, perpendicular to ``tangent``: the image of the moving end's rest
        normal U at angle 0.

    Raises
    ------
    FrameError
        Non-finite entries, zero tangent, or a normal parallel to the tangent.

    Examples
    --------
    >>> f = Frame([0, 0, 0], [0, 0, 2], [1, 0, 1])
    >>> f.tangent.tolist(), f.normal.tolist()
    ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0])
    >>> Frame([0, 0, 0], [0, 0, 1], [0, 0, 3])
    Traceback (most recent call last):
    ...
    vesselgp.errors.FrameError: normal is parallel to tangent; give a normal across the axis
    """

    origin: np.ndarray
    tangent: np.ndarray
    normal: np.ndarray

    def __post_init__(self):
        o = as_vector(self.origin, "origin")
        t = as_vector(self.tangent, "tangent")
        # divide by the largest entry first: any non-zero length (1e-300 or
        # 1e300) gives a unit vector, no overflow or underflow
        mt = float(np.abs(t).max())
        if not mt > 0:
            raise FrameError("tangent is the zero vector; give the direction of the vessel axis at the join")
        t = t / mt
        t = t / np.linalg.norm(t)
        n = as_vector(self.normal, "normal")
        mn = float(np.abs(n).max())
        if not mn > 0:
            raise FrameError("normal is the zero vector; give a direction across the axis")
        n = n / mn
        nn = float(np.linalg.norm(n))
        n = n - (n @ t) * t
        if np.linalg.norm(n) < tol.FRAME_ORTHONORMAL * nn:
            raise FrameError("normal is parallel to tangent; give a normal across the axis")
        n = n / np.linalg.norm(n)
        for name, v in (("origin", o), ("tangent", t), ("normal", n)):
            v.setflags(write=False)
            object.__setattr__(self, name, v)

    @classmethod
    def facing(cls, end, normal):
        """Target that joins onto another vessel's end: centre ``end.center``, tangent ``-end.direction``.

        Parameters
        ----------
        end : VesselEnd
            The other vessel's end (``center``, unit outward ``direction``).
        normal : (3,) float64
            Where the moving end's rest U goes at angle 0.
        """
        return cls(end.center, -np.asarray(end.direction, float), normal)


@dataclass(frozen=True, eq=False)
class JoinResult:
    """Outcome of :func:`minimize_torsion`.

    Attributes
    ----------
    angle : float
        Optimal turn of the moving end about the target tangent, radians.
    energy : float
        Torsion energy (Eq. 8) at ``angle``.
    V : (n, 3) float64
        Deformed vertices at ``angle`` (faces of the problem).
    profile : TorsionProfile
        Measured torsion at ``angle``.
    angles : (k,) float64
        Every angle evaluated, in order (probes first).
    energies : (k,) float64
        Their energies.
    status : int
        NLopt's result code (``nlopt.XTOL_REACHED`` = 4, ...).
    status_name : str
        Its name (``"XTOL_REACHED"``, ...).
    n_evals : int
        Number of energy evaluations (``len(angles)``).
    algorithm : str
        The NLopt algorithm used.
    """

    angle: float
    energy: float
    V: np.ndarray = field(repr=False)
    profile: TorsionProfile = field(repr=False)
    angles: np.ndarray = field(repr=False)
    energies: np.ndarray = field(repr=False)
    status: int = 0
    status_name: str = ""
    n_evals: int = 0
    algorithm: str = "LN_BOBYQA"


def _fit(V, F, ends):
    from .fit import fit_generalized_cylinder

    return fit_generalized_cylinder(V, F, ends=ends)


class JoinProblem:
    """Joining one end of a vessel to a target frame (paper Section 2.3, 3).

    Fits the generalized cylinder, builds the :class:`vesselgp.TorsionMeter`
    and the deformation's factorisations once; each angle then costs one
    placement, a few ARAP iterations and one torsion measurement.

    Parameters
    ----------
    V : (n, 3) float64
        Rest vertices of the vessel that is deformed.
    F : (m, 3) int64
        Its triangles.
    fixed : (p,) int
        Vertex ids held in place (an end ring or a whole region).
    moving : (q,) int
        Vertex ids of the end that is joined.
    target : Frame
        Where the moving end goes.
    method : {"rod_arap", "rod", "arap", "laplacian"}
        Deformation method (:class:`vesselgp.deform.RodDeformer`).
    gc : GeneralizedCylinder, optional
        Rest fit of ``V`` (fitted here when omitted).
    ends : optional
        Ends for that fit (see :func:`vesselgp.fit_generalized_cylinder`).
    arap_iterations : int, optional
    stiffness : {"uniform", "radius4"}
    smoothing : float, optional
        Smoothing of the measured alpha (default: the meter's own, see
        :class:`vesselgp.TorsionMeter`).

    Attributes
    ----------
    deformer : RodDeformer
    meter : TorsionMeter
    gc : GeneralizedCylinder
    target : Frame

    Examples
    --------
    >>> from vesselgp.synthetic import paper_case
    >>> c = paper_case(1, resolution=0.25)
    >>> p = JoinProblem(c.V, c.F, c.fixed, c.moving,
    ...                 Frame(c.target_origin, c.target_tangent, c.target_normal))
    >>> X = p.deform(0.3)
    >>> bool(np.allclose(X[c.fixed], c.V[c.fixed]))
    True
    """

    def __init__(self, V, F, fixed, moving, target, *, method="rod_arap", gc=None, ends=None,
                 arap_iterations=None, stiffness="uniform", smoothing=None, _shared=None):
        if not isinstance(target, Frame):
            raise FrameError("target must be a vesselgp.Frame(origin, tangent, normal)")
        self.target = target
        if _shared is not None:
            self.V, self.F, self.gc, self.deformer, self.meter = _shared
        else:
            V, F = as_mesh(V, F)
            n = len(V)
            fixed = as_vertex_ids(fixed, n, "fixed")
            moving = as_vertex_ids(moving, n, "moving")
            if np.intersect1d(fixed, moving).size:
                raise EndsError("fixed and moving vertex sets overlap; the joined end cannot also be held")
            if gc is None:
                gc = _fit(V, F, ends)
            self.V, self.F, self.gc = V, F, gc
            self.deformer = RodDeformer(V, F, fixed, moving, gc=gc, method=method,
                                        arap_iterations=arap_iterations, stiffness=stiffness)
            kw = {} if smoothing is None else {"smoothing": smoothing}
            self.meter = TorsionMeter(V, F, gc, **kw)
        self._cache = {}

    @property
    def fixed(self):
        """(p,) int64 held vertex ids."""
        return self.deformer.fixed

    @property
    def moving(self):
        """(q,) int64 ids of the joined end."""
        return self.deformer.moving

    @property
    def zero_twist_angle(self):
        """Angle (radians) at which the rod step imposes no twist: ``-alpha_0`` about the tangent.

        The minimum-torsion angle is close to it (exactly for the ``"rod"`` method
        up to the measurement's error).
        """
        d = self.deformer
        return -d.alpha_end(self.target, 0.0) * d._sign

    def retarget(self, target):
        """A problem with another target sharing this one's fit, meter and factorisations."""
        return JoinProblem(None, None, None, None, target, _shared=(self.V, self.F, self.gc, self.deformer, self.meter))

    def deform(self, angle):
        """Deformed vertices (n, 3) with the moving end on the target turned by ``angle`` (radians)."""
        return self.deformer.deform(self.target, float(angle))

    def profile(self, angle):
        """:class:`vesselgp.TorsionProfile` of the deformation at ``angle``."""
        return self._evaluate(float(angle))[1]

    def _evaluate(self, angle):
        hit = self._cache.get(angle)
        if hit is None:
            X = self.deform(angle)
            hit = (X, self.meter(X))
            if len(self._cache) > 8:
                self._cache.pop(next(iter(self._cache)))
            self._cache[angle] = hit
        return hit

    def energy(self, angle):
        """Torsion energy (Eq. 8) of the deformation at ``angle`` (radians)."""
        return float(self._evaluate(float(angle))[1].energy)

    def energy_curve(self, angles):
        """Energies at each of ``angles`` (radians): the paper's Fig. 4.

        Returns
        -------
        E : (k,) float64
        """
        return np.array([self.energy(a) for a in np.atleast_1d(np.asarray(angles, float))])


def _parabola(a, e):
    """Vertex and curvature of the parabola through three (angle, energy) samples."""
    c2, c1, _ = np.polyfit(a, e, 2)
    return (-c1 / (2 * c2) if c2 > 0 else np.nan), c2


def minimize_torsion(problem, *, xtol=tol.JOIN_XTOL, max_evals=tol.JOIN_MAX_EVALS, algorithm="LN_BOBYQA",
                     initial_step=tol.JOIN_INITIAL_STEP, probe_step=tol.JOIN_PROBE_STEP):
    """Angle of the joined end with the least torsion energy (paper Section 2.3, Fig. 2e/3e).

    1. Three probes at ``a0`` and ``a0 +- JOIN_PROBE_STEP`` where ``a0`` is the
       rod's zero-twist angle (:attr:`JoinProblem.zero_twist_angle`); the vertex
       of their parabola estimates the optimum (the energy is close to quadratic,
       Fig. 4). If the parabola is not convex, a 12-point grid over a full turn
       picks the start instead.
    2. NLopt (default ``LN_BOBYQA``, a derivative-free quadratic-model method)
       within ``+- JOIN_BRACKET`` of the estimate, ``xtol`` absolute.
    3. The best evaluated angle is returned (never worse than a probe).

    Parameters
    ----------
    problem : JoinProblem
    xtol : float
        Absolute tolerance on the angle, radians.
    max_evals : int
        Maximum NLopt evaluations (the probes come on top).
    algorithm : str
        Name of a derivative-free NLopt algorithm (``"LN_BOBYQA"``, ``"LN_COBYLA"``, ...).
    initial_step : float
        NLopt's first step from the parabola's vertex, radians.
    probe_step : float
        Spacing of the three probes, radians.

    Returns
    -------
    JoinResult

    Raises
    ------
    OptimizationError
        Non-finite energy, or an NLopt failure.

    Examples
    --------
    >>> from vesselgp.synthetic import paper_case
    >>> c = paper_case(1, resolution=0.25, pre_rotation=0.5)
    >>> p = JoinProblem(c.V, c.F, c.fixed, c.moving,
    ...                 Frame(c.target_origin, c.target_tangent, c.target_normal))
    >>> res = minimize_torsion(p)
    >>> res.energy < 0.01 * p.energy(0.0), res.n_evals < 20
    (True, True)
    """
    if not isinstance(problem, JoinProblem):
        raise OptimizationError("minimize_torsion needs a vesselgp.JoinProblem")
    alg = getattr(nlopt, str(algorithm), None)
    if alg is None or not str(algorithm).startswith(("LN_", "GN_")):
        raise OptimizationError(f"unknown derivative-free NLopt algorithm {algorithm!r}; use e.g. 'LN_BOBYQA'")
    angles, energies = [], []

    def f(a):
        e = problem.energy(a)
        angles.append(float(a))
        energies.append(e)
        if not np.isfinite(e):
            raise OptimizationError(
                f"torsion energy is not finite at angle {np.degrees(a):.3g} degrees; check the mesh and target"
            )
        return e

    a0 = float(problem.zero_twist_angle)
    h = float(probe_step)
    probes = np.array([a0 - h, a0, a0 + h])
    ep = np.array([f(a) for a in probes])
    centre, curv = _parabola(probes, ep)
    if not np.isfinite(centre) or abs(centre - a0) > 3 * h:
        log.info("energy not convex near the zero-twist angle; scanning a full turn")
        grid = a0 + np.linspace(-np.pi, np.pi, 12, endpoint=False)
        eg = np.array([f(a) for a in grid])
        centre = float(grid[int(np.argmin(eg))])
    lo, hi = centre - tol.JOIN_BRACKET, centre + tol.JOIN_BRACKET
    opt = nlopt.opt(alg, 1)
    opt.set_min_objective(lambda x, grad: f(float(x[0])))
    opt.set_lower_bounds([lo])
    opt.set_upper_bounds([hi])
    opt.set_xtol_abs(float(xtol))
    opt.set_ftol_rel(tol.JOIN_FTOL_REL)
    opt.set_maxeval(int(max_evals))
    opt.set_initial_step([float(initial_step)])
    try:
        opt.optimize([centre])
        status = int(opt.last_optimize_result())
    except nlopt.RoundoffLimited:
        status = nlopt.ROUNDOFF_LIMITED
    except OptimizationError:
        raise
    except (RuntimeError, ValueError, MemoryError) as exc:
        raise OptimizationError(f"NLopt {algorithm} failed: {exc}; try algorithm='LN_COBYLA'") from None
    A, E = np.array(angles), np.array(energies)
    k = int(np.argmin(E))
    best = float(A[k])
    X, prof = problem._evaluate(best)
    log.info("minimize_torsion: angle %.4f deg, energy %.4g, %d evaluations, %s",
             np.degrees(best), E[k], len(A), _NLOPT_NAMES.get(status, str(status)))
    return JoinResult(angle=best, energy=float(E[k]), V=X, profile=prof, angles=A, energies=E,
                      status=status, status_name=_NLOPT_NAMES.get(status, str(status)), n_evals=len(A),
                      algorithm=str(algorithm))


# ----------------------------------------------------------------------------- stitching


def _ordered_loop(F, ids, name):
    """The boundary loop of ``F`` made of ``ids``, ordered along the faces' boundary half-edges."""
    ids = np.asarray(ids, np.int64).reshape(-1)
    want = set(ids.tolist())
    for lp in igl.boundary_loop_all(F):
        lp = np.asarray(lp, np.int64)
        if set(lp.tolist()) == want:
            break
    else:
        raise EndsError(f"{name} ids are not one boundary loop of their mesh; give the ids of an open end ring")
    # orient so that (lp[i], lp[i+1]) is a directed edge of some face
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    directed = set(map(tuple, E.tolist()))
    if (int(lp[0]), int(lp[1])) not in directed:
        lp = lp[::-1]
    return lp


def _arc_param(P):
    seg = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)
    c = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
    return c / seg.sum()


def stitch(V, F, moving_loop_ids, other_V, other_F, other_loop_ids):
    """Bridge the joined end ring to the other vessel's end ring: one mesh for export.

    Both loops are parameterised by normalised arc length from aligned starts
    (the other loop's start is the vertex at the angle, about the moving loop's
    axis, closest to the moving loop's first vertex) and zipped into a triangle
    strip that advances on whichever loop is behind, so loops of different
    vertex counts are joined without new vertices or T-junctions. The strip is
    oriented consistently with ``F``; ``other_F`` is flipped if its
    orientation disagrees.

    Parameters
    ----------
    V : (n, 3) float64
        Deformed vessel (e.g. :attr:`JoinResult.V`).
    F : (m, 3) int64
    moving_loop_ids : (q,) int
        Its joined end ring (a boundary loop of ``F``).
    other_V : (n2, 3) float64
    other_F : (m2, 3) int64
    other_loop_ids : (r,) int
        The other vessel's end ring (a boundary loop of ``other_F``).

    Returns
    -------
    V : (n + n2, 3) float64
    F : (m + m2 + q + r, 3) int64
        ``F``, then ``other_F`` (offset by n), then the strip.

    Raises
    ------
    EndsError
        When the ids are not boundary loops.

    Examples
    --------
    >>> from vesselgp.synthetic import synthetic_vessel
    >>> a = synthetic_vessel("straight", n_around=8, remesh=False)
    >>> b = synthetic_vessel([[0, 0, 31], [0, 0, 41], [0, 0, 51], [0, 0, 61]], n_around=12, remesh=False)
    >>> Vj, Fj = stitch(a.V, a.F, np.arange(len(a.V) - 8, len(a.V)), b.V, b.F, np.arange(12))
    >>> len(Fj) == len(a.F) + len(b.F) + 20, len(igl.boundary_loop_all(Fj))
    (True, 2)
    """
    V, F = as_mesh(V, F)
    W, G = as_mesh(other_V, other_F)
    G = G.copy()
    A = _ordered_loop(F, moving_loop_ids, "moving_loop_ids")
    B = _ordered_loop(G, other_loop_ids, "other_loop_ids")
    PA, PB = V[A], W[B]
    ca = PA.mean(axis=0)
    nA = np.sum(np.cross(PA - ca, np.roll(PA, -1, axis=0) - ca), axis=0)
    nA /= np.linalg.norm(nA)
    nB = np.sum(np.cross(PB - PB.mean(0), np.roll(PB, -1, axis=0) - PB.mean(0)), axis=0)
    # a consistently oriented joined tube has the two boundary loops turning opposite ways about the axis
    if nB @ nA > 0:
        log.warning("other_F is oriented opposite to F; flipping it for a consistent joined mesh")
        G = G[:, ::-1].copy()
        B = B[::-1]
        PB = W[B]
    B = B[::-1]  # traverse B in A's rotational sense
    PB = W[B]
    e1 = PA[0] - ca
    e1 -= (e1 @ nA) * nA
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(nA, e1)
    dB = PB - ca
    angB = np.arctan2(dB @ e2, dB @ e1)
    k = int(np.argmin(np.abs(angB)))
    B = np.roll(B, -k)
    PB = W[B]
    ta, tb = _arc_param(PA), _arc_param(PB)
    na, nb = len(A), len(B)
    ia = ib = 0
    tri = []
    off = len(V)
    while ia < na or ib < nb:
        ta_next = ta[ia + 1] if ia + 1 < na else 1.0
        tb_next = tb[ib + 1] if ib + 1 < nb else 1.0
        a, a1 = A[ia % na], A[(ia + 1) % na]
        b, b1 = B[ib % nb] + off, B[(ib + 1) % nb] + off
        if ib >= nb or (ia < na and ta_next <= tb_next):
            tri.append((a1, a, b))  # uses A's edge reversed
            ia += 1
        else:
            tri.append((a, b, b1))
            ib += 1
    S = np.array(tri, np.int64)
    return np.concatenate([V, W]), np.concatenate([F, G + off, S])
