"""The Meshcat view of an eye-to-hand task: the fixed camera's frustum, the markers moving with the tool.

As tests/test_viz.py: what is drawn is checked as numbers (where the camera and the markers' frame
are put), then in a screenshot of the page in Debian's headless Chromium (skipped without it,
except under CI): the markers drawn where the tool carries them, and moving with it.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

import ibvs_youla as iy
from headless_chromium import chromium, meshcat_pixels, screenshot
from ibvs_youla.model.eye_to_hand import EyeToHandArm
from ibvs_youla.simulation.results import SimulationResult
from ibvs_youla.viz import Viewer


@pytest.fixture(scope="module")
def arm():
    return iy.Arm.irb4600()


@pytest.fixture(scope="module")
def scenario(arm):
    return iy.scenarios.eye_to_hand(arm, seed=1)


@pytest.fixture(scope="module")
def viewer(arm):
    view = Viewer(arm)
    yield view
    view.close()


def _markers_O(arm, scenario, q):
    T_O_E = arm.flange_pose(q)  # the markers ride on the flange
    return scenario.markers_E @ T_O_E[:3, :3].T + T_O_E[:3, 3]


def test_the_camera_stands_still_and_the_markers_move_with_the_tool(viewer, arm, scenario):
    viewer.show_scenario(scenario)
    assert isinstance(viewer.arm, EyeToHandArm) and viewer.arm.mount == scenario.mount
    for q in (scenario.q_true_start, scenario.q_target):
        viewer.display(q)
        np.testing.assert_array_equal(viewer.camera_pose_O, scenario.mount.camera_pose)
        np.testing.assert_allclose(viewer.markers_frame_O, arm.flange_pose(q), rtol=0, atol=1e-12)
    moved = np.abs(
        _markers_O(arm, scenario, scenario.q_true_start) - _markers_O(arm, scenario, scenario.q_target)
    )
    assert moved.max() > 0.05  # [m]: the tool moves the markers between start and target
    viewer.show_scenario(iy.scenarios.physical(1))  # an eye-in-hand scenario: the arm's own camera again
    assert viewer.arm.mount.kind == "eye-in-hand"
    np.testing.assert_array_equal(viewer.markers_frame_O, np.eye(4))
    np.testing.assert_allclose(viewer.camera_pose_O, arm.camera_pose(viewer.q), atol=1e-15)


def test_play_mounts_the_arm_as_the_run_was(viewer, arm, scenario):
    result = iy.simulate(scenario, "ibvs-current", plant="kinematic", duration=0.2)
    assert result.metadata["mount"] == scenario.mount.to_dict()
    drawn = viewer.play(result, speed=4.0, fps=30.0)
    assert drawn >= 1 and viewer.arm.mount == scenario.mount
    np.testing.assert_array_equal(viewer.q, result.q_true[-1])
    np.testing.assert_allclose(viewer.markers_frame_O, arm.flange_pose(result.q_true[-1]), atol=1e-12)
    bare = SimulationResult(**{**result.__dict__, "metadata": {}})  # no mount recorded: eye-in-hand
    viewer.play(bare, speed=100.0)
    assert viewer.arm.mount.kind == "eye-in-hand"


def test_a_screenshot_shows_the_markers_where_the_tool_carries_them(viewer, arm, scenario, tmp_path):
    if chromium() is None:
        if os.environ.get("CI"):  # .ci/run sets CI=true and installs chromium: its absence is a failure there
            pytest.fail("CI is set but Debian's chromium is not installed: .ci/run should have installed it")
        pytest.skip("Debian's chromium is not installed (.ci/run installs it)")
    eye = np.array([4.0, -1.5, 2.2])  # [m]: before the arm, beside the fixed camera
    viewer.show_scenario(scenario)
    viewer.set_visible("rays", False)
    viewer.set_visible("target", False)
    viewer.set_view(eye)
    images = {}
    for label, q in (("start", scenario.q_true_start), ("target", scenario.q_target)):
        viewer.display(q)
        images[label] = screenshot(viewer.url, tmp_path / f"{label}.png")
    viewer.set_visible("markers", False)
    try:
        hidden = screenshot(viewer.url, tmp_path / "hidden.png")
    finally:
        for part in ("markers", "rays", "target"):
            viewer.set_visible(part, True)
    for label, q in (("start", scenario.q_true_start), ("target", scenario.q_target)):
        differs = np.abs(images[label] - hidden).sum(axis=2) > 0.1  # [RGB in 0..1]
        for col, row in np.round(meshcat_pixels(_markers_O(arm, scenario, q), eye)).astype(int):
            assert 0 <= col < 800 and 0 <= row < 600
            assert differs[row - 1 : row + 2, col - 1 : col + 2].mean() >= 5 / 9, (label, col, row)
    assert np.abs(images["start"] - images["target"]).sum(axis=2).max() > 0.1  # the tool moved
