"""Branch decomposition of vessel trees against the exact synthetic trees (issue #13, first stage of the tree fit)."""
from __future__ import annotations

import numpy as np
import pytest

import vesselgp
from vesselgp.branches import branch_decomposition
from vesselgp.synthetic import THREE_TIP_PARENTS, synthetic_tree

from _data import REAL


def _truth_clades(truth):
    """Truth branch -> frozenset of the truth leaf branches below it."""
    par = [b.parent for b in truth.branches]
    kids = {k: [c for c, p in enumerate(par) if p == k] for k in range(len(par))}

    def leaves(k):
        return frozenset([k]) if not kids[k] else frozenset().union(*(leaves(c) for c in kids[k]))

    return {k: leaves(k) for k in range(len(par))}


@pytest.fixture(scope="module", params=["4 tips", "3 tips", "8 tips"])
def tree(request):
    kw = {"4 tips": dict(levels=2, voxel=0.5), "3 tips": dict(parents=THREE_TIP_PARENTS, voxel=0.5),
          "8 tips": dict(levels=3)}[request.param]
    t = synthetic_tree(**kw)
    ends = vesselgp.vessel_ends(t.V, t.F)
    return t, ends, branch_decomposition(t.V, t.F, ends)


def test_topology_is_the_true_tree(tree):
    t, ends, b = tree
    tc = np.array([e.center for e in t.truth.ends])
    to_truth = [t.truth.ends[int(np.argmin(np.linalg.norm(tc - e.center, axis=1)))] for e in ends]
    assert to_truth[b.root].kind == "open"  # the widest end is the cut root
    clades = _truth_clades(t.truth)
    inverse = {v: k for k, v in clades.items()}
    mapped = []
    for tips in b.tips:  # each branch's tips are exactly the leaves below one true branch
        leaves = frozenset(to_truth[j].branch for j in tips)
        assert leaves in inverse, (tips, leaves)
        mapped.append(inverse[leaves])
    assert sorted(mapped) == list(range(len(t.truth.branches)))  # one branch per true branch
    for k, p in enumerate(b.parent):  # and the same parents
        assert (p == -1) == (t.truth.branches[mapped[k]].parent == -1)
        if p >= 0:
            assert t.truth.branches[mapped[k]].parent == mapped[p]


def test_vertices_sit_on_their_true_branch(tree):
    """Away from junctions (2 r) and tips (1.5 r), at least 97 % of the vertices are on the branch
    whose true centre line is nearest (the surface about a junction goes to the parent by design)."""
    t, ends, b = tree
    tc = np.array([e.center for e in t.truth.ends])
    to_truth = [t.truth.ends[int(np.argmin(np.linalg.norm(tc - e.center, axis=1)))] for e in ends]
    inverse = {v: k for k, v in _truth_clades(t.truth).items()}
    mapped = np.array([inverse[frozenset(to_truth[j].branch for j in tips)] for tips in b.tips])
    nearest_branch = t.truth.nearest(t.V)[2]
    away = t.truth.interior_mask(t.V)
    agree = np.mean(mapped[b.vertex_branch][away] == nearest_branch[away])
    assert agree >= 0.97, agree
    # every branch holds vertices; every junction lies within a parent radius of a true one
    assert np.all(np.bincount(b.vertex_branch, minlength=len(b.parent)) > 0)
    J, R = t.truth.junctions
    for k in set(b.parent.tolist()) - {-1}:
        i = int(np.argmin(np.linalg.norm(J - b.junctions[k], axis=1)))
        assert np.linalg.norm(J[i] - b.junctions[k]) < R[i]


def test_real_y_splits_into_a_trunk_and_two_iliacs():
    V, F = vesselgp.read_mesh(REAL / "vmtk_abdominal_aorta_iliac_bifurcation_open.stl")
    ends = vesselgp.vessel_ends(V, F)
    b = branch_decomposition(V, F, ends)
    assert ends[b.root].radius > 7 and b.parent.tolist() == [-1, 0, 0]
    assert sorted(b.end_branch) == sorted(j for j in range(3) if j != b.root)
    # the iliac branches are the vertices below the bifurcation (long axis +y, iliacs at low y)
    for j, k in b.end_branch.items():
        yk = V[b.vertex_branch == k, 1]
        assert np.median(yk) < np.median(V[b.vertex_branch == 0, 1])


def test_needs_a_tree():
    ves = vesselgp.synthetic.synthetic_vessel("arc", n_around=16, remesh=False)
    with pytest.raises(vesselgp.EndsError, match="at least three ends"):
        branch_decomposition(ves.V, ves.F, vesselgp.vessel_ends(ves.V, ves.F))



def _cross_lines(d, h=0.01):
    """Centre lines (radius 1) of a trunk along x with three tips: A runs on along x to x = 20, B turns
    off in +y at x = 5 and C in +z at x = 5 + d (each a right-angle corner, sampled every h)."""
    from vesselgp.centerlines import Centerlines

    def corner(x0, axis):
        run = np.c_[np.arange(0.0, x0, h), np.zeros((int(round(x0 / h)), 2))]
        out = np.zeros((int(round(10.0 / h)), 3))
        out[:, 0] = x0
        out[:, axis] = np.arange(0.0, 10.0, h)
        return np.vstack([run, out])

    a = np.c_[np.arange(0.0, 20.0, h), np.zeros((int(round(20.0 / h)), 2))]
    pts = (a, corner(5.0, 1), corner(5.0 + d, 2))
    return Centerlines(root=0, tips=(1, 2, 3), points=pts, radius=tuple(np.ones(len(p)) for p in pts))


@pytest.mark.parametrize("d, merged", [(0.65, True), (0.75, False)])
def test_junctions_closer_than_one_radius_are_one_zone(d, merged):
    """TREE_JUNCTION_MERGE at its edge, from known geometry: the lines part TREE_MEET = 0.3 radii past
    each corner, so the branch between the two junctions is d + 0.3 long; below one inscribed radius
    (d < 0.7) the three tips hang off one junction, above it the tree has two."""
    from vesselgp import tolerances as tol
    from vesselgp.branches import _Topology

    assert tol.TREE_JUNCTION_MERGE == 1.0 and tol.TREE_MEET == 0.3
    topo = _Topology(_cross_lines(d), (1, 2, 3))
    assert (len(topo.kids[topo.top]) == 3) == merged


def test_a_child_starts_where_it_leaves_the_inscribed_spheres():
    """TREE_CHILD_CLEAR at its edge: a point just inside a sphere of radius 2 is covered, just outside is not."""
    from vesselgp import tolerances as tol
    from vesselgp.branches import _covered

    assert tol.TREE_CHILD_CLEAR == 1.0
    P = np.array([[1.99, 0, 0], [2.01, 0, 0], [0, 0.5, 0]])
    others = [(np.zeros((1, 3)), np.array([2.0])), (np.array([[10.0, 0, 0]]), np.array([0.1]))]
    assert _covered(P, others).tolist() == [True, False, True]


def test_each_vertex_is_measured_against_the_branches_within_reach_with_the_same_result_as_against_all():
    """Issue #47: a vertex is compared only with the branches whose line passes within TREE_ASSIGN_REACH of their
    widest inscribed radii (and with all of them when none does). On a wide trunk line, a thin line starting at
    its wall, a third line far off, and vertices near each and far from all, it gives the least ratio over ALL
    lines, computed here by brute force."""
    from vesselgp import tolerances as tol
    from vesselgp.branches import _vertex_branch

    s = np.linspace(0.0, 1.0, 60)[:, None]
    trunk = (np.array([0.0, 0, 0]) + s * [60.0, 0, 0], np.full(60, 6.0))
    thin = (np.array([30.0, 6.5, 0]) + s * [0.0, 20.0, 0], np.full(60, 0.8))
    far = (np.array([0.0, 80.0, 40.0]) + s * [0.0, 0, 30.0], np.full(60, 10.0))
    lines = [trunk[0], thin[0], far[0]]
    radius = [trunk[1], thin[1], far[1]]
    rng = np.random.default_rng(5)
    V = np.vstack([rng.uniform([-10, -10, -10], [70, 30, 10], (3000, 3)),   # about the trunk and the thin line
                   rng.uniform([-5, 75, 35], [5, 85, 75], (300, 3)),         # about the far line
                   rng.uniform([-250, 60, 40], [-150, 100, 70], (50, 3))])  # beyond every reach: the far line's
    ratio = np.stack([np.min(np.linalg.norm(V[:, None] - P[None], axis=2) / R[None], axis=1)
                      for P, R in zip(lines, radius)], axis=1)  # nearest line point (its radius) by brute force
    got = _vertex_branch(V, lines, radius)
    # the brute force takes every point of the lines; _vertex_branch resamples them: compare where the choice is clear
    top2 = np.sort(ratio, axis=1)[:, :2]
    clear = top2[:, 1] > 1.05 * top2[:, 0]
    assert np.array_equal(got[clear], np.argmin(ratio, axis=1)[clear])
    assert clear.mean() > 0.95
    assert np.all(got[-50:] == 2) and np.all(ratio[-50:].min(axis=1) > tol.TREE_ASSIGN_REACH)


@pytest.mark.parametrize("part_at", [10, 63, 64, 65, 200, 700, None])
def test_the_parting_of_two_lines_measured_in_pieces_is_the_parting_of_the_whole_lines(part_at):
    """Two lines of 800 samples together up to sample ``part_at`` (then one turns away; None: never), measured in
    growing pieces from the start: the junction index is the one the whole lines give (TREE_SPLIT, TREE_MEET
    applied to every sample's distance, here by brute force)."""
    from scipy.spatial import cKDTree

    from vesselgp import tolerances as tol
    from vesselgp.branches import _parting

    t = np.linspace(0.0, 80.0, 800)
    b = np.c_[t, 0 * t, 0 * t]
    k = len(t) if part_at is None else part_at
    a = b.copy()
    a[k:, 1] = 0.05 * (t[k:] - t[k - 1]) ** 2  # leaves b smoothly
    R = np.full(len(t), 1.0)
    d = np.array([np.min(np.linalg.norm(b - p, axis=1)) for p in a])
    far = np.flatnonzero(d > tol.TREE_SPLIT * R)
    if far.size:
        near = np.flatnonzero(d[:far[0]] <= tol.TREE_MEET * R[:far[0]])
        want = int(near[-1]) if near.size else 0
    else:
        want = len(a) - 1
    assert _parting(a, R, cKDTree(b)) == want
    assert part_at is None or abs(want - part_at) < 40  # the brute force sees the turn


def test_the_tips_are_agglomerated_by_the_largest_mean_shared_length_over_all_their_pairs():
    """Issue #47: average linkage on a matrix of summed shared lengths (one pass per merge) merges, at every step,
    the pair of clusters whose tips share the most length on average over ALL pairs of their tips, ties to the
    first pair in the order the clusters were made: checked against that definition, by brute force, on random
    symmetric shares (integers on every third draw, so that ties occur), 2 to 30 tips."""
    from vesselgp.branches import _agglomerate

    def brute(tips, share):
        nodes = [((t,), (), share[(t, t)]) for t in tips]
        active = list(range(len(nodes)))
        while len(active) > 1:
            best, pair = -np.inf, None
            for i, a in enumerate(active):
                for b in active[i + 1:]:
                    g = np.mean([share[(x, y)] for x in nodes[a][0] for y in nodes[b][0]])
                    if g > best:
                        best, pair = g, (a, b)
            nodes.append((nodes[pair[0]][0] + nodes[pair[1]][0], pair, best))
            active = [k for k in active if k not in pair] + [len(nodes) - 1]
        return nodes

    rng = np.random.default_rng(11)
    ties = 0
    for trial in range(60):
        n = int(rng.integers(2, 31))
        tips = [int(t) for t in rng.permutation(200)[:n]]
        M = rng.random((n, n)) * 10.0
        if trial % 3 == 0:
            M = np.round(M)
        M = M + M.T
        share = {(a, b): float(M[i, j]) for i, a in enumerate(tips) for j, b in enumerate(tips)}
        want, got = brute(tips, share), _agglomerate(tips, share)
        assert [w[:2] for w in want] == [g[:2] for g in got]
        assert np.allclose([w[2] for w in want], [g[2] for g in got], rtol=1e-12)
        ties += trial % 3 == 0 and len(set(np.round(M[np.triu_indices(n, 1)], 9))) < n * (n - 1) // 2
    assert ties > 5  # the integer draws did hold tied pairs
