"""The controller role of the servo loop: what a controller receives, what it returns.

A servo loop (:func:`ibvs_youla.simulate`) has four roles: a *sensor* and a *plant* on the
world side (they hold the true models), *actuation* between command types, and a
*controller* that holds its own beliefs. This module defines the controller's side of
that contract, so a controller depends on nothing in the simulation:

* :class:`ServoTask` — given once at :meth:`Controller.reset`: the controller's *own*
  models (arm, camera, markers, hand-eye transform inside the arm) and the goal (target
  features as measured at the target, target camera pose, start and target joints) and
  the loop's periods. By default they equal the truth; perturbing them studies
  calibration error and model mismatch without touching the loop.
* :class:`CameraFrame` — each camera frame: features and per-point visibility, each point's
  measured depth when the sensor measures depth (an RGB-D camera), and the image itself for a
  controller that servoes on the image (:attr:`Controller.needs_image`).
* :class:`JointReading` — each joint tick: encoder angles and joint speeds (``None`` on a
  plant without joints, the free-flying camera).
* :class:`CommandType` — what the controller returns each tick: joint torque [N m],
  joint velocity [rad/s], joint position reference [rad] or camera twist [v; w] in the
  camera frame [m/s, rad/s]. The loop converts it to what the plant accepts.

A controller is called twice per cycle: :meth:`Controller.update` at camera rate with a
frame (the image-based part), then :meth:`Controller.command` at every tick (joint rate
on an arm, camera rate on the free-flying camera), whose value is held until the next
tick (zero-order hold). The arrays of the frames and readings it is given are its own copies:
what it writes into them changes neither the recorded measurements nor the plant.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple

import numpy as np

__all__ = ["CameraFrame", "CommandType", "Controller", "JointReading", "ServoTask"]


class CommandType(str, enum.Enum):
    """The quantity a controller commands, and the name it is recorded under in a result."""

    JOINT_TORQUE = "joint_torque"  # tau (n,) [N m]
    JOINT_VELOCITY = "joint_velocity"  # dq_ref (n,) [rad/s]
    JOINT_POSITION = "joint_position"  # q_ref (n,) [rad]
    CAMERA_TWIST = "camera_twist"  # [v; w] (6,) in the camera frame [m/s; rad/s]

    @property
    def signal(self) -> str:
        """Name of the recorded signal (``tau``, ``dq_ref``, ``q_ref``, ``camera_twist``)."""
        return _SIGNAL_NAMES[self]

    @property
    def unit(self) -> str:
        """Unit of the command's entries."""
        return _UNITS[self]

    @classmethod
    def parse(cls, value: Any) -> CommandType:
        """A CommandType from itself or its string value; anything else raises InvalidParameterError."""
        from ..exceptions import InvalidParameterError

        try:
            return cls(value)
        except ValueError:
            raise InvalidParameterError(
                "command_type", value, " or ".join(repr(c.value) for c in cls)
            ) from None


_SIGNAL_NAMES = {
    CommandType.JOINT_TORQUE: "tau",
    CommandType.JOINT_VELOCITY: "dq_ref",
    CommandType.JOINT_POSITION: "q_ref",
    CommandType.CAMERA_TWIST: "camera_twist",
}
_UNITS = {
    CommandType.JOINT_TORQUE: "N m",
    CommandType.JOINT_VELOCITY: "rad/s",
    CommandType.JOINT_POSITION: "rad",
    CommandType.CAMERA_TWIST: "m/s, rad/s",
}


class CameraFrame(NamedTuple):
    """One camera frame as the controller receives it (a named tuple: cheap at camera rate).

    Attributes:
        t: Capture time [s].
        features: Image features (m,), point-major: [u_l, u_r, v] per point for a stereo
            camera (Eq. (24)), [u, v] for a monocular one [m on the sensor; normalized
            coordinates x = X/Z, y = Y/Z for ``PinholeCamera.normalized()``].
        visible: Per-point physical visibility (n,) (in front, in view, in depth range).
        depth: Measured depth Z_C of each point (n,) [m], from a sensor that measures depth
            (``simulate(..., sensor="depth")``, an RGB-D camera); ``None`` when the sensor
            measures none, and a law that needs depths estimates them from its own models.
        image: The grey-level image (height, width) the frame was taken from, float32, for a
            controller that servoes on the image (:attr:`Controller.needs_image`); ``None``
            otherwise (the point sensors measure no image for the controller).
    """

    t: float
    features: np.ndarray
    visible: np.ndarray
    depth: np.ndarray | None = None
    image: np.ndarray | None = None


class JointReading(NamedTuple):
    """Encoder reading at one joint tick (a named tuple: cheap at joint rate).

    Attributes:
        t: Time [s].
        q: Encoder joint angles (n,) [rad] (the true angles minus any unseen offset).
        dq: Joint speeds (n,) [rad/s].
    """

    t: float
    q: np.ndarray
    dq: np.ndarray


@dataclass(frozen=True, eq=False)
class ServoTask:
    """What a controller is told at reset: its own models and the goal.

    Attributes:
        camera: The controller's camera model (a ``StereoCamera`` or ``PinholeCamera``).
        markers_O: The controller's marker coordinates (n, 3) in the base frame [m].
        feature_target: Target features (m,), as measured by the camera at the target.
        T_O_C_target: Target camera pose in the base frame (4, 4) [m].
        tick_period: Period of :meth:`Controller.command` calls [s].
        frame_period: Period of camera frames and :meth:`Controller.update` calls [s].
        virtual_points: Markers may lie behind the camera (the paper's virtual points).
        arm: The controller's arm model (kinematics, dynamics, hand-eye transform T_E_C);
            ``None`` on the free-flying camera.
        q_start: Encoder reading at the start (n,) [rad]; ``None`` without an arm.
        q_target: Joint configuration of the target (n,) [rad]; ``None`` without an arm.
        T_O_C_start: Camera pose at the start (4, 4), as the controller believes it.
        scene: The controller's model of the imaged scene (a
            :class:`~ibvs_youla.model.textured_plane.TexturedPlane`) for a controller that servoes
            on the image; ``None`` otherwise.
        image_target: The image (height, width) taken at the target, noise-free (taught by
            showing, as the target features), for a controller that servoes on the image;
            ``None`` otherwise.

    Raises:
        InvalidArrayError: non-finite or mis-shaped arrays, coincident or collinear markers
            (DegenerateMarkersError), a pose that is not a rigid transform.
        InvalidParameterError: a period that is not a real number > 0, ``virtual_points`` not
            True or False, ``arm`` not an Arm, ``scene`` not a TexturedPlane, ``image_target``
            not a finite 2-D array. (The camera is checked by each controller at
            reset, against what it needs.)
    """

    camera: Any
    markers_O: np.ndarray
    feature_target: np.ndarray
    T_O_C_target: np.ndarray
    tick_period: float
    frame_period: float
    virtual_points: bool = False
    arm: Any = None
    q_start: np.ndarray | None = None
    q_target: np.ndarray | None = None
    T_O_C_start: np.ndarray | None = None
    scene: Any = None
    image_target: np.ndarray | None = None

    def __post_init__(self) -> None:
        from .._validation import as_array, as_pose, flag, instance, positive
        from ..estimation.stereo_pose import check_marker_geometry
        from ..model.arm import Arm
        from ..model.textured_plane import TexturedPlane

        set_ = object.__setattr__
        set_(self, "markers_O", check_marker_geometry(self.markers_O, "markers_O"))
        set_(self, "feature_target", as_array(self.feature_target, "feature_target", (None,)))
        set_(self, "T_O_C_target", as_pose(self.T_O_C_target, "T_O_C_target"))
        set_(self, "tick_period", positive(self.tick_period, "tick_period", unit="s"))
        set_(self, "frame_period", positive(self.frame_period, "frame_period", unit="s"))
        set_(self, "virtual_points", flag(self.virtual_points, "virtual_points"))
        if self.arm is not None:
            instance(self.arm, "arm", Arm, "an Arm or None (the free-flying camera)")
        n = (self.arm.nq,) if self.arm is not None else (None,)
        for name in ("q_start", "q_target"):
            if getattr(self, name) is not None:
                set_(self, name, as_array(getattr(self, name), name, n))
        if self.T_O_C_start is not None:
            set_(self, "T_O_C_start", as_pose(self.T_O_C_start, "T_O_C_start"))
        if self.scene is not None:
            instance(self.scene, "scene", TexturedPlane, "a TexturedPlane or None")
        if self.image_target is not None:
            set_(self, "image_target", as_array(self.image_target, "image_target", (None, None)))

    @property
    def n_points(self) -> int:
        """Number of markers."""
        return int(self.markers_O.shape[0])

    @property
    def ticks_per_frame(self) -> int:
        """Ticks per camera frame (1 on the free-flying camera)."""
        return round(self.frame_period / self.tick_period)


class Controller:
    """Base class of servo controllers; subclass it and override what you need.

    Class attributes:
        command_type: What :meth:`command` returns (a :class:`CommandType`); every controller
            must set it (the loop builds the actuation chain from it).
        name: Short identifier stored in the result's metadata.
        needs_image: The controller servoes on the image itself (default False): ``simulate``
            then needs a scenario with a scene, gives every frame its image
            (:attr:`CameraFrame.image`) and the task the target image and the scene.

    A subclass usually overrides :meth:`reset` (build what depends on the task),
    :meth:`update` (use a camera frame) and :meth:`command` (return the held command).
    :meth:`signals` declares extra signals to record at tick rate, :meth:`spec` the
    parameters stored with the result.
    """

    command_type: ClassVar[CommandType]  # no default: a joint command must never be taken for a twist
    name: ClassVar[str] = "controller"
    needs_image: ClassVar[bool] = False  # servoes on the image: frames carry it, the task its target

    def reset(self, task: ServoTask) -> None:
        """Start a run: keep the task (the controller's models and goal)."""
        self.task = task

    def update(self, frame: CameraFrame, reading: JointReading | None) -> None:
        """Use one camera frame (camera rate); ``reading`` is None without joints."""

    def command(self, reading: JointReading | None) -> np.ndarray:
        """The command for this tick, held until the next (see :attr:`command_type`)."""
        raise NotImplementedError(f"{type(self).__name__}.command")

    def signals(self) -> dict[str, np.ndarray]:
        """Extra signals to record at this tick, name -> array of a fixed shape (none by default)."""
        return {}

    def spec(self) -> dict[str, Any]:
        """JSON-serialisable parameters of this controller, stored in the result."""
        return {"name": self.name, "class": f"{type(self).__module__}.{type(self).__qualname__}"}
