"""The README's Python snippets run, in order, in one namespace, as a reader would paste them."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_FENCE = re.compile(r"^```python[ \t]*\n(.*?)^```[ \t]*$", re.DOTALL | re.MULTILINE)


def python_blocks(markdown: str) -> list[str]:
    """Bodies of the fenced ```python blocks, in order (other languages are skipped)."""
    return [m.group(1) for m in _FENCE.finditer(markdown)]


def test_python_blocks_are_found_and_others_skipped():
    text = (
        "intro\n```bash\npip install x\n```\n"
        "```python\nx = 1\n```\n"
        "text ```python inline``` text\n"
        "```python\ny = x + 1\nprint(y)\n```\n"
        "```\nplain\n```\n"
    )
    assert python_blocks(text) == ["x = 1\n", "y = x + 1\nprint(y)\n"]
    assert python_blocks("no code here\n```bash\nls\n```\n") == []


def test_readme_python_snippets_run(tmp_path, monkeypatch):
    blocks = python_blocks((ROOT / "README.md").read_text(encoding="utf-8"))
    assert len(blocks) >= 1, "the README promises a runnable snippet on its first screen"
    monkeypatch.chdir(tmp_path)  # anything a snippet writes lands here
    monkeypatch.setenv("IBVS_YOULA_SMALL", "1")
    namespace: dict = {"__name__": "__readme__"}
    executed = 0
    out = io.StringIO()
    for i, block in enumerate(blocks):
        try:
            with contextlib.redirect_stdout(out):
                exec(compile(block, f"README.md python block {i + 1}", "exec"), namespace)
        except Exception as exc:  # name the block in the failure
            pytest.fail(f"README.md python block {i + 1} raised {type(exc).__name__}: {exc}\n{block}")
        executed += 1
    assert executed == len(blocks)
    # What the first-run snippet says it prints: the status, then an image error that has
    # come down from the start (paper-2 starts ~2e-3 m away; 2 s of the 100 Hz default run).
    lines = out.getvalue().splitlines()
    assert lines[0] == "complete"
    assert 1e-5 < float(lines[1]) < 1e-3
    assert "(3 tau s + 1)" in (ROOT / "README.md").read_text() and "0.03 s + 1" in out.getvalue()
    # The user-written controller of "One servo loop for every method": a constant twist on the
    # free-flying camera ends exactly on its target (0.25 m/s for 2 s along -z).
    assert "complete (201, 8)" in lines
    mm, deg = (float(v) for v in lines[lines.index("complete (201, 8)") + 1].strip("()").split(","))
    assert mm < 1e-9 and deg < 1e-9
    # The baselines on ViSP's tutorial-ibvs-4pts case: every method reaches the target.
    baselines = [
        line.split(" ", 2) for line in lines if line.split(" ")[0] in namespace["iy"].controllers.names()
    ]
    assert [b[0] for b in baselines] == [
        "ibvs-current",
        "ibvs-desired",
        "ibvs-mean",
        "pbvs",
        "2.5d",
        "hybrid",
        "mpc-ibvs",
    ]
    for name, status, errors in baselines:
        mm, deg = (float(v) for v in errors.strip("()").split(","))
        assert status == "complete" and mm < 3e-3 and deg < 1e-3, name
