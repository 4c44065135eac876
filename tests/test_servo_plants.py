"""The three plants of the servo loop: free-flying camera, kinematic arm, and the role of the dynamic arm."""

from __future__ import annotations

import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla import scenarios
from ibvs_youla.controllers import CommandType, Controller
from ibvs_youla.exceptions import InvalidParameterError, SimulationDivergedError
from ibvs_youla.simulation.free_camera import FreeCameraPlant
from ibvs_youla.simulation.kinematic_arm import KinematicArmPlant, inner_closed_loop_matrices
from servo_helpers import MARKERS_4, ConstantJointVelocity, ConstantTwist


def screw_pose(v, w_z, t):
    """Closed form of exp(t [v; (0, 0, w_z)]^) in SE(3): rotation about z, helix translation."""
    th = w_z * t
    c, s = np.cos(th), np.sin(th)
    T = np.eye(4)
    T[:2, :2] = [[c, -s], [s, c]]
    T[0, 3] = (v[0] * s - v[1] * (1.0 - c)) / w_z
    T[1, 3] = (v[0] * (1.0 - c) + v[1] * s) / w_z
    T[2, 3] = v[2] * t
    return T


def start_pose():
    T = np.eye(4)
    T[:3, :3] = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    T[:3, 3] = [0.3, -0.2, 0.1]
    return T


class PositionStep(Controller):
    command_type = CommandType.JOINT_POSITION
    name = "position-step"

    def __init__(self, step):
        self.step = np.asarray(step, dtype=float)

    def reset(self, task):
        super().reset(task)
        self.q_ref = task.q_start + self.step

    def command(self, reading):
        return self.q_ref


# --------------------------------------------------------------------------- free-flying camera
def test_free_camera_integrates_a_constant_twist_exactly():
    v, w_z, dt = np.array([0.3, -0.1, 0.05]), 0.7, 0.01  # [m/s], [rad/s], [s]
    plant = FreeCameraPlant(start_pose())
    for _ in range(250):
        plant.apply(np.array([*v, 0.0, 0.0, w_z]), dt)
    expected = start_pose() @ screw_pose(v, w_z, 2.5)
    np.testing.assert_allclose(plant.camera_pose(), expected, rtol=0, atol=1e-12)
    assert plant.t == pytest.approx(2.5, abs=1e-12)
    assert plant.reading() is None and plant.signal_values(None) == () and plant.signal_names == ()


def test_free_camera_run_through_simulate_ends_on_the_closed_form_pose():
    twist = np.array([0.1, 0.2, -0.05, 0.0, 0.0, -0.4])
    target = start_pose() @ screw_pose(twist[:3], twist[5], 1.0)
    scenario = iy.Scenario.free_camera(start_pose(), target, MARKERS_4 + np.array([0.3, -0.2, 0.0]))
    result = iy.simulate(
        scenario,
        ConstantTwist(twist),
        duration=1.0,
        plant="free-camera",
        camera=iy.PinholeCamera.normalized(),
    )
    assert result.status == "complete" and result.metadata["plant"] == "free-camera"
    assert len(result) == 101  # 100 Hz camera = control rate on the free camera: 1 s -> ticks 0..100
    np.testing.assert_allclose(result.camera_pose[-1], target, rtol=0, atol=1e-12)
    mm, deg = result.final_pose_error()
    assert mm < 1e-9 and deg < 1e-9
    np.testing.assert_array_equal(result.camera_twist, np.broadcast_to(twist, (101, 6)))
    np.testing.assert_allclose(
        result.camera_pose[50], start_pose() @ screw_pose(twist[:3], twist[5], 0.5), rtol=0, atol=1e-12
    )


def test_free_camera_rejects_a_non_finite_twist():
    plant = FreeCameraPlant(np.eye(4))
    with pytest.raises(SimulationDivergedError, match="camera twist"):
        plant.apply(np.array([0.0, np.nan, 0.0, 0.0, 0.0, 0.0]), 0.01)
    with pytest.raises(InvalidParameterError, match="camera_twist"):
        plant.use_input(CommandType.JOINT_VELOCITY)


# --------------------------------------------------------------------------- kinematic arm
def test_kinematic_arm_follows_a_joint_velocity_exactly(arm):
    sc = scenarios.physical(2)
    dq = np.radians([2.0, -1.0, 0.5, 3.0, -2.0, 1.0])  # [rad/s]
    result = iy.simulate(sc, ConstantJointVelocity(dq), duration=0.5, plant="kinematic", arm=arm)
    assert result.status == "complete"
    np.testing.assert_allclose(result.q, sc.q_start + result.t[:, None] * dq, rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        result.q_true - result.q, np.broadcast_to(sc.joint_offset, result.q.shape), rtol=0, atol=1e-15
    )
    np.testing.assert_allclose(result.dq[1:], np.broadcast_to(dq, (len(result) - 1, 6)), rtol=0, atol=0)
    np.testing.assert_allclose(result.camera_pose[-1], arm.camera_pose(result.q_true[-1]), rtol=0, atol=1e-15)


def step_response(x):
    """Unit-step response of T_in = (3 tau s + 1)/(tau s + 1)^3 at x = t/tau (partial fractions)."""
    return 1.0 - np.exp(-x) * (1.0 + x - x**2)


def test_kinematic_arm_follows_a_position_step_through_t_in(arm):
    sc = scenarios.physical(1)
    step = np.radians([1.0, -2.0, 0.5, 4.0, -3.0, 2.0])
    settings = iy.SimulationSettings(tau_in=0.01)
    result = iy.simulate(sc, PositionStep(step), duration=0.1, plant="kinematic", arm=arm, settings=settings)
    for t in (0.005, 0.02, 0.05):  # [s]: rising, overshooting (peak 1 + e^-2 at t = 2 tau), settling
        k = round(t / 1e-3)
        assert result.t[k] == pytest.approx(t, abs=1e-12)
        np.testing.assert_allclose(
            result.q[k] - sc.q_start,
            step * step_response(t / 0.01),
            rtol=1e-12,
            atol=1e-15,
            err_msg=f"t = {t} s",
        )
    assert step_response(2.0) == pytest.approx(1.0 + np.exp(-2.0), rel=1e-15)
    # the speed is the exact derivative of the step response: d/dx [...] = e^-x x (3 - x) / tau
    x = 0.02 / 0.01
    np.testing.assert_allclose(result.dq[20], step * np.exp(-x) * x * (3.0 - x) / 0.01, rtol=1e-10)


def test_inner_closed_loop_matrices_are_t_in_at_rest():
    Ad, Bd, C, CA = inner_closed_loop_matrices(0.01, 1e-3)
    x = np.linalg.solve(np.eye(3) - Ad, Bd)  # equilibrium for a unit input
    assert C @ x == pytest.approx(1.0, rel=1e-12)  # unit DC gain
    assert CA @ x == pytest.approx(0.0, abs=1e-9)
    # triple pole at -1/tau maps to z = e^(-dt/tau): compare the characteristic polynomial (a triple
    # eigenvalue itself is only computed to ~eps^(1/3))
    np.testing.assert_allclose(np.poly(Ad), np.poly(np.full(3, np.exp(-0.1))), rtol=1e-12, atol=1e-14)


def test_kinematic_arm_takes_joint_commands_only(arm):
    plant = KinematicArmPlant(arm, q_encoder=np.zeros(6))
    with pytest.raises(InvalidParameterError, match="command_type"):
        plant.use_input(CommandType.JOINT_TORQUE)
    with pytest.raises(SimulationDivergedError, match="non-finite"):
        plant.apply(np.full(6, np.inf), 1e-3)


def test_plants_take_their_input_by_name_too(arm):
    plant = KinematicArmPlant(arm, q_encoder=np.zeros(6), dt=1e-3)
    plant.use_input("joint_velocity")  # a string is parsed, not compared by identity
    plant.apply(np.ones(6), 1e-3)
    np.testing.assert_allclose(plant.reading().q, np.full(6, 1e-3), rtol=0, atol=1e-15)
    with pytest.raises(InvalidParameterError, match="command_type"):
        plant.use_input("joint_speed")
    with pytest.raises(InvalidParameterError, match="an Arm"):
        KinematicArmPlant(None, q_encoder=np.zeros(6))
    camera = FreeCameraPlant(np.eye(4))
    camera.use_input("camera_twist")
    with pytest.raises(InvalidParameterError, match="dt"):
        camera.apply(np.zeros(6), 0.0)
    with pytest.raises(InvalidParameterError, match="a \\(6,\\) twist"):
        camera.apply(np.zeros(5), 0.01)


def test_a_torque_command_cannot_drive_the_kinematic_arm(arm):
    class Torque(Controller):
        command_type = CommandType.JOINT_TORQUE
        name = "torque"

        def command(self, reading):
            return np.zeros(6)

    with pytest.raises(iy.exceptions.IncompatibleCommandError, match="no adapter converts it"):
        iy.simulate(scenarios.physical(1), Torque(), duration=0.01, plant="kinematic", arm=arm)
    result = iy.simulate(scenarios.physical(1), Torque(), duration=0.01, plant="dynamic", arm=arm)
    assert result.status == "complete" and set(result.signals) == {"q", "q_true", "dq", "tau"}
