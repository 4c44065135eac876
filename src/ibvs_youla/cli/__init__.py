"""The ``ibvs-youla`` command line: reproduce, simulate, design, view, bench.

``ibvs-youla reproduce --out results`` reruns the paper's Section 7 and prints the
table; ``simulate`` runs one scenario and writes the result, its figures and a
summary; ``design`` prints (and with ``--plot`` draws) the inner, feedforward and
outer designs; ``view`` plays a run in Meshcat; ``bench`` runs the benchmarks.
``ibvs-youla <command> --help`` lists the options of each.

Errors print one line ``ibvs-youla: error: ...`` on stderr: bad arguments exit with
2 (argparse's convention), errors raised by the library (``IbvsYoulaError``: a bad
TOML key, a scenario outside the joint limits, a diverged run) exit with 1.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, NoReturn

from . import __version__
from . import scenarios as _scenarios
from .exceptions import IbvsYoulaError, SimulationDivergedError

__all__ = ["main"]

PROG = "ibvs-youla"
DESIGNS = ("inner", "feedforward", "outer", "all")
BENCHMARKS = {"outer": "bench_outer_loop", "simulation": "bench_simulation"}


class _UsageError(Exception):
    """Raised instead of argparse's print-usage-and-exit, so that main prints one line."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise _UsageError(f"{message} (see '{self.prog} --help')")


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value > 0.0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"received {text!r}; valid values are finite numbers > 0")
    return value


def _non_negative(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value >= 0.0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"received {text!r}; valid values are finite numbers >= 0")
    return value


# ----------------------------------------------------------------------------- parser
def _build_parser() -> _Parser:
    parser = _Parser(
        prog=PROG,
        description="Stereo IBVS with feedforward and adaptive Youla control (Li & Assadian): "
        "reproduce the paper, simulate a scenario, inspect the controller designs, view a run, "
        "benchmark. Errors print one line and exit with 2 (bad arguments) or 1.",
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    names = ", ".join(_scenarios.NAMES)

    p = sub.add_parser(
        "reproduce",
        help="rerun the paper's Section 7: runs, Figures 13-16, table",
        description="rerun the paper's Section 7: runs, Figures 13-16, table",
    )
    p.add_argument(
        "--out", type=Path, metavar="DIR", default=Path("results"), help="output folder (default: results)"
    )
    p.add_argument(
        "--scenarios",
        nargs="+",
        choices=_scenarios.NAMES,
        metavar="NAME",
        help=f"scenarios to run, from {names} (default: the paper's two and their physical twins)",
    )
    p.add_argument("--duration", type=_positive, metavar="S", help="simulated time per run [s] (default 20)")
    p.add_argument(
        "--diagnosis-duration",
        type=_non_negative,
        metavar="S",
        default=120.0,
        help="longer horizon [s] for runs that have not reached the target; 0 skips (default 120)",
    )
    p.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="TOML file whose [settings] (over the paper's, unless it names a preset) and [run] "
        "duration apply",
    )
    p.add_argument("--no-resume", action="store_true", help="simulate again even if runs are saved in --out")
    p.set_defaults(func=_cmd_reproduce)

    p = sub.add_parser(
        "simulate",
        help="simulate one scenario; write the result, figures and a summary",
        description="simulate one scenario; write the result, figures and a summary",
    )
    _add_run_options(p, names)
    p.add_argument(
        "--out",
        type=Path,
        metavar="DIR",
        help="output folder (default: results/<scenario>_<controller>_<loop>)",
    )
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser(
        "design",
        help="print (and plot) the inner, feedforward and outer designs",
        description="print (and plot) the inner, feedforward and outer designs",
    )
    p.add_argument("which", nargs="?", default="all", choices=DESIGNS, help="design to show (default: all)")
    p.add_argument(
        "--tau-in", type=_positive, metavar="S", help="inner-loop time constant [s] (default 0.01)"
    )
    p.add_argument(
        "--omega-n", type=_positive, metavar="RAD_S", help="outer-loop natural frequency [rad/s] (default 10)"
    )
    p.add_argument("--zeta", type=_positive, metavar="ZETA", help="outer-loop damping ratio (default 10)")
    p.add_argument(
        "--tau-forward",
        type=_positive,
        metavar="S",
        help="feedforward time constant [s] (default 0.1 tau_in)",
    )
    p.add_argument("--config", type=Path, metavar="FILE", help="TOML file whose [settings] give the defaults")
    p.add_argument("--plot", action="store_true", help="write Bode, step and pole-zero figures to --out")
    p.add_argument(
        "--out",
        type=Path,
        metavar="DIR",
        default=Path("results/design"),
        help="figure folder (default: results/design)",
    )
    p.set_defaults(func=_cmd_design)

    p = sub.add_parser(
        "view",
        help="play a run in the Meshcat 3-D viewer",
        description="play a run in the Meshcat 3-D viewer",
    )
    _add_run_options(p, names)
    p.add_argument(
        "--result", type=Path, metavar="FILE", help="play a saved result (.npz) instead of simulating"
    )
    p.add_argument(
        "--speed", type=_positive, metavar="X", default=1.0, help="playback speed factor (default 1)"
    )
    p.add_argument(
        "--fps", type=_positive, metavar="HZ", default=30.0, help="playback frame rate (default 30)"
    )
    p.add_argument("--zmq-url", help="connect to a running meshcat-server instead of starting one")
    p.add_argument("--open", action="store_true", help="open the viewer in a web browser")
    p.add_argument(
        "--no-wait", action="store_true", help="exit after playing instead of serving until Ctrl-C"
    )
    p.set_defaults(func=_cmd_view)

    p = sub.add_parser(
        "bench",
        help="run the benchmarks in benchmarks/; arguments after -- are passed on to them",
        description="run the benchmarks in benchmarks/; arguments after -- are passed on to them, "
        "e.g. ibvs-youla bench simulation --json out -- --duration 1 --repeats 1",
    )
    p.add_argument("which", nargs="?", default="all", choices=(*BENCHMARKS, "all"), help="default: all")
    p.add_argument("--json", type=Path, metavar="DIR", help="write <benchmark>.json reports here")
    p.set_defaults(func=_cmd_bench)
    return parser


def _add_run_options(p: argparse.ArgumentParser, names: str) -> None:
    p.add_argument("--scenario", choices=_scenarios.NAMES, metavar="NAME", help=f"one of {names}")
    p.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="TOML file with [scenario], [settings], [run], [camera], [arm] (see examples/)",
    )
    p.add_argument(
        "--controller",
        choices=("fb", "ff+fb"),
        help="feedback only or feedforward + feedback (default ff+fb)",
    )
    loop = p.add_mutually_exclusive_group()
    loop.add_argument(
        "--fixed",
        dest="adaptive",
        action="store_false",
        default=None,
        help="evaluate the image Jacobian once (default: adaptive)",
    )
    loop.add_argument("--adaptive", dest="adaptive", action="store_true", help="re-linearize every frame")
    p.add_argument("--duration", type=_positive, metavar="S", help="simulated time [s] (default 10)")


# ----------------------------------------------------------------------------- entry point
def main(argv: list[str] | None = None) -> int:
    """Run the command line; return the exit code (0 success, 1 error, 2 bad arguments)."""
    parser = _build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    extra: list[str] = []
    if "--" in argv:  # bench passes what follows "--" to the benchmark scripts
        argv, extra = argv[: argv.index("--")], argv[argv.index("--") + 1 :]
    try:
        args = parser.parse_args(argv)
        if extra and args.command != "bench":
            parser.error(f"{args.command}: unrecognized arguments after --: {' '.join(extra)}")
    except _UsageError as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return 2
    except SystemExit as exit_:  # --help, --version
        return int(exit_.code or 0)
    try:
        return int(args.func(args, extra))
    except _UsageError as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return 2
    except IbvsYoulaError as err:
        print(f"{PROG}: error: {_one_line(err)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130


def _one_line(err: BaseException) -> str:
    return " ".join(str(err).split())


def _config(path: Path | None, settings_preset: str = "default") -> Any:
    if path is None:
        return None
    from .config import load_config

    return load_config(path, settings_preset=settings_preset)


# ----------------------------------------------------------------------------- reproduce
def _cmd_reproduce(args: argparse.Namespace, extra: list[str]) -> int:
    from .analysis.reproduce import reproduce
    from .exceptions import ConfigError

    cfg = _config(args.config, settings_preset="paper")  # reproduce() runs the paper's settings
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
    rep = reproduce(
        args.out,
        **chosen,
        duration=duration,
        diagnosis_duration=args.diagnosis_duration,
        settings=settings,
        resume=not args.no_resume,
        progress=True,
    )
    print(rep.table_markdown)
    print(f"wrote {len(rep.paths)} files under {args.out}: table.md, table.json, figures/, runs/")
    return 0


# ----------------------------------------------------------------------------- simulate / view
def _resolve_run(args: argparse.Namespace) -> tuple[Any, dict[str, Any], Any, Any]:
    """Scenario, simulate() keyword arguments, arm and camera from --scenario/--config/flags."""
    from .model.arm import Arm
    from .simulation.simulate import default_camera

    cfg = _config(args.config)
    if args.scenario is not None:
        scenario = _scenarios.get(args.scenario)
    elif cfg is not None and cfg.scenario is not None:
        scenario = cfg.scenario
    else:
        raise _UsageError(
            f"{args.command}: give --scenario NAME ({', '.join(_scenarios.NAMES)}) "
            "or --config FILE with a [scenario] table"
        )

    def pick(flag: Any, key: str, default: Any) -> Any:
        if flag is not None:
            return flag
        value = None if cfg is None else getattr(cfg, key)
        return default if value is None else value

    kwargs = {
        "controller": pick(args.controller, "controller", "ff+fb"),
        "adaptive": pick(args.adaptive, "adaptive", True),
        "duration": pick(args.duration, "duration", 10.0),
        "settings": None if cfg is None else cfg.settings,
    }
    arm = Arm.irb4600() if cfg is None else cfg.make_arm()
    camera = default_camera() if cfg is None else cfg.make_camera()
    return scenario, kwargs, arm, camera


def _cmd_simulate(args: argparse.Namespace, extra: list[str]) -> int:
    from .simulation.simulate import simulate

    scenario, kwargs, arm, camera = _resolve_run(args)
    loop = "adaptive" if kwargs["adaptive"] else "fixed"
    out = args.out or Path("results") / f"{scenario.name or 'custom'}_{kwargs['controller']}_{loop}"
    out.mkdir(parents=True, exist_ok=True)
    try:
        result = simulate(scenario, **kwargs, arm=arm, camera=camera, progress=True)
    except SimulationDivergedError as err:
        where = "no samples recorded"
        if err.partial is not None:
            where = f"partial result saved to {err.partial.save(out / 'result_partial.npz')}"
        print(f"{PROG}: error: simulation diverged: {_one_line(err)} ({where})", file=sys.stderr)
        return 1
    path = result.save(out / "result.npz")
    text, summary = _summary(result, arm)
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    written = [path.name, "summary.json"]
    if not args.no_plots:
        from .analysis.plots import save_result_figures

        save_result_figures(result, out / "figures", arm, camera)
        written.append("figures/*.png")
    print(text)
    print(f"wrote {', '.join(written)} in {out}")
    return 0


def _summary(result: Any, arm: Any) -> tuple[str, dict[str, Any]]:
    """One screen of text and the JSON summary of a run."""
    import numpy as np

    from .analysis.convergence import classify
    from .analysis.metrics import overshoot, settling_time, summary
    from .analysis.reproduce import SETTLING_ATOL_M

    meta = result.metadata
    outcome = classify(result)
    s = summary(result, dq_max=arm.dq_max, tau_max=arm.tau_max)
    settle = settling_time(result.t, result.features, y_final=result.feature_target, atol=SETTLING_ATOL_M)
    over = overshoot(result.features, y_final=result.feature_target)
    s.update(outcome=outcome.to_dict(), settling_time_s=[float(v) for v in settle])
    speed, torque = np.asarray(s["peak_joint_speed_ratio"]), np.asarray(s["peak_torque_ratio"])
    ratios = ", ".join(f"{v:.3g}" for v in speed)
    loop = "adaptive" if meta.get("adaptive") else "fixed"
    lines = [
        f"{meta.get('scenario')}: {meta.get('controller')} with the {loop} outer loop, "
        f"{result.duration:g} s simulated (status {meta.get('status')})",
        f"  outcome           {outcome.kind}; max |e| per marker "
        + ", ".join(f"{v:.2g}" for v in outcome.point_errors_m)
        + f" m; ||e|| changed {100 * outcome.error_change:+.2g} % over the last 20 % of the run",
        f"  final image error max |e| = {outcome.final_image_error_m:.3g} m on the sensor",
        f"  final pose error  {outcome.position_error_mm:.3g} mm, {outcome.rotation_error_deg:.3g} deg",
        f"  2 % settling      {np.max(settle):.3g} s (slowest of 9 coordinates; inf = not settled)",
        f"  overshoot         {np.nanmax(over) if np.any(np.isfinite(over)) else np.nan:.3g} % (largest)",
        f"  peak joint speed  {ratios} x limit (max {speed.max():.3g}x, joint {speed.argmax() + 1})",
        f"  peak torque       max {torque.max():.3g}x limit (joint {torque.argmax() + 1})",
        "  markers visible   "
        + ", ".join(f"{100 * v:.0f} %" for v in s["visibility_fraction"])
        + (" (virtual points, ERRATA 13)" if meta.get("virtual_points") else ""),
    ]
    return "\n".join(lines), s


def _cmd_view(args: argparse.Namespace, extra: list[str]) -> int:
    try:
        from .viz import Viewer
    except ImportError as err:
        raise _ViewUnavailable(err) from None
    from .scenarios import Scenario
    from .simulation.results import SimulationResult
    from .simulation.simulate import default_camera

    if args.result is not None:
        if args.scenario or args.config:
            raise _UsageError("view: give either --result FILE or --scenario/--config, not both")
        result = SimulationResult.load(args.result)
        m = result.metadata
        scenario = Scenario(
            m["q_start"],
            m["q_target"],
            m["markers_O"],
            m["joint_offset"],
            name=m["scenario"],
            virtual_points=m["virtual_points"],
        )
        arm, camera = None, default_camera()
    else:
        from .simulation.simulate import simulate

        scenario, kwargs, arm, camera = _resolve_run(args)
        result = simulate(scenario, **kwargs, arm=arm, camera=camera, progress=True)
    viewer = Viewer(arm, camera, zmq_url=args.zmq_url, open_browser=args.open)
    try:
        print(f"playing {scenario.name or 'the run'} at {args.speed:g}x in {viewer.url}", flush=True)
        viewer.show_scenario(scenario)
        viewer.play(result, speed=args.speed, fps=args.fps)
        if not args.no_wait:
            import time

            print("serving; press Ctrl-C to stop", flush=True)
            while True:
                time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        viewer.close()
    return 0


class _ViewUnavailable(IbvsYoulaError):
    def __init__(self, err: ImportError) -> None:
        super().__init__(
            f"view needs the Meshcat viewer (ibvs_youla.viz and meshcat: "
            f"pip install 'ibvs-youla[viz]'), which cannot be imported: {err}"
        )


# ----------------------------------------------------------------------------- bench
def _benchmarks_dir() -> Path:
    import ibvs_youla

    return Path(ibvs_youla.__file__).resolve().parents[2] / "benchmarks"


def _cmd_bench(args: argparse.Namespace, extra: list[str]) -> int:
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
                raise _UsageError(f"bench: {module_name} rejected {' '.join(argv)}") from None
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


# ----------------------------------------------------------------------------- design
def _cmd_design(args: argparse.Namespace, extra: list[str]) -> int:
    from .analysis.design_report import describe_design, plot_design_of
    from .control.feedforward import FeedforwardDesign
    from .control.inner import InnerLoopDesign
    from .control.outer import OuterLoopDesign
    from .simulation.settings import SimulationSettings

    cfg = _config(args.config)
    base = SimulationSettings() if cfg is None else cfg.settings
    tau_in = args.tau_in if args.tau_in is not None else base.tau_in
    omega_n = args.omega_n if args.omega_n is not None else base.omega_n
    zeta = args.zeta if args.zeta is not None else base.zeta
    tau_forward = (
        args.tau_forward
        if args.tau_forward is not None
        else (base.tau_forward if args.tau_in is None else None)
    )
    inner = InnerLoopDesign(tau_in)
    ff = FeedforwardDesign(tau_in, tau_forward)
    outer = OuterLoopDesign(omega_n, zeta, tau_in, base.sv_policy)
    which = DESIGNS[:3] if args.which == "all" else (args.which,)
    designs = {"inner": inner, "feedforward": ff, "outer": outer}
    print("\n\n".join(describe_design(designs[w]) for w in which))
    if args.plot:
        args.out.mkdir(parents=True, exist_ok=True)
        for w in which:
            path = args.out / f"{w}.png"
            plot_design_of(designs[w]).savefig(path, dpi=110)
            print(f"wrote {path}")
    return 0
