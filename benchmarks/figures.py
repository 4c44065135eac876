"""The tables of ``benchmarks/README.md``, made from the JSON reports in ``benchmarks/reports/``.

Each table is a function of one report (or none, when it is missing); :func:`update_readme`
rewrites every block of the README between ``<!-- figures:NAME -->`` and ``<!-- /figures:NAME -->``
with the table NAME, so that the README's figures are always those of the reports beside it
(``run_all.py`` calls it after the benchmarks). Prose around the blocks is not touched.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

Report = dict[str, Any]


def _num(x: Any, digits: int = 1) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a"
    return f"{x:,.{digits}f}"


def _met(flag: Any) -> str:
    return "**met**" if flag is True else "**not met**" if flag is False else "n/a"


def _when(r: Report) -> str:
    m = r.get("machine", {})
    load = m.get("load_average") or [m.get("load_average_1min")]
    other = r.get("cpu", {}).get("other_cores")
    versions = m.get("versions", {})
    pkgs = ", ".join(
        f"{k} {v}" for k, v in versions.items() if k in ("python", "numpy", "scipy", "pin", "numba")
    )
    busy = "" if other is None else f"; other jobs used {other:.2f} of the {m.get('cores')} cores meanwhile"
    calibration = m.get("calibration_ms")
    speed = (
        "" if calibration is None else f"; calibration loop {calibration:.1f} ms (smaller: faster machine)"
    )
    return (
        f"{m.get('date', '?')}, {m.get('cpu', '?')} ({m.get('cores', '?')} cores), load average "
        f"{' / '.join(_num(x, 2) for x in load)} (1/5/15 min){busy}{speed}; {pkgs}; compiled kernels "
        f"{'on' if m.get('compiled_kernels') else 'off'}"
    )


def outer_loop(r: Report) -> str:
    """The update, its floor and its parts."""
    s = r["stats"]
    rows = [
        "| | median [us] | p95 [us] |",
        "| --- | ---: | ---: |",
        f"| **update** (sensor + `YoulaController.update`) | **{_num(r['update_median_us'])}** | "
        f"{_num(r['update_p95_us'])} |",
    ]
    labels = {
        "camera_pose": "true camera pose (forward kinematics, checked `Arm.camera_pose`)",
        "sensor": "sensor: P_C, features and visibility (one compiled call)",
        "p3p": "stereo P3P: triangulation + Kabsch with its 3x3 SVD (compiled)",
        "ik": "nearest IK branch (compiled) + one Pinocchio pass at q~ (check, T_O_C, J_C)",
        "jacobian": "L(P_C) J_C (compiled)",
        "svd_gains": "9x6 SVD, gains, P e (compiled, LAPACK dgesdd)",
        "state_update": "filter step q_fb = K(z)[P e]",
    }
    for name, label in labels.items():
        if name in s:
            rows.append(f"| {label} | {_num(s[name]['median_us'], 2)} | {_num(s[name]['p95_us'], 2)} |")
    rows.append(f"| the calls between the parts (update - parts) | {_num(r.get('glue_median_us'), 2)} | |")
    floor = " + ".join(
        f"{n} {_num(s[n]['median_us'], 2)}" for n in ("fk", "frame_jacobian", "svd_9x6", "svd_3x3")
    )
    rows.append(f"| **floor** ({floor}) | **{_num(r['floor_median_us'], 2)}** | |")
    target = r.get("target", {})
    rows.append(
        f"| **ratio update / floor** (target <= {target.get('ratio_to_floor_max', 2.5)}) | "
        f"**{_num(r['ratio_to_floor'], 2)}** {_met(target.get('met'))} | |"
    )
    for name, label in (
        ("svd_9x6_compiled", "9x6 dgesdd through the compiled call, from Python"),
        ("svd_3x3_compiled", "3x3 dgesdd through the compiled call, from Python"),
        ("svd_9x6_numpy", "9x6 `np.linalg.svd`"),
    ):
        if name in s:
            rows.append(f"| (for comparison) {label} | {_num(s[name]['median_us'], 2)} | |")
    rows.append(
        f"| literal python-control rebuild of Eq. (58)-(61) | {_num(r['rebuild_median_us'] / 1e3, 2)} ms | "
        f"{_num(r['rebuild_ratio'], 0)}x the update |"
    )
    settings = r["settings"]
    return (
        "\n".join(rows)
        + f"\n\n{settings['configs']} configurations x {settings['repeats']} rounds. Measured {_when(r)}.\n"
    )


def simulation(r: Report) -> str:
    """Realtime factors of the paper's scenarios and of classical IBVS, with the targets."""
    targets = r.get("targets", {})
    mins = targets.get("min_realtime_factor", {"paper": 20.0, "two-rate": 50.0, "classical": 1000.0})
    met = targets.get("met", {})
    rows = [
        "| run | realtime factor | target | plant [us/tick] | camera frame [us/frame] "
        "| tick control [us/tick] |",
        "| --- | ---: | --- | ---: | ---: | ---: |",
    ]
    for name, factors in r["realtime_factor"].items():
        for label, factor in factors.items():
            split = r["cases"][f"{name}/{label}"]["split"]
            rate = "1 kHz / 1 kHz" if label == "paper" else "1 kHz / 100 Hz"
            rows.append(
                f"| {name}, ff+fb adaptive, dynamic arm, {rate} | **{_num(factor)}x** | >= {mins[label]:g}x "
                f"{_met(met.get(label, {}).get(name))} | {_num(split['dynamics_us_per_step'])} | "
                f"{_num(split['outer_us_per_frame'])} | {_num(split['joint_control_us_per_step'])} |"
            )
    for name, c in r.get("classical", {}).items():
        split = c["split"]
        rows.append(
            f"| ibvs-current, {name}, 25 Hz | **{_num(c['realtime_factor'], 0)}x** | "
            f">= {mins['classical']:g}x "
            f"{_met(met.get('classical', {}).get(name))} | {_num(split['dynamics_us_per_step'])} | "
            f"{_num(split['outer_us_per_frame'])} | {_num(split['joint_control_us_per_step'])} |"
        )
    robot_met = met.get("robots", {})
    for name, row in r.get("robots", {}).items():
        paper, classical, ok = row["paper"], row["classical"], robot_met.get(name, {})
        rows.append(
            f"| {name} ({row['n_joints']} joints, IK {row['ik']}), ff+fb adaptive, dynamic arm, "
            f"1 kHz / 100 Hz | **{_num(paper['realtime_factor'])}x** | >= 20x {_met(ok.get('paper'))} | "
            + _split_cells(paper["split"])
        )
        rows.append(
            f"| {name}, ibvs-current, kinematic arm, 25 Hz | **{_num(classical['realtime_factor'], 0)}x** "
            f"({_num(classical['cost_vs_irb4600'], 2)}x the IRB 4600's wall time) | <= 1.5x the IRB "
            f"4600's {_met(ok.get('classical'))} | " + _split_cells(classical["split"])
        )
    settings = r["settings"]
    return (
        "\n".join(rows)
        + f"\n\nMedian of {settings['repeats']} runs of {settings['duration_s']:g} s (paper scenarios) and "
        f"{settings.get('classical_duration_s', 20):g} s (classical IBVS). Measured {_when(r)}.\n"
    )


def _split_cells(split: dict[str, Any]) -> str:
    """The plant, frame and tick-control cells of a run's split."""
    return (
        f"{_num(split['dynamics_us_per_step'])} | {_num(split['outer_us_per_frame'])} | "
        f"{_num(split['joint_control_us_per_step'])} |"
    )


def controllers(r: Report) -> str:
    """One control update of every method, on both cases (a method that refuses the square: on 7 points;
    one that servoes on the image: on the textured plane)."""
    rows = [
        "| method | mono: median / p95 [us] | floor [us] | ratio | stereo: median / p95 [us] "
        "| floor [us] | ratio |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    cases = r["cases"]
    mono, stereo = cases["mono"]["methods"], cases["stereo"]["methods"]
    irregular = cases.get("irregular", {}).get("methods", {})  # reports before the case have none
    textured = cases.get("textured", {}).get("methods", {})
    for name in r["controllers"]:
        cells = []
        if name in textured:  # it servoes on the image: the textured plane is its case (mono columns)
            e = textured[name]
            cells = [
                f"{_num(e['median_us'])} / {_num(e['p95_us'])} (textured plane) | {_num(e['floor_us'])} | "
                f"{_num(e['ratio_to_floor'])}",
                "monocular only | | ",
            ]
        for case in (mono, stereo) if not cells else ():
            e, note = case.get(name), ""
            if e is None and case is mono and name in irregular:
                e, note = irregular[name], " (7 points)"
            if e is None:
                cells.append("stereo and arm only | | " if name in ("fb", "ff+fb") else "refused | | ")
            else:
                cells.append(
                    f"{_num(e['median_us'])} / {_num(e['p95_us'])}{note} | {_num(e['floor_us'])} | "
                    f"{_num(e['ratio_to_floor'])}"
                )
        rows.append(f"| `{name}` | {' | '.join(cells)} |")
    settings = r["settings"]
    parts = cases.get("textured", {}).get("parts_median_us", {})
    frame = (
        f" The textured plane's frame (120 x 90 px image and markers) costs {_num(parts['scene_frame'])} us "
        f"of which the warp {_num(parts['render_plane'])} us."
        if {"scene_frame", "render_plane"} <= set(parts)
        else ""
    )
    return (
        "\n".join(rows)
        + f"\n\n{settings['configs']} configurations x {settings['repeats']} rounds per case.{frame} "
        f"Measured {_when(r)}.\n"
    )


def peers(r: Report) -> str:
    """One step of ViSP's tutorial-ibvs-4pts by ibvs-youla, ViSP 3.5 and MVTB, the same case, one run."""
    visp, mvtb = r["peers"].get("visp"), r["peers"].get("mvtb")
    rows = [
        "| one step of tutorial-ibvs-4pts | median [us] | / ViSP | MVTB / this | features vs ours (max) |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    if visp:
        rows.append(
            f"| ViSP {visp['version']} C++ (vpServo + vpSimulatorCamera) | {_num(visp['step_us'])} | 1.0 | "
            f"{_num(mvtb['step_us'] / visp['step_us']) if mvtb else 'n/a'} | "
            f"{visp['trajectory']['max']:.1e} |"
        )
    labels = {
        "depth": 'ibvs-youla, measured depth (`sensor="depth"`)',
        "depth, plug-in loop": 'ibvs-youla, measured depth, `loop="plug-in"`',
        "monocular": "ibvs-youla, monocular (SQPnP depths, the default)",
        "monocular, IPPE": 'ibvs-youla, monocular (IPPE depths, `pnp="ippe"`)',
        "monocular, plug-in loop": 'ibvs-youla, monocular, `loop="plug-in"`',
    }
    for mode, o in r["ours"].items():
        rows.append(
            f"| {labels.get(mode, mode)}: the {o['loop']} loop | **{_num(o['step_us'])}** | "
            f"{_num(o['step_us'] / visp['step_us']) if visp else 'n/a'} | "
            f"{_num(mvtb['step_us'] / o['step_us']) if mvtb else 'n/a'} | |"
        )
    if mvtb:
        rows.append(
            f"| MVTB-python {mvtb['version']} `IBVS.step` | {_num(mvtb['step_us'])} | "
            f"{_num(mvtb['step_us'] / visp['step_us']) if visp else 'n/a'} | 1.0 | "
            f"{mvtb['trajectory']['max']:.1e} |"
        )
    s = r["settings"]
    skipped = "".join(f" {k} skipped: {v}." for k, v in r.get("skipped", {}).items())
    return (
        "\n".join(rows)
        + f"\n\n{s['steps']} steps per run, {s['rounds']} alternating rounds.{skipped} Measured {_when(r)}.\n"
    )


def batch(r: Report) -> str:
    """A case-frame of simulate_batch at N cases beside an iteration of ViSP's C++ loop, one core, one run."""
    visp = r["peers"].get("visp")
    rows = [
        "| tutorial-ibvs-4pts, one core | cases | per case-frame, CPU [us] | / ViSP | wall [us] | / ViSP "
        "| whole call per case-frame, CPU [us] | set-up per case [ms] |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    if visp:
        rows.append(
            f"| ViSP {visp['version']} C++, an iteration of one run (median) | 1 | "
            f"{_num(visp['step_us'])} | 1.0 | | | | |"
        )
    labels = {"depth": 'simulate_batch, measured depth (`sensor="depth"`)', "monocular": "simulate_batch, "
              "monocular (SQPnP depths, per case)"}  # fmt: skip
    for mode, o in r["ours"].items():
        rows.append(
            f"| {labels.get(mode, mode)} | {o['cases']:,} | **{_num(o['case_frame_us'], 2)}** | "
            f"{_num(o['case_frame_us'] / visp['step_us'], 2) if visp else 'n/a'} | "
            f"{_num(o['case_frame_wall_us'], 2)} | "
            f"{_num(o['case_frame_wall_us'] / visp['step_us'], 2) if visp else 'n/a'} | "
            f"{_num(o['whole_call_per_case_frame_us'], 2)} | {_num(o['setup_per_case_ms'], 2)} |"
        )
    s = r["settings"]
    skipped = "".join(f" {k} skipped: {v}." for k, v in r.get("skipped", {}).items())
    return (
        "\n".join(rows)
        + f"\n\n{s['steps']} and {2 * s['steps']} steps per call, {s['rounds']} alternating rounds, OpenBLAS "
        f"threads {s['openblas_threads']}.{skipped} Measured {_when(r)}.\n"
    )


def campaign(r: Report) -> str:
    """Runs per minute on 1 and 2 Dask workers, scaling, overhead, and the campaign sizings."""
    rows = [
        "| campaign | runs | serial [runs/min] | 1 worker [runs/min] | overhead | 2 workers [runs/min] "
        "| overhead | scaling 2/1 |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for name, c in r["campaigns"].items():
        w1, w2 = c["workers"]["1"], c["workers"]["2"]
        rows.append(
            f"| {name}: {c['family']}, {len(c['methods'])} methods, {c['duration']:g} s, {c['plant']} "
            f"| {c['runs']} | "
            f"{_num(c['serial']['runs_per_minute'], 0)} | {_num(w1['runs_per_minute'], 0)} | "
            f"{_num(100 * w1['overhead_share'])} % | {_num(w2['runs_per_minute'], 0)} | "
            f"{_num(100 * w2['overhead_share'])} % | **{_num(c['scaling'], 2)}** |"
        )
    p, met, targets = r["projection"], r["targets"]["met"], r["targets"]
    sizing = [
        "",
        "| 1,000 cases x 7 methods, 20 s runs | 1 worker [min] | 2 workers [min] | target |",
        "| --- | ---: | ---: | --- |",
        f"| free camera ({p['free_1000x7_minutes_at_duration_s']:g} s runs) | "
        f"{_num(p['free_1000x7_minutes']['1'])} | "
        f"**{_num(p['free_1000x7_minutes']['2'])}** | < {targets['free_1000x7_minutes_max']:g} "
        f"{_met(met['free_1000x7_minutes'])} |",
    ]
    if "arm_1000x7_minutes" in p:
        sizing.append(
            f"| dynamic arm, 1 kHz / 100 Hz ({p['arm_1000x7_minutes_at_duration_s']:g} s runs), "
            "the seven twist "
            f"methods | {_num(p['arm_1000x7_minutes']['1'])} | **{_num(p['arm_1000x7_minutes']['2'])}** | "
            f"< {targets.get('arm_1000x7_minutes_max', 30):g} {_met(met.get('arm_1000x7_minutes'))} |"
        )
        sizing.append(
            f"| dynamic arm, the nine-method mix | {_num(p['arm_1000x7_all_methods_minutes']['1'])} | "
            f"{_num(p['arm_1000x7_all_methods_minutes']['2'])} | |"
        )
    full = r.get("full")
    if full:
        sizing.append(
            f"| free camera, measured: `run_campaign` of {full['cases']:,} cases x 7 "
            f"({full['duration_s']:g} s runs) | | **{_num(full['minutes'], 2)}** "
            f"({_num(full['wall_minutes'], 2)} with the cluster's start) | "
            f"< {targets['free_1000x7_measured_minutes_max']:g} "
            f"{_met(met.get('free_1000x7_measured_minutes'))} |"
        )
    floor = r.get("pnp_floor")
    if floor:
        alone = floor["free_1000x7_minutes"]
        sizing.append(
            f"| free camera, OpenCV's PnP alone: {floor['calls_per_case']:,} "
            f"{'/'.join(floor.get('solvers', ['SQPNP']))} calls a case at "
            f"{_num(floor['us_per_call'])} us (the floor while the rows stay SQPnP's) | "
            f"{_num(alone['1'], 2)} | **{_num(alone['2'], 2)}** | "
            f"< {targets['free_1000x7_measured_minutes_max']:g} for the whole campaign |"
        )
    per_method = p.get("arm_run_s_by_method")
    if per_method:
        sizing.append("")
        sizing.append(
            "Median run on the arm [ms]: "
            + ", ".join(f"`{k}` {_num(1e3 * v, 0)}" for k, v in per_method.items())
            + "."
        )
    s = r["settings"]
    return (
        "\n".join(rows + sizing)
        + f"\n\n{s['cases']} free cases, {s['arm_cases']} arm cases, {s['repeats']} repeat(s). "
        f"Measured {_when(r)}.\n"
    )


def cli(r: Report) -> str:
    """The command line's answers without a simulation: median and 95th percentile of each call."""
    rows = ["| call | median [ms] | p95 [ms] |", "| --- | ---: | ---: |"]
    for c in r["calls"].values():
        rows.append(
            f"| `ibvs-youla {' '.join(c['argv'])}` | {_num(c['median_ms'], 0)} | {_num(c['p95_ms'], 0)} |"
        )
    labels = {
        "interpreter": "reference: `python -c pass` (the interpreter's start)",
        "eager_imports": "reference: importing what the parser imported before it was light",
    }
    for name, c in r["reference"].items():
        rows.append(f"| {labels.get(name, name)} | {_num(c['median_ms'], 0)} | {_num(c['p95_ms'], 0)} |")
    return (
        "\n".join(rows)
        + f"\n\nEach call a new process ({r['settings']['command']}), {r['settings']['repeats']} rounds. "
        f"Measured {_when(r)}.\n"
    )


def _minutes(date: str | None) -> float | None:
    """Minutes since the epoch of an ISO date, or None."""
    import datetime

    try:
        return datetime.datetime.fromisoformat(date).timestamp() / 60.0  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None


def history(reports: dict[str, Report | None]) -> str:
    """The last runs' headline figures, a row per run: an outer-loop run with the simulation run
    taken within 10 minutes of it (the nearest not yet paired), and a simulation run taken alone
    (``run_all.py --only simulation``) on its own row."""
    rows = [
        "| date (UTC) | load 1 min | calibration [ms] | update / floor | paper-1 1 kHz/1 kHz "
        "| paper-1 1 kHz/100 Hz | kinematic IBVS | free-camera IBVS (stereo) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    outer = [(h, _minutes(h.get("date"))) for h in (reports.get("outer_loop") or {}).get("history", [])]
    sims = [(h, _minutes(h.get("date"))) for h in (reports.get("simulation") or {}).get("history", [])]
    runs: list[tuple[float, dict, dict]] = []  # (minutes, outer-loop entry, simulation entry)
    paired: set[int] = set()
    for h, when in outer:
        near = [
            (abs(m - when), i)
            for i, (_, m) in enumerate(sims)
            if i not in paired and m is not None and when is not None and abs(m - when) < 10
        ]
        i = min(near)[1] if near else None
        if i is not None:
            paired.add(i)
        runs.append((when if when is not None else -1.0, h, sims[i][0] if i is not None else {}))
    runs += [(m if m is not None else -1.0, {}, h) for i, (h, m) in enumerate(sims) if i not in paired]
    runs.sort(key=lambda run: run[0])
    for _, h, s in runs[-12:]:
        first = h or s
        factors = s.get("realtime_factor", {}).get("paper-1", {})
        classical = s.get("classical") or {}
        load = (first.get("load_average") or [None])[0]
        rows.append(
            f"| {(first.get('date') or '?')[:16].replace('T', ' ')} | {_num(load, 2)} "
            f"| {_num(first.get('calibration_ms'))} "
            f"| {_num(h.get('ratio_to_floor'), 2)} | {_num(factors.get('paper'))} "
            f"| {_num(factors.get('two-rate'))} "
            f"| {_num(classical.get('kinematic/physical-2'), 0)} "
            f"| {_num(classical.get('free-camera/physical-2'), 0)} |"
        )
    return "\n".join(rows) + "\n"


def targets(reports: dict[str, Report | None]) -> str:
    """The speed targets, each with the value measured in the latest reports and the load then."""

    def load(r: Report | None) -> str:
        if r is None:
            return "no report"
        m, other = r.get("machine", {}), r.get("cpu", {}).get("other_cores")
        la = (m.get("load_average") or [m.get("load_average_1min")])[0]
        busy = "" if other is None else f", other jobs {other:.2f} cores"
        cal = m.get("calibration_ms")
        speed = "" if cal is None else f", calibration {cal:.1f} ms"
        return f"{(m.get('date') or '?')[:16].replace('T', ' ')}, load {_num(la, 2)}{busy}{speed}"

    rows = ["| target | measured | | when, machine load |", "| --- | --- | --- | --- |"]
    outer, sim, camp = reports.get("outer_loop"), reports.get("simulation"), reports.get("campaign")
    cli_ = reports.get("cli")
    if outer is not None:
        rows.append(
            f"| adaptive outer update <= 2.5x its floor | {_num(outer['ratio_to_floor'], 2)}x "
            f"({_num(outer['update_median_us'])} / {_num(outer['floor_median_us'], 2)} us) | "
            f"{_met(outer['ratio_to_floor'] <= 2.5)} | {load(outer)} |"
        )
    if sim is not None:
        for label, bound, what in (("paper", 20, "1 kHz / 1 kHz"), ("two-rate", 50, "1 kHz / 100 Hz")):
            values = {n: f[label] for n, f in sim["realtime_factor"].items()}
            worst = min(values.values())
            rows.append(
                f"| paper scenarios, dynamic arm, {what}: >= {bound}x real time | "
                + ", ".join(f"{n} {_num(v)}x" for n, v in values.items())
                + f" | {_met(worst >= bound)} | {load(sim)} |"
            )
        for name, c in sim.get("classical", {}).items():
            rows.append(
                f"| classical IBVS, {name}, 25 Hz: >= 1,000x | {_num(c['realtime_factor'], 0)}x | "
                f"{_met(c['realtime_factor'] >= 1000)} | {load(sim)} |"
            )
        robots = {n: r for n, r in sim.get("robots", {}).items() if n != "irb4600"}
        if robots:
            factors = {n: r["paper"]["realtime_factor"] for n, r in robots.items()}
            costs = {n: r["classical"]["cost_vs_irb4600"] for n, r in robots.items()}
            rows.append(
                "| the paper's controller on other arms, dynamic, 1 kHz / 100 Hz: >= 20x real time | "
                + ", ".join(f"{n} {_num(v)}x" for n, v in factors.items())
                + f" | {_met(min(factors.values()) >= 20)} | {load(sim)} |"
            )
            rows.append(
                "| classical IBVS on other arms, kinematic, 25 Hz: <= 1.5x the IRB 4600's cost | "
                + ", ".join(f"{n} {_num(v, 2)}x" for n, v in costs.items())
                + f" | {_met(max(costs.values()) <= 1.5)} | {load(sim)} |"
            )
    peer = reports.get("peers")
    if peer is not None and peer.get("ratios"):
        ratios, ours = peer["ratios"], peer["ours"]
        checks = (  # (ratio, the target, what it says)
            ("depth / visp", lambda x: x <= 3.0, "measured depth: a step <= 3x ViSP's C++ iteration"),
            ("mvtb / depth", lambda x: x >= 20.0, "measured depth: >= 20x faster than MVTB's IBVS.step"),
            ("monocular / visp", lambda x: x <= 6.0, "monocular (PnP depths, SQPnP): a step <= 6x ViSP's"),
            (
                "monocular, IPPE / visp",
                lambda x: x <= 6.0,
                "monocular (PnP depths, `pnp='ippe'`): a step <= 6x ViSP's",
            ),
        )
        for key, ok, what in checks:
            if key in ratios:
                mode = "depth" if "depth" in key else key.split(" / ")[0]
                rows.append(
                    f"| {what} | {_num(ratios[key], 2)}x ({_num(ours[mode]['step_us'])} us) | "
                    f"{_met(ok(ratios[key]))} | {load(peer)} |"
                )
    bat = reports.get("batch")
    if bat is not None and bat.get("ratios"):
        ratio = bat["ratios"]["depth case-frame / visp iteration"]
        rows.append(
            f"| simulate_batch at {bat['ours']['depth']['cases']:,} cases: a case-frame <= ViSP's C++ "
            f"iteration (one core, CPU time) | {_num(ratio, 2)}x "
            f"({_num(bat['ours']['depth']['case_frame_us'], 2)} us) | "
            f"{_met(ratio <= 1.0)} | {load(bat)} |"
        )
    if camp is not None and camp.get("full"):
        full = camp["full"]
        rows.append(
            f"| measured: {full['cases']:,} x 7 free-camera runs of {full['duration_s']:g} s < 1 min "
            f"(2 workers), rows to 1e-9 | {_num(full['minutes'], 2)} min | "
            f"{_met(camp['targets']['met'].get('free_1000x7_measured_minutes'))} | {load(camp)} |"
        )
    if camp is not None and camp.get("pnp_floor"):
        floor, bound = camp["pnp_floor"], camp["targets"]["free_1000x7_measured_minutes_max"]
        rows.append(
            f"| floor of the measured target above: OpenCV's {'/'.join(floor.get('solvers', ['SQPNP']))} "
            "calls alone, 1,000 x 7 free-camera runs "
            f"(2 workers) | {_num(floor['free_1000x7_minutes']['2'], 2)} min | "
            f"{_met(floor['free_1000x7_minutes']['2'] < bound)} | {load(camp)} |"
        )
    if camp is not None and "projection" in camp:
        p = camp["projection"]
        rows.append(
            "| 1,000 x 7 free-camera runs of 20 s < 5 min (2 workers) | "
            f"{_num(p['free_1000x7_minutes']['2'])} min | "
            f"{_met(p['free_1000x7_minutes']['2'] < 5.0)} | {load(camp)} |"
        )
        if "arm_1000x7_minutes" in p:
            rows.append(
                f"| 1,000 x 7 dynamic-arm runs of 20 s at 1 kHz / 100 Hz < 30 min (2 workers) | "
                f"{_num(p['arm_1000x7_minutes']['2'])} min | {_met(p['arm_1000x7_minutes']['2'] < 30.0)} | "
                f"{load(camp)} |"
            )
    if cli_ is not None:
        slowest = cli_["slowest"]
        rows.append(
            f"| every `ibvs-youla` help and argument error answers in < 0.5 s | slowest `{slowest['call']}` "
            f"{_num(slowest['median_ms'], 0)} ms | {_met(slowest['median_ms'] < 500.0)} | {load(cli_)} |"
        )
    return "\n".join(rows) + "\n"


TABLES: dict[str, tuple[str, Callable[[Report], str]]] = {
    "outer_loop": ("outer_loop", outer_loop),
    "simulation": ("simulation", simulation),
    "controllers": ("controllers", controllers),
    "peers": ("peers", peers),
    "batch": ("batch", batch),
    "campaign": ("campaign", campaign),
    "cli": ("cli", cli),
}


def load_reports(folder: Path) -> dict[str, Report | None]:
    """Every report of ``folder`` (None for a missing or unreadable one)."""
    out: dict[str, Report | None] = {}
    for name in TABLES:
        try:
            out[name] = json.loads((folder / f"{name}.json").read_text())
        except (OSError, ValueError):
            out[name] = None
    return out


def update_readme(readme: Path, folder: Path) -> list[str]:
    """Rewrite the README's generated blocks from the reports in ``folder``; return the blocks written."""
    reports = load_reports(folder)
    text = readme.read_text(encoding="utf-8")
    written = []
    blocks = {name: fn for name, (_, fn) in TABLES.items()}
    for name in re.findall(r"<!-- figures:(\w+) -->", text):
        if name == "history":
            body = history(reports)
        elif name == "targets":
            body = targets(reports)
        elif reports.get(name) is None or name not in blocks:
            continue  # no report: the block keeps its previous figures
        else:
            try:
                body = blocks[name](reports[name])  # type: ignore[arg-type]
            except (KeyError, TypeError, IndexError) as err:  # an older report without some key
                body = f"(the report {name}.json lacks {err}: run the benchmark again)\n"
        pattern = re.compile(rf"(<!-- figures:{name} -->\n).*?(<!-- /figures:{name} -->)", re.S)
        text = pattern.sub(lambda m, body=body: m.group(1) + body + m.group(2), text)
        written.append(name)
    readme.write_text(text, encoding="utf-8")
    return written
