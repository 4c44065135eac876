"""Screenshots of a local web page with Debian's headless Chromium, and meshcat's default camera model.

Chromium runs in its own process group with a fresh profile and is killed (by that group id)
when the screenshot is taken or the timeout expires. Host resolution is limited to 127.0.0.1,
so a page that needed the internet would fail to render rather than fetch anything.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import tempfile
from pathlib import Path

import matplotlib.image
import numpy as np

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--enable-unsafe-swiftshader",  # software WebGL; newer Chromium no longer falls back silently
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1",
)
MESHCAT_FOV_Y = 75.0  # [deg] vertical field of view of meshcat 0.3's default PerspectiveCamera


def chromium() -> str | None:
    """Path of the Chromium binary, or None."""
    found = shutil.which("chromium")
    if found:
        return found
    return "/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None


def screenshot(
    url: str, path: Path, size: tuple[int, int] = (800, 600), budget_ms: int = 3000, timeout: float = 120.0
) -> np.ndarray:
    """Load ``url``, let its scripts run for ``budget_ms`` of virtual time, return the RGB image (h, w, 3)."""
    binary = chromium()
    if binary is None:
        raise RuntimeError("chromium is not installed (apt-get install -y chromium)")
    path = Path(path)
    path.unlink(missing_ok=True)
    with tempfile.TemporaryDirectory(prefix="chromium-profile-", ignore_cleanup_errors=True) as profile:
        cmd = [
            binary,
            *FLAGS,
            f"--user-data-dir={profile}",
            f"--screenshot={path}",
            f"--window-size={size[0]},{size[1]}",
            f"--virtual-time-budget={budget_ms}",
            url,
        ]
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
        try:
            _, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            err = b"timed out"
        finally:
            try:
                os.killpg(proc.pid, signal.SIGKILL)  # the group we created: browser, GPU and renderer
            except ProcessLookupError:
                pass
            proc.communicate()
    if not path.exists():
        raise RuntimeError(f"chromium wrote no screenshot (exit {proc.returncode}): {err.decode()[-2000:]}")
    return matplotlib.image.imread(path)[..., :3]


def meshcat_pixels(P_O: np.ndarray, eye_O: np.ndarray, size: tuple[int, int] = (800, 600)) -> np.ndarray:
    """Pixel (column, row) of points (n, 3) in meshcat's default view from ``eye_O``.

    Meshcat 0.3's orbit camera looks at the world origin with z up, vertical field of view 75 deg,
    aspect = width / height (the canvas fills the window).
    """
    width, height = size
    eye = np.asarray(eye_O, float)
    forward = -eye / np.linalg.norm(eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = np.asarray(P_O, float) - eye
    x, y, z = d @ right, d @ up, d @ forward
    tan_half = np.tan(np.radians(MESHCAT_FOV_Y) / 2)
    col = width / 2 * (1 + x / z / (tan_half * width / height))
    row = height / 2 * (1 - y / z / tan_half)
    return np.column_stack([col, row])
