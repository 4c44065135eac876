"""Refuse work whose arrays would not fit in memory, before allocating them.

A simulation records every tick (``duration * joint_rate_hz / record_every`` samples); a
duration of 1e12 s would ask numpy for petabytes and die with a raw ``MemoryError`` (or,
below the physical memory but above what is free, push the machine into swap). The caller
estimates the size of what it is about to allocate and calls :func:`fits_in_memory`, which
raises an :class:`~ibvs_youla.exceptions.InvalidParameterError` naming the argument that sets
the size, the estimate, the memory available and what reduces it.
"""

from __future__ import annotations

import math
import os
from typing import Any

from .exceptions import InvalidParameterError

__all__ = ["available_memory", "fits_in_memory", "size_text"]

_SMALL_BYTES = 256 * 2**20  # below this a size is not worth a system call


def fits_in_memory(n_bytes: float, name: str, value: Any, remedy: str) -> None:
    """Refuse, before allocating, work whose arrays need more memory than the machine has.

    The limit is the memory available now (Linux ``MemAvailable``; elsewhere the physical
    memory), so a run refused here would have died with a ``MemoryError`` or sent the machine
    into swap.

    Args:
        n_bytes: Estimated size of the arrays [bytes].
        name: The argument that sets the size (``"duration"``).
        value: Its value.
        remedy: What reduces the size, e.g. ``"a shorter duration or a larger record_every"``.

    Raises:
        InvalidParameterError: naming ``name``, the estimated size, the memory available and the remedy.
    """
    if n_bytes <= _SMALL_BYTES:  # no need to ask the system (False for NaN)
        return
    available = available_memory()
    if not n_bytes <= available:  # NaN or inf (an overflowed estimate) is refused too
        need = f"about {size_text(n_bytes)}" if math.isfinite(n_bytes) else "more than any memory"
        raise InvalidParameterError(
            name,
            value,
            f"a value whose arrays fit in memory: this one needs {need}, "
            f"{size_text(available)} are available; use {remedy}",
        )


def available_memory() -> float:
    """Memory available to this process now [bytes]: Linux ``MemAvailable``, else physical memory."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except (OSError, ValueError, IndexError):
        pass
    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):  # no sysconf (Windows): no limit known
        return math.inf


def size_text(n_bytes: float) -> str:
    """A size in bytes for a message: ``"7.11 PB"``, ``"512 MB"``."""
    if not math.isfinite(n_bytes):
        return "an unbounded size"
    for unit, size in (("EB", 2**60), ("PB", 2**50), ("TB", 2**40), ("GB", 2**30), ("MB", 2**20)):
        if n_bytes >= size:
            x = n_bytes / size
            return f"{x:.0f} {unit}" if 1000 <= x < 1e6 else f"{x:.3g} {unit}"
    return f"{n_bytes:.3g} bytes"
