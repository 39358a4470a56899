"""Synthetic vessel trees with exact centre lines (issue #13, item 7).

A tree is a set of branches, each a tapered tube about a cubic Bezier centre
line ``B(t)``, ``t`` in [0, 1], with a radius linear in ``t``. The root starts
at the origin along +z; every other branch starts at the end of its parent (the
junction) and leaves it at ``branch_angle_deg`` from the parent's end tangent.
Sibling branches are spread evenly about that tangent and each bifurcation
plane is turned by a quarter turn from its parent's, so the tree is not planar;
every centre line is itself a non-planar space curve.

The surface is the zero set of the implicit function

    f_b(x) = |x - B_b(t*)| - r_b(t*),   t* = argmin_{t in [0, 1]} |x - B_b(t)|,
    f(x) = smin_k(f_(1)(x), f_(2)(x)),

with ``f_(1) <= f_(2)`` the two smallest branch functions and ``smin_k`` the
polynomial smooth minimum of width ``k = blend * radius`` (the plain minimum
for ``blend = 0``, which leaves a crease at the junctions). Where ``t*`` is
inside (0, 1) a surface point is at exactly the radius ``r(t*)`` of its foot
point on the centre line (the quantity a generalized-cylinder fit estimates);
where ``t* = 1`` it is on the sphere of radius ``r(1)`` about the tip: every tip
is a rounded hemisphere. The root is cut open by the plane z = 0 through its
first centre-line point, perpendicular to its first tangent (+z): the evaluation
grid starts at that plane, so marching cubes leaves one clean boundary loop
there, a circle of radius ``r(0)``.

Meshing: the function is evaluated on a narrow band about the surface (one
bounding box per few centre-line samples, exact foot points by Newton steps on
the cubic from the nearest dense sample), triangulated by
:func:`skimage.measure.marching_cubes` (grid values within a tenth of a voxel
of zero are pushed off it first, so there are no sliver triangles), every vertex
is projected onto the exact zero set by Newton steps along the exact gradient
(so away from the junctions ``|x - B(t*)| = r(t*)`` holds to rounding error, not
to the marching-cubes error) and the mesh is checked by
:func:`vesselgp.mesh.clean_mesh`.
The staircase variant keeps the voxels (occupancy of the voxel centres, made
well-composed so that their boundary is a manifold) and triangulates the
boundary faces of the occupied voxels: every face normal is a coordinate axis.

The truth does not use the library's fitting code: the centre lines, radii,
ends and paths come from the Bezier control points alone.

Examples
--------
>>> tree = synthetic_tree(levels=1, voxel=0.6)
>>> len(tree.truth.branches), [e.kind for e in tree.truth.ends]
(3, ['open', 'rounded', 'rounded'])
>>> d, r, b, t = tree.truth.nearest(tree.truth.paths[0].centers[:3])
>>> bool(np.all(d < 1e-9))
True
"""
from __future__ import annotations

import heapq
import logging
import math
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from scipy.spatial import cKDTree

from . import tolerances as tol
from .errors import InvalidMeshError, OptionError, TreeDependencyError
from .mesh import clean_mesh
from .mesh.topology import MeshTopology
from .rotations import perpendicular, rotate

__all__ = [
    "THREE_TIP_PARENTS",
    "SyntheticTree",
    "TreeBranch",
    "TreeDependencyError",
    "TreeEnd",
    "TreePath",
    "TreeTruth",
    "synthetic_arterial_tree",
    "synthetic_tree",
    "tree_parents",
]

log = logging.getLogger(__name__)

# ---------------------------------------------------------------------------
# Constants (candidates for vesselgp.tolerances)
# ---------------------------------------------------------------------------


#: Unit of every length of a synthetic tree.
TREE_UNITS = "mm"

#: ``parents`` of the standard 3-tip tree: the root splits in two and its first child again.
THREE_TIP_PARENTS = (-1, 0, 0, 1, 1)


# ---------------------------------------------------------------------------
# Cubic Bezier centre lines
# ---------------------------------------------------------------------------


def _coefficients(control):
    """Power-basis coefficients ``a0 + a1 t + a2 t^2 + a3 t^3`` of a cubic Bezier; (4, 3) float64."""
    P0, P1, P2, P3 = control
    return np.array([P0, 3 * (P1 - P0), 3 * (P2 - 2 * P1 + P0), P3 - 3 * P2 + 3 * P1 - P0])


def _eval(a, t, order=0):
    """``B(t)``, ``B'(t)`` or ``B''(t)`` from power coefficients ``a`` (4, 3) at ``t`` (k,); (k, 3)."""
    t = np.asarray(t, dtype=np.float64)[:, None]
    if order == 0:
        return a[0] + t * (a[1] + t * (a[2] + t * a[3]))
    if order == 1:
        return a[1] + t * (2 * a[2] + 3 * t * a[3])
    return 2 * a[2] + 6 * t * a[3]


def _arclength_table(a):
    """Parameters ``t`` (q,) and cumulative arc length (q,) of the cubic (trapezoid rule)."""
    t = np.linspace(0.0, 1.0, tol.TREE_ARCLENGTH_POINTS)
    speed = np.linalg.norm(_eval(a, t, 1), axis=1)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))])
    return t, s


def _bezier(P0, d0, d1, length, rng):
    """Control points (4, 3) of a non-planar cubic from ``P0`` leaving along ``d0`` and
    arriving along ``d1`` (unit vectors), scaled about ``P0`` to arc length ``length``."""
    n = np.cross(d0, d1)
    n = perpendicular(d0) if np.linalg.norm(n) < 1e-9 else n / np.linalg.norm(n)
    eps = tol.TREE_OUT_OF_PLANE * rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 1.0)
    chord = d0 + d1 + eps * n
    chord /= np.linalg.norm(chord)
    ctrl = np.array([np.zeros(3), d0 / 3.0, chord - d1 / 3.0, chord])
    _, s = _arclength_table(_coefficients(ctrl))
    return P0 + ctrl * (length / s[-1])


# ---------------------------------------------------------------------------
# Truth records
# ---------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class TreeBranch:
    """One branch: a tube about a cubic Bezier centre line, radius linear in the parameter
    (times Gaussian bulges, when it has any).

    Attributes
    ----------
    control : (4, 3) float64
        Bezier control points; ``control[0]`` is the start, ``control[3]`` the end.
    radius_start, radius_end : float
        Radius at ``t = 0`` and ``t = 1`` (linear in ``t`` between them).
    parent : int
        Index of the parent branch, -1 for the root.
    junction : (3,) float64
        Where the branch leaves its parent (the parent's end point); the open end's
        centre for the root.
    level : int
        Number of junctions between the root and this branch (0 for the root).
    t : (k,) float64
        Curve parameters of the samples (uniform in arc length).
    centers : (k, 3) float64
        Exact centre-line points ``B(t)``.
    radii : (k,) float64
        Exact radius at each sample.
    s : (k,) float64
        Arc length of each sample from the branch start.
    length : float
        Arc length of the branch.
    bulges : tuple of (t0, width, amplitude)
        Gaussian factors ``1 + amplitude exp(-(t - t0)^2 / (2 width^2))`` multiplying the linear
        radius (a sinus, an aneurysm, a stenosis with a negative amplitude); in the curve parameter.
    """

    control: np.ndarray
    radius_start: float
    radius_end: float
    parent: int
    junction: np.ndarray
    level: int
    t: np.ndarray
    centers: np.ndarray
    radii: np.ndarray
    s: np.ndarray
    length: float
    bulges: tuple = ()

    @cached_property
    def _a(self):
        return _coefficients(self.control)

    @cached_property
    def _seeds(self):
        t = np.linspace(0.0, 1.0, tol.TREE_SEED_SAMPLES)
        return t, cKDTree(_eval(self._a, t))

    def point(self, t):
        """Centre-line points ``B(t)``; ``t`` (k,) -> (k, 3) float64."""
        return _eval(self._a, np.atleast_1d(t))

    def tangent(self, t):
        """Unit tangents ``B'(t) / |B'(t)|``; ``t`` (k,) -> (k, 3) float64."""
        d = _eval(self._a, np.atleast_1d(t), 1)
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    def radius(self, t):
        """Radius at ``t`` (k,) -> (k,) float64."""
        t = np.asarray(t, dtype=np.float64)
        return (self.radius_start + (self.radius_end - self.radius_start) * t) * self._bulge(t)[0]

    def _bulge(self, t):
        """The bulges' factor at ``t`` and its derivative in ``t``."""
        g, dg = np.ones_like(t), np.zeros_like(t)
        for t0, w, a in self.bulges:
            e = a * np.exp(-0.5 * ((t - t0) / w) ** 2)
            g, dg = g + e, dg - e * (t - t0) / (w * w)
        return g, dg

    def radius_slope(self, t):
        """``dr / dt`` at ``t`` (k,) -> (k,) float64."""
        t = np.asarray(t, dtype=np.float64)
        g, dg = self._bulge(t)
        lin = self.radius_start + (self.radius_end - self.radius_start) * t
        return (self.radius_end - self.radius_start) * g + lin * dg

    def foot(self, X, t=None):
        """Nearest centre-line point of each query point (exact, Newton on the cubic).

        Parameters
        ----------
        X : (n, 3) float64
        t : (n,) float64, optional
            Start parameters close to the answer (default: the nearest dense sample).

        Returns
        -------
        t : (n,) float64
            Parameter of the nearest point, in [0, 1].
        distance : (n,) float64
            ``|X - B(t)|``.
        """
        if t is not None:
            return self._newton(X, np.asarray(t, dtype=np.float64), tol.TREE_FOOT_WARM_STEPS)
        ts, tree = self._seeds
        d0, i = tree.query(X)
        t, d = self._newton(X, ts[i], tol.TREE_FOOT_NEWTON_STEPS)
        worse = d > d0  # never worse than the best dense sample (far queries)
        t[worse], d[worse] = ts[i[worse]], d0[worse]
        return t, d

    def _newton(self, X, t, steps):
        """Newton steps on ``g(t) = (B(t) - x) . B'(t) = 0`` from ``t``, clamped to [0, 1]."""
        a = self._a
        for _ in range(steps):
            D = _eval(a, t) - X
            d1, d2 = _eval(a, t, 1), _eval(a, t, 2)
            g = np.einsum("ij,ij->i", D, d1)
            s2 = np.einsum("ij,ij->i", d1, d1)
            dg = s2 + np.einsum("ij,ij->i", D, d2)
            dg = np.where(dg > 0, dg, s2)  # beyond the centre of curvature: a gradient step
            t = np.clip(t - g / dg, 0.0, 1.0)
        return t, np.linalg.norm(X - _eval(a, t), axis=1)

    def _band_field(self, X, band):
        """The branch function clipped to [-band, band]; exact where |f| < band.

        Points whose nearest dense sample already puts them farther than ``band``
        (plus the seed error) from the surface skip the Newton steps.
        """
        ts, tree = self._seeds
        d0, i = tree.query(X)
        f = d0 - self.radius(ts[i])
        near = np.abs(f) < band + self._seed_error
        t, d = self._newton(X[near], ts[i[near]], tol.TREE_FOOT_NEWTON_STEPS)
        f[near] = d - self.radius(t)
        return np.clip(f, -band, band)

    @cached_property
    def _seed_error(self):
        """Bound on ``|f(seed) - f|`` from the nearest dense sample: twice the largest seed gap
        plus a hundredth of the radius (the radius change across the candidate feet)."""
        ts = self._seeds[0]
        P = _eval(self._a, ts)
        return (2 * float(np.max(np.linalg.norm(np.diff(P, axis=0), axis=1))) + 0.01 * self.radius_start
                + 2 * float(np.max(np.abs(self.radius_slope(ts)))) * (ts[1] - ts[0]))

    def field(self, X, gradient=False, t=None):
        """The branch's implicit function ``|X - B(t*)| - r(t*)`` (and its gradient).

        Parameters
        ----------
        X : (n, 3) float64
        gradient : bool
        t : (n,) float64, optional
            Start parameters of the foot-point search (see :meth:`foot`).

        Returns
        -------
        f : (n,) float64
            Negative inside the tube.
        grad : (n, 3) float64
            Only if ``gradient``.
        """
        f, g, _ = self._field_t(X, t, gradient)
        return (f, g) if gradient else f

    def _field_t(self, X, t, gradient):
        """``(f, grad or None, t*)``; see :meth:`field`."""
        t, d = self.foot(X, t)
        f = d - self.radius(t)
        if not gradient:
            return f, None, t
        a = self._a
        B, d1, d2 = _eval(a, t), _eval(a, t, 1), _eval(a, t, 2)
        n = (X - B) / np.maximum(d, 1e-300)[:, None]
        # dt*/dx = B' / (|B'|^2 + (B - x) . B'') inside (0, 1), zero where t* is clamped
        den = np.einsum("ij,ij->i", d1, d1) + np.einsum("ij,ij->i", B - X, d2)
        inside = (t > 0) & (t < 1)
        dt = np.divide(d1, den[:, None], out=np.zeros_like(d1), where=inside[:, None])
        return f, n - self.radius_slope(t)[:, None] * dt, t


@dataclass(frozen=True)
class TreeEnd:
    """One end of the tree.

    Attributes
    ----------
    kind : {"open", "rounded"}
        The root end is open (a boundary loop in the root plane), every tip rounded
        (a hemisphere of the end radius).
    center : (3,) float64
        End point of the centre line.
    radius : float
        Radius there.
    direction : (3,) float64
        Unit outward direction of the centre line (out of the tree).
    branch : int
        Branch the end belongs to.
    """

    kind: str
    center: np.ndarray
    radius: float
    direction: np.ndarray
    branch: int


@dataclass(frozen=True, eq=False)
class TreePath:
    """The centre line from the root's open end to one tip.

    Attributes
    ----------
    tip : int
        Index of the tip in :attr:`TreeTruth.ends`.
    branches : tuple of int
        Branches from the root to the tip.
    centers : (k, 3) float64
        Concatenated branch samples (each junction once).
    radii : (k,) float64
        Radius at each sample (the parent's at a junction).
    s : (k,) float64
        Arc length from the root end.
    branch : (k,) int64
        Branch of each sample.
    """

    tip: int
    branches: tuple
    centers: np.ndarray
    radii: np.ndarray
    s: np.ndarray
    branch: np.ndarray


@dataclass(frozen=True, eq=False)
class TreeTruth:
    """Exact ground truth of a synthetic tree.

    Attributes
    ----------
    branches : tuple of TreeBranch
        Parents come before their children; branch 0 is the root.
    ends : tuple of TreeEnd
        The root's open end first, then one rounded end per leaf branch.
    paths : tuple of TreePath
        One per tip, in the order of :attr:`ends` ``[1:]``.
    blend : float
        Width ``k`` of the smooth union at the junctions, a length (0: plain minimum).
    root_plane : (2, 3) float64
        A point of the plane cutting the root open and its unit normal out of the tree.
    units : str
    """

    branches: tuple
    ends: tuple
    paths: tuple
    blend: float
    root_plane: np.ndarray
    units: str = TREE_UNITS

    @property
    def tips(self):
        """The rounded ends (one per leaf branch)."""
        return tuple(e for e in self.ends if e.kind == "rounded")

    @property
    def junctions(self):
        """Junction points (j, 3) float64 and the parent's end radius there (j,) float64."""
        parents = sorted({b.parent for b in self.branches if b.parent >= 0})
        P = np.array([self.branches[p].control[3] for p in parents]).reshape(-1, 3)
        return P, np.array([self.branches[p].radius_end for p in parents])

    def nearest(self, X):
        """Nearest true centre-line point (over every branch, hence every path) of each point.

        Parameters
        ----------
        X : (n, 3) float64

        Returns
        -------
        distance : (n,) float64
            Exact distance to the nearest centre line.
        radius : (n,) float64
            True radius at that nearest point.
        branch : (n,) int64
            Its branch.
        t : (n,) float64
            Its curve parameter.
        """
        X = np.atleast_2d(np.asarray(X, dtype=np.float64))
        best = np.full(len(X), np.inf)
        t_best, b_best = np.zeros(len(X)), np.zeros(len(X), dtype=np.int64)
        for k, br in enumerate(self.branches):
            t, d = br.foot(X)
            better = d < best
            best[better], t_best[better], b_best[better] = d[better], t[better], k
        r = np.empty(len(X))
        for k, br in enumerate(self.branches):
            m = b_best == k
            r[m] = br.radius(t_best[m])
        return best, r, b_best, t_best

    def field(self, X, gradient=False):
        """The exact implicit function of the tree surface (negative inside); see the module doc.

        Parameters
        ----------
        X : (n, 3) float64
        gradient : bool
            Also return the gradient (n, 3).
        """
        X = np.atleast_2d(np.asarray(X, dtype=np.float64))
        vals = [br.field(X, gradient) for br in self.branches]
        return _union(vals, self.blend, gradient)

    def interior_mask(self, X, junction_radii=tol.TREE_JUNCTION_RADII, tip_radii=tol.TREE_TIP_RADII):
        """Points away from every junction and tip, where the tube is a plain generalized cylinder.

        Parameters
        ----------
        X : (n, 3) float64
        junction_radii : float
            Leave out points closer to a junction than this many parent end radii.
        tip_radii : float
            Leave out points closer to a tip's end centre than this many end radii.

        Returns
        -------
        (n,) bool
        """
        X = np.atleast_2d(np.asarray(X, dtype=np.float64))
        keep = np.ones(len(X), dtype=bool)
        J, R = self.junctions
        for c, r in zip(J, R):
            keep &= np.linalg.norm(X - c, axis=1) > junction_radii * r
        for e in self.tips:
            keep &= np.linalg.norm(X - e.center, axis=1) > tip_radii * e.radius
        return keep

    def to_dict(self):
        """JSON-ready description: branches, ends, paths, units (numpy arrays as lists)."""
        return {
            "units": self.units,
            "blend": self.blend,
            "root_plane": {"point": self.root_plane[0], "normal": self.root_plane[1]},
            "branches": [
                {"parent": b.parent, "level": b.level, "control": b.control,
                 "radius_start": b.radius_start, "radius_end": b.radius_end, "junction": b.junction,
                 "length": b.length, "t": b.t, "centers": b.centers, "radii": b.radii, "s": b.s}
                for b in self.branches
            ],
            "ends": [{"kind": e.kind, "center": e.center, "radius": e.radius,
                      "direction": e.direction, "branch": e.branch} for e in self.ends],
            "paths": [{"tip": p.tip, "branches": list(p.branches), "centers": p.centers,
                       "radii": p.radii, "s": p.s, "branch": p.branch} for p in self.paths],
        }


@dataclass(frozen=True, eq=False)
class SyntheticTree:
    """A synthetic vessel-tree mesh and its exact ground truth.

    Attributes
    ----------
    V : (n, 3) float64
        Vertices.
    F : (m, 3) int64
        Triangles, consistently oriented with outward normals; one boundary loop (the
        root's open end), otherwise closed and edge-manifold.
    truth : TreeTruth
    root_loop : (k,) int64
        Vertex ids of the root's boundary loop, in order.
    voxel : float
        Grid spacing of the triangulation.
    staircase : bool
        The surface is the boundary of voxels (axis-aligned terraces) rather than the
        marching-cubes surface projected onto the exact one.
    seed : int
    """

    V: np.ndarray
    F: np.ndarray
    truth: TreeTruth
    root_loop: np.ndarray
    voxel: float
    staircase: bool
    seed: int


def _smin(a, b, k):
    """Polynomial smooth minimum of ``a <= b`` of width ``k`` and its weight on ``b``."""
    h = np.maximum(k - (b - a), 0.0) / k
    return a - 0.25 * k * h * h, 0.5 * h


def _union(vals, blend, gradient):
    """Smooth minimum of the two smallest branch functions (and gradient) from per-branch results."""
    F = np.stack([v[0] if gradient else v for v in vals])
    order = np.argsort(F, axis=0)[:2] if len(vals) > 1 else np.zeros((1, F.shape[1]), dtype=np.int64)
    cols = np.arange(F.shape[1])
    a = F[order[0], cols]
    if len(vals) == 1 or blend <= 0:
        f, w = a, np.zeros_like(a)
    else:
        f, w = _smin(a, F[order[1], cols], blend)
    if not gradient:
        return f
    G = np.stack([v[1] for v in vals])
    g = (1 - w)[:, None] * G[order[0], cols]
    if len(vals) > 1:
        g += w[:, None] * G[order[1], cols]
    return f, g


# ---------------------------------------------------------------------------
# Layout: parents, control points, radii
# ---------------------------------------------------------------------------


def tree_parents(levels):
    """Parent index of each branch of a full binary tree with ``levels`` bifurcation levels.

    Parameters
    ----------
    levels : int
        0 gives a single tube, 1 a root with two children, 2 four tips, ...

    Returns
    -------
    tuple of int
        ``-1`` for the root, then parents in breadth-first order.

    Examples
    --------
    >>> tree_parents(2)
    (-1, 0, 0, 1, 1, 2, 2)
    """
    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or not 0 <= levels <= 6:
        raise OptionError(f"levels must be an integer in [0, 6], got {levels!r}")
    return tuple((i - 1) // 2 for i in range(2 ** (int(levels) + 1) - 1))


def _check_parents(parents, allowed=(0, 2, 3)):
    """Validated parent list and each branch's children; raise :class:`OptionError`."""
    try:
        parents = tuple(int(p) for p in parents)
    except (TypeError, ValueError):
        raise OptionError("parents must be a sequence of integers (-1 for the root)") from None
    if not parents or parents[0] != -1 or any(not 0 <= p < i for i, p in enumerate(parents) if i):
        raise OptionError(f"parents must start with -1 (the root) and list earlier branches only, got {parents}")
    children = [[] for _ in parents]
    for i, p in enumerate(parents[1:], 1):
        children[p].append(i)
    if any(len(c) not in allowed for c in children):
        counts = ", ".join(map(str, allowed[:-1])) + f" or {allowed[-1]}"
        raise OptionError(f"every branch must have {counts} children, got parents {parents}")
    return parents, children


def _layout(parents, children, p, rng):
    """Control points (b, 4, 3), start/end radii (b, 2) and levels (b,) of every branch.

    ``p`` holds the validated keyword arguments of :func:`synthetic_tree`.
    """
    n = len(parents)
    ctrl, radii, level = np.zeros((n, 4, 3)), np.zeros((n, 2)), np.zeros(n, dtype=np.int64)
    side = np.zeros((n, 3))
    d0 = np.array([0.0, 0.0, 1.0])
    side[0] = rotate(np.array([1.0, 0.0, 0.0]), d0, rng.uniform(0, 2 * math.pi))
    d1 = rotate(d0, np.cross(d0, side[0]), math.radians(tol.TREE_ROOT_BEND_DEG))
    ctrl[0] = _bezier(np.zeros(3), d0, d1, p["length"], rng)
    radii[0] = p["radius"], p["radius"] * p["tube_taper"]
    alpha = math.radians(p["branch_angle_deg"])
    beta = tol.TREE_CHILD_END_FRACTION * alpha
    for b in range(n):
        if not children[b]:
            continue
        E, T = ctrl[b, 3], _unit(ctrl[b, 3] - ctrl[b, 2])
        S = _unit(side[b] - (side[b] @ T) * T)
        W = np.cross(T, S)
        phi0 = rng.uniform(-tol.TREE_PLANE_JITTER, tol.TREE_PLANE_JITTER)
        for j, c in enumerate(children[b]):
            phi = phi0 + 2 * math.pi * j / len(children[b])
            start = math.cos(alpha) * T + math.sin(alpha) * (math.cos(phi) * S + math.sin(phi) * W)
            phe = phi + rng.uniform(-tol.TREE_END_TWIST, tol.TREE_END_TWIST)
            end = math.cos(beta) * T + math.sin(beta) * (math.cos(phe) * S + math.sin(phe) * W)
            level[c] = level[b] + 1
            ctrl[c] = _bezier(E, start, end, p["length"] * p["length_ratio"] ** level[c], rng)
            radii[c] = p["taper"] * radii[b, 1], p["taper"] * radii[b, 1] * p["tube_taper"]
            side[c] = W  # the next bifurcation plane turns by a quarter turn
    return ctrl, radii, level


def _unit(v):
    return v / np.linalg.norm(v)


def _branches(parents, ctrl, radii, level, bulges=None):
    """The :class:`TreeBranch` records: exact samples uniform in arc length (``bulges``: a dict of each
    bulging branch's (t0, width, amplitude) tuples)."""
    out = []
    for b, par in enumerate(parents):
        a = _coefficients(ctrl[b])
        tq, sq = _arclength_table(a)
        s = np.linspace(0.0, sq[-1], tol.TREE_BRANCH_SAMPLES)
        t = np.interp(s, sq, tq)
        t[0], t[-1] = 0.0, 1.0
        r0, r1 = float(radii[b, 0]), float(radii[b, 1])
        br = TreeBranch(control=ctrl[b].copy(), radius_start=r0, radius_end=r1, parent=int(par),
                        junction=ctrl[b, 0].copy(), level=int(level[b]), t=t, centers=_eval(a, t),
                        radii=r0 + (r1 - r0) * t, s=s, length=float(sq[-1]),
                        bulges=tuple(tuple(map(float, q)) for q in (bulges or {}).get(b, ())))
        out.append(replace(br, radii=br.radius(t)) if br.bulges else br)
    return tuple(out)


def _ends_and_paths(branches, children):
    """The root's open end, one rounded end per leaf, and the root-to-tip paths."""
    root = branches[0]
    ends = [TreeEnd("open", root.control[0].copy(), float(root.radius([0.0])[0]), -root.tangent([0.0])[0], 0)]
    paths = []
    for b, br in enumerate(branches):
        if children[b]:
            continue
        ends.append(TreeEnd("rounded", br.control[3].copy(), float(br.radius([1.0])[0]), br.tangent([1.0])[0], b))
        chain = [b]
        while branches[chain[-1]].parent >= 0:
            chain.append(branches[chain[-1]].parent)
        chain = chain[::-1]
        C = [branches[chain[0]].centers] + [branches[k].centers[1:] for k in chain[1:]]
        R = [branches[chain[0]].radii] + [branches[k].radii[1:] for k in chain[1:]]
        lab = [np.full(len(c), k, dtype=np.int64) for c, k in zip(C, chain)]
        C = np.concatenate(C)
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(C, axis=0), axis=1))])
        paths.append(TreePath(tip=len(ends) - 1, branches=tuple(chain), centers=C,
                              radii=np.concatenate(R), s=s, branch=np.concatenate(lab)))
    return tuple(ends), tuple(paths)


def _check_tubes(branches, voxel, band, least, *, thin, bend, plane, at_voxel=False):
    """Raise :class:`OptionError` where a tube is thinner than ``least`` voxels, bends tighter than
    ``tolerances.TREE_MAX_KAPPA_R`` over its radius and the band, or reaches below the root plane; ``thin``,
    ``bend`` and ``plane`` name the remedy each message suggests."""
    rmin = min(float(b.radii.min()) for b in branches)
    if rmin < least * voxel:
        raise OptionError(f"the thinnest tube (radius {rmin:.3g}) is under {least:g} voxels; "
                          f"use a voxel below {rmin / least:.3g} or {thin}")
    for k, b in enumerate(branches):
        d1, d2 = _eval(b._a, b.t, 1), _eval(b._a, b.t, 2)
        kappa = np.linalg.norm(np.cross(d1, d2), axis=1) / np.linalg.norm(d1, axis=1) ** 3
        if np.max(kappa * (b.radii + band)) > tol.TREE_MAX_KAPPA_R:
            where = f" at voxel {voxel:.3g}" if at_voxel else ""
            raise OptionError(f"branch {k} bends too sharply for its radius{where}; use {bend}")
        low = b.centers[:, 2] - b.radii
        if k == 0:
            low = low[b.s > 2 * b.radius_start + tol.TREE_ROOT_PLANE_MARGIN * voxel]
        if np.any(low < tol.TREE_ROOT_PLANE_MARGIN * voxel):
            raise OptionError(f"branch {k} reaches below the root plane z = 0; use {plane}")


def _check_layout(branches, voxel, band, blend, min_radius_voxels=None):
    """Raise :class:`OptionError` if the tubes would not make a clean tree surface.

    Tubes must be at least 2.5 voxels thick, bend gently (unique foot points within the
    band), stay above the root plane and keep apart by more than the blend width away
    from the junctions (so the surface there is the single tube's, exactly).
    """
    least = tol.TREE_MIN_RADIUS_VOXELS if min_radius_voxels is None else float(min_radius_voxels)
    _check_tubes(branches, voxel, band, least, thin="fewer levels", bend="a longer length or a smaller radius",
                 plane="a smaller branch_angle_deg or another seed")
    for i in range(len(branches)):
        for j in range(i):
            _check_clearance(branches, i, j, blend)


def _check_clearance(branches, i, j, blend):
    """Tubes ``i`` and ``j`` keep apart (by the clearance plus the blend width) away from a
    junction they share."""
    A, B = branches[i], branches[j]
    keep_a, keep_b = np.ones(len(A.t), bool), np.ones(len(B.t), bool)
    for P, r in ((A.junction, branches[A.parent].radius_end if A.parent >= 0 else 0.0),
                 (B.junction, branches[B.parent].radius_end if B.parent >= 0 else 0.0)):
        if min(np.min(np.linalg.norm(A.centers - P, axis=1)), np.min(np.linalg.norm(B.centers - P, axis=1))) > 1e-9:
            continue  # not a junction of both
        keep_a &= np.linalg.norm(A.centers - P, axis=1) > tol.TREE_JUNCTION_RADII * r
        keep_b &= np.linalg.norm(B.centers - P, axis=1) > tol.TREE_JUNCTION_RADII * r
    if not keep_a.any() or not keep_b.any():
        return
    d, idx = cKDTree(B.centers[keep_b]).query(A.centers[keep_a])
    gap = d - A.radii[keep_a] - B.radii[keep_b][idx]
    if np.min(gap) < tol.TREE_CLEARANCE * min(A.radius_end, B.radius_end) + blend:
        raise OptionError(f"branches {i} and {j} collide; use another seed, a larger branch_angle_deg "
                          "or a smaller radius")


# ---------------------------------------------------------------------------
# The implicit function on a grid
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class _Grid:
    """Grid points ``origin + voxel * index``, index in ``[0, shape)``; z of the first layer is 0."""

    origin: np.ndarray
    voxel: float
    shape: tuple

    def points(self, lin):
        return self.origin + self.voxel * np.stack(np.unravel_index(lin, self.shape), axis=1)


def _grid(branches, voxel, pad, centred):
    """The grid covering every tube plus ``pad``; its first z layer is the root plane
    (grid points there, or voxel faces there if ``centred``: points at voxel centres)."""
    lo = np.min([np.min(b.centers - b.radii[:, None], axis=0) for b in branches], axis=0) - pad
    hi = np.max([np.max(b.centers + b.radii[:, None], axis=0) for b in branches], axis=0) + pad
    lo = np.floor(lo / voxel) * voxel
    lo[2] = 0.5 * voxel if centred else 0.0
    shape = tuple(int(k) for k in np.ceil((hi - lo) / voxel).astype(np.int64) + 1)
    return _Grid(lo, float(voxel), shape)


def _band_indices(branch, grid, band):
    """Linear grid indices within ``band`` of the tube (one box per few dense samples)."""
    ts = np.linspace(0.0, 1.0, tol.TREE_SEED_SAMPLES)
    P, R = branch.point(ts), branch.radius(ts)
    shape = np.array(grid.shape)
    out = []
    for k in range(0, len(ts) - 1, tol.TREE_CHUNK_SAMPLES):
        sl = slice(k, k + tol.TREE_CHUNK_SAMPLES + 1)
        pad = R[sl].max() + band
        i0 = np.maximum(np.floor((P[sl].min(0) - pad - grid.origin) / grid.voxel), 0).astype(np.int64)
        i1 = np.minimum(np.ceil((P[sl].max(0) + pad - grid.origin) / grid.voxel), shape - 1).astype(np.int64)
        if np.any(i1 < i0):
            continue
        g = np.mgrid[i0[0]:i1[0] + 1, i0[1]:i1[1] + 1, i0[2]:i1[2] + 1].reshape(3, -1)
        out.append(np.ravel_multi_index(g, grid.shape))
    mark = np.zeros(int(np.prod(grid.shape)), dtype=bool)  # dedupe: faster than np.unique
    for idx in out:
        mark[idx] = True
    return np.flatnonzero(mark)


def _grid_field(truth, grid, band):
    """The implicit function on the grid, clipped to [-band, band]: (nx, ny, nz) float32.

    Each branch's function is exact where it is within ``band`` of zero (grid points
    in its bounding boxes, Newton steps only near its surface); the union (plain or
    smooth minimum of the two smallest) is then exact where ``|f| < band - blend``.
    """
    size = int(np.prod(grid.shape))
    f1 = np.full(size, band, dtype=np.float32)
    f2 = np.full(size, band, dtype=np.float32)
    touched = []
    for br in truth.branches:
        idx = _band_indices(br, grid, band)
        fb = br._band_field(grid.points(idx), band).astype(np.float32)
        a, b = f1[idx], f2[idx]
        f1[idx] = np.minimum(a, fb)
        f2[idx] = np.minimum(np.maximum(a, fb), b)
        touched.append(idx)
    if truth.blend > 0:
        mark = np.zeros(size, dtype=bool)
        for idx in touched:
            mark[idx] = True
        idx = np.flatnonzero(mark)
        f1[idx] = _smin(f1[idx].astype(np.float64), f2[idx].astype(np.float64), truth.blend)[0]
    return f1.reshape(grid.shape)


# ---------------------------------------------------------------------------
# Surfaces: marching cubes (projected) and voxel staircase
# ---------------------------------------------------------------------------


def _skimage_marching_cubes():
    """:func:`skimage.measure.marching_cubes`, or raise :class:`TreeDependencyError`."""
    try:
        from skimage.measure import marching_cubes
    except ImportError:
        raise TreeDependencyError("smooth synthetic trees need scikit-image; install vesselgp[trees] "
                                  "(or pass staircase=True)") from None
    return marching_cubes


def _marching_cubes(field, grid):
    """Marching cubes of the zero set; outward-oriented faces (field negative inside)."""
    V, F, _, _ = _skimage_marching_cubes()(field, level=0.0, spacing=(grid.voxel,) * 3,
                                gradient_direction="ascent", allow_degenerate=False)
    return V.astype(np.float64) + grid.origin, np.ascontiguousarray(F, dtype=np.int64)


def _project(truth, V, fixed_z):
    """Newton steps ``x -= f grad f / |grad f|^2`` onto the exact zero set.

    The union is formed from the two branches whose functions are smallest at the
    start (the vertices move by a fraction of a voxel); ``fixed_z`` vertices (the root
    loop) stay in the root plane.
    """
    X = V.copy()
    F = np.stack([br.foot(X) for br in truth.branches])  # (b, 2, n): t and distance
    fb = F[:, 1] - np.stack([br.radius(F[k, 0]) for k, br in enumerate(truth.branches)])
    pair = np.argsort(fb, axis=0)[:2]  # (<=2, n) branch ids
    cols = np.arange(X.shape[0])
    T = F[pair, 0, cols]
    for _ in range(tol.TREE_PROJECTION_STEPS):
        vals = []
        for j in range(len(pair)):
            f, g = np.empty(len(X)), np.empty_like(X)
            for k, br in enumerate(truth.branches):
                m = pair[j] == k
                if m.any():
                    f[m], g[m], T[j, m] = br._field_t(X[m], T[j, m], True)
            vals.append((f, g))
        f, g = _union(vals, truth.blend, True)
        X -= (f / np.maximum(np.einsum("ij,ij->i", g, g), 1e-12))[:, None] * g
        X[fixed_z, 2] = 0.0
    return X


def _well_composed(occ):
    """Add voxels until no two occupied (or empty) voxels meet at an edge or a corner only.

    The boundary of a well-composed voxel set is a 2-manifold. Voxels are added on the
    side away from the root plane; the layer below z = 0 repeats the first one (the tube
    goes on through the cut).
    """
    P = np.pad(occ, 1)
    for _ in range(tol.TREE_WELL_COMPOSED_ROUNDS):
        P[:, :, 0] = P[:, :, 1]
        bad = 0
        for a, b in ((0, 1), (0, 2), (1, 2)):
            c = [[P[_cell(a, da, b, db)] for db in (0, 1)] for da in (0, 1)]
            e1 = c[0][0] & c[1][1] & ~c[0][1] & ~c[1][0]
            e2 = c[0][1] & c[1][0] & ~c[0][0] & ~c[1][1]
            c[0][1] |= e1  # views into P: the fix lands in P; b = 2 adds the upper voxel
            c[1][1] |= e2
            bad += int(e1.sum() + e2.sum())
        corners = {k: P[k[0]:P.shape[0] - 1 + k[0], k[1]:P.shape[1] - 1 + k[1], k[2]:P.shape[2] - 1 + k[2]]
                   for k in np.ndindex(2, 2, 2)}
        count = sum(v.astype(np.int8) for v in corners.values())
        for lo, hi in (((0, 0, 0), (1, 1, 1)), ((1, 0, 0), (0, 1, 1)), ((0, 1, 0), (1, 0, 1)), ((1, 1, 0), (0, 0, 1))):
            pair2 = (count == 2) & corners[lo] & corners[hi]
            pair6 = (count == 6) & ~corners[lo] & ~corners[hi]
            corners[(lo[0], lo[1], 1)] |= pair2  # a voxel above the lower one joins the pair
            corners[hi] |= pair6
            bad += int(pair2.sum() + pair6.sum())
        if bad == 0:
            return P[1:-1, 1:-1, 1:-1]
    raise InvalidMeshError("the voxel occupancy could not be made well-composed; use another voxel size")


def _cell(a, da, b, db):
    """Slices of the 2x2 block corner (da along axis a, db along axis b) of a padded grid."""
    sl = [slice(None)] * 3
    sl[a] = slice(da, None if da else -1)
    sl[b] = slice(db, None if db else -1)
    return tuple(sl)


def _voxel_faces(occ, grid):
    """Triangulated boundary of the occupied voxels, outward, open at the root plane z = 0.

    Voxel ``(i, j, k)`` spans ``corner + voxel * [i, i + 1] x ...`` with
    ``corner = grid.origin - voxel / 2`` (grid points are the voxel centres).
    """
    P = np.pad(occ, 1)
    P[:, :, 0] = P[:, :, 1]  # no faces on the root plane: it stays open
    quads = []
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        sl_lo, sl_hi = [slice(None)] * 3, [slice(None)] * 3
        sl_lo[a], sl_hi[a] = slice(None, -1), slice(1, None)
        D = P[tuple(sl_hi)].astype(np.int8) - P[tuple(sl_lo)].astype(np.int8)
        for sign in (-1, 1):  # -1: occupied below along a, outward normal +a
            idx = np.argwhere(D == sign)  # padded indices; face at lattice a = idx[a]
            if a != 2:
                idx = idx[idx[:, 2] >= 1]  # the padded layer below the root plane has no faces
            base = idx.copy()
            base[:, b] -= 1
            base[:, c] -= 1
            corner = np.zeros((4, 3), dtype=np.int64)
            corner[[1, 2], b] = 1
            corner[[2, 3], c] = 1
            Q = base[:, None, :] + corner[None]
            quads.append(Q if sign == -1 else Q[:, ::-1])
    Q = np.concatenate(quads).reshape(-1, 3)
    lat = np.array(occ.shape) + 1
    ids, inv = np.unique(np.ravel_multi_index(Q.T, lat), return_inverse=True)
    V = grid.origin - 0.5 * grid.voxel + grid.voxel * np.stack(np.unravel_index(ids, lat), axis=1)
    q = inv.reshape(-1, 4)
    F = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    return V.astype(np.float64), F.astype(np.int64)


def _surface(truth, grid, band, staircase):
    """Triangulated tree surface and its root-plane vertices (before cleaning)."""
    field = _grid_field(truth, grid, band)
    if staircase:
        V, F = _voxel_faces(_well_composed(field < 0), grid)
        return V, F
    # values near zero pushed off it: no crossing lands within tol.TREE_MC_SNAP voxels of a grid point,
    # which would give sliver triangles (the projection restores the exact surface)
    snap = np.float32(tol.TREE_MC_SNAP * grid.voxel)
    near = np.abs(field) < snap
    field[near] = np.where(field[near] < 0, -snap, snap)
    V, F = _marching_cubes(field, grid)
    return _project(truth, V, V[:, 2] == 0.0), F


def _finish(V, F, truth):
    """Clean, orient outward and check: one component, edge-manifold, one boundary loop
    (the root's, in the plane z = 0), a disc topologically (Euler characteristic 1)."""
    V, F, _ = clean_mesh(V, F)
    topo = MeshTopology(F, len(V))
    loops = topo.boundary_loops if topo.is_edge_manifold and topo.is_coherent else ()
    ok = (topo.is_edge_manifold and topo.is_coherent and len(loops) == 1
          and topo.euler_characteristic == 1 and topo.vertex_components[0] == 1)
    if not ok or np.max(np.abs(V[loops[0], 2])) > 1e-9 * truth.branches[0].radius_start:
        raise InvalidMeshError(f"synthetic tree mesh is broken ({len(loops)} boundary loops, "
                               f"Euler characteristic {topo.euler_characteristic}); use a smaller voxel")
    if _closed_volume(V, F, loops[0]) < 0:  # outward: positive volume once the root is capped
        F = F[:, [0, 2, 1]]
        loops = (np.roll(loops[0][::-1], 1),)
    return V, np.ascontiguousarray(F), np.asarray(loops[0], dtype=np.int64)


def _closed_volume(V, F, loop):
    """Signed volume of the mesh closed by a fan from the root loop's centroid to the loop."""
    c = V[loop].mean(axis=0)
    cap = np.c_[np.roll(loop, -1), loop, np.full(len(loop), len(V))]  # loop follows the faces: reversed
    W = np.vstack([V, c])
    T = np.vstack([F, cap])
    a, b, d = W[T[:, 0]], W[T[:, 1]], W[T[:, 2]]
    return float(np.sum(np.einsum("ij,ij->i", a, np.cross(b, d))) / 6.0)


def synthetic_tree(levels=2, *, parents=None, radius=3.0, taper=0.8, tube_taper=0.9,
                   branch_angle_deg=40.0, length=40.0, length_ratio=0.8, voxel=0.4, blend=0.25,
                   seed=0, staircase=False, target_vertices=None, min_radius_voxels=None):
    """A vessel tree: union of tapered tubes about exact Bezier centre lines, root cut open.

    Parameters
    ----------
    levels : int
        Bifurcation levels of a full binary tree (ignored if ``parents`` is given): 0 is one
        tube, 1 gives 2 tips, 2 gives 4 tips (the standard configuration), 3 gives 8.
    parents : sequence of int, optional
        Parent of each branch, -1 first (the root); each branch has 0, 2 or 3 children.
        ``(-1, 0, 0, 1, 1)`` is a 3-tip tree (one child splits again).
    radius : float
        Radius of the root at its open end (mm).
    taper : float
        Child start radius / parent end radius (0.79 is Murray's law for two equal children).
    tube_taper : float
        End radius / start radius within each branch (linear in the curve parameter).
    branch_angle_deg : float
        Angle between a child's start tangent and its parent's end tangent.
    length : float
        Arc length of the root; a branch at level ``l`` has ``length * length_ratio**l``.
    length_ratio : float
    voxel : float
        Grid spacing (mm); ignored if ``target_vertices`` is given.
    blend : float
        Width of the smooth union at the junctions, in root radii (0: plain minimum, a crease).
    seed : int
        Seeds the random bends, plane turns and out-of-plane offsets.
    staircase : bool
        Return the voxel boundary (axis-aligned terraces) instead of the smooth surface.
    target_vertices : int, optional
        Choose the voxel so the mesh has about this many vertices (within ~10 %).
    min_radius_voxels : float, optional
        The thinnest tube allowed, in voxels (default ``tolerances.TREE_MIN_RADIUS_VOXELS``, 2.5; a vein
        tree's tips a few voxels across, as segmentations make them, need less).

    Returns
    -------
    SyntheticTree

    Raises
    ------
    OptionError
        A parameter out of range, tubes that collide, bend too sharply, reach below the root
        plane or are thinner than ``min_radius_voxels``.
    TreeDependencyError
        scikit-image is missing (``pip install vesselgp[trees]``); the staircase variant
        does not need it.
    InvalidMeshError
        The triangulation is not a clean tree surface (use a smaller voxel).

    Examples
    --------
    >>> tree = synthetic_tree(parents=(-1, 0, 0, 1, 1), voxel=0.5)
    >>> len(tree.truth.tips), [path.branches for path in tree.truth.paths]
    (3, [(0, 2), (0, 1, 3), (0, 1, 4)])
    """
    if not staircase:
        _skimage_marching_cubes()  # fail before any work
    parents, children = _check_parents(tree_parents(levels) if parents is None else parents)
    p = _check_options(radius=radius, taper=taper, tube_taper=tube_taper, branch_angle_deg=branch_angle_deg,
                       length=length, length_ratio=length_ratio, voxel=voxel, blend=blend)
    rng = np.random.default_rng(seed)
    ctrl, radii, level = _layout(parents, children, p, rng)
    return tree_surface(parents, ctrl, radii, voxel=p["voxel"], blend=p["blend"] * p["radius"],
                        target_vertices=target_vertices, staircase=staircase, seed=seed,
                        min_radius_voxels=min_radius_voxels)


def tree_surface(parents, control, radii, *, voxel, blend, target_vertices=None, staircase=False, seed=0,
                 bulges=None, min_radius_voxels=None):
    """The tree surface of given Bezier branches (the meshing of :func:`synthetic_tree`).

    Parameters
    ----------
    parents : sequence of int
        Parent of each branch, -1 first; parents come before their children, and a child
        starts at its parent's end point. A branch may have one child (a chain of tubes).
    control : (b, 4, 3) float64
        Bezier control points of each branch; the root starts at the origin along +z
        (the root plane z = 0 cuts it open).
    radii : (b, 2) float64
        Start and end radius of each branch (linear in the curve parameter).
    voxel : float
    blend : float
        Width of the smooth union, a length.
    target_vertices : int, optional
    staircase : bool
    seed : int
        Recorded in the result.
    bulges : dict of int to sequence of (t0, width, amplitude), optional
        Gaussian bulges of a branch's radius (:class:`TreeBranch`), by branch index.
    min_radius_voxels : float, optional
        As for :func:`synthetic_tree`.

    Returns
    -------
    SyntheticTree
    """
    parents, children = _check_parents(parents, allowed=(0, 1, 2, 3))
    control, radii = np.asarray(control, np.float64), np.asarray(radii, np.float64)
    level = np.zeros(len(parents), np.int64)
    for b, par in enumerate(parents):
        level[b] = 0 if par < 0 else level[par] + 1
    branches = _branches(parents, control, radii, level, bulges)
    ends, paths = _ends_and_paths(branches, children)
    truth = TreeTruth(branches=branches, ends=ends, paths=paths, blend=float(blend),
                      root_plane=np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -1.0]]))
    h = float(voxel) if target_vertices is None else _voxel_for(branches, target_vertices)
    band = tol.TREE_BAND_VOXELS * h + truth.blend
    _check_layout(branches, h, band, truth.blend, min_radius_voxels)
    grid = _grid(branches, h, band + h, centred=staircase)
    V, F = _surface(truth, grid, band, staircase)
    V, F, loop = _finish(V, F, truth)
    log.debug("synthetic_tree: %d branches, voxel %.3g, grid %s, %d vertices", len(branches), h, grid.shape, len(V))
    return SyntheticTree(V=V, F=F, truth=truth, root_loop=loop, voxel=h, staircase=bool(staircase), seed=int(seed))


def _check_options(**p):
    """Floats of the size options, validated (raise :class:`OptionError`)."""
    try:
        p = {k: float(v) for k, v in p.items()}
    except (TypeError, ValueError):
        raise OptionError("tree sizes and angles must be numbers") from None
    if not all(np.isfinite(v) for v in p.values()):
        raise OptionError(f"tree options must be finite, got {p}")
    for k in ("radius", "length", "voxel"):
        if not p[k] > 0:
            raise OptionError(f"{k} must be positive, got {p[k]}")
    for k in ("taper", "tube_taper", "length_ratio"):
        if not 0 < p[k] <= 1:
            raise OptionError(f"{k} must be in (0, 1], got {p[k]}")
    if not 0 < p["branch_angle_deg"] < 90:
        raise OptionError(f"branch_angle_deg must be in (0, 90), got {p['branch_angle_deg']}")
    if not 0 <= p["blend"] <= 1:
        raise OptionError(f"blend must be in [0, 1] root radii, got {p['blend']}")
    return p


def _voxel_for(branches, target_vertices):
    """Voxel giving about ``target_vertices`` vertices (tube area / density).

    The staircase has the same density: its vertices are dual to the grid edges that the
    surface crosses, as the marching-cubes vertices are.
    """
    try:
        n = int(target_vertices)
    except (TypeError, ValueError):
        raise OptionError(f"target_vertices must be an integer, got {target_vertices!r}") from None
    if n < 500:
        raise OptionError(f"target_vertices must be at least 500, got {n}")
    area = sum(math.pi * (b.radius_start + b.radius_end) * b.length for b in branches)
    return math.sqrt(tol.TREE_MC_VERTEX_DENSITY * area / n)


# ---------------------------------------------------------------------------
# Large arterial trees (issue #47): many tips, laid out without collisions,
# meshed on a narrow band of grid blocks
# ---------------------------------------------------------------------------

#: Leaf start radius / tip radius: the taper along a terminal branch.
_ART_LEAF_TAPER = 1.25
#: Lengths of a vessel between junctions and of a leaf, as factors of ``spacing`` and ``leaf_length`` (uniform).
_ART_LENGTH_SPREAD = (0.6, 1.4)
#: The root (an internal carotid) is this many times longer than the other vessels that branch, and bends less.
_ART_ROOT_LENGTH = 2.0
_ART_ROOT_BEND_DEG = 20.0
#: Largest angle between a vessel's start and end tangents, degrees (doubled by the last round of candidates).
_ART_BEND_DEG = 35.0
#: Angle between the two children at a junction, degrees (uniform); the wider child turns less.
_ART_SPLIT_DEG = (60.0, 100.0)
#: Share of a vessel's tips that its side branch takes (uniform; at least one, at most half).
_ART_SIDE_SHARE = (0.08, 0.45)
#: Spacing of the layout's centre-line samples (mm).
_ART_LAYOUT_STEP = 0.4
#: Added to the gaps the layout requires (mm): samples a step apart on tubes a millimetre apart find
#: their gap a few hundredths of a millimetre too wide.
_ART_GAP_MARGIN = 0.1
#: Every vessel but the root's first stretch keeps this far above the root plane z = 0 (mm, plus its radius).
_ART_FLOOR = 3.0
#: Candidate placements of a junction's two children: rounds of this many, each with shorter children,
#: wider angles and less free space required than the last.
_ART_CANDIDATES = 48
_ART_ROUNDS = 6
_ART_SHRINK = 0.8
#: Valid candidates compared per junction: the one farthest from the other vessels is kept.
_ART_CHOICES = 8
#: Gaps beyond this many ``min_gap`` count the same when comparing candidates.
_ART_GAP_CAP = 4.0
#: Free space required about the end of a vessel that branches again, in ``spacing`` (relaxed by rounds).
_ART_ROOM = 0.5
#: Largest curvature x (radius + 1.5 tip radii + blend) of a laid-out centre line (TREE_MAX_KAPPA_R holds
#: with a margin at any voxel down to the thinnest tube over ``min_radius_voxels``).
_ART_MAX_KAPPA_R = 0.5
#: Grid points per block edge of the narrow-band marching cubes (at most 31: indices within a block are int16).
_ART_BLOCK = 16
#: Extra Newton steps onto the exact surface for the vertices not yet on it (at junctions).
_ART_EXTRA_STEPS = 8
#: A vertex is on the exact surface when its function is below this times the voxel.
_ART_ON_SURFACE = 1e-12
#: The most tips :func:`synthetic_arterial_tree` lays out.
_ART_MAX_TIPS = 1024


def synthetic_arterial_tree(n_tips=79, *, root_radius=1.8, tip_radius=0.35, spacing=12.0, leaf_length=55.0,
                            min_gap=1.0, voxel=0.25, target_vertices=None, blend=None, seed=0,
                            min_radius_voxels=1.2):
    """A large arterial tree, made the way segmentations of whole arterial trees look.

    A root (cut open by the plane z = 0, leaving it along +z) feeds ``n_tips`` rounded tips through a
    binary tree of tapered tubes about exact Bezier centre lines, as :func:`synthetic_tree` makes them;
    unlike its full binary tree (which collides beyond a few levels), the branches grow through space
    like arteries: at every junction the wider child carries on (a trunk) and the other leaves it,
    mostly 60-100 degrees between them (a side branch, which branches again), directions spread over
    all sides, long thin terminal branches. Each junction's two children are drawn at random, checked
    against every vessel placed before them (a gap of ``min_gap`` away from their junction, the
    mesher's clearance near it, above the root plane, with free space where they branch again) and
    the candidate farthest from the other vessels is kept.

    Radii: a vessel feeding ``n`` tips starts at ``R(n) = 1.25 tip_radius n^(1 / gamma)`` (``gamma`` such
    that ``R(n_tips) = root_radius``: about Murray's 3 for the defaults) and tapers linearly to the
    start radius of its wider child; a leaf tapers from ``1.25 tip_radius`` to ``tip_radius``. So
    radii fall monotonically from the root to the tips along every path.

    Meshing: the tree's function (:class:`TreeTruth`) is evaluated only on the grid points within a
    band of the tubes (found per piece of centre line about as long as the tube is wide, exact foot
    points by Newton steps; points deeper inside only need their sign), stored on the 16^3-point
    blocks they touch; marching cubes runs block by block and the blocks' vertices are merged by the
    grid edge they lie on, so the mesh is the one marching cubes gives on the whole grid, without
    the grid. Every vertex is projected onto the exact surface as in :func:`synthetic_tree`.

    Parameters
    ----------
    n_tips : int
        Rounded tips (the tree has ``n_tips + 1`` ends with the open root), 1 to 1024.
    root_radius : float
        Radius of the root at its open end (mm), above 1.25 ``tip_radius`` (or at least ``tip_radius``
        for one tip).
    tip_radius : float
        Radius of every tip (mm).
    spacing : float
        Mean length of a vessel between two junctions (mm); the root is twice as long.
    leaf_length : float
        Mean length of a terminal branch (mm).
    min_gap : float
        Least gap between the walls of vessels that do not share a junction (mm).
    voxel : float
        Grid spacing (mm); ignored if ``target_vertices`` is given. The same ``seed`` gives the same tree
        at every voxel: about 1, 2, 4, 8 times the vertices at ``voxel``, ``voxel / 2**0.5``,
        ``voxel / 2``, ``voxel / 8**0.5``.
    target_vertices : int, optional
        Choose the voxel so the mesh has about this many vertices.
    blend : float, optional
        Width of the smooth union at the junctions (mm, default half ``tip_radius``; 0: a crease).
    seed : int
        Seeds the layout.
    min_radius_voxels : float
        The thinnest tube allowed, in voxels (1.2: a 0.35 mm tip needs a voxel up to 0.29 mm).

    Returns
    -------
    SyntheticTree
        ``truth.ends`` is the open root then one rounded end per leaf; ``truth.paths`` one root-to-tip
        path per tip; every truth method of :func:`synthetic_tree` applies.

    Raises
    ------
    OptionError
        An option out of range, tubes thinner than ``min_radius_voxels`` or bending too sharply for the
        voxel, or no room to lay the tips out without collisions (use another seed, shorter vessels or
        fewer tips).
    TreeDependencyError
        scikit-image is missing (``pip install vesselgp[trees]``).
    InvalidMeshError
        The triangulation is not a clean tree surface (use a smaller voxel).

    Examples
    --------
    >>> tree = synthetic_arterial_tree(4, root_radius=1.2, tip_radius=0.5, leaf_length=20, spacing=8, voxel=0.4)
    >>> len(tree.truth.tips), len(tree.truth.branches), [e.kind for e in tree.truth.ends][:2]
    (4, 7, ['open', 'rounded'])
    """
    _skimage_marching_cubes()  # fail before any work
    p = _arterial_options(n_tips, root_radius=root_radius, tip_radius=tip_radius, spacing=spacing,
                          leaf_length=leaf_length, min_gap=min_gap, voxel=voxel, blend=blend,
                          min_radius_voxels=min_radius_voxels)
    parents, control, radii = _ArterialLayout(p, np.random.default_rng(seed)).grow()
    parents, children = _check_parents(parents)
    level = np.zeros(len(parents), np.int64)
    for b, par in enumerate(parents):
        level[b] = 0 if par < 0 else level[par] + 1
    branches = _branches(parents, control, radii, level)
    ends, paths = _ends_and_paths(branches, children)
    truth = TreeTruth(branches=branches, ends=ends, paths=paths, blend=p["blend"],
                      root_plane=np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -1.0]]))
    h = p["voxel"] if target_vertices is None else _voxel_for(branches, target_vertices)
    band = tol.TREE_BAND_VOXELS * h + truth.blend
    _check_arterial_layout(branches, h, band, truth.blend, p["min_radius_voxels"])
    origin, shape = _band_grid(branches, h, band)
    V, F, cand = _band_marching_cubes(truth, origin, h, shape, band)
    V = _project_candidates(truth, V, cand, V[:, 2] == 0.0, h)
    V, F, loop = _finish(V, F, truth)
    log.debug("synthetic_arterial_tree: %d tips, %d branches, voxel %.3g, grid %s, %d vertices",
              len(ends) - 1, len(branches), h, shape, len(V))
    return SyntheticTree(V=V, F=F, truth=truth, root_loop=loop, voxel=h, staircase=False, seed=int(seed))


def _arterial_options(n_tips, **p):
    """The validated options of :func:`synthetic_arterial_tree` (raise :class:`OptionError`)."""
    if isinstance(n_tips, bool) or not isinstance(n_tips, (int, np.integer)) or not 1 <= n_tips <= _ART_MAX_TIPS:
        raise OptionError(f"n_tips must be an integer from 1 to {_ART_MAX_TIPS}, got {n_tips!r}")
    if p["blend"] is None:
        p["blend"] = 0.5 * p["tip_radius"] if isinstance(p["tip_radius"], (int, float, np.number)) else None
    try:
        p = {k: float(v) for k, v in p.items()}
    except (TypeError, ValueError):
        raise OptionError("the tree's sizes must be numbers") from None
    if not all(np.isfinite(v) for v in p.values()):
        raise OptionError(f"the tree's sizes must be finite, got {p}")
    for k in ("root_radius", "tip_radius", "spacing", "leaf_length", "min_gap", "voxel", "min_radius_voxels"):
        if not p[k] > 0:
            raise OptionError(f"{k} must be positive, got {p[k]}")
    least = _ART_LEAF_TAPER * p["tip_radius"] if n_tips > 1 else p["tip_radius"]
    if not (p["root_radius"] > least or (n_tips == 1 and p["root_radius"] >= least)):
        raise OptionError(f"root_radius must be above {least:.4g} ({_ART_LEAF_TAPER:g} tip radii: the leaves "
                          f"start there) for {n_tips} tips, got {p['root_radius']}")
    if not 0 <= p["blend"] <= p["tip_radius"]:
        raise OptionError(f"blend must be from 0 to tip_radius ({p['tip_radius']}), got {p['blend']}")
    return {"n_tips": int(n_tips), **p}


def _cross(a, b):
    """Cross products of (..., 3) arrays (numpy's cross is slow on the layout's many small ones)."""
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1], a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def _turn(v, axis, angle):
    """``v`` (3,) turned about the unit ``axis`` by ``angle`` (Rodrigues)."""
    c, s = math.cos(angle), math.sin(angle)
    return v * c + _cross(axis, v) * s + axis * (axis @ v) * (1 - c)


def _arterial_bezier(P0, d0, d1, length, rng):
    """Control points (4, 3) of a non-planar cubic from ``P0`` leaving along ``d0`` and arriving along ``d1``,
    about ``length`` long (the construction of :func:`_bezier` with a coarser length: the layout draws many)."""
    n = _cross(d0, d1)
    nn = float(np.linalg.norm(n))
    n = perpendicular(d0) if nn < 1e-9 else n / nn
    eps = tol.TREE_OUT_OF_PLANE * rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 1.0)
    chord = d0 + d1 + eps * n
    chord /= np.linalg.norm(chord)
    ctrl = np.array([np.zeros(3), d0 / 3.0, chord - d1 / 3.0, chord])
    P = _eval(_coefficients(ctrl), np.linspace(0.0, 1.0, 65))
    return P0 + ctrl * (length / float(np.sum(np.linalg.norm(np.diff(P, axis=0), axis=1))))


class _ArterialLayout:
    """The control points and radii of :func:`synthetic_arterial_tree`, grown one junction at a time.

    Every placed vessel keeps samples of its centre line (``pts``), their radii, their branch and the
    branch's end radius, in one k-d tree the candidates are checked against.
    """

    def __init__(self, p, rng):
        self.p, self.rng = p, rng
        r0 = _ART_LEAF_TAPER * p["tip_radius"]
        n = p["n_tips"]
        self.gamma = math.log(n) / math.log(p["root_radius"] / r0) if n > 1 else 1.0
        self.parents, self.ctrl, self.radii, self.tips, self.split = [], [], [], [], []
        self.pts, self.rad = np.zeros((0, 3)), np.zeros(0)
        self.lab, self.rend = np.zeros(0, np.int64), np.zeros(0)
        self.tree = None
        self.bend = _ART_BEND_DEG

    def R(self, n):
        """Start radius of a vessel feeding ``n`` tips."""
        return _ART_LEAF_TAPER * self.p["tip_radius"] * float(n) ** (1.0 / self.gamma)

    def _split(self, n):
        """Tips of the wider (continuing) and the side child of a vessel feeding ``n`` tips; None for a leaf."""
        if n == 1:
            return None
        side = int(min(n // 2, max(1, round(n * self.rng.uniform(*_ART_SIDE_SHARE)))))
        return n - side, side

    def _radii(self, n, split):
        return self.R(n), (self.p["tip_radius"] if split is None else self.R(split[0]))

    def _length(self, n):
        return (self.p["leaf_length"] if n == 1 else self.p["spacing"]) * self.rng.uniform(*_ART_LENGTH_SPREAD)

    def _end_direction(self, d0):
        across = _turn(perpendicular(d0), d0, self.rng.uniform(0, 2 * math.pi))
        return _turn(d0, across, math.radians(self.rng.uniform(0, self.bend)))

    def _samples(self, ctrl, radii, rj):
        """Centre-line samples about ``_ART_LAYOUT_STEP`` apart and their radii; None if the curve bends too much.

        Within a step of where the clearance checks start at either end (``TREE_JUNCTION_RADII`` times the
        parent's end radius ``rj`` from the start, times the branch's own end radius from the end), the
        samples are a tenth of a step apart: the gaps are closest there.
        """
        a = _coefficients(ctrl)
        tq = np.linspace(0.0, 1.0, 65)
        sq = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(_eval(a, tq), axis=0), axis=1))])
        L = float(sq[-1])
        s = [np.linspace(0.0, L, max(8, int(math.ceil(L / _ART_LAYOUT_STEP)) + 1))]
        for c in (tol.TREE_JUNCTION_RADII * rj, L - tol.TREE_JUNCTION_RADII * radii[1]):
            s.append(np.clip(c + _ART_LAYOUT_STEP * np.linspace(-1.5, 1.5, 31), 0.0, L))
        t = np.interp(np.unique(np.concatenate(s)), sq, tq)
        r = radii[0] + (radii[1] - radii[0]) * t
        d1, d2 = _eval(a, t, 1), _eval(a, t, 2)
        kappa = np.linalg.norm(_cross(d1, d2), axis=1) / np.linalg.norm(d1, axis=1) ** 3
        if np.max(kappa * (r + 1.5 * self.p["tip_radius"] + self.p["blend"])) > _ART_MAX_KAPPA_R:
            return None
        return _eval(a, t), r

    def _clearance(self, r_end, other_end):
        """Gap required between vessels that share a junction (the mesher's), plus a margin for the sampling."""
        return tol.TREE_CLEARANCE * np.minimum(r_end, other_end) + self.p["blend"] + _ART_GAP_MARGIN

    def _gap(self, P, r, r_end, J, rj, parent):
        """Smallest gap (capped) from the tube samples ``(P, r)`` to the vessels placed, and whether it is allowed.

        The ``parent`` shares the junction ``J`` (its end radius ``rj``): samples of either within
        ``TREE_JUNCTION_RADII * rj`` of it are left out, as :func:`_check_clearance` does, and their gap
        needs only the mesher's clearance; every other vessel must keep ``min_gap`` away.
        """
        cap = _ART_GAP_CAP * self.p["min_gap"]
        reach = float(r.max()) + float(self.rad.max()) + max(cap, float(self._clearance(r_end, self.rad.max())))
        M = cKDTree(P).sparse_distance_matrix(self.tree, reach, output_type="ndarray")
        if not len(M):
            return cap, True
        i, j = M["i"], M["j"]
        g = M["v"] - r[i] - self.rad[j]
        shared = self.lab[j] == parent
        ex = tol.TREE_JUNCTION_RADII * rj
        skip = shared & ((np.linalg.norm(P[i] - J, axis=1) <= ex) | (np.linalg.norm(self.pts[j] - J, axis=1) <= ex))
        g, shared, j = g[~skip], shared[~skip], j[~skip]
        need = self._clearance(r_end, self.rend[j])
        need = np.where(shared, need, np.maximum(need, self.p["min_gap"]))
        other = g[~shared]
        return (min(cap, float(other.min())) if len(other) else cap), not np.any(g < need)

    def _pair_gap(self, P, r, rp, Q, q, rq, J, rj):
        """Whether two siblings leaving ``J`` keep the mesher's clearance away from it."""
        ex = tol.TREE_JUNCTION_RADII * rj
        kp, kq = np.linalg.norm(P - J, axis=1) > ex, np.linalg.norm(Q - J, axis=1) > ex
        if not kp.any() or not kq.any():
            return True
        d, i = cKDTree(Q[kq]).query(P[kp])
        return not np.any(d - r[kp] - q[kq][i] < self._clearance(rp, rq))

    def _above_floor(self, P, r, root=False):
        low = P[:, 2] - r
        if root:
            s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
            low = low[s > 2 * r[0] + _ART_FLOOR]
        return bool(np.all(low >= _ART_FLOOR))

    def _room(self, ctrl, relax):
        """A vessel that branches again ends where its children have room above the root plane."""
        E, T = ctrl[3], _unit(ctrl[3] - ctrl[2])
        ahead = 0.5 * self.p["leaf_length"] * (1 - relax)
        return E[2] + ahead * min(T[2], 0.0) >= _ART_FLOOR + 0.5 * ahead

    def _free(self, E):
        """Distance from ``E`` to the nearest wall placed."""
        d, j = self.tree.query(E, k=min(16, len(self.pts)))
        return float(np.min(np.atleast_1d(d) - self.rad[np.atleast_1d(j)]))

    def _add(self, parent, ctrl, radii, n, split, P, r):
        b = len(self.parents)
        self.parents.append(parent)
        self.ctrl.append(ctrl)
        self.radii.append(radii)
        self.tips.append(n)
        self.split.append(split)
        self.pts = np.vstack([self.pts, P])
        self.rad = np.concatenate([self.rad, r])
        self.lab = np.concatenate([self.lab, np.full(len(P), b)])
        self.rend = np.concatenate([self.rend, np.full(len(P), radii[1])])
        self.tree = cKDTree(self.pts)
        return b

    def grow(self):
        """Parents (tuple), control points (b, 4, 3) and radii (b, 2): the root, then junction by junction,
        the vessels feeding the most tips first."""
        n = self.p["n_tips"]
        split = self._split(n)
        radii = (self.p["root_radius"], self.p["tip_radius"]) if n == 1 else self._radii(n, split)
        d0 = np.array([0.0, 0.0, 1.0])
        self.bend = _ART_ROOT_BEND_DEG
        for _ in range(_ART_CANDIDATES * _ART_ROUNDS):
            length = self._length(n) * (1.0 if n == 1 else _ART_ROOT_LENGTH)
            ctrl = _arterial_bezier(np.zeros(3), d0, self._end_direction(d0), length, self.rng)
            S = self._samples(ctrl, radii, radii[0])
            if S is not None and self._above_floor(*S, root=True) and (n == 1 or self._room(ctrl, 0.0)):
                break
        else:
            raise OptionError("the root cannot rise clear of the root plane; use another seed or a longer spacing")
        self._add(-1, ctrl, radii, n, split, *S)
        heap = [(-n, 0)] if split else []
        while heap:
            _, b = heapq.heappop(heap)
            for c in self._junction(b):
                if self.split[c]:
                    heapq.heappush(heap, (-self.tips[c], c))
        return tuple(self.parents), np.array(self.ctrl), np.array(self.radii)

    def _junction(self, b):
        """Place both children of branch ``b``: the wider one carries on, the other is the side branch."""
        J = self.ctrl[b][3]
        T = _unit(self.ctrl[b][3] - self.ctrl[b][2])
        rj = self.radii[b][1]
        kids = []
        for n in self.split[b]:
            sp = self._split(n)
            kids.append((n, sp, self._radii(n, sp)))
        (nc, spc, rc), (ns, sps, rs) = kids
        wc = rs[0] ** 2 / (rs[0] ** 2 + rc[0] ** 2)  # share of the angle between them that the wider child turns
        u0 = perpendicular(T)
        valid = []
        for rnd in range(_ART_ROUNDS):
            shrink = _ART_SHRINK ** rnd
            relax = rnd / (_ART_ROUNDS - 1)
            self.bend = _ART_BEND_DEG * (1 + relax)
            lo, hi = _ART_SPLIT_DEG
            hi += (180.0 - hi) * 0.5 * relax
            room = _ART_ROOM * self.p["spacing"] * (1 - relax)
            for _ in range(_ART_CANDIDATES):
                u = _turn(u0, T, self.rng.uniform(0, 2 * math.pi))
                delta = math.radians(self.rng.uniform(lo, hi))
                dc = math.cos(delta * wc) * T - math.sin(delta * wc) * u
                ds = math.cos(delta * (1 - wc)) * T + math.sin(delta * (1 - wc)) * u
                cc = _arterial_bezier(J, dc, self._end_direction(dc), self._length(nc) * shrink, self.rng)
                cs = _arterial_bezier(J, ds, self._end_direction(ds), self._length(ns) * shrink, self.rng)
                if (spc and not self._room(cc, relax)) or (sps and not self._room(cs, relax)):
                    continue
                Sc, Ss = self._samples(cc, rc, rj), self._samples(cs, rs, rj)
                if Sc is None or Ss is None or not (self._above_floor(*Sc) and self._above_floor(*Ss)):
                    continue
                if not self._pair_gap(*Sc, rc[1], *Ss, rs[1], J, rj):
                    continue
                gc, ok = self._gap(*Sc, rc[1], J, rj, b)
                if not ok:
                    continue
                gs, ok = self._gap(*Ss, rs[1], J, rj, b)
                if not ok:
                    continue
                free = [self._free(c[3]) for c, sp in ((cc, spc), (cs, sps)) if sp]
                if free and min(free) < room:
                    continue
                score = min(gc, gs) + (min(min(free), room) / room if free and room > 0 else 0.0)
                valid.append((score, len(valid), cc, cs, Sc, Ss))
                if len(valid) >= _ART_CHOICES:
                    break
            if valid:
                break
        if not valid:
            raise OptionError(f"no room for the {nc + ns} tips beyond branch {b} without colliding tubes; "
                              "use another seed, a shorter leaf_length or spacing, a smaller min_gap or fewer tips")
        _, _, cc, cs, Sc, Ss = max(valid, key=lambda v: v[:2])
        return self._add(b, cc, rc, nc, spc, *Sc), self._add(b, cs, rs, ns, sps, *Ss)


def _check_arterial_layout(branches, voxel, band, blend, min_radius_voxels):
    """:func:`_check_layout`'s checks (thinnest tube, bends, root plane, clearance), the clearance only between
    branches whose boxes come near each other (the pairs of a large tree are too many to check all)."""
    _check_tubes(branches, voxel, band, float(min_radius_voxels), thin="a larger tip_radius",
                 bend="a smaller voxel", plane="a smaller voxel or another seed", at_voxel=True)
    rmax = max(float(b.radii.max()) for b in branches)
    pad = np.array([float(b.radii.max()) for b in branches]) + 0.5 * (tol.TREE_CLEARANCE * rmax + blend)
    lo = np.array([b.centers.min(axis=0) for b in branches]) - pad[:, None]
    hi = np.array([b.centers.max(axis=0) for b in branches]) + pad[:, None]
    near = np.all((lo[:, None] <= hi[None]) & (lo[None] <= hi[:, None]), axis=2)
    for i, j in zip(*np.nonzero(np.tril(near, -1))):
        try:
            _check_clearance(branches, int(i), int(j), blend)
        except OptionError:
            raise OptionError(f"branches {i} and {j} collide; use another seed or a larger min_gap") from None


def _band_grid(branches, h, band):
    """Origin and shape of the grid over every tube plus the band; its first z layer is the root plane."""
    lo = np.min([np.min(b.centers - b.radii[:, None], axis=0) for b in branches], axis=0) - band - 2 * h
    hi = np.max([np.max(b.centers + b.radii[:, None], axis=0) for b in branches], axis=0) + band + 2 * h
    origin = np.floor(lo / h) * h
    origin[2] = 0.0
    return origin, tuple(int(k) for k in np.ceil((hi - origin) / h).astype(np.int64) + 1)


def _segment_distance(X, A, B):
    """Distance of each point of ``X`` (m, 3) to the segment from ``A`` to ``B``; (m,) float64."""
    AB = B - A
    L2 = float(AB @ AB)
    u = np.clip(((X - A) @ AB) / L2, 0.0, 1.0) if L2 > 0 else np.zeros(len(X))
    return np.linalg.norm(X - A - u[:, None] * AB, axis=1)


def _branch_band(br, origin, h, shape, band):
    """The grid points near a branch and its function there.

    The centre line is cut into pieces about 1.5 (radius + band) long. A grid point farther from a
    piece's chord than its largest radius + band + the piece's distance from its chord is farther than
    ``band`` from that piece's tube; one nearer than the branch's smallest radius - band - that distance
    is deeper inside than ``band`` (the function is ``-band`` there, clipped); the others get the exact
    function (:meth:`TreeBranch._band_field`).

    Returns
    -------
    lin : (m,) int64
        Linear grid indices (unique) of the points within ``band`` of the tube or inside it.
    f : (m,) float32
        The branch function clipped to [-band, band].
    """
    ts = np.linspace(0.0, 1.0, tol.TREE_SEED_SAMPLES)
    P, R = br.point(ts), br.radius(ts)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
    rmin = float(R.min())
    lins, deeps = [], []
    k, last = 0, len(ts) - 1
    while k < last:
        e = min(max(int(np.searchsorted(s, s[k] + max(1.5 * (R[k] + band), 4 * h))), k + 1), last)
        A, B = P[k], P[e]
        sigma = float(_segment_distance(P[k:e + 1], A, B).max()) + 1e-6 * h
        reach = float(R[k:e + 1].max()) + band + sigma
        i0 = np.maximum(np.ceil((np.minimum(A, B) - reach - origin) / h), 0).astype(np.int64)
        i1 = np.minimum(np.floor((np.maximum(A, B) + reach - origin) / h), np.array(shape) - 1).astype(np.int64)
        k = e
        if np.any(i1 < i0):
            continue
        g = np.mgrid[i0[0]:i1[0] + 1, i0[1]:i1[1] + 1, i0[2]:i1[2] + 1].reshape(3, -1)
        d = _segment_distance(origin + h * g.T, A, B)
        keep = d <= reach
        lins.append(np.ravel_multi_index(g[:, keep], shape))
        deeps.append(d[keep] + sigma < rmin - band)
    if not lins:
        return np.zeros(0, np.int64), np.zeros(0, np.float32)
    lin, deep = np.concatenate(lins), np.concatenate(deeps)
    order = np.lexsort((~deep, lin))  # each point once, deep if any piece finds it deep
    lin, deep = lin[order], deep[order]
    first = np.ones(len(lin), bool)
    first[1:] = lin[1:] != lin[:-1]
    lin, deep = lin[first], deep[first]
    f = np.full(len(lin), -band, dtype=np.float32)
    X = origin + h * np.stack(np.unravel_index(lin[~deep], shape), axis=1)
    f[~deep] = br._band_field(X, band)
    return lin, f


class _BandBlocks:
    """The two smallest branch functions and their branches on the grid blocks the band touches.

    Blocks are ``B^3`` grid points; an untouched point is outside every tube by more than the band
    (``f = band``, no branch).
    """

    def __init__(self, shape, B, band):
        self.shape, self.B, self.band = tuple(shape), B, band
        self.cshape = tuple(int(math.ceil(n / B)) for n in shape)
        self.few = int(np.prod(self.cshape, dtype=np.int64)) < 2**31  # block keys fit 32 bits

    def locate(self, lin):
        """Block key and index within the block of each grid point."""
        ijk = np.stack(np.unravel_index(lin, self.shape))
        return (np.ravel_multi_index(ijk // self.B, self.cshape).astype(np.int32 if self.few else np.int64),
                np.ravel_multi_index(ijk % self.B, (self.B,) * 3).astype(np.int16))

    def allocate(self, keys):
        self.keys = np.unique(keys)
        size = (len(self.keys), self.B ** 3)
        self.f1, self.f2 = np.full(size, self.band, np.float32), np.full(size, self.band, np.float32)
        self.b1, self.b2 = np.full(size, -1, np.int16), np.full(size, -1, np.int16)

    def add(self, k, key, loc, fb):
        """Merge branch ``k``'s function ``fb`` at (unique) points ``(key, loc)`` into the two smallest."""
        slot = np.searchsorted(self.keys, key)
        a, b, ia, ib = self.f1[slot, loc], self.f2[slot, loc], self.b1[slot, loc], self.b2[slot, loc]
        first = fb < a
        second = ~first & (fb < b)
        self.f2[slot, loc] = np.where(first, a, np.where(second, fb, b))
        self.b2[slot, loc] = np.where(first, ia, np.where(second, k, ib))
        self.f1[slot, loc] = np.where(first, fb, a)
        self.b1[slot, loc] = np.where(first, k, ia)

    def patch(self, c):
        """The function and the two branches on the (B + 1)^3 points of block ``c`` (3,): its own and the
        first layers of its upper neighbours, so that its cubes are whole."""
        B = self.B
        f = np.full((B + 1,) * 3, self.band, np.float32)
        ids = np.full((2,) + (B + 1,) * 3, -1, np.int16)
        for o in np.ndindex(2, 2, 2):
            n = tuple(int(a + b) for a, b in zip(c, o))
            if any(a >= m for a, m in zip(n, self.cshape)):
                continue
            key = np.ravel_multi_index(n, self.cshape)
            s = int(np.searchsorted(self.keys, key))
            if s == len(self.keys) or self.keys[s] != key:
                continue
            dst = tuple(slice(B, B + 1) if a else slice(0, B) for a in o)
            src = tuple(slice(0, 1) if a else slice(0, B) for a in o)
            f[dst] = self.f1[s].reshape(B, B, B)[src]
            ids[(0,) + dst] = self.b1[s].reshape(B, B, B)[src]
            ids[(1,) + dst] = self.b2[s].reshape(B, B, B)[src]
        return f, ids


def _band_marching_cubes(truth, origin, h, shape, band):
    """Marching cubes of the tree's function on the band, block by block, merged at the grid edges.

    A cube belongs to the block of its lowest corner, so every cube is triangulated once, from the
    same values as on a whole grid; a vertex on a grid edge two blocks share is found by both and
    merged by the edge's index.

    Returns
    -------
    V : (n, 3) float64
        Vertices (mm), before projection.
    F : (m, 3) int64
        Outward triangles.
    cand : (n, 4) int16
        The two branches of smallest function at both ends of each vertex's grid edge (-1: none).
    """
    marching_cubes = _skimage_marching_cubes()
    B = _ART_BLOCK
    blocks = _BandBlocks(shape, B, band)
    per = []
    for br in truth.branches:
        lin, f = _branch_band(br, origin, h, shape, band)
        per.append((*blocks.locate(lin), f))
    blocks.allocate(np.concatenate([p[0] for p in per]))
    for k, (key, loc, f) in enumerate(per):
        blocks.add(k, key, loc, f)
    del per
    if truth.blend > 0:
        m = blocks.f1 < band
        blocks.f1[m] = _smin(blocks.f1[m].astype(np.float64), blocks.f2[m].astype(np.float64), truth.blend)[0]
    snap = np.float32(tol.TREE_MC_SNAP * h)  # as in _surface: no crossing next to a grid point
    near = np.abs(blocks.f1) < snap
    blocks.f1[near] = np.where(blocks.f1[near] < 0, -snap, snap)
    # blocks whose cubes reach a block with points inside: those blocks and their lower neighbours
    C = np.stack(np.unravel_index(blocks.keys[np.any(blocks.f1 < 0, axis=1)], blocks.cshape), axis=1)
    run = np.unique(np.concatenate([C - np.array(o) for o in np.ndindex(2, 2, 2)]), axis=0)
    run = run[np.all(run >= 0, axis=1)]
    keys, verts, faces, cands = [], [], [], []
    nv = 0
    for c in run:
        f, ids = blocks.patch(c)
        if not f.min() < 0 < f.max():  # no crossing: outside every tube, or deep inside a wide one
            continue
        V, F, _, _ = marching_cubes(f, level=0.0, gradient_direction="ascent", allow_degenerate=False)
        lower = np.floor(V).astype(np.int64)
        axis = np.argmax(V - lower, axis=1)  # the one coordinate off the lattice
        upper = lower.copy()
        upper[np.arange(len(V)), axis] += 1
        cands.append(np.concatenate([ids[:, lower[:, 0], lower[:, 1], lower[:, 2]].T,
                                     ids[:, upper[:, 0], upper[:, 1], upper[:, 2]].T], axis=1))
        keys.append(np.ravel_multi_index((lower + c * B).T, shape) * 3 + axis)
        verts.append(V.astype(np.float64) + c * B)
        faces.append(F + nv)
        nv += len(V)
    if not keys:
        raise InvalidMeshError("the tree left no surface on its grid; use a smaller voxel")
    _, first, inv = np.unique(np.concatenate(keys), return_index=True, return_inverse=True)
    V = origin + h * np.concatenate(verts)[first]
    return V, inv.reshape(-1)[np.concatenate(faces)], np.concatenate(cands)[first]


def _project_candidates(truth, X, cand, fixed_z, h):
    """Newton steps onto the exact zero set, as :func:`_project`, with each vertex's union formed from the two
    smallest functions among its candidate branches (not all); vertices not yet on the surface after
    ``TREE_PROJECTION_STEPS`` (at junctions) get up to ``_ART_EXTRA_STEPS`` more."""
    nb, n = len(truth.branches), len(X)
    rows = np.repeat(np.arange(n), cand.shape[1])
    br = cand.reshape(-1).astype(np.int64)
    key = np.unique(rows[br >= 0] * nb + br[br >= 0])
    rows, br = key // nb, key % nb
    f, t = np.empty(len(key)), np.empty(len(key))
    for k, sel in _by_branch(br, np.arange(len(br)), nb):
        t[sel], d = truth.branches[k].foot(X[rows[sel]])
        f[sel] = d - truth.branches[k].radius(t[sel])
    o = np.lexsort((f, rows))
    rows, br, t = rows[o], br[o], t[o]
    start = np.searchsorted(rows, np.arange(n))
    two = np.diff(np.append(start, len(rows))) > 1
    pair, T = np.full((2, n), -1, np.int64), np.zeros((2, n))
    pair[0], T[0] = br[start], t[start]
    pair[1, two], T[1, two] = br[start[two] + 1], t[start[two] + 1]
    X = X.copy()
    for _ in range(tol.TREE_PROJECTION_STEPS):
        vals = []
        for j in range(2):
            fj, gj = np.full(n, np.inf), np.zeros((n, 3))
            for k, sel in _by_branch(pair[j], np.arange(n), nb):
                fj[sel], gj[sel], T[j, sel] = truth.branches[k]._field_t(X[sel], T[j, sel], True)
            vals.append((fj, gj))
        fu, gu = _union(vals, truth.blend, True)
        X -= (fu / np.maximum(np.einsum("ij,ij->i", gu, gu), 1e-12))[:, None] * gu
        X[fixed_z, 2] = 0.0
    return _settle_junctions(truth, X, cand, fixed_z, h)


def _settle_junctions(truth, X, cand, fixed_z, h):
    """More Newton steps for the vertices beside a junction, the union re-formed at every step from the two
    smallest functions among their candidates and the branches meeting at the two nearest junctions (a third
    branch's function can come between the first two there; elsewhere the tubes keep apart by more than the
    blend, so the two candidates are the exact union's)."""
    nb = len(truth.branches)
    J = [(k, br.control[3]) for k, br in enumerate(truth.branches) if any(c.parent == k for c in truth.branches)]
    if not J:
        return X
    meets = {k: [k] + [c for c, br in enumerate(truth.branches) if br.parent == k] for k, _ in J}
    owner = np.array([k for k, _ in J])
    reach = np.array([(tol.TREE_JUNCTION_RADII + 1) * truth.branches[k].radius_end for k, _ in J])
    d, i = cKDTree(np.array([P for _, P in J])).query(X, k=min(2, len(J)))
    d, i = d.reshape(len(X), -1), i.reshape(len(X), -1)
    beside = np.any(d < reach[i] + truth.blend, axis=1)
    active = np.flatnonzero(beside)
    rows, brs = [], []
    for c in range(cand.shape[1]):
        rows.append(active)
        brs.append(cand[active, c].astype(np.int64))
    for c in range(i.shape[1]):
        near = d[active, c] < reach[i[active, c]] + truth.blend
        for k in np.unique(owner[i[active[near], c]]):
            v = active[near][owner[i[active[near], c]] == k]
            for b in meets[k]:
                rows.append(v)
                brs.append(np.full(len(v), b, np.int64))
    rows, brs = np.concatenate(rows), np.concatenate(brs)
    key = np.unique(rows[brs >= 0] * nb + brs[brs >= 0])
    rows, brs = key // nb, key % nb
    t = np.empty(len(key))
    for k, sel in _by_branch(brs, np.arange(len(brs)), nb):
        t[sel] = truth.branches[k].foot(X[rows[sel]])[0]
    X = X.copy()
    for _ in range(_ART_EXTRA_STEPS):
        f, g = np.empty(len(rows)), np.empty((len(rows), 3))
        for k, sel in _by_branch(brs, np.arange(len(brs)), nb):
            f[sel], g[sel], t[sel] = truth.branches[k]._field_t(X[rows[sel]], t[sel], True)
        o = np.lexsort((f, rows))
        r_o = rows[o]
        v, start = np.unique(r_o, return_index=True)
        two = np.diff(np.append(start, len(r_o))) > 1
        second = np.where(two, start + 1, start)
        f1, f2 = f[o[start]], np.where(two, f[o[second]], np.inf)
        fu, gu = _union([(f1, g[o[start]]), (f2, np.where(two[:, None], g[o[second]], 0.0))], truth.blend, True)
        off = np.abs(fu) > _ART_ON_SURFACE * h
        if not off.any():
            break
        v, fu, gu = v[off], fu[off], gu[off]
        X[v] -= (fu / np.maximum(np.einsum("ij,ij->i", gu, gu), 1e-12))[:, None] * gu
        X[v[fixed_z[v]], 2] = 0.0
        keep = np.isin(rows, v)
        rows, brs, t = rows[keep], brs[keep], t[keep]
    return X


def _by_branch(branch, items, nb):
    """``(k, items of branch k)`` for every branch ``k`` in ``branch`` (-1 left out)."""
    o = np.argsort(branch, kind="stable")
    bounds = np.searchsorted(branch[o], np.arange(nb + 1))
    return [(k, items[o[bounds[k]:bounds[k + 1]]]) for k in range(nb) if bounds[k + 1] > bounds[k]]
