"""The arm as a parameter of every entry point: --robot/--urdf and [arm], campaign keys, old folders.

Short runs on the UR5 (6 joints, analytic IK) and the Panda (7 joints, redundant): the command
line, a TOML ``[arm]``, ``compare``, ``campaign`` and ``robustness``; the keys of two arms differ
and the IRB 4600's stay those computed before arms were a parameter; a folder made then resumes.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import ibvs_youla as iy
from ibvs_youla import cli
from ibvs_youla.campaign.arms import arm_from_record, arm_record
from ibvs_youla.campaign.cases import LIMIT_MARGIN, MIN_JACOBIAN_SIGMA, generate_cases
from ibvs_youla.campaign.definition import CampaignDefinition
from ibvs_youla.campaign.runner import run_campaign
from ibvs_youla.model.arm import Arm
from ibvs_youla.simulation.results import SimulationResult

OLD_FOLDER = Path(__file__).parent / "regression" / "campaign_before_arms"
# The specs' keys of this definition, computed by the package before arms were a parameter
# (main at the CLI rework): a stored IRB 4600 campaign resumes by them, so they never change.
IRB4600_DEFINITION = {
    "family": "arm-physical",
    "cases": 2,
    "controllers": ("fb", "ff+fb"),
    "plant": "kinematic",
    "seed": 3,
    "duration": 2.0,
}
IRB4600_KEYS = [
    "eee52b9c4377d050cb46",
    "4c4ff24c36407325f1d8",
    "c50a7c883dac4cc01bcd",
    "3bfa27b45a0914d2506c",
]


def run(capsys, *argv):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def arms():
    return {name: Arm.from_robot(name) for name in ("ur5", "panda")}


# ----------------------------------------------------------------------------- refusals
@pytest.mark.parametrize(
    ("argv", "fragments"),
    [
        (("simulate", "--robot", "ur6"), ["argument --robot", "'ur6'", "'ur5'", "'panda'"]),
        (
            ("simulate", "--robot", "ur5", "--camera-frame", "nope"),
            ["argument --camera-frame", "'nope'", "'tool0'"],
        ),
        (
            ("simulate", "--robot", "panda", "--locked-joint", "elbow=1"),
            ["argument --locked-joint", "'elbow'", "'panda_joint7'"],
        ),
        (("simulate", "--robot", "panda", "--locked-joint", "panda_joint7"), ["NAME=VALUE"]),
        (("simulate", "--urdf", "no/such.urdf"), ["argument --urdf", "no/such.urdf"]),
        (("simulate", "--robot", "ur5", "--T-F-C", "1,2"), ["argument --T-F-C", "X,Y,Z,RX,RY,RZ"]),
        (("simulate", "--robot", "ur5", "--urdf", "x.urdf"), ["not allowed with argument --robot"]),
        (("simulate", "--robot", "ur5", "--scenario", "paper-1"), ["argument --scenario", "seeded scenario"]),
        (("compare", "--suite", "gans2003", "--robot", "panda"), ["argument --robot", "free camera"]),
        (
            ("campaign", "--family", "free-planar", "--robot", "ur5", "--cases", "1", "--out", "x"),
            ["argument --robot", "'free-planar'", "arm-physical"],
        ),
    ],
)
def test_a_bad_arm_exits_2_with_the_candidates(capsys, argv, fragments):
    code, out, err = run(capsys, *argv)
    assert code == 2 and out == "", err
    line = err.strip().splitlines()[-1]
    assert line.startswith("ibvs-youla: error: ") and "Traceback" not in err
    for fragment in fragments:
        assert fragment in line


def test_a_bad_arm_table_exits_2_naming_its_key(capsys, tmp_path):
    config = tmp_path / "c.toml"
    config.write_text('[arm]\nrobot = "ur5"\ncamera_frame = "nope"\n')
    code, _, err = run(capsys, "simulate", "--config", config)
    assert code == 2 and "arm.camera_frame: received 'nope'" in err and "'tool0'" in err


# ----------------------------------------------------------------------------- runs on the arm
@pytest.mark.parametrize(("robot", "n"), [("ur5", 6), ("panda", 7)])
def test_simulate_runs_on_the_named_arm_and_its_seeded_scenario(capsys, tmp_path, robot, n):
    out = tmp_path / robot
    argv = ("simulate", "--robot", robot, "--plant", "kinematic", "--duration", "0.05", "--seed", "3")
    code, text, err = run(capsys, *argv, "--out", out, "--no-plots")
    assert code == 0, err
    result = SimulationResult.load(out / "result.npz")
    assert result.metadata["arm_identity"]["robot"] == robot and result.signals["q"].shape[1] == n
    scenario = iy.scenarios.for_arm(Arm.from_robot(robot), 3)
    np.testing.assert_allclose(result.signals["q"][0], scenario.q_start, atol=1e-12)
    assert result.metadata["scenario"] == scenario.name and "peak joint speed" in text


def test_a_toml_arm_and_seed_choose_the_arm_its_mount_and_scenario(capsys, tmp_path, arms):
    config = tmp_path / "panda.toml"
    config.write_text(
        '[arm]\nrobot = "panda"\nlocked_joints = { panda_joint7 = 0.5 }\n'
        '[scenario]\nseed = 2\n[run]\nplant = "kinematic"\nduration = 0.05\n'
    )
    code, _, err = run(capsys, "simulate", "--config", config, "--out", tmp_path / "a", "--no-plots")
    assert code == 0, err
    meta = SimulationResult.load(tmp_path / "a" / "result.npz").metadata
    locked = Arm.from_robot("panda", locked_joints={"panda_joint7": 0.5})
    assert meta["arm_identity"] == json.loads(json.dumps(locked.identity().to_dict()))
    assert meta["scenario"] == iy.scenarios.for_arm(locked, 2).name
    # --robot replaces the file's [arm] (its locked joint is the Panda's, not the UR5's)
    code, _, err = run(
        capsys, "simulate", "--config", config, "--robot", "ur5", "--out", tmp_path / "b", "--no-plots"
    )
    assert code == 0, err
    assert SimulationResult.load(tmp_path / "b" / "result.npz").metadata["arm_identity"]["robot"] == "ur5"


def test_each_mount_flag_changes_the_arm(arms):
    from ibvs_youla.cli.base import resolve_arm
    from ibvs_youla.cli.parser import build_parser

    def arm(*flags):
        return resolve_arm(build_parser().parse_args(["simulate", "--robot", "panda", *flags]))

    plain = arm()
    assert plain.identity() == arms["panda"].identity()
    moved = arm("--T-F-C", "0,0,0.1,0,0,90")  # 10 cm along z, a quarter turn about z
    np.testing.assert_allclose(moved.T_F_C[:3, 3], [0.0, 0.0, 0.1], atol=1e-15)
    np.testing.assert_allclose(moved.T_F_C[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)
    assert not np.allclose(moved.T_F_C, plain.T_F_C) and moved.identity() != plain.identity()
    on_hand = arm("--camera-frame", "panda_hand")
    assert on_hand.camera_frame == "panda_hand" != plain.camera_frame
    locked = arm("--locked-joint", "panda_joint7=0.5")
    assert (locked.nq, plain.nq) == (6, 7) and locked.locked_joints["panda_joint7"] == 0.5


def test_compare_runs_the_arm_s_scenario(capsys, tmp_path):
    argv = ("compare", "--robot", "ur5", "--controllers", "fb,ibvs-current", "--plant", "kinematic")
    code, text, err = run(capsys, *argv, "--duration", "0.05", "--out", tmp_path, "--no-plots")
    assert code == 0, err
    assert text.startswith("ur5-0 on the kinematic plant of the ur5, 0.05 s simulated")
    rows = json.loads((tmp_path / "table.json").read_text())["rows"]
    assert [r["controller"] for r in rows] == ["fb", "ibvs-current"]


# ----------------------------------------------------------------------------- campaigns
def test_arm_cases_are_drawn_within_the_arm_s_limits_and_away_from_its_singularities(arms):
    panda = arms["panda"]
    lo, hi = np.asarray(panda.q_min), np.asarray(panda.q_max)
    margin = LIMIT_MARGIN * (hi - lo)
    for case in generate_cases("arm-physical", 4, 5, arm=panda):
        for q in (np.asarray(case.scenario["q_start"]), np.asarray(case.scenario["q_target"])):
            assert q.shape == (7,) and np.all(q >= lo + margin - 1e-12) and np.all(q <= hi - margin + 1e-12)
            assert np.linalg.svd(panda.camera_jacobian(q), compute_uv=False)[-1] >= MIN_JACOBIAN_SIGMA
    # the IRB 4600's wrist margin (|q5| >= 10 deg) is its spherical wrist's, not the UR5's
    q5 = [abs(c.scenario["q_target"][4]) for c in generate_cases("arm-physical", 40, 1, arm=arms["ur5"])]
    assert min(q5) < math.radians(10.0)


def test_keys_of_two_arms_differ_and_the_irb4600_s_do_not_change(arms):
    irb = CampaignDefinition(**IRB4600_DEFINITION)
    assert [s.key for s in irb.specs()] == IRB4600_KEYS
    assert irb.arm is None and "arm" not in irb.to_dict()
    same = CampaignDefinition(**IRB4600_DEFINITION, arm=Arm.irb4600())  # the paper's arm is no record
    assert same.arm is None and [s.key for s in same.specs()] == IRB4600_KEYS
    keys = {}
    for name, arm in arms.items():
        definition = CampaignDefinition(**{**IRB4600_DEFINITION, "cases": 1}, arm=arm)
        specs = definition.specs()
        assert all(s.arm["robot"] == name and len(s.arm["urdf_sha256"]) == 64 for s in specs)
        assert len(specs[0].scenario["q_start"]) == arm.nq
        keys[name] = {s.key for s in specs}
        assert CampaignDefinition.from_dict(json.loads(json.dumps(definition.to_dict()))) == definition
    assert not keys["ur5"] & keys["panda"] and not (keys["ur5"] | keys["panda"]) & set(IRB4600_KEYS)
    assert arm_from_record(arm_record(arms["panda"])).identity() == arms["panda"].identity()


def test_a_folder_made_before_arms_were_a_parameter_resumes(tmp_path):
    """The folder was written by the package before this change (2 IRB 4600 runs of fb, seed 3)."""
    out = tmp_path / "old"
    shutil.copytree(OLD_FOLDER, out)
    stored = json.loads((out / "campaign.json").read_text())
    assert "arm" not in stored
    definition = CampaignDefinition.from_dict({k: v for k, v in stored.items() if k != "format"})
    summary = run_campaign(definition, out, workers=0, progress=False)
    assert (summary.runs, summary.stored_before, summary.ran, summary.other_rows) == (2, 2, 0, 0)


def test_campaign_and_robustness_run_on_the_chosen_arm(capsys, tmp_path):
    common = (
        "--cases",
        "1",
        "--controllers",
        "fb",
        "--plant",
        "kinematic",
        "--duration",
        "0.05",
        "--workers",
        "0",
    )
    code, text, err = run(
        capsys, "campaign", "--robot", "ur5", *common, "--no-progress", "--out", tmp_path / "c"
    )
    assert code == 0, err
    assert "on the kinematic plant of the ur5" in text
    assert json.loads((tmp_path / "c" / "campaign.json").read_text())["arm"]["robot"] == "ur5"
    rows = pd.read_parquet(tmp_path / "c" / "rows")
    assert len(rows) == 1 and rows["outcome"].iloc[0] != "error"
    argv = ("robustness", "--robot", "panda", "--axis", "noise", "--values", "0,1", *common, "--no-progress")
    code, text, err = run(capsys, *argv, "--out", tmp_path / "r")
    assert code == 0, err
    study = json.loads((tmp_path / "r" / "study.json").read_text())
    assert study["campaign"]["arm"]["robot"] == "panda"
    for value in ("0", "1"):
        stored = json.loads(next((tmp_path / "r").glob(f"noise={value}*/campaign.json")).read_text())
        assert stored["arm"]["robot"] == "panda"


class _FakeViewer:
    """Stands in for ibvs_youla.viz.Viewer: records the arm it was given and what it played."""

    def __init__(self, arm=None, camera=None, **options):
        self.arm, self.url, self.played = arm, "http://127.0.0.1:7000/static/", None
        _FakeViewer.last = self

    def show_scenario(self, scenario):
        self.scenario = scenario.name

    def play(self, result, speed=1.0, fps=30.0):
        self.played = result.signals["q_true"][-1]

    def close(self):
        pass


def test_view_draws_the_chosen_arm_and_a_saved_run_s_own(capsys, tmp_path, monkeypatch):
    import sys
    import types

    monkeypatch.setitem(sys.modules, "ibvs_youla.viz", types.SimpleNamespace(Viewer=_FakeViewer))
    code, _, err = run(
        capsys, "view", "--robot", "panda", "--plant", "kinematic", "--duration", "0.02", "--no-wait"
    )
    assert code == 0, err
    assert _FakeViewer.last.arm.robot == "panda" and _FakeViewer.last.played.shape == (7,)
    ur5 = Arm.from_robot("ur5")
    result = iy.simulate(iy.scenarios.for_arm(ur5, 1), "fb", arm=ur5, plant="kinematic", duration=0.02)
    code, _, err = run(capsys, "view", "--result", result.save(tmp_path / "ur5.npz"), "--no-wait")
    assert code == 0, err
    assert _FakeViewer.last.arm.identity() == ur5.identity()  # rebuilt from the run's metadata
