"""Eye-in-hand model F: joint angles -> stereo features of fixed markers, its Jacobian and inverse.

Sec. 4.4-4.5 (Eq. 21-25): P_C = T_C_O P_O, features = M(P_C) (Eq. 11; the paper's p_image), so
features = F(q, Pa, P_O) (Eq. 24). Sec. 6.3: the 9 x n Jacobian J = L(P_C) J_C(q) (Eq. 51,
ERRATA 12; 9x6 for six joints) and the estimate q~ = F^-1(features) (Eq. 62) through stereo P3P
(Sec. 3, Appendix C) and the arm's inverse kinematics.
The public methods validate their arguments (a NaN or mis-shaped input raises InvalidArrayError,
never a NaN result or a bare numpy error); constants are precomputed. Two of them are a check in
front of a kernel that the servo loop's controller calls directly, at every camera frame, with
arrays valid by construction: `EyeInHand.image_jacobian` (of `jacobian`, one kinematics pass of
the arm for T_O_C and J_C) and `EyeInHand.q_from_image` (of `estimate_q`); the adaptive controller
calls `EyeInHand.q_and_jacobian_from_image`, both at once from one kinematics pass at q~. The
arithmetic runs in compiled kernels (:mod:`~ibvs_youla.estimation.stereo_kernels`,
:mod:`~ibvs_youla.model.camera_kernels`), pinned to the plain functions they replace
(`triangulate_points`, `kabsch_centred`, `points_interaction_matrix`) by the tests.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .._validation import as_array, as_pose, flag, instance
from ..exceptions import InvalidArrayError
from ..model.camera import (
    StereoCamera,
    Visibility,
    points_interaction_matrix,
    project_points,
    triangulate_points,
)
from ..model.camera_kernels import camera_parameters, image_jacobian
from .stereo_kernels import camera_pose_from_features
from .stereo_pose import check_marker_geometry

if TYPE_CHECKING:
    from ..model.arm import Arm

__all__ = ["EyeInHand"]


class EyeInHand:
    """Stereo camera on the flange of an arm, observing markers fixed in the base frame (Eq. 23-25).

    Features are point-major, ``[u_l1, u_r1, v1, u_l2, ...]`` [m on the sensor] (Eq. 24).

    Args:
        arm: The arm: ``camera_pose(q)`` (T_O_C), ``camera_pose_and_jacobian(q)`` (with J_C,
            6 x n_joints LOCAL, twist [v; w] in C) and ``ik_nearest(T_O_C, q_near)`` (the IK
            solution nearest q_near).
        camera: The stereo camera.
        markers_O: Marker positions (n, 3), n >= 3 (the paper uses 3), in the base frame [m].
        virtual_points: Let markers lie behind the camera (negative depth and disparity), as the
            paper's scenarios need (ERRATA 13). Zero depth or disparity still raises.

    Raises:
        InvalidParameterError: ``arm`` is not an Arm, ``camera`` not a StereoCamera, or
            ``virtual_points`` not True or False.
        InvalidArrayError: markers_O is not a finite (n, 3) array with n >= 3.
        DegenerateMarkersError: coincident or collinear markers (they would not fix the pose, Sec. 3).
    """

    def __init__(self, arm: Arm, camera: StereoCamera, markers_O: object, virtual_points: bool = False):
        from ..model.arm import Arm

        self.arm = instance(arm, "arm", Arm, "an Arm (e.g. Arm.irb4600())")
        self.camera = instance(camera, "camera", StereoCamera, "a StereoCamera (Eq. 24: stereo features)")
        self.markers_O = check_marker_geometry(markers_O, "markers_O").copy()
        self.markers_O.flags.writeable = False
        self.virtual_points = flag(virtual_points, "virtual_points")
        self._markers_mean = np.add.reduce(self.markers_O, axis=0) / self.markers_O.shape[0]  # [m]
        self._markers_centred = self.markers_O - self._markers_mean  # [m], Eq. (C11) for fixed markers
        self._params, self._lens_x = camera_parameters(camera)  # for the compiled kernels

    @property
    def n_features(self) -> int:
        """Number of features, 3 per marker (9 for the paper)."""
        return 3 * self.markers_O.shape[0]

    def points_in_camera_at_pose(self, T_O_C: np.ndarray) -> np.ndarray:
        """Markers in the camera frame, P_C = T_C_O P_O (Eq. 21-22), (n, 3) [m].

        Raises:
            InvalidArrayError: ``T_O_C`` is not a finite 4x4 rigid transform.
        """
        return self._points_in_camera(as_pose(T_O_C, "T_O_C"))

    def points_in_camera(self, q: np.ndarray) -> np.ndarray:
        """Markers in the camera frame at joint angles q (n_joints,) [rad], (n, 3) [m]."""
        return self._points_in_camera(self.arm.camera_pose(q))

    def _points_in_camera(self, T_O_C: np.ndarray) -> np.ndarray:
        R = T_O_C[:3, :3]
        return (self.markers_O - T_O_C[:3, 3]).dot(R)  # rows R^T (P_O - t)

    def features_at_pose(self, T_O_C: np.ndarray) -> np.ndarray:
        """Stereo features (3n,) [m] of the markers seen from camera pose T_O_C (Eq. 11, 21).

        Raises:
            InvalidArrayError: ``T_O_C`` is not a finite 4x4 rigid transform.
            PointBehindCameraError: a marker has Z_C <= 0 (only |Z_C| ~ 0 with virtual points).
        """
        return project_points(self.camera, self.points_in_camera_at_pose(T_O_C), self.virtual_points)

    def features(self, q: np.ndarray) -> np.ndarray:
        """Eye-in-hand map F of Eq. (24): stereo features (3n,) [m] at joint angles q (n_joints,) [rad]."""
        return project_points(self.camera, self.points_in_camera(q), self.virtual_points)

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Image Jacobian dF/dq (3n, n_joints) of Eq. (51) (9x6 for three markers and six joints, ERRATA 12).

        J = L(P_C) J_C(q): the stereo interaction matrix (twist [v; w] in C to feature rates) times
        the arm's LOCAL camera Jacobian (dq to that twist). Rank 5 at wrist singularities (ERRATA 7).

        Raises:
            InvalidArrayError: ``q`` is not a finite (n_joints,) array.
        """
        return self.image_jacobian(as_array(q, "q", (self.arm.nq,)))

    def image_jacobian(self, q: np.ndarray) -> np.ndarray:
        """`jacobian` from one kinematics pass of the arm (``Arm.camera_pose_and_jacobian``).

        Kernel: does not validate ``q``, which must be a finite float64 (n_joints,) array [rad].
        """
        return self._jacobian_at(*self.arm.camera_pose_and_jacobian(q))

    def _jacobian_at(self, T_O_C: np.ndarray, J_C: np.ndarray) -> np.ndarray:
        """L(P_C) J_C from the camera pose and its LOCAL Jacobian, one compiled call (Eq. (51))."""
        J, bad = image_jacobian(T_O_C, J_C, self.markers_O, self._params, self._lens_x, self.virtual_points)
        if bad >= 0:  # a depth the interaction matrix rejects: the reference raises its error
            points_interaction_matrix(self.camera, self._points_in_camera(T_O_C), self.virtual_points)
        return J

    def visibility(self, q: np.ndarray) -> Visibility:
        """Depth sign, field of view and depth range of every marker at q (ERRATA 13)."""
        return self.camera.visibility(self.points_in_camera(q))

    def estimate_camera_pose(self, features: np.ndarray) -> np.ndarray:
        """Stereo P3P (Sec. 3, Appendix C): T_O_C (4x4) from features (3n,) or (n, 3) [m].

        Triangulates the markers (Eq. C6-C8) and fits T_O_C with P_O ≈ T_O_C P_C (Eq. C10-C17).

        Raises:
            InvalidArrayError: ``features`` is not a finite (3n,) or (n, 3) array, n the number of markers.
            InvalidDisparityError: a marker's disparity is ~0, or negative without virtual points.
        """
        return self._camera_pose_from_image(self._check_features(features))

    def _check_features(self, features: object) -> np.ndarray:
        """``features`` as a finite (n, 3) float array, n the number of markers (accepts (3n,) or (n, 3))."""
        n = self.markers_O.shape[0]
        p = as_array(features, "features")
        if p.shape not in ((3 * n,), (n, 3)):
            raise InvalidArrayError(
                "features",
                f"an array of shape {p.shape}",
                f"shape ({3 * n},) or ({n}, 3): [u_l, u_r, v] for each of the {n} markers",
            )
        return p.reshape(n, 3)

    def _camera_pose_from_image(self, features: np.ndarray) -> np.ndarray:
        """Stereo P3P in one compiled call: ``kabsch_centred(triangulate_points(...), ...)``."""
        T_O_C, bad = camera_pose_from_features(
            features.reshape(-1), self._params, self.virtual_points, self._markers_centred, self._markers_mean
        )
        if bad >= 0:  # a disparity the triangulation rejects: the reference raises its error
            triangulate_points(self.camera, features.reshape(-1, 3), self.virtual_points)
        return T_O_C

    def estimate_q(self, features: np.ndarray, q_near: np.ndarray) -> np.ndarray:
        """Joint angles q~ = F^-1(features) of Eq. (62) (n_joints,) [rad]: the IK branch nearest to q_near.

        Raises:
            InvalidArrayError: ``features`` is not a finite (3n,) or (n, 3) array, or ``q_near`` not a
                finite (n_joints,) array.
            InvalidDisparityError: see `estimate_camera_pose`.
            UnreachablePoseError: no IK branch within the joint limits reaches the estimated pose.
        """
        return self.q_from_image(self._check_features(features), as_array(q_near, "q_near", (self.arm.nq,)))

    def q_from_image(self, features: np.ndarray, q_near: np.ndarray) -> np.ndarray:
        """q~ = F^-1(features) of Eq. (62): stereo P3P, then the IK branch nearest q_near (Arm.ik_nearest).

        Kernel of `estimate_q`: does not validate its arguments. ``features`` must be a finite
        float (3n,) or (n, 3) array [m], ``q_near`` a finite float (n_joints,) array [rad]; the errors
        of `estimate_q` on valid input (disparity, unreachable pose) are still raised.
        """
        return self.arm.ik_nearest(self._camera_pose_from_image(features), q_near)

    def q_and_jacobian_from_image(
        self, features: np.ndarray, q_near: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """(q~, J(q~)): `q_from_image` and `image_jacobian` at its result, from one kinematics pass at q~.

        The adaptive loop's frame (Eq. (51), (62)): the pass of the arm that checks the IK
        branch (``Arm.ik_nearest_kinematics``) also gives T_O_C(q~) and J_C(q~). Kernel: arguments
        as `q_from_image`, whose errors it raises.
        """
        q, T_O_C, J_C = self.arm.ik_nearest_kinematics(self._camera_pose_from_image(features), q_near)
        return q, self._jacobian_at(T_O_C, J_C)
