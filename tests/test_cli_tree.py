"""`vesselgp fit` on a branching mesh fits the tree (issue #13, item 6): tree.json, tree.vtp, tree.ply, tree.png."""
import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from vesselgp.cli import main
from vesselgp.io import read_mesh, write_mesh
from vesselgp.synthetic import synthetic_tree

from test_viz import assert_png


@pytest.fixture(scope="module")
def tree_file(tmp_path_factory):
    t = synthetic_tree(levels=1, voxel=0.6)
    path = tmp_path_factory.mktemp("tree") / "y.ply"
    write_mesh(path, t.V, t.F)
    return path, t


def _arrays(elem):
    return {da.get("Name"): np.array(da.text.split(), float) for da in elem.iter("DataArray")}


def test_fit_writes_the_tree(tree_file, tmp_path, capsys):
    path, t = tree_file
    out = tmp_path / "fit"
    assert main(["fit", str(path), "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["tree"] and summary["n_branches"] == 3 and summary["n_junctions"] == 1
    names = {p.name for p in out.iterdir()}
    assert {"tree.json", "tree.vtp", "tree.ply", "tree.png", "mesh_branches.ply"} <= names
    assert not names & {"axis.json", "axis.vtp"}
    d = json.loads((out / "tree.json").read_text())
    assert d["n_ends"] == 3 and d["units"] == "mm" and len(d["paths"]) == 2
    assert [b["parent"] for b in d["branches"]] == [-1, 0, 0]
    # a smooth synthetic Y is a tube throughout: children led in through their zone, no medial zone
    assert d["branches"][0]["junction_zone"] == 0 and all(b["junction_zone"] > 0 for b in d["branches"][1:])
    assert all(b["medial_zones"] == [] for b in d["branches"])
    assert d["bulges"] == [] and summary["bulges"] == []
    J, R = t.truth.junctions
    assert np.linalg.norm(np.array(d["junctions"][0]["point"]) - J[0]) < 0.5 * R[0]
    # VTP as VMTK's branch extractor lays it out: per path (CenterlineIds) its tracts (TractIds) from the root; a
    # child's junction zone a blanked tract of its own; the trunk one group shared by both paths
    root = ET.parse(out / "tree.vtp").getroot()
    piece = root.find("PolyData/Piece")
    assert piece.get("NumberOfLines") == "6"
    pdata, cdata = _arrays(piece.find("PointData")), _arrays(piece.find("CellData"))
    assert cdata["CenterlineIds"].tolist() == [0, 0, 0, 1, 1, 1] and cdata["TractIds"].tolist() == [0, 1, 2] * 2
    assert cdata["GroupIds"].tolist() == [0, 1, 2, 0, 3, 4] and cdata["Blanking"].tolist() == [0, 1, 0, 0, 1, 0]
    lines = _arrays(piece.find("Lines"))
    cells = np.split(lines["connectivity"].astype(int), lines["offsets"][:-1].astype(int))
    pts = _arrays(piece.find("Points"))[None].reshape(-1, 3)
    # the junction: one point per branch on it (the trunk's last, each child's first), as VMTK's cells have
    assert len({cells[0][-1], cells[1][0], cells[4][0]}) == 3
    assert np.allclose(pts[cells[1][0]], pts[cells[0][-1]]) and np.allclose(pts[cells[4][0]], pts[cells[0][-1]])
    # how each branch was fitted, and the root: the widest, said so
    assert all(b["fit"] == "converged" and b["last_step"] < 1e-3 for b in d["branches"])
    assert d["root"] == 0 and d["root_chosen"] == "widest" and summary["root_chosen"] == "widest"
    d_true, r_true, _, _ = t.truth.nearest(pts)
    keep = t.truth.interior_mask(pts)
    assert (d_true[keep] < 0.05 * r_true[keep]).all()  # the points lie on the true centre lines
    assert np.abs(pdata["MeanRadius"][keep] / r_true[keep] - 1).max() < 0.05
    assert np.abs(pdata["MaximumInscribedSphereRadius"][keep] / r_true[keep] - 1).max() < 0.05
    # PLY: vertices and each cell's edges
    ply = (out / "tree.ply").read_text()
    ne = int(ply.split("element edge ")[1].split()[0])
    assert ne == sum(len(c) - 1 for c in cells)
    Vb, Fb = read_mesh(out / "mesh_branches.ply")[:2]
    assert len(Vb) == len(t.V)
    assert_png(out / "tree.png")


def test_ends_still_pick_one_path(tree_file, tmp_path, capsys):
    path, t = tree_file
    out = tmp_path / "one"
    assert main(["fit", str(path), "--ends", "0", "1", "-o", str(out), "-q", "--no-png"]) == 0
    names = {p.name for p in out.iterdir()}
    assert "axis.json" in names and "tree.json" not in names


def test_fit_reports_a_sac(tmp_path, capsys):
    """A vessel with a fusiform aneurysm (true peak radius 1.8 x the tube's 1.5 at s = 0.5): the sac is passed
    through and said in axis.json, the JSON summary and the printed lines."""
    from vesselgp.synthetic import synthetic_vessel

    v = synthetic_vessel("arc", radius=1.5, bulges=[(0.5, 0.05, 0.8)])
    path = tmp_path / "sac.ply"
    write_mesh(path, v.V, v.F)
    assert main(["fit", str(path), "-o", str(tmp_path / "o"), "--no-png"]) == 0
    text = capsys.readouterr().out
    assert "bulge at s 0.4" in text and ("(1.7" in text or "(1.8" in text), text
    (b,) = json.loads((tmp_path / "o" / "axis.json").read_text())["bulges"]
    assert abs(b["s_peak"] - 0.5) < 0.01 and abs(b["peak_radius"] - 2.7) < 0.05 and abs(b["neighbour_radius"] - 1.5) < 0.05
    assert main(["fit", str(path), "-o", str(tmp_path / "j"), "--no-png", "--json"]) == 0
    assert len(json.loads(capsys.readouterr().out)["bulges"]) == 1


@pytest.fixture(scope="module")
def wide_daughter(tmp_path_factory):
    """A Y whose trunk (radius 2.4 at its open root) is narrower than one daughter (2.8 at its tip), as a
    carotid whose internal carotid is wider than the common carotid: the widest end is not the trunk's."""
    from vesselgp.synthetic_anatomy import bezier_between
    from vesselgp.synthetic_tree import tree_surface

    J = np.array([0.0, 0.0, 30.0])
    control = [bezier_between([0, 0, 0], [0, 0, 1], J, [0, 0, 1], 10, 10),
               bezier_between(J, [0.7, 0, 1], J + [16, 0, 22], [0.3, 0, 1], 8, 8),
               bezier_between(J, [-0.7, 0, 1], J + [-16, 2, 20], [-0.4, 0, 1], 8, 8)]
    t = tree_surface([-1, 0, 0], control, [[2.4, 2.4], [2.6, 2.8], [1.6, 1.5]], voxel=0.45, blend=0.5)
    path = tmp_path_factory.mktemp("wide") / "y.ply"
    write_mesh(path, t.V, t.F)
    return path, t


def test_the_root_is_a_choice(wide_daughter, tmp_path, capsys):
    """Issue #44, item 4: the default root is the widest end, said so in tree.json and the summary; --root I
    starts every path at end I (here the trunk's open end, which the default passes over for the wider
    daughter's tip); --root with --ends, or an index that is no end, is refused naming the options."""
    path, t = wide_daughter
    assert main(["fit", str(path), "-o", str(tmp_path / "a"), "--no-png"]) == 0
    out = capsys.readouterr().out
    d = json.loads((tmp_path / "a" / "tree.json").read_text())
    trunk = int(np.argmin([np.linalg.norm(np.array(e["center"])) for e in d["ends"]]))  # the root plane's centre
    widest = int(np.argmax([e["radius"] for e in d["ends"]]))
    assert widest != trunk and d["root"] == widest and d["root_chosen"] == "widest"
    assert f"root end {widest} (the widest; --root I" in out
    assert main(["fit", str(path), "--root", str(trunk), "-o", str(tmp_path / "b"), "--no-png", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    d = json.loads((tmp_path / "b" / "tree.json").read_text())
    assert d["root"] == trunk == summary["root"] and d["root_chosen"] == "given"
    assert all(p["ends"][0] == trunk for p in d["paths"]) and len(d["paths"]) == 2
    assert d["checks"]["worst_end_gap_radii"] < 0.05 and d["checks"]["covered_fraction"] > 0.999
    for args, frag in [(["--root", "3"], "--root 3"), (["--root", "0", "--ends", "0", "1"], "--root")]:
        rc = main(["fit", str(path), *args, "-o", str(tmp_path / "c"), "--no-png"])
        err = capsys.readouterr().err
        assert rc == 2 and frag in err and "=" not in err, err
