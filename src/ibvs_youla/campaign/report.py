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

The figures are those of :mod:`.figures`, one set per family. :func:`write_report` writes
``table.md``, ``table.json`` and ``figures/<family>_<figure>.png``.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..exceptions import InvalidParameterError
from ..files import save_figure, write_text
from .figures import (
    AXES,
    DEFAULT_AXES,
    FIGURES,
    check_axes,
    family_names,
    plot_basins,
    plot_success_vs_difficulty,
    plot_time_to_reach,
    start_pose_axes,
)
from .intervals import wilson_interval
from .metrics import OUTCOMES
from .spec import sort_methods

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = [  # the figures and the interval are re-exported: the report's API before they had modules
    "AXES",
    "DEFAULT_AXES",
    "FIGURES",
    "MethodSummary",
    "check_axes",
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
        for method in sort_methods(in_family):
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


def _json_ready(value: Any) -> Any:
    """NaN and infinities to None (JSON has neither)."""
    if isinstance(value, dict):
        return {k: _json_ready(v) for k, v in value.items()}
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


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
        f"{len(rows)} runs: {family_names(rows)}; plant {', '.join(sorted(set(rows['plant'])))}, "
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
