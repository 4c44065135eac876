"""Bad arguments for the public functions and objects: a typed error that names the argument.

Wrong types, non-finite and out-of-range values, and wrong shapes, across the API: ``simulate``
and its options, the arm, the cameras, the eye-in-hand model and pose estimation, scenarios, the
controller registry, comparisons, the Section 7 reproduction, the suite and campaigns. Each row
asserts the exception type and that the message names the argument as the user wrote it
(``"beliefs.arm"``, ``"gain"``, ...).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import ibvs_youla as iy
from bad_input_rows import case, check
from ibvs_youla import controllers, scenarios
from ibvs_youla.analysis import suites
from ibvs_youla.analysis.compare import compare
from ibvs_youla.analysis.convergence import classify
from ibvs_youla.analysis.metrics import final_error, settling_time
from ibvs_youla.analysis.reproduce import reproduce
from ibvs_youla.campaign.cases import generate_cases
from ibvs_youla.campaign.runner import CampaignDefinition
from ibvs_youla.campaign.spec import ExperimentSpec
from ibvs_youla.controllers import ServoTask, YoulaController
from ibvs_youla.controllers.ibvs import ClassicalIBVS
from ibvs_youla.estimation.hand_eye import calibrate_hand_eye
from ibvs_youla.estimation.monocular_pose import estimate_camera_pose, estimate_pose_monocular
from ibvs_youla.estimation.stereo_pose import estimate_pose, rigid_transform_from_points
from ibvs_youla.exceptions import DegenerateMarkersError, InvalidArrayError, InvalidParameterError
from ibvs_youla.model.camera import PinholeCamera, StereoCamera, default_camera
from ibvs_youla.simulation.inner_loop import inner_step_response
from ibvs_youla.viz.playback import playback_frames

P = InvalidParameterError
A = InvalidArrayError


@functools.cache
def _arm():
    return iy.Arm.irb4600()


@functools.cache
def _model():
    return _arm().model


@functools.cache
def _cam():
    return StereoCamera.zed2()


@functools.cache
def _eye():
    return iy.EyeInHand(_arm(), _cam(), MARKERS, virtual_points=True)


MARKERS = scenarios.PAPER_MARKERS_O
SC = scenarios.paper(1)
FREE = iy.Scenario.free_camera(np.eye(4), np.eye(4), [[0, 0, 2], [1, 0, 2], [0, 1, 2]])
LENS = {"focal_length": 2.8e-3, "sensor_width": 5.2e-3, "sensor_height": 2.9e-3, "pixel_pitch": 4e-6}
STEREO = {**LENS, "baseline": 0.12}
FEATURES = np.full(9, 1e-4)
ROTATION = "rotation about the optical axis"  # a test of the Gans 2003 suite


def _sim(**kwargs):
    return lambda: iy.simulate(**{"scenario": SC, "duration": 0.01, **kwargs})


# --------------------------------------------------------------------------- simulate
SIMULATE = [
    case(_sim(adaptive="false"), P, "adaptive", "adaptive-str-false"),
    case(_sim(adaptive=1), P, "adaptive", "adaptive-int"),
    case(_sim(adaptive=None), P, "adaptive", "adaptive-none"),
    case(_sim(progress="yes"), P, "progress", "progress-str"),
    case(_sim(duration="10"), P, "duration", "duration-str"),
    case(_sim(duration=True), P, "duration", "duration-bool"),
    case(_sim(duration=-1.0), P, "duration", "duration-negative"),
    case(_sim(duration=float("nan")), P, "duration", "duration-nan"),
    case(_sim(duration=1e-4), P, "duration", "duration-below-one-tick"),
    case(_sim(duration=6e-4), P, "duration", "duration-shorter-than-one-joint-step"),
    case(_sim(duration=1e12), P, "duration", "duration-too-large-for-memory"),
    case(_sim(duration=1e308), P, "duration", "duration-ticks-overflow-a-float"),
    case(
        lambda: iy.simulate(SC, duration=3e7, settings=iy.SimulationSettings(record_every=2)),
        P,
        "duration",
        "memory-record",
    ),
    case(_sim(plant="rigid"), P, "plant", "plant-unknown"),
    case(_sim(plant=None), P, "plant", "plant-none"),
    case(_sim(plant=["dynamic"]), P, "plant", "plant-list"),
    case(_sim(scenario=None), P, "scenario", "scenario-none"),
    case(_sim(scenario="paper-1"), P, "scenario", "scenario-name"),
    case(_sim(settings={}), P, "settings", "settings-dict"),
    case(_sim(arm="irb4600"), P, "arm", "arm-str"),
    case(_sim(camera="zed2"), P, "camera", "camera-str"),
    case(_sim(beliefs=1), P, "beliefs", "beliefs-int"),
    case(_sim(controller=123), P, "controller", "controller-int"),
    case(_sim(controller="nope"), P, "controller", "controller-unknown"),
    case(_sim(controller=ClassicalIBVS), P, "controller", "controller-class"),
    case(_sim(controller=["fb"]), P, "controller", "controller-list"),
    case(
        lambda: iy.simulate(
            SC, duration=0.1, settings=iy.SimulationSettings(joint_rate_hz=50.0, camera_rate_hz=50.0)
        ),
        P,
        "joint_rate_hz",
        "joint-rate-below-1/tau",
    ),
    case(_sim(scenario=FREE), P, "plant", "free-scenario-on-arm-plant"),
    case(lambda: iy.Beliefs(arm="irb4600"), P, "beliefs.arm", "beliefs-arm-str"),
    case(lambda: iy.Beliefs(camera=3), P, "beliefs.camera", "beliefs-camera-int"),
    case(lambda: iy.Beliefs(markers_O="abc"), A, "beliefs.markers_O", "beliefs-markers-str"),
]


@pytest.mark.parametrize(("call", "error", "name"), SIMULATE)
def test_simulate_rejects(call, error, name):
    check(call, error, name)


def test_a_run_too_large_for_memory_says_its_size_and_what_reduces_it():
    err = check(_sim(duration=1e12), P, "duration")
    text = str(err)
    assert "record_every" in text and "shorter duration" in text
    assert " PB" in text or " EB" in text  # 1e15 samples of some 200 bytes


# --------------------------------------------------------------------------- arm
ARM = [
    case(lambda: iy.Arm(None), P, "model", "arm-none"),
    case(lambda: iy.Arm("urdf/abb_irb4600_45_205.urdf"), P, "model", "arm-path-str"),
    case(lambda: iy.Arm(_model(), camera_frame=1), P, "camera_frame", "arm-camera-frame-int"),
    case(
        lambda: iy.Arm(_model(), camera_frame="camera", flange_frame=3), P, "flange_frame", "arm-flange-int"
    ),
    case(lambda: iy.Arm(_model(), name=3), P, "name", "arm-name-int"),
    case(lambda: iy.Arm(_model(), armature="x"), A, "armature", "arm-armature-str"),
    case(lambda: iy.Arm.irb4600(actuator="motor"), P, "actuator", "irb-actuator-unknown"),
    case(lambda: iy.Arm.irb4600(actuator=None), P, "actuator", "irb-actuator-none"),
    case(lambda: iy.Arm.from_urdf(None), P, "path", "from-urdf-none"),
    case(lambda: iy.Arm.from_urdf(3.0), P, "path", "from-urdf-float"),
    case(lambda: _arm().with_inertia_scale("2"), P, "factor", "inertia-scale-str"),
    case(lambda: _arm().with_inertia_scale(True), P, "factor", "inertia-scale-bool"),
    case(lambda: _arm().within_limits(np.zeros(6), tol="0"), P, "tol", "within-limits-tol-str"),
    case(lambda: _arm().camera_pose("abc"), A, "q", "camera-pose-str"),
    case(lambda: _arm().camera_pose(np.zeros(5)), A, "q", "camera-pose-shape"),
    case(lambda: _arm().ik(None), A, "T_O_C", "ik-none"),
    case(lambda: _arm().with_hand_eye(np.eye(3)), A, "T_E_C", "hand-eye-shape"),
    case(lambda: _arm().forward_dynamics(np.zeros(6), np.zeros(6), [np.nan] * 6), A, "tau", "aba-nan"),
]


@pytest.mark.parametrize(("call", "error", "name"), ARM)
def test_arm_rejects(call, error, name):
    check(call, error, name)


# --------------------------------------------------------------------------- eye-in-hand and pose estimation
ESTIMATION = [
    case(lambda: iy.EyeInHand(None, _cam(), MARKERS), P, "arm", "eye-arm-none"),
    case(lambda: iy.EyeInHand("irb4600", _cam(), MARKERS), P, "arm", "eye-arm-str"),
    case(lambda: iy.EyeInHand(_arm(), None, MARKERS), P, "camera", "eye-camera-none"),
    case(lambda: iy.EyeInHand(_arm(), PinholeCamera.normalized(), MARKERS), P, "camera", "eye-camera-mono"),
    case(lambda: iy.EyeInHand(_arm(), _cam(), MARKERS, virtual_points="no"), P, "virtual_points", "eye-vp"),
    case(lambda: iy.EyeInHand(_arm(), _cam(), "abc"), A, "markers_O", "eye-markers-str"),
    case(
        lambda: iy.EyeInHand(_arm(), _cam(), np.zeros((3, 3))),
        DegenerateMarkersError,
        "markers_O",
        "eye-coinc",
    ),
    case(lambda: _eye().features(np.zeros(5)), A, "q", "eye-features-q-shape"),
    case(lambda: _eye().jacobian([np.inf] * 6), A, "q", "eye-jacobian-inf"),
    case(lambda: _eye().estimate_q(np.ones(8), np.zeros(6)), A, "features", "eye-estimate-shape"),
    case(lambda: estimate_pose(None, FEATURES, MARKERS), P, "camera", "estimate-pose-no-camera"),
    case(
        lambda: estimate_pose(PinholeCamera.normalized(), FEATURES, MARKERS),
        P,
        "camera",
        "estimate-pose-mono",
    ),
    case(
        lambda: estimate_pose(_cam(), FEATURES, MARKERS, allow_behind="yes"), P, "allow_behind", "est-behind"
    ),
    case(lambda: estimate_pose(_cam(), np.ones(8), MARKERS), A, "features", "estimate-pose-shape"),
    case(lambda: estimate_pose(_cam(), FEATURES, "abc"), A, "P_ref", "estimate-pose-P_ref-str"),
    case(lambda: estimate_camera_pose(None, FEATURES, MARKERS), P, "camera", "estimate-camera-pose-none"),
    case(lambda: estimate_pose_monocular(_cam(), np.ones(8), MARKERS), P, "camera", "monocular-stereo"),
    case(lambda: estimate_pose_monocular(None, np.ones(8), MARKERS), P, "camera", "monocular-none"),
    case(
        lambda: estimate_pose_monocular(PinholeCamera.normalized(), np.ones(8), np.eye(4, 3), method="dlt"),
        P,
        "method",
        "monocular-method",
    ),
    case(lambda: rigid_transform_from_points("abc", MARKERS), A, "P_from", "kabsch-P_from-str"),
    case(lambda: rigid_transform_from_points(MARKERS, MARKERS[:2]), A, "P_to", "kabsch-P_to-shape"),
    case(lambda: calibrate_hand_eye(None, None), A, "A", "hand-eye-none"),
]


@pytest.mark.parametrize(("call", "error", "name"), ESTIMATION)
def test_estimation_rejects(call, error, name):
    check(call, error, name)


# --------------------------------------------------------------------------- scenarios
SCENARIOS = [
    case(lambda: scenarios.get(["paper-1"]), P, "scenario", "get-list"),
    case(lambda: scenarios.get(None), P, "scenario", "get-none"),
    case(lambda: scenarios.get(1), P, "scenario", "get-int"),
    case(lambda: scenarios.get("paper-3"), P, "scenario", "get-unknown"),
    case(lambda: scenarios.get({"paper-1"}), P, "scenario", "get-set"),
    case(lambda: scenarios.paper("1"), P, "index", "paper-index-str"),
    case(lambda: scenarios.paper(True), P, "index", "paper-index-bool"),
    case(lambda: scenarios.paper(1.5), P, "index", "paper-index-float"),
    case(lambda: scenarios.physical(None), P, "index", "physical-index-none"),
    case(lambda: scenarios.physical([1]), P, "index", "physical-index-list"),
    case(lambda: iy.Scenario("abc", np.zeros(6), MARKERS), A, "q_start", "scenario-q_start-str"),
    case(lambda: iy.Scenario(np.zeros(6), np.zeros(6), MARKERS, name=1), P, "name", "scenario-name-int"),
    case(
        lambda: iy.Scenario(np.zeros(6), np.zeros(6), MARKERS, virtual_points="yes"),
        P,
        "virtual_points",
        "scenario-vp-str",
    ),
    case(lambda: iy.Scenario(np.zeros(6), np.zeros(6), None), P, "markers_O", "scenario-markers-none"),
    case(
        lambda: iy.Scenario(np.zeros(6), np.zeros(6), MARKERS, joint_offset=[1.0]),
        A,
        "joint_offset",
        "offset",
    ),
    case(
        lambda: iy.Scenario.free_camera(np.eye(3), np.eye(4), MARKERS), A, "T_O_C_start", "free-start-shape"
    ),
    case(
        lambda: iy.Scenario(np.zeros(6), np.zeros(6), MARKERS, description=3), P, "description", "descr-int"
    ),
]


@pytest.mark.parametrize(("call", "error", "name"), SCENARIOS)
def test_scenarios_reject(call, error, name):
    check(call, error, name)


# --------------------------------------------------------------------------- cameras
CAMERAS = [
    case(lambda: StereoCamera(**STEREO, skew="abc"), P, "skew", "skew-str"),
    case(lambda: StereoCamera(**STEREO, skew=True), P, "skew", "skew-bool"),
    case(lambda: StereoCamera(**STEREO, skew=1j), P, "skew", "skew-complex"),
    case(lambda: StereoCamera(**STEREO, skew=None), P, "skew", "skew-none"),
    case(lambda: StereoCamera(**{**STEREO, "focal_length": "0.0028"}), P, "focal_length", "focal-str"),
    case(lambda: StereoCamera(**{**STEREO, "focal_length": True}), P, "focal_length", "focal-bool"),
    case(lambda: StereoCamera(**{**STEREO, "baseline": "0.12"}), P, "baseline", "baseline-str"),
    case(lambda: StereoCamera(**{**STEREO, "baseline": None}), P, "baseline", "baseline-none"),
    case(lambda: StereoCamera(**STEREO, principal_point="ab"), P, "principal_point", "pp-str"),
    case(lambda: StereoCamera(**STEREO, principal_point=(1, "a")), P, "principal_point", "pp-mixed"),
    case(lambda: StereoCamera(**STEREO, principal_point=(True, 1)), P, "principal_point", "pp-bool"),
    case(lambda: StereoCamera(**STEREO, depth_range=(1,)), P, "depth_range", "depth-range-short"),
    case(lambda: StereoCamera(**STEREO, depth_range=("a", "b")), P, "depth_range", "depth-range-str"),
    case(lambda: StereoCamera(**STEREO, depth_range=(2.0, 1.0)), P, "depth_range", "depth-range-reversed"),
    case(lambda: StereoCamera(**STEREO, depth_range=3.0), P, "depth_range", "depth-range-scalar"),
    case(lambda: StereoCamera(**STEREO, frame_rate=True), P, "frame_rate", "frame-rate-bool"),
    case(lambda: StereoCamera(**STEREO, name=3), P, "name", "name-int"),
    case(lambda: StereoCamera(**STEREO, unbounded_view="yes"), P, "unbounded_view", "unbounded-str"),
    case(lambda: PinholeCamera(**{**LENS, "sensor_width": "x"}), P, "sensor_width", "pinhole-width-str"),
    case(lambda: PinholeCamera(**{**LENS, "pixel_pitch": 0.0}), P, "pixel_pitch", "pinhole-pitch-zero"),
    case(lambda: StereoCamera.zed2(preset=1), P, "preset", "zed2-preset-int"),
    case(lambda: StereoCamera.zed2(mode=["VGA"]), P, "mode", "zed2-mode-list"),
    case(lambda: StereoCamera.zed2(frame_rate="100"), P, "frame_rate", "zed2-rate-str"),
    case(lambda: StereoCamera.zed2(mode="VGA", frame_rate=True), P, "frame_rate", "zed2-rate-bool"),
    case(lambda: PinholeCamera.normalized(frame_rate="30"), P, "frame_rate", "normalized-rate-str"),
    case(lambda: default_camera(mode="4K"), P, "mode", "default-camera-mode"),
    case(lambda: _cam().project("abc"), A, "P_C", "project-str"),
    case(lambda: _cam().project([[0, 0, 2.0]], allow_behind="no"), P, "allow_behind", "project-behind-str"),
    case(lambda: _cam().triangulate(np.ones((1, 4))), A, "features", "triangulate-shape"),
]


@pytest.mark.parametrize(("call", "error", "name"), CAMERAS)
def test_cameras_reject(call, error, name):
    check(call, error, name)


# --------------------------------------------------------------------------- controllers
def _task(**overrides):
    base = dict(
        camera=_cam(),
        markers_O=MARKERS,
        feature_target=FEATURES,
        T_O_C_target=np.eye(4),
        tick_period=1e-3,
        frame_period=1e-2,
    )
    return lambda: ServoTask(**{**base, **overrides})


CONTROLLERS = [
    case(lambda: controllers.make("nope"), P, "controller", "make-unknown"),
    case(lambda: controllers.make(None), P, "controller", "make-none"),
    case(lambda: controllers.make(["fb"]), P, "controller", "make-list"),
    case(lambda: controllers.make("ibvs-current", gain="0.5"), P, "gain", "ibvs-gain-str"),
    case(lambda: controllers.make("ibvs-current", gain=True), P, "gain", "ibvs-gain-bool"),
    case(lambda: controllers.make("ibvs-current", gain={"lambda_0": 1}), P, "gain", "ibvs-gain-dict"),
    case(lambda: controllers.make("ibvs-current", interaction=1), P, "interaction", "ibvs-interaction-int"),
    case(lambda: controllers.make("ibvs-current", bogus=1), P, "bogus", "ibvs-unknown-param"),
    case(lambda: controllers.make("pbvs", gain=-1.0), P, "gain", "pbvs-gain-negative"),
    case(lambda: controllers.make("pbvs", gain="1"), P, "gain", "pbvs-gain-str"),
    case(lambda: controllers.make("hybrid", min_dwell=2.5), P, "min_dwell", "hybrid-dwell-float"),
    case(lambda: controllers.make("hybrid", margin="0"), P, "margin", "hybrid-margin-str"),
    case(lambda: controllers.make("hybrid", start_mode=None), P, "start_mode", "hybrid-mode-none"),
    case(lambda: controllers.make("mpc-ibvs", horizon=True), P, "horizon", "mpc-horizon-bool"),
    case(lambda: controllers.make("mpc-ibvs", fallback=None), P, "fallback", "mpc-fallback-none"),
    case(lambda: controllers.make("mpc-ibvs", solver=1), P, "solver", "mpc-solver-int"),
    case(lambda: controllers.make("mpc-ibvs", v_max="1"), P, "v_max", "mpc-vmax-str"),
    case(lambda: controllers.make("mpc-ibvs", r_weight=float("nan")), P, "r_weight", "mpc-r-nan"),
    case(lambda: controllers.make("2.5d", rotation_from=2), P, "rotation_from", "2.5d-rotation-int"),
    case(
        lambda: controllers.make("2.5d", reference_point=np.array([0])),
        P,
        "reference_point",
        "2.5d-ref-array",
    ),
    case(lambda: controllers.make("2.5d", reference_point=1.5), P, "reference_point", "2.5d-ref-float"),
    case(lambda: controllers.make("2.5d", reference_point=-1), P, "reference_point", "2.5d-ref-negative"),
    case(lambda: controllers.make("fb", adaptive="false"), P, "adaptive", "fb-adaptive-str"),
    case(lambda: controllers.make("ff+fb", zeta="10"), P, "zeta", "ff+fb-zeta-str"),
    case(lambda: controllers.make("ff+fb", settings={}), P, "settings", "ff+fb-settings-dict"),
    case(lambda: controllers.make("fb", nonsense=1), P, "nonsense", "fb-unknown-gain"),
    case(lambda: YoulaController(with_feedforward="yes"), P, "with_feedforward", "youla-ff-str"),
    case(lambda: controllers.register("", ClassicalIBVS, "x"), P, "name", "register-empty"),
    case(lambda: controllers.register("new-one", 3, "x"), P, "factory", "register-not-callable"),
    case(lambda: controllers.register("new-two", ClassicalIBVS, None), P, "summary", "register-summary-none"),
    case(_task(tick_period="0.001"), P, "tick_period", "task-tick-str"),
    case(_task(frame_period=0.0), P, "frame_period", "task-frame-zero"),
    case(_task(markers_O="abc"), A, "markers_O", "task-markers-str"),
    case(_task(feature_target=[np.nan] * 9), A, "feature_target", "task-target-nan"),
    case(_task(T_O_C_target=np.zeros((4, 4))), A, "T_O_C_target", "task-pose-zeros"),
    case(_task(virtual_points="no"), P, "virtual_points", "task-vp-str"),
    case(_task(arm="irb4600"), P, "arm", "task-arm-str"),
    case(_task(arm=_arm(), q_start=np.zeros(5)), A, "q_start", "task-q_start-shape"),
]


@pytest.mark.parametrize(("call", "error", "name"), CONTROLLERS)
def test_controllers_reject(call, error, name):
    check(call, error, name)


# --------------------------------------------------------------------------- analysis and campaigns
def _campaign(**overrides):
    base = dict(family="free-planar", cases=2, controllers=("ibvs-current",))
    return lambda: CampaignDefinition(**{**base, **overrides})


def _spec(**overrides):
    base = dict(
        family="free-planar",
        case=0,
        seed=0,
        scenario=FREE.to_dict(),
        controller="ibvs-current",
        plant="free-camera",
        camera={"kind": "normalized"},
        duration=1.0,
    )
    return lambda: ExperimentSpec(**{**base, **overrides})


ANALYSIS = [
    case(lambda: compare(SC, ["fb"], duration="10"), P, "duration", "compare-duration-str"),
    case(lambda: compare(SC, "fb"), P, "controllers", "compare-controllers-str"),
    case(lambda: compare(None, ["fb"]), P, "scenario", "compare-scenario-none"),
    case(lambda: compare(SC, []), P, "controllers", "compare-controllers-empty"),
    case(lambda: compare(SC, ["fb"], arm="irb4600"), P, "arm", "compare-arm-str"),
    case(lambda: compare(SC, ["fb"], plant=3), P, "plant", "compare-plant-int"),
    case(lambda: reproduce("unused-dir", duration="20"), P, "duration", "reproduce-duration-str"),
    case(
        lambda: reproduce("unused-dir", diagnosis_duration="x"), P, "diagnosis_duration", "reproduce-diag-str"
    ),
    case(
        lambda: reproduce("unused-dir", diagnosis_duration=-1.0),
        P,
        "diagnosis_duration",
        "reproduce-diag-neg",
    ),
    case(
        lambda: reproduce("unused-dir", scenario_names=["nope"]), P, "scenario", "reproduce-scenario-unknown"
    ),
    case(
        lambda: reproduce("unused-dir", scenario_names="paper-1"), P, "scenario_names", "reproduce-names-str"
    ),
    case(lambda: reproduce("unused-dir", settings={}), P, "settings", "reproduce-settings-dict"),
    case(lambda: reproduce("unused-dir", resume="no"), P, "resume", "reproduce-resume-str"),
    case(lambda: reproduce(None), P, "out_dir", "reproduce-out-none"),
    case(lambda: suites.run_suite(duration="x"), P, "duration", "suite-duration-str"),
    case(lambda: suites.run_suite(rate_hz=True), P, "rate_hz", "suite-rate-bool"),
    case(lambda: suites.run_suite(["nope"]), P, "controller", "suite-controller-unknown"),
    case(lambda: suites.task("nope"), P, "task", "suite-task-unknown"),
    case(lambda: suites.task(["gans-rz-180"]), P, "task", "suite-task-list"),
    case(lambda: suites.GansTask("x", "nope"), P, "test", "gans-test-unknown"),
    case(lambda: suites.GansTask("x", ROTATION, rotation_deg="90"), P, "rotation_deg", "gans-rotation-str"),
    case(lambda: suites.GansTask("x", ROTATION, lateral_m=3.0), P, "lateral_m", "gans-lateral-scalar"),
    case(lambda: generate_cases("free-planar", 0, 0), P, "n", "cases-n-zero"),
    case(lambda: generate_cases("free-planar", 2, -1), P, "seed", "cases-seed-negative"),
    case(
        lambda: generate_cases("free-planar", 2, 0, difficulty="1"), P, "difficulty", "cases-difficulty-str"
    ),
    case(lambda: generate_cases(None, 2, 0), P, "family", "cases-family-none"),
    case(_campaign(family="nope"), P, "family", "campaign-family-unknown"),
    case(_campaign(cases=True), P, "cases", "campaign-cases-bool"),
    case(_campaign(cases="3"), P, "cases", "campaign-cases-str"),
    case(_campaign(seed=1.0), P, "seed", "campaign-seed-float"),
    case(_campaign(controllers=()), P, "controllers", "campaign-controllers-empty"),
    case(_campaign(controllers=("nope",)), P, "controllers", "campaign-controllers-unknown"),
    case(_campaign(controllers=3), P, "controllers", "campaign-controllers-int"),
    case(_campaign(camera=3), P, "camera", "campaign-camera-int"),
    case(_campaign(camera="fisheye"), P, "camera.kind", "campaign-camera-unknown"),
    case(_campaign(duration="20"), P, "duration", "campaign-duration-str"),
    case(_campaign(difficulty=True), P, "difficulty", "campaign-difficulty-bool"),
    case(_campaign(settings={"zeta": "10"}), P, "zeta", "campaign-settings-zeta-str"),
    case(_campaign(settings={"bogus": 1}), P, "bogus", "campaign-settings-unknown-key"),
    case(_campaign(settings="x"), P, "settings", "campaign-settings-str"),
    case(_campaign(controller_params={"pbvs": {}}), P, "controller_params", "campaign-params-stray"),
    case(_campaign(controller_params={"ibvs-current": {"gain": "x"}}), P, "gain", "campaign-params-gain-str"),
    case(_campaign(controller_params={"ibvs-current": 3}), P, "controller_params", "campaign-params-int"),
    case(_spec(duration="x"), P, "duration", "spec-duration-str"),
    case(_spec(duration=float("inf")), P, "duration", "spec-duration-inf"),
    case(_spec(case=-1), P, "case", "spec-case-negative"),
    case(_spec(camera=3), P, "camera", "spec-camera-int"),
    case(lambda: settling_time(np.arange(3.0), np.zeros(3), band="0.02"), P, "band", "metrics-band-str"),
    case(lambda: settling_time(np.arange(3.0), np.zeros(3), atol=True), P, "atol", "metrics-atol-bool"),
    case(lambda: classify(None), P, "result", "classify-none"),
    case(lambda: final_error(np.zeros((3, 2)), 1j), A, "y_final", "metrics-final-complex"),
    case(lambda: final_error(np.zeros((3, 2)), np.zeros(3)), A, "y_final", "metrics-final-shape"),
    case(lambda: playback_frames(np.arange(3.0), speed="1"), P, "speed", "playback-speed-str"),
    case(lambda: playback_frames(np.arange(3.0), speed=1e-300), P, "speed", "playback-too-many-frames"),
    case(lambda: generate_cases("free-planar", 10**13, 0), P, "n", "cases-too-many-for-memory"),
    case(
        lambda: inner_step_response(_arm(), np.zeros(6), np.full(6, 0.1), 1e12),
        P,
        "duration",
        "inner-step-huge",
    ),
    case(
        lambda: inner_step_response(_arm(), np.zeros(6), np.full(6, 0.1), 1e-4),
        P,
        "duration",
        "inner-step-short",
    ),
    case(
        lambda: inner_step_response(_arm(), np.zeros(6), np.full(6, 0.1), 1e308),
        P,
        "duration",
        "inner-step-inf",
    ),
    case(
        lambda: inner_step_response(_arm(), np.zeros(6), np.full(6, 0.1), dt="1e-3"),
        P,
        "dt",
        "inner-step-dt-str",
    ),
    case(
        lambda: iy.simulate(
            suites.task("gans-rz-180").scenario(),
            controllers.make("mpc-ibvs", horizon=10**6),
            plant="free-camera",
            camera=suites.suite_camera(),
            settings=suites.suite_settings(),
            duration=1.0,
        ),
        P,
        "horizon",
        "mpc-horizon-too-large-for-memory",
    ),
]


@pytest.mark.parametrize(("call", "error", "name"), ANALYSIS)
def test_analysis_and_campaigns_reject(call, error, name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # reproduce() must refuse before writing, but never in the repository
    check(call, error, name)
    assert not (tmp_path / "unused-dir").exists()  # refused before creating its folders
