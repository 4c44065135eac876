"""Compiled kernels: Numba's ``njit`` with its on-disk cache, falling back gracefully (internal).

The simulator's per-frame and per-tick arithmetic (stereo projection, Eq. (62), the image
Jacobian, the SVD gains, the RK4 stages) runs as Numba-compiled functions, each the twin of a
plain Python/numpy reference that the tests pin it to (``tests/test_compiled_kernels.py``).
:func:`jit` compiles lazily, on the first call with each argument type, and keeps the machine
code in Numba's cache (``__pycache__`` beside the source, or ``NUMBA_CACHE_DIR``), so a later
process loads it in milliseconds instead of compiling again.

Fallbacks, so that nothing fails for want of a cache or a compiler:

* no writable cache directory (a read-only install without a writable ``NUMBA_CACHE_DIR`` or
  user cache): the kernels are compiled in memory, once per process;
* a cache write that fails later (disk full, a directory made read-only meanwhile): a warning,
  the compiled code is used all the same;
* ``NUMBA_DISABLE_JIT=1`` (Numba's own switch) or Numba not importable: the kernels run as
  plain Python, slower but with the same results.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["COMPILE_ERRORS", "jit", "jit_available"]

F = TypeVar("F", bound=Callable[..., Any])


def _compile_errors() -> tuple[type[Exception], ...]:
    try:
        from numba.core.errors import TypingError
    except ImportError:
        return (TypeError, ValueError, AttributeError)
    return (TypingError, TypeError, ValueError, AttributeError)


# What a compiled kernel raises for arguments of a type it was not written for (Numba's typing
# error; the interpreter's errors when the kernels run as plain Python): callers with a checked
# path take it then.
COMPILE_ERRORS = _compile_errors()


def jit_available() -> bool:
    """True when the kernels are compiled (Numba importable and not disabled by ``NUMBA_DISABLE_JIT``)."""
    try:
        from numba.core import config
    except ImportError:
        return False
    return not config.DISABLE_JIT


def jit(fn: F) -> F:
    """``numba.njit(cache=True)`` of ``fn``, or in-memory compilation, or ``fn`` itself (module docstring)."""
    try:
        import numba
    except ImportError:  # a dependency: only a broken install gets here; the reference Python runs
        return fn
    try:
        dispatcher = numba.njit(cache=True)(fn)
    except RuntimeError:  # "cannot cache function ...: no locator available": no writable cache directory
        return numba.njit(cache=False)(fn)  # type: ignore[no-any-return]
    _tolerate_failed_cache_writes(dispatcher)
    return dispatcher  # type: ignore[no-any-return]


def _tolerate_failed_cache_writes(dispatcher: Any) -> None:
    """Turn an OSError while saving compiled code into a warning (the code is compiled all the same).

    Numba checks that its cache directory is writable when the dispatcher is made, but lets an
    OSError of a later write propagate from the first call (outside Windows).
    """
    cache = getattr(dispatcher, "_cache", None)  # Numba's FunctionCache (a stable attribute since 0.24)
    save = getattr(cache, "save_overload", None)
    if save is None:
        return

    def save_or_warn(sig: Any, data: Any) -> None:
        try:
            save(sig, data)
        except OSError as err:
            warnings.warn(
                f"ibvs_youla: could not write Numba's cache for {dispatcher.__name__} ({err}); "
                "compiled in memory for this process",
                RuntimeWarning,
                stacklevel=2,
            )

    cache.save_overload = save_or_warn
