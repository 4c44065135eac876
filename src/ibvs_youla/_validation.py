"""Input checks shared by every module: shapes, finiteness, scalar ranges.

Internal: public functions call these at their boundary so that bad input raises
an :class:`~ibvs_youla.exceptions.IbvsYoulaError` subclass with a message that
names the argument, what was received and what is valid, never a silent NaN.

The checks are cheap for input that is already valid: a float64 array of the right
shape costs a type, shape and one dot-product test (``x . x`` is finite exactly when
every entry is, unless it overflows, |x| > 1e154, and then the full test decides),
about 0.5 us; :func:`as_pose` checks rigidity in scalar arithmetic, about 2 us.
Anything else takes the full path, which converts and names what is wrong.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .exceptions import InvalidArrayError, InvalidParameterError

Shape = Sequence[int | None]


_FLOAT64 = np.dtype(np.float64)
_LAST_ROW = [0.0, 0.0, 0.0, 1.0]
_RIGID_TOL = 1e-6  # max |R^T R - I| and |det R - 1| of a rigid transform


def _fits(actual: tuple[int, ...], shape: Shape) -> bool:
    """True if ``actual`` matches ``shape`` (``None`` entries match any length)."""
    return len(actual) == len(shape) and all(s is None or s == d for s, d in zip(shape, actual, strict=True))


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
    if (
        type(value) is np.ndarray
        and value.dtype == _FLOAT64
        and (shape is None or value.shape == shape or _fits(value.shape, shape))
    ):
        if not finite:
            return value
        flat = value.ravel()
        if math.isfinite(flat.dot(flat)):  # NaN and inf propagate; an overflow falls through to the full test
            return value
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidArrayError(
            name,
            f"{type(value).__name__} that is not numeric ({exc})",
            "a numeric array" + (f" of shape {_shape_text(shape)}" if shape else ""),
        ) from None
    if shape is not None:
        if not _fits(arr.shape, shape):
            raise InvalidArrayError(name, f"an array of shape {arr.shape}", f"shape {_shape_text(shape)}")
    if finite and not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))
        where = ", ".join(str(tuple(int(i) for i in b)) for b in bad[:5])
        more = "" if len(bad) <= 5 else f" (+{len(bad) - 5} more)"
        raise InvalidArrayError(name, f"non-finite entries at {where}{more}", "finite values only")
    return arr


def as_pose(value: Any, name: str) -> np.ndarray:
    """Check a 4x4 homogeneous transform: finite, last row [0, 0, 0, 1], rotation in SO(3).

    Returns:
        The transform as a float64 (4, 4) array (``value`` itself when it already is one).

    Raises:
        InvalidArrayError: if it is not a rigid transform (tolerance 1e-6 on R^T R = I, det R = 1).
    """
    T = as_array(value, name, (4, 4))
    (a, b, c, _), (d, e, f, _), (g, h, i, _), last = T.tolist()
    if last == _LAST_ROW:  # fast path: R^T R - I and det R in scalar arithmetic
        err = max(  # columns of R: unit length, mutually orthogonal
            abs(a * a + d * d + g * g - 1.0),
            abs(b * b + e * e + h * h - 1.0),
            abs(c * c + f * f + i * i - 1.0),
            abs(a * b + d * e + g * h),
            abs(a * c + d * f + g * i),
            abs(b * c + e * f + h * i),
        )
        det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
        if err <= 0.5 * _RIGID_TOL and abs(det - 1.0) <= 0.5 * _RIGID_TOL:  # well inside the bound
            return T
    R = T[:3, :3]
    if not np.allclose(T[3], _LAST_ROW, atol=1e-9):
        raise InvalidArrayError(name, f"last row {T[3].tolist()}", "last row [0, 0, 0, 1]")
    err = np.abs(R.T @ R - np.eye(3)).max()
    det = np.linalg.det(R)
    if err > _RIGID_TOL or abs(det - 1.0) > _RIGID_TOL:
        raise InvalidArrayError(
            name,
            f"a rotation block with max|R^T R - I| = {err:.2e} and det = {det:.6f}",
            "a rotation matrix (R^T R = I and det R = +1 within 1e-6)",
        )
    return T


def frequencies(value: Any, name: str, why: str = "") -> np.ndarray:
    """Flatten ``value`` to a non-empty 1-D array of frequencies > 0 [rad/s].

    Args:
        value: Frequencies, any shape.
        name: Argument name used in the error message.
        why: Reason appended to the message, e.g. ``"K has a pole at 0"``.

    Raises:
        InvalidArrayError: non-numeric or non-finite entries.
        InvalidParameterError: empty, or an entry <= 0.
    """
    w = as_array(value, name).reshape(-1)
    if w.size == 0 or np.any(w <= 0.0):
        valid = "one or more frequencies > 0 rad/s" + (f" ({why})" if why else "")
        raise InvalidParameterError(name, value, valid)
    return w


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
