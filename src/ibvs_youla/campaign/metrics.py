"""One campaign row from one run: outcome, errors, path, speeds, compute time, difficulty.

Outcome of a run (:data:`OUTCOMES`), the first that applies:

1. ``"error"`` — the run raised (the message is in ``error``; set by :func:`~.run.run_spec`);
   ``"timeout"`` — no worker returned the run within the campaign's run timeout, on two
   workers (set by :mod:`~.runner`);
2. the run stopped early: ``"diverged"``, ``"features_lost"`` (a marker left the true
   camera: status ``markers_lost``), ``"estimate_failed"``;
3. ``"joint_limit"`` — on an arm, a true joint angle left the arm's limits at some sample (a
   real arm would have stopped there; the simulated one has no hard stops);
4. ``"reached"`` — the final camera pose within :data:`REACHED_MM` = 1 mm and
   :data:`REACHED_DEG` = 0.1 deg of the target;
5. ``"qp_infeasible"`` — an MPC law met an infeasible QP on some frame (its signal
   ``qp_infeasible_frames``) and did not reach the target;
6. the image error norm changed by less than 0.1 % over the last 20 % of the run
   (``analysis.convergence.classify``'s "stalled") with the camera still away from the target:
   ``"singularity"`` on an arm whose final camera Jacobian has a smallest singular value below
   :data:`SINGULAR_SIGMA` (the arm cannot move the camera in some direction: a stall of the
   arm, not of the image law), else ``"local_minimum"``;
7. ``"not_converged"`` — still moving at the end of the run.

``final_jacobian_sigma`` is that smallest singular value of the 6x6 camera Jacobian (LOCAL
frame, m/rad and 1) at the last sample, for every arm run (NaN on the free camera; rows stored
before the column existed read it as NaN).

Time to reach: the first sample time from which the pose stays within 1 mm / 0.1 deg until
the end (``analysis.compare.time_to_converge``; ``inf`` when it never does).
"""

from __future__ import annotations

import hashlib
import math
from typing import Any

import numpy as np

from ..analysis.compare import path_length_m, time_to_converge
from ..analysis.convergence import classify
from .cases import MIN_JACOBIAN_SIGMA

__all__ = [
    "COLUMNS",
    "LATER_COLUMNS",
    "OUTCOMES",
    "REACHED_DEG",
    "REACHED_MM",
    "SINGULAR_SIGMA",
    "error_row",
    "row_from_result",
    "timeout_row",
    "unreadable_spec_row",
]

OUTCOMES = (
    "reached",
    "local_minimum",
    "singularity",
    "not_converged",
    "diverged",
    "features_lost",
    "estimate_failed",
    "joint_limit",
    "qp_infeasible",
    "error",
    "timeout",
)
REACHED_MM = 1.0  # [mm]
REACHED_DEG = 0.1  # [deg]
SINGULAR_SIGMA = MIN_JACOBIAN_SIGMA  # the case generator's margin: no start or target is closer
_STATUS_OUTCOME = {
    "diverged": "diverged",
    "markers_lost": "features_lost",
    "estimate_failed": "estimate_failed",
}

# column -> Python type of its values (the Parquet schema of a campaign's rows)
COLUMNS: dict[str, type] = {
    "key": str,
    "family": str,
    "case": int,
    "seed": int,
    "controller": str,
    "plant": str,
    "camera": str,
    "duration": float,
    "outcome": str,
    "status": str,
    "error": str,
    "time_to_reach_s": float,
    "final_position_mm": float,
    "final_rotation_deg": float,
    "final_feature_error": float,
    "path_length_m": float,
    "straight_line_m": float,
    "path_ratio": float,
    "peak_joint_speed_ratio": float,
    "peak_torque_ratio": float,
    "qp_infeasible_frames": int,
    "final_jacobian_sigma": float,
    "update_median_us": float,
    "update_p95_us": float,
    "difficulty_rotation_deg": float,
    "difficulty_translation_m": float,
    "wall_s": float,
    "spec": str,
}
# columns added after the first stored campaigns: a part written before reads them as missing (NaN)
LATER_COLUMNS = frozenset({"final_jacobian_sigma"})


def _base(spec: Any, wall_s: float) -> dict[str, Any]:
    return {
        "key": spec.key,
        "family": spec.family,
        "case": spec.case,
        "seed": spec.seed,
        "controller": spec.method,
        "plant": spec.plant,
        "camera": str(spec.camera.get("kind", "")),
        "duration": spec.duration,
        "difficulty_rotation_deg": float(spec.difficulty.get("rotation_deg", math.nan)),
        "difficulty_translation_m": float(spec.difficulty.get("translation_m", math.nan)),
        "wall_s": float(wall_s),
        "spec": spec.to_json(),
    }


def error_row(spec: Any, error: BaseException, wall_s: float = math.nan) -> dict[str, Any]:
    """The row of a run that raised: outcome ``"error"``, the message, NaN metrics."""
    row = {name: (math.nan if kind is float else 0 if kind is int else "") for name, kind in COLUMNS.items()}
    row.update(_base(spec, wall_s))
    row.update(outcome="error", status="error", error=f"{type(error).__name__}: {error}"[:2000])
    return row


def unreadable_spec_row(received: Any, error: BaseException, wall_s: float = math.nan) -> dict[str, Any]:
    """The row of what is not a spec (malformed JSON, or not the JSON of a spec): outcome ``"error"``.

    Nothing of the run is known: the ``key`` is the first 20 hex digits of the SHA-256 of what was
    received (as text), the ``spec`` column holds that text (cut to 2000 characters), the other
    columns are empty, zero or NaN.
    """
    text = received.decode("utf-8", "replace") if isinstance(received, bytes) else str(received)
    row = {name: (math.nan if kind is float else 0 if kind is int else "") for name, kind in COLUMNS.items()}
    row.update(
        key=hashlib.sha256(text.encode("utf-8", "replace")).hexdigest()[:20],
        wall_s=float(wall_s),
        spec=text[:2000],
        outcome="error",
        status="error",
        error=f"{type(error).__name__}: {error}"[:2000],
    )
    return row


def timeout_row(spec: Any, message: str, wall_s: float = math.nan) -> dict[str, Any]:
    """The row of a run no worker returned within the campaign's run timeout, twice: outcome ``"timeout"``."""
    row = {name: (math.nan if kind is float else 0 if kind is int else "") for name, kind in COLUMNS.items()}
    row.update(_base(spec, wall_s))
    row.update(outcome="timeout", status="timeout", error=message[:2000])
    return row


def row_from_result(spec: Any, result: Any, arm: Any = None, wall_s: float = math.nan) -> dict[str, Any]:
    """The row of a finished run (module docstring); ``arm`` gives the joint and speed limits."""
    row = _base(spec, wall_s)
    n = len(result)
    status = result.status
    complete = np.flatnonzero(np.isfinite(result.feature_error).all(axis=1)) if n else ()
    if n:
        mm, deg = result.final_pose_error()
        # the last sample with every feature measured (a dropped marker's features are NaN)
        final_feature = float(np.abs(result.feature_error[complete[-1]]).max()) if len(complete) else math.nan
    else:
        mm = deg = final_feature = math.nan
    straight = (
        float(np.linalg.norm(result.camera_pose_target[:3, 3] - result.camera_pose[0, :3, 3]))
        if n
        else math.nan
    )
    path = path_length_m(result.camera_pose) if n else math.nan
    speed_ratio = torque_ratio = math.nan
    joint_limit = False
    sigma = math.nan
    if arm is not None and "q_true" in result.signals and n:
        sigma = float(np.linalg.svd(arm.camera_jacobian(result.q_true[-1]), compute_uv=False)[-1])
    if arm is not None and "dq" in result.signals and n:
        speed_ratio = float((np.abs(result.dq) / np.asarray(arm.dq_max)).max())
        q = result.q_true
        joint_limit = bool(np.any(q < np.asarray(arm.q_min)) or np.any(q > np.asarray(arm.q_max)))
    if arm is not None and "tau" in result.signals and n:
        torque_ratio = float((np.abs(result.tau) / np.asarray(arm.tau_max)).max())
    infeasible = (
        int(result.qp_infeasible_frames[-1, 0]) if "qp_infeasible_frames" in result.signals and n else 0
    )
    reached = status == "complete" and mm < REACHED_MM and deg < REACHED_DEG
    if status in _STATUS_OUTCOME:
        outcome = _STATUS_OUTCOME[status]
    elif joint_limit:
        outcome = "joint_limit"
    elif reached:
        outcome = "reached"
    elif infeasible:
        outcome = "qp_infeasible"
    elif n and classify(result).kind == "stalled":
        outcome = "singularity" if sigma < SINGULAR_SIGMA else "local_minimum"
    else:
        outcome = "not_converged"
    update_us = np.asarray(result.update_time) * 1e6
    row.update(
        outcome=outcome,
        status=status,
        error=str(result.metadata.get("error", "")) if status != "complete" else "",
        time_to_reach_s=time_to_converge(result),
        final_position_mm=float(mm),
        final_rotation_deg=float(deg),
        final_feature_error=final_feature,
        path_length_m=path,
        straight_line_m=straight,
        path_ratio=path / straight if straight > 1e-6 else math.nan,
        peak_joint_speed_ratio=speed_ratio,
        peak_torque_ratio=torque_ratio,
        qp_infeasible_frames=infeasible,
        final_jacobian_sigma=sigma,
        update_median_us=float(np.median(update_us)) if update_us.size else math.nan,
        update_p95_us=float(np.percentile(update_us, 95)) if update_us.size else math.nan,
    )
    return row
