"""``ibvs-youla simulate``: run one scenario; write the result, its figures and a summary.

:func:`resolve_run` (scenario, arm, camera and ``simulate()`` options from ``--scenario``,
``--config`` and the flags) is shared with ``view``. The output folder is created only once the
run has ended: a run refused (a plant the controller cannot drive) leaves nothing behind.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .. import catalog
from .base import PROG, UsageError, arm_flags, flag_errors, load_optional_config, one_line, resolve_arm

# what null stands for in summary.json (strict JSON)
SUMMARY_NULL = "never, for a settling time; not measured or not applicable, for any other value"
FLAGS = {"duration": "--duration", "controller": "--controller", "plant": "--plant", "seed": "--seed"}


def resolve_run(args: argparse.Namespace) -> tuple[Any, dict[str, Any], Any, Any]:
    """Scenario, simulate() keyword arguments, arm and camera from --scenario/--config/flags.

    The arm is the flags' (``--robot``, ``--urdf``, the mount) over the config's ``[arm]``,
    default the IRB 4600; the scenario ``--scenario`` (the IRB 4600's), the config's
    ``[scenario]``, or, with an arm or a mount given and no scenario named, the arm's seeded
    scenario (:func:`ibvs_youla.scenarios.for_arm`, ``--seed`` or ``[scenario] seed``; eye-to-hand,
    ``--mount eye-to-hand`` or ``[scenario] mount``: :func:`ibvs_youla.scenarios.eye_to_hand`).

    Raises:
        UsageError: no scenario, a named scenario on another arm, ``--seed`` with a scenario, an
            eye-to-hand mount with a scenario of joints and markers (those are eye-in-hand) or on the
            free camera, or a controller that cannot drive the plant (the free camera takes camera
            twists only).
    """
    from .. import controllers
    from .. import scenarios as _scenarios
    from ..controllers import CommandType

    cfg = load_optional_config(args.config)
    arm = resolve_arm(args, cfg)
    camera = default_camera_of(cfg)
    arm_given = bool(arm_flags(args)) or (cfg is not None and bool(cfg.arm_options))
    seed = None if cfg is None else cfg.scenario_seed
    mount_given = getattr(args, "mount", None) or (None if cfg is None else cfg.scenario_mount)
    mount = mount_given or "eye-in-hand"
    if mount == "eye-to-hand" and (
        args.scenario is not None or (cfg is not None and cfg.scenario is not None)
    ):
        what = (
            f"--scenario {args.scenario}" if args.scenario is not None else f"the [scenario] of {args.config}"
        )
        source = "argument --mount" if getattr(args, "mount", None) else f"scenario.mount in {args.config}"
        raise UsageError(
            f"{source}: received 'eye-to-hand' with {what}, an eye-in-hand scenario (markers "
            "fixed in the base); valid: leave the scenario out for the arm's seeded eye-to-hand scenario "
            "(--seed)"
        )
    if args.seed is not None and (
        args.scenario is not None or (cfg is not None and cfg.scenario is not None)
    ):
        raise UsageError(
            f"argument --seed: the seed of the arm's scenario; valid only without --scenario and a "
            f"[scenario] table (received --seed {args.seed} with a scenario)"
        )
    if args.scenario is not None:
        if arm.robot != "irb4600":
            raise UsageError(
                f"argument --scenario: received {args.scenario!r}, a scenario of the IRB 4600 (its joint "
                f"angles and markers); for the arm {arm.name!r} leave --scenario out: its seeded "
                "scenario (--seed)"
            )
        scenario = _scenarios.get(args.scenario)
    elif cfg is not None and cfg.scenario is not None:
        scenario = cfg.scenario
    elif args.seed is not None or seed is not None or arm_given or mount_given:
        if arm.robot is None:
            raise UsageError(
                f"{args.command}: the arm of {arm.name!r} (a URDF) has no home configuration to draw a "
                "seeded scenario about; valid: its scenario in a --config file's [scenario] table "
                "(q_start_deg, q_target_deg, markers_O)"
            )
        seeded = _scenarios.eye_to_hand if mount == "eye-to-hand" else _scenarios.for_arm
        scenario = seeded(arm, args.seed if args.seed is not None else (seed or 0), camera=camera)
    else:
        raise UsageError(
            f"{args.command}: give --scenario NAME ({', '.join(catalog.SCENARIOS)}), --config FILE with a "
            "[scenario] table, or an arm (--robot NAME, --urdf FILE) for its seeded scenario"
        )

    def pick(flag: Any, key: str, default: Any) -> Any:
        if flag is not None:
            return flag
        value = None if cfg is None else getattr(cfg, key)
        return default if value is None else value

    kwargs = {
        "controller": pick(args.controller, "controller", "ff+fb"),
        "plant": pick(getattr(args, "plant", None), "plant", "dynamic"),
        "adaptive": pick(args.adaptive, "adaptive", True),
        "duration": pick(args.duration, "duration", 10.0),
        "settings": None if cfg is None else cfg.settings,
    }
    if kwargs["plant"] == "free-camera" and scenario.is_eye_to_hand:
        raise UsageError(
            f"{args.command}: an eye-to-hand scenario moves the arm that carries the markers; valid: an arm "
            "plant (--plant dynamic or kinematic)"
        )
    if kwargs["plant"] == "free-camera":
        command = controllers.make(kwargs["controller"]).command_type
        if command is not CommandType.CAMERA_TWIST:
            twist = [
                n for n in controllers.names() if controllers.make(n).command_type == CommandType.CAMERA_TWIST
            ]
            raise UsageError(
                f"{args.command}: the 'free-camera' plant takes camera twists and {kwargs['controller']} "
                f"commands {command.value}; valid: an arm plant (--plant dynamic or kinematic), or a "
                f"controller that commands a camera twist: {', '.join(twist)}"
            )
    if kwargs["plant"] != "free-camera" and scenario.has_joints:
        scenario.validate_for(arm)  # JointLimitError: a [scenario] outside the arm's limits
    return scenario, kwargs, arm, camera


def default_camera_of(cfg: Any) -> Any:
    """The camera of the config's ``[camera]``, else the simulator's default (the ZED 2)."""
    from ..model.camera import default_camera

    return default_camera() if cfg is None else cfg.make_camera()


def config_keys(args: argparse.Namespace) -> dict[str, str]:
    """Where each run option came from when the ``--config`` file gave it (for :func:`flag_errors`)."""
    if args.config is None:
        return {}
    return {
        name: f"run.{name} in {args.config}"
        for name in ("controller", "plant", "duration")
        if getattr(args, name, None) is None
    }


def prepare(args: argparse.Namespace, extra: list[str]) -> Callable[[], int]:
    """The scenario, controller, arm and camera of the run, checked; return the function that runs it."""
    scenario, kwargs, arm, camera = resolve_run(args)
    loop = "adaptive" if kwargs["adaptive"] else "fixed"
    out = args.out or Path("results") / f"{scenario.name or 'custom'}_{kwargs['controller']}_{loop}"
    return lambda: _run(args, scenario, kwargs, arm, camera, out)


def _run(
    args: argparse.Namespace, scenario: Any, kwargs: dict[str, Any], arm: Any, camera: Any, out: Path
) -> int:
    """Simulate, then write result.npz, summary.json and the figures into ``out``; return the exit code."""
    from ..exceptions import SimulationDivergedError
    from ..files import write_json
    from ..simulation.simulate import simulate

    try:
        with flag_errors(args, FLAGS, config_keys(args)):
            result = simulate(scenario, **kwargs, arm=arm, camera=camera, progress=True)
    except SimulationDivergedError as err:
        where = "no samples recorded"
        if err.partial is not None:
            out.mkdir(parents=True, exist_ok=True)
            where = f"partial result saved to {err.partial.save(out / 'result_partial.npz')}"
        print(f"{PROG}: error: simulation diverged: {one_line(err)} ({where})", file=sys.stderr)
        return 1
    out.mkdir(parents=True, exist_ok=True)
    path = result.save(out / "result.npz")
    text, summary = _summary(result, arm)
    write_json(out / "summary.json", {"null": SUMMARY_NULL, **summary})
    written = [path.name, "summary.json"]
    if not args.no_plots:
        from ..analysis.plots import save_result_figures

        save_result_figures(result, out / "figures", arm, camera)
        written.append("figures/*.png")
    print(text)
    print(f"wrote {', '.join(written)} in {out}")
    return 0


def _summary(result: Any, arm: Any) -> tuple[str, dict[str, Any]]:
    """One screen of text and the JSON summary of a run."""
    import numpy as np

    from ..analysis.convergence import classify
    from ..analysis.metrics import overshoot, settling_time, summary
    from ..analysis.reproduce import SETTLING_ATOL_M

    meta = result.metadata
    outcome = classify(result)
    s = summary(result, dq_max=arm.dq_max, tau_max=arm.tau_max)
    settle = settling_time(result.t, result.features, y_final=result.feature_target, atol=SETTLING_ATOL_M)
    over = overshoot(result.features, y_final=result.feature_target)
    s.update(outcome=outcome.to_dict(), settling_time_s=[float(v) for v in settle])
    speed, torque = (
        np.asarray(s[k] if s[k] is not None else [np.nan])
        for k in ("peak_joint_speed_ratio", "peak_torque_ratio")
    )
    ratios = ", ".join(f"{v:.3g}" for v in speed)
    adaptive = meta.get("adaptive")  # None for controllers other than the paper's
    loop = "" if adaptive is None else f" with the {'adaptive' if adaptive else 'fixed'} outer loop"
    lines = [
        f"{meta.get('scenario')}: {meta.get('controller')}{loop} on the "
        f"{meta.get('plant', 'dynamic')} plant, {result.duration:g} s simulated "
        f"(status {meta.get('status')})",
        f"  outcome           {outcome.kind}; max |e| per marker "
        + ", ".join(f"{v:.2g}" for v in outcome.point_errors_m)
        + f" m; ||e|| changed {100 * outcome.error_change:+.2g} % over the last "
        + f"{100 * outcome.window:.0f} % of the run",
        f"  final image error max |e| = {outcome.final_image_error_m:.3g} m on the sensor",
        f"  final pose error  {outcome.position_error_mm:.3g} mm, {outcome.rotation_error_deg:.3g} deg",
        f"  2 % settling      {np.max(settle):.3g} s (slowest of {result.features.shape[1]} coordinates; "
        "inf = not settled)",
        f"  overshoot         {np.nanmax(over) if np.any(np.isfinite(over)) else np.nan:.3g} % (largest)",
        f"  peak joint speed  {ratios} x limit (max {speed.max():.3g}x, joint {speed.argmax() + 1})",
        f"  peak torque       max {torque.max():.3g}x limit (joint {torque.argmax() + 1})"
        if np.isfinite(torque).all()
        else "  peak torque       none (this plant takes no torque)",
        "  markers visible   "
        + ", ".join(f"{100 * v:.0f} %" for v in s["visibility_fraction"])
        + (" (virtual points, ERRATA 13)" if meta.get("virtual_points") else ""),
    ]
    return "\n".join(lines), s
