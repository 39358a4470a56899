"""A fit's centre lines as VMTK has them (issue #36): tracts, groups, abscissas and its point arrays.

VMTK's centre lines (``vmtkcenterlines``), split by ``vmtkbranchextractor`` and measured by
``vmtkcenterlinegeometry``, are what 3D Slicer (SlicerVMTK), ParaView users and VMTK scripts read.
:func:`centerline_network` lays a :class:`vesselgp.GeneralizedCylinder` or a
:class:`vesselgp.VesselTree` out the same way:

* **Cells.** One polyline cell per tract of each path (``CenterlineIds``: the path, from the root
  to the ``CenterlineIds``-th tip in :attr:`VesselTree.paths` order; ``TractIds``: 0, 1, ... from
  the root along it). A tree's branch gives one tract, or two when it starts with a junction
  zone (:attr:`VesselTree.junction_zone`, where the axis is led in through the parent's
  junction): the zone is its own tract with ``Blanking`` 1, as VMTK blanks its bifurcation
  tracts. ``GroupIds`` numbers the tracts of the tree (a trunk tract shared by several paths has
  one group id, in every path's cell), so VMTK's group-wise tools see one group per branch piece.
* **Points.** Each branch has its own points, as each of VMTK's cells has: at a junction the
  parent's last point and each child's first lie on the junction, one per branch, each with its
  own branch's values (a child's ``ParallelTransportNormals`` across its own tangent, not its
  parent's; issue #44). A trunk shared by several paths is stored once and its cells repeat for
  each path, as VMTK's do; the tracts of one branch share their boundary point. Each branch is
  sampled about every ``tolerances.NETWORK_SPACING`` local radii (VMTK resamples its lines at a
  similar step).
* **Ends.** A line starts and stops where its inscribed sphere meets the end, as VMTK's do: at an
  open end, the centre of its loop (the sphere reaching the rim); at a rounded tip, the centre of
  its dome; at a flat cap, where the sphere of the fitted radius touches the cap (about one radius
  in from it), not on the cap itself, where the inscribed sphere is none (the fit's axis runs on
  to the cap's centre; a terminal point closer to the surface than
  ``tolerances.NETWORK_CAP_FRACTION`` of its fitted radius lies on a cap).
* **Point data** (VMTK's names): ``MaximumInscribedSphereRadius``, the distance from the point to
  the nearest point of the surface (VMTK's definition: the radius of the largest sphere centred
  there inside the lumen, not the fit's mean radius); ``Abscissas``, the arc length from the root
  in mesh units, continuous along every path; ``ParallelTransportNormals``, the rotation-minimizing
  frame's U (Section 2.2; a child's starts from its parent's frame at the junction);
  ``FrenetTangent``, ``FrenetNormal``, ``FrenetBinormal``, ``Curvature`` and ``Torsion`` of each
  branch's axis (:func:`vesselgp.curves.frenet`, smoothed over about a radius). Where the axis is
  straight (curvature times radius below ``tolerances.STRAIGHT_KAPPA_R``) the Frenet normal,
  binormal and torsion are undefined: they are written as 0 there, and ``FrenetDefined`` (0/1)
  says where (VTK's readers take no NaN in ascii files). vesselgp's own quantities keep their own
  names: ``MeanRadius`` (Eq. 4's mean distance of the wall to the axis), ``BranchId`` (the
  tree's branch) and, from a torsion run, ``MaterialTwist`` (alpha, Eq. 6, in degrees).

A point on a tract boundary within a branch takes the values of both tracts (they are one branch's).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import tolerances as tol
from ._validate import as_mesh
from .curves import frenet
from .errors import OptionError
from .inside import SurfaceWinding
from .prepared import PreparedMesh

__all__ = ["CenterlineNetwork", "centerline_network"]


@dataclass(frozen=True)
class CenterlineNetwork:
    """Centre lines as VTK polylines over shared points, with VMTK's arrays (see the module notes).

    Attributes
    ----------
    points : (k, 3) float64
    cells : tuple of (k_c,) int64
        Point ids of each polyline cell (one per path tract), in cell order.
    point_data : dict of str to (k,) or (k, 3) array
    cell_data : dict of str to (c,) int64
        ``CenterlineIds``, ``TractIds``, ``GroupIds``, ``Blanking``.
    """

    points: np.ndarray
    cells: tuple
    point_data: dict
    cell_data: dict


@dataclass(frozen=True)
class _Piece:
    """One tract of a branch: its branch, its normalised arc-length range and whether it is blanked."""

    branch: int
    s0: float
    s1: float
    blank: int


def _pieces(fit):
    """The branches (cylinders), their parents and the tracts of each branch, for a cylinder or a tree."""
    if hasattr(fit, "branches"):
        branches, parent = fit.branches, np.asarray(fit.parent)
        zones, paths = np.asarray(fit.junction_zone, float), fit.path_branches
    elif hasattr(fit, "dense_points"):
        branches, parent, zones, paths = (fit,), np.array([-1]), np.zeros(1), ((0,),)
    else:
        raise OptionError(f"centre lines are made of a GeneralizedCylinder or a VesselTree, not {type(fit).__name__}")
    pieces = []
    for b, gc in enumerate(branches):
        z = float(zones[b]) / gc.length if parent[b] >= 0 else 0.0
        if 0.0 < z < 1.0 - tol.NETWORK_SPACING * gc.radii.min() / gc.length:
            pieces.append([_Piece(b, 0.0, z, 1), _Piece(b, z, 1.0, 0)])
        else:
            pieces.append([_Piece(b, 0.0, 1.0, 0)])
    return branches, parent, pieces, paths


def _samples(gc, s0, s1):
    """Normalised arc lengths from ``s0`` to ``s1``, about every ``NETWORK_SPACING`` local radii (at least 2)."""
    g = np.linspace(s0, s1, 1 + int(np.ceil((s1 - s0) * len(gc.dense_s))))
    per = gc.length / (tol.NETWORK_SPACING * gc.radius_at(g))  # samples per unit s
    cost = np.concatenate([[0.0], np.cumsum(np.diff(g) * 0.5 * (per[1:] + per[:-1]))])
    return np.interp(np.linspace(0.0, cost[-1], max(int(np.ceil(cost[-1])), 1) + 1), cost, g)


def _branch_frenet(P, radius):
    """Frenet tangent, normal, binormal, curvature, torsion and where they are defined, of one branch's samples."""
    if len(P) < 4:  # too short for the spline: take the chord's direction, no curvature
        T = np.repeat(((P[-1] - P[0]) / np.linalg.norm(P[-1] - P[0]))[None], len(P), axis=0)
        z = np.zeros(len(P))
        return T, np.zeros_like(P), np.zeros_like(P), z, z, z.astype(bool)
    fr = frenet(P, radius, smooth=True)
    d = np.gradient(P, axis=0)
    T = d / np.linalg.norm(d, axis=1)[:, None]
    ok = fr.defined & np.isfinite(fr.normal).all(axis=1) & np.isfinite(fr.torsion)
    N = np.where(ok[:, None], fr.normal, 0.0)
    N -= np.einsum("ij,ij->i", N, T)[:, None] * T  # across the samples' tangent (the spline's differs by ~1e-4)
    norm = np.linalg.norm(N, axis=1)
    N = np.divide(N, norm[:, None], out=np.zeros_like(N), where=ok[:, None])
    B = np.cross(T, N)
    return T, N, B, fr.curvature, np.where(ok, fr.torsion, 0.0), ok


def centerline_network(fit, V, F=None, *, twist=None):
    """The centre lines of a fit as VMTK lays them out (module notes).

    Parameters
    ----------
    fit : GeneralizedCylinder or VesselTree
    V : (n, 3) float64
        The fitted mesh (for ``MaximumInscribedSphereRadius``); or a mesh object with ``F`` None (a
        :class:`vesselgp.PreparedMesh` lends its closed surface, built once).
    F : (m, 3) int64
    twist : callable, optional
        ``twist(branch, s) -> alpha`` in radians at normalised arc lengths ``s`` of a branch (a
        torsion run's material twist, Eq. 6), written as ``MaterialTwist`` in degrees.

    Returns
    -------
    CenterlineNetwork

    Raises
    ------
    OptionError
        ``fit`` is neither a cylinder nor a tree.

    Examples
    --------
    >>> from vesselgp.synthetic import synthetic_tree
    >>> from vesselgp import fit_vessel_tree
    >>> t = synthetic_tree(levels=1, voxel=0.6)
    >>> net = centerline_network(fit_vessel_tree(t.V, t.F), t.V, t.F)
    >>> net.cell_data["CenterlineIds"].tolist(), net.cell_data["Blanking"].tolist()
    ([0, 0, 0, 1, 1, 1], [0, 1, 0, 0, 1, 0])
    >>> trunk_end, child_start = net.points[net.cells[0][-1]], net.points[net.cells[1][0]]
    >>> bool(np.allclose(trunk_end, child_start))  # the junction: one point per branch, both on it
    True
    """
    winding = V.winding if isinstance(V, PreparedMesh) else None  # its closed surface, built once
    V, F = as_mesh(V, F)
    surface = SurfaceWinding(V, F) if winding is None else winding
    branches, parent, pieces, paths = _pieces(fit)
    pts, data = [], {k: [] for k in ("MeanRadius", "Abscissas", "ParallelTransportNormals", "FrenetTangent",
                                     "FrenetNormal", "FrenetBinormal", "Curvature", "Torsion",
                                     "FrenetDefined", "BranchId", "MaterialTwist")}
    piece_ids = [[] for _ in branches]
    n = 0
    for b, gc in enumerate(branches):
        terminal = (parent[b] < 0, not np.any(parent == b))  # a root end at its start, a tip at its end
        parts = _off_caps(gc, [_samples(gc, p.s0, p.s1) for p in pieces[b]], terminal, surface)
        s = np.concatenate([parts[0]] + [q[1:] for q in parts[1:]])  # the tracts share their boundary
        P, fr = gc.at(s)
        T, N, B, kappa, tau, ok = _branch_frenet(P, gc.mean_radius)
        a0 = _abscissa_at_end(branches, parent, parent[b]) if parent[b] >= 0 else 0.0
        pts.append(P)
        for key, val in (("MeanRadius", gc.radius_at(s)), ("Abscissas", a0 + s * gc.length),
                         ("ParallelTransportNormals", fr[:, 1]), ("FrenetTangent", T), ("FrenetNormal", N),
                         ("FrenetBinormal", B), ("Curvature", kappa), ("Torsion", tau),
                         ("FrenetDefined", ok.astype(np.int64)), ("BranchId", np.full(len(s), b, np.int64)),
                         ("MaterialTwist", None if twist is None else np.degrees(twist(b, s)))):
            if val is not None:
                data[key].append(np.asarray(val))
        first = 0
        for q in parts:
            piece_ids[b].append(n + first + np.arange(len(q)))
            first += len(q) - 1
        n += len(s)
    points = np.vstack(pts)
    pdata = {k: np.concatenate(v) for k, v in data.items() if v}
    pdata["MaximumInscribedSphereRadius"] = surface(points)[1]
    cells, cdata = _cells(pieces, piece_ids, paths)
    return CenterlineNetwork(points=points, cells=tuple(cells), point_data=pdata, cell_data=cdata)


def _off_caps(gc, parts, terminal, surface):
    """The tracts' samples ``parts`` of a branch, its first / last tract starting / stopping where the sphere of
    the fitted radius meets a flat cap at a terminal end (``terminal``: whether its start / end is one of the
    mesh's ends), as VMTK's lines do (module notes). An end is on a cap when its point lies closer to the
    surface than ``tolerances.NETWORK_CAP_FRACTION`` of the fitted radius there."""
    parts = list(parts)
    for side, k in ((0, 0), (1, -1)):
        if not terminal[side]:
            continue
        q = parts[k]
        d = surface(gc.at([q[k]])[0])[1][0]
        if d >= tol.NETWORK_CAP_FRACTION * gc.radius_at([q[k]])[0]:
            continue
        qq = q if side == 0 else q[::-1]  # from the cap inwards
        g = np.abs(qq - qq[0]) * gc.length - gc.radius_at(qq)  # arc from the cap less the radius: 0 where they meet
        i = int(np.argmax(g >= 0)) if np.any(g >= 0) else len(qq)
        if i >= len(qq) - 1:
            continue  # a tract shorter than the radius: left whole
        cut = qq[i - 1] + (qq[i] - qq[i - 1]) * (-g[i - 1] / (g[i] - g[i - 1]))  # g < 0 before i
        qq = np.r_[cut, qq[i:]] if qq[i] != cut else qq[i:]
        parts[k] = qq if side == 0 else qq[::-1]
    return parts


def _depths(parent):
    """Depth of each branch below the trunk."""
    depth = np.zeros(len(parent), np.int64)
    for b in range(len(parent)):
        p = parent[b]
        while p >= 0:
            depth[b] += 1
            p = parent[p]
    return depth


def _abscissa_at_end(branches, parent, b):
    """Arc length from the root to the end of branch ``b``."""
    a = 0.0
    while b >= 0:
        a += branches[b].length
        b = parent[b]
    return a


def _cells(pieces, piece_ids, paths):
    """One cell per tract of each path, with VMTK's cell arrays."""
    group = {}
    for b, ps in enumerate(pieces):
        for q in range(len(ps)):
            group[(b, q)] = len(group)
    cells, cid, tid, gid, blank = [], [], [], [], []
    for c, path in enumerate(paths):
        t = 0
        for b in path:
            for q, p in enumerate(pieces[b]):
                cells.append(piece_ids[b][q])
                cid.append(c)
                tid.append(t)
                gid.append(group[(b, q)])
                blank.append(p.blank)
                t += 1
    cdata = {"CenterlineIds": cid, "TractIds": tid, "GroupIds": gid, "Blanking": blank}
    return cells, {k: np.asarray(v, np.int64) for k, v in cdata.items()}
