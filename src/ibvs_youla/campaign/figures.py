"""The figures of a campaign report: success against difficulty, time to reach, basins of attraction.

Matplotlib ``Figure`` objects (no pyplot state), drawn from a campaign's rows (one family):
:func:`plot_success_vs_difficulty` (reached rate against the rotation between the start and
target cameras, binned, with 95 % Wilson error bars), :func:`plot_time_to_reach` (its
distribution per method) and, for the free-camera families, :func:`plot_basins`: every start
pose as a point over two of :data:`AXES`, coloured by its outcome, one panel per method.
"""

from __future__ import annotations

import json
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ..exceptions import InvalidParameterError
from .intervals import wilson_interval
from .metrics import OUTCOMES
from .spec import sort_methods

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    from matplotlib.figure import Figure

__all__ = [
    "AXES",
    "DEFAULT_AXES",
    "FIGURES",
    "check_axes",
    "family_names",
    "plot_basins",
    "plot_success_vs_difficulty",
    "plot_time_to_reach",
    "start_pose_axes",
]

FIGURES = ("success_vs_difficulty", "time_to_reach", "basins")
DEFAULT_AXES = ("twist", "tilt")
# name -> label: coordinates of the start camera in the TARGET camera's frame, T_C*_C0 = T_O_C*^-1 T_O_C0
AXES = {
    "twist": "rotation about the optical axis [deg]",  # swing-twist: R = R_swing R_z(twist)
    "tilt": "tilt of the optical axis [deg]",  # angle between the two optical axes
    "rotation": "rotation angle [deg]",
    "translation": "distance [m]",
    "tx": "x [m]",
    "ty": "y [m]",
    "tz": "z (along the optical axis) [m]",
    "rx": "theta u, x [deg]",
    "ry": "theta u, y [deg]",
    "rz": "theta u, z [deg]",
}
_COLOURS = {
    "reached": "tab:green",
    "local_minimum": "tab:red",
    "singularity": "tab:cyan",
    "not_converged": "tab:orange",
    "diverged": "black",
    "features_lost": "tab:purple",
    "estimate_failed": "tab:brown",
    "joint_limit": "tab:pink",
    "qp_infeasible": "tab:olive",
    "error": "tab:gray",
    "timeout": "lightgray",
}


def family_names(rows: pd.DataFrame) -> str:
    """The families of ``rows``, comma-separated (figure titles, table captions)."""
    return ", ".join(sorted(set(rows["family"])))


# ----------------------------------------------------------------------------- start poses
def _axis_value(T_rel: np.ndarray, axis: str) -> float:
    from scipy.spatial.transform import Rotation

    R, t = T_rel[:3, :3], T_rel[:3, 3]
    if axis in ("tx", "ty", "tz"):
        return float(t["xyz".index(axis[1])])
    if axis == "translation":
        return float(np.linalg.norm(t))
    if axis == "tilt":
        return math.degrees(math.acos(max(-1.0, min(1.0, float(R[2, 2])))))
    rotation = Rotation.from_matrix(R)
    if axis == "twist":
        z, w = rotation.as_quat()[2:]
        return math.degrees(2.0 * math.atan2(z, w) if w >= 0.0 else 2.0 * math.atan2(-z, -w))
    rotvec = np.degrees(rotation.as_rotvec())
    return float(np.linalg.norm(rotvec)) if axis == "rotation" else float(rotvec["xyz".index(axis[1])])


def check_axes(axes: Any) -> tuple[str, str]:
    """Two different names of :data:`AXES`.

    Raises:
        InvalidParameterError: anything else.
    """
    axes = tuple(axes)
    if len(axes) != 2 or axes[0] == axes[1] or not set(axes) <= set(AXES):
        raise InvalidParameterError("axes", axes, f"two different names from {', '.join(AXES)}")
    return axes  # type: ignore[return-value]


def start_pose_axes(rows: pd.DataFrame, axes: Any = DEFAULT_AXES) -> np.ndarray:
    """(n, 2): each row's start camera in the target camera's frame, projected on ``axes``.

    The poses come from the ``spec`` JSON (``scenario.T_O_C_start`` and ``T_O_C_target``);
    rows without them (arm families) give NaN.
    """
    axes = check_axes(axes)
    out = np.full((len(rows), 2), math.nan)
    for i, text in enumerate(rows["spec"]):
        scenario = json.loads(text)["scenario"]
        if scenario.get("T_O_C_start") is None or scenario.get("T_O_C_target") is None:
            continue
        T_start, T_target = np.asarray(scenario["T_O_C_start"]), np.asarray(scenario["T_O_C_target"])
        T_rel = np.linalg.solve(T_target, T_start)  # T_C*_C0
        out[i] = [_axis_value(T_rel, a) for a in axes]
    return out


# ----------------------------------------------------------------------------- figures
def _figure(size: tuple[float, float], title: str) -> Figure:
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, layout="constrained")
    fig.suptitle(title)
    return fig


def plot_success_vs_difficulty(rows: pd.DataFrame, bins: int = 6) -> Figure:
    """Reached rate against the start-to-target rotation, per method, with 95 % Wilson bars.

    At most ``bins`` equal bins from 0 deg, their width a multiple of 10 deg, the last holding
    the largest ``difficulty_rotation_deg``;
    each method's point is its rate in a bin at the bin's centre (methods shifted a little
    apart), drawn only for bins holding runs; ``ax.lines`` has one line per method.
    """
    fig = _figure((7.0, 4.2), f"{family_names(rows)}: success against difficulty")
    ax = fig.subplots()
    angle = rows["difficulty_rotation_deg"].to_numpy(dtype=float)
    largest = max(1e-9, float(np.nanmax(angle))) if np.isfinite(angle).any() else 1.0
    width = 10.0 * math.ceil(largest / (10.0 * bins))  # [deg], a multiple of 10
    bins = math.ceil(largest / width)
    edges = width * np.arange(bins + 1)
    methods = sort_methods(rows)
    width = edges[1] - edges[0]
    for m, method in enumerate(methods):
        runs = rows[rows["controller"] == method]
        which = np.clip(np.digitize(runs["difficulty_rotation_deg"], edges) - 1, 0, bins - 1)
        reached = (runs["outcome"] == "reached").to_numpy()
        x, rate, err = [], [], [[], []]
        for b in range(bins):
            n, k = int((which == b).sum()), int(reached[which == b].sum())
            if n:
                low, high = wilson_interval(k, n)
                x.append(edges[b] + width * (0.5 + 0.4 * (m - (len(methods) - 1) / 2) / max(1, len(methods))))
                rate.append(k / n)
                err[0].append(k / n - low)
                err[1].append(high - k / n)
        ax.errorbar(x, rate, yerr=err, marker="o", capsize=3, color=f"C{m}", label=method)
    ax.set_xticks(edges)
    ax.set(xlabel="rotation between start and target [deg]", ylabel="reached rate", ylim=(-0.05, 1.05))
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    return fig


def plot_time_to_reach(rows: pd.DataFrame) -> Figure:
    """The time to reach per method: its distribution over reached runs, and over every run.

    Left: a box per method over its reached runs (box: quartiles; whiskers: 10th and 90th
    percentiles). Right: the fraction of all the method's runs reached by time t (an
    empirical distribution function that ends at the method's reached rate).
    """
    fig = _figure((11.0, 4.2), f"{family_names(rows)}: time to reach")
    left, right = fig.subplots(1, 2)
    methods = sort_methods(rows)
    times = []
    for m, method in enumerate(methods):
        runs = rows[rows["controller"] == method]
        t = np.sort(runs.loc[runs["outcome"] == "reached", "time_to_reach_s"].to_numpy(dtype=float))
        times.append(t)
        end = float(runs["duration"].max())
        steps = np.concatenate(([0.0], t, [end]))
        fraction = np.concatenate(([0.0], np.arange(1, t.size + 1), [t.size])) / max(1, len(runs))
        right.step(steps, fraction, where="post", color=f"C{m}", label=method)
    left.boxplot(times, whis=(10, 90))
    left.set_xticks(range(1, len(methods) + 1), methods)
    left.set(ylabel="time to reach [s] (reached runs)")
    left.tick_params(axis="x", labelrotation=30)
    right.set(xlabel="t [s]", ylabel="fraction of runs reached by t", ylim=(-0.02, 1.02))
    for ax in (left, right):
        ax.grid(alpha=0.3)
    right.legend(fontsize="small")
    return fig


def plot_basins(rows: pd.DataFrame, axes: Any = DEFAULT_AXES, max_columns: int = 4) -> Figure | None:
    """Which start poses each method brings to the target: one panel per method, None for arm rows.

    Every run is a point at its start pose projected on ``axes`` (:func:`start_pose_axes`),
    coloured by its outcome (``reached`` a green circle, every other outcome a cross of its
    colour); panels run row-major, at most ``max_columns`` per row.
    """
    axes = check_axes(axes)
    xy = start_pose_axes(rows, axes)
    keep = np.isfinite(xy).all(axis=1)
    if not keep.any():
        return None
    rows, xy = rows[keep], xy[keep]
    methods = sort_methods(rows)
    cols = min(max_columns, len(methods))
    n_rows = -(-len(methods) // cols)
    fig = _figure((3.4 * cols + 0.6, 3.2 * n_rows + 0.8), f"{family_names(rows)}: outcome by start pose")
    panels = fig.subplots(n_rows, cols, squeeze=False, sharex=True, sharey=True)
    for ax, method in zip(panels.flat, methods, strict=False):
        mine = (rows["controller"] == method).to_numpy()
        for outcome in OUTCOMES:
            pick = mine & (rows["outcome"] == outcome).to_numpy()
            if pick.any():
                style = {"marker": "o", "s": 14} if outcome == "reached" else {"marker": "x", "s": 22}
                ax.scatter(*xy[pick].T, color=_COLOURS[outcome], label=outcome.replace("_", " "), **style)
        ax.set_title(method)
        ax.grid(alpha=0.3)
        ax.legend(fontsize="x-small")
    for ax in panels.flat[len(methods) :]:
        ax.set_visible(False)
    for ax in panels.flat[max(0, len(methods) - cols) : len(methods)]:  # the lowest panel of each column
        ax.set_xlabel(AXES[axes[0]])
        ax.xaxis.set_tick_params(labelbottom=True)
    for ax in panels[:, 0]:
        ax.set_ylabel(AXES[axes[1]])
    return fig
