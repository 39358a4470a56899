"""Errors a command-line user can act on (issue #36, item 5).

Refusals raised under a command name its options (``--ends I J``, ``--ends-a``, ``--hold``,
``--max-stretch``, ``--end``, ``--other-end``), not the library's Python keywords, in one line with exit
code 2; a refused run leaves no empty output folder (and never removes one the user had); ``vesselgp ends``
can list the same mesh twice into one folder, replacing only its own listing.
"""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

import vesselgp as vg
from vesselgp.cli import _cli_message, main
from vesselgp.synthetic import synthetic_tree, synthetic_vessel

from _data import REAL
from test_cli import assert_error, run
from test_join_vessels import _unit, place_other

CORONARY = REAL / "xra_coronary_single_branch_open.stl"
CAPPED = REAL / "dfemtoolz_artery_segment_lumen_capped.stl"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A tube, a Y (three ends), a tree of two levels (five ends: two side branches along a path) and the capped
    artery placed far beyond the coronary's end 1 (150 mm)."""
    d = tmp_path_factory.mktemp("errors")
    v = synthetic_vessel("arc", n_around=16)
    vg.write_mesh(d / "tube.ply", v.V, v.F)
    t = synthetic_tree(levels=1, voxel=0.6)
    vg.write_mesh(d / "y.ply", t.V, t.F)
    t = synthetic_tree(levels=2, voxel=0.5)
    vg.write_mesh(d / "y2.ply", t.V, t.F)
    V, F = vg.read_mesh(CORONARY)[:2]
    e1 = vg.vessel_ends(V, F)[1]
    Vo, Fo = vg.read_mesh(CAPPED)[:2]
    eo = vg.vessel_ends(Vo, Fo)
    vg.write_mesh(d / "far.ply", place_other(Vo, eo[1], e1.center + 150.0 * _unit(e1.direction), e1.direction, 0.0),
                  Fo)
    return d


def _join(files, *options):
    return ["join", CORONARY, "--end", 1, "--onto", files / "far.ply", "--other-end", 1, *options]


@pytest.mark.parametrize("args, fragment", [
    (["fit", "{y}", "--ends", 0, 7], "--ends 0 7 is invalid: indices must be integers in 0..2"),
    (["torsion", "{y}", "{y}"], "mesh has 3 ends; pass --ends I J to choose the vessel's path"),
    (["twist", "{y}", "{y}", "--ends-a", 0, 9], "scan A: --ends-a 0 9 must be two different end indices in 0..2"),
    (["twist", "{y2}", "{y2}", "--ends-b", 1, 1], "scan B: --ends-b 1 1 must be two different end indices"),
    (["twist", "{y}", "{y}"], "main vessels from end 0 with their landmarks: (0, 1): 1, (0, 2): 1 (choose one with --ends-a)"),
    (["join", CORONARY, "--end", 5, "--onto", "{tube}", "--other-end", 0], "--end 5 is not an end index in 0..1"),
    (["join", CORONARY, "--end", 1, "--onto", "{tube}", "--other-end", 9], "--other-end 9 is not an end index"),
    ("join max-stretch", "--max-stretch must be at least 1 (no stretch), got 0.5"),
    ("join stretched", "(--max-stretch 1.3); move the other vessel closer, hold less (--hold) or raise --max-stretch"),
    ("join hold", "--hold 1.5 is not an arc-length fraction in (0, 1)"),
], ids=["fit-ends", "torsion-ends", "twist-ends-a", "twist-ends-b", "twist-landmarks", "join-end", "join-other-end",
        "join-max-stretch", "join-stretch", "join-hold"])
def test_a_refusal_names_the_option(files, tmp_path, capsys, args, fragment):
    if isinstance(args, str):
        args = _join(files, *{"join max-stretch": ["--max-stretch", 0.5], "join stretched": [],
                              "join hold": ["--hold", 1.5, "--max-stretch", 100]}[args])
    args = [str(a).format(y=files / "y.ply", y2=files / "y2.ply", tube=files / "tube.ply") for a in args]
    out = tmp_path / "out"
    rc, o, e = run([*args, "-o", out, "--no-png"], capsys)
    assert_error(rc, o, e, fragment)
    assert "=" not in e.split("error: ", 1)[1].split("(ends:")[0]  # no keyword=value left
    assert not out.exists()


def test_refusals_name_commands_and_options_not_python(tmp_path, capsys):
    """Issue #44, item 8: what a refusal tells a command-line user to do names commands and options: a raw voxel
    staircase is sent to 'vesselgp clean --smooth N' (not vesselgp.clean_mesh), an axis that bends tighter than
    its radius to --lam 1.0 or --nodes K (half the fit's; not lam=1.0, n_nodes=K; with the first the fit goes
    through), a root that is no end to --root; no 'keyword=' is left in any of them."""
    from test_ends_trees import bent_occupancy, voxel_faces

    V, F = voxel_faces(bent_occupancy())
    vg.write_mesh(tmp_path / "stair.ply", V, F)
    helix = synthetic_vessel("helix", radius=lambda s: 1.0 + 0.2 * np.sin(2 * np.pi * s), ellipticity=0.75,
                             ellipse_angle=0.4, n_around=12, seed=3)  # kinks with the default lam (test_fit)
    vg.write_mesh(tmp_path / "helix.ply", helix.V, helix.F)
    for args, fragment in [(["fit", tmp_path / "stair.ply"], "vesselgp clean --smooth N"),
                           (["fit", tmp_path / "helix.ply"], "fit a stiffer axis, e.g. --lam 1.0 or --nodes "),
                           (["fit", tmp_path / "helix.ply", "--root", 2], "--root 2 is not an end index; use 0 to 1 "
                                                                          "(see vesselgp ends)")]:
        rc, o, e = run([*map(str, args), "-o", tmp_path / "out", "--no-png"], capsys)
        assert_error(rc, o, e, fragment)
        msg = e.split("error: ", 1)[1]
        assert not re.search(r"[A-Za-z_]=", msg) and "vesselgp." not in msg and "command line:" not in msg, msg
    rc, o, e = run(["fit", str(tmp_path / "helix.ply"), "--lam", "1.0", "-o", str(tmp_path / "ok"), "--no-png"],
                   capsys)
    assert rc == 0, e


def test_the_library_keeps_its_keywords(files):
    """The same refusals through the API name the Python keywords."""
    Vy, Fy = vg.read_mesh(files / "y.ply")[:2]
    with pytest.raises(vg.VesselError, match=r"scan A: ends_a=\(0, 9\) must be"):
        vg.twist_between(Vy, Fy, Vy, Fy, ends_a=(0, 9))
    with pytest.raises(vg.VesselError, match=r"pass ends=\(i, j\)"):
        vg.fit_generalized_cylinder(Vy, Fy)
    assert _cli_message("fit", "pass ends=(i, j)") == "pass --ends I J"
    assert _cli_message("join", "other_end=9 and end=5; hold= vertex ids; (hold=)") == \
        "--other-end 9 and --end 5; --hold vertex ids; (--hold)"
    assert _cli_message("ends", "pass ends=(i, j)") == "pass ends=(i, j)"  # a command without the option


def test_a_refused_run_leaves_no_empty_folder_but_keeps_the_users(tmp_path, capsys):
    """fit, torsion, clean and ends create their folder before they read the mesh: when the mesh is refused, the
    folders they made (several levels) are removed again; a folder the user had, empty or not, stays as it was."""
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n not a mesh")
    for cmd in (["fit", bad], ["torsion", bad, bad], ["clean", bad], ["ends", bad]):
        rc, o, e = run([*cmd, "-o", tmp_path / "new" / "deeper"], capsys)
        assert rc == 2 and len(e.strip().splitlines()) == 1
        assert not (tmp_path / "new").exists(), cmd
    mine = tmp_path / "mine"
    mine.mkdir()
    rc, _, _ = run(["fit", bad, "-o", mine], capsys)
    assert rc == 2 and mine.is_dir() and not any(mine.iterdir())
    (mine / "notes.txt").write_text("keep")
    rc, _, _ = run(["fit", bad, "-o", mine, "--overwrite"], capsys)
    assert rc == 2 and [p.name for p in mine.iterdir()] == ["notes.txt"]
    assert (mine / "notes.txt").read_text() == "keep"


def test_ends_can_list_a_mesh_twice(files, tmp_path, capsys, monkeypatch):
    """`vesselgp ends` is a listing: run again into its folder (the default one too) it replaces its own ends.json;
    a folder with anything else in it, or an ends.json it did not write, is refused as before and left unchanged."""
    out = tmp_path / "e"
    first = json.loads(run(["ends", files / "y.ply", "-o", out, "--json"], capsys)[1])
    rc, o, _ = run(["ends", files / "y.ply", "-o", out, "--json"], capsys)
    assert rc == 0 and json.loads(o)["ends"] == first["ends"]
    rc, o, _ = run(["ends", files / "tube.ply", "-o", out, "--json"], capsys)  # another mesh: its listing replaces
    assert rc == 0 and json.loads((out / "ends.json").read_text())["n_ends"] == 2
    monkeypatch.chdir(tmp_path)
    for _ in range(2):
        rc, o, _ = run(["ends", files / "y.ply"], capsys)
        assert rc == 0 and "3 ends" in o
    assert [p.name for p in (tmp_path / "vesselgp-ends").iterdir()] == ["ends.json"]
    (out / "notes.txt").write_text("keep")  # something of the user's beside it
    rc, o, e = run(["ends", files / "y.ply", "-o", out], capsys)
    assert_error(rc, o, e, "exists and is not empty; pass --overwrite")
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "ends.json").write_text('{"ends": "mine"}')
    rc, o, e = run(["ends", files / "y.ply", "-o", theirs], capsys)
    assert_error(rc, o, e, "exists and is not empty")
    assert (theirs / "ends.json").read_text() == '{"ends": "mine"}'
    other = tmp_path / "fitted"
    assert main(["fit", str(files / "tube.ply"), "-o", str(other), "--no-png", "-q"]) == 0
    rc, o, e = run(["fit", files / "tube.ply", "-o", other, "--no-png"], capsys)  # not a listing: refused
    assert_error(rc, o, e, "--overwrite")
    assert np.all([p.is_file() for p in other.iterdir()])
