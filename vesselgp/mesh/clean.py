"""Mesh repair: :func:`clean_mesh` and its :class:`CleanReport`.

:func:`clean_mesh` runs these steps, one function each:

1. :func:`_remove_defects`: unreferenced vertices, exactly coincident
   vertices (and the copies along open seams rounded apart, :func:`_merge_seams`),
   duplicate and zero-area faces (pymeshlab filters);
2. :func:`_repair_non_manifold`: non-manifold edges (dangling fins first, see
   :func:`_fin_faces`, then pymeshlab's face removal) and vertices (split);
3. :func:`_orient_coherently`: pymeshlab's coherent re-orientation, skipped
   when the faces already are coherent, and the faces it flipped;
4. :func:`_keep_largest_component`: edge-connected face components, all but
   the largest by area dropped;
5. a closed surface is turned outward (positive signed volume);
6. :func:`_taubin_smooth` (``smooth=N``): N iterations of Taubin's
   volume-preserving lambda/mu smoothing (pymeshlab), which removes voxel
   staircases of segmentations.

The connectivity of every step comes from one :class:`~.topology.MeshTopology`.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from .. import tolerances as tol
from .._validate import as_mesh
from ..errors import InvalidMeshError, OptionError
from ._geometry import face_vectors, signed_volume
from .scale import mesh_scale
from .seams import open_seams
from .topology import MeshTopology

__all__ = ["clean_mesh", "CleanReport"]

log = logging.getLogger(__name__)


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
        Vertices merged into another vertex at exactly the same position, or along an open
        seam within ``tolerances.SEAM_COINCIDENCE`` median edges of it
        (:func:`vesselgp.mesh.seams.open_seams`).
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
    smoothing_iterations : int
        Iterations of Taubin smoothing applied after the repairs (0: none;
        the vertices are then a subset of the input positions).
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
    smoothing_iterations: int = 0
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
        ("smoothing_iterations", "{} iterations of Taubin smoothing"),
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


def clean_mesh(V, F=None, keep_largest=True, *, smooth=0):
    """Repair a triangle mesh and keep its largest connected component; optionally smooth it.

    Steps (pymeshlab filters unless noted): remove unreferenced vertices,
    merge exactly coincident vertices (and the copies of an open seam's vertices within
    ``tolerances.SEAM_COINCIDENCE`` median edges of each other, the duplicates
    :func:`vesselgp.mesh.seams.open_seams` counts), remove duplicate and zero-area faces,
    repair non-manifold edges (by removing faces) and vertices (by splitting),
    orient faces coherently, keep the largest edge-connected component by area
    (numpy, :attr:`MeshTopology.face_components`), and orient a closed surface
    outward (positive signed volume). With ``smooth=N``, N iterations of
    Taubin's lambda/mu smoothing follow (pymeshlab
    ``apply_coord_taubin_smoothing`` with ``tolerances.TAUBIN_LAMBDA`` and
    ``TAUBIN_MU``): it removes the voxel staircase of a segmentation without
    the shrinking of plain Laplacian smoothing (a staircase tube 6 voxels in
    radius, 20 iterations: the volume changes by 0.2 %); vertices move, the
    faces stay.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions, or a mesh object (``trimesh.Trimesh``, ``pyvista.PolyData``, ``meshio.Mesh``: :func:`vesselgp.as_mesh`).
    F : (m, 3) int64
        Triangles (left out with a mesh object).
    keep_largest : bool
        Drop every component but the largest by area.
    smooth : int
        Taubin smoothing iterations after the repairs (0: none, the default).

    Returns
    -------
    V2 : (n2, 3) float64
        Cleaned vertices (a subset of the input positions unless ``smooth``).
    F2 : (m2, 3) int64
        Cleaned triangles.
    report : CleanReport
        Counts of every change; ``report.vertex_map`` maps output vertices to
        input vertices. Logged at INFO level when something changed.

    Raises
    ------
    InvalidMeshError
        Malformed input, or nothing left after cleaning.
    OptionError
        ``smooth`` is not a non-negative integer.

    Examples
    --------
    A square whose second triangle uses a duplicate of vertex 0:

    >>> V = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 0]]
    >>> V2, F2, rep = clean_mesh(V, [[0, 1, 2], [4, 2, 3]])
    >>> len(V2), rep.duplicate_vertices_merged, rep.changed
    (4, 1, True)
    >>> rep.smoothing_iterations, clean_mesh(V, [[0, 1, 2]], smooth=2)[2].smoothing_iterations
    (0, 2)
    """
    smooth = _smoothing_iterations(smooth)
    V, F = as_mesh(V, F)
    ml = _MeshLab(V, F)
    counts, topo = _remove_defects(ml)
    repaired, topo = _repair_non_manifold(ml, topo)
    counts.update(repaired)
    V2, F2, vmap, flips, topo = _orient_coherently(ml, topo)
    V2, F2, vmap, flips, ncomp, closed = _keep_largest_component(V2, F2, vmap, flips, topo, keep_largest)
    if closed and signed_volume(V2, F2) < 0:  # closed: make it outward
        F2 = F2[:, [0, 2, 1]]
        flips = ~flips
    if smooth:
        V2 = _taubin_smooth(V2, F2, smooth)
    report = CleanReport(
        vertices_before=len(V), faces_before=len(F), vertices_after=len(V2), faces_after=len(F2),
        components_found=ncomp, components_removed=ncomp - 1 if keep_largest else 0,
        faces_flipped=int(np.count_nonzero(flips)), smoothing_iterations=smooth, vertex_map=vmap,
        **{k: int(v) for k, v in counts.items()},
    )
    if report.changed:
        log.info(report.summary())
    scale = mesh_scale(V2, F2)
    if scale.warning:
        log.warning(scale.warning)
    return np.ascontiguousarray(V2, dtype=np.float64), np.ascontiguousarray(F2), report


class _MeshLab:
    """A pymeshlab MeshSet holding one mesh whose vertices carry their input index ("vgp_id")."""

    def __init__(self, V, F):
        import pymeshlab  # slow to import: only when cleaning

        self._pymeshlab = pymeshlab
        self.ms = pymeshlab.MeshSet()
        self._load(V, F, np.arange(len(V), dtype=np.float64))

    def _load(self, V, F, ids):
        mesh = self._pymeshlab.Mesh(vertex_matrix=V, face_matrix=F.astype(np.int32))
        mesh.add_vertex_custom_scalar_attribute(ids, "vgp_id")
        self.ms.clear()
        self.ms.add_mesh(mesh)

    def counts(self):
        """(vertices, faces) of the current mesh."""
        m = self.ms.current_mesh()
        return m.vertex_number(), m.face_number()

    def run(self, name, **kw):
        """Apply filter ``name``; return (vertices removed, faces removed)."""
        before = self.counts()
        getattr(self.ms, name)(**kw)
        after = self.counts()
        return before[0] - after[0], before[1] - after[1]

    def faces(self):
        """(m, 3) int64 faces of the current mesh."""
        return self.ms.current_mesh().face_matrix().astype(np.int64)

    def drop_faces(self, F, drop):
        """Replace the current mesh by itself without faces ``drop`` of its faces ``F``."""
        m = self.ms.current_mesh()
        keep = np.ones(len(F), dtype=bool)
        keep[drop] = False
        self._load(m.vertex_matrix(), F[keep], m.vertex_custom_scalar_attribute_array("vgp_id"))

    def result(self):
        """Vertices (n, 3) float64, faces (m, 3) int64 and input index of each vertex (n,) int64."""
        m = self.ms.current_mesh()
        vmap = np.rint(m.vertex_custom_scalar_attribute_array("vgp_id")).astype(np.int64)
        return m.vertex_matrix(), m.face_matrix().astype(np.int64), vmap


def _remove_defects(ml):
    """Unreferenced vertices, duplicate vertices, duplicate faces, zero-area faces: counts, and the topology.

    Exactly coincident vertices are merged (pymeshlab), then the copies along open seams that
    rounding left apart (:func:`_merge_seams`), and the faces repeated or emptied by the merges removed.

    Returns
    -------
    counts : dict
    topo : MeshTopology
        Of the current faces.
    """
    c = {}
    c["unreferenced_vertices_removed"], _ = ml.run("meshing_remove_unreferenced_vertices")
    dv, df = ml.run("meshing_remove_duplicate_vertices")  # faces that lost a corner go too
    c["duplicate_faces_removed"] = ml.run("meshing_remove_duplicate_faces")[1]
    df += ml.run("meshing_remove_null_faces")[1]
    sv, topo = _merge_seams(ml)
    if sv:
        df += sv[1]
        c["duplicate_faces_removed"] += ml.run("meshing_remove_duplicate_faces")[1]
        df += ml.run("meshing_remove_null_faces")[1]
        topo = MeshTopology(ml.faces(), ml.counts()[0])
    c["duplicate_vertices_merged"] = dv + (sv[0] if sv else 0)
    c["zero_area_faces_removed"] = df
    return c, topo


def _merge_seams(ml):
    """Merge the copies along open seams that are not exactly coincident.

    A float32 file rounds the two copies of a seam vertex apart now and then;
    :func:`vesselgp.mesh.seams.open_seams` takes them as one position (within
    ``tolerances.SEAM_COINCIDENCE`` median edges) and every refusal of a seam names this
    function, so it merges what they count: each copy is moved onto (and takes the input
    index of) the vertex it merges into, and merged exactly.

    Returns
    -------
    merged : tuple or None
        (vertices merged, faces removed) when there were such copies, else None.
    topo : MeshTopology
        Of the current faces before the merge.
    """
    m = ml.ms.current_mesh()
    V, F = m.vertex_matrix(), ml.faces()
    topo = MeshTopology(F, len(V))
    seams = open_seams(V, topo)
    if seams is None:
        return None, topo
    ids = m.vertex_custom_scalar_attribute_array("vgp_id")
    ml._load(V[seams.merge], F, ids[seams.merge])
    return ml.run("meshing_remove_duplicate_vertices"), topo


def _repair_non_manifold(ml, topo):
    """Repair non-manifold edges and vertices (``topo``: of the current faces).

    Returns
    -------
    counts : dict
        ``non_manifold_edges_repaired``, ``non_manifold_faces_removed``,
        ``non_manifold_vertices_split``.
    topo : MeshTopology
        Topology of the faces before these repairs (the current faces when
        there was nothing to repair).

    Raises
    ------
    InvalidMeshError
        No face left.
    """
    Fm = ml.faces()
    c = {"non_manifold_edges_repaired": len(topo.nonmanifold_edges), "non_manifold_faces_removed": 0}
    if c["non_manifold_edges_repaired"]:
        fins = _fin_faces(topo)
        if len(fins):  # remove dangling fins first, so the wall keeps its faces
            ml.drop_faces(Fm, fins)
            c["non_manifold_faces_removed"] = len(fins)
        _, removed = ml.run("meshing_repair_non_manifold_edges", method="Remove Faces")
        c["non_manifold_faces_removed"] += removed
    c["non_manifold_vertices_split"] = -ml.run("meshing_repair_non_manifold_vertices")[0]
    if ml.counts()[1] == 0:
        raise InvalidMeshError("no faces left after cleaning; the mesh has only degenerate faces")
    return c, topo


def _fin_faces(topo):
    """Faces to drop from non-manifold edges: on each edge with k > 2 faces, the
    faces with the most boundary edges (dangling fins), while a face without a
    boundary edge or a tie leaves the choice to pymeshlab."""
    nbound = (topo.edge_face_count[topo.face_edges] == 1).sum(axis=1)  # boundary edges of each face
    drop = set()
    for e in topo.nonmanifold_edges:  # loop over the (few) non-manifold edges
        faces = [int(f) for f in np.unique(topo.faces_of_edge(e)) if f not in drop]
        faces.sort(key=lambda f: -nbound[f])
        extra = len(faces) - 2
        if extra > 0 and nbound[faces[extra - 1]] > nbound[faces[extra]]:
            drop.update(faces[:extra])
    return np.array(sorted(drop), dtype=np.int64)


def _orient_coherently(ml, topo):
    """Orient the current faces coherently (pymeshlab), unless ``topo`` shows they already are.

    Returns
    -------
    V2 : (n, 3) float64
    F2 : (m, 3) int64
    vmap : (n,) int64
        Input index of each vertex.
    flips : (m,) bool
        Faces of ``F2`` whose orientation was reversed.
    topo : MeshTopology
        Topology of ``F2`` up to orientation: its face components, the faces
        of each edge and the set of edges of each face describe ``F2``; the
        corner order and the directions may be those of faces since flipped.
    """
    before = ml.faces()
    unchanged = np.array_equal(before, topo.F)  # no repair touched the faces since `topo`
    if unchanged and topo.is_coherent:
        V2, F2, vmap = ml.result()
        return V2, F2, vmap, np.zeros(len(F2), dtype=bool), topo
    ml.ms.meshing_re_orient_faces_coherently()
    V2, F2, vmap = ml.result()
    flips, same_order = _flipped_faces(before, F2)
    if not (unchanged and same_order):  # flips in place keep the undirected tables, nothing else does
        topo = MeshTopology(F2, len(V2))
    return V2, F2, vmap, flips, topo


def _parity(F):
    """Sorted vertex triple of each face and whether its order is an odd permutation."""
    S = np.sort(F, axis=1)
    even = (F == S).all(1) | (F == np.roll(S, 1, axis=1)).all(1) | (F == np.roll(S, 2, axis=1)).all(1)
    return S, ~even


def _flipped_faces(before, after):
    """Faces of ``after`` whose orientation differs from the same face of ``before``.

    Returns
    -------
    flips : (m,) bool
        Per face of ``after``.
    same_order : bool
        Whether ``after`` lists the faces in the order of ``before``.

    Raises
    ------
    RuntimeError
        ``after`` is not ``before`` with some faces flipped (re-orientation
        only reverses faces; this would be a pymeshlab defect).
    """
    S0, p0 = _parity(before)
    S1, p1 = _parity(after)
    if np.array_equal(S0, S1):
        return p0 != p1, True
    if len(S0) == len(S1):
        o0, o1 = np.lexsort(S0.T[::-1]), np.lexsort(S1.T[::-1])
        if np.array_equal(S0[o0], S1[o1]):
            flips = np.empty(len(S1), dtype=bool)
            flips[o1] = p0[o0] != p1[o1]
            return flips, False
    raise RuntimeError(
        "pymeshlab's coherent re-orientation changed the set of faces instead of only flipping faces; "
        "clean_mesh cannot count the flipped faces"
    )


def _keep_largest_component(V, F, vmap, flips, topo, keep_largest):
    """Keep the largest edge-connected face component by area; drop vertices left unused.

    ``topo`` describes ``F`` up to orientation (only its undirected tables are read).

    Returns
    -------
    V, F, vmap, flips
        Restricted to the kept faces and their vertices (renumbered).
    ncomp : int
        Number of components found.
    closed : bool
        Whether every edge of the kept faces has two faces.
    """
    ncomp, lab = topo.face_components
    if keep_largest and ncomp > 1:
        area = np.bincount(lab, weights=np.linalg.norm(face_vectors(V, F), axis=1))
        keep = lab == int(np.argmax(area))
        # components are edge-connected: every face of an edge of a kept face is kept
        closed = bool(np.all(topo.edge_face_count[topo.face_edges[keep]] == 2))
        F, flips = F[keep], flips[keep]
    else:
        closed = topo.is_closed
    used = np.zeros(len(V), dtype=bool)
    used[F.reshape(-1)] = True
    newid = np.cumsum(used) - 1
    return V[used], newid[F], vmap[used], flips, ncomp, closed


def _smoothing_iterations(smooth):
    """``smooth`` as an int, or :class:`OptionError` when it is not a non-negative whole number."""
    if isinstance(smooth, bool) or not isinstance(smooth, (int, np.integer)) or smooth < 0:
        raise OptionError(f"smooth must be a non-negative integer number of Taubin iterations (0: off), "
                          f"got {smooth!r}; pass e.g. smooth=10")
    return int(smooth)


def _taubin_smooth(V, F, iterations):
    """``iterations`` lambda/mu steps of Taubin smoothing (pymeshlab); the vertex order is kept.

    Returns
    -------
    (n, 3) float64
        The smoothed vertices of the faces ``F``.
    """
    import pymeshlab  # slow to import: only when smoothing

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=V, face_matrix=F.astype(np.int32)))
    ms.apply_coord_taubin_smoothing(lambda_=tol.TAUBIN_LAMBDA, mu=tol.TAUBIN_MU, stepsmoothnum=int(iterations))
    m = ms.current_mesh()
    if m.vertex_number() != len(V) or not np.array_equal(m.face_matrix(), F):
        raise RuntimeError("pymeshlab's Taubin smoothing changed the faces; clean_mesh keeps them")
    log.info("Taubin smoothing: %d iterations (lambda %g, mu %g)", iterations, tol.TAUBIN_LAMBDA, tol.TAUBIN_MU)
    return np.asarray(m.vertex_matrix(), dtype=np.float64)
