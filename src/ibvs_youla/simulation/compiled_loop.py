"""The compiled frame path: a library law's servo loop on an ideal plant, one compiled call per frame.

:func:`~ibvs_youla.simulate` builds the four roles of :mod:`.loop` for every run. When each of them
is the library's own and one the kernels of :mod:`.frame_kernels` cover, it runs
:class:`CompiledLoop` instead of the plug-in :class:`~.loop.ServoLoop` (``simulate(...,
loop="plug-in")`` keeps the plug-in loop):

* the controller: a :class:`~ibvs_youla.controllers.ibvs.ClassicalIBVS` (``ibvs-current``,
  ``ibvs-desired``, ``ibvs-mean``; a constant or adaptive gain), not a subclass nor a wrapper;
  or a :class:`~ibvs_youla.controllers.pbvs.PBVS`, whose law
  :class:`~.compiled_pbvs_loop.CompiledPBVSLoop` runs in this loop (its pose from the controller's
  own estimator, then one compiled call: :mod:`.compiled_pbvs_loop`);
  or a :class:`~ibvs_youla.controllers.two_half_d.TwoHalfD` on its pose route, PBVS's loop with
  the 2.5-D law (:mod:`.compiled_two_half_d_loop`);
  or a :class:`~ibvs_youla.controllers.hybrid.HybridSwitched`, both laws and the switch in one
  compiled call after the same estimator (:mod:`.compiled_hybrid_loop`);
  or a :class:`~ibvs_youla.controllers.polar.PolarIBVS`, this loop's depths with the law on polar
  features (:mod:`.compiled_polar_loop`);
* the sensor: the ideal :class:`~.sensor.MarkerSensor`, with or without depth, not wrapped by a
  disturbance (noise, dropouts, latency, images);
* the plant: the free camera (:class:`~.free_camera.FreeCameraPlant`), or the kinematic arm
  (:class:`~.kinematic_arm.KinematicArmPlant`) following the joint velocities of
  :class:`~.actuation.TwistToJointVelocity`, any number of joints, either mounting: eye-to-hand
  the arm's kinematics are those of :class:`~ibvs_youla.model.eye_to_hand.EyeToHandArm` (the fixed
  camera's pose in the markers' carrier frame and J_rel), which the kernels take as they take
  the eye-in-hand camera pose and J_C (``tests/test_eye_to_hand_servo.py``: equal to the plug-in
  loop).

Beliefs (the controller's camera and markers) and calibration disturbances, which change models and
not roles, are covered. The depths of L come from the depth sensor (``sensor="depth"``) or the
stereo camera's triangulation, or are not needed (``ibvs-desired``); a monocular law at the current
features without measured depths takes them from the controller's own pose estimate, as its update
does: its ``CameraPoseEstimator`` (OpenCV's PnP, SQPnP by default) is called between two compiled
calls, the sensor and the rest of the frame, and the believed markers' depths in that pose
(:meth:`~ibvs_youla.estimation.monocular_pose.CameraPoseEstimator.write_marker_depths`: OpenCV's
PnP, then the depths from its (rvec, tvec) in one compiled call) are written into the frame. Per frame
the free camera is one compiled call (two around the pose); a tick of the kinematic arm is
Pinocchio's camera pose and J_C (the arm's kinematics) and one compiled call.

It gives the plug-in loop's result to rounding (``tests/test_compiled_frame_path.py`` and, for
PBVS, ``tests/test_compiled_pbvs.py``, for 2.5-D ``tests/test_compiled_two_half_d.py``, for the
hybrid law ``tests/test_compiled_hybrid.py``, for polar IBVS ``tests/test_compiled_polar.py``: 1e-12
on every method x plant x camera covered), with
``metadata["loop"] = "compiled"``, except where SQPnP is in the loop (the depths from the PnP pose,
or a monocular pose): SQPnP stops its iterations at a step of ~1e-5 (``||delta||^2 <=
1e-10``), so a last-bit difference of the features can move its pose by up to ~1e-8 of its scale,
and the run then equals the plug-in loop's to that tolerance (the test: 1e-7; measured 4e-9 on the
twist). A batch of classical IBVS runs (:mod:`.batch_loop`) makes the same calls in the same order,
so its cases equal these runs to the bit. Where the plug-in loop stops early, the run stops at the
same tick with its status and reason: a marker the true camera lost (the kernel rejects a depth or
a disparity, and the sensor, measuring the same pose, gives the error the plug-in loop reports), a
pose the controller cannot estimate. Where it would raise (a diverging plant, an invalid command)
or where the sensor measures after all a frame the kernel rejected (a depth at the edge of
rounding), a kernel declines and the run is made again by the plug-in loop from the start, which
gives its status or error.

What differs: ``metadata["phase_seconds"]`` has the whole loop in
``frame`` (the phases are one call), ``update_time`` is each frame's compiled call (the sensor,
the law, the recording and the plant step, not the law alone), and the controller object is reset
but not stepped (its ``update`` is not called; its last twist is not kept; the pose-based laws'
estimator is called, as their update would).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from ..controllers.base import CommandType
from ..controllers.ibvs import INTERACTIONS, PINV_THRESHOLD, AdaptiveGain, ClassicalIBVS
from ..exceptions import InvalidDisparityError, PointBehindCameraError, PoseEstimationError
from ..model.camera import PinholeCamera
from ..model.camera_kernels import camera_parameters
from .actuation import TwistToJointVelocity
from .frame_kernels import (
    DEPTH_MEASURED,
    DEPTH_TRIANGULATED,
    free_camera_step,
    kinematic_tick,
    measure,
    pack_parameters,
)
from .free_camera import FreeCameraPlant
from .kinematic_arm import KinematicArmPlant
from .loop import estimate_failed_reason
from .recorder import ResultRecorder
from .results import SimulationResult
from .sensor import MarkerSensor

__all__ = ["CompiledLoop"]

_FREE_SIGNALS = ("camera_twist", "ibvs_gain")
_ARM_SIGNALS = ("q", "q_true", "dq", "camera_twist", "dq_ref", "ibvs_gain")


class CompiledLoop:
    """One run of classical IBVS on an ideal plant in compiled frame calls (module docstring).

    Build it with :meth:`covering`, which returns None for roles it does not cover. The loop over
    frames and ticks is any law's; a law is its controller type, its recorded signals and the
    methods a subclass overrides (:class:`~.compiled_pbvs_loop.CompiledPBVSLoop`,
    :class:`~.compiled_hybrid_loop.CompiledHybridLoop`):
    :meth:`prepare_law` (its packed data), :meth:`law_inputs` (what it takes from Python between
    the sensor and its compiled call) and that call, :meth:`camera_frame` (the free camera) and
    :meth:`arm_tick` (the kinematic arm). A law that stops the run sets :attr:`stop_status`.
    """

    controller_type: type = ClassicalIBVS
    free_signals: tuple[str, ...] = _FREE_SIGNALS  # the recorder's signals on the free camera
    arm_signals: tuple[str, ...] = _ARM_SIGNALS  # ... and on the kinematic arm

    def __init__(
        self,
        controller: Any,
        sensor: MarkerSensor,
        plant: Any,
        chain: list[Any],
        dt: float,
        n_ticks: int,
        ticks_per_frame: int,
        record_every: int,
        recorder: ResultRecorder,
    ) -> None:
        self.controller, self.sensor = controller, sensor
        self.plant, self.recorder, self.n_ticks, self.dt = plant, recorder, n_ticks, dt
        self.ticks_per_frame, self.record_every = ticks_per_frame, record_every
        self.markers_O = np.ascontiguousarray(sensor.markers_O, dtype=float)
        self.m = np.asarray(controller.task.feature_target).shape[0]  # features per frame
        self.model_arm = chain[0].arm if chain else None
        self.twist = np.zeros(6)  # the law's last twist [m/s, rad/s], held between frames
        self.prepare_law(chain)

    def packed_parameters(self, chain: list[Any], **law: Any) -> np.ndarray:
        """The kernels' parameters (:func:`~.frame_kernels.pack_parameters`) with the law's settings."""
        task, sensor = self.controller.task, self.sensor
        policy = chain[0].policy if chain else None
        return pack_parameters(
            camera_parameters(sensor.camera),
            camera_parameters(task.camera),
            dt=self.dt,
            virtual_points=bool(task.virtual_points),
            measure_depth=sensor.measures_depth,
            record_every=self.record_every,
            n_ticks=self.n_ticks,
            joint_policy=(True, 0.0) if policy is None else (policy.kind == "damped", policy.threshold),
            **law,
        )

    def prepare_law(self, chain: list[Any]) -> None:
        """Classical IBVS's data: its parameters, the law's table (target, L*, L*^+) and gain."""
        controller, sensor = self.controller, self.sensor
        task = controller.task
        gain = controller.gain
        if isinstance(gain, AdaptiveGain):
            gain_ = (gain.lambda_0, gain.lambda_inf, gain.lambda_dot_0, True)
        else:
            gain_ = (float(gain), float(gain), 0.0, False)
        # the depths of L (ibvs-desired needs none): measured, triangulated (stereo), or the believed
        # markers' depths in the pose the controller estimates, written into the frame before its law
        pose = isinstance(task.camera, PinholeCamera) and not sensor.measures_depth
        estimates = pose and controller.interaction != "desired"
        self.pose_estimator = controller.pose_estimator if estimates else None
        depth_from = DEPTH_MEASURED if sensor.measures_depth or pose else DEPTH_TRIANGULATED
        interaction = INTERACTIONS.index(controller.interaction)
        self.params = self.packed_parameters(
            chain, gain=gain_, pinv_threshold=PINV_THRESHOLD, interaction=interaction, depth_from=depth_from
        )
        target = np.asarray(task.feature_target, dtype=float)
        self.law = np.zeros((self.m, 13))
        self.law[:, 0] = target
        if controller.desired_interaction_matrix is not None:
            self.law[:, 1:7] = controller.desired_interaction_matrix
            self.law[:, 7:13] = controller.desired_pseudo_inverse.T
        self.gain = np.zeros(1)  # the law's lambda [1/s] of the last frame (the signal ibvs_gain)

    @classmethod
    def covers_controller(cls, controller: Any) -> bool:
        """True when this loop runs the controller's law: exactly its type (a subclass may differ)."""
        return type(controller) is cls.controller_type

    @classmethod
    def covering(
        cls,
        controller: Any,
        sensor: Any,
        plant: Any,
        chain: list[Any],
        dt: float,
        n_ticks: int,
        ticks_per_frame: int,
        record_every: int,
        recorder: ResultRecorder,
    ) -> CompiledLoop | None:
        """The compiled loop of these roles, or None when one is not covered (module docstring)."""
        if not cls.covers_controller(controller) or type(sensor) is not MarkerSensor:
            return None
        if type(plant) is FreeCameraPlant and not chain:
            expected = cls.free_signals
        elif (
            type(plant) is KinematicArmPlant
            and len(chain) == 1
            and type(chain[0]) is TwistToJointVelocity
            and chain[0].secondary_task is None  # the null-space task: the plug-in loop
            and plant.input_type is CommandType.JOINT_VELOCITY
        ):
            expected = cls.arm_signals
        else:
            return None
        if recorder.signal_names != expected or sensor.n_points != controller.task.n_points:
            return None
        return cls(controller, sensor, plant, chain, dt, n_ticks, ticks_per_frame, record_every, recorder)

    def run(self, progress: bool = False, label: str = "simulate") -> SimulationResult | None:
        """The run's result, or None when a kernel declined (the caller runs the plug-in loop)."""
        n, m = self.markers_O.shape[0], self.m
        n_frames = self.n_ticks // self.ticks_per_frame + 1
        n_rows = self.n_ticks // self.record_every + 2
        recorder = self.recorder
        table, row0 = recorder.reserve(n_rows), len(recorder)
        frames = np.zeros((n_frames, 2 + m + n))  # [t, features, visible, update time]
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=self.n_ticks, unit="tick", desc=label, leave=False)
        t0 = time.perf_counter()
        self._progress = (row0, 0)  # (next table row, frames logged) so far
        self.stop_status = ("complete", "")  # the status and reason of a run that stops early
        try:
            with np.errstate(all="ignore"):
                if type(self.plant) is FreeCameraPlant:
                    declined = self._free_camera(table, row0, frames, bar)
                else:
                    declined = self._kinematic(table, row0, frames, bar)
        except KeyboardInterrupt as err:  # Ctrl-C: keep what was recorded, as the plug-in loop does
            self.stop_status = ("interrupted", "interrupted")
            row, done = self._progress
            err.partial = self._result(row0, row, frames[:done], t0)  # type: ignore[attr-defined]
            raise
        finally:
            if bar is not None:
                bar.close()
        if declined:
            return None
        row, done = self._progress
        return self._result(row0, row, frames[:done], t0)

    def _result(self, row0: int, row: int, frames: np.ndarray, t0: float) -> SimulationResult:
        recorder, m, n = self.recorder, self.m, self.markers_O.shape[0]
        recorder.advance(row - row0)
        recorder.record_frames(
            frames[:, 0], frames[:, 1 : 1 + m], frames[:, 1 + m : 1 + m + n] != 0.0, frames[:, -1]
        )
        seconds = time.perf_counter() - t0
        status, reason = self.stop_status
        extra: dict[str, Any] = {"phase_seconds": {"frame": seconds, "control": 0.0, "plant": 0.0}}
        if status != "complete":
            extra["error"] = reason
        return recorder.result(status=status, extra_metadata=extra)

    def lost_marker(self, T_O_C: np.ndarray, t: float) -> str | None:
        """Why the true camera lost a marker at pose T_O_C (time t [s]), as the plug-in loop says it.

        The sensor kernel rejected a depth or a disparity; the sensor itself, measuring the same pose,
        raises the error whose message the plug-in loop reports. None when it measures the frame (a
        depth at the edge of rounding): the plug-in loop decides then.
        """
        try:
            self.sensor.measure(T_O_C.copy(), t)
        except (PointBehindCameraError, InvalidDisparityError) as err:
            return f"t = {t:.6g} s: the true camera lost a marker: {err}"
        return None

    def frame_depths(self, frame: np.ndarray, t: float) -> str | None:
        """The depths of L from the controller's pose estimate, into ``frame``; the reason if it failed.

        As the plug-in loop reports a failed estimate (status ``"estimate_failed"``).
        """
        m, n = self.m, self.markers_O.shape[0]
        try:
            self.pose_estimator.write_marker_depths(frame[:m], frame[m + n :])  # type: ignore[union-attr]
        except PoseEstimationError as err:
            return estimate_failed_reason(self.controller, t, err)
        return None

    def _measured(self, T_O_C: np.ndarray, frame: np.ndarray, k: int) -> bool | None:
        """Frame k into ``frame`` (features, visibility, the depths of L).

        True; False when the run stops (:attr:`stop_status` says why); None when the plug-in loop decides.
        """
        t = k * self.dt
        if not measure(T_O_C, self.markers_O, self.params, frame):
            reason = self.lost_marker(T_O_C, t)
            if reason is None:
                return None
            self.stop_status = ("markers_lost", reason)
            return False
        return self.law_inputs(frame, t)

    def law_inputs(self, frame: np.ndarray, t: float) -> bool | None:
        """What the law takes from Python after the sensor: the depths of L from the pose estimate.

        Tri-state as :meth:`_measured` (a failed estimate stops the run).
        """
        if self.pose_estimator is not None:
            reason = self.frame_depths(frame, t)
            if reason is not None:
                self.stop_status = ("estimate_failed", reason)
                return False
        return True

    def camera_frame(
        self, k: int, T_O_C: np.ndarray, frame: np.ndarray, table: np.ndarray, row: int, frames: np.ndarray
    ) -> int:
        """The compiled call of frame k on the free camera: the law, the sample, the step (the next row)."""
        n = self.markers_O.shape[0]
        return free_camera_step(  # type: ignore[no-any-return]
            k, T_O_C, n, self.law, self.params, frame, self.twist, self.gain, table, row,
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
        return kinematic_tick(  # type: ignore[no-any-return]
            k, is_frame, True, T_O_C, J_C, state, self.markers_O, self.law, self.params, frame, self.twist,
            self.gain, table, row, self.recorder.row_sizes, frames, k // self.ticks_per_frame,
        )  # fmt: skip

    def _free_camera(self, table: np.ndarray, row: int, frames: np.ndarray, bar: Any) -> bool:
        """The run on the free camera; True when a kernel declined."""
        n, m = self.markers_O.shape[0], self.m
        T = self.plant.camera_pose()
        frame = np.zeros(m + 2 * n)
        clock = time.perf_counter
        for k in range(self.n_ticks + 1):
            tic = clock()
            measured = self._measured(T, frame, k)
            if not measured:
                return measured is None
            row = self.camera_frame(k, T, frame, table, row, frames)
            if row < 0:
                return True
            frames[k, -1] = clock() - tic
            self._progress = (row, k + 1)
            if bar is not None and k % 1000 == 0 and k:
                bar.update(1000)
        return False

    def _kinematic(self, table: np.ndarray, row: int, frames: np.ndarray, bar: Any) -> bool:
        """The run on the kinematic arm; True when a kernel declined."""
        n, m = self.markers_O.shape[0], self.m
        plant, arm = self.plant, self.model_arm
        reading = plant.reading()
        q_encoder, q_true, dq = plant.signal_values(reading)
        state = np.array([q_true, q_encoder, dq, plant.joint_offset], dtype=float)  # (4, n_joints)
        frame = np.zeros(m + 2 * n)
        clock = time.perf_counter
        camera_fk, jacobian = plant.arm.camera_fk, arm.camera_jacobian_at  # type: ignore[union-attr]
        every, record_every, last = self.ticks_per_frame, self.record_every, self.n_ticks
        T = np.eye(4)
        for k in range(last + 1):
            tic = clock()
            is_frame = k % every == 0
            if is_frame or k % record_every == 0 or k == last:
                T = camera_fk(state[0])
            if is_frame:
                measured = self._measured(T, frame, k)
                if not measured:
                    return measured is None
            row = self.arm_tick(k, is_frame, T, jacobian(state[1]), state, frame, table, row, frames)
            if row < 0:
                return True
            if is_frame:
                frames[k // every, -1] = clock() - tic
            self._progress = (row, k // every + 1)
            if bar is not None and k % 1000 == 0 and k:
                bar.update(1000)
        return False
