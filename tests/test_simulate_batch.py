"""simulate_batch gives each case the result simulate() gives it, on every method x plant x camera it covers.

Every batch here is a few seeded cases (start poses perturbed from a scenario's); each case's result
is compared with ``simulate()`` of the same case, every recorded number: times, camera poses,
features, visibility, every signal, the frame log, the status and the reason of a run that stops
early. The bound is 1e-9 (the brief's); the batch makes the single compiled run's calls in the same
order, so what is measured is 0 (the test says so too: ``EXACT``). Covered: ``ibvs-current``,
``ibvs-desired`` and ``ibvs-mean`` on the free camera and the kinematic arm, with the normalized
camera (a depth sensor, or monocular: depths from the controller's SQPnP pose), the stereo ZED 2 and
the ZED 2 lens (monocular and with a depth sensor) on the arm; an adaptive gain with calibration
errors drawn per case; several ticks per frame with a recording stride; runs that end early (a
marker lost, an estimate that fails, an SVD that fails in the law: the case is run again by its
plug-in loop, and its result is the ``ControllerError``'s partial record). A diverging plant is not
reached by these laws on these plants (a command that would overflow comes after the law's SVD has
failed, or after a marker was lost); a case whose kernel declines takes the same path as the SVD
failure. Bad input: typed errors that say what was received and what is valid.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import ibvs_youla as iy
from ibvs_youla.controllers.ibvs import AdaptiveGain, ClassicalIBVS
from ibvs_youla.exceptions import ControllerError, InvalidParameterError, SimulationDivergedError
from ibvs_youla.scenarios import place_markers
from ibvs_youla.simulation.disturbances import Disturbances

SQUARE_O = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]
RATE_25 = iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0)
TOLERANCE = 1e-9  # the brief's bound
EXACT = 0.0  # what the batch gives: the single run's calls, in the same order
METHODS = ("ibvs-current", "ibvs-desired", "ibvs-mean")


def T_O_C(t, theta_u_deg):
    cMo = np.eye(4)
    cMo[:3, :3] = Rotation.from_rotvec(np.radians(theta_u_deg)).as_matrix()
    cMo[:3, 3] = t
    return np.linalg.inv(cMo)


TARGET = T_O_C([0, 0, 0.75], [0, 0, 0])


def free_cases(n, seed=0):
    """ViSP's tutorial start, then seeded starts about it (up to ~20 deg, 10 cm)."""
    rng = np.random.default_rng(seed)
    starts = [T_O_C([0.15, -0.1, 1.0], [10, -10, 50])]
    for _ in range(n - 1):
        starts.append(T_O_C([*rng.uniform(-0.15, 0.15, 2), rng.uniform(0.8, 1.2)], rng.uniform(-20, 20, 3)))
    return [iy.Scenario.free_camera(T_O_C_start=T, T_O_C_target=TARGET, markers_O=SQUARE_O) for T in starts]


@pytest.fixture(scope="module")
def arm():
    return iy.Arm.irb4600()


def arm_cases(n, markers=None, seed=1):
    """physical-2, then seeded starts 0.05 rad per joint away (its markers, or four placed in view)."""
    base = iy.scenarios.physical(2)
    if markers is not None:
        base = dataclasses.replace(base, markers_O=markers)
    rng = np.random.default_rng(seed)
    return [base] + [
        dataclasses.replace(base, q_start=base.q_start + rng.uniform(-0.05, 0.05, 6)) for _ in range(n - 1)
    ]


@pytest.fixture(scope="module")
def four_markers(arm):
    """Four markers in view of physical-2's target camera (a pinhole camera needs four)."""
    scenario = iy.scenarios.physical(2)
    rays = np.array([[-0.15, -0.1], [0.15, -0.1], [0.12, 0.12], [-0.1, 0.1]])
    return place_markers(arm.camera_pose(scenario.q_target), rays, (2.0, 2.4, 2.8, 2.2))


def single(scenario, controller, **kwargs):
    """simulate() of one case; a run that raises gives its partial record (as the batch does)."""
    try:
        return iy.simulate(scenario, controller, **kwargs)
    except (SimulationDivergedError, ControllerError) as err:
        return err.partial


def deviation(a, b):
    """Largest |difference| of every recorded number of two results, after checking what must be equal."""
    assert a.status == b.status
    assert a.metadata.get("error") == b.metadata.get("error")
    assert a.t.shape == b.t.shape and a.frame_t.shape == b.frame_t.shape
    np.testing.assert_array_equal(a.visible, b.visible)
    np.testing.assert_array_equal(a.frame_visible, b.frame_visible)
    assert a.signals.keys() == b.signals.keys()
    pairs = [
        (a.t, b.t), (a.frame_t, b.frame_t), (a.camera_pose, b.camera_pose), (a.features, b.features),
        (a.frame_features, b.frame_features), *((a.signals[k], b.signals[k]) for k in b.signals),
    ]  # fmt: skip
    return max((float(np.abs(x - y).max()) if x.size else 0.0) for x, y in pairs)


def assert_batch_is_simulate(scenarios, controller, **kwargs):
    batch = iy.simulate_batch(scenarios, controller, **kwargs)
    assert len(batch) == len(scenarios)
    worst = 0.0
    for scenario, result in zip(scenarios, batch, strict=True):
        reference = single(scenario, controller, **kwargs)
        worst = max(worst, deviation(result, reference))
        assert result.metadata["loop"] == ("plug-in" if reference.metadata["loop"] == "plug-in" else "batch")
    assert worst <= TOLERANCE
    assert worst == EXACT
    return batch


@pytest.mark.parametrize("method", METHODS)
def test_free_camera(method):
    cases = free_cases(3)
    normalized = iy.PinholeCamera.normalized()
    kwargs = dict(plant="free-camera", duration=1.2, settings=RATE_25)
    for camera, sensor in ((normalized, "depth"), (normalized, None)):
        batch = assert_batch_is_simulate(cases, method, camera=camera, sensor=sensor, **kwargs)
        assert batch.statuses == ("complete",) * 3 and batch.rerun == ()
    stereo = [iy.scenarios.physical(2), *arm_cases(3)[1:]]  # the arm's camera poses, without the arm
    assert_batch_is_simulate(stereo, method, **kwargs)


@pytest.mark.parametrize("method", METHODS)
def test_kinematic_arm(method, arm, four_markers):
    kwargs = dict(plant="kinematic", duration=1.0, settings=RATE_25, arm=arm)
    assert_batch_is_simulate(arm_cases(3), method, **kwargs)  # the stereo ZED 2
    pinhole = arm_cases(3, four_markers)
    for sensor in ("depth", None):
        batch = assert_batch_is_simulate(
            pinhole, method, camera=iy.PinholeCamera.zed2(), sensor=sensor, **kwargs
        )
        assert batch.statuses == ("complete",) * 3


def test_several_ticks_per_frame_and_a_recording_stride(arm):
    """The arm at 250 Hz, the camera at 25 Hz (10 ticks a frame), every 3rd sample kept."""
    settings = iy.SimulationSettings(joint_rate_hz=250.0, camera_rate_hz=25.0, record_every=3)
    batch = assert_batch_is_simulate(
        arm_cases(2), "ibvs-mean", plant="kinematic", duration=0.5, settings=settings, arm=arm
    )
    assert batch[1].t.size == len(range(0, 125, 3)) + 1  # ticks 0, 3, ..., 123, and the last (125)


def test_an_adaptive_gain_and_calibration_errors_drawn_per_case():
    """ViSP's adaptive gain; each case its own seeded calibration errors (focal length, marker offsets)."""
    gain = AdaptiveGain(lambda_0=2.0, lambda_inf=0.4, lambda_dot_0=30.0)
    cases = free_cases(3)
    disturbances = [
        Disturbances(focal_length_scale=1.02, marker_offset_m=(0.01, 0.0, 0.0), seed=s) for s in range(3)
    ]
    kwargs = dict(plant="free-camera", camera=iy.PinholeCamera.normalized(), duration=1.0, settings=RATE_25)
    batch = iy.simulate_batch(cases, ClassicalIBVS("current", gain), disturbances=disturbances, **kwargs)
    plain = iy.simulate_batch(cases, ClassicalIBVS("current", gain), **kwargs)
    for scenario, result, own, other in zip(cases, batch, disturbances, plain, strict=True):
        reference = iy.simulate(scenario, ClassicalIBVS("current", gain), disturbances=own, **kwargs)
        assert deviation(result, reference) == EXACT
        assert result.metadata["disturbances"] == own.to_dict()
        assert np.abs(result.camera_pose[-1] - other.camera_pose[-1]).max() > 1e-4  # the errors act
    assert batch[0].signals["ibvs_gain"][1, 0] != batch[0].signals["ibvs_gain"][-1, 0]  # adaptive
    with_seed_1 = [np.abs(r.camera_pose[-1] - batch[1].camera_pose[-1]).max() for r in batch]
    assert with_seed_1[1] == 0.0  # the case with its own draws


def test_runs_that_end_early():
    """A marker lost and an estimate that fails stop the case at simulate()'s tick with its status and reason;
    a frame the kernels cannot finish (simulate() raises there) makes the case run again alone."""
    normalized = iy.PinholeCamera.normalized()
    at_target = iy.Scenario.free_camera(T_O_C_start=TARGET, T_O_C_target=TARGET, markers_O=SQUARE_O)
    cases = [*free_cases(2), at_target]
    kwargs = dict(plant="free-camera", camera=normalized, duration=1.0, settings=RATE_25)
    # lambda T = 2.4 > 2: the sampled loop overshoots through the markers' plane; at the target, e = 0
    lost = assert_batch_is_simulate(cases, ClassicalIBVS("current", 60.0), sensor="depth", **kwargs)
    assert lost.statuses == ("markers_lost", "markers_lost", "complete") and lost.rerun == ()
    assert "the true camera lost a marker" in lost[0].metadata["error"]
    # lambda = 1e30: the camera flies off after one frame; monocular, SQPnP refuses its features
    failed = assert_batch_is_simulate(cases, ClassicalIBVS("current", 1e30), **kwargs)
    assert failed.statuses == ("estimate_failed", "estimate_failed", "complete")
    assert "ClassicalIBVS's estimate failed" in failed[0].metadata["error"]
    # lambda = 1e200 with measured depths: a twist of 1e200 sends the pose out of range on the first
    # frame, which the free camera refuses (a diverged run and its partial record)
    huge = assert_batch_is_simulate(cases, ClassicalIBVS("current", 1e200), sensor="depth", **kwargs)
    assert huge.statuses == ("diverged", "diverged", "complete") and huge.rerun == (0, 1)
    assert huge[0].metadata["loop"] == "plug-in" and len(huge[0]) == 1
    assert "the camera pose is not finite" in huge[0].metadata["error"]


def test_bad_input_says_what_was_received_and_what_is_valid(arm):
    cases = free_cases(2)
    kwargs = dict(plant="free-camera", camera=iy.PinholeCamera.normalized(), duration=0.1, settings=RATE_25)
    with pytest.raises(InvalidParameterError, match=r"scenarios: received 'a Scenario'.*simulate\(\)"):
        iy.simulate_batch(cases[0], "ibvs-current", **kwargs)
    with pytest.raises(InvalidParameterError, match="an empty sequence"):
        iy.simulate_batch([], "ibvs-current", **kwargs)
    with pytest.raises(InvalidParameterError, match=r"scenarios\[1\]: received 'dict'"):
        iy.simulate_batch([cases[0], {}], "ibvs-current", **kwargs)
    with pytest.raises(InvalidParameterError, match=r"plant: received 'dynamic'.*simulate\(\) runs every"):
        iy.simulate_batch(cases, "ibvs-current", **{**kwargs, "plant": "dynamic"})
    with pytest.raises(InvalidParameterError, match=r"controller: received 'pbvs'.*simulate\(\) runs every"):
        iy.simulate_batch(cases, "pbvs", **kwargs)
    with pytest.raises(InvalidParameterError, match=r"controller: received 'a PBVS'"):
        iy.simulate_batch(cases, iy.controllers.make("pbvs"), **kwargs)
    with pytest.raises(InvalidParameterError, match=r"sensor: received 'images'.*simulate\(\) runs rendered"):
        iy.simulate_batch(cases, "ibvs-current", sensor="images", **kwargs)
    with pytest.raises(InvalidParameterError, match=r"disturbances of scenarios\[0\].*pixel_noise_px"):
        iy.simulate_batch(cases, "ibvs-desired", disturbances=Disturbances(pixel_noise_px=0.5), **kwargs)
    with pytest.raises(
        InvalidParameterError, match=r"disturbances: received 'a sequence of 1'.*one per scenario"
    ):
        iy.simulate_batch(cases, "ibvs-desired", disturbances=[Disturbances()], **kwargs)
    with pytest.raises(InvalidParameterError, match=r"beliefs\[1\]: received 'str'"):
        iy.simulate_batch(cases, "ibvs-desired", beliefs=[None, "truth"], **kwargs)
    six = iy.Scenario.free_camera(
        T_O_C_start=cases[0].T_O_C_start, T_O_C_target=TARGET,
        markers_O=np.vstack((SQUARE_O, [[0.0, 0.05, 0.1], [0.05, -0.05, -0.1]])),
    )  # fmt: skip
    with pytest.raises(InvalidParameterError, match=r"scenarios\[1\] with 6 markers.*4 markers"):
        iy.simulate_batch([cases[0], six], "ibvs-desired", **kwargs)
    # a case that simulate() refuses: its error, noting which case (a free-camera scenario on the arm)
    mixed = [iy.scenarios.physical(2), cases[0]]
    with pytest.raises(InvalidParameterError, match="'free-camera' for the free-camera scenario") as err:
        iy.simulate_batch(mixed, "ibvs-current", plant="kinematic", arm=arm, duration=0.1, settings=RATE_25)
    assert "in simulate_batch's scenarios[1]" in err.value.__notes__


def test_a_signal_before_the_loop_records_anything_is_still_an_interrupt(monkeypatch):
    """A SIGTERM that a campaign turns into KeyboardInterrupt can land while the loop sets up, before
    its own handler: still KeyboardInterrupt (the CLI's exit 130), its partial an empty BatchResult."""
    from ibvs_youla.simulation import batch_loop

    def interrupted_while_setting_up(self, *args, **kwargs):
        raise KeyboardInterrupt("signal SIGTERM")

    monkeypatch.setattr(batch_loop.BatchLoop, "run", interrupted_while_setting_up)
    kwargs = dict(plant="free-camera", camera=iy.PinholeCamera.normalized(), duration=1.0, settings=RATE_25)
    with pytest.raises(KeyboardInterrupt) as err:
        iy.simulate_batch(free_cases(2), "ibvs-mean", sensor="depth", **kwargs)
    assert isinstance(err.value.partial, iy.BatchResult) and len(err.value.partial) == 0


def test_a_signal_while_the_cases_are_prepared_is_an_interrupt_with_nothing_recorded(monkeypatch):
    from ibvs_youla.simulation import batch

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt("signal SIGTERM")

    monkeypatch.setattr(batch, "prepare_run", interrupted)
    kwargs = dict(plant="free-camera", camera=iy.PinholeCamera.normalized(), duration=1.0, settings=RATE_25)
    with pytest.raises(KeyboardInterrupt) as err:
        iy.simulate_batch(free_cases(2), "ibvs-mean", sensor="depth", **kwargs)
    assert isinstance(err.value.partial, iy.BatchResult) and len(err.value.partial) == 0


def test_ctrl_c_keeps_what_every_case_recorded(monkeypatch):
    from ibvs_youla.simulation import batch_loop

    real, calls = batch_loop.free_camera_steps, []

    def interrupted_at_the_third_frame(*args):
        calls.append(args[0])
        if len(calls) == 3:
            raise KeyboardInterrupt
        real(*args)

    monkeypatch.setattr(batch_loop, "free_camera_steps", interrupted_at_the_third_frame)
    kwargs = dict(plant="free-camera", camera=iy.PinholeCamera.normalized(), duration=1.0, settings=RATE_25)
    with pytest.raises(KeyboardInterrupt) as err:
        iy.simulate_batch(free_cases(2), "ibvs-mean", sensor="depth", **kwargs)
    partial = err.value.partial
    assert isinstance(partial, iy.BatchResult) and partial.statuses == ("interrupted", "interrupted")
    assert [r.t.tolist() for r in partial] == [[0.0, 0.04]] * 2 and partial[0].frame_t.size == 2
