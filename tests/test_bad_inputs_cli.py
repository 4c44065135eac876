"""Bad command lines and bad TOML files: one line on stderr, exit 2 or 1, never a traceback.

Each CLI row runs ``main(argv)`` in this process and asserts the exit code
(2 for a bad argument, 1 for everything else), that stderr holds exactly one line
``ibvs-youla: error: ...`` that names the flag (or key, or file), and no ``Traceback``. The TOML
rows load a file with ``load_config`` and assert a ``ConfigError`` naming the dotted key. The
global ``--debug`` flag shows the traceback instead.
"""

from __future__ import annotations

import pytest

from ibvs_youla import cli
from ibvs_youla.config import load_config
from ibvs_youla.exceptions import ConfigError
from ibvs_youla.simulation.progress import COMPILE_MESSAGE
from ibvs_youla.simulation.results import SimulationResult

SIM = ("simulate", "--scenario", "paper-1", "--no-plots")


def run(capsys, argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def one_error_line(err):
    """The one error line a terminal shows: a progress bar's carriage-return redraws are not lines, and a
    mistyped (or missing) command or option has the usage before it. The first run's compile notice
    (COMPILE_MESSAGE, on a cold Numba cache: a clean checkout) is information, not an error line."""
    lines = [line.split("\r")[-1] for line in err.split("\n")]
    lines = [line for line in lines if line.strip() and line.strip() != COMPILE_MESSAGE]
    if lines[0].startswith("usage: ibvs-youla"):
        lines = [line for line in lines[1:] if not line.startswith(" ")]  # wrapped usage lines are indented
    assert len(lines) == 1, err
    assert lines[0].startswith("ibvs-youla: error: "), err
    assert "Traceback" not in err
    return lines[0]


@pytest.fixture
def paths(tmp_path):
    """A file where a folder is expected, a path below that file, and a folder."""
    a_file = tmp_path / "a_file"
    a_file.write_text("not a folder\n")
    folder = tmp_path / "folder"
    folder.mkdir()
    return {"FILE": str(a_file), "UNDER_FILE": str(a_file / "sub"), "DIR": str(folder), "TMP": str(tmp_path)}


def _fill(argv, paths):
    return [paths.get(a, a) if a.isupper() else a for a in argv]


# --------------------------------------------------------------------------- argument errors: exit 2
USAGE = [
    pytest.param((*SIM, "--duration", "0"), "--duration", id="simulate-duration-zero"),
    pytest.param((*SIM, "--duration", "-1"), "--duration", id="simulate-duration-negative"),
    pytest.param((*SIM, "--duration", "nan"), "--duration", id="simulate-duration-nan"),
    pytest.param((*SIM, "--duration", "inf"), "--duration", id="simulate-duration-inf"),
    pytest.param((*SIM, "--duration", "abc"), "--duration", id="simulate-duration-text"),
    pytest.param((*SIM, "--duration", "0.0004"), "--duration", id="simulate-duration-below-one-step"),
    pytest.param((*SIM, "--duration", "1e12"), "--duration", id="simulate-duration-too-large"),
    pytest.param(("simulate", "--scenario", "bogus"), "--scenario", id="simulate-scenario-unknown"),
    pytest.param((*SIM, "--controller", "bogus"), "--controller", id="simulate-controller-unknown"),
    pytest.param((*SIM, "--plant", "rigid"), "--plant", id="simulate-plant-unknown"),
    pytest.param(("simulate", "--no-plots"), "--scenario", id="simulate-no-scenario"),
    pytest.param((*SIM, "--fixed", "--adaptive"), "--adaptive", id="simulate-fixed-and-adaptive"),
    pytest.param((*SIM, "--out", "FILE"), "--out", id="simulate-out-is-a-file"),
    pytest.param((*SIM, "--out", "UNDER_FILE"), "--out", id="simulate-out-under-a-file"),
    pytest.param(("design", "--tau-in", "0"), "--tau-in", id="design-tau-in-zero"),
    pytest.param(("design", "--tau-in", "1e-300"), "--tau-in", id="design-tau-in-tiny"),
    pytest.param(("design", "--tau-in", "1e300"), "--tau-in", id="design-tau-in-huge"),
    pytest.param(("design", "--zeta", "-1"), "--zeta", id="design-zeta-negative"),
    pytest.param(("design", "--zeta", "1e300"), "--zeta", id="design-zeta-1e300"),
    pytest.param(("design", "--omega-n", "200"), "--omega-n", id="design-omega-above-1/tau"),
    pytest.param(("design", "--tau-forward", "1e-300"), "--tau-forward", id="design-tau-forward-tiny"),
    pytest.param(("design", "--tau-forward", "x"), "--tau-forward", id="design-tau-forward-text"),
    pytest.param(("design", "--plot", "--out", "FILE"), "--out", id="design-out-is-a-file"),
    pytest.param(("design", "outer", "--plot", "--out", "UNDER_FILE"), "--out", id="design-out-under-a-file"),
    pytest.param(
        ("bench", "simulation", "--", "--repeats", "0"), "--repeats", id="bench-simulation-repeats-0"
    ),
    pytest.param(("bench", "outer", "--", "--repeats", "0"), "--repeats", id="bench-outer-repeats-0"),
    pytest.param(
        ("bench", "controllers", "--", "--repeats", "0"), "--repeats", id="bench-controllers-repeats-0"
    ),
    pytest.param(("bench", "campaign", "--", "--repeats", "0"), "--repeats", id="bench-campaign-repeats-0"),
    pytest.param(
        ("bench", "simulation", "--", "--duration", "-1"), "--duration", id="bench-duration-negative"
    ),
    pytest.param(("bench", "outer", "--", "--configs", "0"), "--configs", id="bench-outer-configs-0"),
    pytest.param(("bench", "simulation", "--json", "FILE"), "--json", id="bench-json-is-a-file"),
    pytest.param(("bench", "--repeats", "0"), "--repeats", id="bench-repeats-without-separator"),
    pytest.param(
        ("compare", "--scenario", "paper-1", "--duration", "0"), "--duration", id="compare-duration-0"
    ),
    pytest.param(
        ("compare", "--scenario", "paper-1", "--camera-rate", "-5"), "--camera-rate", id="compare-rate-neg"
    ),
    pytest.param(
        ("compare", "--scenario", "paper-1", "--camera-rate", "300"), "--camera-rate", id="compare-rate-300"
    ),
    pytest.param(
        ("compare", "--scenario", "paper-1", "--controllers", "bogus"), "--controllers", id="compare-ctrl"
    ),
    pytest.param(("compare", "--scenario", "paper-1", "--out", "FILE"), "--out", id="compare-out-is-a-file"),
    pytest.param(
        ("compare", "--suite", "gans2003", "--plant", "dynamic"), "--plant", id="compare-suite-plant"
    ),
    pytest.param(("campaign", "--cases", "0", "--out", "DIR"), "--cases", id="campaign-cases-0"),
    pytest.param(
        ("campaign", "--cases", "2", "--workers", "-1", "--out", "DIR"), "--workers", id="campaign-workers"
    ),
    pytest.param(
        ("campaign", "--cases", "2", "--seed", "-1", "--out", "DIR"), "--seed", id="campaign-seed-neg"
    ),
    pytest.param(
        ("campaign", "--cases", "2", "--difficulty", "0", "--out", "DIR"), "--difficulty", id="campaign-d0"
    ),
    pytest.param(
        ("campaign", "--cases", "2", "--batch-rows", "0", "--out", "DIR"), "--batch-rows", id="campaign-b0"
    ),
    pytest.param(
        ("campaign", "--cases", "2", "--duration", "nan", "--out", "DIR"), "--duration", id="campaign-nan"
    ),
    pytest.param(("campaign", "--cases", "2", "--out", "FILE"), "--out", id="campaign-out-is-a-file"),
    pytest.param(("campaign-report", "DIR", "--out", "FILE"), "--out", id="campaign-report-out-is-a-file"),
    pytest.param(("reproduce", "--duration", "0", "--out", "DIR"), "--duration", id="reproduce-duration-0"),
    pytest.param(
        ("reproduce", "--diagnosis-duration", "-1", "--out", "DIR"), "--diagnosis-duration", id="repr-diag"
    ),
    pytest.param(
        ("reproduce", "--scenarios", "bogus", "--out", "DIR"), "--scenarios", id="reproduce-scenario"
    ),
    pytest.param(("reproduce", "--out", "FILE"), "--out", id="reproduce-out-is-a-file"),
    pytest.param(("reproduce", "--out", "UNDER_FILE"), "--out", id="reproduce-out-under-a-file"),
    pytest.param(("view", "--scenario", "paper-1", "--speed", "0"), "--speed", id="view-speed-0"),
    pytest.param(("view", "--scenario", "paper-1", "--fps", "-1"), "--fps", id="view-fps-negative"),
    pytest.param(
        ("campaign", "--cases", "100000000000", "--family", "free-planar", "--workers", "0", "--out", "DIR"),
        "--cases",
        id="campaign-cases-too-many-for-memory",
    ),
    pytest.param(
        ("campaign", "--cases", "1", "--scheduler", "tcp://127.0.0.1:99999", "--out", "DIR"),
        "--scheduler",
        id="campaign-scheduler-port-out-of-range",
    ),
    pytest.param(("robustness", "--axis", "noise", "--out", "FILE"), "--out", id="robustness-out-is-a-file"),
    pytest.param(
        ("compare", "--scenario", "gans-rz-30", "--plant", "dynamic", "--out", "DIR"),
        "--plant",
        id="compare-suite-task-on-an-arm-plant",
    ),
    pytest.param(
        ("compare", "--scenario", "paper-1", "--duration", "1e-6", "--no-plots", "--out", "DIR"),
        "--duration",
        id="compare-duration-below-one-tick",
    ),
    pytest.param((*SIM, "--plant", "free-camera"), "free-camera", id="simulate-joint-controller-free-camera"),
    pytest.param((*SIM, "--out", "/proc/ibvs-youla-out"), "--out", id="simulate-out-cannot-be-created"),
    pytest.param(("bogus",), "bogus", id="unknown-command"),
    pytest.param((), "COMMAND", id="no-command"),
    pytest.param(("--debug",), "COMMAND", id="debug-without-command"),
]


@pytest.mark.parametrize(("argv", "flag"), USAGE)
def test_argument_errors_exit_2_with_one_line_naming_the_flag(capsys, paths, argv, flag):
    code, _, err = run(capsys, _fill(argv, paths))
    line = one_error_line(err)
    assert code == 2, err
    assert flag in line


def test_a_folder_that_cannot_be_created_says_so_and_why(capsys):
    code, _, err = run(capsys, (*SIM, "--out", "/proc/ibvs-youla-out/run"))
    line = one_error_line(err)
    assert code == 2
    assert "the output folder cannot be created (No such file or directory: /proc/ibvs-youla-out)" in line


@pytest.mark.parametrize(
    "argv",
    [
        pytest.param((*SIM, "--plant", "free-camera"), id="simulate-plant-the-controller-cannot-drive"),
        pytest.param((*SIM, "--duration", "1e12"), id="simulate-duration-too-long"),
        pytest.param(("compare", "--scenario", "paper-1", "--duration", "1e-6", "--no-plots"), id="compare"),
    ],
)
def test_a_refused_run_leaves_no_output_folder(capsys, tmp_path, argv):
    code, _, err = run(capsys, (*argv, "--out", str(tmp_path / "out" / "run")))
    assert code == 2, err
    assert list(tmp_path.iterdir()) == []


def test_a_refused_run_says_how_to_make_it_fit(capsys):
    _, _, err = run(capsys, (*SIM, "--duration", "1e12"))
    line = one_error_line(err)
    assert "record_every" in line and "shorter" in line


def test_an_out_file_is_left_untouched(capsys, paths):
    run(capsys, (*SIM, "--out", paths["FILE"], "--duration", "0.01"))
    with open(paths["FILE"]) as f:
        assert f.read() == "not a folder\n"


# ------------------------------------------------------------------- configuration files: exit 2
def _write(tmp_path, content, name="run.toml"):
    path = tmp_path / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    return str(path)


CONFIG = [
    pytest.param(b"[settings]\nzeta = 10.0 # \xe9t\xe9\n", "UTF-8", id="config-latin-1"),
    pytest.param(b"\xff\xfe\x00[\x00s\x00", "UTF-8", id="config-utf-16"),
    pytest.param(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", "UTF-8", id="config-binary"),
    pytest.param("[settings\nzeta = 10\n", "TOML", id="config-not-toml"),
    pytest.param("zeta = ", "TOML", id="config-truncated"),
    pytest.param("[settings]\nbogus = 1\n", "settings.bogus", id="config-unknown-key"),
    pytest.param("[bogus]\nx = 1\n", "bogus", id="config-unknown-table"),
    pytest.param("[settings]\nzeta = '10'\n", "settings.zeta", id="config-zeta-string"),
    pytest.param("[run]\nduration = 1e12\n", "duration", id="config-duration-too-large"),
]


@pytest.mark.parametrize(("content", "fragment"), CONFIG)
def test_config_errors_exit_2_with_one_line_and_write_nothing(capsys, tmp_path, content, fragment):
    path = _write(tmp_path, content)
    code, _, err = run(capsys, (*SIM, "--config", path, "--out", str(tmp_path / "out")))
    line = one_error_line(err)
    assert code == 2, err
    assert fragment in line
    assert not (tmp_path / "out").exists()


def test_config_errors_name_the_file(capsys, tmp_path):
    path = _write(tmp_path, b"\xff\xfe")
    _, _, err = run(capsys, ("design", "--config", path))
    assert path in one_error_line(err)
    code, _, err = run(capsys, ("design", "--config", str(tmp_path)))  # a folder
    assert code == 2 and str(tmp_path) in one_error_line(err)
    code, _, err = run(capsys, ("design", "--config", str(tmp_path / "missing.toml")))
    assert code == 2 and "missing.toml" in one_error_line(err)


def test_a_full_disk_is_one_line_exit_1(capsys, tmp_path, monkeypatch):
    def no_space(self, path, *args, **kwargs):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(SimulationResult, "save", no_space)
    code, _, err = run(capsys, (*SIM, "--duration", "0.01", "--out", str(tmp_path / "out")))
    line = one_error_line(err)
    assert code == 1
    assert "No space left on device" in line and "result.npz" in line


def test_an_unexpected_error_is_one_line_that_points_to_debug(capsys, tmp_path, monkeypatch):
    import ibvs_youla.simulation.simulate as simulate_module

    def broken(*args, **kwargs):
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(simulate_module, "simulate", broken)
    code, _, err = run(capsys, (*SIM, "--duration", "0.01", "--out", str(tmp_path / "out")))
    line = one_error_line(err)
    assert code == 1
    assert "ZeroDivisionError" in line and "--debug" in line


def test_debug_shows_the_traceback(capsys, tmp_path):
    path = _write(tmp_path, "[settings]\nzeta = '10'\n")
    code, _, err = run(capsys, ("--debug", "design", "--config", path))
    assert code == 2
    assert "Traceback" in err and "ConfigError" in err and "settings.zeta" in err
    code, _, err = run(capsys, ("--debug", "design", "--zeta", "1e300"))
    assert code == 2 and "Traceback" in err and "--zeta" in err


def test_debug_does_not_change_a_successful_run(capsys):
    code, out, err = run(capsys, ("--debug", "design", "inner"))
    assert code == 0 and err == ""
    assert "tau_in" in out


# ------------------------------------------------------------------- TOML files: ConfigError naming the key
TOML = [
    pytest.param("[bogus]\nx = 1\n", "bogus", id="unknown-table"),
    pytest.param("[settings]\nbogus = 1\n", "settings.bogus", id="settings-unknown-key"),
    pytest.param("[scenario]\npreset = 'paper-1'\nbogus = 1\n", "scenario.bogus", id="scenario-unknown-key"),
    pytest.param("[run]\nbogus = 1\n", "run.bogus", id="run-unknown-key"),
    pytest.param("[camera]\nbogus = 1\n", "camera.bogus", id="camera-unknown-key"),
    pytest.param("[arm]\nbogus = 1\n", "arm.bogus", id="arm-unknown-key"),
    pytest.param("[settings.sv_policy]\nbogus = 1\n", "settings.sv_policy.bogus", id="sv-policy-unknown-key"),
    pytest.param("settings = 3\n", "settings", id="settings-not-a-table"),
    pytest.param("[[run]]\nduration = 1.0\n", "run", id="run-array-of-tables"),
    pytest.param("[settings]\nzeta = '10'\n", "settings.zeta", id="zeta-string"),
    pytest.param("[settings]\nzeta = true\n", "settings.zeta", id="zeta-bool"),
    pytest.param("[settings]\nzeta = 1e300\n", "settings.zeta", id="zeta-1e300"),
    pytest.param("[settings]\nzeta = nan\n", "settings.zeta", id="zeta-nan"),
    pytest.param("[settings]\ntau_in = inf\n", "settings.tau_in", id="tau_in-inf"),
    pytest.param("[settings]\ntau_in = [0.01]\n", "settings.tau_in", id="tau_in-list"),
    pytest.param("[settings]\ntau_in = 1e-300\n", "settings.tau_in", id="tau_in-tiny"),
    pytest.param("[settings]\nomega_n = 200\n", "settings.omega_n", id="omega_n-above-1/tau"),
    pytest.param("[settings]\ntau_forward = 1e-300\n", "settings.tau_forward", id="tau_forward-tiny"),
    pytest.param("[settings]\nrecord_every = 1.5\n", "settings.record_every", id="record_every-float"),
    pytest.param("[settings]\nrecord_every = 0\n", "settings.record_every", id="record_every-zero"),
    pytest.param("[settings]\nsaturate = 1\n", "settings.saturate", id="saturate-int"),
    pytest.param(
        "[settings]\nestimate_from_image = 'yes'\n", "settings.estimate_from_image", id="estimate-str"
    ),
    pytest.param("[settings]\nsv_policy = 3\n", "settings.sv_policy", id="sv-policy-int"),
    pytest.param("[settings.sv_policy]\nkind = 'pinv'\n", "settings.sv_policy.kind", id="sv-kind"),
    pytest.param("[settings.sv_policy]\nthreshold = 2\n", "settings.sv_policy.threshold", id="sv-threshold"),
    pytest.param("[settings]\ncamera_rate_hz = 300\n", "settings.camera_rate_hz", id="camera-rate-300"),
    pytest.param("[settings]\njoint_rate_hz = -1\n", "settings.joint_rate_hz", id="joint-rate-negative"),
    pytest.param("[settings]\npreset = 'fast'\n", "settings.preset", id="settings-preset"),
    pytest.param("[settings]\nfeedforward = 'step'\n", "settings.feedforward", id="feedforward-unknown"),
    pytest.param("[settings]\nlinearize_at = 1\n", "settings.linearize_at", id="linearize-int"),
    pytest.param(
        "[settings]\nsmooth_speed_fraction = 2\n", "settings.smooth_speed_fraction", id="fraction-2"
    ),
    pytest.param("[run]\nduration = 0\n", "run.duration", id="duration-zero"),
    pytest.param("[run]\nduration = '1'\n", "run.duration", id="duration-string"),
    pytest.param("[run]\nduration = -inf\n", "run.duration", id="duration-minus-inf"),
    pytest.param("[run]\nadaptive = 'false'\n", "run.adaptive", id="adaptive-string"),
    pytest.param("[run]\ncontroller = 'bogus'\n", "run.controller", id="controller-unknown"),
    pytest.param("[run]\nplant = 3\n", "run.plant", id="plant-int"),
    pytest.param("[scenario]\npreset = 'paper-9'\n", "scenario.preset", id="scenario-preset"),
    pytest.param(
        "[scenario]\npreset = 'paper-1'\nq_start_deg = [1, 2]\n", "scenario.q_start_deg", id="q-short"
    ),
    pytest.param("[scenario]\npreset = 'paper-1'\nq_start_deg = 'abc'\n", "scenario.q_start_deg", id="q-str"),
    pytest.param(
        "[scenario]\npreset = 'paper-1'\nq_target_deg = [0, 0, 0, 0, 0, nan]\n",
        "scenario.q_target_deg",
        id="q-nan",
    ),
    pytest.param(
        "[scenario]\npreset = 'paper-1'\nmarkers_O = [[0, 0, 0], [1, 0, 0], [2, 0, 0]]\n",
        "scenario.markers_O",
        id="markers-collinear",
    ),
    pytest.param(
        "[scenario]\npreset = 'paper-1'\nmarkers_O = [[0, 0]]\n", "scenario.markers_O", id="markers-short"
    ),
    pytest.param(
        "[scenario]\npreset = 'paper-1'\njoint_offset_deg = '1'\n", "scenario.joint_offset_deg", id="offset"
    ),
    pytest.param(
        "[scenario]\npreset = 'paper-1'\nvirtual_points = 'yes'\n", "scenario.virtual_points", id="vp"
    ),
    pytest.param("[scenario]\npreset = 'paper-1'\nname = 3\n", "scenario.name", id="scenario-name-int"),
    pytest.param("[scenario]\nq_start_deg = [0, 0, 0, 0, 0, 0]\n", "scenario.", id="scenario-incomplete"),
    pytest.param("[camera]\nframe_rate = 7\n", "camera.frame_rate", id="camera-frame-rate"),
    pytest.param("[camera]\nframe_rate = true\n", "camera.frame_rate", id="camera-frame-rate-bool"),
    pytest.param("[camera]\nmode = '4K'\n", "camera.mode", id="camera-mode"),
    pytest.param("[camera]\npreset = 1\n", "camera.preset", id="camera-preset-int"),
    pytest.param("[arm]\nactuator = 1\n", "arm.actuator", id="arm-actuator-int"),
    pytest.param(b"[settings]\nzeta = 10 # \xe9\n", "config", id="not-utf-8"),
    pytest.param("[settings\n", "config", id="not-toml"),
]


@pytest.mark.parametrize(("content", "key"), TOML)
def test_toml_errors_name_the_key(tmp_path, content, key):
    path = _write(tmp_path, content)
    with pytest.raises(ConfigError) as info:
        cfg = load_config(path)
        cfg.make_camera()
        cfg.make_arm()
    assert key in str(info.value), info.value
    assert info.value.name.startswith(key.rstrip(".")), info.value.name


def test_an_output_folder_another_process_makes_meanwhile_is_accepted(tmp_path, monkeypatch):
    """Two runs started together with one --out: each tries to create the folder (then removes it
    again). The one whose mkdir finds the other's folder takes it as made, not as "cannot be created
    (File exists)" (a clean checkout's CI run, 2026-12-03, in test_reproduce_interrupted.py), and
    leaves it to its maker, whose trial folder may by then hold files."""
    from pathlib import Path

    from ibvs_youla.cli.arguments import folder_path

    out = tmp_path / "out" / "run"
    real_mkdir = Path.mkdir

    def the_other_process_first(self, *args, **kwargs):
        real_mkdir(self, *args, **kwargs)  # made by the other process ...
        if self == out:
            (self / "rows.part").write_text("")  # ... which writes into its run
        raise FileExistsError(17, "File exists", str(self))

    monkeypatch.setattr(Path, "mkdir", the_other_process_first)
    assert folder_path(str(out)) == out
    monkeypatch.setattr(Path, "mkdir", real_mkdir)
    assert (out / "rows.part").is_file()  # not removed: neither folder was this call's to remove

    other = tmp_path / "other" / "run"  # made by this call, written into by the other before removal
    real_rmdir = Path.rmdir

    def written_into_first(self):
        if self == other:
            (self / "rows.part").write_text("")
        real_rmdir(self)

    monkeypatch.setattr(Path, "rmdir", written_into_first)
    assert folder_path(str(other)) == other  # the trial folder is left to the process writing it
    assert (other / "rows.part").is_file()
