"""2.5-D visual servoing: a reference point in the image and its depth ratio, plus the rotation theta u.

Malis, Chaumette & Boudet, "2 1/2 D visual servoing", IEEE Transactions on Robotics and
Automation 15(2):238-250, 1999 (summarized in Chaumette & Hutchinson, "Visual servo control,
Part II: Advanced approaches", IEEE Robotics & Automation Magazine 14(1), 2007). The task
function mixes image and 3-D features,

    e = (x - x*, y - y*, log rho, theta u),    rho = Z / Z*,

with (x, y) the normalized image coordinates of one reference point, Z its depth, * the desired
values, and theta u the angle-axis of the rotation c*R_c (current frame {c} in the desired {c*}).
For a static point seen from a camera moving with [v; omega] (current frame) the interaction
matrix is upper block-triangular,

    L = [[L_v, L_vw], [0, L_w]],    L_v = (1 / Z) [[-1, 0, x], [0, -1, y], [0, 0, -1]],
    L_vw = [[x y, -(1 + x^2), y], [1 + y^2, -x y, -x], [-y, x, 0]],
    L_w = I + (theta/2) [u]x + (1 - sinc(theta) / sinc^2(theta/2)) [u]x^2,

(the rows of x and y are the classical point interaction matrix, the third row d(log Z)/dt =
-v_z / Z - y omega_x + x omega_y; the sign of (theta/2) [u]x is that of theta u of c*R_c with omega
in the current frame, see :mod:`~.pbvs`). L_v is invertible for every Z > 0 and L_w^-1 theta u = theta u,
so v_c = -lambda L^-1 e needs no pseudo-inverse (and no singular-value cut-off):

    omega = -lambda theta u,    v = -lambda L_v^-1 (e_v - L_vw theta u),
    L_v^-1 = Z [[-1, 0, -x], [0, -1, -y], [0, 0, -1]],

so that each part of e decays as exp(-lambda t): the reference point moves on a straight line in
the image, and the rotation about a fixed axis. On the sampled free camera the rotation part is
exact, theta u_{k+1} = (1 - lambda T) theta u_k (as for :class:`~.pbvs.PBVS`); the image part is
not, the held twist being integrated by the exponential map (``tests/test_two_half_d.py`` pins
its deviation).

Reference point (``reference_point``): by default the centroid of the markers, a virtual point.
Any point of the target serves in Malis et al.'s derivation; the centroid's image moves on a
straight line to its desired place near the middle of the pattern, which keeps the pattern's
points in view better than a corner, and it does not depend on the order of the markers. For
coplanar markers it lies on their plane, so the homography maps it as it maps the markers. A
marker index uses that marker instead (its (x, y) then come straight from the image). The desired
(x*, y*, Z*) are those of the point at the task's ``T_O_C_target``.

Rotation and depth ratio (``rotation_from``):

* ``"pose"`` (any camera): the current pose from the image by
  :func:`~ibvs_youla.estimation.monocular_pose.estimate_camera_pose` (stereo P3P, or OpenCV SQPnP
  or the ``pnp`` method for a monocular camera; from the measured depths by Kabsch when the frame
  carries them, as PBVS), the desired one from the task: c*T_c gives theta u, and the reference
  point's depth in {c} gives rho.
* ``"homography"`` (monocular camera, four or more coplanar markers): Malis et al.'s route, no
  current pose; of the 3-D model it uses the plane's normal n* and the depth Z* at the target (the
  scale of L_v, which Malis et al. estimate), both from the task. The homography H with m ~ H m*
  between the desired and current normalized coordinates of the markers is, scaled to middle
  singular value 1 (the Euclidean homography), H = c R_c* + (c t_c* / d*) n*^T, with n* the
  plane's unit normal in {c*} and d* > 0 its distance; for a point of the plane, H m* = rho m, so
  rho = (H m*)_z whichever decomposition is chosen. H comes from :func:`euclidean_homography` (a
  normalized DLT: ``cv2.findHomography`` stops 1e-7 away from the exact H on exact points) and is
  decomposed by ``cv2.decomposeHomographyMat`` with K = I. Its (up to) four solutions are two
  pairs (R, t, n) and (R, -t, -n); :func:`rotation_from_homography` keeps those that put every
  marker in front of the desired camera, n^T m*_i > 0 (the visibility constraint, which removes
  one of each pair), then the one whose normal is closest to n* known from the task (markers_O and
  T_O_C_target). Near the goal (largest entry of |H^T H - I| < 1e-3) OpenCV returns H itself as a single "pure
  rotation", off the true rotation by (t / d*) n*^T; there R is recovered from the known normal
  instead: R a = H a for every a orthogonal to n*.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._geometry import inverse_pose, transform_points
from .._linalg import svd
from .._validation import integer, one_of, positive
from ..estimation.monocular_pose import PNP_METHODS, CameraPoseEstimator
from ..exceptions import InvalidParameterError, PointBehindCameraError, PoseEstimationError
from ..model.camera import PinholeCamera
from .base import CameraFrame, CommandType, Controller, JointReading, ServoTask
from .image_points import pnp_spec
from .pbvs import check_pose_task, check_sampled_gain, pose_options, theta_u
from .two_half_d_kernels import pose_route_twist

__all__ = [
    "REGISTRATIONS",
    "ROTATION_SOURCES",
    "TwoHalfD",
    "euclidean_homography",
    "interaction_matrix",
    "rotation_from_homography",
]

ROTATION_SOURCES = ("pose", "homography")
COPLANAR_TOLERANCE = 1e-6  # off-plane distance of a marker / extent of the markers, for the homography route


def _skew(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def interaction_matrix(x: float, y: float, Z: float, tu: np.ndarray) -> np.ndarray:
    """The 2.5-D interaction matrix L (6, 6) of e = (x - x*, y - y*, log rho, theta u) (module docstring).

    Args:
        x: Normalized image abscissa X / Z of the reference point.
        y: Normalized image ordinate Y / Z.
        Z: Its depth in the current camera frame [m], > 0.
        tu: theta u of c*R_c (3,) [rad], theta < 2 pi.
    """
    L = np.zeros((6, 6))
    L[:3, :3] = np.array([[-1.0, 0.0, x], [0.0, -1.0, y], [0.0, 0.0, -1.0]]) / Z
    L[:3, 3:] = [[x * y, -(1.0 + x * x), y], [1.0 + y * y, -x * y, -x], [-y, x, 0.0]]
    theta = float(np.linalg.norm(tu))
    L[3:, 3:] = np.eye(3)
    if theta > 0.0:
        K = _skew(tu / theta)
        sinc_half = math.sin(theta / 2.0) / (theta / 2.0)
        L[3:, 3:] += 0.5 * theta * K + (1.0 - (math.sin(theta) / theta) / sinc_half**2) * (K @ K)
    return L


def _normalizing_transform(p: np.ndarray) -> np.ndarray:
    """Hartley's conditioning (3, 3): centroid to the origin, mean distance sqrt(2)."""
    c = p.mean(axis=0)
    mean_distance = float(np.mean(np.linalg.norm(p - c, axis=1)))
    s = math.sqrt(2.0) / mean_distance
    return np.array([[s, 0.0, -s * c[0]], [0.0, s, -s * c[1]], [0.0, 0.0, 1.0]])


def euclidean_homography(m_target: np.ndarray, m: np.ndarray) -> np.ndarray:
    """H (3, 3) with H [m*; 1] = rho [m; 1], rho = Z / Z* of each point of the plane (module docstring).

    The direct linear transform on Hartley-normalized coordinates (one SVD of the 2n x 9 system,
    not of its normal equations), scaled to middle singular value 1 and signed so that the depth
    ratios are positive: exact to rounding on exact coplanar points. Unvalidated.

    Args:
        m_target: Desired normalized coordinates (n, 2), n >= 4, no three collinear.
        m: Current normalized coordinates (n, 2) of the same points.
    """
    T_from, T_to = _normalizing_transform(m_target), _normalizing_transform(m)
    n = m_target.shape[0]
    a = np.column_stack((m_target, np.ones(n))) @ T_from.T
    b = np.column_stack((m, np.ones(n))) @ T_to.T
    A = np.zeros((max(2 * n, 9), 9))  # padded to 9 rows: the economy SVD then returns the null vector
    A[0 : 2 * n : 2, 0:3] = a
    A[0 : 2 * n : 2, 6:9] = -b[:, :1] * a
    A[1 : 2 * n : 2, 3:6] = a
    A[1 : 2 * n : 2, 6:9] = -b[:, 1:2] * a
    H = np.linalg.solve(T_to, svd(A)[2][-1].reshape(3, 3) @ T_from)
    H /= svd(H)[1][1]
    rho = H[2, :2] @ m_target.T + H[2, 2]
    return H if rho.sum() > 0.0 else -H


def _rotation_from_normal(H: np.ndarray, n_target: np.ndarray) -> np.ndarray:
    """The rotation c R_c* of H = R + t n*^T with n* known: R a = H a for a orthogonal to n*, on SO(3)."""
    a = np.cross(n_target, [1.0, 0.0, 0.0] if abs(n_target[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(n_target, a)  # (a, b, n*) right-handed
    Ha, Hb = H @ a, H @ b
    M = np.column_stack((Ha, Hb, np.cross(Ha, Hb))) @ np.vstack((a, b, n_target))
    U, _, Vt = svd(M)
    return U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))]) @ Vt


def rotation_from_homography(H: np.ndarray, m_target: np.ndarray, n_target: np.ndarray) -> np.ndarray:
    """c*R_c (3, 3): the rotation of the current camera in the desired frame, from the homography.

    ``cv2.decomposeHomographyMat(H, I)``; of its solutions (R = c R_c*, t / d*, n in {c*}), those
    with n^T m*_i > 0 for every marker (the plane in front of the desired camera), then the one
    whose normal is closest to ``n_target``. OpenCV's pure-rotation answer (one solution, n = 0,
    when every entry of |H^T H - I| < 1e-3) is replaced by the rotation recovered with the known
    normal (module docstring). Unvalidated.

    Args:
        H: Euclidean homography (3, 3) of :func:`euclidean_homography`.
        m_target: Desired normalized coordinates of the markers (n, 2).
        n_target: Unit normal of the markers' plane in the desired frame, n*^T P* = d* > 0.

    Raises:
        PoseEstimationError: no solution puts the markers in front of the desired camera.
    """
    import cv2

    _, rotations, _, normals = cv2.decomposeHomographyMat(H, np.eye(3))
    if len(rotations) == 1 and not np.any(normals[0]):
        return _rotation_from_normal(H, n_target).T
    m_h = np.column_stack((m_target, np.ones(m_target.shape[0])))
    best, best_cos = None, -np.inf
    for R, n in zip(rotations, normals, strict=True):
        n = n.ravel()
        if np.all(m_h @ n > 0.0) and n @ n_target > best_cos:
            best, best_cos = R, float(n @ n_target)
    if best is None:
        raise PoseEstimationError(
            "homography", f"no decomposition of the homography puts the {m_target.shape[0]} markers in front"
        )
    return np.asarray(best).T


class TwoHalfD(Controller):
    """2.5-D visual servoing (Malis, Chaumette & Boudet 1999); see the module docstring.

    Args:
        gain: lambda [1/s], > 0 (default 0.5, ViSP's tutorial value); at reset, lambda T < 2 for the
            frame period T.
        rotation_from: ``"pose"`` (default; stereo P3P or PnP) or ``"homography"`` (monocular camera
            and four or more coplanar markers).
        reference_point: ``"centroid"`` (default, the markers' centroid) or a marker index.
        pnp: The PnP method of the monocular pose (``rotation_from="pose"``), one of
            :data:`~ibvs_youla.estimation.monocular_pose.PNP_METHODS` (default ``"sqpnp"``;
            ``"ippe"`` for coplanar markers). The homography route and a stereo camera estimate no
            PnP pose and take only the default.

    Raises:
        InvalidParameterError: a bad gain, an unknown ``rotation_from``, a ``reference_point`` that
            is neither ``"centroid"`` nor an index, an unknown ``pnp`` or one other than ``"sqpnp"``
            with the homography route; at reset, ``pnp`` other than ``"sqpnp"`` with a stereo
            camera, ``"ippe"`` with markers that are not coplanar, lambda T >= 2, an index out of range,
            too few markers or a camera of another kind (:func:`~.pbvs.check_pose_task`), and for
            the homography route a camera that is not a ``PinholeCamera`` or markers that are not
            coplanar (within 1e-6 of their extent).
    """

    command_type = CommandType.CAMERA_TWIST
    name = "2.5d"

    def __init__(
        self,
        gain: float = 0.5,
        rotation_from: str = "pose",
        reference_point: str | int = "centroid",
        pnp: str = "sqpnp",
    ) -> None:
        self.gain = positive(gain, "gain", unit="1/s")
        self.rotation_from = one_of(rotation_from, "rotation_from", ROTATION_SOURCES)
        self.pnp = one_of(pnp, "pnp", PNP_METHODS)
        if self.rotation_from == "homography" and self.pnp != "sqpnp":
            raise InvalidParameterError(
                "pnp",
                self.pnp,
                "'sqpnp' (the default) with rotation_from='homography', which estimates no PnP pose; "
                "the PnP method acts with rotation_from='pose'",
            )
        if isinstance(reference_point, str) and reference_point == "centroid":
            self.reference_point: str | int = "centroid"
        else:
            try:
                self.reference_point = integer(reference_point, "reference_point", low=0)
            except InvalidParameterError:
                raise InvalidParameterError(
                    "reference_point", reference_point, "'centroid' or a marker index >= 0"
                ) from None

    def spec(self) -> dict[str, Any]:
        """Name, class, gain [1/s], rotation source, reference point, PnP method unless the default."""
        return {
            **super().spec(),
            "gain": self.gain,
            "rotation_from": self.rotation_from,
            "reference_point": self.reference_point,
            **pnp_spec(self.pnp),
        }

    # ------------------------------------------------------------------ run
    def reset(self, task: ServoTask) -> None:
        """Check the task; the desired reference point (x*, y*, Z*), and the plane (homography route)."""
        check_pose_task(task, self.name)
        check_sampled_gain(self.gain, task.frame_period, self.name)
        markers_O = np.asarray(task.markers_O, dtype=float)
        n = markers_O.shape[0]
        index = self.reference_point
        if index != "centroid" and not 0 <= index < n:
            raise InvalidParameterError(
                "reference_point", index, f"'centroid' or a marker index in [0, {n - 1}] ({n} markers)"
            )
        if self.rotation_from == "homography":
            self._check_homography_task(task, markers_O)
        super().reset(task)
        T_O_target = np.asarray(task.T_O_C_target, dtype=float)
        self._T_target_O = inverse_pose(T_O_target)  # T_c*_O
        self._reference_O = markers_O.mean(axis=0) if index == "centroid" else markers_O[index]
        P_target = transform_points(self._T_target_O, self._reference_O[None])[0]  # reference in {c*}
        if P_target[2] <= 0.0:
            raise InvalidParameterError(
                "reference_point", self.reference_point, "a point in front of the camera at the target pose"
            )
        self._Z_target = float(P_target[2])  # Z* [m]
        self._m_ref_target = P_target / P_target[2]  # [x*, y*, 1]
        self._F = float(task.camera.focal_length)
        # the pose route's compiled law (two_half_d_kernels.pose_route_twist)
        per_point = 2 if isinstance(task.camera, PinholeCamera) else 3
        marker = -1.0 if index == "centroid" else float(index)
        self._law = np.array([self._Z_target, *self._m_ref_target[:2], self.gain, marker, self._F, per_point])
        self._options = pose_options(task, self.pnp)
        # the camera pose of each frame (estimate_camera_pose, its arguments checked once)
        self.pose_estimator = CameraPoseEstimator(task.camera, task.markers_O, **self._options)
        if self.rotation_from == "homography":
            self._m_target = np.asarray(task.feature_target, dtype=float).reshape(n, 2) / self._F
            _, _, Vt = svd(markers_O - markers_O.mean(axis=0))
            n_target = T_O_target[:3, :3].T @ Vt[2]  # the plane's normal in {c*}
            self._n_target = n_target if n_target @ P_target > 0.0 else -n_target
        self._error = np.zeros(6)
        self._twist = np.zeros(6)

    @staticmethod
    def _check_homography_task(task: ServoTask, markers_O: np.ndarray) -> None:
        if not isinstance(task.camera, PinholeCamera):
            raise InvalidParameterError(
                "rotation_from",
                "homography",
                f"'pose' with a {type(task.camera).__name__}: the homography route needs a PinholeCamera",
            )
        centred = markers_O - markers_O.mean(axis=0)
        _, _, Vt = svd(centred)
        off_plane = float(np.abs(centred @ Vt[2]).max())  # [m]
        extent = float(np.linalg.norm(centred, axis=1).max())  # [m]
        if off_plane > COPLANAR_TOLERANCE * extent:
            raise InvalidParameterError(
                "rotation_from",
                "homography",
                f"'pose' for these markers: the homography route needs coplanar markers (off-plane "
                f"distance <= {COPLANAR_TOLERANCE:g} x extent {extent:.4g} m; here {off_plane:.4g} m)",
            )

    def update(self, frame: CameraFrame, reading: JointReading | None) -> None:
        """The task function e from the frame and the twist of v_c = -lambda L^-1 e (module docstring)."""
        features = frame.features
        if self.rotation_from == "homography":
            m = features.reshape(-1, 2) / self._F
            H = euclidean_homography(self._m_target, m)
            R_target_C = rotation_from_homography(H, self._m_target, self._n_target)
            if self.reference_point == "centroid":
                q = H @ self._m_ref_target  # rho [x, y, 1]
                rho, x, y = q[2], q[0] / q[2], q[1] / q[2]
            else:
                i = self.reference_point
                rho = H[2] @ np.array([*self._m_target[i], 1.0])
                x, y = m[i]
        else:
            T_O_C = self.pose_estimator(features, frame.depth)
            twist, error = np.empty(6), np.empty(6)
            if pose_route_twist(T_O_C, *self.pose_route_law(), features, twist, error):
                self._twist, self._error = twist, error
            else:  # the reference point behind the camera (raises), or scipy's theta u
                self._pose_route_reference(T_O_C, features)
            return
        self._twist_from(R_target_C, rho, x, y)

    def pose_route_law(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(c*T_O (4, 4), the reference point in O (3,) [m], law): the pose route's constants.

        After :meth:`reset`; the arguments of :func:`~.two_half_d_kernels.pose_route_twist`.
        """
        return self._T_target_O, self._reference_O, self._law

    def _pose_route_reference(self, T_O_C: np.ndarray, features: np.ndarray) -> None:
        """The pose route in numpy: the reference of :func:`~.two_half_d_kernels.pose_route_twist`."""
        R_target_C = (self._T_target_O @ T_O_C)[:3, :3]
        X, Y, Z = (self._reference_O - T_O_C[:3, 3]) @ T_O_C[:3, :3]  # reference in {c}
        rho = Z / self._Z_target
        x, y = (X / Z, Y / Z) if self.reference_point == "centroid" else self._image_point(features)
        self._twist_from(R_target_C, rho, x, y)

    def _twist_from(self, R_target_C: np.ndarray, rho: float, x: float, y: float) -> None:
        """The task function and the twist from c*R_c, rho and the reference point's (x, y) (reference)."""
        if not rho > 0.0:
            raise PointBehindCameraError(
                [self.reference_point],
                [rho * self._Z_target],
                "the 2.5-D reference point is behind the camera",
            )
        tu = theta_u(R_target_C)
        e_v = np.array([x - self._m_ref_target[0], y - self._m_ref_target[1], math.log(rho)])
        Z = rho * self._Z_target
        L_vw = np.array([[x * y, -(1.0 + x * x), y], [1.0 + y * y, -x * y, -x], [-y, x, 0.0]])
        r = e_v - L_vw @ tu
        v = -self.gain * Z * np.array([-r[0] - x * r[2], -r[1] - y * r[2], -r[2]])  # -lambda L_v^-1 r
        self._error = np.concatenate((e_v, tu))
        self._twist = np.concatenate((v, -self.gain * tu))

    def _image_point(self, features: np.ndarray) -> tuple[float, float]:
        """Normalized (x, y) of the reference marker: [u, v] / F, or ((u_l + u_r) / 2, v) / F for stereo."""
        i = self.reference_point
        if isinstance(self.task.camera, PinholeCamera):
            return features[2 * i] / self._F, features[2 * i + 1] / self._F
        u_l, u_r, v = features[3 * i : 3 * i + 3]
        return 0.5 * (u_l + u_r) / self._F, v / self._F

    def command(self, reading: JointReading | None) -> np.ndarray:
        """The twist [v; omega] of the last frame [m/s, rad/s], in the current camera frame."""
        return self._twist

    def signals(self) -> dict[str, np.ndarray]:
        """``servo_error``: e = (x - x*, y - y*, log rho, theta u [rad]) of the last frame (6,)."""
        return {"servo_error": self._error}


REGISTRATIONS = (
    (
        "2.5d",
        TwoHalfD,
        "2.5-D VS (Malis, Chaumette & Boudet 1999): image point, log Z/Z*, theta u from pose or homography",
    ),
)
