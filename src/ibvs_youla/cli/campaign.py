"""``ibvs-youla campaign``: every method on the same seeded cases, locally or on a Dask cluster.

``ibvs-youla campaign --cases 200 --controllers ff+fb,fb,ibvs-current --out runs/arm`` draws 200
cases of ``--family`` (default ``arm-physical``) from ``--seed`` and runs each with every
controller on this machine's cores (a ``LocalCluster`` of one-thread processes), or on an
existing cluster with ``--scheduler tcp://HOST:PORT``. Rows go to ``DIR/rows`` (Parquet) as they
finish; the same command resumes an interrupted campaign. The defaults per family, what a
family may run on, and the storage are those of :mod:`ibvs_youla.campaign.runner` and
:mod:`ibvs_youla.campaign.storage`.

Argument errors (an unknown controller or family, a free family on an arm plant or an arm
family on the free camera, the paper's joint-commanding controllers on the free camera, a
seed that is not an integer, ``--workers`` with ``--scheduler``) exit with 2; a folder holding
another campaign, an unreachable scheduler, or runs the cluster failed to return exit with 1.
Nothing is written to ``--out`` before the arguments, the folder and the scheduler are checked.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable
from typing import Any

from .base import PROG, UsageError, flag_errors

# library argument name -> flag, for the refusals the campaign makes only when it runs
FLAGS = {
    "n": "--cases",
    "cases": "--cases",
    "seed": "--seed",
    "difficulty": "--difficulty",
    "duration": "--duration",
    "workers": "--workers",
    "batch_rows": "--batch-rows",
    "run_timeout": "--run-timeout",
    "plant": "--plant",
    "camera": "--camera",
    "family": "--family",
    "controllers": "--controllers",
}


def prepare(args: argparse.Namespace, extra: list[str]) -> Callable[[], int]:
    """The campaign's definition from the arguments, checked; return the function that runs it."""
    from ..campaign.definition import FAMILY_DEFAULTS, CampaignDefinition, methods_for_plant

    if args.scheduler is not None and args.workers is not None:
        raise UsageError("campaign: --workers sets the local cluster; with --scheduler the cluster's run")
    plant = args.plant or FAMILY_DEFAULTS[args.family]["plant"]
    names = args.controllers
    if names is None:
        names = methods_for_plant(plant, args.family)
    definition = CampaignDefinition(
        family=args.family,
        cases=args.cases,
        controllers=names,
        seed=args.seed,
        plant=plant,
        camera=args.camera,
        duration=args.duration,
        difficulty=args.difficulty,
    )
    return lambda: _run(args, definition)


def quiet_client_log() -> None:
    """Silence the Dask client's log (its reconnection attempts' tracebacks): errors are one line here.

    Dask's import sets its loggers' levels from its configuration (``distributed.client``: warning),
    so it is imported first: set before it, the level would be reset (the parser no longer imports
    it, so that it stays light).
    """
    import distributed  # noqa: F401

    logging.getLogger("distributed.client").setLevel(logging.CRITICAL)


def _run(args: argparse.Namespace, definition: Any) -> int:
    """Run the campaign, print what was stored; return 0, or 1 when runs could not be stored."""
    from ..campaign.runner import run_campaign
    from ..campaign.storage import read_rows

    quiet_client_log()
    try:
        with flag_errors(args, FLAGS):
            summary = run_campaign(
                definition,
                args.out,
                scheduler=args.scheduler,
                workers=args.workers,
                progress=not args.no_progress,
                series=args.series,
                batch_rows=args.batch_rows,
                run_timeout=args.run_timeout,
            )
    except KeyboardInterrupt:  # Ctrl-C or SIGTERM: the returned rows were flushed
        stored = len(read_rows(args.out)) if (args.out / "rows").is_dir() else 0
        print(
            f"{PROG}: interrupted: {stored} of {definition.runs} runs stored in {args.out}; "
            "rerun the same command to resume",
            file=sys.stderr,
        )
        return 130
    d = definition
    where = f"scheduler {args.scheduler}" if args.scheduler else f"{summary.workers} local workers"
    if args.workers == 0:
        where = "this process"
    print(
        f"{d.family}: {d.cases} cases x {len(d.controllers)} methods = {d.runs} runs on the {d.plant} plant "
        f"({d.camera['kind']} camera, {d.duration:g} s, seed {d.seed})"  # type: ignore[index]
    )
    if summary.ran:
        print(
            f"  {summary.stored_before} stored before, {summary.ran} run on {where} in {summary.run_s:.1f} s "
            f"({summary.runs_per_minute:.0f} runs/min), {summary.errors} errors; rows in {args.out / 'rows'}"
        )
    else:
        print(
            f"  {summary.stored_before} of {d.runs} runs stored, nothing to run; rows in {args.out / 'rows'}"
        )
    if summary.other_rows:
        print(f"  note: {summary.other_rows} stored rows are no run of this definition (another version?)")
    rows = read_rows(args.out)
    if len(rows):
        table = rows.pivot_table(index="controller", columns="outcome", values="key", aggfunc="count")
        table = table.reindex(list(d.controllers)).fillna(0).astype(int)
        print(table.to_string())
    if summary.not_stored:
        print(
            f"{PROG}: error: {summary.not_stored} runs failed on their workers and were not stored "
            f"(first: {summary.first_failure}); rerun the same command to retry them",
            file=sys.stderr,
        )
        return 1
    return 0
