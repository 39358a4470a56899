"""Open a closed vessel end: remove a flat cap or a rounded tip, leaving a boundary loop.

A join (:func:`vesselgp.join_vessels`) bridges two end rings, so a capped or
rounded end of either vessel is opened first. A flat cap (``kind == "cap"``)
loses its cap faces (:attr:`VesselEnd.faces`); its rim becomes the boundary
loop. A rounded tip (``kind == "rounded"``) loses its dome: every face with a
vertex beyond the plane through the end's centre (normal: its outward
direction), among the vertices connected to the tip within
``tolerances.OPEN_DOME_REACH`` end radii of the centre. Unreferenced vertices
are dropped; ``kept`` maps the new vertex ids to the old ones.
"""
from __future__ import annotations

import numpy as np
from scipy.sparse.csgraph import connected_components

from .. import tolerances as tol
from .._validate import as_mesh
from ..errors import EndsError
from .ends import VesselEnd
from .topology import MeshTopology

__all__ = ["open_end"]


def open_end(V, F, end):
    """Remove the cap or dome of one vessel end, so that it ends in a boundary loop.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    end : VesselEnd
        One of ``vessel_ends(V, F)``. An open end is returned as it is.

    Returns
    -------
    V : (n', 3) float64
        The vertices that are still used (a new array; ``V`` is not changed).
    F : (m', 3) int64
        The remaining faces, renumbered.
    loop : (k,) int64
        The new end's boundary loop, in new vertex ids, ordered along the faces.
    kept : (n',) int64
        Old id of each new vertex (``V_new = V[kept]``).

    Raises
    ------
    EndsError
        When removing the cap or dome does not leave exactly one new boundary
        loop near the end's centre (the end is not the end of a tube).

    Examples
    --------
    >>> from vesselgp.synthetic import synthetic_vessel
    >>> from vesselgp.mesh import vessel_ends
    >>> v = synthetic_vessel("arc", ends="capped", n_around=16)
    >>> e = vessel_ends(v.V, v.F)
    >>> W, G, loop, kept = open_end(v.V, v.F, e[0])
    >>> [x.kind for x in vessel_ends(W, G)], bool(np.allclose(W, v.V[kept]))
    (['open', 'cap'], True)
    """
    V, F = as_mesh(V, F)
    if not isinstance(end, VesselEnd):
        raise EndsError("end must be a vesselgp.VesselEnd (one of vessel_ends(V, F))")
    if end.kind == "open":
        return V, F, np.asarray(end.loop, np.int64), np.arange(len(V), dtype=np.int64)
    if end.kind == "cap":
        drop = np.zeros(len(F), bool)
        drop[np.asarray(end.faces, np.int64)] = True
    else:
        drop = np.any(_dome(V, F, end)[F], axis=1)
    G = F[~drop]
    kept = np.unique(G)
    new = np.full(len(V), -1, np.int64)
    new[kept] = np.arange(len(kept))
    G = new[G]
    W = V[kept]
    return W, G, _new_loop(W, G, end, F), kept


def _dome(V, F, end):
    """(n,) bool: vertices of a rounded tip beyond its centre plane, connected to the tip."""
    c, d, r = np.asarray(end.center), np.asarray(end.direction), float(end.radius)
    D = V - c
    beyond = (D @ d > 0.0) & (np.linalg.norm(D, axis=1) < tol.OPEN_DOME_REACH * r)
    top = MeshTopology(F, len(V))
    A = top.adjacency
    idx = np.flatnonzero(beyond)
    _, lab = connected_components(A[idx][:, idx], directed=False)
    tip = np.isin(idx, np.asarray(end.vertices, np.int64))
    if not tip.any():
        raise EndsError(f"the rounded end {end.describe()} has no vertices beyond its centre plane; "
                        "it cannot be opened")
    dome = np.zeros(len(V), bool)
    dome[idx[np.isin(lab, np.unique(lab[tip]))]] = True
    return dome


def _new_loop(W, G, end, F_old):
    """The boundary loop of the opened mesh nearest the end's centre (the one that was not there)."""
    before = len(MeshTopology.from_faces(F_old).boundary_loops)
    loops = MeshTopology(G, len(W)).boundary_loops
    if len(loops) != before + 1:
        raise EndsError(
            f"opening the {end.kind} end {end.describe()} left {len(loops)} boundary loops instead of "
            f"{before + 1}; the end is not the closed end of a tube (repair the mesh with vesselgp clean)"
        )
    dist = [float(np.linalg.norm(W[lp].mean(axis=0) - end.center)) for lp in loops]
    return np.asarray(loops[int(np.argmin(dist))], np.int64)
