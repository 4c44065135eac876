"""Campaign cases, specs and rows: seeded and stable, every failure a row, outcomes as stated."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from ibvs_youla.campaign.cases import (
    FAMILIES,
    MAX_JOINT_STEP_DEG,
    MAX_ROLL_DEG,
    MIN_ROLL_DEG,
    ROLL_TILT_DEG,
    ROLL_TRANSLATION_M,
    generate_cases,
)
from ibvs_youla.campaign.definition import CampaignDefinition
from ibvs_youla.campaign.metrics import COLUMNS, OUTCOMES
from ibvs_youla.campaign.run import run_spec
from ibvs_youla.campaign.spec import ExperimentSpec, method_label, parse_method, specs_for, split_methods
from ibvs_youla.exceptions import InvalidParameterError

FREE_25HZ = {"joint_rate_hz": 25.0, "camera_rate_hz": 25.0}


@pytest.mark.parametrize("family", FAMILIES)
def test_cases_depend_on_the_seed_and_index_only(family):
    ten, three = generate_cases(family, 10, 42), generate_cases(family, 3, 42)
    for a, b in zip(ten[:3], three, strict=True):
        assert a.index == b.index and a.difficulty == b.difficulty
        for k in a.scenario:
            np.testing.assert_array_equal(np.asarray(a.scenario[k]), np.asarray(b.scenario[k]))
    other = generate_cases(family, 3, 43)
    assert other[0].difficulty != ten[0].difficulty


def test_arm_cases_keep_their_rules():
    from ibvs_youla.model.arm import Arm
    from ibvs_youla.model.camera import default_camera
    from ibvs_youla.simulation.sensor import MarkerSensor

    arm, camera = Arm.irb4600(), default_camera()
    for case in generate_cases("arm-physical", 8, 5):
        q0, q1 = np.asarray(case.scenario["q_start"]), np.asarray(case.scenario["q_target"])
        assert np.all(np.abs(q0 - q1) <= math.radians(MAX_JOINT_STEP_DEG) + 1e-12)
        assert min(abs(q0[4]), abs(q1[4])) >= math.radians(10.0)  # away from the wrist singularity
        sensor = MarkerSensor(camera, case.scenario["markers_O"])
        for q in (q0, q1):  # every marker in view at both ends
            assert camera.visibility(sensor.points_in_camera(arm.camera_pose(q))).all_visible
        assert case.difficulty["rotation_deg"] > 0.0 and case.difficulty["translation_m"] > 0.0


def test_free_cases_scale_with_the_difficulty():
    easy, hard = generate_cases("free-planar", 30, 9, difficulty=0.2), generate_cases("free-planar", 30, 9)
    assert max(c.difficulty["rotation_deg"] for c in easy) <= 18.0 + 1e-9  # 0.2 x 90 deg
    assert max(c.difficulty["rotation_deg"] for c in hard) > 18.0


def test_a_spec_is_data_with_a_stable_key():
    case = generate_cases("free-planar", 1, 1)[0]
    (spec,) = specs_for(
        [case],
        ["pbvs"],
        seed=1,
        plant="free-camera",
        camera={"kind": "normalized"},
        duration=5.0,
        settings=FREE_25HZ,
    )
    assert ExperimentSpec.from_json(spec.to_json()) == spec and pickle.loads(pickle.dumps(spec)) == spec
    assert spec.key == ExperimentSpec.from_json(spec.to_json()).key and len(spec.key) == 20
    assert spec.key == "c85851d5725d4d8c06a5"  # stored campaigns resume by it: it must never change
    other = ExperimentSpec(**{**spec.to_dict(), "duration": 6.0})
    assert other.key != spec.key
    with pytest.raises(InvalidParameterError, match="seed"):
        ExperimentSpec(**{**spec.to_dict(), "seed": "1"})


def test_rows_have_the_schema_and_the_outcomes():
    cases = generate_cases("free-planar", 2, 1)
    specs = specs_for(
        cases,
        ["ibvs-current", "pbvs"],
        seed=1,
        plant="free-camera",
        camera={"kind": "normalized"},
        duration=20.0,
        settings=FREE_25HZ,
    )
    rows = [run_spec(s) for s in specs]
    for row in rows:
        assert set(row) == set(COLUMNS) and row["outcome"] in OUTCOMES
        assert all(isinstance(row[c], kind) for c, kind in COLUMNS.items())
        assert row["outcome"] == "reached" and row["time_to_reach_s"] < 20.0
        assert math.isnan(row["final_jacobian_sigma"])  # no arm
    assert [r["controller"] for r in rows] == ["ibvs-current", "pbvs", "ibvs-current", "pbvs"]
    assert rows[1]["path_ratio"] == pytest.approx(1.0, abs=1e-3)  # PBVS: a straight line


def test_a_run_that_raises_is_a_row():
    case = generate_cases("arm-physical", 1, 2)[0]
    (spec,) = specs_for(
        [case],
        ["pbvs"],
        seed=2,
        plant="free-camera",
        camera={"kind": "stereo"},
        duration=1.0,
        controller_params={"pbvs": {"gain": -1.0}},
    )
    row = run_spec(spec.to_json())
    assert row["outcome"] == "error" and "gain" in row["error"] and math.isnan(row["final_position_mm"])
    assert set(row) == set(COLUMNS)


@pytest.mark.parametrize(
    ("label", "name", "params"),
    [
        ("fb", "fb", {}),
        ("fb[adaptive=false]", "fb", {"adaptive": False}),
        ("pbvs[gain=0.5,estimator=sqpnp]", "pbvs", {"estimator": "sqpnp", "gain": 0.5}),
        (
            'mpc-ibvs[horizon=5,name="1",weights=[1,2],x=null]',
            "mpc-ibvs",
            {"horizon": 5, "name": "1", "weights": [1, 2], "x": None},
        ),
        ("  2.5d [ gain = 2 ] ", "2.5d", {"gain": 2}),
    ],
)
def test_method_labels_read_back(label, name, params):
    assert parse_method(label) == (name, params)
    assert parse_method(method_label(name, params)) == (name, params)  # the canonical label reads back
    assert method_label("fb", {"adaptive": False, "a": 1}) == "fb[a=1,adaptive=false]"  # sorted keys


@pytest.mark.parametrize(
    "label", ["", "fb[", "fb[adaptive]", "fb[adaptive=false,adaptive=true]", "fb[1x=2]", "fb[x=a b]", 3]
)
def test_malformed_method_labels_are_refused(label):
    with pytest.raises(InvalidParameterError, match="method"):
        parse_method(label)


def test_one_controller_runs_as_two_methods_with_the_keys_of_its_parameters():
    assert split_methods("fb,fb[adaptive=false,gain=2], ff+fb") == [
        "fb",
        "fb[adaptive=false,gain=2]",
        "ff+fb",
    ]
    definition = CampaignDefinition(
        "arm-physical", 1, ("fb", "fb[adaptive=false]"), seed=1, plant="kinematic"
    )
    adaptive, fixed = definition.specs()
    assert (adaptive.controller, adaptive.controller_params) == ("fb", {})
    assert (fixed.controller, fixed.controller_params, fixed.method) == (
        "fb",
        {"adaptive": False},
        "fb[adaptive=false]",
    )
    # the label's spec is the spec the same parameters gave through controller_params: the same key
    (old,) = CampaignDefinition(
        "arm-physical", 1, ("fb",), seed=1, plant="kinematic", controller_params={"fb": {"adaptive": False}}
    ).specs()
    assert old.key == fixed.key != adaptive.key
    with pytest.raises(InvalidParameterError, match="wobble"):
        CampaignDefinition("arm-physical", 1, ("fb[wobble=1]",), plant="kinematic")
    with pytest.raises(InvalidParameterError, match="each once"):
        CampaignDefinition("arm-physical", 1, ("fb[adaptive=false]", "fb[adaptive=false]"), plant="kinematic")
    with pytest.raises(InvalidParameterError, match=r"'nope\[adaptive=false\]'"):
        CampaignDefinition("arm-physical", 1, ("nope[adaptive=false]",), plant="kinematic")


def test_a_stall_at_an_arm_singularity_is_not_called_a_local_minimum():
    """arm-physical case 24 (seed 1): fb turns joint 1 by 191 deg and stalls 65 mm short of the target
    with the camera Jacobian singular (smallest singular value 1.5e-7): the arm cannot move the camera,
    the image law has no local minimum there. Before the outcome existed this row read local_minimum."""
    spec = CampaignDefinition("arm-physical", 25, ("fb",), seed=1, plant="kinematic").specs()[24]
    row = run_spec(spec)
    assert row["outcome"] == "singularity" and row["final_jacobian_sigma"] < 1e-5
    assert row["final_position_mm"] == pytest.approx(64.80, abs=0.05)
    assert row["final_feature_error"] > 1e-5  # the image error stayed (normalized units)


def test_free_roll_cases_turn_about_the_optical_axis():
    cases = generate_cases("free-roll", 60, 4)
    for case in cases:
        T_start, T_target = case.scenario["T_O_C_start"], case.scenario["T_O_C_target"]
        delta = np.linalg.inv(T_target) @ T_start  # T_C*_C0
        tilt_deg = math.degrees(math.acos(np.clip(delta[2, 2], -1.0, 1.0)))  # optical axes apart
        assert tilt_deg <= ROLL_TILT_DEG + 1e-9
        assert MIN_ROLL_DEG - ROLL_TILT_DEG <= case.difficulty["rotation_deg"] <= MAX_ROLL_DEG
        assert case.difficulty["translation_m"] <= ROLL_TRANSLATION_M + 1e-12
    rolls = [c.difficulty["rotation_deg"] for c in cases]
    assert max(rolls) > 170.0 and min(rolls) < 100.0  # the range is covered
    signs = {
        np.sign(np.linalg.inv(c.scenario["T_O_C_target"]) @ c.scenario["T_O_C_start"])[1, 0] for c in cases
    }
    assert signs == {-1.0, 1.0}  # both senses
    with pytest.raises(InvalidParameterError, match="difficulty"):
        generate_cases("free-roll", 1, 4, difficulty=0.0)
