"""Write large synthetic arterial trees with exact centre lines (issue #47, item 3: a benchmark of growth).

Usage::

    python data_gen/big_tree.py [--tips N] [-o OUT] [--voxel V | --target-vertices N | --scale K]
                                [--root-radius R] [--tip-radius R] [--spacing L] [--leaf-length L]
                                [--min-gap G] [--blend B] [--seed S]
    python data_gen/big_tree.py --cases DIR [--seed S]

One tree: ``OUT`` is a mesh file (``.ply``, ``.stl``, ``.obj``, ``.off``, ``.vtp``) written with its
truth beside it (``OUT`` with ``.truth.json`` for the suffix), or a folder that receives ``tree.ply``
and ``truth.json`` as ``data_gen/make_trees.py`` writes them. The tree is built by
:func:`vesselgp.synthetic_tree.synthetic_arterial_tree`: ``--tips`` rounded tips and the root cut
open by the plane z = 0, tapered tubes about cubic Bezier centre lines grown through space without
colliding (a trunk with side branches that branch again), marching cubes of their smooth union on a
narrow band of the grid, every vertex projected onto the exact surface. The truth holds per branch
the Bezier control points, parent, junction, level, length and exact centre-line samples with their
radii; the ends (kind ``open``/``rounded``, centre, radius, outward direction); one root-to-tip path
per tip; units (mm); the mesh's vertex and face counts, voxel, seed and root-loop vertex ids.
``--scale K`` keeps the tree and divides the voxel by sqrt(K): about K times the vertices.

``--cases DIR`` writes the growth benchmark into ``DIR``: ``tips4``, ``tips16``, ``tips64``,
``tips128`` (0.25 mm voxel, tips 0.35 mm) and the 80-end tree ``tips79_x1``, ``_x2``, ``_x4``,
``_x8`` (the same tree at 1, 2, 4 and 8 times its ~340k vertices), each a folder as above, and
``cases.json`` listing them with their sizes and generation times.

Deterministic for a given seed. On 2 busy cores the 79-tip tree at 0.25 mm (about 340k vertices,
5.2 m of vessel) takes about 15-20 s and under 1 GB.
"""
from __future__ import annotations

import argparse
import logging
import math
import sys
import time
from pathlib import Path

import vesselgp.io as vio
from vesselgp.synthetic_tree import synthetic_arterial_tree

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_trees import tree_record  # noqa: E402  (the same truth.json as make_trees.py)

log = logging.getLogger("big_tree")

MESH_SUFFIXES = (".ply", ".stl", ".obj", ".off", ".vtp")

#: The growth benchmark of ``--cases``: (name, tips, vertex multiple of the 0.25 mm voxel).
CASES = (("tips4", 4, 1), ("tips16", 16, 1), ("tips64", 64, 1), ("tips128", 128, 1),
         ("tips79_x1", 79, 1), ("tips79_x2", 79, 2), ("tips79_x4", 79, 4), ("tips79_x8", 79, 8))

#: Voxel of the benchmark's first size (mm): the 0.35 mm tips are 1.4 voxels.
BASE_VOXEL = 0.25


def record(tree, seconds):
    """The truth.json record: make_trees.py's, plus the tree's length, radius range and generation time."""
    rec = tree_record(tree)
    rec["total_length"] = float(sum(b.length for b in tree.truth.branches))
    rec["radius_range"] = [float(min(b.radii.min() for b in tree.truth.branches)),
                           float(max(b.radii.max() for b in tree.truth.branches))]
    rec["seconds"] = float(seconds)
    return rec


def write(tree, out, seconds):
    """Write the mesh and its truth to ``out`` (a mesh file, truth beside it, or a folder); both paths."""
    out = Path(out)
    if out.suffix.lower() in MESH_SUFFIXES:
        out.parent.mkdir(parents=True, exist_ok=True)
        mesh, truth = out, out.with_suffix(".truth.json")
    else:
        out.mkdir(parents=True, exist_ok=True)
        mesh, truth = out / "tree.ply", out / "truth.json"
    vio.write_mesh(mesh, tree.V, tree.F)
    vio.write_json(truth, record(tree, seconds))
    return mesh, truth


def make(tips, voxel, **kw):
    """The tree and the seconds it took."""
    t0 = time.perf_counter()
    tree = synthetic_arterial_tree(tips, voxel=voxel, **kw)
    return tree, time.perf_counter() - t0


def write_cases(folder, seed=0):
    """Write every case of :data:`CASES` into ``folder`` and ``cases.json`` listing them."""
    folder = Path(folder)
    rows = []
    for name, tips, scale in CASES:
        tree, sec = make(tips, BASE_VOXEL / math.sqrt(scale), seed=seed)
        write(tree, folder / name, sec)
        rows.append({"name": name, "tips": tips, "scale": scale, "voxel": tree.voxel, "n_vertices": len(tree.V),
                     "n_faces": len(tree.F), "branches": len(tree.truth.branches), "seconds": sec,
                     "total_length": float(sum(b.length for b in tree.truth.branches))})
        log.info("%s: %d tips, %d vertices, voxel %.4f mm, %.1f s", name, tips, len(tree.V), tree.voxel, sec)
    return vio.write_json(folder / "cases.json", {"seed": seed, "units": "mm", "cases": rows})


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tips", type=int, default=79, help="rounded tips (default 79: 80 ends with the root)")
    ap.add_argument("-o", "--out", default="big_tree", help="mesh file (truth beside it) or folder")
    ap.add_argument("--cases", metavar="DIR", help="write the whole growth benchmark into DIR instead")
    size = ap.add_mutually_exclusive_group()
    size.add_argument("--voxel", type=float, default=BASE_VOXEL, help="grid spacing, mm (default 0.25)")
    size.add_argument("--target-vertices", type=int, help="choose the voxel for about this many vertices")
    size.add_argument("--scale", type=float, help="about this many times the vertices at 0.25 mm (voxel / sqrt)")
    ap.add_argument("--root-radius", type=float, default=1.8, help="mm (default 1.8)")
    ap.add_argument("--tip-radius", type=float, default=0.35, help="mm (default 0.35)")
    ap.add_argument("--spacing", type=float, default=12.0, help="mean vessel length between junctions, mm")
    ap.add_argument("--leaf-length", type=float, default=55.0, help="mean terminal branch length, mm")
    ap.add_argument("--min-gap", type=float, default=1.0, help="least wall gap between vessels, mm")
    ap.add_argument("--blend", type=float, help="junction blend width, mm (default half the tip radius)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    if args.cases:
        log.info("-> %s", write_cases(args.cases, args.seed))
        return
    voxel = BASE_VOXEL / math.sqrt(args.scale) if args.scale else args.voxel
    tree, sec = make(args.tips, voxel, target_vertices=args.target_vertices, root_radius=args.root_radius,
                     tip_radius=args.tip_radius, spacing=args.spacing, leaf_length=args.leaf_length,
                     min_gap=args.min_gap, blend=args.blend, seed=args.seed)
    mesh, _ = write(tree, args.out, sec)
    log.info("%d tips, %d branches, %d vertices, voxel %.4f mm, %.0f mm of vessel, %.1f s -> %s",
             len(tree.truth.tips), len(tree.truth.branches), len(tree.V), tree.voxel,
             sum(b.length for b in tree.truth.branches), sec, mesh)


if __name__ == "__main__":
    main()
