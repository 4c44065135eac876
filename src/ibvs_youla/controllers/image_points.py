"""Point features for the image-based laws: the task's layout and the interaction matrix at the current image.

Shared by classical IBVS (:mod:`.ibvs`) and MPC-IBVS (:mod:`.mpc_ibvs`), which both evaluate
L(s, Z) at the measured features with depths from the controller's own model:

* stereo (a ``StereoCamera``, >= 3 points, 3 rows per point): the points triangulated from the
  features (Eq. (C6)-(C8) of the paper, :func:`~ibvs_youla.model.camera.triangulate_points`);
* monocular (a ``PinholeCamera``, >= 4 points, 2 rows per point): the camera pose estimated
  from the image by OpenCV's PnP (SQPnP, or the controller's ``pnp`` method:
  :func:`~ibvs_youla.estimation.monocular_pose.pnp_options`), and the believed markers' depths
  Z_i in it (r_3 . P_i + t_z of the PnP's [R | t],
  :func:`~ibvs_youla.estimation.monocular_pose.marker_depths_monocular`); the points are
  back-projected, X = u Z / F.

A frame that carries measured depths (a depth sensor, :attr:`~.base.CameraFrame.depth`) gives
the depths instead, with no estimate: the points are back-projected at them, X = u Z / F,
Y = v Z / F (monocular), X = (u_l + u_r) Z / (2 F), Y = v Z / F (stereo, mid-baseline), as
ViSP's tutorials give ``vpFeaturePoint`` the simulator's depth.

The laws on other features of the same points (polar, partitioned, moment IBVS) take the points
in the camera frame as :class:`CurrentPoints` believes them, the normalized image of the camera
frame's origin (:func:`normalized_points`: x = u / F, y = v / F; for a stereo camera the mean of
the two lenses' u, which is F X / Z of the frame {C} mid-baseline, ERRATA 12) and the normalized
point interaction rows (:func:`normalized_point_rows`).
"""

from __future__ import annotations

import numpy as np

from ..estimation.monocular_pose import CameraPoseEstimator, marker_depths_monocular, pnp_options
from ..exceptions import InvalidParameterError
from ..model.camera import (
    PinholeCamera,
    StereoCamera,
    points_at_depths,
    points_interaction_matrix,
    triangulate_points,
)
from ..model.camera_kernels import camera_parameters, interaction_matrix, triangulate
from .base import ServoTask

__all__ = [
    "CurrentInteraction",
    "CurrentPoints",
    "current_interaction_matrix",
    "feature_rows",
    "normalized_point_rows",
    "normalized_points",
    "pnp_spec",
]


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


def pnp_spec(pnp: str) -> dict[str, str]:
    """The ``pnp`` entry of a controller's :meth:`~.base.Controller.spec`: none for the default ``"sqpnp"``.

    A run's metadata holds its controller's spec; with the default left out, the metadata of runs
    made before the option existed, and of runs that do not choose it, stay as they were.
    """
    return {} if pnp == "sqpnp" else {"pnp": pnp}


def current_interaction_matrix(
    task: ServoTask, features: np.ndarray, rows: int, depth: np.ndarray | None = None, pnp: str = "sqpnp"
) -> np.ndarray:
    """L(s, Z) (m, 6) at the measured features, depths measured or from the controller's model.

    The plain reference of :class:`CurrentInteraction`, which the controllers call at every frame
    (module docstring); ``depth`` (n,) [m] is a frame's measured depths, None for none; ``pnp`` the
    monocular pose's PnP method. (It does not fall back from IPPE to SQPnP as the estimator does.)
    """
    camera, n = task.camera, task.n_points
    if depth is not None:
        P_C = points_at_depths(camera, features, depth)
    elif rows == 3:
        P_C = triangulate_points(camera, features.reshape(n, 3), task.virtual_points)
    else:
        Z = marker_depths_monocular(camera, features, task.markers_O, pnp)  # [m]
        P_C = np.column_stack((features.reshape(n, 2) * (Z / camera.focal_length)[:, None], Z))
    return points_interaction_matrix(camera, P_C, task.virtual_points)


class CurrentPoints:
    """The markers in the camera frame as the controller believes them at a frame, P_C (n, 3) [m].

    Stereo: the points triangulated from the features (compiled, as
    :func:`~ibvs_youla.model.camera.triangulate_points`); monocular: the depths of the believed
    markers in the pose of a :class:`~ibvs_youla.estimation.monocular_pose.CameraPoseEstimator`
    (:attr:`pose_estimator`), the measured points back-projected at them (X = u Z / F).

    Args:
        task: The controller's task.
        rows: Rows per point, from :func:`feature_rows`.
        pnp: The monocular pose's PnP method, one of
            :data:`~ibvs_youla.estimation.monocular_pose.PNP_METHODS` (default ``"sqpnp"``).

    Raises:
        InvalidParameterError: ``pnp`` other than ``"sqpnp"`` with a stereo camera, or ``"ippe"``
            with markers that are not coplanar.
    """

    def __init__(self, task: ServoTask, rows: int, pnp: str = "sqpnp") -> None:
        self.task, self._rows, self._n = task, rows, task.n_points
        self._camera, self._allow_behind = task.camera, bool(task.virtual_points)
        self._params, self._lens_x = camera_parameters(task.camera)
        options = pnp_options(task.camera, pnp)  # stereo: {} for the default, else refused
        self.pose_estimator = (
            CameraPoseEstimator(task.camera, task.markers_O, **options) if rows == 2 else None
        )

    def __call__(self, features: np.ndarray, depth: np.ndarray | None = None) -> np.ndarray:
        """P_C (n, 3) [m] at the measured features (m,), at the measured depths (n,) [m] if given."""
        camera, n = self._camera, self._n
        if depth is not None:
            return points_at_depths(camera, features, depth)  # type: ignore[no-any-return]
        if self.pose_estimator is None:  # stereo: the points triangulated
            P_C, bad = triangulate(features.reshape(-1), self._params, self._allow_behind)
            if bad >= 0:  # a disparity the triangulation rejects: the reference raises its error
                triangulate_points(camera, features.reshape(n, 3), self._allow_behind)
            return P_C  # type: ignore[no-any-return]
        Z = self.pose_estimator.marker_depths(features)  # [m], of the markers the estimator was given
        return np.column_stack((features.reshape(n, 2) * (Z / camera.focal_length)[:, None], Z))


class CurrentInteraction:
    """:func:`current_interaction_matrix` of one task, with what does not change made once.

    ``CurrentInteraction(task, rows)(features)`` gives the same matrix by the same arithmetic:
    the triangulation and the interaction matrix in compiled calls
    (:mod:`~ibvs_youla.model.camera_kernels`, the same operations in the same order as the
    plain kernels, hence the same floats), the monocular pose from a
    :class:`~ibvs_youla.estimation.monocular_pose.CameraPoseEstimator` (:attr:`pose_estimator`,
    which a controller may share with another law), both through :class:`CurrentPoints`.

    Args:
        task: The controller's task.
        rows: Rows per point, from :func:`feature_rows`.
        pnp: The monocular pose's PnP method, as :class:`CurrentPoints`.
    """

    def __init__(self, task: ServoTask, rows: int, pnp: str = "sqpnp") -> None:
        self.points = CurrentPoints(task, rows, pnp)
        self._camera, self._allow_behind = task.camera, bool(task.virtual_points)
        self._params, self._lens_x = camera_parameters(task.camera)
        self.pose_estimator = self.points.pose_estimator

    def __call__(self, features: np.ndarray, depth: np.ndarray | None = None) -> np.ndarray:
        """L(s, Z) (m, 6) at the measured features (m,), at the measured depths (n,) [m] if given."""
        P_C = self.points(features, depth)
        L, bad = interaction_matrix(P_C, self._params, self._lens_x, self._allow_behind)
        if bad >= 0:  # a depth the interaction matrix rejects: the reference raises its error
            points_interaction_matrix(self._camera, P_C, self._allow_behind)
        return L  # type: ignore[no-any-return]


def normalized_points(camera: StereoCamera | PinholeCamera, features: np.ndarray) -> np.ndarray:
    """The normalized image (n, 2) of the camera frame's origin, [x, y] = [X / Z, Y / Z] per point.

    Monocular features [u, v]: x = u / F, y = v / F. Stereo features [u_l, u_r, v]: x =
    (u_l + u_r) / (2 F), y = v / F, since u_l = F (X - b/2) / Z and u_r = F (X + b/2) / Z
    (ERRATA 12): the image a pinhole camera at the origin of {C} would take. Unvalidated:
    ``features`` must be a float array of the camera's layout.
    """
    F = camera.focal_length
    if isinstance(camera, StereoCamera):
        p = features.reshape(-1, 3)
        return np.column_stack((0.5 * (p[:, 0] + p[:, 1]), p[:, 2])) / F
    return features.reshape(-1, 2) / F


def normalized_point_rows(x: np.ndarray, y: np.ndarray, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The interaction rows of normalized image points, (L_x, L_y), each (n, 6).

    For a static point seen from a camera moving with [v; w] in its frame (Chaumette &
    Hutchinson 2006, Eq. (11)):

        L_x = [-1/Z, 0, x/Z, x y, -(1 + x^2), y],   L_y = [0, -1/Z, y/Z, 1 + y^2, -x y, -x].

    Unvalidated: x, y, Z are float arrays (n,), Z != 0 [m].
    """
    iz = 1.0 / Z
    zero = np.zeros_like(iz)
    L_x = np.column_stack((-iz, zero, x * iz, x * y, -(1.0 + x * x), y))
    L_y = np.column_stack((zero, -iz, y * iz, 1.0 + y * y, -x * y, -x))
    return L_x, L_y
