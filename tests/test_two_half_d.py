"""2.5-D visual servoing (Malis, Chaumette & Boudet 1999): interaction matrix, homography, reach, bad input.

Closed forms: the interaction matrix against finite differences of the task function along body
twists; the law inverts it (L [v; omega] = -lambda e); theta u decays as (1 - lambda T)^k exactly on
the free camera (omega = -lambda theta u, as in PBVS); on exact features the homography route gives
the pose route's rotation and depth ratio to 1e-9.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

import ibvs_youla as iy
from ibvs_youla.analysis.metrics import pose_error_mm_deg
from ibvs_youla.controllers import CameraFrame, ServoTask
from ibvs_youla.controllers.pbvs import theta_u
from ibvs_youla.controllers.two_half_d import (
    REGISTRATIONS,
    TwoHalfD,
    euclidean_homography,
    interaction_matrix,
    rotation_from_homography,
)
from ibvs_youla.exceptions import InvalidParameterError
from servo_helpers import MARKERS_4

GAIN, PERIOD = 0.5, 0.04  # lambda [1/s], T [s]
DECAY = 1.0 - GAIN * PERIOD  # per frame
POINTS_O = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]


def T_O_C(t, theta_u_deg):
    """Camera pose from an object pose in the camera (ViSP's cMo)."""
    cMo = np.eye(4)
    cMo[:3, :3] = Rotation.from_rotvec(np.radians(theta_u_deg)).as_matrix()
    cMo[:3, 3] = t
    return np.linalg.inv(cMo)


T_TARGET = T_O_C([0, 0, 0.75], [0, 0, 0])
T_START = T_O_C([0.15, -0.1, 1.0], [10, -10, 50])


def run_tutorial(controller, duration=30.0):
    """ViSP's tutorial-ibvs-4pts on the free camera at 25 Hz, normalized camera (as in test_pbvs)."""
    scenario = iy.Scenario.free_camera(T_O_C_start=T_START, T_O_C_target=T_TARGET, markers_O=POINTS_O)
    settings = iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0)
    return iy.simulate(
        scenario,
        controller=controller,
        plant="free-camera",
        camera=iy.PinholeCamera.normalized(),
        duration=duration,
        settings=settings,
    )


def in_camera(T, P_O):
    """Points (n, 3) in the camera frame of pose T_O_C."""
    return (P_O - T[:3, 3]) @ T[:3, :3]


def normalized(T, P_O=POINTS_O):
    """Exact normalized features [x, y] per point (2n,) at pose T."""
    P = in_camera(T, P_O)
    return (P[:, :2] / P[:, 2:]).ravel()


def true_error(T, ref_O, T_target=T_TARGET):
    """e = (x - x*, y - y*, log Z/Z*, theta u of c*R_c) from the poses (no estimation)."""
    (X, Y, Z), (Xs, Ys, Zs) = in_camera(T, ref_O[None])[0], in_camera(T_target, ref_O[None])[0]
    R = (np.linalg.inv(T_target) @ T)[:3, :3]
    return np.array([X / Z - Xs / Zs, Y / Z - Ys / Zs, np.log(Z / Zs), *theta_u(R)])


def se3(xi):
    """4x4 twist matrix of a body twist [v; w]."""
    M = np.zeros((4, 4))
    M[:3, :3] = [[0.0, -xi[5], xi[4]], [xi[5], 0.0, -xi[3]], [-xi[4], xi[3], 0.0]]
    M[:3, 3] = xi[:3]
    return M


def tutorial_task(camera=None, markers_O=POINTS_O):
    camera = iy.PinholeCamera.normalized() if camera is None else camera
    return ServoTask(
        camera=camera,
        markers_O=markers_O,
        feature_target=normalized(T_TARGET, markers_O),
        T_O_C_target=T_TARGET,
        tick_period=PERIOD,
        frame_period=PERIOD,
    )


def random_views(n, seed=3):
    """Seeded camera poses around the target that see the square in front (normalized camera)."""
    rng = np.random.default_rng(seed)
    views = []
    while len(views) < n:
        T = T_O_C(rng.normal(0.0, 0.15, 3) + np.array([0.0, 0.0, 0.9]), rng.normal(0.0, 20.0, 3))
        if in_camera(T, POINTS_O)[:, 2].min() > 0.2:
            views.append(T)
    return views


@pytest.fixture(scope="module")
def runs():
    """The tutorial scenario with the pose and the homography routes (centroid reference)."""
    return {route: run_tutorial(TwoHalfD(rotation_from=route)) for route in ("pose", "homography")}


# ---------------------------------------------------------------------------------- the law
def test_interaction_matrix_matches_finite_differences():
    ref_O = POINTS_O.mean(axis=0)
    h, worst = 1e-6, 0.0
    for T in random_views(10):
        e = true_error(T, ref_O)
        X, Y, Z = in_camera(T, ref_O[None])[0]
        L = interaction_matrix(X / Z, Y / Z, Z, e[3:])
        for j in range(6):
            xi = np.eye(6)[j]
            e_plus, e_minus = (
                true_error(T @ expm(h * se3(xi)), ref_O),
                true_error(T @ expm(-h * se3(xi)), ref_O),
            )
            fd = (e_plus - e_minus) / (2 * h)
            worst = max(worst, float(np.abs(fd - L[:, j]).max()))
    assert worst < 1e-8


def test_the_twist_inverts_the_interaction_matrix():
    controller = TwoHalfD()
    controller.reset(tutorial_task())
    for T in random_views(5):
        controller.update(CameraFrame(0.0, normalized(T), np.ones(4, bool)), None)
        e, twist = controller.signals()["servo_error"], controller.command(None)
        X, Y, Z = in_camera(T, POINTS_O.mean(axis=0)[None])[0]
        assert np.abs(e - true_error(T, POINTS_O.mean(axis=0))).max() < 1e-9
        assert np.abs(interaction_matrix(X / Z, Y / Z, Z, e[3:]) @ twist + GAIN * e).max() < 1e-9


@pytest.mark.parametrize("reference_point", ["centroid", 2])
def test_the_compiled_pose_route_gives_the_numpy_reference(reference_point):
    """update's compiled law (two_half_d_kernels.pose_route_twist) against its numpy reference on the same
    pose: twist and task function to 1e-14 (sums of a few products in the same order; the 4 x 4 product
    BLAS may fuse), on 40 seeded views around the target."""
    from ibvs_youla.controllers.two_half_d_kernels import pose_route_twist

    controller = TwoHalfD(reference_point=reference_point)
    controller.reset(tutorial_task())
    twist, error = np.empty(6), np.empty(6)
    for T in random_views(40, seed=11):
        features = normalized(T)
        T_est = controller.pose_estimator(features)
        assert pose_route_twist(T_est, *controller.pose_route_law(), features, twist, error)  # not declined
        controller._pose_route_reference(T_est, features)
        np.testing.assert_allclose(twist, controller.command(None), rtol=0, atol=1e-14)
        np.testing.assert_allclose(error, controller.signals()["servo_error"], rtol=0, atol=1e-14)
        controller.update(CameraFrame(0.0, features, np.ones(4, bool)), None)  # update calls the kernel
        np.testing.assert_array_equal(controller.command(None), twist)


def test_the_compiled_pose_route_leaves_a_point_behind_the_camera_to_the_reference():
    """rho <= 0 (the reference point behind the camera): the kernel declines, the reference raises."""
    from ibvs_youla.controllers.two_half_d_kernels import pose_route_twist
    from ibvs_youla.exceptions import PointBehindCameraError

    controller = TwoHalfD()
    controller.reset(tutorial_task())
    behind = T_O_C([0.0, 0.0, -0.75], [0, 0, 0])  # the target square 0.75 m behind the camera
    twist, error = np.full(6, 7.0), np.full(6, 7.0)
    assert not pose_route_twist(behind, *controller.pose_route_law(), normalized(behind), twist, error)
    np.testing.assert_array_equal(twist, 7.0)
    with pytest.raises(PointBehindCameraError, match=r"2\.5-D reference point is behind the camera"):
        controller._pose_route_reference(behind, normalized(behind))


# ---------------------------------------------------------------------------------- homography
def test_euclidean_homography_is_exact_and_cv2_find_homography_is_not():
    import cv2

    m_target = normalized(T_TARGET).reshape(4, 2)
    m = normalized(T_START).reshape(4, 2)
    rho = in_camera(T_START, POINTS_O)[:, 2] / in_camera(T_TARGET, POINTS_O)[:, 2]
    H = euclidean_homography(m_target, m)
    mapped = np.column_stack((m_target, np.ones(4))) @ H.T  # rows rho_i [m_i; 1]
    assert np.abs(mapped[:, 2] - rho).max() < 1e-14
    assert np.abs(mapped[:, :2] / mapped[:, 2:] - m).max() < 1e-14
    assert np.linalg.svd(H, compute_uv=False)[1] == pytest.approx(1.0, abs=1e-15)
    # OpenCV's own estimate stops about 1e-7 away: why the DLT is done here (module docstring)
    H_cv = cv2.findHomography(m_target, m, 0)[0]
    assert np.abs(H_cv - H / H[2, 2]).max() > 1e-8


def test_decomposition_choice_visibility_then_known_normal():
    import cv2

    m_target = normalized(T_TARGET).reshape(4, 2)
    H = euclidean_homography(m_target, normalized(T_START).reshape(4, 2))
    n_target = np.array([0.0, 0.0, 1.0])  # the square's normal in the desired frame, n*^T P* = 0.75 m
    R_true = (np.linalg.inv(T_TARGET) @ T_START)[:3, :3]  # c*R_c
    _, rotations, _, normals = cv2.decomposeHomographyMat(H, np.eye(3))
    m_h = np.column_stack((m_target, np.ones(4)))
    visible = [i for i, n in enumerate(normals) if np.all(m_h @ n.ravel() > 0.0)]
    assert len(rotations) == 4 and len(visible) == 2  # one of each (R, t, n), (R, -t, -n) pair
    # the two visible solutions differ: the normal decides
    off = sorted(float(np.abs(rotations[i].T - R_true).max()) for i in visible)
    assert off[0] < 1e-14 and off[1] == pytest.approx(0.27370, abs=1e-5)
    assert np.abs(rotation_from_homography(H, m_target, n_target) - R_true).max() < 1e-14


def test_pure_rotation_branch_of_opencv_is_replaced_by_the_known_normal():
    import cv2

    T = T_TARGET.copy()
    T[:3, 3] += [2e-4, -1e-4, 1e-4]  # 0.24 mm from the goal: |H^T H - I| < 1e-3
    T[:3, :3] = T[:3, :3] @ expm(se3([0, 0, 0, 1e-4, 2e-4, -3e-4]))[:3, :3]
    m_target = normalized(T_TARGET).reshape(4, 2)
    H = euclidean_homography(m_target, normalized(T).reshape(4, 2))
    R_true = (np.linalg.inv(T_TARGET) @ T)[:3, :3]
    count, rotations, translations, normals = cv2.decomposeHomographyMat(H, np.eye(3))
    assert count == 1 and not np.any(normals[0]) and not np.any(translations[0])
    assert np.abs(rotations[0].T - R_true).max() > 1e-4  # OpenCV's answer: H itself, off by t n^T / d*
    assert np.abs(rotation_from_homography(H, m_target, np.array([0.0, 0.0, 1.0])) - R_true).max() < 1e-14


@pytest.mark.parametrize("reference_point", ["centroid", 2])
def test_homography_route_agrees_with_the_pose_route_on_exact_features(reference_point):
    pose, homography = (
        TwoHalfD(rotation_from=r, reference_point=reference_point) for r in ("pose", "homography")
    )
    for controller in (pose, homography):
        controller.reset(tutorial_task())
    worst = 0.0
    for T in [T_START, *random_views(20)]:
        frame = CameraFrame(0.0, normalized(T), np.ones(4, bool))
        pose.update(frame, None)
        homography.update(frame, None)
        e_pose, e_h = pose.signals()["servo_error"], homography.signals()["servo_error"]
        worst = max(worst, float(np.abs(e_pose - e_h).max()))  # (x, y), log rho, theta u
    assert worst < 1e-9  # measured 3.4e-11, SQPnP's round-off


# ---------------------------------------------------------------------------------- free camera
@pytest.mark.parametrize(
    ("route", "position_mm", "rotation_deg", "theta_u_tol"),
    [
        ("pose", 2.0100e-3, 5.6188e-4, 1e-10),  # SQPnP's floor near the symmetric target (test_pbvs)
        ("homography", 8.6622e-5, 1.3653e-5, 1e-12),  # (1 - lambda T)^750 of the start error
    ],
)
def test_reaches_the_tutorial_target_with_exponential_theta_u(
    runs, route, position_mm, rotation_deg, theta_u_tol
):
    r = runs[route]
    assert r.status == "complete"
    assert r.final_pose_error() == pytest.approx((position_mm, rotation_deg), rel=1e-3)
    e = r.signals["servo_error"]
    k = np.arange(400)  # the camera centre is > 1e-4 m from the goal
    assert np.abs(e[:400, 3:] - e[0, 3:] * DECAY ** k[:, None]).max() < theta_u_tol
    # the true rotation too, not only the controller's estimate of it
    R = np.einsum("ij,njk->nik", np.linalg.inv(r.camera_pose_target), r.camera_pose[:400])[:, :3, :3]
    assert np.abs(np.array([theta_u(Ri) for Ri in R]) - e[0, 3:] * DECAY ** k[:, None]).max() < 1e-10
    # the image part is not exact on the sampled loop: the held twist is integrated by the exp map
    assert np.abs(e[:400, :3] - e[0, :3] * DECAY ** k[:, None]).max() == pytest.approx(4.282e-4, rel=1e-3)


def test_marker_reference_point_reaches_the_target():
    r = run_tutorial(TwoHalfD(reference_point=0))
    assert r.status == "complete"
    assert r.final_pose_error() == pytest.approx((2.4490e-3, 5.6188e-4), rel=1e-3)


# ---------------------------------------------------------------------------------- stereo arm
def test_stereo_physical_2_on_the_kinematic_arm():
    r = iy.simulate(iy.scenarios.physical(2), controller=TwoHalfD(), plant="kinematic", duration=10.0)
    assert r.status == "complete"
    start = pose_error_mm_deg(r.camera_pose[0], r.camera_pose_target)
    assert start == pytest.approx((109.739, 7.0503), rel=1e-4)
    assert r.final_pose_error() == pytest.approx((0.84906, 0.045613), rel=1e-3)
    e = r.signals["servo_error"]
    assert np.linalg.norm(e[-1]) / np.linalg.norm(e[0]) == pytest.approx(6.987e-3, rel=1e-3)


# ---------------------------------------------------------------------------------- registry, input
def test_registration_and_spec():
    ((name, factory, summary),) = REGISTRATIONS
    controller = factory(gain=0.8, rotation_from="homography", reference_point=1)
    assert name == "2.5d" == controller.name and isinstance(controller, TwoHalfD) and "Malis" in summary
    spec = json.loads(json.dumps(controller.spec()))
    assert (spec["gain"], spec["rotation_from"], spec["reference_point"]) == (0.8, "homography", 1)


def test_unknown_rotation_source():
    with pytest.raises(
        InvalidParameterError, match=r"rotation_from: received 'essential'.*'pose' or 'homography'"
    ):
        TwoHalfD(rotation_from="essential")


@pytest.mark.parametrize("gain", [0.0, -0.5, float("nan"), "slow"])
def test_bad_gain(gain):
    with pytest.raises(InvalidParameterError, match=r"gain: .*a finite number > 0 1/s"):
        TwoHalfD(gain=gain)


@pytest.mark.parametrize("reference_point", ["center", True, 1.5, None])
def test_bad_reference_point(reference_point):
    with pytest.raises(InvalidParameterError, match=r"reference_point: .*'centroid' or a marker index"):
        TwoHalfD(reference_point=reference_point)


def test_reference_index_out_of_range():
    with pytest.raises(InvalidParameterError, match=r"reference_point: received 4.*\[0, 3\] \(4 markers\)"):
        TwoHalfD(reference_point=4).reset(tutorial_task())


def test_homography_route_with_a_stereo_camera():
    with pytest.raises(InvalidParameterError, match=r"rotation_from: received 'homography'.*StereoCamera"):
        TwoHalfD(rotation_from="homography").reset(tutorial_task(camera=iy.StereoCamera.zed2()))


def test_homography_route_with_markers_off_a_plane():
    with pytest.raises(
        InvalidParameterError, match=r"rotation_from: received 'homography'.*coplanar markers"
    ):
        TwoHalfD(rotation_from="homography").reset(tutorial_task(markers_O=MARKERS_4))
    TwoHalfD(rotation_from="pose").reset(tutorial_task(markers_O=MARKERS_4))  # the pose route takes them


def test_monocular_camera_with_three_markers():
    with pytest.raises(InvalidParameterError, match=r"task.markers_O: received '3 markers'.*four or more"):
        TwoHalfD().reset(tutorial_task(markers_O=POINTS_O[:3]))
