"""Outer image loop (Section 6.3): collapse of Eq. (53)-(61), SV policy, runtime."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest

from ibvs_youla import OuterLoopDesign, SingularValuePolicy
from ibvs_youla.control.discrete import DiscreteFilter
from ibvs_youla.control.inner import InnerLoopDesign
from ibvs_youla.control.literal import literal_matrices, literal_mimo, literal_response
from ibvs_youla.exceptions import InvalidArrayError, InvalidParameterError, SingularConfigurationError

OMEGAS = np.array([1e-3, 0.1, 0.5, 1.0, 10.0, 33.0, 100.0, 200.0, 1e3, 1e4])
EXACT = SingularValuePolicy("truncate", 0.0)  # plain Eq. (57): 1/sigma_i on every non-zero sigma


def _random_J(seed: int, realistic: bool) -> np.ndarray:
    rng = np.random.default_rng(seed)
    J = rng.standard_normal((9, 6))
    if realistic:  # columns of 1e-3..1e-2 image metres per radian, as a stereo camera gives
        J *= 10.0 ** rng.uniform(-3.0, -2.0, size=6)
    return J


def _rank5_J(seed: int = 7) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    U, _ = np.linalg.qr(rng.standard_normal((9, 9)))
    V, _ = np.linalg.qr(rng.standard_normal((6, 6)))
    s = np.array([2e-2, 1e-2, 8e-3, 5e-3, 2e-3, 0.0])  # sigma_6 = 0 as at q = 0 (ERRATA 7)
    return U[:, :6] @ np.diag(s) @ V.T, U, V


def _per_frequency_rel(a: np.ndarray, b: np.ndarray) -> float:
    scale = np.abs(b).max(axis=(1, 2))
    return float((np.abs(a - b).max(axis=(1, 2)) / scale).max())


# ---------------------------------------------------------------- SISO design facts
def test_filter_is_collapsed_eq_57_61():
    d = OuterLoopDesign()
    m_T, T_in = d.target_tf(), d.inner_tf()
    w = np.logspace(-3, 4, 50)
    expected = (m_T(1j * w) / (1.0 - m_T(1j * w))) / T_in(1j * w)
    np.testing.assert_allclose(d.filter_tf()(1j * w), expected, rtol=1e-10)
    K = d.filter_tf()
    np.testing.assert_allclose(np.sort(K.poles().real), [-200.0, -100.0 / 3.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(K.zeros(), -100.0, rtol=1e-4)  # triple zero at -1/tau_in


def test_ibvs_gain_is_low_frequency_integrator():
    d = OuterLoopDesign()
    assert d.ibvs_gain == 0.5
    s = 1e-7j
    assert complex(s * d.filter_tf()(s)) == pytest.approx(0.5, rel=1e-6)


def test_target_poles_and_settling_errata_10():
    d = OuterLoopDesign()
    np.testing.assert_allclose(d.target_poles(), [-0.501256, -199.498744], atol=1e-6)
    p1, p2 = -d.target_poles().real
    # overdamped: 1 - y(t) ~ p2/(p2 - p1) exp(-p1 t) once the fast mode has died
    assert d.settling_time(0.02) == pytest.approx(np.log(50.0 * p2 / (p2 - p1)) / p1, abs=1e-6)
    assert d.settling_time(0.02) == pytest.approx(7.8095, abs=1e-4)  # not "< 3 s"
    assert OuterLoopDesign(zeta=1.0).settling_time(0.02) == pytest.approx(0.58339, abs=1e-5)


# ---------------------------------------------------------------- literal vs closed form
@pytest.mark.parametrize("realistic", [False, True])
@pytest.mark.parametrize("policy", [EXACT, SingularValuePolicy(), SingularValuePolicy("truncate", 1e-2)])
def test_literal_response_equals_closed_form(realistic, policy):
    d = OuterLoopDesign(sv_policy=policy)
    for seed in range(3):
        J = _random_J(seed, realistic)
        closed = d.closed_form_response(J, OMEGAS)
        assert closed.shape == (OMEGAS.size, 6, 9)
        assert _per_frequency_rel(literal_response(d, J, OMEGAS), closed) < 1e-9


def test_closed_form_is_pinv_times_K_without_policy():
    J = _random_J(1, True)
    d = OuterLoopDesign(sv_policy=EXACT)
    closed = d.closed_form_response(J, OMEGAS)
    expected = d.filter_tf()(1j * OMEGAS)[:, None, None] * np.linalg.pinv(J)[None]
    assert _per_frequency_rel(closed, expected) < 1e-12


def test_literal_intermediates_and_printed_order():
    J = _random_J(2, True)
    d = OuterLoopDesign(sv_policy=EXACT)
    U = np.linalg.svd(J)[0]
    lit = literal_matrices(d, J, OMEGAS)
    m_T = d.target_tf()(1j * OMEGAS)
    expected_Ty = m_T[:, None, None] * (U[:, :6] @ U[:, :6].T)[None]  # U M_T U^T
    np.testing.assert_allclose(lit.T_y, expected_Ty, rtol=0, atol=1e-12)
    np.testing.assert_allclose(lit.S_y, np.eye(9)[None] - expected_Ty, rtol=0, atol=1e-12)
    # the printed order U_R M_Y U_L = V^T M_Y U does not achieve the target
    printed = literal_matrices(d, J, OMEGAS, printed_order=True)
    assert np.abs(printed.T_y - expected_Ty).max() > 0.1


def test_literal_mimo_matches_closed_form():
    J = _random_J(4, True)
    d = OuterLoopDesign()
    lit = literal_mimo(d, J)
    w = np.array([0.01, 0.5, 10.0, 300.0])
    closed = d.closed_form_response(J, w)
    assert lit.controller_ss.nstates == 18  # 6 channels x 3 states of K after minimal realization
    assert (lit.controller.noutputs, lit.controller.ninputs) == (6, 9)
    assert (lit.youla.noutputs, lit.youla.ninputs) == (6, 9)
    for sys in (lit.controller, lit.controller_ss):
        resp = np.moveaxis(sys(1j * w), -1, 0)
        assert _per_frequency_rel(resp, closed) < 1e-8
    P = d.sv_policy.pseudo_inverse(J)
    q = (d.target_tf() / d.inner_tf())(1j * w)
    youla = np.moveaxis(lit.youla(1j * w), -1, 0)
    assert _per_frequency_rel(youla, q[:, None, None] * P[None]) < 1e-8
    T_y = np.moveaxis(lit.complementary_sensitivity(1j * w), -1, 0)
    S_y = np.moveaxis(lit.sensitivity(1j * w), -1, 0)
    np.testing.assert_allclose(S_y + T_y, np.broadcast_to(np.eye(9), S_y.shape), rtol=0, atol=1e-12)


# ---------------------------------------------------------------- singular value policy
def test_policy_gains():
    s = np.array([1.0, 0.1, 1e-3, 1e-5, 0.0])
    damped = SingularValuePolicy("damped", 1e-3).gains(s)
    expected = [1.0 / (1.0 + 1e-6), 0.1 / (0.01 + 1e-6), 500.0, 1e-5 / (1e-10 + 1e-6), 0.0]
    np.testing.assert_allclose(damped, expected, rtol=1e-14)
    trunc = SingularValuePolicy("truncate", 1e-3).gains(s)
    np.testing.assert_array_equal(trunc, [1.0, 10.0, 0.0, 0.0, 0.0])  # sigma = threshold is dropped
    with pytest.raises(SingularConfigurationError):
        SingularValuePolicy().gains(np.zeros(6))


def test_default_policy_is_pinv_on_well_conditioned_J():
    J = _random_J(5, True)
    s = np.linalg.svd(J, compute_uv=False)
    rel = np.linalg.norm(SingularValuePolicy().pseudo_inverse(J) - np.linalg.pinv(J), 2) * s[-1]
    assert rel < 1.01 * (1e-3 * s[0] / s[-1]) ** 2  # damping error (lambda/sigma_min)^2


@pytest.mark.parametrize("policy", [SingularValuePolicy(), SingularValuePolicy("truncate", 1e-3)])
def test_rank_deficient_J_gets_bounded_gain(policy):
    J, U, V = _rank5_J()
    assert np.linalg.svd(J, compute_uv=False)[-1] < 1e-17  # rank 5
    dec = policy.decompose(J)
    assert np.all(np.isfinite(dec.pinv))
    # damped: g <= 1/(2 lambda) = 1/(2e-3 * 2e-2); truncate: largest kept 1/sigma = 1/sigma_5
    bound = 1.0 / (2.0 * policy.threshold * dec.sigma[0]) if policy.kind == "damped" else 1.0 / 2e-3
    assert np.linalg.norm(dec.pinv, 2) <= bound * (1.0 + 1e-12)
    # the unreachable image direction u_6 and the joint null direction v_6 get zero gain
    assert np.abs(dec.pinv @ U[:, 5]).max() < 1e-12 * np.abs(dec.pinv).max()
    assert np.abs(V[:, 5] @ dec.pinv).max() < 1e-12 * np.abs(dec.pinv).max()
    d = OuterLoopDesign(sv_policy=policy)
    closed = d.closed_form_response(J, OMEGAS)
    assert np.all(np.isfinite(closed))
    assert _per_frequency_rel(literal_response(d, J, OMEGAS), closed) < 1e-9
    lit = literal_mimo(d, J)
    assert lit.controller_ss.nstates == 15  # five controlled channels
    assert _per_frequency_rel(np.moveaxis(lit.controller_ss(1j * OMEGAS[:4]), -1, 0), closed[:4]) < 1e-8


def test_truncation_drops_small_direction():
    J, U, _ = _rank5_J()
    J = J + 1e-6 * np.outer(U[:, 5], np.ones(6))  # sigma_6 ~ 2.4e-6 < 1e-3 * sigma_max
    P = SingularValuePolicy("truncate", 1e-3).pseudo_inverse(J)
    u6 = np.linalg.svd(J)[0][:, 5]
    assert np.abs(P @ u6).max() < 1e-12 * np.abs(P).max()
    P_damped = SingularValuePolicy("damped", 1e-3).pseudo_inverse(J)
    assert 0.0 < np.linalg.norm(P_damped @ u6) < 1.0 / (2e-3 * 2e-2)


# ---------------------------------------------------------------- runtime in closed loop
def _closed_loop(d, J, p_star, t_end, dt_cam=0.01, dt=1e-3, adaptive=False):
    """Static plant p = J q behind the ideal inner loop T_in (ZOH at the joint rate)."""
    ctrl = d.runtime(dt_cam) if adaptive else d.runtime(dt_cam, J=J)
    inner = InnerLoopDesign(d.tau_in).discrete_closed_loop(dt)
    inner.reset_steady_state(np.zeros(6))
    q = np.zeros(6)
    errors = []
    for _ in range(round(t_end / dt_cam)):
        e = p_star - J @ q
        errors.append(e)
        q_fb = ctrl.update(e, J) if adaptive else ctrl.update(e)
        for _ in range(round(dt_cam / dt)):
            q = inner.step(q_fb)
    return np.array(errors), q


@pytest.mark.parametrize("dt_cam", [1e-3, 0.01])
def test_runtime_drives_reachable_error_to_zero(dt_cam):
    d = OuterLoopDesign()
    J = _random_J(3, True)
    q_star = np.random.default_rng(30).normal(0.0, 0.2, 6)
    errors, q = _closed_loop(d, J, J @ q_star, 30.0, dt_cam=dt_cam)
    norm = np.linalg.norm(errors, axis=1) / np.linalg.norm(errors[0])
    t = np.arange(norm.size) * dt_cam
    # the image error follows 1 - m_T: 2 % after 7.81 s (ERRATA 10); sampling shifts it < 0.05 s
    assert t[np.nonzero(norm > 0.02)[0][-1] + 1] == pytest.approx(d.settling_time(), abs=0.05)
    assert norm[-1] < 5e-7  # exp(-0.501 * 30) = 3e-7
    np.testing.assert_allclose(q, q_star, rtol=0, atol=1e-6)


def test_runtime_leaves_unreachable_component_untouched():
    d = OuterLoopDesign(omega_n=10.0, zeta=1.0)  # faster, same structure
    J = _random_J(6, True)
    U = np.linalg.svd(J)[0]
    n_perp = U[:, 6:] @ np.array([1e-3, -2e-3, 5e-4])  # orthogonal to range(J)
    p_star = J @ np.full(6, 0.1) + n_perp
    errors, _ = _closed_loop(d, J, p_star, 5.0, adaptive=True)
    # the component of e outside range(J) never moves; the rest goes to zero
    np.testing.assert_allclose(errors @ U[:, 6:], np.tile(U[:, 6:].T @ n_perp, (len(errors), 1)), atol=1e-15)
    np.testing.assert_allclose(errors[-1], n_perp, rtol=0, atol=1e-9 * np.linalg.norm(p_star))


def test_fixed_and_adaptive_modes_agree_for_constant_J():
    d = OuterLoopDesign()
    J = _random_J(8, True)
    fixed, adaptive = d.runtime(0.01, J=J), d.runtime(0.01)
    rng = np.random.default_rng(80)
    for _ in range(20):
        e = rng.normal(0.0, 1e-3, 9)
        np.testing.assert_allclose(fixed.update(e), adaptive.update(e, J), rtol=1e-13, atol=1e-16)
    np.testing.assert_allclose(adaptive.last_decomposition.pinv, d.sv_policy.pseudo_inverse(J))


def test_relinearizing_does_not_make_q_fb_jump():
    d = OuterLoopDesign()
    J = _random_J(9, True)
    ctrl = d.runtime(0.01)
    # the other order, P(t) K[e], with the filter state in image space (ERRATA 9)
    image_filter = DiscreteFilter.from_tf(d.filter_tf(), 0.01, 9)
    e = np.full(9, 1e-3)
    for _ in range(300):
        q_prev = ctrl.update(e, J)
        q_other_prev = d.sv_policy.pseudo_inverse(J) @ image_filter.step(e)
    np.testing.assert_allclose(q_other_prev, q_prev, rtol=1e-9)  # same while J is constant
    q_next = ctrl.update(e, 2.0 * J)  # re-linearization halves P: only the rate changes
    q_other = d.sv_policy.pseudo_inverse(2.0 * J) @ image_filter.step(e)
    assert np.linalg.norm(q_next - q_prev) < 0.01 * np.linalg.norm(q_prev)
    np.testing.assert_allclose(q_other, 0.5 * q_prev, rtol=0.01)  # jumps by (P' - P) K[e]


def test_low_frequency_rate_is_classical_ibvs():
    d = OuterLoopDesign()
    J = _random_J(10, True)
    ctrl = d.runtime(0.01, J=J)
    e = np.random.default_rng(100).normal(0.0, 1e-3, 9)
    q = [ctrl.update(e) for _ in range(500)]
    rate = (q[-1] - q[-2]) / 0.01
    np.testing.assert_allclose(rate, 0.5 * d.sv_policy.pseudo_inverse(J) @ e, rtol=1e-9)


def test_reset_sets_output():
    ctrl = OuterLoopDesign().runtime(0.01, J=_random_J(11, True))
    q0 = np.linspace(-0.3, 0.3, 6)
    ctrl.update(np.ones(9) * 1e-3)
    ctrl.reset(q0)
    np.testing.assert_array_equal(ctrl.q_fb, q0)
    for _ in range(5):
        np.testing.assert_allclose(ctrl.update(np.zeros(9)), q0, rtol=0, atol=1e-12)
    ctrl.reset()
    np.testing.assert_allclose(ctrl.update(np.zeros(9)), 0.0, atol=1e-15)


# ---------------------------------------------------------------- validation
def test_design_validation():
    with pytest.raises(InvalidParameterError, match=r"1/tau_in = 100\) rad/s") as info:
        OuterLoopDesign(omega_n=150.0)
    assert info.value.value == 150.0
    bad = [({"zeta": 0.0}, "zeta"), ({"omega_n": -1.0}, "omega_n"), ({"tau_in": 0.0}, "tau_in")]
    for kwargs, name in bad:
        with pytest.raises(InvalidParameterError, match=name):
            OuterLoopDesign(**kwargs)
    with pytest.raises(InvalidParameterError, match="SingularValuePolicy"):
        OuterLoopDesign(sv_policy="damped")
    with pytest.raises(InvalidParameterError, match=r"\[0, 1\)"):
        SingularValuePolicy("damped", 1.5)
    with pytest.raises(InvalidParameterError, match="'damped' or 'truncate'"):
        SingularValuePolicy("svd")
    with pytest.raises(InvalidParameterError, match="omegas"):
        OuterLoopDesign().closed_form_response(_random_J(0, False), [0.0, 1.0])
    with pytest.raises(SingularConfigurationError):
        SingularValuePolicy().pseudo_inverse(np.zeros((9, 6)))


def test_runtime_validation():
    d = OuterLoopDesign()
    ctrl = d.runtime(0.01)
    with pytest.raises(InvalidParameterError, match="no fixed Jacobian"):
        ctrl.update(np.zeros(9))
    with pytest.raises(InvalidArrayError, match=r"\(n, 6\)"):
        ctrl.update(np.zeros(9), np.zeros((9, 5)))
    with pytest.raises(InvalidArrayError, match="e_image"):
        ctrl.update(np.zeros(8), _random_J(0, True))
    with pytest.raises(InvalidParameterError, match="method"):
        d.runtime(0.01, method="euler")
    assert isinstance(d.filter_tf(), ct.TransferFunction)
