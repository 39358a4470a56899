"""Join two real vessels by end index: :func:`join_vessels` (paper Section 2.3 and 3).

Everything a join needs is derived from the two meshes and two end indices
(into :func:`vesselgp.vessel_ends` of each mesh):

* a capped or rounded end is opened (:func:`vesselgp.mesh.open_end`), so that
  both ends are boundary rings;
* the moving vessel is fitted between its other end and the joined end
  (``s = 0`` at the held end, ``s = 1`` at the joined end), and a length of
  vessel next to the other end is held (``tolerances.JOIN_HOLD_FRACTION`` of
  the axis by default); a moving tree is fitted with
  :func:`vesselgp.fit_vessel_tree`, its path from the widest other end to the
  joined end is the axis, and every branch but the joined end's own is held,
  as is that branch through its junction zone (its wall there is the parent's flare);
* the target is the other end's centre, with tangent minus its outward
  direction (the joined vessel continues into the other one);
* angle 0 is a visible anchor: ``moving_normal`` (a direction across the
  moving end) lands on ``target_normal`` (across the other end). By default
  ``moving_normal`` is the world axis (x, y or z) most perpendicular to the
  moving end's direction, projected into its plane, and ``target_normal`` is
  its image under the least rotation that takes the moving end's direction
  onto the target tangent, so a join that only bends the end is at angle 0;
* before the search the join is checked for plausibility: ends whose radii differ by
  more than ``max_radius_ratio`` (``tolerances.JOIN_MAX_RADIUS_RATIO``, 1.5: an end-to-end
  anastomosis joins vessels of similar calibre; the stitch would leave a step in the wall),
  an axial stretch of the free part above ``max_stretch`` (or a compression below its
  inverse) or a bend tighter than the radius allows
  (curvature times radius above ``tolerances.JOIN_MAX_BEND``) are refused, a
  stretch above ``tolerances.JOIN_STRETCH_WARN`` is warned about;
* :func:`vesselgp.minimize_torsion` finds the end rotation of least torsion
  (Eq. 8) and the result is stitched to the other vessel
  (:func:`vesselgp.mesh.stitch`) into one manifold mesh, checked to be one
  connected piece.
"""
from __future__ import annotations

import logging
import time
from dataclasses import replace

import numpy as np
from scipy.spatial.transform import Rotation

from . import tolerances as tol
from ._validate import as_mesh, as_vector, mesh_arguments
from .deform import Frame
from .errors import EndsError, ImplausibleJoinError, InvalidMeshError, OptionError
from .fit import fit_generalized_cylinder
from .tree import fit_vessel_tree
from .join import JoinProblem, minimize_torsion
from .mesh import MeshTopology, open_end, stitch, vessel_ends
from .mesh._ends_format import end_listing
from .rotations import minimal_rotation

log = logging.getLogger(__name__)

__all__ = ["join_vessels", "VesselJoin", "default_normal"]


def default_normal(direction):
    """The default anchor across an end: the world axis most perpendicular to ``direction``, in its plane.

    Parameters
    ----------
    direction : (3,) float64
        An end's axis direction (either sense gives the same anchor).

    Returns
    -------
    (3,) float64
        Unit, perpendicular to ``direction``.

    Examples
    --------
    >>> default_normal([0.0, 0.2, 1.0]).round(3).tolist()
    [1.0, 0.0, 0.0]
    """
    d = as_vector(direction, "direction")
    d = d / np.linalg.norm(d)
    e = np.eye(3)[int(np.argmin(np.abs(d)))]
    n = e - (e @ d) * d
    return n / np.linalg.norm(n)


def _pick(ends, i, what):
    """``ends[i]``, or an :class:`EndsError` that lists the ends."""
    if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i < len(ends):
        raise EndsError(f"{what}={i!r} is not an end index in 0..{len(ends) - 1} (ends: {end_listing(ends)})")
    return ends[int(i)]


def _opened(V, F, ends, i, what):
    """The mesh with end ``i`` opened, its ends, and the index of the opened end among them."""
    e = _pick(ends, i, what)
    W, G, loop, kept = open_end(V, F, e)
    new = vessel_ends(W, G) if e.kind != "open" else ends
    dist = [np.linalg.norm(x.center - e.center) + (0.0 if x.kind == "open" else np.inf) for x in new]
    j = int(np.argmin(dist))
    if not set(np.asarray(new[j].loop).tolist()) == set(loop.tolist()):
        raise EndsError(f"opening {what} {i} ({e.describe()}) did not leave its rim as an end; "
                        "repair the mesh (vesselgp clean) and try again")
    return W, G, kept, new, j


def _held(gc, hold, kept, n_user):
    """Held vertex ids in the opened moving mesh from ``hold`` (None, a fraction, or user vertex ids)."""
    if hold is None or np.ndim(hold) == 0:
        f = tol.JOIN_HOLD_FRACTION if hold is None else float(hold)
        if not 0.0 < f < 1.0:
            raise EndsError(f"hold={hold!r} is not an arc-length fraction in (0, 1); give one like 0.2, or vertex ids")
        fixed = np.flatnonzero(gc.vertex_s <= f)
        if len(fixed) == 0:
            raise EndsError(f"no vertex lies within {f:g} of the axis length of the held end; give a larger hold=")
        return fixed
    ids = np.asarray(hold)
    if ids.dtype == bool or not np.issubdtype(ids.dtype, np.integer) or ids.ndim != 1:
        raise EndsError("hold must be None, an arc-length fraction in (0, 1) or a 1-D array of vertex ids")
    if ids.size == 0 or ids.min() < 0 or ids.max() >= n_user:
        raise EndsError(f"hold= vertex ids must be in 0..{n_user - 1} (the moving vessel's vertices)")
    new = np.full(n_user, -1, np.int64)
    new[kept] = np.arange(len(kept))
    out = new[ids]
    if np.any(out < 0):
        raise EndsError(f"{int(np.sum(out < 0))} of the hold= vertices belong to the cap that was removed to open "
                        "the joined end; hold vertices of the vessel's other end")
    return np.unique(out)


def _calibre(e_move, e_other, max_ratio):
    """Refuse ends whose radii differ by more than ``max_ratio`` (an end-to-end join of unlike calibres)."""
    r, ro = float(e_move.radius), float(e_other.radius)
    ratio = max(r, ro) / min(r, ro)
    if ratio > max_ratio:
        raise ImplausibleJoinError(
            f"the ends' radii differ {ratio:.2f}x (the moving end {r:.3g}, the other end {ro:.3g}; at most "
            f"max_radius_ratio = {max_ratio:g}): an end-to-end join needs vessels of similar calibre, and the wall "
            "would step at the seam; join an end of similar radius, or raise max_radius_ratio to join them anyway"
        )


def _plausible(problem, max_stretch, placed):
    """Refuse a target the vessel cannot reach without tearing or folding; warn when it is a stretch.

    Without a placement (``placed`` False) the stretch and compression refusals name ``place=`` too:
    two vessels in unrelated coordinates need one (the stretch is then the distance between them)."""
    pl, gc = problem.placement, problem.gc
    st = pl.axial_stretch
    place = "" if placed else ", or place the vessel facing the other end first (place=GAP, for two vessels in " \
                              "unrelated coordinates)"
    if st < 1.0 / max_stretch:
        raise ImplausibleJoinError(
            f"the target needs the free part of the vessel compressed to {st:.2f}x its length along the axis "
            f"(at most 1/max_stretch = {1.0 / max_stretch:.2f}); the wall would buckle: move the other vessel "
            f"farther away or hold more (hold=){place}"
        )
    if st > max_stretch:
        raise ImplausibleJoinError(
            f"the target needs the free part of the vessel stretched {st:.2f}x along its axis (max_stretch "
            f"{max_stretch:g}); move the other vessel closer, hold less (hold=) or raise max_stretch{place}"
        )
    kr, s = pl.max_bend
    if kr > tol.JOIN_MAX_BEND:
        raise ImplausibleJoinError(
            f"the target bends the vessel with curvature {kr:.2f}/r at s={s * gc.length:.3g} (radius "
            f"{float(gc.radius_at(s)[0]):.3g}): tighter than the radius allows, the wall would fold; "
            "choose a target that needs a gentler bend"
        )
    if st > tol.JOIN_STRETCH_WARN:
        log.warning("the join stretches the free part of the vessel %.2fx along its axis", st)


def _placed(V, ends, end, other, gap):
    """``V`` moved rigidly so that end ``end`` faces ``other`` on its axis, ``gap`` in front of it.

    The moving end's outward direction is turned by the least rotation onto minus the other end's
    (they face each other) and its centre moved to the other end's centre plus ``gap`` times the
    other end's outward direction (the centres on one line, the other end's axis).

    Returns
    -------
    V : (n, 3) float64
        The moved vertices (a new array).
    ends : tuple of VesselEnd
        The ends moved with them.
    M : (4, 4) float64
        The rigid move, ``[R t; 0 1]``: a point ``x`` goes to ``R x + t``.
    """
    gap = float(gap)
    if not (np.isfinite(gap) and gap >= 0.0):
        raise OptionError(f"place={gap!r} is not a gap between the two ends; give zero or more (mesh units)")
    e = ends[end]
    d_o = np.asarray(other.direction, float) / np.linalg.norm(other.direction)
    R = minimal_rotation(np.asarray(e.direction, float) / np.linalg.norm(e.direction), -d_o).as_matrix()
    t = np.asarray(other.center, float) + gap * d_o - R @ np.asarray(e.center, float)
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = R, t
    moved = tuple(replace(x, center=R @ x.center + t, direction=R @ x.direction) for x in ends)
    log.info("join_vessels: the moving vessel placed %.3g in front of the other end: its end moved %.3g, turned "
             "%.1f deg", gap, float(np.linalg.norm(moved[end].center - e.center)),
             float(np.degrees(Rotation.from_matrix(R).magnitude())))
    return V @ R.T + t, moved, M


def _cropped(gc, s0):
    """The cylinder ``gc`` from normalised arc length ``s0`` on, as a cylinder of its own (s from 0 to 1).

    A re-parameterisation: the same axis points, RMF (a rotation-minimizing frame restricted to a
    stretch of its curve is the RMF of that stretch started from its frame there), radii and vertex
    angles; vertices before ``s0`` get no parameter (NaN) and no weight.
    """
    i0 = int(np.searchsorted(gc.dense_s, s0, side="right")) - 1
    if i0 <= 0:
        return gc
    a = gc.dense_s[i0]
    span = 1.0 - a
    nodes = np.unique(np.concatenate([[a], gc.s[gc.s > a]]))
    centers, frames = gc.at(nodes)
    vs = np.where(gc.vertex_s >= a, (gc.vertex_s - a) / span, np.nan)
    on = np.isfinite(vs)
    return replace(gc, s=(nodes - a) / span, length=gc.length * span, centers=centers, radii=gc.radius_at(nodes),
                   frames=frames, vertex_s=vs, vertex_weight=np.where(on, gc.vertex_weight, 0.0),
                   vertex_area=np.where(on, gc.vertex_area, 0.0), dense_s=(gc.dense_s[i0:] - a) / span,
                   dense_points=gc.dense_points[i0:], dense_frames=gc.dense_frames[i0:])


class VesselJoin:
    """A join of two real vessels by end index, validated and set up: :meth:`solve` runs it.

    Construction does everything that can refuse the join (end indices,
    opening caps, the fit, the held part, the plausibility of the target), so
    a caller that writes files can build it first and write nothing when it
    raises. Parameters are those of :func:`join_vessels`.

    Attributes
    ----------
    problem : JoinProblem
        On the opened moving vessel (its fit, deformer, meter and anchor).
    V : (n', 3) float64
        The moving vessel with its joined end opened (rest).
    F : (m', 3) int64
    kept : (n',) int64
        Input vertex id of each row of ``V``.
    ends : tuple of VesselEnd
        Ends of the opened moving vessel; ``end`` indexes the joined one.
    end : int
    other_V : (n2', 3) float64
        The vessel joined to, with its end opened.
    other_F : (m2', 3) int64
    other_loop : (r,) int64
        Its end ring, in ``other_V``.
    other : VesselEnd
        Its opened end (centre and direction give the target).
    tree : VesselTree or None
        The moving vessel's tree fit when it has more than two ends.
    setup_time_s : float
        Seconds the set-up took (ends, opening, fit, factorisations).
    """

    def __init__(self, V, F=None, end=None, V_other=None, F_other=None, other_end=None, *, hold=None,
                 method="rod_arap", max_stretch=None, moving_normal=None, target_normal=None, place=None,
                 max_radius_ratio=None):
        t0 = time.perf_counter()
        (V, F), end, (V_other, F_other), other_end = mesh_arguments(
            (V, F, end, V_other, F_other, other_end), ("mesh", "end", "mesh", "end"), "join_vessels")
        V, F = as_mesh(V, F)
        Vo, Fo = as_mesh(V_other, F_other)
        max_stretch = tol.JOIN_MAX_STRETCH if max_stretch is None else float(max_stretch)
        if not max_stretch >= 1.0:
            raise ImplausibleJoinError(f"max_stretch must be at least 1 (no stretch), got {max_stretch!r}")
        max_ratio = tol.JOIN_MAX_RADIUS_RATIO if max_radius_ratio is None else float(max_radius_ratio)
        if not max_ratio >= 1.0:
            raise ImplausibleJoinError(f"max_radius_ratio must be at least 1 (equal radii), got {max_radius_ratio!r}")
        ends = vessel_ends(V, F)
        ends_o = vessel_ends(Vo, Fo)
        if len(ends) < 2:
            raise EndsError(f"the moving vessel has {len(ends)} end(s); a vessel to move needs one end to hold "
                            "and one to join (ends: " + end_listing(ends) + ")")
        _pick(ends, end, "end")
        _pick(ends_o, other_end, "other_end")
        self.placement = None  # the rigid move of the moving vessel (place=), (4, 4)
        if place is not None:
            V, ends, self.placement = _placed(V, ends, end, ends_o[other_end], place)
        W, G, kept, new_ends, j = _opened(V, F, ends, end, "end")
        Wo, Go, _, ends_o2, jo = _opened(Vo, Fo, ends_o, other_end, "other_end")
        e_move, e_other = new_ends[j], ends_o2[jo]
        _calibre(e_move, e_other, max_ratio)
        self.tree = None
        if len(new_ends) == 2:
            gc = fit_generalized_cylinder(W, G, ends=(new_ends[1 - j], e_move))
            fixed = _held(gc, hold, kept, len(V))
        else:
            gc, fixed = self._tree_path(W, G, new_ends, j, hold, kept, len(V))
        tangent = -np.asarray(e_other.direction, float)
        mn = default_normal(e_move.direction) if moving_normal is None else moving_normal
        # the target normal: the moving anchor carried by the least rotation onto the target tangent
        tn = (minimal_rotation(e_move.direction, tangent).apply(np.asarray(mn, float)) if target_normal is None
              else target_normal)
        self.problem = JoinProblem(W, G, fixed, np.asarray(e_move.loop, np.int64),
                                   Frame(e_other.center, tangent, tn), method=method, gc=gc, moving_normal=mn)
        _plausible(self.problem, max_stretch, place is not None)
        self.V, self.F, self.kept, self.ends, self.end = W, G, kept, tuple(new_ends), j
        self.other_V, self.other_F, self.other = Wo, Go, e_other
        self.other_loop = np.asarray(e_other.loop, np.int64)
        self.setup_time_s = time.perf_counter() - t0

    def _tree_path(self, W, G, ends, j, hold, kept, n_user):
        """A moving tree: the path from the widest other end (the root) to the moving end, and what is held.

        By default everything but the moving end's own branch is held, and that branch through its
        junction zone (the free part runs from there to the end); a fraction ``hold`` holds that much
        of the path next to the root plus every other branch.
        """
        root = max((i for i in range(len(ends)) if i != j), key=lambda i: ends[i].radius)
        self.tree = tree = fit_vessel_tree(W, G, root, ends=ends)
        k = next(i for i, p in enumerate(tree.paths) if p.ends[1] == j)
        gc = tree.paths[k]
        off = ~np.isfinite(gc.vertex_s)
        if hold is None:
            # held: every other branch, and the moving branch through its junction zone (there the wall
            # is the parent's flare, as wide as the parent); the free part is the branch's own tube
            b = tree.path_branches[k][-1]
            J = tree.junctions[int(np.flatnonzero(tree.junction_branch == tree.parent[b])[0])]
            sz = (gc.dense_s[int(np.argmin(np.linalg.norm(gc.dense_points - J, axis=1)))]
                  + tree.junction_zone[b] / gc.length)
            own = tree.vertex_branch == b
            fixed = np.flatnonzero(~own | (gc.vertex_s < sz))
            # the parent's wall wraps past the junction; its vertices project onto the branch's stretch
            beyond = fixed[~own[fixed] & (gc.vertex_s[fixed] > sz)]
            if len(beyond):
                vs = gc.vertex_s.copy()
                vs[beyond] = np.nan  # held, not on the free part
                gc = replace(gc, vertex_s=vs)
            # the torsion is measured from a branch radius before the free part on: upstream, through the
            # junction zones' turns, the deformed axis Eq. 6 recovers differs from the rest one by tenths of
            # a millimetre and its RMF by up to 26 degrees on held, unmoved wall (the 4D-flow arch)
            gc = _cropped(gc, max(sz - tol.JOIN_TREE_LEAD * tree.branches[b].mean_radius / gc.length, 0.0))
        else:
            fixed = np.union1d(_held(gc, hold, kept, n_user), np.flatnonzero(off))
        return gc, fixed

    def solve(self, **search):
        """The minimum-torsion join (:func:`vesselgp.minimize_torsion`), stitched into one mesh.

        Parameters
        ----------
        **search
            Options of :func:`vesselgp.minimize_torsion` (``xtol``, ``algorithm``, ...).

        Returns
        -------
        JoinResult
            See :func:`join_vessels`.
        """
        p = self.problem
        res = minimize_torsion(p, **search)
        Vj, Fj = stitch(res.V, self.F, p.moving, self.other_V, self.other_F, self.other_loop)
        top = MeshTopology(Fj, len(Vj))
        pieces = top.face_components[0]
        if pieces != 1 or not top.is_edge_manifold:
            raise InvalidMeshError(f"the joined mesh has {pieces} pieces and {len(top.nonmanifold_edges)} "
                                   "non-manifold edges; check both meshes with vesselgp clean")
        log.info("join_vessels: angle %.2f deg from the anchors, roll %.2f deg, axial stretch %.3f, edge "
                 "stretch %.3f", np.degrees(res.angle), np.degrees(res.roll), res.axial_stretch,
                 res.max_edge_stretch)
        return replace(res, joined_V=Vj, joined_F=Fj, seam=p.moving.copy(), kept=self.kept, placement=self.placement)


def join_vessels(V, F=None, end=None, V_other=None, F_other=None, other_end=None, *, hold=None,
                 method="rod_arap", max_stretch=None, moving_normal=None, target_normal=None, place=None,
                 max_radius_ratio=None):
    """Join end ``end`` of one vessel onto end ``other_end`` of another with the least torsion.

    Each vessel is its arrays ``V, F`` or one mesh object (``trimesh.Trimesh``,
    ``pyvista.PolyData``, ``meshio.Mesh``, :class:`vesselgp.PreparedMesh`;
    :func:`vesselgp.as_mesh`): ``join_vessels(mesh, 1, other_mesh, 0)`` reads as
    ``join_vessels(V, F, 1, V_other, F_other, 0)``.

    Parameters
    ----------
    V : (n, 3) float64, or a mesh object
        The vessel that is deformed: a tube with two ends, or a tree (then the
        path from its widest other end to ``end`` is fitted and, by default,
        everything but the moving end's own branch past its junction zone is held).
    F : (m, 3) int64
    end : int
        Index into ``vessel_ends(V, F)`` of the end that moves; the other end is held.
    V_other : (n2, 3) float64, or a mesh object
        The vessel joined to (it does not move; it may be a tree).
    F_other : (m2, 3) int64
    other_end : int
        Index into ``vessel_ends(V_other, F_other)`` of the end joined to.
    hold : None, float or (p,) int, optional
        What stays in place: None for the default fraction
        ``tolerances.JOIN_HOLD_FRACTION`` of the axis next to the other end (a
        tree: every branch but the moving one), a fraction in (0, 1) of the
        axis (a tree: of the path, plus every other branch), or vertex ids of ``V``.
    method : str
        Deformation method (:class:`vesselgp.JoinProblem`).
    max_stretch : float, optional
        Largest axial stretch of the free part accepted (default
        ``tolerances.JOIN_MAX_STRETCH``).
    moving_normal : (3,) float64, optional
        Anchor across the moving end (default :func:`default_normal` of its direction).
    target_normal : (3,) float64, optional
        Where it lands at angle 0 (default: ``moving_normal`` turned by the least rotation
        from the moving end's direction onto the target tangent).
    place : float, optional
        Move the moving vessel rigidly first, so that its joined end faces the other end on the
        other end's axis, this gap (mesh units, >= 0) in front of it: for two vessels in unrelated
        coordinates (two scans). The moving end's direction is turned by the least rotation onto
        minus the other end's. Default: no move (the vessels stay where they are).
    max_radius_ratio : float, optional
        Largest ratio of the two ends' radii joined (default ``tolerances.JOIN_MAX_RADIUS_RATIO``,
        1.5): the rims are stitched as they are, so unlike calibres leave a step in the wall.

    See Also
    --------
    VesselJoin : the same, set up and validated first (for callers that write files).

    Returns
    -------
    JoinResult
        With ``V``/``F`` the deformed (opened) moving vessel, ``kept`` the
        original id of each of its vertices, ``fixed``/``moving`` the held ids
        and the joined ring in it, ``joined_V``/``joined_F`` the stitched mesh
        (moving vessel first) and ``seam`` the ring where they meet. ``angle``
        is measured from the anchors; ``roll`` from the twist-free placement.
        ``placement`` is the (4, 4) rigid move made by ``place`` (None without it); ``V`` and
        ``joined_V`` are in the moved position.

    Raises
    ------
    EndsError
        Bad end indices or a bad ``hold``.
    OptionError
        A negative or non-finite ``place``.
    ImplausibleJoinError
        The ends' radii differ by more than ``max_radius_ratio``, or the target needs too much
        stretch or compression, or too tight a bend.
    InvalidMeshError
        The stitched mesh is not one connected piece.

    Examples
    --------
    >>> from vesselgp.synthetic import paper_case
    >>> c = paper_case(1, resolution=0.25)
    >>> r = join_vessels(c.V, c.F, 1, c.other_V, c.other_F, 0)
    >>> bool(abs(np.degrees(r.profile.total_twist)) < 1.0), len(MeshTopology.from_faces(r.joined_F).boundary_loops)
    (True, 2)
    """
    return VesselJoin(V, F, end, V_other, F_other, other_end, hold=hold, method=method,
                      max_stretch=max_stretch, moving_normal=moving_normal,
                      target_normal=target_normal, place=place, max_radius_ratio=max_radius_ratio).solve()
