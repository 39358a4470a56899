"""Tests of vesselgp.viz: colours, renders, plots, atomic writes, polylines (issue #6)."""
import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from vesselgp.errors import MeshWriteError, VesselError
from vesselgp.synthetic import synthetic_vessel
from vesselgp.viz import (
    atomic_write,
    plot_energy_curve,
    plot_torsion_profile,
    render_mesh,
    torsion_colors,
    view_basis,
    write_polyline,
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


def test_write_polyline_vtp_and_ply(tmp_path):
    P = np.c_[np.linspace(0, 1, 5), np.zeros(5), np.zeros(5)]
    data = {"radius": np.full(5, 2.0), "T": np.tile([1.0, 0, 0], (5, 1))}
    write_polyline(tmp_path / "a.vtp", P, data)
    root = ET.parse(tmp_path / "a.vtp").getroot()
    piece = root.find("PolyData/Piece")
    assert piece.get("NumberOfPoints") == "5" and piece.get("NumberOfLines") == "1"
    conn = piece.find("Lines/DataArray[@Name='connectivity']").text.split()
    assert conn == ["0", "1", "2", "3", "4"]
    names = [d.get("Name") for d in piece.find("PointData")]
    assert names == ["radius", "T"]
    write_polyline(tmp_path / "a.ply", P, data)
    txt = (tmp_path / "a.ply").read_text().splitlines()
    assert "element vertex 5" in txt and "element edge 4" in txt and "property double radius" in txt
    body = txt[txt.index("end_header") + 1:]
    assert len(body) == 9 and body[-1] == "3 4"
    with pytest.raises(MeshWriteError):
        write_polyline(tmp_path / "a.obj", P)
    with pytest.raises(VesselError):
        write_polyline(tmp_path / "b.vtp", P, {"bad": np.zeros(4)})
