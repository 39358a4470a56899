"""A vessel mesh clipped by a plane, as a segmentation's field of view or an analyst's clip cuts it.

``clipped(V, F, normal, point, cap=True)`` keeps the part of the surface on the side of the plane that
``normal`` points to, each triangle the plane crosses cut exactly on it (the cut vertices shared between
neighbours, so every cut is one planar loop), keeps the largest connected piece and, with ``cap``, closes
each of its boundary loops (the plane's and any open end it had) by a fan about the loop's mean: VMTK's ``vmtksurfacecapper`` default ("centerpoint")
and what most pipelines do. A vessel the plane crosses at an angle ends in an oblique flat cap whose rim the
wall meets at 90 degrees minus the obliquity on one side.

``python data_gen/clipped.py`` clips every real mesh of ``../shared/data/real`` by the planes of :func:`planes`,
across its three principal directions and three random ones, into ``--out`` (``scripts/real_meshes.py
--clipped`` fits them, open and capped: ``docs/real_meshes.md``).
"""
from __future__ import annotations

import argparse
import zlib
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

ROOT = Path(__file__).resolve().parents[1]


def clipped(V, F, normal, point, cap=True):
    """``(V, F)`` of the part of the surface in front of the plane through ``point`` with ``normal``.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        A coherently oriented surface.
    normal : (3,) float64
        Points to the part kept.
    point : (3,) float64
        On the plane.
    cap : bool
        Close each boundary loop by a fan about its mean (its faces turned as the surface's).

    Returns
    -------
    V : (k, 3) float64
    F : (l, 3) int64
        The largest connected piece; its cut loops lie on the plane exactly.
    """
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    n = np.asarray(normal, np.float64) / np.linalg.norm(normal)
    sd = (V - np.asarray(point, np.float64)) @ n
    edge = np.median(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1))
    sd = np.where(np.abs(sd) < 1e-3 * edge, 1e-3 * edge, sd)  # no vertex on the plane: no sliver faces
    pos = sd > 0
    npos = pos[F].sum(axis=1)
    crossed = F[(npos == 1) | (npos == 2)]
    p = pos[crossed]
    lone = np.argmax(p == (p.sum(axis=1) == 1)[:, None], axis=1)  # the vertex alone on its side
    r = np.arange(len(crossed))
    a, b, c = (crossed[r, (lone + k) % 3] for k in range(3))
    # the cut points on the crossed edges, one per edge
    keys = np.sort(np.concatenate([np.stack([a, b], 1), np.stack([a, c], 1)]), axis=1)
    uniq, inv = np.unique(keys, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    t = sd[uniq[:, 0]] / (sd[uniq[:, 0]] - sd[uniq[:, 1]])
    cut = V[uniq[:, 0]] + t[:, None] * (V[uniq[:, 1]] - V[uniq[:, 0]])
    ab, ac = len(V) + inv[:len(crossed)], len(V) + inv[len(crossed):]
    one = p.sum(axis=1) == 1  # keep the lone vertex's corner, else the quad beside it
    tri = [F[npos == 3], np.stack([a, ab, ac], 1)[one],
           np.stack([ab, b, c], 1)[~one], np.stack([ab, c, ac], 1)[~one]]
    W, G = _largest(np.vstack([V, cut]), np.vstack(tri))
    if cap:
        W, G = _fans(W, G)
    return W, G


def planes(V, name):
    """The clipping planes of a mesh: ``[(tag, normal, point)]``, the kept part in front of each.

    Across each of its three principal directions at the 20th, 35th, 65th and 80th percentiles of the vertices
    (``pc<k>@<q>``, the larger side kept), and three directions drawn from a generator seeded by the mesh's ``name``
    at their 25th and 50th percentiles (``obl<j>@<q>``).
    """
    c0 = V.mean(axis=0)
    U = np.linalg.svd(V - c0, full_matrices=False)[2]
    out = [(f"pc{k}@{q}", U[k] if q < 0.5 else -U[k], c0 + np.quantile((V - c0) @ U[k], q) * U[k])
           for k in range(3) for q in (0.2, 0.35, 0.65, 0.8)]
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    for j in range(3):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        out += [(f"obl{j}@{q}", n, c0 + np.quantile((V - c0) @ n, q) * n) for q in (0.25, 0.5)]
    return out


def unlike_a_field_of_view(V, F, normal, point):
    """Why the open clip of ``(V, F)`` (:func:`clipped` with ``cap=False``) is not a field of view's cut, or None.

    A cut loop longer than twice its width (a plane along a vessel's side cuts a slot, no end), or a loop that is
    part cut and part an open end the mesh had (a fan over it is folded), or no cut at all.
    """
    from vesselgp.mesh import mesh_topology

    n = np.asarray(normal, np.float64) / np.linalg.norm(normal)
    tol = 1e-6 * float(np.ptp(V))
    cuts = 0
    for loop in mesh_topology(F, len(V)).boundary_loops:
        on = np.abs((V[loop] - point) @ n) < tol
        if on.all():
            sv = np.linalg.svd(V[loop] - V[loop].mean(axis=0), compute_uv=False)
            if sv[0] > 2.0 * sv[1]:
                return f"a cut {sv[0] / sv[1]:.2g} times as long as it is wide"
            cuts += 1
        elif on.any():
            return "the plane crosses an open end"
    return None if cuts else "no cut"


def _largest(V, F):
    """The largest connected piece of ``(V, F)`` by faces, its vertices renumbered."""
    A = coo_matrix((np.ones(F.size), (F.ravel(), np.roll(F, 1, axis=1).ravel())), shape=(len(V), len(V)))
    _, lab = connected_components(A, directed=False)
    big = np.argmax(np.bincount(lab[F[:, 0]]))
    F = F[lab[F[:, 0]] == big]
    ids = np.unique(F)
    new = np.full(len(V), -1)
    new[ids] = np.arange(len(ids))
    return V[ids], new[F]


def _fans(V, F):
    """Each boundary loop of ``(V, F)`` closed by a fan about its centroid."""
    from vesselgp.mesh import mesh_topology
    from vesselgp.mesh._geometry import closed_by_fans

    return closed_by_fans(V, F, mesh_topology(F, len(V)).boundary_loops)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(ROOT.parent / "shared" / "data" / "real"))
    ap.add_argument("--out", default="clipped")
    args = ap.parse_args(argv)
    import vesselgp

    out = Path(args.out)
    out.mkdir(exist_ok=True)
    for path in sorted(Path(args.data).glob("*.st*")) + sorted(Path(args.data).glob("*.vtp")):
        V, F = vesselgp.read_mesh(path)[:2]
        for tag, n, c in planes(V, path.name):
            W, G = clipped(V, F, n, c)
            vesselgp.write_mesh(out / f"{path.stem}_{tag}.stl", W, G)


if __name__ == "__main__":
    main()
