"""Shared helpers of the benchmark scripts: per-call timing, summaries, machine and load, JSON history."""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

perf_counter = time.perf_counter
HISTORY_MAX = 200  # runs kept in a report's history (oldest dropped first)
Headline = Callable[[dict[str, Any]], dict[str, Any]]  # a report's key figures, for its history


def count(text: str) -> int:
    """An argparse type for counts (repeats, configurations, cases): an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"received {text!r}; valid values are integers >= 1")
    return value


def seconds(text: str) -> float:
    """An argparse type for a simulated duration: a finite number > 0 [s]."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 < value < math.inf:
        raise argparse.ArgumentTypeError(f"received {text!r}; valid values are finite numbers > 0 [s]")
    return value


def timed(fn: Callable[..., Any], *args: Any) -> tuple[float, Any]:
    """(seconds, result) of one call."""
    t0 = perf_counter()
    out = fn(*args)
    return perf_counter() - t0, out


def summary_us(seconds: list[float] | np.ndarray) -> dict[str, float]:
    """Median, 5th/95th percentile and count of per-call times, in microseconds."""
    us = np.asarray(seconds, dtype=float) * 1e6
    return {
        "median_us": float(np.median(us)),
        "p05_us": float(np.percentile(us, 5)),
        "p95_us": float(np.percentile(us, 95)),
        "n": int(us.size),
    }


def load_average() -> list[float] | None:
    """The machine's 1, 5 and 15 minute load averages (None where the OS has none)."""
    return [round(x, 2) for x in os.getloadavg()] if hasattr(os, "getloadavg") else None


def _busy_jiffies() -> float | None:
    """CPU time [s] the whole machine spent busy since boot (/proc/stat; None elsewhere)."""
    try:
        fields = Path("/proc/stat").read_text().splitlines()[0].split()[1:]
    except (OSError, IndexError):
        return None
    ticks = [float(x) for x in fields]
    idle = ticks[3] + (ticks[4] if len(ticks) > 4 else 0.0)  # idle + iowait
    steal = ticks[7] if len(ticks) > 7 else 0.0
    return (sum(ticks[:8]) - idle - steal) / os.sysconf("SC_CLK_TCK")


class CpuShare:
    """Cores used, during a timed section, by this process (and its children) and by everything else.

    ``other_cores`` is the machine's busy CPU time minus this process's, over the wall time: the
    other jobs sharing the cores (other sessions, here). Figures measured while it is large are
    slower than the machine can do; the reports keep it beside them.
    """

    def __init__(self) -> None:
        self._start = self._sample()

    @staticmethod
    def _sample() -> tuple[float, float, float | None]:
        t = os.times()
        return perf_counter(), t.user + t.system + t.children_user + t.children_system, _busy_jiffies()

    def stop(self) -> dict[str, float | None]:
        """``wall_s``, ``own_cores`` and ``other_cores`` since construction."""
        end = self._sample()
        wall = end[0] - self._start[0]
        own = (end[1] - self._start[1]) / wall
        if end[2] is None or self._start[2] is None:
            return {"wall_s": wall, "own_cores": own, "other_cores": None}
        busy = (end[2] - self._start[2]) / wall
        return {"wall_s": wall, "own_cores": own, "other_cores": max(0.0, busy - own)}


def calibration_ms(repeats: int = 5) -> float:
    """The fastest of ``repeats`` runs of a fixed interpreter workload [ms]: how fast the machine is now.

    A pure-Python loop of 200,000 float operations (about 10 ms on a quiet 2.6 GHz EPYC core). It
    moves with the hypervisor's share and the other jobs as the benchmarks do, so a history entry
    with a larger calibration than another was taken on a slower machine, whatever the load says.
    """
    best = float("inf")
    for _ in range(repeats):
        t0 = perf_counter()
        x = 0.0
        for i in range(200_000):
            x = x * 0.5 + i
        best = min(best, perf_counter() - t0)
    return best * 1e3


def machine() -> dict[str, Any]:
    """Where and when the figures were measured, with which packages, and how busy the machine was."""
    from ibvs_youla._jit import jit_available
    from ibvs_youla.simulation.results import software_versions

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = load_average()
    versions = software_versions()
    try:
        import numba

        versions["numba"] = numba.__version__
    except ImportError:
        versions["numba"] = "not installed"
    return {
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "cpu": cpu,
        "cores": os.cpu_count(),
        "load_average_1min": load[0] if load else None,
        "load_average": load,
        "calibration_ms": calibration_ms(),
        "compiled_kernels": jit_available(),
        "platform": platform.platform(),
        "versions": versions,
    }


def write_json(path: str | None, report: dict[str, Any], headline: Headline | None = None) -> None:
    """Write the report as indented JSON, keeping the file's history (no-op without a path).

    The file holds the latest report at its top level (the keys other tools read) and a
    ``history`` list of every run's date, load and headline figures (``headline(report)``), oldest
    first, this run's last, so that a regression shows. A file written before histories existed
    contributes its own report's headline as the first entry. Written to a temporary name, then
    renamed, so an interrupted run leaves the previous file.
    """
    if not path:
        return
    file = Path(path)
    history: list[dict[str, Any]] = []
    if file.exists():
        try:
            previous = json.loads(file.read_text())
        except (OSError, ValueError):
            previous = None  # unreadable: a new history begins (the file is replaced)
        if isinstance(previous, dict):
            history = [h for h in previous.get("history", []) if isinstance(h, dict)]
            if not history and isinstance(previous.get("machine"), dict):
                history = [_entry(previous, headline)]

    history = [*history, _entry(report, headline)][-HISTORY_MAX:]
    from ibvs_youla.files import write_text

    write_text(file, json.dumps({**report, "history": history}, indent=2, sort_keys=False) + "\n")


def _entry(report: dict[str, Any], headline: Headline | None) -> dict[str, Any]:
    """One history entry: the run's date, load and headline figures (what a headline cannot read: None)."""
    machine_ = report.get("machine", {})
    entry: dict[str, Any] = {
        "date": machine_.get("date"),
        "load_average": machine_.get("load_average") or [machine_.get("load_average_1min")],
        "calibration_ms": machine_.get("calibration_ms"),
        "compiled_kernels": machine_.get("compiled_kernels"),
    }
    if headline is not None:
        try:
            entry.update(headline(report))
        except (KeyError, TypeError, IndexError):  # an older report without some key
            entry["headline"] = None
    return entry
