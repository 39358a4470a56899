"""The wall's own circles along an axis and the check of an axis against them (issue #48: a fit that smoothed or
rejected its wall and answered an axis off the lumen, every other check passing)."""
from __future__ import annotations

import logging

import numpy as np
import pytest
from scipy.optimize import brentq

from _data import needs_real, repo_module, vmtk_lines
from _reference import polyline_distance
import vesselgp
from vesselgp import tolerances as tol
from vesselgp.checks import OffCentre, check_centre
from vesselgp.wall_circles import wall_circles

rs = repo_module("real_shapes")


def _rings(centre, radius, n_around=16, step=0.1, length=10.0, phase=0.0):
    """Rings every ``step`` along z of a wall whose centre is ``centre(z)`` (2,) and radius ``radius(z)`` from the
    axis z: the offsets in the frame (x, y) and the arc lengths."""
    z = np.arange(0.0, length + 1e-9, step)
    t = np.linspace(0, 2 * np.pi, n_around + 1)[:-1] + phase
    Z, T = np.meshgrid(z, t, indexing="ij")
    c = np.array([centre(zz) for zz in z])[:, None, :]
    r = np.array([radius(zz) for zz in z])[:, None]
    local = np.stack([c[..., 0] + r * np.cos(T), c[..., 1] + r * np.sin(T)], axis=-1).reshape(-1, 2)
    return Z.ravel(), local


@pytest.mark.parametrize("offset", [0.02, 0.3, 0.6])
def test_circles_off_the_axis_are_found_exactly(offset):
    """Kasa's fit is exact for vertices on circles however far off the axis: the centre, radius and no scatter."""
    s, local = _rings(lambda z: (offset * np.cos(0.3 * z), offset * np.sin(0.3 * z)), lambda z: 1.0, step=0.05)
    c = wall_circles(s, local, np.ones(len(s), bool), lambda x: np.ones_like(x), 1.0, 0.5)
    assert len(c.s0) == 21
    # a centre that turns along the window is fitted linearly: the error is its curvature over the window
    truth = offset * np.c_[np.cos(0.3 * c.s0), np.sin(0.3 * c.s0)]
    err = np.linalg.norm(c.centre - truth, axis=1)
    inner = (c.s0 > 1.0) & (c.s0 < 9.0)
    assert err[inner].max() <= 0.3 ** 2 * offset / 6 * 1.5
    assert np.abs(c.radius[inner] - 1.0).max() <= 0.3 ** 2 * offset ** 2
    assert np.hypot(*c.centre.T).min() > 0.8 * offset


def test_a_taper_and_a_polygon_leave_no_offset():
    """A cone (radius 1 -> 0.5) of 8-gons, each turned half a step from the last: no centre off the axis (an
    8-gon's vertices have no first harmonic about its centre) and the radius at each window's centre."""
    s, local = _rings(lambda z: (0.0, 0.0), lambda z: 1.0 - 0.05 * z, n_around=8, step=0.25)
    k = np.repeat(np.arange(41), 8)
    ang = np.pi / 8 * (k % 2)
    rot = np.c_[np.cos(ang) * local[:, 0] - np.sin(ang) * local[:, 1], np.sin(ang) * local[:, 0] + np.cos(ang) * local[:, 1]]
    c = wall_circles(s, rot, np.ones(len(s), bool), lambda x: 1.0 - 0.05 * x, 1.0, 0.5)
    assert np.hypot(*c.centre.T).max() <= 1e-9
    assert np.allclose(c.radius, 1.0 - 0.05 * c.s0, atol=2e-3)


def _arc_spread(alpha):
    """The smaller principal variance of unit directions spread evenly over an arc of half-angle ``alpha``."""
    sx = np.sin(alpha) / alpha
    var_x = 0.5 * (1 + np.sin(2 * alpha) / (2 * alpha)) - sx * sx
    var_y = 0.5 * (1 - np.sin(2 * alpha) / (2 * alpha))
    return min(var_x, var_y)


@pytest.mark.parametrize("factor, judged", [(1.01, True), (0.99, False)])
def test_a_window_is_judged_only_with_its_wall_spread_round_the_axis(factor, judged):
    """The spread guard at its edge: a wall that covers an arc whose directions' smaller variance is just above
    CHECK_CENTRE_MIN_SPREAD is judged, one just below is not (dense arcs: the continuous value)."""
    alpha = brentq(lambda a: _arc_spread(a) - tol.CHECK_CENTRE_MIN_SPREAD, 0.5, np.pi - 1e-6) * factor
    z = np.arange(0.0, 2.0 + 1e-9, 0.05)
    t = np.linspace(-alpha, alpha, 2001)
    Z, T = np.meshgrid(z, t, indexing="ij")
    local = np.c_[np.cos(T.ravel()), np.sin(T.ravel())]
    c = wall_circles(Z.ravel(), local, np.ones(T.size, bool), lambda x: np.ones_like(x), 1.0, 0.5)
    mid = np.abs(c.s0 - 1.0) < 1e-9
    assert mid.any() == judged


@pytest.mark.parametrize("offset, warned", [(0.099, False), (0.101, True)])
def test_the_warning_at_its_edge(offset, warned, caplog):
    """An axis CHECK_CENTRE_WARN radii off its wall's centre, found by the circles of exact rings (no scatter), is
    not named; one just past it is."""
    s, local = _rings(lambda z: (offset, 0.0), lambda z: 1.0)
    c = wall_circles(s, local, np.ones(len(s), bool), lambda x: np.ones_like(x), 1.0, 0.5)
    d = np.hypot(*c.centre.T) / c.radius
    k = int(np.argmax(d))
    with caplog.at_level(logging.WARNING, logger="vesselgp.checks"):
        check_centre(OffCentre(np.zeros(3), 0, c.s0[k] / 10.0, float(d[k]), float(c.se[k] / c.radius[k])), 10.0)
    assert ("off the centre of its wall" in caplog.text) == warned


@needs_real("xra_coronary_single_branch_open.stl")
def test_the_swept_coronary_is_centred_and_not_warned(caplog):
    """Exact circles swept along the real coronary's line: its fit is on the line (docs/accuracy.md), so the
    reported offset is within 1 % r and nothing is named."""
    ves = rs.case_vessel("coronary")
    with caplog.at_level(logging.WARNING, logger="vesselgp.checks"):
        gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    oc = gc.checks.off_centre
    assert oc is not None and oc.offset <= 0.01
    assert "off the centre of its wall" not in caplog.text
    assert gc.checks.to_dict()["off_centre"]["offset_radii"] == oc.offset


def _stenosis_gap(gc, name):
    """The farthest VMTK's line (outside truth) lies from the fitted axis over the real coronary's stenosis
    (s 0.20-0.27), in the fitted radii."""
    s = np.linspace(0.2, 0.27, 30)
    p, _ = gc.at(s)
    return float((polyline_distance(p, vmtk_lines(name)[0][0]) / gc.radius_at(s)).max())


@needs_real("xra_coronary_single_branch_open.stl")
def test_the_real_coronarys_stenosis_is_fitted_again_and_followed(caplog, monkeypatch):
    """The real X-ray coronary's stenosis (its radius 1.2 -> 0.85 mm within 2 mm): the first fit rejected most of
    its wall there as outliers (the smoothed radius lagging behind), its axis cut across, 0.29 radii from VMTK's
    line, and the check names it (offset 0.23 r, VMTK 0.28 r from the axis at the named place). Fitted again with
    the wall on its own circles taken back, the axis follows VMTK's line within 0.12 radii there (0.078
    measured: the lumen is not round there), and nothing is named."""
    from vesselgp import fit as vfit
    from vesselgp.io.meshfile import read_mesh
    from _data import REAL

    name = "xra_coronary_single_branch_open.stl"
    V, F = read_mesh(str(REAL / name))[:2]
    with monkeypatch.context() as m:
        m.setattr(vfit, "_off_its_wall", lambda oc: False)  # the first fit only
        with caplog.at_level(logging.WARNING, logger="vesselgp.checks"):
            first = vesselgp.fit_generalized_cylinder(V, F)
    oc = first.checks.off_centre
    assert "off the centre of its wall" in caplog.text
    assert oc.offset > tol.CHECK_CENTRE_WARN + tol.CHECK_CENTRE_SIGMAS * oc.se
    p, _ = first.at(np.array([oc.s]))
    d = float(polyline_distance(p, vmtk_lines(name)[0][0])[0]) / float(first.radius_at(oc.s)[0])
    assert abs(d - oc.offset) <= 0.1, (d, oc.offset)
    assert _stenosis_gap(first, name) >= 0.2
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="vesselgp"):
        gc = vesselgp.fit_generalized_cylinder(V, F)
    assert "fitted again with the wall on its own circles" in caplog.text
    assert "off the centre of its wall" not in caplog.text
    assert _stenosis_gap(gc, name) <= 0.12
    assert gc.checks.off_centre.offset <= tol.CHECK_CENTRE_WARN


@pytest.mark.parametrize("offset, again", [(0.099, False), (0.101, True)])
def test_a_fit_is_fitted_again_past_the_warnings_edge(offset, again):
    """The second fit is tried exactly where the check would warn (the same edge, exact rings: no scatter)."""
    from vesselgp import fit as vfit

    s, local = _rings(lambda z: (offset, 0.0), lambda z: 1.0)
    c = wall_circles(s, local, np.ones(len(s), bool), lambda x: np.ones_like(x), 1.0, 0.5)
    d = np.hypot(*c.centre.T) / c.radius
    k = int(np.argmax(d))
    assert vfit._off_its_wall(OffCentre(np.zeros(3), 0, 0.5, float(d[k]), float(c.se[k] / c.radius[k]))) == again


@needs_real("xrayangio_xcat-coronary-tree_open.stl")
def test_the_remeshed_thin_line_is_refused_where_its_exact_line_is_off():
    """The known wrong answer of 2026-12-07 (the thin XCAT line, 8 points around, remeshed: 12-31 % r off its exact
    line over 3 mm, every other check passing) is refused by one fit on its default node count (``n_nodes`` given:
    131; on the default nodes a sparse wall takes two fits and is followed, ``tests/test_real_shapes.py``): its axis
    runs off its wall's centre on a wall too sparse to fit again. The refusal names a place where the answer was
    wrong: the axis point it names is at least 0.1 radii from the exact centre line."""
    import re

    ves = rs.case_vessel("xcat_thin", remesh=True)
    with pytest.raises(vesselgp.NotTubularError, match="off the centre of its wall.*too sparse to fit again") as err:
        vesselgp.fit_generalized_cylinder(ves.V, ves.F, n_nodes=131)
    m = re.search(r"runs ([0-9.]+) radii .* at \(([-0-9.e]+), ([-0-9.e]+), ([-0-9.e]+)\) \(s = ([0-9.]+)\)", str(err.value))
    offset, point, s = float(m.group(1)), np.array([float(m.group(k)) for k in (2, 3, 4)]), float(m.group(5))
    t = ves.truth
    r = float(np.interp(s, t.s, t.radii))
    d = float(polyline_distance(point[None], t.centers)[0]) / r
    assert offset > tol.CHECK_CENTRE_WARN and d >= 0.1, (offset, d)


def _sparse_helix():
    """A helix (radius 2.5) swept 8 points around on aligned rings, fitted on 12 nodes (``SPARSE_NODES``): a wall
    dense enough per segment to be fitted again, still off its centre after that."""
    from vesselgp.synthetic import synthetic_vessel

    return synthetic_vessel("helix", radius=2.5, n_around=8, remesh=False)


SPARSE_NODES = 12


def test_a_single_vessel_still_off_its_wall_after_the_fit_again_is_refused(monkeypatch):
    """The 8-around helix on 12 nodes: answered, its axis is 0.42 radii off its exact line at worst (0.31 mean) and
    its check reads it 0.41 radii off its wall's centre, past CHECK_CENTRE_REFUSE. It is refused with the place
    and the advice to remesh, never answered with a warning only (the thin XCAT line, 8 around, on 20-35 nodes:
    42-56 % r off its line, answered so before)."""
    ves = _sparse_helix()
    monkeypatch.setattr(tol, "GC_PULL_WARN", np.inf)  # the fit once more without Eq. 2's pull answers it (below)
    with monkeypatch.context() as m:
        m.setattr(tol, "CHECK_CENTRE_REFUSE", np.inf)
        gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F, n_nodes=SPARSE_NODES)
    t = ves.truth
    st = t.s * t.length
    inner = (st > 2 * t.radii[0]) & (st < t.length - 2 * t.radii[-1])
    assert (polyline_distance(t.centers, gc.dense_points) / t.radii)[inner].max() > 0.3
    with pytest.raises(vesselgp.NotTubularError, match="off the centre of its wall.*also fitted again.*remesh"):
        vesselgp.fit_generalized_cylinder(ves.V, ves.F, n_nodes=SPARSE_NODES)


@pytest.mark.parametrize("factor, refused", [(0.99, True), (1.01, False)])
def test_the_off_centre_refusal_at_its_edge(monkeypatch, factor, refused):
    """CHECK_CENTRE_REFUSE at 0.99 and 1.01 of the 8-around helix's measured offset less four standard errors (read
    from the fit with the refusal off): refused just under it, answered (and named in a WARNING) just over."""
    ves = _sparse_helix()
    monkeypatch.setattr(tol, "GC_PULL_WARN", np.inf)  # the fit once more without Eq. 2's pull answers it
    monkeypatch.setattr(tol, "CHECK_CENTRE_REFUSE", np.inf)
    a = vesselgp.fit_generalized_cylinder(ves.V, ves.F, n_nodes=SPARSE_NODES).checks.off_centre
    edge = a.offset - tol.CHECK_CENTRE_SIGMAS * a.se
    assert edge > tol.CHECK_CENTRE_WARN
    monkeypatch.setattr(tol, "CHECK_CENTRE_REFUSE", factor * edge)
    if refused:
        with pytest.raises(vesselgp.NotTubularError, match="off the centre of its wall"):
            vesselgp.fit_generalized_cylinder(ves.V, ves.F, n_nodes=SPARSE_NODES)
    else:
        gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F, n_nodes=SPARSE_NODES)
        assert gc.checks.off_centre.offset == a.offset


@pytest.mark.parametrize("extra, sparse", [(0, True), (1, False)])
def test_a_wall_is_sparse_up_to_its_vertices_per_segment(extra, sparse):
    """The sparse wall's edge: GC_LAMBDA_VERTICES data vertices per segment of a 40-node axis is sparse (refused
    when off its wall's centre), one more vertex is not (fitted again)."""
    from vesselgp import fit as vfit

    assert vfit._sparse_wall(tol.GC_LAMBDA_VERTICES * 39 + extra, 40) == sparse


def test_the_offsets_uncertainty_covers_its_error_and_holds_the_warning_back(caplog):
    """A wall 0.12 radii off the axis that scatters radially (5 % of the radius, seeded): in every window the
    reported standard error covers the offset's error four times over (the uncertainty is the real one), and where
    the offset is past CHECK_CENTRE_WARN but not past it by four standard errors, nothing is named."""
    rng = np.random.default_rng(7)
    s, local = _rings(lambda z: (0.12, 0.0), lambda z: 1.0, n_around=12, step=0.25, length=20.0)
    rho = np.hypot(*(local - [0.12, 0.0]).T)
    local = [0.12, 0.0] + (local - [0.12, 0.0]) * (1.0 + 0.05 * rng.standard_normal(len(s)) / rho)[:, None]
    c = wall_circles(s, local, np.ones(len(s), bool), lambda x: np.ones_like(x), 1.0, 0.5)
    err = np.linalg.norm(c.centre - [0.12, 0.0], axis=1)
    assert (err <= 4 * c.se).all() and c.se.min() > 0.005
    d, se = np.hypot(*c.centre.T) / c.radius, c.se / c.radius
    k = np.flatnonzero((d > tol.CHECK_CENTRE_WARN) & (d <= tol.CHECK_CENTRE_WARN + tol.CHECK_CENTRE_SIGMAS * se))
    assert len(k)
    with caplog.at_level(logging.WARNING, logger="vesselgp.checks"):
        for j in k:
            check_centre(OffCentre(np.zeros(3), 0, 0.5, float(d[j]), float(se[j])), 20.0)
    assert "off the centre of its wall" not in caplog.text


def test_a_synthetic_trees_axes_run_through_their_walls_centres():
    """A 3-tip tree made as segmentations are (marching cubes of exact tubes): away from its junction zones, mouths
    and ends, every window's wall is centred on the fitted axis within 0.5 % of the radius (3e-5 measured; with
    the junction zones judged, their flares read 2.5 %)."""
    from vesselgp.synthetic_tree import synthetic_tree

    t = synthetic_tree(parents=(-1, 0, 0), voxel=0.5, seed=3)
    tree = vesselgp.fit_vessel_tree(t.V, t.F)
    oc = tree.checks.off_centre
    assert oc is not None and oc.offset <= 0.005
    d, _, _, _ = t.truth.nearest(oc.point[None])
    assert d[0] <= 0.005 * tree.branches[oc.branch].radius_at(oc.s)[0]


def test_only_narrower_circles_take_their_wall_back():
    """The second fit's outlier test (vesselgp.fit._on_wall_circles) on a unit tube's wall, 32 points around: a
    stretch narrowed to 0.8 and one widened to 1.3, both rejected by the first test. The narrowing lies on its
    own circles, no wider than the smoothed fit's: taken back, all of it. The widening's circles are wider (a sac,
    a flare, a branch's mouth): none of it."""
    from vesselgp import fit as vfit

    def radius(z):
        return 0.8 if 4.0 <= z <= 6.0 else 1.3 if 12.0 <= z <= 14.0 else 1.0

    s, loc2 = _rings(lambda z: (0.0, 0.0), radius, n_around=32, step=0.1, length=18.0)
    local = np.c_[np.zeros(len(s)), loc2]
    rho = np.hypot(*loc2.T)
    sel = np.ones(len(s), bool)
    out = np.abs(rho - 1.0) > 0.04
    back = vfit._on_wall_circles(s, local, out, 0.01, sel, lambda x: np.ones_like(x))
    narrow, wide = out & (rho < 1.0), out & (rho > 1.0)
    inner = narrow & (np.abs(s - 5.0) < 0.25)  # nearest to the window wholly inside the stretch: on its circle
    assert back[inner].all() and not back[wide].any()


def _wall_centre_line(truth):
    """The exact wall's circle centres along a swept tube (Kasa's fit of each exact section, 720 angles, in the
    truth's frames): where the axis of a tube whose section is not round belongs."""
    th = np.linspace(0, 2 * np.pi, 721)[:-1]
    out = []
    for k, s in enumerate(truth.s):
        rho = truth.section_radius(np.full_like(th, s), th)
        p = np.c_[rho * np.cos(th), rho * np.sin(th)]
        c = np.linalg.lstsq(np.c_[2 * p, np.ones(len(th))], (p * p).sum(axis=1), rcond=None)[0]
        out.append(truth.centers[k] + c[0] * truth.frames[k, 1] + c[1] * truth.frames[k, 2])
    return np.array(out)


def test_a_one_sided_plaque_in_a_helix_is_fitted_again_and_followed(caplog, monkeypatch):
    """The real coronary's anatomy with exact truth: a helix (radius 1.5, 64 points around, clean rings) whose
    wall is pushed in on one side over a short stretch (a plaque: the radius times 1 - 0.4 g(s) cos^2 on one
    side, 5 % of its length wide), its wall's centre 0.17 radii off the swept line there. The first fit rejects
    that wall and runs 14 % r from the exact wall's centre line; the check finds it (0.142 r) and the second
    fit follows it within 6 % r (4.0 % measured) and is not named. (At 3 % of its length the first fit now
    follows within 5.4 % r itself, its check 0.052 r: not fitted again; before the taper's Newton step, issue
    #48, it rejected the wall there as at 5 %.)"""
    from vesselgp import fit as vfit
    from vesselgp.synthetic import synthetic_vessel

    ves = synthetic_vessel("helix", radius=1.5, n_around=64, remesh=False,
                           bulges=[{"s0": 0.5, "width": 0.05, "amplitude": -0.4, "lobes": 1, "phase": 0.0}])
    t = ves.truth
    C = _wall_centre_line(t)
    inner = (t.s > 0.1) & (t.s < 0.9)
    assert (np.linalg.norm(C - t.centers, axis=1) / t.radii).max() > 0.15  # the plaque moves the wall's centre

    def worst(gc):
        return float((polyline_distance(C, gc.dense_points) / t.radii)[inner].max())

    with monkeypatch.context() as m:
        m.setattr(vfit, "_off_its_wall", lambda oc: False)
        first = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    assert worst(first) > 0.1 and vfit._off_its_wall(first.checks.off_centre)
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="vesselgp"):
        gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    assert "fitted again with the wall on its own circles" in caplog.text
    assert "off the centre of its wall" not in caplog.text
    assert worst(gc) <= 1.5 * 0.040


@needs_real("xra_coronary_single_branch_open.stl")
def test_the_real_coronarys_dilatation_between_its_stenoses_is_where_vmtks_radii_have_it(monkeypatch):
    """With its radius following the stenoses (the second fit), the real coronary's stretch between two of them
    stands above its neighbours (1.32): a bulge. Outside truth: VMTK's inscribed radii along its line, through the
    same rule (vesselgp.bulges.bulges, same reach in VMTK's median radius), have one too, at least 1.3 above its
    neighbours, and the two peaks lie within two radii of each other along the vessel. The first fit, its radius
    lagging through the stenoses, reported none."""
    from vesselgp import fit as vfit
    from vesselgp.bulges import bulges
    from vesselgp.curves import chord_length
    from vesselgp.io.meshfile import read_mesh
    from _data import REAL

    name = "xra_coronary_single_branch_open.stl"
    V, F = read_mesh(str(REAL / name))[:2]
    P, R = vmtk_lines(name)[0]
    a = chord_length(P)
    s = np.linspace(0.0, 1.0, 2001)
    ref = bulges(s, np.interp(s * a[-1], a, R), a[-1], reach=tol.TREE_BULGE_REACH * float(np.median(R)))
    assert len(ref) == 1 and ref[0, 3] >= tol.TREE_BULGE_RATIO * ref[0, 4]
    peak = np.interp(ref[0, 2] * a[-1], a, np.arange(len(P)))
    vmtk_peak = P[int(round(peak))]
    tree = vesselgp.fit_vessel_tree(V, F)
    assert len(tree.bulges) == 1
    b = tree.bulges[0]
    assert b.ratio >= tol.TREE_BULGE_RATIO
    assert np.linalg.norm(b.peak - vmtk_peak) <= 2 * b.peak_radius
    with monkeypatch.context() as m:
        m.setattr(vfit, "_off_its_wall", lambda oc: False)
        assert not vesselgp.fit_vessel_tree(V, F).bulges


def test_the_cli_reports_the_axis_off_its_walls_centre_against_geometry(tmp_path, capsys):
    """`vesselgp fit` of a helix with a one-sided plaque (above): axis.json's checks.off_centre and the printed
    checks line give the same offset; its point is an axis point (on axis.json's centre line, within the
    sampling), and that point's distance to the exact wall's centre line agrees with the offset within 0.05 radii
    plus four standard errors (the window's centre against the nearest exact section's)."""
    import json

    import meshio

    from vesselgp.cli import main
    from vesselgp.synthetic import synthetic_vessel

    ves = synthetic_vessel("helix", radius=1.5, n_around=64, remesh=False,
                           bulges=[{"s0": 0.5, "width": 0.03, "amplitude": -0.4, "lobes": 1, "phase": 0.0}])
    path = tmp_path / "plaque.ply"
    meshio.write(str(path), meshio.Mesh(ves.V, [("triangle", ves.F)]))
    assert main(["fit", str(path), "-o", str(tmp_path / "out")]) == 0
    printed = capsys.readouterr().out
    d = json.loads((tmp_path / "out" / "axis.json").read_text())
    oc = d["checks"]["off_centre"]
    assert f"off its wall's centre by {oc['offset_radii']:.2g} radii" in printed
    P = np.asarray(d["centers"])
    assert float(polyline_distance(np.asarray(oc["point"])[None], P)[0]) <= 0.01 * 1.5
    C = _wall_centre_line(ves.truth)
    r = float(np.interp(oc["s"], ves.truth.s, ves.truth.radii))
    dist = float(polyline_distance(np.asarray(oc["point"])[None], C)[0]) / r
    assert abs(dist - oc["offset_radii"]) <= 0.05 + 4 * oc["standard_error_radii"], (dist, oc)


@pytest.mark.parametrize("n, judged", [(tol.CHECK_CENTRE_MIN_VERTICES, True), (tol.CHECK_CENTRE_MIN_VERTICES - 1, False)])
def test_a_window_needs_its_vertices(n, judged):
    """The vertex guard at its edge: one ring of CHECK_CENTRE_MIN_VERTICES points spread evenly round a circle 0.2
    off the axis is a window, judged, its centre found (the ridge holds its changes along the axis at zero); one
    point fewer is not judged."""
    t = np.linspace(0, 2 * np.pi, n + 1)[:-1]
    local = np.c_[0.2 + np.cos(t), np.sin(t)]
    c = wall_circles(np.full(n, 3.0), local, np.ones(n, bool), lambda x: np.ones_like(x), 1.0, 0.5)
    assert (len(c.s0) == 1) == judged
    if judged:
        assert np.allclose(c.centre[0], [0.2, 0.0], atol=1e-9) and abs(c.radius[0] - 1.0) < 1e-9
