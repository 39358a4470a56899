"""Taubin smoothing in clean_mesh (issue #13): a voxel staircase tube becomes a smooth tube.

The staircase is what a segmentation gives: the boolean occupancy of a tube on
a voxel grid, turned into a surface either by marching cubes of the binary
volume (scikit-image; an axis tilted against the grid) or, without
scikit-image, by the exposed voxel faces (numpy; an axis along z, where the
faces are a manifold). The tube is open at the two ends of the grid, so its
volume is the flux of (x, y, 0) / 2 through the wall (the end planes z = const
add nothing).
"""
from __future__ import annotations

import numpy as np
import pytest

from vesselgp import tolerances as tol
from vesselgp.errors import OptionError
from vesselgp.mesh import CleanReport, clean_mesh

RADIUS, LENGTH, VOXEL = 3.0, 40.0, 0.5  # mm: a vessel 6 voxels in radius
TILTED = np.array([0.35, 0.2, 1.0]) / np.linalg.norm([0.35, 0.2, 1.0])
ALONG_Z = np.array([0.0, 0.0, 1.0])


# --------------------------------------------------------------------------- #
# staircase tubes
# --------------------------------------------------------------------------- #
def tube_occupancy(direction, radius=RADIUS, length=LENGTH, h=VOXEL):
    """Voxels (centres) within ``radius`` of the line through 0 along ``direction``, for 0 < z < length.

    Returns the (nx, ny, nz) bool occupancy and the grid's corner (the low corner of voxel 0).
    """
    d = np.asarray(direction, float)
    top = length * d[:2] / d[2]
    lo = np.minimum(0.0, top) - radius - 2 * h
    hi = np.maximum(0.0, top) + radius + 2 * h
    x, y = (np.arange(lo[i], hi[i], h) + 0.5 * h for i in range(2))
    z = (np.arange(round(length / h)) + 0.5) * h
    P = np.stack(np.meshgrid(x, y, z, indexing="ij"), axis=-1)
    occ = np.einsum("...i,...i", P, P) - (P @ d) ** 2 <= radius ** 2
    return occ, np.array([x[0], y[0], z[0]]) - 0.5 * h


def voxel_faces(occ, corner, h=VOXEL):
    """The faces between occupied and empty voxels (outward), as triangles; none on the grid's z ends."""
    shape = np.array(occ.shape)
    quads = []
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        low = np.take(occ, np.arange(shape[a] - 1), axis=a)
        up = np.take(occ, np.arange(1, shape[a]), axis=a)
        for cells, outward in ((low & ~up, True), (up & ~low, False)):
            idx = np.argwhere(cells)
            idx[:, a] += 1  # the face's lattice plane
            corners = []
            for ob, oc in ((0, 0), (1, 0), (1, 1), (0, 1)):  # counter-clockwise about +e_a
                p = idx.copy()
                p[:, b] += ob
                p[:, c] += oc
                corners.append(np.ravel_multi_index(p.T, shape + 1))
            q = np.stack(corners, axis=1)
            quads.append(q if outward else q[:, ::-1])
    used, Q = np.unique(np.vstack(quads), return_inverse=True)
    Q = Q.reshape(-1, 4)
    V = np.stack(np.unravel_index(used, shape + 1), axis=1) * h + corner
    return V.astype(np.float64), np.vstack([Q[:, [0, 1, 2]], Q[:, [0, 2, 3]]]).astype(np.int64)


def marching_cubes_surface(occ, corner, h=VOXEL):
    """Marching cubes (scikit-image) of the binary volume, padded in x and y, outward."""
    measure = pytest.importorskip("skimage.measure")
    vol = np.pad(occ, ((1, 1), (1, 1), (0, 0))).astype(np.float32)
    V, F, _, _ = measure.marching_cubes(vol, 0.5, spacing=(h, h, h))
    V = V + corner + np.array([-0.5, -0.5, 0.5]) * h  # voxel centres of the padded volume
    return V.astype(np.float64), F[:, [0, 2, 1]].astype(np.int64)


BUILDERS = {"marching_cubes": (marching_cubes_surface, TILTED), "voxel_faces": (voxel_faces, ALONG_Z)}


def staircase(kind):
    build, d = BUILDERS[kind]
    occ, corner = tube_occupancy(d)
    V, F = build(occ, corner)
    return V, F, d


# --------------------------------------------------------------------------- #
# measures
# --------------------------------------------------------------------------- #
def face_normals(V, F):
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    a = np.linalg.norm(n, axis=1)
    return n / a[:, None], 0.5 * a


def axis_aligned_fraction(V, F, deg=5.0):
    """Area fraction of faces whose normal is within ``deg`` of a coordinate axis."""
    n, a = face_normals(V, F)
    aligned = np.abs(n).max(axis=1) > np.cos(np.radians(deg))
    return float(a[aligned].sum() / a.sum())


def tube_volume(V, F):
    """Volume inside an open tube whose ends lie in planes z = const (flux of (x, y, 0) / 2)."""
    n, a = face_normals(V, F)
    c = V[F].mean(axis=1)
    return float(np.sum((c[:, 0] * n[:, 0] + c[:, 1] * n[:, 1]) * a) / 2)


def radius_errors(V, d):
    """(mean distance to the true axis - R) / R and mean |distance - R| / R, over the middle 60 %."""
    s = V @ d * d[2] / LENGTH  # 0 to 1 along the tube
    mid = (s > 0.2) & (s < 0.8)
    P = V[mid]
    r = np.linalg.norm(P - np.outer(P @ d, d), axis=1)
    return float(r.mean() / RADIUS - 1), float(np.abs(r - RADIUS).mean() / RADIUS)


def measure(V, F, d):
    bias, rough = radius_errors(V, d)
    return {"aligned": axis_aligned_fraction(V, F), "volume": tube_volume(V, F), "bias": bias, "rough": rough}


# --------------------------------------------------------------------------- #
# tests
# --------------------------------------------------------------------------- #
SMOOTH = 20


@pytest.fixture(scope="module", params=sorted(BUILDERS))
def smoothed(request):
    V, F, d = staircase(request.param)
    V0, F0, rep0 = clean_mesh(V, F)
    V1, F1, rep1 = clean_mesh(V, F, smooth=SMOOTH)
    return request.param, d, (V0, F0, rep0), (V1, F1, rep1)


def test_staircase_is_a_clean_open_tube(smoothed):
    _, d, (V0, F0, rep0), _ = smoothed
    assert not rep0.changed, rep0.summary()  # a plain surface: cleaning has nothing to repair
    height = np.ptp(V0[:, 2])  # the tube's ends lie in the planes z = min, max
    assert tube_volume(V0, F0) == pytest.approx(np.pi * RADIUS ** 2 * height / d[2], rel=0.02)


def test_taubin_smoothing_removes_the_staircase(smoothed):
    _, d, (V0, F0, _), (V1, F1, rep) = smoothed
    before, after = measure(V0, F0, d), measure(V1, F1, d)
    # the staircase: a large share of the wall faces the grid's axes; smoothed, almost none
    assert before["aligned"] > 0.35
    assert after["aligned"] < 0.05 and after["aligned"] < before["aligned"] / 8
    # every vertex nearer the true radius (mean |r - R| halved), the mean radius within 0.5 %
    assert after["rough"] < 0.5 * before["rough"]
    assert abs(after["bias"]) < 0.005
    # Taubin's lambda/mu steps keep the volume (plain Laplacian smoothing would shrink the tube)
    assert after["volume"] == pytest.approx(before["volume"], rel=0.005)
    assert rep.smoothing_iterations == SMOOTH and rep.changed
    assert f"{SMOOTH} iterations of Taubin smoothing" in rep.summary()


def test_smoothing_moves_vertices_only(smoothed):
    _, _, (V0, F0, rep0), (V1, F1, rep1) = smoothed
    np.testing.assert_array_equal(F1, F0)
    np.testing.assert_array_equal(rep1.vertex_map, rep0.vertex_map)
    assert V1.shape == V0.shape and V1.dtype == np.float64
    assert np.abs(V1 - V0).max() < VOXEL  # less than a voxel
    assert rep1.vertices_after == rep0.vertices_after and rep1.faces_after == rep0.faces_after


def test_smooth_zero_leaves_the_vertices_unchanged():
    V, F, _ = staircase("voxel_faces")
    V0, F0, rep0 = clean_mesh(V, F)
    V1, F1, rep1 = clean_mesh(V, F, smooth=0)
    np.testing.assert_array_equal(V1, V0)
    np.testing.assert_array_equal(V1, V[rep1.vertex_map])  # still a subset of the input positions
    np.testing.assert_array_equal(F1, F0)
    assert rep1.smoothing_iterations == 0 and rep1 == rep0
    assert "Taubin" not in rep1.summary()
    V2, _, rep2 = clean_mesh(V, F, smooth=np.int64(1))  # numpy integers are fine
    assert rep2.smoothing_iterations == 1 and not np.array_equal(V2, V0)


def test_smoothing_runs_after_the_repairs():
    V, F, _ = staircase("voxel_faces")
    n = len(V)
    dup = np.intersect1d(F[::2], F[1::2])[:10]  # used by faces of even and of odd index
    V = np.vstack([V, V[dup]])  # ten duplicate vertices: the faces of even index use the copies
    lut = np.arange(n)
    lut[dup] = n + np.arange(10)
    F = F.copy()
    F[::2] = lut[F[::2]]
    V1, _, rep = clean_mesh(V, F, smooth=5)
    assert rep.duplicate_vertices_merged == 10 and rep.smoothing_iterations == 5
    assert len(V1) == n
    assert "merged 10 duplicate vertices" in rep.summary() and "5 iterations of Taubin" in rep.summary()


def test_smoothing_reads_the_taubin_constants_at_call_time(monkeypatch):
    V, F, _ = staircase("voxel_faces")
    Va, _, _ = clean_mesh(V, F, smooth=3)
    monkeypatch.setattr(tol, "TAUBIN_LAMBDA", 0.3)
    monkeypatch.setattr(tol, "TAUBIN_MU", -0.31)
    Vb, _, _ = clean_mesh(V, F, smooth=3)
    assert not np.allclose(Va, Vb)


@pytest.mark.parametrize("bad", [-1, 1.5, "3", True, None, 2.0])
def test_bad_smooth_is_an_option_error(bad):
    V, F, _ = staircase("voxel_faces")
    with pytest.raises(OptionError, match="smooth must be a non-negative integer"):
        clean_mesh(V, F, smooth=bad)


def test_report_summary_with_smoothing_only():
    rep = CleanReport(4, 2, 4, 2, smoothing_iterations=7)
    assert rep.changed
    assert rep.summary() == "clean_mesh: 4->4 vertices, 2->2 faces: 7 iterations of Taubin smoothing"
    assert CleanReport(4, 2, 4, 2).smoothing_iterations == 0
