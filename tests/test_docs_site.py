"""The documentation site builds with warnings as errors, and every page and notebook is in it."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
MKDOCS = Path(sys.executable).with_name("mkdocs")


def _nav_paths(node: object) -> list[str]:
    """Every page path of a mkdocs ``nav`` (nested lists of strings and one-key mappings)."""
    if isinstance(node, str):
        return [node]
    if isinstance(node, list):
        return [p for child in node for p in _nav_paths(child)]
    if isinstance(node, dict):
        return [p for child in node.values() for p in _nav_paths(child)]
    return []


def _config() -> dict:
    return yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))


def test_the_config_is_strict_and_links_are_checked():
    config = _config()
    assert config["strict"] is True and config["docs_dir"] == "docs"
    assert {key: config["validation"][key] for key in ("omitted_files", "unrecognized_links", "anchors")} == {
        "omitted_files": "warn",
        "unrecognized_links": "warn",
        "anchors": "warn",
    }
    plugins = [p for p in config["plugins"] if isinstance(p, dict)]
    jupyter = next(p["mkdocs-jupyter"] for p in plugins if "mkdocs-jupyter" in p)
    assert jupyter["execute"] is False  # rendered as saved: the test suite executes them instead


def test_every_page_and_notebook_is_in_the_nav():
    nav = set(_nav_paths(_config()["nav"]))
    pages = {p.relative_to(ROOT / "docs").as_posix() for p in (ROOT / "docs").rglob("*.md")}
    notebooks = {f"notebooks/{p.name}" for p in (ROOT / "notebooks").glob("*.ipynb")}
    assert len(notebooks) == 7  # 01-07
    assert pages | notebooks <= nav
    assert all((ROOT / "docs" / p).is_file() for p in nav)


@pytest.mark.slow  # the whole site: the API reference and the seven notebooks rendered
def test_mkdocs_build_strict_passes(tmp_path):
    """The build .ci/run runs: a broken link, a page outside the nav or a docstring reference that
    does not resolve is a warning, and --strict makes it fail. Measured about 15 s on a quiet core."""
    if not MKDOCS.exists():
        pytest.fail(f"{MKDOCS} not found: install the docs extra, pip install -e '.[docs]'")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    start = time.monotonic()
    proc = subprocess.run(
        [str(MKDOCS), "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert "WARNING" not in proc.stderr
    site = tmp_path / "site"
    assert (site / "index.html").is_file()
    assert (site / "errata" / "index.html").is_file()
    for notebook in (ROOT / "notebooks").glob("*.ipynb"):
        assert (site / "notebooks" / notebook.stem / "index.html").is_file(), notebook.name
    api = (site / "api" / "simulation" / "index.html").read_text(encoding="utf-8")
    assert 'id="ibvs_youla.simulation.simulate.simulate"' in api  # rendered from the docstring
    print(f"mkdocs build --strict: {time.monotonic() - start:.1f} s")
