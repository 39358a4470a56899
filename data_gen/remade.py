"""A real mesh made again the way a segmentation is: its lumen on a voxel grid, then marching cubes.

Other real meshes will be tried, most of them from segmentations. ``remade(V, F, voxel)`` samples the signed
distance to the surface (its open ends closed by fans, as vesselgp closes them; inside where the generalized
winding number is above 1/2, libigl's) on a grid of that voxel and meshes its zero level with
``skimage.measure.marching_cubes``: the same lumen, its open ends now capped, every cap's rim rounded off by
the voxels, the thin vessels a few voxels across. The copies of the real meshes at a third and a fifth of the
least inscribed radius of VMTK's lines (``python data_gen/remade.py``, or ``scripts/real_meshes.py --remade``)
are where issue #47's run found a capped arch whose ascending aorta's end was missed (reported as a 2.7x bulge)
and a crash on an empty medial zone.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import igl
import numpy as np
from scipy.spatial import cKDTree

ROOT = Path(__file__).resolve().parents[1]


def remade(V, F, voxel):
    """``(V, F)`` of the marching-cubes surface of the lumen of ``(V, F)`` at ``voxel`` (mesh units).

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        A surface, open or closed (its faces oriented coherently first, as vesselgp does).
    voxel : float
        The grid's spacing.

    Returns
    -------
    V : (k, 3) float64
    F : (l, 3) int64
        A closed surface, its faces turned outwards.
    """
    from skimage.measure import marching_cubes

    from vesselgp.mesh._geometry import closed_by_fans
    from vesselgp.mesh.orient import orient_faces

    F, topo = orient_faces(V, np.asarray(F, np.int64))  # the winding number needs one orientation throughout
    Vc, Fc = closed_by_fans(V, F, topo.boundary_loops)
    lo, hi = Vc.min(axis=0) - 3 * voxel, Vc.max(axis=0) + 3 * voxel
    n = np.ceil((hi - lo) / voxel).astype(int) + 1
    X = np.stack(np.meshgrid(*[lo[k] + voxel * np.arange(n[k]) for k in range(3)], indexing="ij"), -1).reshape(-1, 3)
    bvh = igl.FastWindingNumberBVH()
    bvh.init(Vc, Fc, 2)
    inside = np.abs(np.asarray(bvh.winding_number(X, 2.0))) > 0.5
    near = np.isfinite(cKDTree(Vc).query(X, distance_upper_bound=3 * voxel)[0])  # the distance near the wall only
    d = np.full(len(X), 3 * voxel)
    d[near] = np.sqrt(igl.point_mesh_squared_distance(X[near], Vc, Fc)[0])
    Vm, Fm, _, _ = marching_cubes(np.where(inside, -d, d).reshape(n), 0.0, spacing=(voxel,) * 3)
    return Vm + lo, np.ascontiguousarray(Fm, dtype=np.int64)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mesh")
    ap.add_argument("voxel", type=float)
    ap.add_argument("out")
    ap.add_argument("--scale", type=float, default=1.0, help="multiply the mesh's coordinates first (units)")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    import vesselgp

    V, F = vesselgp.read_mesh(args.mesh)[:2]
    vesselgp.write_mesh(args.out, *remade(V * args.scale, F, args.voxel))


if __name__ == "__main__":
    main()
