"""The ``ibvs-youla`` command line: reproduce, simulate, compare, campaign, robustness, design, view, bench.

``ibvs-youla reproduce --out results`` reruns the paper's Section 7 and prints the
table; ``simulate`` runs one scenario and writes the result, its figures and a
summary; ``compare`` runs several methods on one scenario (or the Gans 2003 task suite)
side by side; ``campaign`` runs every method on seeded random cases (on Dask) and
``campaign-report`` tabulates and plots a campaign folder; ``robustness`` sweeps one
disturbance (pixel noise, rendered images, calibration, model mismatch, latency, saturation)
over a campaign's cases; ``design`` prints (and with ``--plot`` draws) the inner, feedforward
and outer designs; ``view`` plays a run in Meshcat; ``bench`` runs the benchmarks.
``ibvs-youla <command> --help`` lists the options of each.

A command runs in three steps:

1. **parse** (:mod:`.parser`, light: it imports neither numpy nor the simulator, so ``--help``
   and a mistyped option answer at once). A mistyped command, option or choice gets the
   nearest valid one suggested, after the command's usage;
2. **prepare**: the command's module (imported only now) turns the arguments into objects:
   the ``--config`` file, the scenario, the campaign definition, the study...;
3. **run**: it simulates and writes its outputs. Nothing is written before this step (an
   ``--out`` folder is created when the first file is written).

Errors print one line ``ibvs-youla: error: ...`` on stderr, never a traceback. Exit codes:

* 2, an argument or configuration error: what parsing refuses (an unknown option, a value out
  of range, an ``--out`` that is a file or a folder that cannot be created, with the reason),
  every error the library raises for a bad argument while the command prepares (an
  :class:`~ibvs_youla.exceptions.IbvsYoulaError` that is a ``ValueError``: a bad or unknown
  TOML key, a scenario outside the joint limits, an unknown method parameter, a plant the
  controller cannot drive), and, while it runs, the library's refusal of a value given by a
  flag (``--duration`` too long for memory, ``--cases`` too many);
* 1, everything else: errors raised by the library while running (a folder holding another
  campaign, a run that diverged, a damaged result file), the environment (a full disk, an
  unreachable scheduler) and, as ``internal error``, anything unexpected;
* 130 on Ctrl-C.

``--debug`` (anywhere before ``--``) prints the traceback before that line.

Each subcommand lives in the module named after it (:mod:`.reproduce`, :mod:`.simulate`,
:mod:`.compare`, :mod:`.campaign`, :mod:`.campaign_report`, :mod:`.robustness`,
:mod:`.design`, :mod:`.view`, :mod:`.bench`), each with ``prepare(args, extra)`` returning the
function that runs it; :mod:`.arguments` holds the argument types and :mod:`.base` what they
share.
"""

from __future__ import annotations

import importlib
import sys
import traceback
from collections.abc import Callable
from typing import Any

from ..exceptions import IbvsYoulaError
from .base import PROG, UsageError, argument_errors, one_line

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return the exit code (0 success, 1 error, 2 bad arguments, 130 Ctrl-C)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    extra: list[str] = []
    if "--" in argv:  # bench passes what follows "--" to the benchmark scripts
        argv, extra = argv[: argv.index("--")], argv[argv.index("--") + 1 :]
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]
    try:
        args = _parse(argv, extra)
    except UsageError as err:
        return _fail(err, 2, debug=False)  # a parse error has no traceback worth showing
    except SystemExit as exit_:  # --help, --version
        return int(exit_.code or 0)

    def prepare() -> Callable[[], Any]:
        command = importlib.import_module(f".{args.handler}", __name__)
        with argument_errors(args, getattr(command, "FLAGS", {})):
            return command.prepare(args, extra)  # type: ignore[no-any-return]

    job = _guarded(prepare, debug)
    if isinstance(job, int):
        return job
    code = _guarded(job, debug)
    return int(code)


def _parse(argv: list[str], extra: list[str]) -> Any:
    from . import bench
    from .parser import build_parser

    parser = build_parser()
    if argv[:1] == ["bench"]:
        bench.check_own_options(argv[1:])
    args = parser.parse_args(argv)
    if extra and args.command != "bench":
        parser.error(f"{args.command}: unrecognized arguments after --: {' '.join(extra)}")
    return args


def _guarded(step: Callable[[], Any], debug: bool) -> Any:
    """``step()``, or the exit code of the error it raised, printed as one line."""
    try:
        return step()
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
    """Print the traceback (``--debug``), a parse error's usage, then ``ibvs-youla: error: <one line>``."""
    if debug:
        traceback.print_exc(file=sys.stderr)
    usage = getattr(err, "usage", None)
    if usage:
        print(usage, end="" if usage.endswith("\n") else "\n", file=sys.stderr)
    print(
        f"{PROG}: error: {one_line(err) if isinstance(err, BaseException) else ' '.join(err.split())}",
        file=sys.stderr,
    )
    return code
