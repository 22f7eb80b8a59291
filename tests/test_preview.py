"""Preview control of the cart-table model against independent formulations."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from pik_mj.exceptions import InvalidInput, PikError
from pik_mj.walking import (
    GaitParameters,
    PreviewController,
    cart_table_model,
    extended_system,
    plan_gait,
    straight_steps,
)

FEET = {
    "rleg": (np.array([0.0, -0.1, 0.0]), 0.0),
    "lleg": (np.array([0.0, 0.1, 0.0]), 0.0),
}


@pytest.mark.parametrize(
    ("dt", "zc", "q", "r"),
    [(0.01, 0.8, 1.0, 1e-6), (0.005, 0.6, 1.0, 1e-6), (0.02, 0.8, 3.0, 1e-5)],
)
def test_riccati_and_feedback_gain_match_scipy_dare(dt, zc, q, r):
    pc = PreviewController(dt, zc, q=q, r=r)
    A_t, b_t, c_t = pc.A_t, pc.b_t, pc.c_t
    P_ref = scipy.linalg.solve_discrete_are(A_t, b_t, q * c_t.T @ c_t, np.array([[r]]))
    # Relative to the largest entry of P (entries span ~1e-2..1e5).
    scale = np.abs(P_ref).max()
    assert np.abs(pc.gains.P - P_ref).max() / scale < 1e-9
    K_ref = np.linalg.solve(b_t.T @ P_ref @ b_t + r, b_t.T @ P_ref @ A_t)
    assert np.abs(pc.gains.K - K_ref).max() / np.abs(K_ref).max() < 1e-9
    # The closed loop of the extended system is stable.
    assert np.abs(np.linalg.eigvals(A_t - b_t @ K_ref)).max() < 1.0


def test_extended_system_structure_matches_seed():
    A, b, c = cart_table_model(0.01, 0.8, 9.81)
    assert c[0, 2] == pytest.approx(-0.8 / 9.81)
    A_t, b_t, c_t = extended_system(A, b, c)
    # x*_{k+1} = A_t x*_k + b_t du_k reproduces p_{k+1} = c x_{k+1}, dx_{k+1}.
    rng = np.random.default_rng(0)
    x_prev = rng.normal(size=3)
    u_prev, du = rng.normal(), rng.normal()
    x = A @ x_prev + b[:, 0] * u_prev  # x_k from x_{k-1} and u_{k-1}
    x_next = A @ x + b[:, 0] * (u_prev + du)
    xs = np.concatenate([c @ x, x - x_prev])
    xs_next = A_t @ xs + b_t[:, 0] * du
    np.testing.assert_allclose(xs_next[0], (c @ x_next)[0], atol=1e-12)
    np.testing.assert_allclose(xs_next[1:], x_next - x, atol=1e-12)
    np.testing.assert_array_equal(c_t, [[1.0, 0.0, 0.0, 0.0]])


@pytest.mark.parametrize("q", [1.0, 3.0])
def test_preview_gains_against_explicit_sums(q):
    """f_j for j < N, and the tail f_N = sum over j >= N, summed term by term."""
    dt, zc, r = 0.01, 0.8, 1e-6
    pc = PreviewController(dt, zc, q=q, r=r, preview_time=0.5)
    A_t, b_t, c_t = pc.A_t, pc.b_t, pc.c_t
    P = scipy.linalg.solve_discrete_are(A_t, b_t, q * c_t.T @ c_t, np.array([[r]]))
    inv_s = 1.0 / (b_t.T @ P @ b_t + r)[0, 0]
    K = inv_s * b_t.T @ P @ A_t
    A_cl = A_t - b_t @ K
    N = pc.n_preview
    f_ref = np.empty(N)
    for j in range(1, N):
        f_ref[j - 1] = inv_s * (b_t.T @ np.linalg.matrix_power(A_cl.T, j - 1) @ c_t.T)[0, 0] * q
    # Tail: sum_{j >= N} (A_cl^T)^{j-1} c^T Q, summed explicitly (closed-loop
    # spectral radius ~0.966 at dt = 0.01: 3000 terms leave < 1e-40).
    term = np.linalg.matrix_power(A_cl.T, N - 1) @ c_t.T * q
    tail = np.zeros_like(term)
    for _ in range(3000):
        tail += term
        term = A_cl.T @ term
    f_ref[N - 1] = inv_s * (b_t.T @ tail)[0, 0]
    np.testing.assert_allclose(pc.gains.f, f_ref, rtol=1e-8, atol=1e-9 * np.abs(f_ref).max())
    # Steady state: a constant reference is tracked without offset, which needs
    # sum_j f_j = K[0] (the p-component of the feedback).
    assert pc.gains.f.sum() == pytest.approx(pc.gains.K[0, 0], rel=1e-8)


def test_control_law_equals_batch_least_squares_optimum():
    """First input of the preview law = first input of the long-horizon QP."""
    dt, zc, q, r = 0.02, 0.8, 1.0, 1e-6
    pc = PreviewController(dt, zc, q=q, r=r, preview_time=1.6)
    N = pc.n_preview
    A_t, b_t, c_t = pc.A_t, pc.b_t, pc.c_t
    rng = np.random.default_rng(3)
    # A nontrivial current state: run a few ticks on a random reference.
    pc.reset(np.array([0.02]))
    for _ in range(5):
        pc.update(rng.normal(scale=0.05, size=(N, 1)))
    p_future = rng.normal(scale=0.05, size=N)
    x_star = pc.extended_state[:, 0]
    du_law = pc.jerk_increment(p_future)[0]
    # The extended state is consistent with the controller's cart-table state.
    assert x_star[0] == pytest.approx((pc.c @ pc.state)[0, 0], abs=1e-15)
    # Batch problem over H ticks, reference held at p_{k+N} beyond the preview.
    H = N + 800
    p_ref = np.concatenate([p_future, np.full(H - N, p_future[-1])])  # p_{k+1..k+H}
    G = np.zeros((H, H))
    free = np.empty(H)
    Ak = np.eye(4)
    markov = []
    for j in range(H):
        markov.append((c_t @ Ak @ b_t)[0, 0])  # c A^j b
        Ak = A_t @ Ak
        free[j] = (c_t @ Ak @ x_star)[0]  # c A^{j+1} x*
    for j in range(H):
        G[j, : j + 1] = markov[j::-1]
    M = np.vstack([np.sqrt(q) * G, np.sqrt(r) * np.eye(H)])
    rhs = np.concatenate([np.sqrt(q) * (p_ref - free), np.zeros(H)])
    du_batch = np.linalg.lstsq(M, rhs, rcond=None)[0]
    assert du_law == pytest.approx(du_batch[0], rel=1e-6, abs=1e-9)
    assert abs(du_batch[0]) > 1e-3  # the comparison is not between zeros


def test_cart_table_zmp_tracks_four_step_gait_and_com_settles():
    """ZMP tracking error of a real 4-step gait (0.15 m strides, 0.2 m feet apart).

    Bound: the reference is piecewise linear with 0.2 s ramps; a jerk-input
    cart-table cannot follow its kinks exactly, and with R/Q = 1e-6 the error is
    expected at the mm level (measured: RMS 0.4 mm in x, 1.0 mm in y; max 2.7 mm
    in x, 6.1 mm in y, at the lateral transfers). Asserting RMS < 2 mm and
    max < 1 cm leaves margin yet fails for a wrong gain or a one-tick shift.
    """
    params = GaitParameters(step_time=1.0, dt=0.01, double_support_ratio=0.2)
    steps = straight_steps(4, 0.15, FEET)
    plan = plan_gait(FEET, steps, params, com_height=0.8)
    err = plan.zmp - plan.zmp_ref
    rms = np.sqrt(np.mean(err**2, axis=0))
    peak = np.abs(err).max(axis=0)
    assert np.all(rms < 2e-3), rms
    assert np.all(peak < 1e-2), peak
    # Lateral CoM sway must be real (tracking a constant would be trivial).
    assert np.ptp(plan.com[:, 1]) > 0.02
    # CoM ends at rest over the final mid-feet point (slowest closed-loop mode
    # 0.966/tick -> 0.29 s time constant; ~0.9 s of standing after the last
    # transfer leaves ~mm).
    np.testing.assert_allclose(plan.com[-1], plan.final_midpoint[:2], atol=3e-3)
    assert np.abs(plan.com_vel[-1]).max() < 1e-2


def test_cart_table_outputs_are_consistent_with_dynamics():
    pc = PreviewController(0.01, 0.8)
    ref = np.concatenate([np.zeros(50), np.full(100, 0.1), np.full(150, -0.05)])
    res = pc.run(ref)
    dt = 0.01
    # zmp = x - zc/g xdd; acceleration = second difference of position.
    np.testing.assert_allclose(res.zmp, res.com - 0.8 / 9.81 * res.com_acc, atol=1e-14)
    acc_fd = (res.com[2:] - 2 * res.com[1:-1] + res.com[:-2]) / dt**2
    jerk_bound = np.abs(np.diff(res.com_acc)).max() / dt
    np.testing.assert_allclose(acc_fd, res.com_acc[1:-1], atol=jerk_bound * dt)
    # Two axes at once equal two single-axis runs.
    res2 = pc.run(np.stack([ref, -2 * ref], axis=1))
    np.testing.assert_allclose(res2.com[:, 0], res.com, atol=1e-15)
    np.testing.assert_allclose(res2.com[:, 1], -2 * res.com, atol=1e-14)
    # The CoM starts moving before the reference steps (preview).
    assert abs(res.com[45]) > 1e-4


def test_bad_input_raises():
    with pytest.raises(InvalidInput, match="dt"):
        PreviewController(0.0, 0.8)
    with pytest.raises(InvalidInput, match="com_height"):
        PreviewController(0.01, -1.0)
    with pytest.raises(InvalidInput, match="preview_time"):
        PreviewController(0.01, 0.8, preview_time=0.001)
    pc = PreviewController(0.01, 0.8, preview_time=0.1)
    with pytest.raises(InvalidInput, match="NaN"):
        pc.run(np.array([0.0, np.nan]))
    with pytest.raises(PikError, match="reset"):
        PreviewController(0.01, 0.8).update(np.zeros(160))
    pc.reset(0.0)
    with pytest.raises(InvalidInput, match="shape"):
        pc.update(np.zeros(3))
