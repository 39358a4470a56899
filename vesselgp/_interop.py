"""Meshes of other packages, in and out: trimesh, pyvista (VTK) and meshio.

vesselgp computes on arrays; this module converts what Python users hold their meshes in.

* In (behind :func:`vesselgp.as_mesh`, so every function that takes ``(V, F)``): a
  ``trimesh.Trimesh``, a ``pyvista.PolyData`` (any ``vtkPolyData``), a ``meshio.Mesh`` or a
  :class:`vesselgp.PreparedMesh` gives its vertices and triangles. Quads and polygons are
  fan-triangulated (as :func:`vesselgp.read_mesh` does for OBJ and OFF), triangle strips
  unrolled, line and vertex cells left out (logged), volume cells (tetrahedra, hexahedra, ...)
  refused with :class:`vesselgp.InvalidMeshError`. The types are recognised by the names and
  modules of their classes (and base classes), never by importing trimesh, pyvista, vtk or
  meshio: an object of theirs exists only when the caller has imported them.
* The cell conversions (:func:`meshio_triangles`, :func:`vtk_polydata_arrays`) are shared with
  :func:`vesselgp.read_mesh` for ``.vtk`` and ``.vtu`` files.
* Out: :func:`polylines_to_pyvista` and :func:`mesh_to_pyvista` import pyvista when called, or
  raise :class:`vesselgp.errors.DependencyError` naming the ``pip install``.
"""
from __future__ import annotations

import importlib
import logging
import re

import numpy as np

from .errors import DependencyError, InvalidMeshError

log = logging.getLogger(__name__)

__all__ = ["ACCEPTED", "mesh_kind", "type_name", "object_arrays", "meshio_triangles", "vtk_polydata_arrays",
           "require", "polylines_to_pyvista", "mesh_to_pyvista"]

#: What :func:`vesselgp.as_mesh` takes besides ``(V, F)`` (for messages).
ACCEPTED = "trimesh.Trimesh, pyvista.PolyData, meshio.Mesh or vesselgp.PreparedMesh"

# (top-level module, class name) of a class in the object's MRO -> kind
_KNOWN = {("trimesh", "Trimesh"): "trimesh", ("meshio", "Mesh"): "meshio",
          ("vtkmodules", "vtkPolyData"): "vtk", ("vtk", "vtkPolyData"): "vtk"}
# packages whose other objects are refused with a hint rather than taken for arrays
_FOREIGN = ("trimesh", "pyvista", "meshio", "vtkmodules", "vtk", "vesselgp")

_LINE_CELLS = re.compile(r"empty|vertex|line\d*|VTK_(LAGRANGE|BEZIER)_CURVE")
_VOLUME_CELLS = re.compile(r"(tetra|hexahedron|wedge|pyramid|penta_prism|hexa_prism|polyhedron)\d*"
                           r"|VTK_(LAGRANGE|BEZIER)_(TETRAHEDRON|HEXAHEDRON|WEDGE|PYRAMID)")
_FAN_CELLS = re.compile(r"triangle|quad|polygon\d*")


def mesh_kind(obj):
    """The kind of mesh object ``obj`` is, or None for arrays and everything else.

    Returns
    -------
    str or None
        ``"trimesh"``, ``"meshio"``, ``"vtk"`` (pyvista.PolyData, vtkPolyData), ``"vesselgp"``
        (a vesselgp object holding arrays ``V`` and ``F``: :class:`vesselgp.PreparedMesh`, a
        synthetic vessel), ``"other"`` (another object of those packages, e.g. a
        ``pyvista.UnstructuredGrid`` or a ``trimesh.Scene``: refused with a hint), or None.
    """
    if obj is None or isinstance(obj, (np.ndarray, list, tuple, int, float)):
        return None
    for cls in type(obj).__mro__:
        kind = _KNOWN.get((cls.__module__.partition(".")[0], cls.__name__))
        if kind is not None:
            return kind
    package = type(obj).__module__.partition(".")[0]
    if package == "vesselgp" and isinstance(getattr(obj, "V", None), np.ndarray) \
            and isinstance(getattr(obj, "F", None), np.ndarray):
        return "vesselgp"
    return "other" if package in _FOREIGN else None


def type_name(obj):
    """``package.Class`` of ``obj`` for messages (``pyvista.PolyData``, ``trimesh.Trimesh``)."""
    return f"{type(obj).__module__.partition('.')[0]}.{type(obj).__name__}"


def object_arrays(obj, kind=None):
    """Vertices and triangles of a mesh object (not validated yet: :func:`vesselgp.as_mesh` does that).

    Raises
    ------
    InvalidMeshError
        An object of those packages that is not a surface mesh (the message says how to get one),
        a volume mesh, or a mesh without faces.
    """
    kind = mesh_kind(obj) if kind is None else kind
    name = type_name(obj)
    if kind == "vesselgp":
        return obj.V, obj.F
    if kind == "trimesh":
        return np.asarray(obj.vertices, np.float64), np.asarray(obj.faces, np.int64).reshape(-1, 3)
    if kind == "meshio":
        F = meshio_triangles([(c.type, c.data) for c in obj.cells], name, InvalidMeshError)
        return np.asarray(obj.points, np.float64), F
    if kind == "vtk":
        return vtk_polydata_arrays(obj, name, InvalidMeshError)
    if hasattr(obj, "extract_surface"):
        hint = ": take its surface first, mesh.extract_surface()"
    elif hasattr(obj, "to_mesh") or hasattr(obj, "dump"):
        hint = ": make it one mesh first, scene.to_mesh()"
    else:
        hint = ""
    raise InvalidMeshError(f"{name} is not a surface mesh vesselgp takes; give a {ACCEPTED}, "
                           f"or the arrays V and F{hint}")


# ----------------------------------------------------------------------------- cells to triangles


def _fan_fixed(C):
    """Fan triangles of (n, k) cells of k corners each: (c0, cj, cj+1), each cell's triangles together."""
    C = np.asarray(C, np.int64)
    n, k = C.shape
    j = np.arange(1, k - 1)
    T = np.stack([np.broadcast_to(C[:, :1], (n, k - 2)), C[:, j], C[:, j + 1]], axis=-1)
    return T.reshape(-1, 3)


def _ragged(offsets, ntri):
    """Per triangle: its cell, its index within the cell, and the cell's first connectivity slot."""
    cell = np.repeat(np.arange(len(ntri)), ntri)
    t = np.arange(int(ntri.sum())) - (np.cumsum(ntri) - ntri)[cell]
    return cell, t, offsets[:-1][cell]


def fan_triangles(offsets, conn):
    """Fan triangles of ragged cells (VTK offsets, length cells + 1, and connectivity).

    Returns
    -------
    F : (t, 3) int64
    degenerate : int
        Cells of fewer than three corners (left out).
    """
    sizes = np.diff(offsets)
    ntri = np.maximum(sizes - 2, 0)
    _, t, base = _ragged(offsets, ntri)
    return np.c_[conn[base], conn[base + t + 1], conn[base + t + 2]], int(np.count_nonzero(sizes < 3))


def strip_triangles(offsets, conn):
    """Triangles of VTK triangle strips, every other one flipped so that they keep one orientation."""
    ntri = np.maximum(np.diff(offsets) - 2, 0)
    _, t, base = _ragged(offsets, ntri)
    a, b, c = conn[base + t], conn[base + t + 1], conn[base + t + 2]
    odd = t % 2 == 1
    return np.c_[np.where(odd, b, a), np.where(odd, a, b), c]


def _counts(items):
    """``cells: 1200 tetra, 40 triangle``."""
    return "cells: " + ", ".join(f"{n} {name}" for name, n in items)


def _finish(tris, volume, other, ignored, source, error):
    """The triangles, or the error that says why a source has none vesselgp can use."""
    if volume:
        raise error(f"{source}: is a volume mesh ({_counts(volume)}); vesselgp needs the vessel's "
                    "surface: extract it first (pyvista's mesh.extract_surface(), ParaView's Extract Surface)")
    if other:
        raise error(f"{source}: has higher-order faces ({_counts(other)}), which vesselgp does not "
                    "triangulate; convert them to linear triangles first (ParaView's Tessellate filter)")
    F = np.concatenate(tris) if tris else np.zeros((0, 3), np.int64)
    if len(F) == 0:
        only = f" (only {_counts(ignored)})" if ignored else ""
        raise error(f"{source}: has no triangles, quads or polygons{only}; give a surface mesh")
    if ignored:
        log.info("%s: left out %s (vesselgp reads faces only)", source, _counts(ignored))
    return np.ascontiguousarray(F, dtype=np.int64)


def meshio_triangles(blocks, source, error=InvalidMeshError):
    """Triangles of meshio cell blocks: triangles, quads and polygons; lines and vertices left out.

    Parameters
    ----------
    blocks : iterable of (str, (n, k) int)
        ``(cell type, connectivity)`` per block, as ``meshio.Mesh.cells`` holds them.
    source : str
        The file or object, for messages.
    error : type
        The error raised (:class:`vesselgp.MeshReadError` for files).

    Returns
    -------
    F : (m, 3) int64
        Each cell's triangles together, in cell order; a quad ``(a, b, c, d)`` gives
        ``(a, b, c), (a, c, d)``.

    Raises
    ------
    error
        Volume cells (tetrahedra, hexahedra, ...), higher-order faces, or no faces at all.
    """
    tris, volume, other, ignored = [], [], [], []
    for ctype, data in blocks:
        n = len(data)
        if n == 0:
            continue
        if _FAN_CELLS.fullmatch(ctype):
            sizes = {len(c) for c in data}
            if len(sizes) > 1:  # polygons of several sizes in one block
                offsets = np.r_[0, np.cumsum([len(c) for c in data])]
                F, degenerate = fan_triangles(offsets, np.concatenate([np.asarray(c, np.int64) for c in data]))
                tris.append(F)
                if degenerate:
                    ignored.append((f"{ctype} of fewer than 3 corners", degenerate))
            elif min(sizes) < 3:
                ignored.append((f"{ctype} of fewer than 3 corners", n))
            else:
                tris.append(_fan_fixed(np.asarray(data, np.int64)))
        elif _LINE_CELLS.fullmatch(ctype):
            ignored.append((ctype, n))
        elif _VOLUME_CELLS.fullmatch(ctype):
            volume.append((ctype, n))
        else:
            other.append((ctype, n))
    return _finish(tris, volume, other, ignored, source, error)


def _numpy_ids(arr):
    """A VTK id or offset array as int64 numpy (a copy)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    try:
        return np.array(vtk_to_numpy(arr), dtype=np.int64)
    except (TypeError, ValueError, AttributeError):  # an implicit array older numpy_support cannot view
        from vtkmodules.vtkCommonCore import vtkIdTypeArray

        tmp = vtkIdTypeArray()
        tmp.DeepCopy(arr)
        return np.array(vtk_to_numpy(tmp), dtype=np.int64)


def _cells(ca):
    """(offsets, connectivity) int64 of a vtkCellArray (VTK 9 layout)."""
    if ca is None or ca.GetNumberOfCells() == 0:
        return None
    return _numpy_ids(ca.GetOffsetsArray()), _numpy_ids(ca.GetConnectivityArray())


def vtk_polydata_arrays(pd, source, error=InvalidMeshError):
    """Vertices and triangles of a ``vtkPolyData`` (a ``pyvista.PolyData``, or read from a ``.vtk`` file).

    Polygons (and quads) are fan-triangulated, triangle strips unrolled, vertex and line cells
    left out (logged). Faces come in VTK's cell order: polygons, then strips.

    Returns
    -------
    V : (n, 3) float64
    F : (m, 3) int64

    Raises
    ------
    error
        No points, or no faces.
    """
    from vtkmodules.util.numpy_support import vtk_to_numpy

    pts = pd.GetPoints()
    if pts is None or pd.GetNumberOfPoints() == 0:
        raise error(f"{source}: has no points; give a surface mesh")
    V = np.array(vtk_to_numpy(pts.GetData()), dtype=np.float64)
    tris, ignored = [], []
    polys = _cells(pd.GetPolys())
    if polys is not None:
        F, degenerate = fan_triangles(*polys)
        tris.append(F)
        if degenerate:
            ignored.append(("polygons of fewer than 3 corners", degenerate))
    strips = _cells(pd.GetStrips())
    if strips is not None:
        tris.append(strip_triangles(*strips))
    for what, ca in (("vertex", pd.GetVerts()), ("line", pd.GetLines())):
        if ca is not None and ca.GetNumberOfCells():
            ignored.append((what, int(ca.GetNumberOfCells())))
    return V, _finish(tris, [], [], ignored, source, error)


# ----------------------------------------------------------------------------- out: pyvista


def require(module, what):
    """Import an optional package, or raise :class:`DependencyError` naming its ``pip install``."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise DependencyError(f"{what} needs {module}, which is not installed: pip install {module} "
                              "(or pip install \"vesselgp[formats]\")") from None


def _add_arrays(target, arrays, n, where):
    for name, a in (arrays or {}).items():
        a = np.asarray(a)
        if a.shape[:1] != (n,):
            raise InvalidMeshError(f"{where} {name!r} must have {n} rows (one per "
                                   f"{'point' if where == 'point data' else 'cell'}), got shape {a.shape}")
        target[name] = a


def polylines_to_pyvista(lines, point_data=None, cell_data=None, what="to_pyvista()"):
    """A ``pyvista.PolyData`` of polylines: one line cell per entry of ``lines``.

    Parameters
    ----------
    lines : sequence of (k_i, 3) float64
    point_data : dict of str to (sum k_i, ...) arrays, optional
    cell_data : dict of str to (len(lines), ...) arrays, optional

    Raises
    ------
    DependencyError
        pyvista is not installed.
    """
    pv = require("pyvista", what)
    sizes = [len(P) for P in lines]
    ids = np.arange(sum(sizes))
    starts = np.cumsum([0] + sizes[:-1])
    cells = np.concatenate([np.r_[k, ids[s:s + k]] for s, k in zip(starts, sizes)]).astype(np.int64)
    poly = pv.PolyData(np.concatenate([np.asarray(P, np.float64) for P in lines]), lines=cells)
    _add_arrays(poly.point_data, point_data, poly.n_points, "point data")
    _add_arrays(poly.cell_data, cell_data, len(sizes), "cell data")
    return poly


def mesh_to_pyvista(V, F, point_data=None, what="to_pyvista()"):
    """A triangle ``pyvista.PolyData`` of validated ``V``, ``F``, with optional point arrays."""
    pv = require("pyvista", what)
    faces = np.c_[np.full(len(F), 3, np.int64), F].ravel()
    poly = pv.PolyData(np.array(V, np.float64), faces)
    _add_arrays(poly.point_data, point_data, len(V), "point data")
    return poly
