"""The sensor role: image features of fixed markers seen from the true camera pose.

World side of the servo loop: it holds the *true* camera and marker coordinates, while the
controller holds its own (the :class:`~ibvs_youla.controllers.ServoTask`). One class serves
both cameras, because the projection is one equation per lens (Eq. (9)-(11), ERRATA 12):

* a :class:`~ibvs_youla.model.camera.StereoCamera` gives [u_l, u_r, v] per point (Eq. (24)),
  from three or more markers (stereo P3P needs three);
* a :class:`~ibvs_youla.model.camera.PinholeCamera` gives [u, v] per point, from four or
  more markers (three points leave up to four poses, Sec. 3); with
  ``PinholeCamera.normalized()`` these are x = X/Z, y = Y/Z, as ViSP's ``vpFeaturePoint``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validation import as_pose, flag
from ..controllers.base import CameraFrame
from ..estimation.stereo_pose import check_marker_geometry
from ..exceptions import InvalidParameterError
from ..model.camera import PinholeCamera, StereoCamera, project_points
from ..model.camera_kernels import camera_parameters, measure_features

__all__ = ["MarkerSensor"]


class MarkerSensor:
    """Features and per-point visibility of markers fixed in the base frame.

    Eye-to-hand (:mod:`ibvs_youla.model.eye_to_hand`) the markers are fixed in the frame of the
    arm that carries them and the camera poses it is given are the fixed camera's in that frame,
    T_E_C(q): the same projection (``markers_O`` then reads as the markers' coordinates in {E}).

    Args:
        camera: A ``StereoCamera`` (>= 3 markers) or ``PinholeCamera`` (>= 4 markers).
        markers_O: Marker positions (n, 3) in the base frame [m].
        virtual_points: Project markers behind the camera too (the paper's virtual points,
            ERRATA 13); without it a marker with Z_C <= 0 raises PointBehindCameraError.
        depth: Measure each marker's depth Z_C with its features (an RGB-D camera; module
            docstring).

    Raises:
        InvalidParameterError: not a camera, too few markers for it, or ``depth`` with a
            stereo camera.
        InvalidArrayError, DegenerateMarkersError: markers not a finite (n, 3) array of
            non-collinear points.
    """

    def __init__(
        self, camera: Any, markers_O: Any, virtual_points: bool = False, depth: bool = False
    ) -> None:
        if not isinstance(camera, (StereoCamera, PinholeCamera)):
            raise InvalidParameterError("camera", type(camera).__name__, "a StereoCamera or a PinholeCamera")
        markers = check_marker_geometry(markers_O, "markers_O")
        minimum = 3 if isinstance(camera, StereoCamera) else 4
        if markers.shape[0] < minimum:
            raise InvalidParameterError(
                "markers_O",
                f"{markers.shape[0]} markers",
                f">= {minimum} markers for a {type(camera).__name__} (stereo P3P needs 3; a monocular "
                "camera 4, since 3 points leave up to four poses)",
            )
        self.camera = camera
        self.markers_O = markers.copy()
        self.markers_O.setflags(write=False)
        self.virtual_points = flag(virtual_points, "virtual_points")
        self.measures_depth = flag(depth, "depth")
        if self.measures_depth and isinstance(camera, StereoCamera):
            raise InvalidParameterError(
                "depth",
                True,
                "False for a StereoCamera (its features carry the depths, by disparity); a depth "
                "sensor is a PinholeCamera and a depth channel (RGB-D)",
            )
        self._params, self._lens_x = camera_parameters(camera)  # for the compiled projection

    @property
    def n_points(self) -> int:
        """Number of markers n."""
        return int(self.markers_O.shape[0])

    @property
    def features_per_point(self) -> int:
        """3 for a stereo camera ([u_l, u_r, v]), 2 for a monocular one ([u, v])."""
        return 3 if isinstance(self.camera, StereoCamera) else 2

    def points_in_camera(self, T_O_C: np.ndarray) -> np.ndarray:
        """Markers in the camera frame, P_C = T_C_O P_O (Eq. (21)-(22)), (n, 3) [m]."""
        R = T_O_C[:3, :3]
        return (self.markers_O - T_O_C[:3, 3]).dot(R)  # rows R^T (P_O - t)

    def features_at(self, T_O_C: Any) -> np.ndarray:
        """Features (m,) seen from a camera pose T_O_C (4, 4), validated (e.g. the target's)."""
        P_C = self.points_in_camera(as_pose(T_O_C, "T_O_C"))
        return project_points(self.camera, P_C, self.virtual_points)

    def with_depth(self) -> MarkerSensor:
        """The same camera and markers, measuring depth too (``sensor="depth"``; module docstring)."""
        return MarkerSensor(self.camera, self.markers_O, self.virtual_points, depth=True)

    def spec(self) -> dict[str, Any]:
        """Plain data describing the sensor, stored with a run that chose it."""
        return {"name": "depth" if self.measures_depth else "ideal"}

    def measure(self, T_O_C: np.ndarray, t: float) -> CameraFrame:
        """One frame from the true camera pose T_O_C (4, 4), as produced by a plant (unchecked).

        With ``depth``, the frame carries each marker's depth Z_C (n,) [m].

        Raises:
            PointBehindCameraError: a marker at Z_C <= 0 (at |Z_C| ~ 0 with virtual points).
        """
        P_C = self.points_in_camera(T_O_C)
        features, visible, bad = measure_features(P_C, self._params, self._lens_x, self.virtual_points)
        if bad >= 0:  # a depth the projection rejects: the reference raises its error
            project_points(self.camera, P_C, self.virtual_points)
        return CameraFrame(t, features, visible, P_C[:, 2].copy() if self.measures_depth else None)
