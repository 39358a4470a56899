"""Two synthetic scans of one vessel with side branches, with a known material twist (issue #15).

A main vessel with ``k`` side branches is built twice, as state A and state B:

* the main centre line is a chain of ``k + 1`` cubic Bezier segments (tangent
  continuous) that meet at the side branches' junctions; each state has its own
  random bends, and state B's segments are ``stretch`` times as long (a
  shortening for ``stretch < 1``), so junction ``j`` is at material arc length
  ``s_j`` in A and ``stretch * s_j`` in B;
* each side branch leaves its junction at ``branch_angle_deg`` from the main
  tangent, at azimuth ``psi_j`` about it, measured in the main centre line's
  rotation-minimizing frame; in state B the azimuth is ``psi_j + alpha(s_j)``,
  where ``alpha`` is the imposed material twist. A branch has the same shape in
  both states, in the frame (tangent, azimuth direction) at its junction;
* each state is meshed independently by marching cubes
  (:func:`vesselgp.synthetic_tree.tree_surface`, with its own voxel), and
  state B is then moved by a rigid motion. The two surfaces share no vertices.

The truth does not use vesselgp's RMF: the frame is transported along the exact
Bezier tangents by integrating the RMF equation ``U' = -(U . T') T`` with
scipy's ``solve_ivp``. The twist of the segment between landmarks ``j`` and
``j + 1`` is ``alpha(s_{j+1}) - alpha(s_j)``, right-handed about the main axis
from its root end to its tip.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from . import tolerances as tol
from .errors import OptionError
from .rotations import perpendicular, rotate
from .synthetic_tree import SyntheticTree, _bezier, _coefficients, _eval, tree_surface

__all__ = ["ScanPair", "twist_pair"]


@dataclass(frozen=True, eq=False)
class ScanPair:
    """Two scans of one vessel with side branches and the material twist between them.

    Attributes
    ----------
    a, b : SyntheticTree
        The two states. ``b.V`` is moved by the rigid motion; ``b.truth`` stays in
        the pose it was meshed in.
    V_b : (n, 3) float64
        State B's vertices after the rigid motion (the scan a user would get).
    rotation : (3, 3) float64
    translation : (3,) float64
        The rigid motion: ``V_b = b.V @ rotation.T + translation``.
    s_a, s_b : (k,) float64
        Arc length of each junction along the main centre line from its root end.
    alpha : (k,) float64
        Imposed material twist at each junction (radians).
    segment_twist : (k - 1,) float64
        Truth: ``alpha[j + 1] - alpha[j]``.
    total_twist : float
        ``alpha[-1] - alpha[0]``.
    azimuth : (k,) float64
        Azimuth of each side branch in state A (radians, in the true RMF).
    stretch : float
    main_tip : int
        Index in ``a.truth.ends`` of the main vessel's tip (its root end is 0).
    side_radius : (k,) float64
    frames_a, frames_b : (k, 3, 3) float64
        True tangent, RMF normal and binormal (rows) at each junction (state B's in the
        pose it was meshed in: turn by ``rotation`` for ``V_b``'s).
    """

    a: SyntheticTree
    b: SyntheticTree
    V_b: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray
    s_a: np.ndarray
    s_b: np.ndarray
    alpha: np.ndarray
    segment_twist: np.ndarray
    total_twist: float
    azimuth: np.ndarray
    stretch: float
    main_tip: int
    side_radius: np.ndarray
    frames_a: np.ndarray = None
    frames_b: np.ndarray = None


def _rmf_ode(ctrl, U0):
    """RMF normal transported along a Bezier by ``dU/dt = -(U . T'(t)) T(t)`` (exact tangents).

    Returns the unit normal at ``t = 1`` (3,).
    """
    a = _coefficients(ctrl)

    def rhs(t, U):
        d1 = _eval(a, [t], 1)[0]
        d2 = _eval(a, [t], 2)[0]
        sp = np.linalg.norm(d1)
        T = d1 / sp
        dT = (d2 - (d2 @ T) * T) / sp
        return -(U @ dT) * T

    sol = solve_ivp(rhs, (0.0, 1.0), U0, rtol=tol.SCAN_PAIR_RMF_RTOL, atol=tol.SCAN_PAIR_RMF_ATOL, method="DOP853")
    U = sol.y[:, -1]
    T = _eval(a, [1.0], 1)[0]
    T /= np.linalg.norm(T)
    U = U - (U @ T) * T
    return U / np.linalg.norm(U)


def _main_chain(lengths, bend, rng):
    """Control points (k + 1, 4, 3) of the tangent-continuous main chain from the origin along +z."""
    P, d = np.zeros(3), np.array([0.0, 0.0, 1.0])
    out = []
    for L in lengths:
        axis = perpendicular(d)
        axis = rotate(axis, d, rng.uniform(0.0, 2 * math.pi))
        # bends bounded towards +z so that nothing reaches below the root plane
        d1 = rotate(d, axis, math.radians(rng.uniform(0.3, 1.0) * bend))
        if d1[2] < 0.5:
            d1 = rotate(d, -axis, math.radians(rng.uniform(0.3, 1.0) * bend))
        c = _bezier(P, d, d1, L, rng)
        out.append(c)
        P, d = c[3], (c[3] - c[2]) / np.linalg.norm(c[3] - c[2])
    return np.array(out)


def _frames_at_junctions(chain, U0):
    """Exact tangent and RMF normal at the end of each main segment (the junctions)."""
    T, U, u = [], [], np.asarray(U0, float)
    for c in chain:
        u = _rmf_ode(c, u)
        t = (c[3] - c[2]) / np.linalg.norm(c[3] - c[2])
        T.append(t)
        U.append(u)
    return np.array(T), np.array(U)


def _side_shapes(k, length, angle, rng):
    """Each side branch in local coordinates (tangent, azimuth direction, their cross): (k, 4, 3)."""
    out = []
    b = math.radians(angle)
    for _ in range(k):
        d0 = np.array([math.cos(b), math.sin(b), 0.0])
        # arrive a little more along the main direction, turned slightly out of the plane
        e = math.radians(rng.uniform(-15.0, 15.0))
        b1 = b * rng.uniform(0.75, 0.95)
        d1 = np.array([math.cos(b1), math.sin(b1) * math.cos(e), math.sin(b1) * math.sin(e)])
        out.append(_bezier(np.zeros(3), d0, d1, length * rng.uniform(0.85, 1.15), rng))
    return np.array(out)


def _state(chain, shapes, T, U, azimuth, radius, side_radius, taper, drop=()):
    """Parents, control points and radii of one state's tree; the side branches in ``drop`` are left out."""
    k = len(shapes)
    parents, ctrl, radii = [-1], [chain[0]], []
    r_main = radius * np.power(taper, np.arange(k + 2) / (k + 1))
    radii.append((r_main[0], r_main[1]))
    last_main = 0
    for j in range(k):
        t, u = T[j], U[j]
        v = np.cross(t, u)
        m = math.cos(azimuth[j]) * u + math.sin(azimuth[j]) * v
        basis = np.stack([t, m, np.cross(t, m)])
        J = chain[j][3]
        parents.append(last_main)
        ctrl.append(chain[j + 1])
        radii.append((r_main[j + 1], r_main[j + 2]))
        main = len(parents) - 1
        if j not in drop:
            parents.append(last_main)
            ctrl.append(J + shapes[j] @ basis)
            radii.append((side_radius[j], side_radius[j] * 0.9))
        last_main = main
    return parents, np.array(ctrl), np.array(radii)


def twist_pair(n_branches=4, *, twist_deg=60.0, twist=None, stretch=0.87, length=110.0, radius=3.0,
               side_radius=1.3, side_length=14.0, branch_angle_deg=75.0, bend_deg=(20.0, 35.0),
               azimuths=None, voxel=(0.4, 0.45), drop_b=(), seed=0):
    """Two scans of a vessel with side branches: bent differently, shortened, twisted, moved.

    Parameters
    ----------
    n_branches : int
        Side branches (landmarks), at least 2.
    twist_deg : float
        Total imposed twist from the first junction to the last when ``twist`` is None:
        ``alpha(s)`` linear in the arc length of state A, 0 at the root.
    twist : callable, optional
        ``alpha(s)`` in radians of the arc length of state A (mm), e.g. a non-uniform twist.
    stretch : float
        Length of state B over state A (0.85-0.9: shortened by 10-15 %).
    length : float
        Main centre-line length of state A (mm).
    radius : float
        Main radius at the root (tapering by 15 % to the tip).
    side_radius : float or (k,) float
    side_length : float
        Side branch length (mm, +-15 %).
    branch_angle_deg : float
        Angle of each side branch from the main tangent at its junction.
    bend_deg : (float, float)
        Largest bend per main segment in state A and in state B.
    azimuths : (k,) float, optional
        Side branch azimuths in state A (radians); default spread over the turn at random.
    voxel : (float, float)
        Marching-cubes grid of state A and of state B.
    drop_b : sequence of int
        Side branches (0-based, from the root end) that state B lacks: landmarks
        of A without a partner in B.
    seed : int

    Returns
    -------
    ScanPair

    Examples
    --------
    >>> p = twist_pair(3, twist_deg=45.0, voxel=(0.6, 0.6), side_radius=1.8)
    >>> len(p.s_a), bool(np.allclose(p.s_b, 0.87 * p.s_a)), round(float(np.degrees(p.total_twist)), 6) != 0
    (3, True, True)
    """
    k = int(n_branches)
    if k < 2:
        raise OptionError(f"twist_pair needs at least 2 side branches, got {n_branches}")
    if not 0.5 < float(stretch) <= 1.5:
        raise OptionError(f"stretch must be in (0.5, 1.5], got {stretch}")
    rng = np.random.default_rng(seed)
    w = rng.uniform(0.8, 1.2, k + 1)
    w[0] *= 1.3  # the first junction away from the root end
    seg = float(length) * w / w.sum()
    s_a = np.cumsum(seg)[:k]
    if twist is None:
        rate = math.radians(float(twist_deg)) / (s_a[-1] - s_a[0])
        alpha = rate * s_a
    else:
        alpha = np.array([float(twist(s)) for s in s_a])
    if azimuths is None:
        azimuths = np.mod(np.arange(k) * 2.4 + rng.uniform(0, 2 * math.pi), 2 * math.pi)
    azimuths = np.asarray(azimuths, float)
    sr = np.broadcast_to(np.asarray(side_radius, float), (k,)).copy()
    shapes = _side_shapes(k, side_length, branch_angle_deg, rng)
    trees, frames = [], []
    for state, (bend, h, scale, extra) in enumerate(((bend_deg[0], voxel[0], 1.0, np.zeros(k)),
                                                     (bend_deg[1], voxel[1], float(stretch), alpha))):
        chain = _main_chain(seg * scale, bend, np.random.default_rng(seed + 101 * (state + 1)))
        U0 = rotate(np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]), rng.uniform(0, 2 * math.pi))
        T, U = _frames_at_junctions(chain, U0)
        frames.append(np.stack([T[:k], U[:k], np.cross(T[:k], U[:k])], axis=1))
        parents, ctrl, radii = _state(chain, shapes, T, U, azimuths + extra, radius, sr, 0.85,
                                      drop=tuple(drop_b) if state == 1 else ())
        trees.append(tree_surface(parents, ctrl, radii, voxel=h, blend=tol.SCAN_PAIR_BLEND * radius, seed=seed))
    a, b = trees
    R = Rotation.from_rotvec(rng.normal(size=3) * 1.2).as_matrix()
    t = rng.normal(size=3) * 40.0
    main_tip = next(i for i, e in enumerate(a.truth.ends) if e.kind == "rounded" and e.branch == len(a.truth.branches) - 2)
    return ScanPair(a=a, b=b, V_b=b.V @ R.T + t, rotation=R, translation=t, s_a=s_a, s_b=float(stretch) * s_a,
                    alpha=alpha, segment_twist=np.diff(alpha), total_twist=float(alpha[-1] - alpha[0]),
                    azimuth=azimuths, stretch=float(stretch), main_tip=main_tip, side_radius=sr,
                    frames_a=frames[0], frames_b=frames[1])
