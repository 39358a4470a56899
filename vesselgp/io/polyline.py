"""Polylines (medial axes, axis networks) for ParaView (``.vtp`` with ``<Lines>``) and MeshLab (``.ply`` edges)."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .._validate import as_points
from ..errors import MeshWriteError
from .atomic import atomic_write

__all__ = ["write_polyline", "write_polylines", "write_centerlines"]


def write_polyline(path, P, point_data=None):
    """Write a polyline (e.g. a medial axis) that ParaView and MeshLab open, atomically.

    ``.vtp``: VTK XML PolyData with one ``<Lines>`` cell and point arrays
    (scalars or 3-vectors). ``.ply``: ASCII PLY with ``vertex`` and ``edge``
    elements (MeshLab shows the edges); scalar point data become vertex properties.

    Parameters
    ----------
    path : str or os.PathLike
        ``.vtp`` or ``.ply``.
    P : (k, 3) float64
        Points in order.
    point_data : dict of str to (k,) or (k, 3) float64, optional
        Named per-point arrays (3-vectors are stored in VTP only).

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> P = np.c_[np.zeros(3), np.zeros(3), np.arange(3.0)]
    >>> write_polyline(os.path.join(d, "axis.ply"), P, {"radius": np.ones(3)})
    >>> open(os.path.join(d, "axis.ply")).read().count("element")
    2
    """
    write_polylines(path, [P], point_data)


def _checked(lines, point_data, cell_data):
    """Validated points, per-line sizes, point arrays (concatenated) and cell arrays."""
    lines = [as_points(P, f"line {i}", min_rows=2) for i, P in enumerate(lines)]
    if not lines:
        raise MeshWriteError("no polylines to write")
    sizes = [len(P) for P in lines]
    k = sum(sizes)
    pdata, cdata = {}, {}
    for name, a in (point_data or {}).items():
        a = np.asarray(a, float)
        if a.shape not in ((k,), (k, 3)):
            raise MeshWriteError(f"point data {name!r} must have shape ({k},) or ({k}, 3), got {a.shape}")
        pdata[name] = a
    for name, a in (cell_data or {}).items():
        a = np.asarray(a)
        if a.shape != (len(lines),):
            raise MeshWriteError(f"cell data {name!r} must have one value per line ({len(lines)}), got {a.shape}")
        cdata[name] = a
    return np.vstack(lines), sizes, pdata, cdata


def _vtp_arrays(fh, tag, data, n):
    if not data:
        return
    first = next((nm for nm, a in data.items() if a.ndim == 1), None)
    fh.write(f"      <{tag}" + (f' Scalars="{first}"' if first else "") + ">\n")
    for name, a in data.items():
        nc = 1 if a.ndim == 1 else 3
        integer = a.dtype.kind in "iub"
        vtype = ("Int32" if a.dtype.itemsize <= 4 else "Int64") if integer else "Float64"
        fh.write(f'        <DataArray type="{vtype}" Name="{name}" '
                 f'NumberOfComponents="{nc}" format="ascii">\n')
        np.savetxt(fh, a.reshape(n, nc), fmt="%d" if integer else "%.10g")
        fh.write("        </DataArray>\n")
    fh.write(f"      </{tag}>\n")


def write_polylines(path, lines, point_data=None, cell_data=None):
    """Write several polylines (e.g. the branches of an axis network) in one file, atomically.

    ``.vtp``: VTK XML PolyData with one ``<Lines>`` cell per polyline, point
    arrays and cell arrays (one value per line; integers stay integers).
    ``.ply``: ASCII PLY with ``vertex`` and ``edge`` elements; scalar point
    data become vertex properties and each cell array an edge property.

    Parameters
    ----------
    path : str or os.PathLike
        ``.vtp`` or ``.ply``.
    lines : sequence of (k_i, 3) float64
        The polylines' points in order.
    point_data : dict of str to (sum k_i,) or (sum k_i, 3) float64, optional
        Per-point arrays over the lines' points, concatenated in line order.
    cell_data : dict of str to (len(lines),) array, optional
        Per-line values (e.g. a branch id and its parent's).

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> L = [np.c_[np.zeros(3), np.zeros(3), np.arange(3.0)], np.c_[np.arange(2.0), np.zeros(2), np.zeros(2)]]
    >>> write_polylines(os.path.join(d, "tree.vtp"), L, cell_data={"BranchId": np.array([0, 1])})
    >>> 'NumberOfLines="2"' in open(os.path.join(d, "tree.vtp")).read()
    True
    """
    P, sizes, data, cdata = _checked(lines, point_data, cell_data)
    ends = np.cumsum(sizes)
    _write_lines(path, P, [np.arange(e - k, e) for e, k in zip(ends, sizes)], data, cdata)


def write_centerlines(path, network):
    """Write centre lines (:class:`vesselgp.network.CenterlineNetwork`) as VMTK has them, atomically.

    ``.vtp``: VTK XML PolyData over the network's points, one ``<Lines>`` cell per tract, VMTK's point and
    cell arrays (integer cell arrays as ``Int32``, as VMTK writes them), which VTK, ParaView,
    3D Slicer and VMTK's scripts read. ``.ply``: the same points and each cell's edges, scalar
    point arrays as vertex properties and cell arrays as edge properties (MeshLab).

    Parameters
    ----------
    path : str or os.PathLike
        ``.vtp`` or ``.ply``.
    network : CenterlineNetwork

    Examples
    --------
    >>> import tempfile, os
    >>> from vesselgp.network import CenterlineNetwork
    >>> P = np.c_[np.zeros(5), np.zeros(5), np.arange(5.0)]
    >>> net = CenterlineNetwork(P, (np.arange(3), np.arange(2, 5)), {"Abscissas": P[:, 2]},
    ...                         {"TractIds": np.array([0, 1])})
    >>> d = tempfile.mkdtemp()
    >>> write_centerlines(os.path.join(d, "c.vtp"), net)
    >>> 'NumberOfPoints="5" NumberOfVerts="0" NumberOfLines="2"' in open(os.path.join(d, "c.vtp")).read()
    True
    """
    P = as_points(network.points, "centre-line points", min_rows=2)
    k = len(P)
    cells = [np.asarray(c, np.int64) for c in network.cells]
    if not cells or any(len(c) < 2 or c.min() < 0 or c.max() >= k for c in cells):
        raise MeshWriteError(f"centre lines need cells of at least two of their {k} points")
    pdata = {}
    for name, a in network.point_data.items():
        a = np.asarray(a)
        if a.shape not in ((k,), (k, 3)):
            raise MeshWriteError(f"point data {name!r} must have shape ({k},) or ({k}, 3), got {a.shape}")
        pdata[name] = a if a.dtype.kind in "iub" else a.astype(float)
    cdata = {}
    for name, a in network.cell_data.items():
        a = np.asarray(a)
        if a.shape != (len(cells),):
            raise MeshWriteError(f"cell data {name!r} must have one value per cell ({len(cells)}), got {a.shape}")
        cdata[name] = a.astype(np.int32) if a.dtype.kind in "iub" else a.astype(float)
    _write_lines(path, P, cells, pdata, cdata)


def _write_lines(path, P, cells, data, cdata):
    """Points ``P``, polyline cells (point ids) and their point and cell arrays, as .vtp or .ply."""
    k, sizes = len(P), [len(c) for c in cells]
    ext = Path(os.fspath(path)).suffix.lower()
    if ext == ".vtp":
        def w(fh):
            fh.write('<?xml version="1.0"?>\n<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian">\n'
                     "  <PolyData>\n")
            fh.write(f'    <Piece NumberOfPoints="{k}" NumberOfVerts="0" NumberOfLines="{len(sizes)}" '
                     'NumberOfStrips="0" NumberOfPolys="0">\n')
            _vtp_arrays(fh, "PointData", data, k)
            _vtp_arrays(fh, "CellData", cdata, len(sizes))
            fh.write('      <Points>\n        <DataArray type="Float64" NumberOfComponents="3" format="ascii">\n')
            np.savetxt(fh, P, fmt="%.10g")
            fh.write("        </DataArray>\n      </Points>\n      <Lines>\n")
            fh.write('        <DataArray type="Int64" Name="connectivity" format="ascii">\n')
            fh.write(" ".join(map(str, np.concatenate(cells))) + "\n        </DataArray>\n")
            fh.write('        <DataArray type="Int64" Name="offsets" format="ascii">\n'
                     + " ".join(map(str, np.cumsum(sizes))) + "\n        </DataArray>\n")
            fh.write("      </Lines>\n    </Piece>\n  </PolyData>\n</VTKFile>\n")
    elif ext == ".ply":
        scal = {n: a for n, a in data.items() if a.ndim == 1}
        E = np.vstack([np.c_[c[:-1], c[1:]] for c in cells])
        per_edge = {n: np.repeat(a, np.asarray(sizes) - 1) for n, a in cdata.items()}

        def w(fh):
            fh.write(f"ply\nformat ascii 1.0\ncomment polyline written by vesselgp\nelement vertex {k}\n"
                     "property double x\nproperty double y\nproperty double z\n")
            for n in scal:
                fh.write(f"property double {n}\n")
            fh.write(f"element edge {len(E)}\nproperty int vertex1\nproperty int vertex2\n")
            for n in per_edge:
                fh.write(f"property double {n}\n")
            fh.write("end_header\n")
            np.savetxt(fh, np.column_stack([P, *scal.values()]), fmt="%.10g")
            np.savetxt(fh, np.column_stack([E, *per_edge.values()]), fmt="%.10g")
    else:
        raise MeshWriteError(f"{path}: a polyline is written as .vtp or .ply, not {ext!r}")
    atomic_write(path, w)
