"""The progress bar: one line while Numba compiles the kernels the first time, and an estimate without it."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import time

import pytest
from tqdm import tqdm

from ibvs_youla.simulation import progress
from ibvs_youla.simulation.progress import COMPILE_MESSAGE, CompileNotice

RUN = (
    "simulate",
    "--scenario",
    "physical-2",
    "--plant",
    "free-camera",
    "--controller",
    "ibvs-desired",
    "--duration",
    "0.05",
    "--no-plots",
)


def test_the_message_goes_out_once_and_the_bar_restarts_after_each_compilation(monkeypatch):
    monkeypatch.setattr(progress, "_announced", False)
    lines = []
    stream = io.StringIO()
    with CompileNotice(write=lines.append) as notice:
        bar = progress.progress_bar(100, "run")
        bar.fp = stream  # off the terminal
        bar.update(10)
        notice.on_start()
        notice.on_start()  # a kernel compiling one it calls: one compilation
        time.sleep(0.3)  # what the compiler takes
        notice.on_end()
        notice.on_end()
        assert bar.format_dict["elapsed"] < 0.25  # the bar's clock excludes the compilation
        notice.on_start()
        notice.on_end()
        bar.close()
    assert lines == [COMPILE_MESSAGE] and notice.compiles == 2
    with CompileNotice(write=lines.append) as later:  # the next run of the process: no message
        later.on_start()
        later.on_end()
    assert lines == [COMPILE_MESSAGE]


def test_a_bar_without_a_compilation_keeps_its_clock():
    stream = io.StringIO()
    with CompileNotice(write=lambda text: None):
        bar = tqdm(total=10, file=stream)
        time.sleep(0.1)
        assert bar.format_dict["elapsed"] >= 0.1
        bar.close()


@pytest.mark.slow
def test_a_cold_numba_cache_says_it_compiles_and_a_warm_one_does_not(tmp_path):
    """Numba's own cache decides: a fresh NUMBA_CACHE_DIR compiles (the line), the same one again loads."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    code = "import sys; from ibvs_youla.cli import main; sys.exit(main(sys.argv[1:]))"
    seen = []
    for k in range(2):
        done = subprocess.run(
            [sys.executable, "-c", code, *RUN, "--out", str(tmp_path / f"run{k}")],
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert done.returncode == 0, done.stderr
        seen.append(done.stderr.count(COMPILE_MESSAGE))
    assert seen == [1, 0]
    assert any((tmp_path / "numba").rglob("*.nbi"))  # Numba's cache index, written by the first run
