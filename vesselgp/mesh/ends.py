"""Where a vessel ends: :func:`vessel_ends`, :class:`VesselEnd`, :func:`select_ends`.

An end is an open boundary loop, a flat cap of a closed surface, or a rounded
(closed, uncapped) extremity; :func:`select_ends` picks the two ends of the
vessel's path among them. One :class:`~.topology.MeshTopology` of the mesh
serves the surface check, the boundary loops, the cap patches and the
geodesic sweep of rounded ends.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from functools import cmp_to_key

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, dijkstra

from .. import tolerances as tol
from .._arrays import unique_rows
from .._validate import as_mesh
from ..errors import EndsError, InvalidMeshError, NotTubularError
from ._geometry import face_vectors, loop_centroid, median_edge, vector_area
from .topology import MeshTopology

__all__ = ["vessel_ends", "VesselEnd", "select_ends"]

log = logging.getLogger(__name__)



_KIND_RANK = {"open": 0, "cap": 1, "rounded": 2}


@dataclass(frozen=True)
class VesselEnd:
    """One end of a vessel.

    Attributes
    ----------
    kind : str
        "open" (a boundary loop), "cap" (a flat cap of a closed surface) or
        "rounded" (a closed, uncapped extremity).
    loop : (k,) int64
        Ordered rim vertices: the boundary loop, the cap's rim, or for a
        rounded end the ring of vertices where the end meets the tube. Ordered
        counter-clockwise seen from outside (right-handed about ``direction``).
    vertices : (j,) int64
        Vertices of the end region: the loop (open), every cap vertex (cap), or
        the vertices within half a radius (geodesic) of the tip (rounded).
    center : (3,) float64
        Centre of the end's cross-section.
    direction : (3,) float64
        Unit axis direction pointing out of the vessel.
    radius : float
        Mean distance of the loop vertices to ``center``.
    faces : (c,) int64 or None
        Cap faces (caps only).
    """

    kind: str
    loop: np.ndarray = field(repr=False)
    vertices: np.ndarray = field(repr=False)
    center: np.ndarray
    direction: np.ndarray
    radius: float
    faces: np.ndarray | None = field(default=None, repr=False)

    def describe(self):
        """Short text such as ``'open r=7.7 at (221.0, 177.8, 21.0)'``."""
        c = ", ".join(f"{x:.1f}" for x in self.center)
        return f"{self.kind} r={self.radius:.3g} at ({c})"


def vessel_ends(V, F, *, topology=None):
    """Find the ends of a vessel mesh.

    Open ends are boundary loops (:attr:`MeshTopology.boundary_loops`). If fewer
    than two are found, flat caps are looked for: patches of faces not
    separated by sharp edges (normals differing by more than
    ``tolerances.SHARP_EDGE_ANGLE``) that are planar within
    ``tolerances.CAP_FLATNESS``, disk-shaped and at least
    ``tolerances.CAP_MIN_RADIUS_EDGES`` edges in radius. If still fewer than
    two, rounded ends are found as the extremes of a double sweep of geodesic
    (edge-graph Dijkstra) distance; the end's cross-section is the ring of
    vertices where a hemisphere would meet its tube (ring radius = 2/pi times
    the geodesic distance to the tip).

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions (a clean mesh; see :func:`clean_mesh`).
    F : (m, 3) int64
        Triangles.
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
    topo = _topology_of(F, len(V), topology)
    _check_surface(V, F, topo)
    ends = _open_ends(V, topo)
    if len(ends) < 2:
        for fids, loop, center, n in _find_caps(V, F, topo):
            ends.append(_make_end(V, "cap", loop, np.unique(F[fids]), center, n, faces=fids))
    if len(ends) < 2:
        ends = _rounded_ends(V, F, topo, ends)
    ends.sort(key=cmp_to_key(_compare_ends))
    log.info("found %d vessel ends: %s", len(ends), "; ".join(e.describe() for e in ends))
    return tuple(ends)


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


def _check_surface(V, F, topo):
    """Raise :class:`InvalidMeshError` on defects that make boundary loops meaningless.

    Each defect is one that :func:`clean_mesh` repairs, and the message says so:
    faces with a repeated vertex index, non-manifold edges, inconsistently
    oriented faces (their shared edges would look like boundary loops), and
    open seams of duplicate vertices (a seam looks like two vessel ends).
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
    B = topo.edges[topo.boundary_edges]
    if len(B):
        # an open seam: boundary edges lying on top of other boundary edges (a
        # split bow-tie vertex alone, as clean_mesh leaves it, is not one)
        bv = np.unique(B)  # only boundary vertices can form a seam
        _, posb = np.unique(V[bv] + 0.0, axis=0, return_inverse=True)
        pos = np.zeros(len(V), np.int64)
        pos[bv] = posb.reshape(-1)
        _, bc = unique_rows(np.sort(pos[B], axis=1), return_counts=True)
        dup = int(np.count_nonzero(bc > 1))
        if dup:
            raise InvalidMeshError(
                f"mesh has open seams of duplicate vertices ({dup} boundary edges lie on other "
                "boundary edges); run vesselgp.clean_mesh to merge the duplicates"
            )


def _make_end(V, kind, loop, region, center, normal, faces=None):
    """Orient ``normal`` away from the nearby vessel body and build the end."""
    loop = np.array(loop, dtype=np.int64)  # a copy: never a view of a cached topology table
    radius = float(np.linalg.norm(V[loop] - center, axis=1).mean())
    n = normal / np.linalg.norm(normal)
    mask = np.ones(len(V), dtype=bool)
    mask[region] = False
    d = np.linalg.norm(V - center, axis=1)
    near = mask & (d < tol.ENDS_BODY_RADII * radius)
    if near.any() or mask.any():  # (a bare loop has no body to point away from)
        body = V[near].mean(0) if near.any() else V[mask].mean(0)
        if n @ (center - body) < 0:
            n = -n
    if len(loop) >= 3 and vector_area(V[loop]) @ n < 0:
        loop = loop[::-1].copy()
    return VesselEnd(kind, loop, np.unique(np.asarray(region, dtype=np.int64)),
                     np.asarray(center, dtype=np.float64), n, radius,
                     None if faces is None else np.asarray(faces, dtype=np.int64))


def _open_ends(V, topo):
    """One open end per boundary loop of three or more vertices."""
    ends = []
    for loop in topo.boundary_loops:
        if len(loop) < 3:
            continue
        P = V[loop]
        a = vector_area(P)
        per = float(np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1).sum())
        if not np.linalg.norm(a) > tol.DEGENERATE_AREA * per**2:
            c = ", ".join(f"{x:.3g}" for x in P.mean(0))
            raise InvalidMeshError(
                f"boundary loop of {len(loop)} vertices at ({c}) encloses no area (its vertices "
                "coincide or are collinear); run vesselgp.clean_mesh or repair the mesh there"
            )
        ends.append(_make_end(V, "open", loop, loop, loop_centroid(P), a))
    return ends


def _smooth_patches(V, F, topo):
    """Faces grouped into patches not separated by sharp edges.

    Returns
    -------
    patches : list of (k,) int64
        Face ids of each patch of at least ``tolerances.CAP_MIN_FACES`` faces.
    N : (m, 3) float64
        Unit face normals (zero for zero-area faces).
    A : (m,) float64
        Twice the face areas.
    """
    N = face_vectors(V, F)
    A = np.linalg.norm(N, axis=1)
    N = np.divide(N, A[:, None], out=np.zeros_like(N), where=A[:, None] > 0)
    f, g = topo.edge_faces[topo.edge_face_count == 2].T
    cosang = np.abs(np.einsum("ij,ij->i", N[f], N[g]))  # orientation-free
    smooth = cosang > np.cos(tol.SHARP_EDGE_ANGLE)
    m = len(F)
    G = sp.coo_array((np.ones(int(smooth.sum()), dtype=np.int8), (f[smooth], g[smooth])), shape=(m, m))
    ncomp, lab = connected_components(G.tocsr(), directed=False)
    nface = np.bincount(lab, minlength=ncomp)
    order = np.argsort(lab, kind="stable")
    groups = np.split(order, np.cumsum(nface)[:-1])
    return [groups[c] for c in np.flatnonzero(nface >= tol.CAP_MIN_FACES)], N, A


def _find_caps(V, F, topo):
    """Flat patches bounded by sharp edges: list of (faces, rim loop, centre, normal)."""
    patches, N, A = _smooth_patches(V, F, topo)
    med = median_edge(V, F)
    caps = []
    for fids in patches:  # loop over a few patches
        if topo.boundary_faces[fids].any():  # touches a mesh boundary: not a cap of a closed end
            continue
        w = A[fids]
        M = (N[fids] * w[:, None]).T @ N[fids]
        n = np.linalg.eigh(M)[1][:, -1]
        if np.arccos(np.clip(np.abs(N[fids] @ n), 0, 1)).max() > tol.CAP_FLATNESS:
            continue
        patch = MeshTopology(np.ascontiguousarray(F[fids]), len(V))
        loops = patch.boundary_loops
        if len(loops) != 1 or patch.euler_characteristic != 1:
            continue  # not a disk
        loop = loops[0]
        center = (w[:, None] * V[F[fids]].mean(1)).sum(0) / w.sum()
        if np.linalg.norm(V[loop] - center, axis=1).mean() < tol.CAP_MIN_RADIUS_EDGES * med:
            continue
        caps.append((fids, loop, center, n))
    return caps


def _ring_end(V, G, tip, h):
    """Rounded end at vertex ``tip``: hemisphere-crossing ring, centre, radius.

    Returns the :class:`VesselEnd`, or None when no tube meets the tip (no
    ring narrower than a hemisphere's, or the ring lies on the axis line);
    :func:`_rounded_ends` then raises :class:`NotTubularError`.
    """
    g = dijkstra(G, indices=int(tip))
    finite = np.isfinite(g)
    b = np.full(len(V), -1)
    b[finite] = np.floor(g[finite] / h).astype(np.int64)
    nb = b.max() + 1
    ok = b >= 0
    cnt = np.bincount(b[ok], minlength=nb)
    safe = np.maximum(cnt, 1)[:, None]
    C = np.stack([np.bincount(b[ok], weights=V[ok, k], minlength=nb) for k in range(3)], 1) / safe
    rho = np.bincount(b[ok], weights=np.linalg.norm(V[ok] - C[b[ok]], axis=1), minlength=nb) / safe[:, 0]
    dmean = np.bincount(b[ok], weights=g[ok], minlength=nb) / safe[:, 0]
    # on a hemisphere of radius R the ring at geodesic distance d has radius
    # R sin(d/R) > 2d/pi until the equator (d = pi R / 2), on the tube R < 2d/pi
    valid = np.flatnonzero(cnt >= tol.ENDS_MIN_RING)
    cross = valid[rho[valid] <= 2.0 * dmean[valid] / np.pi]
    if len(cross) == 0:
        return None
    # R from the first ring past the crossing; the centre interpolated at the
    # equator's geodesic distance pi R / 2 (independent of how rings fall in bins)
    R = float(rho[cross[0]])
    dstar = 0.5 * np.pi * R
    center = np.array([np.interp(dstar, dmean[valid], C[valid, k]) for k in range(3)])
    ring = np.flatnonzero(b == valid[np.argmin(np.abs(dmean[valid] - dstar))])
    direction = V[tip] - center
    if np.linalg.norm(direction) == 0:
        return None
    region = np.flatnonzero(g <= tol.ENDS_ROUNDED_REGION * R)
    # order the ring by angle about the axis (counter-clockwise seen from outside)
    t = direction / np.linalg.norm(direction)
    u = V[ring] - center
    u -= np.outer(u @ t, t)
    e1 = u[np.argmax(np.linalg.norm(u, axis=1))]
    if not np.linalg.norm(e1) > 0:  # the ring lies on the axis line: no tube here
        return None
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(t, e1)
    ring = ring[np.argsort(np.arctan2(u @ e2, u @ e1), kind="stable")]
    return _make_end(V, "rounded", ring, region, center, direction)


def _compare_ends(a, b):
    """Order of two ends: larger radius first; ties by kind, loop size, region size, centre."""
    scale = max(a.radius, b.radius)
    if abs(a.radius - b.radius) > tol.ENDS_TIE_RTOL * scale:
        return -1 if a.radius > b.radius else 1
    ka = (_KIND_RANK[a.kind], -len(a.loop), -len(a.vertices), *a.center.tolist())
    kb = (_KIND_RANK[b.kind], -len(b.loop), -len(b.vertices), *b.center.tolist())
    return int(ka > kb) - int(ka < kb)


def _rounded_ends(V, F, topo, ends):
    """Add rounded ends (extremes of a double geodesic sweep) to ``ends`` until there are two."""
    used = np.flatnonzero(topo.referenced)
    if not ends:
        if not topo.is_closed:
            raise NotTubularError(
                "mesh is not tubular: no two ends found (no open loop, flat cap or closed "
                "tube); check the mesh with clean_mesh"
            )
        chi = topo.euler_characteristic
        ncomp = topo.vertex_components[0] - (len(V) - len(used))
        if chi != 2 * ncomp:
            raise NotTubularError(
                f"mesh is not tubular: no two ends found; it is a closed surface with Euler "
                f"characteristic {chi} (genus > 0, e.g. a torus); pass a tube with open or capped ends"
            )
    G = topo.edge_graph(V)
    h = median_edge(V, F)
    if not h > 0:
        raise NotTubularError(
            "mesh is not tubular: no two ends found (most edges have zero length); run vesselgp.clean_mesh"
        )
    if ends:
        g = dijkstra(G, indices=ends[0].vertices, min_only=True)
    else:
        start = int(np.argmax(np.linalg.norm(V[used] - V[used].mean(0), axis=1)))
        g = dijkstra(G, indices=int(used[start]))
        a = int(np.argmax(np.where(np.isfinite(g), g, -1)))
        g = dijkstra(G, indices=a)
        end_a = _ring_end(V, G, a, h)
        if end_a is None:
            raise NotTubularError("mesh is not tubular: no two ends found (no tube at the extremes)")
        ends = [end_a]
    b = int(np.argmax(np.where(np.isfinite(g), g, -1)))
    end_b = _ring_end(V, G, b, h)
    if end_b is None:
        raise NotTubularError("mesh is not tubular: no two ends found (no tube at the extremes)")
    a_end = ends[0]
    length = float(np.linalg.norm(a_end.center - end_b.center))
    diam = a_end.radius + end_b.radius
    if length < tol.MIN_ASPECT * diam:
        raise NotTubularError(
            f"mesh is not tubular: no two ends found; its extremes are {length:.3g} apart, less "
            f"than {tol.MIN_ASPECT:g} mean diameter ({diam:.3g}) (a closed blob such as a sphere)"
        )
    return ends + [end_b]


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
    listing = ", ".join(f"{i} {e.describe().split(' ', 1)[1]}" for i, e in enumerate(ends))
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
