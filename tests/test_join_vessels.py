"""Joining two real vessels by end index (issue 14): join_vessels, VesselJoin, open_end, the CLI.

Truth is geometric: the placed other vessel's end is where the moving end must
land, held vertices must not move, the mesh must be one manifold piece, faces
must keep their orientation about the axis, and the anchor must land where it
is told at angle 0 (checked by a Kabsch fit of the moved ring, not by the code's
end map).
"""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

import vesselgp as vg
from vesselgp.cli import main
from vesselgp.errors import EndsError, ImplausibleJoinError
from vesselgp.mesh import MeshTopology, open_end
from vesselgp.rotations import wrap_angle
from vesselgp.synthetic import paper_case, synthetic_vessel

from _data import REAL

CORONARY = REAL / "xra_coronary_single_branch_open.stl"
CAPPED = REAL / "dfemtoolz_artery_segment_lumen_capped.stl"
Y = REAL / "vmtk_abdominal_aorta_iliac_bifurcation_open.stl"


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def place_other(Vo, e, origin, tangent, roll):
    """Move ``Vo`` rigidly so that end ``e`` is centred at ``origin`` facing the moving vessel.

    Its outward direction becomes ``-tangent`` (the joined vessel continues
    into it) and it is turned by ``roll`` about ``tangent``.
    """
    d = _unit(e.direction)
    t = _unit(tangent)
    axis = np.cross(d, -t)
    ang = np.arctan2(np.linalg.norm(axis), d @ -t)
    R0 = Rotation.from_rotvec(_unit(axis) * ang if np.linalg.norm(axis) > 1e-12 else np.zeros(3))
    R = Rotation.from_rotvec(t * roll) * R0
    return (Vo - e.center) @ R.as_matrix().T + origin


def target_at(end, length, distance, bend_deg):
    """A target ``distance`` (fraction of ``length``) from ``end``, its tangent bent by ``bend_deg``."""
    d = _unit(end.direction)
    side = _unit(np.cross(d, np.eye(3)[int(np.argmin(np.abs(d)))]))
    t = Rotation.from_rotvec(side * np.radians(bend_deg)).apply(d)
    lateral = np.cross(side, d)
    origin = end.center + distance * length * _unit(d + lateral)
    return origin, t


@pytest.fixture(scope="module")
def coronary():
    V, F = vg.read_mesh(CORONARY)[:2]
    ends = vg.vessel_ends(V, F)
    L = vg.fit_generalized_cylinder(V, F).length
    return V, F, ends, L


@pytest.fixture(scope="module")
def capped_placed(coronary):
    """The capped real artery placed 0.15 L from the coronary's end 1, 35 deg bend, 70 deg roll."""
    V, F, ends, L = coronary
    Vo, Fo = vg.read_mesh(CAPPED)[:2]
    eo = vg.vessel_ends(Vo, Fo)
    origin, t = target_at(ends[1], L, 0.15, 35.0)
    return place_other(Vo, eo[1], origin, t, np.radians(70.0)), Fo, origin, t


@pytest.fixture(scope="module")
def capped_join(coronary, capped_placed):
    V, F, _, _ = coronary
    Vo, Fo, _, _ = capped_placed
    join = vg.VesselJoin(V, F, 1, Vo, Fo, 1)
    return join, join.solve()


def _inverted_faces(V, X, F, reach):
    """(m,) bool: faces whose deformed normal opposes the rest normal turned by the local rigid motion.

    The local motion is the Kabsch rotation of the rest vertices within ``reach`` of the face onto
    their deformed positions: a face is inverted when it flips against its own neighbourhood.
    """
    c = V[F].mean(axis=1)
    nbr = cKDTree(V).query_ball_point(c, reach)
    n0 = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    n1 = np.cross(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]])
    out = np.zeros(len(F), bool)
    for f, idx in enumerate(nbr):
        idx = np.union1d(idx, F[f])
        out[f] = (_kabsch(V[idx], X[idx]) @ n0[f]) @ n1[f] <= 0
    return out


def _kabsch(A, B):
    """Rotation R minimising |R (A - mean A) - (B - mean B)|."""
    a, b = A - A.mean(0), B - B.mean(0)
    U, _, Wt = np.linalg.svd(b.T @ a)
    D = np.diag([1, 1, np.sign(np.linalg.det(U @ Wt))])
    return U @ D @ Wt


# ----------------------------------------------------------------------------- real meshes


def test_real_coronary_onto_capped_artery(coronary, capped_placed, capped_join):
    V, F, ends, L = coronary
    Vo, Fo, origin, t = capped_placed
    join, res = capped_join
    top = MeshTopology(res.joined_F, len(res.joined_V))
    assert top.face_components[0] == 1 and top.is_edge_manifold and top.is_coherent
    # the capped artery's other cap stays closed, the coronary's held end stays open: one boundary loop
    assert len(top.boundary_loops) == 1
    # the moving end lands on the other end's centre, facing along the target tangent
    ring = res.V[res.moving]
    r_end = ends[1].radius
    assert np.linalg.norm(ring.mean(axis=0) - origin) < 0.15 * r_end
    # the vessel's own direction at the end (principal axis of the wall within 3 radii of the ring,
    # not the fit's tangent: this real end is cut 7 deg oblique) is turned onto the target tangent
    rest_ring = join.V[res.moving]
    near = join.V[np.linalg.norm(join.V - rest_ring.mean(0), axis=1) < 3 * r_end]
    d = np.linalg.svd(near - near.mean(0))[2][0]
    R = _kabsch(rest_ring, ring)
    assert np.degrees(np.arccos(abs((R @ d) @ t))) < 5.0
    # held vertices exactly unchanged, and they are the vessel next to the other end
    assert np.array_equal(res.V[res.fixed], V[res.kept][res.fixed])
    assert len(res.fixed) > 0.05 * len(res.V)
    # the optimum is (almost) twist-free
    assert abs(np.degrees(res.profile.total_twist)) <= 1.0
    # edges bounded, axis stretch as measured from the geometry
    assert res.max_edge_stretch <= 1.5
    assert 1.0 <= res.axial_stretch < 1.3
    # no inverted face (against the local rigid motion of its neighbourhood)
    assert not np.any(_inverted_faces(join.V, res.V, join.F, r_end))


def test_real_join_rolled_70_degrees_keeps_edges_bounded(capped_join):
    """The issue's case (0.15 L, 35 deg bend) with the end rolled 70 deg beyond twist-free: edges <= 1.5."""
    join, res = capped_join
    X = join.problem.deform(res.zero_twist_angle + np.radians(70.0))
    assert join.problem.deformer.edge_stretch(X) <= 1.5
    assert abs(np.degrees(join.problem.profile(res.zero_twist_angle + np.radians(70.0)).total_twist)) > 40.0


def test_real_coronary_onto_iliac_of_a_y(coronary):
    """The vessel joined to may be a tree: the coronary's end 0 onto one iliac's open end, the Y scaled to the
    coronary's calibre (as it is, 3.01 times wider, the join is refused: issue #49)."""
    V, F, ends, L = coronary
    Vy, Fy = vg.read_mesh(Y)[:2]
    ey = vg.vessel_ends(Vy, Fy)
    k = int(np.argmin([e.radius for e in ey]))
    origin, t = target_at(ends[0], L, 0.1, 20.0)
    with pytest.raises(ImplausibleJoinError, match=r"the ends' radii differ 3\.01x \(the moving end 1\.45, the other "
                                                   r"end 4\.38; at most max_radius_ratio = 1\.5\)"):
        vg.join_vessels(V, F, 0, place_other(Vy, ey[k], origin, t, 0.0), Fy, k)
    Vy = Vy * (ends[0].radius / ey[k].radius)  # a Y of the coronary's calibre
    ey = vg.vessel_ends(Vy, Fy)
    W = place_other(Vy, ey[k], origin, t, np.radians(-30.0))
    res = vg.join_vessels(V, F, 0, W, Fy, k)
    top = MeshTopology(res.joined_F, len(res.joined_V))
    assert top.face_components[0] == 1 and top.is_edge_manifold
    assert len(top.boundary_loops) == 3  # the aorta, the other iliac and the coronary's held end
    assert np.linalg.norm(res.V[res.moving].mean(0) - origin) < 0.15 * ends[0].radius
    # docs/accuracy.md: 1.2 degrees at the optimum, the non-uniform part of alpha (a step at the stenosis)
    assert abs(np.degrees(res.profile.total_twist)) <= 1.5 * 1.2
    assert res.max_edge_stretch <= 1.5


def test_real_y_moves_one_iliac(capped_placed):
    """A moving tree: one iliac of the real Y onto the capped artery; the aorta and the other iliac stay put."""
    Vy, Fy = vg.read_mesh(Y)[:2]
    ey = vg.vessel_ends(Vy, Fy)
    Vo, Fo = vg.read_mesh(CAPPED)[:2]
    eo = vg.vessel_ends(Vo, Fo)
    k = int(np.argsort([e.radius for e in ey])[0])
    Vo = Vo * (ey[k].radius / eo[0].radius)  # the capped artery at the iliac's calibre
    eo = vg.vessel_ends(Vo, Fo)
    tree = vg.fit_vessel_tree(Vy, Fy)
    L = tree.branches[tree.path_branches[[p.ends[1] for p in tree.paths].index(k)][-1]].length
    origin, t = target_at(ey[k], L, 0.1, 25.0)
    W = place_other(Vo, eo[0], origin, t, np.radians(40.0))
    join = vg.VesselJoin(Vy, Fy, k, W, Fo, 0)
    res = join.solve()
    # everything within 2 radii of the two other ends is held, exactly
    for i in set(range(3)) - {k}:
        near = np.flatnonzero(np.linalg.norm(Vy - ey[i].center, axis=1) < 2 * ey[i].radius)
        assert np.isin(near, res.fixed).all()
    assert np.array_equal(res.V[res.fixed], Vy[res.fixed])
    # and the moving branch is free: its end's neighbourhood moved onto the target
    assert np.linalg.norm(res.V[res.moving].mean(0) - origin) < 0.15 * ey[k].radius
    assert abs(np.degrees(res.profile.total_twist)) <= 1.0
    assert res.max_edge_stretch <= 1.5
    assert not np.any(_inverted_faces(join.V, res.V, join.F, ey[k].radius))
    top = MeshTopology(res.joined_F, len(res.joined_V))
    # the aorta and the other iliac stay open; the capped artery's far cap stays closed
    assert top.face_components[0] == 1 and top.is_edge_manifold and len(top.boundary_loops) == 2


def test_far_target_is_refused(coronary):
    V, F, ends, L = coronary
    Vo, Fo = vg.read_mesh(CAPPED)[:2]
    eo = vg.vessel_ends(Vo, Fo)
    origin = ends[1].center + 150.0 * _unit(ends[1].direction)
    W = place_other(Vo, eo[1], origin, ends[1].direction, 0.0)
    with pytest.raises(ImplausibleJoinError, match="stretched .*x along its axis"):
        vg.join_vessels(V, F, 1, W, Fo, 1)


def test_compressing_target_is_refused(coronary):
    """A target that pushes the end back halfway along its own axis: the wall would buckle."""
    V, F, ends, L = coronary
    Vo, Fo = vg.read_mesh(CAPPED)[:2]
    eo = vg.vessel_ends(Vo, Fo)
    gc = vg.fit_generalized_cylinder(V, F, ends=(0, 1))
    mid = gc.at([0.55])[0][0]
    W = place_other(Vo, eo[1], mid, ends[1].direction, 0.0)
    with pytest.raises(ImplausibleJoinError, match="compressed"):
        vg.join_vessels(V, F, 1, W, Fo, 1)


def test_u_turn_target_is_refused(coronary):
    """A target right beside the end, facing back: refused when the free part is too short to turn."""
    V, F, ends, L = coronary
    Vo, Fo = vg.read_mesh(CAPPED)[:2]
    eo = vg.vessel_ends(Vo, Fo)
    d = _unit(ends[1].direction)
    side = _unit(np.cross(d, [0, 0, 1.0]))
    W = place_other(Vo, eo[1], ends[1].center + 3 * ends[1].radius * side, -d, 0.0)
    # with the default hold (90 % of the vessel free, about 60 mm at radius 1.3 mm) a U-turn has room
    j = vg.VesselJoin(V, F, 1, W, Fo, 1, max_stretch=10.0)
    assert j.problem.placement.max_bend[0] < 1.0
    with pytest.raises(ImplausibleJoinError, match="tighter than the radius allows"):
        vg.join_vessels(V, F, 1, W, Fo, 1, max_stretch=10.0, hold=0.95)


def test_bad_end_indices_list_the_ends(coronary, capped_placed):
    V, F, _, _ = coronary
    Vo, Fo, _, _ = capped_placed
    with pytest.raises(EndsError, match=r"^end=2 is not an end index in 0\.\.1 \(ends: 0 r="):
        vg.join_vessels(V, F, 2, Vo, Fo, 0)
    with pytest.raises(EndsError, match=r"other_end=-1 is not an end index"):
        vg.join_vessels(V, F, 0, Vo, Fo, -1)


# ----------------------------------------------------------------------------- anchors and angles


def test_anchor_lands_on_target_normal_at_angle_zero(coronary, capped_join):
    """At angle 0 the moved ring's rigid motion (Kabsch, from the vertices) takes moving_normal to target_normal."""
    join, res = capped_join
    p = join.problem
    for a in (0.0, 0.7):
        X = p.deform(a)
        R = _kabsch(join.V[p.moving], X[p.moving])
        got = R @ p.moving_normal
        want = Rotation.from_rotvec(p.target.tangent * a).apply(np.array(p.target.normal))
        assert np.degrees(np.arccos(np.clip(got @ want, -1, 1))) < 0.5


def test_turning_the_target_normal_turns_the_optimum_back(coronary, capped_placed, capped_join):
    """The anchor only names angle 0: turning target_normal by b moves the optimum by -b, same deformation."""
    V, F, _, _ = coronary
    Vo, Fo, _, t = capped_placed
    join, res = capped_join
    b = np.radians(50.0)
    tn = Rotation.from_rotvec(_unit(t) * b).apply(np.array(res.target_normal))
    res2 = vg.join_vessels(V, F, 1, Vo, Fo, 1, target_normal=tn)
    d = np.degrees(vg.rotations.wrap_angle(res2.angle - res.angle + b))
    assert abs(d) < 0.5
    assert np.allclose(res2.V, res.V, atol=1e-3 * np.ptp(res.V))
    assert abs(res2.roll - res.roll) < np.radians(0.5)


def test_paper_case_1_optimum_undoes_its_pre_rotation():
    """Case 1 carries its own anchors (the vessels' material U): the optimum reads as minus the pre-rotation."""
    for pre in (0.0, 0.5, -1.2):
        c = paper_case(1, resolution=0.35, pre_rotation=pre)
        p = vg.JoinProblem(c.V, c.F, c.fixed, c.moving, vg.Frame(c.target_origin, c.target_tangent,
                                                                   c.target_normal),
                           moving_normal=c.moving_normal)
        res = vg.minimize_torsion(p)
        assert abs(np.degrees(vg.rotations.wrap_angle(res.angle + pre))) < 1.0
        assert -np.pi < res.roll <= np.pi and abs(np.degrees(res.roll)) < 2.0


# ----------------------------------------------------------------------------- hold and opening ends


def test_hold_fraction_and_ids(coronary, capped_placed):
    V, F, _, _ = coronary
    Vo, Fo, _, _ = capped_placed
    j1 = vg.VesselJoin(V, F, 1, Vo, Fo, 1, hold=0.3)
    s = j1.problem.gc.vertex_s
    assert np.array_equal(j1.problem.fixed, np.flatnonzero(s <= 0.3))
    ids = np.flatnonzero(s < 0.05)
    j2 = vg.VesselJoin(V, F, 1, Vo, Fo, 1, hold=j1.kept[ids])
    assert np.array_equal(j2.problem.fixed, ids)
    with pytest.raises(EndsError, match=r"hold=1\.5 is not an arc-length fraction in \(0, 1\)"):
        vg.VesselJoin(V, F, 1, Vo, Fo, 1, hold=1.5)


def test_open_cap_and_rounded_tip():
    """A flat cap loses exactly its faces; a rounded tip loses its dome beyond the centre plane."""
    v = synthetic_vessel("arc", ends="capped", n_around=24)
    ends = vg.vessel_ends(v.V, v.F)
    W, G, loop, kept = open_end(v.V, v.F, ends[1])
    assert len(G) == len(v.F) - len(ends[1].faces)
    assert sorted(e.kind for e in vg.vessel_ends(W, G)) == ["cap", "open"]
    assert set(kept[loop]) == set(ends[1].loop)
    from vesselgp.synthetic_tree import synthetic_tree
    tr = synthetic_tree(1, voxel=0.5)
    te = vg.vessel_ends(tr.V, tr.F)
    k = next(i for i, e in enumerate(te) if e.kind == "rounded")
    e = te[k]
    W, G, loop, kept = open_end(tr.V, tr.F, e)
    gone = np.setdiff1d(np.arange(len(tr.V)), kept)
    assert len(gone) > 0 and np.all((tr.V[gone] - e.center) @ e.direction > 0)
    ring = W[loop]
    assert abs(np.linalg.norm(ring - ring.mean(0), axis=1).mean() / e.radius - 1.0) < 0.25
    assert len(MeshTopology(G, len(W)).boundary_loops) == len(MeshTopology(tr.F, len(tr.V)).boundary_loops) + 1


def test_join_capped_synthetic_moving_end():
    """A capped moving end is opened too; the join lands it on a straight open vessel's end."""
    v = synthetic_vessel("arc", ends="capped", n_around=24)
    ends = vg.vessel_ends(v.V, v.F)
    L = v.truth.length
    o = synthetic_vessel("straight", n_around=20, radius=float(ends[1].radius))
    eo = vg.vessel_ends(o.V, o.F)
    origin, t = target_at(ends[1], L, 0.1, 25.0)
    W = place_other(o.V, eo[0], origin, t, 0.3)
    res = vg.join_vessels(v.V, v.F, 1, W, o.F, 0)
    assert len(res.V) < len(v.V)
    assert np.linalg.norm(res.V[res.moving].mean(0) - origin) < 0.15 * ends[1].radius
    top = MeshTopology(res.joined_F, len(res.joined_V))
    assert top.face_components[0] == 1 and top.is_edge_manifold
    assert abs(np.degrees(res.profile.total_twist)) <= 1.0


# ----------------------------------------------------------------------------- CLI


def test_cli_join_by_end_index(tmp_path, coronary, capped_placed):
    Vo, Fo, _, _ = capped_placed
    other = tmp_path / "other.ply"
    vg.write_mesh(other, Vo, Fo)
    out = tmp_path / "j"
    rc = main(["join", str(CORONARY), "--end", "1", "--onto", str(other), "--other-end", "1", "-o", str(out),
               "--n-curve", "5", "--no-png", "-q"])
    assert rc == 0
    r = json.loads((out / "result.json").read_text())
    assert "angle 0 puts the anchor moving_normal" in r["angle_reference"]
    assert -180 < r["optimum_angle_deg"] <= 180 and -180 < r["roll_deg"] <= 180
    assert abs(r["total_twist_deg"]) <= 1.0 and r["max_edge_stretch"] <= 1.5
    assert len(r["moving_normal"]) == 3 and len(r["target_normal"]) == 3
    Vj, Fj = vg.read_mesh(out / "joined_optimum.ply")[:2]
    assert MeshTopology(Fj, len(Vj)).face_components[0] == 1


def test_cli_refuses_before_writing(tmp_path, coronary, capped_placed, capsys):
    V, F, ends, _ = coronary
    Vo, Fo = vg.read_mesh(CAPPED)[:2]
    eo = vg.vessel_ends(Vo, Fo)
    W = place_other(Vo, eo[1], ends[1].center + 150.0 * _unit(ends[1].direction), ends[1].direction, 0.0)
    far = tmp_path / "far.ply"
    vg.write_mesh(far, W, Fo)
    out = tmp_path / "nothing"
    rc = main(["join", str(CORONARY), "--end", "1", "--onto", str(far), "--other-end", "1", "-o", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and not out.exists()
    assert len(err) == 1 and "stretched" in err[0] and "--place GAP" in err[0]  # unrelated coordinates need it
    rc = main(["join", str(CORONARY), "--end", "1", "--onto", str(far), "-o", str(out)])
    assert rc == 2 and not out.exists()
    assert "--other-end" in capsys.readouterr().err


def test_stretch_warning_and_a_rounded_other_end(caplog):
    """Paper case 1 needs a 1.23x axial stretch (warned, above 1.15); a tree's rounded tip is opened to join onto."""
    c = paper_case(1, resolution=0.25)
    with caplog.at_level("WARNING", logger="vesselgp"):
        res = vg.join_vessels(c.V, c.F, 1, c.other_V, c.other_F, 0)
    assert any("stretches the free part" in r.getMessage() for r in caplog.records)
    assert 1.15 < res.axial_stretch < 1.3
    from vesselgp.synthetic_tree import synthetic_tree

    tr = synthetic_tree(1, voxel=0.5)
    te = vg.vessel_ends(tr.V, tr.F)
    k = next(i for i, e in enumerate(te) if e.kind == "rounded")
    v = synthetic_vessel("straight", n_around=24, radius=float(te[k].radius))
    ev = vg.vessel_ends(v.V, v.F)
    # the tube's end 0 placed 0.1 of its length beyond the tip, facing it; then joined onto the opened tip
    W = place_other(v.V, ev[0], te[k].center + 0.1 * v.truth.length * _unit(te[k].direction),
                    te[k].direction, 0.0)
    res = vg.join_vessels(W, v.F, 0, tr.V, tr.F, k)
    top = MeshTopology(res.joined_F, len(res.joined_V))
    assert top.face_components[0] == 1 and top.is_edge_manifold
    assert np.linalg.norm(res.V[res.moving].mean(0) - te[k].center) < 0.2 * te[k].radius
    assert abs(np.degrees(res.profile.total_twist)) <= 1.0


def test_edge_stretch_of_a_uniform_scaling(capped_join):
    """Every edge of the mesh scaled by 1.7 about any point: the largest edge stretch is 1.7."""
    join, _ = capped_join
    d = join.problem.deformer
    assert d.edge_stretch(1.7 * d.V + [3.0, -1.0, 2.0]) == pytest.approx(1.7, rel=1e-12)
    assert d.edge_stretch(d.V) == pytest.approx(1.0, rel=1e-12)


def test_edge_stretch_of_a_one_axis_scaling(capped_join):
    """Scaling x by 1.7: each edge grows by sqrt(1.7^2 ex^2 + ey^2 + ez^2) / |e|, computed face by face."""
    join, _ = capped_join
    d = join.problem.deformer
    e = np.concatenate([d.V[d.F[:, (k + 1) % 3]] - d.V[d.F[:, k]] for k in range(3)])
    want = np.max(np.linalg.norm(e * [1.7, 1.0, 1.0], axis=1) / np.linalg.norm(e, axis=1))
    assert d.edge_stretch(d.V * [1.7, 1.0, 1.0]) == pytest.approx(want, rel=1e-12)


def test_an_arch_branch_of_a_real_tree_moves_past_its_junction_zone():
    """A moving tree's thin branch off a wide trunk: the 4D-flow arch's left subclavian (radius 3.7 mm off an
    arch of 16) onto the capped artery scaled to it, 0.1 of the branch away with a 25 degree bend. Held, exactly:
    every other branch and the branch's own junction zone (its wall there is the arch's flare); the rest of it
    lands on the target; no face turns over; the joined mesh is one manifold piece. (Until issue #34 the arch's
    wall wrapping past the junction left no free part and the join was refused.)"""
    Va, Fa = vg.read_mesh(REAL / "cardiopinns_aortic-arch-4dflow_capped.stl")[:2]
    ea = vg.vessel_ends(Va, Fa)
    k = int(np.argmin([e.radius for e in ea]))
    Vo, Fo = vg.read_mesh(CAPPED)[:2]
    eo = vg.vessel_ends(Vo, Fo)
    tree = vg.fit_vessel_tree(Va, Fa)
    b = tree.path_branches[[p.ends[1] for p in tree.paths].index(k)][-1]
    origin, t = target_at(ea[k], tree.branches[b].length, 0.1, 25.0)
    scaled = (Vo - eo[0].center) * (ea[k].radius / eo[0].radius) + eo[0].center
    join = vg.VesselJoin(Va, Fa, k, place_other(scaled, eo[0], origin, t, np.radians(40.0)), Fo, 0)
    res = join.solve()
    assert np.array_equal(res.V[res.fixed], join.V[res.fixed])
    for i in set(range(len(ea))) - {k}:  # the other ends and their branches
        near = np.flatnonzero(np.linalg.norm(join.V - ea[i].center, axis=1) < 2 * ea[i].radius)
        assert np.isin(near, res.fixed).all()
    free = np.setdiff1d(np.arange(len(join.V)), res.fixed)
    own = np.flatnonzero(join.tree.vertex_branch == b)
    assert np.isin(own, free).mean() > 0.3  # the branch beyond its zone moves ...
    branch = join.tree.branches[b]
    zone = own[branch.vertex_s[own] * branch.length < join.tree.junction_zone[b] - branch.mean_radius]
    assert len(zone) and np.isin(zone, res.fixed).all()  # ... its junction zone is held
    assert np.linalg.norm(res.V[res.moving].mean(0) - origin) < 0.15 * ea[k].radius
    assert res.max_edge_stretch <= 1.5
    assert not np.any(_inverted_faces(join.V, res.V, join.F, ea[k].radius))
    top = MeshTopology(res.joined_F, len(res.joined_V))
    assert top.face_components[0] == 1 and top.is_edge_manifold
    # a join that only bends the branch is twist-free at its optimum, measured over the branch (the held arch
    # upstream, through its junction zones, measured 26 degrees of RMF drift and 30-200 degrees of twist)
    assert abs(np.degrees(res.profile.total_twist)) <= 1.0 and abs(np.degrees(res.roll)) <= 1.0
    # turning the target's anchor by 50 degrees about the target tangent turns the optimum back by 50
    tn = Rotation.from_rotvec(np.radians(50.0) * _unit(t)).apply(np.array(join.problem.target.normal))
    turned = vg.VesselJoin(Va, Fa, k, place_other(scaled, eo[0], origin, t, np.radians(40.0)), Fo, 0,
                           target_normal=tn).solve()
    assert abs(np.degrees(wrap_angle(turned.angle - res.angle)) + 50.0) <= 1.0


def test_a_cropped_cylinder_is_the_same_axis_reparameterised():
    """The stretch of a fit from s0 on, as a cylinder of its own: the same points, frames, radii and vertex angles
    at s' = (s - s0) / (1 - s0); a length (1 - s0) L; no parameter and no weight before s0."""
    from vesselgp.join_vessels import _cropped

    v = synthetic_vessel("helix", radius=1.5, n_around=16, remesh=False)
    gc = vg.fit_generalized_cylinder(v.V, v.F)
    c = _cropped(gc, 0.37)
    s0 = 1.0 - c.length / gc.length
    assert abs(s0 - 0.37) <= 1.0 / (len(gc.dense_s) - 1)
    u = np.linspace(0.0, 1.0, 57)
    P, Fr = c.at(u)
    P0, Fr0 = gc.at(s0 + u * (1.0 - s0))
    assert np.allclose(P, P0, atol=1e-9 * gc.length) and np.allclose(Fr, Fr0, atol=1e-9)
    assert np.allclose(c.radius_at(u), gc.radius_at(s0 + u * (1.0 - s0)), atol=1e-9)
    on = gc.vertex_s >= s0
    assert np.allclose(c.vertex_s[on], (gc.vertex_s[on] - s0) / (1.0 - s0)) and np.isnan(c.vertex_s[~on]).all()
    assert np.array_equal(c.vertex_theta[on], gc.vertex_theta[on]) and not c.vertex_weight[~on].any()


def test_default_target_normal_on_an_oblique_bend(coronary):
    """Issue #35: the documented default target normal is the moving anchor turned by the least rotation from
    the moving end's direction onto the target tangent. Checked against that definition computed apart (Rodrigues: the axis the two
    directions' cross product, the angle between them) on an oblique
    bend: the target tangent out of the end's own plane of bending, 35 degrees off with a 20 degree tilt."""
    V, F, ends, L = coronary
    Vo, Fo = vg.read_mesh(CAPPED)[:2]
    eo = vg.vessel_ends(Vo, Fo)
    d = _unit(ends[1].direction)
    a = _unit(np.cross(d, [0.3, 1.0, 0.2]))
    b = np.cross(d, a)
    t = _unit(np.cos(np.radians(35.0)) * d + np.sin(np.radians(35.0)) * (np.cos(np.radians(20.0)) * a
                                                                          + np.sin(np.radians(20.0)) * b))
    origin = ends[1].center + 0.15 * L * _unit(d + 0.3 * a)
    join = vg.VesselJoin(V, F, 1, place_other(Vo, eo[1], origin, t, np.radians(25.0)), Fo, 1)
    p = join.problem
    u = _unit(join.ends[join.end].direction)
    e = np.eye(3)[int(np.argmin(np.abs(u)))]  # the default moving anchor, by its definition
    mn = _unit(e - (e @ u) * u)
    axis = np.cross(u, p.target.tangent)  # the least rotation from u onto the tangent (Rodrigues, by hand)
    R = Rotation.from_rotvec(_unit(axis) * np.arctan2(np.linalg.norm(axis), u @ p.target.tangent))
    want = R.apply(mn)
    want = _unit(want - (want @ p.target.tangent) * p.target.tangent)
    assert np.allclose(p.target.normal, want, atol=1e-9)
    # and not the image under the inverse rotation, which differs by tens of degrees here
    other = _unit(R.inv().apply(mn) - (R.inv().apply(mn) @ p.target.tangent) * p.target.tangent)
    assert np.degrees(np.arccos(np.clip(other @ want, -1, 1))) > 5.0


@pytest.fixture(scope="module")
def straight_half_free():
    """A straight open tube (radius 2, 30 long) held over its first half, and the free half's start on the axis:
    the join problem whose targets the guard tests retarget (its first target, 2 beyond the end, is a stand-in)."""
    from vesselgp.deform import Frame
    from vesselgp.join import JoinProblem
    from vesselgp.synthetic import named_curve

    v = synthetic_vessel(named_curve("straight", length=30.0), radius=2.0, n_around=32, ends="open")
    e = vg.vessel_ends(v.V, v.F)[1]
    gc = vg.fit_generalized_cylinder(v.V, v.F, ends=(0, 1))
    first = JoinProblem(v.V, v.F, np.flatnonzero(gc.vertex_s < 0.5), np.asarray(e.loop), Frame(
        e.center + 2.0 * e.direction, e.direction, [1.0, 0.0, 0.0]), gc=gc)
    return first, gc.at([first.deformer.s_boundary])[0][0]


def _guarded(p, refused, match):
    from vesselgp.join_vessels import _plausible

    if refused:
        with pytest.raises(ImplausibleJoinError, match=match):
            _plausible(p, 1.3, False)
    else:
        _plausible(p, 1.3, False)


@pytest.mark.parametrize("kr, refused", [(0.9, False), (1.1, True)])
def test_the_join_bend_guard_at_its_edge(straight_half_free, kr, refused):
    """Issue #35: a straight tube (radius 2) whose free half (15 long) is bent by the rod step to a target placed
    where that step puts the end with no correction: its tangent turns by phi (3u^2 - 2u) along the free part
    (the rod step, vesselgp.deform), so its curvature peaks at the end at 4 phi / 15. phi for kappa r = 0.9 is
    accepted, for 1.1 refused (the wall would fold); the measured peak is the analytic one within 3 %."""
    from scipy.integrate import quad

    from vesselgp.deform import Frame

    first, start = straight_half_free
    d = first.deformer
    ell, T = d.free_length, _unit(d.end_tangent)
    n = _unit(np.cross(T, [1.0, 0.0, 0.0]))
    phi = kr * ell / (4.0 * 2.0)
    x = ell * quad(lambda u: np.cos(phi * (3 * u * u - 2 * u)), 0.0, 1.0)[0]
    y = ell * quad(lambda u: np.sin(phi * (3 * u * u - 2 * u)), 0.0, 1.0)[0]
    tan = np.cos(phi) * T + np.sin(phi) * n
    p = first.retarget(Frame(start + x * T + y * n, tan, np.cross(tan, n)))
    assert p.placement.max_bend[0] == pytest.approx(kr, rel=0.03)
    _guarded(p, refused, "bends the vessel")


@pytest.mark.parametrize("stretch, refused", [(1.25, False), (1.35, True), (0.8, False), (0.74, True)])
def test_the_join_stretch_and_compression_guards_at_their_edges(straight_half_free, stretch, refused):
    """Issue #35: the same straight tube's free half pulled or pushed straight along its axis, the target that
    far from where the free part starts: the free axis is stretched exactly that much (1.25 and 0.8 are within
    max_stretch 1.3 and its inverse 0.77; 1.35 and 0.74 are refused)."""
    from vesselgp.deform import Frame

    first, start = straight_half_free
    T = _unit(first.deformer.end_tangent)
    p = first.retarget(Frame(start + stretch * first.deformer.free_length * T, T, [1.0, 0.0, 0.0]))
    assert p.placement.axial_stretch == pytest.approx(stretch, rel=1e-3)
    _guarded(p, refused, "stretched|compressed")


# --------------------------------------------------------------------------- #
# place=GAP: two vessels in unrelated coordinates (issue #37, item 4)
# --------------------------------------------------------------------------- #
def test_placing_a_straight_tube_in_front_of_another_is_a_pure_stretch():
    """A straight tube (30 long, radius 2) turned and moved anywhere, placed 1.5 in front of another's end:
    its joined end then faces the other end on the other's axis (the move checked on the tube's own end ring,
    not the code's end objects), and the join only stretches the free part by the gap: no bend, no twist."""
    from vesselgp.synthetic import named_curve

    a = synthetic_vessel(named_curve("straight", length=30.0), radius=2.0, n_around=32, ends="open")
    b = synthetic_vessel(named_curve("straight", length=20.0), radius=2.0, n_around=32, ends="open")
    Q = Rotation.from_rotvec([0.4, -1.1, 0.7])
    V = Q.apply(a.V) + [40.0, -12.0, 7.0]  # the moving vessel, elsewhere and turned
    ends_b = vg.vessel_ends(b.V, b.F)
    top_b = max(range(2), key=lambda i: ends_b[i].center[2])  # the other's end at z = 20, facing +z
    ends_a = vg.vessel_ends(V, a.F)
    far = max(range(2), key=lambda i: (Q.inv().apply(ends_a[i].center - [40.0, -12.0, 7.0]))[2])  # its z = 30 end
    gap = 1.5
    res = vg.join_vessels(V, a.F, far, b.V, b.F, top_b, place=gap)
    M = res.placement
    ring = np.asarray(ends_a[far].loop)
    moved = V[ring] @ M[:3, :3].T + M[:3, 3]
    assert np.allclose(moved.mean(axis=0), [0.0, 0.0, 20.0 + gap], atol=1e-6)  # on the other's axis, gap ahead
    assert np.allclose(moved[:, 2], 20.0 + gap, atol=1e-6)  # the ring in the plane facing the other end
    held = np.asarray(ends_a[1 - far].loop)
    assert np.allclose((V[held] @ M[:3, :3].T + M[:3, 3])[:, 2], 20.0 + gap + 30.0, atol=1e-6)  # pointing away
    free = 30.0 * (1.0 - vg.tolerances.JOIN_HOLD_FRACTION)
    assert res.axial_stretch == pytest.approx((free + gap) / free, rel=0.02)
    assert res.max_bend < 0.02 and abs(np.degrees(res.profile.total_twist)) < 0.2
    assert np.allclose(res.V[res.moving].mean(axis=0), [0.0, 0.0, 20.0], atol=0.05)  # it reached the other end


@pytest.mark.parametrize("gap, ok", [(0.0, True), (-0.01, False), (np.nan, False)])
def test_the_placement_gap_at_its_edge(coronary, capped_placed, gap, ok):
    """A gap of zero or more is a placement (zero: the ends touch, the free part keeps its length); a negative
    one would push the moving end into the other vessel and is refused, as is a gap that is no number."""
    from vesselgp.errors import OptionError

    V, F, ends, L = coronary
    Vc, Fc = capped_placed[:2]
    k = 1  # the capped artery's end the fixture placed
    if ok:
        res = vg.join_vessels(V, F, 0, Vc, Fc, k, place=gap)
        assert res.axial_stretch == pytest.approx(1.0, abs=0.02)
    else:
        with pytest.raises(OptionError, match="is not a gap between the two ends; give zero or more"):
            vg.join_vessels(V, F, 0, Vc, Fc, k, place=gap)


@pytest.mark.parametrize("moving, end, other", [
    ("xra_coronary_single_branch_open.stl", 0, "dfemtoolz_artery_segment_lumen_capped.stl"),
    ("dfemtoolz_artery_segment_lumen_capped.stl", 0, "gmsh_abdominal-aorta-renal-iliac_open.stl"),
    ("vmtk_abdominal_aorta_iliac_bifurcation_open.stl", 1, "gmsh_aortic-arch_open.stl"),
])
def test_real_vessels_in_their_own_coordinates_join_once_placed(moving, end, other):
    """Pairs of real meshes sit in unrelated coordinates: as they are, the join is refused for stretch (2.5-3.9x);
    placed 1 mm apart (the other end: the one nearest in radius), it runs, stretches the free part a few per cent
    at most, bends it gently and twists it by under a degree, with no wiggle next to the hold."""
    scale = 1000.0 if other.startswith("gmsh_aortic-arch") else 1.0  # that file is in metres
    V, F = vg.read_mesh(REAL / moving)[:2]
    Vo, Fo = vg.read_mesh(REAL / other)[:2]
    Vo = Vo * scale
    eo = vg.vessel_ends(Vo, Fo)
    k = int(np.argmin([abs(e.radius - vg.vessel_ends(V, F)[end].radius) for e in eo]))
    with pytest.raises(ImplausibleJoinError, match=r"stretched .*or place the vessel facing the other end first "
                                                   r"\(place=GAP"):
        vg.VesselJoin(V, F, end, Vo, Fo, k)
    res = vg.join_vessels(V, F, end, Vo, Fo, k, place=1.0)
    assert 1.0 <= res.axial_stretch < 1.1 and res.max_bend < 0.6
    assert abs(np.degrees(res.profile.total_twist)) < 1.0
    near_hold = res.profile.s < 0.3
    assert np.ptp(np.degrees(res.profile.alpha[near_hold])) < 0.5


def test_cli_place(tmp_path, capsys):
    """`vesselgp join A --end 0 --onto B --other-end 1 --place 1`: the two real files (ends of radius 1.45 and 1.40), in their own coordinates,
    are joined; result.json says how far the vessel was moved and turned (checked against the two files' end
    centres: the moved end lands 1 mm in front of the other end); a negative gap is a one-line error naming --place."""
    out = tmp_path / "placed"
    capsys.readouterr()
    # the case: the coronary onto an iliac of the Y, 3.01 times wider, is refused naming the ratio
    assert main(["join", str(CORONARY), "--end", "0", "--onto", str(Y), "--other-end", "2", "--place", "1",
                 "-o", str(tmp_path / "wide"), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "radii differ 3.01x" in err and "--max-radius-ratio 1.5" not in err
    assert "raise --max-radius-ratio" in err and not (tmp_path / "wide").exists()
    assert main(["join", str(CORONARY), "--end", "0", "--onto", str(CAPPED), "--other-end", "1", "--place", "1",
                 "-o", str(out), "-q", "--no-png", "--n-curve", "3"]) == 0
    r = json.loads((out / "result.json").read_text())
    V, F = vg.read_mesh(CORONARY)[:2]
    Vy, Fy = vg.read_mesh(CAPPED)[:2]
    e, eo = vg.vessel_ends(V, F)[0], vg.vessel_ends(Vy, Fy)[1]
    M = np.asarray(r["placement"]["matrix"])
    assert np.linalg.norm(M[:3, :3] @ e.center + M[:3, 3] - (eo.center + eo.direction)) < 0.05 * e.radius
    assert r["placement"]["moved_mm"] == pytest.approx(np.linalg.norm(eo.center + eo.direction - e.center), rel=0.02)
    # the least rotation of the end's direction onto minus the other's turns by the angle between them
    cos = -(e.direction @ eo.direction) / np.linalg.norm(e.direction) / np.linalg.norm(eo.direction)
    assert r["placement"]["turned_deg"] == pytest.approx(np.degrees(np.arccos(cos)), abs=0.01)
    assert r["axial_stretch"] < 1.1 and (out / "joined_optimum.ply").is_file()
    capsys.readouterr()
    assert main(["join", str(CORONARY), "--end", "0", "--onto", str(CAPPED), "--other-end", "1", "--place", "-1",
                 "-o", str(tmp_path / "neg"), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--place -1.0 is not a gap" in err and "\n" not in err and not (tmp_path / "neg").exists()


@pytest.mark.parametrize("ratio, refused", [(1.45, False), (1.55, True), (1 / 1.45, False), (1 / 1.55, True)])
def test_the_calibre_guard_at_its_edge(ratio, refused):
    """Issue #49: two straight tubes, the moving one of radius 2, the other of radius 2 x ratio, placed 1.5 apart:
    an end-to-end join needs similar calibres (tolerances.JOIN_MAX_RADIUS_RATIO = 1.5, either way round). 1.45
    is joined, 1.55 refused with the ratio and both radii in the message; raising max_radius_ratio joins it."""
    from vesselgp.synthetic import named_curve

    a = synthetic_vessel(named_curve("straight", length=30.0), radius=2.0, n_around=32, ends="open")
    b = synthetic_vessel(named_curve("straight", length=20.0), radius=2.0 * ratio, n_around=32, ends="open")
    want = max(ratio, 1 / ratio)
    if not refused:
        join = vg.VesselJoin(a.V, a.F, 1, b.V, b.F, 1, place=1.5)
        got = join.other.radius / join.ends[join.end].radius
        assert max(got, 1 / got) == pytest.approx(want, rel=0.01)
        return
    rm, ro = 2.0, 2.0 * ratio
    with pytest.raises(ImplausibleJoinError, match=rf"the ends' radii differ {want:.2f}x \(the moving end {rm:.3g}, "
                                                   rf"the other end {ro:.3g}; at most max_radius_ratio = 1\.5\)"):
        vg.VesselJoin(a.V, a.F, 1, b.V, b.F, 1, place=1.5)
    vg.VesselJoin(a.V, a.F, 1, b.V, b.F, 1, place=1.5, max_radius_ratio=1.6)


@pytest.mark.parametrize("limit, ok", [(1.0, True), (0.99, False), (np.nan, False)])
def test_the_radius_ratio_option_at_its_edge(limit, ok):
    """max_radius_ratio is a ratio of the larger radius over the smaller: 1 (equal radii only) is an option,
    below 1 or no number is refused as one. Two tubes of radius 2 (their ends' radii equal to round-off)."""
    from vesselgp.synthetic import named_curve

    a = synthetic_vessel(named_curve("straight", length=30.0), radius=2.0, n_around=32, ends="open", remesh=False)
    b = synthetic_vessel(named_curve("straight", length=20.0), radius=2.0, n_around=32, ends="open", remesh=False)
    if ok:
        vg.VesselJoin(a.V, a.F, 1, b.V, b.F, 1, place=1.5, max_radius_ratio=limit * (1 + 1e-9))
    else:
        with pytest.raises(ImplausibleJoinError, match="max_radius_ratio must be at least 1"):
            vg.VesselJoin(a.V, a.F, 1, b.V, b.F, 1, place=1.5, max_radius_ratio=limit)


def test_a_placed_join_refused_for_stretch_does_not_ask_for_a_placement():
    """Placed 10 in front of the other end, the free 27 of a 30-long tube must stretch (27 + 10) / 27 = 1.37x,
    past max_stretch 1.3: refused, and the message names the stretch but not place= (it was given)."""
    from vesselgp.synthetic import named_curve

    a = synthetic_vessel(named_curve("straight", length=30.0), radius=2.0, n_around=32, ends="open")
    b = synthetic_vessel(named_curve("straight", length=20.0), radius=2.0, n_around=32, ends="open")
    with pytest.raises(ImplausibleJoinError, match=r"stretched 1\.3[67]x") as ei:
        vg.VesselJoin(a.V, a.F, 1, b.V, b.F, 1, place=10.0)
    assert "place=" not in str(ei.value)
