"""A tapering tube's fixed point (issue #48, ``vesselgp.taper``): Eq. 3's step as a Newton step, and a cone's
refinement on nodes for its narrow part.

On a cone a section tilted off the true normal plane is not centred on the true axis (its centre lies
``-r r' delta`` off it), so the plain step maps an axis offset through a first difference of gain ``r |r'| / h``:
past 1 the fit oscillates. The exact case is a smooth cone like the 4D-flow arch's supra-aortic trunk (radius
12.9 -> 4.1 mm over 22 of its 36 mm, along a gentle curve), 48 points around, whose swept line is exact.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

import vesselgp
import vesselgp.fit as fit
import vesselgp.taper as taper
from vesselgp import tolerances as tol
from vesselgp.synthetic import synthetic_vessel

from _data import REAL, needs_real, repo_module
from _reference import polyline_distance

#: docs/accuracy.md, "Real shapes" notes: the synthetic trunk cone's axis, mean and worst (% r), away from two
#: end radii of each end
CONE_MEAN, CONE_WORST = 0.0055, 0.0089
FACTOR = 1.5


def _trunk_cone():
    """The trunk's cone: radius 12.9 -> 4.1 (smoothstep over x in [6, 28]) along (x, 3 sin(x / 12), 0), 36 long."""
    x = np.linspace(0.0, 36.0, 400)
    u = np.clip((x - 6.0) / 22.0, 0.0, 1.0)
    radius = 12.9 + (4.1 - 12.9) * u * u * (3.0 - 2.0 * u)
    return synthetic_vessel(np.c_[x, 3.0 * np.sin(x / 12.0), 0.0 * x], radius=radius, n_around=48, remesh=False,
                            units="mm")


def _axis_error(ves, gc):
    """% r from the exact line to the fitted axis, away from two end radii of each end."""
    t = ves.truth
    st = t.s * t.length
    inner = (st > 2 * t.radii[0]) & (st < t.length - 2 * t.radii[-1])
    return (100.0 * polyline_distance(t.centers, gc.dense_points) / t.radii)[inner]


@pytest.fixture(scope="module")
def cone():
    return _trunk_cone()


def test_a_cone_converges_on_its_exact_axis(cone):
    """The trunk's cone (r |r'| / h up to 1.2 on its first nodes) converges, its axis within the docs' figures of
    the exact line and its radius within 5 % of the swept one (3.5 % measured where the taper ends abruptly, its
    radius's second derivative jumping by 0.11 / mm: Eq. 4 smooths the radius, on the fit's 12 nodes)."""
    gc = vesselgp.fit_generalized_cylinder(cone.V, cone.F)
    e = _axis_error(cone, gc)
    assert len(e) >= 100
    assert gc.converged
    assert e.mean() <= FACTOR * CONE_MEAN and e.max() <= FACTOR * CONE_WORST, (e.mean(), e.max())
    t = cone.truth
    st = t.s * t.length
    inner = (st > 2 * t.radii[0]) & (st < t.length - 2 * t.radii[-1])
    s_fit = gc.dense_s[cKDTree(gc.dense_points).query(t.centers[inner])[1]]  # the fit's s at each exact point
    rel = gc.radius_at(s_fit) / t.radii[inner] - 1.0
    assert np.abs(rel).max() <= 0.05


def test_the_plain_step_oscillates_on_the_cone(cone, monkeypatch):
    """The mechanism: with Eq. 3's plain step the same cone stops at the iteration cap, its axis more than
    0.5 % r off the line (1.1 % measured), a hundred times the Newton step's."""
    monkeypatch.setattr(fit, "taper_step", lambda corr, *args: corr)
    gc = vesselgp.fit_generalized_cylinder(cone.V, cone.F)
    assert not gc.converged
    assert _axis_error(cone, gc).mean() > 0.5


def test_a_cones_refinement_spaces_its_nodes_for_its_narrow_part(cone, monkeypatch):
    """Refined on nodes spaced for its mean radius (the cone rule off), the cone's axis is more than the docs'
    worst figure off (0.018 % r measured against 0.0089)."""
    monkeypatch.setattr(tol, "GC_REFINE_TAPER", np.inf)
    gc = vesselgp.fit_generalized_cylinder(cone.V, cone.F)
    assert _axis_error(cone, gc).max() > FACTOR * CONE_WORST


@pytest.mark.parametrize("ratio, cone_rule", [(2.49, False), (2.51, True)])
def test_the_cone_rule_at_its_edge(ratio, cone_rule):
    """``GC_REFINE_TAPER`` at its edge: a converged state 40 long on 21 nodes whose radii run linearly from 2 to
    2 x ratio. Just under the ratio its refinement takes the usual 0.8 spacing (26 nodes); just over, nodes
    0.8 x 0.5 of its narrowest radius apart (2, at least half its mean, 1.76): ceil(40 / 0.8) + 1 = 51."""
    nodes = np.c_[np.linspace(0.0, 40.0, 21), np.zeros(21), np.zeros(21)]
    radii = np.linspace(2.0, 2.0 * ratio, 21)
    it = fit._Iteration(nodes, None, radii, 5, True, lam=0.05 * tol.GC_LAMBDA)
    narrow = max(2.0, tol.GC_REFINE_NARROW_FLOOR * radii.mean())
    assert narrow == 2.0
    expected = 51 if cone_rule else 26
    assert fit._refit_nodes(it, tol.GC_LAMBDA) == expected


def test_the_narrowest_radius_is_floored_at_half_the_mean():
    """A state whose radii dip to a tenth of their mean at one node (a pinch) is refined on nodes for half its
    mean radius, not for the pinch: 40 long, mean radius 4 -> ceil(40 / (0.8 x 0.5 x 2)) + 1 = 51 nodes."""
    nodes = np.c_[np.linspace(0.0, 40.0, 21), np.zeros(21), np.zeros(21)]
    radii = np.full(21, 4.0)
    radii[10] = 0.4
    radii += (4.0 - radii.mean())
    it = fit._Iteration(nodes, None, radii, 5, True, lam=0.05 * tol.GC_LAMBDA)
    assert fit._refit_nodes(it, tol.GC_LAMBDA) == 51


def test_the_radius_slope_is_exact_on_lines_and_parabolas():
    """A least-squares line over a symmetric window gives a parabola's derivative exactly at its centre, and a
    line's slope everywhere (ends included)."""
    h = 0.5
    x = h * np.arange(41)
    line = 6.0 - 0.2 * x
    np.testing.assert_allclose(taper.radius_slope(line, h), -0.2, rtol=0, atol=1e-12)
    par = 6.0 - 0.2 * x + 0.01 * x * x
    slope = taper.radius_slope(par, h)
    half = np.maximum(tol.GC_TAPER_WINDOW * par, 1.5 * h)
    symmetric = (x - half >= 0) & (x + half <= x[-1])
    assert symmetric.sum() >= 15
    np.testing.assert_allclose(slope[symmetric], (-0.2 + 0.02 * x)[symmetric], rtol=0, atol=1e-6 * 0.2)


def test_a_cylinders_step_is_its_correction_and_a_cones_inverts_the_tilt_coupling():
    """On a constant radius the step is the circle fit's correction; on a cone the correction m = (I + A) Delta
    of a known offset field Delta (the first-order model: each node's section centre moved by the tilt of its
    neighbours) gives Delta back."""
    K = 15
    frames = np.tile(np.eye(3), (K, 1, 1))  # the axis along x: T = x, U = y, V = z
    rng = np.random.default_rng(1)
    m = np.c_[np.zeros(K), rng.normal(size=(K, 2))]
    m[[0, -1]] = 0.0
    np.testing.assert_allclose(taper.taper_step(m, np.full(K, 3.0), frames, 14.0), m, atol=1e-12)
    radii = np.linspace(9.0, 3.0, K)  # slope -6 / 14 per unit, nodes 1 apart
    delta = np.c_[np.zeros(K), rng.normal(size=(K, 2))]
    delta[[0, -1]] = 0.0
    a = radii * (-6.0 / 14.0) / 2.0
    m = delta.copy()
    m[1:-1] += a[1:-1, None] * (delta[2:] - delta[:-2])
    np.testing.assert_allclose(taper.taper_step(m, radii, frames, 14.0), delta, atol=1e-10)


@pytest.mark.parametrize("product, singular", [(-1.0, True), (-0.98, False)])
def test_a_singular_taper_step_is_refused_at_its_edge(monkeypatch, product, singular):
    """Four nodes, the two inner ones coupled by a_1 (Delta_2 - Delta_0) and a_2 (Delta_3 - Delta_1): the system is
    singular where a_1 a_2 = -1 (a radius turning from widening to narrowing within a node spacing, no tube).
    There it is refused with the reason; at -0.98 it is solved."""
    frames = np.tile(np.eye(3), (4, 1, 1))
    a1, a2 = 1.0, product
    # radius_slope made to give a_j = r_j slope_j / 2h with r = 1 and h = 1
    monkeypatch.setattr(taper, "radius_slope", lambda radii, h, window=None: np.array([0.0, 2 * a1, 2 * a2, 0.0]))
    m = np.array([[0, 0, 0], [0, 1.0, 0], [0, 0.5, 0], [0, 0, 0]])
    if singular:
        with pytest.raises(vesselgp.NotTubularError, match="widening to narrowing"):
            taper.taper_step(m, np.ones(4), frames, 3.0)
    else:
        assert np.all(np.isfinite(taper.taper_step(m, np.ones(4), frames, 3.0)))


def test_a_cylinder_on_close_nodes_is_not_read_as_a_taper():
    """The radius slope is a line over one radius either way, not over a node's neighbours: a cylinder (radius
    12.9) fitted on nodes a tenth of its radius apart converges on its exact line. From the neighbours alone the
    fitted radii's scatter read as slopes of up to 2 r / h and the fit was refused."""
    x = np.linspace(0.0, 36.0, 400)
    ves = synthetic_vessel(np.c_[x, 3.0 * np.sin(x / 12.0), 0.0 * x], radius=12.9, n_around=48, remesh=False,
                           units="mm")
    gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F, n_nodes=30)
    assert gc.converged
    t = ves.truth
    mid = (t.s * t.length > 3.0) & (t.s * t.length < t.length - 3.0)
    assert (polyline_distance(t.centers, gc.dense_points) / t.radii)[mid].max() <= 0.001


@needs_real("gmsh_carotid-bifurcation_open.stl")
def test_a_junction_side_keeps_the_plain_step():
    """A tree branch's junction side is the junction's wall, not a tube's: with the Newton step there the real
    carotid's internal branch (free at the bifurcation, its radius flaring 1.9 -> 3.4 mm towards it) crept to
    the iteration cap instead of converging in 12 iterations. Every branch of the carotid converges."""
    V, F = vesselgp.read_mesh(REAL / "gmsh_carotid-bifurcation_open.stl")[:2]
    tree = vesselgp.fit_vessel_tree(V * 10.0, F)  # cm to mm (SOURCES.md)
    assert tree.branch_fit == ("converged",) * len(tree.branches)


@needs_real("cardiopinns_aortic-arch-4dflow_capped.stl")
def test_a_swept_network_trees_junction_sides_keep_the_plain_step():
    """The same with exact truth: the 4D-flow arch's network tree (VMTK's lines of the real arch swept and meshed
    as the synthetic trees are, ``data_gen/real_shapes.py``). With the Newton step at its junction sides its branch
    2 stopped at the iteration cap (it converges in 15 iterations); no branch stops unconverged."""
    t = repo_module("real_shapes").network_tree("arch")
    tree = vesselgp.fit_vessel_tree(t.V, t.F)
    assert "stopped" not in tree.branch_fit, tree.branch_fit
