"""vessel_ends on vessel trees and voxel surfaces (issue #13, items 1 and 4).

Every terminal end is found and nothing else: open loops, flat caps of any
size (down to an outlet one edge across), rounded tips; a raw voxel staircase
is refused with an EndsError that names the smoothing. Truths come from the
shapes' construction (synthetic trees' Bezier centre lines, surfaces of
revolution, lofted rings, SOURCES.md of the real meshes), never from the code
under test.
"""
from __future__ import annotations

import numpy as np
import pytest

from vesselgp import tolerances as tol
from vesselgp.errors import EndsError, NotTubularError
from vesselgp.io import read_mesh
from vesselgp.mesh import VesselEnd, clean_mesh, mesh_topology, select_ends, vessel_ends
from vesselgp.mesh._ends_format import format_point
from vesselgp.mesh._ends_staircase import staircase_stats
from vesselgp.synthetic import synthetic_vessel
from vesselgp.synthetic_anatomy import clip_and_cap  # noqa: F401 (test_tree imports it from here)
from vesselgp.synthetic_tree import synthetic_tree

from _data import REAL
from test_mesh import revolve  # the same surfaces of revolution as the mesh tests

VOXEL = 0.5
#: Accuracy asked of every end (issue #13): centre within 0.2 radius, radius within 15 %,
#: outward direction within 15 degrees.
CENTER_RADII = 0.2
RADIUS_REL = 0.15
DIRECTION_DEG = 15.0


# --------------------------------------------------------------------------- #
# matching found ends to true ends
# --------------------------------------------------------------------------- #
def angle_deg(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.degrees(np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1))))


def assert_ends_match(found, truth):
    """Each true end (kind, center, radius, direction) has exactly one found end, and no end is extra.

    ``truth`` is a list of (kind, center, radius, direction). Returns the found end of each truth.
    """
    assert len(found) == len(truth), (
        f"{len(found)} ends found, {len(truth)} expected: {[e.describe() for e in found]}")
    used, out = set(), []
    for kind, c, r, d in truth:
        dist = [np.linalg.norm(e.center - c) for e in found]
        j = int(np.argmin(dist))
        e = found[j]
        assert j not in used, f"two true ends matched {e.describe()}"
        used.add(j)
        assert e.kind == kind, f"{e.describe()} should be {kind} (true centre {c})"
        assert dist[j] < CENTER_RADII * r, f"{e.describe()}: centre off by {dist[j] / r:.2f} radii"
        assert abs(e.radius - r) < RADIUS_REL * r, f"{e.describe()}: radius {e.radius:.4g}, true {r:.4g}"
        assert angle_deg(e.direction, d) < DIRECTION_DEG, (
            f"{e.describe()}: direction off by {angle_deg(e.direction, d):.1f} deg")
        out.append(e)
    return out


def tree_truth(tree):
    return [(e.kind, e.center, e.radius, e.direction) for e in tree.truth.ends]


# --------------------------------------------------------------------------- #
# shapes
# --------------------------------------------------------------------------- #
def capsule(R=1.0, length=5.0, n=32, m=8):
    """A cylinder of radius R along z from 0 to ``length`` between two hemispheres."""
    phi = np.linspace(0, np.pi / 2, m + 1)[1:]
    zb = -R * np.cos(phi)
    zc = np.linspace(0, length, round(length / (np.pi * R / 2 / m)) + 1)[1:-1]
    rho = np.r_[R * np.sin(phi), np.full(len(zc), R), R * np.sin(phi[::-1])]
    z = np.r_[zb, zc, length - zb[::-1]]
    return revolve(rho, z, n, bottom=-R, top=length + R)


def loft(rings, fan_bottom=True, fan_top=False):
    """A closed tube along +z through rings (radius, z, count) of any vertex counts.

    Consecutive rings are joined by one strip ordered by angle. The bottom is
    capped by a fan from a centre vertex, the top by a fan from its first
    vertex (no centre vertex: 1 triangle for a ring of 3, 2 for a ring of 4)
    unless ``fan_top``.
    """
    V, ids, ang = [], [], []
    for r, z, k in rings:
        t = 2 * np.pi * (np.arange(k) + 0.5) / k  # half a step: no vertex on an axis plane
        ids.append(np.arange(len(V), len(V) + k))
        ang.append(t)
        V.extend(np.c_[r * np.cos(t), r * np.sin(t), np.full(k, z)])
    F = []
    for (a, ta), (b, tb) in zip(zip(ids, ang), zip(ids[1:], ang[1:])):
        na, nb = len(a), len(b)
        i = j = 0
        while i < na or j < nb:
            nxt_a = ta[(i + 1) % na] + 2 * np.pi * ((i + 1) // na)
            nxt_b = tb[(j + 1) % nb] + 2 * np.pi * ((j + 1) // nb)
            if j == nb or (i < na and nxt_a <= nxt_b):
                F.append((a[i % na], a[(i + 1) % na], b[j % nb]))
                i += 1
            else:
                F.append((a[i % na], b[(j + 1) % nb], b[j % nb]))
                j += 1
    lo, hi = ids[0], ids[-1]
    if fan_bottom:
        V.append([0.0, 0.0, rings[0][1]])
        F.extend((len(V) - 1, lo[(q + 1) % len(lo)], lo[q]) for q in range(len(lo)))
    if fan_top:
        V.append([0.0, 0.0, rings[-1][1]])
        F.extend((len(V) - 1, hi[q], hi[(q + 1) % len(hi)]) for q in range(len(hi)))
    else:
        F.extend((hi[0], hi[q], hi[q + 1]) for q in range(1, len(hi) - 1))
    return np.array(V, float), np.array(F, np.int64)


def outlet_tube(k):
    """A capped tube of radius 1 (24 around) narrowing to an outlet ring of ``k`` vertices.

    The outlet (radius 0.2, one edge across: its diameter is about 1.5 median
    edges) is closed by k - 2 triangles. Returns V, F and the outlet's radius
    (mean rim distance) and height.
    """
    rings = [(1.0, z, 24) for z in np.arange(0.0, 4.01, 0.25)]
    rings += [(0.5, 4.5, 12), (0.28, 5.0, 6)]
    r = 0.2
    rings += [(r, z, k) for z in (5.5, 6.0, 6.5)]
    V, F = loft(rings)
    return V, F, r, 6.5


def tiny_fan_outlet():
    """Structured capped tube tapering from radius 1 to an outlet of radius 0.08 (0.3 median edges)."""
    z = np.linspace(0, 6, 25)
    return revolve(np.linspace(1.0, 0.08, 25), z, 32, bottom=0.0, top=6.0)


def random_rigid(rng):
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    if np.linalg.det(Q) < 0:
        Q[:, 0] *= -1
    return Q, rng.normal(size=3) * 20


def voxel_faces(occ, spacing=(1.0, 1.0, 1.0)):
    """Boundary faces of the occupied voxels (two triangles each), outward: a raw voxel surface."""
    P = np.pad(occ, 1)
    quads = []
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        lo, hi = [slice(None)] * 3, [slice(None)] * 3
        lo[a], hi[a] = slice(None, -1), slice(1, None)
        D = P[tuple(hi)].astype(np.int8) - P[tuple(lo)].astype(np.int8)
        for sign in (-1, 1):
            base = np.argwhere(D == sign)
            base[:, a] += 1
            corner = np.zeros((4, 3), np.int64)
            corner[[1, 2], b] = 1
            corner[[2, 3], c] = 1
            Q = base[:, None, :] + corner[None]
            quads.append(Q if sign == -1 else Q[:, ::-1])
    Q = np.concatenate(quads).reshape(-1, 3)
    pts, inv = np.unique(Q, axis=0, return_inverse=True)
    q = inv.reshape(-1, 4)
    return pts * np.asarray(spacing), np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]]).astype(np.int64)


def bent_occupancy(R=6.0, bend=40.0, tilt=(0.3, 0.2)):
    """Voxels (unit spacing) of a tube of radius R about a tilted arc of radius ``bend``, flat ends."""
    from scipy.spatial import cKDTree

    c, s = np.cos(tilt[0]), np.sin(tilt[0])
    Q = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    c, s = np.cos(tilt[1]), np.sin(tilt[1])
    Q = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) @ Q
    th = np.linspace(0.2, 2.6, 400)
    P = np.c_[bend * np.cos(th), bend * np.sin(th), 0 * th] @ Q.T
    lo, hi = P.min(0) - R - 3, P.max(0) + R + 3
    g = [np.arange(np.floor(a), np.ceil(b) + 1) for a, b in zip(lo, hi)]
    X = np.stack(np.meshgrid(*g, indexing="ij"), -1)
    d, i = cKDTree(P).query(X.reshape(-1, 3))
    return ((d < R) & (i > 0) & (i < len(P) - 1)).reshape(X.shape[:3])


# --------------------------------------------------------------------------- #
# synthetic trees (vesselgp.synthetic_tree): root cut open, rounded tips
# --------------------------------------------------------------------------- #
@pytest.fixture(scope="module")
def tree4():
    return synthetic_tree(levels=2, voxel=VOXEL)


@pytest.fixture(scope="module")
def tree3():
    return synthetic_tree(parents=(-1, 0, 0, 1, 1), voxel=VOXEL, seed=3)


@pytest.mark.parametrize("name", ["tree3", "tree4"])
def test_tree_every_end_and_nothing_else(name, request):
    tree = request.getfixturevalue(name)
    ends = vessel_ends(tree.V, tree.F)
    truth = tree_truth(tree)
    assert [k for k, *_ in truth].count("rounded") == (3 if name == "tree3" else 4)
    found = assert_ends_match(ends, truth)
    root = found[0]
    assert root.kind == "open" and set(root.loop) == set(tree.root_loop)
    for e in found[1:]:  # the tip (pole) is in the end's region, the rim ring one radius out
        pole = e.center + e.radius * e.direction
        assert np.linalg.norm(tree.V[e.vertices] - pole, axis=1).min() < 0.25 * e.radius
        assert np.allclose(np.linalg.norm(tree.V[e.loop] - e.center, axis=1), e.radius, rtol=0.15)
        P = tree.V[e.loop] - e.center  # ring counter-clockwise about the outward direction
        assert np.cross(P, np.roll(P, -1, axis=0)).sum(0) @ e.direction > 0
    with pytest.raises(EndsError, match=r"pass ends=\(i, j\)"):
        select_ends(ends)


def test_tree_with_crease_junction_and_bigger_tips():
    tree = synthetic_tree(levels=1, voxel=VOXEL, blend=0.0, seed=1)  # plain union: a crease at the junction
    assert_ends_match(vessel_ends(tree.V, tree.F), tree_truth(tree))


def test_tree_ends_follow_rigid_motion_and_renumbering(tree3):
    rng = np.random.default_rng(11)
    Q, t = random_rigid(rng)
    perm = rng.permutation(len(tree3.V))
    inv = np.argsort(perm)
    V2 = (tree3.V @ Q.T + t)[perm]
    F2 = inv[tree3.F][rng.permutation(len(tree3.F))]
    truth = [(k, c @ Q.T + t, r, d @ Q.T) for k, c, r, d in tree_truth(tree3)]
    assert_ends_match(vessel_ends(V2, F2), truth)


def test_tree_with_capped_outlets_and_rounded_tips(tree4):
    """Two tips cut off and capped flat (one right behind its dome, one deeper), two left rounded."""
    V, F = tree4.V, tree4.F
    truth = [tree_truth(tree4)[0]]
    for i, e in enumerate(tree4.truth.ends[1:]):
        if i < 2:
            V, F, c = clip_and_cap(V, F, e.center, e.direction, e.radius, behind=0.3 + 0.9 * i)
            truth.append(("cap", c, e.radius, e.direction))
        else:
            truth.append((e.kind, e.center, e.radius, e.direction))
    found = assert_ends_match(vessel_ends(V, F), truth)
    assert [e.kind for e in found] == ["open", "cap", "cap", "rounded", "rounded"]


def test_metre_scale_tree_prints_distinct_points(tree3):
    """The same tree in metres: the listing resolves its ends (not all '(0.0, 0.0, 0.1)')."""
    V = tree3.V * 1e-3
    ends = vessel_ends(V, tree3.F)
    assert len(ends) == 4
    with pytest.raises(EndsError) as ei:
        select_ends(ends)
    msg = str(ei.value)
    pts = [format_point(e.center, np.linalg.norm(np.ptp(V, axis=0))) for e in ends]
    assert len(set(pts)) == 4 and all(p in msg for p in pts)
    for e in ends:  # the printed centre is within a ten-thousandth of the mesh size of the true one
        got = np.array([float(x) for x in format_point(e.center, e.scale)[1:-1].split(",")])
        assert np.abs(got - e.center).max() <= tol.PRINT_RESOLUTION * e.scale
    assert "open" in msg and "rounded" in msg  # the kinds are listed when they differ


# --------------------------------------------------------------------------- #
# caps of any size
# --------------------------------------------------------------------------- #
def test_tiny_fan_outlet_is_a_cap():
    V, F = tiny_fan_outlet()
    h = np.median(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1))
    assert 2 * 0.08 < h  # the outlet is less than an edge across
    truth = [("cap", np.zeros(3), 1.0, np.r_[0, 0, -1.0]), ("cap", np.r_[0, 0, 6.0], 0.08, np.r_[0, 0, 1.0])]
    small = assert_ends_match(vessel_ends(V, F), truth)[1]
    assert len(small.faces) == 32 and np.allclose(V[small.vertices, 2], 6.0)


@pytest.mark.parametrize("k", [3, 4, 5, 6])
def test_outlet_one_edge_across_is_a_cap(k):
    """An outlet ring of k vertices closed by k - 2 triangles (a triangle, a square ...)."""
    V, F, r, ztop = outlet_tube(k)
    h = np.median(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1))
    assert 2 * r < 2 * h
    assert mesh_topology(F, len(V)).is_closed
    truth = [("cap", np.zeros(3), 1.0, np.r_[0, 0, -1.0]), ("cap", np.r_[0, 0, ztop], r, np.r_[0, 0, 1.0])]
    small = assert_ends_match(vessel_ends(V, F), truth)[1]
    assert len(small.faces) == k - 2 and sorted(small.loop) == sorted(range(len(V) - 1 - k, len(V) - 1))


def test_remeshed_tube_with_small_outlet():
    """Isotropic remeshing: the small cap is a handful of triangles, about 1.5 edges across."""
    v = synthetic_vessel("arc", radius=lambda s: 2.0 - 1.7 * s, ends="capped", n_around=32, remesh=True,
                         target_edge=0.4, seed=0)
    C, T = v.truth.centers, v.truth.frames[:, 0]
    truth = [("cap", C[0], v.truth.radii[0], -T[0]), ("cap", C[-1], v.truth.radii[-1], T[-1])]
    _, small = assert_ends_match(vessel_ends(v.V, v.F), truth)
    h = np.median(np.linalg.norm(v.V[v.F[:, 0]] - v.V[v.F[:, 1]], axis=1))
    assert len(small.faces) <= 12 and 2 * small.radius < 2 * h < small.radius * 4


def test_noisy_walls_still_meet_their_caps():
    """Wall noise of 2 % of the radius: walls meet the cap rim more bluntly here and there."""
    v = synthetic_vessel("aortic_arch", radius=13.0, ends="capped", n_around=96, remesh=False, noise=0.02, seed=1)
    C, T, r = v.truth.centers, v.truth.frames[:, 0], v.truth.radii
    assert_ends_match(vessel_ends(v.V, v.F), [("cap", C[0], r[0], -T[0]), ("cap", C[-1], r[-1], T[-1])])


def test_too_noisy_closed_tube_falls_back_to_its_extremes(caplog):
    """Noise of 5 % of the radius on 0.85-long edges: no cap is recognised, yet the two ends
    are reported (as rounded extremes, as before trees), with a warning."""
    v = synthetic_vessel("aortic_arch", radius=13.0, ends="capped", n_around=96, remesh=False, noise=0.05, seed=1)
    with caplog.at_level("WARNING", logger="vesselgp.mesh.ends"):
        ends = vessel_ends(v.V, v.F)
    assert len(ends) == 2 and "fewer than two vessel ends recognised" in caplog.text
    C = v.truth.centers
    assert sorted(min(np.linalg.norm(e.center - c) for c in (C[0], C[-1])) for e in ends)[-1] < 13.0


def test_capped_tube_along_an_axis_is_not_a_staircase():
    """A short capped can along z: a third of its area faces an axis, in two planes only."""
    z = np.linspace(0, 3.0, 30)
    V, F = revolve(np.full(30, 1.5), z, 96, bottom=0.0, top=3.0)
    assert [e.kind for e in vessel_ends(V, F)] == ["cap", "cap"]


@pytest.mark.parametrize("curve", ["straight", "arc", "aortic_arch", "helix"])
@pytest.mark.parametrize("ends", ["open", "capped"])
@pytest.mark.parametrize("remesh", [False, True])
def test_tubes_have_their_two_ends_and_nothing_else(curve, ends, remesh):
    """No tip on the ridge of the distance from the ends (mid-tube, outside of a bend), no cap elsewhere."""
    v = synthetic_vessel(curve, radius=1.5, ends=ends, n_around=24 if remesh else 48, remesh=remesh)
    C, T, r = v.truth.centers, v.truth.frames[:, 0], v.truth.radii
    kind = "open" if ends == "open" else "cap"
    assert_ends_match(vessel_ends(v.V, v.F), [(kind, C[0], r[0], -T[0]), (kind, C[-1], r[-1], T[-1])])


def test_staircase_terraces_are_not_caps_even_unchecked(stair, monkeypatch):
    """With the staircase check switched off, no terrace along a branch passes for a cap."""
    monkeypatch.setattr(tol, "STAIRCASE_AREA_FRACTION", 2.0)
    V, F, _ = clean_mesh(stair.V, stair.F)
    ends = vessel_ends(V, F)
    tips = stair.truth.tips
    assert sum(e.kind == "open" for e in ends) == 1
    for e in ends:
        if e.kind != "open":  # a voxelised dome's top terrace at most
            assert min(np.linalg.norm(e.center - t.center) / t.radius for t in tips) < 1.5, e.describe()


# --------------------------------------------------------------------------- #
# rounded ends (capsules)
# --------------------------------------------------------------------------- #
@pytest.mark.parametrize("R, L, n, m", [(1.0, 5.0, 32, 8), (2.5, 6.0, 48, 12), (0.5, 10.0, 20, 6)])
def test_capsule_two_rounded_ends(R, L, n, m):
    V, F = capsule(R, L, n, m)
    truth = [("rounded", np.zeros(3), R, np.r_[0, 0, -1.0]), ("rounded", np.r_[0, 0, L], R, np.r_[0, 0, 1.0])]
    found = assert_ends_match(vessel_ends(V, F), truth)
    # the tube's radius behind the dome, not the ring's at the equator: 0-0.29 % off (the ring's, 0.9-2 %)
    assert all(abs(e.radius - R) <= 0.0045 * R for e in found), [e.radius for e in found]


@pytest.mark.parametrize("noise", [0.01, 0.02])
def test_noisy_capsule(noise):
    V, F = capsule(1.0, 6.0, 64, 16)
    rng = np.random.default_rng(0)
    foot = np.c_[np.zeros((len(V), 2)), np.clip(V[:, 2], 0.0, 6.0)]
    N = (V - foot) / np.linalg.norm(V - foot, axis=1, keepdims=True)  # outward normals
    V = V + N * rng.normal(scale=noise, size=(len(V), 1))
    truth = [("rounded", np.zeros(3), 1.0, np.r_[0, 0, -1.0]), ("rounded", np.r_[0, 0, 6.0], 1.0, np.r_[0, 0, 1.0])]
    assert_ends_match(vessel_ends(V, F), truth)


def test_rotated_remeshed_capsule():
    import pymeshlab

    V, F = capsule(1.0, 6.0, 40, 10)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(V, F))
    ms.meshing_isotropic_explicit_remeshing(iterations=5, targetlen=pymeshlab.PureValue(0.12))
    m = ms.current_mesh()
    V, F = m.vertex_matrix().astype(float), m.face_matrix().astype(np.int64)
    Q, t = random_rigid(np.random.default_rng(3))
    V = V @ Q.T + t
    truth = [("rounded", t, 1.0, -Q[:, 2]), ("rounded", Q @ [0, 0, 6.0] + t, 1.0, Q[:, 2])]
    assert_ends_match(vessel_ends(V, F), truth)


def test_open_tube_with_one_rounded_end():
    V, F = capsule(1.0, 5.0)
    keep = ~np.all(V[F][:, :, 2] < 1.0, axis=1)  # cut the bottom dome and a radius of tube
    V2, F2, _ = clean_mesh(V, F[keep])
    ends = vessel_ends(V2, F2)
    assert sorted(e.kind for e in ends) == ["open", "rounded"]
    tip = next(e for e in ends if e.kind == "rounded")
    assert_ends_match([tip], [("rounded", np.r_[0, 0, 5.0], 1.0, np.r_[0, 0, 1.0])])


def test_sphere_is_still_not_tubular():
    phi = np.linspace(0, np.pi, 17)[1:-1]
    V, F = revolve(np.sin(phi), -np.cos(phi), 32, bottom=-1.0, top=1.0)
    with pytest.raises(NotTubularError, match="not tubular"):
        vessel_ends(V, F)


# --------------------------------------------------------------------------- #
# the real meshes (SOURCES.md): no extra ends, no regression
# --------------------------------------------------------------------------- #
def test_real_bifurcation_three_open_ends_no_tip_at_the_junction():
    V, F = read_mesh(REAL / "vmtk_abdominal_aorta_iliac_bifurcation_open.stl")
    truth = [("open", np.r_[220.98, 177.78, 20.99], 7.69, np.r_[0, 1.0, 0]),
             ("open", np.r_[210.10, 102.86, 30.74], 4.38, np.r_[0, -1.0, 0]),
             ("open", np.r_[235.17, 101.55, 28.97], 4.41, np.r_[0, -1.0, 0])]
    # the directions of the real cuts are known only roughly: within 30 degrees of the body axis
    ends = vessel_ends(V, F)
    assert [e.kind for e in ends] == ["open"] * 3
    for _kind, c, r, d in truth:
        e = min(ends, key=lambda e: np.linalg.norm(e.center - c))
        assert np.linalg.norm(e.center - c) < 0.1 * r and e.radius == pytest.approx(r, rel=0.02)
        assert angle_deg(e.direction, d) < 30


def test_real_coronary_two_open_ends():
    V, F = read_mesh(REAL / "xra_coronary_single_branch_open.stl")
    ends = vessel_ends(V, F)
    assert [e.kind for e in ends] == ["open", "open"]
    for e, (c, r) in zip(ends, [((37.31, -30.85, 49.91), 1.45), ((-10.79, -11.39, 88.39), 1.27)]):
        assert np.linalg.norm(e.center - c) < 0.05 and e.radius == pytest.approx(r, abs=0.02)


def test_real_capped_lumen_two_caps():
    V, F = read_mesh(REAL / "dfemtoolz_artery_segment_lumen_capped.stl")
    ends = vessel_ends(V, F)
    assert [e.kind for e in ends] == ["cap", "cap"]
    for e, (c, r) in zip(ends, [((164.5, 79.3, 17.1), 2.46), ((134.8, 109.3, 51.8), 1.40)]):
        assert np.linalg.norm(e.center - c) < 0.1 and e.radius == pytest.approx(r, abs=0.05)
    a, b = ends
    assert a.direction @ (a.center - b.center) > 0 and b.direction @ (b.center - a.center) > 0


# --------------------------------------------------------------------------- #
# voxel staircases
# --------------------------------------------------------------------------- #
def _assert_staircase_error(V, F):
    with pytest.raises(EndsError) as ei:
        vessel_ends(V, F)
    msg = str(ei.value)
    assert "\n" not in msg and "staircase" in msg and "terraces" in msg
    assert "vesselgp.clean_mesh(V, F, smooth=N)" in msg and "vesselgp clean --smooth N" in msg


@pytest.fixture(scope="module")
def stair():
    return synthetic_tree(levels=2, voxel=VOXEL, staircase=True)


def test_synthetic_staircase_tree_raises_then_smoothing_as_advised_finds_its_ends(stair):
    _assert_staircase_error(stair.V, stair.F)
    V, F, _ = clean_mesh(stair.V, stair.F, smooth=10)
    assert_ends_match(vessel_ends(V, F), tree_truth(stair))


@pytest.mark.parametrize("spacing", [(1.0, 1.0, 1.0), (0.88, 0.88, 1.5)])
def test_raw_voxel_faces_and_binary_marching_cubes_raise(spacing):
    from skimage.measure import marching_cubes

    occ = bent_occupancy()
    _assert_staircase_error(*voxel_faces(occ, spacing))  # raw faces: even before clean_mesh
    V, F, _, _ = marching_cubes(np.pad(occ, 1).astype(np.float32), 0.5, spacing=spacing)
    V, F = V.astype(float), F.astype(np.int64)
    _assert_staircase_error(V, F)


def _zigzag(terraces, H, r1=3.0, r2=4.0, n=36):
    """An open tube of revolution about z whose radius steps r1 -> r2 -> r1 ... ``terraces`` times.

    Bands of height ``H`` alternate with flat annuli at the steps, which face -z and +z exactly;
    with ``n`` = 36 the bands' faces face 5, 15, ... degrees from x, never within 1 degree of an
    axis. Returns the mesh, its axis-facing area fraction and its terraces, from the n-gon's areas.
    """
    rho, z = [r1], [0.0]
    for k in range(terraces):
        rho += [rho[-1], r2 if k % 2 == 0 else r1]
        z += [(k + 1) * H, (k + 1) * H]
    rho, z = rho + [rho[-1]], z + [(terraces + 1) * H]
    V, F = revolve(rho, z, n)
    annulus = 0.5 * n * np.sin(2 * np.pi / n) * (r2 ** 2 - r1 ** 2)
    bands = sum(n * 2 * r * np.sin(np.pi / n) * H for r in rho[::2])
    return V, F, terraces * annulus / (terraces * annulus + bands)


def _staircase_check(V, F):
    from vesselgp.mesh._ends_staircase import check_staircase

    N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    A = np.linalg.norm(N, axis=1)
    E = np.unique(np.sort(np.r_[F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]], axis=1), axis=0)
    check_staircase(V, F, N / A[:, None], A, float(np.median(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1))))


@pytest.mark.parametrize("factor", [0.96, 1.04])
def test_staircase_guard_at_its_area_fraction(factor):
    """24 terraces; the axis-facing share of the area just under and just over its limit."""
    f0 = tol.STAIRCASE_AREA_FRACTION * factor
    _, _, f1 = _zigzag(24, 1.0)  # the fraction falls as 1 / (1 + c H): solve for the H that gives f0
    H = (1.0 / f0 - 1.0) / (1.0 / f1 - 1.0)
    V, F, f = _zigzag(24, H)
    assert f == pytest.approx(f0, rel=1e-9)
    if factor < 1:
        _staircase_check(V, F)
    else:
        with pytest.raises(EndsError, match="raw voxel staircase"):
            _staircase_check(V, F)


@pytest.mark.parametrize("extra", [-1, 0])
def test_staircase_guard_at_its_terrace_count(extra):
    """Well over the area share (about 0.4), one terrace short of the limit and at it."""
    V, F, f = _zigzag(tol.STAIRCASE_MIN_TERRACES + extra, 1.5)
    assert f > 1.4 * tol.STAIRCASE_AREA_FRACTION
    if extra < 0:
        _staircase_check(V, F)
    else:
        with pytest.raises(EndsError, match=f"in {tol.STAIRCASE_MIN_TERRACES} terraces"):
            _staircase_check(V, F)


def test_staircase_measure_separates_voxel_and_smooth_meshes(tree4):
    from skimage.measure import marching_cubes

    def stats(V, F):
        N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
        A = np.linalg.norm(N, axis=1)
        N = N / A[:, None]
        h = np.median(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1))
        return staircase_stats(V, F, N, A, h)

    occ = bent_occupancy(R=3.0, bend=25.0, tilt=(0.785, 0.615))
    f, k = stats(*voxel_faces(occ))
    assert f > 0.99 and k >= 3 * tol.STAIRCASE_MIN_TERRACES
    V, F, _, _ = marching_cubes(np.pad(occ, 1).astype(np.float32), 0.5)
    f, k = stats(V.astype(float), F.astype(np.int64))
    assert 1.2 * tol.STAIRCASE_AREA_FRACTION < f < 0.5 and k >= 2 * tol.STAIRCASE_MIN_TERRACES
    for V, F in [(tree4.V, tree4.F), read_mesh(REAL / "dfemtoolz_artery_segment_lumen_capped.stl"),
                 read_mesh(REAL / "vmtk_abdominal_aorta_iliac_bifurcation_open.stl")]:
        f, k = stats(V, F)
        assert f < 0.2 * tol.STAIRCASE_AREA_FRACTION and k < tol.STAIRCASE_MIN_TERRACES


# --------------------------------------------------------------------------- #
# messages: long listings cut short, digits for the mesh's size
# --------------------------------------------------------------------------- #
def _fake_ends(k, scale=None, offset=0.0, step=1.0):
    return tuple(VesselEnd("open", np.arange(3), np.arange(3), np.r_[offset + step * i, 0.0, 0.0],
                           np.r_[0, 0, 1.0], 1.0 + i, scale=scale) for i in range(k))


def test_long_listing_is_cut_after_ten_ends():
    with pytest.raises(EndsError) as ei:
        select_ends(_fake_ends(25))
    msg = str(ei.value)
    assert msg.startswith("mesh has 25 open ends;") and "\n" not in msg
    assert "9 r=10 at (9, 0, 0)" in msg and "10 r=11" not in msg and msg.endswith("... and 15 more)")
    with pytest.raises(EndsError) as ei:
        select_ends(_fake_ends(11), (0, 11))
    assert str(ei.value).endswith("... and 1 more)")
    with pytest.raises(EndsError) as ei:
        select_ends(_fake_ends(10))
    assert "more" not in str(ei.value) and "9 r=10" in str(ei.value)


def test_metre_scale_points_keep_their_digits():
    ends = _fake_ends(3, scale=0.3, offset=0.1001, step=0.0002)  # three ends 0.2 mm apart in a 0.3 m mesh
    texts = [e.describe() for e in ends]
    assert len(set(texts)) == 3 and "(0.1001, 0, 0)" in texts[0] and "(0.1003, 0, 0)" in texts[1]
    with pytest.raises(EndsError) as ei:
        select_ends(ends)
    assert "(0.1005, 0, 0)" in str(ei.value)


def _persistence_by_sweep(nbrs, D, valid):
    """0-dimensional persistence of the superlevel sets of ``D`` on a graph, the textbook way.

    Vertices enter from the highest down (ties: the larger id first, i.e. (D, id) ordered); a vertex
    joins its entered neighbours' components, and where two components meet, the one with the lower
    maximum dies there (elder rule): its persistence is its maximum's D minus the meeting vertex's D.
    Returns {maximum: persistence} (inf for the highest of each piece).
    """
    order = sorted(np.flatnonzero(valid).tolist(), key=lambda v: (D[v], v), reverse=True)
    parent, top, pers, entered = {}, {}, {}, set()

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for v in order:
        roots = {find(u) for u in nbrs[v] if u in entered}
        entered.add(v)
        if not roots:
            parent[v], top[v], pers[v] = v, v, np.inf
            continue
        roots = sorted(roots, key=lambda r: (D[top[r]], top[r]), reverse=True)  # the eldest first
        parent[v] = roots[0]
        for r in roots[1:]:
            pers[top[r]] = float(D[top[r]] - D[v])
            parent[r] = roots[0]
    return pers


@pytest.mark.parametrize("seed", range(6))
def test_persistent_maxima_are_the_textbook_persistence_pairs(seed):
    """Maxima of D and their persistence, on random graphs with many tied values and a few unused or
    unreachable vertices, against the union-find sweep written out above."""
    import scipy.sparse as sp

    from vesselgp.mesh._ends_tips import persistent_maxima

    rng = np.random.default_rng(seed)
    n = 300
    E = np.unique(np.sort(rng.integers(0, n, size=(900, 2)), axis=1), axis=0)
    E = E[E[:, 0] != E[:, 1]]
    G = sp.coo_array((np.ones(2 * len(E)), (np.r_[E[:, 0], E[:, 1]], np.r_[E[:, 1], E[:, 0]])), shape=(n, n)).tocsr()
    D = rng.integers(0, 25, size=n).astype(float)  # many ties: broken by vertex id
    D[rng.choice(n, 10, replace=False)] = np.inf
    used = rng.random(n) > 0.05
    valid = used & np.isfinite(D)
    nbrs = [[] for _ in range(n)]
    for a, b in E:
        if valid[a] and valid[b]:
            nbrs[a].append(b)
            nbrs[b].append(a)
    truth = _persistence_by_sweep(nbrs, D, valid)
    got = persistent_maxima(G, E, D, used)
    assert dict(got) == truth
    assert got == sorted(got, key=lambda t: (-t[1], t[0]))


@pytest.mark.parametrize("delta, kind", [(0.18, "cap"), (0.22, "rounded")])
def test_the_cap_flatness_at_its_edge(delta, kind):
    """Issue #35: a cap is a patch whose face normals are all within CAP_FLATNESS (0.2 rad) of their mean. A tube
    closed by a shallow cone whose faces lean delta from the cap's plane (its normals delta from the axis): 0.18 is
    a flat cap, its centre on the rim's plane and its radius the tube's; 0.22 is not (the cone is a rounded end)."""
    assert (delta < tol.CAP_FLATNESS) == (kind == "cap")
    z = np.linspace(0.0, 6.0, 25)
    V, F = revolve(np.ones(25), z, 32, bottom=0.0, top=6.0 + np.tan(delta))
    ends = vessel_ends(V, F)
    top = max(ends, key=lambda e: e.center[2])
    assert [e.kind for e in ends if e is not top] == ["cap"] and top.kind == kind
    if kind == "cap":
        assert abs(top.radius - 1.0) < 0.01 and abs(top.center[2] - 6.0) < np.tan(delta)


def _capped_cone(phi, t, t_cone, grow, t0=0.0):
    """A tube capped flat at z = 0 (radius 1, fan to a centre vertex) whose wall runs straight down for a length
    ``t0``, then as a cone of half-angle ``phi`` (widening for ``grow`` = 1, narrowing for -1) for a slant
    ``t_cone``, then as a cylinder to an open end; rings at slant distances ``t`` from the rim, along the
    meridians."""
    t = np.asarray(t, float)
    c = np.clip(t - t0, 0.0, t_cone)
    rho = 1.0 + grow * c * np.sin(phi)
    z = -np.minimum(t, t0) - c * np.cos(phi) - np.maximum(t - t0 - t_cone, 0.0)
    order = np.argsort(z)
    return revolve(rho[order], z[order], 32, top=0.0)


def _top_kind(V, F):
    ends = vessel_ends(V, F)
    assert [e.kind for e in ends].count("open") == 1
    return max(ends, key=lambda e: e.center[2]).kind


#: Rings of the flare tests: every 0.15 along the meridian up to 1.95, then 2.15, 2.5, 3.0 and a tube.
_FLARE_T = np.r_[np.arange(0.0, 1.96, 0.15), 2.15, 2.5, 3.0, np.linspace(3.5, 9.0, 8)]


@pytest.mark.parametrize("side", [-1, 1])
def test_the_cap_rim_tilt_of_a_widening_wall_at_its_edge(side):
    """Issue #44: the wall may leave a cap's rim widening (an aortic root flaring into its sinuses behind its
    valve plane) as steeply as narrowing, up to CAP_RIM_TILT (0.8 rad) from perpendicular; a rim blunter than a
    1 rad crease was refused before. A cone widening at half-angle phi for a slant of 0.3 (the tube at most 1.22
    rim radii wide, inside the bulge and flare bounds), then a tube: 0.02 rad below the edge the cap is found;
    0.02 above it is not a cap (nor is the end then found as a rounded one)."""
    V, F = _capped_cone(tol.CAP_RIM_TILT + 0.02 * side, np.r_[0.0, 0.1, 0.2, 0.3, np.linspace(0.6, 9.0, 12)], 0.3,
                        grow=1)
    ends = vessel_ends(V, F)
    top = max(ends, key=lambda e: e.center[2])
    assert (top.kind == "cap") == (side < 0)


@pytest.mark.parametrize("fraction", [0.08, 0.125])
def test_the_cap_rim_walled_fraction_at_its_edge(fraction):
    """Issue #44: the wall meets a cap's rim along at least CAP_RIM_WALLED_FRACTION (0.9) of its length; a
    decimated rim has a folded face here and there (the 4D-flow arch decimated to 30 %: one rim edge of 64,
    which refused its cap). A capped unit tube (64 around) whose first ring below the rim is pushed out along
    ``fraction`` of the rim (consecutive vertices), so that the wall faces across those rim edges lean more
    than 1.2 rad from perpendicular: 8 % of the rim (5 edges) leaves a cap, 12.5 % (8 edges) does not (it is
    then no end at all: the end is found as the mesh's extreme instead)."""
    n = 64
    z = np.r_[np.linspace(-8.0, -0.3, 20), -0.05, 0.0]
    V, F = revolve(np.ones(len(z)), z, n, top=0.0)
    k = int(round(fraction * n))
    ring, rim = (len(z) - 2) * n, (len(z) - 1) * n  # the ring 0.05 below the rim, and the rim
    V[ring + np.arange(k), :2] *= 1.2  # out by 0.2: their faces lean atan(0.2 / 0.05) = 1.33 rad
    tilted = 0
    for i in range(n):  # the wall face across each rim edge, and its lean from perpendicular to the cap
        f = F[np.isin(F, [rim + i, rim + (i + 1) % n]).sum(axis=1) == 2]
        f = f[~(f == len(V) - 1).any(axis=1)][0]  # not the cap's fan
        nrm = np.cross(V[f[1]] - V[f[0]], V[f[2]] - V[f[0]])
        tilted += abs(nrm[2]) / np.linalg.norm(nrm) > np.sin(tol.CAP_RIM_TILT)
    assert tilted == k  # the construction: k of the n rim edges (of equal length) have a leaning wall
    top = max(vessel_ends(V, F), key=lambda e: e.center[2])
    assert (top.kind == "cap") == (k / n <= 1.0 - tol.CAP_RIM_WALLED_FRACTION)


@pytest.mark.parametrize("side", [-1, 1])
def test_the_cap_tube_flare_at_its_edge(side):
    """Issues #35, #44: behind a cap the body, as deep as CAP_TUBE_REACH rim radii, has its deepest part
    (within CAP_TUBE_DEEP of its deepest point) within CAP_TUBE_SPREAD rim radii of the cap's axis plus
    CAP_TUBE_FLARE per unit depth. The wall runs straight for t0 = 0.3 (a sharp rim), then widens at half-angle
    phi: at slant s into the cone it is 1 + s sin(phi) off the axis at depth t0 + s cos(phi). Near the edge the
    deepest ring within 2 radii is the one at slant 2.15 (the next, at 2.5, lies deeper than 2): it breaks the
    bound from sin(phi) - FLARE cos(phi) = (SPREAD - 1 + FLARE t0) / 1.85 on, phi = 0.658 rad. 0.02 rad below,
    the cap is found; 0.02 above, it is not."""
    t0, t_last = 0.3, 2.15
    s = t_last - t0
    edge = np.arctan(tol.CAP_TUBE_FLARE) + np.arcsin((tol.CAP_TUBE_SPREAD - 1.0 + tol.CAP_TUBE_FLARE * t0) / s
                                                     / np.hypot(1.0, tol.CAP_TUBE_FLARE))
    phi = edge + 0.02 * side
    depth = lambda t: t0 + (t - t0) * np.cos(phi)  # noqa: E731
    assert depth(t_last) < tol.CAP_TUBE_REACH < depth(2.5)  # the ring at 2.15 is the slab's deepest
    V, F = _capped_cone(phi, _FLARE_T, 2.7, grow=1, t0=t0)
    assert (_top_kind(V, F) == "cap") == (side < 0)


@pytest.mark.parametrize("factor", [0.97, 1.03])
def test_the_cap_tube_bulge_at_its_edge(factor, caplog):
    """Issue #44: nearer the cap the body may bulge out to CAP_TUBE_BULGE rim radii (plus the flare) and come back,
    as an aortic root's sinuses do behind its valve plane. A capped unit tube whose radius behind the cap is
    1 + A (g(d) - g(0)), g a Gaussian of width 0.35 at depth 0.9, rings every 0.05 deep: A sets the largest
    ratio of the radius to the bound CAP_TUBE_BULGE + CAP_TUBE_FLARE d over the rings to 0.97 or 1.03. The first
    is a cap; the second is not, and is reported as a flat patch that is not a cap."""
    import logging

    d = np.r_[np.arange(0.0, 2.5, 0.05), np.linspace(2.6, 9.0, 20)]
    g = np.exp(-0.5 * ((d - 0.9) / 0.35) ** 2)
    shape = g - g[0]
    bound = tol.CAP_TUBE_BULGE + tol.CAP_TUBE_FLARE * d
    lo, hi = 0.1, 5.0  # the amplitude whose largest ratio to the bound is ``factor`` (bisection on a monotone map)
    for _ in range(60):
        A = 0.5 * (lo + hi)
        lo, hi = (A, hi) if np.max((1.0 + A * shape) / bound) < factor else (lo, A)
    rho = 1.0 + A * shape
    assert abs(np.max(rho / bound) - factor) < 1e-6
    V, F = revolve(rho[::-1], -d[::-1], 48, top=0.0)
    with caplog.at_level(logging.INFO, logger="vesselgp.mesh.ends"):
        top = max(vessel_ends(V, F), key=lambda e: e.center[2])
    assert (top.kind == "cap") == (factor < 1)
    if factor > 1:
        assert any("is not a cap: the body behind it bulges" in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize("phi, kind", [(0.78, "cap"), (0.82, "rounded")])
def test_the_cap_rim_tilt_at_its_edge(phi, kind):
    """Issue #35: across a cap's rim the wall stands within CAP_RIM_TILT (0.8 rad) of perpendicular to the cap.
    A cap on a cone narrowing behind it at half-angle phi has its wall's normals phi off the cap's plane: 0.78 rad
    is a cap of radius 1 centred on the rim; 0.82 is not (the narrowing end is then a rounded end)."""
    assert (phi < tol.CAP_RIM_TILT) == (kind == "cap")
    V, F = _capped_cone(phi, np.r_[np.arange(0.0, 0.61, 0.1), np.linspace(1.0, 9.0, 9)], 0.6, grow=-1)
    assert _top_kind(V, F) == kind
    if kind == "cap":
        top = max(vessel_ends(V, F), key=lambda e: e.center[2])
        assert abs(top.radius - 1.0) < 0.01 and np.linalg.norm(top.center) < 0.01


def _reshaped_tip(V, e, k):
    """The tip ``e`` of a synthetic tree stretched along its direction (its dome ``k`` radii tall instead of 1);
    its end's centre, a radius in from the new tip, moves by (k - 1) radii."""
    d = e.direction / np.linalg.norm(e.direction)
    x = (V - e.center) @ d
    m = (x > 0) & (np.linalg.norm(V - e.center, axis=1) < 1.5 * e.radius + x)
    V = V.copy()
    V[m] += np.outer((k - 1.0) * x[m], d)
    return V, e.center + (k - 1.0) * e.radius * d


def test_a_pointed_tip_in_a_tree_is_found(tree4, caplog):
    """Issue #34: every end of a tree, rounded ends of other shapes than a hemisphere included. One tip of the
    4-tip tree drawn out into a dome 2.8 radii tall (its best-fit sphere's radius is not the tube's, which
    refused it as a tip, and a tree has no fallback): all five ends, the drawn-out one centred a radius in from
    its tip."""
    e = tree4.truth.ends[2]
    V, c = _reshaped_tip(tree4.V, e, 2.8)
    truth = tree_truth(tree4)
    truth[2] = ("rounded", c, e.radius, e.direction)
    assert_ends_match(vessel_ends(V, tree4.F), truth)
    assert "extreme" not in caplog.text


@pytest.mark.parametrize("height", [0.3, 2.5])
def test_flat_and_pointed_domes_are_tips(height, caplog):
    """A closed tube (radius 1) with a hemisphere at one end and at the other a half-spheroid ``height`` radii
    tall: both are rounded ends found by the tip test (no fallback to the surface's extremes), the spheroid's
    centre a radius in from its tip, its radius the tube's."""
    phi = np.linspace(0, np.pi / 2, 17)[1:]
    zc = np.linspace(0.0, 6.0, 65)[1:-1]
    rho = np.r_[np.sin(phi), np.ones(len(zc)), np.sin(phi[::-1])]
    z = np.r_[-height * np.cos(phi), zc, 6.0 + np.cos(phi[::-1])]
    V, F = revolve(rho, z, 48, bottom=-height, top=7.0)
    truth = [("rounded", np.r_[0, 0, 1.0 - height], 1.0, np.r_[0, 0, -1.0]),
             ("rounded", np.r_[0, 0, 6.0], 1.0, np.r_[0, 0, 1.0])]
    assert_ends_match(vessel_ends(V, F), truth)
    assert "extreme" not in caplog.text


def test_a_dome_with_three_sinus_lobes_is_a_tip(caplog):
    """A closed tube whose rounded end bulges into three lobes (an aortic root closed at its valve: the dome's
    height scaled by 1 + 0.5 sin^2(phi) cos(3 theta), up to half again near the rim): a rounded end where the
    hemisphere's centre is, with the tube's radius, found by the tip test (no fallback)."""
    phi = np.linspace(0, np.pi / 2, 17)[1:]
    zc = np.linspace(0.0, 6.0, 65)[1:-1]
    V, F = revolve(np.r_[np.sin(phi), np.ones(len(zc)), np.sin(phi[::-1])],
                   np.r_[-np.cos(phi), zc, 6.0 + np.cos(phi[::-1])], 48, bottom=-1.0, top=7.0)
    low = V[:, 2] < 0
    th, r = np.arctan2(V[low, 1], V[low, 0]), np.minimum(np.hypot(V[low, 0], V[low, 1]), 1.0)
    V[low, 2] *= 1.0 + 0.5 * r**2 * np.cos(3 * th)
    truth = [("rounded", np.zeros(3), 1.0, np.r_[0, 0, -1.0]), ("rounded", np.r_[0, 0, 6.0], 1.0, np.r_[0, 0, 1.0])]
    assert_ends_match(vessel_ends(V, F), truth)
    assert "extreme" not in caplog.text
