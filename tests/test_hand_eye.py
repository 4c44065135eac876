"""Hand-eye calibration AX = XB (Sec. 4.3, Eq. 18-20) by Park & Martin (1994)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from ibvs_youla import calibrate_hand_eye
from ibvs_youla._geometry import inverse_pose, make_pose, pose_error_mm_deg
from ibvs_youla.exceptions import CalibrationError, InvalidArrayError


def random_pose(rng, angle=1.0, scale=0.5):
    return make_pose(pin.exp3(rng.normal(size=3) * angle), rng.normal(size=3) * scale)


def motions(rng, X, n):
    """Flange motions A_i and the camera motions B_i = X^-1 A_i X they induce (X = T_E_C)."""
    A = np.array([random_pose(rng) for _ in range(n)])
    return A, np.array([inverse_pose(X) @ a @ X for a in A])


@pytest.mark.parametrize("n", [2, 3, 20])
def test_recovers_random_hand_eye_transforms(n):
    rng = np.random.default_rng(n)
    for _ in range(50):
        X = random_pose(rng, angle=2.0)
        A, B = motions(rng, X, n)
        X_est = calibrate_hand_eye(A, B)
        assert np.abs(X_est - X).max() <= 1e-9
        assert max(np.abs(a @ X_est - X_est @ b).max() for a, b in zip(A, B, strict=True)) <= 1e-9


def test_recovers_the_irb4600_default_rz_pi():
    """ERRATA 2: T_E_C = Rz(pi), zero translation; a rotation of angle pi is the hard case for log3."""
    rng = np.random.default_rng(1)
    X = make_pose(pin.rpy.rpyToMatrix(0.0, 0.0, np.pi), np.zeros(3))
    A, B = motions(rng, X, 5)
    mm, deg = pose_error_mm_deg(calibrate_hand_eye(A, B), X)
    assert np.radians(deg) <= 1e-12 and mm / 1000.0 <= 1e-12  # [rad], [m]


def test_noisy_camera_motions_still_give_a_rotation():
    rng = np.random.default_rng(2)
    X = random_pose(rng)
    A, B = motions(rng, X, 30)
    B = np.array([b @ random_pose(rng, angle=0.01, scale=0.001) for b in B])  # ~0.01 rad, 1 mm noise
    X_est = calibrate_hand_eye(A, B)
    assert np.linalg.det(X_est[:3, :3]) == pytest.approx(1.0, abs=1e-12)
    mm, deg = pose_error_mm_deg(X_est, X)
    rot, trans = np.radians(deg), mm / 1000.0
    assert rot == pytest.approx(1.736e-3, rel=1e-3)  # [rad] seeded statistic (measured 1.73587e-3)
    assert trans == pytest.approx(1.327e-3, rel=1e-3)  # [m] seeded statistic (measured 1.32744e-3)


def test_too_few_or_degenerate_motions():
    rng = np.random.default_rng(3)
    X = random_pose(rng)
    A, B = motions(rng, X, 4)
    with pytest.raises(CalibrationError, match="received 1 motion pair"):
        calibrate_hand_eye(A[:1], B[:1])
    axis = np.array([0.3, -0.2, 0.9]) / np.linalg.norm([0.3, -0.2, 0.9])
    A_par = np.array([make_pose(pin.exp3(axis * a), rng.normal(size=3)) for a in (0.3, -0.7, 1.1, 2.0)])
    B_par = np.array([inverse_pose(X) @ a @ X for a in A_par])
    with pytest.raises(CalibrationError, match="parallel axes"):
        calibrate_hand_eye(A_par, B_par)
    A_trans = np.array([make_pose(np.eye(3), rng.normal(size=3)) for _ in range(4)])  # pure translations
    with pytest.raises(CalibrationError, match="~0"):
        calibrate_hand_eye(A_trans, A_trans)


def test_bad_arrays():
    rng = np.random.default_rng(4)
    A, B = motions(rng, random_pose(rng), 3)
    with pytest.raises(InvalidArrayError, match=r"B: received an array of shape \(2, 4, 4\)"):
        calibrate_hand_eye(A, B[:2])
    bad = A.copy()
    bad[1, 0, 0] = np.nan
    with pytest.raises(InvalidArrayError, match="non-finite"):
        calibrate_hand_eye(bad, B)
    bad = A.copy()
    bad[2, :3, :3] *= 1.1
    with pytest.raises(InvalidArrayError, match=r"A\[2\]: received a rotation block"):
        calibrate_hand_eye(bad, B)


# ----------------------------------------------------------------------------------------- simulated run
VIEW_MARKERS_O = np.array([[3.0, -0.3, 1.3], [3.0, 0.4, 1.5], [3.3, 0.0, 1.9]])  # in view around q = 0 [m]


def calibration_errors(noise_px, n_runs, seed):
    from ibvs_youla import Arm, StereoCamera
    from ibvs_youla.estimation.hand_eye import simulate_hand_eye_run

    arm, camera, rng = Arm.irb4600(), StereoCamera.zed2(), np.random.default_rng(seed)
    errors = []
    for _ in range(n_runs):
        A, B = simulate_hand_eye_run(arm, camera, VIEW_MARKERS_O, np.zeros(6), 20, rng, pixel_noise=noise_px)
        assert A.shape == B.shape == (19, 4, 4)
        mm, deg = pose_error_mm_deg(calibrate_hand_eye(A, B), arm.T_E_C)
        errors.append((np.radians(deg), mm / 1000.0))
    return np.array(errors)  # (n_runs, 2): rotation [rad], translation [m]


def test_simulated_run_recovers_the_urdf_hand_eye_transform():
    """ERRATA 2: the URDF's T_E_C = Rz(pi); recovered from 20 noise-free stereo marker observations."""
    assert calibration_errors(0.0, 5, 50).max() <= 1e-9


def test_simulated_run_degrades_smoothly_with_pixel_noise():
    """20 poses, paper camera at HD720, markers ~1.7 m away: 0.1 px costs ~1e-2 rad, ~3 cm.

    Each T_C_M inherits the stereo P3P error (depth noise over a 0.7 m marker triangle); AX = XB
    averages 19 motions. Looser than 1e-6 on purpose: these are noise statistics.
    """
    med = {s: np.median(calibration_errors(s, 20, 51), axis=0) for s in (0.01, 0.1, 1.0)}
    assert med[0.1][0] == pytest.approx(2.0196e-2, rel=1e-3)  # rotation [rad], seeded statistic
    assert med[0.1][1] == pytest.approx(3.5805e-2, rel=1e-3)  # translation [m], seeded statistic
    for small, large in ((0.01, 0.1), (0.1, 1.0)):  # 10x the noise -> ~10x the error
        assert 6.0 <= med[large][0] / med[small][0] <= 14.0
        assert 6.0 <= med[large][1] / med[small][1] <= 14.0


def test_simulated_run_needs_markers_in_view():
    from ibvs_youla import Arm, StereoCamera
    from ibvs_youla.estimation.hand_eye import simulate_hand_eye_run

    behind = np.array([[-0.5, 0.0, 0.0], [0.0, 0.0, 0.5], [2.0, -2.0, 0.0]])  # paper's markers, ERRATA 13
    with pytest.raises(CalibrationError, match="in view"):
        simulate_hand_eye_run(
            Arm.irb4600(), StereoCamera.zed2(), behind, np.zeros(6), 5, np.random.default_rng(0), max_tries=50
        )
