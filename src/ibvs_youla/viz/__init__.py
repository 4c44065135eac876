"""3-D views of the servoing task in Meshcat: the arm, markers, camera frustum, target pose, rays.

``Viewer`` starts a local meshcat server (its web page and three.js are served locally), prints
the URL and never opens a browser; it works in Jupyter through ``Viewer.jupyter_cell()``.
Importing this package is cheap and does not need meshcat; constructing a ``Viewer`` without
meshcat raises :class:`~ibvs_youla.exceptions.VisualizationError`. The geometry it draws is
computed by plain functions (:mod:`.geometry`, :mod:`.playback`) that can be tested alone.

Example::

    from ibvs_youla import scenarios
    from ibvs_youla.viz import Viewer

    viewer = Viewer()  # prints e.g. http://127.0.0.1:7000/static/
    viewer.show_scenario(scenarios.physical(1))
"""

from __future__ import annotations

from .geometry import frustum_corners_C, frustum_segments_C, lens_centres_C, ray_segments_O
from .meshcat_server import CONNECT_TIMEOUT, wait_for_server
from .meshcat_viewer import Viewer
from .playback import playback_frames

__all__ = [
    "CONNECT_TIMEOUT",
    "Viewer",
    "frustum_corners_C",
    "frustum_segments_C",
    "lens_centres_C",
    "playback_frames",
    "ray_segments_O",
    "wait_for_server",
]
