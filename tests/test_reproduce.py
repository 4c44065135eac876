"""The reproduction job: every variant, files written, resumable, table states outcomes."""

from __future__ import annotations

import json

import pytest

from ibvs_youla.analysis.reproduce import reproduce, run_key
from ibvs_youla.analysis.reproduction_table import table_markdown
from ibvs_youla.exceptions import InvalidParameterError


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce")
    return out, reproduce(out, scenario_names=("paper-2",), duration=1.0, diagnosis_duration=1.5)


def test_every_variant_is_simulated_and_saved(small):
    out, rep = small
    keys = {(r["controller"], r["outer_loop"]) for r in rep.rows}
    assert keys == {("fb", "fixed"), ("ff+fb", "fixed"), ("fb", "adaptive"), ("ff+fb", "adaptive")}
    for controller in ("fb", "ff+fb"):
        for adaptive in (False, True):
            assert (out / "runs" / f"{run_key('paper-2', controller, adaptive)}.npz").exists()
    # Nothing reaches the 1e-7 m target within 1 s (the outer loop settles in ~8 s), so each
    # run is still converging and got a longer diagnosis run, where it still converges.
    assert [r["outcome"]["kind"] for r in rep.rows] == ["converging"] * 4
    assert all(r["outcome_extended"]["duration"] == pytest.approx(1.5) for r in rep.rows)
    assert all(r["outcome_extended"]["kind"] == "converging" for r in rep.rows)
    # ... and each longer run has cut the image error further
    for r in rep.rows:
        assert r["outcome_extended"]["final_image_error_m"] < r["outcome"]["final_image_error_m"]


def test_figures_and_tables_are_written(small):
    out, _rep = small
    for mode in ("fixed", "adaptive"):
        for kind in ("joints", "image"):
            assert (out / "figures" / f"paper-2_{mode}_{kind}.png").stat().st_size > 10_000
    table = json.loads((out / "table.json").read_text())
    assert len(table["rows"]) == 4 and table["findings"]
    md = (out / "table.md").read_text()
    assert md.count("| paper-2 |") == 4
    assert "third point" in md  # the paper's claim is stated next to what was measured
    row = table["rows"][0]
    assert len(row["final_feature_error_m"]) == 9 and len(row["peak_torque_ratio"]) == 6


def _cells(line):
    return [c.strip() for c in line.strip().strip("|").split("|")]


def test_every_row_of_table_md_has_a_cell_per_header_cell_reached_at_included(small):
    out, rep = small
    lines = [line for line in (out / "table.md").read_text().splitlines() if line.startswith("|")]
    header, rows = _cells(lines[0]), [_cells(line) for line in lines[2:]]
    assert header[-1] == "reached at [s]" and len(rows) == 4
    assert all(len(row) == len(header) for row in rows)
    assert [row[-1] for row in rows] == ["never"] * 4  # still converging at 1.5 s: not reached
    # a row that reached its target in the diagnosis run gives that time, from the longest run
    rows = [dict(r) for r in rep.rows]
    rows[1]["outcome_extended"] = {**rows[1]["outcome_extended"], "kind": "reached", "reached_at_s": 7.25}
    rows[2]["outcome_extended"] = None
    rows[2]["outcome"] = {**rows[2]["outcome"], "reached_at_s": 0.5}
    lines = [line for line in table_markdown(rows, 1.0, 1.5).splitlines() if line.startswith("| paper-2")]
    assert [_cells(line)[-1] for line in lines] == ["never", "7.25", "0.5", "never"]


def test_table_json_is_strict_json_with_null_for_never(small):
    out, rep = small

    def refuse(constant):
        raise ValueError(f"not strict JSON: {constant}")

    table = json.loads((out / "table.json").read_text(), parse_constant=refuse)
    assert "never" in table["null"]
    row = table["rows"][0]
    assert rep.rows[0]["outcome"]["reached_at_s"] == float("inf")  # in memory: inf ...
    assert row["outcome"]["reached_at_s"] is None  # ... in the file: null, as "null" says
    assert row["settling_time_max_s"] is None and rep.rows[0]["settling_time_max_s"] == float("inf")


def test_a_second_call_resumes_from_saved_runs(small):
    out, rep = small
    path = out / "runs" / f"{run_key('paper-2', 'fb', True)}.npz"
    before = path.stat().st_mtime_ns
    # the figures are drawn from the runs, resumed or not: only the runs' resumption is at stake here
    again = reproduce(out, scenario_names=("paper-2",), duration=1.0, diagnosis_duration=1.5, plots=False)
    assert path.stat().st_mtime_ns == before
    assert [r["outcome"] for r in again.rows] == [r["outcome"] for r in rep.rows]


def test_bad_arguments(tmp_path):
    with pytest.raises(InvalidParameterError, match="scenario_names"):
        reproduce(tmp_path, scenario_names=())
    with pytest.raises(InvalidParameterError, match="duration"):
        reproduce(tmp_path, duration=0.0)
