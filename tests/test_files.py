"""files.py: atomic writes (whole or absent), temporaries, the one-writer lock and its stale-lock rule."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import numpy as np
import pytest

from ibvs_youla import files
from ibvs_youla.exceptions import FolderLockedError, InvalidParameterError
from ibvs_youla.simulation.results import SimulationResult


def test_atomic_write_replaces_the_file_whole_and_leaves_no_temporary(tmp_path):
    path = tmp_path / "table.md"
    path.write_text("old")
    assert files.write_text(path, "new ü") == path
    assert path.read_text(encoding="utf-8") == "new ü" and sorted(os.listdir(tmp_path)) == ["table.md"]


def test_a_writer_that_raises_leaves_the_previous_file_and_no_temporary(tmp_path):
    path = tmp_path / "run.bin"
    path.write_bytes(b"previous")

    class Boom(Exception):
        pass

    with pytest.raises(Boom), files.atomic_write(path) as stream:
        stream.write(b"half of the new")
        raise Boom
    assert path.read_bytes() == b"previous" and sorted(os.listdir(tmp_path)) == ["run.bin"]
    with pytest.raises(InvalidParameterError, match="mode: received 'a'"), files.atomic_write(path, "a"):
        pass


def test_temporaries_are_recognised_and_removed(tmp_path):
    kept = ["run.npz", ".lock", ".run.npz.tmp", ".part-1.parquet.damaged", ".x.0123.tmp"]
    for name in kept:
        (tmp_path / name).write_bytes(b"")
    left = [tmp_path / f".run.npz.{'ab' * 16}.tmp", tmp_path / f".table.md.{'0f' * 16}.tmp"]
    for path in left:
        path.write_bytes(b"half")
    assert all(files.is_temporary(p.name) for p in left) and not any(files.is_temporary(n) for n in kept)
    assert files.remove_temporaries(tmp_path) == sorted(left)
    assert sorted(os.listdir(tmp_path)) == sorted(kept)
    assert files.remove_temporaries(tmp_path / "absent") == []


def test_save_figure_writes_the_format_of_the_suffix(tmp_path):
    from matplotlib.figure import Figure

    fig = Figure()
    fig.add_subplot().plot([0, 1], [1, 0])
    assert files.save_figure(fig, tmp_path / "f.png", dpi=50).read_bytes()[:4] == b"\x89PNG"
    assert files.save_figure(fig, tmp_path / "f.svg").read_text().lstrip().startswith("<?xml")
    assert sorted(os.listdir(tmp_path)) == ["f.png", "f.svg"]


def test_a_held_lock_refuses_a_second_writer_with_the_holders_pid(tmp_path):
    with files.folder_lock(tmp_path) as lock:
        assert lock == tmp_path / ".lock" and lock.read_text() == f"{os.getpid()}\n"
        with pytest.raises(FolderLockedError) as info, files.folder_lock(tmp_path):
            pass
        assert info.value.pid == os.getpid() and info.value.folder == tmp_path
        assert f"{tmp_path}: another process (pid {os.getpid()}) is writing this folder" in str(info.value)
    assert lock.read_text() == ""  # released: the pid is cleared, the file stays
    with files.folder_lock(tmp_path):  # and taken again
        pass


HOLD = (
    "import sys, time; from ibvs_youla.files import folder_lock\n"
    "with folder_lock(sys.argv[1]):\n"
    "    print('held', flush=True); time.sleep(120)\n"
)


def test_the_lock_of_a_killed_holder_is_taken_over(tmp_path):
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(tmp_path)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "held\n"
        with pytest.raises(FolderLockedError, match=f"pid {holder.pid}"), files.folder_lock(tmp_path):
            pass
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait(timeout=30)
    assert (tmp_path / ".lock").read_text() == f"{holder.pid}\n"  # left behind by the dead holder
    with files.folder_lock(tmp_path) as lock:  # stale: the system released it with its holder
        assert lock.read_text() == f"{os.getpid()}\n"


def test_the_write_delay_hook_checks_its_value(tmp_path, monkeypatch):
    monkeypatch.setenv(files.WRITE_DELAY_ENV, "soon")
    with pytest.raises(InvalidParameterError, match="IBVS_YOULA_WRITE_DELAY_S: received 'soon'"):
        files.write_text(tmp_path / "a.txt", "x")
    assert os.listdir(tmp_path) == []
    monkeypatch.setenv(files.WRITE_DELAY_ENV, "-1")
    with pytest.raises(InvalidParameterError, match="a number of seconds >= 0"):
        files.write_text(tmp_path / "a.txt", "x")
    monkeypatch.setenv(files.WRITE_DELAY_ENV, "0.01")
    assert files.write_text(tmp_path / "a.txt", "x").read_text() == "x"


def _result(n: int = 4) -> SimulationResult:
    return SimulationResult(
        t=1e-3 * np.arange(n),
        camera_pose=np.tile(np.eye(4), (n, 1, 1)),
        camera_pose_target=np.eye(4),
        features=np.zeros((n, 9)),
        feature_target=np.zeros(9),
        visible=np.ones((n, 3), bool),
        signals={"q": np.zeros((n, 6))},
    )


def test_a_result_owns_read_only_copies_of_its_arrays(tmp_path):
    import pickle

    q = np.zeros((4, 6))
    features = np.zeros((4, 9))
    result = SimulationResult(**{**_result().__dict__, "signals": {"q": q}, "features": features})
    q[0, 0] = np.nan  # the caller's arrays change later: the result does not
    features[1, 2] = 5.0
    assert result.q[0, 0] == 0.0 and result.features[1, 2] == 0.0
    for name in ("t", "camera_pose", "camera_pose_target", "features", "feature_target", "visible"):
        assert not getattr(result, name).flags.writeable, name
    for name in ("frame_t", "frame_features", "frame_visible", "update_time", "q"):
        assert not getattr(result, name).flags.writeable, name
    with pytest.raises(ValueError, match="read-only"):
        result.t[0] = np.nan
    back = SimulationResult.load(result.save(tmp_path / "r.npz"))
    assert not back.q.flags.writeable and not back.t.flags.writeable
    np.testing.assert_array_equal(back.q, np.zeros((4, 6)))
    unpickled = pickle.loads(pickle.dumps(result))  # what a Dask worker returns
    assert not unpickled.q.flags.writeable and not unpickled.camera_pose.flags.writeable
