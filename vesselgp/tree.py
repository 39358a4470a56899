"""Vessel trees: a generalized cylinder per branch, joined at the junctions (issue #13).

:func:`fit_vessel_tree` fits a branching vessel mesh as a network of
generalized cylinders (paper Section 2.1-2.2, applied branch by branch):

1. **Ends and topology.** Every end (:func:`vesselgp.vessel_ends`), the root
   (default the widest) and the branch decomposition
   (:func:`vesselgp.branches.branch_decomposition`: the lumen's medial centre lines
   from the root to every end, :func:`vesselgp.centerlines.centerlines`, give the
   topology, the junction zones, each branch's first axis and each vertex's branch).
2. **One fit per branch, on its own vertices.** The fixed point of Eq. 3 and Eq. 5
   starts from the branch's centre line and is iterated exactly as for a single
   vessel (circle-fit centres, robust reweighting that drops the junction bulges),
   and a clean, densely meshed branch is iterated again on closer nodes, which it
   keeps (:func:`vesselgp.fit.refined`, issue #48), and then with Eq. 2's weight
   on the step only (:func:`vesselgp.fit.freed`). The shared trunk is fitted
   once, not once per path.
3. **Junctions.** A junction is the point closest, in least squares, to the
   lines continuing the parent's distal end and the children's proximal ends
   (centre lines of a bifurcation meet at a corner), held within half the
   inscribed radius of where the centre lines part. The parent's axis is linked to it; each
   child is led in from it along its centre line through the junction zone (a
   straight link cut through the wall where a thin branch leaves a wide trunk).
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
   a path turns through its junctions, so only its branches are held to it, past
   their junction zones: there the axis is the centre line, anatomy, not a fit).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from . import tolerances as tol
from ._interop import polylines_to_pyvista
from .axis import Axis
from ._arrays import within_balls
from .branches import decomposed, root_end
from .centerlines import centerlines
from .bulges import tree_bulges
from .checks import FitChecks, fit_checks
from .curves import chord_length, resample_arclength
from .errors import EndsError, NotTubularError
from .fit import (check_cylinder_bend, cylinder_from_axis, cylinder_sharp_bends,
                  FitProblem, fit_generalized_cylinder, fixed_points, freed, refined)
from .inside import check_axis_inside
from ._per_vertex import on_rows, rows_of
from .medial_zones import medial_zones
from .mesh._ends_tips import own_tube
from .missed_ends import missed_ends
from .prepared import prepared_mesh
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
        vertices of other branches (made whole on first read: see
        :class:`vesselgp.GeneralizedCylinder`'s notes). ``ends`` holds the end index at a terminal
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
    junction_zone : (b,) float64
        Arc length from each branch's start over which its axis is led in along the
        lumen's centre line through its parent's junction zone (0 for the trunk): there the
        axis is the centre line, not the tube model's fit.
    medial_zones : tuple of (z, 2) float64
        Per branch, the ranges of its normalised arc length ``s`` where the tube model does not
        describe the lumen (a sac, a stub, a fold: the fit departed from the lumen's centre line
        by more than half an inscribed radius; a bulb: it turned tighter than its radius) and the
        axis is the centre line instead, not held to the bend check
        (:func:`vesselgp.medial_zones.medial_zones`); empty where the fit holds throughout.
    bulges : tuple of Bulge
        Where the lumen along the paths is wider than on both sides of it (a sac, a bulb, an
        ectasia): each with its paths, its stretch and peak, and its peak and neighbouring radius
        (:func:`vesselgp.bulges.tree_bulges`). The paths pass through it; none on a tube.
    branch_fit : tuple of str
        How each branch's axis was found: ``"converged"`` (the Eq. 3 fixed point settled within
        ``tolerances.GC_CONVERGENCE`` radii), ``"stopped"`` (it reached the iteration cap still moving
        less than ``tolerances.TREE_UNSETTLED`` radii per iteration: its ``last_step`` says how much)
        or ``"centre line"`` (it did not settle: it still moved more than ``tolerances.TREE_UNSETTLED`` radii
        at the cap, or in each of ``tolerances.TREE_UNSETTLED_ITERATIONS`` iterations in a row, where it
        stops; or its system was singular, a stub a few edges around: the axis is the lumen's centre line,
        its radius refitted on it). Every kind passed
        the checks against the mesh.
    checks : FitChecks
        The fit checked against its mesh (:func:`vesselgp.checks.fit_checks`): every path's gap to
        its ends, the fraction of the wall it covers and the pieces it leaves uncovered.
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
    junction_zone: np.ndarray
    medial_zones: tuple
    bulges: tuple
    branch_fit: tuple = ()
    checks: FitChecks | None = None

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

    def to_pyvista(self):
        """The branch axes as a ``pyvista.PolyData`` (needs pyvista: ``pip install "vesselgp[formats]"``).

        Returns
        -------
        pyvista.PolyData
            One line cell per branch (its axis nodes), with cell data ``BranchId`` and
            ``ParentId`` (-1 for the trunk) and point data ``s`` (normalised along the branch),
            ``abscissa`` (arc length from the branch start, mesh units), ``radius`` and the
            frame's ``T``, ``U``, ``V``.

        Raises
        ------
        DependencyError
            pyvista is not installed.
        """
        b = self.branches
        point_data = {"s": np.concatenate([g.s for g in b]),
                      "abscissa": np.concatenate([g.s * g.length for g in b]),
                      "radius": np.concatenate([g.radii for g in b])}
        point_data.update({n: np.concatenate([g.frames[:, k] for g in b]) for k, n in enumerate("TUV")})
        return polylines_to_pyvista([g.centers for g in b], point_data,
                                    {"BranchId": np.arange(len(b)), "ParentId": np.asarray(self.parent)},
                                    what="VesselTree.to_pyvista()")


# ----------------------------------------------------------------------------- one branch


@dataclass(frozen=True)
class _RawBranch:
    """A branch's converged fit before the junctions: nodes, vertex ids and their s, radius scale."""

    idx: np.ndarray
    nodes: np.ndarray
    s: np.ndarray
    it: object
    rscale: float


def _branch_problem(V, area, line, idx, caps, start, end):
    """The Eq. 3 / Eq. 5 fixed point (:class:`FitProblem`) of one branch's vertices, started on its
    medial first axis ``line`` (:class:`vesselgp.branches.Branching`).

    ``start`` / ``end`` are the mesh ends (:class:`vesselgp.VesselEnd`) the axis is pinned to
    (the root and a tip, where the line starts and ends at the end's centre), or None at a
    junction side, which moves with its data. The radius scale is the median distance of the
    branch's wall to the line; each vertex starts at its nearest point on it.
    """
    Vb, ab = V[idx], np.where(caps, 0.0, area[idx])
    L0 = float(chord_length(line)[-1])
    if not L0 > 0 or not (ab > 0).any():
        raise NotTubularError("a branch of the tree has no length or no wall; check the mesh (vesselgp.clean_mesh)")
    dist, near = cKDTree(line).query(Vb)  # the line has a point every MEDIAL_SPACING inscribed radii
    rscale = float(np.median(dist[ab > 0]))
    s0 = chord_length(line)[near] / L0
    K = int(np.clip(L0 / (tol.GC_NODE_SPACING * rscale), tol.GC_MIN_NODES, tol.GC_MAX_NODES))
    return FitProblem(resample_arclength(line, K), s0, Vb, ab, caps, rscale, L0,
                      pin=(start is not None, end is not None),
                      mirror=tuple(e is not None and e.kind != "rounded" for e in (start, end)))


# ----------------------------------------------------------------------------- junctions


class _EndLine(NamedTuple):
    """The line continuing an axis beyond one end (:func:`_end_line`)."""

    point: np.ndarray  # p0, where the axis is kept up to and the link to the junction starts
    direction: np.ndarray  # unit, the chord's direction out of the end
    tangent: np.ndarray  # unit, the axis's own direction at p0, out of the end
    arc: float  # arc length of p0 from the end


def _end_line(nodes, rscale, at_start):
    """A point and unit direction continuing the axis beyond one end, the axis's own direction there
    and the point's arc length from the end (:class:`_EndLine`).

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
    return _EndLine(p0, d / np.linalg.norm(d), (q0 - q1) / np.linalg.norm(q0 - q1), float(a0))


def _beyond(nodes, line, at_start):
    """The nodes farther along the axis from the end than the line's point ``p0`` (by arc length).

    Not the half-space behind ``p0``'s tangent plane: an axis that turns back through more
    than a right angle (a carotid siphon before its branches, a branch looping after its
    junction) has nodes on the far side of that plane, and those were dropped: the paths of a
    siphon started 8.6 radii from their root end (issue #44).
    """
    arc = chord_length(nodes)
    return nodes[arc > line.arc] if at_start else nodes[arc[-1] - arc > line.arc]


def _junction_point(parent_line, child_lines, J0, R0):
    """Where the branch axes' continuations meet, held within the junction zone.

    The point closest in least squares to the lines continuing the parent's distal end and
    the children's proximal ends (centre lines of a bifurcation meet at a corner), weakly
    pulled (``TREE_JUNCTION_ANCHOR``) to the centre lines' junction ``J0``; a result farther
    than ``TREE_JUNCTION_HOLD`` of the inscribed radius ``R0`` there from ``J0`` is brought back
    onto that sphere (the lines of a branch leaving along its parent, nearly parallel, meet
    anywhere, and the parent's axis kinked to reach them).
    """
    A = tol.TREE_JUNCTION_ANCHOR * np.eye(3)
    b = tol.TREE_JUNCTION_ANCHOR * J0
    for line in [parent_line] + list(child_lines):
        a, dc = line.point, line.direction
        P = np.eye(3) - np.outer(dc, dc)
        A, b = A + P, b + P @ a
    J = np.linalg.solve(A, b)
    off, hold = np.linalg.norm(J - J0), tol.TREE_JUNCTION_HOLD * R0
    return J if off <= hold else J0 + (J - J0) * (hold / off)


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
    p0, t_out = line.point, line.tangent
    keep = _beyond(nodes, line, at_start)
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


def _led_in(nodes, J, lead, line, rscale):
    """A child's nodes from the line's point ``p0`` on, led in from its junction ``J`` along its centre line.

    ``lead`` is the child's centre line through the junction zone
    (:class:`vesselgp.branches.Branching`, ``lead_in``); it is taken from its point nearest to
    ``J`` on (a line that parted early from its parent's ran beside it inside the trunk up to
    there), and its points up to ``TREE_PATH_ROUNDING`` radii before ``p0`` (along the axis's
    direction there) are kept; a cubic Hermite curve joins the last of them to ``p0`` with the
    axis's own direction. A straight link from the junction cut through the wall where a branch
    leaves a wide trunk at a steep angle (the arch's branches, the renals). Returns the nodes and
    the arc length of the led-in part (up to ``p0``): the junction zone, anatomy rather than a fit.
    """
    p0, t_out = line.point, line.tangent
    keep = _beyond(nodes, line, at_start=True)
    if len(keep) < 2:
        raise NotTubularError("a branch of the tree is shorter than its junction zone; "
                              "the mesh may have a side bulge detected as an end (see vesselgp.vessel_ends)")
    lead = _lead_from(lead, J)
    before = lead[(lead - p0) @ t_out > tol.TREE_PATH_ROUNDING * rscale]
    before = before if len(before) else lead[:1]  # J itself is closer to p0: one curve from J
    a = before[-1]
    ta = before[-1] - before[-2] if len(before) > 1 else p0 - a
    if not np.linalg.norm(p0 - a) > 0 or not np.linalg.norm(ta) > 0:
        out = np.vstack([before[:-1], keep])
    else:
        k = int(np.ceil(np.linalg.norm(p0 - a) / (tol.GC_NODE_SPACING * rscale))) + 2
        out = np.vstack([before[:-1], _hermite(a, ta / np.linalg.norm(ta), p0, -t_out, k)[:-1], keep])
    return out, float(chord_length(out)[len(out) - len(keep)])


def _lead_from(lead, J):
    """A child's centre line through its junction zone, from ``J`` on: ``J``, then the line's points
    after its point nearest to ``J`` (a line that parted early from its parent's ran beside it up to there)."""
    i = int(np.argmin(np.linalg.norm(lead - J, axis=1))) if len(lead) else -1
    return np.vstack([J, lead[i + 1:]])


def _junctions(raw, parent, junctions, junction_radius, lead_in):
    """The junction points, their branches, each branch's nodes joined to its junctions (:func:`_attach`,
    :func:`_led_in`) and the arc length of its junction zone from its start (0 for the trunk).

    A junction is where the branch axes' continuations meet (:func:`_junction_point`), within
    half the inscribed radius of the centre lines' junction (:class:`vesselgp.branches.Branching`:
    where the medial lines part); several children leaving within one junction zone all join
    the same point.
    """
    nodes = [r.nodes for r in raw]
    zone = np.zeros(len(raw))
    J, Jb = [], []
    for b in range(len(raw)):
        kids = np.flatnonzero(parent == b)
        if not kids.size:
            continue
        pline = _end_line(raw[b].nodes, raw[b].rscale, at_start=False)
        clines = [_end_line(raw[c].nodes, raw[c].rscale, at_start=True) for c in kids]
        Jp = _junction_point(pline, clines, junctions[b], junction_radius[b])
        nodes[b] = _attach(nodes[b], Jp, pline, raw[b].rscale, at_start=False)
        for c, cl in zip(kids, clines):
            nodes[c], zone[c] = _led_in(nodes[c], Jp, lead_in[c], cl, raw[c].rscale)
        J.append(Jp)
        Jb.append(b)
    return np.array(J).reshape(-1, 3), np.array(Jb, np.int64), nodes, zone


# ----------------------------------------------------------------------------- cylinders


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
    return on_rows(gc, idx, len(V)), axis


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


# ----------------------------------------------------------------------------- public entry


def fit_vessel_tree(V, F=None, root=None, *, ends=None, lam=None, mu=None, max_iter=None, geodesics=None):
    """Fit a branching vessel mesh as a tree of generalized cylinders (see the module notes).

    Parameters
    ----------
    V : (n, 3) float64, PreparedMesh or mesh object
        Vertex positions, or a :class:`vesselgp.PreparedMesh` (checked once for several fits;
        ``F`` and ``ends`` are then left out), or a ``trimesh.Trimesh``,
        ``pyvista.PolyData`` or ``meshio.Mesh`` (``F`` left out; :func:`vesselgp.as_mesh`).
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
        and the faces of ``F`` with an area, to reuse its factorisation: a mesh with two ends
        is fitted as one path, whose data mask uses it. A tree's decomposition runs on the
        centre lines instead; a solver given for another mesh is refused all the same.

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
    pm = prepared_mesh(V, F, ends)  # validated, oriented and checked once (vesselgp.prepared)
    V, F, (topo, Fg, _) = pm.V, pm.F, pm.checked
    lam = tol.GC_LAMBDA if lam is None else float(lam)
    mu = tol.GC_MU if mu is None else float(mu)
    max_iter = tol.GC_MAX_ITER if max_iter is None else int(max_iter)
    if geodesics is not None:
        geodesics.check(V, Fg)
    if len(pm.ends) < 2:
        raise EndsError(f"a vessel tree needs at least two ends, the mesh has {len(pm.ends)} "
                        "(see vesselgp.vessel_ends)")
    found = pm._given_ends is None or pm._searched  # the ends were found (and searched for), not given
    pm = with_missed_ends(pm, root)
    ends = pm.ends
    if root is None and found:
        _warn_if_the_root_may_be_a_sac(pm, root_end(ends))
    root = root_end(ends, root)
    if len(ends) == 2:
        return _one_path(pm, root, fit_generalized_cylinder(pm, ends=(root, 1 - root), lam=lam, mu=mu,
                                                           max_iter=max_iter, geodesics=geodesics))
    area = pm.areas
    br = decomposed(V, Fg, ends, root, voronoi=pm.voronoi)
    caps, leaf_tip, problems, ids = _branch_problems(V, area, ends, root, br)
    # the branches' fixed points in lock step (one vectorised pass per iteration over all of them)
    fits = fixed_points(problems, lam=lam, mu=mu, max_iter=max_iter, what="vessel-tree branch fit",
                        singular="stop", unsettled=(tol.TREE_UNSETTLED, tol.TREE_UNSETTLED_ITERATIONS))
    # a clean branch's fixed point again on closer nodes, which it keeps (issue #48; vesselgp.fit.refined)
    fits = refined(problems, fits, lam=lam, mu=mu, max_iter=max_iter, singular="stop", resample=False)
    # ... and a clean branch's fixed point freed of Eq. 2's pull (vesselgp.fit.freed)
    fits = freed(problems, fits, lam=lam, mu=mu, max_iter=max_iter, singular="stop")
    how = [_branch_fit(it, p) for it, p in zip(fits, problems)]
    firsts = [_raw_branch(b, idx, it, p, br, h) for b, (idx, it, p, h) in enumerate(zip(ids, fits, problems, how))]
    raw, medial = [r for r, _ in firsts], [m for _, m in firsts]
    junctions, junction_branch, nodes, zone = _junctions(raw, br.parent, br.junctions, br.junction_radius, br.lead_in)
    lines = [_through_junctions(b, br, junctions, junction_branch) for b in range(len(raw))]
    for b, r in enumerate(raw):  # again through the junction zones, the axes now joined there; the turns
        # are judged here only, past the child's junction zone (a first fit's free end crosses it)
        line, R = lines[b]
        fit_radius = np.interp(np.linspace(0.0, 1.0, len(nodes[b])), np.linspace(0.0, 1.0, len(r.it.radii)),
                               r.it.radii)  # the first fit's radii (the junctions moved the ends only)
        nodes[b], zones = medial_zones(nodes[b], line, R, r.rscale, through=(True, True), fit_radius=fit_radius,
                                       skip_start=zone[b])
        medial[b] = np.concatenate([medial[b], _zone_points(line, zones)])
    branches, axes = _branch_cylinders(V, area, caps, raw, nodes, br, root, leaf_tip, lam, mu)
    if _sharp_turns_to_centre_line(branches, axes, raw, nodes, lines, zone, medial):
        branches, axes = _branch_cylinders(V, area, caps, raw, nodes, br, root, leaf_tip, lam, mu)
    paths, path_branches = _paths(V, area, caps, branches, axes, raw, br, root, lam, mu)
    winding = pm.winding  # one closed surface for every path
    for p in paths:
        check_axis_inside(V, F, p.s, p.centers, p.radii, winding=winding)
    medial = tuple(_zone_s(a, m) for a, m in zip(axes, medial))
    for b, z, m in zip(branches, zone, medial):  # not the paths, a junction zone nor a medial zone:
        check_cylinder_bend(b, winding.scale, skip_start=z, skip=m)  # they turn there by design
    tree = VesselTree(ends=ends, root=root, junctions=junctions, junction_branch=junction_branch,
                      branches=tuple(branches), parent=br.parent, paths=tuple(paths),
                      path_branches=tuple(path_branches), vertex_branch=br.vertex_branch,
                      junction_zone=zone, medial_zones=medial,
                      bulges=tree_bulges(paths, pm.sacs, (pm.V, pm.topology.adjacency)),
                      branch_fit=tuple(how))
    balls = (np.vstack(br.centerlines.points), np.concatenate(br.centerlines.radius))  # the lumen's spheres
    tree = replace(tree, checks=fit_checks(tree, pm, balls))  # every end reached, the wall covered (or raise)
    _log_branch_fits(tree, [p.rscale for p in problems], max_iter)
    return tree


def _branch_fit(it, p):
    """How a branch's fixed point ended (:attr:`VesselTree.branch_fit`)."""
    return ("converged" if it.converged else "stopped" if it.step <= tol.TREE_UNSETTLED * p.rscale
            else "centre line")


def _raw_branch(b, idx, it, p, br, how):
    """Branch ``b``'s first fit (its :class:`_RawBranch`) and the ends of its medial zones on its centre line,
    (z, 2, 3) float64: its fixed point ``it`` with medial zones where it departs from the lumen, or, when it
    did not settle (``how`` "centre line"), the lumen's centre line throughout."""
    if how != "centre line":
        nodes, zones = medial_zones(it.nodes, br.lines[b], br.line_radius[b], p.rscale)
    else:  # a fixed point still wandering (a stub on its junction's flare), or one whose system is
        # singular (a stub with too few vertices around some of its nodes), is no fit: the centre line
        log.debug("tree branch %d: its fit %s; its axis is the lumen's centre line", b,
                  "is singular (too few vertices around it)" if it.singular else
                  f"still moves {it.step / p.rscale:.2g} radii per iteration")
        nodes = resample_arclength(br.lines[b], len(it.nodes))
        a = chord_length(br.lines[b])
        zones = np.array([[0.0, a[-1]]])
        # its radius is refitted about the centre line with outliers judged against the lumen's inscribed
        # radius along it (as when singular from the first iteration), not against the radii where the
        # wandering fit stopped: the wall of a vessel whose end was missed, which made the fit wander, is
        # then an outlier, not a radius of 6.5 where the lumen's is 2 (a bulge, whose reach hid that vessel
        # from the checks: issue #47)
        it = replace(it, radii=np.interp(np.linspace(0.0, a[-1], len(it.nodes)), a, br.line_radius[b]))
    medial = _zone_points(br.lines[b], zones)  # (z, 2, 3) ends
    return _RawBranch(idx=idx, nodes=nodes, s=it.s, it=it, rscale=p.rscale), medial


def _log_branch_fits(tree, rscales, max_iter):
    """One INFO line on the branches whose fit did not converge (:attr:`VesselTree.branch_fit`), if any."""
    stopped = [b for b, h in enumerate(tree.branch_fit) if h == "stopped"]
    medial = [b for b, h in enumerate(tree.branch_fit) if h == "centre line"]
    if not stopped and not medial:
        return
    parts = []
    if stopped:
        worst = max(raw_step / r for raw_step, r in ((tree.branches[b].last_step, rscales[b]) for b in stopped))
        parts.append(f"{len(stopped)} stopped at {max_iter} iterations still moving up to {worst:.2g} radii per "
                     f"iteration (branches {', '.join(map(str, stopped))})")
    if medial:
        parts.append(f"{len(medial)} did not settle and take the lumen's centre line (branches "
                     f"{', '.join(map(str, medial))})")
    log.info("vessel tree: of %d branch fits, %s; every axis passed the checks against the mesh",
             len(tree.branch_fit), "; ".join(parts))


def _one_path(pm, root, gc):
    """The tree of one branch of a mesh with two ends, fitted as the single vessel ``gc``."""
    return VesselTree(ends=pm.ends, root=root, junctions=np.zeros((0, 3)), junction_branch=np.zeros(0, np.int64),
                      branches=(gc,), parent=np.array([-1], np.int64), paths=(gc,), path_branches=((0,),),
                      vertex_branch=np.zeros(len(pm.V), np.int64), junction_zone=np.zeros(1),
                      medial_zones=(np.zeros((0, 2)),),
                      bulges=tree_bulges((gc,), pm.sacs, (pm.V, pm.topology.adjacency)),
                      branch_fit=("converged" if gc.converged else "stopped",), checks=gc.checks)


def _with_missed_caps(pm, root):
    """``pm`` with the flat patches no centre line reaches taken for caps (appended to its ends), if any.

    :func:`vesselgp.vessel_ends` reports the flat disks that the wall meets round most of their rims but
    that it did not take for caps (:attr:`vesselgp.PreparedMesh.flat_patches`: a cap whose rim remeshing
    rounded off, or whose body bulges too far behind it). The lumen's centre lines from the root to every
    end found (:func:`vesselgp.centerlines.centerlines`) pass within their inscribed radius of a patch on a
    vessel's wall (a facet); a patch that no inscribed sphere of theirs reaches, scaled by
    ``1 + tolerances.CHECK_COVER_TOLERANCE``, closes a vessel whose end was missed, and the fit would
    leave that vessel without an axis (or take it for a bulge of the path beside it: issue #44, a capped
    arch whose ascending aorta's cap was missed). So does a patch the wall meets round its whole rim, reached or
    not, whose body behind failed the cap test (a vessel cut and capped next to a junction, whose body widens
    into it: the 4D-flow arch clipped through its arch and capped by a fan lost that end, every check passing,
    the lines to the other ends reaching its cap). Either becomes an end (logged at WARNING) if it spans its
    lumen (:func:`_spans_its_lumen`).
    """
    if not pm.flat_patches:
        return pm
    lines = centerlines(pm.V, pm.checked.faces, pm.ends, root_end(pm.ends, root), voronoi=pm.voronoi)
    C, R = np.vstack(lines.points), (1.0 + tol.CHECK_COVER_TOLERANCE) * np.concatenate(lines.radius)
    reached = [bool(within_balls(p.end.center[None], C, R)[0]) for p in pm.flat_patches]
    missed = [(p.end, r) for p, r in zip(pm.flat_patches, reached)
              if (p.walled or not r) and _spans_its_lumen(pm, p.end, tol.MISSED_CAP_SPAN_MAX if r else np.inf)]
    if not missed:
        return pm
    for k, (p, r) in enumerate(missed):
        log.warning("%s the flat patch %s, which vesselgp.vessel_ends did not take for a cap; it is the cap of a "
                    "vessel whose end was missed: end %d",
                    "the wall meets the whole rim of" if r else "no centre line reaches", p.describe(),
                    len(pm.ends) + k)
    return pm.with_ends(tuple(pm.ends) + tuple(e for e, _ in missed))


def with_missed_ends(pm, root=None):
    """``pm`` with the ends :func:`vesselgp.vessel_ends` missed appended: the flat patches no centre line reaches
    that span their lumen (:func:`_with_missed_caps`), then the vessels no centre line enters
    (:func:`_with_missed_vessels`, :mod:`vesselgp.missed_ends`), each named in a WARNING. Ends the caller gave
    (``PreparedMesh(V, F, ends)``) are the ends: only the flat patches (none then) are looked at.

    :func:`fit_vessel_tree` calls it; so does ``vesselgp fit`` before it decides whether the mesh is one vessel or
    a tree (a capped arch whose end tests found two of its five ends was fitted as one tube and refused).

    Parameters
    ----------
    pm : PreparedMesh
    root : int, optional
        The root end (default the widest).

    Returns
    -------
    PreparedMesh
        ``pm`` itself when nothing was missed.
    """
    if pm._searched:  # (vesselgp fit looks before it decides between one vessel and a tree)
        return pm
    given = pm._given_ends is not None  # ends the caller gave are the ends
    pm = _with_missed_caps(pm, root)
    pm = _with_sacs_past_the_ends(pm, root) if given else _with_missed_vessels(pm, root)
    pm._searched = True  # (a cache of this mesh's, as its diagram is: set on the object given when nothing was added)
    return pm


def _warn_if_the_root_may_be_a_sac(pm, root):
    """A WARNING when the widest end, the tree's root by default, may be a blind sac's dome: a rounded end that goes
    on as a tube of its own for less than ``tolerances.ENDS_SAC_TUBE_RADII`` of its radii
    (:func:`vesselgp.mesh._ends_tips.own_tube`), on a mesh with no open or capped end. There
    :func:`vesselgp.vessel_ends` cannot tell a sac from a vessel's end (its rule compares a dome with the cut ends),
    and a sac wider than the vessels is taken for the root: the intracranial aneurysm made again by marching cubes
    (its sac, 4.8 against 4.5 and 3.6, on a tube of 0.2 radii), the voxelised aneurysm with noise (its sac found
    as a missed end, 7.1 against 3.4, on 2.0 radii). A vessel closed at its valve (the pulmonary trunk, 1.0 radii)
    or whose cap was rounded off reads alike; the warning says so, and how to leave a sac out."""
    e = pm.ends[root]
    if e.kind != "rounded" or any(x.kind in ("open", "cap") for x in pm.ends):
        return
    tube = _own_tube_of(pm, e)
    if tube < tol.ENDS_SAC_TUBE_RADII:
        others = [i for i in range(len(pm.ends)) if i != root]
        log.warning("the widest end, %d (%s), the tree's root, is a dome that goes on as a tube of its own for %.4g "
                    "radii only: a blind sac's dome (an aneurysm) or a vessel closed at its valve or rounded off; a "
                    "mesh with no open or capped end cannot tell them apart. If it is a sac, fit without it: "
                    "vesselgp.fit_vessel_tree with the ends %s (ends=), or one path of them (vesselgp fit --ends I J)",
                    root, e.describe(), tube, " ".join(map(str, others)))


def _spans_its_lumen(pm, cap, most=np.inf):
    """Whether a flat patch is as wide as the lumen behind it (a whole cross-section, a vessel's cap): its radius at
    least ``tolerances.MISSED_CAP_SPAN`` of the largest inscribed sphere (inside Voronoi vertex) that reaches its
    centre, scaled as the lines' spheres are, and at most ``most`` of it. The flat terraces that marching cubes
    leaves on a wide cap whose rim it rounded off are not (the gmsh arch made again at a fifth of its least radius:
    three patches of radius 2.8-3.7 on its ascending aorta's cap of 15.9, each taken for a missed vessel's cap
    before); the lumen's own missed end is found instead (:func:`_with_missed_vessels`). A patch the lines reach is
    held to ``tolerances.MISSED_CAP_SPAN_MAX`` too: a flat side of a coarse wall is wider than the lumen behind it
    (the XCAT tree remeshed at 1.4 edges: 2.0 and 2.5 times it)."""
    cc, R, inside, _ = pm.voronoi.graph(False)
    ids = np.flatnonzero(inside)
    reach = (1.0 + tol.CHECK_COVER_TOLERANCE) * R[ids]
    near = np.linalg.norm(cc[ids] - cap.center, axis=1) <= reach
    behind = float(R[ids][near].max()) if near.any() else 0.0
    span = cap.radius / behind if behind > 0 else np.inf  # no sphere reaches it: nothing behind is wider
    log.debug("the flat patch %s spans %.6g of the lumen's largest sphere behind it", cap.describe(), span)
    if tol.MISSED_CAP_SPAN <= span <= most:
        return True
    log.info("the flat patch %s spans %.4g of the lumen's largest sphere behind it (radius %.4g): %s, not taken for a "
             "cap", cap.describe(), span, behind,
             "not a whole cross-section" if span < tol.MISSED_CAP_SPAN else "wider than the lumen (a flat side)")
    return False


def _with_missed_vessels(pm, root):
    """``pm`` with the ends of the vessels no centre line enters appended, one at a time (:func:`missed_ends`,
    logged at WARNING). A mesh whose ends are all open loops is not searched (a vessel of it that ends closed
    among vessels cut open is not looked for: the lumen's diagram would be drawn for every single open tube)."""
    if all(e.kind == "open" for e in pm.ends):
        return pm
    for _ in range(tol.MISSED_MAX_ENDS):
        lines = centerlines(pm.V, pm.checked.faces, pm.ends, root_end(pm.ends, root), voronoi=pm.voronoi)
        new = missed_ends(pm, lines)
        if not new:
            break
        log.warning("the lumen runs on past every centre line into a vessel with no end found (vesselgp.vessel_ends "
                    "did not take its end for one): %s, end %d", new[0].describe(), len(pm.ends))
        pm = pm.with_ends(tuple(pm.ends) + tuple(new))
    return pm


def _with_sacs_past_the_ends(pm, root):
    """``pm`` (its ends given by the caller, none of them open or capped: the case of the root's warning,
    :func:`_warn_if_the_root_may_be_a_sac`) with the domes the lumen runs on to past its centre lines
    (:func:`missed_ends`) on a tube shorter than ``tolerances.ENDS_SAC_TUBE_RADII`` taken for blind sacs
    (:meth:`vesselgp.PreparedMesh.with_sacs`): the ends given are the ends. Such a sac is reported as a bulge and
    its wall described by it (a closed mesh whose widest dome was a sac, fitted again without it as that warning
    says: the sac's wall was left without an axis and the fit refused). A dome on a longer tube is a vessel the
    caller left out: nothing is added, and the cover check judges its wall as before."""
    if any(e.kind in ("open", "cap") for e in pm.ends):
        return pm
    lines = centerlines(pm.V, pm.checked.faces, pm.ends, root_end(pm.ends, root), voronoi=pm.voronoi)
    for _ in range(tol.MISSED_MAX_ENDS):
        new = missed_ends(pm, lines)
        if not new:
            break
        tube = _own_tube_of(pm, new[0])
        if tube >= tol.ENDS_SAC_TUBE_RADII:  # a vessel left out by the caller: no sac (the cover check judges it)
            log.info("the lumen runs on past every centre line to %s, which is none of the ends given; it goes on as "
                     "a tube of %.4g radii: a vessel, not a sac", new[0].describe(), tube)
            break
        log.info("the lumen runs on past every centre line to %s, which is none of the ends given, on a tube of %.4g "
                 "radii only: a blind sac", new[0].describe(), tube)
        pm = pm.with_sacs([(new[0].center, new[0].direction, new[0].radius)])
    return pm


def _own_tube_of(pm, end):
    """How far the rounded ``end`` goes on as a tube of its own, in its radii (:func:`own_tube` from its region's
    vertex farthest along its direction)."""
    V, topo = pm.V, pm.topology
    w = topo.edge_lengths(V)
    region = np.asarray(end.vertices, np.int64)
    tip = int(region[np.argmax((V[region] - end.center) @ end.direction)])
    return own_tube(V, topo.edge_matrix(w), {"tip": tip, "radius": end.radius}, float(np.median(w)))


def _sharp_turns_to_centre_line(branches, axes, raw, nodes, lines, zone, medial):
    """Where a branch's final cylinder still turns tighter than its final radius, its axis becomes the
    centre line there too (``nodes`` and ``medial`` updated in place); whether any did.

    The first fit's turns are judged on its own radii (:func:`medial_zones`); the final cylinder's
    Eq. 4 radii, on the axis joined at its junctions, can be larger (a sac's, a bulb's), and there
    the tube model does not hold either (issue #34: the pulmonary artery remeshed at 1.4 edges turned
    at kappa r 1.02, and a remeshed intracranial aneurysm's sac at 1.01-1.22, with no medial zone).
    The bend check still judges the result."""
    changed = False
    for b, (gc, a) in enumerate(zip(branches, axes)):
        sharp = cylinder_sharp_bends(gc, skip_start=zone[b], skip=_zone_s(a, medial[b]))
        if not len(sharp):
            continue
        line, R = lines[b]
        nodes[b], zones = medial_zones(nodes[b], line, R, raw[b].rscale, through=(True, True), skip_start=zone[b],
                                       sharp_s=sharp)
        medial[b] = np.concatenate([medial[b], _zone_points(line, zones)])
        log.info("tree branch %d: its axis turns tighter than its fitted radius at s = %.3g-%.3g; the centre "
                 "line there", b, sharp.min(), sharp.max())
        changed = True
    return changed


def _through_junctions(b, br, junctions, junction_branch):
    """Branch ``b``'s centre line from its junction (led in, :func:`_led_in`) to its own distal junction,
    and the inscribed radius along it (its first point's through the lead-in, the junction's at its end)."""
    parts, radii = [br.lines[b]], [br.line_radius[b]]
    if br.parent[b] >= 0:
        J = junctions[np.flatnonzero(junction_branch == br.parent[b])[0]]
        lead = _lead_from(br.lead_in[b], J)
        parts.insert(0, lead)
        radii.insert(0, np.full(len(lead), br.line_radius[b][0]))
    own = np.flatnonzero(junction_branch == b)
    if own.size:
        parts.append(junctions[own[0]][None])
        radii.append(np.array([br.junction_radius[b]]))
    P, R = np.vstack(parts), np.concatenate(radii)
    keep = np.r_[True, np.linalg.norm(np.diff(P, axis=0), axis=1) > 0]
    return P[keep], R[keep]


def _zone_points(line, zones):
    """The points of polyline ``line`` (k, 3) at or next after the arc lengths ``zones`` (z, 2): (z, 2, 3) float64.

    A zone's arc lengths are measured on the line densified (:func:`vesselgp.medial_zones.medial_zones`), whose
    length may exceed this one's by a rounding: a zone ending at the line's end then takes its last point (the
    voxelised aneurysm remeshed at 1.4 edges on one machine: an index one past the end, a crash).
    """
    return line[np.minimum(np.searchsorted(chord_length(line), zones), len(line) - 1)]


def _zone_s(axis, ends):
    """The normalised arc lengths on ``axis`` nearest to each zone's end points: (z, 2) float64."""
    if not len(ends):
        return np.zeros((0, 2))
    k = cKDTree(axis.points).query(ends.reshape(-1, 3))[1]
    return np.sort(axis.s[k].reshape(-1, 2), axis=1)


def _branch_problems(V, area, ends, root, br):
    """The cap and tip vertices, each leaf branch's tip end, and every branch's fixed point and vertex ids."""
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
        problems.append(_branch_problem(V, area, br.lines[b], idx, caps[idx], start, end))
        ids.append(idx)
    return caps, leaf_tip, problems, ids


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
        s_prev = np.concatenate([(offset[k] + rows_of(branches[b], "vertex_s", raw[b].idx) * lengths[k]) / total
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
