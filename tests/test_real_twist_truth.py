"""The twisted copies of real trees (``data_gen/real_twist.py``): is their twist truth what it says?

The generator's truth comes from VMTK's centre lines only; these tests check it with independent
computations on the meshes and VMTK's raw lines (not the generator's smoothed axis): rigid motions by
Kabsch fits, the main vessel's turn by a 2-D Procrustes fit of cross-sections about VMTK's chord
tangent, face orientations against the truth's own rotations, distances by libigl.
"""
from __future__ import annotations

import json

import igl
import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from _data import needs_real, real_twist, vmtk_lines
from _reference import arc_length

RENAL = "gmsh_abdominal-aorta-renal-iliac_open.stl"
XCAT = "xrayangio_xcat-coronary-tree_open.stl"
ILIAC = "vmtk_abdominal_aorta_iliac_bifurcation_open.stl"
ARCH = "gmsh_aortic-arch_open.stl"

pytestmark = needs_real(RENAL, XCAT, ILIAC, ARCH)


rt = real_twist()


def _kabsch(A, B):
    """Proper rotation Q and t with B ~ A @ Q.T + t (least squares)."""
    ca, cb = A.mean(axis=0), B.mean(axis=0)
    U, _, Wt = np.linalg.svd((A - ca).T @ (B - cb))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Wt.T @ U.T))])
    Q = Wt.T @ D @ U.T
    return Q, cb - ca @ Q.T


def _raw_tangents(P, R):
    """Chord tangent of VMTK's raw line at each of its points, over +-1 inscribed radius."""
    a = arc_length(P)
    lo = np.searchsorted(a, a - R)
    hi = np.clip(np.searchsorted(a, a + R), 0, len(P) - 1)
    t = P[hi] - P[lo]
    return t / np.linalg.norm(t, axis=1, keepdims=True)


def _raw_frame(P, R, s):
    """VMTK's raw line point at arc length ``s``, its chord tangent and inscribed radius."""
    i = int(np.clip(np.searchsorted(arc_length(P), s), 0, len(P) - 1))
    return P[i], _raw_tangents(P, R)[i], R[i]


def _unmoved(case):
    """Scan B brought back by the recorded rigid motion (scan A's frame)."""
    return (case.V_b - case.translation) @ case.rotation


@pytest.fixture(scope="module")
def renal_linear():
    """Renal-iliac tree, main vessel the aorta into its right iliac (line 0), 90 degrees linear, no remesh."""
    L = arc_length(vmtk_lines(RENAL)[0][0])[-1]
    return rt.twisted_copy(RENAL, 0, rt.alpha_profile("linear", 90.0, 0.0, L), remesh=False, seed=4)


def test_profiles():
    lin, sine, step = (rt.alpha_profile(k, 60.0, 10.0, 50.0) for k in ("linear", "sine", "step"))
    s = np.array([0.0, 10.0, 30.0, 50.0, 80.0])
    assert np.allclose(np.degrees(lin(s)), [0, 0, 30, 60, 60])
    assert np.allclose(np.degrees(sine(s)), [0, 0, 60, 0, 0], atol=1e-12)
    assert np.allclose(np.degrees(step(s)), [0, 0, 30, 60, 60])
    h = 1e-6  # the step is C1: no slope jump at its ends
    assert abs(step(50.0 - h) - step(50.0)) < 1e-9 and abs(step(10.0 + h) - step(10.0)) < 1e-9
    with pytest.raises(ValueError):
        rt.alpha_profile("linear", 10.0, 5.0, 5.0)


def test_no_twist_no_remesh_is_the_rigid_motion():
    case = rt.twisted_copy(XCAT, 1, rt.alpha_profile("linear", 0.0, 0.0, 1.0), remesh=False, seed=2)
    Rm, t = case.rotation, case.translation
    assert np.allclose(Rm @ Rm.T, np.eye(3), atol=1e-12) and np.isclose(np.linalg.det(Rm), 1.0)
    assert np.degrees(Rotation.from_matrix(Rm).magnitude()) >= 30.0
    assert 40.0 <= np.linalg.norm(t) <= 60.0
    assert np.array_equal(case.F_b, case.F_a)
    assert np.abs(case.V_b - (case.V_a @ Rm.T + t)).max() < 1e-9
    assert all(j.alpha == 0.0 for j in case.junctions)
    # a different seed, a different motion
    other = rt.twisted_copy(XCAT, 1, rt.alpha_profile("linear", 0.0, 0.0, 1.0), remesh=False, seed=3)
    assert not np.allclose(other.rotation, Rm)


def test_side_subtrees_turn_rigidly_by_the_junction_alpha(renal_linear):
    case = renal_linear
    lines = vmtk_lines(RENAL)
    P, R = lines[0]
    X = _unmoved(case)
    assert np.abs(X - case.V_twisted).max() < 1e-9
    assert len(case.junctions) >= 5  # four renal/visceral branches and the left iliac
    assert np.all(np.diff([j.s for j in case.junctions]) >= 0)
    for g, jn in enumerate(case.junctions):
        sub = case.labels == g
        assert sub.sum() > 100, (g, sub.sum())
        Q, t = _kabsch(case.V_a[sub], X[sub])
        assert np.abs(case.V_a[sub] @ Q.T + t - X[sub]).max() < 1e-8  # exactly rigid
        rv = Rotation.from_matrix(Q).as_rotvec()
        assert jn.alpha == pytest.approx(float(case.alpha(jn.s)), abs=1e-15)
        assert np.linalg.norm(rv) == pytest.approx(abs(jn.alpha), abs=1e-9)  # by alpha(s_j) ...
        c, T, r = _raw_frame(P, R, jn.s)  # ... about VMTK's main line tangent there, right-handed
        assert np.degrees(np.arccos(np.clip(np.dot(rv / np.linalg.norm(rv), T), -1, 1))) < 10.0
        # the junction point is on the turn's axis and on VMTK's main line
        assert np.linalg.norm(jn.point @ Q.T + t - jn.point) < 1e-8
        assert np.linalg.norm(jn.point - c) < 0.5 * r
        # the subtree's lines run with the main line before s and have left it two main radii after
        for j in jn.lines:
            Pj = lines[j][0]
            a = arc_length(Pj)
            d = cKDTree(P).query(Pj)[0]
            before = a < jn.s - 0.5 * jn.main_radius
            assert np.all(d[before] < 0.5 * jn.main_radius)
            assert np.all(d[a > jn.s + 2.0 * jn.main_radius] > 0.5 * jn.main_radius)
    # renal branches (narrow, steep) versus the iliac (the main vessel divides)
    renal = [j for j in case.junctions if j.s < 60.0]
    assert len(renal) == 4 and not any(j.divides for j in renal)
    assert all(j.side_radius < 0.4 * j.main_radius and 45.0 < j.angle_deg < 120.0 for j in renal)
    iliac = case.junctions[-1]
    assert iliac.lines == (1,) and iliac.divides


def test_main_vessel_far_end_turns_by_alpha(renal_linear):
    """Cross-sections near the main line's far end turn by alpha(s) about VMTK's tangent (2-D Procrustes)."""
    case = renal_linear
    P, R = vmtk_lines(RENAL)[0]
    a = arc_length(P)
    X = _unmoved(case)
    d, i = cKDTree(P).query(case.V_a)
    checked = 0
    for s in (a[-1] - 60.0, a[-1] - 40.0, a[-1] - 20.0):
        c, T, r = _raw_frame(P, R, s)
        sel = (np.abs(a[i] - s) < 0.3 * r) & (d < 2.0 * r) & (case.labels < 0) & (case.blend == 0)
        assert sel.sum() > 20
        # plane coordinates about T (any centre: the fitted 2-D rotation angle does not depend on it)
        e1 = np.cross(T, [1.0, 0.0, 0.0] if abs(T[0]) < 0.9 else [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(T, e1)
        A2 = np.stack([(case.V_a[sel] - c) @ e1, (case.V_a[sel] - c) @ e2], axis=1)
        B2 = np.stack([(X[sel] - c) @ e1, (X[sel] - c) @ e2], axis=1)
        A2c, B2c = A2 - A2.mean(axis=0), B2 - B2.mean(axis=0)
        ang = np.arctan2(np.sum(A2c[:, 0] * B2c[:, 1] - A2c[:, 1] * B2c[:, 0]), np.sum(A2c * B2c))
        expect = float(np.mean(case.alpha(a[i[sel]])))
        assert np.degrees(abs(ang - expect)) < 0.5, (s, np.degrees(ang), np.degrees(expect))
        # about VMTK's line: the fitted 2-D motion's fixed point is within a tenth of a radius of it
        rot = np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
        b0 = B2.mean(axis=0) - A2.mean(axis=0) @ rot.T
        fixed = np.linalg.solve(np.eye(2) - rot, b0)
        assert np.linalg.norm(fixed) < 0.1 * r, (s, np.linalg.norm(fixed), r)
        checked += 1
    assert checked == 3
    assert np.degrees(case.alpha(a[-1] - 20.0)) > 80.0  # a real turn there


def test_face_orientation_is_kept(renal_linear):
    """Twisted normals agree with scan A's turned by the truth's rotation (VMTK's tangent for main faces)."""
    case = renal_linear
    P, R = vmtk_lines(RENAL)[0]
    a = arc_length(P)
    F, V, X = case.F_a, case.V_a, _unmoved(case)

    def normals(W):
        n = np.cross(W[F[:, 1]] - W[F[:, 0]], W[F[:, 2]] - W[F[:, 0]])
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    cen = V[F].mean(axis=1)
    _, i = cKDTree(P).query(cen)
    rv = case.alpha(a[i])[:, None] * _raw_tangents(P, R)[i]
    lab = case.labels[F[:, 0]]
    for g, jn in enumerate(case.junctions):
        rv[lab == g] = jn.alpha * jn.tangent
    dots = np.einsum("ij,ij->i", Rotation.from_rotvec(rv).apply(normals(V)), normals(X))
    assert np.mean(dots > 0) >= 0.995
    checks = rt.check_case(case, self_intersections=False)
    assert checks["orientation_kept"] >= 0.995 and checks["axis_moved"] < 1e-9
    assert checks["main_line_moved_radii_p50_p95"][1] < 0.1  # VMTK's main line: only its scatter moves
    assert all(r["within_10pct"] == 1.0 for r in checks["side_lines"])


@pytest.mark.parametrize("name,main", [(ILIAC, 0), (ARCH, 0)])
def test_remeshed_scan_b_keeps_ends_and_surface(name, main):
    L = arc_length(vmtk_lines(name)[main][0])[-1]
    case = rt.twisted_copy(name, main, rt.alpha_profile("sine", 70.0, 0.0, L), remesh=True, seed=1)
    loops = lambda F: len(igl.boundary_loop_all(np.asarray(F, np.int64)))  # noqa: E731
    assert loops(case.F_b) == loops(case.F_a) > 0  # the open ends stay open
    assert not np.array_equal(case.F_b.shape, case.F_a.shape) or not np.array_equal(case.F_b, case.F_a)
    X, Fb = _unmoved(case), case.F_b
    tol = max(0.05, 0.15 * case.edge)  # two triangulations of one curved surface differ by their sagittas
    rng = np.random.default_rng(0)

    def samples(W, F):
        w = rng.dirichlet([1.0, 1.0, 1.0], size=len(F))
        return np.vstack([W[np.unique(F)], np.einsum("fk,fkd->fd", w, W[F])])

    d_b = np.sqrt(igl.point_mesh_squared_distance(samples(X, Fb), case.V_twisted, case.F_a)[0])
    d_a = np.sqrt(igl.point_mesh_squared_distance(samples(case.V_twisted, case.F_a), X, Fb)[0])
    assert d_b.max() < tol and d_a.max() < tol, (d_b.max(), d_a.max(), tol)
    assert np.percentile(d_b, 99) < 0.08 * case.edge and np.percentile(d_a, 99) < 0.08 * case.edge, (
        np.percentile(d_b, 99) / case.edge, np.percentile(d_a, 99) / case.edge)
    e = igl.edges(Fb)
    assert 0.7 * case.edge < np.median(np.linalg.norm(X[e[:, 0]] - X[e[:, 1]], axis=1)) < 1.3 * case.edge


def test_xcat_junction_table():
    table = rt.main_line_choices(XCAT)
    lines = vmtk_lines(XCAT)
    assert len(table) == len(lines) == 10
    assert max(len(js) for js in table) >= 6  # a main coronary with many side branches
    kinds = set()
    for k, js in enumerate(table):
        L = arc_length(lines[k][0])[-1]
        assert len(js) >= 1
        seen = set()
        assert np.all(np.diff([j.s for j in js]) >= 0)
        for j in js:
            assert k not in j.lines and not (seen & set(j.lines))
            seen |= set(j.lines)
            vals = [j.s, j.side_radius, j.main_radius, j.angle_deg, j.continuing_radius, j.alpha]
            assert np.all(np.isfinite(vals)) and np.all(np.isfinite(j.point)) and np.all(np.isfinite(j.tangent))
            assert 0.0 < j.s < L and j.side_radius > 0 and j.main_radius > 0 and 0.0 <= j.angle_deg <= 180.0
            assert isinstance(j.divides, bool) and abs(np.linalg.norm(j.tangent) - 1.0) < 1e-12
            d = j.to_dict()
            json.dumps(d)
            kinds.add((j.divides, 30.0 <= j.angle_deg <= 90.0))
    assert kinds >= {(True, True), (False, True)}  # divisions and side branches at 30-90 degrees


def test_cli_writes_the_case(tmp_path):
    import vesselgp

    out = tmp_path / "arch"
    assert rt.main([str(out), "--mesh", ARCH, "--main", "0", "--profile", "step", "--total-deg", "40",
                    "--seed", "5"]) == 0
    truth = json.loads((out / "truth.json").read_text())
    Va, Fa = vesselgp.read_mesh(out / "a.ply")[:2]
    Vb, Fb = vesselgp.read_mesh(out / "b.ply")[:2]
    assert len(Va) == truth["n_vertices_a"] and len(Vb) == truth["n_vertices_b"]
    assert truth["main_line"] == 0 and truth["units"] == "mm" and len(truth["junctions"]) == 2
    for j in truth["junctions"]:
        assert {"s", "alpha_deg", "lines", "side_radius", "main_radius", "angle_deg", "divides"} <= set(j)
        L = truth["main_length"]
        t = np.clip(j["s"] / L, 0, 1)
        assert j["alpha_deg"] == pytest.approx(40.0 * t * t * (3 - 2 * t), abs=1e-9)
    Rm = np.array(truth["rotation"])
    assert np.allclose(Rm @ Rm.T, np.eye(3))
    assert truth["checks"]["orientation_kept"] >= 0.995
