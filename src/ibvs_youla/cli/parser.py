"""The argument definitions of ``ibvs-youla`` and its subcommands."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, NoReturn

from .. import __version__, controllers
from .. import scenarios as _scenarios
from ..simulation.simulate import PLANTS
from . import bench, campaign, campaign_report, compare, design, reproduce, robustness, simulate, view
from .base import PROG, UsageError, folder_path


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{message} (see '{self.prog} --help')")


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


def build_parser() -> argparse.ArgumentParser:
    """The parser of the whole command line; each subcommand sets ``func(args, extra) -> int``."""
    parser = _Parser(
        prog=PROG,
        description="Stereo IBVS with feedforward and adaptive Youla control (Li & Assadian): "
        "reproduce the paper, simulate a scenario, compare methods, run seeded campaigns and robustness "
        "studies, inspect the "
        "controller designs, view a run, benchmark. Errors print one line and exit with 2 (bad arguments) "
        "or 1.",
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    parser.add_argument(
        "--debug",
        action="store_true",
        help="on an error, print the traceback too (accepted anywhere before --)",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    names = ", ".join(_scenarios.NAMES)

    p = sub.add_parser(
        "reproduce",
        help="rerun the paper's Section 7: runs, Figures 13-16, table",
        description="rerun the paper's Section 7: runs, Figures 13-16, table",
    )
    p.add_argument(
        "--out",
        type=folder_path,
        metavar="DIR",
        default=Path("results"),
        help="output folder (default: results)",
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
    p.add_argument("--no-plots", action="store_true", help="skip Figures 13-16 (runs and table only)")
    p.set_defaults(func=reproduce.run)

    p = sub.add_parser(
        "simulate",
        help="simulate one scenario; write the result, figures and a summary",
        description="simulate one scenario; write the result, figures and a summary",
    )
    _add_run_options(p, names)
    p.add_argument(
        "--out",
        type=folder_path,
        metavar="DIR",
        help="output folder (default: results/<scenario>_<controller>_<loop>)",
    )
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.set_defaults(func=simulate.run)

    p = sub.add_parser(
        "design",
        help="print (and plot) the inner, feedforward and outer designs",
        description="print (and plot) the inner, feedforward and outer designs",
    )
    p.add_argument(
        "which", nargs="?", default="all", choices=design.DESIGNS, help="design to show (default: all)"
    )
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
        type=folder_path,
        metavar="DIR",
        default=Path("results/design"),
        help="figure folder (default: results/design)",
    )
    p.set_defaults(func=design.run)

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
    p.add_argument(
        "--zmq-timeout",
        type=_positive,
        metavar="S",
        default=5.0,
        help="give up if the --zmq-url server has not answered after S seconds (default 5)",
    )
    p.add_argument("--open", action="store_true", help="open the viewer in a web browser")
    p.add_argument(
        "--no-wait", action="store_true", help="exit after playing instead of serving until Ctrl-C"
    )
    p.set_defaults(func=view.run)

    p = sub.add_parser(
        "bench",
        help="run the benchmarks in benchmarks/; arguments after -- are passed on to them",
        description="run the benchmarks in benchmarks/; arguments after -- are passed on to them, "
        "e.g. ibvs-youla bench simulation --json out -- --duration 1 --repeats 1",
    )
    p.add_argument("which", nargs="?", default="all", choices=(*bench.BENCHMARKS, "all"), help="default: all")
    p.add_argument("--json", type=folder_path, metavar="DIR", help="write <benchmark>.json reports here")
    p.set_defaults(func=bench.run)

    p = sub.add_parser(
        "compare",
        help="run several controllers on one scenario, or the Gans 2003 suite; tables and figures",
        description="run several controllers on one scenario (side-by-side figures and a table: status, "
        "time to converge, final pose error, camera path, peak joint speed, update time), or every task "
        "of the Gans, Hutchinson & Corke 2003 suite with every twist controller",
    )
    which = p.add_mutually_exclusive_group(required=True)
    which.add_argument(
        "--scenario",
        choices=compare.scenario_names(),
        metavar="NAME",
        help=f"one of {names}, a task of the suite: "
        + ", ".join(compare.scenario_names()[len(_scenarios.NAMES) : -1])
        + f", or {compare.TEXTURED} (a textured plane, for photometric servoing)",
    )
    which.add_argument("--suite", choices=("gans2003",), help="run every task of the suite: gans2003")
    p.add_argument(
        "--controllers",
        type=compare.controller_list,
        metavar="A,B,...",
        help=f"comma-separated, from {', '.join(controllers.names())} (default: every one that can run: "
        "all but photometric on an arm scenario, the camera-twist ones but photometric on a suite task, "
        "the camera-twist ones on the textured plane)",
    )
    p.add_argument(
        "--plant",
        choices=PLANTS,
        help="dynamic (default for an arm scenario), kinematic or free-camera (default, and the only "
        "choice, for the suite)",
    )
    p.add_argument(
        "--duration",
        type=_positive,
        metavar="S",
        help="simulated time per run [s] (default 10 on an arm scenario, 30 for the suite)",
    )
    p.add_argument(
        "--camera-rate",
        type=_positive,
        metavar="HZ",
        help="camera and control rate [Hz] (default 100 on an arm scenario, 25 for the suite)",
    )
    p.add_argument(
        "--out",
        type=folder_path,
        metavar="DIR",
        help="output folder (default: results/compare/<scenario or suite>)",
    )
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.set_defaults(func=compare.run)

    _add_campaign(sub)
    p = sub.add_parser(
        "campaign-report",
        help="tables and figures of a campaign folder",
        description="tables and figures of a campaign folder",
    )
    campaign_report.configure(p)
    p.set_defaults(func=campaign_report.run)
    p = sub.add_parser(
        "robustness",
        help="sweep one disturbance (noise, images, calibration, mismatch, latency, saturation) "
        "over seeded cases",
        description="sweep one disturbance over the same seeded campaign cases, every method, on this "
        "machine's cores or a Dask cluster (one campaign per value in OUT/<axis>=<value>, resumable), then "
        "write a table and figures: success with 95 % Wilson intervals, final pose error and time to "
        "reach against the value",
    )
    robustness.configure(p, _positive)
    return parser


def _add_campaign(sub: Any) -> None:
    from ..campaign.cases import FAMILIES
    from ..campaign.spec import CAMERA_KINDS

    p = sub.add_parser(
        "campaign",
        help="run every method on the same seeded cases, on this machine's cores or a Dask cluster",
        description="run every method on the same seeded cases, on this machine's cores (one process per "
        "core) or an existing Dask cluster; rows go to OUT/rows (Parquet) as they finish, and the same "
        "command resumes an interrupted campaign",
    )
    p.add_argument("--cases", type=campaign.count(1), required=True, metavar="N", help="number of cases")
    p.add_argument(
        "--controllers",
        type=campaign.method_list,
        metavar="A,B,...",
        help=f"comma-separated methods, from {', '.join(controllers.names())}, each optionally with "
        "parameters: NAME[KEY=VALUE,...], e.g. fb[adaptive=false] (default: every one the plant takes; "
        "fb and ff+fb command joints and need an arm plant)",
    )
    p.add_argument(
        "--family",
        choices=FAMILIES,
        default="arm-physical",
        help="case family (default arm-physical); the arm families run on an arm plant, the free ones on "
        "the free camera",
    )
    p.add_argument(
        "--plant",
        choices=PLANTS,
        help="default: dynamic for an arm family (or kinematic: an ideal inner loop); free-camera, the only "
        "choice, for a free family",
    )
    p.add_argument(
        "--camera",
        choices=CAMERA_KINDS,
        help="default: stereo (ZED 2) for an arm family, normalized (F = 1) for a free one, pinhole "
        "(120 x 90 px) for free-textured",
    )
    p.add_argument(
        "--duration",
        type=_positive,
        metavar="S",
        help="simulated time per run [s] (default 20 for an arm family, 30 for a free one; "
        "camera at 100 Hz on an arm, 25 Hz on the free camera)",
    )
    p.add_argument("--seed", type=campaign.seed, default=0, metavar="S", help="integer >= 0 (default 0)")
    p.add_argument(
        "--difficulty",
        type=_positive,
        default=1.0,
        metavar="X",
        help="scales the start-target rotation and translation (default 1)",
    )
    p.add_argument("--out", type=folder_path, required=True, metavar="DIR", help="campaign folder")
    p.add_argument(
        "--scheduler",
        type=campaign.scheduler_address,
        metavar="ADDRESS",
        help="an existing Dask scheduler, e.g. tcp://127.0.0.1:8786 (default: a local cluster)",
    )
    p.add_argument(
        "--workers",
        type=campaign.count(0),
        metavar="K",
        help="processes of the local cluster (default: one per core; 0 runs in this process without Dask)",
    )
    p.add_argument(
        "--series", action="store_true", help="also store every run's time series in OUT/series/<key>.npz"
    )
    p.add_argument(
        "--batch-rows",
        type=campaign.count(1),
        default=20,
        metavar="N",
        help="rows per Parquet file; finished rows wait at most 10 s (default 20)",
    )
    p.add_argument(
        "--run-timeout",
        type=_positive,
        default=600.0,
        metavar="S",
        help="longest run on a worker [s]: then run again elsewhere, and stored as a timeout if late again "
        "(default 600)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=campaign.run)


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
        choices=controllers.names(),
        metavar="NAME",
        help=f"one of {', '.join(controllers.names())} (default ff+fb: the paper's feedforward + feedback)",
    )
    p.add_argument(
        "--plant",
        choices=PLANTS,
        help="dynamic (default: the arm's rigid-body dynamics), kinematic (ideal inner loop) or free-camera",
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
