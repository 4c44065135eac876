"""Performance metrics of a simulated run: pure functions on arrays or a SimulationResult.

Definitions (per coordinate, signal ``y`` sampled at times ``t``, step from ``y_initial``
to ``y_final``, step size ``s = y_final - y_initial``):

* **Settling time** (2 % band by default): the time, measured from ``t[0]``, after which
  ``|y - y_final| <= band * |s|`` holds until the end of the record. ``y_final`` is the
  *target* (e.g. the target image features), not the last measured value, so a signal
  that settles on the wrong value (the feedback-only local minimum of Section 7) never
  settles: ``inf``. The entry time is linearly interpolated between the last sample
  outside the band and the next one. With a zero step the band is ``atol``.
* **Overshoot** [%]: ``100 * max(0, max_k (y_k - y_final) sign(s)) / |s|``, the largest
  excursion past the target in the direction of the step; NaN for a zero step.
* **Final error**: ``y_final - y[-1]`` (target minus measured, like ``feature_error``).
* **Pose error** between two poses ``T_O_A``, ``T_O_B`` (:func:`pose_error_mm_deg`,
  vectorized in :func:`pose_error_series_mm_deg`; both defined in :mod:`ibvs_youla._geometry`
  and re-exported here): ``|p_A - p_B|`` in mm and the angle of ``R_err = R_A^T R_B`` in
  degrees (``atan2(|vee(R_err - R_err^T)| / 2, (tr R_err - 1) / 2)``, accurate near 0
  and pi).
* **Peaks**: ``max_k |x_k|`` per joint and its ratio to the joint's limit (ERRATA 11, 16).
* **Visibility fraction**: share of samples in which each marker is physically visible.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .._geometry import pose_error_mm_deg, pose_error_series_mm_deg
from .._validation import as_array, non_negative, positive
from ..exceptions import InvalidArrayError

if TYPE_CHECKING:  # pragma: no cover
    from ..simulation.results import SimulationResult

__all__ = [
    "final_error",
    "overshoot",
    "peak_with_ratio",
    "pose_error_mm_deg",
    "pose_error_series_mm_deg",
    "settling_time",
    "summary",
    "visibility_fraction",
]


def _signals(t: Any, y: Any) -> tuple[np.ndarray, np.ndarray, bool]:
    t = as_array(t, "t", (None,))
    y = as_array(y, "y", finite=False)
    scalar = y.ndim == 1
    y2 = y[:, None] if scalar else y
    if y2.ndim != 2 or y2.shape[0] != t.shape[0] or t.shape[0] == 0:
        raise InvalidArrayError(
            "y", f"an array of shape {y.shape}", f"shape ({t.shape[0]},) or ({t.shape[0]}, k)"
        )
    return t, y2, scalar


def _endpoints(y2: np.ndarray, y_final: Any, y_initial: Any) -> tuple[np.ndarray, np.ndarray]:
    k = y2.shape[1]
    final = y2[-1] if y_final is None else np.broadcast_to(as_array(y_final, "y_final"), (k,))
    initial = y2[0] if y_initial is None else np.broadcast_to(as_array(y_initial, "y_initial"), (k,))
    return np.asarray(final, dtype=float), np.asarray(initial, dtype=float)


def settling_time(
    t: Any,
    y: Any,
    *,
    y_final: Any = None,
    y_initial: Any = None,
    band: float = 0.02,
    atol: float = 0.0,
) -> np.ndarray | float:
    """Settling time per coordinate (see the module docstring for the definition).

    Args:
        t: Sample times (N,) [s], increasing.
        y: Signal (N,) or (N, k).
        y_final: Target value(s) (k,) or scalar; default: the last sample ``y[-1]``.
        y_initial: Initial value(s); default: the first sample ``y[0]``.
        band: Relative half-width of the band, 0.02 for the 2 % criterion.
        atol: Absolute floor of the band half-width (same unit as ``y``).

    Returns:
        Settling time(s) from ``t[0]`` [s]: a float for 1-D ``y``, else (k,). ``inf`` when
        the last sample is outside the band (or non-finite).
    """
    t, y2, scalar = _signals(t, y)
    band = positive(band, "band")
    atol = non_negative(atol, "atol")
    final, initial = _endpoints(y2, y_final, y_initial)
    half_width = np.maximum(band * np.abs(final - initial), atol)
    excess = np.abs(y2 - final) - half_width  # <= 0 inside the band
    excess = np.where(np.isfinite(excess), excess, np.inf)
    out = np.empty(y2.shape[1])
    for j in range(y2.shape[1]):
        outside = np.flatnonzero(excess[:, j] > 0.0)
        if outside.size == 0:
            out[j] = 0.0
        elif outside[-1] == len(t) - 1:
            out[j] = np.inf
        else:
            i = outside[-1]
            e0, e1 = excess[i, j], excess[i + 1, j]
            frac = 1.0 if not np.isfinite(e0) else e0 / (e0 - e1)
            out[j] = t[i] + frac * (t[i + 1] - t[i]) - t[0]
    return float(out[0]) if scalar else out


def overshoot(y: Any, *, y_final: Any = None, y_initial: Any = None) -> np.ndarray | float:
    """Overshoot past the target in the direction of the step [%] per coordinate.

    Args:
        y: Signal (N,) or (N, k).
        y_final: Target value(s); default ``y[-1]``.
        y_initial: Initial value(s); default ``y[0]``.

    Returns:
        ``100 * max(0, max (y - y_final) sign(s)) / |s|``; NaN where the step ``s`` is zero.
    """
    y = as_array(y, "y", finite=False)
    scalar = y.ndim == 1
    y2 = y[:, None] if scalar else y
    if y2.ndim != 2 or y2.shape[0] == 0:
        raise InvalidArrayError("y", f"an array of shape {y.shape}", "shape (N,) or (N, k) with N >= 1")
    final, initial = _endpoints(y2, y_final, y_initial)
    step = final - initial
    past = np.nanmax((y2 - final) * np.sign(step), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(step != 0.0, 100.0 * np.maximum(past, 0.0) / np.abs(step), np.nan)
    return float(out[0]) if scalar else out


def final_error(y: Any, y_final: Any) -> np.ndarray:
    """Target minus the last sample, ``y_final - y[-1]``, per coordinate."""
    y = as_array(y, "y", finite=False)
    if y.ndim == 0 or y.shape[0] == 0:
        raise InvalidArrayError("y", f"an array of shape {y.shape}", "at least one sample")
    target = as_array(y_final, "y_final", finite=False)
    if target.shape not in ((), y[-1].shape):
        raise InvalidArrayError(
            "y_final", f"an array of shape {target.shape}", f"a scalar or shape {y[-1].shape}"
        )
    return target - y[-1]


def peak_with_ratio(x: Any, limit: Any = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Peak absolute value per column and its ratio to a limit.

    Args:
        x: Samples (N, n), e.g. joint speeds [rad/s] or torques [N m].
        limit: Positive limits (n,) in the same unit, e.g. ``arm.dq_max``; None skips the ratio.

    Returns:
        ``(peak (n,), peak / limit (n,) or None)``; NaN samples are ignored.
    """
    x = as_array(x, "x", (None, None), finite=False)
    if x.shape[0] == 0:
        raise InvalidArrayError("x", "no samples", "at least one sample")
    peak = np.nanmax(np.abs(x), axis=0)
    if limit is None:
        return peak, None
    limit = as_array(limit, "limit", (x.shape[1],))
    if np.any(limit <= 0.0):
        raise InvalidArrayError("limit", f"values {limit.tolist()}", "positive limits")
    return peak, peak / limit


def visibility_fraction(visible: Any) -> np.ndarray:
    """Share of samples (0-1) in which each marker is visible, from ``visible`` (N, k) bool."""
    visible = np.asarray(visible)
    if visible.ndim != 2 or visible.shape[0] == 0:
        raise InvalidArrayError("visible", f"an array of shape {visible.shape}", "shape (N, k) with N >= 1")
    return visible.astype(bool).mean(axis=0)


def summary(
    result: SimulationResult,
    *,
    dq_max: Any = None,
    tau_max: Any = None,
    band: float = 0.02,
) -> dict[str, Any]:
    """All metrics of one run as a JSON-friendly dict (lists of floats).

    Image metrics use the step from the first measured features to ``feature_target``.
    Joint speed and torque entries are None when the plant has no such signal (the
    free-flying camera has no joints; the kinematic arm no torque).

    Args:
        result: The run.
        dq_max: Joint speed limits (n,) [rad/s] for the speed ratio, e.g. ``arm.dq_max``.
        tau_max: Torque limits (n,) [N m] for the torque ratio, e.g. ``arm.tau_max``.
        band: Relative settling band.
    """
    target = result.feature_target
    position_mm, rotation_deg = result.final_pose_error()
    speed = speed_ratio = torque = torque_ratio = None
    if "dq" in result.signals:
        speed, speed_ratio = peak_with_ratio(result.dq, dq_max)
    if "tau" in result.signals:
        torque, torque_ratio = peak_with_ratio(result.tau, tau_max)

    def _list(a: np.ndarray | None) -> list[float] | None:
        return None if a is None else [float(v) for v in np.atleast_1d(a)]

    return {
        "settling_time_s": _list(settling_time(result.t, result.features, y_final=target, band=band)),
        "overshoot_percent": _list(overshoot(result.features, y_final=target)),
        "final_feature_error_m": _list(result.final_feature_error),
        "final_position_error_mm": position_mm,
        "final_rotation_error_deg": rotation_deg,
        "peak_joint_speed_rad_s": _list(speed),
        "peak_joint_speed_ratio": _list(speed_ratio),
        "peak_torque_nm": _list(torque),
        "peak_torque_ratio": _list(torque_ratio),
        "visibility_fraction": _list(visibility_fraction(result.visible)),
    }
