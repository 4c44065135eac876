"""Simulated seconds per wall-clock second of both paper scenarios, and where the time goes.

Two settings per scenario, controller ``"ff+fb"``, adaptive outer loop (the paper's proposal):

* ``paper``: the paper's rates, joint loop and camera/outer loop both at 1 kHz
  (``SimulationSettings.paper()``), every sample recorded;
* ``two-rate``: joint loop at 1 kHz, camera and outer loop at 100 Hz (the ZED's fastest mode),
  every sample recorded.

``realtime_factor`` = simulated time / median wall time of ``simulate(...)`` (arm and camera
built beforehand; the run's own set-up is included). The cost split is the servo loop's own
phase timing of the same runs (``result.metadata["phase_seconds"]``): the plant step (RK4 of
Eq. (29): four ABA calls, divergence checks), the camera frame (true camera pose, sensor and
the adaptive outer-loop update), and the joint-loop control (feedforward, the inner Youla loop
and feedback linearization M(q) v + h in one RNEA pass, recording).

Run: ``python benchmarks/bench_simulation.py --json simulation.json``.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np

try:  # imported as benchmarks.bench_simulation
    from ._timing import count, machine, perf_counter, seconds, write_json
except ImportError:  # run as a script
    from _timing import count, machine, perf_counter, seconds, write_json

import ibvs_youla
from ibvs_youla import scenarios
from ibvs_youla.model.arm import Arm
from ibvs_youla.model.camera import StereoCamera
from ibvs_youla.simulation.settings import SimulationSettings

SETTINGS = {"paper": SimulationSettings.paper(), "two-rate": SimulationSettings(camera_rate_hz=100.0)}


def _split(result: Any, wall: float, settings: SimulationSettings) -> dict:
    """Per-step cost of dynamics, outer loop and joint-loop control from the loop's phase timing."""
    phases = result.metadata["phase_seconds"]
    steps = len(result.t) * settings.record_every  # ticks 0..n recorded every record_every
    n_ticks = round(result.metadata["duration"] * settings.joint_rate_hz)
    frames = len(result.frame_t)
    total = sum(phases.values())
    return {
        "wall_s": wall,
        "dynamics_us_per_step": phases["plant"] / n_ticks * 1e6,
        "outer_us_per_frame": phases["frame"] / frames * 1e6,
        "joint_control_us_per_step": phases["control"] / (n_ticks + 1) * 1e6,
        "fraction": {
            "dynamics": phases["plant"] / total,
            "outer": phases["frame"] / total,
            "joint_control": phases["control"] / total,
        },
        "ticks": n_ticks + 1,
        "recorded": steps,
    }


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmark, print a summary, write JSON if asked; return the report."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="FILE", help="write the report here")
    ap.add_argument("--duration", type=seconds, default=5.0, help="simulated seconds per run (default 5)")
    ap.add_argument("--repeats", type=count, default=3, help="timed runs per case (default 3)")
    args = ap.parse_args(argv)

    arm, camera = Arm.irb4600(), StereoCamera.zed2()
    ibvs_youla.simulate(scenarios.paper(1), duration=0.05, arm=arm, camera=camera)  # warm-up
    realtime: dict[str, dict[str, float]] = {}
    cases: dict[str, dict[str, Any]] = {}
    for sc in scenarios.paper_scenarios():
        realtime[sc.name] = {}
        for label, settings in SETTINGS.items():
            walls, results = [], []
            for _ in range(args.repeats):
                t0 = perf_counter()
                result = ibvs_youla.simulate(
                    sc, "ff+fb", True, args.duration, settings=settings, arm=arm, camera=camera
                )
                walls.append(perf_counter() - t0)
                results.append(result)
            median = int(np.argsort(walls)[len(walls) // 2])
            wall = walls[median]
            realtime[sc.name][label] = args.duration / wall
            cases[f"{sc.name}/{label}"] = {
                "wall_median_s": wall,
                "wall_s": walls,
                "status": result.metadata["status"],
                "update_time_median_us": float(np.median(result.update_time) * 1e6),
                "split": _split(results[median], wall, settings),
            }
            c = cases[f"{sc.name}/{label}"]
            f = c["split"]["fraction"]
            print(
                f"{sc.name:8} {label:9} {realtime[sc.name][label]:6.2f}x real time "
                f"(wall {wall:.3f} s for {args.duration:g} s); split: dynamics {f['dynamics']:.0%} "
                f"({c['split']['dynamics_us_per_step']:.1f} us/step), outer {f['outer']:.0%} "
                f"({c['split']['outer_us_per_frame']:.1f} us/frame), "
                f"joint control {f['joint_control']:.0%} "
                f"({c['split']['joint_control_us_per_step']:.1f} us/step)"
            )
    report = {
        "benchmark": "simulation",
        "realtime_factor": realtime,
        "cases": cases,
        "settings": {
            "duration_s": args.duration,
            "repeats": args.repeats,
            "controller": "ff+fb",
            "adaptive": True,
            "camera_rate_hz": {k: s.joint_rate_hz / s.camera_every for k, s in SETTINGS.items()},
        },
        "machine": machine(),
    }
    write_json(args.json, report)
    return report


if __name__ == "__main__":
    main(sys.argv[1:])
