"""The same work beside the peers: ViSP's tutorial-ibvs-4pts through ibvs-youla, ViSP 3.5 (C++) and MVTB.

One case, run by all three: ViSP's ``tutorial-ibvs-4pts`` (four coplanar points of a 20 cm square,
the normalized camera, the free-flying camera at 40 ms (25 Hz), classical IBVS with L at the current
features, lambda = 0.5, from cMo = (0.15, -0.1, 1 m; theta u = 10, -10, 50 deg) to cdMo = (0, 0,
0.75 m)). A *step* is one loop iteration of each: the camera pose, the points projected, the law
(L, its pseudo-inverse, the twist) and the pose integrated over the period; ours records the sample
too.

* **ViSP 3.5** (Debian's ``libvisp-dev``): ``peers/visp_ibvs_4pts.cpp``, the tutorial's loop
  (``vpSimulatorCamera`` + ``vpServo`` + ``vpFeatureBuilder`` from the tracked ``vpPoint``: the
  simulator's depths), built by this script with pkg-config and g++ (``peers/visp.py``), every
  iteration timed in-process (``steady_clock``); its median.
* **MVTB-python** (``machinevision-toolbox-python`` in a throwaway venv, ``--mvtb-venv``, created if
  absent): ``IBVS.step`` on the same case (``peers/mvtb_ibvs_4pts.py``), exact depths, its gain per
  step lambda T = 0.02 (its step has no period); every step timed alone; its median.
* **ibvs-youla**: ``simulate(scenario, "ibvs-current", plant="free-camera",
  camera=PinholeCamera.normalized(), ...)`` with ``sensor="depth"`` (the depths measured, as ViSP's)
  and without (``monocular``: the depths from OpenCV's SQPnP pose at every frame, the default;
  ``monocular, IPPE``: from IPPE's, the controller's ``pnp="ippe"``, exact for coplanar points as the
  tutorial's are); and, for scale,
  ``sensor="depth"`` through the plug-in loop (``loop="plug-in"``), where ``simulate`` has it. Its
  step is the marginal cost of a step: (median wall of a run of 2 N steps - median wall of a run of
  N steps) / N, each run a whole ``simulate`` call (set-up included in both, so it cancels; it is
  reported apart as ``setup_ms``: the wall of an N-step run minus N steps).

**Same case**: the features after every step of each peer are compared with ours (``trajectory``):
ViSP integrates the twist with the exponential map as we do (``vpExponentialMap``), so its features
agree to rounding; MVTB moves the camera by a first-order differential motion (``SE3.Delta``, I +
[d]^ re-orthonormalized), so its features leave ours at second order in the step (reported, not a
defect of either). ViSP's simulator scales down twists above 1 m/s and 90 deg/s; the tutorial's never
get there (``v_max``, ``w_max`` of its report).

Ratios are of medians measured in one run, the peers and our runs alternating in ``--rounds`` rounds
so that all see the same machine. Targets: ours with measured depth <= 3x ViSP's iteration and >= 20x
faster than MVTB's step; monocular (PnP) <= 6x ViSP's, reported for either solver
(``met["monocular_over_visp"]``: SQPnP, ``met["monocular_ippe_over_visp"]``: IPPE).

Run: ``python benchmarks/bench_peers.py --json benchmarks/reports/peers.json``.
"""

from __future__ import annotations

import argparse
import inspect
import sys
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

try:  # imported as benchmarks.bench_peers
    from ._timing import CpuShare, count, machine, perf_counter, write_json
    from .peers import mvtb, visp
except ImportError:  # run as a script
    from _timing import CpuShare, count, machine, perf_counter, write_json
    from peers import mvtb, visp

import ibvs_youla as iy

PERIOD = 0.04  # [s] the tutorial's sampling time
GAIN = 0.5  # [1/s] the tutorial's lambda
POINTS_O = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]
TARGETS = {"depth_over_visp_max": 3.0, "mvtb_over_depth_min": 20.0, "monocular_over_visp_max": 6.0}


def _T_O_C(t: list[float], theta_u_deg: list[float]) -> np.ndarray:
    """Camera pose from ViSP's cMo (the object's pose in the camera: translation, theta u [deg])."""
    cMo = np.eye(4)
    cMo[:3, :3] = Rotation.from_rotvec(np.radians(theta_u_deg)).as_matrix()
    cMo[:3, 3] = t
    return np.linalg.inv(cMo)


START, TARGET = _T_O_C([0.15, -0.1, 1.0], [10, -10, 50]), _T_O_C([0.0, 0.0, 0.75], [0, 0, 0])


def _ours(steps: int, sensor: str | None, loop: str | None, pnp: str | None = None) -> Any:
    """One ``simulate`` of the tutorial case, ``steps`` steps (``steps + 1`` frames); ``pnp``: the
    monocular law's PnP solver (the controller's ``pnp`` option; None: its default, SQPnP)."""
    scenario = iy.Scenario.free_camera(T_O_C_start=START, T_O_C_target=TARGET, markers_O=POINTS_O)
    extra = {} if loop is None else {"loop": loop}
    options = {} if pnp is None else {"pnp": pnp}
    return iy.simulate(
        scenario,
        iy.controllers.make("ibvs-current", gain=GAIN, **options),
        plant="free-camera",
        camera=iy.PinholeCamera.normalized(1.0 / PERIOD),
        duration=steps * PERIOD,
        settings=iy.SimulationSettings(joint_rate_hz=1.0 / PERIOD, camera_rate_hz=1.0 / PERIOD),
        sensor=sensor,
        **extra,
    )


def _modes() -> dict[str, tuple[str | None, str | None, str | None]]:
    """Our variants: (sensor, loop, pnp); the plug-in loop where simulate can be told to take it, IPPE
    (the four points are coplanar) where the controller takes a ``pnp`` option."""
    modes: dict[str, tuple[str | None, str | None, str | None]] = {
        "depth": ("depth", None, None),
        "monocular": (None, None, None),
    }
    try:
        iy.controllers.make("ibvs-current", pnp="ippe")
        modes["monocular, IPPE"] = (None, None, "ippe")
    except iy.exceptions.InvalidParameterError:  # a version without the option
        pass
    if "loop" in inspect.signature(iy.simulate).parameters:
        modes["depth, plug-in loop"] = ("depth", "plug-in", None)
        modes["monocular, plug-in loop"] = (None, "plug-in", None)
    return modes


def _deviation(ours: np.ndarray, theirs: list[float], steps: int) -> dict[str, float]:
    """Largest |feature difference| after k steps, k = 1, 10 and every step, of the first ``steps``."""
    theirs_ = np.asarray(theirs, dtype=float).reshape(-1, ours.shape[1])[:steps]
    diff = np.abs(ours[: theirs_.shape[0]] - theirs_).max(axis=1)
    return {"after_1": float(diff[1]), "after_10": float(diff[10]), "max": float(diff.max())}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmark, print a summary, write JSON if asked; return the report."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="FILE", help="write the report here")
    ap.add_argument("--steps", type=count, default=150, help="steps per run (default 150, the tutorial's)")
    ap.add_argument("--rounds", type=count, default=3, help="alternating rounds of every variant (3)")
    ap.add_argument("--visp-repeats", type=count, default=20, help="ViSP loops per round (20)")
    ap.add_argument("--mvtb-repeats", type=count, default=3, help="MVTB loops per round (3)")
    ap.add_argument("--ours-repeats", type=count, default=7, help="our runs of each length per round (7)")
    ap.add_argument("--mvtb-venv", type=Path, default=mvtb.DEFAULT_VENV, help="MVTB's venv (made if absent)")
    ap.add_argument("--no-visp", action="store_true", help="skip ViSP")
    ap.add_argument("--no-mvtb", action="store_true", help="skip MVTB")
    args = ap.parse_args(argv)
    steps = args.steps

    skipped: dict[str, str] = {}
    visp_binary = None
    if not args.no_visp:
        try:
            visp_binary = visp.build("visp_ibvs_4pts.cpp")
        except RuntimeError as err:
            skipped["visp"] = str(err)
    mvtb_python = None
    if not args.no_mvtb:
        try:
            mvtb_python = mvtb.python(args.mvtb_venv)
        except (RuntimeError, OSError) as err:
            skipped["mvtb"] = str(err)
    mvtb_setup = {
        "points": POINTS_O.tolist(),
        "start": START.tolist(),
        "target": TARGET.tolist(),
        "gain_per_step": GAIN * PERIOD,
        "steps": steps,
        "repeats": args.mvtb_repeats,
    }

    modes = _modes()
    for sensor, loop, pnp in modes.values():  # warm-up: compiled kernels, caches
        _ours(steps, sensor, loop, pnp)
    cpu = CpuShare()
    walls: dict[str, dict[int, list[float]]] = {m: {steps: [], 2 * steps: []} for m in modes}
    visp_reports: list[dict[str, Any]] = []
    mvtb_reports: list[dict[str, Any]] = []
    results: dict[str, Any] = {}
    for _ in range(args.rounds):
        if visp_binary is not None:
            visp_reports.append(visp.run(visp_binary, steps, args.visp_repeats))
        if mvtb_python is not None:
            mvtb_reports.append(mvtb.run(mvtb_python, "mvtb_ibvs_4pts.py", mvtb_setup))
        for _ in range(args.ours_repeats):
            for mode, (sensor, loop, pnp) in modes.items():
                for n in (steps, 2 * steps):
                    t0 = perf_counter()
                    result = _ours(n, sensor, loop, pnp)
                    walls[mode][n].append(perf_counter() - t0)
                    if n == steps:
                        results[mode] = result
    cores = cpu.stop()

    ours: dict[str, dict[str, Any]] = {}
    for mode, w in walls.items():
        short, long = float(np.median(w[steps])), float(np.median(w[2 * steps]))
        step_us = (long - short) / steps * 1e6
        ours[mode] = {
            "step_us": step_us,
            "run_ms": short * 1e3,
            "run_per_step_us": short / steps * 1e6,
            "setup_ms": (short - steps * step_us * 1e-6) * 1e3,
            "status": results[mode].metadata["status"],
            "loop": results[mode].metadata.get("loop", "plug-in"),
            "walls_s": {str(n): v for n, v in w.items()},
        }
    features = results["depth"].frame_features
    peers: dict[str, Any] = {}
    if visp_reports:
        per_iteration = [r["iteration"]["median_us"] for r in visp_reports]
        first = visp_reports[0]
        peers["visp"] = {
            "version": first["visp_version"],
            "step_us": float(np.median(per_iteration)),
            "round_medians_us": per_iteration,
            "mean_us": float(np.median([r["iteration"]["mean_us"] for r in visp_reports])),
            "v_max": first["v_max"],
            "w_max": first["w_max"],
            "trajectory": _deviation(features, first["features"], steps),
            "twist_deviation_max": float(
                np.abs(
                    results["depth"].signals["camera_twist"][:steps]
                    - np.reshape(first["twists"], (-1, 6))[:steps]
                ).max()
            ),
        }
    if mvtb_reports:
        per_step = [r["step"]["median_us"] for r in mvtb_reports]
        peers["mvtb"] = {
            "version": mvtb_reports[0]["version"],
            "step_us": float(np.median(per_step)),
            "round_medians_us": per_step,
            "trajectory": _deviation(features, mvtb_reports[0]["features"], steps),
        }
    ratios: dict[str, float] = {}
    met: dict[str, bool] = {}
    if "visp" in peers:
        v = peers["visp"]["step_us"]
        for mode, o in ours.items():
            ratios[f"{mode} / visp"] = o["step_us"] / v
        met["depth_over_visp"] = ratios["depth / visp"] <= TARGETS["depth_over_visp_max"]
        met["monocular_over_visp"] = ratios["monocular / visp"] <= TARGETS["monocular_over_visp_max"]
        if "monocular, IPPE / visp" in ratios:  # the same target, the option's solver
            met["monocular_ippe_over_visp"] = (
                ratios["monocular, IPPE / visp"] <= TARGETS["monocular_over_visp_max"]
            )
    if "mvtb" in peers:
        for mode, o in ours.items():
            ratios[f"mvtb / {mode}"] = peers["mvtb"]["step_us"] / o["step_us"]
        met["mvtb_over_depth"] = ratios["mvtb / depth"] >= TARGETS["mvtb_over_depth_min"]
    report = {
        "benchmark": "peers",
        "case": "ViSP tutorial-ibvs-4pts: 4 coplanar points, normalized camera, free camera, 25 Hz, "
        "ibvs-current, lambda 0.5",
        "ours": ours,
        "peers": peers,
        "skipped": skipped,
        "ratios": ratios,
        "targets": {**TARGETS, "met": met},
        "cpu": cores,
        "settings": {
            "steps": steps,
            "rounds": args.rounds,
            "visp_repeats": args.visp_repeats,
            "mvtb_repeats": args.mvtb_repeats,
            "ours_repeats": args.ours_repeats,
        },
        "machine": machine(),
    }
    _print(report)
    write_json(args.json, report, headline)
    return report


def headline(r: dict[str, Any]) -> dict[str, Any]:
    """The figures kept in the report's history."""
    return {
        "step_us": {
            **{mode: o["step_us"] for mode, o in r["ours"].items()},
            **{peer: p["step_us"] for peer, p in r["peers"].items()},
        },
        "ratios": r["ratios"],
        "other_cores": r.get("cpu", {}).get("other_cores"),
    }


def _print(r: dict[str, Any]) -> None:
    for mode, o in r["ours"].items():
        print(
            f"ibvs-youla {mode:24} {o['step_us']:8.1f} us/step ({o['loop']}; a "
            f"{r['settings']['steps']}-step run {o['run_ms']:.2f} ms, set-up {o['setup_ms']:.2f} ms, "
            f"{o['status']})"
        )
    for peer, p in r["peers"].items():
        t = p["trajectory"]
        print(
            f"{peer} {p['version']:20} {p['step_us']:8.1f} us/step; features vs ours: after 1 step "
            f"{t['after_1']:.2g}, after 10 {t['after_10']:.2g}, max {t['max']:.2g}"
        )
    for name, ratio in r["ratios"].items():
        print(f"  {name:34} {ratio:8.2f}")
    for name, why in r["skipped"].items():
        print(f"  {name}: skipped ({why})")
    other = r["cpu"]["other_cores"]
    busy = "?" if other is None else f"{other:.2f}"
    print(f"targets met: {r['targets']['met']}; other jobs used {busy} cores")


if __name__ == "__main__":
    main(sys.argv[1:])
