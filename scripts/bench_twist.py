#!/usr/bin/env python
"""Benchmark of the twist between two scans (issue #15): ``twist_between`` beside the two tree fits it needs.

For each synthetic pair (``vesselgp.synthetic.twist_pair``: two independently meshed states of a vessel
with side branches, bent differently, shortened, twisted by a known alpha(s) and moved rigidly): the
median time of ``twist_between`` (ends, two tree fits, two main-vessel fits, landmarks, matching), of the
two ``fit_vessel_tree`` calls alone, their ratio (target <= 2), and the worst segment and total error
against the imposed twist (target <= 2 degrees).

Usage::

    python scripts/bench_twist.py
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from bench import timeit

#: The issue's targets.
RATIO_LIMIT = 2.0
ERROR_LIMIT_DEG = 2.0

CASES = {
    "4 branches, 60 deg, 13 % shorter": dict(n_branches=4, seed=1),
    "3 branches, -80 deg, 10 % shorter": dict(n_branches=3, twist_deg=-80.0, stretch=0.9, seed=5),
    "5 branches, 120 deg, 15 % shorter": dict(n_branches=5, twist_deg=120.0, stretch=0.85, seed=6, length=140.0),
    "6 branches, 45 deg, bends 10/40 deg": dict(n_branches=6, twist_deg=45.0, stretch=0.86, seed=8, length=160.0,
                                                bend_deg=(10.0, 40.0)),
}


def bench_twist(repeat=3, cases=None):
    import vesselgp as vg
    from vesselgp.synthetic import twist_pair

    rows = []
    for name, kw in (cases or CASES).items():
        p = twist_pair(**kw)
        t, r = timeit(lambda: vg.twist_between(p.a.V, p.a.F, p.V_b, p.b.F), repeat)
        tt, _ = timeit(lambda: (vg.fit_vessel_tree(p.a.V, p.a.F), vg.fit_vessel_tree(p.V_b, p.b.F)), repeat)
        err = np.degrees(r.segment_twist - p.segment_twist)
        rows.append({"case": name, "vertices_a": len(p.a.V), "vertices_b": len(p.V_b), "landmarks": len(r.s_a),
                     "twist_between_s": t, "two_tree_fits_s": tt, "ratio": t / tt,
                     "worst_segment_error_deg": float(np.abs(err).max()),
                     "total_error_deg": float(np.degrees(r.total_twist - p.total_twist)),
                     "total_twist_deg": float(np.degrees(p.total_twist))})
    return rows


def twist_markdown(rows):
    head = ("| pair | vertices A / B | landmarks | twist_between (s) | two tree fits (s) | ratio | worst segment "
            "error (deg) | total twist (error) (deg) |\n|---|---:|---:|---:|---:|---:|---:|---:|")
    body = [f"| {r['case']} | {r['vertices_a']:,} / {r['vertices_b']:,} | {r['landmarks']} | "
            f"{r['twist_between_s']:.2f} | {r['two_tree_fits_s']:.2f} | {r['ratio']:.2f} | "
            f"{r['worst_segment_error_deg']:.2f} | {r['total_twist_deg']:.1f} ({r['total_error_deg']:+.2f}) |"
            for r in rows]
    return "\n".join([head, *body])


def twist_targets(rows):
    out = []
    for r in rows:
        out.append({"target": f"twist_between / two tree fits, {r['case']}", "value": r["ratio"],
                    "limit": RATIO_LIMIT, "unit": "x", "vertices": r["vertices_a"]})
        out.append({"target": f"worst segment twist error, {r['case']}", "value": r["worst_segment_error_deg"],
                    "limit": ERROR_LIMIT_DEG, "unit": "deg", "vertices": r["vertices_a"]})
    for t in out:
        t["status"] = "PASS" if t["value"] <= t["limit"] else "MISS"
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    import logging

    logging.basicConfig(level=logging.ERROR)
    rows = bench_twist(args.repeat)
    print(twist_markdown(rows))
    for t in twist_targets(rows):
        print(f"{t['target']}: {t['value']:.3g} {t['unit']} (<= {t['limit']}) {t['status']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
