"""The compiled frame path of PBVS: the pose from the controller's estimator, the rest one compiled call.

:class:`CompiledPBVSLoop` is :class:`~.compiled_loop.CompiledLoop` (its roles, its loop over frames
and ticks, its stops and declines) with the law of :class:`~ibvs_youla.controllers.pbvs.PBVS`.
:func:`~ibvs_youla.simulate` runs it when the controller is a ``PBVS`` (not a subclass nor a
wrapper), the sensor the ideal :class:`~.sensor.MarkerSensor` (with or without depth) and the plant
the free camera or the kinematic arm following :class:`~.actuation.TwistToJointVelocity`, as for
classical IBVS. Per frame:

1. the sensor's kernel (:func:`~.frame_kernels.measure`), from the true camera pose;
2. in Python, the controller's own pose estimate ``controller.pose_estimator(features, depth)``,
   with the frame's features and, from a depth sensor, its depths, as its update calls it: the
   same ``CameraPoseEstimator`` (OpenCV's PnP on a monocular camera, SQPnP by default or IPPE;
   stereo P3P; Kabsch on measured depths), so the same pose, and its IPPE fallbacks counted as in
   the plug-in loop (``metadata["pnp_fallbacks"]``);
3. one compiled call (:mod:`.pose_frame_kernels`): the law at that pose, the sample (the twist and
   ``servo_error``) and the plant's step (exp6 on the free camera; on the arm, every tick, the
   joint velocities of the twist held).

It gives the plug-in loop's result to rounding (``tests/test_compiled_pbvs.py``: 1e-12), with
``metadata["loop"] = "compiled"``, except where SQPnP is in the loop (a monocular camera without
measured depths, the default ``pnp``): its stopping tolerance bounds the agreement (1e-7;
:mod:`.compiled_loop` says why). Nor does any loop that differs from the plug-in one in the last
bits agree with it where the pose itself is ill-conditioned: four coplanar markers small in the
image (a 20 cm square 2.8 m from a ZED 2 lens on the kinematic arm, ``pnp="ippe"``) give IPPE two
poses of nearly equal error, and which one it returns flips with the last bits of the features;
there the plug-in loop's run moved by 9e-4 rad/s (dq; measured) when its sensor's features were nudged by one
ulp, and the compiled run differs from it by as much.

An estimate that fails as the plug-in loop's update would stop the run
(:data:`~.loop.ESTIMATE_ERRORS`: status ``"estimate_failed"``, the plug-in loop's reason); any
other error of the estimator, a rotation whose theta u is scipy's to compute or a non-finite twist
declines, and the plug-in loop runs the case from the start.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._geometry import inverse_pose
from ..controllers.pbvs import PBVS
from .compiled_loop import CompiledLoop
from .frame_kernels import DEPTH_MEASURED
from .loop import ESTIMATE_ERRORS, estimate_failed_reason
from .pose_frame_kernels import pbvs_free_camera_step, pbvs_kinematic_tick

__all__ = ["CompiledPBVSLoop"]


class CompiledPBVSLoop(CompiledLoop):
    """One run of PBVS on an ideal plant in compiled frame calls (module docstring).

    Build it with :meth:`~.compiled_loop.CompiledLoop.covering`, which returns None for roles it
    does not cover.
    """

    controller_type = PBVS
    free_signals = ("camera_twist", "servo_error")
    arm_signals = ("q", "q_true", "dq", "camera_twist", "dq_ref", "servo_error")

    def prepare_law(self, chain: list[Any]) -> None:
        """PBVS's data: the parameters (no gain schedule, no interaction), c*T_O, lambda, e."""
        controller = self.controller
        self.params = self.packed_parameters(
            chain, gain=(0.0, 0.0, 0.0, False), pinv_threshold=0.0, interaction=0, depth_from=DEPTH_MEASURED
        )
        self.T_target_O = inverse_pose(np.asarray(controller.task.T_O_C_target, dtype=float))  # c*T_O
        self.lambda_ = float(controller.gain)  # PBVS's lambda [1/s] (the base's gain is IBVS's signal array)
        self.pose_estimator = controller.pose_estimator
        self.T_O_C_estimate = np.eye(4)  # the controller's estimate of the frame's pose
        self.error = np.zeros(6)  # e = (c*t_c [m], theta u [rad]): the signal servo_error

    def law_inputs(self, frame: np.ndarray, t: float) -> bool | None:
        """The controller's pose estimate of the frame; False: it failed (the run stops), None: decline."""
        m, n = self.m, self.markers_O.shape[0]
        depth = frame[m + n :].copy() if self.sensor.measures_depth else None
        try:
            T_O_C = self.pose_estimator(frame[:m].copy(), depth)
        except ESTIMATE_ERRORS as err:  # as the plug-in loop reports the failed update
            self.stop_status = ("estimate_failed", estimate_failed_reason(self.controller, t, err))
            return False
        except Exception:  # the plug-in loop raises it as the controller's error
            return None
        self.T_O_C_estimate = np.ascontiguousarray(T_O_C, dtype=float)
        return True

    def camera_frame(
        self, k: int, T_O_C: np.ndarray, frame: np.ndarray, table: np.ndarray, row: int, frames: np.ndarray
    ) -> int:
        """The compiled call of frame k on the free camera: the law, the sample, the step (the next row)."""
        return pbvs_free_camera_step(  # type: ignore[no-any-return]
            k, T_O_C, self.T_O_C_estimate, self.T_target_O, self.lambda_, self.m, self.markers_O.shape[0],
            self.params, frame, self.twist, self.error, table, row, self.recorder.row_sizes, frames,
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
        return pbvs_kinematic_tick(  # type: ignore[no-any-return]
            k, is_frame, T_O_C, J_C, state, self.T_O_C_estimate, self.T_target_O, self.lambda_, self.m,
            self.markers_O.shape[0], self.params, frame, self.twist, self.error, table, row,
            self.recorder.row_sizes, frames, k // self.ticks_per_frame,
        )  # fmt: skip
