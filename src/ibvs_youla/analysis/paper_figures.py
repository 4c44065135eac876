"""Figures in the manner of the paper's Figures 13-16.

Each figure compares two runs of one scenario side by side: feedback only on the
left, feedforward + feedback on the right, as the paper lays them out. Joint
angles (Figures 13, 15) get one row per joint; image coordinates (Figures 14, 16)
one row per coordinate ``u_l, u_r, v`` of each of the three markers. Targets are
dashed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from ..simulation.results import SimulationResult

__all__ = ["FEATURE_LABELS", "plot_image_comparison", "plot_joint_comparison"]

FEATURE_LABELS = tuple(f"{c}{i}" for i in (1, 2, 3) for c in ("ul", "ur", "v"))
_SENSOR_MM = 1e3  # sensor metres -> millimetres


def _new_figure(n_rows: int, title: str) -> tuple[Figure, np.ndarray]:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(n_rows, 2, sharex=True, figsize=(10.0, 1.35 * n_rows + 1.2), squeeze=False)
    fig.suptitle(title)
    return fig, axes


def plot_joint_comparison(
    feedback_only: SimulationResult,
    feedforward_feedback: SimulationResult,
    title: str,
) -> Figure:
    """Six joint angles against time, feedback only (left) vs feedforward + feedback (right).

    The dashed line is the encoder value at which the camera reaches its target pose,
    ``q_target - d`` (ERRATA 14; ``d = 0`` without disturbance).
    """
    fig, axes = _new_figure(6, title)
    for col, (res, name) in enumerate(
        ((feedback_only, "feedback only"), (feedforward_feedback, "feedforward + feedback"))
    ):
        q_goal = np.asarray(res.metadata["q_encoder_goal"])
        for j in range(6):
            ax = axes[j, col]
            ax.plot(res.t, np.degrees(res.q[:, j]), lw=1.4, color="C0")
            ax.axhline(np.degrees(q_goal[j]), ls="--", lw=1.0, color="k")
            ax.set_ylabel(f"q{j + 1} [deg]")
            ax.grid(alpha=0.3)
        axes[0, col].set_title(name)
        axes[-1, col].set_xlabel("t [s]")
    fig.tight_layout()
    return fig


def plot_image_comparison(
    feedback_only: SimulationResult,
    feedforward_feedback: SimulationResult,
    title: str,
) -> Figure:
    """Nine image coordinates against time, feedback only (left) vs feedforward + feedback (right).

    Coordinates are in millimetres on the sensor (the paper's unit is metres; Eq. (9)-(11)).
    """
    fig, axes = _new_figure(9, title)
    for col, (res, name) in enumerate(
        ((feedback_only, "feedback only"), (feedforward_feedback, "feedforward + feedback"))
    ):
        for k in range(9):
            ax = axes[k, col]
            ax.plot(res.t, _SENSOR_MM * res.features[:, k], lw=1.4, color=f"C{k // 3}")
            ax.axhline(_SENSOR_MM * res.feature_target[k], ls="--", lw=1.0, color="k")
            ax.set_ylabel(f"{FEATURE_LABELS[k]} [mm]")
            ax.grid(alpha=0.3)
        axes[0, col].set_title(name)
        axes[-1, col].set_xlabel("t [s]")
    fig.tight_layout()
    return fig
