"""Is a fitted axis inside the vessel? The check behind "never a silent wrong axis".

A generalized cylinder's axis must run inside the lumen and keep clear of the
wall. :func:`check_axis_inside` verifies that against the surface itself, not
against the fit's own data: the generalized winding number (Jacobson et al.
2013) of the surface with its open ends closed is about 1 inside and 0 outside,
whatever holes or caps the mesh has; and the distance from the axis to the
nearest surface sample must be a fair fraction of the local radius.

The winding number is the point-cloud form (Barill et al. 2018, Eq. 5) summed
directly over a few thousand samples (libigl's ``fast_winding_number`` gives
the same values but allocates a fixed ~35 MB for its tree).

The surface is represented by an evenly thinned subset of its vertices (with
area-weighted normals and Voronoi areas scaled by the thinning) and by fan
triangles closing each boundary loop, so the check costs a few tens of
milliseconds at any mesh size.

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
from scipy.spatial import cKDTree

from . import tolerances as tol
from ._arrays import thinned
from .errors import NotTubularError, OptionError
from .mesh import bbox_diagonal, format_point, mesh_topology
from .mesh._geometry import voronoi_areas

__all__ = ["SurfaceWinding", "axis_winding", "check_axis_bend", "check_axis_inside"]


def _closed_samples(V, F, area, loops):
    """Oriented point samples (P, N, A) of the surface with each boundary loop closed by a fan."""
    sub = thinned(len(V), tol.INSIDE_SAMPLES)
    step = sub.step
    P, Nn, A = [V[sub]], [_vertex_normals(V, F, sub)], [area[sub] * step]
    for lp in loops:
        if len(lp) < 3:
            continue
        a, b = lp, np.roll(lp, -1)
        # the loops follow the faces (a -> b is a half-edge of F): the filling faces run b -> a
        c = V[lp].mean(axis=0)
        e1, e2 = V[b] - c, V[a] - c
        cr = 0.5 * np.cross(e1, e2)
        ar = np.linalg.norm(cr, axis=1)
        ok = ar > 0
        P.append((c + (V[a] + V[b] - 2 * c) / 3.0)[ok])
        Nn.append(cr[ok] / ar[ok, None])
        A.append(ar[ok])
    P, Nn, A = np.concatenate(P), np.concatenate(Nn), np.concatenate(A)
    # vertices of zero-area faces only have no normal (NaN) and no area: they carry no surface
    ok = np.isfinite(Nn).all(axis=1) & np.isfinite(P).all(axis=1) & (A > 0)
    if not ok.any():
        raise NotTubularError("mesh is not tubular: its surface has no area; check the mesh (vesselgp.clean_mesh)")
    P, Nn, A = P[ok], Nn[ok], A[ok]
    # coincident samples (duplicated vertices) would count twice: merge them, areas summed
    P, first, inv = _unique_points(P)
    A = np.bincount(inv, weights=A, minlength=len(P))
    return P, np.ascontiguousarray(Nn[first]), A


def _unique_points(P):
    """``np.unique(P, axis=0, return_index=True, return_inverse=True)`` of (k, 3) float64 rows,
    by one ``lexsort`` (numpy's row unique sorts structured rows: several times slower).

    Returns the distinct rows in lexicographic order (k', 3), the index of each one's first
    occurrence (k',) and each row's distinct-row id (k,).
    """
    order = np.lexsort((P[:, 2], P[:, 1], P[:, 0]))  # stable: first occurrences lead their group
    Ps = P[order]
    new = np.empty(len(P), dtype=bool)
    new[:1] = True
    np.any(Ps[1:] != Ps[:-1], axis=1, out=new[1:])
    inv = np.empty(len(P), dtype=np.int64)
    inv[order] = np.cumsum(new) - 1
    return np.ascontiguousarray(Ps[new]), order[new], inv


def _vertex_normals(V, F, sub):
    """libigl's default per-vertex normals (``igl.per_vertex_normals``: the unit sum of the
    incident faces' unit normals weighted by their areas) at the vertices ``range(len(V))[sub]``.

    Only the face corners at a vertex of ``sub`` are visited: a few percent of a large mesh,
    whose full normals would cost more than the rest of the axis check (when ``sub`` takes
    every ``tolerances.INSIDE_FULL_NORMALS_STEP``-th vertex or more, libigl's whole-mesh
    normals are cheaper and are taken). Each face adds its
    cross product (its unit normal times twice its area; a zero-area face adds nothing); a
    vertex used only by zero-area faces gets NaN, as in libigl.
    """
    if sub.step <= tol.INSIDE_FULL_NORMALS_STEP:  # most vertices are samples: libigl's own is cheaper
        return igl.per_vertex_normals(V, F)[sub]
    n = len(V)
    pos = np.full(n, -1, dtype=np.int32 if n < np.iinfo(np.int32).max else np.int64)
    k = len(range(n)[sub])
    pos[sub] = np.arange(k, dtype=pos.dtype)
    at = pos.take(F.reshape(-1))
    corners = np.flatnonzero(at >= 0)  # face corners at a sampled vertex
    Ff = F[corners // 3]
    a = V[Ff[:, 0]]
    cr = np.cross(V[Ff[:, 1]] - a, V[Ff[:, 2]] - a)
    tgt = at[corners]
    N = np.stack([np.bincount(tgt, weights=cr[:, d], minlength=k) for d in range(3)], axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return N / np.linalg.norm(N, axis=1, keepdims=True)


def _point_cloud_winding(P, N, A, Q):
    """Generalized winding number of oriented point samples at ``Q`` (Barill et al. 2018, Eq. 5).

    ``w(q) = sum_i A_i (p_i - q) . n_i / (4 pi |p_i - q|^3)``, summed directly
    (the samples are few: no tree, no far-field expansion; libigl's
    ``fast_winding_number`` costs a fixed ~35 MB for its tree at any size).
    The products are matrix products about the samples' centroid:
    ``(p - q) . n = p . n - q . n`` and ``|p - q|^2 = |p|^2 + |q|^2 - 2 p . q``
    (the query points are at least a wall clearance from every sample, so the
    expansion loses nothing that matters). Queries are processed in blocks of
    about ``tolerances.WINDING_BLOCK_PAIRS`` pairs (small temporaries: see there).
    """
    c = P.mean(axis=0)
    P, Q = P - c, Q - c
    pp = np.einsum("ij,ij->i", P, P)
    pn = np.einsum("ij,ij->i", P, N)
    w = np.empty(len(Q))
    block = max(1, tol.WINDING_BLOCK_PAIRS // len(P))
    for a in range(0, len(Q), block):
        Qb = Q[a:a + block]
        r3 = Qb @ P.T
        r3 *= -2.0
        r3 += pp
        r3 += np.einsum("ij,ij->i", Qb, Qb)[:, None]
        r3 *= np.sqrt(r3)
        num = pn - Qb @ N.T
        num *= A
        num /= r3
        w[a:a + block] = num.sum(axis=1)
    return w / (4.0 * np.pi)


class SurfaceWinding:
    """The closed-surface samples and the k-d tree of one mesh, kept for repeated axis checks.

    Built once per mesh (per-vertex normals, the fans over the boundary loops, the thinned
    vertices' k-d tree); each call then costs only the winding sum and one query, so the
    paths of a tree are checked against one set of samples. :func:`axis_winding` is the
    one-off form.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    area : (n,) float64, optional
        Voronoi areas of the vertices (computed when omitted).
    loops : sequence of (k,) int64, optional
        Boundary loops following the faces' orientation
        (:attr:`vesselgp.mesh.MeshTopology.boundary_loops`, computed when omitted).
    """

    def __init__(self, V, F, area=None, loops=None):
        if area is None:
            area = voronoi_areas(V, F)
        if loops is None:
            loops = mesh_topology(F, len(V)).boundary_loops
        self.shape = (len(V), len(F))
        self._samples = _closed_samples(V, F, area, loops)
        self._tree = cKDTree(V[thinned(len(V), tol.INSIDE_SAMPLES)])
        self.scale = bbox_diagonal(V)

    def __call__(self, Q):
        """Winding number ``w`` (q,) and distance ``d`` (q,) to the surface of query points ``Q`` (q, 3)."""
        Q = np.ascontiguousarray(Q, dtype=np.float64)
        return _point_cloud_winding(*self._samples, Q), self._tree.query(Q)[0]


def axis_winding(V, F, Q, area=None, loops=None):
    """Generalized winding number of the closed surface at query points, and their distance to it.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    Q : (q, 3) float64
        Query points (axis samples).
    area : (n,) float64, optional
        Voronoi areas of the vertices (computed when omitted).
    loops : sequence of (k,) int64, optional
        Boundary loops following the faces' orientation
        (:attr:`vesselgp.mesh.MeshTopology.boundary_loops`, computed when omitted).

    Returns
    -------
    w : (q,) float64
        About +-1 inside (the sign follows the mesh orientation), 0 outside.
    d : (q,) float64
        Distance to the nearest surface sample (a vertex of the thinned subset).
    """
    return SurfaceWinding(V, F, area, loops)(Q)


def check_axis_inside(V, F, s, points, radii, *, area=None, loops=None, ends_margin=None, winding=None):
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
    area : (n,) float64, optional
        Voronoi areas of the vertices.
    loops : sequence of (k,) int64, optional
        The mesh's boundary loops (see :func:`axis_winding`).
    ends_margin : float, optional
        Samples within this arc length of either end are not checked (an axis
        end sits on a cap or a loop's centre). Default: one mean radius.
    winding : SurfaceWinding, optional
        The samples of this mesh when already built (several axes of one mesh);
        ``area`` and ``loops`` are then not used.

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
        winding = SurfaceWinding(V, F, area, loops)
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


def check_axis_bend(s, length, tangents, radii, *, points=None, scale=None, ends_margin=None, skip_start=0.0):
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
    arc = s * float(length)
    kappa = np.linalg.norm(np.gradient(np.asarray(tangents, np.float64), arc, axis=0), axis=1)
    radii = np.asarray(radii, np.float64)
    margin = float(np.mean(radii)) if ends_margin is None else float(ends_margin)
    keep = (arc >= margin + float(skip_start)) & (float(length) - arc >= margin)
    bad = keep & (kappa * radii >= tol.GC_MAX_BEND)
    if not bad.any():
        return
    k = int(np.flatnonzero(bad)[0])
    where = f"at s = {s[k]:.3f}"
    if points is not None:
        where += f" (point {format_point(np.asarray(points)[k], float(length) if scale is None else scale)})"
    raise NotTubularError(
        f"the fitted axis bends tighter than its radius {where}: curvature x radius = {kappa[k] * radii[k]:.2f} "
        f"(a tube needs less than {tol.GC_MAX_BEND:g}; its sections would overlap); likely too few vertices "
        "around a non-circular section (remesh finer, e.g. pymeshlab meshing_isotropic_explicit_remeshing, "
        "or fit with a stiffer axis, e.g. lam=1.0), or a U-turn tighter than the radius"
    )
