"""The hybrid law's compiled frame path gives the plug-in loop's run, to 1e-12, on every plant x camera.

As ``tests/test_compiled_frame_path.py`` for classical IBVS: each case runs ``simulate`` twice,
``loop="auto"`` (the compiled frame path, checked to be the one that ran) and ``loop="plug-in"``,
and compares every recorded number (times, camera poses, features, visibility, the twist,
``hybrid_mode`` and ``hybrid_switches``, the frame log). Cases: the free camera with the normalized
camera (SQPnP, the default, and IPPE), a depth sensor (Kabsch) and the stereo ZED 2 (the pose and
L's depths from the triangulated points); the kinematic arm with the stereo ZED 2 and a ZED 2 lens
with a depth sensor or SQPnP, several ticks per frame with a recording stride, eye-to-hand; beliefs
other than the truth. The runs that switch: ``TURNED`` starts 170 deg about the optical axis from
the goal, slightly tilted, where IBVS retreats until V_p reaches its bound and the law switches to
PBVS at 0.48 s; ``SWUNG``, started in PBVS, moves the image away until V_i reaches its bound and
the law switches to IBVS at 0.16 s (its first frame out of the dwell). (Not 180 deg exactly: there
theta u and -theta u are the same rotation, and which one PBVS turns by flips with the last bits of
the pose, in any two loops that round differently: the twists part by pi rad/s.) On the arm, a
one-frame dwell with no margin switches at the first frame (V(0) is its own bound), the other law
then driving the arm. Where SQPnP is in the loop its stopping tolerance bounds the agreement (1e-7,
``compiled_loop``'s docstring). What it does not cover runs the plug-in loop; an estimate that
fails stops at the plug-in loop's tick with its reason, and both loops solve one PnP per frame.
"""

from __future__ import annotations

import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla.controllers.hybrid import HybridSwitched
from ibvs_youla.simulation.disturbances import Disturbances
from ibvs_youla.simulation.hybrid_frame_kernels import squared_norm
from test_compiled_frame_path import (
    RATE_25,
    SQPNP_TOLERANCE,
    SQUARE_O,
    T_O_C,
    TUTORIAL,
    assert_same_run,
    both,
)
from test_compiled_pbvs import failed_estimate_runs, scripted_pnp

NORMALIZED = iy.PinholeCamera.normalized()
FREE = dict(plant="free-camera", camera=NORMALIZED, duration=2.0, settings=RATE_25)
# 170 deg about the optical axis, tilted 5 deg: classical IBVS retreats, PBVS turns
TURNED = iy.Scenario.free_camera(
    T_O_C_start=T_O_C([0.05, -0.03, 0.8], [5, -5, 170]),
    T_O_C_target=T_O_C([0, 0, 0.75], [0, 0, 0]),
    markers_O=SQUARE_O,
)
SWUNG = iy.Scenario.free_camera(  # started in PBVS: the image leaves the target, then IBVS
    T_O_C_start=T_O_C([0.2, 0.0, 0.8], [0, -35, 120]),
    T_O_C_target=T_O_C([0, 0, 0.75], [0, 0, 0]),
    markers_O=SQUARE_O,
)


def switch_times(result):
    """The times [s] of the samples at which the switch count rose (t = 0 if the first frame switched)."""
    count = np.concatenate(([0.0], result.hybrid_switches[:, 0]))
    return result.t[np.diff(count) > 0].tolist()


def assert_hybrid_run(compiled, plugged, tolerance=1e-12, switched_at=None):
    """The two runs equal (``assert_same_run``), the modes to the bit, the camera moved, and the
    switches at the times given (when given) in both."""
    assert_same_run(compiled, plugged, tolerance)
    np.testing.assert_array_equal(compiled.hybrid_mode, plugged.hybrid_mode)  # decisions: to the bit
    np.testing.assert_array_equal(compiled.hybrid_switches, plugged.hybrid_switches)
    assert np.abs(plugged.camera_pose[-1] - plugged.camera_pose[0]).max() > 1e-3  # [m]
    if switched_at is not None:
        assert switch_times(compiled) == switch_times(plugged) == pytest.approx(switched_at, abs=1e-12)


def test_the_lyapunov_functions_squared_norm_is_numpys_to_the_bit():
    """V_i and V_p decide the switches: ||x||^2 is numpy's x @ x to the bit (BLAS ddot in both), on
    vectors of 1 to 40 entries over eight decades (a sum in index order differs on 28 % of such
    vectors at unit scale, measured)."""
    rng = np.random.default_rng(7)
    for _ in range(2000):
        x = rng.normal(size=rng.integers(1, 41)) * 10.0 ** rng.integers(-6, 3)
        assert squared_norm(x) == x @ x


@pytest.mark.parametrize("pnp", ["sqpnp", "ippe"])
def test_free_camera_monocular_pose_by_pnp_switching_to_pbvs(pnp):
    """IBVS to PBVS at 0.48 s: SQPnP (1e-7, its stopping tolerance; measured 2e-11), IPPE (1e-12; 4e-14)."""
    compiled, plugged = both(TURNED, HybridSwitched(pnp=pnp), **FREE)
    assert_hybrid_run(compiled, plugged, SQPNP_TOLERANCE if pnp == "sqpnp" else 1e-12, switched_at=[0.48])


def test_free_camera_depth_sensor_switching_to_pbvs():
    assert_hybrid_run(*both(TURNED, "hybrid", sensor="depth", **FREE), switched_at=[0.48])  # measured 7e-14


@pytest.mark.parametrize(("options", "switched_at"), [({"margin": 0.5}, [1.0]), ({"gain": 0.9}, [0.28])])
def test_the_margin_and_the_gain_each_move_the_switch_alike_in_both_loops(options, switched_at):
    """Each option alone moves the switch from 0.48 s (the bounds (1 + margin) V(0); both laws' lambda):
    margin 0.5 to 1.0 s, gain 0.9 to 0.28 s, the same in both loops (a depth sensor: 1e-12)."""
    runs = both(TURNED, HybridSwitched(**options), sensor="depth", **FREE)
    assert_hybrid_run(*runs, switched_at=switched_at)


@pytest.mark.parametrize("sensor", ["depth", None])
def test_free_camera_started_in_pbvs_switching_to_ibvs(sensor):
    """PBVS to IBVS at 0.16 s, the first frame out of the 5-frame dwell: a depth sensor (1e-12;
    measured 7e-15), SQPnP (1e-7; 6e-12)."""
    runs = both(SWUNG, HybridSwitched(start_mode="pbvs"), sensor=sensor, **FREE)
    assert_hybrid_run(*runs, 1e-12 if sensor == "depth" else SQPNP_TOLERANCE, switched_at=[0.16])


def test_free_camera_without_a_switch_is_ippe_exact():
    """The tutorial case (no reason to switch): IBVS throughout, with IPPE's pose (1e-12; measured 3e-15)."""
    assert_hybrid_run(*both(TUTORIAL, HybridSwitched(pnp="ippe"), **FREE), switched_at=[])


def test_free_camera_stereo():
    runs = both(iy.scenarios.physical(2), "hybrid", plant="free-camera", duration=2.0, settings=RATE_25)
    assert_hybrid_run(*runs)


@pytest.mark.parametrize("start_mode", ["ibvs", "pbvs"])
def test_kinematic_arm_stereo(start_mode, arm):
    """The default dwell (no switch; measured 9e-16), and a one-frame dwell: a switch at the first frame."""
    scenario = iy.scenarios.physical(2)
    kwargs = dict(plant="kinematic", duration=2.0, settings=RATE_25, arm=arm)
    assert_hybrid_run(*both(scenario, HybridSwitched(start_mode=start_mode), **kwargs), switched_at=[])
    runs = both(scenario, HybridSwitched(start_mode=start_mode, min_dwell=1), **kwargs)
    assert_hybrid_run(*runs, switched_at=[0.0])
    assert runs[0].hybrid_mode[0, 0] == (1.0 if start_mode == "ibvs" else 0.0)  # the other law from the start


def test_several_ticks_per_frame_and_a_recording_stride(arm):
    """The arm at 250 Hz, the camera at 25 Hz (10 ticks a frame, twist and mode held), every 3rd sample."""
    settings = iy.SimulationSettings(joint_rate_hz=250.0, camera_rate_hz=25.0, record_every=3)
    runs = both(
        iy.scenarios.physical(2), HybridSwitched(min_dwell=1), plant="kinematic", duration=0.5,
        settings=settings, arm=arm,
    )  # fmt: skip
    assert_hybrid_run(*runs, switched_at=[0.0])
    assert runs[0].t.size == len(range(0, 125, 3)) + 1  # ticks 0, 3, ..., 123, and the last (125)


@pytest.mark.parametrize("sensor", ["depth", None])
def test_kinematic_arm_pinhole(sensor, arm, arm_four_markers):
    """A ZED 2 lens, started in PBVS: Kabsch on measured depths (1e-12; measured 2e-15), SQPnP (1e-7)."""
    runs = both(
        arm_four_markers, HybridSwitched(start_mode="pbvs"), plant="kinematic",
        camera=iy.PinholeCamera.zed2(), duration=2.0, settings=RATE_25, arm=arm, sensor=sensor,
    )  # fmt: skip
    assert_hybrid_run(*runs, tolerance=1e-12 if sensor == "depth" else SQPNP_TOLERANCE)


def test_eye_to_hand(arm):
    """The fixed camera's pose in the markers' carrier frame, its J_rel: as eye-in-hand (measured 2e-15)."""
    scenario = iy.scenarios.eye_to_hand(arm, seed=1)
    runs = both(scenario, HybridSwitched(min_dwell=1), plant="kinematic", duration=0.3)
    assert_hybrid_run(*runs, switched_at=[0.0])


def test_beliefs_other_than_the_truth():
    """The controller's camera 2 % long and its markers 1 cm off: its F in V_i and its pose, not the
    sensor's; a depth sensor (measured 2e-14), switching at 0.48 s as without them."""
    disturbances = Disturbances(focal_length_scale=1.02, marker_offset_m=(0.01, 0.0, 0.0))
    compiled, plugged = both(TURNED, "hybrid", sensor="depth", disturbances=disturbances, **FREE)
    assert_hybrid_run(compiled, plugged, switched_at=[0.48])
    truth = iy.simulate(TURNED, "hybrid", sensor="depth", **FREE)
    assert np.abs(compiled.camera_pose[-1] - truth.camera_pose[-1]).max() > 1e-3  # the beliefs acted


def test_what_it_does_not_cover_runs_the_plug_in_loop():
    """A subclass of HybridSwitched (its update may differ), a wrapped sensor (noise): the plug-in loop."""

    class OwnHybrid(HybridSwitched):
        pass

    kwargs = dict(FREE, duration=0.2)
    assert iy.simulate(TUTORIAL, HybridSwitched(), **kwargs).metadata["loop"] == "compiled"
    assert iy.simulate(TUTORIAL, OwnHybrid(), **kwargs).metadata["loop"] == "plug-in"
    noisy = Disturbances(pixel_noise_px=0.5)
    assert iy.simulate(TUTORIAL, "hybrid", disturbances=noisy, **kwargs).metadata["loop"] == "plug-in"


def test_an_estimate_that_fails_stops_the_run_as_the_plug_in_loops(monkeypatch):
    """OpenCV finds no pose from the 4th image (t = 0.12 s): status estimate_failed, the same reason."""
    compiled, plugged = failed_estimate_runs(monkeypatch, HybridSwitched(), **dict(FREE, duration=3.0))
    np.testing.assert_allclose(compiled.camera_pose, plugged.camera_pose, rtol=0, atol=SQPNP_TOLERANCE)


def test_one_pnp_per_frame(monkeypatch):
    """The IBVS depths and PBVS's pose share one PnP per frame, in the compiled loop as in the plug-in one."""
    restart = scripted_pnp(monkeypatch, lambda call, image, flags: None)  # OpenCV's own, counted
    calls = {}
    for loop in ("auto", "plug-in"):
        restart()
        result = iy.simulate(TUTORIAL, HybridSwitched(), loop=loop, **dict(FREE, duration=0.2))
        calls[result.metadata["loop"]] = restart()
    assert calls == {"compiled": 6, "plug-in": 6}  # ticks 0 to 5: six frames
