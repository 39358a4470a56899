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

import nlopt
import numpy as np

from . import tolerances as tol
from ._validate import as_mesh, as_vector
from .deform import Frame, RodDeformer, as_vertex_ids
from .errors import EndsError, FrameError, MismatchError, OptimizationError
from .fit import fit_generalized_cylinder
from .mesh import stitch
from .rotations import rotate, wrap_angle
from .torsion import TorsionMeter, TorsionProfile, warn_damped

log = logging.getLogger(__name__)

__all__ = ["Frame", "JoinProblem", "JoinResult", "minimize_torsion", "stitch"]

# stitch (vesselgp.mesh.stitch) and Frame (vesselgp.deform) are re-exported: joining uses both

_NLOPT_NAMES = {
    1: "SUCCESS", 2: "STOPVAL_REACHED", 3: "FTOL_REACHED", 4: "XTOL_REACHED", 5: "MAXEVAL_REACHED",
    6: "MAXTIME_REACHED", -1: "FAILURE", -2: "INVALID_ARGS", -3: "OUT_OF_MEMORY", -4: "ROUNDOFF_LIMITED",
    -5: "FORCED_STOP",
}


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
    grid_scan : bool
        True when the three probes did not give a convex parabola near the
        zero-twist angle and a 12-point scan over a full turn chose NLopt's
        start instead (the energy is then far from Fig. 4's quadratic shape).
    zero_twist_angle : float
        The rod's twist-free angle (:attr:`JoinProblem.zero_twist_angle`), radians.
    roll : float
        ``angle - zero_twist_angle`` wrapped to (-pi, pi]: how far the end is
        rolled beyond the twist-free placement at the optimum.
    axial_stretch : float
        Deformed over rest length of the free axis (:attr:`RodPlacement.axial_stretch`).
    max_bend : float
        Largest curvature times radius of the deformed axis (:attr:`RodPlacement.max_bend`).
    max_edge_stretch : float
        Largest deformed-over-rest edge length at the optimum.
    moving_normal, target_normal : (3,) float64
        The anchors: angle 0 lands ``moving_normal`` (rest, at the moving end)
        on ``target_normal`` (:class:`JoinProblem`).
    joined_V : (N, 3) float64 or None
        The optimum stitched to the other vessel (:func:`vesselgp.join_vessels`), else None.
    joined_F : (M, 3) int64 or None
    seam : (q,) int64 or None
        Vertex ids, in ``joined_V``, of the moving end's ring where the two vessels meet.
    F : (m, 3) int64
        Faces of ``V`` (the problem's; for :func:`vesselgp.join_vessels`, of the moving vessel
        with its joined end opened).
    fixed, moving : (p,), (q,) int64
        Held vertex ids and the joined end ring, in ``V``.
    kept : (n,) int64 or None
        For :func:`vesselgp.join_vessels`: the id in the input mesh of each row of ``V``.
    placement : (4, 4) float64 or None
        For :func:`vesselgp.join_vessels` with ``place``: the rigid move ``[R t; 0 1]`` made to the
        moving vessel before the join (``V`` is deformed from the moved vessel), else None.
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
    grid_scan: bool = False
    zero_twist_angle: float = 0.0
    roll: float = 0.0
    axial_stretch: float = 1.0
    max_bend: float = 0.0
    max_edge_stretch: float = 1.0
    moving_normal: np.ndarray | None = field(default=None, repr=False)
    target_normal: np.ndarray | None = field(default=None, repr=False)
    joined_V: np.ndarray | None = field(default=None, repr=False)
    joined_F: np.ndarray | None = field(default=None, repr=False)
    seam: np.ndarray | None = field(default=None, repr=False)
    F: np.ndarray | None = field(default=None, repr=False)
    fixed: np.ndarray | None = field(default=None, repr=False)
    moving: np.ndarray | None = field(default=None, repr=False)
    kept: np.ndarray | None = field(default=None, repr=False)
    placement: np.ndarray | None = field(default=None, repr=False)


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
    moving_normal : (3,) float64, optional
        The anchor at the moving end: a direction across the end (in rest
        coordinates; its part along the end's axis is dropped). When given,
        angle 0 lands it on ``target.normal``; when omitted, angle 0 lands the
        fit's rest U of the end there (an internal reference). Either way a
        positive angle turns the end right-handed about ``target.tangent``.

    Attributes
    ----------
    deformer : RodDeformer
        Target-free precomputation (fit, factorisations).
    meter : TorsionMeter
    gc : GeneralizedCylinder
    target : Frame
        As given.
    moving_normal : (3,) float64
        The anchor at the moving end (unit, across its rest axis): the given
        one, or the fit's U there.
    anchor_offset : float
        Angle (radians) from the fit's U to ``moving_normal`` about the end's
        outward rest tangent.
    placement : RodPlacement
        The per-target part of the deformation (its frame's normal is where the
        fit's U lands at angle 0).

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
                 arap_iterations=None, stiffness="uniform", smoothing=None, moving_normal=None):
        if not isinstance(target, Frame):
            raise FrameError("target must be a vesselgp.Frame(origin, tangent, normal)")
        V, F = as_mesh(V, F)
        n = len(V)
        fixed = as_vertex_ids(fixed, n, "fixed")
        moving = as_vertex_ids(moving, n, "moving")
        if np.intersect1d(fixed, moving).size:
            raise EndsError("fixed and moving vertex sets overlap; the joined end cannot also be held")
        if gc is None:
            gc = fit_generalized_cylinder(V, F, ends=ends)
        deformer = RodDeformer(V, F, fixed, moving, gc=gc, method=method,
                               arap_iterations=arap_iterations, stiffness=stiffness)
        meter = TorsionMeter(V, F, gc, smoothing=smoothing)
        self._set(deformer, meter, target, moving_normal)

    @classmethod
    def from_precomputed(cls, deformer, meter, target, moving_normal=None):
        """A problem for ``target`` that reuses a deformer's and a meter's factorisations.

        Parameters
        ----------
        deformer : RodDeformer
        meter : TorsionMeter
            Built on the same rest mesh as ``deformer``.
        target : Frame
        moving_normal : (3,) float64, optional
            The anchor at the moving end (see :class:`JoinProblem`).
        """
        if not isinstance(target, Frame):
            raise FrameError("target must be a vesselgp.Frame(origin, tangent, normal)")
        if not isinstance(deformer, RodDeformer) or not isinstance(meter, TorsionMeter):
            raise MismatchError("from_precomputed needs a vesselgp.deform.RodDeformer and a vesselgp.TorsionMeter")
        if meter.rest is not deformer.gc:
            raise MismatchError("the meter and the deformer must share one rest fit (TorsionMeter(V, F, deformer.gc))")
        self = cls.__new__(cls)
        self._set(deformer, meter, target, moving_normal)
        return self

    def _set(self, deformer, meter, target, moving_normal):
        self.target = target
        self.deformer, self.meter = deformer, meter
        self.V, self.F, self.gc = deformer.V, deformer.F, deformer.gc
        t, u = deformer.end_tangent, deformer.end_normal
        if moving_normal is None:
            self.moving_normal, self.anchor_offset = u.copy(), 0.0
        else:
            m = as_vector(moving_normal, "moving_normal")
            m = m - (m @ t) * t
            if not np.linalg.norm(m) > tol.FRAME_ORTHONORMAL * max(1.0, float(np.linalg.norm(moving_normal))):
                raise FrameError("moving_normal is parallel to the moving end's axis; give a direction across it")
            self.moving_normal = m / np.linalg.norm(m)
            self.anchor_offset = float(np.arctan2(np.cross(u, self.moving_normal) @ t, u @ self.moving_normal))
        # Q maps (t, u) to (target.tangent, n(angle)), so it maps moving_normal = rot_t(u, phi) to rot(n, phi):
        # the fit's U must land on the target normal turned back by phi
        inner = Frame(target.origin, target.tangent, rotate(target.normal, target.tangent, -self.anchor_offset))
        self.placement = deformer.place(inner)
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
        return self.placement.zero_twist_angle

    def retarget(self, target):
        """A problem with another target sharing this one's fit, meter, anchor and factorisations."""
        return JoinProblem.from_precomputed(self.deformer, self.meter, target, self.moving_normal)

    def deform(self, angle):
        """Deformed vertices (n, 3) with the moving end on the target turned by ``angle`` (radians)."""
        return self.placement.deform(float(angle))

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

    def result_fields(self, X):
        """The :class:`JoinResult` fields that describe deformed vertices ``X`` of this problem.

        ``axial_stretch``, ``max_bend``, ``max_edge_stretch``, the anchors and the
        problem's ``F``, ``fixed`` and ``moving``.
        """
        pl = self.placement
        return {"axial_stretch": pl.axial_stretch, "max_bend": pl.max_bend[0],
                "max_edge_stretch": self.deformer.edge_stretch(X), "moving_normal": self.moving_normal,
                "target_normal": self.target.normal, "F": self.F, "fixed": self.fixed, "moving": self.moving}

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


def minimize_torsion(problem, *, xtol=None, max_evals=None, algorithm="LN_BOBYQA", initial_step=None,
                     probe_step=None):
    """Angle of the joined end with the least torsion energy (paper Section 2.3, Fig. 2e/3e).

    1. Three probes at ``a0`` and ``a0 +- JOIN_PROBE_STEP`` where ``a0`` is the
       rod's zero-twist angle (:attr:`JoinProblem.zero_twist_angle`); the vertex
       of their parabola estimates the optimum (the energy is close to quadratic,
       Fig. 4). If the parabola is not convex, a 12-point grid over a full turn
       picks the start instead (``JoinResult.grid_scan``).
    2. NLopt (default ``LN_BOBYQA``, a derivative-free quadratic-model method)
       within ``+- JOIN_BRACKET`` of the estimate, ``xtol`` absolute.
    3. The best evaluated angle is returned (never worse than a probe).

    Parameters
    ----------
    problem : JoinProblem
    xtol : float, optional
        Absolute tolerance on the angle, radians (default ``tolerances.JOIN_XTOL``,
        read at call time; likewise the other defaults below).
    max_evals : int, optional
        Maximum NLopt evaluations (the probes come on top; ``JOIN_MAX_EVALS``).
    algorithm : str
        Name of a derivative-free NLopt algorithm (``"LN_BOBYQA"``, ``"LN_COBYLA"``, ...).
    initial_step : float, optional
        NLopt's first step from the parabola's vertex, radians (``JOIN_INITIAL_STEP``).
    probe_step : float, optional
        Spacing of the three probes, radians (``JOIN_PROBE_STEP``).

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
    xtol = tol.JOIN_XTOL if xtol is None else float(xtol)
    max_evals = tol.JOIN_MAX_EVALS if max_evals is None else int(max_evals)
    initial_step = tol.JOIN_INITIAL_STEP if initial_step is None else float(initial_step)
    probe_step = tol.JOIN_PROBE_STEP if probe_step is None else float(probe_step)
    log_ = _EnergyLog(problem)
    centre, grid_scan = _bracket_centre(log_, float(problem.zero_twist_angle), probe_step)
    status = _polish(log_, alg, str(algorithm), centre, xtol, max_evals, initial_step)
    A, E = np.array(log_.angles), np.array(log_.energies)
    k = int(np.argmin(E))
    best = float(A[k])
    X, prof = problem._evaluate(best)
    name = _NLOPT_NAMES.get(status, str(status))
    log.info("minimize_torsion: angle %.4f deg, energy %.4g, %d evaluations, %s%s",
             np.degrees(best), E[k], len(A), name, " (after a grid scan)" if grid_scan else "")
    warn_damped(prof, problem.meter.smoothing, "the twist at the least-torsion angle")
    zero = float(problem.zero_twist_angle)
    return JoinResult(angle=best, energy=float(E[k]), V=X, profile=prof, angles=A, energies=E,
                      status=status, status_name=name, n_evals=len(A), algorithm=str(algorithm),
                      grid_scan=grid_scan, zero_twist_angle=zero, roll=float(wrap_angle(best - zero)),
                      **problem.result_fields(X))


class _EnergyLog:
    """The problem's energy as an objective that records every evaluation and refuses non-finite values."""

    def __init__(self, problem):
        self.problem = problem
        self.angles, self.energies = [], []

    def __call__(self, a):
        e = self.problem.energy(a)
        self.angles.append(float(a))
        self.energies.append(e)
        if not np.isfinite(e):
            raise OptimizationError(
                f"torsion energy is not finite at angle {np.degrees(a):.3g} degrees; check the mesh and target"
            )
        return e


def _bracket_centre(f, a0, h):
    """Vertex of the parabola through three probes about ``a0``; a full-turn grid's best when not convex.

    Returns the centre and whether the grid scan was used.
    """
    probes = np.array([a0 - h, a0, a0 + h])
    ep = np.array([f(a) for a in probes])
    centre, _ = _parabola(probes, ep)
    if np.isfinite(centre) and abs(centre - a0) <= 3 * h:
        return float(centre), False
    log.warning("torsion energy is not convex near the zero-twist angle; scanning a full turn for the start")
    grid = a0 + np.linspace(-np.pi, np.pi, tol.JOIN_GRID_POINTS, endpoint=False)
    eg = np.array([f(a) for a in grid])
    return float(grid[int(np.argmin(eg))]), True


def _polish(f, alg, algorithm, centre, xtol, max_evals, initial_step):
    """NLopt within ``+- JOIN_BRACKET`` of ``centre``; returns NLopt's result code."""
    opt = nlopt.opt(alg, 1)
    opt.set_min_objective(lambda x, grad: f(float(x[0])))
    opt.set_lower_bounds([centre - tol.JOIN_BRACKET])
    opt.set_upper_bounds([centre + tol.JOIN_BRACKET])
    opt.set_xtol_abs(xtol)
    opt.set_ftol_rel(tol.JOIN_FTOL_REL)
    opt.set_maxeval(max_evals)
    opt.set_initial_step([initial_step])
    try:
        opt.optimize([centre])
        return int(opt.last_optimize_result())
    except nlopt.RoundoffLimited:
        return nlopt.ROUNDOFF_LIMITED
    except OptimizationError:
        raise
    except (RuntimeError, ValueError, MemoryError) as exc:
        raise OptimizationError(f"NLopt {algorithm} failed: {exc}; try algorithm='LN_COBYLA'") from None
