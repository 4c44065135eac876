"""Hybrid switched IBVS/PBVS, after Gans & Hutchinson (IEEE Trans. Robotics 23(3), 2007).

Gans & Hutchinson, "Stable visual servoing through hybrid switched-system control". Two
controllers run on every frame: classical IBVS with L at the current features
(:class:`~.ibvs.ClassicalIBVS`, ``"ibvs-current"``) and PBVS (:class:`~.pbvs.PBVS`); one of
them drives the camera. The switching is state based, on the Lyapunov function of each:

    V_i = 1/2 ||s - s*||^2 / F^2          (the image error, in normalized coordinates)
    V_p = 1/2 ||(c*t_c, theta u)||^2       (the pose error of PBVS, [m^2] + [rad^2])

Each law makes its own function decrease to first order (V_i' = -lambda e^T L L^+ e <= 0
for IBVS, V_p' = -2 lambda V_p for PBVS), while the other one may grow: IBVS may move the
camera far in 3-D (the retreat of a rotation about the optical axis), PBVS may drive
features out of the image. So, as Gans & Hutchinson propose, the system switches to the
other controller when the inactive controller's function reaches its upper bound:

* in IBVS mode, switch to PBVS when V_p >= gamma_p;
* in PBVS mode, switch to IBVS when V_i >= gamma_i;

with the bounds set at the first frame, gamma = (1 + ``margin``) V(0) for each function
(this library's choice of bounds: each function is kept below a multiple of where it
started). Hysteresis: a mode is kept for at least ``min_dwell`` frames, so noise near a
bound cannot make the law chatter. The active mode is recorded at tick rate
(``hybrid_mode``: 0 IBVS, 1 PBVS) with the number of switches (``hybrid_switches``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validation import integer, non_negative, one_of
from ..estimation.monocular_pose import PNP_METHODS
from .base import CameraFrame, CommandType, Controller, JointReading, ServoTask
from .ibvs import ClassicalIBVS
from .image_points import pnp_spec
from .pbvs import PBVS

__all__ = ["MODES", "REGISTRATIONS", "HybridSwitched"]

MODES = ("ibvs", "pbvs")


class HybridSwitched(Controller):
    """IBVS and PBVS switched on each other's Lyapunov function (module docstring).

    Args:
        gain: lambda [1/s] of both laws (default 0.5).
        margin: The bounds are (1 + margin) times the initial V_i and V_p (default 0.0: a
            function may never exceed where it started).
        start_mode: ``"ibvs"`` (default) or ``"pbvs"``.
        min_dwell: Frames a mode is kept after a switch (default 5, >= 1).
        pnp: The PnP method of the monocular pose, one of
            :data:`~ibvs_youla.estimation.monocular_pose.PNP_METHODS` (default ``"sqpnp"``), for
            both laws: they share one estimator (one pose per frame). Stereo: only the default.

    Raises:
        InvalidParameterError: a bad gain, margin, mode, dwell or ``pnp``; at reset, what either
            law rejects (a camera of another kind, too few markers, ``pnp`` other than ``"sqpnp"``
            with a stereo camera, ``"ippe"`` with markers that are not coplanar).
    """

    command_type = CommandType.CAMERA_TWIST
    name = "hybrid"

    def __init__(
        self,
        gain: float = 0.5,
        margin: float = 0.0,
        start_mode: str = "ibvs",
        min_dwell: int = 5,
        pnp: str = "sqpnp",
    ) -> None:
        self.pnp = one_of(pnp, "pnp", PNP_METHODS)
        self._ibvs = ClassicalIBVS("current", gain, self.pnp)
        self._pbvs = PBVS(gain, self.pnp)
        self.gain = self._pbvs.gain
        self.margin = non_negative(margin, "margin")
        self.start_mode = one_of(start_mode, "start_mode", MODES)
        self.min_dwell = integer(min_dwell, "min_dwell", low=1, unit="[frames]")

    def spec(self) -> dict[str, Any]:
        """Gain, margin, start mode, dwell, and the PnP method when it is not the default."""
        return {
            **super().spec(),
            "gain": self.gain,
            "margin": self.margin,
            "start_mode": self.start_mode,
            "min_dwell": self.min_dwell,
            **pnp_spec(self.pnp),
        }

    def reset(self, task: ServoTask) -> None:
        """Reset both laws with the task; the bounds are set at the first frame."""
        self._ibvs.reset(task)
        self._pbvs.reset(task)
        if self._ibvs.pose_estimator is not None:  # monocular: both laws from one pose per frame
            self._pbvs.pose_estimator = self._ibvs.pose_estimator  # the same camera, markers and PnP method
        self.pose_estimator = self._pbvs.pose_estimator  # the pose of each frame (both laws' if monocular)
        super().reset(task)
        self._mode = MODES.index(self.start_mode)
        self._bounds: tuple[float, float] | None = None
        self._dwell = 0
        self._switches = 0
        self._focal = float(task.camera.focal_length)

    @property
    def ibvs(self) -> ClassicalIBVS:
        """The IBVS law (L at the current features, this law's gain and ``pnp``), reset with the task."""
        return self._ibvs

    @property
    def pbvs(self) -> PBVS:
        """The PBVS law (this law's gain and ``pnp``), reset with the task."""
        return self._pbvs

    def lyapunov(self) -> tuple[float, float]:
        """(V_i, V_p) of the last frame (module docstring)."""
        e_image = self._image_error / self._focal
        return 0.5 * float(e_image @ e_image), 0.5 * float(self._pbvs_error @ self._pbvs_error)

    def update(self, frame: CameraFrame, reading: JointReading | None) -> None:
        """Both laws on the frame; switch when the inactive law's function reaches its bound."""
        self._ibvs.update(frame, reading)
        self._pbvs.update(frame, reading)
        self._image_error = frame.features - self.task.feature_target
        self._pbvs_error = self._pbvs.signals()["servo_error"]
        V_i, V_p = self.lyapunov()
        if self._bounds is None:
            self._bounds = ((1.0 + self.margin) * V_i, (1.0 + self.margin) * V_p)
        self._dwell += 1
        if self._dwell >= self.min_dwell:
            gamma_i, gamma_p = self._bounds
            if (self._mode == 0 and V_p >= gamma_p and V_p > 0.0) or (
                self._mode == 1 and V_i >= gamma_i and V_i > 0.0
            ):
                self._mode = 1 - self._mode
                self._dwell = 0
                self._switches += 1

    def command(self, reading: JointReading | None) -> np.ndarray:
        """The active law's twist ``[v; w]`` [m/s, rad/s]."""
        return (self._ibvs if self._mode == 0 else self._pbvs).command(reading)

    def signals(self) -> dict[str, np.ndarray]:
        """``hybrid_mode`` (0 IBVS, 1 PBVS) and ``hybrid_switches`` so far, each (1,)."""
        return {
            "hybrid_mode": np.array([float(self._mode)]),
            "hybrid_switches": np.array([float(self._switches)]),
        }


REGISTRATIONS = (
    (
        "hybrid",
        HybridSwitched,
        "hybrid switched IBVS/PBVS on each other's Lyapunov function (Gans & Hutchinson 2007)",
    ),
)
