"""Tubes swept along real vessels' centre lines: real, tortuous anatomy with an exact centre line (issue #48).

Usage::

    python data_gen/real_shapes.py OUT [--case NAME ...] [--remesh] [--list]

writes ``OUT/<case>.ply`` (mm) and ``OUT/<case>.npz`` (the exact centre line ``centers`` (K, 3), arc length
``s`` (K,) in mm, perimeter-mean radius ``radii`` (K,), RMF ``frames`` (K, 3, 3), the imposed twist ``alpha``
(K,) in radians, and per vertex ``vertex_s`` (normalised arc length) and ``vertex_theta``) for each case of
:data:`CASES` (all by default). ``--list`` prints the cases with their length, radius range and tightest bend.

The construction
----------------
Nothing of vesselgp's fitting is used; the shape comes from VMTK 1.5.2's centre lines of the real meshes
(``shared/data/real/vmtk/<mesh>.npz``, one line per target end from the widest end, in mm, with the maximum
inscribed sphere radius at every point).

1. *Centre line.* VMTK line ``line`` is resampled every tenth of its median radius and its coordinates are
   smoothed by a local linear Gaussian regression of width ``smooth`` times the local radius (VMTK's points
   sit on the Voronoi diagram of a voxel surface and zig-zag by up to a voxel, and jump at junctions; a width
   of about half a radius keeps the siphon-like bends, ``kappa r`` up to 0.5-0.7, and removes the zig-zag).
   The radius is smoothed over twice that width, and narrowed to ``KR_MAX`` over the local bend radius where
   the line turns tighter (a tube folds over itself past 1). ``trim`` radii are cut from each end (the filter's edge), and the line is handed to
   :func:`vesselgp.synthetic.synthetic_vessel` every quarter radius (20th percentile).
2. *Tube.* :func:`vesselgp.synthetic.synthetic_vessel` sweeps the section along the quintic arc-length spline
   through those points with its rotation-minimizing frame (integrated from its ODE): circles of the smoothed
   inscribed radius, or ellipses of axis ratio ``ellipticity`` with the same perimeter-mean radius (a
   flattened vein down to 2.5:1, ``ellipticity=0.4``), 48 points around, rings every around spacing, open
   ends; optionally an imposed material twist and pymeshlab's isotropic remeshing. The centre line of the
   swept tube is the spline exactly: its ``truth.centers`` are the ring centres.

3. *Trees* (:func:`real_network_tree`, :data:`NETWORK_TREES`). A real tree's whole network: each line joins the
   lines placed before it where it leaves them, the parent is split there, and the union of the swept
   splines is meshed by the synthetic arterial tree's mesher (:func:`vesselgp.synthetic.synthetic_arterial_tree`:
   narrow-band marching cubes, blended junctions, vertices projected onto the exact surface).

The cases (:data:`CASES`) are the real meshes' most tortuous lines: the X-ray coronary (one tube), the
XCAT coronary tree's longest line and its thinnest branch, the 4D-flow arch's descending line and a
supra-aortic branch, the carotid's internal branch, the renal-iliac tree's renal and iliac lines. The thin
cases are also meshed with 8 points around (the thin distal branches of a segmentation: 6-8 edges around).
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

_HERE = Path(__file__).resolve()
sys.path.insert(0, str(_HERE.parent))

from real_twist import arc_length, load_tree  # noqa: E402  (data_gen's own loader of the real meshes)

#: Width of the centre line's Gaussian smoothing, in local radii (see the module notes).
SMOOTH = 0.5
#: Radii cut from each end of the smoothed line (the Gaussian's edge effect).
TRIM = 3.0
#: Resampling step of the VMTK line before smoothing, in its smallest radii.
STEP = 0.1
#: Spacing of the points handed to synthetic_vessel, in 20th-percentile radii.
HAND = 0.25
#: Largest curvature x radius of a swept case: where the smoothed line turns tighter for its radius, the
#: radius is narrowed to this (a tube through a turn tighter than its radius would fold over itself).
KR_MAX = 0.7


@dataclass(frozen=True)
class Case:
    """One swept case: real mesh ``mesh``, VMTK line ``line``, section and mesh density."""

    mesh: str
    line: int
    ellipticity: float = 1.0
    n_around: int = 48
    what: str = ""


CASES = {
    "coronary": Case("xra_coronary_single_branch_open.stl", 0, what="X-ray coronary, one tortuous tube"),
    "coronary_vein": Case("xra_coronary_single_branch_open.stl", 0, ellipticity=0.4,
                          what="the coronary's line with a 2.5:1 elliptic section (a flattened vein)"),
    "coronary_sparse": Case("xra_coronary_single_branch_open.stl", 0, n_around=8,
                            what="the coronary's line, 8 points around (a thin segmented branch)"),
    "xcat_long": Case("xrayangio_xcat-coronary-tree_open.stl", 0, what="XCAT coronary tree, root to a distal end"),
    "xcat_thin": Case("xrayangio_xcat-coronary-tree_open.stl", 7, n_around=8,
                      what="XCAT coronary tree, a thin side line, 8 points around"),
    "arch": Case("cardiopinns_aortic-arch-4dflow_capped.stl", 0, what="4D-flow aortic arch, descending line"),
    "arch_branch": Case("cardiopinns_aortic-arch-4dflow_capped.stl", 2, what="4D-flow arch, a supra-aortic line"),
    "carotid": Case("gmsh_carotid-bifurcation_open.stl", 0, what="carotid bifurcation, one daughter line"),
    "renal": Case("gmsh_abdominal-aorta-renal-iliac_open.stl", 2, what="renal-iliac tree, a renal line"),
    "iliac": Case("gmsh_abdominal-aorta-renal-iliac_open.stl", 0, what="renal-iliac tree, an iliac line"),
}


def real_centerline(mesh, line, smooth=SMOOTH, trim=TRIM):
    """VMTK line ``line`` of real mesh ``mesh`` smoothed and trimmed (step 1 of the module notes).

    Returns
    -------
    P : (k, 3) float64
        Evenly spaced points (a quarter of the 20th-percentile radius apart, mm), from VMTK's source end.
    R : (k,) float64
        The smoothed inscribed radius at each.
    """
    lines = load_tree(mesh)[2]
    P, R = lines[line]
    s = arc_length(P)
    keep = np.concatenate([[True], np.diff(s) > 0])
    P, R, s = P[keep], R[keep], s[keep]
    h = STEP * float(np.min(R))
    sg = np.linspace(0.0, s[-1], int(np.ceil(s[-1] / h)) + 1)
    Q = np.stack([np.interp(sg, s, P[:, i]) for i in range(3)], axis=1)
    Rq = np.interp(sg, s, R)
    # the width follows the vessel: smooth x the local radius (itself smoothed over a few radii first)
    scale = _local_smooth(sg, Rq[:, None], np.full(len(sg), 2.0 * float(np.median(R))))[:, 0]
    sig = smooth * scale
    Q = _local_smooth(sg, Q, sig)
    Rq = _local_smooth(sg, Rq[:, None], 2 * sig)[:, 0]
    # narrowed where the line turns tighter than KR_MAX radii: the cap's running minimum over twice the
    # smoothing width, smoothed (a smooth radius at most a few per cent above the cap)
    d1 = np.gradient(Q, sg, axis=0)
    d2 = np.gradient(d1, sg, axis=0)
    kappa = np.linalg.norm(np.cross(d1, d2), axis=1) / np.linalg.norm(d1, axis=1) ** 3
    cap = KR_MAX / np.maximum(kappa, 1e-12)
    w = np.ceil(2 * sig / h).astype(int)
    low = np.array([cap[max(i - k, 0):i + k + 1].min() for i, k in enumerate(w)])
    Rq = np.minimum(Rq, _local_smooth(sg, np.minimum(Rq, low)[:, None], sig)[:, 0])
    cut0, cut1 = trim * float(R[s <= trim * R[0]].max()), trim * float(R[s >= s[-1] - trim * R[-1]].max())
    inner = np.flatnonzero((sg > cut0) & (sg < sg[-1] - cut1))
    # evenly spaced (an uneven spacing rings in the quintic spline's curvature), HAND of its
    # 20th-percentile radius apart
    every = max(int(round(HAND * float(np.percentile(R, 20)) / (sg[1] - sg[0]))), 1)
    pick = inner[::every]
    return Q[pick].copy(), Rq[pick].copy()


def _local_smooth(s, X, sig, block=1024):
    """Local linear kernel regression of ``X`` (n, d) against ``s`` (n,) with a Gaussian of width ``sig`` (n,)
    at each point (no edge bias, and a width that may vary along the line)."""
    out = np.empty_like(X)
    for b in range(0, len(s), block):
        e = slice(b, b + block)
        u = (s[None, :] - s[e, None]) / sig[e, None]
        w = np.exp(-0.5 * u * u) * (np.abs(u) < 4.0)
        S0, S1, S2 = w.sum(1), (w * u).sum(1), (w * u * u).sum(1)
        T0, T1 = w @ X, (w * u) @ X
        out[e] = (S2[:, None] * T0 - S1[:, None] * T1) / (S0 * S2 - S1 * S1)[:, None]
    return out


def swept_real(mesh, line, *, ellipticity=1.0, ellipse_angle=0.3, twist=None, n_around=48, remesh=False,
               seed=0, smooth=SMOOTH):
    """The tube swept along :func:`real_centerline` (step 2 of the module notes): a
    :class:`vesselgp.synthetic.SyntheticVessel` in mm whose ``truth`` is exact."""
    from vesselgp.synthetic import synthetic_vessel

    P, R = real_centerline(mesh, line, smooth)
    return synthetic_vessel(P, radius=R, ellipticity=ellipticity, ellipse_angle=ellipse_angle, twist=twist,
                            n_around=n_around, remesh=remesh, seed=seed, units="mm")


def case_vessel(name, twist=None, remesh=False):
    """The :class:`vesselgp.synthetic.SyntheticVessel` of case ``name`` of :data:`CASES`."""
    c = CASES[name]
    return swept_real(c.mesh, c.line, ellipticity=c.ellipticity, n_around=c.n_around, twist=twist, remesh=remesh)


def bend_profile(truth):
    """Curvature times radius along a swept case's exact centre line, (K,) float64 (from its RMF tangents)."""
    T = truth.frames[:, 0]
    st = truth.s * truth.length
    k = np.linalg.norm(np.gradient(T, st, axis=0), axis=1)
    return k * truth.radii


def main(argv=None):
    import vesselgp

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", nargs="?", type=Path)
    ap.add_argument("--case", nargs="*", default=None, choices=sorted(CASES))
    ap.add_argument("--remesh", action="store_true", help="pymeshlab isotropic remeshing of each tube")
    ap.add_argument("--list", action="store_true", help="print the cases and stop")
    a = ap.parse_args(argv)
    names = a.case or sorted(CASES)
    for name in names:
        try:
            ves = case_vessel(name, remesh=a.remesh)
        except ValueError as e:  # a case whose line folds (listed, not written)
            print(json.dumps({"case": name, "error": str(e)}))
            continue
        t = ves.truth
        info = {"case": name, "vertices": len(ves.V), "length_mm": round(t.length, 2),
                "radius_mm": [round(float(t.radii.min()), 3), round(float(t.radii.max()), 3)],
                "max_kappa_r": round(float(bend_profile(t).max()), 3), "what": CASES[name].what}
        print(json.dumps(info))
        if a.list or a.out is None:
            continue
        a.out.mkdir(parents=True, exist_ok=True)
        vesselgp.write_mesh(a.out / f"{name}.ply", ves.V, ves.F)
        np.savez(a.out / f"{name}.npz", centers=t.centers, s=t.s * t.length, radii=t.radii, frames=t.frames,
                 alpha=t.alpha, vertex_s=t.vertex_s, vertex_theta=t.vertex_theta)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())


# --------------------------------------------------------------------------- #
# trees: the real centre-line networks swept as a union of tubes
# --------------------------------------------------------------------------- #
#: A VMTK line leaves the lines already placed where it stays farther than this many of their local radii.
DEPART = 0.5
#: Samples of each branch's quintic spline (uniform in arc length).
BRANCH_SAMPLES = 801


def _polyline_branch_class():
    """:class:`PolylineBranch`, made on first use (it subclasses vesselgp's private TreeBranch)."""
    from dataclasses import dataclass
    from functools import cached_property

    from scipy.interpolate import make_interp_spline
    from scipy.spatial import cKDTree

    from vesselgp.synthetic_tree import TreeBranch

    @dataclass(frozen=True)
    class PolylineBranch(TreeBranch):
        """A tree branch about a quintic spline through smoothed VMTK points (uniform in arc length,
        ``t`` in [0, 1]) with a cubic spline radius; the methods of the Bezier branch it stands for."""

        curve: object = None
        rcurve: object = None

        @classmethod
        def build(cls, P, R, parent, level):
            s = arc_length(P)
            u = s / s[-1]
            curve = make_interp_spline(u, P, k=5)
            rcurve = make_interp_spline(u, R, k=3)
            t = np.linspace(0.0, 1.0, BRANCH_SAMPLES)
            C = curve(t)
            return cls(control=np.array([P[0], P[0], P[-1], P[-1]]), radius_start=float(R[0]),
                       radius_end=float(R[-1]), parent=int(parent), junction=P[0].copy(), level=int(level), t=t,
                       centers=C, radii=rcurve(t), s=arc_length(C), length=float(arc_length(C)[-1]),
                       curve=curve, rcurve=rcurve)

        @cached_property
        def _seeds(self):
            ts = np.linspace(0.0, 1.0, 4 * BRANCH_SAMPLES)
            return ts, cKDTree(self.curve(ts))

        def point(self, t):
            return self.curve(np.atleast_1d(t))

        def tangent(self, t):
            d = self.curve(np.atleast_1d(t), 1)
            return d / np.linalg.norm(d, axis=1, keepdims=True)

        def radius(self, t):
            return self.rcurve(np.asarray(t, dtype=np.float64))

        def radius_slope(self, t):
            return self.rcurve(np.asarray(t, dtype=np.float64), 1)

        def _newton(self, X, t, steps):
            for _ in range(steps):
                D = self.curve(t) - X
                d1, d2 = self.curve(t, 1), self.curve(t, 2)
                g = np.einsum("ij,ij->i", D, d1)
                s2 = np.einsum("ij,ij->i", d1, d1)
                dg = s2 + np.einsum("ij,ij->i", D, d2)
                dg = np.where(dg > 0, dg, s2)
                t = np.clip(t - g / dg, 0.0, 1.0)
            return t, np.linalg.norm(X - self.curve(t), axis=1)

        @cached_property
        def _seed_error(self):
            ts = self._seeds[0]
            P = self.curve(ts)
            return (2 * float(np.max(np.linalg.norm(np.diff(P, axis=0), axis=1))) + 0.01 * self.radius_start
                    + 2 * float(np.max(np.abs(self.radius_slope(ts)))) * (ts[1] - ts[0]))

        def _field_t(self, X, t, gradient):
            t, d = self.foot(X, t)
            f = d - self.radius(t)
            if not gradient:
                return f, None, t
            B, d1, d2 = self.curve(t), self.curve(t, 1), self.curve(t, 2)
            n = (X - B) / np.maximum(d, 1e-300)[:, None]
            den = np.einsum("ij,ij->i", d1, d1) + np.einsum("ij,ij->i", B - X, d2)
            inside = (t > 0) & (t < 1)
            dt = np.divide(d1, den[:, None], out=np.zeros_like(d1), where=inside[:, None])
            return f, n - self.radius_slope(t)[:, None] * dt, t

    return PolylineBranch


def real_network(mesh, lines=None, smooth=SMOOTH, reverse_root=False):
    """The branches of VMTK's centre-line network of ``mesh`` (step 1 of the module notes for every line).

    Line ``lines[0]`` is the root path (from its far end with ``reverse_root``: an arch rooted at its
    descending aorta, which would otherwise cross the root's plane). Every other line runs with the lines placed before it from the
    source and leaves them where it stays farther than ``DEPART`` of their local radii; it starts at the
    nearest point of the line it leaves (a junction) just before that, and that line is split there. Two
    lines leaving within a radius of each other leave at one junction (a trifurcation).

    Returns
    -------
    pieces : list of (P (k, 3), R (k,), parent)
        Each branch's smoothed points, radii and parent index (-1 for the root), parents first.
    """
    from scipy.spatial import cKDTree

    n_lines = len(load_tree(mesh)[2])
    order = list(range(n_lines)) if lines is None else list(lines)
    placed = []  # (P, R, line index)
    splits = {}  # placed index -> list of (point index, child placed index)
    for k in order:
        P, R = real_centerline(mesh, k, smooth, trim=0.0)
        if not placed:
            placed.append((P[::-1].copy(), R[::-1].copy()) if reverse_root else (P, R))
            continue
        d, near, owner = np.full(len(P), np.inf), np.zeros(len(P), int), np.zeros(len(P), int)
        for j, (Q, RQ) in enumerate(placed):
            dj, ij = cKDTree(Q).query(P)
            better = dj / RQ[ij] < d
            d[better], near[better], owner[better] = (dj / RQ[ij])[better], ij[better], j
        out = d > DEPART
        stays = np.flatnonzero(~out)
        if len(stays) == 0 or stays[-1] == len(P) - 1:
            continue  # never with the others, or never leaves them
        i0 = stays[-1]  # the last point still with the placed lines: the branch starts at its foot there
        j, at = int(owner[i0]), int(near[i0])
        Q = placed[j][0]
        start = Q[at]
        tail = P[i0 + 1:]
        keep = np.linalg.norm(tail - start, axis=1) > 0.5 * placed[j][1][at]
        first = int(np.argmax(keep))
        piece = np.vstack([start, tail[first:]])
        placed.append((piece, np.concatenate([[R[i0]], R[i0 + 1 + first:]])))
        splits.setdefault(j, []).append((at, len(placed) - 1))
    return _split(placed, splits)


def _split(placed, splits):
    """Placed lines cut at their children's junctions into branches (parent before child)."""
    pieces = []  # (P, R, parent)

    def add(j, parent):
        P, R = placed[j]
        cuts = sorted(splits.get(j, []))
        merged = []  # junctions within a radius of each other are one
        for at, child in cuts:
            if merged and np.linalg.norm(P[at] - P[merged[-1][0]]) < R[at]:
                merged[-1][1].append(child)
            else:
                merged.append((at, [child]))
        a, par = 0, parent
        for at, children in merged:
            if at <= a or at >= len(P) - 1:
                raise ValueError(f"line {j}: a junction at its very start or end; choose other lines")
            pieces.append((P[a:at + 1], R[a:at + 1], par))
            par = len(pieces) - 1
            a = at
            for c in children:
                add(c, par)
        pieces.append((P[a:], R[a:], par))

    add(0, -1)
    return pieces


def real_network_tree(mesh, *, lines=None, voxel=None, blend=None, smooth=SMOOTH, reverse_root=False):
    """A synthetic tree whose branches are VMTK's centre-line network of real mesh ``mesh`` (:func:`real_network`),
    meshed as :func:`vesselgp.synthetic.synthetic_arterial_tree` meshes its own (marching cubes of the smooth
    union of the tubes on a narrow band, every vertex projected onto the exact surface).

    The network is moved rigidly so that its root starts at the origin along +z (the root is cut open by the
    plane z = 0); the tips are rounded. ``voxel`` defaults to a third of the thinnest radius, ``blend`` to half
    of it. Returns a :class:`vesselgp.synthetic.SyntheticTree` whose truth is the swept splines.
    """
    from scipy.spatial.transform import Rotation

    from vesselgp import tolerances as tol
    from vesselgp.synthetic_tree import (SyntheticTree, TreeTruth, _band_grid, _band_marching_cubes,
                                         _check_parents, _ends_and_paths, _finish, _project_candidates)

    PolylineBranch = _polyline_branch_class()
    pieces = real_network(mesh, lines, smooth, reverse_root)
    P0 = pieces[0][0]
    head = P0[np.searchsorted(arc_length(P0), pieces[0][1][0])] - P0[0]  # the root's direction over a radius
    rot, _ = Rotation.align_vectors([[0.0, 0.0, 1.0]], [head / np.linalg.norm(head)])
    move = lambda P: (P - P0[0]) @ rot.as_matrix().T  # noqa: E731
    parents = [p for _, _, p in pieces]
    level = []
    for p in parents:
        level.append(0 if p < 0 else level[p] + 1)
    branches = tuple(PolylineBranch.build(move(P), R, p, lv) for (P, R, p), lv in zip(pieces, level))
    _, children = _check_parents(np.array(parents))
    ends, paths = _ends_and_paths(branches, children)
    rmin = min(float(b.radii.min()) for b in branches)
    h = rmin / 3.0 if voxel is None else float(voxel)
    blend = 0.5 * rmin if blend is None else float(blend)
    truth = TreeTruth(branches=branches, ends=ends, paths=paths, blend=blend,
                      root_plane=np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -1.0]]), units="mm")
    band = tol.TREE_BAND_VOXELS * h + blend
    origin, shape = _band_grid(branches, h, band)
    V, F, cand = _band_marching_cubes(truth, origin, h, shape, band)
    V = _project_candidates(truth, V, cand, V[:, 2] == 0.0, h)
    V, F, loop = _finish(V, F, truth)
    return SyntheticTree(V=V, F=F, truth=truth, root_loop=loop, voxel=h, staircase=False, seed=0)


#: The real networks swept as trees: name -> (mesh, options of real_network_tree).
NETWORK_TREES = {
    "renal_iliac": ("gmsh_abdominal-aorta-renal-iliac_open.stl", {"voxel": 0.9}),
    "arch": ("cardiopinns_aortic-arch-4dflow_capped.stl", {"reverse_root": True}),
    "carotid": ("gmsh_carotid-bifurcation_open.stl", {}),
    "aorto_iliac": ("vmtk_abdominal_aorta_iliac_bifurcation_open.stl", {}),
    "xcat": ("xrayangio_xcat-coronary-tree_open.stl", {"voxel": 0.25}),
}


def network_tree(name):
    """:func:`real_network_tree` of :data:`NETWORK_TREES` ``name``."""
    mesh, options = NETWORK_TREES[name]
    return real_network_tree(mesh, **options)
