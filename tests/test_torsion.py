"""Material torsion (paper Eq. 6-8) against imposed, analytic twists.

Bounds are 1.5 x the figures of docs/accuracy.md, read from its tables (issue #12: tests as
strict as the claims); each figure is the worst measured error of its row.
"""
import numpy as np
import pytest

from vesselgp import MismatchError, TorsionMeter, fit_generalized_cylinder, measure_torsion
from vesselgp.synthetic import deform_synthetic, named_curve, synthetic_vessel
from _data import REAL
from _docs import figure, figures, table
from _reference import imposed_twist_errors

R0 = 1.5
FACTOR = 1.5  # test bound / documented figure


def smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * x * (x * (6 * x - 15) + 10)


def d_smoothstep(x):
    inside = (x > 0) & (x < 1)
    return np.where(inside, 30 * x * x * (1 - x) ** 2, 0.0)


# alpha(s) and alpha'(s) of the imposed twists
TWISTS = {
    "uniform_2_turns": (lambda s: 4 * np.pi * s, lambda s: 4 * np.pi + 0 * s),
    "uniform_small": (lambda s: 0.7 * s, lambda s: 0.7 + 0 * s),
    "sinusoidal": (lambda s: 0.8 * np.sin(2 * np.pi * s), lambda s: 1.6 * np.pi * np.cos(2 * np.pi * s)),
    # a ramp over the middle 40 % of the length (C2 smooth)
    "ramp_part": (
        lambda s: np.pi * smoothstep((s - 0.3) / 0.4),
        lambda s: np.pi / 0.4 * d_smoothstep((s - 0.3) / 0.4),
    ),
}

CURVES = {
    "straight": lambda: named_curve("straight", length=60.0),
    "arc": lambda: named_curve("arc", bend_radius=19.0),
    "helix": lambda: named_curve("helix"),
    "aortic_arch": lambda: named_curve("aortic_arch") * 0.25,
    "s_curve": lambda: named_curve("s_curve", length=60.0, amplitude=6.0),
}

PAIRS = [  # (rest, deformed): shapes differ in bending too
    ("straight", "aortic_arch"),
    ("aortic_arch", "helix"),
    ("arc", "s_curve"),
    ("helix", "straight"),
    ("s_curve", "arc"),
]

# docs/accuracy.md torsion table, per pair: max alpha error over the four twists (degrees), max energy
# error (%), and the total twist measured under pure bending (degrees). Measured for issue #12:
#   straight -> arch   0.176, 0.293 (ramp), 0.0081
#   arch -> helix      0.432, 0.752 (ramp), 0.0474
#   arc -> S-curve     0.080, 0.152 (sinusoid), 0.0071
#   helix -> straight  0.060, 0.095 (uniform 40 degrees; 0.039 without it), 0.0152
#   S-curve -> arc     0.082, 0.156 (sinusoid), 0.0089
_TORSION = table("accuracy.md", "rest -> deformed", "max alpha error, worst twist (deg)")
DOCS_TORSION = {pair: tuple(figure(c) for c in _TORSION[row][:3]) for pair, row in {
    ("straight", "aortic_arch"): "straight -> aortic arch",
    ("aortic_arch", "helix"): "aortic arch -> helix",
    ("arc", "s_curve"): "half circle -> S-curve",
    ("helix", "straight"): "helix -> straight",
    ("s_curve", "arc"): "S-curve -> half circle"}.items()}


@pytest.fixture(scope="module")
def rest_vessels():
    out = {}
    for name in {p[0] for p in PAIRS} | {"straight"}:
        ves = synthetic_vessel(CURVES[name](), radius=R0, ellipticity=0.8, n_around=32, seed=11)
        gc = fit_generalized_cylinder(ves.V, ves.F)
        out[name] = (ves, gc, TorsionMeter(ves.V, ves.F, gc))
    return out


def energy_true(dalpha):
    s = np.linspace(0, 1, 20001)
    return float(np.trapezoid(dalpha(s) ** 2, s))


def check_profile(prof, alpha, dalpha, gc, truth, tol_deg, tol_energy_pct):
    """alpha within ``tol_deg`` over the interior 90 %, Eq. 8 energy within ``tol_energy_pct`` % (the fit may run
    from either end: ``_reference.imposed_twist_errors`` expresses the truth in the fit's s)."""
    err, rel = imposed_twist_errors(prof, gc, truth, alpha, dalpha)
    assert err <= tol_deg, f"alpha off by {err:.3f} deg (bound {tol_deg:.3g})"
    if rel is not None:
        assert abs(rel) <= tol_energy_pct, f"energy {prof.energy:.5f}: {rel:.3f} % (bound {tol_energy_pct:.3g} %)"


def pair_bounds(pair):
    a, e, _ = DOCS_TORSION[pair]
    return FACTOR * a, FACTOR * e


@pytest.mark.parametrize("rest_name, def_name", PAIRS)
@pytest.mark.parametrize("twist", sorted(TWISTS))
def test_imposed_twist_is_measured(rest_vessels, rest_name, def_name, twist):
    ves, gc, meter = rest_vessels[rest_name]
    alpha, dalpha = TWISTS[twist]
    Vd = deform_synthetic(ves, CURVES[def_name](), twist=alpha)
    prof = meter(Vd)
    check_profile(prof, alpha, dalpha, gc, ves.truth, *pair_bounds((rest_name, def_name)))


def test_uniform_twist_energy_is_phi_squared(rest_vessels):
    """Straight -> aortic arch row: E = Phi^2 (measured 0.17, -0.12, 0.02 %), total twist Phi
    (measured within 0.11 degrees)."""
    ves, gc, meter = rest_vessels["straight"]
    tol_deg, tol_pct = pair_bounds(("straight", "aortic_arch"))
    for phi in (0.5, np.pi, 4 * np.pi):
        prof = meter(deform_synthetic(ves, CURVES["aortic_arch"](), twist=phi))
        assert abs(prof.energy - phi**2) <= tol_pct / 100 * phi**2, (phi, prof.energy)
        # the measured handedness: a right-handed twist about the fit's T (either direction) is positive
        assert abs(prof.total_twist - phi) <= np.radians(tol_deg), (phi, prof.total_twist)
        assert abs(prof.twist_per_length - phi / prof.length) <= 1e-3 * phi / prof.length


@pytest.mark.parametrize("rest_name, def_name", PAIRS)
def test_pure_bending_has_no_twist(rest_vessels, rest_name, def_name):
    """docs/accuracy.md torsion table, last column: the twist measured when only the bending changes."""
    ves, gc, meter = rest_vessels[rest_name]
    prof = meter(deform_synthetic(ves, CURVES[def_name]()))
    bend = DOCS_TORSION[(rest_name, def_name)][2]
    assert np.degrees(abs(prof.total_twist)) <= FACTOR * bend, np.degrees(prof.total_twist)
    assert prof.energy <= 1e-3  # measured 1.5e-6 to 2.0e-4; a 10 degree twist has 0.03
    assert prof.alpha[0] == 0.0


def test_half_node_smoothing_on_the_synthetic_sweep(rest_vessels):
    """docs/accuracy.md: smoothing=0.5 is worse on the synthetic cases, 0.48 degrees worst (arch -> helix;
    the default smoothing gives 0.43 there), so it is not the default."""
    ves, gc, _ = rest_vessels["aortic_arch"]
    meter = TorsionMeter(ves.V, ves.F, gc, smoothing=0.5)
    for name in sorted(TWISTS):
        alpha, dalpha = TWISTS[name]
        prof = meter(deform_synthetic(ves, CURVES["helix"](), twist=alpha))
        check_profile(prof, alpha, dalpha, gc, ves.truth, FACTOR * 0.48, FACTOR * 0.75)


def test_identity_deformation_is_exactly_zero(rest_vessels):
    ves, gc, meter = rest_vessels["arc"]
    prof = meter(ves.V)
    assert np.abs(prof.alpha).max() < 1e-9 and prof.energy < 1e-12


def test_rigid_motion_of_deformed_mesh_changes_nothing(rest_vessels):
    ves, gc, meter = rest_vessels["aortic_arch"]
    Vd = deform_synthetic(ves, CURVES["helix"](), twist=TWISTS["sinusoidal"][0])
    p1 = meter(Vd)
    rng = np.random.default_rng(4)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    Q *= np.sign(np.linalg.det(Q))
    p2 = meter(Vd @ Q.T + [100.0, -3.0, 50.0])
    assert np.abs(p1.alpha - p2.alpha).max() <= 1e-9
    assert abs(p1.energy - p2.energy) <= 1e-9 * max(1.0, p1.energy)
    assert np.abs(p1.vertex_alpha - p2.vertex_alpha).max() <= 1e-9


@pytest.mark.parametrize("twist", ["ramp_part", "uniform_2_turns"])
def test_thinned_eq7_subset_keeps_the_accuracy(rest_vessels, monkeypatch, twist):
    """Above TORSION_MEAN_VERTICES, Eq. 7 averages an evenly thinned subset: still on the truth."""
    from vesselgp import tolerances

    ves, gc, full = rest_vessels["aortic_arch"]
    monkeypatch.setattr(tolerances, "TORSION_MEAN_VERTICES", len(ves.V) // 5)
    meter = TorsionMeter(ves.V, ves.F, gc)
    alpha, dalpha = TWISTS[twist]
    Vd = deform_synthetic(ves, CURVES["helix"](), twist=alpha)
    prof = meter(Vd)
    # the arch -> helix row's bounds (measured 0.47 degrees and -0.71 % on the ramp)
    check_profile(prof, alpha, dalpha, gc, ves.truth, *pair_bounds(("aortic_arch", "helix")))
    # the subset is really in use (the result differs), and agrees with the every-vertex
    # measurement far better than the bound (measured 0.12 degrees)
    diff = np.degrees(np.abs(prof.alpha - full(Vd).alpha).max())
    assert 0 < diff <= 0.2
    assert meter(ves.V).energy < 1e-12  # the identity is still exactly zero


def test_resolution_and_triangulation_independence():
    """24, 48 and 96 vertices around, structured and remeshed (circular sections): each energy
    within the arc -> S-curve row's bound (measured -0.09 to -0.11 %, spread 0.02 %)."""
    alpha, dalpha = TWISTS["sinusoidal"]
    e_true = energy_true(dalpha)
    _, tol_pct = pair_bounds(("arc", "s_curve"))
    energies = {}
    for n_around, remesh in [(24, False), (48, False), (96, False), (24, True), (48, True)]:
        ves = synthetic_vessel(CURVES["arc"](), radius=R0, n_around=n_around, remesh=remesh, seed=2)
        prof = measure_torsion(ves.V, deform_synthetic(ves, CURVES["s_curve"](), twist=alpha), ves.F)
        energies[(n_around, remesh)] = prof.energy
    e = np.array(list(energies.values()))
    assert (np.abs(e - e_true) <= tol_pct / 100 * e_true).all(), (e_true, energies)


def test_frenet_quantities_of_the_deformed_axis(rest_vessels):
    ves, gc, meter = rest_vessels["straight"]
    prof = meter(deform_synthetic(ves, CURVES["helix"]()))
    # default helix: a = 8, c = 20 / 2 pi, scaled to the rest length
    a, c = 8.0, 20.0 / (2 * np.pi)
    scale = ves.truth.length / (1.5 * 2 * np.pi * np.hypot(a, c))
    k_true = a / (a * a + c * c) / scale
    t_true = c / (a * a + c * c) / scale
    inner = (prof.s > 0.1) & (prof.s < 0.9)
    assert np.allclose(prof.curvature[inner], k_true, rtol=0.03)
    middle = (prof.s > 0.2) & (prof.s < 0.8)  # away from the smoothing's end effects
    assert np.allclose(prof.frenet_torsion[middle], t_true, rtol=0.05)
    # a straight deformed axis has no Frenet frame: undefined, not zero
    prof2 = meter(deform_synthetic(ves, CURVES["straight"](), twist=1.0))
    assert not prof2.frenet_defined[inner].any()
    assert np.isnan(prof2.frenet_torsion[inner]).all()


def test_mismatched_meshes_raise(rest_vessels):
    ves, gc, meter = rest_vessels["straight"]
    with pytest.raises(MismatchError, match="differ"):
        measure_torsion(ves.V, ves.V[:-12], ves.F)
    with pytest.raises(MismatchError, match="differ"):
        meter(ves.V[:-1])
    other = synthetic_vessel("straight", radius=R0, n_around=12, remesh=False)
    with pytest.raises(MismatchError, match="rest generalized cylinder"):
        TorsionMeter(other.V, other.F, gc)


def twist_about_axis(V, gc, alpha):
    """Turn every vertex about the fitted axis's tangent at its own s by alpha(s) (Rodrigues)."""
    s = gc.vertex_s
    pts, fr = gc.at(s)
    T, d = fr[:, 0], V - pts
    a = alpha(s)[:, None]
    return pts + d * np.cos(a) + np.cross(T, d) * np.sin(a) + T * np.einsum("ij,ij->i", T, d)[:, None] * (1 - np.cos(a))


# docs/accuracy.md real-mesh table: per mesh, per twist, (max alpha error in degrees over the interior 90 %,
# relative energy error in %). Looser than the synthetic figures where the data is harder: a
# 3.2k-vertex coronary with a stenosis (L = 60 r, about 30 vertices per axis node: the recovered
# axis moves under the twist), and a Y whose paths are only 12.3-12.7 radii long (a ramp over
# 40 % of it changes over 5 radii, which the half-radius smoothing of alpha rounds off).
# Measured for issue #12, with the fit's outlier set fixed once the axis settles (ramp, uniform, sinusoid):
#   lumen     0.259 / -0.60 %, 0.171 / -0.094 %, 0.118 / -0.40 %
#   coronary  0.195 / 0.48 %,  1.568 / -0.66 %,  1.071 / -0.39 %
#   Y path 1  1.704 / -5.38 %, 0.966 / -0.41 %,  0.85 / -2.92 %
#   Y path 2  1.755 / -5.56 %, 0.599 / -0.14 %,  0.95 / -3.41 %
RAMP = TWISTS["ramp_part"]
REAL_TWISTS = {  # alpha(s), alpha'(s)
    "quarter_ramp": (lambda s: 0.5 * RAMP[0](s), lambda s: 0.5 * RAMP[1](s)),  # a quarter turn over 40 %
    "uniform_turn": (lambda s: 2 * np.pi * s, lambda s: 2 * np.pi + 0 * s),  # one full turn
    "sinusoid": (lambda s: 0.6 * np.sin(2 * np.pi * s), lambda s: 1.2 * np.pi * np.cos(2 * np.pi * s)),  # 34 deg
}
REAL_MESHES = {  # name: (file, ends)
    "lumen": ("dfemtoolz_artery_segment_lumen_capped.stl", None),
    "coronary": ("xra_coronary_single_branch_open.stl", None),
    "y_path1": ("vmtk_abdominal_aorta_iliac_bifurcation_open.stl", (0, 1)),
    "y_path2": ("vmtk_abdominal_aorta_iliac_bifurcation_open.stl", (0, 2)),
}
_REAL = table("accuracy.md", "real mesh", "vertices")
DOCS_REAL = {mesh: dict(zip(("quarter_ramp", "uniform_turn", "sinusoid"), (tuple(figures(c)) for c in _REAL[row][1:4])))
               for mesh, row in {"lumen": "capped lumen segment", "coronary": "coronary with stenosis (L = 60 r)",
                                 "y_path1": "aorto-iliac Y, aorta -> iliac 1",
                                 "y_path2": "aorto-iliac Y, aorta -> iliac 2"}.items()}


@pytest.fixture(scope="module")
def real_meters():
    from vesselgp import read_mesh

    cache = {}

    def get(name):
        if name not in cache:
            fname, ends = REAL_MESHES[name]
            V, F = read_mesh(REAL / fname)
            gc = fit_generalized_cylinder(V, F, ends=ends)
            cache[name] = (V, F, gc, TorsionMeter(V, F, gc))
        return cache[name]

    return get


def real_errors(meter, V, gc, twist):
    alpha, dalpha = REAL_TWISTS[twist]
    prof = meter(twist_about_axis(V, gc, alpha))
    inner = (prof.s > 0.05) & (prof.s < 0.95)
    err = np.degrees(np.abs(prof.alpha - (alpha(prof.s) - alpha(0)))[inner].max())
    e_true = energy_true(dalpha)
    return prof, err, 100 * (prof.energy - e_true) / e_true


@pytest.mark.parametrize("twist", sorted(REAL_TWISTS))
@pytest.mark.parametrize("mesh", sorted(REAL_MESHES))
def test_imposed_twist_on_real_meshes(real_meters, mesh, twist):
    """A known twist about the fitted axis of a segmented vessel is measured back: docs/accuracy.md table."""
    V, F, gc, meter = real_meters(mesh)
    assert meter(V).energy < 1e-12
    _, err, rel = real_errors(meter, V, gc, twist)
    tol_deg, tol_pct = (FACTOR * x for x in DOCS_REAL[mesh][twist])
    assert err <= tol_deg, f"{mesh}: alpha off by {err:.3f} deg (bound {tol_deg:.3g})"
    assert abs(rel) <= tol_pct, f"{mesh}: energy off by {rel:.3f} % (bound {tol_pct:.3g} %)"


def test_short_y_path_error_is_the_smoothing(real_meters):
    """docs/accuracy.md: on the short Y path the ramp's raw Eq. 7 bins are within 0.6 degrees, and
    smoothing=0.5 brings it to 0.58 degrees and 1.5 % (measured 0.600, 0.58, -1.48 %)."""
    V, F, gc, meter = real_meters("y_path1")
    prof, _, _ = real_errors(meter, V, gc, "quarter_ramp")
    alpha = REAL_TWISTS["quarter_ramp"][0]
    inner = (prof.bin_s > 0.05) & (prof.bin_s < 0.95)
    raw = np.degrees(np.abs(prof.bin_alpha - (alpha(prof.bin_s) - alpha(0)))[inner].max())
    assert raw <= FACTOR * 0.6, raw
    _, err, rel = real_errors(TorsionMeter(V, F, gc, smoothing=0.5), V, gc, "quarter_ramp")
    assert err <= FACTOR * 0.58 and abs(rel) <= FACTOR * 1.5, (err, rel)
