"""Rounded (hemispherical) tips for :func:`vesselgp.vessel_ends`.

A tip is where the surface ends in a dome: a local maximum of the geodesic
distance ``D`` from the other ends (open loops and caps; on a closed surface
without them, from one extremity found by a double sweep) around which the
geodesic rings close in to a point like those of a hemisphere.

1. **Candidates.** Every vertex climbs to its highest neighbour until it
   reaches a local maximum of ``D`` (ties broken by vertex id); the maxima's
   basins and the highest saddle between each pair of basins give the
   persistence of each maximum (how far ``D`` falls before its superlevel
   component joins an older one). A tip's persistence is at least its dome
   and the tube behind it; maxima below
   ``tolerances.ENDS_TIP_MIN_PERSISTENCE`` median edges are noise on a
   ridge of ``D`` (the middle of an open tube) and are not examined. A
   junction's saddle is not a maximum.
2. **Hemisphere test.** Rings of geodesic distance ``d`` from the candidate
   (edge-graph Dijkstra, bands one median edge wide) have centroid ``C(d)``
   and mean radius ``rho(d)``. On a hemisphere of radius ``R`` capping a tube,
   ``rho = R sin(d / R)`` up to the equator (``d = pi R / 2``, where
   ``rho = 2 d / pi``; from there on ``rho < 2 d / pi`` for
   ``tolerances.ENDS_TIP_CROSS_RINGS`` rings and more) and ``rho = R``
   after it, while the centroids of the tube's rings run down its axis at
   unit speed. The candidate is a tip only if

   * every ring (up to ``tolerances.ENDS_TIP_TUBE_RADII`` radii past the
     equator, and at least ``tolerances.ENDS_TIP_TUBE_RINGS`` rings: a thin
     tip a few edges across needs them for a stable axis) is a planar circle (``ENDS_TIP_RING_ASPECT``,
     ``ENDS_TIP_RING_FLATNESS``),
   * the tube's ring centroids move at about unit speed on a line, its rings
     are round and of radius ``R``, and the dome's rings follow
     ``R sin(d / R)`` (``ENDS_TIP_SPEED_TOL``, ``ENDS_TIP_LINE_TOL``,
     ``ENDS_TIP_RADIUS_TOL``, ``ENDS_TIP_ROUND_TOL``),
   * the tube's face normals are all across one axis (``ENDS_TIP_AXIS_SPREAD``)
     and the candidate lies on that axis seen from the end's centre
     (``ENDS_TIP_AXIS_DEG``).

   A point on the wall of a tube (its rings wrap round the tube and split in
   two, their centroid stays put), a sphere (rings shrink past the equator)
   or a junction (rings split into branches) fail; the checks overlap, so
   one of them failing on a noisy tip is not enough to miss a clean one.
   The end's radius is ``R`` (the tube's) and its direction the tube's axis.
   Its centre is the centre of the dome's best-fit sphere when that sphere's
   radius is the tube's (``ENDS_TIP_RADIUS_TOL``: a hemisphere); a dome
   flatter or more pointed than that (0.3 to 2.8 radii tall; a real one may
   also be lobed or oblique: how closely it fits its sphere is not asked) is
   a tip all the same, centred a radius in from its tip on the rings' axis.
   The candidate (a maximum of ``D``) lies off the pole of a side branch that
   leaves its vessel at a wide angle, and its rings are then oblique on the
   tube: when only the tube or pole checks fail, the test is repeated once
   from the vertex where the rings' axis leaves the dome. The Dijkstra radius grows from
   ``tolerances.ENDS_TIP_START_EDGES`` median edges by
   ``tolerances.ENDS_TIP_GROWTH`` until the test can decide, so the cost is
   that of the dome and a radius of tube (a few times more for the ridge in
   the middle of a short open tube).

When fewer than two ends pass these tests (a closed tube too noisy for its
caps or domes to be recognised), :func:`extreme_tips` takes the extremes of a
double geodesic sweep as rounded ends, as vesselgp did before trees: the end's
centre is where the rings about the extreme stop widening like a
hemisphere's.
"""
from __future__ import annotations

import logging
import math

import numpy as np
from scipy.sparse.csgraph import dijkstra

from .. import tolerances as tol

__all__ = ["find_tips", "extreme_tips", "own_tube", "persistent_maxima"]

log = logging.getLogger(__name__)


def find_tips(V, F, N, A, G, E, h, sources, used):
    """Rounded tips of the surface.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    N : (m, 3) float64
        Unit face normals.
    A : (m,) float64
        Twice the face areas.
    G : (n, n) scipy.sparse.csr_array
        Symmetric edge-length graph.
    E : (e, 2) int64
        Its edges, each once.
    h : float
        Median edge length (> 0).
    sources : (s,) int64
        Vertices of the ends found so far (open loops, caps); may be empty.
    used : (n,) bool
        Vertices referenced by a face.

    Returns
    -------
    tips : list of dict
        Keys ``tip`` (vertex id), ``ring`` (k,) int64 (vertices at the
        equator's distance), ``region`` (j,) int64 (within
        ``tolerances.ENDS_ROUNDED_REGION`` radii of the tip), ``center``,
        ``direction`` (outward unit) and ``radius``.
    """
    extra = []
    if len(sources):
        D = dijkstra(G, indices=sources, min_only=True)
    else:  # double sweep: the farthest point from a far point is an extremity
        idx = np.flatnonzero(used)
        start = int(idx[np.argmax(np.linalg.norm(V[idx] - V[idx].mean(axis=0), axis=1))])
        g = dijkstra(G, indices=start)
        a = int(np.argmax(np.where(np.isfinite(g), g, -1.0)))
        D = dijkstra(G, indices=a)
        extra = [(a, math.inf)]
    cands = extra + persistent_maxima(G, E, D, used)
    tips = []
    tested = 0
    for p, pers in _worth_examining(cands, h):
        if _on_a_tip(V[p], tips):
            continue  # another maximum on a dome already found
        tested += 1
        tip = _tip(V, (F, N, A), G, p, pers, h)
        if tip is not None:
            tips.append(tip)
    log.debug("tips: %d maxima, %d examined, %d tips", len(cands), tested, len(tips))
    return tips


def _worth_examining(cands, h):
    """The maxima ``cands`` (vertex, persistence) whose persistence is at least
    ``tolerances.ENDS_TIP_MIN_PERSISTENCE`` median edges ``h``: a lower one is noise on a ridge."""
    return [(p, pers) for p, pers in cands if pers >= tol.ENDS_TIP_MIN_PERSISTENCE * h]


def _on_a_tip(x, tips):
    """Whether the point ``x`` (3,) is closer than ``tolerances.ENDS_TIP_SEPARATION`` radii to the centre
    of one of the ``tips`` found (records of :func:`find_tips`)."""
    return any(np.linalg.norm(x - t["center"]) < tol.ENDS_TIP_SEPARATION * t["radius"] for t in tips)


def persistent_maxima(G, E, D, used):
    """Local maxima of ``D`` on the graph with their persistence, most persistent first.

    Values are ordered by ``(D, vertex id)``: ties go to the larger id. Every vertex climbs to
    its highest neighbour (steepest ascent) and the maxima's basins come out of pointer jumping;
    the highest edge between two basins (its lower end) is their saddle, and basins merge at
    their saddles from the highest down, the younger maximum dying there (elder rule). This is
    0-dimensional persistence of the superlevel sets; no vertex is sorted but the saddles'.

    Parameters
    ----------
    G : (n, n) scipy.sparse.csr_array
        Symmetric graph (its pattern gives the neighbours).
    E : (e, 2) int64
        Its edges, each once.
    D : (n,) float64
        A function on the vertices (infinite values are left out).
    used : (n,) bool
        Vertices taken into account.

    Returns
    -------
    list of (int, float)
        Vertex of each maximum and its persistence (``inf`` for the highest of
        each connected piece), sorted by decreasing persistence, then vertex.
    """
    valid = used & np.isfinite(D)
    if not valid.any():
        return []
    up = _climb(G, D, valid)
    root = up
    while True:  # pointer jumping to each vertex's maximum
        nxt = root[root]
        if np.array_equal(nxt, root):
            break
        root = nxt
    maxima = np.flatnonzero(valid & (up == np.arange(len(D))))
    pers = _merge(E, D, valid, root, maxima)
    out = sorted(zip(maxima.tolist(), pers.tolist()), key=lambda t: (-t[1], t[0]))
    return out


def _climb(G, D, valid):
    """Highest neighbour of each valid vertex, by ``(D, id)``, if above it, else the vertex itself: (n,) int64."""
    n = len(D)
    indptr, nb = G.indptr, G.indices
    Dn = np.where(valid, D, -np.inf).take(nb)
    deg = np.diff(indptr)
    nz = deg > 0
    top = np.full(n, -np.inf)
    best = np.full(n, -1, dtype=np.int64)
    if nz.any():
        starts = indptr[:-1][nz]
        top[nz] = np.maximum.reduceat(Dn, starts)
        # the largest id among the neighbours at that value (ties go to the larger id); a vertex
        # with no valid neighbour has top = -inf and never climbs
        best[nz] = np.maximum.reduceat(np.where(Dn == np.repeat(top, deg), nb, -1), starts)
    up = np.arange(n)
    climb = valid & ((top > D) | ((top == D) & (best > up)))
    up[climb] = best[climb]
    return up


def _merge(E, D, valid, root, maxima):
    """Persistence of each maximum (elder rule over the basins' highest saddles)."""
    u, v = E[:, 0], E[:, 1]
    keep = (u != v) & valid[u] & valid[v]
    u, v = u[keep], v[keep]
    a, b = root[u], root[v]
    cross = a != b
    u, v = u[cross], v[cross]
    a, b = np.minimum(a[cross], b[cross]), np.maximum(a[cross], b[cross])
    # the saddle: the lower end of the crossing edge, by (D, id)
    s = np.where((D[u] < D[v]) | ((D[u] == D[v]) & (u < v)), u, v)
    if len(s):
        key = a.astype(np.int64) * len(D) + b
        srt = np.lexsort((-s, -D[s], key))  # per pair of basins, the highest saddle first
        first = np.ones(len(srt), dtype=bool)
        first[1:] = key[srt[1:]] != key[srt[:-1]]
        pick = srt[first]
        a, b, s = a[pick], b[pick], s[pick]
        o = np.lexsort((np.arange(len(s)), -s, -D[s]))  # the pairs from the highest saddle down
        a, b, s = a[o], b[o], s[o]
    parent = {int(m): int(m) for m in maxima}
    pers = {int(m): math.inf for m in maxima}

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for x, y, z in zip(a.tolist(), b.tolist(), s.tolist()):
        rx, ry = find(x), find(y)
        if rx == ry:
            continue
        young, old = (rx, ry) if (D[rx], rx) < (D[ry], ry) else (ry, rx)  # a set's root is its maximum
        pers[young] = float(D[young] - D[z])
        parent[young] = old
    return np.array([pers[int(m)] for m in maxima])


def _tip(V, faces, G, p, pers, h):
    """The rounded end at candidate ``p`` of persistence ``pers``, or None (see the module doc).

    The rings are followed at most ``tolerances.ENDS_TIP_REACH`` times the
    persistence away (a dome and its tube lie within the maximum's basin). A dome that closes in
    like a hemisphere on rings that are no round tube, from the candidate or from its pole, is
    returned as a record with ``tube`` False (a sac's dome, :func:`_dome_only`) when no tip is found.
    """
    cap = max(tol.ENDS_TIP_REACH * pers, tol.ENDS_TIP_START_EDGES * h)
    L = tol.ENDS_TIP_START_EDGES * h
    recentred, dome = False, None
    while True:
        L = min(L, cap)
        g = dijkstra(G, indices=int(p), limit=L)
        res = _hemisphere(V, faces, p, g, h, L)
        if isinstance(res, tuple):  # ("pole", q, dome): the rings' axis meets the dome at q, not at p
            dome = res[2] or dome  # a dome on no round tube, from this try or the first
            if recentred or res[1] == p:
                return dome
            log.debug("tip candidate %d: retried from the dome's pole %d", p, res[1])
            p, recentred = res[1], True
            continue
        if res != "more":
            return res or dome
        if L >= cap or _explored_all(G, g):
            return None
        L *= tol.ENDS_TIP_GROWTH


def _explored_all(G, g):
    """Whether a limited Dijkstra reached every vertex connected to its source."""
    inside = np.isfinite(g)
    sub = G[inside]  # rows of the explored vertices
    return bool(np.all(inside[sub.indices]))


def _rings(V, g, h, L):
    """Rings (bands one edge wide) of geodesic distance ``g`` below ``L``.

    Returns
    -------
    dict of arrays over the rings: ``d`` mean distance, ``n`` vertex count,
    ``C`` (k, 3) centroid, ``rho`` mean distance to the centroid, ``spread``
    standard deviation of that distance, ``eig`` (k, 3) eigenvalues of the
    points' scatter about the centroid (ascending); and ``band`` (n,) int64,
    the ring of each vertex (-1 outside).
    """
    sel = np.flatnonzero(g < L)  # (inf is never below L)
    b = np.floor(g[sel] / h).astype(np.int64)
    if math.isfinite(L):  # the last band may be cut by the limit
        full = (b + 1) * h <= L
        sel, b = sel[full], b[full]
    nb = int(b.max()) + 1 if len(b) else 0
    cnt = np.bincount(b, minlength=nb).astype(np.float64)
    safe = np.maximum(cnt, 1.0)
    C = np.stack([np.bincount(b, weights=V[sel, k], minlength=nb) for k in range(3)], axis=1) / safe[:, None]
    r = np.linalg.norm(V[sel] - C[b], axis=1)
    rho = np.bincount(b, weights=r, minlength=nb) / safe
    r2 = np.bincount(b, weights=r * r, minlength=nb) / safe
    X = V[sel] - C[b]
    S = np.empty((nb, 3, 3))
    for i in range(3):
        for j in range(i, 3):
            S[:, i, j] = S[:, j, i] = np.bincount(b, weights=X[:, i] * X[:, j], minlength=nb) / safe
    band = np.full(len(V), -1, dtype=np.int64)
    band[sel] = b
    return {"d": np.bincount(b, weights=g[sel], minlength=nb) / safe, "n": cnt, "C": C, "rho": rho,
            "spread": np.sqrt(np.maximum(r2 - rho * rho, 0.0)), "eig": np.linalg.eigvalsh(S), "band": band}


def _hemisphere(V, faces, p, g, h, L):
    """Fit and check a hemisphere-ended tube at ``p`` from the rings of ``g``.

    Returns the tip's record, None when the rings are not those of a tip,
    or ``"more"`` when rings farther than ``L`` are needed to decide.
    """
    rg = _rings(V, g, h, L)
    d, rho, C, n = rg["d"], rg["rho"], rg["C"], rg["n"]
    valid = n >= tol.ENDS_MIN_RING
    valid[:1] = False  # the tip's own band
    cross = _crossing(valid, rho <= 2.0 * d / np.pi)
    before = np.flatnonzero(valid[:cross[0] if len(cross) else len(valid)])
    if not _circles(rg["eig"][before[before >= tol.ENDS_TIP_FIRST_RING]], h):
        return None  # the rings about p are not circles closing in on it (a tube's wall, a junction)
    if len(cross) == 0:
        return "more"
    R = float(rho[cross[0]])
    for _ in range(2):  # the equator's distance, then the radius of the tube past it
        dstar = 0.5 * np.pi * R
        far = dstar + max(tol.ENDS_TIP_TUBE_RADII * R, tol.ENDS_TIP_TUBE_RINGS * h)
        if far > L:
            return "more"
        tube = np.flatnonzero(valid & (d >= dstar) & (d <= far))
        if len(tube) < 2:
            return None
        R = float(np.average(rho[tube], weights=n[tube]))
    fit = _axis_fit(d[tube], C[tube], n[tube], dstar)
    if fit is None:
        return None
    if not _is_tube(rg, valid, tube, fit, R, dstar, h) or not _circles(rg["eig"][tube], h):
        return _pole(V, g, fit, R, dstar, _dome_only(V, rg, valid, p, g, fit, R, dstar, h))
    dome = np.flatnonzero(g <= tol.ENDS_TIP_DOME_TO * dstar)
    center, Rs, rms = _sphere_fit(V[dome])
    F, N, A = faces
    band = (g >= dstar) & (g <= far)
    walls = band[F[:, 0]] & band[F[:, 1]] & band[F[:, 2]]  # (no (m, 3) gather and row reduction)
    axis, flatness = _cylinder_axis(N[walls], A[walls])
    c0 = fit[0]  # the rings' axis at the equator's distance
    if axis @ (V[p] - c0) < 0:
        axis = -axis
    if abs(Rs - R) > tol.ENDS_TIP_RADIUS_TOL * R:
        # a dome flatter or more pointed than a hemisphere (its sphere's radius is not the tube's, and
        # nor is its centre where the tube ends): the centre is a radius in from the tip on the rings' axis
        center = c0 + ((V[p] - c0) @ axis - R) * axis
    u = V[p] - center
    lu = float(np.linalg.norm(u))
    log.debug("tip candidate %d: R %.4g, sphere %.4g (rms %.2g R), axis flatness %.2g, pole %.1f deg",
              p, R, Rs, rms / R, flatness, np.degrees(np.arccos(np.clip(u @ axis / max(lu, 1e-300), -1, 1))))
    if not _walls_across_one_axis(flatness):
        return None  # not a dome on a tube
    if not _on_axis(u, axis):
        return _pole(V, g, fit, R, dstar)  # not on the tube's axis seen from the dome: retry from its pole
    ring = np.flatnonzero(rg["band"] == tube[0])
    region = np.flatnonzero(g <= tol.ENDS_ROUNDED_REGION * R)
    return {"tip": int(p), "ring": ring, "region": region, "center": center, "direction": axis, "radius": R,
            "tube": True}


def _dome_only(V, rg, valid, p, g, fit, R, dstar, h):
    """A dome on rings that are no round tube (a sac's: its body is no tube, and may be oval or lobed),
    as a record like a tip's with ``tube`` False, or None.

    The rings' centroids run down a line at about unit speed and the dome's rings close in like a
    hemisphere's (the first and last checks of :func:`_is_tube`); the rings past the equator need
    not be round. Its centre is a radius in from the tip on the rings' axis, its direction that axis.
    Such a dome is never a vessel's end: :func:`vesselgp.mesh.ends._without_sacs` takes it for a blind
    sac when it is wider than every cut end, and drops it otherwise (issue #44: the gmsh intracranial
    aneurysm's sac, 24 mm deep, oval behind its dome, was not found and its wall had no description).
    """
    if not _is_dome(rg, valid, fit, R, dstar, h):
        return None
    c0, out = fit[0], fit[1]
    center = c0 + ((V[p] - c0) @ out - R) * out
    ring = np.flatnonzero(rg["band"] == np.flatnonzero(valid & (rg["d"] >= dstar))[0])
    region = np.flatnonzero(g <= tol.ENDS_ROUNDED_REGION * R)
    return {"tip": int(p), "ring": ring, "region": region, "center": center, "direction": out, "radius": R,
            "tube": False}


def _pole(V, g, fit, R, dstar, dome=None):
    """``("pole", q, dome)``: the explored vertex nearest to where the rings' axis leaves the dome
    (and the record of :func:`_dome_only`, or None).

    The maximum of the geodesic distance from the other ends lies off the dome's
    pole on a side branch leaving its vessel at a wide angle; its rings are then
    oblique on the tube. The tip test is repeated once from ``q``.
    """
    c, out, _, _ = fit
    P = c + R * out  # ``c`` is the ring centroid at the equator's distance: the dome's centre
    near = np.flatnonzero(np.isfinite(g))
    return ("pole", int(near[np.argmin(np.linalg.norm(V[near] - P, axis=1))]), dome)


def _crossing(valid, narrow):
    """Rings where the rings stay narrower than a hemisphere's: (k,) int64, ascending.

    A ring counts when it and the next ``tolerances.ENDS_TIP_CROSS_RINGS - 1``
    valid rings are all narrow (a noisy ring near the tip may be narrow alone).
    """
    idx = np.flatnonzero(valid)
    ok = narrow[idx]
    k = tol.ENDS_TIP_CROSS_RINGS
    if len(idx) < k:
        return np.zeros(0, dtype=np.int64)
    run = np.lib.stride_tricks.sliding_window_view(ok, k).all(axis=1)
    return idx[:len(run)][run]


def _sphere_fit(P):
    """Least-squares sphere (algebraic fit) through points (k, 3): centre, radius, rms residual."""
    m = P.mean(axis=0)
    Q = P - m
    M = np.c_[2.0 * Q, np.ones(len(Q))]
    sol = np.linalg.lstsq(M, np.einsum("ij,ij->i", Q, Q), rcond=None)[0]
    c = sol[:3]
    r = float(np.sqrt(max(sol[3] + c @ c, 0.0)))
    rms = float(np.sqrt(np.mean((np.linalg.norm(Q - c, axis=1) - r) ** 2)))
    return c + m, r, rms


def _cylinder_axis(N, w):
    """Axis of a tube from its unit face normals (k, 3) and weights (k,): the direction
    they are all across.

    Returns the unit axis and the ratio of the smallest to the middle
    eigenvalue of the normals' weighted scatter (0 on a cylinder).
    """
    w, U = np.linalg.eigh((N * w[:, None]).T @ N)
    return U[:, 0], float(w[0] / max(w[1], 1e-300))


def _walls_across_one_axis(flatness):
    """Whether a tube's face normals, with scatter ratio ``flatness`` (:func:`_cylinder_axis`), are all
    across one axis: at most ``tolerances.ENDS_TIP_AXIS_SPREAD`` (a cone of half-angle phi has
    ``2 tan(phi)**2``: the edge is phi = 21.2 degrees)."""
    return flatness <= tol.ENDS_TIP_AXIS_SPREAD


def _on_axis(u, axis):
    """Whether the tip, at ``u`` (3,) from the end's centre, lies within ``tolerances.ENDS_TIP_AXIS_DEG``
    of the unit ``axis`` (3,)."""
    return bool(u @ axis >= np.cos(np.radians(tol.ENDS_TIP_AXIS_DEG)) * float(np.linalg.norm(u)))


def _axis_fit(d, C, w, dstar):
    """Least-squares line ``C(d) = c0 + d b`` of the tube rings' centroids.

    Returns (centre at ``dstar``, outward unit axis ``-b / |b|``, speed ``|b|``,
    weighted rms residual), or None if the centroids do not move.
    """
    W = w / w.sum()
    dm = W @ d
    Cm = W @ C
    var = W @ (d - dm) ** 2
    if not var > 0:
        return None
    b = (W * (d - dm)) @ (C - Cm) / var
    speed = float(np.linalg.norm(b))
    if not speed > 0:
        return None
    res = C - (Cm + np.outer(d - dm, b))
    resid = float(np.sqrt(W @ np.einsum("ij,ij->i", res, res)))
    return Cm + (dstar - dm) * b, -b / speed, speed, resid


def _is_tube(rg, valid, tube, fit, R, dstar, h):
    """The ring checks of the module doc, with the tolerances ``ENDS_TIP_*``: the line and the roundness
    each with ``ENDS_TIP_EDGE_SLACK`` median edges ``h`` of slack (a tip a few edges across has rings as
    ragged as its edges: the 32-tip vein tree meshed at 3 voxels across its tips lost two of them)."""
    rho, spread = rg["rho"], rg["spread"]
    slack = _edge_slack(h)
    if np.any(np.abs(rho[tube] - R) > tol.ENDS_TIP_RADIUS_TOL * R) or np.any(
            spread[tube] > tol.ENDS_TIP_ROUND_TOL * rho[tube] + slack):
        return False  # the rings past the equator are not the round sections of a tube
    return _is_dome(rg, valid, fit, R, dstar, h)


def _is_dome(rg, valid, fit, R, dstar, h):
    """The ring checks of :func:`_is_tube` but the roundness of the tube's rings: their centroids run
    down a line at about unit speed, and the dome's rings close in like a hemisphere's."""
    d, rho = rg["d"], rg["rho"]
    _, _, speed, resid = fit
    if abs(speed - 1.0) > tol.ENDS_TIP_SPEED_TOL or resid > tol.ENDS_TIP_LINE_TOL * R + _edge_slack(h):
        return False  # the rings' centroids do not run down an axis
    dome = np.flatnonzero(valid & (d >= tol.ENDS_TIP_DOME_FROM * dstar) & (d <= tol.ENDS_TIP_DOME_TO * dstar))
    if len(dome) and np.any(np.abs(rho[dome] - R * np.sin(d[dome] / R)) > tol.ENDS_TIP_RADIUS_TOL * R):
        return False  # the dome's rings do not close in like a hemisphere's
    return True


def _edge_slack(h):
    """The slack of the line and roundness checks: ``ENDS_TIP_EDGE_SLACK`` median edges ``h``."""
    return tol.ENDS_TIP_EDGE_SLACK * h


def _circles(eig, h):
    """Whether rings with scatter eigenvalues ``eig`` (k, 3) (ascending) are planar circles.

    The two larger eigenvalues must be within ``tolerances.ENDS_TIP_RING_ASPECT``
    of each other, and the smallest below ``tolerances.ENDS_TIP_RING_FLATNESS``
    of the largest plus :func:`_band_variance` (a band one edge ``h`` wide is
    about that thick).
    """
    if len(eig) == 0:
        return True
    return not (np.any(eig[:, 1] < tol.ENDS_TIP_RING_ASPECT * eig[:, 2])
                or np.any(eig[:, 0] > tol.ENDS_TIP_RING_FLATNESS * eig[:, 2] + _band_variance(h)))


def _band_variance(h):
    """The variance across a ring of its band's thickness: a band one median edge ``h`` wide holds mesh
    vertices up to ``tolerances.ENDS_TIP_BAND_EDGES`` edges apart along the tube, uniformly: ``(k h)^2 / 12``."""
    return (tol.ENDS_TIP_BAND_EDGES * h) ** 2 / 12.0


def own_tube(V, G, tip, h, why=False):
    """How far a tip's dome goes on as a tube of its own, in its radii past the dome's equator.

    The geodesic rings from the tip's vertex are followed past the equator (``pi R / 2``) while each
    is planar (:func:`_circles`' flatness), round (the two larger eigenvalues of its scatter within
    ``tolerances.ENDS_SAC_TUBE_ASPECT``), no narrower than ``1 - ENDS_SAC_TUBE_NARROWING`` of the
    dome's ``R`` (wider is the vessel's own bulb or sinus) and its centroid moves on, away from the
    equator's ring; the tube ends between its last ring and the first that is not (where their radius
    crosses the narrowing's floor, else half way), or at ``ENDS_SAC_TUBE_RADII`` and a half radii,
    the most looked at. A vessel's rounded end goes on as its vessel; a sac's
    sphere narrows to 0.75 R within ``R arccos(0.75)`` = 0.72 R past its equator, and its rings then
    close on the neck or break up on the parent's wall (a junction's rings are not round).

    Parameters
    ----------
    V : (n, 3) float64
    G : (n, n) sparse
        The edge-length graph.
    tip : dict
        A record of :func:`find_tips` (``tip``, ``radius``).
    h : float
        Median edge length.
    why : bool
        Also say whether the tube stopped where it narrowed (a sac's neck), rather than where its rings
        stopped being round or moving on (a junction behind a short vessel's end; :mod:`vesselgp.missed_ends`).

    Returns
    -------
    float
        The tube's length past the equator, in radii.
    narrowed : bool
        Only with ``why``: whether the first ring past the tube is narrower than its floor.
    """
    length, narrowed = _own_tube(V, G, tip, h)
    return (length, narrowed) if why else length


def _own_tube(V, G, tip, h):
    """:func:`own_tube`'s length and whether the tube stopped where it narrowed."""
    R = float(tip["radius"])
    dstar = 0.5 * np.pi * R
    L = dstar + (tol.ENDS_SAC_TUBE_RADII + 0.5) * R + 2 * h
    rg = _rings(V, dijkstra(G, indices=int(tip["tip"]), limit=L), h, L)
    d, rho, C, n, eig = rg["d"], rg["rho"], rg["C"], rg["n"], rg["eig"]
    past = np.flatnonzero((n >= tol.ENDS_MIN_RING) & (d >= dstar))
    if not len(past):
        return 0.0, False
    e = eig[past]
    ok = ((rho[past] >= (1.0 - tol.ENDS_SAC_TUBE_NARROWING) * R) & (e[:, 1] >= tol.ENDS_SAC_TUBE_ASPECT * e[:, 2])
          & (e[:, 0] <= tol.ENDS_TIP_RING_FLATNESS * e[:, 2] + _band_variance(h)))
    ok &= np.r_[True, np.einsum("ij,ij->i", np.diff(C[past], axis=0), C[past][1:] - C[past][0]) > 0]  # moving on
    if ok.all():
        return float((d[past[-1]] + h - dstar) / R), False
    stop = int(np.argmin(ok))
    floor = (1.0 - tol.ENDS_SAC_TUBE_NARROWING) * R
    narrowed = bool(rho[past[stop]] < floor)
    if stop == 0:
        return 0.0, narrowed
    a, b = past[stop - 1], past[stop]  # the tube's last ring and the first that is not
    t = (rho[a] - floor) / (rho[a] - rho[b]) if rho[b] < floor < rho[a] else 0.5  # where it narrows past the floor
    return float(max(d[a] + t * (d[b] - d[a]) - dstar, 0.0) / R), narrowed


def extreme_tips(V, G, h, sources, used):
    """The extremes of a double geodesic sweep as rounded ends, unchecked (the fallback).

    Parameters are those of :func:`find_tips` (``sources`` may be empty).

    Returns
    -------
    tips : list of dict
        As :func:`find_tips`, for the farthest vertex from ``sources`` (and,
        without sources, for the extreme the sweep starts from), where a ring
        narrower than a hemisphere's is found.
    """
    starts = []
    if len(sources):
        g = dijkstra(G, indices=sources, min_only=True)
    else:
        idx = np.flatnonzero(used)
        start = int(idx[np.argmax(np.linalg.norm(V[idx] - V[idx].mean(axis=0), axis=1))])
        g = dijkstra(G, indices=start)
        a = int(np.argmax(np.where(np.isfinite(g), g, -1.0)))
        starts = [a]
        g = dijkstra(G, indices=a)
    b = int(np.argmax(np.where(np.isfinite(g), g, -1.0)))
    return [t for t in (_crossing_end(V, G, p, h) for p in starts + [b]) if t is not None]


def _crossing_end(V, G, tip, h):
    """Rounded end at ``tip`` from the first ring narrower than a hemisphere's, or None.

    On a hemisphere of radius R the ring at geodesic distance d has radius
    R sin(d/R) > 2d/pi until the equator (d = pi R / 2), on the tube R < 2d/pi;
    R is the first such ring's radius and the centre the rings' centroid
    interpolated at the equator's distance.
    """
    g = dijkstra(G, indices=int(tip))
    rg = _rings(V, g, h, math.inf)
    d, rho, C = rg["d"], rg["rho"], rg["C"]
    valid = np.flatnonzero(rg["n"] >= tol.ENDS_MIN_RING)
    cross = valid[rho[valid] <= 2.0 * d[valid] / np.pi]
    if len(cross) == 0 or not rho[cross[0]] > 0:
        return None
    R = float(rho[cross[0]])
    dstar = 0.5 * np.pi * R
    center = np.array([np.interp(dstar, d[valid], C[valid, k]) for k in range(3)])
    ring = np.flatnonzero(rg["band"] == valid[np.argmin(np.abs(d[valid] - dstar))])
    direction = V[tip] - center
    u = V[ring] - center
    lu = float(np.linalg.norm(direction))
    if not lu > 0 or not np.any(np.linalg.norm(u - np.outer(u @ direction, direction) / lu**2, axis=1) > 0):
        return None  # the ring lies on the axis line: no tube here
    region = np.flatnonzero(g <= tol.ENDS_ROUNDED_REGION * R)
    radius = float(np.linalg.norm(u, axis=1).mean())
    return {"tip": int(tip), "ring": ring, "region": region, "center": center,
            "direction": direction / lu, "radius": radius, "tube": True}
