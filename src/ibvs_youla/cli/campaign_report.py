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
from pathlib import Path

from .base import PROG, folder_path, one_line

DEFAULT_AXES = "twist,tilt"


def axes_pair(text: str) -> tuple[str, str]:
    """``--axes a,b``: two different names of ``campaign.report.AXES`` (argparse type)."""
    from ..campaign.report import AXES

    axes = tuple(a.strip() for a in text.split(","))
    if len(axes) != 2 or axes[0] == axes[1] or not set(axes) <= set(AXES):
        raise argparse.ArgumentTypeError(
            f"received {text!r}; valid: two different names, comma-separated, from {', '.join(AXES)}"
        )
    return axes  # type: ignore[return-value]


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``campaign-report`` to its subparser (and set ``func`` to :func:`run`)."""
    from ..campaign.report import AXES

    parser.add_argument("dir", type=Path, metavar="DIR", help="campaign folder (it holds DIR/rows)")
    parser.add_argument("--out", type=folder_path, metavar="OUT", help="report folder (default: DIR/report)")
    parser.add_argument(
        "--axes",
        type=axes_pair,
        metavar="A,B",
        default=axes_pair(DEFAULT_AXES),
        help="two coordinates of the start camera in the target camera's frame for the free-camera "
        f"outcome maps, from {', '.join(AXES)} (default: {DEFAULT_AXES})",
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace, extra: list[str] | None = None) -> int:
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
