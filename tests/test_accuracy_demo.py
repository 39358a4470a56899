"""docs/accuracy.md, demo table: both paper cases at the demo's default resolution.

The figures (vertices, optimum, energy at the optimum, evaluations) are what
``vesselgp demo`` reports; here the join is run the same way (default method and
smoothing, ``pre_rotation=0``, the cases' own anchors) without the renders and energy
curves. Timings are not asserted (they live in scripts/bench.py). Measured for issue #14
(angles from the anchors: each vessel's material U):

    case 1: 8299 vertices, optimum 0.222 deg, energy 1.78e-07, 9 evaluations,
            energy at optimum +-90 deg 2.710 / 2.709
    case 2: 14189 vertices, optimum -8.474 deg, energy 2.11e-04, 10 evaluations
"""
import numpy as np
import pytest

import vesselgp
from vesselgp.synthetic import paper_case
from _docs import figure, table
from _reference import wrap

FACTOR = 1.5
# case: (vertices, optimum in degrees, energy at the optimum, evaluations), from docs/accuracy.md
DOCS_DEMO = {int(figure(case)): (int(figure(c[0])), figure(c[1]), figure(c[2]), int(figure(c[3])))
               for case, c in table("accuracy.md", "case", "vertices", "optimum (deg)").items()}


@pytest.fixture(scope="module")
def demo_cases():
    cache = {}

    def get(n):
        if n not in cache:
            c = paper_case(n)  # the demo's default resolution and pre-rotation
            p = vesselgp.JoinProblem(c.V, c.F, c.fixed, c.moving,
                                     vesselgp.Frame(c.target_origin, c.target_tangent, c.target_normal),
                                     moving_normal=c.moving_normal)
            cache[n] = (c, p, vesselgp.minimize_torsion(p))
        return cache[n]

    return get


@pytest.mark.parametrize("n", [1, 2])
def test_demo_table(demo_cases, n):
    c, p, res = demo_cases(n)
    n_vertices, angle_deg, energy, evals = DOCS_DEMO[n]
    assert abs(len(c.V) - n_vertices) <= 0.05 * n_vertices, "not the documented mesh any more"
    # the optimum: the table's figure to within the join's stated accuracy (0.5 degree; the
    # search stops at 1e-4 rad, and the figure is rounded to 0.1 degree)
    assert abs(np.degrees(wrap(res.angle - np.radians(angle_deg)))) <= 0.5, np.degrees(res.angle)
    assert res.energy <= FACTOR * energy, res.energy
    assert res.n_evals <= int(FACTOR * evals), res.n_evals
    assert abs(np.degrees(res.profile.total_twist)) <= 0.1  # measured 0.0004 and 0.048 degrees


def test_case1_optimum_is_orders_of_magnitude_below_a_quarter_turn(demo_cases):
    """docs/accuracy.md: case 1's energy at the optimum is four orders of magnitude below the energy at
    +-90 degrees, which is about 2.7: a quarter turn spread uniformly over the free 90 % of the
    length has E = (pi/2)^2 / 0.9 = 2.74 (measured 2.71: the spline rounds the kink at the
    held part)."""
    c, p, res = demo_cases(1)
    for d in (-90.0, 90.0):
        e = p.energy(res.angle + np.radians(d))
        assert abs(e - (np.pi / 2) ** 2 / 0.9) <= 0.03 * (np.pi / 2) ** 2 / 0.9, e
        assert res.energy <= 1e-4 * e
