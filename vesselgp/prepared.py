"""A vessel mesh checked once, for a job that fits it more than once (issue #34).

Every fit validates its arrays, orients its faces (:func:`vesselgp.mesh.orient.orient_faces`),
checks the mesh (:func:`checked_mesh`: unreferenced vertices, pieces, zero-area faces), finds
its ends and builds the closed surface its axes are checked against
(:class:`vesselgp.inside.SurfaceWinding`). A job that fits one mesh twice (``twist_between``
fits each scan's tree and then its main vessel) did all of that twice per scan. A
:class:`PreparedMesh` does each once, on first use, and every fit given one
(``fit_vessel_tree(pm)``, ``fit_generalized_cylinder(pm, ends=(i, j))``) takes them from it,
as potpourri3d's solvers keep their factorisation.
"""
from __future__ import annotations

import copy
import logging
from functools import cached_property
from typing import NamedTuple

import igl
import numpy as np

from . import tolerances as tol
from ._validate import as_mesh
from .errors import EndsError, InvalidMeshError
from .centerlines import VoronoiDiagram
from .inside import SurfaceWinding
from .mesh import MeshTopology, mesh_topology
from .mesh.ends import found_ends
from .mesh._geometry import voronoi_areas
from .mesh.orient import orient_faces
from .mesh.seams import refuse_seams

log = logging.getLogger(__name__)

__all__ = ["PreparedMesh", "prepared_mesh", "checked_mesh", "CheckedMesh"]


class PreparedMesh:
    """A vessel mesh validated, oriented and checked once; its ends and closed surface built once.

    Parameters
    ----------
    V : (n, 3) float64, or a mesh object
    F : (m, 3) int64, optional
        Converted and validated here (:func:`vesselgp.as_mesh`: ``V`` may be a ``trimesh.Trimesh``,
        ``pyvista.PolyData`` or ``meshio.Mesh``, with ``F`` left out); a mesh whose only
        fault is its faces' winding is oriented (logged), the caller's ``F`` is never changed.
    ends : sequence of VesselEnd, optional
        The mesh's ends, when already found (default :func:`vesselgp.vessel_ends`, on first use).

    Attributes
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        The faces, oriented coherently and outward.
    checked : CheckedMesh
        Topology of ``F``, the faces with an area, the median edge.

    Raises
    ------
    InvalidMeshError
        As :func:`checked_mesh`: run :func:`vesselgp.clean_mesh`.

    Examples
    --------
    >>> from vesselgp.synthetic import synthetic_tree
    >>> from vesselgp import fit_vessel_tree, fit_generalized_cylinder
    >>> t = synthetic_tree(levels=1, voxel=0.6)
    >>> pm = PreparedMesh(t.V, t.F)
    >>> tree = fit_vessel_tree(pm)
    >>> gc = fit_generalized_cylinder(pm, ends=tree.paths[0].ends)
    >>> len(pm.ends), bool(abs(gc.length - tree.paths[0].length) < 0.05 * gc.length)
    (3, True)
    """

    def __init__(self, V, F=None, ends=None):
        V, F = as_mesh(V, F)
        F, topo = orient_faces(V, F)  # a winding fault alone is mended (logged), not refused
        self.V, self.F = V, F
        self.checked = checked_mesh(V, F, topo)
        self._given_ends = None if ends is None else _valid_ends(ends)
        self._searched = False  # whether vesselgp.tree.with_missed_ends has looked at these ends
        self._sacs, self._flat_patches = [], []

    @property
    def topology(self):
        """MeshTopology of ``F``."""
        return self.checked.topology

    @cached_property
    def ends(self):
        """tuple of VesselEnd: the given ends, or :func:`vesselgp.vessel_ends` of the mesh (found once)."""
        if self._given_ends is not None:
            return self._given_ends
        return tuple(found_ends(self.V, self.F, self.topology, sacs=self._sacs, flat_patches=self._flat_patches))

    @property
    def sacs(self):
        """tuple of ((3,) float64, (3,) float64, float): the blind sacs :func:`vesselgp.vessel_ends` left out
        of the ends (a rounded dome wider than every open or capped end), as its dome's centre, outward
        direction and radius; with the ends given, the domes a tree fit finds the lumen running on to past
        them (:func:`vesselgp.tree.with_missed_ends`)."""
        _ = self.ends
        return tuple(self._sacs)

    @property
    def flat_patches(self):
        """tuple of FlatPatch: the flat disks :func:`vesselgp.vessel_ends` did not take for caps though the wall
        meets most of their rims (a cap whose rim remeshing rounded off, or that its body widens too fast
        behind), each as the cap it would be and why it is not one; empty when the ends were given. A tree
        fit whose centre lines reach none takes it for the cap of a vessel whose end was missed (issue #44)."""
        _ = self.ends
        return tuple(self._flat_patches)

    def with_ends(self, ends):
        """This mesh, its checks, areas and closed surface kept, with the given ``ends`` (sequence of VesselEnd).

        Raises
        ------
        EndsError
            ``ends`` are not VesselEnd objects.
        """
        other = copy.copy(self)
        other.__dict__.pop("ends", None)
        other._given_ends, other._sacs, other._flat_patches = _valid_ends(ends), list(self.sacs), []
        other._searched = False
        return other

    def with_sacs(self, sacs):
        """This mesh, its ends kept, with the blind sacs ``sacs`` (sequence of (centre (3,), outward direction (3,),
        radius)) added to :attr:`sacs` (a new object; this one is left as it is)."""
        other = self.with_ends(self.ends)
        other._sacs = list(self.sacs) + [(np.asarray(c, np.float64), np.asarray(d, np.float64), float(r))
                                         for c, d, r in sacs]
        return other

    @cached_property
    def areas(self):
        """(n,) float64: the vertices' Voronoi areas over the faces with an area (Eq. 1's weights), computed once."""
        return voronoi_areas(self.V, self.checked.faces)

    @cached_property
    def winding(self):
        """SurfaceWinding: the closed surface every axis of this mesh is checked against (built once)."""
        return SurfaceWinding(self.V, self.F, self.topology.boundary_loops, coherent=self.topology.is_coherent)

    @cached_property
    def voronoi(self):
        """VoronoiDiagram: the inside Voronoi diagram every set of centre lines of this mesh is drawn on (built
        once; :func:`vesselgp.centerlines.centerlines`)."""
        return VoronoiDiagram(self.V, self.checked.faces, self.topology.boundary_loops)


def prepared_mesh(V, F=None, ends=None):
    """``V`` itself when it is a :class:`PreparedMesh` (``F`` and ``ends`` then None), else ``PreparedMesh(V, F, ends)``.

    ``V`` may also be another mesh object (``trimesh.Trimesh``, ``pyvista.PolyData``,
    ``meshio.Mesh``) with ``F`` left out: it is converted by :func:`vesselgp.as_mesh`.

    Raises
    ------
    InvalidMeshError
        ``F`` missing with arrays, or given with a mesh object.
    """
    if isinstance(V, PreparedMesh):
        if F is not None:
            raise InvalidMeshError("give either a PreparedMesh or the arrays V and F, not a PreparedMesh and F")
        if ends is not None:
            raise EndsError("a PreparedMesh holds its ends: give them to PreparedMesh(V, F, ends=...)")
        return V
    return PreparedMesh(V, F, ends)  # as_mesh: arrays V and F, or one mesh object


def _valid_ends(ends):
    """The given ends as a tuple of VesselEnd-like objects, or raise :class:`EndsError`."""
    ends = tuple(ends)
    if not all(hasattr(e, "center") and hasattr(e, "vertices") for e in ends):
        raise EndsError("ends must be VesselEnd objects (from vesselgp.vessel_ends)")
    return ends


class CheckedMesh(NamedTuple):
    """What :func:`checked_mesh` found: the topology, the faces with an area, the median edge."""

    #: One edge table for the checks, the ends and the axis check.
    topology: MeshTopology
    #: (m', 3) int64: ``F`` without its zero-area faces.
    faces: np.ndarray
    #: Median length of the face corners' edges (:func:`vesselgp.mesh_scale`'s measure).
    median_edge: float

    @property
    def faces_topology(self):
        """``topology`` when it is also that of ``faces`` (no face was dropped), else None."""
        return self.topology if len(self.faces) == self.topology.n_faces else None


def checked_mesh(V, F, topology=None):
    """The checks every fit makes of its mesh; its topology and the faces with a well-defined area.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    topology : MeshTopology, optional
        Of ``F``, when already built (:func:`vesselgp.mesh.orient.orient_faces` returns it).

    Returns
    -------
    CheckedMesh
        ``(topology, faces, median_edge)``: the :class:`MeshTopology`, ``F``
        without its zero-area faces, and the median edge length.

    Raises
    ------
    InvalidMeshError
        Unreferenced vertices, open seams of duplicate vertices (:func:`vesselgp.mesh.seams.open_seams`,
        one piece or several), several connected components, or vertices used only by zero-area
        faces.
    """
    _check_used(V, F)
    topo = mesh_topology(F, len(V)) if topology is None else topology
    _check_connected(V, topo)
    return CheckedMesh(topo, *_nondegenerate_faces(V, F))


def _check_used(V, F):
    used = np.zeros(len(V), bool)
    used[F.ravel()] = True
    if not used.all():
        raise InvalidMeshError(
            f"mesh has {int((~used).sum())} unreferenced vertices; run vesselgp.clean_mesh first"
        )


def _check_connected(V, topo):
    """Raise :class:`InvalidMeshError` when the mesh is torn along open seams or has several pieces.

    Open seams of duplicate vertices (:func:`vesselgp.mesh.seams.refuse_seams`: merge them) are
    refused whether they split the mesh into pieces or leave it one piece with extra boundary;
    genuinely separate pieces get this message.
    """
    refuse_seams(V, topo)
    ncomp = topo.vertex_components[0]
    if ncomp > 1:
        raise InvalidMeshError(
            f"mesh has {ncomp} connected components; run vesselgp.clean_mesh (keeps the largest) "
            "or fit each vessel separately"
        )


def _nondegenerate_faces(V, F):
    """Faces whose area is well defined (above ``DEGENERATE_AREA`` times their longest edge squared)
    and the median length of the face corners' edges (as :func:`vesselgp.mesh_scale` measures it).

    Zero-area faces (collinear or repeated corners) have no cotangent weights;
    they are left out of the area weights and the harmonic field (they carry no
    surface). A vertex used only by such faces has no area and no field value:
    that raises :class:`InvalidMeshError` suggesting :func:`vesselgp.clean_mesh`.
    """
    dbl = igl.doublearea(V, F)
    L = igl.edge_lengths(V, F)
    e2 = np.maximum(np.maximum(L[:, 0], L[:, 1]), L[:, 2]) ** 2  # a tenth of L.max(axis=1)'s time
    bad = ~(dbl > 2.0 * tol.DEGENERATE_AREA * e2)
    med = float(np.median(L, overwrite_input=True))  # L is not needed after: no copy of it
    if not bad.any():
        return F, med
    Fg = F[~bad]
    lost = len(V) - len(np.unique(Fg)) if len(Fg) else len(V)
    if lost:
        raise InvalidMeshError(
            f"mesh has {int(bad.sum())} zero-area faces and {lost} vertices used only by them; "
            "run vesselgp.clean_mesh first"
        )
    log.info("fit ignores %d zero-area faces (vesselgp.clean_mesh removes exactly degenerate ones)",
             int(bad.sum()))
    return Fg, med
