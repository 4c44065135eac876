"""Images in the loop: detected-centre error over depth and blur, and the time to render and detect a frame.

**Error sweep** (:func:`ibvs_youla.analysis.detection_accuracy.detection_error_sweep`): the
simulator's ZED 2 model (``default_camera()``: the paper's optics, VGA 672 x 378, F = 359.8 px,
120 mm baseline), 5 cm discs tilted 30 deg from the optical axis on a jittered 3 x 3 grid,
depths 0.5-3 m, Gaussian blur 0-2 px, sensor noise 2 grey levels (contrast 170), ``--frames``
seeded frames per cell. Per cell: the fraction of markers found, the detected-centre error
against the true projection (median / p95 / max, px, Euclidean per marker and lens), the
first-order perspective bias, and the residual after subtracting it. ``--compare`` repeats the
sweep with the Hough transform (``cv2.HoughCircles``).

**Time per frame**: ``ImageSensor.observe`` (render both images, detect, match) on four 5 cm
discs at 1.4-1.7 m, blur 1 px, noise 2 grey levels, each call timed alone after a warm-up, and
its parts: rendering (``render_unchecked``, both lenses) and detection (``detect_blobs``, both
images); the ideal ``MarkerSensor.measure`` of the same pose for the ratio; and the process CPU
time of ``observe`` (less sensitive than wall time to other jobs on a shared machine). At VGA and
HD720.

Run: ``.venv/bin/python benchmarks/bench_detection.py --compare --json benchmarks/reports/detection.json``.
"""

from __future__ import annotations

import argparse
import gc
import sys
from time import process_time
from typing import Any

import numpy as np

try:  # imported as benchmarks.bench_detection
    from ._timing import machine, perf_counter, summary_us, write_json
except ImportError:  # run as a script
    from _timing import machine, perf_counter, summary_us, write_json

from ibvs_youla.analysis.detection_accuracy import detection_error_sweep, sweep_table
from ibvs_youla.estimation.marker_detection import detect_blobs
from ibvs_youla.model.camera import StereoCamera, default_camera
from ibvs_youla.simulation.image_sensor import ImageSensor
from ibvs_youla.simulation.rendering import DiscMarkers, ImagingSettings, render_unchecked
from ibvs_youla.simulation.sensor import MarkerSensor

DEPTHS = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0)  # [m]
BLURS = (0.0, 0.5, 1.0, 2.0)  # [px]
NOISE = 2.0  # [grey levels]
DIAMETER = 0.05  # [m]
MARKERS_O = np.array([[-0.2, -0.1, 1.5], [0.2, -0.1, 1.6], [0.1, 0.15, 1.4], [-0.15, 0.12, 1.7]])  # [m]


def time_frames(camera: StereoCamera, repeats: int) -> dict[str, Any]:
    """Per-call times of observe, its render and detect parts, and the ideal sensor, alternating."""
    truth = MarkerSensor(camera, MARKERS_O)
    sensor = ImageSensor(truth, DiscMarkers(DIAMETER), ImagingSettings(1.0, NOISE, seed=0))
    T = np.eye(4)
    P_C = truth.points_in_camera(T)
    normals = sensor.markers.normals_C(P_C, T[:3, :3])
    times: dict[str, list[float]] = {
        "observe": [],
        "render": [],
        "detect": [],
        "ideal": [],
        "observe_cpu": [],
    }
    for k in range(repeats + 5):  # 5 warm-up rounds
        c0, t0 = process_time(), perf_counter()
        observation = sensor.observe(T)
        t1, c1 = perf_counter(), process_time()
        frame = render_unchecked(camera, sensor.markers, P_C, normals, sensor.imaging, sensor.rng)
        t2 = perf_counter()
        for image in frame.images:
            detect_blobs(image, sensor.detector)
        t3 = perf_counter()
        truth.measure(T, 0.0)
        t4 = perf_counter()
        if k >= 5:
            for key, dt in zip(times, (t1 - t0, t2 - t1, t3 - t2, t4 - t3, c1 - c0), strict=True):
                times[key].append(dt)
    assert observation.visible.all()
    stats = {key: summary_us(value) for key, value in times.items()}
    return {
        "camera": camera.name,
        "resolution": list(camera.resolution),
        "stats": stats,
        "observe_median_ms": stats["observe"]["median_us"] / 1e3,
        "observe_cpu_median_ms": stats["observe_cpu"]["median_us"] / 1e3,
        "render_median_ms": stats["render"]["median_us"] / 1e3,
        "detect_median_ms": stats["detect"]["median_us"] / 1e3,
        "ratio_to_ideal": stats["observe"]["median_us"] / stats["ideal"]["median_us"],
        "frames_per_second": 1e6 / stats["observe"]["median_us"],
    }


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=10, help="seeded frames per (depth, blur) cell")
    parser.add_argument("--repeats", type=int, default=50, help="timed frames per camera mode")
    parser.add_argument("--compare", action="store_true", help="also sweep the Hough transform")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", default=None, help="write the report to this file")
    args = parser.parse_args(argv)
    gc.disable()
    try:
        methods = ("moments", "hough") if args.compare else ("moments",)
        sweeps = {}
        for method in methods:
            rows = detection_error_sweep(
                default_camera(),
                DIAMETER,
                DEPTHS,
                BLURS,
                NOISE,
                frames=args.frames,
                method=method,
                seed=args.seed,
            )
            sweeps[method] = rows
            print(
                f"\n{method}: {args.frames} frames x 9 markers x 2 lenses a cell, noise {NOISE:g} grey levels"
            )
            print(sweep_table(rows))
        timing = {mode: time_frames(default_camera(mode=mode), args.repeats) for mode in ("VGA", "HD720")}
    finally:
        gc.enable()
    print("\ntime per frame (render both images + detect + match), median [ms]:")
    for mode, t in timing.items():
        print(
            f"  {mode} {t['resolution'][0]}x{t['resolution'][1]}: observe {t['observe_median_ms']:.2f} wall, "
            f"{t['observe_cpu_median_ms']:.2f} CPU; render {t['render_median_ms']:.2f}, detect "
            f"{t['detect_median_ms']:.2f} wall; {t['frames_per_second']:.0f} frames/s (wall), "
            f"{t['ratio_to_ideal']:.0f}x the ideal sensor"
        )
    report = {
        "machine": machine(),
        "settings": {
            "camera": default_camera().name,
            "diameter_m": DIAMETER,
            "depths_m": list(DEPTHS),
            "blurs_px": list(BLURS),
            "noise_grey": NOISE,
            "tilt_deg": 30.0,
            "frames": args.frames,
            "seed": args.seed,
        },
        "sweeps": sweeps,
        "timing": timing,
    }
    write_json(args.json, report)
    return report


if __name__ == "__main__":
    main(sys.argv[1:])
