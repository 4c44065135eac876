"""Many runs at once: a case-frame of simulate_batch beside one iteration of ViSP 3.5's C++ loop, one core.

The work is ViSP's ``tutorial-ibvs-4pts`` (the case of ``bench_peers.py``: four coplanar points, the
normalized camera, the free camera at 40 ms, classical IBVS with L at the current features,
lambda = 0.5, the depths measured as ViSP's simulator gives them), from ``--cases`` N start poses:
the tutorial's, and N - 1 seeded ones about it (up to 20 deg and 15 cm away, 0.8-1.2 m from the
square). One *case-frame* is what one iteration of ViSP's loop does for its one run: the points
projected, the law (L, its pseudo-inverse, the twist), the pose integrated; ours records the sample too.

* **ibvs-youla**: ``iy.simulate_batch(scenarios, "ibvs-current", plant="free-camera",
  camera=PinholeCamera.normalized(), sensor="depth", ...)``. Its cost per case-frame is the marginal
  cost of a frame of the whole call: (median of a call of 2 K steps - median of a call of K steps) /
  (N K), the set-up (each case prepared as ``simulate()`` prepares it) cancelling out; the set-up per
  case and the whole call per case-frame, set-up included, are reported beside it. Both in CPU time
  (this process's, ``time.process_time``: the time it had a core) and in wall time: a call lasts
  seconds, so on a shared host its wall time includes the others' turns on the core, while ViSP's
  per-iteration median (~20 us intervals) skips the iterations they interrupted; the CPU time is the
  like-for-like figure there, and the target is checked on it. Also
  the monocular variant (the depths from each controller's SQPnP pose, called per case), for scale.
* **ViSP 3.5** (Debian's ``libvisp-dev``): the tutorial's loop, ``peers/visp_ibvs_4pts.cpp`` (built
  by ``peers/visp.py``), every iteration timed in-process; its median.

Both on one core: OpenBLAS is held to one thread here (``OPENBLAS_NUM_THREADS=1`` unless set; a
Dask worker of a campaign sets the same), and the batch is one Python thread. ViSP and our calls
alternate in ``--rounds`` rounds. Target: a case-frame cheaper than ViSP's iteration at N = 1,000,
that is an aggregate throughput (case-frames per second) at least ViSP's.

Run: ``python benchmarks/bench_batch.py --json benchmarks/reports/batch.json``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy: one core, as a campaign worker

import argparse
import sys
import time
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

try:  # imported as benchmarks.bench_batch
    from ._timing import CpuShare, count, machine, perf_counter, write_json
    from .bench_peers import GAIN, PERIOD, POINTS_O, START, TARGET
    from .peers import visp
except ImportError:  # run as a script
    from _timing import CpuShare, count, machine, perf_counter, write_json
    from bench_peers import GAIN, PERIOD, POINTS_O, START, TARGET
    from peers import visp

import ibvs_youla as iy

TARGETS = {"batch_over_visp_max": 1.0}


def scenarios(n: int) -> list[Any]:
    """The tutorial's start, then n - 1 seeded starts about it (module docstring)."""
    rng = np.random.default_rng(0)
    starts = [START]
    for _ in range(n - 1):
        T = START.copy()
        T[:3, :3] = T[:3, :3] @ Rotation.from_rotvec(np.radians(rng.uniform(-20.0, 20.0, 3))).as_matrix()
        T[:3, 3] = T[:3, 3] + [*rng.uniform(-0.15, 0.15, 2), rng.uniform(-0.2, 0.2)]
        starts.append(T)
    return [iy.Scenario.free_camera(T_O_C_start=T, T_O_C_target=TARGET, markers_O=POINTS_O) for T in starts]


def batch(cases: list[Any], steps: int, sensor: str | None) -> Any:
    """One simulate_batch call of ``steps`` steps (``steps + 1`` frames) of every case."""
    return iy.simulate_batch(
        cases,
        iy.controllers.make("ibvs-current", gain=GAIN),
        plant="free-camera",
        camera=iy.PinholeCamera.normalized(1.0 / PERIOD),
        duration=steps * PERIOD,
        settings=iy.SimulationSettings(joint_rate_hz=1.0 / PERIOD, camera_rate_hz=1.0 / PERIOD),
        sensor=sensor,
    )


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmark, print a summary, write JSON if asked; return the report."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="FILE", help="write the report here")
    ap.add_argument("--cases", type=count, default=1000, help="cases per batch, N (default 1,000)")
    ap.add_argument(
        "--steps", type=count, default=150, help="steps K of the short call (150, the tutorial's)"
    )
    ap.add_argument("--rounds", type=count, default=3, help="alternating rounds (3)")
    ap.add_argument("--visp-repeats", type=count, default=20, help="ViSP loops per round (20)")
    ap.add_argument(
        "--monocular-cases", type=int, default=100, help="cases of the monocular variant (0: skip)"
    )
    ap.add_argument("--no-visp", action="store_true", help="skip ViSP")
    args = ap.parse_args(argv)
    steps, n = args.steps, args.cases

    skipped: dict[str, str] = {}
    binary = None
    if not args.no_visp:
        try:
            binary = visp.build("visp_ibvs_4pts.cpp")
        except RuntimeError as err:
            skipped["visp"] = str(err)
    modes = {"depth": (scenarios(n), "depth")}
    if args.monocular_cases > 0:
        modes["monocular"] = (scenarios(args.monocular_cases), None)
    for cases, sensor in modes.values():  # warm-up: compiled kernels, caches
        batch(cases[:2], 2, sensor)
    cpu = CpuShare()
    walls: dict[str, dict[int, list[float]]] = {m: {steps: [], 2 * steps: []} for m in modes}
    cpus: dict[str, dict[int, list[float]]] = {m: {steps: [], 2 * steps: []} for m in modes}
    seconds: dict[str, list[dict[str, float]]] = {m: [] for m in modes}
    visp_reports: list[dict[str, Any]] = []
    statuses: dict[str, list[str]] = {}
    for _ in range(args.rounds):
        if binary is not None:
            visp_reports.append(visp.run(binary, steps, args.visp_repeats))
        for mode, (cases, sensor) in modes.items():
            for k in (steps, 2 * steps):
                t0, c0 = perf_counter(), time.process_time()
                result = batch(cases, k, sensor)
                walls[mode][k].append(perf_counter() - t0)
                cpus[mode][k].append(time.process_time() - c0)
                if k == steps:
                    seconds[mode].append(result.seconds)
                    statuses[mode] = sorted(set(result.statuses))
                del result
    cores = cpu.stop()

    ours: dict[str, dict[str, Any]] = {}
    for mode, w in walls.items():
        cases = len(modes[mode][0])
        short, long = float(np.median(w[steps])), float(np.median(w[2 * steps]))
        short_cpu, long_cpu = float(np.median(cpus[mode][steps])), float(np.median(cpus[mode][2 * steps]))
        setup = float(np.median([s["setup"] for s in seconds[mode]]))
        ours[mode] = {
            "cases": cases,
            "case_frame_us": (long_cpu - short_cpu) / (cases * steps) * 1e6,
            "case_frame_wall_us": (long - short) / (cases * steps) * 1e6,
            "whole_call_per_case_frame_us": short_cpu / (cases * (steps + 1)) * 1e6,
            "whole_call_per_case_frame_wall_us": short / (cases * (steps + 1)) * 1e6,
            "setup_per_case_ms": setup / cases * 1e3,
            "call_s": short,
            "statuses": statuses[mode],
            "walls_s": {str(k): v for k, v in w.items()},
            "cpu_s": {str(k): v for k, v in cpus[mode].items()},
        }
    peers: dict[str, Any] = {}
    if visp_reports:
        per_iteration = [r["iteration"]["median_us"] for r in visp_reports]
        peers["visp"] = {
            "version": visp_reports[0]["visp_version"],
            "step_us": float(np.median(per_iteration)),
            "round_medians_us": per_iteration,
        }
    ratios: dict[str, float] = {}
    met: dict[str, bool] = {}
    if "visp" in peers:
        v = peers["visp"]["step_us"]
        for mode, o in ours.items():
            ratios[f"{mode} case-frame / visp iteration"] = o["case_frame_us"] / v
            ratios[f"{mode} case-frame (wall) / visp iteration"] = o["case_frame_wall_us"] / v
            ratios[f"{mode} whole call per case-frame / visp iteration"] = (
                o["whole_call_per_case_frame_us"] / v
            )
        met["batch_over_visp"] = ratios["depth case-frame / visp iteration"] <= TARGETS["batch_over_visp_max"]
    report = {
        "benchmark": "batch",
        "case": "ViSP tutorial-ibvs-4pts from N seeded starts: 4 coplanar points, normalized camera, free "
        "camera, 25 Hz, ibvs-current, lambda 0.5, measured depth",
        "ours": ours,
        "peers": peers,
        "skipped": skipped,
        "ratios": ratios,
        "targets": {**TARGETS, "met": met},
        "cpu": cores,
        "settings": {
            "cases": n,
            "steps": steps,
            "rounds": args.rounds,
            "visp_repeats": args.visp_repeats,
            "openblas_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
        },
        "machine": machine(),
    }
    _print(report)
    write_json(args.json, report, headline)
    return report


def headline(r: dict[str, Any]) -> dict[str, Any]:
    """The figures kept in the report's history."""
    return {
        "case_frame_us": {mode: o["case_frame_us"] for mode, o in r["ours"].items()},
        "visp_step_us": r["peers"].get("visp", {}).get("step_us"),
        "ratios": r["ratios"],
        "other_cores": r.get("cpu", {}).get("other_cores"),
    }


def _print(r: dict[str, Any]) -> None:
    for mode, o in r["ours"].items():
        print(
            f"simulate_batch {mode:10} N = {o['cases']:5}: {o['case_frame_us']:7.2f} us CPU per case-frame "
            f"({o['case_frame_wall_us']:.2f} wall); "
            f"whole call {o['whole_call_per_case_frame_us']:.2f} us per case-frame (set-up "
            f"{o['setup_per_case_ms']:.2f} ms per case); {o['statuses']}"
        )
    for peer, p in r["peers"].items():
        print(f"{peer} {p['version']:10} {p['step_us']:8.2f} us per iteration")
    for name, ratio in r["ratios"].items():
        print(f"  {name:52} {ratio:8.2f}")
    for name, why in r["skipped"].items():
        print(f"  {name}: skipped ({why})")
    other = r["cpu"]["other_cores"]
    busy = "?" if other is None else f"{other:.2f}"
    print(f"targets met: {r['targets']['met']}; other jobs used {busy} cores")


if __name__ == "__main__":
    main(sys.argv[1:])
