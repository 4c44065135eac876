"""How far detected marker centres are from the true projections, over depth and blur.

:func:`detection_error_sweep` renders seeded frames of disc markers at each depth and blur with
the image sensor (:class:`~ibvs_youla.simulation.image_sensor.ImageSensor`: render, detect,
match), and compares each detected centre with two references:

* the **true projection** of the disc's centre (what an ideal sensor reports, and what the
  controller's equations assume): the error the loop actually sees;
* the true projection **plus the first-order perspective bias** (Eq. (B) of
  :mod:`ibvs_youla.model.disc_image`): what is left is the rendering's and the detector's own
  error (the *residual*).

Scene of one frame: the camera at the origin of the base frame, ``markers_per_frame`` discs of
the stated diameter on a jittered 3 x 3 grid spanning the central 60 % x 60 % of the image at
one depth Z (each disc's centre in view of every lens), each facing the camera's optical axis
tilted by ``tilt_deg`` about a random axis in the image plane (seeded). Errors are Euclidean in
pixels, per marker and lens, in that lens's image: (u_l, v) and (u_r, v) for a stereo camera,
the v being the mean of the two rows the sensor reports.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validation import as_array, non_negative, positive
from ..estimation.marker_detection import DetectorSettings
from ..exceptions import InvalidParameterError
from ..model.camera import StereoCamera, default_camera
from ..model.disc_image import perspective_bias
from ..simulation.image_sensor import ImageSensor
from ..simulation.rendering import DiscMarkers, ImagingSettings, check_camera_has_pixels
from ..simulation.sensor import MarkerSensor

__all__ = ["detection_error_sweep", "sweep_table"]

GRID_SPAN = (0.6, 0.6)  # fraction of the image width and height the marker grid spans


def _values(value: Any, name: str, strictly_positive: bool) -> np.ndarray:
    arr = as_array(value, name).reshape(-1)
    if arr.size == 0 or np.any(arr <= 0.0 if strictly_positive else arr < 0.0):
        raise InvalidParameterError(
            name, value, f"one or more values {'> 0' if strictly_positive else '>= 0'}"
        )
    return arr


def _scene(
    camera: Any, depth: float, n: int, tilt: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Disc centres (n, 3) [m] on a jittered grid at one depth, and their tilted normals (n, 3)."""
    width, height = camera.resolution
    f_px = camera.focal_length / camera.pixel_pitch
    u0, v0 = camera.principal_point
    side = int(np.ceil(np.sqrt(n)))
    cells_u = (np.arange(side) + 0.5) / side - 0.5
    grid = np.array([(a, b) for b in cells_u for a in cells_u])[:n]
    jitter = rng.uniform(-0.125, 0.125, size=(n, 2)) / side  # within an eighth of a cell: sub-pixel phases
    u = u0 + (grid[:, 0] + jitter[:, 0]) * GRID_SPAN[0] * width  # [px], about the principal point
    v = v0 + (grid[:, 1] + jitter[:, 1]) * GRID_SPAN[1] * height
    lens_mid = 0.5 * (max(camera.lens_x) + min(camera.lens_x))
    X = (u - u0) / f_px * depth + lens_mid
    Y = (v - v0) / f_px * depth
    P_C = np.column_stack((X, Y, np.full(n, depth)))
    angle = rng.uniform(0.0, 2.0 * np.pi, size=n)
    normals = np.column_stack(
        (np.sin(tilt) * np.cos(angle), np.sin(tilt) * np.sin(angle), np.full(n, -np.cos(tilt)))
    )
    return P_C, normals


def detection_error_sweep(
    camera: Any = None,
    diameter: float = 0.05,
    depths: Any = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0),
    blurs: Any = (0.0, 0.5, 1.0, 2.0),
    noise_sigma_grey: float = 2.0,
    tilt_deg: float = 30.0,
    frames: int = 4,
    markers_per_frame: int = 9,
    method: str = "moments",
    seed: int = 0,
) -> list[dict[str, Any]]:
    """Detected-centre errors against the true projections, one row per (depth, blur).

    Args:
        camera: A camera with pixels; default ``default_camera()`` (the paper's ZED 2 optics, VGA).
        diameter: Marker diameter [m].
        depths: Depths Z of the marker grid [m], > 0.
        blurs: Gaussian blur sigmas [px], >= 0.
        noise_sigma_grey: Sensor noise [grey levels], >= 0.
        tilt_deg: Angle between each disc's normal and the optical axis [deg], in [0, 80].
        frames: Frames per (depth, blur), each with its own jitter, tilts and noise, >= 1.
        markers_per_frame: Discs per frame, 3-9 (the grid is 3 x 3).
        method: Detector (``"moments"`` or ``"hough"``).
        seed: Seed of the scenes and of the noise.

    Returns:
        Rows (dicts): ``depth_m``, ``blur_px``, ``noise_grey``, ``diameter_px`` (the disc's
        image diameter at that depth), ``markers`` (markers x lenses compared), ``detected``
        (fraction found), ``error_median_px``, ``error_p95_px``, ``error_max_px`` (against
        the true projection), ``bias_median_px`` (first-order bias, Eq. (B)),
        ``residual_median_px``, ``residual_p95_px``, ``residual_max_px`` (against projection +
        bias). Error entries are NaN when no marker was found.

    Raises:
        InvalidParameterError: a camera without pixels, an empty or non-positive depth list, a
            negative blur or noise, a tilt outside [0, 80] deg, too few frames or markers.
    """
    camera = check_camera_has_pixels(default_camera() if camera is None else camera)
    depths = _values(depths, "depths", True)
    blurs = _values(blurs, "blurs", False)
    noise = non_negative(noise_sigma_grey, "noise_sigma_grey", unit="[grey levels]")
    diameter = positive(diameter, "diameter", unit="[m]")
    tilt_deg = non_negative(tilt_deg, "tilt_deg", unit="[deg]")
    if tilt_deg > 80.0:
        raise InvalidParameterError("tilt_deg", tilt_deg, "an angle in [0, 80] deg")
    for name, value, lo, hi in (
        ("frames", frames, 1, 10_000),
        ("markers_per_frame", markers_per_frame, 3, 9),
    ):
        if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or not lo <= value <= hi:
            raise InvalidParameterError(name, value, f"an integer in [{lo}, {hi}]")
    detector = DetectorSettings(method=method)
    rng = np.random.default_rng(seed)
    f_px = camera.focal_length / camera.pixel_pitch
    per = 3 if isinstance(camera, StereoCamera) else 2
    rows = []
    for depth in depths:
        for blur in blurs:
            errors, residuals, biases, compared = [], [], [], 0
            for _ in range(frames):
                P_C, normals = _scene(camera, float(depth), int(markers_per_frame), np.radians(tilt_deg), rng)
                imaging = ImagingSettings(float(blur), noise, seed=int(rng.integers(2**31)))
                markers = DiscMarkers(diameter, normals_O=normals)
                sensor = ImageSensor(MarkerSensor(camera, P_C), markers, imaging, detector)
                observation = sensor.observe(np.eye(4))
                truth = camera.to_pixels(observation.features_true.reshape(-1, per))
                bias = camera.to_pixels(
                    observation.features_true.reshape(-1, per)
                    + perspective_bias(camera, P_C, normals, 0.5 * diameter)
                )
                found = observation.visible
                detected = (
                    camera.to_pixels(observation.features.reshape(-1, per)[found]) if found.any() else None
                )
                compared += (per - 1) * P_C.shape[0]
                for lens in range(per - 1):
                    columns = [lens, per - 1]  # this lens's u, the shared v
                    biases.append(np.linalg.norm(bias[:, columns] - truth[:, columns], axis=1))
                    if detected is not None:
                        errors.append(np.linalg.norm(detected[:, columns] - truth[found][:, columns], axis=1))
                        residuals.append(
                            np.linalg.norm(detected[:, columns] - bias[found][:, columns], axis=1)
                        )
            err = np.concatenate(errors) if errors else np.empty(0)
            res = np.concatenate(residuals) if residuals else np.empty(0)
            rows.append(
                {
                    "depth_m": float(depth),
                    "blur_px": float(blur),
                    "noise_grey": noise,
                    "diameter_px": float(f_px * diameter / depth),
                    "markers": compared,
                    "detected": err.size / compared,
                    "error_median_px": _stat(err, 50),
                    "error_p95_px": _stat(err, 95),
                    "error_max_px": _stat(err, 100),
                    "bias_median_px": float(np.median(np.concatenate(biases))),
                    "residual_median_px": _stat(res, 50),
                    "residual_p95_px": _stat(res, 95),
                    "residual_max_px": _stat(res, 100),
                }
            )
    return rows


def _stat(values: np.ndarray, percentile: float) -> float:
    return float(np.percentile(values, percentile)) if values.size else float("nan")


def sweep_table(rows: list[dict[str, Any]]) -> str:
    """A Markdown table of :func:`detection_error_sweep` rows."""
    lines = [
        "| depth [m] | blur [px] | disc [px] | found | error median / p95 / max [px] | bias median [px] "
        "| residual median / p95 [px] |",
        "| ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in rows:
        lines.append(
            f"| {r['depth_m']:.1f} | {r['blur_px']:.1f} | {r['diameter_px']:.1f} | {r['detected']:.0%} "
            f"| {r['error_median_px']:.3f} / {r['error_p95_px']:.3f} / {r['error_max_px']:.3f} "
            f"| {r['bias_median_px']:.3f} | {r['residual_median_px']:.3f} / {r['residual_p95_px']:.3f} |"
        )
    return "\n".join(lines)
