"""Reading and writing triangle mesh files.

:func:`read_mesh` returns ``(V, F)`` for STL (ASCII and binary), PLY (ASCII
and binary), OBJ, OFF, VTK XML PolyData (``.vtp``), legacy VTK (``.vtk``:
polydata and unstructured grids, ASCII and binary) and VTK XML unstructured grids
(``.vtu``); polygons are triangulated and the per-face corners of STL are merged
into shared vertices.
:func:`write_mesh` writes the same formats atomically (a temporary file in the
target folder, then :func:`os.replace`), optionally with per-vertex colours and
scalars (PLY and VTP; colours also in OBJ and OFF).

Backends, chosen after checking each on polygons and on NaN coordinates:

* STL, OBJ, OFF: :func:`igl.read_triangle_mesh` (fan-triangulates polygons
  correctly and keeps NaN coordinates so they can be reported; pymeshlab's
  OFF reader mis-triangulates pentagons and silently drops NaN vertices).
* PLY: pymeshlab (igl aborts the process on PLY files mixing polygon sizes);
  the vertex count declared in the header is checked against what pymeshlab
  kept, because it silently drops vertices with NaN coordinates.
* VTP: a small parser here (xml.etree, base64, zlib): ascii, inline binary
  and appended (base64 or raw) DataArrays, UInt32/UInt64 headers, optional
  ``vtkZLibDataCompressor``.
* VTU and legacy VTK unstructured grids: meshio (a dependency); legacy VTK
  POLYDATA, which meshio does not read: VTK's own ``vtkPolyDataReader`` (the
  ``vtk`` package, in the ``formats`` extra; a clear error without it). Which
  of the two is told by the file's ``DATASET`` line. Cells are turned into
  triangles by :mod:`vesselgp._interop`: quads and polygons fanned,
  strips unrolled, vertex and line cells left out (logged), volume cells
  refused. Exactly equal points are kept apart, as OBJ, PLY and VTP keep them.

Writers are plain numpy so that float64 coordinates round-trip exactly.
"""
from __future__ import annotations

import logging
import os
import re
import threading
import time
from pathlib import Path

import numpy as np

from .._interop import meshio_triangles, vtk_polydata_arrays
from .._validate import as_mesh
from ..errors import DependencyError, InvalidMeshError, MeshReadError, MeshWriteError, VesselError
from .atomic import atomic_write
from .vtp import FLOAT_FMT, read_vtp, write_vtp

__all__ = ["read_mesh", "write_mesh", "READ_FORMATS", "WRITE_FORMATS"]

log = logging.getLogger(__name__)

#: File extensions understood by :func:`read_mesh`.
READ_FORMATS = (".stl", ".ply", ".obj", ".off", ".vtp", ".vtk", ".vtu")
#: File extensions written by :func:`write_mesh`.
WRITE_FORMATS = (".ply", ".obj", ".off", ".stl", ".vtp")


# --------------------------------------------------------------------------- #
# reading
# --------------------------------------------------------------------------- #
def read_mesh(path):
    """Read a triangle mesh from STL, PLY, OBJ, OFF, VTP, legacy VTK or VTU.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its extension (case-insensitive) selects the format.

    Returns
    -------
    V : (n, 3) float64
        Vertex positions. For STL, exactly equal corner positions are merged
        into one vertex (first-occurrence order is kept).
    F : (m, 3) int64
        Triangles; quads and polygons are fan-triangulated (a quad ``(a, b, c, d)``
        gives ``(a, b, c), (a, c, d)``), VTK triangle strips unrolled. Line and
        vertex cells of VTK files are left out (logged).

    Raises
    ------
    MeshReadError
        Missing or empty file, unknown extension, unreadable content, a
        file without triangles, or a VTK volume mesh (tetrahedra, hexahedra:
        the message says to extract its surface) or image.
    InvalidMeshError
        NaN or infinite coordinates, or face indices out of range.
    DependencyError
        A legacy VTK POLYDATA file without the ``vtk`` package installed.

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> p = os.path.join(d, "quad.obj")
    >>> _ = open(p, "w").write("v 0 0 0\\nv 1 0 0\\nv 1 1 0\\nv 0 1 0\\nf 1 2 3 4\\n")
    >>> V, F = read_mesh(p)
    >>> V.shape, F.tolist()
    ((4, 3), [[0, 1, 2], [0, 2, 3]])
    """
    p = Path(os.fspath(path))
    if not p.exists():
        raise MeshReadError(f"{p}: no such file; check the path")
    if not p.is_file():
        raise MeshReadError(f"{p}: is not a regular file; pass the path of a mesh file")
    ext = p.suffix.lower()
    if ext not in READ_FORMATS:
        raise MeshReadError(
            f"{p}: unknown mesh extension {ext!r}; vesselgp reads "
            f"{', '.join(READ_FORMATS)} (convert the file to one of these)"
        )
    if p.stat().st_size == 0:
        raise MeshReadError(f"{p}: file is empty; re-export the mesh")
    t0 = time.perf_counter()
    reader = {".stl": _read_stl, ".ply": _read_ply, ".obj": _read_igl,
              ".off": _read_igl, ".vtp": _read_vtp_mesh, ".vtk": _read_vtk, ".vtu": _read_vtu}[ext]
    V, F = reader(p)
    V = np.asarray(V)
    F = np.asarray(F)
    if V.size == 0 or F.size == 0 or F.ndim != 2:
        raise MeshReadError(
            f"{p}: no triangles could be read (the file is not a valid {ext[1:].upper()} "
            "surface mesh); check or re-export it"
        )
    try:
        V, F = as_mesh(V, F)
    except InvalidMeshError as exc:
        raise InvalidMeshError(f"{p}: {exc}") from None
    log.info("read %s: %d vertices, %d faces in %.3f s", p, len(V), len(F),
             time.perf_counter() - t0)
    return V, F


def _unreadable(p, exc):
    msg = str(exc).strip().splitlines()
    detail = f" ({msg[0]})" if msg else ""
    return MeshReadError(
        f"{p}: unreadable {p.suffix[1:].upper()} content{detail}; check that the file "
        "is a complete mesh of that format"
    )


def _read_igl(p):
    import igl

    try:
        V, F = igl.read_triangle_mesh(str(p))
    except (RuntimeError, ValueError) as exc:
        raise _unreadable(p, exc) from None
    return V, F


def _merge_exact(V, F):
    """Merge exactly equal vertex positions, keeping first-occurrence order."""
    V = V + 0.0  # turn -0.0 into 0.0 so that it merges with 0.0
    _, first, inv = np.unique(V, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return V[first[order]], rank[inv.reshape(-1)][F]


def _read_stl(p):
    V, F = _read_igl(p)
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if V.size == 0 or F.size == 0:
        return V, F
    if not np.all(np.isfinite(V)):
        bad = int(np.count_nonzero(~np.isfinite(V).all(axis=1)))
        raise InvalidMeshError(
            f"{p}: {bad} triangle corners have NaN or infinite coordinates; repair the file"
        )
    return _merge_exact(V, F)


def _ply_header_count(p, element):
    """Count declared for ``element`` in a PLY header, or None."""
    with open(p, "rb") as fh:
        head = fh.read(65536)
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0:
        raise MeshReadError(f"{p}: not a PLY file (no 'ply ... end_header' header); re-export it")
    m = re.search(rb"^element\s+" + element.encode() + rb"\s+(\d+)", head[:end], re.M)
    return int(m.group(1)) if m else None


def _read_ply(p):
    import pymeshlab

    declared = _ply_header_count(p, "vertex")
    ms = pymeshlab.MeshSet()
    try:
        ms.load_new_mesh(str(p))
    except pymeshlab.PyMeshLabException as exc:
        raise _unreadable(p, exc) from None
    m = ms.current_mesh()
    V = m.vertex_matrix()
    if declared is not None and m.vertex_number() < declared:
        raise InvalidMeshError(
            f"{p}: the header declares {declared} vertices but only {m.vertex_number()} "
            "have finite coordinates; remove or repair the NaN/infinite vertices"
        )
    faces = _ply_header_count(p, "face")
    if faces is not None and m.face_number() < faces:  # pymeshlab drops faces with a repeated corner:
        return _read_meshio(p, "ply")  # read every face, so that a repair reports and removes them
    return V, m.face_matrix()


def _read_vtp_mesh(p):
    V, F, _ = read_vtp(p)
    return V, F


def _read_vtu(p):
    return _read_meshio(p, "vtu")


def _read_vtk(p):
    """A legacy VTK file: meshio for unstructured grids, VTK's reader for polydata."""
    dataset = _vtk_dataset(p)
    if dataset == "UNSTRUCTURED_GRID":
        return _read_meshio(p, "vtk")
    if dataset == "POLYDATA":
        return _read_vtk_polydata(p)
    if dataset is None:
        raise MeshReadError(f"{p}: no DATASET line in the legacy VTK header; check that the file is a "
                            "complete mesh (POLYDATA or UNSTRUCTURED_GRID)")
    raise MeshReadError(f"{p}: a legacy VTK {dataset} is an image or grid, not a surface mesh; extract the "
                        "vessel's surface first (ParaView's Contour, skimage.measure.marching_cubes) and save "
                        "it as .vtk, .vtp or .stl")


def _vtk_dataset(p):
    """The dataset type of a legacy VTK file (``POLYDATA``, ...) from its header, or None."""
    with open(p, "rb") as fh:
        lines = fh.read(4096).split(b"\n")
    if not lines[0].lstrip().startswith(b"# vtk DataFile"):
        raise MeshReadError(f"{p}: not a legacy VTK file (no '# vtk DataFile Version' first line); a VTK XML "
                            "file is read as .vtp (PolyData) or .vtu (UnstructuredGrid): rename it")
    for line in lines[3:16]:  # after the version, the title and ASCII/BINARY
        words = line.split()
        if words and words[0].upper() == b"DATASET":
            return words[1].upper().decode("ascii", "replace") if len(words) > 1 else None
    return None


def _read_meshio(p, fmt):
    import meshio

    # the format's own reader: meshio.read(path) prints a failure and calls sys.exit(1)
    reader = {"vtu": meshio.vtu.read, "vtk": meshio.vtk.read, "ply": meshio.ply.read}[fmt]
    try:
        mesh = reader(str(p))
    except VesselError:
        raise
    except Exception as exc:  # noqa: BLE001 - meshio's ReadError and what its parsers raise on a broken file
        raise _unreadable(p, exc) from None
    blocks = [(c.type, c.data) for c in mesh.cells]
    return np.asarray(mesh.points, np.float64), meshio_triangles(blocks, str(p), MeshReadError)


_VTK_LOCK = threading.Lock()


def _read_vtk_polydata(p):
    try:
        from vtkmodules.vtkIOLegacy import vtkPolyDataReader
    except ImportError:
        raise DependencyError(
            f"{p}: a legacy VTK POLYDATA file needs the vtk package, which is not installed: pip install vtk "
            "(or pip install \"vesselgp[formats]\"), or save the mesh as .vtp, .ply or .stl"
        ) from None
    reader = vtkPolyDataReader()
    reader.SetFileName(str(p))
    errors = _vtk_run(reader)
    if errors:
        raise MeshReadError(f"{p}: unreadable VTK content ({errors[0]}); check that the file is a complete "
                            "mesh of that format")
    return vtk_polydata_arrays(reader.GetOutput(), str(p), MeshReadError)


def _vtk_run(reader):
    """Update a VTK reader; its error messages (warnings are logged), none printed by VTK's output window."""
    from vtkmodules.util.misc import calldata_type
    from vtkmodules.vtkCommonCore import VTK_STRING, vtkCommand, vtkOutputWindow, vtkStringOutputWindow

    texts = []

    @calldata_type(VTK_STRING)
    def heard(obj, event, text):
        texts.append(text)

    reader.AddObserver(vtkCommand.ErrorEvent, heard)
    reader.AddObserver(vtkCommand.WarningEvent, heard)
    with _VTK_LOCK:  # VTK's generic warnings (not the reader's) go to its one output window
        previous = vtkOutputWindow.GetInstance()
        window = vtkStringOutputWindow()
        vtkOutputWindow.SetInstance(window)
        try:
            reader.Update()
        finally:
            vtkOutputWindow.SetInstance(previous)
    texts.append(window.GetOutput())
    errors = []
    for text in texts:
        lines = [ln.strip() for ln in str(text or "").splitlines() if ln.strip()]
        if not lines:
            continue
        message = re.sub(r"^vtk\w+ \(0x[0-9a-fA-F]+\): ", "", lines[-1])
        if "error" in text.lower():
            errors.append(message)
        else:
            log.warning("VTK: %s", message)
    return errors


# --------------------------------------------------------------------------- #
# writing
# --------------------------------------------------------------------------- #
def write_mesh(path, V, F, vertex_colors=None, vertex_scalars=None):
    """Write a triangle mesh atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; the extension picks the format: ``.ply`` (binary little
        endian), ``.obj``, ``.off``, ``.stl`` (binary) or ``.vtp`` (XML, inline binary arrays).
    V : (n, 3) float64
        Vertex positions.
    F : (m, 3) int64
        Triangles.
    vertex_colors : (n, 3) or (n, 4) float64 in [0, 1] or uint8, optional
        Per-vertex RGB(A). Stored by PLY (uchar red/green/blue/alpha), VTP
        (UInt8 point array "Colors"), OBJ (``v x y z r g b``) and OFF (COFF).
    vertex_scalars : (n,) float64 or dict of str to (n,) float64, optional
        Per-vertex scalars; a bare array is named ``"quality"``. Stored by PLY
        (double vertex properties) and VTP (Float64 point arrays).

    Raises
    ------
    MeshWriteError
        Unknown extension, attributes of the wrong shape or not storable in the
        format, or any I/O failure. Nothing is left behind and an existing
        file at ``path`` is untouched.
    InvalidMeshError
        Malformed ``V`` or ``F``.

    Examples
    --------
    >>> import tempfile, os
    >>> p = os.path.join(tempfile.mkdtemp(), "tri.ply")
    >>> V = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    >>> write_mesh(p, V, [[0, 1, 2]], vertex_scalars={"s": [1.0, 2.0, 3.0]})
    >>> V2, F2 = read_mesh(p)
    >>> bool(np.array_equal(V2, V)), F2.tolist()
    (True, [[0, 1, 2]])
    """
    p = Path(os.fspath(path))
    ext = p.suffix.lower()
    if ext not in WRITE_FORMATS:
        raise MeshWriteError(
            f"{p}: unknown output extension {ext!r}; use one of {', '.join(WRITE_FORMATS)}"
        )
    V, F = as_mesh(V, F)
    colors = _as_colors(vertex_colors, len(V), p)
    reserved = {".ply": ("x", "y", "z") + (("red", "green", "blue", "alpha") if colors is not None else ()),
                ".vtp": ("Colors",) if colors is not None else ()}.get(ext, ())
    scalars = _as_scalars(vertex_scalars, len(V), p, reserved)
    if scalars and ext not in (".ply", ".vtp"):
        raise MeshWriteError(
            f"{p}: {ext[1:].upper()} cannot store vertex scalars; write .ply or .vtp instead"
        )
    if colors is not None and ext == ".stl":
        raise MeshWriteError(f"{p}: STL cannot store vertex colours; write .ply, .vtp, .obj or .off")
    writer = {".ply": _write_ply, ".obj": _write_obj, ".off": _write_off,
              ".stl": _write_stl, ".vtp": write_vtp}[ext]
    atomic_write(p, lambda fh: writer(fh, V, F, colors, scalars), binary=True)
    log.info("wrote %s: %d vertices, %d faces", p, len(V), len(F))


def _as_colors(C, n, p):
    if C is None:
        return None
    A = np.asarray(C)
    if A.ndim != 2 or A.shape[0] != n or A.shape[1] not in (3, 4):
        raise MeshWriteError(
            f"{p}: vertex_colors must have shape ({n}, 3) or ({n}, 4), got {A.shape}"
        )
    if A.dtype == np.uint8:
        return A
    if np.issubdtype(A.dtype, np.floating):
        if not np.all(np.isfinite(A)) or A.min() < 0 or A.max() > 1:
            raise MeshWriteError(
                f"{p}: float vertex_colors must lie in [0, 1]; scale them or pass uint8"
            )
        return np.round(A * 255).astype(np.uint8)
    if np.issubdtype(A.dtype, np.integer) and A.size and (A.min() < 0 or A.max() > 255):
        raise MeshWriteError(f"{p}: integer vertex_colors must lie in [0, 255]")
    if np.issubdtype(A.dtype, np.integer):
        return A.astype(np.uint8)
    raise MeshWriteError(f"{p}: vertex_colors must be float in [0, 1] or uint8, got {A.dtype}")


def _as_scalars(S, n, p, reserved):
    if S is None:
        return {}
    items = S.items() if isinstance(S, dict) else [("quality", S)]
    out = {}
    for name, a in items:
        if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
            raise MeshWriteError(
                f"{p}: scalar name {name!r} is not a plain identifier; use letters, digits, '_'"
            )
        if name in reserved:
            raise MeshWriteError(
                f"{p}: scalar name {name!r} clashes with a coordinate or colour field; rename it"
            )
        try:
            arr = np.asarray(a, dtype=np.float64)
        except (TypeError, ValueError):
            raise MeshWriteError(f"{p}: vertex scalars {name!r} must be numeric") from None
        if arr.shape != (n,):
            raise MeshWriteError(
                f"{p}: vertex scalars {name!r} must have shape ({n},), got {arr.shape}"
            )
        out[name] = arr
    return out


def _write_ply(fh, V, F, colors, scalars):
    fields = [("x", "<f8"), ("y", "<f8"), ("z", "<f8")]
    props = ["property double x", "property double y", "property double z"]
    if colors is not None:
        for c in ("red", "green", "blue", "alpha")[:colors.shape[1]]:
            fields.append((c, "u1"))
            props.append(f"property uchar {c}")
    for name in scalars:
        fields.append((name, "<f8"))
        props.append(f"property double {name}")
    vd = np.empty(len(V), dtype=fields)
    vd["x"], vd["y"], vd["z"] = V.T
    if colors is not None:
        for k, c in enumerate(("red", "green", "blue", "alpha")[:colors.shape[1]]):
            vd[c] = colors[:, k]
    for name, a in scalars.items():
        vd[name] = a
    fd = np.empty(len(F), dtype=[("n", "u1"), ("v", "<i4", (3,))])
    fd["n"] = 3
    fd["v"] = F
    header = "\n".join(
        ["ply", "format binary_little_endian 1.0", "comment written by vesselgp",
         f"element vertex {len(V)}", *props,
         f"element face {len(F)}", "property list uchar int vertex_indices", "end_header"]
    ) + "\n"
    fh.write(header.encode("ascii"))
    fh.write(vd.tobytes())
    fh.write(fd.tobytes())


def _write_obj(fh, V, F, colors, scalars):
    fh.write(b"# written by vesselgp\n")
    if colors is not None:
        np.savetxt(fh, np.c_[V, colors[:, :3] / 255.0], fmt="v " + " ".join([FLOAT_FMT] * 6))
    else:
        np.savetxt(fh, V, fmt="v " + " ".join([FLOAT_FMT] * 3))
    np.savetxt(fh, F + 1, fmt="f %d %d %d")


def _write_off(fh, V, F, colors, scalars):
    if colors is not None:
        fh.write(f"COFF\n{len(V)} {len(F)} 0\n".encode())
        C = colors if colors.shape[1] == 4 else np.c_[colors, np.full(len(V), 255, np.uint8)]
        fmt = " ".join([FLOAT_FMT] * 3 + ["%d"] * 4)
        np.savetxt(fh, np.c_[V.astype(object), C.astype(object)], fmt=fmt)
    else:
        fh.write(f"OFF\n{len(V)} {len(F)} 0\n".encode())
        np.savetxt(fh, V, fmt=FLOAT_FMT)
    np.savetxt(fh, F, fmt="3 %d %d %d")


def _write_stl(fh, V, F, colors, scalars):
    T = V[F]
    N = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    nrm = np.linalg.norm(N, axis=1, keepdims=True)
    N = np.divide(N, nrm, out=np.zeros_like(N), where=nrm > 0)
    rec = np.zeros(len(F), dtype=[("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["n"] = N
    rec["v"] = T
    header = b"binary STL written by vesselgp".ljust(80, b" ")
    fh.write(header)
    fh.write(np.uint32(len(F)).astype("<u4").tobytes())
    fh.write(rec.tobytes())
