"""Inverse kinematics: closed-form round trips, branch rules, singular poses, errors, UR5 numerical IK."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import brentq

from ibvs_youla.exceptions import InvalidArrayError, UnreachablePoseError
from ibvs_youla.model._resources import example_robot_data_urdf
from ibvs_youla.model.arm import Arm
from ibvs_youla.model.ik import SphericalWristParameters, numerical_branches, select_branches

SEED = 1729
POSE_TOL = 1e-9  # max |FK(q) - T| (rotation entries and metres)


@pytest.fixture(scope="module")
def ur5():
    return Arm.from_urdf(example_robot_data_urdf("ur_description/urdf/ur5_robot.urdf"), camera_frame="tool0")


def random_q(arm, rng, n):
    return arm.q_min + (arm.q_max - arm.q_min) * rng.random((n, 6))


def wrapped(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def test_round_trip_on_1000_random_configurations(arm):
    rng = np.random.default_rng(SEED)
    counts = []
    for q in random_q(arm, rng, 1000):
        T_O_C = arm.camera_pose(q)
        branches = arm.ik(T_O_C)
        counts.append(len(branches))
        for row in branches:
            assert np.abs(arm.camera_pose(row) - T_O_C).max() <= POSE_TOL
            assert arm.within_limits(row)
        # the original configuration is one of the branches, joints 4 and 6 modulo 2 pi
        assert np.abs(wrapped(branches - q)).max(axis=1).min() < 1e-7  # joint-space error of a 1e-12 pose fit
        assert np.all(np.abs(branches[:, [3, 5]]) <= np.pi)  # (-pi, pi] without q_near
    assert max(counts) == 8 and min(counts) >= 1


def test_q_near_returns_the_original_first_and_sorts_by_distance(arm):
    rng = np.random.default_rng(SEED + 1)
    for q in random_q(arm, rng, 200):
        branches = arm.ik(arm.camera_pose(q), q_near=q)
        np.testing.assert_allclose(branches[0], q, rtol=0, atol=1e-7)  # joints 4/6 beyond pi kept as in q
        distances = np.linalg.norm(branches - q, axis=1)
        assert np.all(np.diff(distances) >= 0)


@pytest.mark.parametrize(
    "q_deg",
    [
        (0.48, 2.21, 2.05, -82.68, 9.46, 77.47),
        (42.40, 21.20, 4.58, -2.86, 66.46, -42.40),
        (45, 18.59, 4.35, 0, 67.06, -45),
    ],
)
def test_table1_joint_vectors_are_recovered(arm, q_deg):
    q = np.radians(q_deg)
    branches = arm.ik(arm.camera_pose(q), q_near=q)
    np.testing.assert_allclose(np.degrees(branches[0]), q_deg, atol=1e-8)
    assert len(branches) >= 4  # both shoulders x wrist flips fit the limits here


def test_joints_4_and_6_come_back_nearest_q_near(arm):
    q = np.radians([20.0, 10.0, -20.0, 350.0, 40.0, -300.0])  # beyond one turn on axes 4 and 6
    T_O_C = arm.camera_pose(q)
    np.testing.assert_allclose(arm.ik(T_O_C, q_near=q)[0], q, atol=1e-9)
    plain = arm.ik(T_O_C)[0]  # without q_near: (-pi, pi]
    np.testing.assert_allclose(plain[3:], [np.radians(-10.0), np.radians(40.0), np.radians(60.0)], atol=1e-9)


def test_wrist_singularity_keeps_q4_and_puts_the_rotation_on_q6(arm):
    q = np.radians([10.0, 20.0, -30.0, 70.0, 0.0, 50.0])
    T_O_C = arm.camera_pose(q)
    near = arm.ik(T_O_C, q_near=np.radians([0, 0, 0, 25.0, 0, 0]))[0]
    np.testing.assert_allclose(np.degrees(near), [10, 20, -30, 25, 0, 95], atol=1e-8)
    default = arm.ik(T_O_C)[0]
    np.testing.assert_allclose(np.degrees(default), [10, 20, -30, 0, 0, 120], atol=1e-8)
    home = arm.ik(arm.camera_pose(np.zeros(6)))  # scenario 1 start (ERRATA 7)
    np.testing.assert_allclose(home[0], np.zeros(6), atol=1e-12)


def test_shoulder_singularity_keeps_q1(arm):
    p = SphericalWristParameters.irb4600()
    L, beta = math.hypot(p.a3, p.d4), math.atan2(p.d4, p.a3)
    q2 = np.radians(-40.0)
    # wrist centre on axis 1: a1 + a2 sin q2 + L sin(q2 + q3 + beta) = 0
    q3 = brentq(
        lambda q3: p.a1 + p.a2 * math.sin(q2) + L * math.sin(q2 + q3 + beta), np.radians(-20), np.radians(75)
    )
    q = np.array([0.7, q2, q3, 0.3, 0.5, -0.2])
    branches = arm.ik(arm.camera_pose(q), q_near=np.array([0.7, 0, 0, 0, 0, 0]))
    np.testing.assert_allclose(branches[0][:3], q[:3], atol=1e-9)
    assert np.all(
        np.isclose(wrapped(branches[:, 0] - 0.7), 0.0)
        | np.isclose(np.abs(wrapped(branches[:, 0] - 0.7)), np.pi)
    )


def test_unreachable_pose_raises(arm):
    T_far = np.eye(4)
    T_far[:3, 3] = [5.0, 0.0, 1.0]
    with pytest.raises(UnreachablePoseError, match="outside the workspace") as info:
        arm.ik(T_far)
    np.testing.assert_allclose(info.value.pose, T_far)
    # within reach of the links, but every branch breaks a limit (arm folded back, q2 = -100 deg < -90 deg)
    q_bad = np.radians([0.0, -100.0, 90.0, 0.0, 30.0, 0.0])
    with pytest.raises(UnreachablePoseError, match="joint limits"):
        arm.ik(arm.camera_pose(q_bad), q_near=q_bad)


@pytest.mark.parametrize(
    "bad",
    [np.full((4, 4), np.nan), np.eye(3), np.diag([1.1, 1.0, 1.0, 1.0]), np.diag([1.0, 1.0, -1.0, 1.0])],
    ids=["nan", "shape", "scaled", "reflection"],
)
def test_invalid_poses_raise(arm, bad):
    with pytest.raises(InvalidArrayError):
        arm.ik(bad)


def test_invalid_q_near_raises(arm):
    with pytest.raises(InvalidArrayError):
        arm.ik(arm.camera_pose(np.zeros(6)), q_near=np.zeros(5))
    with pytest.raises(InvalidArrayError):
        arm.ik(arm.camera_pose(np.zeros(6)), q_near=[0, 0, np.nan, 0, 0, 0])


def test_slightly_non_orthonormal_pose_is_projected(arm):
    q = np.radians([5.0, 10.0, 15.0, 20.0, 25.0, 30.0])
    T = arm.camera_pose(q)
    T[:3, :3] *= 1 + 1e-8  # within as_pose's 1e-6 rigidity tolerance
    np.testing.assert_allclose(arm.ik(T, q_near=q)[0], q, atol=1e-7)


def test_identified_parameters_and_the_printed_appendix_b_denominator(arm):
    assert arm.ik_parameters == SphericalWristParameters.irb4600()
    p = arm.ik_parameters
    q = np.radians([0.48, 2.21, 2.05, -82.68, 9.46, 77.47])
    T_O_E = arm.flange_pose(q)
    np.testing.assert_allclose(p.flange_pose(q), T_O_E, atol=1e-12)
    wc = T_O_E[:3, 3] - p.d6 * T_O_E[:3, 2]
    r, s = math.hypot(wc[0], wc[1]) - p.a1, wc[2] - p.d1
    L2, L3, L4 = p.a2, p.a3, p.d4
    numerator = L2**2 + r**2 + s**2 - L3**2 - L4**2
    assert numerator / (2 * L2 * math.hypot(L3, L4)) > 1.0  # (B8) as printed: arccos undefined (ERRATA 4)
    shoulder_angle = math.acos(numerator / (2 * L2 * math.hypot(r, s)))  # corrected denominator
    assert math.degrees(math.pi / 2 - shoulder_angle - math.atan2(s, r)) == pytest.approx(2.21, abs=1e-9)


def test_select_branches_drops_rows_without_an_equivalent_in_limits():
    q_min, q_max = np.radians([-10.0] * 6), np.radians([10.0] * 6)
    rows = np.radians([[5, 5, 5, 5, 5, 365], [5, 5, 5, 5, 5, 20]])
    np.testing.assert_allclose(np.degrees(select_branches(rows, q_min, q_max, np.zeros(6))), [[5] * 6])


def test_numerical_ik_agrees_with_the_closed_form_on_the_irb4600(arm):
    rng = np.random.default_rng(SEED + 2)
    flange = arm.model.getFrameId("flange")
    for q in random_q(arm, rng, 5):
        T_O_E = arm.flange_pose(q)
        found = numerical_branches(arm.model, arm.model.createData(), flange, T_O_E, q[None] + 0.05)
        closed = arm.ik(arm.camera_pose(q), q_near=q)
        assert np.abs(wrapped(closed - found[0])).max(axis=1).min() < 1e-8


def test_ur5_numerical_ik_round_trips(ur5):
    rng = np.random.default_rng(SEED + 3)
    for q in random_q(ur5, rng, 5):
        T_O_C = ur5.camera_pose(q)
        for q_near in (q, None):
            branches = ur5.ik(T_O_C, q_near=q_near)
            assert 1 <= len(branches) <= 8  # a UR5 has at most 8 branches
            for row in branches:
                assert np.abs(ur5.camera_pose(row) - T_O_C).max() <= POSE_TOL
            assert np.abs(wrapped(branches - q)).max(axis=1).min() < 1e-7
        np.testing.assert_allclose(ur5.ik(T_O_C, q_near=q)[0], q, atol=1e-9)
    far = pin.SE3(np.eye(3), np.array([3.0, 0.0, 0.0])).homogeneous
    with pytest.raises(UnreachablePoseError):
        ur5.ik(far)
