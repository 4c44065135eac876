"""Campaign throughput: runs per minute with 1 and 2 Dask workers, their ratio, the time outside the runs.

Two stated campaigns (seed 0), each timed in this process without Dask (``serial``) and on a Dask
``LocalCluster(n_workers=k, threads_per_worker=1, processes=True)`` for k = 1 and 2:

* ``free``: the free-planar family, the seven camera-twist methods (``ibvs-current``,
  ``ibvs-desired``, ``ibvs-mean``, ``pbvs``, ``2.5d``, ``hybrid``, ``mpc-ibvs``), the free camera,
  the normalized monocular camera at 25 Hz, 20 s per run, ``--cases`` 30 cases (210 runs);
* ``arm``: the arm-physical family, every registered method (the paper's ``fb`` and ``ff+fb``
  and the seven), the dynamic IRB 4600 (joint loop 1 kHz), the ZED 2 stereo camera at 100 Hz
  (the library's default rates), 20 s per run, ``--arm-cases`` 3 cases (27 runs).

What one timed campaign does, as a campaign's client would: the specs as the runner's tasks
(``runner.tasks_of``: the classical IBVS runs of one method in batches of up to 50, made by one
``simulate_batch`` call, ``run_specs``; the other runs one per task, ``run_spec``),
``client.map(..., pure=False)``, the rows taken as they complete (``distributed.as_completed``) and
written in batches of ``--batch`` rows (a Parquet file written under a temporary name, then
renamed). Its wall time runs from the map to the last file renamed. Serially, the same tasks in
this process. Each worker first runs a 0.2 s version of
every spec's method, pinned to it (imports, the arm, OpenCV and DAQP warmed up; untimed).

Reported per campaign and worker count: ``runs_per_minute`` = runs / wall x 60; ``busy_s`` = the
sum of the rows' ``wall_s`` (each run's own time in ``run_spec``) / k; ``overhead_share`` = 1 -
busy_s / wall, the share of the wall time the workers did not spend in runs (scheduling,
serialization, the client's writing, idle workers at the end); ``write_s``, the client's time in
the Parquet writes; ``scaling`` = runs per minute with 2 workers / with 1. ``same_rows`` checks that
every worker count gave the serial rows (timing columns aside). ``own_cores`` and ``other_cores``
(:class:`CpuMeter`) tell whether other jobs shared the cores meanwhile. With ``--repeats`` > 1
the configurations alternate and each figure is the median repeat's.

Campaign sizing (the speed targets): a 1,000-case, seven-method campaign of 20 s runs. With
``--full-cases N`` (default 0: skipped) the free one is measured: ``run_campaign`` itself (the
runner, its tasks and Parquet rows) on a local cluster of 2 workers, N free-planar cases x the
seven methods, its minutes from the first submission to the last row (``run_s``) and from the call
to its return (``wall_s``, the cluster's start included); the rows of its first ``--check-cases``
cases are compared with ``run_spec``'s (equal, timing aside) and, for the methods with a compiled
frame path (``COMPILED_METHODS``: the classical IBVS laws, PBVS, 2.5-D, the hybrid law), with the
plug-in loop's (every number to 1e-9, relative or absolute: what the rows were before those methods
had a compiled path). Otherwise (and besides) projected from the
runs per minute measured on 2 workers: ``projection["free_1000x7_minutes"]`` (target under 5
minutes) from the free campaign, and ``projection["arm_1000x7_minutes"]`` (target under 30) from
the arm campaign at the default rates, for the seven twist methods (their mean run, the dearer
ones on the arm: a pseudo-inverse of J_C at every joint tick) and for the nine-method mix.
Both are projections from ``--cases`` and ``--arm-cases`` cases, not 7,000 runs; they assume the
measured mix of outcomes (a run that stops early is shorter).

The floor OpenCV's PnP sets (``pnp_floor``): each of the seven methods' runs of the first free
case is made once with a spy on ``cv2.solvePnP`` that keeps every call's arguments; those calls are
then replayed, timed (the median of ``PNP_REPLAYS`` replays of the run's calls), and their time per
case x 1,000 cases / k workers is the part of the 1,000 x 7 campaign the PnP alone takes, whatever
the rest of the loop costs. Its rows are today's only if the PnP is OpenCV's SQPnP (the
methods' default), so this floor bounds how fast the campaign can be while its rows stay equal.

Run: ``python benchmarks/bench_campaign.py --json campaign.json``.
"""

from __future__ import annotations

import argparse
import functools
import logging
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

try:  # imported as benchmarks.bench_campaign
    from ._timing import CpuShare, count, machine, perf_counter, seconds, write_json
except ImportError:  # run as a script
    from _timing import CpuShare, count, machine, perf_counter, seconds, write_json

from ibvs_youla.campaign.cases import generate_cases
from ibvs_youla.campaign.run import run_spec, run_specs
from ibvs_youla.campaign.runner import tasks_of
from ibvs_youla.campaign.spec import ExperimentSpec, specs_for

TWIST_METHODS = ("ibvs-current", "ibvs-desired", "ibvs-mean", "pbvs", "2.5d", "hybrid", "mpc-ibvs")
ARM_METHODS = ("fb", "ff+fb", *TWIST_METHODS)
WORKERS = (1, 2)
TIMING_COLUMNS = ("wall_s", "update_median_us", "update_p95_us")
WARM_UP_S = 0.2  # [s] simulated per warm-up run
TARGETS = {
    "scaling_min": 1.7,
    "overhead_share_max": 0.05,
    "free_1000x7_minutes_max": 5.0,
    "free_1000x7_measured_minutes_max": 1.0,
    "arm_1000x7_minutes_max": 30.0,
}
ROW_TOLERANCE = 1e-9  # relative or absolute, rows against the plug-in loop's
# the methods of TWIST_METHODS with a compiled frame path (their rows are checked against the plug-in loop's)
COMPILED_METHODS = ("ibvs-current", "ibvs-desired", "ibvs-mean", "pbvs", "2.5d", "hybrid")
PNP_REPLAYS = 5  # timed replays of one case's PnP calls (pnp_floor)


def campaigns(args: argparse.Namespace) -> dict[str, dict[str, Any]]:
    """The two stated campaigns: their description and specs."""
    free = {
        "family": "free-planar",
        "methods": TWIST_METHODS,
        "plant": "free-camera",
        "camera": {"kind": "normalized"},
        "duration": args.duration,
        "settings": {"joint_rate_hz": 25.0, "camera_rate_hz": 25.0},
        "cases": args.cases,
    }
    arm = {
        "family": "arm-physical",
        "methods": ARM_METHODS,
        "plant": "dynamic",
        "camera": {"kind": "stereo"},
        "duration": args.arm_duration,
        "settings": {"joint_rate_hz": 1000.0, "camera_rate_hz": 100.0},
        "cases": args.arm_cases,
    }
    out = {}
    for name, c in (("free", free), ("arm", arm)):
        cases = generate_cases(c["family"], c["cases"], 0)
        specs = specs_for(
            cases,
            c["methods"],
            seed=0,
            plant=c["plant"],
            camera=c["camera"],
            duration=c["duration"],
            settings=c["settings"],
        )
        out[name] = {**c, "methods": list(c["methods"]), "runs": len(specs), "specs": specs}
    return out


def warm_up_specs(specs: list[ExperimentSpec]) -> list[ExperimentSpec]:
    """One short spec per method of ``specs`` (its first case, :data:`WARM_UP_S` simulated)."""
    first: dict[str, ExperimentSpec] = {}
    for s in specs:
        first.setdefault(s.controller, s)
    return [ExperimentSpec(**{**s.to_dict(), "duration": WARM_UP_S}) for s in first.values()]


def write_batch(folder: Path, index: int, rows: list[dict[str, Any]]) -> None:
    """One Parquet file of ``rows``, written under a temporary name and renamed."""
    import pandas as pd

    final = folder / f"part-{index:05d}.parquet"
    tmp = final.with_name(f".{final.name}.tmp")  # hidden: skipped by Parquet readers
    pd.DataFrame(rows).to_parquet(tmp)
    os.replace(tmp, final)


class CpuMeter:
    """CPU used during a timed section [cores]: by this process and its children, and by the rest.

    ``own_cores`` = CPU seconds (user + system) of this process and every process under it (the
    cluster's nannies and workers) / wall; ``other_cores`` = the machine's busy CPU seconds (all
    but idle, I/O wait and steal) / wall - ``own_cores``: other sessions' jobs on the shared
    cores; ``steal_cores``: time the hypervisor gave the virtual CPUs to someone else.
    """

    def __init__(self) -> None:
        import psutil

        self._psutil = psutil
        self._start = self._sample()

    def _sample(self) -> tuple[float, float, float, float]:
        me = self._psutil.Process()
        own = 0.0
        for proc in (me, *me.children(recursive=True)):
            try:
                times = proc.cpu_times()
            except self._psutil.Error:  # a process that ended
                continue
            own += times.user + times.system
        machine_ = self._psutil.cpu_times()
        steal = getattr(machine_, "steal", 0.0)
        busy = sum(machine_) - machine_.idle - getattr(machine_, "iowait", 0.0) - steal
        return perf_counter(), own, busy, steal

    def stop(self) -> dict[str, float]:
        """The cores used since construction."""
        end = self._sample()
        wall = end[0] - self._start[0]
        own, busy, steal = (b - a for a, b in zip(self._start[1:], end[1:], strict=True))
        return {"own_cores": own / wall, "other_cores": (busy - own) / wall, "steal_cores": steal / wall}


def run_on_client(client: Any, specs: list[ExperimentSpec], batch: int) -> dict[str, Any]:
    """Map ``specs`` on the cluster, write the rows as they come in batches; time it all."""
    from distributed import as_completed

    with tempfile.TemporaryDirectory(prefix="bench-campaign-") as tmp:
        folder = Path(tmp)
        rows: list[dict[str, Any]] = []
        pending: list[dict[str, Any]] = []
        write_s, files = 0.0, 0
        meter = CpuMeter()
        t0 = perf_counter()
        tasks = tasks_of(specs)
        singles, batches = [t[0] for t in tasks if len(t) == 1], [list(t) for t in tasks if len(t) > 1]
        futures = [*client.map(run_spec, singles, pure=False), *client.map(run_specs, batches, pure=False)]
        for _, value in as_completed(futures, with_results=True):
            returned = value if isinstance(value, list) else [value]
            rows.extend(returned)
            pending.extend(returned)
            if len(pending) >= batch:
                t_write = perf_counter()
                write_batch(folder, files, pending)
                write_s += perf_counter() - t_write
                files, pending = files + 1, []
        if pending:
            t_write = perf_counter()
            write_batch(folder, files, pending)
            write_s += perf_counter() - t_write
            files += 1
        wall = perf_counter() - t0
        cpu = meter.stop()
    return {"wall_s": wall, "write_s": write_s, "files": files, "rows": rows, "cpu": cpu}


def run_serial(specs: list[ExperimentSpec]) -> dict[str, Any]:
    """The same tasks one after the other in this process (no Dask, no writing)."""
    meter = CpuMeter()
    t0 = perf_counter()
    rows = [row for task in tasks_of(specs) for row in run_specs(task)]
    wall = perf_counter() - t0
    return {"wall_s": wall, "write_s": 0.0, "files": 0, "rows": rows, "cpu": meter.stop()}


def comparable(rows: list[dict[str, Any]]) -> list[tuple]:
    """The rows without their timing columns, sorted by key (NaN made comparable)."""
    out = []
    for row in sorted(rows, key=lambda r: r["key"]):
        items = tuple(
            (k, "nan" if isinstance(v, float) and v != v else v)
            for k, v in sorted(row.items())
            if k not in TIMING_COLUMNS
        )
        out.append(items)
    return out


def figures(timed: dict[str, Any], workers: int) -> dict[str, Any]:
    """Runs per minute, busy time, overhead share and per-run times of one timed campaign."""
    rows = timed["rows"]
    run_wall = np.array([r["wall_s"] for r in rows])
    busy = float(run_wall.sum()) / workers
    outcomes: dict[str, int] = {}
    for r in rows:
        outcomes[r["outcome"]] = outcomes.get(r["outcome"], 0) + 1
    return {
        "wall_s": timed["wall_s"],
        "runs_per_minute": len(rows) / timed["wall_s"] * 60.0,
        "busy_s": busy,
        "overhead_share": 1.0 - busy / timed["wall_s"],
        "write_s": timed["write_s"],
        "files": timed["files"],
        "run_wall_median_s": float(np.median(run_wall)),
        "run_wall_sum_s": float(run_wall.sum()),
        "outcomes": dict(sorted(outcomes.items())),
        **timed["cpu"],
    }


def start_cluster(workers: int) -> tuple[Any, Any]:
    """A LocalCluster of ``workers`` one-thread processes (no dashboard) and its client."""
    from distributed import Client, LocalCluster

    cluster = LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",  # any free port: the dashboard is not used
        silence_logs=logging.ERROR,
    )
    return cluster, Client(cluster)


def warm_up(client: Any, specs: list[ExperimentSpec]) -> None:
    """Run :func:`warm_up_specs` on every worker, pinned to it."""
    for address in client.scheduler_info()["workers"]:
        futures = [client.submit(run_spec, s, workers=[address], pure=False) for s in specs]
        client.gather(futures)


def median_repeat(entries: list[dict[str, Any]]) -> dict[str, Any]:
    """The repeat of median wall time, with every repeat's wall time."""
    walls = [e["wall_s"] for e in entries]
    chosen = dict(entries[int(np.argsort(walls)[len(walls) // 2])])
    chosen["wall_s_repeats"] = walls
    return chosen


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmark, print a summary, write JSON if asked; return the report."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="FILE", help="write the report here")
    ap.add_argument("--cases", type=count, default=30, help="free-camera cases (default 30, x 7 methods)")
    ap.add_argument("--arm-cases", type=count, default=3, help="arm cases (default 3, x 9 methods)")
    ap.add_argument("--duration", type=seconds, default=20.0, help="simulated s per free-camera run (20)")
    ap.add_argument("--arm-duration", type=seconds, default=20.0, help="simulated s per arm run (20)")
    ap.add_argument("--repeats", type=count, default=1, help="timed repeats of every configuration (1)")
    ap.add_argument("--batch", type=count, default=50, help="rows per Parquet file written (50)")
    ap.add_argument(
        "--full-cases", type=int, default=0, help="measure a free campaign of N cases x 7 (0: no)"
    )
    ap.add_argument("--check-cases", type=count, default=10, help="its first cases checked row by row (10)")
    ap.add_argument("--only-full", action="store_true", help="only the measured free campaign")
    args = ap.parse_args(argv)
    if args.only_full:
        report = {"machine": machine(), "settings": {k: v for k, v in vars(args).items() if k != "json"}}
        report["full"] = full_free_campaign(args)
        report["targets"] = {
            **TARGETS,
            "met": {"free_1000x7_measured_minutes": _full_met(report["full"])},
        }
        _print_full(report["full"])
        write_json(args.json, report, headline)
        return report

    load_before = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    cpu = CpuShare()
    plan = campaigns(args)
    warm = [w for c in plan.values() for w in warm_up_specs(c["specs"])]
    for s in warm:  # this process too, for the serial runs
        run_spec(s)
    with tempfile.TemporaryDirectory() as tmp:  # pandas and pyarrow imported before the timing
        write_batch(Path(tmp), 0, [run_spec(warm[0])])
    timed: dict[str, dict[str, list[dict[str, Any]]]] = {n: {} for n in plan}
    serial_rows: dict[str, list[dict[str, Any]]] = {}
    for _ in range(args.repeats):
        for name, c in plan.items():
            result = run_serial(c["specs"])
            serial_rows[name] = result["rows"]
            timed[name].setdefault("serial", []).append({**figures(result, 1), "rows": result["rows"]})
        for k in WORKERS:
            cluster, client = start_cluster(k)
            try:
                warm_up(client, warm)
                for name, c in plan.items():
                    result = run_on_client(client, c["specs"], args.batch)
                    timed[name].setdefault(str(k), []).append({**figures(result, k), "rows": result["rows"]})
            finally:
                client.close()
                cluster.close()

    report: dict[str, Any] = {"machine": machine(), "load_average_1min_before": load_before}
    report["settings"] = {k: v for k, v in vars(args).items() if k != "json"}
    report["campaigns"] = {}
    for name, c in plan.items():
        entry = {k: v for k, v in c.items() if k != "specs"}
        configs = {label: median_repeat(entries) for label, entries in timed[name].items()}
        same = {
            label: comparable(cfg.pop("rows")) == comparable(serial_rows[name])
            for label, cfg in configs.items()
        }
        entry["serial"] = configs.pop("serial")
        entry["workers"] = configs
        entry["same_rows"] = all(same.values())
        entry["scaling"] = configs["2"]["runs_per_minute"] / configs["1"]["runs_per_minute"]
        entry["cases_per_hour"] = {
            k: cfg["runs_per_minute"] * 60.0 / len(c["methods"]) for k, cfg in configs.items()
        }
        report["campaigns"][name] = entry
    free = report["campaigns"]["free"]
    minutes = {k: 1000 * len(TWIST_METHODS) / cfg["runs_per_minute"] for k, cfg in free["workers"].items()}
    arm_minutes = {
        mix: {
            k: 7000 * run_s / 60.0 / int(k) / (1.0 - cfg["overhead_share"]) for k, cfg in arm_workers.items()
        }
        for mix, run_s, arm_workers in (
            ("twist", _mean_run_s(timed["arm"], TWIST_METHODS), report["campaigns"]["arm"]["workers"]),
            ("all", _mean_run_s(timed["arm"], ARM_METHODS), report["campaigns"]["arm"]["workers"]),
        )
    }
    report["projection"] = {
        "free_1000x7_minutes": minutes,
        "free_1000x7_minutes_at_duration_s": args.duration,
        "arm_1000x7_minutes": arm_minutes["twist"],
        "arm_1000x7_all_methods_minutes": arm_minutes["all"],
        "arm_1000x7_minutes_at_duration_s": args.arm_duration,
        "arm_run_s_by_method": _run_s_by_method(timed["arm"]),
    }
    report["targets"] = {
        **TARGETS,
        "met": {
            "scaling": {n: c["scaling"] >= TARGETS["scaling_min"] for n, c in report["campaigns"].items()},
            "overhead_share": {
                f"{n}/{k}": cfg["overhead_share"] < TARGETS["overhead_share_max"]
                for n, c in report["campaigns"].items()
                for k, cfg in c["workers"].items()
            },
            "free_1000x7_minutes": minutes["2"] < TARGETS["free_1000x7_minutes_max"],
            "arm_1000x7_minutes": arm_minutes["twist"]["2"] < TARGETS["arm_1000x7_minutes_max"],
        },
    }
    report["pnp_floor"] = pnp_floor(plan["free"]["specs"])
    if args.full_cases > 0:
        report["full"] = full_free_campaign(args)
        report["targets"]["met"]["free_1000x7_measured_minutes"] = _full_met(report["full"])
    report["load_average_1min_after"] = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    report["cpu"] = cpu.stop()

    for name, c in report["campaigns"].items():
        s = c["serial"]
        print(
            f"{name}: {c['family']}, {len(c['methods'])} methods x {c['cases']} cases = {c['runs']} runs of "
            f"{c['duration']:g} s on the {c['plant']} plant; serial {s['runs_per_minute']:.0f} runs/min "
            f"(other jobs {s['other_cores']:.2f} cores)"
        )
        for k, cfg in c["workers"].items():
            print(
                f"  {k} worker(s): {cfg['runs_per_minute']:7.0f} runs/min, wall {cfg['wall_s']:.2f} s, "
                f"overhead {cfg['overhead_share']:.1%} (writing {cfg['write_s']:.3f} s), "
                f"run median {cfg['run_wall_median_s'] * 1e3:.0f} ms; cores: own {cfg['own_cores']:.2f}, "
                f"other jobs {cfg['other_cores']:.2f}"
            )
        print(f"  scaling 2/1: {c['scaling']:.2f}; same rows as serial: {c['same_rows']}")
    print(
        f"1,000 free cases x 7 methods of {args.duration:g} s: {minutes['1']:.1f} min on 1 worker, "
        f"{minutes['2']:.1f} min on 2 (target < {TARGETS['free_1000x7_minutes_max']:g})"
    )
    print(
        f"1,000 arm cases x 7 twist methods of {args.arm_duration:g} s: "
        f"{arm_minutes['twist']['1']:.1f} min on 1 worker, {arm_minutes['twist']['2']:.1f} min on 2 "
        f"(target < {TARGETS['arm_1000x7_minutes_max']:g}); "
        f"with the nine-method mix {arm_minutes['all']['2']:.1f} min on 2"
    )
    floor = report["pnp_floor"]
    print(
        f"OpenCV's PnP alone in that campaign: {floor['free_1000x7_minutes']['2']:.2f} min on 2 workers "
        f"({floor['calls_per_case']} calls a case, {floor['us_per_call']:.1f} us each; "
        f"target < {TARGETS['free_1000x7_measured_minutes_max']:g} min for the whole campaign)"
    )
    if "full" in report:
        _print_full(report["full"])
    write_json(args.json, report, headline)
    return report


def pnp_floor(specs: list[ExperimentSpec]) -> dict[str, Any]:
    """The minutes OpenCV's PnP alone takes in a 1,000-case free campaign of these methods."""
    import cv2

    first: dict[str, ExperimentSpec] = {}
    for s in specs:
        first.setdefault(s.controller, s)
    calls: dict[str, list[tuple[tuple[Any, ...], dict[str, Any]]]] = {m: [] for m in first}
    real = cv2.solvePnP

    def spy(kept: list[tuple[tuple[Any, ...], dict[str, Any]]], *a: Any, **kw: Any) -> Any:
        kept.append((tuple(np.array(x, copy=True) if isinstance(x, np.ndarray) else x for x in a), kw))
        return real(*a, **kw)

    for method, spec in first.items():
        cv2.solvePnP = functools.partial(spy, calls[method])
        try:
            run_spec(spec)
        finally:
            cv2.solvePnP = real
    replay = [call for method_calls in calls.values() for call in method_calls]
    walls = []
    for _ in range(PNP_REPLAYS):
        t0 = perf_counter()
        for a, kw in replay:
            real(*a, **kw)
        walls.append(perf_counter() - t0)
    case_s = float(np.median(walls))
    per_call = case_s / max(len(replay), 1)
    return {
        "calls_per_case": len(replay),
        "calls_by_method": {m: len(c) for m, c in calls.items()},
        "flags": sorted({int(kw.get("flags", -1)) for _, kw in replay}),
        "solvers": sorted({_solver_name(cv2, int(kw.get("flags", -1))) for _, kw in replay}),
        "us_per_call": per_call * 1e6,
        "case_s": case_s,
        "free_1000x7_minutes": {str(k): 1000 * case_s / k / 60.0 for k in WORKERS},
    }


def _solver_name(cv2: Any, flag: int) -> str:
    """OpenCV's name of a solvePnP flag without its prefix (``SOLVEPNP_SQPNP`` -> ``SQPNP``)."""
    names = [n for n in dir(cv2) if n.startswith("SOLVEPNP_") and getattr(cv2, n) == flag]
    return names[0].removeprefix("SOLVEPNP_") if names else str(flag)


def full_free_campaign(args: argparse.Namespace) -> dict[str, Any]:
    """``run_campaign`` of ``--full-cases`` free-planar cases x the seven methods on 2 local workers, timed.

    Its first ``--check-cases`` cases' rows are compared with ``run_spec``'s and, for the methods with
    a compiled frame path (:data:`COMPILED_METHODS`), with the plug-in loop's (module docstring).
    """
    from ibvs_youla.campaign.definition import CampaignDefinition
    from ibvs_youla.campaign.runner import run_campaign
    from ibvs_youla.campaign.storage import read_rows

    definition = CampaignDefinition(
        "free-planar",
        args.full_cases,
        TWIST_METHODS,
        seed=0,
        plant="free-camera",
        camera="normalized",
        duration=args.duration,
        settings={"joint_rate_hz": 25.0, "camera_rate_hz": 25.0},
    )
    with tempfile.TemporaryDirectory(prefix="bench-campaign-full-") as tmp:
        meter = CpuMeter()
        t0 = perf_counter()
        summary = run_campaign(definition, Path(tmp) / "free", workers=2, progress=False)
        wall = perf_counter() - t0
        cpu = meter.stop()
        stored = read_rows(Path(tmp) / "free").set_index("key")
    checked = [s for s in definition.specs() if s.case < args.check_cases]
    same, worst = True, 0.0
    for spec in checked:
        row = {"key": spec.key, **stored.loc[spec.key].to_dict()}
        same = same and _deviation(row, run_spec(spec)) == 0.0
        if spec.controller in COMPILED_METHODS:
            worst = max(worst, _deviation(row, _plug_in_row(spec)))
    return {
        "cases": args.full_cases,
        "methods": list(TWIST_METHODS),
        "duration_s": args.duration,
        "runs": summary.ran,
        "run_s": summary.run_s,
        "wall_s": wall,
        "minutes": summary.run_s / 60.0,
        "wall_minutes": wall / 60.0,
        "outcomes": dict(sorted(summary.outcomes.items())),
        "checked_rows": len(checked),
        "same_rows_as_run_spec": same,
        "plug_in_row_deviation_max": worst,
        "rows_within_tolerance": same and worst <= ROW_TOLERANCE,
        **cpu,
    }


def _plug_in_row(spec: ExperimentSpec) -> dict[str, Any]:
    """The row of a run made by the plug-in loop (``simulate(..., loop="plug-in")``)."""
    from ibvs_youla.campaign.metrics import row_from_result
    from ibvs_youla.simulation.simulate import simulate

    return row_from_result(spec, simulate(**spec.build(), loop="plug-in"))


def _deviation(a: dict[str, Any], b: dict[str, Any]) -> float:
    """Largest difference of two rows' numbers (over max(1, |b|)), timing aside; inf if another differs."""
    worst = 0.0
    for column, value in b.items():
        if column in TIMING_COLUMNS:
            continue
        other = a[column]
        if isinstance(value, float) and np.isfinite(value):
            worst = max(worst, abs(float(other) - value) / max(1.0, abs(value)))
        elif isinstance(value, float):
            worst = worst if str(float(other)) == str(value) else np.inf
        elif other != value:
            worst = np.inf
    return worst


def _full_met(full: dict[str, Any]) -> bool:
    return bool(
        full["minutes"] < TARGETS["free_1000x7_measured_minutes_max"] and full["rows_within_tolerance"]
    )


def _print_full(full: dict[str, Any]) -> None:
    print(
        f"measured: {full['cases']} free cases x 7 methods of {full['duration_s']:g} s on 2 workers: "
        f"{full['minutes']:.2f} min from the first run to the last row ({full['wall_minutes']:.2f} min with "
        f"the cluster's start; target < {TARGETS['free_1000x7_measured_minutes_max']:g}); outcomes "
        f"{full['outcomes']}; first {full['checked_rows']} rows: as run_spec's "
        f"{full['same_rows_as_run_spec']}, the plug-in loop's to {full['plug_in_row_deviation_max']:.1e}; "
        f"other jobs {full['other_cores']:.2f} cores"
    )


def _arm_rows(entries: dict[str, list[dict[str, Any]]]) -> list[dict[str, Any]]:
    """Every row the arm campaign produced, over every configuration and repeat (the runs' own times)."""
    return [row for config in entries.values() for entry in config for row in entry["rows"]]


def _run_s_by_method(entries: dict[str, list[dict[str, Any]]]) -> dict[str, float]:
    """Median run time [s] of each method (in-worker and serial runs alike)."""
    by: dict[str, list[float]] = {}
    for row in _arm_rows(entries):
        by.setdefault(row["controller"], []).append(row["wall_s"])
    return {name: float(np.median(v)) for name, v in sorted(by.items())}


def _mean_run_s(entries: dict[str, list[dict[str, Any]]], methods: tuple[str, ...]) -> float:
    """Mean over ``methods`` of each method's median in-worker run time [s] (a campaign's mix)."""
    by: dict[str, list[float]] = {}
    for label, config in entries.items():
        if label == "serial":
            continue
        for entry in config:
            for row in entry["rows"]:
                by.setdefault(row["controller"], []).append(row["wall_s"])
    return float(np.mean([np.median(by[m]) for m in methods]))


def headline(r: dict[str, Any]) -> dict[str, Any]:
    """The figures kept in the report's history."""
    if "campaigns" not in r:  # the measured free campaign alone
        return {"free_1000x7_measured_minutes": r["full"]["minutes"], "other_cores": r["full"]["other_cores"]}
    return {
        "runs_per_minute": {
            n: {k: c["runs_per_minute"] for k, c in camp["workers"].items()}
            for n, camp in r["campaigns"].items()
        },
        "scaling": {n: camp["scaling"] for n, camp in r["campaigns"].items()},
        "free_1000x7_minutes_2_workers": r["projection"]["free_1000x7_minutes"]["2"],
        "arm_1000x7_minutes_2_workers": r["projection"].get("arm_1000x7_minutes", {}).get("2"),
        "other_cores": r.get("cpu", {}).get("other_cores"),
    }


if __name__ == "__main__":
    main(sys.argv[1:])
