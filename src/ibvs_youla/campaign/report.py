"""The report of a campaign: outcome rates with Wilson intervals per method, times, and figures.

:func:`read_rows` reads a campaign's rows (``DIR/rows``, the Parquet dataset of
:data:`~.metrics.COLUMNS`); :func:`summarize` makes one :class:`MethodSummary` per (family,
method):

* **runs** and, for every outcome of :data:`~.metrics.OUTCOMES`, its count and rate
  ``k / n`` with the 95 % Wilson score interval (:func:`wilson_interval`);
* **time to reach**: the median and 90th percentile (linear interpolation) over the runs
  whose outcome is ``"reached"`` [s];
* **path ratio**: the median of ``path_ratio`` (camera path over the straight line) over the
  reached runs (a run that failed has no comparable path);
* **compute time**: the median over runs of each run's ``update_median_us`` [us].

Figures (matplotlib ``Figure`` objects, no pyplot state), one set per family:
:func:`plot_success_vs_difficulty` (reached rate against the rotation between the start and
target cameras, binned, with Wilson error bars), :func:`plot_time_to_reach` (its distribution
per method) and, for the free-camera families, :func:`plot_basins`: every start pose as a
point over two of :data:`AXES`, coloured by its outcome, one panel per method.
:func:`write_report` writes ``table.md``, ``table.json`` and ``figures/<family>_<figure>.png``.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from statistics import NormalDist
from typing import TYPE_CHECKING, Any

import numpy as np

from ..exceptions import InvalidParameterError
from ..files import save_figure, write_text
from .metrics import OUTCOMES

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    from matplotlib.figure import Figure

__all__ = [
    "AXES",
    "FIGURES",
    "MethodSummary",
    "plot_basins",
    "plot_success_vs_difficulty",
    "plot_time_to_reach",
    "read_rows",
    "start_pose_axes",
    "summarize",
    "table_markdown",
    "wilson_interval",
    "write_report",
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
    "not_converged": "tab:orange",
    "diverged": "black",
    "features_lost": "tab:purple",
    "estimate_failed": "tab:brown",
    "joint_limit": "tab:pink",
    "qp_infeasible": "tab:olive",
    "error": "tab:gray",
}


def wilson_interval(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """The Wilson score interval of a rate ``k / n`` (Wilson 1927; Brown, Cai & DasGupta 2001, Eq. (4)).

    ``(p + z^2 / 2n -+ z sqrt(p (1 - p) / n + z^2 / 4n^2)) / (1 + z^2 / n)`` with ``p = k / n``
    and ``z`` the ``(1 + confidence) / 2`` quantile of the standard normal (1.95996 at 95 %);
    exactly 0 for ``k = 0`` and 1 for ``k = n``. ``n = 0`` gives ``(0, 1)``: every rate is possible.

    Raises:
        InvalidParameterError: ``k`` or ``n`` not integers with ``0 <= k <= n``, or a confidence
            outside (0, 1).
    """
    if not 0.0 < confidence < 1.0:
        raise InvalidParameterError("confidence", confidence, "a number in (0, 1)")
    if any(isinstance(v, bool) or not isinstance(v, (int, np.integer)) for v in (k, n)) or not 0 <= k <= n:
        raise InvalidParameterError("(k, n)", (k, n), "integers with 0 <= k <= n")
    if n == 0:
        return 0.0, 1.0
    z = NormalDist().inv_cdf(0.5 + 0.5 * confidence)
    p, z2 = k / n, z * z
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n)
    low = 0.0 if k == 0 else max(0.0, centre - half)  # exact ends: the formula gives 0 and 1 there
    high = 1.0 if k == n else min(1.0, centre + half)
    return low, high


def read_rows(folder: str | Path) -> pd.DataFrame:
    """The rows of the campaign in ``folder`` (``folder/rows``), one per (case, method) key.

    A key stored twice (it should not be) counts once, its last row kept.

    Raises:
        InvalidParameterError: ``folder/rows`` missing or holding no row.
        DamagedFileError: (an InvalidParameterError) a part does not read; the message names it.
    """
    from .storage import read_rows as read_stored_rows  # one reader: the storage's schema and parts

    rows_dir = Path(folder) / "rows"
    if not rows_dir.is_dir() or not any(rows_dir.rglob("*.parquet")):
        raise InvalidParameterError("DIR", str(folder), "a campaign folder with rows in DIR/rows")
    rows = read_stored_rows(folder)
    if rows.empty:
        raise InvalidParameterError("DIR", str(folder), "a campaign folder with rows in DIR/rows")
    return rows.drop_duplicates("key", keep="last").reset_index(drop=True)


def _methods(rows: pd.DataFrame) -> list[str]:
    """The methods of ``rows`` in registry order, then any other name alphabetically."""
    from ..controllers import names

    present = set(rows["controller"])
    return [n for n in names() if n in present] + sorted(present - set(names()))


@dataclass(frozen=True)
class MethodSummary:
    """One method's line of the table (module docstring).

    Attributes:
        family: Case family.
        method: Controller name.
        runs: Number of runs.
        outcomes: Outcome -> ``{"count", "rate", "low", "high"}`` (95 % Wilson interval).
        time_to_reach_median_s: Median time to reach over the reached runs [s] (NaN if none).
        time_to_reach_p90_s: Its 90th percentile [s].
        path_ratio_median: Median path ratio over the reached runs.
        update_median_us: Median over runs of the median control-update time [us].
    """

    family: str
    method: str
    runs: int
    outcomes: dict[str, dict[str, float]]
    time_to_reach_median_s: float
    time_to_reach_p90_s: float
    path_ratio_median: float
    update_median_us: float


def _quantile(values: Any, q: float) -> float:
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    return float(np.percentile(values, q)) if values.size else math.nan


def summarize(rows: pd.DataFrame) -> list[MethodSummary]:
    """One :class:`MethodSummary` per (family, method), families sorted, methods in registry order."""
    out = []
    for family in sorted(set(rows["family"])):
        in_family = rows[rows["family"] == family]
        for method in _methods(in_family):
            runs = in_family[in_family["controller"] == method]
            n = len(runs)
            counts = runs["outcome"].value_counts()
            outcomes = {}
            for outcome in OUTCOMES:
                k = int(counts.get(outcome, 0))
                low, high = wilson_interval(k, n)
                outcomes[outcome] = {"count": k, "rate": k / n, "low": low, "high": high}
            reached = runs[runs["outcome"] == "reached"]
            out.append(
                MethodSummary(
                    family=family,
                    method=method,
                    runs=n,
                    outcomes=outcomes,
                    time_to_reach_median_s=_quantile(reached["time_to_reach_s"], 50),
                    time_to_reach_p90_s=_quantile(reached["time_to_reach_s"], 90),
                    path_ratio_median=_quantile(reached["path_ratio"], 50),
                    update_median_us=_quantile(runs["update_median_us"], 50),
                )
            )
    return out


def _rate(entry: dict[str, float]) -> str:
    return f"{100 * entry['rate']:.1f} % [{100 * entry['low']:.0f}, {100 * entry['high']:.0f}]"


def _number(x: float, digits: int) -> str:
    return "-" if not math.isfinite(x) else f"{x:.{digits}f}"


def table_markdown(summaries: list[MethodSummary]) -> str:
    """The Markdown table: one section per family, a column per outcome that occurred.

    Rates in percent with their 95 % Wilson interval in brackets; "reached" always shown.
    """
    lines = []
    families = sorted({s.family for s in summaries})
    for family in families:
        part = [s for s in summaries if s.family == family]
        shown = [o for o in OUTCOMES if o == "reached" or any(s.outcomes[o]["count"] for s in part)]
        if len(families) > 1:
            lines += [f"### {family}", ""]
        head = ["method", "runs", *(o.replace("_", " ") for o in shown)]
        head += ["time to reach median / p90 [s]", "path ratio (median)", "update (median) [us]"]
        lines += ["| " + " | ".join(head) + " |", "|" + "---|" * 2 + "---:|" * (len(head) - 2)]
        for s in part:
            cells = [f"`{s.method}`", str(s.runs), *(_rate(s.outcomes[o]) for o in shown)]
            times = f"{_number(s.time_to_reach_median_s, 2)} / {_number(s.time_to_reach_p90_s, 2)}"
            cells += [times, _number(s.path_ratio_median, 3), _number(s.update_median_us, 1)]
            lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


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
    fig = _figure((7.0, 4.2), f"{_families(rows)}: success against difficulty")
    ax = fig.subplots()
    angle = rows["difficulty_rotation_deg"].to_numpy(dtype=float)
    largest = max(1e-9, float(np.nanmax(angle))) if np.isfinite(angle).any() else 1.0
    width = 10.0 * math.ceil(largest / (10.0 * bins))  # [deg], a multiple of 10
    bins = math.ceil(largest / width)
    edges = width * np.arange(bins + 1)
    methods = _methods(rows)
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
    fig = _figure((11.0, 4.2), f"{_families(rows)}: time to reach")
    left, right = fig.subplots(1, 2)
    methods = _methods(rows)
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
    methods = _methods(rows)
    cols = min(max_columns, len(methods))
    n_rows = -(-len(methods) // cols)
    fig = _figure((3.4 * cols + 0.6, 3.2 * n_rows + 0.8), f"{_families(rows)}: outcome by start pose")
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


def _json_ready(value: Any) -> Any:
    """NaN and infinities to None (JSON has neither)."""
    if isinstance(value, dict):
        return {k: _json_ready(v) for k, v in value.items()}
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _families(rows: pd.DataFrame) -> str:
    return ", ".join(sorted(set(rows["family"])))


def write_report(rows: pd.DataFrame, out: str | Path, axes: Any = DEFAULT_AXES) -> dict[str, Path]:
    """Write ``table.md``, ``table.json`` and ``figures/<family>_<figure>.png``; return their paths.

    ``table.json``: ``{"runs", "families", "methods": [MethodSummary as a dict, ...]}``.
    """
    axes = check_axes(axes)
    out = Path(out)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    summaries = summarize(rows)
    paths = {"table.md": out / "table.md", "table.json": out / "table.json"}
    caption = (
        f"{len(rows)} runs: {_families(rows)}; plant {', '.join(sorted(set(rows['plant'])))}, "
        f"{', '.join(f'{d:g} s' for d in sorted(set(rows['duration'])))} per run. Rates: percent of the "
        "method's runs, 95 % Wilson interval in brackets; time to reach and path ratio over the reached "
        "runs (pose within 1 mm and 0.1 deg to the end).\n\n"
    )
    write_text(paths["table.md"], caption + table_markdown(summaries))
    data = {
        "runs": len(rows),
        "families": sorted(set(rows["family"])),
        "methods": [_json_ready(asdict(s)) for s in summaries],
    }
    write_text(paths["table.json"], json.dumps(data, indent=1, allow_nan=False) + "\n")
    for family in sorted(set(rows["family"])):
        part = rows[rows["family"] == family]
        figures = {
            "success_vs_difficulty": plot_success_vs_difficulty(part),
            "time_to_reach": plot_time_to_reach(part),
            "basins": plot_basins(part, axes),
        }
        for name, fig in figures.items():
            if fig is not None:
                path = out / "figures" / f"{family}_{name}.png"
                save_figure(fig, path, dpi=110)
                paths[path.name] = path
    return paths
