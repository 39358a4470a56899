"""A fit on the caller's nodes or weight is freed of Eq. 2's pull where it pulls hard, or says so (issue #48).

Eq. 2's weight pulls an axis towards its chord by about lambda x curvature x spacing^2, growing with the fourth power
of the node spacing; the refusal of the 2.5:1 vein advised fewer nodes, and on them it was answered 2.6 % r mean,
13.9 % r worst off its exact line, silently. Truth: exact swept tubes (their spline), never the fit.
"""
from __future__ import annotations

import logging

import numpy as np
import pytest

from _data import needs_real, repo_module
from _reference import free_stage_at_edge, swept_axis_errors

import vesselgp
from vesselgp import fit
from vesselgp import tolerances as tol
from vesselgp.fit import _second_difference_pull
from vesselgp.synthetic import synthetic_vessel

_WARNS = "holds the fitted axis about"


@pytest.fixture(autouse=True)
def circle_fit(monkeypatch):
    """These tests hold walls to the paper's circle fit (``GC_ELLIPTIC`` past any amplitude): the 2:1 arch's sections
    otherwise carry their second harmonic (vesselgp.sections) and a fit of it always takes the stage
    (``GC_FREE_PULL``; tests/test_sections.py)."""
    monkeypatch.setattr(tol, "GC_ELLIPTIC", np.inf)


@pytest.fixture(scope="module")
def elliptic_arch():
    """The synthetic aortic arch (radius 13 mm) with 2:1 elliptic sections, 32 around, remeshed: a wall that keeps
    Eq. 2's full weight (not circular), fitted on 18 nodes (the default's half)."""
    return synthetic_vessel("aortic_arch", radius=13.0, ellipticity=0.5, n_around=32, seed=11)


def test_a_hard_pull_on_given_nodes_is_fitted_away(elliptic_arch, caplog):
    """On 18 nodes Eq. 2 holds the axis about 0.07 radii off (2.3 % r mean, 5.1 worst before); fitted once more with
    its weight on the step only it is 0.21 % r mean and 1.1 worst (bounds 1.5x), no WARNING, the iterations of
    both fits counted."""
    ves = elliptic_arch
    with caplog.at_level(logging.WARNING, logger="vesselgp"):
        gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F, n_nodes=18)
    e = swept_axis_errors(ves, gc)
    assert e.mean() <= 1.5 * 0.21 and e.max() <= 1.5 * 1.1, (e.mean(), e.max())
    assert not any(_WARNS in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize("side", [0.99, 1.01])
def test_the_pull_limit_at_its_edge(elliptic_arch, monkeypatch, side):
    """GC_PULL_WARN at 0.99 / 1.01 of the 18-node fit's own pull (read with the stage off): fitted once more just
    below it (the axis within 1.1 % r of its line), kept as it was just above (5 % r off, and named in the
    WARNING)."""
    ves = elliptic_arch
    monkeypatch.setattr(tol, "GC_PULL_WARN", np.inf)
    first = vesselgp.fit_generalized_cylinder(ves.V, ves.F, n_nodes=18)
    ends = vesselgp.vessel_ends(ves.V, ves.F)
    rscale = 0.5 * (ends[first.ends[0]].radius + ends[first.ends[1]].radius)  # the fit's radius scale
    pull = first.final_lam * _second_difference_pull(first.centers, (True, True), rscale)
    assert swept_axis_errors(ves, first).max() > 3.0  # the pull's own error: the test can fail
    monkeypatch.setattr(tol, "GC_PULL_WARN", side * pull)
    gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F, n_nodes=18)
    assert (swept_axis_errors(ves, gc).max() < 1.5 * 1.1) == (side < 1)


def test_the_defaults_are_not_touched(elliptic_arch):
    """On the default nodes GC_PULL_WARN changes nothing: the fit with it at zero is the same bit for bit (it is the
    limit for the caller's nodes or weight; a default fit of a clean wall has GC_FREE_PULL)."""
    ves = elliptic_arch
    a = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    with pytest.MonkeyPatch.context() as m:
        m.setattr(tol, "GC_PULL_WARN", 0.0)
        b = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    assert np.array_equal(a.centers, b.centers) and a.iterations == b.iterations


rs = repo_module("real_shapes")


@needs_real(rs.CASES["renal"].mesh)
def test_a_pull_that_cannot_be_fitted_away_is_said(caplog):
    """The real renal line swept with circles, on 15 nodes (the default's half): the fit without the pull does not
    converge, so the first stands, 5.4 % r mean and 14 % r worst off its line, and the WARNING says Eq. 2 holds it
    about 0.1 radii off: the figure it gives is within a factor 3 of the worst error against the exact line."""
    ves = rs.case_vessel("renal")
    with caplog.at_level(logging.WARNING, logger="vesselgp"):
        gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F, n_nodes=15)
    said = [r.getMessage() for r in caplog.records if _WARNS in r.getMessage()]
    assert len(said) == 1 and "n_nodes given" in said[0]
    pull = float(said[0].split(_WARNS)[1].split()[0])
    worst = swept_axis_errors(ves, gc).max() / 100
    assert worst > 0.05 and pull / 3 <= worst <= 3 * pull, (pull, worst)


def test_the_sparse_helix_on_twelve_nodes_is_answered_on_its_line():
    """The helix (radius 2.5) swept 8 around on 12 nodes, refused before as 0.41 radii off its wall's centre (its
    axis 0.42 radii off its exact line, tests/test_wall_circles.py): fitted once more without Eq. 2's pull it is
    answered 2.0 % r from its line at worst (bound 1.5x)."""
    ves = synthetic_vessel("helix", radius=2.5, n_around=8, remesh=False)
    gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F, n_nodes=12)
    assert swept_axis_errors(ves, gc).max() <= 1.5 * 2.0


@needs_real(rs.CASES["coronary"].mesh)
@pytest.mark.parametrize("side", [0.99, 1.01])
def test_a_clean_walls_pull_is_fitted_away_at_its_edge(side, monkeypatch, caplog):
    """The real coronary's line swept with exact circles, on the default nodes: its final circle fit lowers Eq. 2's
    weight and it is refined, and still the pull holds it 0.0081 % r mean and 0.125 worst off its line; fitted once
    more without the pull, 0.0033 / 0.055 (docs/accuracy.md's table). GC_FREE_PULL at 0.99 / 1.01 of the fit's own
    pull (read with the stage off): fitted once more just under it (within 1.5x of those figures), not just over."""
    first, gc, freed, e0, e = free_stage_at_edge(rs.case_vessel("coronary"), side, monkeypatch, caplog)
    assert first.final_lam < first.lam and e0.mean() > 0.006 and e0.max() > 0.1, (e0.mean(), e0.max())
    assert freed == (side < 1)
    if side < 1:
        assert e.mean() <= 1.5 * 0.0033 and e.max() <= 1.5 * 0.055 and gc.iterations > first.iterations
    else:
        assert np.array_equal(gc.centers, first.centers)


@needs_real(rs.CASES["coronary"].mesh)
def test_a_freed_fit_the_checks_refuse_leaves_the_fit_with_the_pull(monkeypatch, caplog):
    """Where the checks refuse the fit freed of Eq. 2's pull (simulated: every freed state refused), the fit with the
    pull is checked and answered instead, bit for bit the fit with the stage off, and the INFO says so."""
    ves = rs.case_vessel("coronary")
    with pytest.MonkeyPatch.context() as m:
        m.setattr(tol, "GC_FREE_PULL", np.inf)
        pulled = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    real = fit._checked_state

    def refusing(state, *a, **k):
        if state.free:
            raise vesselgp.NotTubularError("refused for the test")
        return real(state, *a, **k)

    monkeypatch.setattr(fit, "_checked_state", refusing)
    with caplog.at_level(logging.INFO, logger="vesselgp.fit"):
        gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    assert any("freed of Eq. 2's pull was refused" in r.getMessage() for r in caplog.records)
    assert np.array_equal(gc.centers, pulled.centers) and gc.iterations == pulled.iterations
