"""The compiled depths from OpenCV's PnP (rvec, tvec): Rodrigues as OpenCV evaluates it, then r_3 . P + t_z.

``pnp_depths`` is pinned bit for bit to ``cv2.Rodrigues``'s third row, and to numpy's
``P @ R[2] + t[2]`` (the reference, :meth:`CameraPoseEstimator.marker_depths`) to rounding;
``CameraPoseEstimator.write_marker_depths``, which the compiled frame path calls, gives
``marker_depths``'s depths, its IPPE fallback and its errors.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla.estimation.monocular_pose import CameraPoseEstimator
from ibvs_youla.estimation.pnp_kernels import pnp_depths
from ibvs_youla.exceptions import PoseEstimationError
from ibvs_youla.simulation.sensor import MarkerSensor

SQUARE = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]
SEED = 20261203


def rotation_vectors(rng, count):
    """Rotation vectors of angles across (0, pi) and down to 1e-20 rad (below DBL_EPSILON: R = I)."""
    for k in range(count):
        angle = rng.uniform(0.0, np.pi) if k % 3 else 10.0 ** rng.uniform(-20.0, -1.0)
        axis = rng.normal(size=3)
        yield (angle * axis / np.linalg.norm(axis)).reshape(3, 1)
    yield np.zeros((3, 1))
    yield np.array([[np.pi], [0.0], [0.0]])


def test_the_rotation_row_is_opencvs_rodrigues_bit_for_bit():
    """With P = I and t = 0 the depths are the third row of R itself: equal to cv2.Rodrigues's, to the bit
    (the same formula in the same order; 2,002 rotation vectors)."""
    rng = np.random.default_rng(SEED)
    out = np.empty(3)
    for rvec in rotation_vectors(rng, 2000):
        assert pnp_depths(rvec, np.zeros((3, 1)), np.eye(3), out)
        np.testing.assert_array_equal(out, cv2.Rodrigues(rvec)[0][2], err_msg=str(rvec.ravel()))


def test_the_depths_are_the_points_in_the_pose_as_numpy_sums_them():
    """Z_i = r_3 . P_i + t_z against numpy's P @ R[2] + t[2] (which may sum with FMA): to 1e-15 m at ~1 m."""
    rng = np.random.default_rng(SEED + 1)
    P = rng.uniform(-0.3, 0.3, (6, 3))
    out = np.empty(6)
    for rvec in rotation_vectors(rng, 300):
        tvec = np.array([[rng.uniform(-0.2, 0.2)], [rng.uniform(-0.2, 0.2)], [rng.uniform(0.5, 2.0)]])
        assert pnp_depths(rvec, tvec, P, out)
        np.testing.assert_allclose(out, P @ cv2.Rodrigues(rvec)[0][2] + tvec[2, 0], rtol=0, atol=1e-15)


@pytest.mark.parametrize("bad", ["rvec", "tvec"])
def test_a_pose_that_is_not_finite_is_refused_and_leaves_the_depths(bad):
    """OpenCV's IPPE reports success with NaN vectors on a fronto-parallel view: False, ``out`` untouched."""
    vectors = {"rvec": np.full((3, 1), 0.1), "tvec": np.array([[0.0], [0.0], [1.0]])}
    vectors[bad][1, 0] = np.nan
    out = np.full(4, 7.0)
    assert not pnp_depths(vectors["rvec"], vectors["tvec"], SQUARE, out)
    np.testing.assert_array_equal(out, 7.0)
    vectors[bad][1, 0] = np.inf
    assert not pnp_depths(vectors["rvec"], vectors["tvec"], SQUARE, out)


def random_pose(rng):
    """A camera 0.6-1.4 m from the square, within 40 deg of its normal (as test_monocular_pose)."""
    from scipy.spatial.transform import Rotation

    cMo = np.eye(4)
    cMo[:3, :3] = Rotation.from_rotvec(rng.uniform(-0.7, 0.7, 3)).as_matrix()
    cMo[:3, 3] = [*rng.uniform(-0.15, 0.15, 2), rng.uniform(0.6, 1.4)]
    return np.linalg.inv(cMo)


@pytest.mark.parametrize("method", ["sqpnp", "ippe"])
def test_write_marker_depths_gives_marker_depths(method):
    """The compiled frame path's call: the depths of marker_depths (1e-15 m) into a view of the frame."""
    camera = iy.PinholeCamera.normalized()
    estimator = CameraPoseEstimator(camera, SQUARE, method=method)
    sensor = MarkerSensor(camera, SQUARE)
    rng = np.random.default_rng(SEED + 2)
    frame = np.zeros(16)
    for _ in range(20):
        frame[:8] = sensor.features_at(random_pose(rng))
        estimator.write_marker_depths(frame[:8], frame[12:])
        np.testing.assert_allclose(frame[12:], estimator.marker_depths(frame[:8].copy()), rtol=0, atol=1e-15)
    assert estimator.fallbacks == 0


def test_write_marker_depths_takes_the_ippe_fallback_and_counts_it():
    """A view IPPE finds no pose for (test_pnp_option's FRONTO_PARALLEL): SQPnP's depths, counted once."""
    from test_pnp_option import FRONTO_PARALLEL

    estimator = CameraPoseEstimator(iy.PinholeCamera.normalized(), SQUARE, method="ippe")
    out = np.zeros(4)
    estimator.write_marker_depths(FRONTO_PARALLEL.ravel(), out)
    assert estimator.fallbacks == 1
    reference = CameraPoseEstimator(iy.PinholeCamera.normalized(), SQUARE, method="ippe")
    np.testing.assert_array_equal(out, reference.marker_depths(FRONTO_PARALLEL.ravel()))


def test_write_marker_depths_reports_opencvs_error_as_marker_depths_does(monkeypatch):
    """cv2.error from solvePnP: the checked path's PoseEstimationError, naming the method."""

    def fails(*args, **kwargs):
        raise cv2.error("simulated failure")

    estimator = CameraPoseEstimator(iy.PinholeCamera.normalized(), SQUARE)
    monkeypatch.setattr(cv2, "solvePnP", fails)
    with pytest.raises(PoseEstimationError, match=r"OpenCV solvePnP \(sqpnp\) failed"):
        estimator.write_marker_depths(np.full(8, 0.1), np.zeros(4))


def test_write_marker_depths_does_not_let_an_older_image_answer_for_a_later_one():
    """Images A (IPPE finds no pose), B, then A again: the third solves A again and counts it, as
    marker_depths does (the fast path forgets the cached PnP of the first A: 2 fallbacks, not 1)."""
    from test_pnp_option import FRONTO_PARALLEL

    a = FRONTO_PARALLEL.ravel().copy()
    b = a.copy()
    b[0] += 1e-3
    counts = {}
    for name in ("marker_depths", "write_marker_depths"):
        estimator = CameraPoseEstimator(iy.PinholeCamera.normalized(), SQUARE, method="ippe")
        out = np.zeros(4)
        for features in (a, b, a):
            if name == "marker_depths":
                out[:] = estimator.marker_depths(features.copy())
            else:
                estimator.write_marker_depths(features.copy(), out)
        counts[name] = estimator.fallbacks
    assert counts == {"marker_depths": 2, "write_marker_depths": 2}


def test_write_marker_depths_checks_its_arguments():
    """A stereo estimator, features of another shape, or ``out`` not (n,): named errors, no write."""
    from ibvs_youla.exceptions import InvalidArrayError, InvalidParameterError

    estimator = CameraPoseEstimator(iy.PinholeCamera.normalized(), SQUARE)
    with pytest.raises(InvalidArrayError, match=r"features: received an array of shape \(7,\)"):
        estimator.write_marker_depths(np.zeros(7), np.zeros(4))
    short = np.zeros(4)
    with pytest.raises(InvalidArrayError, match=r"out: received an array of shape \(2,\)"):
        estimator.write_marker_depths(np.full(8, 0.1), short[:2])
    np.testing.assert_array_equal(short, 0.0)
    stereo = CameraPoseEstimator(iy.StereoCamera.zed2(), SQUARE + np.array([0.0, 0.0, 2.0]))
    with pytest.raises(InvalidParameterError, match="a stereo camera triangulates its depths"):
        stereo.write_marker_depths(np.zeros(12), np.zeros(4))
