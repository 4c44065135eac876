"""Reproduce the paper's Section 7: both scenarios, every controller variant, figures and a table.

For every scenario x {feedback only, feedforward + feedback} x {fixed, adaptive outer
loop} it simulates ``duration`` seconds with the paper's settings, saves the run as
soon as it finishes (a re-run resumes from the saved runs, so a long job loses no
finished work), redraws Figures 13-16 and writes one table (Markdown and JSON,
:mod:`.reproduction_table`) with, per run: final image error per coordinate, final camera
pose error (mm, deg), 2 % settling time, overshoot, peak joint speed and torque against
the IRB 4600's limits, and marker visibility.

Files, interruption and resume: every file is written atomically (a temporary file in
the same folder, renamed into place: :mod:`ibvs_youla.files`), so a job killed at any
point leaves each file whole or absent. One process at a time writes an output folder:
it holds ``out_dir/.lock`` (with its pid) and a second one is refused with
:class:`~ibvs_youla.exceptions.FolderLockedError` (the command exits with 1); the lock
dies with its holder. A resuming job reuses each saved run of the same scenario,
controller, outer loop, settings and number of joint periods; a run file that is damaged
or holds another run is simulated again, and the job says so in one line on stderr
(logger ``ibvs_youla.analysis.reproduce``).

A run that has not reached its target at ``duration`` is simulated again for
``diagnosis_duration`` seconds, so that the table says whether it was merely slow or
stalled in a local minimum (:mod:`.convergence`). Nothing is tuned to make the
paper's claims come true; the table and :func:`findings` state what was measured.
"""

from __future__ import annotations

import json
import logging
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from .._validation import flag, instance, non_negative, one_of, positive
from ..controllers.youla import VARIANTS
from ..exceptions import DamagedFileError, InvalidParameterError, SimulationDivergedError
from ..files import folder_lock, remove_temporaries, save_figure, write_json, write_text
from ..model.arm import Arm
from ..scenarios import NAMES
from ..scenarios import get as get_scenario
from ..simulation.results import SimulationResult
from ..simulation.settings import SimulationSettings
from ..simulation.simulate import simulate
from .convergence import classify
from .paper_figures import plot_image_comparison, plot_joint_comparison
from .reproduction_table import NULL_MEANS, SETTLING_ATOL_M, findings, table_markdown, table_row

__all__ = ["PAPER_FIGURES", "SETTLING_ATOL_M", "Reproduction", "findings", "reproduce", "run_key"]

# Which paper figures a scenario's comparison plots correspond to (joints, image).
PAPER_FIGURES = {"paper-1": (13, 14), "paper-2": (15, 16)}
_LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class Reproduction:
    """What :func:`reproduce` produced.

    Attributes:
        rows: One JSON-friendly dict per run (scenario x controller x outer loop).
        table_markdown: The table and the findings as Markdown.
        paths: Written files by name (``"table_md"``, ``"table_json"``, figures, runs).
    """

    rows: tuple[dict[str, Any], ...]
    table_markdown: str
    paths: dict[str, Path]


def run_key(scenario: str, controller: str, adaptive: bool, suffix: str = "") -> str:
    """File stem of a saved run, e.g. ``paper-1__ff+fb__adaptive``."""
    return f"{scenario}__{controller}__{'adaptive' if adaptive else 'fixed'}{suffix}"


def _saved(
    path: Path,
    scenario_name: str,
    controller: str,
    adaptive: bool,
    n_ticks: int,
    settings: SimulationSettings,
) -> SimulationResult | None:
    """The run saved at ``path`` if it is this run, else None (saying why in one line if a file is there)."""
    if not path.exists():
        return None
    try:
        old = SimulationResult.load(path)
    except DamagedFileError as err:
        _LOG.warning("ibvs-youla: %s: %s; simulating this run again", path, err.problem)
        return None
    meta = old.metadata
    stored_ticks = meta.get("duration")
    if isinstance(stored_ticks, (int, float)):
        stored_ticks = round(stored_ticks / settings.dt)
    wanted = {
        "scenario": (meta.get("scenario"), scenario_name),
        "controller": (meta.get("controller"), controller),
        "adaptive": (meta.get("adaptive"), adaptive),
        "plant": (meta.get("plant"), "dynamic"),
        "virtual_points": (meta.get("virtual_points"), get_scenario(scenario_name).virtual_points),
        "joint periods": (stored_ticks, n_ticks),
        "settings": (meta.get("settings"), json.loads(json.dumps(settings.to_dict()))),
    }
    differ = [name for name, (stored, asked) in wanted.items() if stored != asked]
    if differ:
        _LOG.warning(
            "ibvs-youla: %s holds another run (different %s); simulating this run again",
            path,
            ", ".join(differ),
        )
        return None
    return old


def _run(
    path: Path,
    scenario_name: str,
    controller: str,
    adaptive: bool,
    n_ticks: int,
    settings: SimulationSettings,
    arm: Arm,
    resume: bool,
    progress: bool,
) -> SimulationResult:
    """Load a finished run from ``path`` if it matches, else simulate it and save it at once."""
    old = _saved(path, scenario_name, controller, adaptive, n_ticks, settings) if resume else None
    if old is not None:
        return old
    try:
        result = simulate(
            get_scenario(scenario_name),
            controller=controller,
            adaptive=adaptive,
            duration=n_ticks * settings.dt,
            settings=settings,
            arm=arm,
            progress=progress,
        )
    except SimulationDivergedError as err:
        if err.partial is None:
            raise
        result = err.partial
    result.save(path)
    return result


def _periods(value: float, name: str, dt: float) -> int:
    """Whole joint periods in ``value`` seconds (rounded to the nearest; module docstring)."""
    n_ticks = round(value / dt)
    if n_ticks < 1:
        raise InvalidParameterError(name, value, f"at least one joint period, {dt:g} s")
    if abs(value / dt - n_ticks) > 1e-6:
        _LOG.warning(
            "ibvs-youla: %s = %g s is not a whole number of joint periods (%g s): running %g s (%d periods)",
            name,
            value,
            dt,
            n_ticks * dt,
            n_ticks,
        )
    return n_ticks


def reproduce(
    out_dir: str | Path,
    *,
    scenario_names: tuple[str, ...] | list[str] = ("paper-1", "paper-2", "physical-1", "physical-2"),
    duration: float = 20.0,
    diagnosis_duration: float = 120.0,
    settings: SimulationSettings | None = None,
    resume: bool = True,
    progress: bool = False,
    plots: bool = True,
) -> Reproduction:
    """Simulate every variant of the given scenarios and write figures and the table.

    Durations are whole numbers of joint periods (``settings.dt``): a duration that is not
    one is rounded to the nearest (0.0505 s at 1 kHz runs 50 periods, 0.05 s), the job says
    so in one line, and the rounded value is what each run records (``metadata["duration"]``),
    what the table shows, what ``table.json`` stores next to the requested one
    (``"duration_s": {"requested": ..., "run": ...}``) and what resuming compares.

    ``table.json`` is strict JSON (RFC 8259: no ``Infinity`` or ``NaN``); a time that never came
    (not settled, never reached) is ``null``, as its key ``"null"`` says (:data:`NULL_MEANS`).

    Args:
        out_dir: Output folder; ``runs/``, ``figures/``, ``table.md`` and ``table.json``
            are written under it (atomically, one process at a time: module docstring).
        scenario_names: Names known to :func:`ibvs_youla.scenarios.get`; default the paper's two
            scenarios with its virtual markers and their physical twins (ERRATA 13).
        duration: Simulated time of each run [s] (the figures and the table), at least one
            joint period.
        diagnosis_duration: Longer horizon [s] for runs that have not reached the target;
            0 (or <= duration) skips the diagnosis.
        settings: Simulation settings; default :meth:`SimulationSettings.paper` (both loops
            at 1 kHz, the paper's gains).
        resume: Reuse the runs already saved in ``out_dir/runs`` that are whole and match
            (scenario, controller, outer loop, settings, joint periods); the others run again.
        progress: Show progress bars.
        plots: Draw Figures 13-16 (``figures/``); False writes the runs and the table only.

    Returns:
        The rows, the Markdown table and the written paths.

    Raises:
        InvalidParameterError: no scenario, an unknown one, or a duration under one joint period.
        FolderLockedError: another process is writing ``out_dir``.
    """
    duration = positive(duration, "duration", unit="s")
    diagnosis_duration = non_negative(diagnosis_duration, "diagnosis_duration", unit="s")
    if isinstance(scenario_names, str) or not isinstance(scenario_names, (list, tuple)) or not scenario_names:
        raise InvalidParameterError("scenario_names", scenario_names, "a list of one or more scenario names")
    for name in scenario_names:
        one_of(name, "scenario", NAMES)  # before anything is written
    if settings is not None:
        instance(settings, "settings", SimulationSettings, "a SimulationSettings or None")
    resume, progress = flag(resume, "resume"), flag(progress, "progress")
    instance(out_dir, "out_dir", (str, os.PathLike), "a folder path (str or pathlib.Path)")
    settings = SimulationSettings.paper() if settings is None else settings
    n_ticks = _periods(duration, "duration", settings.dt)
    n_long = _periods(diagnosis_duration, "diagnosis_duration", settings.dt) if diagnosis_duration else 0
    for name in scenario_names:
        get_scenario(name)  # fail early on an unknown name
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with folder_lock(out):
        for folder in (out, out / "runs", out / "figures"):
            folder.mkdir(exist_ok=True)
            remove_temporaries(folder)  # what a killed job left half-written
        rows, paths = _simulate_all(out, scenario_names, n_ticks, n_long, settings, resume, progress, plots)
        run_s, long_s = n_ticks * settings.dt, n_long * settings.dt
        markdown = table_markdown(rows, run_s, long_s)
        paths["table_md"] = write_text(out / "table.md", markdown)
        table = {
            "null": NULL_MEANS,
            "rows": rows,
            "findings": findings(rows),
            "duration_s": {"requested": duration, "run": run_s},
            "diagnosis_duration_s": {"requested": diagnosis_duration, "run": long_s},
        }
        paths["table_json"] = write_json(out / "table.json", table, default=str)
    return Reproduction(rows=tuple(rows), table_markdown=markdown, paths=paths)


def _simulate_all(
    out: Path,
    scenario_names: tuple[str, ...] | list[str],
    n_ticks: int,
    n_long: int,
    settings: SimulationSettings,
    resume: bool,
    progress: bool,
    plots: bool,
) -> tuple[list[dict[str, Any]], dict[str, Path]]:
    """Every run (saved as it finishes), its row, and the figures of each scenario and outer loop."""
    arm = Arm.irb4600()
    paths: dict[str, Path] = {}
    rows: list[dict[str, Any]] = []
    long_settings = replace(settings, record_every=max(settings.record_every, 10))
    for name in scenario_names:
        by_variant: dict[tuple[str, bool], SimulationResult] = {}
        for adaptive in (False, True):
            for controller in VARIANTS:
                key = run_key(name, controller, adaptive)
                path = paths[f"run:{key}"] = out / "runs" / f"{key}.npz"
                result = _run(path, name, controller, adaptive, n_ticks, settings, arm, resume, progress)
                by_variant[(controller, adaptive)] = result
                outcome = classify(result)
                extended = None
                if outcome.kind in ("stalled", "converging") and n_long > n_ticks:
                    long_key = run_key(name, controller, adaptive, f"__{n_long * settings.dt:g}s")
                    long_path = paths[f"run:{long_key}"] = out / "runs" / f"{long_key}.npz"
                    long_result = _run(
                        long_path, name, controller, adaptive, n_long, long_settings, arm, resume, progress
                    )
                    extended = classify(long_result)
                rows.append(table_row(result, outcome, extended, arm))
            if plots:
                paths.update(_figures(out / "figures", name, adaptive, by_variant))
    return rows, paths


def _figures(
    folder: Path, name: str, adaptive: bool, by_variant: dict[tuple[str, bool], SimulationResult]
) -> dict[str, Path]:
    mode = "adaptive" if adaptive else "fixed"
    fig_joints, fig_image = PAPER_FIGURES.get(name, (None, None))
    fb, ffb = by_variant[("fb", adaptive)], by_variant[("ff+fb", adaptive)]
    written = {}
    for kind, plot, number in (
        ("joints", plot_joint_comparison, fig_joints),
        ("image", plot_image_comparison, fig_image),
    ):
        what = "joint angles" if kind == "joints" else "image coordinates"
        label = f"Figure {number} ({name}, {mode} outer loop)" if number else f"{name}, {mode} outer loop"
        fig = plot(fb, ffb, f"{label}: {what}")
        # a pyplot-free Figure: nothing to close, freed with the reference
        path = save_figure(fig, folder / f"{name}_{mode}_{kind}.png", dpi=110)
        written[f"figure:{name}_{mode}_{kind}"] = path
    return written
