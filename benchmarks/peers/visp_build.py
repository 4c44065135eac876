"""Build and run a ViSP C++ harness of benchmarks/peers/ (generic: any single-file harness).

ViSP is a peer, never a dependency: Debian's ``libvisp-dev`` (3.5.0; ``apt-get install -y
libvisp-dev`` as root) provides ``pkg-config visp``. :func:`build` compiles one ``.cpp`` of this
folder with ``g++ -O2`` and the flags ``pkg-config --cflags --libs visp`` gives, into a cache
folder keyed by the source's and the flags' hash (rebuilt only when either changes; binaries are
not committed). :class:`Harness` runs it as a line protocol: one request line on stdin, one answer
line on stdout (the harness defines its requests; see its header comment).

    >>> harness = Harness(build("visp_features.cpp"))  # doctest: +SKIP
    >>> harness.ask("polar 1 0.1 0.2 1.5")  # doctest: +SKIP
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

__all__ = ["HERE", "Harness", "PeerUnavailable", "build", "visp_version"]

HERE = Path(__file__).resolve().parent
CACHE = Path(os.environ.get("IBVS_YOULA_PEER_CACHE", Path(tempfile.gettempdir()) / "ibvs-youla-peers"))


class PeerUnavailable(RuntimeError):
    """The peer cannot be built here (no compiler, no ViSP), with what is missing and how to install it."""


def _pkg_config(*args: str) -> str:
    if shutil.which("pkg-config") is None:
        raise PeerUnavailable("pkg-config not found: apt-get install -y pkg-config libvisp-dev")
    done = subprocess.run(["pkg-config", *args, "visp"], capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise PeerUnavailable(
            f"pkg-config has no visp ({done.stderr.strip()}): apt-get install -y libvisp-dev"
        )
    return done.stdout.strip()


def visp_version() -> str:
    """ViSP's version as pkg-config reports it (e.g. ``3.5.0``)."""
    return _pkg_config("--modversion")


def build(source: str | Path, cache: Path = CACHE) -> Path:
    """The executable of one harness source (a file name in this folder or a path), built if needed.

    Raises:
        PeerUnavailable: no g++, no pkg-config or no ViSP.
        subprocess.CalledProcessError: the source does not compile (g++'s messages on stderr).
    """
    source = Path(source) if Path(source).is_absolute() else HERE / source
    if shutil.which("g++") is None:
        raise PeerUnavailable("g++ not found: apt-get install -y g++")
    flags = _pkg_config("--cflags", "--libs").split()
    key = hashlib.sha256(source.read_bytes() + " ".join(flags).encode()).hexdigest()[:16]
    exe = cache / f"{source.stem}-{key}"
    if not exe.exists():
        cache.mkdir(parents=True, exist_ok=True)
        tmp = exe.with_name(exe.name + f".{os.getpid()}.tmp")
        subprocess.run(["g++", "-O2", "-o", str(tmp), str(source), *flags], check=True)
        os.replace(tmp, exe)
    return exe


class Harness:
    """A running harness: :meth:`ask` sends one request line and returns its answer's numbers."""

    def __init__(self, exe: Path) -> None:
        self.proc = subprocess.Popen([str(exe)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def ask(self, request: str) -> list[float]:
        """The numbers of the answer to ``request`` (its first word echoed back and dropped)."""
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(request + "\n")
        self.proc.stdin.flush()
        answer = self.proc.stdout.readline().split()
        if not answer:
            raise RuntimeError(f"the harness ended (exit code {self.proc.wait()}) on: {request[:60]}")
        return [float(v) for v in answer[1:]]

    def close(self) -> None:
        """End the harness (closing its stdin) and wait for it."""
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        self.proc.wait(timeout=30)

    def __enter__(self) -> Harness:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
