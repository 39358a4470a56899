"""``vesselgp torsion``: the material torsion (Eq. 6-8) of a deformed mesh file against its rest mesh.

:func:`run_torsion` writes ``profile.json`` (:func:`profile_to_dict`), ``profile.csv``,
``deformed_twist.ply``/``.vtp`` (the deformed mesh shaded by its twist), ``axis.vtp`` (the rest
axis with the twist along it) and, with ``render``, ``deformed_twist.png``, ``profile.png`` and
``report.html``.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from .. import tolerances as tol
from ..errors import MismatchError
from ..fit import fit_generalized_cylinder
from ..html_report import ViewMesh, write_report_html
from ..io import write_csv, write_json
from ..network import centerline_network
from ..torsion import measure_torsion
from ..viz import plot_torsion_profile, render_mesh, torsion_colors
from .output import _write_centerlines, _write_shaded, read_mesh_in

__all__ = ["run_torsion", "profile_to_dict"]


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
        "smoothing_residual_deg": math.degrees(prof.smoothing_residual),
    }


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
    prof = measure_torsion(V0, V1, F0, rest=rest_fit, smoothing=smoothing)
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
                          f"{e0} to end {e1} over {prof.length:.4g}\u00a0mm; E\u00a0=\u00a0{prof.energy:.3g}\u00a0rad\u00b2 "
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
