"""`ibvs-youla reproduce` killed with SIGKILL, and two of them on one folder: no damaged file, no lost work.

The job of these tests: paper-2, 0.05 s per run and 0.08 s of diagnosis (8 run files) and the table
(2 files), without the figures (``--no-plots``: they go through the same atomic writes, and drawing
them was most of each process's time); its table from this process, uninterrupted, is the reference.
``IBVS_YOULA_WRITE_DELAY_S`` (ibvs_youla.files) makes every write pause between the temporary
file and its rename, so that a kill can land in the middle of writing a file. Kill points are
drawn from a seeded generator: after how many new files, and whether during a write.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ibvs_youla.analysis.reproduce import reproduce
from ibvs_youla.files import WRITE_DELAY_ENV, is_temporary
from ibvs_youla.simulation.results import SimulationResult

pytestmark = pytest.mark.slow

ARGS = ["--scenarios", "paper-2", "--duration", "0.05", "--diagnosis-duration", "0.08"]
PYTHON_CLI = "import sys; from ibvs_youla.cli import main; sys.exit(main(sys.argv[1:]))"
REDO = "simulating this run again"


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The table of the uninterrupted job, run in this process (figures do not change it)."""
    out = tmp_path_factory.mktemp("reference")
    reproduce(out, scenario_names=("paper-2",), duration=0.05, diagnosis_duration=0.08, plots=False)
    return (out / "table.md").read_text(), json.loads((out / "table.json").read_text())


def _start(processes, out: Path, delay: float | None = None, *extra: str) -> subprocess.Popen:
    env = {k: v for k, v in os.environ.items() if k != WRITE_DELAY_ENV}
    if delay is not None:
        env[WRITE_DELAY_ENV] = str(delay)
    command = [sys.executable, "-c", PYTHON_CLI, "reproduce", *ARGS, "--out", str(out), *extra]
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    processes.append(proc)
    return proc


def _files(out: Path) -> tuple[set[Path], set[Path]]:
    """(finished files, temporaries) under ``out``."""
    found = [p for p in out.rglob("*") if p.is_file() and p.name != ".lock"] if out.exists() else []
    return {p for p in found if not is_temporary(p.name)}, {p for p in found if is_temporary(p.name)}


def _wait_for(condition, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.005)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")


def _holder(out: Path) -> str:
    lock = out / ".lock"
    return lock.read_text().strip() if lock.exists() else ""


def _assert_whole(out: Path) -> dict[Path, int]:
    """Every finished run file loads and every table parses; return the run files' mtimes."""
    runs = sorted((out / "runs").glob("*.npz")) if (out / "runs").exists() else []
    for path in runs:
        SimulationResult.load(path)
    if (out / "table.json").exists():
        json.loads((out / "table.json").read_text())
    return {p: p.stat().st_mtime_ns for p in runs}


def _same_table(out: Path, reference) -> None:
    md, table = reference
    assert (out / "table.md").read_text() == md
    ours = json.loads((out / "table.json").read_text())

    def timeless(rows):
        return [{k: v for k, v in r.items() if k != "update_time_median_us"} for r in rows]

    assert timeless(ours["rows"]) == timeless(table["rows"]) and ours["findings"] == table["findings"]
    assert len(list((out / "runs").glob("*.npz"))) == 8 and not _files(out)[1]


def test_killed_at_seeded_points_then_rerun_gives_the_same_table_and_redoes_no_finished_run(
    tmp_path, reference, processes
):
    rng = np.random.default_rng(13)
    # three kills, each after 0-2 new files (of the 10 the job writes), the first inside a write
    plan = [(int(rng.integers(0, 3)), mid) for mid in (True, *(bool(b) for b in rng.random(2) < 0.5))]
    out = tmp_path / "out"
    finished: dict[Path, int] = {}
    killed_mid_write = 0
    for new_files, mid_write in plan:
        before, _ = _files(out)
        proc = _start(processes, out, 0.3, "--no-plots")

        def due(before=before, new_files=new_files, mid_write=mid_write, proc=proc):
            done, temporaries = _files(out)
            reached = len(done - before) >= new_files and (bool(temporaries) or not mid_write)
            return proc.poll() is not None or reached

        _wait_for(due, 300, f"{new_files} new files")
        in_write = bool(_files(out)[1])
        proc.send_signal(signal.SIGKILL)
        proc.communicate(timeout=30)
        if proc.returncode != -signal.SIGKILL:  # finished before its kill point (not expected)
            continue
        killed_mid_write += in_write and bool(_files(out)[1])  # a temporary left: killed inside a write
        whole = _assert_whole(out)  # no final file is damaged, whenever the kill came
        for path, mtime in finished.items():
            assert whole[path] == mtime, f"{path} was rewritten"
        finished = whole
    assert killed_mid_write >= 1 and 0 < len(finished) < 8  # killed inside a write; some runs done, not all
    assert not (out / "table.md").exists()
    last = _start(processes, out, None, "--no-plots")
    _, err = last.communicate(timeout=300)
    assert last.returncode == 0, err
    assert REDO not in err  # nothing the killed jobs left was damaged
    for path, mtime in finished.items():
        assert path.stat().st_mtime_ns == mtime, f"{path}: a finished run was recomputed"
    _same_table(out, reference)


def test_a_second_process_is_refused_while_the_first_writes_and_the_killed_first_is_resumed(
    tmp_path, reference, processes
):
    out = tmp_path / "out"
    first = _start(processes, out, 120, "--no-plots")  # stays inside its first write
    _wait_for(lambda: _holder(out) == str(first.pid) and _files(out)[1], 300, "the first write")
    second = _start(processes, out, None, "--no-plots")
    _, err = second.communicate(timeout=300)
    lines = [line for line in err.splitlines() if line.strip()]
    assert second.returncode == 1 and len(lines) == 1, err
    assert lines[0] == (
        f"ibvs-youla: error: {out}: another process (pid {first.pid}) is writing this folder "
        f"(it holds {out / '.lock'}); wait for it to finish, or choose another output folder"
    )
    first.send_signal(signal.SIGKILL)
    first.communicate(timeout=30)
    done, temporaries = _files(out)
    assert not done and len(temporaries) == 1  # killed inside its first write: half a file, hidden
    third = _start(processes, out, None, "--no-plots")  # the dead holder's lock is free
    _, err = third.communicate(timeout=300)
    assert third.returncode == 0 and REDO not in err, err
    _same_table(out, reference)


def test_two_processes_started_together_leave_a_correct_folder(tmp_path, reference, processes):
    out = tmp_path / "out"
    both = [_start(processes, out, 0.1, "--no-plots") for _ in range(2)]
    results = [(proc.communicate(timeout=300)[1], proc.returncode) for proc in both]
    assert 0 in [code for _, code in results]
    for err, code in results:
        if code != 0:  # refused: one line, exit 1, nothing written by it
            lines = [line for line in err.splitlines() if line.strip()]
            assert code == 1 and len(lines) == 1 and "is writing this folder" in lines[0], err
        else:
            assert REDO not in err
    _assert_whole(out)
    _same_table(out, reference)
