"""Meshes out to other packages' types: :func:`to_pyvista`, :func:`to_trimesh`, :func:`to_meshio`.

Each imports its package when called (``pip install "vesselgp[formats]"`` installs them) and
raises :class:`vesselgp.errors.DependencyError` naming the ``pip install`` when it is missing.
The other way, every function that takes ``(V, F)`` takes those objects
(:func:`vesselgp.as_mesh`); axes come out as ``GeneralizedCylinder.to_pyvista()`` and
``VesselTree.to_pyvista()``.
"""
from __future__ import annotations

from .._interop import _add_arrays, mesh_to_pyvista, require
from .._validate import as_mesh

__all__ = ["to_pyvista", "to_trimesh", "to_meshio"]


def to_pyvista(V, F=None, point_data=None):
    """A triangle mesh as a ``pyvista.PolyData``, with optional per-vertex arrays.

    Parameters
    ----------
    V : (n, 3) float64, or a mesh object
    F : (m, 3) int64, optional
        Left out with a mesh object (:func:`vesselgp.as_mesh`).
    point_data : dict of str to (n, ...) arrays, optional
        Per-vertex arrays, e.g. ``{"theta": gc.vertex_theta, "s": gc.vertex_s}``.

    Returns
    -------
    pyvista.PolyData
        Same vertices in the same order, one triangle cell per row of ``F``.

    Raises
    ------
    DependencyError
        pyvista is not installed.
    InvalidMeshError
        Malformed mesh, or a point array without one row per vertex.
    """
    V, F = as_mesh(V, F)
    return mesh_to_pyvista(V, F, point_data, what="vesselgp.io.to_pyvista")


def to_trimesh(V, F=None):
    """A triangle mesh as a ``trimesh.Trimesh``, vertices kept as they are (``process=False``).

    Parameters
    ----------
    V : (n, 3) float64, or a mesh object
    F : (m, 3) int64, optional

    Returns
    -------
    trimesh.Trimesh
        Same vertices in the same order (trimesh's default processing, which merges
        duplicate vertices, is not applied, so vertex arrays of vesselgp still index it).

    Raises
    ------
    DependencyError
        trimesh is not installed.
    """
    V, F = as_mesh(V, F)
    trimesh = require("trimesh", "vesselgp.io.to_trimesh")
    return trimesh.Trimesh(vertices=V.copy(), faces=F.copy(), process=False)


def to_meshio(V, F=None, point_data=None):
    """A triangle mesh as a ``meshio.Mesh`` (then ``mesh.write(path)`` in any of meshio's formats).

    Parameters
    ----------
    V : (n, 3) float64, or a mesh object
    F : (m, 3) int64, optional
    point_data : dict of str to (n, ...) arrays, optional

    Returns
    -------
    meshio.Mesh
        One ``triangle`` cell block.

    Examples
    --------
    >>> m = to_meshio([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], {"s": [0.0, 0.5, 1.0]})
    >>> m.cells[0].type, m.point_data["s"].tolist()
    ('triangle', [0.0, 0.5, 1.0])
    """
    V, F = as_mesh(V, F)
    meshio = require("meshio", "vesselgp.io.to_meshio")
    data = {}
    _add_arrays(data, point_data, len(V), "point data")
    return meshio.Mesh(V.copy(), [("triangle", F.copy())], point_data=data)
