"""Photometric visual servoing against ViSP 3.5 (``vpFeatureLuminance``): the same image, pose and law.

A peer benchmark, not a test. The harness ``visp_photometric.cpp`` (built and run by ``peers/visp.py``:
``g++ -O2`` and ``pkg-config --cflags --libs visp``, Debian's ``libvisp-dev`` 3.5, into a folder
outside the repository keyed by the source's hash; nothing is committed) is given this project's textured
plane: the texture rounded to 8 bits (a PGM; ViSP's images are ``vpImage<unsigned char>``), the
120 x 90 px camera of ``scenarios.textured_camera()`` and the target and start poses of
``scenarios.textured_plane()``. It reports:

* the interaction matrix ``vpFeatureLuminance`` builds from *this project's* 8-bit image at the
  target, compared entry by entry with ``luminance_interaction_matrix`` of the same image, pixels
  and depth (1 m); ViSP's pixel (i, j) sits at (j, i), this project's at (j + 1/2, i + 1/2), so
  ViSP is given the principal point (u0 - 1/2, v0 - 1/2);
* the target image ``vpImageSimulator`` renders (bilinear) against this project's
  ``render_plane`` rounded to 8 bits, without ViSP's last row and column (it leaves them at 0):
  the grey-level differences, and those against the same warp with ViSP's texture mapping (the
  quadrilateral's corners on the centres of the corner texels, a scale of (W - 1) / W, where
  ``TexturedPlane`` puts them on the texture's outer edges: texel i covers [i, i + 1));
* a run at 25 Hz (6 s from ``textured_plane()``'s start; 16 s from a turn of 60 deg about the
  optical axis, beyond the basin measured by ``bench_photometric.py``) of ViSP's loop (its
  simulator's images, ``vpFeatureLuminance`` at the target, the Levenberg-Marquardt law with the
  same gain and mu schedule,
  ``vpSimulatorCamera``), without and with that simulator's default velocity limits (1 m/s and
  90 deg/s, which ViSP's own photometric example runs with), against ``simulate`` with
  ``photometric`` on the same texture, 8-bit images (``Disturbances(rendered_images=True)``): the
  pose error at each frame, and the distance between the two camera paths;
* the time of one step in each, medians over the run's frames (the same work: one frame of the
  loop, without the plant), and its parts: ViSP's image (``vpImageSimulator::getImage``), feature
  (``buildFrom`` + ``error``) and law (as its example writes it: ``(H + mu diag H)^-1`` by LU and
  ``Lsd.t()`` every frame), against this project's image (``SceneImageSensor.measure``: the warp
  and the markers' features) and update (``PhotometricVS.update``: the error and the law).

Run: ``python benchmarks/peers/visp_photometric.py --json benchmarks/reports/peers_photometric.json``
(ViSP: ``apt-get install -y libvisp-dev`` as root).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

if __name__ == "__main__":  # one BLAS thread, as the other benchmarks' workers (before numpy loads)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import cv2
import numpy as np

import ibvs_youla as iy
from ibvs_youla import scenarios
from ibvs_youla._geometry import pose_error_mm_deg
from ibvs_youla.model.camera import pixel_centres_normalized
from ibvs_youla.model.luminance import BORDER_PX, image_gradients, luminance_interaction_matrix
from ibvs_youla.model.textured_plane import TexturedPlane, render_plane
from ibvs_youla.simulation.rendering import ImagingSettings, finish_image

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: _timing, peers
from _timing import machine
from peers import visp

HERE = Path(__file__).resolve().parent
_HALF_INV = np.array([[1.0, 0.0, -0.5], [0.0, 1.0, -0.5], [0.0, 0.0, 1.0]])  # pixel coordinates -> index
SOURCE = HERE / "visp_photometric.cpp"
RATE_HZ = 25.0


def build() -> tuple[Path, str]:
    """The harness binary (built by ``peers/visp.py`` when absent or stale) and ViSP's version.

    Raises:
        RuntimeError: pkg-config, g++ or ViSP missing, or the build failed (its output in the message).
    """
    version, why = visp.available()
    if version is None:
        raise RuntimeError(why)
    return visp.build(SOURCE), version


def _rows(T: np.ndarray) -> list[float]:
    return [float(v) for v in np.asarray(T)[:3, :4].ravel()]


def _our_step_us(
    scenario: iy.Scenario, camera: Any, frames: int, poses: list[np.ndarray]
) -> dict[str, list[float]]:
    """Per-frame times [us] of SceneImageSensor.measure ("image") and PhotometricVS.update ("law")."""
    from ibvs_youla import controllers
    from ibvs_youla.controllers import ServoTask
    from ibvs_youla.simulation.scene_sensor import SceneImageSensor
    from ibvs_youla.simulation.sensor import MarkerSensor

    sensor = SceneImageSensor(MarkerSensor(camera, scenario.markers_O), scenario.scene, ImagingSettings())
    T_target = np.asarray(scenario.T_O_C_target)
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
    ctrl.reset(task)
    out: dict[str, list[float]] = {"image": [], "law": []}
    for T in poses[:frames]:
        t0 = time.perf_counter()
        frame = sensor.measure(T, 0.0)
        t1 = time.perf_counter()
        ctrl.update(frame, None)
        t2 = time.perf_counter()
        out["image"].append(1e6 * (t1 - t0))
        out["law"].append(1e6 * (t2 - t1))
    return out


MU = (0.01, 1e-4, 90)  # mu_initial, mu_final, frames of mu_initial (the defaults of PhotometricVS)
STARTS = {"default": (None, 150), "rotation_z_60": (60.0, 400)}  # start, frames (6 s, 16 s)


def _visp(
    binary: Path, work: Path, camera: Any, plane: Any, scenario: Any, frames: int, saturate: int
) -> dict:
    """One run of the harness (module docstring); its JSON."""
    width, height = camera.resolution
    f = camera.intrinsic_matrix()[0, 0]
    u0, v0 = camera.principal_point
    half_w, half_h = (0.5 * s for s in plane.size_m)
    params = [width, height, f, f, u0 - 0.5, v0 - 0.5, 1.0, half_w, half_h]  # ViSP's pixel i sits at i
    params += _rows(np.linalg.inv(scenario.T_O_C_target)) + _rows(np.linalg.inv(scenario.T_O_C_start))
    params += [30.0, *MU, frames, 1.0 / RATE_HZ, saturate]
    (work / "params.txt").write_text(" ".join(repr(float(p)) for p in params))
    return visp.run(binary, work / "texture.pgm", work / "target.pgm", work / "params.txt")


def _compare_images(
    visp: dict, camera: Any, plane: Any, T_target: np.ndarray, target_8bit: np.ndarray
) -> dict:
    """L_I of the same image, and the two renderings of the target (module docstring)."""
    width, height = camera.resolution
    I_x, I_y = image_gradients(target_8bit, camera)
    x, y = pixel_centres_normalized(camera)
    inner = (slice(BORDER_PX, height - BORDER_PX), slice(BORDER_PX, width - BORDER_PX))
    ours = luminance_interaction_matrix(*(a[inner].ravel() for a in (I_x, I_y, x, y)), np.ones(x[inner].size))
    theirs = np.asarray(visp["L"]).reshape(visp["rows"], 6)
    rendered = np.asarray(visp["rendered_target"], dtype=np.float64).reshape(height, width)
    cols, rows = plane.texels
    pixel_to_texture = np.linalg.inv(_HALF_INV @ plane.homography(camera, T_target))  # pixel index -> a, b
    visp_mapping = np.diag([(cols - 1) / cols, (rows - 1) / rows, 1.0]) @ pixel_to_texture  # -> ViSP's index
    remapped = cv2.warpPerspective(
        plane.texture_grey,
        visp_mapping,
        (width, height),
        flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=0.0,
    )
    seen = (slice(0, height - 1), slice(0, width - 1))  # ViSP leaves its last row and column at 0
    ours_d = (rendered - target_8bit.astype(np.float64))[seen]
    remapped_d = (rendered - np.rint(remapped))[seen]
    return {
        "interaction_matrix": {
            "rows": visp["rows"],
            "max_abs_difference_relative": float(np.abs(ours - theirs).max() / np.abs(theirs).max()),
        },
        "rendered_target": {
            "last_row_and_column_zero": bool(np.all(rendered[-1] == 0) and np.all(rendered[:, -1] == 0)),
            "mean_abs_grey": float(np.abs(ours_d).mean()),
            "max_abs_grey": float(np.abs(ours_d).max()),
            "with_visp_mapping_mean_abs_grey": float(np.abs(remapped_d).mean()),
            "with_visp_mapping_max_abs_grey": float(np.abs(remapped_d).max()),
        },
    }


def _compare_runs(visp_runs: dict[str, dict], camera: Any, scenario: Any, frames: int) -> dict[str, Any]:
    """Pose errors, path gaps, twists and step times of ViSP's runs and this project's (module docstring)."""
    T_target = np.asarray(scenario.T_O_C_target)
    ours_run = iy.simulate(
        scenario,
        "photometric",
        plant="free-camera",
        camera=camera,
        duration=(frames - 1) / RATE_HZ,
        settings=iy.SimulationSettings(joint_rate_hz=RATE_HZ, camera_rate_hz=RATE_HZ),
        disturbances=iy.Disturbances(rendered_images=True),  # 8-bit images, as ViSP's
    )
    our_poses = [np.asarray(T) for T in ours_run.camera_pose]
    out: dict[str, Any] = {"ours": {"status": ours_run.status}}
    out["ours"]["error_mm_deg"] = [pose_error_mm_deg(T, T_target) for T in our_poses]
    ours_us = _our_step_us(scenario, camera, frames, our_poses)
    out["ours"]["step_us_median"] = float(np.median(np.add(ours_us["image"], ours_us["law"])))
    out["ours"]["parts_us_median"] = {part: float(np.median(t)) for part, t in ours_us.items()}
    twist = np.abs(ours_run.signals["camera_twist"])
    out["ours"]["twist_max"] = [float(twist[:, :3].max()), float(twist[:, 3:].max())]
    for key, run in visp_runs.items():
        poses = []
        for M in np.asarray(run["cMo"]).reshape(-1, 3, 4):
            cMo = np.eye(4)
            cMo[:3, :4] = M
            poses.append(np.linalg.inv(cMo))
        timing = {part: np.asarray(run[f"{part}_us"]) for part in ("image", "feature", "law")}
        twist = np.abs(np.asarray(run["twist"]).reshape(-1, 6))
        n = min(len(poses), len(our_poses))
        gaps = [pose_error_mm_deg(poses[k], our_poses[k]) for k in range(n)]
        out[key] = {
            "error_mm_deg": [pose_error_mm_deg(T, T_target) for T in poses],
            "step_us_median": float(np.median(sum(timing.values()))),
            "parts_us_median": {part: float(np.median(t)) for part, t in timing.items()},
            "twist_max": [float(twist[:, :3].max()), float(twist[:, 3:].max())],
            "path_gap_max_mm_deg": [max(g[0] for g in gaps), max(g[1] for g in gaps)],
            "frames_compared": n,
        }
    return out


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Build and run the harness, compare, print; write JSON if asked; return the report."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="FILE", help="write the report here")
    args = ap.parse_args(argv)
    binary, version = build()
    camera = scenarios.textured_camera()
    plane = TexturedPlane(texture=np.rint(TexturedPlane().texture_grey))  # the 8-bit texture ViSP reads
    work = Path(tempfile.mkdtemp(prefix="visp-photometric-"))
    cv2.imwrite(str(work / "texture.pgm"), plane.texture_grey.astype(np.uint8))
    report: dict[str, Any] = {"benchmark": "peers_photometric", "visp_version": version, "starts": {}}
    for name, (angle, frames) in STARTS.items():
        if angle is None:
            scenario = scenarios.textured_plane(scene=plane)
        else:
            scenario = scenarios.textured_plane((0.0, 0.0, 0.0), (0.0, 0.0, angle), scene=plane)
        T_target = np.asarray(scenario.T_O_C_target)
        target_8bit = finish_image(render_plane(camera, plane, T_target), ImagingSettings(), None)
        cv2.imwrite(str(work / "target.pgm"), target_8bit)
        runs = {
            key: _visp(binary, work, camera, plane, scenario, frames, s)
            for key, s in (("visp", 0), ("visp_saturated", 1))
        }
        if angle is None:
            report.update(_compare_images(runs["visp"], camera, plane, T_target, target_8bit))
        compared = _compare_runs({key: run["run"] for key, run in runs.items()}, camera, scenario, frames)
        report["starts"][name] = {"frames": frames, "runs": compared}
        for key, run in compared.items():
            e, gap = run["error_mm_deg"], run.get("path_gap_max_mm_deg")
            print(
                f"{name:<13} {key:<15} end {e[-1][0]:.3g} mm {e[-1][1]:.3g} deg"
                + (f"; path off ours by up to {gap[0]:.3g} mm, {gap[1]:.3g} deg" if gap else "")
                + f"; step {run['step_us_median']:.0f} us {run['parts_us_median']}"
            )
    report.update(
        camera={"width": camera.resolution[0], "height": camera.resolution[1], "focal_px": 150.0},
        gain=30.0,
        mu_schedule=list(MU),
        machine=machine(),
    )
    L, image = report["interaction_matrix"], report["rendered_target"]
    print(
        f"ViSP {version}: L_I of one image, {L['rows']} rows: largest difference "
        f"{L['max_abs_difference_relative']:.2e} of the largest entry"
    )
    print(
        f"target image (but ViSP's last row and column, 0): vpImageSimulator - ours: mean |d| "
        f"{image['mean_abs_grey']:.2f}, max {image['max_abs_grey']:.0f} grey levels; with ViSP's texture "
        f"mapping {image['with_visp_mapping_mean_abs_grey']:.2f}, "
        f"max {image['with_visp_mapping_max_abs_grey']:.0f}"
    )
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1) + "\n")
    return report


if __name__ == "__main__":
    main(sys.argv[1:])
