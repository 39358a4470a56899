"""Tests of vesselgp.mesh: cleanup counts, units, vessel ends on known shapes and real meshes."""
from __future__ import annotations


import numpy as np
import pytest

from vesselgp import tolerances as tol
from vesselgp.errors import EndsError, InvalidMeshError, NotTubularError
from vesselgp.io import read_mesh
from vesselgp.mesh import (
    CleanReport,
    MeshScale,
    VesselEnd,
    clean_mesh,
    mesh_scale,
    mesh_topology,
    select_ends,
    vessel_ends,
)
from _data import REAL



# --------------------------------------------------------------------------- #
# shape builders: surfaces of revolution about z, outward-oriented
# --------------------------------------------------------------------------- #
def revolve(rho, z, n=32, bottom=None, top=None):
    """Rings of radius rho[k] at height z[k]; ``bottom``/``top`` = z of a pole vertex or None.

    A pole at the same height as its ring makes a flat (fan) cap.
    """
    rho, z = np.asarray(rho, float), np.asarray(z, float)
    K = len(rho)
    t = 2 * np.pi * np.arange(n) / n
    V = np.c_[np.outer(rho, np.cos(t)).ravel(), np.outer(rho, np.sin(t)).ravel(), np.repeat(z, n)]
    a = np.arange(n)
    r0 = (np.arange(K - 1)[:, None] * n + a).ravel()
    r1 = (np.arange(K - 1)[:, None] * n + (a + 1) % n).ravel()
    F = [np.c_[r0, r1, r0 + n], np.c_[r1, r1 + n, r0 + n]]
    if bottom is not None:
        c = len(V)
        V = np.vstack([V, [0, 0, bottom]])
        F.append(np.c_[np.full(n, c), (a + 1) % n, a])
    if top is not None:
        c = len(V)
        V = np.vstack([V, [0, 0, top]])
        last = (K - 1) * n
        F.append(np.c_[np.full(n, c), last + a, last + (a + 1) % n])
    return V, np.vstack(F).astype(np.int64)


def tube(r=1.0, length=6.0, n=32, rings=25, r_top=None):
    """Open tube along z from 0 to length; radius r at z=0, r_top at the top."""
    z = np.linspace(0, length, rings)
    rho = np.linspace(r, r if r_top is None else r_top, rings)
    return revolve(rho, z, n)


def capped_tube(r=1.0, length=6.0, n=32, rings=25, r_top=None):
    z = np.linspace(0, length, rings)
    rho = np.linspace(r, r if r_top is None else r_top, rings)
    return revolve(rho, z, n, bottom=0.0, top=length)


def capsule(R=1.0, length=5.0, n=32, m=8):
    """Cylinder of radius R and the given length between two hemispheres."""
    phi = np.linspace(0, np.pi / 2, m + 1)[1:]
    zb = -R * np.cos(phi)
    zc = np.linspace(0, length, int(round(length / (np.pi * R / 2 / m))) + 1)[1:-1]
    rho = np.r_[R * np.sin(phi), np.full(len(zc), R), R * np.sin(phi[::-1])]
    z = np.r_[zb, zc, length - zb[::-1]]
    return revolve(rho, z, n, bottom=-R, top=length + R)


def sphere(R=1.0, n=32, m=16):
    phi = np.linspace(0, np.pi, m + 1)[1:-1]
    return revolve(R * np.sin(phi), -R * np.cos(phi), n, bottom=-R, top=R)


def torus(R=3.0, r=1.0, n=32, m=16):
    u = 2 * np.pi * np.arange(n) / n
    v = 2 * np.pi * np.arange(m) / m
    U, W = np.meshgrid(u, v, indexing="ij")
    V = np.c_[((R + r * np.cos(W)) * np.cos(U)).ravel(), ((R + r * np.cos(W)) * np.sin(U)).ravel(),
              (r * np.sin(W)).ravel()]
    i, j = np.meshgrid(np.arange(n), np.arange(m), indexing="ij")
    idx = lambda a, b: (a % n) * m + (b % m)  # noqa: E731
    i, j = i.ravel(), j.ravel()
    F = np.r_[np.c_[idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)], np.c_[idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]]
    return V, F.astype(np.int64)


def random_rigid(rng):
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    if np.linalg.det(Q) < 0:
        Q[:, 0] *= -1
    return Q, rng.normal(size=3) * 50


def by_z(ends):
    return sorted(ends, key=lambda e: e.center[2])


# --------------------------------------------------------------------------- #
# clean_mesh
# --------------------------------------------------------------------------- #
def test_clean_mesh_on_clean_tube_changes_nothing():
    V, F = tube()
    V2, F2, rep = clean_mesh(V, F)
    assert isinstance(rep, CleanReport)
    assert not rep.changed
    assert np.array_equal(V2, V) and np.array_equal(F2, F)
    assert np.array_equal(rep.vertex_map, np.arange(len(V)))
    assert "no change" in rep.summary()


def test_clean_mesh_counts_exactly_the_inserted_defects():
    V, F = tube(n=24, rings=10)
    n0, m0 = len(V), len(F)
    V, F = V.copy(), F.copy()
    # 1. five duplicated vertices; the faces of the last ring-row use the copies
    dup = np.array([100, 101, 102, 103, 104])
    dup_ids = n0 + np.arange(5)
    V = np.vstack([V, V[dup]])
    lut = np.arange(len(V))
    lut[dup] = dup_ids
    even = np.arange(len(F)) % 2 == 0
    F[even] = lut[F[even]]  # faces of even index use the copies, the others the originals
    assert np.isin(dup, F).all() and np.isin(dup_ids, F).all()
    # 2. a zero-area face on a vertical edge (same x, y: exactly collinear)
    a, b = 0, 24  # vertex 0 and the one above it
    mid = len(V)
    V = np.vstack([V, [V[a, 0], V[a, 1], 0.5 * (V[a, 2] + V[b, 2])]])
    # 3. a non-manifold edge: a third face on edge (24, 25) with a new vertex inside
    fin = len(V)
    V = np.vstack([V, 0.5 * (V[24] + V[25]) * 0.5 + [0, 0, 0.1]])
    # 4. a small separate component (a tetrahedron far away), 5. an unreferenced vertex
    tet0 = len(V)
    V = np.vstack([V, [[10, 10, 10], [10.1, 10, 10], [10, 10.1, 10], [10, 10, 10.1]], [[-5, -5, -5]]])
    tet = tet0 + np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    F = np.vstack([F, [[a, b, mid]], [[24, 25, fin]], tet])
    V2, F2, rep = clean_mesh(V, F)
    assert rep.vertices_before == len(V) and rep.faces_before == len(F)
    assert rep.duplicate_vertices_merged == 5
    assert rep.unreferenced_vertices_removed == 1
    assert rep.zero_area_faces_removed == 1
    assert rep.non_manifold_edges_repaired == 1
    assert rep.non_manifold_faces_removed == 1
    assert rep.components_found == 2 and rep.components_removed == 1
    assert rep.duplicate_faces_removed == 0
    assert rep.changed
    # the result is the original tube (same vertex set, same face count)
    assert rep.faces_after == m0 and len(F2) == m0
    assert rep.vertices_after == n0 and len(V2) == n0
    assert np.array_equal(V2, V[rep.vertex_map])
    np.testing.assert_array_equal(np.unique(V2, axis=0), np.unique(tube(n=24, rings=10)[0], axis=0))
    s = rep.summary()
    assert "merged 5 duplicate vertices" in s and "dropped 1 small components" in s


def test_clean_mesh_duplicate_faces_and_orientation():
    V, F = capped_tube(n=16, rings=6)
    F = F.copy()
    F[:10] = F[:10, [0, 2, 1]]  # flip ten faces
    F = np.vstack([F, F[20:22]])  # two duplicate faces
    V2, F2, rep = clean_mesh(V, F)
    assert rep.duplicate_faces_removed == 2
    assert rep.faces_flipped == 10
    vol = np.einsum("ij,ij->", V2[F2[:, 0]], np.cross(V2[F2[:, 1]], V2[F2[:, 2]])) / 6
    assert vol > 0  # closed surface oriented outward
    # every edge is traversed once in each direction: coherent orientation
    D = F2[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    assert len(np.unique(D, axis=0)) == len(D)


def test_clean_mesh_coherent_input_is_kept_or_turned_outward():
    V, F = capped_tube(n=16, rings=6)
    V2, F2, rep = clean_mesh(V, F)  # coherent and outward: nothing to do
    assert rep.faces_flipped == 0 and not rep.changed
    np.testing.assert_array_equal(F2, F)
    V3, F3, rep3 = clean_mesh(V, F[:, [0, 2, 1]])  # coherent but inward: every face turns
    assert rep3.faces_flipped == len(F)
    np.testing.assert_array_equal(F3, F)


def test_clean_mesh_counts_flips_of_kept_faces_only():
    V, F = tube(n=12, rings=4)
    tet0 = len(V)
    V = np.vstack([V, [[10, 10, 10], [10.1, 10, 10], [10, 10.1, 10], [10, 10, 10.1]]])
    tet = tet0 + np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 3, 2]])  # its last face flipped
    _, F2, rep = clean_mesh(V, np.vstack([F, tet]))
    assert rep.components_removed == 1 and len(F2) == len(F)
    assert rep.faces_flipped == 0  # the flipped face was in the dropped component
    np.testing.assert_array_equal(F2, F)
    # kept, it is counted: one face of the tetrahedron flipped, then all four outward or none
    _, F3, rep3 = clean_mesh(V[tet0:], tet - tet0)
    assert rep3.faces_flipped in (1, 3)
    assert mesh_topology(F3).is_coherent and mesh_topology(F3).is_closed


def test_clean_mesh_keep_largest_false_and_errors():
    V, F = tube(n=12, rings=4)
    V = np.vstack([V, [[9, 9, 9], [9.1, 9, 9], [9, 9.1, 9]]])
    F = np.vstack([F, [[len(V) - 3, len(V) - 2, len(V) - 1]]])
    _, F2, rep = clean_mesh(V, F, keep_largest=False)
    assert rep.components_found == 2 and rep.components_removed == 0 and len(F2) == len(F)
    with pytest.raises(InvalidMeshError):
        clean_mesh(np.full((3, 3), np.nan), [[0, 1, 2]])


# --------------------------------------------------------------------------- #
# mesh_scale
# --------------------------------------------------------------------------- #
@pytest.mark.parametrize("factor, units", [(1.0, "mm"), (1e-3, "m"), (1e3, "um")])
def test_mesh_scale_units(factor, units):
    V, F = tube(r=3.0, length=40.0, n=32, rings=60)
    s = mesh_scale(V * factor, F)
    assert isinstance(s, MeshScale)
    assert s.units_guess == units
    assert (s.warning is None) == (units == "mm")
    assert s.bbox_diagonal == pytest.approx(np.linalg.norm([6, 6 * np.sin(np.pi / 2), 40]) * factor, rel=1e-3)
    assert s.median_edge > 0


def test_mesh_scale_cm_and_radius_range():
    V, F = tube(r=0.3, length=4.0, n=64, rings=120)  # a 4 cm vessel in centimetres
    s = mesh_scale(V, F)
    assert s.units_guess == "cm" and "centimetres" in s.warning
    V, F = tube(r=2.0, length=30.0, r_top=1.0)
    ends = vessel_ends(V, F)
    assert mesh_scale(V, F, ends).radius_range == pytest.approx((1.0, 2.0), rel=1e-2)


# --------------------------------------------------------------------------- #
# vessel_ends on synthetic shapes with known answers
# --------------------------------------------------------------------------- #
def test_open_tapered_tube_ends():
    V, F = tube(r=2.0, length=10.0, r_top=1.0, n=40)
    ends = vessel_ends(V, F)
    assert [e.kind for e in ends] == ["open", "open"]
    big, small = ends  # sorted by radius
    np.testing.assert_allclose(big.center, [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(small.center, [0, 0, 10], atol=1e-12)
    np.testing.assert_allclose(big.direction, [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(small.direction, [0, 0, 1], atol=1e-12)
    assert big.radius == pytest.approx(2.0, rel=1e-12) and small.radius == pytest.approx(1.0, rel=1e-12)
    assert len(big.loop) == 40 and set(big.vertices) == set(big.loop)
    for e in ends:  # loop counter-clockwise about the outward direction
        P = V[e.loop] - e.center
        assert np.cross(P, np.roll(P, -1, axis=0)).sum(0) @ e.direction > 0


def test_capped_tube_ends():
    V, F = capped_tube(r=1.5, length=8.0, n=36, rings=30)
    ends = by_z(vessel_ends(V, F))
    assert [e.kind for e in ends] == ["cap", "cap"]
    for e, z, d in zip(ends, (0.0, 8.0), (-1, 1)):
        np.testing.assert_allclose(e.center, [0, 0, z], atol=1e-9)
        np.testing.assert_allclose(e.direction, [0, 0, d], atol=1e-9)
        assert e.radius == pytest.approx(1.5, rel=1e-9)
        assert len(e.loop) == 36 and len(e.vertices) == 37 and len(e.faces) == 36
        assert np.allclose(V[e.vertices, 2], z)


def test_capsule_rounded_ends():
    R, L = 1.0, 5.0
    V, F = capsule(R, L)
    ends = by_z(vessel_ends(V, F))
    assert [e.kind for e in ends] == ["rounded", "rounded"]
    for e, z, d in zip(ends, (0.0, L), (-1, 1)):
        np.testing.assert_allclose(e.center, [0, 0, z], atol=0.1 * R)
        np.testing.assert_allclose(e.direction, [0, 0, d], atol=1e-6)
        assert e.radius == pytest.approx(R, rel=0.1)
        tipz = z + d * R
        assert np.any(np.isclose(V[e.vertices, 2], tipz))  # the pole is in the end region
        assert np.all(np.abs(V[e.vertices, 2] - tipz) <= 0.5 * R + 1e-9)


def test_sphere_and_torus_are_not_tubular():
    with pytest.raises(NotTubularError, match="not tubular"):
        vessel_ends(*sphere())
    with pytest.raises(NotTubularError, match="not tubular"):
        vessel_ends(*torus())


def test_one_open_end_and_one_rounded_end():
    V, F = capsule(1.0, 5.0)
    keep = ~np.all(V[F][:, :, 2] < -0.2, axis=1)  # cut the bottom hemisphere open
    ends = by_z(vessel_ends(V, F[keep]))
    assert [e.kind for e in ends] == ["open", "rounded"]
    assert ends[1].direction[2] == pytest.approx(1.0, abs=1e-6)


def test_ends_invariant_under_rigid_motion_and_renumbering():
    rng = np.random.default_rng(7)
    for V, F in (tube(r=2.0, length=12.0, r_top=1.2), capped_tube(r=1.0, r_top=1.6),
                 *[read_mesh(REAL / "vmtk_abdominal_aorta_iliac_bifurcation_open.stl")]):
        ends = vessel_ends(V, F)
        Q, t = random_rigid(rng)
        perm = rng.permutation(len(V))
        inv = np.argsort(perm)
        V2 = (V @ Q.T + t)[perm]
        F2 = inv[F][rng.permutation(len(F))]
        ends2 = vessel_ends(V2, F2)
        assert [e.kind for e in ends2] == [e.kind for e in ends]
        for a, b in zip(ends, ends2):
            np.testing.assert_allclose(b.center, a.center @ Q.T + t, atol=1e-8 * (1 + np.abs(t).max()))
            np.testing.assert_allclose(b.direction, a.direction @ Q.T, atol=1e-9)
            assert b.radius == pytest.approx(a.radius, rel=1e-9)
            assert set(perm[b.loop]) == set(a.loop)
            assert set(perm[b.vertices]) == set(a.vertices)


# --------------------------------------------------------------------------- #
# real meshes (values from /work/shared/data/real/SOURCES.md)
# --------------------------------------------------------------------------- #
def _match(ends, expected, ctol, rtol):
    for e, (c, r) in zip(ends, expected):
        np.testing.assert_allclose(e.center, c, atol=ctol)
        assert e.radius == pytest.approx(r, abs=rtol)


def test_real_aorta_bifurcation_three_open_ends():
    V, F = read_mesh(REAL / "vmtk_abdominal_aorta_iliac_bifurcation_open.stl")
    ends = vessel_ends(V, F)
    assert [e.kind for e in ends] == ["open"] * 3
    assert [len(e.loop) for e in ends] == [113, 66, 72]
    _match(ends, [((220.98, 177.78, 20.99), 7.69), ((235.17, 101.55, 28.97), 4.41),
                  ((210.10, 102.86, 30.74), 4.38)], ctol=0.5, rtol=0.05)
    # the aorta end points up the body (+y), the iliac ends down
    assert ends[0].direction[1] > 0.9 and ends[1].direction[1] < -0.9 and ends[2].direction[1] < -0.9
    with pytest.raises(EndsError, match=r"mesh has 3 open ends; pass ends=\(i, j\)"):
        select_ends(ends)
    a, b = select_ends(ends, (0, 2))
    assert a is ends[0] and b is ends[2]


def test_real_coronary_two_open_ends():
    V, F = read_mesh(REAL / "xra_coronary_single_branch_open.stl")
    ends = vessel_ends(V, F)
    assert [e.kind for e in ends] == ["open", "open"]
    _match(ends, [((37.31, -30.85, 49.91), 1.45), ((-10.79, -11.39, 88.39), 1.27)], ctol=0.05, rtol=0.02)
    assert select_ends(ends) == (ends[0], ends[1])


def test_real_capped_lumen_two_caps():
    V, F = read_mesh(REAL / "dfemtoolz_artery_segment_lumen_capped.stl")
    ends = vessel_ends(V, F)
    assert [e.kind for e in ends] == ["cap", "cap"]
    _match(ends, [((164.5, 79.3, 17.1), 2.46), ((134.8, 109.3, 51.8), 1.40)], ctol=0.1, rtol=0.05)
    # outward: the cap normal points away from the other end of the tube
    for e, other in ((ends[0], ends[1]), (ends[1], ends[0])):
        assert e.direction @ (e.center - other.center) > 0
        assert e.faces is not None and len(e.faces) > 50


# --------------------------------------------------------------------------- #
# select_ends
# --------------------------------------------------------------------------- #
def _fake_ends(k):
    return tuple(VesselEnd("open", np.arange(3), np.arange(3), np.r_[i, 0.0, 0], np.r_[0, 0, 1.0], 1.0 + i)
                 for i in range(k))


@pytest.mark.parametrize("arg", [(0, 0), (0, 3), (-1, 1), (0.0, 1), "01", 5, (0, 1, 2), (True, 0)])
def test_select_ends_rejects_bad_choices(arg):
    with pytest.raises(EndsError):
        select_ends(_fake_ends(3), arg)


def test_select_ends_two_and_one():
    e = _fake_ends(2)
    assert select_ends(e) == (e[0], e[1])
    assert select_ends(e, (1, 0)) == (e[1], e[0])
    with pytest.raises(EndsError, match="1 end"):
        select_ends(_fake_ends(1))
    with pytest.raises(EndsError, match="0 r=1 at"):
        select_ends(_fake_ends(3))


def test_cap_tolerances_are_used():
    assert 0 < tol.CAP_FLATNESS < 0.5 * np.pi - tol.CAP_RIM_TILT  # a flat patch's faces never meet at a rim's crease


@pytest.mark.parametrize("chunk", [1, 7, 10**9])
def test_voronoi_areas_are_libigls_mass_matrix_in_any_chunks(monkeypatch, chunk):
    """Summing libigl's Voronoi mass matrix over face chunks gives its diagonal for the whole mesh
    (obtuse faces of a jittered real mesh included, and a last vertex no face uses)."""
    import igl

    from vesselgp.mesh._geometry import voronoi_areas

    V, F = read_mesh(REAL / "xra_coronary_single_branch_open.stl")
    V = V + np.random.default_rng(3).normal(scale=0.3 * float(np.median(igl.edge_lengths(V, F))), size=V.shape)
    V = np.vstack([V, V[:1] + 1.0])
    truth = np.zeros(len(V))
    d = igl.massmatrix(V, F, igl.MASSMATRIX_TYPE_VORONOI).diagonal()
    truth[:len(d)] = d
    monkeypatch.setattr(tol, "AREA_FACE_CHUNK", chunk)
    np.testing.assert_allclose(voronoi_areas(V, F), truth, rtol=1e-12, atol=1e-15 * truth.max())
    assert voronoi_areas(V, F)[-1] == 0.0


def test_voronoi_areas_of_known_triangles():
    """Meyer et al.'s mixed areas by hand: an acute equilateral triangle shares its area in thirds;
    a right triangle's circumcentre is its hypotenuse's midpoint (half the area at the right angle, a
    quarter at each other corner); an obtuse one gives half of its area to the obtuse corner and a
    quarter to each other corner."""
    from vesselgp.mesh._geometry import voronoi_areas

    F = np.array([[0, 1, 2]])
    eq = np.array([[0.0, 0, 0], [2, 0, 0], [1, np.sqrt(3), 0]])
    np.testing.assert_allclose(voronoi_areas(eq, F), np.full(3, np.sqrt(3) / 3), rtol=1e-14)
    right = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0]])  # area 2, right angle at corner 0
    np.testing.assert_allclose(voronoi_areas(right, F), [1.0, 0.5, 0.5], rtol=1e-14)
    obtuse = np.array([[0.0, 0, 0], [4, 0, 0], [2, 0.5, 0]])  # area 1, obtuse at corner 2
    np.testing.assert_allclose(voronoi_areas(obtuse, F), [0.25, 0.25, 0.5], rtol=1e-14)
