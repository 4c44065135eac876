"""Which recorded sample to show at each display frame when replaying a run at a given speed.

Display frame k is drawn ``k / fps`` seconds of wall-clock time after the start and shows the
simulated instant ``t_0 + k * speed / fps``, i.e. the last recorded sample at or before it (a
zero-order hold, as the recorded signals are samples of a digital loop). ``speed = 1`` is real
time, ``speed = 0.25`` four times slower. The last sample is always the last frame shown.
"""

from __future__ import annotations

import math

import numpy as np

from .._memory import fits_in_memory
from .._validation import as_array, positive
from ..exceptions import InvalidArrayError

__all__ = ["playback_frames"]

_TIME_TOL = 1e-9  # [s] recorded times are sums of float steps; absorb their rounding


def playback_frames(t: object, speed: float = 1.0, fps: float = 30.0) -> np.ndarray:
    """Sample indices (n_frames,) to draw at ``fps`` so that simulated time runs ``speed`` x wall time.

    Args:
        t: Sample times (N,), non-decreasing [s].
        speed: Simulated seconds per wall-clock second (> 0; 1 = real time, < 1 slower).
        fps: Display frames per wall-clock second [Hz] (> 0).

    Returns:
        ``idx[k] = max{i : t[i] <= t[0] + k speed / fps}`` for
        ``k = 0 .. floor((t[-1] - t[0]) fps / speed)``, then the last index if not yet reached,
        so a run of duration D plays in about ``D / speed`` seconds.

    Raises:
        InvalidArrayError: ``t`` empty, not 1-D, non-finite or decreasing.
        InvalidParameterError: ``speed`` or ``fps`` not positive.
    """
    t = as_array(t, "t", (None,))
    speed = positive(speed, "speed")
    fps = positive(fps, "fps", unit="[Hz]")
    if t.size == 0:
        raise InvalidArrayError("t", "an empty array", "at least one sample time")
    if np.any(np.diff(t) < 0.0):
        raise InvalidArrayError("t", "decreasing sample times", "non-decreasing sample times [s]")
    step = speed / fps  # simulated seconds per frame
    frames = (t[-1] - t[0]) / step + _TIME_TOL
    fits_in_memory(16.0 * frames, "speed", speed, "a higher speed or a lower fps")  # times and indices
    n_frames = math.floor(frames) + 1
    frame_times = t[0] + step * np.arange(n_frames)
    idx = np.searchsorted(t, frame_times + _TIME_TOL, side="right") - 1
    if idx[-1] != t.size - 1:
        idx = np.append(idx, t.size - 1)
    return idx
