"""The axes of a robustness study: what a value of each means, as the disturbances it sets.

:data:`AXES` maps each axis name to an :class:`Axis`: its quantity, default sweep, the check of
its values, and ``levels(value, plant, stereo)``, the fields of
:class:`~ibvs_youla.simulation.disturbances.Disturbances` one value sets (only those that apply
to the plant and camera). The levels of each axis (value 0 is undisturbed, except for
``saturation``, whose ``inf`` is, and ``images``):

* ``noise``: Gaussian pixel noise sigma [px] on every image coordinate (the normalized camera
  of the free families maps 1 px to 1/800);
* ``images``: every frame rendered as a stereo (or mono) pair of grey images of 5 cm discs with a
  1 px Gaussian blur and sensor noise of this standard deviation [grey levels, on a contrast of
  170], the markers detected in them (:class:`~ibvs_youla.simulation.image_sensor.ImageSensor`);
  a frame in which a marker is not found is withheld from the controller. Every value renders
  (value 0 is noise-free images, not the ideal sensor: compare with the ``noise`` axis's 0). A
  camera with pixels only (not the free families' normalized camera); a frame costs 7-8 ms at VGA,
  2,000 of them per 20 s arm run (14-16 s);
* ``calibration``: a level c >= 0 scaling one set of errors of the controller's beliefs:
  focal length and baseline +c %, principal point (+2c, -2c) px, hand-eye transform
  c (1, -1, 1) mm and c (0.1, 0.1, -0.1) deg (rotation vector; arm plants only), markers
  N(0, (c mm)^2) per coordinate;
* ``mismatch``: a level m >= 0 of the dynamic plant against the controller's model: link
  masses and inertias x (1 + m), Coulomb friction 2 m % of each joint's torque limit, viscous
  friction 2 m % of it at the joint's speed limit (IRB 4600: joint 1 62 m N m and 20 m N m
  s/rad); the dynamic plant only;
* ``latency``: k camera frames (integers); the default sweep reaches 300 frames (3 s at the arm's
  100 Hz) because the twist laws' gain lambda = 0.5 1/s keeps the delayed loop e_{k+1} = e_k -
  lambda T e_{k-d} stable up to lambda d T = pi / 2 (d T = 3.1 s), and a delay well inside that
  only speeds the first approach (the dominant root of s = -lambda e^{-s d T} is e times faster
  at lambda d T = 1/e);
* ``saturation``: joint speeds and torques clipped at this fraction of the arm's limits
  (``inf``: no clipping); the dynamic plant only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..exceptions import InvalidParameterError

__all__ = ["AXES", "IMAGE_BLUR_PX", "Axis", "value_label"]

IMAGE_BLUR_PX = 1.0  # the images axis's blur [px]: a focused lens; blur barely moves a centroid


def _noise(value: float, plant: str, stereo: bool) -> dict[str, Any]:
    return {"pixel_noise_px": value}


def _images(noise_grey: float, plant: str, stereo: bool) -> dict[str, Any]:
    return {"rendered_images": True, "image_blur_px": IMAGE_BLUR_PX, "image_noise_grey": noise_grey}


def _calibration(c: float, plant: str, stereo: bool) -> dict[str, Any]:
    errors: dict[str, Any] = {
        "focal_length_scale": 1.0 + 0.01 * c,
        "principal_point_offset_px": (2.0 * c, -2.0 * c),
        "marker_sigma_m": 0.001 * c,
    }
    if stereo:
        errors["baseline_scale"] = 1.0 + 0.01 * c
    if plant != "free-camera":
        errors["hand_eye_translation_m"] = (0.001 * c, -0.001 * c, 0.001 * c)
        errors["hand_eye_rotation_deg"] = (0.1 * c, 0.1 * c, -0.1 * c)
    return errors


def _mismatch(m: float, plant: str, stereo: bool) -> dict[str, Any]:
    from ..model.arm import Arm

    arm = Arm.irb4600()
    tau_max, dq_max = np.asarray(arm.tau_max), np.asarray(arm.dq_max)
    return {
        "plant_inertia_scale": 1.0 + m,
        "viscous_friction": tuple(float(v) for v in 0.02 * m * tau_max / dq_max),
        "coulomb_friction": tuple(float(v) for v in 0.02 * m * tau_max),
    }


def _latency(k: float, plant: str, stereo: bool) -> dict[str, Any]:
    return {"latency_frames": int(k)}


def _saturation(fraction: float, plant: str, stereo: bool) -> dict[str, Any]:
    return {} if math.isinf(fraction) else {"limit_scale": fraction}


@dataclass(frozen=True)
class Axis:
    """One axis of disturbance: what its values mean and where it applies.

    Attributes:
        name: The axis name (``--axis``).
        quantity: What a value is, with its unit (plot and table label).
        defaults: The default sweep.
        levels: ``levels(value, plant, stereo) -> Disturbances fields`` of one value.
        integer: Values are integers (frames).
        positive: Values are > 0 (``inf`` allowed: off); otherwise >= 0 and finite.
        dynamic_only: Acts on the dynamic plant only.
    """

    name: str
    quantity: str
    defaults: tuple[float, ...]
    levels: Callable[[float, str, bool], dict[str, Any]]
    integer: bool = False
    positive: bool = False
    dynamic_only: bool = False

    def check_values(self, values: Sequence[Any]) -> tuple[float, ...]:
        """The values as floats, checked: at least one, distinct, in the axis's range.

        Raises:
            InvalidParameterError: no values, a repeated value, two values that print alike
                (:func:`value_label`: they would share a folder), a value out of range
                (negative; a fraction, for latency; <= 0, for saturation).
        """
        values = tuple(values)
        if not values:
            raise InvalidParameterError("values", [], f"one or more values of {self.quantity}")
        out = []
        for value in values:
            try:
                x = float(value)
            except (TypeError, ValueError):
                x = math.nan
            if self.positive:
                ok = x > 0.0
                valid = "numbers > 0, or inf for no clipping"
            elif self.integer:
                ok = math.isfinite(x) and x >= 0.0 and x == int(x)
                valid = "integers >= 0"
            else:
                ok = math.isfinite(x) and x >= 0.0
                valid = "finite numbers >= 0"
            if not ok:
                raise InvalidParameterError(f"{self.name} value", value, f"{valid} ({self.quantity})")
            out.append(x)
        if len(set(out)) != len(out):
            raise InvalidParameterError("values", list(values), "distinct values")
        labels = [value_label(x) for x in out]
        alike = sorted({label for label in labels if labels.count(label) > 1})
        if alike:  # one folder for two values: the study would never finish
            same = ", ".join(repr(x) for x, label in zip(out, labels, strict=True) if label in alike)
            raise InvalidParameterError(
                "values",
                list(values),
                f"values that print apart in their folder names ({self.name}=<value>, 6 significant "
                f"digits): {same} print as {', '.join(alike)}",
            )
        return tuple(out)


AXES: dict[str, Axis] = {
    axis.name: axis
    for axis in (
        Axis("noise", "pixel noise sigma [px]", (0.0, 0.1, 0.3, 1.0, 3.0), _noise),
        Axis(
            "images",
            "image sensor noise [grey levels] (rendered images, 1 px blur)",
            (0.0, 2.0, 5.0, 10.0, 20.0),
            _images,
        ),
        Axis("calibration", "calibration error level", (0.0, 0.5, 1.0, 2.0, 4.0), _calibration),
        Axis("mismatch", "model mismatch level", (0.0, 0.5, 1.0, 2.0, 4.0), _mismatch, dynamic_only=True),
        Axis("latency", "latency [camera frames]", (0.0, 10.0, 30.0, 100.0, 300.0), _latency, integer=True),
        Axis(
            "saturation",
            "speed and torque limits [fraction of the arm's]",
            (math.inf, 1.0, 0.5, 0.25),
            _saturation,
            positive=True,
            dynamic_only=True,
        ),
    )
}


def value_label(value: float) -> str:
    """A value as written in folder names and tables: ``0.3``, ``2``, ``inf``."""
    return "inf" if math.isinf(value) else f"{value:g}"
