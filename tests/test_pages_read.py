"""Pages that read (issue #49, item 5): no two texts of a figure overlap, and a report.html stays small.

* Figures: every PNG the commands write is captured as the matplotlib Figure it is saved from (a spy on
  ``viz._save_png``) and drawn; no two of its drawn texts (titles, axis and tick labels, annotations, legend
  texts, colour-bar labels, captions) overlap (``tests/_labels.py``). The inputs stress the labels: twelve
  side branches 3-4 mm apart through ``vesselgp twist``'s own functions, a 15-branch tree through ``vesselgp fit``,
  a join through ``vesselgp join``, a fit and a torsion run, and plots with long tick labels and 25 landmarks
  1.5 mm apart.
* Pages: ``report.html`` of a 40k-vertex tree (``vesselgp fit``), of the twist and of the join stay under
  ``tolerances.REPORT_MAX_BYTES``, and still hold what they held: the shaded mesh (decimated within a fifth of an
  edge of the surface, both ways, its shading the distance to the axes), a line per branch, the ends' labels, the
  figures and the numbers; a mesh under the face budget is sent exactly.
"""
from __future__ import annotations

import base64
import contextlib
import io
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.text import Text

import vesselgp as vg
from vesselgp import tolerances as tol
from vesselgp import viz
from vesselgp.cli import main
from vesselgp.commands.fit import run_fit
from vesselgp.commands.output import OutputFolder
from vesselgp.commands.torsion import run_torsion
from vesselgp.commands.twist import twist_scans, write_twist
from vesselgp.html_report import embedded_png, view_lines
from vesselgp.synthetic import deform_synthetic, synthetic_vessel, twist_pair
from vesselgp.synthetic_tree import synthetic_tree

from _labels import assert_no_overlap, overlaps
from test_reports_truth import _decode, _labels, _mesh_trace, plotly_traces


@contextlib.contextmanager
def saved_figures():
    """{file name: Figure} of every PNG written inside the block (the real file is written too)."""
    figs = {}
    real = viz._save_png

    def spy(fig, path, dpi, **kw):
        figs[Path(path).name] = fig
        return real(fig, path, dpi, **kw)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(viz, "_save_png", spy)
        yield figs


def _caption(fig):
    return " ".join(t.get_text() for t in fig.findobj(Text) if t.get_gid() == "caption")


# ----------------------------------------------------------------------------------------------- fixtures

@pytest.fixture(scope="module")
def twist_run(tmp_path_factory):
    """Twelve side branches 3-4 mm apart on a 50 mm vessel (two scans), through `vesselgp twist`'s functions."""
    d = tmp_path_factory.mktemp("twist")
    p = twist_pair(12, length=50.0, seed=0, voxel=(0.54, 0.54), side_radius=1.5, side_length=8.0,
                   bend_deg=(8.0, 12.0))
    assert np.diff(p.s_a).max() < 4.5  # landmarks a few millimetres apart
    vg.write_mesh(d / "a.ply", p.a.V, p.a.F)
    vg.write_mesh(d / "b.ply", p.V_b, p.b.F)
    tw = twist_scans(d / "a.ply", d / "b.ply")
    assert len(tw["result"].s_a) == 12
    with saved_figures() as figs:
        out = write_twist(OutputFolder(d / "out"), tw)
    return dict(figs=figs, d=out, dir=d / "out", k=12)


@pytest.fixture(scope="module")
def tree_run(tmp_path_factory):
    """A 40k-vertex tree of 15 branches (three levels) through `vesselgp fit` (run_fit -> run_fit_tree)."""
    d = tmp_path_factory.mktemp("tree")
    t = synthetic_tree(levels=3, target_vertices=40000)
    assert 36000 < len(t.V) < 44000
    vg.write_mesh(d / "tree.ply", t.V, t.F)
    with saved_figures() as figs:
        tree, js = run_fit(d / "tree.ply", OutputFolder(d / "out"))
    assert len(tree.branches) == 15
    return dict(figs=figs, t=t, tree=tree, d=js, dir=d / "out")


@pytest.fixture(scope="module")
def join_run(tmp_path_factory):
    """The paper's case 2 through `vesselgp join --case` (the demo's join of one case)."""
    d = tmp_path_factory.mktemp("join")
    assert main(["generate", "--paper-cases", "--resolution", "0.5", "-o", str(d / "cases"), "-q"]) == 0
    with saved_figures() as figs:
        assert main(["join", str(d / "cases" / "case2" / "vessel.ply"), "--case",
                     str(d / "cases" / "case2" / "case.json"), "--n-curve", "5", "-o", str(d / "out"), "-q"]) == 0
    return dict(figs=figs, dir=d / "out")


# ------------------------------------------------------------------------------------- the check itself

def test_the_check_sees_overlapping_labels_and_only_drawn_ones():
    """The old twist profile's placement (each segment's twist 8 points above its middle, each landmark's number
    14 below its point) of landmarks 3 mm apart overlaps; tick labels beyond the limits (kept, undrawn) do not
    count, nor texts made invisible."""
    fig = viz._figure((6.4, 4.0))
    ax = fig.subplots()
    s = np.array([5.0, 8.0, 11.5, 14.0, 17.0, 30.0, 33.0, 36.0, 60.0, 62.5, 65.0, 90.0])
    c = np.cumsum(np.r_[0.0, np.random.default_rng(0).normal(3.0, 8.0, len(s) - 1)])
    ax.plot(s, c, "-o")
    for j in range(len(s) - 1):
        ax.annotate(f"{c[j + 1] - c[j]:+.1f} \u00b12.5\u00b0", (0.5 * (s[j] + s[j + 1]), 0.5 * (c[j] + c[j + 1])),
                    xytext=(0, 8), textcoords="offset points", ha="center", fontsize=9)
    for j in range(len(s)):
        ax.annotate(str(j + 1), (s[j], c[j]), xytext=(0, -14), textcoords="offset points", ha="center", fontsize=8)
    fig.tight_layout()
    found = overlaps(fig)
    assert len(found) >= 3 and any(a[0] in "+-" and b[0] in "+-" for a, b, _, _ in found)  # twist on twist too
    with pytest.raises(AssertionError, match="overlapping"):
        assert_no_overlap(fig)
    fig2 = viz._figure((3.0, 2.0))
    ax2 = fig2.subplots()
    ax2.set_xticks([0, 1, 2, 3, 4, 5])
    ax2.set_xlim(0, 1)  # ticks 2-5 keep their labels, undrawn
    hidden = ax2.text(0.5, 0.5, "hidden")
    ax2.text(0.5, 0.5, "shown")
    hidden.set_visible(False)
    assert overlaps(fig2) == []


# --------------------------------------------------------------------------------------------- figures

def test_twist_figures_of_landmarks_a_few_mm_apart_have_no_overlapping_labels(twist_run):
    """twist_scans.png numbers every landmark in both scans and twist_profile.png every landmark and segment (or
    names a segment in its caption), with no two texts overlapping."""
    figs, k = twist_run["figs"], twist_run["k"]
    assert set(figs) == {"twist_scans.png", "twist_profile.png"}
    for name, fig in figs.items():
        assert_no_overlap(fig, name)
    numbers = {str(j + 1) for j in range(k)}
    for ax in figs["twist_scans.png"].axes:  # scan A, scan B
        assert {t.get_text() for t in ax.texts} == numbers
    (ax,) = figs["twist_profile.png"].axes
    on_plot = {t.get_text() for t in ax.texts}
    assert numbers <= on_plot
    caption = _caption(figs["twist_profile.png"])
    for t, u in zip(twist_run["d"]["segment_twist_deg"], twist_run["d"]["segment_uncertainty_deg"]):
        text = f"{t:+.1f} \u00b1{u:.1f}\u00b0"
        assert text in on_plot or text in caption, text


def test_tree_figure_of_fifteen_branches_has_no_overlapping_labels(tree_run):
    fig = tree_run["figs"]["tree.png"]
    assert_no_overlap(fig, "tree.png")
    ticks = {t.get_text() for t in fig.axes[-1].get_yticklabels() + fig.axes[-1].get_xticklabels()}
    assert {str(i) for i in range(15)} <= ticks  # the colour bar names every branch's colour


def test_join_figures_have_no_overlapping_labels(join_run):
    figs = join_run["figs"]
    assert {"energy_curve.png", "optimum.png", "large_torsion.png", "profile_optimum.png",
            "profile_large_torsion.png"} <= set(figs)
    for name, fig in figs.items():
        assert_no_overlap(fig, name)


def test_fit_and_torsion_figures_have_no_overlapping_labels(tmp_path):
    v = synthetic_vessel("arc", radius=1.5, n_around=24, remesh=False)
    vg.write_mesh(tmp_path / "rest.ply", v.V, v.F)
    vg.write_mesh(tmp_path / "def.ply", deform_synthetic(v, twist=lambda s: np.radians(80.0) * np.asarray(s) ** 2),
                  v.F)
    with saved_figures() as figs:
        run_fit(tmp_path / "rest.ply", OutputFolder(tmp_path / "fit"))
        run_fit(tmp_path / "rest.ply", OutputFolder(tmp_path / "theta"), shade="theta")
        run_torsion(tmp_path / "rest.ply", tmp_path / "def.ply", OutputFolder(tmp_path / "torsion"))
    assert {"mesh_radius.png", "mesh_theta.png", "deformed_twist.png", "profile.png"} <= set(figs)
    for name, fig in figs.items():
        assert_no_overlap(fig, name)


def _profile(length, amplitude_rad):
    s = np.linspace(0.0, 1.0, 60)
    al = amplitude_rad * np.sin(6.0 * s)
    return SimpleNamespace(s=s, alpha=al, bin_s=s, bin_alpha=1.1 * al, dalpha=np.gradient(al, s), length=length,
                           total_twist=al[-1] - al[0], energy=float(np.mean(np.gradient(al, s) ** 2)))


def test_plots_with_long_tick_labels_and_crowded_landmarks_have_no_overlapping_labels(tmp_path):
    """Long tick labels (a 123 m 'vessel' in mm, rates of 1e-6 degrees per mm with their offset, energies of
    1e-5 rad^2, arc lengths of 10^5 mm) and 25 landmarks 1.5 mm apart: no overlap; a segment whose twist finds no
    room on the line is named, with its value, in the caption."""
    with saved_figures() as figs:
        viz.plot_torsion_profile(tmp_path / "p1.png", _profile(123456.7, 2e-3), origin="end 0")
        viz.plot_torsion_profile(tmp_path / "p2.png", _profile(0.0123, 20.0), origin="end 0")
        a = np.radians(np.linspace(-180.0, 180.0, 25)) + 2.1
        viz.plot_energy_curve(tmp_path / "e.png", a, 1e-6 * (a - 2.1) ** 2 + 3e-7, optimum=(2.1, 3e-7),
                              evaluated=(a[::3], 1e-6 * (a[::3] - 2.1) ** 2 + 3e-7))
        viz.plot_cumulative_twist(tmp_path / "c1.png", np.array([1000.5, 10500.2, 48000.0, 99000.0]),
                                  np.array([0.0, 1234.5, -2000.0, 5000.0]))
        s = 3.0 + 1.5 * np.arange(25)
        c = np.cumsum(np.r_[0.0, np.random.default_rng(1).normal(2.0, 4.0, 24)])
        viz.plot_cumulative_twist(tmp_path / "c2.png", s, c, segment_uncertainty_deg=np.full(24, 2.5),
                                  cumulative_uncertainty_deg=np.linspace(0.0, 8.0, 25), caption="What zero is.")
    for name, fig in figs.items():
        assert_no_overlap(fig, name)
    fig = figs["c2.png"]
    on_plot = {t.get_text() for t in fig.axes[0].texts}
    assert {str(j + 1) for j in range(25)} <= on_plot  # every landmark numbered
    caption = " ".join(_caption(fig).split())  # unwrapped
    assert caption.startswith("What zero is.")
    for j, v in enumerate(np.diff(c)):
        text = f"{v:+.1f} \u00b12.5\u00b0"
        assert text in on_plot or f"segment {j + 1} (landmarks {j + 1}-{j + 2}): {text}" in caption, text
    assert "Not written on the line" in caption  # some did not fit, and are named


# ------------------------------------------------------------------------------------------------ pages

def _page(folder):
    page = (folder / "report.html").read_text()
    return page, plotly_traces(page)


def test_a_40k_vertex_tree_page_is_under_the_budget_and_holds_its_view_mesh_on_the_surface(tree_run):
    """The page is under REPORT_MAX_BYTES (it was 6.1 MB). Its mesh is the tree decimated to REPORT_MAX_FACES
    faces: every drawn vertex within a fifth of the tree's mean edge of its surface, every vertex of the tree
    within a fifth of an edge of the drawn one (measured: 0.09 and 0.10 edges, 0.04 mm; the render's mesh of
    30,000 faces decimated again) (libigl's exact point-triangle distances); each drawn vertex
    shaded by its distance to the fitted axes (a quarter edge: the shading is carried over from the decimated
    render mesh); a line per branch, each end's label, the figure and the numbers are there."""
    import igl
    from scipy.spatial import cKDTree

    t, tree, folder = tree_run["t"], tree_run["tree"], tree_run["dir"]
    size = (folder / "report.html").stat().st_size
    assert size < tol.REPORT_MAX_BYTES, size
    page, traces = _page(folder)
    X, value, m = _mesh_trace(traces)
    Fv = np.c_[_decode(m["i"]), _decode(m["j"]), _decode(m["k"])].astype(np.int64)
    assert len(Fv) <= tol.REPORT_MAX_FACES and m["x"]["dtype"] == "f4"
    V, F = t.V, np.asarray(t.F, np.int64)
    edge = np.linalg.norm(V[F[:, 1]] - V[F[:, 0]], axis=1).mean()
    X = X.astype(np.float64)
    to_surface = np.sqrt(igl.point_mesh_squared_distance(X, V, F)[0])
    from_surface = np.sqrt(igl.point_mesh_squared_distance(V, X, Fv)[0])
    assert to_surface.max() < 0.2 * edge and from_surface.max() < 0.2 * edge, (to_surface.max(), from_surface.max())
    axes = np.vstack([gc.dense_points for gc in tree.branches])
    assert np.abs(value - cKDTree(axes).query(X)[0]).max() < 0.25 * edge
    lines = [q for q in traces if q["type"] == "scatter3d" and q.get("mode") == "lines"]
    assert len(lines) == len(tree.branches)
    assert sorted(_labels(traces)) == sorted(f"end {i}" for i in range(len(tree.ends)))
    assert page.count("<img alt=") == 1 and '<a href="tree.png">' in page
    rows = dict(re.findall(r"<tr><td>(.*?)</td><td>(.*?)</td></tr>", page))
    assert rows["n_vertices"] == str(len(V)) and float(rows["bbox_diagonal"]) == pytest.approx(
        tree_run["d"]["bbox_diagonal"], rel=1e-5)


def test_the_page_unpacks_plotly_itself_and_calls_it_once(tree_run):
    """plotly.js is in the page once, gzipped and base64-encoded (its 4.8 MB as 2.0), unpacked by the page's own
    script: no script from elsewhere, one Plotly.newPlot call."""
    import gzip

    from plotly.offline import get_plotlyjs

    page = (tree_run["dir"] / "report.html").read_text()
    packed = re.search(r'<script id="plotly-js-gzip" type="application/gzip;base64">([A-Za-z0-9+/=]+)</script>',
                       page)
    assert packed and gzip.decompress(base64.b64decode(packed.group(1))).decode("utf-8") == get_plotlyjs()
    assert len(packed.group(1)) < 0.45 * len(get_plotlyjs())
    assert not re.search(r"<script[^>]+src=", page) and page.count("Plotly.newPlot(") == 1
    assert "DecompressionStream" in page


def test_twist_and_join_pages_are_under_the_budget(twist_run, join_run):
    """The twist page (twelve landmarks, two figures, scan A of 15k faces) and the join page (four figures, the
    joined vessel and the vessel joined to) are under REPORT_MAX_BYTES; both figures of each are embedded,
    each decoding to its PNG's size in at most REPORT_FIGURE_COLORS colours."""
    from PIL import Image

    for folder, figures in ((twist_run["dir"], ("twist_scans.png", "twist_profile.png")),
                            (join_run["dir"], ("optimum.png", "energy_curve.png", "profile_optimum.png",
                                               "large_torsion.png"))):
        size = (folder / "report.html").stat().st_size
        assert size < tol.REPORT_MAX_BYTES, (folder, size)
        page = (folder / "report.html").read_text()
        for name in figures:
            b64 = re.search(rf'<a href="{re.escape(name)}"><img alt="{re.escape(name)}" '
                            r'src="data:image/png;base64,([^"]+)">', page).group(1)
            with Image.open(io.BytesIO(base64.b64decode(b64))) as im, Image.open(folder / name) as full:
                assert im.size == full.size and im.mode == "P"  # a palette PNG of at most that many colours:
                assert len(im.getcolors(maxcolors=tol.REPORT_FIGURE_COLORS)) <= tol.REPORT_FIGURE_COLORS  # else None
    traces = plotly_traces((join_run["dir"] / "report.html").read_text())
    assert sum(len(_decode(q["i"])) for q in traces if q["type"] == "mesh3d") <= tol.REPORT_MAX_FACES


def test_a_mesh_under_the_face_budget_is_sent_exactly(tmp_path):
    """A fit's 1.9k-face arc: the page's mesh is the file's, every coordinate and shading value in double
    precision, and its axis the fitted one point for point."""
    v = synthetic_vessel("arc", radius=1.5, n_around=24, remesh=False)
    vg.write_mesh(tmp_path / "arc.ply", v.V, v.F)
    V, F = vg.read_mesh(tmp_path / "arc.ply")
    gc, _ = run_fit(tmp_path / "arc.ply", OutputFolder(tmp_path / "out"), render=True)
    page, traces = _page(tmp_path / "out")
    X, value, m = _mesh_trace(traces)
    assert m["x"]["dtype"] == "f8" and np.array_equal(X, V)
    assert np.array_equal(np.c_[_decode(m["i"]), _decode(m["j"]), _decode(m["k"])], F)
    assert np.array_equal(value, np.hypot(gc.vertex_local[:, 1], gc.vertex_local[:, 2]))
    (line,) = [q for q in traces if q["type"] == "scatter3d" and q.get("mode") == "lines"]
    assert np.array_equal(np.c_[_decode(line["x"]), _decode(line["y"]), _decode(line["z"])], gc.dense_points)


def test_long_centre_lines_are_simplified_within_their_tolerance():
    """Lines of more than REPORT_MAX_LINE_POINTS points in all: each drawn point is one of the line's (single
    precision) and every point of the line lies within REPORT_LINE_TOLERANCE of the scene's diagonal of the drawn
    polyline; ends kept. Fewer points: the lines as given."""
    from scipy.spatial import cKDTree

    u = np.linspace(0.0, 1.0, 4000)
    helix = np.c_[10 * np.cos(12 * u), 10 * np.sin(12 * u), 60 * u]
    straight = np.c_[np.zeros(2000), np.zeros(2000), np.linspace(0.0, 60.0, 2000)]
    diagonal = 70.0
    drawn = view_lines([helix, straight], diagonal)
    eps = tol.REPORT_LINE_TOLERANCE * diagonal
    for P, Q in zip((helix, straight), drawn):
        assert Q.dtype == np.float32 and len(Q) < len(P) / 4
        assert np.allclose(Q[[0, -1]], P[[0, -1]], atol=1e-5)
        assert cKDTree(P.astype(np.float32)).query(Q)[0].max() == 0.0  # points of the line, none made up
        Qd = Q.astype(float)
        a, b = Qd[:-1], Qd[1:]  # every line point's distance to the drawn polyline
        t = np.clip(np.einsum("pkj,kj->pk", P[:, None] - a[None], b - a) / np.einsum("kj,kj->k", b - a, b - a),
                    0, 1)
        d = np.linalg.norm(P[:, None] - (a[None] + t[..., None] * (b - a)[None]), axis=2).min(axis=1)
        assert d.max() <= eps + 1e-4, d.max()
    few = view_lines([helix[:100], straight[:100]], diagonal)
    assert all(np.array_equal(P, Q) for P, Q in zip((helix[:100], straight[:100]), few))


def test_the_line_and_face_budgets_at_their_edges(monkeypatch):
    """REPORT_MAX_LINE_POINTS points in all are drawn as given (double precision), one more are simplified
    (single); REPORT_MAX_FACES faces in all keep every face, one more share the budget in proportion."""
    from vesselgp.html_report import ViewMesh, face_budgets

    monkeypatch.setattr(tol, "REPORT_MAX_LINE_POINTS", 300)
    u = np.linspace(0.0, 1.0, 300)
    helix = np.c_[10 * np.cos(12 * u), 10 * np.sin(12 * u), 60 * u]
    assert view_lines([helix], 70.0)[0].dtype == np.float64
    assert view_lines([np.vstack([helix, helix[-1] + 1.0])], 70.0)[0].dtype == np.float32
    monkeypatch.setattr(tol, "REPORT_MAX_FACES", 100)
    F = np.zeros((60, 3), np.int64)
    V = np.zeros((3, 3))
    assert face_budgets([ViewMesh(V, F, None), ViewMesh(V, F[:40], None)]) == [60, 40]
    got = face_budgets([ViewMesh(V, F, None), ViewMesh(V, F[:41], None)])
    assert sum(got) <= 100 and got == [int(100 * 60 / 101), int(100 * 41 / 101)]


def test_a_page_over_the_size_budget_is_written_and_warned_about(tmp_path, monkeypatch, caplog):
    """The warning's edge: a page of exactly REPORT_MAX_BYTES is quiet, one byte over names the budget."""
    from vesselgp.html_report import ViewMesh, write_report_html

    v = synthetic_vessel("arc", n_around=12, remesh=False)
    path = tmp_path / "report.html"
    write_report_html(path, "an arc", [ViewMesh(v.V, v.F, v.V[:, 2], label="z (mm)")])
    size = path.stat().st_size
    for limit, warned in ((size, False), (size - 1, True)):
        caplog.clear()
        monkeypatch.setattr(tol, "REPORT_MAX_BYTES", limit)
        with caplog.at_level("WARNING", logger="vesselgp"):
            write_report_html(path, "an arc", [ViewMesh(v.V, v.F, v.V[:, 2], label="z (mm)")])
        assert path.stat().st_size == size
        assert any("REPORT_MAX_BYTES" in r.getMessage() for r in caplog.records) == warned


def test_an_embedded_figure_is_the_png_in_fewer_colours_and_smaller(tmp_path):
    from PIL import Image

    v = synthetic_vessel("arc", radius=1.5, n_around=24, remesh=False)
    viz.render_mesh(tmp_path / "r.png", v.V, v.F, v.V[:, 2], cbar_label="z (mm)", title="an arc", scale_bar="mm")
    raw = (tmp_path / "r.png").read_bytes()
    small = embedded_png(tmp_path / "r.png")
    assert len(small) < 0.7 * len(raw)
    with Image.open(io.BytesIO(small)) as a, Image.open(tmp_path / "r.png") as b:
        assert a.size == b.size and a.mode == "P"
        diff = np.abs(np.asarray(a.convert("RGB"), float) - np.asarray(b.convert("RGB"), float))
        assert np.percentile(diff, 99) < 24 and diff.mean() < 2.0  # the same picture to the eye


def test_the_budgets_live_in_tolerances_and_the_docs_state_them():
    docs = (Path(__file__).resolve().parent.parent / "docs" / "commands.md").read_text()
    assert f"{tol.REPORT_MAX_BYTES / 1e6:g} MB" in docs
    assert f"{tol.REPORT_MAX_FACES:,}" in docs
