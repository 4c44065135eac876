"""reproduce resumes from whole, matching run files only: damaged or foreign files are redone and named.

Cheap: paper-2, 0.05 s per run (50 joint periods at the paper's 1 kHz), no diagnosis runs, no
figures (tests/test_reproduce.py draws them).
"""

from __future__ import annotations

import json
import logging
import shutil

import pytest

from ibvs_youla.analysis.reproduce import reproduce, run_key
from ibvs_youla.exceptions import FolderLockedError, InvalidParameterError
from ibvs_youla.files import folder_lock
from ibvs_youla.simulation.results import SimulationResult

ARGS = {"scenario_names": ("paper-2",), "duration": 0.05, "diagnosis_duration": 0.0, "plots": False}
KEYS = [run_key("paper-2", c, a) for a in (False, True) for c in ("fb", "ff+fb")]
LOGGER = "ibvs_youla.analysis.reproduce"


def _mtimes(out):
    return {key: (out / "runs" / f"{key}.npz").stat().st_mtime_ns for key in KEYS}


def _notes(caplog):
    return [r.getMessage() for r in caplog.records if r.name == LOGGER]


def _without_timing(rows):
    return [{k: v for k, v in r.items() if k != "update_time_median_us"} for r in rows]


@pytest.fixture(scope="module")
def done(tmp_path_factory):
    out = tmp_path_factory.mktemp("resume") / "out"
    rep = reproduce(out, **ARGS)
    return out, rep


def test_a_damaged_and_a_foreign_run_file_are_redone_alone_and_named(done, tmp_path, caplog):
    source, rep = done
    out = tmp_path / "out"
    shutil.copytree(source, out)
    damaged, foreign = (out / "runs" / f"{KEYS[0]}.npz", out / "runs" / f"{KEYS[3]}.npz")
    damaged.write_bytes(damaged.read_bytes()[:1000])  # a truncated archive
    shutil.copy(out / "runs" / f"{KEYS[1]}.npz", foreign)  # whole, but another run (ff+fb, fixed)
    before = _mtimes(out)
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        again = reproduce(out, **ARGS)
    assert _notes(caplog) == [
        f"ibvs-youla: {damaged}: not a whole zip archive (truncated?) (File is not a zip file); "
        "simulating this run again",
        f"ibvs-youla: {foreign} holds another run (different adaptive); simulating this run again",
    ]
    after = _mtimes(out)
    assert [k for k in KEYS if after[k] != before[k]] == [KEYS[0], KEYS[3]]  # only those two were redone
    assert _without_timing(again.rows) == _without_timing(rep.rows)
    assert (out / "table.md").read_text() == (source / "table.md").read_text()
    for key in KEYS:
        SimulationResult.load(out / "runs" / f"{key}.npz")  # every run file is whole again


def test_a_resumed_job_recomputes_nothing_and_other_settings_redo_everything(done, tmp_path, caplog):
    source, rep = done
    out = tmp_path / "out"
    shutil.copytree(source, out)
    before = _mtimes(out)
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        again = reproduce(out, **ARGS)
    assert _notes(caplog) == [] and _mtimes(out) == before
    assert [r["outcome"] for r in again.rows] == [r["outcome"] for r in rep.rows]
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        reproduce(out, **{**ARGS, "duration": 0.06})
    assert len(_notes(caplog)) == 4 and all("(different joint periods)" in n for n in _notes(caplog))


def test_a_duration_that_is_not_whole_joint_periods_is_rounded_recorded_and_resumes(tmp_path, caplog):
    out = tmp_path / "out"
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        rep = reproduce(out, **{**ARGS, "duration": 0.0505})
    assert _notes(caplog) == [
        "ibvs-youla: duration = 0.0505 s is not a whole number of joint periods (0.001 s): "
        "running 0.05 s (50 periods)"
    ]
    assert [r["duration_s"] for r in rep.rows] == [50 * 0.001] * 4
    table = json.loads((out / "table.json").read_text())
    assert table["duration_s"] == {"requested": 0.0505, "run": 50 * 0.001}
    assert "| outcome at 0.05 s |" in (out / "table.md").read_text()
    for key in KEYS:
        assert SimulationResult.load(out / "runs" / f"{key}.npz").metadata["duration"] == 50 * 0.001
    before = _mtimes(out)
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        reproduce(out, **{**ARGS, "duration": 0.0505})  # the same request resumes ...
        reproduce(out, **ARGS)  # ... and so does 0.05 s: the same 50 periods
    assert _mtimes(out) == before and not any("simulating" in n for n in _notes(caplog))


def test_durations_under_one_joint_period_and_a_busy_folder_are_refused(tmp_path):
    with pytest.raises(InvalidParameterError, match=r"^duration: received 0\.0004; valid values are at"):
        reproduce(tmp_path / "a", **{**ARGS, "duration": 0.0004})
    with pytest.raises(InvalidParameterError, match=r"diagnosis_duration: received 0\.0001"):
        reproduce(tmp_path / "a", **{**ARGS, "diagnosis_duration": 1e-4})
    with pytest.raises(InvalidParameterError, match="diagnosis_duration: received -1"):
        reproduce(tmp_path / "a", **{**ARGS, "diagnosis_duration": -1.0})
    assert not (tmp_path / "a").exists()  # refused before anything was written
    (tmp_path / "a").mkdir()
    with folder_lock(tmp_path / "a"), pytest.raises(FolderLockedError, match="is writing this folder"):
        reproduce(tmp_path / "a", **ARGS)
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == [".lock"]  # nothing written


def test_temporaries_of_a_killed_job_are_removed_under_the_lock(done, tmp_path):
    source, _ = done
    out = tmp_path / "out"
    shutil.copytree(source, out)
    left = [out / "runs" / f".{KEYS[0]}.npz.{'a' * 32}.tmp", out / f".table.md.{'b' * 32}.tmp"]
    for path in left:
        path.write_bytes(b"half a file")
    reproduce(out, **ARGS)
    assert not any(p.exists() for p in left)


def test_a_whole_result_whose_metadata_lacks_the_run_keys_is_foreign(done, tmp_path, caplog):
    import numpy as np

    source, rep = done
    out = tmp_path / "out"
    shutil.copytree(source, out)
    path = out / "runs" / f"{KEYS[2]}.npz"
    SimulationResult(
        t=[0.0],
        camera_pose=[np.eye(4)],
        camera_pose_target=np.eye(4),
        features=np.zeros((1, 9)),
        feature_target=np.zeros(9),
        visible=np.ones((1, 3), bool),
        metadata={"scenario": "paper-2"},
    ).save(path)
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        again = reproduce(out, **ARGS)
    assert _notes(caplog) == [
        f"ibvs-youla: {path} holds another run (different controller, adaptive, plant, virtual_points, "
        "joint periods, settings); simulating this run again"
    ]
    assert _without_timing(again.rows) == _without_timing(rep.rows)
