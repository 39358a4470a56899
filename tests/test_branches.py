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

