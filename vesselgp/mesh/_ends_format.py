"""Text of vessel ends in messages: points printed for the mesh's size, listings cut short.

:func:`format_point` is the one rule for printed coordinates (re-exported by
:mod:`vesselgp.mesh`; :mod:`vesselgp.inside` and the commands use it too).
"""
from __future__ import annotations

import numpy as np

from .. import tolerances as tol

__all__ = ["format_point", "bbox_diagonal", "end_listing"]


def format_point(p, scale):
    """A point printed with enough significant digits for a mesh of size ``scale``.

    Coordinates resolve ``tolerances.PRINT_RESOLUTION`` times ``scale``: three
    ends of a metre-scale mesh do not all print as (0.1, 0.1, 0.1).

    Parameters
    ----------
    p : (3,) float64
    scale : float
        The mesh's size (its bounding-box diagonal).

    Returns
    -------
    str

    Examples
    --------
    >>> format_point([0.1234567, 0.1, 0.1], 0.05)
    '(0.123457, 0.1, 0.1)'
    """
    scale = float(scale)
    if not (np.isfinite(scale) and scale > 0):
        scale = 1.0
    dec = max(0, int(np.ceil(-np.log10(tol.PRINT_RESOLUTION * scale))))
    return "(" + ", ".join(f"{round(float(x), dec):.{dec}f}".rstrip("0").rstrip(".") for x in p) + ")"


def bbox_diagonal(V):
    """Length of the bounding-box diagonal of the points ``V`` ((n, 3) float64), 0 if empty."""
    if len(V) == 0:
        return 0.0
    return float(np.linalg.norm([V[:, k].max() - V[:, k].min() for k in range(V.shape[1])]))


def end_listing(ends, limit=None):
    """``"0 r=7.69 at (...), 1 ..."``, at most ``limit`` ends, then ``"... and N more"``.

    Each end's kind follows its centre when the ends are of several kinds.

    Parameters
    ----------
    ends : sequence of VesselEnd
    limit : int, optional
        Default ``tolerances.ENDS_LIST_MAX``.

    Returns
    -------
    str
    """
    limit = tol.ENDS_LIST_MAX if limit is None else int(limit)
    mixed = len({e.kind for e in ends}) > 1
    items = [f"{i} {e.describe().split(' ', 1)[1]}" + (f" {e.kind}" if mixed else "")
             for i, e in enumerate(ends[:limit])]
    if len(ends) > limit:
        items.append(f"... and {len(ends) - limit} more")
    return ", ".join(items)
