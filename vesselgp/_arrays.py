"""Small array helpers shared by the stages."""
from __future__ import annotations

import numpy as np


def unique_rows(A, return_index=False, return_inverse=False, return_counts=False):
    """``np.unique(A, axis=0, ...)`` for integer rows, through one int64 key per row.

    ``np.unique(axis=0)`` sorts structured rows and is about 40 times slower on
    large edge lists; packing each row into one integer gives the same unique
    rows in the same (lexicographic) order. Falls back to ``np.unique(axis=0)``
    when the packed key would overflow.

    Parameters
    ----------
    A : (m, k) int
        Rows of non-negative integers.

    Returns
    -------
    Same as :func:`numpy.unique` with ``axis=0``; ``return_inverse`` is 1-D.

    Examples
    --------
    >>> unique_rows(np.array([[2, 1], [0, 3], [2, 1]]), return_counts=True)
    (array([[0, 3],
           [2, 1]]), array([1, 2]))
    """
    A = np.asarray(A)
    m, k = A.shape
    base = int(A.max()) + 1 if m else 1
    if m == 0 or A.min() < 0 or base ** k >= 2**62:
        out = np.unique(A, axis=0, return_index=return_index, return_inverse=return_inverse,
                        return_counts=return_counts)
        if return_inverse:
            out = list(out)
            out[1 + int(return_index)] = np.asarray(out[1 + int(return_index)]).ravel()
            out = tuple(out)
        return out
    key = np.zeros(m, np.int64)
    for j in range(k):
        key = key * base + A[:, j].astype(np.int64)
    res = np.unique(key, return_index=True, return_inverse=return_inverse, return_counts=return_counts)
    rows = A[res[1]]
    out = [rows]
    if return_index:
        out.append(res[1])
    out.extend(res[2:])
    return tuple(out) if len(out) > 1 else rows


def true_runs(mask):
    """Start and end index (inclusive) of each run of True in the boolean ``mask``: (k, 2) int64.

    Examples
    --------
    >>> true_runs(np.array([0, 1, 1, 0, 1], bool)).tolist()
    [[1, 2], [4, 4]]
    """
    d = np.diff(np.concatenate([[False], mask, [False]]).astype(np.int8))
    return np.c_[np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1]


def chunks(n, size):
    """Slices of at most ``size`` consecutive indices covering ``range(n)`` (one empty slice for n = 0).

    The blocks that bound a large computation's temporaries (issue #16's peak memory).

    Examples
    --------
    >>> chunks(5, 2)
    [slice(0, 2, None), slice(2, 4, None), slice(4, 5, None)]
    """
    return [slice(a, min(a + size, n)) for a in range(0, n, size)] or [slice(0, 0)]


def thinned(n, most):
    """Evenly thinned subset (a slice) of ``range(n)`` with at most about ``most`` entries.

    Examples
    --------
    >>> thinned(10, 4)
    slice(0, 10, 3)
    """
    step = max(1, int(np.ceil(n / most)))
    return slice(0, n, step)


def spread_subset(n, most):
    """Sorted ids of about ``most`` of ``range(n)``, spread evenly but aperiodically (all when ``n <= most``).

    The ``k``-th pick is ``floor(frac(k * phi) * n)`` with the golden ratio ``phi``: evenly spread like
    :func:`thinned`, but without its fixed stride, which on a structured mesh (rings of ``n_around``
    vertices) keeps the same few angles of every ring and biases a circle fit.

    Examples
    --------
    >>> spread_subset(10, 20).tolist(), len(spread_subset(1000, 100)) >= 95
    ([0, 1, 2, 3, 4, 5, 6, 7, 8, 9], True)
    """
    if n <= most:
        return np.arange(n)
    k = np.arange(int(most))
    return np.unique(np.floor(np.mod(k * 0.6180339887498949, 1.0) * n).astype(np.int64))


def within_balls(P, C, R):
    """Whether each point of ``P`` (p, 3) lies inside one of the balls of centres ``C`` (c, 3) and radii ``R`` (c,):
    (p,) bool. A point inside its nearest centre's ball is decided by that; the others are tested against every ball
    whose centre is nearer than the largest radius (two k-d trees). Many lines' balls overlap down a tree's trunk:
    all pairs there were 10^9 for the 64-tip tree's inside Voronoi vertices, this prefilter leaves few.

    Examples
    --------
    >>> within_balls(np.array([[0.0, 0, 0], [3, 0, 0]]), np.array([[0.5, 0, 0], [5, 0, 0]]), np.array([1.0, 1.5]))
    array([ True, False])
    """
    from scipy.spatial import cKDTree

    out = np.zeros(len(P), bool)
    if not len(P) or not len(C):
        return out
    tree = cKDTree(C)
    d, i = tree.query(P)
    out = d < R[i]  # inside the nearest centre's ball: decided; the rest against every ball that may hold it
    rest = np.flatnonzero(~out)
    if len(rest):
        near = tree.sparse_distance_matrix(cKDTree(P[rest]), float(np.max(R)), output_type="ndarray")
        out[rest[near["j"][near["v"] < R[near["i"]]]]] = True
    return out
