"""Material twist between two scans of one artery, from its side branches: :func:`twist_between`.

Two scans of the same artery (supine and flexed, systole and diastole) share no
vertices, so the material twist between them is measured, as clinical studies
do, from the side branches used as fiducials:

1. **Main vessel.** Each scan is fitted as a tree (:func:`vesselgp.fit_vessel_tree`)
   rooted at ``ends[0]``; the main vessel runs to ``ends[1]`` (by default the
   two widest ends, the widest first). Its axis is the single generalized
   cylinder fitted between those ends (:func:`vesselgp.fit_generalized_cylinder`,
   whose robust weights drop the side branches): its RMF runs smoothly through
   the junctions, where the tree path's chain of branch axes and junction links
   added RMF rotation (up to 3.4 degrees per segment on the synthetic pairs,
   against 1.1 with the single fit). ``s`` is arc length from ``ends[0]``.
2. **Landmarks.** Every branch of the tree that leaves the main path is a
   landmark at its junction point, projected onto the main axis for its ``s``
   (at a junction with two side branches, the wider one, with a warning).
3. **Azimuth.** The side branch's initial direction is the chord of its axis
   past the junction zone (from ``TWIST_DIR_START`` main radii to that plus
   ``TWIST_DIR_SPAN`` branch radii along it); its azimuth is the angle of that
   direction about the main tangent, measured from U in the main path's RMF at
   the junction (right-handed about the axis from ``ends[0]`` to ``ends[1]``).
   The RMF carries no twist of its own (paper Section 1), so a landmark's
   azimuth changes between the scans by the material twist there (Eq. 7's
   ``alpha``) plus a constant (the RMFs' arbitrary starting normals).
4. **Matching.** Landmarks are matched in order along the axis by dynamic
   programming on their normalised position ``s / L`` and radius
   (``TWIST_MATCH_POSITION``, ``TWIST_MATCH_RADIUS``, a landmark left unmatched
   costs ``TWIST_MATCH_GAP``). Without given ends the second scan's direction is
   chosen by the landmarks (the order that matches better). Unmatched
   landmarks are reported (and logged); a segment twist above
   ``TWIST_SUSPECT_DEG`` is logged as a suspect match.
5. **Twist.** With ``delta_j = azimuth_b[j] - azimuth_a[j]``, the twist of the
   segment between landmarks ``j`` and ``j + 1`` is ``delta_{j+1} - delta_j``
   wrapped to (-pi, pi]: the material twist ``alpha(s_{j+1}) - alpha(s_j)``.
   The constant cancels, and so does any rigid motion of either scan.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from . import tolerances as tol
from ._validate import mesh_arguments
from .errors import EndsError, NotTubularError
from .mesh._ends_format import end_listing
from .rotations import wrap_angle
from .fit import fit_generalized_cylinder
from .prepared import prepared_mesh
from .tree import fit_vessel_tree

log = logging.getLogger(__name__)

__all__ = ["ScanTwist", "twist_between", "scan_landmarks", "Landmarks"]


@dataclass(frozen=True, eq=False)
class Landmarks:
    """The side-branch landmarks of one scan along its main vessel (see the module notes).

    Attributes
    ----------
    tree : VesselTree
    ends : (int, int)
        End indices (into ``tree.ends``) of the main vessel, from ``s = 0``.
    main : GeneralizedCylinder
        The main vessel's single fit from ``ends[0]`` to ``ends[1]`` (from the
        original ends when ``reversed`` is True).
    length : float
    points : (k, 3) float64
        Junction points, in order of ``s``.
    s : (k,) float64
        Arc length of each along the main axis.
    azimuth : (k,) float64
        Azimuth of each side branch's initial direction (radians, see step 3).
    direction : (k, 3) float64
        That initial direction (unit).
    radius : (k,) float64
        Mean radius of each side branch.
    branch : (k,) int64
        The side branch (index into ``tree.branches``).
    reversed : bool
        The main axis runs from the tree's path end back to its root (``s``
        measured from ``ends[0]`` all the same).
    """

    tree: object
    ends: tuple
    main: object = field(repr=False)
    length: float
    points: np.ndarray
    s: np.ndarray
    azimuth: np.ndarray
    direction: np.ndarray
    radius: np.ndarray
    branch: np.ndarray
    reversed: bool = False

    def flipped(self):
        """The same landmarks seen from the other end: ``s -> L - s``, azimuth negated, order reversed."""
        o = slice(None, None, -1)
        return Landmarks(tree=self.tree, ends=self.ends[::-1], main=self.main, length=self.length,
                         points=self.points[o], s=(self.length - self.s)[o], azimuth=(-self.azimuth)[o],
                         direction=self.direction[o], radius=self.radius[o], branch=self.branch[o],
                         reversed=not self.reversed)


@dataclass(frozen=True, eq=False)
class ScanTwist:
    """Material twist between two scans, segment by segment between matched side branches.

    Attributes
    ----------
    landmarks_a, landmarks_b : (k, 3) float64
        Junction points of the matched side branches, row by row.
    s_a, s_b : (k,) float64
        Their arc length along each scan's main axis.
    azimuth_a, azimuth_b : (k,) float64
        Their azimuths (radians) in each scan's RMF.
    segment_twist : (k - 1,) float64
        Twist between consecutive landmarks (radians), right-handed about the
        main axis from ``ends_a[0]`` to ``ends_a[1]``.
    segment_length_a, segment_length_b : (k - 1,) float64
    twist_per_length : (k - 1,) float64
        ``segment_twist / segment_length_a`` (radians per mesh unit of scan A).
    stretch : (k - 1,) float64
        ``segment_length_b / segment_length_a``.
    total_twist : float
        Sum of the segment twists (radians; not wrapped).
    ends_a, ends_b : (int, int)
        End indices of each main vessel, from its ``s = 0`` end.
    length_a, length_b : float
        Main-axis lengths.
    unmatched_a, unmatched_b : (u,) float64
        Arc lengths of the landmarks left unmatched in each scan.
    side_a, side_b : (k,) int64
        The matched side branches (indices into each tree's branches).
    radius_a, radius_b : (k,) float64
        Their mean radii.
    tree_a, tree_b : VesselTree
    """

    landmarks_a: np.ndarray
    landmarks_b: np.ndarray
    s_a: np.ndarray
    s_b: np.ndarray
    azimuth_a: np.ndarray
    azimuth_b: np.ndarray
    segment_twist: np.ndarray
    segment_length_a: np.ndarray
    segment_length_b: np.ndarray
    twist_per_length: np.ndarray
    stretch: np.ndarray
    total_twist: float
    ends_a: tuple
    ends_b: tuple
    length_a: float
    length_b: float
    unmatched_a: np.ndarray
    unmatched_b: np.ndarray
    side_a: np.ndarray
    side_b: np.ndarray
    radius_a: np.ndarray
    radius_b: np.ndarray
    tree_a: object = field(repr=False)
    tree_b: object = field(repr=False)


def _main_ends(ends, given, which):
    """End indices (i, j) of the main vessel: the given pair, or the two widest, widest first."""
    if given is not None:
        try:
            i, j = (int(x) for x in given)
        except (TypeError, ValueError):
            raise EndsError(f"{which} must be a pair of end indices (i, j), got {given!r}") from None
        if not (0 <= i < len(ends) and 0 <= j < len(ends)) or i == j:
            raise EndsError(f"{which}=({i}, {j}) must be two different end indices in 0..{len(ends) - 1} "
                            f"(ends: {end_listing(ends)})")
        return i, j
    if len(ends) < 3:
        raise EndsError(f"the scan has {len(ends)} ends: no side branch to use as a landmark "
                        f"(ends: {end_listing(ends)})")
    order = np.argsort([-e.radius for e in ends], kind="stable")
    return int(order[0]), int(order[1])


def _at_arclength(gc, a):
    """Point of ``gc``'s axis at arc length ``a`` from its s = 0 end (clipped)."""
    return gc.at([float(np.clip(a / gc.length, 0.0, 1.0))])[0][0]


def _project_s(main, P):
    """Arc length of the point of ``main``'s dense axis nearest to ``P`` (linear refinement on the segment)."""
    X = main.dense_points
    k = int(np.argmin(np.linalg.norm(X - P, axis=1)))
    best = (np.inf, 0.0)
    for a in (max(k - 1, 0), k):
        b = min(a + 1, len(X) - 1)
        d = X[b] - X[a]
        t = float(np.clip((P - X[a]) @ d / (d @ d), 0.0, 1.0)) if d @ d > 0 else 0.0
        dist = float(np.linalg.norm(X[a] + t * d - P))
        if dist < best[0]:
            best = (dist, main.dense_s[a] + t * (main.dense_s[b] - main.dense_s[a]))
    return float(best[1]) * main.length


def scan_landmarks(V, F=None, ends=None):
    """The side-branch landmarks of one scan (steps 1-3 of the module notes).

    Parameters
    ----------
    V : (n, 3) float64, PreparedMesh or mesh object
        Vertex positions, or a mesh (:func:`vesselgp.as_mesh`; ``F`` left out).
    F : (m, 3) int64
    ends : (int, int), optional
        End indices of the main vessel (``vessel_ends`` order), from ``s = 0``;
        default the two widest, the widest first.

    Returns
    -------
    Landmarks

    Raises
    ------
    EndsError
        Bad ends, or fewer than two landmarks.
    """
    pm = prepared_mesh(V, F)  # checked once for both fits (issue #34)
    i, j = _main_ends(pm.ends, ends, "ends")
    tree = fit_vessel_tree(pm, root=i)
    k = next(q for q, p in enumerate(tree.paths) if p.ends[1] == j)
    on_main = set(tree.path_branches[k])
    try:
        main = fit_generalized_cylinder(pm, ends=(i, j))
    except NotTubularError as exc:  # not a fallback: the refusal, told as the twist's
        raise NotTubularError(f"the main vessel between ends {i} and {j} is not one tube its single fit can follow "
                              f"(the twist's main axis, vesselgp.twist notes): {str(exc).split(';')[0]}; choose "
                              "another main vessel with ends=") from None
    rows = []
    for b in tree.path_branches[k][:-1]:
        J = tree.junctions[int(np.flatnonzero(tree.junction_branch == b)[0])]
        s = _project_s(main, J)
        r_main = float(main.radius_at([s / main.length])[0])
        _, fr = main.at([s / main.length])
        T, U, W = fr[0]
        sides = [int(c) for c in np.flatnonzero(tree.parent == b) if int(c) not in on_main]
        if len(sides) > 1:  # a trifurcation: one landmark per junction, the widest side branch
            log.warning("junction at s = %.3g has %d side branches; the widest is its landmark", s, len(sides))
            sides = [max(sides, key=lambda c: tree.branches[c].mean_radius)]
        for c in sides:
            side = tree.branches[int(c)]
            a1 = min(tol.TWIST_DIR_START * r_main, 0.5 * side.length)
            a2 = min(a1 + tol.TWIST_DIR_SPAN * side.mean_radius, side.length)
            d = _at_arclength(side, a2) - _at_arclength(side, a1)
            d /= np.linalg.norm(d)
            across = d - (d @ T) * T
            if np.linalg.norm(across) < math.sin(math.radians(tol.TWIST_MIN_ANGLE_DEG)):
                log.warning("side branch %d leaves the main axis within %g deg of its tangent: its azimuth is "
                            "undefined, it is not used as a landmark", c, tol.TWIST_MIN_ANGLE_DEG)
                continue
            rows.append((s, J, math.atan2(d @ W, d @ U), d, side.mean_radius, int(c)))
    rows.sort(key=lambda r: r[0])
    if len(rows) < 2:
        raise EndsError(f"the main vessel between ends {i} and {j} has {len(rows)} side branch(es); twist between "
                        "scans needs at least two landmarks (choose other ends with ends=)")
    s, P, az, d, r, br = (np.array(x) for x in zip(*rows))
    return Landmarks(tree=tree, ends=(i, j), main=main, length=float(main.length), points=P, s=s, azimuth=az,
                     direction=d, radius=r, branch=br.astype(np.int64))


def _match(A, B):
    """Order-preserving matching of two landmark sequences (dynamic programming); (pairs, cost)."""
    na, nb = len(A.s), len(B.s)
    xa, xb = A.s / A.length, B.s / B.length
    C = (((xa[:, None] - xb[None]) / tol.TWIST_MATCH_POSITION) ** 2
         + (np.log(A.radius[:, None] / B.radius[None]) / tol.TWIST_MATCH_RADIUS) ** 2)
    gap = tol.TWIST_MATCH_GAP
    D = np.zeros((na + 1, nb + 1))
    D[:, 0] = gap * np.arange(na + 1)
    D[0, :] = gap * np.arange(nb + 1)
    for i in range(1, na + 1):
        for j in range(1, nb + 1):
            D[i, j] = min(D[i - 1, j - 1] + C[i - 1, j - 1], D[i - 1, j] + gap, D[i, j - 1] + gap)
    pairs, i, j = [], na, nb
    while i > 0 and j > 0:
        if math.isclose(D[i, j], D[i - 1, j - 1] + C[i - 1, j - 1]) and C[i - 1, j - 1] < 2 * gap:
            pairs.append((i - 1, j - 1))
            i, j = i - 1, j - 1
        elif math.isclose(D[i, j], D[i - 1, j] + gap):
            i -= 1
        else:
            j -= 1
    return pairs[::-1], float(D[na, nb])


def _scan_landmarks(scan, V, F, ends):
    """:func:`scan_landmarks` of scan A or B of :func:`twist_between`; its refusals name the scan and the keyword
    (``ends_a``, ``ends_b``) that chooses its main vessel."""
    try:
        return scan_landmarks(V, F, ends)
    except (EndsError, NotTubularError) as exc:
        raise type(exc)(f"scan {scan.upper()}: " + str(exc).replace("ends=", f"ends_{scan}=")) from None


def twist_between(V_a, F_a=None, V_b=None, F_b=None, *, ends_a=None, ends_b=None):
    """Material twist of an artery between two scans, from its side branches (module notes).

    Each scan is its arrays ``V, F`` or one mesh object (``trimesh.Trimesh``,
    ``pyvista.PolyData``, ``meshio.Mesh``, :class:`vesselgp.PreparedMesh`;
    :func:`vesselgp.as_mesh`): ``twist_between(scan_a, scan_b)`` reads as
    ``twist_between(V_a, F_a, V_b, F_b)``.

    Parameters
    ----------
    V_a : (n, 3) float64, or a mesh object
        First scan (the reference: lengths and the axis direction are its).
    F_a : (m, 3) int64
    V_b : (n2, 3) float64, or a mesh object
        Second scan (any rigid pose, any meshing).
    F_b : (m2, 3) int64
    ends_a, ends_b : (int, int), optional
        Main-vessel end indices (``vessel_ends`` order) of each scan, from the
        same anatomical end. By default the two widest ends, and scan B's
        direction is decided by the landmarks.

    Returns
    -------
    ScanTwist

    Raises
    ------
    EndsError
        Bad ends, fewer than two landmarks in a scan, or fewer than two matched.

    Examples
    --------
    >>> from vesselgp.synthetic import twist_pair
    >>> p = twist_pair(3, twist_deg=40.0, voxel=(0.6, 0.6), side_radius=1.8)
    >>> r = twist_between(p.a.V, p.a.F, p.V_b, p.b.F)
    >>> len(r.segment_twist), bool(abs(np.degrees(r.total_twist - p.total_twist)) < 2.0)
    (2, True)
    """
    (V_a, F_a), (V_b, F_b) = mesh_arguments((V_a, F_a, V_b, F_b), ("mesh", "mesh"), "twist_between")
    A = _scan_landmarks("a", V_a, F_a, ends_a)
    B = _scan_landmarks("b", V_b, F_b, ends_b)
    pairs, cost = _match(A, B)
    if ends_b is None:
        Bf = B.flipped()
        pairs_f, cost_f = _match(A, Bf)
        if (len(pairs_f), -cost_f) > (len(pairs), -cost):
            log.info("twist_between: scan B's main vessel runs the other way (decided by the landmarks)")
            B, pairs, cost = Bf, pairs_f, cost_f
        elif len(pairs_f) == len(pairs) and abs(cost_f - cost) <= tol.TWIST_DIRECTION_MARGIN * max(cost, 1.0):
            log.warning("twist_between: the landmarks fit scan B's main vessel about as well either way; "
                        "its direction is taken from its widest end (give ends_b to decide)")
    if len(pairs) < 2:
        raise EndsError(f"only {len(pairs)} of {len(A.s)} and {len(B.s)} side branches match between the scans; "
                        "check that both scans show the same stretch of artery (or give ends_a and ends_b)")
    ia, ib = (np.array(x, np.int64) for x in zip(*pairs))
    un_a = np.setdiff1d(np.arange(len(A.s)), ia)
    un_b = np.setdiff1d(np.arange(len(B.s)), ib)
    if len(un_a) or len(un_b):
        log.warning("twist_between: %d landmark(s) of scan A (s = %s) and %d of scan B (s = %s) are unmatched",
                    len(un_a), np.round(A.s[un_a], 3).tolist(), len(un_b), np.round(B.s[un_b], 3).tolist())
    delta = B.azimuth[ib] - A.azimuth[ia]
    seg = wrap_angle(np.diff(delta))
    for q in np.flatnonzero(np.abs(seg) > math.radians(tol.TWIST_SUSPECT_DEG)):
        log.warning("twist_between: segment %d twists %.0f deg; check the landmark match there", q,
                    math.degrees(seg[q]))
    la, lb = np.diff(A.s[ia]), np.diff(B.s[ib])
    if not (np.all(la > 0) and np.all(lb > 0)):
        raise EndsError("two matched landmarks sit at the same place on the main axis; the twist between them "
                        "is undefined (check the side branches of both scans)")
    return ScanTwist(
        landmarks_a=A.points[ia], landmarks_b=B.points[ib], s_a=A.s[ia], s_b=B.s[ib],
        azimuth_a=A.azimuth[ia], azimuth_b=B.azimuth[ib], segment_twist=seg, segment_length_a=la,
        segment_length_b=lb, twist_per_length=seg / la, stretch=lb / la, total_twist=float(seg.sum()),
        ends_a=A.ends, ends_b=B.ends, length_a=A.length, length_b=B.length, unmatched_a=A.s[un_a],
        unmatched_b=B.s[un_b], side_a=A.branch[ia], side_b=B.branch[ib], radius_a=A.radius[ia],
        radius_b=B.radius[ib], tree_a=A.tree, tree_b=B.tree,
    )
