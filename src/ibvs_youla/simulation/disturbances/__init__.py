"""Disturbances of the servo loop: sensing, calibration, model mismatch, timing, actuator limits.

:class:`Disturbances` (:mod:`.definition`) holds them as data; ``simulate(...,
disturbances=...)`` wraps the roles it builds with the modules of each kind: :mod:`.sensing`
(pixel noise, quantization, dropouts, principal point), :mod:`.policy` (what a controller does
with a frame whose features are missing), :mod:`.calibration` (the controller's beliefs),
:mod:`.plant_arm` (masses, inertias, friction and limits of the dynamic plant) and
:mod:`.timing` (latency).
"""

from .calibration import believed_models, hand_eye_error
from .definition import Disturbances
from .plant_arm import PlantArm
from .policy import HoldOnMissingFeatures
from .sensing import DisturbedSensor, pixel_grid
from .timing import DelayedSensor

__all__ = [
    "DelayedSensor",
    "Disturbances",
    "DisturbedSensor",
    "HoldOnMissingFeatures",
    "PlantArm",
    "believed_models",
    "hand_eye_error",
    "pixel_grid",
]
