"""Time the command line's answers that need no simulation: help and argument errors, each a new process.

What a user waits for before ``ibvs-youla`` says anything: ``--help``, a command's ``--help``, a
mistyped command or option (answered with the nearest valid one and the usage) and a bad value.
Each call runs as the user runs it: a new process of the installed console script
(``<venv>/bin/ibvs-youla``; ``python -c 'from ibvs_youla.cli import main; ...'`` where it is
missing), its wall time measured from start to exit with ``time.perf_counter``; its exit code is
checked (0 for help, 2 for errors). Python's bytecode caches are written by a warm-up round
(``PYTHONDONTWRITEBYTECODE`` is removed from the calls' environment), as after a first run. Every
round runs each call once, in the same order, so all see the same load; medians and 95th
percentiles are reported.

References, timed in the same rounds: ``interpreter`` (``python -c pass``: the floor every call
pays, the interpreter's start) and ``eager_imports`` (one process importing what the parser
imported before it was made light: the controller registry, the simulator, the scenarios, the
Gans suite and the campaign modules; python-control, SciPy, Pinocchio, Numba, pandas...). The
target is every call's median under 0.5 s; ``ratio_eager_to_help`` = eager_imports / help.

Run: ``python benchmarks/bench_cli.py --json reports/cli.json``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

try:  # imported as benchmarks.bench_cli
    from ._timing import CpuShare, count, machine, perf_counter, write_json
except ImportError:  # run as a script
    from _timing import CpuShare, count, machine, perf_counter, write_json

TARGET_MS = 500.0  # every call's median [ms]
# name -> (arguments, expected exit code)
CALLS: dict[str, tuple[list[str], int]] = {
    "help": (["--help"], 0),
    "simulate_help": (["simulate", "--help"], 0),
    "campaign_help": (["campaign", "--help"], 0),
    "robustness_help": (["robustness", "--help"], 0),
    "mistyped_command": (["simulat"], 2),
    "mistyped_option": (["simulate", "--scenaro", "paper-1"], 2),
    "bad_value": (["simulate", "--scenario", "paper-1", "--duration", "-1"], 2),
    "bad_scheduler": (["campaign", "--cases", "1", "--out", "OUT", "--scheduler", "tcp://host:99999"], 2),
}
EAGER = (
    "import ibvs_youla.controllers, ibvs_youla.scenarios, ibvs_youla.simulation.simulate, "
    "ibvs_youla.analysis.suites, ibvs_youla.campaign.cases, ibvs_youla.campaign.spec, "
    "ibvs_youla.campaign.report, ibvs_youla.campaign.robustness_axes"
)


def command() -> tuple[list[str], str]:
    """The command that starts the CLI, and how it was found."""
    script = Path(sys.executable).with_name("ibvs-youla")
    if script.is_file():
        return [str(script)], "console script"
    code = "import sys; from ibvs_youla.cli import main; sys.exit(main())"
    return [sys.executable, "-c", code], "python -c"


# as a user's shell runs it: Python writes its bytecode caches (the warm-up round does), so no call
# compiles the sources again (PYTHONDONTWRITEBYTECODE, if set here, would make every call do that)
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def _timed_run(argv: list[str], expected: int | None) -> float:
    t0 = perf_counter()
    done = subprocess.run(
        argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, check=False, env=ENV
    )
    elapsed = perf_counter() - t0
    if expected is not None and done.returncode != expected:
        raise RuntimeError(f"{' '.join(argv)} exited {done.returncode}, not {expected}: {done.stderr}")
    return elapsed


def _summary_ms(seconds: list[float]) -> dict[str, float]:
    ms = sorted(1e3 * s for s in seconds)
    p95 = ms[min(len(ms) - 1, round(0.95 * (len(ms) - 1)))]
    return {"median_ms": statistics.median(ms), "p95_ms": p95, "n": len(ms)}


def headline(report: dict[str, Any]) -> dict[str, Any]:
    """The figures a history entry keeps."""
    return {
        "help_median_ms": report["calls"]["help"]["median_ms"],
        "slowest_median_ms": report["slowest"]["median_ms"],
        "ratio_eager_to_help": report["ratio_eager_to_help"],
    }


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmark, print a summary, write JSON if asked; return the report."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="FILE", help="write the report here")
    ap.add_argument("--repeats", type=count, default=15, help="rounds over every call (default 15)")
    ap.add_argument(
        "--no-eager", action="store_true", help="skip the eager_imports reference (seconds a call)"
    )
    args = ap.parse_args(argv)

    cli, how = command()
    with tempfile.TemporaryDirectory(prefix="bench-cli-") as scratch:
        runs = {
            name: ([*cli, *(a.replace("OUT", str(Path(scratch) / "out")) for a in arguments)], code)
            for name, (arguments, code) in CALLS.items()
        }
        runs["interpreter"] = ([sys.executable, "-c", "pass"], 0)
        if not args.no_eager:
            runs["eager_imports"] = ([sys.executable, "-c", EAGER], 0)
        for argv_, code in runs.values():  # warm-up: the file cache, Python's bytecode caches
            _timed_run(argv_, code)
        times: dict[str, list[float]] = {name: [] for name in runs}
        cpu = CpuShare()
        for _ in range(args.repeats):
            for name, (argv_, code) in runs.items():
                times[name].append(_timed_run(argv_, code))
        share = cpu.stop()

    calls = {name: {"argv": CALLS[name][0], **_summary_ms(times[name])} for name in CALLS}
    slowest = max(calls, key=lambda n: calls[n]["median_ms"])
    reference = {name: _summary_ms(times[name]) for name in ("interpreter", "eager_imports") if name in times}
    report: dict[str, Any] = {
        "benchmark": "cli",
        "machine": machine(),
        "cpu": share,
        "settings": {"repeats": args.repeats, "command": how},
        "calls": calls,
        "reference": reference,
        "slowest": {"call": slowest, "median_ms": calls[slowest]["median_ms"]},
        "ratio_eager_to_help": reference["eager_imports"]["median_ms"] / calls["help"]["median_ms"]
        if "eager_imports" in reference
        else None,
        "targets": {"median_ms_max": TARGET_MS, "met": calls[slowest]["median_ms"] < TARGET_MS},
    }
    print(f"ibvs-youla ({how}), {args.repeats} rounds, median / p95 [ms]:")
    for name, c in {**calls, **reference}.items():
        print(f"  {name:18s} {c['median_ms']:7.0f} / {c['p95_ms']:5.0f}")
    verdict = "met" if report["targets"]["met"] else "NOT met"
    print(f"slowest {slowest}: {calls[slowest]['median_ms']:.0f} ms (target < {TARGET_MS:g} ms: {verdict})")
    write_json(args.json, report, headline)
    return report


if __name__ == "__main__":
    main(sys.argv[1:])
