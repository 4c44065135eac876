"""A sensor that measures depth (``sensor="depth"``, an RGB-D camera), its noise, and the laws that use it.

ViSP's tutorial-ibvs-4pts case (normalized camera, the four corners of a 20 cm square, 25 Hz, free
camera) unless a test says otherwise. The laws' references are written here from the equations:
the classical point interaction matrix at the true depths (Chaumette & Hutchinson 2006, Eq. (11))
and the pose of the camera, not the library's own kernels.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import ibvs_youla as iy
from ibvs_youla.controllers import ServoTask, make
from ibvs_youla.exceptions import InvalidParameterError
from ibvs_youla.simulation.disturbances import Disturbances
from ibvs_youla.simulation.sensor import MarkerSensor

SQUARE_O = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]
SETTINGS = iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0)
CAMERA = iy.PinholeCamera.normalized()


def T_O_C(t, theta_u_deg):
    """Camera pose from the object pose in the camera (ViSP's cMo: translation, theta-u [deg])."""
    cMo = np.eye(4)
    cMo[:3, :3] = Rotation.from_rotvec(np.radians(theta_u_deg)).as_matrix()
    cMo[:3, 3] = t
    return np.linalg.inv(cMo)


START, TARGET = T_O_C([0.15, -0.1, 1.0], [10, -10, 50]), T_O_C([0, 0, 0.75], [0, 0, 0])
SCENARIO = iy.Scenario.free_camera(T_O_C_start=START, T_O_C_target=TARGET, markers_O=SQUARE_O)


def P_C_of(T):
    return (SQUARE_O - T[:3, 3]) @ T[:3, :3]


def simulate(controller="ibvs-current", duration=0.4, **kwargs):
    return iy.simulate(
        SCENARIO,
        controller,
        plant="free-camera",
        camera=CAMERA,
        duration=duration,
        settings=SETTINGS,
        **kwargs,
    )


def task_with(markers_O=SQUARE_O):
    truth = MarkerSensor(CAMERA, SQUARE_O)
    return ServoTask(
        camera=CAMERA,
        markers_O=markers_O,
        feature_target=truth.features_at(TARGET),
        T_O_C_target=TARGET,
        tick_period=0.04,
        frame_period=0.04,
    )


def law_at_true_depths(T, gain=0.5):
    """-lambda L^+ e with L the classical point matrix at the true (x, y, Z) (Eq. (11)), built here."""
    P, P_t = P_C_of(T), P_C_of(TARGET)
    s, s_t = (P[:, :2] / P[:, 2:]).ravel(), (P_t[:, :2] / P_t[:, 2:]).ravel()
    return -gain * np.linalg.pinv(L_at_true_depths(T), rcond=1e-6) @ (s - s_t)


def test_the_depth_sensor_reports_each_points_depth():
    T = T_O_C([0.05, 0.02, 0.9], [5, -8, 30])
    ideal, depth = MarkerSensor(CAMERA, SQUARE_O), MarkerSensor(CAMERA, SQUARE_O).with_depth()
    a, b = ideal.measure(T, 0.0), depth.measure(T, 0.0)
    assert a.depth is None
    np.testing.assert_array_equal(a.features, b.features)  # the same projection
    np.testing.assert_allclose(b.depth, P_C_of(T)[:, 2], rtol=0, atol=1e-15)  # Z_C [m]
    assert depth.spec() == {"name": "depth"} and ideal.spec() == {"name": "ideal"}


def test_a_stereo_camera_has_no_depth_sensor():
    with pytest.raises(InvalidParameterError, match="PinholeCamera"):
        MarkerSensor(iy.StereoCamera.zed2(), SQUARE_O[:3], depth=True)
    with pytest.raises(InvalidParameterError, match="depth"):
        iy.simulate(
            iy.scenarios.physical(2), "ibvs-current", duration=0.01, plant="kinematic", sensor="depth"
        )


def L_at_true_depths(T):
    """The classical point interaction matrix (8, 6) at the true (x, y, Z) (Eq. (11)), built here."""
    P = P_C_of(T)
    x, y, Z = P[:, 0] / P[:, 2], P[:, 1] / P[:, 2], P[:, 2]
    L = np.zeros((8, 6))
    L[0::2] = np.column_stack((-1 / Z, 0 * Z, x / Z, x * y, -(1 + x * x), y))
    L[1::2] = np.column_stack((0 * Z, -1 / Z, y / Z, 1 + y * y, -x * y, -x))
    return L


@pytest.mark.parametrize("name", ["ibvs-current", "ibvs-mean", "mpc-ibvs"])
def test_current_depth_laws_use_measured_depths_not_their_model(name):
    """With markers believed 20 % too large, PnP's depths are wrong; measured depths do not depend on it.

    L at the current features is L at the true depths when the frame carries them, whatever the
    belief; without them it follows the belief (the monocular PnP on the believed markers).
    """
    T = T_O_C([0.05, 0.02, 0.9], [5, -8, 30])
    frame = MarkerSensor(CAMERA, SQUARE_O).with_depth().measure(T, 0.0)
    controller = make(name)
    controller.reset(task_with(1.2 * SQUARE_O))
    by_depth = controller.interaction_matrix(frame.features, frame.depth)
    np.testing.assert_allclose(by_depth, L_at_true_depths(T), rtol=0, atol=1e-14)
    assert np.abs(controller.interaction_matrix(frame.features) - by_depth).max() > 1e-2  # PnP: the belief


@pytest.mark.parametrize("name", ["ibvs-polar", "ibvs-partitioned"])
def test_the_other_point_laws_use_measured_depths_too(name):
    """Polar and partitioned IBVS take L's depths from the frame when it carries them: depths 5 %
    long give another twist, and a frame without depths gives the one of the controller's model."""
    T = T_O_C([0.05, 0.02, 0.9], [5, -8, 30])
    frame = MarkerSensor(CAMERA, SQUARE_O).with_depth().measure(T, 0.0)
    controller = make(name)
    controller.reset(task_with())
    controller.update(frame, None)
    by_depth = controller.command(None).copy()
    controller.update(frame._replace(depth=frame.depth * 1.05), None)
    assert np.abs(controller.command(None) - by_depth).max() > 1e-4
    controller.update(frame._replace(depth=None), None)  # PnP on the true markers: the true depths
    np.testing.assert_allclose(controller.command(None), by_depth, rtol=0, atol=1e-9)


def test_ibvs_current_with_measured_depths_is_the_law_at_the_true_depths():
    T = T_O_C([0.05, 0.02, 0.9], [5, -8, 30])
    controller = make("ibvs-current")
    controller.reset(task_with())
    controller.update(MarkerSensor(CAMERA, SQUARE_O).with_depth().measure(T, 0.0), None)
    np.testing.assert_allclose(controller.command(None), law_at_true_depths(T), rtol=0, atol=1e-13)


@pytest.mark.parametrize("name", ["pbvs", "2.5d"])
def test_pose_laws_take_the_pose_from_measured_depths(name):
    """PBVS and 2.5-D fit the back-projected points to the markers (Kabsch): the true pose, no PnP."""
    T = T_O_C([0.05, 0.02, 0.9], [5, -8, 30])
    frame = MarkerSensor(CAMERA, SQUARE_O).with_depth().measure(T, 0.0)
    controller = make(name)
    controller.reset(task_with())
    np.testing.assert_allclose(controller.pose_estimator(frame.features, frame.depth), T, rtol=0, atol=1e-14)
    controller.update(frame, None)
    by_depth = controller.command(None).copy()
    controller.update(frame._replace(depth=frame.depth * 1.05), None)  # depths 5 % long: another pose
    assert np.abs(controller.command(None) - by_depth).max() > 1e-3


def test_a_depth_run_reaches_the_target_as_the_monocular_one():
    """Exact depths and exact PnP poses give the same run (both exact), to rounding; recorded as 'depth'."""
    with_depth, monocular = simulate(duration=4.0, sensor="depth"), simulate(duration=4.0)
    assert with_depth.status == "complete" and with_depth.metadata["spec"]["sensor"] == {"name": "depth"}
    assert "sensor" not in monocular.metadata["spec"]  # undisturbed, unchosen: metadata as before
    np.testing.assert_allclose(with_depth.camera_pose, monocular.camera_pose, rtol=0, atol=1e-11)
    error = np.linalg.norm(with_depth.features - with_depth.feature_target, axis=1)
    assert error[-1] < 0.15 * error[0]  # 4 s at lambda = 0.5: e^-2 = 0.135 for an exponential decay


def test_depth_noise_is_the_fifth_stream_times_z_squared():
    """sigma(Z) = depth_noise_m Z^2, independent N(0, 1) draws from SeedSequence(seed)'s fifth stream."""
    d = Disturbances(depth_noise_m=0.004, seed=3)
    truth = MarkerSensor(CAMERA, SQUARE_O)
    sensor = d.wrap_sensor(truth.with_depth(), *d.generators()[:2])
    draws = np.random.default_rng(np.random.SeedSequence(3).spawn(5)[4]).standard_normal((3, 4))
    for k, T in enumerate((START, TARGET, T_O_C([0.1, 0.0, 1.4], [0, 20, 0]))):
        frame = sensor.measure(T, 0.04 * k)
        Z = P_C_of(T)[:, 2]
        np.testing.assert_allclose(frame.depth, Z + 0.004 * Z**2 * draws[k], rtol=0, atol=1e-15)
        np.testing.assert_array_equal(frame.features, truth.measure(T, 0.0).features)  # pixels untouched
    assert d.to_dict() == {"depth_noise_m": 0.004, "seed": 3}


def test_depth_noise_needs_a_depth_sensor():
    with pytest.raises(InvalidParameterError, match="depth_noise_m"):
        simulate(disturbances=Disturbances(depth_noise_m=0.01))
    with pytest.raises(InvalidParameterError, match="depth_noise_m"):
        Disturbances(depth_noise_m=-0.01)
    with pytest.raises(InvalidParameterError, match="rendered"):  # rendered images have no depth channel
        iy.simulate(
            SCENARIO,
            "ibvs-current",
            duration=0.04,
            plant="free-camera",
            camera=iy.PinholeCamera.zed2(),
            settings=SETTINGS,
            sensor="depth",
            disturbances=Disturbances(rendered_images=True),
        )


def test_a_dropped_marker_has_no_depth_either():
    d = Disturbances(dropout_probability=0.9, seed=1)
    sensor = d.wrap_sensor(MarkerSensor(CAMERA, SQUARE_O).with_depth(), *d.generators()[:2])
    sensor.measure(START, 0.0)  # the first frame is complete
    frame = sensor.measure(START, 0.04)
    missing = ~frame.visible
    assert missing.any()
    assert np.isnan(frame.depth[missing]).all() and np.isfinite(frame.depth[~missing]).all()


def test_a_controller_is_given_the_depths_the_sensor_measured():
    """The plug-in loop hands each controller its own copy of the frame, depths included (not None)."""
    from servo_helpers import ConstantTwist

    recorder = ConstantTwist((0.02, 0.0, 0.0, 0.0, 0.0, 0.1))
    result = iy.simulate(
        SCENARIO, recorder, plant="free-camera", camera=CAMERA, duration=0.2, settings=SETTINGS, sensor="depth"
    )
    assert len(recorder.frames) == len(result) == 6
    for frame, T in zip(recorder.frames, result.camera_pose, strict=True):
        np.testing.assert_allclose(frame.depth, P_C_of(T)[:, 2], rtol=0, atol=1e-15)
