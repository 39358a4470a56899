"""Every field of the two listings, ``ends.json`` (``vesselgp ends``) and ``clean_report.json`` (``vesselgp clean``),
against exact geometry and against the faults built into the input.

Each command runs in-process (``vesselgp.cli.main``) once per input, in module fixtures; the truth is the
construction, never a number the code printed. Every input breaks a symmetry, so that a radius reported as a
diameter, a centre left in the file's units, a flipped direction, a swapped index or a count off by one changes a
number read:

* ``ends`` of a tube about an analytic non-planar curve C(t) = (12 + 40 t, -5 + 4 t + 15 t^2, 7 - 3 t + 6 t^3) mm,
  its exact circles of radius 1.2 + t^2 (1.2 mm at t = 0, 2.2 mm at t = 1), OPEN at the narrow end t = 0 and closed
  by a flat fan CAP at the wide end t = 1 (the widest end is listed first, so the cap precedes the open end against
  the kinds' own order), written in centimetres and read with ``--units cm``;
* ``ends`` of a tube tapered from radius 1 (x = 0) to 2 (x = 24) with a ball of radius 2.7 joined to its side at
  x = 8 (a blind sac wider than every cut end; the zero set of a smooth union of signed distances, as in
  test_bulges_truth.py), written in units of 2.5 mm and read with ``--scale 2.5``;
* ``ends`` of a tube tapered from radius 4.5 to 3 mm, closed by a flat fan that the wall meets on 5/6 of the rim's
  length only (it leans outward over the rest, as in test_reports_truth.py): a flat patch that is not a cap; turned
  and moved off the coordinate axes, written in micrometres and read with ``--units um``;
* ``clean`` of a closed curved tube (the first tube, capped at both ends) carrying known faults: a seam of one
  duplicate vertex per ring, 4 unreferenced vertices, 3 duplicate faces (one with its corners rotated), 2 faces with a
  repeated corner and 1 that loses a corner when the seam is merged, a dangling fin on one edge, a tetrahedron sharing
  one vertex with the wall (a bow tie), a floating octahedron far away (6 vertices), and all its faces but 3
  turned inward (coherent, and outward, only by flipping all the others); written in centimetres (OBJ) and read
  with ``--units cm``;
* ``clean --smooth 3`` of the same tube without faults, in millimetres: only the smoothing is counted.

Field inventory (field -> the test that checks its value against the truth).

ends.json (vesselgp ends; commands.clean.run_ends)
    command, input, units, input_units, to_mm, bbox_diagonal
        ........................... test_ends_bookkeeping_is_the_input_in_millimetres (cm, --scale, um)
    n_ends, ends[].index, ends[].kind, ends[].radius
        ........................... test_ends_are_listed_widest_first_with_their_kind_and_true_radius
    ends[].center ................. test_ends_centres_are_the_true_end_centres_in_millimetres
    ends[].direction .............. test_ends_directions_point_out_of_the_vessel_along_the_true_end_tangent
    sacs[].radius/center/direction  test_a_sac_is_listed_at_the_ball_with_its_radius_and_outward_direction
                                    (none on a plain tube: test_only_the_sac_tube_lists_a_sac)
    not_caps[].radius/center/direction/n_faces/reason
        ........................... test_a_partly_walled_flat_top_is_listed_as_not_a_cap_with_its_rim_share
                                    (none elsewhere: test_only_the_partly_walled_top_is_listed_as_not_a_cap)
clean_report.json (vesselgp clean; commands.clean.run_clean, mesh.clean.CleanReport)
    unreferenced_vertices_removed, duplicate_vertices_merged, duplicate_faces_removed, zero_area_faces_removed,
    non_manifold_edges_repaired, non_manifold_faces_removed, non_manifold_vertices_split, components_found,
    components_removed, faces_flipped, smoothing_iterations
        ........................... test_clean_counts_are_the_faults_built_into_the_input
    vertices_before, faces_before, vertices_after, faces_after (and the cleaned mesh file)
        ........................... test_clean_sizes_are_the_input_file_and_the_tube_alone_written_in_millimetres
    scale.median_edge, scale.bbox_diagonal, scale.units_guess, scale.warning
        ........................... test_clean_scale_is_that_of_the_repaired_tube_in_millimetres
    input, units, input_units, to_mm, summary
        ........................... test_clean_bookkeeping_and_summary_name_each_repair
    every field of a mesh without faults, smoothed
        ........................... test_clean_of_a_faultless_mesh_counts_only_its_smoothing_iterations
"""
from __future__ import annotations

import json
import re

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from vesselgp import tolerances as tol
from vesselgp.cli import main
from vesselgp.io import read_mesh, write_mesh

from _data import level_surface, smooth_union
from _reference import unit


def _run(*args):
    """Run ``vesselgp`` in-process, quietly; it must succeed."""
    assert main([str(a) for a in args] + ["-q"]) == 0


def _json(path):
    return json.loads(path.read_text())


def _bbox_diagonal(V):
    return float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))


def _signed_volume(V, F):
    """Signed volume of a closed surface (divergence theorem; positive when its faces turn outward)."""
    return float(np.einsum("ij,ij->", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])) / 6.0)


# ============================================================================= a curved tapered tube, one end capped

def _curve(t):
    """The analytic centre line (mm): (k,) -> (k, 3)."""
    t = np.asarray(t, float)
    return np.c_[12 + 40 * t, -5 + 4 * t + 15 * t**2, 7 - 3 * t + 6 * t**3]


def _tangent(t):
    """Its exact unit tangent, in the direction of increasing t."""
    t = np.asarray(t, float)
    return unit(np.c_[40 + 0 * t, 4 + 30 * t, -3 + 18 * t**2])


def _tube_radius(t):
    return 1.2 + np.asarray(t, float) ** 2  # 1.2 at t = 0 (narrow), 2.2 at t = 1 (wide)


NR, NA = 40, 16  # rings and vertices per ring of the tube


def _tube(cap0, cap1, seam=False):
    """Rings of exact circles about ``_curve`` (NR rings of NA vertices, faces outward), optionally closed by flat
    fans about the end centres (appended as the last vertices: t = 0, then t = 1). ``seam`` repeats the first
    vertex of every ring as an (NA + 1)-th vertex at the same place, which the ring's last faces use instead:
    an open seam of NR duplicate vertices."""
    t = np.linspace(0.0, 1.0, NR)
    C, T, r = _curve(t), _tangent(t), _tube_radius(t)
    U = unit(np.array([0.0, 0.0, 1.0]) - T[:, 2:3] * T)
    W = np.cross(T, U)
    m = NA + seam
    th = 2 * np.pi * (np.arange(m) % NA) / NA
    ring = np.cos(th)[None, :, None] * U[:, None] + np.sin(th)[None, :, None] * W[:, None]
    X = C[:, None] + r[:, None, None] * ring
    V = [X.reshape(-1, 3)]
    a = np.arange(NA)
    b = a + 1 if seam else (a + 1) % NA
    F = [f for k in range(NR - 1) for f in (np.c_[k * m + a, k * m + b, (k + 1) * m + b],
                                           np.c_[k * m + a, (k + 1) * m + b, (k + 1) * m + a])]
    n = NR * m
    if cap0:
        F.append(np.c_[np.full(NA, n), b, a])
        V.append(C[:1])
        n += 1
    if cap1:
        last = (NR - 1) * m
        F.append(np.c_[np.full(NA, n), last + a, last + b])
        V.append(C[-1:])
    return np.vstack(V), np.vstack(F).astype(np.int64)


@pytest.fixture(scope="module")
def tube(tmp_path_factory):
    """The tube open at t = 0 and capped at t = 1, in cm, listed with --units cm."""
    d = tmp_path_factory.mktemp("tube")
    V, F = _tube(cap0=False, cap1=True)
    path = d / "tube_cm.ply"
    write_mesh(path, V / 10.0, F)
    _run("ends", path, "--units", "cm", "-o", d / "e")
    return {"path": path, "V": V, "json": _json(d / "e" / "ends.json")}


# ============================================================================= a tapered tube with a blind sac

SAC_TL, SAC_XC, SAC_RS, SAC_H = 24.0, 8.0, 2.7, 0.25  # tube length, the sac's place, its ball's radius, grid step
SAC_SCALE = 2.5  # mm per file unit


def _sac_tube_radius(x):
    return 1.0 + np.asarray(x, float) / SAC_TL  # 1 at x = 0, 2 at x = 24


def _sac_centre():
    """Centre of the ball: rs beyond the tube's wall at x = 8, in +y."""
    return np.array([SAC_XC, float(_sac_tube_radius(SAC_XC)) + SAC_RS, 0.0])


@pytest.fixture(scope="module")
def sac(tmp_path_factory):
    """The tube (open where the grid cuts it, x = 0 and 24) and the ball joined by a smooth neck, in units of
    2.5 mm, listed with --scale 2.5."""
    d = tmp_path_factory.mktemp("sac")
    c, rs = _sac_centre(), SAC_RS
    x = np.arange(0.0, SAC_TL + SAC_H / 2, SAC_H)
    y = np.arange(-3.0, c[1] + rs + 1.0, SAC_H)
    z = np.arange(-rs - 1.0, rs + 1.0 + SAC_H / 2, SAC_H)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    tube_sd = np.hypot(Y, Z) - _sac_tube_radius(X)
    ball_sd = np.sqrt((X - c[0]) ** 2 + (Y - c[1]) ** 2 + (Z - c[2]) ** 2) - rs
    V, F = level_surface(smooth_union(tube_sd, ball_sd, 0.6), (x[0], y[0], z[0]), SAC_H)
    path = d / "sac.ply"
    write_mesh(path, V / SAC_SCALE, F)
    _run("ends", path, "--scale", SAC_SCALE, "-o", d / "e")
    return {"path": path, "V": V, "json": _json(d / "e" / "ends.json")}


# ============================================================================= a flat top the wall meets on 5/6 of it

PATCH_N = 60  # rim vertices (evenly spaced)
PATCH_S = 3.0  # mm per unit of the construction: rim radius 3, open end radius 4.5, length 24
PATCH_R = Rotation.from_rotvec([0.4, -0.9, 0.3]).as_matrix()
PATCH_P0 = np.array([20.0, -7.0, 11.0])  # the rim's centre
PATCH_AXIS = PATCH_R[:, 2]  # the tube lies along -PATCH_AXIS behind the top


def _patch_theta():
    return np.linspace(0.0, 2 * np.pi, PATCH_N, endpoint=False)


def _patch_leaning():
    """Rim edges (i -> i + 1) over the arc [pi, 4 pi / 3): a sixth of the rim, where the wall leans outward."""
    th = _patch_theta()
    nxt = np.r_[th[1:], 2 * np.pi]
    return np.flatnonzero((th >= np.pi - 1e-12) & (nxt <= 4 * np.pi / 3 + 1e-12))


def _patch_met_share():
    """Exact share of the rim's length (its chords) across which the wall stands perpendicular to the top."""
    chord = 2.0 * np.sin(0.5 * np.diff(np.r_[_patch_theta(), 2 * np.pi]))
    return 1.0 - chord[_patch_leaning()].sum() / chord.sum()


def _partly_walled_top():
    """A tube along -z from z = 0 (rim radius 1) to z = -8 (radius 1.5, open), the last 0.3 a straight cylinder,
    closed at z = 0 by a flat fan; the ring 0.05 below the rim is pushed out by 0.1 at the leaning edges, so that
    those wall faces lean atan(2) = 63 degrees off the perpendicular. Scaled by 3, turned, moved to PATCH_P0."""
    theta = _patch_theta()
    z = np.r_[np.linspace(-8.0, -0.3, 20), -0.05, 0.0]
    rz = np.where(z < -0.3, 1.0 + 0.5 * (-0.3 - z) / 7.7, 1.0)
    n, K = PATCH_N, len(z)
    rho = np.repeat(rz[:, None], n, axis=1)
    rho[K - 2, _patch_leaning()] += 0.1
    V = np.c_[(rho * np.cos(theta)).ravel(), (rho * np.sin(theta)).ravel(), np.repeat(z, n)]
    a, b = np.arange(n), (np.arange(n) + 1) % n
    F = [f for k in range(K - 1) for f in (np.c_[k * n + a, k * n + b, (k + 1) * n + b],
                                          np.c_[k * n + a, (k + 1) * n + b, (k + 1) * n + a])]
    F.append(np.c_[np.full(n, n * K), (K - 1) * n + a, (K - 1) * n + b])
    V = np.vstack([V, [0.0, 0.0, 0.0]]) * PATCH_S @ PATCH_R.T + PATCH_P0
    return V, np.vstack(F).astype(np.int64)


@pytest.fixture(scope="module")
def patch(tmp_path_factory):
    """The partly walled flat top, in micrometres, listed with --units um."""
    d = tmp_path_factory.mktemp("patch")
    V, F = _partly_walled_top()
    path = d / "top_um.ply"
    write_mesh(path, V * 1000.0, F)
    _run("ends", path, "--units", "um", "-o", d / "e")
    return {"path": path, "V": V, "json": _json(d / "e" / "ends.json")}


# ============================================================================= ends.json

def test_ends_bookkeeping_is_the_input_in_millimetres(tube, sac, patch):
    """command "ends", input the path given, units mm; input_units and to_mm those given (cm: 10; --scale 2.5:
    "2.5 mm", 2.5; um: 0.001); bbox_diagonal the diagonal of the mesh's box in mm (10, 2.5 and 0.001 times the
    file's)."""
    for case, label, factor in ((tube, "cm", 10.0), (sac, "2.5 mm", SAC_SCALE), (patch, "um", 1e-3)):
        d = case["json"]
        assert d["command"] == "ends" and d["input"] == str(case["path"])
        assert d["units"] == "mm" and d["input_units"] == label and d["to_mm"] == factor
        assert d["bbox_diagonal"] == pytest.approx(_bbox_diagonal(case["V"]), rel=1e-9)


def test_ends_are_listed_widest_first_with_their_kind_and_true_radius(tube, sac, patch):
    """n_ends is the number of ends built; index runs 0, 1, ...; the wide capped end (radius 2.2 mm, t = 1) comes
    before the narrow open one (1.2 mm, t = 0) although open ends come first among equals; the sac tube's cut ends
    are open, 2 then 1 mm (marching cubes, 1 %); the partly walled tube's open end (4.5 mm) precedes its top,
    which is no cap but a closed end: rounded, of a radius between the tube's there (3 and 4.5 mm)."""
    d = tube["json"]
    assert d["n_ends"] == len(d["ends"]) == 2
    assert [e["index"] for e in d["ends"]] == [0, 1]
    assert [e["kind"] for e in d["ends"]] == ["cap", "open"]
    assert [e["radius"] for e in d["ends"]] == pytest.approx([2.2, 1.2], rel=1e-9)

    s = sac["json"]
    assert s["n_ends"] == len(s["ends"]) == 2 and [e["index"] for e in s["ends"]] == [0, 1]
    assert [e["kind"] for e in s["ends"]] == ["open", "open"]
    assert [e["radius"] for e in s["ends"]] == pytest.approx([2.0, 1.0], rel=0.01)

    p = patch["json"]
    assert p["n_ends"] == len(p["ends"]) == 2 and [e["index"] for e in p["ends"]] == [0, 1]
    assert [e["kind"] for e in p["ends"]] == ["open", "rounded"]
    assert p["ends"][0]["radius"] == pytest.approx(1.5 * PATCH_S, rel=1e-9)
    assert PATCH_S <= p["ends"][1]["radius"] <= 1.5 * PATCH_S


def test_ends_centres_are_the_true_end_centres_in_millimetres(tube, sac, patch):
    """Each end's centre is the true centre of its cross-section in mm (not in the file's units): C(1) = (52, 14,
    10) for end 0 and C(0) = (12, -5, 7) for end 1 of the curved tube (exact circles: 1e-9 mm); (24, 0, 0) and the
    origin for the sac tube's cut ends (2 % of the radius); the partly walled tube's open end 24 mm behind its rim
    centre along the axis (exact), its rounded top within a rim radius of the rim's centre."""
    C = np.array([e["center"] for e in tube["json"]["ends"]])
    assert np.allclose(C, _curve([1.0, 0.0]), atol=1e-9, rtol=0)

    C = np.array([e["center"] for e in sac["json"]["ends"]])
    assert np.linalg.norm(C[0] - [SAC_TL, 0, 0]) < 0.02 * 2.0 and np.linalg.norm(C[1]) < 0.02 * 1.0

    C = np.array([e["center"] for e in patch["json"]["ends"]])
    assert np.allclose(C[0], PATCH_P0 - 8.0 * PATCH_S * PATCH_AXIS, atol=1e-9, rtol=0)
    assert np.linalg.norm(C[1] - PATCH_P0) < PATCH_S


def test_ends_directions_point_out_of_the_vessel_along_the_true_end_tangent(tube, sac, patch):
    """direction is the unit axis pointing out of the vessel (VesselEnd's docstring): +T(1) at the capped end t = 1
    and -T(0) at the open end t = 0 (T the exact tangent of C, towards increasing t; 1e-9); +x at x = 24 and -x at
    x = 0 on the sac tube; on the partly walled tube -axis at its open end (it lies along -axis behind the top),
    +axis at its top (within 10 degrees)."""
    D = np.array([e["direction"] for e in tube["json"]["ends"]])
    assert np.allclose(D, [_tangent([1.0])[0], -_tangent([0.0])[0]], atol=1e-9, rtol=0)

    D = np.array([e["direction"] for e in sac["json"]["ends"]])
    assert np.allclose(D, [[1, 0, 0], [-1, 0, 0]], atol=1e-6, rtol=0)

    D = np.array([e["direction"] for e in patch["json"]["ends"]])
    assert np.allclose(D[0], -PATCH_AXIS, atol=1e-9, rtol=0)
    assert np.linalg.norm(D[1]) == pytest.approx(1.0) and D[1] @ PATCH_AXIS > np.cos(np.radians(10))


def test_a_sac_is_listed_at_the_ball_with_its_radius_and_outward_direction(sac):
    """One sac: its radius the ball's 2.7 mm (10 %; wider than ENDS_SAC_RATIO x the wide end, and not a diameter),
    its centre the ball's centre (8, 4/3 + 2.7, 0) mm (within 15 % of the radius; in mm, not in file units of
    2.5 mm), its direction a unit vector pointing out of the vessel, away from the tube (+y, within 30 degrees)."""
    (s,) = sac["json"]["sacs"]
    assert abs(s["radius"] - SAC_RS) < 0.1 * SAC_RS and s["radius"] > tol.ENDS_SAC_RATIO * 2.0
    assert np.linalg.norm(np.array(s["center"]) - _sac_centre()) < 0.15 * SAC_RS
    n = np.array(s["direction"])
    assert np.linalg.norm(n) == pytest.approx(1.0) and n @ [0.0, 1.0, 0.0] > np.cos(np.radians(30))


def test_only_the_sac_tube_lists_a_sac(tube, patch):
    """The plain curved tube and the partly walled tube have no dome wider than their cut ends: sacs is empty."""
    assert tube["json"]["sacs"] == [] and patch["json"]["sacs"] == []


def test_a_partly_walled_flat_top_is_listed_as_not_a_cap_with_its_rim_share(patch):
    """One flat patch that is not a cap: its 60 fan faces; its centre the rim's (an even 60-gon: its area centroid
    is the centre, PATCH_P0, exact) and its radius the rim's 3 mm; its direction out of the vessel (+axis: the tube
    lies behind it); its reason the rim's share met by the wall, 1 - (a sixth of its chords) = 83 %."""
    (p,) = patch["json"]["not_caps"]
    assert p["n_faces"] == PATCH_N
    assert np.allclose(p["center"], PATCH_P0, atol=1e-9, rtol=0)
    assert p["radius"] == pytest.approx(PATCH_S, rel=1e-9)
    assert np.allclose(p["direction"], PATCH_AXIS, atol=1e-9, rtol=0)
    share = _patch_met_share()
    assert abs(share - 5.0 / 6.0) < 0.002 and share < tol.CAP_RIM_WALLED_FRACTION
    said = re.search(r"met by the wall on (\d+) % of its length", p["reason"])
    assert said is not None and int(said.group(1)) == round(100 * share), p["reason"]


def test_only_the_partly_walled_top_is_listed_as_not_a_cap(tube, sac):
    """The curved tube's flat cap closes it (a cap, not a refused patch) and the sac tube has no flat patch:
    not_caps is empty for both."""
    assert tube["json"]["not_caps"] == [] and sac["json"]["not_caps"] == []


# ============================================================================= clean_report.json

#: The faults built into the clean input, and how many of each.
FAULTS = {"unreferenced_vertices_removed": 4, "duplicate_vertices_merged": NR, "duplicate_faces_removed": 3,
          "zero_area_faces_removed": 3, "non_manifold_edges_repaired": 1, "non_manifold_faces_removed": 1,
          "non_manifold_vertices_split": 1, "components_found": 3, "components_removed": 2,
          "faces_flipped": 2 * NA * (NR - 1) + 2 * NA - 3, "smoothing_iterations": 0}


def _faulty_tube():
    """The closed tube with every fault of FAULTS (see the module doc), in mm: (V, F), and the tube alone (V, F)."""
    V, F = _tube(cap0=True, cap1=True, seam=True)
    m = NA + 1  # vertices per ring, the seam's duplicate last
    F = F.copy()
    zero = [[10, 10, 11], [50, 51, 50]]  # a repeated corner
    lost = [[7 * m, 7 * m + NA, 8 * m + 3]]  # ring 7's first vertex and its seam duplicate: a corner lost on merging
    inward = np.setdiff1d(np.arange(len(F)), [100, 250, 600])  # all but three faces, none adjacent, left outward
    F[inward] = F[inward][:, ::-1]
    dup = [F[5], F[300], np.roll(F[400], 1)]  # two exact copies, one with its corners rotated
    unref = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [30.0, 0.0, 0.0], [5.0, 5.0, 5.0]])
    a, b = F[150][:2]
    w = len(V) + len(unref)
    fin_v = (V[a] + V[b]) / 2 + [0.0, 0.0, 3.0]
    fin = [[a, b, w]]  # a third face on the edge (a, b)
    octa = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float) * 0.8 + [90, 40, -20]
    o = w + 1
    octa_F = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]) + o
    p = 20 * m + 5  # a wall vertex mid-tube: the tetrahedron stands on it outside the tube
    t = (20 / (NR - 1))
    out = unit(V[p] - _curve([t])[0])
    e1 = unit(np.cross(out, _tangent([t])[0]))
    e2 = np.cross(out, e1)
    tet_V = V[p] + np.array([0.5 * out + 0.3 * e1, 0.5 * out - 0.3 * e1, 0.9 * out + 0.3 * e2])
    q = o + 6
    tet_F = np.array([p, q, q + 1, q + 2])[np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])]
    VV = np.vstack([V, unref, fin_v[None], octa, tet_V])
    FF = np.vstack([F, dup, zero, lost, fin, octa_F, tet_F]).astype(np.int64)
    return VV, FF, _tube(cap0=True, cap1=True)


@pytest.fixture(scope="module", params=[".obj", ".ply"])
def faulty(tmp_path_factory, request):
    """The faulty tube in cm, cleaned with --units cm, as OBJ and as PLY (whose first reader, pymeshlab's, drops
    the faces with a repeated corner: every face written must still be counted and removed)."""
    d = tmp_path_factory.mktemp("clean")
    VV, FF, (Vt, Ft) = _faulty_tube()
    path = d / f"faulty{request.param}"
    write_mesh(path, VV / 10.0, FF)
    _run("clean", path, "--units", "cm", "-o", d / "c")
    return {"path": path, "V": VV, "F": FF, "tube": (Vt, Ft), "json": _json(d / "c" / "clean_report.json"),
            "cleaned": read_mesh(d / "c" / "faulty_clean.ply")}


@pytest.fixture(scope="module")
def smoothed(tmp_path_factory):
    """The closed tube without faults, in mm, cleaned with --smooth 3 and no units."""
    d = tmp_path_factory.mktemp("smooth")
    V, F = _tube(cap0=True, cap1=True)
    path = d / "tube.ply"
    write_mesh(path, V, F)
    _run("clean", path, "--smooth", 3, "-o", d / "c")
    return {"path": path, "V": V, "F": F, "json": _json(d / "c" / "clean_report.json"),
            "cleaned": read_mesh(d / "c" / "tube_clean.ply")}


def test_clean_counts_are_the_faults_built_into_the_input(faulty):
    """Each count is the number of faults of its kind built in: 4 unreferenced vertices, one seam duplicate per
    ring (40), 3 duplicate faces, 3 zero-area faces (2 with a repeated corner, 1 losing one on merging), 1 fin on
    1 non-manifold edge, 1 bow-tie vertex split, 3 components (tube, octahedron, tetrahedron) of which 2 are
    dropped, every tube face but the 3 left outward turned outward (1277), no smoothing."""
    d = faulty["json"]
    assert {k: d[k] for k in FAULTS} == FAULTS


def test_clean_sizes_are_the_input_file_and_the_tube_alone_written_in_millimetres(faulty):
    """vertices_before and faces_before are the file's (all written faces kept); vertices_after and faces_after
    the tube's alone (NR NA + 2 vertices, 2 NA (NR - 1) + 2 NA faces); the cleaned file holds exactly the tube's
    vertices in mm (not cm) and encloses the tube's volume with its faces outward."""
    d = faulty["json"]
    Vt, Ft = faulty["tube"]
    assert d["vertices_before"] == len(faulty["V"]) and d["faces_before"] == len(faulty["F"])
    assert d["vertices_after"] == len(Vt) == NR * NA + 2
    assert d["faces_after"] == len(Ft) == 2 * NA * (NR - 1) + 2 * NA
    V2, F2 = faulty["cleaned"]
    assert len(V2) == d["vertices_after"] and len(F2) == d["faces_after"]
    dist, idx = cKDTree(Vt).query(V2)
    assert dist.max() < 1e-9 and len(np.unique(idx)) == len(Vt)
    assert _signed_volume(V2, F2) == pytest.approx(_signed_volume(Vt, Ft), rel=1e-9) and _signed_volume(Vt, Ft) > 0


def test_clean_scale_is_that_of_the_repaired_tube_in_millimetres(faulty):
    """scale.bbox_diagonal is the tube's box diagonal in mm (the floating octahedron dropped, not in cm);
    scale.median_edge the median of the tube's face-corner edge lengths in mm; a tube of that size in mm needs no
    warning: units_guess "mm", warning null."""
    s = faulty["json"]["scale"]
    Vt, Ft = faulty["tube"]
    assert _bbox_diagonal(faulty["V"]) > 2 * _bbox_diagonal(Vt)  # the octahedron would show
    assert s["bbox_diagonal"] == pytest.approx(_bbox_diagonal(Vt), rel=1e-9)
    corners = np.linalg.norm(Vt[Ft[:, [1, 2, 0]]] - Vt[Ft], axis=2)
    assert s["median_edge"] == pytest.approx(float(np.median(corners)), rel=1e-9)
    assert s["units_guess"] == "mm" and s["warning"] is None


def test_clean_bookkeeping_and_summary_name_each_repair(faulty):
    """input the path given; units mm, input_units cm, to_mm 10; the summary names the sizes before and after
    and every repair with its count."""
    d = faulty["json"]
    assert d["input"] == str(faulty["path"])
    assert d["units"] == "mm" and d["input_units"] == "cm" and d["to_mm"] == 10.0
    Vt, Ft = faulty["tube"]
    said = d["summary"]
    assert f"{len(faulty['V'])}->{len(Vt)} vertices, {len(faulty['F'])}->{len(Ft)} faces" in said
    for phrase in (f"merged {NR} duplicate vertices", "removed 4 unreferenced vertices", "removed 3 duplicate faces",
                   "removed 3 zero-area faces", "repaired 1 non-manifold edges", "split 1 non-manifold vertices",
                   "dropped 2 small components", f"flipped {FAULTS['faces_flipped']} faces"):
        assert phrase in said, (phrase, said)
    assert "smoothing" not in said


def test_clean_of_a_faultless_mesh_counts_only_its_smoothing_iterations(smoothed):
    """A closed outward tube without faults, --smooth 3: every repair count 0, one component, 3 smoothing
    iterations; sizes unchanged and the faces kept as they were (the vertices moved); input_units "mm (assumed)",
    to_mm 1; the scale that of the cleaned file; the summary says only the smoothing."""
    d = smoothed["json"]
    want = {k: 0 for k in FAULTS} | {"components_found": 1, "smoothing_iterations": 3}
    assert {k: d[k] for k in FAULTS} == want
    n, m = len(smoothed["V"]), len(smoothed["F"])
    assert (d["vertices_before"], d["faces_before"], d["vertices_after"], d["faces_after"]) == (n, m, n, m)
    V2, F2 = smoothed["cleaned"]
    assert np.array_equal(F2, smoothed["F"])
    assert np.linalg.norm(V2 - smoothed["V"], axis=1).max() > 0  # smoothed: the vertices moved
    corners = np.linalg.norm(V2[F2[:, [1, 2, 0]]] - V2[F2], axis=2)
    assert d["input"] == str(smoothed["path"]) and d["units"] == "mm"
    assert d["input_units"] == "mm (assumed)" and d["to_mm"] == 1.0
    assert d["scale"]["bbox_diagonal"] == pytest.approx(_bbox_diagonal(V2), rel=1e-9)
    assert d["scale"]["median_edge"] == pytest.approx(float(np.median(corners)), rel=1e-9)
    assert d["summary"] == f"clean_mesh: {n}->{n} vertices, {m}->{m} faces: 3 iterations of Taubin smoothing"
