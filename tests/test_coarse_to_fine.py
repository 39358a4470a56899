"""A single vessel's fit that does not converge from its first axis is fitted again from coarser nodes
(``vesselgp.fit._coarse_to_fine``, issue #48): a flattened vein's first axis lies outside its fixed point's basin.
Truth is the swept spline (``synthetic_vessel``)."""
from __future__ import annotations

import numpy as np
import pytest

from _data import REAL, needs_real
from _reference import polyline_distance

import vesselgp
from vesselgp import fit
from vesselgp import tolerances as tol
from vesselgp.synthetic import synthetic_vessel


def _errors(ves, gc):
    """Exact centre line -> fitted axis, % of the radius, two radii from each end cut."""
    t = ves.truth
    st = t.s * t.length
    inner = (st > 2 * t.radii[0]) & (st < t.length - 2 * t.radii[-1])
    return 100 * polyline_distance(t.centers[inner], gc.dense_points) / t.radii[inner]


def _vein():
    """A helix swept with 2.5:1 ellipses (ellipticity 0.4), 48 points around: a flattened vein."""
    return synthetic_vessel("helix", radius=1.5, ellipticity=0.4, ellipse_angle=0.3, n_around=48, remesh=False)


def test_a_flattened_vein_follows_its_line_where_one_fit_was_refused(monkeypatch):
    """0.035 % r mean, 0.06 % r worst (measured; bounds about 1.5x), its iterations the stages' total (more than the
    first fit's cap); with no second try (GC_COARSE_FIRST past the node count) the first fit kinks and is refused."""
    ves = _vein()
    gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    e = _errors(ves, gc)
    assert gc.converged and e.mean() < 0.055 and e.max() < 0.1, (e.mean(), e.max())
    assert gc.iterations > tol.GC_MAX_ITER
    monkeypatch.setattr(tol, "GC_COARSE_FIRST", 10 ** 9)
    with pytest.raises(vesselgp.NotTubularError, match="bends tighter than its radius"):
        vesselgp.fit_generalized_cylinder(ves.V, ves.F)


def test_a_second_try_that_does_not_converge_leaves_the_first(monkeypatch):
    """Capped at 2 iterations no stage converges: the fit is the first one, bit for bit, as with no second try."""
    ves = synthetic_vessel("helix", radius=1.5, n_around=24, remesh=False)
    a = vesselgp.fit_generalized_cylinder(ves.V, ves.F, max_iter=2)
    monkeypatch.setattr(tol, "GC_COARSE_FIRST", 10 ** 9)
    b = vesselgp.fit_generalized_cylinder(ves.V, ves.F, max_iter=2)
    assert not a.converged and np.array_equal(a.dense_points, b.dense_points) and a.iterations == b.iterations


def test_a_converged_fit_takes_no_second_try(monkeypatch):
    """A fit that converges from its first axis is that fit: the same, bit for bit, with the second try off."""
    ves = synthetic_vessel("helix", radius=1.5, n_around=24, remesh=False)
    a = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    monkeypatch.setattr(tol, "GC_COARSE_FIRST", 10 ** 9)
    b = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    assert a.converged and np.array_equal(a.dense_points, b.dense_points)


@needs_real("cardiopinns_aortic-arch-4dflow_capped.stl")
def test_a_second_try_that_kinks_leaves_the_first(monkeypatch):
    """The 4D-flow arch's main vessel from its root through its branches to the descending aorta (50 nodes) does not
    converge in 30 iterations (answered, with the WARNING); from 13 nodes it converges to an axis that bends tighter
    than its radius (the fit refused it, and the twist module fell back to the tree's path). The first fit stands,
    bit for bit, as with no second try."""
    V, F = vesselgp.read_mesh(REAL / "cardiopinns_aortic-arch-4dflow_capped.stl")[:2]
    a = vesselgp.fit_generalized_cylinder(V, F, ends=(0, 1))
    monkeypatch.setattr(tol, "GC_COARSE_FIRST", 10 ** 9)
    b = vesselgp.fit_generalized_cylinder(V, F, ends=(0, 1))
    assert not a.converged and np.array_equal(a.dense_points, b.dense_points)
    monkeypatch.setattr(tol, "GC_COARSE_FIRST", 4)
    monkeypatch.setattr(fit, "_kinks", lambda it: False)  # the kinked second try taken: refused
    with pytest.raises(vesselgp.NotTubularError, match="bends tighter than its radius"):
        vesselgp.fit_generalized_cylinder(V, F, ends=(0, 1))
