"""``ibvs-youla bench``: run the scripts in ``benchmarks/``, passing on the arguments after ``--``."""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..exceptions import IbvsYoulaError
from .base import UsageError

BENCHMARKS = {
    "outer": "bench_outer_loop",
    "simulation": "bench_simulation",
    "controllers": "bench_controllers",
    "campaign": "bench_campaign",
    "cli": "bench_cli",
}


def check_own_options(argv: list[str]) -> None:
    """Refuse a benchmark's option given before ``--`` with a message that says where it goes.

    Raises:
        UsageError: an option other than ``--json`` and ``--help`` among ``argv`` (the
            arguments of ``bench`` before ``--``).
    """
    stray = [a for a in argv if a.startswith("-") and a.split("=")[0] not in ("--json", "-h", "--help")]
    if stray:
        raise UsageError(
            f"bench: unrecognized arguments: {' '.join(stray)}; a benchmark's own options go after --, "
            f"e.g. ibvs-youla bench simulation -- {stray[0]} ..."
        )


def _benchmarks_dir() -> Path:
    import ibvs_youla

    return Path(ibvs_youla.__file__).resolve().parents[2] / "benchmarks"


def prepare(args: argparse.Namespace, extra: list[str]) -> Callable[[], int]:
    """Find the chosen benchmark scripts; return the function that runs them."""
    folder = _benchmarks_dir()
    names = list(BENCHMARKS) if args.which == "all" else [args.which]
    missing = [f"{BENCHMARKS[n]}.py" for n in names if not (folder / f"{BENCHMARKS[n]}.py").is_file()]
    if missing:
        raise _BenchUnavailable(folder, missing)
    return lambda: _run(args, extra, folder, names)


def _run(args: argparse.Namespace, extra: list[str], folder: Path, names: list[str]) -> int:
    """Run the benchmark scripts; return the largest exit code they returned."""
    import importlib.util

    if args.json is not None:
        args.json.mkdir(parents=True, exist_ok=True)
    code = 0
    sys.path.insert(0, str(folder))  # the scripts import their helpers (_timing) as top-level modules
    try:
        for name in names:
            module_name = BENCHMARKS[name]
            spec = importlib.util.spec_from_file_location(module_name, folder / f"{module_name}.py")
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            argv = [*extra] + (
                [] if args.json is None else ["--json", str(args.json / f"{module_name}.json")]
            )
            print(f"== {module_name} {' '.join(argv)}", flush=True)
            catcher = _UsageCatcher(sys.stderr)
            try:
                with contextlib.redirect_stderr(catcher):
                    returned = module.main(argv)
            except SystemExit as exit_:  # the benchmark's own argparse rejected an argument
                if exit_.code in (0, None):
                    continue
                raise UsageError(f"bench {name}: {catcher.error() or 'rejected ' + ' '.join(argv)}") from None
            finally:
                catcher.release()
            if isinstance(returned, int) and not isinstance(returned, bool):
                code = max(code, returned)
    finally:
        sys.path.remove(str(folder))
    return code


class _UsageCatcher(io.TextIOBase):
    """stderr for a benchmark: passes text through, but holds argparse's usage and error message.

    argparse writes ``usage: ...`` and then ``prog: error: message`` before exiting with 2;
    held, they become the one line of the command's usage error instead of three lines.
    """

    def __init__(self, stream: Any) -> None:
        self._stream = stream
        self._held: list[str] = []

    def write(self, text: str) -> int:
        if self._held or text.startswith("usage:"):
            self._held.append(text)
            return len(text)
        return self._stream.write(text)

    def flush(self) -> None:
        self._stream.flush()

    def error(self) -> str | None:
        """The message argparse wrote after ``error:``, if one was held."""
        for line in reversed("".join(self._held).splitlines()):
            if ": error: " in line:
                return line.split(": error: ", 1)[1].strip()
        return None

    def release(self) -> None:
        """Pass on what was held when it was not an argparse error (the benchmark ran)."""
        if self._held and self.error() is None:
            self._stream.write("".join(self._held))
        self._held = []


class _BenchUnavailable(IbvsYoulaError):
    def __init__(self, folder: Path, missing: list[str]) -> None:
        super().__init__(
            f"bench needs {', '.join(missing)} in {folder} (the benchmarks ship with "
            "the repository, not the installed package: run from an editable install)"
        )
