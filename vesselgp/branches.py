"""Branch decomposition of a vessel tree: which end hangs off which junction, and each vertex's branch.

The first stage of a tree fit (issues #13, #34): from the ends of a branching mesh
(:func:`vesselgp.vessel_ends`) and a root end, it finds the tree's topology, its
junctions and a first axis of every branch, and splits the surface into branches.

* **Centre lines.** The medial lines from the root to every other end
  (:func:`vesselgp.centerlines.centerlines`, VMTK's construction on the internal
  Voronoi diagram): they cross junction zones, sacs and bulbs through the middle of
  the lumen and never leave it, whatever the branch angles or calibres.
* **Where two lines part.** Lines ``a`` and ``b`` run together from the root; ``a`` has
  left ``b`` at its first point farther than ``tolerances.TREE_SPLIT`` of its inscribed
  radius from ``b``, and their junction is the last point before that within
  ``TREE_MEET`` radii of ``b`` (VMTK's branch splitting uses the same inscribed-sphere
  "tube" test). The arc length to it, averaged over the two lines, is the pair's shared
  length; tips are merged bottom-up by the largest shared length (average linkage), which
  gives a rooted binary tree.
* **Junction zones.** A branch between two junctions shorter than
  ``TREE_JUNCTION_MERGE`` inscribed radii of its parent is dropped and its children hang
  off the first junction: a trifurcation, or three arch branches leaving within one
  radius, is one junction with three or four children.
* **Vertices.** Each branch's first axis is its part of one centre line, a child's
  starting where its line leaves the junction zone (the inscribed spheres of the parent's
  and the siblings' lines: the surface there belongs to the parent); a vertex belongs to
  the branch whose first axis passes nearest to it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from . import tolerances as tol
from ._arrays import within_balls
from ._validate import as_mesh
from .centerlines import centerlines
from .curves import chord_length, resample_arclength
from .errors import EndsError

__all__ = ["Branching", "branch_decomposition"]


@dataclass(frozen=True)
class Branching:
    """The topology of a vessel tree, its junctions, first axes and the branch of every vertex.

    Branch 0 is the trunk, from the root end to the first junction. Every
    other branch runs from its parent's junction to a junction or to a tip.

    Attributes
    ----------
    root : int
        Index of the root end (into the ``ends`` given).
    parent : (b,) int64
        Parent branch of each branch, -1 for the trunk.
    tips : tuple of tuple of int
        The end indices reached through each branch (one for a leaf).
    end_branch : dict of int to int
        The leaf branch of each tip end.
    junctions : (b, 3) float64
        The junction at the distal end of each branch (on its centre line); NaN for a leaf.
    junction_radius : (b,) float64
        The inscribed-sphere radius there (NaN for a leaf).
    lines : tuple of (k_i, 3) float64
        Each branch's first axis: its part of a centre line, from the root end's centre (the
        trunk) or from where it leaves its junction zone, to its distal junction or to its
        tip's centre.
    line_radius : tuple of (k_i,) float64
        The inscribed-sphere radius along each first axis.
    lead_in : tuple of (l_i, 3) float64
        A child's centre line through its junction zone, from its point nearest its parent's
        junction to where its first axis starts (the trunk's is empty): the branch's axis there,
        inside the lumen whatever the branch angle.
    vertex_branch : (n,) int64
        The branch of each vertex.
    centerlines : Centerlines
        The medial lines the decomposition was read from.
    """

    root: int
    parent: np.ndarray
    tips: tuple
    end_branch: dict
    junctions: np.ndarray
    junction_radius: np.ndarray
    lines: tuple
    line_radius: tuple
    lead_in: tuple
    vertex_branch: np.ndarray
    centerlines: object

    @property
    def children(self):
        """Child branches of each branch, tuple of tuples."""
        return tuple(tuple(int(c) for c in np.flatnonzero(self.parent == b)) for b in range(len(self.parent)))


def root_end(ends, root=None):
    """The root end's index: ``root`` checked against the ends, or the widest end when None.

    Raises
    ------
    EndsError
        ``root`` is not an index into ``ends``.
    """
    root = int(np.argmax([e.radius for e in ends])) if root is None else int(root)
    if not 0 <= root < len(ends):
        raise EndsError(f"root={root} is not an end index; use 0 to {len(ends) - 1} (see vesselgp.vessel_ends)")
    return root


def _agglomerate(tips, share):
    """Rooted binary tree of the tips, merging the pair of clusters with the largest mean shared length.

    ``share`` holds each pair of tips' shared length (symmetric) and each tip's own length under
    ``(t, t)``. Average linkage: the clusters' summed shared lengths are kept in a matrix (a merged
    cluster's row is the sum of its two), so each merge is one pass over the active pairs, not a mean
    over every pair of their tips (the 128-tip tree's 350k means: issue #47); ties go to the first
    pair in the order the clusters were made.

    Returns the nodes as (tips, children, shared length), leaves first, the top node last.
    """
    n = len(tips)
    nodes = [((t,), (), share[(t, t)]) for t in tips]
    S = np.zeros((2 * n - 1, 2 * n - 1))  # summed shared length between clusters
    S[:n, :n] = [[share[(a, b)] if a != b else 0.0 for b in tips] for a in tips]
    size = np.ones(2 * n - 1)
    active = list(range(n))
    while len(active) > 1:
        A = np.array(active)
        i, j = np.triu_indices(len(A), 1)  # row-major: the pairs in the order the clusters were made
        g = S[A[i], A[j]] / (size[A[i]] * size[A[j]])
        k = int(np.argmax(g))
        a, b, c = int(A[i[k]]), int(A[j[k]]), len(nodes)
        S[c] = S[a] + S[b]
        S[:, c] = S[c]
        size[c] = size[a] + size[b]
        nodes.append((nodes[a][0] + nodes[b][0], (a, b), float(g[k])))
        active = [x for x in active if x not in (a, b)] + [c]
    return nodes


def _parting(Pa, Ra, tree_b):
    """Index on line ``a`` of its junction with line ``b`` (its k-d tree; see the module notes). Line ``a`` is
    measured from its start in growing pieces until it parts, not all of it (a large tree's lines part near
    their start from most others: issue #47)."""
    d, n = np.zeros(0), tol.TREE_PARTING_CHUNK
    while True:
        d = np.concatenate([d, tree_b.query(Pa[len(d):n])[0]])
        far = np.flatnonzero(d > tol.TREE_SPLIT * Ra[:len(d)])
        if far.size or len(d) == len(Pa):
            break
        n *= 2
    if not far.size:  # a runs inside b all the way
        return len(Pa) - 1
    near = np.flatnonzero(d[:far[0]] <= tol.TREE_MEET * Ra[:far[0]])
    return int(near[-1]) if near.size else 0


class _Topology:
    """The agglomerated tips as a tree of nodes with merged junction zones (see the module notes)."""

    def __init__(self, lines, tips):
        self.P = {t: p for t, p in zip(tips, lines.points)}
        self.R = {t: r for t, r in zip(tips, lines.radius)}
        self.arc = {t: chord_length(p) for t, p in self.P.items()}
        kd = {t: cKDTree(p) for t, p in self.P.items()}
        self.part = {(a, b): _parting(self.P[a], self.R[a], kd[b]) for a in tips for b in tips if a != b}
        share = {(a, b): 0.5 * (self.arc[a][self.part[(a, b)]] + self.arc[b][self.part[(b, a)]])
                 for a in tips for b in tips if a != b}
        share.update({(t, t): float(self.arc[t][-1]) for t in tips})
        nodes = _agglomerate(list(tips), share)
        self.top = len(nodes) - 1
        self.rep = {k: n[0][0] for k, n in enumerate(nodes)}  # the line a node's branch is read from
        self.tips = {k: n[0] for k, n in enumerate(nodes)}
        self.kids = {k: list(n[1]) for k, n in enumerate(nodes)}
        self._merge()

    def junction_index(self, k):
        """Index on node ``k``'s line of its distal junction (the first of its children's partings)."""
        return min(self.part[(self.rep[k], self.rep[c])] for c in self.kids[k] if self.rep[c] != self.rep[k])

    def start_index(self, k, parent):
        """Index on node ``k``'s line nearest to its parent's junction (0 for the top node)."""
        if parent < 0:
            return 0
        J = self.P[self.rep[parent]][self.junction_index(parent)]
        return int(np.argmin(np.linalg.norm(self.P[self.rep[k]] - J, axis=1)))

    def _branch_length(self, c, k):
        """Arc length of node ``c``'s branch (child of ``k``) along its own line."""
        t = self.rep[c]
        return self.arc[t][self.junction_index(c)] - self.arc[t][self.start_index(c, k)]

    def _short_branch(self):
        """A (parent, child) whose internal branch is shorter than ``TREE_JUNCTION_MERGE`` of the
        parent's inscribed radius at its junction, or None: the deepest parents first (nodes are
        numbered as they were agglomerated), among the nodes still reached from the top."""
        reached, stack = [], [self.top]
        while stack:
            reached.append(stack.pop())
            stack.extend(self.kids[reached[-1]])
        for k in sorted(reached):
            for c in self.kids[k]:
                if self.kids[c] and self._branch_length(c, k) < (
                        tol.TREE_JUNCTION_MERGE * self.R[self.rep[k]][self.junction_index(k)]):
                    return k, c
        return None

    def _merge(self):
        """Drop the internal branches shorter than ``TREE_JUNCTION_MERGE`` of their parent's radius:
        their children hang off the parent's junction."""
        while (short := self._short_branch()) is not None:
            k, c = short
            self.kids[k] = [x for x in self.kids[k] if x != c] + self.kids[c]


def _covered(P, others):
    """Whether each point of ``P`` lies inside an inscribed sphere, scaled by ``TREE_CHILD_CLEAR``, of
    the lines ``others`` ((points, radii) pairs)."""
    return within_balls(P, np.vstack([q for q, _ in others]),
                        np.concatenate([r for _, r in others]) * tol.TREE_CHILD_CLEAR)


def _branch_line(topo, k, parent):
    """First axis (points, radii) of node ``k``'s branch, its distal junction and inscribed radius there
    (x, y, z, r; NaN for a leaf) and its lead-in.

    A child's first axis starts where its line leaves the junction zone: at its first point
    outside the inscribed spheres (times ``TREE_CHILD_CLEAR``) of the parent's line up to the
    junction and of its siblings' lines from it.
    """
    t = topo.rep[k]
    P, R = topo.P[t], topo.R[t]
    start = i0 = topo.start_index(k, parent)
    i1 = topo.junction_index(k) if topo.kids[k] else len(P) - 1
    J = np.append(P[i1], R[i1]) if topo.kids[k] else np.full(4, np.nan)
    if parent >= 0:
        tp, jp = topo.rep[parent], topo.junction_index(parent)
        others = [(topo.P[tp][:jp + 1], topo.R[tp][:jp + 1])]
        for c in topo.kids[parent]:
            if c != k:
                ic = topo.start_index(c, parent)
                others.append((topo.P[topo.rep[c]][ic:], topo.R[topo.rep[c]][ic:]))
        free = np.flatnonzero(~_covered(P[i0:i1 + 1], others))
        i0 = i0 + int(free[0]) if free.size else i1
    i0 = max(min(i0, i1 - 1), 0)
    lead = P[start:i0 + 1] if parent >= 0 else np.zeros((0, 3))
    return P[i0:i1 + 1], R[i0:i1 + 1], J, lead


def _vertex_branch(V, lines, radius):
    """The branch of each vertex: the one whose first axis is nearest in its own inscribed radii.

    Each branch's nearest dense sample (by distance; a quarter of its least inscribed radius
    apart, at most ``tolerances.TREE_LINE_SAMPLES`` of them) gives the vertex's distance over the
    inscribed radius there; the least ratio wins. Plain distance gave the wall of a wide trunk
    around a thin branch's mouth to the thin branch, whose line passes closer to it than the
    trunk's own.
    """
    samples = []
    for P, R in zip(lines, radius):
        arc = chord_length(P)
        k = int(np.clip(np.ceil(arc[-1] / (0.25 * float(np.min(R)))), 2, tol.TREE_LINE_SAMPLES)) + 1
        Q = resample_arclength(P, k)
        aq = chord_length(Q)
        samples.append((Q, np.interp(aq * (arc[-1] / aq[-1]), arc, R)))  # the samples' arc length on the line
    best = np.full(len(V), np.inf)
    branch = np.zeros(len(V), np.int64)

    def nearer(b, ids):
        Q, Rq = samples[b]
        d, i = cKDTree(Q).query(V[ids])
        r = d / Rq[i]
        win = r < best[ids]
        best[ids[win]], branch[ids[win]] = r[win], b

    # a branch farther from a vertex than TREE_ASSIGN_REACH of its widest inscribed radius has a ratio above
    # that: only the vertices within that reach of its samples' box are measured against it (found in the
    # cube about the box by a k-d tree of the vertices: a box test of every vertex per branch was 3.3 s of a
    # 128-tip tree, of the vertices in its slab of x 1.1 s, this 0.4 s: issue #47) ...
    kd = cKDTree(V, balanced_tree=False, compact_nodes=False)
    for b, (Q, Rq) in enumerate(samples):
        m = tol.TREE_ASSIGN_REACH * float(np.max(Rq))
        lo, hi = Q.min(axis=0) - m, Q.max(axis=0) + m
        c = 0.5 * (lo + hi)  # the half width as the distances are computed: the box's faces in the cube
        ids = np.asarray(kd.query_ball_point(c, max(float(np.max(hi - c)), float(np.max(c - lo))), p=np.inf), np.int64)
        W = V[ids]
        nearer(b, np.sort(ids[np.all((W >= lo) & (W <= hi), axis=1)]))
    # ... and a vertex whose best ratio is above it is measured against every branch (the same least ratio)
    far = np.flatnonzero(best > tol.TREE_ASSIGN_REACH)
    for b in range(len(samples) if far.size else 0):
        nearer(b, far)
    return branch


def branch_decomposition(V, F, ends, root=None, *, loops=None, lines=None):
    """Topology of a vessel tree, its junctions and first axes, and the branch of each vertex.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    ends : sequence of VesselEnd
        Every end of the tree (:func:`vesselgp.vessel_ends`), at least three.
    root : int, optional
        The root end; default the widest.
    loops : sequence of (k,) int64, optional
        The mesh's boundary loops (default from libigl).
    lines : Centerlines, optional
        The medial centre lines from ``root`` (default :func:`vesselgp.centerlines.centerlines`).

    Returns
    -------
    Branching

    Raises
    ------
    EndsError
        Fewer than three ends, or a root index out of range.
    NotTubularError
        The surface encloses no lumen or an end is not connected to the root through it.

    Examples
    --------
    >>> from vesselgp.synthetic import synthetic_tree
    >>> from vesselgp import vessel_ends
    >>> t = synthetic_tree(levels=1, voxel=0.6)
    >>> b = branch_decomposition(t.V, t.F, vessel_ends(t.V, t.F))
    >>> b.parent.tolist(), len(b.tips[0])
    ([-1, 0, 0], 2)
    """
    V, F = as_mesh(V, F)
    return decomposed(V, F, ends, root, loops=loops, lines=lines)


def decomposed(V, F, ends, root=None, *, loops=None, lines=None, voronoi=None):
    """:func:`branch_decomposition` of validated arrays (a :class:`vesselgp.PreparedMesh`'s), not checked again;
    ``voronoi``, the mesh's :class:`vesselgp.centerlines.VoronoiDiagram` when already built."""
    if len(ends) < 3:
        raise EndsError(f"a tree needs at least three ends, the mesh has {len(ends)}; "
                        "fit a single vessel with vesselgp.fit_generalized_cylinder")
    root = root_end(ends, root)
    if lines is None:
        lines = centerlines(V, F, ends, root, loops=loops, voronoi=voronoi)
    topo = _Topology(lines, lines.tips)
    order, parent, stack = [], [], [(topo.top, -1, -1)]
    while stack:  # parents before children
        k, pk, pb = stack.pop()
        order.append((k, pk))
        parent.append(pb)
        b = len(order) - 1
        stack.extend((c, k, b) for c in reversed(topo.kids[k]))
    pieces = [_branch_line(topo, k, pk) for k, pk in order]
    line_pts, line_r = tuple(p[0] for p in pieces), tuple(p[1] for p in pieces)
    return Branching(
        root=root, parent=np.asarray(parent, np.int64), tips=tuple(tuple(topo.tips[k]) for k, _ in order),
        end_branch={topo.tips[k][0]: b for b, (k, _) in enumerate(order) if not topo.kids[k]},
        junctions=np.array([p[2][:3] for p in pieces]).reshape(-1, 3),
        junction_radius=np.array([p[2][3] for p in pieces]), lines=line_pts, line_radius=line_r,
        lead_in=tuple(p[3] for p in pieces),
        vertex_branch=_vertex_branch(V, line_pts, line_r), centerlines=lines,
    )
