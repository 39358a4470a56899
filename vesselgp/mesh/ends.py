"""Where a vessel ends: :func:`vessel_ends`, :class:`VesselEnd`, :func:`select_ends`.

An end is an open boundary loop, a flat cap of a closed part of the surface,
or a rounded (hemispherical) tip; a vessel tree has one per branch end, and
:func:`select_ends` picks the two ends of the vessel's path among them. One
:class:`~.topology.MeshTopology` of the mesh serves the surface check, the
boundary loops, the cap patches and the geodesic search for tips; the caps
live in :mod:`._ends_caps`, the tips in :mod:`._ends_tips` and the voxel
staircase check in :mod:`._ends_staircase`.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace
from functools import cmp_to_key
from typing import NamedTuple

import igl
import numpy as np

from .. import tolerances as tol
from .._validate import as_mesh
from ..errors import EndsError, InvalidMeshError, NotTubularError
from ._ends_caps import find_caps
from ._ends_format import bbox_diagonal, end_listing, format_point
from ._ends_staircase import check_staircase
from ._ends_tips import extreme_tips, find_tips, own_tube
from ._geometry import loop_centroid, vector_area
from .orient import orient_faces
from .seams import refuse_seams
from .topology import MeshTopology

__all__ = ["vessel_ends", "VesselEnd", "FlatPatch", "select_ends"]

log = logging.getLogger(__name__)



_KIND_RANK = {"open": 0, "cap": 1, "rounded": 2}


@dataclass(frozen=True)
class VesselEnd:
    """One end of a vessel.

    Attributes
    ----------
    kind : str
        "open" (a boundary loop), "cap" (a flat cap of a closed surface) or
        "rounded" (a closed, uncapped, dome-shaped tip).
    loop : (k,) int64
        Ordered rim vertices: the boundary loop, the cap's rim, or for a
        rounded end the ring of vertices where the dome meets the tube. Ordered
        counter-clockwise seen from outside (right-handed about ``direction``).
    vertices : (j,) int64
        Vertices of the end region: the loop (open), every cap vertex (cap), or
        the vertices within half a radius (geodesic) of the tip (rounded).
    center : (3,) float64
        Centre of the end's cross-section (for a rounded end, the centre of
        its dome: where the dome meets the tube's axis).
    direction : (3,) float64
        Unit axis direction pointing out of the vessel.
    radius : float
        Mean distance of the loop vertices to ``center`` (open, cap); the
        radius of the tube meeting the dome (rounded).
    faces : (c,) int64 or None
        Cap faces (caps only).
    scale : float or None
        Size of the mesh (its bounding-box diagonal), which sets the digits
        :meth:`describe` prints; None to judge from the end alone.
    """

    kind: str
    loop: np.ndarray = field(repr=False)
    vertices: np.ndarray = field(repr=False)
    center: np.ndarray
    direction: np.ndarray
    radius: float
    faces: np.ndarray | None = field(default=None, repr=False)
    scale: float | None = field(default=None, repr=False, compare=False)

    def describe(self):
        """Short text such as ``'open r=7.69 at (220.98, 177.78, 20.99)'``.

        The centre resolves ``tolerances.PRINT_RESOLUTION`` of the mesh's
        size (:attr:`scale`; without it, of the end's distance from the origin
        plus ten radii).
        """
        scale = self.scale
        if scale is None or not scale > 0:
            scale = float(np.linalg.norm(self.center)) + 10.0 * float(self.radius)
        return f"{self.kind} r={self.radius:.3g} at {format_point(self.center, scale)}"


class FlatPatch(NamedTuple):
    """A flat disk the wall meets round most of its rim that :func:`vessel_ends` did not take for a cap.

    Attributes
    ----------
    end : VesselEnd
        The cap it would be (kind ``"cap"``: its rim, faces, centre, outward direction, radius).
    reason : str
        Why it is not a cap.
    walled : bool
        Whether only the body behind it failed the cap test (it widens or bulges there: a vessel cut next to a
        junction): the wall meets its whole rim (``tolerances.CAP_RIM_WALLED_FRACTION`` of it) and it is no facet
        (``CAP_SUSPECT_FACES`` faces or more).
    """

    end: VesselEnd
    reason: str
    walled: bool = False


def vessel_ends(V, F=None, *, topology=None):
    """Find every end of a vessel or vessel tree, and nothing else.

    Three kinds of ends are found, all of them on every mesh:

    * open ends: the boundary loops (:attr:`MeshTopology.boundary_loops`);
    * flat caps of any size, down to an outlet one or two edges across:
      flat disks of faces bounded by sharp edges (dihedral angle above
      ``tolerances.SHARP_EDGE_ANGLE``) that close the tube, i.e. the wall
      meets the rim all round from behind and the rim is the whole
      cross-section (see :mod:`vesselgp.mesh._ends_caps`);
    * rounded tips: maxima of the geodesic distance from the other ends
      (edge-graph Dijkstra; on a closed surface without caps, from an
      extremity found by a double sweep) around which the geodesic rings close
      in like a hemisphere's on a tube (see :mod:`vesselgp.mesh._ends_tips`);
      a junction's saddle or the ridge in the middle of a tube is not one.

    A raw voxel surface (voxel faces or unsmoothed marching cubes of a mask),
    whose terraces would look like caps, is refused first.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions (a clean mesh; see :func:`clean_mesh`), or a mesh object (``trimesh.Trimesh``, ``pyvista.PolyData``, ``meshio.Mesh``: :func:`vesselgp.as_mesh`).
    F : (m, 3) int64
        Triangles (left out with a mesh object).
    topology : MeshTopology, optional
        The topology of ``F`` with ``len(V)`` vertices, when the caller has
        it already (otherwise it is built here).

    Returns
    -------
    ends : tuple of VesselEnd
        Sorted by radius, largest first; ties (within
        ``tolerances.ENDS_TIE_RTOL``) by kind, then loop size. The order does
        not depend on vertex numbering or on rigid motions.

    Raises
    ------
    EndsError
        The mesh is a raw voxel staircase: at least
        ``tolerances.STAIRCASE_AREA_FRACTION`` of its area faces a coordinate
        axis, in at least ``tolerances.STAIRCASE_MIN_TERRACES`` terraces;
        smooth it first (``vesselgp.clean_mesh(V, F, smooth=N)``).
    NotTubularError
        No two ends (a sphere, a torus, a closed blob).
    InvalidMeshError
        ``topology`` does not describe ``F``, or defects that
        :func:`clean_mesh` repairs and that would make boundary
        loops meaningless: faces with a repeated vertex index, non-manifold
        edges, inconsistently oriented faces, open seams of duplicate vertices.

    Examples
    --------
    An open cylinder of radius 1 along z from 0 to 5:

    >>> t = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    >>> z = np.linspace(0, 5, 11)
    >>> V = np.c_[np.tile(np.cos(t), 11), np.tile(np.sin(t), 11), np.repeat(z, 24)]
    >>> a = np.arange(24); q = [[i * 24 + a, i * 24 + (a + 1) % 24] for i in range(10)]
    >>> F = np.vstack([np.r_[np.c_[r0, r1, r0 + 24], np.c_[r1, r1 + 24, r0 + 24]] for r0, r1 in q])
    >>> ends = vessel_ends(V, F)
    >>> [e.kind for e in ends], round(ends[0].radius, 3)
    (['open', 'open'], 1.0)
    >>> np.round(sorted(e.direction[2] for e in ends), 6).tolist()
    [-1.0, 1.0]
    """
    V, F = as_mesh(V, F)
    F, topo = orient_faces(V, F, _topology_of(F, len(V), topology))
    return found_ends(V, F, topo)


def found_ends(V, F, topo, sacs=None, flat_patches=None):
    """:func:`vessel_ends` of a mesh already validated and oriented (``topo`` of ``F``), not checked again.

    For :class:`vesselgp.PreparedMesh`, which validates its arrays and orients its faces once. The
    blind sacs found on the way (domes that are not ends, :func:`_without_sacs`) are appended to the
    list ``sacs`` when one is given, each as ``(center (3,), outward direction (3,), radius)``; the
    flat disks met round their rims by the wall that are not caps (:func:`._ends_caps.find_caps`,
    logged), to ``flat_patches``, each as a :class:`FlatPatch`.
    """
    N, A = _face_normals(V, F)
    w = topo.edge_lengths(V)
    h = float(np.median(w)) if len(w) else 0.0
    check_staircase(V, F, N, A, h)
    _check_surface(V, F, topo, h)
    scale = bbox_diagonal(V if topo.referenced.all() else V[topo.referenced])
    graph = _Lazy(lambda: topo.edge_matrix(w))
    body = _Nearby(V)
    ends = _open_ends(V, topo, scale, body)
    caps, refused = find_caps(V, F, topo, N, A, graph)
    for fids, loop, center, n in caps:
        ends.append(_make_end(body, "cap", loop, np.unique(F[fids]), center, n, scale, faces=fids))
    ends += _rounded_ends(V, topo, (N, A), ends, graph, h, scale, body, [] if sacs is None else sacs)
    narrowest = min(e.radius for e in ends)
    for fids, loop, center, n, why, walled in refused:
        patch = _make_end(body, "cap", loop, np.unique(F[fids]), center, n, scale, faces=fids)
        if patch.radius < tol.CAP_SUSPECT_RADIUS * narrowest:
            continue  # a facet, a terrace: smaller than any vessel here
        log.info("a flat patch of %d faces (radius %.3g) at %s is not a cap: %s", len(fids), patch.radius,
                 format_point(center, scale), why)
        if flat_patches is not None:
            flat_patches.append(FlatPatch(patch, why, walled))
    ends.sort(key=cmp_to_key(_compare_ends))
    log.info("found %d vessel ends: %s", len(ends), end_listing(ends))
    return tuple(ends)


class _Lazy:
    """A value computed by ``fn()`` on the first call, then kept (callable)."""

    def __init__(self, fn):
        self._fn, self._value, self._done = fn, None, False

    def __call__(self):
        if not self._done:
            self._value, self._done = self._fn(), True
        return self._value


def _face_normals(V, F):
    """Unit face normals (m, 3) float64 (zero rows for zero-area faces) and twice the areas (m,).

    libigl's ``per_face_normals`` (the given zero row where a face has no normal) and
    ``doublearea``: the same cross products as numpy, a quarter of its time.
    """
    return igl.per_face_normals(V, F, np.zeros(3)), igl.doublearea(V, F)


class _Nearby:
    """Vertices within a distance of a point (callable).

    The first few queries scan every vertex; later ones (a tree's many ends)
    use one sort of the x coordinates and scan only the slab about the point.
    """

    _SCANS = 3

    def __init__(self, V):
        self.V = V
        self._calls = 0
        self._order = self._x = None

    def __call__(self, c, r):
        """Ids (k,) int64 of the vertices closer than ``r`` to ``c`` (3,), ascending."""
        self._calls += 1
        if self._calls <= self._SCANS:
            D = self.V - c
            return np.flatnonzero(np.einsum("ij,ij->i", D, D) < r * r)
        if self._order is None:
            self._order = np.argsort(self.V[:, 0], kind="stable")
            self._x = self.V[self._order, 0]
        lo, hi = np.searchsorted(self._x, [c[0] - r, c[0] + r])
        idx = self._order[lo:hi]
        D = self.V[idx] - c
        return np.sort(idx[np.einsum("ij,ij->i", D, D) < r * r])


def _topology_of(F, n, topology):
    """``topology`` after checking that it describes ``F`` with ``n`` vertices, or a new one."""
    if topology is None:
        return MeshTopology(F, n)
    if not isinstance(topology, MeshTopology):
        raise InvalidMeshError(f"topology must be a MeshTopology, got {type(topology).__name__}")
    if topology.n_vertices != n or not np.array_equal(topology.F, F):
        raise InvalidMeshError(
            f"topology describes another mesh ({topology.n_vertices} vertices, {topology.n_faces} faces) "
            f"than V, F ({n} vertices, {len(F)} faces); build it with mesh_topology(F, len(V))"
        )
    return topology


def _check_surface(V, F, topo, h):
    """Raise :class:`InvalidMeshError` on defects that make boundary loops meaningless.

    Each defect is one that :func:`clean_mesh` repairs, and the message says so:
    faces with a repeated vertex index, non-manifold edges, inconsistently
    oriented faces (their shared edges would look like boundary loops), and
    open seams of duplicate vertices (a seam looks like two vessel ends; the message of
    :func:`.seams.refuse_seams`, given by every refusal of a seam). ``h`` is the median of
    ``topo.edge_lengths(V)``.
    """
    rep = int(np.count_nonzero((F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 2] == F[:, 0])))
    if rep:
        raise InvalidMeshError(
            f"mesh has {rep} faces with a repeated vertex index (zero area); "
            "run vesselgp.clean_mesh to remove them"
        )
    nm = len(topo.nonmanifold_edges)
    if nm:
        raise InvalidMeshError(
            f"mesh has {nm} non-manifold edges (shared by more than two faces); "
            "run vesselgp.clean_mesh to repair them"
        )
    bad = len(topo.incoherent_edges)
    if bad:
        raise InvalidMeshError(
            f"mesh faces are not consistently oriented ({bad} edges are used twice in the same "
            "direction); run vesselgp.clean_mesh to orient them"
        )
    refuse_seams(V, topo, h)  # a seam looks like two vessel ends (a split bow-tie vertex alone is none)


def _make_end(nearby, kind, loop, region, center, normal, scale, faces=None):
    """Orient ``normal`` away from the nearby vessel body and build the end.

    The body is the centroid of the vertices within ``tolerances.ENDS_BODY_RADII``
    end radii of ``center`` outside ``region`` (of every other vertex if none is
    that close); ``nearby`` is the :class:`_Nearby` of the vertices.
    """
    V = nearby.V
    loop = np.array(loop, dtype=np.int64)  # a copy: never a view of a cached topology table
    radius = float(np.linalg.norm(V[loop] - center, axis=1).mean())
    n = normal / np.linalg.norm(normal)
    region = np.unique(np.asarray(region, dtype=np.int64))
    near = nearby(center, tol.ENDS_BODY_RADII * radius)
    near = near[~np.isin(near, region, assume_unique=True)]
    if len(near) or len(region) < len(V):  # (a bare loop has no body to point away from)
        if len(near):
            body = V[near].mean(0)
        else:
            mask = np.ones(len(V), dtype=bool)
            mask[region] = False
            body = V[mask].mean(0)
        if n @ (center - body) < 0:
            n = -n
    if len(loop) >= 3 and vector_area(V[loop]) @ n < 0:
        loop = loop[::-1].copy()
    return VesselEnd(kind, loop, region, np.asarray(center, dtype=np.float64), n, radius,
                     None if faces is None else np.asarray(faces, dtype=np.int64), scale)


def _open_ends(V, topo, scale, nearby):
    """One open end per boundary loop of three or more vertices."""
    ends = []
    for loop in topo.boundary_loops:
        if len(loop) < 3:
            continue
        P = V[loop]
        a = vector_area(P)
        per = float(np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1).sum())
        if not np.linalg.norm(a) > tol.DEGENERATE_AREA * per**2:
            raise InvalidMeshError(
                f"boundary loop of {len(loop)} vertices at {format_point(P.mean(0), scale)} encloses no area (its vertices "
                "coincide or are collinear); run vesselgp.clean_mesh or repair the mesh there"
            )
        ends.append(_make_end(nearby, "open", loop, loop, loop_centroid(P), a, scale))
    return ends


def _compare_ends(a, b):
    """Order of two ends: larger radius first; ties by kind, loop size, region size, centre."""
    scale = max(a.radius, b.radius)
    if abs(a.radius - b.radius) > tol.ENDS_TIE_RTOL * scale:
        return -1 if a.radius > b.radius else 1
    ka = (_KIND_RANK[a.kind], -len(a.loop), -len(a.vertices), *a.center.tolist())
    kb = (_KIND_RANK[b.kind], -len(b.loop), -len(b.vertices), *b.center.tolist())
    return int(ka > kb) - int(ka < kb)


def _without_sacs(tips, ends, sacs, V, G, h):
    """The rounded tips that are vessel ends: not a dome wider than every open or capped end on no tube of its own.

    On a mesh whose vessels were cut open (or capped flat) at their ends, a closed rounded dome
    wider than ``tolerances.ENDS_SAC_RATIO`` times the widest of those ends is a blind sac (an
    aneurysm on a side wall or at a bifurcation, whose dome and neck can pass the hemisphere
    test), not a vessel's end (issue #34: "a blind sac is not an end") -- unless the dome closes a
    tube of its own, at least ``ENDS_SAC_TUBE_RADII`` of its radii long (:func:`._ends_tips.own_tube`):
    then a vessel ends there, wider than the cut ends (a carotid's internal carotid wider than the
    common carotid, an aortic root closed at its valve; issue #44: the wider daughter of a Y was taken
    for a sac and its vessel left without an axis). A sac is logged and left to the fit, whose path
    passes it, and appended to ``sacs`` as ``(center, direction, radius)``. A closed mesh's domes (no
    cut end to compare with) and a mesh left with fewer than two ends keep them all.

    A dome on no round tube (a record with ``tube`` False, :func:`._ends_tips._dome_only`: an oval
    or lobed body behind a hemispherical dome) is never an end: wider than ``ENDS_SAC_RATIO`` times
    the widest cut end it is a sac, otherwise it is left out.
    """
    domes = [t for t in tips if not t["tube"]]
    tips = [t for t in tips if t["tube"]]
    if not ends:
        return tips
    widest = max(e.radius for e in ends)
    for t in domes:
        where = f"a rounded dome of radius {t['radius']:.4g} at {np.round(t['center'], 3).tolist()}"
        if t["radius"] > tol.ENDS_SAC_RATIO * widest:
            log.info("%s on a body that is no round tube is wider than every open or capped end (the widest %.4g): "
                     "a blind sac", where, widest)
            sacs.append((np.asarray(t["center"], np.float64), np.asarray(t["direction"], np.float64),
                         float(t["radius"])))
        else:
            log.debug("%s on a body that is no round tube is no wider than the cut ends: not an end", where)
    if not tips:
        return tips
    wide = [t["radius"] > tol.ENDS_SAC_RATIO * widest for t in tips]
    tube = [own_tube(V, G, t, h) if w else np.inf for t, w in zip(tips, wide)]
    sac = [w and L < tol.ENDS_SAC_TUBE_RADII for w, L in zip(wide, tube)]
    keep = [t for t, s in zip(tips, sac) if not s]
    if len(ends) + len(keep) < 2:
        return tips
    for t, w, L, s in zip(tips, wide, tube, sac):
        where = f"a rounded dome of radius {t['radius']:.4g} at {np.round(t['center'], 3).tolist()}"
        if s:
            log.info("%s is wider than every open or capped end (the widest %.4g) and goes on as a tube of its own "
                     "for %.2g radii only: a blind sac, not a vessel end", where, widest, L)
            sacs.append((np.asarray(t["center"], np.float64), np.asarray(t["direction"], np.float64),
                         float(t["radius"])))
        elif w:
            log.info("%s is wider than every open or capped end (the widest %.4g) but closes a tube of its own "
                     "(%.2g radii or more): a vessel end", where, widest, L)
    return keep


def _rounded_ends(V, topo, normals, ends, graph, h, scale, nearby, sacs):
    """Rounded tips (see :func:`._ends_tips.find_tips`) as :class:`VesselEnd` s.

    Raises :class:`NotTubularError` when there are fewer than two ends in all,
    or two ends of which one is rounded that are closer than
    ``tolerances.MIN_ASPECT`` mean diameters (a closed blob).
    """
    used = topo.referenced
    if not ends:
        if not topo.is_closed:
            raise NotTubularError(
                "mesh is not tubular: no two ends found (no open loop, flat cap or closed "
                "tube); check the mesh with clean_mesh"
            )
        chi = topo.euler_characteristic
        ncomp = topo.vertex_components[0] - (len(V) - int(np.count_nonzero(used)))
        if chi != 2 * ncomp:
            raise NotTubularError(
                f"mesh is not tubular: no two ends found; it is a closed surface with Euler "
                f"characteristic {chi} (genus > 0, e.g. a torus); pass a tube with open or capped ends"
            )
    if not h > 0:
        if len(ends) >= 2:
            return []
        raise NotTubularError(
            "mesh is not tubular: no two ends found (most edges have zero length); run vesselgp.clean_mesh"
        )
    sources = np.unique(np.concatenate([e.vertices for e in ends])) if ends else np.zeros(0, np.int64)
    tips = _without_sacs(find_tips(V, topo.F, *normals, graph(), topo.edges, h, sources, used), ends, sacs, V,
                         graph(), h)
    if len(ends) + len(tips) < 2:
        more = [t["region"] for t in tips]
        src = np.unique(np.concatenate([sources, *more])) if more else sources
        extra = extreme_tips(V, graph(), h, src, used)
        log.warning("fewer than two vessel ends recognised; taking %d extreme(s) of the surface as "
                    "rounded ends", len(extra))
        tips = tips + extra
    found = [_make_end(nearby, "rounded", _ordered_ring(V, t), t["region"], t["center"], t["direction"], scale)
             for t in tips]
    found = [replace(e, radius=float(t["radius"])) for e, t in zip(found, tips)]
    total = len(ends) + len(found)
    if total < 2:
        what = "no tube at the extremes" if not ends else "one end only"
        raise NotTubularError(f"mesh is not tubular: no two ends found ({what}); pass a tube with two ends")
    if total == 2 and found:
        a, b = (ends + found)
        length = float(np.linalg.norm(a.center - b.center))
        diam = a.radius + b.radius
        if length < tol.MIN_ASPECT * diam:
            raise NotTubularError(
                f"mesh is not tubular: no two ends found; its extremes are {length:.3g} apart, less "
                f"than {tol.MIN_ASPECT:g} mean diameter ({diam:.3g}) (a closed blob such as a sphere)"
            )
    return found


def _ordered_ring(V, t):
    """The tip's ring ordered by angle about its axis (counter-clockwise seen from outside)."""
    ring, c, n = t["ring"], t["center"], t["direction"]
    u = V[ring] - c
    u -= np.outer(u @ n, n)
    e1 = u[np.argmax(np.linalg.norm(u, axis=1))]
    if not np.linalg.norm(e1) > 0:
        return ring
    e1 = e1 / np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    return ring[np.argsort(np.arctan2(u @ e2, u @ e1), kind="stable")]


def select_ends(ends, ends_arg=None):
    """Choose the two ends of the vessel's path.

    Parameters
    ----------
    ends : sequence of VesselEnd
        From :func:`vessel_ends`.
    ends_arg : None or (int, int)
        The user's choice. ``None`` is allowed only when there are exactly two
        ends.

    Returns
    -------
    (VesselEnd, VesselEnd)
        The chosen ends, in the order given.

    Raises
    ------
    EndsError
        More than two ends and no choice, fewer than two ends, indices out of
        range, or twice the same end.

    Examples
    --------
    >>> e = [VesselEnd("open", np.arange(3), np.arange(3), np.zeros(3), np.r_[0, 0, 1.0], r)
    ...      for r in (2.0, 1.0, 1.5)]
    >>> select_ends(e, (2, 0))[0].radius
    1.5
    >>> select_ends(e)
    Traceback (most recent call last):
    ...
    vesselgp.errors.EndsError: mesh has 3 open ends; pass ends=(i, j) to choose the vessel's path ...
    """
    ends = tuple(ends)
    k = len(ends)
    listing = end_listing(ends)
    kinds = {e.kind for e in ends}
    what = f"{k} {next(iter(kinds))} ends" if len(kinds) == 1 else f"{k} ends"
    if k < 2:
        raise EndsError(f"mesh has {k} end(s); a vessel needs two (ends: {listing})")
    if ends_arg is None:
        if k == 2:
            return ends[0], ends[1]
        r2 = sorted((e.radius for e in ends), reverse=True)[1]
        small = sum(e.radius < tol.ENDS_HOLE_RADIUS_FRACTION * r2 for e in ends)
        holes = (
            f"; {small} of them are less than half as wide as the second-widest end: if they are "
            "holes, close them first (e.g. pymeshlab's meshing_close_holes)"
            if small else ""
        )
        raise EndsError(
            f"mesh has {what}; pass ends=(i, j) to choose the vessel's path{holes} (ends: {listing})"
        )
    try:
        i, j = ends_arg
    except (TypeError, ValueError):
        raise EndsError(f"ends must be a pair of indices (i, j), got {ends_arg!r}") from None
    for x in (i, j):
        if isinstance(x, bool) or not isinstance(x, (int, np.integer)) or not 0 <= x < k:
            raise EndsError(
                f"ends=({i!r}, {j!r}) is invalid: indices must be integers in 0..{k - 1} "
                f"(ends: {listing})"
            )
    if i == j:
        raise EndsError(f"ends=({i}, {j}) names the same end twice; choose two different ends")
    return ends[int(i)], ends[int(j)]
