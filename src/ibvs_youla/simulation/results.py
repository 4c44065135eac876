"""Simulation results as data: arrays over time plus JSON metadata, saved as one ``.npz``.

:class:`SimulationResult` holds every recorded signal of a run (N tick samples) and its
frame log (M camera frames, with the compute time of each control update). The servo loop
fills it through :class:`~.recorder.ResultRecorder`, which can return the finished part of
a run that stopped early, so a diverged or interrupted long job loses no recorded work.
"""

from __future__ import annotations

import json
import os
import zipfile
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from .._geometry import pose_error_mm_deg
from .._validation import as_array, as_pose
from ..exceptions import InvalidArrayError, InvalidParameterError

__all__ = ["STATUSES", "SimulationResult", "normalise_metadata", "software_versions"]

FORMAT_VERSION = 2  # 1: fixed three-marker stereo schema with q_ff/q_fb fields (still loads)
STATUSES = ("complete", "markers_lost", "estimate_failed", "diverged", "interrupted")
_LEGACY_SIGNALS = ("q", "q_true", "dq", "q_ref", "q_ff", "q_fb", "tau")  # format 1's joint signals
_SIGNAL_PREFIX = "signal/"


def software_versions() -> dict[str, str]:
    """Versions of Python and of the packages a result depends on, for ``metadata["versions"]``."""
    import platform
    from importlib import metadata as importlib_metadata

    versions = {"python": platform.python_version()}
    for dist in ("ibvs-youla", "numpy", "scipy", "pin", "control"):
        try:
            versions[dist] = importlib_metadata.version(dist)
        except importlib_metadata.PackageNotFoundError:
            versions[dist] = "not installed"
    return versions


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def normalise_metadata(metadata: Any) -> dict[str, Any]:
    """``metadata`` as plain JSON data (tuples become lists, numpy scalars floats), or an error.

    Raises:
        InvalidParameterError: not a dict, or not JSON-serialisable.
    """
    if metadata is None:
        return {}
    if not isinstance(metadata, dict):
        raise InvalidParameterError("metadata", type(metadata).__name__, "a dict (JSON-serialisable)")
    try:
        return json.loads(json.dumps(metadata, default=_json_default))
    except (TypeError, ValueError) as exc:
        raise InvalidParameterError("metadata", metadata, f"JSON-serialisable values ({exc})") from None


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """Signals of one simulated run, whatever the controller, plant and camera.

    Tick-rate samples (N, at times ``t``) hold the true camera pose, the last image features
    and visibility (held between frames), and named ``signals``: the plant's (``q``
    encoders, ``q_true``, ``dq`` on an arm), each command along the actuation chain
    (``camera_twist``, ``dq_ref``, ``q_ref``, ``tau``), and what the controller declares
    (``q_ff``, ``q_fb`` for the paper's). Each signal reads as an attribute too
    (``result.q_ff``). The frame log (M frames) holds capture times, features, visibility
    and the compute time of each control update. NaN is allowed in recorded signals;
    shapes are checked.

    Attributes:
        t: Sample times (N,) [s].
        camera_pose: True camera pose ``T_O_C`` (N, 4, 4) [m].
        camera_pose_target: Target camera pose ``T_O_C`` (4, 4) [m].
        features: Last measured features (N, m), point-major: [u_l, u_r, v] per point for a
            stereo camera (Eq. (24)), [u, v] for a monocular one [m on the sensor; unitless
            normalized coordinates for ``PinholeCamera.normalized()``].
        feature_target: Target features (m,).
        visible: Per-point physical visibility (N, n) (depth sign, field of view, depth range).
        signals: Name -> (N, ...) array (see above).
        frame_t: Capture time of each camera frame (M,) [s].
        frame_features: Features of each frame (M, m).
        frame_visible: Visibility of each frame (M, n).
        update_time: Wall-clock compute time of each control update (M,) [s]. Files of
            format 1 have no frame log: then ``frame_t`` is empty and only this is kept.
        metadata: JSON-serialisable dict: ``"status"`` (one of :data:`STATUSES`),
            ``"spec"`` (the full run specification), scenario, controller, plant, rates,
            settings, versions. Stored JSON-normalised so save/load round-trips exactly.
    """

    t: np.ndarray
    camera_pose: np.ndarray
    camera_pose_target: np.ndarray
    features: np.ndarray
    feature_target: np.ndarray
    visible: np.ndarray
    signals: dict[str, np.ndarray] = field(default_factory=dict)
    frame_t: np.ndarray | None = None
    frame_features: np.ndarray | None = None
    frame_visible: np.ndarray | None = None
    update_time: np.ndarray | None = None
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        t = as_array(self.t, "t", (None,))
        n = t.shape[0]
        set_(self, "t", t)
        target = as_array(self.feature_target, "feature_target", (None,))
        m = target.shape[0]
        set_(self, "feature_target", target)
        set_(self, "camera_pose_target", as_pose(self.camera_pose_target, "camera_pose_target"))
        set_(self, "camera_pose", _shaped(self.camera_pose, "camera_pose", (n, 4, 4)))
        set_(self, "features", _shaped(self.features, "features", (n, m)))
        visible = np.asarray(self.visible, dtype=bool)
        if visible.ndim != 2 or visible.shape[0] != n:
            raise InvalidArrayError("visible", f"an array of shape {visible.shape}", f"shape ({n}, n_points)")
        set_(self, "visible", visible)
        n_points = visible.shape[1]
        if not isinstance(self.signals, dict):
            raise InvalidParameterError(
                "signals", type(self.signals).__name__, "a dict name -> (N, ...) array"
            )
        signals = {}
        for name, value in self.signals.items():
            arr = as_array(value, f"signals[{name!r}]", finite=False)
            if arr.ndim == 0 or arr.shape[0] != n:
                raise InvalidArrayError(f"signals[{name!r}]", f"an array of shape {arr.shape}", f"({n}, ...)")
            signals[str(name)] = arr
        set_(self, "signals", signals)
        frame_t = np.zeros(0) if self.frame_t is None else as_array(self.frame_t, "frame_t", (None,))
        k = frame_t.shape[0]
        set_(self, "frame_t", frame_t)
        frame_features = np.zeros((k, m)) if self.frame_features is None else self.frame_features
        set_(self, "frame_features", _shaped(frame_features, "frame_features", (k, m)))
        frame_visible = np.ones((k, n_points), bool) if self.frame_visible is None else self.frame_visible
        frame_visible = np.asarray(frame_visible, dtype=bool)
        if frame_visible.shape != (k, n_points):
            raise InvalidArrayError(
                "frame_visible", f"an array of shape {frame_visible.shape}", f"shape ({k}, {n_points})"
            )
        set_(self, "frame_visible", frame_visible)
        update_time = (
            np.zeros(k) if self.update_time is None else as_array(self.update_time, "update_time", (None,))
        )
        if k and update_time.shape != (k,):
            raise InvalidArrayError("update_time", f"an array of shape {update_time.shape}", f"shape ({k},)")
        set_(self, "update_time", update_time)
        set_(self, "metadata", normalise_metadata(self.metadata))

    def __getattr__(self, name: str) -> np.ndarray:
        """A recorded signal by name, e.g. ``result.q`` or ``result.q_ff``."""
        if name.startswith("__") or name == "signals":
            raise AttributeError(name)
        signals = self.__dict__.get("signals", {})
        if name in signals:
            return signals[name]
        raise AttributeError(
            f"{type(self).__name__} has no attribute or signal {name!r}; "
            f"signals: {', '.join(signals) or 'none'}"
        )

    # ------------------------------------------------------------------ convenience
    def __len__(self) -> int:
        return int(self.t.shape[0])

    @property
    def n_points(self) -> int:
        """Number of markers n."""
        return int(self.visible.shape[1])

    @property
    def status(self) -> str:
        """How the run ended (``metadata["status"]``; ``"complete"`` when absent)."""
        return str(self.metadata.get("status", "complete"))

    @property
    def feature_error(self) -> np.ndarray:
        """``feature_target - features`` (N, m)."""
        return self.feature_target - self.features

    @property
    def duration(self) -> float:
        """Simulated time covered, ``t[-1] - t[0]`` [s] (0 for fewer than two samples)."""
        return float(self.t[-1] - self.t[0]) if len(self) > 1 else 0.0

    @property
    def final_feature_error(self) -> np.ndarray:
        """Last sample of ``feature_target - features`` (m,)."""
        self._require_samples("final_feature_error")
        return self.feature_target - self.features[-1]

    def final_pose_error(self) -> tuple[float, float]:
        """Distance between the last camera pose and the target: (position [mm], rotation [deg])."""
        self._require_samples("final_pose_error")
        return pose_error_mm_deg(self.camera_pose[-1], self.camera_pose_target)

    def _require_samples(self, what: str) -> None:
        if len(self) == 0:
            raise InvalidArrayError("SimulationResult", f"no samples (asked for {what})", ">= 1 sample")

    # ------------------------------------------------------------------ persistence
    def _arrays(self) -> dict[str, np.ndarray]:
        arrays = {
            f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("metadata", "signals")
        }
        arrays.update({_SIGNAL_PREFIX + name: value for name, value in self.signals.items()})
        return arrays

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write every array and the metadata (as a JSON string) to one ``.npz`` file.

        Args:
            path: Destination; ``.npz`` is appended when the name has another or no suffix.

        Returns:
            The path actually written.
        """
        path = Path(path)
        if path.suffix != ".npz":
            path = path.with_name(path.name + ".npz")
        header = {"format_version": FORMAT_VERSION, "metadata": self.metadata}
        meta = np.array(json.dumps(header, default=_json_default, allow_nan=True))
        np.savez_compressed(path, __metadata__=meta, **self._arrays())
        return path

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> SimulationResult:
        """Read a result written by :meth:`save` (``path`` with or without ``.npz``), any format version.

        Raises:
            InvalidParameterError: the file is missing or is not a saved result.
        """
        path = Path(path)
        if not path.exists() and path.with_name(path.name + ".npz").exists():
            path = path.with_name(path.name + ".npz")
        if not path.exists():
            raise InvalidParameterError(
                "path", str(path), "an existing file written by SimulationResult.save"
            )
        valid = "a file written by SimulationResult.save (an .npz archive with a JSON header)"
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {name: data[name] for name in data.files}
            header = json.loads(str(arrays.pop("__metadata__")))
            if not isinstance(header, dict) or not isinstance(header.get("metadata"), dict):
                raise ValueError("the JSON header has no 'metadata' object")
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
            raise InvalidParameterError("path", str(path), f"{valid}; reading it failed: {exc}") from None
        version = header.get("format_version")
        if version == 1:
            return cls._from_format_1(path, arrays, header["metadata"])
        if version != FORMAT_VERSION:
            raise InvalidParameterError(
                "format_version", version, f"1 or {FORMAT_VERSION} (the formats this library reads)"
            )
        names = [f.name for f in fields(cls) if f.name not in ("metadata", "signals")]
        missing = [n for n in names if n not in arrays]
        if missing:
            raise InvalidParameterError("path", str(path), f"a saved SimulationResult (missing {missing})")
        signals = {k[len(_SIGNAL_PREFIX) :]: v for k, v in arrays.items() if k.startswith(_SIGNAL_PREFIX)}
        return cls(**{n: arrays[n] for n in names}, signals=signals, metadata=header["metadata"])

    @classmethod
    def _from_format_1(
        cls, path: Path, arrays: dict[str, np.ndarray], metadata: dict[str, Any]
    ) -> SimulationResult:
        """Format 1: fixed fields, no frame log (``feature_error`` was stored; it is derived now)."""
        required = [
            "t",
            *_LEGACY_SIGNALS,
            "features",
            "feature_target",
            "camera_pose",
            "camera_pose_target",
            "visible",
            "update_time",
        ]
        missing = [n for n in required if n not in arrays]
        if missing:
            raise InvalidParameterError("path", str(path), f"a saved SimulationResult (missing {missing})")
        return cls(
            t=arrays["t"],
            camera_pose=arrays["camera_pose"],
            camera_pose_target=arrays["camera_pose_target"],
            features=arrays["features"],
            feature_target=arrays["feature_target"],
            visible=arrays["visible"],
            signals={name: arrays[name] for name in _LEGACY_SIGNALS},
            update_time=arrays["update_time"],
            metadata={"plant": "dynamic", **metadata},
        )


def _shaped(value: Any, name: str, shape: tuple[int, ...]) -> np.ndarray:
    arr = as_array(value, name, finite=False)
    if arr.shape != shape:
        raise InvalidArrayError(name, f"an array of shape {arr.shape}", f"shape {shape}")
    return arr
