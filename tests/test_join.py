"""Minimum-torsion joining (vesselgp.join) on the paper's two cases (Section 3, Figs. 2-4)."""
import igl
import numpy as np
import pytest

from vesselgp import (EndsError, Frame, FrameError, JoinProblem, JoinResult, OptimizationError,
                      minimize_torsion, stitch)
from vesselgp.synthetic import paper_case

PRE_ROTATIONS = [-120, -45, 30, 90, 170]


def wrap_deg(a):
    return (a + 180.0) % 360.0 - 180.0


def frame_of(case):
    return Frame(case.target_origin, case.target_tangent, case.target_normal)


@pytest.fixture(scope="module")
def case1():
    c = paper_case(1, resolution=0.5)  # 24 points per ring, ~2k vertices
    p = JoinProblem(c.V, c.F, c.fixed, c.moving, frame_of(c))
    return c, p, minimize_torsion(p)


@pytest.fixture(scope="module")
def case2():
    c = paper_case(2, resolution=0.375)  # 24 points per ring, ~2k vertices
    p = JoinProblem(c.V, c.F, c.fixed, c.moving, frame_of(c))
    return c, p, minimize_torsion(p)


# ----------------------------------------------------------------------------- Frame


def test_frame_is_validated_and_normalised():
    f = Frame([1, 2, 3], [0, 0, 5], [2, 0, 7])
    assert np.allclose(f.tangent, [0, 0, 1]) and np.allclose(f.normal, [1, 0, 0])
    with pytest.raises(FrameError, match="zero"):
        Frame([0, 0, 0], [0, 0, 0], [1, 0, 0])
    with pytest.raises(FrameError, match="parallel"):
        Frame([0, 0, 0], [0, 0, 1], [0, 0, -2])
    with pytest.raises(FrameError):
        Frame([0, 0, np.nan], [0, 0, 1], [1, 0, 0])
    with pytest.raises(ValueError, match="read-only"):
        f.origin[0] = 5.0  # frozen, read-only arrays


# ----------------------------------------------------------------------------- case 1


def test_case1_optimum_has_no_twist(case1):
    c, p, res = case1
    assert isinstance(res, JoinResult) and res.status > 0
    assert res.n_evals == len(res.angles) == len(res.energies) <= 15
    assert abs(np.degrees(res.profile.total_twist)) < 0.5
    assert res.energy == min(res.energies)
    assert np.allclose(res.V, p.deform(res.angle))


@pytest.mark.parametrize("pre", PRE_ROTATIONS)
def test_case1_search_cancels_the_pre_rotation(case1, pre):
    c, p, base = case1
    cp = paper_case(1, resolution=0.5, pre_rotation=np.radians(pre))
    assert np.allclose(cp.V, c.V)
    q = p.retarget(frame_of(cp))  # same vessel, same fit and factorisations
    res = minimize_torsion(q)
    err = wrap_deg(np.degrees(res.angle) - (np.degrees(base.angle) - pre))
    assert abs(err) < 0.5, err
    e_start = q.energy(0.0)
    assert res.energy <= 0.01 * e_start, (res.energy, e_start)
    assert res.n_evals <= 15 and res.status > 0


def test_case1_energy_curve_is_quadratic(case1):
    """Paper Fig. 4(a): energy against the end rotation is a parabola about the optimum."""
    c, p, res = case1
    a = res.angle + np.radians(np.linspace(-90, 90, 13))
    E = p.energy_curve(a)
    coef = np.polyfit(a, E, 2)
    r2 = 1 - np.sum((np.polyval(coef, a) - E) ** 2) / np.sum((E - E.mean()) ** 2)
    assert r2 >= 0.99, r2
    assert coef[0] > 0 and abs(-coef[1] / (2 * coef[0]) - res.angle) < np.radians(0.5)


# ----------------------------------------------------------------------------- case 2


def test_case2_optimum(case2):
    """Paper Fig. 3(e): aorta to root; total twist ~ 0 and the best on a 5-degree grid."""
    c, p, res = case2
    assert abs(np.degrees(res.profile.total_twist)) < 1.0
    grid = res.angle + np.radians(np.arange(-180, 180, 5.0))
    E = p.energy_curve(grid)
    assert res.energy <= E.min() + 1e-12, (res.energy, E.min())
    sel = np.abs(grid - res.angle) <= np.radians(90)
    coef = np.polyfit(grid[sel], E[sel], 2)
    r2 = 1 - np.sum((np.polyval(coef, grid[sel]) - E[sel]) ** 2) / np.sum((E[sel] - E[sel].mean()) ** 2)
    assert r2 >= 0.99, r2  # Fig. 4(b)


def test_case2_handles_and_orientation(case2):
    c, p, res = case2
    X = res.V
    L = p.gc.length
    assert np.abs(X[c.fixed] - c.V[c.fixed]).max() <= 1e-12
    d = p.deformer
    # the moving end moved rigidly (Kabsch rotation of the ring, residual ~0) and its GC centre
    # (the fit's axis end) lands on the target origin
    ring, ring0 = X[c.moving], c.V[c.moving]
    A, B = ring0 - ring0.mean(0), ring - ring.mean(0)
    u_, _, vt_ = np.linalg.svd(A.T @ B)
    Q = (u_ @ np.diag([1, 1, np.linalg.det(u_ @ vt_)]) @ vt_).T
    assert np.abs(A @ Q.T - B).max() <= 1e-9 * L
    ends_c = p.gc.at([0.0, 1.0])[0]
    end_center = ends_c[np.argmin(np.linalg.norm(ends_c - ring0.mean(0), axis=1))]
    centre = ring.mean(0) - Q @ (ring0.mean(0) - end_center)
    assert np.linalg.norm(centre - c.target_origin) <= 1e-6 * L
    # the moving loop's plane is normal to the target tangent
    _, _, vt = np.linalg.svd(ring - ring.mean(0))
    assert abs(abs(vt[2] @ c.target_tangent) - 1) < 1e-3
    # and the axis leaves it along +tangent (out of the aorta, into the root)
    s, P, Fr = d.axis(p.target)
    assert np.allclose(-Fr[0, 0], c.target_tangent, atol=1e-9) and np.allclose(P[0], c.target_origin)
    # no face flips against the outward direction from the measured deformed axis
    F = c.F
    sf = p.gc.vertex_s[F].mean(axis=1)
    cen = np.stack([np.interp(sf, res.profile.s, res.profile.centers[:, k]) for k in range(3)], 1)
    a, b, cc = X[F[:, 0]], X[F[:, 1]], X[F[:, 2]]
    n = np.cross(b - a, cc - a)
    r = (a + b + cc) / 3 - cen
    assert np.all(np.sum(n * r, axis=1) > 0)


# ----------------------------------------------------------------------------- search robustness and errors


def test_nonfinite_energy_raises(case1, monkeypatch):
    c, p, _ = case1
    q = p.retarget(frame_of(c))
    monkeypatch.setattr(q, "energy", lambda a: float("nan"))
    with pytest.raises(OptimizationError, match="not finite"):
        minimize_torsion(q)
    with pytest.raises(OptimizationError, match="algorithm"):
        minimize_torsion(p, algorithm="LD_MMA")


def test_join_problem_validation(case1):
    c, p, _ = case1
    with pytest.raises(EndsError, match="overlap"):
        JoinProblem(c.V, c.F, c.fixed, np.r_[c.moving, c.fixed[:1]], frame_of(c), gc=p.gc)
    with pytest.raises(FrameError):
        JoinProblem(c.V, c.F, c.fixed, c.moving, (c.target_origin, c.target_tangent, c.target_normal), gc=p.gc)


# ----------------------------------------------------------------------------- stitching


def test_stitch_gives_one_consistent_manifold_mesh(case1):
    c, p, res = case1
    Vj, Fj = stitch(res.V, c.F, c.moving, c.other_V, c.other_F, c.other_end)
    assert len(Vj) == len(c.V) + len(c.other_V)
    assert len(Fj) == len(c.F) + len(c.other_F) + len(c.moving) + len(c.other_end)
    assert len(igl.boundary_loop_all(Fj)) == 2  # the two far ends stay open
    assert igl.is_edge_manifold(Fj)
    # consistent orientation: every directed edge occurs once
    E = np.concatenate([Fj[:, [0, 1]], Fj[:, [1, 2]], Fj[:, [2, 0]]])
    assert len(np.unique(E, axis=0)) == len(E)
    # the bridge is short: its edges span the gap between the moved end and the other end
    S = Fj[-(len(c.moving) + len(c.other_end)):]
    el = np.linalg.norm(Vj[S] - Vj[np.roll(S, 1, axis=1)], axis=2)
    assert el.max() < 2 * p.gc.mean_radius
    with pytest.raises(EndsError):
        stitch(res.V, c.F, c.moving[:-1], c.other_V, c.other_F, c.other_end)
