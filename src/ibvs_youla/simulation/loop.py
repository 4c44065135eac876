"""The servo loop: sensor, controller, actuation and plant, ticking with zero-order holds.

Two periodic events (sampled-data semantics): every tick (period ``dt``: the joint rate on
an arm, the camera rate on the free-flying camera) reads the plant; every
``ticks_per_frame``-th tick the sensor takes a frame from the true camera pose and the
controller updates on it. Then, every tick, in this order:

1. the controller's command (held until the next tick);
2. the actuation chain turns it into what the plant accepts (e.g. the paper's inner loop
   into torque), each link with the controller's own models;
3. the sample is recorded (every ``record_every``-th tick and the last);
4. the plant integrates over dt with the command held.

A run ends early, with a status in the result rather than an exception, when the true
camera loses a marker (``"markers_lost"``: behind the camera, seen by the sensor) or the
controller's own models fail on a valid image (``"estimate_failed"``: e.g. no IK branch
within the joint limits reaches the pose seen, Eq. (62), a PnP finds no pose, a believed
marker lies behind the camera, or an image feature of the law has no value there). A diverging plant raises
:class:`~ibvs_youla.exceptions.SimulationDivergedError`, and Ctrl-C a ``KeyboardInterrupt``,
each with the samples recorded so far in ``error.partial`` (status ``"diverged"``,
``"interrupted"``). A controller method that raises, a command that is not an array of the
command type's shape (checked cheaply every tick; the first one must also be finite), or signals
that are not those it declared (:mod:`.controller_checks`) raise
:class:`~ibvs_youla.exceptions.ControllerError` with ``error.partial`` (status
``"controller_failed"``); later commands' values are left to the plant's divergence test (a
finite but huge one too: each plant diverges on a state it cannot hold). The controller is given
its own copies of each frame's and reading's arrays: what it writes into them changes neither
the recorded measurements nor the plant.

The loop times its phases (wall clock, summed over the run) and stores them in
``metadata["phase_seconds"]``: ``frame`` (the encoder reading, the true camera pose, the
sensor and the controller's image update), ``control`` (the command at tick rate, the
actuation chain, recording) and ``plant`` (integration).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..controllers.base import CameraFrame, CommandType, Controller, JointReading
from ..exceptions import (
    ControllerError,
    FeatureSingularityError,
    InvalidCommandError,
    InvalidDisparityError,
    PointBehindCameraError,
    PoseEstimationError,
    SimulationDivergedError,
    UnreachablePoseError,
)
from .controller_checks import checked_signals, controller_name, failed
from .progress import progress_bar
from .recorder import ResultRecorder
from .results import SimulationResult

__all__ = ["ESTIMATE_ERRORS", "ServoLoop", "estimate_failed_reason"]

# What a controller's update raises when its own models fail on a valid image: the run stops with
# status "estimate_failed" (e.g. Eq. (62) has no IK branch within the joint limits, a PnP finds no
# pose, a belief puts a marker behind the camera)
ESTIMATE_ERRORS = (
    PointBehindCameraError,
    InvalidDisparityError,
    UnreachablePoseError,
    PoseEstimationError,
    FeatureSingularityError,
)


def estimate_failed_reason(controller: Any, t: float, err: Exception) -> str:
    """The reason of a run that stops with status ``"estimate_failed"`` at t [s] (every loop's words)."""
    return f"t = {t:.6g} s: {type(controller).__name__}'s estimate failed: {err}"


@dataclass
class ServoLoop:
    """One run of the four roles; built by :func:`~ibvs_youla.simulate`, run once.

    Attributes:
        controller: Already reset with its task.
        sensor: ``measure(T_O_C, t) -> CameraFrame``.
        plant: ``reading()``, ``camera_pose()``, ``apply(command, dt)``, ``signals()``.
        chain: Actuation adapters, ``adapter(command, reading) -> command``.
        dt: Tick period [s].
        n_ticks: Number of plant steps (the run records ticks 0..n_ticks).
        ticks_per_frame: Ticks per camera frame.
        record_every: Keep every n-th tick sample (and the last).
        recorder: Receives the samples.
        command_signals: Names under which each command along the chain is recorded. The
            recorder's ``signal_names`` are the plant's, these, then the controller's
            declared signals (the keys of its first ``signals()``), in that order.
        command_type: The controller's command type (parsed once: the controller may give
            its string value).
        declared_shapes: Name -> shape of each signal the controller declared (its first
            ``signals()``).
    """

    controller: Controller
    sensor: Any
    plant: Any
    chain: list[Any]
    dt: float
    n_ticks: int
    ticks_per_frame: int
    record_every: int
    recorder: ResultRecorder
    command_signals: tuple[str, ...]
    command_type: CommandType
    declared_shapes: dict[str, tuple[int, ...]]

    def run(self, progress: bool = False, label: str = "simulate") -> SimulationResult:
        """Run to the end or to an early stop; return the result with its status."""
        bar = None
        if progress:
            bar = progress_bar(self.n_ticks, label)
        self._reason = ""
        self.phase_seconds: dict[str, float] = {}
        try:
            # A diverging state raises from the plant; numpy's overflow warnings on the way are noise.
            with np.errstate(all="ignore"):
                status = self._ticks(bar)
        except SimulationDivergedError as err:
            err.partial = self.recorder.result(
                status="diverged", extra_metadata={"error": str(err), "phase_seconds": self.phase_seconds}
            )
            raise
        except ControllerError as err:
            err.partial = self.recorder.result(
                status="controller_failed",
                extra_metadata={"error": str(err), "phase_seconds": self.phase_seconds},
            )
            raise
        except KeyboardInterrupt as err:  # Ctrl-C: keep what was recorded, then stop as asked
            err.partial = self.recorder.result(  # type: ignore[attr-defined]
                status="interrupted",
                extra_metadata={"error": "interrupted", "phase_seconds": self.phase_seconds},
            )
            raise
        finally:
            if bar is not None:
                bar.close()
        extra: dict[str, Any] = {"phase_seconds": self.phase_seconds}  # set by _ticks, even on early stops
        if status != "complete":
            extra["error"] = self._reason
        return self.recorder.result(status=status, extra_metadata=extra)

    def _checked_command(self, command: Any, t: float, finite: bool) -> np.ndarray:
        """A command that is not a float array of the command type's shape (the first: finite too)."""
        command_type = self.command_type
        n = 6 if command_type is CommandType.CAMERA_TWIST else getattr(self.plant, "n_joints", 6)
        arr = np.asarray(command, dtype=float) if isinstance(command, (np.ndarray, list, tuple)) else None
        if arr is None or arr.shape != (n,) or (finite and not np.all(np.isfinite(arr))):
            raise InvalidCommandError(
                controller_name(self.controller),
                t,
                repr(command) if arr is None else f"an array of shape {arr.shape} {arr.tolist()}",
                f"a finite ({n},) array: a {command_type.value} [{command_type.unit}]",
            )
        return arr

    def _ticks(self, bar: Any) -> str:
        controller, sensor, plant, chain, dt = self.controller, self.sensor, self.plant, self.chain, self.dt
        record, record_frame = self.recorder.record, self.recorder.record_frame
        n_ticks, every, record_every = self.n_ticks, self.ticks_per_frame, self.record_every
        declared_shapes = self.declared_shapes
        declared_names = tuple(declared_shapes)
        clock = time.perf_counter
        frame = None
        shape: tuple[int, ...] = ()  # the command's, set by the first tick's check
        frame_s = control_s = plant_s = 0.0  # phase times [s], summed over the run
        t_tick = clock()
        try:
            for k in range(n_ticks + 1):
                t = k * dt
                reading = plant.reading()
                given = reading if reading is None else _own_reading(reading)  # the controller's copy
                is_frame = k % every == 0
                if is_frame:
                    T_O_C = plant.camera_pose()
                    try:
                        frame = sensor.measure(T_O_C, t)
                    except (PointBehindCameraError, InvalidDisparityError) as err:
                        self._reason = f"t = {t:.6g} s: the true camera lost a marker: {err}"
                        return "markers_lost"
                    tic = clock()
                    try:
                        controller.update(_own_frame(frame), given)
                    except ESTIMATE_ERRORS as err:  # the controller's own models failed on a valid image
                        self._reason = estimate_failed_reason(controller, t, err)
                        return "estimate_failed"
                    except Exception as err:  # a user's bug: typed, named, with the samples so far
                        raise failed(controller, "update", t, err) from err
                    elapsed = clock() - tic
                    record_frame(t, frame.features, frame.visible, elapsed)
                t_frame = clock()
                try:
                    command = controller.command(given)
                except Exception as err:
                    raise failed(controller, "command", t, err) from err
                if k == 0 or type(command) is not np.ndarray or command.shape != shape:  # cheap, every tick
                    command = self._checked_command(command, t, k == 0)
                    shape = command.shape
                commands = [command]
                for adapter in chain:
                    command = adapter(command, reading)
                    commands.append(command)
                if k % record_every == 0 or k == n_ticks:
                    try:
                        declared = controller.signals()
                    except Exception as err:
                        raise failed(controller, "signals", t, err) from err
                    if type(declared) is not dict or tuple(declared) != declared_names:  # cheap, every sample
                        declared = checked_signals(controller, declared, t, declared_shapes)
                    pose = T_O_C if is_frame else plant.camera_pose()
                    values = (*plant.signal_values(reading), *commands, *declared.values())
                    try:
                        record(t, pose, frame.features, frame.visible, values)  # type: ignore[union-attr]
                    except (ValueError, TypeError):  # the recorder names the signal; say whose it is
                        checked_signals(controller, declared, t, declared_shapes)
                        raise
                t_control = clock()
                if k < n_ticks:
                    plant.apply(command, dt)
                t_plant = clock()
                frame_s += t_frame - t_tick
                control_s += t_control - t_frame
                plant_s += t_plant - t_control
                t_tick = t_plant
                if bar is not None and k % 1000 == 0 and k:
                    bar.update(1000)
        finally:  # also when a run stops early or diverges
            self.phase_seconds = {"frame": frame_s, "control": control_s, "plant": plant_s}
        return "complete"


def _own_frame(frame: CameraFrame) -> CameraFrame:
    """``frame`` with copies of its arrays: the recorder keeps the sensor's, whatever a controller writes.

    Every field is copied (a field left out would reach the controller as ``None``: a depth sensor's
    depths, a rendered image).
    """
    return CameraFrame(frame.t, *(None if field is None else np.array(field) for field in frame[1:]))


def _own_reading(reading: JointReading) -> JointReading:
    """``reading`` with copies of its arrays: the plant, the actuation chain and the recorder keep theirs.

    Copies, not read-only views: a read-only array is another type to the compiled kernels that
    controllers call with it (and a tuple mixing both is not iterable in them).
    """
    return JointReading(reading.t, reading.q.copy(), reading.dq.copy())
