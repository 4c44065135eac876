"""What the servo loop accepts from a controller, and the typed errors naming it when it gets less.

A controller may be anyone's code (:class:`~ibvs_youla.controllers.Controller`), so every value
the loop takes from it is checked once where it enters, and every method that raises is
reported as :class:`~ibvs_youla.exceptions.ControllerError` naming the controller, the method
and the simulated time, the original exception chained:

* ``command_type``: a :class:`~ibvs_youla.controllers.CommandType` or its string value (the
  enum is a ``str`` enum, so ``"camera_twist"`` already compares equal to
  ``CommandType.CAMERA_TWIST``; it is parsed once, here);
* ``spec()``: a mapping of JSON-serialisable values (it is stored in the result);
* ``signals()``: a mapping from names to numeric arrays (bool, integer or float), the same
  names in the same order at every tick as at the first call, each value of the shape it had
  then (the recorder checks the shapes; this module names the controller when it fails).

What fails here is :class:`~ibvs_youla.exceptions.InvalidControllerOutputError`, both a
``ControllerError`` and an ``InvalidParameterError``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..controllers.base import CommandType
from ..exceptions import ControllerError, InvalidControllerOutputError, InvalidParameterError
from .results import normalise_metadata

__all__ = ["checked_signals", "checked_spec", "command_type_of", "controller_name", "failed"]

_SIGNALS_VALID = "a dict name -> numeric array of a fixed shape (bool, integer or float)"


def controller_name(controller: Any) -> str:
    """The class name of ``controller``, or of the one it wraps (a disturbance's wrapper)."""
    return type(getattr(controller, "controller", controller)).__name__


def failed(controller: Any, method: str, t: float, err: BaseException) -> ControllerError:
    """The typed error for ``controller.<method>()`` that raised ``err`` at time ``t`` [s] (chain err)."""
    return ControllerError(controller_name(controller), method, t, f"raised {type(err).__name__}: {err}")


def command_type_of(controller: Any) -> CommandType:
    """The controller's ``command_type`` as a CommandType (its string value is accepted).

    Raises:
        InvalidParameterError: no ``command_type``, or not one of the four command types; the
            name is ``"<Controller>.command_type"``.
    """
    name = f"{controller_name(controller)}.command_type"
    valid = " or ".join(repr(c.value) for c in CommandType)
    if not hasattr(controller, "command_type"):
        raise InvalidParameterError(name, None, valid)
    value = controller.command_type
    try:
        return CommandType.parse(value)
    except InvalidParameterError:
        raise InvalidParameterError(name, value, valid) from None


def checked_spec(controller: Any) -> dict[str, Any]:
    """``controller.spec()`` as a plain dict, or a typed error naming the controller.

    Raises:
        ControllerError: ``spec()`` raised (at t = 0 s, chained).
        InvalidControllerOutputError: it returned something other than a mapping of
            JSON-serialisable values.
    """
    try:
        spec = controller.spec()
    except Exception as err:
        raise failed(controller, "spec", 0.0, err) from err
    valid = "a dict of JSON-serialisable values (str keys; numbers, strings, lists, dicts, None)"
    if not isinstance(spec, Mapping):
        raise InvalidControllerOutputError(controller_name(controller), "spec", 0.0, _short(spec), valid)
    try:
        normalise_metadata(dict(spec))
    except InvalidParameterError as err:
        raise InvalidControllerOutputError(
            controller_name(controller), "spec", 0.0, _short(spec), f"{valid} ({err.valid})"
        ) from None
    return dict(spec)


def checked_signals(
    controller: Any,
    declared: Any,
    t: float,
    shapes: Mapping[str, tuple[int, ...]] | None = None,
) -> dict[str, Any]:
    """``declared`` (what ``controller.signals()`` returned at ``t``) if the loop can record it.

    Args:
        controller: The controller (for its name).
        declared: The returned value.
        t: Simulated time [s].
        shapes: Name -> shape of the first call's signals (None at the first call itself).

    Raises:
        InvalidControllerOutputError: not a mapping, a name that is not a non-empty string, a
            value that is not a numeric array, other names (or another order) than the first
            call's, or a value of another shape.
    """
    name = controller_name(controller)
    if not isinstance(declared, Mapping):
        raise InvalidControllerOutputError(name, "signals", t, _short(declared), _SIGNALS_VALID)
    for key, value in declared.items():
        if not (isinstance(key, str) and key):
            raise InvalidControllerOutputError(
                name, "signals", t, f"the name {key!r}", f"{_SIGNALS_VALID}: non-empty str names"
            )
        kind = _dtype_kind(value)
        if kind not in "biuf":
            raise InvalidControllerOutputError(
                name, "signals", t, f"{key!r}: {_short(value)}", _SIGNALS_VALID
            )
    if shapes is not None:
        if tuple(declared) != tuple(shapes):
            raise InvalidControllerOutputError(
                name,
                "signals",
                t,
                f"the names {list(declared)}",
                f"the names it declared first, {list(shapes)}",
            )
        for key, value in declared.items():
            if np.shape(value) != shapes[key]:
                raise InvalidControllerOutputError(
                    name,
                    "signals",
                    t,
                    f"{key!r} of shape {np.shape(value)}",
                    f"the shape it declared first, {shapes[key]}",
                )
    return dict(declared)


def _dtype_kind(value: Any) -> str:
    """The numpy dtype kind of ``value`` as an array (``"O"`` for what does not convert)."""
    try:
        return np.asarray(value).dtype.kind
    except (TypeError, ValueError):  # ragged sequences and the like
        return "O"


def _short(value: Any, limit: int = 120) -> str:
    """``repr(value)`` cut to ``limit`` characters (a message names what was received, not all of it)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."
