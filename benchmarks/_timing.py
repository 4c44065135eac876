"""Shared helpers of the benchmark scripts: per-call timing, summaries, machine description, JSON."""

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


def machine() -> dict[str, Any]:
    """Where and when the figures were measured, and with which packages."""
    from ibvs_youla.simulation.results import software_versions

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "cpu": cpu,
        "cores": os.cpu_count(),
        "load_average_1min": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
        "platform": platform.platform(),
        "versions": software_versions(),
    }


def write_json(path: str | None, report: dict[str, Any]) -> None:
    """Write the report as indented JSON, atomically (no-op without a path)."""
    from ibvs_youla.files import write_text

    if path:
        write_text(path, json.dumps(report, indent=2, sort_keys=False) + "\n")
