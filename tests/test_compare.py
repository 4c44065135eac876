"""``ibvs-youla compare`` and the Gans, Hutchinson & Corke 2003 suite (analysis/compare.py, suites.py).

The table's numbers are checked against metrics computed here, independently, from the
same runs (deterministic: the free camera at 25 Hz, the normalized monocular camera and the
20 cm square); the suite's start poses against the displacement each task states; a few
outcomes of the suite are pinned (measured).
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import ibvs_youla as iy
from ibvs_youla.analysis import suites
from ibvs_youla.analysis.compare import CONVERGED_MM, compare, time_to_converge
from ibvs_youla.analysis.comparison_figures import COMPARISON_FIGURES, plot_comparison
from ibvs_youla.exceptions import InvalidParameterError, SimulationDivergedError
from test_cli import one_error_line, run

CONTROLLERS_PAGE = Path(__file__).resolve().parents[1] / "docs" / "controllers.md"
Z_STAR = 0.75  # [m]
CENTRE_O = np.zeros(3)  # the square's centre in the base frame [m]


def simulate_task(name, controller, duration):
    return iy.simulate(
        suites.task(name).scenario(),
        iy.controllers.make(controller),
        plant="free-camera",
        camera=iy.PinholeCamera.normalized(),
        duration=duration,
        settings=iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0),
    )


def in_camera(T_O_C, P_O):
    """P_C = R^T (P_O - t)."""
    return (np.asarray(P_O) - T_O_C[:3, 3]) @ T_O_C[:3, :3]


# ----------------------------------------------------------------------------- the suite's tasks
def test_the_suite_has_the_four_tests_and_unique_names():
    assert suites.TASK_NAMES == (
        "gans-rz-30",
        "gans-rz-60",
        "gans-rz-90",
        "gans-rz-120",
        "gans-rz-150",
        "gans-rz-180",
        "gans-tz-approach",
        "gans-tz-retreat",
        "gans-plane-30",
        "gans-plane-60",
        "gans-general",
    )
    assert [t.test for t in suites.GANS_2003].count(suites.TESTS[0]) == 6
    assert {t.test for t in suites.GANS_2003} == set(suites.TESTS)
    assert not set(suites.TASK_NAMES) & set(iy.scenarios.NAMES)
    assert suites.SUITES["gans2003"] is suites.GANS_2003


@pytest.mark.parametrize("angle", [30, 60, 90, 120, 150, 180])
def test_optical_axis_rotations_differ_from_the_target_by_the_angle_about_z(angle):
    t = suites.task(f"gans-rz-{angle}")
    scenario = t.scenario()
    target = scenario.T_O_C_target
    assert target == pytest.approx(np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -Z_STAR], [0, 0, 0, 1]]))
    D = np.linalg.inv(target) @ scenario.T_O_C_start  # T_C*_C0
    assert np.abs(D[:3, 3]).max() < 1e-15  # [m]: the same centre
    rotvec = Rotation.from_matrix(D[:3, :3]).as_rotvec(degrees=True)
    assert np.linalg.norm(rotvec) == pytest.approx(angle, abs=1e-12)
    assert abs(abs(rotvec[2]) - angle) < 1e-12 and np.abs(rotvec[:2]).max() < 1e-12  # about z
    if angle < 180:
        assert rotvec[2] == pytest.approx(angle, abs=1e-12)  # +theta about z_C*
    # the image: the square's corners turned by -theta about the principal point
    camera = iy.PinholeCamera.normalized()
    s0 = camera.project(in_camera(scenario.T_O_C_start, suites.SQUARE_O))
    s_star = camera.project(in_camera(target, suites.SQUARE_O))
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    assert s0 == pytest.approx(s_star @ np.array([[c, -s], [s, c]]), abs=1e-15)


@pytest.mark.parametrize(("name", "depth"), [("gans-tz-approach", 1.5), ("gans-tz-retreat", 0.375)])
def test_optical_axis_translations_move_along_z_only(name, depth):
    scenario = suites.task(name).scenario()
    D = np.linalg.inv(scenario.T_O_C_target) @ scenario.T_O_C_start
    assert D[:3, :3] == pytest.approx(np.eye(3), abs=0.0)
    assert D[:3, 3] == pytest.approx([0.0, 0.0, Z_STAR - depth], abs=1e-15)
    assert in_camera(scenario.T_O_C_start, CENTRE_O) == pytest.approx([0.0, 0.0, depth], abs=1e-15)


@pytest.mark.parametrize("t", suites.GANS_2003, ids=lambda t: t.name)
def test_every_start_sees_the_square_centre_where_its_parameters_say(t):
    """O(phi) and Rz(theta) keep the camera looking at the centre from Z*; then T(l_x, l_y, -delta):
    the centre is at (-l_x, -l_y, Z* + delta) in the start camera, and the plane's normal makes
    the angle phi with the optical axis (the feature plane appears tilted by phi)."""
    start = t.T_O_C_start
    l_x, l_y = t.lateral_m
    assert in_camera(start, CENTRE_O) == pytest.approx([-l_x, -l_y, Z_STAR + t.retreat_m], abs=1e-15)
    tilt = math.degrees(math.acos(np.clip(start[:3, 2] @ [0.0, 0.0, 1.0], -1.0, 1.0)))
    assert tilt == pytest.approx(abs(t.orbit_deg), abs=1e-6)
    assert np.all(in_camera(start, suites.SQUARE_O)[:, 2] > 0.0)  # in front of the camera


def test_feature_plane_rotation_orbits_about_the_centre():
    for phi in (30.0, 60.0):
        start = suites.task(f"gans-plane-{phi:.0f}").T_O_C_start
        assert np.linalg.norm(start[:3, 3] - CENTRE_O) == pytest.approx(Z_STAR, abs=1e-15)
        assert start[:3, 3] == pytest.approx(
            [-Z_STAR * math.sin(math.radians(phi)), 0.0, -Z_STAR * math.cos(math.radians(phi))], abs=1e-15
        )  # in the x-z plane of the base frame: an orbit about y through the centre


def test_bad_tasks_and_names_are_rejected():
    with pytest.raises(InvalidParameterError, match=r"'gans-rz-45'.*'gans-rz-30'"):
        suites.task("gans-rz-45")
    with pytest.raises(InvalidParameterError, match="test"):
        suites.GansTask("x", "spin")
    with pytest.raises(InvalidParameterError, match="retreat_m"):
        suites.GansTask("x", suites.TESTS[1], retreat_m=-0.75)
    with pytest.raises(InvalidParameterError, match="orbit_deg"):
        suites.GansTask("x", suites.TESTS[2], orbit_deg=90.0)
    with pytest.raises(InvalidParameterError, match="finite"):
        suites.GansTask("x", suites.TESTS[0], rotation_deg=float("nan"))


# ----------------------------------------------------------------------------- the table's numbers
def test_cli_writes_the_table_and_figures_with_the_numbers_of_the_runs(capsys, tmp_path):
    """Every number of table.json recomputed here from a fresh run of the same controller."""
    out = tmp_path / "rz60"
    code, text, _ = run(
        capsys,
        "compare",
        "--scenario",
        "gans-rz-60",
        "--controllers",
        "ibvs-current,pbvs",
        "--duration",
        "15",
        "--out",
        str(out),
    )
    assert code == 0
    assert sorted(p.name for p in (out / "figures").iterdir()) == sorted(
        f"{n}.png"
        for n in COMPARISON_FIGURES
        if n != "joint_speeds"  # no joints on the free camera
    )
    table = json.loads((out / "table.json").read_text())
    assert (table["scenario"], table["plant"], table["duration_s"]) == ("gans-rz-60", "free-camera", 15.0)
    assert table["converged_within"] == {"position_mm": 1.0, "rotation_deg": 0.1}
    markdown = (out / "table.md").read_text()
    assert markdown in text
    for row in table["rows"]:
        result = simulate_task("gans-rz-60", row["controller"], 15.0)
        p = result.camera_pose[:, :3, 3]
        path = sum(np.linalg.norm(p[k + 1] - p[k]) for k in range(len(p) - 1))
        mm = 1e3 * np.linalg.norm(p - result.camera_pose_target[:3, 3], axis=1)
        deg = [
            np.degrees(Rotation.from_matrix(T[:3, :3].T @ result.camera_pose_target[:3, :3]).magnitude())
            for T in result.camera_pose
        ]
        ok = (mm < 1.0) & (np.array(deg) < 0.1)
        first = next(k for k in range(len(ok)) if ok[k:].all())
        assert row["status"] == "complete" and row["outcome"] == "converged"
        assert row["path_length_m"] == pytest.approx(path, rel=1e-12)
        assert row["straight_line_m"] == pytest.approx(0.0, abs=1e-15) and row["path_ratio"] is None
        assert row["max_distance_from_start_m"] == pytest.approx(
            np.linalg.norm(p - p[0], axis=1).max(), rel=1e-12
        )
        assert row["time_to_converge_s"] == pytest.approx(result.t[first], abs=1e-12)
        assert (row["final_position_mm"], row["final_rotation_deg"]) == pytest.approx(
            (mm[-1], deg[-1]), rel=1e-6
        )
        assert row["feature_excursion"] == pytest.approx(np.abs(result.features).max(), rel=1e-12)
        assert row["rotation_needed_deg"] == pytest.approx(60.0, rel=1e-12)
        assert row["markers_left_view"] is False and row["peak_joint_speed_ratio"] is None
        assert row["median_update_us"] > 0.0
        assert f"| {row['controller']} | complete | converged | {result.t[first]:.3g} |" in markdown
        assert f"| {path:.3g} |" in markdown
    ibvs, pbvs = table["rows"]
    # measured: IBVS retreats along the axis and comes back; PBVS turns in place (t_c = 0 throughout)
    assert ibvs["path_length_m"] == pytest.approx(0.236691, rel=1e-5) and pbvs["path_length_m"] < 1e-9
    assert (ibvs["time_to_converge_s"], pbvs["time_to_converge_s"]) == pytest.approx((12.32, 12.68), abs=1e-9)
    assert pbvs["rotation_travelled_deg"] == pytest.approx(60.0 - pbvs["final_rotation_deg"], rel=1e-9)


def test_time_to_converge_is_inf_for_a_run_that_ends_outside():
    short = simulate_task("gans-rz-30", "pbvs", 2.0)
    assert time_to_converge(short) == math.inf
    assert (
        compare(
            suites.task("gans-rz-30").scenario(),
            ["pbvs"],
            plant="free-camera",
            camera=iy.PinholeCamera.normalized(),
            duration=2.0,
            settings=suites.suite_settings(),
        )
        .rows[0]
        .to_dict()["time_to_converge_s"]
        is None
    )


CONVERGED_M = 1e-3 * CONVERGED_MM  # the end point's tolerance [m]


def _general(names, duration):
    task = suites.task("gans-general")
    settings = iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0)
    camera = iy.PinholeCamera.normalized()
    return compare(
        task.scenario(), names, plant="free-camera", camera=camera, duration=duration, settings=settings
    )


def test_the_path_ratio_is_given_for_a_converged_run_and_is_then_at_least_one():
    short, full = _general(["pbvs"], 2.0).row("pbvs"), _general(["pbvs"], 30.0).row("pbvs")
    assert short.outcome == "not converged" and short.straight_line_m > 0.1
    assert short.path_length_m < short.straight_line_m  # a ratio below 1: it stopped short, no detour
    assert short.path_ratio is None
    assert full.outcome == "converged" and full.path_ratio == pytest.approx(1.0, abs=1e-3)
    assert full.path_ratio >= 1.0 - CONVERGED_M / full.straight_line_m


def test_the_image_panels_share_one_scale_and_say_when_a_path_leaves_it():
    """The general motion: ibvs-desired sends the points to |x| = 13.8, the others stay within 0.5."""
    comparison = _general(["ibvs-current", "ibvs-desired", "pbvs"], 30.0)
    panels = [ax for ax in plot_comparison(comparison)["image_plane"].axes if ax.get_visible()]
    assert len(panels) == 3
    limits = {(ax.get_xlim(), ax.get_ylim()) for ax in panels}
    assert len(limits) == 1  # one scale
    ((x_lim, y_lim),) = limits
    assert y_lim[0] > y_lim[1]  # v down
    assert x_lim[1] - x_lim[0] == pytest.approx(y_lim[0] - y_lim[1])  # a square view
    assert x_lim[1] < 2.0  # not stretched to the 13.8 of the one that ran off
    current, desired, pbvs = panels
    assert not current.texts and not pbvs.texts
    assert [t.get_text() for t in desired.texts] == ["leaves the panel: up to |x|, |y| = 13.8"]


def test_incompatible_and_rejected_controllers_get_a_row_not_a_crash(capsys, tmp_path):
    """fb commands joint positions: no arm on the free camera. On the kinematic arm, MPC-IBVS refuses
    paper-2, whose virtual target features lie outside its image box (ERRATA 13)."""
    code, text, _ = run(
        capsys,
        "compare",
        "--scenario",
        "gans-rz-30",
        "--controllers",
        "fb,pbvs",
        "--duration",
        "0.2",
        "--out",
        str(tmp_path / "free"),
        "--no-plots",
    )
    assert code == 0 and not (tmp_path / "free" / "figures").exists()
    fb, pbvs = json.loads((tmp_path / "free" / "table.json").read_text())["rows"]
    assert (fb["status"], fb["outcome"], fb["path_length_m"]) == ("incompatible", "incompatible", None)
    assert "joint_position" in fb["reason"] and "'free-camera'" in fb["reason"]
    assert pbvs["status"] == "complete"
    assert "| fb | incompatible | the controller commands joint_position" in text

    comparison = compare(
        iy.scenarios.paper(2), ["fb", "ibvs-current", "mpc-ibvs"], plant="kinematic", duration=0.2
    )
    mpc = comparison.row("mpc-ibvs")
    assert (mpc.status, mpc.ran) == (
        "rejected",
        False,
    ) and "a box that contains the target features" in mpc.reason
    assert set(comparison.results) == {"fb", "ibvs-current"}
    for name in ("fb", "ibvs-current"):
        result, row = comparison.results[name], comparison.row(name)
        expected = np.max(np.abs(result.dq) / iy.Arm.irb4600().dq_max)
        assert row.peak_joint_speed_ratio == pytest.approx(expected, rel=1e-12)
        assert row.markers_left_view is True  # the paper's markers are out of view (ERRATA 13)
    assert set(plot_comparison(comparison)) == set(COMPARISON_FIGURES)  # joint speeds on an arm


def test_a_diverged_run_is_measured_on_its_partial_record(monkeypatch):
    import ibvs_youla.simulation.simulate as simulate_module

    partial = simulate_task("gans-rz-30", "pbvs", 0.2)
    real = simulate_module.simulate

    def diverging(scenario, controller, **kwargs):
        if controller == "ibvs-desired":
            raise SimulationDivergedError(0.2, "features", 1e9, 1e6, "features left their bound", partial)
        if controller == "ibvs-mean":
            raise SimulationDivergedError(0.0, "features", 1e9, 1e6, "left at once", None)
        return real(scenario, controller, **kwargs)

    monkeypatch.setattr(simulate_module, "simulate", diverging)
    task = suites.task("gans-rz-30")
    comparison = compare(
        task.scenario(),
        ["ibvs-desired", "ibvs-mean", "pbvs"],
        plant="free-camera",
        camera=suites.suite_camera(),
        duration=0.2,
        settings=suites.suite_settings(),
    )
    desired, mean, pbvs = comparison.rows
    assert (desired.status, desired.outcome, desired.reason) == (
        "diverged",
        "diverged",
        "features left their bound",
    )
    assert desired.path_length_m == pbvs.path_length_m  # the partial record is pbvs's run
    assert (mean.status, mean.ran, mean.path_length_m) == ("diverged", False, None)
    assert "| ibvs-mean | diverged | left at once |" in comparison.table_markdown()
    assert set(comparison.results) == {"ibvs-desired", "pbvs"}


@pytest.mark.parametrize(
    ("argv", "fragments"),
    [
        (("--scenario", "gans-rz-45"), ["--scenario", "'gans-rz-45'", "gans-rz-180", "physical-2"]),
        (("--scenario", "gans-rz-30", "--controllers", "pbvs,pid"), ["'pid'", "ibvs-current"]),
        (("--scenario", "gans-rz-30", "--controllers", "pbvs,pbvs"), ["a name given twice"]),
        (("--suite", "gans2004"), ["'gans2004'", "'gans2003'"]),
        ((), ["one of the arguments --scenario --suite is required"]),
        (("--scenario", "paper-1", "--suite", "gans2003"), ["not allowed with"]),
        (
            ("--suite", "gans2003", "--plant", "dynamic"),
            ["--suite gans2003 runs on the free camera", "dynamic"],
        ),
        (("--scenario", "paper-1", "--camera-rate", "0"), ["--camera-rate", "'0'"]),
    ],
)
def test_bad_arguments_exit_2_with_one_line(capsys, argv, fragments):
    code, out, err = run(capsys, "compare", *argv)
    assert code == 2 and out == ""
    line = one_error_line(err)
    for fragment in fragments:
        assert fragment in line


def test_a_suite_task_on_an_arm_plant_exits_2_with_one_line(capsys, tmp_path):
    code, _, err = run(
        capsys, "compare", "--scenario", "gans-rz-30", "--plant", "dynamic", "--out", str(tmp_path / "out")
    )
    assert code == 2 and not (tmp_path / "out").exists()
    assert "--plant: received 'dynamic'" in one_error_line(err) and "free-camera" in err


# ----------------------------------------------------------------------------- the suite's outcomes
def test_rotation_of_pi_pinned_outcomes():
    """Measured on gans-rz-180 over 30 s: classical IBVS retreats until the pose is lost, L* advances
    into the plane, the mean stalls (tests/test_ibvs.py derives all three in closed form); PBVS and
    2.5-D turn in place; the hybrid law switches to PBVS after its dwell and converges."""
    report = suites.run_suite(
        ["ibvs-current", "ibvs-desired", "ibvs-mean", "pbvs", "2.5d", "hybrid"], [suites.task("gans-rz-180")]
    )
    c = report.comparison("gans-rz-180")
    current, desired, mean = c.row("ibvs-current"), c.row("ibvs-desired"), c.row("ibvs-mean")
    assert (current.outcome, desired.outcome, mean.outcome) == ("estimate_failed", "markers_lost", "stalled")
    assert current.path_length_m == pytest.approx(38.432515, rel=1e-6)  # straight back along the axis
    assert current.max_distance_from_start_m == pytest.approx(current.path_length_m, rel=1e-9)
    assert desired.markers_left_view and desired.feature_excursion > suites.NOMINAL_HALF_VIEW
    assert mean.path_length_m < 1e-9 and mean.final_rotation_deg == pytest.approx(180.0, abs=1e-9)
    for name in ("pbvs", "2.5d"):
        row = c.row(name)
        assert row.converged and row.time_to_converge_s == pytest.approx(14.88, abs=1e-9)
        assert row.path_length_m < 1e-9  # a pure rotation about the optical axis
    hybrid = c.row("hybrid")
    assert hybrid.converged and hybrid.time_to_converge_s == pytest.approx(15.04, abs=1e-9)
    table = report.table_markdown()
    assert table.splitlines()[2].startswith(
        "| gans-rz-180 | 0 m, 180 deg | **estimate failed**, 38.43 m | **markers lost**, 0.69 m † | "
        "**stalled**, 0.00 m | 14.9 s, 0.00 m | 14.9 s, 0.00 m | 15.0 s, 0.26 m |"
    )


# Cells whose numbers change with the BLAS kernel's rounding (OpenBLAS picks it per CPU): MPC-IBVS
# retreats 24 m about the optical axis, the QP's active set changes with the last bits, and the time
# and path move by ~2-4 % (27.2 s, 24.26 m on the Haswell kernel; 27.6 s, 25.17 m on SkylakeX), as
# docs/controllers.md says under the table; at 150 deg it goes 3.31 m on Haswell, 3.32 m on
# SkylakeX. Their outcome must match; their numbers within 5 %. The partitioned law's turns from
# 120 deg on are set off by round-off (its xy partition is unstable about the pure roll,
# tests/test_partitioned_ibvs.py): 22.5 s, 1.14 m at 150 deg and 24.5 s, 1.71 m at 180 deg on
# SkylakeX against 22.5 s, 1.18 m and 24.4 s, 1.71 m on Haswell. Any last-bit change moves them:
# taking the monocular depths from the PnP's [R | t] directly moved the Haswell 150 deg cell from
# 23.0 s, 1.34 m. The table is the Haswell kernel's (.ci/run sets it), printed with the code it
# documents.
KERNEL_SENSITIVE_CELLS = {
    ("gans-rz-150", "mpc-ibvs"),
    ("gans-rz-180", "mpc-ibvs"),
    *((f"gans-rz-{angle}", "ibvs-partitioned") for angle in (120, 150, 180)),
}


def _cells(table: str) -> tuple[list[str], dict[str, list[str]]]:
    lines = [line.strip().strip("|").split("|") for line in table.strip().splitlines()]
    header = [c.strip() for c in lines[0]]
    return header, {row[0].strip(): [c.strip() for c in row] for row in lines[2:]}


def _assert_documented(table: str, page: str) -> None:
    """The page holds this table: every cell equal, the kernel-sensitive ones to 5 % in their numbers."""
    header, rows = _cells(table)
    start = page.index("| " + " | ".join(header) + " |")
    doc_header, doc_rows = _cells(page[start:].split("\n\n", 1)[0])
    assert doc_header == header and list(doc_rows) == list(rows)
    for task, cells in rows.items():
        for controller, got, documented in zip(header, cells, doc_rows[task], strict=True):
            if (task, controller) not in KERNEL_SENSITIVE_CELLS:
                assert got == documented, (task, controller)
                continue
            number = r"[-+]?\d+\.?\d*"
            assert re.sub(number, "#", got) == re.sub(number, "#", documented), (task, controller)
            values = [float(v) for v in re.findall(number, got)]
            expected = [float(v) for v in re.findall(number, documented)]
            assert values == pytest.approx(expected, rel=0.05), (task, controller)


def test_the_whole_suite_outcomes(capsys, tmp_path):
    """ibvs-desired loses the markers from 150 deg on and sends the points to |x| = 13.8 in the
    general motion; only the mean and the pose-based laws (PBVS, 2.5-D) turn about the optical axis
    in place; PBVS moves the camera centre on the straight line (the general motion's ratio 1)."""
    code, text, _ = run(capsys, "compare", "--suite", "gans2003", "--out", str(tmp_path), "--no-plots")
    assert code == 0
    report = json.loads((tmp_path / "suite.json").read_text())
    assert report["controllers"] == list(suites.twist_controllers())
    assert (tmp_path / "suite.md").read_text() in text
    table = (tmp_path / "suite.md").read_text().split("\n\n", 1)[1]
    _assert_documented(table, CONTROLLERS_PAGE.read_text(encoding="utf-8"))  # the docs page's table
    outcome = {(t["task"], r["controller"]): r for t in report["tasks"] for r in t["rows"]}
    # photometric servoing does not apply to four points and the normalized camera: n/a, not run
    not_run = {key: r for key, r in outcome.items() if r["status"] == "n/a"}
    assert set(not_run) == {(t.name, "photometric") for t in suites.GANS_2003}
    assert all(r["reason"] == suites.NOT_APPLICABLE and r["duration_s"] is None for r in not_run.values())
    assert f"n/a: photometric does not apply ({suites.NOT_APPLICABLE})." in text
    outcome = {key: r for key, r in outcome.items() if key not in not_run}
    failed = {key: r["outcome"] for key, r in outcome.items() if r["outcome"] != "converged"}
    # the moment features refuse the face-on square (isotropic moments) on every task
    assert {key: failed.pop(key) for key in list(failed) if key[1] == "ibvs-moments"} == {
        (t.name, "ibvs-moments"): "rejected" for t in suites.GANS_2003
    }
    assert failed == {
        ("gans-rz-150", "ibvs-desired"): "markers_lost",
        ("gans-rz-180", "ibvs-current"): "estimate_failed",
        ("gans-rz-180", "ibvs-desired"): "markers_lost",
        ("gans-rz-180", "ibvs-mean"): "stalled",
    }
    for angle in (30, 60, 90, 120, 150, 180):
        for name in ("pbvs", "2.5d"):
            assert outcome[(f"gans-rz-{angle}", name)]["path_length_m"] < 1e-9
    general = {
        name: outcome[("gans-general", name)] for name in report["controllers"] if name != "photometric"
    }
    assert general["pbvs"]["path_ratio"] == pytest.approx(1.0, abs=1e-3)
    assert general["ibvs-desired"]["feature_excursion"] == pytest.approx(13.777953, rel=1e-6)
    assert all(
        r["feature_excursion"] < suites.NOMINAL_HALF_VIEW
        for n, r in general.items()
        if n not in ("ibvs-desired", "ibvs-moments")  # the moments did not run
    )
    assert (tmp_path / "gans-general" / "table.md").is_file()


def test_the_textured_plane_compares_photometric_servoing_with_the_point_laws(capsys, tmp_path):
    """``--scenario textured-plane``: the free camera at 25 Hz, the 120 x 90 px camera. Photometric
    servoing converges first (2.28 s, measured) on a path 1.75 times the straight line; classical
    IBVS on the square's corners at 8.24 s, on the line (lambda = 0.5 against 30)."""
    out = tmp_path / "textured"
    argv = ("compare", "--scenario", "textured-plane", "--controllers", "photometric,ibvs-current")
    code, text, _ = run(capsys, *argv, "--duration", "10", "--out", str(out), "--no-plots")
    assert code == 0 and "textured-plane on the free-camera plant, 10 s simulated" in text
    photometric, ibvs = json.loads((out / "table.json").read_text())["rows"]
    assert photometric["outcome"] == ibvs["outcome"] == "converged"
    assert photometric["time_to_converge_s"] == pytest.approx(2.28, abs=1e-9)
    assert ibvs["time_to_converge_s"] == pytest.approx(8.24, abs=1e-9)
    assert photometric["path_ratio"] == pytest.approx(1.745, abs=0.001) and ibvs["path_ratio"] < 1.0 + 1e-9
    assert not photometric["markers_left_view"]
    assert photometric["feature_excursion"] == pytest.approx(0.558, abs=1e-3)
    # on a scenario without a scene it is refused by name, a row and not a crash
    rows = compare(
        suites.task("gans-rz-30").scenario(),
        ["photometric", "pbvs"],
        plant="free-camera",
        camera=iy.PinholeCamera.normalized(),
        duration=0.2,
        settings=suites.suite_settings(),
    ).rows
    assert (rows[0].status, rows[1].status) == ("rejected", "complete")
    assert "a scenario with a scene for 'photometric'" in rows[0].reason


def test_the_suite_gives_photometric_servoing_an_na_column_with_the_reason():
    report = suites.run_suite(["pbvs", "photometric"], [suites.task("gans-rz-30")], duration=0.2)
    row = report.comparison("gans-rz-30").row("photometric")
    assert (row.status, row.ran, row.reason) == ("n/a", False, suites.NOT_APPLICABLE)
    assert report.table_markdown().splitlines()[2].endswith(" | n/a |")
    alone = suites.run_suite(["photometric"], [suites.task("gans-rz-30")], duration=0.2)
    assert [r.status for r in alone.comparisons[0].rows] == ["n/a"]


def test_compare_has_help_and_is_listed(capsys):
    code, out, _ = run(capsys, "compare", "--help")
    assert code == 0 and out.startswith("usage: ibvs-youla compare")
    assert "gans-general" in out and "mpc-ibvs" in out
    code, out, _ = run(capsys, "--help")
    assert code == 0 and "compare" in out
