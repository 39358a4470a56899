"""Mesh cleanup, scale and units, and the ends of a vessel.

* :func:`clean_mesh` repairs what segmentation and STL export leave behind
  (pymeshlab filters) and keeps the largest connected piece.
* :func:`mesh_scale` reports edge length, size and a guess of the units.
* :func:`vessel_ends` finds where a vessel ends: open boundary loops, flat
  caps of a closed surface, or rounded (closed, uncapped) extremities.
  :func:`select_ends` picks the two ends of the vessel's path among them.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from functools import cmp_to_key

import igl
import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, dijkstra

from . import tolerances as tol
from ._arrays import unique_rows
from ._validate import as_mesh
from .errors import EndsError, InvalidMeshError, NotTubularError

__all__ = [
    "clean_mesh",
    "CleanReport",
    "mesh_scale",
    "MeshScale",
    "vessel_ends",
    "VesselEnd",
    "select_ends",
]

log = logging.getLogger(__name__)


# --------------------------------------------------------------------------- #
# small geometric helpers (vectorised)
# --------------------------------------------------------------------------- #
def _face_vectors(V, F):
    """Unnormalised face normals (twice the area vectors), (m, 3)."""
    return np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])


def _edge_keys(F):
    """One int64 key per face corner edge (m, 3), ``min * base + max``, and the base."""
    base = int(F.max()) + 1 if len(F) else 1
    a, b = F, F[:, [1, 2, 0]]
    return np.minimum(a, b) * base + np.maximum(a, b), base


def _unique_edges(F):
    """Undirected edges (e, 2) sorted per row (lexicographic order), and how many faces use each."""
    key, base = _edge_keys(F)
    u, count = np.unique(key.ravel(), return_counts=True)
    return np.stack([u // base, u % base], axis=1), count


def _face_edges(F):
    """Undirected edge id of each face corner edge (3 m,) (face-major) and faces per edge (e,)."""
    key, _ = _edge_keys(F)
    _, inv, count = np.unique(key.ravel(), return_inverse=True, return_counts=True)
    return inv, count


def _median_edge(V, F):
    # over face corners: interior edges count twice, which leaves the median as it is
    return float(np.median(igl.edge_lengths(V, F)))


def _signed_volume(V, F):
    return float(np.einsum("ij,ij->", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])) / 6.0)


def _edge_graph(V, F):
    """Sparse symmetric graph of mesh edges weighted by length."""
    E, _ = _unique_edges(F)
    w = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    n = len(V)
    G = sp.coo_matrix((w, (E[:, 0], E[:, 1])), shape=(n, n)).tocsr()
    return G + G.T


def _coherent(F, einv, ecount):
    """Whether every edge is manifold and its two faces traverse it in opposite directions.

    ``einv, ecount`` are :func:`_face_edges` of ``F``.
    """
    if np.any(ecount > 2):
        return False
    return _incoherent_edges(F, einv, ecount) == 0


def _incoherent_edges(F, einv, ecount):
    """Number of edges whose two faces traverse them in the same direction."""
    up = np.bincount(einv, weights=(F < F[:, [1, 2, 0]]).ravel(), minlength=len(ecount))
    return int(np.count_nonzero((ecount == 2) & (up != 1)))


def _parity(F):
    """Sorted vertex triple of each face and whether its order is an odd permutation."""
    S = np.sort(F, axis=1)
    even = (F == np.roll(S, 0, axis=1)).all(1) | (F == np.roll(S, 1, axis=1)).all(1) | (
        F == np.roll(S, 2, axis=1)
    ).all(1)
    return S, ~even


# --------------------------------------------------------------------------- #
# clean_mesh
# --------------------------------------------------------------------------- #
@dataclass(frozen=True)
class CleanReport:
    """What :func:`clean_mesh` changed.

    Attributes
    ----------
    vertices_before, faces_before, vertices_after, faces_after : int
        Sizes of the input and output meshes.
    unreferenced_vertices_removed : int
        Vertices of the input that no face used.
    duplicate_vertices_merged : int
        Vertices merged into another vertex at exactly the same position.
    duplicate_faces_removed : int
        Faces repeating the vertex set of another face.
    zero_area_faces_removed : int
        Faces of exactly zero area (including faces that lost a corner when
        duplicate vertices were merged).
    non_manifold_edges_repaired : int
        Edges shared by more than two faces, made manifold by removing faces.
    non_manifold_faces_removed : int
        Faces removed to repair those edges.
    non_manifold_vertices_split : int
        Vertices added by splitting non-manifold (bow-tie) vertices.
    components_found, components_removed : int
        Edge-connected face components, and how many were dropped (all but the
        largest by area when ``keep_largest``).
    faces_flipped : int
        Faces whose orientation was reversed to make it coherent (and outward
        for a closed surface).
    vertex_map : (vertices_after,) int64
        Input index of each output vertex.
    """

    vertices_before: int
    faces_before: int
    vertices_after: int
    faces_after: int
    unreferenced_vertices_removed: int = 0
    duplicate_vertices_merged: int = 0
    duplicate_faces_removed: int = 0
    zero_area_faces_removed: int = 0
    non_manifold_edges_repaired: int = 0
    non_manifold_faces_removed: int = 0
    non_manifold_vertices_split: int = 0
    components_found: int = 1
    components_removed: int = 0
    faces_flipped: int = 0
    vertex_map: np.ndarray = field(default=None, repr=False, compare=False)

    _ITEMS = (
        ("duplicate_vertices_merged", "merged {} duplicate vertices"),
        ("unreferenced_vertices_removed", "removed {} unreferenced vertices"),
        ("duplicate_faces_removed", "removed {} duplicate faces"),
        ("zero_area_faces_removed", "removed {} zero-area faces"),
        ("non_manifold_edges_repaired", "repaired {} non-manifold edges"),
        ("non_manifold_vertices_split", "split {} non-manifold vertices"),
        ("components_removed", "dropped {} small components"),
        ("faces_flipped", "flipped {} faces"),
    )

    @property
    def changed(self):
        """True if the output differs from the input in any way."""
        return bool(
            self.vertices_before != self.vertices_after
            or self.faces_before != self.faces_after
            or any(getattr(self, k) for k, _ in self._ITEMS)
        )

    def summary(self):
        """One-line description of the changes.

        Examples
        --------
        >>> CleanReport(4, 2, 4, 2).summary()
        'clean_mesh: no change (4 vertices, 2 faces)'
        """
        if not self.changed:
            return f"clean_mesh: no change ({self.vertices_after} vertices, {self.faces_after} faces)"
        done = [msg.format(getattr(self, k)) for k, msg in self._ITEMS if getattr(self, k)]
        return (
            f"clean_mesh: {self.vertices_before}->{self.vertices_after} vertices, "
            f"{self.faces_before}->{self.faces_after} faces"
            + (": " + ", ".join(done) if done else "")
        )


def _fin_faces(F):
    """Faces to drop from non-manifold edges: on each edge with k > 2 faces, the
    faces with the most boundary edges (dangling fins), while a face without a
    boundary edge or a tie leaves the choice to pymeshlab."""
    H = np.sort(F[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, inv, cnt = unique_rows(H, return_inverse=True, return_counts=True)
    inv = inv.reshape(-1, 3)
    nbound = (cnt[inv] == 1).sum(axis=1)  # boundary edges of each face
    drop = set()
    for e in np.flatnonzero(cnt > 2):  # loop over the (few) non-manifold edges
        faces = [f for f in np.flatnonzero((inv == e).any(axis=1)) if f not in drop]
        faces.sort(key=lambda f: -nbound[f])
        extra = len(faces) - 2
        if extra > 0 and nbound[faces[extra - 1]] > nbound[faces[extra]]:
            drop.update(int(f) for f in faces[:extra])
    return np.array(sorted(drop), dtype=np.int64)


def clean_mesh(V, F, keep_largest=True):
    """Repair a triangle mesh and keep its largest connected component.

    Steps (pymeshlab filters unless noted): remove unreferenced vertices,
    merge exactly coincident vertices, remove duplicate and zero-area faces,
    repair non-manifold edges (by removing faces) and vertices (by splitting),
    orient faces coherently, keep the largest edge-connected component by area
    (numpy, :func:`scipy.sparse.csgraph.connected_components`), and orient a
    closed surface outward (positive signed volume).

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, 3) int64
        Triangles.
    keep_largest : bool
        Drop every component but the largest by area.

    Returns
    -------
    V2 : (n2, 3) float64
        Cleaned vertices (a subset of the input positions).
    F2 : (m2, 3) int64
        Cleaned triangles.
    report : CleanReport
        Counts of every change; ``report.vertex_map`` maps output vertices to
        input vertices. Logged at INFO level when something changed.

    Raises
    ------
    InvalidMeshError
        Malformed input, or nothing left after cleaning.

    Examples
    --------
    A square whose second triangle uses a duplicate of vertex 0:

    >>> V = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 0]]
    >>> V2, F2, rep = clean_mesh(V, [[0, 1, 2], [4, 2, 3]])
    >>> len(V2), rep.duplicate_vertices_merged, rep.changed
    (4, 1, True)
    """
    import pymeshlab

    from .errors import InvalidMeshError

    V, F = as_mesh(V, F)
    n0, m0 = len(V), len(F)
    mesh = pymeshlab.Mesh(vertex_matrix=V, face_matrix=F.astype(np.int32))
    mesh.add_vertex_custom_scalar_attribute(np.arange(n0, dtype=np.float64), "vgp_id")
    ms = pymeshlab.MeshSet()
    ms.add_mesh(mesh)

    def counts():
        m = ms.current_mesh()
        return m.vertex_number(), m.face_number()

    def run(name, **kw):
        before = counts()
        getattr(ms, name)(**kw)
        after = counts()
        return before[0] - after[0], before[1] - after[1]

    c = {}
    c["unreferenced_vertices_removed"], _ = run("meshing_remove_unreferenced_vertices")
    dv, df = run("meshing_remove_duplicate_vertices")
    c["duplicate_vertices_merged"] = dv
    c["duplicate_faces_removed"] = run("meshing_remove_duplicate_faces")[1]
    c["zero_area_faces_removed"] = df + run("meshing_remove_null_faces")[1]
    Fm = ms.current_mesh().face_matrix().astype(np.int64)
    edges = _face_edges(Fm)  # (edge id of each face corner, faces per edge), reused below
    c["non_manifold_edges_repaired"] = int(np.count_nonzero(edges[1] > 2)) if len(Fm) else 0
    c["non_manifold_faces_removed"] = 0
    if c["non_manifold_edges_repaired"]:
        fins = _fin_faces(Fm)
        if len(fins):  # remove dangling fins first, so the wall keeps its faces
            m = ms.current_mesh()
            ids = m.vertex_custom_scalar_attribute_array("vgp_id")
            keep = np.ones(len(Fm), bool)
            keep[fins] = False
            mesh = pymeshlab.Mesh(vertex_matrix=m.vertex_matrix(), face_matrix=Fm[keep].astype(np.int32))
            mesh.add_vertex_custom_scalar_attribute(ids, "vgp_id")
            ms.clear()
            ms.add_mesh(mesh)
            c["non_manifold_faces_removed"] = len(fins)
        c["non_manifold_faces_removed"] += run(
            "meshing_repair_non_manifold_edges", method="Remove Faces"
        )[1]
    c["non_manifold_vertices_split"] = -run("meshing_repair_non_manifold_vertices")[0]
    if counts()[1] == 0:
        raise InvalidMeshError("no faces left after cleaning; the mesh has only degenerate faces")

    before = ms.current_mesh().face_matrix().astype(np.int64)
    unchanged = np.array_equal(before, Fm)  # no repair touched the faces since `edges`
    coherent = unchanged and _coherent(Fm, *edges)
    if not coherent:
        ms.meshing_re_orient_faces_coherently()
    m = ms.current_mesh()
    F2 = m.face_matrix().astype(np.int64)
    V2 = m.vertex_matrix()
    vmap = np.rint(m.vertex_custom_scalar_attribute_array("vgp_id")).astype(np.int64)
    flipped = 0
    same_faces = coherent  # F2 holds the faces of Fm, in the same order (re-orientation only flips)
    if not coherent and len(before) == len(F2):
        S0, p0 = _parity(before)
        S1, p1 = _parity(F2)
        if np.array_equal(S0, S1):  # pymeshlab keeps the face order
            flipped = int(np.count_nonzero(p0 != p1))
            same_faces = unchanged
        else:
            o0, o1 = np.lexsort(S0.T[::-1]), np.lexsort(S1.T[::-1])
            if np.array_equal(S0[o0], S1[o1]):
                flipped = int(np.count_nonzero(p0[o0] != p1[o1]))
    einv, ecount = edges if same_faces else _face_edges(F2)

    # connected components by edge adjacency (faces joined through their shared
    # edges: a face-edge incidence graph), keep the largest by area
    m2, ne = len(F2), len(ecount)
    fid = np.repeat(np.arange(m2), 3)
    inc = sp.coo_matrix((np.ones(3 * m2), (fid, m2 + einv)), shape=(m2 + ne, m2 + ne))
    ncomp, lab = connected_components(inc.tocsr(), directed=False)
    lab = lab[:m2]  # every edge belongs to a face: the components are the face components
    removed = 0
    if keep_largest and ncomp > 1:
        area = np.bincount(lab, weights=np.linalg.norm(_face_vectors(V2, F2), axis=1))
        keep = lab == int(np.argmax(area))
        removed = ncomp - 1
        F2 = F2[keep]
        ecount = np.bincount(einv.reshape(-1, 3)[keep].ravel(), minlength=ne)
        ecount = ecount[ecount > 0]
    used = np.zeros(len(V2), dtype=bool)
    used[F2.reshape(-1)] = True
    newid = np.cumsum(used) - 1
    V2, F2, vmap = V2[used], newid[F2], vmap[used]

    if np.all(ecount == 2) and _signed_volume(V2, F2) < 0:  # closed: make it outward
        F2 = F2[:, [0, 2, 1]]
        flipped = len(F2) - flipped

    report = CleanReport(
        vertices_before=n0, faces_before=m0, vertices_after=len(V2), faces_after=len(F2),
        components_found=int(ncomp), components_removed=removed, faces_flipped=flipped,
        vertex_map=vmap, **{k: int(v) for k, v in c.items()},
    )
    if report.changed:
        log.info(report.summary())
    scale = mesh_scale(V2, F2)
    if scale.warning:
        log.warning(scale.warning)
    return np.ascontiguousarray(V2, dtype=np.float64), np.ascontiguousarray(F2), report


# --------------------------------------------------------------------------- #
# mesh_scale
# --------------------------------------------------------------------------- #
@dataclass(frozen=True)
class MeshScale:
    """Size of a mesh and a guess of its length unit.

    Attributes
    ----------
    median_edge : float
        Median edge length.
    bbox_diagonal : float
        Length of the bounding-box diagonal.
    radius_range : tuple of float or None
        (smallest, largest) end radius, when ends were given.
    units_guess : str
        "mm" (vessels span 10-500 mm), "cm", "m" or "um".
    warning : str or None
        Why the units look unusual and what to do, or None.
    """

    median_edge: float
    bbox_diagonal: float
    radius_range: tuple | None
    units_guess: str
    warning: str | None


def mesh_scale(V, F, ends=None):
    """Edge length, size and a guess of the length unit of a vessel mesh.

    Vessels in millimetres have bounding-box diagonals of about 10-500. A
    diagonal below ``tolerances.UNITS_M_MAX_DIAG`` suggests metres; one below
    ``tolerances.UNITS_CM_MAX_DIAG`` with edges finer than
    ``tolerances.UNITS_CM_EDGE_FRACTION`` of it suggests centimetres; one above
    ``tolerances.UNITS_UM_MIN_DIAG`` suggests micrometres. This is a guess:
    callers should log ``warning`` rather than rescale silently.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, 3) int64
        Triangles.
    ends : sequence of VesselEnd, optional
        Ends from :func:`vessel_ends`; their radii give ``radius_range``.

    Returns
    -------
    MeshScale

    Examples
    --------
    >>> V = np.array([[0, 0, 0], [0.05, 0, 0], [0, 0.05, 0.02]])
    >>> s = mesh_scale(V, [[0, 1, 2]])
    >>> s.units_guess, s.warning is not None
    ('m', True)
    """
    V, F = as_mesh(V, F)
    med = _median_edge(V, F)
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    rr = None
    if ends:
        r = [e.radius for e in ends]
        rr = (float(min(r)), float(max(r)))
    warning = None
    if diag < tol.UNITS_M_MAX_DIAG:
        units = "m"
        warning = (f"bounding-box diagonal {diag:.3g} is far below the 10-500 of a vessel in "
                   "millimetres; the mesh looks like metres: multiply V by 1000")
    elif diag < tol.UNITS_CM_MAX_DIAG and med < tol.UNITS_CM_EDGE_FRACTION * diag:
        units = "cm"
        warning = (f"bounding-box diagonal {diag:.3g} with fine edges ({med:.3g}) looks like "
                   "centimetres: multiply V by 10 if so")
    elif diag > tol.UNITS_UM_MIN_DIAG:
        units = "um"
        warning = (f"bounding-box diagonal {diag:.3g} is far above the 10-500 of a vessel in "
                   "millimetres; the mesh looks like micrometres: divide V by 1000")
    else:
        units = "mm"
    return MeshScale(med, diag, rr, units, warning)


# --------------------------------------------------------------------------- #
# vessel ends
# --------------------------------------------------------------------------- #
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


def _vector_area(P):
    """Vector area of a closed polygon (rows of P in order), (3,)."""
    c = P.mean(0)
    return 0.5 * np.cross(P - c, np.roll(P, -1, axis=0) - c).sum(0)


def _loop_centroid(P):
    """Centroid of a closed polyline weighted by the length around each vertex."""
    seg = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)
    w = 0.5 * (seg + np.roll(seg, 1))
    return (w[:, None] * P).sum(0) / w.sum()


def _make_end(V, kind, loop, region, center, normal, faces=None):
    """Orient ``normal`` away from the nearby vessel body and build the end."""
    loop = np.asarray(loop, dtype=np.int64)
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
    if len(loop) >= 3 and _vector_area(V[loop]) @ n < 0:
        loop = loop[::-1].copy()
    return VesselEnd(kind, loop, np.unique(np.asarray(region, dtype=np.int64)),
                     np.asarray(center, dtype=np.float64), n, radius,
                     None if faces is None else np.asarray(faces, dtype=np.int64))


def _open_ends(V, F):
    import igl

    ends = []
    for loop in igl.boundary_loop_all(F):
        loop = np.asarray(loop, dtype=np.int64)
        if len(loop) < 3:
            continue
        P = V[loop]
        a = _vector_area(P)
        per = float(np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1).sum())
        if not np.linalg.norm(a) > tol.DEGENERATE_AREA * per**2:
            c = ", ".join(f"{x:.3g}" for x in P.mean(0))
            raise InvalidMeshError(
                f"boundary loop of {len(loop)} vertices at ({c}) encloses no area (its vertices "
                "coincide or are collinear); run vesselgp.clean_mesh or repair the mesh there"
            )
        ends.append(_make_end(V, "open", loop, loop, _loop_centroid(P), a))
    return ends


def _find_caps(V, F):
    """Flat patches bounded by sharp edges: list of (faces, rim loop)."""
    import igl

    TT, _ = igl.triangle_triangle_adjacency(F)
    N = _face_vectors(V, F)
    A = np.linalg.norm(N, axis=1)
    N = np.divide(N, A[:, None], out=np.zeros_like(N), where=A[:, None] > 0)
    i = np.repeat(np.arange(len(F)), 3)
    j = TT.reshape(-1)
    has = j >= 0
    cosang = np.abs(np.einsum("ij,ij->i", N[i[has]], N[j[has]]))  # orientation-free
    smooth = cosang > np.cos(tol.SHARP_EDGE_ANGLE)
    G = sp.coo_matrix((np.ones(smooth.sum()), (i[has][smooth], j[has][smooth])),
                      shape=(len(F), len(F)))
    ncomp, lab = connected_components(G, directed=False)
    nface = np.bincount(lab, minlength=ncomp)
    med = _median_edge(V, F)
    caps = []
    for c in np.flatnonzero(nface >= tol.CAP_MIN_FACES):  # loop over a few patches
        fids = np.flatnonzero(lab == c)
        if TT[fids].min() < 0:  # touches a mesh boundary: not a cap of a closed end
            continue
        w = A[fids]
        M = (N[fids] * w[:, None]).T @ N[fids]
        n = np.linalg.eigh(M)[1][:, -1]
        if np.arccos(np.clip(np.abs(N[fids] @ n), 0, 1)).max() > tol.CAP_FLATNESS:
            continue
        loops = igl.boundary_loop_all(F[fids])
        if len(loops) != 1:
            continue
        loop = np.asarray(loops[0], dtype=np.int64)
        Vc = np.unique(F[fids])
        if len(Vc) - len(np.unique(np.sort(F[fids][:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1),
                                   axis=0)) + len(fids) != 1:
            continue  # not a disk
        center = (w[:, None] * V[F[fids]].mean(1)).sum(0) / w.sum()
        if np.linalg.norm(V[loop] - center, axis=1).mean() < tol.CAP_MIN_RADIUS_EDGES * med:
            continue
        caps.append((fids, loop, center, n))
    return caps


def _ring_end(V, G, tip, h):
    """Rounded end at vertex ``tip``: hemisphere-crossing ring, centre, radius."""
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
    scale = max(a.radius, b.radius)
    if abs(a.radius - b.radius) > tol.ENDS_TIE_RTOL * scale:
        return -1 if a.radius > b.radius else 1
    ka = (_KIND_RANK[a.kind], -len(a.loop), -len(a.vertices), *a.center.tolist())
    kb = (_KIND_RANK[b.kind], -len(b.loop), -len(b.vertices), *b.center.tolist())
    return int(ka > kb) - int(ka < kb)


def vessel_ends(V, F):
    """Find the ends of a vessel mesh.

    Open ends are boundary loops (:func:`igl.boundary_loop_all`). If fewer
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
        Defects that :func:`clean_mesh` repairs and that would make boundary
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
    _check_surface(V, F)
    ends = _open_ends(V, F)
    if len(ends) < 2:
        for fids, loop, center, n in _find_caps(V, F):
            ends.append(_make_end(V, "cap", loop, np.unique(F[fids]), center, n, faces=fids))
    if len(ends) < 2:
        ends = _rounded_ends(V, F, ends)
    ends.sort(key=cmp_to_key(_compare_ends))
    log.info("found %d vessel ends: %s", len(ends), "; ".join(e.describe() for e in ends))
    return tuple(ends)


def _check_surface(V, F):
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
    einv, ec = _face_edges(F)
    nm = int(np.count_nonzero(ec > 2))
    if nm:
        raise InvalidMeshError(
            f"mesh has {nm} non-manifold edges (shared by more than two faces); "
            "run vesselgp.clean_mesh to repair them"
        )
    bad = _incoherent_edges(F, einv, ec)
    if bad:
        raise InvalidMeshError(
            f"mesh faces are not consistently oriented ({bad} edges are used twice in the same "
            "direction); run vesselgp.clean_mesh to orient them"
        )
    on_boundary = ec[einv] == 1
    B = np.sort(np.stack([F.ravel()[on_boundary], F[:, [1, 2, 0]].ravel()[on_boundary]], axis=1), axis=1)
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


def _rounded_ends(V, F, ends):
    used = np.unique(F)
    E, ec = _unique_edges(F)
    closed = np.all(ec == 2)
    if not ends:
        if not closed:
            raise NotTubularError(
                "mesh is not tubular: no two ends found (no open loop, flat cap or closed "
                "tube); check the mesh with clean_mesh"
            )
        chi = len(used) - len(E) + len(F)
        ncomp = connected_components(_edge_graph(V, F), directed=False)[0] - (len(V) - len(used))
        if chi != 2 * ncomp:
            raise NotTubularError(
                f"mesh is not tubular: no two ends found; it is a closed surface with Euler "
                f"characteristic {chi} (genus > 0, e.g. a torus); pass a tube with open or capped ends"
            )
    G = _edge_graph(V, F)
    h = _median_edge(V, F)
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
        small = sum(e.radius < 0.5 * r2 for e in ends)
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
