"""The progress bar of a run, and one line while Numba compiles the kernels for the first time.

A first run on a fresh install compiles the simulator's kernels (Numba, ``ibvs_youla._jit``)
before and during its first ticks: 20-80 s on this project's 2-core machine, in which the bar
would sit at 0 % and then estimate the whole run from a rate that includes the compilation.
With ``simulate(..., progress=True)`` (the command line always shows progress):

* the first time Numba starts compiling one of them in the process, one line goes to stderr,
  :data:`COMPILE_MESSAGE`. It is Numba's own ``numba:compile`` event that triggers it, which
  Numba fires only when a kernel is compiled, not when it is loaded from its cache: a warm
  cache prints nothing;
* when a compilation ends, the bar's clock restarts (``tqdm.unpause``), so its rate and
  estimate count the ticks only.
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["COMPILE_MESSAGE", "CompileNotice", "announces_compiles", "progress_bar"]

F = TypeVar("F", bound=Callable[..., Any])

COMPILE_MESSAGE = (
    "ibvs-youla: compiling the simulator's kernels, first run only (Numba caches them): "
    "about 20-80 s on 2 cores; the progress estimate starts after it"
)
_announced = False  # COMPILE_MESSAGE went out in this process
_active: CompileNotice | None = None  # the notice of the run with a progress bar, if any


class CompileNotice:
    """Listens to Numba's ``numba:compile`` events while a run with a progress bar is set up and runs.

    Attributes:
        bars: The progress bars to restart when a compilation ends.
        compiles: Compilations seen (outermost ones: a kernel compiling the kernels it calls is one).
    """

    def __init__(self, write: Callable[[str], None] | None = None) -> None:
        self.bars: list[Any] = []
        self.compiles = 0
        self._depth = 0
        self._write = write

    def on_start(self, event: Any = None) -> None:
        """A compilation starts: the message, the first time in this process."""
        global _announced
        if self._depth == 0:
            self.compiles += 1
            if not _announced:
                _announced = True
                (self._write or _stderr)(COMPILE_MESSAGE)
        self._depth += 1

    def on_end(self, event: Any = None) -> None:
        """A compilation ends: once the outermost one has, the bars' clocks restart."""
        self._depth -= 1
        if self._depth == 0:
            for bar in self.bars:
                bar.unpause()

    def __enter__(self) -> CompileNotice:
        global _active
        self._listener = _listener(self)
        if self._listener is not None:
            from numba.core import event

            event.register("numba:compile", self._listener)
        self._previous, _active = _active, self
        return self

    def __exit__(self, *exc: Any) -> None:
        global _active
        _active = self._previous
        if self._listener is not None:
            from numba.core import event

            event.unregister("numba:compile", self._listener)


def _stderr(text: str) -> None:
    from tqdm import tqdm

    tqdm.write(text, file=sys.stderr)  # above a bar that is drawn, without breaking it


def _listener(notice: CompileNotice) -> Any:
    """A Numba event listener calling ``notice``, or None without Numba."""
    try:
        from numba.core import event
    except ImportError:
        return None

    class _Forward(event.Listener):  # type: ignore[misc]
        def on_start(self, ev: Any) -> None:
            notice.on_start(ev)

        def on_end(self, ev: Any) -> None:
            notice.on_end(ev)

    return _Forward()


def announces_compiles(fn: F) -> F:
    """Decorate ``simulate``: with ``progress=True``, a :class:`CompileNotice` spans the whole call."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        if kwargs.get("progress") is not True or _active is not None:
            return fn(*args, **kwargs)
        with CompileNotice():
            return fn(*args, **kwargs)

    return wrapper  # type: ignore[return-value]


def progress_bar(total: int, label: str) -> Any:
    """A tqdm bar of ``total`` ticks on stderr, restarted after each compilation of the run's notice."""
    from tqdm import tqdm

    bar = tqdm(total=total, unit="tick", desc=label, leave=False)
    if _active is not None:
        _active.bars.append(bar)
    return bar
