"""What every subcommand shares: the program name, the usage error, one-line messages, --config."""

from __future__ import annotations

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
