"""A clean single vessel's fixed point is refined on closer nodes (issue #48, ``vesselgp.fit._refined``).

The refinement runs when the final circle fit's weight (:func:`vesselgp.fit.data_lambda`, ``(sigma / 0.01)^2``
times ``lam``) comes out at ``GC_REFINE_LAMBDA`` of ``lam`` or less. Its edge is tested on a bent tube whose
rings alternate between radii ``r (1 + a)`` and ``r (1 - a)`` (every vertex ``a`` off the mean radius: a robust
scatter sigma = 1.4826 a), at 0.95 and 1.05 times the ``a`` where the weight is at that edge; a refinement that
does not converge leaves the first fit as it was.
"""
from __future__ import annotations

import logging

import numpy as np
import pytest

import vesselgp
import vesselgp.fit as fit
from vesselgp import tolerances as tol
from vesselgp.synthetic import _ring_mesh

from _data import REAL, needs_real

R, BEND, N_AROUND, N_RINGS = 1.0, 12.0, 48, 121


@pytest.fixture(autouse=True)
def refinement_alone(monkeypatch):
    """These tests read the refinement on closer nodes alone: the fit freed of Eq. 2's pull that follows it on a
    clean wall (``GC_FREE_PULL``, tests/test_sections.py and tests/test_real_shapes.py) is held off."""
    monkeypatch.setattr(tol, "GC_FREE_PULL", np.inf)


def _alternating_tube(a):
    """An open quarter torus (centre-line radius BEND), rings of N_AROUND points alternating r (1 +- a), and its
    centre line's ring centres."""
    phi = np.linspace(0.0, 0.5 * np.pi, N_RINGS)
    th = 2.0 * np.pi * np.arange(N_AROUND) / N_AROUND
    sign = np.where((np.arange(N_RINGS)[:, None] + np.arange(N_AROUND)[None]) % 2 == 0, 1.0, -1.0)
    rho = R * (1.0 + a * sign)
    C = BEND * np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], 1)  # the centre line
    N = -C / BEND  # towards the bend's centre
    B = np.array([0.0, 0.0, 1.0])
    V = C[:, None] + rho[..., None] * (np.cos(th)[None, :, None] * N[:, None] + np.sin(th)[None, :, None] * B)
    return V.reshape(-1, 3), _ring_mesh(N_RINGS, N_AROUND, capped=False), C


def _refined_runs(V, F, caplog):
    caplog.clear()
    with caplog.at_level(logging.DEBUG, logger="vesselgp.fit"):
        gc = vesselgp.fit_generalized_cylinder(V, F)
    return gc, any("fit refined on" in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize("k, refined", [(0.95, True), (1.05, False)])
def test_refinement_runs_on_walls_that_scatter_less_than_its_edge(k, refined, caplog):
    a_edge = tol.GC_LAMBDA_SCATTER * np.sqrt(tol.GC_REFINE_LAMBDA) / 1.4826  # (1.4826 a / 0.01)^2 = 0.5
    V, F, _ = _alternating_tube(k * a_edge)
    gc, ran = _refined_runs(V, F, caplog)
    assert ran == refined
    assert (gc.final_lam <= tol.GC_REFINE_LAMBDA * gc.lam) == refined  # the weight the gate read
    # either way the axis is on the centre line (the circle of radius BEND in z = 0), away from the ends
    P = gc.dense_points[(gc.dense_s > 0.05) & (gc.dense_s < 0.95)]
    assert (np.hypot(np.hypot(P[:, 0], P[:, 1]) - BEND, P[:, 2])).max() < 2e-3 * R


def test_a_refinement_that_does_not_converge_leaves_the_first_fit(caplog, monkeypatch):
    V, F, _ = _alternating_tube(0.0)
    monkeypatch.setattr(tol, "GC_REFINE_LAMBDA", -1.0)  # no refinement: the first fit alone
    first = vesselgp.fit_generalized_cylinder(V, F)
    monkeypatch.setattr(tol, "GC_REFINE_LAMBDA", 0.5)
    real = fit.fixed_points
    calls = []

    def counted(problems, **kw):  # the first fit, then the refinement, which stalls
        calls.append(len(problems[0].nodes))
        states = real(problems, **kw)
        return states if len(calls) == 1 else [fit.replace(st, converged=False) for st in states]

    monkeypatch.setattr(fit, "fixed_points", counted)
    with caplog.at_level(logging.INFO, logger="vesselgp.fit"):
        gc = vesselgp.fit_generalized_cylinder(V, F)
    assert len(calls) == 2 and calls[1] > calls[0]  # the refinement ran, on more nodes
    assert any("did not converge" in r.getMessage() for r in caplog.records)
    assert np.array_equal(gc.centers, first.centers) and gc.iterations == first.iterations


CORONARY = "xra_coronary_single_branch_open.stl"


@needs_real(CORONARY)
def test_a_refinement_whose_steps_grow_is_given_up_at_the_third_growing_step(caplog, monkeypatch):
    """On the real X-ray coronary (a clean NURBS mesh, 30 vertices per node) the refinement diverges slowly once
    its outlier set is fixed. It stops at the first GC_REFINE_GROWING-th growing step in a row (its step history:
    no earlier such run, the last GC_REFINE_GROWING steps each larger than the one before), and the fit is the
    first one, bit for bit."""
    V, F = vesselgp.read_mesh(REAL / CORONARY)[:2]
    monkeypatch.setattr(tol, "GC_REFINE_LAMBDA", -1.0)
    first = vesselgp.fit_generalized_cylinder(V, F)
    monkeypatch.setattr(tol, "GC_REFINE_LAMBDA", 0.5)
    steps, real = {}, fit._advance

    def advance(it, axis, corr, radii, s, w, jac, inside, rscale):
        out = real(it, axis, corr, radii, s, w, jac, inside, rscale)
        steps.setdefault(len(it.nodes), []).append((out.step, it.rejected is not None))
        return out

    monkeypatch.setattr(fit, "_advance", advance)
    with caplog.at_level(logging.INFO, logger="vesselgp.fit"):
        gc = vesselgp.fit_generalized_cylinder(V, F)
    assert any("did not converge" in r.getMessage() for r in caplog.records)
    assert np.array_equal(gc.centers, first.centers) and gc.iterations == first.iterations
    fine = steps[max(steps)]  # the refinement's steps (more nodes)
    run, runs = 0, []
    for (prev, _), (step, frozen) in zip(fine, fine[1:]):
        run = run + 1 if frozen and step > prev else 0
        runs.append(run)
    n = tol.GC_REFINE_GROWING
    assert runs[-1] == n and max(runs[:-1]) < n
    assert len(fine) < tol.GC_MAX_ITER  # given up before the cap


# ----------------------------------------------------------------------------- the refinement's gates


def test_second_difference_pull_is_the_fourth_difference_of_the_nodes():
    """On nodes C_k = (k, c k^4, 0) the fourth difference is 24 c at every node; the pull is that in radii."""
    k = np.arange(30.0)
    C = np.c_[k, 1e-5 * k**4, 0 * k]
    assert np.isclose(fit._second_difference_pull(C, (True, True), 2.0), 24e-5 / 2.0, rtol=1e-6)


@pytest.mark.parametrize("at, counted", [(0.99, False), (1.01, True)])
def test_second_difference_pull_leaves_out_a_free_ends_margin(at, counted):
    """A bump of delta at node 10 of a straight line (unit spacing) gives fourth differences 6 delta there and
    4 delta at its neighbours. With a free first end and node 10 at 0.99 / 1.01 of GC_REFINE_FREE_END radii
    from it, the pull is 4 delta (the row at node 10 left out) / 6 delta."""
    r = 10.0 / (at * tol.GC_REFINE_FREE_END)
    k = np.arange(30.0)
    C = np.c_[k, 0 * k, 0 * k]
    C[10, 1] = 1e-3
    got = fit._second_difference_pull(C, (False, True), r)
    assert np.isclose(got, (6e-3 if counted else 4e-3) / r, rtol=1e-9)
    assert np.isclose(fit._second_difference_pull(C, (True, True), r), 6e-3 / r, rtol=1e-9)  # pinned: counted


@pytest.mark.parametrize("at, counted", [(0.99, False), (1.01, True)])
def test_refinement_move_is_the_farthest_node_off_the_first_axis(at, counted):
    """First axis: a straight line of 21 nodes, x = 0..20. Refined nodes on it, one moved delta sideways at x =
    ``at`` x GC_REFINE_FREE_END radii from a free first end: its move counts at 1.01, not at 0.99. A node past
    the first axis's end (its foot is the end) never counts."""
    r = 2.0
    first = np.c_[np.arange(21.0), np.zeros(21), np.zeros(21)]
    x = np.linspace(0.0, 20.0, 26)
    j = 5
    x[j] = at * tol.GC_REFINE_FREE_END * r
    fine = np.c_[x, np.zeros(26), np.zeros(26)]
    fine[j, 1] = 1e-3
    got = fit._refinement_move(first, fine, (False, True), r)
    assert np.isclose(got, 1e-3 / r if counted else 0.0, rtol=1e-6, atol=1e-12)
    over = np.r_[fine, [[21.0, 0.5, 0.0]]]  # 0.5 sideways, past the end: its foot is the end
    assert np.isclose(fit._refinement_move(first, over, (True, True), r), 1e-3 / r, rtol=1e-6)


def _arch():
    from vesselgp.synthetic import synthetic_vessel

    v = synthetic_vessel("aortic_arch", radius=12.0, n_around=24, remesh=False)
    return v.V, v.F


def _recorded(monkeypatch, name):
    """Wrap fit.<name> to record what it returns."""
    got, real = [], getattr(fit, name)

    def rec(*args, **kw):
        out = real(*args, **kw)
        got.append(out)
        return out

    monkeypatch.setattr(fit, name, rec)
    return got


@pytest.fixture(scope="module")
def arch_first_and_refined():
    V, F = _arch()
    with pytest.MonkeyPatch.context() as m:
        m.setattr(tol, "GC_FREE_PULL", np.inf)  # the refinement alone (refinement_alone above)
        refined = vesselgp.fit_generalized_cylinder(V, F)
        m.setattr(tol, "GC_REFINE_LAMBDA", -1.0)
        first = vesselgp.fit_generalized_cylinder(V, F)
    return V, F, first, refined


def test_the_arch_is_refined_by_default(arch_first_and_refined):
    """The synthetic aortic arch (curvature varying from the ascending aorta into the arch) is refined: its axis
    moved, its node count kept (a single vessel's refinement is resampled back)."""
    _, _, first, gc = arch_first_and_refined
    assert len(gc.s) == len(first.s) and gc.iterations > first.iterations
    assert np.abs(gc.centers - first.centers).max() > tol.GC_REFINE_MIN_MOVE * float(np.median(first.radii))


@pytest.mark.parametrize("k, runs", [(0.99, True), (1.01, False)])
def test_the_refinement_is_not_tried_where_eq2_pulls_less_than_its_threshold(k, runs, monkeypatch,
                                                                              arch_first_and_refined):
    """GC_REFINE_MIN_MOVE at 0.99 / 1.01 of lam times the converged arch's pull (its nodes' largest fourth
    difference, tested above): the refinement runs (a second fixed point) / is not tried."""
    V, F, first, _ = arch_first_and_refined
    pulls = _recorded(monkeypatch, "_second_difference_pull")
    vesselgp.fit_generalized_cylinder(V, F)
    edge = first.lam * pulls[0]
    assert edge > tol.GC_REFINE_MIN_MOVE  # the default tries it
    monkeypatch.setattr(tol, "GC_REFINE_MIN_MOVE", k * edge)
    calls = _recorded(monkeypatch, "fixed_points")
    vesselgp.fit_generalized_cylinder(V, F)
    assert len(calls) == (2 if runs else 1)


@pytest.mark.parametrize("k, kept", [(0.99, True), (1.01, False)])
def test_a_refinement_that_moves_the_axis_less_than_its_threshold_is_dropped(k, kept, monkeypatch,
                                                                            arch_first_and_refined):
    """GC_REFINE_MIN_MOVE at 0.99 / 1.01 of the refinement's move on the arch (tested above; below Eq. 2's pull,
    so the refinement runs either way): the refined axis is kept / the first fit is returned, bit for bit."""
    V, F, first, refined = arch_first_and_refined
    moves = _recorded(monkeypatch, "_refinement_move")
    vesselgp.fit_generalized_cylinder(V, F)
    monkeypatch.setattr(tol, "GC_REFINE_MIN_MOVE", k * moves[0])
    gc = vesselgp.fit_generalized_cylinder(V, F)
    assert np.array_equal(gc.centers, (refined if kept else first).centers)
    assert gc.iterations == (refined if kept else first).iterations


@pytest.mark.parametrize("k, kept", [(0.99, True), (1.01, False)])
def test_a_refinement_whose_nodes_see_too_few_vertices_is_dropped(k, kept, monkeypatch, arch_first_and_refined):
    """GC_LAMBDA_VERTICES at 0.99 / 1.01 of the refined fit's data vertices per node (counted by data_lambda on
    its final circle fit; the first fit has 1.25 times as many per node and keeps its lowered weight): the
    refined fit's own weight is lowered and it is kept / it keeps lam and the first fit is returned."""
    V, F, first, refined = arch_first_and_refined
    seen, real = [], fit.data_lambda

    def counted(lam, rel, K):
        seen.append((len(rel) / (K - 1), K))
        return real(lam, rel, K)

    monkeypatch.setattr(fit, "data_lambda", counted)
    vesselgp.fit_generalized_cylinder(V, F)
    per_first = [p for p, K in seen if K == len(first.s)][-1]
    per_fine = [p for p, K in seen if K > len(first.s)][-1]
    assert per_first > 1.2 * per_fine
    monkeypatch.setattr(tol, "GC_LAMBDA_VERTICES", k * per_fine)
    gc = vesselgp.fit_generalized_cylinder(V, F)
    assert gc.final_lam <= tol.GC_REFINE_LAMBDA * gc.lam  # the first fit's weight is lowered either way
    assert np.array_equal(gc.centers, (refined if kept else first).centers)


# ----------------------------------------------------------------------------- a sparse clean wall, on fewer nodes


def _residuals(sigma, n):
    """n relative residuals of robust scatter sigma (median |x| = sigma / 1.4826)."""
    return np.resize([sigma / 1.4826, -sigma / 1.4826], n)


@pytest.mark.parametrize("extra, sparse", [(0, True), (1, False)])
def test_a_sparse_wall_is_one_of_at_most_its_vertices_per_node(extra, sparse):
    """sparse_clean_wall at its vertex edge: GC_LAMBDA_VERTICES data vertices per segment (sparse, its count
    returned) and one vertex more (dense: None), both scattering far less than the refinement's edge."""
    K = 31
    q = tol.GC_LAMBDA_VERTICES * (K - 1) + extra
    got = fit.sparse_clean_wall(_residuals(1e-4, q), K)
    assert got == (q if sparse else None)


@pytest.mark.parametrize("k, clean", [(0.99, True), (1.01, False)])
def test_a_sparse_wall_is_clean_below_the_refinements_scatter(k, clean):
    """sparse_clean_wall at its scatter edge: sigma at 0.99 / 1.01 of GC_LAMBDA_SCATTER sqrt(GC_REFINE_LAMBDA),
    where a dense wall's weight comes out at GC_REFINE_LAMBDA of lam."""
    K, q = 31, 10 * 30
    sigma = k * tol.GC_LAMBDA_SCATTER * np.sqrt(tol.GC_REFINE_LAMBDA)
    assert fit.sparse_clean_wall(_residuals(sigma, q), K) == (q if clean else None)


@pytest.mark.parametrize("sparse, K2", [(tol.GC_COARSEN_VERTICES * 20, 21), (tol.GC_COARSEN_VERTICES * 20 - 1, None)])
def test_a_sparse_wall_is_coarsened_at_most_by_its_spacing_limit(sparse, K2):
    """31 nodes (30 segments) whose wall has GC_COARSEN_VERTICES x 20 data vertices: 21 nodes, 1.5 times as far
    apart, at GC_COARSEN_SPACING; one vertex fewer would need 20 nodes, 30 / 19 > 1.5 times as far: not tried."""
    assert tol.GC_COARSEN_SPACING == 1.5
    it = fit._Iteration(np.zeros((31, 3)), None, None, 5, True, lam=0.3, sparse=sparse)
    assert fit._refit_nodes(it, 0.3) == K2
    assert fit._refit_nodes(fit.replace(it, sparse=None), 0.3) is None  # a wall that is not sparse and clean
    assert fit._refit_nodes(fit.replace(it, lam=0.15), 0.3) == 39  # a lowered weight: refined, (30 / 0.8) + 1
    # never under GC_MIN_NODES: 15 nodes whose wall would give 11 at 22 vertices each get 12
    short = fit._Iteration(np.zeros((15, 3)), None, None, 5, True, lam=0.3, sparse=tol.GC_COARSEN_VERTICES * 10)
    assert tol.GC_MIN_NODES == 12 and fit._refit_nodes(short, 0.3) == 12


def test_a_sparse_clean_arch_is_closer_to_its_centre_line_on_fewer_nodes():
    """The synthetic aortic arch swept with 15 points around: about 18 data vertices per node, which keep lam.
    Fitted again on fewer nodes (22 vertices each), its axis is within 0.06 % r of the exact centre line on
    average, against 0.15 on its own nodes (0.037 and 0.152 measured), and its final weight is lowered."""
    from vesselgp.synthetic import synthetic_vessel
    from _reference import polyline_distance

    v = synthetic_vessel("aortic_arch", radius=12.0, n_around=15, remesh=False)
    t = v.truth
    st = t.s * t.length
    inner = (st > 24.0) & (st < t.length - 24.0)
    with pytest.MonkeyPatch.context() as m:
        m.setattr(tol, "GC_COARSEN_VERTICES", np.inf)  # no coarsening: the first fit
        first = vesselgp.fit_generalized_cylinder(v.V, v.F)
    gc = vesselgp.fit_generalized_cylinder(v.V, v.F)
    e0 = 100 * polyline_distance(t.centers[inner], first.dense_points) / t.radii[inner]
    e1 = 100 * polyline_distance(t.centers[inner], gc.dense_points) / t.radii[inner]
    assert first.final_lam == first.lam and gc.final_lam <= tol.GC_REFINE_LAMBDA * gc.lam
    assert e0.mean() > 0.1 and e1.mean() < 0.06 and e1.max() < 0.6 * e0.max()
    assert len(gc.s) == len(first.s)  # a single vessel's axis is resampled to its node count
