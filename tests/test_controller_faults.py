"""A user-written controller that raises or returns what the loop cannot use: a typed error naming it.

The samples recorded so far are kept in ``error.partial``; a huge command is a divergence, and
what a controller is given (frames, readings) is its own copy.
"""

from __future__ import annotations

import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla.controllers import CommandType
from ibvs_youla.exceptions import (
    ControllerError,
    InvalidCommandError,
    InvalidParameterError,
    SimulationDivergedError,
)
from ibvs_youla.model.camera import PinholeCamera
from servo_helpers import MARKERS_4, ConstantCommand, ConstantJointVelocity, ConstantTwist


class RaisesAt(ConstantTwist):
    """Zero twist; ``method`` raises ZeroDivisionError from its 4th call on."""

    def __init__(self, method):
        super().__init__()
        self.method, self.calls = method, 0

    def _maybe(self, method):
        if method == self.method:
            self.calls += 1
            if self.calls >= 4:
                raise ZeroDivisionError("a user's bug")

    def update(self, frame, reading):
        self._maybe("update")

    def command(self, reading):
        self._maybe("command")
        return self.value

    def signals(self):
        self._maybe("signals")
        return {}


@pytest.mark.parametrize("method", ["update", "command", "signals"])
def test_a_raising_controller_method_is_named_and_keeps_the_recorded_samples(method):
    free = iy.Scenario.free_camera(np.eye(4), np.eye(4), MARKERS_4)
    with pytest.raises(
        ControllerError, match=rf"RaisesAt\.{method}\(\) at t = 0\.0[23] s: raised ZeroDivisionError"
    ) as info:
        iy.simulate(
            free, RaisesAt(method), duration=0.1, plant="free-camera", camera=PinholeCamera.normalized()
        )
    err = info.value
    assert (
        isinstance(err.__cause__, ZeroDivisionError) and err.method == method and err.controller == "RaisesAt"
    )
    assert err.partial.status == "controller_failed" and len(err.partial) == (
        2 if method == "signals" else 3
    )  # simulate() calls signals() once first


@pytest.mark.parametrize("bad", [np.zeros(5), None, "fast"])
def test_a_later_malformed_command_is_named_and_keeps_the_recorded_samples(bad):
    class Later(ConstantTwist):
        def reset(self, task):
            super().reset(task)
            self.k = 0

        def command(self, reading):
            self.k += 1
            return bad if self.k == 4 else self.value

    free = iy.Scenario.free_camera(np.eye(4), np.eye(4), MARKERS_4)
    with pytest.raises(
        InvalidCommandError, match=r"Later\.command\(\) at t = 0\.03 s: received .*a finite \(6,\) array"
    ) as info:
        iy.simulate(free, Later(), duration=0.1, plant="free-camera", camera=PinholeCamera.normalized())
    assert info.value.partial.status == "controller_failed" and len(info.value.partial) == 3


class SetUpRaises(ConstantTwist):
    """Zero twist; ``reset`` or ``spec`` (the set-up calls, before any tick) raises."""

    def __init__(self, method):
        super().__init__()
        self.method = method

    def reset(self, task):
        super().reset(task)
        if self.method == "reset":
            raise KeyError("a user's bug")

    def spec(self):
        if self.method == "spec":
            raise KeyError("a user's bug")
        return super().spec()


@pytest.mark.parametrize("method", ["reset", "spec"])
def test_a_raising_set_up_method_is_named_and_chained(method):
    free = iy.Scenario.free_camera(np.eye(4), np.eye(4), MARKERS_4)
    with pytest.raises(
        ControllerError, match=rf"SetUpRaises\.{method}\(\) at t = 0 s: raised KeyError"
    ) as info:
        iy.simulate(
            free, SetUpRaises(method), duration=0.1, plant="free-camera", camera=PinholeCamera.normalized()
        )
    err = info.value
    assert isinstance(err.__cause__, KeyError) and (err.controller, err.method, err.time) == (
        "SetUpRaises",
        method,
        0.0,
    )
    assert err.partial is None  # nothing was recorded before the first tick


class Returns(ConstantTwist):
    """Zero twist; from the ``k``-th call on, ``method`` returns ``value`` (signals declare ``s``)."""

    def __init__(self, method, value, k=1):
        super().__init__()
        self.method, self.value_from_k, self.k = method, value, k
        self.calls = {"signals": 0, "spec": 0}

    def _returns(self, method, usual):
        self.calls[method] += 1
        return self.value_from_k if method == self.method and self.calls[method] >= self.k else usual

    def signals(self):
        return self._returns("signals", {"s": np.zeros(2)})

    def spec(self):
        return self._returns("spec", super().spec())


@pytest.mark.parametrize(
    ("method", "value", "k", "received"),
    [
        ("signals", None, 1, "received None"),
        ("signals", {"s": "xy"}, 1, "received 's': 'xy'"),
        ("signals", {"s": [None, 1.0]}, 1, "received 's': [None, 1.0]"),
        ("signals", {3: np.zeros(2)}, 1, "received the name 3"),
        ("signals", None, 3, "received None"),  # a later tick: the samples so far are kept
        ("signals", {"s": "xy"}, 3, "received 's': 'xy'"),
        ("signals", {"s": np.array(["a", "b"])}, 3, "received 's': array(['a', 'b']"),
        ("spec", ["a", "list"], 1, "received ['a', 'list']"),
        ("spec", {"arm": object()}, 1, "received {'arm': <object"),
    ],
    ids=lambda v: repr(v)[:20],
)
def test_what_a_controller_returns_that_the_loop_cannot_use_is_named(method, value, k, received):
    free = iy.Scenario.free_camera(np.eye(4), np.eye(4), MARKERS_4)
    time = (
        "0" if k == 1 else "0.01"
    )  # simulate() calls signals() once to declare them, then at ticks 0, 1, ...
    with pytest.raises(
        iy.exceptions.InvalidControllerOutputError, match=rf"^Returns\.{method}\(\) at t = {time} s: "
    ) as info:
        iy.simulate(
            free,
            Returns(method, value, k),
            duration=0.1,
            plant="free-camera",
            camera=PinholeCamera.normalized(),
        )
    err = info.value
    assert received in str(err) and isinstance(err, InvalidParameterError) and err.method == method
    if k == 1:
        assert err.partial is None
    else:
        assert err.partial.status == "controller_failed" and len(err.partial) == 1


def test_a_command_type_given_as_its_string_is_parsed_and_any_other_is_refused_by_name():
    free = iy.Scenario.free_camera(np.eye(4), np.eye(4), MARKERS_4)
    run = dict(duration=0.05, plant="free-camera", camera=PinholeCamera.normalized())

    class AsString(ConstantTwist):
        command_type = "camera_twist"

    class Unknown(ConstantTwist):
        command_type = "twist"

    as_enum = iy.simulate(free, ConstantTwist([0.0, 0.0, 0.1, 0.0, 0.0, 0.2]), **run)
    as_string = iy.simulate(free, AsString([0.0, 0.0, 0.1, 0.0, 0.0, 0.2]), **run)
    np.testing.assert_array_equal(as_string.camera_pose, as_enum.camera_pose)  # the same run
    np.testing.assert_array_equal(as_string.camera_twist, as_enum.camera_twist)
    with pytest.raises(
        InvalidParameterError, match=r"Unknown\.command_type: received 'twist'; .*'camera_twist'"
    ):
        iy.simulate(free, Unknown(), **run)


class HugeCommand(ConstantCommand):
    """A finite but huge command (1e300 in every entry) of the given type."""

    name = "huge"

    def __init__(self, command_type):
        super().__init__()
        self.command_type = command_type

    def reset(self, task):
        super().reset(task)
        self.value = np.full(6, 1e300)


@pytest.mark.parametrize(
    ("plant", "command_type"),
    [
        ("free-camera", CommandType.CAMERA_TWIST),
        ("kinematic", CommandType.JOINT_VELOCITY),
        ("kinematic", CommandType.JOINT_POSITION),
        ("dynamic", CommandType.JOINT_TORQUE),
        ("dynamic", CommandType.JOINT_POSITION),
    ],
)
def test_a_huge_finite_command_diverges_on_every_plant_with_the_samples_kept(arm, plant, command_type):
    tick = 0.01 if plant == "free-camera" else 0.001  # [s] the camera rate, the joint rate
    with pytest.raises(SimulationDivergedError, match=rf"simulation diverged at t = {tick:g} s") as info:
        iy.simulate(iy.scenarios.physical(1), HugeCommand(command_type), duration=0.02, plant=plant, arm=arm)
    partial = info.value.partial
    assert partial.status == "diverged" and len(partial) == 1  # tick 0, recorded before the step
    assert np.isfinite(partial.camera_pose).all()


class Writer(ConstantJointVelocity):
    """Zero joint velocity; writes 1.0 into every frame and reading it is given."""

    name = "writer"

    def update(self, frame, reading):
        super().update(frame, reading)
        for array in (frame.features, frame.visible, reading.q, reading.dq):
            array[...] = 1.0

    def command(self, reading):
        reading.q[...] = reading.dq[...] = 1.0
        return self.value


@pytest.mark.parametrize("plant", ["kinematic", "dynamic"])
def test_what_a_controller_writes_into_its_frames_and_readings_changes_neither_records_nor_plant(arm, plant):
    writer, run = Writer(), dict(duration=0.02, plant=plant, arm=arm)
    written = iy.simulate(iy.scenarios.physical(1), writer, **run)
    assert all(
        (f.features == 1.0).all() and r.q[0] == 1.0
        for f, r in zip(writer.frames, writer.readings, strict=True)
    )
    reference = iy.simulate(iy.scenarios.physical(1), ConstantJointVelocity(), **run)
    for name in (
        "camera_pose",
        "features",
        "visible",
        "frame_features",
        "frame_visible",
        "q",
        "dq",
        "q_true",
    ):
        np.testing.assert_array_equal(getattr(written, name), getattr(reference, name), err_msg=name)
