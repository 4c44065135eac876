"""Polar IBVS's compiled frame path gives the plug-in loop's run, to 1e-12, on every plant x camera.

As ``tests/test_compiled_frame_path.py`` for classical IBVS: each case runs ``simulate`` twice,
``loop="auto"`` (the compiled frame path, checked to be the one that ran) and ``loop="plug-in"``,
and compares every recorded number (times, camera poses, features, visibility, the twist, the frame
log). Cases: the free camera with the normalized camera (the depths from the controller's SQPnP
pose, the default, or IPPE's), a depth sensor (both angle wrappings), the stereo ZED 2 (triangulated
depths, both lenses' polar features) and a start turned 170 deg about the optical axis (the law's
point: a turn, where the phi errors near the cut decide); the kinematic arm with the stereo ZED 2
and a ZED 2 lens, several ticks per frame with a recording stride; beliefs other than the truth.
Where SQPnP is in the loop its stopping tolerance bounds the agreement (1e-7, ``compiled_loop``'s
docstring). What it does not cover runs the plug-in loop; an estimate that fails stops at the
plug-in loop's tick with its reason; a kernel that declines (a point at the principal point) gives
the plug-in loop's run.
"""

from __future__ import annotations

import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla.controllers.polar import PolarIBVS
from ibvs_youla.simulation.disturbances import Disturbances
from ibvs_youla.simulation.polar_frame_kernels import _numpy_sum
from test_compiled_frame_path import (
    RATE_25,
    SQPNP_TOLERANCE,
    SQUARE_O,
    T_O_C,
    TUTORIAL,
    assert_same_run,
    both,
)
from test_compiled_pbvs import failed_estimate_runs

NORMALIZED = iy.PinholeCamera.normalized()
FREE = dict(plant="free-camera", camera=NORMALIZED, duration=2.0, settings=RATE_25)
# 170 deg about the optical axis, slightly tilted: polar IBVS turns about the axis
TURNED = iy.Scenario.free_camera(
    T_O_C_start=T_O_C([0.05, -0.03, 0.8], [5, -5, 170]),
    T_O_C_target=T_O_C([0, 0, 0.75], [0, 0, 0]),
    markers_O=SQUARE_O,
)


def assert_polar_run(compiled, plugged, tolerance=1e-12):
    """The runs equal (``assert_same_run``), the same signals in the same order, the camera moved."""
    assert_same_run(compiled, plugged, tolerance)
    assert list(compiled.signals) == list(plugged.signals)
    assert np.abs(plugged.camera_pose[-1] - plugged.camera_pose[0]).max() > 1e-3  # [m]


def test_the_joint_wraps_sums_are_numpys_to_the_bit():
    """The circular mean of the phi errors sums their sines and cosines as numpy's ``x.sum()`` (its pairwise
    leaf: eight running sums from 8 entries on, as a stereo camera's 8 lens points), on 1 to 40 entries."""
    rng = np.random.default_rng(3)
    for _ in range(2000):
        x = rng.normal(size=rng.integers(1, 41)) * 10.0 ** rng.integers(-6, 3)
        assert _numpy_sum(x) == x.sum()


@pytest.mark.parametrize("pnp", ["sqpnp", "ippe"])
def test_free_camera_monocular_depths_from_the_pose(pnp):
    """SQPnP (1e-7, its stopping tolerance; measured 5e-11), IPPE (1e-12; measured 2e-13)."""
    runs = both(TUTORIAL, PolarIBVS(pnp=pnp), **FREE)
    assert_polar_run(*runs, SQPNP_TOLERANCE if pnp == "sqpnp" else 1e-12)


@pytest.mark.parametrize("wrap", ["joint", "per-point"])
def test_free_camera_depth_sensor(wrap):
    """Measured depths (measured 2e-13 joint, 9e-14 per-point)."""
    assert_polar_run(*both(TUTORIAL, PolarIBVS(wrap=wrap), sensor="depth", **FREE))


@pytest.mark.parametrize("wrap", ["joint", "per-point"])
def test_free_camera_turned_about_the_optical_axis(wrap):
    """170 deg about the axis (the phi errors 10 deg from the cut: the wraps differ here, not rounding):
    the camera turns (its z axis barely moves)."""
    compiled, plugged = both(TURNED, PolarIBVS(wrap=wrap), sensor="depth", **FREE)
    assert_polar_run(compiled, plugged)
    assert np.abs(plugged.camera_twist[:, 5]).max() > 0.1  # [rad/s]: a turn about the optical axis


def test_free_camera_stereo():
    runs = both(iy.scenarios.physical(2), "ibvs-polar", plant="free-camera", duration=2.0, settings=RATE_25)
    assert_polar_run(*runs)


def test_kinematic_arm_stereo(arm):
    scenario = iy.scenarios.physical(2)
    assert_polar_run(
        *both(scenario, "ibvs-polar", plant="kinematic", duration=2.0, settings=RATE_25, arm=arm)
    )


@pytest.mark.parametrize("sensor", ["depth", None])
def test_kinematic_arm_pinhole(sensor, arm, arm_four_markers):
    """A ZED 2 lens: measured depths (1e-12), SQPnP's (1e-7)."""
    runs = both(
        arm_four_markers, "ibvs-polar", plant="kinematic", camera=iy.PinholeCamera.zed2(), duration=2.0,
        settings=RATE_25, arm=arm, sensor=sensor,
    )  # fmt: skip
    assert_polar_run(*runs, tolerance=1e-12 if sensor == "depth" else SQPNP_TOLERANCE)


def test_several_ticks_per_frame_and_a_recording_stride(arm):
    """The arm at 250 Hz, the camera at 25 Hz (10 ticks a frame, the twist held), every 3rd sample."""
    settings = iy.SimulationSettings(joint_rate_hz=250.0, camera_rate_hz=25.0, record_every=3)
    runs = both(
        iy.scenarios.physical(2), "ibvs-polar", plant="kinematic", duration=0.5, settings=settings, arm=arm
    )
    assert_polar_run(*runs)
    assert runs[0].t.size == len(range(0, 125, 3)) + 1  # ticks 0, 3, ..., 123, and the last (125)


def test_beliefs_other_than_the_truth():
    """The controller's camera 2 % long and its markers 1 cm off: its F and depths, not the sensor's."""
    disturbances = Disturbances(focal_length_scale=1.02, marker_offset_m=(0.01, 0.0, 0.0))
    compiled, plugged = both(TUTORIAL, "ibvs-polar", sensor="depth", disturbances=disturbances, **FREE)
    assert_polar_run(compiled, plugged)
    truth = iy.simulate(TUTORIAL, "ibvs-polar", sensor="depth", **FREE)
    assert np.abs(compiled.camera_pose[-1] - truth.camera_pose[-1]).max() > 1e-3  # the beliefs acted


def test_what_it_does_not_cover_runs_the_plug_in_loop():
    """A subclass of PolarIBVS (its update may differ), a wrapped sensor (noise): the plug-in loop."""

    class OwnPolar(PolarIBVS):
        pass

    kwargs = dict(FREE, duration=0.2)
    assert iy.simulate(TUTORIAL, PolarIBVS(), **kwargs).metadata["loop"] == "compiled"
    assert iy.simulate(TUTORIAL, OwnPolar(), **kwargs).metadata["loop"] == "plug-in"
    noisy = Disturbances(pixel_noise_px=0.5)
    assert iy.simulate(TUTORIAL, "ibvs-polar", disturbances=noisy, **kwargs).metadata["loop"] == "plug-in"


def test_an_estimate_that_fails_stops_the_run_as_the_plug_in_loops(monkeypatch):
    """OpenCV finds no pose from the 4th image (t = 0.12 s): status estimate_failed, the same reason."""
    failed_estimate_runs(monkeypatch, PolarIBVS(), **dict(FREE, duration=3.0))


def test_a_point_at_the_principal_point_declines_to_the_plug_in_loop():
    """A marker on the optical axis at the first frame: phi has no value, the kernel declines, and the run
    is the plug-in loop's (which stops it: FeatureSingularityError is a failed estimate)."""
    on_axis = np.array([[0.0, 0.0, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.05]])
    scenario = iy.Scenario.free_camera(
        T_O_C_start=T_O_C([0.0, 0.0, 0.8], [0, 0, 0]),
        T_O_C_target=T_O_C([0.01, 0.0, 0.75], [0, 0, 10]),
        markers_O=on_axis,
    )
    outcome = {}
    for loop in ("auto", "plug-in"):
        result = iy.simulate(scenario, "ibvs-polar", loop=loop, sensor="depth", **dict(FREE, duration=0.2))
        outcome[loop] = (result.metadata["loop"], result.status, result.metadata["error"])
    assert outcome["auto"] == outcome["plug-in"]
    assert outcome["auto"][:2] == ("plug-in", "estimate_failed") and "principal point" in outcome["auto"][2]


@pytest.mark.parametrize("wrap", ["joint", "per-point"])
def test_an_exact_half_turn_is_the_plug_in_loops_to_wrap(wrap):
    """The start turned exactly 180 deg about the optical axis: every phi error on the wrap's cut, where the
    kernel's atan2 and numpy's may round to opposite sides (w_z = +-lambda pi). The kernel declines at
    the first frame and the plug-in loop makes the run: its result, in both loops (the same floats)."""
    half_turn = iy.Scenario.free_camera(
        T_O_C_start=T_O_C([0, 0, 0.75], [0, 0, 180]),
        T_O_C_target=T_O_C([0, 0, 0.75], [0, 0, 0]),
        markers_O=SQUARE_O,
    )
    compiled, plugged = both(half_turn, PolarIBVS(wrap=wrap), sensor="depth", **FREE)
    assert compiled.metadata["loop"] == plugged.metadata["loop"] == "plug-in"
    np.testing.assert_array_equal(compiled.signals["camera_twist"], plugged.signals["camera_twist"])


def test_the_kernel_declines_a_phi_error_on_the_cut_and_not_one_off_it():
    """polar_twist itself: a per-point phi error of pi (to 1e-12) declines, one of pi - 1e-6 does not."""
    from ibvs_youla.model.camera_kernels import camera_parameters
    from ibvs_youla.simulation.frame_kernels import DEPTH_MEASURED, pack_parameters
    from ibvs_youla.simulation.polar_frame_kernels import polar_twist

    camera = camera_parameters(NORMALIZED)
    params = pack_parameters(
        camera, camera, dt=0.04, gain=(0.5, 0.5, 0.0, False), pinv_threshold=1e-6, interaction=0,
        depth_from=DEPTH_MEASURED, virtual_points=False, measure_depth=True, record_every=1, n_ticks=1,
    )  # fmt: skip
    points = np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]])  # normalized, at Z = 1 m
    frame = np.concatenate((points.ravel(), np.ones(4), np.ones(4)))
    r, phi = np.hypot(points[:, 0], points[:, 1]), np.arctan2(points[:, 1], points[:, 0])
    settings = np.array([0.5, 1.0, 1.0, 2.0])  # lambda, per-point, F, rows per point
    for offset, declines in ((np.pi, True), (np.pi - 1e-6, False)):
        law = np.column_stack((r, phi - offset)).ravel()  # s*: every phi error = offset
        twist = np.full(6, 7.0)
        assert polar_twist(frame, 4, 8, law, params, settings, twist) is not declines, offset


def test_the_gain_alone_changes_the_run_alike_in_both_loops():
    """lambda 0.8 instead of 0.5: the compiled path reads it (equal to the plug-in loop to 1e-12) and it
    acts (the camera ends elsewhere by more than 1 mm after 0.4 s)."""
    kwargs = dict(FREE, duration=0.4)
    compiled, plugged = both(TUTORIAL, PolarIBVS(gain=0.8), sensor="depth", **kwargs)
    assert_polar_run(compiled, plugged)
    default = iy.simulate(TUTORIAL, PolarIBVS(), sensor="depth", **kwargs)
    assert np.abs(compiled.camera_pose[-1] - default.camera_pose[-1]).max() > 1e-3
