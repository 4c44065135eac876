"""Files that are whole or absent, and one writer per output folder.

Every file the library writes (results, run files, tables, figures, campaign data) goes
through :func:`atomic_write`: the content goes to a hidden temporary file in the same folder
(``.<name>.<32 hex digits>.tmp``), which is flushed to disk (``fsync``) and then renamed
over the final name with :func:`os.replace` (atomic on POSIX and Windows), after which the
folder entry is flushed too. A reader therefore sees the previous file or the new one,
never a part of one, whatever kills the writer; a killed writer leaves at most a temporary
file, which :func:`remove_temporaries` deletes (call it while holding the folder's lock) and
which readers that list ``*.npz`` or ``*.parquet`` never see.

:func:`folder_lock` makes a folder single-writer: the writer holds ``<folder>/.lock`` with an
exclusive ``flock`` (``msvcrt.locking`` on Windows) and writes its process id in it. A second
writer is refused at once with :class:`~ibvs_youla.exceptions.FolderLockedError` naming that
pid (it does not wait). Stale-lock rule: the operating system releases the lock when the
holder's process ends, however it ends (SIGKILL included), so a lock file left by a dead
process is free and the next writer takes it over; the pid in it is information only.

Test hook: when the environment variable ``IBVS_YOULA_WRITE_DELAY_S`` holds a number of
seconds, :func:`atomic_write` sleeps that long after the content has gone to the temporary
file and before it is renamed, so that a test can kill a writer in the middle of a write.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import time
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from .exceptions import FolderLockedError, InvalidParameterError

__all__ = [
    "LOCK_FILE",
    "WRITE_DELAY_ENV",
    "atomic_write",
    "folder_lock",
    "is_temporary",
    "remove_temporaries",
    "save_figure",
    "strict_json",
    "write_json",
    "write_text",
]

LOCK_FILE = ".lock"
WRITE_DELAY_ENV = "IBVS_YOULA_WRITE_DELAY_S"
_TEMPORARY = re.compile(r"^\..+\.[0-9a-f]{32}\.tmp$")


def is_temporary(name: str) -> bool:
    """Whether a file name is one of :func:`atomic_write`'s temporary files."""
    return _TEMPORARY.match(name) is not None


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike[str], mode: str = "wb") -> Iterator[IO[Any]]:
    """A stream whose content replaces ``path`` in one step when the block ends without error.

    Args:
        path: The final file; its folder must exist.
        mode: ``"wb"`` (bytes) or ``"w"`` (text, UTF-8).

    Yields:
        The open temporary file. If the block raises, it is deleted and ``path`` is untouched.

    Raises:
        InvalidParameterError: ``path`` is a folder, or its folder does not exist or cannot be
            written (the message names ``path`` and its folder, not the temporary file).
    """
    if mode not in ("wb", "w"):
        raise InvalidParameterError("mode", mode, "'wb' or 'w'")
    path = Path(path)
    if path.is_dir():
        raise InvalidParameterError("path", str(path), "a file to write (this is a folder)")
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    try:
        opened = open(tmp, mode, **({} if mode == "wb" else {"encoding": "utf-8"}))
    except OSError as err:  # named by the file asked for, not by the hidden temporary one
        folder = path.parent
        why = (
            f"its folder {folder} does not exist"
            if not folder.exists()
            else f"its folder {folder} is not a folder"
            if not folder.is_dir()
            else f"its folder {folder} cannot be written ({err.strerror})"
        )
        raise InvalidParameterError(
            "path", str(path), f"a file in a folder that exists and can be written: {why}"
        ) from None
    try:
        with opened as stream:
            yield stream
            _pause_for_tests()
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    _fsync_folder(path.parent)


def write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`atomic_write`); return the path."""
    with atomic_write(path, "w") as stream:
        stream.write(text)
    return Path(path)


def strict_json(value: Any) -> Any:
    """``value`` with every float that is not finite replaced by None, for strict JSON (RFC 8259).

    Python's ``json`` writes ``Infinity`` and ``NaN``, which strict parsers (JavaScript's
    ``JSON.parse``, jq) reject. Every JSON file the library writes says what its ``null`` means
    (typically "never": a time that never came, such as a settling time).
    """
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict_json(v) for v in value]
    return value


def write_json(path: str | os.PathLike[str], value: Any, **dumps_kwargs: Any) -> Path:
    """Write ``value`` as strict JSON (:func:`strict_json`, indented) atomically; return the path."""
    text = json.dumps(strict_json(value), allow_nan=False, **{"indent": 1, **dumps_kwargs})
    return write_text(path, text)


def save_figure(fig: Any, path: str | os.PathLike[str], **savefig_kwargs: Any) -> Path:
    """``fig.savefig`` to ``path`` atomically, in the format of its suffix (default PNG); return the path."""
    path = Path(path)
    with atomic_write(path) as stream:
        fig.savefig(stream, format=path.suffix.lstrip(".") or "png", **savefig_kwargs)
    return path


def remove_temporaries(folder: str | os.PathLike[str]) -> list[Path]:
    """Delete the temporary files that killed writers left in ``folder``; return them.

    Only while holding the folder's :func:`folder_lock`: another writer's temporary file is
    its work in progress.
    """
    folder = Path(folder)
    if not folder.is_dir():
        return []
    removed = []
    for entry in sorted(folder.iterdir()):
        if is_temporary(entry.name) and entry.is_file():
            with contextlib.suppress(FileNotFoundError):
                entry.unlink()
                removed.append(entry)
    return removed


@contextlib.contextmanager
def folder_lock(folder: str | os.PathLike[str]) -> Iterator[Path]:
    """Hold ``folder/.lock`` while the block runs (module docstring); yield the lock file.

    Raises:
        FolderLockedError: another process holds it (the message names its pid).
    """
    folder = Path(folder)
    lock = folder / LOCK_FILE
    fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        if not _try_lock(fd):
            raise FolderLockedError(folder, lock, _holder(fd))
        try:
            _rewrite(fd, f"{os.getpid()}\n")
            yield lock
        finally:
            _rewrite(fd, "")
            _unlock(fd)
    finally:
        os.close(fd)


def _rewrite(fd: int, text: str) -> None:
    os.ftruncate(fd, 0)
    os.lseek(fd, 0, os.SEEK_SET)
    os.write(fd, text.encode())


def _holder(fd: int) -> int | None:
    """The pid written in a lock file held by another process (None if unreadable or empty)."""
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        return int(os.read(fd, 32).decode().strip())
    except (OSError, ValueError):
        return None


def _try_lock(fd: int) -> bool:
    try:
        import fcntl
    except ImportError:  # Windows
        import msvcrt

        try:
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
        except OSError:
            return False
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    return True


def _unlock(fd: int) -> None:
    try:
        import fcntl
    except ImportError:  # Windows
        import msvcrt

        os.lseek(fd, 0, os.SEEK_SET)
        msvcrt.locking(fd, msvcrt.LK_UNLCK, 1)
        return
    fcntl.flock(fd, fcntl.LOCK_UN)


def _fsync_folder(folder: Path) -> None:
    """Flush a folder's entries (the rename) to disk; a no-op where folders cannot be opened."""
    if os.name != "posix":
        return
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _pause_for_tests() -> None:
    text = os.environ.get(WRITE_DELAY_ENV)
    if not text:
        return
    try:
        delay = float(text)
    except ValueError:
        delay = float("nan")
    if not delay >= 0.0:
        raise InvalidParameterError(WRITE_DELAY_ENV, text, "a number of seconds >= 0 (a test hook)")
    time.sleep(delay)
