"""report.html opens in a browser (issue #37, item 2): headless Chromium, no console error, the mesh drawn.

The page of a fit, a tree fit and a join is opened from disk in Debian's ``chromium`` (installed by
``.ci/run`` when missing; without it these tests are skipped with that reason). A console message
other than the browser's own performance notices fails the test, and a screenshot must show the
shaded mesh: saturated pixels (the colour scale's) in the 3D view's area, left of its colour bar.
"""
from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

from vesselgp import write_mesh
from vesselgp.cli import main
from vesselgp.synthetic import synthetic_tree

CHROMIUM = next((shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome") if shutil.which(n)), None)
needs_browser = pytest.mark.skipif(CHROMIUM is None, reason="no chromium on this machine (apt-get install chromium); "
                                                            ".ci/run installs it")
#: The browser's own notices about software WebGL's speed: not the page's errors.
BENIGN = ("GL Driver Message (OpenGL, Performance", "Canvas2D: Multiple readback operations",
          "Automatic fallback to software WebGL")
WINDOW = (1200, 900)


def open_in_browser(page, shot):
    """Console messages (other than BENIGN) of ``page`` opened in headless Chromium, and its screenshot."""
    run = subprocess.run([CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
                          "--use-angle=swiftshader", "--enable-logging=stderr", "--v=0", "--virtual-time-budget=8000",
                          f"--window-size={WINDOW[0]},{WINDOW[1]}", f"--screenshot={shot}", page.resolve().as_uri()],
                         capture_output=True, text=True, timeout=120)
    console = re.findall(r"CONSOLE:\d+\] (.*)", run.stderr)
    return [c for c in console if not any(b in c for b in BENIGN)]


def drawn_fraction(page, tmp_path):
    """Fraction of the window that changes when the page's meshes are made fully transparent (the same page,
    the same axes: only the meshes' pixels differ)."""
    import matplotlib.image as mpimg

    bare = tmp_path / f"bare_{page.parent.name}.html"
    bare.write_text(re.sub(r'"opacity":[0-9.]+', '"opacity":0.0', page.read_text()))
    shots = []
    for p in (page, bare):
        shot = tmp_path / f"{p.stem}_{page.parent.name}.png"
        assert open_in_browser(p, shot) == []
        shots.append(mpimg.imread(shot)[:, :, :3])
    return float(np.mean(np.abs(shots[0] - shots[1]).max(axis=2) > 0.1))


@needs_browser
def test_the_console_check_sees_a_page_error(tmp_path):
    page = tmp_path / "bad.html"
    page.write_text('<html><body><script>throw new Error("boom")</script></body></html>')
    assert any("boom" in c for c in open_in_browser(page, tmp_path / "bad.png"))


@pytest.fixture(scope="module")
def reports(tmp_path_factory):
    d = tmp_path_factory.mktemp("reports")
    assert main(["generate", "--curve", "arc", "--n-around", "24", "-o", str(d / "gen"), "-q"]) == 0
    assert main(["fit", str(d / "gen" / "vessel.ply"), "-o", str(d / "fit"), "-q"]) == 0
    t = synthetic_tree(levels=1, voxel=0.6)
    write_mesh(d / "tree.ply", t.V, t.F)
    assert main(["fit", str(d / "tree.ply"), "-o", str(d / "tree"), "-q"]) == 0
    assert main(["demo", "--resolution", "0.3", "--n-curve", "5", "-o", str(d / "demo"), "-q"]) == 0
    from vesselgp.synthetic import twist_pair

    p = twist_pair(3, twist_deg=40.0, voxel=(0.6, 0.6), side_radius=1.8)
    write_mesh(d / "a.ply", p.a.V, p.a.F)
    write_mesh(d / "b.ply", p.V_b, p.b.F)
    assert main(["twist", str(d / "a.ply"), str(d / "b.ply"), "-o", str(d / "twist"), "-q"]) == 0
    return {"fit": d / "fit" / "report.html", "tree": d / "tree" / "report.html",
            "join": d / "demo" / "case1" / "report.html", "twist": d / "twist" / "report.html"}


@pytest.mark.parametrize("kind", ["fit", "tree", "join", "twist"])
def test_the_page_is_one_self_contained_file(reports, kind):
    page = reports[kind].read_text()
    assert not re.search(r"<script[^>]+src=", page) and "cdn.plot.ly" not in page.split("</script>")[-1]
    assert page.count("Plotly") > 0 and "mesh3d" in page.lower() and "<h2>Numbers</h2>" in page
    assert "data:image/png;base64," in page  # the run's figures, embedded
    assert "(mm)" in page  # the view's axes and colour bar in mm


@needs_browser
@pytest.mark.parametrize("kind", ["fit", "tree", "join", "twist"])
def test_the_page_draws_its_mesh_in_a_browser(reports, kind, tmp_path):
    # over 1 % of the window (10,800 pixels; a view that draws no mesh changes none): and no console error
    assert drawn_fraction(reports[kind], tmp_path) > 0.01
