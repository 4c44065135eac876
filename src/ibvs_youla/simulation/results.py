"""Simulation results as data: arrays over time plus JSON metadata, saved as one ``.npz``.

:class:`SimulationResult` holds every recorded signal of a run (N tick samples) and its
frame log (M camera frames, with the compute time of each control update). The servo loop
fills it through :class:`~.recorder.ResultRecorder`, which can return the finished part of
a run that stopped early, so a diverged or interrupted long job loses no recorded work.
"""

from __future__ import annotations

import functools
import json
import os
import zipfile
import zlib
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from .._geometry import pose_error_mm_deg
from .._validation import as_array, as_pose
from ..exceptions import DamagedFileError, IbvsYoulaError, InvalidArrayError, InvalidParameterError
from ..files import atomic_write

__all__ = ["STATUSES", "SimulationResult", "check_loaded", "normalise_metadata", "software_versions"]

FORMAT_VERSION = 2  # 1: fixed three-marker stereo schema with q_ff/q_fb fields (still loads)
STATUSES = ("complete", "markers_lost", "estimate_failed", "diverged", "interrupted", "controller_failed")
_LEGACY_SIGNALS = ("q", "q_true", "dq", "q_ref", "q_ff", "q_fb", "tau")  # format 1's joint signals
_SIGNAL_PREFIX = "signal/"
_ZIP_MAGIC = b"PK\x03\x04"  # every .npz archive starts with a zip local file header
_EXPECTED = "a file written by SimulationResult.save (an .npz archive with a JSON header)"


def software_versions() -> dict[str, str]:
    """Versions of Python and of the packages a result depends on, for ``metadata["versions"]``.

    Looked up once per process (reading the installed packages' metadata costs ~3 ms, a few
    percent of a short campaign run); each call returns a new dict.
    """
    return dict(_installed_versions())


@functools.cache
def _installed_versions() -> tuple[tuple[str, str], ...]:
    import platform
    from importlib import metadata as importlib_metadata

    versions = [("python", platform.python_version())]
    for dist in ("ibvs-youla", "numpy", "scipy", "pin", "control"):
        try:
            versions.append((dist, importlib_metadata.version(dist)))
        except importlib_metadata.PackageNotFoundError:
            versions.append((dist, "not installed"))
    return tuple(versions)


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
    shapes are checked. A result owns its arrays: it stores copies of the ones it is given
    and exposes them read-only (``writeable=False``), so nothing written later, by the
    caller or by a reader, can change what it holds or saves.

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
        def set_(name: str, value: np.ndarray) -> None:
            object.__setattr__(self, name, _owned(value))

        t = as_array(self.t, "t", (None,))
        n = t.shape[0]
        set_("t", t)
        target = as_array(self.feature_target, "feature_target", (None,))
        m = target.shape[0]
        set_("feature_target", target)
        set_("camera_pose_target", as_pose(self.camera_pose_target, "camera_pose_target"))
        set_("camera_pose", _shaped(self.camera_pose, "camera_pose", (n, 4, 4)))
        set_("features", _shaped(self.features, "features", (n, m)))
        visible = np.asarray(self.visible, dtype=bool)
        if visible.ndim != 2 or visible.shape[0] != n:
            raise InvalidArrayError("visible", f"an array of shape {visible.shape}", f"shape ({n}, n_points)")
        set_("visible", visible)
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
            signals[str(name)] = _owned(arr)
        object.__setattr__(self, "signals", signals)
        frame_t = np.zeros(0) if self.frame_t is None else as_array(self.frame_t, "frame_t", (None,))
        k = frame_t.shape[0]
        set_("frame_t", frame_t)
        frame_features = np.zeros((k, m)) if self.frame_features is None else self.frame_features
        set_("frame_features", _shaped(frame_features, "frame_features", (k, m)))
        frame_visible = np.ones((k, n_points), bool) if self.frame_visible is None else self.frame_visible
        frame_visible = np.asarray(frame_visible, dtype=bool)
        if frame_visible.shape != (k, n_points):
            raise InvalidArrayError(
                "frame_visible", f"an array of shape {frame_visible.shape}", f"shape ({k}, {n_points})"
            )
        set_("frame_visible", frame_visible)
        update_time = (
            np.zeros(k) if self.update_time is None else as_array(self.update_time, "update_time", (None,))
        )
        if k and update_time.shape != (k,):
            raise InvalidArrayError("update_time", f"an array of shape {update_time.shape}", f"shape ({k},)")
        set_("update_time", update_time)
        object.__setattr__(self, "metadata", normalise_metadata(self.metadata))

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Unpickled (e.g. returned by a Dask worker): the arrays are read-only again."""
        for value in state.values():
            if isinstance(value, np.ndarray):
                value.flags.writeable = False
        for value in state.get("signals", {}).values():
            value.flags.writeable = False
        self.__dict__.update(state)

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
        if len(self) == 0:  # say why: a run stopped before its first sample (its status and error)
            error = self.metadata.get("error")
            why = f"the run ended with status {self.status!r} before its first sample" + (
                f" ({error})" if error else ""
            )
            raise InvalidArrayError(
                "SimulationResult", f"no samples (asked for {what}): {why}", ">= 1 sample"
            )

    # ------------------------------------------------------------------ persistence
    def _arrays(self) -> dict[str, np.ndarray]:
        arrays = {
            f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("metadata", "signals")
        }
        arrays.update({_SIGNAL_PREFIX + name: value for name, value in self.signals.items()})
        return arrays

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write every array and the metadata (as a JSON string) to one ``.npz`` file, atomically.

        The archive goes to a temporary file in the same folder, which is renamed over
        ``path`` once complete (:func:`ibvs_youla.files.atomic_write`): ``path`` holds the
        previous file or this result, never a part of one.

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
        with atomic_write(path) as stream:
            np.savez_compressed(stream, __metadata__=meta, **self._arrays())
        return path

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> SimulationResult:
        """Read a result written by :meth:`save` (``path`` with or without ``.npz``), format 1 or 2.

        Raises:
            InvalidParameterError: there is no file at ``path`` (nor at ``path`` + ``.npz``).
            DamagedFileError: (an :class:`InvalidParameterError`) the file is not a whole saved
                result: a directory, empty, not a zip archive, truncated, corrupted (CRC or
                decompression), a header that is not JSON or lacks ``metadata``, missing
                arrays, arrays that do not fit together, or an unknown format version; or values
                no run records (:func:`check_loaded`: non-finite or non-rigid camera poses, time
                running backwards, visibility that is not boolean, an unknown status). The
                message names the file, the field and what is wrong.
        """
        path = Path(path)
        if not path.exists() and path.with_name(path.name + ".npz").exists():
            path = path.with_name(path.name + ".npz")
        if not path.exists():
            raise InvalidParameterError(
                "path", str(path), "an existing file written by SimulationResult.save"
            )
        arrays, header = _read_archive(path)
        version = header.get("format_version")
        if version not in (1, FORMAT_VERSION):
            raise DamagedFileError(
                path,
                f"format version {version!r}",
                f"format 1 or {FORMAT_VERSION} (the formats this library reads)",
            )
        if version == 1:
            names = ["t", *_LEGACY_SIGNALS, "features", "feature_target", "camera_pose"]
            names += ["camera_pose_target", "visible", "update_time"]
        else:
            names = [f.name for f in fields(cls) if f.name not in ("metadata", "signals")]
        missing = [n for n in names if n not in arrays]
        if missing:
            raise DamagedFileError(path, f"missing the arrays {missing} (format {version})", _EXPECTED)
        for name in ("visible", "frame_visible"):  # numpy reads any non-empty string as True
            if name in arrays and arrays[name].dtype.kind != "b":
                raise DamagedFileError(
                    path, f"field {name!r} holds {arrays[name].dtype} values, not booleans", _EXPECTED
                )
        try:
            if version == 1:
                result = cls._from_format_1(arrays, header["metadata"])
            else:
                signals = {
                    k[len(_SIGNAL_PREFIX) :]: v for k, v in arrays.items() if k.startswith(_SIGNAL_PREFIX)
                }
                result = cls(**{n: arrays[n] for n in names}, signals=signals, metadata=header["metadata"])
        except IbvsYoulaError as err:
            raise DamagedFileError(path, f"its arrays do not form a result ({err})", _EXPECTED) from None
        problem = check_loaded(result)
        if problem:
            raise DamagedFileError(path, problem, _EXPECTED)
        return result

    @classmethod
    def _from_format_1(cls, arrays: dict[str, np.ndarray], metadata: dict[str, Any]) -> SimulationResult:
        """Format 1: fixed fields, no frame log (``feature_error`` was stored; it is derived now)."""
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


def check_loaded(result: SimulationResult) -> str:
    """What no run records in ``result`` ("" when nothing): the checks of a file read back.

    A run records finite rigid camera poses (the plants diverge before holding any other), times
    that never run backwards (ticks and frames), and one of :data:`STATUSES`. The constructor
    allows NaN in recorded signals and features (a dropped marker, a diverged signal); these
    checks are for a file, whose poses, times and status the readers trust.
    """
    for name in ("t", "frame_t"):
        times = getattr(result, name)
        if not np.isfinite(times).all():
            i = int(np.flatnonzero(~np.isfinite(times))[0])
            return f"field {name!r}: sample {i} is {times[i]} s, not a finite time"
        back = np.flatnonzero(np.diff(times) < 0.0)
        if back.size:
            i = int(back[0]) + 1
            return f"field {name!r} runs backwards: sample {i} at {times[i]:.6g} s after {times[i - 1]:.6g} s"
    poses = result.camera_pose
    if poses.size:
        finite = np.isfinite(poses).all(axis=(1, 2))
        R = np.where(finite[:, None, None], poses[:, :3, :3], 0.0)
        error = np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max(axis=(1, 2))
        det = np.linalg.det(R)
        last = np.abs(poses[:, 3] - _LAST_ROW).max(axis=1)
        rigid = finite & (error <= _RIGID_TOL) & (np.abs(det - 1.0) <= _RIGID_TOL) & (last <= 1e-9)
        if not rigid.all():
            i = int(np.flatnonzero(~rigid)[0])
            what = (
                "is not finite"
                if not finite[i]
                else f"is not a rigid transform (max|R^T R - I| = {error[i]:.2e}, det R = {det[i]:.6f}, "
                f"last row {poses[i, 3].tolist()})"
            )
            return f"field 'camera_pose': sample {i} (t = {result.t[i]:.6g} s) {what}"
    status = result.metadata.get("status", "complete")
    if status not in STATUSES:
        return f"field 'metadata.status' is {status!r}, not one of {', '.join(STATUSES)}"
    return ""


_RIGID_TOL = 1e-6  # max |R^T R - I| and |det R - 1| of a rigid transform (as_pose's)
_LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])


def _read_archive(path: Path) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """The arrays and the JSON header of a saved result, or a :class:`DamagedFileError` saying why not."""
    if path.is_dir():
        raise DamagedFileError(path, "a directory, not a file", _EXPECTED)
    with open(path, "rb") as stream:
        head = stream.read(len(_ZIP_MAGIC))
    if not head:
        raise DamagedFileError(path, "empty (0 bytes)", _EXPECTED)
    if head != _ZIP_MAGIC:
        raise DamagedFileError(path, f"not an .npz (zip) archive: it starts with {head!r}", _EXPECTED)
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
    except zlib.error as exc:
        raise DamagedFileError(
            path, f"corrupted: compressed data does not decompress ({exc})", _EXPECTED
        ) from None
    except zipfile.BadZipFile as exc:
        what = (
            "corrupted: a CRC check failed" if "CRC" in str(exc) else "not a whole zip archive (truncated?)"
        )
        raise DamagedFileError(path, f"{what} ({exc})", _EXPECTED) from None
    except Exception as exc:  # whatever a damaged archive makes numpy or zipfile raise
        raise DamagedFileError(path, f"unreadable ({type(exc).__name__}: {exc})", _EXPECTED) from None
    if "__metadata__" not in arrays:
        raise DamagedFileError(path, "no __metadata__ entry (the JSON header)", _EXPECTED)
    try:
        header = json.loads(str(arrays.pop("__metadata__")))
    except ValueError as exc:
        raise DamagedFileError(path, f"its header is not JSON ({exc})", _EXPECTED) from None
    if not isinstance(header, dict) or not isinstance(header.get("metadata"), dict):
        raise DamagedFileError(path, "its JSON header has no 'metadata' object", _EXPECTED)
    return arrays, header


def _owned(value: np.ndarray) -> np.ndarray:
    """A read-only copy of ``value`` that no caller holds a reference to."""
    owned = np.array(value, copy=True)
    owned.flags.writeable = False
    return owned


def _shaped(value: Any, name: str, shape: tuple[int, ...]) -> np.ndarray:
    arr = as_array(value, name, finite=False)
    if arr.shape != shape:
        raise InvalidArrayError(name, f"an array of shape {arr.shape}", f"shape {shape}")
    return arr
