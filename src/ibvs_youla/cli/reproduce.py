"""``ibvs-youla reproduce``: rerun the paper's Section 7 (runs, Figures 13-16) and print the table."""

from __future__ import annotations

import argparse

from .base import flag_errors, load_optional_config


def run(args: argparse.Namespace, extra: list[str]) -> int:
    """Rerun Section 7 into ``args.out`` and print the table; return the exit code."""
    from ..analysis.reproduce import reproduce
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
    with flag_errors(args, {"duration": "--duration", "diagnosis_duration": "--diagnosis-duration"}):
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
