"""Robots by name: the IRB 4600 of the paper and the arms of example-robot-data, each with a camera mount.

``Arm.from_robot(name, **overrides)`` builds one (:class:`~ibvs_youla.model.arm.Arm`);
:func:`names` lists them and :func:`get` gives the entry (plain data: the file, the mount, the
locked joints, a home configuration). The descriptions are the maintained ones of
example-robot-data (a dependency), except the IRB 4600, whose URDF ships with ibvs-youla.

**Default camera mount.** On the tool flange, the optical axis (z of the camera frame) along
the tool's approach axis, the optical centre at the flange's origin: ``T_F_C`` from the mount
frame F to the camera {C}.

| name | mount frame F | T_F_C | locked joints (off the chain, at neutral) |
| --- | --- | --- | --- |
| irb4600 | ``camera`` | identity (the URDF's camera link, Rz(pi) on the flange, ERRATA 2) | none |
| ur3, ur5, ur10 | ``tool0`` | identity (z out of the flange) | none |
| panda | ``panda_link8`` | identity (z out of the flange) | the hand's two fingers |
| xarm7 | ``link_eef`` | identity (z out of the flange) | none |
| z1 | ``link06`` | Ry(pi/2) (the flange's approach axis is its x) | ``jointGripper`` |
| kinova | ``j2s6s200_end_effector`` | Ry(pi/2) (approach along the frame's x) | none (fixed fingers) |

**Limits and dynamics.** Joint position, speed and torque limits are the URDF's ``<limit>``; a
continuous joint has no position limit (-inf, +inf); a joint of the chain without a finite
speed or torque limit is refused (``ModelLoadError``) unless the caller gives ``dq_max`` /
``tau_max``. Armature is zero and damping the URDF's ``<dynamics damping>`` (zero when absent:
the UR and Kinova files; 0.003 N m s/rad on the Panda, 1 to 10 on the xArm7 and Z1), unless the
caller gives them (the xArm7's damping on its light wrist needs a joint rate of about 5.2 kHz on
the dynamic plant, which ``simulate`` says); the URDF's ``<dynamics friction>`` (Coulomb) is not
applied by the arm (the plant's ``Disturbances`` model joint friction). The IRB 4600 keeps the
paper's actuator terms (Table A4, :class:`~ibvs_youla.model.actuators.ActuatorParameters`).

**Home configuration** ``q_home``: within the limits, away from singularities (smallest singular
value of the camera Jacobian >= 0.12), the camera above the base plane looking down or forward:
the centre of :func:`ibvs_youla.scenarios.for_arm`'s seeded scenarios.

An arm's identity (:class:`ArmIdentity`, ``arm.identity()``) is the plain data that tells two
arms apart in a campaign spec: name, URDF content hash, mount, locked joints, actuator terms.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._validation import one_of
from ..exceptions import InvalidParameterError
from ._resources import example_robot_data_urdf, urdf_path

__all__ = ["DEFAULT_ROBOT", "ArmIdentity", "Robot", "get", "names", "urdf"]

DEFAULT_ROBOT = "irb4600"
_PI = math.pi


def _ry(angle: float) -> tuple[tuple[float, ...], ...]:
    c, s = math.cos(angle), math.sin(angle)
    return ((c, 0.0, s, 0.0), (0.0, 1.0, 0.0, 0.0), (-s, 0.0, c, 0.0), (0.0, 0.0, 0.0, 1.0))


_IDENTITY = ((1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0), (0.0, 0.0, 0.0, 1.0))


@dataclass(frozen=True)
class Robot:
    """A named robot: where its description is, how the camera is mounted, its home configuration.

    Attributes:
        name: Registry name (``"ur5"``).
        title: Human-readable name.
        urdf: The URDF, relative to example-robot-data's ``robots`` folder (or the file name
            of a URDF shipped in ``ibvs_youla.urdf`` when ``shipped``).
        camera_frame: The mount frame F.
        T_F_C: The camera in F (4, 4), nested tuples.
        flange_frame: The flange frame {E} (T_E_C, the closed-form IK's frame).
        locked_joints: Joints locked at a value other than their neutral one (besides every
            joint off the chain, locked at neutral).
        q_home: Home configuration (n,) [rad or m] (module docstring).
        shipped: The URDF ships with ibvs-youla (the IRB 4600).
    """

    name: str
    title: str
    urdf: str
    camera_frame: str
    T_F_C: tuple[tuple[float, ...], ...]
    flange_frame: str
    q_home: tuple[float, ...]
    locked_joints: Mapping[str, float] = field(default_factory=dict)
    shipped: bool = False


_UR_HOME = (0.0, -1.6, 1.6, -0.5 * _PI, -0.5 * _PI, 0.0)
_ROBOTS = {
    robot.name: robot
    for robot in (
        Robot(
            "irb4600",
            "ABB IRB 4600-45/2.05",
            "abb_irb4600_45_205.urdf",
            "camera",
            _IDENTITY,
            "flange",
            tuple(np.radians((0.0, 0.0, 0.0, 0.0, 30.0, 0.0)).tolist()),
            shipped=True,
        ),
        Robot(
            "ur3",
            "Universal Robots UR3",
            "ur_description/urdf/ur3_robot.urdf",
            "tool0",
            _IDENTITY,
            "tool0",
            _UR_HOME,
        ),
        Robot(
            "ur5",
            "Universal Robots UR5",
            "ur_description/urdf/ur5_robot.urdf",
            "tool0",
            _IDENTITY,
            "tool0",
            _UR_HOME,
        ),
        Robot(
            "ur10",
            "Universal Robots UR10",
            "ur_description/urdf/ur10_robot.urdf",
            "tool0",
            _IDENTITY,
            "tool0",
            _UR_HOME,
        ),
        Robot(
            "panda",
            "Franka Emika Panda",
            "panda_description/urdf/panda.urdf",
            "panda_link8",
            _IDENTITY,
            "panda_link8",
            (0.0, -0.25 * _PI, 0.0, -0.75 * _PI, 0.0, 0.5 * _PI, 0.25 * _PI),
        ),
        Robot(
            "xarm7",
            "UFACTORY xArm7",
            "xarm_description/urdf/xarm7.urdf",
            "link_eef",
            _IDENTITY,
            "link_eef",
            (0.0, -0.3, 0.0, 1.0, 0.0, 1.3, 0.0),
        ),
        Robot(
            "z1",
            "Unitree Z1",
            "z1_description/urdf/z1.urdf",
            "link06",
            _ry(0.5 * _PI),
            "link06",
            (0.0, 1.5, -1.0, -0.5, 0.0, 0.0),
        ),
        Robot(
            "kinova",
            "Kinova Jaco2 j2s6s200",
            "kinova_description/robots/kinova.urdf",
            "j2s6s200_end_effector",
            _ry(0.5 * _PI),
            "j2s6s200_end_effector",
            (0.0, 2.9, 1.3, -2.07, 1.4, 1.3),
        ),
    )
}


def names() -> tuple[str, ...]:
    """The registered robots' names (``"irb4600"`` first)."""
    return tuple(_ROBOTS)


def get(name: str) -> Robot:
    """The entry of robot ``name``.

    Raises:
        InvalidParameterError: an unknown name (the message lists the valid ones).
    """
    return _ROBOTS[one_of(name, "robot", names())]


def urdf(name: str) -> Path:
    """The URDF file of robot ``name`` (example-robot-data's, or the IRB 4600's shipped one)."""
    entry = get(name)
    return urdf_path(entry.urdf) if entry.shipped else example_robot_data_urdf(entry.urdf)


@dataclass(frozen=True)
class ArmIdentity:
    """What tells two arms apart, as plain data (``arm.identity()``; a campaign spec's arm).

    Attributes:
        robot: Registry name, or None for an arm from a URDF file or a model.
        urdf_sha256: SHA-256 of the URDF file's bytes (None for an arm built from a model).
        camera_frame: The mount frame F.
        T_F_C: The camera in F (4, 4) as nested lists.
        flange_frame: The flange frame.
        T_E_C: The camera in the flange frame (4, 4), nested lists (moved by ``with_hand_eye``).
        locked_joints: Locked joints and their values (joint coordinates).
        armature: Armature per joint [kg m^2].
        damping: Viscous damping per joint [N m s/rad].
        dq_max: Speed limits [rad/s or m/s].
        tau_max: Torque limits [N m or N].
        inertia_scale: Factor of :meth:`~ibvs_youla.model.arm.Arm.with_inertia_scale` (1 for none).
    """

    robot: str | None
    urdf_sha256: str | None
    camera_frame: str
    T_F_C: tuple[tuple[float, ...], ...]
    flange_frame: str
    T_E_C: tuple[tuple[float, ...], ...]
    locked_joints: Mapping[str, Any]
    armature: tuple[float, ...]
    damping: tuple[float, ...]
    dq_max: tuple[float, ...]
    tau_max: tuple[float, ...]
    inertia_scale: float = 1.0

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ArmIdentity:
        """The identity of :meth:`to_dict`'s data.

        Raises:
            InvalidParameterError: missing or unknown keys.
        """
        names = set(cls.__dataclass_fields__)
        if not isinstance(data, Mapping) or set(data) != names:
            got = sorted(data) if isinstance(data, Mapping) else type(data).__name__
            raise InvalidParameterError("identity", got, f"a mapping with the keys {sorted(names)}")

        def rows(value: Any) -> Any:
            return tuple(
                tuple(float(x) for x in row) if isinstance(row, (list, tuple)) else row for row in value
            )

        return cls(
            **{key: rows(value) if isinstance(value, (list, tuple)) else value for key, value in data.items()}
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready plain data (lists, floats, strings), keys sorted."""
        out: dict[str, Any] = {}
        for key in sorted(self.__dataclass_fields__):
            value = getattr(self, key)
            if isinstance(value, tuple):
                value = [list(row) if isinstance(row, tuple) else row for row in value]
            elif isinstance(value, Mapping):
                value = {str(k): value[k] for k in sorted(value)}
            out[key] = value
        return out
