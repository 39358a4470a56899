"""Open seams: a mesh torn along lines of duplicate vertices (issue #49, item 3).

A structured or multi-patch export (a quad mesh written patch by patch, an STL-like
writer that repeats shared vertices) gives each patch its own copy of the vertices along
the seams between patches: the triangle mesh is then several pieces, or one piece with
extra boundary loops, glued only geometrically. Nothing is missing, and
:func:`vesselgp.clean_mesh` merges the copies into one piece.

:func:`open_seams` recognises that cause (boundary edges that lie on other boundary edges,
their ends within ``tolerances.SEAM_COINCIDENCE`` median edges of each other), and
:meth:`OpenSeams.message` is the one message every refusal that meets it gives
(:func:`vesselgp.vessel_ends`, the fits' mesh check, geodesic distances), so a seam is never
reported as pieces to throw away. :func:`refuse_seams` raises it.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from .. import tolerances as tol
from .._arrays import unique_rows
from ..errors import InvalidMeshError

__all__ = ["OpenSeams", "open_seams", "refuse_seams"]


class OpenSeams(NamedTuple):
    """The open seams of a mesh (:func:`open_seams`).

    Attributes
    ----------
    duplicates : int
        Seam vertices that merging removes (each extra copy of a position counts once).
    edges : int
        Boundary edges that lie on another boundary edge.
    pieces : int
        Connected pieces of the mesh (referenced vertices).
    touching : int
        Pieces that touch another along a seam (0 when every seam is within one piece).
    pieces_merged : int
        Connected pieces once the duplicates are merged (1: the seams explain every piece).
    merge : (n,) int64
        The vertex each vertex merges into (itself for every vertex but the duplicates);
        at the same position within the tolerance.
    """

    duplicates: int
    edges: int
    pieces: int
    touching: int
    pieces_merged: int
    merge: np.ndarray

    def message(self):
        """The refusal's text: the duplicates, the pieces they join, the fix.

        Examples
        --------
        >>> print(OpenSeams(390, 768, 6, 6, 1, np.arange(3)).message())
        mesh has open seams of 390 duplicate vertices (its 6 pieces touch along them);
        run vesselgp.clean_mesh (command line: vesselgp clean) to merge them
        >>> print(OpenSeams(390, 768, 7, 6, 2, np.arange(3)).message())  # and a piece of its own
        mesh has open seams of 390 duplicate vertices (6 of its 7 pieces touch along them; merged, the mesh is
        2 separate pieces); run vesselgp.clean_mesh (command line: vesselgp clean) to merge them and keep the
        largest piece
        >>> print(OpenSeams(120, 238, 1, 0, 1, np.arange(3)).message())  # one piece, open along a seam
        mesh has open seams of 120 duplicate vertices (238 boundary edges lie on other boundary edges);
        run vesselgp.clean_mesh (command line: vesselgp clean) to merge them
        """
        if self.touching == self.pieces:
            why = f"its {self.pieces} pieces touch along them"
        elif self.touching:
            why = f"{self.touching} of its {self.pieces} pieces touch along them"
        else:
            why = f"{self.edges} boundary edges lie on other boundary edges"
        fix = "to merge them"
        if self.pieces_merged > 1:
            why += f"; merged, the mesh is {self.pieces_merged} separate pieces"
            fix = "to merge them and keep the largest piece"
        return (f"mesh has open seams of {self.duplicates} duplicate vertices ({why}); "
                f"run vesselgp.clean_mesh (command line: vesselgp clean) {fix}")


def open_seams(V, topo, edge=None):
    """The open seams of a mesh, or None when it has none.

    Two boundary vertices coincide when they are within ``tolerances.SEAM_COINCIDENCE``
    times the mesh's median edge length of each other (chains of such pairs are one
    position). A seam is a boundary edge whose two ends coincide with the two ends of another
    boundary edge; its vertices are the seam's duplicates. Coinciding boundary vertices with no
    coinciding edge (a bow-tie vertex split by :func:`vesselgp.clean_mesh`) are not a seam.

    Parameters
    ----------
    V : (n, 3) float64
    topo : MeshTopology
        Of the mesh's faces.
    edge : float, optional
        The median of ``topo.edge_lengths(V)``, when already computed (default computed here).

    Returns
    -------
    OpenSeams or None

    Examples
    --------
    Two triangles of a unit square that share no vertex (its diagonal repeated):

    >>> from vesselgp.mesh.topology import mesh_topology
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [1, 1, 0], [0, 0, 0], [1, 1, 0], [0, 1, 0]])
    >>> s = open_seams(V, mesh_topology([[0, 1, 2], [3, 4, 5]]))
    >>> s.duplicates, s.edges, s.pieces, s.pieces_merged, s.merge.tolist()
    (2, 2, 2, 1, [0, 1, 2, 0, 2, 5])
    """
    B = topo.edges[topo.boundary_edges].astype(np.int64)
    if not len(B):
        return None
    if edge is None:
        w = topo.edge_lengths(V)
        edge = float(np.median(w)) if len(w) else 0.0
    radius = tol.SEAM_COINCIDENCE * edge if edge > 0 else 0.0
    bv = np.unique(B)
    pairs = cKDTree(V[bv]).query_pairs(radius, output_type="ndarray")
    if not len(pairs):
        return None
    nb = len(bv)
    _, place = connected_components(
        sp.coo_array((np.ones(len(pairs), np.int8), (pairs[:, 0], pairs[:, 1])), shape=(nb, nb)), directed=False)
    where = np.full(topo.n_vertices, -1, np.int64)
    where[bv] = place
    key = np.sort(where[B], axis=1)
    real = key[:, 0] != key[:, 1]  # an edge shorter than the tolerance is no seam
    B, key = B[real], key[real]
    if not len(B):
        return None
    _, inv, count = unique_rows(key, return_inverse=True, return_counts=True)
    on = count[inv.reshape(-1)] > 1
    if not on.any():
        return None
    sv = np.unique(B[on])
    first = np.full(nb, np.iinfo(np.int64).max)
    np.minimum.at(first, where[sv], sv)  # each position's lowest seam vertex stays
    merge = np.arange(topo.n_vertices, dtype=np.int64)
    merge[sv] = first[where[sv]]
    return OpenSeams(int(np.count_nonzero(merge[sv] != sv)), int(np.count_nonzero(on)),
                     *_pieces(topo, sv, merge[sv]), merge)


def _pieces(topo, a, b):
    """Connected pieces of the referenced vertices; how many join another when vertices ``a[i]`` and
    ``b[i]`` are merged; how many pieces there are then."""
    k, lab = topo.vertex_components
    used = np.unique(lab[topo.referenced])
    G = sp.coo_array((np.ones(len(a), np.int8), (lab[a], lab[b])), shape=(k, k))
    _, joined = connected_components(G, directed=False)
    size = np.bincount(joined[used])
    return len(used), int(np.count_nonzero(size[joined[used]] > 1)), len(size[size > 0])


def refuse_seams(V, topo, edge=None):
    """Raise :class:`InvalidMeshError` with :meth:`OpenSeams.message` when the mesh has open seams.

    Parameters are those of :func:`open_seams`.
    """
    seams = open_seams(V, topo, edge)
    if seams is not None:
        raise InvalidMeshError(seams.message())
