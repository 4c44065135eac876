"""What every subcommand shares: the program name, the usage error, one-line messages, --config, --out."""

from __future__ import annotations

import argparse
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

PROG = "ibvs-youla"


class UsageError(Exception):
    """A bad argument, option or configuration file: ``main`` prints one line and exits with 2.

    Attributes:
        usage: The usage of the command whose arguments were wrong (printed before the line), or
            None when it would not help (an error in a configuration file).
    """

    def __init__(self, message: str, usage: str | None = None) -> None:
        super().__init__(message)
        self.usage = usage


def one_line(err: BaseException) -> str:
    """The message of ``err`` with its whitespace (newlines included) collapsed to single spaces."""
    return " ".join(str(err).split())


def load_optional_config(path: Path | None, settings_preset: str = "default") -> Any:
    """The parsed ``--config`` TOML file, or None when the option was not given."""
    if path is None:
        return None
    from ..config import load_config

    return load_config(path, settings_preset=settings_preset)


def _flag_message(err: Any, args: argparse.Namespace, flags: Mapping[str, str]) -> str | None:
    """``argument --flag: received ...; valid values are ...`` for an error about a given flag, else None."""
    from ..exceptions import ConfigError

    flag = flags.get(getattr(err, "name", None))  # type: ignore[arg-type]
    given = None if flag is None else getattr(args, flag.lstrip("-").replace("-", "_"), None)
    if given is None or isinstance(err, ConfigError):  # a value from a TOML file names its key
        return None
    return f"argument {flag}: received {given!r}; valid values are {err.valid}"


@contextmanager
def argument_errors(args: argparse.Namespace, flags: Mapping[str, str]) -> Iterator[None]:
    """Report the library's refusal of an argument, while arguments become objects, as an argument error.

    Wraps a command's ``prepare`` (see :mod:`ibvs_youla.cli`): every error the library raises
    for a bad argument (an ``IbvsYoulaError`` that is also a ``ValueError``: an
    ``InvalidParameterError``, a ``ConfigError`` naming a key of the ``--config`` file, a
    scenario outside the joint limits) becomes a :class:`UsageError` (exit 2); one about a
    value given by a flag names the flag.

    Args:
        args: The parsed arguments.
        flags: Library argument name -> flag, e.g. ``{"duration": "--duration"}``; the flag's
            ``dest`` is its name without dashes, with ``-`` turned into ``_``.
    """
    from ..exceptions import IbvsYoulaError, InvalidParameterError

    try:
        yield
    except IbvsYoulaError as err:
        if not isinstance(err, ValueError):
            raise
        message = _flag_message(err, args, flags) if isinstance(err, InvalidParameterError) else None
        raise UsageError(message or one_line(err)) from err


@contextmanager
def flag_errors(
    args: argparse.Namespace, flags: Mapping[str, str], config_keys: Mapping[str, str] | None = None
) -> Iterator[None]:
    """While a command runs, report the library's refusal of a value the user gave as an argument error.

    For the checks the library makes only when it runs (e.g. whether a ``--duration`` fits in
    memory, ``--cases`` too many to draw), so that they exit 2 like every argument error.

    Args:
        args: The parsed arguments.
        flags: Library argument name -> flag (as in :func:`argument_errors`).
        config_keys: Library argument name -> where its value came from when the ``--config``
            file gave it, e.g. ``{"duration": "run.duration in run.toml"}``.

    Raises:
        UsageError: from an ``InvalidParameterError`` whose name maps to a flag that was given,
            or to a key of the configuration file (exit 2); other errors pass unchanged.
    """
    from ..exceptions import InvalidParameterError

    try:
        yield
    except InvalidParameterError as err:
        message = _flag_message(err, args, flags)
        where = (config_keys or {}).get(err.name)
        if message is None and where is not None:
            message = f"{where}: received {err.value!r}; valid values are {err.valid}"
        if message is None:
            raise
        raise UsageError(message) from err
