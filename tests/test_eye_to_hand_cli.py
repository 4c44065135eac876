"""Eye-to-hand from the command line and TOML: ``--mount``, ``[scenario] mount``, compare and view.

``--mount eye-to-hand`` (``simulate``, ``view``, ``compare``) and ``[scenario] mount =
"eye-to-hand"`` choose the arm's seeded eye-to-hand scenario (``scenarios.eye_to_hand``: a camera
fixed in front of the arm, the markers on its flange) where ``--seed`` alone chooses the eye-in-hand
one (``scenarios.for_arm``); each test runs the same command without the mount and checks that the
mount alone changed the run. A mount with a scenario of joints and markers (those are eye-in-hand)
or on the free camera is an argument error (exit 2). Campaigns choose the mount by their family
(``--family arm-eye-to-hand``, tests/test_eye_to_hand_campaign.py).
"""

from __future__ import annotations

import json
import sys
import types

import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla import cli
from ibvs_youla.config import load_config
from ibvs_youla.exceptions import ConfigError
from ibvs_youla.model.arm import Arm
from ibvs_youla.simulation.results import SimulationResult

SHORT = ("--plant", "kinematic", "--controller", "ibvs-current", "--duration", "0.2", "--no-plots")


def run(capsys, *argv):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_simulate_mount_eye_to_hand_runs_the_arm_s_eye_to_hand_scenario(capsys, tmp_path):
    code, _, err = run(
        capsys, "simulate", "--mount", "eye-to-hand", "--seed", "2", *SHORT, "--out", tmp_path / "e"
    )
    assert code == 0, err
    code, _, err = run(capsys, "simulate", "--seed", "2", *SHORT, "--out", tmp_path / "i")
    assert code == 0, err
    to_hand = SimulationResult.load(tmp_path / "e" / "result.npz")
    in_hand = SimulationResult.load(tmp_path / "i" / "result.npz")
    expected = iy.scenarios.eye_to_hand(Arm.irb4600(), 2)
    assert to_hand.metadata["mount"] == expected.mount.to_dict()
    np.testing.assert_array_equal(to_hand.metadata["markers_E"], expected.markers_E)
    assert "mount" not in in_hand.metadata and "markers_O" in in_hand.metadata
    np.testing.assert_allclose(to_hand.signals["q"][0], expected.q_start, rtol=0, atol=1e-12)
    assert to_hand.metadata["scenario"] == expected.name != in_hand.metadata["scenario"]


def test_a_toml_scenario_mount_chooses_the_eye_to_hand_scenario(capsys, tmp_path):
    config = tmp_path / "e2h.toml"
    config.write_text('[arm]\nrobot = "ur5"\n\n[scenario]\nmount = "eye-to-hand"\nseed = 1\n')
    loaded = load_config(config)
    assert loaded.scenario is None and (loaded.scenario_mount, loaded.scenario_seed) == ("eye-to-hand", 1)
    code, _, err = run(capsys, "simulate", "--config", config, *SHORT, "--out", tmp_path / "run")
    assert code == 0, err
    result = SimulationResult.load(tmp_path / "run" / "result.npz")
    expected = iy.scenarios.eye_to_hand(Arm.from_robot("ur5"), 1)
    assert result.metadata["mount"] == expected.mount.to_dict()
    assert result.metadata["arm_identity"]["robot"] == "ur5"
    config.write_text('[scenario]\nmount = "eye-to-hand"\npreset = "paper-1"\n')
    with pytest.raises(ConfigError, match=r"scenario\.mount.*\(which is eye-in-hand\): remove preset"):
        load_config(config)
    code, _, err = run(capsys, "simulate", "--config", config, *SHORT, "--out", tmp_path / "bad")
    assert code == 2 and "scenario.mount" in err
    config.write_text('[scenario]\nmount = "eye-on-the-wall"\n')
    with pytest.raises(ConfigError, match="'eye-in-hand' or 'eye-to-hand'"):
        load_config(config)


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (("simulate", "--mount", "eye-to-hand", "--scenario", "paper-1"), "an eye-in-hand scenario"),
        (
            ("simulate", "--mount", "eye-to-hand", "--plant", "free-camera", "--controller", "pbvs"),
            "arm plant",
        ),
        (("compare", "--mount", "eye-to-hand", "--scenario", "paper-2"), "seeded eye-to-hand scenario"),
        (("compare", "--mount", "eye-to-hand", "--suite", "gans2003"), "--suite gans2003"),
        (("simulate", "--mount", "eye-in-the-sky"), "invalid choice"),
    ],
)
def test_a_mount_the_scenario_cannot_take_exits_2(capsys, tmp_path, argv, fragment):
    code, _, err = run(capsys, *argv, "--out", tmp_path / "x")
    assert code == 2 and fragment in err, err
    assert not (tmp_path / "x").exists()


def test_compare_mount_eye_to_hand_compares_on_the_eye_to_hand_scenario(capsys, tmp_path):
    argv = ("--controllers", "ibvs-current,pbvs", "--plant", "kinematic", "--duration", "0.2", "--no-plots")
    code, text, err = run(capsys, "compare", "--mount", "eye-to-hand", *argv, "--out", tmp_path / "e")
    assert code == 0, err
    name = iy.scenarios.eye_to_hand(Arm.irb4600(), 0).name
    assert text.startswith(f"{name} on the kinematic plant")
    code, text, err = run(capsys, "compare", "--robot", "irb4600", *argv, "--out", tmp_path / "i")
    assert code == 0, err
    assert not text.startswith(f"{name} ")  # without the mount: the eye-in-hand scenario
    table = json.loads((tmp_path / "e" / "table.json").read_text())
    assert table["scenario"] == name and [row["controller"] for row in table["rows"]] == [
        "ibvs-current",
        "pbvs",
    ]


class _FakeViewer:
    """Stands in for ibvs_youla.viz.Viewer: records the scenario it was shown."""

    def __init__(self, arm=None, camera=None, **options):
        self.arm, self.url = arm, "http://127.0.0.1:7000/static/"
        _FakeViewer.last = self

    def show_scenario(self, scenario):
        self.scenario = scenario

    def play(self, result, speed=1.0, fps=30.0):
        pass

    def close(self):
        pass


def test_view_plays_a_saved_eye_to_hand_run_with_its_mount(capsys, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ibvs_youla.viz", types.SimpleNamespace(Viewer=_FakeViewer))
    scenario = iy.scenarios.eye_to_hand(Arm.irb4600(), 0)
    result = iy.simulate(scenario, "ibvs-current", plant="kinematic", duration=0.05)
    code, _, err = run(capsys, "view", "--result", result.save(tmp_path / "e2h.npz"), "--no-wait")
    assert code == 0, err
    shown = _FakeViewer.last.scenario
    assert shown.mount.to_dict() == scenario.mount.to_dict()
    np.testing.assert_array_equal(shown.markers_E, scenario.markers_E)
    code, _, err = run(capsys, "view", "--mount", "eye-to-hand", *SHORT[:-1], "--no-wait")
    assert code == 0, err
    assert _FakeViewer.last.scenario.is_eye_to_hand


def test_an_eye_in_hand_mount_alone_chooses_the_seeded_eye_in_hand_scenario(capsys, tmp_path):
    """``--mount eye-in-hand`` (or ``[scenario] mount``) alone: the arm's seeded scenario, as ``--seed 0``."""
    code, _, err = run(capsys, "simulate", "--mount", "eye-in-hand", *SHORT, "--out", tmp_path / "flag")
    assert code == 0, err
    config = tmp_path / "e2h.toml"
    config.write_text('[scenario]\nmount = "eye-to-hand"\n')
    code, _, err = run(
        capsys, "simulate", "--config", config, "--mount", "eye-in-hand", *SHORT, "--out", tmp_path / "over"
    )
    assert code == 0, err  # the flag over the file's mount
    for folder in ("flag", "over"):
        result = SimulationResult.load(tmp_path / folder / "result.npz")
        assert result.metadata["scenario"] == iy.scenarios.for_arm(Arm.irb4600(), 0).name
        assert "mount" not in result.metadata
    config.write_text('[scenario]\nmount = "eye-in-hand"\npreset = "paper-1"\n')  # consistent: the table
    assert load_config(config).scenario.name == "paper-1"
    config.write_text('[scenario]\nmount = "eye-to-hand"\n')
    code, _, err = run(capsys, "simulate", "--config", config, "--scenario", "paper-1", *SHORT)
    assert code == 2 and f"scenario.mount in {config}: received 'eye-to-hand' with --scenario paper-1" in err


def test_view_of_a_saved_run_refuses_a_mount(capsys, tmp_path):
    code, _, err = run(capsys, "view", "--result", tmp_path / "r.npz", "--mount", "eye-to-hand", "--no-wait")
    assert code == 2 and "--scenario/--config/--seed/--mount, not both" in err


def test_an_arm_without_a_home_configuration_needs_its_scenario(capsys, tmp_path):
    """A URDF arm has no home to draw a seeded scenario about: simulate and compare say what to give."""
    from ibvs_youla.model._resources import example_robot_data_urdf

    urdf = example_robot_data_urdf("ur_description/urdf/ur5_robot.urdf")
    for command in ("simulate", "compare"):
        argv = (
            command,
            "--urdf",
            urdf,
            "--camera-frame",
            "tool0",
            "--mount",
            "eye-to-hand",
            "--plant",
            "kinematic",
        )
        code, _, err = run(capsys, *argv, "--out", tmp_path / command)
        assert code == 2 and "has no home configuration" in err, err
