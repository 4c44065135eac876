"""Recording a servo run: preallocated tick buffers and a frame log, turned into a result at any time.

:class:`ResultRecorder` fills a preallocated table one tick sample (one row) at a time
(amortised O(1): the table doubles when a run is longer than announced) and appends each
camera frame to its log. :meth:`ResultRecorder.result` copies what was recorded so far, so a
run that stops early (diverged, markers lost, interrupted) keeps every finished sample.

A row is [t, camera pose (16), features (m), visibility (n, as 0/1), each signal flattened].
:func:`record_row` writes one in a compiled call (:func:`ibvs_youla._jit.jit`) when every
part has its announced size; anything else takes the checked path of :meth:`ResultRecorder.record`,
which names the part whose shape is wrong (the reference the compiled call is pinned to).
A compiled loop writes rows itself: :meth:`ResultRecorder.reserve` gives it the table,
:meth:`ResultRecorder.advance` counts what it wrote, :meth:`ResultRecorder.record_frames` appends
its frame log.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from itertools import pairwise
from math import prod
from typing import Any

import numpy as np

from .._jit import COMPILE_ERRORS, jit
from .._validation import as_array, as_pose
from ..exceptions import InvalidArrayError, InvalidParameterError
from .results import STATUSES, SimulationResult, normalise_metadata

__all__ = ["ResultRecorder", "record_row"]


@jit
def record_row(
    table: np.ndarray,
    i: int,
    t: float,
    camera_pose: np.ndarray,
    features: np.ndarray,
    visible: np.ndarray,
    values: Any,
    sizes: np.ndarray,
) -> bool:
    """Write row i of ``table``: t, the pose, features, visibility and ``values`` (a tuple of arrays).

    ``sizes`` holds the sizes of features, visibility and each value; returns False, having
    possibly written part of the row, when a part has another size (the pose must be 4x4).
    """
    row = table[i]
    if camera_pose.shape[0] != 4 or camera_pose.shape[1] != 4 or features.size != sizes[0]:
        return False
    if visible.size != sizes[1] or len(values) != sizes.shape[0] - 2:
        return False
    row[0] = t
    c = 1
    for a in range(4):
        for b in range(4):
            row[c] = camera_pose[a, b]
            c += 1
    for x in features.flat:
        row[c] = x
        c += 1
    for x in visible.flat:
        row[c] = 1.0 if x else 0.0
        c += 1
    j = 2
    for value in values:
        if value.size != sizes[j]:
            return False
        for x in value.flat:
            row[c] = x
            c += 1
        j += 1
    return c == row.shape[0]


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
        self._shapes = list(shapes.values())
        sizes = [m, n, *(prod(shape) for shape in self._shapes)]
        # column slices of the table: t, pose, features, visible, then each signal
        edges = np.cumsum([0, 1, 16, *sizes]).tolist()
        self._columns = [slice(a, b) for a, b in pairwise(edges)]
        self._table = np.empty((capacity, edges[-1]))
        self._sizes = np.array(sizes, dtype=np.int64)
        self._compiled = all(len(shape) == 1 for shape in self._shapes)  # the fast path's values are 1-D
        self._n = 0
        # The frame log is appended to lists (a list append costs a tenth of a numpy row write)
        # and stacked in `result`: a frame's features and visibility are new arrays every frame
        # (the sensor's), so keeping references is safe.
        self._frames: tuple[list[float], list[Any], list[Any], list[float]] = ([], [], [], [])

    def __len__(self) -> int:
        return self._n

    @property
    def row_sizes(self) -> np.ndarray:
        """Sizes of a row's parts after t and the pose: features, visibility, each signal (record_row)."""
        return self._sizes

    def reserve(self, n_rows: int) -> np.ndarray:
        """The tick table, grown to hold ``n_rows`` samples after those recorded, for a compiled writer.

        The writer fills rows ``len(self)`` on with :func:`record_row` (``row_sizes``), then calls
        :meth:`advance`; the table it got is valid until the next :meth:`record` or :meth:`reserve`.
        """
        need = self._n + int(n_rows)
        if need > self._table.shape[0]:
            grown = np.empty((need, self._table.shape[1]))
            grown[: self._n] = self._table[: self._n]
            self._table = grown
        return self._table

    def advance(self, n_rows: int) -> None:
        """Count ``n_rows`` samples written into the table of :meth:`reserve`.

        Raises:
            InvalidParameterError: more rows than reserved, or fewer than none.
        """
        if not 0 <= n_rows <= self._table.shape[0] - self._n:
            raise InvalidParameterError(
                "n_rows", n_rows, f"0 to {self._table.shape[0] - self._n} (the rows reserved)"
            )
        self._n += int(n_rows)

    def record_frames(
        self, t: np.ndarray, features: np.ndarray, visible: np.ndarray, update_time: np.ndarray
    ) -> None:
        """Append m camera frames at once (``record_frame`` of each row).

        Times (m,) [s], features (m, n_features), visibility (m, n), update times (m,) [s]. The
        rows are kept by reference (as :meth:`record_frame`'s arrays): do not modify them after.
        """
        frame_t, frame_features, frame_visible, update_times = self._frames
        frame_t.extend(t.tolist())
        frame_features.extend(features)
        frame_visible.extend(visible)
        update_times.extend(update_time.tolist())

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
        if i == self._table.shape[0]:
            self._table = np.concatenate([self._table, np.empty_like(self._table)])
        if len(values) != len(self._shapes):
            raise InvalidParameterError(
                "values", f"{len(values)} signals", f"one per name of {self.signal_names}"
            )
        if self._compiled:
            try:
                values = values if type(values) is tuple else tuple(values)
                done = record_row(self._table, i, t, camera_pose, features, visible, values, self._sizes)
            except COMPILE_ERRORS:  # a part that is not an array (e.g. a float): checked below, always
                self._compiled = done = False
            if done:
                self._n = i + 1
                return
        self._record_checked(i, t, camera_pose, features, visible, values)
        self._n = i + 1

    def _record_checked(
        self, i: int, t: float, camera_pose: Any, features: Any, visible: Any, values: Sequence[Any]
    ) -> None:
        """Row i, part by part, each shape checked (what :func:`record_row` does in one call)."""
        row, columns = self._table[i], self._columns
        row[0] = t
        row[columns[1]] = np.reshape(camera_pose, 16)
        row[columns[2]] = features
        row[columns[3]] = visible
        for j, (shape, value) in enumerate(zip(self._shapes, values)):  # noqa: B905
            if getattr(value, "shape", None) != shape and np.shape(value) != shape:  # no silent broadcast
                raise InvalidArrayError(
                    f"signal {self.signal_names[j]!r}",
                    f"a value of shape {np.shape(value)}",
                    f"shape {shape}",
                )
            row[columns[4 + j]] = np.reshape(value, -1)

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
        m, n_features, n_points = len(frame_t), self.feature_target.shape[0], int(self._sizes[1])
        metadata = {**self.metadata, **normalise_metadata(extra_metadata), "status": status}
        table, columns = self._table[:n], self._columns
        return SimulationResult(
            t=table[:, 0],
            camera_pose=table[:, columns[1]].reshape(n, 4, 4),
            features=table[:, columns[2]],
            visible=table[:, columns[3]] != 0.0,
            feature_target=self.feature_target,
            camera_pose_target=self.camera_pose_target,
            signals={
                name: table[:, column].reshape(n, *shape)
                for name, column, shape in zip(self.signal_names, columns[4:], self._shapes, strict=True)
            },
            frame_t=np.array(frame_t, dtype=float),
            frame_features=np.array(frame_features, dtype=float).reshape(m, n_features),
            frame_visible=np.array(frame_visible, dtype=bool).reshape(m, n_points),
            update_time=np.array(update_times, dtype=float),
            metadata=metadata,
        )
