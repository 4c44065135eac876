"""Free-flying camera plant: a camera with no arm, moved by the twist it is commanded.

As ViSP's ``vpSimulatorCamera``: the commanded twist xi = [v; w] (6,) in the camera frame
[m/s; rad/s] is held over the control period dt and integrated with the exponential map
of SE(3),

    T_O_C(t + dt) = T_O_C(t) exp(dt [xi]^),

exact for a constant body twist (Pinocchio's ``exp6``, through ``_geometry.exp_twist``).
This is the plant of the classical IBVS studies (local minima, camera retreat), where no
joint limits or dynamics interfere.
It has no joints: the controller's :class:`~ibvs_youla.controllers.JointReading` is None.

Two differences from ViSP's simulator, to know when comparing with its tutorials: ViSP
scales a commanded twist down to at most 1 m/s and 90 deg/s (``saturateVelocities``),
which this plant does not, and ViSP's default period is 40 ms, while here the control
period is ``1 / SimulationSettings.camera_rate_hz`` (e.g. ``SimulationSettings(
joint_rate_hz=25.0, camera_rate_hz=25.0)`` for 40 ms; on the free camera the joint rate only
has to be a multiple of the camera rate).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._geometry import exp_twist
from .._validation import as_pose
from ..controllers.base import CommandType
from ..exceptions import InvalidParameterError, SimulationDivergedError

__all__ = ["FreeCameraPlant"]


class FreeCameraPlant:
    """A camera pose integrated from held body twists (module docstring).

    Args:
        T_O_C: Initial camera pose in the base frame (4, 4).
    """

    name = "free-camera"
    accepts = (CommandType.CAMERA_TWIST,)
    n_joints = 0

    def __init__(self, T_O_C: Any) -> None:
        self._T = as_pose(T_O_C, "T_O_C").copy()
        self.t = 0.0

    def use_input(self, command_type: CommandType | str) -> None:
        """The free camera takes a camera twist only; anything else raises InvalidParameterError."""
        if CommandType.parse(command_type) is not CommandType.CAMERA_TWIST:
            raise InvalidParameterError(
                "command_type", command_type, "camera_twist (the free camera's input)"
            )

    def reading(self) -> None:
        """No joints, no encoders."""
        return None

    def camera_pose(self) -> np.ndarray:
        """Camera pose T_O_C (4, 4) (a copy)."""
        return self._T.copy()

    signal_names: tuple[str, ...] = ()

    def signal_values(self, reading: None) -> tuple[np.ndarray, ...]:
        """Nothing beyond the camera pose, which every result records."""
        return ()

    def apply(self, command: np.ndarray, dt: float) -> None:
        """T_O_C <- T_O_C exp(dt [xi]^) for the body twist ``command`` = [v; w] (6,) held over dt.

        Raises:
            SimulationDivergedError: a non-finite twist, or a finite one so large that the pose
                it leads to is not finite (the pose is left at the start of the step).
        """
        if not dt > 0.0:
            raise InvalidParameterError("dt", dt, "a control period > 0 s")
        xi = np.asarray(command, dtype=float)
        if xi.shape != (6,):
            raise InvalidParameterError("command", f"an array of shape {xi.shape}", "a (6,) twist [v; w]")
        if not math.isfinite(xi.dot(xi)) and not np.isfinite(xi).all():  # the dot: one cheap test
            raise SimulationDivergedError(
                self.t,
                "camera_twist",
                np.array(xi),
                "a finite (6,) twist",
                f"simulation diverged at t = {self.t:.6g} s: camera twist {xi.tolist()} is not a finite "
                "(6,) vector [v; w] [m/s, rad/s]",
            )
        T = self._T @ exp_twist(xi * dt)
        flat = T.ravel()
        if not math.isfinite(flat.dot(flat)) and not np.isfinite(flat).all():  # a huge finite twist
            raise SimulationDivergedError(
                self.t + dt,
                "T_O_C",
                T,
                "a finite pose",
                f"simulation diverged at t = {self.t + dt:.6g} s: the camera pose is not finite after "
                f"the twist {xi.tolist()} [m/s, rad/s] held over {dt:g} s",
            )
        self._T = T
        self.t += dt
