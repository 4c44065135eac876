"""Shared test configuration: hypothesis runs derandomized (every run draws the same examples), and every
temporary file of the session stays under pytest's temporary folder."""

from __future__ import annotations

import os
import subprocess
import tempfile

import pytest
from hypothesis import settings

from ibvs_youla.model.arm import Arm
from ibvs_youla.model.camera import StereoCamera

# derandomize=True: examples come from a fixed seed (project rule: seeded randomness), so a failure
# reproduces on every run and CI and local runs test the same inputs. deadline=None: the machine is
# shared, and timing is not what these property tests check.
settings.register_profile("ibvs-youla", derandomize=True, deadline=None)
settings.load_profile("ibvs-youla")


@pytest.fixture(scope="session", autouse=True)
def scratch_inside_pytest_tmp(tmp_path_factory):
    """Every temporary file of the session, this process's and its children's, under pytest's basetemp.

    Python's ``tempfile`` (here and, through TMPDIR, in every subprocess: CLI runs, Dask workers,
    Jupyter kernels, whose notebooks make their folders with ``mkdtemp``), Jupyter's connection
    files (JUPYTER_RUNTIME_DIR) and Dask's worker scratch space (its ``temporary-directory``) go to
    one folder of the session, which pytest keeps or removes with its others.
    """
    scratch = tmp_path_factory.mktemp("scratch")
    names = ("TMPDIR", "JUPYTER_RUNTIME_DIR", "DASK_TEMPORARY_DIRECTORY")
    saved = {name: os.environ.get(name) for name in names}
    os.environ.update({name: str(scratch) for name in names})
    saved_tempdir, tempfile.tempdir = tempfile.tempdir, str(scratch)
    import dask

    with dask.config.set({"temporary-directory": str(scratch)}):
        yield scratch
    tempfile.tempdir = saved_tempdir
    for name, value in saved.items():
        if value is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = value


@pytest.fixture(scope="module")
def arm():
    """The IRB 4600 of the URDF, paper actuator mapping (a test file may override it)."""
    return Arm.irb4600()


@pytest.fixture(scope="module")
def arm_four_markers(arm):
    """physical-2 with four markers in view of the target camera (a pinhole camera needs four): the
    compiled frame paths' arm case with a ZED 2 lens (tests/test_compiled_*.py)."""
    import dataclasses

    import numpy as np

    from ibvs_youla.scenarios import physical, place_markers

    scenario = physical(2)
    rays = np.array([[-0.15, -0.1], [0.15, -0.1], [0.12, 0.12], [-0.1, 0.1]])
    markers = place_markers(arm.camera_pose(scenario.q_target), rays, (2.0, 2.4, 2.8, 2.2))
    return dataclasses.replace(scenario, markers_O=markers)


@pytest.fixture(scope="module")
def camera():
    """The paper's ZED 2 preset: 86.09 x 55.35 deg, 0.5-25 m (a test file may override it)."""
    return StereoCamera.zed2()


@pytest.fixture
def processes():
    """Subprocesses started by a test; every one still alive is killed (by its id) at teardown.

    ``communicate`` rather than ``wait``: a process whose pipes nobody reads could block on them.
    """
    started: list[subprocess.Popen] = []
    yield started
    for proc in started:
        if proc.poll() is None:
            proc.kill()
        proc.communicate(timeout=30)
