"""Input checks shared by every module: shapes, finiteness, scalar ranges.

Internal: public functions call these at their boundary so that bad input raises
an :class:`~ibvs_youla.exceptions.IbvsYoulaError` subclass with a message that
names the argument, what was received and what is valid, never a silent NaN.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .exceptions import InvalidArrayError, InvalidParameterError

Shape = Sequence[int | None]


def _shape_text(shape: Shape) -> str:
    return (
        "(" + ", ".join("n" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
    )


def as_array(value: Any, name: str, shape: Shape | None = None, *, finite: bool = True) -> np.ndarray:
    """Convert ``value`` to a float64 array and check its shape and finiteness.

    Args:
        value: Anything ``np.asarray`` accepts.
        name: Argument name used in the error message.
        shape: Expected shape; ``None`` entries match any length. ``None`` skips the check.
        finite: Reject NaN and infinite entries.

    Returns:
        The array, as float64 (a copy only when a conversion was needed).

    Raises:
        InvalidArrayError: wrong shape, non-numeric content, or non-finite entries.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidArrayError(
            name,
            f"{type(value).__name__} that is not numeric ({exc})",
            "a numeric array" + (f" of shape {_shape_text(shape)}" if shape else ""),
        ) from None
    if shape is not None:
        ok = arr.ndim == len(shape) and all(
            s is None or s == d for s, d in zip(shape, arr.shape, strict=False)
        )
        if not ok:
            raise InvalidArrayError(name, f"an array of shape {arr.shape}", f"shape {_shape_text(shape)}")
    if finite and not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))
        where = ", ".join(str(tuple(int(i) for i in b)) for b in bad[:5])
        more = "" if len(bad) <= 5 else f" (+{len(bad) - 5} more)"
        raise InvalidArrayError(name, f"non-finite entries at {where}{more}", "finite values only")
    return arr


def as_pose(value: Any, name: str) -> np.ndarray:
    """Check a 4x4 homogeneous transform: finite, last row [0, 0, 0, 1], rotation in SO(3).

    Raises:
        InvalidArrayError: if it is not a rigid transform (tolerance 1e-6 on R^T R = I, det R = 1).
    """
    T = as_array(value, name, (4, 4))
    R = T[:3, :3]
    if not np.allclose(T[3], [0.0, 0.0, 0.0, 1.0], atol=1e-9):
        raise InvalidArrayError(name, f"last row {T[3].tolist()}", "last row [0, 0, 0, 1]")
    err = np.abs(R.T @ R - np.eye(3)).max()
    det = np.linalg.det(R)
    if err > 1e-6 or abs(det - 1.0) > 1e-6:
        raise InvalidArrayError(
            name,
            f"a rotation block with max|R^T R - I| = {err:.2e} and det = {det:.6f}",
            "a rotation matrix (R^T R = I and det R = +1 within 1e-6)",
        )
    return T


def _bounded_below(value: Any, name: str, unit: str, strict: bool) -> float:
    valid = f"a finite number {'>' if strict else '>='} 0{(' ' + unit) if unit else ''}"
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(name, value, valid) from None
    if not np.isfinite(x) or x < 0.0 or (strict and x == 0.0):
        raise InvalidParameterError(name, value, valid)
    return x


def positive(value: Any, name: str, *, unit: str = "") -> float:
    """Return ``value`` as a float after checking it is finite and > 0."""
    return _bounded_below(value, name, unit, strict=True)


def non_negative(value: Any, name: str, *, unit: str = "") -> float:
    """Return ``value`` as a float after checking it is finite and >= 0."""
    return _bounded_below(value, name, unit, strict=False)


def one_of(value: Any, name: str, choices: Sequence[str]) -> str:
    """Check that ``value`` is one of ``choices`` (strings)."""
    if value not in choices:
        raise InvalidParameterError(name, value, " or ".join(repr(c) for c in choices))
    return value
