"""Twist between two scans on real trees, against exact truth (issue #45).

Scan A is a real tree of ``shared/data/real``; scan B is a copy twisted by a known
``alpha(s)`` about VMTK's centre line of its main vessel (side subtrees turned rigidly by
``alpha`` at their junctions), remeshed by pymeshlab and moved rigidly
(``data_gen/real_twist.py``): the truth comes from VMTK's lines, never from vesselgp's fit.
A measured landmark's truth is the twist of the subtree its side branch's vertices lie in.

Each segment must be within 2 degrees of the truth or within 2 degrees plus its stated 95 %
half-width (the issue's bound); over all cases the truth lies inside the stated interval for
at least 90 % of segments. The wider sweep (9 cases) is ``scripts/twist_real.py``.
"""
from __future__ import annotations

import numpy as np
import pytest

import vesselgp as vg
from vesselgp import tolerances as tol
from vesselgp.errors import EndsError
from vesselgp.rotations import wrap_angle
from vesselgp.twist import _segment_uncertainty
from _data import REAL, needs_real, real_twist
from _docs import figure, table

XCAT = "xrayangio_xcat-coronary-tree_open.stl"
RENAL = "gmsh_abdominal-aorta-renal-iliac_open.stl"
ARCH = "cardiopinns_aortic-arch-4dflow_capped.stl"
GMSH_ARCH = "gmsh_aortic-arch_open.stl"

pytestmark = needs_real(XCAT, RENAL, ARCH, GMSH_ARCH)

#: (mesh, VMTK line of the main vessel, profile, total degrees): a coronary whose main vessel the single fit cannot
#: follow (tree path), with 7 side branches at 18-77 degrees; an aorta with visceral branches and the iliac
#: bifurcation (comparable daughters) as its last landmark; an arch with three supra-aortic branches
CASES = {"XCAT coronary, linear 40 deg": (XCAT, 1, "linear", 40.0),
         "renal-iliac aorta, sine -30 deg": (RENAL, 0, "sine", -30.0),
         "capped arch, linear 30 deg": (ARCH, 0, "linear", 30.0)}

#: docs/accuracy.md, real twist table: worst error and the largest stated half-width (degrees) of each case
_DOCS = table("accuracy.md", "real tree, main vessel, profile", "segments", "worst error (deg)",
              "stated 95 % half-width (deg)")
DOCS = {label: (figure(_DOCS[row][1]), float(_DOCS[row][2].split("-")[-1])) for label, row in {
    "XCAT coronary, linear 40 deg": "XCAT coronary (VMTK line 1, 7 side branches at 18-77 deg; tree path in scan A), "
                                    "linear 40 deg",
    "renal-iliac aorta, sine -30 deg": "renal-iliac aorta (visceral branches, then the iliac bifurcation), sine -30 deg",
    "capped arch, linear 30 deg": "capped arch (three supra-aortic branches, two leaving together), linear 30 deg",
}.items()}


def measured_against_truth(case):
    """twist_between on the case with the main vessel's ends given; (result, truth per segment in radians)."""
    near = lambda ends, p: int(np.argmin([np.linalg.norm(e.center - p) for e in ends]))  # noqa: E731
    ea, eb = vg.vessel_ends(case.V_a, case.F_a), vg.vessel_ends(case.V_b, case.F_b)
    moved = lambda p: p @ case.rotation.T + case.translation  # noqa: E731
    r = vg.twist_between(case.V_a, case.F_a, case.V_b, case.F_b,
                         ends_a=(near(ea, case.source), near(ea, case.target)),
                         ends_b=(near(eb, moved(case.source)), near(eb, moved(case.target))))
    truth = []
    for c in r.side_a:  # the subtree most of the side branch's vertices lie in
        lab = case.labels[r.tree_a.vertex_branch == c]
        lab = lab[lab >= 0]
        assert len(lab) and np.mean(lab == np.bincount(lab).argmax()) > 0.8
        truth.append(case.junctions[np.bincount(lab).argmax()].alpha)
    return r, np.diff(truth)


@pytest.fixture(scope="module")
def runs():
    rt = real_twist()
    out = {}
    for k, (name, line, kind, total) in enumerate(CASES.values()):
        L = rt.arc_length(rt.load_tree(name)[2][line][0])[-1]
        case = rt.twisted_copy(name, line, rt.alpha_profile(kind, total, 0.0, L), seed=k)
        out[list(CASES)[k]] = (case, *measured_against_truth(case))
    return out


@pytest.mark.parametrize("label", list(CASES))
def test_segments_within_two_degrees_plus_their_uncertainty(runs, label):
    case, r, truth = runs[label]
    assert len(r.unmatched_a) == 0 and len(r.unmatched_b) == 0 and len(r.segment_twist) >= 1
    err = np.degrees(np.abs(wrap_angle(r.segment_twist - truth)))
    unc = np.degrees(r.segment_uncertainty)
    assert np.all(err <= 2.0 + unc), (err, unc)
    assert np.all((err <= 2.0) | (err <= unc)), (err, unc)  # each precise (2 degrees) or honest (its interval)
    assert np.all(np.isfinite(unc)) and np.all(unc > 0)
    worst, widest = DOCS[label]  # the figures docs/accuracy.md states, within 1.5x
    assert err.max() <= 1.5 * worst and widest / 1.5 <= unc.max() <= 1.5 * widest
    # the twist from landmark 1 to every landmark, the same bound with its cumulative interval
    cum_err = np.degrees(np.abs(np.cumsum(wrap_angle(r.segment_twist - truth))))
    assert np.all(cum_err <= 2.0 + np.degrees(r.cumulative_uncertainty[1:]))


def test_the_stated_interval_holds_the_truth_for_nine_segments_in_ten(runs):
    err, unc = (np.concatenate(x) for x in zip(*[(np.degrees(np.abs(wrap_angle(r.segment_twist - t))),
                                                   np.degrees(r.segment_uncertainty)) for _, r, t in runs.values()]))
    assert np.mean(err <= unc) >= 0.9, (err, unc)
    # and the intervals say something: the median half-width is a few degrees (docs/accuracy.md)
    assert np.median(unc) <= 4.0


def test_the_main_vessel_is_told_how_it_was_followed(runs):
    """The XCAT coronary's main vessel is refused by the single fit in scan A (the issue's table): its axis is
    the tree's path, said in the result; the aorta and the arch have their single fits. The iliac bifurcation at
    the aorta's end is said to divide into comparable daughters; the arch's supra-aortic branches are not."""
    _, r, _ = runs["XCAT coronary, linear 40 deg"]
    assert "tree path" in (r.main_axis_a, r.main_axis_b)
    _, r, _ = runs["renal-iliac aorta, sine -30 deg"]
    assert r.main_axis_a == r.main_axis_b == "single fit"
    assert r.divides_a[-1] and not r.divides_a[0]
    assert r.segment_uncertainty[-1] > r.segment_uncertainty[0]  # the division is less sure
    _, r, _ = runs["capped arch, linear 30 deg"]
    assert not np.any(r.divides_a) and r.main_axis_a == "single fit"


@pytest.mark.parametrize("name", [XCAT, RENAL, ARCH, GMSH_ARCH])
def test_default_ends_run_on_every_real_tree_with_three_side_branches(name):
    """The real trees with at least three side branches run with the default ends: from the widest end to the
    tip with the most landmarks; the scan against itself gives zero twist inside its intervals."""
    V, F = vg.read_mesh(REAL / name)[:2]
    V = V * (1000.0 if name == GMSH_ARCH else 1.0)  # stored in metres
    r = vg.twist_between(V, F, V, F)
    assert len(r.s_a) >= 2 and r.ends_a == r.ends_b
    ends = vg.vessel_ends(V, F)
    assert r.ends_a[0] == int(np.argmax([e.radius for e in ends]))
    assert np.allclose(r.segment_twist, 0.0, atol=1e-9)
    # every branch off the main vessel, however deep, leaves it where its subtree's junction with it lies: between
    # one main radius before that junction's place and TWIST_DIR_START + 1 radii past it (the ostium); NaN on it
    t = r.tree_a
    k = next(q for q, p in enumerate(t.paths) if p.ends[1] == r.ends_a[1])
    main, on = t.paths[k], set(t.path_branches[k])
    assert np.all(np.isnan(r.leaves_a[list(on)]))
    for c in set(range(len(t.branches))) - on:
        a = c
        while int(t.parent[a]) not in on:
            a = int(t.parent[a])
        J = t.junctions[int(np.flatnonzero(t.junction_branch == t.parent[a])[0])]
        i = int(np.argmin(np.linalg.norm(main.dense_points - J, axis=1)))
        s_j, r_j = main.dense_s[i] * r.length_a, float(main.radius_at([main.dense_s[i]])[0])
        assert s_j - r_j <= r.leaves_a[c] <= s_j + (tol.TWIST_DIR_START + 1.0) * r_j, (c, a, s_j, r.leaves_a[c])
        assert r.leaves_a[c] == r.leaves_a[a]


def test_a_main_vessel_with_too_few_landmarks_names_the_ones_that_work():
    """Given a main vessel with one side branch (the capped arch's root to its first supra-aortic branch), the
    refusal lists every main vessel from that root with its landmarks, the most first."""
    V, F = vg.read_mesh(REAL / ARCH)[:2]
    ends = vg.vessel_ends(V, F)
    root = int(np.argmax([e.radius for e in ends]))
    tips = [j for j in range(len(ends)) if j != root]
    msg = None
    for j in sorted(tips, key=lambda j: np.linalg.norm(ends[j].center - ends[root].center)):
        try:
            vg.twist_between(V, F, V, F, ends_a=(root, j), ends_b=(root, j))
        except EndsError as exc:
            msg = str(exc)
            break
    assert msg is not None, "every main vessel of the capped arch has two landmarks"
    assert "main vessels from end" in msg and "ends_a=" in msg and "scan A" in msg
    parts = msg.split(f"({root}, ")[1:]
    assert sorted(int(x.split(")")[0]) for x in parts) == sorted(tips)  # every candidate named
    counts = [int(x.split(": ")[1].split(",")[0].split(" ")[0]) for x in parts]
    assert counts[0] >= 2 and counts == sorted(counts, reverse=True)


@pytest.mark.parametrize("factor", [0.99, 1.01])
def test_unreliable_at_its_edge(factor):
    """Four equal landmark sigmas x give a half-width of TWIST_Z95 * 2 x: a segment is unreliable just above
    TWIST_UNRELIABLE_DEG, not just below."""
    x = factor * np.radians(tol.TWIST_UNRELIABLE_DEG) / (2 * tol.TWIST_Z95)
    s = np.full(3, x * tol.TWIST_Z95)  # half-widths of the landmarks
    useg, ucum, bad = _segment_uncertainty(s, s, np.ones(3), np.ones(3), 0)
    assert np.allclose(np.degrees(useg), factor * tol.TWIST_UNRELIABLE_DEG)
    assert np.all(bad == (factor > 1))
    assert np.allclose(ucum, [0.0, useg[0], useg[0]])


@pytest.mark.parametrize("ratio,widens", [(np.exp(tol.TWIST_RADIUS_AGREE) * 0.99, False),
                                          (np.exp(tol.TWIST_RADIUS_AGREE) * 1.01, True)])
def test_a_pair_of_unequal_side_branches_widens_its_interval_at_the_edge(ratio, widens):
    s = np.full(2, 0.01)
    base, _, _ = _segment_uncertainty(s, s, np.ones(2), np.ones(2), 0)
    useg, _, _ = _segment_uncertainty(s, s, np.array([1.0, ratio]), np.ones(2), 0)
    assert (useg[0] > base[0] * (1 + 1e-9)) == widens
    # the tree path's own RMF error adds per scan and per segment
    path, _, _ = _segment_uncertainty(s, s, np.ones(2), np.ones(2), 2)
    assert np.isclose(path[0] ** 2, base[0] ** 2 + 2 * (tol.TWIST_Z95 * tol.TWIST_SIGMA_TREE_PATH) ** 2)


@pytest.mark.parametrize("factor,crowded", [(0.99, True), (1.01, False)])
def test_ostia_crowd_each_other_within_the_chord_at_its_edge(factor, crowded):
    """Two ostia TWIST_MAIN_CHORD main radii apart (times 0.99 or 1.01) crowd each other or not; a third far
    away never."""
    from vesselgp.twist import _crowded

    r = np.array([2.0, 2.0, 2.0])
    s = np.array([10.0, 10.0 + factor * tol.TWIST_MAIN_CHORD * 2.0, 60.0])
    assert list(_crowded(s, r)) == [crowded, crowded, False]


def test_the_tree_path_axis_is_a_helix_rmf_where_the_path_is_a_helix():
    """PathAxis (the main axis where the single fit cannot follow) on a left-handed helix of radius 20 and pitch
    angle 27 degrees, radius 1: its points within 0.02 (0.1 % of the helix radius) of the helix, its length within
    0.1 %, and its U the exact RMF normal (closed form, tests/_reference.py) to 0.1 degree after the start."""
    from types import SimpleNamespace

    from _reference import helix, signed_angle
    from vesselgp.twist import PathAxis

    a, c = 20.0, -10.0  # left-handed
    t = np.linspace(0.0, 3.0, 801)
    P, T, U = helix(t, a, c)
    L = 3.0 * np.hypot(a, c)
    path = SimpleNamespace(dense_points=P, length=L, s=np.linspace(0, 1, 5), radii=np.ones(5),
                           dense_frames=np.stack([T, U, np.cross(T, U)], axis=1))
    ax = PathAxis.of(path)
    assert abs(ax.length - L) < 1e-3 * L
    inner = slice(40, -40)  # away from the ends (the average runs off them)
    X, fr = ax.at(np.linspace(0, 1, 801)[inner])
    Pi, Ti, Ui = P[inner], T[inner], U[inner]
    # the average over half a radius moves a helix point inwards by about kappa sigma^2 / 2: 0.1 % of the radius
    assert np.max(np.linalg.norm(X - Pi, axis=1)) < 0.02
    assert np.max(np.degrees(np.arccos(np.clip(np.sum(fr[:, 0] * Ti, axis=1), -1, 1)))) < 0.1
    turn = np.degrees(signed_angle(Ti, Ui, fr[:, 1]))
    assert np.ptp(turn) < 0.1  # the same RMF up to its starting normal


@pytest.mark.parametrize("factor,together", [(0.99, True), (1.01, False)])
def test_side_branches_leave_together_at_the_edge(factor, together):
    """Two ostia TWIST_SAME_PLACE main radii apart (times 0.99 or 1.01) are one landmark, the wider, or two."""
    from vesselgp.twist import _together

    rows = [dict(s=10.0, r_main=2.0, radius=0.5, branch=1),
            dict(s=10.0 + factor * tol.TWIST_SAME_PLACE * 2.0, r_main=2.0, radius=0.8, branch=2)]
    kept = _together(rows, quiet=True)
    assert [r["branch"] for r in kept] == ([2] if together else [1, 2])


@pytest.mark.parametrize("factor,divides", [(0.99, False), (1.01, True)])
def test_the_main_vessel_divides_at_the_edge(factor, divides):
    """A side branch TWIST_COMPARABLE times the main vessel past the junction (times 0.99 or 1.01)."""
    from vesselgp.twist import _divides

    assert _divides(factor * tol.TWIST_COMPARABLE * 3.0, 3.0) == divides


def test_side_branches_leaving_together_are_agreed_between_the_scans(runs, monkeypatch):
    """The renal-iliac case with scan B made to keep the narrower of the side branches leaving together (two renal
    arteries at one level, radii within 8 %): without settling the members between the scans, a segment read 136
    degrees off with a 6-degree interval (issue #48's note); with it, every segment stays within 2 degrees plus its
    interval, as without the perturbation."""
    import vesselgp.twist as tw

    case, r0, truth = runs["renal-iliac aorta, sine -30 deg"]
    together = tw._together
    calls = []

    changed = []

    def narrower_in_b(rows, quiet=False):
        kept = together(rows, quiet)
        if not quiet:
            calls.append(1)
        if len(calls) >= 2 and not quiet:  # scan B (scan A's landmarks are found first)
            out = []
            for k in kept:
                narrow = min(k["members"], key=lambda m: m["radius"])
                if len(k["members"]) > 1 and narrow["branch"] != k["branch"]:
                    changed.append(k["branch"])
                    k = dict(narrow, members=k["members"])
                out.append(k)
            kept = out
        return kept

    monkeypatch.setattr(tw, "_together", narrower_in_b)
    r, truth2 = measured_against_truth(case)
    assert len(calls) >= 2 and changed  # scan B did keep another branch of a group
    err = np.degrees(np.abs(wrap_angle(r.segment_twist - truth2)))
    assert np.all(err <= 2.0 + np.degrees(r.segment_uncertainty)), (err, np.degrees(r.segment_uncertainty))
