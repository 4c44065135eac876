"""Recording a servo run: preallocated tick buffers and a frame log, turned into a result at any time.

:class:`ResultRecorder` fills preallocated arrays one tick sample at a time (amortised O(1):
the buffers double when a run is longer than announced) and appends each camera frame to
its log. :meth:`ResultRecorder.result` copies what was recorded so far, so a run that stops
early (diverged, markers lost, interrupted) keeps every finished sample.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .._validation import as_array, as_pose
from ..exceptions import InvalidArrayError, InvalidParameterError
from .results import STATUSES, SimulationResult, normalise_metadata

__all__ = ["ResultRecorder"]


class ResultRecorder:
    """Preallocated buffers that a servo loop fills, one tick sample and one frame at a time.

    Args:
        feature_target: Target features (m,).
        camera_pose_target: Target camera pose ``T_O_C`` (4, 4).
        capacity: Expected number of tick samples (>= 1).
        n_points: Number of markers n (visibility columns).
        signals: Name -> shape of one sample of each signal :meth:`record` receives, in its
            order (e.g. ``{"q": (6,), "tau": (6,)}``); a run that stops before its first sample
            still has every signal, with no rows.
        metadata: JSON-serialisable dict copied into the result.
    """

    def __init__(
        self,
        feature_target: np.ndarray,
        camera_pose_target: np.ndarray,
        capacity: int,
        *,
        n_points: int = 3,
        signals: Mapping[str, tuple[int, ...]] | None = None,
        metadata: dict[str, Any] | None = None,
    ) -> None:
        if isinstance(capacity, bool) or not isinstance(capacity, (int, np.integer)) or capacity < 1:
            raise InvalidParameterError("capacity", capacity, "an integer >= 1")
        if isinstance(n_points, bool) or not isinstance(n_points, (int, np.integer)) or n_points < 1:
            raise InvalidParameterError("n_points", n_points, "an integer >= 1")
        shapes = dict(signals or {})
        for name, shape in shapes.items():
            if not (isinstance(name, str) and name and isinstance(shape, tuple)):
                raise InvalidParameterError(
                    "signals", f"{name!r}: {shape!r}", "non-empty names mapped to shape tuples"
                )
        self.feature_target = as_array(feature_target, "feature_target", (None,)).copy()
        self.camera_pose_target = as_pose(camera_pose_target, "camera_pose_target").copy()
        self.metadata = normalise_metadata(metadata)
        self.signal_names = tuple(shapes)
        capacity, m, n = int(capacity), self.feature_target.shape[0], int(n_points)
        self._tick = {
            "t": np.empty(capacity),
            "camera_pose": np.empty((capacity, 4, 4)),
            "features": np.empty((capacity, m)),
            "visible": np.empty((capacity, n), dtype=bool),
        }
        self._signals = [np.empty((capacity, *shape)) for shape in shapes.values()]
        self._shapes = list(shapes.values())
        self._n = 0
        # The frame log is appended to lists (a list append costs a tenth of a numpy row write)
        # and stacked in `result`: a frame's features and visibility are new arrays every frame
        # (the sensor's), so keeping references is safe.
        self._frames: tuple[list[float], list[Any], list[Any], list[float]] = ([], [], [], [])

    def __len__(self) -> int:
        return self._n

    @staticmethod
    def estimate_bytes(
        n_rows: int, n_frames: int, n_features: int, n_points: int, signals: Mapping[str, tuple[int, ...]]
    ) -> float:
        """Peak memory [bytes] of recording ``n_rows`` tick samples and ``n_frames`` camera frames.

        Tick buffers (time, 4x4 pose, features, visibility, every signal) are counted twice
        (:meth:`result` copies them); each frame costs its features and visibility as arrays
        with their object headers and list slots (about 300 bytes besides the data) and once
        more when :meth:`result` stacks them.
        """
        row = 8.0 * (1 + 16 + n_features) + n_points + sum(8.0 * math.prod(s) for s in signals.values())
        frame = 2.0 * (8.0 * n_features + n_points) + 300.0
        return 2.0 * float(n_rows) * row + float(n_frames) * frame

    def record(
        self, t: float, camera_pose: np.ndarray, features: np.ndarray, visible: Any, values: Sequence[Any]
    ) -> None:
        """Append one tick sample; ``values`` are the signals of ``signal_names``, in order (copied).

        Raises:
            InvalidParameterError: not one value per signal.
            InvalidArrayError: a value whose shape is not the signal's (no silent broadcast).
        """
        i = self._n
        tick = self._tick
        if i == tick["t"].shape[0]:
            for name, buf in tick.items():
                tick[name] = np.concatenate([buf, np.empty_like(buf)])
            self._signals = [np.concatenate([buf, np.empty_like(buf)]) for buf in self._signals]
        if len(values) != len(self._signals):
            raise InvalidParameterError(
                "values", f"{len(values)} signals", f"one per name of {self.signal_names}"
            )
        tick["t"][i] = t
        tick["camera_pose"][i] = camera_pose
        tick["features"][i] = features
        tick["visible"][i] = visible
        for j, (buf, shape, value) in enumerate(zip(self._signals, self._shapes, values)):  # noqa: B905
            if getattr(value, "shape", None) != shape and np.shape(value) != shape:  # cheap for arrays
                raise InvalidArrayError(
                    f"signal {self.signal_names[j]!r}",
                    f"a value of shape {np.shape(value)}",
                    f"shape {shape}",
                )
            buf[i] = value
        self._n = i + 1

    def record_frame(self, t: float, features: np.ndarray, visible: Any, update_time: float) -> None:
        """Append one camera frame: capture time [s], features, visibility, control-update time [s].

        ``features`` and ``visible`` are kept by reference until :meth:`result`: pass arrays
        that are not modified afterwards (the sensor makes new ones every frame).
        """
        frame_t, frame_features, frame_visible, update_times = self._frames
        frame_t.append(t)
        frame_features.append(features)
        frame_visible.append(visible)
        update_times.append(update_time)

    def result(
        self, *, status: str = "complete", extra_metadata: dict[str, Any] | None = None
    ) -> SimulationResult:
        """The samples recorded so far as a :class:`SimulationResult` (which copies them).

        Args:
            status: One of :data:`~.results.STATUSES`, stored as ``metadata["status"]``.
            extra_metadata: Merged over the recorder's metadata (e.g. the error message).
        """
        if status not in STATUSES:
            raise InvalidParameterError("status", status, " or ".join(repr(s) for s in STATUSES))
        n = self._n
        frame_t, frame_features, frame_visible, update_times = self._frames
        m, n_features, n_points = len(frame_t), self.feature_target.shape[0], self._tick["visible"].shape[1]
        metadata = {**self.metadata, **normalise_metadata(extra_metadata), "status": status}
        return SimulationResult(
            **{name: buf[:n] for name, buf in self._tick.items()},
            feature_target=self.feature_target,
            camera_pose_target=self.camera_pose_target,
            signals={name: buf[:n] for name, buf in zip(self.signal_names, self._signals, strict=True)},
            frame_t=np.array(frame_t, dtype=float),
            frame_features=np.array(frame_features, dtype=float).reshape(m, n_features),
            frame_visible=np.array(frame_visible, dtype=bool).reshape(m, n_points),
            update_time=np.array(update_times, dtype=float),
            metadata=metadata,
        )
