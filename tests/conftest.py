"""Shared test configuration: hypothesis runs derandomized, so every run draws the same examples."""

from __future__ import annotations

import subprocess

import pytest
from hypothesis import settings

from ibvs_youla.model.arm import Arm
from ibvs_youla.model.camera import StereoCamera

# derandomize=True: examples come from a fixed seed (project rule: seeded randomness), so a failure
# reproduces on every run and CI and local runs test the same inputs. deadline=None: the machine is
# shared, and timing is not what these property tests check.
settings.register_profile("ibvs-youla", derandomize=True, deadline=None)
settings.load_profile("ibvs-youla")


@pytest.fixture(scope="module")
def arm():
    """The IRB 4600 of the URDF, paper actuator mapping (a test file may override it)."""
    return Arm.irb4600()


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
