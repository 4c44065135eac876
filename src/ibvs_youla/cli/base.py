"""What every subcommand shares: the program name, the usage error, one-line messages, --config, --out."""

from __future__ import annotations

import argparse
import os
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

PROG = "ibvs-youla"


class UsageError(Exception):
    """Raised instead of argparse's print-usage-and-exit, so that main prints one line (exit 2)."""


def one_line(err: BaseException) -> str:
    """The message of ``err`` with its whitespace (newlines included) collapsed to single spaces."""
    return " ".join(str(err).split())


def load_optional_config(path: Path | None, settings_preset: str = "default") -> Any:
    """The parsed ``--config`` TOML file, or None when the option was not given."""
    if path is None:
        return None
    from ..config import load_config

    return load_config(path, settings_preset=settings_preset)


def folder_path(text: str) -> Path:
    """An argparse type for ``--out DIR``: a folder that exists or can be created (nothing is created).

    Refused (exit 2, one line): an existing file, a path below a file, a path whose nearest
    existing folder is not writable.
    """
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(
            f"received {text!r}, an existing file; valid values are a folder, existing or to be created"
        )
    ancestor = path.absolute()
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise argparse.ArgumentTypeError(
            f"received {text!r}: {str(ancestor)!r} is a file, so no folder can be created below it"
        )
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise argparse.ArgumentTypeError(f"received {text!r}: the folder {str(ancestor)!r} is not writable")
    return path


@contextmanager
def flag_errors(args: argparse.Namespace, flags: Mapping[str, str]) -> Iterator[None]:
    """Report a library error about a value the user gave by a flag as an argument error naming the flag.

    Args:
        args: The parsed arguments.
        flags: Library argument name -> flag, e.g. ``{"duration": "--duration"}``; the flag's
            ``dest`` is its name without dashes, with ``-`` turned into ``_``.

    Raises:
        UsageError: from an ``InvalidParameterError`` whose name maps to a flag that was given
            (exit 2); other errors pass unchanged (a value from a TOML file is a ConfigError).
    """
    from ..exceptions import ConfigError, InvalidParameterError

    try:
        yield
    except InvalidParameterError as err:
        flag = flags.get(err.name)
        given = None if flag is None else getattr(args, flag.lstrip("-").replace("-", "_"), None)
        if given is None or isinstance(err, ConfigError):
            raise
        raise UsageError(f"argument {flag}: received {given!r}; valid values are {err.valid}") from err
