"""``ibvs-youla reproduce``: rerun the paper's Section 7 (runs, Figures 13-16) and print the table."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from .base import flag_errors, load_optional_config

FLAGS = {"duration": "--duration", "diagnosis_duration": "--diagnosis-duration"}


def prepare(args: argparse.Namespace, extra: list[str]) -> Callable[[], int]:
    """The settings and duration from ``--config`` and the flags, checked; return the function that runs."""
    from ..exceptions import ConfigError

    # reproduce() runs the paper's settings
    cfg = load_optional_config(args.config, settings_preset="paper")
    settings, duration = None, args.duration
    if cfg is not None:
        given = {
            "scenario": None if cfg.scenario is None else cfg.scenario.name,
            "run.controller": cfg.controller,
            "run.adaptive": cfg.adaptive,
            "camera": dict(cfg.camera_options) or None,
            "arm": dict(cfg.arm_options) or None,
        }
        for key, value in given.items():
            if value is not None:
                raise ConfigError(
                    key,
                    value,
                    f"nothing in {cfg.source}: reproduce reads only [settings] and [run] duration; it runs "
                    "every controller variant of --scenarios with the default arm and camera",
                )
        settings = cfg.settings
        duration = duration if duration is not None else cfg.duration
    duration = 20.0 if duration is None else duration
    chosen = {} if args.scenarios is None else {"scenario_names": tuple(args.scenarios)}
    return lambda: _run(args, chosen, duration, settings)


def _run(args: argparse.Namespace, chosen: dict[str, Any], duration: float, settings: Any) -> int:
    """Rerun Section 7 into ``args.out`` and print the table; return 0."""
    from ..analysis.reproduce import reproduce

    from_config = (
        {}
        if args.config is None or args.duration is not None
        else {"duration": f"run.duration in {args.config}"}
    )
    with flag_errors(args, FLAGS, from_config):
        rep = reproduce(
            args.out,
            **chosen,
            duration=duration,
            diagnosis_duration=args.diagnosis_duration,
            settings=settings,
            resume=not args.no_resume,
            progress=True,
            plots=not args.no_plots,
        )
    print(rep.table_markdown)
    figures = "" if args.no_plots else " figures/,"
    print(f"wrote {len(rep.paths)} files under {args.out}: table.md, table.json,{figures} runs/")
    return 0
