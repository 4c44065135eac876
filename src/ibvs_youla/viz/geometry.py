"""What the viewer draws for the camera, computed from its intrinsics: lens centres, frusta, rays.

Pure numpy, no meshcat, so every number drawn can be tested. Frames follow docs/conventions.md:
{C} sits mid-baseline with z along the optical axis and y down; the left lens is at x_C = +b/2
and the right lens at x_C = -b/2 (Eq. 9-10 with ERRATA 12). A lens's viewing
frustum is bounded by the rays through the four corners of its sensor, which are the pixel
corners (0, 0), (W, 0), (W, H), (0, H) of the image taken back through K (Eq. 6), so a skewed
or off-centre principal point is drawn as it is modelled, and a point on the frustum's boundary
is exactly on the edge of the visibility test of the camera model.
"""

from __future__ import annotations

import numpy as np

from .._validation import as_array, as_pose, non_negative, positive
from ..exceptions import InvalidParameterError
from ..model.camera import PinholeCamera, StereoCamera

__all__ = ["frustum_corners_C", "frustum_segments_C", "lens_centres_C", "ray_segments_O"]


def lens_centres_C(camera: StereoCamera | PinholeCamera) -> np.ndarray:
    """Optical centres of the lenses in the camera frame (k, 3) [m].

    Stereo: rows (left, right) = (+b/2, 0, 0), (-b/2, 0, 0) (Eq. 9-10, ERRATA 12); pinhole: the origin.
    """
    if isinstance(camera, StereoCamera):
        half = 0.5 * camera.baseline
        return np.array([[half, 0.0, 0.0], [-half, 0.0, 0.0]])
    if isinstance(camera, PinholeCamera):
        return np.zeros((1, 3))
    raise InvalidParameterError("camera", type(camera).__name__, "a StereoCamera or a PinholeCamera")


def frustum_corners_C(camera: StereoCamera | PinholeCamera, depth: float) -> np.ndarray:
    """Points at depth Z_C = ``depth`` on the rays through each lens's sensor corners (k, 4, 3) [m].

    Corners are ordered as the image's top-left, top-right, bottom-right, bottom-left pixel
    corners; for lens centre x0 and sensor point (u, v) [m], ``P_C = (x0 + u Z / F, v Z / F, Z)``
    (Eq. 9-11 solved for the point). With a centred principal point the corners make angles of
    half the field of view with the optical axis.
    """
    depth = positive(depth, "depth", unit="[m]")
    lenses = lens_centres_C(camera)
    width_px, height_px = camera.sensor_width / camera.pixel_pitch, camera.sensor_height / camera.pixel_pitch
    corners_px = np.array([[0.0, 0.0], [width_px, 0.0], [width_px, height_px], [0.0, height_px]])
    rows_px = np.column_stack([np.repeat(corners_px[:, :1], len(lenses), axis=1), corners_px[:, 1]])
    sensor = camera.from_pixels(rows_px)  # [m on the sensor]; every lens shares K (Eq. 6)
    scale = depth / camera.focal_length
    out = np.empty((len(lenses), 4, 3))
    out[:, :, 0] = lenses[:, :1] + sensor[:, 0][None, :] * scale
    out[:, :, 1] = sensor[:, -1][None, :] * scale
    out[:, :, 2] = depth
    return out


def frustum_segments_C(camera: StereoCamera | PinholeCamera, near: float, far: float) -> np.ndarray:
    """Line segments (m, 2, 3) [m] of each lens's frustum between depths ``near`` and ``far``.

    Per lens: the four edges from the lens centre to the far corners, the far rectangle and,
    when ``near > 0``, the near rectangle (e.g. the camera's minimum depth).
    """
    far = positive(far, "far", unit="[m]")
    near = non_negative(near, "near", unit="[m]")
    if near >= far:
        raise InvalidParameterError("near", near, f"0 <= near < far = {far} [m]")
    lenses = lens_centres_C(camera)
    far_corners = frustum_corners_C(camera, far)
    rectangles = [far_corners] + ([frustum_corners_C(camera, near)] if near > 0.0 else [])
    segments = []
    for i, lens in enumerate(lenses):
        segments += [(lens, corner) for corner in far_corners[i]]
        for corners in rectangles:
            segments += [(corners[i, j], corners[i, (j + 1) % 4]) for j in range(4)]
    return np.array(segments)


def ray_segments_O(camera: StereoCamera | PinholeCamera, T_O_C: object, markers_O: object) -> np.ndarray:
    """Segments (k, n, 2, 3) [m] in the base frame from each lens centre to each marker.

    ``[i, j, 0]`` is lens i's centre ``T_O_C @ lens_i`` and ``[i, j, 1]`` is marker j.
    """
    T_O_C = as_pose(T_O_C, "T_O_C")
    markers_O = as_array(markers_O, "markers_O", (None, 3))
    lenses_O = lens_centres_C(camera) @ T_O_C[:3, :3].T + T_O_C[:3, 3]
    out = np.empty((len(lenses_O), len(markers_O), 2, 3))
    out[:, :, 0] = lenses_O[:, None, :]
    out[:, :, 1] = markers_O[None, :, :]
    return out
