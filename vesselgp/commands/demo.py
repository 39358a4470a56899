"""``vesselgp demo`` and ``vesselgp generate``: the paper's joining cases and synthetic vessels.

:func:`run_demo` runs both joining cases of the paper (Section 3) on generated data: ``report.json``
and, per case, ``case<k>/`` with the files of :func:`vesselgp.commands.join.run_join`, ``result.json``
and the case files (``vessel.ply``, ``other.ply``, ``case.json``). ``vesselgp generate`` writes
:func:`run_generate`'s synthetic vessel (``vessel.<fmt>``, ``truth.json``, ``deformed.<fmt>``) or,
with ``--paper-cases``, :func:`run_paper_cases`'s ``case1/`` and ``case2/``.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from ..deform import Frame
from ..io import to_json, write_case, write_json, write_mesh
from ..synthetic import deform_synthetic, paper_case, synthetic_vessel
from .join import REPORT_FIELDS, run_join

__all__ = ["run_demo", "run_paper_cases", "run_generate"]


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
    from .._version import __version__

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
