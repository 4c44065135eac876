"""Scenarios: Table 1 numbers, ERRATA 13/14 facts, physical markers in view, validation errors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ibvs_youla import scenarios
from ibvs_youla.exceptions import (
    DegenerateMarkersError,
    InvalidArrayError,
    InvalidParameterError,
    JointLimitError,
)
from ibvs_youla.scenarios import Scenario


def _in_camera(arm, q, P_O):
    T_O_C = arm.camera_pose(q)
    return (P_O - T_O_C[:3, 3]) @ T_O_C[:3, :3]  # P_C = R^T (P_O - t), row-wise


def test_paper_scenarios_hold_table_1_and_the_errata():
    s1, s2 = scenarios.paper_scenarios()
    np.testing.assert_array_equal(np.degrees(s1.q_start), np.zeros(6))
    np.testing.assert_allclose(np.degrees(s1.q_target), [0.48, 2.21, 2.05, -82.68, 9.46, 77.47], atol=1e-12)
    np.testing.assert_allclose(np.degrees(s2.q_start), [42.40, 21.20, 4.58, -2.86, 66.46, -42.40], atol=1e-12)
    np.testing.assert_allclose(np.degrees(s2.q_target), [45, 18.59, 4.35, 0, 67.06, -45], atol=1e-12)
    for s in (s1, s2):
        np.testing.assert_array_equal(s.markers_O, [[-0.5, 0, 0], [0, 0, 0.5], [2, -2, 0]])
        assert s.virtual_points
    np.testing.assert_array_equal(s1.joint_offset, np.zeros(6))  # scenario 1: no disturbance
    np.testing.assert_allclose(s2.joint_offset, np.full(6, np.pi / 180), rtol=1e-15)  # ERRATA 14
    assert not s1.has_disturbance and s2.has_disturbance
    np.testing.assert_allclose(s2.q_encoder_goal, s2.q_target - np.pi / 180, rtol=1e-15)
    np.testing.assert_allclose(s2.q_true_start, s2.q_start + np.pi / 180, rtol=1e-15)
    assert (s1.name, s2.name) == ("paper-1", "paper-2")


def test_arrays_are_read_only_and_registry_returns_equal_fresh_objects():
    s = scenarios.get("paper-2")
    for name in ("q_start", "q_target", "markers_O", "joint_offset"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(s, name)[0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.name = "x"
    assert scenarios.get("paper-2") == s and scenarios.get("paper-1") != s
    assert scenarios.NAMES == ("paper-1", "paper-2", "physical-1", "physical-2")
    assert [scenarios.get(n).name for n in scenarios.NAMES] == list(scenarios.NAMES)
    with pytest.raises(InvalidParameterError, match="'paper-1' or 'paper-2'"):
        scenarios.get("paper-3")
    with pytest.raises(InvalidParameterError, match="1 or 2"):
        scenarios.paper(3)


def test_paper_markers_are_not_physically_visible(arm, camera):
    # ERRATA 13: behind the camera in scenario 1, outside the field of view in scenario 2
    s1, s2 = scenarios.paper_scenarios()
    vis1 = camera.visibility(_in_camera(arm, s1.q_start, s1.markers_O))
    assert not vis1.in_front.all() and np.min(vis1.depth) < 0.0
    vis2 = camera.visibility(_in_camera(arm, s2.q_true_start, s2.markers_O))
    assert not vis2.in_fov.all()


@pytest.mark.parametrize("index", [1, 2])
def test_physical_markers_are_placed_as_documented(arm, index):
    s = scenarios.physical(index)
    placed = scenarios.place_markers(
        arm.camera_pose(s.q_target), scenarios.MARKER_RAYS_XY, scenarios.MARKER_DEPTHS[index]
    )
    # stored rounded to 1 mm (<= 0.5 mm); 0.7625 m (physical-2, marker 3) sits on a rounding boundary
    np.testing.assert_allclose(s.markers_O, placed, rtol=0, atol=6e-4)
    assert not s.virtual_points and s.name == f"physical-{index}"
    np.testing.assert_array_equal(s.q_start, scenarios.paper(index).q_start)
    np.testing.assert_array_equal(s.joint_offset, scenarios.paper(index).joint_offset)


@pytest.mark.parametrize(("index", "min_depth", "max_fraction"), [(1, 1.95, 0.79), (2, 0.62, 0.68)])
def test_physical_markers_stay_in_view_along_the_joint_space_path(
    arm, camera, index, min_depth, max_fraction
):
    s = scenarios.physical(index)
    d = s.joint_offset
    depths, fractions = [], []
    # encoder path q_start -> q_target and the true paths shifted by d (ERRATA 14), both ends included
    for start, goal in (
        (s.q_start, s.q_target),
        (s.q_true_start, s.q_target),
        (s.q_true_start, s.q_target + d),
    ):
        for alpha in np.linspace(0.0, 1.0, 41):
            vis = camera.visibility(_in_camera(arm, start + alpha * (goal - start), s.markers_O))
            assert vis.all_visible, (index, alpha, vis.describe())
            depths.append(vis.depth.min())
            p = camera.project(_in_camera(arm, start + alpha * (goal - start), s.markers_O))
            half = np.array([camera.sensor_width, camera.sensor_width, camera.sensor_height]) / 2
            fractions.append(np.max(np.abs(p) / half))
    assert min(depths) > min_depth  # [m], well beyond the 0.5 m minimum depth
    assert max(fractions) < max_fraction  # of the half sensor extent: margin documented in scenarios.py


def test_validation_errors_say_what_was_received():
    q, m = np.zeros(6), scenarios.PAPER_MARKERS_O
    with pytest.raises(InvalidArrayError, match=r"q_start: received 5 joint\(s\); expected n >= 6 joints"):
        Scenario(np.zeros(5), q, m)
    with pytest.raises(
        InvalidArrayError, match=r"q_target: received an array of shape \(6,\); expected shape \(7,\)"
    ):
        Scenario(np.zeros(7), q, m)
    with pytest.raises(InvalidArrayError, match="q_target: received non-finite"):
        Scenario(q, np.full(6, np.nan), m)
    with pytest.raises(InvalidArrayError, match="markers_O"):
        Scenario(q, q, np.zeros((4, 2)))
    with pytest.raises(InvalidArrayError, match="markers_O: received 2 points"):
        Scenario(q, q, np.eye(3)[:2])
    with pytest.raises(InvalidArrayError, match="joint_offset"):
        Scenario(q, q, m, joint_offset=np.zeros(7))
    with pytest.raises(DegenerateMarkersError, match="collinear"):
        Scenario(q, q, [[0, 0, 0], [1, 1, 1], [2, 2, 2.0]])
    with pytest.raises(DegenerateMarkersError, match="coincide"):
        Scenario(q, q, np.ones((3, 3)))
    with pytest.raises(InvalidParameterError, match="virtual_points"):
        Scenario(q, q, m, virtual_points="yes")
    with pytest.raises(InvalidParameterError, match="depths"):
        scenarios.place_markers(np.eye(4), depths=(1.0, -1.0, 2.0))


def test_validate_for_checks_every_configuration_against_the_joint_limits(arm):
    for name in scenarios.NAMES:
        assert scenarios.get(name).validate_for(arm).name == name
    q_bad = np.array(scenarios.paper(2).q_target)
    q_bad[4] = arm.q_max[4] - np.radians(0.5)  # inside the limits, but q + d (1 deg) is not
    s = dataclasses.replace(scenarios.paper(2), q_start=q_bad)
    with pytest.raises(JointLimitError, match=r"q_start \+ joint_offset outside the joint limits \(joint 5"):
        s.validate_for(arm)
    q_far = np.zeros(6)
    q_far[1] = np.radians(170.0)  # joint 2 stops at 150 deg
    with pytest.raises(JointLimitError, match="q_target outside") as info:
        Scenario(np.zeros(6), q_far, scenarios.PAPER_MARKERS_O).validate_for(arm)
    assert "170.00" in str(info.value) and info.value.q[1] == q_far[1]
