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
   are placed by the rigid map of the end frame onto the target frame.
5. **Refinement.** A few libigl ARAP iterations from that start with the
   fixed and moving vertices as handles (the factorisation is computed once).

``"rod"`` stops after step 4. ``"arap"`` (ARAP from the rest shape) and
``"laplacian"`` (cotangent-Laplacian editing: the bi-Laplacian of the
displacement is minimised, paper ref. [7] without rotation updates) are kept
for comparison; both concentrate an end twist near the end.

Everything that does not depend on the target (the fit, the vertex
interpolation weights, the ARAP and Laplacian factorisations) is computed
once per :class:`RodDeformer`; everything that does not depend on the angle
(axis, RMF, per-vertex frames) once per target; an angle costs one vectorised
placement plus the ARAP iterations.
"""
from __future__ import annotations

import logging

import igl
import numpy as np
import scipy.sparse as sp

from . import tolerances as tol
from ._validate import as_mesh, as_vector
from .curves import rotation_minimizing_frames, transport_angle
from .errors import EndsError, FrameError, MismatchError, OptionError

log = logging.getLogger(__name__)

__all__ = ["RodDeformer", "deform_vessel", "METHODS", "as_vertex_ids"]

#: Deformation methods of :class:`RodDeformer`.
METHODS = ("rod_arap", "rod", "arap", "laplacian")


# ----------------------------------------------------------------------------- helpers


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


def _rotate(v, k, ang):
    """Rotate rows ``v`` about unit axis ``k`` by angles ``ang`` (Rodrigues, vectorised)."""
    ang = np.asarray(ang, float)
    c, s = np.cos(ang)[..., None], np.sin(ang)[..., None]
    return v * c + np.cross(k, v) * s + np.outer(v @ k, k) * (1 - c)


def _axis_angle(a, b):
    """Unit axis and angle of the minimal rotation taking unit ``a`` to unit ``b``."""
    ax = np.cross(a, b)
    sn = float(np.linalg.norm(ax))
    cs = float(a @ b)
    if sn < tol.STRAIGHT_SIN:
        if cs > 0:
            return np.array([1.0, 0.0, 0.0]), 0.0
        e = np.zeros(3)
        e[int(np.argmin(np.abs(a)))] = 1.0
        e -= (e @ a) * a
        log.warning("target tangent is opposite to the rest end tangent: the bend direction is arbitrary")
        return e / np.linalg.norm(e), np.pi
    return ax / sn, float(np.arctan2(sn, cs))


def _unit(x, name):
    v = as_vector(x, name)
    m = float(np.abs(v).max())
    if not m > 0:  # relative: any non-zero length is a direction (no unit-dependent threshold)
        raise FrameError(f"{name} is the zero vector; give a non-zero direction")
    v = v / m
    return v / np.linalg.norm(v)


def _target(target):
    """(origin, tangent, normal) from a :class:`vesselgp.Frame` or a 3-tuple (validated)."""
    from .join import Frame

    if not isinstance(target, Frame):
        try:
            o, t, nrm = target
        except (TypeError, ValueError):
            raise FrameError("target must be a vesselgp.Frame or a tuple (origin, tangent, normal)") from None
        target = Frame(o, t, nrm)
    return target.origin, target.tangent, target.normal


# ----------------------------------------------------------------------------- the deformer


class RodDeformer:
    """Precomputed handle deformation of one vessel (paper Section 2.3; module notes).

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
        Fitted on ``V`` (fitted here when omitted, with ``ends``).
    ends : optional
        Passed to :func:`vesselgp.fit_generalized_cylinder`.
    method : {"rod_arap", "rod", "arap", "laplacian"}
        See the module notes.
    arap_iterations : int, optional
        ARAP iterations: default :data:`~vesselgp.tolerances.DEFORM_REFINE_ITERATIONS`
        for ``"rod_arap"``, :data:`~vesselgp.tolerances.DEFORM_ARAP_ITERATIONS`
        for ``"arap"``.
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

    Raises
    ------
    EndsError
        Empty, overlapping or out-of-range vertex sets, moving vertices not at
        an end of the vessel, or no free part between the fixed and moving sets.
    """

    def __init__(self, V, F, fixed, moving, *, gc=None, ends=None, method="rod_arap",
                 arap_iterations=None, stiffness="uniform"):
        from .fit import GeneralizedCylinder, fit_generalized_cylinder

        V, F = as_mesh(V, F)
        n = len(V)
        if method not in METHODS:
            raise OptionError(f"unknown deformation method {method!r}; use one of {', '.join(METHODS)}")
        if stiffness not in ("uniform", "radius4"):
            raise OptionError(f"unknown stiffness {stiffness!r}; use 'uniform' or 'radius4'")
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
        self.V, self.F, self.gc = V, F, gc
        self.fixed, self.moving = fixed, moving
        self.method = method
        self.stiffness = stiffness
        self.n = n
        r = gc.mean_radius
        L = gc.length
        # -- which end moves, where the free part starts
        sm = gc.vertex_s[moving]
        self.s_end = 1.0 if float(np.mean(sm)) >= 0.5 else 0.0
        far = float(np.max(np.abs(sm - self.s_end))) * L
        if far > tol.JOIN_END_REACH * r:
            raise EndsError(
                f"moving vertices reach {far / r:.1f} radii from the vessel's end; give the ids of one end "
                "(its boundary loop) as moving"
            )
        ds = gc.dense_s
        sf = gc.vertex_s[fixed]
        if self.s_end == 1.0:
            jb = int(np.searchsorted(ds, float(sf.max()) - 1e-9, side="left"))
            nodes = np.arange(jb, len(ds))
        else:
            jb = int(np.searchsorted(ds, float(sf.min()) + 1e-9, side="right")) - 1
            nodes = np.arange(jb, -1, -1)
        jb = int(np.clip(jb, 0, len(ds) - 1))
        self.s_boundary = float(ds[jb])
        self.free_length = abs(self.s_end - self.s_boundary) * L
        if len(nodes) < 3 or self.free_length < tol.JOIN_MIN_FREE_LENGTH * r:
            raise EndsError(
                f"the fixed vertices reach within {self.free_length / r:.2f} radii of the moving end; "
                "leave a free part of the vessel between them"
            )
        self._nodes = nodes  # dense-axis node indices from s_b to s_e
        self._u = (ds[nodes] - self.s_boundary) / (self.s_end - self.s_boundary)
        self._sign = 1.0 if self.s_end > self.s_boundary else -1.0
        # twist shape g(u): alpha = alpha_end * g
        if stiffness == "uniform":
            g = self._u.copy()
        else:
            inv = 1.0 / np.maximum(gc.radius_at(ds[nodes]), 1e-12 * r) ** 4
            cum = np.concatenate([[0.0], np.cumsum(0.5 * (inv[1:] + inv[:-1]) * np.diff(self._u))])
            g = cum / cum[-1]
        self._g = g
        # -- per-vertex interpolation on the dense axis (free vertices only)
        sv = gc.vertex_s
        free = (sv > self.s_boundary) if self.s_end == 1.0 else (sv < self.s_boundary)
        free[fixed] = False
        free[moving] = False
        self._free = np.flatnonzero(free)
        s = sv[self._free]
        j = np.clip(np.searchsorted(ds, s, side="right") - 1, 0, len(ds) - 2)
        self._j = j
        self._t = ((s - ds[j]) / (ds[j + 1] - ds[j]))[:, None]
        self._local = gc.vertex_local[self._free]
        # -- rest end frame (GC convention: rows T, U, V with T towards increasing s)
        pe, fe = gc.at([self.s_end])
        self.end_center = pe[0]
        self.end_frame = fe[0]
        self.end_tangent = self._sign * fe[0, 0]  # outward
        self.end_normal = fe[0, 1]
        self.handles = np.concatenate([fixed, moving])
        self._cache_key = None
        # -- factorisations, once per problem
        self._arap = None
        self._mqwf = None
        if method in ("rod_arap", "arap"):
            if arap_iterations is None:
                arap_iterations = tol.DEFORM_REFINE_ITERATIONS if method == "rod_arap" else tol.DEFORM_ARAP_ITERATIONS
            self.arap_iterations = int(arap_iterations)
            if self.arap_iterations > 0:
                self._arap = igl.ARAPData()
                self._arap.max_iter = self.arap_iterations
                igl.arap_precomputation(V, F, 3, self.handles.astype(np.int32), self._arap)
        else:
            self.arap_iterations = 0
        if method == "laplacian":
            Lc = igl.cotmatrix(V, F)
            M = igl.massmatrix(V, F, igl.MASSMATRIX_TYPE_VORONOI).diagonal()
            A = (Lc.T @ sp.diags(1.0 / M) @ Lc).tocsc()
            self._mqwf = igl.min_quad_with_fixed_data()
            igl.min_quad_with_fixed_precompute(A, self.handles, sp.csc_matrix((0, n)), True, self._mqwf)
            self._lap_B = np.ascontiguousarray(-(A @ V))
        log.debug("RodDeformer: method %s, free part %.3g (%.1f radii), %d free vertices",
                  method, self.free_length, self.free_length / r, len(self._free))

    # ------------------------------------------------------------------ per target

    def _prepare(self, origin, tangent, normal):
        key = (origin.tobytes(), tangent.tobytes(), normal.tobytes())
        if key == self._cache_key:
            return
        gc = self.gc
        nodes, u = self._nodes, self._u
        P = gc.dense_points[nodes]
        Tu = self._sign * gc.dense_frames[nodes, 0]  # forward (towards the moving end)
        k, phi = _axis_angle(self.end_tangent, tangent)
        w = 3.0 * u * u - 2.0 * u
        Tn = _rotate(Tu, k, w * phi) if phi != 0.0 else Tu.copy()
        Tn[-1] = tangent
        du = np.diff(u)[:, None] * self.free_length
        dP = np.concatenate([np.zeros((1, 3)), np.cumsum(0.5 * (Tn[1:] - Tu[1:] + Tn[:-1] - Tu[:-1]) * du, axis=0)])
        Pi = P + dP
        c = origin - Pi[-1]
        h = 3.0 * u * u - 2.0 * u**3
        dh = 6.0 * u - 6.0 * u * u
        Pn = Pi + h[:, None] * c
        Pn[-1] = origin
        Dn = self.free_length * Tn + dh[:, None] * c
        Dn /= np.linalg.norm(Dn, axis=1)[:, None]
        Tf, Uf, _ = rotation_minimizing_frames(Pn, Dn, initial_normal=gc.dense_frames[nodes[0], 1])
        Tg = self._sign * Tf
        Vg = np.cross(Tg, Uf)
        # alpha_0: angle about T_gc at the end from the transported U to the target normal
        self._alpha0 = float(transport_angle(Tg[-1:], Uf[-1:], normal[None])[0])
        # full dense arrays: rest outside the free part
        M = len(gc.dense_s)
        Pd = gc.dense_points.copy()
        Fd = gc.dense_frames.copy()
        gd = np.zeros(M)
        Pd[nodes] = Pn
        Fd[nodes] = np.stack([Tg, Uf, Vg], axis=1)
        gd[nodes] = self._g
        if self.s_end == 1.0:
            gd[nodes[-1]:] = 1.0
        else:
            gd[: nodes[-1] + 1] = 1.0
        j, t = self._j, self._t
        self._vm = (1 - t) * Pd[j] + t * Pd[j + 1]
        T = (1 - t) * Fd[j, 0] + t * Fd[j + 1, 0]
        T /= np.linalg.norm(T, axis=1)[:, None]
        U = (1 - t) * Fd[j, 1] + t * Fd[j + 1, 1]
        U -= np.sum(U * T, axis=1)[:, None] * T
        U /= np.linalg.norm(U, axis=1)[:, None]
        self._vT, self._vU, self._vV = T, U, np.cross(T, U)
        self._vg = ((1 - t[:, 0]) * gd[j] + t[:, 0] * gd[j + 1])
        self._axis_s = gc.dense_s
        self._axis_points = Pd
        self._axis_frames = Fd
        self._target = (origin, tangent, normal)
        self._cache_key = key

    def alpha_end(self, target, angle):
        """Material angle ``alpha(s_e)`` (radians, about the GC tangent) the rod imposes at ``angle``."""
        o, t, nrm = _target(target)
        self._prepare(o, t, nrm)
        return self._alpha0 + self._sign * float(angle)

    def axis(self, target):
        """Deformed axis of the rod step: dense ``s``, points (M, 3) and RMF frames (M, 3, 3)."""
        o, t, nrm = _target(target)
        self._prepare(o, t, nrm)
        return self._axis_s, self._axis_points, self._axis_frames

    def _end_map(self, angle):
        """Rotation Q (3, 3) and the moved end vertices: p = origin + Q (p - m(s_e))."""
        origin, tangent, normal = self._target
        Tg = self._sign * tangent
        Um = _rotate(normal[None], tangent, float(angle))[0]
        Um -= (Um @ Tg) * Tg
        Um /= np.linalg.norm(Um)
        Fm = np.stack([Tg, Um, np.cross(Tg, Um)])
        Q = Fm.T @ self.end_frame
        return Q, origin + (self.V[self.moving] - self.end_center) @ Q.T

    def handle_positions(self, target, angle):
        """Positions (p + q, 3) of :attr:`handles` at ``angle``: fixed at rest, moving on the target."""
        o, t, nrm = _target(target)
        self._prepare(o, t, nrm)
        _, Pm = self._end_map(angle)
        return np.concatenate([self.V[self.fixed], Pm])

    def rod(self, target, angle):
        """Steps 1-4 of the module notes: the rod placement of every vertex, (n, 3)."""
        o, t, nrm = _target(target)
        self._prepare(o, t, nrm)
        X = self.V.copy()
        a = (self._alpha0 + self._sign * float(angle)) * self._vg
        ca, sa = np.cos(a), np.sin(a)
        L = self._local
        x = ca * L[:, 1] - sa * L[:, 2]
        y = sa * L[:, 1] + ca * L[:, 2]
        X[self._free] = self._vm + L[:, :1] * self._vT + x[:, None] * self._vU + y[:, None] * self._vV
        _, X[self.moving] = self._end_map(angle)
        return X

    def deform(self, target, angle=0.0):
        """Deformed vertices with the moving end on ``target`` turned by ``angle``.

        Parameters
        ----------
        target : Frame or (origin, tangent, normal)
            Where the moving end goes (see :class:`vesselgp.Frame`).
        angle : float
            Radians about the target tangent; 0 maps the rest U of the moving
            end onto the target normal.

        Returns
        -------
        X : (n, 3) float64
            Fixed vertices exactly at rest, moving vertices exactly on the
            rigid image of the end frame.
        """
        o, t, nrm = _target(target)
        self._prepare(o, t, nrm)
        bc = self.handle_positions(target, angle)
        if self.method == "laplacian":
            X = igl.min_quad_with_fixed_solve(self._mqwf, self._lap_B, bc, np.zeros((0, 3)))
        elif self.method == "arap":
            X = self.V.copy()
            X[self.handles] = bc
            if self._arap is not None:
                X = igl.arap_solve(bc, self._arap, X)
        else:
            X = self.rod(target, angle)
            if self.method == "rod_arap" and self._arap is not None:
                X = igl.arap_solve(bc, self._arap, X)
        X = np.array(X, dtype=np.float64, order="C")
        X[self.handles] = bc
        return X


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
    >>> X = d.deform((d.end_center, d.end_tangent, d.end_normal), np.pi / 2)
    >>> mid = (rings // 2) * na
    >>> a = np.degrees(np.arctan2(*X[mid, [1, 0]]) - np.arctan2(*V[mid, [1, 0]]))
    >>> bool(abs(a - 90 * (rings // 2) / (rings - 1)) < 1e-6)
    True
    """
    d = RodDeformer(V, F, fixed, moving, gc=gc, ends=ends, method=method,
                    arap_iterations=arap_iterations, stiffness=stiffness)
    return d.deform(target, angle)
