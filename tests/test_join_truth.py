"""The join optimum against values known without vesselgp (issue #12, section 6).

* A straight tube whose moving end is turned in place by ``phi`` (the target is
  the rest end frame turned by ``phi`` about its axis): the least-torsion angle
  undoes the turn, ``-phi`` (angle 0 maps the end's rest normal U onto
  ``target.normal``, so ``-phi`` puts the end back where it was), the deformed
  mesh at the optimum is the rest mesh, and the energy of Eq. 8 at ``-phi + d``
  is a uniform twist ``d`` over the free length: ``d^2`` (normalised arc length).
* Paper case 1: at the optimum an independent torsion measurement
  (``_reference.material_twist``: circle-fitted sections, an ODE rotation-
  minimizing frame, no vesselgp code) finds no twist, and turning the end by
  ``+30`` degrees twists the far end by about ``+30`` degrees; a pre-rotation
  ``a`` of the target normal (``paper_case(1, pre_rotation=a)`` turns the
  normal by ``+a`` about the target tangent) moves the optimum by ``-a``.
"""
import numpy as np
import pytest

import vesselgp
from vesselgp.synthetic import paper_case, synthetic_vessel
from _reference import material_twist, unit, wrap

R0 = 1.5
NA = 24


def rotate(v, axis, angle):
    """Rodrigues rotation of vector v about unit axis (independent of vesselgp)."""
    axis = unit(axis)
    return v * np.cos(angle) + np.cross(axis, v) * np.sin(angle) + axis * (axis @ v) * (1 - np.cos(angle))


@pytest.fixture(scope="module")
def straight_tube():
    """Structured straight tube along +z, 20 radii long: ring k, point j is vertex k * NA + j."""
    ves = synthetic_vessel("straight", radius=R0, n_around=NA, remesh=False)
    V, F = ves.V, ves.F
    rings = len(V) // NA
    first, last = np.arange(NA), np.arange((rings - 1) * NA, rings * NA)
    gc = vesselgp.fit_generalized_cylinder(V, F)
    return V, F, first, last, gc


def turned_in_place(V, gc, ring, phi):
    """Target: the rest frame of the end at ``ring``, turned by ``phi`` about its outward axis."""
    centre = V[ring].mean(axis=0)  # a regular ring: its mean is the end centre
    outward = unit(centre - V.mean(axis=0))  # the tube is straight: the axis is z, outward from the middle
    # the end's rest normal U (the GC's convention); on a straight tube the RMF is constant
    s_end = 0.0 if np.linalg.norm(gc.centers[0] - centre) < np.linalg.norm(gc.centers[-1] - centre) else 1.0
    _, fr = gc.at([s_end])
    U = fr[0, 1]
    assert abs(U @ outward) < 1e-9 and abs(abs(fr[0, 0] @ outward) - 1) < 1e-9
    return vesselgp.Frame(centre, outward, rotate(U, outward, phi))


@pytest.mark.parametrize("moving_end", ["last", "first"])
@pytest.mark.parametrize("phi_deg", [-150.0, 35.0, 120.0])
def test_straight_tube_turned_in_place_optimum_undoes_the_turn(straight_tube, moving_end, phi_deg):
    V, F, first, last, gc = straight_tube
    fixed, moving = (first, last) if moving_end == "last" else (last, first)
    phi = np.radians(phi_deg)
    p = vesselgp.JoinProblem(V, F, fixed, moving, turned_in_place(V, gc, moving, phi), gc=gc)
    res = vesselgp.minimize_torsion(p)
    err = np.degrees(wrap(res.angle + phi))
    assert abs(err) <= 0.5, f"optimum {np.degrees(res.angle):.3f} deg, expected {-phi_deg} (off by {err:.3f})"
    # the deformed mesh at the optimum is the rest mesh (0.5 degree at the end ring is 0.0087 r)
    assert np.abs(res.V - V).max() <= 0.01 * R0
    assert res.energy <= 1e-4
    # Eq. 8 of a uniform twist d over the whole free length (only the end rings are held):
    # E = d^2. Measured error 0.015 % (structured tube, the rod places an exact uniform twist);
    # the bound 0.1 % still fails a 1.5 % energy scale, and |alpha'| for alpha'^2 by far
    for d in (np.radians(60.0), -np.radians(90.0)):
        e = p.energy(-phi + d)
        assert abs(e - d * d) <= 1e-3 * d * d, (np.degrees(d), e, d * d)
    # the end turns the right way: +d about the outward tangent is a right-handed twist +d
    # (the handedness does not depend on which end moves or which way s runs)
    tw = np.degrees(p.profile(-phi + np.radians(60.0)).total_twist)
    assert abs(tw - 60.0) <= 0.5, tw


# ----------------------------------------------------------------------------- paper case 1


@pytest.fixture(scope="module")
def case1():
    c = paper_case(1, resolution=0.5)  # 24 points per ring, ~2k vertices
    p = vesselgp.JoinProblem(c.V, c.F, c.fixed, c.moving,
                             vesselgp.Frame(c.target_origin, c.target_tangent, c.target_normal))
    return c, p, vesselgp.minimize_torsion(p)


def reference_end_twist_deg(c, X):
    """Independent twist (degrees) of the deformed vessel from its held end to the last section bin."""
    sb, alpha = material_twist(c.V, X, c.truth.vertex_s)
    return np.degrees(alpha[-1] - alpha[0])


def test_case1_optimum_has_no_twist_by_an_independent_measurement(case1):
    c, p, res = case1
    # at the optimum: no twist (the reference itself is good to about 0.03 degrees on such tubes)
    t0 = reference_end_twist_deg(c, res.V)
    assert abs(t0) <= 0.5, t0
    # the zero of the independently measured twist, interpolated between +-10 degrees
    tm, tp = (reference_end_twist_deg(c, p.deform(res.angle + np.radians(d))) for d in (-10.0, 10.0))
    zero = -10.0 + 20.0 * (0.0 - tm) / (tp - tm)
    assert abs(zero) <= 0.5, zero
    # a positive turn of the end about the target tangent twists the vessel positively: the last
    # bin (s ~ 0.98) of a twist spread uniformly over the free part s > 0.1 holds about 98 % of it
    t30 = reference_end_twist_deg(c, p.deform(res.angle + np.radians(30.0)))
    assert 0.95 * 30.0 <= t30 <= 30.5, t30


@pytest.mark.parametrize("pre_deg", [-100.0, 65.0])
def test_case1_optimum_undoes_the_pre_rotation(case1, pre_deg):
    c, p, base = case1
    cp = paper_case(1, resolution=0.5, pre_rotation=np.radians(pre_deg))
    assert np.allclose(cp.V, c.V)
    # paper_case turns the target normal by +pre about the target tangent
    expected = rotate(c.target_normal, c.target_tangent, np.radians(pre_deg))
    assert np.allclose(cp.target_normal, expected, atol=1e-12)
    q = p.retarget(vesselgp.Frame(cp.target_origin, cp.target_tangent, cp.target_normal))
    res = vesselgp.minimize_torsion(q)
    err = np.degrees(wrap(res.angle - (base.angle - np.radians(pre_deg))))
    assert abs(err) <= 0.5, err
    # and independently: no twist at that optimum
    assert abs(reference_end_twist_deg(c, res.V)) <= 0.5
