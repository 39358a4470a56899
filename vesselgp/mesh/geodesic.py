"""Geodesic distances on a mesh: the heat method (Crane, Weischedel and Wardetzky 2013).

One precomputation serves every source set (:class:`GeodesicDistances`), as in libigl's
``heat_geodesics_precompute`` / ``heat_geodesics_solve`` split, and several source sets are
solved at once (:meth:`GeodesicDistances.from_each`). The three steps of the method, on the
mesh closed by fans over its open ends (:func:`_closed`):

1. heat flow ``(M - t L) u = delta_sources`` (Voronoi mass matrix ``M``, cotangent
   Laplacian ``L``; one Cholesky factorisation, no boundary condition: the mesh is closed);
2. the normalised field ``X = -grad u / |grad u|`` per face (zero where ``grad u`` is);
3. the Poisson equation ``L phi = div X``, with one vertex pinned (the surface is closed and
   connected, so the right-hand side sums to zero and the pinned solution is the
   zero-mean one plus a constant); ``phi`` is shifted to zero mean over the sources.

libigl's ``heat_geodesics_precompute`` solves step 3 with a zero-mean constraint, by a
sparse LU of the bordered system; the pinned Poisson matrix is positive definite, so here
both steps are Cholesky factorisations (``igl.min_quad_with_fixed``, 0.13-0.15 s together
on a 27k-vertex tree; the whole precomputation 0.19-0.23 s against libigl's 0.25-0.32 s, in
turn). The distances agree with libigl's to 1e-12 of the largest (``tests/test_geodesic.py``).
The cotangent Laplacian, the per-face gradient and the face areas come from one numpy pass
(:func:`vesselgp.mesh._geometry.cotangent_operators`, libigl's ``cotmatrix`` and ``grad``
to 1e-14): 16 ms against the two libigl calls' 31 ms on a 27k tree.

The heat time is the larger of libigl's default (the mean edge length squared) and the time
at which heat from a source still reaches the far side of the mesh above
``exp(-tolerances.GEODESIC_HEAT_DECAY)``: with the default alone, on a fine mesh of a long
vessel the heat underflows a few dozen edges from the source and the distances beyond are
wrong (the Gromov product of two tips of a 200k vertex tree came out 13 % short). The far
side is measured by a rigid-invariant extent (twice the largest distance from the vertex
centroid, at least the mesh's diameter): the bounding-box diagonal used before changes when
the mesh turns, and so did every distance (by 2e-4 of the length for a 45-degree turn of a
tube).
"""
from __future__ import annotations

import igl
import numpy as np
import scipy.sparse as sp

from .. import tolerances as tol
from ..errors import InvalidMeshError, OptionError
from ._geometry import cotangent_operators, voronoi_areas
from .seams import refuse_seams
from .topology import mesh_topology

__all__ = ["GeodesicDistances"]


class GeodesicDistances:
    """Heat-method geodesic distances from vertex sets, with both factorisations kept.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        One connected surface; faces with a well-defined area (zero-area faces have no
        cotangent weights).
    topology : MeshTopology, optional
        The :class:`vesselgp.mesh.topology.MeshTopology` of these ``F``, when already built;
        default built here.
    areas : (n,) float64, optional
        The Voronoi areas of ``V, F`` (:func:`vesselgp.mesh._geometry.voronoi_areas`), when a
        fit has them already; default computed here. The closed mesh's mass matrix adds the
        shares of the fans' faces to them (the areas are sums over faces).

    Raises
    ------
    InvalidMeshError
        Open seams of duplicate vertices (:func:`vesselgp.mesh.seams.open_seams`: one piece or
        several; distances would go the long way round the tear), several connected components
        (their distances from each other are undefined; an unreferenced vertex counts as one), or non-manifold or
        inconsistently oriented faces (boundary loops are then undefined).
    OptionError
        A ``topology`` of other faces, or ``areas`` not one per vertex.

    Examples
    --------
    >>> import numpy as np
    >>> from vesselgp.synthetic import synthetic_vessel
    >>> ves = synthetic_vessel("straight", radius=1.0, n_around=24, remesh=False)
    >>> geo = GeodesicDistances(ves.V, ves.F)
    >>> d = geo(np.flatnonzero(ves.V[:, 2] == ves.V[:, 2].min()))
    >>> bool(abs(d.max() - np.ptp(ves.V[:, 2])) < 0.05 * np.ptp(ves.V[:, 2]))
    True
    """

    def __init__(self, V, F, topology=None, *, areas=None):
        self.shape = (len(V), len(F))  # the mesh it was built for (see :meth:`check`)
        topo = mesh_topology(F, len(V)) if topology is None else topology
        if topo.n_vertices != len(V) or not np.array_equal(topo.F, F):
            raise OptionError(f"the topology given is of other faces ({topo.n_faces} faces, {topo.n_vertices} "
                              f"vertices; these are {len(F)} and {len(V)}); pass the topology of F or none")
        refuse_seams(V, topo)  # a mesh torn along open seams (one piece or several): merge them
        if topo.vertex_components[0] > 1:
            raise InvalidMeshError(
                f"mesh has {topo.vertex_components[0]} connected components (unreferenced vertices count "
                "as one each), so geodesic distances between them are undefined; run vesselgp.clean_mesh "
                "(keeps the largest) first")
        h = float(topo.edge_lengths(V).mean())  # igl.avg_edge_length: the mean over the unique edges
        extent = 2.0 * float(np.sqrt(((V - V.mean(axis=0)) ** 2).sum(axis=1).max()))
        self.t = max(h * h, extent**2 / (4.0 * tol.GEODESIC_HEAT_DECAY))
        if areas is not None and np.shape(areas) != (len(V),):
            raise OptionError(f"areas must have one entry per vertex ({len(V)}), got shape {np.shape(areas)}")
        Vc, Fc = _closed(V, F, topo.boundary_loops)
        mass = voronoi_areas(V, F) if areas is None else areas
        if len(Vc) > len(V):  # the fans' faces (the last ones) add their shares
            mass = np.concatenate([mass, np.zeros(len(Vc) - len(V))]) + voronoi_areas(Vc, Fc[len(F):])
        L, self._grad, self._area = cotangent_operators(Vc, Fc)  # (3 m, n) gradient, as igl.grad
        none = np.zeros(0, np.int64)
        no_eq = sp.csc_matrix((0, len(Vc)))
        self._heat = igl.min_quad_with_fixed_data()   # step 1: M - t L
        igl.min_quad_with_fixed_precompute((sp.diags(mass) - self.t * L).tocsc(), none, no_eq,
                                           True, self._heat)
        self._poisson = igl.min_quad_with_fixed_data()  # step 3: -L, vertex 0 pinned
        igl.min_quad_with_fixed_precompute((-L).tocsc(), np.zeros(1, np.int64), no_eq, True, self._poisson)
        self._div = self._grad.T  # minus the weak divergence of a face field, times the area
        self._n = len(Vc)

    def check(self, V, F):
        """``self`` when it was built for a mesh of ``len(V)`` vertices and ``len(F)`` faces.

        Raises
        ------
        OptionError
            It was built for another mesh.
        """
        if self.shape != (len(V), len(F)):
            raise OptionError(
                f"geodesics were precomputed for a mesh of {self.shape[0]} vertices and {self.shape[1]} faces, "
                f"not this one ({len(V)}, {len(F)}); build GeodesicDistances(V, F) of this mesh (its faces with "
                "an area, as vesselgp.fit.checked_mesh returns them) or pass none")
        return self

    def __call__(self, sources):
        """Distance of every vertex from the nearest of ``sources`` (vertex ids), (n,) float64."""
        return self.from_each([sources])[:, 0]

    def from_each(self, source_sets):
        """Distances from each of ``k`` vertex sets, solved together.

        Parameters
        ----------
        source_sets : sequence of (s_c,) array_like of int
            ``k`` non-empty sets of vertex ids.

        Returns
        -------
        D : (n, k) float64
            Column ``c`` is the distance of every vertex from set ``c`` (zero mean over the
            set, as libigl's ``heat_geodesics_solve``). At most
            ``tolerances.GEODESIC_SOLVE_COLUMNS`` sets share one solve (bounded temporaries).

        Raises
        ------
        OptionError
            A set that is empty, not a sequence of ids, or names a vertex outside the mesh.
        """
        sets = [self._source_ids(s) for s in source_sets]
        D = np.empty((self.shape[0], len(sets)))
        step = tol.GEODESIC_SOLVE_COLUMNS
        for a in range(0, len(sets), step):
            D[:, a:a + step] = self._solve(sets[a:a + step])
        return D

    def _source_ids(self, s):
        ids = np.asarray(s)
        if ids.ndim != 1 or not len(ids) or not np.issubdtype(ids.dtype, np.integer):
            raise OptionError(f"a source set must be a non-empty 1-D sequence of vertex ids, got {s!r:.60}; "
                              "pass a list of sets to from_each, or one set to the solver itself")
        if ids.min() < 0 or ids.max() >= self.shape[0]:
            raise OptionError(f"source ids must lie in [0, {self.shape[0]}), got {int(ids.min())} .. {int(ids.max())}")
        return ids.astype(np.int64, copy=False)

    def _solve(self, sets):
        """Steps 1-3 of the module notes for a few validated source sets: (n, k) float64."""
        k, m = len(sets), len(self._area)
        u0 = np.zeros((self._n, k))
        for c, s in enumerate(sets):
            u0[s, c] = 1.0
        u = igl.min_quad_with_fixed_solve(self._heat, -u0, np.zeros((0, k)), np.zeros((0, k)))
        g = (self._grad @ u).reshape(3, m, k)
        norm = np.sqrt((g * g).sum(axis=0))
        # A grad u / |grad u| = -A X per face (zero where grad u is: heat that underflowed)
        scale = np.divide(self._area[:, None], norm, out=np.zeros_like(norm), where=norm > 0)
        # the Poisson step L phi = div X, with the weak divergence div X = -G^T (A X) (G^T A G = -L):
        # -L phi = -G^T (A grad u / |grad u|); min_quad_with_fixed solves (-L) x = -B
        rhs = self._div @ (g * scale).reshape(3 * m, k)
        D = igl.min_quad_with_fixed_solve(self._poisson, rhs, np.zeros((1, k)), np.zeros((0, k)))
        D = D[: self.shape[0]]
        for c, s in enumerate(sets):
            D[:, c] -= D[s, c].mean()
        return D


def _closed(V, F, loops):
    """``V, F`` with every boundary loop (``loops``, lists of vertex ids) closed by a fan about its centroid.

    One vertex per loop. With a boundary, the heat method (libigl's too) would factorise the
    heat step a second time, with Dirichlet conditions, and average the two solutions; on the
    closed mesh the one (Neumann) factorisation is the whole heat step, and the Poisson step
    needs no boundary condition either (when the fans were introduced, for libigl's
    precompute on a 27k-vertex tree: 0.18 -> 0.14 s). Distances from an end's whole loop, or from sources away
    from the ends, which are all a tree fit asks for, reach a ring's points along the tube, so
    the fans offer no shortcut; measured against the averaged solution they differ by at most
    0.13 % of the largest distance on the 27k synthetic trees and 1.4 % on the real aorto-iliac
    Y (6k vertices, three open ends), near the ends. (From a single vertex on a ring, the far
    side of the ring is nearer across the fan: a chord instead of an arc.) The extra vertices
    come last; distances are returned for ``V`` only.
    """
    if not loops:
        return V, F
    centres = np.array([V[loop].mean(axis=0) for loop in loops])
    # the loop runs along its faces' half-edges: a fan face takes each edge the other way round
    fans = [np.stack([np.roll(loop, -1), loop, np.full(len(loop), len(V) + k)], axis=1)
            for k, loop in enumerate(loops)]
    return np.vstack([V, centres]), np.vstack([F] + fans)
