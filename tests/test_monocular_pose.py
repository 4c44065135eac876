"""Monocular PnP through OpenCV: exact poses from exact features, the stereo path, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from ibvs_youla.estimation.monocular_pose import PNP_METHODS, estimate_camera_pose, estimate_pose_monocular
from ibvs_youla.exceptions import DegenerateMarkersError, InvalidArrayError, InvalidParameterError
from ibvs_youla.model.camera import PinholeCamera, StereoCamera
from ibvs_youla.simulation.sensor import MarkerSensor

PLANAR = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]
SEED = 20261201


def random_pose(rng):
    """A camera 0.6-1.4 m from the points, looking at them from within 40 deg of their normal."""
    from scipy.spatial.transform import Rotation

    cMo = np.eye(4)
    cMo[:3, :3] = Rotation.from_rotvec(rng.uniform(-0.7, 0.7, 3)).as_matrix()
    cMo[:3, 3] = [*rng.uniform(-0.15, 0.15, 2), rng.uniform(0.6, 1.4)]
    return np.linalg.inv(cMo)


# Worst pose error on 50 seeded poses and exact features [m or rotation-matrix entries]: SQPnP
# and IPPE are closed form (round-off), EPnP is approximate, "iterative" stops at its tolerance.
TOLERANCE = {"sqpnp": 1e-9, "ippe": 1e-12, "epnp": 1e-7, "iterative": 1e-5}


CUBE = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (-0.1, 0.1)])  # [m]


@pytest.mark.parametrize("method", PNP_METHODS)
@pytest.mark.parametrize(
    "camera", [PinholeCamera.normalized(), PinholeCamera.zed2()], ids=["normalized", "zed2"]
)
def test_pnp_recovers_the_pose_from_exact_features(camera, method):
    """Four coplanar points for every method but EPnP, which gets the eight corners of a cube.

    EPnP with four (nearly) coplanar points is not reliable (the next test), which is why SQPnP
    is the default.
    """
    rng = np.random.default_rng(SEED)
    points = CUBE if method == "epnp" else PLANAR
    sensor = MarkerSensor(camera, points)
    worst = 0.0
    for _ in range(50):
        T_O_C = random_pose(rng)
        estimate = estimate_pose_monocular(camera, sensor.measure(T_O_C, 0.0).features, points, method)
        worst = max(worst, np.abs(estimate - T_O_C).max())
    assert worst < TOLERANCE[method]


def test_epnp_on_four_coplanar_points_is_the_finding_stated_above():
    rng = np.random.default_rng(SEED)
    camera = PinholeCamera.normalized()
    sensor = MarkerSensor(camera, PLANAR)
    errors = []
    for _ in range(50):
        T_O_C = random_pose(rng)
        estimate = estimate_pose_monocular(camera, sensor.measure(T_O_C, 0.0).features, PLANAR, "epnp")
        errors.append(np.abs(estimate - T_O_C).max())
    assert sum(e > 1.0 for e in errors) == 5 and sum(e < 1e-6 for e in errors) == 45


def test_non_planar_points_and_the_stereo_path():
    rng = np.random.default_rng(SEED + 1)
    points = PLANAR + np.array([0.0, 0.0, 1.0]) * rng.uniform(-0.05, 0.05, (4, 1))
    T_O_C = random_pose(rng)
    mono = MarkerSensor(PinholeCamera.normalized(), points).measure(T_O_C, 0.0).features
    np.testing.assert_allclose(
        estimate_camera_pose(PinholeCamera.normalized(), mono, points), T_O_C, rtol=0, atol=1e-9
    )
    stereo = StereoCamera.zed2()
    features = MarkerSensor(stereo, points[:3]).measure(T_O_C, 0.0).features
    np.testing.assert_allclose(estimate_camera_pose(stereo, features, points[:3]), T_O_C, rtol=0, atol=1e-9)


def test_bad_input_is_named():
    camera = PinholeCamera.normalized()
    with pytest.raises(InvalidArrayError, match="four or more points"):
        estimate_pose_monocular(camera, np.zeros(6), PLANAR[:3])
    with pytest.raises(InvalidArrayError, match="features"):
        estimate_pose_monocular(camera, np.zeros(7), PLANAR)
    with pytest.raises(InvalidArrayError, match="non-finite"):
        estimate_pose_monocular(camera, np.full(8, np.nan), PLANAR)
    with pytest.raises(DegenerateMarkersError, match="collinear"):
        estimate_pose_monocular(camera, np.zeros(8), np.outer(np.arange(4.0), [1.0, 0.0, 0.0]))
    with pytest.raises(InvalidParameterError, match="method"):
        estimate_pose_monocular(camera, np.zeros(8), PLANAR, method="p3p-magic")
    with pytest.raises(InvalidParameterError, match="camera"):
        estimate_camera_pose("zed", np.zeros(8), PLANAR)


def test_the_pose_estimator_gives_estimate_camera_pose_and_solves_once_per_image():
    """CameraPoseEstimator(camera, P, **options)(features) is estimate_camera_pose(camera, features, P,
    **options), bit for bit, for both cameras; the same image again returns that pose without a
    second solve; another shape of features is refused by name."""
    from unittest import mock

    from ibvs_youla.estimation import monocular_pose
    from ibvs_youla.estimation.monocular_pose import CameraPoseEstimator

    rng = np.random.default_rng(SEED + 1)
    for camera, P, options in (
        (PinholeCamera.normalized(), PLANAR, {}),
        (StereoCamera.zed2(), PLANAR + np.array([0.0, 0.0, 2.0]), {"allow_behind": False}),
    ):
        estimator = CameraPoseEstimator(camera, P, **options)
        sensor = MarkerSensor(camera, P)
        for _ in range(20):
            T_O_C = random_pose(rng)  # looking at the square (2 m in front of a stereo camera at about 0)
            if isinstance(camera, StereoCamera):
                T_O_C = np.eye(4)
                T_O_C[:3, 3] = rng.uniform(-0.1, 0.1, 3)
            features = sensor.features_at(T_O_C)
            np.testing.assert_array_equal(
                estimator(features), estimate_camera_pose(camera, features, P, **options)
            )
    estimator = CameraPoseEstimator(PinholeCamera.normalized(), PLANAR)
    features = MarkerSensor(PinholeCamera.normalized(), PLANAR).features_at(random_pose(rng))
    first = estimator(features)
    with mock.patch.object(monocular_pose, "_solve_pnp_C", side_effect=AssertionError("solved again")):
        np.testing.assert_array_equal(estimator(features.copy()), first)
    with pytest.raises(InvalidArrayError, match=r"features: received an array of shape \(7,\)"):
        estimator(np.zeros(7))


@pytest.mark.parametrize("method", ["sqpnp", "ippe"])
def test_marker_depths_are_the_points_in_the_estimated_pose_solved_once(method):
    """CameraPoseEstimator.marker_depths(features): Z_C of the known points in the estimated pose, from
    the PnP's [R_C_ref | t_C] directly; equal to the round trip through T_ref_C and its inverse to
    rounding (measured 2.2e-16 m on these poses), and the truth on exact features (SQPnP 5.4e-12 m,
    IPPE 8.9e-16 m; the bound is the SQPnP tolerance above). The pose and the
    depths of one image share one solve (the hybrid law asks both)."""
    from unittest import mock

    from ibvs_youla._geometry import inverse_pose, transform_points
    from ibvs_youla.estimation import monocular_pose
    from ibvs_youla.estimation.monocular_pose import CameraPoseEstimator

    camera = PinholeCamera.normalized()
    estimator = CameraPoseEstimator(camera, PLANAR, method=method)
    sensor = MarkerSensor(camera, PLANAR)
    rng = np.random.default_rng(SEED + 2)
    for _ in range(20):
        T_O_C = random_pose(rng)
        features = sensor.features_at(T_O_C)
        Z = estimator.marker_depths(features)
        with mock.patch.object(monocular_pose, "_solve_pnp_C", side_effect=AssertionError("solved again")):
            round_trip = transform_points(inverse_pose(estimator(features.copy())), PLANAR)[:, 2]
        np.testing.assert_allclose(Z, round_trip, rtol=0, atol=1e-14)
        np.testing.assert_allclose(Z, transform_points(inverse_pose(T_O_C), PLANAR)[:, 2], rtol=0, atol=1e-8)
    with pytest.raises(InvalidArrayError, match=r"features: received an array of shape \(7,\)"):
        estimator.marker_depths(np.zeros(7))
    with pytest.raises(InvalidParameterError, match="a stereo camera triangulates its depths"):
        stereo = CameraPoseEstimator(StereoCamera.zed2(), PLANAR + np.array([0.0, 0.0, 2.0]))
        stereo.marker_depths(np.zeros(12))
