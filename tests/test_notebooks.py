"""Every notebook in notebooks/ runs top to bottom (small-size switch on) and is stored with its outputs.

The saved outputs are those of a full-size run (the command in docs/notebooks.md), which the
documentation site renders as they are: every code cell executed once, in order, without an error.

The kernel is this interpreter (``sys.executable``), started from a kernel spec written to a
temporary folder, so the notebooks see the package under test whatever kernels are installed.
``IBVS_YOULA_SMALL=1`` makes each notebook shorten its simulations.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import nbformat
import pytest
from jupyter_client.kernelspec import KernelSpecManager
from jupyter_client.manager import KernelManager
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
TIMEOUT_S = 300  # per cell; the small-size switch keeps a whole notebook well under a minute here
KERNEL = "ibvs-youla-test"


def test_the_notebooks_are_there():
    names = [p.name for p in NOTEBOOKS]
    assert {"01_reproduce_paper.ipynb", "02_controller_design.ipynb", "04_baselines.ipynb"} <= set(names)


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_is_stored_executed_with_its_outputs(path):
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code, "a notebook without code cells runs nothing"
    assert [c.execution_count for c in code] == list(range(1, len(code) + 1))  # one run, top to bottom
    assert any(c.outputs for c in code)
    outputs = [o for c in code for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    assert "small switch on" not in str(outputs)  # saved from a full-size run (01 prints the switch)
    assert path.stat().st_size < 2_000_000  # [bytes] figures at 80-90 dpi


@pytest.fixture(scope="module")
def kernel_manager_factory(tmp_path_factory):
    spec_dir = tmp_path_factory.mktemp("kernels") / KERNEL
    spec_dir.mkdir()
    spec = {
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "ibvs-youla tests",
        "language": "python",
    }
    (spec_dir / "kernel.json").write_text(json.dumps(spec))
    specs = KernelSpecManager(kernel_dirs=[str(spec_dir.parent)])
    assert specs.get_kernel_spec(KERNEL).argv[0] == sys.executable

    def make() -> KernelManager:
        return KernelManager(kernel_name=KERNEL, kernel_spec_manager=specs)

    return make


@pytest.mark.slow  # 20-90 s each: a kernel, and the notebook's small runs and figures
@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_runs(path, tmp_path, monkeypatch, kernel_manager_factory):
    monkeypatch.setenv("IBVS_YOULA_SMALL", "1")
    nb = nbformat.read(path, as_version=4)
    client = NotebookClient(
        nb,
        km=kernel_manager_factory(),
        timeout=TIMEOUT_S,
        resources={"metadata": {"path": str(tmp_path)}},  # notebooks write nothing next to themselves
    )
    start = time.perf_counter()
    client.execute()
    elapsed = time.perf_counter() - start
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert errors == []
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert [c.execution_count for c in code] == list(range(1, len(code) + 1))
    print(f"{path.name}: {elapsed:.1f} s")  # shown with pytest -s; not asserted (wall clock)
