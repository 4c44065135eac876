"""2.5-D VS's compiled frame path (its pose route) gives the plug-in loop's run, to 1e-12.

As ``tests/test_compiled_pbvs.py`` for PBVS: each case runs ``simulate`` twice, ``loop="auto"`` (the
compiled frame path, checked to be the one that ran) and ``loop="plug-in"``, and compares every
recorded number (``assert_same_run``). The law is the controller's own kernel
(``two_half_d_kernels.pose_route_twist``) in both loops, so the runs differ only by the sensor's and
the plant's rounding, and by SQPnP's stopping tolerance where it is in the loop (1e-7,
``compiled_loop``'s docstring). Cases: the free camera with the normalized camera (SQPnP and IPPE,
the centroid and a marker as the reference point), a depth sensor (Kabsch) and the stereo ZED 2
(P3P, a marker's image point from both lenses); the kinematic arm with the stereo ZED 2 and a ZED 2
lens, several ticks per frame, eye-to-hand. The homography route, a subclass and a wrapped sensor
take the plug-in loop; the reference point behind the camera makes the kernel decline, and the
plug-in loop then gives its error.
"""

from __future__ import annotations

import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla.controllers.two_half_d import TwoHalfD
from ibvs_youla.simulation.disturbances import Disturbances
from test_compiled_frame_path import RATE_25, SQPNP_TOLERANCE, TUTORIAL, assert_same_run, both
from test_compiled_pbvs import scripted_pnp

NORMALIZED = iy.PinholeCamera.normalized()
FREE = dict(plant="free-camera", camera=NORMALIZED, duration=3.0, settings=RATE_25)


def assert_two_half_d_run(compiled, plugged, tolerance=1e-12):
    """The two runs equal (``assert_same_run``), e recorded, and the camera moved."""
    assert_same_run(compiled, plugged, tolerance)
    assert "servo_error" in compiled.signals
    assert np.abs(plugged.camera_pose[-1] - plugged.camera_pose[0]).max() > 1e-3  # [m]


@pytest.mark.parametrize("reference_point", ["centroid", 2])
@pytest.mark.parametrize("pnp", ["sqpnp", "ippe"])
def test_free_camera_monocular_pose_by_pnp(pnp, reference_point):
    """SQPnP (1e-7: its stopping tolerance; measured 5e-11) and IPPE, exact on the square (1e-12; 3e-13)."""
    compiled, plugged = both(TUTORIAL, TwoHalfD(pnp=pnp, reference_point=reference_point), **FREE)
    assert_two_half_d_run(compiled, plugged, SQPNP_TOLERANCE if pnp == "sqpnp" else 1e-12)


@pytest.mark.parametrize("reference_point", ["centroid", 1])
def test_free_camera_depth_sensor(reference_point):
    runs = both(TUTORIAL, TwoHalfD(reference_point=reference_point), sensor="depth", **FREE)
    assert_two_half_d_run(*runs)  # measured 8e-16


@pytest.mark.parametrize("reference_point", ["centroid", 1])
def test_free_camera_stereo(reference_point):
    """The ZED 2 (P3P); a marker's image point is ((u_l + u_r) / 2, v) / F in both loops."""
    runs = both(
        iy.scenarios.physical(2), TwoHalfD(reference_point=reference_point), plant="free-camera",
        duration=2.0, settings=RATE_25,
    )  # fmt: skip
    assert_two_half_d_run(*runs)


def test_kinematic_arm_stereo(arm):
    runs = both(iy.scenarios.physical(2), "2.5d", plant="kinematic", duration=2.0, settings=RATE_25, arm=arm)
    assert_two_half_d_run(*runs)


@pytest.mark.parametrize("sensor", ["depth", None])
def test_kinematic_arm_pinhole(sensor, arm, arm_four_markers):
    """A ZED 2 lens: Kabsch on measured depths (1e-12), or SQPnP (1e-7)."""
    runs = both(
        arm_four_markers, "2.5d", plant="kinematic", camera=iy.PinholeCamera.zed2(), duration=2.0,
        settings=RATE_25, arm=arm, sensor=sensor,
    )  # fmt: skip
    assert_two_half_d_run(*runs, tolerance=1e-12 if sensor == "depth" else SQPNP_TOLERANCE)


def test_several_ticks_per_frame_and_eye_to_hand(arm):
    """The arm at 250 Hz and the camera at 25 Hz (the twist and e held), every 3rd sample; eye-to-hand."""
    settings = iy.SimulationSettings(joint_rate_hz=250.0, camera_rate_hz=25.0, record_every=3)
    runs = both(iy.scenarios.physical(2), "2.5d", plant="kinematic", duration=0.5, settings=settings, arm=arm)
    assert_two_half_d_run(*runs)
    scenario = iy.scenarios.eye_to_hand(arm, seed=1)
    assert_two_half_d_run(*both(scenario, "2.5d", plant="kinematic", duration=0.3))


def test_what_it_does_not_cover_runs_the_plug_in_loop():
    """The homography route, a subclass (its update may differ) and a wrapped sensor: the plug-in loop."""

    class OwnTwoHalfD(TwoHalfD):
        pass

    kwargs = dict(FREE, duration=0.2)
    assert iy.simulate(TUTORIAL, TwoHalfD(), **kwargs).metadata["loop"] == "compiled"
    homography = TwoHalfD(rotation_from="homography")
    assert iy.simulate(TUTORIAL, homography, **kwargs).metadata["loop"] == "plug-in"
    assert iy.simulate(TUTORIAL, OwnTwoHalfD(), **kwargs).metadata["loop"] == "plug-in"
    noisy = Disturbances(pixel_noise_px=0.5)
    assert iy.simulate(TUTORIAL, "2.5d", disturbances=noisy, **kwargs).metadata["loop"] == "plug-in"


def test_the_reference_point_behind_the_camera_declines_to_the_plug_in_loop(monkeypatch):
    """A PnP that puts the square 0.75 m behind the camera from the 3rd image on (a scripted solvePnP, by
    the image: the square 0.2785 wide in x in the 2nd, 0.2806 in the 3rd, as test_compiled_pbvs): rho < 0,
    the kernel declines, and the plug-in loop, run again from the start, gives the update's error."""
    behind = (True, np.zeros((3, 1)), np.array([[0.0], [0.0], [-0.75]]))
    restart = scripted_pnp(
        monkeypatch, lambda call, image, flags: behind if np.ptp(image[:, 0]) > 0.2795 else None
    )
    outcome, calls = {}, {}
    for loop in ("auto", "plug-in"):
        restart()
        try:
            result = iy.simulate(TUTORIAL, "2.5d", loop=loop, **FREE)
            outcome[loop] = (result.metadata["loop"], result.status, result.metadata.get("error"))
        except Exception as err:  # the plug-in loop's error, whichever loop was asked
            outcome[loop] = (err.partial.metadata["loop"], type(err).__name__, str(err))
        calls[loop] = restart()
    assert outcome["auto"] == outcome["plug-in"]
    assert calls == {"auto": 6, "plug-in": 3}  # the compiled path's three images, then the plug-in loop's
    assert outcome["auto"][0] == "plug-in"
    assert (
        outcome["auto"][2].startswith("t = 0.08 s")
        and "reference point is behind the camera" in outcome["auto"][2]
    )


def test_campaign_rows_stay_those_of_the_numpy_law(monkeypatch):
    """A free-planar campaign's 2.5-D rows (run_spec: the compiled path) against the plug-in loop's and
    against the rows of the law before its kernel (the numpy reference, the kernel made to decline):
    every number to 1e-9 (relative, or absolute below 1), issue 22's bound; measured 2.3e-10 on 30 cases."""
    from ibvs_youla.campaign.cases import generate_cases
    from ibvs_youla.campaign.metrics import row_from_result
    from ibvs_youla.campaign.run import run_spec
    from ibvs_youla.campaign.spec import specs_for
    from ibvs_youla.controllers import two_half_d
    from test_campaign_batch import FREE as CAMPAIGN
    from test_campaign_batch import same_row

    specs = specs_for(generate_cases("free-planar", 3, 0), ("2.5d",), seed=0, **CAMPAIGN)
    rows = [run_spec(spec) for spec in specs]
    for spec, row in zip(specs, rows, strict=True):
        result = iy.simulate(**spec.build(), loop="plug-in")
        assert row["status"] == "complete" and result.metadata["loop"] == "plug-in"
        same_row(row, row_from_result(spec, result), tolerance=1e-9)
    declined = []
    monkeypatch.setattr(two_half_d, "pose_route_twist", lambda *args: declined.append(1))  # the numpy law
    for spec, row in zip(specs, rows, strict=True):
        result = iy.simulate(**spec.build(), loop="plug-in")
        same_row(row, row_from_result(spec, result), tolerance=1e-9)
        assert result.signals["servo_error"][-1, 0] != 0.0  # the law acted
    assert len(declined) == 3 * 201  # every frame of the three runs (8 s at 25 Hz) took the numpy law


def test_a_run_the_compiled_path_gives_up_counts_its_ippe_fallbacks_once(monkeypatch):
    """IPPE fails on the first images, then the scripted PnP puts the square behind the camera (both by
    the image): the compiled path declines at the 3rd image and the plug-in loop makes the run again.
    The estimator is restarted first, so pnp_fallbacks counts the plug-in run's images only (2 as with
    loop="plug-in"; 4 before: the compiled attempt's were kept)."""
    import cv2

    nan = np.full((3, 1), np.nan)
    behind = (True, np.zeros((3, 1)), np.array([[0.0], [0.0], [-0.75]]))

    def script(call, image, flags):
        if flags == cv2.SOLVEPNP_IPPE and np.ptp(image[:, 0]) < 0.2790:
            return (True, nan, nan)
        return behind if np.ptp(image[:, 0]) > 0.2795 else None

    restart = scripted_pnp(monkeypatch, script)
    fallbacks = {}
    for loop in ("auto", "plug-in"):
        restart()
        result = iy.simulate(TUTORIAL, TwoHalfD(pnp="ippe"), loop=loop, **FREE)
        assert result.metadata["loop"] == "plug-in" and result.status == "estimate_failed"
        fallbacks[loop] = result.metadata["pnp_fallbacks"]
    assert fallbacks == {"auto": 2, "plug-in": 2}
