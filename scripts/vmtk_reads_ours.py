"""VMTK's own tools reading vesselgp's centre lines (issue #36): vmtkcenterlinegeometry and vmtkbranchgeometry.

Fits a mesh (a tree or a single vessel, in mm), writes its centre lines as ``tree.vtp`` the way
``vesselgp fit`` does (:func:`vesselgp.network.centerline_network`), then runs, in VMTK's Python
(``../shared/peers/vmtk``, see its README), ``vmtkCenterlineGeometry`` (per point curvature and torsion,
per cell length) and ``vmtkBranchGeometry`` (per group length, curvature, torsion, from our
``GroupIds`` and ``Blanking``) on the file as it is, and prints VMTK's numbers beside ours.

    python scripts/vmtk_reads_ours.py [MESH] [--units mm|cm|m] --vmtk /tmp/peer-vmtk/bin/python

Default mesh: ../shared/data/real/vmtk_abdominal_aorta_iliac_bifurcation_open.stl.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
from pathlib import Path

import numpy as np

import vesselgp
from vesselgp.io import write_centerlines
from vesselgp.mesh.scale import units_factor
from vesselgp.network import centerline_network

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ROOT.parent / "shared" / "data" / "real" / "vmtk_abdominal_aorta_iliac_bifurcation_open.stl"

VMTK_SIDE = r"""
import json, sys
from vmtk import vmtkscripts
from vtk.util.numpy_support import vtk_to_numpy
r = vmtkscripts.vmtkSurfaceReader(); r.InputFileName = sys.argv[1]; r.Execute()
g = vmtkscripts.vmtkCenterlineGeometry(); g.Centerlines = r.Surface; g.LineSmoothing = 0; g.Execute()
c = g.Centerlines
pd, cd = c.GetPointData(), c.GetCellData()
b = vmtkscripts.vmtkBranchGeometry(); b.Centerlines = r.Surface; b.RadiusArrayName = "MaximumInscribedSphereRadius"
b.GroupIdsArrayName = "GroupIds"; b.BlankingArrayName = "Blanking"; b.CenterlineIdsArrayName = "CenterlineIds"
b.TractIdsArrayName = "TractIds"; b.LineSmoothing = 0; b.Execute()
bd = b.GeometryData.GetPointData()
out = {"n_cells": c.GetNumberOfCells(),
       "curvature": vtk_to_numpy(pd.GetArray("Curvature")).tolist(),
       "torsion": vtk_to_numpy(pd.GetArray("Torsion")).tolist(),
       "cell_length": vtk_to_numpy(cd.GetArray("Length")).tolist(),
       "group_ids": vtk_to_numpy(bd.GetArray("GroupIds")).tolist(),
       "group_length": vtk_to_numpy(bd.GetArray("Length")).tolist()}
print(json.dumps(out))
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mesh", nargs="?", default=str(DEFAULT))
    ap.add_argument("--units", default="mm")
    ap.add_argument("--vmtk", required=True, help="the Python of VMTK's environment")
    a = ap.parse_args()
    V, F = vesselgp.read_mesh(a.mesh)[:2]
    V = V * units_factor(a.units)[0]
    tree = vesselgp.fit_vessel_tree(V, F)
    net = centerline_network(tree, V, F)
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "tree.vtp"
        write_centerlines(path, net)
        run = subprocess.run([a.vmtk, "-c", VMTK_SIDE, str(path)], capture_output=True, text=True)
    if run.returncode:
        raise SystemExit(f"VMTK failed on our file:\n{run.stderr[-2000:]}")
    v = json.loads(run.stdout.strip().splitlines()[-1])
    P = net.points
    ours_len = [float(np.linalg.norm(np.diff(P[c], axis=0), axis=1).sum()) for c in net.cells]
    print(f"{Path(a.mesh).name}: {len(net.points)} points, {len(net.cells)} cells; VMTK read {v['n_cells']} cells")
    print("| cell | centre line | tract | group | blanked | length ours (mm) | length VMTK (mm) |")
    print("|---|---|---|---|---|---|---|")
    for i, c in enumerate(net.cells):
        cd = {k: int(x[i]) for k, x in net.cell_data.items()}
        print(f"| {i} | {cd['CenterlineIds']} | {cd['TractIds']} | {cd['GroupIds']} | {cd['Blanking']} | "
              f"{ours_len[i]:.2f} | {v['cell_length'][i]:.2f} |")
    k_ours, k_vmtk = net.point_data["Curvature"], np.asarray(v["curvature"])
    ok = net.point_data["FrenetDefined"].astype(bool)
    print(f"curvature, median over {int(ok.sum())} points: ours {np.median(k_ours[ok]):.4f} /mm, "
          f"VMTK's on our points {np.median(k_vmtk[ok]):.4f} /mm (VMTK differentiates the polyline unsmoothed)")
    groups = dict(zip(v["group_ids"], v["group_length"]))
    print("VMTK's branch geometry, per group: " + ", ".join(f"{int(g)}: {L:.2f} mm" for g, L in sorted(groups.items())))


if __name__ == "__main__":
    main()
