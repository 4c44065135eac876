"""Several controllers on one scenario: the runs, a table of their metrics and side-by-side figures.

:func:`compare` runs each controller (a registered name or a controller object) on the same
scenario, plant, camera and settings, and returns a :class:`Comparison`: one
:class:`MethodRow` per controller and the results of those that ran. A controller whose
command cannot drive the plant (``IncompatibleCommandError``, e.g. the paper's joint-position
controllers on the free camera) gets the status ``"incompatible"``; one that refuses the task
when it is reset (``InvalidParameterError``, e.g. MPC-IBVS with target features outside its
image box) the status ``"rejected"``; both keep the reason and no metrics. A run that diverges
(``SimulationDivergedError``) is measured on its partial record, with the status
``"diverged"``.

Metrics of a run (:func:`method_row`), on the recorded samples (every ``record_every``-th tick):

* **time to converge**: the first sample time from which the camera pose stays within
  :data:`CONVERGED_MM` = 1 mm and :data:`CONVERGED_DEG` = 0.1 deg of the target until the
  end of the run; ``inf`` when the last sample is outside, or the run stopped early;
* **outcome**: ``"converged"`` (a finite time to converge); the status of a run that stopped
  early (``"markers_lost"``, ``"estimate_failed"``, ``"diverged"``); else ``"stalled"`` when
  the image error norm changed by less than 0.1 % over the last 20 % of the run (the verdict
  of :func:`~ibvs_youla.analysis.convergence.classify`), or ``"not converged"``;
* **final pose error**: ``|p - p*|`` [mm] and the angle of ``R^T R*`` [deg] at the last sample;
* **camera path**: the length of the polyline through the camera centres,
  ``sum_k |p_{k+1} - p_k|`` [m]; the straight line ``|p* - p_0|`` from the start to the
  *target*; their ratio, for a run that converged only, so that it reads as "how much longer
  than the shortest way": it is then >= 1 (up to the 1 mm tolerance of the end point), while a
  run that stopped short of the target would give any value, below 1 included (``None`` for
  such a run, and when the straight line is shorter than 1 um: a pure rotation, whose ideal
  path has length 0); the largest distance from the start [m]; the
  rotation travelled, ``sum_k angle(R_k^T R_{k+1})`` [deg], against the angle of
  ``R_0^T R*``;
* **feature excursion**: the largest image coordinate over the run as a fraction of the
  sensor's half extent, ``max |u| / (w/2)``, ``|v| / (h/2)`` over every lens and marker (for
  ``PinholeCamera.normalized()``, whose nominal sensor is 2 x 2, this is ``max |x|, |y|``, the
  tangent of the angle off the optical axis); ``markers_left_view``: some marker was not
  visible at some sample (behind the camera, outside a bounded sensor or depth range), or the
  run stopped because one was lost (its last frame is not recorded);
* **peak joint speed ratio**: ``max_j max_k |dq_j| / dq_max,j`` (arm plants only);
* **median update time**: the median of ``result.update_time`` [us], the wall-clock time of
  each control update (noisy on a shared machine: compare ratios within one run).

The figures and the files of a comparison are in :mod:`.comparison_figures`
(``plot_comparison``, ``save_comparison``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..exceptions import (
    IncompatibleCommandError,
    InvalidParameterError,
    SimulationDivergedError,
)
from .convergence import classify
from .metrics import pose_error_series_mm_deg

if TYPE_CHECKING:  # pragma: no cover
    from ..controllers import Controller
    from ..model.arm import Arm
    from ..model.camera import PinholeCamera, StereoCamera
    from ..scenarios import Scenario
    from ..simulation.results import SimulationResult
    from ..simulation.settings import SimulationSettings

__all__ = [
    "CONVERGED_DEG",
    "CONVERGED_MM",
    "Comparison",
    "MethodRow",
    "compare",
    "method_row",
    "path_length_m",
    "time_to_converge",
]

CONVERGED_MM = 1.0  # [mm] pose tolerance of "converged"
CONVERGED_DEG = 0.1  # [deg]
STRAIGHT_LINE_FLOOR_M = 1e-6  # below it the start-target line counts as a point (pure rotation)
# simulate()'s refusals that hold for every method (the run's length): compare raises instead of a row
_COMMON_ARGUMENTS = ("duration",)


@dataclass(frozen=True)
class MethodRow:
    """The metrics of one controller's run (module docstring); ``None`` where they do not apply.

    Attributes:
        controller: The controller's name.
        status: ``result.status`` (``"complete"``, ``"markers_lost"``, ...), or
            ``"incompatible"`` / ``"rejected"`` when it did not run.
        outcome: ``"converged"``, ``"stalled"``, ``"not converged"``, the status of a run that
            stopped early, or the status of a controller that did not run.
        reason: Why it did not run or stopped early (``metadata["error"]``), else ``""``.
        duration_s: Simulated time covered [s].
        time_to_converge_s: From when the pose stays within 1 mm and 0.1 deg [s]; ``inf``: never.
        final_position_mm: Final camera position error [mm].
        final_rotation_deg: Final camera rotation error [deg].
        path_length_m: Length of the camera centre's path [m].
        straight_line_m: Distance from the start to the target [m].
        path_ratio: ``path_length_m / straight_line_m`` for a run that converged (>= 1 up to
            the 1 mm tolerance); ``None`` for a run that did not, and for a pure rotation.
        max_distance_from_start_m: Largest distance of the camera centre from its start [m].
        rotation_travelled_deg: Sum of the rotation angles between samples [deg].
        rotation_needed_deg: Angle of the start-to-target rotation [deg].
        feature_excursion: Largest image coordinate / half sensor extent over the run.
        markers_left_view: Some marker was invisible at some sample, or the run stopped with
            ``"markers_lost"``.
        peak_joint_speed_ratio: ``max |dq| / dq_max`` over joints and time; ``None`` without joints.
        median_update_us: Median control update time [us].
    """

    controller: str
    status: str
    outcome: str
    reason: str = ""
    duration_s: float | None = None
    time_to_converge_s: float | None = None
    final_position_mm: float | None = None
    final_rotation_deg: float | None = None
    path_length_m: float | None = None
    straight_line_m: float | None = None
    path_ratio: float | None = None
    max_distance_from_start_m: float | None = None
    rotation_travelled_deg: float | None = None
    rotation_needed_deg: float | None = None
    feature_excursion: float | None = None
    markers_left_view: bool | None = None
    peak_joint_speed_ratio: float | None = None
    median_update_us: float | None = None

    @property
    def ran(self) -> bool:
        """True when the row has metrics: the controller ran and recorded samples."""
        return self.duration_s is not None

    @property
    def converged(self) -> bool:
        """True when the run converged (a finite time to converge)."""
        return self.outcome == "converged"

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form; an infinite time to converge (never) becomes ``None``."""
        return {
            k: None if isinstance(v, float) and not math.isfinite(v) else v for k, v in asdict(self).items()
        }


def time_to_converge(result: SimulationResult) -> float:
    """First sample time after which the pose stays within 1 mm and 0.1 deg of the target [s].

    ``inf`` when the last sample is outside the tolerance or the run stopped early (a status
    other than ``"complete"``).
    """
    if result.status != "complete" or len(result) == 0:
        return math.inf
    mm, deg = pose_error_series_mm_deg(result.camera_pose, result.camera_pose_target)
    outside = np.flatnonzero((mm >= CONVERGED_MM) | (deg >= CONVERGED_DEG))
    if outside.size == 0:
        return float(result.t[0])
    if outside[-1] == len(result) - 1:
        return math.inf
    return float(result.t[outside[-1] + 1])


def path_length_m(camera_pose: np.ndarray) -> float:
    """Length of the polyline through the camera centres ``camera_pose[:, :3, 3]`` [m]."""
    p = np.asarray(camera_pose)[:, :3, 3]
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


def _rotation_travelled_deg(camera_pose: np.ndarray) -> float:
    if len(camera_pose) < 2:
        return 0.0
    R = camera_pose[:, :3, :3]
    R_step = np.einsum("nji,njk->nik", R[:-1], R[1:])  # R_k^T R_{k+1}
    cos = np.clip(0.5 * (np.trace(R_step, axis1=1, axis2=2) - 1.0), -1.0, 1.0)
    skew = R_step - np.transpose(R_step, (0, 2, 1))
    sin = 0.5 * np.linalg.norm(np.stack([skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]], axis=1), axis=1)
    return float(np.degrees(np.arctan2(sin, cos)).sum())


def _feature_excursion(result: SimulationResult, camera: StereoCamera | PinholeCamera) -> float:
    """Largest |image coordinate| / half sensor extent: u columns over w/2, v (last per point) over h/2."""
    n, m = result.n_points, result.features.shape[1]
    per_point = m // n
    f = np.abs(result.features.reshape(len(result), n, per_point))
    u = np.nanmax(f[:, :, :-1]) / (0.5 * camera.sensor_width)
    v = np.nanmax(f[:, :, -1]) / (0.5 * camera.sensor_height)
    return float(max(u, v))


def method_row(
    name: str,
    result: SimulationResult,
    camera: StereoCamera | PinholeCamera,
    arm: Arm | None = None,
) -> MethodRow:
    """The metrics of one run (module docstring).

    Args:
        name: The controller's name for the row.
        result: Its run (at least one sample).
        camera: The true camera of the run (its sensor extent scales the feature excursion).
        arm: The arm whose ``dq_max`` scales the joint speeds; needed when the result has ``dq``.
    """
    pose = result.camera_pose
    mm, deg = result.final_pose_error()
    straight = float(np.linalg.norm(result.camera_pose_target[:3, 3] - pose[0, :3, 3]))
    path = path_length_m(pose)
    _, needed = pose_error_series_mm_deg(pose[:1], result.camera_pose_target)
    t_conv = time_to_converge(result)
    if math.isfinite(t_conv):
        outcome = "converged"
    elif result.status != "complete":
        outcome = result.status
    else:
        outcome = "stalled" if classify(result).kind == "stalled" else "not converged"
    speed = None
    if "dq" in result.signals and arm is not None:
        speed = float(np.nanmax(np.abs(result.dq) / np.asarray(arm.dq_max, dtype=float)))
    return MethodRow(
        controller=name,
        status=result.status,
        outcome=outcome,
        reason=str(result.metadata.get("error", "")) if result.status != "complete" else "",
        duration_s=result.duration,
        time_to_converge_s=t_conv,
        final_position_mm=mm,
        final_rotation_deg=deg,
        path_length_m=path,
        straight_line_m=straight,
        path_ratio=path / straight if straight >= STRAIGHT_LINE_FLOOR_M and outcome == "converged" else None,
        max_distance_from_start_m=float(np.linalg.norm(pose[:, :3, 3] - pose[0, :3, 3], axis=1).max()),
        rotation_travelled_deg=_rotation_travelled_deg(pose),
        rotation_needed_deg=float(needed[0]),
        feature_excursion=_feature_excursion(result, camera),
        markers_left_view=bool(not result.visible.all() or result.status == "markers_lost"),
        peak_joint_speed_ratio=speed,
        median_update_us=float(1e6 * np.median(result.update_time)) if result.update_time.size else None,
    )


@dataclass(frozen=True, eq=False)
class Comparison:
    """Several controllers on one scenario: a row per controller, the results of those that ran.

    Attributes:
        scenario: The scenario.
        plant: The plant name.
        camera: The true camera.
        duration: Simulated time asked for [s].
        rows: One :class:`MethodRow` per controller, in the order given.
        results: Controller name -> its result, for the controllers that ran.
        arm: The arm of an arm plant (``None`` on the free camera).
    """

    scenario: Scenario
    plant: str
    camera: StereoCamera | PinholeCamera
    duration: float
    rows: tuple[MethodRow, ...]
    results: Mapping[str, SimulationResult] = field(default_factory=dict)
    arm: Arm | None = None

    def row(self, controller: str) -> MethodRow:
        """The row of one controller.

        Raises:
            InvalidParameterError: no row has that name.
        """
        for r in self.rows:
            if r.controller == controller:
                return r
        raise InvalidParameterError(
            "controller", controller, " or ".join(repr(r.controller) for r in self.rows)
        )

    def table_markdown(self) -> str:
        """The table as Markdown: one row per controller (numbers to 3 significant digits)."""
        head = (
            "| method | status | outcome | converged at [s] | final error [mm, deg] | path [m] "
            "| path / straight line | max image excursion [half sensor] | peak joint speed / limit "
            "| median update [us] |"
        )
        lines = [head, "|" + "---|" * head.count(" | ") + "---|"]
        for r in self.rows:
            if not r.ran:
                lines.append(f"| {r.controller} | {r.status} | {_one_line(r.reason)} |" + " |" * 7)
                continue
            ratio = "-" if r.path_ratio is None else f"{r.path_ratio:.3g}"
            speed = "-" if r.peak_joint_speed_ratio is None else f"{r.peak_joint_speed_ratio:.3g}"
            update = "-" if r.median_update_us is None else f"{r.median_update_us:.3g}"
            lines.append(
                f"| {r.controller} | {r.status} | {r.outcome} | {_seconds(r.time_to_converge_s)} "
                f"| {r.final_position_mm:.3g}, {r.final_rotation_deg:.3g} | {r.path_length_m:.3g} "
                f"| {ratio} | {r.feature_excursion:.3g}{' (left view)' if r.markers_left_view else ''} "
                f"| {speed} | {update} |"
            )
        return "\n".join(lines) + "\n"

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form: the run's setting and the rows."""
        return {
            "scenario": self.scenario.name,
            "plant": self.plant,
            "camera": repr(self.camera),
            "duration_s": self.duration,
            "converged_within": {"position_mm": CONVERGED_MM, "rotation_deg": CONVERGED_DEG},
            "rows": [r.to_dict() for r in self.rows],
        }


def _seconds(t: float | None) -> str:
    return "never" if t is None or not math.isfinite(t) else f"{t:.3g}"


def _one_line(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "/")


def compare(
    scenario: Scenario,
    controllers: Sequence[str | Controller],
    *,
    plant: str = "dynamic",
    camera: StereoCamera | PinholeCamera | None = None,
    duration: float = 10.0,
    settings: SimulationSettings | None = None,
    arm: Arm | None = None,
) -> Comparison:
    """Run every controller on the same scenario, plant, camera and settings.

    Args:
        scenario: The scenario (an arm scenario or ``Scenario.free_camera``).
        controllers: Registered names (``iy.controllers.names()``) or controller objects; a
            name appears once.
        plant: ``"dynamic"``, ``"kinematic"`` or ``"free-camera"``.
        camera: The true camera; default ``simulate``'s (the ZED 2 stereo preset).
        duration: Simulated time [s].
        settings: Rates and options; default ``SimulationSettings()``.
        arm: The true arm of an arm plant; default ``Arm.irb4600()``.

    Returns:
        The :class:`Comparison`. Controllers that could not run have a row with their reason.

    Raises:
        InvalidParameterError: an unknown controller name, a name given twice, an empty list,
            a bad plant or duration (also one the simulator refuses: shorter than one tick of
            the plant, or too long for memory: raised at the first method, before any runs),
            or a free-camera scenario on an arm plant.
    """
    from .. import controllers as registry
    from .._validation import instance, one_of, positive
    from ..controllers import Controller
    from ..model.arm import Arm
    from ..model.camera import PinholeCamera, StereoCamera, default_camera
    from ..scenarios import Scenario
    from ..simulation.settings import SimulationSettings
    from ..simulation.simulate import PLANTS, simulate

    instance(scenario, "scenario", Scenario, "a Scenario (e.g. iy.scenarios.get('paper-1'))")
    if isinstance(controllers, (str, Controller)) or not isinstance(controllers, Sequence):
        raise InvalidParameterError(
            "controllers", controllers, "a list of registered names or controller objects: ['fb', 'ff+fb']"
        )
    if arm is not None:
        instance(arm, "arm", Arm, "an Arm or None")
    duration = positive(duration, "duration", unit="s")
    if camera is not None and not isinstance(camera, (StereoCamera, PinholeCamera)):
        raise InvalidParameterError(
            "camera", type(camera).__name__, "a StereoCamera, a PinholeCamera or None"
        )
    if settings is not None and not isinstance(settings, SimulationSettings):
        raise InvalidParameterError("settings", type(settings).__name__, "a SimulationSettings or None")
    one_of(plant, "plant", PLANTS)
    if plant != "free-camera" and not scenario.has_joints:
        raise InvalidParameterError(
            "plant", plant, f"'free-camera' for the free-camera scenario {scenario.name!r} (it has no joints)"
        )
    labelled = [
        (c, c) if isinstance(c, str) else (getattr(c, "name", type(c).__name__), c) for c in controllers
    ]
    names = [label for label, _ in labelled]
    for _, c in labelled:
        if isinstance(c, str) and c not in registry.names():
            raise InvalidParameterError("controller", c, "one of " + ", ".join(registry.names()))
    if not names or len(set(names)) != len(names):
        raise InvalidParameterError("controllers", names, "one or more controllers, each named once")
    camera = default_camera() if camera is None else camera
    arm = None if plant == "free-camera" else (Arm.irb4600() if arm is None else arm)
    rows, results = [], {}
    for label, c in labelled:
        try:
            result = simulate(
                scenario, c, duration=duration, plant=plant, camera=camera, settings=settings, arm=arm
            )
        except IncompatibleCommandError as err:
            rows.append(MethodRow(label, "incompatible", "incompatible", _one_line(str(err))))
            continue
        except InvalidParameterError as err:
            if err.name in _COMMON_ARGUMENTS:  # no method can run with it: the comparison is refused
                raise
            # the controller refused the task at reset
            rows.append(MethodRow(label, "rejected", "rejected", _one_line(str(err))))
            continue
        except SimulationDivergedError as err:  # measured on the samples recorded until then
            reason = _one_line(str(err))
            if err.partial is None or len(err.partial) == 0:
                rows.append(MethodRow(label, "diverged", "diverged", reason))
                continue
            results[label] = err.partial
            row = method_row(label, err.partial, camera, arm)
            rows.append(replace(row, status="diverged", outcome="diverged", reason=reason))
            continue
        results[label] = result
        rows.append(method_row(label, result, camera, arm))
    return Comparison(scenario, plant, camera, duration, tuple(rows), results, arm)
