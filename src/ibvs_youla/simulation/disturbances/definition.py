"""The disturbances of one run as data: what breaks the paper's assumptions, each off by default.

:class:`Disturbances` is frozen, validated at construction, seeded and serializable
(:meth:`Disturbances.to_dict` lists only what differs from the default, so all-off is ``{}``).
``simulate(..., disturbances=...)`` applies it by *wrapping* the roles it builds, never by a
branch in the loop; with every field at its default nothing is wrapped and the run is the
undisturbed one, bit for bit:

* images (:class:`~ibvs_youla.simulation.image_sensor.ImageSensor`): every frame rendered as
  images (5 cm discs, blur, sensor noise) and the markers detected in them, in place of the true
  projections; a marker the images do not show is missing (NaN), not filled in with the truth;
* sensing (:mod:`.sensing`): pixel noise, quantization, dropouts and, for a sensor that
  measures depth (``sensor="depth"``), depth noise, wrapped around the sensor, and a frame with
  a missing marker withheld from the controller (:mod:`.policy`);
* calibration (:mod:`.calibration`): the controller's beliefs (camera, hand-eye transform,
  markers); the principal point also shifts the features it receives (:mod:`.sensing`);
* model mismatch and actuator limits (:mod:`.plant_arm`): the dynamic plant's arm (scaled
  masses and inertias, friction, clipped speeds and torques), the controller's model untouched;
* timing (:mod:`.timing`): a latency of k camera frames, wrapped around the sensor (the camera
  and joint-loop rates are settings: ``SimulationSettings(camera_rate_hz=..., joint_rate_hz=...)``).

The random draws (pixel noise, dropouts, marker errors, image noise, depth noise) come from five
independent streams of ``numpy.random.SeedSequence(seed)``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from ..._validation import keywords_checked, non_negative, positive
from ...exceptions import InvalidParameterError

__all__ = ["Disturbances"]

_N_JOINTS = 6
_VECTORS = {  # tuple fields -> length
    "principal_point_offset_px": 2,
    "hand_eye_translation_m": 3,
    "hand_eye_rotation_deg": 3,
    "marker_offset_m": 3,
}
SENSING = ("pixel_noise_px", "quantize", "dropout_probability", "principal_point_offset_px", "depth_noise_m")
IMAGES = ("rendered_images", "image_blur_px", "image_noise_grey")
CALIBRATION = (
    "focal_length_scale",
    "baseline_scale",
    "principal_point_offset_px",
    "hand_eye_translation_m",
    "hand_eye_rotation_deg",
    "marker_offset_m",
    "marker_scale",
    "marker_sigma_m",
)
PLANT = ("plant_inertia_scale", "viscous_friction", "coulomb_friction", "limit_scale")
_PARAMETERS = {  # a parameter of other disturbances -> those disturbances
    "normalized_focal_px": ("pixel_noise_px", "quantize", "dropout_probability", "principal_point_offset_px"),
    "coulomb_speed": ("coulomb_friction",),
    "seed": ("pixel_noise_px", "dropout_probability", "marker_sigma_m", "image_noise_grey", "depth_noise_m"),
}


def _floats(value: Any) -> np.ndarray:
    """``value`` as a float array; NaN for a string or what numpy cannot make one array of (ragged)."""
    if isinstance(value, str):
        return np.array([np.nan])
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return np.array([np.nan])


def _vector(value: Any, name: str, n: int) -> tuple[float, ...]:
    arr = _floats(value)
    if arr.shape != (n,) or not np.all(np.isfinite(arr)):
        raise InvalidParameterError(name, value, f"{n} finite numbers")
    return tuple(float(v) for v in arr)


def _friction(value: Any, name: str, unit: str) -> float | tuple[float, ...]:
    """A friction coefficient: one number >= 0 for every joint, or one per joint (equal ones: one)."""
    arr = _floats(value)
    if arr.ndim == 0 or isinstance(value, str):  # one number (a string: its error names the field)
        return non_negative(value, name, unit=unit)
    if arr.shape != (_N_JOINTS,) or not np.all(np.isfinite(arr)) or np.any(arr < 0.0):
        raise InvalidParameterError(name, value, f"a number >= 0 or {_N_JOINTS} numbers >= 0 [{unit}]")
    if np.all(arr == arr[0]):  # one value for every joint, written once: six zeros are "off"
        return float(arr[0])
    return tuple(float(v) for v in arr)


@keywords_checked
@dataclass(frozen=True)
class Disturbances:
    """Disturbances of one run (module docstring); every default is "off".

    Attributes:
        pixel_noise_px: Standard deviation of Gaussian noise on every image coordinate [px].
        quantize: Round every image coordinate to the centre of its pixel.
        dropout_probability: Probability that a marker is missing from a frame, in [0, 1).
        rendered_images: Measure every frame in rendered images, the markers detected in them
            (:class:`~ibvs_youla.simulation.image_sensor.ImageSensor`: 5 cm discs facing the
            camera, the moments detector, ``missing="nan"``), instead of the true projections;
            a frame with a missing marker is withheld from the controller (:mod:`.policy`).
            Needs a camera with pixels (not ``PinholeCamera.normalized()``). For a controller
            that servoes on the image of a scene (``photometric``), the image of the scene is
            the rendered image instead: blurred, noisy and rounded to 8 bits, not exact.
        image_blur_px: Standard deviation of the rendered images' Gaussian blur [px] (needs
            ``rendered_images``).
        image_noise_grey: Standard deviation of the rendered images' sensor noise [grey levels,
            on a disc-to-background contrast of 170] (needs ``rendered_images``).
        normalized_focal_px: Focal length [px] that gives the normalized camera (F = 1, no
            pixels) a pixel grid for the sensing disturbances: sigma_px pixels are sigma_px /
            normalized_focal_px in normalized coordinates (default 800 px: a 640 x 480 camera
            with a 44 deg horizontal field of view).
        focal_length_scale: The controller's focal length over the true one.
        baseline_scale: The controller's stereo baseline over the true one.
        principal_point_offset_px: (du, dv), the controller's principal point minus the true [px].
        hand_eye_translation_m: Translation of the believed camera on the flange, in {C} [m].
        hand_eye_rotation_deg: Rotation vector of the believed camera on the flange, in {C} [deg].
        marker_offset_m: Offset o of every believed marker [m].
        marker_scale: Scale s of the believed markers about their centroid.
        marker_sigma_m: Standard deviation of seeded per-marker errors of the beliefs [m].
        plant_inertia_scale: The dynamic plant's link masses and inertias over the controller's model.
        viscous_friction: Viscous joint friction of the plant, one value or six [N m s/rad].
        coulomb_friction: Coulomb joint friction of the plant, one value or six [N m].
        coulomb_speed: Regularization speed of the Coulomb law [rad/s] (:mod:`.plant_arm`).
        latency_frames: The controller sees the frame captured this many frames earlier.
        limit_scale: The dynamic plant clips joint speeds and torques at this fraction of the
            arm's limits (None: no clipping beyond ``SimulationSettings.saturate``).
        seed: Seed of the noise, dropout and marker-error draws (an integer >= 0).
        depth_noise_m: Standard deviation of the measured depths' noise at a depth of 1 m [m];
            at depth Z it is ``depth_noise_m * Z**2`` (the error of a triangulating depth
            sensor, structured light or stereo, grows with the square of the depth: Khoshelham
            & Elberink 2012). Needs a sensor that measures depth (``sensor="depth"``).

    Raises:
        InvalidParameterError: a negative noise, latency, friction or sigma; a scale <= 0; a
            dropout probability outside [0, 1); a vector of the wrong length; a seed or
            latency that is not an integer; image blur or noise without ``rendered_images``.
    """

    pixel_noise_px: float = 0.0
    quantize: bool = False
    dropout_probability: float = 0.0
    rendered_images: bool = False
    image_blur_px: float = 0.0
    image_noise_grey: float = 0.0
    normalized_focal_px: float = 800.0
    focal_length_scale: float = 1.0
    baseline_scale: float = 1.0
    principal_point_offset_px: tuple[float, float] = (0.0, 0.0)
    hand_eye_translation_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    hand_eye_rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    marker_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    marker_scale: float = 1.0
    marker_sigma_m: float = 0.0
    plant_inertia_scale: float = 1.0
    viscous_friction: float | tuple[float, ...] = 0.0
    coulomb_friction: float | tuple[float, ...] = 0.0
    coulomb_speed: float = 0.05
    latency_frames: int = 0
    limit_scale: float | None = None
    seed: int = 0
    depth_noise_m: float = 0.0

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "pixel_noise_px", non_negative(self.pixel_noise_px, "pixel_noise_px", unit="px"))
        for name in ("quantize", "rendered_images"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise InvalidParameterError(name, getattr(self, name), "True or False")
            set_(self, name, bool(getattr(self, name)))
        set_(self, "image_blur_px", non_negative(self.image_blur_px, "image_blur_px", unit="px"))
        set_(
            self,
            "image_noise_grey",
            non_negative(self.image_noise_grey, "image_noise_grey", unit="grey levels"),
        )
        if not self.rendered_images and (self.image_blur_px or self.image_noise_grey):
            raise InvalidParameterError(
                "image_blur_px, image_noise_grey",
                (self.image_blur_px, self.image_noise_grey),
                "zero without rendered_images=True (they describe the rendered images)",
            )
        p = non_negative(self.dropout_probability, "dropout_probability")
        if p >= 1.0:
            raise InvalidParameterError("dropout_probability", p, "a probability in [0, 1)")
        set_(self, "dropout_probability", p)
        for name in (
            "normalized_focal_px",
            "focal_length_scale",
            "baseline_scale",
            "marker_scale",
            "plant_inertia_scale",
            "coulomb_speed",
        ):
            set_(self, name, positive(getattr(self, name), name))
        for name, n in _VECTORS.items():
            set_(self, name, _vector(getattr(self, name), name, n))
        if np.linalg.norm(self.hand_eye_rotation_deg) >= 180.0:
            raise InvalidParameterError(
                "hand_eye_rotation_deg", self.hand_eye_rotation_deg, "a rotation vector of norm < 180 deg"
            )
        set_(self, "marker_sigma_m", non_negative(self.marker_sigma_m, "marker_sigma_m", unit="m"))
        set_(self, "depth_noise_m", non_negative(self.depth_noise_m, "depth_noise_m", unit="m at 1 m"))
        set_(self, "viscous_friction", _friction(self.viscous_friction, "viscous_friction", "N m s/rad"))
        set_(self, "coulomb_friction", _friction(self.coulomb_friction, "coulomb_friction", "N m"))
        if self.limit_scale is not None:
            set_(self, "limit_scale", positive(self.limit_scale, "limit_scale"))
        for name in ("latency_frames", "seed"):
            value = getattr(self, name)
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < 0:
                raise InvalidParameterError(name, value, "an integer >= 0")
            set_(self, name, int(value))

    # ------------------------------------------------------------------ data
    def to_dict(self) -> dict[str, Any]:
        """The fields that differ from their defaults, as JSON values (``{}``: nothing disturbed).

        The parameters of other disturbances are listed only when those are on: the seed with
        something random (noise, dropouts, marker draws), ``normalized_focal_px`` with a pixel
        disturbance, ``coulomb_speed`` with Coulomb friction.
        """
        default = _DEFAULT
        out: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name not in _PARAMETERS and value != getattr(default, f.name):
                out[f.name] = list(value) if isinstance(value, tuple) else value
        for name, needs in _PARAMETERS.items():  # parameters of other disturbances, when those are on
            if any(n in out for n in needs) and (
                name == "seed" or getattr(self, name) != getattr(default, name)
            ):
                out[name] = getattr(self, name)
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Disturbances:
        """The disturbances of :meth:`to_dict` (or any subset of the fields).

        Raises:
            InvalidParameterError: not a mapping, or an unknown field (the message lists the
                valid ones).
        """
        names = {f.name for f in fields(cls)}
        if not isinstance(data, Mapping):
            raise InvalidParameterError(
                "disturbances", type(data).__name__, "a mapping of fields among " + ", ".join(sorted(names))
            )
        unknown = sorted(set(data) - names)
        if unknown:
            raise InvalidParameterError("disturbances", unknown, "fields among " + ", ".join(sorted(names)))
        return cls(**data)

    @property
    def active(self) -> bool:
        """Whether anything is disturbed."""
        return bool(self.to_dict())

    def _any(self, names: tuple[str, ...]) -> bool:
        default = _DEFAULT
        return any(getattr(self, n) != getattr(default, n) for n in names)

    @property
    def plant_changed(self) -> bool:
        """Whether the dynamic plant's arm differs (inertias, friction, limits)."""
        return self._any(PLANT)

    @property
    def calibration_changed(self) -> bool:
        """Whether a belief of the controller differs (camera, hand-eye, markers)."""
        return self._any(CALIBRATION)

    # ------------------------------------------------------------------ applicability
    def check_applies(self, plant: str, camera: Any) -> None:
        """Raise if a disturbance has nothing to act on in this run.

        Raises:
            InvalidParameterError: plant inertias, friction or limits on a plant other than
                ``"dynamic"`` (the kinematic arm and the free camera have no dynamics); a
                hand-eye error without an arm; a baseline error of a monocular camera;
                rendered images of a camera without pixels (the normalized camera).
        """
        if plant != "dynamic" and self.plant_changed:
            names = [n for n in PLANT if getattr(self, n) != getattr(_DEFAULT, n)]
            raise InvalidParameterError(
                "disturbances",
                ", ".join(names),
                f"defaults on the {plant!r} plant: masses, friction and actuator limits act on the "
                "'dynamic' plant only",
            )
        if plant == "free-camera" and self._any(("hand_eye_translation_m", "hand_eye_rotation_deg")):
            raise InvalidParameterError(
                "disturbances", "hand_eye_*", "zero on the free camera (no arm, no hand-eye transform)"
            )
        if self.rendered_images:
            from ..rendering import check_camera_has_pixels

            try:
                check_camera_has_pixels(camera)
            except InvalidParameterError as err:
                raise InvalidParameterError(
                    "rendered_images", True, f"False for camera {err.value}: rendering needs {err.valid}"
                ) from None
        if self.baseline_scale != 1.0 and not hasattr(camera, "baseline"):
            raise InvalidParameterError(
                "baseline_scale", self.baseline_scale, f"1.0 for a {type(camera).__name__} (no baseline)"
            )

    # ------------------------------------------------------------------ assembly
    def generators(self) -> tuple[np.random.Generator, np.random.Generator, np.random.Generator]:
        """(noise, dropout, marker) generators: the first three streams of SeedSequence(seed)."""
        noise, dropout, markers = np.random.SeedSequence(self.seed).spawn(3)
        return (
            np.random.default_rng(noise),
            np.random.default_rng(dropout),
            np.random.default_rng(markers),
        )

    @property
    def depth_seed(self) -> np.random.SeedSequence:
        """Seed of the depth noise: the fifth stream of SeedSequence(seed)."""
        return np.random.SeedSequence(self.seed).spawn(5)[4]

    @property
    def image_seed(self) -> int:
        """Seed of the rendered images' noise: the fourth stream of SeedSequence(seed)."""
        return int(np.random.SeedSequence(self.seed).spawn(4)[3].generate_state(1)[0])

    def wrap_sensor(self, sensor: Any, noise_rng: Any, dropout_rng: Any, scene: Any = None) -> Any:
        """The sensor with the images, the sensing disturbances and the latency around it (or itself).

        With a ``scene`` (a controller that servoes on the image), every frame carries the image of
        the scene (:class:`~ibvs_youla.simulation.scene_sensor.SceneImageSensor`), and
        ``rendered_images`` with its blur and noise describe that image, not disc markers: the
        point features stay those of ``sensor``.

        Raises:
            InvalidParameterError: ``rendered_images`` around a sensor other than the true
                :class:`~ibvs_youla.simulation.sensor.MarkerSensor` (e.g. ``sensor="images"``:
                give one or the other) or around one that measures depth (rendered images have
                no depth channel); ``depth_noise_m`` with a sensor that measures no depth.
        """
        from .sensing import DisturbedSensor
        from .timing import DelayedSensor

        if scene is not None:
            from ..rendering import ImagingSettings
            from ..scene_sensor import SceneImageSensor

            imaging = None
            if self.rendered_images:
                imaging = ImagingSettings(self.image_blur_px, self.image_noise_grey, seed=self.image_seed)
            sensor = SceneImageSensor(sensor, scene, imaging)
        elif self.rendered_images:
            from ..image_sensor import ImageSensor
            from ..rendering import ImagingSettings
            from ..sensor import MarkerSensor

            if not isinstance(sensor, MarkerSensor) or sensor.measures_depth:
                raise InvalidParameterError(
                    "sensor",
                    type(sensor).__name__,
                    "the ideal sensor (None or 'ideal') with rendered_images=True, which renders the "
                    "images itself; or sensor='images' (or a function) without rendered_images",
                )
            imaging = ImagingSettings(self.image_blur_px, self.image_noise_grey, seed=self.image_seed)
            sensor = ImageSensor(sensor, imaging=imaging, missing="nan")
        if self.depth_noise_m and not getattr(sensor, "measures_depth", False):
            raise InvalidParameterError(
                "depth_noise_m",
                self.depth_noise_m,
                "0.0 with a sensor that measures no depth; or sensor='depth' (an RGB-D camera)",
            )
        if self._any(SENSING):
            sensor = DisturbedSensor(
                sensor,
                noise_px=self.pixel_noise_px,
                quantize=self.quantize,
                principal_point_offset_px=self.principal_point_offset_px,
                dropout=self.dropout_probability,
                normalized_focal_px=self.normalized_focal_px,
                noise_rng=noise_rng,
                dropout_rng=dropout_rng,
                depth_noise_m=self.depth_noise_m,
                depth_rng=np.random.default_rng(self.depth_seed),
            )
        if self.latency_frames:
            sensor = DelayedSensor(sensor, self.latency_frames)
        return sensor

    def wrap_controller(self, controller: Any) -> Any:
        """The controller, holding on frames with missing features (dropouts or rendered images)."""
        from .policy import HoldOnMissingFeatures

        if self.dropout_probability or self.rendered_images:
            return HoldOnMissingFeatures(controller)
        return controller

    def plant_arm(self, arm: Any) -> Any:
        """The dynamic plant's arm: ``arm`` itself, or a :class:`~.plant_arm.PlantArm` around it."""
        from .plant_arm import PlantArm

        if not self.plant_changed:
            return arm
        scale = self.plant_inertia_scale
        true_arm = arm if scale == 1.0 else arm.with_inertia_scale(scale)
        n = len(np.asarray(arm.q_min))
        return PlantArm(
            true_arm,
            viscous=np.broadcast_to(np.asarray(self.viscous_friction, dtype=float), (n,)),
            coulomb=np.broadcast_to(np.asarray(self.coulomb_friction, dtype=float), (n,)),
            coulomb_speed=self.coulomb_speed,
            limit_scale=1.0 if self.limit_scale is None else self.limit_scale,
        )

    def believed_models(
        self, arm: Any, camera: Any, markers_O: np.ndarray, rng: Any
    ) -> tuple[Any, Any, np.ndarray | None]:
        """The controller's (arm, camera, markers) with the calibration errors (None: unchanged)."""
        from .calibration import believed_models

        return believed_models(self, arm, camera, markers_O, rng)

    def describe(self) -> str:
        """One line: the fields that differ from the defaults."""
        d = self.to_dict()
        return ", ".join(f"{k}={v}" for k, v in d.items()) if d else "none"


_DEFAULT = Disturbances()
