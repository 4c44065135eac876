"""Side-by-side figures and the files of a :class:`~.compare.Comparison`.

:func:`plot_comparison` draws the runs side by side (matplotlib ``Figure`` objects, no
pyplot): the image trajectories of each method, the camera paths in 3-D, the image and pose
errors over time on log scales and, on an arm, the joint speeds against their limits.
:func:`save_comparison` writes ``table.md``, ``table.json`` and ``figures/*.png``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..files import save_figure, write_json, write_text
from .compare import CONVERGED_DEG, CONVERGED_MM
from .metrics import pose_error_series_mm_deg
from .plots import draw_marker_trajectories

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from .compare import Comparison

__all__ = ["COMPARISON_FIGURES", "plot_comparison", "save_comparison"]

COMPARISON_FIGURES = ("image_plane", "camera_path", "error_norm", "joint_speeds")


# ----------------------------------------------------------------------------- figures
def _new_figure(size: tuple[float, float], title: str) -> Figure:
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, layout="constrained")
    fig.suptitle(title)
    return fig


def _line_style(k: int) -> dict[str, Any]:
    """Method k's colour and dash (a dash cycle shows methods whose curves coincide)."""
    return {"color": f"C{k}", "ls": ("-", "--", "-.", ":")[k % 4]}


def _title(comparison: Comparison, what: str) -> str:
    return f"{comparison.scenario.name or 'scenario'} on the {comparison.plant} plant: {what}"


def plot_image_trajectories(comparison: Comparison, max_columns: int = 4) -> Figure:
    """Each method's marker trajectories in the image, one panel per method and lens, on one scale.

    Panels run row-major, at most ``max_columns`` per row: one per method for a monocular
    camera, two (left ``(u_l, v)``, then right ``(u_r, v)``) for a stereo one; unused panels
    are hidden. In each panel ``ax.lines[i]`` (i < n markers) is marker i + 1's trajectory,
    then the starts (circles) and the targets (crosses); a bounded sensor is outlined.
    Coordinates are in mm on the sensor, or unitless for a normalized camera (focal length 1,
    unbounded view).

    Every panel has the same limits, so that the methods compare by eye: the square that holds
    every trajectory, but no larger than the starts, targets and sensor outline widened by
    their own extent on each side; a panel whose trajectory leaves it says how far it went
    (``ax.texts``).
    """
    from matplotlib.patches import Rectangle

    results = comparison.results
    camera = comparison.camera
    normalized = camera.unbounded_view and camera.focal_length == 1.0
    scale, unit = (1.0, "normalized") if normalized else (1e3, "mm")
    first = next(iter(results.values()), None)
    n = comparison.scenario.n_points
    per = 2 if first is None else first.features.shape[1] // n
    lenses = ("left", "right") if per == 3 else ("",)
    panels = [(name, result, k, lens) for name, result in results.items() for k, lens in enumerate(lenses)]
    cols = max(1, min(max_columns, len(panels)))
    rows = max(1, -(-len(panels) // cols))
    fig = _new_figure((3.6 * cols + 0.6, 3.3 * rows + 0.6), _title(comparison, "image trajectories"))
    axes = fig.subplots(rows, cols, squeeze=False)
    w, h = 1e3 * camera.sensor_width, 1e3 * camera.sensor_height
    (x_lim, y_lim), reach = _shared_limits(panels, scale, per, None if camera.unbounded_view else (w, h))
    for ax, (name, result, k, lens) in zip(axes.flat, panels, strict=False):
        p, target = scale * result.features, scale * result.feature_target
        draw_marker_trajectories(ax, p, target, per, k)
        if not camera.unbounded_view:
            ax.add_patch(Rectangle((-w / 2, -h / 2), w, h, fill=False, lw=1.0, color="0.3"))
        ax.set_xlim(*x_lim)
        ax.set_ylim(y_lim[1], y_lim[0])  # v down
        ax.set_aspect("equal", adjustable="box")
        far = reach[(name, k)]
        if far is not None:
            ax.text(
                0.02,
                0.02,
                f"leaves the panel: up to |{'x' if normalized else 'u'}|, "
                f"|{'y' if normalized else 'v'}| = {far:.3g}",
                transform=ax.transAxes,
                fontsize="x-small",
                color="0.2",
                bbox={"facecolor": "white", "edgecolor": "0.6", "alpha": 0.9},
            )
        ax.set_title(f"{name}{f' ({lens} lens)' if lens else ''}", fontsize="medium")
        ax.set_xlabel(f"{'x' if normalized else 'u'}{f'_{lens[0]}' if lens else ''} [{unit}]")
        ax.set_ylabel(f"{'y' if normalized else 'v'} [{unit}]")
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(panels) :]:
        ax.set_visible(False)
    if panels:
        axes[0, 0].legend(loc="best", fontsize="x-small")
    return fig


def _shared_limits(
    panels: list[tuple[str, Any, int, str]], scale: float, per: int, sensor: tuple[float, float] | None
) -> tuple[tuple[tuple[float, float], tuple[float, float]], dict[tuple[str, int], float | None]]:
    """One square view for every panel, and how far each panel's trajectory goes beyond it (None: not).

    The core is the starts, the targets and the sensor outline; the view holds every finite
    trajectory point, clipped to the core widened by the core's extent on each side.
    """
    core, paths = [], {}
    for name, result, k, _ in panels:
        f, target = scale * result.features, scale * result.feature_target
        n = f.shape[1] // per
        u, v = [per * i + k for i in range(n)], [per * i + per - 1 for i in range(n)]
        xy = np.stack([f[:, u].ravel(), f[:, v].ravel()], axis=1)
        paths[(name, k)] = xy[np.all(np.isfinite(xy), axis=1)]
        core += [np.stack([f[0, u], f[0, v]], axis=1), np.stack([target[u], target[v]], axis=1)]
    if sensor is not None:
        core.append(np.array([[-sensor[0] / 2, -sensor[1] / 2], [sensor[0] / 2, sensor[1] / 2]]))
    points = np.concatenate(core)
    points = points[np.all(np.isfinite(points), axis=1)]
    if points.size == 0:
        return ((-1.0, 1.0), (-1.0, 1.0)), dict.fromkeys(paths)
    lo, hi = points.min(axis=0), points.max(axis=0)
    grow = max(float(np.max(hi - lo)), 1e-9)
    bound_lo, bound_hi = lo - grow, hi + grow
    every = np.concatenate([points, *paths.values()])
    lo, hi = np.maximum(every.min(axis=0), bound_lo), np.minimum(every.max(axis=0), bound_hi)
    centre, half = 0.5 * (lo + hi), 0.55 * float(np.max(hi - lo))  # a square, 10 % margin
    view_lo, view_hi = centre - half, centre + half
    reach: dict[tuple[str, int], float | None] = {}
    for key, xy in paths.items():
        outside = xy.size and bool(np.any((xy < view_lo) | (xy > view_hi)))
        reach[key] = float(np.max(np.abs(xy))) if outside else None
    return ((view_lo[0], view_hi[0]), (view_lo[1], view_hi[1])), reach


def plot_camera_paths(comparison: Comparison) -> Figure:
    """The camera centre's path of each method in 3-D (base frame, m), markers and target.

    ``ax.lines[k]`` is method k's path; then its start (circle); the markers are scattered in
    black and the target camera position is a black cross.
    """
    fig = _new_figure((7.5, 6.5), _title(comparison, "camera paths"))
    ax = fig.add_subplot(projection="3d")
    items = list(comparison.results.items())
    for k, (name, result) in enumerate(items):
        p = result.camera_pose[:, :3, 3]
        ax.plot(p[:, 0], p[:, 1], p[:, 2], lw=1.4, **_line_style(k), label=name)
    for k, (_, result) in enumerate(items):
        p0 = result.camera_pose[0, :3, 3]
        ax.plot([p0[0]], [p0[1]], [p0[2]], "o", color=f"C{k}", mfc="none")
    markers = np.asarray(comparison.scenario.markers_O)
    ax.scatter(markers[:, 0], markers[:, 1], markers[:, 2], color="k", s=12, label="markers")
    if items:
        target = items[0][1].camera_pose_target[:3, 3]
        ax.scatter([target[0]], [target[1]], [target[2]], color="k", marker="x", s=60, label="target")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.legend(loc="upper left", fontsize="small")
    return fig


def plot_error_norms(comparison: Comparison) -> Figure:
    """Image error norm ``||e||`` (top) and camera position [mm] and rotation [deg] errors over time.

    All on log scales; ``axes[r].lines[k]`` is method k's curve in row r (0: ``||e||``, 1:
    position, 2: rotation); the tolerances of "converged" (1 mm, 0.1 deg) are dashed.
    """
    fig = _new_figure((8.5, 8.0), _title(comparison, "errors"))
    axes = fig.subplots(3, 1, sharex=True)
    tiny = 1e-300  # log scale: an exact zero drawn at the bottom
    for k, (name, result) in enumerate(comparison.results.items()):
        mm, deg = pose_error_series_mm_deg(result.camera_pose, result.camera_pose_target)
        e = np.linalg.norm(result.feature_error, axis=1)
        for ax, y in zip(axes, (e, mm, deg), strict=True):
            ax.plot(result.t, np.maximum(y, tiny), lw=1.3, **_line_style(k), label=name)
    axes[1].axhline(CONVERGED_MM, ls="--", lw=1.0, color="k")
    axes[2].axhline(CONVERGED_DEG, ls="--", lw=1.0, color="k")
    normalized = comparison.camera.unbounded_view and comparison.camera.focal_length == 1.0
    labels = (
        "||e|| [normalized]" if normalized else "||e|| [m on the sensor]",
        "position [mm]",
        "rotation [deg]",
    )
    for ax, label in zip(axes, labels, strict=True):
        ax.set_yscale("log")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3, which="both")
    axes[-1].set_xlabel("t [s]")
    if comparison.results:
        axes[0].legend(loc="best", fontsize="small")
    return fig


def plot_joint_speeds(comparison: Comparison) -> Figure | None:
    """``|dq_j| / dq_max,j`` over time, one panel per joint, every method; the limit 1 dashed.

    ``None`` when no run has joint speeds (the free camera). ``axes.flat[j].lines[k]`` is
    method k's joint j + 1 (methods without ``dq`` skipped), then the limit.
    """
    runs = [(k, name, r) for k, (name, r) in enumerate(comparison.results.items()) if "dq" in r.signals]
    if not runs or comparison.arm is None:
        return None
    limit = np.asarray(comparison.arm.dq_max, dtype=float)
    n = limit.shape[0]
    fig = _new_figure((10.0, 1.6 * ((n + 1) // 2) + 1.2), _title(comparison, "joint speeds / limits"))
    axes = fig.subplots((n + 1) // 2, 2, sharex=True, squeeze=False)
    for j, ax in enumerate(axes.flat[:n]):
        for k, name, result in runs:
            ax.plot(result.t, np.abs(result.dq[:, j]) / limit[j], lw=1.1, **_line_style(k), label=name)
        ax.axhline(1.0, ls="--", lw=1.0, color="C3")
        ax.set_yscale("log")
        ax.set_ylabel(f"|dq{j + 1}| / limit")
        ax.grid(alpha=0.3, which="both")
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")
    axes[0, 0].legend(loc="best", fontsize="x-small")
    return fig


def plot_comparison(comparison: Comparison) -> dict[str, Figure]:
    """Every comparison figure by name (:data:`COMPARISON_FIGURES`; ``joint_speeds`` only on an arm)."""
    figures = {
        "image_plane": plot_image_trajectories(comparison),
        "camera_path": plot_camera_paths(comparison),
        "error_norm": plot_error_norms(comparison),
        "joint_speeds": plot_joint_speeds(comparison),
    }
    return {name: fig for name, fig in figures.items() if fig is not None}


def save_comparison(
    comparison: Comparison, out_dir: str | Path, *, plots: bool = True, dpi: int = 110
) -> dict[str, Path]:
    """Write ``table.md``, ``table.json`` and (with ``plots``) ``figures/<name>.png``; return the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"table.md": out / "table.md", "table.json": out / "table.json"}
    write_text(paths["table.md"], comparison.table_markdown())
    write_json(paths["table.json"], comparison.to_dict())
    if plots:
        (out / "figures").mkdir(exist_ok=True)
        for name, fig in plot_comparison(comparison).items():
            paths[name] = out / "figures" / f"{name}.png"
            save_figure(fig, paths[name], dpi=dpi)
    return paths
