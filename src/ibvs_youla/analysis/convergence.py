"""Did a run reach its target, stall in a local minimum, or is it still converging?

The paper asserts that feedback-only stereo IBVS "falls into local minima" while
feedforward + feedback reaches the target (Section 7). This module turns that into
a measurement on a :class:`~ibvs_youla.simulation.results.SimulationResult`:

* **reached**: the final image error and camera pose error are within tolerance;
* **stalled**: not reached, and the image-error norm changed by less than
  ``stall_rtol`` (relative) over the last ``window`` fraction of the run, i.e. the
  closed loop sits at an equilibrium that is not the target: a local minimum of the
  controller (for the outer loop q_fb = K(z)[J^+ e] every equilibrium has J^+ e = 0,
  so the residual e lies in the left null space of the Jacobian the controller uses);
* **converging**: not reached and still moving;
* **markers_lost** / **estimate_failed** / **diverged**: the run stopped early
  (``metadata["status"]``, see :func:`ibvs_youla.simulate`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._geometry import pose_error_series_mm_deg
from .._validation import instance, positive, real

if TYPE_CHECKING:  # pragma: no cover
    from ..simulation.results import SimulationResult

__all__ = ["Outcome", "Tolerances", "classify"]


@dataclass(frozen=True)
class Tolerances:
    """What "reached the target" means (defaults: ~0.04 px of image error, 0.1 mm and 0.01 deg of pose).

    Attributes:
        image_m: Largest final image error per coordinate [m on the sensor] (1e-7 m is
            about 0.04 px of the paper's ZED 2 at HD720).
        position_mm: Final camera position error [mm].
        rotation_deg: Final camera rotation error [deg].
        window: Trailing fraction of the run used to judge whether the error still moves.
        stall_rtol: Relative change of the error norm over the window below which the
            run counts as stalled.
    """

    image_m: float = 1e-7
    position_mm: float = 0.1
    rotation_deg: float = 0.01
    window: float = 0.2
    stall_rtol: float = 1e-3

    def __post_init__(self) -> None:
        for name in ("image_m", "position_mm", "rotation_deg", "stall_rtol"):
            object.__setattr__(self, name, positive(getattr(self, name), name))
        window = real(self.window, "window", low=0.0, high=1.0, low_open=True, high_open=True)
        object.__setattr__(self, "window", window)


@dataclass(frozen=True)
class Outcome:
    """Verdict on one run, with the numbers behind it.

    Attributes:
        kind: ``"reached"``, ``"stalled"``, ``"converging"``, or the status of a run that
            stopped early: ``"markers_lost"``, ``"estimate_failed"``, ``"diverged"``.
        final_image_error_m: Largest final |e| over the image coordinates [m].
        point_errors_m: Largest final |e| per marker (n,) [m]: which points are unmatched.
        position_error_mm: Final camera position error [mm].
        rotation_error_deg: Final camera rotation error [deg].
        error_change: Relative change of ||e|| over the trailing window,
            ``(||e||(end) - ||e||(start of window)) / ||e||(start of window)``.
        duration: Simulated time covered [s].
        reached_at_s: Time from which image and pose errors stay within tolerance until
            the end [s]; ``inf`` if the run ends outside it.
        window: The trailing fraction of the run over which ``error_change`` was measured
            (the ``Tolerances.window`` the verdict used).
    """

    kind: str
    final_image_error_m: float
    point_errors_m: tuple[float, ...]
    position_error_mm: float
    rotation_error_deg: float
    error_change: float
    duration: float
    reached_at_s: float = float("inf")
    window: float = Tolerances.window

    def describe(self) -> str:
        """One line for tables and notes."""
        pts = ", ".join(f"{e:.1e}" for e in self.point_errors_m)
        return (
            f"{self.kind} after {self.duration:g} s: max|e| = {self.final_image_error_m:.2e} m "
            f"(per point {pts}), pose error {self.position_error_mm:.3g} mm / "
            f"{self.rotation_error_deg:.3g} deg, ||e|| change over the last "
            f"{100 * self.window:.0f} %: {100 * self.error_change:+.2g} %"
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        d = asdict(self)
        d["point_errors_m"] = list(self.point_errors_m)
        return d


def classify(result: SimulationResult, tolerances: Tolerances | None = None) -> Outcome:
    """Classify a run as reached / stalled / converging (see the module docstring).

    Samples with a missing feature (NaN: a marker dropped from the frame) are left out.
    """
    from ..simulation.results import SimulationResult

    instance(result, "result", SimulationResult, "a SimulationResult")
    tol = Tolerances() if tolerances is None else instance(tolerances, "tolerances", Tolerances, "Tolerances")
    e = result.feature_error
    n_points = result.n_points
    status = result.metadata.get("status", "complete")
    complete = np.isfinite(e).all(axis=1)  # samples whose every feature was measured (dropouts: NaN)
    if not complete.any():  # stopped before the first sample (e.g. markers lost at t = 0)
        nan = float("nan")
        return Outcome(status, nan, (nan,) * n_points, nan, nan, nan, 0.0, float("inf"), tol.window)
    position_mm, rotation_deg = result.final_pose_error()
    t = result.t
    pose_within = _pose_within(result, tol)
    if not complete.all():
        e, t, pose_within = e[complete], t[complete], pose_within[complete]
    final = np.abs(e[-1])
    norms = np.linalg.norm(e, axis=1)
    i0 = int(np.searchsorted(t, t[-1] - tol.window * (t[-1] - t[0])))
    i0 = min(i0, len(t) - 1)
    ref = norms[i0]
    change = float((norms[-1] - ref) / ref) if ref > 0 else 0.0
    if status != "complete":
        kind = status
    elif final.max() <= tol.image_m and position_mm <= tol.position_mm and rotation_deg <= tol.rotation_deg:
        kind = "reached"
    elif abs(change) < tol.stall_rtol:
        kind = "stalled"
    else:
        kind = "converging"
    inside = (np.abs(e).max(axis=1) <= tol.image_m) & pose_within
    outside = np.flatnonzero(~inside)
    if outside.size == 0:
        reached_at = float(t[0])
    elif outside[-1] == len(t) - 1:
        reached_at = float("inf")
    else:
        reached_at = float(t[outside[-1] + 1])
    return Outcome(
        reached_at_s=reached_at,
        kind=kind,
        final_image_error_m=float(final.max()),
        point_errors_m=tuple(float(v) for v in final.reshape(n_points, -1).max(axis=1)),
        position_error_mm=float(position_mm),
        rotation_error_deg=float(rotation_deg),
        error_change=change,
        duration=float(t[-1] - t[0]),
        window=tol.window,
    )


def _pose_within(result: SimulationResult, tol: Tolerances) -> np.ndarray:
    """Per sample: camera position and rotation errors within tolerance."""
    position_mm, rotation_deg = pose_error_series_mm_deg(result.camera_pose, result.camera_pose_target)
    return (position_mm <= tol.position_mm) & (rotation_deg <= tol.rotation_deg)
