"""Simulation results as data: arrays over time plus JSON metadata, saved as one ``.npz``.

:class:`SimulationResult` holds every recorded signal of a run (N samples) and the
compute time of each control update (M updates). :class:`ResultRecorder` fills
preallocated arrays sample by sample (amortised O(1) per sample, growing by doubling
if the run is longer than announced) and can return the finished part of a run that
stopped early, so a diverged or interrupted long job loses no recorded work.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from .._validation import as_array, as_pose
from ..exceptions import InvalidArrayError, InvalidParameterError

__all__ = ["ResultRecorder", "SimulationResult", "software_versions"]

FORMAT_VERSION = 1

# name -> trailing shape of one sample (None = length of the joint vector, 6 for the IRB 4600)
_SAMPLE_SHAPES: dict[str, tuple[int | None, ...]] = {
    "q": (None,),
    "q_true": (None,),
    "dq": (None,),
    "q_ref": (None,),
    "q_ff": (None,),
    "q_fb": (None,),
    "tau": (None,),
    "features": (9,),
    "feature_error": (9,),
    "camera_pose": (4, 4),
    "visible": (3,),
}


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


def _normalise_metadata(metadata: Any) -> dict[str, Any]:
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
    """Signals of one simulated run, sampled at times ``t``.

    Joint vectors are (N, n) with n = 6 for the IRB 4600. NaN is allowed in recorded
    signals (e.g. features of a point behind the camera); shapes are checked.

    Attributes:
        t: Sample times (N,) [s].
        q: Encoder joint angles (N, n) [rad] (what the controller sees).
        q_true: True joint angles (N, n) [rad]; ``q_true = q + d`` (ERRATA 14).
        dq: Joint velocities (N, n) [rad/s].
        q_ref: Inner-loop reference ``q_ff + q_fb`` (N, n) [rad].
        q_ff: Feedforward reference (N, n) [rad] (zeros for a feedback-only run).
        q_fb: Feedback (outer-loop) reference (N, n) [rad].
        tau: Joint torques applied (N, n) [N m].
        features: Measured stereo features (N, 9) [m on the sensor], point-major Eq. (24).
        feature_target: Target features (9,) [m on the sensor].
        feature_error: ``feature_target - features`` (N, 9) [m on the sensor].
        camera_pose: True camera pose ``T_O_C`` (N, 4, 4) [m].
        camera_pose_target: Target camera pose ``T_O_C`` (4, 4) [m].
        visible: Per-marker physical visibility (N, 3) (depth sign, field of view, depth range).
        update_time: Wall-clock compute time of each control update (M,) [s].
        metadata: JSON-serialisable dict: scenario name, controller ("fb" / "ff+fb"),
            adaptive flag, rates, settings, versions, ``"status"`` of the run. Stored
            JSON-normalised (tuples become lists) so that save/load round-trips exactly.
    """

    t: np.ndarray
    q: np.ndarray
    q_true: np.ndarray
    dq: np.ndarray
    q_ref: np.ndarray
    q_ff: np.ndarray
    q_fb: np.ndarray
    tau: np.ndarray
    features: np.ndarray
    feature_target: np.ndarray
    feature_error: np.ndarray
    camera_pose: np.ndarray
    camera_pose_target: np.ndarray
    visible: np.ndarray
    update_time: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        t = as_array(self.t, "t", (None,))
        n_samples = t.shape[0]
        object.__setattr__(self, "t", t)
        q = as_array(self.q, "q", (n_samples, None), finite=False)
        n_joints = q.shape[1]
        for name, tail in _SAMPLE_SHAPES.items():
            shape = (n_samples, *(n_joints if s is None else s for s in tail))
            value = self.visible if name == "visible" else as_array(getattr(self, name), name, finite=False)
            value = np.asarray(value, dtype=bool if name == "visible" else float)
            if value.shape != shape:
                raise InvalidArrayError(name, f"an array of shape {value.shape}", f"shape {shape}")
            object.__setattr__(self, name, value)
        object.__setattr__(self, "feature_target", as_array(self.feature_target, "feature_target", (9,)))
        object.__setattr__(self, "camera_pose_target", as_pose(self.camera_pose_target, "camera_pose_target"))
        object.__setattr__(self, "update_time", as_array(self.update_time, "update_time", (None,)))
        object.__setattr__(self, "metadata", _normalise_metadata(self.metadata))

    # ------------------------------------------------------------------ convenience
    def __len__(self) -> int:
        return int(self.t.shape[0])

    @property
    def duration(self) -> float:
        """Simulated time covered, ``t[-1] - t[0]`` [s] (0 for fewer than two samples)."""
        return float(self.t[-1] - self.t[0]) if len(self) > 1 else 0.0

    @property
    def final_feature_error(self) -> np.ndarray:
        """Last sample of ``feature_target - features`` (9,) [m on the sensor]."""
        self._require_samples("final_feature_error")
        return self.feature_error[-1].copy()

    def final_pose_error(self) -> tuple[float, float]:
        """Distance between the last camera pose and the target: (position [mm], rotation [deg])."""
        from ..analysis.metrics import pose_error

        self._require_samples("final_pose_error")
        return pose_error(self.camera_pose[-1], self.camera_pose_target)

    def _require_samples(self, what: str) -> None:
        if len(self) == 0:
            raise InvalidArrayError("SimulationResult", f"no samples (asked for {what})", ">= 1 sample")

    # ------------------------------------------------------------------ persistence
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
        arrays = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "metadata"}
        header = {"format_version": FORMAT_VERSION, "metadata": self.metadata}
        meta = np.array(json.dumps(header, default=_json_default, allow_nan=True))
        np.savez_compressed(path, __metadata__=meta, **arrays)
        return path

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> SimulationResult:
        """Read a result written by :meth:`save` (``path`` with or without ``.npz``).

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
        with np.load(path, allow_pickle=False) as data:
            names = [f.name for f in fields(cls) if f.name != "metadata"]
            missing = [n for n in [*names, "__metadata__"] if n not in data.files]
            if missing:
                raise InvalidParameterError(
                    "path", str(path), f"a saved SimulationResult (missing {missing})"
                )
            arrays = {n: data[n] for n in names}
            header = json.loads(str(data["__metadata__"]))
        if header.get("format_version") != FORMAT_VERSION:
            raise InvalidParameterError(
                "format_version", header.get("format_version"), f"{FORMAT_VERSION} (this library's format)"
            )
        return cls(**arrays, metadata=header["metadata"])


class ResultRecorder:
    """Preallocated sample buffers that a simulator fills one sample at a time.

    Appending is amortised O(1): the buffers are allocated for ``capacity`` samples and
    doubled if the run records more. :meth:`result` copies only the filled part, so it
    can be called at any time, e.g. from an ``except`` block when a run diverges.

    Args:
        feature_target: Target features (9,) [m on the sensor].
        camera_pose_target: Target camera pose ``T_O_C`` (4, 4).
        capacity: Expected number of samples (>= 1), e.g. ``round(duration / dt_record) + 1``.
        n_joints: Length of the joint vectors (6 for the IRB 4600).
        metadata: JSON-serialisable dict copied into the result.
    """

    def __init__(
        self,
        feature_target: np.ndarray,
        camera_pose_target: np.ndarray,
        capacity: int,
        *,
        n_joints: int = 6,
        metadata: dict[str, Any] | None = None,
    ) -> None:
        if isinstance(capacity, bool) or not isinstance(capacity, (int, np.integer)) or capacity < 1:
            raise InvalidParameterError("capacity", capacity, "an integer >= 1")
        if isinstance(n_joints, bool) or not isinstance(n_joints, (int, np.integer)) or n_joints < 1:
            raise InvalidParameterError("n_joints", n_joints, "an integer >= 1")
        self.feature_target = as_array(feature_target, "feature_target", (9,)).copy()
        self.camera_pose_target = as_pose(camera_pose_target, "camera_pose_target").copy()
        self.metadata = _normalise_metadata(metadata)
        self._n_joints = int(n_joints)
        self._t = np.empty(int(capacity))
        self._buf = {
            name: np.empty(
                (int(capacity), *(self._n_joints if s is None else s for s in tail)),
                dtype=bool if name == "visible" else float,
            )
            for name, tail in _SAMPLE_SHAPES.items()
            if name != "feature_error"  # derived from features in `result`
        }
        self._n = 0
        self._update_time = np.empty(max(16, int(capacity)))
        self._m = 0

    def __len__(self) -> int:
        return self._n

    def _grow(self) -> None:
        self._t = np.concatenate([self._t, np.empty_like(self._t)])
        for name, buf in self._buf.items():
            self._buf[name] = np.concatenate([buf, np.empty_like(buf)])

    def record(
        self,
        t: float,
        *,
        q: np.ndarray,
        q_true: np.ndarray,
        dq: np.ndarray,
        q_ref: np.ndarray,
        q_ff: np.ndarray,
        q_fb: np.ndarray,
        tau: np.ndarray,
        features: np.ndarray,
        camera_pose: np.ndarray,
        visible: np.ndarray,
    ) -> None:
        """Append one sample (``feature_error = feature_target - features`` is derived in :meth:`result`).

        Values are copied into the buffers (broadcasting rules of numpy assignment apply,
        so a wrong length raises ``ValueError`` from numpy).
        """
        if self._n == self._t.shape[0]:
            self._grow()
        i = self._n
        b = self._buf
        self._t[i] = t
        b["q"][i] = q
        b["q_true"][i] = q_true
        b["dq"][i] = dq
        b["q_ref"][i] = q_ref
        b["q_ff"][i] = q_ff
        b["q_fb"][i] = q_fb
        b["tau"][i] = tau
        b["features"][i] = features
        b["camera_pose"][i] = camera_pose
        b["visible"][i] = visible
        self._n = i + 1

    def record_update_time(self, seconds: float) -> None:
        """Append the wall-clock compute time of one control update [s]."""
        if self._m == self._update_time.shape[0]:
            self._update_time = np.concatenate([self._update_time, np.empty_like(self._update_time)])
        self._update_time[self._m] = seconds
        self._m += 1

    def result(
        self, *, status: str = "complete", extra_metadata: dict[str, Any] | None = None
    ) -> SimulationResult:
        """Return the samples recorded so far as a :class:`SimulationResult` (copies).

        Args:
            status: Stored as ``metadata["status"]``, e.g. ``"complete"``, ``"diverged"``,
                ``"interrupted"``; anything but ``"complete"`` marks a partial result.
            extra_metadata: Merged over the recorder's metadata (e.g. the error message).
        """
        n = self._n
        metadata = {**self.metadata, **_normalise_metadata(extra_metadata), "status": status}
        return SimulationResult(
            t=self._t[:n].copy(),
            **{name: buf[:n].copy() for name, buf in self._buf.items()},
            feature_error=self.feature_target - self._buf["features"][:n],
            feature_target=self.feature_target.copy(),
            camera_pose_target=self.camera_pose_target.copy(),
            update_time=self._update_time[: self._m].copy(),
            metadata=metadata,
        )
