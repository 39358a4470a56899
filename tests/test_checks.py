"""A fit checked against its mesh: every end reached, the whole wall covered (issue #44, item 1).

Truths come from construction: the siphon tree's Bezier centre lines, a tube's exact radius, a
tree whose end is left out of the fit on purpose (its vessel is known to have no axis).
"""
from __future__ import annotations

from types import SimpleNamespace as NS

import numpy as np
import pytest

import vesselgp
from vesselgp import tolerances as tol
from vesselgp.checks import check_end_gaps, end_gaps, wall_coverage
from vesselgp.errors import NotTubularError
from vesselgp.mesh import mesh_topology
from vesselgp.prepared import PreparedMesh
from vesselgp.synthetic import synthetic_tree
from vesselgp.synthetic_anatomy import siphon_tree


@pytest.fixture(scope="module")
def siphon():
    t = siphon_tree()
    return t, vesselgp.fit_vessel_tree(t.V, t.F)


def test_a_siphon_and_a_looping_branch_have_an_axis_from_end_to_end(siphon):
    """The trunk turns back on itself before its junction and one child loops back after it: every
    path starts at the root's centre and ends at its tip's (issue #44: the half-space cut at the
    junctions left the first 8.6 radii of both paths and the looping child's last 1.7 radii without
    an axis), and follows the true centre line from end to end: every true centre-line point one
    radius or more from the ends and three trunk radii from the junction lies within 2 % of its radius
    of the path's axis (0.4 % measured)."""
    import igl

    t, tree = siphon
    assert [p.ends for p in tree.paths] == [(0, 1), (0, 2)]
    J = t.truth.branches[2].centers[0]
    for p, truth in zip(tree.paths, t.truth.paths):
        assert np.linalg.norm(p.centers[0] - t.truth.ends[0].center) < 1e-9
        tip = t.truth.ends[p.ends[1]]
        assert np.linalg.norm(p.centers[-1] - tip.center) < 0.05 * tip.radius
        L = p.dense_points
        d = np.sqrt(igl.point_mesh_squared_distance(truth.centers, L, np.c_[np.arange(len(L) - 1),
                                                                            np.arange(1, len(L))])[0])
        judged = ((truth.s > truth.radii[0]) & (truth.s < truth.s[-1] - truth.radii[-1])
                  & (np.linalg.norm(truth.centers - J, axis=1) > 3 * 2.6))
        assert judged.sum() > 0.7 * len(judged) and judged[(truth.s > 3.0) & (truth.s < 26.0)].all()
        assert np.max(d[judged] / truth.radii[judged]) < 0.02
    assert tree.checks.worst_end_gap < 0.05
    assert tree.checks.covered_fraction > 0.999 and tree.checks.largest_uncovered < 0.3


@pytest.fixture(scope="module")
def tree4():
    return synthetic_tree(levels=2, voxel=0.5)


@pytest.mark.parametrize("left_out", [1, 4])
def test_a_vessel_whose_end_is_left_out_is_refused_where_it_is(tree4, left_out):
    """A 4-tip tree fitted with one tip left out of its ends (as a missed end would be): the tree of the
    other three has no axis in that tip's vessel, whose wall the fit then does not describe. It is refused
    with the piece's place, a point on the left-out vessel (nearest its own centre line of every branch),
    and its size (2.5-6.9 radii of wall measured, against the limit of 1.5). (With the medial zones and
    bulges exempt whatever their reach, as first measured, two of the four left-out vessels passed.)"""
    t = tree4
    pm = PreparedMesh(t.V, t.F)
    keep = [e for k, e in enumerate(pm.ends) if k != left_out]
    with pytest.raises(NotTubularError, match=r"without an axis at \(") as ei:
        vesselgp.fit_vessel_tree(PreparedMesh(t.V, t.F, ends=keep))
    msg = str(ei.value)
    point = np.array([float(x) for x in msg.split("without an axis at (")[1].split(")")[0].split(",")])
    missing = pm.ends[left_out]
    _, _, branch, _ = t.truth.nearest(point[None])
    tip_branch = min(t.truth.ends[1:], key=lambda e: np.linalg.norm(e.center - missing.center)).branch
    assert branch[0] == tip_branch
    size = float(msg.split("as much wall as ")[1].split(" radii")[0])
    assert size > tol.CHECK_MAX_UNCOVERED
    # with every end, the same mesh is covered
    assert vesselgp.fit_vessel_tree(pm).checks.largest_uncovered < 0.5


def _window_tube(rho_out, height, width=np.pi / 2, n_around=64, n_rings=401, length=10.0):
    """A unit tube along z (rings every length / (n_rings - 1)), a window of its wall ``height`` long and
    ``width`` radians wide at mid length pushed out to radius ``rho_out``: V, F, Voronoi-like areas
    (the pushed-out cell's exact area on its cylinder), D (distance to the axis) and R = 1."""
    t = np.linspace(0, 2 * np.pi, n_around + 1)[:-1]
    z = np.linspace(0, length, n_rings)
    T, Z = np.meshgrid(t, z)
    dz, dt = z[1] - z[0], t[1] - t[0]
    out = (np.abs(Z - length / 2) < height / 2 + 1e-9) & (T < width - 1e-9)
    rho = np.where(out, rho_out, 1.0).ravel()
    V = np.c_[rho * np.cos(T.ravel()), rho * np.sin(T.ravel()), Z.ravel()]
    i = (np.arange(n_rings - 1)[:, None] * n_around + np.arange(n_around)).ravel()
    j = i - i % n_around + (i + 1) % n_around
    F = np.r_[np.c_[i, j, i + n_around], np.c_[j, j + n_around, i + n_around]]
    A = rho * dt * dz
    A[:n_around] /= 2
    A[-n_around:] /= 2
    return V, F, A, rho, np.ones(len(V))


def _coverage(V, F, A, D, R, zone=None, zone_radius=None, balls=None):
    no = np.zeros(len(V), bool)
    return wall_coverage(V, mesh_topology(F, len(V)).adjacency, A, D, R, no, no if zone is None else zone,
                         R if zone_radius is None else zone_radius, np.zeros(len(V), np.int64), balls)


@pytest.mark.parametrize("limit", ["CHECK_MAX_UNCOVERED", "CHECK_WARN_UNCOVERED"])
@pytest.mark.parametrize("factor", [0.97, 1.03])
def test_the_uncovered_limit_at_its_edge(factor, limit, caplog):
    """A unit tube with a window of its wall pushed out to 1.6 (0.6 > CHECK_COVER_TOLERANCE off its radius):
    the window's area over 2 pi is its size in radii of tube wall. The window is 90 degrees wide and h long
    (its exact area 1.6 (pi / 2) h, on the rings' grid), h chosen so that the size is 0.97 and 1.03 times
    CHECK_MAX_UNCOVERED: the first passes the check, the second is refused, naming the size; and 0.97 and
    1.03 times CHECK_WARN_UNCOVERED: the first passes unsaid, the second with a WARNING naming it."""
    import logging

    from vesselgp.checks import check_coverage

    rings_per_unit = 40
    size = factor * getattr(tol, limit)
    h = size * 2 * np.pi / (1.6 * np.pi / 2)  # area 1.6 (pi/2) h = size * 2 pi
    n = int(round(h * rings_per_unit))  # rows of cells: the window's rings span n + 1 rows of vertices
    V, F, A, D, R = _window_tube(1.6, n / rings_per_unit, n_rings=10 * rings_per_unit + 1)
    frac, pieces = _coverage(V, F, A, D, R)
    exact = A[np.abs(D - 1.6) < 1e-12].sum() / (2 * np.pi)
    assert len(pieces) == 1 and pieces[0].size == pytest.approx(exact, rel=1e-12)
    assert abs(exact / getattr(tol, limit) - factor) < 0.02
    assert frac == pytest.approx(1 - A[np.abs(D - 1.6) < 1e-12].sum() / A.sum())
    if limit == "CHECK_MAX_UNCOVERED" and factor > 1:
        with pytest.raises(NotTubularError, match=rf"as much wall as {exact:.1f} radii"):
            check_coverage(pieces, 10.0)
        return
    with caplog.at_level(logging.WARNING, logger="vesselgp.checks"):
        check_coverage(pieces, 10.0)
    warned = any("are not described by the fit" in r.getMessage() for r in caplog.records)
    assert warned == (limit == "CHECK_MAX_UNCOVERED" or factor > 1)


@pytest.mark.parametrize("rho, covered", [(1.48, True), (1.52, False), (0.52, True), (0.48, False)])
def test_the_cover_tolerance_at_its_edge(rho, covered):
    """A wall vertex is described when its distance to the axis is within CHECK_COVER_TOLERANCE (half) of
    the fitted radius: a window pushed out to 1.48 or in to 0.52 is covered, to 1.52 or 0.48 is not."""
    assert abs(abs(rho - 1) / tol.CHECK_COVER_TOLERANCE - 1) < 0.05
    V, F, A, D, R = _window_tube(rho, 1.0)
    frac, pieces = _coverage(V, F, A, D, R)
    assert (frac == 1.0 and not pieces) == covered


@pytest.mark.parametrize("reach, covered", [(1.96, True), (2.04, False)])
def test_the_zone_reach_at_its_edge(reach, covered):
    """In a medial zone or a bulge the wall out to CHECK_ZONE_REACH times the zone's radius is the zone's:
    a window 1.2 long pushed out to 1.96 / 2.04 times the zone's radius (1, the tube's) inside a zone that
    spans it is covered / not."""
    assert abs(reach / tol.CHECK_ZONE_REACH - 1) < 0.03
    V, F, A, D, R = _window_tube(reach, 1.2)
    zone = np.abs(V[:, 2] - 5.0) < 1.0
    frac, pieces = _coverage(V, F, A, D, R, zone=zone, zone_radius=R)
    assert (not pieces) == covered
    # counted in the zone's radius, not the fitted one: with a bulge's peak radius of 1.5 both are covered
    assert not _coverage(V, F, A, D, R, zone=zone, zone_radius=np.where(zone, 1.5, 1.0))[1]


@pytest.mark.parametrize("factor, covered", [(1.03, True), (0.97, False)])
def test_the_lumens_spheres_cover_the_wall_they_touch_at_their_edge(factor, covered):
    """On a tree the lumen's maximal spheres cover the wall within 1 + CHECK_COVER_TOLERANCE of their radius
    (a junction's flare). A unit tube's window pushed out to 1.6 (uncovered by the tube) and one sphere on the
    axis at the window's middle, of radius 1.6 / 1.5 times 1.03 or 0.97 over the window's half-height and
    reach: the window's farthest vertex lies at sqrt(1.6^2 + 0.25^2) from its centre."""
    V, F, A, D, R = _window_tube(1.6, 0.5)
    far = np.hypot(1.6, 0.25)  # the window's corners, 0.25 off its middle along the axis
    balls = (np.array([[0.0, 0.0, 5.0]]), np.array([factor * far / (1.0 + tol.CHECK_COVER_TOLERANCE)]))
    frac, pieces = _coverage(V, F, A, D, R, balls=balls)
    assert (not pieces) == covered
    if not covered:  # only the window's corners, beyond the sphere, are left
        assert np.all(np.linalg.norm(np.array([p.point for p in pieces]) - [0, 0, 5.0], axis=1) > 0.97 * 1.6)


@pytest.mark.parametrize("gap, refused", [(0.98, False), (1.02, True)])
def test_an_end_gap_at_its_edge(gap, refused):
    """A path's first or last point farther than CHECK_END_GAP radii from its end's centre is refused as a
    fault, naming the path, the end and the gap; 0.98 radii passes, 1.02 does not (either side)."""
    ends = [NS(center=np.zeros(3), radius=2.0, describe=lambda: "open r=2 at (0, 0, 0)"),
            NS(center=np.array([30.0, 0, 0]), radius=1.5, describe=lambda: "open r=1.5 at (30, 0, 0)")]
    for side in (0, 1):
        C = np.c_[np.linspace(0, 30, 31), np.zeros(31), np.zeros(31)]
        e = ends[side]
        C[-side] = e.center + gap * tol.CHECK_END_GAP * e.radius * np.array([0.0, 0.6, 0.8])
        p = NS(ends=(0, 1), centers=C)
        gaps = end_gaps([p], ends)
        assert gaps[0, side] == pytest.approx(gap * tol.CHECK_END_GAP) and gaps[0, 1 - side] == 0
        if refused:
            with pytest.raises(NotTubularError, match=rf"path 0 -> 1 {('starts', 'stops')[side]} {gap:.2f} end "
                                                      rf"radii from the centre of end {side}"):
                check_end_gaps([p], ends, gaps, 30.0)
        else:
            check_end_gaps([p], ends, gaps, 30.0)


def test_a_single_vessel_reports_its_checks():
    """A tube's fit reports its checks: both ends reached (pinned at their centres) and its wall covered;
    a path between two ends of a branching mesh is checked for its gaps only."""
    from vesselgp.synthetic import synthetic_vessel

    v = synthetic_vessel("arc", radius=1.5, n_around=24, remesh=False)
    gc = vesselgp.fit_generalized_cylinder(v.V, v.F)
    assert gc.checks.worst_end_gap < 1e-9 and gc.checks.covered_fraction == 1.0 and not gc.checks.uncovered
    t = synthetic_tree(levels=1, voxel=0.6)
    gc = vesselgp.fit_generalized_cylinder(t.V, t.F, ends=(0, 1))
    assert gc.checks.covered_fraction is None and gc.checks.worst_end_gap < 0.05


@pytest.mark.parametrize("reach, exempt", [(0.98, True), (1.02, False)])
@pytest.mark.parametrize("child_radius", [1.0, 3.0])
def test_the_mouth_reaches_no_farther_than_the_zones_at_its_edge(reach, exempt, child_radius):
    """Issue #44: a child's mouth (its wall up to CHECK_MOUTH_RADII of its radius past its junction zone) is
    exempt out to CHECK_ZONE_REACH times the larger of the child's fitted radius and its parent's end radius
    (2) from the child's axis: a vertex in the mouth at 0.98 / 1.02 times that is exempt / judged. (A sac
    beside a daughter, whose wall has its foot at the daughter's start, hid there on the gmsh intracranial
    aneurysm.) Past the mouth nothing is exempt; near the junction everything is."""
    from vesselgp.checks import _zones

    rp = 2.0
    bound = tol.CHECK_ZONE_REACH * max(child_radius, rp)
    parent = NS(radii=np.full(5, rp))
    child = NS(radii=np.full(5, child_radius), length=40.0, vertex_s=np.array([0.01, 0.5, 0.01]))
    V = np.array([[50.0, 0, 0], [50.0, 0, 0], [0.5, 0, 0]])  # the junction at the origin
    tree = NS(junctions=[np.zeros(3)], junction_branch=[0], branches=[parent, child], parent=[-1, 0],
              vertex_branch=np.array([1, 1, 1]), junction_zone=[0.0, 0.0], medial_zones=[np.zeros((0, 2))] * 2,
              bulges=(), paths=())
    D = np.full(3, reach * bound)
    R = np.full(3, child_radius)
    ex, zone, _ = _zones(V, tree, D, R)
    assert ex.tolist() == [exempt, False, True] and not zone.any()


@pytest.mark.parametrize("at, exempt", [(0.99, True), (1.01, False)])
def test_the_wall_near_each_junction_is_exempt_within_its_own_radii(at, exempt):
    """Issue #47 (the junctions' balls found in one pass): a vertex at 0.99 / 1.01 times CHECK_JUNCTION_RADII times
    the radius at the end of the junction's branch, from either of two junctions whose branches end at radii 2 and
    0.5, is exempt / not (the other junction is far); a vertex far from both is not."""
    from vesselgp.checks import _zones

    radii = (2.0, 0.5)
    J = np.array([[0.0, 0, 0], [100.0, 0, 0]])
    d = at * tol.CHECK_JUNCTION_RADII * np.array(radii)
    u = np.array([0.6, 0.0, 0.8])
    V = np.vstack([J[0] + d[0] * u, J[1] - d[1] * u, [50.0, 50, 50]])
    branches = [NS(radii=np.full(5, r)) for r in radii]
    tree = NS(junctions=list(J), junction_branch=[0, 1], branches=branches, parent=[-1, -1],
              vertex_branch=np.zeros(3, np.int64), junction_zone=[0.0, 0.0], medial_zones=[np.zeros((0, 2))] * 2,
              bulges=(), paths=())
    ex, zone, _ = _zones(V, tree, np.zeros(3), np.ones(3))
    assert ex.tolist() == [exempt, exempt, False] and not zone.any()


def test_a_bulge_zone_is_the_path_vertices_whose_foot_lies_in_its_range():
    """A bulge's zone is the vertices of its path whose foot on the path's axis lies within its s range, with
    its peak radius: on a path stored on rows 40.. of the mesh (a tree's path keeps its arrays on its own
    rows), against the path's parameters read over the whole mesh."""
    from vesselgp._per_vertex import on_rows
    from vesselgp.checks import _zones

    t = synthetic_tree(levels=0, voxel=0.6)
    gc = vesselgp.fit_generalized_cylinder(t.V, t.F)
    n = len(gc.vertex_s) + 40
    path = on_rows(gc, np.arange(40, n), n)
    bulge = NS(paths=(0,), s_range=(0.3, 0.5), peak_radius=9.0, wall=np.zeros(0, np.int64))
    tree = NS(junctions=[], junction_branch=[], branches=[], parent=[], vertex_branch=np.zeros(n, np.int64),
              junction_zone=[], medial_zones=[], bulges=(bulge,), paths=(path,))
    ex, zone, zone_radius = _zones(np.zeros((n, 3)), tree, np.zeros(n), np.ones(n))
    s = path.vertex_s  # over the whole mesh, NaN on rows 0-39
    want = (s >= 0.3) & (s <= 0.5)
    assert want.sum() > 100 and np.array_equal(zone, want) and not ex.any()
    assert np.all(zone_radius[want] == 9.0) and np.all(zone_radius[~want] == 1.0)
