"""Rotation-minimizing frames and Frenet quantities against analytic curves."""
import numpy as np
import pytest

from vesselgp import FrameError, frenet, rotation_minimizing_frames
from vesselgp.curves import transport_angle

C = 0.5  # helix (cos t, sin t, C t)


def helix(K):
    t = np.linspace(0, 4 * np.pi, K)
    P = np.c_[np.cos(t), np.sin(t), C * t]
    d1 = np.c_[-np.sin(t), np.cos(t), np.full_like(t, C)]
    T = d1 / np.linalg.norm(d1, axis=1)[:, None]
    N = np.c_[-np.cos(t), -np.sin(t), 0 * t]
    B = np.cross(T, N)
    # exact RMF: the Frenet normal turned by -integral of tau ds, tau = C / (1 + C^2)
    ang = -C / (1 + C * C) * np.sqrt(1 + C * C) * t
    U = np.cos(ang)[:, None] * N + np.sin(ang)[:, None] * B
    return P, T, U


def rmf_error_deg(K, exact_tangents, method="double_reflection"):
    P, T, Uex = helix(K)
    Tc, U, _ = rotation_minimizing_frames(
        P, T if exact_tangents else None, initial_normal=Uex[0] + 0.3 * T[0], method=method
    )
    a = transport_angle(Tc, Uex, U)
    a = np.angle(np.exp(1j * (a - a[0])))  # remove the constant initial offset
    return np.degrees(np.abs(a).max())


def test_double_reflection_helix_exact_tangents_fourth_order():
    e50, e100 = rmf_error_deg(50, True), rmf_error_deg(100, True)
    assert e100 <= 1e-4
    assert np.log2(e50 / e100) >= 3.5


def test_double_reflection_helix_from_points():
    assert rmf_error_deg(100, False) <= 1e-3


@pytest.mark.parametrize("method", ["rotation", "projection"])
def test_lower_order_methods_are_less_accurate_and_converge(method):
    e50, e100 = rmf_error_deg(50, True, method), rmf_error_deg(100, True, method)
    assert e100 > 100 * rmf_error_deg(100, True)  # what double reflection buys
    assert e100 < e50  # they still converge (order 1-2)


def test_frames_orthonormal_and_right_handed():
    P, _, _ = helix(80)
    T, U, V = rotation_minimizing_frames(P)
    for A, B in [(T, U), (T, V), (U, V)]:
        assert np.abs(np.sum(A * B, axis=1)).max() < 1e-12
    for A in (T, U, V):
        assert np.abs(np.linalg.norm(A, axis=1) - 1).max() < 1e-12
    assert np.allclose(np.cross(T, U), V, atol=1e-12)


def test_planar_s_curve_keeps_plane_normal_where_frenet_flips():
    t = np.linspace(-np.pi, np.pi, 120)
    P = np.c_[t, np.sin(t), 0 * t]  # inflection at t = 0
    T, U, V = rotation_minimizing_frames(P, initial_normal=[0, 0, 1])
    assert np.abs(U - [0, 0, 1]).max() <= 1e-9
    fr = frenet(P, length_scale=1.0)
    n_left = fr.normal[np.argmin(np.abs(t + 1.5))]
    n_right = fr.normal[np.argmin(np.abs(t - 1.5))]
    assert n_left @ n_right < -0.5  # the Frenet normal flips across the inflection
    assert not fr.defined[np.argmin(np.abs(t))] or abs(fr.curvature[np.argmin(np.abs(t))]) < 1e-2


def test_rmf_is_rotation_covariant():
    P, _, _ = helix(60)
    th = 0.7
    R = np.array([[np.cos(th), -np.sin(th), 0], [np.sin(th), np.cos(th), 0], [0, 0, 1]]) @ np.array(
        [[1, 0, 0], [0, np.cos(1.1), -np.sin(1.1)], [0, np.sin(1.1), np.cos(1.1)]]
    )
    n0 = np.array([1.0, 0.2, 0.0])
    T, U, V = rotation_minimizing_frames(P, initial_normal=n0)
    T2, U2, V2 = rotation_minimizing_frames(P @ R.T + 5.0, initial_normal=R @ n0)
    assert np.allclose(U @ R.T, U2, atol=1e-12)


def test_frenet_straight_segment_is_undefined_not_zero():
    s = np.linspace(0, 10, 60)
    P = np.c_[s, 0 * s, 0 * s]
    fr = frenet(P, length_scale=1.0)
    assert not fr.defined.any()
    assert np.isnan(fr.torsion).all() and np.isnan(fr.normal).all()
    assert np.allclose(fr.curvature, 0, atol=1e-12)


def test_frenet_helix_values():
    t = np.linspace(0, 4 * np.pi, 300)
    fr = frenet(np.c_[2 * np.cos(t), 2 * np.sin(t), t])
    # a = 2, b = 1: kappa = a / (a^2 + b^2) = 0.4, tau = b / (a^2 + b^2) = 0.2
    assert np.allclose(fr.curvature[3:-3], 0.4, atol=1e-5)
    assert np.allclose(fr.torsion[3:-3], 0.2, atol=1e-5)


def test_bad_inputs_raise_frame_errors():
    P, T, _ = helix(20)
    with pytest.raises(FrameError, match="parallel"):
        rotation_minimizing_frames(P, T, initial_normal=2 * T[0])
    with pytest.raises(FrameError, match="unknown RMF method"):
        rotation_minimizing_frames(P, method="bishop")
    with pytest.raises(FrameError, match="repeated"):
        rotation_minimizing_frames(np.vstack([P[:3], P[2:]]))
    with pytest.raises(ValueError):
        rotation_minimizing_frames(np.full((5, 3), np.nan))
