"""Real, tortuous anatomy with an exact centre line (issue #48): tubes swept along VMTK's centre lines of the
real meshes (``data_gen/real_shapes.py``), fitted and measured against the swept line itself.

The figures are docs/accuracy.md's "Real shapes" table (read from it: ``_docs.table``); each bound is 1.5 x
the figure. The truth never comes from vesselgp: the centre line is the spline the rings were swept along.
"""
from __future__ import annotations

import numpy as np
import pytest

from _data import needs_real, repo_module
from _docs import figure, table
from _reference import SWEPT_TWISTS, imposed_twist_errors, polyline_distance

import vesselgp
from vesselgp.synthetic import deform_synthetic

FACTOR = 1.5


rs = repo_module("real_shapes")
acc = repo_module("real_shape_accuracy", "scripts")

_ROWS = table("accuracy.md", "case", "real line", "vertices")
#: case -> (mean, worst) axis error in % r, from the docs table
DOCS = {case.strip("`"): (figure(row[4]), figure(row[5])) for case, row in _ROWS.items() if row[4] != "refused"}
REFUSED = sorted(case.strip("`") for case, row in _ROWS.items() if row[4] == "refused")
#: case -> (mean, worst) at the sections the mesh carries, % r (the table's "at its sections" column)
SECTIONS = {case.strip("`"): tuple(figure(x) for x in row[8].split("/")) for case, row in _ROWS.items()
            if row[4] != "refused"}


def _mesh(case):
    return rs.CASES[case].mesh


@pytest.fixture(scope="module", params=sorted(DOCS))
def fitted(request):
    case = request.param
    ves = rs.case_vessel(case)
    return case, ves, vesselgp.fit_generalized_cylinder(ves.V, ves.F)


def test_the_docs_table_names_every_case():
    assert set(DOCS) | set(REFUSED) == set(rs.CASES)
    assert len(DOCS) >= 6


@needs_real(*{c.mesh for c in rs.CASES.values()})
def test_fitted_axis_follows_the_swept_centre_line(fitted):
    """Exact centre line -> fitted axis polyline: mean and worst in % of the local radius within 1.5 x the
    docs table's figures; at the sections the mesh carries (its rings' centres, issue #48's exact truth) within
    1.5 x the table's "at its sections" figures, and none farther than 5 % r from the axis (between the rings of
    an 8-around ring mesh the wall is flat facets: the thin XCAT line turns 12.8 degrees at one ring, and the
    spline there is 7.5 % r from the axis)."""
    case, ves, gc = fitted
    mean, worst = DOCS[case]
    e, inner = acc.axis_errors(ves.truth, gc.dense_points)
    assert inner.sum() >= 80  # of the 2001 samples of the exact line (90 on the short arch_branch cone)
    assert e[inner].mean() <= FACTOR * mean, f"{case}: mean {e[inner].mean():.4f} % r (figure {mean})"
    assert e[inner].max() <= FACTOR * worst, f"{case}: worst {e[inner].max():.3f} % r (figure {worst})"
    smean, sworst = SECTIONS[case]
    es, ins = acc.section_errors(ves.truth, gc.dense_points)
    assert ins.sum() >= 2  # rings measured (2 on the short arch_branch cone, 3 on the carotid line)
    assert es[ins].mean() <= FACTOR * smean and es[ins].max() <= FACTOR * sworst, (es[ins].mean(), es[ins].max())
    assert (es[ins] <= 5.0).all()


@needs_real(*{c.mesh for c in rs.CASES.values()})
def test_fitted_axis_has_no_excursion_and_ends_on_the_line(fitted):
    """The other way round: every dense axis point lies on the true centre line within the case's worst figure
    (away from the ends), the axis reaches both end centres, and its length is the line's within 0.5 %."""
    case, ves, gc = fitted
    t = ves.truth
    _, worst = DOCS[case]
    L = t.length
    far = (gc.dense_s * gc.length > acc.EDGE * t.radii[0]) & (gc.dense_s * gc.length < gc.length - acc.EDGE * t.radii[-1])
    d = polyline_distance(gc.dense_points[far], t.centers)
    r = np.interp(nearest_sample(t.s * L, t.centers, gc.dense_points[far]), t.s * L, t.radii)
    assert (100 * d / r).max() <= FACTOR * worst, f"{case}: axis leaves the line by {(100 * d / r).max():.3f} % r"
    ends = sorted(np.linalg.norm(gc.centers[[0, -1]][:, None] - t.centers[[0, -1]][None], axis=2).min(axis=1))
    assert ends[-1] <= 0.01 * t.radii.min()
    assert abs(gc.length - L) <= 0.005 * L


def nearest_sample(values, samples, X):
    """``values`` at the sample of ``samples`` (k, 3) nearest to each point of ``X``."""
    from scipy.spatial import cKDTree

    return values[cKDTree(samples).query(X)[1]]


@needs_real(*{c.mesh for c in rs.CASES.values()})
def test_fitted_radius_is_the_swept_radius(fitted):
    """The fitted perimeter-mean radius against the swept one, within 1 % over the interior (3 % on the
    ``arch_branch`` cone, 2.1 % off where its taper ends: Eq. 4 smooths the radius on the fit's 12 nodes,
    docs/accuracy.md)."""
    case, ves, gc = fitted
    t = ves.truth
    st = t.s * t.length
    inner = (st > acc.EDGE * t.radii[0]) & (st < t.length - acc.EDGE * t.radii[-1])
    s_fit = np.clip(nearest_sample(gc.dense_s, gc.dense_points, t.centers[inner]), 0, 1)
    rel = np.abs(gc.radius_at(s_fit) / t.radii[inner] - 1)
    bound = 0.03 if case == "arch_branch" else 0.01  # docs: the cone's radius is 2.1 % off
    assert rel.max() <= bound, f"{case}: radius off by {rel.max():.3%}"


@needs_real(*{c.mesh for c in rs.CASES.values()})
def test_cases_the_fit_cannot_follow_are_refused_not_answered():
    """The swept cases the fit does not follow yet (docs table: "refused"; none since 2026-12-07, late: the 2.5:1
    vein and the 8-around ring meshes were) are refused with the reason, never returned with an axis off the line:
    either the fit raises, or its axis is within 5 % r of the line everywhere. Every other case is answered."""
    for case in REFUSED:
        ves = rs.case_vessel(case)
        try:
            gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
        except vesselgp.VesselError as err:
            assert any(why in str(err) for why in ("wall", "bends tighter", "leaves the surface"))
            continue
        e, inner = acc.axis_errors(ves.truth, gc.dense_points)
        assert e[inner].max() <= 5.0, f"{case} answered with an axis {e[inner].max():.1f} % r off its line"
    assert set(DOCS) == set(rs.CASES) - set(REFUSED)


@needs_real("xrayangio_xcat-coronary-tree_open.stl")
def test_the_remeshed_thin_line_is_followed():
    """The thin XCAT line swept 8 points around and remeshed isotropically (docs/accuracy.md, "Real shapes"): it
    was answered 12-31 % r off over 3 mm of a bend (its sparse wall there rejected as outliers; a strict xfail
    until 2026-12-07), then refused (its axis off its wall's centre on a wall too sparse to fit again). Now a
    sparse wall's two fits follow it: 0.11 % r mean, 2.4 % r worst from the swept spline (measured; bounds 1.5x),
    no stretch farther than 5 % r."""
    ves = rs.case_vessel("xcat_thin", remesh=True)
    gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    e, inner = acc.axis_errors(ves.truth, gc.dense_points)
    assert e[inner].mean() <= FACTOR * 0.11 and e[inner].max() <= FACTOR * 2.4, (e[inner].mean(), e[inner].max())
    assert (e[inner] <= 5.0).all()


@needs_real("xra_coronary_single_branch_open.stl")
def test_the_swept_tube_is_the_stated_shape():
    """The generator's own truth: every vertex at its section's radius from the swept centre line, the bends
    within KR_MAX (curvature x radius), and the line within half a radius of VMTK's line it was made from."""
    ves = rs.case_vessel("coronary")
    t = ves.truth
    c, _ = t.axis_at(t.vertex_s)
    d = np.linalg.norm(ves.V - c, axis=1)
    assert np.allclose(d, t.section_radius(t.vertex_s, t.vertex_theta), rtol=1e-9, atol=0)
    assert rs.bend_profile(t).max() <= rs.KR_MAX * 1.05
    from _data import vmtk_lines

    P, _ = vmtk_lines(rs.CASES["coronary"].mesh)[0]
    dv = polyline_distance(t.centers, P)
    assert (dv / t.radii).max() <= 0.5


@needs_real("xra_coronary_single_branch_open.stl")
@pytest.mark.parametrize("twist", ["uniform", "ramp"])
def test_torsion_on_the_swept_coronary_is_the_imposed_twist(twist):
    """A known twist about the real coronary's line (the swept rings turned by alpha(s) about it): the measured
    alpha within the single-tube bound of docs/accuracy.md (the torsion table's worst row, 0.43 degrees ->
    0.645) and the energy within its 0.75 % (-> 1.125 %)."""
    ves = rs.case_vessel("coronary")
    gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    alpha, dalpha = SWEPT_TWISTS[twist]
    prof = vesselgp.measure_torsion(ves.V, deform_synthetic(ves, twist=alpha), ves.F, rest=gc)
    err, energy = imposed_twist_errors(prof, gc, ves.truth, alpha, dalpha)
    assert err <= 0.645, f"{twist}: alpha off by {err:.3f} deg"
    assert abs(energy) <= 1.125, energy


_TREES = table("accuracy.md", "network tree", "real mesh", "vertices")
#: network tree -> (mean, worst) axis error in % r, from the docs table
TREE_DOCS = {case.strip("`"): (figure(row[3]), figure(row[4])) for case, row in _TREES.items()}


@needs_real(*{c[0] for c in rs.NETWORK_TREES.values()})
@pytest.mark.parametrize("name", sorted(TREE_DOCS))
def test_real_network_trees_fit_every_end_and_follow_their_lines(name):
    """VMTK's centre-line networks of real trees swept as one surface (data_gen/real_shapes.py's
    real_network_tree: the synthetic arterial tree's mesher fed the real lines): every end found, and each
    true branch's centre line (away from its junctions and ends) within 1.5 x the docs table's mean and worst
    of the nearest fitted path, no sample farther than 5 % r."""
    tree = rs.network_tree(name)
    fit = vesselgp.fit_vessel_tree(tree.V, tree.F)
    assert len(fit.ends) == len(tree.truth.ends)
    got = [e[m] for e, m in acc.tree_axis_errors(tree.truth, fit) if m.any()]
    e = np.concatenate(got)
    assert len(e) >= 300
    mean, worst = TREE_DOCS[name]
    assert e.mean() <= FACTOR * mean, f"{name}: mean {e.mean():.3f} % r (figure {mean})"
    assert e.max() <= FACTOR * worst, f"{name}: worst {e.max():.3f} % r (figure {worst})"
    assert (e <= 5.0).all()


@needs_real("gmsh_carotid-bifurcation_open.stl")
def test_a_network_tree_is_the_stated_shape():
    """The network generator's own truth on the carotid: every vertex on the union of the swept tubes (its
    nearest branch's function within 1e-6 of the radius away from the blended junction) and the root open in
    the plane z = 0."""
    tree = rs.network_tree("carotid")
    t = tree.truth
    f = np.min([br.field(tree.V) for br in t.branches], axis=0)
    J, JR = t.junctions
    far = np.all(np.linalg.norm(tree.V[:, None] - J[None], axis=2) > 2 * JR[None] + t.blend, axis=1)
    assert np.abs(f[far]).max() <= 1e-6 * min(float(b.radii.min()) for b in t.branches)
    assert np.allclose(tree.V[tree.root_loop, 2], 0.0, atol=1e-9)
