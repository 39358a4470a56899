"""Size and length unit of a mesh: :func:`mesh_scale`, :class:`MeshScale`."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import tolerances as tol
from .._validate import as_mesh
from ._geometry import median_edge as _median_edge

__all__ = ["mesh_scale", "MeshScale"]


@dataclass(frozen=True)
class MeshScale:
    """Size of a mesh and a guess of its length unit.

    Attributes
    ----------
    median_edge : float
        Median edge length.
    bbox_diagonal : float
        Length of the bounding-box diagonal.
    radius_range : tuple of float or None
        (smallest, largest) end radius, when ends were given.
    units_guess : str
        "mm" (vessels span 10-500 mm), "cm", "m" or "um".
    warning : str or None
        Why the units look unusual and what to do, or None.
    """

    median_edge: float
    bbox_diagonal: float
    radius_range: tuple | None
    units_guess: str
    warning: str | None


def mesh_scale(V, F, ends=None):
    """Edge length, size and a guess of the length unit of a vessel mesh.

    Vessels in millimetres have bounding-box diagonals of about 10-500. A
    diagonal below ``tolerances.UNITS_M_MAX_DIAG`` suggests metres; one below
    ``tolerances.UNITS_CM_MAX_DIAG`` with edges finer than
    ``tolerances.UNITS_CM_EDGE_FRACTION`` of it suggests centimetres; one above
    ``tolerances.UNITS_UM_MIN_DIAG`` suggests micrometres. This is a guess:
    callers should log ``warning`` rather than rescale silently.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, 3) int64
        Triangles.
    ends : sequence of VesselEnd, optional
        Ends from :func:`vessel_ends`; their radii give ``radius_range``.

    Returns
    -------
    MeshScale

    Examples
    --------
    >>> V = np.array([[0, 0, 0], [0.05, 0, 0], [0, 0.05, 0.02]])
    >>> s = mesh_scale(V, [[0, 1, 2]])
    >>> s.units_guess, s.warning is not None
    ('m', True)
    """
    V, F = as_mesh(V, F)
    med = _median_edge(V, F)
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    rr = None
    if ends:
        r = [e.radius for e in ends]
        rr = (float(min(r)), float(max(r)))
    warning = None
    if diag < tol.UNITS_M_MAX_DIAG:
        units = "m"
        warning = (f"bounding-box diagonal {diag:.3g} is far below the 10-500 of a vessel in "
                   "millimetres; the mesh looks like metres: multiply V by 1000")
    elif diag < tol.UNITS_CM_MAX_DIAG and med < tol.UNITS_CM_EDGE_FRACTION * diag:
        units = "cm"
        warning = (f"bounding-box diagonal {diag:.3g} with fine edges ({med:.3g}) looks like "
                   "centimetres: multiply V by 10 if so")
    elif diag > tol.UNITS_UM_MIN_DIAG:
        units = "um"
        warning = (f"bounding-box diagonal {diag:.3g} is far above the 10-500 of a vessel in "
                   "millimetres; the mesh looks like micrometres: divide V by 1000")
    else:
        units = "mm"
    return MeshScale(med, diag, rr, units, warning)
