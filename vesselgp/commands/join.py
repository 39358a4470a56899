"""``vesselgp join``: the minimum-torsion join (Section 2.3) of one vessel end, with paper Figs. 2-4.

To a target frame (:func:`join_inputs`, :func:`run_join`) or onto another vessel's end by end index
(:func:`join_vessels_inputs`, :func:`run_join_vessels`); both write, through
:func:`write_join_outputs`, the files of :data:`JOIN_FILES`: ``result.json`` (the fields of
:data:`REPORT_FIELDS`, angles as :data:`ANGLE_REFERENCE` says), ``optimum.ply``/``.vtp`` and
``large_torsion.ply``/``.vtp`` (shaded by the twist), ``joined_optimum.ply``/``.vtp`` (stitched to
the other vessel), ``energy_curve.csv`` and, with ``render``, ``optimum.png``, ``large_torsion.png``,
``energy_curve.png``, ``profile_optimum.png``, ``profile_large_torsion.png`` and ``report.html``.
:func:`summary_table` is the printed table of ``vesselgp join`` and ``vesselgp demo``.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from .. import tolerances as tol
from ..errors import VesselError
from ..fit import fit_generalized_cylinder
from ..html_report import ViewMesh, write_report_html
from ..io import read_case, write_csv
from ..join import JoinProblem, minimize_torsion
from ..join_vessels import VesselJoin
from ..mesh import stitch
from ..rotations import wrap_angle
from ..viz import ENERGY_IN_WORDS, plot_energy_curve, plot_torsion_profile, render_mesh, torsion_colors
from .output import _progress_iter, _write_shaded, read_mesh_in

log = logging.getLogger(__name__)

__all__ = [
    "REPORT_FIELDS", "JOIN_FILES", "ANGLE_REFERENCE", "join_inputs", "run_join", "join_vessels_inputs",
    "run_join_vessels", "write_join_outputs", "placement_to_dict", "wrap_deg", "summary_table",
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
                        moving_normal=None, target_normal=None, units=None, scale=None, place=None,
                        max_radius_ratio=None):
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
                      moving_normal=moving_normal, target_normal=target_normal, place=place,
                      max_radius_ratio=max_radius_ratio)
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
