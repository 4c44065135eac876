"""The compiled frame path of the hybrid switched law: the pose in Python, both laws and the switch compiled.

:class:`CompiledHybridLoop` is :class:`~.compiled_loop.CompiledLoop` (its roles, its loop over
frames and ticks, its stops and declines) with the law of
:class:`~ibvs_youla.controllers.hybrid.HybridSwitched` (Gans & Hutchinson 2007: classical IBVS and
PBVS on every frame, switched on each other's Lyapunov function). :func:`~ibvs_youla.simulate` runs
it when the controller is a ``HybridSwitched`` (not a subclass nor a wrapper), the sensor the ideal
:class:`~.sensor.MarkerSensor` (with or without depth) and the plant the free camera or the
kinematic arm following :class:`~.actuation.TwistToJointVelocity`, as for classical IBVS and PBVS.
Per frame:

1. the sensor's kernel (:func:`~.frame_kernels.measure`), from the true camera pose;
2. in Python, what both laws take from the controller's one pose estimator, called as its update
   calls it: on a monocular camera without measured depths, first the IBVS law's depths
   (``pose_estimator.marker_depths(features)``: OpenCV's PnP, SQPnP by default or IPPE), written
   into the frame, then PBVS's pose ``pose_estimator(features)``, which takes the PnP of the same
   features from the estimator's cache (one PnP per frame, as in the plug-in loop, and the same
   floats); with a depth sensor or a stereo camera, the pose alone (Kabsch on the measured depths,
   stereo P3P), IBVS's depths being the sensor's or triangulated in the compiled call;
3. one compiled call (:mod:`.hybrid_frame_kernels`): both laws, V_i and V_p, the bounds at the first
   frame, the dwell and the switch, the active law's twist, the sample (the twist, ``hybrid_mode``
   and ``hybrid_switches``) and the plant's step.

The mode, the switch count, the dwell and the bounds live in the loop's own array (the controller
object is reset but not stepped, as for the other laws). It gives the plug-in loop's result to
rounding (``tests/test_compiled_hybrid.py``: 1e-12, switching runs and ``start_mode="pbvs"``
included), with ``metadata["loop"] = "compiled"``, except where SQPnP is in the loop (a monocular
camera without measured depths, the default ``pnp``): its stopping tolerance bounds the agreement
(1e-7; :mod:`.compiled_loop` says why). An estimate that fails on a monocular camera stops the run as
the plug-in loop's update would (status ``"estimate_failed"``, its reason); where IBVS's depths are
not the estimator's (stereo, a depth sensor), the plug-in loop's update would meet IBVS's own errors
first, so a failed pose declines to it, as does any other error of the estimator.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._geometry import inverse_pose
from ..controllers.hybrid import MODES, HybridSwitched
from ..controllers.ibvs import INTERACTIONS, PINV_THRESHOLD
from ..model.camera import PinholeCamera
from .compiled_loop import CompiledLoop
from .frame_kernels import DEPTH_MEASURED, DEPTH_TRIANGULATED
from .hybrid_frame_kernels import hybrid_free_camera_step, hybrid_kinematic_tick
from .loop import ESTIMATE_ERRORS, estimate_failed_reason

__all__ = ["CompiledHybridLoop"]

_SIGNALS = ("hybrid_mode", "hybrid_switches")


class CompiledHybridLoop(CompiledLoop):
    """One run of the hybrid switched law on an ideal plant in compiled frame calls (module docstring).

    Build it with :meth:`~.compiled_loop.CompiledLoop.covering`, which returns None for roles it
    does not cover.
    """

    controller_type = HybridSwitched
    free_signals = ("camera_twist", *_SIGNALS)
    arm_signals = ("q", "q_true", "dq", "camera_twist", "dq_ref", *_SIGNALS)

    def prepare_law(self, chain: list[Any]) -> None:
        """Both laws' data: IBVS's parameters and target, c*T_O, the settings and state of the switch."""
        hybrid, sensor = self.controller, self.sensor
        task, ibvs = hybrid.task, hybrid.ibvs
        # IBVS's depths: measured, triangulated (stereo), or from the pose estimate (written into the frame)
        self.monocular = isinstance(task.camera, PinholeCamera) and not sensor.measures_depth
        depth_from = DEPTH_MEASURED if sensor.measures_depth or self.monocular else DEPTH_TRIANGULATED
        lam = float(ibvs.gain)  # a number: the hybrid law takes no adaptive gain (PBVS refuses it)
        self.params = self.packed_parameters(
            chain,
            gain=(lam, lam, 0.0, False),
            pinv_threshold=PINV_THRESHOLD,
            interaction=INTERACTIONS.index(ibvs.interaction),
            depth_from=depth_from,
        )
        self.law = np.zeros((self.m, 13))
        self.law[:, 0] = np.asarray(task.feature_target, dtype=float)
        self.pose_estimator = hybrid.pose_estimator
        self.T_target_O = inverse_pose(np.asarray(task.T_O_C_target, dtype=float))  # c*T_O
        self.T_O_C_estimate = np.eye(4)  # the controller's estimate of the frame's pose
        self.error = np.zeros(6)  # PBVS's e = (c*t_c [m], theta u [rad])
        # (lambda of PBVS [1/s], F of the believed camera, margin, min_dwell [frames])
        F = float(task.camera.focal_length)
        self.settings = np.array([float(hybrid.pbvs.gain), F, hybrid.margin, float(hybrid.min_dwell)])
        # (mode, switches, frames in the mode, gamma_i, gamma_p): the first two are the recorded signals
        self.state = np.array([float(MODES.index(hybrid.start_mode)), 0.0, 0.0, 0.0, 0.0])
        sizes = self.recorder.row_sizes  # ..., camera_twist, hybrid_mode (1), hybrid_switches (1)
        self.sizes = np.concatenate((sizes[:-2], sizes[-2:].sum(keepdims=True)))  # the last two as one part

    def law_inputs(self, frame: np.ndarray, t: float) -> bool | None:
        """IBVS's depths (monocular) and PBVS's pose, as the update asks them; False: stop, None: decline."""
        m, n = self.m, self.markers_O.shape[0]
        features = frame[:m].copy()
        depth = frame[m + n :].copy() if self.sensor.measures_depth else None
        try:
            if self.monocular:  # IBVS's update first (its PnP, kept), then PBVS's (the same PnP)
                frame[m + n :] = self.pose_estimator.marker_depths(features)
            T_O_C = self.pose_estimator(features, depth)
        except ESTIMATE_ERRORS as err:
            if not self.monocular:  # IBVS's own errors come first in the plug-in loop: it decides
                return None
            self.stop_status = ("estimate_failed", estimate_failed_reason(self.controller, t, err))
            return False
        except Exception:  # the plug-in loop raises it as the controller's error
            return None
        self.T_O_C_estimate = np.ascontiguousarray(T_O_C, dtype=float)
        return True

    def camera_frame(
        self, k: int, T_O_C: np.ndarray, frame: np.ndarray, table: np.ndarray, row: int, frames: np.ndarray
    ) -> int:
        """The compiled call of frame k on the free camera: both laws, the switch, the sample, the step."""
        return hybrid_free_camera_step(  # type: ignore[no-any-return]
            k, T_O_C, self.T_O_C_estimate, self.T_target_O, self.settings, self.markers_O.shape[0],
            self.law, self.params, frame, self.twist, self.error, self.state, table, row, self.sizes, frames,
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
        """The compiled call of tick k on the kinematic arm: on a frame both laws and the switch; the tick."""
        return hybrid_kinematic_tick(  # type: ignore[no-any-return]
            k, is_frame, T_O_C, J_C, state, self.T_O_C_estimate, self.T_target_O, self.settings,
            self.markers_O.shape[0], self.law, self.params, frame, self.twist, self.error, self.state,
            table, row, self.sizes, frames, k // self.ticks_per_frame,
        )  # fmt: skip
