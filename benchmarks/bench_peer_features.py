"""Polar and moment features against their peers: ViSP 3.5 (C++) and the Machine Vision Toolbox for Python.

An agreement benchmark, not a speed one: on the same cases it compares the interaction matrices
and short runs of this package's ``ibvs-polar`` and ``ibvs-moments`` with

* ViSP 3.5's ``vpFeaturePointPolar`` (the polar rows) and ``vpFeatureMomentCommon`` on a
  ``DISCRETE`` ``vpMomentObject`` (x_n, y_n, a_n, the invariants P_x and P_y, alpha: values and
  rows), and a ``vpServo`` run on those moment features with L at the desired features, through
  ``benchmarks/peers/visp_features.cpp`` (built by ``benchmarks/peers/visp.py``: g++ and
  ``pkg-config visp``, Debian's ``libvisp-dev``);
* the toolbox's ``CentralCamera.visjac_p_polar`` and ``IBVS_polar`` (its law's first step and a
  whole run), in a worker process of a throwaway interpreter (``benchmarks/peers/mvtb.py``, or
  ``--mvtb-python PATH``).

Cases: ``polar``: 40 seeded points (x, y within +-0.6, Z in 0.5-3 m), and the point at r = 0.03
inside the toolbox's clamp; the half turn of the 20 cm square about the optical axis at 0.75 m and
ViSP's tutorial-ibvs-4pts start (``tests/test_ibvs.py``); ``moments``: the seven irregular points
(ViSP's ``servoMomentPoints`` set) at a parallel target 0.75 m away, seen from 12 seeded poses up
to 25 deg and 0.1 m off (tilted planes, so the general rows are compared), and a 30 s run at
25 Hz from the tutorial's start.

JSON (``--json``): per comparison the largest absolute difference, and where the peers differ by
design the relation checked (e.g. ViSP's P_y over this package's).

Where they differ, and why (measured; the numbers in docs/controllers.md):

* the toolbox's ``visjac_p_polar`` is minus this package's rows, in the order (phi, r): its law
  pairs it with e = s* - s, so the twist is the same; it clamps r at 0.05 inside the rows (a
  point nearer the principal point gets other rows); its ``IBVS_polar`` clips each step's
  displacement to a norm of 0.02 (0.5 rad/s at 25 Hz), so its half turn is slower;
* ViSP's discrete P_y is a I_2 / I_3^3 with a = mu20 + mu02 (its stand-in for the area), this
  package's n I_2 / I_3^3: ViSP's value is this one's times a / n, its row the chain rule of that
  product, and it moves with v_z at a parallel target (this one's does not);
* both lift alpha from the ellipse angle to a full turn with the third-order moments turned back
  by alpha - alpha*; ViSP adds pi when any one of the four changes sign (above 1e-6), this package
  when their dot product with the target's is negative. A tilt of ~20 deg can flip the sign of
  the smallest one alone, and ViSP then reads a half turn that is not there. Run:
``python benchmarks/bench_peer_features.py --json peers.json [--mvtb-python PATH]``.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from peers import mvtb, visp  # noqa: E402

try:  # imported as benchmarks.bench_peer_features
    from ._timing import machine, write_json
except ImportError:  # run as a script
    from _timing import machine, write_json

import ibvs_youla as iy  # noqa: E402
from ibvs_youla.controllers.image_moments import MomentFeatures, centred_moments, plane_of_points  # noqa: E402
from ibvs_youla.controllers.image_points import normalized_point_rows  # noqa: E402
from ibvs_youla.controllers.moments import MomentIBVS  # noqa: E402
from ibvs_youla.controllers.polar import PolarIBVS, polar_features, polar_interaction_matrix  # noqa: E402

SQUARE_O = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])
IRREGULAR_O = np.array([[1, 0], [3, 1], [4, 4], [-1, 4], [-3, -2], [-2, -2], [-1, 1]], dtype=float) / 20.0
IRREGULAR_O = np.column_stack((IRREGULAR_O - IRREGULAR_O.mean(axis=0), np.zeros(7)))
LAMBDA, T, Z_TARGET = 0.5, 0.04, 0.75  # [1/s], [s], [m]
SETTINGS = iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0)


def T_O_C(t: list[float], theta_u_deg: list[float]) -> np.ndarray:
    """Camera pose from the object pose in the camera (ViSP's cMo: translation, theta-u [deg])."""
    cMo = np.eye(4)
    cMo[:3, :3] = Rotation.from_rotvec(np.radians(theta_u_deg)).as_matrix()
    cMo[:3, 3] = t
    return np.linalg.inv(cMo)


TARGET = T_O_C([0, 0, Z_TARGET], [0, 0, 0])
STARTS = {
    "half turn": T_O_C([0, 0, Z_TARGET], [0, 0, 180]),
    "tutorial": T_O_C([0.15, -0.1, 1.0], [10, -10, 50]),
}


def _numbers(values: Any) -> str:
    return " ".join(f"{float(v):.17g}" for v in np.ravel(values))


def _run(controller: Any, start: np.ndarray, points_O: np.ndarray, duration: float = 30.0) -> Any:
    scenario = iy.Scenario.free_camera(T_O_C_start=start, T_O_C_target=TARGET, markers_O=points_O)
    return iy.simulate(
        scenario,
        controller=controller,
        plant="free-camera",
        camera=iy.PinholeCamera.normalized(),
        duration=duration,
        settings=SETTINGS,
    )


def _pose_error(T_a: np.ndarray, T_b: np.ndarray) -> tuple[float, float]:
    from ibvs_youla.analysis.metrics import pose_error_mm_deg

    return pose_error_mm_deg(T_a, T_b)


# ---------------------------------------------------------------------------------------- polar
def polar_cases(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) (m, 2) and Z (m,) of the polar comparison: 40 seeded points and one at r = 0.03."""
    p = rng.uniform(-0.6, 0.6, (40, 2))
    p = p[np.hypot(p[:, 0], p[:, 1]) > 0.05]
    p = np.vstack((p, [[0.03 * math.cos(0.4), 0.03 * math.sin(0.4)]]))
    return p, rng.uniform(0.5, 3.0, len(p))


def ours_polar_rows(p: np.ndarray, Z: np.ndarray) -> np.ndarray:
    """This package's L_(r, phi) (2 m, 6)."""
    return polar_interaction_matrix(polar_features(p), *normalized_point_rows(p[:, 0], p[:, 1], Z))


def compare_polar(harness: visp.Harness, worker: Any, rng: np.random.Generator) -> dict[str, Any]:
    p, Z = polar_cases(rng)
    ours = ours_polar_rows(p, Z)
    answer = np.array(harness.ask(f"polar {len(p)} " + _numbers(np.column_stack((p, Z)))))
    visp_rows = answer.reshape(len(p), 14)[:, 2:].reshape(-1, 6)
    out: dict[str, Any] = {
        "points": len(p),
        "visp_rows_max_abs_difference": float(np.abs(visp_rows - ours).max()),
    }
    if worker is not None:
        J = np.array(worker.ask({"what": "jacobian", "p": p.tolist(), "Z": Z.tolist()})["J"])
        # the toolbox's rows are (phi, r), its J maps the camera's velocity to minus our rates
        as_ours = -J.reshape(-1, 2, 6)[:, ::-1].reshape(-1, 6)
        r = np.hypot(p[:, 0], p[:, 1])
        far = np.repeat(r >= 0.05, 2)
        out["mvtb_rows_max_abs_difference_r_ge_0.05"] = float(np.abs(as_ours[far] - ours[far]).max())
        out["mvtb_rows_max_abs_difference_r_0.03"] = float(np.abs(as_ours[~far] - ours[~far]).max())
        out["mvtb_runs"] = {name: compare_polar_run(worker, name, start) for name, start in STARTS.items()}
    return out


def compare_polar_run(worker: Any, name: str, start: np.ndarray) -> dict[str, Any]:
    """The toolbox's IBVS_polar (gain lambda T per step, its 0.02 clip) against ibvs-polar, 750 steps."""
    ours = {wrap: _run(PolarIBVS(wrap=wrap), start, SQUARE_O) for wrap in ("joint", "per-point")}
    answer = worker.ask(
        {
            "what": "run",
            "P": SQUARE_O.T.tolist(),
            "pose_0": start.tolist(),
            "pose_d": TARGET.tolist(),
            "lmbda": LAMBDA * T,
            "steps": 750,
        }
    )
    poses = np.array(answer["poses"])
    first_unclipped = np.array(answer["first_step_unclipped"]) / T  # a displacement per step -> a twist
    mvtb_depth = -poses[:, 2, 3]
    out = {
        "mvtb_first_twist_unclipped": first_unclipped.tolist(),
        "mvtb_first_step_clipped_norm": float(np.linalg.norm(answer["first_step"])),
        "mvtb_final_pose_error_mm_deg": _pose_error(poses[-1], TARGET),
        "mvtb_depth_range_m": [float(mvtb_depth.min()), float(mvtb_depth.max())],
    }
    for wrap, result in ours.items():
        depth = -result.camera_pose[:, 2, 3]
        out[f"ours_{wrap}"] = {
            "first_twist": result.signals["camera_twist"][0].tolist(),
            "first_twist_difference_to_mvtb_unclipped": float(
                np.abs(result.signals["camera_twist"][0] - first_unclipped).max()
            ),
            "final_pose_error_mm_deg": result.final_pose_error(),
            "depth_range_m": [float(depth.min()), float(depth.max())],
        }
    return out


# ---------------------------------------------------------------------------------------- moments
def moment_poses(rng: np.random.Generator, n: int = 12) -> list[np.ndarray]:
    """Seeded camera poses up to 25 deg and 0.1 m off the target (planes tilted in both axes)."""
    return [
        T_O_C(rng.uniform(-0.1, 0.1, 3) + np.array([0.0, 0.0, 1.0]), rng.uniform(-25, 25, 3))
        for _ in range(n)
    ]


def _image(T: np.ndarray, P_O: np.ndarray) -> tuple[np.ndarray, tuple[float, float, float]]:
    P_C = (P_O - T[:3, 3]) @ T[:3, :3]
    return P_C[:, :2] / P_C[:, 2:], plane_of_points(P_C)


def compare_moments(harness: visp.Harness, rng: np.random.Generator) -> dict[str, Any]:
    p_t, plane_t = _image(TARGET, IRREGULAR_O)
    ours = MomentFeatures(p_t, plane_t)
    n = len(p_t)
    worst = {name: 0.0 for name in ("features", "rows", "P_y_relation", "L_P_y_relation")}
    per_feature = np.zeros(6)
    per_row = np.zeros(6)
    vz_at_target = None
    alpha_turn: list[dict[str, Any]] = []
    for T in [TARGET, *moment_poses(rng)]:
        p, plane = _image(T, IRREGULAR_O)
        request = f"moments {n} {ours.depth_target:.17g} {_numbers(plane_t)} {_numbers(plane)} "
        answer = np.array(harness.ask(request + _numbers(p_t) + " " + _numbers(p)))
        s_visp, L_visp = answer[:6], answer[6:42].reshape(6, 6)
        a = answer[44]  # mu20 + mu02 of the image, ViSP's discrete stand-in for the area
        s, L = ours.features(p), ours.interaction_matrix(p, plane)
        mu = centred_moments(p, 2)
        assert abs(a - (mu[2, 0] + mu[0, 2])) < 1e-12
        same = [0, 1, 2, 3, 5]  # x_n, y_n, a_n, P_x, alpha: the same definitions
        d_s = np.abs(MomentFeatures.error(s_visp, s))
        per_feature = np.maximum(per_feature, d_s)
        per_row = np.maximum(per_row, np.abs(L_visp - L).max(axis=1))
        worst["features"] = max(worst["features"], float(d_s[same[:4]].max()))
        worst["rows"] = max(worst["rows"], float(np.abs(L_visp[same] - L[same]).max()))
        # alpha: the same ellipse angle, lifted to a full turn by different rules (module docstring)
        alpha_turn.append(
            {
                "ours_minus_target_rad": float(MomentFeatures.error(s, ours.features(p_t))[5]),
                "visp_minus_target_rad": float(MomentFeatures.error(s_visp, ours.features(p_t))[5]),
                "differ_by_pi": bool(abs(d_s[5] - math.pi) < 1e-9),
            }
        )
        # ViSP's P_y = a I_2 / I_3^3 with a = mu20 + mu02; ours n I_2 / I_3^3: ViSP's = ours * a / n
        worst["P_y_relation"] = max(worst["P_y_relation"], abs(s_visp[4] - s[4] * a / n) / abs(s_visp[4]))
        L_a = _area_row(p, plane)
        expected_row = (a * L[4] + s[4] * L_a) / n
        worst["L_P_y_relation"] = max(worst["L_P_y_relation"], float(np.abs(L_visp[4] - expected_row).max()))
        if T is TARGET:
            vz_at_target = {"visp_P_y_v_z": float(L_visp[4, 2]), "ours_P_y_v_z": float(L[4, 2])}
    return {
        "poses": 13,
        "max_abs_difference_x_n_y_n_a_n_P_x": worst["features"],
        "alpha_differs_by_pi_at_poses": sum(a["differ_by_pi"] for a in alpha_turn),
        "alpha_max_abs_difference_elsewhere": max(
            abs(a["ours_minus_target_rad"] - a["visp_minus_target_rad"])
            for a in alpha_turn
            if not a["differ_by_pi"]
        ),
        "alpha_largest_turn_from_target_rad": {
            "ours": max(abs(a["ours_minus_target_rad"]) for a in alpha_turn),
            "visp": max(abs(a["visp_minus_target_rad"]) for a in alpha_turn),
        },
        "max_abs_difference_rows_same_definitions": worst["rows"],
        "max_abs_difference_per_feature": dict(
            zip(("x_n", "y_n", "a_n", "P_x", "P_y", "alpha"), per_feature.tolist(), strict=True)
        ),
        "max_abs_difference_per_row": dict(
            zip(("x_n", "y_n", "a_n", "P_x", "P_y", "alpha"), per_row.tolist(), strict=True)
        ),
        "P_y_visp_over_ours_is_a_over_n_rel": worst["P_y_relation"],
        "L_P_y_visp_is_chain_rule_of_a_P_y_over_n_max_abs": worst["L_P_y_relation"],
        "at_parallel_target": vz_at_target,
    }


def _area_row(p: np.ndarray, plane: tuple[float, float, float]) -> np.ndarray:
    """L_a of a = mu20 + mu02 (6,), from the point rows with the plane's depths."""
    A, B, C = plane
    Z = 1.0 / (A * p[:, 0] + B * p[:, 1] + C)
    L_x, L_y = normalized_point_rows(p[:, 0], p[:, 1], Z)
    q = p - p.mean(axis=0)
    return 2.0 * (q[:, 0] @ (L_x - L_x.mean(axis=0)) + q[:, 1] @ (L_y - L_y.mean(axis=0)))


def compare_moment_run(harness: visp.Harness) -> dict[str, Any]:
    """ViSP's vpServo on its moment features (L at the desired ones) against ibvs-moments, 30 s at 25 Hz."""
    start = STARTS["tutorial"]
    steps = 750
    cMo, cdMo = np.linalg.inv(start), np.linalg.inv(TARGET)

    def pose12(M: np.ndarray) -> str:
        return _numbers(np.concatenate((M[:3, :3].ravel(), M[:3, 3])))

    request = f"servo {len(IRREGULAR_O)} {LAMBDA} {T} {steps} {pose12(cMo)} {pose12(cdMo)} " + _numbers(
        IRREGULAR_O
    )
    answer = np.array(harness.ask(request)).reshape(steps, 12)
    visp_poses = []
    for row in answer:
        M = np.eye(4)
        M[:3, :3], M[:3, 3] = row[:9].reshape(3, 3), row[9:]
        visp_poses.append(np.linalg.inv(M))  # cMo -> T_O_C
    ours = _run(MomentIBVS(), start, IRREGULAR_O)
    ours_poses = ours.camera_pose[1:]  # after each step, as the harness reports
    gap = [float(np.linalg.norm(a[:3, 3] - b[:3, 3])) for a, b in zip(visp_poses, ours_poses, strict=False)]
    return {
        "steps": steps,
        "visp_final_pose_error_mm_deg": _pose_error(visp_poses[-1], TARGET),
        "ours_final_pose_error_mm_deg": ours.final_pose_error(),
        "largest_distance_between_the_camera_paths_m": max(gap),
        "distance_after_1_s_m": gap[24],
    }


# ---------------------------------------------------------------------------------------- toolbox worker
_MVTB_WORKER = r"""
import json, sys
import numpy as np
from machinevisiontoolbox import CentralCamera, IBVS_polar
from spatialmath import SE3
import spatialmath.base as smb

def camera():
    return CentralCamera(f=1.0, rho=1.0, pp=(0.0, 0.0), imagesize=(2, 2))  # normalized coordinates

for line in sys.stdin:
    q = json.loads(line)
    if q["what"] == "jacobian":
        p = np.array(q["p"])
        polar = np.vstack((np.arctan2(p[:, 1], p[:, 0]), np.hypot(p[:, 0], p[:, 1])))
        out = {"J": camera().visjac_p_polar(polar, np.array(q["Z"])).tolist()}
    else:
        vs = IBVS_polar(camera(), P=np.array(q["P"]), pose_0=SE3(np.array(q["pose_0"]), check=False),
                        pose_d=SE3(np.array(q["pose_d"]), check=False), lmbda=q["lmbda"], graphics=False)
        vs.init()
        cam = vs.camera
        p = cam.project_point(vs.P)
        e = vs.p_star - p
        e[0, :] = smb.wrap_mpi_pi(e[0, :])
        Z = (cam.pose.inv() * vs.P)[2, :]
        first = -vs.lmbda @ np.linalg.pinv(cam.visjac_p_polar(p, Z)) @ e.flatten(order="F")
        poses = []
        for k in range(q["steps"]):
            vs.step(k)
            poses.append(cam.pose.A.tolist())
        out = {"first_step_unclipped": first.tolist(), "first_step": vs.history[0].vel.tolist()}
        out["poses"] = poses
    print(json.dumps(out), flush=True)
"""


class _Worker:
    def __init__(self, python: str) -> None:
        self.proc = subprocess.Popen(
            [python, "-c", _MVTB_WORKER],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env={"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin"},
        )
        version = subprocess.run(
            [python, "-c", "import machinevisiontoolbox as m; print(m.__version__)"],
            capture_output=True,
            text=True,
            check=True,
        )
        self.version = version.stdout.strip()

    def ask(self, request: dict[str, Any]) -> dict[str, Any]:
        self.proc.stdin.write(json.dumps(request) + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError(f"the toolbox worker ended (exit code {self.proc.wait()})")
        return json.loads(line)

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait(timeout=60)


# ---------------------------------------------------------------------------------------- main
def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the comparisons, print them, write JSON if asked; return the report."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="FILE", help="write the report here")
    ap.add_argument("--mvtb-python", metavar="PATH", help="an interpreter with the toolbox (default: a venv)")
    ap.add_argument("--no-mvtb", action="store_true", help="skip the toolbox")
    ap.add_argument("--seed", type=int, default=24)
    args = ap.parse_args(argv)

    rng = np.random.default_rng(args.seed)
    worker = None if args.no_mvtb else _Worker(args.mvtb_python or str(mvtb.python()))
    version, why = visp.available()
    if version is None:
        raise SystemExit(f"bench_peer_features: {why}")
    try:
        with visp.Harness(visp.build("visp_features.cpp")) as harness:
            report: dict[str, Any] = {
                "benchmark": "peer_features",
                "visp": version,
                "mvtb": None if worker is None else worker.version,
                "polar": compare_polar(harness, worker, rng),
                "moments": compare_moments(harness, rng),
                "moment_run": compare_moment_run(harness),
                "settings": {"seed": args.seed, "lambda": LAMBDA, "period_s": T},
                "machine": machine(),
            }
    finally:
        if worker is not None:
            worker.close()
    print(json.dumps({k: v for k, v in report.items() if k != "machine"}, indent=1, default=float))
    write_json(args.json, report, lambda r: {"visp": r["visp"], "mvtb": r["mvtb"]})
    return report


if __name__ == "__main__":
    main(sys.argv[1:])
