"""Tests of vesselgp.io: every format round-trips, polygons triangulate, errors are clear."""
from __future__ import annotations

import base64
import xml.etree.ElementTree as ET
import os
import re
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

import vesselgp.io.meshfile as meshfile_mod
import vesselgp.io.vtp as vtp_mod
from vesselgp.errors import InvalidMeshError, MeshReadError, MeshWriteError, VesselError
from vesselgp.io import read_mesh, write_mesh, write_polyline
from _data import REAL


CUBE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                   [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float)
CUBE_F = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                   [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])


def random_mesh(rng, n=40, m=60):
    V = rng.normal(size=(n, 3)) * 10
    F = np.array([rng.choice(n, 3, replace=False) for _ in range(m)])
    return V, F


def same_triangles(V1, F1, V2, F2):
    """Same set of oriented triangles by corner positions (cyclic rotation allowed)."""
    def key(V, F):
        rows = []
        for t in V[F].tolist():  # rotate each triangle to start at its smallest corner
            i = min(range(3), key=lambda j: t[j])
            rows.append(tuple(map(tuple, t[i:] + t[:i])))
        return sorted(rows)

    return key(V1, F1) == key(V2, F2)


def read_ply_vertices(path):
    """Independent little reader of a binary little-endian PLY vertex element."""
    raw = Path(path).read_bytes()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    head = raw[:end].decode()
    assert "format binary_little_endian 1.0" in head
    n = int(re.search(r"element vertex (\d+)", head).group(1))
    vert_part = head.split("element vertex")[1].split("element face")[0]
    types = {"double": "<f8", "float": "<f4", "uchar": "u1", "int": "<i4"}
    fields = [(name, types[t]) for t, name in re.findall(r"property (\w+) (\w+)", vert_part)]
    return np.frombuffer(raw[end:end + n * np.dtype(fields).itemsize], dtype=fields)


# --------------------------------------------------------------------------- #
# real meshes
# --------------------------------------------------------------------------- #
@pytest.mark.parametrize("name, nv, nf", [
    ("vmtk_abdominal_aorta_iliac_bifurcation_open.stl", 6068, 11887),
    ("xra_coronary_single_branch_open.stl", 3232, 6400),
    ("dfemtoolz_artery_segment_lumen_capped.stl", 6319, 12634),
])
def test_real_meshes_counts(name, nv, nf):
    V, F = read_mesh(REAL / name)
    assert V.shape == (nv, 3) and V.dtype == np.float64
    assert F.shape == (nf, 3) and F.dtype == np.int64
    assert len(np.unique(V, axis=0)) == nv  # no duplicates left
    assert np.array_equal(np.unique(F), np.arange(nv))  # every vertex used


# --------------------------------------------------------------------------- #
# STL
# --------------------------------------------------------------------------- #
def ascii_stl(V, F):
    out = ["solid cube"]
    for t in V[F].tolist():
        out += ["facet normal 0 0 0", "outer loop", *[f"vertex {p[0]!r} {p[1]!r} {p[2]!r}" for p in t],
                "endloop", "endfacet"]
    return "\n".join(out + ["endsolid cube", ""])


def test_ascii_stl_cube_merges_corners(tmp_path):
    p = tmp_path / "cube.stl"
    p.write_text(ascii_stl(CUBE_V, CUBE_F))
    V, F = read_mesh(p)
    assert V.shape == (8, 3) and F.shape == (12, 3)
    assert same_triangles(V, F, CUBE_V, CUBE_F)


def test_binary_stl_roundtrip_and_merge(tmp_path):
    p = tmp_path / "cube.STL"  # extension is case-insensitive
    write_mesh(p, CUBE_V * 3.5, CUBE_F)
    assert p.stat().st_size == 84 + 50 * 12
    V, F = read_mesh(p)
    assert V.shape == (8, 3)
    assert same_triangles(V, F, CUBE_V * 3.5, CUBE_F)
    # normals written are unit outward normals
    rec = np.frombuffer(p.read_bytes()[84:], dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    np.testing.assert_allclose(np.linalg.norm(rec["n"], axis=1), 1, atol=1e-6)


def test_binary_stl_float32_precision(tmp_path):
    rng = np.random.default_rng(0)
    V, F = random_mesh(rng)
    write_mesh(tmp_path / "r.stl", V, F)
    V2, F2 = read_mesh(tmp_path / "r.stl")
    assert len(V2) == len(np.unique(F))
    assert same_triangles(V2, F2, V.astype(np.float32).astype(float), F)


def test_stl_nan_is_invalid(tmp_path):
    p = tmp_path / "nan.stl"
    p.write_text(ascii_stl(CUBE_V, CUBE_F).replace("vertex 1.0 1.0 0.0", "vertex 1.0 nan 0.0", 1))
    with pytest.raises(InvalidMeshError, match="nan.stl.*NaN"):
        read_mesh(p)


# --------------------------------------------------------------------------- #
# PLY
# --------------------------------------------------------------------------- #
def test_ply_roundtrip_colours_and_scalars(tmp_path):
    import pymeshlab

    rng = np.random.default_rng(1)
    V, F = random_mesh(rng)
    C = rng.random((len(V), 3))
    s = rng.normal(size=len(V))
    p = tmp_path / "m.ply"
    write_mesh(p, V, F, vertex_colors=C, vertex_scalars=s)
    V2, F2 = read_mesh(p)
    assert np.array_equal(V2, V) and np.array_equal(F2, F)
    vd = read_ply_vertices(p)
    assert np.array_equal(vd["quality"], s)
    assert np.array_equal(np.c_[vd["red"], vd["green"], vd["blue"]], np.round(C * 255).astype(np.uint8))
    ms = pymeshlab.MeshSet()  # another reader agrees
    ms.load_new_mesh(str(p))
    m = ms.current_mesh()
    np.testing.assert_array_equal(m.vertex_scalar_array(), s)
    np.testing.assert_allclose(m.vertex_color_matrix()[:, :3], np.round(C * 255) / 255, atol=1e-6)


def test_ply_named_scalars_and_rgba_uint8(tmp_path):
    V, F = CUBE_V, CUBE_F
    C = np.arange(32, dtype=np.uint8).reshape(8, 4)
    p = tmp_path / "m.ply"
    write_mesh(p, V, F, vertex_colors=C, vertex_scalars={"alpha_angle": np.arange(8.0), "s2": -np.arange(8.0)})
    vd = read_ply_vertices(p)
    assert np.array_equal(vd["alpha_angle"], np.arange(8.0)) and np.array_equal(vd["s2"], -np.arange(8.0))
    assert np.array_equal(np.c_[vd["red"], vd["green"], vd["blue"], vd["alpha"]], C)
    assert np.array_equal(read_mesh(p)[1], F)


def test_ascii_ply_polygons_triangulated(tmp_path):
    p = tmp_path / "poly.ply"
    p.write_text(
        "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\n"
        "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 1.5 0\n9 9 9\n5 0 1 2 4 3\n3 0 1 2\n")
    V, F = read_mesh(p)
    assert V.shape == (6, 3)  # the unreferenced vertex is kept
    assert F.tolist() == [[0, 1, 2], [0, 2, 4], [0, 4, 3], [0, 1, 2]]


def test_ply_nan_is_invalid(tmp_path):
    p = tmp_path / "nan.ply"
    p.write_text(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
        "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n3 0 2 3\n")
    with pytest.raises(InvalidMeshError, match="declares 4 vertices"):
        read_mesh(p)


# --------------------------------------------------------------------------- #
# OBJ and OFF
# --------------------------------------------------------------------------- #
@pytest.mark.parametrize("ext", [".obj", ".off", ".vtp"])
def test_text_formats_roundtrip_exactly(tmp_path, ext):
    rng = np.random.default_rng(2)
    V, F = random_mesh(rng)
    V[0] = [1e-300, -0.1, 1 / 3]
    write_mesh(tmp_path / f"m{ext}", V, F)
    V2, F2 = read_mesh(tmp_path / f"m{ext}")
    assert np.array_equal(V2, V) and np.array_equal(F2, F)


def test_obj_quads_and_polygons(tmp_path):
    p = tmp_path / "q.obj"
    p.write_text("# quads\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 1.5 0\n"
                 "f 1/1/1 2/2/2 3/3/3 4/4/4\nf 3 5 4\n")
    V, F = read_mesh(p)
    assert V.shape == (5, 3)
    assert F.tolist() == [[0, 1, 2], [0, 2, 3], [2, 4, 3]]


def test_off_pentagon_fan(tmp_path):
    p = tmp_path / "p.off"
    p.write_text("OFF\n5 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 1.5 0\n5 0 1 2 4 3\n")
    V, F = read_mesh(p)
    assert F.tolist() == [[0, 1, 2], [0, 2, 4], [0, 4, 3]]
    # the triangles tile the pentagon: total area 1.25
    A = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    assert A.sum() == pytest.approx(1.25)


def test_off_and_obj_with_colours(tmp_path):
    C = np.linspace(0, 1, 24).reshape(8, 3)
    write_mesh(tmp_path / "c.off", CUBE_V, CUBE_F, vertex_colors=C)
    txt = (tmp_path / "c.off").read_text().splitlines()
    assert txt[0] == "COFF" and txt[2].split()[3:] == ["0", "11", "22", "255"]
    V, F = read_mesh(tmp_path / "c.off")
    assert np.array_equal(V, CUBE_V) and np.array_equal(F, CUBE_F)
    write_mesh(tmp_path / "c.obj", CUBE_V, CUBE_F, vertex_colors=C)
    V, F = read_mesh(tmp_path / "c.obj")
    assert np.array_equal(V, CUBE_V) and np.array_equal(F, CUBE_F)


def test_off_nan_is_invalid(tmp_path):
    p = tmp_path / "n.off"
    p.write_text("OFF\n3 1 0\n0 0 nan\n1 0 0\n1 1 0\n3 0 1 2\n")
    with pytest.raises(InvalidMeshError, match="n.off.*NaN"):
        read_mesh(p)


# --------------------------------------------------------------------------- #
# VTP
# --------------------------------------------------------------------------- #
def _encode(a, mode, hdt, blocksize):
    """Bytes or base64 text of one DataArray payload in the given VTK encoding."""
    raw = a.tobytes()
    if mode == "zlib":
        blocks = [raw[i:i + blocksize] for i in range(0, len(raw), blocksize)] or [b""]
        comp = [zlib.compress(b) for b in blocks]
        head = np.array([len(blocks), blocksize, len(blocks[-1]), *map(len, comp)], dtype=hdt)
        return head.tobytes(), b"".join(comp)
    return np.array([len(raw)], dtype=hdt).tobytes(), raw


def make_vtp(V, conn, offsets, mode="binary", header="UInt32", endian="<", blocksize=64,
             joint=True, appended=None, strips=0):
    """A VTK XML PolyData file written by the rules of the VTK file-format spec."""
    hdt = np.dtype(endian + ("u4" if header == "UInt32" else "u8"))
    arrays = [("Points", np.asarray(V, endian + "f8"), 3), ("connectivity", np.asarray(conn, endian + "i8"), 1),
              ("offsets", np.asarray(offsets, endian + "i8"), 1)]
    bo = "LittleEndian" if endian == "<" else "BigEndian"
    comp = ' compressor="vtkZLibDataCompressor"' if mode == "zlib" else ""
    chunks, app, pos = {}, [], 0
    for name, a, nc in arrays:
        if mode == "ascii":
            body, attr = " ".join(repr(x) for x in a.ravel().tolist()), 'format="ascii"'
        else:
            h, d = _encode(a, mode, hdt, blocksize)
            if appended == "raw":
                blob = h + d
                attr = f'format="appended" offset="{pos}"'
                app.append(blob)
                pos += len(blob)
                body = ""
            else:
                if mode == "zlib" or not joint:
                    text = base64.b64encode(h).decode() + base64.b64encode(d).decode()
                else:
                    text = base64.b64encode(h + d).decode()
                if appended == "base64":
                    attr = f'format="appended" offset="{pos}"'
                    app.append(text.encode())
                    pos += len(text)
                    body = ""
                else:
                    body, attr = text, 'format="binary"'
        comps = f' NumberOfComponents="{nc}"' if nc > 1 else ""
        tname = {"f8": "Float64", "i8": "Int64"}[a.dtype.str[1:]]
        chunks[name] = f'<DataArray type="{tname}" Name="{name}"{comps} {attr}>{body}</DataArray>'
    xml = (f'<?xml version="1.0"?>\n<VTKFile type="PolyData" version="1.0" byte_order="{bo}" '
           f'header_type="{header}"{comp}>\n<PolyData>\n'
           f'<Piece NumberOfPoints="{len(V)}" NumberOfVerts="0" NumberOfLines="0" '
           f'NumberOfStrips="{strips}" NumberOfPolys="{len(offsets)}">\n'
           f'<Points>{chunks["Points"]}</Points>\n'
           f'<Polys>{chunks["connectivity"]}{chunks["offsets"]}</Polys>\n</Piece>\n</PolyData>\n')
    data = xml.encode()
    if appended:
        enc = "raw" if appended == "raw" else "base64"
        data += f'<AppendedData encoding="{enc}">\n   _'.encode() + b"".join(app) + b"\n</AppendedData>\n"
    return data + b"</VTKFile>\n"


def _quad_strip(k=7):
    """A strip of k quads and one pentagon, with the expected fan triangles."""
    x = np.arange(k + 1, dtype=float)
    V = np.r_[np.c_[x, 0 * x, 0 * x], np.c_[x, 0 * x + 1, 0 * x + 0.25 * x], [[k + 1.0, 0.5, 0.3]]]
    n = k + 1
    quads = [[i, i + 1, n + i + 1, n + i] for i in range(k - 1)]
    pent = [k - 1, k, 2 * n, 2 * n - 1, 2 * n - 2]
    conn = np.concatenate(quads + [pent])
    offsets = np.cumsum([4] * (k - 1) + [5])
    tris = [t for q in quads for t in ([q[0], q[1], q[2]], [q[0], q[2], q[3]])]
    tris += [[pent[0], pent[j], pent[j + 1]] for j in range(1, 4)]
    return V, conn, offsets, np.array(tris)


VTP_CASES = {
    "ascii": dict(mode="ascii"),
    "binary-u32": dict(mode="binary", header="UInt32"),
    "binary-u64": dict(mode="binary", header="UInt64"),
    "binary-separate": dict(mode="binary", joint=False),
    "binary-bigendian": dict(mode="binary", endian=">"),
    "zlib-u32": dict(mode="zlib", header="UInt32", blocksize=48),
    "zlib-u64": dict(mode="zlib", header="UInt64", blocksize=1000),
    "appended-base64-zlib": dict(mode="zlib", appended="base64", blocksize=40),
    "appended-base64": dict(mode="binary", appended="base64"),
    "appended-raw": dict(mode="binary", appended="raw"),
    "appended-raw-zlib": dict(mode="zlib", appended="raw", blocksize=40),
}


@pytest.mark.parametrize("case", list(VTP_CASES))
def test_vtp_variants(tmp_path, case):
    V, conn, offsets, tris = _quad_strip()
    p = tmp_path / f"{case}.vtp"
    p.write_bytes(make_vtp(V, conn, offsets, **VTP_CASES[case]))
    V2, F2 = read_mesh(p)
    assert np.array_equal(V2, V)
    assert np.array_equal(F2, tris)


def test_vtp_point_data_roundtrip(tmp_path):
    rng = np.random.default_rng(3)
    V, F = random_mesh(rng)
    s = {"torsion": rng.normal(size=len(V)), "alpha": rng.normal(size=len(V))}
    C = rng.integers(0, 256, size=(len(V), 4)).astype(np.uint8)
    p = tmp_path / "pd.vtp"
    write_mesh(p, V, F, vertex_colors=C, vertex_scalars=s)
    V2, F2, pdata = vtp_mod.read_vtp(p)
    assert np.array_equal(V2, V) and np.array_equal(F2, F)
    assert np.array_equal(pdata["torsion"], s["torsion"]) and np.array_equal(pdata["alpha"], s["alpha"])
    assert np.array_equal(pdata["Colors"], C)


def test_vtp_errors(tmp_path):
    V, conn, offsets, _ = _quad_strip()
    p = tmp_path / "s.vtp"
    p.write_bytes(make_vtp(V, conn, offsets, strips=2))
    with pytest.raises(MeshReadError, match="strips"):
        read_mesh(p)
    p.write_text('<?xml version="1.0"?><VTKFile type="UnstructuredGrid"></VTKFile>')
    with pytest.raises(MeshReadError, match="not a VTK PolyData"):
        read_mesh(p)
    p.write_text("<VTKFile type='PolyData'><PolyData><Piece")
    with pytest.raises(MeshReadError, match="not valid VTP XML"):
        read_mesh(p)
    good = make_vtp(V, conn, offsets, mode="zlib")
    p.write_bytes(good.replace(b'format="binary">', b'format="binary">AAAA', 1))
    with pytest.raises(MeshReadError, match="s.vtp"):
        read_mesh(p)


# --------------------------------------------------------------------------- #
# errors and atomic writes
# --------------------------------------------------------------------------- #
@pytest.mark.parametrize("ext", [".stl", ".ply", ".obj", ".off", ".vtp"])
def test_garbage_and_empty_files(tmp_path, ext):
    p = tmp_path / f"bad{ext}"
    p.write_bytes(b"this is not a mesh \x00\x01\x02 at all\n" * 3)
    with pytest.raises(MeshReadError, match=f"bad\\{ext}"):
        read_mesh(p)
    e = tmp_path / f"empty{ext}"
    e.write_bytes(b"")
    with pytest.raises(MeshReadError, match="empty"):
        read_mesh(e)


def test_missing_unknown_and_directory(tmp_path):
    with pytest.raises(MeshReadError, match="no such file"):
        read_mesh(tmp_path / "nope.stl")
    (tmp_path / "m.xyz").write_text("1 2 3\n")
    with pytest.raises(MeshReadError, match="unknown mesh extension '.xyz'"):
        read_mesh(tmp_path / "m.xyz")
    (tmp_path / "d.stl").mkdir()
    with pytest.raises(MeshReadError, match="not a regular file"):
        read_mesh(tmp_path / "d.stl")
    (tmp_path / "pts.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(MeshReadError, match="no triangles"):
        read_mesh(tmp_path / "pts.obj")


@pytest.mark.parametrize("ext", [".ply", ".stl", ".obj", ".off", ".vtp"])
def test_atomic_write_keeps_old_file(tmp_path, ext, monkeypatch):
    p = tmp_path / f"m{ext}"
    write_mesh(p, CUBE_V, CUBE_F)
    before = p.read_bytes()
    writer = {".ply": "_write_ply", ".stl": "_write_stl", ".obj": "_write_obj",
              ".off": "_write_off", ".vtp": "write_vtp"}[ext]

    def broken(fh, *args):
        fh.write(b"half a mesh")
        raise OSError("disk full")

    monkeypatch.setattr(meshfile_mod, writer, broken)
    with pytest.raises(MeshWriteError, match="disk full.*unchanged"):
        write_mesh(p, CUBE_V * 2, CUBE_F)
    assert p.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == [p.name]
    monkeypatch.undo()
    V, F = read_mesh(p)
    assert same_triangles(V, F, CUBE_V, CUBE_F)


def test_write_errors_leave_nothing(tmp_path):
    p = tmp_path / "m.ply"
    with pytest.raises(MeshWriteError, match=r"shape \(8, 3\) or \(8, 4\)"):
        write_mesh(p, CUBE_V, CUBE_F, vertex_colors=np.zeros((7, 3)))
    with pytest.raises(MeshWriteError, match=r"\[0, 1\]"):
        write_mesh(p, CUBE_V, CUBE_F, vertex_colors=np.full((8, 3), 2.0))
    with pytest.raises(MeshWriteError, match=r"shape \(8,\)"):
        write_mesh(p, CUBE_V, CUBE_F, vertex_scalars={"s": np.zeros(9)})
    with pytest.raises(MeshWriteError, match="plain identifier"):
        write_mesh(p, CUBE_V, CUBE_F, vertex_scalars={"two words": np.zeros(8)})
    with pytest.raises(MeshWriteError, match="STL cannot store vertex scalars"):
        write_mesh(tmp_path / "m.stl", CUBE_V, CUBE_F, vertex_scalars=np.zeros(8))
    with pytest.raises(MeshWriteError, match="unknown output extension"):
        write_mesh(tmp_path / "m.xyz", CUBE_V, CUBE_F)
    with pytest.raises(MeshWriteError, match="does not exist"):
        write_mesh(tmp_path / "no" / "m.ply", CUBE_V, CUBE_F)
    with pytest.raises(InvalidMeshError):
        write_mesh(p, CUBE_V, CUBE_F + 8)
    assert os.listdir(tmp_path) == []


def test_struct_header_of_binary_stl_is_count(tmp_path):
    write_mesh(tmp_path / "c.stl", CUBE_V, CUBE_F)
    assert struct.unpack("<I", (tmp_path / "c.stl").read_bytes()[80:84])[0] == 12


def test_atomic_write_leaves_the_umask_alone(tmp_path, monkeypatch):
    """Writes never change the process umask (other threads would see it); new files get 0o666 & ~umask."""
    calls = []
    real = os.umask
    monkeypatch.setattr(os, "umask", lambda m: calls.append(m) or real(m))
    write_mesh(tmp_path / "a.ply", CUBE_V, CUBE_F)
    assert calls == []
    monkeypatch.undo()
    mask = os.umask(0o022)
    try:
        write_mesh(tmp_path / "b.ply", CUBE_V, CUBE_F)
        assert os.stat(tmp_path / "b.ply").st_mode & 0o777 == 0o644
        os.chmod(tmp_path / "b.ply", 0o600)
        write_mesh(tmp_path / "b.ply", CUBE_V * 2, CUBE_F)  # a replaced file keeps its mode
        assert os.stat(tmp_path / "b.ply").st_mode & 0o777 == 0o600
    finally:
        os.umask(mask)


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
