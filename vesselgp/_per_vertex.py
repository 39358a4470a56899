"""Per-vertex arrays of a cylinder fitted on part of a mesh, kept on that part (issue #47).

A tree's branches and paths (:func:`vesselgp.fit_vessel_tree`) are each fitted on some of the mesh's vertices,
and their :class:`vesselgp.GeneralizedCylinder` reads its ``vertex_*`` arrays over all of them, NaN or 0 off its
own. Written whole, the 191 cylinders of a 64-tip tree of 260k vertices took 2.8 GB and 5 s of its 24 s fit.
:func:`on_rows` keeps them on the cylinder's own rows; the whole array is made when it is first read (once per
array), and the library's own readers use :func:`rows_of` and :func:`stored_rows`, which never make it.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

__all__ = ["on_rows", "rows_of", "stored_rows"]


class PerVertex:
    """A ``vertex_*`` field of :class:`GeneralizedCylinder`: stored over the mesh, or over the sorted vertex
    rows the cylinder was fitted on (:func:`on_rows`) and made whole, with ``fill`` elsewhere, on first read."""

    def __init__(self, name, fill):
        self.name, self.fill = name, fill

    def __get__(self, obj, owner=None):
        if obj is None:
            return self
        d = obj.__dict__
        rows = d.get("_rows")
        if rows is None:
            return d[self.name]
        key = "_whole_" + self.name
        if key not in d:
            ids, n = rows
            part = d[self.name]
            whole = np.full((n,) + part.shape[1:], self.fill, dtype=part.dtype)
            whole[ids] = part
            d[key] = whole
        return d[key]

    def __set__(self, obj, value):  # the dataclass's __init__ (frozen: only through object.__setattr__)
        obj.__dict__[self.name] = value


#: The per-vertex fields and their value off a cylinder's own rows.
VERTEX_FILLS = {"vertex_s": np.nan, "vertex_theta": np.nan, "vertex_local": np.nan, "vertex_weight": 0.0,
                "vertex_area": 0.0}


def on_rows(gc, idx, n):
    """``gc``, fitted on the vertex rows ``idx`` (distinct) of an ``n``-vertex mesh, keeping its per-vertex
    arrays on those rows only (see :class:`vesselgp.GeneralizedCylinder`'s notes).

    Parameters
    ----------
    gc : GeneralizedCylinder
        Per-vertex arrays with one row per entry of ``idx``.
    idx : (q,) int64
    n : int

    Returns
    -------
    GeneralizedCylinder
        Reads ``vertex_*`` as (n, ...) arrays; :func:`rows_of` gives the stored rows without making them whole.
    """
    order = np.argsort(idx, kind="stable")
    part = {k: getattr(gc, k)[order] for k in VERTEX_FILLS}
    out = replace(gc, **part)
    out.__dict__["_rows"] = (idx[order], int(n))
    return out


def rows_of(gc, name, rows):
    """``getattr(gc, name)[rows]`` without making a partly stored array whole (:func:`on_rows`).

    Parameters
    ----------
    gc : GeneralizedCylinder
    name : str
        One of the ``vertex_*`` fields.
    rows : (q,) int64
        Vertex rows of the mesh.

    Returns
    -------
    (q, ...) array
    """
    stored = gc.__dict__.get("_rows")
    if stored is None or "_whole_" + name in gc.__dict__:
        return getattr(gc, name)[rows]
    ids, _ = stored
    part = gc.__dict__[name]
    out = np.full((len(rows),) + part.shape[1:], VERTEX_FILLS[name], dtype=part.dtype)
    if len(ids):
        pos = np.minimum(np.searchsorted(ids, rows), len(ids) - 1)
        hit = ids[pos] == rows
        out[hit] = part[pos[hit]]
    return out


def stored_rows(gc, name):
    """``(rows, values)``: the vertex rows a per-vertex field is stored on (all, for a whole one) and its
    values there, without making it whole (:func:`on_rows`)."""
    stored = gc.__dict__.get("_rows")
    if stored is None:
        v = getattr(gc, name)
        return np.arange(len(v)), v
    return stored[0], gc.__dict__[name]
