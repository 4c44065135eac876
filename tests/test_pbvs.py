"""PBVS (Chaumette & Hutchinson 2006): theta u, straight-line centre, exponential decays, reach, bad input.

The free-camera checks use ViSP's tutorial-ibvs-4pts scenario at 25 Hz (T = 0.04 s, lambda = 0.5 1/s,
lambda T = 0.02). The plant holds each twist over T and integrates it by the exponential map; the
closed forms of what that does to the PBVS law are derived in ``ibvs_youla/controllers/pbvs.py``:
theta u_k = (1 - lambda T)^k theta u_0 exactly; the centre c*t_c follows the one-step map
t_(k+1) = (I - lambda T V(-lambda T theta_k u_k)) t_k, V the left Jacobian of SO(3), so it leaves the
start-goal segment by at most |t_0| lambda T theta_0 / 8 and its distance to the goal exceeds
|t_0| (1 - lambda T)^k by a relative (lambda T theta_0)^2 / 12 at most.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import ibvs_youla as iy
from ibvs_youla.analysis.metrics import pose_error_mm_deg
from ibvs_youla.controllers import ServoTask
from ibvs_youla.controllers.pbvs import PBVS, REGISTRATIONS, theta_u
from ibvs_youla.exceptions import InvalidParameterError

GAIN, PERIOD = 0.5, 0.04  # lambda [1/s], T [s]
DECAY = 1.0 - GAIN * PERIOD  # per frame
POINTS_O = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]
# Frames before the estimate's floor: near the fronto-parallel target, OpenCV's SQPnP returns the
# symmetric pose itself for displacements below ~1e-5 m, so the decays are checked while the camera
# centre is still > 1e-5 m from the goal (k < 500: 2.2e-5 m left at k = 499).
K_EXACT = 500


def T_O_C(t, theta_u_deg):
    """Camera pose from an object pose in the camera (ViSP's cMo)."""
    cMo = np.eye(4)
    cMo[:3, :3] = Rotation.from_rotvec(np.radians(theta_u_deg)).as_matrix()
    cMo[:3, 3] = t
    return np.linalg.inv(cMo)


def tutorial_scenario():
    """ViSP's tutorial-ibvs-4pts on the free camera."""
    return iy.Scenario.free_camera(
        T_O_C_start=T_O_C([0.15, -0.1, 1.0], [10, -10, 50]),
        T_O_C_target=T_O_C([0, 0, 0.75], [0, 0, 0]),
        markers_O=POINTS_O,
    )


def run_tutorial(controller, duration=30.0):
    settings = iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0)
    return iy.simulate(
        tutorial_scenario(),
        controller=controller,
        plant="free-camera",
        camera=iy.PinholeCamera.normalized(),
        duration=duration,
        settings=settings,
    )


def rodrigues(rotvec):
    """exp([w]x) by Rodrigues' formula (independent of scipy's quaternions)."""
    theta = np.linalg.norm(rotvec)
    if theta == 0.0:
        return np.eye(3)
    k = rotvec / theta
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(theta) * K + (1.0 - np.cos(theta)) * (K @ K)


@pytest.fixture(scope="module")
def tutorial_run():
    return run_tutorial(PBVS())


@pytest.fixture(scope="module")
def relative_poses(tutorial_run):
    """c*T_c (N, 4, 4) of every sample: the true current pose in the desired frame."""
    r = tutorial_run
    return np.einsum("ij,njk->nik", np.linalg.inv(r.camera_pose_target), r.camera_pose)


# ---------------------------------------------------------------------------------- theta u
@pytest.mark.parametrize("theta", [0.0, 1e-12, 1e-6, 0.5, 3.0, np.pi - 1e-6, np.pi - 1e-9])
def test_theta_u_recovers_the_rotation_vector_at_every_angle(theta):
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(50):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        worst = max(worst, float(np.abs(theta_u(rodrigues(theta * u)) - theta * u).max()))
    assert worst < 4e-15  # [rad]; acos((tr R - 1) / 2) is off by 4e-11 rad at pi - 1e-6


def test_theta_u_at_pi_is_the_axis_up_to_sign():
    u = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
    tu = theta_u(rodrigues(np.pi * u))
    assert np.linalg.norm(tu) == pytest.approx(np.pi, abs=1e-15)
    assert min(np.abs(tu - np.pi * u).max(), np.abs(tu + np.pi * u).max()) < 1e-14


# ---------------------------------------------------------------------------------- free camera
def test_pbvs_reaches_the_tutorial_target(tutorial_run):
    r = tutorial_run
    assert r.status == "complete"
    position_mm, rotation_deg = r.final_pose_error()
    # SQPnP's floor near the symmetric target (see K_EXACT), not the law: (1 - lambda T)^750 |t_0| = 9.5e-5 mm
    assert position_mm == pytest.approx(1.982e-3, rel=1e-3)
    assert rotation_deg == pytest.approx(5.619e-4, rel=1e-3)


def test_theta_u_decays_as_the_sampled_exponential(tutorial_run, relative_poses):
    tu = np.array([theta_u(T[:3, :3]) for T in relative_poses[:K_EXACT]])
    k = np.arange(K_EXACT)
    assert np.linalg.norm(tu[0]) == pytest.approx(0.906900, abs=1e-6)  # [rad]
    assert np.abs(tu - tu[0] * DECAY ** k[:, None]).max() < 1e-11  # exact but for the PnP round-off
    # the recorded error is the controller's own e = (c*t_c, theta u)
    e = tutorial_run.signals["servo_error"]
    assert np.abs(e[:K_EXACT, 3:] - tu).max() < 1e-10  # SQPnP on exact features: 7e-11 rad


def test_centre_follows_the_exp_map_one_step_closed_form(relative_poses):
    t = relative_poses[:, :3, 3]
    worst = 0.0
    for k in range(K_EXACT):
        tu = theta_u(relative_poses[k, :3, :3])
        theta = np.linalg.norm(tu)
        u = tu / theta
        K = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])  # [u]x
        phi = -GAIN * PERIOD * theta  # angle of the held rotation step about u
        V = np.eye(3) + (1.0 - np.cos(phi)) / phi * K + (phi - np.sin(phi)) / phi * (K @ K)
        worst = max(worst, float(np.abs(t[k + 1] - (t[k] - GAIN * PERIOD * V @ t[k])).max()))
    assert worst < 2e-12  # [m]


def test_centre_moves_on_the_start_goal_segment(tutorial_run, relative_poses):
    p = tutorial_run.camera_pose[:, :3, 3]
    p0, p_goal = p[0], tutorial_run.camera_pose_target[:3, 3]
    d0 = np.linalg.norm(p0 - p_goal)
    axis = (p0 - p_goal) / d0
    along = (p - p_goal) @ axis
    lateral = np.linalg.norm((p - p_goal) - np.outer(along, axis), axis=1)
    theta0 = np.linalg.norm(theta_u(relative_poses[0, :3, :3]))
    bound = d0 * GAIN * PERIOD * theta0 / 8.0  # [m], first order in lambda T
    assert d0 == pytest.approx(0.349800, abs=1e-6)
    assert bound == pytest.approx(7.931e-4, rel=1e-3)
    assert lateral.max() < bound
    assert lateral.max() == pytest.approx(4.570e-4, rel=1e-3)  # 0.13 % of the path
    assert along.min() > 0.0 and along.max() <= d0 + 1e-12  # never passes the goal or backs off


def test_distance_to_goal_decays_as_the_sampled_exponential(relative_poses):
    d = np.linalg.norm(relative_poses[:K_EXACT, :3, 3], axis=1)
    theta0 = np.linalg.norm(theta_u(relative_poses[0, :3, :3]))
    excess = d / (d[0] * DECAY ** np.arange(K_EXACT)) - 1.0
    bound = (GAIN * PERIOD * theta0) ** 2 / 12.0
    assert bound == pytest.approx(2.742e-5, rel=1e-3)
    assert excess.min() >= -1e-12  # never below the exponential
    assert excess.max() < bound
    assert excess.max() == pytest.approx(9.156e-6, rel=1e-3)


# ---------------------------------------------------------------------------------- stereo arm
def test_stereo_physical_2_on_the_kinematic_arm():
    r = iy.simulate(iy.scenarios.physical(2), controller=PBVS(), plant="kinematic", duration=10.0)
    assert r.status == "complete"
    start_mm, start_deg = pose_error_mm_deg(r.camera_pose[0], r.camera_pose_target)
    end_mm, end_deg = r.final_pose_error()
    assert (start_mm, start_deg) == pytest.approx((109.739, 7.0503), rel=1e-4)
    assert (end_mm, end_deg) == pytest.approx((0.76035, 0.045566), rel=1e-3)
    e = r.signals["servo_error"]
    # exp(-lambda 10 s) = 6.74e-3; the inner loop's lag of the kinematic arm slows it slightly
    assert np.linalg.norm(e[-1]) / np.linalg.norm(e[0]) == pytest.approx(6.673e-3, rel=1e-3)


# ---------------------------------------------------------------------------------- registry, input
def test_registration_and_spec():
    ((name, factory, summary),) = REGISTRATIONS
    controller = factory(gain=0.8)
    assert name == "pbvs" == controller.name and isinstance(controller, PBVS) and "Chaumette" in summary
    spec = json.loads(json.dumps(controller.spec()))
    assert spec["gain"] == 0.8 and spec["name"] == "pbvs"
    assert PBVS().gain == 0.5


@pytest.mark.parametrize("gain", [0.0, -1.0, float("nan"), float("inf"), "fast", None])
def test_bad_gain(gain):
    with pytest.raises(InvalidParameterError, match=r"gain: .*valid values are a finite number > 0 1/s"):
        PBVS(gain=gain)


def test_gain_beyond_the_sampled_stability_limit():
    with pytest.raises(InvalidParameterError, match=r"gain: received 50\.0.*\(0, 50\) 1/s"):
        run_tutorial(PBVS(gain=50.0), duration=0.04)


def test_monocular_camera_with_three_markers():
    task = ServoTask(
        camera=iy.PinholeCamera.normalized(),
        markers_O=POINTS_O[:3],
        feature_target=np.zeros(6),
        T_O_C_target=T_O_C([0, 0, 0.75], [0, 0, 0]),
        tick_period=PERIOD,
        frame_period=PERIOD,
    )
    with pytest.raises(InvalidParameterError, match=r"task.markers_O: received '3 markers'.*four or more"):
        PBVS().reset(task)
