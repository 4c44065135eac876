"""The progress bar: one line while Numba compiles the kernels the first time, and an estimate without it.

That a cold Numba cache prints the line and a warm one does not is checked on real compilations in
test_compiled_kernels.py (its run into an empty cache, then from that cache).
"""

from __future__ import annotations

import io
import time

from tqdm import tqdm

from ibvs_youla.simulation import progress
from ibvs_youla.simulation.progress import COMPILE_MESSAGE, CompileNotice


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
