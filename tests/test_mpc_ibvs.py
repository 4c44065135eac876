"""MPC-based IBVS (controllers/mpc_ibvs.py): one QP per frame, on the free camera at 25 Hz.

Every scenario is deterministic (no random draw). The classical IBVS law used for comparison
is written here, v = -lambda L^+ e with L at the current features (depths from the pose that
SQPnP estimates from the image, the points back-projected) and numpy's pinv.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import qpsolvers
from scipy.spatial.transform import Rotation

import ibvs_youla as iy
from ibvs_youla.controllers import CameraFrame, CommandType, Controller, ServoTask
from ibvs_youla.controllers.mpc_ibvs import REGISTRATIONS, MpcIBVS
from ibvs_youla.estimation.monocular_pose import estimate_camera_pose
from ibvs_youla.exceptions import InvalidParameterError
from ibvs_youla.model.camera import points_interaction_matrix, project_points

POINTS_O = np.array([[-0.1, -0.1, 0], [0.1, -0.1, 0], [0.1, 0.1, 0], [-0.1, 0.1, 0]])  # [m]
SETTINGS = iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0)
NORMALIZED = iy.PinholeCamera.normalized()
LAMBDA = 0.5  # [1/s]


def T_O_C(t, theta_u_deg):
    """Camera pose from ViSP's cMo (object pose in the camera): translation [m], theta-u [deg]."""
    cMo = np.eye(4)
    cMo[:3, :3] = Rotation.from_rotvec(np.radians(theta_u_deg)).as_matrix()
    cMo[:3, 3] = t
    return np.linalg.inv(cMo)


# ViSP's tutorial-ibvs-4pts (the acceptance scenario)
TUTORIAL = iy.Scenario.free_camera(
    T_O_C_start=T_O_C([0.15, -0.1, 1.0], [10, -10, 50]),
    T_O_C_target=T_O_C([0, 0, 0.75], [0, 0, 0]),
    markers_O=POINTS_O,
)
# A 92 deg turn about the optical axis with a tilt, to a tilted target: IBVS's feature paths
# bulge out of the box spanned by the start and target features (0.3129) up to 0.3307.
BULGE = iy.Scenario.free_camera(
    T_O_C_start=T_O_C([-0.13, 0.1, 0.9], [32, -25, -92]),
    T_O_C_target=T_O_C([-0.03, -0.09, 0.61], [-16, -16, -18]),
    markers_O=POINTS_O,
)
# A 155 deg turn about the optical axis with a tilt: IBVS passes near a singular L and commands
# over 1000 m/s; the features fly out to |x| = 2.9.
WILD = iy.Scenario.free_camera(
    T_O_C_start=T_O_C([-0.28, -0.19, 1.2], [5, -35, 155]),
    T_O_C_target=T_O_C([-0.07, 0, 0.6], [13, -13, -22]),
    markers_O=POINTS_O,
)


def current_L(task, features):
    """L (8, 6) at the measured features, depths from the SQPnP pose (as ClassicalIBVS, written here)."""
    T = estimate_camera_pose(task.camera, features, task.markers_O)
    Z = ((task.markers_O - T[:3, 3]) @ T[:3, :3])[:, 2]
    P_C = np.column_stack((features.reshape(-1, 2) * (Z / task.camera.focal_length)[:, None], Z))
    return points_interaction_matrix(task.camera, P_C, False)


class IBVS(Controller):
    """v = -lambda L^+ e, L at the current features, numpy's pinv (the test's reference law)."""

    command_type = CommandType.CAMERA_TWIST
    name = "test-ibvs"

    def reset(self, task):
        super().reset(task)
        self.v = np.zeros(6)

    def update(self, frame, reading):
        L = current_L(self.task, frame.features)
        self.v = -LAMBDA * np.linalg.pinv(L) @ (frame.features - self.task.feature_target)

    def command(self, reading):
        return self.v


def run(scenario, controller, duration=30.0, camera=NORMALIZED):
    return iy.simulate(
        scenario,
        controller=controller,
        plant="free-camera",
        camera=camera,
        duration=duration,
        settings=SETTINGS,
    )


def task_of(scenario, camera=NORMALIZED, frame_period=0.04):
    """The ServoTask simulate() builds, and the features at the start."""

    def features(T):
        return project_points(camera, (POINTS_O - T[:3, 3]) @ T[:3, :3], False)

    T_t = scenario.T_O_C_target
    task = ServoTask(
        camera=camera,
        markers_O=POINTS_O,
        feature_target=features(T_t),
        T_O_C_target=T_t,
        tick_period=frame_period,
        frame_period=frame_period,
    )
    return task, features(scenario.T_O_C_start)


def first_move(controller, task, features):
    controller.reset(task)
    controller.update(CameraFrame(0.0, features, np.ones(len(task.markers_O), bool)), None)
    return controller.command(None), controller.signals()


# ---------------------------------------------------------------------- 1. acceptance
def test_tutorial_reaches_the_target_as_ibvs_does():
    result = run(TUTORIAL, MpcIBVS())
    position_mm, rotation_deg = result.final_pose_error()
    assert result.status == "complete"
    assert position_mm == pytest.approx(1.376e-4, rel=0.05)  # measured 1.3760e-4 mm
    assert rotation_deg < 1e-4  # measured 9.6e-6 deg
    # no constraint is ever active (ViSP's bounds are far), so with R = 0 every move is IBVS's
    assert result.qp_solved.min() == 1.0 and result.qp_active.max() == 0.0
    assert result.qp_infeasible_frames[-1, 0] == 0.0
    reference = run(TUTORIAL, IBVS())
    assert np.abs(result.camera_twist - reference.camera_twist).max() < 1e-9
    assert np.all(result.qp_time > 0.0) and np.median(result.qp_time) < 0.01  # [s] (about 2e-5 s)


# ---------------------------------------------------------------------- 2. IBVS as a special case
@pytest.mark.parametrize("horizon", [1, 5])
def test_unconstrained_move_with_r_zero_is_classical_ibvs(horizon):
    """With R = 0 and no active bound the first move is -lambda L^+ e (module docstring): N = 1, and N = 5."""
    task, s = task_of(TUTORIAL)
    v_ibvs = -LAMBDA * np.linalg.pinv(current_L(task, s)) @ (s - task.feature_target)
    v, signals = first_move(MpcIBVS(horizon=horizon, r_weight=0.0), task, s)
    assert np.abs(v - v_ibvs).max() < 1e-9  # measured 5e-14 (N = 1), 6e-13 (N = 5)
    assert signals["qp_solved"][0] == 1.0 and signals["qp_active"][0] == 0.0
    # R > 0 penalizes speed: a shorter move along nearly the same direction
    v_r, _ = first_move(MpcIBVS(horizon=horizon, r_weight=1e-4), task, s)
    assert np.linalg.norm(v_r) < np.linalg.norm(v_ibvs)


# ---------------------------------------------------------------------- 3. visibility
def test_features_stay_in_the_box_where_ibvs_leaves_it():
    box = 0.32  # |x|, |y| <= box (normalized); start and target features lie within 0.3129
    ibvs = run(BULGE, IBVS())
    mpc = run(BULGE, MpcIBVS(image_half_extent=box))
    ends = max(np.abs(ibvs.features[0]).max(), np.abs(ibvs.feature_target).max())
    assert ends == pytest.approx(0.3129, abs=1e-4)
    assert np.abs(ibvs.features).max() == pytest.approx(0.3307, abs=1e-4)  # IBVS leaves the box
    assert np.abs(mpc.features).max() <= box + 1e-6  # measured 0.31999991: the true features too
    assert np.count_nonzero(mpc.qp_active > 0) > 100  # the image bounds act (124 ticks)
    assert mpc.qp_infeasible_frames[-1, 0] == 0.0
    # ... and the MPC still converges, more slowly along the border
    position_mm, rotation_deg = mpc.final_pose_error()
    assert position_mm < 0.05 and rotation_deg < 0.01  # measured 0.0124 mm, 0.0011 deg
    assert ibvs.final_pose_error()[0] < position_mm  # IBVS: 0.0055 mm


def test_a_tighter_box_deadlocks_the_local_model():
    """Known limit (module docstring: local model): at 0.316 the constrained QP stalls far from the target."""
    mpc = run(BULGE, MpcIBVS(image_half_extent=0.316), duration=10.0)
    assert np.abs(mpc.features).max() <= 0.316 + 1e-6
    assert mpc.final_pose_error()[0] > 100.0  # measured 555 mm at 30 s, for N = 5, 20 and 50 alike


def test_finite_sensor_box_edge_is_half_the_sensor_less_the_margin():
    """Stereo ZED (VGA): zero motion is feasible exactly when every u, v lies within (W/2, H/2) - margin."""
    camera = iy.StereoCamera.zed2(mode="VGA")
    task, s = task_of(TUTORIAL, camera)
    rows = s.reshape(-1, 3)
    u_room = camera.sensor_width / 2 - np.abs(rows[:, :2]).max()  # [m on the sensor]
    v_room = camera.sensor_height / 2 - np.abs(rows[:, 2]).max()
    assert v_room < u_room  # v is the binding coordinate here (7.8e-4 m of room, u 1.6e-3 m)
    crawl = dict(v_max=1e-9, omega_max=1e-9, fallback="stop")  # no move can cross 1e-6 m in a frame
    for margin, solved in ((v_room - 1e-6, 1.0), (v_room + 1e-6, 0.0)):
        _, signals = first_move(MpcIBVS(margin=margin, **crawl), task, s)
        assert signals["qp_solved"][0] == solved
        assert signals["qp_infeasible_frames"][0] == 1.0 - solved
    # the stereo run itself: triangulated depths, both lenses bounded, converges
    result = run(TUTORIAL, MpcIBVS(margin=5e-4), camera=camera)
    assert result.final_pose_error()[0] < 1e-3  # measured 2e-4 mm
    assert (
        np.abs(result.features.reshape(len(result), -1, 3)[:, :, :2]).max() <= camera.sensor_width / 2 - 5e-4
    )


# ---------------------------------------------------------------------- 4. speed bounds
def test_speed_bounds_hold_and_the_servo_converges():
    v_max, omega_max = 0.05, 0.2  # IBVS's first move here has |w_z| = 0.516 rad/s
    result = run(TUTORIAL, MpcIBVS(v_max=v_max, omega_max=omega_max))
    twist = result.camera_twist
    assert np.abs(twist[:, :3]).max() <= v_max + 1e-9  # measured 1.7e-14 above
    assert np.abs(twist[:, 3:]).max() <= omega_max + 1e-9
    assert np.abs(twist[:, 5]).max() == pytest.approx(omega_max, abs=1e-9)  # the bound acts
    assert result.final_pose_error()[0] < 1e-3  # measured 2.5e-4 mm


def test_visp_bounds_tame_a_wild_ibvs_run():
    ibvs = run(WILD, IBVS())
    mpc = run(WILD, MpcIBVS())  # v_max = 1 m/s, omega_max = 90 deg/s
    assert np.abs(ibvs.camera_twist[:, :3]).max() > 100.0  # measured 1023 m/s
    assert np.abs(ibvs.features).max() > 2.0  # measured 2.90
    twist = mpc.camera_twist
    assert np.abs(twist[:, :3]).max() == pytest.approx(1.0, abs=1e-9)
    assert np.abs(twist[:, 3:]).max() <= math.radians(90.0) + 1e-9
    # the features stay within the box of the start and target features (the target's 0.3496)
    assert np.abs(mpc.features).max() <= np.abs(mpc.feature_target).max() + 1e-6
    assert mpc.final_pose_error()[0] < 0.01  # measured 1.07e-3 mm


# ---------------------------------------------------------------------- 5. infeasible QP
SLOW_BOX = dict(image_half_extent=0.25, v_max=0.1, omega_max=0.1)  # x of point 2 starts at 0.2862


def test_infeasible_qp_stop_fallback_holds_still():
    result = run(TUTORIAL, MpcIBVS(fallback="stop", **SLOW_BOX), duration=2.0)
    assert np.all(result.qp_solved == 0.0)
    assert np.all(result.camera_twist == 0.0)
    assert result.qp_infeasible_frames[-1, 0] == 51.0  # every frame of 2 s at 25 Hz
    assert np.abs(result.features - result.features[0]).max() == 0.0


def test_infeasible_qp_relax_fallback_brings_the_feature_back():
    result = run(TUTORIAL, MpcIBVS(**SLOW_BOX))
    out = np.abs(result.features[0]) > 0.25
    assert np.flatnonzero(out).tolist() == [2]  # x of point 2 (index 2: point 1's x)
    assert result.qp_infeasible_frames[-1, 0] == 9.0  # frames at t = 0 .. 0.32 s
    solved = result.qp_solved[:, 0]
    assert np.all(solved[:9] == 0.0) and np.all(solved[9:] == 1.0)
    # the relaxed QP never lets the violating feature move further out than it started
    assert np.abs(result.features[:, out]).max() == np.abs(result.features[0, out]).max()
    # inside once the QP is feasible, to the one-frame error of the local model (measured 4.3e-5)
    assert np.abs(result.features[10:]).max() == pytest.approx(0.25, abs=1e-4)
    assert result.final_pose_error()[0] < 0.01  # measured 6e-4 mm


# ---------------------------------------------------------------------- 6. bad input
@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"horizon": 0}, "horizon"),
        ({"horizon": 2.0}, "horizon"),
        ({"horizon": True}, "horizon"),
        ({"q_weight": 0.0}, "q_weight"),
        ({"r_weight": -1.0}, "r_weight"),
        ({"gain": 0.0}, "gain"),
        ({"v_max": -1.0}, "v_max"),
        ({"omega_max": float("nan")}, "omega_max"),
        ({"margin": -0.1}, "margin"),
        ({"image_half_extent": 0.0}, "image_half_extent"),
        ({"fallback": "coast"}, "fallback"),
    ],
)
def test_bad_parameters_are_refused(kwargs, name):
    with pytest.raises(InvalidParameterError) as err:
        MpcIBVS(**kwargs)
    assert err.value.name == name


def test_a_solver_that_is_not_installed_names_the_installed_ones():
    missing = next(
        s for s in ("osqp", "quadprog", "cvxopt", "no-such-solver") if s not in qpsolvers.available_solvers
    )
    with pytest.raises(InvalidParameterError, match="'daqp'") as err:
        MpcIBVS(solver=missing)
    assert err.value.name == "solver" and err.value.value == missing


def test_bad_tasks_are_refused_at_reset():
    task, _ = task_of(TUTORIAL)
    with pytest.raises(InvalidParameterError, match="gain"):  # lambda T = 30 * 0.04 = 1.2 > 1
        MpcIBVS(gain=30.0).reset(task)
    with pytest.raises(InvalidParameterError, match="below half the image extent"):
        MpcIBVS(margin=0.5).reset(task)
    with pytest.raises(InvalidParameterError, match="contains the target features"):
        MpcIBVS(image_half_extent=0.1).reset(task)  # target features reach 0.1333
    three = ServoTask(
        camera=NORMALIZED,
        markers_O=POINTS_O[:3],
        feature_target=task.feature_target[:6],
        T_O_C_target=task.T_O_C_target,
        tick_period=0.04,
        frame_period=0.04,
    )
    with pytest.raises(InvalidParameterError, match="4 or more points"):
        MpcIBVS().reset(three)
    with pytest.raises(InvalidParameterError, match="StereoCamera or a PinholeCamera"):
        MpcIBVS().reset(ServoTask("camera", POINTS_O, task.feature_target, task.T_O_C_target, 0.04, 0.04))


def test_registration_and_spec():
    (name, factory, summary), *rest = REGISTRATIONS
    assert (name, rest) == ("mpc-ibvs", [])
    controller = factory(horizon=3, margin=0.01)
    spec = controller.spec()
    assert isinstance(controller, MpcIBVS) and controller.name == "mpc-ibvs"
    assert (spec["horizon"], spec["margin"], spec["solver"], spec["fallback"]) == (3, 0.01, "daqp", "relax")
    assert spec["omega_max"] == pytest.approx(math.pi / 2)
    assert "Allibert" in summary


@pytest.mark.parametrize("horizon, r_weight", [(1, 0.0), (5, 0.0), (7, 0.3)])
def test_qp_matrices_are_the_kronecker_products_of_the_module_docstring(horizon, r_weight):
    """P, q, G, h built without np.kron are the Kronecker formulas' floats, bit for bit."""
    rng = np.random.default_rng(7)
    for scenario in (TUTORIAL, BULGE, WILD):
        task, start = task_of(scenario)
        mpc = MpcIBVS(horizon=horizon, r_weight=r_weight, q_weight=1.7)
        mpc.reset(task)
        N, T, F = horizon, 0.04, task.camera.focal_length
        a = 1.0 - mpc.gain * T
        lower = np.tril(np.ones((N, N)))
        W, w = lower.T.dot(lower), lower.T.dot(1.0 - a ** np.arange(1, N + 1))
        A_img, b_img = mpc._A_img, mpc._b_img
        for _ in range(20):
            features = start + rng.normal(0.0, 0.05, start.shape)
            L = mpc.interaction_matrix(features) / F
            e0 = (features - task.feature_target) / F
            expected = (
                1.7 * np.kron(W, L.T.dot(L)) + (r_weight / T**2) * np.eye(6 * N),
                (1.7 / T) * np.kron(w, L.T.dot(e0)),
                np.kron(lower, A_img.dot(L)),
                np.tile((b_img - A_img.dot(features / F)) / T, N),
            )
            for got, want in zip(mpc.qp(features), expected, strict=True):
                np.testing.assert_array_equal(got, want)
