"""Consistent, outward face orientation of a mesh whose only fault is its winding (issue #34).

Voxel and marching-cubes exporters (the Palabos aneurysm among the real meshes) write
triangles with arbitrary winding. Orientation is not a user's problem (VMTK ignores it), so
:func:`orient_faces` turns the faces of an edge-manifold, connected mesh coherently
(libigl's ``bfs_orient``) and then outward (the signed volume of the surface with its
boundary loops closed by fans is positive), and logs that it did. Anything else wrong
(non-manifold edges, several pieces) is left to the checks that name it.
"""
from __future__ import annotations

import logging

import igl
import numpy as np

from ._geometry import closed_by_fans, signed_volume
from .topology import mesh_topology

log = logging.getLogger(__name__)

__all__ = ["orient_faces"]


def orient_faces(V, F, topology=None):
    """``F`` oriented coherently and outward when that is its only fault; ``F`` itself otherwise.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    topology : MeshTopology, optional
        Of ``F`` (default built here).

    Returns
    -------
    F : (m, 3) int64
        A new array when faces were flipped (the caller's is never changed).
    topology : MeshTopology
        Of the returned faces.

    Examples
    --------
    >>> import numpy as np
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> G, _ = orient_faces(V, F)
    >>> bool((G == F).all())
    True
    >>> G, topo = orient_faces(V, np.array([[0, 2, 1], [0, 3, 1], [0, 3, 2], [1, 2, 3]]))
    >>> len(topo.incoherent_edges), bool(signed_volume(V, G) > 0)
    (0, True)
    """
    topo = mesh_topology(F, len(V)) if topology is None else topology
    if not len(topo.incoherent_edges) or len(topo.nonmanifold_edges):
        return F, topo
    G, comp = igl.bfs_orient(F)
    if int(np.max(comp)) > 0:  # several pieces: left to the connectivity check that names it
        return F, topo
    G = np.ascontiguousarray(G, dtype=np.int64)
    gt = mesh_topology(G, len(V))
    if signed_volume(*closed_by_fans(V, G, gt.boundary_loops)) < 0:
        G = np.ascontiguousarray(G[:, ::-1])
        gt = mesh_topology(G, len(V))
    flipped = int(np.count_nonzero((G != F).any(axis=1)))
    log.info("mesh faces were not consistently oriented (%d edges used twice in the same direction): "
             "%d of %d faces flipped", len(topo.incoherent_edges), flipped, len(F))
    return G, gt
