"""The benchmark scripts run and write the JSON keys other tools read (numbers only; no timing asserted)."""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def load(name):
    sys.path.insert(0, str(BENCHMARKS))  # as `ibvs-youla bench` does: the scripts import _timing
    try:
        spec = importlib.util.spec_from_file_location(name, BENCHMARKS / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(BENCHMARKS))
    return module


def finite_positive(x):
    return isinstance(x, float) and math.isfinite(x) and x > 0.0


@pytest.mark.slow
def test_outer_loop_benchmark_writes_its_keys(tmp_path):
    out = tmp_path / "outer.json"
    report = load("bench_outer_loop").main(
        ["--configs", "4", "--repeats", "1", "--rebuilds", "1", "--json", str(out)]
    )
    saved = json.loads(out.read_text())
    keys = [
        "update_median_us",
        "update_p95_us",
        "floor_median_us",
        "ratio_to_floor",
        "rebuild_ratio",
        "features_median_us",
        "pose_ik_median_us",
        "jacobian_median_us",
        "svd_median_us",
        "state_update_median_us",
    ]
    for key in keys:
        assert finite_positive(saved[key]), key
    assert saved["ratio_to_floor"] == pytest.approx(saved["update_median_us"] / saved["floor_median_us"])
    assert saved["stats"]["update"]["n"] == 4
    assert saved["machine"]["cores"] >= 1 and saved["machine"]["date"]
    assert report["update_median_us"] == saved["update_median_us"]


@pytest.mark.slow
def test_simulation_benchmark_writes_realtime_factors(tmp_path):
    out = tmp_path / "simulation.json"
    load("bench_simulation").main(["--duration", "0.02", "--repeats", "1", "--json", str(out)])
    saved = json.loads(out.read_text())
    assert set(saved["realtime_factor"]) == {"paper-1", "paper-2"}
    for factors in saved["realtime_factor"].values():
        assert set(factors) == {"paper", "two-rate"}
        assert all(finite_positive(v) for v in factors.values())
    for case in saved["cases"].values():
        assert case["status"] == "complete"
        assert sum(case["split"]["fraction"].values()) == pytest.approx(1.0)
