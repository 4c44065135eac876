"""Hybrid switched IBVS/PBVS (Gans & Hutchinson 2007) on the textbook cases, against its two laws.

Monocular, normalized coordinates, four coplanar points, 25 Hz on the free camera, as the
classical-IBVS tests (tests/test_ibvs.py reuses the same cases).
"""

from __future__ import annotations

import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla import controllers
from ibvs_youla.controllers.hybrid import HybridSwitched
from ibvs_youla.exceptions import InvalidParameterError
from test_ibvs import SETTINGS, SQUARE_O, T_O_C, TILT_START, TILT_TARGET


def run(start, target, name, duration=30.0, loop="auto", **params):
    scenario = iy.Scenario.free_camera(start, target, SQUARE_O)
    return iy.simulate(
        scenario,
        controllers.make(name, **params),
        plant="free-camera",
        camera=iy.PinholeCamera.normalized(),
        duration=duration,
        settings=SETTINGS,
        loop=loop,
    )


def test_a_rotation_of_pi_switches_to_pbvs_and_converges():
    """IBVS retreats along the optical axis (V_p grows at once); the hybrid law leaves it at the
    4th frame (after the 5-frame dwell: 0.16 s) and PBVS turns the camera to the goal."""
    start, target = T_O_C([0, 0, 0.75], [0, 0, 180]), T_O_C([0, 0, 0.75], [0, 0, 0])
    ibvs = run(start, target, "ibvs-current")
    assert ibvs.status == "estimate_failed"  # retreated until the PnP lost the tiny square
    hybrid = run(start, target, "hybrid")
    assert hybrid.status == "complete"
    switches, mode = hybrid.hybrid_switches[:, 0], hybrid.hybrid_mode[:, 0]
    assert switches[-1] == 1 and mode[-1] == 1.0
    assert hybrid.t[np.argmax(switches > 0)] == pytest.approx(0.16, abs=1e-12)
    mm, deg = hybrid.final_pose_error()
    assert mm < 1e-3 and deg < 1e-3
    # before the switch the camera moved back along its axis, away from the points, as IBVS does
    away = np.linalg.norm(hybrid.camera_pose[4, :3, 3]) - np.linalg.norm(start[:3, 3])  # [m]
    assert away > 0.1 and np.abs(hybrid.camera_pose[4, :2, 3]).max() < 1e-9


def test_the_local_minimum_of_ibvs_traps_the_hybrid_law_too():
    """A finding: with bounds at the initial values, V_p never rises above V_p(0) on the way
    into classical IBVS's local minimum (tests/test_ibvs.py), so the hybrid law never switches
    and stops 1034.658 mm / 83.752 deg from the target, where PBVS and 2.5-D reach it."""
    hybrid = run(TILT_START, TILT_TARGET, "hybrid")
    assert hybrid.hybrid_switches[-1, 0] == 0
    assert hybrid.final_pose_error() == pytest.approx((1034.65802, 83.752113), rel=1e-6)
    for name in ("pbvs", "2.5d"):
        mm, deg = run(TILT_START, TILT_TARGET, name).final_pose_error()
        assert mm < 1e-3 and deg < 1e-4, name


def test_with_no_reason_to_switch_it_is_classical_ibvs():
    start, target = T_O_C([0.15, -0.1, 1.0], [10, -10, 50]), T_O_C([0, 0, 0.75], [0, 0, 0])
    # both in the plug-in loop: each law's compiled frame path rounds otherwise (1e-7 from it there,
    # SQPnP's stopping tolerance amplifying the last bits: tests/test_compiled_hybrid.py)
    hybrid = run(start, target, "hybrid", loop="plug-in")
    ibvs = run(start, target, "ibvs-current", loop="plug-in")
    assert hybrid.hybrid_switches[-1, 0] == 0
    np.testing.assert_array_equal(hybrid.camera_pose, ibvs.camera_pose)


def test_starting_in_pbvs_and_bad_options():
    start, target = T_O_C([0.15, -0.1, 1.0], [10, -10, 50]), T_O_C([0, 0, 0.75], [0, 0, 0])
    # in either loop, both laws in the same one: the compiled paths of the hybrid law and of PBVS ask
    # the same estimator for the same pose and give it to the same kernel (pbvs_twist)
    for loop in ("plug-in", "auto"):
        hybrid = run(start, target, "hybrid", loop=loop, start_mode="pbvs")
        pbvs = run(start, target, "pbvs", loop=loop)
        assert hybrid.metadata["loop"] == pbvs.metadata["loop"] == ("compiled" if loop == "auto" else loop)
        assert hybrid.hybrid_switches[-1, 0] == 0
        np.testing.assert_array_equal(hybrid.camera_pose, pbvs.camera_pose)
    with pytest.raises(InvalidParameterError, match="start_mode"):
        HybridSwitched(start_mode="2.5d")
    with pytest.raises(InvalidParameterError, match="margin"):
        HybridSwitched(margin=-0.1)
    assert HybridSwitched(margin=0.5).spec()["margin"] == 0.5
