"""Input checks shared by every module: types, shapes, finiteness, ranges, sizes.

Internal: public functions call these at their boundary so that bad input raises
an :class:`~ibvs_youla.exceptions.IbvsYoulaError` subclass with a message that
names the argument, what was received and what is valid, never a silent NaN.

The checks are cheap for input that is already valid: a float64 array of the right
shape costs a type, shape and one dot-product test (``x . x`` is finite exactly when
every entry is, unless it overflows, |x| > 1e154, and then the full test decides),
about 0.5 us; :func:`as_pose` checks rigidity in scalar arithmetic, about 2 us.
Anything else takes the full path, which converts and names what is wrong.

Scalars: a real number (:func:`real`, :func:`positive`, :func:`non_negative`) is an ``int``,
a ``float`` or a numpy real scalar, never a bool, a string or a complex number, whatever
``float()`` would make of them; an integer (:func:`integer`) is not a bool and not ``2.0``; a
flag (:func:`flag`) is ``True`` or ``False``, not ``"false"``; a choice (:func:`one_of`) is a
string. Each returns the validated value in its own type (``float(x)``, ``int(n)``), which the
caller stores.
"""

from __future__ import annotations

import math
import numbers
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


_REAL = (int, float, np.integer, np.floating)


def _real_or_none(value: Any) -> float | None:
    """``value`` as a float if it is a real number (numpy real scalars and 0-d arrays too), else None.

    bool, str, bytes, complex, None and sequences are not real numbers (``float()`` would accept
    ``True`` and ``"0.01"``, which is how a typo becomes a silent value).
    """
    if type(value) is float:  # the common case, first
        return value
    if (isinstance(value, (*_REAL, numbers.Real)) and not isinstance(value, (bool, np.bool_))) or (
        isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf"
    ):
        try:
            return float(value)
        except OverflowError:  # an int beyond the float range
            return math.inf
    return None


def real(
    value: Any,
    name: str,
    *,
    unit: str = "",
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
) -> float:
    """Return ``value`` as a float after checking it is a finite real number within the bounds.

    A real number is an ``int``, a ``float``, a numpy real scalar (or 0-d array) or any
    ``numbers.Real`` (a ``Fraction``); bool, str,
    complex and None are not, whatever ``float()`` would make of them.

    Args:
        value: The value received.
        name: Argument name used in the error message, as the user wrote it.
        unit: Unit appended to the bounds in the message, e.g. ``"s"``.
        low: Lower bound (``None``: unbounded below).
        high: Upper bound (``None``: unbounded above).
        low_open: Exclude ``low`` itself.
        high_open: Exclude ``high`` itself.

    Raises:
        InvalidParameterError: not a real number, not finite, or out of the bounds.
    """
    x = _real_or_none(value)
    if (
        x is not None
        and math.isfinite(x)
        and (low is None or x > low or (x == low and not low_open))
        and (high is None or x < high or (x == high and not high_open))
    ):
        return x
    raise InvalidParameterError(name, value, _range_text(unit, low, high, low_open, high_open))


def _range_text(unit: str, low: float | None, high: float | None, low_open: bool, high_open: bool) -> str:
    u = f" {unit}" if unit else ""
    if low is not None and high is not None:
        return f"a number in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}{u}"
    if low is not None:
        return f"a finite number {'>' if low_open else '>='} {low:g}{u}"
    if high is not None:
        return f"a finite number {'<' if high_open else '<='} {high:g}{u}"
    return f"a finite number [{unit}]" if unit else "a finite number"


def positive(value: Any, name: str, *, unit: str = "") -> float:
    """Return ``value`` as a float after checking it is a finite real number > 0 (see :func:`real`)."""
    if type(value) is float and 0.0 < value < math.inf:  # fast path
        return value
    return real(value, name, unit=unit, low=0.0, low_open=True)


def non_negative(value: Any, name: str, *, unit: str = "") -> float:
    """Return ``value`` as a float after checking it is a finite real number >= 0 (see :func:`real`)."""
    if type(value) is float and 0.0 <= value < math.inf:  # fast path
        return value
    return real(value, name, unit=unit, low=0.0)


def integer(value: Any, name: str, *, low: int | None = None, high: int | None = None, unit: str = "") -> int:
    """Return ``value`` as an int after checking it is an integer (not a bool, not 2.0) within the bounds.

    Raises:
        InvalidParameterError: not an ``int`` or numpy integer, or out of ``[low, high]``.
    """
    if (
        isinstance(value, (int, np.integer))
        and not isinstance(value, bool)
        and (low is None or value >= low)
        and (high is None or value <= high)
    ):
        return int(value)
    u = f" {unit}" if unit else ""
    if low is not None and high is not None:
        valid = f"an integer in [{low}, {high}]{u}"
    elif low is not None:
        valid = f"an integer >= {low}{u}"
    else:
        valid = f"an integer{u}" if high is None else f"an integer <= {high}{u}"
    raise InvalidParameterError(name, value, valid)


def flag(value: Any, name: str) -> bool:
    """Return ``value`` as a bool after checking it is one (``True``, ``False`` or a numpy bool).

    ``"false"``, 0 and 1 are not flags: ``bool("false")`` is True.

    Raises:
        InvalidParameterError: anything else.
    """
    if value is True or value is False:
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    raise InvalidParameterError(name, value, "True or False")


def instance(value: Any, name: str, kind: type | tuple[type, ...], valid: str) -> Any:
    """Return ``value`` after checking ``isinstance(value, kind)``.

    Raises:
        InvalidParameterError: naming the type received and ``valid`` (e.g. ``"a StereoCamera"``).
    """
    if isinstance(value, kind):
        return value
    raise InvalidParameterError(name, type(value).__name__ if value is not None else None, valid)


def text(value: Any, name: str, *, empty: bool = True) -> str:
    """Return ``value`` after checking it is a string (non-empty unless ``empty``).

    Raises:
        InvalidParameterError: not a string, or empty when ``empty`` is False.
    """
    if isinstance(value, str) and (empty or value):
        return str(value)
    raise InvalidParameterError(name, value, "a string" if empty else "a non-empty string")


def is_pair(value: Any) -> bool:
    """Whether ``value`` is two entries, e.g. a tuple or a (2,) array (not a string; not ragged).

    ``np.shape`` of a ragged sequence such as ``(1.0, [2.0])`` raises numpy's ``ValueError``;
    here it is simply not a pair, so the caller raises its own error naming the argument.
    """
    if isinstance(value, str):
        return False
    try:
        return np.shape(value) == (2,)
    except ValueError:
        return False


def one_of(value: Any, name: str, choices: Sequence[str]) -> str:
    """Return ``value`` after checking it is a string among ``choices``.

    Raises:
        InvalidParameterError: not a string (a list or an array is never compared), or not a choice.
    """
    if not isinstance(value, str) or value not in choices:
        raise InvalidParameterError(name, value, " or ".join(repr(c) for c in choices))
    return str(value)


def keywords_checked(cls: Any) -> Any:
    """Class decorator: arguments its ``__init__`` cannot bind raise InvalidParameterError, not TypeError.

    A dataclass's generated ``__init__`` answers an unknown keyword (``Disturbances(foo=1)``), a
    missing required one or one too many positional arguments with a bare ``TypeError``; the
    decorated class names itself, what was wrong and its valid keywords. The binding is checked
    only when ``__init__`` raised TypeError (a correct call costs nothing), and a TypeError from
    inside a valid call (its ``__post_init__``) passes through as it was.
    """
    import functools
    import inspect

    init = cls.__init__
    signature = inspect.signature(init)
    params = list(signature.parameters.values())[1:]
    valid = ", ".join(p.name for p in params)
    required = [p.name for p in params if p.default is inspect.Parameter.empty]

    @functools.wraps(init)
    def checked(self: Any, *args: Any, **kwargs: Any) -> None:
        try:
            init(self, *args, **kwargs)
        except TypeError:
            try:
                signature.bind(self, *args, **kwargs)
            except TypeError:
                names = {p.name for p in params}
                unknown = sorted(set(kwargs) - names)
                given = {p.name for p in params[: len(args)]} | set(kwargs)
                missing = [name for name in required if name not in given]
                if unknown:
                    received = f"unknown keywords {unknown}"
                elif missing:
                    received = f"no {', '.join(missing)}"
                else:
                    received = f"{len(args)} positional arguments"
                needed = ", ".join(required) or "none"
                raise InvalidParameterError(
                    cls.__name__, received, f"keywords among {valid} (required: {needed})"
                ) from None
            raise

    cls.__init__ = checked
    return cls
