"""ArmPlant: encoder offset (ERRATA 14), RK4 stepping, saturation, divergence errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ibvs_youla.exceptions import InvalidArrayError, InvalidParameterError, SimulationDivergedError
from ibvs_youla.simulation.integrators import rk4_arm_step
from ibvs_youla.simulation.plant import ArmPlant, DivergenceBounds

D = np.full(6, np.radians(1.0))  # scenario 2's disturbance (ERRATA 14)
Q0 = np.radians([42.40, 21.20, 4.58, -2.86, 66.46, -42.40])  # Table 1 scenario 2 start


def test_encoders_do_not_see_the_joint_offset_and_the_camera_moves_with_the_true_angles(arm):
    plant = ArmPlant(arm, D, q_encoder=Q0)
    np.testing.assert_allclose(plant.q_encoder, Q0, rtol=0, atol=1e-15)  # (Q0 + d) - d: round-off only
    np.testing.assert_allclose(plant.q_true, Q0 + D, rtol=0, atol=1e-15)
    np.testing.assert_allclose(plant.camera_pose(), arm.camera_pose(Q0 + D), rtol=0, atol=1e-15)
    rng = np.random.default_rng(4)
    tau_hold = arm.nonlinear_effects(plant.q_true, np.zeros(6))
    for _ in range(50):
        plant.step(tau_hold + 50.0 * rng.normal(size=6), 1e-3)
        np.testing.assert_allclose(plant.q_true - plant.q_encoder, D, rtol=0, atol=1e-14)
    assert plant.t == pytest.approx(0.05, abs=1e-15)
    assert np.abs(plant.dq).max() > 1e-3  # it moved


def test_gravity_at_the_true_angles_holds_the_arm_and_at_the_encoder_angles_does_not(arm):
    plant = ArmPlant(arm, D, q_encoder=Q0)
    plant.step(arm.nonlinear_effects(Q0 + D, np.zeros(6)), 1e-3)
    assert np.abs(plant.dq).max() < 1e-9  # exact equilibrium up to round-off
    plant.reset(Q0)
    plant.step(arm.nonlinear_effects(Q0, np.zeros(6)), 1e-3)  # what a controller trusting encoders sends
    assert np.abs(plant.dq).max() > 1e-5  # the 1 deg offset is a real disturbance


EPS = float(np.finfo(float).eps)


def test_step_is_one_rk4_step_of_arm_forward_dynamics(arm):
    rng = np.random.default_rng(5)
    dq0, tau = rng.normal(size=6), 100.0 * rng.normal(size=6)
    plant = ArmPlant(arm, D, q_encoder=Q0, dq=dq0, t=2.0)
    applied = plant.step(tau, 1e-3)
    k = np.empty((4, 12))
    x_ref = rk4_arm_step(arm.forward_dynamics, np.concatenate([Q0 + D, dq0]), tau, 1e-3, k)
    np.testing.assert_array_equal(applied, tau)
    # The plant's step runs the compiled ABA, Pinocchio's to 1e-12 of its scale
    # (test_dynamics_kernels.py): over one step of dt that is 1e-12 dt |ddq| on dq, dt times less on q.
    bound = 1e-12 * 1e-3 * max(1.0, np.abs(k[:, 6:]).max())
    q_scale = max(1.0, np.abs(x_ref[:6]).max())
    np.testing.assert_allclose(plant.q_true, x_ref[:6], rtol=0.0, atol=1e-3 * bound + 4 * EPS * q_scale)
    np.testing.assert_allclose(plant.dq, x_ref[6:], rtol=0.0, atol=bound)
    assert plant.t == 2.001


def test_torque_saturation_clips_at_tau_max(arm):
    tau = 3.0 * np.asarray(arm.tau_max) * np.array([1, -1, 1, -1, 1, 0.2])
    clipped = np.clip(tau, -arm.tau_max, arm.tau_max)
    sat, free = ArmPlant(arm, q_encoder=Q0, saturate_torque=True), ArmPlant(arm, q_encoder=Q0)
    np.testing.assert_array_equal(sat.step(tau, 1e-3), clipped)
    np.testing.assert_array_equal(free.step(clipped, 1e-3), clipped)
    np.testing.assert_array_equal(sat.dq, free.dq)
    np.testing.assert_array_equal(sat.last_tau, clipped)


def test_speed_saturation_clips_at_dq_max(arm):
    dq0 = 2.0 * np.asarray(arm.dq_max) * np.array([1, -1, 1, -1, 1, -1])
    hold = arm.nonlinear_effects(Q0, dq0)  # zero acceleration: without the limiter dq stays ~2 dq_max
    sat = ArmPlant(arm, q_encoder=Q0, dq=dq0, saturate_speed=True)
    free = ArmPlant(arm, q_encoder=Q0, dq=dq0)
    sat.step(hold, 1e-3)
    free.step(hold, 1e-3)
    np.testing.assert_allclose(np.abs(sat.dq), arm.dq_max, rtol=1e-12)
    assert np.all(np.abs(free.dq) > 1.9 * np.asarray(arm.dq_max))


def test_huge_torque_raises_divergence_with_time_and_quantity_and_never_nan(arm):
    plant = ArmPlant(arm, D, q_encoder=Q0, t=1.5)
    plant.step(arm.nonlinear_effects(Q0 + D, np.zeros(6)), 1e-3)
    q_before = plant.q_true
    with pytest.raises(SimulationDivergedError, match=r"at t = 1\.502 s: dq: \|dq_\d\| = ") as info:
        plant.step(np.full(6, 1e9), 1e-3)
    err = info.value
    assert err.quantity == "dq" and err.time == pytest.approx(1.502, abs=1e-12)
    np.testing.assert_allclose(err.bound, 1000.0 * np.asarray(arm.dq_max))
    assert np.any(np.abs(err.value) > err.bound)
    # the state stays at the start of the failed step: finite, never NaN
    np.testing.assert_array_equal(plant.q_true, q_before)
    assert np.all(np.isfinite(plant.dq)) and plant.t == pytest.approx(1.501, abs=1e-12)
    with pytest.raises(SimulationDivergedError, match="tau: non-finite tau at joints \\[3\\]") as info:
        plant.step([0, 0, np.nan, 0, 0, 0], 1e-3)
    assert info.value.quantity == "tau"


def test_position_beyond_a_turn_past_the_limit_raises(arm):
    q = np.array(Q0)
    q[5] = arm.q_max[5] + 2 * math.pi - 1e-4
    dq = np.zeros(6)
    dq[5] = 1.0  # [rad/s]: crosses the bound within the 1 ms step
    plant = ArmPlant(arm, q_encoder=q, dq=dq)
    with pytest.raises(SimulationDivergedError, match=r"q: q_true_6 = .* outside") as info:
        plant.step(arm.nonlinear_effects(q, dq), 1e-3)
    assert info.value.quantity == "q" and info.value.time == pytest.approx(1e-3)


def test_default_speed_bound_admits_the_papers_1_ms_feedforward(arm):
    # ERRATA 11: joint 4 follows a -82.68 deg step through 1/(tau_f s + 1)^2, tau_f = 1 ms:
    # ideal peak speed |step| / (e tau_f) ~ 531 rad/s = 121.7x its limit; sampled at 1 kHz
    # (dt = tau_f) the simulation reaches 292x (FeedforwardDesign.sampled_step_demand,
    # tests/test_simulate.py), still under the 1000x bound.
    peak = np.radians(82.68) / (math.e * 1e-3)
    assert peak / arm.dq_max[3] == pytest.approx(121.66, rel=1e-4)
    assert DivergenceBounds().speed_factor == 1000.0
    q, dq = np.array(Q0), np.zeros(6)
    dq[3] = 293 * arm.dq_max[3]  # just above the sampled feedforward's peak speed
    plant = ArmPlant(arm, q_encoder=q, dq=dq)
    plant.step(arm.nonlinear_effects(q, dq), 1e-3)  # no error: the bound admits it
    assert plant.dq[3] / arm.dq_max[3] == pytest.approx(292.875, rel=1e-5)  # the step barely slows it
    dq[3] = 1100 * arm.dq_max[3]  # past the 1000x bound (the step itself slows it by ~0.2 %)
    plant = ArmPlant(arm, q_encoder=q, dq=dq)
    message = r"\|dq_4\| = .* rad/s > .* \(1000 x the speed limit"
    with pytest.raises(SimulationDivergedError, match=message) as info:
        plant.step(arm.nonlinear_effects(q, dq), 1e-3)
    assert info.value.quantity == "dq"


def test_bad_arguments(arm):
    with pytest.raises(InvalidArrayError, match="joint_offset"):
        ArmPlant(arm, np.zeros(5))
    with pytest.raises(InvalidParameterError, match="speed_factor"):
        DivergenceBounds(speed_factor=0.0)
    with pytest.raises(InvalidParameterError, match="dt"):
        ArmPlant(arm).step(np.zeros(6), 0.0)
    with pytest.raises(InvalidArrayError, match="tau"):
        ArmPlant(arm).step(np.zeros(5), 1e-3)
