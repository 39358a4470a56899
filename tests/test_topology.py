"""Tests of vesselgp.mesh.topology (MeshTopology) on small meshes with known answers, and of stitch."""
from __future__ import annotations

import igl
import numpy as np
import pytest
import scipy.sparse as sp
from _data import REAL

from vesselgp.errors import EndsError, InvalidMeshError, MismatchError
from vesselgp.io import read_mesh
from vesselgp.mesh import MeshTopology, mesh_topology, stitch, vessel_ends
from vesselgp.mesh.topology import MeshTopology as TopologyFromModule
from vesselgp.synthetic import synthetic_vessel

TET = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def cylinder(n=12, rings=5):
    """Open cylinder: ``rings`` rings of ``n`` vertices, outward-oriented faces."""
    t = 2 * np.pi * np.arange(n) / n
    z = np.repeat(np.arange(rings, dtype=float), n)
    V = np.c_[np.tile(np.cos(t), rings), np.tile(np.sin(t), rings), z]
    a = np.arange(n)
    r0 = (np.arange(rings - 1)[:, None] * n + a).ravel()
    r1 = (np.arange(rings - 1)[:, None] * n + (a + 1) % n).ravel()
    return V, np.vstack([np.c_[r0, r1, r0 + n], np.c_[r1, r1 + n, r0 + n]])


def brute_edges(F):
    H = np.sort(np.c_[F.ravel(), F[:, [1, 2, 0]].ravel()], axis=1)
    return np.unique(H, axis=0, return_counts=True)


def follows_halfedges(t, loop):
    return bool(t.has_halfedges(loop, np.roll(loop, -1)).all())


# --------------------------------------------------------------------------- #
# known answers
# --------------------------------------------------------------------------- #
def test_tetrahedron():
    t = mesh_topology(TET)
    assert t.n_vertices == 4 and t.n_faces == 4 and t.n_edges == 6
    np.testing.assert_array_equal(t.edges, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])
    assert t.is_closed and t.is_coherent and t.is_edge_manifold
    assert t.vertex_components[0] == 1 and t.face_components[0] == 1
    assert t.euler_characteristic == 2
    assert len(t.boundary_edges) == 0 and t.boundary_loops == ()
    np.testing.assert_array_equal(t.edge_face_count, 2)
    np.testing.assert_array_equal(t.edge_up_count, 1)
    assert len(t.incoherent_edges) == 0 and len(t.nonmanifold_edges) == 0
    # every corner edge maps to its undirected edge; twins are opposite half-edges
    for f in range(4):
        for i in range(3):
            a, b = TET[f, i], TET[f, (i + 1) % 3]
            assert tuple(t.edges[t.face_edges[f, i]]) == (min(a, b), max(a, b))
            h = t.twin[3 * f + i]
            assert tuple(t.halfedge_vertices(h)) == (b, a)
    assert t.adjacency.shape == (4, 4) and t.adjacency.sum() == 12
    assert TopologyFromModule is MeshTopology


def test_open_cylinder_has_two_boundary_loops_of_known_size():
    n, rings = 12, 5
    V, F = cylinder(n, rings)
    t = MeshTopology.from_faces(F, len(V))
    assert t.n_edges == n * rings + len(F)  # Euler characteristic 0
    assert t.euler_characteristic == 0
    assert not t.is_closed and t.is_coherent
    assert len(t.boundary_edges) == 2 * n
    loops = t.boundary_loops
    assert [len(lp) for lp in loops] == [n, n]
    assert set(loops[0]) == set(range(n)) and set(loops[1]) == set(range((rings - 1) * n, rings * n))
    assert [lp[0] for lp in loops] == [0, (rings - 1) * n]  # each starts at its smallest vertex
    assert all(follows_halfedges(t, lp) for lp in loops)
    assert t.boundary_faces.sum() == 2 * n
    assert t.vertex_components[0] == 1 and t.face_components[0] == 1


def test_two_disjoint_triangles_are_two_components():
    F = np.array([[0, 1, 2], [3, 4, 5]])
    t = mesh_topology(F, 7)  # vertex 6 unreferenced
    k, lab = t.vertex_components
    assert k == 3 and lab[0] == lab[1] == lab[2] != lab[3] == lab[4] == lab[5] != lab[6]
    k, lab = t.face_components
    assert k == 2 and lab[0] != lab[1]
    assert [lp.tolist() for lp in t.boundary_loops] == [[0, 1, 2], [3, 4, 5]]
    np.testing.assert_array_equal(t.referenced, [True] * 6 + [False])
    assert t.euler_characteristic == 2  # two disks


def test_vertex_components_are_libigls_on_several_shuffled_pieces():
    """Three copies of a real mesh and two unreferenced vertices, vertices and faces shuffled: the
    components (found on the adjacency as strongly connected ones) are libigl's partition."""
    V, F = read_mesh(REAL / "xra_coronary_single_branch_open.stl")
    n = len(V)
    rng = np.random.default_rng(4)
    F3 = np.vstack([F, F + n, F + 2 * n])
    perm = rng.permutation(3 * n + 2)  # vertex 3n and 3n + 1 are referenced by no face
    F3 = perm[F3][rng.permutation(len(F3))]
    k, lab = mesh_topology(F3, 3 * n + 2).vertex_components
    ref = np.zeros(3 * n + 2, bool)
    ref[F3.ravel()] = True
    truth = igl.vertex_components(F3)[: len(ref)]
    assert k == 3 + 2 == len(np.unique(truth[ref])) + int((~ref).sum())
    pairs = np.unique(np.c_[lab[ref], truth[ref]], axis=0)  # one label of ours for each of libigl's
    assert len(pairs) == 3 == len(np.unique(pairs[:, 0])) == len(np.unique(pairs[:, 1]))
    assert len(np.unique(lab[~ref])) == 2 and not np.isin(lab[~ref], lab[ref]).any()


def test_flipped_face_is_detected():
    F = TET.copy()
    F[3] = F[3, ::-1]
    t = mesh_topology(F)
    assert t.is_edge_manifold and not t.is_coherent
    np.testing.assert_array_equal(np.sort(t.incoherent_edges), np.sort(t.face_edges[3]))
    assert t.boundary_loops == ()  # closed: no boundary, whatever the orientation
    # an open mesh with one flipped face: its loops are undefined
    _, Fc = cylinder(8, 3)
    Fc = Fc.copy()
    Fc[5] = Fc[5, [0, 2, 1]]
    with pytest.raises(InvalidMeshError, match="inconsistently oriented.*clean_mesh"):
        _ = mesh_topology(Fc).boundary_loops


def test_non_manifold_edge():
    F = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])  # edge (0, 1) has three faces
    t = mesh_topology(F)
    e = t.edge_index([0], [1])[0]
    np.testing.assert_array_equal(t.nonmanifold_edges, [e])
    assert t.edge_face_count[e] == 3 and not t.is_edge_manifold and not t.is_coherent
    np.testing.assert_array_equal(t.faces_of_edge(e), [0, 1, 2])
    np.testing.assert_array_equal(t.edge_faces[e], [0, 1])
    assert t.twin[0] == -1  # no twin on a non-manifold edge
    assert t.face_components[0] == 1


def test_pinch_vertex_loops():
    # two squares touching at vertex 0 (a bow-tie): two loops through vertex 0
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 4, 5], [0, 5, 6]])
    t = mesh_topology(F)
    loops = [lp.tolist() for lp in t.boundary_loops]
    assert loops == [[0, 1, 2, 3], [0, 4, 5, 6]]
    assert t.vertex_components[0] == 1 and t.face_components[0] == 2
    # one square with a fan of two triangles: vertex 0 on a single loop
    loops = mesh_topology([[0, 1, 2], [0, 2, 3], [3, 4, 0]]).boundary_loops
    assert [lp.tolist() for lp in loops] == [[0, 1, 2, 3, 4]]


def test_edge_lookups_and_graph():
    V, F = cylinder(6, 3)
    t = mesh_topology(F, len(V))
    E = t.edges
    np.testing.assert_array_equal(t.edge_index(E[:, 1], E[:, 0]), np.arange(t.n_edges))
    np.testing.assert_array_equal(t.edge_index([0, 0, -1, 99], [3, 0, 1, 0]), [-1, -1, -1, -1])
    # each face's own half-edges exist, their reverses only across interior edges
    a, b = F.ravel(), F[:, [1, 2, 0]].ravel()
    assert t.has_halfedges(a, b).all()
    interior = t.edge_face_count[t.face_edges.ravel()] == 2
    np.testing.assert_array_equal(t.has_halfedges(b, a), interior)
    G = t.edge_graph(V)
    assert (G != G.T).nnz == 0 and G.nnz == 2 * t.n_edges
    np.testing.assert_allclose(G[E[:, 0], E[:, 1]], np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1))


@pytest.mark.parametrize("seed", [0, 1])
def test_tables_match_brute_force_and_igl(seed):
    V, F = read_mesh(REAL / "xra_coronary_single_branch_open.stl")
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(V))
    F = np.argsort(perm)[F][rng.permutation(len(F))]
    t = mesh_topology(F, len(V))
    E, cnt = brute_edges(F)
    np.testing.assert_array_equal(t.edges, E)
    np.testing.assert_array_equal(t.edge_face_count, cnt)
    loops = igl.boundary_loop_all(F)
    assert [lp.tolist() for lp in t.boundary_loops] == [list(lp) for lp in loops]
    # edge_faces pairs are igl's triangle-triangle adjacency
    TT, _ = igl.triangle_triangle_adjacency(F)
    ef = t.edge_faces[t.face_edges]  # (m, 3, 2): the two faces of each corner edge
    other = np.where(ef[..., 0] == np.arange(len(F))[:, None], ef[..., 1], ef[..., 0])
    np.testing.assert_array_equal(other, TT)
    # the shared symmetric pattern is libigl's adjacency, rows sorted; edge_matrix puts w[e] on both sides
    A = t.adjacency
    assert A.has_sorted_indices and A.nnz == 2 * t.n_edges
    assert (A != sp.csr_array(igl.adjacency_matrix(F))).nnz == 0
    w = rng.random(t.n_edges)
    W = t.edge_matrix(w)
    np.testing.assert_array_equal(W[E[:, 0], E[:, 1]], w)
    np.testing.assert_array_equal(W[E[:, 1], E[:, 0]], w)
    with pytest.raises(MismatchError, match="one value per edge"):
        t.edge_matrix(w[:-1])


@pytest.mark.parametrize("F, n", [([[0, 1]], None), ([[0, 1, -1]], None), ([[0, 1, 5]], 4),
                                  ([[0, 1, 2.5]], None), ("abc", None)])
def test_from_faces_rejects_bad_faces(F, n):
    with pytest.raises(InvalidMeshError):
        MeshTopology.from_faces(F, n)


def test_tables_are_read_only_and_input_untouched():
    F = TET.copy()
    t = mesh_topology(F)
    assert F.flags.writeable
    with pytest.raises(ValueError):
        t.edges[0, 0] = 5
    with pytest.raises(ValueError):
        t.F[0, 0] = 5


def test_vessel_ends_reuses_a_given_topology():
    V, F = cylinder(16, 8)
    t = mesh_topology(F, len(V))
    a, b = vessel_ends(V, F), vessel_ends(V, F, topology=t)
    assert [e.radius for e in a] == [e.radius for e in b]
    with pytest.raises(InvalidMeshError, match="another mesh"):
        vessel_ends(V, F, topology=mesh_topology(F[:-2], len(V)))


# --------------------------------------------------------------------------- #
# stitch, from its place in the mesh package
# --------------------------------------------------------------------------- #
def test_stitch_joins_two_tubes_into_one_coherent_mesh():
    a = synthetic_vessel("straight", n_around=8, remesh=False)
    b = synthetic_vessel([[0, 0, 31], [0, 0, 41], [0, 0, 51], [0, 0, 61]], n_around=12, remesh=False)
    ring_a = np.arange(len(a.V) - 8, len(a.V))
    Vj, Fj = stitch(a.V, a.F, ring_a, b.V, b.F, np.arange(12))
    assert len(Vj) == len(a.V) + len(b.V)
    assert len(Fj) == len(a.F) + len(b.F) + 8 + 12
    t = mesh_topology(Fj, len(Vj))
    assert t.is_coherent and t.face_components[0] == 1
    assert [len(lp) for lp in t.boundary_loops] == [8, 12]  # the two far ends remain open
    # other mesh oriented the other way: flipped to match
    Vk, Fk = stitch(a.V, a.F, ring_a, b.V, b.F[:, ::-1], np.arange(12))
    assert mesh_topology(Fk, len(Vk)).is_coherent
    with pytest.raises(EndsError, match="not one boundary loop"):
        stitch(a.V, a.F, ring_a[:-1], b.V, b.F, np.arange(12))
    flat = b.V.copy()
    flat[:12, 1] = 0.0  # the other ring collapsed onto a line
    with pytest.raises(EndsError, match="other_loop_ids ring encloses no area"):
        stitch(a.V, a.F, ring_a, flat, b.F, np.arange(12))


# --------------------------------------------------------------------------- #
# compact index tables (peak memory, issue #16)
# --------------------------------------------------------------------------- #
def test_int32_tables_are_the_int64_tables(monkeypatch):
    """The int32 tables of an ordinary mesh hold exactly what int64 ones would."""
    import vesselgp.mesh.topology as topology

    V, F = read_mesh(REAL / "xra_coronary_single_branch_open.stl")
    small = mesh_topology(F, len(V))
    assert small.index_dtype == np.int32 and small.edges.dtype == np.int32
    monkeypatch.setattr(topology, "_index_dtype", lambda *_: np.dtype(np.int64))
    wide = mesh_topology(F, len(V))
    assert wide.edges.dtype == np.int64
    for name in ("edges", "face_edges", "edge_face_count", "edge_up_count", "edge_halfedges", "edge_faces",
                 "twin", "boundary_halfedges"):
        np.testing.assert_array_equal(getattr(small, name), getattr(wide, name), err_msg=name)
    assert [lp.tolist() for lp in small.boundary_loops] == [lp.tolist() for lp in wide.boundary_loops]
    assert all(lp.dtype == np.int64 for lp in small.boundary_loops)
    assert small.face_components[0] == wide.face_components[0] == 1


def test_index_dtype_widens_past_int32():
    from vesselgp.mesh.topology import _index_dtype

    assert _index_dtype(3 * 1000, 500) == np.int32
    assert _index_dtype(2**31, 10) == np.int64 and _index_dtype(30, 2**31) == np.int64
