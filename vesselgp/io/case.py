"""``case.json``: a joining case (held and moving vertex ids, target frame, the other vessel's end ring).

One definition, used by ``data_gen/make_paper_cases.py``, ``vesselgp generate
--paper-cases``, the demo and ``vesselgp join --case``. A case folder holds
``vessel.ply`` (the vessel that is deformed), ``other.ply`` (the vessel joined
to) and ``case.json``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..deform import Frame
from ..errors import MismatchError, VesselError
from .meshfile import write_mesh
from .report import read_json, write_json

__all__ = ["case_to_dict", "case_from_dict", "write_case", "read_case", "CASE_FILES"]

#: Files of a case folder.
CASE_FILES = ("vessel.ply", "other.ply", "case.json")


def case_to_dict(case, resolution=None):
    """``case.json`` of a :class:`vesselgp.synthetic.JoinCase` (the layout of data_gen/make_paper_cases.py)."""
    return {
        "name": case.name, "units": case.units, "seed": case.seed, "resolution": resolution,
        "pre_rotation": case.pre_rotation, "n_vertices": len(case.V), "n_faces": len(case.F),
        "other_n_vertices": len(case.other_V), "fixed": case.fixed, "moving": case.moving,
        "moving_at": case.moving_at, "other_end": case.other_end, "target_origin": case.target_origin,
        "target_tangent": case.target_tangent, "target_normal": case.target_normal,
        "moving_normal": case.moving_normal, "vessel_length": case.truth.length, "vessel_curve": case.truth.name,
        "vessel_mesh": "vessel.ply", "other_mesh": "other.ply",
    }


def case_from_dict(d, n_vertices=None):
    """The join inputs of a ``case.json`` dictionary.

    Returns a dict with ``fixed``, ``moving`` (int64 ids), ``target``
    (:class:`vesselgp.Frame`), ``other_end`` (int64 ids or None) and
    ``moving_normal`` ((3,) float64 or None: the anchor at the moving end that
    lands on the target normal at angle 0; without it the fit's U does).
    ``other_mesh`` (the file of the vessel joined to, relative to the case
    file) is read by :func:`read_case`.

    Raises
    ------
    VesselError
        Missing fields or a vertex count that does not match the mesh.
    """
    need = ("fixed", "moving", "target_origin", "target_tangent", "target_normal")
    missing = [k for k in need if k not in d]
    if missing:
        raise VesselError(f"case file lacks {', '.join(missing)}; see data_gen/make_paper_cases.py for the layout")
    if n_vertices is not None and d.get("n_vertices") not in (None, n_vertices):
        raise MismatchError(f"case file is for a mesh of {d['n_vertices']} vertices, the mesh has {n_vertices}")
    try:
        fixed = np.asarray(d["fixed"], np.int64)
        moving = np.asarray(d["moving"], np.int64)
        other_end = None if d.get("other_end") is None else np.asarray(d["other_end"], np.int64)
    except (TypeError, ValueError) as exc:
        raise VesselError(f"case file vertex ids must be lists of integers ({exc})") from None
    target = Frame(d["target_origin"], d["target_tangent"], d["target_normal"])
    mn = d.get("moving_normal")
    return {"fixed": fixed, "moving": moving, "target": target, "other_end": other_end,
            "moving_normal": None if mn is None else np.asarray(mn, float)}


def write_case(folder, case, resolution=None):
    """Write a :class:`vesselgp.synthetic.JoinCase` as ``vessel.ply``, ``other.ply`` and ``case.json``.

    Parameters
    ----------
    folder : str or os.PathLike
        Existing folder.
    case : JoinCase
    resolution : float, optional
        Recorded in ``case.json``.

    Returns
    -------
    dict of str to pathlib.Path
        ``{"vessel", "other", "case_json"}``.
    """
    out = Path(folder)
    write_mesh(out / "vessel.ply", case.V, case.F)
    write_mesh(out / "other.ply", case.other_V, case.other_F)
    write_json(out / "case.json", case_to_dict(case, resolution), indent=None)
    return {"vessel": out / "vessel.ply", "other": out / "other.ply", "case_json": out / "case.json"}


def read_case(path, n_vertices=None):
    """A ``case.json`` file: the dict of :func:`case_from_dict` plus ``other``.

    ``other`` is the path of the vessel joined to, as the case file names
    it (``"other_mesh"``, relative to the case file's folder), or None when
    the case names none.

    Raises
    ------
    VesselError
        Unreadable or malformed case file, or a named ``other_mesh`` that does not exist.
    """
    d = read_json(path, "case file")
    out = case_from_dict(d, n_vertices)
    other = d.get("other_mesh")
    if other is not None:
        other = Path(path).parent / str(other)
        if not other.is_file():
            raise VesselError(f"case file {path} names other_mesh {other}, which does not exist; "
                              "restore it or remove 'other_mesh' from the case file")
    return {**out, "other": other}
