"""IK of any arm (Eq. (28); Eq. (62) at camera rate): the UR closed form, the warm start, redundancy.

Tolerances: every solution's camera pose within 1e-9 of the target (entries of the 4x4 matrix,
metres and rotation entries; the check ``Arm.ik`` applies); the original configuration recovered
within 1e-7 rad by the closed forms (the acos steps lose precision near a stretched elbow:
measured 1.8e-8 rad on the seeds below) and 1e-9 by the warm start.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from ibvs_youla import robots
from ibvs_youla.exceptions import UnreachablePoseError
from ibvs_youla.model.arm import Arm
from ibvs_youla.model.ik import select_branches
from ibvs_youla.model.ik_kernels import nearest_row_compiled
from ibvs_youla.model.ik_numerical import NEAREST_TOL, solve_near
from ibvs_youla.model.ik_ur import UrParameters, ur_branches

SEED = 20240620
POSE_TOL = 1e-9


@pytest.fixture(scope="module")
def arms():
    return {name: Arm.from_robot(name) for name in ("ur3", "ur5", "ur10", "panda", "xarm7", "z1", "kinova")}


def _wrapped(x):
    return (x + np.pi) % (2 * np.pi) - np.pi


def _random_q(arm, rng, k):
    lo, hi = np.maximum(arm.q_min, -np.pi), np.minimum(arm.q_max, np.pi)
    return lo + (hi - lo) * rng.random((k, arm.nq))


@pytest.mark.parametrize("name", ["ur3", "ur5", "ur10"])
def test_ur_closed_form_round_trips(arms, name):
    arm = arms[name]
    assert arm.ik_method == "ur"
    rng = np.random.default_rng(SEED)
    for q in _random_q(arm, rng, 25):
        T_O_C = arm.camera_pose(q)
        raw = ur_branches(arm._ur, arm.flange_pose(q), q)
        assert 1 <= raw.shape[0] <= 8
        for row in raw:  # every branch reaches the pose
            assert np.abs(arm.camera_pose(row) - T_O_C).max() <= POSE_TOL
        assert np.abs(_wrapped(raw - q)).max(axis=1).min() <= 1e-7  # one of them is q
        solutions = arm.ik(T_O_C, q_near=q)
        np.testing.assert_allclose(solutions[0], q, rtol=0, atol=1e-7)
        # the compiled nearest branch (Eq. (62) at camera rate) is ik's first row
        np.testing.assert_allclose(
            arm.ik_nearest(T_O_C, q + 0.01), arm.ik(T_O_C, q + 0.01)[0], rtol=0, atol=1e-12
        )


def test_the_ur_parameters_are_ur5s_published_dh_table(arms):
    p = arms["ur5"]._ur
    published = (-0.425, -0.39225, 0.10915, 0.09465, 0.0823)  # a2, a3, d4, d5, d6 [m] (Universal Robots)
    np.testing.assert_allclose((p.a2, p.a3, p.d4, p.d5, p.d6), published, rtol=0, atol=1e-12)
    # ur_description's base_link is the DH base turned by pi about z, 0.089159 m below joint 2's axis
    np.testing.assert_allclose(p.T_O_0[:3, :3], np.diag([-1.0, -1.0, 1.0]), atol=1e-12)
    np.testing.assert_allclose(p.T_O_0[:3, 3], [0.0, 0.0, 0.089159], atol=1e-12)


def test_ur_identification_declines_other_geometries():
    irb = Arm.irb4600()
    assert UrParameters.identify(irb.model, irb._flange_id) is None
    kinova = Arm.from_robot("kinova")
    assert kinova.ik_method == "numerical"


def test_compiled_nearest_row_is_select_branches_first_row():
    rng = np.random.default_rng(SEED + 1)
    q_min, q_max = (
        np.radians([-170, -90, -170, -400, -125, -400.0]),
        np.radians([170, 150, 75, 400, 120, 400.0]),
    )
    for _ in range(200):
        rows = rng.uniform(-np.pi, np.pi, (8, 6))
        count = int(rng.integers(0, 9))
        q_near = rng.uniform(-7, 7, 6)
        found, q = nearest_row_compiled(rows, count, q_min, q_max, q_near, 1e-9)
        expected = select_branches(rows[:count], q_min, q_max, q_near)
        assert found == (expected.shape[0] > 0)
        if found:  # the same rule; the 2*pi-wrap is written differently (a few ulps apart)
            np.testing.assert_allclose(q, expected[0], rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", ["z1", "kinova"])
def test_warm_start_recovers_the_configuration_of_a_six_joint_arm(arms, name):
    arm = arms[name]
    rng = np.random.default_rng(SEED + 2)
    regular = [
        q
        for q in _random_q(arm, rng, 40)
        if np.linalg.svd(arm.camera_jacobian(q), compute_uv=False)[-1] > 0.05
    ]
    for q in regular[:10]:  # near a singularity the solutions are not isolated
        T_O_C = arm.camera_pose(q)
        q_near = q + rng.uniform(-0.05, 0.05, arm.nq)  # a camera frame's motion, and more
        np.testing.assert_allclose(arm.ik_nearest(T_O_C, q_near), q, rtol=0, atol=1e-9)
        assert np.abs(arm.ik(T_O_C, q_near=q_near)[0] - q).max() <= 1e-9
    # from far away the warm start may land on another branch, or fail and fall back: any result is exact
    q = np.array(robots.get(name).q_home)
    T_O_C = arm.camera_pose(q)
    found = arm.ik_nearest(T_O_C, q + 1.0)
    assert np.abs(arm.camera_pose(found) - T_O_C).max() <= POSE_TOL and arm.within_limits(found)


@pytest.mark.parametrize("name", ["panda", "xarm7"])
def test_redundant_arm_ik_is_the_solution_nearest_the_warm_start(arms, name):
    """FK of the solution is the pose; q - q_near is orthogonal to the self-motion (first-order condition,
    <= NEAREST_TOL + 1e-12), and configurations moved along the self-motion manifold are farther."""
    arm = arms[name]
    rng = np.random.default_rng(SEED + 3)
    home = np.array(robots.get(name).q_home)
    for _ in range(5):
        q = np.clip(home + rng.uniform(-0.3, 0.3, arm.nq), arm.q_min + 0.05, arm.q_max - 0.05)
        T_O_C = arm.camera_pose(q)
        q_near = q + rng.uniform(-0.05, 0.05, arm.nq)
        s = arm.ik_nearest(T_O_C, q_near)
        assert np.abs(arm.camera_pose(s) - T_O_C).max() <= POSE_TOL
        J = arm.camera_jacobian(s)
        N = np.eye(arm.nq) - np.linalg.pinv(J) @ J
        assert np.abs(N @ (s - q_near)).max() <= NEAREST_TOL + 1e-12
        d_best = np.linalg.norm(s - q_near)
        assert d_best <= np.linalg.norm(q - q_near) + 1e-12  # q itself is on the manifold
        model, data = arm.model, arm.model.createData()
        for v in rng.normal(size=(4, arm.nq)):
            moved = s + 0.05 * (N @ v) / np.linalg.norm(N @ v)
            other = solve_near(
                model, data, arm._camera_id, T_O_C, moved, moved
            )  # a neighbour on the manifold
            assert other is not None and np.linalg.norm(other - q_near) >= d_best - 1e-12
        np.testing.assert_allclose(arm.ik(T_O_C, q_near=q_near)[0], s, rtol=0, atol=1e-9)


@pytest.mark.parametrize("name", ["ur5", "panda", "kinova"])
def test_an_unreachable_pose_raises_never_a_nearest_miss(arms, name):
    arm = arms[name]
    far = pin.SE3(np.eye(3), np.array([3.0, 0.0, 0.5])).homogeneous  # beyond every arm's reach
    with pytest.raises(UnreachablePoseError, match="outside the workspace"):
        arm.ik(far)
    with pytest.raises(UnreachablePoseError):
        arm.ik_nearest(far, np.array(robots.get(name).q_home))
