"""End-to-end tests of the vesselgp command (issue #6, CLI part of #8).

Every subcommand runs in a temporary folder at reduced resolution; the tests
check the files it writes: meshes load back with the right vertex count and
colours, JSON has the documented fields, plots are valid PNGs.
"""
import hashlib
import json
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from vesselgp.cli import main
from vesselgp.commands.join import REPORT_FIELDS
from vesselgp.io import read_mesh

from test_viz import assert_png


def run(args, capsys):
    rc = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return rc, out, err


def ply_colours(path):
    """(n, 3) uint8 vertex colours of a PLY file (via pymeshlab)."""
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(path))
    m = ms.current_mesh()
    assert m.has_vertex_color()
    return np.round(m.vertex_color_matrix()[:, :3] * 255).astype(np.uint8)


def assert_error(rc, out, err, fragment):
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vesselgp: error: "), err
    assert fragment in lines[0]
    assert "Traceback" not in err


@pytest.fixture(scope="module")
def gen(tmp_path_factory):
    """A straight vessel and a copy twisted by 90 degrees, written by `vesselgp generate`."""
    d = tmp_path_factory.mktemp("gen") / "straight"
    rc = main(["generate", "--curve", "straight", "--n-around", "16", "--deformed-twist", "90", "-o", str(d),
               "-q"])
    assert rc == 0
    return d


@pytest.fixture(scope="module")
def cases(tmp_path_factory):
    d = tmp_path_factory.mktemp("cases") / "cases"
    assert main(["generate", "--paper-cases", "--resolution", "0.3", "-o", str(d), "-q"]) == 0
    return d


def test_generate(gen):
    V, F = read_mesh(gen / "vessel.ply")
    Vd, Fd = read_mesh(gen / "deformed.ply")
    assert V.shape == Vd.shape and np.array_equal(F, Fd)
    truth = json.loads((gen / "truth.json").read_text())
    assert truth["n_vertices"] == len(V) and truth["name"] == "straight"
    assert truth["deformed"]["twist_deg"] == 90
    for k in ("length", "s", "centers", "radii", "alpha_deg", "units"):
        assert k in truth


def test_generate_paper_cases(cases):
    for n in (1, 2):
        c = json.loads((cases / f"case{n}" / "case.json").read_text())
        V, _ = read_mesh(cases / f"case{n}" / "vessel.ply")
        Vo, _ = read_mesh(cases / f"case{n}" / "other.ply")
        assert c["n_vertices"] == len(V) and c["other_n_vertices"] == len(Vo)
        for k in ("fixed", "moving", "other_end", "target_origin", "target_tangent", "target_normal"):
            assert k in c


def test_fit(gen, tmp_path, capsys):
    out = tmp_path / "fit"
    rc, stdout, _ = run(["fit", gen / "vessel.ply", "-o", out, "--json"], capsys)
    assert rc == 0
    summary = json.loads(stdout)
    assert abs(summary["length"] - 30) < 0.3 and abs(summary["mean_radius"] - 1.5) < 0.05
    d = json.loads((out / "axis.json").read_text())
    for k in ("s", "length", "mean_radius", "centers", "radii", "frames", "ends", "units", "n_nodes",
              "bbox_diagonal", "iterations"):
        assert k in d, k
    K = d["n_nodes"]
    assert len(d["s"]) == K and np.asarray(d["centers"]).shape == (K, 3)
    assert np.asarray(d["frames"]["T"]).shape == (K, 3)
    csv = (out / "axis.csv").read_text().splitlines()
    assert csv[0].startswith("s,arclength,x,y,z,radius,Tx") and len(csv) == K + 1
    piece = ET.parse(out / "axis.vtp").getroot().find("PolyData/Piece")
    n = int(piece.get("NumberOfPoints"))  # a point about every 0.1 radius (VMTK's sampling): 30 / 0.15 steps
    assert abs(n - 1 - 30 / (0.1 * 1.5)) <= 3 and piece.get("NumberOfLines") == "1"
    assert f"element edge {n - 1}" in (out / "axis.ply").read_text()
    V, _ = read_mesh(gen / "vessel.ply")
    Vs, _ = read_mesh(out / "mesh_radius.ply")  # the default shading: each vertex's distance to the axis, in mm
    assert len(Vs) == len(V)
    from test_vtk_outputs import arrays, read_vtp

    radius = arrays(read_vtp(out / "mesh_radius.vtp").GetPointData())["radius"]
    assert np.allclose(radius, 1.5, rtol=0.02)  # the generated straight tube's radius
    assert_png(out / "mesh_radius.png")
    assert (out / "report.html").stat().st_size > 0


def test_torsion(gen, tmp_path, capsys):
    out = tmp_path / "tor"
    rc, stdout, _ = run(["torsion", gen / "vessel.ply", gen / "deformed.ply", "-o", out], capsys)
    assert rc == 0 and "torsion energy" in stdout
    d = json.loads((out / "profile.json").read_text())
    for k in ("energy", "total_twist_deg", "twist_per_length_deg", "length", "s", "alpha_deg", "dalpha_deg",
              "curvature", "frenet_torsion"):
        assert k in d, k
    assert abs(d["total_twist_deg"] - 90) < 2
    assert abs(d["energy"] - np.radians(90) ** 2) < 0.1 * np.radians(90) ** 2  # uniform twist: Phi^2
    V, _ = read_mesh(gen / "vessel.ply")
    assert len(read_mesh(out / "deformed_twist.ply")[0]) == len(V)
    C = ply_colours(out / "deformed_twist.ply")
    assert C.shape == (len(V), 3)
    # twist grows along the vessel: one end neutral, the other saturated red
    assert int(C[:, 0].max()) - int(C[:, 2].min()) > 150
    assert_png(out / "deformed_twist.png")
    assert_png(out / "profile.png")
    assert (out / "profile.csv").read_text().startswith("s,alpha_deg,dalpha_deg")


def test_torsion_mismatch(gen, cases, tmp_path, capsys):
    rc, out, err = run(["torsion", gen / "vessel.ply", cases / "case1" / "vessel.ply", "-o", tmp_path / "x"],
                       capsys)
    assert_error(rc, out, err, "must share vertices and faces")


def test_join_with_case_file(cases, tmp_path, capsys):
    out = tmp_path / "join"
    c = json.loads((cases / "case1" / "case.json").read_text())
    rc, stdout, _ = run(["join", cases / "case1" / "vessel.ply", "--case", cases / "case1" / "case.json",
                         "-o", out, "--n-curve", "7", "--json"], capsys)
    assert rc == 0
    summary = json.loads(stdout)
    assert summary["n_evals"] >= 3 and summary["energy"] >= 0
    r = json.loads((out / "result.json").read_text())
    for k in REPORT_FIELDS:
        assert k in r or "demo only" in REPORT_FIELDS[k], k
    assert not {"case", "title", "generate_time_s"} & set(r)
    assert len(r["energy_curve"]["angles_deg"]) == 7
    # the optimum is the curve's minimum and well below the large-torsion energy
    assert r["energy"] <= min(r["energy_curve"]["energies"]) + 1e-9
    assert r["large_torsion"]["energy"] > 10 * r["energy"] + 0.1
    for name in ("optimum.ply", "large_torsion.ply"):
        V, _ = read_mesh(out / name)
        assert len(V) == c["n_vertices"]
        assert ply_colours(out / name).shape == (c["n_vertices"], 3)
    C = ply_colours(out / "large_torsion.ply")
    assert int(C[:, 0].max()) > 200 or int(C[:, 2].max()) > 200  # saturated somewhere
    Vj, _ = read_mesh(out / "joined_optimum.ply")
    assert len(Vj) == c["n_vertices"] + c["other_n_vertices"]
    for name in ("optimum", "large_torsion", "joined_optimum"):  # ParaView's copies: the same mesh, alpha as data
        from test_vtk_outputs import arrays, read_vtp

        pd = read_vtp(out / f"{name}.vtp")
        V, F = read_mesh(out / f"{name}.ply")[:2]
        assert pd.GetNumberOfPoints() == len(V) and pd.GetNumberOfPolys() == len(F)
        assert pd.GetPointData().GetScalars().GetName() == "alpha_deg"
        alpha = arrays(pd.GetPointData())["alpha_deg"]
        assert np.isfinite(alpha).all() and (alpha != 0).any()
    assert r["files"]["optimum_vtp"].endswith("optimum.vtp")
    for name in ("optimum.png", "large_torsion.png", "energy_curve.png", "profile_optimum.png"):
        assert_png(out / name)
    assert (out / "energy_curve.csv").read_text().startswith("angle_deg,energy")


def test_join_with_explicit_target(cases, tmp_path, capsys):
    c = json.loads((cases / "case1" / "case.json").read_text())
    (tmp_path / "moving.txt").write_text(" ".join(map(str, c["moving"])))
    fixed = ",".join(map(str, c["fixed"]))
    out = tmp_path / "join"
    args = ["join", cases / "case1" / "vessel.ply", "--fixed", fixed, "--moving", f"@{tmp_path / 'moving.txt'}",
            "--target-origin", *c["target_origin"], "--target-tangent", *c["target_tangent"],
            "--target-normal", *c["target_normal"], "-o", out, "--n-curve", "3", "--no-png", "-q"]
    rc, _, _ = run(args, capsys)
    assert rc == 0
    r = json.loads((out / "result.json").read_text())
    assert not (out / "optimum.png").exists() and (out / "optimum.ply").exists()
    assert abs(abs(r["optimum_angle_deg"]) - 180) < 5  # case 1's anchor is half a turn off (as with --case)
    # missing target options: one-line error
    rc, o, e = run(["join", cases / "case1" / "vessel.ply", "--fixed", fixed, "-o", tmp_path / "j2"], capsys)
    assert_error(rc, o, e, "missing --moving")
    rc, o, e = run(["join", cases / "case1" / "vessel.ply", "--fixed", "a-b", "--moving", "1",
                    "--target-origin", 0, 0, 0, "--target-tangent", 1, 0, 0, "--target-normal", 0, 0, 1,
                    "-o", tmp_path / "j3"], capsys)
    assert_error(rc, o, e, "--fixed")


def test_clean(gen, tmp_path, capsys):
    pytest.importorskip("vesselgp.mesh")
    out = tmp_path / "clean"
    rc, stdout, _ = run(["clean", gen / "vessel.ply", "-o", out, "--json"], capsys)
    assert rc == 0, stdout
    d = json.loads((out / "clean_report.json").read_text())
    for k in ("vertices_before", "vertices_after", "faces_after", "summary"):
        assert k in d
    V, _ = read_mesh(out / "vessel_clean.ply")
    assert len(V) == d["vertices_after"]


def test_demo_reduced_resolution(tmp_path, capsys):
    out = tmp_path / "demo"
    rc, stdout, _ = run(["demo", "--resolution", "0.3", "--n-curve", "9", "-o", out], capsys)
    assert rc == 0
    assert "case 1" in stdout and "case 2" in stdout and "angle (deg)" in stdout
    rep = json.loads((out / "report.json").read_text())
    assert set(rep) >= {"version", "resolution", "cases", "total_time_s", "fields"}
    assert [c["case"] for c in rep["cases"]] == [1, 2]
    for c in rep["cases"]:
        for k in REPORT_FIELDS:
            assert k in c, k
        case = json.loads((out / c["files"]["case_json"]).read_text())
        for key in ("optimum_mesh", "large_torsion_mesh"):
            V, F = read_mesh(out / c["files"][key])
            assert len(V) == case["n_vertices"] == c["n_vertices"] and len(F) == c["n_faces"]
            C = ply_colours(out / c["files"][key])
            assert C.shape == (len(V), 3)
        # the large-torsion mesh is visibly coloured, the optimum nearly neutral
        Cl = ply_colours(out / c["files"]["large_torsion_mesh"]).astype(int)
        Co = ply_colours(out / c["files"]["optimum_mesh"]).astype(int)
        assert np.abs(Cl[:, 0] - Cl[:, 2]).max() > 3 * np.abs(Co[:, 0] - Co[:, 2]).max() + 10
        for key in ("optimum_png", "large_torsion_png", "energy_curve_png"):
            assert_png(out / c["files"][key], (400, 200))
        assert c["large_torsion"]["energy"] > c["energy"]
    # refuses to reuse the folder, then accepts --overwrite
    rc, o, e = run(["demo", "--resolution", "0.3", "-o", out], capsys)
    assert_error(rc, o, e, "--overwrite")


def test_errors_are_one_line_exit_2(gen, tmp_path, capsys):
    rc, o, e = run(["fit", tmp_path / "missing.stl", "-o", tmp_path / "o"], capsys)
    assert_error(rc, o, e, "missing.stl")
    bad = tmp_path / "bad.ply"
    bad.write_text("this is not a mesh\n")
    rc, o, e = run(["fit", bad, "-o", tmp_path / "o2"], capsys)
    assert rc == 2 and e.startswith("vesselgp: error: ") and "Traceback" not in e
    (tmp_path / "file").write_text("x")
    rc, o, e = run(["fit", gen / "vessel.ply", "-o", tmp_path / "file"], capsys)
    assert_error(rc, o, e, "not a folder")
    # argparse usage errors exit 2 too, with one line naming the command's --help
    rc, o, e = run(["fit"], capsys)
    assert_error(rc, o, e, "the following arguments are required: mesh (see 'vesselgp fit --help')")
    rc, o, e = run(["nosuchcommand"], capsys)
    assert_error(rc, o, e, "invalid choice: 'nosuchcommand'")
    rc, o, e = run(["demo", "--resolution", "abc"], capsys)
    assert_error(rc, o, e, "argument --resolution: invalid float value: 'abc'")


def test_never_overwrites_an_input(cases, tmp_path, capsys):
    d = tmp_path / "work"
    d.mkdir()
    src = cases / "case1"
    inp = d / "optimum.ply"  # an input named like an output
    inp.write_bytes((src / "vessel.ply").read_bytes())
    digest = hashlib.sha256(inp.read_bytes()).hexdigest()
    rc, o, e = run(["join", inp, "--case", src / "case.json", "-o", d, "--overwrite", "--no-png"], capsys)
    assert_error(rc, o, e, "refusing to overwrite input file")
    assert hashlib.sha256(inp.read_bytes()).hexdigest() == digest
    assert sorted(p.name for p in d.iterdir()) == ["optimum.ply"]


def test_console_entry_point_help():
    r = subprocess.run([sys.executable, "-m", "vesselgp.cli", "join", "--help"], capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 0 and "examples:" in r.stdout and "--target-normal" in r.stdout
    r = subprocess.run([sys.executable, "-m", "vesselgp.cli", "torsion", "nope.ply", "nope2.ply", "-o", "x"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and r.stderr.startswith("vesselgp: error:") and "Traceback" not in r.stderr
