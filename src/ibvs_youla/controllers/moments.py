"""Image-moment IBVS: v = -lambda L_s^+ (s - s*) on six moment features of the points.

Tahri & Chaumette, "Point-based and region-based image moments for visual servoing of planar
objects", IEEE T-RO 21(6), 2005: the features s = [x_n, y_n, a_n, P_x, P_y, alpha] of
:mod:`.image_moments`, computed from the discrete moments of the points in the normalized image
of the camera frame's origin (:func:`~.image_points.normalized_points`, the mean of both lenses
for a stereo camera), and their interaction matrix in closed form. At a target whose plane is
parallel to the image plane, L_s* is block-triangular: v_x and v_y move only x_n and y_n, v_z only
a_n, w_z only alpha and (off the principal point) the centroid, while P_x and P_y move with w_x
and w_y alone; that is the decoupling the paper designs the features for.

Law: e = s - s* (the alpha error wrapped into [-pi, pi)), v = -lambda L^+ e, the SVD
pseudo-inverse truncated at 1e-6 sigma_max as :class:`~.ibvs.ClassicalIBVS`, with L

* ``"desired"`` (default, the form the paper analyses): L_s* at the target features and the
  target plane (A*, B*, C*) of the controller's believed target pose, computed once;
* ``"current"``: L_s at the current features and the plane through the points of the
  controller's model at the frame (:class:`~.image_points.CurrentPoints`: the monocular pose by
  SQPnP or the ``pnp`` method, or the stereo triangulation; :func:`~.image_moments.plane_of_points`).

The paper's features are for a planar object: markers that are not coplanar, and a target image
whose orientation has no value (isotropic second-order moments, e.g. a square seen face-on) or
whose L_s* is singular (an image symmetric about an axis or its centre: P_x and P_y, sums of
squares, lose the motion that breaks the symmetry), are refused at reset with a typed error.
The paper's generalization to a target plane not parallel to the image (a virtual camera turned
parallel to it) is not implemented: at such a target L_s* is full but not block-triangular.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._geometry import inverse_pose, transform_points
from .._validation import one_of, positive
from ..control.singular_values import SingularValuePolicy
from ..estimation.monocular_pose import PNP_METHODS
from ..exceptions import FeatureSingularityError, InvalidParameterError
from .base import CameraFrame, CommandType, Controller, JointReading, ServoTask
from .ibvs import PINV_THRESHOLD
from .image_moments import MomentFeatures, plane_of_points
from .image_points import CurrentPoints, feature_rows, normalized_points, pnp_spec

__all__ = ["INTERACTIONS", "MIN_TARGET_CONDITION", "REGISTRATIONS", "MomentIBVS"]

INTERACTIONS = ("desired", "current")
MIN_TARGET_CONDITION = 1e-4  # sigma_min / sigma_max of L_s* below this: refused at reset
COPLANAR_TOLERANCE = 1e-9  # smallest / largest singular value of the centred markers above this: not coplanar


class MomentIBVS(Controller):
    """Image-moment IBVS (module docstring).

    Args:
        interaction: ``"desired"`` (L_s* once) or ``"current"`` (L_s at every frame).
        gain: lambda [1/s], a number > 0 (default 0.5, as the other twist laws).
        pnp: The PnP method of the monocular pose that gives the plane of the points with
            ``interaction="current"``, one of
            :data:`~ibvs_youla.estimation.monocular_pose.PNP_METHODS` (default ``"sqpnp"``; the
            markers are coplanar, so ``"ippe"`` always applies). ``"desired"`` estimates no pose
            and a stereo camera triangulates: both take only the default.

    Raises:
        InvalidParameterError: an unknown ``interaction``, a bad gain, an unknown ``pnp`` or one
            other than ``"sqpnp"`` with ``"desired"``; at reset, ``pnp`` other than ``"sqpnp"``
            with a stereo camera, a camera other
            than a ``PinholeCamera`` (>= 4 points) or a ``StereoCamera`` (>= 3 points), markers
            that are not coplanar, a target image whose alpha has no value or whose L_s* is
            singular (sigma_min / sigma_max < 1e-6).
        FeatureSingularityError: at a frame, an isotropic image (alpha has no value).
    """

    command_type = CommandType.CAMERA_TWIST
    name = "ibvs-moments"

    def __init__(self, interaction: str = "desired", gain: Any = 0.5, pnp: str = "sqpnp") -> None:
        self.interaction = one_of(interaction, "interaction", INTERACTIONS)
        self.pnp = one_of(pnp, "pnp", PNP_METHODS)
        if self.interaction == "desired" and self.pnp != "sqpnp":
            raise InvalidParameterError(
                "pnp",
                self.pnp,
                "'sqpnp' (the default) with interaction='desired', which estimates no pose (L_s* from the "
                "believed target pose); the PnP method acts with interaction='current'",
            )
        self.gain = positive(gain, "gain", unit="1/s")
        self._policy = SingularValuePolicy("truncate", PINV_THRESHOLD)
        self._twist = np.zeros(6)

    def spec(self) -> dict[str, Any]:
        """Interaction matrix, gain, the pseudo-inverse's cut-off, and the PnP method unless the default."""
        return {
            **super().spec(),
            "interaction": self.interaction,
            "gain": self.gain,
            "pinv_threshold": PINV_THRESHOLD,
            **pnp_spec(self.pnp),
        }

    def reset(self, task: ServoTask) -> None:
        """Check the camera, the markers' plane and the target image; the target features and L_s*."""
        rows = feature_rows(task, self.name)
        centred = task.markers_O - task.markers_O.mean(axis=0)
        sv = np.linalg.svd(centred, compute_uv=False)
        if sv[-1] > COPLANAR_TOLERANCE * sv[0]:
            raise InvalidParameterError(
                "task.markers_O",
                f"markers {sv[-1] / sv[0]:.3g} off their plane (relative)",
                f"coplanar markers for {self.name!r} (the moments of a planar object; relative "
                f"out-of-plane extent <= {COPLANAR_TOLERANCE:g})",
            )
        p_target = normalized_points(task.camera, np.asarray(task.feature_target, dtype=float))
        P_C_target = transform_points(inverse_pose(task.T_O_C_target), task.markers_O)
        plane_target = plane_of_points(P_C_target)
        try:
            features = MomentFeatures(p_target, plane_target)
        except FeatureSingularityError as err:
            raise InvalidParameterError(
                "task.feature_target", f"a target image with {err.feature} undefined", f"{err}"
            ) from None
        L_target = features.interaction_matrix(p_target, plane_target)
        sigma = np.linalg.svd(L_target, compute_uv=False)
        if sigma[-1] < MIN_TARGET_CONDITION * sigma[0]:
            raise InvalidParameterError(
                "task.feature_target",
                f"a target image whose L_s* has sigma_min / sigma_max = {sigma[-1] / sigma[0]:.3g}",
                f">= {MIN_TARGET_CONDITION:g} (an image symmetric about an axis or about its centre, "
                "e.g. a tilted square, an isosceles triangle or a rectangle, leaves P_x and P_y without "
                "the motion that breaks the symmetry)",
            )
        super().reset(task)
        self.moment_features = features
        self.feature_target = features.features(p_target)
        self.L_target = L_target
        self._L_target_pinv = self._policy.decompose(L_target).pinv
        self._points = CurrentPoints(task, rows, self.pnp) if self.interaction == "current" else None
        # monocular "current": the pose giving the plane of the points (None for "desired" and stereo)
        self.pose_estimator = None if self._points is None else self._points.pose_estimator
        self._twist = np.zeros(6)

    def update(self, frame: CameraFrame, reading: JointReading | None) -> None:
        """One camera frame: v = -lambda L^+ e."""
        p = normalized_points(self.task.camera, frame.features)
        e = MomentFeatures.error(self.moment_features.features(p), self.feature_target)
        if self._points is None:
            L_pinv_e = self._L_target_pinv.dot(e)
        else:
            L = self.moment_features.interaction_matrix(p, plane_of_points(self._points(frame.features)))
            U, _, g, Vt = self._policy.svd_gains(L)
            L_pinv_e = (Vt.T * g).dot(U.T).dot(e)
        self._twist = -self.gain * L_pinv_e

    def command(self, reading: JointReading | None) -> np.ndarray:
        """The twist [v; w] of the last frame [m/s, rad/s] (zero before the first)."""
        return self._twist


def _moments(interaction: str = "desired", gain: Any = 0.5, pnp: str = "sqpnp") -> MomentIBVS:
    return MomentIBVS(interaction, gain, pnp)


REGISTRATIONS = (
    (
        "ibvs-moments",
        _moments,
        "image-moment IBVS, six moment features of the points (Tahri & Chaumette 2005)",
    ),
)
