"""The hand-written package list in pyproject.toml must match the source tree."""

from __future__ import annotations

import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]


def test_every_subpackage_is_listed_in_pyproject():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    on_disk = {
        ".".join(p.parent.relative_to(ROOT / "src").parts) for p in (ROOT / "src").rglob("__init__.py")
    }
    on_disk.add("ibvs_youla.urdf")
    assert listed == on_disk


def test_ci_runs_the_readme_test_command():
    readme = (ROOT / "README.md").read_text()
    ci = (ROOT / ".ci" / "run").read_text()
    command = 'python3 -m venv .venv && .venv/bin/pip install -e ".[dev]" && .venv/bin/python -m pytest'
    assert command in readme
    assert command in ci


def test_urdf_resources_are_importable():
    import importlib.resources

    names = {p.name for p in importlib.resources.files("ibvs_youla.urdf").iterdir()}
    assert "__init__.py" in names


def test_lazy_api_names_match_all():
    import ibvs_youla

    lazy = set(ibvs_youla._LAZY) | ibvs_youla._SUBMODULES | set(ibvs_youla._ALIASES)
    assert lazy | {"IbvsYoulaError", "__version__", "exceptions"} == set(ibvs_youla.__all__)
