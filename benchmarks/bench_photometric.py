"""Photometric visual servoing: its cost per frame, its basin against the point law's, texture and noise.

Four measurements on the textured plane (``scenarios.textured_plane()``: the free camera 1 m before
a 1.2 x 0.9 m plane with a seeded 1/f texture, a 0.2 m square of markers at its centre; 25 Hz),
each printed and written to the JSON report:

* ``cost``: per frame, at three image sizes of one field of view (44 x 33 deg: 120 x 90 px at
  150 px, ViSP's photometric example's 320 x 240 at 400 px, 640 x 480 at 800 px), the medians of
  the scene sensor's frame (``SceneImageSensor.measure``: the warp and the markers' features), of
  ``PhotometricVS.update`` and of its floor (the product L_I*^T e, numpy), and the one-off
  ``reset`` (the gradients of I*, L_I* and the two 6 x 6 inverses); poses near the target
  (1 cm, 1 deg), each call timed alone after warm-up, GC off.
* ``domains``: the convergence domain along two axes, for ``photometric`` and ``ibvs-current``
  (classical IBVS on the square's corners, the same scene): starts turned about the optical axis
  by 0-180 deg, and moved along x by 0-0.6 m; a start converges when the pose is within 1 mm and
  0.1 deg from some time on, within 30 s. Reported: every value's outcome, and the largest value up
  to which every start converged (the basin's contiguous part).
* ``texture``: the share of 24 seeded starts (a random axis and direction; 3-10 cm and 3-10 deg)
  from which photometric servoing converges within 10 s, for textures low-passed over 1.5, 3
  (the default) and 6 texels (7.5, 15 and 30 mm).
* ``noise``: the pose error in steady state, the RMS over the last 2 s of a 20 s run from the
  default start, with rendered images (8 bits, 1 px blur) of sensor noise 0, 2, 5, 10 and 20 grey
  levels (seeded), for ``photometric`` (the noise in every pixel of the error) and
  ``ibvs-current`` (the centroids of 5 cm discs detected in the images of the same noise).

OpenBLAS runs on one thread here (``OPENBLAS_NUM_THREADS=1``, set before numpy is imported when run
as a script, as the campaigns' one-thread workers do): on two cores shared with other jobs, its
second thread made one 320 x 240 update 12.7 ms instead of 1.0 ms in a trial.

Run: ``python benchmarks/bench_photometric.py --json benchmarks/reports/photometric.json``
(about 4 minutes on an idle core; ``--quick`` for a short check of the script).
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import sys
from typing import Any

if __name__ == "__main__":  # before numpy loads OpenBLAS (module docstring)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from scipy.spatial.transform import Rotation

try:  # imported as benchmarks.bench_photometric
    from ._timing import CpuShare, count, machine, perf_counter, summary_us, write_json
except ImportError:  # run as a script
    from _timing import CpuShare, count, machine, perf_counter, summary_us, write_json

import ibvs_youla as iy
from ibvs_youla import controllers, scenarios
from ibvs_youla.analysis.compare import time_to_converge
from ibvs_youla.controllers import ServoTask
from ibvs_youla.model.luminance import BORDER_PX
from ibvs_youla.model.textured_plane import TexturedPlane
from ibvs_youla.simulation.scene_sensor import SceneImageSensor
from ibvs_youla.simulation.sensor import MarkerSensor

RATE_HZ = 25.0
SIZES = ((120, 90, 150.0), (320, 240, 400.0), (640, 480, 800.0))  # width, height [px], focal [px]
ROTATIONS_DEG = tuple(float(a) for a in range(0, 181, 5))
SHIFTS_M = tuple(round(0.025 * k, 3) for k in range(25))
SMOOTHINGS = (1.5, 3.0, 6.0)  # [texels]
NOISES = (0.0, 2.0, 5.0, 10.0, 20.0)  # [grey levels]


def _settings() -> iy.SimulationSettings:
    return iy.SimulationSettings(joint_rate_hz=RATE_HZ, camera_rate_hz=RATE_HZ)


def _converges(scenario: iy.Scenario, method: str, duration: float, camera: Any = None) -> bool:
    result = iy.simulate(
        scenario,
        method,
        plant="free-camera",
        camera=scenarios.textured_camera() if camera is None else camera,
        duration=duration,
        settings=_settings(),
    )
    return math.isfinite(time_to_converge(result))


# ---------------------------------------------------------------------------------------- cost
def _cost(configs: int, repeats: int, rng: np.random.Generator) -> list[dict[str, Any]]:
    out = []
    scenario = scenarios.textured_plane()
    T_target = np.asarray(scenario.T_O_C_target)
    for width, height, focal in SIZES:
        camera = iy.PinholeCamera.from_focal_px(focal, (width, height))
        sensor = SceneImageSensor(MarkerSensor(camera, scenario.markers_O), scenario.scene)
        task = ServoTask(
            camera=camera,
            markers_O=scenario.markers_O,
            feature_target=sensor.features_at(T_target),
            T_O_C_target=T_target,
            tick_period=1.0 / RATE_HZ,
            frame_period=1.0 / RATE_HZ,
            scene=scenario.scene,
            image_target=sensor.image_at(T_target),
        )
        ctrl = controllers.make("photometric")
        poses = []
        for _ in range(configs):
            T = T_target.copy()
            T[:3, :3] = Rotation.from_rotvec(np.radians(1.0) * rng.standard_normal(3)).as_matrix()
            T[:3, 3] += 0.01 * rng.standard_normal(3)
            poses.append(T)
        frames = [sensor.measure(T, 0.0) for T in poses]
        ctrl.reset(task)
        L_T = np.ascontiguousarray(ctrl.interaction_matrix().T)
        b = BORDER_PX
        errors = [(f.image[b:-b, b:-b] - task.image_target[b:-b, b:-b]).ravel() for f in frames]
        jobs = {
            "frame": (sensor.measure, [(T, 0.0) for T in poses]),
            "update": (ctrl.update, [(f, None) for f in frames]),
            "floor_LTe": (L_T.dot, [(e,) for e in errors]),
            "reset": (ctrl.reset, [(task,)] * min(configs, 5)),
        }
        times: dict[str, list[float]] = {k: [] for k in jobs}
        gc_was_enabled = gc.isenabled()
        gc.disable()
        try:
            for i in range(2 + repeats):
                for key, (fn, arguments) in jobs.items():
                    for a in arguments:
                        t0 = perf_counter()
                        fn(*a)
                        if i >= 2:
                            times[key].append(perf_counter() - t0)
        finally:
            if gc_was_enabled:
                gc.enable()
        entry: dict[str, Any] = {
            "width_px": width,
            "height_px": height,
            "focal_px": focal,
            "feature_pixels": int(L_T.shape[1]),
        }
        for key, seconds in times.items():
            entry[key] = summary_us(seconds)
        entry["update_ratio_to_floor"] = entry["update"]["median_us"] / entry["floor_LTe"]["median_us"]
        out.append(entry)
    return out


# ---------------------------------------------------------------------------------------- basins
def _basin(values: tuple[float, ...], flags: list[bool]) -> float:
    """The largest value up to which every value converged (0 if the first did not)."""
    largest = 0.0
    for value, ok in zip(values, flags, strict=True):
        if not ok:
            break
        largest = value
    return largest


def _domains(duration: float, rotations: tuple[float, ...], shifts: tuple[float, ...]) -> dict[str, Any]:
    out: dict[str, Any] = {"duration_s": duration}
    for axis, values, start in (
        ("rotation_z_deg", rotations, lambda v: ((0.0, 0.0, 0.0), (0.0, 0.0, v))),
        ("translation_x_m", shifts, lambda v: ((v, 0.0, 0.0), (0.0, 0.0, 0.0))),
    ):
        for method in ("photometric", "ibvs-current"):
            flags = [_converges(scenarios.textured_plane(*start(v)), method, duration) for v in values]
            out.setdefault(axis, {})[method] = {
                "values": list(values),
                "converged": flags,
                "basin": _basin(values, flags),
            }
            print(f"domain {axis:<16} {method:<13} basin {_basin(values, flags):g}", flush=True)
    return out


def _texture(starts: int, duration: float, rng: np.random.Generator) -> dict[str, Any]:
    offsets = []
    for _ in range(starts):
        t = rng.standard_normal(3)
        t *= 0.1 * rng.uniform(0.3, 1.0) / np.linalg.norm(t)
        r = rng.standard_normal(3)
        r *= 10.0 * rng.uniform(0.3, 1.0) / np.linalg.norm(r)
        offsets.append((t, r))
    out: dict[str, Any] = {"starts": starts, "duration_s": duration, "smoothing_texels": {}}
    for smoothing in SMOOTHINGS:
        plane = TexturedPlane(smoothing_texels=smoothing)
        reached = [
            _converges(scenarios.textured_plane(t, r, scene=plane), "photometric", duration)
            for t, r in offsets
        ]
        out["smoothing_texels"][f"{smoothing:g}"] = {
            "reached": int(sum(reached)),
            "share": sum(reached) / starts,
        }
        print(
            f"texture smoothing {smoothing:g} texels: {sum(reached)} of {starts} starts reached", flush=True
        )
    return out


def _noise(duration: float) -> dict[str, Any]:
    from ibvs_youla.analysis.metrics import pose_error_series_mm_deg

    out: dict[str, Any] = {"duration_s": duration, "blur_px": 1.0, "steady_mm": {}, "steady_deg": {}}
    for method in ("photometric", "ibvs-current"):
        for noise in NOISES:
            result = iy.simulate(
                scenarios.textured_plane(),
                method,
                plant="free-camera",
                camera=scenarios.textured_camera(),
                duration=duration,
                settings=_settings(),
                disturbances=iy.Disturbances(rendered_images=True, image_blur_px=1.0, image_noise_grey=noise),
            )
            last = result.t >= result.t[-1] - 2.0  # the last 2 s
            mm, deg = pose_error_series_mm_deg(result.camera_pose[last], result.camera_pose_target)
            rms_mm, rms_deg = float(np.sqrt(np.mean(mm**2))), float(np.sqrt(np.mean(deg**2)))
            out["steady_mm"].setdefault(method, {})[f"{noise:g}"] = rms_mm
            out["steady_deg"].setdefault(method, {})[f"{noise:g}"] = rms_deg
            print(
                f"noise {noise:>4g} grey levels  {method:<13} steady {rms_mm:.3g} mm, {rms_deg:.3g} deg",
                flush=True,
            )
    return out


# ---------------------------------------------------------------------------------------- main
def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmark, print its figures, write JSON if asked; return the report."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="FILE", help="write the report here")
    ap.add_argument("--configs", type=count, default=50, help="poses per image size (default 50)")
    ap.add_argument("--repeats", type=count, default=10, help="timed passes over them (default 10)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="a few values of each sweep, short runs")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    cpu = CpuShare()
    cost = _cost(args.configs, args.repeats, rng)
    for e in cost:
        print(
            f"{e['width_px']} x {e['height_px']} px: frame {e['frame']['median_us']:.0f} us, update "
            f"{e['update']['median_us']:.0f} us (floor {e['floor_LTe']['median_us']:.0f} us), reset "
            f"{e['reset']['median_us'] / 1e3:.1f} ms",
            flush=True,
        )
    if args.quick:
        domains = _domains(2.0, ROTATIONS_DEG[:2], SHIFTS_M[:2])
        texture = _texture(2, 2.0, rng)
        noise = _noise(0.4)
    else:
        domains = _domains(30.0, ROTATIONS_DEG, SHIFTS_M)
        texture = _texture(24, 10.0, rng)
        noise = _noise(20.0)
    report = {
        "benchmark": "photometric",
        "cost": cost,
        "domains": domains,
        "texture": texture,
        "noise": noise,
        "settings": {
            "configs": args.configs,
            "repeats": args.repeats,
            "seed": args.seed,
            "quick": args.quick,
        },
        "cpu": cpu.stop(),
        "machine": machine(),
    }
    write_json(args.json, report, headline)
    return report


def headline(r: dict[str, Any]) -> dict[str, Any]:
    """The figures kept in the report's history: the update and frame at 120 x 90 px, the basins."""
    small = r["cost"][0]
    return {
        "update_median_us": small["update"]["median_us"],
        "frame_median_us": small["frame"]["median_us"],
        "basin_rotation_z_deg": r["domains"]["rotation_z_deg"]["photometric"]["basin"],
        "basin_translation_x_m": r["domains"]["translation_x_m"]["photometric"]["basin"],
    }


if __name__ == "__main__":
    main(sys.argv[1:])
