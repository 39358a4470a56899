"""``vesselgp twist``: the twist between two scans of one vessel tree, side branches as landmarks.

:func:`twist_scans` reads the scans and measures (:func:`vesselgp.twist_between`); :func:`write_twist`
writes the files of :data:`TWIST_FILES`: ``twist.json`` (:func:`twist_to_dict`), ``twist.csv`` (one
row per segment) and, with ``render``, ``twist_scans.png``, ``twist_profile.png`` and ``report.html``
(scan A shaded by :func:`scan_twist_field`). :func:`twist_table` is the printed table.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from .. import tolerances as tol
from ..html_report import ViewMesh, write_report_html
from ..io import write_csv, write_json
from ..twist import twist_between
from ..viz import plot_cumulative_twist, render_panels
from .output import read_mesh_in

__all__ = ["TWIST_FILES", "twist_scans", "twist_to_dict", "write_twist", "scan_twist_field", "twist_table"]


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
                              f"{sense}); a side branch takes the value where it leaves. Red numbers: the "
                              f"landmarks (side branches). Total "
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
