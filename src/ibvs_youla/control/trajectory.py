"""Minimum-jerk (quintic) joint trajectory for the speed-limited feedforward (ERRATA 11).

q(t) = q_start + (q_des - q_start)(10 s^3 - 15 s^4 + 6 s^5), s = t/duration, sized so that
the peak joint speed stays at a chosen fraction of the speed limits. It feeds the filter of
:class:`~ibvs_youla.control.feedforward.FeedforwardDesign` in place of a step of q_des.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validation import as_array, positive, real
from ..exceptions import InvalidArrayError

__all__ = ["MinimumJerkTrajectory"]

_PEAK_SPEED = 15.0 / 8.0  # max of d/ds (10 s^3 - 15 s^4 + 6 s^5) on [0, 1], at s = 1/2
_PEAK_ACCEL = 10.0 / np.sqrt(3.0)  # max of its second derivative, at s = (3 - sqrt(3))/6


@dataclass(frozen=True)
class MinimumJerkTrajectory:
    """q(t) = q_start + (q_des - q_start)(10 s^3 - 15 s^4 + 6 s^5), s = t/duration in [0, 1].

    Zero speed and acceleration at both ends; peak speed (15/8)|Delta|/duration at
    mid-course. Before t = 0 it holds q_start, after t = duration it holds q_des.

    Attributes:
        q_start: Initial joint vector [rad], shape (n,).
        q_des: Final joint vector [rad], shape (n,).
        duration: Travel time [s].
    """

    q_start: np.ndarray
    q_des: np.ndarray
    duration: float

    def __post_init__(self) -> None:
        q0 = as_array(self.q_start, "q_start", (None,))
        q1 = as_array(self.q_des, "q_des", q0.shape)
        object.__setattr__(self, "q_start", q0.copy())
        object.__setattr__(self, "q_des", q1.copy())
        object.__setattr__(self, "duration", positive(self.duration, "duration", unit="s"))

    @classmethod
    def within_speed_limits(
        cls,
        q_start: Any,
        q_des: Any,
        speed_limits: Any,
        fraction: float = 0.5,
        min_duration: float = 0.1,
    ) -> MinimumJerkTrajectory:
        """The shortest trajectory whose peak joint speeds stay within fraction * limits.

        duration = max(min_duration, max_i (15/8) |Delta_i| / (fraction * limit_i)).

        Args:
            q_start: Initial joint vector [rad], shape (n,).
            q_des: Final joint vector [rad], shape (n,).
            speed_limits: Joint speed limits [rad/s], shape (n,), all > 0 (IRB 4600:
                radians of 175, 175, 175, 250, 250, 360 deg/s; ERRATA 16).
            fraction: Fraction of the limits used at peak, in (0, 1].
            min_duration: Lower bound on the duration [s] (also used when q_des = q_start).
        """
        q0 = as_array(q_start, "q_start", (None,))
        q1 = as_array(q_des, "q_des", q0.shape)
        vmax = as_array(speed_limits, "speed_limits", q0.shape)
        if np.any(vmax <= 0.0):
            raise InvalidArrayError("speed_limits", f"{vmax.tolist()}", "entries > 0 [rad/s]")
        fraction = real(fraction, "fraction", low=0.0, low_open=True, high=1.0)
        t_min = positive(min_duration, "min_duration", unit="s")
        needed = float(np.max(_PEAK_SPEED * np.abs(q1 - q0) / (fraction * vmax)))
        return cls(q0, q1, max(t_min, needed))

    @property
    def peak_speed(self) -> np.ndarray:
        """Peak speed of each joint (15/8)|Delta|/duration [rad/s], shape (n,)."""
        return _PEAK_SPEED * np.abs(self.q_des - self.q_start) / self.duration

    @property
    def peak_acceleration(self) -> np.ndarray:
        """Peak acceleration of each joint (10/sqrt(3))|Delta|/duration^2 [rad/s^2]."""
        return _PEAK_ACCEL * np.abs(self.q_des - self.q_start) / self.duration**2

    def position(self, t: float) -> np.ndarray:
        """Joint vector at time t [s] (held outside [0, duration]); t must be finite."""
        s = self._phase(t)
        return self.q_start + (self.q_des - self.q_start) * (s**3 * (10.0 + s * (-15.0 + 6.0 * s)))

    def velocity(self, t: float) -> np.ndarray:
        """Joint speeds at time t [rad/s]; t must be finite."""
        s = self._phase(t)
        return (self.q_des - self.q_start) * (30.0 * s**2 * (1.0 - s) ** 2 / self.duration)

    def _phase(self, t: float) -> float:
        """Phase s = t/duration clipped to [0, 1]; NaN and +-inf are rejected (min/max would pass NaN on)."""
        return min(max(real(t, "t", unit="s") / self.duration, 0.0), 1.0)
