"""Timing disturbance: the controller sees the camera frame captured k frames earlier.

:class:`DelayedSensor` wraps the sensor role. At every camera frame it takes a frame from the
true camera (so a marker lost *now* still stops the run as ``markers_lost``) and returns the
one captured ``latency_frames`` frames before, which carries its own capture time
(:attr:`~ibvs_youla.controllers.CameraFrame.t`). Before k frames exist, the oldest frame (the
first) is returned: the history before the start is the start, the usual initial condition of
a delayed system (the arm starts at rest). A latency longer than the run is no special case: the
controller sees the first frame throughout (the buffer never holds more than the frames taken).

A delay of d frames on the free camera's classical IBVS, v_k = -lambda L^+ e_{k-d}, gives the
loop e_{k+1} = e_k - lambda T e_{k-d} (T the frame period), stable for lambda T < 2 sin(pi /
(2 (2 d + 1))) (2 for d = 0, 1 for d = 1, 0.618 for d = 2); ``tests/test_disturbance_effects.py``
checks the simulated boundary against the gain margin python-control computes.

The camera and joint-loop *rates* are not disturbances: they are settings
(``SimulationSettings(joint_rate_hz=..., camera_rate_hz=...)``).
"""

from __future__ import annotations

import sys
from collections import deque
from typing import Any

import numpy as np

from ...controllers.base import CameraFrame

__all__ = ["DelayedSensor"]


class DelayedSensor:
    """A sensor that returns the frame captured ``latency_frames`` frames earlier (module docstring).

    Args:
        sensor: The wrapped sensor (``measure``, ``features_at``, ...).
        latency_frames: k >= 1, the delay in camera frames.
    """

    def __init__(self, sensor: Any, latency_frames: int) -> None:
        self.sensor = sensor
        self.latency_frames = int(latency_frames)
        # bounded by the frames taken; deque's maxlen must fit a C ssize_t (a latency of 1e30 frames)
        self._buffer: deque[CameraFrame] = deque(maxlen=min(self.latency_frames + 1, sys.maxsize))

    def __getattr__(self, name: str) -> Any:
        """Everything else (``camera``, ``n_points``, ``features_at``...) is the wrapped sensor's."""
        if name == "sensor":  # not set yet (unpickling): no recursion
            raise AttributeError(name)
        return getattr(self.sensor, name)

    def measure(self, T_O_C: np.ndarray, t: float) -> CameraFrame:
        """Take the frame of now; return the one captured k frames ago (the first, early on)."""
        self._buffer.append(self.sensor.measure(T_O_C, t))
        return self._buffer[0]
