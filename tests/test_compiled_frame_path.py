"""The compiled frame path gives the plug-in loop's run, to 1e-12, on every method x plant x camera it covers.

Each case runs ``simulate`` twice, ``loop="auto"`` (the compiled frame path, checked to be the one
that ran) and ``loop="plug-in"`` (the roles' loop), and compares every recorded number: times,
camera poses, features, visibility, every signal, the frame log. Cases: ``ibvs-current``,
``ibvs-desired``, ``ibvs-mean`` on the free camera and the kinematic arm, with the normalized camera
and a depth sensor (ViSP's tutorial case), a ZED 2 lens with a depth sensor, and the stereo ZED 2
(depths triangulated); plus an adaptive gain, a believed camera and markers that differ from the
truth, several ticks per frame and a recording stride on the arm. Monocular laws without measured
depths take them from the controller's SQPnP pose, whose stopping tolerance bounds their agreement
(1e-7). What it does not cover runs the plug-in loop (checked); a run that stops early stops at the
plug-in loop's tick with its status and reason.
"""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial.transform import Rotation

import ibvs_youla as iy
from ibvs_youla.controllers.ibvs import AdaptiveGain, ClassicalIBVS
from ibvs_youla.exceptions import InvalidParameterError
from ibvs_youla.simulation.disturbances import Disturbances
from ibvs_youla.simulation.frame_kernels import exp6_integrate

SQUARE_O = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]
RATE_25 = iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0)
TOLERANCE = 1e-12  # the brief's bound; measured 3e-15 (free camera, depth) to 1e-15 (arm)
# SQPnP stops at a step of ~1e-5, so a last-bit difference of the features moves its pose by up to
# ~1e-8 of its scale (compiled_loop's docstring); measured 4e-9 (the twist) on seeded tutorial poses
SQPNP_TOLERANCE = 1e-7


def T_O_C(t, theta_u_deg):
    cMo = np.eye(4)
    cMo[:3, :3] = Rotation.from_rotvec(np.radians(theta_u_deg)).as_matrix()
    cMo[:3, 3] = t
    return np.linalg.inv(cMo)


TUTORIAL = iy.Scenario.free_camera(
    T_O_C_start=T_O_C([0.15, -0.1, 1.0], [10, -10, 50]),
    T_O_C_target=T_O_C([0, 0, 0.75], [0, 0, 0]),
    markers_O=SQUARE_O,
)


def both(scenario, controller, **kwargs):
    compiled = iy.simulate(scenario, controller, loop="auto", **kwargs)
    plugged = iy.simulate(scenario, controller, loop="plug-in", **kwargs)
    return compiled, plugged


def assert_same_run(compiled, plugged, tolerance=TOLERANCE):
    assert compiled.metadata["loop"] == "compiled" and plugged.metadata["loop"] == "plug-in"
    assert compiled.status == plugged.status == "complete"
    np.testing.assert_array_equal(compiled.t, plugged.t)
    np.testing.assert_array_equal(compiled.frame_t, plugged.frame_t)
    np.testing.assert_array_equal(compiled.visible, plugged.visible)
    np.testing.assert_array_equal(compiled.frame_visible, plugged.frame_visible)
    assert compiled.signals.keys() == plugged.signals.keys()
    pairs = [
        (compiled.camera_pose, plugged.camera_pose),
        (compiled.features, plugged.features),
        (compiled.frame_features, plugged.frame_features),
        *((compiled.signals[k], plugged.signals[k]) for k in plugged.signals),
    ]
    for a, b in pairs:
        assert a.shape == b.shape
        np.testing.assert_allclose(a, b, rtol=0, atol=tolerance)
    assert compiled.update_time.shape == plugged.update_time.shape


METHODS = ("ibvs-current", "ibvs-desired", "ibvs-mean")


@pytest.mark.parametrize("method", METHODS)
def test_free_camera_normalized_depth_sensor(method):
    runs = both(
        TUTORIAL, method, plant="free-camera", camera=iy.PinholeCamera.normalized(), duration=3.0,
        settings=RATE_25, sensor="depth",
    )  # fmt: skip
    assert_same_run(*runs)


@pytest.mark.parametrize("method", METHODS)
def test_free_camera_stereo(method):
    runs = both(iy.scenarios.physical(2), method, plant="free-camera", duration=2.0, settings=RATE_25)
    assert_same_run(*runs)


@pytest.mark.parametrize("method", METHODS)
def test_kinematic_arm_stereo(method, arm):
    runs = both(iy.scenarios.physical(2), method, plant="kinematic", duration=2.0, settings=RATE_25, arm=arm)
    assert_same_run(*runs)


@pytest.mark.parametrize("method", METHODS)
def test_kinematic_arm_pinhole_depth_sensor(method, arm, arm_four_markers):
    runs = both(
        arm_four_markers, method, plant="kinematic", camera=iy.PinholeCamera.zed2(), duration=2.0,
        settings=RATE_25, arm=arm, sensor="depth",
    )  # fmt: skip
    assert_same_run(*runs)


@pytest.mark.parametrize("method", ("ibvs-current", "ibvs-mean"))
def test_monocular_depths_from_the_controllers_pnp_pose(method, arm, arm_four_markers):
    """No depth sensor: the depths of L from the controller's SQPnP pose, between two compiled calls."""
    free = both(
        TUTORIAL, method, plant="free-camera", camera=iy.PinholeCamera.normalized(), duration=3.0,
        settings=RATE_25,
    )  # fmt: skip
    assert_same_run(*free, tolerance=SQPNP_TOLERANCE)
    kinematic = both(
        arm_four_markers, method, plant="kinematic", camera=iy.PinholeCamera.zed2(), duration=2.0,
        settings=RATE_25, arm=arm,
    )  # fmt: skip
    assert_same_run(*kinematic, tolerance=SQPNP_TOLERANCE)


def test_several_ticks_per_frame_and_a_recording_stride(arm):
    """The arm at 250 Hz, the camera at 25 Hz (10 ticks a frame), every 3rd sample kept."""
    settings = iy.SimulationSettings(joint_rate_hz=250.0, camera_rate_hz=25.0, record_every=3)
    runs = both(
        iy.scenarios.physical(2), "ibvs-current", plant="kinematic", duration=0.5, settings=settings, arm=arm
    )
    assert_same_run(*runs)
    assert runs[0].t.size == len(range(0, 125, 3)) + 1  # ticks 0, 3, ..., 123, and the last (125)


def test_adaptive_gain_and_beliefs_other_than_the_truth():
    """ViSP's adaptive gain; the controller's camera 2 % long and its markers 1 cm off (calibration)."""
    gain = AdaptiveGain(lambda_0=2.0, lambda_inf=0.4, lambda_dot_0=30.0)
    disturbances = Disturbances(focal_length_scale=1.02, marker_offset_m=(0.01, 0.0, 0.0))
    for method in ("ibvs-current", "ibvs-mean"):
        runs = both(
            TUTORIAL, ClassicalIBVS(method.split("-")[1], gain), plant="free-camera",
            camera=iy.PinholeCamera.normalized(), duration=2.0, settings=RATE_25, sensor="depth",
            disturbances=disturbances,
        )  # fmt: skip
        assert_same_run(*runs)
        assert runs[0].signals["ibvs_gain"][1, 0] != runs[0].signals["ibvs_gain"][-1, 0]  # adaptive


def test_what_it_does_not_cover_runs_the_plug_in_loop():
    kwargs = dict(plant="free-camera", camera=iy.PinholeCamera.normalized(), duration=0.2, settings=RATE_25)
    assert iy.simulate(TUTORIAL, "ibvs-current", **kwargs).metadata["loop"] == "compiled"  # PnP depths
    assert iy.simulate(TUTORIAL, "ibvs-desired", **kwargs).metadata["loop"] == "compiled"  # no depths needed
    assert iy.simulate(TUTORIAL, "mpc-ibvs", sensor="depth", **kwargs).metadata["loop"] == "plug-in"
    noisy = Disturbances(pixel_noise_px=0.5)  # a wrapped sensor
    assert iy.simulate(TUTORIAL, "ibvs-desired", disturbances=noisy, **kwargs).metadata["loop"] == "plug-in"
    with pytest.raises(InvalidParameterError, match="loop"):
        iy.simulate(TUTORIAL, "ibvs-desired", loop="compiled", **kwargs)


def test_a_run_that_stops_early_stops_as_the_plug_in_loops():
    """lambda T = 2.4 > 2 (lambda = 60 /s at 25 Hz): the sampled loop overshoots and the camera passes the
    markers' plane at 0.16 s; the compiled run stops there with the plug-in loop's status and reason."""
    kwargs = dict(plant="free-camera", camera=iy.PinholeCamera.normalized(), duration=1.0, settings=RATE_25)
    compiled = iy.simulate(TUTORIAL, ClassicalIBVS("current", 60.0), sensor="depth", **kwargs)
    plugged = iy.simulate(TUTORIAL, ClassicalIBVS("current", 60.0), sensor="depth", loop="plug-in", **kwargs)
    assert compiled.status == plugged.status == "markers_lost"
    assert compiled.metadata["loop"] == "compiled"
    # the same reason; its numbers (the depths) to rounding, which the overshooting loop amplifies
    number = r"-?\d+\.\d+(e-?\d+)?"
    assert re.sub(number, "#", compiled.metadata["error"]) == re.sub(number, "#", plugged.metadata["error"])
    assert compiled.t.size == plugged.t.size == 4 and compiled.frame_t.size == plugged.frame_t.size == 4
    # the camera 55 m away at 0.12 s: rounding relative to that scale (measured 2.6e-13)
    np.testing.assert_allclose(compiled.camera_pose, plugged.camera_pose, rtol=TOLERANCE, atol=TOLERANCE)


def test_exp6_is_pinocchios():
    """T exp(dt [xi]^) against pin.exp6 on seeded twists, angles from 1e-9 to 3 rad (both branches)."""
    rng = np.random.default_rng(0)
    worst = 0.0
    for scale in (1e-9, 1e-6, 1e-4, 1e-2, 1.0, 3.0):
        for _ in range(200):
            xi = rng.standard_normal(6) * scale
            T0 = pin.SE3.Random().homogeneous
            T = T0.copy()
            exp6_integrate(T, xi, 0.04)
            worst = max(worst, np.abs(T - T0 @ pin.exp6(xi * 0.04).homogeneous).max())
    assert worst < 1e-14  # measured 4.4e-16
