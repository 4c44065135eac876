"""Many runs at once: cases of classical IBVS on an ideal plant, advanced in lockstep in compiled calls.

:func:`~ibvs_youla.simulate_batch` prepares every case as :func:`~ibvs_youla.simulate` does and
takes each case's compiled loop (:class:`~.compiled_loop.CompiledLoop`: its packed camera, law and
markers). :class:`BatchLoop` stacks them and advances every case one frame (the free camera) or one
tick (the kinematic arm) at a time, each step one compiled call over the cases that calls the
per-equation kernels of :mod:`.frame_kernels` on each case's own rows:

1. the sensor, :func:`measure_cases`: every running case's frame from its true camera pose;
2. for a monocular law at the current features without measured depths, the depths of L: the
   controller's own pose estimate (its ``CameraPoseEstimator``, OpenCV's SQPnP, called per case as
   its update calls it) and the believed markers' depths in that pose, written into the frame;
3. the law, the sample and the plant step: :func:`free_camera_steps`, or on the arm
   :func:`kinematic_ticks` after Pinocchio's camera pose and J_C of each case.

Where the plug-in loop would stop or raise, a case stops: a marker its true camera lost (the
case's own sensor is asked for the reason, and gives the plug-in loop's), a pose its controller
cannot estimate (its estimator's error). Anything else a kernel declines (a non-finite command, a
depth the law rejects, a failed SVD), and the case is made again by its plug-in loop from the start
(:func:`~ibvs_youla.simulate_batch` does), which gives its status or error.

A case's arithmetic is its single run's in :class:`~.compiled_loop.CompiledLoop` (the same kernels,
the same estimator, in the same order), so each result equals the case's ``simulate()`` to the bit.
A frame's ``update_time`` is the batch's compiled calls for that frame divided by the cases they
advanced (its share), and ``metadata["phase_seconds"]["frame"]`` the loop's time divided by the cases.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from .._jit import jit
from .compiled_loop import CompiledLoop
from .frame_kernels import free_camera_step, kinematic_tick, measure
from .free_camera import FreeCameraPlant
from .results import SimulationResult

__all__ = [
    "DECLINED",
    "ESTIMATE_FAILED",
    "MARKERS_LOST",
    "RUNNING",
    "BatchLoop",
    "free_camera_steps",
    "kinematic_ticks",
    "measure_cases",
]

RUNNING, DECLINED, MARKERS_LOST, ESTIMATE_FAILED, INTERRUPTED = 0, 1, 2, 3, 4  # a case's state
_LOST = 5  # the sensor kernel rejected a depth: the case's sensor gives the reason (or declines)
_STATUS = {RUNNING: "complete", MARKERS_LOST: "markers_lost", ESTIMATE_FAILED: "estimate_failed"}


@jit
def measure_cases(
    T_O_C: np.ndarray, markers_O: np.ndarray, params: np.ndarray, frame: np.ndarray, state: np.ndarray
) -> None:
    """The frame of every running case (:func:`~.frame_kernels.measure`); a rejected depth marks it lost.

    T_O_C (N, 4, 4), markers_O (N, n, 3), params (N, P), frame (N, m + 2 n), state (N,).
    """
    for c in range(state.shape[0]):
        if state[c] == RUNNING and not measure(T_O_C[c], markers_O[c], params[c], frame[c]):
            state[c] = _LOST


@jit
def free_camera_steps(
    k: int,
    T_O_C: np.ndarray,
    n: int,
    law: np.ndarray,
    params: np.ndarray,
    frame: np.ndarray,
    twist: np.ndarray,
    gain: np.ndarray,
    table: np.ndarray,
    rows: np.ndarray,
    sizes: np.ndarray,
    frames: np.ndarray,
    state: np.ndarray,
) -> None:
    """Frame k of every running case on the free camera after its frame is measured (``free_camera_step``).

    Per case c: its rows of every array (``table[c]`` its samples, ``rows[c]`` the next free one,
    ``frames[c]`` its frame log); a case whose kernel declines is marked DECLINED.
    """
    for c in range(state.shape[0]):
        if state[c] == RUNNING:
            row = free_camera_step(
                k, T_O_C[c], n, law[c], params[c], frame[c], twist[c], gain[c], table[c], rows[c], sizes,
                frames[c],
            )  # fmt: skip
            if row < 0:
                state[c] = DECLINED
            else:
                rows[c] = row


@jit
def kinematic_ticks(
    k: int,
    is_frame: bool,
    T_O_C: np.ndarray,
    J_C: np.ndarray,
    joints: np.ndarray,
    markers_O: np.ndarray,
    law: np.ndarray,
    params: np.ndarray,
    frame: np.ndarray,
    twist: np.ndarray,
    gain: np.ndarray,
    table: np.ndarray,
    rows: np.ndarray,
    sizes: np.ndarray,
    frames: np.ndarray,
    frame_index: int,
    state: np.ndarray,
) -> None:
    """Tick k of every running case on the kinematic arm (``kinematic_tick``, the frame measured already).

    ``joints`` (N, 4, n_joints): each case's true joints, encoders, speeds and offset; J_C (N, 6,
    n_joints) its controller's camera Jacobian at the encoders; T_O_C its true camera pose.
    """
    for c in range(state.shape[0]):
        if state[c] == RUNNING:
            row = kinematic_tick(
                k, is_frame, True, T_O_C[c], J_C[c], joints[c], markers_O[c], law[c], params[c], frame[c],
                twist[c], gain[c], table[c], rows[c], sizes, frames[c], frame_index,
            )  # fmt: skip
            if row < 0:
                state[c] = DECLINED
            else:
                rows[c] = row


class BatchLoop:
    """The cases of :func:`~ibvs_youla.simulate_batch` advanced in lockstep (module docstring).

    Args:
        loops: Each case's compiled loop (``CompiledLoop.covering``), all on
            one plant type with the same number of ticks, frames, samples, features and markers
            (the caller checks).
    """

    def __init__(self, loops: Sequence[CompiledLoop]) -> None:
        first = loops[0]
        self.loops = list(loops)
        self.free_camera = type(first.plant) is FreeCameraPlant
        self.n_ticks, self.dt = first.n_ticks, first.dt
        self.ticks_per_frame, self.record_every = first.ticks_per_frame, first.record_every
        self.sizes = first.recorder.row_sizes
        self.markers_O = np.ascontiguousarray([loop.markers_O for loop in loops])
        self.law = np.ascontiguousarray([loop.law for loop in loops])
        self.params = np.ascontiguousarray([loop.params for loop in loops])
        self.pose_cases = [c for c, loop in enumerate(loops) if loop.pose_estimator is not None]
        if self.free_camera:
            self.T_O_C = np.ascontiguousarray([loop.plant.camera_pose() for loop in loops])
        else:
            self.T_O_C = np.zeros((len(loops), 4, 4))
            self.joints = np.ascontiguousarray([self._joints(loop.plant) for loop in loops])
            self.J_C = np.zeros((len(loops), 6, self.joints.shape[2]))

    @staticmethod
    def _joints(plant: Any) -> np.ndarray:
        q_encoder, q_true, dq = plant.signal_values(plant.reading())
        return np.array([q_true, q_encoder, dq, plant.joint_offset], dtype=float)

    def run(self, progress: bool = False, label: str = "simulate_batch") -> list[SimulationResult | None]:
        """Each case's result in order, None for a case whose kernel declined (its plug-in loop decides).

        Ctrl-C raises ``KeyboardInterrupt`` with ``error.partial``, the list of what each case recorded
        (status ``"interrupted"`` for the cases still running, and for those whose kernel declined).
        """
        N, n = len(self.loops), self.markers_O.shape[1]
        m = self.law.shape[1]
        n_frames = self.n_ticks // self.ticks_per_frame + 1
        n_rows = self.n_ticks // self.record_every + 2
        width = self.loops[0].recorder.reserve(0).shape[1]
        self.table = np.empty((N, n_rows, width))
        self.frames = np.zeros((N, n_frames, 2 + m + n))  # [t, features, visible, update time]
        self.frame = np.zeros((N, m + 2 * n))
        self.twist, self.gain = np.zeros((N, 6)), np.zeros((N, 1))
        self.rows = np.zeros(N, dtype=np.int64)
        self.state = np.zeros(N, dtype=np.int64)
        self.logged = np.zeros(N, dtype=np.int64)  # frames logged per case
        self.reasons: dict[int, str] = {}
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=self.n_ticks, unit="tick", desc=label, leave=False)
        t0 = time.perf_counter()
        try:
            with np.errstate(all="ignore"):
                for k in range(self.n_ticks + 1):
                    if not (self.state == RUNNING).any():
                        break
                    if self.free_camera:
                        self._free_camera_frame(k, n)
                    else:
                        self._kinematic_tick(k)
                    if bar is not None and k % 1000 == 0 and k:
                        bar.update(1000)
        except KeyboardInterrupt as err:  # Ctrl-C: what each case recorded, as the single-run loops do
            self.state[(self.state == RUNNING) | (self.state == DECLINED)] = INTERRUPTED
            err.partial = self._results(time.perf_counter() - t0)  # type: ignore[attr-defined]
            raise
        finally:
            if bar is not None:
                bar.close()
        return self._results(time.perf_counter() - t0)

    def _free_camera_frame(self, k: int, n: int) -> None:
        tic = time.perf_counter()
        measure_cases(self.T_O_C, self.markers_O, self.params, self.frame, self.state)
        self._settle(k)
        free_camera_steps(
            k, self.T_O_C, n, self.law, self.params, self.frame, self.twist, self.gain, self.table, self.rows,
            self.sizes, self.frames, self.state,
        )  # fmt: skip
        self._log_frame(k, time.perf_counter() - tic)

    def _kinematic_tick(self, k: int) -> None:
        every, last = self.ticks_per_frame, self.n_ticks
        is_frame = k % every == 0
        tic = time.perf_counter()
        running = np.flatnonzero(self.state == RUNNING)
        joints, T_O_C, J_C = self.joints, self.T_O_C, self.J_C
        if is_frame or k % self.record_every == 0 or k == last:
            for c in running:
                T_O_C[c] = self.loops[c].plant.arm.camera_fk(joints[c, 0])
        for c in running:
            J_C[c] = self.loops[c].model_arm.camera_jacobian_at(joints[c, 1])  # type: ignore[union-attr]
        if is_frame:
            measure_cases(T_O_C, self.markers_O, self.params, self.frame, self.state)
            self._settle(k)
        kinematic_ticks(
            k, is_frame, T_O_C, J_C, joints, self.markers_O, self.law, self.params, self.frame, self.twist,
            self.gain, self.table, self.rows, self.sizes, self.frames, k // every, self.state,
        )  # fmt: skip
        if is_frame:
            self._log_frame(k // every, time.perf_counter() - tic)

    def _log_frame(self, index: int, seconds: float) -> None:
        """The frame's update time of each case it advanced: its share of the compiled calls."""
        running = self.state == RUNNING
        count = int(running.sum())
        if count:
            self.frames[running, index, -1] = seconds / count
            self.logged[running] = index + 1

    def _settle(self, k: int) -> None:
        """After the sensor: the reason of each lost marker, then the depths of the pose-estimating cases.

        Each case's own loop says it (:meth:`~.compiled_loop.CompiledLoop.lost_marker`,
        :meth:`~.compiled_loop.CompiledLoop.frame_depths`), as its single run does.
        """
        t = k * self.dt
        for c in np.flatnonzero(self.state == _LOST):
            reason = self.loops[c].lost_marker(self.T_O_C[c], t)
            self.state[c] = DECLINED if reason is None else MARKERS_LOST
            if reason is not None:
                self.reasons[c] = reason
        if not self.pose_cases or k % self.ticks_per_frame:
            return
        for c in self.pose_cases:
            if self.state[c] == RUNNING:
                reason = self.loops[c].frame_depths(self.frame[c], t)
                if reason is not None:
                    self.state[c] = ESTIMATE_FAILED
                    self.reasons[c] = reason

    def _results(self, seconds: float) -> list[SimulationResult | None]:
        m, n, N = self.law.shape[1], self.markers_O.shape[1], len(self.loops)
        results: list[SimulationResult | None] = []
        for c, loop in enumerate(self.loops):
            state = int(self.state[c])
            if state == DECLINED:
                results.append(None)
                continue
            recorder, rows = loop.recorder, int(self.rows[c])
            table = recorder.reserve(rows)
            start = len(recorder)
            table[start : start + rows] = self.table[c, :rows]
            recorder.advance(rows)
            frames = self.frames[c, : self.logged[c]]
            recorder.record_frames(
                frames[:, 0], frames[:, 1 : 1 + m], frames[:, 1 + m : 1 + m + n] != 0.0, frames[:, -1]
            )
            recorder.metadata["loop"] = "batch"
            extra: dict[str, Any] = {"phase_seconds": {"frame": seconds / N, "control": 0.0, "plant": 0.0}}
            status = "interrupted" if state == INTERRUPTED else _STATUS[state]
            if status != "complete":
                extra["error"] = "interrupted" if state == INTERRUPTED else self.reasons[c]
            fallbacks = getattr(loop.pose_estimator, "fallbacks", 0)  # as simulate's with_pnp_fallbacks
            if fallbacks:
                extra["pnp_fallbacks"] = int(fallbacks)
            results.append(recorder.result(status=status, extra_metadata=extra))
        return results
