"""Branch decomposition of a vessel tree: which end hangs off which junction, and each vertex's branch.

The first stage of a tree fit (issue #13): from the ends of a branching mesh
(:func:`vesselgp.vessel_ends`) and a root end, it finds the tree's topology and
splits the surface into branches, without fitting any axis.

* **Distances.** Heat-method geodesic distances
  (:class:`vesselgp.mesh.geodesic.GeodesicDistances`, one precomputation)
  from every end's vertices, solved together.
* **Topology.** For tips ``a`` and ``b``, the length of the path they share
  from the root is the Gromov product
  ``g(a, b) = (d(root, a) + d(root, b) - d(a, b)) / 2``; on a tree it is the
  geodesic distance from the root to their junction. Tips are merged bottom-up
  by the largest shared length (average linkage), which gives a rooted binary
  tree: a trifurcation comes out as two junctions close together.
* **Vertices.** Vertex ``v`` follows the root-to-tip path it is nearest to,
  the tip ``j`` of least geodesic excess ``d(root, v) + d(j, v) - d(root, j)``.
  Along that path it sits on the first branch whose distal junction (shared
  length) is farther from the root than ``d(root, v)``: a trunk vertex is
  nearer the root than the first junction whichever side of the trunk it is
  on, and the surface around a junction, up to the crotch, goes to the parent
  branch. (A threshold on the excess, in tip radii, would hand the far side
  of a wide trunk near a junction to a child.)
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validate import as_mesh
from .errors import EndsError
from .mesh.geodesic import GeodesicDistances

__all__ = ["Branching", "branch_decomposition"]


@dataclass(frozen=True)
class Branching:
    """The topology of a vessel tree and the branch of every vertex.

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
    shared_length : (b,) float64
        Geodesic distance from the root to each branch's distal junction
        (the Gromov product of its tips); for a leaf, to its tip.
    vertex_branch : (n,) int64
        The branch of each vertex.
    root_distance : (n,) float64
        Geodesic distance of each vertex from the root end.
    """

    root: int
    parent: np.ndarray
    tips: tuple
    end_branch: dict
    shared_length: np.ndarray
    vertex_branch: np.ndarray
    root_distance: np.ndarray

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
        raise EndsError(f"root {root} is not an end index; use 0 to {len(ends) - 1} (see vesselgp.vessel_ends)")
    return root


def _agglomerate(tips, share):
    """Rooted binary tree of the tips, merging the pair of clusters with the largest mean shared length.

    Returns the nodes as (tips, children, shared length), leaves first, the top node last.
    """
    nodes = [((t,), (), share[(t, t)]) for t in tips]
    active = list(range(len(nodes)))
    while len(active) > 1:
        best, pair = -np.inf, None
        for i, a in enumerate(active):
            for b in active[i + 1:]:
                g = np.mean([share[(x, y)] for x in nodes[a][0] for y in nodes[b][0]])
                if g > best:
                    best, pair = g, (a, b)
        a, b = pair
        nodes.append((nodes[a][0] + nodes[b][0], (a, b), best))
        active = [k for k in active if k not in pair] + [len(nodes) - 1]
    return nodes


def branch_decomposition(V, F, ends, root=None, *, geodesics=None):
    """Topology of a vessel tree and the branch of each vertex (see the module notes).

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    ends : sequence of VesselEnd
        Every end of the tree (:func:`vesselgp.vessel_ends`), at least three.
    root : int, optional
        The root end; default the widest.
    geodesics : GeodesicDistances, optional
        The heat-method solver of this ``V, F``, to reuse its factorisation; default built here.

    Returns
    -------
    Branching

    Raises
    ------
    EndsError
        Fewer than three ends, or a root index out of range.

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
    if len(ends) < 3:
        raise EndsError(f"a tree needs at least three ends, the mesh has {len(ends)}; "
                        "fit a single vessel with vesselgp.fit_generalized_cylinder")
    root = root_end(ends, root)
    geo = GeodesicDistances(V, F) if geodesics is None else geodesics.check(V, F)
    dist = list(geo.from_each([e.vertices for e in ends]).T)  # one solve for all ends
    tips = [j for j in range(len(ends)) if j != root]
    to_tip = {j: float(np.mean(dist[root][ends[j].vertices])) for j in tips}
    share = {(a, b): 0.5 * (to_tip[a] + to_tip[b] - float(np.mean(dist[a][ends[b].vertices])))
             for a in tips for b in tips if a != b}
    share.update({(j, j): to_tip[j] for j in tips})
    nodes = _agglomerate(tips, share)
    # branches: the top node is the trunk (0); then each node below, parents before children
    order, parent, stack = [], [], [(len(nodes) - 1, -1)]
    while stack:
        k, p = stack.pop()
        order.append(k)
        parent.append(p)
        stack.extend((c, len(order) - 1) for c in reversed(nodes[k][1]))
    branch_of = {k: i for i, k in enumerate(order)}
    # each vertex follows the path it is nearest to (least geodesic excess), and sits on the
    # first branch of that path whose distal junction is farther from the root than itself
    excess = np.stack([dist[root] + dist[j] - to_tip[j] for j in tips], axis=1)
    nearest = np.argmin(excess, axis=1)
    vb = np.zeros(len(V), np.int64)
    for c, j in enumerate(tips):
        leaf = branch_of[next(k for k in order if nodes[k][0] == (j,))]
        path = [leaf]
        while parent[path[-1]] >= 0:
            path.append(parent[path[-1]])
        path = path[::-1]
        reach = np.array([nodes[order[p]][2] for p in path[:-1]])
        m = nearest == c
        vb[m] = np.asarray(path)[np.searchsorted(reach, dist[root][m], side="left")]
    return Branching(
        root=root, parent=np.asarray(parent, np.int64), tips=tuple(tuple(nodes[k][0]) for k in order),
        end_branch={nodes[k][0][0]: branch_of[k] for k in order if len(nodes[k][0]) == 1},
        shared_length=np.array([nodes[k][2] for k in order]), vertex_branch=vb, root_distance=dist[root],
    )
