"""Run and design figures: the axes they have and that the drawn data are the result's arrays."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.figure import Figure

from ibvs_youla.analysis import plots
from ibvs_youla.simulation.results import SimulationResult

N = 40


@pytest.fixture(scope="module")
def result():
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 0.39, N)
    features = 1e-3 * rng.standard_normal((N, 9))
    target = 1e-3 * rng.standard_normal(9)
    pose = np.eye(4)
    signals = {name: rng.standard_normal((N, 6)) for name in ("q", "q_true", "dq", "q_ref", "q_ff", "q_fb")}
    signals["tau"] = 100.0 * rng.standard_normal((N, 6))
    return SimulationResult(
        t=t,
        camera_pose=np.broadcast_to(pose, (N, 4, 4)),
        camera_pose_target=pose,
        features=features,
        feature_target=target,
        visible=np.ones((N, 3), dtype=bool),
        signals=signals,
        frame_t=t,
        frame_features=features,
        frame_visible=np.ones((N, 3), dtype=bool),
        update_time=np.full(N, 1e-4),
        metadata={
            "scenario": "synthetic",
            "controller": "fb",
            "adaptive": False,
            "q_encoder_goal": rng.standard_normal(6).tolist(),
        },
    )


@pytest.fixture(scope="module")
def arm():
    return SimpleNamespace(dq_max=np.linspace(3.0, 6.0, 6), tau_max=np.linspace(50.0, 3000.0, 6))


def test_joint_angles_are_the_encoders_in_degrees_with_the_goal_dashed(result):
    fig = plots.plot_joint_angles(result)
    assert isinstance(fig, Figure) and len(fig.axes) == 6
    goal = np.degrees(result.metadata["q_encoder_goal"])
    for j, ax in enumerate(fig.axes):
        np.testing.assert_array_equal(ax.lines[0].get_xdata(), result.t)
        np.testing.assert_allclose(ax.lines[0].get_ydata(), np.degrees(result.q[:, j]), rtol=1e-15, atol=0)
        assert ax.lines[1].get_linestyle() == "--"
        np.testing.assert_allclose(ax.lines[1].get_ydata(), goal[j], rtol=1e-15, atol=0)
        assert ax.get_ylabel() == f"q{j + 1} [deg]"


def test_image_coordinates_in_mm_with_targets_dashed(result):
    fig = plots.plot_image_coordinates(result)
    assert len(fig.axes) == 9
    for k, ax in enumerate(fig.axes):
        np.testing.assert_allclose(ax.lines[0].get_ydata(), 1e3 * result.features[:, k], rtol=1e-15, atol=0)
        assert ax.lines[1].get_linestyle() == "--"
        np.testing.assert_allclose(
            ax.lines[1].get_ydata(), 1e3 * result.feature_target[k], rtol=1e-15, atol=0
        )
    assert [ax.get_ylabel() for ax in fig.axes[:3]] == ["ul1 [mm]", "ur1 [mm]", "v1 [mm]"]


def test_feature_error_norm_is_on_a_log_scale(result):
    (ax,) = plots.plot_feature_error_norm(result).axes
    assert ax.get_yscale() == "log"
    e = result.feature_error
    np.testing.assert_allclose(ax.lines[0].get_ydata(), np.linalg.norm(e, axis=1), rtol=1e-15, atol=0)
    for i in range(3):
        per_point = np.linalg.norm(e[:, 3 * i : 3 * i + 3], axis=1)
        np.testing.assert_allclose(ax.lines[1 + i].get_ydata(), per_point, rtol=1e-15, atol=0)


def test_image_plane_has_both_lenses_the_sensor_outline_and_start_target_markers(result):
    from ibvs_youla.model.camera import StereoCamera

    camera = StereoCamera.zed2()
    fig = plots.plot_image_plane(result, camera)
    assert len(fig.axes) == 2
    p, target = 1e3 * result.features, 1e3 * result.feature_target
    w, h = 1e3 * camera.sensor_width, 1e3 * camera.sensor_height
    for col, ax in enumerate(fig.axes):  # col 0: u_l, col 1: u_r
        for i in range(3):
            np.testing.assert_array_equal(ax.lines[i].get_xdata(), p[:, 3 * i + col])
            np.testing.assert_array_equal(ax.lines[i].get_ydata(), p[:, 3 * i + 2])
            assert (ax.lines[3 + i].get_marker(), ax.lines[6 + i].get_marker()) == ("o", "x")
            np.testing.assert_array_equal(ax.lines[3 + i].get_xdata(), [p[0, 3 * i + col]])
            np.testing.assert_array_equal(ax.lines[6 + i].get_ydata(), [target[3 * i + 2]])
        rect = ax.patches[0]
        np.testing.assert_allclose(rect.get_xy(), (-w / 2, -h / 2), rtol=1e-15, atol=0)
        assert (rect.get_width(), rect.get_height()) == pytest.approx((w, h), rel=1e-15, abs=0)
        assert ax.yaxis_inverted()  # v points down, as in the image


def test_speeds_and_torques_against_the_arm_limits(result, arm):
    fig = plots.plot_joint_speeds_torques(result, arm)
    assert len(fig.axes) == 12
    axes = np.array(fig.axes).reshape(6, 2)
    for j in range(6):
        speed, torque = axes[j]
        np.testing.assert_allclose(
            speed.lines[0].get_ydata(), np.degrees(result.dq[:, j]), rtol=1e-15, atol=0
        )
        np.testing.assert_allclose(speed.lines[1].get_ydata(), np.degrees(arm.dq_max[j]), rtol=1e-15, atol=0)
        np.testing.assert_allclose(speed.lines[2].get_ydata(), -np.degrees(arm.dq_max[j]), rtol=1e-15, atol=0)
        np.testing.assert_array_equal(torque.lines[0].get_ydata(), result.tau[:, j])
        np.testing.assert_array_equal(torque.lines[1].get_ydata(), [arm.tau_max[j]] * 2)
        np.testing.assert_array_equal(torque.lines[2].get_ydata(), [-arm.tau_max[j]] * 2)
        assert speed.lines[1].get_linestyle() == torque.lines[2].get_linestyle() == "--"
        ratio = np.abs(result.tau[:, j]).max() / arm.tau_max[j]
        assert torque.get_title(loc="right") == f"peak {ratio:.3g} x limit"


def test_default_arm_limits_are_the_irb4600s(result):
    from ibvs_youla.model.arm import Arm

    fig = plots.plot_joint_speeds_torques(result)
    limits = Arm.irb4600()
    np.testing.assert_allclose(fig.axes[7].lines[1].get_ydata(), limits.tau_max[3], rtol=1e-15, atol=0)


def test_plot_result_and_save(result, arm, tmp_path):
    import matplotlib.pyplot as plt

    before = plt.get_fignums()
    figures = plots.plot_result(result, arm)
    assert tuple(figures) == plots.RESULT_FIGURES
    paths = plots.save_result_figures(result, tmp_path / "figs", arm)
    assert sorted(p.name for p in (tmp_path / "figs").iterdir()) == sorted(f"{n}.png" for n in figures)
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in paths.values())
    assert plt.get_fignums() == before  # no pyplot state: nothing to close, no backend switched


def test_plots_of_a_real_run(tmp_path):
    import ibvs_youla as iy

    run = iy.simulate(iy.scenarios.physical(1), duration=0.02)
    paths = plots.save_result_figures(run, tmp_path)
    assert len(paths) == 5 and all(p.stat().st_size > 10_000 for p in paths.values())
    title = plots.plot_joint_angles(run).get_suptitle()
    assert title == "physical-1, ff+fb (adaptive outer loop): joint angles"


def test_plot_design_draws_python_control_responses():
    from ibvs_youla.control.inner import InnerLoopDesign

    design = InnerLoopDesign(0.01)
    T = design.complementary_sensitivity()
    fig = plots.plot_design({"T": T, "S": design.sensitivity()}, {"T": T}, "inner", t_final=0.2)
    mag, step, phase, pz = fig.axes
    w = mag.lines[0].get_xdata()
    np.testing.assert_allclose(mag.lines[0].get_ydata()[0], 0.0, atol=1e-3)  # |T(j w)| -> 1 as w -> 0
    np.testing.assert_allclose(10 ** (mag.lines[1].get_ydata()[-1] / 20), 1.0, rtol=1e-3)  # |S| -> 1
    # two decades beyond the slowest and fastest non-zero root: T's zero -1/(3 tau), S's zero -3/tau
    assert w[0] == pytest.approx(100 / 3 / 100, rel=1e-9) and w[-1] == pytest.approx(3e4, rel=1e-9)
    np.testing.assert_allclose(phase.lines[0].get_ydata()[-1], -180.0, atol=1.0)  # relative degree 2
    y = step.lines[0].get_ydata()
    assert y[-1] == pytest.approx(1.0, abs=1e-3) and y.max() == pytest.approx(1.249, abs=1e-3)
    np.testing.assert_allclose(pz.lines[0].get_xdata(), -100.0, rtol=1e-4)  # triple pole at -1/tau
    np.testing.assert_allclose(pz.lines[0].get_ydata(), 0.0, atol=0)
    np.testing.assert_allclose(pz.lines[1].get_xdata(), -100.0 / 3.0, rtol=1e-9)  # zero at -1/(3 tau)
