"""``ibvs-youla compare``: several controllers on one scenario, or the Gans 2003 suite; tables and figures.

``--scenario NAME`` takes the named scenarios (``paper-1``, ..., ``physical-2``: the dynamic arm,
the ZED 2 stereo camera at 100 Hz and 10 s by default, every registered controller) or a task
of the suite (``gans-rz-180``, ...: the free camera, the normalized monocular camera at 25 Hz and
30 s, every controller that commands a camera twist), or ``textured-plane``
(:func:`ibvs_youla.scenarios.textured_plane`: a textured plane and a square of markers, the free
camera, the 120 x 90 px camera of :func:`~ibvs_youla.scenarios.textured_camera` at 25 Hz and 30 s,
every controller that commands a camera twist, photometric servoing included). ``--suite
gans2003`` runs every task of :mod:`ibvs_youla.analysis.suites`. The metrics are those of
:mod:`ibvs_youla.analysis.compare`.
``--robot NAME`` or ``--urdf FILE`` (with the mount options) runs the arm scenario on that arm:
without ``--scenario``, its seeded scenario (:func:`ibvs_youla.scenarios.for_arm`, ``--seed``);
the named scenarios are the IRB 4600's, and the suite's tasks and the textured plane are the free
camera's, so those refuse another arm (exit 2). ``--mount eye-to-hand`` (without ``--scenario``)
compares on the arm's seeded eye-to-hand scenario (:func:`ibvs_youla.scenarios.eye_to_hand`: a
camera fixed in front of the arm, the markers on its flange).
A ``--duration`` or ``--camera-rate`` that the simulator refuses stops the comparison before
any method runs (exit 2), rather than giving every method a 'rejected' row.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .. import catalog
from ..files import write_json, write_text
from .base import ARM_FLAGS, UsageError, arm_flags, flag_errors, resolve_arm

FLAGS = {
    "duration": "--duration",
    "camera_rate_hz": "--camera-rate",
    "rate_hz": "--camera-rate",
    "plant": "--plant",
    "controllers": "--controllers",
}


def prepare(args: argparse.Namespace, extra: list[str]) -> Callable[[], int]:
    """Check the plant and arm against the scenario or suite; return the function that runs the comparison."""
    given = [ARM_FLAGS[k] for k in arm_flags(args)] + (["--mount"] if args.mount is not None else [])
    if args.scenario is None and args.suite is None and not given:
        raise UsageError(
            "one of the arguments --scenario --suite is required (or --robot NAME / --urdf FILE / --mount: "
            "the arm's seeded scenario)"
        )
    if args.mount == "eye-to-hand" and (args.scenario is not None or args.suite is not None):
        what = f"--suite {args.suite}" if args.suite is not None else f"--scenario {args.scenario}"
        raise UsageError(
            f"argument --mount: received 'eye-to-hand' with {what}, whose camera is not fixed in the cell; "
            "valid: leave --scenario and --suite out for the arm's seeded eye-to-hand scenario (--seed)"
        )
    free = args.suite is not None or args.scenario in (*catalog.SUITE_TASKS, catalog.TEXTURED_SCENARIO)
    on_free_camera = args.suite is not None or args.scenario in catalog.SUITE_TASKS
    if on_free_camera and args.plant not in (None, "free-camera"):
        what = f"--suite {args.suite}" if args.suite is not None else f"the suite's task {args.scenario}"
        raise UsageError(
            f"argument --plant: received {args.plant!r}; {what} runs on the free camera: valid values are "
            "free-camera (the default)"
        )
    if free and given:
        what = f"--suite {args.suite}" if args.suite is not None else f"--scenario {args.scenario}"
        raise UsageError(
            f"argument {given[0]}: {what} runs on the free camera, without an arm; valid: an arm scenario "
            f"({', '.join(catalog.SCENARIOS)} on the IRB 4600, or no --scenario: the arm's seeded scenario)"
        )
    if args.seed is not None and (args.scenario is not None or args.suite is not None):
        raise UsageError(
            "argument --seed: the seed of the arm's scenario; valid only without --scenario and --suite"
        )
    arm = None if free else resolve_arm(args)
    if arm is not None and args.scenario is None and arm.robot is None:
        raise UsageError(
            f"compare: the arm of {arm.name!r} (a URDF) has no home configuration to draw a seeded "
            "scenario about; valid: a named robot (--robot), or simulate with a --config [scenario] table"
        )
    if arm is not None and args.scenario is not None and arm.robot != "irb4600":
        raise UsageError(
            f"argument --scenario: received {args.scenario!r}, a scenario of the IRB 4600 (its joint "
            f"angles and markers); for the arm {arm.name!r} leave --scenario out: its seeded "
            "scenario (--seed)"
        )

    def run() -> int:
        with flag_errors(args, FLAGS):
            return _run_suite(args) if args.suite is not None else _run_scenario(args, arm)

    return run


def _run_scenario(args: argparse.Namespace, arm: Any) -> int:
    from .. import controllers, scenarios
    from ..analysis import suites
    from ..analysis.compare import compare
    from ..analysis.comparison_figures import save_comparison
    from ..model.camera import default_camera
    from ..simulation.settings import SimulationSettings

    name = args.scenario
    if name == catalog.TEXTURED_SCENARIO:  # the free camera before a textured plane, with pixels
        scenario = scenarios.textured_plane()
        plant = args.plant or "free-camera"
        camera: Any = scenarios.textured_camera()
        settings = suites.suite_settings(args.camera_rate or suites.RATE_HZ)
        duration = args.duration or suites.DURATION_S
        names = args.controllers or suites.twist_controllers()
    elif name in suites.TASK_NAMES:
        scenario = suites.task(name).scenario()
        plant = args.plant or "free-camera"
        camera = suites.suite_camera()
        settings = suites.suite_settings(args.camera_rate or suites.RATE_HZ)
        duration = args.duration or suites.DURATION_S
        names = args.controllers or _without_image_methods(suites.twist_controllers())
    else:
        camera = default_camera()
        seeded = scenarios.eye_to_hand if args.mount == "eye-to-hand" else scenarios.for_arm
        scenario = scenarios.get(name) if name is not None else seeded(arm, args.seed or 0, camera=camera)
        name = scenario.name
        plant = args.plant or "dynamic"
        settings = None if args.camera_rate is None else SimulationSettings(camera_rate_hz=args.camera_rate)
        duration = args.duration or 10.0
        names = args.controllers or _without_image_methods(controllers.names())
    comparison = compare(
        scenario, names, plant=plant, camera=camera, duration=duration, settings=settings, arm=arm
    )
    out = args.out or Path("results") / "compare" / name
    paths = save_comparison(comparison, out, plots=not args.no_plots)
    on = "" if arm is None or arm.robot == "irb4600" else f" of the {arm.name}"
    print(f"{name} on the {plant} plant{on}, {duration:g} s simulated")
    print(comparison.table_markdown(), end="")
    print(f"wrote {', '.join(_relative(p, out) for p in paths.values())} in {out}")
    return 0


def _without_image_methods(names: tuple[str, ...]) -> tuple[str, ...]:
    """The default methods of a scenario without a scene: those that do not servo on its image."""
    from .. import controllers

    return tuple(n for n in names if not controllers.make(n).needs_image)


def _run_suite(args: argparse.Namespace) -> int:
    from ..analysis import suites
    from ..analysis.comparison_figures import save_comparison

    duration = args.duration or suites.DURATION_S
    rate = args.camera_rate or suites.RATE_HZ
    report = suites.run_suite(args.controllers, duration=duration, rate_hz=rate, name=args.suite)
    out = args.out or Path("results") / "compare" / args.suite
    out.mkdir(parents=True, exist_ok=True)
    caption = (
        f"{args.suite}: {len(report.tasks)} tasks x {len(report.controllers)} methods on the free camera, "
        f"normalized monocular camera, four coplanar points, {rate:g} Hz, {duration:g} s per run. "
        "Cell: time to converge (pose within 1 mm and 0.1 deg for good), camera path length; "
        f"otherwise the outcome in bold. † a point left the nominal view (|x| or |y| > "
        f"{suites.NOMINAL_HALF_VIEW:g}) or went behind the camera."
        + "".join(
            f" n/a: {n} does not apply ({why})."
            for n, why in suites.not_applicable(report.controllers).items()
        )
        + "\n\n"
    )
    table = report.table_markdown()
    write_text(out / "suite.md", caption + table)
    write_json(out / "suite.json", report.to_dict())
    for t, comparison in zip(report.tasks, report.comparisons, strict=True):
        save_comparison(comparison, out / t.name, plots=not args.no_plots)
    print(caption + table, end="")
    figures = "" if args.no_plots else ", figures/"
    print(f"wrote suite.md, suite.json and <task>/table.md, table.json{figures} in {out}")
    return 0


def _relative(path: Path, out: Path) -> str:
    try:
        return str(path.relative_to(out))
    except ValueError:
        return str(path)
