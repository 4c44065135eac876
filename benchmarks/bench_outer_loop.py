"""Time one adaptive outer-loop update, its parts, its floor and the literal rebuild, in one run.

The update is what the servo loop does at every camera frame of an adaptive run, through the
public roles: the true camera pose (forward kinematics of the true arm), the sensor's features
(``MarkerSensor.measure``: stereo projection, Eq. (11), (24), and per-point visibility), and the
paper's controller (``YoulaController.update``): the configuration estimate of Eq. (62) (stereo P3P +
closed-form IK, nearest branch), the image Jacobian L(P_C) J_C(q~) of Eq. (51), its SVD with
the singular-value policy (Eq. (57), ERRATA 7), and the controller state update
q_fb = K(z)[J^+ e] (ERRATA 9).

Parts, timed alone on the same data, calling what the update calls: ``camera_pose`` (forward
kinematics of the true arm), ``sensor`` (``MarkerSensor.measure``: P_C, then features and
visibility in one compiled call), ``p3p`` (triangulation + Kabsch with its 3x3 SVD, one compiled
call), ``ik`` (``Arm.ik_nearest_kinematics``: the compiled nearest IK branch, then one Pinocchio
pass at q~ that checks it and gives T_O_C(q~) and J_C(q~)), ``jacobian`` (L(P_C) J_C, compiled),
``svd_gains`` (the 9x6 SVD, the gains and P e, compiled) and ``state_update`` (the filter step).
``glue_median_us`` = update - the sum of the parts' medians: the calls between them (method
calls, the image error, the frame tuple).

Configurations: seeded random perturbations (0.05 rad) of points on the joint path of both
paper scenarios, the encoders reading q_true - d (the default branch prior of Eq. (62) picks
the IK branch nearest them). Every call is timed alone (``time.perf_counter``) in a pass over
all configurations: a pass of updates, a pass of their parts, a pass of the floor calls,
alternating for every round, so that all see the same machine load; medians and 95th
percentiles are reported. (Inside the simulator, between joint-loop steps, the same update
costs 5-10 % more: bench_simulation.py.)

Floor: the calls an update cannot avoid, timed alone on the same data: Pinocchio forward
kinematics + frame placement of the camera, its LOCAL frame Jacobian, and the bare LAPACK
``dgesdd`` of the 9x6 image Jacobian and of the 3x3 cross-covariance of stereo P3P.
``floor_median_us`` is the sum of their medians; ``ratio_to_floor`` = update / floor.

Rebuild: Eq. (58)-(61) built literally every frame with python-control (MIMO transfer
matrices and a minimal state-space realization, :func:`ibvs_youla.control.literal.literal_mimo`),
reported as ``rebuild_ratio`` = rebuild median / update median.

The SVDs inside the update are LAPACK's ``dgesdd`` called from compiled code
(:func:`ibvs_youla._linalg.gesdd`), the same routine bit for bit as the floor's, without the f2py
wrapper; ``svd_9x6_compiled`` and ``svd_3x3_compiled`` time that call from Python (its Numba
dispatch included) for comparison.

Run: ``python benchmarks/bench_outer_loop.py --json outer_loop.json``.
"""

from __future__ import annotations

import argparse
import gc
import sys
from typing import Any

import numpy as np
import pinocchio as pin
from scipy.linalg import lapack

try:  # imported as benchmarks.bench_outer_loop
    from ._timing import CpuShare, count, machine, perf_counter, summary_us, write_json
except ImportError:  # run as a script
    from _timing import CpuShare, count, machine, perf_counter, summary_us, write_json

from ibvs_youla import scenarios
from ibvs_youla._linalg import gesdd
from ibvs_youla.control.discrete import DiscreteFilter
from ibvs_youla.control.literal import literal_mimo
from ibvs_youla.control.outer import OuterLoopDesign
from ibvs_youla.control.svd_kernels import svd_gains_apply
from ibvs_youla.controllers import JointReading, ServoTask, YoulaController
from ibvs_youla.estimation.stereo_kernels import camera_pose_from_features
from ibvs_youla.model.arm import Arm
from ibvs_youla.model.camera import StereoCamera
from ibvs_youla.model.camera_kernels import camera_parameters, image_jacobian
from ibvs_youla.simulation.sensor import MarkerSensor
from ibvs_youla.simulation.settings import SimulationSettings

PARTS = ("camera_pose", "sensor", "p3p", "ik", "jacobian", "svd_gains", "state_update")
FLOOR = ("fk", "frame_jacobian", "svd_9x6", "svd_3x3")
EXTRA = ("svd_9x6_numpy", "svd_3x3_numpy", "svd_9x6_compiled", "svd_3x3_compiled")
TARGET_RATIO = 2.5  # target: the update within 2.5x of its floor


def _configurations(arm: Arm, n: int, seed: int) -> list[tuple[Any, np.ndarray]]:
    """n (scenario, q_true) on both paper scenarios' joint paths, perturbed by 0.05 rad, within limits."""
    rng = np.random.default_rng(seed)
    out = []
    paper = scenarios.paper_scenarios()
    while len(out) < n:
        sc = paper[len(out) % 2]
        q = sc.q_start + rng.random() * (sc.q_target - sc.q_start) + 0.05 * rng.standard_normal(6)
        out.append((sc, np.clip(q, arm.q_min + 0.01, arm.q_max - 0.01)))
    return out


class _Frame:
    """One scenario's sensor and paper controller, built through the public roles, and the parts."""

    def __init__(self, sc: Any, arm: Arm, camera: StereoCamera) -> None:
        settings = SimulationSettings.paper()  # adaptive outer loop at every 1 kHz sample
        self.sensor = MarkerSensor(camera, sc.markers_O, virtual_points=sc.virtual_points)
        T_target = arm.camera_pose(sc.q_target)
        self.task = ServoTask(
            camera=camera,
            markers_O=sc.markers_O,
            feature_target=self.sensor.features_at(T_target),
            T_O_C_target=T_target,
            tick_period=settings.dt,
            frame_period=settings.dt,
            virtual_points=sc.virtual_points,
            arm=arm,
            q_start=sc.q_start,
            q_target=sc.q_target,
        )
        s = settings.controller_settings()
        self.controller = YoulaController(with_feedforward=True, adaptive=True, settings=s)
        self.controller.reset(self.task)
        self.arm = arm
        # The update's parts, built as the controller builds its own, for the timed parts.
        self.params, self.lens_x = camera_parameters(camera)
        self.markers_O = np.array(sc.markers_O, dtype=float)
        self.markers_mean = self.markers_O.mean(axis=0)
        self.markers_centred = self.markers_O - self.markers_mean
        self.virtual_points = sc.virtual_points
        design = OuterLoopDesign(s.omega_n, s.zeta, s.tau_in, s.sv_policy)
        self.damped, self.threshold = design.sv_policy.kind == "damped", design.sv_policy.threshold
        self.filter = DiscreteFilter.from_tf(design.filter_tf(), settings.dt, arm.nq)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmark, print a summary, write JSON if asked; return the report."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="FILE", help="write the report here")
    ap.add_argument("--configs", type=count, default=200, help="seeded configurations (default 200)")
    ap.add_argument("--repeats", type=count, default=15, help="timed passes over them (default 15)")
    ap.add_argument("--rebuilds", type=count, default=15, help="timed literal rebuilds (default 15)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)

    arm, camera = Arm.irb4600(), StereoCamera.zed2()
    runs = {sc.name: _Frame(sc, arm, camera) for sc in scenarios.paper_scenarios()}
    model, data, cam_id = arm.model, arm.model.createData(), arm.model.getFrameId(arm.camera_frame)
    configs = _configurations(arm, args.configs, args.seed)

    # Data of each configuration, computed once with the library's checked methods.
    from ibvs_youla.estimation.eye_in_hand import EyeInHand

    prepared = []
    for sc, q_true in configs:
        run = runs[sc.name]
        eye = EyeInHand(arm, camera, sc.markers_O, virtual_points=sc.virtual_points)
        q_enc = q_true - sc.joint_offset  # Eq. (62) picks the branch nearest the encoders
        p = eye.features(q_true)
        q_est = eye.estimate_q(p, q_enc)
        J = eye.jacobian(q_est)
        H = eye.camera.triangulate(p.reshape(-1, 3), allow_behind=True)
        H = (H - H.mean(axis=0)).T @ (eye.markers_O - eye.markers_O.mean(axis=0))
        prepared.append((run, q_true, q_enc, q_est, J, H))

    names = ("update", *PARTS, *FLOOR, *EXTRA)
    times: dict[str, list[float]] = {k: [] for k in names}

    zeros = np.zeros(6)

    def update_pass(record: bool) -> None:
        for run, q_true, q_enc, _, _, _ in prepared:
            reading = JointReading(0.0, q_enc, zeros)  # this configuration, at rest
            t0 = perf_counter()
            frame = run.sensor.measure(run.arm.camera_pose(q_true), 0.0)  # the update, as the loop runs it
            run.controller.update(frame, reading)
            t1 = perf_counter()
            if record:
                times["update"].append(t1 - t0)

    def parts_pass(record: bool) -> None:
        """The update's parts in its order, calling what the sensor and the controller call."""
        for run, q_true, q_enc, _, _, _ in prepared:
            t = [perf_counter()]
            T_true = run.arm.camera_pose(q_true)
            t.append(perf_counter())
            frame = run.sensor.measure(T_true, 0.0)
            t.append(perf_counter())
            T_seen, _ = camera_pose_from_features(
                frame.features, run.params, run.virtual_points, run.markers_centred, run.markers_mean
            )
            t.append(perf_counter())
            _, T_q, J_C = run.arm.ik_nearest_kinematics(T_seen, q_enc)
            t.append(perf_counter())
            J_hat, _ = image_jacobian(T_q, J_C, run.markers_O, run.params, run.lens_x, run.virtual_points)
            t.append(perf_counter())
            Pe = np.empty(6)
            svd_gains_apply(J_hat, run.task.feature_target - frame.features, run.damped, run.threshold, Pe)
            t.append(perf_counter())
            run.filter.step(Pe)
            t.append(perf_counter())
            if record:
                for name, a, b in zip(PARTS, t[:-1], t[1:], strict=True):
                    times[name].append(b - a)

    def floor_pass(record: bool) -> None:
        """The bare Pinocchio and LAPACK calls on the same data (and numpy's SVD wrapper)."""
        for _, q_true, _, q_est, J, H in prepared:
            t = [perf_counter()]
            pin.forwardKinematics(model, data, q_true)
            pin.updateFramePlacement(model, data, cam_id)
            t.append(perf_counter())
            pin.computeFrameJacobian(model, data, q_est, cam_id, pin.LOCAL)
            t.append(perf_counter())
            lapack.dgesdd(J, 1, 0)  # compute_uv, full_matrices
            t.append(perf_counter())
            lapack.dgesdd(H, 1, 0)
            t.append(perf_counter())
            np.linalg.svd(J, full_matrices=False)
            t.append(perf_counter())
            np.linalg.svd(H)
            t.append(perf_counter())
            gesdd(J)
            t.append(perf_counter())
            gesdd(H)
            t.append(perf_counter())
            if record:
                for name, a, b in zip((*FLOOR, *EXTRA), t[:-1], t[1:], strict=True):
                    times[name].append(b - a)

    cpu = CpuShare()
    gc_was_enabled = gc.isenabled()
    gc.disable()
    try:
        for i in range(3 + args.repeats):  # 3 warm-up rounds; the passes alternate, so all see the same load
            for one_pass in (update_pass, parts_pass, floor_pass):
                one_pass(record=i >= 3)
    finally:
        if gc_was_enabled:
            gc.enable()
    cores = cpu.stop()

    s = SimulationSettings.paper()
    design = OuterLoopDesign(s.omega_n, s.zeta, s.tau_in, s.sv_policy)
    rebuild = []
    literal_mimo(design, prepared[0][4])  # warm-up
    for i in range(args.rebuilds):
        J = prepared[i % len(prepared)][4]
        t0 = perf_counter()
        literal_mimo(design, J)
        rebuild.append(perf_counter() - t0)

    stats = {name: summary_us(v) for name, v in times.items()}
    update = stats["update"]
    floor = sum(stats[name]["median_us"] for name in FLOOR)
    floor_numpy = (
        floor
        - stats["svd_9x6"]["median_us"]
        - stats["svd_3x3"]["median_us"]
        + (stats["svd_9x6_numpy"]["median_us"] + stats["svd_3x3_numpy"]["median_us"])
    )
    rebuild_stats = summary_us(rebuild)
    parts_sum = sum(stats[name]["median_us"] for name in PARTS)
    report: dict[str, Any] = {
        "benchmark": "outer_loop",
        "update_median_us": update["median_us"],
        "update_p95_us": update["p95_us"],
        "floor_median_us": floor,
        "ratio_to_floor": update["median_us"] / floor,
        "target": {"ratio_to_floor_max": TARGET_RATIO, "met": update["median_us"] / floor <= TARGET_RATIO},
        "rebuild_median_us": rebuild_stats["median_us"],
        "rebuild_ratio": rebuild_stats["median_us"] / update["median_us"],
        **{f"{name}_median_us": stats[name]["median_us"] for name in PARTS},
        "parts_sum_median_us": parts_sum,
        "glue_median_us": update["median_us"] - parts_sum,
        "floor_numpy_svd_median_us": floor_numpy,
        "cpu": cores,
        "stats": {**stats, "rebuild": rebuild_stats},
        "settings": {
            "configs": args.configs,
            "repeats": args.repeats,
            "rebuilds": args.rebuilds,
            "seed": args.seed,
        },
        "machine": machine(),
    }
    _print(report)
    write_json(args.json, report, headline)
    return report


def headline(r: dict[str, Any]) -> dict[str, Any]:
    """The figures kept in the report's history."""
    return {
        "update_median_us": r["update_median_us"],
        "floor_median_us": r["floor_median_us"],
        "ratio_to_floor": r["ratio_to_floor"],
        "rebuild_ratio": r["rebuild_ratio"],
        "other_cores": r.get("cpu", {}).get("other_cores"),
    }


def _print(r: dict[str, Any]) -> None:
    s = r["stats"]
    print(
        f"adaptive outer-loop update: median {r['update_median_us']:.1f} us, "
        f"p95 {r['update_p95_us']:.1f} us (n = {s['update']['n']})"
    )
    for name in PARTS:
        print(f"  {name:<16} {s[name]['median_us']:8.2f} us  (p95 {s[name]['p95_us']:.2f})")
    print(f"  {'glue':<16} {r['glue_median_us']:8.2f} us  (update - the parts' medians)")
    print(
        f"floor {r['floor_median_us']:.2f} us  (ratio update/floor {r['ratio_to_floor']:.2f}, target "
        f"<= {TARGET_RATIO} {'met' if r['target']['met'] else 'NOT met'}; with numpy's svd wrapper "
        f"{r['floor_numpy_svd_median_us']:.2f} us); other jobs used {_cores(r['cpu'])} cores meanwhile"
    )
    for name in (*FLOOR, *EXTRA):
        print(f"  {name:<16} {s[name]['median_us']:8.2f} us")
    print(
        f"literal python-control rebuild: median {r['rebuild_median_us'] / 1e3:.2f} ms, "
        f"{r['rebuild_ratio']:.0f}x the update"
    )


def _cores(cpu: dict[str, Any]) -> str:
    return "?" if cpu.get("other_cores") is None else f"{cpu['other_cores']:.2f}"


if __name__ == "__main__":
    main(sys.argv[1:])
