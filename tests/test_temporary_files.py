"""The test session's temporary files stay under pytest's temporary folder (conftest.py), children's too."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path


def test_tempfile_jupyter_and_dask_scratch_point_under_pytest_s_basetemp(tmp_path_factory):
    base = tmp_path_factory.getbasetemp()
    assert Path(tempfile.gettempdir()).is_relative_to(base)
    for name in ("TMPDIR", "JUPYTER_RUNTIME_DIR", "DASK_TEMPORARY_DIRECTORY"):
        assert Path(os.environ[name]).is_relative_to(base), name
    import dask

    assert Path(dask.config.get("temporary-directory")).is_relative_to(base)
    code = "import tempfile; from jupyter_core.paths import jupyter_runtime_dir; "
    code += "print(tempfile.gettempdir()); print(jupyter_runtime_dir())"
    child = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60
    )
    assert all(Path(line).is_relative_to(base) for line in child.stdout.splitlines())
