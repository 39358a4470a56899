"""Write the paper's two joining test cases (Section 3, Figs. 2-3) to a folder.

Usage::

    python data_gen/make_paper_cases.py [OUT] [--resolution R] [--seed S] [--pre-rotation A] [--noise N]

For each case ``OUT/case1`` and ``OUT/case2`` get ``vessel.ply`` (the vessel
that is deformed), ``other.ply`` (the vessel joined to), ``truth.npz`` (the
ground truth of both) and ``case.json`` (fixed and moving vertex ids, target
frame, units, seed). Deterministic for a given seed; a few seconds in total.
"""
from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

import numpy as np

import vesselgp.io as vio
from vesselgp.synthetic import paper_case

log = logging.getLogger("make_paper_cases")


def _truth_arrays(prefix, t):
    return {
        f"{prefix}_s": t.s, f"{prefix}_centers": t.centers, f"{prefix}_radii": t.radii,
        f"{prefix}_frames": t.frames, f"{prefix}_alpha": t.alpha, f"{prefix}_vertex_s": t.vertex_s,
        f"{prefix}_vertex_theta": t.vertex_theta, f"{prefix}_vertex_offset": t.vertex_offset,
        f"{prefix}_vertex_on_cap": t.vertex_on_cap,
    }


def write_case(case, folder, resolution):
    """Write one :class:`vesselgp.synthetic.JoinCase` into ``folder``: the case files of
    :func:`vesselgp.io.write_case` (``vessel.ply``, ``other.ply``, ``case.json``) and ``truth.npz``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    vio.write_case(folder, case, resolution)
    np.savez_compressed(folder / "truth.npz", **_truth_arrays("vessel", case.truth),
                        **_truth_arrays("other", case.other_truth))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", default="paper-cases", help="output folder (default ./paper-cases)")
    ap.add_argument("--resolution", type=float, default=1.0, help="points-per-ring multiplier")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--pre-rotation", type=float, default=0.0, help="anchor error, radians")
    ap.add_argument("--noise", type=float, default=0.0, help="relative normal noise")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    for n in (1, 2):
        t0 = time.perf_counter()
        case = paper_case(n, pre_rotation=args.pre_rotation, resolution=args.resolution,
                          seed=args.seed, noise=args.noise)
        write_case(case, Path(args.out) / f"case{n}", args.resolution)
        log.info("case %d (%s): %d + %d vertices, %.2f s -> %s", n, case.name, len(case.V),
                 len(case.other_V), time.perf_counter() - t0, Path(args.out) / f"case{n}")


if __name__ == "__main__":
    main()
