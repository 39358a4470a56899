"""Axis accuracy on tubes swept along real centre lines (issue #48), beside VMTK on the same meshes.

Usage::

    python scripts/real_shape_accuracy.py [--case NAME ...] [--vmtk /tmp/peer-vmtk/bin/python] [--remesh] [--json OUT]
    python scripts/real_shape_accuracy.py --torsion [--case NAME ...]
    python scripts/real_shape_accuracy.py --tree [NAME ...]

For each case of ``data_gen/real_shapes.py`` (real, tortuous centre lines of ``shared/data/real`` with circles
or ellipses swept along them, exact centre line known) it fits :func:`vesselgp.fit_generalized_cylinder` and
measures, away from the open ends (``EDGE`` radii of each end cut from it):

- ``mean`` and ``worst``: distance from the exact centre line (its 2001 samples) to the fitted axis polyline
  (``dense_points``), in % of the local radius;
- ``over5``: samples of the exact centre line farther than 5 % r from the axis (a stretch with no axis);
- ``bend``: the worst of those where curvature x radius >= 0.3 (tight bends);
- ``sections``: mean and worst distance from the exact centres of the sections the mesh carries (each vertex's own
  section: a ring mesh's ring centres) to the axis, % r (:func:`section_errors`).

With ``--vmtk`` the same is measured for VMTK 1.5.2's centre line between the two end centres
(``shared/peers/vmtk/vmtk_centerline.py``, qhull Delaunay); VMTK's line stops short of open ends, so only the
samples within its arc are counted, and ``vmtk_cover`` says how much of the line it covers.

``--torsion`` measures, for each case, the twists ``SWEPT_TWISTS`` of ``tests/_reference.py`` imposed on the
swept rings about the exact line (a uniform 1.2 rad; a ramp of 180 degrees over 40 % of the length, its steepest
rate given in degrees per mean radius): the worst alpha error (degrees), the energy error (%) and the profile's
``smoothing_residual`` (degrees) of :func:`vesselgp.measure_torsion` (the "torsion on the swept real lines" table of docs/accuracy.md).

``--tree`` measures the network trees instead (``NETWORK_TREES``: a real tree's whole VMTK network meshed by the
synthetic tree's mesher) with :func:`vesselgp.fit_vessel_tree`: each true branch against the nearest fitted path,
away from ``JUNCTION`` parent radii of every junction (the "Real shapes" tree table of docs/accuracy.md).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "data_gen"))
sys.path.insert(0, str(ROOT / "tests"))

#: Radii (of the end) cut from each end of the exact centre line before measuring.
EDGE = 2.0
#: On a tree, parent radii about each junction not measured.
JUNCTION = 3.0


def _polyline_distance(X, Q):
    from _reference import polyline_distance

    return polyline_distance(X, Q)


def axis_errors(truth, points):
    """Exact centre line -> polyline ``points``: distance in % of the local radius at each truth sample, and the
    mask of the samples measured (``EDGE`` radii of each end cut from it)."""
    L = truth.length
    st = truth.s * L
    inner = (st > EDGE * truth.radii[0]) & (st < L - EDGE * truth.radii[-1])
    e = 100.0 * _polyline_distance(truth.centers, points) / truth.radii
    return e, inner


def section_errors(truth, points):
    """The exact centres of the sections the mesh carries (each vertex's own section, ``truth.vertex_s``: the ring
    centres of a ring mesh, issue #48's exact truth) -> polyline ``points``, in % of the local radius, and the mask
    of those measured (``EDGE`` radii of each end cut). Between the rings of a sparse ring mesh the wall is flat
    facets, not the swept spline: a bend of the spline sharper than the rings' spacing is not in the mesh."""
    s = np.unique(truth.vertex_s[~truth.vertex_on_cap])
    C, _ = truth.axis_at(s)
    r = np.interp(s, truth.s, truth.radii)
    st, L = s * truth.length, truth.length
    inner = (st > EDGE * truth.radii[0]) & (st < L - EDGE * truth.radii[-1])
    return 100.0 * _polyline_distance(C, points) / r, inner


def tree_axis_errors(truth, tree):
    """Each true branch's centre line -> the nearest of the fitted tree's path axes, in % of the local radius,
    with the mask of the samples measured: farther than ``JUNCTION`` parent radii from every junction and
    ``EDGE`` radii from the ends (there the fitted axis follows the junction's lumen, not either tube).

    Returns a list of (e, mask) per true branch, in :attr:`TreeTruth.branches` order."""
    J, JR = truth.junctions
    Q = [p.dense_points for p in tree.paths]
    out = []
    for br in truth.branches:
        C, R, s = br.centers, br.radii, br.s
        e = 100.0 * np.min([_polyline_distance(C, q) for q in Q], axis=0) / R
        far = (s > EDGE * R[0]) & (s < s[-1] - EDGE * R[-1])
        for j, r in zip(J, JR):
            far &= np.linalg.norm(C - j, axis=1) > JUNCTION * r
        out.append((e, far))
    return out


def summary(e, mask, kr):
    m = mask
    bend = m & (kr >= 0.3)
    return {"mean": float(e[m].mean()), "worst": float(e[m].max()), "over5": int((e[m] > 5).sum()),
            "bend": float(e[bend].max()) if bend.any() else None, "samples": int(m.sum())}


def run_vmtk(py, V, F, truth):
    """VMTK's centre line between the swept tube's end centres: its points (k, 3) and the seconds it took."""
    import vesselgp

    with tempfile.TemporaryDirectory() as d:
        mesh, out = Path(d) / "tube.stl", Path(d) / "line.npz"
        vesselgp.write_mesh(mesh, V, F)
        a, b = truth.centers[0], truth.centers[-1]
        script = next(p for p in (ROOT.parent / "shared" / "peers" / "vmtk" / "vmtk_centerline.py",
                                  Path("/work/shared/peers/vmtk/vmtk_centerline.py")) if p.is_file())
        cmd = [py, str(script), str(mesh), "--source", *map(str, a), "--target", *map(str, b), "-o", str(out),
               "--delaunay", "qhull"]
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True, text=True)
        dt = time.perf_counter() - t0
        z = np.load(out)
        key = next(k for k in z.files if k.endswith("points"))
        return z[key].astype(np.float64), dt


def measure(name, vmtk=None, remesh=False):
    import real_shapes as rs

    import vesselgp

    ves = rs.case_vessel(name, remesh=remesh)
    t = ves.truth
    kr = rs.bend_profile(t)
    _, inner = axis_errors(t, t.centers)
    row = {"case": name, "vertices": len(ves.V), "length_mm": round(t.length, 1),
           "r_mm": [round(float(t.radii.min()), 2), round(float(t.radii.max()), 2)],
           "max_kr": round(float(kr[inner].max()), 2)}
    t0 = time.perf_counter()
    try:
        gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    except vesselgp.VesselError as err:  # a refusal is a result of this table, not the end of the run
        row["vesselgp"] = {"error": str(err)[:160]}
    else:
        row["fit_s"], row["iterations"] = round(time.perf_counter() - t0, 2), gc.iterations
        e, _ = axis_errors(t, gc.dense_points)
        row["vesselgp"] = summary(e, inner, kr)
        es, ins = section_errors(t, gc.dense_points)
        row["vesselgp"]["sections"] = [round(float(es[ins].mean()), 4), round(float(es[ins].max()), 3)]
    if vmtk:
        P, dt = run_vmtk(vmtk, ves.V, ves.F, t)
        ev, _ = axis_errors(t, P)
        # VMTK's line stops where its inscribed sphere meets the open end: count the samples it spans
        from scipy.spatial import cKDTree

        _, j = cKDTree(t.centers).query(P[[0, -1]])
        lo, hi = sorted(j)
        span = np.zeros(len(ev), bool)
        span[lo:hi + 1] = True
        row["vmtk"] = summary(ev, inner & span, kr)
        es, ins = section_errors(t, P)
        _, jv = cKDTree(t.centers).query(t.axis_at(np.unique(t.vertex_s[~t.vertex_on_cap]))[0])
        ins &= (jv >= lo) & (jv <= hi)
        row["vmtk"]["sections"] = [round(float(es[ins].mean()), 4), round(float(es[ins].max()), 3)]
        row["vmtk"]["cover"] = round(float((inner & span).sum() / inner.sum()), 3)
        row["vmtk_s"] = round(dt, 2)
    return row


def measure_torsion(name):
    import real_shapes as rs
    from _reference import SWEPT_TWISTS, imposed_twist_errors

    import vesselgp
    from vesselgp.synthetic import deform_synthetic

    ves = rs.case_vessel(name)
    gc = vesselgp.fit_generalized_cylinder(ves.V, ves.F)
    row = {"case": name, "length_radii": round(float(gc.length / gc.mean_radius), 1)}
    for tag, (alpha, dalpha) in SWEPT_TWISTS.items():
        try:
            prof = vesselgp.measure_torsion(ves.V, deform_synthetic(ves, twist=alpha), ves.F, rest=gc)
        except vesselgp.VesselError as err:
            row[tag] = {"error": str(err)[:120]}
            continue
        a, e = imposed_twist_errors(prof, gc, ves.truth, alpha, dalpha)
        row[tag] = {"alpha_deg": round(a, 3), "energy_pct": round(e, 2),
                    "residual_deg": round(float(np.degrees(prof.smoothing_residual)), 2)}
    s = np.linspace(0, 1, 2001)
    row["ramp_deg_per_radius"] = round(float(np.degrees(np.abs(SWEPT_TWISTS["ramp"][1](s)).max())
                                             * gc.mean_radius / gc.length), 1)
    return row


def measure_tree(name):
    import real_shapes as rs

    import vesselgp

    net = rs.network_tree(name)
    t0 = time.perf_counter()
    tree = vesselgp.fit_vessel_tree(net.V, net.F)
    dt = time.perf_counter() - t0
    got = [e[m] for e, m in tree_axis_errors(net.truth, tree) if m.any()]
    e = np.concatenate(got)
    return {"tree": name, "vertices": len(net.V), "branches": len(tree.branches), "ends": len(tree.ends),
            "mean": round(float(e.mean()), 4), "worst": round(float(e.max()), 3), "over5": int((e > 5).sum()),
            "fit_s": round(dt, 2)}


def main(argv=None):
    import real_shapes as rs

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--case", nargs="*", choices=sorted(rs.CASES))
    ap.add_argument("--vmtk", help="python of a VMTK environment (shared/peers/vmtk)")
    ap.add_argument("--remesh", action="store_true")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--tree", nargs="*", choices=sorted(rs.NETWORK_TREES), help="measure these network trees "
                    "(all when none is named) instead of the single tubes")
    ap.add_argument("--torsion", action="store_true", help="measure imposed twists on the cases instead")
    a = ap.parse_args(argv)
    if a.torsion:
        names, one = a.case or list(rs.CASES), measure_torsion
    elif a.tree is not None:
        names, one = a.tree or list(rs.NETWORK_TREES), measure_tree
    else:
        names, one = a.case or list(rs.CASES), (lambda name: measure(name, a.vmtk, a.remesh))
    rows = []
    for name in names:
        rows.append(one(name))
        print(json.dumps(rows[-1]), flush=True)
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))
    return 0

if __name__ == "__main__":
    raise SystemExit(main())
