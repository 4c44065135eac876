"""ibvs_youla.viz: frustum and ray geometry, playback schedule, the Meshcat viewer in headless Chromium."""

from __future__ import annotations

import contextlib
import os
import re
import socket
import subprocess
import sys
import urllib.request

import numpy as np
import pinocchio as pin
import pytest

from headless_chromium import chromium, meshcat_pixels, screenshot
from ibvs_youla import cli, scenarios
from ibvs_youla.exceptions import IbvsYoulaError, InvalidArrayError, InvalidParameterError, VisualizationError
from ibvs_youla.model import robots as iy_robots
from ibvs_youla.model._resources import package_dirs, urdf_path
from ibvs_youla.model.arm import Arm
from ibvs_youla.model.camera import PinholeCamera, StereoCamera
from ibvs_youla.simulation.results import SimulationResult
from ibvs_youla.viz import (
    Viewer,
    frustum_corners_C,
    frustum_segments_C,
    lens_centres_C,
    playback_frames,
    ray_segments_O,
    wait_for_server,
)

CAMERAS = {
    "paper": StereoCamera.zed2(),
    "zed2-HD1080": StereoCamera.zed2("zed2", "HD1080"),
    # off-centre principal point and skew: corners must follow K (Eq. 6), not a centred-sensor shortcut
    "skewed": StereoCamera(
        focal_length=3e-3,
        sensor_width=4e-3,
        sensor_height=3e-3,
        pixel_pitch=5e-6,
        skew=12.0,
        principal_point=(350.0, 260.0),
        baseline=0.1,
    ),
}


# ---------------------------------------------------------------------------- geometry
def test_lens_centres_put_the_left_lens_at_plus_half_baseline():
    cam = StereoCamera.zed2()
    np.testing.assert_array_equal(lens_centres_C(cam), [[0.06, 0.0, 0.0], [-0.06, 0.0, 0.0]])  # ERRATA 12
    np.testing.assert_array_equal(lens_centres_C(PinholeCamera.zed2()), [[0.0, 0.0, 0.0]])
    with pytest.raises(InvalidParameterError, match="StereoCamera or a PinholeCamera"):
        lens_centres_C("zed2")


@pytest.mark.parametrize("name", ["paper", "zed2-HD1080"])
def test_frustum_corners_make_half_the_field_of_view_with_the_optical_axis(name):
    cam = CAMERAS[name]
    fov_h, fov_v = cam.field_of_view
    corners = frustum_corners_C(cam, depth=2.0)
    assert corners.shape == (2, 4, 3)
    for lens, pts in zip(lens_centres_C(cam), corners, strict=True):
        half_h = np.arctan(np.abs(pts[:, 0] - lens[0]) / pts[:, 2])  # [rad]
        half_v = np.arctan(np.abs(pts[:, 1]) / pts[:, 2])
        np.testing.assert_allclose(half_h, fov_h / 2, rtol=0, atol=1e-12)
        np.testing.assert_allclose(half_v, fov_v / 2, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(pts[:, 2], 2.0)


@pytest.mark.parametrize("name", sorted(CAMERAS))
def test_frustum_corners_project_to_the_image_corners_of_their_own_lens(name):
    cam = CAMERAS[name]
    width, height = cam.sensor_width / cam.pixel_pitch, cam.sensor_height / cam.pixel_pitch
    expected = np.array([[0.0, 0.0], [width, 0.0], [width, height], [0.0, height]])
    for lens, pts in enumerate(frustum_corners_C(cam, depth=1.3)):
        px = cam.to_pixels(cam.project(pts))  # rows [u_l, u_r, v] [px]
        np.testing.assert_allclose(px[:, [lens, 2]], expected, rtol=0, atol=1e-8)  # [px]


def test_frustum_segments_edges_and_rectangles():
    cam = StereoCamera.zed2()
    segments = frustum_segments_C(cam, near=0.5, far=1.0)
    assert segments.shape == (2 * (4 + 4 + 4), 2, 3)  # per lens: 4 edges, far and near rectangles
    np.testing.assert_array_equal(segments[0, 0], [0.06, 0.0, 0.0])  # edges start at the left lens
    np.testing.assert_array_equal(np.unique(np.round(segments[:, :, 2], 12)), [0.0, 0.5, 1.0])
    assert frustum_segments_C(cam, near=0.0, far=1.0).shape == (16, 2, 3)
    with pytest.raises(InvalidParameterError, match="near"):
        frustum_segments_C(cam, near=1.0, far=1.0)
    with pytest.raises(InvalidParameterError, match="far"):
        frustum_segments_C(cam, near=0.0, far=-1.0)


def test_rays_run_from_each_lens_to_each_marker_along_the_stereo_projection():
    rng = np.random.default_rng(7)
    cam = StereoCamera.zed2()
    T_O_C = _random_pose(rng)
    P_C = rng.uniform([-0.5, -0.4, 1.0], [0.5, 0.4, 3.0], size=(3, 3))
    markers_O = P_C @ T_O_C[:3, :3].T + T_O_C[:3, 3]
    rays = ray_segments_O(cam, T_O_C, markers_O)
    assert rays.shape == (2, 3, 2, 3)
    np.testing.assert_allclose(rays[:, :, 1], np.broadcast_to(markers_O, (2, 3, 3)), rtol=0, atol=0)
    lenses_O = rays[:, 0, 0]
    np.testing.assert_allclose(np.linalg.norm(lenses_O[0] - lenses_O[1]), cam.baseline, rtol=0, atol=1e-12)
    # Direction of each ray in {C}: F dx / dz is that lens's u (Eq. 9-10 with ERRATA 12), F dy / dz is v.
    features, F = cam.project(P_C), cam.focal_length
    for lens in range(2):
        d_C = (rays[lens, :, 1] - rays[lens, :, 0]) @ T_O_C[:3, :3]
        np.testing.assert_allclose(F * d_C[:, 0] / d_C[:, 2], features[:, lens], rtol=0, atol=1e-15)  # [m]
        np.testing.assert_allclose(F * d_C[:, 1] / d_C[:, 2], features[:, 2], rtol=0, atol=1e-15)


def _random_pose(rng: np.random.Generator) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = pin.exp3(rng.normal(size=3))
    T[:3, 3] = rng.normal(size=3)
    return T


# ---------------------------------------------------------------------------- playback
def test_playback_frames_at_real_speed_and_slower():
    t = np.arange(2001) * 1e-3  # 2 s at 1 kHz [s]
    real = playback_frames(t, speed=1.0, fps=30.0)
    assert len(real) == 61  # frames at 0, 1/30, ..., 2 s: plays in 2 s
    np.testing.assert_array_equal(real, [k * 100 // 3 for k in range(61)])  # last t[i] <= k / 30
    slow = playback_frames(t, speed=0.5, fps=30.0)
    assert len(slow) == 121  # twice as many frames: plays in 4 s
    np.testing.assert_array_equal(slow, [k * 50 // 3 for k in range(121)])
    assert real[-1] == slow[-1] == 2000


def test_playback_ends_on_the_last_sample_and_rejects_bad_input():
    t = np.array([0.0, 0.1, 0.2, 0.25])
    np.testing.assert_array_equal(playback_frames(t, speed=1.0, fps=10.0), [0, 1, 2, 3])
    np.testing.assert_array_equal(playback_frames([5.0], speed=1.0, fps=30.0), [0])
    with pytest.raises(InvalidParameterError, match="speed"):
        playback_frames(t, speed=0.0)
    with pytest.raises(InvalidParameterError, match="fps"):
        playback_frames(t, fps=-30.0)
    with pytest.raises(InvalidArrayError, match="decreasing"):
        playback_frames([0.0, 0.2, 0.1])


# ---------------------------------------------------------------------------- import and errors
def test_importing_viz_loads_neither_meshcat_nor_pinocchio():
    heavy = "('meshcat', 'pinocchio', 'zmq')"
    code = f"import sys, ibvs_youla.viz; print([m for m in {heavy} if m in sys.modules])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_viewer_without_meshcat_raises_visualization_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "meshcat", None)  # makes `import meshcat` raise ImportError
    with pytest.raises(VisualizationError, match=r"pip install 'ibvs-youla\[viz\]'") as info:
        Viewer()
    assert isinstance(info.value, IbvsYoulaError)


def test_viewer_of_an_arm_built_without_a_urdf_raises_visualization_error():
    arm = Arm(pin.buildModelFromUrdf(str(urdf_path("abb_irb4600_45_205.urdf"))))  # from a model: no urdf_path
    assert arm.urdf_path is None
    with pytest.raises(VisualizationError, match="was built without a URDF, so it has no visual geometry"):
        Viewer(arm)


# ---------------------------------------------------------------------------- a server given by URL
def _closed_port() -> int:
    """A loopback TCP port nothing listens on (bound by the OS, then released)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_a_zmq_url_with_no_server_times_out_with_a_visualization_error():
    url = f"tcp://127.0.0.1:{_closed_port()}"
    message = rf"zmq_url '{re.escape(url)}': no meshcat server answered within 0\.2 s \(connect_timeout\)"
    with pytest.raises(VisualizationError, match=message):
        wait_for_server(url, 0.2)
    with pytest.raises(VisualizationError, match=message):
        Viewer(zmq_url=url, connect_timeout=0.2)


@pytest.mark.parametrize(
    ("url", "timeout", "name", "received"),
    [
        ("nonsense", 1.0, "zmq_url", "'nonsense'"),
        (6000, 1.0, "zmq_url", "6000"),
        ("tcp://127.0.0.1:6000", 0.0, "connect_timeout", "0.0"),
        ("tcp://127.0.0.1:6000", float("nan"), "connect_timeout", "nan"),
    ],
)
def test_a_bad_zmq_url_or_timeout_is_named(url, timeout, name, received):
    with pytest.raises(InvalidParameterError, match=rf"^{name}: received {received}"):
        wait_for_server(url, timeout)


def test_cli_view_with_no_server_at_zmq_url_exits_1_in_one_line(capsys):
    url = f"tcp://127.0.0.1:{_closed_port()}"
    argv = ["view", "--scenario", "physical-1", "--no-wait", "--zmq-url", url, "--zmq-timeout", "0.2"]
    assert cli.main(argv) == 1
    err = capsys.readouterr().err
    assert err == (
        f"ibvs-youla: error: --zmq-url {url!r}: no meshcat server answered within 0.2 s (--zmq-timeout); "
        "start one with meshcat-server, or omit --zmq-url to start a local one\n"
    )
    assert cli.main(["view", "--zmq-url", url, "--zmq-timeout", "0"]) == 2
    assert "argument --zmq-timeout: received '0'" in capsys.readouterr().err


def test_a_running_server_answers_its_url_and_a_viewer_connects_to_it():
    with Viewer() as local:
        zmq_url = local._vis.window.zmq_url
        assert wait_for_server(zmq_url, 10.0) == local.url
        with Viewer(zmq_url=zmq_url, connect_timeout=10.0) as remote:
            assert remote.url == local.url and remote._server is None  # connected, started nothing


# ---------------------------------------------------------------------------- live viewer
@pytest.fixture(scope="module")
def viewer():
    view = Viewer()
    yield view
    view.close()


def test_viewer_prints_its_url_and_close_stops_its_server(capsys):
    view = Viewer()
    server = view._server
    assert capsys.readouterr().out.strip() == f"Meshcat viewer: {view.url}"
    assert re.fullmatch(r"http://127\.0\.0\.1:\d+/static/", view.url)
    view.close()
    assert server.poll() is not None  # the server process has exited


def test_view_stopped_by_sigterm_stops_its_meshcat_server(tmp_path):
    """``ibvs-youla view`` killed by SIGTERM (kill, a batch system) took its meshcat server with it only
    on Ctrl-C: the server, in a session of its own, outlived it. Now the server goes with the view."""
    import signal

    import psutil

    sc = scenarios.physical(1)
    pose = Arm.irb4600().camera_pose(sc.q_start)
    run = {
        "q_start": sc.q_start.tolist(),
        "q_target": sc.q_target.tolist(),
        "markers_O": sc.markers_O.tolist(),
    }
    path = SimulationResult(  # a saved arm run of two samples at rest: all view needs to serve it
        t=[0.0, 0.01],
        camera_pose=[pose, pose],
        camera_pose_target=pose,
        features=np.zeros((2, 9)),
        feature_target=np.zeros(9),
        visible=np.ones((2, 3), bool),
        signals={"q_true": [sc.q_start, sc.q_start]},
        metadata={**run, "joint_offset": [0.0] * 6, "scenario": "at-rest", "virtual_points": False},
    ).save(tmp_path / "run.npz")
    code = "import sys; from ibvs_youla.cli import main; sys.exit(main(sys.argv[1:]))"
    view = subprocess.Popen(
        [sys.executable, "-c", code, "view", "--result", str(path), "--speed", "100"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    servers = []
    try:
        for line in view.stdout:  # the viewer is up and serving
            if line.startswith("serving"):
                break
        servers = [p for p in psutil.Process(view.pid).children() if "meshcat" in " ".join(p.cmdline())]
        assert len(servers) == 1, "the view started no meshcat server of its own"
        view.send_signal(signal.SIGTERM)
        assert view.wait(timeout=30) == 128 + signal.SIGTERM
        _, alive = psutil.wait_procs(servers, timeout=10)
        assert not alive, "the meshcat server outlived the view"
    finally:
        for proc in [view, *servers]:  # by id, whatever happened
            with contextlib.suppress(Exception):
                proc.kill()


def test_page_and_three_js_are_served_locally(viewer):
    html = urllib.request.urlopen(viewer.url, timeout=10).read().decode()
    sources = re.findall(r'(?:src|href)="([^"]*)"', html)
    assert sources == ["main.min.js"]  # relative: served by meshcat's own server
    js = urllib.request.urlopen(viewer.url + "main.min.js", timeout=10).read().decode()
    assert "WebGLRenderer" in js  # three.js is bundled
    hosts = set(re.findall(r"https?://([A-Za-z0-9.-]+)", js))
    assert hosts <= {"www.w3.org"}, hosts  # XML namespace URIs only: nothing is fetched from the internet


def test_display_rejects_a_wrong_joint_vector(viewer):
    with pytest.raises(InvalidArrayError, match=r"q: received an array of shape \(5,\)"):
        viewer.display(np.zeros(5))
    with pytest.raises(InvalidParameterError, match="part"):
        viewer.set_visible("robot", False)


def test_play_ends_on_the_last_configuration(viewer):
    sc = scenarios.physical(1)
    result = _straight_run(viewer.arm, sc, duration=0.3)
    drawn = viewer.play(result, speed=1.0, fps=30.0)
    # play() drops frames it is late for by the wall clock, so on a loaded machine fewer than the 10
    # scheduled frames may be drawn; at least one (the last) always is.
    assert 1 <= drawn <= len(playback_frames(result.t, 1.0, 30.0)) == 10
    np.testing.assert_array_equal(viewer.q, result.q_true[-1])
    with pytest.raises(InvalidParameterError, match="speed"):
        viewer.play(result, speed=0.0)


def _straight_run(arm: Arm, sc: scenarios.Scenario, duration: float) -> SimulationResult:
    """A SimulationResult whose joints move on a straight line from q_start to q_target at 100 Hz."""
    t = np.arange(0.0, duration + 1e-9, 0.01)
    s = (t / duration)[:, None]
    q = (1 - s) * sc.q_start + s * sc.q_target
    n, zeros = len(t), np.zeros((len(t), 6))
    return SimulationResult(
        t=t,
        camera_pose=np.array([arm.camera_pose(qi) for qi in q]),
        camera_pose_target=arm.camera_pose(sc.q_target),
        features=np.zeros((n, 9)),
        feature_target=np.zeros(9),
        visible=np.ones((n, 3), bool),
        signals={"q": q, "q_true": q, "dq": zeros, "q_ref": q, "q_ff": zeros, "q_fb": q, "tau": zeros},
        metadata={"markers_O": sc.markers_O.tolist()},
    )


def test_screenshot_shows_the_arm_where_it_should_be(viewer, tmp_path):
    """Screenshots with the arm shown and hidden differ where the arm projects; links are orange there."""
    if chromium() is None:
        if os.environ.get("CI"):  # .ci/run sets CI=true and installs chromium: its absence is a failure there
            pytest.fail("CI is set but Debian's chromium is not installed: .ci/run should have installed it")
        pytest.skip("Debian's chromium is not installed (.ci/run installs it)")
    eye = np.array([-1.0, -3.5, 2.0])  # [m]
    viewer.show_scenario(scenarios.physical(1))  # arm at q = 0, markers, frustum, target pose, rays
    viewer.set_view(eye)
    shown = screenshot(viewer.url, tmp_path / "arm.png")
    viewer.set_visible("arm", False)
    try:
        hidden = screenshot(viewer.url, tmp_path / "no_arm.png")
    finally:
        viewer.set_visible("arm", True)
    assert shown.shape == (600, 800, 3)
    differs = np.abs(shown - hidden).sum(axis=2) > 0.1  # [RGB in 0..1]
    assert differs.mean() > 0.01  # the arm covers a few per cent of the picture

    # Centres of the URDF's visual solids (convex: each projects inside its own silhouette)
    visual = pin.buildGeomFromUrdf(viewer.arm.model, str(viewer.arm.urdf_path), pin.GeometryType.VISUAL)
    data, gdata = viewer.arm.model.createData(), visual.createData()
    pin.updateGeometryPlacements(viewer.arm.model, data, visual, gdata, np.zeros(6))
    centres = np.array([m.translation for m in gdata.oMg])
    pixels = np.round(meshcat_pixels(centres, eye)).astype(int)
    orange = [o.meshColor[0] > 0.5 for o in visual.geometryObjects]  # links; base and camera are grey
    for (col, row), is_orange, obj in zip(pixels, orange, visual.geometryObjects, strict=True):
        assert 0 <= col < 800 and 0 <= row < 600, obj.name
        window = (slice(row - 1, row + 2), slice(col - 1, col + 2))
        assert differs[window].mean() >= 5 / 9, f"{obj.name}: no arm drawn at pixel ({col}, {row})"
        if is_orange:  # URDF colour (0.93, 0.45, 0.1), shaded; the sky behind is blue (b > r)
            r, g, b = np.median(shown[window].reshape(-1, 3), axis=0)
            assert r > 0.4 and r > g > b and r - b > 0.25, f"{obj.name}: ({r:.2f}, {g:.2f}, {b:.2f})"


# ---------------------------------------------------------------------------- another arm, its meshes
def test_the_visual_model_puts_each_mesh_where_the_full_urdf_does():
    """The Panda with joint 7 locked at 0.3 rad (and its fingers, off the chain, at 0): the reduced
    visual model places every mesh where the full URDF's model does at that configuration."""
    arm = Arm.from_robot("panda", locked_joints={"panda_joint7": 0.3})
    visual = arm.visual_model()
    assert all(o.meshPath.endswith(".dae") for o in visual.geometryObjects)  # the URDF's own meshes
    full = pin.buildModelFromUrdf(str(arm.urdf_path))
    full_visual = pin.buildGeomFromUrdf(
        full, str(arm.urdf_path), pin.GeometryType.VISUAL, package_dirs=package_dirs(arm.urdf_path)
    )
    q = np.array([0.1, -0.4, 0.2, -2.0, 0.3, 1.6])
    placements = []
    for model, geometry, config in ((arm.model, visual, q), (full, full_visual, np.r_[q, 0.3, 0.0, 0.0])):
        data, gdata = model.createData(), geometry.createData()
        pin.updateGeometryPlacements(model, data, geometry, gdata, config)
        placements.append(
            {o.name: m.homogeneous for o, m in zip(geometry.geometryObjects, gdata.oMg, strict=True)}
        )
    reduced, expected = placements
    assert reduced.keys() == expected.keys() and len(reduced) == 11  # links 0-7, hand, two fingers
    for name, T in reduced.items():
        np.testing.assert_allclose(T, expected[name], atol=1e-12, err_msg=name)


def test_screenshot_draws_another_arm_from_its_meshes(tmp_path):
    """The UR5's meshes are drawn, around its base: a screenshot with the arm and one without differ there.

    The UR5 is small at meshcat's view (0.2-0.3 % of the picture, measured: its .dae meshes load
    asynchronously in the page), so this checks that it is drawn and where, not each link.
    """
    if chromium() is None:
        if os.environ.get("CI"):
            pytest.fail("CI is set but Debian's chromium is not installed: .ci/run should have installed it")
        pytest.skip("Debian's chromium is not installed (.ci/run installs it)")
    arm = Arm.from_robot("ur5")
    eye = np.array([-1.2, -1.6, 1.0])  # [m]
    with Viewer(arm) as view:
        view.display(np.asarray(iy_robots.get("ur5").q_home))
        view.set_view(eye)
        view.set_visible("arm", False)
        hidden = screenshot(view.url, tmp_path / "no_ur5.png", budget_ms=6000)
        view.set_visible("arm", True)
        # the page fetches the meshes from the server while virtual time runs: on a loaded host (a clean
        # checkout's suite, both cores busy) 6 s of it drew 0.04 % of the picture, so a page that has
        # not drawn them yet is loaded again with more time (an arm never drawn fails all three)
        for budget_ms in (6000, 15000, 30000):
            shown = screenshot(view.url, tmp_path / "ur5.png", budget_ms=budget_ms)
            differs = np.abs(shown - hidden).sum(axis=2) > 0.1  # [RGB in 0..1]
            if differs.mean() > 0.001:
                break
    assert differs.mean() > 0.001, f"{differs.mean():.5f} of the picture differs after {budget_ms} ms"
    rows, cols = np.nonzero(differs)
    base = meshcat_pixels(np.zeros((1, 3)), eye)[0]
    centre = (cols.mean(), rows.mean())
    assert np.hypot(centre[0] - base[0], centre[1] - base[1]) < 80.0, (centre, base)  # [px] on its base
