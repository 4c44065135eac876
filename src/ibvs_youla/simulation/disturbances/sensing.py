"""Sensing disturbances: pixel noise, quantization, a miscalibrated principal point, dropouts.

:class:`DisturbedSensor` wraps the sensor role of the servo loop (``measure(T_O_C, t) ->
CameraFrame``, ``features_at(T_O_C)``) and changes what the controller is given, in the order a
real camera and its detector would:

1. the true projection (the wrapped sensor: metres on the sensor, from the true principal point);
2. **pixel noise**: an independent N(0, sigma^2) draw [px] on every feature entry ([u_l, u_r, v]
   per point on a stereo camera: the rectified row v is one measurement; [u, v] on a monocular
   one), converted with the pixel pitch p (``sigma_m = sigma_px p``);
3. **quantization**: each entry moved to the centre of the pixel that holds it on the *true*
   pixel grid (pixel i covers [i, i + 1), :mod:`~ibvs_youla.model.camera`): ``px -> floor(px) +
   1/2``, an error uniform in [-1/2, 1/2) px (standard deviation 0.29 px);
4. **principal-point belief**: the controller converts pixels to metres with its own principal
   point (u0 + du, v0 + dv), so every u entry it receives is shifted by ``-du p`` and every v
   entry by ``-dv p``. The taught target (:meth:`DisturbedSensor.features_at`) is shifted the
   same way: it was measured with the same conversion;
5. **dropouts**: on every frame but the first (a run starts on a complete frame), each marker is
   missing with probability ``dropout`` (independent Bernoulli draws): its features become NaN
   in both images and its ``visible`` flag False. What a controller does with such a frame is
   :class:`~.policy.HoldOnMissingFeatures`; its measured depth, if any, is NaN too;
6. **depth noise** (a sensor that measures depth, ``sensor="depth"``): an independent
   N(0, (sigma_1 Z^2)^2) draw [m] on every measured depth Z, sigma_1 the standard deviation at
   1 m (a triangulating depth sensor's error grows with Z^2).

For the normalized camera (``PinholeCamera.normalized()``, F/p = 1 px: pixels mean nothing)
the pixel pitch is taken as ``1 / focal_px`` of a nominal camera with ``focal_px`` pixels of
focal length (:attr:`~.definition.Disturbances.normalized_focal_px`), the principal point at
the origin of the normalized plane.

The noise, dropout and depth-noise draws come from three independent seeded streams, so turning
one on does not change the others' draws.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...controllers.base import CameraFrame
from ...exceptions import InvalidParameterError

__all__ = ["DisturbedSensor", "pixel_grid"]


def pixel_grid(
    camera: Any, n_points: int, normalized_focal_px: float
) -> tuple[float, np.ndarray, np.ndarray]:
    """The pixel pitch [m] and, per feature entry, the pixel origin [px] and whether it is a u entry.

    Feature entry j of a point-major vector maps to pixels as ``px_j = f_j / p + origin_j``
    (Eq. (6) with zero skew): ``origin`` is u0 for the u entries of each lens and v0 for v.

    Returns:
        (p [m], origin (m,) [px], is_u (m,) bool).
    """
    per_point = 3 if hasattr(camera, "baseline") else 2
    f_px = camera.focal_length / camera.pixel_pitch
    if f_px == 1.0:  # the normalized camera: a nominal pixel grid
        pitch = camera.focal_length / normalized_focal_px
        u0 = v0 = 0.0
    else:
        pitch = camera.pixel_pitch
        u0, v0 = camera.principal_point
    is_u = np.tile(np.arange(per_point) < per_point - 1, n_points)
    origin = np.where(is_u, u0, v0)
    return pitch, origin, is_u


class DisturbedSensor:
    """A sensor whose frames carry pixel noise, quantization, a principal-point shift and dropouts.

    Args:
        sensor: The wrapped sensor (``measure``, ``features_at``, ``camera``, ``n_points``).
        noise_px: Standard deviation of the pixel noise [px] (0: none).
        quantize: Round every entry to the centre of its pixel.
        principal_point_offset_px: (du, dv) [px], the controller's principal point minus the true one.
        dropout: Probability that a marker is missing from a frame, in [0, 1).
        normalized_focal_px: Focal length [px] of the nominal pixel grid of the normalized camera.
        noise_rng: Generator of the noise draws.
        dropout_rng: Generator of the dropout draws.
        depth_noise_m: Standard deviation of the depth noise at 1 m [m] (0: none).
        depth_rng: Generator of the depth-noise draws.

    Raises:
        InvalidParameterError: quantization of a camera with skew (its pixel grid is not modelled).
    """

    def __init__(
        self,
        sensor: Any,
        *,
        noise_px: float = 0.0,
        quantize: bool = False,
        principal_point_offset_px: tuple[float, float] = (0.0, 0.0),
        dropout: float = 0.0,
        normalized_focal_px: float = 800.0,
        noise_rng: np.random.Generator | None = None,
        dropout_rng: np.random.Generator | None = None,
        depth_noise_m: float = 0.0,
        depth_rng: np.random.Generator | None = None,
    ) -> None:
        camera = sensor.camera
        if quantize and camera.skew != 0.0:
            raise InvalidParameterError(
                "quantize", True, f"False for a camera with skew {camera.skew} px (zero-skew grids only)"
            )
        self.sensor = sensor
        self.camera = camera
        self.n_points = int(sensor.n_points)
        pitch, origin, is_u = pixel_grid(camera, self.n_points, normalized_focal_px)
        self.pixel_pitch = pitch  # [m]
        self._origin = origin
        self._sigma_m = float(noise_px) * pitch
        self._quantize = bool(quantize)
        du, dv = principal_point_offset_px
        offset = -np.where(is_u, du, dv) * pitch  # [m]
        self._offset = offset if np.any(offset) else None
        self._dropout = float(dropout)
        self._noise_rng = noise_rng if noise_rng is not None else np.random.default_rng(0)
        self._dropout_rng = dropout_rng if dropout_rng is not None else np.random.default_rng(1)
        self._depth_sigma = float(depth_noise_m)  # [m at 1 m]
        self._depth_rng = depth_rng if depth_rng is not None else np.random.default_rng(2)
        self._frames = 0

    def __getattr__(self, name: str) -> Any:
        """Everything else (``markers_O``, ``virtual_points``, ``features_per_point``...) is the sensor's."""
        if name == "sensor":  # not set yet (unpickling): no recursion
            raise AttributeError(name)
        return getattr(self.sensor, name)

    def features_at(self, T_O_C: Any) -> np.ndarray:
        """The noise-free features at a pose, in the controller's conversion (the taught target)."""
        features = self.sensor.features_at(T_O_C)
        return features if self._offset is None else features + self._offset

    def measure(self, T_O_C: np.ndarray, t: float) -> CameraFrame:
        """One frame of the wrapped sensor, disturbed (module docstring)."""
        frame = self.sensor.measure(T_O_C, t)
        features, visible, depth = frame.features, frame.visible, frame.depth
        if self._sigma_m:
            features = features + self._sigma_m * self._noise_rng.standard_normal(features.shape[0])
        if self._quantize:
            p, origin = self.pixel_pitch, self._origin
            features = (np.floor(features / p + origin) + 0.5 - origin) * p
        if self._offset is not None:
            features = features + self._offset
        if self._dropout:
            draws = self._dropout_rng.random(self.n_points)
            missing = draws < self._dropout
            if self._frames and missing.any():
                features = np.array(features, dtype=float)
                features.reshape(self.n_points, -1)[missing] = np.nan
                visible = visible & ~missing
                if depth is not None:
                    depth = np.where(missing, np.nan, depth)
        if self._depth_sigma and depth is not None:
            depth = depth + self._depth_sigma * depth**2 * self._depth_rng.standard_normal(depth.shape[0])
        self._frames += 1
        return frame._replace(features=features, visible=visible, depth=depth)  # an image, if any, passes
