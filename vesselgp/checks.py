"""A fit checked against its mesh before it is returned: every end reached, the whole wall covered (issue #44).

The inside test (:func:`vesselgp.inside.check_axis_inside`) sees what the fit put inside the
lumen; it cannot see what the fit left out. Two results that came back whole and were wrong
(a path that stopped 32 mm short of the end it was named for; an artery whose first 22 mm had
no axis; a vessel whose end was not found, its wall taken for a bulge of the next one) are what
this module checks for, on every fit of a whole mesh (:func:`vesselgp.fit_vessel_tree`, and
:func:`vesselgp.fit_generalized_cylinder` of a mesh with two ends):

* **Every end is reached.** Each path's first and last axis points lie within
  ``tolerances.CHECK_END_GAP`` radii of the centres of the ends it is named for (VMTK's lines
  stop within about one radius of an open end). The paths are pinned there, so a gap is a bug,
  never a result: it raises.
* **The whole wall is covered.** The generalized cylinder describes a wall vertex when its
  distance ``D`` to its branch's axis (to the axis's end point beyond either end) agrees with
  the fitted radius ``r`` there: ``|D - r| <= CHECK_COVER_TOLERANCE r``. Exempt are the end
  regions (caps and rounded tips, which close the tube), the surface within
  ``CHECK_JUNCTION_RADII`` of the parent's radius about each junction, a child's mouth up to
  ``CHECK_MOUTH_RADII`` of its radius (at most its parent's) past its junction zone and out to
  ``CHECK_ZONE_REACH`` times the larger of its fitted radius and its parent's from its axis, and, out to
  ``CHECK_ZONE_REACH`` radii of the axis (a bulge's peak radius in a bulge), the medial zones
  and the reported bulges; a blind sac's wall beyond the tubes is the sac's
  (:func:`vesselgp.bulges.sac_wall`). On a tree, the lumen's maximal inscribed spheres along its
  centre lines cover the wall they touch (within the same tolerance), as at a shallow junction's
  flare. The rest is uncovered: its pieces (connected on the mesh) are
  measured by their area over ``2 pi r^2``, the length in radii of a tube of the local radius
  with that much wall. A piece larger than ``CHECK_MAX_UNCOVERED`` is a vessel or an end with
  no axis, and the fit is refused with its place and size; one larger than
  ``CHECK_WARN_UNCOVERED`` is named in a WARNING. The limits are measured: on the 11 real meshes
  the largest uncovered piece is 0.01 radii of wall, on their 77 coarser copies 1.36 (the voxelised
  aneurysm remeshed at 2 edges, whose sac is then not reported as a bulge: warned), and a vessel
  whose end is left out of a 4-tip tree leaves 2.5-6.9; the intracranial aneurysm's sac, left
  undescribed, 3.0 (its wall was hidden in a daughter's mouth, unbounded then).
* **The axis runs through its wall's centre.** Circles fitted to the judged wall in windows along each
  branch with no smoothing (:func:`vesselgp.wall_circles.wall_circles`) give the wall's own centre; an axis
  farther from it than ``CHECK_CENTRE_WARN`` radii plus ``CHECK_CENTRE_SIGMAS`` standard errors is named in a
  WARNING (:func:`off_centre`, :func:`check_centre`; the fit stands: a lumen far from round also reads so).

:class:`FitChecks` holds what was measured; ``checks`` of ``axis.json`` and ``tree.json``
report it.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np
from scipy.sparse.csgraph import connected_components

from . import tolerances as tol
from ._per_vertex import rows_of, stored_rows
from ._arrays import within_balls
from .bulges import tree_bulges
from .errors import NotTubularError
from .wall_circles import wall_circles
from .mesh._ends_format import format_point

__all__ = ["FitChecks", "OffCentre", "Uncovered", "check_centre", "cylinder_checks", "end_gaps", "fit_checks",
           "off_centre", "off_its_wall", "wall_coverage"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Uncovered:
    """A connected piece of wall that the fit does not describe.

    Attributes
    ----------
    point : (3,) float64
        The piece's vertex nearest to its centroid.
    area : float
        Its area (Voronoi areas of its vertices), mesh units squared.
    radius : float
        The fitted radius of the axis beside it (median over its vertices).
    size : float
        ``area / (2 pi radius^2)``: the length, in radii, of a tube of that radius with as much wall.
    branch : int
        The branch its vertices belong to (most of them; 0 for a single vessel).
    """

    point: np.ndarray
    area: float
    radius: float
    size: float
    branch: int


@dataclass(frozen=True)
class OffCentre:
    """Where an axis runs farthest from its wall's own centre (:func:`off_centre`).

    Attributes
    ----------
    point : (3,) float64
        The axis point there.
    branch : int
        Its branch (0 for a single vessel).
    s : float
        Its normalised arc length on the branch.
    offset : float
        The distance from the axis to the centre of the wall's circle there, in its radii.
    se : float
        The offset's standard error, in radii.
    """

    point: np.ndarray
    branch: int
    s: float
    offset: float
    se: float


@dataclass(frozen=True)
class FitChecks:
    """What the checks of a fit against its mesh measured (see the module notes).

    Attributes
    ----------
    end_gaps : (p, 2) float64
        For each path (a tree's, in order; one for a single vessel), the distance from its first
        and its last axis point to the centre of the end it is named for, in that end's radii.
    covered_fraction : float or None
        The fraction of the wall's area (Voronoi areas, end regions left out) that the fit
        describes or that lies in an exempt zone; None when the fit covers a path between two
        of a branching mesh's ends, not the whole mesh (not judged).
    uncovered : tuple of Uncovered
        The uncovered pieces, largest first.
    off_centre : OffCentre or None
        Where the axis runs farthest from its wall's own centre, beyond that centre's uncertainty (None when
        not judged: a path between two of a branching mesh's ends, or no window with its wall all round).
    """

    end_gaps: np.ndarray
    covered_fraction: float
    uncovered: tuple
    off_centre: OffCentre | None = None

    @property
    def worst_end_gap(self):
        """The largest end gap, in end radii (0 with no path)."""
        return float(self.end_gaps.max()) if self.end_gaps.size else 0.0

    @property
    def largest_uncovered(self):
        """The size of the largest uncovered piece (:attr:`Uncovered.size`), 0 when none."""
        return self.uncovered[0].size if self.uncovered else 0.0

    def to_dict(self):
        """JSON-ready summary (``checks`` of ``axis.json`` and ``tree.json``)."""
        return {"worst_end_gap_radii": self.worst_end_gap,
                "end_gap_limit_radii": tol.CHECK_END_GAP,
                "covered_fraction": self.covered_fraction,
                "largest_uncovered_radii": self.largest_uncovered,
                "uncovered_limit_radii": tol.CHECK_MAX_UNCOVERED,
                "uncovered": [{"point": u.point, "area": u.area, "radius": u.radius, "size_radii": u.size,
                               "branch": u.branch} for u in self.uncovered[:tol.CHECK_LIST_MAX]],
                "off_centre": None if self.off_centre is None else {
                    "point": self.off_centre.point, "branch": self.off_centre.branch, "s": self.off_centre.s,
                    "offset_radii": self.off_centre.offset, "standard_error_radii": self.off_centre.se,
                    "warn_above_radii": tol.CHECK_CENTRE_WARN, "sigmas": tol.CHECK_CENTRE_SIGMAS}}


def end_gaps(paths, ends):
    """Distance of each path's first and last axis point to its ends' centres, in end radii: (p, 2) float64.

    Parameters
    ----------
    paths : sequence of GeneralizedCylinder
        Each with ``ends == (i, j)`` indexing ``ends``.
    ends : sequence of VesselEnd

    Examples
    --------
    >>> from types import SimpleNamespace as NS
    >>> ends = [NS(center=np.zeros(3), radius=2.0), NS(center=np.array([10.0, 0, 0]), radius=1.0)]
    >>> p = NS(ends=(0, 1), centers=np.array([[0.0, 1, 0], [5, 0, 0], [9.5, 0, 0]]))
    >>> end_gaps([p], ends).tolist()
    [[0.5, 0.5]]
    """
    out = np.zeros((len(paths), 2))
    for k, p in enumerate(paths):
        for side, (e, c) in enumerate(zip(p.ends, (p.centers[0], p.centers[-1]))):
            out[k, side] = np.linalg.norm(c - ends[e].center) / ends[e].radius
    return out


def check_end_gaps(paths, ends, gaps, scale):
    """Raise :class:`NotTubularError` when a path stops farther than ``CHECK_END_GAP`` radii from its end.

    ``gaps`` is :func:`end_gaps` of ``paths`` and ``ends``; ``scale`` the mesh's size (printed digits).
    """
    bad = np.argwhere(gaps > tol.CHECK_END_GAP)
    if not len(bad):
        return
    k, side = (int(x) for x in bad[np.argmax(gaps[tuple(bad.T)])])
    p, e = paths[k], ends[paths[k].ends[side]]
    raise NotTubularError(
        f"the path {p.ends[0]} -> {p.ends[1]} {'starts' if side == 0 else 'stops'} {gaps[k, side]:.2f} end radii "
        f"from the centre of end {p.ends[side]} ({e.describe()}), at "
        f"{format_point(p.centers[-side], scale)}; a path must reach its ends (within {tol.CHECK_END_GAP:g} "
        "radius): this is a fault of vesselgp, not of the mesh; please report it with the mesh")


def wall_coverage(V, adjacency, area, D, R, exempt, zone, zone_radius, branch, balls=None):
    """Which wall vertices the fit describes, and the pieces it does not (see the module notes).

    Parameters
    ----------
    V : (n, 3) float64
    adjacency : (n, n) sparse
        The mesh's vertex adjacency (:attr:`vesselgp.mesh.MeshTopology.adjacency`).
    area : (n,) float64
        Each vertex's Voronoi area (0 for vertices that are no wall: end regions).
    D : (n,) float64
        Each vertex's distance to its branch's axis (to its end point beyond an end).
    R : (n,) float64
        The fitted radius at its foot.
    exempt : (n,) bool
        Vertices not judged (junction zones, mouths, end regions).
    zone : (n,) bool
        Vertices in a medial zone or a bulge: covered out to ``CHECK_ZONE_REACH`` times ``zone_radius``.
    zone_radius : (n,) float64
        The radius the reach is counted in (a bulge's peak radius there, else ``R``).
    branch : (n,) int64
        Each vertex's branch (names a piece).
    balls : ((k, 3) float64, (k,) float64), optional
        The lumen's centre lines, as points and inscribed radii (:class:`vesselgp.centerlines.Centerlines`):
        a wall vertex within ``1 + CHECK_COVER_TOLERANCE`` of the inscribed radius of one of their points
        is covered too (the lumen's maximal spheres touch it: a junction's flare, a shallow crotch).

    Returns
    -------
    covered_fraction : float
    uncovered : tuple of Uncovered
        Largest first.

    Examples
    --------
    A unit tube's wall (D = R = 1) with a window 0.5 long and 90 degrees wide pushed out to
    D = 1.6 (its area on the pushed-out surface 1.6 x pi / 2 x 0.5 = 1.257): one piece of size
    1.257 / (2 pi) = 0.2 radii.

    >>> from vesselgp.mesh import mesh_topology
    >>> t, z = np.linspace(0, 2 * np.pi, 65)[:-1], np.linspace(0, 10, 201)
    >>> T, Z = np.meshgrid(t, z)
    >>> out = (np.abs(Z - 5) <= 0.25) & (T <= np.pi / 2)
    >>> rho = np.where(out, 1.6, 1.0).ravel()
    >>> V = np.c_[rho * np.cos(T.ravel()), rho * np.sin(T.ravel()), Z.ravel()]
    >>> i = (np.arange(200)[:, None] * 64 + np.arange(64)).ravel(); j = i - i % 64 + (i + 1) % 64
    >>> F = np.r_[np.c_[i, j, i + 64], np.c_[j, j + 64, i + 64]]
    >>> A = np.full(len(V), 2 * np.pi / 64 * 0.05) * rho; A[:64] /= 2; A[-64:] /= 2
    >>> no = np.zeros(len(V), bool)
    >>> f, pieces = wall_coverage(V, mesh_topology(F, len(V)).adjacency, A, rho, np.ones(len(V)), no, no,
    ...                           np.ones(len(V)), np.zeros(len(V), np.int64))
    >>> len(pieces), round(pieces[0].size, 2)
    (1, 0.2)
    """
    bad = (np.abs(D - R) > tol.CHECK_COVER_TOLERANCE * R) & ~exempt
    bad &= ~(zone & (D <= tol.CHECK_ZONE_REACH * zone_radius)) & (area > 0)
    if balls is not None and bad.any():
        ids = np.flatnonzero(bad)
        bad[ids[within_balls(V[ids], balls[0], (1.0 + tol.CHECK_COVER_TOLERANCE) * balls[1])]] = False
    total = float(area.sum())
    fraction = 1.0 - float(area[bad].sum()) / total if total > 0 else 1.0
    ids = np.flatnonzero(bad)
    if not ids.size:
        return fraction, ()
    _, lab = connected_components(adjacency[ids][:, ids], directed=False)
    pieces = []
    for c in range(int(lab.max()) + 1):
        m = ids[lab == c]
        a, r = float(area[m].sum()), float(np.median(R[m]))
        centre = V[m].mean(axis=0)
        point = V[m[np.argmin(np.linalg.norm(V[m] - centre, axis=1))]]
        pieces.append(Uncovered(point, a, r, a / (2.0 * np.pi * r * r), int(np.bincount(branch[m]).argmax())))
    pieces.sort(key=lambda u: -u.size)
    return fraction, tuple(pieces)


def check_coverage(uncovered, scale):
    """Raise :class:`NotTubularError` when an uncovered piece is larger than ``CHECK_MAX_UNCOVERED``; log a
    WARNING naming the largest when it is larger than ``CHECK_WARN_UNCOVERED`` (a sac or a bulge that was not
    reported as one, a stub: the fit stands, but it does not describe that piece of the surface).

    ``uncovered`` is :func:`wall_coverage`'s, largest first; ``scale`` the mesh's size (printed digits).
    """
    if not uncovered:
        return
    u = uncovered[0]
    if u.size <= tol.CHECK_MAX_UNCOVERED:
        if u.size > tol.CHECK_WARN_UNCOVERED:
            log.warning("%.3g square units of wall at %s (%.2g radii of a tube of radius %.3g) are not described by "
                        "the fit: a sac or a bulge not reported as one, or a stub (checks in the outputs)", u.area,
                        format_point(u.point, scale), u.size, u.radius)
        return
    raise NotTubularError(
        f"the fit leaves {u.area:.3g} square units of wall without an axis at {format_point(u.point, scale)} "
        f"(as much wall as {u.size:.1f} radii of a tube of radius {u.radius:.3g}; at most "
        f"{tol.CHECK_MAX_UNCOVERED:g} is left to noise): likely a vessel whose end was not found there, or a "
        "blind sac not recognised as one; list the ends (vesselgp.vessel_ends) and, if its end is a closed dome "
        "or a cap that is not listed, cut the vessel open there")


def off_centre(tree, judged):
    """The place where a fitted tree's (or single vessel's) axis runs farthest from its wall's own centre.

    Each branch's judged wall vertices (``judged``, over the mesh: no end region, junction zone, mouth, medial
    zone or bulge) get circles fitted in windows of ``CHECK_CENTRE_REACH`` radii either side, one every
    ``CHECK_CENTRE_STEP`` of its smallest radius (:func:`vesselgp.wall_circles.wall_circles`: Eq. 2's circle
    fit without its lam term); the axis should run through their centres.

    Returns
    -------
    OffCentre or None
        The window whose centre is farthest beyond its own uncertainty (offset minus ``CHECK_CENTRE_SIGMAS``
        standard errors), None when no window is judged.
    """
    worst = None
    for b, (g, m) in enumerate(zip(tree.branches, _rows_by_branch(tree.vertex_branch, len(tree.branches)))):
        gs = rows_of(g, "vertex_s", m)
        o = np.argsort(gs, kind="stable")
        use = (judged[m] & (gs > 0) & (gs < 1))[o]
        c = wall_circles(gs[o] * g.length, rows_of(g, "vertex_local", m)[o][:, 1:], use,
                         lambda x, g=g: g.radius_at(x / g.length), tol.CHECK_CENTRE_REACH, tol.CHECK_CENTRE_STEP)
        if not len(c.s0):
            continue
        d, se = np.hypot(c.centre[:, 0], c.centre[:, 1]) / c.radius, c.se / c.radius
        k = int(np.argmax(d - tol.CHECK_CENTRE_SIGMAS * se))
        if worst is None or d[k] - tol.CHECK_CENTRE_SIGMAS * se[k] > worst.offset - tol.CHECK_CENTRE_SIGMAS * worst.se:
            p, _ = g.at(np.array([c.s0[k] / g.length]))
            worst = OffCentre(p[0], b, min(float(c.s0[k] / g.length), 1.0), float(d[k]), float(se[k]))
    return worst


def off_its_wall(worst):
    """Whether an axis runs off its wall's centre by more than ``CHECK_CENTRE_WARN`` radii plus
    ``CHECK_CENTRE_SIGMAS`` standard errors (``worst``: :func:`off_centre`'s, or None)."""
    return worst is not None and worst.offset > tol.CHECK_CENTRE_WARN + tol.CHECK_CENTRE_SIGMAS * worst.se


def check_centre(worst, scale):
    """Log a WARNING when the axis runs off its wall's centre (:func:`off_its_wall`); the fit stands."""
    if not off_its_wall(worst):
        return
    log.warning("the axis runs %.2g radii (+- %.2g) off the centre of its wall at %s (branch %d, s = %.3f): the "
                "fit smoothed or rejected the wall there (a stenosis, a sparse bend), or the lumen is far from round "
                "there (checks in the outputs)", worst.offset, worst.se, format_point(worst.point, scale),
                worst.branch, worst.s)


def _rows_by_branch(vertex_branch, n_branches):
    """Each branch's vertex rows, increasing, from one sort (not one sweep of the mesh per branch: issue #47)."""
    order = np.argsort(vertex_branch, kind="stable")
    return np.split(order, np.cumsum(np.bincount(vertex_branch, minlength=n_branches))[:-1])


def _wall_of_branches(V, branches, vertex_branch):
    """Each vertex's distance to its branch's axis (to its end point beyond an end) and the radius at its foot."""
    D, R = np.full(len(V), np.nan), np.full(len(V), np.nan)
    for g, m in zip(branches, _rows_by_branch(vertex_branch, len(branches))):
        D[m] = np.linalg.norm(rows_of(g, "vertex_local", m), axis=1)
        R[m] = g.radius_at(rows_of(g, "vertex_s", m))
    return D, R


def _zones(V, tree, D, R):
    """The exempt vertices (junction zones, mouths, blind sacs' walls) and the zone vertices with their radii
    (medial zones, bulges) of a fitted tree (:class:`vesselgp.VesselTree`); ``D``: each vertex's distance to
    its branch's axis, ``R``: the fitted radius at its foot."""
    exempt, zone, zone_radius = np.zeros(len(V), bool), np.zeros(len(V), bool), R.copy()
    if len(tree.junctions):  # near any junction (one pass, not one sweep of the mesh per junction: issue #47)
        reach = np.array([float(tree.branches[b].radii[-1]) for b in tree.junction_branch])
        exempt |= within_balls(V, np.asarray(tree.junctions, np.float64).reshape(-1, 3),
                               tol.CHECK_JUNCTION_RADII * reach)
    for b, (g, m) in enumerate(zip(tree.branches, _rows_by_branch(tree.vertex_branch, len(tree.branches)))):
        if tree.parent[b] < 0 and not len(tree.medial_zones[b]):
            continue
        gs = rows_of(g, "vertex_s", m)
        if tree.parent[b] >= 0:  # the mouth, in the child's radius, at most its parent's there (a branch whose
            # wall has a vessel with no axis in it has that vessel's wall in its mean radius: issue #44), and
            # no farther from the child's axis than the zones reach in the parent's radius (the mouth's flare
            # is the parent's wall; a sac beside it, whose wall has its foot there, is not: issue #44)
            rp = float(tree.branches[tree.parent[b]].radii[-1])
            r = min(float(np.median(g.radii)), rp)
            exempt[m] |= (gs * g.length <= tree.junction_zone[b] + tol.CHECK_MOUTH_RADII * r) & (
                D[m] <= tol.CHECK_ZONE_REACH * np.maximum(R[m], rp))
        for z0, z1 in tree.medial_zones[b]:
            zone[m] |= (gs >= z0) & (gs <= z1)
    for bl in tree.bulges:
        rows, s = stored_rows(tree.paths[bl.paths[0]], "vertex_s")  # the path's own vertices
        m = rows[(s >= bl.s_range[0]) & (s <= bl.s_range[1])]
        zone[m] = True
        zone_radius[m] = np.maximum(zone_radius[m], bl.peak_radius)
        exempt[bl.wall] = True  # a sac's wall beyond the tubes: described by the sac
    return exempt, zone, zone_radius


def fit_checks(tree, pm, balls=None, warn_centre=True):
    """Check a fitted tree (or a single vessel's fit as a one-branch tree) against its mesh.

    Parameters
    ----------
    tree : VesselTree
        The fit: its ends, paths, branches, each vertex's branch, junctions, junction and medial
        zones and bulges (a single vessel: one branch, one path, no junction).
    pm : PreparedMesh
        Its mesh (vertices, adjacency, Voronoi areas, end regions).
    balls : ((k, 3) float64, (k,) float64), optional
        The lumen's centre lines as points and inscribed radii (a tree's, :func:`wall_coverage`).
    warn_centre : bool
        Whether an axis off its wall's centre is named in a WARNING here (:func:`check_centre`; off for a
        first fit that may be fitted again).

    Returns
    -------
    FitChecks

    Raises
    ------
    NotTubularError
        A path that stops farther than ``CHECK_END_GAP`` radii from an end it is named for, or a
        piece of wall larger than ``CHECK_MAX_UNCOVERED`` that the fit does not describe.
    """
    V, scale = pm.V, pm.winding.scale
    gaps = end_gaps(tree.paths, tree.ends)
    check_end_gaps(tree.paths, tree.ends, gaps, scale)
    D, R = _wall_of_branches(V, tree.branches, tree.vertex_branch)
    exempt, zone, zone_radius = _zones(V, tree, D, R)
    area = pm.areas.copy()
    for i in {i for p in tree.paths for i in p.ends}:  # every end is on a path (a dict of two for a single vessel)
        if tree.ends[i].kind != "open":  # a cap or a dome closes the tube: not its wall
            area[np.asarray(tree.ends[i].vertices, np.int64)] = 0.0
    fraction, pieces = wall_coverage(V, pm.topology.adjacency, area, D, R, exempt, zone, zone_radius,
                                     tree.vertex_branch, balls)
    check_coverage(pieces, scale)
    centre = off_centre(tree, (area > 0) & ~exempt & ~zone)
    if warn_centre:
        check_centre(centre, scale)
    return FitChecks(gaps, fraction, pieces, centre)


class _OneBranch:
    """A single vessel's fit seen as a tree of one branch (for :func:`fit_checks`)."""

    def __init__(self, gc, ends, bulges):
        self.ends, self.paths, self.branches, self.bulges = ends, (gc,), (gc,), bulges
        self.vertex_branch = np.zeros(len(gc.vertex_s), np.int64)
        self.junctions, self.junction_branch = np.zeros((0, 3)), np.zeros(0, np.int64)
        self.parent, self.junction_zone, self.medial_zones = np.array([-1]), np.zeros(1), (np.zeros((0, 2)),)


def cylinder_checks(gc, pm, e0, e1, whole, warn_centre=True):
    """:func:`fit_checks` of a single vessel's fit between ends ``e0`` and ``e1``.

    ``whole`` says whether the fit covers the whole mesh (a mesh with these two ends only); a path
    between two ends of a branching mesh is checked for its end gaps only (``covered_fraction``
    None). ``warn_centre`` as :func:`fit_checks`'s. The path is named by ``gc.ends`` where they are
    indices into the mesh's ends.
    """
    ids = tuple(gc.ends) if min(gc.ends) >= 0 else (0, 1)
    ends, named = {ids[0]: e0, ids[1]: e1}, replace(gc, ends=ids)  # the same arrays, the ends named
    if not whole:
        gaps = end_gaps((named,), ends)
        check_end_gaps((named,), ends, gaps, pm.winding.scale)
        return FitChecks(gaps, None, ())
    return fit_checks(_OneBranch(named, ends, tree_bulges((gc,), pm.sacs, (pm.V, pm.topology.adjacency))), pm,
                      warn_centre=warn_centre)
