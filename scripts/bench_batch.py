#!/usr/bin/env python
"""Benchmark of cohort batches (issue #17): ``vesselgp.batch.run`` on 2 Dask workers against a serial run.

A cohort of ``--n`` distinct synthetic meshes (vessel trees and single vessels of ``--vertices``
vertices, written as PLY; distinct, or the batch would compute identical inputs once) is run into
fresh output folders, ``--repeat`` times in turn (the fastest of each kept: the machine's speed
drifts by tens of per cent within a minute):

* through the API in this process: serially (``workers=0``, no Dask), and on LocalClusters of 1
  and of 2 worker processes (one thread each, as Dask sets them), whose start-up is included;
* as whole commands, ``vesselgp batch --workers 0`` and ``--workers 2``, each a new process with
  its own start-up and imports, as a user runs them. The target (>= 1.6x on 2 cores) is read on
  these; the API's serial run had its imports done before its clock started.

The results of the runs must agree to 1e-9.

``--crossover`` measures instead where Dask starts to pay (issue #36): whole commands
``vesselgp batch --workers 0`` and ``--workers 2`` on the first ``n`` rows of a cohort of small
distinct meshes, for growing ``n``, and a least-squares fit of both times against the serial work
(the sum of the rows' own times): serial = a + W, Dask = a + C + W / S. C is Dask's fixed cost
(import, cluster start-up, the workers' imports, shut-down), S its speed-up on the rows; the
default runner's rule (``tolerances.BATCH_DASK_STARTUP_S``, ``BATCH_DASK_EFFICIENCY``, ``BATCH_DASK_ROW_S``) is set
from them.

Usage::

    python scripts/bench_batch.py               # 16 meshes of ~60k vertices
    python scripts/bench_batch.py --n 12 --vertices 15000
    python scripts/bench_batch.py --crossover tree --counts 1 2 3 4 6 8 12
    python scripts/bench_batch.py --crossover vessel --counts 8 16 32 64 128
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

#: The issue's target.
SPEEDUP_TARGET = 1.6
#: ``vesselgp`` on the command line, run by this interpreter.
CLI = "import sys\nfrom vesselgp.cli import main\nsys.exit(main(sys.argv[1:]))"


def make_cohort(folder, n, vertices):
    import vesselgp as vg
    from vesselgp.synthetic import synthetic_tree, synthetic_vessel

    rows = ["mesh"]
    for i in range(n):
        if i % 2:  # a different tree each time (levels 1-2, its own random layout)
            t = synthetic_tree(1 + (i // 2) % 2, seed=i, target_vertices=vertices)
            V, F = t.V, t.F
        else:  # a different single vessel each time (radius)
            r = 12.0 + 0.25 * i
            na = max(16, int(round(np.sqrt(vertices * 2 * np.pi * r / 251.9))))
            v = synthetic_vessel("aortic_arch", radius=r, n_around=na, remesh=False)
            V, F = v.V, v.F
        vg.write_mesh(Path(folder) / f"m{i:02d}.ply", V, F)
        rows.append(f"m{i:02d}.ply")
    (Path(folder) / "cohort.csv").write_text("\n".join(rows) + "\n")
    return Path(folder) / "cohort.csv"


def bench_batch(n=16, vertices=60_000, workers=2, repeat=2):
    """Serial in this process (libraries free to use every core), then Dask with 1 and with ``workers`` workers.

    The three runs are repeated ``repeat`` times, in turn, and each one's fastest time is kept: the
    machine's speed drifts by tens of per cent over a minute, and runs taken in turn see the same drift.
    """
    from vesselgp import batch

    with tempfile.TemporaryDirectory(prefix="vesselgp-bench-batch-") as tmp:
        manifest = make_cohort(tmp, n, vertices)
        times, reps = {}, {}
        for rep in range(repeat):
            for w in (0, 1, workers):
                t0 = time.perf_counter()
                reps[w] = batch.run(manifest, Path(tmp) / f"out{w}-{rep}", workers=w)
                times[w] = min(times.get(w, np.inf), time.perf_counter() - t0)
        for rep in range(repeat):  # whole commands, as a user runs them: start-up and imports in both
            for w in (0, workers):
                out = Path(tmp) / f"cli{w}-{rep}"
                t0 = time.perf_counter()
                subprocess.run([sys.executable, "-c", CLI, "batch", str(manifest), "-o", str(out), "--workers", str(w),
                                "-q"], check=True, capture_output=True)
                times[f"cli{w}"] = min(times.get(f"cli{w}", np.inf), time.perf_counter() - t0)
        keys = ("length", "mean_radius", "n_ends")
        agree = all(np.allclose([a[k] for k in keys], [b[k] for k in keys], rtol=1e-9)
                    for a, b in zip(reps[0].rows, reps[workers].rows))
        return {"meshes": n, "vertices": vertices, "workers": workers, "serial_s": times[0], "one_worker_s": times[1],
                "dask_s": times[workers], "api_speedup": times[0] / times[workers],
                "cli_serial_s": times["cli0"], "cli_dask_s": times[f"cli{workers}"],
                "speedup": times["cli0"] / times[f"cli{workers}"],
                "speedup_vs_one_worker": times[1] / times[workers], "repeat": repeat,
                "failed": sum(r.failed for r in reps.values()), "agree_1e-9": bool(agree)}


def batch_markdown(r):
    return ("| meshes | vertices each | API: serial, in-process (s) | API: 1 Dask worker (s) | API: 2 Dask workers (s) | "
            "API speed-up | vs 1 worker | CLI: --workers 0 (s) | CLI: --workers 2 (s) | CLI speed-up | results agree |\n"
            "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n"
            f"| {r['meshes']} | ~{r['vertices']:,} | {r['serial_s']:.1f} | {r['one_worker_s']:.1f} | {r['dask_s']:.1f} | "
            f"{r['api_speedup']:.2f} | {r['speedup_vs_one_worker']:.2f} | {r['cli_serial_s']:.1f} | {r['cli_dask_s']:.1f} | "
            f"{r['speedup']:.2f} | {'yes' if r['agree_1e-9'] else 'NO'} |")


def batch_targets(r):
    if r is None:
        return []
    return [{"target": f"batch speed-up, vesselgp batch --workers 2 vs --workers 0, {r['meshes']} meshes", "value": r["speedup"],
             "limit": SPEEDUP_TARGET, "unit": "x", "vertices": r["vertices"],
             "status": "PASS" if r["speedup"] >= SPEEDUP_TARGET and r["agree_1e-9"] else "MISS"}]


def make_small_cohort(folder, n, kind):
    """``n`` distinct small meshes: Y-shaped trees (~6k vertices, ~0.4 s a row) or single vessels (~1-4k, ~0.04 s)."""
    import vesselgp as vg
    from vesselgp.synthetic import synthetic_tree, synthetic_vessel

    rows = ["mesh"]
    for i in range(n):
        if kind == "tree":
            m = synthetic_tree(levels=1, voxel=0.6, seed=i)
        else:
            m = synthetic_vessel(("arc", "straight", "s_curve", "helix")[i % 4], radius=1.2 + 0.01 * i,
                                 n_around=16 + i % 16)
        vg.write_mesh(Path(folder) / f"m{i:03d}.ply", m.V, m.F)
        rows.append(f"m{i:03d}.ply")
    return rows


def bench_crossover(kind="tree", counts=(1, 2, 3, 4, 6, 8, 12), repeat=2):
    """Whole commands, serial and on 2 Dask workers, on the first ``n`` rows; the fitted fixed cost and speed-up."""
    import json

    with tempfile.TemporaryDirectory(prefix="vesselgp-bench-crossover-") as tmp:
        rows = make_small_cohort(tmp, max(counts), kind)
        table = []
        for n in counts:
            manifest = Path(tmp) / f"first{n}.csv"
            manifest.write_text("\n".join(rows[:n + 1]) + "\n")
            t = {}
            for rep in range(repeat):
                for w in (0, 2):
                    out = Path(tmp) / f"out{n}-{w}-{rep}"
                    t0 = time.perf_counter()
                    r = subprocess.run([sys.executable, "-c", CLI, "batch", str(manifest), "-o", str(out), "--workers",
                                        str(w), "-q", "--json"], check=True, capture_output=True, text=True)
                    t[w] = min(t.get(w, np.inf), time.perf_counter() - t0)
                    if w == 0 and rep == 0:
                        import csv

                        with open(out / "results.csv") as fh:
                            work = sum(float(x["time_s"]) for x in csv.DictReader(fh))
                    assert json.loads(r.stdout)["failed"] == 0
            table.append({"n": n, "work_s": work, "serial_s": t[0], "dask_s": t[2]})
    W = np.array([r["work_s"] for r in table])
    ser = np.array([r["serial_s"] for r in table])
    dask = np.array([r["dask_s"] for r in table])
    a = float(np.median(ser - W))  # serial = a + W: the command's own start-up and imports
    # dask = a + C + W / S, with W read off the serial command (serial - a): its noise is the machine's drift
    (inv_s, c), *_ = np.linalg.lstsq(np.c_[ser - a, np.ones_like(ser)], dask - a, rcond=None)
    return {"kind": kind, "rows": table, "startup_s": a, "dask_fixed_s": float(c), "dask_speedup": float(1 / inv_s),
            "crossover_work_s": float(c / (1 - inv_s)) if inv_s < 1 else None}


def crossover_markdown(r):
    lines = [f"{r['kind']} rows: command start-up {r['startup_s']:.2f} s; Dask's fixed cost {r['dask_fixed_s']:.2f} s, "
             f"speed-up on 2 workers {r['dask_speedup']:.2f}: Dask pays above "
             + (f"{r['crossover_work_s']:.2f} s of serial work" if r["crossover_work_s"] else "never"),
             "", "| rows | serial work (s) | --workers 0 (s) | --workers 2 (s) | Dask / serial |",
             "|---:|---:|---:|---:|---:|"]
    lines += [f"| {x['n']} | {x['work_s']:.2f} | {x['serial_s']:.2f} | {x['dask_s']:.2f} | "
              f"{x['dask_s'] / x['serial_s']:.2f} |" for x in r["rows"]]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=16)
    ap.add_argument("--vertices", type=int, default=60_000)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--crossover", choices=("tree", "vessel"), help="measure where Dask starts to pay, on these rows")
    ap.add_argument("--counts", type=int, nargs="+", default=[1, 2, 3, 4, 6, 8, 12], help="row counts of --crossover")
    args = ap.parse_args(argv)
    import logging

    logging.basicConfig(level=logging.ERROR)
    if args.crossover:
        print(crossover_markdown(bench_crossover(args.crossover, args.counts, args.repeat)))
        return 0
    r = bench_batch(args.n, args.vertices, repeat=args.repeat)
    print(batch_markdown(r))
    for t in batch_targets(r):
        print(f"{t['target']}: {t['value']:.2f} x (>= {t['limit']}) {t['status']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
