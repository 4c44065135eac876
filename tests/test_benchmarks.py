"""The benchmark scripts run and write the JSON keys other tools read (numbers only; no timing asserted)."""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def load(name):
    sys.path.insert(0, str(BENCHMARKS))  # as `ibvs-youla bench` does: the scripts import _timing
    try:
        spec = importlib.util.spec_from_file_location(name, BENCHMARKS / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(BENCHMARKS))
    return module


def controllers_names():
    from ibvs_youla import controllers

    return controllers.names()


def finite_positive(x):
    return isinstance(x, float) and math.isfinite(x) and x > 0.0


@pytest.mark.slow
def test_outer_loop_benchmark_writes_its_keys(tmp_path):
    out = tmp_path / "outer.json"
    report = load("bench_outer_loop").main(
        ["--configs", "4", "--repeats", "1", "--rebuilds", "1", "--json", str(out)]
    )
    saved = json.loads(out.read_text())
    keys = [
        "update_median_us",
        "update_p95_us",
        "floor_median_us",
        "ratio_to_floor",
        "rebuild_ratio",
        "camera_pose_median_us",
        "sensor_median_us",
        "p3p_median_us",
        "ik_median_us",
        "jacobian_median_us",
        "svd_gains_median_us",
        "state_update_median_us",
    ]
    for key in keys:
        assert finite_positive(saved[key]), key
    assert saved["ratio_to_floor"] == pytest.approx(saved["update_median_us"] / saved["floor_median_us"])
    assert saved["glue_median_us"] == pytest.approx(saved["update_median_us"] - saved["parts_sum_median_us"])
    assert saved["target"]["met"] == (saved["ratio_to_floor"] <= 2.5)
    assert saved["stats"]["update"]["n"] == 4
    assert saved["machine"]["cores"] >= 1 and saved["machine"]["date"]
    assert report["update_median_us"] == saved["update_median_us"]
    assert [h["ratio_to_floor"] for h in saved["history"]] == [saved["ratio_to_floor"]]


@pytest.mark.slow
def test_simulation_benchmark_writes_realtime_factors(tmp_path):
    out = tmp_path / "simulation.json"
    load("bench_simulation").main(
        ["--duration", "0.02", "--classical-duration", "0.2", "--repeats", "1", "--json", str(out)]
    )
    saved = json.loads(out.read_text())
    assert set(saved["realtime_factor"]) == {"paper-1", "paper-2"}
    for factors in saved["realtime_factor"].values():
        assert set(factors) == {"paper", "two-rate"}
        assert all(finite_positive(v) for v in factors.values())
    for case in [*saved["cases"].values(), *saved["classical"].values()]:
        assert case["status"] == "complete"
        assert sum(case["split"]["fraction"].values()) == pytest.approx(1.0)
    assert set(saved["classical"]) == {
        "kinematic/physical-2",
        "free-camera/physical-2",
        "free-camera/gans-general",
    }
    assert all(finite_positive(c["realtime_factor"]) for c in saved["classical"].values())
    met = saved["targets"]["met"]
    assert met["two-rate"]["paper-1"] == (saved["realtime_factor"]["paper-1"]["two-rate"] >= 50.0)
    assert set(saved["robots"]) == {"irb4600", "ur5", "panda"}
    for name, row in saved["robots"].items():
        assert row["paper"]["status"] == row["classical"]["status"] == "complete", name
        assert finite_positive(row["paper"]["realtime_factor"]) and finite_positive(
            row["classical"]["cost_vs_irb4600"]
        )
    assert saved["robots"]["irb4600"]["classical"]["cost_vs_irb4600"] == 1.0
    assert met["robots"]["panda"]["paper"] == (saved["robots"]["panda"]["paper"]["realtime_factor"] >= 20.0)


@pytest.mark.slow
def test_controllers_benchmark_writes_every_method(tmp_path):
    from ibvs_youla import controllers

    out = tmp_path / "controllers.json"
    report = load("bench_controllers").main(["--configs", "3", "--repeats", "1", "--json", str(out)])
    saved = json.loads(out.read_text())
    names = controllers.names()
    assert tuple(saved["controllers"]) == names  # every registered method, in registry order
    for name, entry in saved["controllers"].items():
        for key in ("median_us", "p95_us", "floor_us", "ratio_to_floor"):
            assert finite_positive(entry[key]), (name, key)
        assert entry["ratio_to_floor"] == pytest.approx(entry["median_us"] / entry["floor_us"])
        assert entry["n"] == 3
        # the moment features refuse the square and physical-2's isosceles markers: timed on seven points
        # photometric servoing needs the image of a textured scene: it runs on the textured case alone
        expected_case = {
            "fb": "stereo",
            "ff+fb": "stereo",
            "ibvs-moments": "irregular",
            "photometric": "textured",
        }
        assert entry["case"] == expected_case.get(name, "mono")
    assert set(saved["cases"]["stereo"]["methods"]) == set(names) - {"ibvs-moments", "photometric"}
    assert set(saved["cases"]["mono"]["methods"]) == set(names) - {
        "fb",
        "ff+fb",
        "ibvs-moments",
        "photometric",
    }
    assert set(saved["cases"]["irregular"]["methods"]) == set(names) - {"fb", "ff+fb", "photometric"}
    assert set(saved["cases"]["textured"]["methods"]) == {"photometric"}
    assert saved["controllers"]["photometric"]["floor_us"] == pytest.approx(
        saved["cases"]["textured"]["floor_calls_median_us"]["dot_LTe"]
    )
    assert set(saved["cases"]["textured"]["parts_median_us"]) == {"scene_frame", "render_plane"}
    assert "isotropic" in saved["cases"]["mono"]["refused"]["ibvs-moments"]
    assert set(saved["cases"]["stereo"]["refused"]) == {"ibvs-moments"}
    floor_calls = saved["cases"]["mono"]["floor_calls_median_us"]
    assert saved["controllers"]["mpc-ibvs"]["floor_us"] == pytest.approx(
        floor_calls["solvepnp"] + floor_calls["daqp"]
    )
    for name in ("numpy-ibvs", "library-ibvs-law"):
        assert finite_positive(saved["reference"][name]["median_us"])
        assert saved["reference"][name]["n"] == 3
    assert "visp-computeControlLaw" in saved["reference"]["not_timed"]
    assert saved["machine"]["cores"] >= 1 and saved["machine"]["date"]
    assert report["controllers"] == saved["controllers"]


def test_controllers_benchmark_reference_law_is_classical_ibvs():
    """The numpy reference law computes what ClassicalIBVS computes from the same features and depths."""
    import numpy as np

    from ibvs_youla import PinholeCamera
    from ibvs_youla.controllers.ibvs import ClassicalIBVS
    from ibvs_youla.model.camera import points_interaction_matrix

    rng = np.random.default_rng(3)
    P_C = np.column_stack((rng.uniform(-0.2, 0.2, (4, 2)), rng.uniform(0.6, 1.2, 4)))  # [m]
    s = (P_C[:, :2] / P_C[:, 2:]).ravel()
    s_target = s + 0.05 * rng.standard_normal(8)
    camera = PinholeCamera.normalized()
    L = points_interaction_matrix(camera, P_C, False)
    expected = -0.5 * ClassicalIBVS().pinv(L).dot(s - s_target)
    got = load("bench_controllers").numpy_ibvs(s, P_C[:, 2], s_target, 0.5)
    assert np.max(np.abs(got - expected)) < 1e-12
    assert np.linalg.norm(expected) > 1e-3  # a non-trivial twist


def test_cli_benchmark_writes_every_call_and_its_table(tmp_path):
    out = tmp_path / "cli.json"
    report = load("bench_cli").main(["--repeats", "1", "--no-eager", "--json", str(out)])
    saved = json.loads(out.read_text())
    bench = load("bench_cli")
    assert set(saved["calls"]) == set(bench.CALLS) and set(saved["reference"]) == {"interpreter"}
    for call in saved["calls"].values():
        assert finite_positive(call["median_ms"]) and call["n"] == 1
    slowest = max(saved["calls"].values(), key=lambda c: c["median_ms"])
    assert saved["slowest"]["median_ms"] == slowest["median_ms"]
    assert saved["targets"]["met"] is (slowest["median_ms"] < 500.0)  # the verdict follows the figure
    assert report["ratio_eager_to_help"] is None and len(saved["history"]) == 1
    table = load("figures").cli(saved)
    assert "`ibvs-youla simulate --scenaro paper-1`" in table and "python -c pass" in table


@pytest.mark.slow
def test_campaign_benchmark_writes_runs_per_minute_and_scaling(tmp_path):
    out = tmp_path / "campaign.json"
    argv = [
        "--cases",
        "1",
        "--arm-cases",
        "1",
        "--duration",
        "0.2",
        "--arm-duration",
        "0.05",
        "--json",
        str(out),
    ]
    report = load("bench_campaign").main(argv)
    saved = json.loads(out.read_text())
    assert set(saved["campaigns"]) == {"free", "arm"}
    for name, runs in (("free", 7), ("arm", 9)):  # 1 case x 7 twist methods; x all 9 methods on the arm
        campaign = saved["campaigns"][name]
        assert campaign["runs"] == runs and campaign["same_rows"] is True
        assert set(campaign["workers"]) == {"1", "2"}
        for entry in (campaign["serial"], *campaign["workers"].values()):
            assert finite_positive(entry["runs_per_minute"]) and finite_positive(entry["wall_s"])
            assert entry["runs_per_minute"] == pytest.approx(runs / entry["wall_s"] * 60.0)
            assert sum(entry["outcomes"].values()) == runs
        for k, entry in campaign["workers"].items():
            assert entry["overhead_share"] == pytest.approx(
                1.0 - entry["run_wall_sum_s"] / int(k) / entry["wall_s"]
            )
            assert entry["files"] == 1  # fewer rows than one batch
        one, two = (campaign["workers"][k]["runs_per_minute"] for k in ("1", "2"))
        assert campaign["scaling"] == pytest.approx(two / one)
    minutes = saved["projection"]["free_1000x7_minutes"]
    assert minutes["2"] == pytest.approx(7000 / saved["campaigns"]["free"]["workers"]["2"]["runs_per_minute"])
    assert set(saved["targets"]["met"]) == {
        "scaling",
        "overhead_share",
        "free_1000x7_minutes",
        "arm_1000x7_minutes",
    }
    arm = saved["projection"]["arm_1000x7_minutes"]
    assert finite_positive(arm["2"]) and finite_positive(
        saved["projection"]["arm_1000x7_all_methods_minutes"]["2"]
    )
    # its fixed set (the paper's two and the seven methods it compares itself with), not the registry:
    # the projections are per 1000 cases x 7 twist methods
    bench = load("bench_campaign")
    assert set(saved["projection"]["arm_run_s_by_method"]) == set(bench.ARM_METHODS)
    assert set(bench.ARM_METHODS) <= set(controllers_names())
    assert len(saved["history"]) == 1 and saved["history"][0]["arm_1000x7_minutes_2_workers"] == arm["2"]
    assert saved["machine"]["cores"] >= 1 and saved["machine"]["date"]
    assert report["campaigns"]["free"]["scaling"] == saved["campaigns"]["free"]["scaling"]
    # OpenCV's PnP alone: one SQPnP a frame (0.2 s at 25 Hz: 6 frames) for each method but ibvs-desired,
    # whose L needs no depth; the minutes are the replayed calls' time x 1,000 cases / k workers
    import cv2

    floor = saved["pnp_floor"]
    assert floor["calls_by_method"] == {m: 0 if m == "ibvs-desired" else 6 for m in bench.TWIST_METHODS}
    assert floor["calls_per_case"] == 36 and floor["flags"] == [cv2.SOLVEPNP_SQPNP]
    assert floor["solvers"] == ["SQPNP"]
    assert floor["us_per_call"] == pytest.approx(floor["case_s"] / 36 * 1e6)
    for k in ("1", "2"):
        assert floor["free_1000x7_minutes"][k] == pytest.approx(1000 * floor["case_s"] / int(k) / 60.0)
    # the methods whose measured-campaign rows are checked against the plug-in loop: those that run compiled
    import ibvs_youla as iy
    from test_compiled_frame_path import RATE_25, TUTORIAL

    free = dict(plant="free-camera", camera=iy.PinholeCamera.normalized(), duration=0.08, settings=RATE_25)
    loops = {m: iy.simulate(TUTORIAL, m, **free).metadata["loop"] for m in bench.TWIST_METHODS}
    assert {m for m, loop in loops.items() if loop == "compiled"} == set(bench.COMPILED_METHODS)
    figures = load("figures")  # README's tables: the floor beside the sizings, and among the targets
    assert "OpenCV's PnP alone: 36 SQPNP calls a case" in figures.campaign(saved)
    assert "OpenCV's SQPNP calls alone" in figures.targets({"campaign": saved})


def test_peers_benchmark_writes_our_steps_and_its_table(tmp_path):
    """Without the peers (not tests: ViSP and MVTB are not installed by the suite), the script still
    times our variants, writes their keys and renders its README table; no ratio without a peer."""
    out = tmp_path / "peers.json"
    argv = [
        "--steps",
        "12",
        "--rounds",
        "1",
        "--ours-repeats",
        "1",
        "--no-visp",
        "--no-mvtb",
        "--json",
        str(out),
    ]
    report = load("bench_peers").main(argv)
    saved = json.loads(out.read_text())
    modes = {"depth", "monocular", "monocular, IPPE", "depth, plug-in loop"}
    assert saved["ours"].keys() == report["ours"].keys() >= modes
    compiled = ("depth", "monocular", "monocular, IPPE")
    assert all(saved["ours"][mode]["loop"] == "compiled" for mode in compiled)
    assert saved["ours"]["monocular, plug-in loop"]["loop"] == "plug-in"
    assert all(finite_positive(o["run_ms"]) for o in saved["ours"].values())
    assert saved["peers"] == {} and saved["ratios"] == {} and saved["targets"]["met"] == {}
    table = load("figures").peers(saved)
    assert "measured depth" in table and "ViSP 3.5" not in table and "| n/a | n/a |" in table
    assert 'IPPE depths, `pnp="ippe"`' in table


def test_batch_benchmark_writes_the_case_frame_and_its_table(tmp_path):
    """Without ViSP (the suite does not install it) the script times simulate_batch and renders its table."""
    out = tmp_path / "batch.json"
    argv = [
        "--cases",
        "6",
        "--steps",
        "4",
        "--rounds",
        "1",
        "--monocular-cases",
        "2",
        "--no-visp",
        "--json",
        str(out),
    ]
    report = load("bench_batch").main(argv)
    saved = json.loads(out.read_text())
    assert saved["ours"].keys() == report["ours"].keys() == {"depth", "monocular"}
    for mode, cases in (("depth", 6), ("monocular", 2)):
        o = saved["ours"][mode]
        assert o["cases"] == cases and o["statuses"] == ["complete"]
        assert finite_positive(o["setup_per_case_ms"]) and finite_positive(o["whole_call_per_case_frame_us"])
        short, long = (np.median(o["cpu_s"][k]) for k in ("4", "8"))
        assert o["case_frame_us"] == pytest.approx((long - short) / (cases * 4) * 1e6)
        short, long = (np.median(o["walls_s"][k]) for k in ("4", "8"))
        assert o["case_frame_wall_us"] == pytest.approx((long - short) / (cases * 4) * 1e6)
    assert saved["peers"] == {} and saved["ratios"] == {} and saved["targets"]["met"] == {}
    assert saved["settings"]["openblas_threads"] is not None
    table = load("figures").batch(saved)
    assert "simulate_batch, measured depth" in table and "ViSP" not in table.split("\n")[2]


@pytest.mark.slow
def test_photometric_benchmark_writes_its_keys(tmp_path):
    out = tmp_path / "photometric.json"
    report = load("bench_photometric").main(
        ["--quick", "--configs", "2", "--repeats", "1", "--json", str(out)]
    )
    saved = json.loads(out.read_text())
    assert [e["width_px"] for e in saved["cost"]] == [120, 320, 640]
    for entry in saved["cost"]:
        for key in ("frame", "update", "floor_LTe", "reset"):
            assert finite_positive(entry[key]["median_us"]), key
        assert entry["update_ratio_to_floor"] == pytest.approx(
            entry["update"]["median_us"] / entry["floor_LTe"]["median_us"]
        )
    for axis in ("rotation_z_deg", "translation_x_m"):
        for method in ("photometric", "ibvs-current"):
            d = saved["domains"][axis][method]
            assert len(d["values"]) == len(d["converged"]) == 2 and d["basin"] in d["values"] + [0.0]
    assert set(saved["texture"]["smoothing_texels"]) == {"1.5", "3", "6"}
    assert set(saved["noise"]["steady_mm"]) == {"photometric", "ibvs-current"}
    assert report["cost"] == saved["cost"] and saved["machine"]["date"]


@pytest.mark.slow
def test_detection_benchmark_writes_the_sweep_and_the_time_per_frame(tmp_path):
    out = tmp_path / "detection.json"
    report = load("bench_detection").main(["--frames", "1", "--repeats", "2", "--json", str(out)])
    saved = json.loads(out.read_text())
    rows = saved["sweeps"]["moments"]
    assert len(rows) == 24 and {r["depth_m"] for r in rows} == {0.5, 1.0, 1.5, 2.0, 2.5, 3.0}
    assert all(r["detected"] == 1.0 and r["residual_max_px"] < 0.3 for r in rows)
    for mode in ("VGA", "HD720"):
        timing = saved["timing"][mode]
        for key in ("observe_median_ms", "observe_cpu_median_ms", "render_median_ms", "detect_median_ms"):
            assert finite_positive(timing[key]), key
        assert timing["stats"]["observe"]["n"] == 2
    assert saved["timing"]["HD720"]["resolution"] == [1280, 720]
    assert report["settings"]["diameter_m"] == 0.05


def test_reports_keep_their_history(tmp_path):
    """write_json appends the run's headline to the file's history; a report from before histories
    existed becomes the first entry; the latest report stays at the top level."""
    timing = load("_timing")
    out = tmp_path / "report.json"
    legacy = {
        "benchmark": "x",
        "ratio": 5.5,
        "machine": {"date": "2026-11-23T11:19:00+00:00", "load_average_1min": 0.7},
    }
    out.write_text(json.dumps(legacy))
    for ratio, date in ((2.2, "2026-12-02T10:00:00+00:00"), (2.1, "2026-12-02T11:00:00+00:00")):
        report = {
            "benchmark": "x",
            "ratio": ratio,
            "machine": {"date": date, "load_average": [0.5, 0.4, 0.3]},
        }
        timing.write_json(str(out), report, lambda r: {"ratio": r["ratio"]})
    saved = json.loads(out.read_text())
    assert saved["ratio"] == 2.1
    assert [h["ratio"] for h in saved["history"]] == [5.5, 2.2, 2.1]
    assert [h["date"][:10] for h in saved["history"]] == ["2026-11-23", "2026-12-02", "2026-12-02"]
    assert saved["history"][0]["load_average"] == [0.7] and saved["history"][-1]["load_average"] == [
        0.5,
        0.4,
        0.3,
    ]


@pytest.mark.slow
def test_run_all_regenerates_the_readme_blocks_from_the_reports(tmp_path):
    """run_all.py runs the chosen benchmarks into the reports folder (their histories grow), then
    rewrites each README block between its markers from the reports, leaving the prose alone."""
    readme = tmp_path / "README.md"
    readme.write_text(
        "Prose before.\n<!-- figures:outer_loop -->\nold figures\n<!-- /figures:outer_loop -->\n"
        "Prose between.\n<!-- figures:history -->\nold\n<!-- /figures:history -->\nProse after.\n"
    )
    reports = tmp_path / "reports"
    argv = ["--quick", "--only", "outer_loop", "--reports", str(reports), "--readme", str(readme)]
    assert load("run_all").main(argv) == 0
    assert load("run_all").main(argv) == 0
    saved = json.loads((reports / "outer_loop.json").read_text())
    assert len(saved["history"]) == 2
    text = readme.read_text()
    assert text.startswith("Prose before.\n<!-- figures:outer_loop -->\n| |")
    assert "old figures" not in text and "Prose between." in text and text.endswith("Prose after.\n")
    assert f"**{saved['ratio_to_floor']:,.2f}**" in text  # the ratio of the latest report
    assert text.count("| 20") >= 2  # two rows of history, one per run (dates of this century)


def test_the_history_pairs_runs_taken_together_and_keeps_a_simulation_run_taken_alone():
    """An outer-loop run and the simulation run of the same run_all.py call share a row; a
    simulation run taken again later (``--only simulation``) gets a row of its own."""
    figures = load("figures")

    def sim(date, paper):
        return {"date": date, "realtime_factor": {"paper-1": {"paper": paper, "two-rate": 2 * paper}}}

    reports = {
        "outer_loop": {"history": [{"date": "2026-12-02T00:43:29+00:00", "ratio_to_floor": 2.06}]},
        "simulation": {
            "history": [sim("2026-12-02T00:43:32+00:00", 16.0), sim("2026-12-02T00:49:36+00:00", 21.8)]
        },
    }
    rows = figures.history(reports).splitlines()[2:]
    assert rows == [
        "| 2026-12-02 00:43 | n/a | n/a | 2.06 | 16.0 | 32.0 | n/a | n/a |",
        "| 2026-12-02 00:49 | n/a | n/a | n/a | 21.8 | 43.6 | n/a | n/a |",
    ]
