"""Generalized-cylinder fit (paper Eq. 1-5) against analytic axes and radii, and on real meshes.

The truth is the synthetic vessel's centre line and radius, and for the frames
an RMF integrated from its ODE along the true centre line (tests/_reference.py),
never vesselgp's own RMF.
"""

import igl
import numpy as np
import pytest

import vesselgp
from vesselgp import InvalidMeshError, NotTubularError, fit_generalized_cylinder
from vesselgp.synthetic import named_curve, synthetic_vessel
from _data import REAL
from _docs import figure, table
from _reference import curve_spline, polyline_distance, rmf_ode, signed_angle, unit, wrap

R0 = 1.5

# docs/accuracy.md, fit table: vertices, max axis error (% of the radius) and max radius error (%) over
# the interior 90 %. Measured for issue #12 (helix mesh: 10154 vertices since the synthetic RMF is
# integrated from its ODE; 10152 before):
# 0.164 / 0.102, 0.111 / 0.150, 0.080 / 0.106, 0.759 / 0.132. Each test bound is 1.5 x the figure.
_FIT = table("accuracy.md", "centre line", "vertices", "max axis error (% of radius)")
DOCS_FIT = {name: (int(figure(_FIT[row][0])), figure(_FIT[row][1]), figure(_FIT[row][2])) for name, row in {
    "half_circle": "half circle (bend radius 10)", "helix": "helix (1.5 turns)", "s_curve": "S-curve (inflection)",
    "aortic_arch": "aortic arch (bend radius 3.2 r)"}.items()}
FACTOR = 1.5


def arch_curve():
    """The aortic arch of the synthetic module scaled to a radius-1.5 tube (bend radius 3.2 r)."""
    return named_curve("aortic_arch") * 0.15


CURVES = {
    "half_circle": "arc",
    "helix": "helix",
    "s_curve": "s_curve",
    "aortic_arch": None,
}


@pytest.fixture(scope="module", params=sorted(CURVES))
def fitted(request):
    name = request.param
    curve = CURVES[name] if CURVES[name] is not None else arch_curve()
    ves = synthetic_vessel(
        curve,
        radius=lambda s: R0 * (1 + 0.2 * np.sin(2 * np.pi * s)),  # radius varying by 20 %
        ellipticity=0.7,
        ellipse_angle=0.4,
        n_around=32,
        seed=3,
    )
    return name, ves, fit_generalized_cylinder(ves.V, ves.F)


def _orient(gc, truth):
    """s of the fit may run either way between two equal-looking ends."""
    if np.linalg.norm(gc.centers[0] - truth.centers[0]) < np.linalg.norm(gc.centers[0] - truth.centers[-1]):
        return gc.s
    return 1.0 - gc.s


def test_axis_error_within_readme_figure(fitted):
    """Exact distance from the fitted axis to the true centre line: docs/accuracy.md, fit table."""
    name, ves, gc = fitted
    n_readme, axis_pct, _ = DOCS_FIT[name]
    assert abs(len(ves.V) - n_readme) <= 0.05 * n_readme, "not the documented mesh any more"
    inner = (gc.dense_s > 0.05) & (gc.dense_s < 0.95)
    d = polyline_distance(gc.dense_points[inner], ves.truth.centers)
    assert d.max() <= FACTOR * axis_pct / 100 * R0, f"{name}: axis off by {d.max() / R0:.3%} of the radius"
    # length: measured within 0.32 % of a radius (aortic arch), 0.016-0.13 % on the others
    assert abs(gc.length - ves.truth.length) <= 0.005 * R0


def test_radius_error_within_readme_figure(fitted):
    """Perimeter-mean radius (what Eq. 4 estimates) against the truth: docs/accuracy.md, fit table.

    The bounds (0.15-0.23 %) are far below a 0.8 % bias of the radius."""
    name, ves, gc = fitted
    _, _, radius_pct = DOCS_FIT[name]
    s_true = _orient(gc, ves.truth)
    r_true = np.interp(s_true, ves.truth.s, ves.truth.radii)
    inner = (gc.s > 0.05) & (gc.s < 0.95)
    err = np.abs(gc.radii - r_true)[inner] / r_true[inner]
    assert err.max() <= FACTOR * radius_pct / 100, f"{name}: radius off by {err.max():.3%}"


def reference_frames(truth, s_true, n=2001):
    """Points, tangents and RMF normals of the true centre line at true ``s``: ODE transport.

    The RMF is integrated along a quintic spline of the true centres (scipy only) from an
    arbitrary start normal; only angles relative to it up to one constant are meaningful.
    """
    u, sp = curve_spline(truth.centers)
    grid = np.linspace(0, u[-1], n)
    T0 = unit(sp.derivative(1)(0.0))
    U0 = np.cross(T0, [1.0, 0, 0] if abs(T0[0]) < 0.9 else [0, 1.0, 0])
    Tg, Ug = rmf_ode(grid, sp.derivative(1), sp.derivative(2), U0)
    uq = np.interp(s_true, truth.s, u)
    T = unit(np.stack([np.interp(uq, grid, Tg[:, k]) for k in range(3)], 1))
    U = np.stack([np.interp(uq, grid, Ug[:, k]) for k in range(3)], 1)
    U = unit(U - np.sum(U * T, 1)[:, None] * T)
    return sp(uq), T, U


def test_fitted_frames_are_the_rmf_of_the_true_axis(fitted):
    """U of the fit turns against the RMF of the true centre line by a constant only.

    Measured drift: 0.007-0.009 degrees (half circle, helix, S-curve), 0.025 (aortic arch,
    bend radius 3.2 r); bound 1.5 x 0.025. A spurious RMF twist of 2 degrees fails it."""
    name, ves, gc = fitted
    s_true = _orient(gc, ves.truth)
    _, T, U = reference_frames(ves.truth, s_true)
    inner = (gc.s > 0.05) & (gc.s < 0.95)
    # tangents agree (worst 1.8 degrees where the arch's curvature jumps at its C1 joins)
    assert np.abs(np.abs(np.sum(T * gc.frames[:, 0], 1)) - 1)[inner].max() < 1e-3
    a = signed_angle(T, U, gc.frames[:, 1])[inner]  # a transported normal is one whichever way T points
    drift = np.degrees(np.abs(wrap(a - a[0])))
    assert drift.max() <= FACTOR * 0.025, f"{name}: fitted frame drifts {drift.max():.4f} deg from the RMF"


def test_frames_are_rmf_and_vertex_parameters_consistent(fitted):
    name, ves, gc = fitted
    T, U, V = gc.frames[:, 0], gc.frames[:, 1], gc.frames[:, 2]
    assert np.abs(np.einsum("ij,ij->i", T, U)).max() < 1e-12
    assert np.allclose(np.cross(T, U), V, atol=1e-12)
    # every vertex is reproduced by its parameters: p = m(s) + frame(s)^T local
    pts, fr = gc.at(gc.vertex_s)
    rec = pts + np.einsum("nji,nj->ni", fr, gc.vertex_local)
    assert np.abs(rec - ves.V).max() < 1e-9
    # wall vertices lie in their section plane and at the wall radius
    w = gc.vertex_weight > 0
    assert np.abs(gc.vertex_local[w, 0]).max() < 1e-6 * gc.length
    # the angle theta_i agrees with the vertex's angle about the true centre line from its
    # RMF (ODE reference, at the vertex's true s) up to one constant (the choice of U at
    # s = 0); a reversed axis turns angles the other way. Measured spread: 0.05-0.10 degrees,
    # 0.50 on the aortic arch (bend radius 3.2 r)
    reversed_axis = _orient(gc, ves.truth)[0] != 0
    s_true = 1 - gc.vertex_s if reversed_axis else gc.vertex_s
    sign = -1.0 if reversed_axis else 1.0
    inner = w & (s_true > 0.05) & (s_true < 0.95)
    m, Tr, Ur = reference_frames(ves.truth, ves.truth.vertex_s[inner])
    theta_ref = signed_angle(Tr, Ur, ves.V[inner] - m)
    d = wrap(gc.vertex_theta[inner] - sign * theta_ref)
    mean = np.angle(np.mean(np.exp(1j * d)))
    spread = np.abs(wrap(d - mean))
    assert np.degrees(spread).max() < 0.75
    # s of each vertex is its true section's s (measured 0.006-0.01 r, 0.039 r on the arch)
    assert np.abs(s_true[inner] - ves.truth.vertex_s[inner]).max() * gc.length < 0.05 * R0


def test_centroid_bias_removed_on_a_bent_tube():
    """Eq. 1's centroid sits ~kappa r^2 / 2 outside the bend; the fit does not."""
    bend = 10.0
    ves = synthetic_vessel(named_curve("arc", bend_radius=bend), radius=R0, n_around=32, seed=1)
    gc = fit_generalized_cylinder(ves.V, ves.F)
    # naive Eq. 1: area-weighted centroid of the vertices of each section
    area = igl.massmatrix(ves.V, ves.F, igl.MASSMATRIX_TYPE_VORONOI).diagonal()
    b = np.minimum((ves.truth.vertex_s * 40).astype(int), 39)
    cen = np.stack([np.bincount(b, area * ves.V[:, k], 40) for k in range(3)], 1) / np.bincount(b, area, 40)[:, None]
    centre_of_bend = np.array([bend, 0.0, 0.0])
    naive = np.linalg.norm(cen[4:-4] - centre_of_bend, axis=1) - bend
    assert np.median(naive) > 0.5 * R0**2 / bend / 2  # the bias exists (~0.11 here)
    inner = (gc.dense_s > 0.05) & (gc.dense_s < 0.95)
    ours = np.linalg.norm(gc.dense_points[inner] - centre_of_bend, axis=1) - bend
    assert np.abs(ours).max() < 0.1 * np.median(naive)


def test_rigid_motion_and_renumbering_invariance():
    ves = synthetic_vessel("helix", radius=R0, ellipticity=0.8, n_around=24, seed=5)
    gc = fit_generalized_cylinder(ves.V, ves.F)
    rng = np.random.default_rng(0)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    Q *= np.sign(np.linalg.det(Q))
    t = np.array([12.0, -40.0, 7.0])
    perm = rng.permutation(len(ves.V))
    inv = np.argsort(perm)
    V2 = (ves.V @ Q.T + t)[perm]
    F2 = inv[ves.F]
    gc2 = fit_generalized_cylinder(V2, F2)
    scale = gc.length
    if np.linalg.norm(gc2.centers[0] - (gc.centers[0] @ Q.T + t)) > 0.5 * scale:
        pytest.fail("end order changed under a rigid motion")
    assert np.abs(gc2.centers - (gc.centers @ Q.T + t)).max() <= 1e-6 * scale
    assert np.abs(gc2.radii - gc.radii).max() <= 1e-6 * gc.radii.max()
    assert np.abs(gc2.vertex_s[inv] - gc.vertex_s).max() <= 1e-6
    dtheta = np.angle(np.exp(1j * (gc2.vertex_theta[inv] - gc.vertex_theta)))
    assert np.abs(dtheta).max() <= 1e-6


def test_at_interpolates_frames_smoothly():
    ves = synthetic_vessel("arc", radius=R0, n_around=24, remesh=False)
    gc = fit_generalized_cylinder(ves.V, ves.F)
    pts, fr = gc.at(np.linspace(0, 1, 500))
    assert np.allclose(np.einsum("nij,nkj->nik", fr, fr), np.eye(3), atol=1e-12)
    assert np.allclose(np.linalg.det(fr), 1.0)
    # the axis of a half circle of bend radius 10 stays on it
    assert np.abs(np.linalg.norm(pts - [10, 0, 0], axis=1) - 10).max() < 0.01 * R0


def test_capped_vessel_fits_through_caps():
    ves = synthetic_vessel("arc", radius=R0, ends="capped", n_around=32, seed=2)
    gc = fit_generalized_cylinder(ves.V, ves.F)
    on_cap = ves.truth.vertex_on_cap
    assert (gc.vertex_weight[on_cap] == 0).all()  # cap faces are not wall
    inner = (gc.dense_s > 0.05) & (gc.dense_s < 0.95)
    assert polyline_distance(gc.dense_points[inner], ves.truth.centers).max() <= 0.01 * R0
    assert np.abs(gc.radii[2:-2] - R0).max() <= 0.01 * R0


def test_short_vessel_is_not_tubular():
    ves = synthetic_vessel(named_curve("straight", length=2.0), radius=R0, n_around=24, remesh=False)
    with pytest.raises(NotTubularError, match="shorter than its diameter"):
        fit_generalized_cylinder(ves.V, ves.F)


def test_unreferenced_vertices_are_reported():
    ves = synthetic_vessel("straight", radius=R0, n_around=12, remesh=False)
    V = np.vstack([ves.V, [[100.0, 0, 0]]])
    with pytest.raises(InvalidMeshError, match="clean_mesh"):
        fit_generalized_cylinder(V, ves.F)


# ----------------------------------------------------------------------------- real meshes


def close_holes(V, F):
    """Fan-fill every boundary loop (to test inside/outside of an open tube)."""
    Vs, Fs = [V], [F]
    n = len(V)
    directed = {(int(a), int(b)) for f in F for a, b in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
    for loop in igl.boundary_loop_all(F):
        loop = np.asarray(loop)
        if (int(loop[0]), int(loop[1])) in directed:  # the fan must run against the mesh's edge
            loop = loop[::-1]
        c = V[loop].mean(axis=0)
        Vs.append(c[None])
        Fs.append(np.c_[loop, np.roll(loop, -1), np.full(len(loop), n)])
        n += 1
    return np.vstack(Vs), np.vstack(Fs)


def assert_axis_inside(V, F, gc):
    Vc, Fc = close_holes(V, F)
    inner = (gc.dense_s > 0.02) & (gc.dense_s < 0.98)
    wn = igl.fast_winding_number(Vc, Fc, gc.dense_points[inner])
    assert np.abs(wn).min() > 0.5, "axis leaves the lumen"
    # and it is well inside: at least a third of the local radius from the wall
    d = np.sqrt(igl.point_mesh_squared_distance(gc.dense_points[inner], V, F)[0])
    r = gc.radius_at(gc.dense_s[inner])
    assert (d / r).min() > 0.3


@pytest.mark.parametrize(
    "fname, ends",
    [
        ("dfemtoolz_artery_segment_lumen_capped.stl", None),
        ("xra_coronary_single_branch_open.stl", None),
    ],
)
def test_real_single_vessels(fname, ends):
    V, F = vesselgp.read_mesh(REAL / fname)
    gc = fit_generalized_cylinder(V, F, ends=ends)
    assert np.all(np.isfinite(gc.centers)) and np.all(gc.radii > 0)
    assert_axis_inside(V, F, gc)
    # radii in the documented ranges (SOURCES.md): coronary-sized, mm
    assert 0.8 < np.median(gc.radii) < 3.0


def test_real_bifurcation_needs_chosen_ends_and_follows_each_path():
    V, F = vesselgp.read_mesh(REAL / "vmtk_abdominal_aorta_iliac_bifurcation_open.stl")
    ends = vesselgp.vessel_ends(V, F)
    assert len(ends) == 3
    with pytest.raises(vesselgp.EndsError, match="ends=\\(i, j\\)"):
        fit_generalized_cylinder(V, F)
    aorta = int(np.argmax([e.radius for e in ends]))
    for iliac in (i for i in range(3) if i != aorta):
        gc = fit_generalized_cylinder(V, F, ends=(aorta, iliac))
        assert gc.ends == (aorta, iliac)
        assert np.linalg.norm(gc.centers[0] - ends[aorta].center) < 1e-6
        assert np.linalg.norm(gc.centers[-1] - ends[iliac].center) < 1e-6
        assert_axis_inside(V, F, gc)
        # the radius goes from the aorta's (7.7 mm) to the iliac's (4.4 mm)
        assert gc.radii[:3].mean() > 1.3 * gc.radii[-3:].mean()


def test_areas_on_a_second_thread_give_the_same_fit_and_the_ends_errors(monkeypatch):
    """Large meshes compute the wall's areas on a thread beside the end detection: the same fit bit
    for bit (the real Y, a path between two of its three ends), and an error of the ends still
    reaches the caller (the thread is waited for)."""
    V, F = vesselgp.read_mesh(REAL / "vmtk_abdominal_aorta_iliac_bifurcation_open.stl")
    serial = fit_generalized_cylinder(V, F, ends=(0, 1))
    monkeypatch.setattr(vesselgp.tolerances, "THREAD_MIN_VERTICES", 0)
    threaded = fit_generalized_cylinder(V, F, ends=(0, 1))
    for name in ("centers", "radii", "frames", "vertex_s", "vertex_theta", "vertex_area"):
        assert np.array_equal(getattr(serial, name), getattr(threaded, name), equal_nan=True), name
    with pytest.raises(vesselgp.EndsError, match="ends=\\(i, j\\)"):
        fit_generalized_cylinder(V, F)


def test_coarse_harmonic_from_the_unique_edges_is_the_one_from_the_faces(monkeypatch):
    """The coarse harmonic initialisation joins its cells along the mesh's edges: read once each
    (the topology's edge list) or as the faces' corners (each interior edge twice), the cell graph
    and so the field must be the same, bit for bit; and the field runs from 0 at one end to 1 at
    the other along the vessel."""
    import vesselgp.fit as fit
    from vesselgp import tolerances as tol
    from vesselgp.mesh import mesh_topology

    monkeypatch.setattr(tol, "GC_COARSE_INIT_VERTICES", 1000)
    ves = synthetic_vessel("s_curve", radius=R0, n_around=24, remesh=True, seed=2)
    V, F = ves.V, ves.F
    ends = vesselgp.vessel_ends(V, F)
    b = np.concatenate([ends[0].vertices, ends[1].vertices])
    bc = np.r_[np.zeros(len(ends[0].vertices)), np.ones(len(ends[1].vertices))]
    area = float(igl.doublearea(V, F).sum() / 2)
    a = fit._harmonic_between(V, F, b, bc, R0, area)
    e = fit._harmonic_between(V, F, b, bc, R0, area, mesh_topology(F, len(V)).edges)
    assert len(V) > 1000 and np.array_equal(a, e)
    along = np.corrcoef(a, (V - ends[0].center) @ (ends[1].center - ends[0].center))[0, 1]
    assert a.min() >= -1e-9 and a.max() <= 1 + 1e-9 and along > 0.9


def test_fixed_points_in_lock_step_equal_each_problem_alone(monkeypatch):
    """A tree's branches iterate on one stack (vesselgp.fit.fixed_points): each problem must get the
    same nodes, parameters, radii and iteration count, bit for bit, as alone, also while the stack
    shrinks (problems converging after different numbers of iterations)."""
    import vesselgp.fit as fit
    from vesselgp import tolerances as tol

    seen, real = [], fit.fixed_points
    monkeypatch.setattr(fit, "fixed_points", lambda problems, **kw: seen.extend(problems) or real(problems, **kw))
    for curve, n in (("arc", 24), ("helix", 20), ("s_curve", 28)):
        ves = synthetic_vessel(curve, radius=R0, n_around=n, remesh=False, noise=0.01, seed=5)
        fit_generalized_cylinder(ves.V, ves.F)
    kw = dict(lam=tol.GC_LAMBDA, mu=tol.GC_MU, max_iter=tol.GC_MAX_ITER)
    together = real(seen, **kw)
    alone = [real([p], **kw)[0] for p in seen]
    assert len(seen) == 3 and len({a.count for a in alone}) > 1
    for a, b in zip(alone, together):
        assert (a.count, a.converged) == (b.count, b.converged) and a.converged
        for x, y in ((a.nodes, b.nodes), (a.s, b.s), (a.radii, b.radii), (a.rejected, b.rejected)):
            assert np.array_equal(x, y)


@pytest.mark.parametrize("case", ["arch", "coronary"])
def test_a_converged_fit_is_at_its_fixed_point_within_the_tolerance(case, monkeypatch):
    """``converged`` means the axis is within about the tolerance of the fixed point: iterated on
    with a tolerance 10^4 times smaller, the axis moves by at most 2.5 GC_CONVERGENCE radii."""
    from vesselgp import tolerances as tol

    if case == "arch":
        ves = synthetic_vessel("aortic_arch", radius=1.5, n_around=32, noise=0.02, seed=3)
        V, F = ves.V, ves.F
    else:
        V, F = vesselgp.read_mesh(REAL / "xra_coronary_single_branch_open.stl")[:2]
    a = fit_generalized_cylinder(V, F)
    assert a.converged
    bound = 2.5 * tol.GC_CONVERGENCE * a.mean_radius
    monkeypatch.setattr(tol, "GC_CONVERGENCE", 1e-4 * tol.GC_CONVERGENCE)
    b = fit_generalized_cylinder(V, F, max_iter=80)
    assert b.converged and b.iterations > a.iterations
    assert np.abs(a.centers - b.centers).max() < bound
    assert np.abs(a.radii - b.radii).max() < bound


@pytest.mark.parametrize("case, axis_pct", [("helix", 0.015), ("arch", 1.1)])
def test_a_thinned_fit_matches_the_truth_and_puts_every_vertex_at_its_foot(case, axis_pct, monkeypatch):
    """Large meshes iterate on an evenly thinned quarter of their vertices, from the coarse (vertex-
    clustered) harmonic initialisation; every vertex then starts from its mesh neighbours' converged
    parameters. Forced here on 10k-vertex tubes: the axis against the true centre line (measured 0.009 %
    of the radius on the circular helix, 0.71 % on the elliptical structured arch, as without thinning),
    and every wall vertex in its section plane (|x_T| measured 4e-10 L) at its true section's s."""
    from vesselgp import tolerances as tol

    if case == "helix":
        ves = synthetic_vessel("helix", radius=lambda s: R0 * (1 + 0.2 * np.sin(2 * np.pi * s)), n_around=32, seed=3)
    else:
        ves = synthetic_vessel(arch_curve(), radius=lambda s: R0 * (1 + 0.2 * np.sin(2 * np.pi * s)),
                               ellipticity=0.8, n_around=48, remesh=False, seed=3)
    monkeypatch.setattr(tol, "GC_MAX_FIT_VERTICES", len(ves.V) // 4)
    monkeypatch.setattr(tol, "GC_COARSE_INIT_VERTICES", 2000)
    gc = fit_generalized_cylinder(ves.V, ves.F)
    inner = (gc.dense_s > 0.05) & (gc.dense_s < 0.95)
    d = polyline_distance(gc.dense_points[inner], ves.truth.centers)
    assert d.max() <= axis_pct / 100 * R0, f"axis off by {d.max() / R0:.3%} of the radius"
    w = gc.vertex_weight > 0
    assert np.abs(gc.vertex_local[w, 0]).max() < 1e-6 * gc.length
    reversed_axis = _orient(gc, ves.truth)[0] != 0
    s = 1 - gc.vertex_s if reversed_axis else gc.vertex_s
    inn = (ves.truth.vertex_s > 0.05) & (ves.truth.vertex_s < 0.95)
    assert np.abs(s - ves.truth.vertex_s)[inn].max() * gc.length < 0.05 * R0


@pytest.mark.parametrize("per_vertex", [8, 0])
def test_grid_cells_number_cubes_as_numpy_unique_does(per_vertex, monkeypatch):
    """The coarse initialisation's vertex clustering: each vertex's cube of side h, numbered in the
    lexicographic order of the cubes' integer coordinates; through the dense table (8 cells per vertex)
    and the sorted branch (0). Truth: numpy's unique rows of the floored coordinates."""
    from vesselgp import tolerances as tol
    from vesselgp.fit import _grid_cells

    monkeypatch.setattr(tol, "GRID_TABLE_PER_VERTEX", per_vertex)
    rng = np.random.default_rng(4)
    V = rng.normal(size=(3000, 3)) * [5.0, 1.0, 2.0] + [100.0, -40.0, 7.0]
    V[:2] = V.min(axis=0)  # a vertex on the grid's corner
    h = 0.7
    _, truth = np.unique(np.floor((V - V.min(axis=0)) / h).astype(np.int64), axis=0, return_inverse=True)
    cell = _grid_cells(V, h)
    assert cell.dtype == np.int32
    np.testing.assert_array_equal(cell, truth.ravel())


def _sparse_elliptic_helix(ellipticity, n_around):
    return synthetic_vessel("helix", radius=lambda s: 1.0 + 0.2 * np.sin(2 * np.pi * s), ellipticity=ellipticity,
                            ellipse_angle=0.4, n_around=n_around, seed=3)


def _helix_axis_error(ves, gc):
    inner = (gc.dense_s > 0.05) & (gc.dense_s < 0.95)
    return polyline_distance(gc.dense_points[inner], ves.truth.centers).max()


def test_a_kinked_fit_of_a_sparse_elliptical_section_raises_and_a_stiffer_axis_fits():
    """Found in the #16 work: an elliptical helix meshed with few vertices around (isotropic remesh) makes the
    fixed point kink (curvature x radius over 1 where a tube allows less). That must raise, not return; the remedy
    the message names (lam=1.0) fits it. Since issue #48's elliptic sections (vesselgp.sections) the 0.7 helix 14
    around that kinked then (12 % r off) is followed on the defaults within 0.01 % r (measured; 1.5x); a 0.75 helix
    12 around, its sections' second harmonic under GC_ELLIPTIC, still kinks, and lam=1.0 fits it within 0.69 % r
    (measured; 1.5x)."""
    ves = _sparse_elliptic_helix(0.7, 14)
    assert _helix_axis_error(ves, fit_generalized_cylinder(ves.V, ves.F)) <= FACTOR * 0.0001
    ves = _sparse_elliptic_helix(0.75, 12)
    with pytest.raises(NotTubularError, match=r"bends tighter than its radius at s = .*lam=1\.0"):
        fit_generalized_cylinder(ves.V, ves.F)
    gc = fit_generalized_cylinder(ves.V, ves.F, lam=1.0)
    d = _helix_axis_error(ves, gc)
    assert d <= FACTOR * 0.0069, f"axis off by {d:.3%} of the radius"


@pytest.mark.parametrize("free", ["first", "last"])
def test_a_free_end_node_moves_onto_the_axis_and_a_pinned_one_stays(free):
    """A tree branch's junction side is not pinned (Eq. 3's correction is solved there too).
    Rings of a cylinder about the z axis, radius 1; the axis nodes on it but one end node 0.2
    off in x. Free, that node comes back onto the z axis in a few circle-fit steps; pinned, it
    stays where it was, and the other end stays in both cases."""
    from vesselgp.axis import Axis, circle_fit_correction, local_coords

    z = np.arange(0.0, 11.0 + 1e-9, 0.05)
    th = np.linspace(0, 2 * np.pi, 48, endpoint=False)
    P = np.stack([np.repeat(np.cos(th)[None], len(z), 0), np.repeat(np.sin(th)[None], len(z), 0),
                  np.repeat(z[:, None], len(th), 1)], axis=-1).reshape(-1, 3)
    k = 0 if free == "first" else -1
    for pin in ((free == "last", free == "first"), True):
        nodes = np.c_[np.zeros(12), np.zeros(12), np.linspace(0.0, 11.0, 12)]
        nodes[k, 0] = 0.2
        for _ in range(6):
            ax = Axis(nodes)
            s = np.clip(ax.project(P, P[:, 2] / 11.0, None, 3), 0, 1)
            local, _ = local_coords(ax, P, s)
            nodes = nodes + circle_fit_correction(ax.node_frames(), nodes, s, local, np.ones(len(P)), 1e-3, 1.0, pin)
        if pin is True:
            assert nodes[k, 0] == 0.2 and nodes[k, 1] == 0.0
        else:
            assert np.hypot(*nodes[k, :2]) < 1e-3, nodes[k]
        assert np.hypot(*nodes[-1 - k, :2]) == 0.0  # the pinned end
        assert np.abs(nodes[3:-3, :2]).max() < 0.01  # the middle, on the axis


def test_a_singular_problem_stops_alone_in_a_tree_and_raises_alone(monkeypatch):
    """``fixed_points(..., singular="stop")`` (a tree's branches): a problem with no data (every vertex's
    area 0: no wall around its nodes, its circle-fit system singular) stops, marked singular with an
    infinite step, while the others get bit for bit what they get alone; by default it raises."""
    import dataclasses

    import vesselgp.fit as fit
    from vesselgp import tolerances as tol
    from vesselgp.errors import NotTubularError

    seen, real = [], fit.fixed_points
    monkeypatch.setattr(fit, "fixed_points", lambda problems, **kw: seen.extend(problems) or real(problems, **kw))
    ves = synthetic_vessel("arc", radius=R0, n_around=24, remesh=False, noise=0.01, seed=5)
    fit_generalized_cylinder(ves.V, ves.F)
    good = seen[0]
    empty = dataclasses.replace(good, areas=np.zeros_like(good.areas))
    kw = dict(lam=tol.GC_LAMBDA, mu=tol.GC_MU, max_iter=tol.GC_MAX_ITER)
    a, b = real([good, empty], singular="stop", **kw)
    alone = real([good], **kw)[0]
    assert a.converged and not a.singular and a.count == alone.count
    assert np.array_equal(a.nodes, alone.nodes) and np.array_equal(a.radii, alone.radii)
    assert b.singular and not b.converged and b.step == np.inf and b.count == 0
    with pytest.raises(NotTubularError, match="singular"):
        real([good, empty], **kw)


def test_the_final_weight_follows_the_scatter_at_its_edges():
    """vesselgp.fit.data_lambda (issue #48) at its edges, from residuals of a known robust scatter: +-s / 1.4826
    alternately (robust sigma 1.4826 median |e| exactly s). lam holds for GC_LAMBDA_VERTICES vertices per segment and
    fewer (20.0 per segment) and scales from just above (20.1); lam * (s / GC_LAMBDA_SCATTER)^2 between the
    floor and 1; the floor just below its scatter, lam itself just above GC_LAMBDA_SCATTER."""
    from vesselgp import tolerances as tol
    from vesselgp.fit import data_lambda

    def residuals(sigma, n):
        return sigma / 1.4826 * np.where(np.arange(n) % 2, 1.0, -1.0)

    K, lam = 11, 0.3
    ref, floor = tol.GC_LAMBDA_SCATTER, tol.GC_LAMBDA_FLOOR
    per = tol.GC_LAMBDA_VERTICES
    assert data_lambda(lam, residuals(0.5 * ref, int(per * (K - 1))), K) == lam  # sparse: lam
    n = int(per * (K - 1)) + 1  # just above: scaled by (sigma / ref)^2
    assert data_lambda(lam, residuals(0.5 * ref, n), K) == pytest.approx(lam * 0.25, rel=1e-12)
    s_floor = ref * np.sqrt(floor)
    assert data_lambda(lam, residuals(0.98 * s_floor, n), K) == pytest.approx(lam * floor, rel=1e-12)
    assert data_lambda(lam, residuals(1.02 * s_floor, n), K) == pytest.approx(lam * floor * 1.02**2, rel=1e-12)
    assert data_lambda(lam, residuals(0.98 * ref, n), K) == pytest.approx(lam * 0.98**2, rel=1e-12)
    assert data_lambda(lam, residuals(1.02 * ref, n), K) == lam
    assert data_lambda(lam, np.zeros(0), K) == lam  # no radii yet
