"""Every output kind read back by VTK (PyPI ``vtk``) and PyVista, as ParaView, 3D Slicer and VMTK read them (issue #36).

Centre lines carry VMTK's arrays and cells (vmtkbranchextractor's CenterlineIds, TractIds, GroupIds, Blanking
each branch with its own points); their inscribed radius is checked against VTK's own distance to the input surface
(vtkImplicitPolyDataDistance), their abscissas against the chords of the points, their curvature and torsion
against a helix's closed forms. Shaded meshes are read as VTK point data.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
import vtk
from vtk.util.numpy_support import vtk_to_numpy

from vesselgp import fit_generalized_cylinder, fit_vessel_tree, write_mesh
from vesselgp.cli import main
from vesselgp.io import write_centerlines
from vesselgp.network import centerline_network
from vesselgp.synthetic import synthetic_tree, synthetic_vessel

VMTK_POINT_ARRAYS = {"MaximumInscribedSphereRadius", "Abscissas", "ParallelTransportNormals", "FrenetTangent",
                     "FrenetNormal", "FrenetBinormal", "Curvature", "Torsion"}
VMTK_CELL_ARRAYS = {"CenterlineIds", "GroupIds", "TractIds", "Blanking"}


def read_vtp(path):
    r = vtk.vtkXMLPolyDataReader()
    r.SetFileName(str(path))
    r.Update()
    pd = r.GetOutput()
    assert r.GetErrorCode() == 0 and pd.GetNumberOfPoints() > 0, path
    return pd


def arrays(data):
    return {data.GetArrayName(i): vtk_to_numpy(data.GetArray(i)) for i in range(data.GetNumberOfArrays())}


def cells(pd):
    lines = pd.GetLines()
    offsets, conn = vtk_to_numpy(lines.GetOffsetsArray()), vtk_to_numpy(lines.GetConnectivityArray())
    return [conn[a:b] for a, b in zip(offsets[:-1], offsets[1:])]


def vtk_distance(V, F, P):
    """Distance from points to the surface (V, F), by VTK (not vesselgp's AABB)."""
    poly = vtk.vtkPolyData()
    pts = vtk.vtkPoints()
    for v in V:
        pts.InsertNextPoint(*v)
    tris = vtk.vtkCellArray()
    for f in F:
        tris.InsertNextCell(3, [int(i) for i in f])
    poly.SetPoints(pts)
    poly.SetPolys(tris)
    dist = vtk.vtkImplicitPolyDataDistance()
    dist.SetInput(poly)
    return np.abs([dist.EvaluateFunction(*p) for p in P])


@pytest.fixture(scope="module")
def tree_vtp(tmp_path_factory):
    t = synthetic_tree(levels=1, voxel=0.6)
    tree = fit_vessel_tree(t.V, t.F)
    path = tmp_path_factory.mktemp("net") / "tree.vtp"
    write_centerlines(path, centerline_network(tree, t.V, t.F))
    return t, tree, read_vtp(path)


def test_a_tree_is_vmtks_branch_split_network(tree_vtp):
    t, tree, pd = tree_vtp
    pdata, cdata = arrays(pd.GetPointData()), arrays(pd.GetCellData())
    assert VMTK_POINT_ARRAYS | {"MeanRadius", "BranchId", "FrenetDefined"} <= set(pdata)
    assert VMTK_CELL_ARRAYS == set(cdata)
    assert all(pd.GetCellData().GetArray(k).GetDataType() == vtk.VTK_INT for k in VMTK_CELL_ARRAYS)  # as VMTK's
    C = cells(pd)
    assert len(C) == pd.GetNumberOfLines() == len(cdata["CenterlineIds"])
    P = vtk_to_numpy(pd.GetPoints().GetData())
    for c in range(len(tree.paths)):  # each centre line: its tracts in order, joined end to start
        tracts = [C[i] for i in np.flatnonzero(cdata["CenterlineIds"] == c)]
        assert cdata["TractIds"][cdata["CenterlineIds"] == c].tolist() == list(range(len(tracts)))
        for a, b in zip(tracts[:-1], tracts[1:]):  # every split: one point on it (within a branch) or two (a junction)
            same = pdata["BranchId"][a[-1]] == pdata["BranchId"][b[0]]
            assert (a[-1] == b[0]) if same else (a[-1] != b[0] and np.allclose(P[a[-1]], P[b[0]], atol=1e-9))
        ids = np.concatenate([tracts[0]] + [q[1:] for q in tracts[1:]])
        a = pdata["Abscissas"][ids]
        assert a[0] == 0 and np.allclose(np.diff(a), np.linalg.norm(np.diff(P[ids], axis=0), axis=1), rtol=1e-3)
        assert a[-1] == pytest.approx(tree.paths[c].length, rel=0.02)  # the path's own length, from the root
    # the junction: the trunk's last point and each child's first lie on it; one point per 0.1 radius about
    J = P[C[0][-1]]
    assert [i for i, c in enumerate(C) if np.allclose(P[c[0]], J)] == [1, 4]
    assert np.linalg.norm(J - tree.junctions[0]) < 1e-6
    step = np.linalg.norm(np.diff(P[C[0]], axis=0), axis=1) / pdata["MeanRadius"][C[0][1:]]
    assert np.all(np.abs(step - 0.1) < 0.02)
    # VMTK's inscribed radius is the distance to the surface, measured here by VTK
    d = vtk_distance(t.V, t.F, P[::7])
    assert np.allclose(pdata["MaximumInscribedSphereRadius"][::7], d, rtol=1e-6, atol=1e-9)
    # blanked tracts are the children's junction zones, one group each; the trunk's group is in both paths
    assert cdata["Blanking"].tolist() == [0, 1, 0, 0, 1, 0] and cdata["GroupIds"].tolist() == [0, 1, 2, 0, 3, 4]


def test_parallel_transport_normals_are_across_each_cells_own_tangent(tree_vtp):
    """Issue #44: at every point of every cell, junctions included, ParallelTransportNormals is a unit vector
    across the cell's own tangent (its points' central differences, second-order one-sided at the cell's
    ends), as VMTK's are: a child's first point is its own, with the child's frame (the junction point shared by the parent
    and its children carried the parent's normal, up to 0.94 off perpendicular on a real arch)."""
    _, tree, pd = tree_vtp
    P = vtk_to_numpy(pd.GetPoints().GetData())
    U = arrays(pd.GetPointData())["ParallelTransportNormals"]
    worst = 0.0
    for c in cells(pd):
        T = np.gradient(P[c], axis=0, edge_order=2)
        T /= np.linalg.norm(T, axis=1)[:, None]
        assert np.allclose(np.linalg.norm(U[c], axis=1), 1.0, atol=1e-9)
        worst = max(worst, float(np.abs(np.einsum("ij,ij->i", T, U[c])).max()))
    assert worst < 0.02, worst  # the differences against the spline's tangent (0.011 measured)


def test_a_capped_vessels_lines_start_where_the_inscribed_sphere_meets_the_cap(tmp_path):
    """Issue #44: a capped tube's centre line starts and stops where the sphere of the fitted radius meets
    each cap (VMTK's lines start where the inscribed sphere meets the end): the first and last points lie
    one radius (1.5) inside the caps, and their MaximumInscribedSphereRadius, measured by VTK, is the
    tube's radius, not 0 (the point on the cap itself, as written before). An open tube's line runs from the
    centre of one loop to the other's (the sphere there reaches the rim: radius 1.5)."""
    for ends in ("capped", "open"):
        v = synthetic_vessel("arc", radius=1.5, ends=ends, n_around=32, remesh=False)
        gc = fit_generalized_cylinder(v.V, v.F)
        write_centerlines(tmp_path / f"{ends}.vtp", centerline_network(gc, v.V, v.F))
        pd = read_vtp(tmp_path / f"{ends}.vtp")
        P = vtk_to_numpy(pd.GetPoints().GetData())
        r = arrays(pd.GetPointData())["MaximumInscribedSphereRadius"]
        for k, c in ((0, v.truth.centers[0]), (-1, v.truth.centers[-1])):  # the true centres of the end planes
            assert abs(np.linalg.norm(P[k] - c) - (1.5 if ends == "capped" else 0.0)) < 0.1
            assert abs(r[k] - 1.5) < 0.05 and abs(vtk_distance(v.V, v.F, P[[k]])[0] - r[k]) < 1e-6


def test_frenet_arrays_of_a_helix_are_its_closed_forms(tmp_path):
    """Helix (8 cos t, 8 sin t, c t), c = 20 / 2 pi: curvature 8 / (64 + c^2), torsion c / (64 + c^2)."""
    v = synthetic_vessel("helix", radius=1.5, n_around=24, remesh=False)
    gc = fit_generalized_cylinder(v.V, v.F)
    write_centerlines(tmp_path / "axis.vtp", centerline_network(gc, v.V, v.F))
    pd = read_vtp(tmp_path / "axis.vtp")
    p = arrays(pd.GetPointData())
    c = 20 / (2 * np.pi)
    inner = slice(len(p["Curvature"]) // 8, -len(p["Curvature"]) // 8)
    assert np.allclose(p["Curvature"][inner], 8 / (64 + c * c), rtol=0.03)
    assert np.allclose(p["Torsion"][inner], c / (64 + c * c), rtol=0.1)
    T, N, B, U = (p[k][inner] for k in ("FrenetTangent", "FrenetNormal", "FrenetBinormal", "ParallelTransportNormals"))
    assert p["FrenetDefined"][inner].all()
    assert np.allclose(np.einsum("ij,ij->i", T, N), 0, atol=1e-6) and np.allclose(np.cross(T, N), B, atol=1e-6)
    assert np.abs(np.einsum("ij,ij->i", T, U)).max() < 0.02  # the RMF's normal is across the tangent
    # the Frenet normal points at the helix's axis (z): its x-y part is minus the radial direction
    X = vtk_to_numpy(pd.GetPoints().GetData())[inner]
    radial = (X[:, :2] - [-8.0, 0.0]) / np.linalg.norm(X[:, :2] - [-8.0, 0.0], axis=1)[:, None]
    assert np.einsum("ij,ij->i", N[:, :2], radial).max() < -0.95


def test_a_straight_axis_says_where_its_frenet_frame_is_undefined(tmp_path):
    v = synthetic_vessel("straight", radius=1.5, n_around=24, remesh=False)
    gc = fit_generalized_cylinder(v.V, v.F)
    write_centerlines(tmp_path / "axis.vtp", centerline_network(gc, v.V, v.F))
    p = arrays(read_vtp(tmp_path / "axis.vtp").GetPointData())
    assert not p["FrenetDefined"].any()
    assert (p["FrenetNormal"] == 0).all() and (p["Torsion"] == 0).all() and (p["Curvature"] < 1e-3).all()


@pytest.fixture(scope="module")
def cli_runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    gen = d / "gen"
    assert main(["generate", "--curve", "arc", "--n-around", "24", "--deformed-twist", "90", "-o", str(gen),
                 "-q"]) == 0
    assert main(["fit", str(gen / "vessel.ply"), "-o", str(d / "fit"), "-q", "--no-png", "--shade", "radius"]) == 0
    assert main(["torsion", str(gen / "vessel.ply"), str(gen / "deformed.ply"), "-o", str(d / "tor"), "-q",
                 "--no-png"]) == 0
    t = synthetic_tree(levels=1, voxel=0.6)
    write_mesh(d / "tree.ply", t.V, t.F)
    assert main(["fit", str(d / "tree.ply"), "-o", str(d / "tree"), "-q", "--no-png"]) == 0
    return d


def test_the_fit_outputs_open_in_vtk(cli_runs):
    d = cli_runs
    from vesselgp import read_mesh

    V, F = read_mesh(d / "gen" / "vessel.ply")[:2]
    axis = read_vtp(d / "fit" / "axis.vtp")
    p = arrays(axis.GetPointData())
    assert VMTK_POINT_ARRAYS | {"MeanRadius"} <= set(p) and axis.GetNumberOfLines() == 1
    assert np.allclose(p["MeanRadius"], 1.5, rtol=0.02)
    mesh = read_vtp(d / "fit" / "mesh_radius.vtp")
    m = arrays(mesh.GetPointData())
    assert mesh.GetNumberOfPoints() == len(V) and mesh.GetNumberOfPolys() == len(F)
    assert mesh.GetPointData().GetScalars().GetName() == "radius"  # ParaView colours by it on opening
    assert {"radius", "s", "theta", "Colors"} <= set(m)
    # each vertex's radius is its distance to the axis: the tube's 1.5 on a smooth arc
    assert np.allclose(m["radius"], 1.5, rtol=0.03) and m["s"].min() >= 0 and m["s"].max() <= 1
    tree = read_vtp(d / "tree" / "tree.vtp")
    assert VMTK_CELL_ARRAYS <= set(arrays(tree.GetCellData()))
    branches = arrays(read_vtp(d / "tree" / "mesh_branches.vtp").GetPointData())["branch"]
    assert set(np.unique(branches)) == {0, 1, 2}


def test_the_torsion_outputs_carry_the_twist(cli_runs):
    d = cli_runs
    prof = json.loads((d / "tor" / "profile.json").read_text())
    axis = read_vtp(d / "tor" / "axis.vtp")
    p = arrays(axis.GetPointData())
    # the generated copy is twisted uniformly by 90 degrees end to end (alpha 0 at s = 0)
    a = p["MaterialTwist"]
    assert abs(a[0]) < 2 and abs(a[-1] - 90) < 2 and np.all(np.diff(a) > -0.5)
    assert np.isclose(a[-1] - a[0], prof["total_twist_deg"], atol=0.5)
    mesh = arrays(read_vtp(d / "tor" / "deformed_twist.vtp").GetPointData())
    assert mesh["alpha_deg"].min() > -5 and mesh["alpha_deg"].max() > 85


def test_pyvista_reads_the_centre_lines(tree_vtp, tmp_path):
    import pyvista

    t, tree, _ = tree_vtp
    write_centerlines(tmp_path / "tree.vtp", centerline_network(tree, t.V, t.F))
    net = pyvista.read(tmp_path / "tree.vtp")
    assert net.n_lines == 6 and "Abscissas" in net.point_data and "GroupIds" in net.cell_data


def test_the_ply_copies_open_in_vtk_too(cli_runs):
    """MeshLab's PLY copies are read by VTK's own PLY reader as the same meshes (points, faces, colours)."""
    d = cli_runs
    for ply, vtp in [(d / "fit" / "mesh_radius.ply", d / "fit" / "mesh_radius.vtp"),
                     (d / "tree" / "mesh_branches.ply", d / "tree" / "mesh_branches.vtp"),
                     (d / "tor" / "deformed_twist.ply", d / "tor" / "deformed_twist.vtp")]:
        r = vtk.vtkPLYReader()
        r.SetFileName(str(ply))
        r.Update()
        a, b = r.GetOutput(), read_vtp(vtp)
        assert a.GetNumberOfPoints() == b.GetNumberOfPoints() and a.GetNumberOfPolys() == b.GetNumberOfPolys()
        assert np.allclose(vtk_to_numpy(a.GetPoints().GetData()), vtk_to_numpy(b.GetPoints().GetData()), atol=1e-6)
        rgb = vtk_to_numpy(a.GetPointData().GetScalars())
        assert rgb.shape == (a.GetNumberOfPoints(), 3) and np.array_equal(rgb, arrays(b.GetPointData())["Colors"])


def test_parallel_transport_normals_are_the_transported_normal_of_a_helix(tmp_path):
    """Issue #46: ParallelTransportNormals is the rotation-minimizing normal, not any vector across the tangent:
    on the helix (8 cos t, 8 sin t, c t) (moved) its angle about the exact tangent from the closed-form RMF
    normal (tests/_reference.py: the Frenet normal turned by minus the integrated torsion) is one constant
    along the line, to 1 degree, where the Frenet normal would turn by the torsion times the length."""
    from _reference import helix, signed_angle

    v = synthetic_vessel("helix", radius=1.5, n_around=24, remesh=False)
    gc = fit_generalized_cylinder(v.V, v.F)
    write_centerlines(tmp_path / "axis.vtp", centerline_network(gc, v.V, v.F))
    pd = read_vtp(tmp_path / "axis.vtp")
    U = arrays(pd.GetPointData())["ParallelTransportNormals"]
    X = vtk_to_numpy(pd.GetPoints().GetData())
    c = 20 / (2 * np.pi)
    inner = slice(len(X) // 8, -len(X) // 8)
    X, U = X[inner], U[inner]
    t = np.unwrap(np.arctan2(X[:, 1], X[:, 0] + 8.0))  # the helix's parameter at each point (its axis at x = -8)
    t += 2 * np.pi * np.round((X[:, 2] / c - t).mean() / (2 * np.pi))
    _, T, U_exact = helix(t, 8.0, c)
    angle = np.degrees(np.unwrap(signed_angle(T, U_exact, U)))
    assert np.ptp(angle) < 1.0, np.ptp(angle)
    frenet_turn = np.degrees(c / (64 + c * c) * np.hypot(8.0, c) * np.ptp(t))
    assert frenet_turn > 30.0  # the test can tell the RMF from the Frenet frame (or any other)
