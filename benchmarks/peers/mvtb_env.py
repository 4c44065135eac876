"""A throwaway interpreter with the Machine Vision Toolbox for Python, never a dependency of the package.

``mvtb_python()`` returns the interpreter of a virtual environment that has
``machinevision-toolbox-python`` installed, creating it on first use:

    python3 -m venv /tmp/ibvs-youla-mvtb-venv
    /tmp/ibvs-youla-mvtb-venv/bin/pip install machinevision-toolbox-python

(the folder is ``$IBVS_YOULA_MVTB_VENV`` when set). A peer script passes the interpreter to
its worker processes; nothing of the toolbox is imported into this project's environment.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

__all__ = ["VENV", "mvtb_python"]

VENV = Path(os.environ.get("IBVS_YOULA_MVTB_VENV", Path(tempfile.gettempdir()) / "ibvs-youla-mvtb-venv"))


def _has_toolbox(python: Path) -> bool:
    done = subprocess.run(
        [str(python), "-c", "import machinevisiontoolbox"], capture_output=True, check=False
    )
    return done.returncode == 0


def mvtb_python(venv: Path = VENV) -> str:
    """The venv's interpreter, with the toolbox installed (created and installed when missing)."""
    python = venv / "bin" / "python"
    if python.exists() and _has_toolbox(python):
        return str(python)
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    subprocess.run([str(python), "-m", "pip", "install", "-q", "machinevision-toolbox-python"], check=True)
    return str(python)
