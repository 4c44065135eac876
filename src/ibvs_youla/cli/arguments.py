"""The value types of the command line's arguments (argparse ``type=`` functions), each light.

Each turns one argument's text into a value or raises ``argparse.ArgumentTypeError`` with what
was received and what is valid; argparse then reports ``argument --flag: ...`` (exit 2). They
import nothing heavy, so that a bad value is refused at once: names are checked against
:mod:`ibvs_youla.catalog`, and what only the library can check (a robustness axis's values, a
method's parameters beyond its name) is checked when the command turns its arguments into
objects (still exit 2, see :mod:`ibvs_youla.cli`).
"""

from __future__ import annotations

import argparse
import difflib
import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from .. import catalog

__all__ = [
    "axes_pair",
    "count",
    "folder_path",
    "locked_joint",
    "method_list",
    "name_list",
    "non_negative",
    "positive",
    "scheduler_address",
    "seed",
    "suggestion",
    "transform",
    "transform_matrix",
    "value_list",
]

SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")  # Dask's network protocols with a host and port


def suggestion(word: str, valid: Sequence[str]) -> str:
    """``"; did you mean 'x'?"`` for the valid word nearest ``word`` (difflib), or ``""`` if none is near."""
    close = difflib.get_close_matches(word, list(valid), n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return math.nan


def positive(text: str) -> float:
    """A finite number > 0."""
    value = _number(text)
    if not (value > 0.0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"received {text!r}; valid values are finite numbers > 0")
    return value


def non_negative(text: str) -> float:
    """A finite number >= 0."""
    value = _number(text)
    if not (value >= 0.0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"received {text!r}; valid values are finite numbers >= 0")
    return value


def count(low: int) -> Callable[[str], int]:
    """The type of an integer >= ``low``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = low - 1
        if value < low:
            raise argparse.ArgumentTypeError(f"received {text!r}; valid values are integers >= {low}")
        return value

    return parse


def seed(text: str) -> int:
    """``--seed``: an integer >= 0."""
    return count(0)(text)


def folder_path(text: str) -> Path:
    """``--out DIR``: a folder that exists, or that can be created (tried, then removed again).

    Refused, with the reason: an existing file, a path below a file, a folder that is not
    writable, a folder that the system refuses to create (``/proc/foo``: no such file or
    directory; a read-only file system; a permission). Nothing is left behind: the folders
    created to try are removed, so a run refused later leaves no empty folder.
    """
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(
            f"received {text!r}, an existing file; valid values are a folder, existing or to be created"
        )
    missing = []
    ancestor = path.absolute()
    while not ancestor.exists() and ancestor != ancestor.parent:
        missing.append(ancestor)
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise argparse.ArgumentTypeError(
            f"received {text!r}: {str(ancestor)!r} is a file, so no folder can be created below it"
        )
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise argparse.ArgumentTypeError(f"received {text!r}: the folder {str(ancestor)!r} is not writable")
    created = []
    try:
        for folder in reversed(missing):
            try:
                folder.mkdir()
            except FileExistsError:
                if folder.is_dir():  # another process made it meanwhile (two runs started together)
                    continue
                raise
            created.append(folder)
    except OSError as err:
        reason = err.strerror or type(err).__name__
        raise argparse.ArgumentTypeError(
            f"received {text!r}: the output folder cannot be created ({reason}: {err.filename})"
        ) from None
    finally:
        for folder in reversed(created):
            try:
                folder.rmdir()
            except OSError:  # another process wrote into it meanwhile: its folder now, left to it
                pass
    return path


def name_list(valid: Sequence[str], what: str = "names") -> Callable[[str], tuple[str, ...]]:
    """The type of ``a,b,c``: names from ``valid``, comma-separated, each once (in the order given)."""

    def parse(text: str) -> tuple[str, ...]:
        names = tuple(n.strip() for n in text.split(","))
        unknown = [n for n in names if n not in valid]
        if unknown or len(set(names)) != len(names):
            problem = (
                f"unknown {', '.join(repr(n) for n in unknown)}{suggestion(unknown[0], valid)}"
                if unknown
                else "a name given twice"
            )
            raise argparse.ArgumentTypeError(
                f"received {text!r} ({problem}); valid: comma-separated {what}, each once, "
                f"from {', '.join(valid)}"
            )
        return names

    return parse


def method_list(text: str) -> tuple[str, ...]:
    """``--controllers a,b[k=v],...``: labels of the package's controllers, each once."""
    from ..campaign.spec import parse_method, split_methods  # the label syntax's one parser (numpy only)
    from ..exceptions import InvalidParameterError

    labels = tuple(split_methods(text))
    valid = catalog.CONTROLLERS
    try:
        unknown = [label for label in labels if parse_method(label)[0] not in valid]
    except InvalidParameterError as err:
        raise argparse.ArgumentTypeError(f"received {text!r}; {' '.join(str(err).split())}") from None
    if unknown or len(set(labels)) != len(labels):
        what = (
            f"unknown {', '.join(repr(n) for n in unknown)}{suggestion(unknown[0], valid)}"
            if unknown
            else "a method given twice"
        )
        raise argparse.ArgumentTypeError(
            f"received {text!r} ({what}); valid: comma-separated methods, each once, a name from "
            f"{', '.join(valid)}, optionally with parameters as name[key=value,...], e.g. fb[adaptive=false]"
        )
    return labels


def scheduler_address(text: str) -> str:
    """``--scheduler``: ``[PROTOCOL://]HOST:PORT``, the port 1-65535 (reaching it is checked later)."""
    from urllib.parse import urlsplit

    parts = urlsplit(text if "://" in text else f"tcp://{text}")
    try:
        port = parts.port
    except ValueError as err:  # "Port out of range 0-65535", or not a number
        port, problem = None, str(err)
    else:
        problem = "no port" if port is None else "port 0"
    if (
        parts.scheme not in SCHEDULER_SCHEMES
        or not parts.hostname
        or port is None
        or port == 0
        or parts.path not in ("", "/")
    ):
        if parts.scheme not in SCHEDULER_SCHEMES:
            problem = f"protocol {parts.scheme!r}"
        elif not parts.hostname:
            problem = "no host"
        raise argparse.ArgumentTypeError(
            f"received {text!r} ({problem}); valid: a scheduler address [PROTOCOL://]HOST:PORT with PORT "
            f"from 1 to 65535 and PROTOCOL one of {', '.join(SCHEDULER_SCHEMES)}, e.g. tcp://127.0.0.1:8786"
        )
    return text


def value_list(text: str) -> tuple[str, ...]:
    """``--values v1,v2,...``: the raw values (the study checks them against its axis)."""
    values = tuple(v.strip() for v in text.split(",") if v.strip())
    if not values:
        raise argparse.ArgumentTypeError(f"received {text!r}; valid: one or more comma-separated values")
    return values


def axes_pair(text: str) -> tuple[str, str]:
    """``--axes a,b``: two different names of :data:`ibvs_youla.catalog.MAP_AXES`."""
    axes = tuple(a.strip() for a in text.split(","))
    if len(axes) != 2 or axes[0] == axes[1] or not set(axes) <= set(catalog.MAP_AXES):
        raise argparse.ArgumentTypeError(
            f"received {text!r}; valid: two different names, comma-separated, from "
            f"{', '.join(catalog.MAP_AXES)}"
        )
    return axes  # type: ignore[return-value]


def transform(text: str) -> tuple[float, ...]:
    """``--T-F-C``: ``X,Y,Z,RX,RY,RZ`` (translation [m], rotation vector [deg]) or 16 numbers row by row.

    Returns the 6 or 16 numbers; :func:`transform_matrix` makes the 4x4 transform of them once
    the arm is built (this module imports no numpy: ``--help`` answers at once).
    """
    values = tuple(_number(v) for v in text.split(","))
    if len(values) not in (6, 16) or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(
            f"received {text!r}; valid: X,Y,Z,RX,RY,RZ (translation [m], rotation vector [deg]) or the 16 "
            "entries of a 4x4 transform row by row, finite numbers"
        )
    return values


def transform_matrix(values: tuple[float, ...]) -> Any:
    """The 4x4 transform of :func:`transform`'s numbers (rotation vector by SciPy; a full 4x4 as given).

    A 4x4 given in full is checked for rigidity by the arm.
    """
    import numpy as np
    from scipy.spatial.transform import Rotation

    if len(values) == 16:
        return np.array(values, dtype=float).reshape(4, 4)
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(values[3:], degrees=True).as_matrix()
    T[:3, 3] = values[:3]
    return T


def locked_joint(text: str) -> tuple[str, float]:
    """``--locked-joint NAME=VALUE``: a joint name and a finite value [rad or m]."""
    name, sep, value = text.partition("=")
    number = _number(value)
    if not sep or not name.strip() or not math.isfinite(number):
        raise argparse.ArgumentTypeError(
            f"received {text!r}; valid: NAME=VALUE, a joint of the robot and a finite number [rad or m], "
            "e.g. panda_joint7=0.785"
        )
    return name.strip(), number
