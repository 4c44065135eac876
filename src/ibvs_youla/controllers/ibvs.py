"""Classical image-based visual servoing (IBVS): v = -lambda L^+ (s - s*).

Chaumette & Hutchinson, "Visual servo control, Part I: basic approaches", IEEE Robotics &
Automation Magazine 13(4), 2006: the error e = s - s* (Eq. (1)), the interaction matrix of
an image point (Eq. (11)) stacked over the points, and the control law

    v_c = -lambda L_e^+ e                                                    (Eq. (5))

with L_e^+ the Moore-Penrose pseudo-inverse of an approximation L_e of the interaction
matrix, chosen as in ViSP's ``vpServo`` (``interaction``):

* ``"current"``: L_e = L(s, Z), at the current features and depths (the first choice of
  Sec. "Approximating the interaction matrix", ViSP's ``vpServo::CURRENT``);
* ``"desired"``: L_e = L* = L(s*, Z*), constant, at the target (``vpServo::DESIRED``);
* ``"mean"``: L_e = (L + L*) / 2 (Malis 2004, the third choice of the 2006 paper,
  ``vpServo::MEAN``).

The twist v_c = [v; w] is in the camera frame [m/s, rad/s] (:data:`CommandType.CAMERA_TWIST`),
computed at each camera frame and held until the next.

Features are those of the camera the controller believes in (``task.camera``): [x, y] per
point for a monocular :class:`~ibvs_youla.model.camera.PinholeCamera` (F = 1 gives ViSP's
``vpFeaturePoint``), whose point interaction matrix (2 rows) is Eq. (11) scaled by F;
[u_l, u_r, v] per point for a :class:`~ibvs_youla.model.camera.StereoCamera` (3 rows per
point, :func:`~ibvs_youla.model.camera.points_interaction_matrix`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from .._geometry import inverse_pose, transform_points
from .._validation import non_negative, one_of, positive
from ..control.singular_values import SingularValuePolicy
from ..estimation.monocular_pose import PNP_METHODS
from ..exceptions import InvalidParameterError
from ..model.camera import points_interaction_matrix
from .base import CameraFrame, CommandType, Controller, JointReading, ServoTask
from .image_points import CurrentInteraction, feature_rows, pnp_spec

__all__ = ["INTERACTIONS", "PINV_THRESHOLD", "REGISTRATIONS", "AdaptiveGain", "ClassicalIBVS"]

INTERACTIONS = ("current", "desired", "mean")
PINV_THRESHOLD = 1e-6  # singular values <= this times the largest are dropped (vpMatrix::pseudoInverse)


@dataclass(frozen=True)
class AdaptiveGain:
    """ViSP's ``vpAdaptiveGain``: a gain high near the goal and low far from it.

        lambda(x) = (lambda_0 - lambda_inf) exp(-lambda_dot_0 x / (lambda_0 - lambda_inf)) + lambda_inf

    with x = ||e||_inf, the infinity norm of the image error (ViSP's ``vpServo`` calls
    ``vpAdaptiveGain::operator()(const vpColVector &)``, which takes ``e.infinityNorm()``).
    lambda(0) = lambda_0, lambda(inf) = lambda_inf and the slope at 0 is -lambda_dot_0
    (ViSP names lambda_dot_0 ``slope_at_zero``). With lambda_0 = lambda_inf the gain is the
    constant lambda_0 (ViSP sets the exponent's coefficient to 0 then).

    Attributes:
        lambda_0: Gain at ||e||_inf = 0 [1/s], >= lambda_inf.
        lambda_inf: Gain as ||e||_inf -> infinity [1/s], > 0.
        lambda_dot_0: Decrease rate of the gain at 0 [1/s per unit of e], >= 0.
    """

    lambda_0: float
    lambda_inf: float
    lambda_dot_0: float

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "lambda_inf", positive(self.lambda_inf, "lambda_inf", unit="1/s"))
        lam0 = positive(self.lambda_0, "lambda_0", unit="1/s")
        if lam0 < self.lambda_inf:
            raise InvalidParameterError(
                "lambda_0", self.lambda_0, f"a number >= lambda_inf = {self.lambda_inf:g} 1/s"
            )
        set_(self, "lambda_0", lam0)
        set_(self, "lambda_dot_0", non_negative(self.lambda_dot_0, "lambda_dot_0", unit="1/s per unit of e"))

    def __call__(self, x: float) -> float:
        """lambda(x) [1/s] for x = ||e||_inf >= 0 (class docstring)."""
        a = self.lambda_0 - self.lambda_inf
        if a == 0.0:
            return self.lambda_0
        return a * math.exp(-self.lambda_dot_0 * x / a) + self.lambda_inf


def _gain(value: Any) -> float | AdaptiveGain:
    if isinstance(value, AdaptiveGain):
        return value
    if isinstance(value, Mapping):
        keys = ("lambda_0", "lambda_inf", "lambda_dot_0")
        if set(value) != set(keys):
            raise InvalidParameterError("gain", dict(value), f"a mapping with exactly the keys {keys}")
        return AdaptiveGain(**value)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InvalidParameterError("gain", value, "a finite number > 0 [1/s] or an AdaptiveGain")
    return positive(value, "gain", unit="1/s")


class ClassicalIBVS(Controller):
    """Classical IBVS, v = -lambda L_e^+ (s - s*) (Chaumette & Hutchinson 2006, Eq. (5)).

    Depths of the interaction matrix (Eq. (11) needs Z of each point):

    * current, monocular (>= 4 points): the controller's own model, not the truth: the
      camera pose estimated from the image, ``estimate_camera_pose(task.camera, features,
      task.markers_O)`` (SQPnP, or the ``pnp`` method), and the believed markers give Z_i; L
      is evaluated at the measured features with those depths (the points back-projected, X = u Z / F);
    * current, stereo (>= 3 points): the points triangulated from the features (Eq. (C6)-(C8)
      of the paper, :func:`~ibvs_youla.model.camera.triangulate_points`), 3 rows per point;
    * desired: the believed markers in the believed target pose ``task.T_O_C_target``,
      evaluated once at :meth:`reset`;
    * current, a frame with measured depths (``sensor="depth"``, an RGB-D camera): those
      depths, no estimate (the points back-projected at them), as ViSP's ``tutorial-ibvs-4pts``
      gives each ``vpFeaturePoint`` the simulator's depth.

    Pseudo-inverse: through the SVD L = U S V^T, L^+ = V S^+ U^T where singular values
    sigma_i <= ``PINV_THRESHOLD`` (1e-6) sigma_max are dropped (1/sigma_i replaced by 0), as
    ViSP's ``vpMatrix::pseudoInverse`` default (``SingularValuePolicy("truncate", 1e-6)``).

    The visibility flags of a frame are not used: every point's features enter e.

    Args:
        interaction: ``"current"``, ``"desired"`` or ``"mean"`` (module docstring).
        gain: lambda [1/s] (default 0.5, ViSP's tutorial value), or an :class:`AdaptiveGain`
            (or a mapping of its three fields), evaluated at ||e||_inf at each frame.
        pnp: The PnP method of the monocular pose that gives L its depths (``"current"`` and
            ``"mean"``), one of :data:`~ibvs_youla.estimation.monocular_pose.PNP_METHODS`
            (default ``"sqpnp"``; ``"ippe"`` for coplanar markers). ``"desired"`` estimates no
            pose and takes only the default; so does a stereo camera (triangulated depths).

    Raises:
        InvalidParameterError: an unknown ``interaction``, a bad gain, an unknown ``pnp`` or one
            other than ``"sqpnp"`` with ``"desired"``; at reset, a monocular camera with fewer
            than 4 points, a stereo one with fewer than 3, or another camera, ``pnp`` other than
            ``"sqpnp"`` with a stereo camera, or ``"ippe"`` with markers that are not coplanar.
    """

    command_type = CommandType.CAMERA_TWIST

    def __init__(self, interaction: str = "current", gain: Any = 0.5, pnp: str = "sqpnp") -> None:
        self.interaction = one_of(interaction, "interaction", INTERACTIONS)
        self.pnp = one_of(pnp, "pnp", PNP_METHODS)
        if self.interaction == "desired" and self.pnp != "sqpnp":
            raise InvalidParameterError(
                "pnp",
                self.pnp,
                "'sqpnp' (the default) with interaction='desired', which estimates no pose (L* from the "
                "believed target pose); the PnP method acts with 'current' and 'mean'",
            )
        self.gain = _gain(gain)
        self._policy = SingularValuePolicy("truncate", PINV_THRESHOLD)
        self._twist = np.zeros(6)
        self._lambda = np.zeros(1)
        self._L_desired: np.ndarray | None = None
        self._L_desired_pinv: np.ndarray | None = None

    @property
    def name(self) -> str:  # type: ignore[override]
        """``"ibvs-current"``, ``"ibvs-desired"`` or ``"ibvs-mean"``: the registry name."""
        return f"ibvs-{self.interaction}"

    def spec(self) -> dict[str, Any]:
        """Interaction matrix, gain (a number or an adaptive gain's fields), cut-off; PnP unless default."""
        gain = asdict(self.gain) if isinstance(self.gain, AdaptiveGain) else self.gain
        return {
            **super().spec(),
            "interaction": self.interaction,
            "gain": gain,
            "pinv_threshold": PINV_THRESHOLD,
            **pnp_spec(self.pnp),
        }

    # ------------------------------------------------------------------ run
    def reset(self, task: ServoTask) -> None:
        """Check the camera and point count; build L* when the law needs it."""
        rows = feature_rows(task, self.name)
        target = np.asarray(task.feature_target, dtype=float)
        super().reset(task)
        self._feature_target = target
        self._rows = rows
        # L(s, Z), what does not change made once
        self._interaction = CurrentInteraction(task, rows, self.pnp)
        # monocular: the pose that gives L its depths (CameraPoseEstimator; None for stereo)
        self.pose_estimator = self._interaction.pose_estimator
        self._L_desired = self._L_desired_pinv = None
        if self.interaction != "current":
            P_C_target = transform_points(inverse_pose(task.T_O_C_target), task.markers_O)
            self._L_desired = points_interaction_matrix(task.camera, P_C_target, task.virtual_points)
            self._L_desired_pinv = self.pinv(self._L_desired)  # constant: factorized once
        self._twist = np.zeros(6)
        self._lambda = np.zeros(1)

    def update(self, frame: CameraFrame, reading: JointReading | None) -> None:
        """One camera frame: v = -lambda L_e^+ e (Eq. (5))."""
        e = frame.features - self._feature_target
        if self.interaction == "desired":
            L_pinv_e = self._L_desired_pinv.dot(e)
        else:
            L = self.interaction_matrix(frame.features, frame.depth)
            if self.interaction == "mean":
                L = 0.5 * (L + self._L_desired)
            U, _, g, Vt = self._policy.svd_gains(L)  # self.pinv(L) without the argument check
            L_pinv_e = (Vt.T * g).dot(U.T).dot(e)
        gain = self.gain
        lam = gain(float(np.max(np.abs(e)))) if isinstance(gain, AdaptiveGain) else gain
        self._lambda = np.array([lam])
        self._twist = -lam * L_pinv_e

    def interaction_matrix(self, features: np.ndarray, depth: np.ndarray | None = None) -> np.ndarray:
        """L(s, Z) (m, 6) at the features, at measured depths (n,) [m] or the model's (class docstring)."""
        return self._interaction(features, depth)

    @property
    def desired_interaction_matrix(self) -> np.ndarray | None:
        """L* = L(s*, Z*) (m, 6) of the last reset (``"desired"`` and ``"mean"``; None for ``"current"``)."""
        return self._L_desired

    @property
    def desired_pseudo_inverse(self) -> np.ndarray | None:
        """L*^+ (6, m) of the last reset, as :meth:`pinv` (None for ``"current"``)."""
        return self._L_desired_pinv

    def pinv(self, L: np.ndarray) -> np.ndarray:
        """L^+ (6, m) through the SVD, singular values <= 1e-6 sigma_max dropped (class docstring)."""
        return self._policy.decompose(L).pinv

    def command(self, reading: JointReading | None) -> np.ndarray:
        """The twist [v; w] of the last frame [m/s, rad/s] (zero before the first)."""
        return self._twist

    def signals(self) -> dict[str, np.ndarray]:
        """``ibvs_gain`` (1,): the lambda of the last frame [1/s] (0 before the first)."""
        return {"ibvs_gain": self._lambda}


def _factory(interaction: str) -> Any:
    if interaction == "desired":  # estimates no pose: no ``pnp`` to offer

        def factory(gain: Any = 0.5) -> ClassicalIBVS:
            return ClassicalIBVS(interaction, gain)

    else:

        def factory(gain: Any = 0.5, pnp: str = "sqpnp") -> ClassicalIBVS:  # type: ignore[misc]
            return ClassicalIBVS(interaction, gain, pnp)

    factory.__name__ = f"ibvs_{interaction}"
    return factory


REGISTRATIONS = (
    (
        "ibvs-current",
        _factory("current"),
        "classical IBVS, L at the current features and depths (Chaumette & Hutchinson 2006, Eq. (5))",
    ),
    (
        "ibvs-desired",
        _factory("desired"),
        "classical IBVS, L* at the target features and depths (Chaumette & Hutchinson 2006, Eq. (5))",
    ),
    (
        "ibvs-mean",
        _factory("mean"),
        "classical IBVS, L = (L + L*)/2 (Chaumette & Hutchinson 2006, Eq. (5); ViSP's MEAN)",
    ),
)
