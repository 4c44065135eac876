"""Eye-in-hand map F (Eq. 24), its 9x6 Jacobian (Eq. 51, ERRATA 7, 12) and inverse (Eq. 62); IRB 4600."""

from __future__ import annotations

import numpy as np
import pytest

from ibvs_youla import EyeInHand
from ibvs_youla._geometry import inverse_pose, pose_error_mm_deg, transform_points
from ibvs_youla.exceptions import (
    DegenerateMarkersError,
    InvalidArrayError,
    InvalidDisparityError,
    InvalidParameterError,
    PointBehindCameraError,
)

PAPER_MARKERS_O = np.array([[-0.5, 0.0, 0.0], [0.0, 0.0, 0.5], [2.0, -2.0, 0.0]])  # Sec. 7 [m]
# In view of the camera around q = 0 (it sits at (1.27, 0, 1.57) m looking along +x_O): a physical set.
VIEW_MARKERS_O = np.array([[3.0, -0.3, 1.3], [3.0, 0.4, 1.5], [3.3, 0.0, 1.9]])
Q_VIEW = np.array([0.05, 0.1, -0.1, 0.3, 0.4, -0.2])  # [rad] VIEW markers visible; no singularity


def random_q(rng, arm, n, margin=0.2):
    lo, hi = np.maximum(arm.q_min, -np.pi) + margin, np.minimum(arm.q_max, np.pi) - margin
    return rng.uniform(lo, hi, (n, 6))


def fd_jacobian(f, q, eps=1e-6):
    return np.column_stack([(f(q + eps * e) - f(q - eps * e)) / (2 * eps) for e in np.eye(6)])


def test_features_follow_eq_21_and_24(arm, camera):
    eih = EyeInHand(arm, camera, VIEW_MARKERS_O)
    T_O_C = arm.camera_pose(Q_VIEW)
    P_C = transform_points(inverse_pose(T_O_C), VIEW_MARKERS_O)
    assert eih.points_in_camera(Q_VIEW) == pytest.approx(P_C, abs=1e-14)
    s = eih.features(Q_VIEW)
    assert s.shape == (9,) and eih.n_features == 9
    assert s == pytest.approx(camera.project(P_C).reshape(-1), abs=1e-18)  # point-major [u_l1, u_r1, v1, ...]
    assert np.array_equal(eih.features_at_pose(T_O_C), s)
    assert eih.visibility(Q_VIEW).all_visible


@pytest.mark.parametrize("virtual", [False, True])
def test_jacobian_matches_finite_differences(arm, camera, virtual):
    rng = np.random.default_rng(20 + virtual)
    if virtual:  # the paper's markers, anywhere around the camera
        eih, qs = EyeInHand(arm, camera, PAPER_MARKERS_O, virtual_points=True), random_q(rng, arm, 30)
    else:
        eih, qs = EyeInHand(arm, camera, VIEW_MARKERS_O), Q_VIEW + rng.uniform(-0.1, 0.1, (30, 6))
    checked = 0
    for q in qs:
        if np.abs(eih.points_in_camera(q)[:, 2]).min() < 0.3:  # a marker near the lens plane: skip
            continue
        J = eih.jacobian(q)
        assert J.shape == (9, 6)
        assert np.abs(J - fd_jacobian(eih.features, q)).max() <= 1e-6 * np.abs(J).max()
        checked += 1
    assert checked >= 20


def test_scenario_1_start_is_a_wrist_singularity(arm, camera):
    """ERRATA 7: q = 0 has q5 = 0 (axes 4 and 6 aligned), so the 9x6 Jacobian has rank 5."""
    eih = EyeInHand(arm, camera, PAPER_MARKERS_O, virtual_points=True)
    for q in (np.zeros(6), np.array([0, 0, 0, 0, 1e-4, 0])):  # at and near the singularity
        J = eih.jacobian(q)
        assert np.abs(J - fd_jacobian(eih.features, q)).max() <= 1e-6 * np.abs(J).max()
    s0 = np.linalg.svd(eih.jacobian(np.zeros(6)), compute_uv=False)
    assert s0[5] <= 1e-15 * s0[0]  # rank 5: smallest singular value ~ 0
    assert s0[4] >= 1e-3 * s0[0]
    s_near = np.linalg.svd(eih.jacobian(np.array([0, 0, 0, 0, 1e-4, 0])), compute_uv=False)
    assert 1e-7 * s0[0] <= s_near[5] <= 1e-4 * s0[0]
    s_twice = np.linalg.svd(eih.jacobian(np.array([0, 0, 0, 0, 2e-4, 0])), compute_uv=False)
    assert s_twice[5] / s_near[5] == pytest.approx(2.0, rel=1e-3)  # linear in q5: measured 2.00009


def test_paper_markers_are_behind_the_camera_at_scenario_1_start(arm, camera):
    """ERRATA 13: at q = 0 markers 1-2 have negative depth; marker 3 is far outside the 86 x 55 deg view."""
    vis = EyeInHand(arm, camera, PAPER_MARKERS_O, virtual_points=True).visibility(np.zeros(6))
    assert vis.depth == pytest.approx([-1.77, -1.27, 0.73], abs=1e-12)  # Z_C = x_O - 1.27 m
    assert vis.in_front.tolist() == [False, False, True]
    assert vis.in_fov.tolist() == [False, False, False]
    assert vis.in_depth_range.tolist() == [False, False, True]
    assert not vis.all_visible
    with pytest.raises(PointBehindCameraError, match=r"points \[0, 1\]"):
        EyeInHand(arm, camera, PAPER_MARKERS_O).features(np.zeros(6))


@pytest.mark.parametrize("virtual", [False, True])
def test_stereo_p3p_and_inverse_model_recover_pose_and_joints(arm, camera, virtual):
    """Eq. (62): q~ = F^-1(F(q)), the IK branch nearest to a nearby q_near."""
    rng = np.random.default_rng(30 + virtual)
    if virtual:
        eih, qs = EyeInHand(arm, camera, PAPER_MARKERS_O, virtual_points=True), random_q(rng, arm, 30)
    else:
        eih, qs = EyeInHand(arm, camera, VIEW_MARKERS_O), Q_VIEW + rng.uniform(-0.1, 0.1, (30, 6))
    for q in qs:
        if np.abs(eih.points_in_camera(q)[:, 2]).min() < 0.05:
            continue
        s = eih.features(q)
        mm, deg = pose_error_mm_deg(eih.estimate_camera_pose(s), arm.camera_pose(q))
        assert np.radians(deg) <= 1e-9 and mm / 1000.0 <= 1e-9  # [rad], [m]
        assert np.abs(eih.estimate_q(s, q_near=q + rng.uniform(-0.05, 0.05, 6)) - q).max() <= 1e-9
    assert np.abs(eih.estimate_q(eih.features(Q_VIEW).reshape(3, 3), Q_VIEW) - Q_VIEW).max() <= 1e-9


def test_estimate_q_with_pixel_noise_degrades_smoothly(arm, camera):
    eih, rng = EyeInHand(arm, camera, VIEW_MARKERS_O), np.random.default_rng(40)
    s = eih.features(Q_VIEW).reshape(3, 3)
    err = {}
    for sigma in (0.01, 0.1):  # [px]
        trials = [camera.from_pixels(camera.to_pixels(s) + rng.normal(0, sigma, s.shape)) for _ in range(100)]
        err[sigma] = np.median([np.abs(eih.estimate_q(p, Q_VIEW) - Q_VIEW).max() for p in trials])
    # [rad] P3P error ~1.5e-3 rad, amplified by the wrist (1 / sin q5)
    assert err[0.01] == pytest.approx(4.2030e-3, rel=1e-3)  # seeded statistic (measured 4.20298e-3)
    assert err[0.1] / err[0.01] == pytest.approx(10.51, rel=1e-3)  # seeded statistic (measured 10.508)
    assert 6.0 <= err[0.1] / err[0.01] <= 14.0  # smooth: ~linear in the noise whatever the seed


def test_virtual_points_allow_negative_disparity_only_when_enabled(arm, camera):
    behind = EyeInHand(arm, camera, PAPER_MARKERS_O, virtual_points=True).features(np.zeros(6))
    with pytest.raises(InvalidDisparityError, match="points"):
        EyeInHand(arm, camera, PAPER_MARKERS_O).estimate_camera_pose(behind)


def test_bad_markers_and_camera(arm, camera):
    with pytest.raises(DegenerateMarkersError, match="collinear"):
        EyeInHand(arm, camera, [[0, 0, 0], [1, 1, 1], [2, 2, 2.0]])
    with pytest.raises(DegenerateMarkersError, match="coincide"):
        EyeInHand(arm, camera, np.ones((3, 3)))
    with pytest.raises(InvalidArrayError, match="non-finite"):
        EyeInHand(arm, camera, [[0, 0, np.inf], [1, 0, 0], [0, 1, 0]])
    with pytest.raises(InvalidArrayError, match=r"shape \(n, 3\)"):
        EyeInHand(arm, camera, np.zeros(9))
    with pytest.raises(InvalidParameterError, match="StereoCamera"):
        EyeInHand(arm, "zed2", VIEW_MARKERS_O)


def test_public_methods_reject_bad_arrays(arm, camera):
    """Bad input raises InvalidArrayError naming the argument: never NaN, never a bare numpy error."""
    eih = EyeInHand(arm, camera, VIEW_MARKERS_O)
    T_O_C, p = arm.camera_pose(Q_VIEW), eih.features(Q_VIEW)
    nan_pose = T_O_C.copy()
    nan_pose[0, 3] = np.nan
    for method in (eih.features_at_pose, eih.points_in_camera_at_pose):
        with pytest.raises(InvalidArrayError, match=r"T_O_C: received non-finite entries at \(0, 3\)"):
            method(nan_pose)
        with pytest.raises(InvalidArrayError, match=r"T_O_C: received an array of shape \(3, 3\)"):
            method(np.eye(3))
        with pytest.raises(InvalidArrayError, match="T_O_C: received a rotation block"):
            method(np.diag([2.0, 1.0, 1.0, 1.0]))
    # A list is a valid pose: converted, same result as the array.
    assert np.array_equal(eih.points_in_camera_at_pose(T_O_C.tolist()), eih.points_in_camera(Q_VIEW))
    nan_p = p.copy()
    nan_p[4] = np.nan
    with pytest.raises(InvalidArrayError, match=r"features: received non-finite entries at \(4,\)"):
        eih.estimate_camera_pose(nan_p)
    with pytest.raises(InvalidArrayError, match=r"features: received non-finite entries at \(4,\)"):
        eih.estimate_q(nan_p, Q_VIEW)
    for bad in (p[:8], np.concatenate((p, p[:3]))):  # 8 values; 12 values (4 markers) for 3 markers
        with pytest.raises(InvalidArrayError, match=r"features: .*expected shape \(9,\) or \(3, 3\)"):
            eih.estimate_camera_pose(bad)
        with pytest.raises(InvalidArrayError, match=r"features: .*expected shape \(9,\) or \(3, 3\)"):
            eih.estimate_q(bad, Q_VIEW)
    with pytest.raises(InvalidArrayError, match="features: received str that is not numeric"):
        eih.estimate_camera_pose("features")
    with pytest.raises(InvalidArrayError, match=r"q_near: received non-finite entries at \(2,\)"):
        eih.estimate_q(p, [0.0, 0.0, np.nan, 0.0, 0.0, 0.0])
    with pytest.raises(InvalidArrayError, match=r"q_near: received an array of shape \(5,\)"):
        eih.estimate_q(p, np.zeros(5))
