"""A user-written controller that raises: a typed error naming it, with the samples recorded so far."""

from __future__ import annotations

import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla.exceptions import ControllerError, InvalidCommandError
from ibvs_youla.model.camera import PinholeCamera
from servo_helpers import MARKERS_4, ConstantTwist


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
