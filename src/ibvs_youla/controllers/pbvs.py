"""Position-based visual servoing (PBVS): the camera pose from the image, driven to the target.

Chaumette & Hutchinson, "Visual servo control, Part I: Basic approaches", IEEE Robotics &
Automation Magazine 13(4), 2006, Sec. "Position-Based Visual Servo". The features are the pose
of the current camera frame {c} in the desired one {c*}, s = (c*t_c, theta u), with theta u the
angle-axis of c*R_c; then s* = 0 and e = s. Their interaction matrix for this choice,

    L_e = [[c*R_c, 0], [0, L_thetau]],
    L_thetau = I + (theta/2) [u]x + (1 - sinc(theta) / sinc^2(theta/2)) [u]x^2,

is invertible in closed form (L_thetau^-1 theta u = theta u), and v_c = -lambda L_e^-1 e gives
their second PBVS law

    v = -lambda c*R_c^T c*t_c,    omega = -lambda theta u                              (PBVS)

(camera twist in the current frame {c}, ViSP's convention). The sign of the (theta/2) [u]x term:
with theta u of c*R_c and omega in the current frame, d(theta u)/dt = L_thetau omega holds with
+theta/2, as finite differences confirm (``tests/test_two_half_d.py``); the form with -theta/2
often quoted holds for omega expressed in {c*}. The law does not depend on it, since
L_thetau theta u = theta u for either sign. Why this variant and not their first,
s = (c t_o, theta u) with an object frame {o}: here de/dt = -lambda e for both parts, so the
camera centre c*t_c moves on the straight line to the goal (in continuous time) and the rotation
turns about one fixed axis; the first variant keeps the object origin on a straight line in the
image instead, and the camera centre leaves the line when the rotation is large.

The current pose comes from the image at every frame:
:func:`~ibvs_youla.estimation.monocular_pose.estimate_camera_pose` (stereo P3P for a
``StereoCamera``, three or more markers; OpenCV SQPnP for a ``PinholeCamera``, four or more; for a
frame with measured depths, ``sensor="depth"``, the points back-projected at them fitted to the
markers, Kabsch, as the stereo camera's triangulated points); the desired pose is the task's
``T_O_C_target``. No pseudo-inverse and so no singular-value cut-off:
L_e is inverted in closed form.

Sampled loop (the free-flying camera holds the twist over T and integrates it with the
exponential map of SE(3)): the rotation is exact, theta u_{k+1} = (1 - lambda T) theta u_k, since
omega is parallel to u (the step exp(-lambda T theta [u]x) turns about the same axis). The
translation is not: with the step angle phi = lambda T theta the held twist moves the centre by
-lambda T V(phi) c*t_c, V the left Jacobian of SO(3), which leaves the line by
lambda T (1 - cos phi) / phi ~ lambda T phi / 2 of |c*t_c| per step; over a run the centre stays
within |c*t_c(0)| lambda T theta_0 / 8 of the start-goal segment (to first order in lambda T), and
its distance to the goal exceeds |c*t_c(0)| (1 - lambda T)^k by a relative (lambda T theta_0)^2 / 12 at
most (the per-step excess lambda T phi^2 / 6 summed over the run; ``tests/test_pbvs.py`` pins
both). Both tend to the continuous straight line as T -> 0.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from .._geometry import inverse_pose
from .._validation import one_of, positive
from ..estimation.monocular_pose import PNP_METHODS, CameraPoseEstimator, pnp_options
from ..exceptions import InvalidParameterError
from ..model.camera import PinholeCamera, StereoCamera
from ..model.rotation_kernels import theta_u_compiled
from .base import CameraFrame, CommandType, Controller, JointReading, ServoTask
from .image_points import pnp_spec

__all__ = ["PBVS", "REGISTRATIONS", "check_pose_task", "check_sampled_gain", "pose_options", "theta_u"]


def theta_u(R: np.ndarray) -> np.ndarray:
    """The angle-axis vector theta u (3,) [rad] of a rotation matrix, theta in [0, pi].

    Through the unit quaternion (scipy's ``Rotation.from_matrix(R).as_rotvec()``: Shepperd's
    largest-diagonal branch for the quaternion, then theta = 2 atan2(|q_v|, q_w)), which is accurate
    at every angle, near 0 and near pi included, where the trace formula acos((tr R - 1) / 2) and
    the skew part (R - R^T) / 2 lose half the digits. At theta = pi, u and -u are the same rotation;
    either may be returned.

    The same floats in one compiled call
    (:func:`~ibvs_youla.model.rotation_kernels.theta_u_compiled`) for a float64 (3, 3) rotation,
    scipy itself for anything else (a matrix that scipy would orthogonalize, or refuse).
    """
    if isinstance(R, np.ndarray) and R.dtype == np.float64 and R.shape == (3, 3):
        out = np.empty(3)
        if theta_u_compiled(R, out):
            return out
    return Rotation.from_matrix(R).as_rotvec()


def check_sampled_gain(gain: float, frame_period: float, controller: str) -> None:
    """Raise InvalidParameterError if lambda T >= 2: e_{k+1} = (1 - lambda T) e_k then diverges."""
    if gain * frame_period >= 2.0:
        raise InvalidParameterError(
            "gain",
            gain,
            f"a gain in (0, 2/T) = (0, {2.0 / frame_period:g}) 1/s for {controller!r} at the frame period "
            f"T = {frame_period:g} s: the sampled loop e_(k+1) = (1 - gain T) e_k diverges beyond",
        )


def check_pose_task(task: ServoTask, controller: str) -> None:
    """Check that the camera pose can be estimated from the task's image: camera type and marker count.

    Raises:
        InvalidParameterError: a camera that is neither a ``StereoCamera`` nor a ``PinholeCamera``,
            a monocular camera with fewer than four markers (three leave up to four poses), or a
            stereo camera with fewer than three.
    """
    n = task.n_points
    if isinstance(task.camera, StereoCamera):
        if n < 3:
            raise InvalidParameterError(
                "task.markers_O", f"{n} markers", f"three or more markers for {controller!r} (stereo P3P)"
            )
    elif isinstance(task.camera, PinholeCamera):
        if n < 4:
            raise InvalidParameterError(
                "task.markers_O",
                f"{n} markers",
                f"four or more markers for {controller!r} with a PinholeCamera (PnP: three leave up to "
                "four poses), or a StereoCamera (three suffice)",
            )
    else:
        raise InvalidParameterError(
            "task.camera", type(task.camera).__name__, "a StereoCamera or a PinholeCamera"
        )


def pose_options(task: ServoTask, pnp: str = "sqpnp") -> dict[str, Any]:
    """Options of :func:`estimate_camera_pose` for the task's camera: virtual points (stereo), or PnP method.

    Raises:
        InvalidParameterError: ``pnp`` other than ``"sqpnp"`` with a ``StereoCamera`` (stereo P3P,
            no PnP: :func:`~ibvs_youla.estimation.monocular_pose.pnp_options`).
    """
    options = pnp_options(task.camera, pnp)
    return {"allow_behind": task.virtual_points} if isinstance(task.camera, StereoCamera) else options


class PBVS(Controller):
    """Position-based visual servoing, v = -lambda c*R_c^T c*t_c, omega = -lambda theta u (module docstring).

    Args:
        gain: lambda [1/s], > 0 (default 0.5, ViSP's tutorial value); at reset, lambda T < 2 for the
            frame period T.
        pnp: The monocular pose's PnP method, one of
            :data:`~ibvs_youla.estimation.monocular_pose.PNP_METHODS` (default ``"sqpnp"``; ``"ippe"``
            for coplanar markers). A stereo camera takes only the default (its pose is stereo P3P),
            and a frame with measured depths is fitted by Kabsch, no PnP.

    Raises:
        InvalidParameterError: a gain that is not a finite number > 0, an unknown ``pnp``; at reset,
            lambda T >= 2, a camera of another kind, too few markers (:func:`check_pose_task`),
            ``pnp`` other than ``"sqpnp"`` with a stereo camera, or ``"ippe"`` with markers that
            are not coplanar.
    """

    command_type = CommandType.CAMERA_TWIST
    name = "pbvs"

    def __init__(self, gain: float = 0.5, pnp: str = "sqpnp") -> None:
        self.gain = positive(gain, "gain", unit="1/s")
        self.pnp = one_of(pnp, "pnp", PNP_METHODS)

    def spec(self) -> dict[str, Any]:
        """Name, class, gain [1/s], and the PnP method when it is not the default."""
        return {**super().spec(), "gain": self.gain, **pnp_spec(self.pnp)}

    def reset(self, task: ServoTask) -> None:
        """Check the task; keep the inverse of the desired pose T_c*_O."""
        check_pose_task(task, self.name)
        check_sampled_gain(self.gain, task.frame_period, self.name)
        super().reset(task)
        self._T_target_O = inverse_pose(np.asarray(task.T_O_C_target, dtype=float))  # T_c*_O
        self._options = pose_options(task, self.pnp)
        # the camera pose of each frame (estimate_camera_pose, its arguments checked once)
        self.pose_estimator = CameraPoseEstimator(task.camera, task.markers_O, **self._options)
        self._error = np.zeros(6)
        self._twist = np.zeros(6)

    def update(self, frame: CameraFrame, reading: JointReading | None) -> None:
        """Estimate the pose from the frame, e = (c*t_c, theta u), twist of (PBVS)."""
        T_O_C = self.pose_estimator(frame.features, frame.depth)
        T_target_C = self._T_target_O @ T_O_C  # c*T_c
        R, t = T_target_C[:3, :3], T_target_C[:3, 3]
        tu = theta_u(R)
        self._error = np.concatenate((t, tu))
        self._twist = np.concatenate((-self.gain * (R.T @ t), -self.gain * tu))

    def command(self, reading: JointReading | None) -> np.ndarray:
        """The twist [v; omega] of the last frame [m/s, rad/s], in the current camera frame."""
        return self._twist

    def signals(self) -> dict[str, np.ndarray]:
        """``servo_error``: e = (c*t_c [m], theta u [rad]) of the last frame (6,)."""
        return {"servo_error": self._error}


REGISTRATIONS = (
    (
        "pbvs",
        PBVS,
        "position-based VS (Chaumette & Hutchinson 2006): camera pose from P3P/PnP, straight-line centre",
    ),
)
