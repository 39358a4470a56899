"""Size and length unit of a mesh: :func:`mesh_scale`, :class:`MeshScale`, :func:`units_factor`."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np  # noqa: F401 (the doctests use it)

from .. import tolerances as tol
from .._validate import as_mesh
from ..errors import OptionError
from ._ends_format import bbox_diagonal
from ._geometry import median_edge as _median_edge

__all__ = ["mesh_scale", "MeshScale", "units_factor", "UNITS_TO_MM", "UNIT_NAMES"]

#: Length units a mesh can be given in, and how many millimetres one of them is.
UNITS_TO_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "um": 1e-3}
#: Their names, as :func:`mesh_scale`'s warnings spell them.
UNIT_NAMES = {"mm": "millimetres", "cm": "centimetres", "m": "metres", "um": "micrometres"}


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


def mesh_scale(V, F=None, ends=None, *, median_edge=None):
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
        Vertex positions, or a mesh object (``trimesh.Trimesh``, ``pyvista.PolyData``, ``meshio.Mesh``: :func:`vesselgp.as_mesh`).
    F : (m, 3) int64
        Triangles (left out with a mesh object).
    ends : sequence of VesselEnd, optional
        Ends from :func:`vessel_ends`; their radii give ``radius_range``.
    median_edge : float, optional
        The median length of the face corners' edges, when the caller has it
        (:func:`vesselgp.fit.checked_mesh` does); computed here otherwise.

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
    return scale_of(V, _median_edge(V, F) if median_edge is None else float(median_edge), ends)


def scale_of(V, med, ends=None):
    """:func:`mesh_scale` of validated vertices ``V`` whose median edge ``med`` is known (not checked again)."""
    diag = bbox_diagonal(V)
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


def units_factor(units=None, scale=None):
    """The factor that brings a mesh's coordinates into millimetres, and a label of its units.

    Parameters
    ----------
    units : {"mm", "cm", "m", "um"}, optional
        The mesh's length unit.
    scale : float, optional
        Millimetres per mesh unit (instead of ``units``).

    Returns
    -------
    factor : float
        Multiply the vertices by it to get millimetres (1 when neither is given).
    label : str or None
        ``units``, or ``"<scale> mm"`` for a ``scale``, or None when neither is
        given (the mesh is taken to be in millimetres).

    Raises
    ------
    OptionError
        An unknown unit, a scale that is not a finite positive number, or both given.

    Examples
    --------
    >>> units_factor("m"), units_factor(scale=25.4), units_factor()
    ((1000.0, 'm'), (25.4, '25.4 mm'), (1.0, None))
    """
    if units is not None and scale is not None:
        raise OptionError("give the mesh's units or a scale factor, not both")
    if units is not None:
        if units not in UNITS_TO_MM:
            raise OptionError(f"unknown length unit {units!r}; use one of {', '.join(UNITS_TO_MM)}")
        return UNITS_TO_MM[units], str(units)
    if scale is not None:
        try:
            f = float(scale)
        except (TypeError, ValueError):
            f = math.nan
        if isinstance(scale, bool) or not (math.isfinite(f) and f > 0):
            raise OptionError(f"scale must be a finite positive number of millimetres per mesh unit, got {scale!r}")
        return f, f"{f:g} mm"
    return 1.0, None
