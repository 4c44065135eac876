"""The performance tests of Gans, Hutchinson & Corke (2003) as free-camera scenarios.

Gans, Hutchinson & Corke, "Performance tests for visual servo control systems, with
application to partitioned approaches to visual servo control", IJRR 22(10-11), 2003 (the
conference version: "Performance tests of partitioned approaches to visual servo control",
ICRA 2002), propose canonical servoing tasks and quantitative metrics, and run classical IBVS
and three partitioned methods on them, with ideal and non-ideal conditions. What this project
could check of that paper is the ICRA 2002 abstract (four canonical tasks, a set of
performance metrics, IBVS against three partitioned methods); the four tests below follow the
headings the project's issue cites (rotation about the optical axis, translation along it,
rotation of the feature plane, a general motion). The magnitudes (angles, distances), the
target, the rate and the duration are this suite's choices, not numbers taken from the paper;
its non-ideal conditions (noise, calibration errors) are not part of it.

Setting (as ViSP's ``tutorial-ibvs-4pts`` and the tests of the baselines): four coplanar
points, the corners of a 0.2 m square in the plane z = 0 of the base frame
(:data:`SQUARE_O`); a monocular normalized camera (``PinholeCamera.normalized()``: x = X/Z,
y = Y/Z, no field-of-view limit); the free-flying camera at 25 Hz
(``SimulationSettings(joint_rate_hz=25, camera_rate_hz=25)``: the twist held over 40 ms and
integrated with the SE(3) exponential); :data:`DURATION_S` = 30 s per run. The target camera
looks straight at the square's centre from :data:`Z_TARGET` = 0.75 m, its axes parallel to the
base frame's (``T_O_C* = [I, (0, 0, -0.75)]``).

Each task's start is the target camera displaced, in the target camera frame {C*}, by

    T_C*_C0 = O(phi) Rz(theta) T(l_x, l_y, -delta),  O(phi) = T(c) Ry(phi) T(-c),  c = (0, 0, Z*),

so ``T_O_C0 = T_O_C* T_C*_C0``: the camera orbits by phi about the axis through the square's
centre parallel to y_C* (it keeps looking at the centre from Z*, and the feature plane appears
tilted by phi), turns by theta about its own optical axis, shifts by (l_x, l_y) in its image
plane and backs off by delta along its optical axis (delta < 0: it starts nearer).

==================== =============================== =====================================
task                 test                            displacement from the target
==================== =============================== =====================================
gans-rz-30 ... -180  rotation about the optical axis theta = 30, 60, 90, 120, 150, 180 deg
gans-tz-approach     translation along the axis      delta = +0.75 m (start 1.5 m away)
gans-tz-retreat      translation along the axis      delta = -0.375 m (start 0.375 m away)
gans-plane-30, -60   rotation of the feature plane   phi = 30, 60 deg
gans-general         general motion                  theta = 120 deg, phi = 40 deg,
                                                     delta = 0.3 m, l = (0.05, 0.05) m
==================== =============================== =====================================

Metrics (:mod:`.compare`): whether and when the task completes (pose within 1 mm and 0.1 deg
for good), the camera's excursion (path length against the straight line to the target, the
largest distance from the start, the rotation travelled) and the features' excursion in the
image (largest |x|, |y|), with points counted as leaving the view when they pass
:data:`NOMINAL_HALF_VIEW` = 0.5 (a square view of 2 atan 0.5 = 53.1 deg, this suite's choice)
or go behind the camera. :func:`run_suite` runs every task with every registered controller that
commands a camera twist (by default) and :meth:`SuiteReport.table_markdown` gives the table:
tasks as rows, methods as columns.

The suite is point-based: its scene is the four corners of the square, seen by the normalized
camera, which has no pixels. A method that servoes on the image of a textured scene
(``photometric``, :attr:`~ibvs_youla.controllers.Controller.needs_image`) does not apply: it is
not run, and its column reads ``n/a`` with the reason (:data:`NOT_APPLICABLE`), rather than
``rejected`` on every task.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validation import is_pair, one_of, positive, real, text
from ..exceptions import InvalidParameterError
from .compare import Comparison, MethodRow, compare

if TYPE_CHECKING:  # pragma: no cover
    from ..model.camera import PinholeCamera
    from ..scenarios import Scenario
    from ..simulation.settings import SimulationSettings

__all__ = [
    "DURATION_S",
    "GANS_2003",
    "NOMINAL_HALF_VIEW",
    "NOT_APPLICABLE",
    "RATE_HZ",
    "SQUARE_O",
    "SUITES",
    "TASK_NAMES",
    "TESTS",
    "Z_TARGET",
    "GansTask",
    "SuiteReport",
    "not_applicable",
    "run_suite",
    "suite_camera",
    "suite_settings",
    "task",
    "twist_controllers",
]

SQUARE_O = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]
SQUARE_O.setflags(write=False)
Z_TARGET = 0.75  # [m] depth of the square's centre in the target camera
RATE_HZ = 25.0  # camera (and control) rate of the free camera [Hz]
DURATION_S = 30.0  # [s] simulated per run
NOMINAL_HALF_VIEW = 0.5  # max |x|, |y| of a nominal square view (53.1 deg)
NOT_APPLICABLE = (
    "it servoes on the image of a textured scene; the suite's scene is four points seen by the "
    "normalized camera, which has no pixels"
)
TESTS = (
    "rotation about the optical axis",
    "translation along the optical axis",
    "rotation of the feature plane",
    "general motion",
)


def _rot(axis: str, deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    T = np.eye(4)
    if axis == "y":
        T[:3, :3] = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
    else:
        T[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    return T


def _trans(x: float, y: float, z: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


@dataclass(frozen=True)
class GansTask:
    """One task of the suite: the start is the target camera displaced (module docstring).

    Attributes:
        name: Scenario name, e.g. ``"gans-rz-180"``.
        test: One of :data:`TESTS`.
        rotation_deg: theta, the turn about the optical axis [deg].
        retreat_m: delta, how much farther from the square the camera starts, along its
            optical axis [m]; negative: nearer. The start depth Z* + delta must stay > 0.05 m.
        orbit_deg: phi, the orbit about the axis through the square's centre parallel to
            y_C* [deg], |phi| < 90.
        lateral_m: (l_x, l_y), the shift in the start camera's image plane [m].

    Raises:
        InvalidParameterError: an empty name, an unknown test, a non-finite value, a start
            at or behind the square, or |phi| >= 90 deg.
    """

    name: str
    test: str
    rotation_deg: float = 0.0
    retreat_m: float = 0.0
    orbit_deg: float = 0.0
    lateral_m: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "name", text(self.name, "name", empty=False))
        set_(self, "test", one_of(self.test, "test", TESTS))
        for field_name in ("rotation_deg", "retreat_m", "orbit_deg"):
            set_(self, field_name, real(getattr(self, field_name), field_name))
        lateral = self.lateral_m
        if not is_pair(lateral):
            raise InvalidParameterError("lateral_m", lateral, "(l_x, l_y): two finite numbers [m]")
        set_(self, "lateral_m", tuple(real(v, "lateral_m") for v in lateral))
        if Z_TARGET + self.retreat_m <= 0.05:
            raise InvalidParameterError(
                "retreat_m",
                self.retreat_m,
                f"> {0.05 - Z_TARGET:g} m (the start 0.05 m or more before the square)",
            )
        if abs(self.orbit_deg) >= 90.0:
            raise InvalidParameterError(
                "orbit_deg", self.orbit_deg, "|phi| < 90 deg (the square seen from the front)"
            )

    @property
    def T_C_target_C_start(self) -> np.ndarray:
        """The displacement ``T_C*_C0 = O(phi) Rz(theta) T(l_x, l_y, -delta)`` (4, 4)."""
        orbit = _trans(0.0, 0.0, Z_TARGET) @ _rot("y", self.orbit_deg) @ _trans(0.0, 0.0, -Z_TARGET)
        return orbit @ _rot("z", self.rotation_deg) @ _trans(*self.lateral_m, -self.retreat_m)

    @property
    def T_O_C_target(self) -> np.ndarray:
        """The target camera pose: looking at the square's centre from Z* = 0.75 m (4, 4)."""
        return _trans(0.0, 0.0, -Z_TARGET)

    @property
    def T_O_C_start(self) -> np.ndarray:
        """The start camera pose ``T_O_C* T_C*_C0`` (4, 4)."""
        return self.T_O_C_target @ self.T_C_target_C_start

    def describe(self) -> str:
        """One line: the test and the displacement's non-zero parameters."""
        parts = [
            f"theta = {self.rotation_deg:g} deg" if self.rotation_deg else "",
            f"delta = {self.retreat_m:+g} m" if self.retreat_m else "",
            f"phi = {self.orbit_deg:g} deg" if self.orbit_deg else "",
            f"l = ({self.lateral_m[0]:g}, {self.lateral_m[1]:g}) m" if any(self.lateral_m) else "",
        ]
        return f"{self.test}: {', '.join(p for p in parts if p)}"

    def scenario(self) -> Scenario:
        """The task as ``Scenario.free_camera`` (the square, the start and target poses)."""
        from ..scenarios import Scenario

        return Scenario.free_camera(
            self.T_O_C_start,
            self.T_O_C_target,
            SQUARE_O,
            name=self.name,
            description=f"Gans, Hutchinson & Corke 2003 suite, {self.describe()}",
        )


GANS_2003: tuple[GansTask, ...] = (
    *(GansTask(f"gans-rz-{a}", TESTS[0], rotation_deg=float(a)) for a in (30, 60, 90, 120, 150, 180)),
    GansTask("gans-tz-approach", TESTS[1], retreat_m=0.75),
    GansTask("gans-tz-retreat", TESTS[1], retreat_m=-0.375),
    GansTask("gans-plane-30", TESTS[2], orbit_deg=30.0),
    GansTask("gans-plane-60", TESTS[2], orbit_deg=60.0),
    GansTask(
        "gans-general", TESTS[3], rotation_deg=120.0, retreat_m=0.3, orbit_deg=40.0, lateral_m=(0.05, 0.05)
    ),
)
SUITES: dict[str, tuple[GansTask, ...]] = {"gans2003": GANS_2003}
TASK_NAMES: tuple[str, ...] = tuple(t.name for t in GANS_2003)


def task(name: str) -> GansTask:
    """A task of the suite by name (:data:`TASK_NAMES`).

    Raises:
        InvalidParameterError: unknown name (the message lists the valid ones).
    """
    for t in GANS_2003:
        if t.name == name:
            return t
    raise InvalidParameterError("task", name, " or ".join(repr(n) for n in TASK_NAMES))


def suite_camera() -> PinholeCamera:
    """The suite's camera: ``PinholeCamera.normalized()`` (x = X/Z, y = Y/Z, unbounded view)."""
    from ..model.camera import PinholeCamera

    return PinholeCamera.normalized()


def suite_settings(rate_hz: float = RATE_HZ) -> SimulationSettings:
    """The suite's rates: the free camera's tick and the control period ``1 / rate_hz`` (25 Hz)."""
    from ..simulation.settings import SimulationSettings

    return SimulationSettings(joint_rate_hz=rate_hz, camera_rate_hz=rate_hz)


def twist_controllers() -> tuple[str, ...]:
    """Every registered controller that commands a camera twist (those that run on the free camera)."""
    from .. import controllers

    return tuple(
        n
        for n in controllers.names()
        if controllers.make(n).command_type is controllers.CommandType.CAMERA_TWIST
    )


def not_applicable(names: Sequence[str]) -> dict[str, str]:
    """The named controllers the suite does not run, each with the reason (module docstring)."""
    from .. import controllers

    return {n: NOT_APPLICABLE for n in names if controllers.make(n).needs_image}


@dataclass(frozen=True, eq=False)
class SuiteReport:
    """Every task of a suite with every controller: one :class:`~.compare.Comparison` per task.

    Attributes:
        name: The suite's name (``"gans2003"``).
        tasks: The tasks, in order.
        comparisons: The comparison of each task, in the same order.
        controllers: The controllers' names (the table's columns).
        duration: Simulated time per run [s].
    """

    name: str
    tasks: tuple[GansTask, ...]
    comparisons: tuple[Comparison, ...]
    controllers: tuple[str, ...]
    duration: float

    def comparison(self, task_name: str) -> Comparison:
        """The comparison of one task.

        Raises:
            InvalidParameterError: no task has that name.
        """
        for t, c in zip(self.tasks, self.comparisons, strict=True):
            if t.name == task_name:
                return c
        raise InvalidParameterError("task", task_name, " or ".join(repr(t.name) for t in self.tasks))

    def table_markdown(self) -> str:
        """Tasks as rows, methods as columns.

        A converged cell reads ``time to converge [s], camera path [m]``; another gives the
        outcome in bold and the path; a dagger marks points that left the nominal view
        (|x| or |y| > 0.5) or went behind the camera.
        """
        head = "| task | straight line, rotation | " + " | ".join(self.controllers) + " |"
        lines = [head, "|---|---|" + "---|" * len(self.controllers)]
        for t, c in zip(self.tasks, self.comparisons, strict=True):
            distance = float(np.linalg.norm(t.T_C_target_C_start[:3, 3]))
            angle = _angle_deg(t.T_C_target_C_start[:3, :3])
            cells = [_cell(c.row(name)) for name in self.controllers]
            lines.append(f"| {t.name} | {distance:.3g} m, {angle:.3g} deg | " + " | ".join(cells) + " |")
        return "\n".join(lines) + "\n"

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form: the setting, each task and its rows."""
        return {
            "suite": self.name,
            "duration_s": self.duration,
            "rate_hz": RATE_HZ,
            "nominal_half_view": NOMINAL_HALF_VIEW,
            "controllers": list(self.controllers),
            "tasks": [
                {"task": t.name, "test": t.test, "describe": t.describe(), **c.to_dict()}
                for t, c in zip(self.tasks, self.comparisons, strict=True)
            ],
        }


def _angle_deg(R: np.ndarray) -> float:
    skew = R - R.T
    sin = 0.5 * float(np.linalg.norm([skew[2, 1], skew[0, 2], skew[1, 0]]))
    return math.degrees(math.atan2(sin, 0.5 * (float(np.trace(R)) - 1.0)))


def _cell(row: Any) -> str:
    if not row.ran:
        return row.status
    dagger = " †" if row.markers_left_view or row.feature_excursion > NOMINAL_HALF_VIEW else ""
    if row.converged:
        return f"{row.time_to_converge_s:.1f} s, {row.path_length_m:.2f} m{dagger}"
    return f"**{row.outcome.replace('_', ' ')}**, {row.path_length_m:.2f} m{dagger}"


def run_suite(
    controllers: Sequence[str] | None = None,
    tasks: Sequence[GansTask] = GANS_2003,
    *,
    duration: float = DURATION_S,
    rate_hz: float = RATE_HZ,
    name: str = "gans2003",
) -> SuiteReport:
    """Run every task with every controller on the free camera (module docstring).

    Args:
        controllers: Registered names; default :func:`twist_controllers` (every method that
            commands a camera twist; the paper's joint-position controllers need an arm).
        tasks: The tasks; default the whole suite.
        duration: Simulated time per run [s].
        rate_hz: Camera and control rate [Hz].
        name: The suite's name in the report.

    Raises:
        InvalidParameterError: an unknown controller, no tasks, a bad duration or rate.
    """
    names = twist_controllers() if controllers is None else tuple(controllers)
    duration, rate_hz = positive(duration, "duration", unit="s"), positive(rate_hz, "rate_hz", unit="Hz")
    tasks = tuple(tasks)
    if not tasks or not all(isinstance(t, GansTask) for t in tasks):
        raise InvalidParameterError("tasks", tasks, "one or more GansTask")
    settings, camera = suite_settings(rate_hz), suite_camera()
    skipped = not_applicable(names)
    run = [n for n in names if n not in skipped]
    comparisons = []
    for t in tasks:
        if run:
            c = compare(
                t.scenario(), run, plant="free-camera", camera=camera, duration=duration, settings=settings
            )
        else:
            c = Comparison(t.scenario(), "free-camera", camera, duration, ())
        rows = {r.controller: r for r in c.rows}
        rows.update({n: MethodRow(n, "n/a", "n/a", reason) for n, reason in skipped.items()})
        comparisons.append(replace(c, rows=tuple(rows[n] for n in names)))
    return SuiteReport(name, tasks, tuple(comparisons), names, duration)
