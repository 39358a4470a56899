"""Vessel trees: a generalized cylinder per branch, joined at the junctions (issue #13).

:func:`fit_vessel_tree` fits a branching vessel mesh as a network of
generalized cylinders (paper Section 2.1-2.2, applied branch by branch):

1. **Ends and topology.** Every end (:func:`vesselgp.vessel_ends`), the root
   (default the widest) and the branch decomposition
   (:func:`vesselgp.branches.branch_decomposition`: heat geodesics from every
   end, tips merged by their shared path length, each vertex's branch).
2. **One fit per branch, on its own vertices.** The initial axis is the
   area-weighted centroid of bands of geodesic distance from the root (Eq. 1
   with indicator weights on those bands); the fixed point of Eq. 3 and Eq. 5
   is then iterated exactly as for a single vessel (circle-fit centres, robust
   reweighting that drops the junction bulges). The shared trunk is fitted
   once, not once per path.
3. **Junctions.** A junction is the point closest, in least squares, to the
   lines continuing the parent's distal end and the children's proximal ends
   (centre lines of a bifurcation meet at a corner). Each branch axis is
   trimmed or extended to its junction(s).
4. **Frames.** The trunk's RMF starts as a single vessel's; each child's RMF
   starts from its parent's frame at the junction turned by the least rotation
   onto the child's tangent (the discrete RMF step, paper Section 1), so angles
   ``theta`` compare across a junction.
5. **Paths.** The axis from the root to each tip is the chain of its branch
   axes, with one RMF transported along it and the radius of Eq. 4 refitted on
   the chain's vertices.
6. **No silent wrong axis.** Every path is checked against the surface
   (:func:`vesselgp.inside.check_axis_inside`): an axis that leaves the lumen
   or grazes the wall raises :class:`vesselgp.NotTubularError`; so does a branch
   axis that bends tighter than its radius (:func:`vesselgp.inside.check_axis_bend`;
   a path turns through its junctions, so only its branches are held to it).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from . import tolerances as tol
from ._validate import as_mesh
from .axis import Axis
from .branches import branch_decomposition, root_end
from .curves import chord_length, resample_arclength
from .errors import EndsError, NotTubularError
from .fit import (check_cylinder_bend, checked_mesh, cylinder_from_axis,
                  FitProblem, fit_generalized_cylinder, fixed_points)
from .inside import SurfaceWinding, check_axis_inside
from .mesh import vessel_ends
from .mesh._geometry import voronoi_areas
from .mesh.geodesic import GeodesicDistances
from .rotations import minimal_rotation

log = logging.getLogger(__name__)

__all__ = ["VesselTree", "fit_vessel_tree"]


@dataclass(frozen=True)
class VesselTree:
    """A fitted vessel tree: its ends, junctions, branch cylinders and root-to-tip paths.

    Attributes
    ----------
    ends : tuple of VesselEnd
        Every end of the mesh (:func:`vesselgp.vessel_ends`).
    root : int
        Index into ``ends`` of the root end.
    junctions : (j, 3) float64
        Junction points (where the centre lines of a parent and its children meet).
    junction_branch : (j,) int64
        The branch ending at each junction (its children start there).
    branches : tuple of GeneralizedCylinder
        One per segment between the root, junctions and tips; branch 0 is the
        trunk. Each is fitted on its own vertices: its per-vertex arrays have
        one row per mesh vertex, NaN (``vertex_s``, ``vertex_theta``,
        ``vertex_local``) and 0 (``vertex_weight``, ``vertex_area``) for
        vertices of other branches. ``ends`` holds the end index at a terminal
        side and -1 at a junction side (the trunk ``(root, -1)``, a leaf
        ``(-1, tip)``).
    parent : (b,) int64
        Parent branch of each branch, -1 for the trunk.
    paths : tuple of GeneralizedCylinder
        One per end other than the root, in end order, from the root to that
        end (``path.ends == (root, j)``); its per-vertex arrays cover the
        vertices of its branches (NaN and 0 elsewhere, as for branches).
    path_branches : tuple of tuple of int
        The branches each path runs through, root first.
    vertex_branch : (n,) int64
        The branch of each vertex (the surface around a junction belongs to
        the parent).
    """

    ends: tuple
    root: int
    junctions: np.ndarray
    junction_branch: np.ndarray
    branches: tuple
    parent: np.ndarray
    paths: tuple
    path_branches: tuple
    vertex_branch: np.ndarray

    def path_to(self, end):
        """The path from the root to end index ``end``.

        Raises
        ------
        EndsError
            ``end`` is the root or not an end index.
        """
        for p in self.paths:
            if p.ends[1] == int(end):
                return p
        raise EndsError(f"end {end} is not a tip of this tree; tips are "
                        f"{[p.ends[1] for p in self.paths]} (the root is {self.root})")

    @property
    def children(self):
        """Child branches of each branch, tuple of tuples."""
        return tuple(tuple(int(c) for c in np.flatnonzero(self.parent == b)) for b in range(len(self.parent)))


# ----------------------------------------------------------------------------- one branch


@dataclass(frozen=True)
class _RawBranch:
    """A branch's converged fit before the junctions: nodes, vertex ids and their s, radius scale."""

    idx: np.ndarray
    nodes: np.ndarray
    s: np.ndarray
    it: object
    rscale: float


def _bands(V, area, phi, K0):
    """Area-weighted centroids of K0 bands of ``phi`` in [0, 1], their mean phi and mean distance."""
    band = np.minimum((phi * K0).astype(np.int64), K0 - 1)
    wsum = np.bincount(band, weights=area, minlength=K0)
    cen = np.stack([np.bincount(band, weights=area * V[:, d], minlength=K0) for d in range(3)], 1)
    ph = np.bincount(band, weights=area * phi, minlength=K0)
    ok = wsum > 0
    cen, ph = cen[ok] / wsum[ok, None], ph[ok] / wsum[ok]
    dist = np.linalg.norm(V - cen[np.searchsorted(np.flatnonzero(ok), band).clip(0, ok.sum() - 1)], axis=1)
    rad = np.bincount(band, weights=area * dist, minlength=K0)[ok] / wsum[ok]
    return cen, ph, rad


def _behind(V, weights, ends):
    """``weights`` (n,) zeroed on the vertices beyond the plane of any of ``ends`` (a copy).

    A branch's initial axis is a polyline through band centroids, pinned to the centres of
    its mesh ends. A rounded tip's centre is its dome's (sphere) centre, so bands of the dome
    beyond it put centroids past the end and started the axis with a hairpin there: the
    first radii near the tip came out a quarter short, and the outlier test (Eq. 5) then took
    four to six more iterations to let the wall there back in (a 27k tree's leaf branches: 9
    to 11 iterations, now 5). An end's plane passes through its centre across its
    ``direction``, taken in the sense that puts the area centroid of ``weights`` behind it (an
    end given with its direction reversed cuts the same side).

    The single-path fit (:func:`vesselgp.fit_generalized_cylinder`) starts from a harmonic
    field instead; the same cut there made no difference at its tips and, on paths through
    a junction, took 3-5 more iterations, so it is not used there.
    """
    out = weights.copy()
    centroid = weights @ V / weights.sum()
    for e in ends:
        h = (V - e.center) @ e.direction
        out[h * np.sign((centroid - e.center) @ e.direction) < 0] = 0.0
    return out


def _branch_problem(V, area, rd, idx, caps, start, end):
    """The Eq. 3 / Eq. 5 fixed point (:class:`FitProblem`) of one branch's vertices, initialised on
    bands of root distance.

    ``start`` / ``end`` are the mesh ends (:class:`vesselgp.VesselEnd`) to pin the initial axis
    to (the root and a tip), or None at a junction side. The bands take only the wall behind a
    pinned end's plane (:func:`_behind`: a tip's dome would start the axis with a hairpin).
    """
    Vb, ab = V[idx], np.where(caps, 0.0, area[idx])
    r = rd[idx]
    lo, hi = float(r[ab > 0].min()), float(r[ab > 0].max())
    if not hi > lo:
        raise NotTubularError("a branch of the tree has no length; check the mesh (vesselgp.clean_mesh)")
    phi = np.clip((r - lo) / (hi - lo), 0.0, 1.0)
    behind = _behind(Vb, ab, [e for e in (start, end) if e is not None])
    _, _, rad = _bands(Vb, behind, phi, tol.TREE_INIT_BANDS)
    rscale = float(np.median(rad))
    K0 = int(np.clip((hi - lo) / (tol.GC_NODE_SPACING * rscale), tol.GC_MIN_NODES, tol.GC_MAX_NODES))
    cen, ph, _ = _bands(Vb, behind, phi, K0)
    pts, pv = [cen], [ph]
    if start is not None:
        pts, pv = [start.center[None]] + pts, [[0.0]] + pv
    if end is not None:
        pts, pv = pts + [end.center[None]], pv + [[1.0]]
    pts, pv = np.vstack(pts), np.concatenate(pv)
    arc = chord_length(pts)
    L0 = float(arc[-1])
    s0 = np.interp(phi, pv, arc / L0)
    K = int(np.clip(L0 / (tol.GC_NODE_SPACING * rscale), tol.GC_MIN_NODES, tol.GC_MAX_NODES))
    # only the ends at a mesh end's centre are pinned: a junction side starts at the band centroid of
    # the junction's bulge and must move (pinned there, it bent the axis 1-4 % r out to 3 radii)
    return FitProblem(resample_arclength(pts, K), s0, Vb, ab, caps, rscale, L0,
                      pin=(start is not None, end is not None),
                      mirror=tuple(e is not None and e.kind != "rounded" for e in (start, end)))


# ----------------------------------------------------------------------------- junctions


def _end_line(nodes, rscale, at_start):
    """A point and unit direction continuing the axis beyond one end, and the axis's own direction there.

    The line through the axis between ``TREE_JUNCTION_SKIP`` and
    ``TREE_JUNCTION_SKIP + TREE_JUNCTION_CHORD`` radii from the end: the last
    stretch before a junction is bent by the junction's bulge. The third value is
    the axis's unit direction at the line's point ``p0`` (its chord over
    ``TREE_LINK_TANGENT`` radii either side), where the link to the junction
    starts (:func:`_attach`): the line's direction, a chord over three radii,
    differs from it on a bending branch, and a link started along it kinked the
    axis (worst path-axis error 0.14 / 0.15 / 0.195 % on the 4 / 3 / 8-tip test
    trees, against 0.113 / 0.108 / 0.139 %).
    """
    arc = chord_length(nodes)
    if not at_start:
        nodes, arc = nodes[::-1], arc[-1] - arc[::-1]
    a0 = min(tol.TREE_JUNCTION_SKIP * rscale, 0.25 * arc[-1])
    a1 = min(a0 + tol.TREE_JUNCTION_CHORD * rscale, 0.5 * arc[-1])
    p0 = np.array([np.interp(a0, arc, nodes[:, d]) for d in range(3)])
    p1 = np.array([np.interp(a1, arc, nodes[:, d]) for d in range(3)])
    d = p0 - p1
    h = tol.TREE_LINK_TANGENT * rscale
    q0, q1 = (np.array([np.interp(a, arc, nodes[:, k]) for k in range(3)]) for a in (max(a0 - h, 0.0), a0 + h))
    return p0, d / np.linalg.norm(d), (q0 - q1) / np.linalg.norm(q0 - q1)


def _junction_point(parent_line, child_lines, reach, rscale):
    """Where the children's lines come closest to the parent's, on the parent's line beyond its point.

    The junction is ``p0 + t d`` on the parent's end line with ``0 <= t``:
    least squares over the distances to the children's lines, pulled weakly
    (``TREE_JUNCTION_ANCHOR``) to ``t = reach``, where the parent's fitted axis
    ended (so a shallow bifurcation, whose lines are nearly parallel, stays
    solvable), and at most ``TREE_JUNCTION_REACH`` radii beyond that.
    """
    p0, d, _ = parent_line
    num, den = tol.TREE_JUNCTION_ANCHOR * reach, tol.TREE_JUNCTION_ANCHOR
    for a, dc, _ in child_lines:
        P = np.eye(3) - np.outer(dc, dc)
        num += d @ P @ (a - p0)
        den += d @ P @ d
    t = float(np.clip(num / den, 0.0, reach + tol.TREE_JUNCTION_REACH * rscale))
    J = p0 + t * d
    for a, dc, _ in child_lines:  # each child's line point must lie beyond the junction, along the child
        if (a - J) @ dc >= 0:
            raise NotTubularError(
                f"the branches meeting near ({', '.join(f'{x:.4g}' for x in J)}) do not form a junction "
                "(a child starts behind it); the mesh may have an undetected end or a side branch "
                "shorter than its radius")
    return J


def _hermite(a, ta, b, tb, k):
    """``k`` points of the cubic Hermite curve from ``a`` (unit tangent ``ta``) to ``b`` (``tb``), ends included."""
    u = np.linspace(0.0, 1.0, k)[:, None]
    L = float(np.linalg.norm(b - a))
    return ((2 * u**3 - 3 * u**2 + 1) * a + (u**3 - 2 * u**2 + u) * L * ta
            + (-2 * u**3 + 3 * u**2) * b + (u**3 - u**2) * L * tb)


def _attach(nodes, J, line, rscale, at_start):
    """The nodes from the line's point ``p0`` on (away from the junction), joined smoothly to ``J``.

    The stretch between the end and ``p0`` (bent by the junction's bulge) is
    replaced by a cubic Hermite curve from ``p0`` (with the axis's own direction
    there, the line's third value) to ``J`` (heading straight at it), so the
    branch has no kink.
    """
    p0, _, t_out = line
    t = (nodes - p0) @ t_out
    keep = nodes[t < 0]
    if len(keep) < 2:
        raise NotTubularError("a branch of the tree is shorter than its junction zone; "
                              "the mesh may have a side bulge detected as an end (see vesselgp.vessel_ends)")
    gap = J - p0
    if not np.linalg.norm(gap) > 0:
        link = p0[None]
    else:
        k = int(np.ceil(np.linalg.norm(gap) / (tol.GC_NODE_SPACING * rscale))) + 2
        link = _hermite(p0, t_out, J, gap / np.linalg.norm(gap), k)
    return np.vstack([link[::-1], keep]) if at_start else np.vstack([keep, link])


def _junctions(raw, parent):
    """Junction of every branch with children, and each branch's nodes trimmed/extended to its junctions."""
    nodes = [r.nodes for r in raw]
    J, Jb = [], []
    for b in range(len(raw)):
        kids = np.flatnonzero(parent == b)
        if not kids.size:
            continue
        lines = [_end_line(raw[b].nodes, raw[b].rscale, at_start=False)]
        lines += [_end_line(raw[c].nodes, raw[c].rscale, at_start=True) for c in kids]
        reach = float((raw[b].nodes[-1] - lines[0][0]) @ lines[0][1])
        Jp = _junction_point(lines[0], lines[1:], reach, raw[b].rscale)
        nodes[b] = _attach(nodes[b], Jp, lines[0], raw[b].rscale, at_start=False)
        for c, line in zip(kids, lines[1:]):
            nodes[c] = _attach(nodes[c], Jp, line, raw[c].rscale, at_start=True)
        J.append(Jp)
        Jb.append(b)
    return np.array(J).reshape(-1, 3), np.array(Jb, np.int64), nodes


# ----------------------------------------------------------------------------- cylinders


def _scattered(gc, idx, n):
    """``gc`` fitted on vertices ``idx``, with per-vertex arrays over all ``n`` (NaN / 0 elsewhere)."""
    def full(a, fill):
        out = np.full((n,) + a.shape[1:], fill, dtype=a.dtype)
        out[idx] = a
        return out
    return replace(gc, vertex_s=full(gc.vertex_s, np.nan), vertex_theta=full(gc.vertex_theta, np.nan),
                   vertex_local=full(gc.vertex_local, np.nan), vertex_weight=full(gc.vertex_weight, 0.0),
                   vertex_area=full(gc.vertex_area, 0.0))


def _cylinder(V, area, caps_all, idx, nodes, s_prev, it, normal, ends, lam, mu, rscale, spn=None):
    """The generalized cylinder of one branch (or path) through ``nodes``, on vertices ``idx``.

    ``s_prev`` is each vertex's parameter on this axis, or ``(points, index)``:
    (p, 3) points near the axis and each vertex's row in them, whose nearest
    axis sample is the vertex's start (the few points are looked up once, not
    once per vertex). Newton steps refine it, as in the fixed point's own
    iterations after the first: the points are the converged axis's samples,
    so each start lies within a sample or two of its foot. (A windowed
    projection from these starts, as until 2026-12-04, gave the same feet to
    4e-7 mesh units on the 27k trees, and its k-d tree query of every vertex
    cost 11 ms.) The few vertices whose steps end off their foot are projected
    again (:func:`_refooted`). ``spn`` is the axis's dense samples per node (default
    ``tolerances.GC_SAMPLES_PER_NODE``; 1 when ``nodes`` are already that dense).
    """
    axis = Axis(nodes, normal, samples_per_node=spn)
    if isinstance(s_prev, tuple):
        points, row = s_prev
        s_prev = axis.s[cKDTree(axis.points).query(points)[1]][row]
    s_raw = _refooted(axis, V[idx], s_prev, axis.project(V[idx], s_prev), rscale)
    gc = cylinder_from_axis(axis, V[idx], s_raw, caps_all[idx], area[idx], it, mu, lam, ends)
    return _scattered(gc, idx, len(V)), axis


def _refooted(axis, P, s_start, s, rscale):
    """``s`` with the rows whose Newton steps stopped off their foot projected again.

    A path's start for a vertex near a junction is its own branch's foot, which can lie
    radii from its foot on the path (the parent's vertices up to the crotch end at the
    parent's end); there Newton's steps converge slowly (0.2-0.5 % of a 27k tree's path
    vertices were still up to 2 radii off after three). A row within the axis whose offset
    from its axis point has a component along the tangent above ``tolerances.FOOT_TOLERANCE``
    radii starts again from the dense sample nearest to it within ``TREE_FOOT_WINDOW`` radii
    of its start (:meth:`vesselgp.axis.Axis.project`); their number is logged (debug). The
    test ``test_every_vertex_of_a_path_sits_at_its_foot`` checks that none is left off.
    """
    inner = np.flatnonzero((s > 0) & (s < 1))
    off = inner[np.abs(axis.tangential_offset(P[inner], s[inner])) > tol.FOOT_TOLERANCE * rscale]
    if not off.size:
        return s
    window = tol.TREE_FOOT_WINDOW * rscale / axis.length
    s = s.copy()
    s[off] = axis.project(P[off], s_start[off], window)
    log.debug("%d of %d vertices projected again onto a tree axis (their Newton steps stopped off the foot)",
              off.size, len(P))
    return s


def _tree_ends(V, F, topo, ends):
    """The mesh's ends (given or found), validated."""
    if ends is None:
        return tuple(vessel_ends(V, F, topology=topo))
    ends = tuple(ends)
    if not all(hasattr(e, "center") and hasattr(e, "vertices") for e in ends):
        raise EndsError("ends must be VesselEnd objects (from vesselgp.vessel_ends)")
    return ends


# ----------------------------------------------------------------------------- public entry


def fit_vessel_tree(V, F, root=None, *, ends=None, lam=None, mu=None, max_iter=None, geodesics=None):
    """Fit a branching vessel mesh as a tree of generalized cylinders (see the module notes).

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    root : int, optional
        Index into the ends of the root end; default the widest.
    ends : sequence of VesselEnd, optional
        The mesh's ends, when already found (default :func:`vesselgp.vessel_ends`).
    lam, mu, max_iter : optional
        As for :func:`vesselgp.fit_generalized_cylinder` (Eq. 2 and Eq. 4 weights,
        iteration cap), per branch.
    geodesics : GeodesicDistances, optional
        The heat-method solver (:class:`vesselgp.mesh.geodesic.GeodesicDistances`) of ``V``
        and the faces of ``F`` with an area, to reuse its factorisation (the largest single
        cost of a tree fit) across fits of one mesh; default built here.

    Returns
    -------
    VesselTree
        A mesh with two ends gives a tree of one branch, which is its one path.

    Raises
    ------
    InvalidMeshError
        As for :func:`vesselgp.fit_generalized_cylinder` (run :func:`vesselgp.clean_mesh`).
    EndsError
        Fewer than two ends, a staircase surface, or a root that is not an end index.
    NotTubularError
        A path that leaves the surface or grazes its wall, a branch axis that bends tighter
        than its radius, branches that do not meet, or a branch with no length (the message
        says where and why).

    Examples
    --------
    >>> from vesselgp.synthetic import synthetic_tree
    >>> t = synthetic_tree(levels=1, voxel=0.6)
    >>> tree = fit_vessel_tree(t.V, t.F)
    >>> tree.parent.tolist(), [p.ends for p in tree.paths], tree.junctions.shape
    ([-1, 0, 0], [(0, 1), (0, 2)], (1, 3))
    """
    V, F = as_mesh(V, F)
    lam = tol.GC_LAMBDA if lam is None else float(lam)
    mu = tol.GC_MU if mu is None else float(mu)
    max_iter = tol.GC_MAX_ITER if max_iter is None else int(max_iter)
    checked = checked_mesh(V, F)
    topo, Fg, _ = checked
    ends = _tree_ends(V, F, topo, ends)
    if len(ends) < 2:
        raise EndsError(f"a vessel tree needs at least two ends, the mesh has {len(ends)} "
                        "(see vesselgp.vessel_ends)")
    root = root_end(ends, root)
    if len(ends) == 2:
        gc = fit_generalized_cylinder(V, F, ends=(root, 1 - root), lam=lam, mu=mu, max_iter=max_iter,
                                      mesh_ends=ends, geodesics=geodesics)
        return VesselTree(ends=ends, root=root, junctions=np.zeros((0, 3)), junction_branch=np.zeros(0, np.int64),
                          branches=(gc,), parent=np.array([-1], np.int64), paths=(gc,), path_branches=((0,),),
                          vertex_branch=np.zeros(len(V), np.int64))
    area = voronoi_areas(V, Fg)
    if geodesics is None:
        geodesics = GeodesicDistances(V, Fg, checked.faces_topology, areas=area)
    br = branch_decomposition(V, Fg, ends, root, geodesics=geodesics)
    caps = np.zeros(len(V), bool)
    for e in ends:
        if e.kind != "open":
            caps[np.asarray(e.vertices, np.int64)] = True
    leaf_tip = {b: t for t, b in br.end_branch.items()}
    problems, ids = [], []
    for b in range(len(br.parent)):
        idx = np.flatnonzero(br.vertex_branch == b)
        start = ends[root] if b == 0 else None
        end = ends[leaf_tip[b]] if b in leaf_tip else None
        problems.append(_branch_problem(V, area, br.root_distance, idx, caps[idx], start, end))
        ids.append(idx)
    # the branches' fixed points in lock step (one vectorised pass per iteration over all of them)
    fits = fixed_points(problems, lam=lam, mu=mu, max_iter=max_iter, what="vessel-tree branch fit")
    raw = [_RawBranch(idx=idx, nodes=it.nodes, s=it.s, it=it, rscale=p.rscale)
           for idx, it, p in zip(ids, fits, problems)]
    junctions, junction_branch, nodes = _junctions(raw, br.parent)
    branches, axes = _branch_cylinders(V, area, caps, raw, nodes, br, root, leaf_tip, lam, mu)
    paths, path_branches = _paths(V, area, caps, branches, axes, raw, br, root, lam, mu)
    winding = SurfaceWinding(V, F, area, topo.boundary_loops)  # one set of samples for every path
    for p in paths:
        check_axis_inside(V, F, p.s, p.centers, p.radii, winding=winding)
    for b in branches:  # not the paths: they turn through the junctions by design
        check_cylinder_bend(b, winding.scale)
    return VesselTree(ends=ends, root=root, junctions=junctions, junction_branch=junction_branch,
                      branches=tuple(branches), parent=br.parent, paths=tuple(paths),
                      path_branches=tuple(path_branches), vertex_branch=br.vertex_branch)


def _branch_cylinders(V, area, caps, raw, nodes, br, root, leaf_tip, lam, mu):
    """Each branch's cylinder on its final nodes, its RMF started from the parent's at the junction."""
    branches, axes = [], []
    for b, r in enumerate(raw):
        nb = resample_arclength(nodes[b], len(r.nodes))
        # each vertex's foot on the axis before the junctions, to the nearest dense sample of the
        # last iteration's axis (it moved less than the tolerance since): only a projection's seed
        on_old = (r.it.axis.points, r.it.axis.nearest_sample(r.s))
        normal = None
        if br.parent[b] >= 0:
            pf = axes[br.parent[b]].frames[-1]
            T0 = resample_arclength(nb, len(nb), with_tangents=True)[1][0]
            normal = minimal_rotation(pf[0], T0).apply(pf[1])
        ends = (root if b == 0 else -1, leaf_tip.get(b, -1))
        gc, axis = _cylinder(V, area, caps, r.idx, nb, on_old, r.it, normal, ends, lam, mu, r.rscale)
        branches.append(gc)
        axes.append(axis)
    return branches, axes


def _rounded_chain(parts, rscales):
    """The branch axes' dense points end to end, each turn at a junction rounded: (p, 3) float64.

    Each child's points start at the junction where its parent's end. Within
    ``tolerances.TREE_PATH_ROUNDING`` radii (the smaller of the two branches') of the junction
    on either side, the points give way to the cubic Hermite curve between the two cut points
    along the axes' directions there: a path turns through a junction with a curvature of about
    its angle over twice that length (the paths are not held to the bend limit; see
    :func:`vesselgp.inside.check_axis_bend`), and elsewhere keeps to its branches' axes.
    """
    out = [parts[0]]
    for k in range(1, len(parts)):
        a = tol.TREE_PATH_ROUNDING * min(rscales[k - 1], rscales[k])
        head, tail = out[-1], parts[k]
        ah, at = chord_length(head[::-1]), chord_length(tail)
        ih = int(np.searchsorted(ah, min(a, 0.5 * ah[-1])))  # samples from the junction back
        it = int(np.searchsorted(at, min(a, 0.5 * at[-1])))
        P, Q = head[len(head) - 1 - ih], tail[it]
        tp = head[len(head) - 1 - ih] - head[len(head) - 2 - ih]
        tq = tail[it + 1] - tail[it]
        n = max(ih + it, 2) + 1
        out[-1] = head[:len(head) - 1 - ih]
        out += [_hermite(P, tp / np.linalg.norm(tp), Q, tq / np.linalg.norm(tq), n)[:-1], tail[it:]]
    return np.vstack(out)


def _paths(V, area, caps, branches, axes, raw, br, root, lam, mu):
    """The root-to-tip chain of branch axes for every tip, with one RMF and its own radius fit.

    A path's axis is the spline through its branches' dense samples end to end, each turn at a
    junction rounded (:func:`_rounded_chain`), resampled at equal arc length; its radius is
    fitted (Eq. 5) on as many nodes as its branches have together."""
    paths, chains = [], []
    for tip in sorted(br.end_branch):
        chain = [br.end_branch[tip]]
        while br.parent[chain[-1]] >= 0:
            chain.append(int(br.parent[chain[-1]]))
        chain = chain[::-1]
        pts = _rounded_chain([axes[b].points for b in chain], [raw[b].rscale for b in chain])
        lengths = np.array([axes[b].length for b in chain])
        offset = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
        total = float(lengths.sum())
        idx = np.concatenate([raw[b].idx for b in chain])
        s_prev = np.concatenate([(offset[k] + branches[b].vertex_s[raw[b].idx] * lengths[k]) / total
                                 for k, b in enumerate(chain)])
        K = int(sum(len(raw[b].nodes) for b in chain))
        # the axis through the branches' dense samples, not through K nodes: a spline through the
        # nodes rang at the turn at each junction (0.1 % r still at 2-3 radii from it)
        dense = resample_arclength(pts, tol.GC_SAMPLES_PER_NODE * (K - 1) + 1)
        sK = np.linspace(0, 1, K)
        radii = np.empty(K)
        for k, b in enumerate(chain):  # later branches overwrite from their start on
            m = sK * total >= offset[k]
            radii[m] = branches[b].radius_at((sK[m] * total - offset[k]) / lengths[k])
        # the path's own K nodes for its radius fit (the leaf's K, as until 2026-12-05, fitted the
        # radius of the whole path on the leaf's node count: 0.85-3.7 % r off at junction edges)
        it = replace(raw[chain[-1]].it, nodes=dense[::tol.GC_SAMPLES_PER_NODE], radii=radii,
                     count=max(raw[b].it.count for b in chain), converged=all(raw[b].it.converged for b in chain))
        gc, _ = _cylinder(V, area, caps, idx, dense, s_prev, it, axes[0].frames[0, 1], (root, tip), lam, mu,
                          min(raw[b].rscale for b in chain), spn=1)
        paths.append(gc)
        chains.append(tuple(chain))
    return paths, chains
