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
import logging
import sys
from typing import Any

from .base import PROG, UsageError, one_line


def value_list(text: str) -> tuple[str, ...]:
    """``--values v1,v2,...``: the raw values, checked against the axis later (argparse type)."""
    values = tuple(v.strip() for v in text.split(",") if v.strip())
    if not values:
        raise argparse.ArgumentTypeError(f"received {text!r}; valid: one or more comma-separated values")
    return values


def tolerance_pair(text: str) -> tuple[float, float]:
    """``--tolerance MM,DEG``: two finite numbers > 0 (argparse type)."""
    from ..campaign.robustness_report import check_tolerance
    from ..exceptions import InvalidParameterError

    try:
        return check_tolerance(text.split(","))
    except InvalidParameterError:
        raise argparse.ArgumentTypeError(
            f"received {text!r}; valid: MM,DEG, two finite numbers > 0 (e.g. 1,0.1)"
        ) from None


def configure(parser: argparse.ArgumentParser, positive: Any) -> None:
    """Add the arguments of ``robustness`` to its subparser (and set ``func`` to :func:`run`)."""
    from .. import controllers
    from ..campaign.cases import FAMILIES
    from ..campaign.robustness_axes import AXES, value_label
    from ..campaign.spec import CAMERA_KINDS
    from ..simulation.simulate import PLANTS
    from . import campaign, compare

    defaults = "; ".join(f"{a.name} {','.join(value_label(v) for v in a.defaults)}" for a in AXES.values())
    parser.add_argument("--axis", choices=tuple(AXES), required=True, help="the disturbance to sweep")
    parser.add_argument(
        "--values",
        type=value_list,
        metavar="V1,V2,...",
        help=f"the sweep (defaults: {defaults}); noise in px, images in grey levels of sensor noise, "
        "calibration and mismatch as levels, latency in camera frames, saturation as a fraction of "
        "the arm's limits (inf: none)",
    )
    parser.add_argument("--cases", type=campaign.count(1), default=20, metavar="N", help="cases (default 20)")
    parser.add_argument(
        "--controllers",
        type=compare.controller_list,
        metavar="A,B,...",
        help=f"comma-separated, from {', '.join(controllers.names())} (default: every one the plant takes)",
    )
    parser.add_argument("--family", choices=FAMILIES, default="arm-physical", help="default arm-physical")
    parser.add_argument("--plant", choices=PLANTS, help="default: the family's (dynamic or free-camera)")
    parser.add_argument("--camera", choices=CAMERA_KINDS, help="default: the family's")
    parser.add_argument("--duration", type=positive, metavar="S", help="simulated time per run [s]")
    parser.add_argument("--seed", type=campaign.seed, default=0, metavar="S", help="integer >= 0 (default 0)")
    parser.add_argument("--difficulty", type=positive, default=1.0, metavar="X", help="default 1")
    parser.add_argument(
        "--feedforward",
        choices=("paper", "smooth"),
        default="paper",
        help="ff+fb's feedforward: the paper's 1 ms step filter, or the smooth minimum-jerk one within "
        "half the speed limits (default paper)",
    )
    parser.add_argument(
        "--tolerance",
        type=tolerance_pair,
        default=(1.0, 0.1),
        metavar="MM,DEG",
        help="final pose error that counts as a success (default 1,0.1: the campaign's 'reached')",
    )
    parser.add_argument("--out", type=_path, required=True, metavar="DIR", help="study folder")
    parser.add_argument(
        "--scheduler",
        type=campaign.scheduler_address,
        metavar="ADDRESS",
        help="an existing Dask scheduler (default: one local cluster for the whole study)",
    )
    parser.add_argument(
        "--workers",
        type=campaign.count(0),
        metavar="K",
        help="processes of the local cluster (default: one per core; 0 runs in this process)",
    )
    parser.add_argument(
        "--run-timeout",
        type=positive,
        default=600.0,
        metavar="S",
        help="longest run on a worker [s]: then run again elsewhere, and stored as a timeout if late again "
        "(default 600)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    parser.set_defaults(func=run)


def _path(text: str) -> Any:
    from pathlib import Path

    return Path(text)


def run(args: argparse.Namespace, extra: list[str] | None = None) -> int:
    """Run the study, write its report, print the table; return 0 (1 when runs could not be stored)."""
    from ..campaign.definition import FAMILY_DEFAULTS, methods_for_plant
    from ..campaign.robustness import RobustnessStudy, run_study
    from ..campaign.robustness_report import write_study_report
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
    try:
        study = RobustnessStudy(args.axis, args.values, campaign)
    except InvalidParameterError as err:
        raise UsageError(f"robustness: {one_line(err)}") from None
    logging.getLogger("distributed.client").setLevel(logging.CRITICAL)

    def done(value: float, summary: Any) -> None:
        print(
            f"{args.axis} = {value:g}: {summary.stored_before} runs stored before, {summary.ran} run "
            f"({summary.errors} errors)",
            file=sys.stderr,
        )

    try:
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
    paths = write_study_report(args.out, tolerance=args.tolerance)
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
