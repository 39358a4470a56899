"""The rounded-tip test's ring checks held at their edges (issue #35, item 1).

On a whole mesh the tip test's checks overlap (an elliptic tube trips the ring aspect before its
roundness, a widening tube its radius before its speed), so no mesh puts one of them alone at a
known value. Each check is therefore held here on rings built from analytic curves: the points of
each ring are sampled on a known curve (an ellipse, a saddle, a trefoil, a circle moved along a
line) and carry their geodesic distance by construction, so the value the check compares is known
in closed form, and the rings go through the same statistics (``_rings``) and the same line fit
(``_axis_fit``) as on a mesh. Each check is tried just inside its tolerance (accepted) and just
outside it (refused), every other check being exactly satisfied.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from vesselgp import tolerances as tol
from vesselgp.mesh._ends_tips import (_axis_fit, _circles, _crossing, _cylinder_axis, _is_dome, _is_tube,
                                      _on_axis, _rings, _walls_across_one_axis)

R = 1.0
H = 0.05  # band width (the median edge): rings one band apart
NPTS = 96  # points per ring, uniform in angle (their scatter is then exact for harmonics below 96)


def _ring(center, radius_of, z_of=None, ellipse=(1.0, 1.0)):
    """Points of one ring about ``center`` in the plane z = const: angle theta uniform,
    radius ``radius_of(theta)``, semi-axes scaled by ``ellipse``, height ``z_of(theta)`` added."""
    th = 2.0 * np.pi * np.arange(NPTS) / NPTS
    r = radius_of(th)
    z = np.zeros_like(th) if z_of is None else z_of(th)
    return np.c_[ellipse[0] * r * np.cos(th), ellipse[1] * r * np.sin(th), z] + center


def _stack(rings):
    """Ring k's points at geodesic distance (k + 1/2) H (the middle of band k): V and g."""
    V = np.vstack(rings)
    g = np.repeat((np.arange(len(rings)) + 0.5) * H, [len(r) for r in rings])
    return V, g


# --------------------------------------------------------------------------- #
# planar circles: ring aspect and flatness (_circles)
# --------------------------------------------------------------------------- #
#: an ellipse sampled uniformly in its angle has scatter eigenvalues a^2 / 2 and b^2 / 2: the aspect
#: check refuses (b / a)^2 < ENDS_TIP_RING_ASPECT
ASPECT_EDGE = math.sqrt(tol.ENDS_TIP_RING_ASPECT)


@pytest.mark.parametrize("factor, accepted", [(1.03, True), (0.97, False)])
def test_ring_aspect_at_its_edge(factor, accepted):
    rings = [_ring([0, 0, -k * H], lambda t: np.full_like(t, R), ellipse=(1.0, factor * ASPECT_EDGE))
             for k in range(6)]
    rg = _rings(*_stack(rings), H, math.inf)
    assert np.allclose(rg["eig"][:, 1] / rg["eig"][:, 2], (factor * ASPECT_EDGE) ** 2)  # the analytic ratio
    assert _circles(rg["eig"], H) is accepted


#: a saddle ring (R cos t, R sin t, c cos 2t) has scatter eigenvalues R^2 / 2, R^2 / 2 and c^2 / 2: the
#: flatness check refuses c^2 / 2 > ENDS_TIP_RING_FLATNESS R^2 / 2 + (ENDS_TIP_BAND_EDGES H)^2 / 12
FLAT_EDGE = math.sqrt(tol.ENDS_TIP_RING_FLATNESS * R * R + (tol.ENDS_TIP_BAND_EDGES * H) ** 2 / 6.0)


@pytest.mark.parametrize("factor, accepted", [(0.97, True), (1.03, False)])
def test_ring_flatness_at_its_edge(factor, accepted):
    c = factor * FLAT_EDGE
    rings = [_ring([0, 0, -k * H], lambda t: np.full_like(t, R), z_of=lambda t: c * np.cos(2 * t))
             for k in range(6)]
    rg = _rings(*_stack(rings), H, math.inf)
    assert np.allclose(rg["eig"], [c * c / 2, R * R / 2, R * R / 2])
    assert _circles(rg["eig"], H) is accepted


# --------------------------------------------------------------------------- #
# the tube past the equator: speed, line, radius, roundness; the dome's profile (_is_tube)
# --------------------------------------------------------------------------- #
DSTAR = 0.5 * np.pi * R  # a hemisphere's equator
NBANDS = int(round((DSTAR + R) / H))  # the dome and one radius of tube, a band each
NTUBE = int(np.sum((np.arange(NBANDS) + 0.5) * H >= DSTAR))  # the tube's rings


def _tube_verdict(speed=1.0, offsets=None, radius=None, ripple=None, dome_bump=None, check=_is_tube):
    """Rings of a hemisphere of radius R (the dome, R sin(d / R)) and of the tube past its equator
    (one radius of it), built exactly, with one property changed; the verdict of ``check`` (``_is_tube``,
    or ``_is_dome``: the same without the tube rings' radius and roundness).

    speed : the tube rings' centres move down the axis by ``speed`` per unit geodesic distance
    offsets : (k,) sideways offset of each tube ring's centre (from the line)
    radius : (k,) radius of each tube ring
    ripple : (k,) amplitude e of r = R (1 + e cos 3t) of each tube ring (its spread is R e / sqrt 2)
    dome_bump : added to every dome ring's radius
    """
    d = (np.arange(NBANDS) + 0.5) * H
    tube = np.flatnonzero(d >= DSTAR)
    k = NTUBE
    offsets = np.zeros(k) if offsets is None else offsets
    radius = np.full(k, R) if radius is None else radius
    ripple = np.zeros(k) if ripple is None else ripple
    rings = []
    for i, di in enumerate(d):
        if di < DSTAR:  # the dome: centre on the axis at height R cos(d / R) above the equator
            rad = R * np.sin(di / R) + (dome_bump or 0.0)
            rings.append(_ring([0, 0, R * np.cos(di / R)], lambda t, rad=rad: np.full_like(t, rad)))
        else:
            j = i - tube[0]
            rings.append(_ring([offsets[j], 0, -speed * (di - DSTAR)],
                               lambda t, j=j: radius[j] * (1.0 + ripple[j] * np.cos(3 * t))))
    rg = _rings(*_stack(rings), H, math.inf)
    valid = rg["n"] >= tol.ENDS_MIN_RING
    valid[:1] = False
    fit = _axis_fit(rg["d"][tube], rg["C"][tube], rg["n"][tube], DSTAR)
    if check is _is_dome:
        return fit, _is_dome(rg, valid, fit, R, DSTAR, H)
    return fit, _is_tube(rg, valid, tube, fit, R, DSTAR, H)


def test_the_exact_hemisphere_on_its_tube_passes_every_check():
    fit, ok = _tube_verdict()
    assert ok and fit[2] == pytest.approx(1.0) and fit[3] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("speed, accepted", [
    (1.0 - 0.97 * tol.ENDS_TIP_SPEED_TOL, True), (1.0 - 1.03 * tol.ENDS_TIP_SPEED_TOL, False),
    (1.0 + 0.97 * tol.ENDS_TIP_SPEED_TOL, True), (1.0 + 1.03 * tol.ENDS_TIP_SPEED_TOL, False)])
def test_ring_speed_at_its_edges(speed, accepted):
    fit, ok = _tube_verdict(speed=speed)
    assert fit[2] == pytest.approx(speed)  # circles moved at that speed
    assert ok is accepted


@pytest.mark.parametrize("factor, accepted", [(0.97, True), (1.03, False)])
def test_ring_line_at_its_edge(factor, accepted):
    """Sideways offsets +e, -e, -e, +e, ... are orthogonal to a constant and to a linear trend over
    equally spaced rings (in blocks of four), so the line fit keeps them whole: rms residual e; refused when
    e > ENDS_TIP_LINE_TOL R + ENDS_TIP_EDGE_SLACK H."""
    k = NTUBE
    edge = tol.ENDS_TIP_LINE_TOL * R + tol.ENDS_TIP_EDGE_SLACK * H
    e = factor * edge
    pattern = np.resize([1.0, -1.0, -1.0, 1.0], k)
    if k % 4:  # an incomplete block would leave a trend: fill the rest with zero offsets
        pattern[k - k % 4:] = 0.0
        e *= math.sqrt(k / (k - k % 4))
    fit, ok = _tube_verdict(offsets=e * pattern)
    assert fit[3] == pytest.approx(factor * edge, rel=1e-9)
    assert ok is accepted


@pytest.mark.parametrize("factor, accepted", [(0.96, True), (1.04, False)])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_tube_ring_radius_at_its_edge(factor, accepted, sign):
    k = NTUBE
    radius = np.full(k, R)
    radius[k // 2] = R * (1.0 + sign * factor * tol.ENDS_TIP_RADIUS_TOL)  # one ring off by that fraction
    assert _tube_verdict(radius=radius)[1] is accepted


@pytest.mark.parametrize("factor, accepted", [(0.97, True), (1.03, False)])
def test_ring_roundness_at_its_edge(factor, accepted):
    """r = R (1 + e cos 3t): mean R, standard deviation R e / sqrt 2, centroid and scatter those of a
    circle (three-fold symmetric); refused when R e / sqrt 2 > ENDS_TIP_ROUND_TOL R + ENDS_TIP_EDGE_SLACK H."""
    k = NTUBE
    ripple = np.zeros(k)
    ripple[1] = factor * math.sqrt(2.0) * (tol.ENDS_TIP_ROUND_TOL + tol.ENDS_TIP_EDGE_SLACK * H / R)
    assert _tube_verdict(ripple=ripple)[1] is accepted


@pytest.mark.parametrize("factor, accepted", [(0.96, True), (1.04, False)])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_dome_profile_at_its_edge(factor, accepted, sign):
    """The dome's rings (from ENDS_TIP_DOME_FROM to ENDS_TIP_DOME_TO of the equator's distance) off
    R sin(d / R) by that fraction of R."""
    assert _tube_verdict(dome_bump=sign * factor * tol.ENDS_TIP_RADIUS_TOL * R)[1] is accepted


@pytest.mark.parametrize("body", ["ripple", "widening"])
def test_a_dome_on_a_body_that_is_no_round_tube_is_a_dome_only(body):
    """Issue #44: a sac's dome on a body that is no round tube (lobed: r = R (1 + e cos 3t) with e twice the
    roundness limit; or widening to 1.5 R within a radius past the equator) fails the tube test but passes
    the dome test (_is_dome: the line and the dome's profile only), which a sac's dome takes."""
    k = NTUBE
    kw = ({"ripple": np.full(k, 2 * math.sqrt(2.0) * tol.ENDS_TIP_ROUND_TOL)} if body == "ripple" else
          {"radius": R * (1.0 + 0.5 * np.arange(1, k + 1) / k)})
    assert _tube_verdict(**kw)[1] is False
    assert _tube_verdict(**kw, check=_is_dome)[1] is True


@pytest.mark.parametrize("factor, accepted", [(0.96, True), (1.04, False)])
def test_the_dome_only_test_keeps_the_dome_profile_and_line_at_their_edges(factor, accepted):
    """_is_dome refuses what _is_tube refuses on the dome and the line: the dome's rings off R sin(d / R) by
    (1.04) ENDS_TIP_RADIUS_TOL R, and tube ring centres moving at 1 +- (1.04) ENDS_TIP_SPEED_TOL, on a lobed
    body that alone would pass as a dome."""
    ripple = np.full(NTUBE, 2 * math.sqrt(2.0) * tol.ENDS_TIP_ROUND_TOL)
    assert _tube_verdict(ripple=ripple, dome_bump=factor * tol.ENDS_TIP_RADIUS_TOL * R, check=_is_dome)[1] is accepted
    assert _tube_verdict(ripple=ripple, speed=1.0 + factor * tol.ENDS_TIP_SPEED_TOL, check=_is_dome)[1] is accepted


# --------------------------------------------------------------------------- #
# the tube's walls and the tip's place on its axis
# --------------------------------------------------------------------------- #
#: a cone of half-angle phi: unit normals (cos phi cos t, cos phi sin t, sin phi) have scatter
#: eigenvalues sin^2 phi and cos^2 phi / 2 (twice): ratio 2 tan^2 phi
SPREAD_EDGE = math.atan(math.sqrt(tol.ENDS_TIP_AXIS_SPREAD / 2.0))


@pytest.mark.parametrize("factor, accepted", [(0.97, True), (1.03, False)])
def test_wall_normals_across_one_axis_at_their_edge(factor, accepted):
    phi = factor * SPREAD_EDGE
    t = 2.0 * np.pi * np.arange(NPTS) / NPTS
    N = np.c_[np.cos(phi) * np.cos(t), np.cos(phi) * np.sin(t), np.full_like(t, np.sin(phi))]
    axis, flatness = _cylinder_axis(N, np.ones(NPTS))
    assert abs(axis[2]) == pytest.approx(1.0) and flatness == pytest.approx(2.0 * math.tan(phi) ** 2)
    assert _walls_across_one_axis(flatness) is accepted


@pytest.mark.parametrize("factor, accepted", [(0.97, True), (1.03, False)])
def test_tip_on_the_axis_at_its_edge(factor, accepted):
    a = math.radians(factor * tol.ENDS_TIP_AXIS_DEG)
    axis = np.array([0.3, -0.4, np.sqrt(0.75)])
    side = np.cross(axis, [1.0, 0.0, 0.0])
    side /= np.linalg.norm(side)
    u = 2.5 * (math.cos(a) * axis + math.sin(a) * side)  # the tip seen at angle a from the centre
    assert _on_axis(u, axis) is accepted


@pytest.mark.parametrize("run, crossed", [(tol.ENDS_TIP_CROSS_RINGS, True), (tol.ENDS_TIP_CROSS_RINGS - 1, False)])
def test_equator_needs_its_run_of_narrow_rings(run, crossed):
    """A noisy ring near the tip may be narrow alone: the equator is where ENDS_TIP_CROSS_RINGS
    consecutive valid rings are narrower than a hemisphere's, not fewer."""
    narrow = np.zeros(12, dtype=bool)
    narrow[4:4 + run] = True
    assert (4 in _crossing(np.ones(12, dtype=bool), narrow)) is crossed
    assert (len(_crossing(np.ones(12, dtype=bool), narrow)) > 0) is crossed


# --------------------------------------------------------------------------- #
# which maxima are examined: persistence and separation
# --------------------------------------------------------------------------- #
@pytest.mark.parametrize("factor, examined", [(1.02, True), (0.98, False)])
def test_a_maximum_is_examined_from_its_persistence_edge(factor, examined):
    """D along a path graph rises to 10 h, falls to a saddle at 6 h and rises again to 6 h + p: the
    second maximum's persistence is p exactly (the elder rule); it is examined when p is at least
    ENDS_TIP_MIN_PERSISTENCE h."""
    import scipy.sparse as sp

    from vesselgp.mesh._ends_tips import _worth_examining, persistent_maxima

    h = 0.2
    p = factor * tol.ENDS_TIP_MIN_PERSISTENCE * h
    D = np.concatenate([np.linspace(0.0, 10 * h, 11), np.linspace(10 * h, 6 * h, 6)[1:],
                        np.linspace(6 * h, 6 * h + p, 6)[1:]])
    n = len(D)
    E = np.c_[np.arange(n - 1), np.arange(1, n)]
    G = sp.csr_array((np.ones(2 * (n - 1)), (np.r_[E[:, 0], E[:, 1]], np.r_[E[:, 1], E[:, 0]])), shape=(n, n))
    cands = persistent_maxima(G, E, D, np.ones(n, dtype=bool))
    assert [c[0] for c in cands] == [10, n - 1] and cands[1][1] == pytest.approx(p)
    assert ((n - 1) in [c[0] for c in _worth_examining(cands, h)]) is examined


@pytest.mark.parametrize("factor, on_it", [(0.98, True), (1.02, False)])
def test_a_maximum_near_a_found_tip_is_on_it_at_its_edge(factor, on_it):
    from vesselgp.mesh._ends_tips import _on_a_tip

    tip = {"center": np.array([1.0, 2.0, 3.0]), "radius": 2.0}
    x = tip["center"] + factor * tol.ENDS_TIP_SEPARATION * tip["radius"] * np.array([0.6, 0.0, -0.8])
    assert _on_a_tip(x, [tip]) is on_it
