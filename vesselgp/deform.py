"""Handle-based deformation of a vessel that spreads an end rotation like an elastic rod.

Paper Section 2.3 deforms the mesh with a differential-geometry method
(Laplacian deformation, ref. [7]) while some vertices are held and the joined
end is moved. Plain Laplacian editing and ARAP with a few iterations keep a
rotation of the end within a few radii of it: a twist does not travel along a
tube through local smoothing. This module therefore deforms the *generalized
cylinder* first and the mesh second (method ``"rod_arap"``, the default):

1. **Axis.** Between the boundary ``s_b`` of the fixed region and the moving
   end ``s_e`` (normalised free parameter ``u = (s - s_b) / (s_e - s_b)``), the
   rest tangent is turned about the axis ``k`` of the minimal rotation
   ``R(k, phi)`` that takes the rest outward end tangent to the target tangent,
   by ``w(u) phi`` with ``w(u) = 3u^2 - 2u`` (the slope of a clamped elastic
   beam's end-rotation mode), and integrated; the remaining end offset ``c``
   is added with the clamped-beam displacement mode ``h(u) = 3u^2 - 2u^3``.
   Position and tangent are continuous at ``s_b`` (C1 join to the fixed part)
   and exact at ``s_e``; in the linear regime this is the minimum-bending
   (cubic Hermite) beam.
2. **Frames.** The RMF of the new axis (double reflection, Section 1) is
   transported from the fixed part's frame at ``s_b``.
3. **Twist.** The material director at ``s_e`` must be the target normal
   turned by ``angle`` about the target tangent; its angle about the axis from
   the transported RMF is ``alpha_end = alpha_0 + angle`` (not wrapped, so the
   energy is a smooth, nearly quadratic function of ``angle``: Fig. 4).
   ``alpha(s)`` minimises ``int J(s) alpha'(s)^2 ds`` with ``alpha(s_b) = 0``:
   ``alpha(u) = alpha_end int_0^u J^-1 / int_0^1 J^-1``. With the default
   ``stiffness="uniform"`` (``J = 1``) alpha is linear, which is the minimiser
   of the paper's Eq. 8 itself; ``stiffness="radius4"`` uses ``J ~ r(s)^4``
   (thin-walled tube with wall thickness proportional to the radius).
4. **Placement.** Every vertex keeps its rest ``(s_i, theta_i, offset)``
   (``GeneralizedCylinder.vertex_local``) and is placed in the new frame turned
   by ``alpha(s_i)``; fixed vertices keep their positions, the moving vertices
   are placed by the rigid map of the end frame onto the target frame. An end
   cut obliquely spans a range of ``s``; the free vertices within that range
   follow the rigid map too and the rod placement blends into it over
   ``tolerances.DEFORM_END_BLEND`` times the range (smoothstep), so the ring
   and its neighbours do not disagree by the bend's rotation across the ring
   (which folded faces next to the cut end of a real iliac).
5. **Refinement.** A few ARAP iterations (libigl's spokes-and-rims energy and
   its local and global steps, :mod:`vesselgp._arap`) from that start with the
   fixed and moving vertices as handles (the factorisation is computed once).

``"rod"`` stops after step 4. ``"arap"`` (ARAP from the rest shape) and
``"laplacian"`` (cotangent-Laplacian editing: the bi-Laplacian of the
displacement is minimised, paper ref. [7] without rotation updates) are kept
for comparison; both concentrate an end twist near the end.

The split follows libigl's ``arap_precomputation`` / ``arap_solve``:
:class:`RodDeformer` holds everything that does not depend on the target (the
fit, the free part, the vertex interpolation weights, the ARAP and Laplacian
factorisations); :meth:`RodDeformer.place` returns a :class:`RodPlacement`
holding what does not depend on the angle (deformed axis, its RMF, per-vertex
frames); each angle then costs one vectorised placement plus the ARAP
iterations. The join target is a :class:`Frame`.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import igl
import numpy as np
import scipy.sparse as sp

from . import tolerances as tol
from ._arap import ArapSolver
from ._validate import as_mesh, as_vector
from .axis import interp_frames
from .curves import rotation_minimizing_frames, transport_angle
from .errors import EndsError, FrameError, MismatchError, OptionError
from .fit import GeneralizedCylinder, fit_generalized_cylinder
from .mesh import MeshTopology
from .mesh._geometry import voronoi_areas
from .rotations import minimal_rotation, rotate, unit, unit_rows

log = logging.getLogger(__name__)

__all__ = ["Frame", "RodDeformer", "RodPlacement", "deform_vessel", "METHODS", "STIFFNESS", "as_vertex_ids"]

#: Deformation methods of :class:`RodDeformer`.
METHODS = ("rod_arap", "rod", "arap", "laplacian")
#: Torsional stiffness laws of :class:`RodDeformer`.
STIFFNESS = ("uniform", "radius4")


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
        t = unit(self.tangent, "tangent", "the direction of the vessel axis at the join")
        n = unit(self.normal, "normal", "a direction across the axis")
        n = n - (n @ t) * t
        nn = float(np.linalg.norm(n))
        if nn < tol.FRAME_ORTHONORMAL:
            raise FrameError("normal is parallel to tangent; give a normal across the axis")
        n = n / nn
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


def as_frame(target):
    """A :class:`Frame` from a Frame or a tuple ``(origin, tangent, normal)`` (validated)."""
    if isinstance(target, Frame):
        return target
    try:
        o, t, nrm = target
    except (TypeError, ValueError):
        raise FrameError("target must be a vesselgp.Frame or a tuple (origin, tangent, normal)") from None
    return Frame(o, t, nrm)


def as_vertex_ids(ids, n, name):
    """Sorted unique int64 vertex ids in ``[0, n)``, or raise :class:`EndsError`.

    Parameters
    ----------
    ids : array_like of int or bool mask of length n
    n : int
        Number of vertices.
    name : str
        Used in messages (``"fixed"``, ``"moving"``).

    Examples
    --------
    >>> as_vertex_ids([3, 1, 3], 5, "fixed")
    array([1, 3])
    """
    a = np.asarray(ids)
    if a.dtype == bool:
        if a.shape != (n,):
            raise EndsError(f"{name} mask has shape {a.shape}; it must have one entry per vertex ({n})")
        a = np.flatnonzero(a)
    a = a.reshape(-1)
    if a.size == 0:
        raise EndsError(f"{name} vertex set is empty; give the ids of the {name} vertices")
    if not np.issubdtype(a.dtype, np.integer):
        if not np.issubdtype(a.dtype, np.floating) or np.any(a != np.round(a)):
            raise EndsError(f"{name} must hold integer vertex ids")
    a = np.unique(a.astype(np.int64))
    if a[0] < 0 or a[-1] >= n:
        raise EndsError(f"{name} ids span [{a[0]}, {a[-1]}] but the mesh has {n} vertices; use ids in [0, {n - 1}]")
    return a


# ----------------------------------------------------------------------------- precompute (target-free)


class RodDeformer:
    """Target-free precomputation of a vessel's handle deformation (paper Section 2.3; module notes).

    Holds the fit, the free part between the held and the moving vertices,
    the per-vertex interpolation weights and the ARAP / Laplacian
    factorisations. :meth:`place` gives the per-target :class:`RodPlacement`.

    Parameters
    ----------
    V : (n, 3) float64
        Rest vertex positions.
    F : (m, 3) int64
        Triangles.
    fixed : (p,) int
        Vertex ids held in place: an end ring or a whole region. Everything on
        the fixed side of the fixed vertex farthest from the moving end stays put.
    moving : (q,) int
        Vertex ids of the end that is moved (its boundary loop, or loop and cap).
    gc : GeneralizedCylinder, optional
        Fitted on ``V`` (fitted here when omitted, with ``ends``). A path of
        :func:`vesselgp.fit_vessel_tree` works too: the vertices it leaves
        unparameterised (NaN, other branches) must then be in ``fixed``.
    ends : optional
        Passed to :func:`vesselgp.fit_generalized_cylinder`.
    method : {"rod_arap", "rod", "arap", "laplacian"}
        See the module notes.
    arap_iterations : int, optional
        ARAP iterations: default :data:`~vesselgp.tolerances.DEFORM_REFINE_ITERATIONS`
        for ``"rod_arap"``, :data:`~vesselgp.tolerances.DEFORM_ARAP_ITERATIONS`
        for ``"arap"`` (read at construction).
    stiffness : {"uniform", "radius4"}
        Torsional stiffness ``J(s)`` used to distribute the twist.

    Attributes
    ----------
    gc : GeneralizedCylinder
    fixed, moving : (p,), (q,) int64
    s_end : float
        0.0 or 1.0: the GC end at the moving vertices.
    s_boundary : float
        ``s`` of the dense axis node where the free part starts.
    free_length : float
        Rest arc length of the free part (mesh units).
    handles : (p + q,) int64
        ``fixed`` then ``moving``.
    end_center : (3,) float64
        Rest centre of the moving end.
    end_frame : (3, 3) float64
        Rest frame at the moving end, rows ``T, U, V`` of the fit.
    end_tangent, end_normal : (3,) float64
        Outward rest axis direction and rest U at the moving end: the
        :class:`Frame` ``(end_center, end_tangent, end_normal)`` leaves the end in place.

    Raises
    ------
    EndsError
        Empty, overlapping or out-of-range vertex sets, moving vertices not at
        an end of the vessel, or no free part between the fixed and moving sets.
    OptionError
        Unknown method or stiffness.
    """

    def __init__(self, V, F, fixed, moving, *, gc=None, ends=None, method="rod_arap",
                 arap_iterations=None, stiffness="uniform"):
        V, F = as_mesh(V, F)
        n = len(V)
        if method not in METHODS:
            raise OptionError(f"unknown deformation method {method!r}; use one of {', '.join(METHODS)}")
        if stiffness not in STIFFNESS:
            raise OptionError(f"unknown stiffness {stiffness!r}; use {' or '.join(map(repr, STIFFNESS))}")
        fixed = as_vertex_ids(fixed, n, "fixed")
        moving = as_vertex_ids(moving, n, "moving")
        both = np.intersect1d(fixed, moving)
        if both.size:
            raise EndsError(
                f"fixed and moving vertex sets overlap in {both.size} vertices; the joined end cannot also be held"
            )
        if gc is None:
            gc = fit_generalized_cylinder(V, F, ends=ends)
        if not isinstance(gc, GeneralizedCylinder) or len(gc.vertex_s) != n:
            raise MismatchError("gc must be a GeneralizedCylinder fitted on V (same vertex count)")
        off = ~np.isfinite(gc.vertex_s)
        off[fixed] = False
        if off.any():
            raise EndsError(f"{int(off.sum())} vertices lie off the fitted path (other branches of a tree) and are "
                            "not held; hold them (add them to fixed)")
        self.V, self.F, self.gc = V, F, gc
        self.fixed, self.moving = fixed, moving
        self.method = method
        self.stiffness = stiffness
        self.n = n
        self.handles = np.concatenate([fixed, moving])
        self._free_part()
        self._twist_shape()
        self._vertex_weights()
        pe, fe = gc.at([self.s_end])
        self.end_center = pe[0]
        self.end_frame = fe[0]
        self.end_tangent = self.sign * fe[0, 0]  # outward
        self.end_normal = fe[0, 1]
        self._factorise(arap_iterations)
        self._edges = self._edge_rest = None  # for edge_stretch, built on first use
        log.debug("RodDeformer: method %s, free part %.3g (%.1f radii), %d free vertices",
                  method, self.free_length, self.free_length / gc.mean_radius, len(self.free))

    def _free_part(self):
        """Which end moves (``s_end``), where the free part starts, its dense-axis nodes."""
        gc, r, L = self.gc, self.gc.mean_radius, self.gc.length
        sm = gc.vertex_s[self.moving]
        if not np.all(np.isfinite(sm)):
            raise EndsError("moving vertices lie off the fitted path; give the ring of the end the path runs to")
        self.s_end = 1.0 if float(np.mean(sm)) >= 0.5 else 0.0
        far = float(np.max(np.abs(sm - self.s_end))) * L
        if far > tol.JOIN_END_REACH * r:
            raise EndsError(
                f"moving vertices reach {far / r:.1f} radii from the vessel's end; give the ids of one end "
                "(its boundary loop) as moving"
            )
        ds = gc.dense_s
        sf = gc.vertex_s[self.fixed]
        sf = sf[np.isfinite(sf)]  # a tree path leaves the other branches' vertices unparameterised (NaN)
        if len(sf) == 0:
            raise EndsError("no fixed vertex lies on the fitted path; hold part of the vessel the path runs through")
        # the node at or beyond the fixed vertex nearest the moving end (half a sample of slack)
        half = 0.5 / (len(ds) - 1)
        if self.s_end == 1.0:
            jb = int(np.searchsorted(ds, float(sf.max()) - half * tol.DEFORM_NODE_SLACK, side="left"))
            nodes = np.arange(jb, len(ds))
        else:
            jb = int(np.searchsorted(ds, float(sf.min()) + half * tol.DEFORM_NODE_SLACK, side="right")) - 1
            nodes = np.arange(jb, -1, -1)
        jb = int(np.clip(jb, 0, len(ds) - 1))
        self.s_boundary = float(ds[jb])
        self.free_length = abs(self.s_end - self.s_boundary) * L
        if len(nodes) < 3 or self.free_length < tol.JOIN_MIN_FREE_LENGTH * r:
            raise EndsError(
                f"the fixed vertices reach within {self.free_length / r:.2f} radii of the moving end; "
                "leave a free part of the vessel between them"
            )
        self.nodes = nodes  # dense-axis node indices from s_b to s_e
        self.u = (ds[nodes] - self.s_boundary) / (self.s_end - self.s_boundary)
        self.sign = 1.0 if self.s_end > self.s_boundary else -1.0

    def _twist_shape(self):
        """g(u) with alpha = alpha_end g: minimiser of int J alpha'^2 with alpha(s_b) = 0 (module notes, step 3)."""
        if self.stiffness == "uniform":
            self.g = self.u.copy()
            return
        r = self.gc.radius_at(self.gc.dense_s[self.nodes])
        if not np.all(r > 0):
            raise MismatchError("the fitted radius vanishes on the free part; stiffness='radius4' needs r(s) > 0")
        inv = 1.0 / r**4
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (inv[1:] + inv[:-1]) * np.diff(self.u))])
        self.g = cum / cum[-1]

    def _vertex_weights(self):
        """Free vertices, their rest ``s`` and rest local coordinates (offset, x, y in the frame at ``s``)."""
        sv = self.gc.vertex_s
        free = (sv > self.s_boundary) if self.s_end == 1.0 else (sv < self.s_boundary)
        free[self.fixed] = False
        free[self.moving] = False
        self.free = np.flatnonzero(free)
        self.free_s = sv[self.free]
        self.local = self.gc.vertex_local[self.free]
        self._end_blend()

    def _end_blend(self):
        """Weights of the rigid end map for free vertices next to an oblique end ring (module notes, step 4).

        The moving ring spans the axial range from ``s_r`` (its vertex farthest
        from the end) to ``s_e``. Free vertices in that range follow the ring's
        rigid map; over ``DEFORM_END_BLEND`` times the range before it the rod
        placement blends into it (smoothstep). A ring square to the axis
        (``s_r = s_e``) leaves the rod placement unchanged.
        """
        sm = self.gc.vertex_s[self.moving]
        s_r = float(sm.min() if self.s_end == 1.0 else sm.max())
        extent = abs(self.s_end - s_r)
        x = np.zeros(len(self.free))
        if extent > 0.0:
            beyond = (self.free_s - s_r) * np.sign(self.s_end - s_r)  # > 0 inside the ring's range
            width = min(tol.DEFORM_END_BLEND * extent, abs(s_r - self.s_boundary))  # never into the held part
            x = np.clip(1.0 + beyond / max(width, np.finfo(float).eps), 0.0, 1.0)
        self._blend = np.flatnonzero(x > 0.0)
        self._beta = (x * x * (3.0 - 2.0 * x))[self._blend]

    def edge_stretch(self, X):
        """Largest deformed-over-rest edge length of deformed vertices ``X`` ((n, 3) float64)."""
        if self._edges is None:  # the mesh's edge table, once (MeshTopology's single sort)
            top = MeshTopology(self.F, self.n)
            ln = top.edge_lengths(self.V)
            self._edges, self._edge_rest = top.edges[ln > 0], ln[ln > 0]
        E = self._edges
        return float(np.max(np.linalg.norm(X[E[:, 0]] - X[E[:, 1]], axis=1) / self._edge_rest))

    def _factorise(self, arap_iterations):
        """The target-free factorisations: the ARAP solver or the bi-Laplacian's min_quad_with_fixed."""
        V, F, method = self.V, self.F, self.method
        self._arap = None
        self._mqwf = None
        self.arap_iterations = 0
        if method in ("rod_arap", "arap"):
            if arap_iterations is None:
                arap_iterations = tol.DEFORM_REFINE_ITERATIONS if method == "rod_arap" else tol.DEFORM_ARAP_ITERATIONS
            self.arap_iterations = int(arap_iterations)
            if self.arap_iterations > 0:
                self._arap_part = _arap_part(F, self.n, self.handles)
                Vp, Fp, bp = self._arap_part
                self._arap = ArapSolver(V[Vp], Fp, bp)
        if method == "laplacian":
            Lc = igl.cotmatrix(V, F)
            M = voronoi_areas(V, F)
            A = (Lc.T @ sp.diags(1.0 / M) @ Lc).tocsc()
            self._mqwf = igl.min_quad_with_fixed_data()
            igl.min_quad_with_fixed_precompute(A, self.handles, sp.csc_matrix((0, self.n)), True, self._mqwf)
            self._lap_B = np.ascontiguousarray(-(A @ V))

    def arap(self, X, bc, iterations=None):
        """ARAP iterations (libigl's spokes and rims, :mod:`vesselgp._arap`) from ``X`` with the handles at ``bc``.

        Parameters
        ----------
        X : (n, 3) float64
            Start positions.
        bc : (p + q, 3) float64
            Handle positions (:meth:`RodPlacement.handle_positions`).
        iterations : int, optional
            Default: the deformer's ``arap_iterations``.

        Returns
        -------
        (n, 3) float64
        """
        if self._arap is None:
            raise OptionError(f"method {self.method!r} with {self.arap_iterations} ARAP iterations has no ARAP data")
        it = self.arap_iterations if iterations is None else int(iterations)
        Vp, _, bp = self._arap_part
        out = np.array(X, dtype=np.float64, order="C")
        out[self.handles] = bc
        out[Vp] = self._arap.solve(out[Vp], out[Vp[bp]], it)
        return out

    def laplacian(self, bc):
        """Bi-Laplacian editing with the handles at ``bc`` (paper ref. [7] without rotation updates)."""
        return igl.min_quad_with_fixed_solve(self._mqwf, self._lap_B, bc, np.zeros((0, 3)))

    def place(self, target):
        """The per-target :class:`RodPlacement` (deformed axis and frames) for ``target``.

        Parameters
        ----------
        target : Frame or (origin, tangent, normal)
        """
        return RodPlacement(self, as_frame(target))

    # one-off conveniences (each builds the placement for the target)

    def deform(self, target, angle=0.0):
        """Deformed vertices (n, 3) with the moving end on ``target`` turned by ``angle`` (radians)."""
        return self.place(target).deform(angle)

    def rod(self, target, angle):
        """The rod placement (steps 1-4 of the module notes) of every vertex, (n, 3)."""
        return self.place(target).rod(angle)

    def alpha_end(self, target, angle):
        """Material angle ``alpha(s_e)`` the rod imposes at ``angle`` (see :meth:`RodPlacement.alpha_end`)."""
        return self.place(target).alpha_end(angle)

    def axis(self, target):
        """Deformed axis of the rod step: dense ``s``, points (M, 3) and RMF frames (M, 3, 3)."""
        p = self.place(target)
        return self.gc.dense_s, p.axis_points, p.axis_frames

    def handle_positions(self, target, angle):
        """Positions (p + q, 3) of :attr:`handles` at ``angle``."""
        return self.place(target).handle_positions(angle)


# ----------------------------------------------------------------------------- per target


class RodPlacement:
    """The per-target part of a :class:`RodDeformer`: deformed axis, its RMF, per-vertex frames.

    Built by :meth:`RodDeformer.place`; each :meth:`deform` call then costs a
    vectorised placement and the ARAP iterations.

    Attributes
    ----------
    deformer : RodDeformer
    target : Frame
    alpha0 : float
        Angle about the GC tangent at the moving end from the transported RMF
        normal to the target normal: ``alpha_end(angle) = alpha0 + sign * angle``.
    axis_points : (M, 3) float64
        Deformed dense axis (rest outside the free part).
    axis_frames : (M, 3, 3) float64
        Its RMF, rows ``T, U, V`` in the fit's orientation.
    """

    def __init__(self, deformer, target):
        self.deformer = deformer
        self.target = target
        d, gc = deformer, deformer.gc
        Pn, Tg, Uf = self._bent_axis()
        # alpha_0: angle about T_gc at the end from the transported U to the target normal
        self.alpha0 = float(transport_angle(Tg[-1:], Uf[-1:], target.normal[None])[0])
        Pd = gc.dense_points.copy()
        Fd = gc.dense_frames.copy()
        gd = np.zeros(len(gc.dense_s))
        Pd[d.nodes] = Pn
        Fd[d.nodes] = np.stack([Tg, Uf, np.cross(Tg, Uf)], axis=1)
        gd[d.nodes] = d.g
        if d.s_end == 1.0:
            gd[d.nodes[-1]:] = 1.0
        else:
            gd[: d.nodes[-1] + 1] = 1.0
        self.axis_points, self.axis_frames = Pd, Fd
        self._vm, fr = interp_frames(gc.dense_s, Pd, Fd, d.free_s)
        self._vT, self._vU, self._vV = fr[:, 0], fr[:, 1], fr[:, 2]
        self._vg = np.interp(d.free_s, gc.dense_s, gd)

    def _bent_axis(self):
        """Steps 1-2 of the module notes: the bent free axis, its tangents and transported RMF normals."""
        d, gc, target = self.deformer, self.deformer.gc, self.target
        u = d.u
        P = gc.dense_points[d.nodes]
        Tu = d.sign * gc.dense_frames[d.nodes, 0]  # forward (towards the moving end)
        R = minimal_rotation(d.end_tangent, target.tangent)
        phi = float(R.magnitude())
        if phi > np.pi - tol.STRAIGHT_SIN:
            log.warning("target tangent is opposite to the rest end tangent: the bend direction is arbitrary")
        w = 3.0 * u * u - 2.0 * u
        Tn = Tu.copy()
        if phi > 0.0:
            Tn = rotate(Tu, R.as_rotvec() / phi, w * phi)
        Tn[-1] = target.tangent
        du = np.diff(u)[:, None] * d.free_length
        dP = np.concatenate([np.zeros((1, 3)), np.cumsum(0.5 * (Tn[1:] - Tu[1:] + Tn[:-1] - Tu[:-1]) * du, axis=0)])
        Pi = P + dP
        c = target.origin - Pi[-1]
        h = 3.0 * u * u - 2.0 * u**3
        dh = 6.0 * u - 6.0 * u * u
        Pn = Pi + h[:, None] * c
        Pn[-1] = target.origin
        Dn = d.free_length * Tn + dh[:, None] * c
        Dn = unit_rows(Dn)
        Tf, Uf, _ = rotation_minimizing_frames(Pn, Dn, initial_normal=gc.dense_frames[d.nodes[0], 1])
        return Pn, d.sign * Tf, Uf

    def alpha_end(self, angle):
        """Material angle ``alpha(s_e)`` (radians, about the GC tangent) the rod imposes at ``angle``."""
        return self.alpha0 + self.deformer.sign * float(angle)

    @property
    def axial_stretch(self):
        """Arc length of the deformed free axis over its rest length (1 = inextensible; angle-free)."""
        P = self.axis_points[self.deformer.nodes]
        return float(np.linalg.norm(np.diff(P, axis=0), axis=1).sum() / self.deformer.free_length)

    @property
    def max_bend(self):
        """Largest ``kappa(s) r(s)`` along the deformed free axis, and the ``s`` where it is.

        ``kappa`` is the discrete curvature (turning angle over the mean length of
        the two segments at a node) and ``r`` the rest radius there: above 1 the
        inner wall of the bend would fold over itself.

        Returns
        -------
        value : float
        s : float
        """
        d = self.deformer
        P = self.axis_points[d.nodes]
        e = np.diff(P, axis=0)
        ln = np.linalg.norm(e, axis=1)
        if len(ln) < 2 or not np.all(ln > 0) or not np.all(np.isfinite(P)):
            return math.inf, float(d.gc.dense_s[d.nodes[0]])  # a degenerate axis is not a plausible bend
        c = np.einsum("ij,ij->i", e[1:], e[:-1]) / (ln[1:] * ln[:-1])
        kappa = np.arccos(np.clip(c, -1.0, 1.0)) / (0.5 * (ln[1:] + ln[:-1]))
        s = d.gc.dense_s[d.nodes[1:-1]]
        kr = kappa * d.gc.radius_at(s)
        k = int(np.argmax(kr))
        return float(kr[k]), float(s[k])

    @property
    def zero_twist_angle(self):
        """Angle (radians) at which the rod step imposes no twist: ``-alpha0`` about the target tangent."""
        return -self.alpha0 * self.deformer.sign

    def end_map(self, angle):
        """Rotation Q (3, 3) and the moved end vertices (q, 3): ``p = origin + Q (p - m(s_e))``."""
        d, t = self.deformer, self.target
        Tg = d.sign * t.tangent
        Um = rotate(t.normal, t.tangent, float(angle))
        Um -= (Um @ Tg) * Tg
        Um /= np.linalg.norm(Um)
        Fm = np.stack([Tg, Um, np.cross(Tg, Um)])
        Q = Fm.T @ d.end_frame
        return Q, t.origin + (d.V[d.moving] - d.end_center) @ Q.T

    def handle_positions(self, angle):
        """Positions (p + q, 3) of the deformer's handles: fixed at rest, moving on the target."""
        _, Pm = self.end_map(angle)
        return np.concatenate([self.deformer.V[self.deformer.fixed], Pm])

    def rod(self, angle):
        """Steps 1-4 of the module notes: the rod placement of every vertex, (n, 3)."""
        d = self.deformer
        X = d.V.copy()
        a = self.alpha_end(angle) * self._vg
        ca, sa = np.cos(a), np.sin(a)
        L = d.local
        x = ca * L[:, 1] - sa * L[:, 2]
        y = sa * L[:, 1] + ca * L[:, 2]
        X[d.free] = self._vm + L[:, :1] * self._vT + x[:, None] * self._vU + y[:, None] * self._vV
        Q, X[d.moving] = self.end_map(angle)
        if len(d._blend):
            ids = d.free[d._blend]
            rigid = self.target.origin + (d.V[ids] - d.end_center) @ Q.T
            X[ids] += d._beta[:, None] * (rigid - X[ids])
        return X

    def deform(self, angle=0.0):
        """Deformed vertices with the moving end on the target turned by ``angle``.

        Parameters
        ----------
        angle : float
            Radians about the target tangent; 0 maps the rest U of the moving
            end onto the target normal.

        Returns
        -------
        X : (n, 3) float64
            Fixed vertices exactly at rest, moving vertices exactly on the
            rigid image of the end frame.
        """
        d = self.deformer
        bc = self.handle_positions(angle)
        if d.method == "laplacian":
            X = d.laplacian(bc)
        elif d.method == "arap":
            X = d.V.copy()
            X[d.handles] = bc
            if d.arap_iterations > 0:
                X = d.arap(X, bc)
        else:
            X = self.rod(angle)
            if d.method == "rod_arap" and d.arap_iterations > 0:
                X = d.arap(X, bc)
        X = np.array(X, dtype=np.float64, order="C")
        X[d.handles] = bc
        return X


def _arap_part(F, n, handles):
    """The part of the mesh ARAP has to see: vertices ``Vp`` (sorted ids), faces ``Fp`` in them, handles ``bp``.

    libigl's ARAP energy for triangles in 3-D (spokes and rims) sums, for each vertex ``i``,
    the edges of the faces around ``i`` against one rotation ``R_i`` fitted to those faces.
    An edge with a free (non-handle) endpoint lies in faces that touch a free vertex; the
    rotations its terms use belong to the vertices of those faces, and each such rotation is
    fitted to all faces around its vertex. Those faces (two face rings about the free
    vertices) therefore hold every term that depends on a free vertex, and ARAP on them gives
    the free vertices exactly what ARAP on the whole mesh does: the held part of a join (a
    third of paper case 2) is left out of the factorisation and of every iteration.
    """
    free = np.ones(n, bool)
    free[handles] = False
    ring = np.zeros(n, bool)
    ring[F[free[F].any(axis=1)].ravel()] = True
    Fp = F[ring[F].any(axis=1)]
    Vp = np.unique(Fp)
    local = np.full(n, -1, np.int64)
    local[Vp] = np.arange(len(Vp))
    bp = np.flatnonzero(~free[Vp])
    return Vp, np.ascontiguousarray(local[Fp]), bp


def deform_vessel(V, F, fixed, moving, target, angle=0.0, *, method="rod_arap", gc=None, ends=None,
                  arap_iterations=None, stiffness="uniform"):
    """One-off handle deformation of a vessel (see :class:`RodDeformer`).

    Parameters
    ----------
    V : (n, 3) float64
        Rest vertices.
    F : (m, 3) int64
        Triangles.
    fixed, moving : (p,), (q,) int
        Held vertex ids and the ids of the end that is moved.
    target : Frame or (origin, tangent, normal)
        Where the moving end goes: centre, outward axis direction, image of the
        end's rest normal U at ``angle = 0``.
    angle : float
        Turn of the end about the target tangent, radians.
    method, gc, ends, arap_iterations, stiffness
        See :class:`RodDeformer`.

    Returns
    -------
    X : (n, 3) float64
        Deformed vertices (faces unchanged).

    Examples
    --------
    Turn the far end of a straight tube (20 radii) by 90 degrees in place:
    the middle turns by 45.

    >>> from vesselgp.synthetic import synthetic_vessel
    >>> ves = synthetic_vessel("straight", radius=1.5, n_around=16, remesh=False)
    >>> na = 16; V = ves.V; rings = len(V) // na
    >>> fixed, moving = np.arange(na), np.arange((rings - 1) * na, rings * na)
    >>> d = RodDeformer(V, ves.F, fixed, moving, method="rod")
    >>> X = d.place((d.end_center, d.end_tangent, d.end_normal)).deform(np.pi / 2)
    >>> mid = (rings // 2) * na
    >>> a = np.degrees(np.arctan2(*X[mid, [1, 0]]) - np.arctan2(*V[mid, [1, 0]]))
    >>> bool(abs(a - 90 * (rings // 2) / (rings - 1)) < 1e-6)
    True
    """
    d = RodDeformer(V, F, fixed, moving, gc=gc, ends=ends, method=method,
                    arap_iterations=arap_iterations, stiffness=stiffness)
    return d.place(target).deform(angle)
