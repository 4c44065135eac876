"""PBVS's compiled frame path gives the plug-in loop's run, to 1e-12, on every plant x camera it covers.

As ``tests/test_compiled_frame_path.py`` for classical IBVS: each case runs ``simulate`` twice,
``loop="auto"`` (the compiled frame path, checked to be the one that ran) and ``loop="plug-in"``,
and compares every recorded number (times, camera poses, features, visibility, every signal with
``servo_error``, the frame log). Cases: the free camera with the normalized camera (SQPnP, the
default, and IPPE), a depth sensor (Kabsch) and the stereo ZED 2 (P3P); the kinematic arm with the
stereo ZED 2, a ZED 2 lens with a depth sensor or SQPnP, several ticks per frame and a recording
stride, eye-to-hand; beliefs other than the truth. Where SQPnP is in the loop its stopping
tolerance bounds the agreement (1e-7, ``compiled_loop``'s docstring). What it does not cover runs
the plug-in loop; an estimate that fails stops at the plug-in loop's tick with its reason; an
estimator error the plug-in loop raises makes the compiled path decline; IPPE's fallbacks are
counted alike. The last three replace OpenCV's ``solvePnP`` by a scripted one (the same script in
both runs): the views where OpenCV itself fails are not met in a short run.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla.controllers.pbvs import PBVS
from ibvs_youla.exceptions import ControllerError
from ibvs_youla.simulation.disturbances import Disturbances
from test_compiled_frame_path import RATE_25, SQPNP_TOLERANCE, TUTORIAL, assert_same_run, both

NORMALIZED = iy.PinholeCamera.normalized()
FREE = dict(plant="free-camera", camera=NORMALIZED, duration=3.0, settings=RATE_25)


def assert_pbvs_run(compiled, plugged, tolerance=1e-12):
    """The two runs equal (``assert_same_run``), PBVS's signals recorded, and the camera moved."""
    assert_same_run(compiled, plugged, tolerance)
    assert "servo_error" in compiled.signals
    assert np.abs(plugged.camera_pose[-1] - plugged.camera_pose[0]).max() > 1e-3  # [m]


@pytest.mark.parametrize("pnp", ["sqpnp", "ippe"])
def test_free_camera_monocular_pose_by_pnp(pnp):
    """SQPnP (1e-7: its stopping tolerance; measured 6e-11) and IPPE, exact on the square (1e-12)."""
    compiled, plugged = both(TUTORIAL, PBVS(pnp=pnp), **FREE)
    assert_pbvs_run(compiled, plugged, SQPNP_TOLERANCE if pnp == "sqpnp" else 1e-12)  # IPPE: 9e-15


def test_free_camera_depth_sensor():
    assert_pbvs_run(*both(TUTORIAL, "pbvs", sensor="depth", **FREE))  # measured 7e-16


def test_free_camera_stereo():
    runs = both(iy.scenarios.physical(2), "pbvs", plant="free-camera", duration=2.0, settings=RATE_25)
    assert_pbvs_run(*runs)  # measured 1e-15


def test_kinematic_arm_stereo(arm):
    runs = both(iy.scenarios.physical(2), "pbvs", plant="kinematic", duration=2.0, settings=RATE_25, arm=arm)
    assert_pbvs_run(*runs)  # measured 1.4e-15


@pytest.mark.parametrize("sensor", ["depth", None])
def test_kinematic_arm_pinhole(sensor, arm, arm_four_markers):
    """A ZED 2 lens: Kabsch on measured depths (1e-12; measured 4e-15), or SQPnP (1e-7; 4e-11)."""
    runs = both(
        arm_four_markers, "pbvs", plant="kinematic", camera=iy.PinholeCamera.zed2(), duration=2.0,
        settings=RATE_25, arm=arm, sensor=sensor,
    )  # fmt: skip
    assert_pbvs_run(*runs, tolerance=1e-12 if sensor == "depth" else SQPNP_TOLERANCE)


def test_several_ticks_per_frame_and_a_recording_stride(arm):
    """The arm at 250 Hz, the camera at 25 Hz (10 ticks a frame, the twist and e held), every 3rd sample."""
    settings = iy.SimulationSettings(joint_rate_hz=250.0, camera_rate_hz=25.0, record_every=3)
    runs = both(iy.scenarios.physical(2), "pbvs", plant="kinematic", duration=0.5, settings=settings, arm=arm)
    assert_pbvs_run(*runs)
    assert runs[0].t.size == len(range(0, 125, 3)) + 1  # ticks 0, 3, ..., 123, and the last (125)


def test_eye_to_hand(arm):
    """The fixed camera's pose in the markers' carrier frame, T_E_C(q), and its J_rel: as eye-in-hand."""
    scenario = iy.scenarios.eye_to_hand(arm, seed=1)
    assert_pbvs_run(*both(scenario, "pbvs", plant="kinematic", duration=0.3))


def test_beliefs_other_than_the_truth():
    """The controller's camera 2 % long and its markers 1 cm off: its pose, not the sensor's, differs."""
    disturbances = Disturbances(focal_length_scale=1.02, marker_offset_m=(0.01, 0.0, 0.0))
    compiled, plugged = both(TUTORIAL, "pbvs", sensor="depth", disturbances=disturbances, **FREE)
    assert_pbvs_run(compiled, plugged)
    truth = iy.simulate(TUTORIAL, "pbvs", sensor="depth", **FREE)
    assert np.abs(compiled.camera_pose[-1] - truth.camera_pose[-1]).max() > 1e-3  # the beliefs acted


def test_what_it_does_not_cover_runs_the_plug_in_loop():
    """A subclass of PBVS (its update may differ) and a wrapped sensor (noise) take the plug-in loop."""

    class OwnPBVS(PBVS):
        pass

    kwargs = dict(FREE, duration=0.2)
    assert iy.simulate(TUTORIAL, PBVS(), **kwargs).metadata["loop"] == "compiled"
    assert iy.simulate(TUTORIAL, OwnPBVS(), **kwargs).metadata["loop"] == "plug-in"
    noisy = Disturbances(pixel_noise_px=0.5)
    assert iy.simulate(TUTORIAL, "pbvs", disturbances=noisy, **kwargs).metadata["loop"] == "plug-in"
    assert iy.simulate(TUTORIAL, "mpc-ibvs", **kwargs).metadata["loop"] == "plug-in"  # another law


def scripted_pnp(monkeypatch, script):
    """Replace ``cv2.solvePnP``: ``script(call, image, flags)`` gives a result, or None for OpenCV's own.

    ``image`` is the normalized points (n, 2). Returns a function that restarts the count of calls
    (and returns the calls made since the last restart).
    """
    real, calls = cv2.solvePnP, [0]

    def solve(*args, **kwargs):
        calls[0] += 1
        result = script(calls[0], args[1], kwargs.get("flags"))
        return real(*args, **kwargs) if result is None else result

    monkeypatch.setattr(cv2, "solvePnP", solve)

    def restart():
        done, calls[0] = calls[0], 0
        return done

    return restart


def scripted_runs(restart, controller, **kwargs):
    """The compiled and the plug-in run, each with the script from its first call."""
    restart()
    compiled = iy.simulate(TUTORIAL, controller, **kwargs)
    restart()
    plugged = iy.simulate(TUTORIAL, controller, loop="plug-in", **kwargs)
    return compiled, plugged


def failed_estimate_runs(monkeypatch, controller, **kwargs):
    """The compiled and the plug-in run when OpenCV finds no pose from the 4th image (t = 0.12 s), checked
    to stop alike: status estimate_failed at the same tick, the same reason naming the controller."""
    no_pose = (False, np.zeros((3, 1)), np.zeros((3, 1)))
    restart = scripted_pnp(monkeypatch, lambda call, image, flags: no_pose if call >= 4 else None)
    compiled, plugged = scripted_runs(restart, controller, **kwargs)
    assert compiled.metadata["loop"] == "compiled"
    assert compiled.status == plugged.status == "estimate_failed"
    assert compiled.metadata["error"] == plugged.metadata["error"]
    assert compiled.metadata["error"].startswith(
        f"t = 0.12 s: {type(controller).__name__}'s estimate failed: "
    )
    assert compiled.t.size == plugged.t.size == 3 and compiled.frame_t.size == plugged.frame_t.size == 3
    return compiled, plugged


def test_an_estimate_that_fails_stops_the_run_as_the_plug_in_loops(monkeypatch):
    """OpenCV finds no pose from the 4th image (t = 0.12 s): status estimate_failed, the same reason."""
    compiled, plugged = failed_estimate_runs(monkeypatch, PBVS(), **FREE)
    for a, b in (
        (compiled.camera_pose, plugged.camera_pose),
        (compiled.signals["servo_error"], plugged.signals["servo_error"]),
    ):
        np.testing.assert_allclose(a, b, rtol=0, atol=SQPNP_TOLERANCE)


def test_an_estimator_error_the_plug_in_loop_raises_declines_to_it(monkeypatch):
    """An error that is not an estimate's (a broken solver, from the 3rd image: the square 0.2785 wide
    in x in the 2nd, 0.2806 in the 3rd) is the plug-in loop's to raise; the compiled path declines."""

    def broken(call, image, flags):
        if np.ptp(image[:, 0]) > 0.2795:
            raise RuntimeError("a broken solver")

    restart = scripted_pnp(monkeypatch, broken)
    calls = {}
    for loop in ("auto", "plug-in"):
        restart()
        with pytest.raises(ControllerError, match="a broken solver") as raised:
            iy.simulate(TUTORIAL, PBVS(), loop=loop, **FREE)
        calls[loop] = restart()
        assert raised.value.partial.metadata["loop"] == "plug-in"
        assert raised.value.partial.t.size == 2  # ticks 0 and 1 recorded
        assert str(raised.value).startswith("PBVS.update() at t = 0.08 s")
    assert calls == {"auto": 6, "plug-in": 3}  # the compiled path's three images, then the plug-in loop's


def test_ippe_fallbacks_are_counted_as_in_the_plug_in_loop(monkeypatch):
    """IPPE made to return NaN (as OpenCV's does on a view within rounding of fronto-parallel) on every
    third image: each is solved by SQPnP, and both runs count the same images and give the same run."""
    nan = np.full((3, 1), np.nan)
    ippe_calls = [0]

    def script(call, image, flags):
        if flags != cv2.SOLVEPNP_IPPE:
            return None
        if call == 1:
            ippe_calls[0] = 0
        ippe_calls[0] += 1
        return (True, nan, nan) if ippe_calls[0] % 3 == 0 else None

    restart = scripted_pnp(monkeypatch, script)
    compiled, plugged = scripted_runs(restart, PBVS(pnp="ippe"), **dict(FREE, duration=1.0))
    assert_same_run(compiled, plugged, SQPNP_TOLERANCE)  # the SQPnP images: its tolerance
    # 26 images (ticks 0 to 25), every third one IPPE's failure
    assert compiled.metadata["pnp_fallbacks"] == plugged.metadata["pnp_fallbacks"] == 26 // 3 == 8


def test_an_exact_half_turn_is_the_plug_in_loops_to_turn():
    """The start turned exactly 180 deg about the optical axis: theta u or -theta u is the pose's last
    bits' choice (w_z = +-lambda pi), which the reference's numpy product and the kernel's sums may round
    differently. The kernel declines at the first frame and the plug-in loop makes the run: its result
    in both loops (a depth sensor; the same floats)."""
    from test_compiled_frame_path import SQUARE_O, T_O_C

    half_turn = iy.Scenario.free_camera(
        T_O_C_start=T_O_C([0, 0, 0.75], [0, 0, 180]),
        T_O_C_target=T_O_C([0, 0, 0.75], [0, 0, 0]),
        markers_O=SQUARE_O,
    )
    compiled, plugged = both(half_turn, "pbvs", sensor="depth", **dict(FREE, duration=1.0))
    assert compiled.metadata["loop"] == plugged.metadata["loop"] == "plug-in"
    np.testing.assert_array_equal(compiled.signals["camera_twist"], plugged.signals["camera_twist"])
    assert abs(plugged.signals["camera_twist"][0, 5]) > 1.0  # it turns: lambda pi = 1.57 rad/s
