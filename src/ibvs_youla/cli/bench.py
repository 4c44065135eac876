"""``ibvs-youla bench``: run the scripts in ``benchmarks/``, passing on the arguments after ``--``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..exceptions import IbvsYoulaError
from .base import UsageError

BENCHMARKS = {
    "outer": "bench_outer_loop",
    "simulation": "bench_simulation",
    "controllers": "bench_controllers",
    "campaign": "bench_campaign",
}


def _benchmarks_dir() -> Path:
    import ibvs_youla

    return Path(ibvs_youla.__file__).resolve().parents[2] / "benchmarks"


def run(args: argparse.Namespace, extra: list[str]) -> int:
    """Run the chosen benchmark scripts; return the largest exit code they returned."""
    import importlib.util

    folder = _benchmarks_dir()
    names = list(BENCHMARKS) if args.which == "all" else [args.which]
    missing = [f"{BENCHMARKS[n]}.py" for n in names if not (folder / f"{BENCHMARKS[n]}.py").is_file()]
    if missing:
        raise _BenchUnavailable(folder, missing)
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
            try:
                returned = module.main(argv)
            except SystemExit as exit_:  # the benchmark's own argparse rejected an argument
                if exit_.code in (0, None):
                    continue
                raise UsageError(f"bench: {module_name} rejected {' '.join(argv)}") from None
            if isinstance(returned, int) and not isinstance(returned, bool):
                code = max(code, returned)
    finally:
        sys.path.remove(str(folder))
    return code


class _BenchUnavailable(IbvsYoulaError):
    def __init__(self, folder: Path, missing: list[str]) -> None:
        super().__init__(
            f"bench needs {', '.join(missing)} in {folder} (the benchmarks ship with "
            "the repository, not the installed package: run from an editable install)"
        )
