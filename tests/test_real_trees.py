"""Real vessel trees by other people (issue #34): the tree fit runs, its paths stay in the lumen and
follow VMTK's centre lines (``shared/data/real/vmtk``, VMTK 1.5.2, a reference made outside vesselgp).

The truth of "inside" is libigl's winding number of the surface with its open ends closed by fans,
and the wall distance libigl's point-to-mesh distance, both on the mesh file itself; the local radius
is VMTK's maximum inscribed sphere at the nearest point of its line. The meshes that do not fit yet
(issue #34 left open: the gmsh arch, the intracranial aneurysm, the XCAT coronary tree, the closed
pulmonary artery) are not listed here.
"""
from __future__ import annotations

import igl
import numpy as np
import pytest
from scipy.spatial import cKDTree

import vesselgp
from vesselgp.curves import chord_length

from _data import REAL

MM = {"gmsh_carotid-bifurcation_open.stl": 10.0}
FITS = ["vmtk_abdominal_aorta_iliac_bifurcation_open.stl", "cardiopinns_aortic-arch-4dflow_capped.stl",
        "gmsh_carotid-bifurcation_open.stl", "palabos_aneurysm-voxelized_closed.stl",
        "gmsh_abdominal-aorta-renal-iliac_open.stl"]


def _closed(V, F):
    """The surface oriented by pymeshlab (not vesselgp's libigl-based orientation) with its loops closed by fans."""
    import pymeshlab
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(V, F))
    ms.meshing_re_orient_faces_coherently()
    V, F = ms.current_mesh().vertex_matrix(), ms.current_mesh().face_matrix().astype(np.int64)
    Vs, Fs = [V], [F]
    for lp in igl.boundary_loop_all(F):
        lp = np.asarray(lp, np.int64)
        Vs.append(V[lp].mean(axis=0)[None])
        Fs.append(np.stack([np.roll(lp, -1), lp, np.full(len(lp), sum(len(v) for v in Vs) - 1)], 1))
    return np.vstack(Vs), np.vstack(Fs)


@pytest.fixture(scope="module", params=FITS)
def real_tree(request):
    name = request.param
    V, F = vesselgp.read_mesh(REAL / name)[:2]
    V = V * MM.get(name, 1.0)
    ref = np.load(REAL / "vmtk" / f"{name}.npz")
    lines = [(ref[f"line{k}_points"].astype(np.float64), ref[f"line{k}_radius"])
             for k in range(sum(f.endswith("_points") for f in ref.files))]
    return name, V, F, vesselgp.fit_vessel_tree(V, F), lines


def test_every_path_runs_inside_the_lumen(real_tree):
    """Issue #34: interior samples inside (winding >= 0.5) at >= 99 %, >= 95 % at least 0.2 local radii from the wall."""
    name, V, F, tree, lines = real_tree
    Vc, Fc = _closed(V, F)
    P_ref = np.vstack([p for p, _ in lines])
    R_ref = np.concatenate([r for _, r in lines])
    kd = cKDTree(P_ref)
    for p in tree.paths:
        P = p.dense_points
        arc = chord_length(P)
        r_end = [tree.ends[e].radius for e in p.ends]
        inner = (arc > r_end[0]) & (arc[-1] - arc > r_end[1])
        Q = P[inner]
        w = np.abs(igl.fast_winding_number(Vc, Fc, Q))
        assert np.mean(w >= 0.5) >= 0.99, (name, p.ends, np.mean(w >= 0.5))
        d2 = igl.point_mesh_squared_distance(Q, V, F)[0]
        local = R_ref[kd.query(Q)[1]]
        assert np.mean(np.sqrt(d2) >= 0.2 * local) >= 0.95, (name, p.ends)


def test_paths_follow_vmtk_away_from_junctions_and_ends(real_tree):
    """Issue #34: within 10 % of the local radius of VMTK's centre line on average, away from the
    junctions (2 inscribed radii) and the ends (VMTK's lines stop short of open ends)."""
    name, V, F, tree, lines = real_tree
    dense = [cKDTree(p.dense_points) for p in tree.paths]
    for P, R in lines:
        arc = chord_length(P)
        keep = (arc > 2 * R[0]) & (arc[-1] - arc > 2 * R[-1])
        for J in tree.junctions:
            keep &= np.linalg.norm(P - J, axis=1) > 2 * R
        # the path to the same tip: the one nearest to the line's far end
        k = int(np.argmin([t.query(P[-1])[0] for t in dense]))
        d = dense[k].query(P[keep])[0] / R[keep]
        assert keep.sum() > 10
        assert d.mean() <= 0.10, (name, d.mean())
