"""XY/Z-partitioned IBVS: depth and roll from two image features, the other four DOF from the points.

Corke & Hutchinson, "A new partitioned approach to image-based visual servo control", IEEE T-RA
17(4), 2001. Classical IBVS couples the translation along the optical axis with the rotation
about it (a roll of pi makes it retreat, Chaumette 1998); this law gives v_z and w_z their own
image features and decouples them from the rest.

Features, in the normalized image of the camera frame's origin (x = X/Z, y = Y/Z;
:func:`~.image_points.normalized_points`, the mean of both lenses for a stereo camera):

* sigma = sqrt(|a|), a = 1/2 sum_i (x_i y_(i+1) - x_(i+1) y_i) the signed area of the polygon
  through the points in the order of the markers (shoelace; index i + 1 taken modulo n). For
  a planar polygon parallel to the image plane a scales as 1/Z^2, so ln(sigma) moves with
  v_z / Z and not with w_z;
* theta = atan2(y_j - y_i, x_j - x_i), the angle of the segment from point i to point j, the
  longest segment of the current image (the paper's choice, for conditioning; it may change
  during the motion, ties going to the first pair in marker order). A roll w_z about the
  optical axis turns every segment by -w_z; a translation along it scales them.

Their rows (``partition_interaction``), from the point rows L_x, L_y of
:func:`~.image_points.normalized_point_rows`:

    L_a = 1/2 sum_i ((y_(i+1) - y_(i-1)) L_x,i + (x_(i-1) - x_(i+1)) L_y,i),   L_ln_sigma = L_a / (2 a)
    L_theta = (d_x (L_y,j - L_y,i) - d_y (L_x,j - L_x,i)) / (d_x^2 + d_y^2),   d = p_j - p_i.

The w_z column of L_theta is -1 for any image (d' = w_z [d_y, -d_x]); its v_z column is 0 when
the points lie at one depth; the w_z column of L_ln_sigma is 0 (a rotation keeps areas), and
its v_z column is 1/Z at one depth.

Law (the paper's): with the point features f (the camera's, over F: [x, y] per point, or
[x_l, x_r, y] for a stereo camera) and their target f*,

    v_z = lambda ln(sigma* / sigma),   w_z = lambda wrap(theta - theta*)   [theta' = -w_z],
    [v_x, v_y, w_x, w_y] = L_xy^+ (-lambda (f - f*) - L_z [v_z, w_z]),

where L_xy and L_z are the (v_x, v_y, w_x, w_y) and (v_z, w_z) columns of the points'
interaction matrix over F, at the current features and the depths of the controller's model
(:class:`~.image_points.CurrentInteraction`, as ``ibvs-current``), and wrap(.) maps into
[-pi, pi). The paper's separate
gains for v_z and w_z are one gain lambda here; its repulsive potential that keeps points in
the image is not part of this law (the project's cameras report a lost point instead).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._validation import one_of, positive
from ..control.singular_values import SingularValuePolicy
from ..estimation.monocular_pose import PNP_METHODS
from ..exceptions import FeatureSingularityError
from .base import CameraFrame, CommandType, Controller, JointReading, ServoTask
from .ibvs import PINV_THRESHOLD
from .image_points import CurrentInteraction, feature_rows, normalized_point_rows, normalized_points, pnp_spec

__all__ = [
    "REGISTRATIONS",
    "PartitionedIBVS",
    "longest_segment",
    "partition_features",
    "partition_interaction",
    "polygon_area",
]

MIN_AREA = 1e-14  # below this |a| (normalized units^2) the points span no area: ln(sigma) has no value
_XY, _Z = [0, 1, 3, 4], [2, 5]  # the columns of the two partitions: (v_x, v_y, w_x, w_y), (v_z, w_z)


def polygon_area(p: np.ndarray) -> float:
    """The signed area a of the polygon through the points p (n, 2) in their order (shoelace)."""
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def longest_segment(p: np.ndarray) -> tuple[int, int]:
    """(i, j), i < j, of the longest segment between the points p (n, 2); ties: the first in order."""
    d = np.linalg.norm(p[:, None, :] - p[None, :, :], axis=2)
    i, j = np.unravel_index(int(np.argmax(np.triu(d, 1))), d.shape)
    return int(i), int(j)


def partition_features(p: np.ndarray, pair: tuple[int, int]) -> tuple[float, float]:
    """(ln sigma, theta [rad]) of the points p (n, 2) and the segment ``pair`` (module docstring).

    Raises:
        FeatureSingularityError: the polygon has no area (|a| < 1e-14).
    """
    a = polygon_area(p)
    if abs(a) < MIN_AREA:
        raise FeatureSingularityError(
            "sigma", a, f"the points' polygon has no area (a = {a:.3g}; valid: |a| >= {MIN_AREA:g})"
        )
    i, j = pair
    return 0.5 * math.log(abs(a)), math.atan2(p[j, 1] - p[i, 1], p[j, 0] - p[i, 0])


def partition_interaction(p: np.ndarray, Z: np.ndarray, pair: tuple[int, int]) -> np.ndarray:
    """Rows of [ln sigma, theta] (2, 6) at points p (n, 2), depths Z (n,) [m] (module docstring)."""
    x, y = p[:, 0], p[:, 1]
    L_x, L_y = normalized_point_rows(x, y, Z)
    dx_da = 0.5 * (np.roll(y, -1) - np.roll(y, 1))
    dy_da = 0.5 * (np.roll(x, 1) - np.roll(x, -1))
    L_a = dx_da @ L_x + dy_da @ L_y
    i, j = pair
    d = p[j] - p[i]
    L_theta = (d[0] * (L_y[j] - L_y[i]) - d[1] * (L_x[j] - L_x[i])) / float(d @ d)
    return np.vstack((L_a / (2.0 * polygon_area(p)), L_theta))


class PartitionedIBVS(Controller):
    """XY/Z-partitioned IBVS (Corke & Hutchinson 2001; module docstring).

    Args:
        gain: lambda [1/s] of the point features, the depth and the roll, a number > 0 (default
            0.5, as the other twist laws).
        pnp: The PnP method of the monocular pose that gives the depths, one of
            :data:`~ibvs_youla.estimation.monocular_pose.PNP_METHODS` (default ``"sqpnp"``;
            ``"ippe"`` for coplanar markers). A stereo camera takes only the default
            (triangulated depths).

    Raises:
        InvalidParameterError: a bad gain or ``pnp``; at reset, a camera other than a
            ``PinholeCamera`` (>= 4 points: the pose by PnP) or a ``StereoCamera`` (>= 3 points),
            ``pnp`` other than ``"sqpnp"`` with a stereo camera, or ``"ippe"`` with markers that
            are not coplanar.
        FeatureSingularityError: at reset or at a frame, points whose polygon has no area.
    """

    command_type = CommandType.CAMERA_TWIST
    name = "ibvs-partitioned"

    def __init__(self, gain: Any = 0.5, pnp: str = "sqpnp") -> None:
        self.gain = positive(gain, "gain", unit="1/s")
        self.pnp = one_of(pnp, "pnp", PNP_METHODS)
        self._policy = SingularValuePolicy("truncate", PINV_THRESHOLD)
        self._twist = np.zeros(6)

    def spec(self) -> dict[str, Any]:
        """Gain, the pseudo-inverse's cut-off, and the PnP method unless the default."""
        return {**super().spec(), "gain": self.gain, "pinv_threshold": PINV_THRESHOLD, **pnp_spec(self.pnp)}

    def reset(self, task: ServoTask) -> None:
        """Check the camera, the point count and the target polygon's area."""
        rows = feature_rows(task, self.name)
        target = np.asarray(task.feature_target, dtype=float)
        p_target = normalized_points(task.camera, target)
        partition_features(p_target, (0, 1))  # raises on a target polygon without area
        super().reset(task)
        self.p_target = p_target
        self._focal_length = task.camera.focal_length
        self._feature_target = target / self._focal_length
        self._interaction = CurrentInteraction(task, rows, self.pnp)
        self.pose_estimator = self._interaction.pose_estimator
        self._twist = np.zeros(6)

    def update(self, frame: CameraFrame, reading: JointReading | None) -> None:
        """One camera frame: v_z and w_z from (sigma, theta), the rest from the points."""
        lam, F = self.gain, self._focal_length
        p = normalized_points(self.task.camera, frame.features)
        pair = longest_segment(p)
        ln_sigma, theta = partition_features(p, pair)
        ln_sigma_t, theta_t = partition_features(self.p_target, pair)
        v_z = lam * (ln_sigma_t - ln_sigma)
        w_z = lam * ((theta - theta_t + math.pi) % (2.0 * math.pi) - math.pi)
        L = self._interaction(frame.features, frame.depth) / F  # at measured depths when the frame has them
        rhs = -lam * (frame.features / F - self._feature_target) - L[:, _Z].dot((v_z, w_z))
        U, _, g, Vt = self._policy.svd_gains(L[:, _XY])
        twist = np.empty(6)
        twist[_XY] = (Vt.T * g).dot(U.T).dot(rhs)
        twist[_Z] = v_z, w_z
        self._twist = twist

    def command(self, reading: JointReading | None) -> np.ndarray:
        """The twist [v; w] of the last frame [m/s, rad/s] (zero before the first)."""
        return self._twist


def _partitioned(gain: Any = 0.5, pnp: str = "sqpnp") -> PartitionedIBVS:
    return PartitionedIBVS(gain, pnp)


REGISTRATIONS = (
    (
        "ibvs-partitioned",
        _partitioned,
        "XY/Z-partitioned IBVS, v_z and w_z from area and segment angle (Corke & Hutchinson 2001)",
    ),
)
