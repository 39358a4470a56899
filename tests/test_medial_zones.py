"""Where the tube model does not hold, the axis is the centre line (issue #34, vesselgp.medial_zones).

Truth is analytic: a straight centre line along x with unit inscribed radius and fitted axes displaced
from it by known offsets (a Gaussian bump, a sac's pull; a U-turn, a stub's sliding end; an overshoot
past a junction).
"""
from __future__ import annotations

import numpy as np
import pytest

from vesselgp import tolerances as tol
from vesselgp.medial_zones import medial_zones

T = np.linspace(0.0, 20.0, 81)
LINE = np.c_[T, 0 * T, 0 * T]
ONES = np.ones(81)


def _bump(height, width=1.5):
    return LINE + np.c_[0 * T, height * np.exp(-((T - 10.0) / width) ** 2), 0 * T]


def test_a_sideways_pull_becomes_the_centre_line_over_the_departure_and_a_radius():
    """A fit bulging 1.2 radii sideways departs by more than half a radius for |t - 10| < 1.5 sqrt(ln 2.4)
    = 1.403: the zone covers that, widened by one radius (to a quarter-radius sample), and inside it the
    axis is the line (y = 0); beyond the zone and its two-radius blend the fit is kept."""
    out, zones = medial_zones(_bump(1.2), LINE, ONES, 1.0)
    half = 1.5 * np.sqrt(np.log(2.4))
    assert zones.shape == (1, 2)
    z0, z1 = zones[0]
    assert 10 - half - 1.0 - 0.26 <= z0 <= 10 - half - 1.0 + 0.5
    assert 10 + half + 1.0 - 0.5 <= z1 <= 10 + half + 1.0 + 0.26
    mid = (out[:, 0] > z0 + 0.3) & (out[:, 0] < z1 - 0.3)
    assert np.abs(out[mid, 1:]).max() < 1e-6  # the equal-arc resample's spline, to 2e-8
    far = np.abs(out[:, 0] - 10.0) > 10 - z0 + tol.TREE_MEDIAL_BLEND + 0.3
    truth = 1.2 * np.exp(-((out[far, 0] - 10.0) / 1.5) ** 2)
    np.testing.assert_allclose(out[far, 1], truth, atol=1e-3)


@pytest.mark.parametrize("height, departs", [(0.45, False), (0.55, True)])
def test_the_departure_guard_at_its_edge(height, departs):
    """Half an inscribed radius: a bump of 0.45 radii is the tube model's (the input comes back as it is);
    one of 0.55 radii is not."""
    fit = _bump(height)
    out, zones = medial_zones(fit, LINE, ONES, 1.0)
    assert (len(zones) > 0) == departs
    if not departs:
        assert out is fit


def test_the_departure_is_measured_in_the_local_inscribed_radius():
    """The same 0.55 bump departs on a line of inscribed radius 1 and not on one of radius 1.2 (0.46 R)."""
    assert len(medial_zones(_bump(0.55), LINE, ONES, 1.0)[1]) == 1
    assert len(medial_zones(_bump(0.55), LINE, 1.2 * ONES, 1.0)[1]) == 0


def test_a_stub_that_slid_along_itself_becomes_its_centre_line():
    """A stub's first fit that runs out 1.5 radii sideways and back (a U over the whole short line, as the
    gmsh arch's left subclavian did) is replaced by the line throughout: every output point on y = z = 0,
    from the line's start to its end."""
    t = np.linspace(0.0, 3.0, 13)
    line = np.c_[t, 0 * t, 0 * t]
    u = np.linspace(0, np.pi, 30)
    fit = np.c_[1.5 - 1.5 * np.cos(u), 1.5 * np.sin(u), 0 * u]
    out, zones = medial_zones(fit, line, np.ones(13), 1.0)
    assert np.abs(out[:, 1:]).max() < 1e-6
    np.testing.assert_allclose([out[:, 0].min(), out[:, 0].max()], [0.0, 3.0], atol=1e-6)


@pytest.mark.parametrize("through", [False, True])
def test_an_overshoot_past_a_junction_counts_only_through_it(through):
    """An axis running on 1.5 radii beyond the line's end, off to the side (a parent's free junction
    side that slid on): ignored where the line ends at a pinned end, replaced when the line runs to
    the junction the axis must end at (``through``)."""
    extra = np.c_[20.0 + np.linspace(0.25, 1.5, 6), np.linspace(0.25, 1.5, 6), 0 * np.arange(6)]
    fit = np.vstack([LINE, extra])
    out, zones = medial_zones(fit, LINE, ONES, 1.0, through=(False, through))
    if through:
        assert zones[-1, 1] == pytest.approx(20.0)
        np.testing.assert_allclose(out[-1], [20.0, 0.0, 0.0], atol=1e-9)
    else:
        assert len(zones) == 0 and out is fit


# --------------------------------------------------------------------------- #
# an axis turning tighter than its radius (kappa r >= 1) while near the line
# --------------------------------------------------------------------------- #
T_FINE = np.linspace(0.0, 20.0, 321)
LINE_FINE = np.c_[T_FINE, 0 * T_FINE, 0 * T_FINE]


def _kink(kr, height=0.3):
    """A Gaussian wiggle of 0.3 radii (no departure) whose curvature at its peak, 2 h / w^2 (y' = 0 there),
    times the unit radius is ``kr``."""
    w = np.sqrt(2.0 * height / kr)
    return LINE_FINE + np.c_[0 * T_FINE, height * np.exp(-((T_FINE - 10.0) / w) ** 2), 0 * T_FINE]


@pytest.mark.parametrize("kr, zoned", [(0.85, False), (1.2, True)])
def test_the_bend_guard_at_its_edge(kr, zoned):
    """A wiggle 0.3 radii high (inside the departure guard) whose peak turns with kappa r = 0.85 is the tube
    model's; one with kappa r = 1.2 (its sections would overlap) is the centre line there, the wiggle gone."""
    fit = _kink(kr)
    out, zones = medial_zones(fit, LINE_FINE, np.ones(len(T_FINE)), 1.0, fit_radius=np.ones(len(T_FINE)))
    assert (len(zones) > 0) == zoned
    if zoned:
        assert zones.shape == (1, 2) and zones[0, 0] < 10.0 < zones[0, 1]
        assert np.abs(out[np.abs(out[:, 0] - 10.0) < 0.5, 1]).max() < 1e-3
    else:
        assert out is fit


def test_the_bend_is_judged_in_the_fitted_radius_and_past_the_junction_zone():
    """The same wiggle (kappa 2.4 per unit length at its peak): with a fitted radius of 0.3 (kappa r = 0.72)
    it stays; without a fitted radius only the departure is judged; within ``skip_start`` (a child's junction
    zone, turning off its parent by design) it is not judged either."""
    fit = _kink(1.2)
    ones = np.ones(len(T_FINE))
    assert len(medial_zones(fit, LINE_FINE, ones, 1.0, fit_radius=0.3 * ones)[1]) == 0
    assert len(medial_zones(fit, LINE_FINE, ones, 1.0)[1]) == 0
    assert len(medial_zones(fit, LINE_FINE, ones, 1.0, fit_radius=ones, skip_start=11.5)[1]) == 0
    assert len(medial_zones(fit, LINE_FINE, ones, 1.0, fit_radius=ones, skip_start=8.0)[1]) == 1


def test_a_turn_found_on_the_final_cylinder_becomes_the_centre_line():
    """``sharp_s``: where the branch's final cylinder turns tighter than its final radius (judged after the
    junctions, :func:`vesselgp.tree._sharp_turns_to_centre_line`), the axis becomes the line too, over a
    radius either side. A fit 0.3 radii off the line (under the departure) with the turn flagged at its
    middle: the zone is [9, 11] to a quarter-radius sample, the line inside it; unflagged, no zone."""
    fit = _bump(0.3)
    assert medial_zones(fit, LINE, ONES, 1.0)[1].shape == (0, 2)
    out, zones = medial_zones(fit, LINE, ONES, 1.0, sharp_s=[0.5])
    assert zones.shape == (1, 2) and np.allclose(zones[0], [9.0, 11.0], atol=0.26)
    mid = (out[:, 0] > zones[0, 0] + 0.3) & (out[:, 0] < zones[0, 1] - 0.3)
    assert mid.any() and np.abs(out[mid, 1:]).max() < 1e-6


def test_a_zone_ending_a_rounding_past_the_line_takes_its_last_point():
    """A zone's arc lengths are measured on the line densified, whose length can exceed the given line's by a
    rounding (7e-15 on the voxelised aneurysm remeshed at 1.4 edges on one machine: an IndexError there): the
    zone's end points are the line's points at or next after them, its last point past its end."""
    from vesselgp.curves import chord_length
    from vesselgp.tree import _zone_points

    line = np.c_[np.linspace(0.0, 1.0, 7) ** 2, np.zeros(7), np.zeros(7)]
    L = chord_length(line)[-1]
    ends = _zone_points(line, np.array([[0.3, np.nextafter(L, np.inf)], [0.0, 0.25]]))
    assert ends.shape == (2, 2, 3)
    assert np.array_equal(ends[0, 1], line[-1]) and np.array_equal(ends[1, 0], line[0])
    assert np.array_equal(ends[0, 0], line[np.searchsorted(chord_length(line), 0.3)])
