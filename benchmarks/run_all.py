"""Regenerate every figure of ``benchmarks/README.md``: run the benchmarks, keep histories, rewrite tables.

One command, from the repository's root with an editable install:

    .venv/bin/python benchmarks/run_all.py            # every benchmark, its default size (~15-25 min)
    .venv/bin/python benchmarks/run_all.py --quick    # small sizes: checks the pipeline (~2 min)

Steps: (1) warm Numba's cache (compile or load every kernel once, so that no timing includes
it); (2) run ``bench_outer_loop``, ``bench_simulation``, ``bench_controllers``, ``bench_peers``
(ViSP 3.5 and MVTB-python on the same work: it builds its C++ harness and makes MVTB's venv),
``bench_batch`` (simulate_batch beside ViSP's C++ iteration), ``bench_campaign`` and ``bench_cli`` one
after the other, each writing ``reports/<name>.json`` (latest report at the top level, every run's
headline appended to its ``history``); (3) rewrite the generated blocks of ``README.md`` from the
reports (:mod:`figures`). A benchmark that fails is reported
and the others still run; its README block keeps the previous figures; the exit code is 1.
The load of the machine (load averages, and the cores other jobs used during each benchmark)
is in every report and printed at the end: figures taken while other jobs used a large share
of the cores should be taken again (``--only NAME`` runs one).
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
import traceback
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ORDER = ("outer_loop", "simulation", "controllers", "peers", "batch", "campaign", "cli")
QUICK = {
    "outer_loop": ["--configs", "20", "--repeats", "2", "--rebuilds", "2"],
    "simulation": ["--duration", "0.5", "--classical-duration", "4", "--repeats", "1"],
    "controllers": ["--configs", "10", "--repeats", "2"],
    "peers": [
        "--steps",
        "30",
        "--rounds",
        "1",
        "--ours-repeats",
        "2",
        "--visp-repeats",
        "3",
        "--mvtb-repeats",
        "1",
    ],
    "batch": [
        "--cases",
        "50",
        "--steps",
        "20",
        "--rounds",
        "1",
        "--visp-repeats",
        "3",
        "--monocular-cases",
        "5",
    ],
    "campaign": ["--cases", "2", "--arm-cases", "1", "--duration", "4", "--arm-duration", "1"],
    "cli": ["--repeats", "2"],
}


def _load(name: str) -> Any:
    if str(HERE) not in sys.path:
        sys.path.insert(0, str(HERE))  # the scripts import _timing as a top-level module
    spec = importlib.util.spec_from_file_location(name, HERE / f"{name}.py")
    module = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
    spec.loader.exec_module(module)  # type: ignore[union-attr]
    return module


def warm_up() -> float:
    """Compile (or load from Numba's cache) every kernel the benchmarks run; return the seconds it took."""
    t0 = time.perf_counter()
    import ibvs_youla as iy
    from ibvs_youla import scenarios
    from ibvs_youla.analysis import suites

    arm = iy.Arm.irb4600()
    for settings in (iy.SimulationSettings.paper(), iy.SimulationSettings()):
        for name in ("ff+fb", "ibvs-current"):
            sc = scenarios.paper(2) if name == "ff+fb" else scenarios.physical(2)
            iy.simulate(sc, name, duration=0.02, settings=settings, arm=arm)
    for method in ("ibvs-current", "ibvs-desired", "ibvs-mean"):  # the compiled frame path
        iy.simulate(
            scenarios.physical(2), method, duration=0.2, plant="kinematic", arm=arm,
            settings=iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0),
        )  # fmt: skip
    quick = iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0)
    for plant in ("kinematic", "free-camera"):
        iy.simulate(scenarios.physical(2), "ibvs-current", duration=0.2, plant=plant, settings=quick, arm=arm)
    tutorial = [suites.task("gans-general").scenario()] * 2
    for sensor in (None, "depth"):  # simulate_batch's kernels
        iy.simulate_batch(
            tutorial, "ibvs-current", duration=0.2, plant="free-camera", camera=iy.PinholeCamera.normalized(),
            settings=quick, sensor=sensor,
        )  # fmt: skip
    for sensor in (None, "depth"):
        iy.simulate(
            suites.task("gans-general").scenario(),
            "ibvs-current",
            duration=0.2,
            plant="free-camera",
            camera=iy.PinholeCamera.normalized(25.0),
            settings=quick,
            sensor=sensor,
        )
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    """Run the benchmarks and rewrite the README's figures; 0 when every benchmark ran."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (checks the pipeline, not for figures)")
    ap.add_argument("--only", metavar="NAMES", help=f"comma-separated subset of {', '.join(ORDER)}")
    ap.add_argument("--reports", type=Path, default=HERE / "reports", help="folder of the JSON reports")
    ap.add_argument(
        "--readme", type=Path, default=HERE / "README.md", help="README whose blocks are rewritten"
    )
    ap.add_argument("--mvtb-python", metavar="PATH", help="passed on to bench_controllers")
    args = ap.parse_args(argv)
    names = ORDER if not args.only else tuple(n.strip() for n in args.only.split(","))
    unknown = sorted(set(names) - set(ORDER))
    if unknown:
        ap.error(f"--only: unknown {', '.join(unknown)}; valid: {', '.join(ORDER)}")
    args.reports.mkdir(parents=True, exist_ok=True)

    print(f"warming Numba's cache ... {warm_up():.1f} s", flush=True)
    failed: dict[str, str] = {}
    loads: dict[str, Any] = {}
    for name in names:
        argv_ = [*(QUICK[name] if args.quick else []), "--json", str(args.reports / f"{name}.json")]
        if name == "controllers" and args.mvtb_python:
            argv_ += ["--mvtb-python", args.mvtb_python]
        print(f"\n== bench_{name} {' '.join(argv_)}", flush=True)
        t0 = time.perf_counter()
        try:
            report = _load(f"bench_{name}").main(argv_)
        except Exception as err:  # one failing benchmark must not stop the others
            traceback.print_exc()
            failed[name] = f"{type(err).__name__}: {err}"
            continue
        except SystemExit as exit_:  # its argument parser refused
            failed[name] = f"exit {exit_.code}"
            continue
        loads[name] = (
            report.get("machine", {}).get("load_average"),
            report.get("cpu", {}).get("other_cores"),
        )
        print(f"== bench_{name}: {time.perf_counter() - t0:.0f} s", flush=True)

    figures = _load("figures")
    written = figures.update_readme(args.readme, args.reports)
    print(f"\nrewrote the README blocks: {', '.join(written) or 'none'} ({args.readme})")
    for name, (load, other) in loads.items():
        busy = "" if other is None else f", other jobs {other:.2f} cores"
        warn = "  <- busy machine: take it again" if other is not None and other > 0.3 else ""
        print(f"  {name}: load average {load}{busy}{warn}")
    for name, why in failed.items():
        print(f"  {name}: FAILED ({why})")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
