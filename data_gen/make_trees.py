"""Write a synthetic vessel tree with exact centre lines to a folder.

Usage::

    python data_gen/make_trees.py OUT [--levels N | --parents P ...] [--staircase] [--voxel V]
                                      [--target-vertices N] [--blend B] [--seed S]

``OUT/tree.ply`` is the mesh (root end open: one boundary loop in the plane
z = 0; rounded tips), ``OUT/truth.json`` its ground truth built by
:func:`vesselgp.synthetic_tree.synthetic_tree`: per branch the Bezier control
points, parent, junction, level, length and exact centre-line samples with
their radii; the ends (kind ``open``/``rounded``, centre, radius, outward
direction); one root-to-tip path per tip; units (mm); the mesh's vertex and
face counts, voxel, seed and root-loop vertex ids. Deterministic for a given
seed; about a second for the ~27k-vertex 4-tip tree (``--target-vertices 27000``).
"""
from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

import vesselgp.io as vio
from vesselgp.synthetic_tree import synthetic_tree

log = logging.getLogger("make_trees")


def tree_record(tree):
    """The JSON record of a :class:`~vesselgp.synthetic_tree.SyntheticTree` (truth and mesh facts)."""
    return {
        **tree.truth.to_dict(),
        "n_vertices": len(tree.V), "n_faces": len(tree.F), "voxel": tree.voxel,
        "staircase": tree.staircase, "seed": tree.seed, "root_loop": tree.root_loop,
        "n_tips": len(tree.truth.tips),
    }


def write_tree(tree, folder):
    """Write ``tree.ply`` and ``truth.json`` into ``folder`` (created if needed); returns both paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    vio.write_mesh(folder / "tree.ply", tree.V, tree.F)
    return folder / "tree.ply", vio.write_json(folder / "truth.json", tree_record(tree))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", help="output folder")
    shape = ap.add_mutually_exclusive_group()
    shape.add_argument("--levels", type=int, default=2, help="bifurcation levels (2: four tips; default)")
    shape.add_argument("--parents", type=int, nargs="+", help="parent of each branch, -1 first "
                       "(e.g. -1 0 0 1 1: three tips)")
    ap.add_argument("--staircase", action="store_true", help="voxel boundary (axis-aligned terraces)")
    ap.add_argument("--voxel", type=float, default=0.4, help="grid spacing, mm (default 0.4)")
    ap.add_argument("--target-vertices", type=int, help="choose the voxel for about this many vertices")
    ap.add_argument("--blend", type=float, default=0.25, help="junction blend width, root radii (0: crease)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    t0 = time.perf_counter()
    tree = synthetic_tree(args.levels, parents=args.parents, staircase=args.staircase, voxel=args.voxel,
                          target_vertices=args.target_vertices, blend=args.blend, seed=args.seed)
    write_tree(tree, args.out)
    log.info("%d tips, %d vertices, voxel %.3f mm, %.2f s -> %s", len(tree.truth.tips), len(tree.V),
             tree.voxel, time.perf_counter() - t0, args.out)


if __name__ == "__main__":
    main()
