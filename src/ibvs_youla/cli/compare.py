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
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from ..files import write_text
from .base import UsageError, flag_errors

TEXTURED = "textured-plane"  # --scenario name of scenarios.textured_plane()


def scenario_names() -> tuple[str, ...]:
    """Names ``--scenario`` takes: the named scenarios, the suite's tasks, then the textured plane."""
    from .. import scenarios
    from ..analysis.suites import TASK_NAMES

    return (*scenarios.NAMES, *TASK_NAMES, TEXTURED)


def controller_list(text: str) -> tuple[str, ...]:
    """``--controllers a,b,c``: registered names, comma-separated, each once (argparse type)."""
    from .. import controllers

    names = tuple(n.strip() for n in text.split(","))
    valid = controllers.names()
    unknown = [n for n in names if n not in valid]
    if unknown or len(set(names)) != len(names):
        what = f"unknown {', '.join(repr(n) for n in unknown)}" if unknown else "a name given twice"
        raise argparse.ArgumentTypeError(
            f"received {text!r} ({what}); valid: comma-separated names, each once, from {', '.join(valid)}"
        )
    return names


def run(args: argparse.Namespace, extra: list[str]) -> int:
    """Run the comparison or the suite, write the tables (and figures), print the table; return 0."""
    with flag_errors(
        args, {"duration": "--duration", "camera_rate_hz": "--camera-rate", "rate_hz": "--camera-rate"}
    ):
        if args.suite is not None:
            return _run_suite(args)
        return _run_scenario(args)


def _run_scenario(args: argparse.Namespace) -> int:
    from .. import controllers, scenarios
    from ..analysis import suites
    from ..analysis.compare import compare
    from ..analysis.comparison_figures import save_comparison
    from ..model.camera import default_camera
    from ..simulation.settings import SimulationSettings

    name = args.scenario
    if name == TEXTURED:  # the free camera before a textured plane, as the suite's tasks but with pixels
        scenario = scenarios.textured_plane()
        plant = args.plant or "free-camera"
        camera = scenarios.textured_camera()
        settings = suites.suite_settings(args.camera_rate or suites.RATE_HZ)
        duration = args.duration or suites.DURATION_S
        names = args.controllers or suites.twist_controllers()
    elif name in suites.TASK_NAMES:
        scenario = suites.task(name).scenario()
        plant = args.plant or "free-camera"
        camera: Any = suites.suite_camera()
        settings = suites.suite_settings(args.camera_rate or suites.RATE_HZ)
        duration = args.duration or suites.DURATION_S
        names = args.controllers or _without_image_methods(suites.twist_controllers())
    else:
        scenario = scenarios.get(name)
        plant = args.plant or "dynamic"
        camera = default_camera()
        settings = None if args.camera_rate is None else SimulationSettings(camera_rate_hz=args.camera_rate)
        duration = args.duration or 10.0
        names = args.controllers or _without_image_methods(controllers.names())
    comparison = compare(scenario, names, plant=plant, camera=camera, duration=duration, settings=settings)
    out = args.out or Path("results") / "compare" / name
    paths = save_comparison(comparison, out, plots=not args.no_plots)
    print(f"{name} on the {plant} plant, {duration:g} s simulated")
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

    if args.plant not in (None, "free-camera"):
        raise UsageError(f"compare: --suite runs on the free camera; received --plant {args.plant}")
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
    write_text(out / "suite.json", json.dumps(report.to_dict(), indent=1))
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
