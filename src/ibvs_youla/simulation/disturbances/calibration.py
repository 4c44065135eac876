"""Calibration errors: the controller's camera, hand-eye transform and markers, not the truth.

:func:`believed_models` perturbs the models a controller is given (its
:class:`~ibvs_youla.Beliefs`), never the world's:

* **camera**: focal length F' = s_F F and baseline b' = s_b b (stereo); the principal point
  (u0 + du, v0 + dv) [px], whose effect on the features the controller receives is in
  :mod:`.sensing` (it converts pixels with its own principal point);
* **hand-eye**: X' = X T_err, T_err a rotation by the rotation vector r [deg] and a translation
  t [m], both in the camera frame {C}, X the hand-eye transform of the mount (``arm.hand_eye``):
  eye-in-hand T_E_C, the controller believing its camera sits there on the flange
  (``Arm.with_hand_eye``); eye-to-hand T_O_C, the controller believing the fixed camera stands
  there in the base frame (``EyeToHandArm.with_camera_pose``);
* **markers**: m_i' = c + s (m_i - c) + o + n_i, with c the markers' centroid, s a scale, o an
  offset [m] and n_i seeded N(0, sigma^2 I) draws [m] per marker.

First-order geometry (tested): a marker offset o moves the camera pose a pose-based law (PBVS)
converges to by -o, and a marker scale s about c moves a monocular camera from t* to
c + (t* - c) / s; a law whose goal is the taught image (IBVS, the paper's controllers) converges
to the taught pose whatever the beliefs, which then change its path only.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = ["believed_models", "hand_eye_error"]


def hand_eye_error(translation_m: Any, rotation_deg: Any) -> np.ndarray:
    """T_err (4, 4): a rotation by the rotation vector ``rotation_deg`` [deg], then ``translation_m`` [m]."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(np.radians(np.asarray(rotation_deg, dtype=float))).as_matrix()
    T[:3, 3] = translation_m
    return T


def believed_models(
    disturbances: Any, arm: Any, camera: Any, markers_O: np.ndarray, rng: np.random.Generator
) -> tuple[Any, Any, np.ndarray | None]:
    """The controller's (arm, camera, markers) under the calibration errors of ``disturbances``.

    Args:
        disturbances: A :class:`~.definition.Disturbances`.
        arm: The controller's arm before the errors (None on the free camera).
        camera: Its camera before the errors.
        markers_O: Its markers (n, 3) [m] before the errors.
        rng: Generator of the marker draws.

    Returns:
        (arm, camera, markers_O), each None when that belief is unchanged.
    """
    d = disturbances
    new_arm = new_camera = new_markers = None
    if arm is not None and (any(d.hand_eye_translation_m) or any(d.hand_eye_rotation_deg)):
        T_err = hand_eye_error(d.hand_eye_translation_m, d.hand_eye_rotation_deg)
        X = np.asarray(arm.hand_eye) @ T_err
        new_arm = arm.with_camera_pose(X) if arm.mount.is_eye_to_hand else arm.with_hand_eye(X)
    changes: dict[str, Any] = {}
    if d.focal_length_scale != 1.0:
        changes["focal_length"] = camera.focal_length * d.focal_length_scale
    if d.baseline_scale != 1.0:
        changes["baseline"] = camera.baseline * d.baseline_scale
    du, dv = d.principal_point_offset_px
    if (du or dv) and camera.focal_length != camera.pixel_pitch:  # the normalized camera has no pixels
        u0, v0 = camera.principal_point
        changes["principal_point"] = (u0 + du, v0 + dv)
    if changes:
        new_camera = dataclasses.replace(camera, **changes)
    draws = rng.standard_normal(np.shape(markers_O))  # drawn whatever sigma: the stream stays aligned
    if d.marker_scale != 1.0 or any(d.marker_offset_m) or d.marker_sigma_m:
        centre = markers_O.mean(axis=0)
        new_markers = (
            centre
            + d.marker_scale * (markers_O - centre)
            + np.asarray(d.marker_offset_m)
            + d.marker_sigma_m * draws
        )
    return new_arm, new_camera, new_markers
