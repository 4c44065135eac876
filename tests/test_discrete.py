"""DiscreteFilter: exactness of ZOH/FOH, Tustin accuracy, resets, validation."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest

from ibvs_youla.control.discrete import DiscreteFilter
from ibvs_youla.control.feedforward import FeedforwardDesign
from ibvs_youla.control.inner import InnerLoopDesign
from ibvs_youla.control.outer import OuterLoopDesign
from ibvs_youla.exceptions import InvalidArrayError, InvalidParameterError

DT = 1e-3


def _run(filt: DiscreteFilter, inputs: np.ndarray) -> np.ndarray:
    return np.array([filt.step(u) for u in inputs])


def _freq_response(filt: DiscreteFilter, omega: float) -> complex:
    A, B, C, D = filt.matrices
    z = np.exp(1j * omega * filt.dt)
    return complex(C @ np.linalg.solve(z * np.eye(A.shape[0]) - A, B) + D)


def test_zoh_step_response_is_exact_at_samples():
    tf = FeedforwardDesign().filter_tf()
    filt = DiscreteFilter.from_tf(tf, DT, 1, method="zoh")
    t = np.arange(200) * DT
    y = _run(filt, np.ones((t.size, 1)))[:, 0]
    y_ref = ct.step_response(tf, t).outputs
    # y[0] is the continuous value at 0+ (the feedthrough D), later samples are exact
    np.testing.assert_allclose(y[1:], y_ref[1:], rtol=0, atol=1e-9)
    assert y[0] == pytest.approx(FeedforwardDesign().high_frequency_gain, rel=1e-12)


def test_foh_is_exact_for_piecewise_linear_input():
    tf = FeedforwardDesign().filter_tf()
    filt = DiscreteFilter.from_tf(tf, DT, 1, method="foh")
    t = np.arange(300) * DT
    u = np.interp(t, [0.0, 0.05, 0.12, 1.0], [0.0, 1.0, -0.5, -0.5])
    y = _run(filt, u[:, None])[:, 0]
    y_ref = ct.forced_response(tf, t, u).outputs  # python-control interpolates u linearly
    np.testing.assert_allclose(y, y_ref, rtol=0, atol=1e-9)


def test_tustin_filter_matches_continuous_step_response_of_outer_filter():
    # K(s) is an integrator plus fast terms; Tustin keeps the integrator exact. After the
    # fast modes (-200, -33 rad/s) die out the error is the trapezoid rule's, O(dt).
    K = OuterLoopDesign().filter_tf()
    filt = DiscreteFilter.from_tf(K, DT, 1, method="tustin")
    t = np.arange(2000) * DT
    y = _run(filt, np.ones((t.size, 1)))[:, 0]
    y_ref = ct.step_response(K, t).outputs
    # 0.5 * dt: half a sample of the integrator's ramp slope omega/(2 zeta) = 0.5 1/s
    assert np.abs(y - y_ref).max() < 0.5 * DT
    assert y[-1] == pytest.approx(y_ref[-1], rel=1e-3)


def test_discrete_inner_loop_tracks_continuous_closed_loop():
    """Tustin G_C around the exact ZOH double integrator at 1 kHz vs continuous T.

    Tolerance 0.04 of the step: sampling costs the loop about omega_c dt / 2 = 0.05 rad
    (2.9 deg) of phase at the 100 rad/s crossover, which shows as a ~3.6 % larger
    overshoot (25 % continuous).
    """
    inner = InnerLoopDesign()
    Gc = inner.discrete_controller(DT, n_joints=1)
    Ad = np.array([[1.0, DT], [0.0, 1.0]])
    Bd = np.array([DT**2 / 2.0, DT])
    x = np.zeros(2)
    t = np.arange(150) * DT
    q = np.empty(t.size)
    for k in range(t.size):
        q[k] = x[0]
        v = Gc.step(np.array([1.0 - x[0]]))[0]
        x = Ad @ x + Bd * v
    q_ref = ct.step_response(inner.complementary_sensitivity(), t).outputs
    assert np.abs(q - q_ref).max() < 0.04
    assert q.max() == pytest.approx(q_ref.max(), abs=0.04)


def test_tustin_prewarp_matches_frequency_response_exactly():
    G = InnerLoopDesign().controller()
    w0 = 100.0
    filt = DiscreteFilter.from_tf(G, DT, 1, method="tustin", prewarp_frequency=w0)
    assert _freq_response(filt, w0) == pytest.approx(complex(G(1j * w0)), rel=1e-10)
    plain = DiscreteFilter.from_tf(G, DT, 1, method="tustin")
    assert abs(_freq_response(plain, w0) / G(1j * w0) - 1.0) > 1e-5


def test_channels_are_independent():
    G = InnerLoopDesign().controller()
    multi = DiscreteFilter.from_tf(G, DT, 3)
    rng = np.random.default_rng(0)
    u = rng.standard_normal((50, 3))
    y = _run(multi, u)
    for j in range(3):
        single = DiscreteFilter.from_tf(G, DT, 1)
        np.testing.assert_allclose(y[:, j], _run(single, u[:, [j]])[:, 0], rtol=1e-14, atol=1e-12)


def test_reset_steady_state_holds_constant_output():
    tf = FeedforwardDesign().filter_tf()
    filt = DiscreteFilter.from_tf(tf, DT, 6, method="zoh")
    u0 = np.linspace(-1.0, 2.0, 6)
    filt.reset_steady_state(u0)
    # 1e-10: I - A has eigenvalues down to 1 - exp(-dt/(3 tau)) = 0.033, so solving with
    # it costs a few ulps times its condition number
    assert filt.dc_gain() == pytest.approx(1.0, abs=1e-10)
    for _ in range(20):
        np.testing.assert_allclose(filt.step(u0), u0, rtol=0, atol=1e-10)


def test_reset_output_of_integrating_filter():
    filt = DiscreteFilter.from_tf(OuterLoopDesign().filter_tf(), 0.01, 6)
    y0 = np.arange(6.0) - 2.5
    filt.reset_output(y0)
    assert filt.dc_gain() == float("inf")
    for _ in range(20):
        np.testing.assert_allclose(filt.step(np.zeros(6)), y0, rtol=0, atol=1e-12)
    with pytest.raises(InvalidParameterError, match="reset_output"):
        filt.reset_steady_state(np.ones(6))


def test_reset_output_rejects_filter_without_integrator():
    filt = DiscreteFilter.from_tf(InnerLoopDesign().controller(), DT, 2)
    with pytest.raises(InvalidParameterError, match="reset_steady_state"):
        filt.reset_output(np.zeros(2))


def test_reset_to_zero_and_given_state():
    filt = DiscreteFilter.from_tf(InnerLoopDesign().controller(), DT, 2)
    filt.step(np.ones(2))
    assert np.abs(filt.state).max() > 0.0
    filt.reset()
    assert np.abs(filt.state).max() == 0.0
    filt.reset(np.full((1, 2), 3.0))
    np.testing.assert_array_equal(filt.state, [[3.0, 3.0]])


def test_validation_errors():
    G = InnerLoopDesign().controller()
    with pytest.raises(InvalidParameterError, match="n_channels"):
        DiscreteFilter.from_tf(G, DT, 0)
    with pytest.raises(InvalidParameterError, match="'zoh' or 'foh' or 'tustin'"):
        DiscreteFilter.from_tf(G, DT, 1, method="euler")
    with pytest.raises(InvalidParameterError, match="> 0"):
        DiscreteFilter.from_tf(G, -1e-3, 1)
    with pytest.raises(InvalidParameterError, match="continuous"):
        DiscreteFilter.from_tf(ct.tf([1.0], [1.0, 0.5], 0.1), DT, 1)
    with pytest.raises(InvalidParameterError, match="SISO"):
        mimo = ct.ss([[-1.0, 0.0], [0.0, -2.0]], np.eye(2), np.eye(2), np.zeros((2, 2)))  # fixed 2x2 plant
        DiscreteFilter.from_tf(mimo, DT, 1)
    filt = DiscreteFilter.from_tf(G, DT, 6)
    with pytest.raises(InvalidArrayError, match=r"shape \(6,\)"):
        filt.step(np.zeros(5))
    with pytest.raises(InvalidArrayError, match="square"):
        DiscreteFilter(np.zeros((2, 3)), np.zeros(2), np.zeros(2), 0.0, DT, 1)


@pytest.mark.parametrize(
    "method, prewarp", [("tustin", None), ("tustin", 30.0), ("zoh", None), ("foh", None)]
)
def test_from_tf_reuses_its_discretization_with_the_same_floats(method, prewarp):
    """A transfer function discretized again (the same object, an equal one, its state space) gives the
    matrices of the direct conversion bit for bit; another dt, method or system gives its own."""
    from scipy.signal import cont2discrete

    tau = 0.0123
    systems = [ct.tf([3 * tau, 1], [tau**3, 3 * tau**2, 3 * tau, 1]) for _ in range(2)]
    systems.append(ct.ss(systems[0]))
    for dt in (1e-3, 7e-3):
        ss = ct.ss(systems[0])
        if prewarp is None:
            direct = cont2discrete(
                (ss.A, ss.B, ss.C, ss.D), dt, method={"tustin": "bilinear"}.get(method, method)
            )
        else:
            dt_eff = 2.0 * np.tan(prewarp * dt / 2.0) / prewarp
            direct = cont2discrete((ss.A, ss.B, ss.C, ss.D), dt_eff, method="bilinear")
        for sys in systems * 2:
            A, B, C, D = DiscreteFilter.from_tf(sys, dt, 3, method=method, prewarp_frequency=prewarp).matrices
            np.testing.assert_array_equal(A, direct[0])
            np.testing.assert_array_equal(B, direct[1][:, 0])
            np.testing.assert_array_equal(C, direct[2][0])
            assert D == direct[3][0, 0]
    other = DiscreteFilter.from_tf(
        ct.tf([1.0], [tau, 1.0]), 1e-3, 3, method=method, prewarp_frequency=prewarp
    )
    assert other.matrices[0].shape == (1, 1)
    filt = DiscreteFilter.from_tf(systems[0], 1e-3, 2, method=method, prewarp_frequency=prewarp)
    filt.step(np.ones(2))  # a filter's own state: the shared matrices are not written
    np.testing.assert_array_equal(
        DiscreteFilter.from_tf(systems[0], 1e-3, 2, method=method, prewarp_frequency=prewarp).state, 0.0
    )
