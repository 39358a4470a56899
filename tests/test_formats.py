"""Inputs people have (issue #36, part 3): legacy .vtk and .vtu files, and trimesh, pyvista and meshio
meshes wherever (V, F) is taken; axes out as pyvista polylines."""
import subprocess
import sys

import meshio
import numpy as np
import pytest

import vesselgp
from vesselgp import as_mesh, read_mesh
from vesselgp.errors import DependencyError, InvalidMeshError, MeshReadError, MismatchError, OptionError
from vesselgp.synthetic import deform_synthetic, synthetic_tree, synthetic_vessel

RADIUS = 1.5


@pytest.fixture(scope="module")
def tube():
    return synthetic_vessel("arc", radius=RADIUS, n_around=24, remesh=False)


@pytest.fixture(scope="module")
def quads(tube):
    """The tube's quads: its structured faces are (a, b, c) then (a, c, d) for every quad (a, b, c, d)."""
    m = len(tube.F) // 2
    Q = np.c_[tube.F[:m], tube.F[m:, 2]]
    assert np.array_equal(tube.F[m:], Q[:, [0, 2, 3]])
    return Q


def _split(Q):
    """What a reader must make of quads: (a, b, c), (a, c, d), each quad's two triangles together."""
    return np.stack([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]], axis=1).reshape(-1, 3)


def _area(V, F):
    T = V[F]
    return 0.5 * np.linalg.norm(np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]), axis=1).sum()


def _vtk_polydata(V, faces):
    """A vtkPolyData (pyvista's) of faces given as one (m, k) array."""
    pv = pytest.importorskip("pyvista")
    k = faces.shape[1]
    return pv.PolyData(V, np.c_[np.full(len(faces), k), faces].ravel())


def _write_legacy(poly, path, version, binary):
    from vtkmodules.vtkIOLegacy import vtkPolyDataWriter

    w = vtkPolyDataWriter()
    w.SetInputData(poly)
    w.SetFileName(str(path))
    w.SetFileVersion(version)
    w.SetFileTypeToBinary() if binary else w.SetFileTypeToASCII()
    assert w.Write() == 1


# ----------------------------------------------------------------------------- files


@pytest.mark.parametrize("binary", [False, True])
@pytest.mark.parametrize("version", [42, 51])
def test_legacy_vtk_polydata_of_triangles_and_of_quads(tube, quads, tmp_path, binary, version):
    pytest.importorskip("vtkmodules.vtkIOLegacy")
    for name, faces, want in (("tri", tube.F, tube.F), ("quad", quads, _split(quads))):
        p = tmp_path / f"{name}.vtk"
        _write_legacy(_vtk_polydata(tube.V, faces), p, version, binary)
        V, F = read_mesh(p)
        np.testing.assert_array_equal(F, want)
        assert V.dtype == np.float64 and F.dtype == np.int64
        if binary:
            np.testing.assert_array_equal(V, tube.V)
        else:  # VTK's ascii writer keeps 11 digits
            np.testing.assert_allclose(V, tube.V, atol=1e-8)
        assert _area(V, F) == pytest.approx(_area(tube.V, tube.F), rel=1e-9)


@pytest.mark.parametrize("fmt", ["vtk42", "vtk"])  # legacy 4.2 and 5.1 layouts
@pytest.mark.parametrize("binary", [False, True])
def test_legacy_vtk_unstructured_grid_of_quads(tube, quads, tmp_path, fmt, binary):
    p = tmp_path / "quads.vtk"
    meshio.write(p, meshio.Mesh(tube.V, [("quad", quads)]), file_format=fmt, binary=binary)
    V, F = read_mesh(p)
    assert len(F) == 2 * len(quads)  # each quad split into two triangles
    np.testing.assert_array_equal(F, _split(quads))
    np.testing.assert_allclose(V, tube.V, rtol=0, atol=0 if binary else 1e-9)
    assert _area(V, F) == pytest.approx(_area(tube.V, tube.F), rel=1e-9)


@pytest.mark.parametrize("binary", [False, True])
def test_vtu_of_quads_and_of_triangles(tube, quads, tmp_path, binary):
    for cells, want in (([("quad", quads)], _split(quads)), ([("triangle", tube.F)], tube.F)):
        p = tmp_path / "mesh.vtu"
        meshio.write(p, meshio.Mesh(tube.V, cells), binary=binary)
        V, F = read_mesh(p)
        np.testing.assert_array_equal(F, want)
        np.testing.assert_allclose(V, tube.V, rtol=0, atol=0 if binary else 1e-9)
        assert _area(V, F) == pytest.approx(_area(tube.V, tube.F), rel=1e-9)


def test_vtk_files_fit_as_their_arrays(tube, quads, tmp_path):
    p = tmp_path / "quads.vtu"
    meshio.write(p, meshio.Mesh(tube.V, [("quad", quads)]))
    gc = vesselgp.fit_generalized_cylinder(*read_mesh(p))
    assert gc.mean_radius == pytest.approx(RADIUS, rel=0.02)


def test_polygons_quads_and_lines_in_a_grid(tmp_path, caplog):
    # a legacy grid as VTK writes it: a quad (cell type 9), a pentagon (7), a line (3), a vertex (1)
    p = tmp_path / "mixed.vtk"
    p.write_text("# vtk DataFile Version 4.2\nmixed\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 7 double\n"
                 "0 0 0 1 0 0 2 0 0 0 1 0 1 1 0 2 1 0 1 2 0\nCELLS 4 16\n4 0 1 4 3\n5 1 2 5 6 4\n2 0 6\n1 2\n"
                 "CELL_TYPES 4\n9\n7\n3\n1\n")
    with caplog.at_level("INFO", logger="vesselgp"):
        _, F = read_mesh(p)
    # the quad and the pentagon are fans from their first corners
    assert F.tolist() == [[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 6], [1, 6, 4]]
    assert "left out cells: 1 line, 1 vertex" in caplog.text


def test_a_volume_mesh_is_refused_with_what_to_do(tmp_path):
    tet = meshio.Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
                      [("tetra", [[0, 1, 2, 3]]), ("triangle", [[0, 1, 2]])])
    for name in ("tet.vtu", "tet.vtk"):
        meshio.write(tmp_path / name, tet)
        with pytest.raises(MeshReadError, match=rf"{name}: is a volume mesh \(cells: 1 tetra\); .*extract it first"):
            read_mesh(tmp_path / name)


def test_higher_order_faces_and_lines_alone_are_refused(tmp_path):
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, 0, 0], [0.5, 0.5, 0], [0, 0.5, 0]], float)
    meshio.write(tmp_path / "t6.vtu", meshio.Mesh(V, [("triangle6", [[0, 1, 2, 3, 4, 5]])]))
    with pytest.raises(MeshReadError, match=r"higher-order faces \(cells: 1 triangle6\).*linear triangles"):
        read_mesh(tmp_path / "t6.vtu")
    meshio.write(tmp_path / "lines.vtu", meshio.Mesh(V, [("line", [[0, 1], [1, 2]])]))
    with pytest.raises(MeshReadError, match=r"no triangles, quads or polygons \(only cells: 2 line\)"):
        read_mesh(tmp_path / "lines.vtu")


def test_legacy_files_that_are_no_surface_mesh(tmp_path):
    img = tmp_path / "image.vtk"
    img.write_text("# vtk DataFile Version 3.0\nimage\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\n"
                   "ORIGIN 0 0 0\nSPACING 1 1 1\n")
    with pytest.raises(MeshReadError, match="STRUCTURED_POINTS is an image or grid, not a surface mesh"):
        read_mesh(img)
    xml = tmp_path / "xml.vtk"
    xml.write_text('<?xml version="1.0"?>\n<VTKFile type="PolyData"></VTKFile>\n')
    with pytest.raises(MeshReadError, match=r"not a legacy VTK file .*\.vtp .* or \.vtu"):
        read_mesh(xml)
    headless = tmp_path / "headless.vtk"
    headless.write_text("# vtk DataFile Version 3.0\nfield only\nASCII\nFIELD f 0\n")
    with pytest.raises(MeshReadError, match="no DATASET line"):
        read_mesh(headless)


def test_broken_files_are_unreadable_not_crashes(tube, quads, tmp_path):
    cases = []
    for name, kw in (("grid.vtk", {"file_format": "vtk", "binary": True}), ("grid.vtu", {})):
        p = tmp_path / name
        meshio.write(p, meshio.Mesh(tube.V, [("quad", quads)]), **kw)
        cases.append(p)
    try:
        import vtkmodules.vtkIOLegacy  # noqa: F401

        for binary in (False, True):
            p = tmp_path / f"poly{int(binary)}.vtk"
            _write_legacy(_vtk_polydata(tube.V, tube.F), p, 51, binary=binary)
            cases.append(p)
    except ImportError:
        pass
    for p in cases:
        data = p.read_bytes()
        p.write_bytes(data[: 3 * len(data) // 4])  # into the cells
        with pytest.raises(MeshReadError, match=rf"{p.name}: unreadable VT. content"):
            read_mesh(p)  # meshio.read would have called sys.exit(1)


@pytest.mark.parametrize("name, content", [
    ("garbage.vtu", b"\x00\x01 this is not a mesh \xff" * 7),
    ("garbage.vtk", b"\x00\x01 this is not a mesh \xff" * 7),
    ("grid.vtk", b"# vtk DataFile Version 4.2\nx\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 9 double\n\x00\xff"),
    ("poly.vtk", b"# vtk DataFile Version 4.2\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 double\n0 0 0 1 0 0 0 1 0\n"
                 b"POLYGONS 1 4\n3 0 1\n"),
])
def test_garbage_is_refused_with_the_path(tmp_path, name, content):
    if name == "poly.vtk":
        pytest.importorskip("vtkmodules.vtkIOLegacy")
    p = tmp_path / name
    p.write_bytes(content)
    with pytest.raises(MeshReadError) as ei:
        read_mesh(p)
    msg = str(ei.value)
    assert msg.startswith(str(p)) and "\n" not in msg and ("check" in msg or "rename" in msg)


def test_nan_points_in_a_vtu_name_the_file(tube, tmp_path):
    V = tube.V.copy()
    V[5] = np.nan
    meshio.write(tmp_path / "nan.vtu", meshio.Mesh(V, [("triangle", tube.F)]))
    with pytest.raises(InvalidMeshError, match=r"nan\.vtu: V has 1 rows with NaN"):
        read_mesh(tmp_path / "nan.vtu")


def test_legacy_polydata_without_vtk_says_what_to_install(tube, tmp_path, monkeypatch):
    p = tmp_path / "poly.vtk"
    p.write_text("# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\n"
                 "POLYGONS 1 4\n3 0 1 2\n")
    monkeypatch.setitem(sys.modules, "vtkmodules.vtkIOLegacy", None)  # import fails as if not installed
    with pytest.raises(DependencyError, match=r"POLYDATA file needs the vtk package.*pip install vtk"):
        read_mesh(p)


def test_vtk_formats_are_listed():
    assert {".vtk", ".vtu"} <= set(vesselgp.io.READ_FORMATS)


# ----------------------------------------------------------------------------- objects


def _objects(tube, quads):
    """The tube as the other packages hold it."""
    trimesh = pytest.importorskip("trimesh")
    pytest.importorskip("pyvista")
    return {"trimesh": trimesh.Trimesh(tube.V, tube.F, process=False),
            "pyvista": _vtk_polydata(tube.V, tube.F),
            "meshio": meshio.Mesh(tube.V, [("triangle", tube.F)]),
            "meshio quads": meshio.Mesh(tube.V, [("quad", quads)]),
            "pyvista quads": _vtk_polydata(tube.V, quads)}


def test_as_mesh_takes_each_object(tube, quads):
    for name, obj in _objects(tube, quads).items():
        V, F = as_mesh(obj)
        assert V.dtype == np.float64 and F.dtype == np.int64 and V.flags.c_contiguous, name
        np.testing.assert_array_equal(V, tube.V)
        np.testing.assert_array_equal(F, _split(quads) if "quads" in name else tube.F, err_msg=name)
    pm = vesselgp.PreparedMesh(tube.V, tube.F)
    assert as_mesh(pm)[0] is pm.V
    np.testing.assert_array_equal(as_mesh(tube)[1], tube.F)  # a synthetic vessel holds V and F too


def test_objects_give_the_results_of_their_arrays(tube, quads):
    ends = vesselgp.vessel_ends(tube.V, tube.F)
    gc = vesselgp.fit_generalized_cylinder(tube.V, tube.F)
    for name, obj in _objects(tube, quads).items():
        got = vesselgp.vessel_ends(obj)
        np.testing.assert_allclose([e.center for e in got], [e.center for e in ends], atol=1e-12, err_msg=name)
        g = vesselgp.fit_generalized_cylinder(obj)
        assert g.mean_radius == pytest.approx(RADIUS, rel=0.02), name
        if "quads" not in name:  # the same arrays: the same fit
            np.testing.assert_array_equal(g.centers, gc.centers)
    obj = _objects(tube, quads)["trimesh"]
    assert vesselgp.mesh_scale(obj) == vesselgp.mesh_scale(tube.V, tube.F)
    V2, F2, rep = vesselgp.clean_mesh(obj)
    assert not rep.changed and len(F2) == len(tube.F)
    pm = vesselgp.PreparedMesh(obj)
    np.testing.assert_array_equal(vesselgp.fit_generalized_cylinder(pm).centers, gc.centers)


def test_torsion_of_objects(tube):
    pv = pytest.importorskip("pyvista")
    straight = synthetic_vessel("straight", radius=RADIUS, n_around=24, remesh=False)
    Vd = deform_synthetic(straight, twist=1.0)
    rest = pv.PolyData.from_regular_faces(straight.V, straight.F)
    deformed = pv.PolyData.from_regular_faces(Vd, straight.F)
    want = vesselgp.measure_torsion(straight.V, Vd, straight.F)
    for got in (vesselgp.measure_torsion(rest, deformed), vesselgp.measure_torsion(rest, Vd),
                vesselgp.TorsionMeter(rest)(deformed)):
        assert got.total_twist == pytest.approx(want.total_twist, abs=1e-12)
    other = pv.PolyData.from_regular_faces(Vd, straight.F[:, [0, 2, 1]])
    with pytest.raises(MismatchError, match="other faces than the rest mesh"):
        vesselgp.measure_torsion(rest, other)


def test_two_mesh_functions_take_objects_in_either_slot(tube, monkeypatch):
    jv, tw = sys.modules["vesselgp.join_vessels"], sys.modules["vesselgp.twist"]  # the modules, not the functions

    class Seen(Exception):
        pass

    def record(into):
        """A stand-in for the first per-mesh step: notes the mesh, stops at the second."""
        def fake(V, F, *args, **kw):
            into.append(as_mesh(V, F))
            if len(into) == 2:
                raise Seen
        return fake

    trimesh = pytest.importorskip("trimesh")
    a = trimesh.Trimesh(tube.V, tube.F, process=False)
    b = meshio.Mesh(tube.V + 1.0, [("triangle", tube.F)])
    for args in ((a, b), (tube.V, tube.F, b), (a, tube.V + 1.0, tube.F), (tube.V, tube.F, tube.V + 1.0, tube.F)):
        scans = []
        monkeypatch.setattr(tw, "scan_landmarks", record(scans))
        with pytest.raises(Seen):
            vesselgp.twist_between(*args)
        np.testing.assert_array_equal(scans[0][0], tube.V)
        np.testing.assert_array_equal(scans[1][0], tube.V + 1.0)
    scans = []
    monkeypatch.setattr(tw, "scan_landmarks", record(scans))
    with pytest.raises(Seen):
        vesselgp.twist_between(V_a=a, V_b=b, ends_a=(0, 1))
    for args, kw in (((a, 1, b, 0), {}), ((tube.V, tube.F, 1, b, 0), {}),
                     ((a,), {"end": 1, "V_other": b, "other_end": 0})):
        meshes = []
        monkeypatch.setattr(jv, "vessel_ends", record(meshes))
        with pytest.raises(Seen):
            vesselgp.join_vessels(*args, **kw)
        np.testing.assert_array_equal(meshes[1][0], tube.V + 1.0)
    with pytest.raises(InvalidMeshError, match="twist_between: more arguments than its meshes"):
        vesselgp.twist_between(a, b, tube.V)


def test_objects_that_are_not_surface_meshes_say_what_to_do(tube):
    pv = pytest.importorskip("pyvista")
    trimesh = pytest.importorskip("trimesh")
    grid = _vtk_polydata(tube.V, tube.F).cast_to_unstructured_grid()
    with pytest.raises(InvalidMeshError, match=r"pyvista.UnstructuredGrid is not a surface mesh.*extract_surface"):
        as_mesh(grid)
    with pytest.raises(InvalidMeshError, match=r"trimesh.Scene is not a surface mesh.*to_mesh"):
        vesselgp.vessel_ends(trimesh.Scene([trimesh.Trimesh(tube.V, tube.F, process=False)]))
    with pytest.raises(InvalidMeshError, match=r"meshio.Mesh: is a volume mesh \(cells: 1 tetra\)"):
        as_mesh(meshio.Mesh(np.eye(4, 3), [("tetra", [[0, 1, 2, 3]])]))
    with pytest.raises(InvalidMeshError, match=r"pyvista.PolyData: has no triangles, quads or polygons"):
        as_mesh(pv.PolyData(tube.V))
    V = tube.V.copy()
    V[0] = np.nan
    with pytest.raises(InvalidMeshError, match=r"^meshio.Mesh: V has 1 rows with NaN"):
        as_mesh(meshio.Mesh(V, [("triangle", tube.F)]))
    with pytest.raises(InvalidMeshError, match=r"either a mesh object \(pyvista.PolyData\) or the arrays"):
        vesselgp.fit_generalized_cylinder(_vtk_polydata(tube.V, tube.F), (0, 1))
    with pytest.raises(InvalidMeshError, match=r"F is missing: .*trimesh.Trimesh, pyvista.PolyData, meshio.Mesh"):
        vesselgp.vessel_ends(tube.V)
    with pytest.raises(InvalidMeshError, match=r"V is a path .*vesselgp.read_mesh"):
        vesselgp.fit_generalized_cylinder("vessel.stl")


def test_pyvista_strips_polygons_and_lines():
    pv = pytest.importorskip("pyvista")
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 2, 0], [1, 2, 0], [3, 3, 3]], float)
    strip = pv.PolyData(V, strips=[6, 0, 1, 2, 3, 4, 5], lines=[2, 5, 6])
    want = strip.triangulate().faces.reshape(-1, 4)[:, 1:]  # VTK's own unrolling of the strip
    np.testing.assert_array_equal(as_mesh(strip)[1], want)
    pent = pv.PolyData(V, faces=[5, 0, 1, 3, 5, 4, 3, 0, 1, 2])
    assert as_mesh(pent)[1].tolist() == [[0, 1, 3], [0, 3, 5], [0, 5, 4], [0, 1, 2]]


def test_polygons_of_several_sizes_in_one_block():
    from vesselgp._interop import meshio_triangles

    F = meshio_triangles([("polygon", [[0, 1, 2, 3, 4], [0, 1, 2], [5, 6]]), ("triangle", [[1, 2, 3]])], "x")
    assert F.tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 1, 2], [1, 2, 3]]


def test_import_vesselgp_imports_none_of_them():
    code = "import vesselgp, sys; print([m for m in ('trimesh', 'pyvista', 'meshio', 'vtk', 'vtkmodules') " \
           "if m in sys.modules])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


# ----------------------------------------------------------------------------- out


def test_cylinder_to_pyvista(tube):
    pytest.importorskip("pyvista")
    gc = vesselgp.fit_generalized_cylinder(tube.V, tube.F)
    poly = gc.to_pyvista()
    assert poly.n_points == len(gc.s) and poly.n_lines == 1 and poly.n_cells == 1
    np.testing.assert_array_equal(poly.points, gc.centers)
    np.testing.assert_array_equal(poly.point_data["s"], gc.s)
    np.testing.assert_array_equal(poly.point_data["radius"], gc.radii)
    np.testing.assert_allclose(poly.point_data["abscissa"][-1], gc.length)
    np.testing.assert_array_equal(poly.point_data["U"], gc.frames[:, 1])
    assert poly.lines.tolist() == [len(gc.s), *range(len(gc.s))]


def test_tree_to_pyvista():
    pytest.importorskip("pyvista")
    t = synthetic_tree(levels=1, voxel=0.6)
    tree = vesselgp.fit_vessel_tree(t.V, t.F)
    poly = tree.to_pyvista()
    sizes = [len(b.s) for b in tree.branches]
    assert poly.n_cells == poly.n_lines == len(tree.branches) == 3
    assert poly.n_points == sum(sizes)
    assert poly.cell_data["BranchId"].tolist() == [0, 1, 2]
    assert poly.cell_data["ParentId"].tolist() == tree.parent.tolist() == [-1, 0, 0]
    np.testing.assert_array_equal(poly.point_data["radius"], np.concatenate([b.radii for b in tree.branches]))
    lines, k, cells = poly.lines, 0, []
    while k < len(lines):
        cells.append(lines[k + 1:k + 1 + lines[k]])
        k += 1 + lines[k]
    for b, ids in zip(tree.branches, cells):
        np.testing.assert_array_equal(poly.points[ids], b.centers)


def test_meshes_out_to_each_package_and_back(tube):
    pytest.importorskip("pyvista")
    pytest.importorskip("trimesh")
    theta = np.arange(len(tube.V), dtype=float)
    poly = vesselgp.io.to_pyvista(tube.V, tube.F, point_data={"theta": theta})
    np.testing.assert_array_equal(poly.point_data["theta"], theta)
    tm = vesselgp.io.to_trimesh(tube.V, tube.F)
    m = vesselgp.io.to_meshio(tube.V, tube.F)
    for obj in (poly, tm, m):
        V, F = as_mesh(obj)
        np.testing.assert_array_equal(V, tube.V)
        np.testing.assert_array_equal(F, tube.F)
    with pytest.raises(InvalidMeshError, match=r"point data 'theta' must have 1944 rows"):
        vesselgp.io.to_pyvista(tube, point_data={"theta": theta[:-1]})


def test_missing_packages_say_what_to_install(tube, monkeypatch):
    gc = vesselgp.fit_generalized_cylinder(tube.V, tube.F)
    monkeypatch.setitem(sys.modules, "pyvista", None)
    monkeypatch.setitem(sys.modules, "trimesh", None)
    with pytest.raises(DependencyError, match=r"GeneralizedCylinder.to_pyvista\(\) needs pyvista.*pip install pyvista"):
        gc.to_pyvista()
    with pytest.raises(DependencyError, match=r"to_trimesh needs trimesh.*pip install trimesh"):
        vesselgp.io.to_trimesh(tube.V, tube.F)
    assert issubclass(vesselgp.TreeDependencyError, DependencyError)
    assert issubclass(vesselgp.TreeDependencyError, OptionError)


@pytest.mark.parametrize("command", ["fit", "torsion", "join", "twist", "clean", "ends"])
def test_every_command_lists_every_format_it_reads(command, capsys):
    """Issue #49: `--help` of each command that reads meshes lists every format read_mesh takes (it listed
    five of seven), and each listed format is one read_mesh reads (READ_FORMATS is the reader's own list,
    and the tests above read .vtk and .vtu files)."""
    import re

    from vesselgp.cli import main

    assert main([command, "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    lists = re.findall(r"\((\.\w+(?: \.\w+)+)\)", text)
    assert lists, text
    for listed in lists:
        assert listed.split() == list(vesselgp.io.READ_FORMATS), listed
