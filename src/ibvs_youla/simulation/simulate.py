"""``simulate()``: one servo loop for every controller, plant and camera.

It assembles the four roles of :mod:`.loop` from a scenario and runs them:

* **sensor** (:class:`~.sensor.MarkerSensor`): the *true* camera and markers; or, chosen by
  ``sensor=``, what measures through them (:class:`~.image_sensor.ImageSensor`: rendered
  images and detected centres; any wrapper of the true sensor);
* **plant**: ``"dynamic"`` (the arm's rigid-body dynamics, Pinocchio ABA + RK4 with the
  torque held, :class:`~.plant.ArmPlant`), ``"kinematic"`` (an ideal inner loop,
  :class:`~.kinematic_arm.KinematicArmPlant`) or ``"free-camera"`` (no arm,
  :class:`~.free_camera.FreeCameraPlant`);
* **controller**: a registered name (:mod:`ibvs_youla.controllers`) or any
  :class:`~ibvs_youla.controllers.Controller` object, reset with a
  :class:`~ibvs_youla.controllers.ServoTask` that carries its *own* models — equal to the
  truth unless ``beliefs`` says otherwise;
* **actuation** (:mod:`.actuation`): from the controller's command to what the plant
  accepts, e.g. the paper's inner loop (Eq. (33)-(46)) from a joint position reference to
  torque on the dynamic arm.

The scenario-2 disturbance is the plant's unseen encoder offset (ERRATA 14): the camera
moves with ``q_true = q + d`` while the controller reads ``q``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._memory import fits_in_memory
from .._validation import flag, one_of, positive
from ..catalog import PLANTS
from ..controllers import Controller, ServoTask, YoulaSettings, make, names, uses_youla_settings
from ..controllers.base import CommandType
from ..estimation.stereo_pose import check_marker_geometry
from ..exceptions import IbvsYoulaError, InvalidControllerOutputError, InvalidParameterError
from ..model.arm import Arm
from ..model.camera import PinholeCamera, StereoCamera, default_camera
from ..model.eye_to_hand import mounted
from ..scenarios import Scenario
from .actuation import actuation_chain
from .compiled_hybrid_loop import CompiledHybridLoop
from .compiled_loop import CompiledLoop
from .compiled_pbvs_loop import CompiledPBVSLoop
from .compiled_polar_loop import CompiledPolarLoop
from .compiled_two_half_d_loop import CompiledTwoHalfDLoop
from .controller_checks import checked_signals, checked_spec, command_type_of, controller_name, failed
from .disturbances import Disturbances
from .free_camera import FreeCameraPlant
from .kinematic_arm import KinematicArmPlant
from .loop import ServoLoop
from .plant import ArmPlant
from .progress import announces_compiles
from .recorder import ResultRecorder
from .results import SimulationResult, software_versions
from .sensor import MarkerSensor
from .settings import SimulationSettings

__all__ = ["PLANTS", "SENSORS", "Beliefs", "PreparedRun", "default_camera", "prepare_run", "simulate"]

LOOPS = ("auto", "plug-in")
# the compiled frame paths, by the law they run
COMPILED_LOOPS = (CompiledLoop, CompiledPBVSLoop, CompiledTwoHalfDLoop, CompiledHybridLoop, CompiledPolarLoop)
SENSORS = ("ideal", "depth", "images")


@dataclass(frozen=True, eq=False)
class Beliefs:
    """What the controller believes where it differs from the truth (``None``: the truth).

    Attributes:
        arm: The controller's arm model: kinematics (hence the hand-eye transform: T_E_C
            eye-in-hand; eye-to-hand, the fixed camera's pose T_O_C, given as an
            :class:`~ibvs_youla.model.eye_to_hand.EyeToHandArm`, e.g.
            ``mounted(arm, scenario.mount).with_camera_pose(T_O_C_believed)``; a plain Arm
            in an eye-to-hand scenario takes the scenario's mount), dynamics for the feedback
            linearization. ``SimulationSettings.model_inertia_scale`` scales it further.
        camera: The controller's camera model (focal length, baseline, principal point).
        markers_O: The controller's marker coordinates (n, 3) [m], in the frame they are fixed
            in (the base eye-in-hand, the carrier eye-to-hand).
    """

    arm: Arm | None = None
    camera: StereoCamera | PinholeCamera | None = None
    markers_O: Any = None

    def __post_init__(self) -> None:
        if self.arm is not None and not isinstance(self.arm, Arm):
            raise InvalidParameterError("beliefs.arm", type(self.arm).__name__, "an Arm or None")
        if self.camera is not None and not isinstance(self.camera, (StereoCamera, PinholeCamera)):
            raise InvalidParameterError(
                "beliefs.camera", type(self.camera).__name__, "a StereoCamera, a PinholeCamera or None"
            )
        if self.markers_O is not None:
            markers = check_marker_geometry(self.markers_O, "beliefs.markers_O").copy()
            markers.setflags(write=False)
            object.__setattr__(self, "markers_O", markers)

    def check_against(self, scenario: Scenario, camera: Any, has_arm: bool) -> None:
        """Beliefs must describe the same kind of world: marker count, feature layout, an arm.

        Raises:
            InvalidParameterError: a different number of markers than the scenario's, a
                monocular belief of a stereo camera (or the reverse), an arm belief without an
                arm plant.
        """
        if self.markers_O is not None and self.markers_O.shape != scenario.markers.shape:
            raise InvalidParameterError(
                "beliefs.markers_O",
                f"{self.markers_O.shape[0]} markers",
                f"the scenario's {scenario.n_points} (a belief about the same markers)",
            )
        if self.camera is not None and isinstance(self.camera, StereoCamera) != isinstance(
            camera, StereoCamera
        ):
            raise InvalidParameterError(
                "beliefs.camera",
                type(self.camera).__name__,
                f"a {type(camera).__name__} like the true camera (the same feature layout)",
            )
        if self.arm is not None and not has_arm:
            raise InvalidParameterError(
                "beliefs.arm", self.arm.name, "None on the free-flying camera (no arm)"
            )
        if self.arm is not None and self.arm.mount.is_eye_to_hand and not scenario.is_eye_to_hand:
            raise InvalidParameterError(
                "beliefs.arm",
                repr(self.arm),
                f"an eye-in-hand Arm for the eye-in-hand scenario {scenario.name!r}",
            )

    def to_dict(self) -> dict[str, Any]:
        """Plain data for the run's specification (the arm by name and hand-eye transform)."""
        arm = None
        if self.arm is not None:  # its hand-eye transform: T_E_C eye-in-hand, T_O_C eye-to-hand
            key = "T_O_C" if self.arm.mount.is_eye_to_hand else "T_E_C"
            arm = {"name": self.arm.name, key: np.asarray(self.arm.hand_eye).tolist()}
        return {
            "arm": arm,
            "camera": None if self.camera is None else repr(self.camera),
            "markers_O": None if self.markers_O is None else self.markers_O.tolist(),
        }


@announces_compiles
def simulate(
    scenario: Scenario,
    controller: str | Controller = "ff+fb",
    adaptive: bool = True,
    duration: float = 10.0,
    *,
    plant: str = "dynamic",
    camera: StereoCamera | PinholeCamera | None = None,
    settings: SimulationSettings | None = None,
    arm: Arm | None = None,
    beliefs: Beliefs | None = None,
    sensor: str | Callable[[MarkerSensor], Any] | None = None,
    disturbances: Disturbances | None = None,
    progress: bool = False,
    loop: str = "auto",
) -> SimulationResult:
    """Simulate one scenario in closed loop and return every signal as data.

    Args:
        scenario: Start, target, markers and disturbance (e.g. ``scenarios.paper(1)``), or
            a free-camera scenario (``Scenario.free_camera(...)``).
        controller: A registered name (``iy.controllers.names()``: ``"ff+fb"`` the paper's
            feedforward + feedback, ``"fb"`` feedback only, ...) or a controller object.
        adaptive: For the paper's controllers: re-linearize the outer loop at every camera
            frame at the configuration estimated from the image (Eq. (62)); False evaluates
            J once (``settings.linearize_at``). Other controllers take their options from
            ``iy.controllers.make(name, **params)``.
        duration: Simulated time [s].
        plant: ``"dynamic"`` (default), ``"kinematic"`` or ``"free-camera"`` (module docstring).
        camera: The true camera; default ``default_camera()``: the paper's ZED 2 optics in the
            VGA mode whose frame rate reaches 100 Hz. A ``PinholeCamera`` is monocular.
        settings: Rates, the paper controller's gains, options; default
            ``SimulationSettings()`` (joint loop 1 kHz, camera 100 Hz).
            ``SimulationSettings.paper()`` runs the camera at the joint rate. On the
            free-flying camera the tick is the camera period.
        arm: The true arm; default ``Arm.irb4600()`` (not built for a free-camera scenario).
            An eye-to-hand scenario (``scenario.mount``) mounts it
            (:func:`~ibvs_youla.model.eye_to_hand.mounted`): the sensor, the controller's task
            and the recorded ``camera_pose`` are then the fixed camera's pose in the markers'
            carrier frame, T_E_C(q) (docs/eye-to-hand.md).
        beliefs: Where the controller's models differ from the truth (:class:`Beliefs`).
        sensor: What measures each frame. None (or ``"ideal"``): the true projections,
            :class:`~.sensor.MarkerSensor`; ``"depth"``: the same with each point's depth in
            every frame (an RGB-D camera, a ``PinholeCamera`` only: the laws that need depths
            use the measured ones, ``MarkerSensor(..., depth=True)``); ``"images"``: rendered
            images and detected centres with default settings, :class:`~.image_sensor.ImageSensor`;
            or a function of the true ``MarkerSensor`` returning the sensor to use (an object with
            ``measure(T_O_C, t) -> CameraFrame``; e.g. ``lambda truth: ImageSensor(truth,
            DiscMarkers(0.04), ImagingSettings(blur_sigma_px=1.0))``, or a wrapper that disturbs
            ``truth.measure``). The goal features stay the true projections at the target.
        disturbances: Pixel noise, dropouts, calibration errors (on top of ``beliefs``), model
            mismatch, latency, actuator limits (:class:`~.disturbances.Disturbances`); each
            wraps a role built here, and ``None`` or all-off wraps nothing.
        progress: Show a progress bar (tqdm) on stderr, and one line while Numba compiles the
            kernels the first time (:mod:`~ibvs_youla.simulation.progress`).
        loop: ``"auto"``: the compiled frame path (:mod:`.compiled_loop`: one compiled call per
            frame, the same result to rounding) when every role is the library's own and one it
            covers (classical IBVS, PBVS (:mod:`.compiled_pbvs_loop`), 2.5-D on its pose route
            (:mod:`.compiled_two_half_d_loop`), the hybrid law (:mod:`.compiled_hybrid_loop`) or
            polar IBVS (:mod:`.compiled_polar_loop`);
            the ideal sensor with or without depth; the free camera or the kinematic arm), else the
            plug-in loop
            (:mod:`.loop`); ``"plug-in"``: always the plug-in loop. ``result.metadata["loop"]``
            says which ran.

    Returns:
        The result. ``result.status`` is ``"complete"``; ``"markers_lost"`` when a marker
        went behind the camera (or its disparity vanished); ``"estimate_failed"`` when the
        controller's estimate failed (e.g. no IK branch within the joint limits reaches the
        camera pose seen in the image, Eq. (62)). ``metadata["error"]`` says when and why;
        ``metadata["spec"]`` holds the full run specification.

    Raises:
        InvalidParameterError: unknown controller, plant or sensor, ``adaptive`` or ``progress``
            not True or False, a duration that is not a real number > 0, is shorter than one
            tick or whose recording would not fit in memory (refused before allocating; the
            message gives the size and what reduces it), a scenario, settings, arm, camera,
            beliefs or disturbances of the wrong type, a sensor function that returns no
            sensor, a joint rate below 1/tau_in on the dynamic arm, a free-camera scenario on an
            arm plant, a disturbance with nothing to act on (e.g. friction on the kinematic
            arm), or a controller that cannot use the task (e.g. the paper's controller with a
            monocular camera); eye-to-hand: the free-flying camera plant, an arm mounted
            otherwise than the scenario, a carrier frame not on the arm's last link, or a
            camera pose from which no marker is visible at the start.
        IncompatibleCommandError: the controller's command cannot drive the plant.
        JointLimitError: the scenario's configurations are outside the arm's limits.
        ControllerError: a controller object's method raised (``reset``, ``spec``, ``update``,
            ``command``, ``signals``) or returned what the loop cannot use
            (:class:`~ibvs_youla.exceptions.InvalidControllerOutputError`); ``error.partial``
            holds the samples recorded until then (None before the first tick).
        SimulationDivergedError: a state left its bounds (a finite but huge command too);
            ``error.partial`` holds the samples recorded until then.
    """
    one_of(loop, "loop", LOOPS)
    progress = flag(progress, "progress")
    prepared = prepare_run(
        scenario,
        controller,
        adaptive,
        duration,
        plant=plant,
        camera=camera,
        settings=settings,
        arm=arm,
        beliefs=beliefs,
        sensor=sensor,
        disturbances=disturbances,
    )
    return prepared.run(loop, progress)


@dataclass
class PreparedRun:
    """The four roles of one run, assembled and checked by :func:`prepare_run`, ready to run once.

    Attributes:
        controller: Already reset with its task.
        sensor: What measures each frame (the true ``MarkerSensor``, or what wraps or replaces it).
        plant: The true plant.
        chain: The actuation adapters from the controller's command to the plant's.
        dt: Tick period [s].
        n_ticks: Number of plant steps (the run records ticks 0..n_ticks).
        ticks_per_frame: Ticks per camera frame.
        record_every: Keep every n-th tick sample (and the last).
        recorder: Receives the samples; its metadata is the run's.
        command_signals: Names under which each command along the chain is recorded.
        command_type: The controller's command type (checked once, before the run).
        declared_shapes: The shapes of the controller's own signals (checked once, before the run).
        label: The progress bar's label (the scenario's name).
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
    label: str

    @property
    def roles(self) -> tuple[Any, ...]:
        """The loops' arguments (controller, sensor, plant, chain, dt, n_ticks, ticks_per_frame, ...)."""
        return (
            self.controller,
            self.sensor,
            self.plant,
            self.chain,
            self.dt,
            self.n_ticks,
            self.ticks_per_frame,
            self.record_every,
        )

    def run(self, loop: str = "auto", progress: bool = False) -> SimulationResult:
        """The run's result: the compiled frame path when ``loop="auto"`` covers it, else the plug-in loop.

        As :func:`simulate` (its ``loop`` and ``progress``; its errors from the loop).
        """
        compiled = None
        if loop == "auto":
            for kind in COMPILED_LOOPS:
                compiled = kind.covering(*self.roles, self.recorder)
                if compiled is not None:
                    break
        if compiled is not None:
            self.recorder.metadata["loop"] = "compiled"
            result = compiled.run(progress, self.label)
            if result is not None:
                return with_pnp_fallbacks(result, self.controller)
            # declined: the plug-in loop makes the run again, its estimator's count from zero
            restart = getattr(getattr(self.controller, "pose_estimator", None), "restart", None)
            if restart is not None:
                restart()
        self.recorder.metadata["loop"] = "plug-in"  # the roles' loop; also where the compiled one declined
        result = ServoLoop(
            *self.roles, self.recorder, self.command_signals, self.command_type, self.declared_shapes
        ).run(progress, self.label)
        return with_pnp_fallbacks(result, self.controller)


def with_pnp_fallbacks(result: SimulationResult, controller: Any) -> SimulationResult:
    """``result`` with ``metadata["pnp_fallbacks"]`` when the controller's IPPE failed on some images.

    Those images were solved by SQPnP (:data:`~ibvs_youla.estimation.monocular_pose.IPPE_FALLBACK`);
    the entry is there only when there were some, so that other runs' metadata is as it was.
    """
    fallbacks = getattr(getattr(controller, "pose_estimator", None), "fallbacks", 0)
    if fallbacks:
        result.metadata["pnp_fallbacks"] = int(fallbacks)
    return result


def prepare_run(
    scenario: Scenario,
    controller: str | Controller = "ff+fb",
    adaptive: bool = True,
    duration: float = 10.0,
    *,
    plant: str = "dynamic",
    camera: StereoCamera | PinholeCamera | None = None,
    settings: SimulationSettings | None = None,
    arm: Arm | None = None,
    beliefs: Beliefs | None = None,
    sensor: str | Callable[[MarkerSensor], Any] | None = None,
    disturbances: Disturbances | None = None,
) -> PreparedRun:
    """The roles of one run of :func:`simulate`, assembled and checked, not yet run.

    The arguments, their checks and errors are :func:`simulate`'s (all but ``progress`` and
    ``loop``, which choose how to run it): ``simulate(...)`` is ``prepare_run(...).run(loop,
    progress)``. Each call builds new roles: a prepared run runs once.
    """
    duration = positive(duration, "duration", unit="s")
    one_of(plant, "plant", PLANTS)
    for name, value, kind in (
        ("scenario", scenario, Scenario),
        ("settings", settings, SimulationSettings),
        ("arm", arm, Arm),
        ("camera", camera, (StereoCamera, PinholeCamera)),
        ("beliefs", beliefs, Beliefs),
        ("disturbances", disturbances, Disturbances),
    ):
        if not (isinstance(value, kind) or (value is None and name != "scenario")):
            valid = " or ".join(k.__name__ for k in (kind if isinstance(kind, tuple) else (kind,)))
            raise InvalidParameterError(name, type(value).__name__, f"a {valid}")
    adaptive = flag(adaptive, "adaptive")
    settings = SimulationSettings() if settings is None else settings
    beliefs = Beliefs() if beliefs is None else beliefs
    disturbances = Disturbances() if disturbances is None else disturbances
    ctrl = disturbances.wrap_controller(_controller(controller, adaptive, settings))
    camera = default_camera() if camera is None else camera
    disturbances.check_applies(plant, camera)
    noise_rng, dropout_rng, marker_rng = disturbances.generators()
    if plant == "free-camera":
        world = _free_camera_world(scenario, arm, settings)
    else:
        arm = Arm.irb4600() if arm is None else arm
        world = _arm_world(scenario, plant, arm, settings, disturbances, camera)
    ticks = duration / world.dt  # a float: 1e308 s is inf ticks, refused below before any rounding
    if ticks < 1.0 - 1e-9:  # no silent zero-step (or rounded-up) run
        raise InvalidParameterError(
            "duration",
            duration,
            f"at least one tick of the {plant!r} plant, {world.dt:g} s (settings' rates)",
        )
    truth = MarkerSensor(camera, scenario.markers, virtual_points=scenario.virtual_points)
    chosen = _sensor(sensor, truth)
    scene = _scene_for(ctrl, scenario)
    measuring = disturbances.wrap_sensor(chosen, noise_rng, dropout_rng, scene=scene)
    beliefs.check_against(scenario, camera, world.arm is not None)
    if beliefs.arm is not None and not beliefs.arm.mount.is_eye_to_hand:  # the scenario's mount
        beliefs = Beliefs(mounted(beliefs.arm, scenario.mount), beliefs.camera, beliefs.markers_O)
    if disturbances.calibration_changed:
        beliefs = _disturbed_beliefs(beliefs, disturbances, scenario, camera, world.arm, marker_rng)
    model_arm = None
    if world.arm is not None:
        model_arm = world.arm if beliefs.arm is None else beliefs.arm
        if settings.model_inertia_scale != 1.0:
            model_arm = model_arm.with_inertia_scale(settings.model_inertia_scale)
    command_type = command_type_of(ctrl)
    if settings.secondary_task is not None:
        _check_secondary_task(settings, ctrl, model_arm, command_type)
    chain = actuation_chain(
        command_type,
        world.plant,
        arm=model_arm,
        q_start=scenario.q_start,
        tau_in=settings.tau_in,
        dt=world.dt,
        secondary_task=settings.secondary_task,
    )
    joints = model_arm is not None
    task = ServoTask(
        camera=camera if beliefs.camera is None else beliefs.camera,
        markers_O=scenario.markers if beliefs.markers_O is None else beliefs.markers_O,
        # taught by showing: the goal is what the camera saw at the true target pose, noise-free, in
        # the controller's conversion (a sensor function's sensor without features_at: the truth's)
        feature_target=(measuring if hasattr(chosen, "features_at") else truth).features_at(
            world.T_O_C_target
        ),
        T_O_C_target=world.T_O_C_target,
        tick_period=world.dt,
        frame_period=world.dt * world.ticks_per_frame,
        virtual_points=scenario.virtual_points,
        arm=model_arm,
        q_start=scenario.q_start if joints else None,
        q_target=scenario.q_target if joints else None,
        # what the controller believes: its arm at the encoder reading (it cannot see an offset)
        T_O_C_start=model_arm.camera_pose(scenario.q_start) if joints else world.T_O_C_start,
        # a controller that servoes on the image: the scene as it is, the image taught at the target
        scene=scene,
        image_target=None if scene is None else measuring.image_at(world.T_O_C_target),
    )
    try:
        ctrl.reset(task)
    except IbvsYoulaError:  # a typed refusal of the task (e.g. the paper's controller, a monocular camera)
        raise
    except Exception as err:  # a user's bug: typed, named, chained
        raise failed(ctrl, "reset", 0.0, err) from err
    record_every = settings.record_every
    command_signals = (command_type.signal, *(a.output_type.signal for a in chain))
    try:
        declared = ctrl.signals()
    except Exception as err:
        raise failed(ctrl, "signals", 0.0, err) from err
    declared_shapes = {name: np.shape(value) for name, value in checked_signals(ctrl, declared, 0.0).items()}
    n_joints = getattr(world.plant, "n_joints", 0)
    shapes = {
        **{name: (n_joints,) for name in world.plant.signal_names},
        **{name: (6,) if name == "camera_twist" else (n_joints,) for name in command_signals},
        **declared_shapes,
    }
    if len(shapes) != len(world.plant.signal_names) + len(command_signals) + len(declared_shapes):
        raise InvalidControllerOutputError(
            controller_name(ctrl),
            "signals",
            0.0,
            f"the names {list(declared_shapes)}",
            f"names other than the plant's and the commands' "
            f"({', '.join((*world.plant.signal_names, *command_signals))})",
        )
    n_rows, n_frames = ticks / record_every + 2, ticks / world.ticks_per_frame + 1  # floats until checked
    fits_in_memory(
        ResultRecorder.estimate_bytes(n_rows, n_frames, task.feature_target.size, truth.n_points, shapes),
        "duration",
        duration,
        f"a shorter duration or a larger settings.record_every (now {record_every}: {n_rows:.3g} samples "
        f"of {ticks:.3g} ticks are kept, and all {n_frames:.3g} camera frames)",
    )
    n_ticks = round(ticks)
    n_rows = n_ticks // record_every + 2
    metadata = _metadata(scenario, ctrl, plant, world, camera, settings, beliefs, n_ticks)
    if chosen is not truth:  # recorded only when a sensor was chosen: undisturbed runs keep their metadata
        describe = getattr(chosen, "spec", None)
        metadata["spec"]["sensor"] = describe() if callable(describe) else type(chosen).__name__
    if disturbances.active:
        metadata["disturbances"] = metadata["spec"]["disturbances"] = disturbances.to_dict()
    recorder = ResultRecorder(
        task.feature_target,
        world.T_O_C_target,
        n_rows,
        n_points=truth.n_points,
        signals=shapes,
        metadata=metadata,
    )
    return PreparedRun(
        ctrl,
        measuring,
        world.plant,
        chain,
        world.dt,
        n_ticks,
        world.ticks_per_frame,
        record_every,
        recorder,
        command_signals,
        command_type,
        declared_shapes,
        scenario.name or "simulate",
    )


def _scene_for(ctrl: Controller, scenario: Scenario) -> Any:
    """The scene a controller that servoes on the image sees (None for the others).

    Raises:
        InvalidParameterError: such a controller on a scenario without a scene.
    """
    if not getattr(ctrl, "needs_image", False):
        return None
    if scenario.scene is None:
        raise InvalidParameterError(
            "scenario",
            f"{scenario.name!r} (point markers, no scene)",
            f"a scenario with a scene for {ctrl.name!r}, which servoes on the image of a textured "
            "plane, not on points: e.g. scenarios.textured_plane(), or Scenario(..., "
            "scene=TexturedPlane(...))",
        )
    return scenario.scene


def _sensor(sensor: Any, truth: MarkerSensor) -> Any:
    """The sensor role: the truth, the image sensor, or what a sensor function makes of the truth."""
    if sensor is None:
        return truth
    names = ", ".join(map(repr, SENSORS[:-1])) + f" or {SENSORS[-1]!r}"
    valid = f"None, {names}, or a function of the true MarkerSensor returning one"
    if isinstance(sensor, str):
        if sensor not in SENSORS:
            raise InvalidParameterError("sensor", sensor, valid)
        if sensor == "ideal":
            return truth
        if sensor == "depth":
            return truth.with_depth()
        from .image_sensor import ImageSensor

        return ImageSensor(truth)
    if not callable(sensor):
        raise InvalidParameterError("sensor", type(sensor).__name__, valid)
    made = sensor(truth)
    if not callable(getattr(made, "measure", None)):
        raise InvalidParameterError(
            "sensor",
            f"a function returning {type(made).__name__}",
            "a function returning a sensor: an object with measure(T_O_C, t) -> CameraFrame",
        )
    return made


def _controller(controller: Any, adaptive: bool, settings: SimulationSettings) -> Controller:
    if isinstance(controller, str):
        if uses_youla_settings(controller):
            return make(controller, adaptive=adaptive, settings=settings.controller_settings())
        if not adaptive:
            raise InvalidParameterError(
                "adaptive",
                adaptive,
                f"True for {controller!r} (only the paper's controllers have a fixed-J "
                "variant; pass options with iy.controllers.make)",
            )
        _no_paper_gains(settings, controller)
        return make(controller)
    if isinstance(controller, type):
        raise InvalidParameterError(
            "controller",
            f"the class {controller.__name__}",
            "a controller object: an instance, e.g. MyController()",
        )
    if not isinstance(controller, Controller):
        raise InvalidParameterError(
            "controller",
            type(controller).__name__,
            "a registered name (" + ", ".join(repr(n) for n in names()) + ") or an iy.controllers.Controller",
        )
    command_type_of(controller)  # a CommandType or its string value, else an error naming the controller
    if not adaptive:
        raise InvalidParameterError(
            "adaptive", adaptive, "True when the controller is an object (it carries its own options)"
        )
    _no_paper_gains(settings, type(controller).__name__)
    return controller


def _check_secondary_task(
    settings: SimulationSettings, ctrl: Controller, arm: Arm | None, command_type: CommandType
) -> None:
    """A secondary task needs a redundant arm and a controller whose camera twist the actuation converts."""
    task = settings.secondary_task.to_dict()  # type: ignore[union-attr]
    if arm is None or not arm.redundant:
        where = "the free-flying camera" if arm is None else f"{arm.name!r} ({arm.nq} joints)"
        raise InvalidParameterError(
            "settings.secondary_task",
            task,
            f"None on {where}: a secondary task acts in the null space of J_C, which needs more than "
            "six joints",
        )
    if command_type is not CommandType.CAMERA_TWIST:
        raise InvalidParameterError(
            "settings.secondary_task",
            task,
            f"None for {ctrl.name!r}, which commands {command_type.value}: the task "
            "is added where a camera twist becomes joint velocities (the twist-commanding methods)",
        )


def _no_paper_gains(settings: SimulationSettings, who: str) -> None:
    """The paper controller's gains in ``settings`` apply to the named paper controllers only."""
    default = YoulaSettings()
    changed = [
        f
        for f in YoulaSettings.field_names()
        if f != "tau_in" and getattr(settings, f) != getattr(default, f)
    ]
    if changed:
        raise InvalidParameterError(
            "settings",
            ", ".join(f"{f}={getattr(settings, f)!r}" for f in changed),
            f"the defaults for {who}: these are gains of the paper's controllers ('fb', 'ff+fb'); "
            "another controller takes its options as an object (tau_in stays: it is the inner loop's)",
        )


@dataclass(frozen=True)
class _World:
    plant: Any
    arm: Arm | None
    dt: float
    ticks_per_frame: int
    T_O_C_start: np.ndarray
    T_O_C_target: np.ndarray


def _disturbed_beliefs(
    beliefs: Beliefs,
    disturbances: Disturbances,
    scenario: Scenario,
    camera: Any,
    arm: Arm | None,
    rng: np.random.Generator,
) -> Beliefs:
    """The beliefs with the calibration errors of ``disturbances`` applied on top."""
    new_arm, new_camera, new_markers = disturbances.believed_models(
        beliefs.arm if beliefs.arm is not None else arm,
        beliefs.camera if beliefs.camera is not None else camera,
        beliefs.markers_O if beliefs.markers_O is not None else scenario.markers,
        rng,
    )
    return Beliefs(
        arm=beliefs.arm if new_arm is None else new_arm,
        camera=beliefs.camera if new_camera is None else new_camera,
        markers_O=beliefs.markers_O if new_markers is None else new_markers,
    )


def _arm_world(
    scenario: Scenario,
    plant: str,
    arm: Arm,
    settings: SimulationSettings,
    disturbances: Disturbances,
    camera: Any,
) -> _World:
    if not scenario.has_joints:
        raise InvalidParameterError(
            "plant", plant, f"'free-camera' for the free-camera scenario {scenario.name!r} (it has no joints)"
        )
    arm = mounted(arm, scenario.mount)  # the arm itself eye-in-hand
    scenario.validate_for(arm)
    dt = settings.dt
    if plant == "dynamic" and dt > settings.tau_in:  # the kinematic arm holds T_in exactly (ZOH)
        raise InvalidParameterError(
            "settings.joint_rate_hz",
            settings.joint_rate_hz,
            f">= 1/tau_in = {1.0 / settings.tau_in:g} Hz on the dynamic arm: the inner loop (Eq. (33)-(46)) "
            "runs at the joint rate and needs a period <= tau_in",
        )
    if plant == "dynamic" and np.any(arm.damping > 0.0):
        _check_damping_is_not_stiff(arm, scenario.q_true_start, settings)
    if plant == "dynamic":
        saturate = settings.saturate or disturbances.limit_scale is not None
        world_plant: Any = ArmPlant(
            disturbances.plant_arm(arm),  # the true arm, if it differs from the controller's model
            scenario.joint_offset,
            q_encoder=scenario.q_start,
            saturate_torque=saturate,
            saturate_speed=saturate,
        )
    else:
        world_plant = KinematicArmPlant(
            arm, scenario.joint_offset, q_encoder=scenario.q_start, tau_in=settings.tau_in, dt=dt
        )
    world = _World(
        world_plant,
        arm,
        dt,
        settings.camera_every,
        arm.camera_pose(scenario.q_true_start),
        arm.camera_pose(scenario.q_target),
    )
    if scenario.is_eye_to_hand and not scenario.virtual_points:
        _check_start_view(scenario, camera, world.T_O_C_start)
    return world


def _check_start_view(scenario: Scenario, camera: Any, T_E_C: np.ndarray) -> None:
    """An eye-to-hand camera must see one of the tool's markers at least, at the start (T_E_C, true q)."""
    P_C = (scenario.markers - T_E_C[:3, 3]) @ T_E_C[:3, :3]
    seen = camera.visibility(P_C)
    if not seen.visible.any():
        where = np.round(scenario.mount.camera_pose[:3, 3], 4).tolist()  # type: ignore[union-attr]
        raise InvalidParameterError(
            "scenario.mount.T_O_C",
            f"a camera at {where} m that sees none of the {scenario.n_points} markers on the tool at the "
            f"start (depths {np.round(seen.depth, 3).tolist()} m; in front {seen.in_front.tolist()}, in the "
            f"field of view {seen.in_fov.tolist()}, in the depth range {seen.in_depth_range.tolist()})",
            "a camera pose from which at least one marker is in front, in the field of view and within the "
            f"depth range {tuple(camera.depth_range)} m at the start configuration",
        )


RK4_REAL_STABILITY = 2.785  # RK4 is stable for dt * lambda <= 2.785 on the negative real axis


def _check_damping_is_not_stiff(arm: Arm, q: np.ndarray, settings: SimulationSettings) -> None:
    """Refuse a joint period at which RK4 cannot integrate the arm's damping (it would diverge at once).

    The viscous damping B dq with the mass matrix M(q) makes the joint velocities decay at the
    rates of the eigenvalues of M(q)^-1 B (the stiffest, a light link with a large URDF damping:
    the xArm7's wrist, 1.4e4 1/s); RK4 at period dt is stable for rate * dt <= 2.785. Checked at
    the start configuration.
    """
    M = arm.mass_matrix(q)
    rate = float(np.linalg.eigvals(np.linalg.solve(M, np.diag(arm.damping))).real.max())  # [1/s]
    if rate * settings.dt > RK4_REAL_STABILITY:
        needed = rate / RK4_REAL_STABILITY
        raise InvalidParameterError(
            "settings.joint_rate_hz",
            settings.joint_rate_hz,
            f">= {needed:.4g} Hz for {arm.name!r} on the dynamic arm: its joint damping decays the joint "
            f"speeds at up to {rate:.4g} 1/s at the start (light links, large damping), which fixed-step RK4 "
            f"integrates only with a period below {RK4_REAL_STABILITY} / {rate:.4g} s; or a smaller damping "
            "(the arm's damping= argument)",
        )


def _free_camera_world(scenario: Scenario, arm: Arm | None, settings: SimulationSettings) -> _World:
    if scenario.is_eye_to_hand:
        raise InvalidParameterError(
            "plant",
            "free-camera",
            f"'dynamic' or 'kinematic' for the eye-to-hand scenario {scenario.name!r}: its markers ride on "
            "the arm and its camera is fixed (the free-flying camera plant has neither)",
        )
    if scenario.has_joints:  # an arm scenario: its camera poses, without the arm
        arm = Arm.irb4600() if arm is None else arm
        scenario.validate_for(arm)
        T_start, T_target = arm.camera_pose(scenario.q_true_start), arm.camera_pose(scenario.q_target)
    else:
        T_start, T_target = scenario.T_O_C_start, scenario.T_O_C_target
    rate = settings.joint_rate_hz if settings.camera_rate_hz is None else settings.camera_rate_hz
    return _World(FreeCameraPlant(T_start), None, 1.0 / rate, 1, np.array(T_start), np.array(T_target))


def _metadata(
    scenario: Scenario,
    ctrl: Controller,
    plant: str,
    world: _World,
    camera: Any,
    settings: SimulationSettings,
    beliefs: Beliefs,
    n_ticks: int,
) -> dict[str, Any]:
    spec = checked_spec(ctrl)
    joints = scenario.has_joints
    metadata: dict[str, Any] = {
        "scenario": scenario.name,
        "scenario_description": scenario.description,
        "controller": ctrl.name,
        "adaptive": spec.get("adaptive"),  # the paper's controllers' option; None for others
        "plant": plant,
        "duration": n_ticks * world.dt,
        "joint_rate_hz": 1.0 / world.dt if plant != "free-camera" else None,
        "camera_rate_hz": 1.0 / (world.dt * world.ticks_per_frame),
        "settings": settings.to_dict(),
        "virtual_points": scenario.virtual_points,
        **_markers_metadata(scenario),
        "arm": world.arm.name if world.arm is not None else None,
        "camera": repr(camera),
        "versions": software_versions(),
        "spec": {
            "scenario": scenario.to_dict(),
            "controller": spec,
            "plant": plant,
            "camera": repr(camera),
            "settings": settings.to_dict(),
            "duration": n_ticks * world.dt,
            "beliefs": beliefs.to_dict(),
        },
    }
    if world.arm is not None:  # which arm, to rebuild it (Arm.from_identity; e.g. view --result)
        metadata["arm_identity"] = world.arm.identity().to_dict()
        if world.arm.robot is None and world.arm.urdf_path is not None:
            metadata["arm_urdf"] = str(world.arm.urdf_path)
    if joints:
        metadata.update(
            q_start=scenario.q_start.tolist(),  # type: ignore[union-attr]
            q_target=scenario.q_target.tolist(),  # type: ignore[union-attr]
            joint_offset=scenario.joint_offset.tolist(),
            q_encoder_goal=scenario.q_encoder_goal.tolist(),
        )
    return metadata


def _markers_metadata(scenario: Scenario) -> dict[str, Any]:
    """The run's markers: ``markers_O`` eye-in-hand; ``markers_E`` and ``mount`` eye-to-hand."""
    if scenario.mount is None:
        return {"markers_O": scenario.markers.tolist()}
    return {"markers_E": scenario.markers.tolist(), "mount": scenario.mount.to_dict()}
