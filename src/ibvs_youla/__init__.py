"""ibvs-youla: stereo IBVS of a 6-DOF arm with feedforward and adaptive Youla control.

Implements Li & Assadian's feedforward + Youla-parameterized stereo image-based
visual servoing on Pinocchio rigid-body dynamics. The data flows
model (arm, camera) -> estimation (stereo pose, hand-eye) -> control (inner,
feedforward, outer designs) -> controllers (the servo laws, by name) -> simulation
(sensor, plants, actuation, the loop) -> analysis. See docs/conventions.md for
frames, units and feature ordering.

Public names are imported lazily (PEP 562), so ``import ibvs_youla`` stays cheap
and loads Pinocchio or python-control only when a name that needs them is used.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from . import exceptions
from .exceptions import IbvsYoulaError

__version__ = "0.1.0"

# public name -> module that defines it (relative to this package)
_LAZY: dict[str, str] = {
    # model
    "Arm": ".model.arm",
    "StereoCamera": ".model.camera",
    "PinholeCamera": ".model.camera",
    "Visibility": ".model.camera",
    "TexturedPlane": ".model.textured_plane",
    # estimation
    "EyeInHand": ".estimation.eye_in_hand",
    "rigid_transform_from_points": ".estimation.stereo_pose",
    "calibrate_hand_eye": ".estimation.hand_eye",
    "DetectorSettings": ".estimation.marker_detection",
    # control
    "InnerLoopDesign": ".control.inner",
    "FeedforwardDesign": ".control.feedforward",
    "OuterLoopDesign": ".control.outer",
    "SingularValuePolicy": ".control.singular_values",
    # simulation
    "Scenario": ".scenarios",
    "simulate": ".simulation.simulate",
    "simulate_batch": ".simulation.batch",
    "BatchResult": ".simulation.batch",
    "Beliefs": ".simulation.simulate",
    "Disturbances": ".simulation.disturbances.definition",
    "SimulationSettings": ".simulation.settings",
    "SimulationResult": ".simulation.results",
    "ImageSensor": ".simulation.image_sensor",
    "DiscMarkers": ".simulation.rendering",
    "ImagingSettings": ".simulation.rendering",
}
_SUBMODULES = {"scenarios", "model", "estimation", "control", "controllers", "simulation", "analysis"}
_ALIASES = {"robots": ".model.robots"}  # iy.robots: robots by name

__all__ = [
    "Arm",
    "BatchResult",
    "Beliefs",
    "DetectorSettings",
    "DiscMarkers",
    "Disturbances",
    "EyeInHand",
    "FeedforwardDesign",
    "IbvsYoulaError",
    "ImageSensor",
    "ImagingSettings",
    "InnerLoopDesign",
    "OuterLoopDesign",
    "PinholeCamera",
    "Scenario",
    "SimulationResult",
    "SimulationSettings",
    "SingularValuePolicy",
    "StereoCamera",
    "TexturedPlane",
    "Visibility",
    "__version__",
    "analysis",
    "calibrate_hand_eye",
    "control",
    "controllers",
    "estimation",
    "exceptions",
    "model",
    "rigid_transform_from_points",
    "robots",
    "scenarios",
    "simulate",
    "simulate_batch",
    "simulation",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    if name in _SUBMODULES or name in _ALIASES:
        module = importlib.import_module(_ALIASES.get(name, f".{name}"), __name__)
        globals()[name] = module
        return module
    raise AttributeError(f"module 'ibvs_youla' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    from . import controllers, scenarios
    from .control.feedforward import FeedforwardDesign
    from .control.inner import InnerLoopDesign
    from .control.outer import OuterLoopDesign
    from .control.singular_values import SingularValuePolicy
    from .estimation.eye_in_hand import EyeInHand
    from .estimation.hand_eye import calibrate_hand_eye
    from .estimation.marker_detection import DetectorSettings
    from .estimation.stereo_pose import rigid_transform_from_points
    from .model import robots
    from .model.arm import Arm
    from .model.camera import PinholeCamera, StereoCamera, Visibility
    from .model.textured_plane import TexturedPlane
    from .scenarios import Scenario
    from .simulation.batch import BatchResult, simulate_batch
    from .simulation.disturbances.definition import Disturbances
    from .simulation.image_sensor import ImageSensor
    from .simulation.rendering import DiscMarkers, ImagingSettings
    from .simulation.results import SimulationResult
    from .simulation.settings import SimulationSettings
    from .simulation.simulate import Beliefs, simulate
