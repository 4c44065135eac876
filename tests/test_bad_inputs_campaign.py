"""Bad inputs of campaigns, robustness studies and their parts: refused up front, typed, named.

Each class of the table is a kind of input that the argument checks used to pass and the runs
then choked on (or that stored what it should not): each row asserts the exception type, that
the message names the argument, and that nothing was written (no folder is bound to a campaign
that cannot run).
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

import ibvs_youla as iy
from bad_input_rows import case, check
from ibvs_youla.analysis import suites
from ibvs_youla.campaign.cases import generate_cases
from ibvs_youla.campaign.robustness import RobustnessStudy, run_study
from ibvs_youla.campaign.runner import CampaignDefinition, check_runnable, max_workers, run_campaign
from ibvs_youla.campaign.spec import ExperimentSpec
from ibvs_youla.exceptions import InvalidParameterError
from ibvs_youla.model.camera import PinholeCamera

P = InvalidParameterError
FREE = {"family": "free-planar", "cases": 2, "controllers": ("ibvs-current",), "duration": 1.0}


def _campaign(**changes):
    return lambda out: CampaignDefinition(**{**FREE, **changes})


def _run(**options):
    return lambda out: run_campaign(CampaignDefinition(**FREE), out, progress=False, **options)


def _study(**changes):
    campaign = {**FREE, **changes}
    return lambda out: run_study(RobustnessStudy("noise", (0.0,), campaign), out, workers=0, progress=False)


@functools.cache
def _free_spec():
    return CampaignDefinition(**FREE).specs()[0]


# values the argument checks passed and every run then failed on (or the Parquet writer lost)
PASSED_THEN_CHOKED = [
    case(_campaign(seed=2**63), P, "seed", "seed-beyond-int64"),
    case(
        lambda out: ExperimentSpec(**{**_free_spec().to_dict(), "seed": 2**64}), P, "seed", "spec-seed-int64"
    ),
    case(lambda out: generate_cases("free-planar", 2, 2**64), P, "seed", "cases-seed-int64"),
    case(_campaign(difficulty=1e300), P, "difficulty", "difficulty-nan-poses"),
    case(_campaign(difficulty=math.inf), P, "difficulty", "difficulty-inf"),
    case(
        lambda out: generate_cases("free-roll", 2, 0, difficulty=1e300), P, "difficulty", "cases-difficulty"
    ),
    case(_campaign(duration=1e-6), P, "duration", "duration-below-a-frame"),
    case(
        _campaign(family="arm-physical", duration=0.005), P, "duration", "duration-below-an-arm-frame"
    ),  # one tick of 1 kHz, half a frame of 100 Hz
    case(lambda out: check_runnable(CampaignDefinition(**{**FREE, "duration": 1e9})), P, "duration", "check"),
    case(
        lambda out: run_campaign(CampaignDefinition(**{**FREE, "duration": 1e300}), out), P, "duration", "run"
    ),
    case(_study(duration=1e9), P, "duration", "study-duration-huge"),
    case(_run(workers=1000), P, "workers", "workers-1000"),
    case(_run(workers=max_workers() + 1), P, "workers", "workers-beyond-bound"),
    case(
        lambda out: run_study(RobustnessStudy("noise", (0.0,), FREE), out, workers=1000), P, "workers", "st"
    ),
    case(_run(workers=0, batch_rows=0), P, "batch_rows", "batch-rows-zero"),
    case(_run(workers=0, batch_rows=2.5), P, "batch_rows", "batch-rows-float"),
    case(_run(workers=0, batch_seconds=math.nan), P, "batch_seconds", "batch-seconds-nan"),
    case(_run(workers=0, batch_seconds=-1.0), P, "batch_seconds", "batch-seconds-negative"),
    # the paper controller's options in the settings: simulate() refuses them for a controller object
    case(
        _campaign(
            family="arm-physical", plant="dynamic", controllers=("ff+fb",), settings={"feedforward": "smooth"}
        ),
        P,
        "settings",
        "paper-gains-in-settings",
    ),
]


@pytest.mark.parametrize(("call", "error", "name"), PASSED_THEN_CHOKED)
def test_a_value_every_run_would_choke_on_is_refused_before_anything_is_written(call, error, name, tmp_path):
    out = tmp_path / "out"
    check(lambda: call(out), error, name)
    assert not out.exists()


def test_a_latency_longer_than_the_run_holds_the_first_frame_instead_of_overflowing():
    """1e30 frames overflowed the delay buffer in every run; it is the documented rule: the first frame."""
    task = suites.task("gans-general")
    run = dict(plant="free-camera", camera=PinholeCamera.normalized(25.0), duration=0.4)
    settings = iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0)
    results = [
        iy.simulate(
            task.scenario(),
            "ibvs-current",
            settings=settings,
            **run,
            disturbances=iy.Disturbances(latency_frames=k),
        )
        for k in (10**30, 11)  # 11 frames: every frame of the run
    ]
    assert results[0].status == "complete"
    np.testing.assert_array_equal(results[0].camera_pose, results[1].camera_pose)
    assert np.abs(results[0].camera_pose[-1] - results[0].camera_pose[0]).max() > 1e-3  # it moved


# two spellings of one thing: every run stored twice, or two values in one folder
ONE_THING_TWICE = [
    case(
        _campaign(controllers=("ibvs-current", "ibvs-current[]")),
        P,
        "controllers",
        "label-and-empty-brackets",
    ),
    case(
        _campaign(controllers=("pbvs[gain=0.5]", "pbvs"), controller_params={"pbvs": {"gain": 0.5}}),
        P,
        "controllers",
        "label-and-params",
    ),
    case(lambda out: RobustnessStudy("noise", (0.1, 0.1000001), FREE), P, "values", "values-printing-alike"),
    case(
        lambda out: RobustnessStudy("calibration", (1.0, 1.0000004, 2.0), FREE), P, "values", "values-alike-3"
    ),
]


@pytest.mark.parametrize(("call", "error", "name"), ONE_THING_TWICE)
def test_two_spellings_of_one_method_or_one_folder_are_refused(call, error, name, tmp_path):
    err = check(lambda: call(tmp_path / "out"), error, name)
    assert "print" in str(err) or "each method once" in str(err)


# objects of the API given the wrong type, an unknown or a missing field
WRONG_TYPES = [
    case(_campaign(camera={"kind": "stereo", "foo": 1}), P, "camera", "campaign-camera-unknown-option"),
    case(_campaign(camera={"kind": "normalized", "mode": "VGA"}), P, "camera", "campaign-normalized-option"),
    case(_campaign(disturbances=3), P, "disturbances", "campaign-disturbances-int"),
    case(_campaign(disturbances=["pixel_noise_px"]), P, "disturbances", "campaign-disturbances-list"),
    case(_campaign(foo=1), P, "foo", "campaign-unknown-keyword"),
    case(lambda out: CampaignDefinition.from_dict({"cases": 2}), P, "family", "campaign-from-dict-missing"),
    case(lambda out: CampaignDefinition.from_dict([1]), P, "data", "campaign-from-dict-list"),
    case(lambda out: RobustnessStudy("noise", 3, FREE), P, "values", "study-values-int"),
    case(lambda out: RobustnessStudy("noise", "0.1", FREE), P, "values", "study-values-str"),
    case(lambda out: RobustnessStudy("noise", None, 3), P, "campaign", "study-campaign-int"),
    case(lambda out: RobustnessStudy("noise", None, {**FREE, "foo": 1}), P, "foo", "study-campaign-unknown"),
    case(lambda out: RobustnessStudy("noise", None, {"cases": 2}), P, "family", "study-campaign-missing"),
    case(lambda out: RobustnessStudy(["noise"]), P, "axis", "study-axis-list"),
    case(lambda out: RobustnessStudy.from_dict({"axis": "noise"}), P, "campaign", "study-from-dict-missing"),
    case(lambda out: iy.Disturbances(foo=1), P, "foo", "disturbances-unknown-keyword"),
    case(
        lambda out: iy.Disturbances(0.1, False, 0.0, *range(30)), P, "positional", "disturbances-positional"
    ),
    case(lambda out: iy.Disturbances.from_dict(["pixel_noise_px"]), P, "disturbances", "from-dict-list"),
    case(lambda out: ExperimentSpec.from_json("{"), P, "text", "spec-json-malformed"),
    case(lambda out: ExperimentSpec.from_json("[1]"), P, "text", "spec-json-array"),
    case(lambda out: ExperimentSpec.from_json('{"family": "x"}'), P, "case", "spec-json-missing"),
    case(lambda out: ExperimentSpec(), P, "family", "spec-nothing"),
]


@pytest.mark.parametrize(("call", "error", "name"), WRONG_TYPES)
def test_api_objects_refuse_wrong_types_and_fields_by_name(call, error, name, tmp_path):
    check(lambda: call(tmp_path / "out"), error, name)


@pytest.mark.parametrize("received", ["not json", "{}", '{"family": "free-planar"}', "[1, 2]", None, 3.5])
def test_run_spec_returns_an_error_row_whatever_it_is_given(received):
    from ibvs_youla.campaign.metrics import COLUMNS
    from ibvs_youla.campaign.run import run_spec

    row = run_spec(received)
    assert set(row) == set(COLUMNS) and (row["outcome"], row["status"]) == ("error", "error")
    assert row["error"].startswith("InvalidParameterError: ") and len(row["key"]) == 20
    assert row["spec"] == str(received)
