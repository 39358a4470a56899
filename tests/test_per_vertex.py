"""A tree's branches and paths keep their per-vertex arrays on their own vertices (issue #47).

Each branch and path of :func:`vesselgp.fit_vessel_tree` is fitted on part of the mesh; its ``vertex_*``
arrays read over the whole mesh (NaN / 0 off its own vertices) but are stored on its own rows until first
read. Checked against geometry: every stored row puts its vertex back where it is,
``V[i] = m(s_i) + local_i . (T, U, V)(s_i)``, read whole, through ``rows_of`` and through ``stored_rows``,
so a row paired with another vertex's values fails; and against the plain scatter on made-up values.
"""
from __future__ import annotations

import pickle
from dataclasses import replace

import numpy as np
import pytest

import vesselgp
from vesselgp._per_vertex import VERTEX_FILLS, on_rows, rows_of, stored_rows
from vesselgp.synthetic import synthetic_tree


@pytest.fixture(scope="module")
def tree():
    t = synthetic_tree(levels=1, voxel=0.6)
    return t.V, vesselgp.fit_vessel_tree(t.V, t.F)


def _placed(g, rows, s, local):
    """Each vertex put back from its foot's parameter and its frame coordinates: (q, 3)."""
    P, fr = g.at(s)
    return P + np.einsum("qk,qkj->qj", local, fr)


def test_tree_cylinders_are_stored_on_their_own_rows_and_give_each_vertex_back(tree):
    V, t = tree
    n = len(V)
    cylinders = list(t.branches) + list(t.paths)
    repr(t)  # printing the tree makes no array whole
    assert not any(k.startswith("_whole_") for g in cylinders for k in g.__dict__)
    stored = [len(stored_rows(g, "vertex_s")[0]) for g in cylinders]
    # stored compactly: the branches partition the vertices, a path holds its branches' rows
    assert sum(stored[:len(t.branches)]) <= n
    assert all(q < n for q in stored)
    for g in cylinders:
        rows, s = stored_rows(g, "vertex_s")
        assert np.all(np.diff(rows) > 0)
        local = stored_rows(g, "vertex_local")[1]
        assert np.abs(_placed(g, rows, s, local) - V[rows]).max() < 1e-9 * np.abs(V).max() + 1e-9
        # read through rows_of on shuffled rows, a third of them off the cylinder
        off = np.setdiff1d(np.arange(n), rows)[: len(rows) // 3]
        ask = np.random.default_rng(0).permutation(np.concatenate([rows, off]))
        s_ask, l_ask = rows_of(g, "vertex_s", ask), rows_of(g, "vertex_local", ask)
        on = np.isin(ask, rows)
        assert np.abs(_placed(g, ask[on], s_ask[on], l_ask[on]) - V[ask[on]]).max() < 1e-9 * np.abs(V).max() + 1e-9
        assert np.isnan(s_ask[~on]).all() and np.isnan(l_ask[~on]).all()
        assert (rows_of(g, "vertex_weight", off) == 0).all() and (rows_of(g, "vertex_area", off) == 0).all()
    # read whole: the same geometry, over the mesh, NaN / 0 off the cylinder
    for g in cylinders:
        rows = stored_rows(g, "vertex_s")[0]
        assert g.vertex_s.shape == (n,) and g.vertex_local.shape == (n, 3)
        on = np.isfinite(g.vertex_s)
        assert np.array_equal(np.flatnonzero(on), rows)
        assert np.abs(_placed(g, rows, g.vertex_s[on], g.vertex_local[on]) - V[on]).max() < 1e-9 * np.abs(V).max() + 1e-9
        assert np.isnan(g.vertex_theta[~on]).all() and not g.vertex_weight[~on].any() and not g.vertex_area[~on].any()
        # theta is the angle of the local offset about T from U (the class's definition)
        assert np.allclose(g.vertex_theta[on], np.arctan2(g.vertex_local[on, 2], g.vertex_local[on, 1]))
        assert g.vertex_s is g.vertex_s  # made once


@pytest.fixture(scope="module")
def single():
    t = synthetic_tree(levels=0, voxel=0.6)
    return vesselgp.fit_generalized_cylinder(t.V, t.F)


def test_on_rows_reads_as_the_scatter_of_its_rows(single):
    g = single
    q, n = len(g.vertex_s), len(g.vertex_s) + 57
    idx = np.random.default_rng(1).permutation(n)[:q]  # distinct, unsorted
    part = on_rows(g, idx, n)
    for name, fill in VERTEX_FILLS.items():
        a = getattr(g, name)
        whole = np.full((n,) + a.shape[1:], fill)
        whole[idx] = a
        # rows before the first stored and after the last one, in and out, repeated
        ask = np.concatenate([[0, n - 1], idx[:5], np.setdiff1d(np.arange(n), idx)[:5], idx[:2]])
        assert np.array_equal(rows_of(part, name, ask), whole[ask], equal_nan=True)
        rows, vals = stored_rows(part, name)
        assert np.array_equal(rows, np.sort(idx)) and np.array_equal(vals, whole[rows], equal_nan=True)
        assert np.array_equal(getattr(part, name), whole, equal_nan=True)
        assert np.array_equal(rows_of(part, name, ask), whole[ask], equal_nan=True)  # and once it is whole
    # the fields that are not per vertex are the fit's own
    assert part.centers is g.centers and part.length == g.length


def test_a_partly_stored_cylinder_copies_and_pickles_whole(single):
    g = single
    n = len(g.vertex_s) + 10
    idx = np.arange(5, 5 + len(g.vertex_s))
    part = on_rows(g, idx, n)
    again = pickle.loads(pickle.dumps(part))
    assert np.array_equal(again.vertex_local, part.vertex_local, equal_nan=True)
    assert again.vertex_s.shape == (n,)
    moved = replace(part, lam=2 * g.lam)  # a replace reads the whole arrays: a plain cylinder
    assert "_rows" not in moved.__dict__
    assert np.array_equal(moved.vertex_s, part.vertex_s, equal_nan=True) and moved.vertex_s.shape == (n,)
    assert np.array_equal(stored_rows(moved, "vertex_s")[0], np.arange(n))
