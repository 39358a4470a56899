"""``vesselgp clean`` and ``vesselgp ends``: a mesh file repaired, and the ends of a vessel mesh listed.

:func:`run_clean` writes ``<name>_clean.<fmt>`` (in millimetres) and ``clean_report.json``;
:func:`run_ends` writes ``ends.json``, printed by :func:`ends_table`.
"""
from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import numpy as np

from ..io import to_json, write_json, write_mesh
from ..mesh import clean_mesh, format_point, mesh_scale
from ..prepared import PreparedMesh
from .output import read_mesh_in

__all__ = ["run_clean", "run_ends", "ends_table"]


def run_clean(mesh, out, *, fmt="ply", smooth=0, units=None, scale=None):
    """Repair a mesh file (:func:`vesselgp.clean_mesh`); writes ``<name>_clean.<fmt>`` and ``clean_report.json``.

    Parameters
    ----------
    mesh : str or os.PathLike
    out : OutputFolder
    fmt : {"ply", "stl", "obj", "off", "vtp"}
    smooth : int
        Taubin smoothing iterations after the repairs (0: none).
    units, scale : optional
        Length unit of the file, or millimetres per mesh unit (:func:`read_mesh_in`);
        the cleaned mesh is written in millimetres.

    Returns
    -------
    (CleanReport, dict)
    """
    V, F, uinfo = read_mesh_in(mesh, units, scale)
    V2, F2, rep = clean_mesh(V, F, smooth=smooth)
    write_mesh(out(f"{Path(mesh).stem}_clean.{fmt}"), V2, F2)
    d = {k: v for k, v in asdict(rep).items() if k != "vertex_map"}
    d["summary"] = rep.summary()
    d["input"] = str(mesh)
    d.update(uinfo)
    sc = mesh_scale(V2, F2)
    d["scale"] = {"median_edge": sc.median_edge, "bbox_diagonal": sc.bbox_diagonal,
                  "units_guess": sc.units_guess, "warning": sc.warning}
    write_json(out("clean_report.json"), d)
    return rep, d


def run_ends(mesh, out, *, units=None, scale=None):
    """The ends of a vessel mesh file (:func:`vesselgp.vessel_ends`); writes ``ends.json``.

    Parameters
    ----------
    mesh : str or os.PathLike
    out : OutputFolder
    units, scale : optional
        Length unit of the file, or millimetres per mesh unit (:func:`read_mesh_in`).

    Returns
    -------
    dict
        The contents of ``ends.json``: ``command``, ``input``, ``units``,
        ``input_units``, ``to_mm``, ``bbox_diagonal``, ``n_ends`` and ``ends``,
        one ``{index, kind, radius, center, direction}`` per end in the order
        of :func:`vesselgp.vessel_ends` (the indices ``--ends I J`` takes); what was
        left out: ``sacs`` (rounded domes that are blind sacs: ``{radius, center, direction}``)
        and ``not_caps`` (flat patches the wall meets round most of their rims that are not
        caps: ``{radius, center, direction, n_faces, reason}``).
    """
    V, F, uinfo = read_mesh_in(mesh, units, scale)
    pm = PreparedMesh(V, F)
    ends = pm.ends
    d = {"command": "ends", "input": str(mesh), **uinfo,
         "bbox_diagonal": float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))), "n_ends": len(ends),
         "ends": [{"index": i, "kind": e.kind, "radius": float(e.radius), "center": np.asarray(e.center, float),
                   "direction": np.asarray(e.direction, float)} for i, e in enumerate(ends)],
         "sacs": [{"radius": r, "center": c, "direction": n} for c, n, r in pm.sacs],
         "not_caps": [{"radius": float(p.end.radius), "center": p.end.center, "direction": p.end.direction,
                       "n_faces": len(p.end.faces), "reason": p.reason} for p in pm.flat_patches]}
    write_json(out("ends.json"), d)
    return to_json(d)


def ends_table(d):
    """Plain-text table (index, kind, radius, centre, direction) of :func:`run_ends`' result.

    Centres are printed to a ten-thousandth of the bounding-box diagonal
    (:func:`vesselgp.mesh.format_point`), directions to four decimals.

    Examples
    --------
    >>> print(ends_table({"units": "mm", "bbox_diagonal": 50.0, "ends": [{"index": 0, "kind": "open",
    ...       "radius": 7.712, "center": [1.23456, 2, 3], "direction": [0, 0, -1]}]}))
    end  kind     radius (mm)  centre (mm)                   direction
      0  open           7.712  (1.235, 2, 3)                 (0, 0, -1)
    """
    u = d["units"]
    rows = ["{:<4} {:<8} {:>11}  {:<29} {}".format("end", "kind", f"radius ({u})", f"centre ({u})", "direction")]
    for e in d["ends"]:
        rows.append("{:>3}  {:<8} {:>11.4g}  {:<29} {}".format(
            e["index"], e["kind"], e["radius"], format_point(e["center"], d["bbox_diagonal"]),
            format_point(e["direction"], 1.0)))
    for s in d.get("sacs", ()):
        rows.append(f"not an end: a blind sac, dome radius {s['radius']:.4g} {u} at "
                    f"{format_point(s['center'], d['bbox_diagonal'])}")
    for p in d.get("not_caps", ()):
        rows.append(f"not an end: a flat patch of {p['n_faces']} faces, radius {p['radius']:.4g} {u} at "
                    f"{format_point(p['center'], d['bbox_diagonal'])}: {p['reason']}")
    return "\n".join(rows)
