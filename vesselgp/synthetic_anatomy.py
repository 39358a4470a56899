"""Synthetic cases of the anatomy that real meshes show, each with exact truth (issue #44).

Every real mesh shows a few shapes that a fit must get right: a carotid siphon that turns back
on itself before its branches, a branch that loops back after its junction, an arch whose widest
end is capped flat behind its sinuses, a side-wall or a bifurcation sac, a flattened vein, a vein
tree with dozens of small blind ends. The real files are few; each shape is made here with known
centre lines, radii and ends, from the tree generator (:func:`vesselgp.synthetic_tree.tree_surface`:
tubes about cubic Bezier centre lines, the surface projected onto the exact implicit surface) or
the swept-tube generator (:func:`vesselgp.synthetic.synthetic_vessel`). None of the truth comes
from vesselgp's fitting code.

Examples
--------
>>> t = siphon_tree(voxel=0.5)
>>> [e.kind for e in t.truth.ends], len(t.truth.branches)
(['open', 'rounded', 'rounded'], 4)
"""
from __future__ import annotations

import numpy as np

from .mesh import mesh_topology
from .synthetic_tree import synthetic_tree, tree_surface

__all__ = ["bezier_between", "capped_arch", "clip_and_cap", "siphon_tree", "vein_tree"]


def bezier_between(P0, d0, P3, d1, k0, k1):
    """Control points (4, 3) of the cubic Bezier from ``P0`` leaving along ``d0`` to ``P3`` arriving along
    ``d1`` (directions normalised here), its inner control points ``k0`` and ``k1`` along them.

    Examples
    --------
    >>> bezier_between([0, 0, 0], [0, 0, 2], [1, 0, 5], [0, 0, 1], 1.0, 2.0).tolist()
    [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 3.0], [1.0, 0.0, 5.0]]
    """
    P0, P3 = np.asarray(P0, np.float64), np.asarray(P3, np.float64)
    d0 = np.asarray(d0, np.float64) / np.linalg.norm(d0)
    d1 = np.asarray(d1, np.float64) / np.linalg.norm(d1)
    return np.array([P0, P0 + k0 * d0, P3 - k1 * d1, P3])


def siphon_tree(voxel=0.35, blend=0.5):
    """A trunk that turns back on itself before it divides, and a branch that loops back after it.

    The shape of an internal carotid artery's siphon: the trunk (radius 3 at its open root, mm)
    rises 30 mm, turns through 180 degrees over a U of 24 mm span and divides heading down; one
    child (radius 1.8) leaves gently, the other (radius 1.8) turns back up until its tip lies
    behind the plane across its first tangent. Half of the trunk's centre line (its first 26 mm)
    lies ahead of the plane across the trunk's end tangent: a fit that cut the axes by those
    planes near the junction left the first 8.6 radii of every path, and the looping child's last
    1.7 radii, without an axis (issue #44).

    Parameters
    ----------
    voxel : float
        Grid spacing of the marching cubes (mm).
    blend : float
        Width of the smooth union at the junction (mm).

    Returns
    -------
    SyntheticTree
        Branches: 0 the rising trunk, 1 its U-turn, 2 the gentle child, 3 the looping child (ends
        0 the open root, 1 and 2 the rounded tips of branches 2 and 3).
    """
    A, J = np.array([0.0, 0.0, 30.0]), np.array([24.0, 0.0, 26.0])
    control = [bezier_between([0, 0, 0], [0, 0, 1], A, [0, 0, 1], 10, 10),
               bezier_between(A, [0, 0, 1], J, [0, 0, -1], 17, 17),
               bezier_between(J, [0.6, 0.3, -0.75], J + [16, 8, -12], [0.6, 0.5, 0.1], 7, 7),
               bezier_between(J, [-0.3, -0.5, -0.8], J + [4, -14, 10], [0.3, 0.3, 1.0], 16, 12)]
    radii = [[3.0, 2.9], [2.9, 2.6], [1.8, 1.6], [1.8, 1.5]]
    return tree_surface([-1, 0, 1, 1], control, radii, voxel=voxel, blend=blend)


def clip_and_cap(V, F, center, direction, radius, behind=0.0):
    """Cut a tube's end off by a plane and close the cut with a flat fan: a capped outlet.

    The plane lies ``behind`` radii behind ``center`` along the unit outward ``direction``; only the
    surface within ``behind + 2`` radii of ``center`` is cut (the rest of the mesh is left whole).
    Vertices within a twentieth of a median edge of the plane are moved onto it (no slivers); the
    faces in front are dropped, those across it cut, and the one new boundary loop on the plane is
    closed by a fan from its centroid (as many triangles as the loop has vertices), whose rim is sharp
    where the wall meets the plane.

    Returns
    -------
    V : (n', 3) float64
    F : (m', 3) int64
    centre : (3,) float64
        The cap's true centre: the point of the plane on the line through ``center`` along ``direction``.

    Raises
    ------
    ValueError
        The plane does not cut one loop off the surface near ``center``.
    """
    n = np.asarray(direction, np.float64) / np.linalg.norm(direction)
    q = np.asarray(center, np.float64) - behind * radius * n
    V = np.array(V, np.float64)
    phi = (V - q) @ n
    h = np.median(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1))
    local = np.linalg.norm(V - center, axis=1) < (behind + 2.0) * radius
    snap = local & (np.abs(phi) < 0.05 * h)  # onto the plane: no sliver triangles
    V[snap] -= np.outer(phi[snap], n)
    phi[snap] = 0.0
    front = local & (phi > 0)
    nf = front[F].sum(axis=1)
    out = [F[nf == 0]]
    W = list(V)
    cache = {}

    def cross(a, b):  # the plane's crossing of edge a (in front) - b (behind or on it)
        if phi[b] == 0:
            return b
        key = (min(a, b), max(a, b))
        if key not in cache:
            t = phi[a] / (phi[a] - phi[b])
            W.append(V[a] + t * (V[b] - V[a]))
            cache[key] = len(W) - 1
        return cache[key]

    for f in F[(nf == 1) | (nf == 2)]:
        fr = front[f]
        if fr.sum() == 2:  # keep the back vertex and the two crossings
            s = int(np.flatnonzero(~fr)[0])
            a, b, c = f[s], f[(s + 1) % 3], f[(s + 2) % 3]
            out.append([[a, cross(b, a), cross(c, a)]])
        else:  # one vertex in front: keep the quad behind
            s = int(np.flatnonzero(fr)[0])
            a, b, c = f[s], f[(s + 1) % 3], f[(s + 2) % 3]
            x, y = cross(a, b), cross(a, c)
            out.append([[x, b, c], [x, c, y]])
    W = np.array(W)
    F2 = np.vstack(out).astype(np.int64)
    on = np.abs((W - q) @ n) < 1e-12 * (1 + np.abs(q).max())
    F2 = F2[(F2[:, 0] != F2[:, 1]) & (F2[:, 1] != F2[:, 2]) & (F2[:, 2] != F2[:, 0]) & ~on[F2].all(axis=1)]
    used = np.unique(F2)
    remap = np.full(len(W), -1)
    remap[used] = np.arange(len(used))
    W, F2 = W[used], remap[F2]
    loops = [lp for lp in mesh_topology(F2, len(W)).boundary_loops
             if np.abs((W[lp] - q) @ n).max() < 1e-9 * (1 + np.abs(q).max())]
    if len(loops) != 1:
        raise ValueError(f"the plane cuts {len(loops)} loops off the surface near {center}, not one")
    lp = loops[0]
    c = W[lp].mean(axis=0)
    W = np.vstack([W, c])
    cap = np.c_[np.full(len(lp), len(W) - 1), np.roll(lp, -1), lp]
    return W, np.vstack([F2, cap]), q


def capped_arch(voxel=1.4, blend=2.0, sinus=0.45):
    """An aortic arch with three arch branches, every end capped flat, the widest (the ascending aorta's,
    radius 13.8 mm: 2.6-3.3 times the branches') behind a sinus bulge.

    The shape of a capped arch segmented from 4D-flow MRI (the real one whose widest cap was missed,
    issue #44): the descending aorta (radius 10.6-11.3 mm) rises to the arch (12.2-12.8 mm), which
    gives off the brachiocephalic (6.0-5.4), the left carotid (4.6-4.2) and the left subclavian
    (5.4-5.0) arteries and comes down as the ascending aorta to its root, closed at the valve plane by
    a flat cap of radius 13.8 mm. Behind that cap the root widens by ``sinus`` (a Gaussian bulge of the
    radius peaking 8 mm in: the sinuses of Valsalva, 1.3 times the annulus with the default) and
    narrows again. Every end is cut flat across its tube (:func:`clip_and_cap`): the caps are fans of
    as many triangles as their rims have vertices (about 60 for the root's at the default voxel).

    Parameters
    ----------
    voxel : float
        Grid spacing of the marching cubes (mm): the mesh's edge length, about.
    blend : float
        Width of the smooth union at the junctions (mm).
    sinus : float
        Amplitude of the root's bulge (0: none).

    Returns
    -------
    V : (n, 3) float64
    F : (m, 3) int64
    truth : SyntheticTree
        The tree before capping (its branches' exact centre lines and radii).
    caps : list of (centre (3,), outward direction (3,), radius)
        The five caps, the root's (the ascending aorta's) first, then the brachiocephalic's, the
        carotid's, the subclavian's and the descending aorta's.
    """
    z = np.array([0.0, 0.0, 1.0])
    c45, k = np.sqrt(0.5), 40.0 * 4.0 / 3.0 * np.tan(np.pi / 16)  # the arch: a half circle of radius 40 mm
    D, J3, J2, J1, A = (np.array(p, np.float64) for p in ([0, 0, 56], [-40 + 40 * c45, 0, 56 + 40 * c45],
                                                           [-40, 0, 96], [-40 - 40 * c45, 0, 56 + 40 * c45],
                                                           [-80, 0, 24]))
    control = [bezier_between([0, 0, 0], z, D, z, 18, 18),  # 0 descending aorta (the generator's root)
               bezier_between(D, z, J3, [-1, 0, 1], k, k),  # 1 distal arch
               bezier_between(J3, [0.3, -0.15, 1], J3 + [8, -6, 34], [0.3, -0.2, 1], 10, 10),  # 2 subclavian
               bezier_between(J3, [-1, 0, 1], J2, [-1, 0, 0], k, k),  # 3 arch
               bezier_between(J2, [0, 0.15, 1], J2 + [2, 4, 34], [0.1, 0.1, 1], 10, 10),  # 4 left carotid
               bezier_between(J2, [-1, 0, 0], J1, [-1, 0, -1], k, k),  # 5 proximal arch
               bezier_between(J1, [-0.25, 0.1, 1], J1 + [-8, 6, 34], [-0.1, 0.2, 1], 10, 10),  # 6 brachiocephalic
               bezier_between(J1, [-1, 0, -1], A, -z, 18, 25)]  # 7 ascending aorta, down to its root
    t0, w = 0.885, 0.07
    root = 13.8 / (1.0 + sinus * np.exp(-0.5 * ((1.0 - t0) / w) ** 2))  # the linear radius that ends at 13.8
    radii = [[10.6, 11.3], [11.3, 11.8], [5.4, 5.0], [11.8, 12.2], [4.6, 4.2], [12.2, 12.6], [6.0, 5.4],
             [12.6, root]]
    truth = tree_surface([-1, 0, 1, 1, 3, 3, 5, 5], control, radii, voxel=voxel, blend=blend,
                         bulges={7: [(t0, w, sinus)]} if sinus else None)
    V, F = truth.V, truth.F
    caps = []
    for b in (7, 6, 4, 2):  # the tips: cut across at their centres (the dome in front goes)
        br = truth.truth.branches[b]
        c, d, r = br.point([1.0])[0], br.tangent([1.0])[0], float(br.radius([1.0])[0])
        V, F, q = clip_and_cap(V, F, c, d, r)
        caps.append((q, d, r))
    V, F, q = clip_and_cap(V, F, np.zeros(3), -z, 10.6, behind=1.0 / 10.6)  # the descending aorta's open end,
    caps.append((q, -z, 10.6))  # cut 1 mm up its tube
    return V, F, truth, caps


def vein_tree(voxel=0.35, seed=0):
    """A closed vein tree of 32 small rounded blind ends over five generations, its root capped flat.

    The shape of a portal vein segmented from CT (issue #44: about 40 rounded blind ends a few voxels
    across; 6 of them were found and the fit was refused): a full binary tree of five levels
    (:func:`vesselgp.synthetic_tree.synthetic_tree`: root radius 3 mm and 30 mm long, each child 0.8 of its
    parent's end radius and 0.75 of its length, leaving at 55 degrees), its tips of radius 0.52 mm, meshed
    by marching cubes at ``voxel`` (0.35: the tips 3 voxels across; 0.5: 2), and its root cut 0.5 mm up and
    capped flat, so that the surface is closed.

    Returns
    -------
    V : (n, 3) float64
    F : (m, 3) int64
    truth : SyntheticTree
        The tree before capping: its 63 branches' exact centre lines and radii, its 32 rounded tips.
    cap : (centre (3,), outward direction (3,), radius)
        The root's cap.
    """
    truth = synthetic_tree(levels=5, radius=3.0, voxel=voxel, length=30.0, length_ratio=0.75,
                           branch_angle_deg=55.0, seed=seed, blend=0.2 / 3.0, min_radius_voxels=1.0)
    down = np.array([0.0, 0.0, -1.0])
    V, F, q = clip_and_cap(truth.V, truth.F, np.zeros(3), down, 3.0, behind=0.5 / 3.0)
    return V, F, truth, (q, down, float(truth.truth.branches[0].radius([0.0])[0]))
