"""Polar-coordinate IBVS (Iwatsuki & Okiyama 2005; Corke's IBVS_polar): features, rows, behaviour.

Free camera at 25 Hz and the normalized monocular camera unless a test says otherwise
(tests/feature_laws.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import ibvs_youla as iy
from feature_laws import (
    LAMBDA,
    SQUARE_O,
    T_O_C,
    TARGET,
    TILT_START,
    TILT_TARGET,
    TUTORIAL_START,
    Z_TARGET,
    P_C_of,
    T,
    rotation_angle_deg,
    run,
    twist_differences,
)
from ibvs_youla import controllers, scenarios
from ibvs_youla.controllers import ServoTask
from ibvs_youla.controllers.polar import (
    REGISTRATIONS,
    PolarIBVS,
    lens_points,
    lens_rows,
    polar_error,
    polar_features,
    polar_interaction_matrix,
)
from ibvs_youla.exceptions import FeatureSingularityError, InvalidParameterError
from ibvs_youla.model.camera import points_interaction_matrix, project_points


@pytest.mark.parametrize(
    "camera", [iy.PinholeCamera.normalized(), iy.StereoCamera.zed2()], ids=["mono", "stereo"]
)
def test_interaction_matrix_equals_finite_differences(camera):
    """L_(r,phi) of each lens against central differences (h = 1e-6) under a camera twist.

    Five seeded points 1-3 m away; the phi differences wrapped. Measured: largest deviation
    3.1e-10 (mono) and 4.4e-9 (stereo) of the largest entry, and 100 times that with h = 1e-5:
    the h^2 truncation of the differences, not an error of the rows.
    """
    rng = np.random.default_rng(24)
    rows, F = (3, camera.focal_length) if isinstance(camera, iy.StereoCamera) else (2, 1.0)

    def features(P_C):
        return polar_features(lens_points(project_points(camera, P_C, False), rows, F))

    for _ in range(5):
        P_C = np.column_stack((rng.uniform(-0.5, 0.5, (5, 2)), rng.uniform(1.0, 3.0, 5)))
        L = polar_interaction_matrix(
            features(P_C), *lens_rows(points_interaction_matrix(camera, P_C, False), rows, F)
        )
        L_fd = twist_differences(features, P_C, difference=lambda a, b: polar_error(a, b, "per-point"))
        assert L.shape == (2 * (rows - 1) * 5, 6)
        assert np.abs(L - L_fd).max() < 1e-8 * np.abs(L).max()


def test_rows_in_closed_form():
    """The derived rows of the module docstring, at one point.

    L_r = [-c/Z, -s/Z, r/Z, (1+r^2) s, -(1+r^2) c, 0], L_phi = [s/(rZ), -c/(rZ), 0, c/r, s/r, -1].
    """
    x, y, Z = 0.3, -0.2, 1.7
    r, c, s = math.hypot(x, y), x / math.hypot(x, y), y / math.hypot(x, y)
    P_C = np.array([[x * Z, y * Z, Z]])
    camera = iy.PinholeCamera.normalized()
    L = polar_interaction_matrix(
        polar_features(np.array([[x, y]])), *lens_rows(points_interaction_matrix(camera, P_C, False), 2, 1.0)
    )
    expected = [
        [-c / Z, -s / Z, r / Z, (1 + r * r) * s, -(1 + r * r) * c, 0.0],
        [s / (r * Z), -c / (r * Z), 0.0, c / r, s / r, -1.0],
    ]
    assert L == pytest.approx(np.array(expected), abs=1e-15)


def test_angle_wrapping_joint_and_per_point():
    """Per point: each error into [-pi, pi); joint: about the errors' circular mean, so all turn one way."""
    s_target = np.array([1.0, 0.0, 1.0, 0.5])
    d = np.array([math.pi - 1e-9, math.pi + 1e-9])  # a half turn seen through round-off
    s = s_target + np.array([0.0, d[0], 0.0, d[1]])
    per_point = polar_error(s, s_target, "per-point")[1::2]
    joint = polar_error(s, s_target, "joint")[1::2]
    assert per_point == pytest.approx([math.pi - 1e-9, -math.pi + 1e-9], abs=1e-12)  # opposite turns
    assert np.sign(joint[0]) == np.sign(joint[1]) and np.abs(joint) == pytest.approx([math.pi] * 2, abs=2e-9)
    small = s_target + np.array([0.0, 0.3, 0.0, -6.0])  # away from the cut both rules agree
    assert polar_error(small, s_target, "joint") == pytest.approx(polar_error(small, s_target, "per-point"))
    assert polar_error(small, s_target)[3] == pytest.approx(2.0 * math.pi - 6.0)


def test_pi_rotation_turns_in_place_with_the_angle_decaying_geometrically():
    """The start turned by pi about the optical axis at the target's depth: a pure roll, no retreat.

    Every r error is 0 and every (jointly wrapped) phi error the same angle: e is pi times the
    w_z column of L, so L^+ e is a pure turn, w_z = +-lambda pi, and held over T it turns every
    phi by the same amount. The angle left after k frames is exactly pi (1 - lambda T)^k (checked
    to 1e-9 over the 751 samples of 30 s, ending at 180 x 0.98^750 = 4.73e-5 deg); the depth
    stays 0.75 m to 1e-12 and never grows past the start, and the translation stays below 1e-12.
    """
    result = run("ibvs-polar", T_O_C([0, 0, Z_TARGET], [0, 0, 180]))
    assert result.status == "complete"
    angle = np.array([rotation_angle_deg(R.T @ TARGET[:3, :3]) for R in result.camera_pose[:, :3, :3]])
    k = np.arange(len(angle))
    assert angle == pytest.approx(180.0 * (1.0 - LAMBDA * T) ** k, rel=1e-9)
    depth = -result.camera_pose[:, 2, 3]
    assert np.abs(depth - Z_TARGET).max() < 1e-12 and depth.max() <= Z_TARGET + 1e-12
    twist = result.signals["camera_twist"]
    assert np.abs(twist[:, :5]).max() < 1e-12
    assert abs(twist[0, 5]) == pytest.approx(LAMBDA * math.pi, rel=1e-12)
    mm, deg = result.final_pose_error()
    assert mm < 1e-9 and deg == pytest.approx(180.0 * 0.98**750, rel=1e-9)


def test_per_point_wrapping_splits_the_half_turn():
    """With the toolbox's per-point wrapping, the same exact half turn moves the camera off its axis.

    The start's rotation matrix (scipy's, of theta-u = pi e_z) rounds so that two of the square's
    four phi errors wrap to +pi and two to -pi: the first twist asks w_z = -lambda pi / 2 and
    4.6 m/s sideways (measured); the depth leaves 0.75 m (the joint rule keeps it to 1e-12).
    """
    start = T_O_C([0, 0, Z_TARGET], [0, 0, 180])
    result = run(PolarIBVS(wrap="per-point"), start, duration=2.0)
    first = result.signals["camera_twist"][0]
    assert abs(first[5]) == pytest.approx(LAMBDA * math.pi / 2.0, rel=1e-9)
    assert np.abs(first[:2]).max() == pytest.approx(4.5749443, rel=1e-6)
    assert np.abs(-result.camera_pose[:, 2, 3] - Z_TARGET).max() > 0.1


def test_tilted_square_local_minimum_traps_polar_ibvs_too():
    """From the tilted-square start where ibvs-current stops (tests/test_ibvs.py), polar IBVS also stops.

    It ends 1077 mm / 89.8 deg from the target with the twist below 1e-7 and L^T e = 0 to 1e-6
    relative: a stationary point of ||e||^2 in the polar features, not the target.
    """
    controller = PolarIBVS()
    result = run(controller, TILT_START, TILT_TARGET)
    assert result.status == "complete"
    assert result.final_pose_error() == pytest.approx((1077.35248, 89.849026), rel=1e-6)
    assert np.abs(result.signals["camera_twist"][-1]).max() < 1e-7
    features = result.frame_features[-1]
    L = controller.interaction_matrix(features)
    e = polar_error(polar_features(lens_points(features, 2, 1.0)), controller.feature_target)
    assert np.linalg.norm(L.T @ e) < 1e-6 * np.linalg.norm(L, 2) * np.linalg.norm(e)


def test_tutorial_case_reaches_the_target():
    """ViSP's tutorial-ibvs-4pts start: within 1e-2 mm and 1e-3 deg after 30 s (measured 6.4e-3 mm)."""
    mm, deg = run("ibvs-polar", TUTORIAL_START).final_pose_error()
    assert mm == pytest.approx(6.3597e-3, rel=1e-3) and deg < 1e-3


@pytest.mark.parametrize("plant", ["kinematic", "dynamic"])
def test_stereo_physical_2_on_the_arm(plant, arm):
    """physical-2 (three markers, ZED 2 stereo, both lenses' polar features), 5 s on each arm plant.

    The image error falls to 0.0773 of its start (e^(-2.5) = 0.082), the same to 1.4e-4 on the
    kinematic arm and through the paper's inner loop (pinned, measured).
    """
    result = iy.simulate(
        scenarios.physical(2), controllers.make("ibvs-polar"), duration=5.0, plant=plant, arm=arm
    )
    assert result.status == "complete"
    e0, e1 = (np.linalg.norm(result.feature_error[i]) for i in (0, -1))
    assert e1 / e0 == pytest.approx({"kinematic": 0.0772999, "dynamic": 0.0773106}[plant], rel=2e-3)


def test_bad_input_is_rejected_with_what_is_valid():
    with pytest.raises(InvalidParameterError, match="wrap"):
        PolarIBVS(wrap="mean")
    with pytest.raises(InvalidParameterError, match="gain"):
        PolarIBVS(gain=0.0)
    with pytest.raises(FeatureSingularityError, match="principal point") as err:
        polar_interaction_matrix(np.array([0.0, 0.0, 1.0, 0.5]), np.ones((2, 6)), np.ones((2, 6)))
    assert err.value.feature == "phi" and err.value.value == 0.0
    on_axis = np.vstack((SQUARE_O, [0.0, 0.0, 0.0]))  # a fifth marker on the target's optical axis
    task = ServoTask(
        camera=iy.PinholeCamera.normalized(),
        markers_O=on_axis,
        feature_target=project_points(iy.PinholeCamera.normalized(), P_C_of(TARGET, on_axis), False),
        T_O_C_target=TARGET,
        tick_period=T,
        frame_period=T,
    )
    with pytest.raises(FeatureSingularityError, match="principal point"):
        PolarIBVS().reset(task)


def test_a_point_at_the_principal_point_ends_the_run_with_estimate_failed():
    """phi has no value there: the loop ends the run (``estimate_failed``), the reason named."""
    markers = np.vstack((SQUARE_O, [0.05, 0.0, 0.0]))
    start = T_O_C([-0.05, 0.0, Z_TARGET], [0, 0, 0])  # the fifth marker on the start's optical axis
    result = run("ibvs-polar", start, markers_O=markers, duration=1.0)
    assert result.status == "estimate_failed" and len(result) == 0  # at the first frame
    assert "principal point" in result.metadata["error"] and "PolarIBVS" in result.metadata["error"]


def test_registration_and_spec():
    ((name, factory, summary),) = REGISTRATIONS
    controller = factory(gain=0.8, wrap="per-point")
    assert name == "ibvs-polar" == controller.name and "Iwatsuki" in summary
    assert controller.command_type is controllers.CommandType.CAMERA_TWIST
    assert controller.spec()["gain"] == 0.8 and controller.spec()["wrap"] == "per-point"
