"""Polylines (medial axes) for ParaView (``.vtp`` with ``<Lines>``) and MeshLab (``.ply`` edges)."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .._validate import as_points
from ..errors import MeshWriteError
from .atomic import atomic_write

__all__ = ["write_polyline"]


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
    P = as_points(P, "P", min_rows=2)
    k = len(P)
    data = {}
    for name, a in (point_data or {}).items():
        a = np.asarray(a, float)
        if a.shape not in ((k,), (k, 3)):
            raise MeshWriteError(f"point data {name!r} must have shape ({k},) or ({k}, 3), got {a.shape}")
        data[name] = a
    ext = Path(os.fspath(path)).suffix.lower()
    if ext == ".vtp":
        def w(fh):
            fh.write('<?xml version="1.0"?>\n<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian">\n'
                     "  <PolyData>\n")
            fh.write(f'    <Piece NumberOfPoints="{k}" NumberOfVerts="0" NumberOfLines="1" '
                     'NumberOfStrips="0" NumberOfPolys="0">\n')
            if data:
                first = next((n for n, a in data.items() if a.ndim == 1), None)
                fh.write("      <PointData" + (f' Scalars="{first}"' if first else "") + ">\n")
                for name, a in data.items():
                    nc = 1 if a.ndim == 1 else 3
                    fh.write(f'        <DataArray type="Float64" Name="{name}" NumberOfComponents="{nc}" '
                             'format="ascii">\n')
                    np.savetxt(fh, a.reshape(k, nc), fmt="%.10g")
                    fh.write("        </DataArray>\n")
                fh.write("      </PointData>\n")
            fh.write('      <Points>\n        <DataArray type="Float64" NumberOfComponents="3" format="ascii">\n')
            np.savetxt(fh, P, fmt="%.10g")
            fh.write("        </DataArray>\n      </Points>\n      <Lines>\n")
            fh.write('        <DataArray type="Int64" Name="connectivity" format="ascii">\n')
            fh.write(" ".join(map(str, range(k))) + "\n        </DataArray>\n")
            fh.write(f'        <DataArray type="Int64" Name="offsets" format="ascii">\n{k}\n        </DataArray>\n')
            fh.write("      </Lines>\n    </Piece>\n  </PolyData>\n</VTKFile>\n")
    elif ext == ".ply":
        scal = {n: a for n, a in data.items() if a.ndim == 1}

        def w(fh):
            fh.write(f"ply\nformat ascii 1.0\ncomment polyline written by vesselgp\nelement vertex {k}\n"
                     "property double x\nproperty double y\nproperty double z\n")
            for n in scal:
                fh.write(f"property double {n}\n")
            fh.write(f"element edge {k - 1}\nproperty int vertex1\nproperty int vertex2\nend_header\n")
            np.savetxt(fh, np.column_stack([P, *scal.values()]), fmt="%.10g")
            np.savetxt(fh, np.c_[np.arange(k - 1), np.arange(1, k)], fmt="%d")
    else:
        raise MeshWriteError(f"{path}: a polyline is written as .vtp or .ply, not {ext!r}")
    atomic_write(path, w)
