"""Flat caps of any size for :func:`vesselgp.vessel_ends`.

A cap is a maximal patch of coplanar faces (joined across edges whose
dihedral angle is below ``tolerances.CAP_FLATNESS``) that

* is flat (every face normal within ``tolerances.CAP_FLATNESS`` of the mean),
  a disk (one rim loop, Euler characteristic 1) and touches no mesh boundary;
* is bounded by sharp edges (dihedral angle above
  ``tolerances.SHARP_EDGE_ANGLE``) on at least
  ``tolerances.CAP_RIM_SHARP_FRACTION`` of its rim, and met all round its rim
  by the vessel wall: across every rim edge the neighbouring face stands
  within ``tolerances.CAP_RIM_TILT`` of perpendicular to the cap, and lies
  behind the cap's plane, on the same side for every rim edge (a noisy wall
  may meet the rim more bluntly than a sharp edge here and there);
* closes the tube, so the rim is the whole cross-section: the surface within
  ``tolerances.CAP_TUBE_REACH`` rim radii (or wall edges, if longer) of the
  rim, geodesic, stays behind the plane, reaches
  ``tolerances.CAP_TUBE_MIN_DEPTH`` rim radii deep, and stays within
  ``tolerances.CAP_TUBE_SPREAD`` times the rim's largest radius of the cap's
  axis, plus ``tolerances.CAP_TUBE_FLARE`` times its depth (a tube may
  widen behind its cap like a cone, not like the next terrace of a
  staircase).

The size is judged against the vessel there, never in absolute edges: an
outlet capped by a single triangle or two is a cap when its rim is the whole
cross-section. The terraces of a voxel staircase are not caps (the body
widens, or rises, around them), nor are flat sliver faces of a noisy wall.
The tests are vectorised over all patches first; only the few patches that
pass them get the geodesic check.
"""
from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, dijkstra

from .. import tolerances as tol
from .._arrays import chunks
from .topology import MeshTopology

__all__ = ["find_caps"]

log = logging.getLogger(__name__)


def find_caps(V, F, topo, N, A, graph):
    """Flat caps closing the vessel (see the module doc).

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    topo : MeshTopology
        Of ``F``; edge-manifold and coherently oriented.
    N : (m, 3) float64
        Unit face normals (zero rows for zero-area faces).
    A : (m,) float64
        Twice the face areas.
    graph : callable
        Returns the (n, n) edge-length graph (built on first need).

    Returns
    -------
    caps : list of (faces, loop, center, normal)
        Face ids (c,) int64, the rim loop (k,) int64, the centre (3,) float64
        (area-weighted) and the unit normal (3,) float64 pointing out of the
        vessel (away from the wall behind the cap).
    """
    split = _patches(topo, N)
    if split is None:
        return []
    lab, ncomp, rim, sharp = split
    flat, mhat = _flat_patches(topo, N, A, lab, ncomp)
    sign = _rim_sides(V, F, topo, N, lab, flat, mhat, rim, sharp)
    cands = np.flatnonzero(flat & (sign != 0))
    if len(cands) == 0:
        return []
    order = np.argsort(lab, kind="stable")
    starts = np.searchsorted(lab[order], cands)
    counts = np.bincount(lab, minlength=ncomp)[cands]
    caps = []
    for c, s0, k in zip(cands, starts, counts):
        fids = np.sort(order[s0:s0 + k])
        cap = _closing_cap(V, F, fids, A, -sign[c] * mhat[c], graph)
        if cap is not None:
            caps.append(cap)
    log.debug("caps: %d patches, %d flat, %d walled all round, %d close the tube",
              ncomp, int(flat.sum()), len(cands), len(caps))
    return caps


def _patches(topo, N):
    """Face labels of the coplanar patches, or None when no edge is sharp (then no cap exists).

    Faces are joined across edges whose dihedral angle is below
    ``tolerances.CAP_FLATNESS``, so a noisy wall face meeting a cap at a
    blunter angle than ``tolerances.SHARP_EDGE_ANGLE`` is not taken into it.

    Returns
    -------
    lab : (m,) int32
        Patch of each face.
    ncomp : int
    rim : (s,) int64
        Ids of the interior edges between patches.
    sharp : (s,) bool
        Which of them are sharp (dihedral angle above ``tolerances.SHARP_EDGE_ANGLE``).
    """
    inner = np.flatnonzero(topo.edge_face_count == 2)
    # take, not fancy indexing: numpy gathers rows that way 2-8x faster (the same rows)
    f, g = topo.edge_faces.take(inner, axis=0).T
    N32 = N.astype(np.float32)  # (half the memory traffic of the gathers; ample for the test)
    cos = np.empty(len(inner), np.float32)  # coherent mesh: normals agree in sense
    for c in chunks(len(inner), tol.EDGE_CHUNK):  # the gathered normals a few MB at a time
        np.einsum("ij,ij->i", N32.take(f[c], axis=0), N32.take(g[c], axis=0), out=cos[c])
    is_sharp = cos < np.cos(tol.SHARP_EDGE_ANGLE)
    if not is_sharp.any():
        return None
    keep = cos >= np.cos(tol.CAP_FLATNESS)
    m = len(N)
    G = sp.csr_array((np.ones(int(keep.sum()), dtype=np.int8), (f[keep], g[keep])), shape=(m, m))
    ncomp, lab = connected_components(G, directed=False)
    return lab, ncomp, inner[~keep], is_sharp[~keep]


def _flat_patches(topo, N, A, lab, ncomp):
    """Which patches are flat closed disks candidates, and their unit mean normals.

    Returns
    -------
    flat : (ncomp,) bool
        Positive area, no boundary face, every face normal within
        ``tolerances.CAP_FLATNESS`` of the area-weighted mean.
    mhat : (ncomp, 3) float64
        Unit area-weighted mean normal (zero where it vanishes).
    """
    S = np.stack([np.bincount(lab, weights=N[:, k] * A, minlength=ncomp) for k in range(3)], axis=1)
    norm = np.linalg.norm(S, axis=1)
    mhat = np.divide(S, norm[:, None], out=np.zeros_like(S), where=norm[:, None] > 0)
    bent = (np.einsum("ij,ij->i", N, mhat[lab]) < np.cos(tol.CAP_FLATNESS)) & (A > 0)  # zero area: no direction
    bad = bent | topo.boundary_faces
    flat = (np.bincount(lab, weights=bad, minlength=ncomp) == 0) & (norm > 0)
    return flat, mhat


def _rim_sides(V, F, topo, N, lab, flat, mhat, rim, sharp):
    """For each patch, on which side of its plane the wall lies all round its rim.

    Across each rim edge of a flat patch, the wall face must stand within
    ``tolerances.CAP_RIM_TILT`` of perpendicular to the patch, and its third
    vertex must lie off the patch's plane; all on one side. At least
    ``tolerances.CAP_RIM_SHARP_FRACTION`` of the rim's length must be sharp.

    Returns
    -------
    sign : (ncomp,) int
        -1 when the wall is behind the mean normal all round, +1 in front all
        round, 0 otherwise (or for patches that are not flat).
    """
    ncomp = len(flat)
    E = topo.edges[rim]
    ef = topo.edge_faces[rim]
    length = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    sides = []
    for own, wall in ((ef[:, 0], ef[:, 1]), (ef[:, 1], ef[:, 0])):
        p = lab[own]
        ok = flat[p]
        p, w, e = p[ok], wall[ok], E[ok]
        n = mhat[p]
        upright = np.abs(np.einsum("ij,ij->i", N[w], n)) <= np.sin(tol.CAP_RIM_TILT)
        Fw = F[w]
        third = np.where((Fw[:, 0] != e[:, 0]) & (Fw[:, 0] != e[:, 1]), Fw[:, 0],
                         np.where((Fw[:, 1] != e[:, 0]) & (Fw[:, 1] != e[:, 1]), Fw[:, 1], Fw[:, 2]))
        off = V[third] - V[e[:, 0]]
        reach = np.linalg.norm(off, axis=1)
        h = np.einsum("ij,ij->i", off, n)
        s = np.where(h > tol.CAP_RIM_MIN_SLOPE * reach, 1, np.where(h < -tol.CAP_RIM_MIN_SLOPE * reach, -1, 0))
        sides.append((p, np.where(upright, s, 0), length[ok], sharp[ok]))
    p, s, ln, sh = (np.concatenate(x) for x in zip(*sides))
    total = np.bincount(p, minlength=ncomp)
    pos = np.bincount(p, weights=s == 1, minlength=ncomp)
    neg = np.bincount(p, weights=s == -1, minlength=ncomp)
    rim_len = np.bincount(p, weights=ln, minlength=ncomp)
    sharp_len = np.bincount(p, weights=ln * sh, minlength=ncomp)
    sign = np.zeros(ncomp, dtype=np.int64)
    sharp_enough = sharp_len >= tol.CAP_RIM_SHARP_FRACTION * rim_len
    sign[(total > 0) & (pos == total) & sharp_enough] = 1
    sign[(total > 0) & (neg == total) & sharp_enough] = -1
    return sign


def _closing_cap(V, F, fids, A, n_out, graph):
    """(faces, loop, centre, normal) when the patch is a disk that closes the tube, else None."""
    ids, local = np.unique(F[fids], return_inverse=True)
    patch = MeshTopology(np.ascontiguousarray(local.reshape(-1, 3), dtype=np.int64), len(ids))
    loops = patch.boundary_loops
    if len(loops) != 1 or patch.euler_characteristic != 1:
        return None  # not a disk
    loop = ids[loops[0]]
    w = A[fids]
    center = (w[:, None] * V[F[fids]].mean(axis=1)).sum(axis=0) / w.sum()
    P = V[loop] - center
    lateral = np.linalg.norm(P - np.outer(P @ n_out, n_out), axis=1)
    a, amax = float(lateral.mean()), float(lateral.max())
    if not a > 0:
        return None
    G = graph()
    rows = G[loop]
    size = max(amax, float(rows.data.max()) if rows.nnz else 0.0)  # the rim radius, or the wall's edges
    g = dijkstra(G, indices=loop, min_only=True, limit=tol.CAP_TUBE_REACH * size)
    near = np.flatnonzero(g < np.inf)
    near = near[~np.isin(near, ids, assume_unique=True)]
    X = V[near] - center
    depth = -(X @ n_out)
    if len(X) == 0 or depth.min() < -tol.CAP_FRONT_TOLERANCE * a:
        return None  # the surface goes on in front of the cap: a step, not an end
    if depth.max() < tol.CAP_TUBE_MIN_DEPTH * a:
        return None  # nothing behind it: a flat side, not a cross-section
    side = np.linalg.norm(X + np.outer(depth, n_out), axis=1)
    if np.any(side > tol.CAP_TUBE_SPREAD * amax + tol.CAP_TUBE_FLARE * np.maximum(depth, 0.0)):
        return None  # the body widens behind it: a terrace or a facet, not the whole section
    return fids, loop, center, n_out
