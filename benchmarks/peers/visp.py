"""Build and run a C++ harness against ViSP (Debian's ``libvisp-dev``), for any peer benchmark.

A harness is one C++ source file under ``benchmarks/peers/`` (it may include ``harness.h``, the
shared timing and JSON helpers). :func:`build` compiles it with ``g++ -O2`` and the flags
``pkg-config --cflags --libs visp`` gives, into a build folder outside the repository, keyed by the
source's and the header's hash (a changed source is built again; nothing is committed). A harness
talks one of two ways: it prints one JSON object (:func:`run` runs it and parses it), or it answers
request lines on standard input (:class:`Harness`, e.g. the feature harness of
``bench_peer_features.py``). The tutorial, image-moment and luminance harnesses all use this.

ViSP is installed with ``apt-get install -y libvisp-dev`` (as root); :func:`available` says which
version pkg-config finds, or why none.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
BUILD_DIR = Path(tempfile.gettempdir()) / "ibvs-youla-peers"
INSTALL_HINT = "apt-get install -y libvisp-dev pkg-config g++ (as root)"


def available() -> tuple[str | None, str]:
    """(ViSP's version, "") when pkg-config finds ViSP and g++ exists, else (None, the reason)."""
    if shutil.which("pkg-config") is None or shutil.which("g++") is None:
        return None, f"pkg-config or g++ not found: {INSTALL_HINT}"
    done = subprocess.run(["pkg-config", "--modversion", "visp"], capture_output=True, text=True)
    if done.returncode != 0:
        return None, f"pkg-config finds no ViSP ({done.stderr.strip()}): {INSTALL_HINT}"
    return done.stdout.strip(), ""


def build(source: str | Path, build_dir: Path = BUILD_DIR) -> Path:
    """The harness binary of ``source`` (a .cpp under peers/ or a path), built if absent or stale.

    Raises:
        RuntimeError: ViSP or the compiler is missing, or the build failed (g++'s output in the message).
    """
    version, why = available()
    if version is None:
        raise RuntimeError(why)
    src = Path(source) if Path(source).is_absolute() else HERE / source
    digest = hashlib.sha256(
        src.read_bytes() + (HERE / "harness.h").read_bytes() + version.encode()
    ).hexdigest()
    binary = build_dir / f"{src.stem}-{digest[:16]}"
    if binary.exists():
        return binary
    build_dir.mkdir(parents=True, exist_ok=True)
    flags = subprocess.run(
        ["pkg-config", "--cflags", "--libs", "visp"], capture_output=True, text=True, check=True
    ).stdout.split()
    partial = binary.with_name(f"{binary.name}.{os.getpid()}.tmp")  # two builds never share a file
    command = ["g++", "-O2", "-std=c++17", f"-I{HERE}", str(src), "-o", str(partial), *flags]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"building {src.name} failed:\n{' '.join(command)}\n{done.stderr[-4000:]}")
    os.replace(partial, binary)
    return binary


def run(binary: Path, *args: object, timeout: float = 600.0) -> dict[str, Any]:
    """Run a built harness with ``args`` and return the JSON object it prints.

    Raises:
        RuntimeError: it failed or printed no JSON (its output in the message).
    """
    done = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True, timeout=timeout)
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode != 0 or not lines:
        raise RuntimeError(f"{binary.name} failed (exit {done.returncode}): {done.stderr[-2000:]}")
    return json.loads(lines[-1])  # type: ignore[no-any-return]


class Harness:
    """A running line-protocol harness: :meth:`ask` sends a request line, returns the answer's numbers."""

    def __init__(self, binary: Path) -> None:
        self.proc = subprocess.Popen([str(binary)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def ask(self, request: str) -> list[float]:
        """The numbers of the answer to ``request`` (its first word echoed back and dropped)."""
        stdin, stdout = self.proc.stdin, self.proc.stdout
        if stdin is None or stdout is None:
            raise RuntimeError("the harness was started without pipes")
        stdin.write(request + "\n")
        stdin.flush()
        answer = stdout.readline().split()
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
