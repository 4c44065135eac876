"""The sensor of a controller that servoes on the image: every frame carries the image of the scene.

:class:`SceneImageSensor` wraps any sensor of the servo loop (the true
:class:`~ibvs_youla.simulation.sensor.MarkerSensor`, the disc-detecting
:class:`~ibvs_youla.simulation.image_sensor.ImageSensor`, ...) and adds to each of its frames
the image of the scenario's scene seen from the true camera pose
(:attr:`~ibvs_youla.controllers.CameraFrame.image`): the textured plane imaged through its
homography (:mod:`~ibvs_youla.model.textured_plane`). The wrapped sensor's features and
visibility pass through unchanged: they are what the metrics of a run are computed on, while a
photometric controller uses the image alone.

The image is exact (float32 grey levels) by default. With imaging settings
(``Disturbances(rendered_images=True, image_blur_px=..., image_noise_grey=...)``, or given here)
it is what a camera makes of it (:func:`~ibvs_youla.simulation.rendering.finish_image`): Gaussian
blur, seeded sensor noise, rounded to 8 bits. The target image (:meth:`SceneImageSensor.image_at`)
is taken the same way without the noise: the target is taught by showing, as the target
features are the noise-free projections.

Only a monocular camera with pixels images the scene (a ``PinholeCamera``; not
``PinholeCamera.normalized()``, which has no pixel grid, and not a stereo pair).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ..controllers.base import CameraFrame
from ..exceptions import InvalidParameterError
from ..model.camera import PinholeCamera, check_camera_has_pixels
from ..model.textured_plane import TexturedPlane, render_plane
from .rendering import ImagingSettings, finish_image

__all__ = ["SceneImageSensor"]


class SceneImageSensor:
    """Frames of the wrapped sensor with the image of the scene (module docstring).

    Args:
        sensor: The wrapped sensor (``measure``, ``features_at``, ``camera``, ...).
        scene: The true scene (a :class:`~ibvs_youla.model.textured_plane.TexturedPlane`).
        imaging: Blur, noise and seed of the camera; None: the exact image.

    Raises:
        InvalidParameterError: a scene that is not a TexturedPlane, imaging settings of the wrong
            type, a camera that is not a PinholeCamera with pixels.
    """

    def __init__(self, sensor: Any, scene: TexturedPlane, imaging: ImagingSettings | None = None) -> None:
        if not isinstance(scene, TexturedPlane):
            raise InvalidParameterError("scene", type(scene).__name__, "a TexturedPlane")
        if imaging is not None and not isinstance(imaging, ImagingSettings):
            raise InvalidParameterError("imaging", type(imaging).__name__, "an ImagingSettings or None")
        camera = sensor.camera
        if not isinstance(camera, PinholeCamera):
            raise InvalidParameterError(
                "camera",
                type(camera).__name__,
                "a PinholeCamera with pixels to image the scene on (one lens; not a stereo pair)",
            )
        check_camera_has_pixels(camera)
        self.sensor = sensor
        self.scene = scene
        self.imaging = imaging
        self._rng = np.random.default_rng(imaging.seed) if imaging is not None else None
        self._noise_free = None if imaging is None else replace(imaging, noise_sigma_grey=0.0)

    def __getattr__(self, name: str) -> Any:
        """Everything else (``camera``, ``features_at``, ``n_points``...) is the wrapped sensor's."""
        if name == "sensor":  # not set yet (unpickling): no recursion
            raise AttributeError(name)
        return getattr(self.sensor, name)

    def image_at(self, T_O_C: np.ndarray) -> np.ndarray:
        """The noise-free image (height, width) float32 from the camera pose T_O_C (the target's)."""
        image = render_plane(self.sensor.camera, self.scene, np.asarray(T_O_C, dtype=float))
        if self._noise_free is None:
            return image
        return finish_image(image, self._noise_free, None).astype(np.float32)

    def measure(self, T_O_C: np.ndarray, t: float) -> CameraFrame:
        """The wrapped sensor's frame at the true pose T_O_C (4, 4), with the image it sees.

        Raises:
            PointBehindCameraError: as the wrapped sensor (a marker behind the camera).
        """
        frame = self.sensor.measure(T_O_C, t)
        image = render_plane(self.sensor.camera, self.scene, T_O_C)
        if self.imaging is not None:
            image = finish_image(image, self.imaging, self._rng).astype(np.float32)
        return frame._replace(image=image)

    def spec(self) -> dict[str, Any]:
        """Plain data describing the sensor: the imaging settings (the scene is the scenario's)."""
        return {"name": "scene-images", "imaging": None if self.imaging is None else self.imaging.to_dict()}
