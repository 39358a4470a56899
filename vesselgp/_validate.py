"""Input conversion at the public boundary: arrays in, validated arrays out.

Every public function converts its inputs once, here; internals assume
``V`` (n, 3) float64 C-contiguous and ``F`` (m, 3) int64 C-contiguous.
"""
from __future__ import annotations

import numpy as np

from .errors import FrameError, InvalidMeshError


def as_points(P, name="P", rows=None, min_rows=1):
    """(k, 3) float64 array of finite points, or raise :class:`InvalidMeshError`."""
    try:
        A = np.ascontiguousarray(P, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidMeshError(f"{name} must be a numeric (k, 3) array: {exc}") from None
    if A.ndim != 2 or A.shape[1] != 3:
        raise InvalidMeshError(f"{name} must have shape (k, 3), got {A.shape}")
    if rows is not None and A.shape[0] != rows:
        raise InvalidMeshError(f"{name} must have {rows} rows, got {A.shape[0]}")
    if A.shape[0] < min_rows:
        raise InvalidMeshError(f"{name} needs at least {min_rows} points, got {A.shape[0]}")
    if not np.all(np.isfinite(A)):
        bad = int(np.count_nonzero(~np.isfinite(A).all(axis=1)))
        raise InvalidMeshError(
            f"{name} has {bad} rows with NaN or infinite coordinates; remove or repair them"
        )
    return A


def as_vector(x, name="vector"):
    """Finite (3,) float64 vector, or raise :class:`FrameError`."""
    try:
        a = np.asarray(x, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise FrameError(f"{name} must be a 3-vector") from None
    if a.shape != (3,):
        raise FrameError(f"{name} must be a 3-vector, got shape {np.shape(x)}")
    if not np.all(np.isfinite(a)):
        raise FrameError(f"{name} has NaN or infinite entries")
    return a


def as_mesh(V, F):
    """Validate a triangle mesh and return ``(V, F)`` as float64 / int64 arrays.

    Raises
    ------
    InvalidMeshError
        Wrong shapes, non-triangular faces, NaN coordinates, face indices out
        of range, or an empty mesh.
    """
    V = as_points(V, "V", min_rows=3)
    try:
        Fa = np.asarray(F)
    except (TypeError, ValueError) as exc:
        raise InvalidMeshError(f"F must be an integer (m, 3) array: {exc}") from None
    if Fa.ndim != 2 or Fa.shape[0] == 0:
        raise InvalidMeshError(f"F must be a non-empty (m, 3) array, got shape {Fa.shape}")
    if Fa.shape[1] != 3:
        raise InvalidMeshError(
            f"F has {Fa.shape[1]} vertices per face; vesselgp needs triangles "
            "(read the file with vesselgp.read_mesh, which triangulates polygons)"
        )
    if not np.issubdtype(Fa.dtype, np.integer):
        if not np.issubdtype(Fa.dtype, np.floating) or np.any(Fa != np.round(Fa)):
            raise InvalidMeshError("F must hold integer vertex indices")
    F = np.ascontiguousarray(Fa, dtype=np.int64)
    if F.min() < 0 or F.max() >= len(V):
        raise InvalidMeshError(
            f"F indexes vertices in [{F.min()}, {F.max()}] but V has {len(V)} rows"
        )
    return V, F
