"""Meshcat viewer: the arm from its URDF visual geometry, markers, camera frustum, target pose, rays.

The arm is drawn by Pinocchio's :class:`~pinocchio.visualize.MeshcatVisualizer` from the URDF's
visual shapes (``pin.buildGeomFromUrdf(..., pin.GeometryType.VISUAL)``); everything else is
computed in :mod:`ibvs_youla.viz.geometry` and sent as meshcat line segments and spheres.
Meshcat serves its web page and three.js from a local server (no internet needed); the viewer
never opens a browser, it prints the URL. Given the ``zmq_url`` of a running server instead, it
first asks that server for its URL and gives up after ``connect_timeout`` (default 5 s) with a
:class:`~ibvs_youla.exceptions.VisualizationError` (:mod:`.meshcat_server`); meshcat itself
would wait forever. Scene paths: ``arm``, ``markers``, ``camera``, ``target``, ``rays`` (see
:meth:`Viewer.set_visible`).

A server the viewer started is its own to stop: :meth:`Viewer.close` does, and so does the end of
the process, even by SIGTERM or SIGHUP (``kill``, a closed terminal, a batch system's stop). Their
default action ends Python without unwinding, and meshcat's server, in a session of its own,
outlived it; while a viewer holds a server (and the program has not set a handler of its own, in
the main thread), either signal raises ``SystemExit`` instead, so ``finally`` blocks and meshcat's
exit handler stop the server.
"""

from __future__ import annotations

import contextlib
import io
import signal
import threading
import time
import warnings
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validation import as_array, as_pose, positive
from ..exceptions import InvalidArrayError, InvalidParameterError, VisualizationError
from ..model.camera import StereoCamera
from ..scenarios import Scenario
from .geometry import frustum_segments_C, ray_segments_O
from .meshcat_server import CONNECT_TIMEOUT, wait_for_server
from .playback import playback_frames

if TYPE_CHECKING:  # Arm imports Pinocchio: loaded when a Viewer is built, so importing viz stays cheap
    from ..model.arm import Arm

__all__ = ["Viewer"]

FRUSTUM_FAR = 1.0  # [m] default far end of the drawn frustum
MARKER_COLORS = (0xE53935, 0x43A047, 0x1E88E5)  # markers 1, 2, 3 (point order of Eq. 24): red, green, blue
LENS_RAY_COLORS = (0x00BCD4, 0xE040FB)  # rays from the left, right lens (ERRATA 12): cyan, magenta
FRUSTUM_COLOR = 0xFFD600  # current camera: yellow
GHOST_COLOR = 0xFFFFFF  # target camera pose: translucent white
ZED2_BODY_C = (0.175, 0.03, 0.033)  # [m] ZED 2 housing along x_C, y_C, z_C (Stereolabs datasheet)
DEFAULT_EYE_O = (-2.0, -4.5, 2.5)  # [m] meshcat's orbit camera; it always looks at the base origin
_PARTS = ("arm", "markers", "camera", "target", "rays")


def _import_meshcat() -> tuple[Any, Any]:
    """(meshcat, pinocchio.visualize.MeshcatVisualizer), or VisualizationError naming the fix."""
    try:
        with warnings.catch_warnings():  # meshcat 0.3 imports zmq.eventloop.ioloop, deprecated by pyzmq
            warnings.filterwarnings("ignore", "zmq.eventloop.ioloop is deprecated", DeprecationWarning)
            import meshcat
            import meshcat.geometry
            from pinocchio.visualize import MeshcatVisualizer
    except ImportError as exc:
        raise VisualizationError(
            f"the 3-D viewer needs meshcat (import failed: {exc}); install it with "
            "pip install 'ibvs-youla[viz]'"
        ) from exc
    return meshcat, MeshcatVisualizer


def _translation(p: Any) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = p
    return T


class Viewer:
    """A meshcat scene of the eye-in-hand servoing task (use as a context manager or call close()).

    Args:
        arm: The arm; default ``Arm.irb4600()``. Needs ``arm.urdf_path`` (its visual geometry).
        camera: The stereo camera; default ``StereoCamera.zed2()``.
        zmq_url: Connect to a running ``meshcat-server`` instead of starting one.
        connect_timeout: How long to wait for that server's answer [s]
            (:func:`~.meshcat_server.wait_for_server`).
        open_browser: Open the page in the system browser (default: only print the URL).
        frustum_far: Far end of the drawn frustum [m]; the near rectangle is the camera's
            minimum depth when it is closer.

    Attributes:
        url: The page to open in a browser.
        q: The configuration last displayed (6,) [rad] (true joint angles).

    Raises:
        VisualizationError: meshcat is not installed, the arm has no URDF, or no server
            answered at ``zmq_url`` within ``connect_timeout``.
    """

    def __init__(
        self,
        arm: Arm | None = None,
        camera: StereoCamera | None = None,
        *,
        zmq_url: str | None = None,
        open_browser: bool = False,
        frustum_far: float = FRUSTUM_FAR,
        connect_timeout: float = CONNECT_TIMEOUT,
    ) -> None:
        meshcat, MeshcatVisualizer = _import_meshcat()
        if zmq_url is not None:  # meshcat would wait forever for a server that is not there
            wait_for_server(zmq_url, connect_timeout)
        import pinocchio as pin

        from ..model.arm import Arm

        self.arm = Arm.irb4600() if arm is None else arm
        self.camera = StereoCamera.zed2() if camera is None else camera
        if not isinstance(self.camera, StereoCamera):
            raise InvalidParameterError("camera", type(self.camera).__name__, "a StereoCamera")
        self.frustum_far = positive(frustum_far, "frustum_far", unit="[m]")
        if self.arm.urdf_path is None:
            raise VisualizationError(f"{self.arm!r} was built without a URDF, so it has no visual geometry")
        visual = pin.buildGeomFromUrdf(self.arm.model, str(self.arm.urdf_path), pin.GeometryType.VISUAL)
        with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints the URL; we print it once below
            self._vis = meshcat.Visualizer(zmq_url=zmq_url)
        self._g = meshcat.geometry
        self._server = self._vis.window.server_proc  # None when connected to an existing server
        self._signals: dict[int, Any] = {}  # signal -> the handler it had before this viewer's
        if self._server is not None:  # drain its pipes so a chatty server never blocks on a full pipe
            for pipe in (self._server.stdout, self._server.stderr):
                threading.Thread(target=pipe.read, daemon=True).start()
            self._signals = _exit_on_termination()
        self.url: str = self._vis.url()
        self._markers_O: np.ndarray | None = None
        self._camera_shown = self._rays_shown = False
        self.q = np.zeros(self.arm.nq)
        try:
            self._robot = MeshcatVisualizer(self.arm.model.copy(), None, visual)
            self._robot.initViewer(viewer=self._vis)
            self._robot.loadViewerModel(rootNodeName="arm")
            self.set_view(DEFAULT_EYE_O)
            self.display(self.q)
        except BaseException:
            self.close()
            raise
        print(f"Meshcat viewer: {self.url}")
        if open_browser:
            self._vis.open()

    # ------------------------------------------------------------------ scene
    def display(self, q: Any) -> None:
        """Put the arm at true joint angles ``q`` (6,) [rad]; the camera and rays follow if shown."""
        self.q = as_array(q, "q", (self.arm.nq,)).copy()
        self._robot.display(self.q)
        if self._camera_shown:
            self._vis["camera"].set_transform(self.arm.camera_pose(self.q))
        if self._rays_shown:
            self._draw_rays()

    def show_markers(self, markers_O: Any, radius: float = 0.05) -> None:
        """Spheres at the markers (n, 3) [m] (base frame); 1, 2, 3 are red, green, blue."""
        markers_O = as_array(markers_O, "markers_O", (None, 3))
        radius = positive(radius, "radius", unit="[m]")
        self._markers_O = markers_O.copy()
        self._vis["markers"].delete()
        g = self._g
        for i, p in enumerate(markers_O):
            node = self._vis["markers"][f"marker_{i + 1}"]
            color = MARKER_COLORS[i % len(MARKER_COLORS)]
            node.set_object(g.Sphere(radius), g.MeshLambertMaterial(color=color))
            node.set_transform(_translation(p))
        if self._rays_shown:
            self._draw_rays()

    def show_camera(self, q: Any = None, far: float | None = None) -> None:
        """The frustum of each lens from the intrinsics, near/far rectangles, and the camera axes.

        Args:
            q: True joint angles (6,) [rad]; default the configuration displayed.
            far: Far end of the frustum [m]; default ``frustum_far``.
        """
        node = self._vis["camera"]
        node["frustum"].set_object(self._frustum(far, FRUSTUM_COLOR, 1.0))
        node["axes"].set_object(self._g.triad(0.15))
        self._camera_shown = True
        self.display(self.q if q is None else q)

    def show_target(self, T_O_C: Any) -> None:
        """The target camera pose T_O_C (4, 4) as a ghost: translucent frustum, body and axes."""
        T_O_C = as_pose(T_O_C, "T_O_C")
        g, node = self._g, self._vis["target"]
        node["frustum"].set_object(self._frustum(None, GHOST_COLOR, 0.45))
        node["body"].set_object(
            g.Box(ZED2_BODY_C), g.MeshLambertMaterial(color=GHOST_COLOR, transparent=True, opacity=0.35)
        )
        node["axes"].set_object(g.triad(0.25))
        node.set_transform(T_O_C)

    def show_rays(self, q: Any = None, markers_O: Any = None) -> None:
        """Lines from each lens centre (left cyan, right magenta) to each marker.

        Args:
            q: True joint angles (6,) [rad]; default the configuration displayed.
            markers_O: Markers (n, 3) [m]; default those of :meth:`show_markers` (which are
                drawn if given here).
        """
        if markers_O is not None:
            self.show_markers(markers_O)
        if self._markers_O is None:
            raise InvalidParameterError("markers_O", None, "markers (n, 3) [m] here or via show_markers")
        self._rays_shown = True
        self.display(self.q if q is None else q)

    def show_scenario(self, scenario: Scenario) -> None:
        """Arm at the true start ``q_start + d``, markers, camera, rays and the target camera pose."""
        if not isinstance(scenario, Scenario):
            raise InvalidParameterError("scenario", type(scenario).__name__, "a Scenario")
        self.show_markers(scenario.markers_O)
        self.show_target(self.arm.camera_pose(scenario.q_target))
        self.show_camera(scenario.q_true_start)
        self.show_rays()

    def set_visible(self, part: str, visible: bool = True) -> None:
        """Show or hide one part: ``"arm"``, ``"markers"``, ``"camera"``, ``"target"`` or ``"rays"``."""
        if part not in _PARTS:
            raise InvalidParameterError("part", part, " or ".join(repr(p) for p in _PARTS))
        self._vis[part].set_property("visible", bool(visible))

    def set_view(self, eye_O: Any) -> None:
        """Place the browser's orbit camera at ``eye_O`` (3,) [m], looking at the base origin.

        Meshcat 0.3 orbits about the world origin; (x, y, z) in {O} is (x, z, -y) in its y-up frame.
        """
        x, y, z = as_array(eye_O, "eye_O", (3,))
        self._vis["/Cameras/default"].set_transform(np.eye(4))
        self._vis["/Cameras/default/rotated/<object>"].set_property("position", [x, z, -y])

    # ------------------------------------------------------------------ playback
    def play(self, result: Any, speed: float = 1.0, fps: float = 30.0) -> int:
        """Replay a :class:`~ibvs_youla.SimulationResult`: the true arm ``result.q_true`` over time.

        Simulated time runs ``speed`` times wall-clock time (1 = real time, 0.25 four times
        slower); frames follow :func:`~ibvs_youla.viz.playback.playback_frames`. If drawing falls
        behind, frames are dropped to keep the speed (never the last one). Markers (from
        ``result.metadata["markers_O"]``, with rays) and the target camera pose are drawn first.

        Returns:
            The number of frames drawn.
        """
        q_true = np.asarray(getattr(result, "q_true", None), dtype=float)
        if q_true.ndim != 2 or q_true.shape[1] != self.arm.nq:
            raise InvalidArrayError("result.q_true", f"shape {q_true.shape}", f"(N, {self.arm.nq})")
        frames = playback_frames(result.t, speed, fps)
        markers = result.metadata.get("markers_O")
        if markers is not None:
            self.show_markers(markers)
            self._rays_shown = True
        self.show_target(result.camera_pose_target)
        self.show_camera(q_true[frames[0]])
        start, drawn = time.perf_counter(), 0
        for k, i in enumerate(frames):
            due, now = start + k / fps, time.perf_counter()
            if now > due + 1.0 / fps and k < len(frames) - 1:
                continue  # behind schedule: drop this frame to keep the speed
            if due > now:
                time.sleep(due - now)
            self.display(q_true[i])
            drawn += 1
        return drawn

    # ------------------------------------------------------------------ notebook, lifetime
    def jupyter_cell(self, height: int = 400) -> Any:
        """An IPython HTML iframe of the live scene (make it the last expression of a cell)."""
        return self._vis.jupyter_cell(height=height)

    def static_html(self) -> str:
        """The current scene as one self-contained HTML page (e.g. to save next to a notebook)."""
        return self._vis.static_html()

    def close(self) -> None:
        """Close the connection and stop the server if this viewer started it."""
        window = self._vis.window
        window.zmq_socket.close(linger=0)
        if self._server is not None and self._server.poll() is None:
            self._server.kill()
            self._server.wait()
        for signum, previous in self._signals.items():  # the program's handlers again
            if signal.getsignal(signum) is _raise_system_exit:
                signal.signal(signum, previous)
        self._signals = {}

    def __enter__(self) -> Viewer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Viewer({self.arm.name!r}, url={self.url!r})"

    # ------------------------------------------------------------------ internals
    def _frustum(self, far: float | None, color: int, opacity: float) -> Any:
        far = self.frustum_far if far is None else positive(far, "far", unit="[m]")
        near = self.camera.depth_range[0]
        segments = frustum_segments_C(self.camera, near if near < far else 0.0, far)
        return self._lines(segments.reshape(-1, 3), color, opacity)

    def _lines(self, points: np.ndarray, color: Any, opacity: float = 1.0) -> Any:
        """LineSegments through consecutive point pairs (2m, 3); ``color`` one hex or per-point RGB."""
        g = self._g
        if isinstance(color, int):
            geometry = g.PointsGeometry(points.T.astype(np.float32))
            material = g.LineBasicMaterial(color=color, transparent=opacity < 1.0, opacity=opacity)
        else:
            geometry = g.PointsGeometry(points.T.astype(np.float32), color=np.asarray(color, np.float32).T)
            material = g.LineBasicMaterial(vertexColors=True)
        return g.LineSegments(geometry, material)

    def _draw_rays(self) -> None:
        segments = ray_segments_O(self.camera, self.arm.camera_pose(self.q), self._markers_O)
        rgb = [[(c >> 16) / 255, (c >> 8 & 255) / 255, (c & 255) / 255] for c in LENS_RAY_COLORS]
        colors = np.repeat(np.array(rgb), 2 * segments.shape[1], axis=0)
        self._vis["rays"].set_object(self._lines(segments.reshape(-1, 3), colors))


def _raise_system_exit(signum: int, frame: Any) -> None:
    """A signal handler: end the program as ``exit(128 + signum)`` would, unwinding it."""
    raise SystemExit(128 + signum)


def _exit_on_termination() -> dict[int, Any]:
    """Make SIGTERM and SIGHUP raise SystemExit where they still have their default action.

    Only in the main thread (Python runs handlers there) and only for signals the program has not
    given a handler; returns signal -> previous handler, for :meth:`Viewer.close` to restore.
    """
    if threading.current_thread() is not threading.main_thread():
        return {}
    changed = {}
    for name in ("SIGTERM", "SIGHUP"):
        signum = getattr(signal, name, None)  # no SIGHUP on Windows
        if signum is not None and signal.getsignal(signum) is signal.SIG_DFL:
            changed[signum] = signal.signal(signum, _raise_system_exit)
    return changed
