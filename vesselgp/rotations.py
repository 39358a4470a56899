"""Rotations and unit vectors: the one set of helpers every stage uses.

Built on :class:`scipy.spatial.transform.Rotation`. Angles are radians; angle
differences are wrapped to (-pi, pi] by :func:`wrap_angle`.

Degenerate cases are documented, not silent: the minimal rotation between two
opposite directions is a half turn about :func:`perpendicular` of the first
(a fixed, documented choice), and a zero vector raises :class:`FrameError`.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from . import tolerances as tol
from ._validate import as_vector
from .errors import FrameError

__all__ = ["unit", "unit_rows", "perpendicular", "rotate", "minimal_rotation", "rotation_matrix",
           "wrap_angle"]


def unit(v, name="vector", what="a non-zero direction"):
    """``v / |v|`` for a non-zero 3-vector of any length (no unit-dependent threshold).

    Parameters
    ----------
    v : (3,) float64
    name : str
        Used in the error message.
    what : str
        What to give instead of a zero vector (the message's remedy).

    Raises
    ------
    FrameError
        Not a finite 3-vector, or the zero vector.

    Examples
    --------
    >>> unit([0, 3e-300, 4e-300]).tolist()
    [0.0, 0.6, 0.8]
    """
    a = as_vector(v, name)
    m = float(np.abs(a).max())
    if not m > 0:
        raise FrameError(f"{name} is the zero vector; give {what}")
    a = a / m  # scale first: no overflow or underflow for any non-zero length
    return a / np.linalg.norm(a)


def unit_rows(X):
    """Rows of ``X`` divided by their norms (rows must be non-zero: checked by the caller's geometry).

    Parameters
    ----------
    X : (k, 3) float64

    Returns
    -------
    (k, 3) float64

    Examples
    --------
    >>> unit_rows(np.array([[3.0, 4, 0], [0, 0, 2]])).tolist()
    [[0.6, 0.8, 0.0], [0.0, 0.0, 1.0]]
    """
    return X / np.sqrt(np.einsum("ij,ij->i", X, X))[:, None]


def perpendicular(t):
    """Unit vectors perpendicular to unit ``t``: the coordinate axis least aligned with it, projected.

    A fixed, documented choice (not rotation-covariant), used only where the
    geometry offers none (a straight axis has no bend direction).

    Parameters
    ----------
    t : (3,) or (k, 3) float64
        Unit vector(s).

    Returns
    -------
    (3,) or (k, 3) float64

    Examples
    --------
    >>> perpendicular(np.array([0.0, 0.0, 1.0])).tolist()
    [1.0, 0.0, 0.0]
    >>> perpendicular(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])).tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    """
    t = np.asarray(t, float)
    T = np.atleast_2d(t)
    e = np.eye(3)[np.argmin(np.abs(T), axis=1)]
    u = unit_rows(e - np.einsum("ij,ij->i", e, T)[:, None] * T)
    return u.reshape(t.shape)


def rotate(v, axis, angle):
    """Rotate vectors ``v`` about unit ``axis`` by ``angle`` (right-handed).

    Parameters
    ----------
    v : (3,) or (k, 3) float64
    axis : (3,) or (k, 3) float64
        Unit axis (one for all rows, or one per row).
    angle : float or (k,) float64
        Radians (one for all rows, or one per row).

    Returns
    -------
    Same shape as ``v``.

    Examples
    --------
    >>> np.round(rotate([1.0, 0, 0], [0, 0, 1.0], np.pi / 2), 12).tolist()
    [0.0, 1.0, 0.0]
    """
    v = np.asarray(v, float)
    if not v.flags.writeable:  # scipy's apply needs a writeable buffer (read-only Frame fields)
        v = v.copy()
    rv = np.asarray(axis, float) * np.asarray(angle, float)[..., None]
    return Rotation.from_rotvec(rv).apply(v)


def minimal_rotation(a, b):
    """The rotation of least angle taking unit ``a`` to unit ``b``.

    Opposite directions have no unique minimal rotation: a half turn about
    :func:`perpendicular` of ``a`` is returned (documented choice).

    Parameters
    ----------
    a, b : (3,) float64
        Unit vectors.

    Returns
    -------
    scipy.spatial.transform.Rotation

    Examples
    --------
    >>> R = minimal_rotation(np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))
    >>> np.round(R.apply([1.0, 0, 0]), 12).tolist(), round(float(np.degrees(R.magnitude())), 9)
    ([0.0, 1.0, 0.0], 90.0)
    """
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    ax = np.cross(a, b)
    sn = float(np.linalg.norm(ax))
    cs = float(a @ b)
    if sn < tol.STRAIGHT_SIN:
        if cs > 0:
            return Rotation.identity()
        return Rotation.from_rotvec(np.pi * perpendicular(a))
    return Rotation.from_rotvec(ax / sn * np.arctan2(sn, cs))


def rotation_matrix(axis, angle):
    """(3, 3) matrix of the right-handed rotation about unit ``axis`` by ``angle``.

    Examples
    --------
    >>> np.round(rotation_matrix([0, 0, 1.0], np.pi / 2) @ [1.0, 0, 0], 12).tolist()
    [0.0, 1.0, 0.0]
    """
    return Rotation.from_rotvec(unit(axis, "axis") * float(angle)).as_matrix()


def wrap_angle(a):
    """Wrap angles (radians) to (-pi, pi].

    Examples
    --------
    >>> wrap_angle(np.array([np.pi, -np.pi, 3 * np.pi / 2])).round(6).tolist()
    [3.141593, 3.141593, -1.570796]
    """
    return np.pi - np.mod(np.pi - np.asarray(a, float), 2 * np.pi)
