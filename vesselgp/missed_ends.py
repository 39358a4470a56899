"""Ends that :func:`vesselgp.vessel_ends` missed, found from the lumen itself (issue #47's segmentation-like copies).

An end is missed where its shape fits none of the end tests: a cap that is neither flat nor rounded (a fan
or a clipping plane smoothed over, its rim rounded off by marching cubes or remeshing), a tip that is no
hemisphere. The fit then has no path into that vessel. The cover check does not see it when the path beside it
takes the vessel's wall for a bulge of its own (a capped arch whose ascending aorta's cap was missed was reported
as an aneurysm of 2.7 times the arch's radius, every check passing).

The lumen shows it all the same. The inside Voronoi vertices of the surface (:mod:`vesselgp.centerlines`)
fill every vessel; those that no centre line's inscribed sphere reaches (scaled by ``1 +
tolerances.CHECK_COVER_TOLERANCE``, as the cover check scales them) lie in sacs, in sections that are not
round, at the tips of the medial spikes of a ragged wall, or in a vessel that no line enters. Only the last goes
on: a Voronoi vertex whose sphere is a vessel's (its radius at least ``tolerances.MISSED_CORE`` of the nearest
line's) at least ``tolerances.MISSED_REACH`` of its own radii past the reached ones, along the diagram, is
where a vessel runs on with no end. From the farthest such vertex, along the way the diagram came, the surface
is met near the vessel's end; there, the vertex farthest along the surface from the wall the lines reach (a flat
cap's centre, a dome's pole) is where the end is read, as a rounded tip is (:func:`vesselgp.mesh._ends_tips._tip`
recentred on its pole, else :func:`vesselgp.mesh._ends_tips._crossing_end`: its rings widen as a dome's, or a
disk's, until they are the tube's), and read again from where that end's own axis meets the surface. It is an
end if the tube goes on behind it for ``tolerances.ENDS_SAC_TUBE_RADII`` of its radii
(:func:`vesselgp.mesh._ends_tips.own_tube`), as every rounded tip must, or for ``tolerances.MISSED_MIN_TUBE`` of
them and then meets a junction without narrowing (a short, wide vessel); a dome whose rings close in on a neck is
a sac's, left to the fit (its path passes it, its bulge is measured).
"""
from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

from . import tolerances as tol
from ._arrays import within_balls
from .mesh._ends_format import bbox_diagonal
from .mesh._ends_tips import _crossing_end, _tip, own_tube
from .mesh.ends import _face_normals, _make_end, _Nearby, _ordered_ring

log = logging.getLogger(__name__)

__all__ = ["missed_ends"]


def missed_ends(pm, lines):
    """The end of a vessel that no centre line enters, or none (see the module notes).

    Parameters
    ----------
    pm : PreparedMesh
        The mesh, its ends and its inside Voronoi diagram (:attr:`vesselgp.PreparedMesh.voronoi`).
    lines : Centerlines
        Its centre lines from the root to every end found (:func:`vesselgp.centerlines.centerlines`).

    Returns
    -------
    list of VesselEnd
        At most one: the rounded end (kind ``"rounded"``) of the vessel that runs on farthest past the
        lines, if its tube goes on behind it; empty when every vessel is entered (or what runs on is a sac).

    Examples
    --------
    A Y whose third vessel's end is left out: that end is found again.

    >>> from vesselgp.synthetic_tree import synthetic_tree
    >>> from vesselgp.prepared import PreparedMesh
    >>> from vesselgp.centerlines import centerlines
    >>> t = synthetic_tree(levels=1, voxel=0.6)
    >>> full = PreparedMesh(t.V, t.F)
    >>> pm = full.with_ends(full.ends[:2])
    >>> found = missed_ends(pm, centerlines(pm.V, pm.checked.faces, pm.ends, 0, voronoi=pm.voronoi))
    >>> len(found), bool(np.linalg.norm(found[0].center - full.ends[2].center) < full.ends[2].radius)
    (1, True)
    """
    cc, R, inside, G = pm.voronoi.graph(False)
    ids = np.flatnonzero(inside)
    C, Rl = np.vstack(lines.points), np.concatenate(lines.radius)
    reached = np.zeros(len(cc), bool)
    reached[ids] = within_balls(cc[ids], C, (1.0 + tol.CHECK_COVER_TOLERANCE) * Rl)
    un = ids[~reached[ids]]
    rn = Rl[cKDTree(C).query(cc[un])[1]]
    core = R[un] >= tol.MISSED_CORE * rn
    if not core.any():  # (every vessel entered: nothing unreached but the spikes of a ragged or flattened wall)
        return []
    dE, pred = _past_the_lines(G, cc, R, inside, reached)
    fin = np.isfinite(dE[un])
    un, core = un[fin], core[fin]
    cand = un[core & (dE[un] >= tol.MISSED_REACH * R[un])]
    if not len(cand):
        return []
    # each run of unreached vertices is judged once, by its farthest candidate
    sub = np.zeros(len(cc), bool)
    sub[un] = True
    _, comp = connected_components(G[sub][:, sub], directed=False)
    where = np.full(len(cc), -1)
    where[np.flatnonzero(sub)] = comp
    V, topo = pm.V, pm.topology
    balls = (C, (1.0 + tol.CHECK_COVER_TOLERANCE) * Rl)
    w = topo.edge_lengths(V)
    h, graph = float(np.median(w)), topo.edge_matrix(w)
    from_wall = _from_the_wall(V, graph, np.flatnonzero(topo.referenced), balls)
    normals = _face_normals(V, pm.checked.faces)
    for c in np.unique(where[cand]):
        mine = cand[where[cand] == c]
        k = int(mine[np.argmax(dE[mine])])
        end = _end_beyond(pm, cc, R, pred, k, graph, h, float(dE[k] + R[k]), from_wall, normals)
        if end is not None:
            return [end]
    return []


def _past_the_lines(G, cc, R, inside, reached):
    """Each inside Voronoi vertex's distance along the diagram (Euclidean, its edges' lengths) from the nearest
    reached one, and its predecessor on that way (-9999 at the reached ones and where none leads)."""
    Gc = G.tocoo()
    # the way from the nearest reached vertex runs through unreached ones only after its last reached one: the
    # unreached vertices and the reached ones beside them are enough (the whole diagram: 0.6 s of a 48k-vertex tree)
    un = inside & ~reached
    m = inside[Gc.row] & inside[Gc.col] & (un[Gc.row] | un[Gc.col])
    r, c = Gc.row[m], Gc.col[m]
    # (co-spherical tetrahedra share a circumcentre: their edge still connects, as in the centre lines' graph)
    d = np.maximum(np.linalg.norm(cc[r] - cc[c], axis=1), tol.MEDIAL_MIN_EDGE_COST * np.minimum(R[r], R[c]))
    GE = sp.csr_matrix((d, (r, c)), shape=G.shape)
    border = np.unique(np.concatenate([r[reached[r]], c[reached[c]]]))
    if not len(border):
        return np.full(len(cc), np.inf), np.full(len(cc), -9999)
    dist, pred, _ = dijkstra(GE, directed=True, indices=border, min_only=True, return_predecessors=True)
    return dist, pred


def _end_beyond(pm, cc, R, pred, k, graph, h, dE_k, from_wall, normals):
    """The rounded end where the way to Voronoi vertex ``k`` meets the surface past it, or None (no surface met,
    no end read there, or a sac's dome: logged)."""
    # the way's direction over the last radius
    b, walked = k, 0.0
    while walked < R[k] and pred[b] >= 0:
        walked += float(np.linalg.norm(cc[pred[b]] - cc[b]))
        b = int(pred[b])
    u = cc[k] - cc[b]
    if not np.linalg.norm(u) > 0:
        return None
    V = pm.V
    used = np.flatnonzero(pm.topology.referenced)
    hit = _surface_ahead(pm, cc[k], u / np.linalg.norm(u), tol.MISSED_SEARCH * R[k], h)
    rec = None
    for _ in range(tol.MISSED_RECENTRE + 1):  # read, then again from where the read end's own axis meets the surface
        if hit is None:
            break
        tip = _farthest_near(V, used, hit, tol.MISSED_SEARCH * R[k], from_wall)
        if rec is not None and tip == rec["tip"]:
            break
        where = f"at {np.round(hit, 3).tolist()}"
        rec = _read_end(pm, graph, tip, h, dE_k, normals) or rec
        if rec is None:
            break
        hit = _surface_ahead(pm, np.asarray(rec["center"], np.float64), np.asarray(rec["direction"], np.float64),
                             tol.MISSED_SEARCH * float(rec["radius"]), h)
    if rec is None:
        log.info("the lumen runs on %.3g past the centre lines to the surface, where no end is read", R[k])
        return None
    tube, narrowed = own_tube(V, graph, rec, h, why=True)
    log.debug("missed end read at %s: radius %.4g, tube %.4g radii behind it, narrowed %s", where, rec["radius"],
              tube, narrowed)
    if tube < tol.ENDS_SAC_TUBE_RADII and (narrowed or tube < tol.MISSED_MIN_TUBE):
        log.info("the lumen runs on past the centre lines to a dome of radius %.4g %s whose tube goes on for %.2g "
                 "radii only%s: a sac, not a vessel end", rec["radius"], where, tube,
                 " and narrows" if narrowed else "")
        return None
    sac = _a_known_sac(pm, rec, tube)
    if sac:
        log.info("the lumen runs on past the centre lines to a dome of radius %.4g %s: %s, not a vessel end",
                 rec["radius"], where, sac)
        return None
    scale = bbox_diagonal(V[used])
    end = _make_end(_Nearby(V), "rounded", _ordered_ring(V, rec), _beyond(V, graph, rec), rec["center"],
                    rec["direction"], scale)
    return replace(end, radius=float(rec["radius"]))


def _a_known_sac(pm, rec, tube):
    """Why the dome read (``rec``, its tube ``tube`` radii long) is a blind sac by :func:`vesselgp.vessel_ends`' own
    rule, or "": it is the dome of a sac that function found (its centre within that sac's radius of the sac's), or
    it is wider than ``tolerances.ENDS_SAC_RATIO`` times every open or capped end on a tube shorter than
    ``ENDS_SAC_TUBE_RADII`` (a closed tube capped flat with an aneurysm on its side: the sac left out by the end
    tests was found again here and made the tree's root)."""
    c, r = np.asarray(rec["center"], np.float64), float(rec["radius"])
    for centre, _, radius in pm.sacs:
        if np.linalg.norm(c - centre) <= max(radius, r):
            return f"the blind sac the end tests found (radius {radius:.4g})"
    cut = [e.radius for e in pm.ends if e.kind in ("open", "cap")]
    if cut and r > tol.ENDS_SAC_RATIO * max(cut) and tube < tol.ENDS_SAC_TUBE_RADII:
        return (f"wider than {tol.ENDS_SAC_RATIO:g} times every open or capped end (the widest {max(cut):.4g}) on a "
                f"tube of {tube:.2g} radii only: a blind sac")
    return ""


def _beyond(V, graph, rec):
    """The end's region: the surface beyond its centre's plane, within ``tolerances.MISSED_REGION`` of its radii of
    the tip along the surface: a dome's vertices, or a cap's and the stretch of wall between it and the centre
    read ``0.6-0.8`` radii inside it (with the dome's half radius only, the rest of a flat cap was judged as wall,
    and the axis named off its centre there)."""
    R = float(rec["radius"])
    g = dijkstra(graph, directed=False, indices=int(rec["tip"]), limit=tol.MISSED_REGION * R)
    near = np.flatnonzero(np.isfinite(g))
    ahead = (V[near] - np.asarray(rec["center"], np.float64)) @ np.asarray(rec["direction"], np.float64) >= 0.0
    return np.union1d(near[ahead], np.asarray(rec["region"], np.int64))


def _from_the_wall(V, graph, used, balls):
    """Each vertex's distance along the surface from the wall the lines' spheres ``balls`` reach, (n,) float64 (inf
    where none is reached)."""
    wall = used[within_balls(V[used], *balls)]
    if not len(wall):
        return np.full(len(V), np.inf)
    return dijkstra(graph, directed=False, indices=wall, min_only=True)


def _farthest_near(V, used, hit, reach, g):
    """The surface vertex within ``reach`` of the point ``hit`` farthest along the surface from the reached wall
    (``g``, :func:`_from_the_wall`): a flat cap's centre (the rim is nearer), a dome's pole."""
    d = np.linalg.norm(V[used] - hit, axis=1)
    near = used[d <= reach]
    if not len(near):
        return int(used[np.argmin(d)])
    far = np.where(np.isfinite(g[near]), g[near], -1.0)
    if not (far >= 0).any():
        return int(used[np.argmin(d)])
    return int(near[int(np.argmax(far))])


def _surface_ahead(pm, p, u, reach, h):
    """The first point outside the surface from ``p`` along the unit ``u`` in steps of half an edge ``h``, within
    ``reach``; None when there is none."""
    t = np.arange(1, int(np.ceil(reach / (0.5 * h))) + 1) * (0.5 * h)
    Q = p + t[:, None] * u
    out = np.flatnonzero(np.abs(pm.winding.winding(Q)) < 0.5)
    return Q[out[0]] if len(out) else None


def _read_end(pm, graph, tip, h, reach, normals):
    """The end read from the surface about vertex ``tip``: a rounded tip's test first (:func:`_tip`, recentred on
    its dome's pole; ``normals`` the faces' unit normals and twice their areas), else the rings' crossing from a
    dome or a disk into the tube (:func:`_crossing_end`)."""
    V, F = pm.V, pm.checked.faces
    rec = _tip(V, (F, *normals), graph, tip, reach, h)
    if rec is not None and rec.get("tube", True):
        return rec
    return _crossing_end(V, graph, tip, h)
