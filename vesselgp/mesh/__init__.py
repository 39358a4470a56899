"""Mesh stage: connectivity, cleanup, scale and units, vessel ends, stitching.

One concept per module:

* :mod:`.topology`: :class:`MeshTopology`, every edge table of a mesh from one
  sort (edges, face edges, orientation, boundary loops, adjacency,
  components), built once and shared by the other modules;
* :mod:`.clean`: :func:`clean_mesh` repairs what segmentation and STL export
  leave behind (pymeshlab filters) and keeps the largest connected piece;
* :mod:`.seams`: :func:`~.seams.open_seams` recognises a mesh torn along seams of
  duplicate vertices (a multi-patch export), and gives the one message every
  refusal of it raises;
* :mod:`.scale`: :func:`mesh_scale` reports edge length, size and a guess of
  the units;
* :mod:`.ends`: :func:`vessel_ends` finds where a vessel ends (open boundary
  loops, flat caps of a closed surface, or rounded extremities), and
  :func:`select_ends` picks the two ends of the vessel's path among them;
* :mod:`.open_end`: :func:`open_end` removes a flat cap or a rounded tip, leaving a boundary loop;
* :mod:`.stitch`: :func:`stitch` bridges two vessels' end rings into one mesh.

The package is a lower layer: it imports only errors, tolerances, input
validation and array helpers of vesselgp.
"""
from __future__ import annotations

from .clean import CleanReport, clean_mesh
from .ends import VesselEnd, select_ends, vessel_ends
from .scale import MeshScale, mesh_scale
from .open_end import open_end
from .stitch import stitch
from .topology import MeshTopology, mesh_topology
from ._ends_format import bbox_diagonal, format_point

__all__ = [
    "clean_mesh",
    "CleanReport",
    "mesh_scale",
    "MeshScale",
    "vessel_ends",
    "VesselEnd",
    "select_ends",
    "stitch",
    "open_end",
    "MeshTopology",
    "mesh_topology",
    "format_point",
    "bbox_diagonal",
]
