"""Point features for the image-based laws: the task's layout and the interaction matrix at the current image.

Shared by classical IBVS (:mod:`.ibvs`) and MPC-IBVS (:mod:`.mpc_ibvs`), which both evaluate
L(s, Z) at the measured features with depths from the controller's own model:

* stereo (a ``StereoCamera``, >= 3 points, 3 rows per point): the points triangulated from the
  features (Eq. (C6)-(C8) of the paper, :func:`~ibvs_youla.model.camera.triangulate_points`);
* monocular (a ``PinholeCamera``, >= 4 points, 2 rows per point): the camera pose estimated
  from the image, ``estimate_camera_pose(task.camera, features, task.markers_O)`` (SQPnP), and
  the believed markers give the depths Z_i; the points are back-projected, X = u Z / F.
"""

from __future__ import annotations

import numpy as np

from .._geometry import inverse_pose, transform_points
from ..estimation.monocular_pose import CameraPoseEstimator, estimate_camera_pose
from ..exceptions import InvalidParameterError
from ..model.camera import PinholeCamera, StereoCamera, points_interaction_matrix, triangulate_points
from .base import ServoTask

__all__ = ["current_interaction_matrix", "feature_rows"]


def feature_rows(task: ServoTask, controller: str) -> int:
    """Rows per point of the task's camera, 3 (stereo) or 2 (monocular), after checking the task.

    Raises:
        InvalidParameterError: a camera of another kind, a monocular camera with fewer than 4
            points or a stereo one with fewer than 3 (a rank-6 L needs them; PnP needs 4), or
            target features of another size.
    """
    camera, n = task.camera, task.n_points
    if isinstance(camera, StereoCamera):
        n_min, rows = 3, 3
    elif isinstance(camera, PinholeCamera):
        n_min, rows = 4, 2
    else:
        raise InvalidParameterError("task.camera", type(camera).__name__, "a StereoCamera or a PinholeCamera")
    if n < n_min:
        why = "the monocular pose (PnP) and a rank-6 L" if rows == 2 else "a rank-6 L"
        raise InvalidParameterError(
            "task.markers_O",
            f"{n} points",
            f"{n_min} or more points for {controller!r} with a {type(camera).__name__} ({why})",
        )
    target = np.asarray(task.feature_target)
    if target.shape != (rows * n,):
        raise InvalidParameterError(
            "task.feature_target", f"an array of shape {target.shape}", f"shape ({rows * n},)"
        )
    return rows


def current_interaction_matrix(
    task: ServoTask, features: np.ndarray, rows: int, pose: CameraPoseEstimator | None = None
) -> np.ndarray:
    """L(s, Z) (m, 6) at the measured features, depths from the controller's model (module docstring).

    ``pose``: for a monocular camera, ``CameraPoseEstimator(task.camera, task.markers_O)`` made once
    (the same pose as ``estimate_camera_pose``, without checking the markers at every frame).
    """
    camera, n = task.camera, task.n_points
    if rows == 3:
        P_C = triangulate_points(camera, features.reshape(n, 3), task.virtual_points)
    else:
        T_O_C = estimate_camera_pose(camera, features, task.markers_O) if pose is None else pose(features)
        Z = transform_points(inverse_pose(T_O_C), task.markers_O)[:, 2]  # [m]
        P_C = np.column_stack((features.reshape(n, 2) * (Z / camera.focal_length)[:, None], Z))
    return points_interaction_matrix(camera, P_C, task.virtual_points)
