"""Is a fitted axis inside the vessel? The check behind "never a silent wrong axis".

A generalized cylinder's axis must run inside the lumen and keep clear of the
wall. :func:`check_axis_inside` verifies that against the surface itself, not
against the fit's own data: the generalized winding number (Jacobson et al.
2013) of the surface with its open ends closed by fans is 1 inside and 0 outside;
and the distance from the axis to the surface must be a fair fraction of the
local radius.

Both are exact and cost what the axis samples need, not a structure over the
whole surface (:class:`SurfaceWinding`, issue #47): the winding number counts
the faces a ray from each sample crosses, the clearance comes from the nearest
vertex with a proven bound and libigl's point-to-face distance where the bound
cannot decide. On a 400k-face tube the check of 300 samples costs about 0.1 s
(libigl's fast-winding-number and AABB trees took 0.85 s to build).

:func:`check_axis_bend` is the second half of the check: a tube of radius ``r``
about an axis of curvature ``kappa`` is the one-to-one image of its
``(s, theta, rho)`` coordinates (the normal planes of nearby axis points do not
cross inside it) only where ``kappa r < 1``. A fitted axis that bends tighter
than its radius has left the tubular model: the sections of Eq. 1-5 overlap, and
the fit is not the vessel's centre line, whether or not it stays inside.
"""
from __future__ import annotations

import logging
from functools import cached_property

import igl
import numpy as np
from scipy.spatial import cKDTree

from . import tolerances as tol
from .errors import NotTubularError, OptionError
from .mesh import bbox_diagonal, format_point, mesh_topology
from .mesh._geometry import closed_by_fans

log = logging.getLogger(__name__)

__all__ = ["SurfaceWinding", "axis_winding", "ray_winding", "check_axis_bend", "check_axis_inside", "sharp_bends"]


class SurfaceWinding:
    """The closed surface of one mesh, kept for repeated axis checks: exact winding numbers and wall distances.

    Built once per mesh (the fans over the boundary loops, :func:`vesselgp.mesh._geometry.closed_by_fans`);
    each call answers for its query points only, at a cost that follows the points, not the surface
    (issue #47: libigl's fast-winding-number tree and AABB tree of a 400k-face tube took 0.85 s to check
    300 axis points):

    * **Winding number** (Jacobson et al. 2013): the signed number of times the closed surface crosses
      the ray ``q + t d``, ``t > 0`` (+1 where its normal points along the ray; ``d`` a fixed direction
      along no coordinate axis, so that no grid or axis of the mesh lines up with it). For a closed, coherently
      oriented surface this is the generalized winding number exactly, an integer. The faces whose
      bounding box across the ray holds ``q`` are found through a grid of the faces' boxes, built once. The whole line ``q + t d`` must cross as often
      outwards as inwards (it does on a closed surface); where it does not, or where the line grazes
      an edge or a vertex, that point's winding number is libigl's direct sum over every face
      (``igl.winding_number``), the same number computed the slow way.
    * **Distance** to the mesh's faces (the fans excluded). The nearest vertex, at ``d_v``, bounds the
      true distance ``d``: ``d <= d_v`` and ``d_v^2 <= d^2 + delta^2``, where ``delta`` (the longest edge
      over sqrt(3)) bounds how far a point of a face lies from its nearest corner (Pythagoras: the
      nearest point's offset is normal to its face or edge). :meth:`nearer_than`, the clearance test of
      an axis, decides most points from ``d_v`` alone (a k-d tree of the vertices). An exact
      :meth:`distance` of a few points (up to ``tolerances.INSIDE_FEW_POINTS``) runs libigl's
      point-to-face distance over the faces with a corner within ``sqrt(d_v^2 + delta^2)``, which hold
      the nearest; of more points, over libigl's AABB tree of every face (built once, on first use).

    (Until issue #34 the sum ran over 3000 thinned vertices as a point cloud: on the XCAT coronary
    tree's 0.4 mm branches, sampled too sparsely for it, it put 46 axis points outside that are
    inside.) :func:`axis_winding` is the one-off form.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    loops : sequence of (k,) int64, optional
        Boundary loops following the faces' orientation
        (:attr:`vesselgp.mesh.MeshTopology.boundary_loops`, computed when omitted).
    coherent : bool, optional
        Whether the mesh is edge-manifold and coherently oriented
        (:attr:`vesselgp.mesh.MeshTopology.is_coherent`; known with ``loops`` omitted): then the fanned
        surface is closed without counting its edges. Default: counted.

    Examples
    --------
    >>> from vesselgp.synthetic import synthetic_vessel
    >>> ves = synthetic_vessel("helix", radius=1.0, n_around=24)
    >>> c = ves.truth.centers[len(ves.truth.centers) // 2]  # on the true axis, radius 1
    >>> w, d = SurfaceWinding(ves.V, ves.F)(np.array([c, c + [0.0, 0.0, 5.0]]))
    >>> np.round(np.abs(w), 6).tolist(), bool(abs(d[0] - 1.0) < 0.02)
    ([1.0, 0.0], True)
    """

    def __init__(self, V, F, loops=None, coherent=None):
        if loops is None:
            topo = mesh_topology(F, len(V))
            loops, coherent = topo.boundary_loops, topo.is_coherent
        self.shape = (len(V), len(F))
        self._V, self._F = np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int64)
        self._Vc, self._Fc = closed_by_fans(self._V, self._F, loops)
        # a coherent, edge-manifold mesh with every boundary loop fanned is closed (each edge run once each way:
        # the fan's faces run each boundary edge backwards, consecutive fan faces share their spokes oppositely);
        # otherwise the grid finds out (an edge count over the whole surface)
        self._closed = True if coherent and all(len(lp) >= 3 for lp in loops) else None
        self.scale = bbox_diagonal(V)

    @cached_property
    def _vertices(self):
        """A k-d tree of the used vertices, their ids, and ``delta`` (see the class notes)."""
        used = np.flatnonzero(np.bincount(self._F.ravel(), minlength=len(self._V)))
        a, b, c = self._V[self._F[:, 0]], self._V[self._F[:, 1]], self._V[self._F[:, 2]]
        longest = max(float(np.max(np.einsum("ij,ij->i", x, x), initial=0.0)) for x in (b - a, c - b, a - c))
        return cKDTree(self._V[used], balanced_tree=False, compact_nodes=False), used, float(np.sqrt(longest / 3.0))

    @cached_property
    def _aabb(self):
        tree = igl.AABB()
        tree.init(self._V, self._F)
        return tree

    @cached_property
    def _faces_of(self):
        """Each vertex's faces: ``(face ids sorted by vertex, start of each vertex's run)``."""
        order = np.argsort(self._F.ravel(), kind="stable")
        return order // 3, np.searchsorted(self._F.ravel()[order], np.arange(len(self._V) + 1))

    def __call__(self, Q):
        """Winding number ``w`` (q,) and distance ``d`` (q,) to the surface of query points ``Q`` (q, 3)."""
        Q = np.ascontiguousarray(Q, dtype=np.float64).reshape(-1, 3)
        return self.winding(Q), self.distance(Q)

    def winding(self, Q):
        """The generalized winding number of the closed surface at ``Q`` (q, 3): (q,) float64, exact."""
        Q = np.ascontiguousarray(Q, dtype=np.float64).reshape(-1, 3)
        return ray_winding(self._Vc, self._Fc, Q, self._grid)

    @cached_property
    def _grid(self):
        return _ColumnGrid(self._Vc, self._Fc, self._closed)

    def distance(self, Q):
        """Distance from ``Q`` (q, 3) to the mesh's nearest face: (q,) float64, exact."""
        Q = np.ascontiguousarray(Q, dtype=np.float64).reshape(-1, 3)
        if not len(Q):
            return np.zeros(0)
        if len(Q) > tol.INSIDE_FEW_POINTS:  # many points: libigl's AABB tree of every face, built once
            return np.sqrt(np.asarray(self._aabb.squared_distance(self._V, self._F, Q)[0], np.float64))
        kd, used, delta = self._vertices
        face_of, starts = self._faces_of
        dv = kd.query(Q)[0]
        near = kd.query_ball_point(Q, np.sqrt(dv ** 2 + delta ** 2) * (1.0 + tol.INSIDE_BALL_SLACK))
        verts = used[np.unique(np.concatenate([np.asarray(n, np.int64) for n in near]))]
        n = starts[verts + 1] - starts[verts]
        faces = np.unique(face_of[np.repeat(starts[verts], n) + np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)])
        d2 = igl.point_mesh_squared_distance(Q, self._V, self._F[faces])[0]
        return np.sqrt(np.asarray(d2, np.float64))

    def nearer_than(self, Q, limit):
        """Whether each point of ``Q`` (q, 3) lies nearer the mesh's faces than ``limit`` (q,): (q,) bool, exact.

        The nearest vertex decides most points (``d <= d_v`` and ``d >= sqrt(d_v^2 - delta^2)``, see the
        class notes); :meth:`distance` decides the rest.
        """
        Q = np.ascontiguousarray(Q, dtype=np.float64).reshape(-1, 3)
        limit = np.broadcast_to(np.asarray(limit, np.float64), (len(Q),))
        if not len(Q):
            return np.zeros(0, bool)
        kd, used, delta = self._vertices
        dv = kd.query(Q)[0]
        near = dv < limit
        unsure = ~near & (dv ** 2 - delta ** 2 < limit ** 2)
        if unsure.any():
            near[unsure] = self.distance(Q[unsure]) < limit[unsure]
        return near


def _ray_frame():
    """Rows: the rays' direction, then two unit vectors across it (a right-handed frame). The direction
    is no coordinate axis, so that a mesh laid out on a grid or along an axis (a straight synthetic
    tube, its fans' centres on the axis) is not met by the rays along its edges or through its corners."""
    d = np.array([1.0, np.sqrt(2.0) - 1.0, np.pi - 3.0])
    d /= np.linalg.norm(d)
    e1 = np.cross(d, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    return np.stack([d, e1, np.cross(d, e1)])


_RAY_FRAME = _ray_frame()


class _ColumnGrid:
    """The faces of a surface, in the rays' frame (:func:`_ray_frame`; ``W`` its vertices there: along
    the ray first), each listed with the grid cells across the ray its bounding box touches (cells
    ``tolerances.INSIDE_RAY_CELL`` median edges wide), built once without sorting: :meth:`pairs` gives the
    faces whose box may hold a point's position across the ray, those its ray can cross, by looking each
    face's cells up among the queries' (issue #47: sorting the faces' cells, and counting the edges for
    closedness, was 2 s of a 5 s fit of a 1M-vertex tube to check 300 axis points).

    ``closed``: whether every edge is run as often one way as the other (then a line crosses as often in as
    out); counted over the surface when None."""

    def __init__(self, V, F, closed=None):
        self.W = V @ _RAY_FRAME.T
        Y, Z = self.W[:, 1], self.W[:, 2]
        ya, yb, yc, za, zb, zc = Y[F[:, 0]], Y[F[:, 1]], Y[F[:, 2]], Z[F[:, 0]], Z[F[:, 1]], Z[F[:, 2]]
        self.h = tol.INSIDE_RAY_CELL * float(np.median(np.abs(yb - ya) + np.abs(zb - za))) or 1.0
        lo = np.stack([np.minimum(np.minimum(ya, yb), yc), np.minimum(np.minimum(za, zb), zc)], 1)
        hi = np.stack([np.maximum(np.maximum(ya, yb), yc), np.maximum(np.maximum(za, zb), zc)], 1)
        self.off = np.floor(lo.min(axis=0, initial=np.inf) / self.h) - 1 if len(F) else np.zeros(2)
        lo, hi = self._cell(lo), self._cell(hi)
        self.shape = hi.max(axis=0, initial=0) + 2
        n0, n1 = hi[:, 0] - lo[:, 0] + 1, hi[:, 1] - lo[:, 1] + 1
        count = n0 * n1
        self.face = np.repeat(np.arange(len(F)), count)
        k = np.arange(len(self.face)) - np.repeat(np.cumsum(count) - count, count)
        self.key = (lo[self.face, 0] + k // n1[self.face]) * self.shape[1] + lo[self.face, 1] + k % n1[self.face]
        if closed is None:  # every edge run as often one way as the other
            a, b = F.ravel(), F[:, [1, 2, 0]].ravel()
            edge = np.unique(np.minimum(a, b) * np.int64(len(V)) + np.maximum(a, b), return_inverse=True)[1]
            closed = not np.any(np.bincount(edge, weights=np.where(a < b, 1.0, -1.0)))
        self.closed = bool(closed)

    def _cell(self, P):
        return (np.floor(P / self.h) - self.off).astype(np.int64)

    def pairs(self, Qp):
        """``(face, query)`` index pairs, (k,) int64 each, for query points ``Qp`` (q, 2) across the ray: every
        face listed with a cell that holds a query, with each query there."""
        c = self._cell(Qp)
        valid = np.all((c >= 0) & (c < self.shape), axis=1)
        ids = np.flatnonzero(valid)
        qkey = c[ids, 0] * self.shape[1] + c[ids, 1]
        order = np.argsort(qkey, kind="stable")
        cells, first, many = np.unique(qkey[order], return_index=True, return_counts=True)
        if not len(cells):
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        at = np.minimum(np.searchsorted(cells, self.key), len(cells) - 1)
        hit = cells[at] == self.key
        face, at = self.face[hit], at[hit]
        n = many[at]
        pf = np.repeat(face, n)
        pq = ids[order[np.repeat(first[at], n) + np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)]]
        return pf, pq


def ray_winding(V, F, Q, grid=None):
    """Generalized winding number of a closed, coherently oriented surface at ``Q``, exactly, by rays.

    See :class:`SurfaceWinding`: the signed crossings of the ray ``q + t d`` (``t > 0``); a point whose
    whole line does not cross as often in as out, or whose line meets an edge or corner of a face in
    projection, gets libigl's direct sum (``igl.winding_number``) instead, and so does every point when
    the surface is not closed (an edge run more often one way than the other).

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        A closed surface (every edge run as often one way as the other), e.g. :func:`closed_by_fans`; any
        other gets the direct sum (exact, slower).
    Q : (q, 3) float64
    grid : optional
        The faces' column grid when already built (:class:`SurfaceWinding` keeps one).

    Returns
    -------
    (q,) float64
        +1 inside a surface whose normals point out, -1 inside one whose normals point in, 0 outside.

    Examples
    --------
    A unit cube, its faces turned outwards: a point inside, one outside, one on the cube's mid-plane.

    >>> V = np.array([[x, y, z] for x in (0.0, 1) for y in (0.0, 1) for z in (0.0, 1)])
    >>> F = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
    ...               [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    >>> np.round(ray_winding(V, F, np.array([[0.5, 0.3, 0.6], [1.5, 0.3, 0.6], [0.2, 0.5, 0.5]])), 9).tolist()
    [1.0, 0.0, 1.0]
    """
    Q = np.ascontiguousarray(Q, np.float64).reshape(-1, 3)
    w = np.zeros(len(Q))
    if not len(Q) or not len(F):
        return w
    grid = _ColumnGrid(V, F) if grid is None else grid
    if not grid.closed:  # a ray's count is the winding number of a closed surface only
        log.debug("winding numbers: the surface is not closed; summed directly over its %d faces", len(F))
        return np.asarray(igl.winding_number(V, F, Q), np.float64)
    Q = Q @ _RAY_FRAME.T  # in the rays' frame: along the ray first
    pf, pq = grid.pairs(Q[:, 1:])
    T = grid.W[F[pf]]  # (pairs, 3, 3)
    a, b, c = T[:, 0, 1:] - Q[pq, 1:], T[:, 1, 1:] - Q[pq, 1:], T[:, 2, 1:] - Q[pq, 1:]
    # twice the signed areas of the projected sub-triangles (q, b, c), (q, c, a), (q, a, b)
    u = b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0]
    v = c[:, 0] * a[:, 1] - c[:, 1] * a[:, 0]
    t = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    pos, neg = (u > 0) & (v > 0) & (t > 0), (u < 0) & (v < 0) & (t < 0)
    inside = pos | neg
    graze = ~inside & (((u >= 0) & (v >= 0) & (t >= 0)) | ((u <= 0) & (v <= 0) & (t <= 0)))  # on an edge
    area = u + v + t
    ok = inside & (area != 0)
    x = (u[ok] * T[ok, 0, 0] + v[ok] * T[ok, 1, 0] + t[ok] * T[ok, 2, 0]) / area[ok]
    sign = np.where(pos[ok], 1.0, -1.0)  # the face's normal along the ray: its projection turns counter-clockwise
    ahead = x > Q[pq[ok], 0]
    np.add.at(w, pq[ok][ahead], sign[ahead])
    total = np.zeros(len(Q))
    np.add.at(total, pq[ok], sign)
    unsure = total != 0
    unsure[pq[graze]] = True
    if unsure.any():
        log.debug("winding numbers: %d of %d rays met an edge or an open surface; summed directly",
                  int(unsure.sum()), len(Q))
        w[unsure] = np.asarray(igl.winding_number(grid.W, F, Q[unsure]), np.float64)
    return w


def axis_winding(V, F, Q, loops=None):
    """Generalized winding number of the closed surface at query points, and their distance to it.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    Q : (q, 3) float64
        Query points (axis samples).
    loops : sequence of (k,) int64, optional
        Boundary loops following the faces' orientation
        (:attr:`vesselgp.mesh.MeshTopology.boundary_loops`, computed when omitted).

    Returns
    -------
    w : (q,) float64
        About +-1 inside (the sign follows the mesh orientation), 0 outside.
    d : (q,) float64
        Distance to the surface (its nearest face).
    """
    return SurfaceWinding(V, F, loops)(Q)


def check_axis_inside(V, F, s, points, radii, *, loops=None, ends_margin=None, winding=None):
    """Raise :class:`NotTubularError` when the axis leaves the surface or grazes its wall.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    s : (q,) float64
        Normalised arc length of the axis samples.
    points : (q, 3) float64
        Axis samples.
    radii : (q,) float64
        Fitted radius at each sample.
    loops : sequence of (k,) int64, optional
        The mesh's boundary loops (see :func:`axis_winding`).
    ends_margin : float, optional
        Samples within this arc length of either end are not checked (an axis
        end sits on a cap or a loop's centre). Default: one mean radius.
    winding : SurfaceWinding, optional
        This mesh's closed surface and distance tree when already built (several axes of
        one mesh); ``loops`` is then not used.

    Raises
    ------
    NotTubularError
        Naming the first offending ``s``, its point, and the likely causes.
    """
    length = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))
    margin = float(np.mean(radii)) if ends_margin is None else float(ends_margin)
    keep = (s * length >= margin) & ((1 - s) * length >= margin)
    if not keep.any():
        return
    if winding is None:
        winding = SurfaceWinding(V, F, loops)
    elif winding.shape != (len(V), len(F)):
        raise OptionError(f"winding was built for a mesh of {winding.shape[0]} vertices and {winding.shape[1]} "
                          f"faces, not this one ({len(V)}, {len(F)}); build SurfaceWinding(V, F) of this mesh")
    w = winding.winding(points[keep])
    outside = np.abs(w) < tol.INSIDE_WINDING
    grazing = winding.nearer_than(points[keep], tol.INSIDE_CLEARANCE * radii[keep])
    bad = outside | grazing
    if not bad.any():
        return
    k = int(np.flatnonzero(bad)[0])
    d = np.zeros(len(w))
    d[k] = winding.distance(points[keep][k])[0]
    where = f"at s = {s[keep][k]:.3f} (point {format_point(points[keep][k], winding.scale)})"
    what = (f"leaves the surface {where}, on {int(outside.sum())} of {int(keep.sum())} checked samples"
            if outside[k] else
            f"comes within {d[k] / radii[keep][k]:.2f} radii of the wall {where}")
    raise NotTubularError(
        f"the fitted axis {what}; likely an end that was not detected (pass ends=, see vesselgp.vessel_ends), "
        "a staircase (voxel) surface (smooth it: vesselgp.clean_mesh), or a U-turn tighter than the radius"
    )


def sharp_bends(s, length, tangents, radii, *, ends_margin=None, skip_start=0.0, skip=None):
    """The samples where an axis bends tighter than its radius, as :func:`check_axis_bend` judges them.

    Parameters are those of :func:`check_axis_bend`.

    Returns
    -------
    bad : (q,) bool
        Judged samples (past the margins and ``skip_start``, outside ``skip``) with
        ``kappa r >= tolerances.GC_MAX_BEND``.
    kr : (q,) float64
        ``kappa r`` at every sample.
    """
    s = np.asarray(s, np.float64)
    arc = s * float(length)
    kappa = np.linalg.norm(np.gradient(np.asarray(tangents, np.float64), arc, axis=0), axis=1)
    radii = np.asarray(radii, np.float64)
    margin = float(np.mean(radii)) if ends_margin is None else float(ends_margin)
    keep = (arc >= margin + float(skip_start)) & (float(length) - arc >= margin)
    for z0, z1 in np.zeros((0, 2)) if skip is None else np.asarray(skip, np.float64):
        keep &= (s < z0) | (s > z1)
    kr = kappa * radii
    return keep & (kr >= tol.GC_MAX_BEND), kr


def check_axis_bend(s, length, tangents, radii, *, points=None, scale=None, ends_margin=None, skip_start=0.0,
                    skip=None, fewer_nodes=None):
    """Raise :class:`NotTubularError` where the axis bends tighter than its radius.

    The curvature is ``|dT/ds|`` of the unit tangents by central differences; the
    condition is ``kappa r < tolerances.GC_MAX_BEND`` (1: the tube map is
    one-to-one, see the module notes). A straight axis (``kappa = 0``, no Frenet
    normal) passes; nothing here needs one.

    Parameters
    ----------
    s : (q,) float64
        Normalised arc length of the axis samples, increasing (dense: a few per radius).
    length : float
        Arc length of the axis, mesh units.
    tangents : (q, 3) float64
        Unit tangents at the samples.
    radii : (q,) float64
        Fitted radius at each sample.
    points : (q, 3) float64, optional
        The samples, to name the offending one.
    scale : float, optional
        The mesh's size, for the printed point's digits (default: ``length``).
    ends_margin : float, optional
        Samples within this arc length of either end are not checked (an axis end
        turns into a cap or a junction). Default: one mean radius.
    skip_start : float, optional
        Arc length from the start that is not checked either, before the margin (a tree
        branch's junction zone, whose axis is the lumen's centre line, not a fit).
    skip : (z, 2) float64, optional
        Intervals of ``s`` not checked either (a tree branch's medial zones, where the axis is
        the lumen's centre line: :attr:`vesselgp.VesselTree.medial_zones`).
    fewer_nodes : int, optional
        A number of axis nodes to name as a stiffer fit's (``n_nodes=``) in the refusal.

    Raises
    ------
    NotTubularError
        Naming the first offending ``s`` (and its point), ``kappa r`` there, and
        the likely causes and remedies.

    Examples
    --------
    Three quarters of a circle of bend radius 2 (arc length 3 pi) with a tube of radius 1
    (kappa r = 0.5) passes; with radius 3 it does not.

    >>> t = np.linspace(0, 1.5 * np.pi, 400)
    >>> T = np.c_[-np.sin(t), np.cos(t), 0 * t]
    >>> check_axis_bend(t / t[-1], 3 * np.pi, T, np.full(400, 1.0))
    >>> check_axis_bend(t / t[-1], 3 * np.pi, T, np.full(400, 3.0))
    Traceback (most recent call last):
    ...
    vesselgp.errors.NotTubularError: the fitted axis bends tighter than its radius at s = 0.32...: curvature x radius = 1.50 (a tube needs less than 1; ...
    """
    s = np.asarray(s, np.float64)
    bad, kr = sharp_bends(s, length, tangents, radii, ends_margin=ends_margin, skip_start=skip_start, skip=skip)
    if not bad.any():
        return
    k = int(np.flatnonzero(bad)[0])
    where = f"at s = {s[k]:.3f}"
    if points is not None:
        where += f" (point {format_point(np.asarray(points)[k], float(length) if scale is None else scale)})"
    raise NotTubularError(
        f"the fitted axis bends tighter than its radius {where}: curvature x radius = {kr[k]:.2f} "
        f"(a tube needs less than {tol.GC_MAX_BEND:g}; its sections would overlap); likely too few vertices "
        "around a non-circular section (remesh finer, e.g. pymeshlab meshing_isotropic_explicit_remeshing, "
        f"or fit a stiffer axis, e.g. lam=1.0{'' if fewer_nodes is None else f' or n_nodes={fewer_nodes}'}), or a "
        "U-turn tighter than the radius"
    )
