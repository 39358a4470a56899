"""Synthetic vessels (issue #3): topology, orientation and ground-truth geometry.

The twist checks are independent of any torsion module: on structured tubes
(``remesh=False``) the vector from a ring's centre to its j-th vertex is
measured against an RMF recomputed from the ring centres alone.
"""
import time

import igl
import numpy as np
import pytest

from vesselgp import synthetic as S
from vesselgp.curves import frenet, rotation_minimizing_frames, transport_angle
from vesselgp.errors import FrameError, InvalidMeshError, VesselError

R = 1.5


def n_rings_of(v, n_around):
    n = len(v.V) - (2 if v.truth.vertex_on_cap.any() else 0)
    assert n % n_around == 0
    return n // n_around


def ring_drift(V, n_around, n_rings):
    """Angle (rings x n_around) of each ring vector about the independent RMF,
    minus that of ring 0, unwrapped along the rings."""
    rings = V[: n_rings * n_around].reshape(n_rings, n_around, 3)
    C = rings.mean(axis=1)
    T, U, _ = rotation_minimizing_frames(C)
    W = rings - C[:, None, :]
    ang = np.stack([transport_angle(T, U, W[:, j]) for j in range(n_around)], axis=1)
    return np.unwrap(ang - ang[0], axis=0), C


def topology(V, F):
    ncomp = len(np.unique(igl.vertex_components(F)))
    return ncomp, bool(igl.is_edge_manifold(F)[0]), igl.boundary_loop_all(F)


def axis_frames(v):
    t = v.truth
    c, fr = t.axis_at(t.vertex_s)
    return c, fr


# --------------------------------------------------------------------------- curves


@pytest.mark.parametrize("name", sorted(S.CURVE_NAMES))
def test_named_curves_start_at_origin_and_are_smooth(name):
    P = S.named_curve(name)
    assert P.shape == (2000, 3)
    assert np.allclose(P[0], 0)
    d = np.linalg.norm(np.diff(P, axis=0), axis=1)
    assert d.min() > 0
    t = np.diff(P, axis=0) / d[:, None]
    # no kinks: consecutive chords turn by less than 2 degrees
    assert np.max(np.arccos(np.clip(np.sum(t[1:] * t[:-1], axis=1), -1, 1))) < np.deg2rad(2)


def test_aortic_arch_dimensions():
    P = S.named_curve("aortic_arch")
    assert 48 < P[:, 2].max() - 32 < 52  # ascending ~50 mm then an arch of radius 32
    assert 95 < P[:, 2].max() - P[-1, 2] - 32 < 105  # descending ~100 mm down
    assert np.ptp(P[:, 1]) > 10  # out-of-plane component


def test_bad_inputs_raise():
    with pytest.raises(VesselError):
        S.named_curve("spiral")
    with pytest.raises(VesselError):
        S.named_curve("arc", radius=3)
    with pytest.raises(InvalidMeshError):
        S.synthetic_vessel("straight", radius=-1.0, remesh=False)
    with pytest.raises(InvalidMeshError):  # radius 9.5 on a bend of radius 10 folds
        S.synthetic_vessel("arc", radius=9.5, remesh=False)
    with pytest.raises(VesselError):
        S.synthetic_vessel("straight", ends="closed")
    with pytest.raises(InvalidMeshError):
        S.synthetic_vessel("straight", bulges=[(0.5, 0.0, 0.3)], remesh=False)


def test_bad_initial_normal_and_twist_raise():
    """The truth RMF's start and the twist are validated, not turned into NaN vertices."""
    with pytest.raises(FrameError, match="initial_normal is parallel to the first tangent"):
        S.synthetic_vessel("straight", initial_normal=[0, 0, 2.0], remesh=False)
    with pytest.raises(FrameError, match="initial_normal is the zero vector"):
        S.synthetic_vessel("straight", initial_normal=[0, 0, 0], remesh=False)
    with pytest.raises(InvalidMeshError, match="twist"):
        S.synthetic_vessel("arc", twist=lambda s: np.where(s > 0.5, np.nan, s), n_around=8, remesh=False)
    rest = S.synthetic_vessel("straight", n_around=8, remesh=False)
    with pytest.raises(InvalidMeshError, match="twist"):
        S.deform_synthetic(rest, "arc", twist=lambda s: np.where(s < 0.5, s, np.inf))
    x = np.r_[np.linspace(0, 1, 10), np.linspace(0.95, 0, 10)]  # out along x and back: a cusp
    with pytest.raises(FrameError, match="tangent vanishes"):
        S.synthetic_vessel(np.c_[x, np.zeros(20), np.zeros(20)], radius=0.01, remesh=False)


# --------------------------------------------------------------------------- twist


@pytest.mark.parametrize("name", ["helix", "aortic_arch", "s_curve"])
def test_rmf_sweep_has_zero_twist(name):
    r = 12.0 if name == "aortic_arch" else R
    v = S.synthetic_vessel(name, radius=r, n_around=24, remesh=False)
    drift, _ = ring_drift(v.V, 24, n_rings_of(v, 24))
    # measured: ~1e-9 (helix, s-curve); 2e-5 on the arch, whose curvature jumps at the
    # C1 joins blur the spline tangents of the coarse (3 mm) ring-centre polyline
    assert np.abs(drift).max() < 1e-4


def test_frenet_sweep_twists_by_integral_of_torsion():
    """A naive Frenet sweep of the same helix turns by int tau ds: the test above can see twist."""
    v = S.synthetic_vessel("helix", radius=R, n_around=24, remesh=False)
    k = n_rings_of(v, 24)
    s = np.linspace(0, 1, k)
    C, _ = v.truth.axis_at(s)
    fr = frenet(C)
    assert fr.defined.all()
    T = np.gradient(C, axis=0)
    T /= np.linalg.norm(T, axis=1)[:, None]
    N = fr.normal
    B = np.cross(T, N)
    th = 2 * np.pi * np.arange(24) / 24
    Vf = (C[:, None] + R * (np.cos(th)[None, :, None] * N[:, None] + np.sin(th)[None, :, None] * B[:, None]))
    drift, _ = ring_drift(Vf.reshape(-1, 3), 24, k)
    a, c = 8.0, 20.0 / (2 * np.pi)
    expected = c / (a * a + c * c) * v.truth.length  # 3.48 rad for the default helix
    assert expected > 3
    assert np.allclose(drift[-1], expected, rtol=5e-3)
    # linear in s, like a uniform twist
    assert np.allclose(drift[:, 0], expected * s, atol=2e-2)


def test_imposed_twist_is_measured_against_the_rmf():
    phi = 2.0
    v = S.synthetic_vessel("arc", radius=R, twist=phi, n_around=24, remesh=False)
    k = n_rings_of(v, 24)
    drift, _ = ring_drift(v.V, 24, k)
    assert np.allclose(drift, phi * np.linspace(0, 1, k)[:, None], atol=1e-5)
    assert np.allclose(v.truth.alpha, phi * v.truth.s)


@pytest.mark.parametrize("target", ["arc", "helix"])
def test_deform_synthetic_imposes_known_twist(target):
    rest = S.synthetic_vessel("straight", radius=R, n_around=24, remesh=False)
    k = n_rings_of(rest, 24)
    s = np.linspace(0, 1, k)
    P = S.named_curve(target) if target == "arc" else S.named_curve("helix", radius=6.0, pitch=30.0, turns=0.5)
    for phi in (None, -1.3):
        Vd = S.deform_synthetic(rest, P, twist=phi)
        drift, C = ring_drift(Vd, 24, k)
        want = 0.0 if phi is None else phi * s[:, None]
        assert np.allclose(drift, want, atol=1e-5)
        # unstretched axis and unchanged sections
        assert np.isclose(np.sum(np.linalg.norm(np.diff(C, axis=0), axis=1)), rest.truth.length, rtol=1e-4)
        rd = np.linalg.norm(Vd.reshape(k, 24, 3) - C[:, None], axis=2)
        assert np.allclose(rd, R, rtol=1e-9)
    # the straight rest and the arc start along +z: the first ring does not move without twist
    if target == "arc":
        assert np.allclose(S.deform_synthetic(rest, P)[:24], rest.V[:24], atol=1e-9)


def test_deform_remeshed_vessel_keeps_vertex_truth():
    rest = S.synthetic_vessel("straight", radius=R, ellipticity=0.7, n_around=24)
    Vd = S.deform_synthetic(rest, "arc", twist=0.9)
    t = rest.truth
    P = S.named_curve("arc")
    ax = S._arc_length_axis(P, None)
    ax = S._axis_from_centers(ax.centers[0] + t.length / ax.length * (ax.centers - ax.centers[0]), [1, 0, 0])
    T, U, V = ax.frames(t.vertex_s)
    D = Vd - ax.point(t.vertex_s)
    assert np.abs(np.sum(D * T, axis=1)).max() < 1e-9  # in the new section plane
    assert np.allclose(np.linalg.norm(D, axis=1), np.linalg.norm(t.vertex_offset, axis=1))
    ang = transport_angle(T, U, D) - t.vertex_theta
    assert np.abs(np.angle(np.exp(1j * (ang - 0.9 * t.vertex_s)))).max() < 1e-9


# --------------------------------------------------------------------------- radius truth


def perimeter_mean_of_rings(V, n_around, n_rings):
    rings = V[: n_rings * n_around].reshape(n_rings, n_around, 3)
    C = rings.mean(axis=1)  # the axis point for sections with 2- or 3-fold symmetry
    d = np.linalg.norm(rings - C[:, None], axis=2)
    seg = np.linalg.norm(np.roll(rings, -1, axis=1) - rings, axis=2)
    w = 0.5 * (seg + np.roll(seg, 1, axis=1))
    return np.sum(w * d, axis=1) / np.sum(w, axis=1)


def test_elliptic_section_mean_radius_convention():
    """radius = mean distance to the centre along the perimeter (paper Eq. 4), not a or b."""
    v = S.synthetic_vessel("straight", radius=R, ellipticity=0.5, ellipse_angle=0.4, n_around=256,
                           spacing=3.0, remesh=False)
    k = n_rings_of(v, 256)
    m = perimeter_mean_of_rings(v.V, 256, k)
    assert np.allclose(m, R, rtol=1e-4)
    assert np.allclose(v.truth.radii, R, rtol=1e-9)
    d = np.linalg.norm(v.V[:256] - v.V[:256].mean(0), axis=1)
    assert np.isclose(d.max() / d.min(), 2.0, rtol=1e-3)  # b / a = 0.5


def test_bulges_change_the_true_radius():
    bul = [(0.3, 0.08, 0.5), (0.7, 0.08, -0.3)]
    v = S.synthetic_vessel("straight", radius=R, bulges=bul, n_around=128, spacing=0.3, remesh=False)
    t = v.truth
    assert np.isclose(np.interp(0.3, t.s, t.radii), 1.5 * R, rtol=1e-3)  # aneurysm
    assert np.isclose(np.interp(0.7, t.s, t.radii), 0.7 * R, rtol=1e-3)  # stenosis
    # sinus bulges: three lobes, the true mean radius is reported, and matches the rings
    sin = [{"s0": 0.5, "width": 0.15, "amplitude": 0.3, "lobes": 3}]
    v = S.synthetic_vessel("aortic_root", radius=13.0, bulges=sin, n_around=256, spacing=1.0, remesh=False)
    k = n_rings_of(v, 256)
    s = np.linspace(0, 1, k)
    m = perimeter_mean_of_rings(v.V, 256, k)
    # the ring centroid is off-centre only by symmetric lobes: 3 lobes keep it on the axis
    assert np.allclose(m, np.interp(s, v.truth.s, v.truth.radii), rtol=2e-4)
    assert np.interp(0.5, v.truth.s, v.truth.radii) > 13.0 * 1.05
    ring = v.V[(k // 2) * 256:(k // 2 + 1) * 256]
    d = np.linalg.norm(ring - ring.mean(0), axis=1)
    peaks = np.flatnonzero((d > np.roll(d, 1)) & (d > np.roll(d, -1)))
    assert len(peaks) == 3


@pytest.mark.parametrize("name,kw", [
    ("arc", dict(ellipticity=0.7, twist=0.8, bulges=[(0.5, 0.1, 0.3)])),
    ("helix", dict()),
    ("aortic_arch", dict(radius=13.0, ends="capped")),
])
def test_remeshed_vertices_sit_on_the_true_surface(name, kw):
    v = S.synthetic_vessel(name, **{"radius": R, "n_around": 32, **kw})
    t = v.truth
    c, fr = axis_frames(v)
    D = v.V - c
    tube = ~t.vertex_on_cap
    rho = t.section_radius(t.vertex_s, t.vertex_theta)
    r = float(np.mean(t.radii))
    assert np.abs(np.linalg.norm(D, axis=1) - rho)[tube].max() < 1e-9 * r
    assert np.abs(np.sum(D * fr[:, 0], axis=1)).max() < 1e-9 * r  # in the section plane
    ang = transport_angle(fr[:, 0], fr[:, 1], D) - t.twist(t.vertex_s)
    assert np.abs(np.angle(np.exp(1j * (ang - t.vertex_theta)))).max() < 1e-9
    # faces are a faithful tessellation: centroids within the chord sagitta of the surface
    G = v.V[v.F].mean(axis=1)
    _, idx = __import__("scipy.spatial", fromlist=["cKDTree"]).cKDTree(t.centers).query(G)
    dG = np.linalg.norm(G - t.centers[idx], axis=1)
    e = np.linalg.norm(v.V[v.F[:, 0]] - v.V[v.F[:, 1]], axis=1)
    ftube = ~t.vertex_on_cap[v.F].any(axis=1)
    rG = np.interp(t.s[idx], t.s, t.radii)
    if "ellipticity" not in kw and "bulges" not in kw:
        assert np.all(np.abs(dG - rG)[ftube] < 3 * e.max() ** 2 / r + 1e-3 * r)


# --------------------------------------------------------------------------- topology


@pytest.mark.parametrize("name", ["arc", "helix", "s_curve"])
def test_open_tube_topology_and_orientation(name):
    v = S.synthetic_vessel(name, radius=R, n_around=32, twist=1.0)
    ncomp, manifold, loops = topology(v.V, v.F)
    assert ncomp == 1 and manifold and len(loops) == 2
    t = v.truth
    ends = sorted(float(np.mean(t.vertex_s[lp])) for lp in loops)
    assert ends == [0.0, 1.0]
    for lp in loops:  # the ends are exactly the requested rings
        s0 = t.vertex_s[lp][0]
        assert np.all(t.vertex_s[lp] == s0)
        c, fr = t.axis_at([s0])
        D = v.V[lp] - c
        assert np.abs(D @ fr[0, 0]).max() < 1e-9
        assert np.allclose(np.linalg.norm(D, axis=1), R, rtol=1e-9)
    c, _ = axis_frames(v)
    N = igl.per_vertex_normals(v.V, v.F)
    assert np.min(np.sum(N * (v.V - c), axis=1)) > 0.9 * R  # outward
    FN = igl.per_face_normals(v.V, v.F, np.zeros(3))
    cf = c[v.F].mean(axis=1)
    assert np.min(np.sum(FN * (v.V[v.F].mean(axis=1) - cf), axis=1)) > 0


def test_capped_tube_is_closed_with_two_flat_caps():
    v = S.synthetic_vessel("arc", radius=R, n_around=32, ends="capped")
    ncomp, manifold, loops = topology(v.V, v.F)
    assert ncomp == 1 and manifold and len(loops) == 0
    t = v.truth
    vol = S.signed_volume(v.V, v.F)
    assert vol > 0
    assert np.isclose(vol, np.pi * R * R * t.length, rtol=1e-2)
    cap = t.vertex_on_cap
    assert set(np.unique(t.vertex_s[cap])) == {0.0, 1.0}
    FN = igl.per_face_normals(v.V, v.F, np.zeros(3))
    T0, T1 = t.frames[0, 0], t.frames[-1, 0]
    G = v.V[v.F].mean(axis=1)
    # (the half-circle arc ends in the plane it starts in: look near each end only)
    c0 = np.flatnonzero((FN @ -T0 > 1 - 1e-9) & (np.linalg.norm(G - t.centers[0], axis=1) < 2 * R))
    c1 = np.flatnonzero((FN @ T1 > 1 - 1e-9) & (np.linalg.norm(G - t.centers[-1], axis=1) < 2 * R))
    assert len(c0) > 10 and len(c1) > 10
    for faces, at in ((c0, 0), (c1, -1)):  # each cap is one flat disc in its end plane
        assert igl.facet_components(v.F[faces])[0] == 1
        assert np.abs((v.V[v.F[faces]] - t.centers[at]) @ t.frames[at, 0]).max() < 1e-9
    assert np.all(np.isin(np.flatnonzero(cap), v.F[np.r_[c0, c1]]))  # flagged vertices lie on the caps


def test_remeshed_vertices_are_off_the_rings():
    n_around = 48
    v0 = S.synthetic_vessel("arc", radius=R, n_around=n_around, remesh=False)
    v1 = S.synthetic_vessel("arc", radius=R, n_around=n_around)
    k = n_rings_of(v0, n_around)
    for v, structured in ((v0, True), (v1, False)):
        x = v.truth.vertex_s * (k - 1)
        near = np.mean(np.abs(x - np.round(x)) < 0.05)  # uniform: 0.1, on rings: 1
        cnt = np.histogram(v.truth.vertex_s, bins=10 * (k - 1))[0]
        cv = cnt.std() / cnt.mean()
        if structured:
            assert near == 1.0 and cv > 2.5
        else:
            assert near < 0.2 and cv < 1.0
    assert len(np.unique(np.round(v1.truth.vertex_s, 9))) > 0.9 * len(v1.V)


def test_noise_is_seeded_and_keeps_ends_planar():
    a = S.synthetic_vessel("arc", radius=R, n_around=24, noise=0.02, seed=3)
    b = S.synthetic_vessel("arc", radius=R, n_around=24, noise=0.02, seed=3)
    c = S.synthetic_vessel("arc", radius=R, n_around=24, noise=0.02, seed=4)
    assert np.array_equal(a.V, b.V) and not np.array_equal(a.V, c.V)
    t = a.truth
    cc, fr = axis_frames(a)
    dev = np.linalg.norm(a.V - cc, axis=1) - t.section_radius(t.vertex_s, t.vertex_theta)
    assert 0.01 * R < dev.std() < 0.03 * R
    ends = (t.vertex_s == 0) | (t.vertex_s == 1)
    assert np.abs(np.sum((a.V - cc) * fr[:, 0], axis=1)[ends]).max() < 1e-9


# --------------------------------------------------------------------------- paper cases


@pytest.mark.parametrize("n", [1, 2])
def test_paper_case_deterministic_fast_and_sane(n):
    t0 = time.perf_counter()
    c = S.paper_case(n, seed=5)
    dt = time.perf_counter() - t0
    assert dt < 10
    d = S.paper_case(n, seed=5)
    for f in ("V", "F", "fixed", "moving", "target_origin", "target_tangent", "target_normal",
              "other_V", "other_F", "other_end"):
        assert np.array_equal(getattr(c, f), getattr(d, f)), f
    assert c.units == "mm"
    assert 3000 < len(c.V) < 30000
    assert np.isclose(np.linalg.norm(c.target_tangent), 1.0)
    assert np.isclose(np.linalg.norm(c.target_normal), 1.0)
    assert abs(c.target_tangent @ c.target_normal) < 1e-12
    assert np.intersect1d(c.fixed, c.moving).size == 0 and len(c.fixed) > 100
    for V, F, ids in ((c.V, c.F, c.moving), (c.other_V, c.other_F, c.other_end)):
        ncomp, manifold, loops = topology(V, F)
        assert ncomp == 1 and manifold and len(loops) == 2
        assert any(sorted(lp) == sorted(ids.tolist()) for lp in loops)
    assert np.all(c.truth.vertex_s[c.moving] == c.moving_at)
    # the target is the other vessel's end centre, ahead of the moving end
    assert np.linalg.norm(c.other_V[c.other_end].mean(0) - c.target_origin) < 1e-3
    gap = c.target_origin - c.V[c.moving].mean(0)
    assert gap @ c.target_tangent > 0
    out = c.truth.frames[-1, 0] if c.moving_at == 1.0 else -c.truth.frames[0, 0]
    tilt = np.degrees(np.arccos(out @ c.target_tangent))
    assert 5 < tilt < 30  # the join must bend the vessel
    e = S.paper_case(n, seed=5, pre_rotation=0.7, resolution=0.5)
    ang = transport_angle(c.target_tangent[None], c.target_normal[None], e.target_normal[None])[0]
    assert np.isclose(ang, 0.7)


def test_make_paper_cases_script(tmp_path):
    import json
    import runpy
    import sys

    argv = sys.argv
    sys.argv = ["make_paper_cases.py", str(tmp_path), "--resolution", "0.3"]
    try:
        runpy.run_path(str(__import__("pathlib").Path(__file__).parents[1] / "data_gen" / "make_paper_cases.py"),
                       run_name="__main__")
    finally:
        sys.argv = argv
    for name in ("case1", "case2"):
        meta = json.loads((tmp_path / name / "case.json").read_text())
        V, F = igl.read_triangle_mesh(str(tmp_path / name / "vessel.ply"))
        assert len(V) == meta["n_vertices"] and np.max(meta["moving"]) < len(V)
        assert meta["units"] == "mm" and len(meta["target_tangent"]) == 3
