"""TOML run configurations: schema, defaults, and one error per bad key naming key and valid values."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from ibvs_youla import scenarios
from ibvs_youla.config import RunConfig, load_config, parse_config
from ibvs_youla.exceptions import ConfigError, IbvsYoulaError
from ibvs_youla.model.camera import StereoCamera, default_camera
from ibvs_youla.simulation.settings import SimulationSettings

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples").glob("*.toml"))


def test_empty_document_gives_the_paper_defaults():
    cfg = parse_config({})
    assert isinstance(cfg, RunConfig)
    assert cfg.scenario is None
    assert cfg.settings == SimulationSettings()
    assert (cfg.controller, cfg.adaptive, cfg.duration) == (None, None, None)
    # no [camera]: simulate()'s default, the paper's optics in the 100 fps VGA mode
    assert cfg.make_camera() == default_camera()
    # spelled out, not built from the code under test: the paper preset's optics in the VGA mode
    assert cfg.make_camera() == StereoCamera.zed2("paper", "VGA") != StereoCamera.zed2()
    assert cfg.make_camera().frame_rate == 100.0


def test_preset_with_overrides_in_degrees():
    cfg = parse_config(
        {
            "scenario": {
                "preset": "paper-2",
                "name": "mine",
                "joint_offset_deg": 2.0,
                "q_start_deg": [1] * 6,
            },
            "settings": {"zeta": 1.0, "sv_policy": {"kind": "truncate", "threshold": 0.01}, "saturate": True},
            "run": {"controller": "fb", "adaptive": False, "duration": 3},
        }
    )
    base = scenarios.paper(2)
    assert cfg.scenario.name == "mine"
    np.testing.assert_allclose(cfg.scenario.joint_offset, np.full(6, np.radians(2.0)), rtol=0, atol=1e-15)
    np.testing.assert_allclose(cfg.scenario.q_start, np.full(6, np.radians(1.0)), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(cfg.scenario.q_target, base.q_target)
    np.testing.assert_array_equal(cfg.scenario.markers_O, base.markers_O)
    assert cfg.settings.zeta == 1.0 and cfg.settings.saturate is True
    assert (cfg.settings.sv_policy.kind, cfg.settings.sv_policy.threshold) == ("truncate", 0.01)
    assert (cfg.controller, cfg.adaptive, cfg.duration) == ("fb", False, 3.0)


def test_settings_presets():
    assert parse_config({"settings": {"preset": "paper"}}).settings == SimulationSettings.paper()
    assert parse_config({"settings": {"preset": "paper", "zeta": 1.0}}).settings == SimulationSettings.paper(
        zeta=1.0
    )
    assert parse_config({}, settings_preset="paper").settings == SimulationSettings.paper()
    assert parse_config({"settings": {"preset": "default"}}, settings_preset="paper").settings == (
        SimulationSettings()
    )
    assert SimulationSettings.paper().camera_every == 1 and SimulationSettings().camera_every == 10


def test_scenario_written_in_full():
    table = {
        "q_start_deg": [0, 0, 0, 0, 30, 0],
        "q_target_deg": [10, 5, 0, 0, 25, 0],
        "markers_O": [[3.0, 0.0, 1.0], [3.0, 0.5, 0.0], [3.5, -0.5, 0.5], [3.2, 0.2, 0.8]],
    }
    sc = parse_config({"scenario": table}).scenario
    np.testing.assert_allclose(np.degrees(sc.q_target), table["q_target_deg"], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(sc.markers_O, table["markers_O"])
    assert sc.name == "custom" and not sc.virtual_points and not sc.has_disturbance


def test_settings_keys_cover_every_simulation_setting():
    from ibvs_youla.config import _settings_keys

    # secondary_task (the null-space task of a redundant arm) joins the TOML keys with the config's arm
    fields = {f.name for f in dataclasses.fields(SimulationSettings)} - {"secondary_task"}
    assert set(_settings_keys()) == fields | {"preset"}


@pytest.mark.parametrize(
    ("document", "key", "valid_fragment"),
    [
        ({"setings": {}}, "setings", "[settings]"),
        ({"settings": {"zetta": 1.0}}, "settings.zetta", "zeta"),
        ({"settings": {"zeta": -1.0}}, "settings.zeta", "[1e-06, 1e+12]"),  # ZETA_RANGE
        ({"settings": {"zeta": "ten"}}, "settings.zeta", "a finite number"),
        ({"settings": {"feedforward": "fast"}}, "settings.feedforward", "'paper' or 'smooth'"),
        ({"settings": {"saturate": "yes"}}, "settings.saturate", "true or false"),
        ({"settings": {"record_every": 1.5}}, "settings.record_every", "an integer"),
        ({"settings": {"camera_rate_hz": 300.0}}, "settings.camera_rate_hz", "divides joint_rate_hz"),
        ({"settings": {"omega_n": 10.0, "linearize_at": "end"}}, "settings.linearize_at", "'start'"),
        ({"settings": {"sv_policy": {"kin": "damped"}}}, "settings.sv_policy.kin", "kind, threshold"),
        ({"settings": {"sv_policy": {"kind": "clip"}}}, "settings.sv_policy.kind", "'damped' or 'truncate'"),
        ({"settings": {"sv_policy": {"threshold": 1.5}}}, "settings.sv_policy.threshold", "[0, 1)"),
        ({"settings": {"sv_policy": 3}}, "settings.sv_policy", "kind, threshold"),
        ({"scenario": {"preset": "paper-3"}}, "scenario.preset", "'physical-2'"),
        ({"scenario": {"preset": "paper-1", "q_start": [0] * 6}}, "scenario.q_start", "q_start_deg"),
        ({"scenario": {"preset": "paper-1", "q_start_deg": [0] * 5}}, "scenario.q_start_deg", "6 finite"),
        ({"scenario": {"preset": "paper-1", "joint_offset_deg": "1"}}, "scenario.joint_offset_deg", "number"),
        (
            {"scenario": {"preset": "paper-1", "markers_O": [[0, 0, 0]] * 2}},
            "scenario.markers_O",
            "three or more",
        ),
        (
            {"scenario": {"preset": "paper-1", "markers_O": [[0, 0, 0], [1, 1, 1], [2, 2, 2]]}},
            "scenario.markers_O",
            "non-collinear",
        ),
        (
            {"scenario": {"preset": "paper-1", "virtual_points": 1}},
            "scenario.virtual_points",
            "true or false",
        ),
        ({"scenario": {"name": "only a name"}}, "scenario.q_start_deg", "preset"),
        ({"settings": {"preset": "fast"}}, "settings.preset", "'default' or 'paper'"),
        ({"settings": {"branch_prior": "nearest"}}, "settings.branch_prior", "'encoders'"),
        ({"run": {"controller": "pid"}}, "run.controller", "'fb' or 'ff+fb'"),
        ({"run": {"duration": -2.0}}, "run.duration", "> 0"),
        ({"run": {"adaptive": "no"}}, "run.adaptive", "true or false"),
        ({"camera": {"mode": "4K"}}, "camera.mode", "'HD720'"),
        ({"camera": {"lens": "wide"}}, "camera.lens", "preset, mode, frame_rate"),
        ({"arm": {"actuator": "direct"}}, "arm.actuator", "'paper' or 'reflected'"),
        ({"run": 5}, "run", "controller, plant, adaptive, duration"),
    ],
)
def test_bad_keys_and_values_name_the_key_and_what_is_valid(document, key, valid_fragment):
    with pytest.raises(ConfigError) as info:
        parse_config(document)
    err = info.value
    assert err.name == key
    assert valid_fragment in err.valid
    assert str(err).startswith(f"{key}: received ")
    assert isinstance(err, IbvsYoulaError) and isinstance(err, ValueError)


def test_camera_frame_rate_is_checked_against_the_mode():
    cfg = parse_config({"camera": {"mode": "HD720", "frame_rate": 100.0}})
    with pytest.raises(ConfigError) as info:
        cfg.make_camera()
    assert info.value.name == "camera.frame_rate"
    assert "(15, 30, 60)" in info.value.valid


def test_camera_and_arm_options_build_them():
    cfg = parse_config({"camera": {"preset": "zed2", "mode": "VGA", "frame_rate": 100}, "arm": {}})
    camera = cfg.make_camera()
    assert camera.focal_length == pytest.approx(2.12e-3, rel=0, abs=1e-15)
    assert camera.frame_rate == 100.0
    assert cfg.make_arm().name.endswith("(paper actuator)")


def test_load_config_reads_toml(tmp_path):
    path = tmp_path / "run.toml"
    path.write_text('[scenario]\npreset = "physical-2"\n[settings]\ntau_in = 0.02\n[run]\nduration = 1.5\n')
    cfg = load_config(path)
    assert cfg.scenario == scenarios.physical(2)
    assert cfg.settings.tau_in == 0.02 and cfg.duration == 1.5
    assert cfg.source == str(path)


def test_load_config_rejects_invalid_toml_and_missing_files(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[settings]\nzeta = \n")
    with pytest.raises(ConfigError) as info:
        load_config(bad)
    assert info.value.name == "config" and "valid TOML" in info.value.valid and "line 2" in info.value.valid
    with pytest.raises(ConfigError) as info:
        load_config(tmp_path / "missing.toml")
    assert info.value.name == "config" and "readable" in info.value.valid


def test_examples_exist_and_load():
    assert [p.name for p in EXAMPLES] == [
        "custom_scenario.toml",
        "kinematic_arm.toml",
        "paper_scenario1.toml",
        "physical.toml",
    ]
    configs = {p.stem: load_config(p) for p in EXAMPLES}
    kinematic = configs["kinematic_arm"]
    assert kinematic.scenario == scenarios.paper(2) and kinematic.plant == "kinematic"
    assert kinematic.controller == "ff+fb" and kinematic.settings == SimulationSettings.paper()
    assert configs["paper_scenario1"].scenario == scenarios.paper(1)
    assert configs["paper_scenario1"].settings == SimulationSettings.paper()  # spelled out
    assert configs["physical"].scenario == scenarios.physical(1)
    assert configs["physical"].settings.feedforward == "smooth"
    custom = configs["custom_scenario"].scenario
    assert custom.name == "custom-small-move" and not custom.virtual_points
