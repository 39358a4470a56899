"""The ``vesselgp`` command: every stage of the toolkit from the shell.

A thin layer over the library: argument parsing, calls into :mod:`vesselgp`,
writing outputs (atomically, never over an input file), printing. Bad input
(any :class:`vesselgp.VesselError`) ends with a one-line message
``vesselgp: error: ...`` on stderr and exit code 2, as do usage errors. A batch
whose rows ran but some failed ends with one line on stderr and exit code 1.
Commands that read meshes take ``--units``/``--scale`` and report in millimetres.

Examples
--------
>>> main(["--version"])  # doctest: +ELLIPSIS
vesselgp ...
0
"""
from __future__ import annotations

import argparse
import json
import logging
import re
import sys
import time
from pathlib import Path

import numpy as np

from . import tolerances as tol
from .commands.clean import ends_table, run_clean, run_ends
from .commands.demo import run_demo, run_generate, run_paper_cases
from .commands.fit import run_fit
from .commands.join import JOIN_FILES, join_inputs, join_vessels_inputs, run_join, run_join_vessels, summary_table
from .commands.output import OutputFolder, library_scale_warnings_replaced
from .commands.torsion import run_torsion
from .commands.twist import TWIST_FILES, twist_scans, twist_table, write_twist
from .deform import METHODS, Frame
from .errors import VesselError
from .io import READ_FORMATS, read_json, to_json, write_json
from .mesh.scale import UNITS_TO_MM

log = logging.getLogger("vesselgp.cli")

#: Every format read_mesh takes, as the mesh arguments' help lists them.
MESH_FORMATS = f"({' '.join(READ_FORMATS)})"

EPILOG = {
    "main": """examples:
  vesselgp demo                                   both paper cases -> ./vesselgp-demo/
  vesselgp generate --curve arc --twist 0 -o arc  a synthetic vessel (vessel.ply, truth.json)
  vesselgp ends aorta.stl                         list the vessel's ends (for --ends I J)
  vesselgp fit vessel.stl -o fit                  axis.json/.csv/.vtp/.ply, shaded mesh
  vesselgp torsion rest.ply deformed.ply -o tor   twist profile, energy, shaded mesh
  vesselgp join vessel.ply --case case.json -o j  minimum-torsion end rotation, Fig. 2-4 outputs
  vesselgp twist scan_a.stl scan_b.stl -o tw     twist between two scans, side branches as landmarks
  vesselgp batch cohort.csv -o results            a cohort on Dask (results.csv, one JSON per row)
  vesselgp clean raw.stl -o cleaned               repaired mesh + report

meshes in metres, centimetres or micrometres: pass --units m|cm|um (or --scale
FACTOR, millimetres per mesh unit); lengths in every report are then millimetres.

run 'vesselgp <command> --help' for the options of a command.""",
    "fit": """examples:
  vesselgp fit vessel.stl -o fit
  vesselgp fit aorto_iliac.stl -o tree                (branching: tree.json, tree.vtp, tree.png)
  vesselgp fit aorta.ply --ends 0 2 --axis-format vtp -o fit --json
  vesselgp fit vessel_in_metres.stl --units m -o fit     (lengths reported in mm)""",
    "torsion": """examples:
  vesselgp generate --curve straight --deformed-twist 90 -o gen
  vesselgp torsion gen/vessel.ply gen/deformed.ply -o tor
  vesselgp torsion rest_y.stl deformed_y.stl --ends 0 2 -o tor""",
    "join": """examples:
  vesselgp generate --paper-cases -o cases
  vesselgp join cases/case1/vessel.ply --case cases/case1/case.json -o join1
  vesselgp join coronary.stl --end 1 --onto artery.stl --other-end 0 -o j2
  vesselgp join v.ply --fixed 0-99 --moving @moving.txt --target-origin 40 2 0 \\
      --target-tangent 1 0 0 --target-normal 0 0 1 -o join""",
    "twist": """examples:
  vesselgp twist supine.stl flexed.stl -o tw
  vesselgp twist a.stl b.stl --ends-a 0 3 --ends-b 1 0 --units cm -o tw""",
    "batch": """examples:
  vesselgp batch cohort.csv -o results --workers 2
  vesselgp batch cohort.csv -o results --scheduler tcp://10.0.0.5:8786 --timeout 600

a cluster: 'dask scheduler' on one machine, 'dask worker tcp://HOST:8786 --nthreads 1' on each
of the others (each with vesselgp installed and the meshes at the same paths; docs/api.md, Cohorts,
gives the workers' malloc setting, without which a fit runs 1.6x slower).""",
    "clean": """examples:
  vesselgp clean segmentation.stl -o cleaned --json
  vesselgp clean voxel_staircase.stl --smooth 20 --units m -o cleaned""",
    "ends": """examples:
  vesselgp ends aorta.stl
  vesselgp ends aorta_in_metres.stl --units m --json -o ends""",
    "generate": """examples:
  vesselgp generate --curve helix --radius 1.5 --twist 45 -o helix
  vesselgp generate --curve arc --deformed-curve s_curve --deformed-twist 90 -o pair
  vesselgp generate --paper-cases --resolution 0.5 -o cases""",
    "demo": """examples:
  vesselgp demo
  vesselgp demo --resolution 0.5 -o quick-demo --overwrite""",
}


# ----------------------------------------------------------------------------- helpers


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line ``vesselgp: error: ...`` (exit code 2)."""

    def error(self, message):
        self.exit(2, f"vesselgp: error: {_one_line(message)} (see '{self.prog} --help')\n")


def _positive_float(text):
    try:
        x = float(text)
    except ValueError:
        x = float("nan")
    if not (np.isfinite(x) and x > 0):
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive number")
    return x


def _ids(text, name):
    """Vertex ids from '0,3,7-12' or '@file'.

    ``@file.json`` holds a JSON list of ids; any other ``@file`` holds ids and
    ranges separated by commas or whitespace, as on the command line.
    """
    text = str(text).strip()
    if text.startswith("@"):
        path = Path(text[1:])
        if path.suffix.lower() == ".json":
            d = read_json(path, f"--{name} file", expect=list)
            if not all(isinstance(v, int) and not isinstance(v, bool) for v in d):
                raise VesselError(f"--{name} file {path} must hold a JSON list of integer vertex ids")
            return np.asarray(d, np.int64).reshape(-1)
        try:
            text = path.read_text()
        except OSError as exc:
            raise VesselError(f"--{name}: cannot read {path} ({exc.strerror})") from None
        text = ",".join(text.split())
    out = []
    for part in filter(None, (p.strip() for p in text.split(","))):
        try:
            if "-" in part[1:]:
                a, b = part.split("-", 1)
                out.extend(range(int(a), int(b) + 1))
            else:
                out.append(int(part))
        except ValueError:
            raise VesselError(f"--{name}: {part!r} is not a vertex id or range like 3-7") from None
    if not out:
        raise VesselError(f"--{name}: no vertex ids given")
    return np.asarray(out, np.int64)


def _progress(args):
    return (not args.quiet) and sys.stderr.isatty()


def _emit(args, summary, text):
    if args.json:
        print(json.dumps(to_json(summary), indent=2, allow_nan=False))
    elif not args.quiet:
        print(text)


def _lengths_in(d):
    """'lengths in mm', or, when the mesh's units were not given, that they are taken as mm."""
    return "lengths in mm" if d["input_units"] != "mm (assumed)" else "lengths in mesh units, taken as mm"


def _bulges_text(bulges, paths=False):
    """One line per bulge of ``axis.json`` / ``tree.json`` (sacs, bulbs: passed through, said)."""
    text = ""
    for b in bulges:
        on = f" on path{'s' * (len(b['paths']) > 1)} {', '.join(map(str, b['paths']))}" if paths else ""
        text += (f"\n  bulge{on} at s {b['s_range'][0]:.2f}-{b['s_range'][1]:.2f}: radius {b['peak_radius']:.3g} mm "
                 f"against {b['neighbour_radius']:.3g} mm beside it ({b['ratio']:.2f}x)")
    return text


def _files_text(out):
    return "\n".join(f"  {f}" for f in out.files)


def _output(args, inputs, **kwargs):
    """The command's :class:`OutputFolder`, kept on ``args``: :func:`main` removes it again, if it created it
    and it is still empty, when the command is refused."""
    args.output_folder = OutputFolder(args.output, inputs, args.overwrite, **kwargs)
    return args.output_folder


# ----------------------------------------------------------------------------- subcommands


def cmd_fit(args):
    out = _output(args, [args.mesh])
    gc, d = run_fit(args.mesh, out, ends=args.ends, root=args.root, n_nodes=args.nodes, lam=args.lam,
                    axis_format=args.axis_format, shade=args.shade, units=args.units, scale=args.scale,
                    render=not args.no_png)
    if "paths" in d:  # a branching mesh, fitted as a tree
        summary = {"command": "fit", "tree": True, **{k: d[k] for k in ("n_ends", "root", "root_chosen", "converged",
                                                                        "time_s", "checks", *_UNIT_KEYS)},
                   "n_branches": len(d["branches"]), "n_junctions": len(d["junctions"]),
                   "paths": [{k: p[k] for k in ("ends", "length", "mean_radius")} for p in d["paths"]],
                   "bulges": d["bulges"], "files": out.files}
        lines = "\n".join(f"  path {p['ends'][0]} -> {p['ends'][1]}: length {p['length']:.4g} mm, "
                          f"mean radius {p['mean_radius']:.4g} mm" for p in d["paths"])
        lines += _bulges_text(d["bulges"], paths=True)
        summary["branch_fits"] = [{k: b[k] for k in ("id", "fit", "iterations", "last_step")} for b in d["branches"]]
        root = (f"root end {d['root']} (--root)" if d["root_chosen"] == "given" else
                f"root end {d['root']} (the widest; --root I starts the paths at another)")
        _emit(args, summary, f"fitted tree: {len(d['branches'])} branches, {len(d['junctions'])} junctions, "
                             f"{root}, {d['time_s']:.2f} s\n{lines}\n{_branch_fits_text(d['branches'])}\n"
                             f"{_checks_text(d['checks'])}\n{_files_text(out)}")
        return 0
    summary = {"command": "fit", **{k: d[k] for k in ("length", "mean_radius", "n_nodes", "iterations",
                                                      "converged", "time_s", "bulges", "checks", *_UNIT_KEYS)},
               "files": out.files}
    stopped = "" if gc.converged else f" (stopped there, still moving {gc.last_step:.2g} mm per iteration)"
    _emit(args, summary, f"fitted axis: length {gc.length:.4g} mm, mean radius {gc.mean_radius:.4g} mm, "
                         f"{len(gc.s)} nodes, {gc.iterations} iterations{stopped}, {d['time_s']:.2f} s"
                         f"{_bulges_text(d['bulges'])}\n{_checks_text(d['checks'])}\n{_files_text(out)}")
    return 0


def _branch_fits_text(branches):
    """One line on how the branches' axes were found (``fit`` of each branch of ``tree.json``).

    Examples
    --------
    >>> print(_branch_fits_text([{"id": 0, "fit": "converged", "iterations": 9, "last_step": 1e-5},
    ...                          {"id": 1, "fit": "stopped", "iterations": 30, "last_step": 0.0049},
    ...                          {"id": 2, "fit": "centre line", "iterations": 30, "last_step": 0.19}]))
    branch fits: 1 converged, 1 stopped at 30 iterations (still moving up to 0.0049 mm per iteration: branch 1), 1 the lumen's centre line (branch 2); every axis passed the checks
    """
    def ids(kind):
        return [b for b in branches if b["fit"] == kind]

    parts = [f"{len(ids('converged'))} converged"]
    if ids("stopped"):
        st = ids("stopped")
        parts.append(f"{len(st)} stopped at {max(b['iterations'] for b in st)} iterations (still moving up to "
                     f"{max(b['last_step'] for b in st):.2g} mm per iteration: branch{'es' * (len(st) > 1)} "
                     f"{', '.join(str(b['id']) for b in st)})")
    if ids("centre line"):
        cl = ids("centre line")
        parts.append(f"{len(cl)} the lumen's centre line (branch{'es' * (len(cl) > 1)} "
                     f"{', '.join(str(b['id']) for b in cl)})")
    return f"branch fits: {', '.join(parts)}; every axis passed the checks"


def _checks_text(c):
    """One line on the fit's checks against its mesh (:class:`vesselgp.checks.FitChecks`, as a dict).

    Examples
    --------
    >>> print(_checks_text({"worst_end_gap_radii": 0.0, "covered_fraction": 0.99961,
    ...                     "largest_uncovered_radii": 0.21, "uncovered_limit_radii": 1.5,
    ...                     "off_centre": {"offset_radii": 0.045, "standard_error_radii": 0.0067,
    ...                                    "warn_above_radii": 0.1, "sigmas": 4.0}}))
    checks: every end reached (worst gap 0.00 end radii), 99.96 % of the wall covered (largest uncovered piece 0.21 radii of wall, at most 1.5), the axis off its wall's centre by 0.045 radii (+- 0.0067) at worst (limit 0.1 + 4 standard errors)
    """
    cover = ("coverage not judged (a path between two of the mesh's ends)" if c["covered_fraction"] is None else
             f"{100 * c['covered_fraction']:.2f} % of the wall covered (largest uncovered piece "
             f"{c['largest_uncovered_radii']:.2f} radii of wall, at most {c['uncovered_limit_radii']:g})")
    oc = c.get("off_centre")
    centre = "" if oc is None else (
        f", the axis off its wall's centre by {oc['offset_radii']:.2g} radii (+- {oc['standard_error_radii']:.2g}) at "
        f"worst (limit {oc['warn_above_radii']:g} + {oc['sigmas']:g} standard errors)")
    return f"checks: every end reached (worst gap {c['worst_end_gap_radii']:.2f} end radii), {cover}{centre}"


def cmd_torsion(args):
    out = _output(args, [args.rest, args.deformed])
    prof, d = run_torsion(args.rest, args.deformed, out, smoothing=args.smoothing, ends=args.ends,
                          units=args.units, scale=args.scale, render=not args.no_png)
    summary = {"command": "torsion", **{k: d[k] for k in ("energy", "total_twist_deg", "twist_per_length_deg",
                                                          "length", "time_s", *_UNIT_KEYS)}, "files": out.files}
    _emit(args, summary, f"torsion energy {prof.energy:.4g} (Eq. 8), total twist "
                         f"{d['total_twist_deg']:.2f} deg, {d['time_s']:.2f} s\n{_files_text(out)}")
    return 0


def _hold(text):
    """``--hold``: an arc-length fraction ('0.2') or vertex ids ('0-99', @file)."""
    text = str(text).strip()
    if "." in text and not text.startswith("@"):
        try:
            return float(text)
        except ValueError:
            raise VesselError(f"--hold: {text!r} is neither an arc-length fraction like 0.2 nor vertex ids") from None
    return _ids(text, "hold")


def _join_summary(args, r, inp, out):
    r = {"command": "join", "vessel": str(args.vessel), **inp["units"], **r}
    write_json(out("result.json"), r)
    out.files.extend(str(out.dir / f) for f in r["files"].values())
    summary = {k: r[k] for k in ("optimum_angle_deg", "roll_deg", "energy", "total_twist_deg", "n_evals", "status",
                                 "grid_scan", "axial_stretch", "max_edge_stretch", "setup_time_s", "time_s")}
    summary.update(command="join", large_torsion=r["large_torsion"], **inp["units"], files=out.files)
    text = (summary_table([r]) + f"\nroll beyond the twist-free placement {r['roll_deg']:+.2f} deg, "
            f"axial stretch {r['axial_stretch']:.3f}, largest edge stretch {r['max_edge_stretch']:.3f}\n"
            "angle 0: the moving anchor lies on the target normal (result.json: angle_reference)\n"
            + _files_text(out))
    _emit(args, summary, text)
    return 0


def cmd_join(args):
    if args.onto is not None:
        return _cmd_join_vessels(args)
    if args.end is not None:
        raise VesselError("--end needs --onto OTHER and --other-end J (the end index of the other vessel)")
    if args.case is None:
        need = {"--fixed": args.fixed, "--moving": args.moving, "--target-origin": args.target_origin,
                "--target-tangent": args.target_tangent, "--target-normal": args.target_normal}
        missing = [k for k, v in need.items() if v is None]
        if missing:
            raise VesselError(f"give --case, or --end I --onto OTHER --other-end J, or all of {', '.join(need)} "
                              f"(missing {', '.join(missing)})")
    inp = join_inputs(
        args.vessel, case=args.case,
        fixed=None if args.fixed is None else _ids(args.fixed, "fixed"),
        moving=None if args.moving is None else _ids(args.moving, "moving"),
        target=None if args.case is not None else Frame(args.target_origin, args.target_tangent,
                                                          args.target_normal),
        other=args.other, other_end=None if args.other_end is None else _ids(args.other_end, "other-end"),
        units=args.units, scale=args.scale)
    out = _output(args, inp["inputs"])
    out.check(JOIN_FILES)
    mn = inp["moving_normal"] if args.moving_normal is None else args.moving_normal
    r = run_join(out.dir, inp["V"], inp["F"], inp["fixed"], inp["moving"], inp["target"],
                 other=inp["other"], name=Path(args.vessel).stem, n_curve=args.n_curve,
                 curve_range_deg=args.range, large_deg=args.large, method=args.method,
                 progress=_progress(args), render=not args.no_png, moving_normal=mn)
    return _join_summary(args, r, inp, out)


def _cmd_join_vessels(args):
    """``join VESSEL --end I --onto OTHER --other-end J``: two vessels by end index."""
    clash = [k for k, v in (("--case", args.case), ("--fixed", args.fixed), ("--moving", args.moving),
                            ("--target-origin", args.target_origin), ("--target-tangent", args.target_tangent),
                            ("--other", args.other)) if v is not None]
    if clash:
        raise VesselError(f"--onto finds the held part, the moving ring and the target itself; drop {', '.join(clash)}")
    if args.end is None or args.other_end is None:
        raise VesselError("--onto needs --end I and --other-end J: end indices as 'vesselgp ends' lists them")
    try:
        other_end = int(args.other_end)
    except ValueError:
        raise VesselError(f"--other-end with --onto is an end index like 0, got {args.other_end!r}") from None
    inp = join_vessels_inputs(
        args.vessel, args.onto, args.end, other_end, hold=None if args.hold is None else _hold(args.hold),
        method=args.method, max_stretch=args.max_stretch, moving_normal=args.moving_normal,
        target_normal=args.target_normal, units=args.units, scale=args.scale, place=args.place,
        max_radius_ratio=args.max_radius_ratio)
    out = _output(args, inp["inputs"])
    out.check(JOIN_FILES)
    r = run_join_vessels(out.dir, inp["join"], name=Path(args.vessel).stem, n_curve=args.n_curve,
                         curve_range_deg=args.range, large_deg=args.large, progress=_progress(args),
                         render=not args.no_png)
    r["onto"] = str(args.onto)
    return _join_summary(args, r, inp, out)


def cmd_twist(args):
    tw = twist_scans(args.scan_a, args.scan_b, ends_a=args.ends_a, ends_b=args.ends_b, units=args.units,
                     scale=args.scale)
    out = _output(args, tw["inputs"])
    out.check(TWIST_FILES)
    d = write_twist(out, tw, render=not args.no_png)
    summary = {k: d[k] for k in ("command", "n_landmarks", "ends_a", "ends_b", "segment_twist_deg", "stretch",
                                 "twist_per_length_deg_per_cm", "total_twist_deg", "time_s", *_UNIT_KEYS)}
    summary["files"] = out.files
    _emit(args, summary, twist_table(d) + "\n" + _files_text(out))
    return 0


def cmd_batch(args):
    from . import batch

    rep = batch.run(args.manifest, args.output, workers=args.workers, scheduler=args.scheduler,
                    timeout=args.timeout, retry_errors=args.retry_errors, progress=_progress(args) or None)
    summary = {"command": "batch", "rows": len(rep.rows), "computed": rep.computed, "skipped": rep.skipped,
               "failed": rep.failed, "time_s": rep.time_s, "runner": rep.runner, "serial_rows": rep.serial_rows,
               "dask_rows": rep.dask_rows, "results": [f for f in rep.files if not f.endswith(".json")],
               "failed_kinds": rep.failed_kinds, "notes": list(rep.notes)}
    how = {"serial": " serially, in this process", "dask": " on Dask",
           "serial, then dask": f": {rep.serial_rows} in this process, then {rep.dask_rows} on a local Dask cluster"}
    fails = "\n".join(f"  row {r['row']}: {r['error_type']}: {r['error']}" for r in rep.rows if r["status"] != "ok")
    _emit(args, summary, f"{len(rep.rows)} rows: {rep.computed} computed{how.get(rep.runner, '')}, {rep.skipped} "
                         f"already done, {rep.failed} failed, {rep.time_s:.1f} s" + (f"\n{fails}" if fails else "")
                         + "\n" + "\n".join(f"  {f}" for f in summary["results"] + list(rep.notes)))
    if rep.failed:  # a cohort fails loudly: one line on stderr and exit code 1 (2 is bad input: nothing ran)
        print(f"vesselgp: {rep.failure_summary()}", file=sys.stderr)
        return 1
    return 0


def cmd_clean(args):
    out = _output(args, [args.mesh])
    rep, d = run_clean(args.mesh, out, fmt=args.format, smooth=args.smooth, units=args.units,
                       scale=args.scale)
    _emit(args, {"command": "clean", **d, "files": out.files}, rep.summary() + "\n" + _files_text(out))
    return 0


def cmd_ends(args):
    out = _output(args, [args.mesh], rerun=("ends.json", "ends"))  # a listing: a re-run replaces its own
    d = run_ends(args.mesh, out, units=args.units, scale=args.scale)
    _emit(args, {**d, "files": out.files},
          f"{d['n_ends']} ends of {args.mesh} ({_lengths_in(d)}; --ends I J takes these indices)\n"
          + ends_table(d) + "\n" + _files_text(out))
    return 0


def cmd_generate(args):
    out = _output(args, [])
    if args.paper_cases:
        info = run_paper_cases(out, resolution=args.resolution, seed=args.seed, noise=args.noise,
                               pre_rotation=np.radians(args.pre_rotation))
        text = "\n".join(f"case {i['case']} ({i['name']}): {i['n_vertices']} + {i['other_n_vertices']} vertices"
                         for i in info)
        _emit(args, {"command": "generate", "cases": info, "files": out.files}, text + "\n" + _files_text(out))
        return 0
    summary = run_generate(
        out, args.curve, radius=args.radius, twist_deg=args.twist, ends=args.ends, n_around=args.n_around,
        remesh=not args.no_remesh, noise=args.noise, seed=args.seed, ellipticity=args.ellipticity,
        deformed_curve=args.deformed_curve, deformed_twist_deg=args.deformed_twist, fmt=args.format)
    summary["files"] = out.files
    _emit(args, summary, f"{summary['curve']} vessel: {summary['n_vertices']} vertices, length "
                         f"{summary['length']:.4g} {summary['units']}\n" + _files_text(out))
    return 0


def cmd_demo(args):
    out = _output(args, [])
    t0 = time.perf_counter()
    rep = run_demo(out.dir, resolution=args.resolution, n_curve=args.n_curve, progress=_progress(args),
                   render=not args.no_png, pre_rotation=np.radians(args.pre_rotation))
    dt = time.perf_counter() - t0
    files = [str(out.dir / "report.json")] + [str(out.dir / f) for c in rep["cases"] for f in c["files"].values()]
    summary = {"command": "demo", "output": str(out.dir), "total_time_s": dt,
               "cases": [{k: c[k] for k in ("case", "name", "optimum_angle_deg", "energy", "n_evals",
                                            "setup_time_s", "time_s")} for c in rep["cases"]],
               "files": files}
    _emit(args, summary, "vesselgp demo: the paper's two joining cases (Section 3) on generated vessels\n"
                         + summary_table(rep["cases"])
                         + f"\ntotal {dt:.1f} s; figures, meshes and report.json in {out.dir}/"
                         + ("" if args.no_png else f"; open {out.dir}/case2/report.html in a browser"))
    return 0


# ----------------------------------------------------------------------------- parser


#: Report fields of the mesh's units (commands.output.read_mesh_in), copied into the JSON summaries.
_UNIT_KEYS = ("units", "input_units", "to_mm")


def _units_options(p, what="the mesh"):
    g = p.add_mutually_exclusive_group()
    g.add_argument("--units", choices=tuple(UNITS_TO_MM),
                   help=f"length unit of {what}: converted into millimetres, and every length reported is in mm "
                        "(default: taken as mm, with a warning naming this option when its size looks like m, cm "
                        "or um)")
    g.add_argument("--scale", type=_positive_float, metavar="FACTOR",
                   help="millimetres per mesh unit, instead of --units (e.g. 25.4 for inches)")


def _common(p, default_out):
    p.add_argument("-o", "--output", default=default_out, metavar="DIR",
                   help=f"output folder (default: ./{default_out}); must be new or empty unless --overwrite")
    p.add_argument("--overwrite", action="store_true", help="write into an existing non-empty output folder")
    _reporting(p)


def _reporting(p):
    """--json, --quiet and --verbose, as every subcommand has them."""
    p.add_argument("--json", action="store_true", help="print a machine-readable JSON summary on stdout")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars, no summary text")
    p.add_argument("-v", "--verbose", action="count", default=0, help="log progress (-vv: debug)")


def _add_fit(sub, fmt):
    """The ``fit`` subcommand."""
    p = sub.add_parser("fit", help="fit a generalized cylinder (axis, radius, frames) to a vessel mesh, "
                                   "or a tree of them to a branching one",
                       description="Fit a generalized cylinder (paper Eq. 1-5): axis, radius, "
                                   "rotation-minimizing frames. A mesh with more than two ends is fitted as a "
                                   "tree (one cylinder per branch, tree.json/.vtp/.ply and tree.png) unless "
                                   "--ends picks one path.", formatter_class=fmt, epilog=EPILOG["fit"])
    p.add_argument("mesh", help=f"vessel mesh {MESH_FORMATS}")
    p.add_argument("--ends", type=int, nargs=2, metavar=("I", "J"),
                   help="indices of the two ends to fit between (for meshes with more than two ends; "
                        "'vesselgp ends' lists them)")
    p.add_argument("--root", type=int, metavar="I",
                   help="the end the paths start from (default: the widest end, which is not always the trunk: "
                        "a carotid whose daughter is wider than the common carotid); 'vesselgp ends' lists them")
    p.add_argument("--nodes", type=int, help="number of axis nodes (default: one per half radius)")
    p.add_argument("--lam", type=float,
                   help=f"weight of the axis's bending (paper Eq. 2; default {tol.GC_LAMBDA:g}): larger is stiffer")
    p.add_argument("--axis-format", choices=("vtp", "ply", "both"), default="both",
                   help="polyline file(s) of the axis (default: both)")
    p.add_argument("--shade", choices=("radius", "theta", "none"), default="radius",
                   help="write the mesh coloured by its distance to the axis in mm (a stenosis shows dark, a bulge "
                        "bright) or by its angle about the axis (default: radius)")
    _units_options(p)
    p.add_argument("--no-png", action="store_true", help="do not render PNGs")
    _common(p, "vesselgp-fit")
    p.set_defaults(func=cmd_fit)


def _add_torsion(sub, fmt):
    """The ``torsion`` subcommand."""
    p = sub.add_parser("torsion", help="material torsion of a deformed vessel (profile, energy, shaded mesh)",
                       description="Material torsion of a deformed vessel against its RMF (paper Eq. 6-8).",
                       formatter_class=fmt, epilog=EPILOG["torsion"])
    p.add_argument("rest", help=f"rest mesh {MESH_FORMATS}")
    p.add_argument("deformed", help=f"deformed mesh, same vertices and faces {MESH_FORMATS}")
    p.add_argument("--smoothing", type=float, default=tol.TORSION_SMOOTHING,
                   help="smoothing length of alpha(s) in axis-node spacings (default: %(default)s)")
    p.add_argument("--ends", type=int, nargs=2, metavar=("I", "J"),
                   help="indices of the rest mesh's two ends to fit between (see 'vesselgp ends'; for meshes "
                        "with more than two ends)")
    _units_options(p, "both meshes")
    p.add_argument("--no-png", action="store_true", help="do not render PNGs")
    _common(p, "vesselgp-torsion")
    p.set_defaults(func=cmd_torsion)


def _add_join(sub, fmt):
    """The ``join`` subcommand."""
    p = sub.add_parser("join", help="join a vessel end to a target with the least torsion",
                       description="Minimum-torsion joining (paper Section 2.3): the end rotation of least "
                                   "torsion energy, shaded meshes at the optimum and at large torsion, the "
                                   "energy curve (Fig. 4).", formatter_class=fmt, epilog=EPILOG["join"])
    p.add_argument("vessel", help=f"mesh of the vessel that is deformed {MESH_FORMATS}")
    p.add_argument("--case", help="case.json (as written by 'vesselgp generate --paper-cases' or "
                                  "data_gen/make_paper_cases.py); the vessel joined to is the file it names "
                                  "as other_mesh, unless --other is given")
    p.add_argument("--fixed", help="held vertex ids: '0,5,10-99', @ids.txt (the same, any separators) "
                                   "or @ids.json (a JSON list)")
    p.add_argument("--moving", help="vertex ids of the joined end ring: '...' or @file")
    p.add_argument("--target-origin", type=float, nargs=3, metavar=("X", "Y", "Z"),
                   help="where the joined end's centre goes")
    p.add_argument("--target-tangent", type=float, nargs=3, metavar=("X", "Y", "Z"),
                   help="axis direction at the joined end, out of the vessel")
    p.add_argument("--target-normal", type=float, nargs=3, metavar=("X", "Y", "Z"),
                   help="where the moving anchor goes at rotation 0 (with --onto: default the world axis most "
                        "across the other end)")
    p.add_argument("--end", type=int, metavar="I",
                   help="index of the moving end (as 'vesselgp ends' lists them), with --onto and --other-end")
    p.add_argument("--onto", metavar="OTHER",
                   help=f"mesh of the vessel joined to {MESH_FORMATS}: the held part, the moving ring and the target are "
                        "found "
                        "from the end indices; caps are opened and the two are stitched into one mesh")
    p.add_argument("--other-end", metavar="J",
                   help="with --onto: the end index of the other vessel; with --other: vertex ids of its end "
                        "ring, for the stitched mesh")
    p.add_argument("--hold", help="with --onto: what stays in place, an arc-length fraction next to the other "
                                  f"end (default {tol.JOIN_HOLD_FRACTION}) or vertex ids ('0-99', @file)")
    p.add_argument("--place", type=float, metavar="GAP",
                   help="with --onto: first move the vessel rigidly so that its end faces the other end, on its "
                        "axis, GAP mm in front of it (for two vessels in unrelated coordinates; default: no move)")
    p.add_argument("--max-stretch", type=float, default=tol.JOIN_MAX_STRETCH,
                   help="with --onto: refuse a target that stretches the free part more (default: %(default)s)")
    p.add_argument("--max-radius-ratio", type=float, default=tol.JOIN_MAX_RADIUS_RATIO,
                   help="with --onto: refuse ends whose radii differ more (default: %(default)s; an end-to-end "
                        "join needs vessels of similar calibre, the rims are stitched as they are)")
    p.add_argument("--moving-normal", type=float, nargs=3, metavar=("X", "Y", "Z"),
                   help="anchor across the moving end that lands on the target normal at angle 0 (default with "
                        "--onto: the world axis most across the end; otherwise the case's, or the fit's U)")
    p.add_argument("--other", help=f"mesh of the vessel joined to {MESH_FORMATS}: drawn in sand; stitched with "
                                  "--other-end ids")
    p.add_argument("--n-curve", type=int, default=tol.DEMO_CURVE_POINTS,
                   help="points of the energy curve (default: %(default)s)")
    p.add_argument("--range", type=float, default=tol.DEMO_CURVE_RANGE_DEG,
                   help="half-width of the energy curve about the optimum, degrees (default: %(default)s)")
    p.add_argument("--large", type=float, default=tol.DEMO_LARGE_TORSION_DEG,
                   help="rotation from the optimum of the large-torsion mesh, degrees (default: %(default)s)")
    p.add_argument("--method", default="rod_arap", choices=METHODS,
                   help="deformation method (default: %(default)s)")
    _units_options(p, "both meshes and of the target origin")
    p.add_argument("--no-png", action="store_true", help="do not render PNGs")
    _common(p, "vesselgp-join")
    p.set_defaults(func=cmd_join)


def _add_twist(sub, fmt):
    """The ``twist`` subcommand."""
    p = sub.add_parser("twist", help="material twist between two scans of one artery, from its side branches",
                       description="Twist between two scans of the same artery (e.g. supine and flexed): the side "
                                   "branches are the landmarks, matched in order along the main vessel; each "
                                   "segment's twist is the change of their azimuths in the rotation-minimizing "
                                   "frame.", formatter_class=fmt, epilog=EPILOG["twist"])
    p.add_argument("scan_a", help=f"first scan {MESH_FORMATS}: the reference for lengths and direction")
    p.add_argument("scan_b", help=f"second scan {MESH_FORMATS}: any pose and meshing")
    p.add_argument("--ends-a", type=int, nargs=2, metavar=("I", "J"),
                   help="main-vessel ends of scan A, from I (default: from the widest end to the tip with the most "
                        "landmarks)")
    p.add_argument("--ends-b", type=int, nargs=2, metavar=("I", "J"),
                   help="main-vessel ends of scan B, from the same anatomical end (default: as for scan A, "
                        "direction decided by the landmarks)")
    _units_options(p, "both scans")
    p.add_argument("--no-png", action="store_true", help="do not render PNGs")
    _common(p, "vesselgp-twist")
    p.set_defaults(func=cmd_twist)


def _add_batch(sub, fmt):
    """The ``batch`` subcommand."""
    p = sub.add_parser("batch", help="run a cohort (a CSV manifest) on Dask, locally or on a cluster",
                       description="Run every row of a manifest (CSV with a 'mesh' column, or 'rest' and "
                                   "'deformed', or 'scan_a' and 'scan_b'; optional 'ends' and 'units') as Dask "
                                   "tasks. Failures are recorded in their rows and every row is run; then, when "
                                   "any row failed, one line on stderr says how many and of which kinds, and the "
                                   "exit code is 1. A re-run skips rows already done (keyed by the inputs' content "
                                   "hash). results.parquet needs pyarrow (the batch extra).", formatter_class=fmt,
                       epilog=EPILOG["batch"])
    p.add_argument("manifest", help="the CSV manifest (paths relative to its folder)")
    p.add_argument("-o", "--output", default="vesselgp-batch", metavar="DIR",
                   help="output folder (default: ./%(default)s); an existing one is resumed")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--workers", type=int, metavar="N",
                   help="run on a local Dask cluster of N worker processes (0: serially, without Dask; default: "
                        "serially while the rows left would not pay for a cluster's start-up, the rest on one "
                        "worker per core)")
    g.add_argument("--scheduler", metavar="ADDRESS", help="submit to a running Dask scheduler, e.g. tcp://host:8786")
    p.add_argument("--timeout", type=_positive_float, metavar="S",
                   help="seconds a row may run on a worker before it is recorded as failed (runs every row "
                        "on Dask unless --workers 0)")
    p.add_argument("--retry-errors", action="store_true", help="run rows that failed before again")
    _reporting(p)
    p.set_defaults(func=cmd_batch)


def _add_clean(sub, fmt):
    """The ``clean`` subcommand."""
    p = sub.add_parser("clean", help="repair a mesh (duplicates, non-manifold parts, small pieces)",
                       description="Repair a segmented vessel mesh and keep its largest piece; --smooth N "
                                   "then removes a voxel staircase (Taubin smoothing).",
                       formatter_class=fmt, epilog=EPILOG["clean"])
    p.add_argument("mesh", help=f"input mesh {MESH_FORMATS}")
    p.add_argument("--format", choices=("ply", "stl", "obj", "off", "vtp"), default="ply",
                   help="format of the cleaned mesh (default: ply)")
    p.add_argument("--smooth", type=int, default=0, metavar="N",
                   help="N iterations of Taubin (volume-preserving) smoothing after the repairs, e.g. 20 for a "
                        "voxel staircase (default: 0, off)")
    _units_options(p, "the mesh (the cleaned mesh is written in mm)")
    _common(p, "vesselgp-clean")
    p.set_defaults(func=cmd_clean)


def _add_ends(sub, fmt):
    """The ``ends`` subcommand."""
    p = sub.add_parser("ends", help="list the ends of a vessel mesh (kind, radius, centre, direction)",
                       description="List the ends of a vessel mesh (open boundary loops, flat caps or rounded "
                                   "ends), with the indices that --ends I J of fit and torsion take.",
                       formatter_class=fmt, epilog=EPILOG["ends"])
    p.add_argument("mesh", help=f"vessel mesh {MESH_FORMATS}")
    _units_options(p)
    _common(p, "vesselgp-ends")
    p.set_defaults(func=cmd_ends)


def _add_generate(sub, fmt):
    """The ``generate`` subcommand."""
    p = sub.add_parser("generate", help="synthetic vessels with known axis and twist, or the paper's cases",
                       description="Generate synthetic vessels swept with the RMF (exact ground truth), "
                                   "or the paper's two joining cases.", formatter_class=fmt,
                       epilog=EPILOG["generate"])
    p.add_argument("--curve", default="arc", help="centre line: straight, arc, helix, s_curve, aortic_arch, "
                                                  "aortic_root (default: arc)")
    p.add_argument("--radius", type=float, default=1.5, help="section radius (default: 1.5)")
    p.add_argument("--ellipticity", type=float, default=1.0, help="section axis ratio (default: 1)")
    p.add_argument("--twist", type=float, help="material twist from end to end, degrees")
    p.add_argument("--ends", choices=("open", "capped"), default="open")
    p.add_argument("--n-around", type=int, default=48, help="points per ring (default: 48)")
    p.add_argument("--no-remesh", action="store_true", help="keep the structured ring mesh")
    p.add_argument("--noise", type=float, default=0.0, help="normal noise, fraction of the radius")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--deformed-curve", help="also write deformed.<fmt>: the vessel moved onto this curve")
    p.add_argument("--deformed-twist", type=float, help="... with this twist, degrees (also without a curve)")
    p.add_argument("--format", choices=("ply", "stl", "obj", "off", "vtp"), default="ply")
    p.add_argument("--paper-cases", action="store_true", help="write the paper's cases to case1/, case2/")
    p.add_argument("--resolution", type=float, default=1.0, help="paper cases: resolution multiplier")
    p.add_argument("--pre-rotation", type=float, default=0.0, help="paper cases: anchor error, degrees")
    _common(p, "vesselgp-generate")
    p.set_defaults(func=cmd_generate)


def _add_demo(sub, fmt):
    """The ``demo`` subcommand."""
    p = sub.add_parser("demo", help="run both paper cases on generated data (figures, report, table)",
                       description="Run the paper's two joining cases (Section 3) on generated vessels and "
                                   "write torsion-shaded meshes (PLY) and renders (PNG) at the optimum and at "
                                   "large torsion (Figs. 2-3), the energy curves (Fig. 4) and report.json.",
                       formatter_class=fmt, epilog=EPILOG["demo"])
    p.add_argument("--resolution", type=float, default=1.0,
                   help="mesh resolution multiplier (default: 1; 0.5 for a quick run)")
    p.add_argument("--n-curve", type=int, default=tol.DEMO_CURVE_POINTS,
                   help="points of each energy curve (default: %(default)s)")
    p.add_argument("--pre-rotation", type=float, default=0.0, help="anchor error, degrees (default: 0)")
    p.add_argument("--no-png", action="store_true", help="do not render PNGs")
    _common(p, "vesselgp-demo")
    p.set_defaults(func=cmd_demo)


def build_parser():
    """The ``argparse`` parser of the ``vesselgp`` command."""
    from ._version import __version__

    fmt = argparse.RawDescriptionHelpFormatter
    ap = _Parser(
        prog="vesselgp", formatter_class=fmt, epilog=EPILOG["main"],
        description="Torsion of blood vessels: generalized-cylinder fit, material torsion against a "
                    "rotation-minimizing frame, minimum-torsion joining.")
    ap.add_argument("--version", action="version", version=f"vesselgp {__version__}")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND")
    for add in (_add_fit, _add_torsion, _add_join, _add_twist, _add_batch, _add_clean, _add_ends, _add_generate, _add_demo):
        add(sub, fmt)
    return ap


def _one_line(msg):
    return " ".join(str(msg).split())


#: The library's keywords that each command's options set. The library's messages name a keyword as
#: ``name=value``, ``name=(i, j)``, ``name=`` or, when it holds an underscore, by its name; under the
#: command they name the option instead (:func:`_cli_message`).
OPTION_OF_KEYWORD = {
    "fit": {"ends": "--ends", "n_nodes": "--nodes", "root": "--root", "lam": "--lam"},
    "torsion": {"ends": "--ends"},
    "join": {"end": "--end", "other_end": "--other-end", "hold": "--hold", "max_stretch": "--max-stretch",
             "max_radius_ratio": "--max-radius-ratio",
             "place": "--place",
             "moving_normal": "--moving-normal", "target_normal": "--target-normal"},
    "twist": {"ends_a": "--ends-a", "ends_b": "--ends-b"},
    "batch": {"workers": "--workers"},
}

#: The library's functions that a command does, as the library's messages name them (most specific first):
#: under any command they name the command instead (:func:`_cli_message`).
COMMAND_OF_FUNCTION = (
    (r"vesselgp\.clean_mesh\(V, F, smooth=N\)", "vesselgp clean --smooth N"),
    (r"vesselgp\.clean_mesh", "vesselgp clean"),
    (r"vesselgp\.vessel_ends", "vesselgp ends"),
    (r"vesselgp\.fit_generalized_cylinder", "vesselgp fit --ends I J"),
)


def _cli_message(command, message):
    """``message`` with the library keywords of ``command``'s options written as the options.

    Examples
    --------
    >>> _cli_message("torsion", "mesh has 3 open ends; pass ends=(i, j) to choose (ends: ...); ends=(0, 7) is invalid")
    'mesh has 3 open ends; pass --ends I J to choose (ends: ...); --ends 0 7 is invalid'
    >>> _cli_message("join", "stretched 1.40x (max_stretch 1.3); hold less (hold=) or raise max_stretch; end=2 is not")
    'stretched 1.40x (--max-stretch 1.3); hold less (--hold) or raise --max-stretch; --end 2 is not'
    >>> _cli_message("fit", "smooth it with vesselgp.clean_mesh(V, F, smooth=N) (command line: vesselgp clean "
    ...              "--smooth N); the ends (see vesselgp.vessel_ends); a stiffer axis, lam=1.0; root=3 is not an end")
    'smooth it with vesselgp clean --smooth N; the ends (see vesselgp ends); a stiffer axis, --lam 1.0; --root 3 is not an end'
    """
    def pair(flag):
        return lambda m: " ".join([flag, *(x.strip().upper() if x.strip() in ("i", "j") else x.strip()
                                           for x in m.group(1).split(","))])

    message = re.sub(r"\s*\(command line: [^()]*\)", "", message)  # the library's own hint at the command line
    for pattern, cli in COMMAND_OF_FUNCTION:
        message = re.sub(pattern, cli, message)
    for kw, flag in OPTION_OF_KEYWORD.get(command, {}).items():
        k = re.escape(kw)
        message = re.sub(rf"\b{k}=\(([^()]*)\)", pair(flag), message)  # ends=(i, j) -> --ends I J
        message = re.sub(rf"\b{k}=(?=[-\w.'\"])", flag + " ", message)  # hold=1.5 -> --hold 1.5
        message = re.sub(rf"\b{k}=", flag, message)  # (hold=) -> (--hold)
        if "_" in kw:
            message = re.sub(rf"\b{k}\b", flag, message)  # max_stretch -> --max-stretch
    return message


def main(argv=None):
    """Entry point of the ``vesselgp`` command; returns the exit code.

    0 on success, 2 on bad input (one line ``vesselgp: error: ...`` on stderr)
    or a usage error, 1 on an I/O failure outside the input's control, 130 on Ctrl-C.
    """
    ap = build_parser()
    try:
        args = ap.parse_args(argv)
    except SystemExit as exc:  # --help, --version, usage errors (argparse prints them)
        return int(exc.code or 0)
    if args.command is None:
        ap.print_help()
        return 2
    level = logging.WARNING if args.verbose == 0 else (logging.INFO if args.verbose == 1 else logging.DEBUG)
    if args.quiet:
        level = logging.ERROR
    logging.basicConfig(level=level, format="vesselgp: %(message)s", stream=sys.stderr)
    logging.getLogger("vesselgp").setLevel(level)
    for h in logging.getLogger().handlers:  # records propagated from other libraries' loggers (Dask's) too
        h.setLevel(level)
    done = False
    try:
        with library_scale_warnings_replaced():
            code = int(args.func(args) or 0)
        done = True
        return code
    except VesselError as exc:
        print(f"vesselgp: error: {_one_line(_cli_message(args.command, str(exc)))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("vesselgp: interrupted", file=sys.stderr)
        return 130
    except OSError as exc:
        print(f"vesselgp: error: {_one_line(exc)}", file=sys.stderr)
        return 1
    finally:
        if not done and getattr(args, "output_folder", None) is not None:
            args.output_folder.remove_if_empty()  # a refused run leaves no empty folder behind


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
