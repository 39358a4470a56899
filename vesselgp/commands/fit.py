"""``vesselgp fit``: a generalized cylinder (Eq. 1-5) of a mesh file, or a vessel tree when it branches.

:func:`run_fit` writes, for one vessel, ``axis.json`` (:func:`gc_to_dict`, with the bulges of
:func:`bulges_to_dicts`), ``axis.csv``, ``axis.vtp``/``.ply`` (the centre line), the shaded mesh
``mesh_<shade>.ply``/``.vtp`` and, with ``render``, ``mesh_<shade>.png`` and ``report.html``. A mesh
with more than two ends goes to :func:`run_fit_tree`: ``tree.json`` (:func:`tree_to_dict`),
``tree.vtp``/``.ply``, ``mesh_branches.ply``/``.vtp`` and, with ``render``, ``tree.png`` and
``report.html``. Lengths are millimetres (:func:`vesselgp.commands.output.read_mesh_in`).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .. import tolerances as tol
from ..branches import root_end
from ..bulges import tree_bulges
from ..errors import OptionError
from ..fit import fit_generalized_cylinder
from ..html_report import ViewMesh, write_report_html
from ..io import to_json, write_csv, write_json
from ..network import centerline_network
from ..prepared import PreparedMesh
from ..tree import fit_vessel_tree, with_missed_ends
from ..viz import first_colors, render_mesh, torsion_colors
from .output import _for_view, _write_centerlines, _write_shaded, read_mesh_in

__all__ = ["run_fit", "run_fit_tree", "gc_to_dict", "tree_to_dict", "bulges_to_dicts"]


def gc_to_dict(gc, units="mm"):
    """JSON-ready description of a :class:`vesselgp.GeneralizedCylinder` (``axis.json`` of ``vesselgp fit``)."""
    return {
        "units": units,
        "length": gc.length,
        "mean_radius": gc.mean_radius,
        "n_nodes": len(gc.s),
        "iterations": gc.iterations,
        "converged": gc.converged,
        "fit": "converged" if gc.converged else "stopped",
        "last_step": gc.last_step,
        "lam": gc.lam,
        "mu": gc.mu,
        "ends": list(gc.ends),
        "s": gc.s,
        "centers": gc.centers,
        "radii": gc.radii,
        "frames": {"T": gc.frames[:, 0], "U": gc.frames[:, 1], "V": gc.frames[:, 2]},
        "n_vertices": len(gc.vertex_s),
        "vertices_used": int(np.count_nonzero(gc.vertex_weight > 0)),
        "checks": None if gc.checks is None else gc.checks.to_dict(),
    }


def run_fit(mesh, out, *, ends=None, root=None, n_nodes=None, lam=None, axis_format="both", shade="radius",
            units=None, scale=None, render=True):
    """Fit a generalized cylinder to a mesh file and write ``axis.*`` and the shaded mesh into ``out``.

    A mesh with more than two ends and no ``ends`` given is fitted as a tree
    (:func:`run_fit_tree`). Lengths in every output are millimetres (see :func:`read_mesh_in`).

    Parameters
    ----------
    mesh : str or os.PathLike
    out : OutputFolder
    ends : (int, int), optional
    root : int, optional
        The end the paths start from (default the widest); with two ends, the end the axis starts at.
    n_nodes : int, optional
    lam : float, optional
        Eq. 2's weight of the axis's bending (default ``tolerances.GC_LAMBDA``), for a tube or a tree.
    axis_format : {"vtp", "ply", "both"}
    shade : {"radius", "theta", "none"}
        The shaded mesh's quantity: distance to the axis (mm) or angle about it (degrees).
    units : {"mm", "cm", "m", "um"}, optional
        Length unit of the mesh file (default: millimetres).
    scale : float, optional
        Millimetres per mesh unit (instead of ``units``).
    render : bool

    Returns
    -------
    (GeneralizedCylinder, dict) or (VesselTree, dict)
        The fit and the contents of ``axis.json`` (``tree.json`` for a tree).
    """
    if ends is not None and root is not None:
        raise OptionError("give the root end (root=) or the two ends of one path (ends=), not both")
    V, F, uinfo = read_mesh_in(mesh, units, scale)
    pm = PreparedMesh(V, F)  # checked once: the ends, the fit, the centre lines' inscribed radius
    if ends is None and len(pm.ends) >= 2:  # ends the end tests missed count (vesselgp.tree.with_missed_ends)
        # (with two ends ``root`` names where the axis starts; the lines are then drawn from the widest)
        pm = with_missed_ends(pm, root if len(pm.ends) > 2 else None)
    elif ends is not None and len(pm.ends) >= 2:  # the ends of one path named: what the lumen runs on to past
        pm = with_missed_ends(pm.with_ends(pm.ends))  # every end found is a sac (a closed mesh's, whose root was)
    if ends is None and len(pm.ends) > 2:
        return run_fit_tree(pm, mesh, out, uinfo, root=root, lam=lam, axis_format=axis_format, render=render)
    if root is not None:
        r = root_end(pm.ends, root)
        ends = (r, 1 - r) if len(pm.ends) == 2 else ends
    t0 = time.perf_counter()
    gc = fit_generalized_cylinder(pm, ends=ends, n_nodes=n_nodes, lam=lam)
    dt = time.perf_counter() - t0
    found = tree_bulges((gc,), pm.sacs, (pm.V, pm.topology.adjacency))
    d = {**gc_to_dict(gc), **uinfo, "bulges": bulges_to_dicts(found)}
    d.update(bbox_diagonal=float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))), input=str(mesh), time_s=dt)
    write_json(out("axis.json"), d)
    fr = gc.frames
    cols = {"s": gc.s, "arclength": gc.s * gc.length}
    cols.update({c: gc.centers[:, i] for i, c in enumerate("xyz")})
    cols["radius"] = gc.radii
    cols.update({f"{n}{c}": fr[:, k, i] for k, n in enumerate("TUV") for i, c in enumerate("xyz")})
    write_csv(out("axis.csv"), cols)
    _write_centerlines(out, "axis", centerline_network(gc, pm), axis_format)
    theta, dist = np.degrees(gc.vertex_theta), np.hypot(gc.vertex_local[:, 1], gc.vertex_local[:, 2])
    Vv, Fv, theta_v, dist_v = _for_view(V, F, theta, dist) if render else (V, F, theta, dist)
    if shade != "none":
        if shade == "theta":
            val, lo, hi, cmap = theta, -180.0, 180.0, "twilight"
            label = "angle \u03b8 about the axis (deg)"
            caption = (f"Black line: the fitted axis. Colour: each vertex's angle \u03b8 about it, from the axis "
                       f"frame's U direction (0), right-handed about the axis from end {gc.ends[0]} to end "
                       f"{gc.ends[1]}.")
        else:
            val = dist
            lo, hi, cmap, label = float(val.min()), float(val.max()), "viridis", "distance to the axis (mm)"
            caption = ("Black line: the fitted axis. Colour: each vertex's distance to it in mm: a narrowing "
                       "(stenosis) shows dark, a bulge bright.")
        others = {"s": gc.vertex_s, "theta": theta, "radius": dist}
        _write_shaded(out, f"mesh_{shade}", V, F, torsion_colors(val, lo, hi, cmap),
                      {shade: val, **{k: v for k, v in others.items() if k != shade}})
        if render:
            render_mesh(out(f"mesh_{shade}.png"), Vv, Fv, theta_v if shade == "theta" else dist_v, vmin=lo, vmax=hi,
                        cmap=cmap, cbar_label=label,
                        title=f"{Path(mesh).name}: generalized cylinder, length {gc.length:.4g} mm, "
                              f"mean radius {gc.mean_radius:.3g} mm",
                        period=360.0 if shade == "theta" else None, lines=[gc.dense_points], caption=caption,
                        scale_bar="mm")
    if render:
        write_report_html(out("report.html"), f"{Path(mesh).name}: generalized cylinder",
                          [ViewMesh(Vv, Fv, dist_v, label="distance to the axis (mm)")], lines=[gc.dense_points],
                          labels=[(gc.centers[0], f"end {gc.ends[0]}"), (gc.centers[-1], f"end {gc.ends[1]}")],
                          figures=[out.dir / f"mesh_{shade}.png"], numbers=d,
                          caption=f"Length {gc.length:.4g} mm, mean radius {gc.mean_radius:.3g} mm. The surface is "
                                  "shaded by each vertex's distance to the fitted axis (the black line): a narrowing "
                                  "(stenosis) shows dark, a bulge bright. Red numbers: the ends. Drag to turn, scroll to zoom.")
    return gc, d


def bulges_to_dicts(bulges):
    """JSON-ready list of :class:`vesselgp.bulges.Bulge` (``bulges`` of ``axis.json`` and ``tree.json``)."""
    return [{"paths": list(b.paths), "s_range": b.s_range, "s_peak": b.s_peak, "peak": b.peak,
             "peak_radius": b.peak_radius, "neighbour_radius": b.neighbour_radius, "ratio": b.ratio} for b in bulges]


def tree_to_dict(tree, units="mm"):
    """JSON-ready description of a :class:`vesselgp.tree.VesselTree` (``tree.json`` of ``vesselgp fit``)."""
    def branch(b, gc):
        return {"id": b, "parent": int(tree.parent[b]), "ends": list(gc.ends), "length": gc.length,
                "mean_radius": gc.mean_radius, "iterations": gc.iterations, "converged": gc.converged,
                "fit": tree.branch_fit[b], "last_step": gc.last_step,
                "n_vertices": int(np.count_nonzero(tree.vertex_branch == b)), "s": gc.s, "centers": gc.centers,
                "radii": gc.radii, "frames": {"T": gc.frames[:, 0], "U": gc.frames[:, 1], "V": gc.frames[:, 2]},
                "junction_zone": float(tree.junction_zone[b]),
                "medial_zones": [[float(a), float(c)] for a, c in tree.medial_zones[b]]}
    return {
        "units": units, "n_ends": len(tree.ends), "root": tree.root,
        "ends": [{"index": i, "kind": e.kind, "radius": float(e.radius), "center": np.asarray(e.center, float),
                  "direction": np.asarray(e.direction, float)} for i, e in enumerate(tree.ends)],
        "junctions": [{"point": q, "branch": int(b), "children": [int(c) for c in np.flatnonzero(tree.parent == b)]}
                      for q, b in zip(tree.junctions, tree.junction_branch)],
        "branches": [branch(b, gc) for b, gc in enumerate(tree.branches)],
        "paths": [{"ends": list(p.ends), "branches": list(c), "length": p.length, "mean_radius": p.mean_radius,
                   "min_radius": float(p.radii.min()), "max_radius": float(p.radii.max())}
                  for p, c in zip(tree.paths, tree.path_branches)],
        "bulges": bulges_to_dicts(tree.bulges),
        "converged": all(gc.converged for gc in tree.branches),
        "n_vertices": len(tree.vertex_branch),
        "checks": tree.checks.to_dict(),
    }


def run_fit_tree(pm, mesh, out, uinfo, *, root=None, lam=None, axis_format="both", render=True):
    """Fit a branching mesh as a vessel tree and write ``tree.*`` and the branch-coloured mesh into ``out``.

    Parameters
    ----------
    pm : PreparedMesh
        The mesh in millimetres, checked, with its ends (and blind sacs) found.
    mesh : str or os.PathLike
        The input file (named in the report and the picture).
    out : OutputFolder
    uinfo : dict
        Units of the input (:func:`read_mesh_in`).
    root : int, optional
        The root end (default the widest; ``tree.json`` says which: ``root_chosen``).
    lam : float, optional
        Eq. 2's weight of the branch axes' bending (default ``tolerances.GC_LAMBDA``).
    axis_format : {"vtp", "ply", "both"}
    render : bool

    Returns
    -------
    (VesselTree, dict)
        The tree and the contents of ``tree.json``. ``tree.vtp`` / ``tree.ply``
        hold one polyline per branch with point data ``Radius`` (also as
        ``MaximumInscribedSphereRadius``, VMTK's and 3D Slicer's name) and
        ``Abscissa`` (mm from the branch start), and cell data ``BranchId``
        and ``ParentId``; ``mesh_branches.ply`` has each vertex's ``branch``.
    """
    t0 = time.perf_counter()
    V, F = pm.V, pm.F
    tree = fit_vessel_tree(pm, root=root, lam=lam)
    dt = time.perf_counter() - t0
    d = {**tree_to_dict(tree), "root_chosen": "widest" if root is None else "given", **uinfo, "bbox_diagonal": float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))),
         "input": str(mesh), "time_s": dt}
    write_json(out("tree.json"), d)
    _write_centerlines(out, "tree", centerline_network(tree, pm), axis_format)
    vb = tree.vertex_branch.astype(float)
    ncol = 10 if len(tree.branches) <= 10 else 20  # one colour of the qualitative map per branch (cycled)
    cmap, shade = f"tab{ncol}", np.mod(vb, ncol)
    _write_shaded(out, "mesh_branches", V, F, torsion_colors(shade, -0.5, ncol - 0.5, cmap), {"branch": vb})
    if render:
        nb, nj = len(tree.branches), len(tree.junctions)
        used = min(nb, ncol)  # the colour bar shows the colours in use (the same as mesh_branches.ply's)
        from scipy.spatial import cKDTree

        axes = np.vstack([gc.dense_points for gc in tree.branches])
        which = "the widest" if root is None else "the root given"
        Vv, Fv, shade_v = _for_view(V, F, shade)
        render_mesh(out("tree.png"), Vv, Fv, shade_v, vmin=-0.5, vmax=used - 0.5, cmap=first_colors(cmap, used),
                    cbar_label="branch (id in tree.json)", alpha=tol.VIZ_TREE_ALPHA,
                    lines=[gc.dense_points for gc in tree.branches], cbar_ticks=range(used), scale_bar="mm",
                    title=f"{Path(mesh).name}: {nb} branch{'es' * (nb != 1)}, {nj} junction{'s' * (nj != 1)}, "
                          f"{len(tree.paths)} paths; axes {sum(gc.length for gc in tree.branches):.0f} mm in all",
                    caption=f"Black lines: the branch axes; the translucent surface is coloured by branch. The "
                            f"paths run from end {tree.root} ({which}) to each other end.")
        write_report_html(out("report.html"), f"{Path(mesh).name}: vessel tree",
                          [ViewMesh(Vv, Fv, cKDTree(axes).query(Vv)[0], label="distance to the axis (mm)")],
                          lines=[gc.dense_points for gc in tree.branches],
                          labels=[(e.center, f"end {i}") for i, e in enumerate(tree.ends)],
                          figures=[out.dir / "tree.png"], numbers=d,
                          caption=f"{len(tree.branches)} branches, {len(tree.junctions)} junctions, {len(tree.paths)} "
                                  f"paths from end {tree.root} ({which}). The surface is shaded by each vertex's "
                                  "distance to the nearest branch axis (black lines). Red numbers: the ends (their names "
                                  "on hover). Drag to turn, scroll to zoom.")
    return tree, to_json(d)
