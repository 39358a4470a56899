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

from .synthetic_tree import tree_surface

__all__ = ["bezier_between", "siphon_tree"]


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
