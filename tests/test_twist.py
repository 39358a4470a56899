"""Twist between two scans with side branches as landmarks (issue 15): twist_between, twist_pair, the CLI.

The truth comes from the generator (vesselgp.synthetic_scans): the imposed material
twist alpha at each side branch's junction, placed with an RMF integrated by scipy's
ODE solver along the exact Bezier tangents (not vesselgp's RMF). Each scan is meshed
independently by marching cubes at its own voxel and scan B is moved rigidly.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import vesselgp as vg
from vesselgp.cli import main
from vesselgp.errors import EndsError
from vesselgp.synthetic import synthetic_vessel, twist_pair
from _docs import figure, table

SEG_TOL_DEG = 2.0  # the target, per segment and for the total

#: docs/accuracy.md, twist table: worst segment error and total error (degrees) of each pair, asserted within
#: 1.5x (totals under 0.1 degree within 0.1: a rounding's worth); the pairs by their rows there
_TWIST = table("accuracy.md", "pair", "worst segment error (deg)", "total error (deg)")
DOCS_TWIST = {name: (figure(_TWIST[row][0]), figure(_TWIST[row][1])) for name, row in {
    "4 branches, 60 deg, 13 % shorter": "4 branches, 60 deg, 13 % shorter",
    "3 branches, -80 deg, 10 % shorter": "3 branches, -80 deg, 10 % shorter",
    "5 branches, 120 deg, 15 % shorter": "5 branches, 120 deg, 15 % shorter",
    "4 branches, non-uniform twist": "4 branches, non-uniform twist",
    "6 branches, gentle vs strong bends": "6 branches, 45 deg, bends 10 and 40 deg"}.items()}

PAIRS = {
    "3 branches, -80 deg, 10 % shorter": dict(n_branches=3, twist_deg=-80.0, stretch=0.9, seed=5),
    "5 branches, 120 deg, 15 % shorter": dict(n_branches=5, twist_deg=120.0, stretch=0.85, seed=6, length=140.0),
    "4 branches, non-uniform twist": dict(n_branches=4, twist=lambda s: 0.02 * s + 0.6 * np.sin(s / 20.0),
                                          stretch=0.88, seed=7),
    "6 branches, gentle vs strong bends": dict(n_branches=6, twist_deg=45.0, stretch=0.86, seed=8, length=160.0,
                                               bend_deg=(10.0, 40.0)),
}


@pytest.fixture(scope="module")
def pairs():
    cache = {}

    def get(name):
        if name not in cache:
            p = twist_pair(**PAIRS[name]) if name in PAIRS else twist_pair(4, seed=1)
            cache[name] = (p, vg.twist_between(p.a.V, p.a.F, p.V_b, p.b.F))
        return cache[name]

    return get


@pytest.mark.parametrize("name", list(DOCS_TWIST))
def test_segment_twists_match_the_imposed_twist(pairs, name):
    p, r = pairs(name)
    k = len(p.s_a)
    assert len(r.s_a) == k and len(r.unmatched_a) == 0 and len(r.unmatched_b) == 0  # every landmark matched
    err = np.degrees(r.segment_twist - p.segment_twist)
    seg, total = DOCS_TWIST[name]
    assert np.all(np.abs(err) <= min(1.5 * seg, SEG_TOL_DEG)), err
    assert abs(np.degrees(r.total_twist - p.total_twist)) <= min(max(1.5 * abs(total), 0.1), SEG_TOL_DEG)
    # landmarks where the true junctions are (at the ostium: two main radii along a side branch leaving at
    # 75 degrees lie about half a main radius downstream), arc lengths and stretch as built
    assert np.all(np.abs(r.s_a - p.s_a) < 3.0)
    assert np.allclose(r.stretch, p.stretch, atol=0.04)
    assert np.allclose(r.twist_per_length, r.segment_twist / r.segment_length_a)
    # scan B's junction points are the true ones moved by the rigid motion
    true_b = np.array([p.b.truth.branches[p.b.truth.branches[c].parent].control[3] for c in
                       [i for i, b in enumerate(p.b.truth.branches) if i > 0 and b.radius_start < 2.0]])
    true_b = true_b @ p.rotation.T + p.translation
    d = np.linalg.norm(r.landmarks_b[:, None] - true_b[None], axis=2).min(axis=1)
    assert np.all(d < 0.5 * 3.0)


def test_rigid_motion_vertex_order_and_swap(pairs):
    """Rotating scan A, shuffling scan B's vertices, or swapping the scans (twist negated) changes nothing."""
    p, r = pairs("default")
    rng = np.random.default_rng(3)
    R = Rotation.from_rotvec([0.3, -1.1, 0.7]).as_matrix()
    perm = rng.permutation(len(p.V_b))
    inv = np.argsort(perm)
    Vb, Fb = p.V_b[perm], inv[p.b.F]
    r2 = vg.twist_between(p.a.V @ R.T + [5.0, -7.0, 2.0], p.a.F, Vb, Fb)
    assert np.allclose(np.degrees(r2.segment_twist), np.degrees(r.segment_twist), atol=0.3)
    r3 = vg.twist_between(p.V_b, p.b.F, p.a.V, p.a.F)
    assert np.allclose(np.degrees(r3.segment_twist), -np.degrees(r.segment_twist), atol=0.5)
    assert np.allclose(r3.stretch, 1.0 / r.stretch, rtol=0.02)


def test_direction_is_decided_by_the_landmarks(pairs):
    """Scan A given from its tip: scan B (default ends, widest first) is turned round by the landmarks;
    the segment twists come in reverse order with the same values (twist is chiral, not directed)."""
    p, r = pairs("default")
    ea = r.ends_a
    rr = vg.twist_between(p.a.V, p.a.F, p.V_b, p.b.F, ends_a=(ea[1], ea[0]))
    assert rr.ends_b == (r.ends_b[1], r.ends_b[0])
    # measured 0.61 degrees apart since junctions are held within half an inscribed radius (issue #34;
    # 0.36 before): the reversed run moved towards the truth (worst 0.79 against 1.23 degrees off)
    assert np.allclose(np.degrees(rr.segment_twist), np.degrees(r.segment_twist[::-1]), atol=0.9)
    want = np.degrees(np.diff(p.alpha))[::-1]
    assert np.all(np.abs(np.degrees(rr.segment_twist) - want) <= SEG_TOL_DEG)


def test_density_does_not_change_the_result():
    """The same two states meshed at other voxels: the same twists (to the method's accuracy)."""
    p1 = twist_pair(4, seed=1)
    p2 = twist_pair(4, seed=1, voxel=(0.34, 0.38))
    assert len(p2.a.V) > 1.3 * len(p1.a.V)
    r1 = vg.twist_between(p1.a.V, p1.a.F, p1.V_b, p1.b.F)
    r2 = vg.twist_between(p2.a.V, p2.a.F, p2.V_b, p2.b.F)
    assert np.allclose(np.degrees(r1.segment_twist), np.degrees(r2.segment_twist), atol=1.5)
    assert np.all(np.abs(np.degrees(r2.segment_twist - p2.segment_twist)) <= SEG_TOL_DEG)


def test_a_side_branch_missing_in_one_scan_is_reported(caplog):
    """Scan B lacks side branch 1: it is reported unmatched and the segment across it has both twists."""
    p = twist_pair(4, seed=1, drop_b=(1,))
    with caplog.at_level("WARNING", logger="vesselgp.twist"):
        r = vg.twist_between(p.a.V, p.a.F, p.V_b, p.b.F)
    assert len(r.s_a) == 3 and len(r.unmatched_a) == 1 and len(r.unmatched_b) == 0
    assert abs(r.unmatched_a[0] - p.s_a[1]) < 3.0  # at its ostium, within a main radius of the junction
    assert any("unmatched" in rec.getMessage() for rec in caplog.records)
    want = np.array([p.alpha[2] - p.alpha[0], p.alpha[3] - p.alpha[2]])
    assert np.all(np.abs(np.degrees(r.segment_twist - want)) <= SEG_TOL_DEG)


def test_no_side_branch_is_refused():
    v = synthetic_vessel("arc", n_around=24)
    with pytest.raises(EndsError, match="no side branch"):
        vg.twist_between(v.V, v.F, v.V, v.F)


def test_cli_twist(tmp_path, pairs, capsys):
    p, r = pairs("default")
    a, b = tmp_path / "a.ply", tmp_path / "b.ply"
    vg.write_mesh(a, p.a.V, p.a.F)
    vg.write_mesh(b, p.V_b, p.b.F)
    out = tmp_path / "tw"
    assert main(["twist", str(a), str(b), "-o", str(out), "-q"]) == 0
    d = json.loads((out / "twist.json").read_text())
    assert np.allclose(d["segment_twist_deg"], np.degrees(r.segment_twist), atol=1e-6)
    assert abs(d["total_twist_deg"] - np.degrees(p.total_twist)) <= SEG_TOL_DEG
    rows = (out / "twist.csv").read_text().strip().splitlines()
    assert len(rows) == 1 + len(p.segment_twist) and "twist_deg_per_cm" in rows[0]
    # the uncertainty in every output: the truth inside each stated interval, the same numbers everywhere
    err = np.abs(np.asarray(d["segment_twist_deg"]) - np.degrees(p.segment_twist))
    assert np.all(err <= np.asarray(d["segment_uncertainty_deg"])) and not any(d["unreliable"])
    assert np.allclose(d["segment_uncertainty_deg"], np.degrees(r.segment_uncertainty))
    head = rows[0].split(",")
    csv_unc = [float(x.split(",")[head.index("uncertainty_deg")]) for x in rows[1:]]
    assert np.allclose(csv_unc, d["segment_uncertainty_deg"], atol=1e-6)
    assert len(d["landmark_uncertainty_a_deg"]) == len(d["s_a"]) and d["main_axis_a"] == "single fit"
    assert np.isclose(d["cumulative_uncertainty_deg"][0], 0.0)
    assert (out / "twist_scans.png").stat().st_size > 10_000 and (out / "twist_profile.png").exists()
    assert sorted(x.name for x in out.iterdir()) == ["report.html", "twist.csv", "twist.json", "twist_profile.png",
                                                       "twist_scans.png"]
    # the report's shading: scan A's vertices past the last side branch carry the whole imposed twist, those
    # before the first none (the truth's, not the run's numbers)
    from vesselgp.commands.twist import scan_twist_field

    field = scan_twist_field(r, p.a.V, np.degrees(np.r_[0.0, np.cumsum(r.segment_twist)]))
    root_end = p.a.truth.ends[0].center  # the main vessel's root; its tip is the end farthest from it
    tip_end = max((e.center for e in p.a.truth.ends), key=lambda c: np.linalg.norm(c - root_end))
    tip, root = (np.linalg.norm(p.a.V - c, axis=1) < 10.0 for c in (tip_end, root_end))  # past the last, before the first
    assert abs(np.median(field[tip]) - np.degrees(p.total_twist)) <= SEG_TOL_DEG and abs(np.median(field[root])) < 1e-9
    page = (out / "report.html").read_text()
    assert "cumulative twist (deg)" in page and "landmark 1" in page and page.count("<img alt=") == 2
    # the report states each segment's interval, as twist.json has it
    assert "segment_uncertainty_deg" in page
    for t, u in zip(d["segment_twist_deg"], d["segment_uncertainty_deg"]):
        assert f"{t:+.1f} \u00b1 {u:.1f}" in page
    tube = tmp_path / "tube.ply"
    v = synthetic_vessel("arc", n_around=24)
    vg.write_mesh(tube, v.V, v.F)
    capsys.readouterr()
    assert main(["twist", str(tube), str(b), "-o", str(tmp_path / "none")]) == 2
    assert not (tmp_path / "none").exists()
    assert "side branch" in capsys.readouterr().err


@pytest.mark.parametrize("name", list(PAIRS))
def test_every_side_tip_is_found(pairs, name):
    """vessel_ends finds the root, the main tip and every side branch's rounded tip of both scans
    (side branches leave at 75 degrees: the farthest point of a dome lies off its pole, so the tip
    test is retried from the pole)."""
    p, _ = pairs(name)
    for V, F, truth in ((p.a.V, p.a.F, p.a.truth), (p.V_b, p.b.F, p.b.truth)):
        assert len(vg.vessel_ends(V, F)) == len(truth.ends) == len(p.s_a) + 2


def test_branches_leaving_together_are_the_same_landmark_in_both_scans():
    """Two renal arteries at one level (the renal-iliac twist case, issue #48's note): scan A merged branch 3 into
    branch 1's landmark and kept branch 4 alone, scan B merged branches 4 and 3 and kept the wider, 4 -- the other
    artery (radii 2.67 against 2.48). A segment then read 136 degrees off with a 6-degree interval. The matched
    pair must be made of the members most alike in position, radius and length: B's branch 3 (75.4 long, as A's
    branch 4 is 74.9), with its own azimuth; a pair with no choice is left alone; a branch is used once."""
    from vesselgp.twist import Landmarks, _agree_members

    def member(s, r, length, branch, az):
        return dict(s=s, point=np.array([0.0, 0.0, s]), azimuth=az, direction=np.array([1.0, 0.0, 0.0]),
                    radius=r, branch=branch, angle=1.2, divides=False, uncertainty=0.1, length=length)

    def landmarks(groups, kept):
        rows = [g[k] for g, k in zip(groups, kept)]
        col = {key: np.array([r[key] for r in rows]) for key in rows[0]}
        return Landmarks(tree=None, ends=(0, 1), main=None, length=300.0, points=col["point"], s=col["s"],
                         azimuth=col["azimuth"], direction=col["direction"], radius=col["radius"],
                         branch=col["branch"], angle=col["angle"], divides=col["divides"],
                         uncertainty=col["uncertainty"], main_axis="single fit", leaves=np.zeros(0),
                         members=tuple(tuple(g) for g in groups))

    A = landmarks([[member(48.6, 3.13, 83.3, 1, 0.5), member(53.6, 2.69, 52.9, 3, 2.9)],
                   [member(55.5, 2.53, 74.9, 4, -0.4)], [member(160.0, 6.33, 203.1, 7, 1.0)]], [0, 0, 0])
    B = landmarks([[member(48.4, 3.11, 83.7, 1, 0.6), member(47.8, 2.49, 53.5, 2, -2.0)],
                   [member(53.7, 2.67, 53.8, 4, 3.0), member(54.2, 2.48, 75.4, 3, -0.3)],
                   [member(160.0, 6.32, 203.0, 7, 1.1)]], [0, 0, 0])
    ia = ib = np.arange(3)
    A2, B2 = _agree_members(A, B, ia, ib)
    assert A2.branch.tolist() == [1, 4, 7] and B2.branch.tolist() == [1, 3, 7]
    assert B2.azimuth[1] == -0.3 and B2.s[1] == 54.2 and B2.radius[1] == 2.48  # the member's own values
    assert A2.azimuth.tolist() == A.azimuth.tolist() and B2.azimuth[[0, 2]].tolist() == [0.6, 1.1]
    # the member another pair took is not taken twice: A's landmark 1 offers branch 1 (the very image of B's
    # branch 4, but landmark 0 took it) and branch 3
    A3 = landmarks([[member(48.6, 3.13, 83.3, 1, 0.5)], [member(53.7, 2.67, 53.8, 1, 0.5),
                                                          member(55.0, 3.0, 70.0, 3, 2.9)]], [0, 0])
    B3 = landmarks([[member(48.4, 3.11, 83.7, 1, 0.6)], [member(53.7, 2.67, 53.8, 4, 3.0)]], [0, 0])
    A4, B4 = _agree_members(A3, B3, np.arange(2), np.arange(2))
    assert A4.branch.tolist() == [1, 3] and B4.branch.tolist() == [1, 4]
    # seen from the other end, a member's s and azimuth turn with its landmark's
    F = A.flipped()
    assert F.members[0][0]["s"] == 300.0 - 160.0 and F.members[-1][1]["azimuth"] == -2.9
