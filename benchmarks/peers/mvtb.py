"""The Machine Vision Toolbox for Python (MVTB) in a throwaway virtual environment, for peer benchmarks.

:func:`python` returns the interpreter of a virtual environment where
``machinevision-toolbox-python`` is installed, creating it (``python3 -m venv`` and ``pip install``,
a few minutes) when it is absent; it is never a dependency of this project. :func:`run` runs a
worker script (a file under ``benchmarks/peers/``, e.g. ``mvtb_ibvs_4pts.py``) in it with a JSON
set-up on standard input and returns the JSON object it prints.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
DEFAULT_VENV = Path("/tmp/mvtb-venv")
PACKAGE = "machinevision-toolbox-python"


def python(venv: Path = DEFAULT_VENV, create: bool = True) -> Path:
    """The venv's interpreter with the toolbox importable; made if absent and ``create``.

    Raises:
        RuntimeError: the toolbox is not there (and not ``create``), or installing it failed.
    """
    exe = venv / "bin" / "python"
    probe = [str(exe), "-c", "import machinevisiontoolbox, spatialmath"]
    if exe.exists() and subprocess.run(probe, capture_output=True).returncode == 0:
        return exe
    if not create:
        raise RuntimeError(f"no {PACKAGE} in {venv}: run without --no-install, or install it there")
    print(f"creating {venv} with {PACKAGE} (a few minutes) ...", file=sys.stderr, flush=True)
    if not exe.exists():
        subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    done = subprocess.run([str(exe), "-m", "pip", "install", "-q", PACKAGE], capture_output=True, text=True)
    if done.returncode != 0 or subprocess.run(probe, capture_output=True).returncode != 0:
        raise RuntimeError(f"installing {PACKAGE} in {venv} failed: {done.stderr[-2000:]}")
    return exe


def run(exe: Path, script: str, setup: dict[str, Any], timeout: float = 1200.0) -> dict[str, Any]:
    """Run ``script`` (under peers/) with ``exe``, ``setup`` as JSON on stdin; return its JSON output.

    Raises:
        RuntimeError: the worker failed or printed no JSON (its error output in the message).
    """
    done = subprocess.run(
        [str(exe), str(HERE / script)],
        input=json.dumps(setup),
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode != 0 or not lines:
        raise RuntimeError(f"{script} failed (exit {done.returncode}): {done.stderr[-3000:]}")
    return json.loads(lines[-1])  # type: ignore[no-any-return]
