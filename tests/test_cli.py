"""The ibvs-youla command line: help, one-line errors with exit codes, and every subcommand's output."""

from __future__ import annotations

import json
import subprocess
import sys
import types
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla import cli
from ibvs_youla.cli import bench as cli_bench
from ibvs_youla.exceptions import SimulationDivergedError
from ibvs_youla.simulation.results import SimulationResult

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = (
    "reproduce",
    "simulate",
    "compare",
    "campaign",
    "campaign-report",
    "robustness",
    "design",
    "view",
    "bench",
)


def run(capsys, *argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def one_error_line(err):
    """The one error line; a mistyped (or missing) command or option has the usage before it."""
    lines = [line for line in err.splitlines() if line.strip()]
    if lines[0].startswith("usage: ibvs-youla"):
        lines = [line for line in lines[1:] if not line.startswith(" ")]  # wrapped usage lines are indented
    assert len(lines) == 1, err
    assert lines[0].startswith("ibvs-youla: error: ")
    assert "Traceback" not in err
    return lines[0]


# ----------------------------------------------------------------------------- help and usage errors
@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_has_help(capsys, command):
    code, out, _ = run(capsys, command, "--help")
    assert code == 0
    assert out.startswith(f"usage: ibvs-youla {command}")


def test_top_level_help_lists_the_commands_and_version(capsys):
    code, out, _ = run(capsys, "--help")
    assert code == 0 and all(c in out for c in COMMANDS)
    code, out, _ = run(capsys, "--version")
    assert (code, out.strip()) == (0, f"ibvs-youla {iy.__version__}")


def test_console_script_is_declared():
    from importlib.metadata import entry_points

    (script,) = [e for e in entry_points(group="console_scripts") if e.name == "ibvs-youla"]
    assert script.value == "ibvs_youla.cli:main"


@pytest.mark.parametrize(
    ("argv", "fragments"),
    [
        ((), ["required: COMMAND"]),
        (("simulate", "--scenario", "paper-3"), ["'paper-3'", "'physical-2'"]),
        (("simulate", "--scenario", "paper-1", "--duration", "-1"), ["--duration", "'-1'", "> 0"]),
        (("simulate", "--scenario", "paper-1", "--duration", "nan"), ["'nan'", "> 0"]),
        (("simulate", "--scenario", "paper-1", "--controller", "pid"), ["'pid'", "'ff+fb'"]),
        (("simulate", "--scenario", "paper-1", "--fixed", "--adaptive"), ["not allowed with"]),
        (("simulate", "--duration", "1"), ["--scenario NAME", "--config FILE"]),
        (("simulate", "--scenario", "paper-1", "--bogus"), ["unrecognized arguments: --bogus"]),
        (("reproduce", "--scenarios", "paper-9"), ["'paper-9'", "'paper-1'"]),
        (("reproduce", "--diagnosis-duration", "-5"), ["'-5'", ">= 0"]),
        (("design", "middle"), ["'middle'", "'outer'"]),
        (("design", "--zeta", "0"), ["--zeta", "'0'", "> 0"]),
        (("bench", "fast"), ["'fast'", "'simulation'"]),
        (("view", "--speed", "-2"), ["--speed", "'-2'"]),
        (("frobnicate",), ["'frobnicate'", "'reproduce'"]),
        (("design", "--", "--zeta", "1"), ["design: unrecognized arguments after --: --zeta 1"]),
        (("simulat",), ["'simulat'; did you mean 'simulate'?"]),
        (("campaign-reprot", "x"), ["did you mean 'campaign-report'?"]),
        (("simulate", "--scenaro", "paper-1"), ["--scenaro paper-1; did you mean --scenario?"]),
        (("simulate", "--duraton=3"), ["did you mean --duration?", "'ibvs-youla simulate --help'"]),
        (("simulate", "--controller", "ff-fb"), ["'ff-fb'; did you mean 'ff+fb'?"]),
        (("compare", "--scenario", "paper-1", "--controllers", "pvbs"), ["'pvbs'; did you mean 'pbvs'?"]),
        (
            ("campaign", "--cases", "1", "--out", "x", "--controllers", "ibvs-curent"),
            ["did you mean 'ibvs-current'"],
        ),
        (("robustness", "--axis", "noize", "--out", "x"), ["'noize'; did you mean 'noise'?"]),
        (("simulate", "--zzz"), ["unrecognized arguments: --zzz (see"]),  # nothing near: no suggestion
    ],
)
def test_bad_arguments_exit_2_with_one_line(capsys, argv, fragments):
    code, out, err = run(capsys, *argv)
    assert code == 2 and out == ""
    line = one_error_line(err)
    for fragment in fragments:
        assert fragment in line


@pytest.mark.parametrize(
    ("argv", "usage"),
    [
        (("simulate", "--scenaro", "paper-1"), "usage: ibvs-youla simulate [-h]"),
        (("campaign", "--cases", "1", "--out", "x", "--seeed", "1"), "usage: ibvs-youla campaign [-h]"),
        (("simulat",), "usage: ibvs-youla [-h]"),
        ((), "usage: ibvs-youla [-h]"),
    ],
)
def test_a_mistyped_option_or_command_shows_its_usage(capsys, argv, usage):
    code, out, err = run(capsys, *argv)
    assert code == 2 and out == "" and err.startswith(usage)
    if argv:
        assert "did you mean" in one_error_line(err)


def test_a_bad_value_is_one_line_without_the_usage(capsys):
    code, _, err = run(capsys, "simulate", "--duration", "-1")
    assert code == 2 and err.startswith("ibvs-youla: error: argument --duration:") and err.count("\n") == 1


def test_config_and_library_argument_errors_exit_2_with_one_line(capsys, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[scenario]\npreset = "paper-1"\n[settings]\nzetta = 2.0\n')
    code, _, err = run(capsys, "simulate", "--config", str(bad), "--out", str(tmp_path))
    line = one_error_line(err)
    assert code == 2
    assert "settings.zetta: received 2.0" in line and "zeta" in line and "omega_n" in line
    # a design the library rejects (Section 6.3: 1/omega_n > tau_in) from a flag: an argument error
    code, _, err = run(capsys, "design", "outer", "--omega-n", "200")
    assert code == 2
    assert "argument --omega-n: received 200.0" in one_error_line(err)


def test_scenario_outside_the_joint_limits_is_a_config_error(capsys, tmp_path):
    config = tmp_path / "far.toml"
    config.write_text('[scenario]\npreset = "physical-1"\nq_target_deg = [0, 0, 0, 0, 170, 0]\n')
    code, _, err = run(capsys, "simulate", "--config", str(config), "--out", str(tmp_path / "out"))
    assert code == 2
    assert "joint 5" in one_error_line(err)
    assert not (tmp_path / "out").exists()


# ----------------------------------------------------------------------------- simulate
def refuse_non_finite(constant):
    raise ValueError(f"not strict JSON: {constant}")


def test_simulate_writes_result_figures_and_summary(capsys, tmp_path):
    out = tmp_path / "run"
    code, text, _ = run(
        capsys, "simulate", "--scenario", "physical-2", "--duration", "0.05", "--out", str(out)
    )
    assert code == 0
    result = SimulationResult.load(out / "result.npz")
    assert result.metadata["scenario"] == "physical-2" and result.metadata["controller"] == "ff+fb"
    assert result.metadata["adaptive"] is True and result.duration == pytest.approx(0.05, abs=1e-12)
    assert sorted(p.name for p in (out / "figures").iterdir()) == sorted(
        f"{name}.png"
        for name in (
            "feature_error_norm",
            "image_coordinates",
            "image_plane",
            "joint_angles",
            "joint_speeds_torques",
        )
    )
    summary = json.loads((out / "summary.json").read_text(), parse_constant=refuse_non_finite)
    assert summary["settling_time_s"][0] is None and "never" in summary["null"]  # not settled in 0.05 s
    assert summary["final_feature_error_m"] == pytest.approx(result.final_feature_error.tolist(), abs=0)
    assert summary["outcome"]["kind"] == "converging"
    for label in ("final image error", "final pose error", "2 % settling", "peak joint speed", "outcome"):
        assert label in text
    assert f"max |e| = {np.abs(result.final_feature_error).max():.3g} m" in text


def test_simulate_flags_override_the_config(capsys, tmp_path):
    config = tmp_path / "c.toml"
    config.write_text('[scenario]\npreset = "paper-2"\n[run]\ncontroller = "ff+fb"\nduration = 5.0\n')
    out = tmp_path / "run"
    argv = ("simulate", "--config", str(config), "--controller", "fb", "--fixed", "--duration", "0.02")
    code, _, _ = run(capsys, *argv, "--out", str(out), "--no-plots")
    assert code == 0 and not (out / "figures").exists()
    meta = SimulationResult.load(out / "result.npz").metadata
    assert (meta["scenario"], meta["controller"], meta["adaptive"]) == ("paper-2", "fb", False)
    assert meta["duration"] == pytest.approx(0.02, abs=1e-12)


@pytest.mark.parametrize("example", sorted((ROOT / "examples").glob("*.toml")), ids=lambda p: p.name)
def test_every_example_config_runs(capsys, tmp_path, example):
    code, text, _ = run(
        capsys,
        "simulate",
        "--config",
        str(example),
        "--duration",
        "0.02",
        "--out",
        str(tmp_path),
        "--no-plots",
    )
    assert code == 0
    meta = SimulationResult.load(tmp_path / "result.npz").metadata
    assert text.startswith(f"{meta['scenario']}: ")


def test_default_out_folder_names_the_run(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, _, _ = run(
        capsys, "simulate", "--scenario", "physical-1", "--fixed", "--duration", "0.01", "--no-plots"
    )
    assert code == 0
    assert (tmp_path / "results" / "physical-1_ff+fb_fixed" / "result.npz").is_file()


def test_diverged_run_saves_the_partial_result_and_exits_1(capsys, tmp_path, monkeypatch):
    import ibvs_youla.simulation.simulate as simulate_module

    partial = iy.simulate(iy.scenarios.physical(1), duration=0.01)

    def diverging(*args, **kwargs):
        raise SimulationDivergedError(0.01, "dq", 1e9, 6.3, "dq left its bound at t = 0.01 s", partial)

    monkeypatch.setattr(simulate_module, "simulate", diverging)
    code, _, err = run(capsys, "simulate", "--scenario", "physical-1", "--out", str(tmp_path))
    assert code == 1
    line = one_error_line(err)
    assert "simulation diverged: dq left its bound at t = 0.01 s" in line
    assert str(tmp_path / "result_partial.npz") in line
    assert len(SimulationResult.load(tmp_path / "result_partial.npz")) == len(partial)


def test_interrupt_exits_130(capsys, tmp_path, monkeypatch):
    import ibvs_youla.simulation.simulate as simulate_module

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(simulate_module, "simulate", interrupted)
    code, _, err = run(capsys, "simulate", "--scenario", "paper-1", "--out", str(tmp_path))
    assert (code, err) == (130, "ibvs-youla: interrupted\n")


# ----------------------------------------------------------------------------- design
def test_design_prints_the_errata_numbers(capsys):
    code, out, _ = run(capsys, "design")
    assert code == 0
    assert "closed-loop poles -100, -100, -100 rad/s" in out  # corrected inner loop
    assert "4.736-56.65j, 4.736+56.65j (unstable)" in out  # ERRATA 8, printed numerator
    assert "phase 53.13 deg at 100 rad/s" in out
    assert "poles -199.5, -0.5013 rad/s" in out and "settling_time() = 7.809 s" in out  # ERRATA 10
    assert "omega_n/(2 zeta) = 0.5 1/s" in out
    assert "max 122x, joint 4" in out  # ERRATA 11: paper-1 step demand on joint 4
    assert "high-frequency gain 33.33" in out


def test_design_options_and_plots(capsys, tmp_path):
    code, out, _ = run(
        capsys, "design", "outer", "--omega-n", "5", "--zeta", "1", "--plot", "--out", str(tmp_path)
    )
    assert code == 0
    assert "INNER" not in out and "poles -5, -5 rad/s" in out
    assert "overshoot 0 %, 2 % settling 1.167 s" in out  # critically damped: 5.834/omega_n
    assert [p.name for p in tmp_path.iterdir()] == ["outer.png"]
    config = tmp_path / "gains.toml"
    config.write_text("[settings]\ntau_in = 0.02\n")
    code, out, _ = run(capsys, "design", "inner", "--config", str(config))
    assert code == 0 and "tau_in = 0.02 s" in out and "closed-loop poles -50, -50, -50" in out


# ----------------------------------------------------------------------------- reproduce
def test_reproduce_runs_and_prints_the_table(capsys, tmp_path):
    argv = (
        "reproduce",
        "--out",
        str(tmp_path),
        "--scenarios",
        "physical-2",
        "--duration",
        "0.02",
        "--diagnosis-duration",
        "0",
    )
    code, out, _ = run(capsys, *argv)
    assert code == 0
    assert "| physical-2 | feedback only | fixed |" in out
    assert (tmp_path / "table.md").read_text() in out
    rows = json.loads((tmp_path / "table.json").read_text())["rows"]
    assert len(rows) == 4
    assert [r["duration_s"] for r in rows] == pytest.approx([0.02] * 4, abs=1e-12)


def test_reproduce_takes_settings_from_a_config(capsys, tmp_path, monkeypatch):
    import ibvs_youla.analysis.reproduce as reproduce_module

    seen = {}

    def fake(out_dir, **kwargs):
        seen.update(kwargs, out_dir=out_dir)
        return reproduce_module.Reproduction(rows=(), table_markdown="| table |", paths={})

    monkeypatch.setattr(reproduce_module, "reproduce", fake)
    config = tmp_path / "r.toml"
    config.write_text("[settings]\nzeta = 1.0\n[run]\nduration = 4.0\n")
    code, out, _ = run(capsys, "reproduce", "--out", str(tmp_path), "--config", str(config), "--no-resume")
    assert code == 0 and "| table |" in out
    assert seen["settings"] == iy.simulation.settings.SimulationSettings.paper(zeta=1.0)
    assert (seen["duration"], seen["resume"], seen["progress"]) == (4.0, False, True)
    assert "scenario_names" not in seen  # reproduce()'s own default
    for text, key in (
        ('[scenario]\npreset = "paper-1"\n', "scenario"),
        ("[run]\nadaptive = false\n", "run.adaptive"),
    ):
        config.write_text(text)
        code, _, err = run(capsys, "reproduce", "--config", str(config))
        line = one_error_line(err)
        assert code == 2 and line.startswith(f"ibvs-youla: error: {key}: received ")
        assert "reproduce reads only [settings] and [run] duration" in line


# ----------------------------------------------------------------------------- view
class FakeViewer:
    instances: ClassVar[list[FakeViewer]] = []

    def __init__(self, arm=None, camera=None, *, zmq_url=None, open_browser=False, connect_timeout=5.0):
        self.url, self.calls = "http://127.0.0.1:7000/static/", []
        self.options = (zmq_url, open_browser)
        FakeViewer.instances.append(self)

    def show_scenario(self, scenario):
        self.calls.append(("show_scenario", scenario.name))

    def play(self, result, speed=1.0, fps=30.0):
        self.calls.append(("play", len(result), speed, fps))
        return 1

    def close(self):
        self.calls.append(("close",))


@pytest.fixture
def fake_viz(monkeypatch):
    FakeViewer.instances.clear()
    monkeypatch.setitem(sys.modules, "ibvs_youla.viz", types.SimpleNamespace(Viewer=FakeViewer))
    return FakeViewer


def test_view_plays_a_saved_result(capsys, tmp_path, fake_viz):
    result = iy.simulate(iy.scenarios.physical(2), duration=0.01)
    path = result.save(tmp_path / "r.npz")
    code, out, _ = run(capsys, "view", "--result", str(path), "--speed", "0.5", "--no-wait")
    assert code == 0 and "http://127.0.0.1:7000/static/" in out
    (viewer,) = fake_viz.instances
    assert viewer.calls == [("show_scenario", "physical-2"), ("play", len(result), 0.5, 30.0), ("close",)]


def test_view_simulates_a_named_scenario(capsys, fake_viz):
    code, _, _ = run(capsys, "view", "--scenario", "physical-1", "--duration", "0.01", "--no-wait", "--open")
    assert code == 0
    (viewer,) = fake_viz.instances
    assert viewer.calls[0] == ("show_scenario", "physical-1") and viewer.calls[1][1] == 11
    assert viewer.options == (None, True)


def test_view_without_the_viewer_is_one_line(capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ibvs_youla.viz", None)  # import raises ImportError
    code, _, err = run(capsys, "view", "--scenario", "paper-1", "--no-wait")
    assert code == 1 and "view needs the Meshcat viewer" in one_error_line(err)


# ----------------------------------------------------------------------------- bench
def test_bench_looks_in_the_repository_benchmarks_folder():
    assert cli_bench._benchmarks_dir() == ROOT / "benchmarks"  # editable install: src/ibvs_youla -> repo root


def test_bench_runs_each_script_with_json_and_extra_arguments(capsys, tmp_path, monkeypatch):
    folder = tmp_path / "benchmarks"
    folder.mkdir()
    for name in cli_bench.BENCHMARKS.values():
        (folder / f"{name}.py").write_text(
            "import json, sys\n"
            "def main(argv):\n"
            "    path = argv[argv.index('--json') + 1]\n"
            f"    open(path, 'w').write(json.dumps({{'name': '{name}', 'argv': argv}}))\n"
            "    return 0\n"
        )
    monkeypatch.setattr(cli_bench, "_benchmarks_dir", lambda: folder)
    code, out, _ = run(capsys, "bench", "--json", str(tmp_path / "reports"), "--", "--repeats", "1")
    assert code == 0 and out.count("== bench_") == len(cli_bench.BENCHMARKS)
    report = json.loads((tmp_path / "reports" / "bench_simulation.json").read_text())
    assert report["argv"][:2] == ["--repeats", "1"]
    assert (tmp_path / "reports" / "bench_outer_loop.json").is_file()


def test_bench_without_benchmarks_is_one_line(capsys, tmp_path, monkeypatch):
    monkeypatch.setattr(cli_bench, "_benchmarks_dir", lambda: tmp_path / "nowhere")
    code, _, err = run(capsys, "bench", "outer")
    assert code == 1 and "bench_outer_loop.py" in one_error_line(err)


# ----------------------------------------------------------------------------- answering at once
HEAVY = (
    "numpy",
    "scipy",
    "pinocchio",
    "control",
    "numba",
    "cv2",
    "dask",
    "distributed",
    "matplotlib",
    "pandas",
    "pyarrow",
    "qpsolvers",
    "meshcat",
    "ibvs_youla.controllers",
    "ibvs_youla.simulation",
    "ibvs_youla.config",
)


def test_help_and_argument_errors_import_no_heavy_package():
    """Parsing is light (lazy imports): what --help and a bad argument load, checked in a fresh process."""
    code = f"""
import sys
from ibvs_youla.cli import main
calls = [["--help"], ["simulate", "--help"], ["campaign", "--help"], ["robustness", "--help"],
         ["simulat"], ["simulate", "--scenaro", "paper-1"],
         ["compare", "--scenario", "paper-1", "--duration", "0"],
         ["campaign", "--cases", "1", "--out", "x", "--scheduler", "tcp://h:99999"]]
codes = [main(argv) for argv in calls]
print(codes, sorted(m for m in {HEAVY!r} if m in sys.modules))
"""
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    )
    assert done.stdout.strip().splitlines()[-1] == "[0, 0, 0, 0, 2, 2, 2, 2] []"
