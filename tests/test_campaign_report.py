"""The campaign report: Wilson intervals against published values, the table recomputed from the rows,
the start poses in closed form, the figures' data, and the command's files and errors."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from ibvs_youla import cli
from ibvs_youla.campaign import report
from ibvs_youla.campaign.cases import generate_cases
from ibvs_youla.campaign.metrics import COLUMNS, LATER_COLUMNS, OUTCOMES
from ibvs_youla.campaign.run import run_spec
from ibvs_youla.campaign.spec import specs_for
from ibvs_youla.exceptions import InvalidParameterError

FREE = {
    "plant": "free-camera",
    "camera": {"kind": "normalized"},
    "duration": 20.0,
    "settings": {"joint_rate_hz": 25.0, "camera_rate_hz": 25.0},
}


@pytest.fixture(scope="module")
def rows():
    """Four free-planar cases x (ibvs-current, pbvs), and one pbvs run that raises (collinear markers)."""
    cases = generate_cases("free-planar", 4, 3)
    specs = specs_for(cases, ["ibvs-current", "pbvs"], seed=3, **FREE)
    (bad,) = specs_for(cases[:1], ["pbvs"], seed=3, **FREE)
    on_a_line = [[-0.1, 0.0, 0.0], [0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.2, 0.0, 0.0]]  # [m]
    specs.append(dataclasses.replace(bad, scenario={**bad.scenario, "markers_O": on_a_line}))
    return pd.DataFrame([run_spec(s) for s in specs])


def write_rows(folder, frame):
    (folder / "rows").mkdir(parents=True)
    frame.to_parquet(folder / "rows" / "part-0.parquet")
    return folder


@pytest.mark.parametrize(
    ("k", "n", "low", "high"),
    [
        (0, 10, 0.0, 0.2775),
        (5, 10, 0.2366, 0.7634),
        (10, 10, 0.7225, 1.0),
        # Newcombe 1998, Table II, method 3 (score interval without continuity correction)
        (81, 263, 0.2553, 0.3662),
        (15, 148, 0.0624, 0.1605),
        (0, 20, 0.0, 0.1611),
        (1, 29, 0.0061, 0.1718),
    ],
)
def test_wilson_interval_matches_published_values(k, n, low, high):
    got = report.wilson_interval(k, n)
    assert got == pytest.approx((low, high), abs=5e-5)
    assert report.wilson_interval(0, 7)[0] == 0.0 and report.wilson_interval(7, 7)[1] == 1.0  # exact ends


def test_wilson_interval_refuses_bad_counts():
    assert report.wilson_interval(0, 0) == (0.0, 1.0)
    for k, n in ((3, 2), (-1, 4), (1.0, 4), (True, 4)):
        with pytest.raises(InvalidParameterError, match=r"0 <= k <= n"):
            report.wilson_interval(k, n)
    with pytest.raises(InvalidParameterError, match="confidence"):
        report.wilson_interval(1, 2, confidence=1.0)
    # 99 %, k = n / 2: 1/2 -+ z sqrt(1 / 4n + z^2 / 4n^2) / (1 + z^2 / n) with z = 2.5758293035489
    z, n = 2.5758293035489, 10
    half = z * math.sqrt(1 / (4 * n) + z * z / (4 * n * n)) / (1 + z * z / n)
    assert report.wilson_interval(5, 10, 0.99) == pytest.approx((0.5 - half, 0.5 + half), abs=1e-12)
    assert half == pytest.approx(0.3158, abs=5e-5)


def test_the_table_is_recomputed_from_the_rows(rows):
    assert set(rows.columns) == set(COLUMNS)
    summaries = report.summarize(rows)
    assert [(s.family, s.method, s.runs) for s in summaries] == [
        ("free-planar", "ibvs-current", 4),
        ("free-planar", "pbvs", 5),
    ]
    ibvs, pbvs = summaries
    assert set(ibvs.outcomes) == set(OUTCOMES)
    assert ibvs.outcomes["reached"] == {
        "count": 4,
        "rate": 1.0,
        "low": pytest.approx(0.5101, abs=5e-5),
        "high": 1.0,
    }
    assert pbvs.outcomes["reached"]["count"] == 4 and pbvs.outcomes["error"]["count"] == 1
    assert (pbvs.outcomes["error"]["low"], pbvs.outcomes["error"]["high"]) == report.wilson_interval(1, 5)
    for s in summaries:
        mine = rows[(rows.controller == s.method) & (rows.outcome == "reached")]
        assert s.time_to_reach_median_s == pytest.approx(np.median(mine.time_to_reach_s), abs=1e-12)
        assert s.time_to_reach_p90_s == pytest.approx(np.percentile(mine.time_to_reach_s, 90), abs=1e-12)
        assert s.path_ratio_median == pytest.approx(np.median(mine.path_ratio), abs=1e-12)
    # times fall on the 25 Hz frames, so half a frame (0.02 s) pins them; measured 12.46 s and 11.04 s
    # (the range 8-20 s it replaces admitted a controller twice as slow)
    assert ibvs.time_to_reach_median_s == pytest.approx(12.46, abs=0.02)
    assert pbvs.time_to_reach_median_s == pytest.approx(11.04, abs=0.02)
    # PBVS: a straight line that stops 5-11 um short of its 0.13-0.27 m: 1 - 3.5e-5 measured
    assert pbvs.path_ratio_median == pytest.approx(1.0, abs=1e-4)
    # the error row ran no update: the compute time is the median over the four that ran
    ran = rows[(rows.controller == "pbvs") & (rows.outcome != "error")]
    assert pbvs.update_median_us == pytest.approx(np.median(ran.update_median_us), abs=1e-9)
    table = report.table_markdown(summaries)
    lines = table.splitlines()
    assert lines[0].split(" | ")[:4] == ["| method", "runs", "reached", "error"]  # outcomes that occurred
    assert lines[3].startswith("| `pbvs` | 5 | 80.0 % [38, 96] | 20.0 % [4, 62] |")


def test_read_rows_keeps_one_row_per_key_and_refuses_an_empty_folder(rows, tmp_path):
    folder = write_rows(tmp_path / "c", rows)
    rows.iloc[:3].to_parquet(folder / "rows" / "part-1.parquet")  # three keys stored twice
    again = report.read_rows(folder)
    assert len(again) == len(rows) == 9 and sorted(again.key) == sorted(rows.key)
    (tmp_path / "empty" / "rows").mkdir(parents=True)
    for where in (tmp_path / "empty", tmp_path / "missing"):
        with pytest.raises(InvalidParameterError, match="DIR/rows"):
            report.read_rows(where)


def test_start_poses_in_the_target_frame_in_closed_form(rows):
    free = rows[rows.outcome != "error"]
    rotation, translation = report.start_pose_axes(free, ("rotation", "translation")).T
    np.testing.assert_allclose(rotation, free.difficulty_rotation_deg, atol=1e-9)
    np.testing.assert_allclose(translation, free.difficulty_translation_m, atol=1e-12)
    # the start camera T_C*_C0 = (R_x(tilt) R_z(twist), t): swing about x, then twist about the optical axis
    T_target = np.eye(4)
    T_target[:3, 3] = (0.0, 0.0, -0.75)
    specs, expected = [], []
    for twist, tilt, t in (
        (150.0, 30.0, (0.1, -0.2, 0.05)),
        (-170.0, 80.0, (0.0, 0.3, -0.1)),
        (5.0, 0.0, (0, 0, 0)),
    ):
        delta = np.eye(4)
        delta[:3, :3] = Rotation.from_euler("xz", (tilt, twist), degrees=True).as_matrix()
        delta[:3, 3] = t
        scenario = {"T_O_C_start": (T_target @ delta).tolist(), "T_O_C_target": T_target.tolist()}
        specs.append(json.dumps({"scenario": scenario}))
        rotvec = np.degrees(Rotation.from_matrix(delta[:3, :3]).as_rotvec())
        expected.append((twist, tilt, *t, *rotvec))
    frame = pd.DataFrame({"spec": specs})
    names = ("twist", "tilt", "tx", "ty", "tz", "rx", "ry", "rz")
    got = np.column_stack([report.start_pose_axes(frame, (a, "rotation"))[:, 0] for a in names])
    np.testing.assert_allclose(got, expected, atol=1e-9)
    with pytest.raises(InvalidParameterError, match="two different names"):
        report.start_pose_axes(frame, ("tilt", "tilt"))


def test_arm_rows_have_no_outcome_map():
    case = generate_cases("arm-physical", 1, 2)[0]
    (spec,) = specs_for([case], ["ff+fb"], seed=2, plant="dynamic", camera={"kind": "stereo"}, duration=1.0)
    frame = pd.DataFrame(
        {
            "spec": [spec.to_json()],
            "controller": ["ff+fb"],
            "outcome": ["reached"],
            "family": ["arm-physical"],
        }
    )
    assert np.isnan(report.start_pose_axes(frame)).all()
    assert report.plot_basins(frame) is None


def test_figures_hold_the_rates_and_the_runs(rows):
    fig = report.plot_success_vs_difficulty(rows)
    ax = fig.axes[0]
    bars = ax.containers
    assert [b.get_label() for b in bars] == ["ibvs-current", "pbvs"]
    # the cases turn by 19.19, 2.57, 25.47 and 48.07 deg: 10-deg bins up to 50 deg, bins 0, 1, 2 and 4
    # hold one case each, and pbvs's error row (case 0) makes its bin 1 reach 1 run of 2
    np.testing.assert_array_equal(ax.get_xticks(), [0, 10, 20, 30, 40, 50])
    np.testing.assert_array_equal(np.asarray(bars[0].lines[0].get_ydata()), [1.0, 1.0, 1.0, 1.0])
    np.testing.assert_array_equal(np.asarray(bars[1].lines[0].get_ydata()), [1.0, 0.5, 1.0, 1.0])
    np.testing.assert_array_equal(np.asarray(bars[1].lines[0].get_xdata()) // 10, [0, 1, 2, 4])
    bar = bars[1].lines[2][0].get_segments()[1]  # the error bar of bin 1: the Wilson interval of 1 of 2
    np.testing.assert_allclose(bar[:, 1], report.wilson_interval(1, 2), atol=1e-12)

    fig = report.plot_time_to_reach(rows)
    right = fig.axes[1]
    assert [line.get_ydata()[-1] for line in right.lines] == [1.0, 0.8]  # the reached rates
    assert right.lines[1].get_xdata()[-1] == 20.0  # drawn to the end of the runs

    fig = report.plot_basins(rows, ("tx", "ty"))
    panels = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_title() for ax in panels] == ["ibvs-current", "pbvs"]
    counts = [sum(len(c.get_offsets()) for c in ax.collections) for ax in panels]
    assert counts == [4, 5]
    assert panels[1].get_xlabel() == report.AXES["tx"] and panels[0].get_ylabel() == report.AXES["ty"]


def run_command(argv):
    return cli.main(["campaign-report", *argv])


def test_command_writes_the_table_and_figures(rows, tmp_path, capsys):
    folder = write_rows(tmp_path / "campaign", rows)
    assert run_command([str(folder)]) == 0
    out = folder / "report"
    printed = capsys.readouterr().out
    assert (out / "table.md").read_text().splitlines()[2] in printed
    saved = json.loads((out / "table.json").read_text())
    assert saved["runs"] == 9 and saved["families"] == ["free-planar"]
    pbvs = saved["methods"][1]
    assert pbvs["method"] == "pbvs" and pbvs["outcomes"]["reached"]["count"] == 4
    assert pbvs["outcomes"]["reached"]["low"] == pytest.approx(report.wilson_interval(4, 5)[0], abs=1e-15)
    names = sorted(p.name for p in (out / "figures").iterdir())
    assert names == [f"free-planar_{name}.png" for name in sorted(report.FIGURES)]
    assert all((out / "figures" / n).stat().st_size > 10_000 for n in names)

    elsewhere = tmp_path / "elsewhere"
    assert run_command([str(folder), "--out", str(elsewhere), "--axes", "tz,rotation"]) == 0
    assert (elsewhere / "table.md").read_text() == (out / "table.md").read_text()


def test_command_without_rows_is_one_line_and_exit_1(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    assert run_command([str(tmp_path / "empty")]) == 1
    captured = capsys.readouterr()
    assert captured.out == "" and len(captured.err.strip().splitlines()) == 1
    assert captured.err.startswith("ibvs-youla: error: campaign-report:") and "DIR/rows" in captured.err
    assert not (tmp_path / "empty" / "report").exists()  # nothing written


def test_command_refuses_bad_axes(capsys):
    assert run_command(["somewhere", "--axes", "twist,yaw"]) == 2
    assert "valid: two different names" in capsys.readouterr().err


def test_rows_stored_before_a_column_existed_read_it_as_missing(rows, tmp_path):
    old = rows.drop(columns=["final_jacobian_sigma"])  # a part written by the previous version
    assert LATER_COLUMNS == {"final_jacobian_sigma"}
    folder = write_rows(tmp_path / "old", old)
    again = report.read_rows(folder)
    assert list(again.columns) == list(COLUMNS) and again["final_jacobian_sigma"].isna().all()
    assert again.drop(columns=["final_jacobian_sigma"]).equals(
        old[list(again.columns.drop("final_jacobian_sigma"))]
    )
