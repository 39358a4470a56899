"""Figures that mean something (issue 37, part 3): units on every axis, torsion profiles against arc length in
mm, twist colours that agree with the titles' signs, titles never cut, the quadratic fit visible, a readable
twist_scans.png with a scale bar, renders framed on the vessel.

Each test captures the matplotlib figure a function saves (a spy on ``viz._save_png``) and checks geometry,
signs and units in it, not numbers copied from the code's output.
"""
import re

import numpy as np
import pytest
from matplotlib.image import imread
from matplotlib.text import Text

import vesselgp
from vesselgp import viz
from vesselgp.commands.join import summary_table, write_join_outputs
from vesselgp.cli import main
from vesselgp.synthetic import deform_synthetic, paper_case, synthetic_vessel, twist_pair
from vesselgp.torsion import measure_torsion


@pytest.fixture
def saved(monkeypatch):
    """{file name: figure} of every PNG written while the test runs."""
    figs = {}
    real = viz._save_png

    def spy(fig, path, dpi, **kw):
        figs[str(path).replace("\\", "/").rsplit("/", 1)[-1]] = fig
        return real(fig, path, dpi, **kw)

    monkeypatch.setattr(viz, "_save_png", spy)
    return figs


def texts(fig):
    """The non-empty, visible text artists of a drawn figure."""
    fig.canvas.draw()
    return [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()]


def assert_text_inside(fig):
    """Every text (titles, labels, captions, legends; the tick labels drawn) lies inside the figure: nothing
    is cut."""
    box = fig.bbox
    r = fig.canvas.get_renderer()
    ticks = {id(t) for ax in fig.axes for t in ax.get_xticklabels() + ax.get_yticklabels()}
    for t in texts(fig):
        if id(t) in ticks:  # matplotlib keeps labels of ticks beyond the limits, undrawn
            continue
        e = t.get_window_extent(r)
        assert e.x0 >= box.x0 - 1 and e.x1 <= box.x1 + 1 and e.y0 >= box.y0 - 1 and e.y1 <= box.y1 + 1, \
            (t.get_text(), e, box)
    tight = fig.get_tightbbox(r)  # inches, the drawn tick labels included
    W, H = fig.get_size_inches()
    assert tight.x0 >= -0.01 and tight.y0 >= -0.01 and tight.x1 <= W + 0.01 and tight.y1 <= H + 0.01, (tight, W, H)


def title_of(fig):
    """The figure's title text (a render's or a plot's)."""
    for t in texts(fig):
        if t.get_gid() == "title":
            return t.get_text()
    return " ".join(ax.get_title() for ax in fig.axes if ax.get_title())


def view_pixels(fig):
    """RGB in [0, 1] of the first axes (the picture of the mesh) of a drawn render."""
    fig.canvas.draw()
    img = np.asarray(fig.canvas.buffer_rgba())[..., :3] / 255.0
    e = fig.axes[0].get_window_extent()
    H = img.shape[0]
    return img[int(H - e.y1):int(H - e.y0), int(e.x0):int(e.x1)]


def red_and_blue(rgb):
    """Counts of strongly red and strongly blue pixels (coolwarm's ends; not the sand of other vessels)."""
    R, G, B = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    red = (R > 0.35) & (G < 0.45 * R) & (B < 0.6 * R)
    blue = (B > 0.35) & (R < 0.7 * B) & (G < 0.9 * B)
    return int(red.sum()), int(blue.sum())


def signed_after(word, title):
    """The signed number of degrees written after ``word`` in a title."""
    m = re.search(word + r"[^+\-\d]*([+\-\u2212]\d+(?:\.\d+)?)\u00b0", title)
    assert m, f"no signed angle after {word!r} in {title!r}"
    return float(m.group(1).replace("\u2212", "-"))


# ----------------------------------------------------------------------------- torsion profile


@pytest.fixture(scope="module")
def twisted():
    """A straight vessel twisted uniformly by +90 degrees, and its profile."""
    ves = synthetic_vessel("straight", radius=1.5, n_around=16, remesh=False)
    return measure_torsion(ves.V, deform_synthetic(ves, twist=np.pi / 2), ves.F)


@pytest.mark.parametrize("reverse", [False, True])
def test_profile_is_drawn_against_arc_length_in_mm(tmp_path, saved, twisted, reverse):
    prof = twisted
    L = prof.length
    viz.plot_torsion_profile(tmp_path / "p.png", prof, reverse=reverse)
    fig = saved["p.png"]
    a1, a2 = fig.axes
    assert "(mm)" in a2.get_xlabel() and "arc length" in a2.get_xlabel()
    assert "(deg)" in a1.get_ylabel() and "deg/mm" in a2.get_ylabel()
    for ax in (a1, a2):
        x = np.concatenate([ln.get_xdata() for ln in ax.get_lines() if len(ln.get_xdata()) > 2])
        assert abs(x.min()) < 1e-6 * L and abs(x.max() - L) < 1e-6 * L  # [0, length], not [0, 1]
    alpha = max((ln for ln in a1.get_lines() if len(ln.get_xdata()) > 2), key=lambda ln: len(ln.get_xdata()))
    x, y = np.asarray(alpha.get_xdata()), np.asarray(alpha.get_ydata())
    # a right-handed quarter turn: 0 where the arc length starts, +90 degrees at the far end, from either end
    assert abs(y[np.argmin(x)]) < 3 and abs(y[np.argmax(x)] - 90) < 3
    rate = next(ln for ln in a2.get_lines() if len(ln.get_xdata()) > 2)
    mid = np.abs(np.asarray(rate.get_xdata()) - 0.5 * L) < 0.3 * L
    assert np.allclose(np.asarray(rate.get_ydata())[mid], 90.0 / L, rtol=0.05)  # degrees per mm
    cap = " ".join(t.get_text() for t in texts(fig) if t.get_gid() == "caption")
    assert "rad\u00b2" in cap and "0 at" in cap and "right-handed" in cap  # the energy's unit and what zero is
    assert "rad\u00b2" in title_of(fig)
    assert_text_inside(fig)


# ----------------------------------------------------------------------------- energy curve


def test_energy_curve_fit_is_visible_and_the_long_title_is_not_cut(tmp_path, saved):
    a = np.radians(np.linspace(-180, 180, 25)) + 0.2
    e = (a - 0.2) ** 2 / 0.9
    name = "xra_coronary_single_branch_open_with_a_longer_name"
    viz.plot_energy_curve(tmp_path / "e.png", a, e, optimum=(0.2, 0.0), evaluated=(a[10:15], e[10:15]),
                          relative_to=0.2, title=f"{name}: torsion energy against the rotation of the joined end "
                                                 f"(paper Fig. 4)")
    fig = saved["e.png"]
    ax = fig.axes[0]
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    fit = next(ln for k, ln in lines.items() if "quadratic" in k)
    data = next(ln for k, ln in lines.items() if k.startswith("torsion energy"))
    assert fit.get_zorder() > data.get_zorder()  # drawn over the data, not hidden under it
    assert fit.get_color() != data.get_color() and fit.get_linestyle() == "--"
    assert any("quadratic" in t.get_text() for t in ax.get_legend().get_texts())
    assert "rad\u00b2" in ax.get_ylabel() and "(deg)" in ax.get_xlabel()
    assert "(paper Fig. 4)" in ax.get_title().replace("\n", " ")  # whole, wrapped
    assert_text_inside(fig)


# ----------------------------------------------------------------------------- renders: framing, titles


def test_a_render_is_framed_on_the_vessel(tmp_path, saved):
    tube = synthetic_vessel("straight", radius=1.5, n_around=16, remesh=False)
    arc = synthetic_vessel("arc", radius=1.5, n_around=16, remesh=False)
    for name, ves in (("tube.png", tube), ("arc.png", arc)):
        viz.render_mesh(tmp_path / name, ves.V, ves.F, None, color=(0.9, 0.1, 0.1))
        img = imread(str(tmp_path / name))[..., :3]
        mesh = (img[..., 0] > 0.25) & (img[..., 1] < 0.6 * img[..., 0])
        rows, cols = np.flatnonzero(mesh.any(axis=1)), np.flatnonzero(mesh.any(axis=0))
        h, w = img.shape[:2]
        # the vessel spans the picture's width; a thin strip is not lost in white space above and below
        assert (cols[-1] - cols[0]) > 0.8 * w, name
        assert (rows[-1] - rows[0]) * (cols[-1] - cols[0]) > 0.5 * h * w or (rows[-1] - rows[0]) > 0.4 * h, name


def test_render_titles_and_captions_are_wrapped_not_cut(tmp_path, saved):
    ves = synthetic_vessel("arc", radius=1.5, n_around=16, remesh=False)
    long = "a_rather_long_vessel_file_name_from_a_segmentation.stl: " + "twist and more words " * 8
    viz.render_mesh(tmp_path / "r.png", ves.V, ves.F, ves.V[:, 0], title=long, caption="what zero is " * 30,
                    scale_bar="mm")
    fig = saved["r.png"]
    assert "\n" in title_of(fig)
    assert_text_inside(fig)


# ----------------------------------------------------------------------------- twist colours and titles


@pytest.mark.parametrize("deg", [90.0, -90.0])
def test_a_twist_render_is_red_where_its_title_says_plus(tmp_path, saved, deg):
    ves = synthetic_vessel("arc", radius=1.5, n_around=24, remesh=False)
    vesselgp.write_mesh(tmp_path / "rest.ply", ves.V, ves.F)
    vesselgp.write_mesh(tmp_path / "def.ply", deform_synthetic(ves, twist=np.radians(deg)), ves.F)
    assert main(["torsion", str(tmp_path / "rest.ply"), str(tmp_path / "def.ply"), "-o", str(tmp_path / "t"),
                 "-q"]) == 0
    fig = saved["deformed_twist.png"]
    said = signed_after("twist", title_of(fig))
    red, blue = red_and_blue(view_pixels(fig))
    assert np.sign(said) == np.sign(deg)
    assert (red > 10 * blue) if said > 0 else (blue > 10 * red), (said, red, blue)
    bar = fig.axes[1]
    assert "0 at end" in (bar.get_ylabel() + bar.get_xlabel())  # the colour bar says what zero is
    prof = saved["profile.png"]
    assert np.sign(signed_after("total twist", title_of(prof))) == np.sign(deg)
    assert_text_inside(fig)


@pytest.fixture(scope="module")
def case2_join():
    """Paper case 2, coarse: its moving end is the fit's s = 0 end (colour relative to the held part)."""
    c = paper_case(2, resolution=0.3)
    p = vesselgp.JoinProblem(c.V, c.F, c.fixed, c.moving,
                             vesselgp.Frame(c.target_origin, c.target_tangent, c.target_normal),
                             moving_normal=c.moving_normal)
    return p, vesselgp.minimize_torsion(p)


@pytest.mark.parametrize("large", [90.0, -90.0])
def test_join_twist_colour_agrees_with_its_title_and_the_turn(tmp_path, saved, case2_join, large):
    problem, res = case2_join
    write_join_outputs(tmp_path, problem, res, {"setup_time_s": 0.0, "time_s": 0.0}, name="case 2",
                       n_curve=3, large_deg=large)
    fig = saved["large_torsion.png"]
    title = title_of(fig)
    there = signed_after("twist there", title)
    # turning the joined end by +90 degrees from the (untwisted) optimum twists it right-handed: positive, red
    assert np.sign(there) == np.sign(large) and abs(there) > 45, title
    red, blue = red_and_blue(view_pixels(fig))
    assert (red > 10 * blue) if there > 0 else (blue > 10 * red), (there, red, blue)
    cbar = fig.axes[1]
    assert "held part" in (cbar.get_ylabel() + cbar.get_xlabel())
    prof = saved["profile_large_torsion.png"]
    a1 = prof.axes[0]
    alpha = max((ln for ln in a1.get_lines() if len(ln.get_xdata()) > 2), key=lambda ln: len(ln.get_xdata()))
    x, y = np.asarray(alpha.get_xdata()), np.asarray(alpha.get_ydata())
    assert abs(y[np.argmin(x)]) < 5 and np.sign(y[np.argmax(x)]) == np.sign(large)  # 0 at the held end
    assert "held end (mm)" in prof.axes[1].get_xlabel()
    for f in (fig, prof, saved["energy_curve.png"]):
        assert_text_inside(f)


# ----------------------------------------------------------------------------- two scans


def _scale_bar(fig):
    """(bar length in display pixels, its label's length in mm)."""
    fig.canvas.draw()
    bar = next(a for a in fig.findobj() if a.get_gid() == "scale bar")
    xy = bar.get_transform().transform(np.column_stack([bar.get_xdata(), bar.get_ydata()]))
    label = next(t for t in texts(fig) if t.get_gid() == "scale bar label").get_text()
    m = re.fullmatch(r"(\d+(?:\.\d+)?) mm", label)
    assert m, label
    return float(np.linalg.norm(xy[1] - xy[0])), float(m.group(1))


def _pixels_per_unit(ax):
    p = ax.transData.transform([[0.0, 0.0], [1.0, 0.0]])
    return float(p[1, 0] - p[0, 0])


def test_twist_scans_have_a_readable_aspect_and_a_scale_bar(tmp_path, saved):
    p = twist_pair(3, twist_deg=40.0, voxel=(0.6, 0.6), side_radius=1.8)
    vesselgp.write_mesh(tmp_path / "a.ply", p.a.V, p.a.F)
    vesselgp.write_mesh(tmp_path / "b.ply", p.V_b, p.b.F)
    assert main(["twist", str(tmp_path / "a.ply"), str(tmp_path / "b.ply"), "-o", str(tmp_path / "tw"), "-q"]) == 0
    img = imread(str(tmp_path / "tw" / "twist_scans.png"))
    h, w = img.shape[:2]
    assert max(w / h, h / w) <= 2.5 + 1e-9, (w, h)
    fig = saved["twist_scans.png"]
    views = [ax for ax in fig.axes]
    assert len(views) == 2
    scale = [_pixels_per_unit(ax) for ax in views]
    assert abs(scale[0] - scale[1]) < 1e-6 * scale[0]  # both scans at one scale
    bar_px, bar_mm = _scale_bar(fig)
    assert abs(bar_px - bar_mm * scale[0]) < 0.01 * bar_px  # the bar is as long as it says
    assert_text_inside(fig)


def test_two_long_thin_scans_still_make_a_readable_picture(tmp_path, saved):
    ves = synthetic_vessel("straight", radius=1.0, n_around=12, remesh=False)
    long = ves.V * [1.0, 1.0, 4.0] if np.ptp(ves.V[:, 2]) > np.ptp(ves.V[:, 0]) else ves.V * [4.0, 1.0, 1.0]
    viz.render_panels(tmp_path / "s.png", [{"V": long, "F": ves.F, "title": "scan A"},
                                           {"V": long + [0.0, 20.0, 0.0], "F": ves.F, "title": "scan B"}],
                      title="two scans")
    img = imread(str(tmp_path / "s.png"))
    h, w = img.shape[:2]
    assert max(w / h, h / w) <= 2.5 + 1e-9, (w, h)
    bar_px, bar_mm = _scale_bar(saved["s.png"])
    assert abs(bar_px - bar_mm * _pixels_per_unit(saved["s.png"].axes[0])) < 0.01 * bar_px


# ----------------------------------------------------------------------------- printed table


def test_the_summary_table_keeps_whole_case_names():
    rows = [{"name": n, "optimum_angle_deg": 1.0, "energy": 0.5, "n_evals": 9, "setup_time_s": 0.1, "time_s": 0.2}
            for n in ("xra_coronary_single_branch_open", "case 1")]
    lines = summary_table(rows).splitlines()
    assert lines[1].startswith("xra_coronary_single_branch_open ")
    assert len({len(ln) for ln in lines}) == 1  # columns still aligned
