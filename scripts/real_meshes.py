"""Every real mesh of ../shared/data/real through vesselgp's tree fit, beside VMTK's stored lines (issue #34).

Prints one row per mesh: its ends, the paths fitted (or the refusal), the fraction of interior path
samples inside the lumen (libigl's winding number of the surface closed by fans, >= 0.5) and at least
0.2 local radii from the wall, the mean and worst distance from VMTK's centre lines (stored in
``vmtk/<mesh>.npz``, VMTK 1.5.2) to our paths in VMTK's inscribed radii, the branches whose axis is
the centre line somewhere (``VesselTree.medial_zones``), the bulges (``VesselTree.bulges``: peak radius
over the radius beside), the fit's checks against its mesh (``VesselTree.checks``, issue #44: the worst
gap from a path's end to the centre of its end, in that end's radii; the wall's area the fit covers and
its largest uncovered piece, in radii of tube wall) and the fit's time.

    python scripts/real_meshes.py [--data ../shared/data/real] [--vmtk /tmp/peer-vmtk/bin/python]

With ``--vmtk`` (the Python of ../shared/peers/vmtk's environment, see its README) VMTK runs on each
mesh too, in mm, from the widest end vesselgp finds to every other (``vmtk_tree.py --delaunay qhull``,
its fastest configuration), and its time (tessellation, centre lines and branch splitting) is printed
beside vesselgp's. The lines compared are the stored ones (``tests/data/vmtk`` where a file there
replaces the shared one).

With ``--coarser`` each mesh is instead fitted as copies made by pymeshlab (isotropically remeshed at
0.7, 1.4 and 2 median edges, decimated to 30 % and 15 % of its faces) and with normal noise of 0.1
and 0.3 median edges, against VMTK's lines of the original: other meshes of the same anatomy. With
``--remade``, made again by marching cubes (``data_gen/remade.py``); with ``--clipped``, clipped by planes as a
field of view cuts it, open and capped by fans (``data_gen/clipped.py``; VMTK's lines compared in front of the
plane only).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
import sys
import time
from pathlib import Path

import igl
import numpy as np
from scipy.spatial import cKDTree

import vesselgp
from vesselgp.curves import chord_length
from vesselgp.mesh import mesh_topology
from vesselgp.mesh._geometry import closed_by_fans

#: the files' units, to mm (SOURCES.md)
TO_MM = {"gmsh_aortic-arch_open.stl": 1000.0, "gmsh_carotid-bifurcation_open.stl": 10.0}
ROOT = Path(__file__).resolve().parents[1]
PEER = ROOT.parent / "shared" / "peers" / "vmtk" / "vmtk_tree.py"


def _reference(path):
    """VMTK's stored lines of a mesh: the repository's ``tests/data/vmtk`` file, else the shared one."""
    local = ROOT / "tests" / "data" / "vmtk" / f"{path.name}.npz"
    return np.load(local if local.is_file() else path.parent / "vmtk" / f"{path.name}.npz")


def _vmtk_seconds(python, V, F, ends, root):
    """VMTK's time for the same network (widest end to every other), on the mesh in mm."""
    with tempfile.TemporaryDirectory() as d:
        stl = Path(d) / "mesh.stl"
        vesselgp.write_mesh(stl, V, F)
        targets = [float(x) for k, e in enumerate(ends) if k != root for x in e.center]
        out = subprocess.run([python, str(PEER), str(stl), "--source", *map(str, ends[root].center),
                              "--targets", *map(str, targets), "--delaunay", "qhull"],
                             capture_output=True, text=True, check=True)
    tm = json.loads(out.stdout.strip().splitlines()[-1])["timings_s"]
    return tm["qhull_tessellation"] + tm["centerlines"] + tm["branch_extractor"]


def _median_edge(V, F):
    E = igl.edges(F)
    return float(np.median(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)))


def _coarser(V, F, how, k):
    """A copy of the surface made by pymeshlab: ``remeshed`` (isotropic, ``k`` median edges; its output
    depends on the machine's threads), ``decimated`` (quadric edge collapse to fraction ``k`` of the faces,
    topology and boundary kept); or with ``noise`` (each vertex moved along its normal by a normal
    deviate of ``k`` median edges, seed 0)."""
    import pymeshlab
    if how == "noise":
        N = igl.per_vertex_normals(V, F)
        return V + N * (k * _median_edge(V, F) * np.random.default_rng(0).standard_normal(len(V)))[:, None], F
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(V, F))
    if how == "remeshed":
        ms.meshing_isotropic_explicit_remeshing(iterations=4, targetlen=pymeshlab.PureValue(k * _median_edge(V, F)))
    else:
        ms.meshing_decimation_quadric_edge_collapse(targetperc=k, preservetopology=True, preserveboundary=True)
    m = ms.current_mesh()
    return m.vertex_matrix().astype(np.float64), m.face_matrix().astype(np.int64)


def _remade(path, V, F, k):
    """The mesh made again as a segmentation is (``data_gen/remade.py``: marching cubes of its signed distance) at a
    voxel of ``1 / k`` of the least inscribed radius of VMTK's lines of it (their 10th percentile)."""
    sys.path.insert(0, str(ROOT / "data_gen"))
    from remade import remade

    ref = _reference(path)
    n = sum(f.endswith("_points") for f in ref.files)
    voxel = min(float(np.percentile(ref[f"line{i}_radius"], 10)) for i in range(n)) / k
    cells = float(np.prod((V.max(axis=0) - V.min(axis=0)) / voxel + 6))
    if cells > REMADE_MAX_CELLS:
        raise MemoryError(f"a grid of {cells:.2g} voxels (more than {REMADE_MAX_CELLS:.2g})")
    return remade(V, F, voxel)


def _in_front(P, R, V, variant):
    """Which of VMTK's points ``P`` (radii ``R``) are compared: all, or for a clipped copy those at least
    2.5 of their radii in front of the plane and within 1.3 of them of a kept vertex."""
    if variant is None or variant[0] != "clipped":
        return np.ones(len(P), bool)
    n, c = variant[2], variant[3]
    return ((P - c) @ n > 2.5 * R) & (cKDTree(V).query(P)[0] < 1.3 * R)


def _clipping(path, V, F):
    """The planes of ``data_gen/clipped.py`` that cut ``(V, F)`` as a field of view does: ``[(tag, normal, point)]``,
    and the others with why not (printed)."""
    sys.path.insert(0, str(ROOT / "data_gen"))
    from clipped import clipped, planes, unlike_a_field_of_view

    kept = []
    for tag, n, c in planes(V, path.name):
        W, G = clipped(V, F, n, c, cap=False)
        why = unlike_a_field_of_view(W, G, n, c)
        if why:
            print(f"<!-- {path.name} {tag}: not tried, {why} -->", flush=True)
        else:
            kept.append((tag, n, c))
    return kept


def _oriented(V, F):
    """``F`` turned coherently by pymeshlab (the voxelised aneurysm's faces are not)."""
    import pymeshlab
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(V, F))
    ms.meshing_re_orient_faces_coherently()
    return ms.current_mesh().face_matrix().astype(np.int64)


#: ``--remade`` makes no grid larger than this (the XCAT tree at a fifth of its least radius: 5.3e8 voxels)
REMADE_MAX_CELLS = 1.5e8


#: the copies of ``--remade``: voxels of 1/k of the least inscribed radius
REMADE = [("remade", 3.0), ("remade", 5.0)]

#: the copies of ``--coarser``: (how, k)
COARSER = [("remeshed", 0.7), ("remeshed", 1.4), ("remeshed", 2.0), ("decimated", 0.3), ("decimated", 0.15),
           ("noise", 0.1), ("noise", 0.3)]


def _row(path, vmtk=None, variant=None):
    V, F = vesselgp.read_mesh(path)[:2]
    V = V * TO_MM.get(path.name, 1.0)
    name = path.name
    if variant is not None and variant[0] == "remade":
        name = f"{path.name} remade at 1/{variant[1]:g} of its least radius"
        try:
            V, F = _remade(path, V, F, variant[1])
        except MemoryError as e:
            return [name] + ["-"] * 10 + [f"not made: {e}"]
    elif variant is not None and variant[0] == "clipped":
        sys.path.insert(0, str(ROOT / "data_gen"))
        from clipped import clipped
        _, tag, n, c, cap = variant
        V, F = clipped(V, _oriented(V, F), n, c, cap=cap)
        name = f"{path.name} clipped {tag}, {'capped by a fan' if cap else 'open'}"
    elif variant is not None:
        V, F = _coarser(V, F, *variant)
        name = f"{path.name} {variant[0]} {variant[1]:g}"
    t = time.perf_counter()
    try:
        tree = vesselgp.fit_vessel_tree(V, F)
    except ValueError as e:
        return [name, "-", "refused", "-", "-", "-", "-", "-", "-", f"{time.perf_counter() - t:.2f}", "-",
                str(e).split(";")[0][:70]]
    dt = time.perf_counter() - t
    Fo = _oriented(V, F)  # the winding's orientation from pymeshlab, not from vesselgp's own mending
    Vc, Fc = closed_by_fans(V, Fo, mesh_topology(Fo, len(V)).boundary_loops)
    inside, clear, n = 0, 0, 0
    for p in tree.paths:
        arc = chord_length(p.dense_points)
        r0, r1 = (tree.ends[e].radius for e in p.ends)
        inner = (arc > r0) & (arc[-1] - arc > r1)
        Q, r = p.dense_points[inner], p.radius_at(p.dense_s[inner])
        inside += int((np.abs(igl.fast_winding_number(Vc, Fc, Q)) >= 0.5).sum())
        clear += int((np.sqrt(igl.point_mesh_squared_distance(Q, V, F)[0]) >= 0.2 * r).sum())
        n += len(Q)
    ref = _reference(path)
    dense = cKDTree(np.vstack([p.dense_points for p in tree.paths]))
    d = np.concatenate([dense.query(ref[f"line{k}_points"][kept])[0] / ref[f"line{k}_radius"][kept]
                        for k in range(sum(f.endswith("_points") for f in ref.files))
                        for kept in [_in_front(ref[f"line{k}_points"], ref[f"line{k}_radius"], V, variant)]])
    zoned = sum(1 for z in tree.medial_zones if len(z))
    bul = ", ".join(f"{b.ratio:.2f}x" for b in tree.bulges) or "-"
    tv = "-" if vmtk is None else f"{_vmtk_seconds(vmtk, V, F, tree.ends, tree.root):.2f}"
    c = tree.checks
    return [name, str(len(tree.ends)), f"{len(tree.paths)} paths", f"{100 * inside / n:.1f} / {100 * clear / n:.1f}",
            f"{d.mean():.3f} / {d.max():.2f}" if len(d) else "-", f"{zoned} of {len(tree.branches)}", bul, f"{c.worst_end_gap:.2f}",
            f"{100 * c.covered_fraction:.2f} / {c.largest_uncovered:.2f}", f"{dt:.2f}", tv, ""]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(Path(__file__).resolve().parents[2] / "shared" / "data" / "real"))
    ap.add_argument("--vmtk", help="the Python of ../shared/peers/vmtk's environment, to time VMTK beside")
    ap.add_argument("--coarser", action="store_true",
                    help="instead, copies of each mesh remeshed, decimated and noisier (VMTK's lines of the original)")
    ap.add_argument("--remade", action="store_true",
                    help="instead, each mesh made again by marching cubes at a third and a fifth of its least radius")
    ap.add_argument("--clipped", action="store_true",
                    help="instead, each mesh clipped by planes as a field of view cuts it, open and capped by fans "
                         "(data_gen/clipped.py; VMTK's lines of the original in front of the plane)")
    args = ap.parse_args()
    files = sorted(p for p in Path(args.data).iterdir() if p.suffix in (".stl", ".vtp", ".ply", ".obj"))
    head = ["mesh", "ends", "fit", "inside / clear (%)", "VMTK line to path (r): mean / worst",
            "branches with medial zones", "bulges (peak / beside)", "end gap (end r)",
            "wall covered (%) / largest uncovered (r)", "time (s)", "VMTK time (s)", "refusal"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for f in files:
        if args.clipped:
            V, F = vesselgp.read_mesh(f)[:2]
            V = V * TO_MM.get(f.name, 1.0)
            F = _oriented(V, F)
            for tag, n, c in _clipping(f, V, F):
                for cap in (False, True):
                    print("| " + " | ".join(_row(f, None, ("clipped", tag, n, c, cap))) + " |", flush=True)
            continue
        copies = COARSER if args.coarser else REMADE if args.remade else [None]
        for variant in copies:
            print("| " + " | ".join(_row(f, None if variant else args.vmtk, variant)) + " |", flush=True)


if __name__ == "__main__":
    main()
