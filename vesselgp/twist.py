"""Material twist between two scans of one artery, from its side branches: :func:`twist_between`.

Two scans of the same artery (supine and flexed, systole and diastole) share no
vertices, so the material twist between them is measured, as clinical studies
do, from the side branches used as fiducials:

1. **Main vessel.** Each scan is fitted as a tree (:func:`vesselgp.fit_vessel_tree`)
   rooted at ``ends[0]``; the main vessel runs to ``ends[1]``. By default
   ``ends[0]`` is the widest end and ``ends[1]`` the tip whose path has the most
   landmarks where the vessel does not divide (then the most landmarks, then the
   widest tip); a refusal lists every candidate with its landmarks. Its axis is
   the single generalized cylinder fitted between those ends
   (:func:`vesselgp.fit_generalized_cylinder`, whose robust weights drop the side
   branches): its RMF runs smoothly through the junctions. Where the single fit
   cannot follow the main vessel (a coronary or pulmonary tree whose main vessel
   is several generations long), the axis is the tree's path to ``ends[1]``
   (``main_axis = "tree path"``, logged) averaged along itself over
   ``TWIST_PATH_SMOOTH`` radii, so that its junction links' kinks do not turn
   its RMF (:class:`PathAxis`); the segment uncertainty carries what is left
   (``TWIST_SIGMA_TREE_PATH``). ``s`` is arc length from
   ``ends[0]``.
2. **Landmarks.** Every side branch leaving the main path is a landmark at its
   ostium: its axis point ``TWIST_DIR_START`` main radii past the junction,
   projected onto the main axis for its ``s``. Side branches whose ostia lie
   within ``TWIST_SAME_PLACE`` main radii leave together: the wider is the
   landmark (logged). A side branch at least ``TWIST_COMPARABLE`` times as wide
   as the main vessel past it makes the main vessel divide there into comparable
   daughters: said in the log and the result (``divides``).
3. **Azimuth.** Where the side branch lies about the main axis, not which way it
   points: ``TWIST_OSTIUM_SAMPLES`` points of its axis from its ostium over
   ``TWIST_DIR_SPAN`` branch radii are each projected onto the main axis, and the
   angle of each offset from U in the main axis's RMF there (right-handed about
   the axis from ``ends[0]`` to ``ends[1]``) is averaged as a circular mean
   weighted by the offsets. (The direction of the branch's first chord, used
   before, depends on a few faces and on the main tangent at a junction: twice
   the error on the synthetic pairs, up to 9 degrees on real coronaries.) A side
   branch whose chord leaves within ``TWIST_MIN_ANGLE_DEG`` of the main tangent
   is no landmark.
   The RMF carries no twist of its own (paper Section 1), so a landmark's
   azimuth changes between the scans by the material twist there (Eq. 7's
   ``alpha``) plus a constant (the RMFs' arbitrary starting normals).
4. **Matching.** Landmarks are matched in order along the axis by dynamic
   programming on their normalised position ``s / L`` and radius
   (``TWIST_MATCH_POSITION``, ``TWIST_MATCH_RADIUS``, a landmark left unmatched
   costs ``TWIST_MATCH_GAP``). Without given ends the second scan's direction is
   chosen by the landmarks (the order that matches better). Where side branches
   leave together (step 2), each matched pair is then made of the two branches,
   one per scan, most alike in position, radius and length
   (``TWIST_MATCH_LENGTH``; :func:`_agree_members`), not of each scan's wider
   one. Unmatched
   landmarks are reported (and logged); a segment twist above
   ``TWIST_SUSPECT_DEG`` is logged as a suspect match.
5. **Twist and its uncertainty.** With ``delta_j = azimuth_b[j] - azimuth_a[j]``,
   the twist of the segment between landmarks ``j`` and ``j + 1`` is
   ``delta_{j+1} - delta_j`` wrapped to (-pi, pi]: the material twist
   ``alpha(s_{j+1}) - alpha(s_j)``. The constant cancels, and so does any rigid
   motion of either scan. Each azimuth has a one-sigma uncertainty from what
   makes it ill-conditioned::

       sigma^2 = f^2 + (c_S spread)^2 + (c_E h / offset)^2 + (c_T eps_T)^2

   with ``spread`` the circular spread of the angles of the side branch's
   samples (step 3: a branch that winds round the main vessel, or a ragged
   one), ``h / offset`` the median edge over the samples' mean offset from the
   main axis (a lever a few edges long: a branch a few edges across), and
   ``eps_T`` the angle between the fitted main tangent and the chord of the main
   axis across the junction (``TWIST_MAIN_CHORD`` main radii each side: large
   where the vessel divides and the fit cuts the corner); a landmark with another
   ostium within ``TWIST_MAIN_CHORD`` main radii adds ``TWIST_SIGMA_CROWDED``
   (overlapping junction zones). A matched pair whose
   side radii differ by more than ``TWIST_RADIUS_AGREE`` (log ratio) may not be
   one fiducial and adds ``TWIST_SIGMA_RADIUS`` times the excess. The
   constants (``TWIST_SIGMA_*``) are calibrated on twisted copies of real trees with exact truth (``data_gen/real_twist.py``,
   ``tests/test_twist_real.py``). A segment's 95 % half-width is
   ``TWIST_Z95`` times the root sum of squares of its two landmarks' sigmas in
   both scans (and ``TWIST_SIGMA_TREE_PATH`` per scan whose main axis is the tree
   path); above ``TWIST_UNRELIABLE_DEG`` the segment is reported unreliable.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace

import numpy as np

from . import tolerances as tol
from ._validate import mesh_arguments
from .axis import interp_frames
from .curves import chord_length, curve_tangents, resample_arclength, rotation_minimizing_frames
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
    angle : (k,) float64
        Angle (radians) between each side direction and the main direction there.
    divides : (k,) bool
        The main vessel divides there into comparable daughters (the side branch at least
        ``TWIST_COMPARABLE`` times the radius of the main vessel past it).
    uncertainty : (k,) float64
        Half-width (radians) of the 95 % interval of each azimuth (step 5).
    main_axis : str
        ``"single fit"`` or ``"tree path"`` (step 1).
    leaves : (b,) float64
        For every branch of ``tree``: the arc length along the main axis where it, or the side branch it grows
        from, leaves the main vessel (at that side branch's ostium, step 2, landmark or not); NaN on the main
        vessel's own branches.
    reversed : bool
        The main axis runs from the tree's path end back to its root (``s``
        measured from ``ends[0]`` all the same).
    members : tuple of tuple of dict
        For each landmark, the side branches leaving there together (``TWIST_SAME_PLACE``; itself included),
        each as its landmark row (``s``, ``point``, ``azimuth``, ``direction``, ``radius``, ``branch``,
        ``angle``, ``divides``, ``uncertainty``, ``length``): which of them is the landmark is settled
        against the other scan (:func:`_agree_members`).
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
    angle: np.ndarray
    divides: np.ndarray
    uncertainty: np.ndarray
    main_axis: str
    leaves: np.ndarray
    reversed: bool = False
    members: tuple = ()

    def flipped(self):
        """The same landmarks seen from the other end: ``s -> L - s``, azimuth negated, order reversed."""
        o = slice(None, None, -1)
        return Landmarks(tree=self.tree, ends=self.ends[::-1], main=self.main, length=self.length,
                         points=self.points[o], s=(self.length - self.s)[o], azimuth=(-self.azimuth)[o],
                         direction=self.direction[o], radius=self.radius[o], branch=self.branch[o],
                         angle=self.angle[o], divides=self.divides[o], uncertainty=self.uncertainty[o],
                         main_axis=self.main_axis, leaves=self.length - self.leaves, reversed=not self.reversed,
                         members=tuple(tuple(dict(m, s=self.length - m["s"], azimuth=-m["azimuth"]) for m in g)
                                       for g in self.members[::-1]))


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
    landmark_uncertainty_a, landmark_uncertainty_b : (k,) float64
        Half-width (radians) of the 95 % interval of each landmark's azimuth (step 5).
    segment_uncertainty : (k - 1,) float64
        Half-width (radians) of the 95 % interval of each segment's twist (step 5).
    cumulative_uncertainty : (k,) float64
        Half-width (radians) of the 95 % interval of the twist from landmark 1 to each landmark (0 at the first).
    unreliable : (k - 1,) bool
        Segments whose ``segment_uncertainty`` exceeds ``TWIST_UNRELIABLE_DEG``.
    angle_a : (k,) float64
        Angle (radians) between each side branch and the main direction in scan A.
    divides_a, divides_b : (k,) bool
        The main vessel divides at the landmark into comparable daughters.
    main_axis_a, main_axis_b : str
        ``"single fit"`` or ``"tree path"`` (step 1).
    leaves_a : (b,) float64
        For every branch of ``tree_a``: the arc length along scan A's main axis where it, or the side branch it
        grows from, leaves the main vessel (:attr:`Landmarks.leaves`; NaN on the main vessel).
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
    landmark_uncertainty_a: np.ndarray
    landmark_uncertainty_b: np.ndarray
    segment_uncertainty: np.ndarray
    cumulative_uncertainty: np.ndarray
    unreliable: np.ndarray
    angle_a: np.ndarray
    divides_a: np.ndarray
    divides_b: np.ndarray
    main_axis_a: str
    main_axis_b: str
    leaves_a: np.ndarray = field(repr=False)
    tree_a: object = field(repr=False)
    tree_b: object = field(repr=False)


def _given_ends(ends, given, which):
    """End indices (i, j) of a given main vessel, checked."""
    try:
        i, j = (int(x) for x in given)
    except (TypeError, ValueError):
        raise EndsError(f"{which} must be a pair of end indices (i, j), got {given!r}") from None
    if not (0 <= i < len(ends) and 0 <= j < len(ends)) or i == j:
        raise EndsError(f"{which}=({i}, {j}) must be two different end indices in 0..{len(ends) - 1} "
                        f"(ends: {end_listing(ends)})")
    return i, j


def _at_arclength(gc, a):
    """Point of ``gc``'s axis at arc length ``a`` from its s = 0 end (clipped)."""
    return gc.at([float(np.clip(a / gc.length, 0.0, 1.0))])[0][0]


def _unit(x):
    return x / np.linalg.norm(x)


def _angle(a, b):
    """Angle (radians) between two unit vectors."""
    return math.atan2(float(np.linalg.norm(np.cross(a, b))), float(a @ b))


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


def _side_branches(tree, k):
    """(junction branch b, its junction point, side branches leaving the path there, the path's next branch) along
    path ``k``, root first."""
    path = tree.path_branches[k]
    on_main = set(path)
    out = []
    for q, b in enumerate(path[:-1]):
        J = tree.junctions[int(np.flatnonzero(tree.junction_branch == b)[0])]
        sides = [int(c) for c in np.flatnonzero(tree.parent == b) if int(c) not in on_main]
        if sides:
            out.append((b, J, sides, path[q + 1]))
    return out


def _main_direction(main, s, r_main):
    """The main vessel's frame at arc length ``s`` (step 3) and how ill-defined its direction is there: the angle
    between the fitted tangent and the chord of the axis across the junction, between the points
    ``TWIST_MAIN_CHORD`` main radii before and after it (one-sided within that of an end). On a smooth vessel the
    two agree to a degree or two; where the vessel divides into comparable daughters the fit cuts the corner."""
    a = tol.TWIST_MAIN_CHORD * r_main
    lo, hi = max(s - a, 0.0), min(s + a, main.length)
    chord = _unit(_at_arclength(main, hi) - _at_arclength(main, lo))
    _, fr = main.at([s / main.length])
    return fr[0], _angle(chord, fr[0][0])


def _side_direction(side, start):
    """A side branch's initial direction: the chord of its axis from ``start`` over ``TWIST_DIR_SPAN`` side radii
    (within its length). Its angle to the main tangent decides whether it is a landmark (``TWIST_MIN_ANGLE_DEG``)."""
    a1 = min(start, 0.5 * side.length)
    a2 = min(a1 + tol.TWIST_DIR_SPAN * side.mean_radius, side.length)
    return _unit(_at_arclength(side, a2) - _at_arclength(side, a1))


def _side_azimuth(main, side, start):
    """A side branch's azimuth from where it lies about the main axis (step 3): each of ``TWIST_OSTIUM_SAMPLES``
    points of its axis from ``start`` over ``TWIST_DIR_SPAN`` side radii, projected onto the main axis, gives
    the angle of its offset from the axis in the RMF there; the azimuth is their circular mean weighted by the
    offsets. Returns the azimuth, the samples' circular spread (radians) and their mean offset."""
    a1 = min(start, 0.5 * side.length)
    a2 = min(a1 + tol.TWIST_DIR_SPAN * side.mean_radius, side.length)
    P = side.at(np.linspace(a1, a2, tol.TWIST_OSTIUM_SAMPLES) / side.length)[0]
    s = np.array([_project_s(main, p) for p in P])
    C, fr = main.at(s / main.length)
    O = P - C
    O -= np.sum(O * fr[:, 0], axis=1)[:, None] * fr[:, 0]
    w = np.linalg.norm(O, axis=1)
    z = np.sum(w * np.exp(1j * np.arctan2(np.sum(O * fr[:, 2], axis=1), np.sum(O * fr[:, 1], axis=1))))
    spread = math.sqrt(max(-2.0 * math.log(max(abs(z) / w.sum(), 1e-300)), 0.0))  # circular std
    return float(np.angle(z)), spread, float(w.mean())


def _landmark_sigma(spread, edges, eps_T):
    """One sigma (radians) of a landmark's azimuth (step 5), from what makes it ill-conditioned: the circular
    spread of its samples' azimuths (a branch that winds round the main vessel, or a short, ragged one), the
    median edge over its offset from the main axis (a branch a few edges across, a lever of a few edges) and
    the main direction's ill-definition ``eps_T`` (constants in :mod:`vesselgp.tolerances`, calibrated on real
    trees)."""
    return math.sqrt(tol.TWIST_SIGMA_FLOOR ** 2 + (tol.TWIST_SIGMA_SPREAD * spread) ** 2
                     + (tol.TWIST_SIGMA_EDGES * edges) ** 2 + (tol.TWIST_SIGMA_TANGENT * eps_T) ** 2)


def _crowded(s, r_main):
    """Landmarks at arc lengths ``s`` (k,) with another within ``TWIST_MAIN_CHORD`` main radii ``r_main`` (k,):
    their junction zones overlap and the ostia perturb each other (step 5)."""
    d = np.abs(s[:, None] - s[None, :])
    np.fill_diagonal(d, np.inf)
    return np.any(d < tol.TWIST_MAIN_CHORD * r_main[:, None], axis=1)


def _divides(side_radius, next_radius):
    """The main vessel divides into comparable daughters: the side branch at least ``TWIST_COMPARABLE`` times the
    radius of the main vessel past the junction (step 2)."""
    return bool(side_radius >= tol.TWIST_COMPARABLE * next_radius)


def _together(rows, quiet=False):
    """Landmark rows (sorted by ``s``) with side branches whose ostia lie within ``TWIST_SAME_PLACE`` main radii
    merged: they leave the main vessel together, and the wider is the landmark (step 2); each kept row lists
    the group's rows as ``members`` (the other scan settles which member is the landmark: :func:`_agree_members`)."""
    kept = []
    for r in rows:  # two side branches leaving together: one landmark, the wider
        r = dict(r, members=[r])
        if kept and r["s"] - kept[-1]["s"] < tol.TWIST_SAME_PLACE * max(r["r_main"], kept[-1]["r_main"]):
            if not quiet:
                log.warning("side branches %d and %d leave the main vessel together (s = %.3g and %.3g); the wider "
                            "is the landmark", kept[-1]["branch"], r["branch"], kept[-1]["s"], r["s"])
            members = kept[-1]["members"] + [r]
            if r["radius"] > kept[-1]["radius"]:
                kept[-1] = r
            kept[-1]["members"] = members
            continue
        kept.append(r)
    return kept


def _ostium(main, side, r_j):
    """Where a side branch leaves the main vessel (step 2): the arc length along ``main`` of its axis point
    ``TWIST_DIR_START`` main radii ``r_j`` past the junction (at most half the branch), and that arc length along
    the side branch."""
    start = min(tol.TWIST_DIR_START * r_j, 0.5 * side.length)
    return _project_s(main, _at_arclength(side, start)), start


def _leaves(main, tree, k):
    """:attr:`Landmarks.leaves` of path ``k`` about the axis ``main``: (b,) float64."""
    out = np.full(len(tree.branches), np.nan)
    for b, J, sides, nxt in _side_branches(tree, k):
        r_j = float(main.radius_at([_project_s(main, J) / main.length])[0])
        for c in sides:
            out[c] = _ostium(main, tree.branches[c], r_j)[0]
    for c in range(len(tree.branches)):  # a branch grown from a side branch leaves where that one does
        b = c
        while b >= 0 and np.isnan(out[b]) and b not in tree.path_branches[k]:
            b = int(tree.parent[b])
        out[c] = out[b] if b >= 0 else np.nan
    return out


def _landmark_rows(main, tree, k, h, quiet=False):
    """The landmarks of path ``k`` about the axis ``main`` (step 2): one row per side branch leaving it, at the
    arc length of its ostium (its axis point past the junction zone, projected on the main axis); of two within
    ``TWIST_SAME_PLACE`` main radii of each other, the wider (``quiet``: nothing logged, counting candidates)."""
    rows = []
    for b, J, sides, nxt in _side_branches(tree, k):
        s_j = _project_s(main, J)
        r_j = float(main.radius_at([s_j / main.length])[0])
        for c in sides:
            side = tree.branches[c]
            s, start = _ostium(main, side, r_j)
            r_main = float(main.radius_at([s / main.length])[0])
            (T, _, _), eps_T = _main_direction(main, s, r_main)
            d = _side_direction(side, start)
            theta = _angle(d, T)
            if min(theta, math.pi - theta) < math.radians(tol.TWIST_MIN_ANGLE_DEG):
                if not quiet:
                    log.warning("side branch %d leaves the main axis within %g deg of its tangent: its azimuth is "
                                "undefined, it is not used as a landmark", c, tol.TWIST_MIN_ANGLE_DEG)
                continue
            divides = _divides(side.mean_radius, tree.branches[nxt].mean_radius)
            az, spread, offset = _side_azimuth(main, side, start)
            sigma = _landmark_sigma(spread, h / offset, eps_T)
            log.debug("landmark s=%.1f theta=%.1f eps_T=%.2f spread=%.2f h/offset=%.3f sigma=%.2f deg", s,
                      math.degrees(theta), math.degrees(eps_T), math.degrees(spread), h / offset, math.degrees(sigma))
            rows.append(dict(s=s, point=J, azimuth=az, direction=d, radius=side.mean_radius,
                             branch=c, angle=theta, divides=bool(divides), r_main=r_main,
                             sigma=sigma))
    rows.sort(key=lambda r: r["s"])
    for r, crowded in zip(rows, _crowded(np.array([r["s"] for r in rows]), np.array([r["r_main"] for r in rows]))):
        if crowded:
            r["sigma"] = math.hypot(r["sigma"], tol.TWIST_SIGMA_CROWDED)
    kept = _together(rows, quiet)
    for r in kept:
        del r["r_main"]
    return kept


def _candidates(tree, h):
    """Every main vessel from the tree's root: (tip end, landmarks, landmarks where it does not divide, tip radius),
    the most landmarks where it does not divide first (a path that turns into a side branch counts the main vessel
    past it as a landmark where it divides), then the most landmarks, then the widest tip."""
    out = []
    for q, p in enumerate(tree.paths):
        rows = _landmark_rows(p, tree, q, h, quiet=True)
        out.append((p.ends[1], len(rows), sum(not r["divides"] for r in rows), tree.ends[p.ends[1]].radius))
    return sorted(out, key=lambda x: (-x[2], -x[1], -x[3]))


def _candidate_text(root, cands, n=6):
    return ", ".join(f"({root}, {j}): {m}" for j, m, _, _ in cands[:n])


@dataclass(frozen=True, eq=False)
class PathAxis:
    """A tree path smoothed into one main axis (step 1): its points averaged along it over
    ``TWIST_PATH_SMOOTH`` radii (the junction links' kinks smoothed out), resampled at equal arc length, with
    their RMF (double reflection, paper Section 1). The interface of a :class:`GeneralizedCylinder` that the
    landmarks use: ``length``, ``dense_s`` (normalised), ``dense_points``, ``dense_frames``, :meth:`at`,
    :meth:`radius_at`."""

    length: float
    dense_s: np.ndarray
    dense_points: np.ndarray
    dense_frames: np.ndarray
    s: np.ndarray
    radii: np.ndarray

    @classmethod
    def of(cls, path):
        from scipy.ndimage import gaussian_filter1d

        P = path.dense_points
        step = path.length / (len(P) - 1)
        sigma = tol.TWIST_PATH_SMOOTH * float(np.median(path.radii)) / step
        n = min(int(math.ceil(4.0 * sigma)), len(P) - 1)  # extended through its ends by point reflection: the
        Pp = np.vstack([2 * P[0] - P[n:0:-1], P, 2 * P[-1] - P[-2:-n - 2:-1]])  # ends stay where they are
        X = gaussian_filter1d(Pp, sigma, axis=0, mode="nearest")[n:n + len(P)]
        X = resample_arclength(X, len(P))
        T = curve_tangents(X)
        T, U, W = rotation_minimizing_frames(X, T, initial_normal=path.dense_frames[0][1])
        return cls(length=float(chord_length(X)[-1]), dense_s=np.linspace(0.0, 1.0, len(X)), dense_points=X,
                   dense_frames=np.stack([T, U, W], axis=1), s=path.s, radii=path.radii)

    def at(self, s):
        """Axis points and frames (rows T, U, V) at normalised arc lengths ``s``."""
        return interp_frames(self.dense_s, self.dense_points, self.dense_frames, np.atleast_1d(s))

    def radius_at(self, s):
        """Radius at normalised arc lengths ``s`` (the path's)."""
        return np.interp(np.atleast_1d(np.asarray(s, float)), self.s, self.radii)


def _main_axis(pm, tree, k, i, j):
    """The main vessel's axis (step 1): its single fit between the ends, or the tree's path where the single fit
    cannot follow it (said in the log and in the result, whose uncertainty then includes the path's RMF)."""
    try:
        return fit_generalized_cylinder(pm, ends=(i, j)), "single fit"
    except NotTubularError as exc:  # the documented second axis (module notes, step 1), reported as main_axis
        log.warning("the main vessel between ends %d and %d is not one tube its single fit can follow (%s); its "
                    "axis is the tree's path through the junctions", i, j, str(exc).split(";")[0])
        return PathAxis.of(tree.paths[k]), "tree path"


def scan_landmarks(V, F=None, ends=None):
    """The side-branch landmarks of one scan (steps 1-3 of the module notes).

    Parameters
    ----------
    V : (n, 3) float64, PreparedMesh or mesh object
        Vertex positions, or a mesh (:func:`vesselgp.as_mesh`; ``F`` left out).
    F : (m, 3) int64
    ends : (int, int), optional
        End indices of the main vessel (``vessel_ends`` order), from ``s = 0``;
        default from the widest end to the tip with the most landmarks.

    Returns
    -------
    Landmarks

    Raises
    ------
    EndsError
        Bad ends, or fewer than two landmarks (the message lists the main vessels that have them).
    """
    pm = prepared_mesh(V, F)  # checked once for both fits (issue #34)
    if ends is not None:
        i, j = _given_ends(pm.ends, ends, "ends")
    elif len(pm.ends) < 3:
        raise EndsError(f"the scan has {len(pm.ends)} ends: no side branch to use as a landmark "
                        f"(ends: {end_listing(pm.ends)})")
    else:
        i = int(np.argmax([e.radius for e in pm.ends]))
    h = pm.checked.median_edge
    tree = fit_vessel_tree(pm, root=i)
    if ends is None:
        cands = _candidates(tree, h)
        j = cands[0][0]
        log.info("twist main vessel: ends (%d, %d), the most landmarks from the widest end (%s)", i, j,
                 _candidate_text(i, cands))
    k = next(q for q, p in enumerate(tree.paths) if p.ends[1] == j)
    main, kind = _main_axis(pm, tree, k, i, j)
    return _landmarks(tree, k, main, kind, h)


def _landmarks(tree, k, main, kind, h):
    """The :class:`Landmarks` of path ``k`` of ``tree`` about the axis ``main`` (of ``kind``); ``h`` the median
    edge. Raises EndsError, listing the candidates, when it has fewer than two."""
    i, j = tree.paths[k].ends
    rows = _landmark_rows(main, tree, k, h)
    if len(rows) < 2:
        cands = _candidates(tree, h)
        raise EndsError(f"the main vessel between ends {i} and {j} has {len(rows)} side branch(es); twist between "
                        f"scans needs at least two landmarks; main vessels from end {i} with their landmarks: "
                        f"{_candidate_text(i, cands)} (choose one with ends=)")
    for r in rows:
        if r["divides"]:
            log.warning("the main vessel divides at s = %.3g into comparable daughters (side radius %.3g): its "
                        "direction there is less well defined, the landmark's uncertainty says by how much",
                        r["s"], r["radius"])
    col = {key: np.array([r[key] for r in rows]) for key in rows[0] if key != "members"}
    members = tuple(tuple(dict(s=m["s"], point=m["point"], azimuth=m["azimuth"], direction=m["direction"],
                               radius=m["radius"], branch=m["branch"], angle=m["angle"], divides=m["divides"],
                               uncertainty=tol.TWIST_Z95 * m["sigma"], length=float(tree.branches[m["branch"]].length))
                          for m in r["members"]) for r in rows)
    return Landmarks(tree=tree, ends=(i, j), main=main, length=float(main.length), points=col["point"],
                     s=col["s"], azimuth=col["azimuth"], direction=col["direction"], radius=col["radius"],
                     branch=col["branch"].astype(np.int64), angle=col["angle"], divides=col["divides"],
                     uncertainty=tol.TWIST_Z95 * col["sigma"], main_axis=kind, leaves=_leaves(main, tree, k),
                     members=members)


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


_MEMBER_KEYS = ("s", "point", "azimuth", "direction", "radius", "branch", "angle", "divides", "uncertainty")
_MEMBER_FIELDS = ("s", "points", "azimuth", "direction", "radius", "branch", "angle", "divides", "uncertainty")


def _member_cost(a, b, la, lb):
    """How unlike two side branches are, by what a twist leaves alone: position along the main axis (normalised
    by the lengths ``la``, ``lb``), radius and length (log ratios)."""
    return (((a["s"] / la - b["s"] / lb) / tol.TWIST_MATCH_POSITION) ** 2
            + (math.log(a["radius"] / b["radius"]) / tol.TWIST_MATCH_RADIUS) ** 2
            + (math.log(a["length"] / b["length"]) / tol.TWIST_MATCH_LENGTH) ** 2)


def _agree_members(A, B, ia, ib):
    """Landmarks ``A``, ``B`` with each matched pair ``(ia[q], ib[q])`` made of the same side branch where
    either scan has several leaving there together (``members``).

    Within a scan, "the wider of the branches leaving together" is a coin toss when their radii are close, and
    which branches count as together depends on ostia a few tenths of a radius apart: two renal arteries at one
    level were the landmark in one scan and the other one in the other, a segment 136 degrees off with a
    6-degree interval. Each matched pair therefore takes the two members (one per scan) most alike in position,
    radius and length (:func:`_member_cost`), never a branch another pair already took."""
    if not A.members or not B.members:
        return A, B
    cols = {X: {f: np.array(getattr(L, f), copy=True) for f in _MEMBER_FIELDS} for X, L in (("a", A), ("b", B))}
    used = {"a": set(), "b": set()}  # first the pairs with no choice
    for i, j in zip(ia, ib):
        if len(A.members[i]) == 1 and len(B.members[j]) == 1:
            used["a"].add(int(A.branch[i]))
            used["b"].add(int(B.branch[j]))
    for i, j in zip(ia, ib):
        ga, gb = A.members[i], B.members[j]
        if len(ga) == 1 and len(gb) == 1:
            continue
        options = sorted((_member_cost(a, b, A.length, B.length), ka, kb)
                         for ka, a in enumerate(ga) for kb, b in enumerate(gb)
                         if int(a["branch"]) not in used["a"] and int(b["branch"]) not in used["b"])
        if not options:
            continue
        _, ka, kb = options[0]
        for X, g, k, at in (("a", ga, ka, i), ("b", gb, kb, j)):
            used[X].add(int(g[k]["branch"]))
            for key, f in zip(_MEMBER_KEYS, _MEMBER_FIELDS):
                cols[X][f][at] = g[k][key]
        if ka or kb:
            log.info("twist_between: landmarks %d / %d are side branches %d / %d (most alike of those leaving "
                     "there together)", i, j, ga[ka]["branch"], gb[kb]["branch"])
    return replace(A, **cols["a"]), replace(B, **cols["b"])


def _segment_uncertainty(u_a, u_b, r_a, r_b, n_path):
    """95 % half-widths (radians) of the segment twists and of the twist from landmark 1 to each landmark, and
    the unreliable segments (step 5), from the matched landmarks' half-widths ``u_a``, ``u_b`` (k,), their side
    radii ``r_a``, ``r_b`` (k,) and the number of scans whose main axis is the tree path."""
    ua, ub = u_a / tol.TWIST_Z95, u_b / tol.TWIST_Z95  # one sigma
    path = n_path * tol.TWIST_SIGMA_TREE_PATH ** 2
    # a pair of side branches of different sizes may not be one fiducial: its azimuth change is less sure
    ub = np.hypot(ub, tol.TWIST_SIGMA_RADIUS * np.maximum(np.abs(np.log(r_a / r_b)) - tol.TWIST_RADIUS_AGREE, 0.0))
    useg = tol.TWIST_Z95 * np.sqrt(ua[:-1] ** 2 + ua[1:] ** 2 + ub[:-1] ** 2 + ub[1:] ** 2 + path)
    # from landmark 1 to landmark j the landmarks between cancel; the path's RMF error adds up per segment
    ucum = tol.TWIST_Z95 * np.sqrt(ua[0] ** 2 + ua ** 2 + ub[0] ** 2 + ub ** 2 + path * np.arange(len(ua)))
    ucum[0] = 0.0
    return useg, ucum, useg > math.radians(tol.TWIST_UNRELIABLE_DEG)


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
        same anatomical end. By default from the widest end to the tip with
        the most landmarks (module notes, step 1), and scan B's direction is
        decided by the landmarks.

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
    A, B = _agree_members(A, B, ia, ib)
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
    n_path = sum(X.main_axis == "tree path" for X in (A, B))
    useg, ucum, unreliable = _segment_uncertainty(A.uncertainty[ia], B.uncertainty[ib], A.radius[ia],
                                                  B.radius[ib], n_path)
    for q in np.flatnonzero(unreliable):
        log.warning("twist_between: segment %d is unreliable: its twist %.1f deg is known to +- %.1f deg", q + 1,
                    math.degrees(seg[q]), math.degrees(useg[q]))
    return ScanTwist(
        landmarks_a=A.points[ia], landmarks_b=B.points[ib], s_a=A.s[ia], s_b=B.s[ib],
        azimuth_a=A.azimuth[ia], azimuth_b=B.azimuth[ib], segment_twist=seg, segment_length_a=la,
        segment_length_b=lb, twist_per_length=seg / la, stretch=lb / la, total_twist=float(seg.sum()),
        ends_a=A.ends, ends_b=B.ends, length_a=A.length, length_b=B.length, unmatched_a=A.s[un_a],
        unmatched_b=B.s[un_b], side_a=A.branch[ia], side_b=B.branch[ib], radius_a=A.radius[ia],
        radius_b=B.radius[ib], landmark_uncertainty_a=A.uncertainty[ia], landmark_uncertainty_b=B.uncertainty[ib],
        segment_uncertainty=useg, cumulative_uncertainty=ucum, unreliable=unreliable, angle_a=A.angle[ia],
        divides_a=A.divides[ia], divides_b=B.divides[ib], main_axis_a=A.main_axis, main_axis_b=B.main_axis,
        leaves_a=A.leaves, tree_a=A.tree, tree_b=B.tree,
    )
