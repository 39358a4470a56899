"""Twisted copies of real vessel trees with exact twist truth taken from VMTK's centre lines.

Usage::

    python data_gen/real_twist.py OUT --mesh NAME --main K --profile linear|sine|step --total-deg D
                                  [--s0 S0] [--s1 S1] [--seed S] [--edge E] [--no-remesh] [--no-checks]

writes ``OUT/a.ply`` (scan A: the real mesh in mm), ``OUT/b.ply`` (scan B: the twisted, remeshed and
rigidly moved copy) and ``OUT/truth.json`` (the main line, the profile, every side junction with its
arc length, twist, lines, radii, angle and ``divides``, the rigid motion, the checks).
:func:`main_line_choices` lists, for every VMTK line taken as main vessel, its side junctions.

The construction
----------------
Everything that defines the truth comes from VMTK 1.5.2's centre lines of the mesh
(``shared/data/real/vmtk/<mesh>.npz``: one line per target end, all from one source end, in mm,
with the maximum inscribed sphere radius at every point); nothing of vesselgp's fitting is used.

1. *Axis.* The mesh is read and scaled to mm (``mm_scale`` of the npz). The main vessel is VMTK line
   ``main_line`` (points ``main_points``, arc length ``main_s`` = cumulative chord length, from its
   source end). Its points are noisy (0.05-0.7 mm apart), so the twist axis is a local quadratic
   least-squares fit of the line against arc length with Gaussian weights of width one inscribed
   radius, evaluated on a dense grid of ``s``: the axis point ``c(s)`` and the unit tangent ``T(s)``
   (pointing from source to target) are its value and derivative. ``s`` stays the VMTK line's arc
   length, so ``alpha(s)`` and the junctions use one parameter.
2. *Side junctions.* Every other line ``j`` runs with the main line from the source and then leaves it.
   Its departure is the first point after which it stays farther than ``0.5 *`` the local main
   inscribed radius from the axis; the junction ``s`` is the arc length of that point's projection onto
   the axis. A line that never leaves is ignored. Lines that leave within one main radius of each
   other (in ``s``) and still run together one main radius past the departure (within half a main
   radius) form one side subtree (a side branch that itself divides); two branches leaving at the
   same level on opposite sides (renal arteries) stay two subtrees. Each junction records the side's
   radius and angle past its *junction zone* (where the side line's inscribed spheres stop overlapping
   the main line's), the main line's radius there and past its own zone (``continuing_radius``) and
   ``divides`` (side and continuation comparable: see :class:`SideJunction`).
3. *Labels.* Each vertex takes the VMTK line point (lines resampled densely) minimising
   distance / inscribed radius, so a thin branch is not swallowed by a wide trunk beside it. If that
   point is on the main line, on a line of no subtree, or on a side line before its departure the
   vertex is *main*; otherwise it belongs to the subtree of that line. Subtrees whose vertices touch
   (share a mesh edge) are merged into one (two rigid turns side by side would tear the surface).
4. *Twist.* A main vertex ``v`` projected onto the axis at ``c(s)`` moves to
   ``c(s) + R(T(s), alpha(s)) (v - c(s))``: the right-handed rotation by ``alpha(s)`` about the axis
   line through ``c(s)`` along ``T(s)``. Every vertex of side subtree ``j`` moves rigidly,
   ``c_j + R(T_j, alpha_j) (v - c_j)`` with ``c_j = c(s_j)``, ``T_j = T(s_j)``, ``alpha_j = alpha(s_j)``.
   The two fields differ at the edge of a subtree (a main vertex beside it projects to
   ``s != s_j`` and, on a curved axis, ``T(s) != T_j``), so main vertices within a blend width
   ``D_j`` of the subtree's border (its vertices sharing an edge with a main vertex) take
   ``(1 - w) main + w rigid_j`` with ``w = smoothstep(1 - d / D_j)``, ``d`` the distance to the border
   (weights of several junctions summing above 1 are normalised). ``D_j`` is the largest of the main
   radius at ``s_j``, 3 median edges and 3 times the largest jump between the two fields at the border
   (so the blend shears by at most about a third). The surface is continuous; side subtrees stay
   exactly rigid; main vertices outside the blend zones (``blend == 0``) follow ``alpha(s)`` exactly.
   A constant twist about a curved axis stretches the wall (the inner bend goes to the outer):
   twisted/original edge lengths span about 0.6-1.7 at 90 degrees on these trees.
5. *Scan B.* The twisted mesh (scan A's faces) is remeshed with pymeshlab's isotropic explicit
   remeshing (target edge = scan A's median edge unless ``edge`` is given; boundary loops, i.e. open
   ends, kept and checked) and moved rigidly, ``V_b = X @ rotation.T + translation`` with a random
   rotation of at least 30 degrees and a translation of 50 mm (``seed``).
6. *Checks* (:func:`check_case`): no twist and no remesh gives scan A moved rigidly; face normals of the
   twisted (un-remeshed) mesh agree with scan A's turned by each face's rotation; self-intersecting
   faces (pymeshlab) before and after; the axis is fixed and VMTK's main line moves only by its
   scatter about the axis; each side line past its junction zone, turned with its subtree, keeps its
   distance to the twisted surface (inscribed radius) within 10 %. Large twists can make neighbouring
   branches that turn differently collide (self-intersections reported, not prevented).

Truth: the twist of side subtree ``j`` relative to the main vessel's start is exactly ``alpha(s_j)``
(``SideJunction.alpha``) about ``T(s_j)``; the main vessel's cross-sections turn by ``alpha(s)``.
"""
from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

# --------------------------------------------------------------------------- #
# where the data lives
# --------------------------------------------------------------------------- #
_HERE = Path(__file__).resolve()


def real_dir():
    """The folder of real meshes: ``$VESSELGP_REAL_DATA``, else the first ``shared/data/real`` above this file.

    Returns
    -------
    pathlib.Path
    """
    env = os.environ.get("VESSELGP_REAL_DATA")
    if env:
        return Path(env)
    for parent in _HERE.parents:
        cand = parent / "shared" / "data" / "real"
        if cand.is_dir():
            return cand
    return Path("/work/shared/data/real")


def _vmtk_file(name):
    """VMTK's npz for mesh ``name``: ``tests/data/vmtk`` overrides the shared one (as ``tests/_data.py``)."""
    local = _HERE.parents[1] / "tests" / "data" / "vmtk" / f"{name}.npz"
    return local if local.is_file() else real_dir() / "vmtk" / f"{name}.npz"


def load_tree(name):
    """Read real mesh ``name`` in mm with VMTK's centre lines.

    Parameters
    ----------
    name : str
        File name in :func:`real_dir` (e.g. ``"gmsh_abdominal-aorta-renal-iliac_open.stl"``) or a path
        whose base name has an npz in ``real_dir()/vmtk``.

    Returns
    -------
    V : (n, 3) float64
        Vertices in mm (the file's coordinates times ``mm_scale``).
    F : (m, 3) int64
    lines : list of ((k, 3) float64, (k,) float64)
        VMTK's lines (points in mm, maximum inscribed sphere radius), each from the source.
    info : dict
        ``source`` (3,), ``targets`` (L, 3), ``mm_scale`` (float), ``path`` (str).
    """
    import vesselgp

    p = Path(name)
    if not p.is_file():
        p = real_dir() / name
    ref = np.load(_vmtk_file(p.name))
    scale = float(ref["mm_scale"])
    V, F = vesselgp.read_mesh(p)[:2]
    V = np.asarray(V, np.float64) * scale
    F = np.asarray(F, np.int64)
    n = sum(f.endswith("_points") for f in ref.files)
    lines = [(ref[f"line{k}_points"].astype(np.float64), ref[f"line{k}_radius"].astype(np.float64))
             for k in range(n)]
    return V, F, lines, {"source": ref["source"].astype(np.float64), "targets": ref["targets"].astype(np.float64),
                         "mm_scale": scale, "path": str(p)}


# --------------------------------------------------------------------------- #
# small geometry helpers
# --------------------------------------------------------------------------- #
def arc_length(P):
    """Cumulative chord length of polyline ``P`` (k, 3), starting at 0."""
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])


def _resample(P, R, step):
    """Polyline ``P`` with radii ``R`` linearly resampled so no step exceeds ``step``; returns (Q, r, arc)."""
    s = arc_length(P)
    n = max(int(np.ceil(s[-1] / step)), 1) + 1
    t = np.unique(np.concatenate([np.linspace(0.0, s[-1], n), s]))
    return (np.stack([np.interp(t, s, P[:, i]) for i in range(3)], axis=1), np.interp(t, s, R), t)


def median_edge(V, F):
    """Median edge length of mesh (V, F)."""
    E = _edges(F)
    return float(np.median(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)))


def _edges(F):
    """Unique undirected edges (e, 2) of faces ``F``."""
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1).astype(np.int64)
    n = int(E.max()) + 1 if len(E) else 1
    key = np.unique(E[:, 0] * n + E[:, 1])
    return np.stack([key // n, key % n], axis=1)


def boundary_loops(F):
    """Number of boundary loops of ``F`` (connected components of the edges used by one face)."""
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    u, c = np.unique(E, axis=0, return_counts=True)
    b = u[c == 1]
    if len(b) == 0:
        return 0
    ids, inv = np.unique(b, return_inverse=True)
    inv = inv.reshape(-1, 2)
    g = coo_matrix((np.ones(len(inv)), (inv[:, 0], inv[:, 1])), shape=(len(ids), len(ids)))
    return int(connected_components(g, directed=False)[0])


def min_angles_deg(V, F):
    """Smallest corner angle (degrees) of each face."""
    A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    out = np.full(len(F), 180.0)
    for p, q, r in ((A, B, C), (B, C, A), (C, A, B)):
        u, v = q - p, r - p
        c = np.einsum("ij,ij->i", u, v) / np.maximum(np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1), 1e-300)
        out = np.minimum(out, np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
    return out


def face_normals(V, F):
    """Unit face normals (m, 3) (right-hand rule on each face's vertex order)."""
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)


def _closest_on_triangles(P, A, B, C):
    """Closest points on triangles (A, B, C) to points ``P`` (all (n, 3)): Ericson's region test, vectorised."""
    ab, ac, ap = B - A, C - A, P - A
    d1, d2 = np.einsum("ij,ij->i", ab, ap), np.einsum("ij,ij->i", ac, ap)
    bp = P - B
    d3, d4 = np.einsum("ij,ij->i", ab, bp), np.einsum("ij,ij->i", ac, bp)
    cp = P - C
    d5, d6 = np.einsum("ij,ij->i", ab, cp), np.einsum("ij,ij->i", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    den = np.where(np.abs(va + vb + vc) > 1e-300, va + vb + vc, 1e-300)
    v, w = vb / den, vc / den
    out = A + ab * v[:, None] + ac * w[:, None]  # interior
    eps = 1e-300
    # edges
    m = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
    t = d1 / np.where(np.abs(d1 - d3) > eps, d1 - d3, eps)
    out[m] = (A + ab * t[:, None])[m]
    m2 = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
    t = d2 / np.where(np.abs(d2 - d6) > eps, d2 - d6, eps)
    out[m2] = (A + ac * t[:, None])[m2]
    m3 = (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0)
    t = (d4 - d3) / np.where(np.abs((d4 - d3) + (d5 - d6)) > eps, (d4 - d3) + (d5 - d6), eps)
    out[m3] = (B + (C - B) * t[:, None])[m3]
    # vertices (last: they win)
    out[(d1 <= 0) & (d2 <= 0)] = A[(d1 <= 0) & (d2 <= 0)]
    out[(d3 >= 0) & (d4 <= d3)] = B[(d3 >= 0) & (d4 <= d3)]
    out[(d6 >= 0) & (d5 <= d6)] = C[(d6 >= 0) & (d5 <= d6)]
    return out


def point_mesh_distance(P, V, F, k=16):
    """Exact distance from points ``P`` (n, 3) to the triangle surface (V, F).

    Faces are tried by increasing centroid distance (cKDTree), ``k`` at a time doubling, until the next
    centroid is farther than the best distance plus the largest centroid-to-corner distance (so no
    untried face can be nearer). Agrees with libigl's ``point_mesh_squared_distance`` to rounding.
    """
    P = np.atleast_2d(np.asarray(P, np.float64))
    cen = V[F].mean(axis=1)
    rho = float(np.linalg.norm(V[F] - cen[:, None], axis=2).max())
    tree = cKDTree(cen)
    best = np.full(len(P), np.inf)
    todo = np.arange(len(P))
    done_k = 0
    while len(todo):
        k = min(max(k, 2 * done_k), len(F))
        dc, idx = tree.query(P[todo], k=k)
        dc, idx = dc.reshape(len(todo), k), idx.reshape(len(todo), k)
        step = max(1, 400000 // max(k - done_k, 1))
        for b in range(0, len(todo), step):  # all new (point, face) pairs of a block at once
            t = todo[b:b + step]
            f = F[idx[b:b + step, done_k:k].ravel()]
            Pp = np.repeat(P[t], k - done_k, axis=0)
            q = _closest_on_triangles(Pp, V[f[:, 0]], V[f[:, 1]], V[f[:, 2]])
            d = np.linalg.norm(Pp - q, axis=1).reshape(len(t), k - done_k).min(axis=1)
            best[t] = np.minimum(best[t], d)
        if k == len(F):
            break
        todo = todo[dc[:, -1] - rho < best[todo]]
        done_k = k
    return best


def _smoothstep(t):
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


# --------------------------------------------------------------------------- #
# twist profiles
# --------------------------------------------------------------------------- #
def alpha_profile(kind, total_deg, s0, s1):
    """A twist profile ``alpha(s)`` in radians along the main line's arc length ``s`` (mm).

    Parameters
    ----------
    kind : {"linear", "sine", "step"}
        ``"linear"``: 0 up to ``s0``, rising linearly to ``total_deg`` at ``s1``, constant after.
        ``"sine"``: ``total_deg * sin(pi (s - s0) / (s1 - s0))`` between ``s0`` and ``s1``, 0 outside
        (back to 0 at ``s1``). ``"step"``: a C1 smooth step, ``total_deg * (3 t^2 - 2 t^3)`` with
        ``t = (s - s0) / (s1 - s0)`` clipped to [0, 1]: 0 before ``s0``, ``total_deg`` after ``s1``.
    total_deg : float
        Amplitude, degrees.
    s0, s1 : float
        The interval (mm), ``s1 > s0``.

    Returns
    -------
    callable
        ``alpha(s)`` (float or array in, same shape out), radians; ``alpha.kind``, ``alpha.total_deg``,
        ``alpha.s0`` and ``alpha.s1`` record the parameters.
    """
    s0, s1, tot = float(s0), float(s1), np.radians(float(total_deg))
    if not s1 > s0:
        raise ValueError(f"alpha_profile: s1 ({s1}) must exceed s0 ({s0})")
    if kind not in ("linear", "sine", "step"):
        raise ValueError(f"alpha_profile: unknown kind {kind!r}; use linear, sine or step")

    def alpha(s):
        t = (np.asarray(s, np.float64) - s0) / (s1 - s0)
        if kind == "linear":
            a = tot * np.clip(t, 0.0, 1.0)
        elif kind == "sine":
            a = np.where((t > 0) & (t < 1), tot * np.sin(np.pi * np.clip(t, 0.0, 1.0)), 0.0)
        else:
            a = tot * _smoothstep(t)
        return a if a.ndim else float(a)

    alpha.kind, alpha.total_deg, alpha.s0, alpha.s1 = kind, float(total_deg), s0, s1
    return alpha


# --------------------------------------------------------------------------- #
# the main axis: local quadratic fit of VMTK's main line
# --------------------------------------------------------------------------- #
class MainAxis:
    """The smoothed main line: axis points ``c(s)`` and unit tangents ``T(s)`` on a dense grid of VMTK arc length.

    Parameters
    ----------
    P : (k, 3) VMTK line points (mm), from the source.
    R : (k,) their inscribed radii.

    Attributes
    ----------
    s_raw, P, R : the VMTK line, its arc length and radii.
    s, c, T, r : the grid (step <= a fifth of the smallest radius, at most 0.5 mm), axis points,
        tangents and radius (interpolated VMTK radius).
    """

    def __init__(self, P, R):
        self.P, self.R = np.asarray(P, np.float64), np.asarray(R, np.float64)
        self.s_raw = arc_length(self.P)
        L = self.s_raw[-1]
        h = min(0.5, 0.2 * float(self.R.min()))
        self.s = np.linspace(0.0, L, max(int(np.ceil(L / h)), 2) + 1)
        self.r = np.interp(self.s, self.s_raw, self.R)
        self.c, self.T = self._fit(self.s)
        self._tree = cKDTree(self.c)

    def _fit(self, se, block=2048):
        """Local quadratic fit of P(s) at ``se``: value and unit derivative; weights exp(-u^2/2), u = ds / sigma."""
        steps = np.diff(self.s_raw)
        gap = np.maximum(np.concatenate([[steps[0]], steps]), np.concatenate([steps, [steps[-1]]]))
        gap_e = np.interp(se, self.s_raw, gap)
        sig = np.maximum(np.interp(se, self.s_raw, self.R), 2.0 * gap_e)
        C, D = np.empty((len(se), 3)), np.empty((len(se), 3))
        for b in range(0, len(se), block):
            e = slice(b, b + block)
            u = (self.s_raw[None, :] - se[e, None]) / sig[e, None]
            w = np.exp(-0.5 * u * u) * (np.abs(u) < 4.0)
            B = np.stack([np.ones_like(u), u, u * u], axis=2)  # (e, k, 3)
            A = np.einsum("ek,eki,ekj->eij", w, B, B)
            rhs = np.einsum("ek,eki,kd->eid", w, B, self.P)
            A += 1e-12 * np.eye(3)[None]
            X = np.linalg.solve(A, rhs)  # (e, 3 basis, 3 dims)
            C[e], D[e] = X[:, 0], X[:, 1] / sig[e, None]
        return C, D / np.linalg.norm(D, axis=1, keepdims=True)

    def at(self, s):
        """Axis point, unit tangent and radius at arc length(s) ``s`` (linear interpolation on the grid)."""
        s = np.atleast_1d(np.asarray(s, np.float64))
        c = np.stack([np.interp(s, self.s, self.c[:, i]) for i in range(3)], axis=1)
        T = np.stack([np.interp(s, self.s, self.T[:, i]) for i in range(3)], axis=1)
        return c, T / np.linalg.norm(T, axis=1, keepdims=True), np.interp(s, self.s, self.r)

    def project(self, X):
        """Nearest points of the axis polyline to ``X`` (n, 3): returns (s, c, T, distance)."""
        X = np.atleast_2d(X)
        _, i = self._tree.query(X)
        n = len(self.s)
        best_d = np.full(len(X), np.inf)
        best_s = np.zeros(len(X))
        for a in (i - 1, i):
            a = np.clip(a, 0, n - 2)
            A, B = self.c[a], self.c[a + 1]
            d = B - A
            t = np.clip(np.einsum("ij,ij->i", X - A, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-300), 0, 1)
            q = A + t[:, None] * d
            dist = np.linalg.norm(X - q, axis=1)
            m = dist < best_d
            best_d[m] = dist[m]
            best_s[m] = (self.s[a] + t * (self.s[a + 1] - self.s[a]))[m]
        c, T, _ = self.at(best_s)
        return best_s, c, T, np.linalg.norm(X - c, axis=1)


#: ``SideJunction.divides``: the narrower of side and continuing main at least this times the wider
DIVIDES = 0.6

# --------------------------------------------------------------------------- #
# junctions
# --------------------------------------------------------------------------- #
@dataclass(frozen=True)
class SideJunction:
    """Where a side subtree leaves the main line, with its twist.

    Attributes
    ----------
    s : float
        Arc length along the main line (mm) where the subtree leaves (its earliest line's departure).
    point : (3,) float64
        The main axis point ``c(s)`` there (scan A coordinates, mm): the rigid turn's axis passes here.
    lines : tuple of int
        VMTK line indices of the subtree.
    alpha : float
        ``alpha(s)``: the subtree's rigid turn about ``tangent`` (radians, right-handed). 0 in
        :func:`main_line_choices` (no profile).
    side_radius : float
        Median VMTK inscribed radius of the side line (the subtree's widest) over three side radii
        past its junction zone (where its inscribed sphere stops overlapping the main line's).
    main_radius : float
        VMTK inscribed radius of the main line at ``s`` (inflated where the main vessel divides).
    angle_deg : float
        Angle (degrees) between the side's initial direction, the chord from the end of its junction
        zone over three side radii, and the main tangent ``T(s)``.
    divides : bool
        ``min(side_radius, continuing_radius) >= 0.6 * max(side_radius, continuing_radius)``: the
        main vessel divides here into two comparable daughters (the side and the main line's
        continuation, neither more than 1/0.6 = 1.67 times as wide as the other) rather than giving off
        a small side branch (side much narrower) or leaving the trunk as a small branch itself (side,
        the trunk's continuation, much wider). 0.6 rather than 0.7: the carotid's external/internal
        carotid (0.66) and the renal-iliac tree's iliacs (0.69, one with an aneurysmal bulge) are the
        bifurcations of comparable daughters that a 0.7 would miss. With a narrow branch as main
        line, its junctions still in the parent trunk compare the side with the main line's own
        narrow continuation (its branch), so read ``divides`` with ``continuing_radius``.
    tangent : (3,) float64
        The main axis tangent ``T(s)`` (the rigid turn's axis direction).
    continuing_radius : float
        Median inscribed radius of the main line over three radii past its own junction zone (where
        its spheres stop overlapping the side line's); when the main line ends before that, over its
        last three radii.
    main_end_radii : float
        Main-line arc length left after ``s``, in main radii (the main line "ends here" when small).
    zone_exit : float
        Arc length along the side line (mm, from the source) where its junction zone ends.
    line_zone_exits : tuple of float
        The same for each of ``lines``.
    side_line : int
        The line ``side_radius``, ``angle_deg`` and ``zone_exit`` are measured on (the subtree's widest).
    """

    s: float
    point: np.ndarray
    lines: tuple
    alpha: float
    side_radius: float
    main_radius: float
    angle_deg: float
    divides: bool
    tangent: np.ndarray = field(default=None, repr=False)
    continuing_radius: float = float("nan")
    main_end_radii: float = float("nan")
    zone_exit: float = float("nan")
    line_zone_exits: tuple = ()
    side_line: int = -1

    def to_dict(self):
        """JSON-ready record (alpha also in degrees)."""
        return {"s": self.s, "point": np.asarray(self.point).tolist(), "lines": list(self.lines),
                "alpha_deg": float(np.degrees(self.alpha)), "alpha_rad": self.alpha,
                "side_radius": self.side_radius, "main_radius": self.main_radius,
                "angle_deg": self.angle_deg, "divides": bool(self.divides),
                "tangent": np.asarray(self.tangent).tolist(), "continuing_radius": self.continuing_radius,
                "main_end_radii": self.main_end_radii, "zone_exit": self.zone_exit,
                "line_zone_exits": list(self.line_zone_exits), "side_line": self.side_line}


def _departure(axis, P):
    """Index of line ``P``'s departure from the axis (first point after which it stays beyond half the main
    radius) and the axis arc length of its projection; ``None`` if it never leaves."""
    s, _, _, d = axis.project(P)
    r = np.interp(s, axis.s, axis.r)
    near = np.nonzero(d <= 0.5 * r)[0]
    i = 0 if len(near) == 0 else near[-1] + 1
    if i >= len(P):
        return None
    return i, float(s[i])


def _clear_index(Q, rq, M, rm, start):
    """First index >= start where the sphere (Q[i], rq[i]) no longer overlaps any sphere (M, rm); else None."""
    tree = cKDTree(M)
    rmax = float(rm.max())
    for b in range(start, len(Q), 256):
        q = Q[b:b + 256]
        # candidates: centres within rq + rmax
        clear = np.ones(len(q), bool)
        for k, (pt, rr) in enumerate(zip(q, rq[b:b + 256])):
            idx = tree.query_ball_point(pt, rr + rmax)
            if idx:
                clear[k] = not np.any(np.linalg.norm(M[idx] - pt, axis=1) < rm[idx] + rr)
        hit = np.nonzero(clear)[0]
        if len(hit):
            return b + int(hit[0])
    return None


def _window_median(a, r, start, n_radii=3.0):
    """Median of ``r`` over arc ``a`` in [a[start], a[start] + n_radii * r[start]] (at least 2 points if there)."""
    end = a[start] + n_radii * r[start]
    sel = np.nonzero((a >= a[start]) & (a <= end))[0]
    if len(sel) < 2:
        sel = np.arange(start, min(start + 2, len(a)))
    return float(np.median(r[sel])), int(sel[-1])


def find_junctions(lines, main_line, axis=None, groups=None):
    """Side junctions of VMTK line ``main_line`` (the construction's step 2), sorted by ``s``; ``alpha`` 0.

    Parameters
    ----------
    lines : list of ((k, 3), (k,))
        VMTK lines (mm) with inscribed radii.
    main_line : int
    axis : MainAxis, optional
        Of the main line (built if not given).
    groups : list of list of int, optional
        The subtrees' lines (default: lines leaving within one main radius of each other and running
        together one main radius on, within half a main radius).

    Returns
    -------
    junctions : tuple of SideJunction
    departures : dict
        Line index -> arc length along that line (mm) where it leaves the main line (lines that never
        leave are absent).
    """
    if axis is None:
        axis = MainAxis(*lines[main_line])
    Pm, Rm = lines[main_line]
    dep = {}
    for j, (P, R) in enumerate(lines):
        if j == main_line:
            continue
        d = _departure(axis, P)
        if d is not None:
            dep[j] = d  # (index on line j, s on main)
    if groups is None:
        # group lines leaving together and running together
        groups = []
        for j in sorted(dep, key=lambda j: dep[j][1]):
            placed = False
            for g in groups:
                j0 = g[0]
                sj, s0 = dep[j][1], dep[j0][1]
                rmain = float(np.interp(min(sj, s0), axis.s, axis.r))
                if abs(sj - s0) > rmain:
                    continue
                if _run_together(lines[j][0], dep[j][0], lines[j0][0], dep[j0][0], rmain):
                    g.append(j)
                    placed = True
                    break
            if not placed:
                groups.append([j])
    out = []
    for g in groups:
        g = sorted(g)
        s_j = min(dep[j][1] for j in g)
        c, T, rm = axis.at(s_j)
        c, T, rm = c[0], T[0], float(rm[0])
        recs = [_side_measures(lines, j, dep[j][0], axis, T) for j in g]
        rep = max(range(len(g)), key=lambda i: recs[i][0])
        side_r, angle, zone_exit = recs[rep]
        cont, left = _continuing_radius(Pm, Rm, lines[g[rep]], s_j, axis)
        out.append(SideJunction(s=float(s_j), point=c, lines=tuple(g), alpha=0.0,
                                side_radius=side_r, main_radius=rm, angle_deg=angle,
                                divides=bool(min(side_r, cont) >= DIVIDES * max(side_r, cont)), tangent=T,
                                continuing_radius=cont, main_end_radii=left / rm, zone_exit=zone_exit,
                                line_zone_exits=tuple(r[2] for r in recs), side_line=g[rep]))
    out.sort(key=lambda j: j.s)
    return tuple(out), {j: float(arc_length(lines[j][0])[dep[j][0]]) for j in dep}


def side_junctions(V, F, lines, main_line, axis=None):
    """Junctions and vertex labels of main line ``main_line`` on mesh (V, F) (construction steps 2-3).

    Subtrees whose vertices touch (share a mesh edge) are merged into one: two rigid turns side by side
    would tear the surface (e.g. a renal artery taken as main vessel: another renal leaving right beside
    it and the aorta's continuation both leave it within a radius).

    Returns
    -------
    junctions : tuple of SideJunction (``alpha`` 0), sorted by ``s``
    departures : dict (see :func:`find_junctions`)
    labels : (n,) int64, -1 main, else the junction index
    """
    if axis is None:
        axis = MainAxis(*lines[main_line])
    jns, dep = find_junctions(lines, main_line, axis)
    labels = vertex_labels(V, lines, main_line, jns, dep)
    E = _edges(F)
    le = labels[E]
    m = (le[:, 0] >= 0) & (le[:, 1] >= 0) & (le[:, 0] != le[:, 1])
    if m.any():
        n = len(jns)
        g = coo_matrix((np.ones(int(m.sum())), (le[m, 0], le[m, 1])), shape=(n, n))
        k, comp = connected_components(g, directed=False)
        if k < n:
            groups = [sorted(j for c in np.nonzero(comp == q)[0] for j in jns[c].lines) for q in range(k)]
            jns, dep = find_junctions(lines, main_line, axis, groups=groups)
            labels = vertex_labels(V, lines, main_line, jns, dep)
    return jns, dep, labels


def _run_together(P1, i1, P2, i2, rmain):
    """Whether two lines, one main radius past their departures, are within half a main radius of each other."""
    ok = True
    for (A, ia), B in (((P1, i1), P2), ((P2, i2), P1)):
        a = arc_length(A)
        k = int(np.searchsorted(a, min(a[ia] + rmain, a[-1])))
        k = min(k, len(A) - 1)
        Bd, _, _ = _resample(B, np.zeros(len(B)), 0.05 * rmain)
        ok &= float(cKDTree(Bd).query(A[k])[0]) <= 0.5 * rmain
    return bool(ok)


def _side_measures(lines, j, i_dep, axis, T):
    """(side radius, angle to T in degrees, zone-exit arc length) of side line ``j`` departing at index ``i_dep``."""
    P, R = lines[j]
    a = arc_length(P)
    Q, rq, aq = _resample(P, R, max(0.2 * float(R.min()), 0.02))
    start = int(np.searchsorted(aq, a[i_dep]))
    M, rmr = axis.c, axis.r
    ex = _clear_index(Q, rq, M, rmr, start)
    if ex is None:  # a stub: its sphere never clears the main line's; take its farthest point
        _, _, _, d = axis.project(Q[start:])
        ex = start + int(np.argmax(d - rq[start:]))
    side_r, last = _window_median(aq, rq, ex)
    chord = Q[last] - Q[ex]
    if np.linalg.norm(chord) < 1e-9:  # line ends at the exit: use the last stretch before it
        chord = Q[ex] - Q[max(start, ex - max(1, int(3 * rq[ex] / max(aq[1] - aq[0], 1e-9))))]
    cosang = np.dot(chord, T) / max(np.linalg.norm(chord), 1e-300)
    return side_r, float(np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))), float(aq[ex])


def _continuing_radius(Pm, Rm, side, s_j, axis):
    """Main line's median radius over three radii past its junction zone with ``side``; and its length left."""
    Qm, rqm, aqm = _resample(Pm, Rm, max(0.2 * float(Rm.min()), 0.02))
    Ps, Rs = side
    Qs, rqs, _ = _resample(Ps, Rs, max(0.2 * float(Rs.min()), 0.02))
    # the side's spheres from its first point beyond half a main radius on (before: the main vessel's)
    sp, _, _, ds = axis.project(Qs)
    away = np.nonzero(ds > 0.5 * np.interp(sp, axis.s, axis.r))[0]
    own = np.arange(len(Qs)) >= (away[0] if len(away) else len(Qs))
    start = int(np.searchsorted(aqm, s_j))
    left = float(aqm[-1] - s_j)
    ex = _clear_index(Qm, rqm, Qs[own], rqs[own], min(start, len(Qm) - 1)) if own.any() else start
    if ex is None or aqm[-1] - aqm[ex] < 3.0 * rqm[ex]:
        # the main line ends within its junction zone or three radii after: its last three radii
        k = int(np.searchsorted(aqm, aqm[-1] - 3.0 * rqm[-1]))
        return float(np.median(rqm[k:])), left
    return _window_median(aqm, rqm, ex)[0], left


def main_line_choices(name):
    """For each VMTK line of mesh ``name`` taken as the main vessel, its side junctions.

    Parameters
    ----------
    name : str
        Real mesh file name (see :func:`load_tree`).

    Returns
    -------
    list of tuple of SideJunction
        Entry ``k``: the junctions with line ``k`` as main (``alpha`` 0), sorted by ``s``; pick a
        trunk with small side branches (``divides`` False, small ``side_radius / main_radius``), a vessel
        ending in a bifurcation of comparable daughters (``divides`` True), branches leaving at 30-90
        degrees (``angle_deg``).
    """
    V, F, lines, _ = load_tree(name)
    return [side_junctions(V, F, lines, k)[0] for k in range(len(lines))]


# --------------------------------------------------------------------------- #
# labels and the twist
# --------------------------------------------------------------------------- #
def vertex_labels(V, lines, main_line, junctions, departures):
    """Label each vertex: -1 main vessel, else the index of its side junction in ``junctions``.

    The nearest VMTK point by distance / inscribed radius over all lines (resampled to steps of at most
    a fifth of each line's smallest radius) decides: on the main line, on a line of no subtree, or on a
    side line before its departure the vertex is main; otherwise it is in that line's subtree.
    """
    of_line = {j: g for g, jn in enumerate(junctions) for j in jn.lines}
    best = np.full(len(V), np.inf)
    lab = np.full(len(V), -1, np.int64)
    samples = [_resample(P, R, max(0.2 * float(R.min()), 0.02)) for P, R in lines]
    trees = [cKDTree(Q) for Q, _, _ in samples]
    # first pass within 3 largest radii of each line (fast); vertices left unlabelled get a full search
    for bounded in (True, False):
        todo = np.arange(len(V)) if bounded else np.nonzero(~np.isfinite(best))[0]
        if len(todo) == 0:
            break
        for j, ((Q, rq, aq), tree) in enumerate(zip(samples, trees)):
            k = min(6, len(Q))
            ub = 3.0 * float(rq.max()) if bounded else np.inf
            d, i = tree.query(V[todo], k=k, workers=-1, distance_upper_bound=ub)
            d, i = d.reshape(len(todo), k), i.reshape(len(todo), k)
            rq1, aq1 = np.append(rq, 1.0), np.append(aq, 0.0)  # index len(Q): no neighbour (d inf)
            q = d / rq1[i]
            m = np.argmin(q, axis=1)
            qm = q[np.arange(len(todo)), m]
            im = i[np.arange(len(todo)), m]
            better = qm < best[todo]
            tb = todo[better]
            best[tb] = qm[better]
            if j == main_line or j not in of_line:
                lab[tb] = -1
            else:
                lab[tb] = np.where(aq1[im[better]] >= departures[j], of_line[j], -1)
    return lab


def _rotate_about(X, c, rotvec):
    """Rotate points ``X`` about axis lines through ``c`` by rotation vectors ``rotvec`` (broadcast)."""
    return c + Rotation.from_rotvec(np.array(np.broadcast_to(rotvec, X.shape), np.float64)).apply(X - c)


def twist_vertices(V, F, axis, alpha, junctions, labels, blend_edges=3.0, jump_factor=3.0):
    """Apply the twist (construction step 4) to scan A's vertices.

    Returns
    -------
    X : (n, 3) twisted vertices.
    blend : (n,) total weight of side rigid motions in each main vertex (0 outside blend zones, 1 in subtrees).
    rotvec : (n, 3) rotation vector of each vertex's motion (main field or the subtree's; for blended
        vertices the main field's).
    widths : (J,) blend width of each junction (mm; 0 for a subtree without vertices or border).
    """
    n = len(V)
    X = np.empty_like(V)
    rotvec = np.zeros_like(V)
    main = labels < 0
    s, c, T, _ = axis.project(V[main])
    rv = alpha(s)[:, None] * T
    X[main] = _rotate_about(V[main], c, rv)
    rotvec[main] = rv
    blend = np.zeros(n)
    blend[~main] = 1.0
    E = _edges(F)
    edge = float(np.median(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)))
    mi = np.nonzero(main)[0]
    W, Y, widths = [], [], []
    for g, jn in enumerate(junctions):
        rv_j = jn.alpha * jn.tangent
        sub = labels == g
        if not sub.any():
            widths.append(0.0)
            continue
        X[sub] = _rotate_about(V[sub], jn.point, rv_j)
        rotvec[sub] = rv_j
        # border of the subtree: its vertices sharing an edge with a main vertex
        lab_e = labels[E]
        bmask = ((lab_e[:, 0] == g) & main[E[:, 1]]) | ((lab_e[:, 1] == g) & main[E[:, 0]])
        border = np.unique(np.where(lab_e[bmask, 0] == g, E[bmask, 0], E[bmask, 1]))
        if len(border) == 0:
            widths.append(0.0)
            continue
        # the main field's jump from the rigid turn at the border sets the blend width (at most a third
        # of it per unit length), at least the main radius and ``blend_edges`` edges
        bm = np.unique(np.where(lab_e[bmask, 0] == g, E[bmask, 1], E[bmask, 0]))
        jump = float(np.linalg.norm(X[bm] - _rotate_about(V[bm], jn.point, rv_j), axis=1).max())
        D = max(jn.main_radius, blend_edges * edge, jump_factor * jump)
        widths.append(D)
        d, _ = cKDTree(V[border]).query(V[mi], distance_upper_bound=D)
        w = _smoothstep(1.0 - np.minimum(d, D) / D)
        if not np.any(w > 0):
            continue
        W.append(w)
        Y.append(_rotate_about(V[mi], jn.point, rv_j))
    if W:
        W = np.array(W)
        tot = W.sum(axis=0)
        scale = np.where(tot > 1.0, 1.0 / np.maximum(tot, 1e-300), 1.0)
        W = W * scale
        Xm = X[mi] * (1.0 - W.sum(axis=0))[:, None]
        for w, y in zip(W, Y):
            Xm += w[:, None] * y
        X[mi] = Xm
        blend[mi] = W.sum(axis=0)
    return X, blend, rotvec, np.array(widths)


def remesh_mesh(V, F, edge, iterations=5):
    """pymeshlab's isotropic explicit remeshing at target edge ``edge`` (mm), surface distance checked.

    Returns (V, F) with the same number of boundary loops (raises RuntimeError otherwise).
    """
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int32)))
    ms.meshing_isotropic_explicit_remeshing(iterations=iterations, targetlen=pymeshlab.PureValue(edge),
                                            featuredeg=30.0, checksurfdist=True,
                                            maxsurfdist=pymeshlab.PureValue(0.05 * edge), reprojectflag=True)
    m = ms.current_mesh()
    V2, F2 = m.vertex_matrix().astype(np.float64), m.face_matrix().astype(np.int64)
    # drop unreferenced vertices, if any
    used = np.unique(F2)
    if len(used) < len(V2):
        remap = np.full(len(V2), -1, np.int64)
        remap[used] = np.arange(len(used))
        V2, F2 = V2[used], remap[F2]
    if boundary_loops(F2) != boundary_loops(F):
        raise RuntimeError(f"remesh changed the boundary loops: {boundary_loops(F)} -> {boundary_loops(F2)}")
    return V2, F2


def random_rigid(seed, min_angle_deg=30.0, distance=50.0):
    """A random rotation (angle >= ``min_angle_deg``) and a translation of length ``distance`` (mm)."""
    rng = np.random.default_rng(seed)
    while True:
        rot = Rotation.random(random_state=rng)
        if np.degrees(rot.magnitude()) >= min_angle_deg:
            break
    t = rng.normal(size=3)
    return rot.as_matrix(), distance * t / np.linalg.norm(t)


@dataclass(frozen=True)
class RealTwistCase:
    """A real tree (scan A) and its twisted, remeshed, rigidly moved copy (scan B) with the twist truth.

    Attributes
    ----------
    name : str
    V_a, F_a : the real mesh in mm (float64, int64).
    V_b, F_b : scan B: ``V_b = X @ rotation.T + translation``, ``X`` the twisted (remeshed) mesh.
    rotation : (3, 3); translation : (3,)
    main_line : int
        VMTK line used as main vessel.
    main_points : (k, 3)
        That VMTK line (mm), from its source end.
    main_s : (k,)
        Its arc length (cumulative chord length); the ``s`` of ``alpha`` and the junctions.
    source, target : (3,)
        VMTK's source (centre of the main vessel's first end, near ``main_points[0]``) and the main
        line's last point.
    alpha : callable
        ``alpha(s)`` radians.
    junctions : tuple of SideJunction
        Sorted by ``s``, with ``alpha = alpha(s)``.
    V_twisted : (n, 3)
        Scan A twisted (scan A's faces), before remeshing and the rigid motion.
    labels : (n,) int64
        Per scan A vertex: -1 main vessel, else its junction's index.
    blend : (n,)
        Weight of the side rigid motions in each vertex (1 in subtrees, 0 where the main field is exact).
    axis_s, axis_points, axis_tangents : the smoothed main axis (grid of ``s``, ``c(s)``, ``T(s)``).
    rotvec : (n, 3)
        Rotation vector of each scan A vertex's motion (``alpha(s) T(s)`` or the subtree's
        ``alpha_j T_j``; blended vertices carry the main field's).
    blend_widths : (J,)
        Blend width ``D_j`` of each junction (mm).
    remeshed : bool
    edge : float
        Remeshing target edge (mm).
    seed : int
    """

    name: str
    V_a: np.ndarray
    F_a: np.ndarray
    V_b: np.ndarray
    F_b: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray
    main_line: int
    main_points: np.ndarray
    main_s: np.ndarray
    source: np.ndarray
    target: np.ndarray
    alpha: Callable
    junctions: tuple
    V_twisted: np.ndarray = field(repr=False, default=None)
    labels: np.ndarray = field(repr=False, default=None)
    blend: np.ndarray = field(repr=False, default=None)
    axis_s: np.ndarray = field(repr=False, default=None)
    axis_points: np.ndarray = field(repr=False, default=None)
    axis_tangents: np.ndarray = field(repr=False, default=None)
    rotvec: np.ndarray = field(repr=False, default=None)
    blend_widths: np.ndarray = field(repr=False, default=None)
    remeshed: bool = False
    edge: float = float("nan")
    seed: int = 0

    def truth(self):
        """JSON-ready truth: main line, profile, junctions, rigid motion."""
        a = self.alpha
        return {"mesh": self.name, "units": "mm", "main_line": self.main_line,
                "main_length": float(self.main_s[-1]),
                "profile": {"kind": getattr(a, "kind", None), "total_deg": getattr(a, "total_deg", None),
                            "s0": getattr(a, "s0", None), "s1": getattr(a, "s1", None)},
                "source": self.source.tolist(), "target": self.target.tolist(),
                "main_points": self.main_points.tolist(), "main_s": self.main_s.tolist(),
                "alpha_deg_at_main_s": np.degrees(a(self.main_s)).tolist(),
                "junctions": [j.to_dict() for j in self.junctions],
                "rotation": self.rotation.tolist(), "translation": self.translation.tolist(),
                "rigid_motion": "V_b = X @ rotation.T + translation",
                "remeshed": self.remeshed, "edge": self.edge, "seed": self.seed,
                "n_vertices_a": len(self.V_a), "n_faces_a": len(self.F_a),
                "n_vertices_b": len(self.V_b), "n_faces_b": len(self.F_b)}


def twisted_copy(name, main_line, alpha, *, remesh=True, seed=0, edge=None):
    """Build a twisted copy of real tree ``name`` about VMTK line ``main_line`` (see the module docstring).

    Parameters
    ----------
    name : str
        Real mesh file name (in :func:`real_dir`) or path.
    main_line : int
        VMTK line index of the main vessel.
    alpha : callable
        Twist profile, radians, of the main line's arc length (e.g. :func:`alpha_profile`).
    remesh : bool
        Remesh scan B isotropically (pymeshlab); otherwise scan B keeps scan A's faces.
    seed : int
        Seed of the rigid motion.
    edge : float, optional
        Remeshing target edge (mm); scan A's median edge by default.

    Returns
    -------
    RealTwistCase
    """
    V, F, lines, info = load_tree(name)
    Pm, Rm = lines[main_line]
    axis = MainAxis(Pm, Rm)
    jns, _, labels = side_junctions(V, F, lines, main_line, axis)
    jns = tuple(replace(j, alpha=float(alpha(j.s))) for j in jns)
    X, blend, rotvec, widths = twist_vertices(V, F, axis, alpha, jns, labels)
    e = median_edge(V, F) if edge is None else float(edge)
    if remesh:
        Xb, Fb = remesh_mesh(X, F, e)
    else:
        Xb, Fb = X.copy(), F.copy()
    rot, t = random_rigid(seed)
    return RealTwistCase(name=Path(name).name, V_a=V, F_a=F, V_b=Xb @ rot.T + t, F_b=Fb, rotation=rot,
                         translation=t, main_line=int(main_line), main_points=Pm, main_s=arc_length(Pm),
                         source=info["source"], target=Pm[-1].copy(), alpha=alpha, junctions=jns,
                         V_twisted=X, labels=labels, blend=blend, axis_s=axis.s, axis_points=axis.c,
                         axis_tangents=axis.T, rotvec=rotvec, blend_widths=widths, remeshed=bool(remesh),
                         edge=e, seed=int(seed))


# --------------------------------------------------------------------------- #
# checks
# --------------------------------------------------------------------------- #
def self_intersecting_faces(V, F):
    """Number of faces pymeshlab selects as self-intersecting."""
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int32)))
    ms.compute_selection_by_self_intersections_per_face()
    return int(ms.current_mesh().selected_face_number())


def check_case(case, self_intersections=True):
    """Check a :class:`RealTwistCase` (construction step 6).

    Returns
    -------
    dict
        ``orientation_kept``: fraction of faces whose twisted normal has a positive dot with scan A's
        normal turned by the face's first vertex's rotation; ``orientation_kept_well_shaped``: the same
        over faces whose smallest angle is at least 5 degrees (``n_slivers`` the others: the real meshes
        have slivers of 0.1-1 degree that any motion may flip); ``orientation_kept_area``: area
        weighted; ``edge_ratio``: (min, max) of twisted over original edge length;
        ``self_intersect_a`` / ``_twisted``: faces
        pymeshlab selects as self-intersecting in scan A and in the twisted mesh; ``axis_moved``: largest
        motion (mm) of a point of the smoothed axis under the main field; ``main_line_moved``: largest
        motion of a VMTK main-line point under the twist (its scatter about the axis turned by alpha),
        also in units of the local radius (``main_line_moved_radii``; ``main_line_moved_radii_p50_p95``
        its median and 95th percentile: VMTK's lines jump by up to half a radius in places); ``side_lines``: per junction, the
        fraction of side line points past the junction zone, turned with the subtree, whose distance to
        the twisted surface is within 10 % of their distance to scan A, and the worst relative change;
        ``blend_jump``: largest |main field - rigid field| (mm) at a subtree's border, with its ratio to
        the blend width.
    """
    V, F, X = case.V_a, case.F_a, case.V_twisted
    nA, nX = face_normals(V, F), face_normals(X, F)
    rv = case.rotvec[F[:, 0]]
    expect = Rotation.from_rotvec(rv).apply(nA)
    dots = np.einsum("ij,ij->i", expect, nX)
    ok = min_angles_deg(V, F) >= 5.0
    area = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    E = _edges(F)
    ratio = np.linalg.norm(X[E[:, 0]] - X[E[:, 1]], axis=1) / np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    out = {"orientation_kept": float(np.mean(dots > 0)), "n_faces": len(F),
           "orientation_kept_well_shaped": float(np.mean(dots[ok] > 0)), "n_slivers": int(np.sum(~ok)),
           "orientation_kept_area": float(np.sum(area[dots > 0]) / np.sum(area)),
           "edge_ratio": (float(ratio.min()), float(ratio.max()))}
    if self_intersections:
        out["self_intersect_a"] = self_intersecting_faces(V, F)
        out["self_intersect_twisted"] = self_intersecting_faces(X, F)
    axis = MainAxis(case.main_points, _main_radius(case))
    c = axis.c
    rv_c = case.alpha(axis.s)[:, None] * axis.T
    out["axis_moved"] = float(np.abs(_rotate_about(c, c, rv_c) - c).max())
    s, cc, T, d = axis.project(case.main_points)
    moved = np.linalg.norm(_rotate_about(case.main_points, cc, case.alpha(s)[:, None] * T) - case.main_points, axis=1)
    out["main_line_moved"] = float(moved.max())
    out["main_line_moved_radii"] = float((moved / axis.R).max())
    out["main_line_moved_radii_p50_p95"] = tuple(float(x) for x in np.percentile(moved / axis.R, [50, 95]))
    _, _, lines, _ = load_tree(case.name)
    sides = []
    for jn in case.junctions:
        rec = {"s": jn.s, "lines": list(jn.lines)}
        fr, worst = [], 0.0
        for j, ex in zip(jn.lines, jn.line_zone_exits):
            P, R = lines[j]
            a = arc_length(P)
            Pp = P[a > ex]
            if len(Pp) == 0:
                continue
            Pp = Pp[:: max(1, len(Pp) // 60)]  # about 60 points a line
            dA = point_mesh_distance(Pp, V, F)
            dB = point_mesh_distance(_rotate_about(Pp, jn.point, jn.alpha * jn.tangent), X, F)
            rel = np.abs(dB - dA) / np.maximum(dA, 1e-12)
            fr.append(rel <= 0.10)
            worst = max(worst, float(rel.max()))
        rec["within_10pct"] = float(np.mean(np.concatenate(fr))) if fr else float("nan")
        rec["worst_rel"] = worst
        sides.append(rec)
    out["side_lines"] = sides
    # jump between the fields at the subtree borders (what the blend spreads)
    jumps = []
    main = case.labels < 0
    for g, jn in enumerate(case.junctions):
        m = ((case.labels[E[:, 0]] == g) & main[E[:, 1]]) | ((case.labels[E[:, 1]] == g) & main[E[:, 0]])
        if not m.any():
            continue
        vi = np.unique(np.where(main[E[m, 0]], E[m, 0], E[m, 1]))
        s, cc, T, _ = axis.project(V[vi])
        fm = _rotate_about(V[vi], cc, case.alpha(s)[:, None] * T)
        fj = _rotate_about(V[vi], jn.point, jn.alpha * jn.tangent)
        jmp = float(np.linalg.norm(fm - fj, axis=1).max())
        jumps.append((jmp, jmp / case.blend_widths[g]))
    out["blend_jump"] = max(jumps) if jumps else (0.0, 0.0)
    return out


def _main_radius(case):
    _, _, lines, _ = load_tree(case.name)
    return lines[case.main_line][1]


# --------------------------------------------------------------------------- #
# CLI
# --------------------------------------------------------------------------- #
def write_case(case, folder, checks=None):
    """Write ``a.ply``, ``b.ply`` and ``truth.json`` into ``folder``; returns the three paths."""
    import vesselgp.io as vio

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    vio.write_mesh(folder / "a.ply", case.V_a, case.F_a)
    vio.write_mesh(folder / "b.ply", case.V_b, case.F_b)
    rec = case.truth()
    if checks is not None:
        rec["checks"] = checks
    (folder / "truth.json").write_text(json.dumps(rec, indent=1, default=_jsonable))
    return folder / "a.ply", folder / "b.ply", folder / "truth.json"


def _jsonable(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    raise TypeError(type(o))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", help="output folder")
    ap.add_argument("--mesh", required=True, help="real mesh file name (shared/data/real) or path")
    ap.add_argument("--main", type=int, required=True, help="VMTK line index of the main vessel")
    ap.add_argument("--profile", choices=("linear", "sine", "step"), default="linear")
    ap.add_argument("--total-deg", type=float, required=True, help="twist amplitude, degrees")
    ap.add_argument("--s0", type=float, default=0.0, help="profile start, mm of main arc length (default 0)")
    ap.add_argument("--s1", type=float, help="profile end, mm (default: the main line's length)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the rigid motion")
    ap.add_argument("--edge", type=float, help="remeshing target edge, mm (default: scan A's median edge)")
    ap.add_argument("--no-remesh", action="store_true", help="scan B keeps scan A's faces")
    ap.add_argument("--no-checks", action="store_true", help="skip check_case")
    args = ap.parse_args(argv)
    _, _, lines, _ = load_tree(args.mesh)
    L = float(arc_length(lines[args.main][0])[-1])
    alpha = alpha_profile(args.profile, args.total_deg, args.s0, L if args.s1 is None else args.s1)
    t0 = time.perf_counter()
    case = twisted_copy(args.mesh, args.main, alpha, remesh=not args.no_remesh, seed=args.seed, edge=args.edge)
    dt = time.perf_counter() - t0
    checks = None if args.no_checks else check_case(case)
    paths = write_case(case, args.out, checks)
    print(f"{case.name}: main line {case.main_line} ({L:.1f} mm), {len(case.junctions)} side junctions, "
          f"{len(case.V_b)} vertices in scan B, built in {dt:.1f} s")
    for j in case.junctions:
        print(f"  s {j.s:7.1f} mm  alpha {np.degrees(j.alpha):7.2f} deg  lines {list(j.lines)}  "
              f"side r {j.side_radius:.2f}  main r {j.main_radius:.2f}  angle {j.angle_deg:5.1f}  "
              f"divides {j.divides}")
    if checks is not None:
        print(f"  orientation kept {checks['orientation_kept']:.4f}, self-intersecting faces "
              f"{checks['self_intersect_a']} -> {checks['self_intersect_twisted']}")
    print("wrote", *paths)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
