"""Real vessel trees by other people (issue #34): the tree fit runs, its paths stay in the lumen and
follow VMTK's centre lines (``shared/data/real/vmtk``, VMTK 1.5.2, a reference made outside vesselgp).

The truth of "inside" is libigl's winding number of the surface with its open ends closed by fans,
and the wall distance libigl's point-to-mesh distance, both on the mesh file itself; the local radius
is VMTK's maximum inscribed sphere at the nearest point of its line. For the closed pulmonary artery
VMTK's lines run from the trunk's rounded end (``tests/data/vmtk``: the shared file predates finding it).
"""
from __future__ import annotations

import functools

import igl
import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

import vesselgp
from vesselgp import tolerances as tol
from vesselgp.curves import chord_length

from _data import REAL, decimated, vmtk_lines

MM = {"gmsh_carotid-bifurcation_open.stl": 10.0, "gmsh_aortic-arch_open.stl": 1000.0}
FITS = ["vmtk_abdominal_aorta_iliac_bifurcation_open.stl", "cardiopinns_aortic-arch-4dflow_capped.stl",
        "gmsh_carotid-bifurcation_open.stl", "palabos_aneurysm-voxelized_closed.stl",
        "gmsh_abdominal-aorta-renal-iliac_open.stl", "gmsh_aortic-arch_open.stl",
        "gmsh_intracranial-aneurysm_open.stl", "xrayangio_xcat-coronary-tree_open.stl",
        "cbcl_pulmonary-artery_closed.vtp"]

#: Branches whose axis may be the centre line somewhere: on tubes at most half (or 2); the closed
#: pulmonary artery is three bulbs (a trunk wider than it is long, closed at its valve, and two
#: branches with a wide junction), each with its zone; on the coarse gmsh arch the three arch branches
#: are stubs 2.5-4.4 radii long on the arch's flare and the arch itself folds between them; on the XCAT
#: tree the fits of 8 coronaries 0.4 mm across, one edge of the mesh around, do not settle (still
#: moving 0.07-0.5 radii an iteration), so the centre line is their axis throughout.
ZONED = {"cbcl_pulmonary-artery_closed.vtp": 3, "gmsh_aortic-arch_open.stl": 4, "xrayangio_xcat-coronary-tree_open.stl": 9}

def _closed(V, F):
    """The surface oriented by pymeshlab (not vesselgp's libigl-based orientation) with its loops closed by fans."""
    import pymeshlab
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(V, F))
    ms.meshing_re_orient_faces_coherently()
    V, F = ms.current_mesh().vertex_matrix(), ms.current_mesh().face_matrix().astype(np.int64)
    Vs, Fs = [V], [F]
    for lp in igl.boundary_loop_all(F):
        lp = np.asarray(lp, np.int64)
        Vs.append(V[lp].mean(axis=0)[None])
        Fs.append(np.stack([np.roll(lp, -1), lp, np.full(len(lp), sum(len(v) for v in Vs) - 1)], 1))
    return np.vstack(Vs), np.vstack(Fs)


#: Real meshes made coarser by pymeshlab, which the fit refused before (issue #34: other meshes of the same
#: anatomy will be tried): the pulmonary artery remeshed at 1.4 edges turned tighter than its final radius
#: (kappa r 1.02) where its first fit did not.
REMESHED = {"cbcl_pulmonary-artery_closed.vtp@remeshed 1.4": ("remeshed", 1.4),
            "gmsh_intracranial-aneurysm_open.stl@remeshed 0.7": ("remeshed", 0.7),
            "gmsh_intracranial-aneurysm_open.stl@decimated 0.3": ("decimated", 0.3)}


def remeshed(V, F, factor):
    """pymeshlab's isotropic remeshing of (V, F) at ``factor`` times its median edge (4 iterations)."""
    import pymeshlab
    E = igl.edges(F)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(V, F))
    ms.meshing_isotropic_explicit_remeshing(iterations=4, targetlen=pymeshlab.PureValue(
        factor * float(np.median(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)))))
    m = ms.current_mesh()
    return m.vertex_matrix().astype(np.float64), m.face_matrix().astype(np.int64)


@functools.lru_cache(maxsize=None)
def _fitted(param):
    """(name, V, F, tree, VMTK's lines) of a real mesh, or of one made coarser (``name@how factor``)."""
    name = param.split("@")[0]
    V, F = vesselgp.read_mesh(REAL / name)[:2]
    V = V * MM.get(name, 1.0)
    if param in REMESHED:
        how, factor = REMESHED[param]
        V, F = (remeshed if how == "remeshed" else decimated)(V, F, factor)
    return name, V, F, vesselgp.fit_vessel_tree(V, F), vmtk_lines(name)


@pytest.fixture(scope="module", params=FITS + list(REMESHED))
def real_tree(request):
    return _fitted(request.param)


@pytest.fixture(scope="module", params=FITS)
def original_tree(request):
    """The real meshes as their authors made them (the rigid-motion test: on a mesh coarsened until a
    branch's fixed point stops on the edge of settling, a rigid motion can flip that branch to its centre
    line, 0.22 local radii on the intracranial aneurysm decimated to 30 %)."""
    return _fitted(request.param)


def test_every_path_runs_inside_the_lumen(real_tree):
    """Issue #34: interior samples inside (winding >= 0.5) at >= 99 %, >= 95 % at least 0.2 local radii from the wall."""
    name, V, F, tree, lines = real_tree
    Vc, Fc = _closed(V, F)
    P_ref = np.vstack([p for p, _ in lines])
    R_ref = np.concatenate([r for _, r in lines])
    kd = cKDTree(P_ref)
    for p in tree.paths:
        P = p.dense_points
        arc = chord_length(P)
        r_end = [tree.ends[e].radius for e in p.ends]
        inner = (arc > r_end[0]) & (arc[-1] - arc > r_end[1])
        Q = P[inner]
        w = np.abs(igl.fast_winding_number(Vc, Fc, Q))
        assert np.mean(w >= 0.5) >= 0.99, (name, p.ends, np.mean(w >= 0.5))
        d2 = igl.point_mesh_squared_distance(Q, V, F)[0]
        local = R_ref[kd.query(Q)[1]]
        assert np.mean(np.sqrt(d2) >= 0.2 * local) >= 0.95, (name, p.ends)


def test_every_stretch_of_vmtks_centre_lines_has_an_axis_and_every_end_is_reached(real_tree):
    """Issue #44: every point of VMTK's centre lines (its own, not vesselgp's) lies within one of its inscribed
    radii of a path (the intracranial aneurysm's path 0 -> 1 stopped 1.96 end radii short of its end: VMTK's line
    there was 1.13 of its radii from any path), every path starts and ends within 5 % of a radius of its ends'
    centres, and the fit's checks say so: the wall covered but for pieces smaller than CHECK_MAX_UNCOVERED."""
    name, V, F, tree, lines = real_tree
    dense = cKDTree(np.vstack([p.dense_points for p in tree.paths]))
    worst = max(float(np.max(dense.query(P)[0] / R)) for P, R in lines)
    assert worst <= 1.0, (name, worst)
    for p in tree.paths:
        for e, c in zip(p.ends, (p.dense_points[0], p.dense_points[-1])):
            assert np.linalg.norm(c - tree.ends[e].center) < 0.05 * tree.ends[e].radius, (name, p.ends)
    assert tree.checks.worst_end_gap < 0.05 and tree.checks.largest_uncovered <= tol.CHECK_MAX_UNCOVERED


def test_paths_follow_vmtk_away_from_junctions_and_ends(real_tree):
    """Issue #34: within 10 % of the local radius of VMTK's centre line on average, away from the
    junctions (2 inscribed radii) and the ends (VMTK's lines stop short of open ends)."""
    name, V, F, tree, lines = real_tree
    dense = [cKDTree(p.dense_points) for p in tree.paths]
    compared = 0
    for P, R in lines:
        arc = chord_length(P)
        keep = (arc > 2 * R[0]) & (arc[-1] - arc > 2 * R[-1])
        for J in tree.junctions:
            keep &= np.linalg.norm(P - J, axis=1) > 2 * R
        if keep.sum() < 10:  # an arch branch's stub: all of it within two radii of its junction or end
            continue
        compared += 1
        # the path to the same tip: the one nearest to the line's far end
        k = int(np.argmin([t.query(P[-1])[0] for t in dense]))
        d = dense[k].query(P[keep])[0] / R[keep]
        assert d.mean() <= 0.10, (name, d.mean())
    assert compared >= (len(lines) + 1) // 2, (name, compared)


def test_the_axis_is_the_centre_line_only_where_the_tube_model_fails(real_tree):
    """Medial zones (the axis taken from the lumen's centre line) where the wall is not a tube: on the
    intracranial aneurysm they cover the sac, the stretch of its line whose inscribed radius exceeds
    1.3 times the parent vessel's (VMTK's radii: the truth of where the sac is); on the gmsh arch the
    stubs of the arch branches; elsewhere, on tubes, the fit holds and most branches have none."""
    name, V, F, tree, lines = real_tree
    zoned = [b for b, z in enumerate(tree.medial_zones) if len(z)]
    assert len(zoned) <= ZONED.get(name, max(2, len(tree.branches) // 2)), (name, zoned)
    if "intracranial" in name:
        trunk = np.median(lines[0][1][:len(lines[0][1]) // 4])
        sac = np.vstack([P[R > 1.3 * trunk] for P, R in lines])
        assert len(sac) > 10
        covered = np.zeros(len(sac), bool)
        for b in zoned:
            g = tree.branches[b]
            for s0, s1 in tree.medial_zones[b]:
                seg = g.dense_points[(g.dense_s >= s0) & (g.dense_s <= s1)]
                d, _ = cKDTree(seg).query(sac)
                covered |= d < 1.5 * trunk
        assert covered.mean() >= 0.8, covered.mean()
    if "pulmonary" in name:  # the trunk, a bulb closed at its valve, wound about (kappa r 1.9 to 2.6):
        trunk = tree.medial_zones[0]  # the centre line from its closed end on
        assert len(trunk) and trunk[:, 0].min() == 0.0 and np.max(trunk[:, 1] - trunk[:, 0]) >= 0.25, trunk


def test_closed_pulmonary_artery_has_its_three_rounded_ends():
    """Issue #34: every end of a closed mesh whose rounded ends differ in size (trunk 8 mm, branches 4.4 and
    3.2 mm): three rounded ends, the widest the trunk's, each with the radius of the lumen there (VMTK's
    largest inscribed sphere within two end radii, within 20 %: the trunk's section is not round)."""
    name = "cbcl_pulmonary-artery_closed.vtp"
    V, F = vesselgp.read_mesh(REAL / name)[:2]
    ends = vesselgp.vessel_ends(V, F)
    assert [e.kind for e in ends] == ["rounded"] * 3
    P = np.vstack([p for p, _ in vmtk_lines(name)])
    R = np.concatenate([r for _, r in vmtk_lines(name)])
    for e in ends:
        near = np.linalg.norm(P - e.center, axis=1) < 2 * e.radius
        assert near.any(), e.describe()
        assert abs(e.radius - R[near].max()) <= 0.2 * R[near].max(), (e.describe(), R[near].max())
    assert max(ends, key=lambda e: e.radius).radius > 1.5 * sorted(e.radius for e in ends)[1]


#: Bulges on the real meshes: the intracranial aneurysm's sac, the voxelised aneurysm (one place, on both
#: paths), the two common iliac aneurysms of the abdominal aorta; none on the tubes, arches and trees.
BULGES = {"gmsh_intracranial-aneurysm_open.stl": 1, "palabos_aneurysm-voxelized_closed.stl": 1,
          "gmsh_abdominal-aorta-renal-iliac_open.stl": 2}


def test_sacs_and_dilatations_are_reported_where_vmtk_sees_them(real_tree):
    """Issue #34: sacs and bulbs are passed through and reported (VesselTree.bulges). Each bulge is where
    VMTK's lumen is wide: its inscribed radius at the peak is at least 1.3 times its median along the same
    line, or (the intracranial sac, which VMTK's lines pass at its neck) the peak lies within two parent
    radii of the stretch of VMTK's lines whose inscribed radius exceeds 1.3 times the parent's."""
    name, V, F, tree, lines = real_tree
    assert len(tree.bulges) == BULGES.get(name, 0), (name, [(b.paths, b.ratio) for b in tree.bulges])
    for b in tree.bulges:
        assert b.ratio >= 1.3 and b.s_range[0] < b.s_peak < b.s_range[1]
        if "intracranial" in name:
            trunk = np.median(lines[0][1][:len(lines[0][1]) // 4])
            sac = np.vstack([P[R > 1.3 * trunk] for P, R in lines])
            assert np.min(np.linalg.norm(sac - b.peak, axis=1)) < 2 * trunk
            continue
        P, R = min(lines, key=lambda pr: cKDTree(pr[0]).query(b.peak)[0])
        assert R[cKDTree(P).query(b.peak)[1]] >= 1.3 * np.median(R), (name, b.peak)


def test_a_rigid_motion_moves_the_tree_with_the_mesh(original_tree):
    """Invariance: the tree of a rotated and shifted mesh is the tree of the mesh rotated and shifted, within
    0.05 local radii (the fits of stubs on a junction's flare wandered and moved the arch's junctions 4-6 mm
    until a fit that does not settle took the centre line, which is invariant)."""
    name, V, F, tree, lines = original_tree
    Q = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
    t = np.array([5.0, -3.0, 2.0])
    moved = vesselgp.fit_vessel_tree(V @ Q.T + t, F)
    assert len(moved.paths) == len(tree.paths)
    for p, q in zip(tree.paths, moved.paths):
        d = cKDTree((q.dense_points - t) @ Q).query(p.dense_points)[0]
        assert np.max(d / p.radius_at(p.dense_s)) < 0.05, name
    if len(tree.junctions):
        assert np.allclose((moved.junctions - t) @ Q, tree.junctions, atol=0.05 * min(e.radius for e in tree.ends))


# --------------------------------------------------------------------------- #
# twist between two scans of a real tree (issue #34, item 6)
# --------------------------------------------------------------------------- #
def _twisted(V, ends, lines, alpha):
    """The real tree twisted by ``alpha(u)`` (u = arc length over length of VMTK's line from the widest end to the
    second widest, the main vessel): each main-vessel vertex turned by alpha about that line's tangent at its
    nearest point, each side branch (the vertices nearer to where VMTK's line to its tip has parted from the
    main line by more than the main line's inscribed radius) turned rigidly about the main tangent at the
    parting by alpha there. Built from VMTK's lines, not vesselgp's fit. Returns the vertices and the u of
    each side branch's parting with its point on the main line."""
    order = np.argsort([-e.radius for e in ends])
    km = int(np.argmin([np.linalg.norm(P[-1] - ends[order[1]].center) for P, _ in lines]))
    M, RM = lines[km]
    aM = chord_length(M)
    T = np.gradient(M, aM, axis=0)
    T /= np.linalg.norm(T, axis=1)[:, None]
    kd = cKDTree(M)
    parts = []
    for i, (P, _) in enumerate(lines):
        if i != km:
            d, idx = kd.query(P)
            out = np.flatnonzero(d > RM[idx])
            if len(out):
                parts.append((P[out[0]:], int(idx[out[0]])))
    best, iM = kd.query(V)
    owner = np.full(len(V), -1)
    for q, (P, _) in enumerate(parts):
        d = cKDTree(P).query(V)[0]
        owner[d < best], best = q, np.minimum(best, d)
    W = V.copy()
    m = owner < 0
    c = M[iM[m]]
    W[m] = c + Rotation.from_rotvec(T[iM[m]] * alpha(aM[iM[m]] / aM[-1])[:, None]).apply(V[m] - c)
    for q, (_, j) in enumerate(parts):
        m = owner == q
        W[m] = M[j] + Rotation.from_rotvec(T[j] * alpha(aM[j] / aM[-1])).apply(V[m] - M[j])
    return W, [(aM[j] / aM[-1], M[j]) for _, j in parts]


@pytest.mark.parametrize("profile", ["linear 60 deg", "non-uniform -50 deg"])
def test_twist_between_a_real_tree_and_its_twisted_remeshed_moved_copy(profile):
    """Issue #34: the abdominal aorta with its renal and iliac branches against a copy twisted by a known
    alpha(s) about the aorta (side branches turned rigidly at their partings), remeshed independently
    (pymeshlab's isotropic remeshing) and moved rigidly: each segment between landmarks within 2 degrees of
    alpha at the later landmark's parting minus alpha at the earlier one's (measured 1.0-1.8 degrees), the one
    to the iliac bifurcation within 2 degrees plus its stated half-width (measured 4.0-5.2 degrees off)."""
    import igl
    import pymeshlab

    name = "gmsh_abdominal-aorta-renal-iliac_open.stl"
    V, F = vesselgp.read_mesh(REAL / name)[:2]
    alpha = {"linear 60 deg": lambda u: np.radians(60.0) * u,
             "non-uniform -50 deg": lambda u: np.radians(-50.0) * u * u * (3 - 2 * u)}[profile]
    W, partings = _twisted(V, vesselgp.vessel_ends(V, F), vmtk_lines(name), alpha)
    E = igl.edges(F)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(W, F))
    ms.meshing_isotropic_explicit_remeshing(
        iterations=4, targetlen=pymeshlab.PureValue(float(np.median(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)))))
    W2, F2 = ms.current_mesh().vertex_matrix().astype(np.float64), ms.current_mesh().face_matrix().astype(np.int64)
    assert len(W2) != len(V)  # another mesh of the same surface
    Q = Rotation.from_rotvec([0.4, -0.3, 0.2]).as_matrix()
    r = vesselgp.twist_between(V, F, W2 @ Q.T + [10.0, -4.0, 3.0], F2)
    assert len(r.segment_twist) >= 1
    u = np.array([min(partings, key=lambda pm: np.linalg.norm(pm[1] - P))[0] for P in r.landmarks_a])
    truth = np.degrees(np.diff(alpha(u)))
    err = np.abs(np.degrees(r.segment_twist) - truth)
    # issue #45: within 2 degrees, or 2 plus the stated half-width; the segments between the visceral branches
    # within 2, the one to the iliac bifurcation (comparable daughters, said) wider
    assert np.all(err <= 2.0 + np.degrees(r.segment_uncertainty)), (np.degrees(r.segment_twist), truth)
    assert np.all(err[~r.divides_a[1:]] <= 2.0) and r.divides_a[-1]


# --------------------------------------------------------------------------- #
# centre lines of a coarse real tree (issue #34: a tube a few edges around)
# --------------------------------------------------------------------------- #
def test_centre_lines_of_a_coarse_real_tree_reach_every_end():
    """The XCAT coronary tree decimated to 30 % (pymeshlab's quadric edge collapse, 3688 vertices; its thin
    coronaries 4-6 edges around, VMTK's lines of the original mesh all inside it): the tetrahedra across them
    have their circumcentres outside the wall and the inside Voronoi vertices fall apart (ends were "not
    connected to the root through the lumen"); bridged by the tetrahedra whose centroids are inside, every
    end is reached, the lines stay inside (>= 99 % of samples) and VMTK's lines lie 0.105 local radii from
    them on average (asserted within 1.5x). (pymeshlab's isotropic remeshing of this tree is not used: its
    output depends on the process's threads, and at 1.4 edges it can pinch the thin coronaries shut, VMTK's
    lines leaving the surface for 11-41 samples; the lines are then rightly refused.)"""
    mean_off = 0.105
    from scipy.sparse.csgraph import connected_components

    from vesselgp.centerlines import _voronoi_graph, centerlines
    from vesselgp.mesh._geometry import closed_by_fans

    name = "xrayangio_xcat-coronary-tree_open.stl"
    V, F = vesselgp.read_mesh(REAL / name)[:2]
    V, F = decimated(V, F, 0.3)
    ends = vesselgp.vessel_ends(V, F)
    assert len(ends) == 11
    loops = igl.boundary_loop_all(F)
    lines = vmtk_lines(name)
    Vc, Fc = closed_by_fans(V, F, loops)
    assert all(np.all(np.abs(igl.fast_winding_number(Vc, Fc, p)) >= 0.5) for p, _ in lines)  # a faithful surface
    cc, _, inside, G = _voronoi_graph(V, F, loops)  # unbridged: the ends' seeds lie in separate pieces
    lab = connected_components(G, directed=False)[1]
    ids = np.flatnonzero(inside)
    seeds = ids[cKDTree(cc[ids]).query([e.center for e in ends])[1]]
    assert len(set(lab[seeds])) > 1
    root = int(np.argmax([e.radius for e in ends]))
    c = centerlines(V, F, ends, root, loops=loops)
    assert sorted(c.tips) == [j for j in range(11) if j != root]
    P = np.vstack(c.points)
    assert np.mean(np.abs(igl.fast_winding_number(Vc, Fc, P)) >= 0.5) >= 0.99
    Pr, Rr = np.vstack([p for p, _ in lines]), np.concatenate([r for _, r in lines])
    assert np.mean(cKDTree(P).query(Pr)[0] / Rr) <= 1.5 * mean_off


def test_a_stub_too_coarse_to_fit_takes_its_centre_line(caplog):
    """The gmsh arch decimated to 30 % (697 vertices; its arch branches 4-6 edges around): an arch branch's
    circle-fit system is singular (no wall around some of its nodes), which refused the whole tree
    ("the generalized-cylinder fit is singular"). That branch now takes the lumen's centre line, as a fit
    that does not settle does: it has a medial zone and its axis lies on VMTK's centre line of the original
    mesh (within 0.25 of its inscribed radius; 0.11 measured), and every path stays inside the lumen."""
    import logging

    name = "gmsh_aortic-arch_open.stl"
    V, F = vesselgp.read_mesh(REAL / name)[:2]
    V, F = decimated(V * MM[name], F, 0.3)
    with caplog.at_level(logging.INFO, logger="vesselgp.tree"):
        tree = vesselgp.fit_vessel_tree(V, F)
    # a singular branch takes the centre line; its abandoned fit's last step is infinite (VesselTree.branch_fit)
    singular = [b for b, h in enumerate(tree.branch_fit) if h == "centre line" and np.isinf(tree.branches[b].last_step)]
    assert singular, "no branch was singular: the test no longer reaches the case"
    assert any("take the lumen's centre line" in r.getMessage() for r in caplog.records)  # said once
    lines = vmtk_lines(name)
    P, R = np.vstack([p for p, _ in lines]), np.concatenate([r for _, r in lines])
    for b in singular:
        assert len(tree.medial_zones[b])
        d, i = cKDTree(P).query(tree.branches[b].dense_points)
        assert np.max(d / R[i]) <= 0.25
    assert len(tree.paths) == len(tree.ends) - 1
    Vc, Fc = _closed(V, F)
    for p in tree.paths:
        arc = chord_length(p.dense_points)
        inner = (arc > tree.ends[p.ends[0]].radius) & (arc[-1] - arc > tree.ends[p.ends[1]].radius)
        assert np.mean(np.abs(igl.fast_winding_number(Vc, Fc, p.dense_points[inner])) >= 0.5) >= 0.99


def test_a_noisy_arch_turning_tighter_than_its_final_radius_takes_the_centre_line_there(caplog):
    """The gmsh arch with each vertex moved along its normal by normal noise of 0.3 median edges (seed 0): the
    arch branch's final cylinder turns tighter than its final radius at s = 0.53-0.55 where its first fit did
    not, which refused the tree; that stretch now takes the centre line, the bend check passes, the paths stay
    in the lumen and VMTK's lines of the original mesh lie 0.073 local radii from them on average (asserted
    within 1.5x)."""
    import logging

    name = "gmsh_aortic-arch_open.stl"
    V, F = vesselgp.read_mesh(REAL / name)[:2]
    V = V * MM[name]
    E = igl.edges(F)
    h = float(np.median(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)))
    V = V + igl.per_vertex_normals(V, F) * (0.3 * h * np.random.default_rng(0).standard_normal(len(V)))[:, None]
    with caplog.at_level(logging.INFO, logger="vesselgp.tree"):
        tree = vesselgp.fit_vessel_tree(V, F)
    assert any("turns tighter than its fitted radius" in r.getMessage() for r in caplog.records)
    Vc, Fc = _closed(V, F)
    for p in tree.paths:
        arc = chord_length(p.dense_points)
        inner = (arc > tree.ends[p.ends[0]].radius) & (arc[-1] - arc > tree.ends[p.ends[1]].radius)
        assert np.mean(np.abs(igl.fast_winding_number(Vc, Fc, p.dense_points[inner])) >= 0.5) >= 0.99
    lines = vmtk_lines(name)
    Pr, Rr = np.vstack([q for q, _ in lines]), np.concatenate([r for _, r in lines])
    d = cKDTree(np.vstack([p.dense_points for p in tree.paths])).query(Pr)[0] / Rr
    assert d.mean() <= 1.5 * 0.073


def test_the_capped_arch_centre_lines_are_as_vmtk_reads_them():
    """Issue #44, on the real 4D-flow arch (five flat caps, three junctions): at every point of every cell of its
    centre lines, junctions included, ParallelTransportNormals is a unit vector across the cell's own tangent
    (second-order differences of the cell's points; 0.057 measured, 0.94 when a junction point was shared by
    the parent's and the children's cells), and at each line's ends the inscribed sphere is the lumen's, not 0
    on a cap: MaximumInscribedSphereRadius at least half the fitted radius there (0.69 measured)."""
    from vesselgp.network import centerline_network
    from vesselgp.prepared import PreparedMesh

    name = "cardiopinns_aortic-arch-4dflow_capped.stl"
    V, F = vesselgp.read_mesh(REAL / name)[:2]
    pm = PreparedMesh(V, F)
    net = centerline_network(vesselgp.fit_vessel_tree(pm), pm)
    P, U = net.points, net.point_data["ParallelTransportNormals"]
    mis, mean = net.point_data["MaximumInscribedSphereRadius"], net.point_data["MeanRadius"]
    worst = 0.0
    for c in net.cells:
        T = np.gradient(P[c], axis=0, edge_order=2)
        T /= np.linalg.norm(T, axis=1)[:, None]
        assert np.allclose(np.linalg.norm(U[c], axis=1), 1.0, atol=1e-9)
        worst = max(worst, float(np.abs(np.einsum("ij,ij->i", T, U[c])).max()))
    assert worst < 0.1, worst
    terminal = [c[0] for c, t in zip(net.cells, net.cell_data["TractIds"]) if t == 0] + [c[-1] for c in net.cells]
    assert np.min(mis[terminal] / mean[terminal]) > 0.5


def test_a_tree_says_once_how_its_branches_were_fitted(caplog):
    """Issue #44: the XCAT coronary tree's 19 branch fits (6 converged, 5 stopped at the iteration cap still
    moving, 8 taking the lumen's centre line) give no warning (13 "did not converge" warnings per run before)
    and one INFO line; each branch says what was done (VesselTree.branch_fit, last_step; the CLI's
    tree.json is tested in tests/test_cli_tree.py)."""
    import logging

    name = "xrayangio_xcat-coronary-tree_open.stl"
    V, F = vesselgp.read_mesh(REAL / name)[:2]
    with caplog.at_level(logging.INFO, logger="vesselgp"):
        tree = vesselgp.fit_vessel_tree(V, F)
    warned = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    # the one warning is the check of the axis against its wall's centre (issue #48), where VMTK's line (outside
    # truth) is as far from the axis, beyond the warning's limit: branch 11, 0.13 radii off, VMTK 0.12
    assert all("off the centre of its wall" in m for m in warned) and len(warned) <= 1
    if warned:
        from _reference import polyline_distance

        oc = tree.checks.off_centre
        g = tree.branches[oc.branch]
        d = min(float(polyline_distance(oc.point[None], P)[0]) for P, _ in vmtk_lines(name))
        assert d / float(g.radius_at(oc.s)[0]) >= tol.CHECK_CENTRE_WARN
    lines = [r.getMessage() for r in caplog.records if "branch fits" in r.getMessage()]
    assert len(lines) == 1 and "every axis passed the checks" in lines[0]
    kinds = set(tree.branch_fit)
    assert kinds <= {"converged", "stopped", "centre line"} and len(kinds) == 3
    for b, how in zip(tree.branches, tree.branch_fit):
        assert (how == "converged") == b.converged
        if how == "stopped":  # still moving, but less than TREE_UNSETTLED radii an iteration
            assert 0 < b.last_step < 2 * tol.TREE_UNSETTLED * b.mean_radius


def test_the_intracranial_sac_is_found_and_its_wall_described_by_it():
    """Issue #44, on the gmsh intracranial aneurysm: its sac, a lobe about 24 mm deep that leans along the
    daughter beside it, oval behind a hemispherical dome (no round tube: the tip test failed it, and it was
    not found), is a blind sac (a dome on no round tube, wider than every cut end). Its wall is the wall
    VMTK's lines leave alone (farther than two of their inscribed radii from every point of them, 1922
    vertices): at least 90 % of it is the reported bulge's (96 % measured), and the fit's wall is all
    covered. Without the sac's wall the same fit is refused (3.0 radii of wall: the lobe's foot on the
    daughter's axis is at its mouth, whose exemption hid it, now bounded), with VMTK's inscribed spheres
    as the lumen's."""
    from dataclasses import replace

    from vesselgp.checks import fit_checks
    from vesselgp.errors import NotTubularError
    from vesselgp.prepared import PreparedMesh

    name = "gmsh_intracranial-aneurysm_open.stl"
    V, F = vesselgp.read_mesh(REAL / name)[:2]
    pm = PreparedMesh(V, F)
    assert len(pm.ends) == 3 and len(pm.sacs) == 1
    # the sac's dome: its centre inside the lumen, as deep as VMTK's widest sphere in the lobe is wide, and its
    # pole, a radius out along its direction, on the surface (issue #46: a centre put outside, beyond the pole)
    (c, out, rs), = pm.sacs
    from vesselgp.inside import axis_winding

    w, dist = axis_winding(V, F, np.vstack([c, c + rs * out]))
    assert abs(w[0]) > 0.5 and dist[0] > 0.5 * rs and dist[1] < 0.1 * rs, (w, dist, rs)
    tree = vesselgp.fit_vessel_tree(pm)
    lines = vmtk_lines(name)
    P, R = np.vstack([p for p, _ in lines]), np.concatenate([r for _, r in lines])
    d, i = cKDTree(P).query(V)
    lobe = np.flatnonzero(d > 2 * R[i])
    assert len(lobe) > 1000
    (b,) = tree.bulges
    assert np.isin(lobe, b.wall).mean() >= 0.9
    assert tree.checks.covered_fraction == 1.0 and not tree.checks.uncovered
    bare = replace(tree, bulges=tuple(replace(x, wall=np.zeros(0, np.int64)) for x in tree.bulges))
    with pytest.raises(NotTubularError, match="without an axis"):
        fit_checks(bare, pm, (P, R))
