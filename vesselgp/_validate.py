"""Input conversion at the public boundary: arrays in, validated arrays out.

Every public function converts its inputs once, here; internals assume
``V`` (n, 3) float64 C-contiguous and ``F`` (m, 3) int64 C-contiguous. A mesh may also come
as one object of another package (``trimesh.Trimesh``, ``pyvista.PolyData``, ``meshio.Mesh``)
or a :class:`vesselgp.PreparedMesh`, in place of ``V`` with ``F`` left out (:func:`as_mesh`,
conversions in :mod:`vesselgp._interop`).
"""
from __future__ import annotations

import os

import numpy as np

from ._interop import ACCEPTED, mesh_kind, object_arrays, type_name
from .errors import FrameError, InvalidMeshError, MismatchError


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


def as_mesh(V, F=None):
    """Validate a triangle mesh and return ``(V, F)`` as float64 / int64 arrays.

    Every vesselgp function that takes ``(V, F)`` converts them here, so each of them also takes
    one mesh object in place of ``V`` with ``F`` left out.

    Parameters
    ----------
    V : (n, 3) float64, or a mesh object
        Vertex positions; or a ``trimesh.Trimesh``, a ``pyvista.PolyData`` (any ``vtkPolyData``),
        a ``meshio.Mesh`` or a :class:`vesselgp.PreparedMesh` (or another vesselgp object holding
        ``V`` and ``F``, such as a synthetic vessel). Quads and polygons of pyvista and meshio
        meshes are fan-triangulated, triangle strips unrolled, line and vertex cells left out;
        none of those packages is imported here.
    F : (m, 3) int64, optional
        Triangles; required with arrays, left out with a mesh object.

    Returns
    -------
    V : (n, 3) float64
    F : (m, 3) int64

    Raises
    ------
    InvalidMeshError
        Wrong shapes, non-triangular faces, NaN coordinates, face indices out
        of range, or an empty mesh; ``F`` missing with arrays or given with a mesh object; an
        object that is not a surface mesh (a volume mesh, a ``pyvista.UnstructuredGrid``: the
        message says how to get its surface).

    Examples
    --------
    >>> import meshio
    >>> quad = meshio.Mesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [("quad", [[0, 1, 2, 3]])])
    >>> V, F = as_mesh(quad)
    >>> V.dtype, F.tolist()
    (dtype('float64'), [[0, 1, 2], [0, 2, 3]])
    """
    kind = mesh_kind(V)
    if kind is not None:
        if F is not None:
            raise InvalidMeshError(
                f"give either a mesh object ({type_name(V)}) or the arrays V and F, not both; "
                "pass the arguments that follow a mesh object by keyword"
            )
        arrays = object_arrays(V, kind)  # raises with the type's name
        try:
            return _arrays_mesh(*arrays)
        except InvalidMeshError as exc:
            raise InvalidMeshError(f"{type_name(V)}: {exc}") from None
    if F is None:
        if isinstance(V, (str, os.PathLike)):
            raise InvalidMeshError(f"V is a path ({os.fspath(V)!r}); read the mesh with vesselgp.read_mesh first")
        raise InvalidMeshError(f"F is missing: give the arrays V and F, or one mesh object ({ACCEPTED})")
    return _arrays_mesh(V, F)


def _arrays_mesh(V, F):
    """:func:`as_mesh` of arrays."""
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


def as_deformed(V_deformed, F, name="V_deformed"):
    """Deformed vertex positions: an (n, 3) array, or a mesh object with the faces ``F`` of the rest mesh.

    Raises
    ------
    InvalidMeshError
        Malformed points or mesh object.
    MismatchError
        A mesh object whose faces are not ``F``.
    """
    if mesh_kind(V_deformed) is None:
        return as_points(V_deformed, name)
    W, G = as_mesh(V_deformed)
    if G.shape != F.shape or not np.array_equal(G, F):
        raise MismatchError(
            f"{name} ({type_name(V_deformed)}) has other faces than the rest mesh; the deformed mesh must "
            "keep the rest mesh's vertices and faces (or give its vertex array)"
        )
    return W


def mesh_arguments(args, layout, what):
    """Regroup positional arguments in which each mesh is either ``V, F`` or one mesh object.

    Parameters
    ----------
    args : sequence
        The arguments as the signature names them (``V_a, F_a, V_b, F_b``, ...).
    layout : sequence of str
        ``"mesh"`` for a ``V, F`` pair of slots, anything else for one value.
    what : str
        The function, for messages.

    Returns
    -------
    list
        Per ``"mesh"`` a pair ``(V, F)`` (``F`` None for a mesh object), per other slot its value.
        A mesh object whose ``F`` slot is empty (arguments by keyword) keeps its slots; one
        followed by a value (positional) moves the following arguments back by one slot, so
        ``f(mesh_a, mesh_b)`` reads as ``f(V_a, F_a, V_b, F_b)``.

    Raises
    ------
    InvalidMeshError
        Arguments left over.

    Examples
    --------
    >>> import meshio
    >>> a = meshio.Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [("triangle", [[0, 1, 2]])])
    >>> [type(x[0]).__name__ for x in mesh_arguments((a, a, None, None), ("mesh", "mesh"), "f")]
    ['Mesh', 'Mesh']
    """
    args = list(args)
    out, i = [], 0
    for slot in layout:
        a = args[i] if i < len(args) else None
        if slot == "mesh":
            nxt = args[i + 1] if i + 1 < len(args) else None
            if mesh_kind(a) is not None:
                out.append((a, None))
                i += 2 if nxt is None else 1
            else:
                out.append((a, nxt))
                i += 2
        else:
            out.append(a)
            i += 1
    if any(a is not None for a in args[i:]):
        raise InvalidMeshError(
            f"{what}: more arguments than its meshes and values take; give each mesh as V, F or as one "
            "mesh object, in order, or every argument by keyword"
        )
    return out
