"""Simulated seconds per wall-clock second: the paper's scenarios, and classical IBVS on the ideal plants.

**The paper's scenarios** (``realtime_factor[scenario][settings]``): both paper scenarios,
controller ``"ff+fb"``, adaptive outer loop (the paper's proposal), on the dynamic arm, in two
settings:

* ``paper``: the paper's rates, joint loop and camera/outer loop both at 1 kHz
  (``SimulationSettings.paper()``), every sample recorded;
* ``two-rate``: joint loop at 1 kHz, camera and outer loop at 100 Hz (the ZED's fastest mode,
  the library's default), every sample recorded.

**Classical IBVS** (``classical[case]``): ``"ibvs-current"`` (L at the current features and
depths) on the two ideal plants, at ViSP's 40 ms control period (25 Hz, ``tutorial-ibvs-4pts``,
the campaigns' free-camera rate), ``--classical-duration`` seconds per run:

* ``kinematic/physical-2``: the kinematic arm (joint velocities followed exactly, a tick per
  frame: ``SimulationSettings(joint_rate_hz=25, camera_rate_hz=25)``), the physical-2 scenario
  (three markers in view), the default ZED 2 stereo camera (depths by triangulation);
* ``free-camera/physical-2``: the free-flying camera between the same start and target poses,
  same camera;
* ``free-camera/gans-general``: the free-flying camera, ViSP's normalized monocular camera and
  four coplanar points (the general motion of the Gans et al. suite, ``analysis.suites``): the
  depths come from the monocular pose, OpenCV's SQPnP at every frame.

**Per robot** (``robots[name]``): the IRB 4600, the UR5 (closed-form IK of the UR family) and the
Panda (seven joints: the warm-started IK nearest the previous estimate, Eq. (62)), each on its own
seeded scenario (``scenarios.for_arm(arm, seed=0)``), measured in the same run:

* ``paper``: ``"ff+fb"``, adaptive, on the dynamic arm, joint loop 1 kHz and camera 100 Hz (the
  library's default), ``--duration`` seconds: ``realtime_factor`` (target: at least 20x on every
  robot);
* ``classical``: ``"ibvs-current"`` on the kinematic arm at 25 Hz, ``--classical-duration``
  seconds: ``realtime_factor`` and ``cost_vs_irb4600``, its median wall time over the IRB 4600's
  (target: at most 1.5).

Their repeats are interleaved, a round running every robot's case once.

``realtime_factor`` = simulated time / median wall time of ``simulate(...)`` (arm and camera
built beforehand; the run's own set-up is included). The cost split is the servo loop's own
phase timing of the median run (``result.metadata["phase_seconds"]``): the plant step (RK4 of
Eq. (29): four ABA calls, divergence checks), the camera frame (true camera pose, sensor and
the controller's update), and the tick-rate control (the controller's command, the actuation
chain, recording). ``cpu["other_cores"]`` is what other jobs used of the cores meanwhile.

Run: ``python benchmarks/bench_simulation.py --json simulation.json``.
"""

from __future__ import annotations

import argparse
import sys
from functools import partial
from typing import Any

import numpy as np

try:  # imported as benchmarks.bench_simulation
    from ._timing import CpuShare, count, machine, perf_counter, seconds, write_json
except ImportError:  # run as a script
    from _timing import CpuShare, count, machine, perf_counter, seconds, write_json

import ibvs_youla
from ibvs_youla import scenarios
from ibvs_youla.analysis import suites
from ibvs_youla.model.arm import Arm
from ibvs_youla.model.camera import PinholeCamera, StereoCamera, default_camera
from ibvs_youla.simulation.settings import SimulationSettings

SETTINGS = {"paper": SimulationSettings.paper(), "two-rate": SimulationSettings(camera_rate_hz=100.0)}
CLASSICAL_RATE_HZ = 25.0  # [Hz] ViSP's 40 ms period
TARGETS = {"paper": 20.0, "two-rate": 50.0, "classical": 1000.0}  # targets: x real time, at least
ROBOTS = ("irb4600", "ur5", "panda")
ROBOT_TARGETS = {"paper": 20.0, "classical_cost_vs_irb4600": 1.5}  # x real time at least; ratio at most


CLASSICAL_SETTINGS = SimulationSettings(joint_rate_hz=CLASSICAL_RATE_HZ, camera_rate_hz=CLASSICAL_RATE_HZ)


def _classical_cases() -> dict[str, dict[str, Any]]:
    """Scenario, plant and camera of each classical-IBVS case (module docstring)."""
    physical = scenarios.physical(2)
    return {
        "kinematic/physical-2": {"scenario": physical, "plant": "kinematic", "camera": default_camera()},
        "free-camera/physical-2": {"scenario": physical, "plant": "free-camera", "camera": default_camera()},
        "free-camera/gans-general": {
            "scenario": suites.task("gans-general").scenario(),
            "plant": "free-camera",
            "camera": PinholeCamera.normalized(CLASSICAL_RATE_HZ),
        },
    }


def _split(result: Any) -> dict:
    """Per-step cost of the plant, the camera frame and the tick-rate control from the loop's timing."""
    phases, meta = result.metadata["phase_seconds"], result.metadata
    tick_rate = meta["joint_rate_hz"] or meta["camera_rate_hz"]  # the free camera ticks at its frames
    n_ticks = max(1, round(meta["duration"] * tick_rate))
    frames = max(1, len(result.frame_t))
    total = sum(phases.values())
    return {
        "dynamics_us_per_step": phases["plant"] / n_ticks * 1e6,
        "outer_us_per_frame": phases["frame"] / frames * 1e6,
        "joint_control_us_per_step": phases["control"] / (n_ticks + 1) * 1e6,
        "fraction": {
            "dynamics": phases["plant"] / total,
            "outer": phases["frame"] / total,
            "joint_control": phases["control"] / total,
        },
        "ticks": n_ticks + 1,
        "frames": frames,
    }


def _time(repeats: int, run: Any) -> tuple[list[float], Any]:
    walls, results = [], []
    for _ in range(repeats):
        t0 = perf_counter()
        results.append(run())
        walls.append(perf_counter() - t0)
    median = int(np.argsort(walls)[len(walls) // 2])
    return walls, results[median]


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmark, print a summary, write JSON if asked; return the report."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="FILE", help="write the report here")
    ap.add_argument("--duration", type=seconds, default=5.0, help="simulated s per paper run (default 5)")
    ap.add_argument("--classical-duration", type=seconds, default=20.0, help="simulated s per IBVS run (20)")
    ap.add_argument("--repeats", type=count, default=3, help="timed runs per case (default 3)")
    args = ap.parse_args(argv)

    arm, camera = Arm.irb4600(), StereoCamera.zed2()
    ibvs_youla.simulate(scenarios.paper(1), duration=0.05, arm=arm, camera=camera)  # warm-up
    cpu = CpuShare()
    realtime: dict[str, dict[str, float]] = {}
    cases: dict[str, dict[str, Any]] = {}
    for sc in scenarios.paper_scenarios():
        realtime[sc.name] = {}
        for label, settings in SETTINGS.items():

            def paper_run(sc: Any = sc, settings: SimulationSettings = settings) -> Any:
                return ibvs_youla.simulate(
                    sc, "ff+fb", True, args.duration, settings=settings, arm=arm, camera=camera
                )

            walls, result = _time(args.repeats, paper_run)
            wall = float(np.median(walls))
            realtime[sc.name][label] = args.duration / wall
            cases[f"{sc.name}/{label}"] = {
                "wall_median_s": wall,
                "wall_s": walls,
                "status": result.metadata["status"],
                "update_time_median_us": float(np.median(result.update_time) * 1e6),
                "split": _split(result),
            }
            _print(
                f"{sc.name}/{label}",
                realtime[sc.name][label],
                wall,
                args.duration,
                cases[f"{sc.name}/{label}"],
            )

    classical: dict[str, dict[str, Any]] = {}
    rate = CLASSICAL_SETTINGS
    for name, spec in _classical_cases().items():

        def ibvs_run(spec: dict[str, Any] = spec) -> Any:
            return ibvs_youla.simulate(
                spec["scenario"],
                "ibvs-current",
                duration=args.classical_duration,
                plant=spec["plant"],
                camera=spec["camera"],
                settings=rate,
                arm=arm,
            )

        ibvs_youla.simulate(
            spec["scenario"],
            "ibvs-current",
            duration=1.0,
            plant=spec["plant"],
            camera=spec["camera"],
            settings=rate,
            arm=arm,
        )  # warm-up
        walls, result = _time(args.repeats, ibvs_run)
        wall = float(np.median(walls))
        classical[name] = {
            "realtime_factor": args.classical_duration / wall,
            "wall_median_s": wall,
            "wall_s": walls,
            "status": result.metadata["status"],
            "frames": len(result.frame_t),
            "update_time_median_us": float(np.median(result.update_time) * 1e6),
            "split": _split(result),
        }
        _print(name, classical[name]["realtime_factor"], wall, args.classical_duration, classical[name])
    robots = _robot_rows(args)
    cores = cpu.stop()

    met = {
        "paper": {n: f["paper"] >= TARGETS["paper"] for n, f in realtime.items()},
        "two-rate": {n: f["two-rate"] >= TARGETS["two-rate"] for n, f in realtime.items()},
        "classical": {n: c["realtime_factor"] >= TARGETS["classical"] for n, c in classical.items()},
        "robots": {
            n: {
                "paper": r["paper"]["realtime_factor"] >= ROBOT_TARGETS["paper"],
                "classical": r["classical"]["cost_vs_irb4600"] <= ROBOT_TARGETS["classical_cost_vs_irb4600"],
            }
            for n, r in robots.items()
        },
    }
    report = {
        "benchmark": "simulation",
        "realtime_factor": realtime,
        "cases": cases,
        "classical": classical,
        "robots": robots,
        "targets": {"min_realtime_factor": TARGETS, "robots": ROBOT_TARGETS, "met": met},
        "cpu": cores,
        "settings": {
            "duration_s": args.duration,
            "classical_duration_s": args.classical_duration,
            "repeats": args.repeats,
            "controller": "ff+fb",
            "adaptive": True,
            "camera_rate_hz": {k: s.joint_rate_hz / s.camera_every for k, s in SETTINGS.items()},
            "classical_rate_hz": CLASSICAL_RATE_HZ,
        },
        "machine": machine(),
    }
    other = cores["other_cores"]
    print(f"other jobs used {'?' if other is None else f'{other:.2f}'} cores meanwhile")
    write_json(args.json, report, headline)
    return report


def _robot_rows(args: argparse.Namespace) -> dict[str, dict[str, Any]]:
    """The paper's controller and classical IBVS on each robot of ROBOTS (module docstring).

    The repeats are interleaved (each round runs every robot's case once), so that a change of the
    machine's load between the rounds shows in every robot's times alike, not in one robot's ratio.
    """
    runs: dict[tuple[str, str], Any] = {}
    rows: dict[str, dict[str, Any]] = {}
    for name in ROBOTS:
        arm = Arm.from_robot(name)
        case = {"scenario": scenarios.for_arm(arm, seed=0), "camera": default_camera(), "arm": arm}
        rows[name] = {"n_joints": arm.nq, "ik": arm.ik_method}
        for label, method, plant, duration, settings in (
            ("paper", "ff+fb", "dynamic", args.duration, SETTINGS["two-rate"]),
            ("classical", "ibvs-current", "kinematic", args.classical_duration, CLASSICAL_SETTINGS),
        ):
            run = partial(ibvs_youla.simulate, controller=method, plant=plant, settings=settings, **case)
            run(duration=0.05)  # warm-up (the compiled kernels of this arm's IK)
            runs[(name, label)] = (partial(run, duration=duration), duration)
    walls: dict[tuple[str, str], list[float]] = {key: [] for key in runs}
    results: dict[tuple[str, str], list[Any]] = {key: [] for key in runs}
    for _ in range(args.repeats):
        for key, (run, _duration) in runs.items():
            t0 = perf_counter()
            results[key].append(run())
            walls[key].append(perf_counter() - t0)
    for (name, label), (_run, duration) in runs.items():
        times = walls[(name, label)]
        result = results[(name, label)][int(np.argsort(times)[len(times) // 2])]
        wall = float(np.median(times))
        rows[name][label] = {
            "realtime_factor": duration / wall,
            "wall_median_s": wall,
            "wall_s": times,
            "status": result.metadata["status"],
            "update_time_median_us": float(np.median(result.update_time) * 1e6),
            "split": _split(result),
        }
        _print(f"{name}/{label}", duration / wall, wall, duration, rows[name][label])
    for row in rows.values():
        row["classical"]["cost_vs_irb4600"] = (
            row["classical"]["wall_median_s"] / rows["irb4600"]["classical"]["wall_median_s"]
        )
    return rows


def headline(r: dict[str, Any]) -> dict[str, Any]:
    """The figures kept in the report's history."""
    return {
        "realtime_factor": r["realtime_factor"],
        "classical": {n: c["realtime_factor"] for n, c in r.get("classical", {}).items()},
        "robots": {
            n: {
                "paper": c["paper"]["realtime_factor"],
                "classical_cost_vs_irb4600": c["classical"]["cost_vs_irb4600"],
            }
            for n, c in r.get("robots", {}).items()
        },
        "other_cores": r.get("cpu", {}).get("other_cores"),
    }


def _print(name: str, factor: float, wall: float, duration: float, case: dict[str, Any]) -> None:
    f, split = case["split"]["fraction"], case["split"]
    print(
        f"{name:26} {factor:8.1f}x real time (wall {wall:.3f} s for {duration:g} s, {case['status']}); "
        f"plant {f['dynamics']:.0%} ({split['dynamics_us_per_step']:.1f} us/tick), frame {f['outer']:.0%} "
        f"({split['outer_us_per_frame']:.1f} us/frame), tick control {f['joint_control']:.0%} "
        f"({split['joint_control_us_per_step']:.1f} us/tick)"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
