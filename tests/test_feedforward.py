"""Feedforward (Section 6.2): inverse of the inner loop, ERRATA 11, smooth variant."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest

from ibvs_youla import FeedforwardDesign, InnerLoopDesign
from ibvs_youla.control.feedforward import MinimumJerkTrajectory
from ibvs_youla.exceptions import InvalidArrayError, InvalidParameterError

DT = 1e-3
# IRB 4600 joint speed limits (ERRATA 16) [rad/s]
V_MAX = np.radians([175.0, 175.0, 175.0, 250.0, 250.0, 360.0])
# Table 1, scenario 1: from q = 0 to these joint angles
Q1_DES = np.radians([0.48, 2.21, 2.05, -82.68, 9.46, 77.47])


def test_defaults_follow_eq_49_and_65():
    d = FeedforwardDesign()
    assert d.tau_in == 0.01
    assert d.tau_forward == pytest.approx(0.001, rel=1e-15)
    assert FeedforwardDesign(0.02, 0.005).tau_forward == 0.005


def test_filter_coefficients_eq_48():
    d = FeedforwardDesign(0.01)
    tf = d.filter_tf()
    np.testing.assert_allclose(tf.num[0][0], [1e-6, 3e-4, 3e-2, 1.0], rtol=1e-12)
    # (0.03 s + 1)(1e-6 s^2 + 2e-3 s + 1)
    np.testing.assert_allclose(tf.den[0][0], [3e-8, 1e-6 + 6e-5, 2e-3 + 3e-2, 1.0], rtol=1e-12)
    assert d.high_frequency_gain == pytest.approx(100.0 / 3.0, rel=1e-12)


@pytest.mark.parametrize("tau_in", [0.005, 0.01, 0.05])
def test_feedforward_times_inner_is_double_pole(tau_in):
    d = FeedforwardDesign(tau_in)
    w = np.logspace(-1, 5, 60)
    product = InnerLoopDesign(tau_in).complementary_sensitivity()(1j * w) * d.filter_tf()(1j * w)
    expected = 1.0 / (d.tau_forward * 1j * w + 1.0) ** 2
    np.testing.assert_allclose(product, expected, rtol=1e-10)
    np.testing.assert_allclose(d.tracking_tf()(1j * w), expected, rtol=1e-12)


def test_step_demand_errata_11():
    d = FeedforwardDesign()
    speed, accel = d.step_demand(Q1_DES)
    # peak of the impulse response of 1/(tau_f s + 1)^2 is 1/(e tau_f), at t = tau_f
    t = np.linspace(0.0, 0.01, 100001)
    h = ct.impulse_response(d.tracking_tf(), t).outputs
    assert h.max() == pytest.approx(1.0 / (np.e * d.tau_forward), rel=1e-6)
    np.testing.assert_allclose(speed, np.abs(Q1_DES) / (np.e * 1e-3), rtol=1e-12)
    np.testing.assert_allclose(np.degrees(speed), [176.6, 813.0, 754.2, 30416.3, 3480.1, 28499.6], atol=0.1)
    assert np.all(speed > V_MAX)  # every joint of scenario 1 exceeds its limit, joint 4 by 121x
    assert speed[3] / V_MAX[3] == pytest.approx(121.7, abs=0.1)
    np.testing.assert_allclose(accel, np.abs(Q1_DES) * 1e6, rtol=1e-12)


def test_step_runtime_starts_at_rest_and_matches_continuous():
    d = FeedforwardDesign()
    q0 = np.radians([42.40, 21.20, 4.58, -2.86, 66.46, -42.40])
    q1 = np.radians([45.0, 18.59, 4.35, 0.0, 67.06, -45.0])
    rt = d.step_runtime(q0, q1, DT)
    out = np.array([rt.step() for _ in range(60)])
    # biproper Eq. (48): at t = 0+ q_ff jumps by tau_in^2/(3 tau_f^2) = 33.3 times the step
    np.testing.assert_allclose(out[0], q0 + (100.0 / 3.0) * (q1 - q0), rtol=0, atol=1e-9)
    y = ct.step_response(d.filter_tf(), np.arange(60) * DT).outputs
    np.testing.assert_allclose(out[1:], q0 + np.outer(y[1:], q1 - q0), rtol=0, atol=1e-9)
    assert rt.time == pytest.approx(60 * DT)
    np.testing.assert_allclose(rt.reference(-1.0), q0)
    np.testing.assert_allclose(rt.reference(0.0), q1)
    rt.reset()
    assert rt.time == 0.0
    np.testing.assert_allclose(rt.step(), out[0], rtol=0, atol=1e-12)


def test_sampled_step_chain_is_even_faster_than_continuous():
    """Held q_ff (1 kHz = 1/tau_f) into the ZOH inner loop: joints move 2.2x faster than ideal.

    The staircase of a signal that changes on the scale of one sample is not the
    continuous q_ff, so the 1/(tau_f s + 1)^2 tracking only holds for dt << tau_f.
    """
    d = FeedforwardDesign()
    rt = d.step_runtime(np.zeros(6), Q1_DES, DT)
    inner = InnerLoopDesign().discrete_closed_loop(DT)
    inner.reset_steady_state(np.zeros(6))
    q = np.array([inner.step(rt.step()) for _ in range(400)])
    peak = np.abs(np.diff(q, axis=0)).max(axis=0) / DT
    ratio = peak / d.step_demand(Q1_DES)[0]
    np.testing.assert_allclose(ratio, 2.197, atol=0.01)
    np.testing.assert_allclose(q[-1], Q1_DES, rtol=0, atol=1e-9)


def test_sampled_step_at_1_khz_is_far_from_the_ideal():
    """dt = tau_f = 1 ms: ZOH T_forward -> Tustin G_C -> ZOH double integrator.

    Scenario 1's joint-4 step of -82.68 deg peaks at 292x the 250 deg/s limit (the ideal
    |Delta|/(e tau_f) gives 122x) and swings to 2.80 times the step (-232 deg).
    """
    d = FeedforwardDesign()
    speed, overshoot = d.sampled_step_demand(Q1_DES[3], DT)
    assert speed / V_MAX[3] == pytest.approx(292.4, rel=0.01)
    assert overshoot == pytest.approx(1.801, rel=0.01)
    assert np.degrees(Q1_DES[3]) * (1.0 + overshoot) == pytest.approx(-231.6, rel=0.01)
    assert speed / d.step_demand(Q1_DES[3])[0] == pytest.approx(2.403, rel=0.01)
    # linear in the step: every joint scales, the overshoot fraction is shared
    speeds, ov6 = d.sampled_step_demand(Q1_DES, DT)
    np.testing.assert_allclose(speeds / np.abs(Q1_DES), speed / abs(Q1_DES[3]), rtol=1e-12)
    assert ov6 == overshoot


def test_sampled_step_at_10_khz():
    d = FeedforwardDesign()
    speed, overshoot = d.sampled_step_demand(Q1_DES[3], 1e-4)
    assert speed / V_MAX[3] == pytest.approx(134.7, rel=0.01)
    assert overshoot == pytest.approx(0.137, rel=0.01)


def test_sampled_step_tends_to_the_ideal():
    d = FeedforwardDesign()
    ideal = d.step_demand(1.0)[0]
    ratios, overshoots = [], []
    for dt in (1e-3, 1e-4, 1e-5, 1e-6):
        speed, overshoot = d.sampled_step_demand(1.0, dt, horizon=0.05)
        ratios.append(float(speed / ideal))
        overshoots.append(overshoot)
    assert np.all(np.diff(ratios) < 0.0) and np.all(np.diff(overshoots) < 0.0)
    assert ratios[-1] == pytest.approx(1.0, abs=2e-3)
    assert overshoots[-1] < 2e-3
    # the sampled position response approaches q(t) = 1 - (1 + t/tau_f) e^(-t/tau_f)
    dt = 1e-6
    t = np.arange(0, 10001) * dt
    q = ct.step_response(d.sampled_tracking(dt), t).outputs[0, 0]
    ideal_q = 1.0 - (1.0 + t / d.tau_forward) * np.exp(-t / d.tau_forward)
    assert np.abs(q - ideal_q).max() < 5e-3


def test_sampled_tracking_matches_the_runtime_filters():
    """The discrete system is the runtime chain: step_runtime + discrete_controller + exact ZOH plant."""
    d = FeedforwardDesign()
    n = 300
    y = ct.step_response(d.sampled_tracking(DT, 2), np.arange(n) * DT).outputs  # (4 outputs, 2 inputs, n)
    assert y.shape == (4, 2, n)
    np.testing.assert_allclose(y[0, 0], y[1, 1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(y[2, 0], y[3, 1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(y[1, 0], 0.0, atol=0)
    rt = d.step_runtime(np.zeros(1), np.ones(1), DT)
    gc = InnerLoopDesign().discrete_controller(DT, 1)
    q = dq = 0.0
    qs, dqs = [], []
    for _ in range(n):
        qs.append(q)
        dqs.append(dq)
        v = float(gc.step(rt.step() - q)[0])
        q, dq = q + DT * dq + 0.5 * DT**2 * v, dq + DT * v
    np.testing.assert_allclose(y[0, 0], qs, rtol=0, atol=1e-9)
    np.testing.assert_allclose(y[2, 0], dqs, rtol=0, atol=1e-6)
    assert y[0, 0, -1] == pytest.approx(1.0, abs=1e-4)


def test_minimum_jerk_profile():
    traj = MinimumJerkTrajectory([0.0, 1.0], [2.0, -1.0], 1.6)
    np.testing.assert_allclose(traj.position(0.0), [0.0, 1.0])
    np.testing.assert_allclose(traj.position(0.8), [1.0, 0.0])
    np.testing.assert_allclose(traj.position(9.0), [2.0, -1.0])
    np.testing.assert_allclose(np.abs(traj.velocity(0.8)), traj.peak_speed, rtol=1e-12)
    np.testing.assert_allclose(traj.peak_speed, 1.875 * 2.0 / 1.6, rtol=1e-12)
    t = np.linspace(0.0, 1.6, 160001)
    pos = np.array([traj.position(ti) for ti in t[::100]])
    acc = np.abs(np.diff(pos, 2, axis=0)).max(axis=0) / (t[100] ** 2)
    np.testing.assert_allclose(acc, traj.peak_acceleration, rtol=1e-4)  # second difference, h = 1 ms
    vel = np.array([traj.velocity(ti) for ti in t[50:-1:100]])
    fd = np.diff(pos, axis=0) / t[100]
    # central difference: error h^2 max|jerk|/24 = 1e-6 * (60 * 2 / 1.6^3) / 24 = 1.2e-6
    np.testing.assert_allclose(fd, vel, rtol=0, atol=1.3e-6)


@pytest.mark.parametrize("fraction", [0.25, 0.5, 1.0])
def test_smooth_runtime_respects_speed_limits(fraction):
    d = FeedforwardDesign()
    rt = d.smooth_runtime(np.zeros(6), Q1_DES, V_MAX, DT, speed_fraction=fraction)
    traj = rt.trajectory
    # joint 4 binds: duration = (15/8) 82.68 deg / (fraction * 250 deg/s)
    assert traj.duration == pytest.approx(1.875 * 82.68 / (fraction * 250.0), rel=1e-12)
    np.testing.assert_allclose(traj.peak_speed.max() / (fraction * V_MAX[3]), 1.0, rtol=1e-12)
    inner = InnerLoopDesign().discrete_closed_loop(DT)
    inner.reset_steady_state(np.zeros(6))
    n = int(traj.duration / DT) + 400
    q_ff = np.array([rt.step() for _ in range(n)])
    q = np.array([inner.step(x) for x in q_ff])
    np.testing.assert_allclose(q_ff[0], 0.0, atol=1e-15)  # q_ff(0) = q_start
    speed = np.abs(np.diff(q, axis=0)).max(axis=0) / DT
    # 1e-3: the joints see q_ff held between samples, which adds ~1e-5 relative ripple
    assert np.all(speed <= fraction * V_MAX * (1.0 + 1e-3))
    np.testing.assert_allclose(q[-1], Q1_DES, rtol=0, atol=1e-9)
    # tracking lag of the trajectory: about (2 tau_f + dt/2) * peak speed
    lag = np.abs(q - np.array([traj.position(k * DT) for k in range(n)])).max(axis=0)
    np.testing.assert_allclose(lag, (2.0 * d.tau_forward + DT / 2.0) * traj.peak_speed, rtol=0.05)


def test_smooth_runtime_null_move_uses_min_duration():
    rt = FeedforwardDesign().smooth_runtime(np.ones(6), np.ones(6), V_MAX, min_duration=0.25)
    assert rt.trajectory.duration == 0.25
    # 1e-10: rounding of the steady state (I - A)^-1 B u0, see test_discrete
    np.testing.assert_allclose([rt.step() for _ in range(10)], 1.0, rtol=0, atol=1e-10)


def test_validation():
    with pytest.raises(InvalidParameterError, match="tau_in"):
        FeedforwardDesign(0.0)
    with pytest.raises(InvalidParameterError, match="tau_forward"):
        FeedforwardDesign(0.01, -1e-3)
    with pytest.raises(InvalidParameterError, match=r"\(0, 1\]") as info:
        MinimumJerkTrajectory.within_speed_limits(np.zeros(6), Q1_DES, V_MAX, fraction=1.5)
    assert info.value.value == 1.5
    with pytest.raises(InvalidArrayError, match="speed_limits"):
        MinimumJerkTrajectory.within_speed_limits(np.zeros(6), Q1_DES, -V_MAX)
    with pytest.raises(InvalidArrayError, match=r"shape \(6,\)"):
        FeedforwardDesign().step_runtime(np.zeros(6), np.zeros(5))
    with pytest.raises(InvalidParameterError, match="duration"):
        MinimumJerkTrajectory(np.zeros(2), np.ones(2), 0.0)
    traj = MinimumJerkTrajectory(np.zeros(2), np.ones(2), 1.0)
    for bad in (np.nan, np.inf, -np.inf):
        with pytest.raises(InvalidParameterError, match=r"finite number \[s\]"):
            traj.position(bad)
        with pytest.raises(InvalidParameterError, match=r"finite number \[s\]"):
            traj.velocity(bad)
    with pytest.raises(InvalidParameterError, match="dt"):
        FeedforwardDesign().sampled_tracking(0.02)  # dt > tau_in
    with pytest.raises(InvalidParameterError, match="n_joints"):
        FeedforwardDesign().sampled_tracking(DT, 0)
