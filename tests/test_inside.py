"""The axis check: an axis outside the surface, or grazing its wall, raises (issue #13, item 3)."""
from __future__ import annotations

import numpy as np
import pytest

import vesselgp
from vesselgp.inside import axis_winding, check_axis_inside
from vesselgp.synthetic import synthetic_vessel


@pytest.fixture(scope="module", params=["open", "capped"])
def tube(request):
    return synthetic_vessel("arc", radius=1.5, n_around=24, remesh=False, ends=request.param)


def _axis(tube, offset):
    t = tube.truth
    s = np.linspace(0, 1, 60)
    pts, fr = t.axis_at(s)
    return s, pts + offset * fr[:, 1], np.full(len(s), 1.5)


def test_true_axis_is_inside(tube):
    s, P, r = _axis(tube, 0.0)
    w, d = axis_winding(tube.V, tube.F, P[5:-5])
    assert np.all(np.abs(np.abs(w) - 1) < 0.05)  # the closed surface winds once around the axis
    assert np.all(np.abs(d - 1.5) < 0.2)
    check_axis_inside(tube.V, tube.F, s, P, r)


def test_axis_outside_raises_with_where_and_why(tube):
    s, P, r = _axis(tube, 3.0)  # two radii off the centre line: outside the wall
    w, _ = axis_winding(tube.V, tube.F, P[5:-5])
    assert np.all(np.abs(w) < 0.1)
    with pytest.raises(vesselgp.NotTubularError, match=r"leaves the surface at s = 0\.\d+ \(point \(.*\)\).*not detected.*staircase.*U-turn"):
        check_axis_inside(tube.V, tube.F, s, P, r)


def test_axis_grazing_the_wall_raises(tube):
    s, P, r = _axis(tube, 1.35)  # inside, 0.1 radius from the wall
    with pytest.raises(vesselgp.NotTubularError, match="radii of the wall"):
        check_axis_inside(tube.V, tube.F, s, P, r)


def test_one_winding_checks_several_axes_and_refuses_another_mesh(tube):
    """A SurfaceWinding built once checks the true axis (inside) and an offset one (outside) as the
    one-off check does; a winding of another mesh is refused."""
    from vesselgp.errors import OptionError
    from vesselgp.inside import SurfaceWinding

    wind = SurfaceWinding(tube.V, tube.F)
    s, P, r = _axis(tube, 0.0)
    w, d = wind(P[5:-5])
    assert np.all(np.abs(np.abs(w) - 1) < 0.05) and np.all(np.abs(d - 1.5) < 0.2)
    check_axis_inside(tube.V, tube.F, s, P, r, winding=wind)
    s, P, r = _axis(tube, 3.0)
    with pytest.raises(vesselgp.NotTubularError, match="leaves the surface"):
        check_axis_inside(tube.V, tube.F, s, P, r, winding=wind)
    with pytest.raises(OptionError, match="another|not this one"):
        check_axis_inside(tube.V[:-1], tube.F[:-1], s, P, r, winding=wind)
