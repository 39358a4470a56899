"""Tests of vesselgp.viz: colours, renders, plots, atomic writes, polylines (issues #6, #12)."""
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from vesselgp import tolerances as tol
from vesselgp import viz
from vesselgp.errors import MeshWriteError, OptionError, VesselError
from vesselgp.io import atomic_write
from vesselgp.synthetic import synthetic_vessel
from vesselgp.errors import DecimationError
from vesselgp.viz import (
    plot_energy_curve,
    plot_torsion_profile,
    render_mesh,
    torsion_colors,
    view_basis,
)

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def assert_png(path, min_size=(100, 100)):
    """A valid, non-blank PNG of at least min_size (width, height) pixels."""
    import matplotlib.image as mpimg

    with open(path, "rb") as fh:
        assert fh.read(8) == PNG_MAGIC
    img = mpimg.imread(path)
    assert img.ndim == 3 and img.shape[1] >= min_size[0] and img.shape[0] >= min_size[1]
    assert float(img[..., :3].std()) > 0.01  # not blank
    return img


@pytest.fixture(scope="module")
def arc():
    return synthetic_vessel("arc", radius=1.5, n_around=16, remesh=False)


def test_torsion_colors_symmetric_and_neutral_at_zero():
    c = torsion_colors([-10.0, 0.0, 5.0, np.nan])
    assert c.shape == (4, 3) and c.dtype == np.uint8
    # zero is the colormap's centre (a neutral grey for coolwarm): channels nearly equal
    assert int(c[1].max()) - int(c[1].min()) < 20
    # symmetric range: +5 is half as saturated as -10, i.e. closer to neutral
    assert abs(int(c[2, 0]) - int(c[2, 2])) < abs(int(c[0, 0]) - int(c[0, 2]))
    assert c[3].tolist() == [128, 128, 128]  # NaN grey
    # explicit range clips
    d = torsion_colors([-100.0, 100.0], vmin=-1, vmax=1)
    assert d[0].tolist() == torsion_colors([-1.0], -1, 1)[0].tolist()
    # all zero: no division by zero, neutral colour
    z = torsion_colors(np.zeros(5))
    assert np.all(z == z[0])


def test_view_basis_is_side_on_and_right_handed(arc):
    B = view_basis(arc.V)
    assert np.allclose(B @ B.T, np.eye(3), atol=1e-12)
    assert np.allclose(np.cross(B[0], B[1]), B[2], atol=1e-12)
    # the arc lies in the xz-plane: the viewer looks along y, z is up
    assert abs(abs(B[2, 1]) - 1) < 1e-6
    assert B[1, 2] > 0.99
    B2 = view_basis(arc.V, view=[1, 0, 0])
    assert np.allclose(B2[2], [1, 0, 0])
    with pytest.raises(VesselError):
        view_basis(arc.V, view=[0, 0, 0])


def test_render_mesh_with_colour_bar(tmp_path, arc):
    p = tmp_path / "arc.png"
    out = render_mesh(p, arc.V, arc.F, np.degrees(arc.truth.vertex_theta), title="arc")
    assert out == p
    img = assert_png(p, (300, 150))
    h, w = img.shape[:2]
    # colour bar on the right: strongly coloured (blue and red) pixels in the right 20 %
    right = img[:, int(0.8 * w):, :3]
    assert np.any((right[..., 2] > 0.6) & (right[..., 0] < 0.4))
    assert np.any((right[..., 0] > 0.6) & (right[..., 2] < 0.4))
    assert not list(tmp_path.glob(".*tmp"))  # no temporary left behind
    mask = os.umask(0)
    os.umask(mask)
    assert os.stat(p).st_mode & 0o777 == 0o666 & ~mask  # ordinary permissions, not mkstemp's 0600


def test_render_mesh_plain_decimated_and_others(tmp_path, arc):
    p = tmp_path / "plain.png"
    other = (arc.V + [30.0, 0, 0], arc.F)
    render_mesh(p, arc.V, arc.F, None, others=[other], max_faces=200)  # forces decimation
    assert_png(p)
    with pytest.raises(VesselError):
        render_mesh(tmp_path / "bad.png", arc.V, arc.F, np.zeros(3))


def test_plot_energy_curve_and_profile(tmp_path):
    a = np.radians(np.linspace(-180, 180, 13)) + 0.3
    e = (a - 0.3) ** 2
    p = plot_energy_curve(tmp_path / "e.png", a, e, optimum=(0.3, 0.0), evaluated=(a[5:8], e[5:8]),
                          relative_to=0.3, title="curve")
    assert_png(p, (500, 300))
    with pytest.raises(VesselError):
        plot_energy_curve(tmp_path / "bad.png", a, e[:-1])

    from vesselgp.synthetic import deform_synthetic
    from vesselgp.torsion import measure_torsion

    ves = synthetic_vessel("straight", radius=1.5, n_around=12, remesh=False)
    prof = measure_torsion(ves.V, deform_synthetic(ves, twist=1.0), ves.F)
    assert_png(plot_torsion_profile(tmp_path / "prof.png", prof), (500, 300))


ROOT = Path(__file__).resolve().parents[1]

# Runs in a fresh interpreter whose backend is not Agg (like a Jupyter kernel's inline
# backend): every figure function is used, then the global matplotlib state is compared.
_GLOBAL_STATE_SCRIPT = textwrap.dedent("""
    import sys
    import matplotlib
    matplotlib.use("svg")
    before = matplotlib.rcParams.copy()
    import numpy as np
    from vesselgp.synthetic import deform_synthetic, synthetic_vessel
    from vesselgp.torsion import measure_torsion
    from vesselgp.viz import plot_energy_curve, plot_torsion_profile, render_mesh, torsion_colors

    out = sys.argv[1]
    ves = synthetic_vessel("straight", radius=1.5, n_around=12, remesh=False)
    prof = measure_torsion(ves.V, deform_synthetic(ves, twist=1.0), ves.F)
    torsion_colors(np.degrees(prof.vertex_alpha))
    render_mesh(out + "/m.png", ves.V, ves.F, np.degrees(prof.vertex_alpha), title="t")
    render_mesh(out + "/d.png", ves.V, ves.F, None, max_faces=100)
    a = np.linspace(-3, 3, 9)
    plot_energy_curve(out + "/e.png", a, a ** 2, optimum=(0.0, 0.0), title="e")
    plot_torsion_profile(out + "/p.png", prof)
    changed = sorted(k for k in before if matplotlib.rcParams[k] != before[k])
    print("backend", matplotlib.get_backend())
    print("changed", changed)
    print("pyplot", "matplotlib.pyplot" in sys.modules)
""")


def test_figures_leave_global_matplotlib_state_alone(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    env.pop("MPLBACKEND", None)
    r = subprocess.run([sys.executable, "-c", _GLOBAL_STATE_SCRIPT, str(tmp_path)], cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert "backend svg" in lines  # not switched to Agg
    assert "changed []" in lines  # no rcParams touched
    assert "pyplot False" in lines  # pyplot never imported
    for name in ("m", "d", "e", "p"):
        assert_png(tmp_path / f"{name}.png")


def _rc_snapshot():
    """rcParams without "backend" (reading an unresolved backend would resolve it)."""
    import matplotlib

    return {k: matplotlib.rcParams[k] for k in matplotlib.rcParams if k != "backend"}


def test_figures_keep_rcparams_in_process(tmp_path, arc):
    had_pyplot = "matplotlib.pyplot" in sys.modules
    before = _rc_snapshot()
    torsion_colors([-1.0, 2.0])
    render_mesh(tmp_path / "a.png", arc.V, arc.F, arc.V[:, 0], max_faces=300)
    plot_energy_curve(tmp_path / "e.png", [0.0, 1.0, 2.0], [1.0, 0.0, 1.0])
    assert _rc_snapshot() == before
    assert ("matplotlib.pyplot" in sys.modules) == had_pyplot


def test_render_mesh_above_viz_max_faces_keeps_scalars(tmp_path, monkeypatch):
    ves = synthetic_vessel("arc", radius=1.5, n_around=96, remesh=False)
    assert len(ves.F) > 2 * tol.VIZ_MAX_FACES
    a = np.array([0.7, 0.2, -0.3])
    S = ves.V @ a + 2.0  # linear field: exact value known at any point
    seen = []

    def spy(V, F, scalars, max_faces):
        out = real(V, F, scalars, max_faces)
        seen.append(out)
        return out

    real = viz._decimate
    monkeypatch.setattr(viz, "_decimate", spy)
    assert_png(render_mesh(tmp_path / "big.png", ves.V, ves.F, S), (300, 150))
    (V2, F2, S2), = seen
    assert len(F2) <= tol.VIZ_MAX_FACES and S2.shape == (len(V2),)
    err = np.abs(S2 - (V2 @ a + 2.0))
    # interpolated at the closest original surface point: far below one edge times the gradient
    assert err.max() < 1e-4 * np.ptp(S)


def test_decimate_scalars_none_and_nan(arc):
    V2, F2, S2 = viz._decimate(arc.V, arc.F, None, 300)
    assert S2 is None and 0 < len(F2) <= 300 and F2.max() < len(V2)
    S = arc.V[:, 2].copy()
    S[0] = np.nan
    V2, F2, S2 = viz._decimate(arc.V, arc.F, S, 300)
    assert np.count_nonzero(np.isfinite(S2)) > 0.9 * len(V2)  # NaN stays local


def _raise_pymeshlab(*args, **kwargs):
    import pymeshlab

    raise pymeshlab.PyMeshLabException("Failed to apply filter: simulated failure")


@pytest.mark.parametrize("filter_name", ["meshing_decimation_quadric_edge_collapse",
                                         "transfer_attributes_per_vertex"])
def test_decimation_failure_raises_instead_of_drawing(tmp_path, arc, monkeypatch, filter_name):
    import pymeshlab

    monkeypatch.setattr(pymeshlab.MeshSet, filter_name, _raise_pymeshlab)
    p = tmp_path / "x.png"
    with pytest.raises(DecimationError, match="simulated failure.*max_faces >= ") as info:
        render_mesh(p, arc.V, arc.F, arc.V[:, 0], max_faces=200)
    assert isinstance(info.value, VesselError) and "\n" not in str(info.value)
    assert not p.exists() and not list(tmp_path.iterdir())  # nothing drawn, nothing left behind
    render_mesh(p, arc.V, arc.F, arc.V[:, 0], max_faces=len(arc.F))  # undecimated still draws
    assert_png(p)


def test_decimation_leaving_no_face_raises(tmp_path, arc, monkeypatch):
    import pymeshlab

    def wipe(self, **kwargs):
        self.set_selection_all()
        self.meshing_remove_selected_vertices_and_faces()

    monkeypatch.setattr(pymeshlab.MeshSet, "meshing_decimation_quadric_edge_collapse", wipe)
    with pytest.raises(DecimationError, match="left no face"):
        render_mesh(tmp_path / "x.png", arc.V, arc.F, None, max_faces=200)
    assert not list(tmp_path.iterdir())


def test_bad_cmap_and_max_faces_are_option_errors(tmp_path, arc):
    with pytest.raises(OptionError, match="colormap"):
        torsion_colors([0.0, 1.0], cmap="no-such-map")
    with pytest.raises(OptionError, match="colormap"):
        render_mesh(tmp_path / "a.png", arc.V, arc.F, arc.V[:, 0], cmap="no-such-map")
    for bad in (0, -5, 2.5, "many"):
        with pytest.raises(OptionError, match="max_faces"):
            render_mesh(tmp_path / "a.png", arc.V, arc.F, max_faces=bad)
    assert not list(tmp_path.iterdir())


def test_atomic_write_keeps_old_file_on_failure(tmp_path):
    p = tmp_path / "x.txt"
    atomic_write(p, lambda fh: fh.write("old"))

    def boom(fh):
        fh.write("partial")
        raise RuntimeError("disk full")

    with pytest.raises(MeshWriteError):
        atomic_write(p, boom)
    assert p.read_text() == "old"
    assert sorted(os.listdir(tmp_path)) == ["x.txt"]
    with pytest.raises(MeshWriteError):
        atomic_write(tmp_path / "missing" / "y.txt", lambda fh: fh.write("y"))


def test_periodic_scalars_have_no_seam_and_the_axis_is_drawn(tmp_path):
    """An angle about a tube's axis wraps at +-180: faces at the wrap get the circular mean of their
    corners (about +-180, red/blue at the ends of a cyclic map), not the linear mean (about 0)."""
    from vesselgp.viz import _face_values

    S = np.array([179.0, -179.0, 178.0])
    F = np.array([[0, 1, 2]])
    assert abs(abs(_face_values(S, F, 360.0)[0]) - 179.33) < 0.01
    assert abs(_face_values(S, F, None)[0] - 59.33) < 0.01  # what the linear mean would give
    ves = synthetic_vessel("arc", radius=1.5, n_around=24, remesh=False)
    theta = np.degrees(np.arctan2(ves.V[:, 1] - ves.V[:, 1].mean(), ves.V[:, 2]))
    render_mesh(tmp_path / "t.png", ves.V, ves.F, theta, vmin=-180, vmax=180, cmap="twilight", period=360.0,
                lines=[ves.truth.centers])
    assert_png(tmp_path / "t.png")
    render_mesh(tmp_path / "d.png", ves.V, ves.F, theta, vmin=-180, vmax=180, cmap="twilight", period=360.0,
                max_faces=500)
    assert_png(tmp_path / "d.png")
