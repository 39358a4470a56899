"""The README's three pictures, regenerated with the library's current figure styles.

    python scripts/docs_pictures.py [--data ../shared/data/real] [--out docs] [--width 900]

Writes, each scaled to ``--width`` pixels and stored as a palette PNG (about 100 KB or less):

* ``docs/tree.png``: the real abdominal aorta with its renal and iliac arteries
  (``gmsh_abdominal-aorta-renal-iliac_open.stl``) fitted as a tree (``fit_vessel_tree``), shaded by
  each vertex's distance to the nearest branch axis in mm, the branch axes drawn (``render_mesh``);
* ``docs/join.png``: the real coronary joined onto the real capped artery with the least torsion,
  placed 1 mm in front of it first (``vesselgp join ... --place 1``: the two files sit in unrelated
  coordinates): the command's ``optimum.png``;
* ``docs/torsion.png``: the torsion profile of a generated arc bent into an S with a 90 degree twist
  (``vesselgp generate`` then ``vesselgp torsion``): the command's ``profile.png``.

The figures are drawn by ``vesselgp.viz`` as the commands draw them, so re-run this script after a
change of the figure styles. The real meshes are not part of the repository: ``--data`` (default:
``$VESSELGP_REAL_DATA``, else the first ``shared/data/real`` above this checkout) is where they are.
"""
from __future__ import annotations

import argparse
import inspect
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image
from scipy.spatial import cKDTree

import vesselgp
from vesselgp.cli import main as vesselgp_cli

ROOT = Path(__file__).resolve().parents[1]
TREE_MESH = "gmsh_abdominal-aorta-renal-iliac_open.stl"
JOIN_MOVING, JOIN_OTHER = "xra_coronary_single_branch_open.stl", "dfemtoolz_artery_segment_lumen_capped.stl"


def real_data_dir():
    """Where the real meshes are: ``$VESSELGP_REAL_DATA``, else ``shared/data/real`` above this checkout."""
    env = os.environ.get("VESSELGP_REAL_DATA")
    if env:
        return Path(env)
    for parent in ROOT.parents:
        if (parent / "shared" / "data" / "real").is_dir():
            return parent / "shared" / "data" / "real"
    return ROOT.parent / "shared" / "data" / "real"


def combined(images, across):
    """PNG files as one white RGB image: side by side (``across``) or one above the other."""
    ims = [Image.open(p).convert("RGB") for p in images]
    if across:  # to one height
        h = min(im.height for im in ims)
        ims = [im.resize((round(im.width * h / im.height), h), Image.LANCZOS) for im in ims]
        size = (sum(im.width for im in ims), h)
    else:
        size = (max(im.width for im in ims), sum(im.height for im in ims))
    out, at = Image.new("RGB", size, "white"), 0
    for im in ims:
        out.paste(im, (at, 0) if across else ((size[0] - im.width) // 2, at))
        at += im.width if across else im.height
    return out


def shrink(images, dst, width, across=False):
    """``images`` combined, scaled to ``width`` pixels (never up) and saved as an optimised 256-colour PNG."""
    im = combined(images, across)
    if im.width > width:
        im = im.resize((width, round(im.height * width / im.width)), Image.LANCZOS)
    im.quantize(colors=256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE).save(dst, optimize=True)
    print(f"{dst}: {im.width} x {im.height} px, {Path(dst).stat().st_size / 1000:.0f} KB")


def tree_picture(data, png):
    """A real vessel tree fitted and shaded by its radius, with the branch axes."""
    V, F = vesselgp.read_mesh(data / TREE_MESH)
    tree = vesselgp.fit_vessel_tree(V, F)
    axes = [b.dense_points for b in tree.branches]
    dist = cKDTree(np.vstack(axes)).query(V)[0]
    extra = {"scale_bar": "mm", "caption": "Colour: each vertex's distance to the nearest branch axis (black lines). "
                                           "The two bright bulges on the iliac arteries are aneurysms."}
    accepted = inspect.signature(vesselgp.render_mesh).parameters  # scale bar and caption: newer figure styles
    vesselgp.render_mesh(png, V, F, dist, vmin=float(dist.min()), vmax=float(np.percentile(dist, 99.5)),
                         cmap="viridis", cbar_label="distance to the axis (mm)", lines=axes, alpha=0.55,
                         title=f"abdominal aorta, renal and iliac arteries: {len(tree.branches)} branches",
                         **{k: v for k, v in extra.items() if k in accepted})


def join_picture(data, tmp):
    """The least-torsion join of two real vessels, the moving one placed 1 mm in front of the other."""
    out = tmp / "join"
    vesselgp_cli(["join", str(data / JOIN_MOVING), "--end", "1", "--onto", str(data / JOIN_OTHER),
                  "--other-end", "1", "--place", "1", "-o", str(out), "-q"])
    return out / "optimum.png", out / "large_torsion.png"


def torsion_picture(tmp):
    """The torsion profile of a generated vessel bent and twisted by a known 90 degrees."""
    gen, tor = tmp / "gen", tmp / "torsion"
    vesselgp_cli(["generate", "--curve", "arc", "--deformed-curve", "s_curve", "--deformed-twist", "90",
                  "-o", str(gen), "-q"])
    vesselgp_cli(["torsion", str(gen / "vessel.ply"), str(gen / "deformed.ply"), "-o", str(tor), "-q"])
    return tor / "deformed_twist.png", tor / "profile.png"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=None, help="folder of the real meshes")
    ap.add_argument("--out", type=Path, default=ROOT / "docs", help="folder of the pictures (default: docs/)")
    ap.add_argument("--width", type=int, default=900, help="width of each picture in pixels (default: 900)")
    args = ap.parse_args(argv)
    data = args.data or real_data_dir()
    if not (data / TREE_MESH).is_file():
        ap.error(f"{data / TREE_MESH} not found: give the folder of the real meshes with --data")
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="vesselgp-docs-") as t:
        tmp = Path(t)
        tree_picture(data, tmp / "tree.png")
        shrink([tmp / "tree.png"], args.out / "tree.png", args.width)
        shrink(join_picture(data, tmp), args.out / "join.png", args.width)
        shrink(torsion_picture(tmp), args.out / "torsion.png", args.width)
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
