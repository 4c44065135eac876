"""The report of a robustness study: per axis value and method, success, final error, time to reach.

:func:`summarize_study` makes one :class:`LevelSummary` per (axis value, method) from the rows of
:func:`~.robustness.read_study_rows`:

* **success**: runs that ended complete, inside the joint limits and with the final camera pose
  within ``tolerance`` = (mm, deg) of the target; with the default (1 mm, 0.1 deg) that is the
  campaign's outcome ``"reached"``. A looser tolerance suits a noise sweep, where no method
  sits within 1 mm of the target at the end once the image carries noise. Rate ``k / n`` with
  its 95 % Wilson interval (:func:`~.report.wilson_interval`);
* **final pose error**: median and quartiles over every run that ended complete [mm], and the
  median rotation error [deg];
* **time to reach**: median over the runs that reached the campaign's tolerance (1 mm, 0.1 deg,
  to the end) [s], NaN when none did;
* the count of every outcome.

:func:`degradation` names, per method, the first value whose success interval lies wholly below
the first value's (the sweep's reference, undisturbed by default): where the method degrades
first. :func:`plot_study` draws success, final position error and time to reach against the axis
value, one line per method (values evenly spaced, labelled: the sweeps are roughly geometric and
``saturation`` holds ``inf``); :func:`write_study_report` writes ``table.md``, ``table.json`` and
``figures/robustness_<axis>.png``.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..exceptions import InvalidParameterError
from .metrics import OUTCOMES, REACHED_DEG, REACHED_MM
from .report import wilson_interval

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    from matplotlib.figure import Figure

__all__ = ["LevelSummary", "degradation", "plot_study", "summarize_study", "write_study_report"]

DEFAULT_TOLERANCE = (REACHED_MM, REACHED_DEG)


@dataclass(frozen=True)
class LevelSummary:
    """One method at one axis value (module docstring).

    Attributes:
        value: The axis value.
        label: The value as written (``inf`` included).
        method: Controller name (``ff+fb (smooth)`` for the smooth feedforward).
        runs: Number of runs.
        success: Runs within the tolerance.
        rate, low, high: ``success / runs`` and its 95 % Wilson interval.
        position_median_mm, position_q25_mm, position_q75_mm: Final position error over the
            complete runs [mm].
        rotation_median_deg: Final rotation error over the complete runs [deg].
        time_to_reach_median_s: Over the runs that reached 1 mm / 0.1 deg [s].
        outcomes: Outcome -> count (the outcomes that occurred).
    """

    value: float
    label: str
    method: str
    runs: int
    success: int
    rate: float
    low: float
    high: float
    position_median_mm: float
    position_q25_mm: float
    position_q75_mm: float
    rotation_median_deg: float
    time_to_reach_median_s: float
    outcomes: dict[str, int]


def check_tolerance(tolerance: Any) -> tuple[float, float]:
    """(mm, deg), both finite and > 0.

    Raises:
        InvalidParameterError: anything else.
    """
    try:
        mm, deg = (float(v) for v in tolerance)
    except (TypeError, ValueError):
        mm = deg = math.nan
    if not (math.isfinite(mm) and math.isfinite(deg) and mm > 0.0 and deg > 0.0):
        raise InvalidParameterError("tolerance", tolerance, "(mm, deg), two finite numbers > 0")
    return mm, deg


def method_label(row_spec: str, controller: str) -> str:
    """The method's name in the study: the controller, marked when its feedforward is the smooth one."""
    params = json.loads(row_spec).get("controller_params", {})
    return f"{controller} (smooth)" if params.get("feedforward") == "smooth" else controller


def _methods(rows: pd.DataFrame) -> list[str]:
    from ..controllers import names

    present = list(dict.fromkeys(rows["method"]))
    order = {n: i for i, n in enumerate(names())}
    return sorted(present, key=lambda m: (order.get(m.split(" ")[0], len(order)), m))


def _quantile(values: Any, q: float) -> float:
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    return float(np.percentile(values, q)) if values.size else math.nan


def summarize_study(rows: pd.DataFrame, tolerance: Any = DEFAULT_TOLERANCE) -> list[LevelSummary]:
    """One :class:`LevelSummary` per (value, method), values in sweep order, methods in registry order."""
    mm, deg = check_tolerance(tolerance)
    rows = rows.assign(
        method=[method_label(s, c) for s, c in zip(rows["spec"], rows["controller"], strict=True)]
    )
    values = list(dict.fromkeys(rows["axis_value"]))
    out = []
    for value in values:
        at = rows[rows["axis_value"] == value]
        for method in _methods(rows):
            runs = at[at["method"] == method]
            n = len(runs)
            if not n:
                continue
            complete = runs[(runs["status"] == "complete") & (runs["outcome"] != "joint_limit")]
            k = int(((complete["final_position_mm"] < mm) & (complete["final_rotation_deg"] < deg)).sum())
            low, high = wilson_interval(k, n)
            reached = runs[runs["outcome"] == "reached"]
            counts = runs["outcome"].value_counts()
            out.append(
                LevelSummary(
                    value=float(value),
                    label=str(runs["axis_label"].iloc[0]),
                    method=method,
                    runs=n,
                    success=k,
                    rate=k / n,
                    low=low,
                    high=high,
                    position_median_mm=_quantile(complete["final_position_mm"], 50),
                    position_q25_mm=_quantile(complete["final_position_mm"], 25),
                    position_q75_mm=_quantile(complete["final_position_mm"], 75),
                    rotation_median_deg=_quantile(complete["final_rotation_deg"], 50),
                    time_to_reach_median_s=_quantile(reached["time_to_reach_s"], 50),
                    outcomes={o: int(counts[o]) for o in OUTCOMES if counts.get(o, 0)},
                )
            )
    return out


def degradation(summaries: list[LevelSummary]) -> dict[str, str | None]:
    """Method -> label of the first value whose success interval lies below the first value's.

    None when the method never drops significantly (its intervals always overlap the first).
    """
    out: dict[str, str | None] = {}
    for method in dict.fromkeys(s.method for s in summaries):
        mine = [s for s in summaries if s.method == method]
        reference = mine[0]
        out[method] = next((s.label for s in mine[1:] if s.high < reference.low), None)
    return out


def _number(x: float, digits: int) -> str:
    return "-" if not math.isfinite(x) else f"{x:.{digits}g}"


def table_markdown(summaries: list[LevelSummary], quantity: str, tolerance: tuple[float, float]) -> str:
    """One row per (method, value): success with its interval, final errors, time to reach, outcomes."""
    mm, deg = tolerance
    lines = [
        f"| method | {quantity} | runs | success (within {mm:g} mm, {deg:g} deg) | final position "
        "median [q25, q75] [mm] | final rotation median [deg] | time to reach median [s] | outcomes |",
        "|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for method in dict.fromkeys(s.method for s in summaries):
        for s in (s for s in summaries if s.method == method):
            position = (
                f"{_number(s.position_median_mm, 3)} [{_number(s.position_q25_mm, 3)}, "
                f"{_number(s.position_q75_mm, 3)}]"
            )
            rate = f"{100 * s.rate:.0f} % [{100 * s.low:.0f}, {100 * s.high:.0f}]"
            outcomes = ", ".join(f"{k} {o.replace('_', ' ')}" for o, k in s.outcomes.items())
            lines.append(
                f"| `{method}` | {s.label} | {s.runs} | {rate} | {position} | "
                f"{_number(s.rotation_median_deg, 3)} | {_number(s.time_to_reach_median_s, 3)} | {outcomes} |"
            )
    degrade = degradation(summaries)
    lines += ["", "First value whose success interval lies wholly below the first value's:", ""]
    lines += [f"- `{m}`: {'never, over this sweep' if v is None else v}" for m, v in degrade.items()]
    return "\n".join(lines) + "\n"


def plot_study(summaries: list[LevelSummary], quantity: str, title: str) -> Figure:
    """Success, final position error and time to reach against the axis value, a line per method."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(15.0, 4.4), layout="constrained")
    fig.suptitle(title)
    success, position, timing = fig.subplots(1, 3)
    labels = list(dict.fromkeys(s.label for s in summaries))
    x_of = {label: i for i, label in enumerate(labels)}
    methods = list(dict.fromkeys(s.method for s in summaries))
    for m, method in enumerate(methods):
        mine = [s for s in summaries if s.method == method]
        offset = 0.25 * (m - (len(methods) - 1) / 2) / max(1, len(methods))
        x = np.array([x_of[s.label] for s in mine]) + offset
        rate = np.array([s.rate for s in mine])
        err = [rate - [s.low for s in mine], [s.high for s in mine] - rate]
        style = {"color": f"C{m % 10}", "marker": "os^v<>"[m // 10 % 6], "label": method}
        success.errorbar(x, rate, yerr=err, capsize=3, **style)
        median = np.array([s.position_median_mm for s in mine])
        spread = [median - [s.position_q25_mm for s in mine], [s.position_q75_mm for s in mine] - median]
        position.errorbar(x, median, yerr=np.abs(spread), capsize=3, **style)
        timing.plot(x, [s.time_to_reach_median_s for s in mine], **style)
    success.set(ylabel="success rate (95 % Wilson interval)", ylim=(-0.05, 1.05))
    position.set(ylabel="final position error [mm] (median, quartiles)", yscale="log")
    timing.set(ylabel="time to reach 1 mm, 0.1 deg [s] (median)")
    for ax in (success, position, timing):
        ax.set_xticks(range(len(labels)), labels)
        ax.set_xlabel(quantity)
        ax.grid(alpha=0.3)
    success.legend(fontsize="small")
    return fig


def _json_ready(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _json_ready(v) for k, v in value.items()}
    if isinstance(value, float) and not math.isfinite(value):
        return None if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return value


def write_study_report(
    folder: str | Path, out: str | Path | None = None, tolerance: Any = DEFAULT_TOLERANCE
) -> dict[str, Path]:
    """Write ``table.md``, ``table.json`` and ``figures/robustness_<axis>.png``; return their paths.

    Args:
        folder: The study folder (``study.json`` and the value folders).
        out: Where to write (default: ``folder``).
        tolerance: (mm, deg) of a success.
    """
    from .robustness import read_study, read_study_rows
    from .robustness_axes import AXES

    study = read_study(folder)
    tolerance = check_tolerance(tolerance)
    rows = read_study_rows(folder)
    summaries = summarize_study(rows, tolerance)
    out = Path(folder if out is None else out)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    quantity = AXES[study.axis].quantity
    campaign = study.campaign
    caption = (
        f"Robustness to {study.axis} ({quantity}): {campaign['cases']} cases of {campaign['family']} "
        f"(seed {campaign['seed']}) on the {campaign['plant']} plant, {campaign['duration']:g} s per run, "
        f"{len(rows)} runs. Success: complete, within the joint limits and within {tolerance[0]:g} mm "
        f"and {tolerance[1]:g} deg of the target at the end; 95 % Wilson interval in brackets. Final "
        "errors over the complete runs; time to reach over the runs within 1 mm and 0.1 deg to the end.\n\n"
    )
    paths = {"table.md": out / "table.md", "table.json": out / "table.json"}
    paths["table.md"].write_text(caption + table_markdown(summaries, quantity, tolerance))
    data = {
        "axis": study.axis,
        "quantity": quantity,
        "values": list(dict.fromkeys(s.label for s in summaries)),
        "tolerance": {"mm": tolerance[0], "deg": tolerance[1]},
        "runs": len(rows),
        "campaign": campaign,
        "degrades_at": degradation(summaries),
        "levels": [_json_ready(asdict(s)) for s in summaries],
    }
    paths["table.json"].write_text(json.dumps(data, indent=1, allow_nan=False) + "\n")
    figure = out / "figures" / f"robustness_{study.axis}.png"
    title = f"{campaign['family']}: robustness to {study.axis}"
    plot_study(summaries, quantity, title).savefig(figure, dpi=110)
    paths[figure.name] = figure
    return paths
