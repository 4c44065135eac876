"""Hand-eye calibration AX = XB (Sec. 4.3, Eq. 18-20) by Park & Martin, and a simulated calibration run.

Frames (docs/conventions.md): A_i = T_E1_E2 is a relative flange motion, B_i = T_C1_C2 the same
motion seen by the camera, X = T_E_C. From T_O_C = T_O_E X: T_C1_C2 = X^-1 T_E1_E2 X, i.e.
A_i X = X B_i. Eq. (19)-(20) as printed mix the paper's two transform conventions; re-derived here:
A_i = T_O_E1^-1 T_O_E2 and, with T_C_M the marker pose of Appendix C, B_i = T_C1_M T_C2_M^-1.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .._geometry import inverse_pose, make_pose, transform_points
from .._validation import as_array, as_pose, non_negative
from ..exceptions import CalibrationError, InvalidParameterError
from ..model.camera import StereoCamera, project_points, triangulate_points
from .stereo_pose import check_marker_geometry, kabsch, marker_coordinates

__all__ = ["AXIS_TOL", "calibrate_hand_eye", "simulate_hand_eye_run"]

AXIS_TOL = 1e-6  # rotation axes count as all parallel when s2/s1 of the stacked log(R_A_i) is below this


def calibrate_hand_eye(A: object, B: object) -> np.ndarray:
    """Solve A_i X = X B_i (Eq. 18) for X = T_E_C by Park & Martin's closed form.

    F. C. Park and B. J. Martin, "Robot sensor calibration: solving AX = XB on the Euclidean group",
    IEEE Trans. Robotics and Automation 10(5):717-721, 1994. Rotation: alpha_i = log R_A_i and
    beta_i = log R_B_i satisfy alpha_i = R_X beta_i; with M = sum_i beta_i alpha_i^T,
    R_X = (M^T M)^-1/2 M^T = V U^T for M = U S V^T (here with a det correction so that noisy data
    still give a rotation). Translation: least squares on (R_A_i - I) t_X = R_X t_B_i - t_A_i.

    Args:
        A: Relative flange motions T_E1_E2, shape (n, 4, 4), n >= 2 (Eq. 19, re-derived).
        B: The matching relative camera motions T_C1_C2, shape (n, 4, 4) (Eq. 20, re-derived).

    Returns:
        X = T_E_C (4x4).

    Raises:
        InvalidArrayError: wrong shapes, non-finite entries, or matrices that are not rigid transforms.
        CalibrationError: fewer than 2 motions, or rotation axes all parallel (or rotations all ~0),
            which leaves X undetermined.
    """
    A = as_array(A, "A", (None, 4, 4))
    B = as_array(B, "B", (A.shape[0], 4, 4))
    n = A.shape[0]
    if n < 2:
        raise CalibrationError(
            f"received {n} motion pair(s); AX = XB needs at least 2 motions with non-parallel rotation axes"
        )
    for i in range(n):
        as_pose(A[i], f"A[{i}]")
        as_pose(B[i], f"B[{i}]")
    alpha = np.array([pin.log3(A[i, :3, :3]) for i in range(n)])  # [rad] axis * angle
    beta = np.array([pin.log3(B[i, :3, :3]) for i in range(n)])
    s = np.linalg.svd(alpha, compute_uv=False)
    if s[0] < 1e-9 or s[1] <= AXIS_TOL * s[0]:
        raise CalibrationError(
            f"the {n} flange rotations have parallel axes or are ~0 (singular values of the stacked "
            f"log R_A_i: {np.round(s, 12).tolist()} rad); valid data need two rotation axes whose "
            f"ratio s2/s1 exceeds {AXIS_TOL:g}"
        )
    U, _, Vt = np.linalg.svd(beta.T @ alpha)  # M = sum_i beta_i alpha_i^T
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
    R_X = Vt.T @ D @ U.T
    C = (A[:, :3, :3] - np.eye(3)).reshape(-1, 3)
    d = (B[:, :3, 3] @ R_X.T - A[:, :3, 3]).reshape(-1)
    t_X = np.linalg.lstsq(C, d, rcond=None)[0]
    return make_pose(R_X, t_X)


def simulate_hand_eye_run(
    arm: object,
    camera: StereoCamera,
    markers_O: object,
    q_center: object,
    n_poses: int,
    rng: np.random.Generator,
    *,
    spread: float = 0.3,
    pixel_noise: float = 0.0,
    max_tries: int = 1000,
) -> tuple[np.ndarray, np.ndarray]:
    """Simulate a calibration run: (A, B) from arm motions and stereo observations of three markers.

    Draws joint vectors q_center + U(-spread, spread) within the arm's limits, keeps those where every
    marker is visible (`StereoCamera.visibility`), projects the markers with the arm's true camera
    pose (so with its T_E_C), adds Gaussian noise of `pixel_noise` px to every feature, triangulates
    (Eq. C6-C8) and estimates T_C_M (Appendix C, Eq. C10-C17), then forms consecutive motions
    A_i = T_O_Ei^-1 T_O_Ei+1 and B_i = T_CiM T_Ci+1M^-1.

    Args:
        arm: Provides ``flange_pose(q)``, ``camera_pose(q)``, ``q_min``, ``q_max``.
        camera: The stereo camera.
        markers_O: Marker positions (3, 3) in the base frame [m].
        q_center: Joint vector (n,) around which poses are drawn [rad], n the arm's joints.
        n_poses: Number of poses (>= 3 gives >= 2 motions).
        rng: Random generator (seeded by the caller).
        spread: Half-width of the uniform joint perturbation [rad].
        pixel_noise: Standard deviation of the feature noise [px].
        max_tries: Draws allowed before giving up.

    Returns:
        (A, B), each (n_poses - 1, 4, 4).

    Raises:
        CalibrationError: fewer than n_poses draws had every marker in view.
    """
    markers_O = check_marker_geometry(markers_O, "markers_O")
    n_joints = len(np.asarray(arm.q_min))
    q_center = as_array(q_center, "q_center", (n_joints,))
    if int(n_poses) != n_poses or n_poses < 2:
        raise InvalidParameterError("n_poses", n_poses, "an integer >= 2")
    spread, pixel_noise = non_negative(spread, "spread"), non_negative(pixel_noise, "pixel_noise")
    P_M = marker_coordinates(markers_O)
    T_O_E, T_C_M = [], []
    for _ in range(max_tries):
        q = np.clip(q_center + rng.uniform(-spread, spread, n_joints), arm.q_min, arm.q_max)
        P_C = transform_points(inverse_pose(arm.camera_pose(q)), markers_O)
        if not camera.visibility(P_C).all_visible:
            continue
        p = project_points(camera, P_C, False).reshape(-1, 3)
        if pixel_noise > 0:
            p = camera.from_pixels(camera.to_pixels(p) + rng.normal(0.0, pixel_noise, p.shape))
        T_C_M.append(kabsch(P_M, triangulate_points(camera, p, False)))
        T_O_E.append(arm.flange_pose(q))
        if len(T_O_E) == n_poses:
            break
    else:
        raise CalibrationError(
            f"only {len(T_O_E)} of {n_poses} poses had every marker in view after "
            f"{max_tries} draws; move q_center or the markers, or reduce spread"
        )
    A = np.array([inverse_pose(T_O_E[i]) @ T_O_E[i + 1] for i in range(n_poses - 1)])
    B = np.array([T_C_M[i] @ inverse_pose(T_C_M[i + 1]) for i in range(n_poses - 1)])
    return A, B
