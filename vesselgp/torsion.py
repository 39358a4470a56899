"""Material torsion of a deformed vessel against its rotation-minimizing frame (paper Eq. 6-8).

Given a rest mesh and a deformed mesh with the same connectivity, from any
deformation method:

1. the deformed medial axis is recovered by Eq. 6, the fixed point of Eq. 3
   with the rest correspondence (each vertex keeps its rest ``s_i``), followed
   by the circle-fit corrections of :mod:`vesselgp.fit` that remove Eq. 1's bend
   bias (on a clean, densely meshed wall with the rest fit's final weight, to their convergence);
2. its RMF is computed by double reflection (Section 1) and every vertex is
   re-parameterised ``(s_i, theta_i)`` on the deformed axis (above
   ``tolerances.TORSION_MEAN_VERTICES`` vertices, an evenly thinned subset of
   that size: each bin of step 3 still averages hundreds of vertices);
3. ``alpha(s)`` is Eq. 7's mean of ``theta_i - theta_i^0`` over the vertices of
   each stretch of axis, taken as a *circular* mean of wrapped differences and
   then unwrapped along ``s`` so that twists of several turns are measured;
4. ``alpha`` is smoothed by a cubic smoothing spline with a smoothing length of
   about half a radius (the derivative amplifies noise; Eq. 2 likewise
   regularises the axis), and the torsion energy of Eq. 8 is the integral of
   the spline's ``alpha'(s)^2`` over normalised arc length.

The rest parameterisation ``theta_i^0`` is computed by the very same recovery on
the rest mesh, so the identity deformation gives exactly zero and the small
discretisation errors of the recovery cancel between rest and deformed states.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.interpolate import make_smoothing_spline

from . import tolerances as tol
from ._validate import as_deformed, as_mesh
from .curves import frenet, polyline_feet
from .errors import MismatchError, NotTubularError
from ._arrays import spread_subset, thinned
from .axis import Axis, circle_fit_correction, difference_matrix, hat_matrix, local_coords
from .sections import section_shape
from .fit import GeneralizedCylinder, fit_generalized_cylinder
from .rotations import wrap_angle

log = logging.getLogger(__name__)

__all__ = ["TorsionProfile", "TorsionMeter", "measure_torsion"]


@dataclass(frozen=True)
class TorsionProfile:
    """Material torsion of a deformed vessel (paper Eq. 7-8) and its Frenet quantities.

    Attributes
    ----------
    s : (K,) float64
        Normalised (rest) arc length of the samples, in [0, 1].
    alpha : (K,) float64
        Rotation of the material directors about the axis against the RMF,
        radians, unwrapped along ``s``, ``alpha[0] = 0`` (Eq. 7).
    dalpha : (K,) float64
        Material torsion ``d alpha / ds``, radians per unit of normalised arc length.
    energy : float
        Torsion energy ``E = int_0^1 alpha'(s)^2 ds`` (Eq. 8).
    total_twist : float
        ``alpha(1) - alpha(0)``, radians.
    twist_per_length : float
        ``total_twist`` divided by ``length``: radians per mesh unit.
    length : float
        Arc length of the deformed axis, mesh units: the rest fit's axis length
        (:attr:`GeneralizedCylinder.length`, as ``vesselgp fit`` reports it) times the
        measured stretch of the Eq. 6 axis (deformed over rest recovery), so the rest mesh
        itself gives the fit's length and a stretch of the vessel scales it.
    vertex_alpha : (n,) float64
        ``alpha`` at each vertex's ``s`` (for shading).
    centers : (K, 3) float64
        Deformed axis points at ``s``.
    frames : (K, 3, 3) float64
        RMF of the deformed axis at ``s`` (rows ``T, U, V``).
    bin_s, bin_alpha : (B,) float64
        The raw, unsmoothed circular means of Eq. 7 per bin (unwrapped), for
        inspection.
    smoothing_residual : float
        The largest departure, radians, of those bin means from the smoothed ``alpha`` at their ``s``, over
        the interior 90 % of ``s`` (``tolerances.TORSION_RESIDUAL_EDGE``): most
        of how far ``alpha`` is off where the twist varies faster than the smoothing length (the spline
        damps it: 0.91-0.97 of the error on the swept real lines), more where the bins scatter (a wall too
        sparse for its bends). Above
        ``tolerances.TORSION_DAMPED`` :func:`measure_torsion` says so at WARNING (issue #48: 180 degrees
        over 1.8 radii of a swept real carotid, alpha 13.7 degrees off, read 12.5; the clean single-tube
        cases read at most 0.19 degrees).
    axis_scale : float
        Mean rest radius: the length below whose reciprocal the axis counts as
        straight (see :func:`vesselgp.curves.frenet`).
    curvature : (K,) float64
        Frenet curvature of the deformed axis, per mesh unit (computed on
        first access: the torsion energy does not need it).
    frenet_torsion : (K,) float64
        Frenet torsion of the deformed axis (the *other* torsion of Section 1,
        as reported by VMTK), per mesh unit; NaN where the axis is straight.
    frenet_defined : (K,) bool
        False where the axis is straight and the Frenet frame does not exist.
    """

    s: np.ndarray
    alpha: np.ndarray
    dalpha: np.ndarray
    energy: float
    total_twist: float
    twist_per_length: float
    length: float
    vertex_alpha: np.ndarray = field(repr=False)
    centers: np.ndarray = field(repr=False)
    frames: np.ndarray = field(repr=False)
    bin_s: np.ndarray = field(repr=False)
    bin_alpha: np.ndarray = field(repr=False)
    axis_scale: float = field(repr=False)
    smoothing_residual: float = 0.0

    @cached_property
    def _frenet(self):
        return frenet(self.centers, length_scale=self.axis_scale, smooth=True)

    @property
    def curvature(self):
        return self._frenet.curvature

    @property
    def frenet_torsion(self):
        return self._frenet.torsion

    @property
    def frenet_defined(self):
        return self._frenet.defined


class TorsionMeter:
    """Measures torsion of many deformations of one rest vessel (precompute object).

    Holds the rest generalized cylinder, the factorised Eq. 6 system (the hat
    basis of the rest ``s_i`` and the ``lambda`` regulariser) and the rest angles
    ``theta_i^0``, so each call costs one sparse back-substitution, two circle-fit
    corrections (up to their convergence on a clean, dense wall: 4-8) and the vertex projection.

    Parameters
    ----------
    V_rest : (n, 3) float64, or a mesh object
        Rest vertex positions, or a ``trimesh.Trimesh``, ``pyvista.PolyData``,
        ``meshio.Mesh`` or :class:`vesselgp.PreparedMesh` (``F`` left out; :func:`vesselgp.as_mesh`).
    F : (m, 3) int64
        Triangles (shared by rest and deformed meshes).
    rest : GeneralizedCylinder, optional
        Fitted on ``V_rest``; fitted here when omitted. A path or branch of
        :func:`vesselgp.fit_vessel_tree` measures the twist of its own vertices
        (the others, with NaN parameters, are left out).
    ends : optional
        Passed to :func:`vesselgp.fit_generalized_cylinder` when ``rest`` is fitted here.
    smoothing : float, optional
        Smoothing length of the alpha spline in axis-node spacings (half a
        mean radius each); twist that varies faster than this is damped.
        Default ``tolerances.TORSION_SMOOTHING``, read when the meter is built.
    correct_bias : int, optional
        Number of circle-fit corrections after Eq. 6 (they remove Eq. 1's bend
        bias), with the rest fit's ``lam``; 0 keeps the plain Eq. 6 axis. Default
        ``tolerances.TORSION_BIAS_CORRECTIONS``, or on a clean, densely meshed circular wall
        (:func:`_clean_dense_wall`) corrections with the rest fit's final weight (``final_lam``) until
        they converge, at most ``tolerances.TORSION_CLEAN_CORRECTIONS``.

    Examples
    --------
    >>> from vesselgp.synthetic import synthetic_vessel, deform_synthetic
    >>> ves = synthetic_vessel("straight", radius=1.5, n_around=24, remesh=False)
    >>> meter = TorsionMeter(ves.V, ves.F)
    >>> prof = meter(deform_synthetic(ves, twist=np.pi / 2))
    >>> round(float(np.degrees(prof.total_twist)))
    90
    """

    def __init__(self, V_rest, F=None, rest=None, *, ends=None, smoothing=None, correct_bias=None):
        V_rest, F = as_mesh(V_rest, F)
        self.F = F
        self.n = len(V_rest)
        if rest is None:
            rest = fit_generalized_cylinder(V_rest, F, ends=ends)
        if not isinstance(rest, GeneralizedCylinder):
            raise MismatchError("rest must be a GeneralizedCylinder from fit_generalized_cylinder")
        if len(rest.vertex_s) != self.n:
            raise MismatchError(
                f"rest generalized cylinder has {len(rest.vertex_s)} vertices, the mesh {self.n}; "
                "fit it on V_rest"
            )
        self.rest = rest
        self.smoothing = tol.TORSION_SMOOTHING if smoothing is None else float(smoothing)
        self.correct_bias = tol.TORSION_BIAS_CORRECTIONS if correct_bias is None else int(correct_bias)
        self.lam = rest.lam  # Eq. 2's lambda of the rest fit, for Eq. 6
        # a clean, dense circular wall: its corrections with the rest fit's final weight, to their convergence
        self._converge = correct_bias is None and _clean_dense_wall(rest)
        self._lam_corr = self.lam
        K = len(rest.s)
        self.K = K
        self.n_bins = tol.TORSION_BINS_PER_NODE * K
        # a tree's branch or path parameterises only its own vertices (NaN elsewhere): those are left out
        on = np.isfinite(rest.vertex_s)
        if not on.any():
            raise MismatchError("rest generalized cylinder parameterises no vertex; fit it on V_rest")
        if on.all():
            self._sub = spread_subset(self.n, tol.TORSION_RECOVERY_VERTICES)  # bias correction on a subset
            self._mean = thinned(self.n, tol.TORSION_MEAN_VERTICES)  # Eq. 7 means on a thinned subset
        else:
            ids = np.flatnonzero(on)
            self._sub = ids[spread_subset(len(ids), tol.TORSION_RECOVERY_VERTICES)]
            self._mean = ids[thinned(len(ids), tol.TORSION_MEAN_VERTICES)]
        self.s0 = np.where(on, rest.vertex_s, 0.0)  # off the cylinder: no area, no weight in Eq. 6
        self.w = rest.vertex_weight
        self.area = rest.vertex_area
        # an elliptic wall's corrections carry its sections' second harmonic, as its fit did (vesselgp.sections)
        sub = self._sub
        self._elliptic = section_shape(self.s0[sub], rest.vertex_local[sub], self.area[sub], K).elliptic
        self.rscale = rest.mean_radius
        # Eq. 6: (B^T W B + lambda R) m = B^T W p, factorised once.
        B = hat_matrix(self.s0, K)
        self.BtW = (B.multiply(self.area[:, None])).T.tocsr()
        N = (self.BtW @ B).tocsc()
        Wbar = float(N.diagonal().mean())
        D2 = difference_matrix(K, 2)
        N = N + self.lam * Wbar * (D2.T @ D2) + tol.TORSION_EQ6_RIDGE * Wbar * sp.eye(K)
        self._eq6 = spla.splu(N.tocsc())
        # rest angles by the same recovery
        self._theta0 = None
        rest_axis, _, self._theta0 = self._parameterise(V_rest)
        _check_recovery(rest_axis, rest)
        # the deformed length is the rest fit's scaled by the Eq. 6 axis's own stretch: the Eq. 6 axis of an
        # open end overshoots it by tenths of a millimetre (0.7 % on the real coronary), which cancels
        self._length_scale = rest.length / rest_axis.length

    def _recover_axis(self, V):
        """Eq. 6 with the rest correspondence, then the circle-fit corrections: ``correct_bias`` of them, or on a
        clean, dense circular wall with the rest fit's final weight until they converge (:func:`_converged`)."""
        nodes = self._eq6.solve(np.asarray(self.BtW @ V))
        axis = Axis(nodes)
        sub = self._sub
        Vs = V[sub]
        steps = []
        for _ in range(tol.TORSION_CLEAN_CORRECTIONS if self._converge else self.correct_bias):
            s = self._map_s(axis, nodes, sub)
            local, jac = local_coords(axis, Vs, s)
            w = self.area[sub] / np.clip(jac, tol.GC_MIN_STRETCH, None)
            _, frn = axis.at(self._node_s(axis, nodes))
            corr = circle_fit_correction(frn, nodes, s, local, w, self._lam_corr, self.rscale, pin_ends=False,
                                         elliptic=self._elliptic)
            nodes = nodes + corr
            axis = Axis(nodes)
            steps.append(float(np.linalg.norm(corr, axis=1).max()) / self.rscale)
            if self._converge and _converged(steps):
                break
        return axis, nodes

    def _node_s(self, axis, nodes):
        """Deformed normalised arc length of each node (nodes sit at rest s = k / (K-1))."""
        seg = np.linalg.norm(np.diff(nodes, axis=0), axis=1)
        c = np.concatenate([[0.0], np.cumsum(seg)])
        return c / c[-1]

    def _map_s(self, axis, nodes, sub):
        """The rest ``s`` of vertices ``sub`` mapped onto the deformed axis."""
        return np.interp(self.s0[sub], np.linspace(0, 1, self.K), self._node_s(axis, nodes))

    def _parameterise(self, V):
        """Deformed axis and the angle ``theta_i`` of each vertex of the Eq. 7 subset."""
        axis, nodes = self._recover_axis(V)
        # the rest s mapped onto the deformed axis is a close start: Newton only
        sub = self._mean
        Vm = V[sub]
        s_start = self._map_s(axis, nodes, sub)
        s = np.clip(axis.project(Vm, s_start), 0.0, 1.0)
        pts, fr = axis.at(s)
        d = Vm - pts
        theta = np.arctan2(np.einsum("ij,ij->i", d, fr[:, 2]), np.einsum("ij,ij->i", d, fr[:, 1]))
        return axis, nodes, theta

    def __call__(self, V_deformed):
        """Torsion profile of a deformed copy of the rest mesh.

        Parameters
        ----------
        V_deformed : (n, 3) float64, or a mesh object
            Deformed vertex positions, same order and count as ``V_rest``; or a mesh object
            (as ``V_rest``) with the rest mesh's faces.

        Returns
        -------
        TorsionProfile
        """
        V = as_deformed(V_deformed, self.F)
        if len(V) != self.n:
            raise MismatchError(
                f"rest and deformed meshes differ: {self.n} vs {len(V)} vertices; "
                "the deformed mesh must keep the rest mesh's vertices and faces"
            )
        axis, nodes, theta = self._parameterise(V)
        dtheta = wrap_angle(theta - self._theta0)
        return self._profile(axis, nodes, dtheta)

    def _profile(self, axis, nodes, dtheta):
        K = self.K
        w = self.w[self._mean]
        s0 = self.s0[self._mean]
        # Eq. 7 per bin: circular mean of the wrapped differences
        nb = self.n_bins
        b = np.minimum((s0 * nb).astype(np.int64), nb - 1)
        z = np.bincount(b, weights=w * np.cos(dtheta), minlength=nb) + 1j * np.bincount(
            b, weights=w * np.sin(dtheta), minlength=nb
        )
        wb = np.bincount(b, weights=w, minlength=nb)
        sb = np.bincount(b, weights=w * s0, minlength=nb)
        ok = (wb > 0) & (np.abs(z) > 0)
        sb = sb[ok] / wb[ok]
        ab = np.unwrap(np.angle(z[ok]))
        conf = np.abs(z[ok]) / wb[ok]  # 1 for a coherent rotation, lower when scattered
        wts = wb[ok] * conf**2
        keep = np.concatenate([[True], np.diff(sb) > tol.TORSION_MIN_BIN_GAP / nb])
        sb, ab, wts = sb[keep], ab[keep], wts[keep]
        # smoothing length: `smoothing` node spacings (a node is half a radius);
        # lam = (bins per unit s) * length^4 gives a transfer 1 / (1 + (omega length)^4)
        lam = len(sb) * (self.smoothing / K) ** 4
        spl = make_smoothing_spline(sb, ab, w=wts / wts.mean(), lam=lam)
        sK = np.linspace(0.0, 1.0, K)
        a0 = float(spl(0.0))
        alpha = spl(sK) - a0
        dspl = spl.derivative()
        dalpha = dspl(sK)
        sq = np.linspace(0.0, 1.0, 20 * K + 1)
        energy = float(np.trapezoid(dspl(sq) ** 2, sq))
        a_q = spl(sq) - a0  # the smooth spline on 20 samples per node: linear interpolation is exact to ~1e-6 of a turn
        total = float(spl(1.0) - a0)
        centers, frames = axis.at(self._node_s(axis, nodes))
        length = self._length_scale * axis.length
        return TorsionProfile(
            s=sK,
            alpha=alpha,
            dalpha=dalpha,
            energy=energy,
            total_twist=total,
            twist_per_length=total / length,
            length=length,
            vertex_alpha=np.interp(self.s0, sq, a_q),
            centers=centers,
            frames=frames,
            bin_s=sb,
            bin_alpha=ab - a0,
            axis_scale=self.rscale,
            smoothing_residual=_smoothing_residual(spl, sb, ab),
        )


def _clean_dense_wall(rest):
    """Whether rest fit ``rest`` is of a clean, densely meshed circular wall: its final circle fit lowered Eq. 2's
    weight to at most ``GC_REFINE_LAMBDA`` of ``lam`` (:func:`vesselgp.fit.data_lambda`: scatter about its circles
    under 0.7 % of the radius) and it has at least ``GC_SPARSE_VERTICES`` data vertices per axis segment (a sparse
    ring wall's corrections with the lower weight ran away: the thin XCAT line swept 8 around)."""
    if rest.final_lam is None or rest.final_lam > tol.GC_REFINE_LAMBDA * rest.lam:
        return False
    n_data = np.count_nonzero((rest.vertex_weight > 0) & np.isfinite(rest.vertex_s))
    return n_data >= tol.GC_SPARSE_VERTICES * (len(rest.s) - 1)


def _converged(steps):
    """Whether the recovery's corrections (their largest node moves, radii) have converged: the last under
    ``GC_CONVERGENCE``, or the next one predicted from the last two (``step^2 / previous``, contracting) under it."""
    if steps[-1] < tol.GC_CONVERGENCE:
        return True
    return len(steps) > 1 and steps[-1] < steps[-2] and steps[-1] ** 2 / steps[-2] < tol.GC_CONVERGENCE


def _smoothing_residual(spl, sb, ab):
    """The largest departure (radians) of Eq. 7's bin means ``ab`` at ``sb`` from the smoothed profile ``spl``, over
    the bins of the interior 90 % of s (where the accuracy of docs/accuracy.md is stated): the half-bins at an open
    end follow the end's own wall, up to 1.5 degrees off an imposed smooth twist, and the spline rightly leaves
    them."""
    inner = (sb > tol.TORSION_RESIDUAL_EDGE) & (sb < 1.0 - tol.TORSION_RESIDUAL_EDGE)
    return float(np.abs(spl(sb[inner]) - ab[inner]).max()) if inner.any() else 0.0


def _check_recovery(recovered, rest):
    """Raise :class:`NotTubularError` when the meter's axis recovery (Eq. 6 and its circle-fit corrections) on the
    rest mesh itself runs on average more than ``TORSION_RECOVERY_OFF`` radii from the rest fit's axis (the middle
    90 % of it): its angles about that axis would not be the material twist. A 2.5:1 flattened vein (issue #48)
    read 0.046 radii, and its imposed twists were measured 12-34 degrees off, energies 45-133 % off; circular walls
    read at most 0.016 (the thin XCAT line swept 8 around; the real coronary 0.005)."""
    m = len(recovered.points)
    inner = slice(m // 20, m - m // 20)
    _, _, d = polyline_feet(recovered.points[inner], rest.dense_points)
    off = float(np.mean(d / rest.radius_at(recovered.s[inner])))
    if off > tol.TORSION_RECOVERY_OFF:
        raise NotTubularError(
            f"cannot measure torsion on this vessel: the meter's axis, recovered from the rest mesh itself, runs "
            f"{off:.2g} radii off the rest fit's axis on average (at most {tol.TORSION_RECOVERY_OFF:g}); its "
            "sections are likely far from round (a flattened vein), and angles about that axis would not be the "
            "material twist")


def measure_torsion(V_rest, V_deformed, F=None, rest=None, *, ends=None, smoothing=None):
    """Material torsion of a deformed vessel against its RMF (paper Eq. 6-8).

    One-off form of :class:`TorsionMeter`; use the meter when measuring many
    deformations of the same rest mesh.

    Parameters
    ----------
    V_rest : (n, 3) float64, or a mesh object
        Rest vertex positions, or a ``trimesh.Trimesh``, ``pyvista.PolyData``,
        ``meshio.Mesh`` or :class:`vesselgp.PreparedMesh` (``F`` left out; :func:`vesselgp.as_mesh`).
    V_deformed : (n, 3) float64, or a mesh object
        Deformed vertex positions, same vertex order; or a mesh object with the same faces.
    F : (m, 3) int64
        Triangles shared by both (left out when ``V_rest`` is a mesh object).
    rest : GeneralizedCylinder, optional
        Fitted on ``V_rest`` (fitted when omitted); a path or branch of
        :func:`vesselgp.fit_vessel_tree` measures its own vertices only.
    ends : optional
        Ends for the rest fit (see :func:`vesselgp.fit_generalized_cylinder`).
    smoothing : float, optional
        Smoothing length of the alpha spline, in axis-node spacings (default
        ``tolerances.TORSION_SMOOTHING``).

    Returns
    -------
    TorsionProfile

    Raises
    ------
    MismatchError
        When the rest and deformed meshes have different vertex counts (or faces).

    Examples
    --------
    A uniform twist of total Phi has torsion energy Phi^2 (Eq. 8):

    >>> from vesselgp.synthetic import synthetic_vessel, deform_synthetic
    >>> ves = synthetic_vessel("straight", radius=1.5, n_around=24, remesh=False)
    >>> prof = measure_torsion(ves.V, deform_synthetic(ves, twist=1.0), ves.F)
    >>> round(prof.energy, 2)
    1.0
    """
    V_rest, F = as_mesh(V_rest, F)
    V_def = as_deformed(V_deformed, F)
    if V_def.shape != V_rest.shape:
        raise MismatchError(
            f"rest and deformed meshes differ: {len(V_rest)} vs {len(V_def)} vertices; "
            "the deformed mesh must keep the rest mesh's vertices and faces"
        )
    if F.max() >= len(V_def):
        raise MismatchError("faces index vertices the deformed mesh does not have")
    prof = TorsionMeter(V_rest, F, rest, ends=ends, smoothing=smoothing)(V_def)
    warn_damped(prof, smoothing)
    return prof


def warn_damped(prof, smoothing=None, what="the measured twist"):
    """Log a WARNING where profile ``prof``'s Eq. 7 bin means depart from its smoothed alpha by more than
    ``tolerances.TORSION_DAMPED`` (:attr:`TorsionProfile.smoothing_residual`): alpha may be off by as much
    (:func:`measure_torsion`; :func:`vesselgp.minimize_torsion` of its optimum's profile). ``smoothing``: the
    meter's, named in the advice (default ``tolerances.TORSION_SMOOTHING``)."""
    if prof.smoothing_residual > tol.TORSION_DAMPED:
        log.warning("%s departs from its smoothed profile by up to %.2g degrees (at most %.2g expected): alpha may "
                    "be off by as much; it varies faster than the smoothing length (smoothing %g node spacings: pass "
                    "a smaller smoothing, e.g. 0.3) or the wall is too sparse for its bends", what,
                    np.degrees(prof.smoothing_residual), np.degrees(tol.TORSION_DAMPED),
                    tol.TORSION_SMOOTHING if smoothing is None else smoothing)
