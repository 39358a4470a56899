"""fit_vessel_tree against the exact synthetic trees and on the real aorto-iliac Y (issue #13, item 2-3).

The truth is the synthetic trees' Bezier centre lines (``TreeTruth.nearest``), never the
library's fit; the real Y is checked against its own surface with libigl's exact winding
number and point-to-mesh distance, computed here.
"""
from __future__ import annotations

import dataclasses

import igl
import numpy as np
import pytest

import vesselgp
from vesselgp.synthetic import THREE_TIP_PARENTS, synthetic_tree
from vesselgp.branches import branch_decomposition
from vesselgp.inside import sharp_bends
from vesselgp.tree import VesselTree, fit_vessel_tree

from _data import REAL
from _docs import figure, table

# docs/accuracy.md "Vessel trees" table, per tree: worst and mean path-axis error (% of the true radius) away
# from junctions (2 r) and tips (1.5 r), worst radius error (%, same stretch), junction distance from the true
# one (parent end radii); the tests assert 1.5 x these figures.
_TREES = {name: [figure(c) if c else None for c in cells]
          for name, cells in table("accuracy.md", "tree", "vertices", "path axis, worst (%)").items()}
_ROW = {"4 tips": "4 tips (2 levels)", "3 tips": "3 tips (one child splits again)", "8 tips": "8 tips (3 levels)"}
DOCS_AXIS = {name: tuple(_TREES[row][1:3]) for name, row in _ROW.items()}
DOCS_RADIUS_MAX = {name: _TREES[row][3] for name, row in _ROW.items()}
DOCS_JUNCTION = max(_TREES[row][4] for row in _ROW.values())  # one bound for the three trees
# docs/accuracy.md "segmentation-like tree" (prose under the table): the voxel staircase of the 4-tip tree (voxel 0.4) smoothed by
# clean_mesh(smooth=10); worst and worst mean path-axis error (% r), same stretch
DOCS_STAIRCASE_AXIS = (3.25, 0.72)


@pytest.fixture(scope="module", params=list(DOCS_AXIS))
def fitted(request):
    kw = {"4 tips": dict(levels=2, target_vertices=27000), "3 tips": dict(parents=THREE_TIP_PARENTS, voxel=0.4),
          "8 tips": dict(levels=3, voxel=0.3)}[request.param]
    t = synthetic_tree(**kw)
    return request.param, t, fit_vessel_tree(t.V, t.F)


def _truth_end(t, e):
    tc = np.array([x.center for x in t.truth.ends])
    return int(np.argmin(np.linalg.norm(tc - e.center, axis=1)))


def test_every_end_and_the_true_topology(fitted):
    name, t, tree = fitted
    assert isinstance(tree, VesselTree)
    assert len(tree.ends) == len(t.truth.ends)
    assert sorted(_truth_end(t, e) for e in tree.ends) == list(range(len(t.truth.ends)))
    assert t.truth.ends[_truth_end(t, tree.ends[tree.root])].kind == "open"
    assert len(tree.branches) == len(t.truth.branches) == len(tree.parent)
    assert list(tree.parent).count(-1) == 1 and tree.parent[0] == -1
    assert len(tree.junctions) == len({b.parent for b in t.truth.branches if b.parent >= 0})
    # one path per tip, from the root, through its chain of branches
    assert sorted(p.ends[1] for p in tree.paths) == sorted(set(range(len(tree.ends))) - {tree.root})
    for p, chain in zip(tree.paths, tree.path_branches):
        assert p.ends[0] == tree.root and chain[0] == 0
        assert all(tree.parent[c] == a for a, c in zip(chain, chain[1:]))
        assert len(chain) == len(t.truth.paths[_truth_end(t, tree.ends[p.ends[1]]) - 1].branches)
    assert all(b.converged and p.converged for b in tree.branches for p in tree.paths)


def test_path_axes_lie_on_the_true_centre_lines(fitted):
    """Issue target: within 5 % of the radius at worst and 1 % on average, away from junctions and tips."""
    name, t, tree = fitted
    worst, mean = DOCS_AXIS[name]
    for p in tree.paths:
        P = p.dense_points
        d, r, _, _ = t.truth.nearest(P)
        keep = t.truth.interior_mask(P)
        err = 100 * d[keep] / r[keep]
        assert keep.sum() > 0.6 * len(P)
        assert err.max() <= min(1.5 * worst, 5.0), (p.ends, err.max())
        assert err.mean() <= min(1.5 * mean, 1.0), (p.ends, err.mean())
        rad = 100 * np.abs(p.radius_at(p.dense_s)[keep] - r[keep]) / r[keep]
        assert rad.max() <= 1.5 * DOCS_RADIUS_MAX[name], (p.ends, rad.max())
        # the path runs from the root's centre to the tip's
        tip = t.truth.ends[_truth_end(t, tree.ends[p.ends[1]])]
        assert np.linalg.norm(P[0] - t.truth.ends[0].center) < 0.05 * t.truth.ends[0].radius
        assert np.linalg.norm(P[-1] - tip.center) < 0.5 * tip.radius


def test_paths_of_a_smoothed_voxel_staircase_lie_on_the_true_centre_lines():
    """A segmentation-like surface: the voxel boundary of the tree, smoothed as the staircase error advises.

    The truth is the tree's exact centre lines (its Bezier curves), not a fit of the smooth surface.
    """
    t = synthetic_tree(levels=2, voxel=0.4, staircase=True)
    V, F, _ = vesselgp.clean_mesh(t.V, t.F, smooth=10)
    tree = fit_vessel_tree(V, F)
    assert len(tree.paths) == len(t.truth.tips)
    worst, mean = DOCS_STAIRCASE_AXIS
    for p in tree.paths:
        d, r, _, _ = t.truth.nearest(p.dense_points)
        keep = t.truth.interior_mask(p.dense_points)
        err = 100 * d[keep] / r[keep]
        assert keep.sum() > 0.6 * len(keep)
        assert err.max() <= min(1.5 * worst, 5.0), (p.ends, err.max())
        assert err.mean() <= min(1.5 * mean, 1.0), (p.ends, err.mean())


def test_every_vertex_of_a_path_sits_at_its_foot(fitted):
    """Each vertex's parameter on a path is its closest point there: its offset from the axis point is
    normal to the tangent (along T below 1e-3 r), also near the junctions, where a vertex's start (its
    own branch's foot, at the parent's end for the surface up to the crotch) can lie radii away."""
    name, t, tree = fitted
    for p in tree.paths:
        on = np.isfinite(p.vertex_s) & (p.vertex_s > 0) & (p.vertex_s < 1)
        pts, T = p.at(p.vertex_s[on])[0], p.at(p.vertex_s[on])[1][:, 0]
        along = np.einsum("ij,ij->i", t.V[on] - pts, T)
        assert np.abs(along).max() < 1.5e-3 * p.mean_radius, (p.ends, np.abs(along).max() / p.mean_radius)


def test_junctions_are_where_the_true_centre_lines_meet(fitted):
    name, t, tree = fitted
    J, R = t.truth.junctions
    for q in tree.junctions:
        k = int(np.argmin(np.linalg.norm(J - q, axis=1)))
        assert np.linalg.norm(J[k] - q) <= 1.5 * DOCS_JUNCTION * R[k]
    # each junction is where its branch ends and its children start
    for q, b in zip(tree.junctions, tree.junction_branch):
        assert np.allclose(tree.branches[b].centers[-1], q, atol=1e-9 * np.abs(q).max())
        for c in np.flatnonzero(tree.parent == b):
            assert np.allclose(tree.branches[c].centers[0], q, atol=1e-9 * np.abs(q).max())


def _rodrigues(v, a, b):
    """Rotate v by the least rotation taking unit a to unit b (written out, not vesselgp.rotations)."""
    k = np.cross(a, b)
    s, c = np.linalg.norm(k), float(a @ b)
    k = k / s
    return v * c + np.cross(k, v) * s + k * (k @ v) * (1 - c)


def test_child_frames_start_from_the_parents_frame(fitted):
    """Angles compare across a junction: a child's U at its start is the parent's U at the junction
    turned by the least rotation onto the child's tangent; the paths carry the same frames."""
    name, t, tree = fitted
    for c, p in enumerate(tree.parent):
        if p < 0:
            continue
        Tp, Up = tree.branches[p].dense_frames[-1, :2]
        Tc, Uc = tree.branches[c].dense_frames[0, :2]
        expect = _rodrigues(Up, Tp, Tc)
        assert np.degrees(np.arccos(np.clip(expect @ Uc, -1, 1))) < 0.05
    for path, chain in zip(tree.paths, tree.path_branches):
        leaf = tree.branches[chain[-1]]
        # the leaf's U at mid-length against the path's U at the same point
        pt, fr = leaf.at([0.5])
        j = int(np.argmin(np.linalg.norm(path.dense_points - pt[0], axis=1)))
        assert np.linalg.norm(path.dense_points[j] - pt[0]) < 0.1 * leaf.mean_radius  # a dense sample apart
        ang = np.degrees(np.arccos(np.clip(path.dense_frames[j, 1] @ fr[0, 1], -1, 1)))
        # docs/accuracy.md: 2 degrees (1 until issue #34: a child led in along its centre line turns through its
        # junction zone on another curve than the path's rounded chain; 1.0 / 1.1 / 2.0 degrees on the
        # 4- / 3- / 8-tip trees)
        assert ang < 1.5 * 2.0, (path.ends, ang)


def test_trunk_is_fitted_once_and_shared_by_every_path(fitted):
    name, t, tree = fitted
    trunk = tree.branches[0]
    for p in tree.paths:
        s = np.linspace(0.05, 0.95, 40) * trunk.length / p.length
        pts = p.at(s)[0]
        ref = trunk.at(np.linspace(0.05, 0.95, 40))[0]
        assert np.abs(pts - ref).max() < 0.01 * trunk.mean_radius


def test_vertices_belong_to_their_branch_and_carry_its_parameters(fitted):
    name, t, tree = fitted
    n = len(t.V)
    assert tree.vertex_branch.shape == (n,)
    for b, gc in enumerate(tree.branches):
        own = tree.vertex_branch == b
        assert gc.vertex_s.shape == (n,)
        assert np.isfinite(gc.vertex_s[own]).all() and np.isnan(gc.vertex_s[~own]).all()
        assert (gc.vertex_weight[~own] == 0).all() and (gc.vertex_weight[own] > 0).mean() > 0.8
        # a branch vertex sits about one radius from its foot point
        rho = np.hypot(gc.vertex_local[own, 1], gc.vertex_local[own, 2])
        ok = gc.vertex_weight[own] > 0
        assert np.median(np.abs(rho[ok] / gc.radius_at(gc.vertex_s[own][ok]) - 1)) < 0.02
    # the truth: away from junctions and tips, vertices lie on the branch whose true centre line is nearest
    _, _, tb, _ = t.truth.nearest(t.V)
    keep = t.truth.interior_mask(t.V)
    mapped = np.array([t.truth.nearest(gc.at([0.5])[0])[2][0] for gc in tree.branches])
    assert (mapped[tree.vertex_branch[keep]] == tb[keep]).mean() >= 0.97


def test_a_rigid_motion_moves_the_tree_with_the_mesh():
    # every stage sees only lengths and angles: the same branches vertex for vertex, and axes equal
    # up to where each fixed point stopped (tolerances.GC_CONVERGENCE radii); the heat time of a
    # bounding-box diagonal once moved a junction vertex and the radii by 1.7e-3 r
    t = synthetic_tree(levels=1, voxel=0.5)
    a = fit_vessel_tree(t.V, t.F)
    for seed in (3, 5):
        R = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))[0]
        R *= np.sign(np.linalg.det(R))
        shift = np.array([120.0, -40.0, 7.5])
        b = fit_vessel_tree(t.V @ R.T + shift, t.F)
        assert a.parent.tolist() == b.parent.tolist()
        assert np.array_equal(a.vertex_branch, b.vertex_branch)
        for pa, pb in zip(a.paths, b.paths):
            assert pa.ends == pb.ends
            assert np.abs(pa.centers @ R.T + shift - pb.centers).max() < 1e-4 * pa.mean_radius
            assert np.abs(pa.radii - pb.radii).max() < 1e-4 * pa.mean_radius


def test_two_ends_give_one_branch():
    t = synthetic_tree(levels=0, voxel=0.5)
    tree = fit_vessel_tree(t.V, t.F)
    assert len(tree.branches) == len(tree.paths) == 1 and len(tree.junctions) == 0
    d, r, _, _ = t.truth.nearest(tree.paths[0].dense_points)
    keep = t.truth.interior_mask(tree.paths[0].dense_points)
    assert (d[keep] / r[keep]).max() < 0.02


def test_bad_root_and_staircase_are_refused():
    t = synthetic_tree(levels=1, voxel=0.6)
    with pytest.raises(vesselgp.EndsError, match="not an end index"):
        fit_vessel_tree(t.V, t.F, root=7)
    s = synthetic_tree(levels=1, voxel=0.6, staircase=True)
    with pytest.raises(vesselgp.EndsError, match="smooth"):
        fit_vessel_tree(s.V, s.F)


def test_a_path_outside_the_surface_raises(monkeypatch):
    """The axis check runs on every path: one moved out of the lumen is refused, not returned."""
    import vesselgp.tree as tree_mod

    t = synthetic_tree(levels=1, voxel=0.6)
    real = tree_mod._paths

    def moved(*args):
        paths, chains = real(*args)
        p = paths[0]
        off = 3.0 * p.mean_radius * p.frames[:, 1]
        return [dataclasses.replace(p, centers=p.centers + off)] + paths[1:], chains

    monkeypatch.setattr(tree_mod, "_paths", moved)
    with pytest.raises(vesselgp.NotTubularError, match="leaves the surface"):
        fit_vessel_tree(t.V, t.F)


def _closed(V, F, loops):
    """The mesh with each boundary loop closed by a fan about its centroid (test-side)."""
    V2, F2 = [V], [F]
    n = len(V)
    for lp in loops:
        c = V[lp].mean(axis=0)
        V2.append(c[None])
        F2.append(np.stack([lp, np.full(len(lp), n), np.roll(lp, -1)], axis=1))
        n += 1
    return np.vstack(V2), np.vstack(F2).astype(np.int64)


def test_real_y_paths_stay_inside_the_lumen():
    V, F = vesselgp.read_mesh(REAL / "vmtk_abdominal_aorta_iliac_bifurcation_open.stl")[:2]
    tree = fit_vessel_tree(V, F)
    assert len(tree.ends) == 3 and len(tree.paths) == 2 and len(tree.junctions) == 1
    # SOURCES.md: the aorta (r 7.69) is the root, the two iliacs (r 4.4) the tips
    assert tree.ends[tree.root].radius > 6.5
    loops = igl.boundary_loop_all(F)
    assert len(loops) == 3
    Vc, Fc = _closed(V, F, [np.asarray(lp, np.int64) for lp in loops])
    for p in tree.paths:
        assert p.converged
        inner = (p.dense_s * p.length > p.mean_radius) & ((1 - p.dense_s) * p.length > p.mean_radius)
        Q = p.dense_points[inner]
        w = igl.winding_number(Vc, Fc, Q)
        assert np.abs(np.abs(w) - 1).max() < 0.05
        d2 = igl.point_mesh_squared_distance(Q, V, F)[0]
        assert (np.sqrt(d2) > 0.2 * p.radius_at(p.dense_s[inner])).all()
        # no longer than a gentle curve between its end centres, each end on its loop's centre
        chord = np.linalg.norm(tree.ends[p.ends[1]].center - tree.ends[p.ends[0]].center)
        assert chord < p.length < 1.15 * chord
        for k, e in zip((0, -1), p.ends):
            assert np.linalg.norm(p.dense_points[k] - tree.ends[e].center) < 0.2 * tree.ends[e].radius


@pytest.fixture(scope="module")
def fine_tree():
    t = synthetic_tree(levels=2, target_vertices=200_000)
    ends = vesselgp.vessel_ends(t.V, t.F)
    return t, branch_decomposition(t.V, t.F, ends), fit_vessel_tree(t.V, t.F, ends=ends)


def test_centre_line_junctions_are_near_the_true_ones_on_a_fine_mesh(fine_tree):
    """The centre lines' junctions (where the medial lines part) lie within one parent radius of the
    true junctions, also on a 200k-vertex mesh, whose Voronoi diagram is built on a thinned subset."""
    t, b, _ = fine_tree
    J, R = t.truth.junctions
    inner = [k for k in range(len(b.parent)) if k in b.parent]
    assert len(inner) == 3
    for k in inner:
        q = b.junctions[k]
        i = int(np.argmin(np.linalg.norm(J - q, axis=1)))
        assert np.linalg.norm(J[i] - q) < R[i], (k, np.linalg.norm(J[i] - q) / R[i])


def test_paths_of_a_fine_tree_stay_on_the_true_centre_lines(fine_tree):
    """At 200k vertices too (where wrong far-field distances once gave 37 % with exit code 0)."""
    t, _, tree = fine_tree
    for p in tree.paths:
        d, r, _, _ = t.truth.nearest(p.dense_points)
        keep = t.truth.interior_mask(p.dense_points)
        err = 100 * d[keep] / r[keep]
        assert err.max() <= 1.5 * DOCS_AXIS["4 tips"][0] and err.mean() <= 1.5 * DOCS_AXIS["4 tips"][1]


def test_torsion_along_a_tree_path_of_the_real_y():
    """measure_torsion with a tree path as the rest fit: the identity has no twist, and a known
    twist of the path's vertices about its axis, Phi s, is measured back (other vertices stay)."""
    V, F = vesselgp.read_mesh(REAL / "vmtk_abdominal_aorta_iliac_bifurcation_open.stl")[:2]
    tree = fit_vessel_tree(V, F)
    p = tree.paths[0]
    assert vesselgp.measure_torsion(V, V, F, rest=p).total_twist == 0.0
    on = np.isfinite(p.vertex_s)
    phi = np.radians(60.0)
    pts, fr = p.at(p.vertex_s[on])
    a = phi * p.vertex_s[on]
    d = V[on] - pts
    # rotate the offset about the local tangent by a (Rodrigues, written out)
    T = fr[:, 0]
    c, s = np.cos(a)[:, None], np.sin(a)[:, None]
    d2 = d * c + np.cross(T, d) * s + T * np.einsum("ij,ij->i", T, d)[:, None] * (1 - c)
    V2 = V.copy()
    V2[on] = pts + d2
    prof = vesselgp.measure_torsion(V, V2, F, rest=p)
    assert abs(np.degrees(prof.total_twist) - 60.0) < 1.0  # measured 0.21 degrees off


def test_a_shared_geodesic_solver_gives_the_same_fits_and_a_wrong_one_is_refused():
    from vesselgp.fit import checked_mesh
    from vesselgp.mesh.geodesic import GeodesicDistances

    t = synthetic_tree(levels=1, voxel=0.6)
    geo = GeodesicDistances(t.V, checked_mesh(t.V, t.F)[1])
    a, b = fit_vessel_tree(t.V, t.F), fit_vessel_tree(t.V, t.F, geodesics=geo)
    assert (a.vertex_branch == b.vertex_branch).all()
    for pa, pb in zip(a.paths, b.paths):
        assert np.array_equal(pa.centers, pb.centers) and np.array_equal(pa.radii, pb.radii)
    # the single fit between two ends of the tree (its path mask) reuses it too
    ga = vesselgp.fit_generalized_cylinder(t.V, t.F, ends=(0, 1))
    gb = vesselgp.fit_generalized_cylinder(t.V, t.F, ends=(0, 1), geodesics=geo)
    assert np.array_equal(ga.centers, gb.centers)
    other = synthetic_tree(levels=1, voxel=0.7)
    with pytest.raises(vesselgp.OptionError, match="precomputed for a mesh of"):
        fit_vessel_tree(other.V, other.F, geodesics=geo)


def test_branches_are_held_to_the_bend_limit_and_paths_may_turn_at_junctions(monkeypatch):
    """Every branch axis goes through check_axis_bend (kappa r below tolerances.GC_MAX_BEND) where it
    is not the centre line; the paths, which turn through their junctions, do not. The 2-tip tree's
    paths turn at their junction (rounded over ``TREE_PATH_ROUNDING`` radii each side: kappa r about 0.4
    there, the branches below 0.1): with the limit between the two the tree fits untouched. With the
    limit lowered below the trunk's sharpest judged bend (near its junction side), that stretch is
    either handed to the centre line (a medial zone over it) or the fit is refused; what is returned
    never bends past the limit outside its medial zones."""
    from vesselgp import tolerances as tol

    t = synthetic_tree(levels=1, voxel=0.6)
    tree = fit_vessel_tree(t.V, t.F)

    def kappa_r(gc):
        k = np.linalg.norm(np.gradient(gc.dense_frames[:, 0], gc.dense_s * gc.length, axis=0), axis=1)
        return k * gc.radius_at(gc.dense_s)

    def judged_bends(tr, b):  # the bend where the check judges it (sharp_bends with the limit at 0 marks them)
        gc = tr.branches[b]
        with monkeypatch.context() as m:
            m.setattr(tol, "GC_MAX_BEND", 0.0)
            judged, kr = sharp_bends(gc.dense_s, gc.length, gc.dense_frames[:, 0], gc.radius_at(gc.dense_s),
                                     skip_start=tr.junction_zone[b], skip=tr.medial_zones[b])
        return judged, kr

    turn = max(kappa_r(p).max() for p in tree.paths)
    judged, trunk = judged_bends(tree, 0)
    assert judged.mean() > 0.5
    assert np.allclose(trunk, kappa_r(tree.branches[0]))
    assert not any(len(z) for z in tree.medial_zones)
    bend = trunk[judged].max()
    s_bend = tree.branches[0].dense_s[np.argmax(np.where(judged, trunk, -1.0))]
    assert bend < turn < tol.GC_MAX_BEND  # a path's turn is rounded, yet sharper than its trunk
    monkeypatch.setattr(tol, "GC_MAX_BEND", 1.05 * bend)  # just above the trunk's bend: fits as it was
    same = fit_vessel_tree(t.V, t.F)
    assert not any(len(z) for z in same.medial_zones)
    refused = 0
    for f in (0.95, 0.8, 0.7):  # below it: the sharp stretch is the centre line, or the fit is refused
        monkeypatch.setattr(tol, "GC_MAX_BEND", f * bend)
        try:
            low = fit_vessel_tree(t.V, t.F)
        except vesselgp.NotTubularError as e:
            assert "bends tighter than its radius" in str(e)
            refused += 1
            continue
        zs = low.medial_zones[0]  # normalised arc lengths of the trunk
        assert any(z0 <= s_bend <= z1 for z0, z1 in zs), (f, zs, s_bend)
        for b in range(len(low.branches)):
            judged, kr = judged_bends(low, b)
            assert kr[judged].max(initial=0.0) < f * bend, (f, b)
    assert refused < 3


def test_every_branch_of_a_finer_smoothed_staircase_converges(caplog):
    """The benchmark's segmentation-like tree (voxel 0.366, about 27k vertices): with a hard cut at a
    branch's free junction side, three vertices there went in and out of the data and that end node
    cycled (1.5e-2 radii each way) to the iteration cap; tapered in, every fixed point converges
    (and says nothing), and the paths keep to the true centre lines."""
    t = synthetic_tree(levels=2, voxel=0.4 * np.sqrt(22_610 / 27_000), staircase=True)
    V, F, _ = vesselgp.clean_mesh(t.V, t.F, smooth=10)
    with caplog.at_level("WARNING", logger="vesselgp"):
        tree = fit_vessel_tree(V, F)
    assert all(b.converged and b.iterations < 20 for b in tree.branches), [b.iterations for b in tree.branches]
    assert not [r for r in caplog.records if "did not converge" in r.getMessage()]
    worst, mean = DOCS_STAIRCASE_AXIS
    for p in tree.paths:
        d, r, _, _ = t.truth.nearest(p.dense_points)
        keep = t.truth.interior_mask(p.dense_points)
        err = 100 * d[keep] / r[keep]
        assert err.max() <= 5.0 and err.mean() <= 1.0, (p.ends, err.max(), err.mean())


def test_a_junction_link_leaves_a_bending_axis_along_its_tangent():
    """The link to a junction starts where the axis is kept (``TREE_JUNCTION_SKIP`` radii from its
    end) heading along the axis there, so a bending branch has no kink: on a circular arc of radius
    10 r the link's start tangent is the circle's to 0.2 degrees (a link along the three-radius end
    chord started 8.6 degrees off). The link is sampled finely here (``_attach``'s radius sets only
    its sampling), so its first step shows its start tangent; the kept nodes are the arc's."""
    from vesselgp import tolerances as tol
    from vesselgp.tree import _attach, _end_line

    R, r = 10.0, 1.0
    th = np.arange(0.0, 12.0 + 1e-9, 0.5) / R  # nodes every half radius along the arc
    nodes = R * np.c_[np.cos(th), np.sin(th), 0 * th]
    line = _end_line(nodes, r, at_start=False)
    th0 = th[-1] - tol.TREE_JUNCTION_SKIP * r / R  # where the link starts (arc length from the end)
    assert np.linalg.norm(line[0] - R * np.array([np.cos(th0), np.sin(th0), 0])) < 1e-2 * r
    J = R * np.array([np.cos(th[-1] + 1.0 / R), np.sin(th[-1] + 1.0 / R), 0.0])  # on the arc beyond the end
    out = _attach(nodes, J, line, 1e-3 * r, at_start=False)
    k = int(np.argmin(np.linalg.norm(out - line[0], axis=1)))
    step = out[k + 1] - out[k]
    tangent = np.array([-np.sin(th0), np.cos(th0), 0.0])
    assert np.degrees(np.arccos(np.clip(step @ tangent / np.linalg.norm(step), -1, 1))) < 0.2
    assert np.abs(np.linalg.norm(out[:k, :2], axis=1) - R).max() < 1e-9  # the kept nodes are the arc's
    np.testing.assert_allclose(out[-1], J)


def test_a_branch_starts_behind_its_tip_and_converges_in_a_few_iterations(fitted, monkeypatch):
    """A leaf branch's initial axis is pinned to its tip's centre, the centre of the dome's sphere:
    the wall behind the tip's plane lies on the tube, the dome beyond it does not. With the dome
    in the initial bands, the axis began with a hairpin out to 0.79-0.90 radii past the plane
    and back, its first radii near the tip a quarter short, and the outlier test took leaf
    branches 8-14 iterations (6.7-7.8 on average per tree) instead of 4-9 (4.6-5.1)."""
    import vesselgp.tree as vt

    name, t, _ = fitted
    seen = {}

    def spy(problems, **kw):
        seen["problems"], seen["fits"] = problems, vt.fixed_points.__wrapped__(problems, **kw)
        return seen["fits"]

    spy.__wrapped__ = vt.fixed_points
    monkeypatch.setattr(vt, "fixed_points", spy)
    tree = fit_vessel_tree(t.V, t.F)
    leaves = []
    for p, it in zip(seen["problems"], seen["fits"]):
        tip = [e for e in tree.ends if e.kind != "open" and np.linalg.norm(p.nodes[-1] - e.center) < 1e-9 * e.radius]
        if tip:
            e = tip[0]
            assert ((p.nodes - e.center) @ e.direction).max() <= 1e-9 * e.radius
            leaves.append(it.count)
    assert len(leaves) == len(tree.paths)
    assert max(leaves) <= 10 and np.mean(leaves) <= 6.0, leaves
    # the root branch, with a mirror ghost past its open end (taken from the corrected nodes), as
    # quickly as without one (3-4 iterations; from the last axis's frame the ghost lagged: 5-6)
    assert seen["fits"][0].count <= 4, seen["fits"][0].count


def test_ends_given_with_their_directions_reversed_give_the_same_tree():
    """The initial bands keep the wall behind each pinned end's plane, on the side of the branch:
    ends a caller built with the opposite sense of ``direction`` cut the same vertices."""
    t = synthetic_tree(levels=1, voxel=0.6)
    ends = vesselgp.vessel_ends(t.V, t.F)
    flipped = [dataclasses.replace(e, direction=-e.direction) for e in ends]
    a, b = fit_vessel_tree(t.V, t.F, ends=ends), fit_vessel_tree(t.V, t.F, ends=flipped)
    for p, q in zip(a.paths, b.paths):
        np.testing.assert_array_equal(p.dense_points, q.dense_points)
    assert [x.iterations for x in a.branches] == [x.iterations for x in b.branches]


@pytest.mark.parametrize("off", [0.45, 0.55, 2.0])
def test_junction_is_where_the_branch_lines_meet_held_within_the_zone(off):
    """Three non-coplanar lines through the origin meet there; with the centre lines' junction J0 at 0.45
    of its inscribed radius R0 from it the junction is the origin (to the anchor's weak pull), at 0.55 R0
    and 2 R0 it is held on the sphere of half that radius about J0 (tolerances.TREE_JUNCTION_HOLD),
    towards the origin."""
    from vesselgp.tree import _EndLine, _junction_point

    dirs = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0.6, 0.8]])
    lines = [_EndLine(3.0 * d, d, d, 0.5) for d in dirs]
    J0 = off * np.array([0.0, 0.0, 1.0])
    J = _junction_point(lines[0], lines[1:], J0, 1.0)
    if off < 0.5:
        assert np.linalg.norm(J) < 0.05
    else:
        assert np.isclose(np.linalg.norm(J - J0), 0.5) and np.linalg.norm(J) < off


#: Anatomy the binary synthetic trees do not show (issue #34): three children off one junction (the arch's
#: branches, a left main's trifurcation) and two thin children (0.45 of the trunk's radius) leaving it at 85
#: degrees. docs/accuracy.md tree table: path axis worst / mean (% r), radius worst (%), junction (parent radii).
DOCS_ANATOMY = {
    "trifurcation": (dict(parents=(-1, 0, 0, 0), voxel=0.4, taper=0.5, branch_angle_deg=70.0),
                     *_TREES["trifurcation (3 children off one junction, 70 deg)"][1:5]),
    "thin at 85 deg": (dict(parents=(-1, 0, 0), voxel=0.35, taper=0.45, branch_angle_deg=85.0),
                       *_TREES["two thin children (0.45 of the trunk) at 85 deg"][1:5])}


@pytest.mark.parametrize("name", list(DOCS_ANATOMY))
def test_a_trifurcation_and_thin_branches_at_right_angles(name):
    """One junction with all its children, every path on the true centre lines (within 1.5x the documented
    figures, away from junctions and tips), the radius true, the junction where the true centre lines meet."""
    kw, worst, mean, radius, junction = DOCS_ANATOMY[name]
    t = synthetic_tree(**kw)
    tree = fit_vessel_tree(t.V, t.F)
    assert len(tree.paths) == len(kw["parents"]) - 1 and len(tree.junctions) == 1
    assert sorted(tree.parent.tolist()) == sorted(kw["parents"])
    for p in tree.paths:
        P = p.dense_points
        d, r, _, _ = t.truth.nearest(P)
        keep = t.truth.interior_mask(P)
        err = 100 * d[keep] / r[keep]
        assert err.max() <= 1.5 * worst and err.mean() <= 1.5 * mean, (p.ends, err.max(), err.mean())
        assert (100 * np.abs(p.radius_at(p.dense_s)[keep] - r[keep]) / r[keep]).max() <= 1.5 * radius
    J, R = t.truth.junctions
    assert np.linalg.norm(tree.junctions[0] - J[0]) <= 1.5 * junction * R[0]
    assert all(len(z) == 0 for z in tree.medial_zones) and tree.bulges == ()


#: docs/accuracy.md tree table: the 4-tip tree with two tips cut off and capped flat (0.3 and 1.2 radii behind the
#: dome): path axis worst / mean (% r), measured on all four paths.
DOCS_CAPPED_TIPS = tuple(_TREES["4 tips, two of them cut off and capped flat"][1:3])


def test_a_tree_with_capped_tips_keeps_its_accuracy():
    """Issue #35: capped tips in the accuracy tests. A capped end mirrors its wall across the cap's plane (a
    ghost node past it), as an open end does; without that the capped path's worst error triples."""
    from test_ends_trees import clip_and_cap

    t = synthetic_tree(levels=2, target_vertices=27000)
    V, F = t.V, t.F
    for i, e in enumerate(t.truth.ends[1:3]):
        V, F, _ = clip_and_cap(V, F, e.center, e.direction, e.radius, behind=0.3 + 0.9 * i)
    tree = fit_vessel_tree(V, F)
    assert sorted(e.kind for e in tree.ends) == ["cap", "cap", "open", "rounded", "rounded"]
    worst, mean = DOCS_CAPPED_TIPS
    for p in tree.paths:
        P = p.dense_points
        d, r, _, _ = t.truth.nearest(P)
        keep = t.truth.interior_mask(P)
        err = 100 * d[keep] / r[keep]
        assert err.max() <= 1.5 * worst and err.mean() <= 1.5 * mean, (tree.ends[p.ends[1]].kind, err.max())
