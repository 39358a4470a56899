"""Robustness on corrupted and unusual input (issue #8).

One test per case of the issue: each either raises a :class:`vesselgp.VesselError`
subclass whose one-line message names the problem and the fix, or is repaired
(by :func:`vesselgp.clean_mesh` or inside the call) and then fits. A
property-based test corrupts small synthetic vessels at random and checks that
every public call either returns finite results or raises a VesselError.
"""
from __future__ import annotations

import contextlib
import logging
import signal
import tempfile
import warnings
from datetime import timedelta
from pathlib import Path
from types import SimpleNamespace

import nlopt
import numpy as np
import pymeshlab
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.sparse.linalg import MatrixRankWarning

import vesselgp
from vesselgp import (
    EndsError,
    FrameError,
    InvalidMeshError,
    MeshReadError,
    MismatchError,
    NotTubularError,
    OptimizationError,
    VesselError,
    clean_mesh,
    fit_generalized_cylinder,
    measure_torsion,
    read_mesh,
    vessel_ends,
    write_mesh,
)
from vesselgp import tolerances as tol
from vesselgp.synthetic import deform_synthetic, named_curve, paper_case, synthetic_vessel
from _data import REAL

R0 = 1.5


def one_line(exc_info):
    msg = str(exc_info.value)
    assert "\n" not in msg and msg.strip() == msg and msg
    return msg


@pytest.fixture(scope="module")
def tube():
    """Structured open arc of radius 1.5: 492 vertices, 960 faces, 12 around."""
    return synthetic_vessel("arc", radius=R0, n_around=12, remesh=False)


@pytest.fixture(scope="module")
def tube_fit(tube):
    return fit_generalized_cylinder(tube.V, tube.F)


def assert_same_fit(gc, ref, rtol=1e-2):
    """Two fits of (nearly) the same vessel agree (centres to rtol radii, radii to rtol)."""
    assert np.all(np.isfinite(gc.centers)) and np.all(np.isfinite(gc.radii))
    assert np.abs(gc.centers - ref.centers).max() < rtol * R0 * 10
    assert np.abs(gc.radii - ref.radii).max() < rtol * R0 * 10
    assert abs(gc.mean_radius - ref.mean_radius) < rtol * R0


# ----------------------------------------------------------------------------- hierarchy


def test_one_error_hierarchy():
    for cls in (vesselgp.MeshReadError, vesselgp.MeshWriteError, InvalidMeshError, NotTubularError,
                EndsError, MismatchError, FrameError, OptimizationError, vesselgp.OptionError):
        assert issubclass(cls, VesselError) and issubclass(cls, ValueError)


# ----------------------------------------------------------------------------- files


def test_empty_file(tmp_path):
    p = tmp_path / "empty.stl"
    p.write_bytes(b"")
    with pytest.raises(MeshReadError) as ei:
        read_mesh(p)
    assert "file is empty; re-export the mesh" in one_line(ei)


@pytest.mark.parametrize("ext", [".stl", ".ply", ".obj", ".off", ".vtp"])
def test_unreadable_file(tmp_path, ext):
    p = tmp_path / f"garbage{ext}"
    p.write_bytes(b"\x00\x01 this is not a mesh \xff" * 7)
    with pytest.raises(MeshReadError) as ei:
        read_mesh(p)
    msg = one_line(ei)
    assert str(p) in msg and ("re-export" in msg or "check" in msg)


def test_unknown_format(tmp_path):
    p = tmp_path / "vessel.xyz"
    p.write_text("0 0 0\n")
    with pytest.raises(MeshReadError) as ei:
        read_mesh(p)
    msg = one_line(ei)
    assert "unknown mesh extension '.xyz'" in msg and ".stl" in msg and "convert" in msg
    with pytest.raises(vesselgp.MeshWriteError, match="unknown output extension"):
        write_mesh(tmp_path / "out.xyz", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])


def test_missing_file(tmp_path):
    with pytest.raises(MeshReadError, match="no such file; check the path"):
        read_mesh(tmp_path / "nope.stl")


# ----------------------------------------------------------------------------- faces


def test_non_triangular_faces_array_is_rejected(tube):
    quads = np.c_[tube.F, tube.F[:, 0]]
    with pytest.raises(InvalidMeshError) as ei:
        fit_generalized_cylinder(tube.V, quads)
    msg = one_line(ei)
    assert "4 vertices per face; vesselgp needs triangles" in msg and "read_mesh" in msg


def test_non_triangular_faces_in_file_are_triangulated(tmp_path, tube, tube_fit):
    """Repair: read_mesh fan-triangulates polygons; the quad mesh then fits like the tri mesh."""
    n = 12
    rings = len(tube.V) // n
    a = np.arange(n)
    Q = np.vstack([np.c_[i * n + a, i * n + (a + 1) % n, (i + 1) * n + (a + 1) % n, (i + 1) * n + a]
                   for i in range(rings - 1)])
    # same orientation as the triangle mesh
    if not set(map(tuple, tube.F[:, :2].tolist())) & set(map(tuple, Q[:, :2].tolist())):
        Q = Q[:, ::-1]
    p = tmp_path / "quads.obj"
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in tube.V] + [f"f {' '.join(str(i + 1) for i in q)}" for q in Q]
    p.write_text("\n".join(lines) + "\n")
    V, F = read_mesh(p)
    assert F.shape == (2 * len(Q), 3)
    gc = fit_generalized_cylinder(V, F)
    assert_same_fit(gc, tube_fit)


def test_face_index_out_of_range(tube):
    F = tube.F.copy()
    F[5, 1] = len(tube.V)
    with pytest.raises(InvalidMeshError, match=r"F indexes vertices in \[0, 492\] but V has 492 rows"):
        fit_generalized_cylinder(tube.V, F)


# ----------------------------------------------------------------------------- coordinates


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_nan_or_infinite_coordinates(tube, bad):
    V = tube.V.copy()
    V[7, 2] = bad
    for call in (lambda: fit_generalized_cylinder(V, tube.F), lambda: clean_mesh(V, tube.F),
                 lambda: vessel_ends(V, tube.F), lambda: measure_torsion(tube.V, V, tube.F)):
        with pytest.raises(InvalidMeshError) as ei:
            call()
        assert "1 rows with NaN or infinite coordinates; remove or repair them" in one_line(ei)


def test_nan_in_file(tmp_path, tube):
    p = tmp_path / "nan.off"
    V = tube.V.copy()
    V[3] = np.nan
    lines = ["OFF", f"{len(V)} {len(tube.F)} 0"] + [f"{x} {y} {z}" for x, y, z in V]
    lines += [f"3 {a} {b} {c}" for a, b, c in tube.F]
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(InvalidMeshError) as ei:
        read_mesh(p)
    assert "NaN or infinite" in one_line(ei)


# ----------------------------------------------------------------------------- duplicates


def _unmerge_seam(V, F, n_around=12):
    """Split the tube along one seam line of vertices (as an unmerged STL export would)."""
    seam = np.arange(0, len(V), n_around)  # vertex 0 of every ring
    V2 = np.vstack([V, V[seam]])
    new = dict(zip(seam.tolist(), range(len(V), len(V) + len(seam))))
    F2 = F.copy()
    # faces on one side of the seam (those using vertex 1 of a ring) take the copies
    side = np.isin(F2, np.arange(1, len(V), n_around)).any(axis=1)
    for f in np.flatnonzero(side):
        F2[f] = [new.get(int(i), int(i)) for i in F2[f]]
    return V2, F2


def test_duplicate_vertices_error_then_repair(tube, tube_fit):
    V2, F2 = _unmerge_seam(tube.V, tube.F)
    with pytest.raises(InvalidMeshError) as ei:
        fit_generalized_cylinder(V2, F2)
    msg = one_line(ei)
    assert msg.startswith(f"mesh has open seams of {len(V2) - len(tube.V)} duplicate vertices (") and (
        "run vesselgp.clean_mesh (command line: vesselgp clean) to merge them" in msg)
    V3, F3, rep = clean_mesh(V2, F2)
    assert rep.duplicate_vertices_merged == len(V2) - len(tube.V)
    assert len(V3) == len(tube.V)
    assert_same_fit(fit_generalized_cylinder(V3, F3), tube_fit)


def test_unreferenced_vertex(tube):
    V = np.vstack([tube.V, [[100.0, 0, 0]]])
    with pytest.raises(InvalidMeshError) as ei:
        fit_generalized_cylinder(V, tube.F)
    assert "1 unreferenced vertices; run vesselgp.clean_mesh first" in one_line(ei)


# ----------------------------------------------------------------------------- degenerate faces


def test_repeated_index_face_error_then_repair(tube, tube_fit):
    F = np.vstack([tube.F, [[5, 5, 6]]])
    with pytest.raises(InvalidMeshError) as ei:
        fit_generalized_cylinder(tube.V, F)
    assert "1 faces with a repeated vertex index (zero area); run vesselgp.clean_mesh" in one_line(ei)
    V2, F2, rep = clean_mesh(tube.V, F)
    assert rep.zero_area_faces_removed == 1
    assert_same_fit(fit_generalized_cylinder(V2, F2), tube_fit)


def test_zero_area_face_is_ignored_by_the_fit(tube, tube_fit):
    """A vertex moved onto an edge of its face: area ~1e-16, infinite cotangent weights.

    clean_mesh keeps it (not exactly zero), and the fit leaves it out of the areas
    and the harmonic field instead of returning NaN.
    """
    V = tube.V.copy()
    f = tube.F[100]
    V[f[2]] = 0.5 * (V[f[0]] + V[f[1]])
    gc = fit_generalized_cylinder(V, tube.F)
    assert np.all(np.isfinite(gc.vertex_s)) and np.all(np.isfinite(gc.vertex_theta))
    assert_same_fit(gc, tube_fit, rtol=3e-2)
    V2, F2, _ = clean_mesh(V, tube.F)
    assert np.all(np.isfinite(fit_generalized_cylinder(V2, F2).centers))


@pytest.mark.parametrize("threaded", [False, True])
def test_faces_with_a_zero_length_edge_are_left_out_of_the_areas(tube, tube_fit, threaded, monkeypatch):
    """Two distinct vertices at one position (an unmerged seam point): the two faces across their
    edge have a zero-length edge, and their corners no Voronoi area (NaN in libigl's formula). The
    fit leaves them out of the wall's areas and matches the clean tube's fit (with the areas
    computed beside the ends on a second thread, as on large meshes, or not)."""
    if threaded:
        monkeypatch.setattr(tol, "THREAD_MIN_VERTICES", 0)
    V = tube.V.copy()
    f = tube.F[100]
    V[f[1]] = V[f[0]]  # f[1] moves onto f[0]
    gc = fit_generalized_cylinder(V, tube.F)
    assert np.all(np.isfinite(gc.vertex_area)) and np.all(gc.vertex_area >= 0)
    assert_same_fit(gc, tube_fit, rtol=3e-2)


def test_vertex_only_in_zero_area_faces(tube):
    """A vertex whose only faces all have zero area has no area weight: clear error."""
    V = np.vstack([tube.V, tube.V[0] + 0.5 * (tube.V[1] - tube.V[0])])  # on the rim edge 0-1
    F = np.vstack([tube.F, [[0, 1, len(tube.V)]]])
    with pytest.raises(InvalidMeshError) as ei:
        fit_generalized_cylinder(V, F)
    assert "1 zero-area faces and 1 vertices used only by them; run vesselgp.clean_mesh" in one_line(ei)


# ----------------------------------------------------------------------------- topology


def test_non_manifold_edge_error_then_repair(tube, tube_fit):
    e = tube.F[200, :2]
    # a fin: a third face on an interior edge
    V = np.vstack([tube.V, tube.V[e].mean(0) + [0, 0, 3.0]])
    n = len(tube.V)
    F = np.vstack([tube.F, [[e[1], e[0], n]]])
    with pytest.raises(InvalidMeshError) as ei:
        fit_generalized_cylinder(V, F)
    msg = one_line(ei)
    assert "non-manifold edges (shared by more than two faces); run vesselgp.clean_mesh" in msg
    V2, F2, rep = clean_mesh(V, F)
    assert rep.non_manifold_edges_repaired == 1 and rep.non_manifold_faces_removed == 1
    assert_same_fit(fit_generalized_cylinder(V2, F2), tube_fit)


def test_inconsistent_orientation_is_mended_or_repaired(tube, tube_fit):
    """Since issue #34 a winding fault alone is mended by the fit (logged); clean_mesh repairs it too."""
    F = tube.F.copy()
    F[::3] = F[::3, ::-1]
    before = F.copy()
    assert len(vessel_ends(tube.V, F)) == 2
    assert_same_fit(fit_generalized_cylinder(tube.V, F), tube_fit)
    assert np.array_equal(F, before)  # the caller's faces are not touched
    V2, F2, rep = clean_mesh(tube.V, F)
    assert rep.faces_flipped > 0
    assert_same_fit(fit_generalized_cylinder(V2, F2), tube_fit)


def test_orientation_is_mended_only_where_it_is_the_one_fault():
    """orient_faces at its edge: one tetrahedron with a face turned is mended (outward); the same beside
    a second, disjoint one is left as it is for the connectivity check, which names the pieces."""
    from vesselgp.mesh._geometry import signed_volume
    from vesselgp.mesh.orient import orient_faces

    V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    F = np.array([[0, 2, 1], [0, 3, 1], [0, 3, 2], [1, 2, 3]])  # the second face turned
    G, topo = orient_faces(V, F)
    assert len(topo.incoherent_edges) == 0 and signed_volume(V, G) > 0
    V2, F2 = np.vstack([V, V + 5.0]), np.vstack([F, F + 4])
    assert orient_faces(V2, F2)[0] is F2
    with pytest.raises(InvalidMeshError, match="connected components"):
        vesselgp.fit.checked_mesh(V2, F2)


def test_several_components_error_then_repair(tube, tube_fit):
    small = synthetic_vessel(named_curve("straight", length=6.0), radius=0.5, n_around=8, remesh=False)
    V = np.vstack([tube.V, small.V + [50.0, 0, 0]])
    F = np.vstack([tube.F, small.F + len(tube.V)])
    with pytest.raises(InvalidMeshError) as ei:
        fit_generalized_cylinder(V, F)
    msg = one_line(ei)
    assert "mesh has 2 connected components; run vesselgp.clean_mesh (keeps the largest)" in msg
    V2, F2, rep = clean_mesh(V, F)
    assert rep.components_found == 2 and rep.components_removed == 1
    assert_same_fit(fit_generalized_cylinder(V2, F2), tube_fit)


def test_isolated_triangle_is_a_component(tube, tube_fit):
    n = len(tube.V)
    V = np.vstack([tube.V, [[50, 50, 50], [51, 50, 50], [50, 51, 50]]])
    F = np.vstack([tube.F, [[n, n + 1, n + 2]]])
    with pytest.raises(InvalidMeshError, match="2 connected components"):
        fit_generalized_cylinder(V, F)
    V2, F2, _ = clean_mesh(V, F)
    assert_same_fit(fit_generalized_cylinder(V2, F2), tube_fit)


def test_holes_name_the_holes(tube, tube_fit):
    """Missing faces make extra boundary loops: the error lists them and says how to proceed."""
    keep = np.ones(len(tube.F), bool)
    keep[[300, 301, 600, 601]] = False  # two quad holes in the wall
    F = tube.F[keep]
    with pytest.raises(EndsError) as ei:
        fit_generalized_cylinder(tube.V, F)
    msg = one_line(ei)
    assert msg.startswith("mesh has 4 open ends; pass ends=(i, j) to choose the vessel's path")
    assert "if they are holes, close them first" in msg
    gc = fit_generalized_cylinder(tube.V, F, ends=(0, 1))  # the two wide ends
    assert_same_fit(gc, tube_fit, rtol=3e-2)


def test_closed_sphere_is_not_a_vessel():
    ms = pymeshlab.MeshSet()
    ms.create_sphere(subdiv=3)
    m = ms.current_mesh()
    V, F = m.vertex_matrix() * 10.0, m.face_matrix().astype(np.int64)
    for call in (vessel_ends, fit_generalized_cylinder):
        with pytest.raises(NotTubularError) as ei:
            call(V, F)
        assert one_line(ei).startswith("mesh is not tubular: no two ends found")


def test_branch_without_chosen_ends():
    V, F = read_mesh(REAL / "vmtk_abdominal_aorta_iliac_bifurcation_open.stl")
    with pytest.raises(EndsError) as ei:
        fit_generalized_cylinder(V, F)
    msg = one_line(ei)
    assert msg.startswith("mesh has 3 open ends; pass ends=(i, j) to choose the vessel's path")
    assert "holes" not in msg  # the iliacs are branches, not holes
    with pytest.raises(EndsError, match="names the same end twice"):
        fit_generalized_cylinder(V, F, ends=(1, 1))
    with pytest.raises(EndsError, match="indices must be integers in 0..2"):
        fit_generalized_cylinder(V, F, ends=(0, 3))


def test_vessel_shorter_than_its_diameter():
    ves = synthetic_vessel(named_curve("straight", length=2.0), radius=R0, n_around=12, remesh=False)
    with pytest.raises(NotTubularError) as ei:
        fit_generalized_cylinder(ves.V, ves.F)
    msg = one_line(ei)
    assert "vessel is shorter than its diameter (axis 2, diameter 3)" in msg


def test_bad_n_nodes(tube):
    for bad in (2, 3.5, True):
        with pytest.raises(VesselError, match="n_nodes must be an integer of at least 4"):
            fit_generalized_cylinder(tube.V, tube.F, n_nodes=bad)


# ----------------------------------------------------------------------------- torsion


def test_rest_deformed_mismatch_message_of_the_issue():
    # 100 rings of 12: exactly 1200 vertices, as in the issue's example
    ves = synthetic_vessel("straight", radius=R0, n_around=12, spacing=30.0 / 99, remesh=False)
    assert len(ves.V) == 1200
    V_def = ves.V[:-12]
    with pytest.raises(MismatchError) as ei:
        measure_torsion(ves.V, V_def, ves.F)
    assert one_line(ei).startswith("rest and deformed meshes differ: 1200 vs 1188 vertices")
    meter = vesselgp.TorsionMeter(ves.V, ves.F)
    with pytest.raises(MismatchError, match="rest and deformed meshes differ: 1200 vs 1188 vertices"):
        meter(V_def)
    other = synthetic_vessel("straight", radius=R0, n_around=12, remesh=False)
    with pytest.raises(MismatchError, match="fit it on V_rest"):
        vesselgp.TorsionMeter(ves.V, ves.F, rest=fit_generalized_cylinder(other.V, other.F))


def test_collapsed_deformed_mesh(tube):
    with pytest.raises(NotTubularError) as ei:
        measure_torsion(tube.V, np.zeros_like(tube.V), tube.F)
    assert "axis collapsed to a point" in one_line(ei)


# ----------------------------------------------------------------------------- frames


@pytest.mark.parametrize(
    "tangent, match",
    [([0, 0, 0], "tangent is the zero vector; give the direction of the vessel axis"),
     ([np.nan, 0, 1], "tangent has NaN or infinite entries"),
     ([0, 0], "tangent must be a 3-vector")],
)
def test_target_frame_with_bad_tangent(tangent, match):
    with pytest.raises(FrameError) as ei:
        vesselgp.Frame([0, 0, 0], tangent, [1, 0, 0])
    assert match in one_line(ei)


def test_frame_other_degeneracies_and_extreme_scales():
    with pytest.raises(FrameError, match="normal is parallel to tangent; give a normal across the axis"):
        vesselgp.Frame([0, 0, 0], [0, 0, 1], [0, 0, 5])
    with pytest.raises(FrameError, match="normal is the zero vector"):
        vesselgp.Frame([0, 0, 0], [0, 0, 1], [0, 0, 0])
    # directions are unit-free: tiny and huge vectors are fine (no underflow or overflow)
    for k in (1e-300, 1e-9, 1e9, 1e300):
        f = vesselgp.Frame([0, 0, 0], [k, k, 0], [0, 0, k])
        assert np.allclose(f.tangent, [2**-0.5, 2**-0.5, 0]) and np.allclose(f.normal, [0, 0, 1])
    with pytest.raises(FrameError, match="target must be a vesselgp.Frame"):
        vesselgp.JoinProblem(None, None, None, None, target=([0, 0, 0], [0, 0, 0], [1, 0, 0]))


def test_deform_vessel_with_zero_tangent_target():
    c = paper_case(1, resolution=0.25)
    with pytest.raises(FrameError, match="tangent is the zero vector"):
        vesselgp.deform_vessel(c.V, c.F, c.fixed, c.moving, (c.target_origin, [0, 0, 0], c.target_normal))


@pytest.mark.parametrize("kw, match", [({"method": "bogus"}, "unknown deformation method 'bogus'; use one of"),
                                       ({"stiffness": "soft"}, "unknown stiffness 'soft'; use 'uniform'")])
def test_unknown_keyword_option_values(tube, tube_fit, kw, match):
    from vesselgp.deform import RodDeformer

    with pytest.raises(vesselgp.OptionError, match=match) as e:
        RodDeformer(tube.V, tube.F, [0], [len(tube.V) - 1], gc=tube_fit, **kw)
    one_line(e)


def test_rmf_relative_tolerances():
    P = np.c_[np.linspace(0, 1, 20), np.zeros(20), np.zeros(20)]
    for k in (1e-9, 1.0, 1e9):
        T, U, V = vesselgp.rotation_minimizing_frames(P * k, tangents=np.tile([k, 0, 0], (20, 1)),
                                                      initial_normal=[0, k, 0])
        assert np.allclose(U, [0, 1, 0])
    with pytest.raises(FrameError, match="a tangent is zero"):
        vesselgp.rotation_minimizing_frames(P, tangents=np.r_[np.tile([1.0, 0, 0], (19, 1)), [[0, 0, 0]]])
    with pytest.raises(FrameError, match="initial_normal is the zero vector"):
        vesselgp.rotation_minimizing_frames(P, initial_normal=[0, 0, 0])
    with pytest.raises(FrameError, match="initial_normal is parallel to the first tangent"):
        vesselgp.rotation_minimizing_frames(P, initial_normal=[3, 0, 0])


# ----------------------------------------------------------------------------- NLopt


class _Quadratic(vesselgp.JoinProblem):
    """A JoinProblem stand-in with an analytic energy (no mesh): E = (a - 0.3)^2, or bad values."""

    def __init__(self, bad_after=None, bad=np.nan):  # noqa: D107 - no parent init on purpose
        self.calls = 0
        self.bad_after = bad_after
        self.bad = bad

    zero_twist_angle = 0.0
    meter = SimpleNamespace(smoothing=1.0)  # what minimize_torsion reads of a problem's meter and profile

    def energy(self, angle):
        self.calls += 1
        if self.bad_after is not None and self.calls > self.bad_after:
            return self.bad
        return (angle - 0.3) ** 2

    def _evaluate(self, angle):
        return None, SimpleNamespace(smoothing_residual=0.0)

    def result_fields(self, X):
        return {}


def test_nlopt_success_on_the_stand_in():
    res = vesselgp.minimize_torsion(_Quadratic())
    assert abs(res.angle - 0.3) < 1e-3 and res.status > 0


@pytest.mark.parametrize("bad", [np.nan, np.inf])
@pytest.mark.parametrize("bad_after", [0, 3])  # at a probe, or inside NLopt
def test_nlopt_non_finite_energy(bad, bad_after):
    with pytest.raises(OptimizationError) as ei:
        vesselgp.minimize_torsion(_Quadratic(bad_after=bad_after, bad=bad))
    assert "torsion energy is not finite at angle" in one_line(ei) and "check the mesh and target" in str(ei.value)


@pytest.mark.parametrize("exc", [RuntimeError("nlopt failure"), ValueError("nlopt invalid argument"),
                                 MemoryError()])
def test_nlopt_raises(monkeypatch, exc):
    def boom(self, x):
        raise exc

    monkeypatch.setattr(nlopt.opt, "optimize", boom)
    with pytest.raises(OptimizationError) as ei:
        vesselgp.minimize_torsion(_Quadratic())
    assert "NLopt LN_BOBYQA failed" in one_line(ei) and "try algorithm='LN_COBYLA'" in str(ei.value)


def test_nlopt_roundoff_limited_keeps_the_best(monkeypatch):
    def roundoff(self, x):
        raise nlopt.RoundoffLimited("roundoff")

    monkeypatch.setattr(nlopt.opt, "optimize", roundoff)
    res = vesselgp.minimize_torsion(_Quadratic())
    assert res.status_name == "ROUNDOFF_LIMITED" and np.isfinite(res.energy)


def test_nlopt_bad_algorithm_and_problem():
    with pytest.raises(OptimizationError, match="unknown derivative-free NLopt algorithm 'LD_LBFGS'"):
        vesselgp.minimize_torsion(_Quadratic(), algorithm="LD_LBFGS")
    with pytest.raises(OptimizationError, match="needs a vesselgp.JoinProblem"):
        vesselgp.minimize_torsion("not a problem")


def test_nlopt_nan_energy_on_a_real_problem(monkeypatch):
    c = paper_case(1, resolution=0.25)
    p = vesselgp.JoinProblem(c.V, c.F, c.fixed, c.moving,
                             vesselgp.Frame(c.target_origin, c.target_tangent, c.target_normal))
    calls = {"n": 0}
    real = vesselgp.JoinProblem.energy

    def flaky(self, a):
        calls["n"] += 1
        return np.nan if calls["n"] > 4 else real(self, a)

    monkeypatch.setattr(vesselgp.JoinProblem, "energy", flaky)
    with pytest.raises(OptimizationError, match="not finite"):
        vesselgp.minimize_torsion(p)


# ----------------------------------------------------------------------------- units and scale


def test_metres_are_reported_with_the_scale(tube, caplog):
    with caplog.at_level(logging.WARNING, logger="vesselgp"):
        fit_generalized_cylinder(tube.V * 1e-3, tube.F)
    msgs = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any("looks like metres" in m and "multiply V by 1000" in m and "median edge" in m
               and "end radii 0.0015 to 0.0015" in m for m in msgs), msgs


def test_centimetres_are_reported(caplog):
    ves = synthetic_vessel(named_curve("straight", length=3.0), radius=0.15, n_around=48, remesh=False)
    with caplog.at_level(logging.WARNING, logger="vesselgp"):
        fit_generalized_cylinder(ves.V, ves.F)
    assert any("centimetres" in r.getMessage() for r in caplog.records if r.levelno == logging.WARNING)


def test_millimetres_give_no_warning(tube, caplog):
    with caplog.at_level(logging.INFO, logger="vesselgp"):
        fit_generalized_cylinder(tube.V, tube.F)
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert any("mesh scale: median edge" in r.getMessage() and "units look like mm" in r.getMessage()
               for r in caplog.records)


@pytest.mark.parametrize("k", [1e-3, 1e3])
def test_fit_and_torsion_are_scale_invariant(tube, tube_fit, k):
    gc = fit_generalized_cylinder(tube.V * k, tube.F)
    L = tube_fit.length
    assert np.abs(gc.centers / k - tube_fit.centers).max() <= 1e-6 * L
    assert np.abs(gc.radii / k - tube_fit.radii).max() <= 1e-6 * tube_fit.mean_radius
    assert abs(gc.length / k - L) <= 1e-6 * L
    assert np.abs(gc.vertex_s - tube_fit.vertex_s).max() <= 1e-6
    Vd = deform_synthetic(tube, twist=1.0)
    p1 = measure_torsion(tube.V, Vd, tube.F)
    p2 = measure_torsion(tube.V * k, Vd * k, tube.F)
    assert abs(p2.energy - p1.energy) <= 1e-6 * p1.energy
    assert np.abs(p2.alpha - p1.alpha).max() <= 1e-6


# ----------------------------------------------------------------------------- property-based


@pytest.fixture(scope="module")
def bases():
    """Small structured vessels: an open arc, a capped straight tube, an open helix."""
    return [
        synthetic_vessel("arc", radius=R0, n_around=12, remesh=False),
        synthetic_vessel(named_curve("straight", length=12.0), radius=R0, n_around=10, ends="capped",
                         remesh=False),
        synthetic_vessel("helix", radius=R0, n_around=8, remesh=False),
    ]


def _corrupt(V, F, op, rng):
    """Apply one corruption; returns new (V, F) (F may not be (m, 3) any more)."""
    V = V.copy()
    F = F.copy()
    n, m = len(V), len(F)
    if op == "drop_faces":
        F = F[rng.random(m) > rng.uniform(0.01, 0.3)]
    elif op == "duplicate_vertices":
        k = rng.integers(1, 20)
        ids = rng.choice(n, k, replace=False)
        V = np.vstack([V, V[ids]])
        for j, i in enumerate(ids):
            faces = np.flatnonzero((F == i).any(1))
            half = faces[: max(1, len(faces) // 2)]
            F[half] = np.where(F[half] == i, n + j, F[half])
    elif op in ("nan", "inf"):
        V[rng.integers(n), rng.integers(3)] = np.nan if op == "nan" else -np.inf
    elif op == "jitter":
        V += rng.normal(scale=rng.choice([0.01, 0.1, 0.5, 3.0]), size=V.shape)
    elif op == "scale":
        V *= rng.choice([1e-3, 1e3, 1e-6])
    elif op == "flip_faces":
        sel = rng.random(m) < rng.uniform(0.01, 1.0)
        F[sel] = F[sel, ::-1]
    elif op == "isolated_triangle":
        c = V.mean(0) + rng.normal(size=3) * 50
        V = np.vstack([V, c, c + [1, 0, 0], c + [0, 1, 0]])
        F = np.vstack([F, [[n, n + 1, n + 2]]])
    elif op == "delete_ring":
        r0 = rng.integers(0, max(1, n // 8)) * 8
        F = F[~np.isin(F, np.arange(r0, r0 + rng.integers(1, 13))).any(1)]
    elif op == "index_out_of_range":
        F[rng.integers(m), rng.integers(3)] = rng.choice([n, n + 5, -1])
    elif op == "collapse_face":
        f = rng.integers(m)
        F[f, 1] = F[f, 0]
    elif op == "collinear_face":
        f = F[rng.integers(m)]
        V[f[2]] = V[f[0]] + rng.uniform(0, 1) * (V[f[1]] - V[f[0]])
    elif op == "collapse_vertices":
        ids = rng.choice(n, rng.integers(2, max(3, n // 4)), replace=False)
        V[ids] = V[ids[0]]
    elif op == "quads":
        F = np.c_[F, F[:, 0]]
    elif op == "fin":
        f = F[rng.integers(m)]
        V = np.vstack([V, V[f[:2]].mean(0) + rng.normal(size=3)])
        F = np.vstack([F, [[f[0], f[1], n]]])
    elif op == "unreferenced":
        V = np.vstack([V, rng.normal(size=(3, 3))])
    elif op == "renumber":
        perm = rng.permutation(n)
        inv = np.empty(n, np.int64)
        inv[perm] = np.arange(n)
        ok = (F >= 0) & (F < n)  # indices corrupted earlier stay as they are
        V, F = V[perm], np.where(ok, inv[np.where(ok, F, 0)], F)
        F = F[rng.permutation(m)]
    elif op == "flatten":
        V[:, rng.integers(3)] = 0.0
    elif op == "few_faces":
        F = F[: rng.integers(1, 6)]
    elif op == "float_faces":
        F = F.astype(np.float64) + rng.choice([0.0, 0.5])
    return V, F


OPS = ["drop_faces", "duplicate_vertices", "nan", "inf", "jitter", "scale", "flip_faces",
       "isolated_triangle", "delete_ring", "index_out_of_range", "collapse_face", "collinear_face",
       "collapse_vertices", "quads", "fin", "unreferenced", "renumber", "flatten", "few_faces", "float_faces"]


@contextlib.contextmanager
def _time_limit(seconds):
    """Fail (rather than hang) when one example takes far longer than any should."""
    def handler(signum, frame):
        raise TimeoutError(f"example took more than {seconds} s")

    old = signal.signal(signal.SIGALRM, handler)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _call(fn, *args, **kw):
    """Result of fn, or None when it raised a VesselError with a one-line message."""
    try:
        return fn(*args, **kw)
    except VesselError as exc:
        msg = str(exc)
        assert msg and "\n" not in msg, f"{type(exc).__name__} message is not one line: {msg!r}"
        return None


def _finite(*arrays):
    for a in arrays:
        assert np.all(np.isfinite(np.asarray(a, dtype=float))), "non-finite result"


def _check_fit(gc, n):
    _finite(gc.centers, gc.radii, gc.frames, gc.vertex_s, gc.vertex_theta, gc.vertex_weight, gc.length)
    assert len(gc.vertex_s) == n and gc.length > 0


@settings(max_examples=70, deadline=timedelta(seconds=8), derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(base=st.integers(0, 2), ops=st.lists(st.tuples(st.sampled_from(OPS), st.integers(0, 2**16)),
                                                min_size=1, max_size=3),
       fmt=st.sampled_from([".ply", ".obj", ".off", ".stl", ".vtp"]))
def test_corrupted_meshes_fail_cleanly(bases, base, ops, fmt):
    ves = bases[base]
    V, F = ves.V, ves.F
    # quads and float face arrays last: the other corruptions need (m, 3) integer faces
    for op, seed in sorted(ops, key=lambda o: o[0] in ("quads", "float_faces")):
        V, F = _corrupt(V, F, op, np.random.default_rng(seed))
    with _time_limit(30), warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # NaN/overflow arithmetic is a bug, not a result
        warnings.simplefilter("error", MatrixRankWarning)  # a singular solve returns NaN
        # file round trip
        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / f"m{fmt}"
            if _call(write_mesh, p, V, F) is not None or p.exists():
                got = _call(read_mesh, p)
                if got is not None:
                    _finite(got[0])
        # the pipeline on the raw input
        ends = _call(vessel_ends, V, F)
        if ends is not None:
            for e in ends:
                _finite(e.center, e.direction, e.radius)
        gc = _call(fit_generalized_cylinder, V, F)
        if gc is not None:
            _check_fit(gc, len(V))
        # and after the documented repair
        cleaned = _call(clean_mesh, V, F)
        if cleaned is not None:
            V2, F2, rep = cleaned
            _finite(V2)
            assert F2.shape[1] == 3 and F2.min() >= 0 and F2.max() < len(V2)
            gc2 = _call(fit_generalized_cylinder, V2, F2)
            if gc2 is not None:
                _check_fit(gc2, len(V2))
        # torsion of the corrupted positions against the intact rest mesh
        if np.shape(V) == ves.V.shape:
            prof = _call(measure_torsion, ves.V, V, ves.F)
            if prof is not None:
                _finite(prof.alpha, prof.dalpha, prof.energy, prof.total_twist, prof.vertex_alpha)
