"""Bulges of the lumen along a vessel's paths: sacs, bulbs, ectasias (issue #34).

An aneurysm sac, the carotid bulb or a dilated stretch is passed through by the tree's paths the
way VMTK's centre line passes through it (:mod:`vesselgp.medial_zones`), and reported here: where
along a path the fitted radius (Eq. 4) stands well above the lumen's radius on both sides of it.

The neighbouring radius at arc length ``a`` is the larger of the median radius over the
``reach`` before ``a`` and over the ``reach`` after it (one side only where the path ends within
it). A median ignores a stretch shorter than half its window, so a stenosis beside a bulge does not
lower it, and a bulge shorter than ``reach`` (a sac up to three radii each side of its peak with
the default reach of ``tolerances.TREE_BULGE_REACH`` = 6 radii) does not raise it; the larger side
makes a taper, or the step from a parent to a thinner child, no bulge (the wider side is as wide).
A bulge peaks at least ``tolerances.TREE_BULGE_RATIO`` times its neighbouring radius and spans the
samples around the peak at least ``tolerances.TREE_BULGE_EDGE`` times that radius (1.3: on the real meshes
the sacs and the iliac aneurysms stand 1.33-1.72 above their neighbours, tubes, stenoses and thin
noisy tips at most 1.26; the real X-ray coronary's stretch between two stenoses 1.32, VMTK's own radii through
the same rule 1.36 there: a dilatation, reported). The first radius of a path at either end is not judged (a cap's or a
tip's region). A peak is a bulge only where the wall measures its radius: the wall vertices within a
radius of it cover at least ``tolerances.TREE_BULGE_MIN_COVER`` of the circle about the axis (their
largest gap in angle is less than the rest). Where a sibling branch leaves beside a junction, a path
keeps a few vertices on the far side (issue #47: 4 vertices on 12 % of the circle made a junction of the
XCAT coronary tree a bulge of 1.38; the real sacs and aneurysms are measured all round, 79-99 %).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from . import tolerances as tol
from ._per_vertex import stored_rows
from ._arrays import true_runs

__all__ = ["Bulge", "bulges", "sac_wall", "tree_bulges"]


@dataclass(frozen=True)
class Bulge:
    """A stretch of a vessel where the lumen is wider than on both sides of it.

    Attributes
    ----------
    paths : tuple of int
        The tree's paths through it (indices into :attr:`vesselgp.VesselTree.paths`); ``s_range``
        and ``s_peak`` are on the first.
    s_range : (2,) float64
        Normalised arc length of its start and end on ``paths[0]``.
    s_peak : float
        Where it is widest.
    peak : (3,) float64
        The axis point there.
    peak_radius : float
        The fitted radius there (Eq. 4); for a blind sac beside the path (a dome that is not an end,
        :attr:`vesselgp.PreparedMesh.sacs`), the dome's radius.
    neighbour_radius : float
        The lumen's radius beside it (the module notes).
    wall : (k,) int64
        A blind sac's wall beyond the paths' tubes (mesh vertex ids, :func:`sac_wall`): described by
        the sac, not by an axis (:mod:`vesselgp.checks`). Empty for a widening of the path itself.
    """

    paths: tuple
    s_range: np.ndarray
    s_peak: float
    peak: np.ndarray
    peak_radius: float
    neighbour_radius: float
    wall: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64), repr=False)

    @property
    def ratio(self):
        """Peak radius over the neighbouring radius."""
        return self.peak_radius / self.neighbour_radius


def _nan_medians(rows):
    """``np.nanmedian(rows, axis=1)`` (NaN for a row of NaN only), without numpy's masked-array path for the
    rows with NaN (sorted, NaN last: the middle of each row's numbers), 20x faster on a tree's paths."""
    out = np.empty(len(rows))
    gap = np.isnan(rows).any(axis=1)
    if (~gap).any():
        out[~gap] = np.median(rows[~gap], axis=1)
    if gap.any():
        S = np.sort(rows[gap], axis=1)
        k = (~np.isnan(S)).sum(axis=1)
        lo, hi = np.maximum(k - 1, 0) // 2, np.maximum(k, 1) // 2
        rr = np.arange(len(S))
        out[gap] = np.where(k > 0, 0.5 * (S[rr, lo] + S[rr, hi]), np.nan)
    return out


def wall_cover(gc, s, half):
    """The share of the circle about the axis that the wall vertices of ``gc`` with weight within ``half`` arc
    length of each ``s`` cover: one minus the largest gap between their angles over 2 pi (0 with fewer than two).

    Parameters
    ----------
    gc : GeneralizedCylinder
    s : (q,) float64
        Normalised arc length.
    half : (q,) float64
        Half the window, in mesh units.

    Returns
    -------
    (q,) float64
    """
    weight = stored_rows(gc, "vertex_weight")[1]  # the rows a tree's cylinder is stored on hold its data
    data = weight > 0
    vs, th = stored_rows(gc, "vertex_s")[1][data], stored_rows(gc, "vertex_theta")[1][data]
    order = np.argsort(vs)
    vs, th = vs[order], th[order]
    lo = np.searchsorted(vs, s - half / gc.length, side="left")
    hi = np.searchsorted(vs, s + half / gc.length, side="right")
    out = np.zeros(len(s))
    for q, (a, b) in enumerate(zip(lo, hi)):
        if b - a >= 2:
            t = np.sort(th[a:b])
            out[q] = 1.0 - max(float(np.max(np.diff(t))), float(t[0] + 2.0 * np.pi - t[-1])) / (2.0 * np.pi)
    return out


def bulges(s, radius, length, *, reach, margin=(0.0, 0.0), measured=None):
    """Stretches of an axis where the radius stands above its neighbours (see the module notes).

    Parameters
    ----------
    s : (q,) float64
        Normalised arc length of the samples, uniform (a fit's ``dense_s``).
    radius : (q,) float64
        The radius at each sample.
    length : float
        Arc length of the axis.
    reach : float
        Arc length of the window on each side (the neighbouring radius is its median).
    margin : (float, float), optional
        Arc length at the start and at the end that is not judged.
    measured : callable, optional
        Of sample indices (k,) int64, whether the wall measures the radius there ((k,) bool; asked about
        each bulge's peak): a peak that it does not measure is no bulge. Default: every sample is measured.

    Returns
    -------
    (k, 5) float64
        One row per bulge: normalised start, end and peak arc length, peak radius and the
        neighbouring radius at the peak.

    Examples
    --------
    A tube of radius 1 and length 20 with a fusiform bulge of height 0.6 (a Gaussian of width 1.5
    at the middle): its neighbouring radius is the median over 6 before the peak, the radius at
    ``a = 7``, ``1 + 0.6 exp(-4) = 1.011``; it spans ``|a - 10| <= 1.5 sqrt(ln(0.6 / 0.1121)) = 1.94``,
    where the radius is at least 1.1 times that.

    >>> s = np.linspace(0.0, 1.0, 801)
    >>> r = 1.0 + 0.6 * np.exp(-((20 * s - 10.0) / 1.5) ** 2)
    >>> (bulges(s, r, 20.0, reach=6.0) * [20, 20, 20, 1, 1]).round(3).tolist()
    [[8.075, 11.925, 10.0, 1.6, 1.011]]
    """
    s = np.asarray(s, np.float64)
    r = np.asarray(radius, np.float64)
    n = len(s)
    w = max(int(round(reach / (float(length) * (s[1] - s[0])))), 1) if n > 1 else 1
    pad = np.concatenate([np.full(w, np.nan), r, np.full(w, np.nan)])
    win = sliding_window_view(pad, w)  # win[j] = pad[j:j + w]
    before = _nan_medians(win[:n])  # r[i - w], ..., r[i - 1]
    after = _nan_medians(win[w + 1:w + 1 + n])  # r[i + 1], ..., r[i + w]
    base = np.fmax(before, after)
    arc = s * float(length)
    judged = (arc >= margin[0]) & (float(length) - arc >= margin[1]) & np.isfinite(base)
    q = np.where(judged, r / np.where(judged, base, 1.0), 0.0)
    out, covered = [], np.zeros(n, bool)
    for i0, i1 in true_runs(q >= tol.TREE_BULGE_RATIO):
        k = i0 + int(np.argmax(q[i0:i1 + 1]))
        if covered[k]:  # a second peak within the first's stretch
            continue
        if measured is not None and not measured(np.array([k]))[0]:  # a peak the wall does not measure
            continue
        wide = r >= tol.TREE_BULGE_EDGE * base[k]  # its stretch: wider than EDGE x the peak's neighbours
        a = k - int(np.argmin(wide[k::-1])) + 1 if not wide[:k + 1].all() else 0
        b = k + int(np.argmin(wide[k:])) - 1 if not wide[k:].all() else n - 1
        covered[a:b + 1] = True
        out.append([s[a], s[b], s[k], r[k], base[k]])
    return np.array(out, np.float64).reshape(-1, 5)


def sac_wall(V, adjacency, pole, paths):
    """A blind sac's wall: the wall no path's tube holds that its dome's pole reaches, and its neck.

    A wall vertex is beyond the paths' tubes when its distance to the nearest dense path sample is more
    than ``1 + tolerances.CHECK_COVER_TOLERANCE`` times the fitted radius there (the wall the coverage
    check of :mod:`vesselgp.checks` would not find described). The sac's wall is the piece of such
    vertices, connected on the mesh, that holds the pole; its rim (the piece's vertices next to wall a
    tube holds) is the neck.

    Parameters
    ----------
    V : (n, 3) float64
    adjacency : (n, n) sparse
        The mesh's vertex adjacency.
    pole : int
        The vertex at the dome's pole.
    paths : sequence of GeneralizedCylinder

    Returns
    -------
    wall : (k,) int64
        The sac's wall vertices (empty when the pole lies within a tube: a sac no deeper than that).
    neck : (3,) float64
        The centroid of the rim (the pole itself when ``wall`` is empty).
    """
    P = np.vstack([p.dense_points for p in paths])
    r = np.concatenate([p.radius_at(p.dense_s) for p in paths])
    d, i = cKDTree(P).query(V)
    beyond = d > (1.0 + tol.CHECK_COVER_TOLERANCE) * r[i]
    if not beyond[pole]:
        return np.zeros(0, np.int64), V[pole].copy()
    ids = np.flatnonzero(beyond)
    _, lab = connected_components(adjacency[ids][:, ids], directed=False)
    wall = ids[lab == lab[np.searchsorted(ids, pole)]]
    inner = np.asarray(adjacency[wall][:, np.flatnonzero(~beyond)].sum(axis=1)).ravel() > 0
    return wall, V[wall[inner]].mean(axis=0) if inner.any() else V[pole].copy()


def _nearest_sample(paths, x):
    """(path, dense sample) nearest to the point ``x`` (3,)."""
    return min(((k, int(np.argmin(np.linalg.norm(p.dense_points - x, axis=1)))) for k, p in enumerate(paths)),
               key=lambda ki: np.linalg.norm(paths[ki[0]].dense_points[ki[1]] - x))


def _stretch_within(path, s_range, c, reach):
    """Whether the path's dense samples within ``s_range`` come closer than ``reach`` to ``c``."""
    m = (path.dense_s >= s_range[0]) & (path.dense_s <= s_range[1])
    return bool(m.any() and np.min(np.linalg.norm(path.dense_points[m] - c, axis=1)) <= reach)


def _beside(nearest, wall, k, sp, half, fitted):
    """The lumen's radius beside a sac placed at ``sp`` on path ``k``: the median distance to that path of the
    mesh's vertices nearest to its samples within ``half`` (normalised arc length) of ``sp``, the sac's wall left
    out. (The path's fitted radius there is drawn into the neck: 7-37 % too wide on tapered tubes and next to a
    bifurcation, measured.) ``nearest``: each vertex's distance to the paths' samples, the path and the ``s`` of
    its nearest; with no such vertex, ``fitted``, the path's fitted radius at ``sp``."""
    d, path, s = nearest
    near = (path == k) & (np.abs(s - sp) <= half)
    near[wall] = False
    return float(np.median(d[near])) if near.any() else fitted


def _nearest_samples(V, paths):
    """Each vertex's distance to the nearest dense sample of the paths, that sample's path and its ``s``."""
    d, i = cKDTree(np.vstack([p.dense_points for p in paths])).query(V)
    path = np.concatenate([np.full(len(p.dense_s), q) for q, p in enumerate(paths)])
    return d, path[i], np.concatenate([p.dense_s for p in paths])[i]


def tree_bulges(paths, sacs=(), mesh=None, *, wall=True):
    """The bulges of a tree's paths, one per place (a bulge on a shared trunk is on several paths).

    Parameters
    ----------
    paths : sequence of GeneralizedCylinder
        The root-to-tip paths (or a single vessel's fit); the first and last fitted radius of
        each are not judged.
    sacs : sequence of ((3,) float64, (3,) float64, float), optional
        Blind sacs found by :func:`vesselgp.vessel_ends` (:attr:`vesselgp.PreparedMesh.sacs`:
        domes that are not ends), as their dome's centre, outward direction and radius. A sac's
        place on the paths is the path sample nearest to its neck (:func:`sac_wall`, from the
        vertex of ``mesh`` nearest to the dome's pole). Where a path's bulge already reaches within
        the sac's diameter of that place (a path through the neck), that bulge reports the sac and
        takes its wall; otherwise the sac is a bulge of that path there: ``peak_radius`` the dome's
        radius, ``neighbour_radius`` the lumen's radius beside it (the median distance to the path of
        the vertices about that place, the sac's wall left out: the fitted radius there is drawn into the
        neck), ``s_range`` the sac's diameter about it.
    mesh : ((n, 3) float64, (n, n) sparse), optional
        The vertices and vertex adjacency of the mesh; needed when ``sacs`` is not empty.
    wall : bool
        Whether a peak must be measured by the path's wall data (:func:`wall_cover`, the module notes);
        False for exact axes given with their radius and no wall.

    Returns
    -------
    tuple of Bulge
        Two paths' bulges are one when each peak lies within the other's peak radius.
    """
    found = []
    for k, p in enumerate(paths):
        r = p.radius_at(p.dense_s)
        reach = tol.TREE_BULGE_REACH * float(np.median(r))
        def measured(i, p=p, r=r):
            return wall_cover(p, p.dense_s[i], r[i]) >= tol.TREE_BULGE_MIN_COVER

        for s0, s1, sp, rp, rb in bulges(p.dense_s, r, p.length, reach=reach, margin=(float(r[0]), float(r[-1])),
                                         measured=measured if wall else None):
            peak = p.dense_points[np.argmin(np.abs(p.dense_s - sp))]  # sp is one of the dense samples
            same = next((i for i, b in enumerate(found)
                         if np.linalg.norm(b.peak - peak) <= min(b.peak_radius, rp)), None)
            if same is None:
                found.append(Bulge((k,), np.array([s0, s1]), float(sp), peak, float(rp), float(rb)))
            else:
                found[same] = replace(found[same], paths=found[same].paths + (k,))
    if len(sacs) and mesh is None:
        raise ValueError("tree_bulges: sacs are placed on the mesh; pass mesh=(V, adjacency)")
    if len(sacs):
        V, adjacency = mesh
        nearest = _nearest_samples(V, paths)
    for c, out, rs in sacs:
        wall, neck = sac_wall(V, adjacency, int(np.argmin(np.linalg.norm(V - (c + rs * out), axis=1))), paths)
        k, i = _nearest_sample(paths, neck)
        p = paths[k]
        at = next((j for j, b in enumerate(found)
                   if _stretch_within(paths[b.paths[0]], b.s_range, p.dense_points[i], 2.0 * rs)), None)
        if at is not None:  # a path passes through its neck: its own bulge there reports it
            found[at] = replace(found[at], wall=np.union1d(found[at].wall, wall))
            continue
        sp = float(p.dense_s[i])
        half = rs / p.length
        found.append(Bulge((k,), np.array([max(sp - half, 0.0), min(sp + half, 1.0)]), sp, p.dense_points[i],
                           float(rs), _beside(nearest, wall, k, sp, half, float(p.radius_at([sp])[0])), wall))
    return tuple(found)
