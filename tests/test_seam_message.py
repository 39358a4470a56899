"""One cause, one message (issue #49, item 3): a mesh torn along seams of duplicate vertices.

A structured tube cut into patches (3 sectors around times 2 halves along), each patch with its own copy of the
vertices on the seams between patches, as a quad or multi-patch export writes it: 6 pieces glued only
geometrically, with a known number of duplicate vertices. Every refusal that meets it (the ends, the fits, the
prepared mesh, geodesic distances; every command) gives the same message naming the fix, ``vesselgp clean``,
which merges the copies and the fit then works. Genuinely separate pieces keep the message about components;
copies just outside the coincidence tolerance are not a seam, copies just inside are.
"""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import vesselgp as vg
from vesselgp import InvalidMeshError
from vesselgp import tolerances as tol
from vesselgp.mesh.geodesic import GeodesicDistances
from vesselgp.mesh.seams import open_seams
from vesselgp.mesh.topology import mesh_topology
from vesselgp.prepared import PreparedMesh, checked_mesh
from vesselgp.synthetic import synthetic_vessel

NA = 24  # vertices around
SECTORS, HALVES = 3, 2


def _message(duplicates, pieces):
    return (f"mesh has open seams of {duplicates} duplicate vertices (its {pieces} pieces touch along them); "
            "run vesselgp.clean_mesh (command line: vesselgp clean) to merge them")


def _split(V, F, labels):
    """Each patch (faces of one label) takes its own copy of the vertices an earlier patch used: (V, F, copies),
    copies (c, 2) int64 as (original, copy)."""
    F2, extra, pairs = F.copy(), [], []
    first = np.full(len(V), -1)
    for p in np.unique(labels):
        rows = np.flatnonzero(labels == p)
        used = np.unique(F[rows])
        mine = first[used] < 0
        first[used[mine]] = p
        taken = used[~mine]
        ids = len(V) + len(extra) + np.arange(len(taken))
        relabel = np.arange(len(V))
        relabel[taken] = ids
        F2[rows] = relabel[F[rows]]
        extra.extend(taken.tolist())
        pairs += list(zip(taken.tolist(), ids.tolist()))
    return np.vstack([V, V[extra]]), F2, np.array(pairs, dtype=np.int64).reshape(-1, 2)


@pytest.fixture(scope="module")
def tube():
    """Structured open arc of radius 1 (121 rings of 24), its true axis known."""
    return synthetic_vessel("arc", radius=1.0, n_around=NA, remesh=False)


@pytest.fixture(scope="module")
def torn(tube):
    """The tube in 3 x 2 patches: (V, F, copies, expected duplicates)."""
    q = np.arange(len(tube.F)) % (len(tube.F) // 2)  # the quad of each face (ring k, position j: k * NA + j)
    k, j = q // NA, q % NA
    rings = len(tube.V) // NA
    labels = j // (NA // SECTORS) + SECTORS * (k >= (rings - 1) // 2)
    V, F, copies = _split(tube.V, tube.F, labels)
    # three seams along (one copy of each of their ring vertices), the ring between the halves (one copy of
    # each vertex) and where they cross (four patches: three copies)
    expected = SECTORS * (rings - 1) + (NA - SECTORS) + SECTORS * 3
    assert len(copies) == expected == 390
    assert mesh_topology(F, len(V)).vertex_components[0] == SECTORS * HALVES
    return V, F, copies, expected


def _refusals(V, F):
    """The message of every library refusal the commands meet on this mesh."""
    calls = {
        "vessel_ends": lambda: vg.vessel_ends(V, F),
        "fit_generalized_cylinder": lambda: vg.fit_generalized_cylinder(V, F),
        "fit_vessel_tree": lambda: vg.fit_vessel_tree(V, F),
        "PreparedMesh": lambda: PreparedMesh(V, F),
        "checked_mesh": lambda: checked_mesh(V, F),
        "GeodesicDistances": lambda: GeodesicDistances(V, F),
        "twist_between": lambda: vg.twist_between(V, F, V, F),
        "measure_torsion": lambda: vg.measure_torsion(V, V, F),
    }
    out = {}
    for name, call in calls.items():
        with pytest.raises(InvalidMeshError) as ei:
            call()
        assert type(ei.value) is InvalidMeshError, name
        out[name] = str(ei.value)
    return out


def test_every_refusal_of_a_torn_mesh_names_its_seams_and_clean(torn):
    V, F, _, expected = torn
    said = _refusals(V, F)
    assert set(said.values()) == {_message(expected, SECTORS * HALVES)}, said
    assert "connected components" not in said["fit_generalized_cylinder"]


def test_open_seams_counts_the_copies_and_merges_them_onto_their_originals(torn, tube):
    V, F, copies, expected = torn
    s = open_seams(V, mesh_topology(F, len(V)))
    assert (s.duplicates, s.pieces, s.touching, s.pieces_merged) == (expected, 6, 6, 1)
    # each copy merges into the original vertex it copies (the lowest index at its position)
    assert np.array_equal(s.merge[copies[:, 1]], copies[:, 0])
    assert np.array_equal(s.merge[: len(tube.V)], np.arange(len(tube.V)))


def test_one_piece_open_along_a_seam_gets_the_same_message_from_every_call(tube):
    """The tube cut open along one line of its rings (one piece): ends and fits say the same."""
    q = np.arange(len(tube.F)) % (len(tube.F) // 2)
    V, F, copies = _split(tube.V, tube.F, (q % NA == NA - 1).astype(int))  # the last quad of each ring copies
    rings = len(tube.V) // NA
    # the strip of last quads is a piece of its own: its two lines of vertices (j = 23 and j = 0) are copies
    s = open_seams(V, mesh_topology(F, len(V)))
    assert (s.duplicates, s.pieces, s.touching, s.pieces_merged) == (len(copies), 2, 2, 1)
    assert len(copies) == 2 * rings
    for fn in (lambda: vg.vessel_ends(V, F), lambda: vg.fit_generalized_cylinder(V, F)):
        with pytest.raises(InvalidMeshError) as ei:
            fn()
        assert str(ei.value) == _message(2 * rings, 2)
    # a true one-piece seam: the first vertex of every ring repeated for the last quads
    V1 = np.vstack([tube.V, tube.V[::NA]])
    F1 = tube.F.copy()
    last = np.flatnonzero(q % NA == NA - 1)
    F1[last] = np.where(F1[last] % NA == 0, len(tube.V) + F1[last] // NA, F1[last])
    s = open_seams(V1, mesh_topology(F1, len(V1)))
    assert (s.duplicates, s.pieces, s.touching, s.pieces_merged) == (rings, 1, 0, 1)
    text = (f"mesh has open seams of {rings} duplicate vertices ({2 * (rings - 1)} boundary edges lie on other "
            "boundary edges); run vesselgp.clean_mesh (command line: vesselgp clean) to merge them")
    # checked_mesh and GeodesicDistances are public too: a one-piece tear would send geodesics the long way round
    for fn in (lambda: vg.vessel_ends(V1, F1), lambda: vg.fit_generalized_cylinder(V1, F1),
               lambda: vg.fit_vessel_tree(V1, F1), lambda: checked_mesh(V1, F1), lambda: GeodesicDistances(V1, F1)):
        with pytest.raises(InvalidMeshError) as ei:
            fn()
        assert str(ei.value) == text
    checked_mesh(tube.V, tube.F)  # the same tube untorn (two open rings, no seam) passes both
    GeodesicDistances(tube.V, tube.F)


def _axis_error(centers, truth):
    """Largest distance of fitted axis points to the true axis (its dense samples)."""
    d = np.linalg.norm(centers[:, None] - truth.centers[None], axis=2).min(axis=1)
    return d.max()


def test_after_clean_the_torn_mesh_fits_on_the_true_axis(torn, tube):
    V, F, _, expected = torn
    V2, F2, rep = vg.clean_mesh(V, F)
    assert rep.duplicate_vertices_merged == expected and rep.components_found == 1
    assert rep.components_removed == 0 and len(V2) == len(tube.V) and len(F2) == len(tube.F)
    gc = vg.fit_generalized_cylinder(V2, F2)
    truth = tube.truth
    assert gc.length == pytest.approx(truth.length, rel=0.02)
    assert _axis_error(gc.centers, truth) < 0.05  # radius 1
    tree = vg.fit_vessel_tree(V2, F2)
    assert len(tree.paths) == 1
    assert tree.paths[0].length == pytest.approx(truth.length, rel=0.02)


def test_separate_tubes_keep_the_components_message(tube):
    """Two copies of the tube side by side, 5 radii apart (no vertex shared or coinciding): not a seam."""
    V = np.vstack([tube.V, tube.V + [0.0, 0.0, 5.0]])
    F = np.vstack([tube.F, tube.F + len(tube.V)])
    assert open_seams(V, mesh_topology(F, len(V))) is None
    text = ("mesh has 2 connected components; run vesselgp.clean_mesh (keeps the largest) or fit each vessel "
            "separately")
    for fn in (lambda: vg.fit_generalized_cylinder(V, F), lambda: vg.fit_vessel_tree(V, F),
               lambda: PreparedMesh(V, F), lambda: checked_mesh(V, F)):
        with pytest.raises(InvalidMeshError) as ei:
            fn()
        assert str(ei.value) == text
    with pytest.raises(InvalidMeshError, match="mesh has 2 connected components .unreferenced"):
        GeodesicDistances(V, F)


def test_a_torn_mesh_beside_a_separate_piece_says_both(torn, tube):
    V, F, _, expected = torn
    V2 = np.vstack([V, tube.V + [0.0, 0.0, 5.0]])
    F2 = np.vstack([F, tube.F + len(V)])
    with pytest.raises(InvalidMeshError) as ei:
        vg.fit_generalized_cylinder(V2, F2)
    assert str(ei.value) == (
        f"mesh has open seams of {expected} duplicate vertices (6 of its 7 pieces touch along them; merged, the "
        "mesh is 2 separate pieces); run vesselgp.clean_mesh (command line: vesselgp clean) to merge them and "
        "keep the largest piece")


@pytest.mark.parametrize("fraction", [0.9, 1.1])
def test_copies_within_the_tolerance_are_a_seam_and_beyond_it_are_not(torn, tube, fraction):
    """Each copy moved ``fraction`` of the coincidence tolerance (SEAM_COINCIDENCE median edges) from the one
    before it (the i-th copy of a vertex i steps from the original): a seam within it, which clean_mesh merges
    into the tube; separate pieces beyond it."""
    V, F, copies, expected = torn
    radius = tol.SEAM_COINCIDENCE * float(np.median(mesh_topology(F, len(V)).edge_lengths(V)))
    step = np.zeros(len(V))
    for orig in np.unique(copies[:, 0]):
        ids = copies[copies[:, 0] == orig, 1]
        step[ids] = np.arange(1, len(ids) + 1)
    direction = np.array([1.0, 2.0, 2.0]) / 3.0
    Vj = V + (fraction * radius * step)[:, None] * direction
    seams = open_seams(Vj, mesh_topology(F, len(Vj)))
    with pytest.raises(InvalidMeshError) as ei:
        vg.fit_generalized_cylinder(Vj, F)
    V2, F2, rep = vg.clean_mesh(Vj, F)
    if fraction < 1:
        assert seams.duplicates == expected
        assert str(ei.value) == _message(expected, 6)
        assert rep.duplicate_vertices_merged == expected and len(V2) == len(tube.V)
        assert np.array_equal(V2, Vj[rep.vertex_map])  # the positions kept are the originals'
        assert np.abs(V2 - tube.V[rep.vertex_map]).max() == 0.0
    else:
        assert seams is None
        assert str(ei.value).startswith("mesh has 6 connected components; run vesselgp.clean_mesh (keeps the")
        assert rep.duplicate_vertices_merged == 0 and rep.components_removed == 5


# ----------------------------------------------------------------------------- the command line


def _start(*args):
    """``vesselgp ARGS`` started in a subprocess (its output captured)."""
    return subprocess.Popen([sys.executable, "-m", "vesselgp.cli", *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _cli(*args):
    """``vesselgp ARGS`` in a subprocess: (exit code, stdout, stderr)."""
    r = _start(*args)
    o, e = r.communicate(timeout=600)
    return r.returncode, o, e


def test_every_command_that_reads_the_torn_mesh_prints_the_same_line(torn, tmp_path):
    V, F, _, expected = torn
    mesh = tmp_path / "torn.ply"
    vg.write_mesh(mesh, V, F)
    assert len(vg.read_mesh(mesh)[0]) == len(V)  # PLY keeps the copies
    out = tmp_path / "out"  # the runs that succeed
    commands = {
        "ends": ["ends", mesh],
        "fit": ["fit", mesh, "-o", tmp_path / "fit", "--no-png"],
        "torsion": ["torsion", mesh, mesh, "-o", tmp_path / "torsion", "--no-png"],
        "twist": ["twist", mesh, mesh, "-o", tmp_path / "twist", "--no-png"],
        "join": ["join", mesh, "--end", 0, "--onto", mesh, "--other-end", 1, "-o", tmp_path / "join", "--no-png"],
    }
    line = ("vesselgp: error: mesh has open seams of 390 duplicate vertices (its 6 pieces touch along them); "
            "run vesselgp clean to merge them")
    runs = {name: _start(*args) for name, args in commands.items()}  # side by side: each mostly imports
    for name, r in runs.items():
        o, e = r.communicate(timeout=600)
        assert r.returncode == 2, (name, o, e)
        assert e.strip().splitlines() == [line], (name, e)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["torn.ply"]  # a refused run leaves no folder
    rc, o, e = _cli("clean", mesh, "-o", out / "clean")
    assert rc == 0, e
    assert "merged 390 duplicate vertices" in o
    rc, o, e = _cli("fit", out / "clean" / "torn_clean.ply", "-o", out / "fitted", "--no-png", "-q")
    assert rc == 0, e
