"""The mount families of campaigns: matched eye-in-hand and eye-to-hand cases, the mount in each spec.

``arm-eye-to-hand`` and ``arm-eye-in-hand`` draw case k from the same stream
(``scenarios.mount_pair``): the same joints and the same target image, one with a camera fixed in
front of the tool, one with the arm's own camera. The eye-to-hand spec carries its mount, so it
rebuilds the same scenario anywhere; the specs of every other family are unchanged (their keys
are pinned in tests/test_campaign_core.py).
"""

from __future__ import annotations

import numpy as np
import pytest

from ibvs_youla import cli
from ibvs_youla.campaign.cases import MOUNT_STEP_DEG, generate_cases
from ibvs_youla.campaign.definition import CampaignDefinition
from ibvs_youla.campaign.report import read_rows
from ibvs_youla.campaign.run import run_spec
from ibvs_youla.campaign.spec import ExperimentSpec, specs_for
from ibvs_youla.exceptions import InvalidParameterError
from ibvs_youla.model.arm import Arm
from ibvs_youla.model.eye_to_hand import mounted
from ibvs_youla.model.robots import get


@pytest.fixture(scope="module")
def cases():
    return generate_cases("arm-eye-in-hand", 3, 11), generate_cases("arm-eye-to-hand", 3, 11)


def test_case_k_is_one_draw_in_both_mountings(cases):
    for in_hand, to_hand in zip(*cases, strict=True):
        for key in ("q_start", "q_target", "joint_offset"):
            np.testing.assert_array_equal(in_hand.scenario[key], to_hand.scenario[key])
        assert "mount" not in in_hand.scenario and "markers_O" in in_hand.scenario
        assert to_hand.scenario["mount"]["kind"] == "eye-to-hand" and "markers_E" in to_hand.scenario
        step = np.abs(np.subtract(in_hand.scenario["q_start"], in_hand.scenario["q_target"])).max()
        assert step <= np.radians(MOUNT_STEP_DEG) + 1e-12
        # the tool's rotation is the camera's relative rotation in both mountings; the lever arm is not
        assert in_hand.difficulty["rotation_deg"] == pytest.approx(
            to_hand.difficulty["rotation_deg"], abs=1e-9
        )


def test_an_eye_to_hand_spec_rebuilds_its_scenario_and_keeps_its_key(cases):
    case = cases[1][0]
    (spec,) = specs_for(
        [case], ["ibvs-current"], seed=11, plant="kinematic", camera={"kind": "stereo"}, duration=15.0
    )
    again = ExperimentSpec.from_json(spec.to_json())
    assert again == spec and again.key == spec.key
    scenario = spec.build()["scenario"]
    assert scenario.mount.to_dict() == case.scenario["mount"]
    np.testing.assert_array_equal(scenario.markers_E, case.scenario["markers_E"])
    assert spec.key == "89f465f589e918f56673"  # stored campaigns resume by it (the same on every BLAS kernel)


def test_an_eye_to_hand_run_is_a_row_measured_relative_to_the_markers(cases):
    case = cases[1][0]
    (spec,) = specs_for(
        [case], ["ibvs-current"], seed=11, plant="kinematic", camera={"kind": "stereo"}, duration=15.0
    )
    row = run_spec(spec)
    assert row["outcome"] == "reached" and row["time_to_reach_s"] < 15.0
    result_arm = mounted(Arm.irb4600(), spec.build()["scenario"].mount)
    q_target = np.asarray(case.scenario["q_target"])
    sigma = np.linalg.svd(result_arm.camera_jacobian(q_target), compute_uv=False)[-1]
    assert row["final_jacobian_sigma"] == pytest.approx(sigma, rel=1e-3)  # J_rel's, at the target reached


def test_the_mount_families_run_on_an_arm_plant_only():
    definition = CampaignDefinition("arm-eye-to-hand", 2, ("ff+fb", "pbvs"), plant="kinematic")
    assert definition.camera == {"kind": "stereo"} and len(definition.specs()) == 4
    with pytest.raises(InvalidParameterError, match="plant"):
        CampaignDefinition("arm-eye-to-hand", 1, ("pbvs",), plant="free-camera")


def test_the_command_line_runs_an_eye_to_hand_campaign(tmp_path):
    """``ibvs-youla campaign --family arm-eye-to-hand``: the family is a choice of the command line."""
    out = tmp_path / "e2h"
    args = ["campaign", "--family", "arm-eye-to-hand", "--cases", "1", "--controllers", "ibvs-current"]
    args += [
        "--plant",
        "kinematic",
        "--duration",
        "0.2",
        "--workers",
        "0",
        "--out",
        str(out),
        "--no-progress",
    ]
    assert cli.main(args) == 0
    rows = read_rows(out)
    assert list(rows["family"]) == ["arm-eye-to-hand"] and rows["status"].iloc[0] == "complete"
    assert '"mount":{"T_O_C"' in rows["spec"].iloc[0]  # the mount is in the stored spec


def test_the_mount_families_draw_and_run_on_the_campaign_s_arm():
    """``arm=`` acts on the mount families too: the UR5's cases, its record in the spec, a run on it."""
    ur5 = Arm.from_robot("ur5")
    on_irb = generate_cases("arm-eye-to-hand", 1, 0)[0].scenario
    on_ur5 = generate_cases("arm-eye-to-hand", 1, 0, arm=ur5)[0].scenario
    assert not np.allclose(on_irb["q_target"], on_ur5["q_target"])  # drawn about the UR5's home
    home = get("ur5").q_home
    # the draw's spread about the home configuration: +-10 deg per joint
    np.testing.assert_allclose(on_ur5["q_target"], home, rtol=0, atol=np.radians(10.0) + 1e-12)
    definition = CampaignDefinition(
        "arm-eye-to-hand", 1, ("ibvs-current",), plant="kinematic", arm=ur5, duration=15.0
    )
    (spec,) = definition.specs()
    assert spec.arm["robot"] == "ur5" and spec.build()["scenario"].mount.is_eye_to_hand
    row = run_spec(spec)
    # measured 8.068 s; within one camera frame (10 ms), the resolution of a time to reach
    assert row["outcome"] == "reached" and row["time_to_reach_s"] == pytest.approx(8.068, abs=0.01)


def test_mount_families_on_a_reduced_arm_and_on_an_arm_without_a_home():
    """A joint locked on request leaves the home configuration's entry out (as for_arm); an arm from a
    URDF has no home to draw about: refused by name, not as a difficulty no draw meets."""
    from ibvs_youla.model._resources import example_robot_data_urdf

    panda = Arm.from_robot("panda", locked_joints={"panda_joint7": 0.785})
    (case,) = generate_cases("arm-eye-to-hand", 1, 0, arm=panda)
    assert len(case.scenario["q_target"]) == 6
    urdf_arm = Arm.from_urdf(
        example_robot_data_urdf("ur_description/urdf/ur5_robot.urdf"), camera_frame="tool0"
    )
    with pytest.raises(InvalidParameterError, match=r"a named robot .* for the family 'arm-eye-to-hand'"):
        generate_cases("arm-eye-to-hand", 1, 0, arm=urdf_arm)
