"""End-to-end runs behind the ``vesselgp`` commands, and their reports.

Each ``run_*`` function takes inputs (arrays or file paths) and an output
folder, calls the library and writes every output file (atomically, through
:mod:`vesselgp.io`); the command line only parses arguments and prints.

* :func:`run_fit`: generalized cylinder (Eq. 1-5) of a mesh file: ``axis.json``, ``axis.csv``,
  ``axis.vtp``/``.ply``, a shaded mesh;
* :func:`run_torsion`: material torsion (Eq. 6-8) of a rest/deformed pair;
* :func:`run_join`: minimum-torsion join (Section 2.3) with the figures of paper Figs. 2-4;
* :func:`run_demo`: both of the paper's joining cases (Section 3) on generated data;
* :func:`run_ends`: the ends of a vessel mesh (:func:`vesselgp.vessel_ends`);
* :func:`run_clean`, :func:`run_generate`, :func:`run_paper_cases`.

Angles are radians in the API and degrees in reports and figures. Mesh files
are read through :func:`read_mesh_in`, which converts them into millimetres
(``units``/``scale``); every report records the input's units and the factor.
"""
from __future__ import annotations

import contextlib
import json
import logging
import math
import os
import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from . import tolerances as tol
from .bulges import tree_bulges
from .deform import Frame
from .branches import root_end
from .errors import MismatchError, OptionError, VesselError
from .fit import fit_generalized_cylinder
from .tree import fit_vessel_tree
from .io import (read_case, read_mesh, to_json, write_case, write_centerlines, write_csv, write_json, write_mesh)
from .join import JoinProblem, minimize_torsion
from .join_vessels import VesselJoin
from .mesh import clean_mesh, format_point, mesh_scale, stitch
from .mesh.scale import UNIT_NAMES, units_factor
from .network import centerline_network
from .prepared import PreparedMesh
from .html_report import ViewMesh, write_report_html
from .rotations import wrap_angle
from .synthetic import deform_synthetic, paper_case, synthetic_vessel
from .torsion import TorsionMeter
from .twist import twist_between
from .viz import (ENERGY_IN_WORDS, decimated, plot_cumulative_twist, plot_energy_curve, plot_torsion_profile, render_mesh,
                  render_panels, first_colors, torsion_colors)

log = logging.getLogger(__name__)

__all__ = [
    "OutputFolder", "REPORT_FIELDS", "gc_to_dict", "profile_to_dict", "summary_table", "ends_table", "join_inputs",
    "read_mesh_in", "library_scale_warnings_replaced", "run_fit", "run_torsion", "run_join", "run_demo",
    "run_clean", "run_ends", "run_generate", "run_paper_cases",
]

#: Fields of each case in ``report.json`` (and of ``result.json`` of ``vesselgp join``).
REPORT_FIELDS = {
    "name": "case name",
    "n_vertices": "vertices of the deformed vessel",
    "n_faces": "faces of the deformed vessel",
    "optimum_angle_deg": "rotation of the joined end with the least torsion (degrees in (-180, 180]; 0 = the anchor)",
    "energy": "torsion energy at the optimum (paper Eq. 8, radians^2 per unit normalised length)",
    "total_twist_deg": "alpha(1) - alpha(0) at the optimum (degrees, Eq. 7)",
    "roll_deg": "optimum minus the zero-twist angle (degrees): the roll beyond the twist-free placement",
    "zero_twist_angle_deg": "the deformation's own zero-twist angle (degrees), the search's start",
    "angle_reference": "what angle 0 and a positive angle mean (ANGLE_REFERENCE)",
    "moving_normal": "the anchor across the moving end (rest) that lands on target_normal at angle 0",
    "target_normal": "the anchor across the target end",
    "target_origin": "where the moving end's centre goes",
    "target_tangent": "the axis direction there, out of the moving vessel",
    "axial_stretch": "deformed over rest length of the free part of the axis",
    "max_bend": "largest curvature times radius of the deformed axis (above 1 the wall folds)",
    "max_edge_stretch": "largest deformed over rest edge length at the optimum",
    "n_evals": "energy evaluations of the search (probes + NLopt)",
    "status": "NLopt result name",
    "grid_scan": "true when the search started from a full-turn grid scan (energy not convex near zero twist)",
    "setup_time_s": "generalized-cylinder fit and factorisations (seconds)",
    "time_s": "minimum-torsion search (seconds)",
    "large_torsion": "the configuration rotated DEMO_LARGE_TORSION_DEG from the optimum: angle_deg, energy, total_twist_deg",
    "energy_curve": "angles_deg and energies of paper Fig. 4",
    "evaluations": "angles_deg and energies the search evaluated",
    "files": "files written for this case, relative to the output folder",
    "curve_time_s": "the energy curve of paper Fig. 4 (seconds)",
    "output_time_s": "writing the meshes, figures and report (seconds)",
    "placement": "null, or what --place did first: matrix (4 x 4), turned_deg, moved_mm (the joined end's centre)",
    "case": "the paper's case, 1 or 2 (vesselgp demo only)",
    "title": "the case's title (vesselgp demo only)",
    "generate_time_s": "generating the case's meshes (seconds; vesselgp demo only)",
}


# ----------------------------------------------------------------------------- output folder


class OutputFolder:
    """An output folder that must be new or empty (unless ``overwrite``) and never holds an input.

    A run that is refused leaves no empty folder behind: :meth:`remove_if_empty` (called when a
    ``with OutputFolder(...)`` block ends in an exception) removes the folders this object created
    while they hold nothing; a folder that existed before is never removed.

    Parameters
    ----------
    folder : str or os.PathLike
    inputs : sequence of path, optional
        Files that must never be written over.
    overwrite : bool
    rerun : (str, str), optional
        ``(name, command)`` of a command whose output is one JSON listing (``("ends.json", "ends")``):
        a folder that holds only that file, written by the same command (its ``"command"`` field),
        is the command's earlier output and is written over without ``overwrite``.

    Attributes
    ----------
    dir : pathlib.Path
    files : list of str
        Every path handed out by calling the folder (the files written).

    Raises
    ------
    VesselError
        The folder is a file, is not empty (without ``overwrite``) or is an input.
    """

    def __init__(self, folder, inputs=(), overwrite=False, *, rerun=None):
        self.dir = Path(folder)
        self.inputs = [Path(p) for p in inputs if p is not None]
        if self.dir.exists() and not self.dir.is_dir():
            raise VesselError(f"output {self.dir} exists and is not a folder; choose another -o")
        if self.dir.is_dir() and not overwrite and not _earlier_run(self.dir, rerun):
            raise VesselError(f"output folder {self.dir} exists and is not empty; pass --overwrite or choose another -o")
        for p in self.inputs:
            if p.exists() and p.resolve() == self.dir.resolve():
                raise VesselError(f"output folder {self.dir} is an input; choose another -o")
        self._made = []  # folders this object created, outermost first
        self._mkdir(self.dir)
        self.files = []

    def _mkdir(self, folder):
        missing = [d for d in (folder, *folder.parents) if not d.exists()][::-1]
        folder.mkdir(parents=True, exist_ok=True)
        self._made += [d for d in missing if d.is_dir()]

    def remove_if_empty(self):
        """Remove the folders this object created that hold nothing (innermost first); returns them."""
        gone = []
        for d in reversed(self._made):
            with contextlib.suppress(OSError):  # not empty (or gone): it stays
                d.rmdir()
                gone.append(d)
        self._made = [d for d in self._made if d not in gone]
        return gone

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None:
            self.remove_if_empty()
        return False

    def check(self, names):
        """Refuse, before anything is written, names that are inputs."""
        for name in names:
            self._path(name)

    def _path(self, name):
        p = self.dir / name
        for q in self.inputs:
            if p.resolve() == q.resolve() or (p.exists() and q.exists() and os.path.samefile(p, q)):
                raise VesselError(f"refusing to overwrite input file {q}; choose another -o")
        return p

    def __call__(self, name):
        """Path of ``name`` in the folder (created on first use), recorded in :attr:`files`."""
        p = self._path(name)
        self._mkdir(p.parent)
        self.files.append(str(p))
        return p


def _earlier_run(folder, rerun):
    """Whether ``folder`` is empty, or holds only the JSON listing ``rerun = (name, command)`` written by that
    command (:class:`OutputFolder`)."""
    held = list(folder.iterdir())
    if not held:
        return True
    if rerun is None or len(held) != 1 or held[0].name != rerun[0] or not held[0].is_file():
        return False
    try:
        d = json.loads(held[0].read_bytes())
    except (OSError, ValueError):  # unreadable or not JSON: not ours
        return False
    return isinstance(d, dict) and d.get("command") == rerun[1]


# ----------------------------------------------------------------------------- units


def read_mesh_in(path, units=None, scale=None):
    """Read a mesh file and bring it into millimetres.

    Without ``units`` and ``scale`` the mesh is taken to be in millimetres;
    when its size suggests metres, centimetres or micrometres
    (:func:`vesselgp.mesh_scale`) a WARNING names the ``--units`` option that
    converts it. With them, a WARNING says when the converted mesh still does
    not look like millimetres.

    Parameters
    ----------
    path : str or os.PathLike
    units : {"mm", "cm", "m", "um"}, optional
        The mesh's length unit.
    scale : float, optional
        Millimetres per mesh unit (instead of ``units``).

    Returns
    -------
    V : (n, 3) float64
        Vertices in millimetres.
    F : (m, 3) int64
    units : dict
        ``{"units": "mm", "input_units": label, "to_mm": factor}`` for the
        reports: ``label`` is ``units``, ``"<scale> mm"`` or ``"mm (assumed)"``.

    Raises
    ------
    OptionError
        Unknown ``units``, a bad ``scale``, or both given.
    """
    factor, label = units_factor(units, scale)
    V, F = read_mesh(path)
    if factor != 1.0:
        V = V * factor
    _warn_units(path, mesh_scale(V, F), label)
    return V, F, {"units": "mm", "input_units": label or "mm (assumed)", "to_mm": factor}


def _warn_units(path, sc, label):
    """Log a WARNING naming the option to pass when a mesh in millimetres does not look like it.

    Without ``--units``/``--scale`` (``label`` None) the mesh's size is matched against metres,
    centimetres and micrometres (:func:`vesselgp.mesh_scale`); with them, the converted mesh must span
    a vessel's size (``tolerances.UNITS_MM_MIN_DIAG`` to ``UNITS_MM_MAX_DIAG`` mm of bounding-box
    diagonal), else the units given are likely wrong (issue #44: a coronary in millimetres fitted
    with ``--units cm`` spanned 724 mm, with no word)."""
    if label is None:
        if sc.warning is not None:
            log.warning("%s: bounding-box diagonal %.3g looks like %s, not millimetres; pass --units %s to convert "
                        "it (reports are then in millimetres), or --units mm if it is in millimetres", path,
                        sc.bbox_diagonal, UNIT_NAMES[sc.units_guess], sc.units_guess)
        return
    if not tol.UNITS_MM_MIN_DIAG <= sc.bbox_diagonal <= tol.UNITS_MM_MAX_DIAG:
        log.warning("%s converted from %s into millimetres has a bounding-box diagonal of %.3g mm, outside the "
                    "%g-%g mm of a vessel; check --units/--scale (--units mm if it is in millimetres already)", path,
                    label, sc.bbox_diagonal, tol.UNITS_MM_MIN_DIAG, tol.UNITS_MM_MAX_DIAG)


class _LibraryScaleWarnings(logging.Filter):
    """Drops the library's WARNINGs that a mesh's units look unusual (:func:`read_mesh_in` gave its own)."""

    def filter(self, record):
        msg = record.getMessage()
        return not (record.levelno == logging.WARNING
                    and any(f"looks like {name}" in msg for name in UNIT_NAMES.values()))


#: Loggers of the library functions that warn about a mesh's units.
_SCALE_LOGGERS = ("vesselgp.fit", "vesselgp.mesh.clean", "vesselgp.mesh.ends")


@contextlib.contextmanager
def library_scale_warnings_replaced():
    """While active, :func:`read_mesh_in`'s unit warnings (naming ``--units``) replace the library's.

    The library's own (:func:`vesselgp.clean_mesh`, :func:`vesselgp.fit_generalized_cylinder`)
    advise multiplying V; the command line runs every command in this context,
    so a mesh that looks like metres gets one warning, the one naming the option.
    """
    filt = _LibraryScaleWarnings()
    loggers = [logging.getLogger(n) for n in _SCALE_LOGGERS]
    for lg in loggers:
        lg.addFilter(filt)
    try:
        yield
    finally:
        for lg in loggers:
            lg.removeFilter(filt)


# ----------------------------------------------------------------------------- library results as dicts


def gc_to_dict(gc, units="mm"):
    """JSON-ready description of a :class:`vesselgp.GeneralizedCylinder` (``axis.json`` of ``vesselgp fit``)."""
    return {
        "units": units,
        "length": gc.length,
        "mean_radius": gc.mean_radius,
        "n_nodes": len(gc.s),
        "iterations": gc.iterations,
        "converged": gc.converged,
        "fit": "converged" if gc.converged else "stopped",
        "last_step": gc.last_step,
        "lam": gc.lam,
        "mu": gc.mu,
        "ends": list(gc.ends),
        "s": gc.s,
        "centers": gc.centers,
        "radii": gc.radii,
        "frames": {"T": gc.frames[:, 0], "U": gc.frames[:, 1], "V": gc.frames[:, 2]},
        "n_vertices": len(gc.vertex_s),
        "vertices_used": int(np.count_nonzero(gc.vertex_weight > 0)),
        "checks": None if gc.checks is None else gc.checks.to_dict(),
    }


def profile_to_dict(prof):
    """JSON-ready :class:`vesselgp.TorsionProfile` (degrees; Frenet torsion None where undefined)."""
    return {
        "energy": prof.energy,
        "total_twist_deg": math.degrees(prof.total_twist),
        "twist_per_length_deg": math.degrees(prof.twist_per_length),
        "length": prof.length,
        "s": prof.s,
        "alpha_deg": np.degrees(prof.alpha),
        "dalpha_deg": np.degrees(prof.dalpha),
        "curvature": prof.curvature,
        "frenet_torsion": np.where(prof.frenet_defined, prof.frenet_torsion, np.nan),
    }


def summary_table(cases):
    """Plain-text table (case, optimum angle, energy, evaluations, time) of demo/join results.

    The first column is as wide as the longest name (at least 8 characters): names are never cut.

    Examples
    --------
    >>> print(summary_table([{"name": "case 1", "optimum_angle_deg": -179.8, "energy": 4.6e-7,
    ...                       "n_evals": 9, "setup_time_s": 0.2, "time_s": 0.7}]))
    case     angle (deg)     energy  evals  setup (s)  search (s)
    case 1        -179.8    4.6e-07      9       0.20        0.70
    """
    n = max([8] + [len(str(c["name"])) for c in cases])
    rows = ["{:<{n}} {:>11} {:>10} {:>6} {:>10} {:>11}".format(
        "case", "angle (deg)", "energy", "evals", "setup (s)", "search (s)", n=n)]
    for c in cases:
        rows.append("{:<{n}} {:>11.1f} {:>10.3g} {:>6d} {:>10.2f} {:>11.2f}".format(
            str(c["name"]), c["optimum_angle_deg"], c["energy"], int(c["n_evals"]),
            c["setup_time_s"], c["time_s"], n=n))
    return "\n".join(rows)


def _progress_iter(progress, it, desc):
    if progress is None or progress is False:
        return it
    if progress is True:
        from tqdm.auto import tqdm

        return tqdm(it, desc=desc, leave=False)
    return progress(it, desc=desc)


# ----------------------------------------------------------------------------- fit, torsion


def run_fit(mesh, out, *, ends=None, root=None, n_nodes=None, lam=None, axis_format="both", shade="radius",
            units=None, scale=None, render=True):
    """Fit a generalized cylinder to a mesh file and write ``axis.*`` and the shaded mesh into ``out``.

    A mesh with more than two ends and no ``ends`` given is fitted as a tree
    (:func:`run_fit_tree`). Lengths in every output are millimetres (see :func:`read_mesh_in`).

    Parameters
    ----------
    mesh : str or os.PathLike
    out : OutputFolder
    ends : (int, int), optional
    root : int, optional
        The end the paths start from (default the widest); with two ends, the end the axis starts at.
    n_nodes : int, optional
    lam : float, optional
        Eq. 2's weight of the axis's bending (default ``tolerances.GC_LAMBDA``), for a tube or a tree.
    axis_format : {"vtp", "ply", "both"}
    shade : {"radius", "theta", "none"}
        The shaded mesh's quantity: distance to the axis (mm) or angle about it (degrees).
    units : {"mm", "cm", "m", "um"}, optional
        Length unit of the mesh file (default: millimetres).
    scale : float, optional
        Millimetres per mesh unit (instead of ``units``).
    render : bool

    Returns
    -------
    (GeneralizedCylinder, dict) or (VesselTree, dict)
        The fit and the contents of ``axis.json`` (``tree.json`` for a tree).
    """
    if ends is not None and root is not None:
        raise OptionError("give the root end (root=) or the two ends of one path (ends=), not both")
    V, F, uinfo = read_mesh_in(mesh, units, scale)
    pm = PreparedMesh(V, F)  # checked once: the ends, the fit, the centre lines' inscribed radius
    if ends is None and len(pm.ends) > 2:
        return run_fit_tree(pm, mesh, out, uinfo, root=root, lam=lam, axis_format=axis_format, render=render)
    if root is not None:
        r = root_end(pm.ends, root)
        ends = (r, 1 - r) if len(pm.ends) == 2 else ends
    t0 = time.perf_counter()
    gc = fit_generalized_cylinder(pm, ends=ends, n_nodes=n_nodes, lam=lam)
    dt = time.perf_counter() - t0
    found = tree_bulges((gc,), pm.sacs, (pm.V, pm.topology.adjacency))
    d = {**gc_to_dict(gc), **uinfo, "bulges": bulges_to_dicts(found)}
    d.update(bbox_diagonal=float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))), input=str(mesh), time_s=dt)
    write_json(out("axis.json"), d)
    fr = gc.frames
    cols = {"s": gc.s, "arclength": gc.s * gc.length}
    cols.update({c: gc.centers[:, i] for i, c in enumerate("xyz")})
    cols["radius"] = gc.radii
    cols.update({f"{n}{c}": fr[:, k, i] for k, n in enumerate("TUV") for i, c in enumerate("xyz")})
    write_csv(out("axis.csv"), cols)
    _write_centerlines(out, "axis", centerline_network(gc, pm), axis_format)
    theta, dist = np.degrees(gc.vertex_theta), np.hypot(gc.vertex_local[:, 1], gc.vertex_local[:, 2])
    Vv, Fv, theta_v, dist_v = _for_view(V, F, theta, dist) if render else (V, F, theta, dist)
    if shade != "none":
        if shade == "theta":
            val, lo, hi, cmap = theta, -180.0, 180.0, "twilight"
            label = "angle \u03b8 about the axis (deg)"
            caption = (f"Black line: the fitted axis. Colour: each vertex's angle \u03b8 about it, from the axis "
                       f"frame's U direction (0), right-handed about the axis from end {gc.ends[0]} to end "
                       f"{gc.ends[1]}.")
        else:
            val = dist
            lo, hi, cmap, label = float(val.min()), float(val.max()), "viridis", "distance to the axis (mm)"
            caption = ("Black line: the fitted axis. Colour: each vertex's distance to it in mm: a narrowing "
                       "(stenosis) shows dark, a bulge bright.")
        others = {"s": gc.vertex_s, "theta": theta, "radius": dist}
        _write_shaded(out, f"mesh_{shade}", V, F, torsion_colors(val, lo, hi, cmap),
                      {shade: val, **{k: v for k, v in others.items() if k != shade}})
        if render:
            render_mesh(out(f"mesh_{shade}.png"), Vv, Fv, theta_v if shade == "theta" else dist_v, vmin=lo, vmax=hi,
                        cmap=cmap, cbar_label=label,
                        title=f"{Path(mesh).name}: generalized cylinder, length {gc.length:.4g} mm, "
                              f"mean radius {gc.mean_radius:.3g} mm",
                        period=360.0 if shade == "theta" else None, lines=[gc.dense_points], caption=caption,
                        scale_bar="mm")
    if render:
        write_report_html(out("report.html"), f"{Path(mesh).name}: generalized cylinder",
                          [ViewMesh(Vv, Fv, dist_v, label="distance to the axis (mm)")], lines=[gc.dense_points],
                          labels=[(gc.centers[0], f"end {gc.ends[0]}"), (gc.centers[-1], f"end {gc.ends[1]}")],
                          figures=[out.dir / f"mesh_{shade}.png"], numbers=d,
                          caption=f"Length {gc.length:.4g} mm, mean radius {gc.mean_radius:.3g} mm. The surface is "
                                  "shaded by each vertex's distance to the fitted axis (the black line): a narrowing "
                                  "(stenosis) shows dark, a bulge bright. Drag to turn, scroll to zoom.")
    return gc, d


def _for_view(V, F, *values):
    """The mesh for the pictures and the 3D view, decimated once to ``tolerances.VIZ_MAX_FACES`` faces when it
    has more (pymeshlab's quadric collapse: seconds on a million faces), and each per-vertex array on it (the
    nearest original vertex's value: no blending, so periodic angles stay whole)."""
    if len(F) <= tol.VIZ_MAX_FACES:
        return (V, F, *values)
    from scipy.spatial import cKDTree

    V2, F2, _ = decimated(V, F, None, tol.VIZ_MAX_FACES, None)
    idx = cKDTree(V).query(V2)[1]
    return (V2, F2, *(np.asarray(v)[idx] for v in values))


def _write_centerlines(out, stem, network, axis_format):
    """``stem.vtp`` (VTK, ParaView, 3D Slicer, VMTK) and/or ``stem.ply`` (MeshLab) of centre lines."""
    for ext in (("vtp", "ply") if axis_format == "both" else (axis_format,)):
        write_centerlines(out(f"{stem}.{ext}"), network)


def _write_shaded(out, stem, V, F, colors, scalars):
    """A shaded mesh as ``stem.ply`` (MeshLab: colours and scalars) and ``stem.vtp`` (ParaView: the scalars as
    point data, the first one active, and the colours as ``Colors``)."""
    for ext in ("ply", "vtp"):
        write_mesh(out(f"{stem}.{ext}"), V, F, vertex_colors=colors, vertex_scalars=scalars)


def bulges_to_dicts(bulges):
    """JSON-ready list of :class:`vesselgp.bulges.Bulge` (``bulges`` of ``axis.json`` and ``tree.json``)."""
    return [{"paths": list(b.paths), "s_range": b.s_range, "s_peak": b.s_peak, "peak": b.peak,
             "peak_radius": b.peak_radius, "neighbour_radius": b.neighbour_radius, "ratio": b.ratio} for b in bulges]


def tree_to_dict(tree, units="mm"):
    """JSON-ready description of a :class:`vesselgp.tree.VesselTree` (``tree.json`` of ``vesselgp fit``)."""
    def branch(b, gc):
        return {"id": b, "parent": int(tree.parent[b]), "ends": list(gc.ends), "length": gc.length,
                "mean_radius": gc.mean_radius, "iterations": gc.iterations, "converged": gc.converged,
                "fit": tree.branch_fit[b], "last_step": gc.last_step,
                "n_vertices": int(np.count_nonzero(tree.vertex_branch == b)), "s": gc.s, "centers": gc.centers,
                "radii": gc.radii, "frames": {"T": gc.frames[:, 0], "U": gc.frames[:, 1], "V": gc.frames[:, 2]},
                "junction_zone": float(tree.junction_zone[b]),
                "medial_zones": [[float(a), float(c)] for a, c in tree.medial_zones[b]]}
    return {
        "units": units, "n_ends": len(tree.ends), "root": tree.root,
        "ends": [{"index": i, "kind": e.kind, "radius": float(e.radius), "center": np.asarray(e.center, float),
                  "direction": np.asarray(e.direction, float)} for i, e in enumerate(tree.ends)],
        "junctions": [{"point": q, "branch": int(b), "children": [int(c) for c in np.flatnonzero(tree.parent == b)]}
                      for q, b in zip(tree.junctions, tree.junction_branch)],
        "branches": [branch(b, gc) for b, gc in enumerate(tree.branches)],
        "paths": [{"ends": list(p.ends), "branches": list(c), "length": p.length, "mean_radius": p.mean_radius,
                   "min_radius": float(p.radii.min()), "max_radius": float(p.radii.max())}
                  for p, c in zip(tree.paths, tree.path_branches)],
        "bulges": bulges_to_dicts(tree.bulges),
        "converged": all(gc.converged for gc in tree.branches),
        "n_vertices": len(tree.vertex_branch),
        "checks": tree.checks.to_dict(),
    }


def run_fit_tree(pm, mesh, out, uinfo, *, root=None, lam=None, axis_format="both", render=True):
    """Fit a branching mesh as a vessel tree and write ``tree.*`` and the branch-coloured mesh into ``out``.

    Parameters
    ----------
    pm : PreparedMesh
        The mesh in millimetres, checked, with its ends (and blind sacs) found.
    mesh : str or os.PathLike
        The input file (named in the report and the picture).
    out : OutputFolder
    uinfo : dict
        Units of the input (:func:`read_mesh_in`).
    root : int, optional
        The root end (default the widest; ``tree.json`` says which: ``root_chosen``).
    lam : float, optional
        Eq. 2's weight of the branch axes' bending (default ``tolerances.GC_LAMBDA``).
    axis_format : {"vtp", "ply", "both"}
    render : bool

    Returns
    -------
    (VesselTree, dict)
        The tree and the contents of ``tree.json``. ``tree.vtp`` / ``tree.ply``
        hold one polyline per branch with point data ``Radius`` (also as
        ``MaximumInscribedSphereRadius``, VMTK's and 3D Slicer's name) and
        ``Abscissa`` (mm from the branch start), and cell data ``BranchId``
        and ``ParentId``; ``mesh_branches.ply`` has each vertex's ``branch``.
    """
    t0 = time.perf_counter()
    V, F = pm.V, pm.F
    tree = fit_vessel_tree(pm, root=root, lam=lam)
    dt = time.perf_counter() - t0
    d = {**tree_to_dict(tree), "root_chosen": "widest" if root is None else "given", **uinfo, "bbox_diagonal": float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))),
         "input": str(mesh), "time_s": dt}
    write_json(out("tree.json"), d)
    _write_centerlines(out, "tree", centerline_network(tree, pm), axis_format)
    vb = tree.vertex_branch.astype(float)
    ncol = 10 if len(tree.branches) <= 10 else 20  # one colour of the qualitative map per branch (cycled)
    cmap, shade = f"tab{ncol}", np.mod(vb, ncol)
    _write_shaded(out, "mesh_branches", V, F, torsion_colors(shade, -0.5, ncol - 0.5, cmap), {"branch": vb})
    if render:
        nb, nj = len(tree.branches), len(tree.junctions)
        used = min(nb, ncol)  # the colour bar shows the colours in use (the same as mesh_branches.ply's)
        from scipy.spatial import cKDTree

        axes = np.vstack([gc.dense_points for gc in tree.branches])
        which = "the widest" if root is None else "the root given"
        Vv, Fv, shade_v = _for_view(V, F, shade)
        render_mesh(out("tree.png"), Vv, Fv, shade_v, vmin=-0.5, vmax=used - 0.5, cmap=first_colors(cmap, used),
                    cbar_label="branch (id in tree.json)", alpha=tol.VIZ_TREE_ALPHA,
                    lines=[gc.dense_points for gc in tree.branches], cbar_ticks=range(used), scale_bar="mm",
                    title=f"{Path(mesh).name}: {nb} branch{'es' * (nb != 1)}, {nj} junction{'s' * (nj != 1)}, "
                          f"{len(tree.paths)} paths; axes {sum(gc.length for gc in tree.branches):.0f} mm in all",
                    caption=f"Black lines: the branch axes; the translucent surface is coloured by branch. The "
                            f"paths run from end {tree.root} ({which}) to each other end.")
        write_report_html(out("report.html"), f"{Path(mesh).name}: vessel tree",
                          [ViewMesh(Vv, Fv, cKDTree(axes).query(Vv)[0], label="distance to the axis (mm)")],
                          lines=[gc.dense_points for gc in tree.branches],
                          labels=[(e.center, f"end {i}") for i, e in enumerate(tree.ends)],
                          figures=[out.dir / "tree.png"], numbers=d,
                          caption=f"{len(tree.branches)} branches, {len(tree.junctions)} junctions, {len(tree.paths)} "
                                  f"paths from end {tree.root} ({which}). The surface is shaded by each vertex's "
                                  "distance to the nearest branch axis (black lines). Drag to turn, scroll to zoom.")
    return tree, to_json(d)


def run_torsion(rest, deformed, out, *, smoothing=None, ends=None, units=None, scale=None, render=True):
    """Material torsion of a deformed mesh file against its rest mesh file; writes ``profile.*`` and a shaded mesh.

    Parameters
    ----------
    rest, deformed : str or os.PathLike
        Mesh files with the same vertices and faces.
    out : OutputFolder
    smoothing : float, optional
        Smoothing length of alpha(s) (:class:`vesselgp.TorsionMeter`).
    ends : (int, int), optional
        The ends of the rest fit (:func:`vesselgp.fit_generalized_cylinder`).
    units, scale : optional
        Length unit of both files, or millimetres per mesh unit (:func:`read_mesh_in`).
    render : bool

    Returns
    -------
    (TorsionProfile, dict)
        The profile and the contents of ``profile.json``.

    Raises
    ------
    MismatchError
        When the two meshes do not share vertices and faces.
    """
    V0, F0, uinfo = read_mesh_in(rest, units, scale)
    V1, F1, _ = read_mesh_in(deformed, units, scale)
    if V0.shape != V1.shape or F0.shape != F1.shape or not np.array_equal(F0, F1):
        raise MismatchError(f"rest ({len(V0)} vertices, {len(F0)} faces) and deformed ({len(V1)} vertices, "
                            f"{len(F1)} faces) meshes must share vertices and faces")
    t0 = time.perf_counter()
    rest_fit = fit_generalized_cylinder(V0, F0, ends=ends)
    prof = TorsionMeter(V0, F0, rest_fit, smoothing=smoothing)(V1)
    dt = time.perf_counter() - t0
    d = {"command": "torsion", "rest": str(rest), "deformed": str(deformed), **uinfo, "time_s": dt,
         **profile_to_dict(prof)}
    write_json(out("profile.json"), d)
    write_csv(out("profile.csv"), {k: d[k] for k in ("s", "alpha_deg", "dalpha_deg", "curvature", "frenet_torsion")})
    al = np.degrees(prof.vertex_alpha)
    _write_shaded(out, "deformed_twist", V1, F1, torsion_colors(al), {"alpha_deg": al})
    _write_centerlines(out, "axis", centerline_network(rest_fit, V0, F0,
                                                       twist=lambda b, s: np.interp(s, prof.s, prof.alpha)), "vtp")
    if render:
        e0, e1 = rest_fit.ends
        render_mesh(out("deformed_twist.png"), V1, F1, al, cbar_label=f"material twist \u03b1 (deg), 0 at end {e0}",
                    title=f"{Path(deformed).name}: material twist {np.degrees(prof.total_twist):+.1f}\u00b0 from end "
                          f"{e0} to end {e1} over {prof.length:.3g}\u00a0mm; E\u00a0=\u00a0{prof.energy:.3g}\u00a0rad\u00b2 "
                          f"(Eq.\u00a08)",
                    caption=f"Colour: each cross-section's material twist \u03b1 about the axis against "
                            f"{Path(rest).name}, 0 (white) at end {e0}; red turns right-handed about the axis "
                            f"pointing from end {e0} to end {e1}, blue left-handed.", scale_bar="mm")
        plot_torsion_profile(out("profile.png"), prof, origin=f"end {e0}")
        m = max(float(np.max(np.abs(al))), tol.VIZ_MIN_RANGE)
        write_report_html(out("report.html"), f"{Path(deformed).name}: material torsion against {Path(rest).name}",
                          [ViewMesh(V1, F1, al, label="material twist \u03b1 (deg)", cmap="RdBu_r", vrange=(-m, m))],
                          lines=[prof.centers],
                          figures=[out.dir / "deformed_twist.png", out.dir / "profile.png"], numbers=d,
                          caption=f"The deformed vessel shaded by its material twist \u03b1 (degrees, Eq. 6) about "
                                  f"its axis, 0 at the rest fit's s = 0 end: red turns positively (right-handed "
                                  f"about the axis from s = 0), blue negatively. Total twist "
                                  f"{np.degrees(prof.total_twist):.1f}\u00b0, energy {prof.energy:.3g} (Eq. 8).")
    return prof, d


# ----------------------------------------------------------------------------- one join


#: Files :func:`run_join` may write (checked against the inputs before anything is written).
JOIN_FILES = ("optimum.ply", "large_torsion.ply", "optimum.vtp", "large_torsion.vtp", "joined_optimum.vtp", "report.html",
              "energy_curve.csv", "result.json", "joined_optimum.ply",
              "optimum.png", "large_torsion.png", "energy_curve.png", "profile_optimum.png",
              "profile_large_torsion.png")


def join_inputs(vessel, *, case=None, fixed=None, moving=None, target=None, other=None, other_end=None,
                units=None, scale=None):
    """Read what a join needs: the vessel, held and moving ids, target, and the other vessel.

    Either ``case`` (a ``case.json``, which also names the other vessel's file)
    or all of ``fixed``, ``moving`` and ``target`` must be given; ``other`` and
    ``other_end`` override the case's. Both meshes and the target's origin are
    in the units ``units``/``scale`` and are converted into millimetres
    (:func:`read_mesh_in`).

    Returns
    -------
    dict
        ``V, F, fixed, moving, target, other`` (``(V2, F2, other_end)`` or None), ``inputs``
        (every file read), ``units`` (:func:`read_mesh_in`) and ``moving_normal`` (the case's
        anchor at the moving end, or None).
    """
    V, F, uinfo = read_mesh_in(vessel, units, scale)
    inputs = [vessel, case, other]
    case_other_end = None
    moving_normal = None
    if case is not None:
        c = read_case(case, len(V))
        fixed, moving, target, case_other_end, case_other = (c[k] for k in ("fixed", "moving", "target",
                                                                            "other_end", "other"))
        moving_normal = c["moving_normal"]
        if other is None and case_other is not None:
            log.info("the vessel joined to is %s (named by %s)", case_other, case)
            other = case_other
            inputs.append(other)
    elif fixed is None or moving is None or target is None:
        raise VesselError("give a case file or all of the held ids, the moving ids and the target frame")
    other_end = case_other_end if other_end is None else other_end
    o = None
    if other is not None:
        Vo, Fo, _ = read_mesh_in(other, units, scale)
        o = (Vo, Fo, other_end)
    if uinfo["to_mm"] != 1.0:
        target = replace(target, origin=np.asarray(target.origin) * uinfo["to_mm"])
    return {"V": V, "F": F, "fixed": fixed, "moving": moving, "target": target, "other": o, "inputs": inputs,
            "units": uinfo, "moving_normal": moving_normal}


def _join_search(V, F, fixed, moving, target, method, ends, moving_normal):
    """Fit, problem set-up and :func:`minimize_torsion`; times of both."""
    t0 = time.perf_counter()
    gc = fit_generalized_cylinder(V, F, ends=ends)
    problem = JoinProblem(V, F, fixed, moving, target, method=method, gc=gc, moving_normal=moving_normal)
    t1 = time.perf_counter()
    res = minimize_torsion(problem)
    return problem, res, {"setup_time_s": t1 - t0, "time_s": time.perf_counter() - t1}


def _toward_joined_end(problem):
    """+1 when the joined end lies at larger ``s`` of the rest fit than the held part, else -1: the sign that
    turns the fit's alpha into twist right-handed about the axis pointing from the held part to the joined end
    (so turning the joined end by a positive angle twists it positively, red, whichever end s = 0 is)."""
    s = problem.gc.vertex_s
    return 1.0 if np.mean(s[problem.moving]) >= np.mean(s[problem.fixed]) else -1.0


def _twist_relative_to_held(prof, fixed, toward=1.0):
    """Vertex twist in degrees relative to the held part (0 there; alpha(0) = 0 at s = 0 may be the moving end),
    times ``toward`` (:func:`_toward_joined_end`)."""
    return toward * np.degrees(prof.vertex_alpha - np.median(prof.vertex_alpha[fixed]))


def wrap_deg(a):
    """An angle in radians as degrees wrapped to (-180, 180] (how every report gives angles)."""
    return float(np.degrees(wrap_angle(float(a))))


#: What ``result.json`` says angle 0 and the sign of a rotation mean.
ANGLE_REFERENCE = (
    "angles are degrees in (-180, 180]; angle 0 puts the anchor moving_normal (a direction across the moving "
    "end, at rest) on target_normal (across the target end); a positive angle turns the end right-handed "
    "about the target tangent (the axis direction out of the moving vessel, into the other one); roll_deg "
    "is the optimum minus the zero-twist angle: how far the end is turned beyond the twist-free placement"
)


def _marks(problem, X, angle):
    """Lines drawn over a join render of ``X`` (the deformation at ``angle``): the end ring, the target
    normal and the moving anchor's image."""
    ring = X[problem.moving]
    ring = np.concatenate([ring, ring[:1]])
    o = problem.target.origin
    r = float(problem.gc.radius_at([problem.deformer.s_end])[0]) * tol.VIZ_ANCHOR_LENGTH
    Q, _ = problem.placement.end_map(angle)
    Qi, _ = problem.placement.end_map(0.0)
    # end_map(angle) maps the fit's U; the anchor's image is turned with it
    m = Q @ (Qi.T @ problem.target.normal)
    return [ring, np.stack([o, o + r * problem.target.normal]), np.stack([o, o + 0.8 * r * m])]


#: Caption of the join renders: what the colours, zero and the lines mean.
JOIN_RENDER_CAPTION = (
    "Colour: each cross-section's material twist \u03b1 relative to the held part (0, white); red turns "
    "right-handed about the axis pointing towards the joined end, blue left-handed. Sand: the vessel joined to. "
    "Black at the joined end: its ring (the seam), the target normal (long tick) and where the anchor went "
    "(short tick).")


def _write_join_states(out, F, states, m, others, name, large_deg, prefix, render, problem, toward=1.0):
    """Shaded meshes, renders and profiles of the optimum and the large-torsion state (twist ``al`` of each
    relative to the held part, oriented by ``toward``, :func:`_toward_joined_end`)."""
    files = {}
    label = "material twist \u03b1 (deg), 0 at the held part"
    for key, X, al, prof, ang in states:
        _write_shaded(lambda name: out / name, key, X, F, torsion_colors(al, -m, m), {"alpha_deg": al})
        files[f"{key}_mesh"] = prefix + f"{key}.ply"
        files[f"{key}_vtp"] = prefix + f"{key}.vtp"
        if render:
            what = "minimum torsion" if key == "optimum" else f"large torsion, the optimum {large_deg:+.0f}\u00b0"
            at_end = float(np.median(al[problem.moving]))  # the colour of the joined end
            render_mesh(out / f"{key}.png", X, F, al, vmin=-m, vmax=m, others=others, cbar_label=label,
                        title=f"{name}: {what}\njoined end turned {wrap_deg(ang):+.1f}\u00b0 from the anchor;\n"
                              f"twist there {at_end:+.1f}\u00b0 from the held part; E\u00a0=\u00a0{prof.energy:.3g}\u00a0rad\u00b2",
                        lines=_marks(problem, X, ang), caption=JOIN_RENDER_CAPTION, scale_bar="mm")
            plot_torsion_profile(out / f"profile_{key}.png", prof, reverse=toward < 0, origin="the held end",
                                 zero=float(np.median(prof.vertex_alpha[problem.fixed])),
                                 title=f"{name}: {what}; twist {np.degrees(prof.total_twist):+.1f}\u00b0 over "
                                       f"{prof.length:.3g}\u00a0mm, E\u00a0=\u00a0{prof.energy:.3g}\u00a0rad\u00b2 (Eq.\u00a08)")
            files[f"{key}_png"] = prefix + f"{key}.png"
            files[f"profile_{key}_png"] = prefix + f"profile_{key}.png"
    return files


def _write_joined(out, Vj, Fj, n_moving, al_opt, m, prefix):
    """The optimum stitched to the other vessel, coloured (the other vessel in ``VIZ_OTHER_COLOR``)."""
    cj = np.full((len(Vj), 3), np.round(np.array(tol.VIZ_OTHER_COLOR) * 255), dtype=np.uint8)
    cj[:n_moving] = torsion_colors(al_opt, -m, m)
    aj = np.zeros(len(Vj))
    aj[:n_moving] = al_opt
    _write_shaded(lambda name: out / name, "joined_optimum", Vj, Fj, cj, {"alpha_deg": aj})
    return {"joined_mesh": prefix + "joined_optimum.ply", "joined_vtp": prefix + "joined_optimum.vtp"}


def run_join(outdir, V, F, fixed, moving, target, *, other=None, name="join", n_curve=None,
             curve_range_deg=None, large_deg=None, method="rod_arap", ends=None, progress=None, prefix="",
             render=True, moving_normal=None):
    """Minimum-torsion join of one vessel end given by ids and a target frame, with the paper's figures (Figs. 2-4).

    Builds a :class:`vesselgp.JoinProblem`, runs :func:`vesselgp.minimize_torsion`
    and writes the files of :func:`write_join_outputs` into ``outdir``.

    Parameters
    ----------
    outdir : str or os.PathLike
        Existing folder.
    V : (n, 3) float64
    F : (m, 3) int64
    fixed, moving : (p,), (q,) int
        Held vertices and the joined end ring.
    target : Frame
    other : (V2, F2, loop_ids) or (V2, F2), optional
        The vessel joined to: drawn in the renders, stitched when its end ring is given.
    name : str
    n_curve, curve_range_deg, large_deg, progress, prefix, render
        See :func:`write_join_outputs`.
    method : str
        Deformation method (:class:`vesselgp.JoinProblem`).
    ends : optional
        Ends for the rest fit (default: found by :func:`vesselgp.vessel_ends`).
    moving_normal : (3,) float64, optional
        The anchor at the moving end that lands on ``target.normal`` at angle 0
        (:class:`vesselgp.JoinProblem`; default the fit's U).

    Returns
    -------
    dict
        The fields of :data:`REPORT_FIELDS`.
    """
    problem, res, times = _join_search(V, F, fixed, moving, target, method, ends, moving_normal)
    joined = None
    if other is not None and len(other) > 2 and other[2] is not None:
        joined = stitch(res.V, problem.F, problem.moving, other[0], other[1], other[2])
    others = [] if other is None else [(other[0], other[1])]
    return write_join_outputs(outdir, problem, res, times, others=others, joined=joined, name=name,
                              n_curve=n_curve, curve_range_deg=curve_range_deg, large_deg=large_deg,
                              progress=progress, prefix=prefix, render=render)


def join_vessels_inputs(vessel, onto, end, other_end, *, hold=None, method="rod_arap", max_stretch=None,
                        moving_normal=None, target_normal=None, units=None, scale=None, place=None):
    """Read two vessel files and set up their join by end index (:class:`vesselgp.VesselJoin`).

    Everything that can refuse the join happens here, before any output is written.

    Returns
    -------
    dict
        ``join`` (the :class:`vesselgp.VesselJoin`), ``inputs`` (both files) and ``units``.
    """
    V, F, uinfo = read_mesh_in(vessel, units, scale)
    Vo, Fo, _ = read_mesh_in(onto, units, scale)
    join = VesselJoin(V, F, end, Vo, Fo, other_end, hold=hold, method=method, max_stretch=max_stretch,
                      moving_normal=moving_normal, target_normal=target_normal, place=place)
    return {"join": join, "inputs": [vessel, onto], "units": uinfo}


def run_join_vessels(outdir, join, *, name="join", n_curve=None, curve_range_deg=None, large_deg=None,
                     progress=None, render=True):
    """Solve a :class:`vesselgp.VesselJoin` (two vessels by end index) and write :func:`write_join_outputs`'s files.

    Returns
    -------
    dict
        The fields of :data:`REPORT_FIELDS`, plus ``end``, ``other_end_center``
        and the number of vertices of the joined mesh.
    """
    t0 = time.perf_counter()
    res = join.solve()
    times = {"setup_time_s": join.setup_time_s, "time_s": time.perf_counter() - t0}
    r = write_join_outputs(outdir, join.problem, res, times, others=[(join.other_V, join.other_F)],
                           joined=(res.joined_V, res.joined_F), name=name, n_curve=n_curve,
                           curve_range_deg=curve_range_deg, large_deg=large_deg, progress=progress, render=render)
    r["joined_n_vertices"] = len(res.joined_V)
    r["held_vertices"] = len(res.fixed)
    return r


def placement_to_dict(M, point):
    """What ``join_vessels(place=)`` did to the moving vessel (``placement`` of ``result.json``): None, or the
    (4, 4) matrix, the rotation's angle in degrees and how far ``point`` (the joined end's centre, moved)
    moved, in mm."""
    if M is None:
        return None
    R, t = M[:3, :3], M[:3, 3]
    turned = math.degrees(Rotation.from_matrix(R).magnitude())
    c = np.asarray(point, float)  # where it is now; it came from R^T (c - t)
    return {"matrix": M, "turned_deg": turned, "moved_mm": float(np.linalg.norm(c - R.T @ (c - t)))}


def write_join_outputs(outdir, problem, res, times, *, others=(), joined=None, name="join", n_curve=None,
                       curve_range_deg=None, large_deg=None, progress=None, prefix="", render=True):
    """The energy curve about a join's optimum and the files of paper Figs. 2-4.

    Writes into ``outdir``:

    * ``optimum.ply`` / ``.png``: the deformed vessel at the optimum, vertex
      colours from the twist ``alpha`` relative to the held vertices (degrees,
      right-handed about the axis pointing from the held part to the joined end,
      also stored as the PLY property ``alpha_deg``); ``large_torsion.ply`` / ``.png``: the same at
      ``optimum + large_deg`` (paper Figs. 2-3 (e) and (a, c)); both use one
      colour range; the renders draw the vessel joined to in sand
      (``tolerances.VIZ_OTHER_COLOR``), the end ring (the seam) and two ticks
      at the target: the target normal (long) and where the moving anchor
      went (short; they coincide at angle 0);
    * ``energy_curve.png`` / ``.csv``: Fig. 4;
    * ``profile_optimum.png``, ``profile_large_torsion.png``: ``alpha`` (degrees, 0 at the held part) and its
      rate (degrees per mm) against the arc length from the held end (mm);
    * ``joined_optimum.ply``: the stitched mesh, when ``joined`` is given.

    Parameters
    ----------
    outdir : str or os.PathLike
        Existing folder.
    problem : JoinProblem
    res : JoinResult
        Its optimum (:func:`vesselgp.minimize_torsion`).
    times : dict
        ``setup_time_s`` and ``time_s``, copied into the result.
    others : sequence of (V, F)
        Meshes drawn for context.
    joined : (V, F), optional
        The optimum stitched to the other vessel (moving vessel's vertices first).
    name : str
    n_curve : int, optional
        Points of the energy curve (``tolerances.DEMO_CURVE_POINTS``).
    curve_range_deg : float, optional
        Half-width of the curve about the optimum (``DEMO_CURVE_RANGE_DEG``).
    large_deg : float, optional
        Rotation from the optimum of the "large torsion" configuration (``DEMO_LARGE_TORSION_DEG``).
    progress : None, bool or callable
        Progress bar over the energy curve: True for tqdm, or a ``tqdm``-like callable.
    prefix : str
        Prepended to the file names listed in ``files``.
    render : bool
        Write the PNGs.

    Returns
    -------
    dict
        The fields of :data:`REPORT_FIELDS`.
    """
    n_curve = tol.DEMO_CURVE_POINTS if n_curve is None else int(n_curve)
    curve_range_deg = tol.DEMO_CURVE_RANGE_DEG if curve_range_deg is None else float(curve_range_deg)
    large_deg = tol.DEMO_LARGE_TORSION_DEG if large_deg is None else float(large_deg)
    out = Path(outdir)
    t2 = time.perf_counter()
    half = math.radians(curve_range_deg)
    angles = res.angle + np.linspace(-half, half, int(n_curve))
    energies = np.array([problem.energy(a) for a in _progress_iter(progress, angles, f"{name}: energy curve")])
    times = {**times, "curve_time_s": time.perf_counter() - t2}
    t3 = time.perf_counter()
    a_large = res.angle + math.radians(large_deg)
    p_large = problem.profile(a_large)
    toward = _toward_joined_end(problem)
    al_opt = _twist_relative_to_held(res.profile, problem.fixed, toward)
    al_large = _twist_relative_to_held(p_large, problem.fixed, toward)
    m = max(float(np.max(np.abs(al_large))), float(np.max(np.abs(al_opt))), tol.VIZ_MIN_RANGE)
    states = (("optimum", res.V, al_opt, res.profile, res.angle),
              ("large_torsion", problem.deform(a_large), al_large, p_large, a_large))
    files = _write_join_states(out, problem.F, states, m, list(others), name, large_deg, prefix, render, problem,
                               toward)
    write_csv(out / "energy_curve.csv", {"angle_deg": np.degrees(angles), "energy": energies})
    files["energy_curve_csv"] = prefix + "energy_curve.csv"
    if render:
        plot_energy_curve(out / "energy_curve.png", angles, energies, optimum=(res.angle, res.energy),
                          evaluated=(res.angles, res.energies), relative_to=res.angle,
                          title=f"{name}: torsion energy against the rotation of the joined end (paper Fig. 4)",
                          caption=f"The minimum is the joined end turned {wrap_deg(res.angle):+.1f}\u00b0 from the "
                                  f"anchor (0: the moving anchor on the target normal; positive: right-handed "
                                  f"about the target tangent, into the other vessel). " + ENERGY_IN_WORDS)
        files["energy_curve_png"] = prefix + "energy_curve.png"
    if joined is not None:
        files.update(_write_joined(out, joined[0], joined[1], len(res.V), al_opt, m, prefix))
    log.info("%s: optimum %.2f deg, E = %.4g, %d evaluations, %.2f s search", name, wrap_deg(res.angle),
             res.energy, res.n_evals, times["time_s"])
    r = {
        "name": name, "n_vertices": int(np.shape(res.V)[0]), "n_faces": len(problem.F),
        "optimum_angle_deg": wrap_deg(res.angle), "roll_deg": wrap_deg(res.roll), "energy": res.energy,
        "total_twist_deg": math.degrees(res.profile.total_twist),
        "zero_twist_angle_deg": wrap_deg(res.zero_twist_angle), "n_evals": res.n_evals,
        "status": res.status_name, "grid_scan": res.grid_scan,
        "angle_reference": ANGLE_REFERENCE, "moving_normal": res.moving_normal, "target_normal": res.target_normal,
        "target_origin": problem.target.origin, "target_tangent": problem.target.tangent,
        "axial_stretch": res.axial_stretch, "max_bend": res.max_bend, "max_edge_stretch": res.max_edge_stretch,
        **times, "output_time_s": time.perf_counter() - t3,
        "large_torsion": {"angle_deg": wrap_deg(a_large), "energy": p_large.energy,
                          "total_twist_deg": math.degrees(p_large.total_twist)},
        "energy_curve": {"angles_deg": np.degrees(angles), "energies": energies},
        "evaluations": {"angles_deg": np.degrees(res.angles), "energies": res.energies},
        "placement": placement_to_dict(res.placement, problem.V[problem.moving].mean(axis=0)),
        "files": files,
    }
    if render:
        _join_report(out / "report.html", problem, res, al_opt, m, others, name, r, prefix)
    return r


def _join_report(path, problem, res, al_opt, m, others, name, r, prefix):
    """``report.html`` of a join: the optimum shaded by its twist, the vessel joined to, the figures, the numbers."""
    moved = "" if r["placement"] is None else (
        f" The moving vessel was first placed against the other end: turned {r['placement']['turned_deg']:.1f}\u00b0"
        f" and its end moved {r['placement']['moved_mm']:.1f} mm.")
    files = r["files"]
    write_report_html(
        path, f"{name}: minimum-torsion join",
        [ViewMesh(res.V, problem.F, al_opt, label="material twist \u03b1 (deg)", cmap="RdBu_r", vrange=(-m, m),
                  name="joined vessel")] + [ViewMesh(Vo, Fo, name="vessel joined to") for Vo, Fo in others],
        lines=[res.profile.centers], labels=[(problem.target.origin, "joined end")],
        figures=[Path(path).parent / files[k][len(prefix):] for k in
                 ("optimum_png", "energy_curve_png", "profile_optimum_png", "large_torsion_png") if k in files],
        numbers={k: v for k, v in r.items() if k not in ("files",)},
        caption=f"The joined vessel at the end rotation of least torsion ({r['optimum_angle_deg']:+.1f}\u00b0 from the "
                f"anchor), shaded by its material twist \u03b1 in degrees relative to the held part (0 there): red "
                f"turns right-handed about the axis pointing towards the joined end, blue left-handed. The vessel "
                f"joined to is drawn in sand. Energy "
                f"{r['energy']:.3g} (Eq. 8), total twist {r['total_twist_deg']:+.2f}\u00b0.{moved}")


# ----------------------------------------------------------------------------- the demo


def run_demo(outdir, *, resolution=1.0, n_curve=None, cases=(1, 2), pre_rotation=0.0, progress=None,
             render=True):
    """Run both joining cases of the paper (Section 3) on generated data and write the figures.

    For case ``k`` the folder ``outdir/case<k>`` gets the files of
    :func:`run_join` plus the case files of :func:`vesselgp.io.write_case`
    (``vessel.ply``, ``other.ply``, ``case.json``); ``outdir/report.json``
    collects the results.

    Parameters
    ----------
    outdir : str or os.PathLike
        Output folder (created; existing files of the same names are replaced).
    resolution : float
        Mesh resolution multiplier of :func:`vesselgp.synthetic.paper_case`
        (1.0: about 8k and 14k vertices; 0.3 for quick tests).
    n_curve : int, optional
        Points of each energy curve.
    cases : sequence of {1, 2}
    pre_rotation : float
        Error of the given anchor (radians), see :func:`vesselgp.synthetic.paper_case`.
    progress : None, bool or callable
        Progress bars (see :func:`run_join`).
    render : bool
        Write the PNGs.

    Returns
    -------
    dict
        ``{"version", "resolution", "cases": [...], "total_time_s", "fields"}``,
        also written to ``outdir/report.json``; each case has the fields of
        :data:`REPORT_FIELDS` plus ``case`` (1 or 2) and ``generate_time_s``.

    Examples
    --------
    >>> import tempfile
    >>> rep = run_demo(tempfile.mkdtemp(), resolution=0.25, n_curve=5, cases=(1,), render=False)
    >>> rep["cases"][0]["n_evals"] > 3, sorted(rep)
    (True, ['cases', 'fields', 'resolution', 'total_time_s', 'version'])
    """
    from ._version import __version__

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    T0 = time.perf_counter()
    results = []
    for n in cases:
        t0 = time.perf_counter()
        case = paper_case(int(n), resolution=resolution, pre_rotation=pre_rotation)
        tg = time.perf_counter() - t0
        sub = out / f"case{n}"
        sub.mkdir(exist_ok=True)
        write_case(sub, case, resolution)
        target = Frame(case.target_origin, case.target_tangent, case.target_normal)
        r = run_join(sub, case.V, case.F, case.fixed, case.moving, target,
                     other=(case.other_V, case.other_F, case.other_end), name=f"case {n}",
                     n_curve=n_curve, progress=progress, prefix=f"case{n}/", render=render,
                     moving_normal=case.moving_normal)
        r["files"].update({"vessel": f"case{n}/vessel.ply", "other": f"case{n}/other.ply",
                           "case_json": f"case{n}/case.json"})
        r = {"case": int(n), "title": case.name, **r, "generate_time_s": tg}
        write_json(sub / "result.json", r)
        results.append(r)
    report = {"version": __version__, "resolution": float(resolution), "cases": results,
              "total_time_s": time.perf_counter() - T0, "fields": REPORT_FIELDS}
    write_json(out / "report.json", report)
    return report


# ----------------------------------------------------------------------------- twist between two scans


#: Files :func:`write_twist` may write.
TWIST_FILES = ("twist.json", "twist.csv", "twist_scans.png", "twist_profile.png", "report.html")


def twist_scans(scan_a, scan_b, *, ends_a=None, ends_b=None, units=None, scale=None):
    """Read two scans and measure the twist between them (:func:`vesselgp.twist_between`).

    Nothing is written: a refusal leaves no output behind.

    Returns
    -------
    dict
        ``result`` (:class:`vesselgp.ScanTwist`), ``A`` and ``B`` (``(V, F)`` in mm),
        ``inputs``, ``units`` and ``time_s``.
    """
    Va, Fa, uinfo = read_mesh_in(scan_a, units, scale)
    Vb, Fb, _ = read_mesh_in(scan_b, units, scale)
    t0 = time.perf_counter()
    r = twist_between(Va, Fa, Vb, Fb, ends_a=ends_a, ends_b=ends_b)
    return {"result": r, "A": (Va, Fa), "B": (Vb, Fb), "inputs": [scan_a, scan_b], "units": uinfo,
            "time_s": time.perf_counter() - t0}


def twist_to_dict(r):
    """JSON-ready :class:`vesselgp.ScanTwist` (lengths in mm, angles in degrees, rates in degrees per cm)."""
    seg = np.degrees(r.segment_twist)
    return {
        "n_landmarks": len(r.s_a), "ends_a": list(r.ends_a), "ends_b": list(r.ends_b),
        "length_a": r.length_a, "length_b": r.length_b,
        "landmarks_a": r.landmarks_a, "landmarks_b": r.landmarks_b, "s_a": r.s_a, "s_b": r.s_b,
        "azimuth_a_deg": np.degrees(r.azimuth_a), "azimuth_b_deg": np.degrees(r.azimuth_b),
        "side_radius_a": r.radius_a, "side_radius_b": r.radius_b,
        "segment_twist_deg": seg, "segment_length_a": r.segment_length_a, "segment_length_b": r.segment_length_b,
        "twist_per_length_deg_per_cm": np.degrees(r.twist_per_length) * 10.0, "stretch": r.stretch,
        "cumulative_twist_deg": np.concatenate([[0.0], np.cumsum(seg)]),
        "total_twist_deg": math.degrees(r.total_twist),
        "segment_uncertainty_deg": np.degrees(r.segment_uncertainty), "unreliable": r.unreliable,
        "cumulative_uncertainty_deg": np.degrees(r.cumulative_uncertainty),
        "landmark_uncertainty_a_deg": np.degrees(r.landmark_uncertainty_a),
        "landmark_uncertainty_b_deg": np.degrees(r.landmark_uncertainty_b),
        "side_angle_a_deg": np.degrees(r.angle_a), "divides_a": r.divides_a, "divides_b": r.divides_b,
        "main_axis_a": r.main_axis_a, "main_axis_b": r.main_axis_b,
        "uncertainty": "half-width of the 95 % interval (degrees)",
        "unmatched_s_a": r.unmatched_a, "unmatched_s_b": r.unmatched_b,
        "sign": "right-handed about the main axis from ends_a[0] to ends_a[1]",
    }


def write_twist(out, tw, *, render=True):
    """``twist.json``, ``twist.csv`` (one row per segment) and, with ``render``, ``twist_scans.png``
    (both scans at one scale, stacked or side by side, each main vessel left to right, landmarks
    numbered, axes drawn, a scale bar in mm) and ``twist_profile.png`` (cumulative twist against
    arc length, each segment's value on it).

    Parameters
    ----------
    out : OutputFolder
    tw : dict
        From :func:`twist_scans`.
    render : bool

    Returns
    -------
    dict
        The contents of ``twist.json``.
    """
    r = tw["result"]
    d = {"command": "twist", "scan_a": str(tw["inputs"][0]), "scan_b": str(tw["inputs"][1]), **tw["units"],
         "time_s": tw["time_s"], **twist_to_dict(r)}
    write_json(out("twist.json"), d)
    k = len(r.segment_twist)
    write_csv(out("twist.csv"), {
        "segment": np.arange(1, k + 1), "s_a_start": r.s_a[:-1], "s_a_end": r.s_a[1:],
        "length_a": r.segment_length_a, "length_b": r.segment_length_b, "stretch": r.stretch,
        "twist_deg": d["segment_twist_deg"], "uncertainty_deg": d["segment_uncertainty_deg"],
        "unreliable": r.unreliable.astype(int), "twist_deg_per_cm": d["twist_per_length_deg_per_cm"],
        "cumulative_deg": d["cumulative_twist_deg"][1:]})
    if render:
        panels = []
        for name, (V, F), P, tree, e in (("A", tw["A"], r.landmarks_a, r.tree_a, r.ends_a),
                                         ("B", tw["B"], r.landmarks_b, r.tree_b, r.ends_b)):
            panels.append({"V": V, "F": F, "alpha": tol.VIZ_TREE_ALPHA, "color": tol.VIZ_OTHER_COLOR,
                           "lines": [b.dense_points for b in tree.branches],
                           "labels": [(p, str(j + 1)) for j, p in enumerate(P)],
                           "right": tree.ends[e[1]].center - tree.ends[e[0]].center,
                           "title": f"scan {name}: main vessel from end {e[0]} (left) to end {e[1]} (right), "
                                    f"{r.length_a if name == 'A' else r.length_b:.0f} mm"})
        sense = f"right-handed about scan A's main axis from end {r.ends_a[0]} to end {r.ends_a[1]}"
        render_panels(out("twist_scans.png"), panels, scale_bar="mm",
                      title=f"twist between the scans: total {d['total_twist_deg']:+.1f}\u00b0 over "
                            f"{len(r.s_a)} landmarks (side branches)",
                      caption=f"Both scans at one scale, seen side-on. Numbers: the side branches (landmarks), "
                              f"matched in order along the main vessel; black: the fitted axes. Twist: the turn of "
                              f"the side branches (where each lies about the main axis) from scan A to scan B, {sense}.")
        plot_cumulative_twist(out("twist_profile.png"), r.s_a, d["cumulative_twist_deg"],
                              segment_deg=d["segment_twist_deg"], segment_uncertainty_deg=d["segment_uncertainty_deg"],
                              cumulative_uncertainty_deg=d["cumulative_uncertainty_deg"],
                              caption=f"0 at landmark 1 (the first side branch from end {r.ends_a[0]}); each number on "
                                      f"the line is that segment's twist \u00b1 its 95 % half-width; the band: the 95 % "
                                      f"interval of the twist from landmark 1; positive: {sense}.")
        _twist_report(out, tw, d, sense)
    return d


def scan_twist_field(r, V, cumulative_deg):
    """Each vertex of scan A's mesh ``V``: the twist from scan A to scan B accumulated along the main vessel up to
    its place there (degrees, 0 at landmark 1; interpolated linearly in scan A's arc length between the landmarks,
    constant past the first and the last); a side branch's vertex, and those of what grows from it, take the value
    where it leaves the main vessel (:attr:`vesselgp.ScanTwist.leaves_a`: its ostium, twist module notes, step 2).

    Parameters
    ----------
    r : ScanTwist
    V : (n, 3) float64
    cumulative_deg : (k,) float64
        The cumulative twist at the landmarks ``r.s_a`` (``twist.json``'s ``cumulative_twist_deg``).

    Returns
    -------
    (n,) float64
    """
    from scipy.spatial import cKDTree

    main = r.tree_a.path_to(r.ends_a[1])
    on = np.isfinite(main.vertex_s)
    twist = np.empty(len(V))
    twist[on] = np.interp(main.vertex_s[on] * r.length_a, r.s_a, cumulative_deg)
    off = np.flatnonzero(~on)
    place = r.leaves_a[r.tree_a.vertex_branch[off]]  # where each vertex's side branch leaves the main vessel
    side = np.isfinite(place)
    twist[off[side]] = np.interp(place[side], r.s_a, cumulative_deg)
    rest = off[~side]  # on a main-vessel branch without a place along it: the nearest main-vessel vertex's value
    if len(rest):
        ids = np.flatnonzero(on)
        twist[rest] = twist[ids[cKDTree(V[ids]).query(V[rest])[1]]]
    return twist


def _twist_report(out, tw, d, sense):
    """``report.html`` of ``vesselgp twist``: scan A shaded by the cumulative twist along its main vessel."""
    r = tw["result"]
    V, F = tw["A"]
    twist = scan_twist_field(r, V, d["cumulative_twist_deg"])
    m = max(float(np.max(np.abs(twist))), tol.VIZ_MIN_RANGE)
    write_report_html(out("report.html"), f"twist between {Path(d['scan_a']).name} and {Path(d['scan_b']).name}",
                      [ViewMesh(V, F, twist, label="cumulative twist (deg)", cmap="RdBu_r", vrange=(-m, m))],
                      lines=[b.dense_points for b in r.tree_a.branches],
                      labels=[(p, f"landmark {j + 1}") for j, p in enumerate(r.landmarks_a)],
                      figures=[out.dir / "twist_scans.png", out.dir / "twist_profile.png"], numbers=d,
                      caption=f"Scan A shaded by the twist from scan A to scan B accumulated along its main vessel "
                              f"(degrees; 0 at landmark 1, the first side branch from end {r.ends_a[0]}; positive: "
                              f"{sense}); a side branch takes the value where it leaves. Total "
                              f"{d['total_twist_deg']:+.1f} \u00b1 {d['cumulative_uncertainty_deg'][-1]:.1f} degrees "
                              f"(95 %) over {len(r.s_a)} landmarks; segments: "
                              + "; ".join(f"{j + 1}: {t:+.1f} \u00b1 {u:.1f}{' (unreliable)' if bad else ''}"
                                          for j, (t, u, bad) in enumerate(zip(d["segment_twist_deg"],
                                                                              d["segment_uncertainty_deg"],
                                                                              d["unreliable"]))) + ".")


def twist_table(d):
    """The printed table of ``vesselgp twist``."""
    rows = [f"{'seg':>3} {'s_a (mm)':>17} {'len A':>7} {'len B':>7} {'stretch':>7} {'twist':>8} {'+-95%':>6} "
            f"{'deg/cm':>7}"]
    for j, tw in enumerate(d["segment_twist_deg"]):
        flag = "  unreliable" if d["unreliable"][j] else ""
        rows.append(f"{j + 1:>3} {d['s_a'][j]:>7.1f} - {d['s_a'][j + 1]:>7.1f} {d['segment_length_a'][j]:>7.1f} "
                    f"{d['segment_length_b'][j]:>7.1f} {d['stretch'][j]:>7.3f} {tw:>+8.1f} "
                    f"{d['segment_uncertainty_deg'][j]:>6.1f} {d['twist_per_length_deg_per_cm'][j]:>+7.2f}{flag}")
    rows.append(f"total twist {d['total_twist_deg']:+.1f} deg over {d['n_landmarks']} landmarks "
                f"(right-handed about scan A's main axis from end {d['ends_a'][0]} to {d['ends_a'][1]})")
    rows.append(f"+-95%: half-width of each segment's 95 % interval (degrees); unreliable above "
                f"{tol.TWIST_UNRELIABLE_DEG:g}; main axis {d['main_axis_a']} (A), {d['main_axis_b']} (B)")
    div = [j + 1 for j, v in enumerate(d["divides_a"]) if v]
    if div:
        rows.append(f"the main vessel divides into comparable daughters at landmark(s) {div}")
    if len(d["unmatched_s_a"]) or len(d["unmatched_s_b"]):
        rows.append(f"unmatched landmarks: scan A at s = {np.round(d['unmatched_s_a'], 1).tolist()}, "
                    f"scan B at s = {np.round(d['unmatched_s_b'], 1).tolist()}")
    return "\n".join(rows)


# ----------------------------------------------------------------------------- clean, generate


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


# ----------------------------------------------------------------------------- ends


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


def run_paper_cases(out, *, resolution=1.0, seed=0, noise=0.0, pre_rotation=0.0):
    """Write the paper's two joining cases into ``out/case1``, ``out/case2`` (:func:`vesselgp.io.write_case`).

    Returns
    -------
    list of dict
        ``case, name, n_vertices, other_n_vertices`` per case.
    """
    info = []
    for n in (1, 2):
        c = paper_case(n, resolution=resolution, seed=seed, noise=noise, pre_rotation=pre_rotation)
        for f in ("vessel.ply", "other.ply", "case.json"):
            out(f"case{n}/{f}")
        write_case(out.dir / f"case{n}", c, resolution)
        info.append({"case": n, "name": c.name, "n_vertices": len(c.V), "other_n_vertices": len(c.other_V)})
    return info


def run_generate(out, curve="arc", *, radius=1.5, twist_deg=None, ends="open", n_around=48, remesh=True,
                 noise=0.0, seed=0, ellipticity=1.0, deformed_curve=None, deformed_twist_deg=None, fmt="ply"):
    """A synthetic vessel (``vessel.<fmt>``, ``truth.json``) and optionally its deformation (``deformed.<fmt>``).

    Returns
    -------
    dict
        Summary: curve, vertex count, length, deformed twist.
    """
    twist = None if twist_deg is None else math.radians(twist_deg)
    v = synthetic_vessel(curve, radius=radius, twist=twist, ends=ends, n_around=n_around, remesh=remesh,
                         noise=noise, seed=seed, ellipticity=ellipticity)
    write_mesh(out(f"vessel.{fmt}"), v.V, v.F)
    t = v.truth
    truth = {"name": t.name, "units": t.units, "length": t.length, "s": t.s[::10], "centers": t.centers[::10],
             "radii": t.radii[::10], "alpha_deg": np.degrees(t.alpha[::10]), "n_vertices": len(v.V),
             "n_faces": len(v.F), "radius": radius, "twist_deg": twist_deg, "ends": ends}
    summary = {"command": "generate", "curve": t.name, "n_vertices": len(v.V), "length": t.length,
               "units": t.units}
    if deformed_curve is not None or deformed_twist_deg is not None:
        dtw = None if deformed_twist_deg is None else math.radians(deformed_twist_deg)
        write_mesh(out(f"deformed.{fmt}"), deform_synthetic(v, deformed_curve, twist=dtw), v.F)
        truth["deformed"] = {"curve": deformed_curve, "twist_deg": deformed_twist_deg}
        summary["deformed_twist_deg"] = deformed_twist_deg
    write_json(out("truth.json"), truth)
    return to_json(summary)
