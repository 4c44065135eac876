"""Robustness studies: the axes' levels, one campaign per value on the same cases, the report, the CLI."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from ibvs_youla.campaign.robustness import RobustnessStudy, read_study_rows, run_study
from ibvs_youla.campaign.robustness_axes import AXES
from ibvs_youla.campaign.robustness_report import degradation, plot_study, summarize_study
from ibvs_youla.cli import main
from ibvs_youla.exceptions import InvalidParameterError

FREE = {"family": "free-planar", "controllers": ("ibvs-current",), "seed": 2}


def test_each_axis_states_its_levels():
    assert AXES["noise"].levels(0.3, "dynamic", True) == {"pixel_noise_px": 0.3}
    assert AXES["latency"].levels(4.0, "free-camera", False) == {"latency_frames": 4}
    assert AXES["saturation"].levels(math.inf, "dynamic", True) == {}
    assert AXES["saturation"].levels(0.5, "dynamic", True) == {"limit_scale": 0.5}
    arm = AXES["calibration"].levels(2.0, "dynamic", True)
    assert arm["focal_length_scale"] == pytest.approx(1.02) and arm["baseline_scale"] == pytest.approx(1.02)
    assert arm["principal_point_offset_px"] == (4.0, -4.0) and arm["marker_sigma_m"] == pytest.approx(0.002)
    assert np.linalg.norm(arm["hand_eye_translation_m"]) == pytest.approx(0.002 * math.sqrt(3))
    free = AXES["calibration"].levels(2.0, "free-camera", False)  # no baseline, no hand-eye
    assert not {"baseline_scale", "hand_eye_translation_m", "hand_eye_rotation_deg"} & set(free)
    mismatch = AXES["mismatch"].levels(1.0, "dynamic", True)
    assert mismatch["plant_inertia_scale"] == 2.0
    assert mismatch["coulomb_friction"][0] == pytest.approx(0.02 * 3100.0)  # 2 % of joint 1's 3100 N m


def test_every_value_runs_the_same_cases():
    study = RobustnessStudy("latency", (0, 2), {**FREE, "cases": 3})
    (v0, undisturbed), (v2, delayed) = study.campaigns()
    assert (v0, v2) == (0.0, 2.0)
    a, b = undisturbed.specs(), delayed.specs()
    assert [s.scenario for s in a] == [s.scenario for s in b]
    assert a[0].disturbances == {} and b[0].disturbances == {"latency_frames": 2}
    assert not {s.key for s in a} & {s.key for s in b}
    assert (
        undisturbed.to_dict()
        == RobustnessStudy("latency", (0,), {**FREE, "cases": 3}).campaigns()[0][1].to_dict()
    )


@pytest.mark.parametrize(
    ("axis", "values", "campaign", "match"),
    [
        ("noise", (), {}, "values"),
        ("noise", (-0.5,), {}, "noise value"),
        ("latency", (1.5,), {}, "latency value"),
        ("saturation", (0.0,), {"family": "arm-physical"}, "saturation value"),
        ("calibration", (1.0, 1.0), {}, "distinct"),
        ("mismatch", None, {}, "dynamic arm only"),
        ("saturation", None, {"family": "arm-physical", "plant": "kinematic"}, "dynamic arm only"),
        ("images", None, {}, "rendered_images"),  # the free family's normalized camera has no pixels
    ],
)
def test_a_bad_study_is_refused(axis, values, campaign, match):
    with pytest.raises(InvalidParameterError, match=match):
        RobustnessStudy(axis, values, {**FREE, "cases": 2, **campaign})


@pytest.fixture(scope="module")
def study_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("study") / "noise"
    code = main(
        [
            "robustness",
            "--axis",
            "noise",
            "--values",
            "0,2",
            "--cases",
            "4",
            "--family",
            "free-planar",
            "--controllers",
            "ibvs-current,pbvs",
            "--seed",
            "2",
            "--duration",
            "20",
            "--workers",
            "0",
            "--no-progress",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    return out


def test_a_study_stores_one_campaign_per_value_and_a_report(study_dir):
    assert sorted(p.name for p in study_dir.iterdir()) == [
        "figures",
        "noise=0",
        "noise=2",
        "study.json",
        "table.json",
        "table.md",
    ]
    assert len(pd.read_parquet(study_dir / "noise=2" / "rows")) == 8  # a plain campaign folder
    rows = read_study_rows(study_dir)
    assert sorted(set(rows["axis_value"])) == [0.0, 2.0] and len(rows) == 16
    table = json.loads((study_dir / "table.json").read_text())
    by = {(lv["method"], lv["label"]): lv for lv in table["levels"]}
    for method in ("ibvs-current", "pbvs"):
        assert by[(method, "0")]["success"] == 4  # every case reached without noise
        assert by[(method, "2")]["success"] == 0  # 2 px: a millimetre floor, never within 1 mm
        assert 1.0 < by[(method, "2")]["position_median_mm"] < 30.0
    assert table["degrades_at"] == {"ibvs-current": "2", "pbvs": "2"}  # [51, 100] % against [0, 49] %
    assert (study_dir / "figures" / "robustness_noise.png").stat().st_size > 10_000


def test_the_same_command_resumes_without_rerunning(study_dir, capsys):
    before = {p: p.stat().st_mtime_ns for p in study_dir.glob("noise=*/rows/*.parquet")}
    args = ["robustness", "--axis", "noise", "--values", "0,2", "--cases", "4", "--family", "free-planar"]
    args += ["--controllers", "ibvs-current,pbvs", "--seed", "2", "--duration", "20", "--workers", "0"]
    assert main([*args, "--no-progress", "--out", str(study_dir), "--tolerance", "50,5"]) == 0
    assert {p: p.stat().st_mtime_ns for p in study_dir.glob("noise=*/rows/*.parquet")} == before
    assert "8 runs stored before, 0 run" in capsys.readouterr().err
    table = json.loads((study_dir / "table.json").read_text())  # the report again, another tolerance
    assert table["tolerance"] == {"mm": 50.0, "deg": 5.0}
    assert all(lv["success"] == 4 for lv in table["levels"])


def test_the_report_draws_a_line_per_method_and_names_where_each_degrades(study_dir):
    summaries = summarize_study(read_study_rows(study_dir))
    fig = plot_study(summaries, AXES["noise"].quantity, "test")
    success = fig.axes[0]
    assert [c.get_label() for c in success.containers] == ["ibvs-current", "pbvs"]  # errorbar lines
    assert [t.get_text() for t in success.get_legend().get_texts()] == ["ibvs-current", "pbvs"]
    _, rate = success.containers[0].lines[0].get_data()
    np.testing.assert_allclose(rate, [1.0, 0.0])  # success at 0 and 2 px
    assert degradation(summaries) == {"ibvs-current": "2", "pbvs": "2"}


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--axis", "images"], "no pixels"),
        (["--axis", "mismatch"], "dynamic arm only"),
        (["--axis", "noise", "--values", "-1"], "finite numbers >= 0"),
        (["--axis", "noise", "--values", ","], "one or more"),
        (["--axis", "latency", "--values", "0,0.5"], "integers >= 0"),
        (["--axis", "noise", "--feedforward", "smooth"], "ff+fb"),
        (["--axis", "noise", "--tolerance", "1"], "MM,DEG"),
        (["--axis", "noise", "--controllers", "nope"], "unknown"),
        (["--axis", "wind"], "invalid choice"),
    ],
)
def test_bad_arguments_exit_2_and_write_nothing(tmp_path, capsys, args, message):
    out = tmp_path / "study"
    base = ["robustness", "--family", "free-planar", "--cases", "2", "--workers", "0", "--out", str(out)]
    assert main([*base, *args]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_a_folder_holding_something_else_is_refused_untouched(study_dir, tmp_path, capsys):
    other = ["robustness", "--axis", "noise", "--values", "0,3", "--cases", "4", "--family", "free-planar"]
    other += ["--controllers", "ibvs-current,pbvs", "--seed", "2", "--duration", "20", "--workers", "0"]
    assert main([*other, "--out", str(study_dir)]) == 1
    assert "holds another study" in capsys.readouterr().err
    assert not (study_dir / "noise=3").exists()
    cluttered = tmp_path / "cluttered"
    cluttered.mkdir()
    (cluttered / "notes.txt").write_text("mine")
    assert main([*other, "--out", str(cluttered)]) == 1
    assert "other files" in capsys.readouterr().err
    assert sorted(p.name for p in cluttered.iterdir()) == ["notes.txt"]


@pytest.mark.slow  # a Dask local cluster started and stopped
def test_a_study_runs_on_one_local_cluster(tmp_path):
    study = RobustnessStudy("latency", (0, 3), {**FREE, "cases": 1, "duration": 5.0})
    summaries = run_study(study, tmp_path / "latency", workers=1, progress=False)
    assert [(v, s.ran, s.workers) for v, s in summaries] == [(0.0, 1, 1), (3.0, 1, 1)]
    assert len(read_study_rows(tmp_path / "latency")) == 2


def test_a_copied_undisturbed_campaign_is_adopted_not_rerun(study_dir, tmp_path):
    """The undisturbed campaign is the same in every study of a family: copied, it is resumed."""
    import shutil

    out = tmp_path / "latency"
    shutil.copytree(study_dir / "noise=0", out / "latency=0")
    campaign = {"family": "free-planar", "cases": 4, "controllers": ("ibvs-current", "pbvs"), "seed": 2}
    study = RobustnessStudy("latency", (0, 5), {**campaign, "duration": 20.0})
    (_, s0), (_, s5) = run_study(study, out, workers=0, progress=False)
    assert (s0.stored_before, s0.ran) == (8, 0) and (s5.stored_before, s5.ran) == (0, 8)
    rows = read_study_rows(out)
    assert len(rows) == 16 and rows[rows["axis_value"] == 0.0]["outcome"].eq("reached").all()


@pytest.mark.parametrize("axis", sorted(set(AXES) - {"images"}))
def test_the_reference_value_of_every_axis_is_the_undisturbed_campaign(axis):
    """Level 0 (saturation: inf) disturbs nothing: the same campaign, keys and rows in every study."""
    reference = AXES[axis].defaults[0]
    campaign = {"family": "arm-physical", "cases": 2, "controllers": ("fb",)}
    ((_, definition),) = RobustnessStudy(axis, (reference,), campaign).campaigns()
    assert "disturbances" not in definition.to_dict()
