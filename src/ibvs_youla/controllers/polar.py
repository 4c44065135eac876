"""Polar-coordinate IBVS: each point's image as (r, phi) about the principal point.

Iwatsuki & Okiyama, "A new formulation of visual servoing based on cylindrical coordinate
system", IEEE T-RO 21(2), 2005 (the polar special case, whose origin is the principal point), as
Corke's ``IBVS_polar`` (Machine Vision Toolbox; Corke, "Robotics, Vision and Control", the
chapter on advanced visual servoing): a rotation about the optical axis changes only the angles
phi, so the law turns the camera about its axis instead of retreating along it as point IBVS does
(Chaumette 1998).

Features, per point and lens, in the lens's normalized image (x = u / F, y = v / F, from the
lens's principal point), point-major ``s = [r_1, phi_1, r_2, phi_2, ...]`` for a monocular
camera and ``[r_l1, phi_l1, r_r1, phi_r1, ...]`` for a stereo one (each lens's image in polar
coordinates about its own principal point: both lenses, as point IBVS uses both):

    r = sqrt(x^2 + y^2),   phi = atan2(y, x)   [rad],   so x = r cos(phi), y = r sin(phi).

Interaction matrix. With c = cos(phi), s = sin(phi), differentiating r^2 = x^2 + y^2 and
tan(phi) = y / x gives

    L_r = c L_x + s L_y,   L_phi = (c L_y - s L_x) / r,

with L_x, L_y the rows of the lens's x and y (for a monocular camera, or a lens at the origin,
:func:`~.image_points.normalized_point_rows`: L_x = [-1/Z, 0, x/Z, x y, -(1 + x^2), y],
L_y = [0, -1/Z, y/Z, 1 + y^2, -x y, -x]; for a stereo lens, the rows of
``camera.interaction_matrix`` over F, whose u rows carry the lens offset, ERRATA 12).
Substituting x = r c, y = r s in the monocular rows (c x + s y = r, c y - s x = 0,
c x y + s (1 + y^2) = s (1 + r^2), c (1 + x^2) + s x y = c (1 + r^2), c (1 + y^2) - s x y = c,
s (1 + x^2) - c x y = s) gives

    L_r   = [ -c/Z,      -s/Z,      r/Z,  (1 + r^2) s,  -(1 + r^2) c,   0 ]
    L_phi = [  s/(r Z),  -c/(r Z),  0,    c/r,           s/r,          -1 ]

The last column is the point of the method: a turn w_z about the optical axis moves every phi
by -w_z and no r. For the symmetric start rotated by pi about the optical axis, at the target's
depth, the r errors vanish and every phi error is the same angle, so e is a multiple of the
w_z column: with L of full column rank, L^+ e is a pure turn and the depth never changes (the
test derives the geometric decay of the angle). phi is undefined at the principal point and
L_phi grows as 1/r near it (:class:`~ibvs_youla.exceptions.FeatureSingularityError` at r = 0).

Angle wrapping (``wrap``): the toolbox wraps each point's phi error into [-pi, pi) on its own
(``"per-point"``: phi - phi* - 2 pi floor((phi - phi* + pi) / (2 pi)), ``wrap_mpi_pi``). Near a
rotation of pi the points' errors then fall on both sides of the cut by round-off alone, and
their demands on w_z cancel: at an exact half turn whose rotation matrix rounds one way, half of
the square's points ask for +pi and half for -pi (the test shows the twist). The default
(``"joint"``) wraps the errors about their circular mean c = atan2(sum sin d_i, sum cos d_i),
d_i = phi_i - phi*_i: e_i = c + wrap(d_i - c), so all points turn the same way; away from the cut
both rules agree.

Law: e = s - s* (phi errors wrapped), v = -lambda L^+ e with L at the current features and the
depths of the controller's model (:class:`~.image_points.CurrentInteraction`, as
``ibvs-current``: the monocular pose by SQPnP, or the stereo triangulation), the SVD
pseudo-inverse truncated at 1e-6 sigma_max as :class:`~.ibvs.ClassicalIBVS`. The toolbox's
``IBVS_polar`` also clips the twist's norm to 0.02 per step; this law does not (no other law
here clips).
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
from .image_points import CurrentInteraction, feature_rows, pnp_spec

__all__ = [
    "REGISTRATIONS",
    "WRAPS",
    "PolarIBVS",
    "lens_points",
    "lens_rows",
    "polar_error",
    "polar_features",
    "polar_interaction_matrix",
]

WRAPS = ("joint", "per-point")
MIN_RADIUS = 1e-12  # below this normalized radius phi has no value (the principal point)


def lens_points(features: np.ndarray, rows: int, focal_length: float) -> np.ndarray:
    """Each lens's normalized image points (k n, 2): [u, v] / F per point, or [u_l, v] / F, [u_r, v] / F."""
    p = features.reshape(-1, rows) / focal_length
    if rows == 2:
        return p
    return np.stack((p[:, [0, 2]], p[:, [1, 2]]), axis=1).reshape(-1, 2)


def lens_rows(L_points: np.ndarray, rows: int, focal_length: float) -> tuple[np.ndarray, np.ndarray]:
    """(L_x, L_y) (k n, 6) of :func:`lens_points` from the features' interaction matrix (rows n, 6)."""
    L = L_points.reshape(-1, rows, 6) / focal_length
    if rows == 2:
        return L[:, 0], L[:, 1]
    return L[:, :2].reshape(-1, 6), np.repeat(L[:, 2], 2, axis=0)


def polar_features(p: np.ndarray) -> np.ndarray:
    """The features [r_1, phi_1, ...] (2 m,) of normalized image points p (m, 2); phi [rad] in (-pi, pi]."""
    s = np.empty(2 * len(p))
    s[0::2] = np.hypot(p[:, 0], p[:, 1])
    s[1::2] = np.arctan2(p[:, 1], p[:, 0])
    return s


def polar_interaction_matrix(s: np.ndarray, L_x: np.ndarray, L_y: np.ndarray) -> np.ndarray:
    """The rows d s / d[v; w] (2 m, 6) at polar features s (2 m,), from the points' rows L_x, L_y (m, 6).

    (Module docstring.)

    Raises:
        FeatureSingularityError: a point at the principal point (r < 1e-12), where phi and its
            row have no value.
    """
    r, phi = s[0::2], s[1::2]
    if r.min() < MIN_RADIUS:
        raise FeatureSingularityError(
            "phi",
            float(r.min()),
            f"image point {int(np.argmin(r))} lies at the principal point (r = {r.min():.3g}): its polar "
            f"angle has no value; valid: r >= {MIN_RADIUS:g}",
        )
    c, sn = np.cos(phi)[:, None], np.sin(phi)[:, None]
    L = np.empty((2 * r.size, 6))
    L[0::2] = c * L_x + sn * L_y
    L[1::2] = (c * L_y - sn * L_x) / r[:, None]
    return L


def _wrapped(angle: np.ndarray) -> np.ndarray:
    return np.mod(angle + math.pi, 2.0 * math.pi) - math.pi  # into [-pi, pi)


def polar_error(s: np.ndarray, s_target: np.ndarray, wrap: str = "joint") -> np.ndarray:
    """The error e = s - s* (2 m,), the phi errors wrapped ``"joint"``ly or ``"per-point"`` [rad].

    (Module docstring.) Unvalidated: ``wrap`` is one of :data:`WRAPS`.
    """
    e = s - s_target
    d = e[1::2]
    if wrap == "per-point":
        e[1::2] = _wrapped(d)
    else:
        c = math.atan2(float(np.sin(d).sum()), float(np.cos(d).sum()))
        e[1::2] = c + _wrapped(d - c)
    return e


class PolarIBVS(Controller):
    """Polar IBVS: v = -lambda L_(r,phi)^+ e (module docstring), at the current features and depths.

    Args:
        gain: lambda [1/s], a number > 0 (default 0.5, as the other twist laws).
        wrap: ``"joint"`` (default) or ``"per-point"``: how the phi errors are wrapped (module
            docstring).
        pnp: The PnP method of the monocular pose that gives the depths, one of
            :data:`~ibvs_youla.estimation.monocular_pose.PNP_METHODS` (default ``"sqpnp"``;
            ``"ippe"`` for coplanar markers). A stereo camera takes only the default
            (triangulated depths).

    Raises:
        InvalidParameterError: a bad gain, ``wrap`` or ``pnp``; at reset, a camera other than a
            ``PinholeCamera`` (>= 4 points: the pose by PnP) or a ``StereoCamera`` (>= 3 points),
            ``pnp`` other than ``"sqpnp"`` with a stereo camera, or ``"ippe"`` with markers that
            are not coplanar.
        FeatureSingularityError: at reset or at a frame, a point at the principal point.
    """

    command_type = CommandType.CAMERA_TWIST
    name = "ibvs-polar"

    def __init__(self, gain: Any = 0.5, wrap: str = "joint", pnp: str = "sqpnp") -> None:
        self.gain = positive(gain, "gain", unit="1/s")
        self.wrap = one_of(wrap, "wrap", WRAPS)
        self.pnp = one_of(pnp, "pnp", PNP_METHODS)
        self._policy = SingularValuePolicy("truncate", PINV_THRESHOLD)
        self._twist = np.zeros(6)

    def spec(self) -> dict[str, Any]:
        """Gain, angle wrapping, the pseudo-inverse's cut-off, and the PnP method unless the default."""
        return {
            **super().spec(),
            "gain": self.gain,
            "wrap": self.wrap,
            "pinv_threshold": PINV_THRESHOLD,
            **pnp_spec(self.pnp),
        }

    def reset(self, task: ServoTask) -> None:
        """Check the camera and point count; the target's polar features."""
        rows = feature_rows(task, self.name)
        F = task.camera.focal_length
        s_target = polar_features(lens_points(np.asarray(task.feature_target, dtype=float), rows, F))
        if s_target[0::2].min() < MIN_RADIUS:
            raise FeatureSingularityError(
                "phi", float(s_target[0::2].min()), "a target image point lies at the principal point"
            )
        super().reset(task)
        self.feature_target = s_target
        self._rows, self._focal_length = rows, F
        self._interaction = CurrentInteraction(task, rows, self.pnp)
        self.pose_estimator = self._interaction.pose_estimator
        self._twist = np.zeros(6)

    def interaction_matrix(self, features: np.ndarray, depth: np.ndarray | None = None) -> np.ndarray:
        """L_(r,phi) (2 k n, 6) at the measured features and depths (n,) [m], or the model's depths."""
        rows, F = self._rows, self._focal_length
        s = polar_features(lens_points(features, rows, F))
        return polar_interaction_matrix(s, *lens_rows(self._interaction(features, depth), rows, F))

    def update(self, frame: CameraFrame, reading: JointReading | None) -> None:
        """One camera frame: v = -lambda L^+ e (L at the frame's measured depths when it carries them)."""
        rows, F = self._rows, self._focal_length
        s = polar_features(lens_points(frame.features, rows, F))
        L = polar_interaction_matrix(s, *lens_rows(self._interaction(frame.features, frame.depth), rows, F))
        U, _, g, Vt = self._policy.svd_gains(L)
        self._twist = -self.gain * (Vt.T * g).dot(U.T).dot(polar_error(s, self.feature_target, self.wrap))

    def command(self, reading: JointReading | None) -> np.ndarray:
        """The twist [v; w] of the last frame [m/s, rad/s] (zero before the first)."""
        return self._twist


def _polar(gain: Any = 0.5, wrap: str = "joint", pnp: str = "sqpnp") -> PolarIBVS:
    return PolarIBVS(gain, wrap, pnp)


REGISTRATIONS = (
    (
        "ibvs-polar",
        _polar,
        "polar-coordinate IBVS, (r, phi) per point (Iwatsuki & Okiyama 2005; Corke's IBVS_polar)",
    ),
)
