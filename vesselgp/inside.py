"""Is a fitted axis inside the vessel? The check behind "never a silent wrong axis".

A generalized cylinder's axis must run inside the lumen and keep clear of the
wall. :func:`check_axis_inside` verifies that against the surface itself, not
against the fit's own data: the generalized winding number (Jacobson et al.
2013) of the surface with its open ends closed is about 1 inside and 0 outside,
whatever holes or caps the mesh has; and the distance from the axis to the
surface must be a fair fraction of the local radius.

Both come from libigl on the triangles themselves: ``fast_winding_number`` of the
surface with fan triangles closing each boundary loop (Barill et al. 2018), and an
AABB tree's point-to-face distance. The check costs 30-100 ms on 12-48k vertices.

:func:`check_axis_bend` is the second half of the check: a tube of radius ``r``
about an axis of curvature ``kappa`` is the one-to-one image of its
``(s, theta, rho)`` coordinates (the normal planes of nearby axis points do not
cross inside it) only where ``kappa r < 1``. A fitted axis that bends tighter
than its radius has left the tubular model: the sections of Eq. 1-5 overlap, and
the fit is not the vessel's centre line, whether or not it stays inside.
"""
from __future__ import annotations

import igl
import numpy as np

from . import tolerances as tol
from .errors import NotTubularError, OptionError
from .mesh import bbox_diagonal, format_point, mesh_topology
from .mesh._geometry import closed_by_fans

__all__ = ["SurfaceWinding", "axis_winding", "check_axis_bend", "check_axis_inside", "sharp_bends"]


class SurfaceWinding:
    """The closed surface and the distance tree of one mesh, kept for repeated axis checks.

    Built once per mesh (the fans over the boundary loops, libigl's fast-winding-number tree of
    the closed triangles, ``FastWindingNumberBVH``, and its AABB tree of the faces); each call
    then costs the winding number's tree-based sum (Barill et al. 2018, exact at this
    resolution) and one distance query per point, so the paths of a tree are checked against one surface. (Until issue #34
    the sum ran over 3000 thinned vertices as a point cloud: on the XCAT coronary tree's
    0.4 mm branches, sampled too sparsely for it, it put 46 axis points outside that are
    inside.) :func:`axis_winding` is the one-off form.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    loops : sequence of (k,) int64, optional
        Boundary loops following the faces' orientation
        (:attr:`vesselgp.mesh.MeshTopology.boundary_loops`, computed when omitted).
    """

    def __init__(self, V, F, loops=None):
        if loops is None:
            loops = mesh_topology(F, len(V)).boundary_loops
        self.shape = (len(V), len(F))
        self._V, self._F = np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int64)
        self._bvh = igl.FastWindingNumberBVH()  # built once, queried by every path of a tree
        self._bvh.init(*closed_by_fans(self._V, self._F, loops))
        self._tree = igl.AABB()
        self._tree.init(self._V, self._F)
        self.scale = bbox_diagonal(V)

    def __call__(self, Q):
        """Winding number ``w`` (q,) and distance ``d`` (q,) to the surface of query points ``Q`` (q, 3)."""
        Q = np.ascontiguousarray(Q, dtype=np.float64)
        w = self._bvh.winding_number(Q)
        d2 = self._tree.squared_distance(self._V, self._F, Q)[0]
        return np.asarray(w, np.float64), np.sqrt(d2)


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
    w, d = winding(points[keep])
    outside = np.abs(w) < tol.INSIDE_WINDING
    grazing = d < tol.INSIDE_CLEARANCE * radii[keep]
    bad = outside | grazing
    if not bad.any():
        return
    k = int(np.flatnonzero(bad)[0])
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
