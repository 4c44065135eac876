"""What every subcommand shares: the program name, the usage error, one-line messages, --config, the arm."""

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


# the arm's options -> their flags (parser._add_arm_options)
ARM_FLAGS = {
    "robot": "--robot",
    "urdf": "--urdf",
    "camera_frame": "--camera-frame",
    "T_F_C": "--T-F-C",
    "locked_joints": "--locked-joint",
}


def arm_flags(args: argparse.Namespace) -> dict[str, Any]:
    """The arm options given by flags (``--robot``, ``--urdf``, ...), as ``config.make_arm`` takes them."""
    out: dict[str, Any] = {}
    for name in ARM_FLAGS:
        value = getattr(args, name, None)
        if value is not None:
            out[name] = dict(value) if name == "locked_joints" else str(value) if name == "urdf" else value
    return out


def resolve_arm(args: argparse.Namespace, cfg: Any = None) -> Any:
    """The arm of the flags over the ``--config`` file's ``[arm]`` (default: the IRB 4600).

    ``--robot`` or ``--urdf`` replaces the file's whole ``[arm]`` table (its mount and terms are
    another arm's); the mount flags alone override its keys.

    Raises:
        UsageError: the arm cannot be built from the flags (a URDF that cannot be loaded, a camera
            frame or locked joint it does not have: the message lists the candidates), naming the
            flag; an error of the file's ``[arm]`` is the ``ConfigError`` naming its key.
    """
    from ..config import arm_option_at_fault, make_arm
    from ..exceptions import IbvsYoulaError, ModelLoadError
    from .arguments import transform_matrix

    flags = arm_flags(args)
    if "T_F_C" in flags:
        flags["T_F_C"] = transform_matrix(flags["T_F_C"])
    file_options = {} if cfg is None else dict(cfg.arm_options)
    if "robot" in flags or "urdf" in flags:  # another arm: the file's [arm] (its mount, its terms) is not its
        file_options = {}
    from_file = sorted(set(file_options) - set(flags))
    options = {**file_options, **flags}
    try:
        return make_arm(options)
    except ModelLoadError as err:
        key = arm_option_at_fault(err, options)
        if key not in flags and cfg is not None:
            return cfg.make_arm(**flags)  # the file's key is at fault: its ConfigError names it
        raise UsageError(f"argument {ARM_FLAGS.get(key, '--robot')}: {one_line(err)}") from None
    except IbvsYoulaError as err:
        if not isinstance(err, ValueError):
            raise
        if cfg is not None and from_file:
            return cfg.make_arm(**flags)  # raises the ConfigError of the file's key, if it is one
        raise UsageError(f"arm ({', '.join(ARM_FLAGS[k] for k in flags)}): {one_line(err)}") from None


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
