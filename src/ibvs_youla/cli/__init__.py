"""The ``ibvs-youla`` command line: reproduce, simulate, compare, campaign, robustness, design, view, bench.

``ibvs-youla reproduce --out results`` reruns the paper's Section 7 and prints the
table; ``simulate`` runs one scenario and writes the result, its figures and a
summary; ``compare`` runs several methods on one scenario (or the Gans 2003 task suite)
side by side; ``campaign`` runs every method on seeded random cases (on Dask) and
``campaign-report`` tabulates and plots a campaign folder; ``robustness`` sweeps one
disturbance (pixel noise, rendered images, calibration, model mismatch, latency, saturation) over a campaign's
cases; ``design`` prints (and with
``--plot`` draws) the inner, feedforward and outer designs; ``view`` plays a run in
Meshcat; ``bench`` runs the benchmarks.
``ibvs-youla <command> --help`` lists the options of each.

Errors print one line ``ibvs-youla: error: ...`` on stderr, never a traceback: bad arguments
exit with 2 (argparse's convention: an unknown option, a value out of range, an ``--out`` that is
a file), everything else with 1: errors raised by the library (``IbvsYoulaError``: a bad TOML
key, a scenario outside the joint limits, a run too large for memory), the environment (a full
disk, a folder that cannot be written) and, as ``internal error``, anything unexpected.
``--debug`` (anywhere before ``--``) prints the traceback before that line.

The arguments are defined in :mod:`.parser`; each subcommand lives in the module
named after it (:mod:`.reproduce`, :mod:`.simulate`, :mod:`.compare`, :mod:`.campaign`,
:mod:`.campaign_report`, :mod:`.robustness`, :mod:`.design`, :mod:`.view`, :mod:`.bench`),
and :mod:`.base` holds what they share.
"""

from __future__ import annotations

import sys
import traceback

from ..exceptions import IbvsYoulaError
from . import bench
from .base import PROG, UsageError, one_line
from .parser import build_parser

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return the exit code (0 success, 1 error, 2 bad arguments, 130 Ctrl-C)."""
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    extra: list[str] = []
    if "--" in argv:  # bench passes what follows "--" to the benchmark scripts
        argv, extra = argv[: argv.index("--")], argv[argv.index("--") + 1 :]
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]
    try:
        if argv[:1] == ["bench"]:
            bench.check_own_options(argv[1:])
        args = parser.parse_args(argv)
        if extra and args.command != "bench":
            parser.error(f"{args.command}: unrecognized arguments after --: {' '.join(extra)}")
    except UsageError as err:
        return _fail(err, 2, debug=False)  # a parse error has no traceback worth showing
    except SystemExit as exit_:  # --help, --version
        return int(exit_.code or 0)
    try:
        return int(args.func(args, extra))
    except UsageError as err:
        return _fail(err, 2, debug)
    except IbvsYoulaError as err:
        return _fail(err, 1, debug)
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    except OSError as err:  # the environment: a full disk, a folder that cannot be written, ...
        return _fail(err, 1, debug)
    except MemoryError:
        return _fail("out of memory", 1, debug)
    except Exception as err:  # a bug: one line that says how to see more
        hint = "" if debug else "; rerun with --debug for the traceback"
        return _fail(f"internal error ({type(err).__name__}: {err}){hint}", 1, debug)


def _fail(err: BaseException | str, code: int, debug: bool) -> int:
    """Print the traceback (with ``--debug``), then ``ibvs-youla: error: <one line>``; return ``code``."""
    if debug:
        traceback.print_exc(file=sys.stderr)
    print(
        f"{PROG}: error: {one_line(err) if isinstance(err, BaseException) else ' '.join(err.split())}",
        file=sys.stderr,
    )
    return code
