"""Connectivity of a triangle mesh, computed once: :class:`MeshTopology`.

One sort of the faces' corner edges gives every edge table the mesh stage
needs: the unique undirected edges, the edge of each face corner, how many
faces use each edge and in which direction, the two faces of each interior
edge, boundary edges and ordered boundary loops, vertex adjacency and
connected components. :func:`vesselgp.clean_mesh`, :func:`vesselgp.vessel_ends`
and :func:`vesselgp.mesh.stitch` all read these tables from one object.

Half-edges are numbered face-major: half-edge ``h = 3 f + i`` runs from
``F[f, i]`` to ``F[f, (i + 1) % 3]``.
"""
from __future__ import annotations

from functools import cached_property

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .. import tolerances as tol
from .._arrays import chunks
from ..errors import InvalidMeshError, MismatchError

__all__ = ["MeshTopology", "mesh_topology"]


def _as_faces(F, n_vertices):
    """Validated (m, 3) int64 faces and the vertex count, or raise :class:`InvalidMeshError`."""
    try:
        Fa = np.asarray(F)
    except (TypeError, ValueError) as exc:
        raise InvalidMeshError(f"F must be an integer (m, 3) array: {exc}") from None
    if Fa.ndim != 2 or Fa.shape[1] != 3:
        raise InvalidMeshError(f"F must have shape (m, 3), got {Fa.shape}")
    if Fa.size and not np.issubdtype(Fa.dtype, np.integer) and (
            not np.issubdtype(Fa.dtype, np.floating) or np.any(Fa != np.round(Fa))):
        raise InvalidMeshError("F must hold integer vertex indices")
    Fa = np.ascontiguousarray(Fa, dtype=np.int64)
    top = int(Fa.max()) + 1 if Fa.size else 0
    n = top if n_vertices is None else int(n_vertices)
    if Fa.size and (Fa.min() < 0 or top > n):
        raise InvalidMeshError(
            f"F indexes vertices in [{Fa.min()}, {top - 1}] but the mesh has {n} vertices")
    return Fa, n


class MeshTopology:
    """Edges, adjacency, boundary loops and components of one triangle mesh.

    Built from the faces alone (geometry enters only through the methods that
    take ``V``). The edge table is computed on construction from one stable
    sort of the corner edges' int64 keys ``min * n + max``; everything else is
    computed on first use and cached. The object describes ``F`` as it was
    when built: do not modify ``F`` afterwards. Its index tables are
    :attr:`index_dtype` (int32 whenever every half-edge and vertex index fits,
    which halves their memory; int64 beyond), written ``int`` below; the
    vertex and face ids it returns (loops, components, edge lookups) are int64.

    Parameters
    ----------
    F : (m, 3) int64
        Triangles, C-contiguous and already validated (use
        :meth:`from_faces` for arbitrary input).
    n_vertices : int
        Number of vertices (every index of ``F`` is below it).

    Attributes
    ----------
    F : (m, 3) int64
        The faces.
    n_vertices : int
        Number of vertices, including unreferenced ones.
    index_dtype : numpy.dtype
        int32, or int64 for a mesh with 2**31 half-edges or vertices or more.
    edges : (e, 2) int
        Unique undirected edges, ``edges[:, 0] <= edges[:, 1]``, rows in
        lexicographic order. A face with a repeated vertex gives a self-loop
        edge ``(a, a)``.
    face_edges : (m, 3) int
        Edge id of each corner edge: ``face_edges[f, i]`` is the edge from
        ``F[f, i]`` to ``F[f, (i + 1) % 3]``.
    edge_face_count : (e,) int
        Faces using each edge (1 boundary, 2 interior, > 2 non-manifold).
    edge_up_count : (e,) int
        Faces traversing each edge from its smaller to its larger vertex.

    Examples
    --------
    A tetrahedron:

    >>> t = MeshTopology.from_faces([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> t.n_edges, t.is_closed, t.is_coherent, t.vertex_components[0]
    (6, True, True, 1)
    """

    def __init__(self, F, n_vertices):
        self.F = F.view()  # read-only view: the caller's array keeps its flags
        self.n_vertices = int(n_vertices)
        base = max(self.n_vertices, 1)
        self.index_dtype = _index_dtype(3 * len(F), self.n_vertices)
        a = F.reshape(-1)
        b = F[:, [1, 2, 0]].reshape(-1)
        up = a < b
        key = np.minimum(a, b) * base + np.maximum(a, b)
        del a, b
        # stable: faces of an edge stay in face order (deterministic first/second face),
        # and timsort is fast on the partly ordered corner keys of real meshes
        order = np.argsort(key, kind="stable")
        ks = key[order]
        del key
        new = np.ones(len(ks), dtype=bool)
        np.not_equal(ks[1:], ks[:-1], out=new[1:])
        starts = np.flatnonzero(new).astype(self.index_dtype)
        inv = np.empty(len(ks), dtype=self.index_dtype)
        inv[order] = np.cumsum(new, dtype=self.index_dtype) - 1
        self._order = order.astype(self.index_dtype)
        del order
        self._starts = starts
        self._same = ~new  # sorted position i repeats the edge of position i - 1
        self._keys = ks[starts]
        del ks
        self._base = base
        self.edges = np.stack([self._keys // base, self._keys % base], axis=1).astype(self.index_dtype)
        self.face_edges = inv.reshape(-1, 3)
        self.edge_face_count = np.diff(np.append(starts, len(inv))).astype(self.index_dtype)
        self.edge_up_count = np.bincount(inv, weights=up, minlength=len(starts)).astype(self.index_dtype)
        for arr in (self.F, self.edges, self.face_edges, self.edge_face_count, self.edge_up_count):
            arr.flags.writeable = False

    # ------------------------------------------------------------------ build
    @classmethod
    def from_faces(cls, F, n_vertices=None):
        """Validate ``F`` and build its topology.

        Parameters
        ----------
        F : (m, 3) array_like of int
            Triangles.
        n_vertices : int, optional
            Number of vertices; default ``F.max() + 1``.

        Returns
        -------
        MeshTopology

        Raises
        ------
        InvalidMeshError
            ``F`` is not an (m, 3) integer array, or indexes vertices outside
            ``[0, n_vertices)``.
        """
        return cls(*_as_faces(F, n_vertices))

    def __repr__(self):
        return (f"MeshTopology({self.n_vertices} vertices, {self.n_faces} faces, {self.n_edges} edges, "
                f"{len(self.boundary_edges)} boundary edges)")

    # ------------------------------------------------------------------ sizes
    @property
    def n_faces(self):
        """Number of faces (int)."""
        return len(self.F)

    @property
    def n_edges(self):
        """Number of unique undirected edges (int)."""
        return len(self.edges)

    @cached_property
    def referenced(self):
        """(n_vertices,) bool: vertices used by at least one face."""
        used = np.zeros(self.n_vertices, dtype=bool)
        used[self.F.reshape(-1)] = True
        return used

    @property
    def euler_characteristic(self):
        """V - E + F over the referenced vertices (int): 2 for a sphere, 1 for a disk, 0 for a tube."""
        return int(np.count_nonzero(self.referenced)) - self.n_edges + self.n_faces

    # ------------------------------------------------------------------ edges and faces
    @cached_property
    def edge_halfedges(self):
        """(e, 2) int: the first two half-edges of each edge in face order; -1 if it has one face."""
        second = np.full(self.n_edges, -1, dtype=self.index_dtype)
        two = self.edge_face_count >= 2
        second[two] = self._order[self._starts[two] + 1]
        return np.stack([self._order[self._starts], second], axis=1)

    @cached_property
    def edge_faces(self):
        """(e, 2) int: the faces of each edge, lower face first; -1 for a boundary edge's missing face.

        A non-manifold edge lists only its first two faces; see :meth:`faces_of_edge`.
        """
        H = self.edge_halfedges
        return np.where(H >= 0, H // 3, -1).astype(self.index_dtype)

    def faces_of_edge(self, e):
        """All faces using edge ``e`` ((k,) int64, ascending), also for non-manifold edges."""
        s = self._starts[e]
        return (self._order[s:s + self.edge_face_count[e]] // 3).astype(np.int64)

    @cached_property
    def twin(self):
        """(3 m,) int: the other half-edge of a two-face edge; -1 on boundary, non-manifold edges."""
        tw = np.full(3 * self.n_faces, -1, dtype=self.index_dtype)
        H = np.compress(self.edge_face_count == 2, self.edge_halfedges, axis=0)
        h0, h1 = np.ascontiguousarray(H[:, 0]), np.ascontiguousarray(H[:, 1])  # contiguous: 2x faster scatters
        tw[h0] = h1
        tw[h1] = h0
        return tw

    def edge_index(self, a, b):
        """Edge id of each vertex pair (a[i], b[i]) in either order, -1 where it is not an edge.

        Parameters
        ----------
        a, b : (k,) int
            Vertex ids.

        Returns
        -------
        (k,) int64
        """
        a = np.asarray(a, dtype=np.int64).reshape(-1)
        b = np.asarray(b, dtype=np.int64).reshape(-1)
        inside = (a >= 0) & (b >= 0) & (a < self.n_vertices) & (b < self.n_vertices)
        key = np.minimum(a, b) * self._base + np.maximum(a, b)
        i = np.searchsorted(self._keys, key)
        hit = inside & (i < self.n_edges)
        hit[hit] = self._keys[i[hit]] == key[hit]
        return np.where(hit, i, -1)

    def has_halfedges(self, a, b):
        """Whether some face runs from ``a[i]`` to ``b[i]`` ((k,) bool): a directed-edge lookup.

        Examples
        --------
        >>> t = MeshTopology.from_faces([[0, 1, 2]])
        >>> t.has_halfedges([0, 1, 0], [1, 0, 2]).tolist()
        [True, False, False]
        """
        a = np.asarray(a, dtype=np.int64).reshape(-1)
        b = np.asarray(b, dtype=np.int64).reshape(-1)
        e = self.edge_index(a, b)
        out = e >= 0
        up = self.edge_up_count[e[out]]
        forward = a[out] < b[out]
        out[out] = np.where(forward, up > 0, self.edge_face_count[e[out]] - up > 0)
        return out

    # ------------------------------------------------------------------ manifoldness and orientation
    @cached_property
    def nonmanifold_edges(self):
        """(k,) int64: edges shared by more than two faces."""
        return np.flatnonzero(self.edge_face_count > 2)

    @cached_property
    def incoherent_edges(self):
        """(k,) int64: two-face edges that both faces traverse in the same direction."""
        return np.flatnonzero((self.edge_face_count == 2) & (self.edge_up_count != 1))

    @property
    def is_edge_manifold(self):
        """True when no edge has more than two faces."""
        return len(self.nonmanifold_edges) == 0

    @property
    def is_coherent(self):
        """True when the mesh is edge-manifold and every interior edge is traversed once each way."""
        return self.is_edge_manifold and len(self.incoherent_edges) == 0

    @property
    def is_closed(self):
        """True when every edge has exactly two faces (no boundary, no non-manifold edge)."""
        return bool(np.all(self.edge_face_count == 2))

    # ------------------------------------------------------------------ boundary
    @cached_property
    def boundary_edges(self):
        """(b,) int64: edges with one face."""
        return np.flatnonzero(self.edge_face_count == 1)

    @cached_property
    def boundary_halfedges(self):
        """(b,) int64: the half-edge of each boundary edge (same order as :attr:`boundary_edges`)."""
        return self._order[self._starts[self.boundary_edges]].astype(np.int64)

    @cached_property
    def boundary_faces(self):
        """(m,) bool: faces with at least one boundary edge."""
        return (self.edge_face_count[self.face_edges] == 1).any(axis=1)

    def halfedge_vertices(self, h):
        """Source and target vertex of half-edges ``h``: (k, 2) int64."""
        h = np.asarray(h, dtype=np.int64)
        f, i = np.divmod(h, 3)
        return np.stack([self.F[f, i], self.F[f, (i + 1) % 3]], axis=-1)

    @cached_property
    def boundary_loops(self):
        """Ordered boundary loops: tuple of (k,) int64 vertex arrays.

        Each loop follows the faces' orientation (``(loop[i], loop[i + 1])``
        is a half-edge of a face) and starts at its smallest vertex id; loops
        are sorted by that vertex (the conventions of
        :func:`igl.boundary_loop_all`). At a vertex where boundaries touch, the
        loop turns into the boundary edge reached by rotating about the vertex
        through its faces, so the loops are well defined there too.

        Raises
        ------
        InvalidMeshError
            The mesh has non-manifold edges or inconsistently oriented faces,
            which leave the direction and the continuation of a loop undefined.
        """
        hb = self.boundary_halfedges
        if len(hb) == 0:
            return ()
        if not self.is_coherent:
            raise InvalidMeshError(
                f"boundary loops are undefined: the mesh has {len(self.nonmanifold_edges)} non-manifold "
                f"edges and {len(self.incoherent_edges)} inconsistently oriented edges; "
                "run vesselgp.clean_mesh to repair them"
            )
        nxt = self._next_boundary(hb)
        return tuple(_cycles(nxt, self.halfedge_vertices(hb)[:, 0]))

    def _next_boundary(self, hb):
        """Position in ``hb`` of the boundary half-edge that follows each one.

        From the target ``v`` of boundary half-edge ``h``, rotate about ``v``
        through the faces (next half-edge in the face, across its twin) until a
        half-edge leaving ``v`` has no twin. The rotation is injective and
        starts at a half-edge without a predecessor, so it ends after at most
        the valence of ``v`` steps.
        """
        tw = self.twin
        cur = hb - hb % 3 + (hb % 3 + 1) % 3  # the half-edge leaving the target in the same face
        nxt = np.empty(len(hb), dtype=np.int64)
        active = np.arange(len(hb))
        while len(active):
            t = tw[cur]
            done = t < 0
            nxt[active[done]] = cur[done]
            t = t[~done]
            active, cur = active[~done], t - t % 3 + (t % 3 + 1) % 3
        rank = np.argsort(hb)
        return rank[np.searchsorted(hb[rank], nxt)]

    # ------------------------------------------------------------------ adjacency and components
    @cached_property
    def _edge_pattern(self):
        """(n, n) csr_array of edge ids: ``e`` at ``(i, j)`` and ``(j, i)`` for edge ``e = (i, j)``.

        Built once; every symmetric matrix over the edges shares its pattern
        (:meth:`edge_matrix`). Rows hold their columns in ascending order: for each
        row, the entries below the diagonal (the transposed edges, which the
        lexicographic edge order lists by ascending smaller vertex) come before
        those above, and the coordinate-to-CSR conversion is a stable counting
        sort. A self-loop edge ``(a, a)`` appears once, on the diagonal.
        """
        E, n = self.edges, self.n_vertices
        ids = np.arange(self.n_edges, dtype=self.index_dtype)
        low = E[:, 0] != E[:, 1]
        rows = np.concatenate([E[low, 1], E[:, 0]])
        cols = np.concatenate([E[low, 0], E[:, 1]])
        return sp.coo_array((np.concatenate([ids[low], ids]), (rows, cols)), shape=(n, n)).tocsr()

    def edge_matrix(self, w):
        """(n, n) scipy.sparse.csr_array: ``w[e]`` at ``(i, j)`` and ``(j, i)`` of each edge ``e = (i, j)``.

        ``w`` is (e,) (one value per row of :attr:`edges`); the sparsity pattern
        is computed once per topology and shared. Self-loop edges ``(a, a)``
        (faces with a repeated vertex) put ``w`` once on the diagonal.
        """
        P = self._edge_pattern
        w = np.asarray(w)
        if w.shape != (self.n_edges,):
            raise MismatchError(f"edge_matrix: w must have one value per edge, shape ({self.n_edges},); "
                                f"got {w.shape} (values for another mesh?)")
        return sp.csr_array((w.take(P.data), P.indices, P.indptr), shape=P.shape)

    @cached_property
    def adjacency(self):
        """(n, n) scipy.sparse.csr_array of int8: 1 where two vertices share an edge (symmetric)."""
        return self.edge_matrix(np.ones(self.n_edges, dtype=np.int8))

    def edge_lengths(self, V):
        """(e,) float64: length of each edge for vertex positions ``V`` ((n, 3) float64).

        ``tolerances.EDGE_CHUNK`` edges at a time: the gathered (k, 3) differences of all
        edges at once would cost about 0.2 KB a vertex at the peak (issue #16).
        """
        E = self.edges
        out = np.empty(len(E))
        for c in chunks(len(E), tol.EDGE_CHUNK):
            # take, not V[E[:, 0]]: numpy gathers rows that way about 3x faster; the same lengths
            d = V.take(E[c, 0], axis=0)
            d -= V.take(E[c, 1], axis=0)
            np.sqrt(np.einsum("ij,ij->i", d, d), out=out[c])
        return out

    def edge_graph(self, V):
        """(n, n) scipy.sparse.csr_array of float64: edge lengths, symmetric (for Dijkstra)."""
        return self.edge_matrix(self.edge_lengths(V))

    @cached_property
    def vertex_components(self):
        """(count, labels): vertex-connected components, labels (n,) int32; unreferenced vertices alone.

        The adjacency is symmetric, so its strongly connected components (Pearce's algorithm,
        on the matrix as it is) are the undirected ones; scipy's undirected and weak searches
        first build the transpose (at 1M vertices 136 ms against 48 ms).
        """
        k, lab = connected_components(self.adjacency, directed=True, connection="strong")
        return int(k), lab

    @cached_property
    def face_components(self):
        """(count, labels): edge-connected face components (faces joined through shared edges).

        Faces touching only at a vertex are in different components. Labels
        (m,) int32 are numbered in order of each component's lowest face.
        """
        m = self.n_faces
        pos = np.flatnonzero(self._same)
        f = self._order[pos - 1] // 3
        g = self._order[pos] // 3
        G = sp.coo_array((np.ones(len(pos), dtype=np.int8), (f, g)), shape=(m, m)).tocsr()
        k, lab = connected_components(G, directed=False)
        return int(k), lab


def _index_dtype(n_halfedges, n_vertices):
    """int32 when every half-edge and vertex index fits in it, else int64."""
    return np.dtype(np.int32 if max(n_halfedges, n_vertices) < np.iinfo(np.int32).max else np.int64)


def _cycles(nxt, src):
    """Split the permutation ``nxt`` of boundary half-edges into ordered vertex loops.

    Each cycle starts at its half-edge of smallest source vertex (then lowest
    position); cycles are sorted by that vertex. Positions within a cycle come
    from pointer jumping (log of the longest loop steps, vectorised).
    """
    b = len(nxt)
    idx = np.arange(b)
    G = sp.coo_array((np.ones(b, dtype=np.int8), (idx, nxt)), shape=(b, b)).tocsr()
    k, lab = connected_components(G, directed=False)
    first = np.lexsort((idx, src, lab))
    starts = np.flatnonzero(np.r_[True, lab[first][1:] != lab[first][:-1]])
    head = first[starts]  # one per cycle, in label order
    pred = np.empty(b, dtype=np.int64)
    pred[nxt] = idx
    pred[head] = -1
    dist = (pred >= 0).astype(np.int64)
    p = pred.copy()
    while True:
        live = np.flatnonzero(p >= 0)
        if not len(live):
            break
        q = p[live]
        dist[live] += dist[q]  # synchronous: dist[q] and p[q] are gathered before the updates
        p[live] = p[q]
    order = np.lexsort((dist, lab))
    sizes = np.bincount(lab, minlength=k)
    loops = np.split(src[order], np.cumsum(sizes)[:-1])
    by_start = np.argsort(src[head], kind="stable")
    return [np.ascontiguousarray(loops[c]) for c in by_start]


def mesh_topology(F, n_vertices=None):
    """The :class:`MeshTopology` of faces ``F`` (validated; see :meth:`MeshTopology.from_faces`).

    Parameters
    ----------
    F : (m, 3) array_like of int
    n_vertices : int, optional
        Default ``F.max() + 1``.

    Returns
    -------
    MeshTopology

    Examples
    --------
    Two triangles sharing an edge: a square with one boundary loop.

    >>> t = mesh_topology([[0, 1, 2], [0, 2, 3]])
    >>> t.n_edges, [lp.tolist() for lp in t.boundary_loops]
    (5, [[0, 1, 2, 3]])
    """
    return MeshTopology.from_faces(F, n_vertices)
