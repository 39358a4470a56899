#!/usr/bin/env python
"""Vessel-tree benchmark (issue #13): fit_vessel_tree beside a libigl cotmatrix and VMTK on the same mesh.

For each size, a synthetic 4-tip tree (``synthetic_tree(levels=2, target_vertices=n)``; the 2-tip
``levels=1`` tree below 20k vertices, where a 4-tip tree's thinnest tube would be under 2.5 voxels): the
median time of ``fit_vessel_tree`` (ends, branch decomposition, branch fits, paths, axis checks),
of one ``igl.cotmatrix`` of the same mesh (the machine-independent yardstick), their ratio, and the
path-axis error against the exact centre lines away from junctions (2 r) and tips (1.5 r).

When the VMTK peer environment exists (``../shared/peers/vmtk``; ``--vmtk PYTHON`` or
``/tmp/peer-vmtk/bin/python``), VMTK runs on the same mesh (STL) in its own process with its fastest
Delaunay (qhull), seeded at the true root and tip centres: its centre-line stages
(``qhull_tessellation + centerlines``), its branch splitting, and the error of its lines.

Usage::

    python scripts/bench_tree.py                  # 27k, 50k, 200k trees (VMTK on 27k)
    python scripts/bench_tree.py --sizes 27k --vmtk /tmp/peer-vmtk/bin/python
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench import number, timeit

REPO = Path(__file__).resolve().parents[1]
PEER = REPO.parent / "shared" / "peers" / "vmtk" / "vmtk_tree.py"
DEFAULT_VMTK = Path("/tmp/peer-vmtk/bin/python")


def add_vmtk_options(ap):
    """``--vmtk PYTHON`` and ``--no-vmtk`` (shared with bench_small.py)."""
    ap.add_argument("--vmtk", help="python of the VMTK peer venv (default /tmp/peer-vmtk/bin/python if present)")
    ap.add_argument("--no-vmtk", action="store_true")


def vmtk_from_args(args):
    """The VMTK venv's python from those options, or None (not asked for, or not there)."""
    if args.no_vmtk:
        return None
    return Path(args.vmtk) if args.vmtk else (DEFAULT_VMTK if DEFAULT_VMTK.exists() else None)


def _errors(truth, P):
    """Worst and mean distance (% of the true radius) of points to the true centre lines, interior only."""
    d, r, _, _ = truth.nearest(P)
    keep = truth.interior_mask(P)
    e = 100 * d[keep] / r[keep]
    return float(e.max()), float(e.mean())


def _vmtk(python, stl, truth, tmp, timeout=None):
    """VMTK's tree on the same mesh: stage timings and the error of its centre lines."""
    src = truth.ends[0].center
    tg = np.concatenate([e.center for e in truth.tips])
    out = os.path.join(tmp, "vmtk.npz")
    cmd = [str(python), str(PEER), str(stl), "--source", *map(str, src), "--targets", *map(str, tg),
           "--delaunay", "qhull", "-o", out]
    res = subprocess.run(cmd, capture_output=True, text=True, check=True, timeout=timeout)
    tm = json.loads(res.stdout.strip().splitlines()[-1])["timings_s"]
    z = np.load(out)
    lines = [z[k] for k in z.files if k.endswith("_points")]
    errs = [_errors(truth, L) for L in lines]
    return {"vmtk_centerline_s": tm["qhull_tessellation"] + tm["centerlines"],
            "vmtk_branch_split_s": tm["branch_extractor"],
            "vmtk_axis_max_pct": max(e[0] for e in errs), "vmtk_axis_mean_pct": float(np.mean([e[1] for e in errs]))}


#: Taubin iterations for the voxel-staircase trees (what the staircase error advises; tests use 10).
STAIRCASE_SMOOTH = 10


def _tree_mesh(n_target, surface):
    """The synthetic tree and its mesh: the marching-cubes surface, or a segmentation-like one.

    ``"staircase"``: the voxel boundary of the same kind of tree (axis-aligned terraces, as a
    thresholded segmentation gives), smoothed by ``clean_mesh(smooth=STAIRCASE_SMOOTH)`` as the
    staircase error advises; its voxel is chosen for about ``n_target`` vertices after cleaning.
    """
    from vesselgp import clean_mesh
    from vesselgp.synthetic import synthetic_tree

    if surface == "exact":
        # below ~20k vertices a 4-tip tree's thinnest tube would be under 2.5 voxels across:
        # the small size is the 2-tip tree (levels=1)
        t = synthetic_tree(levels=2 if n_target >= 20_000 else 1, target_vertices=n_target)
        return t, t.V, t.F
    voxel = 0.4 * np.sqrt(22_610 / n_target)  # 0.4 gives 22.6k vertices after cleaning
    t = synthetic_tree(levels=2, voxel=voxel, staircase=True)
    V, F, _ = clean_mesh(t.V, t.F, smooth=STAIRCASE_SMOOTH)
    return t, V, F


def bench_tree(n_target, repeat, vmtk_python=None, surface="exact"):
    import igl

    from vesselgp.io import write_mesh
    from vesselgp.tree import fit_vessel_tree

    t, V, F = _tree_mesh(n_target, surface)
    row = {"surface": surface, "vertices": len(V), "tips": len(t.truth.tips)}
    fit_vessel_tree(V, F)  # warm-up: lazy imports
    row["fit_vessel_tree_s"], tree = timeit(lambda: fit_vessel_tree(V, F), repeat)
    row["cotmatrix_s"], _ = timeit(lambda: igl.cotmatrix(V, F), max(repeat, 5))
    row["tree_over_cotmatrix"] = row["fit_vessel_tree_s"] / row["cotmatrix_s"]
    errs = [_errors(t.truth, p.dense_points) for p in tree.paths]
    row["axis_max_pct"] = max(e[0] for e in errs)
    row["axis_mean_pct"] = float(np.mean([e[1] for e in errs]))
    row["branches"], row["paths"] = len(tree.branches), len(tree.paths)
    if vmtk_python is not None and PEER.exists():
        with tempfile.TemporaryDirectory(prefix="vesselgp-vmtk-") as tmp:
            stl = os.path.join(tmp, "tree.stl")
            write_mesh(stl, V, F)
            row.update(_vmtk(vmtk_python, stl, t.truth, tmp))
        row["vmtk_over_tree"] = row["vmtk_centerline_s"] / row["fit_vessel_tree_s"]
    return row


def tree_targets(rows):
    """Issue #13 targets, per surface: <= 0.5 s and <= 1/10 of VMTK's time for the ~27k 4-tip tree
    (its centre lines and branch splitting, as the issue measured VMTK; also against its centre
    lines alone); accuracy within 5 % / 1 % of the radius and better than VMTK's on the same mesh."""
    out = []
    for surface in ("exact", "staircase"):
        cand = [x for x in rows if x.get("surface", "exact") == surface]
        r = min(cand, key=lambda x: abs(x["vertices"] - 27_000)) if cand else None
        if r is None or abs(r["vertices"] - 27_000) > 0.35 * 27_000:
            continue
        tag = f"~27k tree ({surface})"
        out.append({"target": f"fit_vessel_tree, {tag}", "value": r["fit_vessel_tree_s"], "limit": 0.5,
                    "unit": "s", "vertices": r["vertices"]})
        if "vmtk_centerline_s" in r:
            # the measure: VMTK's time "including branch splitting" (its 4.9 s); and the
            # stricter one against its centre lines alone
            out.append({"target": f"fit_vessel_tree / VMTK centre lines + branch split (qhull), {tag}",
                        "value": r["fit_vessel_tree_s"] / (r["vmtk_centerline_s"] + r["vmtk_branch_split_s"]),
                        "limit": 1 / 15, "unit": "x", "vertices": r["vertices"]})  # issue #47: 15x
            out.append({"target": f"fit_vessel_tree / VMTK centre lines alone (qhull), {tag}",
                        "value": r["fit_vessel_tree_s"] / r["vmtk_centerline_s"], "limit": 0.1, "unit": "x",
                        "vertices": r["vertices"]})
        out.append({"target": f"worst path-axis error, {tag}", "value": r["axis_max_pct"], "limit": 5.0,
                    "unit": "% r", "vertices": r["vertices"]})
        out.append({"target": f"mean path-axis error, {tag}", "value": r["axis_mean_pct"], "limit": 1.0,
                    "unit": "% r", "vertices": r["vertices"]})
        if "vmtk_axis_max_pct" in r:
            for k, what in (("max", "worst"), ("mean", "mean")):
                out.append({"target": f"{what} path-axis error / VMTK's, {tag}",
                            "value": r[f"axis_{k}_pct"] / r[f"vmtk_axis_{k}_pct"], "limit": 1.0, "unit": "x",
                            "vertices": r["vertices"]})
    for t in out:
        t["status"] = "PASS" if t["value"] <= t["limit"] else "MISS"
    return out


def tree_markdown(rows):
    f = number

    L = ["Vessel trees: synthetic_tree(levels=2) (4 tips, root cut open); surface 'exact' is its marching-cubes "
         "surface (target_vertices=n), 'staircase' its voxel boundary smoothed by clean_mesh(smooth="
         f"{STAIRCASE_SMOOTH}) (segmentation-like). Times in s (median); VMTK 1.5.2 with qhull in its own venv, "
         "seeded at the true end centres; errors in % of the true radius away from junctions (2 r) and tips (1.5 r).",
         "", "| surface | vertices | fit_vessel_tree | igl.cotmatrix | tree / cotmatrix | axis max / mean (%) "
         "| VMTK centre lines | VMTK branch split | VMTK axis max / mean (%) | VMTK lines / our tree |",
         "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        vm = "vmtk_centerline_s" in r
        L.append(f"| {r.get('surface', 'exact')} | {r['vertices']:,} | {f(r['fit_vessel_tree_s'])} | {f(r['cotmatrix_s'], 4)} "
                 f"| {f(r['tree_over_cotmatrix'], 0)} | {f(r['axis_max_pct'], 2)} / {f(r['axis_mean_pct'], 3)} "
                 f"| {f(r.get('vmtk_centerline_s'))} | {f(r.get('vmtk_branch_split_s'))} "
                 f"| {(f(r['vmtk_axis_max_pct'], 2) + ' / ' + f(r['vmtk_axis_mean_pct'], 3)) if vm else '-'} "
                 f"| {f(r.get('vmtk_over_tree'), 1)} |")
    return "\n".join(L)


def _fit_row(label, V, F, truth, vmtk_python, repeat):
    """One row of the growth tables: vertices, ends found, fit time, the exact-truth error, VMTK beside."""
    from vesselgp import fit_vessel_tree
    from vesselgp.io import write_mesh

    row = {"case": label, "vertices": len(V), "tips": len(truth.tips)}
    t, tree = timeit(lambda: fit_vessel_tree(V, F), repeat)
    row["fit_vessel_tree_s"] = t
    row["ends_found"] = len(tree.ends)
    errs = [_errors(truth, p.dense_points) for p in tree.paths]
    row["axis_max_pct"] = max(e[0] for e in errs)
    row["axis_mean_pct"] = float(np.mean([e[1] for e in errs]))
    if vmtk_python is not None and PEER.exists() and len(V) <= VMTK_GROWTH_MAX_VERTICES:
        with tempfile.TemporaryDirectory(prefix="vesselgp-vmtk-") as tmp:
            stl = os.path.join(tmp, "tree.stl")
            write_mesh(stl, V, F)
            try:
                row.update(_vmtk(vmtk_python, stl, truth, tmp, timeout=VMTK_TIMEOUT_S))
                row["vmtk_over_tree"] = (row["vmtk_centerline_s"] + row["vmtk_branch_split_s"]) / t
            except subprocess.TimeoutExpired:
                row["vmtk_centerline_s"] = f"> {VMTK_TIMEOUT_S}"
    return row


#: VMTK is stopped after this long on one growth-table tree (it did not finish a 321k-vertex tree in 25 min) ...
VMTK_TIMEOUT_S = 600
#: ... and runs only on the trees up to this size (its branch splitting took 147 s on the 27k-vertex tree).
VMTK_GROWTH_MAX_VERTICES = 30_000


def growth(vertex_scales=(1, 2, 4, 8), tips=(4, 16, 64, 128), repeat=1, vmtk_python=None, base=27_000):
    """The growth tables of issue #47: the 4-tip tree at 1, 2, 4 and 8 times ``base`` vertices; trees of
    ``synthetic_arterial_tree`` with 4-128 tips (thinnest 0.35 mm at a 0.25 mm voxel); and the 80-end tree of
    about 300k vertices. Each row: time, ends found, error against the exact centre lines, VMTK beside."""
    from vesselgp.synthetic import synthetic_arterial_tree, synthetic_tree

    rows = []
    for k in vertex_scales:
        t = synthetic_tree(levels=2, target_vertices=int(base * k))
        rows.append({"table": "vertices", **_fit_row(f"4 tips, {k}x", t.V, t.F, t.truth, vmtk_python, repeat)})
        print("   ", rows[-1], flush=True)
    for n in tips:
        t = synthetic_arterial_tree(n)
        rows.append({"table": "tips", **_fit_row(f"{n} tips", t.V, t.F, t.truth, vmtk_python, repeat)})
        print("   ", rows[-1], flush=True)
    t = synthetic_arterial_tree(79, voxel=FOREST_80_VOXEL)
    rows.append({"table": "80 ends", **_fit_row("79 tips + root", t.V, t.F, t.truth, vmtk_python, 1)})
    print("   ", rows[-1], flush=True)
    return rows


#: The voxel that gives the 80-end tree (79 tips) about 300k vertices.
FOREST_80_VOXEL = 0.264


def growth_markdown(rows):
    f = number
    L = ["| table | case | vertices | tips | ends found | fit_vessel_tree (s) | s per 100k vertices | axis max / mean (% r) "
         "| VMTK lines + split (s) | VMTK / ours |", "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        vm = r.get("vmtk_centerline_s")
        vt = (f"{f(vm + r['vmtk_branch_split_s'])}" if isinstance(vm, float) else (vm or "-"))
        L.append(f"| {r['table']} | {r['case']} | {r['vertices']:,} | {r['tips']} | {r['ends_found']} "
                 f"| {f(r['fit_vessel_tree_s'])} | {f(1e5 * r['fit_vessel_tree_s'] / r['vertices'])} "
                 f"| {f(r['axis_max_pct'], 2)} / {f(r['axis_mean_pct'], 3)} | {vt} | {f(r.get('vmtk_over_tree'), 1)} |")
    return "\n".join(L)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="27k,50k,200k")
    ap.add_argument("--staircase-sizes", default="27k",
                    help="sizes of the segmentation-like (smoothed voxel staircase) tree, VMTK beside the ~27k one")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--growth", action="store_true",
                    help="instead, the growth tables of issue #47 (vertices 1-8x, 4-128 tips, the 80-end tree)")
    add_vmtk_options(ap)
    ap.add_argument("--json", default=str(REPO / "bench-results" / "bench_tree.json"))
    args = ap.parse_args(argv)
    import logging

    logging.basicConfig(level=logging.ERROR)
    vm = vmtk_from_args(args)
    if args.growth:
        rows = growth(repeat=1, vmtk_python=vm)
        print(growth_markdown(rows))
        out = Path(args.json).with_name("bench_tree_growth.json")
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps({"rows": rows}, indent=1))
        return 0
    rows = []
    jobs = [(tok, "exact") for tok in args.sizes.split(",") if tok.strip()]
    jobs += [(tok, "staircase") for tok in args.staircase_sizes.split(",") if tok.strip()]
    for tok, surface in jobs:
        n = int(float(tok[:-1]) * 1000) if tok.lower().endswith("k") else int(tok)
        print(f"tree ~{tok} ({surface}) ...", flush=True)
        rows.append(bench_tree(n, args.repeat, vm if n <= 30_000 else None, surface))
        print("   ", {k: (round(v, 4) if isinstance(v, float) else v) for k, v in rows[-1].items()}, flush=True)
    print()
    print(tree_markdown(rows))
    targets = tree_targets(rows)
    print()
    for t in targets:
        print(f"| {t['target']} | {t['vertices']:,} | {t['value']:.3g} {t['unit']} | <= {t['limit']:g} {t['unit']} "
              f"| {t['status']} |")
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"rows": rows, "targets": targets}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
