"""Small controllers and marker sets shared by the servo-loop tests."""

from __future__ import annotations

import numpy as np

from ibvs_youla.controllers import CommandType, Controller

MARKERS_4 = np.array([[-0.2, -0.1, 2.0], [0.2, -0.1, 2.1], [0.15, 0.2, 1.9], [-0.1, 0.15, 2.2]])  # [m]


class ConstantCommand(Controller):
    """Commands one constant value at every tick and keeps the frames and readings it is given."""

    command_type = CommandType.CAMERA_TWIST
    name = "constant"

    def __init__(self, value=(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)):
        self.value = np.asarray(value, dtype=float)

    def reset(self, task):
        super().reset(task)
        self.frames, self.readings = [], []

    def update(self, frame, reading):
        self.frames.append(frame)
        self.readings.append(reading)

    def command(self, reading):
        return self.value


class ConstantTwist(ConstantCommand):
    """The same camera twist [v; w] in {C} at every tick."""

    name = "constant-twist"


class ConstantJointVelocity(ConstantCommand):
    """The same joint velocity [rad/s] at every tick."""

    command_type = CommandType.JOINT_VELOCITY
    name = "constant-dq"
