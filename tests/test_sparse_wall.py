"""A single vessel's sparse wall, fewer data vertices per segment than a ring (6-8 around; issue #48):
``vesselgp.fit._sparse_fit``'s two fits, the first on nodes a ring or more apart, the second without Eq. 2's pull
(``pull=False`` in :func:`vesselgp.axis.circle_fit_solve`). Truth is the swept spline (``synthetic_vessel``)."""
from __future__ import annotations

import numpy as np
import pytest

from _reference import swept_axis_errors

import vesselgp
from vesselgp import fit
from vesselgp import tolerances as tol
from vesselgp.axis import Axis, circle_fit_solve, circle_fit_sums, local_coords
from vesselgp.synthetic import named_curve, synthetic_vessel


def _helix6():
    """A helix swept 6 points around on aligned rings (3 data vertices per segment of its 66 default nodes)."""
    return synthetic_vessel("helix", radius=2.5, n_around=6, remesh=False)


def _tight8():
    """A tight helix (curvature x radius 0.52) swept 8 points around (5 data vertices per segment)."""
    return synthetic_vessel(named_curve("helix", radius=4.0, pitch=10.0, turns=1.5), radius=2.4, n_around=8,
                            remesh=False)


def _one_fit(monkeypatch):
    """The fit as before the sparse route: one fixed point on the default nodes, whatever the wall."""
    monkeypatch.setattr(tol, "GC_SPARSE_VERTICES", 0)


def test_a_helix_six_around_follows_its_line_where_one_fit_was_refused(monkeypatch):
    """6 around: 0.022 % r mean and 0.08 % r worst (measured), bounds 1.5-2x; one fit on the default nodes
    is refused (its axis comes within 0.17 radii of the wall)."""
    ves = _helix6()
    gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    e = swept_axis_errors(ves, gc)
    assert gc.converged and e.mean() < 0.04 and e.max() < 0.15, (e.mean(), e.max())
    assert abs(gc.mean_radius / 2.5 - 1) < 0.01
    _one_fit(monkeypatch)
    with pytest.raises(vesselgp.NotTubularError):
        vesselgp.fit_generalized_cylinder(ves.V, ves.F)


def test_a_tight_helix_eight_around_follows_its_line(monkeypatch):
    """curvature x radius 0.52, 8 around: 0.016 % r mean, 0.13 worst (measured); one fit left it 0.42 % r mean,
    0.80 worst, unconverged."""
    ves = _tight8()
    gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    e = swept_axis_errors(ves, gc)
    assert gc.converged and e.mean() < 0.03 and e.max() < 0.25, (e.mean(), e.max())
    _one_fit(monkeypatch)
    one = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    assert swept_axis_errors(ves, one).mean() > 0.25


def test_without_the_pull_an_exact_axis_stays_put():
    """From the exact axis of the 8-around helix (nodes on the swept spline), Eq. 3's correction with Eq. 2's pull
    moves it by 1.1 % of the radius (rings every 1.5 nodes leave corrections between them to Eq. 2 alone);
    without the pull by 1.3e-4 (the spline through the nodes, not the exact line), measured."""
    ves = synthetic_vessel("helix", radius=2.5, n_around=8, remesh=False)
    t, K = ves.truth, 66
    nodes, _ = t.axis_at(np.linspace(0, 1, K))
    ax = Axis(nodes)
    s = np.clip(ax.project(ves.V, t.vertex_s, 4.0 / (K - 1), None), 0, 1)
    local, jac = local_coords(ax, ves.V, s)
    w = np.where((s > 0) & (s < 1), 1.0 / jac, 0.0)
    S, R = circle_fit_sums(s, local, w, K, 2.5)
    pulled = circle_fit_solve(ax.node_frames(), nodes, S, R, 0.3, 2.5, True, pull=True)
    free = circle_fit_solve(ax.node_frames(), nodes, S, R, 0.3, 2.5, True, pull=False)
    assert np.abs(pulled).max() > 5e-3 * 2.5
    assert np.abs(free).max() < 5e-4 * 2.5
    # with a lam of zero the two are one solve
    a = circle_fit_solve(ax.node_frames(), nodes, S, R, 0.0, 2.5, True, pull=True)
    b = circle_fit_solve(ax.node_frames(), nodes, S, R, 0.0, 2.5, True, pull=False)
    assert np.array_equal(a, b)


def _spy(monkeypatch):
    calls = []
    real = fit._sparse_fit

    def spy(nodes, s0, Vs, areas, ends_s, *args, **kw):
        calls.append((len(nodes), int(np.count_nonzero((areas > 0) & ~ends_s))))
        return real(nodes, s0, Vs, areas, ends_s, *args, **kw)

    monkeypatch.setattr(fit, "_sparse_fit", spy)
    return calls


@pytest.mark.parametrize("factor, sparse", [(1.0, False), (1.0 + 1e-9, True)])
def test_the_sparse_route_at_its_edge(monkeypatch, factor, sparse):
    """GC_SPARSE_VERTICES at exactly the helix's data vertices per segment of its default nodes: not sparse (fewer
    than that is); a hair over it: sparse."""
    ves = _helix6()
    calls = _spy(monkeypatch)
    vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    (K, n), = calls
    assert n < tol.GC_SPARSE_VERTICES * (K - 1)
    calls.clear()
    monkeypatch.setattr(tol, "GC_SPARSE_VERTICES", factor * n / (K - 1))
    try:
        vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    except vesselgp.VesselError:
        pass  # the dense route on this wall is refused; which route was taken is the question
    assert bool(calls) == sparse


def test_given_nodes_take_one_fit(monkeypatch):
    """n_nodes given: the fit on those nodes, as asked (the sparse route only chooses its own)."""
    ves = _tight8()
    calls = _spy(monkeypatch)
    vesselgp.fit_generalized_cylinder(ves.V, ves.F, n_nodes=36)
    assert calls == []


def test_a_sparse_wall_that_is_not_round_takes_one_fit(monkeypatch):
    """An 8-around tube of 0.6 ellipses scatters about its circles far more than the clean limit: the sparse route
    leaves it (without Eq. 2's pull an elliptic section's fit left its surface) and the fit is the one fit's, bit
    for bit."""
    ves = synthetic_vessel(named_curve("helix", radius=4.0, pitch=10.0, turns=1.5), radius=1.5, n_around=8,
                           ellipticity=0.6, remesh=False)
    calls, out = _spy(monkeypatch), []
    for patch in (False, True):
        if patch:
            _one_fit(monkeypatch)
        try:
            out.append(vesselgp.fit_generalized_cylinder(ves.V, ves.F).dense_points)
        except vesselgp.VesselError as err:
            out.append(str(err))
    assert len(calls) == 1  # tried once, left
    assert type(out[0]) is type(out[1])
    assert (out[0] == out[1]) if isinstance(out[0], str) else np.array_equal(out[0], out[1])
