"""``ibvs-youla robustness``: one disturbance axis swept over the same seeded cases, every method.

``ibvs-youla robustness --axis noise --cases 30 --out runs/noise`` runs one campaign per value
of the axis (default sweep, or ``--values``) on the same cases of ``--family``, on this
machine's cores (one local cluster for the whole study) or ``--scheduler``, each in
``OUT/<axis>=<value>/`` (resumable: the same command skips what is stored), then writes
``OUT/table.md``, ``OUT/table.json`` and ``OUT/figures/robustness_<axis>.png``: success with
95 % Wilson intervals, final pose error and time to reach against the value, a line per
method. Axes and their levels: :mod:`ibvs_youla.campaign.robustness`.

Argument errors (an unknown axis, no values, a negative noise, latency or scale, a fractional
latency, an axis that does not apply to the plant, such as ``mismatch`` off the dynamic arm,
``--feedforward smooth`` without ``ff+fb``, an unknown controller) exit with 2 and write
nothing; a folder holding another study or campaign, an unreachable scheduler exit with 1.
``--axis images`` renders every frame and detects the markers (7-8 ms a frame at VGA: a 20 s arm
run at 100 Hz takes 14-16 s on a quiet core); it needs a camera with pixels (not the free
families' normalized camera).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import Any

from .base import PROG, UsageError, flag_errors
from .campaign import FLAGS as CAMPAIGN_FLAGS
from .campaign import quiet_client_log

FLAGS = {**CAMPAIGN_FLAGS, "values": "--values", "tolerance": "--tolerance", "axis": "--axis"}


def prepare(args: argparse.Namespace, extra: list[str]) -> Callable[[], int]:
    """The study from the arguments, checked (axis values, tolerance, campaign); return its runner."""
    from ..campaign.definition import FAMILY_DEFAULTS, methods_for_plant
    from ..campaign.robustness import RobustnessStudy
    from ..campaign.robustness_report import check_tolerance
    from ..exceptions import InvalidParameterError

    if args.scheduler is not None and args.workers is not None:
        raise UsageError("robustness: --workers sets the local cluster; with --scheduler the cluster's run")
    plant = args.plant or FAMILY_DEFAULTS[args.family]["plant"]
    names = args.controllers
    if names is None:
        names = methods_for_plant(plant, args.family)
    params = {}
    if args.feedforward == "smooth":
        if "ff+fb" not in names:
            raise UsageError("robustness: --feedforward smooth is ff+fb's option; add ff+fb to --controllers")
        params = {"ff+fb": {"feedforward": "smooth"}}
    campaign = {
        "family": args.family,
        "cases": args.cases,
        "controllers": names,
        "seed": args.seed,
        "plant": plant,
        "camera": args.camera,
        "duration": args.duration,
        "difficulty": args.difficulty,
        "controller_params": params,
    }
    study = RobustnessStudy(args.axis, args.values, campaign)
    try:
        tolerance = check_tolerance(args.tolerance)
    except InvalidParameterError:
        raise UsageError(
            f"argument --tolerance: received {','.join(args.tolerance)!r}; valid: MM,DEG, two finite numbers "
            "> 0 (e.g. 1,0.1)"
        ) from None
    return lambda: _run(args, study, tolerance)


def _run(args: argparse.Namespace, study: Any, tolerance: tuple[float, float]) -> int:
    """Run the study, write its report, print the table; return 0 (1 when runs could not be stored)."""
    from ..campaign.robustness import run_study
    from ..campaign.robustness_report import write_study_report

    quiet_client_log()

    def done(value: float, summary: Any) -> None:
        print(
            f"{args.axis} = {value:g}: {summary.stored_before} runs stored before, {summary.ran} run "
            f"({summary.errors} errors)",
            file=sys.stderr,
        )

    try:
        with flag_errors(args, FLAGS):
            summaries = run_study(
                study,
                args.out,
                scheduler=args.scheduler,
                workers=args.workers,
                progress=not args.no_progress,
                on_campaign=done,
                run_timeout=args.run_timeout,
            )
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted; rerun the same command to resume", file=sys.stderr)
        return 130
    paths = write_study_report(args.out, tolerance=tolerance)
    print(paths["table.md"].read_text(), end="")
    print(f"wrote {', '.join(str(p.relative_to(args.out)) for p in paths.values())} in {args.out}")
    not_stored = sum(s.not_stored for _, s in summaries)
    if not_stored:
        print(
            f"{PROG}: error: {not_stored} runs failed on their workers and were not stored; "
            "rerun the same command to retry them",
            file=sys.stderr,
        )
        return 1
    return 0
