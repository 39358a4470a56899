"""Centre lines on the internal Voronoi diagram: the lumen's medial paths between ends (issue #34).

The Eq. 1-5 fixed point refines an axis from a good start; on a real tree it needs to
know, before any fit, which end hangs off which junction and roughly where the lumen runs
through junction zones, sacs and bulbs. :func:`centerlines` gives that the way VMTK does
(Antiga et al. 2003, "Computational geometry for patient-specific reconstruction and
meshing of blood vessels from MR and CT angiography"):

1. **Voronoi diagram.** The Delaunay tetrahedra of surface points (TetGen through libigl,
   :func:`igl.copyleft.tetgen.tetrahedralize` with no surface: the points' Delaunay tetrahedralisation,
   exact predicates; the same tetrahedra as qhull's on every real mesh, 6-8x faster, issue #47)
   have their circumcentres at the Voronoi vertices. The points are
   the surface's vertices; beyond ``tolerances.MEDIAL_ALL_POINTS`` of them, thinned to a spacing of
   ``tolerances.MEDIAL_SAMPLE_RADII`` local radii (:func:`_medial_sample`): the Voronoi diagram
   approximates the medial axis when the sampling is dense against the local feature size (Amenta,
   Choi and Kolluri 2001), so a thin branch keeps all its vertices and a wide trunk a few hundred,
   and the tessellation of a large mesh costs what the lumen's shape needs rather than what the
   mesh's resolution gives (issue #47). Those inside the surface
   (generalized winding number of the surface, its open ends closed by fans, above 1/2)
   approximate its medial axis, and each circumradius is the radius of a maximal sphere
   inscribed in the lumen (VMTK's ``MaximumInscribedSphereRadius``).
2. **Minimal paths.** Two inside Voronoi vertices of face-adjacent tetrahedra are joined by
   an edge of cost ``length / radius`` (the mean of its ends' radii): a path of least total
   cost, the integral of ``ds / R`` (VMTK's fast marching with speed ``R``, here Dijkstra on
   the diagram's own edges), keeps to the middle of the lumen, crosses a junction zone or a
   sac through its widest part and never leaves the surface.
   *1b.* On a tube only a few edges around, the tetrahedra across it can have their
   circumcentres outside its wall and the inside Voronoi vertices fall apart. When an end is not
   connected to the root through them, the tetrahedra of the same tessellation whose centroid
   is inside join as bridges (node at the centroid, radius its distance to the nearest
   corner: a costly step, taken only where nothing else connects). Only meshes that would
   otherwise be refused take this step, so the others' lines do not depend on how the tessellation splits
   co-spherical points into tetrahedra (centroids do, circumcentres do not).
3. **One source, every target.** One Dijkstra run from the root end's seed (the inside Voronoi
   vertex nearest its centre) gives the path to every other end; the paths form a tree.

Each line runs from the root end's centre to the tip's centre (both prepended/appended to the
Voronoi path) with the inscribed-sphere radius at each point, resampled and smoothed over about
one local radius (:func:`_smoothed`).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import igl
import igl.copyleft.tetgen
import numpy as np
from scipy.sparse import coo_matrix, diags
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from . import tolerances as tol
from .errors import NotTubularError, OptionError
from .mesh._geometry import closed_by_fans

log = logging.getLogger(__name__)

__all__ = ["Centerlines", "VoronoiDiagram", "centerlines"]


@dataclass(frozen=True)
class Centerlines:
    """Medial centre lines from a root end to every other end.

    Attributes
    ----------
    root : int
        Index of the root end.
    tips : tuple of int
        The other ends, in end order; line ``k`` runs from the root to ``tips[k]``.
    points : tuple of (k_i, 3) float64
        Each line, from the root end's centre to the tip's centre.
    radius : tuple of (k_i,) float64
        The radius of the largest sphere inside the lumen at each point (the ends' own
        radii at the two end centres).
    """

    root: int
    tips: tuple
    points: tuple
    radius: tuple


def _circumspheres(P, T):
    """Circumcentres and circumradii of tetrahedra ``T`` of points ``P``; radius inf where flat.

    ``x = (|b|^2 (c x d) + |c|^2 (d x b) + |d|^2 (b x c)) / (2 b . (c x d))`` relative to the
    first corner (``b, c, d`` the other corners' offsets), ``tolerances.MEDIAL_TET_CHUNK`` tetrahedra at a
    time (the temporaries of 2.7M at once made it twice as slow).
    """
    C, R = np.empty((len(T), 3)), np.empty(len(T))
    for a in range(0, len(T), tol.MEDIAL_TET_CHUNK):
        C[a:a + tol.MEDIAL_TET_CHUNK], R[a:a + tol.MEDIAL_TET_CHUNK] = _circumspheres_of(P, T[a:a + tol.MEDIAL_TET_CHUNK])
    return C, R


def _circumspheres_of(P, T):
    """:func:`_circumspheres` of one chunk."""
    a = P[T[:, 0]]
    PT = np.ascontiguousarray(P.T)  # component-major: the cross products on whole rows (2x faster than np.cross)
    aT = np.ascontiguousarray(a.T)
    b, c, d = PT[:, T[:, 1]] - aT, PT[:, T[:, 2]] - aT, PT[:, T[:, 3]] - aT
    cd, db, bc = _cross_rows(c, d), _cross_rows(d, b), _cross_rows(b, c)
    bb, cc, dd = (b * b).sum(axis=0), (c * c).sum(axis=0), (d * d).sum(axis=0)
    det = 2.0 * (b * cd).sum(axis=0)
    num = bb * cd + cc * db + dd * bc
    scale = np.maximum(np.maximum(bb, cc), dd) ** 1.5
    flat = np.abs(det) <= tol.MEDIAL_FLAT_TET * scale
    x = num / np.where(flat, 1.0, det)
    R = np.sqrt((x * x).sum(axis=0))
    R[flat] = np.inf
    return a + x.T, R


def _cross_rows(u, v):
    """Cross products of component-major vectors ``u``, ``v`` (3, n): (3, n) float64."""
    return np.stack([u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]])


def _lumen_radius(V, F, Vc, Fc, E):
    """Each vertex's radius of curvature across the lumen, (n,) float64 (inf where the wall is flat or convex
    outwards in every direction of its edges): for an edge ``e`` from a vertex with inward normal ``n`` the
    circle through both ends tangent to the wall there has radius ``|e|^2 / (2 e.n)`` (exact on a circular
    section); the least over the vertex's edges, the normals and then the log radii averaged over 1-rings
    ``tolerances.MEDIAL_RADIUS_SMOOTHING`` times. On a tube it is about 0.7 times its radius (marching-cubes
    surfaces, 1st-99th percentile 0.4-1.1): a density estimate, never a measurement."""
    n = len(V)
    i, j = np.concatenate([E[:, 0], E[:, 1]]), np.concatenate([E[:, 1], E[:, 0]])
    A = coo_matrix((np.ones(len(i)), (i, j)), shape=(n, n)).tocsr()
    A = A + diags(np.ones(n))
    mean = diags(1.0 / np.asarray(A.sum(axis=1)).ravel()) @ A
    N = igl.per_vertex_normals(V, F)
    volume = np.einsum("ij,ij->", Vc[Fc[:, 0]], np.cross(Vc[Fc[:, 1]], Vc[Fc[:, 2]]))
    if volume > 0:  # outward normals: turn them into the lumen
        N = -N
    for _ in range(tol.MEDIAL_RADIUS_SMOOTHING):
        N = mean @ N
        N /= np.maximum(np.linalg.norm(N, axis=1), np.finfo(float).tiny)[:, None]
    e = V[j] - V[i]
    across = 2.0 * np.einsum("ij,ij->i", e, N[i])
    length2 = np.einsum("ij,ij->i", e, e)
    bent = across > tol.MEDIAL_FLAT_TET * length2  # the wall bends into the lumen along this edge
    r = np.full(n, np.inf)
    np.minimum.at(r, i[bent], length2[bent] / across[bent])
    finite = np.isfinite(r)
    if not finite.any():
        return r
    logr = np.log(np.where(finite, r, r[finite].max()))
    for _ in range(tol.MEDIAL_RADIUS_SMOOTHING):
        logr = mean @ logr
    return np.exp(logr)


def _medial_sample(V, F, Vc, Fc):
    """Ids of the surface vertices the Voronoi diagram is built on, (k,) int64 sorted: every used vertex of
    a surface of at most ``tolerances.MEDIAL_ALL_POINTS``; of a larger one, at most one per cell of a grid
    whose cells are ``tolerances.MEDIAL_SAMPLE_RADII`` times the vertices' lumen radius
    (:func:`_lumen_radius`, binned by half octaves), laid in the surface's principal axes (so that a
    rigid motion of the mesh keeps the same points)."""
    used = np.zeros(len(V), bool)
    used[F.ravel()] = True
    if used.sum() <= tol.MEDIAL_ALL_POINTS:
        return np.flatnonzero(used)
    E = igl.edges(F)
    r = _lumen_radius(V, F, Vc, Fc, E)
    ids = np.flatnonzero(used)
    r = r[ids]
    if not np.isfinite(r).any():
        raise NotTubularError("the surface bends into no lumen anywhere (no vertex has an edge curving inwards); "
                              "is it flat or inside out? check it with vesselgp.clean_mesh")
    r = np.where(np.isfinite(r), r, r[np.isfinite(r)].max())
    X = V[ids] - V[ids].mean(axis=0)
    _, axes = np.linalg.eigh(X.T @ X)
    X = X @ axes
    X *= np.where(np.sum(X ** 3, axis=0) < 0, -1.0, 1.0)  # principal axes' signs from the skew
    level = np.floor(2.0 * np.log2(r)).astype(np.int64)
    keep = []
    for L in np.unique(level):
        m = np.flatnonzero(level == L)
        cell = np.floor(X[m] / (tol.MEDIAL_SAMPLE_RADII * 2.0 ** (0.5 * L))).astype(np.int64)
        cell -= cell.min(axis=0)  # one integer per cell: as np.unique(cell, axis=0), 10x faster
        key = np.ravel_multi_index(tuple(cell.T), tuple(cell.max(axis=0) + 1))
        keep.append(m[np.unique(key, return_index=True)[1]])
    return ids[np.sort(np.concatenate(keep))]


@dataclass(frozen=True)
class _Tetrahedra:
    """A Delaunay tetrahedralisation: corners ``simplices`` (t, 4) int64 into the points, and ``neighbors``
    (t, 4) int64, the tetrahedron across the face opposite each corner (-1 on the hull), as in
    :class:`scipy.spatial.Delaunay`."""

    simplices: np.ndarray
    neighbors: np.ndarray


def _delaunay(P):
    """The Delaunay tetrahedra of distinct points ``P`` (k, 3), a :class:`_Tetrahedra`.

    Raises :class:`NotTubularError` when the points span no volume (TetGen would fail on them, fewer than
    four or all on one plane, to ``tolerances.MEDIAL_FLAT_POINTS`` of their extent)."""
    X = P - P.mean(axis=0)
    sv = np.linalg.svd(X, compute_uv=False) if len(P) >= 4 else np.zeros(3)
    if len(P) < 4 or sv[2] <= tol.MEDIAL_FLAT_POINTS * sv[0]:
        raise NotTubularError(f"the surface's {len(P)} vertices span no volume (no 3-D Delaunay tessellation); "
                              "is the mesh flat? check it with vesselgp.clean_mesh")
    try:
        out = igl.copyleft.tetgen.tetrahedralize(P, flags="Qn")  # no surface: the points' Delaunay; neighbours
    except RuntimeError as exc:
        raise NotTubularError(f"the surface's {len(P)} vertices have no 3-D Delaunay tessellation (TetGen: {exc}); "
                              "is the mesh flat? check it with vesselgp.clean_mesh") from None
    TV, T, N = out[0], out[1], out[5]
    if len(TV) != len(P) or not len(T) or N.shape != T.shape:
        raise NotTubularError(f"the Delaunay tessellation of the surface's {len(P)} vertices kept {len(TV)} of them "
                              "(a point repeated); check the mesh with vesselgp.clean_mesh")
    return _Tetrahedra(T, N)


def _inside_voronoi(V, F, loops):
    """The Delaunay tetrahedra of the surface's vertices and their circumspheres inside it.

    Returns the tessellated points ``P``, the :class:`_Tetrahedra` ``tri``, the circumcentres
    ``cc`` and radii ``R`` (one per tetrahedron), which of them lie ``inside`` the surface, and the
    winding number of the surface closed by fans (a callable of query points, for :func:`_bridged`):
    libigl's fast winding number of order ``tolerances.MEDIAL_WINDING_ORDER`` at accuracy
    ``tolerances.MEDIAL_WINDING_ACCURACY``, whose error (under 0.1 on the real meshes and synthetic
    trees) is far from the 1/2 it is judged by. Points at one place (a vertex repeated) are tessellated
    once."""
    Vc, Fc = closed_by_fans(V, F, loops)
    P = V[_medial_sample(V, F, Vc, Fc)]
    P = P[np.sort(np.unique(P, axis=0, return_index=True)[1])]  # in their order, each place once
    tri = _delaunay(P)
    cc, R = _circumspheres(P, tri.simplices)
    ok = np.isfinite(R)
    bvh = igl.FastWindingNumberBVH()
    bvh.init(Vc, Fc, tol.MEDIAL_WINDING_ORDER)

    def winding(Q):
        return np.asarray(bvh.winding_number(np.ascontiguousarray(Q), tol.MEDIAL_WINDING_ACCURACY), np.float64)

    w = np.zeros(len(cc))
    w[ok] = winding(cc[ok])
    inside = ok & (np.abs(w) > 0.5)  # either orientation of a closed surface
    return P, tri, cc, R, inside, winding


def _bridged(P, tri, cc, R, inside, winding):
    """``(cc, R, inside)`` with every tetrahedron whose circumcentre lies outside the surface but whose
    centroid is inside joined too, its node at the centroid and its radius the distance from there to
    its nearest corner (step 1b of the module notes); new arrays, the given ones unchanged."""
    out = np.flatnonzero(~inside)
    T = tri.simplices[out]
    cen = P[T].mean(axis=1)
    bridge = np.abs(winding(cen)) > 0.5
    out, cen = out[bridge], cen[bridge]
    cc, R, inside = cc.copy(), R.copy(), inside.copy()
    cc[out] = cen
    R[out] = np.min(np.linalg.norm(P[T[bridge]] - cen[:, None], axis=2), axis=1)
    inside[out] = True
    return cc, R, inside


def _edge_graph(tri, cc, R, inside):
    """The csr graph of the ``ds / R`` edges between inside nodes of face-adjacent tetrahedra."""
    ins = np.flatnonzero(inside)  # the inside tetrahedra's faces only (half of them; issue #47)
    i = np.repeat(ins, 4)
    j = tri.neighbors[ins].ravel()
    m = j > i  # each edge once (a hull face's -1 never)
    i, j = i[m], j[m]
    m = inside[j]
    i, j = i[m], j[m]
    if not i.size:
        raise NotTubularError("no Voronoi vertex of the surface lies inside it: the mesh encloses no lumen; "
                              "check it with vesselgp.clean_mesh")
    cost = np.linalg.norm(cc[i] - cc[j], axis=1) / (0.5 * (R[i] + R[j]))
    # zero-length edges (co-spherical tetrahedra share a circumcentre) still connect
    cost = np.maximum(cost, tol.MEDIAL_MIN_EDGE_COST)
    return coo_matrix((np.concatenate([cost, cost]), (np.concatenate([i, j]), np.concatenate([j, i]))),
                      shape=(len(cc), len(cc))).tocsr()


class VoronoiDiagram:
    """The inside Voronoi diagram of one mesh and its ``ds / R`` graph, built once (steps 1 and 1b of the
    module notes), for every set of ends its centre lines are asked for (a tree fit asks twice: for the
    ends found, and again with the caps that no line reached). The tessellation is most of a large tree's
    fit (issue #47: 37 s of a 300k-vertex, 80-end tree's).

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        A checked mesh (:func:`vesselgp.fit.checked_mesh`).
    loops : sequence of (k,) int64, optional
        The boundary loops (closed by fans for the inside test); default from libigl.
    """

    def __init__(self, V, F, loops=None):
        if loops is None:
            loops = igl.boundary_loop_all(F)
        self.shape = (len(V), len(F))
        self._P, self._tri, cc, R, inside, self._winding = _inside_voronoi(V, F, loops)
        self._graphs = {False: (cc, R, inside, _edge_graph(self._tri, cc, R, inside))}
        self._lines = {}  # the centre lines drawn on it, by (root, the ends' centres and radii): a tree fit
        # asks twice for the same ones when it looks for missed caps and finds none (3 s of a 64-tip tree)

    def graph(self, bridged=False):
        """Inside Voronoi vertices ``cc`` (t, 3), their radii ``R`` (t,), the ``inside`` flags (t,) and the csr
        graph of their ``ds / R`` edges; with ``bridged``, the tetrahedra of :func:`_bridged` joined too."""
        if bridged not in self._graphs:
            cc, R, inside = self._graphs[False][:3]
            cc, R, inside = _bridged(self._P, self._tri, cc, R, inside, self._winding)
            self._graphs[True] = (cc, R, inside, _edge_graph(self._tri, cc, R, inside))
        return self._graphs[bridged]


def _voronoi_graph(V, F, loops, bridged=False):
    """:meth:`VoronoiDiagram.graph` of a one-off diagram."""
    return VoronoiDiagram(V, F, loops).graph(bridged)


def _smoothed(P, R):
    """A Voronoi path resampled at ``MEDIAL_SPACING`` inscribed radii and smoothed over about one radius.

    The samples are equally spaced in ``integral ds / R`` (the paths' own cost), so a fixed binomial
    filter (``MEDIAL_SMOOTHING_PASSES`` of [1, 2, 1] / 4, the end points held) smooths the Voronoi
    vertices' jitter over a length proportional to the local radius, in a wide trunk as in a thin
    branch (VMTK resamples and smooths its lines alike).
    """
    ds = np.linalg.norm(np.diff(P, axis=0), axis=1)
    u = np.concatenate([[0.0], np.cumsum(ds / (0.5 * (R[1:] + R[:-1])))])
    k = max(int(np.ceil(u[-1] / tol.MEDIAL_SPACING)), 2) + 1
    uq = np.linspace(0.0, u[-1], k)
    Q = np.stack([np.interp(uq, u, P[:, d]) for d in range(3)], axis=1)
    Rq = np.interp(uq, u, R)
    for _ in range(tol.MEDIAL_SMOOTHING_PASSES):
        Q[1:-1] = 0.25 * Q[:-2] + 0.5 * Q[1:-1] + 0.25 * Q[2:]
    return Q, Rq


def centerlines(V, F, ends, root, *, loops=None, voronoi=None):
    """Medial centre lines from the root end to every other end (see the module notes).

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        A checked mesh (:func:`vesselgp.fit.checked_mesh`): faces with an area, consistently
        oriented.
    ends : sequence of VesselEnd
        Every end (:func:`vesselgp.vessel_ends`), at least two.
    root : int
        The root end's index (:func:`vesselgp.branches.root_end` picks the widest).
    loops : sequence of (k,) int64, optional
        The boundary loops (closed by fans for the inside test); default from libigl.
    voronoi : VoronoiDiagram, optional
        This mesh's diagram when already built (:attr:`vesselgp.PreparedMesh.voronoi`); ``loops`` is
        then not used.

    Returns
    -------
    Centerlines

    Raises
    ------
    NotTubularError
        The surface encloses no lumen, or an end is not connected to the root through it.

    Examples
    --------
    >>> import numpy as np
    >>> from vesselgp.synthetic import synthetic_tree
    >>> from vesselgp import vessel_ends
    >>> t = synthetic_tree(levels=1, voxel=0.6)
    >>> c = centerlines(t.V, t.F, vessel_ends(t.V, t.F), 0)
    >>> c.tips, [len(p) > 10 for p in c.points]
    ((1, 2), [True, True])
    >>> d, r, _, _ = t.truth.nearest(c.points[0])
    >>> bool(np.median(d / r) < 0.1)
    True
    """
    if voronoi is None:
        voronoi = VoronoiDiagram(V, F, loops)  # tessellated once
    elif voronoi.shape != (len(V), len(F)):
        raise OptionError(f"voronoi was built for a mesh of {voronoi.shape[0]} vertices and {voronoi.shape[1]} "
                          f"faces, not this one ({len(V)}, {len(F)}); build VoronoiDiagram(V, F) of this mesh")
    key = (int(root), tuple((tuple(np.asarray(e.center, np.float64).tolist()), float(e.radius)) for e in ends))
    if key not in voronoi._lines:
        voronoi._lines[key] = _drawn(voronoi, ends, root)
    return voronoi._lines[key]


class _PathWalk:
    """The nodes from ``source`` to any node of a shortest-path tree given by its predecessors ``pred`` (n,).

    Each walk back stops at the first node an earlier walk passed and takes the rest from that walk's
    path, so the tips of a tree cost the nodes of their union once, not each root-to-tip path in full
    (a 64-tip tree's paths repeat their trunks: 780k steps; issue #47). The paths are the same.
    """

    def __init__(self, pred, source):
        self.back = pred.tolist()  # the predecessors as Python ints: the walk is 10x faster than on numpy scalars
        self.source = int(source)
        self.seen = {}  # node -> (index of the path it was first met on, its position there)
        self.paths = []

    def __call__(self, node):
        """The node ids from the source to ``node``, (k,) int64."""
        back, seen, walked = self.back, self.seen, [int(node)]
        while walked[-1] != self.source and walked[-1] not in seen:
            walked.append(back[walked[-1]])
        if walked[-1] in seen:
            k, at = seen[walked[-1]]
            head = self.paths[k][:at + 1]
        else:  # reached the source: the walk is the whole path
            head = np.zeros(0, np.int64)
        path = np.concatenate([head, np.asarray(walked[::-1][len(head) > 0:], np.int64)])
        k = len(self.paths)
        seen.update(zip(path[len(head):].tolist(), ((k, at) for at in range(len(head), len(path)))))
        self.paths.append(path)
        return path


def _drawn(voronoi, ends, root):
    """:func:`centerlines` on a built diagram (steps 2 and 3 of the module notes)."""
    for bridged in (False, True):
        cc, R, inside, G = voronoi.graph(bridged)
        ids = np.flatnonzero(inside)
        kd = cKDTree(cc[ids])
        seeds = [int(ids[i]) for i in kd.query(np.array([e.center for e in ends]))[1]]  # each end's nearest
        # the graph holds each edge both ways (_edge_graph): as a directed graph, scipy does not symmetrise it
        dist, pred = dijkstra(G, directed=True, indices=seeds[root], return_predecessors=True)
        if bridged or np.all(np.isfinite(dist[seeds])):
            break
        log.info("centre lines: the inside Voronoi vertices fall apart between the ends (a tube a few edges "
                 "around); tetrahedra whose centroids are inside bridge them")
    tips, points, radius = [], [], []
    walk = _PathWalk(pred, seeds[root])
    for j, e in enumerate(ends):
        if j == root:
            continue
        if not np.isfinite(dist[seeds[j]]):
            raise NotTubularError(f"end {j} (centre {np.round(e.center, 3).tolist()}) is not connected to the "
                                  f"root end {root} through the lumen; check the mesh with vesselgp.clean_mesh")
        path = walk(seeds[j])
        Q, Rq = _smoothed(np.vstack([ends[root].center, cc[path], e.center]),
                          np.concatenate([[ends[root].radius], R[path], [e.radius]]))
        Q.flags.writeable = Rq.flags.writeable = False  # kept on the diagram for the next caller
        points.append(Q)
        radius.append(Rq)
        tips.append(j)
    log.debug("centre lines: %d inside Voronoi vertices, %d edges, %d lines", len(ids), G.nnz // 2, len(tips))
    return Centerlines(root=root, tips=tuple(tips), points=tuple(points), radius=tuple(radius))
