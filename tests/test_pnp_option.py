"""The ``pnp`` option: the PnP method of every controller that estimates a monocular pose.

Each law with the option (``ibvs-current``, ``ibvs-mean``, ``pbvs``, ``2.5d``, ``hybrid``,
``mpc-ibvs``, ``ibvs-polar``, ``ibvs-partitioned``, ``ibvs-moments`` with ``interaction="current"``)
runs ViSP's tutorial-ibvs-4pts start on the free camera with the normalized monocular camera (the
square; the moments take the seven irregular points, tests/feature_laws.py) for 1 s at 25 Hz, with
``pnp="sqpnp"`` (the default) and ``pnp="ippe"``. On noise-free features both methods give the
exact pose, so the runs agree to rounding; with pixel noise the two estimates of a noisy image
differ, so the runs do: the option acts. Its estimator is the chosen method's; where it cannot act
(``ibvs-desired``, the moments' ``"desired"``, the 2.5-D homography route, a stereo camera) it is
refused, as is IPPE on markers off one plane. The compiled frame path, ``simulate_batch`` and a
campaign label ``ibvs-current[pnp=ippe]`` carry it.
"""

from __future__ import annotations

import numpy as np
import pytest

import ibvs_youla as iy
from feature_laws import IRREGULAR_O, SETTINGS, SQUARE_O, TARGET, TUTORIAL_START, P_C_of
from ibvs_youla.campaign.run import run_spec, run_specs
from ibvs_youla.campaign.spec import ExperimentSpec, parse_method
from ibvs_youla.controllers import ServoTask
from ibvs_youla.controllers.ibvs import ClassicalIBVS
from ibvs_youla.controllers.moments import MomentIBVS
from ibvs_youla.controllers.two_half_d import TwoHalfD
from ibvs_youla.estimation.monocular_pose import PNP_METHODS, CameraPoseEstimator, estimate_pose_monocular
from ibvs_youla.exceptions import InvalidParameterError
from ibvs_youla.model.camera import project_points

# name -> (further parameters of make, markers)
CASES = {
    "ibvs-current": ({}, SQUARE_O),
    "ibvs-mean": ({}, SQUARE_O),
    "pbvs": ({}, SQUARE_O),
    "2.5d": ({}, SQUARE_O),
    "hybrid": ({}, SQUARE_O),
    "mpc-ibvs": ({}, SQUARE_O),
    "ibvs-polar": ({}, SQUARE_O),
    "ibvs-partitioned": ({}, SQUARE_O),
    "ibvs-moments": ({"interaction": "current"}, IRREGULAR_O),  # the moments refuse the square
}
DURATION = 1.0  # [s], 26 frames
# Noise-free, SQPnP and IPPE both give the exact pose: measured max |difference| of the features and
# camera poses 1.5e-13 (ibvs-current) to 3.7e-12 (pbvs) over 1 s, and the same up to 10 s except the
# moments' "current" law, chaotic near the goal (docs/controllers.md); the bound leaves 27x margin.
NOISE_FREE_TOLERANCE = 1e-10
NOISE = iy.Disturbances(pixel_noise_px=1.0, seed=7)  # 1 px at the normalized camera's 800 px
# With that noise the two methods' estimates of one noisy image differ: measured 5.0e-4
# (ibvs-current, hybrid, mpc-ibvs) to 1.5e-2 (ibvs-polar), 1e5 times the noise-free agreement
NOISY_MIN_DIFFERENCE = 1e-5
COMPILED_TOLERANCE = 1e-12  # tests/test_compiled_frame_path.py's; IPPE measured 3.3e-15 (SQPnP: 1.2e-11)


def scenario(markers_O):
    return iy.Scenario.free_camera(T_O_C_start=TUTORIAL_START, T_O_C_target=TARGET, markers_O=markers_O)


def run(name, pnp, disturbances=None, duration=DURATION, **kwargs):
    extra, markers_O = CASES[name]
    return iy.simulate(
        scenario(markers_O),
        iy.controllers.make(name, pnp=pnp, **extra),
        plant="free-camera",
        camera=iy.PinholeCamera.normalized(),
        duration=duration,
        settings=SETTINGS,
        disturbances=disturbances,
        **kwargs,
    )


def largest_difference(a, b):
    """max |a - b| over the recorded features and camera poses of two runs of one length."""
    assert a.features.shape == b.features.shape and a.status == b.status == "complete"
    return max(np.abs(a.features - b.features).max(), np.abs(a.camera_pose - b.camera_pose).max())


def task(markers_O, camera=None):
    camera = iy.PinholeCamera.normalized() if camera is None else camera
    return ServoTask(
        camera=camera,
        markers_O=markers_O,
        feature_target=project_points(camera, P_C_of(TARGET, markers_O), False),
        T_O_C_target=TARGET,
        tick_period=0.04,
        frame_period=0.04,
    )


@pytest.mark.parametrize("name", CASES)
def test_noise_free_ippe_gives_the_sqpnp_run(name):
    """Both methods are exact on exact features of coplanar points: the runs agree to rounding."""
    assert largest_difference(run(name, "sqpnp"), run(name, "ippe")) < NOISE_FREE_TOLERANCE


@pytest.mark.parametrize("name", CASES)
def test_with_pixel_noise_the_option_changes_the_run(name):
    """The two methods' poses of a noisy image differ, and so do the runs (the same noise draws)."""
    assert largest_difference(run(name, "sqpnp", NOISE), run(name, "ippe", NOISE)) > NOISY_MIN_DIFFERENCE


@pytest.mark.parametrize("name", CASES)
def test_the_controllers_pose_is_the_chosen_methods(name):
    """After reset, the controller's estimator gives estimate_pose_monocular's pose of that method.

    On a noisy image (seeded, 1e-3 in normalized units) the two methods' poses differ by more than
    1e-6 (measured 9.4e-3 for the square, 8.9e-2 for the seven points, largest entry of T_O_C);
    the controller's is the chosen one's, to the last bit.
    """
    extra, markers_O = CASES[name]
    camera = iy.PinholeCamera.normalized()
    T_O_C = TUTORIAL_START
    features = project_points(camera, P_C_of(T_O_C, markers_O), False)
    features = features + 1e-3 * np.random.default_rng(3).standard_normal(features.shape)
    poses = {m: estimate_pose_monocular(camera, features, markers_O, method=m) for m in ("sqpnp", "ippe")}
    assert np.abs(poses["sqpnp"] - poses["ippe"]).max() > 1e-6
    for pnp, pose in poses.items():
        controller = iy.controllers.make(name, pnp=pnp, **extra)
        controller.reset(task(markers_O))
        np.testing.assert_array_equal(controller.pose_estimator(features), pose)


@pytest.mark.parametrize("name", [n for n in CASES if n != "ibvs-moments"])
def test_ippe_on_markers_off_one_plane_is_refused_at_reset(name):
    """A fifth marker 5 cm off the square's plane: IPPE refused at reset, naming what is valid.

    (The moments refuse such markers whatever the method: tests/test_moment_ibvs.py.) SQPnP, the
    same controller without the option, takes them.
    """
    markers_O = np.vstack((SQUARE_O, [0.0, 0.05, 0.05]))
    iy.controllers.make(name, pnp="sqpnp").reset(task(markers_O))
    with pytest.raises(
        InvalidParameterError, match=r"received 'ippe'.*'sqpnp', 'epnp' or 'iterative'.*coplanar"
    ):
        iy.controllers.make(name, pnp="ippe").reset(task(markers_O))


def test_the_estimator_refuses_ippe_off_one_plane_once_at_construction():
    """CameraPoseEstimator(method="ippe"): relative out-of-plane extent > 1e-9 refused, <= accepted."""
    camera = iy.PinholeCamera.normalized()
    tilted = SQUARE_O @ np.linalg.qr(np.random.default_rng(5).standard_normal((3, 3)))[0].T
    CameraPoseEstimator(camera, tilted, method="ippe")  # coplanar, any plane: round-off only
    off = tilted.copy()
    off[0] += 1e-6 * np.array([0.0, 0.0, 1.0])  # 1e-6 m off a 0.28 m square: ~1.8e-6 relative
    with pytest.raises(InvalidParameterError, match="IPPE needs coplanar markers"):
        CameraPoseEstimator(camera, off, method="ippe")
    CameraPoseEstimator(camera, off, method="sqpnp")


@pytest.mark.parametrize("name", CASES)
@pytest.mark.parametrize("bad", ["p3p", "IPPE", 3, None])
def test_unknown_methods_are_refused_with_the_valid_ones(name, bad):
    extra, _ = CASES[name]
    with pytest.raises(
        InvalidParameterError, match=r"pnp: received .*'sqpnp' or 'epnp' or 'iterative' or 'ippe'"
    ):
        iy.controllers.make(name, pnp=bad, **extra)


@pytest.mark.parametrize("name", CASES)
def test_a_stereo_camera_takes_only_the_default(name):
    """A stereo camera's pose is P3P on triangulated points: a PnP method would not act, so is refused."""
    extra, markers_O = CASES[name]
    stereo = task(markers_O, iy.StereoCamera.zed2())
    iy.controllers.make(name, pnp="sqpnp", **extra).reset(stereo)
    with pytest.raises(InvalidParameterError, match=r"pnp: received 'ippe'.*StereoCamera.*monocular"):
        iy.controllers.make(name, pnp="ippe", **extra).reset(stereo)


def test_laws_that_estimate_no_pose_refuse_the_option():
    """ibvs-desired's factory has no pnp; L* or the homography route would leave a choice unused."""
    with pytest.raises(InvalidParameterError, match="parameters of 'ibvs-desired': gain"):
        iy.controllers.make("ibvs-desired", pnp="ippe")
    with pytest.raises(InvalidParameterError, match="interaction='desired', which estimates no pose"):
        ClassicalIBVS("desired", pnp="ippe")
    with pytest.raises(InvalidParameterError, match="interaction='desired', which estimates no pose"):
        iy.controllers.make("ibvs-moments", pnp="ippe")  # the moments' default interaction
    with pytest.raises(InvalidParameterError, match="rotation_from='homography', which estimates no PnP"):
        TwoHalfD(rotation_from="homography", pnp="ippe")
    assert ClassicalIBVS("desired", pnp="sqpnp").pnp == MomentIBVS("desired").pnp == "sqpnp"


@pytest.mark.parametrize("name", CASES)
def test_the_spec_names_the_method_only_when_chosen(name):
    """The metadata of runs with the default are as before the option; a chosen method is recorded."""
    extra, _ = CASES[name]
    assert "pnp" not in iy.controllers.make(name, **extra).spec()
    for pnp in PNP_METHODS[1:]:
        assert iy.controllers.make(name, pnp=pnp, **extra).spec()["pnp"] == pnp


@pytest.mark.parametrize("name", ["ibvs-current", "ibvs-mean"])
def test_the_compiled_frame_path_takes_the_option(name):
    """With IPPE the compiled path gives the plug-in loop's run to 1e-12 (with SQPnP only to 1e-7).

    IPPE is a closed form, so the compiled path's features (equal to the last bits or nearly) give
    its pose to rounding; SQPnP's stopping step bounds the agreement with it
    (tests/test_compiled_frame_path.py): with SQPnP this case differs by 1.2e-11 (ibvs-current). Every
    PnP the compiled run solves is IPPE's (a spy on the OpenCV call).
    """
    from unittest import mock

    import cv2

    solved, real = [], cv2.solvePnP

    def spy(*args, **kwargs):
        solved.append(kwargs["flags"])
        return real(*args, **kwargs)

    with mock.patch.object(cv2, "solvePnP", spy):
        compiled = run(name, "ippe", duration=3.0)
    # one PnP a frame, IPPE's
    assert len(solved) == len(compiled.frame_t) and set(solved) == {cv2.SOLVEPNP_IPPE}
    plugged = run(name, "ippe", duration=3.0, loop="plug-in")
    assert compiled.metadata["loop"] == "compiled" and plugged.metadata["loop"] == "plug-in"
    assert compiled.metadata["spec"]["controller"]["pnp"] == "ippe"
    for key in plugged.signals:
        np.testing.assert_allclose(
            compiled.signals[key], plugged.signals[key], rtol=0, atol=COMPILED_TOLERANCE
        )
    assert largest_difference(compiled, plugged) < COMPILED_TOLERANCE


def test_simulate_batch_gives_each_case_simulates_run_with_the_option():
    """simulate_batch with ibvs-current(pnp="ippe"): each case is simulate()'s run with the same option.

    The batch covers no noise; markers believed a few mm off the truth in their plane play its part
    (the image is then no exact view of the believed markers, so the two methods' poses differ): the
    batch's runs equal simulate()'s with IPPE bit for bit, and differ from those with SQPnP
    (measured 1.5e-3 and 1.3e-3 in the features).
    """
    scales = (1.0, 1.2)
    scenarios = [scenario(k * SQUARE_O) for k in scales]
    off_O = np.array([[0.005, 0.0, 0.0], [0.0, -0.004, 0.0], [0.003, 0.002, 0.0], [0.0, 0.0, 0.0]])  # [m]
    beliefs = [iy.Beliefs(markers_O=k * SQUARE_O + off_O) for k in scales]
    kwargs = {
        "plant": "free-camera",
        "camera": iy.PinholeCamera.normalized(),
        "duration": 2.0,
        "settings": SETTINGS,
    }
    batch = iy.simulate_batch(
        scenarios, iy.controllers.make("ibvs-current", pnp="ippe"), beliefs=beliefs, **kwargs
    )
    assert batch.rerun == ()
    for case, belief, result in zip(scenarios, beliefs, batch, strict=True):
        alone = {
            pnp: iy.simulate(case, iy.controllers.make("ibvs-current", pnp=pnp), beliefs=belief, **kwargs)
            for pnp in ("ippe", "sqpnp")
        }
        assert largest_difference(result, alone["ippe"]) == 0.0
        assert np.abs(result.features - alone["sqpnp"].features).max() > 1e-4
        assert result.metadata["spec"]["controller"]["pnp"] == "ippe"


def test_a_campaign_label_chooses_the_method():
    """``ibvs-current[pnp=ippe]``: parsed, run alone, in a batch (one row); keyed apart from the default."""
    name, params = parse_method("ibvs-current[pnp=ippe]")
    assert (name, params) == ("ibvs-current", {"pnp": "ippe"})

    def spec(controller_params):
        return ExperimentSpec(
            family="free-camera", case=0, seed=1, scenario=scenario(SQUARE_O).to_dict(), controller=name,
            controller_params=controller_params, plant="free-camera", camera={"kind": "normalized"},
            duration=1.0, settings={"camera_rate_hz": 25.0},
        )  # fmt: skip

    chosen, default = spec(params), spec({})
    assert chosen.method == "ibvs-current[pnp=ippe]" and default.method == "ibvs-current"
    assert chosen.key != default.key  # the runs of either method are stored apart
    alone = run_spec(chosen)
    in_batch = run_specs([chosen, chosen])
    assert alone["outcome"] != "error" and alone["status"] == "complete"
    assert alone["controller"] == in_batch[0]["controller"] == "ibvs-current[pnp=ippe]"
    assert alone["final_position_mm"] == in_batch[0]["final_position_mm"] == in_batch[1]["final_position_mm"]
    refused = run_spec(ExperimentSpec.from_json(chosen.to_json().replace("ibvs-current", "ibvs-desired")))
    assert refused["outcome"] == "error" and "pnp" in refused["error"]


# The image of the converged ViSP tutorial run (R_C_O = I at 0.75 m) after 841 frames with pnp="ippe":
# features 1e-8 off the target's, a view within rounding of fronto-parallel.
FRONTO_PARALLEL = np.array(
    [
        [-0.13333332114408078, -0.13333333784573506],
        [0.13333333961395516, -0.1333333311586877],
        [0.1333333333417445, 0.13333332921187108],
        [-0.13333332744365126, 0.13333332332713715],
    ]
)


def test_an_image_ippe_finds_no_pose_for_is_solved_by_sqpnp():
    """OpenCV's IPPE returns NaN (reporting success) on this view; the estimator solves it by SQPnP,
    counts it, and its depths are the truth (Z = 0.75 m to 2e-8, the features' offset), where
    estimate_pose_monocular(method="ippe"), one named solver, raises. If a newer OpenCV solves the
    view, the first assertion fails: IPPE_FALLBACK's comment must then say which versions need it."""
    import cv2

    from ibvs_youla.exceptions import PoseEstimationError

    square = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]
    _, rvec, tvec = cv2.solvePnP(square, FRONTO_PARALLEL, np.eye(3), None, flags=cv2.SOLVEPNP_IPPE)
    assert not np.isfinite(rvec).any() and not np.isfinite(tvec).any(), cv2.__version__
    camera = iy.PinholeCamera.normalized()
    with pytest.raises(PoseEstimationError, match=r"OpenCV solvePnP \(ippe\) found no pose for 4 points"):
        estimate_pose_monocular(camera, FRONTO_PARALLEL, square, method="ippe")
    estimator = CameraPoseEstimator(camera, square, method="ippe")
    np.testing.assert_allclose(estimator.marker_depths(FRONTO_PARALLEL.ravel()), 0.75, rtol=0, atol=2e-8)
    np.testing.assert_array_equal(
        estimator(FRONTO_PARALLEL.ravel()), estimate_pose_monocular(camera, FRONTO_PARALLEL, square, "sqpnp")
    )
    assert estimator.fallbacks == 1
    assert CameraPoseEstimator(camera, square, method="sqpnp").fallbacks == 0


def test_the_tutorial_run_with_ippe_holds_its_converged_target():
    """ViSP's tutorial case for 120 s with pnp="ippe": it converges and stays (the run met the view
    above at t = 33.68 s and ended "estimate_failed" before the fallback); the features end on the
    target's to 1e-7, as the SQPnP run's. The images solved by SQPnP are counted in the metadata by
    the compiled loop, the plug-in loop and simulate_batch alike; a run without any has no entry."""
    scenario = iy.Scenario.free_camera(T_O_C_start=TUTORIAL_START, T_O_C_target=TARGET, markers_O=SQUARE_O)
    kwargs = {
        "plant": "free-camera",
        "camera": iy.PinholeCamera.normalized(25.0),
        "duration": 120.0,
        "settings": SETTINGS,
    }
    results = {
        "sqpnp": iy.simulate(scenario, iy.controllers.make("ibvs-current", pnp="sqpnp"), **kwargs),
        "ippe": iy.simulate(scenario, iy.controllers.make("ibvs-current", pnp="ippe"), **kwargs),
        "ippe, plug-in": iy.simulate(
            scenario, iy.controllers.make("ibvs-current", pnp="ippe"), loop="plug-in", **kwargs
        ),
        "ippe, batch": iy.simulate_batch(
            [scenario], iy.controllers.make("ibvs-current", pnp="ippe"), **kwargs
        )[0],
    }
    target = np.asarray(results["sqpnp"].feature_target)
    for name, result in results.items():
        assert result.metadata["status"] == "complete", (name, result.metadata.get("error"))
        assert np.abs(np.asarray(result.frame_features)[-1] - target).max() < 1e-7, name
    assert "pnp_fallbacks" not in results["sqpnp"].metadata
    assert results["ippe"].metadata["loop"] == "compiled"
    assert results["ippe, batch"].metadata["loop"] == "batch"
    counts = {name: results[name].metadata.get("pnp_fallbacks", 0) for name in results if name != "sqpnp"}
    assert all(count > 0 for count in counts.values()), counts
    assert counts["ippe"] == counts["ippe, batch"]  # the same calls in the same order
