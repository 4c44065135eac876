"""Servo controllers by name: the one place a controller is registered.

``simulate()``, the command line, TOML configs and ``reproduce`` all resolve controller
names here. A controller module lists its entries in a ``REGISTRATIONS`` tuple of
``(name, factory, summary)``; adding a controller means adding its module to
``_BASELINES`` below (or one :func:`register` call at run time).

The paper's controllers ("fb", "ff+fb") command joint positions; the methods the paper
compares itself with command a camera twist and run on every plant: classical IBVS with L
at the current, desired or mean features (Chaumette & Hutchinson 2006), PBVS, 2.5-D visual
servoing (Malis, Chaumette & Boudet 1999), hybrid switched IBVS/PBVS (Gans & Hutchinson
2007) and MPC-IBVS (a QP per frame through qpsolvers); and the field's answers to the
retreat and the local minima of point IBVS: polar-coordinate IBVS (Iwatsuki & Okiyama 2005)
XY/Z-partitioned IBVS (Corke & Hutchinson 2001) and image-moment IBVS (Tahri & Chaumette
2005); and photometric visual servoing (Collewet & Marchand 2011: the luminance of every pixel,
on a scenario with a textured scene).

>>> from ibvs_youla import controllers
>>> controllers.names()  # doctest: +NORMALIZE_WHITESPACE
('fb', 'ff+fb', 'ibvs-current', 'ibvs-desired', 'ibvs-mean', 'pbvs', '2.5d', 'hybrid', 'mpc-ibvs',
 'ibvs-polar', 'ibvs-partitioned', 'ibvs-moments', 'photometric')
>>> controllers.make("ff+fb", adaptive=False).command_type.value
'joint_position'
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .._validation import flag, text
from ..exceptions import InvalidParameterError
from .base import CameraFrame, CommandType, Controller, JointReading, ServoTask
from .youla import VARIANTS, YoulaController, YoulaSettings

__all__ = [
    "VARIANTS",
    "CameraFrame",
    "CommandType",
    "Controller",
    "JointReading",
    "ServoTask",
    "YoulaController",
    "YoulaSettings",
    "describe",
    "make",
    "names",
    "register",
    "uses_youla_settings",
]


@dataclass(frozen=True)
class _Entry:
    factory: Callable[..., Controller]
    summary: str
    youla_settings: bool  # takes ``adaptive`` and the YoulaSettings gains of SimulationSettings


_REGISTRY: dict[str, _Entry] = {}


def register(
    name: str, factory: Callable[..., Controller], summary: str, *, youla_settings: bool = False
) -> None:
    """Make ``factory(**params)`` available as ``make(name, **params)`` and ``simulate(controller=name)``.

    Args:
        name: Registry name, e.g. ``"ibvs-current"``; must be new.
        factory: Returns a fresh :class:`Controller` for keyword parameters.
        summary: One line for ``describe()`` and ``--help``.
        youla_settings: The factory accepts ``adaptive`` and the :class:`YoulaSettings`
            gains, which ``simulate`` then takes from its ``settings``.
    """
    if not isinstance(name, str) or not name or name in _REGISTRY:
        raise InvalidParameterError("name", name, f"a new non-empty name (taken: {', '.join(_REGISTRY)})")
    if not callable(factory):
        raise InvalidParameterError("factory", type(factory).__name__, "a callable returning a Controller")
    _REGISTRY[name] = _Entry(factory, text(summary, "summary"), flag(youla_settings, "youla_settings"))


def names() -> tuple[str, ...]:
    """Registered controller names, in registration order."""
    return tuple(_REGISTRY)


def describe() -> dict[str, str]:
    """Name -> one-line summary."""
    return {name: entry.summary for name, entry in _REGISTRY.items()}


def _entry(name: Any) -> _Entry:
    if not isinstance(name, str) or name not in _REGISTRY:
        raise InvalidParameterError(
            "controller", name, "a controller object or one of " + ", ".join(repr(n) for n in _REGISTRY)
        )
    return _REGISTRY[name]


def uses_youla_settings(name: str) -> bool:
    """True when the named controller takes ``adaptive`` and the paper's gains."""
    return _entry(name).youla_settings


def make(name: str, **params: Any) -> Controller:
    """A new controller by name, with its parameters.

    Raises:
        InvalidParameterError: unknown name, or a parameter the controller does not take
            (the message lists those it does).
    """
    entry = _entry(name)
    try:
        inspect.signature(entry.factory).bind(**params)
    except TypeError as exc:
        accepted = ", ".join(inspect.signature(entry.factory).parameters)
        raise InvalidParameterError(
            "params", sorted(params), f"parameters of {name!r}: {accepted} ({exc})"
        ) from None
    return entry.factory(**params)


def _youla(with_feedforward: bool) -> Callable[..., Controller]:
    def factory(adaptive: bool = True, settings: YoulaSettings | None = None, **gains: Any) -> Controller:
        return YoulaController(with_feedforward, adaptive, settings, **gains)

    return factory


register(
    "fb",
    _youla(False),
    f"the paper's controller, {VARIANTS['fb']}: SVD/Youla image loop (Eq. (53)-(62))",
    youla_settings=True,
)
register(
    "ff+fb",
    _youla(True),
    f"the paper's controller, {VARIANTS['ff+fb']} (Eq. (47)-(49), (53)-(62))",
    youla_settings=True,
)


# The modules of the methods the paper compares itself with, in registration order.
_BASELINES = (
    "ibvs",
    "pbvs",
    "two_half_d",
    "hybrid",
    "mpc_ibvs",
    "polar",
    "partitioned",
    "moments",
    "photometric",
)


def _register_baselines() -> None:
    import importlib

    for module_name in _BASELINES:
        module = importlib.import_module(f".{module_name}", __name__)
        for name, factory, summary in module.REGISTRATIONS:
            register(name, factory, summary)


_register_baselines()
