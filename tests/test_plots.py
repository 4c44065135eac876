"""Run and design figures: the axes they have and that the drawn data are the result's arrays."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.figure import Figure

from ibvs_youla.analysis import plots
from ibvs_youla.simulation.results import SimulationResult
from servo_helpers import MARKERS_4, ConstantTwist

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


def test_plot_result_draws_every_figure_without_pyplot(result, arm):
    import matplotlib.pyplot as plt

    before = plt.get_fignums()
    figures = plots.plot_result(result, arm)
    assert tuple(figures) == plots.RESULT_FIGURES
    assert plt.get_fignums() == before  # no pyplot state: nothing to close, no backend switched


def test_the_figures_of_a_real_run_are_saved_as_png(tmp_path):
    """One save (the slow part: drawing five figures) of a real run's figures."""
    import matplotlib.pyplot as plt

    import ibvs_youla as iy

    run = iy.simulate(iy.scenarios.physical(1), duration=0.02)
    before = plt.get_fignums()
    paths = plots.save_result_figures(run, tmp_path / "figs")
    assert tuple(paths) == plots.RESULT_FIGURES
    assert sorted(p.name for p in (tmp_path / "figs").iterdir()) == sorted(f"{n}.png" for n in paths)
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in paths.values())
    assert all(p.stat().st_size > 10_000 for p in paths.values())
    assert plt.get_fignums() == before
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


# --------------------------------------------------------------- any markers, either camera
@pytest.fixture(scope="module")
def four_marker_runs():
    """0.2 s free-camera runs (no joint signals) with four markers: monocular normalized, stereo ZED 2."""
    import ibvs_youla as iy

    markers = MARKERS_4
    target = np.eye(4)
    target[:3, 3] = (0.05, -0.02, 0.1)  # [m] so the image error is not zero at the start
    scenario = iy.Scenario.free_camera(np.eye(4), target, markers)
    runs = {}
    for layout, camera in (("monocular", iy.PinholeCamera.normalized()), ("stereo", iy.StereoCamera.zed2())):
        twist = ConstantTwist([0.01, 0.0, 0.0, 0.0, 0.0, 0.1])
        run = iy.simulate(scenario, twist, duration=0.2, plant="free-camera", camera=camera)
        runs[layout] = run, camera
    return runs


def test_four_monocular_markers_in_normalized_coordinates(four_marker_runs, tmp_path):
    run, camera = four_marker_runs["monocular"]
    assert run.features.shape[1] == 8 and run.n_points == 4 and "q" not in run.signals
    figures = plots.plot_result(run, camera=camera)
    assert tuple(figures) == ("image_coordinates", "feature_error_norm", "image_plane")  # no joints

    coordinates = figures["image_coordinates"].axes
    assert len(coordinates) == 8  # 4 markers x (x, y)
    for k, ax in enumerate(coordinates):  # unitless: drawn unscaled
        np.testing.assert_array_equal(ax.lines[0].get_ydata(), run.features[:, k])
        np.testing.assert_array_equal(ax.lines[1].get_ydata(), [run.feature_target[k]] * 2)
    assert [ax.get_ylabel() for ax in coordinates[-2:]] == ["x4 [normalized]", "y4 [normalized]"]

    (error,) = figures["feature_error_norm"].axes
    assert len(error.lines) == 1 + 4 and error.get_ylabel() == "||e|| [normalized]"
    e = run.feature_error
    for i in range(4):
        np.testing.assert_allclose(
            error.lines[1 + i].get_ydata(),
            np.linalg.norm(e[:, 2 * i : 2 * i + 2], axis=1),
            rtol=1e-15,
            atol=0,
        )
    assert error.lines[0].get_label() == "||e|| (8 coordinates)"

    (image,) = figures["image_plane"].axes  # one image for one lens
    assert len(image.lines) == 3 * 4 and len(image.patches) == 0  # nominal sensor: no outline
    for i in range(4):
        np.testing.assert_array_equal(image.lines[i].get_xdata(), run.features[:, 2 * i])
        np.testing.assert_array_equal(image.lines[i].get_ydata(), run.features[:, 2 * i + 1])
        np.testing.assert_array_equal(image.lines[8 + i].get_xdata(), [run.feature_target[2 * i]])
    assert (image.get_xlabel(), image.get_ylabel()) == ("x [normalized]", "y [normalized]")

    paths = plots.save_result_figures(run, tmp_path, camera=camera)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f"{name}.png" for name in figures)
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in paths.values())


def test_four_stereo_markers_in_mm_on_both_lenses(four_marker_runs, tmp_path):
    run, camera = four_marker_runs["stereo"]
    assert run.features.shape[1] == 12 and run.n_points == 4
    figures = plots.plot_result(run, camera=camera)
    assert tuple(figures) == ("image_coordinates", "feature_error_norm", "image_plane")

    coordinates = figures["image_coordinates"].axes
    assert len(coordinates) == 12  # 4 markers x (u_l, u_r, v): the 4th marker is drawn
    np.testing.assert_allclose(coordinates[11].lines[0].get_ydata(), 1e3 * run.features[:, 11], rtol=1e-15)
    assert [ax.get_ylabel() for ax in coordinates[-3:]] == ["ul4 [mm]", "ur4 [mm]", "v4 [mm]"]

    (error,) = figures["feature_error_norm"].axes
    assert len(error.lines) == 1 + 4 and error.get_ylabel() == "||e|| [m on the sensor]"
    np.testing.assert_allclose(
        error.lines[4].get_ydata(), np.linalg.norm(run.feature_error[:, 9:12], axis=1), rtol=1e-15, atol=0
    )

    image = figures["image_plane"].axes
    assert len(image) == 2
    w, h = 1e3 * camera.sensor_width, 1e3 * camera.sensor_height
    for col, ax in enumerate(image):  # col 0: u_l, col 1: u_r
        assert len(ax.lines) == 3 * 4 and len(ax.patches) == 1
        np.testing.assert_array_equal(ax.lines[3].get_xdata(), 1e3 * run.features[:, 9 + col])
        np.testing.assert_array_equal(ax.lines[3].get_ydata(), 1e3 * run.features[:, 11])
        np.testing.assert_array_equal(ax.lines[4 + 3].get_xdata(), [1e3 * run.features[0, 9 + col]])
        assert (ax.patches[0].get_width(), ax.patches[0].get_height()) == pytest.approx((w, h), rel=1e-15)
    assert [ax.get_xlabel() for ax in image] == ["u_l [mm]", "u_r [mm]"]

    paths = plots.save_result_figures(run, tmp_path, camera=camera)
    assert len(paths) == 3 and all(p.stat().st_size > 10_000 for p in paths.values())


def test_monocular_default_camera_is_one_zed2_lens_in_mm(four_marker_runs):
    from ibvs_youla.model.camera import PinholeCamera

    run, _ = four_marker_runs["monocular"]
    (ax,) = plots.plot_image_plane(run).axes
    lens = PinholeCamera.zed2()
    assert ax.get_xlabel() == "u [mm]"
    np.testing.assert_array_equal(ax.lines[0].get_xdata(), 1e3 * run.features[:, 0])
    assert ax.patches[0].get_width() == pytest.approx(1e3 * lens.sensor_width, rel=1e-15)


def test_image_figures_reject_a_camera_or_features_of_another_layout(four_marker_runs, result):
    from ibvs_youla.exceptions import InvalidArrayError, InvalidParameterError
    from ibvs_youla.model.camera import StereoCamera

    run, _ = four_marker_runs["monocular"]
    with pytest.raises(InvalidParameterError, match="2 coordinates per marker"):
        plots.plot_image_plane(run, StereoCamera.zed2())
    odd = SimulationResult(  # 9 coordinates for 4 markers
        t=result.t,
        camera_pose=result.camera_pose,
        camera_pose_target=result.camera_pose_target,
        features=result.features,
        feature_target=result.feature_target,
        visible=np.ones((N, 4), dtype=bool),
    )
    with pytest.raises(InvalidArrayError, match="9 coordinates for 4 markers"):
        plots.plot_image_coordinates(odd)
