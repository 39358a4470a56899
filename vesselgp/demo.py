"""End-to-end runs behind ``vesselgp demo`` and ``vesselgp join``, and their reports.

:func:`run_join` solves one joining problem (paper Section 2.3) and writes the
figures of paper Figs. 2-4 for it; :func:`run_demo` does so for both of the
paper's test cases (Section 3) on generated data and writes ``report.json``.
The helpers turn library results into JSON-ready dictionaries
(:func:`gc_to_dict`, :func:`profile_to_dict`, :func:`case_to_dict`) and write
them atomically (:func:`write_json`, :func:`write_csv`).

Angles are radians in the API and degrees in reports and figures.
"""
from __future__ import annotations

import json
import logging
import math
import time
from pathlib import Path

import numpy as np

from . import tolerances as tol
from .errors import MismatchError, VesselError
from .fit import fit_generalized_cylinder
from .viz import atomic_write, plot_energy_curve, plot_torsion_profile, render_mesh, torsion_colors

log = logging.getLogger(__name__)

__all__ = [
    "run_demo",
    "run_join",
    "gc_to_dict",
    "profile_to_dict",
    "case_to_dict",
    "case_from_dict",
    "to_json",
    "write_json",
    "write_csv",
    "REPORT_FIELDS",
    "summary_table",
]

#: Fields of each case in ``report.json`` (and of ``result.json`` of ``vesselgp join``).
REPORT_FIELDS = {
    "name": "case name",
    "n_vertices": "vertices of the deformed vessel",
    "n_faces": "faces of the deformed vessel",
    "optimum_angle_deg": "rotation of the joined end with the least torsion (degrees; 0 = given anchor)",
    "energy": "torsion energy at the optimum (paper Eq. 8, radians^2 per unit normalised length)",
    "total_twist_deg": "alpha(1) - alpha(0) at the optimum (degrees, Eq. 7)",
    "zero_twist_angle_deg": "the deformation's own zero-twist angle (degrees), the search's start",
    "n_evals": "energy evaluations of the search (probes + NLopt)",
    "status": "NLopt result name",
    "setup_time_s": "generalized-cylinder fit and factorisations (seconds)",
    "time_s": "minimum-torsion search (seconds)",
    "large_torsion": "the configuration rotated DEMO_LARGE_TORSION_DEG from the optimum: angle_deg, energy, total_twist_deg",
    "energy_curve": "angles_deg and energies of paper Fig. 4",
    "evaluations": "angles_deg and energies the search evaluated",
    "files": "files written for this case, relative to the output folder",
}


# ----------------------------------------------------------------------------- JSON / CSV


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


# ----------------------------------------------------------------------------- library results as dicts


def gc_to_dict(gc, units="mesh units"):
    """JSON-ready description of a :class:`vesselgp.GeneralizedCylinder` (``axis.json`` of ``vesselgp fit``)."""
    return {
        "units": units,
        "length": gc.length,
        "mean_radius": gc.mean_radius,
        "n_nodes": len(gc.s),
        "iterations": gc.iterations,
        "ends": list(gc.ends),
        "s": gc.s,
        "centers": gc.centers,
        "radii": gc.radii,
        "frames": {"T": gc.frames[:, 0], "U": gc.frames[:, 1], "V": gc.frames[:, 2]},
        "n_vertices": len(gc.vertex_s),
        "vertices_used": int(np.count_nonzero(gc.vertex_weight > 0)),
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


def case_to_dict(case, resolution=None):
    """``case.json`` of a :class:`vesselgp.synthetic.JoinCase` (the layout of data_gen/make_paper_cases.py)."""
    return {
        "name": case.name, "units": case.units, "seed": case.seed, "resolution": resolution,
        "pre_rotation": case.pre_rotation, "n_vertices": len(case.V), "n_faces": len(case.F),
        "other_n_vertices": len(case.other_V), "fixed": case.fixed, "moving": case.moving,
        "moving_at": case.moving_at, "other_end": case.other_end, "target_origin": case.target_origin,
        "target_tangent": case.target_tangent, "target_normal": case.target_normal,
        "vessel_length": case.truth.length, "vessel_curve": case.truth.name,
    }


def case_from_dict(d, n_vertices=None):
    """``(fixed, moving, Frame, other_end)`` from a ``case.json`` dictionary.

    Raises
    ------
    VesselError
        Missing fields or a vertex count that does not match the mesh.
    """
    from .join import Frame

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
    return fixed, moving, target, other_end


# ----------------------------------------------------------------------------- one join


def _progress_iter(progress, it, desc):
    if progress is None or progress is False:
        return it
    if progress is True:
        from tqdm.auto import tqdm

        return tqdm(it, desc=desc, leave=False)
    return progress(it, desc=desc)


def run_join(outdir, V, F, fixed, moving, target, *, other=None, name="join", n_curve=tol.DEMO_CURVE_POINTS,
             curve_range_deg=tol.DEMO_CURVE_RANGE_DEG, large_deg=tol.DEMO_LARGE_TORSION_DEG,
             method="rod_arap", ends=None, progress=None, prefix="", render=True):
    """Minimum-torsion join of one vessel end, with the paper's figures (Figs. 2-4).

    Builds a :class:`vesselgp.JoinProblem`, runs :func:`vesselgp.minimize_torsion`,
    evaluates the energy curve about the optimum and writes into ``outdir``:

    * ``optimum.ply`` / ``.png``: the deformed vessel at the optimum, vertex
      colours from the twist ``alpha`` relative to the held vertices (degrees,
      also stored as the PLY property ``alpha_deg``); ``large_torsion.ply`` / ``.png``: the same at
      ``optimum + large_deg`` (paper Figs. 2-3 (e) and (a, c)); both use one
      colour range;
    * ``energy_curve.png`` / ``.csv``: Fig. 4;
    * ``profile_optimum.png``, ``profile_large_torsion.png``: ``alpha(s)`` and ``alpha'(s)``;
    * ``joined_optimum.ply``: the optimum stitched to ``other`` (if given).

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
        The vessel joined to: drawn grey in the renders, stitched when its end ring is given.
    name : str
    n_curve : int
        Points of the energy curve.
    curve_range_deg : float
        Half-width of the curve about the optimum.
    large_deg : float
        Rotation from the optimum of the "large torsion" configuration.
    method : str
        Deformation method (:class:`vesselgp.JoinProblem`).
    ends : optional
        Ends for the rest fit (default: found by :func:`vesselgp.vessel_ends`).
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
    from .io import write_mesh
    from .join import JoinProblem, minimize_torsion, stitch

    out = Path(outdir)
    t0 = time.perf_counter()
    gc = fit_generalized_cylinder(V, F, ends=ends)
    problem = JoinProblem(V, F, fixed, moving, target, method=method, gc=gc, smoothing=tol.TORSION_SMOOTHING)
    t1 = time.perf_counter()
    res = minimize_torsion(problem)
    t2 = time.perf_counter()
    opt = res.angle
    half = math.radians(curve_range_deg)
    angles = opt + np.linspace(-half, half, int(n_curve))
    energies = np.array([problem.energy(a) for a in _progress_iter(progress, angles, f"{name}: energy curve")])
    t3 = time.perf_counter()
    a_large = opt + math.radians(large_deg)
    X_large = problem.deform(a_large)
    p_large = problem.profile(a_large)
    F = problem.F
    files = {}
    # shown relative to the held part (alpha(0) = 0 at s = 0 may be the moving end)
    fixed_ids = problem.fixed
    al_opt = np.degrees(res.profile.vertex_alpha - np.median(res.profile.vertex_alpha[fixed_ids]))
    al_large = np.degrees(p_large.vertex_alpha - np.median(p_large.vertex_alpha[fixed_ids]))
    m = max(float(np.max(np.abs(al_large))), float(np.max(np.abs(al_opt))), tol.VIZ_MIN_RANGE)
    others = []
    if other is not None:
        others = [(other[0], other[1])]
    label = "material twist \u03b1 (deg)"
    for key, X, al, prof, ang in (("optimum", res.V, al_opt, res.profile, opt),
                                  ("large_torsion", X_large, al_large, p_large, a_large)):
        write_mesh(out / f"{key}.ply", X, F, vertex_colors=torsion_colors(al, -m, m),
                   vertex_scalars={"alpha_deg": al})
        files[f"{key}_mesh"] = prefix + f"{key}.ply"
        if render:
            what = "minimum torsion" if key == "optimum" else f"large torsion (optimum {large_deg:+.0f}\u00b0)"
            render_mesh(out / f"{key}.png", X, F, al, vmin=-m, vmax=m, others=others, cbar_label=label,
                        title=f"{name}: {what}, end rotation {math.degrees(ang):.1f}\u00b0, "
                              f"E = {prof.energy:.3g}")
            plot_torsion_profile(out / f"profile_{key}.png", prof)
            files[f"{key}_png"] = prefix + f"{key}.png"
            files[f"profile_{key}_png"] = prefix + f"profile_{key}.png"
    write_csv(out / "energy_curve.csv", {"angle_deg": np.degrees(angles), "energy": energies})
    files["energy_curve_csv"] = prefix + "energy_curve.csv"
    if render:
        plot_energy_curve(out / "energy_curve.png", angles, energies, optimum=(opt, res.energy),
                          evaluated=(res.angles, res.energies), relative_to=opt,
                          title=f"{name}: torsion energy vs end rotation (Fig. 4)")
        files["energy_curve_png"] = prefix + "energy_curve.png"
    if other is not None and len(other) > 2 and other[2] is not None:
        Vj, Fj = stitch(res.V, F, moving, other[0], other[1], other[2])
        cj = np.full((len(Vj), 3), np.round(np.array(tol.VIZ_OTHER_GREY) * 255), dtype=np.uint8)
        cj[: len(res.V)] = torsion_colors(al_opt, -m, m)
        aj = np.zeros(len(Vj))
        aj[: len(res.V)] = al_opt
        write_mesh(out / "joined_optimum.ply", Vj, Fj, vertex_colors=cj, vertex_scalars={"alpha_deg": aj})
        files["joined_mesh"] = prefix + "joined_optimum.ply"
    t4 = time.perf_counter()
    log.info("%s: optimum %.2f deg, E = %.4g, %d evaluations, %.2f s search", name, math.degrees(opt),
             res.energy, res.n_evals, t2 - t1)
    return {
        "name": name,
        "n_vertices": len(V) if not hasattr(V, "shape") else int(V.shape[0]),
        "n_faces": len(F),
        "optimum_angle_deg": math.degrees(opt),
        "energy": res.energy,
        "total_twist_deg": math.degrees(res.profile.total_twist),
        "zero_twist_angle_deg": math.degrees(problem.zero_twist_angle),
        "n_evals": res.n_evals,
        "status": res.status_name,
        "setup_time_s": t1 - t0,
        "time_s": t2 - t1,
        "curve_time_s": t3 - t2,
        "output_time_s": t4 - t3,
        "large_torsion": {"angle_deg": math.degrees(a_large), "energy": p_large.energy,
                          "total_twist_deg": math.degrees(p_large.total_twist)},
        "energy_curve": {"angles_deg": np.degrees(angles), "energies": energies},
        "evaluations": {"angles_deg": np.degrees(res.angles), "energies": res.energies},
        "files": files,
    }


# ----------------------------------------------------------------------------- the demo


def run_demo(outdir, *, resolution=1.0, n_curve=tol.DEMO_CURVE_POINTS, cases=(1, 2), pre_rotation=0.0,
             progress=None, render=True):
    """Run both joining cases of the paper (Section 3) on generated data and write the figures.

    For case ``k`` the folder ``outdir/case<k>`` gets the files of
    :func:`run_join` plus ``vessel.ply``, ``other.ply`` and ``case.json`` (the
    generated input); ``outdir/report.json`` collects the results.

    Parameters
    ----------
    outdir : str or os.PathLike
        Output folder (created; existing files of the same names are replaced).
    resolution : float
        Mesh resolution multiplier of :func:`vesselgp.synthetic.paper_case`
        (1.0: about 8k and 14k vertices; 0.3 for quick tests).
    n_curve : int
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
    from . import __version__
    from .io import write_mesh
    from .synthetic import paper_case

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
        write_mesh(sub / "vessel.ply", case.V, case.F)
        write_mesh(sub / "other.ply", case.other_V, case.other_F)
        write_json(sub / "case.json", case_to_dict(case, resolution), indent=None)
        from .join import Frame

        target = Frame(case.target_origin, case.target_tangent, case.target_normal)
        r = run_join(sub, case.V, case.F, case.fixed, case.moving, target,
                     other=(case.other_V, case.other_F, case.other_end), name=f"case {n}",
                     n_curve=n_curve, progress=progress, prefix=f"case{n}/", render=render)
        r["files"].update({"vessel": f"case{n}/vessel.ply", "other": f"case{n}/other.ply",
                           "case_json": f"case{n}/case.json"})
        r = {"case": int(n), "title": case.name, **r, "generate_time_s": tg}
        write_json(sub / "result.json", r)
        results.append(r)
    report = {
        "version": __version__,
        "resolution": float(resolution),
        "cases": results,
        "total_time_s": time.perf_counter() - T0,
        "fields": REPORT_FIELDS,
    }
    write_json(out / "report.json", report)
    return report


def summary_table(cases):
    """Plain-text table (case, optimum angle, energy, evaluations, time) of demo/join results.

    Examples
    --------
    >>> print(summary_table([{"name": "case 1", "optimum_angle_deg": -179.8, "energy": 4.6e-7,
    ...                       "n_evals": 9, "setup_time_s": 0.2, "time_s": 0.7}]))
    case     angle (deg)     energy  evals  setup (s)  search (s)
    case 1        -179.8    4.6e-07      9       0.20        0.70
    """
    rows = ["{:<8} {:>11} {:>10} {:>6} {:>10} {:>11}".format(
        "case", "angle (deg)", "energy", "evals", "setup (s)", "search (s)")]
    for c in cases:
        rows.append("{:<8} {:>11.1f} {:>10.3g} {:>6d} {:>10.2f} {:>11.2f}".format(
            str(c["name"])[:8], c["optimum_angle_deg"], c["energy"], int(c["n_evals"]),
            c["setup_time_s"], c["time_s"]))
    return "\n".join(rows)
