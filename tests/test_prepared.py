"""A job checks its mesh once (issue #34, item 8): vesselgp.PreparedMesh."""
import cProfile
import pstats

import numpy as np
import pytest

import vesselgp
from vesselgp import PreparedMesh, fit_generalized_cylinder, fit_vessel_tree
from vesselgp.errors import EndsError, InvalidMeshError
from vesselgp.synthetic import synthetic_tree, twist_pair


@pytest.fixture(scope="module")
def tree_mesh():
    return synthetic_tree(levels=1, voxel=0.6)


def _calls(fn):
    """How often each function of vesselgp ran during ``fn()``, by (module file, name)."""
    prof = cProfile.Profile()
    prof.enable()
    fn()
    prof.disable()
    out = {}
    for (path, _, name), row in pstats.Stats(prof).stats.items():
        if "/vesselgp/" in path:
            key = (path.split("/vesselgp/")[-1], name)
            out[key] = out.get(key, 0) + row[1]
    return out


def test_twist_between_checks_each_scan_once():
    # twist_between fits each scan's tree and then its main vessel: two fits per scan, one check
    p = twist_pair(3, twist_deg=40.0, voxel=(0.6, 0.6), side_radius=1.8)
    n = _calls(lambda: vesselgp.twist_between(p.a.V, p.a.F, p.V_b, p.b.F))
    once_per_scan = {
        ("_validate.py", "as_mesh"): "validated",
        ("mesh/orient.py", "orient_faces"): "oriented",
        ("prepared.py", "checked_mesh"): "checked",
        ("mesh/topology.py", "mesh_topology"): "given a topology",
        ("mesh/ends.py", "found_ends"): "searched for ends",
        ("inside.py", "_grid"): "binned for the winding number's rays",  # SurfaceWinding's ray grid, built once
    }
    for key, what in once_per_scan.items():
        assert n.get(key, 0) == 2, f"each of the two scans is {what} once, got {n.get(key, 0)} calls of {key}"
    # SurfaceWinding and its ray grid: one of each per scan
    assert n.get(("inside.py", "__init__"), 0) == 4, n.get(("inside.py", "__init__"), 0)
    areas = n[("mesh/_geometry.py", "voronoi_areas")]
    geodesic_fans = n.get(("mesh/geodesic.py", "__init__"), 0)  # the heat method's closing fans add theirs
    assert areas == 2 + geodesic_fans


def test_fits_of_a_prepared_mesh_are_the_fits_of_its_arrays(tree_mesh):
    t = tree_mesh
    pm = PreparedMesh(t.V, t.F)
    a, b = fit_vessel_tree(pm), fit_vessel_tree(t.V, t.F)
    assert [p.ends for p in a.paths] == [p.ends for p in b.paths]
    for p, q in zip(a.paths, b.paths):
        np.testing.assert_array_equal(p.centers, q.centers)
    g1 = fit_generalized_cylinder(pm, ends=(0, 2))
    g2 = fit_generalized_cylinder(t.V, t.F, ends=(0, 2))
    np.testing.assert_array_equal(g1.centers, g2.centers)
    np.testing.assert_array_equal(g1.s, g2.s)


def test_a_prepared_mesh_keeps_the_callers_faces_and_orients_its_own(tree_mesh):
    t = tree_mesh
    F = t.F.copy()
    F[::7] = F[::7, ::-1]  # every seventh face wound the other way
    before = F.copy()
    pm = PreparedMesh(t.V, F)
    np.testing.assert_array_equal(F, before)
    np.testing.assert_array_equal(pm.F, t.F)  # the synthetic tree is wound outward: the mending restores it
    assert len(pm.topology.incoherent_edges) == 0


def test_a_prepared_mesh_is_given_alone(tree_mesh):
    t = tree_mesh
    pm = PreparedMesh(t.V, t.F)
    with pytest.raises(InvalidMeshError, match="either a PreparedMesh or"):
        fit_vessel_tree(pm, t.F)
    with pytest.raises(EndsError, match="holds its ends"):
        fit_generalized_cylinder(pm, ends=(0, 1), mesh_ends=pm.ends)
    with pytest.raises(InvalidMeshError, match="F is missing"):
        fit_vessel_tree(t.V)
    with pytest.raises(EndsError, match="VesselEnd objects"):
        PreparedMesh(t.V, t.F, ends=[0, 1, 2])
