"""Where the tube model does not describe the lumen, the axis is the lumen's centre line (issue #34).

The Eq. 3 fixed point puts a branch's axis at the weighted mean of its wall's sections. That is
the centre of a tube, and stays within about a tenth of the inscribed radius of the lumen's
medial centre line (:func:`vesselgp.centerlines.centerlines`) on real branches and a fiftieth
on the synthetic trees. Where the wall is not a tube around one axis, the mean is not the
centre and the fit can wander off it, then kink back (``kappa r`` of 2 to 5 on the real meshes):

* a sac (an aneurysm) pulls the mean into its dome;
* a stub, a branch whose own length past its junction zone is a radius or two, has for its
  wall mostly its junction's flare, and its free junction side slides towards its tip;
* a fold or a turn tighter than the smoothing of Eq. 2 lets the fit cut the corner;
* a bulb, a closed rounded end wider than it is long (the pulmonary trunk's), or a section far
  from round lets it wind within the lumen, turning tighter than its radius (``kappa r >= 1``,
  the tube's sections would overlap: :func:`vesselgp.inside.check_axis_bend`) while staying
  near the centre line;
* a stub on its junction's flare, or a branch one or two mesh edges across, has a fixed point
  that does not settle: still moving more than ``tolerances.TREE_UNSETTLED`` radii an iteration
  at the iteration cap, its axis is wherever the iteration stopped (a rigid motion of the mesh
  moved the arch's junctions 4-6 mm). :func:`vesselgp.fit_vessel_tree` takes the centre line
  for the whole branch then.

:func:`medial_zones` finds the stretches where the fitted axis is farther than
``tolerances.TREE_MEDIAL_DEPARTURE`` inscribed radii from the branch's centre line, or turns
tighter than its fitted radius (``tolerances.GC_MAX_BEND``), widens
them by ``TREE_MEDIAL_MARGIN`` radii, and there replaces the axis by the centre line, blended
back into the fit over ``TREE_MEDIAL_BLEND`` radii (a smoothstep of the offset). Elsewhere the
fit is untouched. The stretches are returned so that the result can say where the axis is the
centre line rather than the tube model's fit (:attr:`vesselgp.VesselTree.medial_zones`): VMTK
takes the centre line everywhere; vesselgp where the tube model cannot.
"""
from __future__ import annotations

import numpy as np

from . import tolerances as tol
from ._arrays import true_runs
from .axis import Axis
from .curves import chord_length, polyline_feet, resample_arclength

__all__ = ["medial_zones"]


def _densified(line, radius, step):
    """The polyline ``line`` (k, 3) with points added on its segments longer than ``step`` (equally spaced,
    ``step`` apart at most), and the radius interpolated there: the same curve, whose points a zone can mark
    however far apart the given ones are. A tree branch's line starts at its junction, up to 2.5 radii before its
    next point: an axis departing only there marked no point, and the fit failed on an empty zone (the 4D-flow
    arch made again by marching cubes at a third of its least radius)."""
    seg = np.linalg.norm(np.diff(line, axis=0), axis=1)
    extra = np.maximum(np.ceil(seg / step).astype(np.int64) - 1, 0)
    if not extra.any():
        return line, radius
    t = np.concatenate([i + np.arange(e + 1) / (e + 1) for i, e in enumerate(extra)] + [[len(line) - 1]])
    i = np.minimum(np.floor(t).astype(np.int64), len(line) - 2)
    f = (t - i)[:, None]
    return (1.0 - f) * line[i] + f * line[i + 1], (1.0 - f[:, 0]) * radius[i] + f[:, 0] * radius[i + 1]


def medial_zones(nodes, line, radius, rscale, *, through=(False, False), fit_radius=None, skip_start=0.0,
                 sharp_s=None):
    """A branch's fitted axis with the stretches far from its centre line replaced by the line.

    Parameters
    ----------
    nodes : (K, 3) float64
        The fitted axis (the Eq. 3 fixed point's nodes), in the line's direction.
    line : (k, 3) float64
        The branch's medial centre line (:class:`vesselgp.branches.Branching` ``lines``).
    radius : (k,) float64
        The inscribed-sphere radius along it.
    rscale : float
        The branch's radius scale (the axis is compared every ``tolerances.TREE_MEDIAL_SAMPLING`` of it).
    fit_radius : (K,) float64, optional
        The fitted radius at each node (the Eq. 4 radii of the fixed point): where the axis turns
        tighter than it (``kappa r >= tolerances.GC_MAX_BEND``) it is replaced as well, judged
        where :func:`vesselgp.inside.check_axis_bend` judges it (a mean radius from either end and
        past ``skip_start``). Without it only the departure from the line is judged.
    skip_start : float, optional
        Arc length of the axis from its start where its turn is not judged (a child's junction
        zone, where it turns off its parent by design).
    sharp_s : (j,) float64, optional
        Normalised arc lengths of the axis where it is known to turn tighter than its radius
        (judged on the branch's final cylinder, :func:`vesselgp.fit.cylinder_sharp_bends`): they
        are replaced as well.
    through : (bool, bool), optional
        Whether the line's start / end is where the axis must end too (a junction the line runs
        through): the axis's points beyond it are compared with it as well. By default only axis
        points whose foot lies strictly inside the line are: before its start a child's first fit
        crosses its junction zone (led in along its centre line later), and a line ending at the
        root's or a tip's centre has the fit pinned there.

    Returns
    -------
    nodes : (K, 3) float64
        The axis, resampled to ``K`` points at equal arc length (the input itself when nothing
        departs).
    zones : (z, 2) float64
        The arc-length intervals of ``line`` where the axis is the line (empty when none).

    Examples
    --------
    A straight line and a fit that bulges 1.2 radii sideways in its middle (a sac's pull): the
    middle becomes the line. It departs by more than half a radius for ``|t - 10| < 1.40``; the zone
    is that widened by one radius, on the axis's samples every quarter radius.

    >>> t = np.linspace(0.0, 20.0, 81)
    >>> line = np.c_[t, 0 * t, 0 * t]
    >>> fit = line + np.c_[0 * t, 1.2 * np.exp(-((t - 10.0) / 1.5) ** 2), 0 * t]
    >>> out, zones = medial_zones(fit, line, np.ones(81), 1.0)
    >>> float(abs(out[:, 1]).max()) < 0.5, zones.round(1).tolist()
    (True, [[8.0, 12.0]])
    """
    line, R = _densified(np.asarray(line, np.float64), np.asarray(radius, np.float64),
                         tol.TREE_MEDIAL_SAMPLING * rscale)
    aL = chord_length(line)
    n = int(np.clip(chord_length(nodes)[-1] / (tol.TREE_MEDIAL_SAMPLING * rscale), len(nodes),
                    tol.TREE_MEDIAL_MAX_SAMPLES))
    X = resample_arclength(nodes, n)
    a, foot, d = polyline_feet(X, line, aL)
    Ri = np.interp(a, aL, R)
    inner = ((a > 0.0) | through[0]) & ((a < aL[-1]) | through[1])
    bad = d > tol.TREE_MEDIAL_DEPARTURE * Ri
    if fit_radius is not None:  # kappa r on the fit's own dense axis, as check_axis_bend has it
        ax = Axis(nodes)
        fr = np.asarray(fit_radius, np.float64)
        kr = np.linalg.norm(ax.kvec, axis=1) * np.interp(ax.s, np.linspace(0.0, 1.0, len(fr)), fr)
        arc, margin = ax.s * ax.length, float(fr.mean())
        judged = (arc >= margin + skip_start) & (ax.length - arc >= margin)
        sharp = np.interp(np.linspace(0.0, 1.0, n), ax.s, (judged & (kr >= tol.GC_MAX_BEND)).astype(np.float64)) > 0
        bad |= sharp
    if sharp_s is not None and len(sharp_s):
        bad[np.clip(np.rint(np.asarray(sharp_s, np.float64) * (n - 1)).astype(np.int64), 0, n - 1)] = True
    bad &= inner
    if not bad.any():
        return nodes, np.zeros((0, 2))
    # the line's points within TREE_MEDIAL_MARGIN radii (along it) of a departing point
    lo, hi = a[bad] - tol.TREE_MEDIAL_MARGIN * Ri[bad], a[bad] + tol.TREE_MEDIAL_MARGIN * Ri[bad]
    order = np.argsort(lo)
    lo, hi = lo[order], np.maximum.accumulate(hi[order])
    k = np.searchsorted(lo, aL, side="right") - 1
    marked = (k >= 0) & (aL <= hi[np.maximum(k, 0)])
    runs = true_runs(marked)
    zones = np.c_[aL[runs[:, 0]], aL[runs[:, 1]]]
    # smoothstep weight by the arc-length distance to the nearest zone, over TREE_MEDIAL_BLEND radii
    gap = np.min(np.maximum(0.0, np.maximum(zones[:, :1] - a[None], a[None] - zones[:, 1:2])), axis=0)
    u = np.clip(1.0 - gap / (tol.TREE_MEDIAL_BLEND * Ri), 0.0, 1.0)
    w = u * u * (3.0 - 2.0 * u)
    inside = np.zeros(len(a), bool)
    for z0, z1 in zones:
        inside |= (a >= z0) & (a <= z1)
    moved = (1.0 - w[:, None]) * X + w[:, None] * foot
    kept = ~inside
    P = np.concatenate([moved[kept], line[marked]])
    key = np.concatenate([a[kept], aL[marked]])
    P = P[np.argsort(key, kind="stable")]
    keep = np.r_[True, np.linalg.norm(np.diff(P, axis=0), axis=1) > 0]
    return resample_arclength(P[keep], len(nodes)), zones
