"""JSON and CSV reports, written atomically (strict JSON: NaN and infinity become null)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..errors import VesselError
from .atomic import atomic_write

__all__ = ["to_json", "write_json", "read_json", "write_csv"]


def to_json(obj):
    """Convert numpy scalars/arrays (nested in dicts, lists, tuples) to JSON types; NaN/inf -> None.

    Examples
    --------
    >>> to_json({"a": np.array([1.0, np.nan]), "b": np.int64(3), "c": (np.float32(0.5),)})
    {'a': [1.0, None], 'b': 3, 'c': [0.5]}
    """
    if isinstance(obj, dict):
        return {str(k): to_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_json(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_json(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer, int)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        f = float(obj)
        return f if math.isfinite(f) else None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_json(path, obj, *, indent=2):
    """Write ``to_json(obj)`` atomically (strict JSON: no NaN)."""
    text = json.dumps(to_json(obj), indent=indent, allow_nan=False) + "\n"
    atomic_write(path, lambda fh: fh.write(text))
    return Path(path)


def write_csv(path, columns):
    """Write named equal-length columns as CSV atomically.

    Parameters
    ----------
    path : str or os.PathLike
    columns : dict of str to (k,) array
    """
    names = list(columns)
    A = np.column_stack([np.asarray(columns[k], float).reshape(-1) for k in names])

    def w(fh):
        fh.write(",".join(names) + "\n")
        np.savetxt(fh, A, delimiter=",", fmt="%.10g")

    atomic_write(path, w)
    return Path(path)


def read_json(path, what="JSON file", expect=dict):
    """Parse JSON from ``path`` whose top level is an ``expect`` (dict or list).

    Raises
    ------
    VesselError
        Unreadable file, invalid JSON, or another type at the top level.
    """
    try:
        d = json.loads(Path(path).read_text())
    except OSError as exc:
        raise VesselError(f"cannot read {what} {path} ({exc.strerror})") from None
    except ValueError as exc:
        raise VesselError(f"{what} {path} is not valid JSON ({exc})") from None
    if not isinstance(d, expect):
        kind = "an object" if expect is dict else "a list"
        raise VesselError(f"{what} {path} must hold {kind} at the top level")
    return d
