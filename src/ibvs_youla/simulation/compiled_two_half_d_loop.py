"""The compiled frame path of 2.5-D visual servoing on its pose route: PBVS's loop with the 2.5-D law.

:class:`CompiledTwoHalfDLoop` is :class:`~.compiled_pbvs_loop.CompiledPBVSLoop` (the sensor's
kernel, the controller's own pose estimate in Python, its stops and declines) with the law of
:class:`~ibvs_youla.controllers.two_half_d.TwoHalfD` for ``rotation_from="pose"``: one compiled
call does the law (:func:`~ibvs_youla.controllers.two_half_d_kernels.pose_route_twist`, the very
kernel the controller's update calls, so the same floats), the sample (the twist and
``servo_error``, e = (x - x*, y - y*, log rho, theta u)) and the plant's step. The homography route
(OpenCV's ``decomposeHomographyMat`` and its choice of solution at every frame) takes the plug-in
loop.

Where the update computes in numpy instead (the reference point behind the camera, which raises;
a rotation whose theta u is scipy's), the kernel declines and the plug-in loop runs the case from
the start. The run equals the plug-in loop's to rounding (``tests/test_compiled_two_half_d.py``:
1e-12; 1e-7 where SQPnP is in the loop, :mod:`.compiled_loop` says why).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..controllers.two_half_d import TwoHalfD
from .compiled_pbvs_loop import CompiledPBVSLoop
from .pose_frame_kernels import two_half_d_free_camera_step, two_half_d_kinematic_tick

__all__ = ["CompiledTwoHalfDLoop"]


class CompiledTwoHalfDLoop(CompiledPBVSLoop):
    """One run of 2.5-D VS (pose route) on an ideal plant in compiled frame calls (module docstring)."""

    controller_type = TwoHalfD

    @classmethod
    def covers_controller(cls, controller: Any) -> bool:
        """A ``TwoHalfD`` (not a subclass) on its pose route."""
        return type(controller) is TwoHalfD and controller.rotation_from == "pose"

    def prepare_law(self, chain: list[Any]) -> None:
        """PBVS's data (the parameters, the estimator, e), and the 2.5-D law's constants."""
        super().prepare_law(chain)
        T_target_O, reference_O, law = self.controller.pose_route_law()
        self.T_target_O = np.ascontiguousarray(T_target_O, dtype=float)
        self.reference_O = np.ascontiguousarray(reference_O, dtype=float)
        self.two_half_d_law = np.ascontiguousarray(law, dtype=float)

    def camera_frame(
        self, k: int, T_O_C: np.ndarray, frame: np.ndarray, table: np.ndarray, row: int, frames: np.ndarray
    ) -> int:
        """The compiled call of frame k on the free camera: the law, the sample, the step (the next row)."""
        return two_half_d_free_camera_step(  # type: ignore[no-any-return]
            k, T_O_C, self.T_O_C_estimate, self.T_target_O, self.reference_O, self.two_half_d_law, self.m,
            self.markers_O.shape[0], self.params, frame, self.twist, self.error, table, row,
            self.recorder.row_sizes, frames,
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
        return two_half_d_kinematic_tick(  # type: ignore[no-any-return]
            k, is_frame, T_O_C, J_C, state, self.T_O_C_estimate, self.T_target_O, self.reference_O,
            self.two_half_d_law, self.m, self.markers_O.shape[0], self.params, frame, self.twist, self.error,
            table, row, self.recorder.row_sizes, frames, k // self.ticks_per_frame,
        )  # fmt: skip
