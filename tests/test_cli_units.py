"""Units on the command line (issue #13): --units/--scale, reports in millimetres, `vesselgp ends`,
`torsion --ends`, `clean --smooth`, and one-line errors for bad option values.

A mesh in metres read with ``--units m`` must give the results of the same mesh
in millimetres, in millimetres; without ``--units`` the command warns, naming
the option.
"""
from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest

from vesselgp.cli import main
from vesselgp.errors import OptionError
from vesselgp.io import read_mesh, write_mesh
from vesselgp.mesh.scale import units_factor
from vesselgp.commands.output import read_mesh_in

from _data import REAL
from test_cli import assert_error, run

Y = REAL / "vmtk_abdominal_aorta_iliac_bifurcation_open.stl"
UNIT_KEYS = ("units", "input_units", "to_mm")


def scaled_copy(src, dst, factor):
    V, F = read_mesh(src)
    write_mesh(dst, V * factor, F)
    return dst


@pytest.fixture(scope="module")
def vessel(tmp_path_factory):
    """A synthetic arc in millimetres, its copy in metres and the pair twisted by 90 degrees."""
    d = tmp_path_factory.mktemp("units")
    assert main(["generate", "--curve", "arc", "--n-around", "16", "--deformed-twist", "90", "-o",
                 str(d / "gen"), "-q"]) == 0
    return {"mm": d / "gen" / "vessel.ply", "deformed_mm": d / "gen" / "deformed.ply",
            "m": scaled_copy(d / "gen" / "vessel.ply", d / "vessel_m.ply", 1e-3),
            "deformed_m": scaled_copy(d / "gen" / "deformed.ply", d / "deformed_m.ply", 1e-3),
            "um": scaled_copy(d / "gen" / "vessel.ply", d / "vessel_um.ply", 1e3)}


@pytest.fixture(scope="module")
def y_metres(tmp_path_factory):
    return scaled_copy(Y, tmp_path_factory.mktemp("y") / "y_m.ply", 1e-3)


def json_run(args, capsys):
    rc, out, err = run(list(args) + ["--json"], capsys)
    assert rc == 0, err
    return json.loads(out)


# --------------------------------------------------------------------------- #
# fit
# --------------------------------------------------------------------------- #
def test_fit_in_metres_with_units_m_gives_millimetres(vessel, tmp_path, capsys):
    ref = json_run(["fit", vessel["mm"], "-o", tmp_path / "mm", "--no-png"], capsys)
    got = json_run(["fit", vessel["m"], "--units", "m", "-o", tmp_path / "m", "--no-png"], capsys)
    assert got["length"] == pytest.approx(ref["length"], rel=1e-6)
    assert got["mean_radius"] == pytest.approx(ref["mean_radius"], rel=1e-6)
    assert abs(ref["length"] - np.pi * 10) < 0.5  # the arc: half a circle of bend radius 10 mm
    axis = json.loads((tmp_path / "m" / "axis.json").read_text())
    assert {k: axis[k] for k in UNIT_KEYS} == {"units": "mm", "input_units": "m", "to_mm": 1000.0}
    assert axis["bbox_diagonal"] == pytest.approx(json.loads((tmp_path / "mm" / "axis.json").read_text())
                                                  ["bbox_diagonal"], rel=1e-9)
    assert np.allclose(axis["centers"], json.loads((tmp_path / "mm" / "axis.json").read_text())["centers"],
                       atol=1e-6)
    assert {k: got[k] for k in UNIT_KEYS} == {k: axis[k] for k in UNIT_KEYS}  # the --json summary too
    # --scale 1000 is --units m
    sc = json_run(["fit", vessel["m"], "--scale", "1000", "-o", tmp_path / "s", "--no-png"], capsys)
    assert sc["length"] == pytest.approx(ref["length"], rel=1e-6) and sc["input_units"] == "1000 mm"
    # without --units the mesh is taken as millimetres
    raw = json_run(["fit", vessel["m"], "-o", tmp_path / "raw", "--no-png"], capsys)
    assert raw["length"] == pytest.approx(ref["length"] * 1e-3, rel=1e-6)
    assert raw["input_units"] == "mm (assumed)" and raw["to_mm"] == 1.0


def _stderr_of(args):
    r = subprocess.run([sys.executable, "-m", "vesselgp.cli", *map(str, args)], capture_output=True, text=True,
                       timeout=120, check=False)
    assert r.returncode == 0, r.stderr
    return r.stderr


def test_metres_without_units_warn_once_naming_the_option(vessel, tmp_path):
    err = _stderr_of(["fit", vessel["m"], "-o", tmp_path / "f", "--no-png", "--json"])
    lines = [ln for ln in err.splitlines() if "looks like" in ln]
    assert len(lines) == 1, err  # the library's own warning ("multiply V by 1000") is replaced
    assert "--units m" in lines[0] and "metres" in lines[0] and str(vessel["m"]) in lines[0]
    assert "multiply V" not in err
    # micrometres, through clean
    err = _stderr_of(["clean", vessel["um"], "-o", tmp_path / "c"])
    assert "--units um" in err and "micrometres" in err and err.count("looks like") == 1
    # given units: no warning; wrong units: a warning to check them
    assert "looks like" not in _stderr_of(["fit", vessel["m"], "--units", "m", "-o", tmp_path / "f2", "--no-png"])
    err = _stderr_of(["ends", vessel["mm"], "--units", "m", "-o", tmp_path / "e"])
    assert "check --units" in err and "converted from m" in err


@pytest.mark.parametrize("edge, factor", [("UNITS_MM_MIN_DIAG", 0.97), ("UNITS_MM_MIN_DIAG", 1.03),
                                          ("UNITS_MM_MAX_DIAG", 0.97), ("UNITS_MM_MAX_DIAG", 1.03)])
def test_given_units_are_checked_against_a_vessels_size_at_their_edges(tmp_path, caplog, edge, factor):
    """Issue #44: after --units or --scale the mesh must span a vessel (its bounding-box diagonal within
    UNITS_MM_MIN_DIAG-UNITS_MM_MAX_DIAG mm), else a warning names --units (a coronary in mm fitted with
    --units cm spanned 724 mm, unwarned). A straight tube of radius 1 and length 10 (diagonal sqrt(108),
    its rings reaching +-1 on both axes) scaled to 0.97 and 1.03 times each limit: only the ones outside warn."""
    import logging

    from vesselgp import tolerances as tol

    t = np.linspace(0, 2 * np.pi, 25)[:-1]
    z = np.linspace(0, 10, 11)
    V = np.c_[np.tile(np.cos(t), 11), np.tile(np.sin(t), 11), np.repeat(z, 24)]
    a = np.arange(24)
    F = np.vstack([np.r_[np.c_[i * 24 + a, i * 24 + (a + 1) % 24, i * 24 + 24 + a],
                         np.c_[i * 24 + (a + 1) % 24, i * 24 + 24 + (a + 1) % 24, i * 24 + 24 + a]] for i in range(10)])
    write_mesh(tmp_path / "tube.ply", V, F)
    limit = getattr(tol, edge)
    scale = factor * limit / np.sqrt(108.0)
    with caplog.at_level(logging.WARNING, logger="vesselgp"):
        W = read_mesh_in(tmp_path / "tube.ply", scale=scale)[0]
    assert np.linalg.norm(np.ptp(W, axis=0)) == pytest.approx(factor * limit, rel=1e-9)
    outside = (factor < 1) == (edge == "UNITS_MM_MIN_DIAG")
    warned = [r.getMessage() for r in caplog.records if "check --units" in r.getMessage()]
    assert bool(warned) == outside and all("outside the" in w for w in warned)


# --------------------------------------------------------------------------- #
# torsion, clean, join
# --------------------------------------------------------------------------- #
def test_torsion_in_metres(vessel, tmp_path, capsys):
    ref = json_run(["torsion", vessel["mm"], vessel["deformed_mm"], "-o", tmp_path / "mm", "--no-png"], capsys)
    got = json_run(["torsion", vessel["m"], vessel["deformed_m"], "--units", "m", "-o", tmp_path / "m",
                    "--no-png"], capsys)
    assert got["energy"] == pytest.approx(ref["energy"], rel=1e-6)
    assert got["total_twist_deg"] == pytest.approx(ref["total_twist_deg"], abs=1e-6)
    assert got["length"] == pytest.approx(ref["length"], rel=1e-6)  # millimetres
    assert got["twist_per_length_deg"] == pytest.approx(ref["twist_per_length_deg"], rel=1e-6)  # degrees per mm
    prof = json.loads((tmp_path / "m" / "profile.json").read_text())
    assert {k: prof[k] for k in UNIT_KEYS} == {"units": "mm", "input_units": "m", "to_mm": 1000.0}


def test_torsion_ends_choose_the_path_of_a_bifurcation(tmp_path, capsys):
    rc, o, e = run(["torsion", Y, Y, "-o", tmp_path / "none", "--no-png"], capsys)
    assert_error(rc, o, e, "3 open ends; pass --ends I J to choose")  # which path? the fit cannot tell
    assert not (tmp_path / "none").exists()  # the refused run left no empty folder (issue #36)
    for ends in ((0, 1), (0, 2)):
        d = json_run(["torsion", Y, Y, "--ends", *ends, "-o", tmp_path / f"e{ends[1]}", "--no-png"], capsys)
        assert abs(d["total_twist_deg"]) < 1e-6 and d["energy"] < 1e-10  # the identity: no twist
        assert 60 < d["length"] < 120  # aorta -> iliac, in mm
    rc, o, e = run(["torsion", Y, Y, "--ends", 0, 7, "-o", tmp_path / "bad", "--no-png"], capsys)
    assert_error(rc, o, e, "--ends 0 7 is invalid")  # the option, not the Python keyword (issue #36)


def test_clean_units_and_smoothing(vessel, tmp_path, capsys):
    d = json_run(["clean", vessel["m"], "--units", "m", "--smooth", "5", "-o", tmp_path / "c"], capsys)
    assert d["smoothing_iterations"] == 5 and "5 iterations of Taubin smoothing" in d["summary"]
    rep = json.loads((tmp_path / "c" / "clean_report.json").read_text())
    assert {k: rep[k] for k in UNIT_KEYS} == {"units": "mm", "input_units": "m", "to_mm": 1000.0}
    assert rep["smoothing_iterations"] == 5 and rep["scale"]["units_guess"] == "mm"
    V, _ = read_mesh(tmp_path / "c" / "vessel_m_clean.ply")  # written in millimetres
    V0, _ = read_mesh(vessel["mm"])
    assert np.ptp(V, axis=0) == pytest.approx(np.ptp(V0, axis=0), rel=0.02)
    d0 = json_run(["clean", vessel["mm"], "-o", tmp_path / "c0"], capsys)  # no --smooth: no smoothing
    assert d0["smoothing_iterations"] == 0
    np.testing.assert_array_equal(read_mesh(tmp_path / "c0" / "vessel_clean.ply")[0], V0)


def test_join_in_metres(tmp_path, capsys):
    assert main(["generate", "--paper-cases", "--resolution", "0.3", "-o", str(tmp_path / "cases"), "-q"]) == 0
    src, m = tmp_path / "cases" / "case1", tmp_path / "m"
    m.mkdir()
    for name in ("vessel.ply", "other.ply"):
        scaled_copy(src / name, m / name, 1e-3)
    case = json.loads((src / "case.json").read_text())
    case["target_origin"] = [x * 1e-3 for x in case["target_origin"]]
    (m / "case.json").write_text(json.dumps(case))
    common = ["--n-curve", "3", "--no-png"]
    ref = json_run(["join", src / "vessel.ply", "--case", src / "case.json", "-o", tmp_path / "jmm", *common],
                   capsys)
    got = json_run(["join", m / "vessel.ply", "--case", m / "case.json", "--units", "m", "-o", tmp_path / "jm",
                    *common], capsys)
    assert got["optimum_angle_deg"] == pytest.approx(ref["optimum_angle_deg"], abs=1e-3)
    assert got["energy"] == pytest.approx(ref["energy"], rel=1e-3, abs=1e-9)
    r = json.loads((tmp_path / "jm" / "result.json").read_text())
    assert {k: r[k] for k in UNIT_KEYS} == {"units": "mm", "input_units": "m", "to_mm": 1000.0}
    Vj, _ = read_mesh(tmp_path / "jm" / "joined_optimum.ply")  # both vessels in mm, joined at the target
    Vr, _ = read_mesh(tmp_path / "jmm" / "joined_optimum.ply")
    assert np.abs(Vj - Vr).max() < 1e-3


# --------------------------------------------------------------------------- #
# ends
# --------------------------------------------------------------------------- #
def _centre_texts(text):
    """The centres of an `ends` table as printed."""
    return re.findall(r"\d\s+\(([-\d., e+]+)\)\s+\(", text)


def _centres(text):
    """The printed centres of an `ends` table."""
    return [tuple(float(x) for x in c.split(", ")) for c in _centre_texts(text)]


def test_ends_of_the_aorto_iliac_y(tmp_path, capsys):
    rc, text, _ = run(["ends", Y, "-o", tmp_path / "e"], capsys)
    assert rc == 0
    assert "3 ends" in text and "radius (mm)" in text and "direction" in text
    rows = [ln.split() for ln in text.splitlines() if re.match(r"\s+\d\s+open", ln)]
    assert [r[0] for r in rows] == ["0", "1", "2"]
    radii = [float(r[2]) for r in rows]
    assert radii == pytest.approx([7.7, 4.4, 4.4], abs=0.05)
    d = json.loads((tmp_path / "e" / "ends.json").read_text())
    assert d["n_ends"] == 3 and [e["kind"] for e in d["ends"]] == ["open"] * 3
    assert [e["index"] for e in d["ends"]] == [0, 1, 2]
    assert len(_centres(text)) == 3
    for e, c in zip(d["ends"], _centres(text)):
        assert set(e) == {"index", "kind", "radius", "center", "direction"}
        assert np.linalg.norm(e["direction"]) == pytest.approx(1.0)
        assert np.allclose(c, e["center"], atol=1e-3 * d["bbox_diagonal"])  # printed to 1e-4 of the size
    assert {k: d[k] for k in UNIT_KEYS} == {"units": "mm", "input_units": "mm (assumed)", "to_mm": 1.0}
    js = json_run(["ends", Y, "-o", tmp_path / "j"], capsys)  # --json: the same fields on stdout
    assert js["ends"] == d["ends"] and js["files"] == [str(tmp_path / "j" / "ends.json")]


def test_ends_of_a_metre_copy(y_metres, tmp_path, capsys):
    _, mm, _ = run(["ends", Y, "-o", tmp_path / "mm"], capsys)
    rc, raw, _ = run(["ends", y_metres, "-o", tmp_path / "raw"], capsys)
    assert rc == 0 and "taken as mm" in raw
    c_mm, c_raw = np.array(_centres(mm)), np.array(_centres(raw))
    assert c_raw.shape == (3, 3)
    # printed with the digits a 0.09-unit mesh needs: not rounded away, and different text
    assert np.allclose(c_raw * 1e3, c_mm, atol=0.01)
    assert all(a != b for a, b in zip(_centre_texts(mm), _centre_texts(raw)))
    # --units m: the millimetre table
    rc, conv, _ = run(["ends", y_metres, "--units", "m", "-o", tmp_path / "m"], capsys)
    assert np.allclose(np.array(_centres(conv)), c_mm, atol=0.002)
    d = json.loads((tmp_path / "m" / "ends.json").read_text())
    dm = json.loads((tmp_path / "mm" / "ends.json").read_text())
    assert d["to_mm"] == 1000.0 and d["input_units"] == "m"
    for a, b in zip(d["ends"], dm["ends"]):
        assert a["radius"] == pytest.approx(b["radius"], rel=1e-6)
        assert np.allclose(a["center"], b["center"], rtol=1e-6)


# --------------------------------------------------------------------------- #
# bad option values: exit 2, one line
# --------------------------------------------------------------------------- #
@pytest.mark.parametrize("args, fragment", [
    (["fit", "{m}", "--units", "km"], "invalid choice: 'km'"),
    (["fit", "{m}", "--units", "mesh units"], "--units"),
    (["fit", "{m}", "--scale", "0"], "--scale: '0' is not a positive number"),
    (["ends", "{m}", "--scale", "abc"], "--scale: 'abc' is not a positive number"),
    (["ends", "{m}", "--scale", "nan"], "--scale"),
    (["clean", "{m}", "--units", "m", "--scale", "1000"], "not allowed with argument"),
    (["clean", "{m}", "--smooth", "-3"], "smooth must be a non-negative integer"),
    (["clean", "{m}", "--smooth", "2.5"], "--smooth: invalid int value"),
    (["torsion", "{m}", "{m}", "--ends", "0"], "--ends: expected 2 arguments"),
    (["join", "{m}", "--units", "ft"], "invalid choice: 'ft'"),
    (["ends"], "required: mesh"),
])
def test_bad_option_values_exit_2_with_one_line(vessel, tmp_path, capsys, args, fragment):
    args = [str(a).format(m=vessel["m"]) for a in args] + ["-o", str(tmp_path / "o")]
    rc, out, err = run(args, capsys)
    assert_error(rc, out, err, fragment)
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


# --------------------------------------------------------------------------- #
# the commands' shared helpers (vesselgp.commands.output) and library helpers
# --------------------------------------------------------------------------- #
def test_read_mesh_in_and_units_factor(vessel):
    V0, F0 = read_mesh(vessel["mm"])
    V, F, info = read_mesh_in(vessel["m"], units="m")
    assert np.allclose(V, V0, rtol=1e-12, atol=1e-12) and np.array_equal(F, F0)
    assert info == {"units": "mm", "input_units": "m", "to_mm": 1000.0}
    assert read_mesh_in(vessel["mm"])[2] == {"units": "mm", "input_units": "mm (assumed)", "to_mm": 1.0}
    assert units_factor("cm") == (10.0, "cm") and units_factor("um") == (1e-3, "um")
    for kw in ({"units": "km"}, {"scale": -1}, {"scale": float("inf")}, {"scale": True}, {"scale": "x"},
               {"units": "m", "scale": 1000}):
        with pytest.raises(OptionError):
            units_factor(**kw)
