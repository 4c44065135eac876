"""Monocular pose from four or more known points (PnP), through OpenCV's ``solvePnP``.

A monocular camera sees [u, v] = F (X, Y) / Z per point [m on the sensor] (normalized
coordinates x = u / F, y = v / F). Three points leave up to four poses (Sec. 3 of the paper);
four or more fix it. The paper cites EPnP and SQPnP for this problem; both are in OpenCV, and
this module calls them on the normalized coordinates (camera matrix I, no distortion), so
the pixel grid plays no part. The default is SQPnP (Terzakis & Lourakis, 2020): a globally
optimal solver for any n >= 3 points, planar or not. EPnP is not reliable on four (nearly)
coplanar points: on 50 seeded views of a 20 cm square it is off by more than 1 m or 1 rad on
5 (``tests/test_monocular_pose.py``); IPPE is exact for planar points only.

:func:`estimate_camera_pose` gives either camera's pose from its own features: stereo P3P
(Appendix C) for a :class:`~ibvs_youla.model.camera.StereoCamera`, PnP for a
:class:`~ibvs_youla.model.camera.PinholeCamera`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validation import as_array, instance, one_of
from ..exceptions import InvalidArrayError, InvalidParameterError, PoseEstimationError
from ..model.camera import PinholeCamera, StereoCamera
from .stereo_pose import check_marker_geometry, estimate_pose

__all__ = ["PNP_METHODS", "estimate_camera_pose", "estimate_pose_monocular"]

PNP_METHODS = ("sqpnp", "epnp", "iterative", "ippe")  # OpenCV's SOLVEPNP_* flags, by name


def estimate_pose_monocular(
    camera: PinholeCamera, features: Any, P_ref: Any, method: str = "sqpnp"
) -> np.ndarray:
    """T_ref_C (4, 4): the pose of a monocular camera from features of points known in a frame ref.

    Args:
        camera: The pinhole camera (its focal length turns features into normalized coordinates).
        features: [u, v] per point (n, 2) or flat (2n,) [m on the sensor].
        P_ref: The points (n, 3), n >= 4, in the frame ref [m]; not coincident or collinear.
        method: ``"sqpnp"`` (default), ``"epnp"``, ``"iterative"`` (Levenberg-Marquardt from
            an initial DLT/homography) or ``"ippe"`` (planar points only).

    Raises:
        InvalidParameterError: ``camera`` is not a PinholeCamera, or an unknown ``method``.
        InvalidArrayError: mis-shaped or non-finite input, or fewer than four points.
        DegenerateMarkersError: coincident or collinear points.
        PoseEstimationError: OpenCV found no pose (e.g. ``"ippe"`` on non-planar points).
    """
    import cv2

    instance(camera, "camera", PinholeCamera, "a PinholeCamera (a StereoCamera: estimate_pose, stereo P3P)")
    one_of(method, "method", PNP_METHODS)
    P_ref = check_marker_geometry(P_ref, "P_ref")
    n = P_ref.shape[0]
    if n < 4:
        raise InvalidArrayError("P_ref", f"{n} points", "four or more points: three leave up to four poses")
    p = as_array(features, "features")
    if p.shape not in ((n, 2), (2 * n,)):
        raise InvalidArrayError(
            "features", f"an array of shape {p.shape}", f"shape ({n}, 2) or ({2 * n},): [u, v] for each point"
        )
    normalized = np.ascontiguousarray(p.reshape(n, 2) / camera.focal_length)
    flag = {
        "sqpnp": cv2.SOLVEPNP_SQPNP,
        "epnp": cv2.SOLVEPNP_EPNP,
        "iterative": cv2.SOLVEPNP_ITERATIVE,
        "ippe": cv2.SOLVEPNP_IPPE,
    }[method]
    try:
        ok, rvec, tvec = cv2.solvePnP(np.ascontiguousarray(P_ref), normalized, np.eye(3), None, flags=flag)
    except cv2.error as exc:
        raise PoseEstimationError(method, f"OpenCV solvePnP ({method}) failed: {exc}") from None
    if not ok or not (np.all(np.isfinite(rvec)) and np.all(np.isfinite(tvec))):
        raise PoseEstimationError(method, f"OpenCV solvePnP ({method}) found no pose for {n} points")
    R_C_ref = cv2.Rodrigues(rvec)[0]
    T = np.eye(4)
    T[:3, :3] = R_C_ref.T
    T[:3, 3] = -R_C_ref.T @ tvec.ravel()
    return T


def estimate_camera_pose(
    camera: StereoCamera | PinholeCamera, features: Any, P_ref: Any, **options: Any
) -> np.ndarray:
    """T_ref_C (4, 4) from a camera's own features: stereo P3P or monocular PnP (module docstring).

    ``options`` go to :func:`~.stereo_pose.estimate_pose` (``allow_behind``) or to
    :func:`estimate_pose_monocular` (``method``).
    """
    if isinstance(camera, StereoCamera):
        return estimate_pose(camera, features, P_ref, **options)
    if isinstance(camera, PinholeCamera):
        return estimate_pose_monocular(camera, features, P_ref, **options)
    raise InvalidParameterError("camera", type(camera).__name__, "a StereoCamera or a PinholeCamera")
