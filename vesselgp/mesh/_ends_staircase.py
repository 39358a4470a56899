"""Is a mesh a raw voxel staircase? The check :func:`vesselgp.vessel_ends` runs first.

A surface made of voxel faces, or marching cubes of a binary mask without
smoothing, is covered by terraces: flat patches facing the coordinate axes,
one per voxel layer. Each terrace is bounded by sharp edges and would be taken
for a flat cap, so a raw staircase would list dozens of "ends". Smooth meshes
have almost no area facing an axis exactly (a flat cap or two at most), so
the check measures the area whose normals lie within
``tolerances.STAIRCASE_AXIS_DEG`` of a coordinate axis and the number of
distinct axis-aligned planes holding it.
"""
from __future__ import annotations

import numpy as np

from .. import tolerances as tol
from ..errors import EndsError

__all__ = ["staircase_stats", "check_staircase"]


def staircase_stats(V, F, N, A, h):
    """Area fraction facing a coordinate axis and the number of axis-aligned planes (terraces).

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    N : (m, 3) float64
        Unit face normals (zero rows for zero-area faces).
    A : (m,) float64
        Twice the face areas.
    h : float
        Median edge length: faces in planes closer than
        ``tolerances.STAIRCASE_PLANE_EDGES`` of it are in one terrace, and a
        terrace needs ``tolerances.STAIRCASE_TERRACE_AREA`` squared edges of area.

    Returns
    -------
    fraction : float
        Area of the axis-facing faces over the whole area (0 for no area).
    terraces : int
        Distinct axis-aligned planes (axis, side, offset) holding such area.
    """
    total = float(A.sum())
    if not total > 0 or not h > 0:
        return 0.0, 0
    ax = np.argmax(np.abs(N), axis=1)
    comp = N[np.arange(len(N)), ax]
    al = np.abs(comp) > np.cos(np.radians(tol.STAIRCASE_AXIS_DEG))
    if not al.any():
        return 0.0, 0
    fraction = float(A[al].sum()) / total
    k = np.flatnonzero(al)
    off = V[F[k, 0], ax[k]]  # the face's plane: a vertex coordinate along its axis
    q = np.floor(off / (tol.STAIRCASE_PLANE_EDGES * h)).astype(np.int64)
    q -= q.min()
    key = (ax[k] * 2 + (comp[k] > 0)).astype(np.int64) * (int(q.max()) + 1) + q
    _, inv = np.unique(key, return_inverse=True)
    area = np.bincount(inv.ravel(), weights=0.5 * A[k])
    terraces = int(np.count_nonzero(area >= tol.STAIRCASE_TERRACE_AREA * h * h))
    return fraction, terraces


def check_staircase(V, F, N, A, h):
    """Raise :class:`EndsError` when the mesh is a raw voxel staircase (see the module doc).

    Parameters are those of :func:`staircase_stats`.
    """
    fraction, terraces = staircase_stats(V, F, N, A, h)
    if fraction >= tol.STAIRCASE_AREA_FRACTION and terraces >= tol.STAIRCASE_MIN_TERRACES:
        raise EndsError(
            f"mesh is a raw voxel staircase surface ({fraction:.0%} of its area faces a coordinate axis, "
            f"in {terraces} terraces) whose terraces would be taken for vessel ends; smooth it first "
            "with vesselgp.clean_mesh(V, F, smooth=N) (command line: vesselgp clean --smooth N)"
        )
