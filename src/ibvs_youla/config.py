"""Run configurations in TOML: a scenario, simulation settings and run options.

A file has up to five tables; every key is optional and every unknown key or
invalid value raises :class:`~ibvs_youla.exceptions.ConfigError` naming the key
(``"settings.zeta"``), the value received and what is valid::

    [scenario]                     # omitted: the command line names the scenario
    preset = "paper-1"             # start from a named scenario (scenarios.NAMES) ...
    name = "my-run"                # ... and override any of these:
    description = "free text"
    q_start_deg = [0, 0, 0, 0, 0, 0]           # initial encoder angles [deg]
    q_target_deg = [0.48, 2.21, 2.05, -82.68, 9.46, 77.47]  # true target angles [deg]
    markers_O = [[-0.5, 0, 0], [0, 0, 0.5], [2, -2, 0]]    # base frame [m]
    joint_offset_deg = 1.0         # disturbance d [deg]: one number or six (ERRATA 14)
    virtual_points = true          # project markers behind the camera (ERRATA 13)

    [settings]                     # SimulationSettings fields over a preset:
    preset = "default"             # SimulationSettings(): camera at 100 Hz (ZED 2), or
                                   # "paper": SimulationSettings.paper(), camera at 1 kHz
    tau_in = 0.01                  # [s]
    omega_n = 10.0                 # [rad/s]
    zeta = 10.0
    feedforward = "paper"          # or "smooth"
    sv_policy = { kind = "damped", threshold = 1e-3 }
    # joint_rate_hz, camera_rate_hz, tau_forward, smooth_speed_fraction, linearize_at,
    # model_inertia_scale, saturate, estimate_from_image, branch_prior, record_every

    [run]
    controller = "ff+fb"           # a name of ibvs_youla.controllers.names(): "ff+fb", "fb", ...
    plant = "dynamic"              # or "kinematic", "free-camera"
    adaptive = true                # false: J evaluated once (settings.linearize_at)
    duration = 10.0                # [s]

    [camera]                       # StereoCamera.zed2(preset, mode, frame_rate)
    preset = "paper"               # or "zed2" (the real ZED 2, ERRATA 15)
    mode = "HD720"

    [arm]                          # default: the IRB 4600 of the paper
    robot = "ur5"                  # a name of ibvs_youla.robots.names(), or instead:
    # urdf = "my_arm.urdf"         # a URDF file (relative to this file's folder)
    camera_frame = "tool0"         # the frame F the camera is on (default: the robot's mount)
    T_F_C = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.05], [0, 0, 0, 1]]  # the camera in F [m]
    locked_joints = { finger = 0.02 }   # joints locked at a value [rad or m]
    # flange_frame, armature, damping, dq_max, tau_max (one number per joint): Arm.from_urdf's;
    # actuator = "paper" or "reflected": the IRB 4600's actuator terms (Arm.irb4600)

Without ``preset`` a ``[scenario]`` table must give ``q_start_deg``, ``q_target_deg``
and ``markers_O`` (joint vectors of the arm's n >= 6 joints), or ``seed`` alone: the
seeded scenario of :func:`ibvs_youla.scenarios.for_arm` for the ``[arm]`` (markers in
front of the camera near the robot's home configuration). ``mount = "eye-to-hand"``, alone or
with ``seed``, makes it the arm's seeded eye-to-hand scenario instead
(:func:`ibvs_youla.scenarios.eye_to_hand`: a camera fixed in front of the arm, markers on its
flange); a table of joints and markers is eye-in-hand. Joint angles are in degrees, as
in the paper's Table 1; everything else is SI. The arm's joint limits and size are checked
when the scenario is simulated (``Scenario.validate_for``), since that needs the arm model.
``[settings] secondary_task = { kind = "joint_limit_avoidance", rho = 0.1 }`` turns on the
null-space task of a redundant arm (:class:`~ibvs_youla.control.redundancy.JointLimitAvoidance`).
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from . import catalog
from . import scenarios as _scenarios
from .exceptions import (
    ConfigError,
    DegenerateMarkersError,
    IbvsYoulaError,
    InvalidArrayError,
    InvalidParameterError,
    ModelLoadError,
)
from .model.camera import ZED_MODES, default_camera

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

if TYPE_CHECKING:  # pragma: no cover
    from .model.arm import Arm
    from .model.camera import StereoCamera
    from .scenarios import Scenario
    from .simulation.settings import SimulationSettings

__all__ = ["RunConfig", "arm_option_at_fault", "load_config", "make_arm", "parse_config"]

Check = Callable[[str, Any], Any]


# ----------------------------------------------------------------------------- value checks
def _number(key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(key, value, "a finite number")
    return float(value)


def _integer(key: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(key, value, "an integer")
    return value


def _boolean(key: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(key, value, "true or false")
    return value


def _text(key: str, value: Any) -> str:
    if not isinstance(value, str):
        raise ConfigError(key, value, "a string")
    return value


def _choice(*choices: str) -> Check:
    def check(key: str, value: Any) -> str:
        if value not in choices:
            raise ConfigError(key, value, " or ".join(repr(c) for c in choices))
        return value

    return check


def _vector(n: int, *, scalar_ok: bool = False, at_least: bool = False) -> Check:
    """A list of ``n`` finite numbers (``at_least``: ``n`` or more); ``scalar_ok``: or one number."""

    def check(key: str, value: Any) -> np.ndarray | float:
        if scalar_ok and not isinstance(value, list):
            return np.full(n, _number(key, value)) if not at_least else _number(key, value)
        size = f"{n} or more" if at_least else f"{n}"
        valid = f"a list of {size} finite numbers" + (" or one number" if scalar_ok else "")
        if not isinstance(value, list) or len(value) < n or (len(value) != n and not at_least):
            raise ConfigError(key, value, valid)
        try:
            return np.array([_number(key, v) for v in value])
        except ConfigError:
            raise ConfigError(key, value, valid) from None

    return check


def _transform(key: str, value: Any) -> np.ndarray:
    valid = "a 4x4 rigid transform as four rows of four numbers [m]"
    if not isinstance(value, list) or len(value) != 4:
        raise ConfigError(key, value, valid)
    try:
        return np.array([_vector(4)(key, row) for row in value])
    except ConfigError:
        raise ConfigError(key, value, valid) from None


def _joint_values(key: str, value: Any) -> dict[str, float]:
    if not isinstance(value, Mapping):
        raise ConfigError(key, value, "a table joint name = value [rad or m], e.g. { panda_joint7 = 0.785 }")
    return {str(name): _number(f"{key}.{name}", v) for name, v in value.items()}


def _secondary_task(key: str, value: Any) -> dict[str, Any]:
    from .control.redundancy import secondary_task_from

    if not isinstance(value, Mapping):
        raise ConfigError(key, value, "a table { kind = 'joint_limit_avoidance', rho, rho1, lambda_tune }")
    try:
        secondary_task_from(dict(value))
    except InvalidParameterError as err:
        raise ConfigError(key, value, err.valid) from None
    return dict(value)


def _points(key: str, value: Any) -> np.ndarray:
    valid = "three or more points [[x, y, z], [x, y, z], [x, y, z], ...] in metres"
    if not isinstance(value, list) or len(value) < 3:
        raise ConfigError(key, value, valid)
    try:
        return np.array([_vector(3)(key, p) for p in value])
    except ConfigError:
        raise ConfigError(key, value, valid) from None


def _settings_keys() -> dict[str, Check]:
    from .controllers.youla import BRANCH_PRIORS, FEEDFORWARD_KINDS, LINEARIZE_AT

    return {
        "preset": _choice(*SETTINGS_PRESETS),
        "joint_rate_hz": _number,
        "camera_rate_hz": _number,
        "tau_in": _number,
        "omega_n": _number,
        "zeta": _number,
        "tau_forward": _number,
        "feedforward": _choice(*FEEDFORWARD_KINDS),
        "smooth_speed_fraction": _number,
        "sv_policy": _sv_table,
        "linearize_at": _choice(*LINEARIZE_AT),
        "model_inertia_scale": _number,
        "saturate": _boolean,
        "estimate_from_image": _boolean,
        "branch_prior": _choice(*BRANCH_PRIORS),
        "record_every": _integer,
        "secondary_task": _secondary_task,
    }


_SCENARIO_KEYS: dict[str, Check] = {
    "preset": _choice(*_scenarios.NAMES),
    "name": _text,
    "description": _text,
    "q_start_deg": _vector(6, at_least=True),
    "q_target_deg": _vector(6, at_least=True),
    "markers_O": _points,
    "joint_offset_deg": _vector(6, scalar_ok=True, at_least=True),
    "virtual_points": _boolean,
    "seed": _integer,
    "mount": _choice(*catalog.MOUNTS),
}


def _run_keys() -> dict[str, Check]:
    from . import controllers
    from .simulation.simulate import PLANTS

    return {
        "controller": _choice(*controllers.names()),
        "plant": _choice(*PLANTS),  # the simulator's plants
        "adaptive": _boolean,
        "duration": _number,
    }


_CAMERA_KEYS: dict[str, Check] = {
    "preset": _choice("paper", "zed2"),
    "mode": _choice(*ZED_MODES),
    "frame_rate": _number,
}


def _arm_keys() -> dict[str, Check]:
    from .model.robots import names

    per_joint = _vector(6, at_least=True)
    return {
        "robot": _choice(*names()),
        "urdf": _text,
        "camera_frame": _text,
        "flange_frame": _text,
        "T_F_C": _transform,
        "locked_joints": _joint_values,
        "actuator": _choice("paper", "reflected"),
        "armature": per_joint,
        "damping": per_joint,
        "dq_max": per_joint,
        "tau_max": per_joint,
    }


_SV_KEYS: dict[str, Check] = {"kind": _choice("damped", "truncate"), "threshold": _number}


def _sv_table(key: str, value: Any) -> dict[str, Any]:
    return _table({"sv_policy": value}, "sv_policy", _SV_KEYS, prefix="settings.")


TABLES = ("scenario", "settings", "run", "camera", "arm")
SETTINGS_PRESETS = ("default", "paper")


def _table(
    data: Mapping[str, Any], table: str, keys: Mapping[str, Check], prefix: str = ""
) -> dict[str, Any]:
    """Check the keys and value types of ``data[table]``; return the converted values."""
    raw = data.get(table, {})
    if not isinstance(raw, Mapping):
        raise ConfigError(prefix + table, raw, f"a table with keys {', '.join(keys)}")
    out = {}
    for key, value in raw.items():
        name = f"{prefix}{table}.{key}"
        if key not in keys:
            raise ConfigError(name, value, f"a key of [{prefix}{table}]: {', '.join(keys)}")
        out[key] = keys[key](name, value)
    return out


def _rename(err: IbvsYoulaError, table: str, aliases: Mapping[str, str] | None = None) -> ConfigError:
    """A library validation error re-raised as a ConfigError on ``table.key``."""
    if isinstance(err, InvalidParameterError):
        key = (aliases or {}).get(err.name, err.name)
        return ConfigError(f"{table}.{key}", err.value, err.valid)
    if isinstance(err, DegenerateMarkersError):
        return ConfigError(
            f"{table}.markers_O", np.asarray(err.points).tolist(), "three or more non-collinear points"
        )
    if isinstance(err, InvalidArrayError):
        key = (aliases or {}).get(err.name, err.name)
        return ConfigError(f"{table}.{key}", err.received, err.expected)
    return ConfigError(table, "its values", str(err))


# ----------------------------------------------------------------------------- the configuration
@dataclass(frozen=True)
class RunConfig:
    """A loaded configuration; ``None`` fields were not given in the file.

    Attributes:
        scenario: The ``[scenario]`` table as a Scenario, or None without that table.
        settings: ``[settings]`` over its preset (``SimulationSettings()`` or ``.paper()``).
        controller: ``[run] controller`` (a registered name, ``controllers.names()``) or None.
        plant: ``[run] plant`` (``"dynamic"``, ``"kinematic"``, ``"free-camera"``) or None.
        adaptive: ``[run] adaptive`` or None.
        duration: ``[run] duration`` [s] or None.
        camera_options: Keyword arguments of ``StereoCamera.zed2`` from ``[camera]``.
        arm_options: The ``[arm]`` table, checked (:func:`make_arm`'s options; a relative
            ``urdf`` resolved against the file's folder).
        source: Where it was read from (a path, or ``"<dict>"``).
        scenario_seed: ``[scenario] seed``: the seed of :func:`ibvs_youla.scenarios.for_arm`
            for the arm (then :attr:`scenario` is None), or None.
        scenario_mount: ``[scenario] mount`` (``"eye-in-hand"`` or ``"eye-to-hand"``: the arm's
            seeded scenario of that mount; then :attr:`scenario` is None), or None.
    """

    scenario: Scenario | None
    settings: SimulationSettings
    controller: str | None = None
    plant: str | None = None
    adaptive: bool | None = None
    duration: float | None = None
    camera_options: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    arm_options: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    source: str = "<dict>"
    scenario_seed: int | None = None
    scenario_mount: str | None = None

    def make_camera(self) -> StereoCamera:
        """The stereo camera of ``[camera]`` (default: ``simulate``'s, the paper's ZED 2 in VGA mode)."""
        try:
            return default_camera(**self.camera_options)
        except InvalidParameterError as err:  # e.g. a frame rate the mode does not offer
            raise _rename(err, "camera") from None

    def make_arm(self, **overrides: Any) -> Arm:
        """The arm of ``[arm]`` (default: the IRB 4600 with the paper's actuator terms).

        Args:
            **overrides: Options over the table's (:func:`make_arm`), e.g. from the command line;
                ``robot`` or ``urdf`` replaces the whole table (its mount and terms are another
                arm's).

        Raises:
            ConfigError: a value of the table that the arm refuses (a robot description that
                cannot be loaded, an unknown camera frame or locked joint: the message lists the
                candidates), naming the key.
        """
        options = {} if "robot" in overrides or "urdf" in overrides else dict(self.arm_options)
        options.update(overrides)
        try:
            return make_arm(options)
        except ModelLoadError as err:
            key = arm_option_at_fault(err, options)
            raise ConfigError(f"arm.{key}", options.get(key), " ".join(str(err).split())) from None
        except IbvsYoulaError as err:
            unknown = getattr(err, "value", None)
            if getattr(err, "name", None) == "overrides" and isinstance(unknown, list) and unknown:
                raise ConfigError(f"arm.{unknown[0]}", options.get(unknown[0]), err.valid) from None
            raise _rename(err, "arm") from None


def arm_option_at_fault(err: ModelLoadError, options: Mapping[str, Any]) -> str:
    """The ``[arm]`` key a robot description's refusal is about: a frame, a locked joint, else the file."""
    for key in ("camera_frame", "flange_frame"):
        if key in options and err.element == f"frame {options[key]!r}":
            return key
    if any(err.element == f"joint {name!r}" for name in options.get("locked_joints") or {}):
        return "locked_joints"
    return "urdf" if "urdf" in options else "robot"


def make_arm(options: Mapping[str, Any]) -> Arm:
    """The arm of ``[arm]`` options (module docstring): a robot by name or a URDF file, its mount.

    ``robot`` (default ``"irb4600"``) goes to :meth:`~ibvs_youla.model.arm.Arm.from_robot`,
    ``urdf`` to :meth:`~ibvs_youla.model.arm.Arm.from_urdf`, with the other options as keywords.

    Raises:
        InvalidParameterError: both ``robot`` and ``urdf``, or an option the arm refuses.
        ModelLoadError: the robot description cannot be loaded or used (an unknown camera frame
            or locked joint: the message lists the candidates).
    """
    from .model.arm import Arm

    options = dict(options)
    robot, urdf = options.pop("robot", None), options.pop("urdf", None)
    if robot is not None and urdf is not None:
        raise InvalidParameterError("arm", f"robot {robot!r} and urdf {urdf!r}", "one of robot and urdf")
    if urdf is not None:
        return Arm.from_urdf(urdf, **options)
    return Arm.from_robot(robot or "irb4600", **options)


def _scenario(values: dict[str, Any]) -> Scenario:
    from .scenarios import Scenario

    preset = values.pop("preset", None)
    offset = values.get("joint_offset_deg")
    if offset is not None and np.ndim(offset) == 0:  # one number: every joint of the scenario's arm
        q_start = values.get("q_start_deg")
        if q_start is None and preset is not None:
            q_start = _scenarios.get(preset).q_start
        values["joint_offset_deg"] = np.full(6 if q_start is None else len(q_start), offset)
    base = _scenarios.get(preset) if preset is not None else None
    required = ("q_start_deg", "q_target_deg", "markers_O")
    missing = [k for k in required if k not in values]
    if base is None and missing:
        raise ConfigError(
            f"scenario.{missing[0]}",
            None,
            f"a value, or scenario.preset = one of {', '.join(repr(n) for n in _scenarios.NAMES)}",
        )
    fields: dict[str, Any] = (
        {} if base is None else {f.name: getattr(base, f.name) for f in dataclasses.fields(base)}
    )
    for key, value in values.items():
        if key.endswith("_deg"):
            fields[key[: -len("_deg")]] = np.radians(value)
        else:
            fields[key] = value
    if base is None:
        fields.setdefault("name", "custom")
    aliases = {"q_start": "q_start_deg", "q_target": "q_target_deg", "joint_offset": "joint_offset_deg"}
    try:
        return Scenario(**fields)
    except IbvsYoulaError as err:
        raise _rename(err, "scenario", aliases) from None


def _settings(values: dict[str, Any], default_preset: str) -> SimulationSettings:
    from .control.outer import SingularValuePolicy
    from .simulation.settings import SimulationSettings

    preset = values.pop("preset", default_preset)
    build = SimulationSettings.paper if preset == "paper" else SimulationSettings
    if "sv_policy" in values:
        try:
            values["sv_policy"] = SingularValuePolicy(**values["sv_policy"])
        except IbvsYoulaError as err:
            raise _rename(err, "settings.sv_policy") from None
    try:
        return build(**values)
    except IbvsYoulaError as err:
        raise _rename(err, "settings") from None


def parse_config(
    data: Mapping[str, Any], source: str = "<dict>", *, settings_preset: str = "default"
) -> RunConfig:
    """Validate a parsed TOML document (nested dicts) and build the run configuration.

    Args:
        data: Tables ``scenario``, ``settings``, ``run``, ``camera``, ``arm`` (module docstring).
        source: Where ``data`` came from, kept in :attr:`RunConfig.source`.
        settings_preset: The settings that ``[settings]`` overrides when it names no
            ``preset``: ``"default"`` (``SimulationSettings()``, camera at 100 Hz) or
            ``"paper"`` (``SimulationSettings.paper()``, camera at the 1 kHz joint rate).

    Raises:
        ConfigError: an unknown table or key, or an invalid value; ``err.name`` is the
            dotted key, ``err.value`` the value received, ``err.valid`` what is valid.
    """
    if not isinstance(data, Mapping):
        raise ConfigError("config", data, "a mapping of TOML tables")
    for table, value in data.items():
        if table not in TABLES:
            raise ConfigError(table, value, f"a table: {', '.join(f'[{t}]' for t in TABLES)}")
    scenario_values = _table(data, "scenario", _SCENARIO_KEYS)
    settings_values = _table(data, "settings", _settings_keys())
    run = _table(data, "run", _run_keys())
    if "duration" in run and run["duration"] <= 0.0:
        raise ConfigError("run.duration", run["duration"], "a finite number > 0 s")
    mount = scenario_values.pop("mount", None)
    seed = scenario_values.pop("seed", None)
    if mount == "eye-to-hand" and scenario_values:
        raise ConfigError(
            "scenario.mount",
            mount,
            "'eye-to-hand' alone in [scenario] or with scenario.seed (the arm's seeded eye-to-hand "
            "scenario), or 'eye-in-hand' with a table of joints and markers (which is eye-in-hand): "
            f"remove {', '.join(sorted(scenario_values))}",
        )
    if seed is not None and (seed < 0 or scenario_values):
        raise ConfigError(
            "scenario.seed",
            seed,
            "an integer >= 0, alone in [scenario] or with scenario.mount (the seeded scenario of the "
            "[arm], scenarios.for_arm or scenarios.eye_to_hand)"
            + (f"; remove {', '.join(sorted(scenario_values))}" if scenario_values else ""),
        )
    # the table's own scenario, unless it only chooses the seeded one (a seed, a mount, or both)
    own_table = "scenario" in data and seed is None and (mount is None or bool(scenario_values))
    arm = _table(data, "arm", _arm_keys())
    if "robot" in arm and "urdf" in arm:
        raise ConfigError("arm.urdf", arm["urdf"], f"no urdf with arm.robot = {arm['robot']!r}: one of them")
    if "urdf" in arm and source != "<dict>":
        arm["urdf"] = str(Path(source).parent / arm["urdf"])
    return RunConfig(
        scenario=_scenario(scenario_values) if own_table else None,
        settings=_settings(settings_values, _choice(*SETTINGS_PRESETS)("settings_preset", settings_preset)),
        controller=run.get("controller"),
        plant=run.get("plant"),
        adaptive=run.get("adaptive"),
        duration=run.get("duration"),
        camera_options=_table(data, "camera", _CAMERA_KEYS),
        arm_options=arm,
        source=source,
        scenario_seed=seed,
        scenario_mount=mount,
    )


def load_config(path: str | Path, *, settings_preset: str = "default") -> RunConfig:
    """Read and validate a TOML run configuration (schema in the module docstring).

    ``settings_preset`` is what ``[settings]`` overrides when it names no ``preset``
    (see :func:`parse_config`).

    Raises:
        ConfigError: the file is missing, unreadable, not UTF-8 or not valid TOML (``err.name == "config"``),
            or a key is unknown or has an invalid value (``err.name`` is the dotted key).
    """
    if not isinstance(path, (str, os.PathLike)):
        raise ConfigError("config", path, "a TOML file path (str or pathlib.Path)")
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError("config", str(path), f"a readable TOML file ({exc.strerror})") from None
    except UnicodeDecodeError as exc:  # TOML is UTF-8 (TOML 1.0, "Spec")
        raise ConfigError(
            "config", str(path), f"a UTF-8 text file (TOML); byte {exc.start} is {exc.object[exc.start]:#04x}"
        ) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError("config", str(path), f"a valid TOML file ({exc})") from None
    return parse_config(data, source=str(path), settings_preset=settings_preset)
