"""``ibvs-youla campaign-report DIR``: the table and figures of a campaign's rows.

Reads ``DIR/rows`` (the Parquet dataset that ``ibvs-youla campaign --out DIR`` writes) and
writes ``table.md``, ``table.json`` and ``figures/<family>_<figure>.png`` to ``--out``
(default ``DIR/report``): per method, the rate of each outcome with its 95 % Wilson interval,
the time to reach (median and 90th percentile), the path ratio and the compute time; success
against difficulty, the time-to-reach distribution and, for the free-camera families, the
outcome of every start pose over the two ``--axes`` (see :mod:`ibvs_youla.campaign.report`).
A DIR without rows is a one-line error (exit 1).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from .base import PROG, one_line


def prepare(args: argparse.Namespace, extra: list[str]) -> Callable[[], int]:
    """Nothing to check beyond parsing (the folder's rows are read when it runs); return the writer."""
    return lambda: run(args)


def run(args: argparse.Namespace) -> int:
    """Write the report of ``args.dir`` to ``args.out``; print the table; return 0 (1 without rows)."""
    from ..campaign.report import read_rows, write_report
    from ..exceptions import IbvsYoulaError

    try:
        rows = read_rows(args.dir)
    except IbvsYoulaError as err:
        print(f"{PROG}: error: campaign-report: {one_line(err)}", file=sys.stderr)
        return 1
    out = args.out if args.out is not None else args.dir / "report"
    paths = write_report(rows, out, args.axes)
    print(paths["table.md"].read_text(), end="")
    names = ", ".join(str(p.relative_to(out)) for p in paths.values())
    print(f"wrote {names} in {out}")
    return 0
