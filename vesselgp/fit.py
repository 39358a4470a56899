"""Generalized-cylinder fit: medial axis and radius of a vessel mesh (paper Section 2.1-2.2).

The paper fits the medial axis ``m(s)`` by gradient descent on Eq. 2 (data term:
weighted centroids of the surface points that project near ``m(s)``, Eq. 1;
regulariser ``lambda``), and the radius ``r(s)`` by descent on Eq. 4 (mean
distance of those points to the axis; regulariser ``mu``). We solve the same
fixed points directly, with three changes a geometry-processing user expects:

* **Initialisation that holds on strongly curved vessels.** A harmonic field
  between the two ends (libigl ``harmonic``, cotangent Laplacian) orders the
  surface along the vessel; area-weighted centroids of its level bands (Eq. 1
  with indicator weights, libigl ``massmatrix`` areas) give the first axis.
* **No bend bias.** Eq. 1's centroid lies outside the true centre of a bent tube
  by about ``kappa r^2 / 2`` (the outer wall has more area per unit axis
  length). Instead of the centroid, each cross-section's centre comes from an
  area-weighted algebraic circle fit (Kasa) of the vertices' in-plane
  coordinates ``(x_i, y_i)`` in the frame at their own projection ``s_i``. The
  fit is linear in the centre correction and the node values, solved in one
  sparse least-squares system per iteration with piecewise-linear (hat)
  functions of ``s`` (this is Eq. 3's fixed point with the unbiased data term).
  For elliptic sections the area-weighted fit is centred by symmetry.
* **Regulariser.** Eq. 2's ``lambda`` term is applied to the second difference of
  the axis (bending), not the first: the first-order term pulls an arc of
  curvature ``kappa`` inwards by ``lambda kappa``, the second-order one leaves
  arcs and helices unbiased. Eq. 4's ``mu`` term is used as written.
* **A tapering tube's Newton step.** On a cone a section tilted off the true normal plane is not centred on
  the true axis, and Eq. 3's plain step oscillates once the taper's gain ``r |r'| / h`` passes 1; an axis
  pinned at both ends takes the Newton step of the linearised fixed point instead (:mod:`vesselgp.taper`).

Vertices that are not on the tubular wall (cap faces, side branches, the far
side of a bifurcation) are removed from the data by robust reweighting against
the fitted radius.

On meshes of ``tolerances.THREAD_MIN_VERTICES`` vertices or more, the wall's Voronoi areas
are computed on a second thread beside the end detection: both are mostly numpy, which lets
go of the GIL on large arrays, so on a 1M-vertex mesh about 0.2 s of the fit overlap. The fit
waits for its thread before it returns or raises, and the results are the same numbers either
way.
"""
from __future__ import annotations

import logging
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace

import igl
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from . import tolerances as tol
from ._arrays import thinned
from ._interop import polylines_to_pyvista
from ._per_vertex import VERTEX_FILLS, PerVertex
from ._validate import as_vector
from .checks import check_centre, cylinder_checks, off_its_wall
from .axis import (Axis, AxisStack, circle_fit_solve, circle_fit_sums, hat, interp_frames,
                   banded_spd_or_none, local_coords, solve_banded_spd)
from .curves import _chords, _resample_arclength, chord_length, polyline_feet, resample_arclength
from .errors import InvalidMeshError, NotTubularError, OptionError, VesselError
from .inside import check_axis_bend, check_axis_inside, sharp_bends
from .mesh import select_ends
from .mesh._ends_format import format_point
from .mesh.scale import scale_of
from .mesh.geodesic import GeodesicDistances
from .sections import conic_residual, section_shape
from .taper import taper_step
from .wall_circles import wall_circles
from .prepared import CheckedMesh, checked_mesh, prepared_mesh  # noqa: F401 (vesselgp.fit.checked_mesh)

log = logging.getLogger(__name__)

__all__ = ["GeneralizedCylinder", "fit_generalized_cylinder"]


@dataclass(frozen=True)
class GeneralizedCylinder:
    """A fitted generalized cylinder: axis, radius, RMF and vertex parameters.

    Attributes
    ----------
    s : (K,) float64
        Normalised arc length of the axis nodes, ``s[0] = 0``, ``s[-1] = 1``.
    length : float
        Arc length of the axis in mesh units.
    centers : (K, 3) float64
        Axis points ``m(s)``.
    radii : (K,) float64
        Radius ``r(s)``: area-weighted mean distance of the wall to the axis (Eq. 4).
    frames : (K, 3, 3) float64
        Rotation-minimizing frames; ``frames[k]`` has rows ``T, U, V`` (Section 2.2).
    vertex_s : (n,) float64
        Normalised arc length of each vertex's projection on the axis.
    vertex_theta : (n,) float64
        Angle of ``p_i - m(s_i)`` about ``T(s_i)`` measured from ``U(s_i)``, in (-pi, pi].
    vertex_local : (n, 3) float64
        Coordinates of ``p_i - m(s_i)`` in the frame ``(T, U, V)`` at ``s_i``;
        the first is non-zero only for vertices beyond the axis ends (caps).
    vertex_weight : (n,) float64
        Weight each vertex had in the final fit: its Voronoi area divided by the
        tube-map stretch ``1 - kappa . offset`` (so every direction about the
        axis counts equally), 0 when it was rejected as not belonging to the
        tubular wall (caps, side branches).
    vertex_area : (n,) float64
        Voronoi area of each vertex where ``vertex_weight > 0``, else 0 (Eq. 1's weights).
    ends : tuple of int
        Indices (into :func:`vesselgp.vessel_ends`) of the ends at ``s = 0`` and
        ``s = 1``; ``(-1, -1)`` when the caller passed the ends themselves.
    dense_s, dense_points, dense_frames : arrays
        The axis sampled densely at equal arc length with its RMF, used by
        :meth:`at` for interpolation.
    iterations : int
        Outer iterations the fit used.
    converged : bool
        Whether the axis step (or the next one predicted, see :func:`fixed_point`) fell below
        ``tolerances.GC_CONVERGENCE`` radii before ``max_iter`` iterations.
    last_step : float
        The axis's last step (its largest node move) in mesh units: below the tolerance when
        ``converged``; how far the axis still moved per iteration when the fit stopped at
        ``max_iter``; infinite for a fit whose system was singular.
    lam, mu : float
        The regularisation weights of Eq. 2 and Eq. 4 the fit used.
    final_lam : float or None
        Eq. 2's weight of the fit's last circle fit (:func:`data_lambda`): ``lam`` on a segmented or
        non-circular wall, down to ``tolerances.GC_LAMBDA_FLOOR`` times it on a clean, dense circular one
        (:class:`vesselgp.TorsionMeter` recovers deformed axes with ``lam``: with the lower weight its
        one-pass recovery of a twisted real coronary read 0.46 degrees off instead of 0.33). None: ``lam``.
    checks : FitChecks or None
        The fit checked against its mesh (:func:`vesselgp.checks.cylinder_checks`: its gaps to its
        ends, the wall it covers); None for a tree's branches and paths (the tree has them).

    Notes
    -----
    A tree's branches and paths (:func:`vesselgp.fit_vessel_tree`) are fitted on part of the mesh. They
    keep their five ``vertex_*`` arrays on those vertices only and give the arrays over the whole mesh
    (NaN or 0 elsewhere, as documented above) when one is first read, once per array. Kept whole, the
    191 cylinders of a 64-tip tree of 260k vertices held 2.8 GB and took 5 s of its fit to write.
    """

    s: np.ndarray
    length: float
    centers: np.ndarray
    radii: np.ndarray
    frames: np.ndarray
    vertex_s: np.ndarray = field(repr=False)  # not in the repr: a tree's cylinder would make them whole
    vertex_theta: np.ndarray = field(repr=False)
    vertex_local: np.ndarray = field(repr=False)
    vertex_weight: np.ndarray = field(repr=False)
    vertex_area: np.ndarray = field(repr=False)
    ends: tuple
    dense_s: np.ndarray = field(repr=False)
    dense_points: np.ndarray = field(repr=False)
    dense_frames: np.ndarray = field(repr=False)
    iterations: int
    converged: bool
    lam: float
    mu: float
    last_step: float = float("nan")
    checks: object = field(default=None, repr=False)
    final_lam: float | None = None

    def at(self, s):
        """Axis point and frame at normalised arc lengths ``s``.

        Parameters
        ----------
        s : (q,) float64
            Values in [0, 1] (clipped).

        Returns
        -------
        points : (q, 3) float64
        frames : (q, 3, 3) float64
            Rows ``T, U, V`` at each ``s``.
        """
        return interp_frames(self.dense_s, self.dense_points, self.dense_frames, np.atleast_1d(s))

    def radius_at(self, s):
        """Radius ``r(s)`` at normalised arc lengths ``s`` (linear interpolation)."""
        return np.interp(np.atleast_1d(np.asarray(s, float)), self.s, self.radii)

    @property
    def mean_radius(self):
        """Length-weighted mean radius."""
        return float(np.trapezoid(self.radii, self.s))

    def to_pyvista(self):
        """The axis as a ``pyvista.PolyData`` polyline (needs pyvista: ``pip install "vesselgp[formats]"``).

        Returns
        -------
        pyvista.PolyData
            The K axis nodes ``centers`` as one line cell, with point data ``s`` (normalised arc
            length), ``abscissa`` (arc length in mesh units), ``radius`` and the frame's ``T``,
            ``U``, ``V`` (3-vectors); ``poly.tube(scalars="radius", absolute=True)`` draws the
            fitted cylinder.

        Raises
        ------
        DependencyError
            pyvista is not installed.
        """
        fr = self.frames
        return polylines_to_pyvista(
            [self.centers], {"s": self.s, "abscissa": self.s * self.length, "radius": self.radii,
                             "T": fr[:, 0], "U": fr[:, 1], "V": fr[:, 2]},
            what="GeneralizedCylinder.to_pyvista()")


# the five per-vertex fields read through PerVertex: whole arrays, or a tree cylinder's rows made whole on read
for _name, _fill in VERTEX_FILLS.items():
    setattr(GeneralizedCylinder, _name, PerVertex(_name, _fill))


# ----------------------------------------------------------------------------- radius and weights


def _radius_fit(s, rho, w, K, mu):
    """Eq. 4: r(s) minimising sum w (r(s_i) - rho_i)^2 + mu * int r'^2, hat functions in s.

    The normal matrix of hat functions is tridiagonal: it is assembled with
    ``bincount`` (:func:`_radius_sums`) and solved by banded Cholesky (:func:`_radius_solve`).
    """
    return _radius_solve(*_radius_sums(s, rho, w, K), mu)


def _radius_solve(diag, off, rhs, mu, singular="raise"):
    """Eq. 4's tridiagonal system from its data sums (:func:`_radius_sums`) and ``mu``, solved: (K,)
    (None where singular with ``singular="none"``)."""
    K = len(diag)
    Wbar = float(diag.mean())
    reg = mu * Wbar
    d1 = np.full(K, 2.0 * reg)
    d1[[0, -1]] = reg
    ab = np.zeros((2, K))
    ab[0] = diag + d1 + tol.GC_RADIUS_RIDGE * Wbar
    ab[1, :-1] = off - reg
    return banded_spd_or_none(ab, rhs) if singular == "none" else solve_banded_spd(ab, rhs)


def _radius_sums(s, rho, w, K, nodeoff=None, total=None):
    """The normal matrix's diagonal (N,), off-diagonal (N - 1,) and right-hand side (N,) of Eq. 4's
    data term, ``N = K``; for several axes, per-row ``K`` and ``nodeoff`` and the node ``total``
    (as :func:`vesselgp.axis.circle_fit_sums`)."""
    j, t = hat(s, K)
    if nodeoff is not None:
        j = j + nodeoff
    N = K if total is None else total
    a, b = w * (1 - t), w * t
    diag = np.bincount(j, a * (1 - t), N) + np.bincount(j + 1, b * t, N)
    off = np.bincount(j, a * t, N - 1)
    rhs = np.bincount(j, a * rho, N) + np.bincount(j + 1, b * rho, N)
    return diag, off, rhs


def _robust_weights(s, local, jac, area, radii, inside, rejected=None, length=None):
    """Area weights divided by the tube-map Jacobian, zeroed outside the axis range
    and for vertices far from the fitted wall (or for ``rejected`` ones, when given). With the axis's
    ``length`` (a second fit's, :attr:`FitProblem.rescue`), a rejected vertex on its wall's own circle is
    kept (:func:`_on_wall_circles`)."""
    rho = np.hypot(local[:, 1], local[:, 2])
    ok = inside & (jac > tol.GC_MIN_STRETCH)
    w = np.where(ok, area / np.where(ok, jac, 1.0), 0.0)
    if rejected is not None:
        w[rejected] = 0.0
        return w
    if radii is None:
        return w
    r = np.interp(s, np.linspace(0, 1, len(radii)), radii)
    e = rho - r
    sel = w > 0
    if not np.any(sel):
        return w
    mad = np.median(np.abs(e[sel]))
    sigma = max(1.4826 * mad, 0.01 * float(np.median(radii)))
    out = np.abs(e) > tol.GC_OUTLIER_SIGMAS * sigma
    if length is not None and np.any(out & sel) and not _sparse_wall(np.count_nonzero(sel), len(radii)):
        out[_on_wall_circles(s * length, local, out & sel, sigma, sel, lambda x: np.interp(
            x / length, np.linspace(0, 1, len(radii)), radii))] = False
    w[out] = 0.0
    return w


def _on_wall_circles(s, local, cand, sigma, sel, radius):
    """The vertices of ``cand`` (rejected by the outlier test) that lie on their wall's own circle there
    (:func:`vesselgp.wall_circles.wall_circles` of all the data vertices ``sel``, the nearest window's; within
    ``GC_OUTLIER_SIGMAS`` times ``sigma`` of it), however far that circle is from the smoothed fit: a stenosis
    the smoothed radius lags behind, a sparse bend Eq. 2's weight pulls the axis across. Their rejection left
    Eq. 2's data term without them and the axis cut across (issue #48: 0.29 radii from VMTK's line in the real
    X-ray coronary's stenosis, 84 % of its wall rejected there). Only circles no wider than the smoothed fit's
    (within the same margin) take vertices back: what is not the tube's wall (a side branch, a sac, a junction's
    flare) widens the circle of its window, whose wall then stays out. ``s`` in mesh units; ``radius`` the
    smoothed radius at arc lengths. Returns a mask over the vertices."""
    back = np.zeros(len(s), bool)
    o = np.argsort(s, kind="stable")
    c = wall_circles(s[o], local[o, 1:], sel[o], radius, tol.CHECK_CENTRE_REACH, tol.CHECK_CENTRE_STEP)
    idx = np.flatnonzero(cand)
    if not len(c.s0) or not len(idx):
        return back
    r = radius(s[idx])
    e, rc = c.residual(s[idx], local[idx, 1:], tol.CHECK_CENTRE_STEP * r)
    near = tol.GC_OUTLIER_SIGMAS * sigma
    back[idx[(np.abs(e) <= near) & (rc <= r + near)]] = True
    return back


# ----------------------------------------------------------------------------- initialisation


def _resolve_ends(pm, ends):
    """The two ends to fit between, their indices, and how many ends the mesh has."""
    if ends is not None and len(ends) == 2 and all(hasattr(e, "center") for e in ends):
        return ends[0], ends[1], (-1, -1), 2
    all_ends = pm.ends
    e0, e1 = select_ends(all_ends, ends)
    i0 = next(i for i, e in enumerate(all_ends) if e is e0)
    i1 = next(i for i, e in enumerate(all_ends) if e is e1)
    return e0, e1, (i0, i1), len(all_ends)


def _ends_and_areas(pm, ends):
    """:func:`_resolve_ends` and the wall's Voronoi areas (of the faces with an area, ``Fg``).

    From ``tolerances.THREAD_MIN_VERTICES`` vertices on, the areas are computed on a second
    thread while the ends are found: both are mostly numpy, which lets go of the GIL on large
    arrays (a 1M fit: the areas' 0.2 s hidden). Leaving the block waits for the thread, also
    when the ends raise. On smaller meshes the gain is a few per cent and the two steps'
    temporaries, alive at once, would raise the peak memory per vertex.
    """
    if len(pm.V) < tol.THREAD_MIN_VERTICES:
        found = _resolve_ends(pm, ends)
        return (*found, pm.areas)
    with ThreadPoolExecutor(1, thread_name_prefix="vesselgp-areas") as pool:
        wall = pool.submit(lambda: pm.areas)  # the only thread that touches pm.areas until it is kept
        found = _resolve_ends(pm, ends)
        return (*found, wall.result())


def _path_mask(V, F, e0, e1, rscale, geodesics=None, topology=None, areas=None):
    """Vertices on the path between the two ends (excess geodesic length <= ``BRANCH_PATH_RADII`` radii).

    Used when the mesh has other ends (branches): vertices deeper than about a
    radius into a side branch have d0 + d1 well above the shortest d0 + d1.
    """
    geo = GeodesicDistances(V, F, topology, areas=areas) if geodesics is None else geodesics.check(V, F)
    ex = geo.from_each([e0.vertices, e1.vertices]).sum(axis=1)
    ex -= np.min(ex)
    return ex <= tol.BRANCH_PATH_RADII * rscale


def _harmonic_between(V, F, b, bc, rscale, total_area, edges=None):
    """Harmonic field with values ``bc`` at vertices ``b`` (cotangent Laplacian, libigl).

    Meshes above :data:`tolerances.GC_COARSE_INIT_VERTICES` vertices get the
    field of a vertex-clustered copy (cells a fraction of the radius wide, and
    about ``total_area / GC_COARSE_INIT_CELLS`` in area at most; graph
    Laplacian): it only seeds the fit, and a million-row factorisation would
    cost far more than the whole fit. Its cells are joined where an edge of ``F``
    joins them: ``edges`` ((e, 2), each edge of ``F`` once), when given, are read
    instead of the faces' three corner edges (half the rows, the same graph).
    """
    if len(V) <= tol.GC_COARSE_INIT_VERTICES:
        return igl.harmonic(V, F, b, np.ascontiguousarray(bc[:, None]), 1).ravel()
    h = min(np.sqrt(total_area / tol.GC_COARSE_INIT_CELLS), tol.GC_COARSE_CELL_RADII * rscale)
    cell = _grid_cells(V, h)
    nc = int(cell.max()) + 1
    # the cells' graph: the mesh's edges between two cells (symmetrised below)
    if edges is None:  # every face's corner edges (each interior edge twice)
        cf = cell[F]
        ce = np.concatenate([cf[:, [i, (i + 1) % 3]][cf[:, i] != cf[:, (i + 1) % 3]] for i in range(3)])
        del cf
        ca, cb = ce[:, 0], ce[:, 1]
    else:
        ca, cb = cell.take(edges[:, 0]), cell.take(edges[:, 1])
        cross = ca != cb
        ca, cb = ca[cross], cb[cross]
    A = sp.coo_matrix((np.ones(len(ca)), (ca, cb)), shape=(nc, nc)).tocsr()
    A = ((A + A.T) > 0).astype(float)
    L = (sp.diags(np.asarray(A.sum(axis=1)).ravel()) - A).tocsr()
    cb = cell[b]
    cval = np.bincount(cb, weights=bc, minlength=nc) / np.maximum(np.bincount(cb, minlength=nc), 1)
    known = np.unique(cb)
    free = np.setdiff1d(np.arange(nc), known)
    x = np.zeros(nc)
    x[known] = cval[known]
    x[free] = spla.spsolve(L[free][:, free].tocsc(), -L[free][:, known] @ x[known])
    return x[cell]


def _grid_cells(V, h):
    """Id of each vertex's cube of side ``h`` ((n,) int32, or int64 for 2**31 cells), numbered in
    lexicographic order of the cubes' integer coordinates (as ``np.unique(axis=0)`` numbers them).

    The occupied cubes are marked in a table over the bounding grid when it has at most
    ``tolerances.GRID_TABLE_PER_VERTEX`` entries per vertex (one pass, no sort), else sorted.
    """
    # one coordinate at a time: a reduction along the rows of an (n, 3) array runs about 6x slower
    key = [((V[:, d] - V[:, d].min()) / h).astype(np.int64) for d in range(3)]  # truncation is the floor
    dims = np.array([k.max() + 1 for k in key])
    lin = (key[0] * dims[1] + key[1]) * dims[2] + key[2]
    del key
    total = int(np.prod(dims.astype(object)))
    if total <= tol.GRID_TABLE_PER_VERTEX * len(V):
        occupied = np.zeros(total, dtype=bool)
        occupied[lin] = True
        ids = np.cumsum(occupied, dtype=np.int64) - 1
        cell = ids.take(lin)
    else:
        cell = np.unique(lin, return_inverse=True)[1].reshape(-1)
    return cell.astype(np.int32 if cell.max() < np.iinfo(np.int32).max else np.int64)


def _initial_axis(V, F, e0, e1, area, K0, rscale, total_area, edges=None):
    """Harmonic field between the ends, then area-weighted centroids of its level bands (Eq. 1)."""
    b = np.concatenate([np.asarray(e0.vertices, np.int64), np.asarray(e1.vertices, np.int64)])
    bc = np.concatenate([np.zeros(len(e0.vertices)), np.ones(len(e1.vertices))])
    b, first = np.unique(b, return_index=True)
    phi = _harmonic_between(V, F, b, bc[first], rscale, total_area, edges)
    phi = np.clip(phi, 0.0, 1.0)
    band = np.minimum((phi * K0).astype(np.int64), K0 - 1)
    wsum = np.bincount(band, weights=area, minlength=K0)
    cen = np.stack([np.bincount(band, weights=area * V[:, d], minlength=K0) for d in range(3)], 1)
    phim = np.bincount(band, weights=area * phi, minlength=K0)
    ok = wsum > 0
    cen = cen[ok] / wsum[ok, None]
    phim = phim[ok] / wsum[ok]
    pts = np.vstack([e0.center, cen, e1.center])
    ph = np.concatenate([[0.0], phim, [1.0]])
    arc = chord_length(pts)
    if arc[-1] <= 0:
        raise NotTubularError("mesh is not tubular: its two ends coincide")
    s0 = np.interp(phi, ph, arc / arc[-1])
    return pts, s0


def _check_aspect(length, radius):
    if length < tol.MIN_ASPECT * 2 * radius:
        raise NotTubularError(
            f"vessel is shorter than its diameter (axis {length:.3g}, diameter {2 * radius:.3g}); "
            "it cannot be modelled as a generalized cylinder"
        )


def _log_scale(V, e0, e1, median_edge):
    """Log the mesh's scale; warn when its units look like metres or centimetres (or micrometres)."""
    sc = scale_of(V, median_edge, (e0, e1))
    r0, r1 = sc.radius_range
    report = (f"median edge {sc.median_edge:.3g}, end radii {r0:.3g} to {r1:.3g}, "
              f"bounding-box diagonal {sc.bbox_diagonal:.3g}")
    if sc.warning:
        log.warning("mesh scale: %s; %s", report, sc.warning)
    else:
        log.info("mesh scale: %s (units look like %s)", report, sc.units_guess)


# ----------------------------------------------------------------------------- public entry


def fit_generalized_cylinder(
    V,
    F=None,
    ends=None,
    *,
    n_nodes=None,
    lam=None,
    mu=None,
    max_iter=None,
    initial_normal=None,
    mesh_ends=None,
    geodesics=None,
):
    """Fit a generalized cylinder (medial axis, radius, RMF) to a vessel mesh.

    Implements paper Section 2.2: the medial-axis fixed point of Eq. 3 (with an
    unbiased circle-fit centre in place of Eq. 1's centroid, see the module
    notes), the radius fixed point of Eq. 5 (mean distance, Eq. 4, with the
    ``mu`` regulariser), the RMF by double reflection, and the vertex
    parameterisation ``(s_i, theta_i)``.

    The mesh's scale (median edge, end radii) is logged at INFO level, and at
    WARNING level when it looks like metres, centimetres or micrometres rather
    than millimetres (:func:`vesselgp.mesh_scale`); the fit itself does not
    depend on the unit.

    Parameters
    ----------
    V : (n, 3) float64, PreparedMesh or mesh object
        Vertex positions, a :class:`vesselgp.PreparedMesh` (checked once for several fits; ``F`` and
        ``mesh_ends`` left out) or a mesh object (``F`` left out; :func:`vesselgp.as_mesh`).
    F : (m, 3) int64
        Triangles.
    ends : None, (int, int) or (VesselEnd, VesselEnd), optional
        The two ends the vessel runs between (``s = 0`` at the first). ``None``
        takes the two ends of :func:`vesselgp.vessel_ends` when there are
        exactly two; pass indices into that tuple for a branching mesh.
    n_nodes : int, optional
        Number of axis nodes K. Default: one per half mean radius of length (on a clean wall, with the
        axis refined on closer nodes first and resampled to K: issue #48).
    lam : float, optional
        Eq. 2's regularisation weight (dimensionless; on the axis's second
        difference). Default ``tolerances.GC_LAMBDA``, read at call time.
    mu : float, optional
        Eq. 4's regularisation weight (dimensionless; on the radius's first
        difference). Default ``tolerances.GC_MU``.
    max_iter : int, optional
        Maximum outer iterations (projection, circle fit, radius fit). Default
        ``tolerances.GC_MAX_ITER``. A fit that stops there has ``converged``
        False (logged as a warning).
    initial_normal : (3,) float64, optional
        Direction of U at ``s = 0``. Default: towards the way the axis bends
        (rigid-covariant); a fixed coordinate direction for a straight axis.
    mesh_ends : sequence of VesselEnd, optional
        Every end of the mesh, when already found (:func:`vesselgp.vessel_ends` of
        this mesh); ``ends`` indexes into them. Default: found here.
    geodesics : GeodesicDistances, optional
        On a mesh with more than two ends, the path between ``ends`` is found with
        heat-method geodesics; this reuses a solver of ``V`` and the faces of ``F``
        with an area (:class:`vesselgp.mesh.geodesic.GeodesicDistances`). Default:
        built here when needed.

    Returns
    -------
    GeneralizedCylinder

    Raises
    ------
    InvalidMeshError
        Malformed arrays, unreferenced vertices, several connected components,
        vertices used only by zero-area faces, or (through
        :func:`vesselgp.vessel_ends`) other defects: run :func:`vesselgp.clean_mesh`.
        Zero-area faces themselves are left out of the area weights.
    NotTubularError, EndsError
        No two ends, ambiguous ends on a branching mesh, or a vessel shorter
        than its diameter; a fitted axis that leaves the surface or grazes its
        wall (:func:`vesselgp.inside.check_axis_inside`), or that bends tighter
        than its radius (:func:`vesselgp.inside.check_axis_bend`: a sparsely
        meshed non-circular section can make the fixed point kink).

    Examples
    --------
    >>> from vesselgp.synthetic import synthetic_vessel
    >>> ves = synthetic_vessel("arc", radius=1.5, n_around=24, remesh=False)
    >>> gc = fit_generalized_cylinder(ves.V, ves.F)
    >>> bool(abs(gc.mean_radius - 1.5) < 0.02)
    True
    """
    pm = prepared_mesh(V, F, mesh_ends)  # validated, oriented and checked once (vesselgp.prepared)
    V, F, checked = pm.V, pm.F, pm.checked
    given = "n_nodes given" if n_nodes is not None else None if lam is None else "lam given"  # _answered's WARNING
    lam = tol.GC_LAMBDA if lam is None else float(lam)
    mu = tol.GC_MU if mu is None else float(mu)
    max_iter = tol.GC_MAX_ITER if max_iter is None else int(max_iter)
    _check_options(n_nodes, lam, mu, max_iter)
    topo, Fg, median_edge = checked
    if initial_normal is not None:
        initial_normal = as_vector(initial_normal, "initial_normal")
    e0, e1, end_ids, n_ends, wall_area = _ends_and_areas(pm, ends)
    _log_scale(V, e0, e1, median_edge)
    rscale = 0.5 * (float(e0.radius) + float(e1.radius))
    if not np.isfinite(rscale) or rscale <= 0:
        raise NotTubularError("mesh is not tubular: the ends have no positive radius")
    # Shorter than its diameter: judged by the distance between the end centres
    # (the initial axis of such a stub is not reliable).
    chord = float(np.linalg.norm(np.asarray(e1.center) - np.asarray(e0.center)))
    _check_aspect(chord, rscale)
    area, end_region = _data_weights(V, Fg, wall_area, e0, e1, n_ends, rscale, geodesics, checked.faces_topology)
    ftopo = checked.faces_topology  # the topology of Fg, when no zero-area face was dropped
    nodes, s_prev, L0 = _initial_nodes(V, Fg, e0, e1, np.where(end_region, 0.0, area), chord, rscale, n_nodes,
                                       float(wall_area.sum()), None if ftopo is None else ftopo.edges)
    sub = thinned(len(V), tol.GC_MAX_FIT_VERTICES)
    it = _fitted_axis(nodes, s_prev[sub], V[sub], area[sub], end_region[sub], rscale, L0, lam=lam, mu=mu,
                      max_iter=max_iter, initial_normal=initial_normal, default_nodes=n_nodes is None,
                      two_ended=n_ends == 2, defaults=given is None)
    data = (V, sub, topo, end_region, area, end_ids, initial_normal)
    checking = (pm, e0, e1, rscale, n_ends == 2 and min(end_ids) >= 0)
    gc, it = _checked_or_again(it, (nodes, s_prev[sub], L0), data, checking, lam=lam, mu=mu,
                               max_iter=max_iter, default_nodes=n_nodes is None)
    return _answered(gc, it, data, checking, given, L0=L0, lam=lam, mu=mu, max_iter=max_iter)


def _answered(gc, it, data, checking, given, *, L0, lam, mu, max_iter):
    """The cylinder a single vessel's fit answers: on the caller's nodes or weight (``given`` names which; None
    on the defaults) fitted once more without Eq. 2's pull where it pulls hard (:func:`_free_of_pull`), then
    judged against its wall's own centres (:func:`_on_its_wall`), and a pull still over ``GC_PULL_WARN`` radii
    named in a WARNING (:func:`_warn_pull`)."""
    if given is not None:
        gc, it = _free_of_pull(gc, it, data, checking, L0=L0, lam=lam, mu=mu, max_iter=max_iter)
    gc = _on_its_wall(gc, it, data, checking[:4], L0=L0, lam=lam, mu=mu, max_iter=max_iter)
    if given is not None:
        _warn_pull(gc, it, checking[3], given)
    return gc


def _fitted_axis(nodes, s0, Vs, areas, ends_s, rscale, length0, *, lam, mu, max_iter, initial_normal, default_nodes,
                 two_ended, defaults=False):
    """The fixed point of a single vessel's data from its initial ``nodes``: on the default nodes (``default_nodes``)
    a wall with fewer than ``GC_SPARSE_VERTICES`` data vertices per segment takes :func:`_sparse_fit`; any other
    (or a sparse one that route leaves) one fit, refined on closer nodes when it is clean and has two ends
    (``two_ended``; :func:`_refined`, issue #48), and on the default nodes and weight (``defaults``) freed of Eq.
    2's pull when it is clean (:func:`_freed`)."""
    if default_nodes and np.count_nonzero((areas > 0) & ~ends_s) < tol.GC_SPARSE_VERTICES * (len(nodes) - 1):
        it = _sparse_fit(nodes, s0, Vs, areas, ends_s, rscale, length0, lam=lam, mu=mu, max_iter=max_iter,
                         initial_normal=initial_normal)
        if it is not None:
            return it
    it = fixed_point(nodes, s0, Vs, areas, ends_s, rscale, length0, lam=lam, mu=mu, max_iter=max_iter,
                     initial_normal=initial_normal)
    if two_ended and default_nodes:
        it = _refined(it, Vs, areas, ends_s, rscale, length0, lam, mu, max_iter, initial_normal)
    if defaults:
        it = _freed(it, Vs, areas, ends_s, rscale, length0, lam=lam, mu=mu, max_iter=max_iter,
                    initial_normal=initial_normal)
    return it


def _freed(it, Vs, areas, ends_s, rscale, length0, *, lam, mu, max_iter, initial_normal):
    """:func:`freed` of a single vessel's fixed point ``it`` (its :class:`FitProblem` from these arguments)."""
    problem = FitProblem(it.nodes, it.s, Vs, areas, ends_s, rscale, length0, initial_normal)
    return freed([problem], [it], lam=lam, mu=mu, max_iter=max_iter)[0]


def freed(problems, states, *, lam, mu, max_iter, singular="raise"):
    """Converged fixed points ``states`` of clean walls (a single vessel's, a tree's branches'; :func:`_freeable`:
    the final circle fit lowered Eq. 2's weight to at most ``GC_REFINE_LAMBDA`` of ``lam``, :func:`data_lambda`,
    circular or elliptic, and the pull exceeds ``GC_FREE_PULL`` radii), fitted once more from there with the weight
    on the step only (``pull=False``), in lock step, warm. A freed state, where it converges, counts the iterations of
    both and keeps the state as ``pulled``: where a single vessel's checks refuse it, that one is checked instead
    (:func:`_checked_or_again`). Freed before the checks, a single vessel's cylinder is built and checked once (after
    them, the stage took a 200k-vertex arch's fit from 0.67 to 0.91 s). A tree's branches (their junction sides
    free) come up to 1.9 times closer to the real networks' exact lines on average (docs/accuracy.md).

    The lower final weight and the refinement on closer nodes take back only part of the pull: the real coronary's
    line swept with exact circles read 0.0081 / 0.125 % r with it, 0.0033 / 0.055 without, and the other dense swept
    real lines come 1.4-2.5 times closer on average (docs/accuracy.md). An ellipse's section holds its centre across
    its minor axis only as firmly as ``b^2`` (its circle fit's normal equations): the same pull moves it farther
    (the 2.5:1 vein on the same line, 0.060 / 0.95 with it, 0.003 / 0.065 without; :mod:`vesselgp.sections`). A
    noisy wall keeps the pull: freed, it follows its noise (the vein helix with 1 % r of normal noise, 0.22 / 0.72
    % r off its line freed, 0.15 / 0.50 not)."""
    todo = [b for b, (p, it) in enumerate(zip(problems, states)) if _freeable(p, it, lam)]
    out = list(states)
    if not todo:
        return out
    fines = fixed_points([replace(problems[b], nodes=states[b].nodes, s0=states[b].s, pull=False, warm=True,
                                  elliptic=states[b].elliptic) for b in todo],
                         lam=lam, mu=mu, max_iter=max_iter, singular=singular)
    for b, fine in zip(todo, fines):
        if not fine.converged:
            log.info("the axis, fitted again without Eq. 2's pull, did not converge; kept as fitted")
            continue
        log.info("Eq. 2's weight held the axis about %.2g radii off its wall's fixed point; fitted again with the "
                 "weight on the step only", _pull_of(problems[b], states[b]))
        out[b] = replace(fine, count=states[b].count + fine.count, pulled=states[b])
    return out


def _pull_of(problem, it):
    """Eq. 2's pull on fixed point ``it`` of ``problem``, radii (its last weight times the nodes' pull)."""
    return it.lam * _second_difference_pull(it.nodes, problem.pin, problem.rscale)


def _freeable(problem, it, lam):
    """Whether :func:`freed` fits ``it`` again: converged, its final circle fit lowered Eq. 2's weight to at most
    ``GC_REFINE_LAMBDA`` of ``lam`` (a clean wall), and its pull over ``GC_FREE_PULL`` radii."""
    if not it.converged or it.singular or it.lam is None or it.lam > tol.GC_REFINE_LAMBDA * lam:
        return False
    return _pull_of(problem, it) > tol.GC_FREE_PULL


def _cylinder_of(it, V, sub, topo, end_region, area, mu, lam, end_ids, initial_normal, rescue=False):
    """The cylinder of a converged fixed point ``it`` fitted on the rows ``sub`` of ``V``: every vertex
    projected on its axis, each from its own or a nearby vertex of the thinned subset."""
    axis = Axis(it.nodes, initial_normal)
    s_raw = axis.project(V, it.s if sub.step == 1 else _spread_to_neighbours(topo.adjacency, sub, it.s), None)
    return cylinder_from_axis(axis, V, s_raw, end_region, area, it, mu, lam, end_ids, rescue=rescue)


#: what the refusals of an axis off its wall's centre advise (fewer nodes answered such walls wrong: issue #48)
_REMESH_FINER = ("remesh it finer (isotropically, e.g. pymeshlab's meshing_isotropic_explicit_remeshing with a target "
                 "edge under a third of its radius)")
_off_its_wall = off_its_wall  # the checks' warning decides a second fit (a module name: tests hold it to the edge)


def _on_its_wall(first, it, data, checking, *, L0, lam, mu, max_iter):
    """The fit whose axis runs nearer its wall's centre: ``first`` (fixed point ``it``), or, where its axis ran off
    that centre (:func:`_off_its_wall`), the fit again from ``it`` with the outlier test taking back the vertices
    on their wall's own circles (:func:`_on_wall_circles`; issue #48: the real X-ray coronary's stenosis, 84 % of
    its wall rejected by the first fit, its axis 0.29 radii from VMTK's line there, 0.078 after); a wall too
    sparse for that (:func:`_sparse_wall`) is refused instead (the thin XCAT line remeshed, 12-31 % r off its
    exact line over 3 mm, answered before). The second fit is checked as the first was; one the checks refuse
    leaves the first (said so at INFO). The one kept is named in a WARNING if it is still off
    (:func:`vesselgp.checks.check_centre`). ``data``: the first fit's vertices, subset, topology, end region,
    areas, end ids and initial normal; ``checking``: its mesh, ends and radius scale."""
    V, sub, topo, end_region, area, end_ids, normal = data
    pm, e0, e1, rscale = checking
    a = first.checks.off_centre
    if not _off_its_wall(a):
        check_centre(a, pm.winding.scale)  # the fit kept is always judged by the checks' own rule
        return first
    if _sparse_wall(np.count_nonzero((area[sub] > 0) & ~end_region[sub]), len(it.nodes)):
        raise NotTubularError(
            f"the fitted axis runs {a.offset:.2g} radii (+- {a.se:.2g}) off the centre of its wall at "
            f"{format_point(a.point, pm.winding.scale)} (s = {a.s:.3f}), and the wall is too sparse to fit again "
            f"(at most {tol.GC_LAMBDA_VERTICES} vertices per axis segment): {_REMESH_FINER}")
    kept = first  # a stenosis the first fit's smoothed radius lagged behind: fitted again
    again = fixed_point(it.nodes, it.s, V[sub], area[sub], end_region[sub], rscale, L0, lam=lam, mu=mu,
                        max_iter=max_iter, initial_normal=normal, rescue=True)
    again = _cylinder_of(again, V, sub, topo, end_region, area, mu, lam, end_ids, normal, rescue=True)
    try:
        again = _checked(again, pm, e0, e1, whole=True, rscale=rscale, warn_centre=False)
    except VesselError as err:
        log.info("the fit again with the wall on its own circles taken back was refused (%s); the first fit "
                 "stands", err)
        again = None
    b = None if again is None else again.checks.off_centre
    if b is not None and b.offset - tol.CHECK_CENTRE_SIGMAS * b.se < a.offset - tol.CHECK_CENTRE_SIGMAS * a.se:
        log.info("the axis ran %.2g radii off its wall's centre; fitted again with the wall on its own circles "
                 "taken back: %.2g", a.offset, b.offset)
        kept = again
    k = kept.checks.off_centre
    if k.offset - tol.CHECK_CENTRE_SIGMAS * k.se > tol.CHECK_CENTRE_REFUSE:
        raise NotTubularError(
            f"the fitted axis runs {k.offset:.2g} radii (+- {k.se:.2g}) off the centre of its wall at "
            f"{format_point(k.point, pm.winding.scale)} (s = {k.s:.3f}), also fitted again with its wall there taken "
            f"back: the wall does not give an axis there (too sparse for its bend, or far from round); {_REMESH_FINER}")
    check_centre(k, pm.winding.scale)
    return kept


def _sparse_wall(n_data, K):
    """Whether ``n_data`` data vertices on ``K`` nodes are at most ``GC_LAMBDA_VERTICES`` per axis segment: too
    few for the fit again with the wall on its own circles (an 8-around ring's fit then wandered 13-15 % r off
    its line, unconverged), so an axis off its wall's centre there is refused (:func:`_on_its_wall`)."""
    return n_data <= tol.GC_LAMBDA_VERTICES * (K - 1)


def _checked_or_again(it, start, data, checking, *, lam, mu, max_iter, default_nodes):
    """The cylinder of fixed point ``it`` checked against its mesh (:func:`_checked`), and ``it``; or, where the checks
    refuse a fit that did not converge on the default nodes, the fit again from coarser nodes
    (:func:`_coarse_to_fine`) if that converges and passes them (logged at INFO), else the first refusal.
    ``start``: the initial nodes, vertex parameters and length; ``data``: the vertices, subset, topology, end
    region, areas, end ids and initial normal; ``checking``: the mesh, its ends, the radius scale and whether the
    fit covers the whole mesh. An unconverged fit the checks pass is answered as before (with the WARNING)."""
    V, sub, topo, end_region, area, end_ids, normal = data
    pm, e0, e1, rscale, whole = checking

    def checked(state):
        return _checked_state(state, data, checking, lam=lam, mu=mu)

    try:
        return checked(it), it
    except NotTubularError as err:
        if it.pulled is not None:  # freed of Eq. 2's pull and refused: the fit with the pull (_freed)
            log.info("the axis freed of Eq. 2's pull was refused (%s); the fit with the pull is checked instead",
                     str(err).split(";")[0])
            return _checked_or_again(it.pulled, start, data, checking, lam=lam, mu=mu, max_iter=max_iter,
                                     default_nodes=default_nodes)
        if it.converged or not default_nodes:
            raise
        nodes, s0, length0 = start
        again = _coarse_to_fine(it, nodes, s0, V[sub], area[sub], end_region[sub], rscale, length0, lam=lam, mu=mu,
                                max_iter=max_iter, initial_normal=normal)
        if again is None:
            raise
        try:
            gc = checked(again)
        except NotTubularError:
            log.info("fitted again from coarser nodes, the fit was refused too; the first refusal stands")
            raise err from None
        log.info("the fit did not converge and was refused (%s); fitted again from coarser nodes it passes its checks",
                 str(err).split(";")[0])
        return gc, again


def _checked_state(state, data, checking, *, lam, mu):
    """The cylinder of fixed point ``state`` on ``data`` (:func:`_cylinder_of`), checked against its mesh
    (:func:`_checked`; ``checking``: the mesh, its ends, the radius scale, whether the fit covers the whole mesh)."""
    V, sub, topo, end_region, area, end_ids, normal = data
    pm, e0, e1, rscale, whole = checking
    cyl = _cylinder_of(state, V, sub, topo, end_region, area, mu, lam, end_ids, normal)
    return _checked(cyl, pm, e0, e1, whole=whole, rscale=rscale, warn_centre=False)


def _eq2_pull(gc, it, rscale):
    """Eq. 2's pull at fixed point ``it`` of cylinder ``gc`` in radii (:func:`_second_difference_pull` times the
    final weight; 0 for a fit with Eq. 2's weight on the step only, which pulls nothing)."""
    if it.free:
        return 0.0
    return gc.final_lam * _second_difference_pull(gc.centers, (True, True), rscale)


def _free_of_pull(gc, it, data, checking, *, L0, lam, mu, max_iter):
    """A fit on the caller's nodes or weight whose Eq. 2 pull exceeds ``GC_PULL_WARN`` radii (:func:`_eq2_pull`),
    fitted once more from its converged state with Eq. 2's weight on the step only (``pull=False``): kept, with
    the iterations of both, where that converges and passes the checks (logged at INFO); else ``gc``, ``it``.
    (A clean wall's fit on the defaults is freed before it is checked: :func:`_freed`.)

    Eq. 2's pull grows with the fourth power of the node spacing: the 2.5:1 flattened vein swept along the real
    coronary's line, on 58 nodes given (the default's half), read 0.068 radii and ran 2.6 % r mean and 13.9 % r
    worst off its exact line, silently; fitted once more without the pull, 0.08 / 0.75 (issue #48)."""
    V, sub, _, end_region, area, _, normal = data
    rscale = checking[3]
    pull = _eq2_pull(gc, it, rscale)
    if not it.converged or pull <= tol.GC_PULL_WARN:
        return gc, it
    free = fixed_point(it.nodes, it.s, V[sub], area[sub], end_region[sub], rscale, L0, lam=lam, mu=mu,
                       max_iter=max_iter, initial_normal=normal, pull=False)
    if not free.converged:
        log.info("the axis, fitted again without Eq. 2's pull, did not converge; kept as fitted")
        return gc, it
    free = replace(free, count=it.count + free.count)  # the cylinder reports the iterations of both
    try:
        cyl = _checked_state(free, data, checking, lam=lam, mu=mu)
    except NotTubularError as err:
        log.info("the axis, fitted again without Eq. 2's pull, was refused (%s); kept as fitted",
                 str(err).split(";")[0])
        return gc, it
    log.info("Eq. 2's weight held the axis about %.2g radii off its wall's fixed point; fitted "
             "again with the weight on the step only", pull)
    return cyl, free


def _warn_pull(gc, it, rscale, given):
    """WARNING where the fit on the caller's nodes or weight still has Eq. 2 pulling its axis more than
    ``GC_PULL_WARN`` radii from its wall's own fixed point (:func:`_free_of_pull` could not remove it)."""
    pull = _eq2_pull(gc, it, rscale)
    if pull > tol.GC_PULL_WARN:
        log.warning("Eq. 2's weight (lam %.3g on %d nodes) holds the fitted axis about %.2g radii from where its "
                    "wall alone would put it (%s): the axis may be that far off its centre in its bends; leave "
                    "n_nodes and lam to their defaults, or remesh the wall finer", gc.final_lam, len(gc.s), pull, given)


def _coarse_to_fine(it, nodes, s0, Vs, areas, ends_s, rscale, length0, *, lam, mu, max_iter, initial_normal):
    """A single vessel's fixed point ``it`` that did not converge from its first axis, fitted again from a fixed
    point on nodes ``GC_COARSE_FIRST`` times as far apart (issue #48).

    A 2.5:1 flattened vein's first axis (the harmonic level sets' centroids, 24-28 % r off in its bends: an
    ellipse's band centroids lie outward) lies outside the basin of its fixed point on half-radius nodes, which
    exists and is stable (started on the exact line, it stays within 0.2 % r): the fit wandered 30 iterations and
    kinked (refused). On nodes four times as far apart the first axis is inside the basin; from that fit's axis the
    one on ``nodes`` converges (0.21 % r mean, 1.9 worst), and then once more with Eq. 2's weight on the step only
    (``pull=False``: the data's own fixed point, Eq. 2's pull towards the chord gone; 0.074 / 0.83). Each stage is
    kept only if it converged; if the fit on ``nodes`` does not, None is returned. Its iteration count is the
    stages' total. Not tried (None) where the coarser nodes would be fewer than ``GC_MIN_NODES``. Only for a fit
    the checks refused (:func:`_checked_or_again`): taken for every unconverged fit, the real coronary decimated to
    15 % (answered, unconverged) came out 0.15 radii from its wall and refused, and the 4D-flow arch's main vessel
    through its branches converged from 13 nodes to a kink."""
    K = len(nodes)
    k1 = int(round((K - 1) / tol.GC_COARSE_FIRST)) + 1
    if k1 < tol.GC_MIN_NODES:
        return None
    kw = dict(lam=lam, mu=mu, max_iter=max_iter, initial_normal=initial_normal)
    first = fixed_point(_resample_arclength(nodes, k1), s0, Vs, areas, ends_s, rscale, length0, **kw)
    again = fixed_point(_resample_arclength(first.nodes, K), first.s, Vs, areas, ends_s, rscale, length0, **kw)
    count = it.count + first.count + again.count
    if again.converged:
        free = fixed_point(again.nodes, again.s, Vs, areas, ends_s, rscale, length0, pull=False, **kw)
        count += free.count
        again = free if free.converged else again
    log.info("the fit did not converge in %d iterations; from a fit on %d nodes first it %s", it.count, k1,
             "did" if again.converged else "did not either")
    return replace(again, count=count) if again.converged else None


def _sparse_fit(nodes, s0, Vs, areas, ends_s, rscale, length0, *, lam, mu, max_iter, initial_normal):
    """The fixed point of a sparse wall (fewer than ``GC_SPARSE_VERTICES`` data vertices per segment of the
    ``nodes``, less than a ring: a thin segmented branch, 6-8 edges around), in two fits (issue #48).

    On such a wall a node often has no ring of its own: the rings fix the corrections only where they lie,
    and Eq. 2's weight moves the corrections between them towards the chord with nothing to resist it (an
    exact axis of the X-ray coronary's line swept 8 around moved 5 % of its radius in one step, then ran
    away; on nodes one per ring Eq. 2 cut its sharpest bend by 0.3-2 radii). So:

    1. a first fit on nodes ``GC_SPARSE_VERTICES`` data vertices per segment apart (every segment holds
       more than a ring) with Eq. 2's weight at ``GC_LAMBDA_FLOOR`` times ``lam``, from the initial axis;
    2. where that fit converged on a clean circular wall (:func:`sparse_clean_wall`: its data vertices scatter
       about their circles by at most ``sqrt(GC_REFINE_LAMBDA)`` times ``GC_LAMBDA_SCATTER``, 0.71 % of the
       radius, robustly), from its axis the fit on ``nodes``' count
       with Eq. 2's weight on the step only (``pull=False``, :func:`vesselgp.axis.circle_fit_solve`): its
       fixed point is the rings' own, the nodes between them carried along smoothly.

    On 6-8-around tubes with exact truth this answers what one fit refused or left 1-3 % r off (a helix
    swept 6 around: refused, now 0.10 % r worst). A wall that scatters more (a segmented staircase, an
    elliptic section, whose circles do not pin the centres: without Eq. 2's pull a 14-around elliptic helix
    left its surface) or a first fit that did not converge returns None: the caller fits it as a dense wall.
    Returns the second fit's :class:`_Iteration`, or None."""
    K, n_data = len(nodes), np.count_nonzero((areas > 0) & ~ends_s)
    k1 = min(K, max(4, n_data // tol.GC_SPARSE_VERTICES))
    first = nodes if k1 == K else _resample_arclength(nodes, k1)
    it = fixed_point(first, s0, Vs, areas, ends_s, rscale, length0, lam=lam * tol.GC_LAMBDA_FLOOR, mu=mu,
                     max_iter=max_iter, initial_normal=initial_normal)
    log.debug("sparse wall (%d data vertices on %d nodes): first fit on %d nodes, %d iterations, %s", n_data, K, k1,
              it.count, "clean" if it.sparse is not None else "not clean or unconverged: fitted as a dense wall")
    if it.sparse is None:
        return None
    return fixed_point(_resample_arclength(it.nodes, K), it.s, Vs, areas, ends_s, rscale, length0,
                       lam=lam * tol.GC_LAMBDA_FLOOR, mu=mu, max_iter=max_iter, initial_normal=initial_normal,
                       pull=False)


def _refined(it, Vs, areas, ends_s, rscale, length0, lam, mu, max_iter, initial_normal):
    """:func:`refined` of a single vessel's fixed point ``it`` (its :class:`FitProblem` from these arguments)."""
    problem = FitProblem(it.nodes, it.s, Vs, areas, ends_s, rscale, length0, initial_normal)
    return refined([problem], [it], lam=lam, mu=mu, max_iter=max_iter)[0]


def refined(problems, states, *, lam, mu, max_iter, singular="raise", resample=True):
    """Converged fixed points ``states`` of clean walls, refined on closer nodes (issue #48).

    With nodes half a radius apart, Eq. 2's weight on the axis's second differences pulls a bend of
    varying curvature towards its chord, and the final circle fit with :func:`data_lambda`'s lower weight
    takes back only part of it (a real renal artery's line swept with exact circles: 0.084 % r mean, 0.45
    worst; the aorto-iliac network tree's branches 0.11 % r mean). Where that final fit lowered the weight to
    at most ``tolerances.GC_REFINE_LAMBDA`` of ``lam`` (a clean, densely meshed circular wall), Eq. 3 and
    Eq. 5 are iterated again from its axis on nodes ``tolerances.GC_REFINE_SPACING`` times as far apart (0.040
    % r on the same artery); a wall that scatters more keeps its state, as closer nodes fit its noise.

    A wall that scatters as little but keeps ``lam`` only because its nodes see too few vertices each
    (:func:`sparse_clean_wall`: a thin, cleanly meshed branch) is fitted again the other way, on fewer nodes,
    ``tolerances.GC_COARSEN_VERTICES`` data vertices per segment, where that spaces them at most
    ``tolerances.GC_COARSEN_SPACING`` times as far apart: its final circle fit can then lower the weight (the
    XCAT network tree's thin branches, 16 vertices per node, 1.6 % r worst in a kink before, 0.62 after; the
    synthetic aortic arch at 15 points around, 0.15 % r mean before, 0.037 after). A much sparser wall keeps
    its fit (without that limit, a branch of 5 vertices per node of a remeshed copy of the real XCAT tree went
    from 160 to 36 nodes, and the twist between that copy and the original read 1.7 degrees off instead of 0.7).

    A state is kept as it is (the refinement is not tried, or its result is dropped):

    - when Eq. 2's pull on it (:func:`_second_difference_pull` times ``lam``) is at most
      ``tolerances.GC_REFINE_MIN_MOVE`` radii: there is nothing to correct (a straight tube, a circular arc);
    - when the refined iteration does not converge within ``max_iter``, or its steps grow
      ``tolerances.GC_REFINE_GROWING`` times in a row once its outlier set is fixed (it diverges: the real X-ray
      coronary, a NURBS mesh of 30 vertices per node, from 0.0009 to 0.018 radii per step);
    - when the refined fit's own final circle fit kept the weight above ``tolerances.GC_REFINE_LAMBDA`` of
      ``lam`` (closer nodes that see too few vertices each: thin branches of the XCAT network tree, 16-20 per
      node, came out 0.2 % r worse; or fewer nodes that still see too few);
    - when it moved the axis by at most ``tolerances.GC_REFINE_MIN_MOVE`` radii (:func:`_refinement_move`):
      then only the node count would change (on the synthetic trees' branches it moved 1e-4 radii away from
      their junction sides).

    Each is logged (INFO for the first two kinds of failure, DEBUG otherwise). The refinement starts its
    outlier test afresh; started from the first fit's radii instead, it converged on that coronary (in 24 more
    iterations), and a twist imposed on it was then read back 0.65 degrees off instead of 0.33.

    With ``resample`` (a single vessel's fit) the refined axis is resampled back to the state's node count:
    the RMF, the torsion meter's Eq. 6 axis and its curvature and Frenet torsion see as many nodes as before
    (with the closer nodes a deformed helix's Frenet torsion was 11.6 % off near its ends, against 10). A
    tree's branches keep their closer nodes (``resample=False``): resampled back, the real network trees'
    branches lost the gain (the aorto-iliac Y 0.104 % r mean instead of 0.030), as each branch's node count
    also sets its path's.

    The refinements run in lock step (:func:`fixed_points`, a tree's branches together).

    Parameters
    ----------
    problems : sequence of FitProblem
        The fixed points' problems (their data; their initial nodes are not used).
    states : sequence of _Iteration
        Their converged states (:func:`fixed_points`).
    lam, mu, max_iter, singular
        As :func:`fixed_points`.
    resample : bool
        Resample a refined axis back to its state's node count.

    Returns
    -------
    list of _Iteration
        Each state itself, or its refined state: its nodes (resampled to the state's node count with
        ``resample``), the iteration count the two fits' together.
    """
    todo, counts = [], []
    for b, it in enumerate(states):
        K2 = _refit_nodes(it, lam)
        if K2 is not None and lam * _second_difference_pull(it.nodes, problems[b].pin,
                                                            problems[b].rscale) > tol.GC_REFINE_MIN_MOVE:
            todo.append(b)
            counts.append(K2)
    out = list(states)
    if not todo:
        return out
    fine_problems = [replace(problems[b], nodes=resample_arclength(states[b].nodes, K2), s0=states[b].s,
                             elliptic=states[b].elliptic)
                     for b, K2 in zip(todo, counts)]
    fines = fixed_points(fine_problems, lam=lam, mu=mu, max_iter=max_iter, singular=singular,
                         growing=tol.GC_REFINE_GROWING)
    for b, p, fine in zip(todo, fine_problems, fines):
        it, K, K2 = states[b], len(states[b].nodes), len(p.nodes)
        if not fine.converged:
            log.info("the fit's refinement on %d nodes did not converge (%d iterations); the axis on %d nodes is "
                     "kept", K2, fine.count, K)
            continue
        if fine.lam is None or fine.lam > tol.GC_REFINE_LAMBDA * lam:  # its nodes see too few vertices each
            log.info("the fit's refinement on %d nodes kept Eq. 2's weight at %.3g of lam (too few vertices per "
                     "node); the axis on %d nodes is kept", K2, 1.0 if fine.lam is None else fine.lam / lam, K)
            continue
        moved = _refinement_move(it.nodes, fine.nodes, p.pin, p.rscale)
        if moved <= tol.GC_REFINE_MIN_MOVE:  # nothing to correct: the first fit, on its own nodes
            log.debug("the fit's refinement on %d nodes moved its axis %.2g radii; the axis on %d nodes is kept",
                      K2, moved, K)
            continue
        log.debug("fit refined on %d nodes instead of %d (Eq. 2's final weight %.3g of lam, was %.3g): %d more "
                  "iterations", K2, K, fine.lam / lam, it.lam / lam, fine.count)
        out[b] = replace(fine, nodes=resample_arclength(fine.nodes, K) if resample else fine.nodes,
                         count=it.count + fine.count)
    return out


def _refit_nodes(it, lam):
    """The node count :func:`refined` fits a converged state ``it`` again on, or None.

    ``GC_REFINE_SPACING`` times as far apart where its final circle fit lowered the weight to
    ``GC_REFINE_LAMBDA`` of ``lam`` or less, and on a cone (its radii differ more than ``GC_REFINE_TAPER``-fold)
    at least as many as space them ``GC_REFINE_SPACING`` times half its narrowest radius apart (that radius at
    least ``GC_REFINE_NARROW_FLOOR`` times its mean): spaced for its mean radius, the narrow part of the 4D-flow
    arch's supra-aortic trunk (12.9 -> 4.1 mm) had nodes 0.8 of its own radius apart and its fit stayed 0.20 %
    r off its exact line (0.028 % r on nodes for its narrow part); where it kept ``lam`` only for too few
    vertices per node on a clean wall (``it.sparse``, :func:`sparse_clean_wall`), as many as give each segment
    ``GC_COARSEN_VERTICES`` of them (at least ``GC_MIN_NODES``), if that is fewer than it has and at most
    ``GC_COARSEN_SPACING`` times as far apart."""
    if not it.converged or it.lam is None:
        return None
    K = len(it.nodes)
    if it.lam <= tol.GC_REFINE_LAMBDA * lam:
        K2 = int(round((K - 1) / tol.GC_REFINE_SPACING))
        r = it.radii
        if r is not None and r.max() > tol.GC_REFINE_TAPER * r.min():  # a cone: nodes for its narrow part
            narrow = max(float(r.min()), tol.GC_REFINE_NARROW_FLOOR * float(r.mean()))
            spacing = tol.GC_REFINE_SPACING * tol.GC_NODE_SPACING * narrow
            K2 = max(K2, int(np.ceil(_chords(it.nodes)[-1] / spacing)))
        return K2 + 1
    if it.sparse is not None:
        K2 = max(tol.GC_MIN_NODES, int(it.sparse // tol.GC_COARSEN_VERTICES) + 1)
        return K2 if K2 < K and (K - 1) <= tol.GC_COARSEN_SPACING * (K2 - 1) else None
    return None


def _away_from_free_ends(arc, pin, rscale):
    """Which points of arc lengths ``arc`` (increasing) lie at least ``tolerances.GC_REFINE_FREE_END`` radii
    from each free end (``pin`` False there: a tree branch's junction side, which its junction redraws)."""
    keep = np.ones(len(arc), bool)
    margin = tol.GC_REFINE_FREE_END * rscale
    if not pin[0]:
        keep &= arc - arc[0] >= margin
    if not pin[1]:
        keep &= arc[-1] - arc >= margin
    return keep


def _second_difference_pull(nodes, pin, rscale):
    """Eq. 2's pull on a converged axis per unit ``lam``, in radii: the largest fourth difference of its nodes.

    At the fixed point the data's circle fits balance ``lam`` times the regulariser's gradient, ``D2^T D2 C``
    (the fourth difference inside), in units of the mean data weight per node: the axis sits about that far
    from where the data alone would put it. A refinement on closer nodes lowers it (by 0.8^4 at 0.8 times the
    spacing) and moves the axis by less than it (0.05-1 of it on the synthetic and the real network trees).
    Nodes within ``tolerances.GC_REFINE_FREE_END`` radii of a free end are not counted. (K,) nodes, K >= 5.
    """
    C = nodes
    d4 = np.linalg.norm(C[:-4] - 4.0 * C[1:-3] + 6.0 * C[2:-2] - 4.0 * C[3:-1] + C[4:], axis=1)
    keep = _away_from_free_ends(chord_length(C), pin, rscale)[2:-2]
    return float(d4[keep].max()) / rscale if keep.any() else 0.0


def _refinement_move(first, fine, pin, rscale):
    """The farthest a refined axis's node lies from the first axis, in radii: float.

    ``first`` (K, 3) and ``fine`` (k, 3) are the two fits' nodes; the first axis is the spline through
    ``first``. Nodes within ``tolerances.GC_REFINE_FREE_END`` radii of a free end are not counted
    (:func:`_away_from_free_ends`), nor nodes whose foot is an end of the first axis (a free end's overshoot
    along it).
    """
    L = resample_arclength(first, tol.GC_REFINE_MOVE_SAMPLES * (len(first) - 1) + 1)
    _, foot, d = polyline_feet(fine, L)
    counted = _away_from_free_ends(chord_length(fine), pin, rscale)
    counted &= ~(np.all(foot == L[0], axis=1) | np.all(foot == L[-1], axis=1))
    return float(d[counted].max()) / rscale if counted.any() else 0.0


def _checked(gc, pm, e0, e1, whole, rscale, warn_centre=True):
    """``gc`` checked against its mesh (inside the lumen, no turn tighter than its radius, its ends reached
    and, when it covers the whole mesh, its wall covered: :func:`vesselgp.checks.cylinder_checks`), with its
    checks; a fit stopped at the iteration cap is said so once (WARNING), with what the checks found. An axis off
    its wall's centre is named only with ``warn_centre``."""
    check_axis_inside(pm.V, pm.F, gc.s, gc.centers, gc.radii, winding=pm.winding)
    check_cylinder_bend(gc, pm.winding.scale, nodes=True)
    gc = replace(gc, checks=cylinder_checks(gc, pm, e0, e1, whole=whole, warn_centre=warn_centre))
    if not gc.converged:
        log.warning("the generalized-cylinder fit stopped at %d iterations, its axis still moving %.3g radii per "
                    "iteration (the tolerance is %.3g); its axis passed the checks against the mesh (inside the "
                    "lumen, every end reached%s)", gc.iterations, gc.last_step / rscale, tol.GC_CONVERGENCE,
                    "" if gc.checks.covered_fraction is None else ", the wall covered")
    return gc


def check_cylinder_bend(gc, scale, skip_start=0.0, skip=None, nodes=False):
    """:func:`vesselgp.inside.check_axis_bend` of a fitted cylinder's dense axis (mesh size ``scale``),
    past the first ``skip_start`` of its arc length (a tree branch's junction zone, led in along the
    lumen's centre line: anatomy, not the fit) and outside the ``skip`` intervals of ``s`` (its
    medial zones, the centre line too); with ``nodes``, the refusal also names fewer axis nodes
    (``n_nodes=``, half the fit's) as a stiffer axis (a single vessel's fit takes them)."""
    check_axis_bend(gc.dense_s, gc.length, gc.dense_frames[:, 0], gc.radius_at(gc.dense_s),
                    points=gc.dense_points, scale=scale, skip_start=skip_start, skip=skip,
                    fewer_nodes=max(len(gc.s) // 2, 4) if nodes else None)


def cylinder_sharp_bends(gc, skip_start=0.0, skip=None):
    """Where :func:`check_cylinder_bend` would refuse a fitted cylinder: the dense samples' ``s``
    (normalised arc length) that turn tighter than the radius there, (j,) float64."""
    bad, _ = sharp_bends(gc.dense_s, gc.length, gc.dense_frames[:, 0], gc.radius_at(gc.dense_s),
                         skip_start=skip_start, skip=skip)
    return gc.dense_s[bad]


def _spread_to_neighbours(adjacency, sub, s_sub):
    """Parameters of every vertex from those of the subset ``sub``: the mean over a vertex's
    mesh neighbours that have one, ring by ring outwards from the subset, (n,) float64.

    A start for the Newton projection within about an edge of each vertex's foot, on its own
    stretch of axis (a mesh neighbour lies on the same stretch even where the vessel folds
    close to itself), without a k-d tree query of every vertex.
    """
    n = adjacency.shape[0]
    s = np.zeros(n)
    known = np.zeros(n, bool)
    s[sub], known[sub] = s_sub, True
    A = adjacency.astype(np.float64)  # once: scipy would upcast small integer data in every product
    while not known.all():
        total, count = A @ s, A @ known.astype(np.float64)
        new = ~known & (count > 0)
        if not new.any():  # unreachable: the mesh is one connected component (checked_mesh)
            raise InvalidMeshError("mesh has vertices unconnected to the rest; run vesselgp.clean_mesh first")
        s[new] = total[new] / count[new]
        known |= new
    return s


@dataclass(frozen=True)
class FitProblem:
    """One Eq. 3 / Eq. 5 fixed point: initial nodes and vertex parameters, and its data.

    Attributes
    ----------
    nodes : (K, 3) float64
        Initial axis nodes.
    s0 : (q,) float64
        Initial normalised arc length of each data vertex.
    Vs : (q, 3) float64
        The data vertices.
    areas : (q,) float64
        Their Voronoi areas (0 leaves a vertex out).
    ends_s : (q,) bool
        Cap or tip vertices (never data).
    rscale : float
        Radius scale: convergence and the outlier floor are in its units.
    length0 : float
        Length of the initial axis (sizes the first projection window).
    initial_normal : (3,) float64, optional
    pin : (bool, bool)
        Whether the first and the last node stay where they are (Eq. 3's correction held at
        zero there): an end at a mesh end's centre. A free end (a tree branch's junction side,
        first placed at a biased band centroid of the junction's bulge) moves with its data,
        which are tapered in over its last segment (:func:`fixed_points`).
    mirror : (bool, bool)
        At a pinned end, whether Eq. 2's second differences continue past it to a mirror
        ghost node (:func:`vesselgp.axis.circle_fit_solve`): ends whose wall reaches the end's
        plane (open and capped). Off for a rounded tip: there it made some branches of the
        8-tip test tree take 24 iterations.
    rescue : bool
        Whether the outlier test takes back vertices that lie on their wall's own circles
        (:func:`_on_wall_circles`): a second pass where the first fit's axis ran off its wall's centre.
    pull : bool
        Whether Eq. 2's weight pulls the axis towards its chord (the paper's term), or only smooths and damps
        each step (``pull=False``, :func:`vesselgp.axis.circle_fit_solve`): a sparse wall's second fit.
    elliptic : bool, optional
        Whether its wall's sections are elliptic (:mod:`vesselgp.sections`); None reads it on the first
        iteration. A fit from a converged state on the same wall passes the state's.
    warm : bool
        Whether ``s0`` is the data's projection on ``nodes`` already (a converged state's, fitted again from its
        own nodes): the first projection is then Newton's from ``s0``, not a search of a window about it.
    """

    nodes: np.ndarray
    s0: np.ndarray
    Vs: np.ndarray
    areas: np.ndarray
    ends_s: np.ndarray
    rscale: float
    length0: float
    initial_normal: np.ndarray | None = None
    pin: tuple = (True, True)
    mirror: tuple = (False, False)
    rescue: bool = False
    pull: bool = True
    elliptic: bool | None = None
    warm: bool = False


def fixed_point(nodes, s0, Vs, areas, ends_s, rscale, length0, *, lam, mu, max_iter, initial_normal=None,
                what="generalized-cylinder fit", growing=None, rescue=False, pull=True, elliptic=None, warm=False):
    """Iterate Eq. 3 and Eq. 5 (projection, circle-fit correction, radius) to their fixed point.

    :func:`fixed_points` of the one :class:`FitProblem` these arguments describe (its attributes, ``rescue``,
    ``pull``, ``elliptic`` and ``warm`` among them; ``lam``, ``mu``, ``max_iter``, ``what`` and ``growing`` as there).

    Returns
    -------
    _Iteration
    """
    problem = FitProblem(nodes, s0, Vs, areas, ends_s, rscale, length0, initial_normal, rescue=rescue, pull=pull,
                         elliptic=elliptic, warm=warm)
    return fixed_points([problem], lam=lam, mu=mu, max_iter=max_iter, what=what, growing=growing)[0]


def fixed_points(problems, *, lam, mu, max_iter, what="generalized-cylinder fit", singular="raise", unsettled=None,
                 growing=None):
    """Iterate Eq. 3 and Eq. 5 of independent problems (a tree's branches) to their fixed points.

    The problems run in lock step on one :class:`vesselgp.axis.AxisStack`: each iteration
    projects, parameterises and sums the data of every problem still running in one
    vectorised pass, then solves each problem's banded systems; a problem that has
    converged stops. Each problem gets the same numbers, bit for bit, as it would alone
    (the stack's rows and segment sums are its own), only about as many passes as the
    slowest problem takes instead of one per problem and iteration (a 27k-vertex tree's
    seven branches: 9 passes instead of 49 iterations).

    Parameters
    ----------
    problems : sequence of FitProblem
    lam, mu : float
        Eq. 2 and Eq. 4 weights.
    max_iter : int
    what : str
        Names the fit in the debug log of the problems that stop unconverged (the callers say what
        that means for their result: :func:`fit_generalized_cylinder` warns once, a tree reports it
        per branch).
    singular : {"raise", "stop"}
        A problem whose system is singular (a stretch with no wall around it) raises
        :class:`NotTubularError`, or (``"stop"``, a tree's branches) stops there with
        ``singular`` set, ``converged`` False and an infinite ``step``.
    unsettled : (float, int), optional
        ``(radii, n)``: a problem whose axis has moved more than ``radii`` of its radius scale in
        each of its last ``n`` iterations stops there, unconverged (a tree's branch that wanders
        rather than settles, whose axis is then the centre line: :func:`vesselgp.fit_vessel_tree`).
        Default: every problem runs to ``max_iter``.
    growing : int, optional
        A problem whose step, once its outlier set is fixed, has grown in each of its last ``growing``
        iterations stops there, unconverged: with fixed weights a fixed point that settles contracts (a
        refinement on closer nodes that diverges slowly, :func:`_refined`). Default: never.

    Returns
    -------
    list of _Iteration
        The last state of each problem; ``converged`` says whether the axis step, or once the
        outlier set is fixed the next step predicted from the last two (``step^2 / previous``,
        the iteration then contracting geometrically), fell below ``tolerances.GC_CONVERGENCE``
        radii.
    """
    states = [_Iteration(p.nodes, p.s0, None, 0, False, elliptic=p.elliptic) for p in problems]
    windows = None if all(p.warm for p in problems) else [
        4.0 / (len(p.nodes) - 1) + 2.0 * p.rscale / p.length0 for p in problems]
    running = list(range(len(problems)))
    stack = None
    polishing, polished = set(), set()
    moving = [0] * len(problems)  # iterations in a row that moved more than unsettled[0] radii
    grew = [0] * len(problems)  # iterations in a row whose step grew, the outlier set fixed
    for i in range(max_iter + 1):
        if i == max_iter:  # past the cap only the polish of problems that converged on it
            running = [b for b in running if b in polishing]
            if not running:
                break
        if stack is None or stack.ids != running:
            stack = _ProblemStack([problems[b] for b in running], running)
        new = _iterate(stack, [states[b] for b in running], windows, lam, mu, singular == "stop",
                       [b in polishing for b in running])
        for b, st in zip(running, new):
            grew[b] = grew[b] + 1 if states[b].rejected is not None and st.step > states[b].step else 0
            if b in polishing:
                polished.add(b)
                st = replace(st, converged=states[b].converged, count=states[b].count, step=states[b].step)
            states[b] = st
        windows = None
        if unsettled is not None:
            for b in running:
                moving[b] = moving[b] + 1 if states[b].step > unsettled[0] * problems[b].rscale else 0
        # a converged problem gets one more circle fit with data_lambda's weight (issue #48)
        polishing = {b for b in running if states[b].converged and not states[b].singular and b not in polished}
        running = [b for b in running if b in polishing or not (states[b].converged or states[b].singular
                                                               or (unsettled is not None and moving[b] >= unsettled[1])
                                                               or (growing is not None and grew[b] >= growing))]
        if not running:
            return [replace(st, free=not p.pull) for st, p in zip(states, problems)]
    log.debug("%d %s(s) stopped at %d iterations, unconverged", len(running), what, max_iter)
    return [replace(st, free=not p.pull) for st, p in zip(states, problems)]


@dataclass(frozen=True)
class _Iteration:
    """State of the fixed-point iteration: nodes, vertex parameters, radii, count, converged."""

    nodes: np.ndarray
    s: np.ndarray
    radii: np.ndarray | None
    count: int
    converged: bool
    rejected: np.ndarray | None = None
    inside: np.ndarray | None = None
    step: float = float("inf")
    axis: Axis | None = None  # the axis this iteration worked on (its frame is carried to the next)
    singular: bool = False  # its system was singular (fixed_points with singular="stop")
    lam: float | None = None  # Eq. 2's weight of its last circle fit (data_lambda's on the polish)
    sparse: int | None = None  # its data vertices, when the polish kept lam only for too few of them per node
    free: bool = False  # its fit put Eq. 2's weight on the step only (pull=False; set by fixed_points): no pull
    elliptic: bool | None = None  # its wall's sections are elliptic (vesselgp.sections; read on its first iteration)
    pulled: "_Iteration | None" = None  # the fit with Eq. 2's pull this one was freed of (_freed)


class _ProblemStack:
    """The data of the problems still running, stacked once: rows, slices, per-row node counts."""

    def __init__(self, problems, ids):
        self.ids, self.problems = list(ids), problems
        counts = [len(p.Vs) for p in problems]
        edges = np.concatenate([[0], np.cumsum(counts)])
        self.counts, self.slices = counts, [slice(a, b) for a, b in zip(edges[:-1], edges[1:])]
        K = np.array([len(p.nodes) for p in problems])
        self.nodeoff = np.concatenate([[0], np.cumsum(K)[:-1]])
        if len(problems) == 1:
            self.PT = np.ascontiguousarray(problems[0].Vs.T)
            self.K, self.rscale, self.rowoff, self.total = int(K[0]), problems[0].rscale, None, None
        else:
            self.PT = np.ascontiguousarray(np.concatenate([p.Vs for p in problems]).T)
            self.K = np.repeat(K, counts)
            self.rscale = np.repeat([p.rscale for p in problems], counts)
            self.rowoff = np.repeat(self.nodeoff, counts)
            self.total = int(K.sum())


def _iterate(stack, its, windows, lam, mu, stop_singular=False, polish=None):
    """One outer iteration of every problem on ``stack``: project (s_i), circle-fit correction
    (Eq. 3), radius (Eq. 5), resample. ``windows`` (one per problem) on the first iteration. With
    ``stop_singular`` a problem whose system is singular is returned unchanged, marked singular. A problem pinned
    at both ends takes Eq. 3's correction as the taper's Newton step (:func:`vesselgp.taper.taper_step`)."""
    probs = stack.problems
    axes = [Axis(it.nodes, p.initial_normal, carry=it.axis) for it, p in zip(its, probs)]
    ax = AxisStack(axes, stack.PT, stack.counts)
    if windows is not None:
        s_raw = _joined([a.project(p.Vs, it.s, w, None) for a, p, it, w in zip(axes, probs, its, windows)])
    else:
        s_raw = ax.project(_joined([it.s for it in its]), tol.GC_NEWTON_STEPS_WARM)
    s = np.clip(s_raw, 0, 1)
    local, jac = ax.local_coords(s)
    w = np.empty(len(s))
    inside = []
    for b, (it, p, r) in enumerate(zip(its, probs, stack.slices)):
        # once the outlier set is fixed, so is the set of vertices within the axis's range: a vertex
        # crossing an unpinned end would otherwise switch on and off and the fixed point cycle
        ins = it.inside if it.rejected is not None else (s_raw[r] > 0) & (s_raw[r] < 1) & ~p.ends_s
        w[r] = _robust_weights(s[r], local[r], jac[r], p.areas, it.radii, ins, it.rejected,
                               axes[b].length if p.rescue else None)
        _taper_free_ends(w[r], s_raw[r], len(it.nodes) - 1, p.pin)
        inside.append(ins)
    its = [it if it.elliptic is not None else _read_sections(it, s[r], local[r], w[r]) for it, r in zip(its, stack.slices)]
    elliptic = [it.elliptic for it in its]
    rows = elliptic[0] if len(its) == 1 else np.repeat(elliptic, stack.counts)
    circle = circle_fit_sums(s, local, w, stack.K, stack.rscale, stack.rowoff, stack.total, elliptic=rows)
    radius = _radius_sums(s, np.hypot(local[:, 1], local[:, 2]), w, stack.K, stack.rowoff, stack.total)
    out = []
    how = "none" if stop_singular else "raise"
    for b, (it, p, r) in enumerate(zip(its, probs, stack.slices)):
        K, o = len(it.nodes), int(stack.nodeoff[b])
        lam_b = lam
        if polish is not None and polish[b]:
            rel = (conic_residual if it.elliptic else _rel_residual)(s[r], local[r], w[r], it.radii)
            lam_b = data_lambda(lam, rel, K)
            if lam_b >= lam:  # the converged axis is the polished one: nothing to redo
                out.append(replace(it, lam=lam, sparse=sparse_clean_wall(rel, K)))
                continue
        corr = circle_fit_solve(axes[b].node_frames(), it.nodes, circle[0][o:o + K - 1], circle[1][o:o + K - 1],
                                lam_b, p.rscale, p.pin, p.mirror, singular=how, pull=p.pull)
        radii = None if corr is None else _radius_solve(radius[0][o:o + K], radius[1][o:o + K - 1],
                                                        radius[2][o:o + K], mu, singular=how)
        if radii is None:
            out.append(replace(it, converged=False, step=float("inf"), axis=axes[b], singular=True))
            continue
        if all(p.pin):  # a tapering tube's Newton step (not at a junction's side: the wall there is not a tube's)
            corr = taper_step(corr, radii, axes[b].node_frames(), axes[b].length)
        out.append(replace(_advance(it, axes[b], corr, radii, s[r], w[r], jac[r], inside[b], p.rscale), lam=lam_b))
    return out


def _read_sections(it, s, local, w):
    """State ``it`` with its wall's sections read at its first axis (:func:`vesselgp.sections.section_shape`); an
    elliptic wall is logged at INFO (its fit carries their second harmonic)."""
    shape = section_shape(s, local, w, len(it.nodes))
    if shape.elliptic:
        log.info("the wall's sections are ellipses (second harmonic %.2g, about (a^2 - b^2) / (a^2 + b^2); %.2g of "
                 "its departure from circles left about them): fitted about their centres", shape.amplitude,
                 shape.explained)
    return replace(it, elliptic=shape.elliptic)


def data_lambda(lam, rel_residual, K):
    """Eq. 2's weight on the axis's second differences, from the data's own scatter about the fit.

    ``lam`` is the weight for a wall that scatters about its circles by ``tolerances.GC_LAMBDA_SCATTER``
    radii (robust standard deviation of ``rel_residual``, the data vertices' ``(rho - r) / r``) with
    ``tolerances.GC_LAMBDA_VERTICES`` data vertices per segment, and for any wall with fewer vertices per
    segment (a thin segmented branch, 6-8 edges around: each node's circle is loose, and the fixed point of
    an 8-point-around tube ran away in its bends with less). Above that, a node's circle-fit centre varies as
    the scatter squared, and the weight follows, ``lam * (sigma / GC_LAMBDA_SCATTER)^2``, never above ``lam``
    and never below ``GC_LAMBDA_FLOOR`` times it (the number of vertices per segment only decides whether the
    weight is lowered at all). A
    segmented or non-circular wall (sigma of several per cent of the radius) keeps ``lam``: its sections
    do not pin the centres, and without the weight an elliptic section's fit wandered off in bends. A
    clean, densely meshed circular tube (sigma 0.1-0.3 %) gets the floor: with ``lam`` its axis was pulled
    towards the chord by about ``lam`` x curvature x spacing^2, 3 % of the radius in bends of curvature x
    radius 0.5 (issue #48).

    Parameters
    ----------
    lam : float
    rel_residual : (q,) float64
        ``(rho - r) / r`` of the data vertices (weight > 0); empty on the first iteration (no radii yet).
    K : int
        Axis nodes.

    Returns
    -------
    float
    """
    if len(rel_residual) == 0:
        return lam
    factor, per = _wall_scatter(rel_residual, K)
    if per <= tol.GC_LAMBDA_VERTICES:  # a sparse wall: few vertices per node leave its circles loose
        return lam
    return lam * float(np.clip(factor, tol.GC_LAMBDA_FLOOR, 1.0))


def _wall_scatter(rel_residual, K):
    """``(sigma / GC_LAMBDA_SCATTER)^2`` of the data vertices' ``rel_residual`` (sigma their robust standard
    deviation, 1.4826 x the median absolute value) and their number per segment of ``K`` nodes."""
    sigma = 1.4826 * float(np.median(np.abs(rel_residual)))
    return (sigma / tol.GC_LAMBDA_SCATTER) ** 2, len(rel_residual) / max(K - 1, 1)


def sparse_clean_wall(rel_residual, K):
    """The data vertices of a wall clean enough to lower Eq. 2's weight that keeps it for too few of them per node.

    :func:`data_lambda` keeps ``lam`` where a segment has at most ``tolerances.GC_LAMBDA_VERTICES`` data
    vertices, however little they scatter. Where they scatter so little that, denser, the weight would come
    out at ``tolerances.GC_REFINE_LAMBDA`` of ``lam`` or less (a thin, cleanly meshed branch: the XCAT network
    tree's, 16 vertices per node), :func:`refined` fits it again on fewer nodes.

    Returns
    -------
    int or None
        The number of data vertices, or None for a wall that is dense enough, or scatters too much.
    """
    if len(rel_residual) == 0:
        return None
    factor, per = _wall_scatter(rel_residual, K)
    return len(rel_residual) if per <= tol.GC_LAMBDA_VERTICES and factor <= tol.GC_REFINE_LAMBDA else None


def _rel_residual(s, local, w, radii):
    """``(rho - r) / r`` of the vertices with weight (none before the first radii), (q,) float64."""
    if radii is None:
        return np.zeros(0)
    sel = w > 0
    r = np.interp(s[sel], np.linspace(0, 1, len(radii)), radii)
    return np.hypot(local[sel, 1], local[sel, 2]) / r - 1.0


def _taper_free_ends(w, s_raw, segments, pin):
    """Weights ``w`` (in place) ramped from 0 at a free (unpinned) end to 1 a segment in.

    A vertex crossing a free end then enters or leaves the data with no weight. With a hard
    cut, a few vertices at a junction side toggled in and out and the end node cycled, a
    step of 1.5e-2 radii each way, to the iteration cap. Taking the vertices beyond a free
    end in instead converged, but to where the outlier set happened to be frozen: a rigid
    motion moved a branch by 2e-3 radii instead of 1e-14.
    """
    if not pin[0]:
        w *= np.clip(s_raw * segments, 0.0, 1.0)
    if not pin[1]:
        w *= np.clip((1.0 - s_raw) * segments, 0.0, 1.0)


def _joined(arrays):
    """The arrays end to end (the one array itself when there is one)."""
    return arrays[0] if len(arrays) == 1 else np.concatenate(arrays)


def _advance(it, axis, corr, radii, s, w, jac, inside, rscale):
    """The next state of one problem from its circle-fit correction and radii."""
    nodes = it.nodes
    K = len(nodes)
    frozen = it.rejected is not None
    step = float(np.abs(corr).max())
    nodes = nodes + corr
    # parameters on the corrected axis, for the next projection's start
    new_arc = _chords(nodes)
    s_next = np.interp(s, np.linspace(0, 1, K), new_arc / new_arc[-1])
    log.debug("GC iteration %d: axis moved %.3g (radius %.3g)", it.count + 1, step, rscale)
    # robust reweighting until the axis has nearly settled, then a fixed outlier set (IRLS):
    # vertices near the outlier threshold would otherwise toggle and the fixed point drift
    rejected, kept = it.rejected, it.inside
    if not frozen and it.radii is not None and step < tol.GC_REWEIGHT_UNTIL * rscale:
        rejected, kept = (w == 0) & inside & (jac > tol.GC_MIN_STRETCH), inside
    # converged: the axis moved less than the tolerance, or (outlier set fixed, the step shrinking
    # geometrically) the next move, predicted as step^2 / previous step, would
    predicted = step * step / it.step if frozen and step < it.step else step
    return _Iteration(_resample_arclength(nodes, K), s_next, radii, it.count + 1,
                      min(step, predicted) < tol.GC_CONVERGENCE * rscale, rejected, kept, step, axis,
                      elliptic=it.elliptic)


def cylinder_from_axis(axis, V, s_raw, end_region, area, it, mu, lam, end_ids, rescue=False):
    """The :class:`GeneralizedCylinder` of a converged axis from the final projection ``s_raw`` of ``V``.

    The radius (Eq. 4-5) is refitted on these vertices with the outlier test
    against ``it.radii`` (taking back the vertices on their wall's own circles with ``rescue``); ``it`` also
    gives the iteration count and convergence.
    """
    K = len(it.nodes)
    inside = (s_raw > 0) & (s_raw < 1) & ~end_region
    s = np.clip(s_raw, 0, 1)
    local, jac = local_coords(axis, V, s)
    w = _robust_weights(s, local, jac, area, it.radii, inside, length=axis.length if rescue else None)
    radii = _radius_fit(s, np.hypot(local[:, 1], local[:, 2]), w, K, mu)
    sK = np.linspace(0, 1, K)
    centers, frames = axis.at(sK)
    return GeneralizedCylinder(
        s=sK, length=axis.length, centers=centers, radii=radii, frames=frames,
        vertex_s=s, vertex_theta=np.arctan2(local[:, 2], local[:, 1]), vertex_local=local,
        vertex_weight=w, vertex_area=np.where(w > 0, area, 0.0), ends=tuple(end_ids),
        dense_s=axis.s, dense_points=axis.points, dense_frames=axis.frames,
        iterations=it.count, converged=it.converged, lam=lam, mu=mu, last_step=float(it.step),
        final_lam=lam if it.lam is None else float(it.lam),
    )


def _check_options(n_nodes, lam, mu, max_iter):
    if n_nodes is not None and (isinstance(n_nodes, bool) or not isinstance(n_nodes, (int, np.integer))
                                or n_nodes < 4):
        raise OptionError(f"n_nodes must be an integer of at least 4, got {n_nodes!r}; or None for the default")
    if not (np.isfinite(lam) and lam >= 0 and np.isfinite(mu) and mu >= 0):
        raise OptionError(f"lam and mu must be finite and non-negative, got {lam!r}, {mu!r}")
    if max_iter < 1:
        raise OptionError(f"max_iter must be at least 1, got {max_iter}")


def _data_weights(V, Fg, wall_area, e0, e1, n_ends, rscale, geodesics=None, topology=None):
    """Eq. 1's weights (the wall's Voronoi areas, zero off the path between the ends) and the cap vertices.

    ``wall_area`` is ``voronoi_areas(V, Fg)``, of the faces with a well-defined area
    (zero-area faces have infinite cotangent weights).
    """
    end_region = np.zeros(len(V), bool)
    for e in (e0, e1):
        if getattr(e, "kind", "open") != "open":
            end_region[np.asarray(e.vertices, np.int64)] = True
    area = wall_area
    if n_ends > 2:
        area = np.where(_path_mask(V, Fg, e0, e1, rscale, geodesics, topology, wall_area), wall_area, 0.0)
    return area, end_region


def _initial_nodes(V, Fg, e0, e1, area, chord, rscale, n_nodes, total_area, edges=None):
    """Harmonic initialisation: K nodes at equal arc length, the vertices' first s and the axis length.

    ``area`` weighs the band centroids; ``total_area`` (the surface's) sizes the coarse cells
    of :func:`_harmonic_between`, ``edges`` (each edge of ``Fg`` once, when known) join them."""
    K0 = int(np.clip(chord / (tol.GC_NODE_SPACING * rscale), tol.GC_MIN_NODES, tol.GC_MAX_NODES))
    pts, s_prev = _initial_axis(V, Fg, e0, e1, area, K0, rscale, total_area, edges)
    L0 = chord_length(pts)[-1]
    K = int(n_nodes or np.clip(L0 / (tol.GC_NODE_SPACING * rscale), tol.GC_MIN_NODES, tol.GC_MAX_NODES))
    nodes = resample_arclength(pts, K)
    nodes[0], nodes[-1] = e0.center, e1.center
    return nodes, s_prev, L0
