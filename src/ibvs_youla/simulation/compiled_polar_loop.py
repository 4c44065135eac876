"""The compiled frame path of polar IBVS: classical IBVS's loop with the law on (r, phi) features.

:class:`CompiledPolarLoop` is :class:`~.compiled_loop.CompiledLoop` (its roles, its loop over frames
and ticks, its stops and declines, and the depths of L: measured, triangulated, or the believed
markers' depths in the controller's own pose estimate, written into the frame in Python) with the
law of :class:`~ibvs_youla.controllers.polar.PolarIBVS` (``"ibvs-polar"``): one compiled call per
frame (:mod:`.polar_frame_kernels`) does the law, the sample (the twist alone: the law records no
other signal) and the plant's step. :func:`~ibvs_youla.simulate` runs it when the controller is a
``PolarIBVS`` (not a subclass nor a wrapper), the sensor the ideal :class:`~.sensor.MarkerSensor`
(with or without depth) and the plant the free camera or the kinematic arm following
:class:`~.actuation.TwistToJointVelocity`, as for classical IBVS.

The run equals the plug-in loop's to rounding (``tests/test_compiled_polar.py``: 1e-12; 1e-7 where
SQPnP is in the loop, :mod:`.compiled_loop` says why). Where the update would raise (a point at the
principal point, a rejected depth or disparity, a failed SVD) or give a non-finite twist, and where
a phi error lies on the wrap's cut (within 1e-9 rad of +-pi: which side it wraps to is the rounding
of numpy's arctan2, :mod:`.polar_frame_kernels`), the kernel declines and the plug-in loop runs the
case from the start.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..controllers.ibvs import PINV_THRESHOLD
from ..controllers.polar import WRAPS, PolarIBVS
from ..model.camera import PinholeCamera
from .compiled_loop import CompiledLoop
from .frame_kernels import DEPTH_MEASURED, DEPTH_TRIANGULATED
from .polar_frame_kernels import polar_free_camera_step, polar_kinematic_tick

__all__ = ["CompiledPolarLoop"]


class CompiledPolarLoop(CompiledLoop):
    """One run of polar IBVS on an ideal plant in compiled frame calls (module docstring).

    Build it with :meth:`~.compiled_loop.CompiledLoop.covering`, which returns None for roles it
    does not cover.
    """

    controller_type = PolarIBVS
    free_signals = ("camera_twist",)
    arm_signals = ("q", "q_true", "dq", "camera_twist", "dq_ref")

    def prepare_law(self, chain: list[Any]) -> None:
        """The parameters, the depths' source and estimator, s*, and (lambda, wrap, F, rows)."""
        controller, sensor = self.controller, self.sensor
        task = controller.task
        monocular = isinstance(task.camera, PinholeCamera) and not sensor.measures_depth
        self.pose_estimator = controller.pose_estimator if monocular else None
        depth_from = DEPTH_MEASURED if sensor.measures_depth or monocular else DEPTH_TRIANGULATED
        self.params = self.packed_parameters(
            chain,
            gain=(0.0, 0.0, 0.0, False),  # the law's lambda is in its settings
            pinv_threshold=PINV_THRESHOLD,
            interaction=0,
            depth_from=depth_from,
        )
        self.law = np.ascontiguousarray(controller.feature_target, dtype=float)  # s* (polar)
        rows = 2 if isinstance(task.camera, PinholeCamera) else 3
        F = float(task.camera.focal_length)
        self.settings = np.array(
            [float(controller.gain), float(WRAPS.index(controller.wrap)), F, float(rows)]
        )
        self.sizes = np.append(self.recorder.row_sizes, 0)  # the law's own signal: none (an empty part)

    def camera_frame(
        self, k: int, T_O_C: np.ndarray, frame: np.ndarray, table: np.ndarray, row: int, frames: np.ndarray
    ) -> int:
        """The compiled call of frame k on the free camera: the law, the sample, the step (the next row)."""
        return polar_free_camera_step(  # type: ignore[no-any-return]
            k, T_O_C, self.markers_O.shape[0], self.m, self.law, self.settings, self.params, frame,
            self.twist, table, row, self.sizes, frames,
        )  # fmt: skip

    def arm_tick(
        self,
        k: int,
        is_frame: bool,
        T_O_C: np.ndarray,
        J_C: np.ndarray,
        state: np.ndarray,
        frame: np.ndarray,
        table: np.ndarray,
        row: int,
        frames: np.ndarray,
    ) -> int:
        """The compiled call of tick k on the kinematic arm: on a frame the law, then the tick."""
        return polar_kinematic_tick(  # type: ignore[no-any-return]
            k, is_frame, T_O_C, J_C, state, self.markers_O.shape[0], self.m, self.law, self.settings,
            self.params, frame, self.twist, table, row, self.sizes, frames, k // self.ticks_per_frame,
        )  # fmt: skip
