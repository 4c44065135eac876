"""Figures in the manner of the paper's Figures 13-16.

Each figure compares two runs of one scenario side by side: feedback only on the
left, feedforward + feedback on the right, as the paper lays them out. Joint
angles (Figures 13, 15) get one row per joint; image coordinates (Figures 14, 16)
one row per coordinate ``u_l, u_r, v`` of each of the three markers. Targets are
dashed.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..simulation.results import SimulationResult

__all__ = ["FEATURE_LABELS", "plot_image_comparison", "plot_joint_comparison"]

FEATURE_LABELS = tuple(f"{c}{i}" for i in (1, 2, 3) for c in ("ul", "ur", "v"))
_SENSOR_MM = 1e3  # sensor metres -> millimetres


def _new_figure(n_rows: int, title: str) -> tuple[Figure, np.ndarray]:
    # No pyplot (as in .plots): the figure needs no display and never touches the
    # caller's backend; a notebook shows it by displaying the returned Figure.
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10.0, 1.35 * n_rows + 1.5))
    axes = fig.subplots(n_rows, 2, sharex=True, squeeze=False)
    fig.suptitle(title)
    return fig, axes


TRANSIENT_S = 0.05  # [s] the paper's feedforward acts within a few milliseconds


def _zoom_past_transient(ax: Axes, t: np.ndarray, y: np.ndarray, y_goal: float) -> None:
    """Scale the axis to the signal after the first 50 ms when an early spike dwarfs it.

    The paper's 1 ms feedforward (ERRATA 11) throws the features far across the (virtual)
    sensor in the first milliseconds; plotted to scale, that spike hides the convergence.
    The spike is not hidden: the panel says how far it went.
    """
    late = y[t >= t[0] + TRANSIENT_S]
    if late.size < 2 or not np.all(np.isfinite(y)):
        return
    lo, hi = min(late.min(), y_goal), max(late.max(), y_goal)
    span = max(hi - lo, 1e-12)
    if (y.max() - y.min()) <= 3.0 * span:
        return
    ax.set_ylim(lo - 0.15 * span, hi + 0.15 * span)
    # above the panel, where neither the signal nor the dashed target can cross it
    ax.set_title(
        f"off scale in the first {1000 * TRANSIENT_S:.0f} ms; full range {y.min():.3g} to {y.max():.3g}",
        loc="right",
        fontsize=7,
        color="0.3",
        pad=2.0,
    )


def _comparison(
    feedback_only: SimulationResult,
    feedforward_feedback: SimulationResult,
    title: str,
    rows: list[
        tuple[str, Callable[[SimulationResult], np.ndarray], Callable[[SimulationResult], float], str]
    ],
    target_label: str,
    run_label: str,
) -> Figure:
    """Two columns (fb | ff+fb), one row per (label, signal, target, colour); targets dashed.

    The figure's legend (``fig.legends[0]``, below the panels) names the run and ``target_label``
    (the dashed line); each column's name sits above its first panel, higher than a panel's note.
    """
    from matplotlib.lines import Line2D

    fig, axes = _new_figure(len(rows), title)
    runs = ((feedback_only, "feedback only"), (feedforward_feedback, "feedforward + feedback"))
    for col, (res, name) in enumerate(runs):
        for row, (label, signal, target, colour) in enumerate(rows):
            ax = axes[row, col]
            y, y_goal = signal(res), target(res)
            ax.plot(res.t, y, lw=1.4, color=colour)
            ax.axhline(y_goal, ls="--", lw=1.0, color="k")
            _zoom_past_transient(ax, res.t, y, y_goal)
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
        axes[0, col].annotate(
            name,
            (0.5, 1.0),
            xycoords="axes fraction",
            xytext=(0.0, 13.0),  # [pt] above a note in the panel's title line
            textcoords="offset points",
            ha="center",
            va="bottom",
            fontsize="large",
        )
        axes[-1, col].set_xlabel("t [s]")
    fig.tight_layout(rect=(0.0, 0.025, 1.0, 1.0))
    handles = [Line2D([], [], lw=1.4, color="0.35"), Line2D([], [], ls="--", lw=1.0, color="k")]
    fig.legend(handles, [run_label, target_label], loc="lower center", ncols=2, frameon=False)
    return fig


def plot_joint_comparison(
    feedback_only: SimulationResult,
    feedforward_feedback: SimulationResult,
    title: str,
) -> Figure:
    """Six joint angles against time, feedback only (left) vs feedforward + feedback (right).

    The dashed line is the encoder value at which the camera reaches its target pose,
    ``q_target - d`` (ERRATA 14; ``d = 0`` without disturbance).
    """
    rows = [
        (
            f"q{j + 1} [deg]",
            lambda r, j=j: np.degrees(r.q[:, j]),
            lambda r, j=j: float(np.degrees(r.metadata["q_encoder_goal"][j])),
            "C0",
        )
        for j in range(6)
    ]
    return _comparison(
        feedback_only, feedforward_feedback, title, rows, "target: q_target - d (ERRATA 14)", "run"
    )


def plot_image_comparison(
    feedback_only: SimulationResult,
    feedforward_feedback: SimulationResult,
    title: str,
) -> Figure:
    """Nine image coordinates against time, feedback only (left) vs feedforward + feedback (right).

    Coordinates are in millimetres on the sensor (the paper's unit is metres; Eq. (9)-(11)).
    """
    rows = [
        (
            f"{FEATURE_LABELS[k]} [mm]",
            lambda r, k=k: _SENSOR_MM * r.features[:, k],
            lambda r, k=k: float(_SENSOR_MM * r.feature_target[k]),
            f"C{k // 3}",
        )
        for k in range(9)
    ]
    return _comparison(
        feedback_only, feedforward_feedback, title, rows, "target features", "run (colour: the marker)"
    )
