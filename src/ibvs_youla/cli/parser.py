"""The argument definitions of ``ibvs-youla`` and its subcommands (light: see :mod:`ibvs_youla.cli`).

This module imports only the standard library, :mod:`ibvs_youla.catalog` (the names the
choices list) and :mod:`.arguments` (the value types), so that ``--help`` and a bad argument
answer at once. Each subcommand names the module that runs it (``handler``), imported only
once the arguments have parsed. Options that several commands share are added by one function
each (:func:`_add_run_options`, :func:`_add_campaign_options`, :func:`_add_arm_options`), the place
for a new shared option.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, NoReturn

from .. import __version__, catalog
from .arguments import (
    axes_pair,
    count,
    folder_path,
    locked_joint,
    method_list,
    name_list,
    non_negative,
    positive,
    scheduler_address,
    seed,
    suggestion,
    transform,
    value_list,
)
from .base import PROG, UsageError
from .bench import BENCHMARKS

# command -> the module of this package that prepares and runs it
HANDLERS = {
    "reproduce": "reproduce",
    "simulate": "simulate",
    "design": "design",
    "view": "view",
    "bench": "bench",
    "compare": "compare",
    "campaign": "campaign",
    "campaign-report": "campaign_report",
    "robustness": "robustness",
}
DESIGNS = ("inner", "feedforward", "outer", "all")
MAP_AXES_DEFAULT = "twist,tilt"
# the errors that come with the usage: a mistyped option or command, or no command
_MISTYPED = (
    "unrecognized arguments",
    "argument COMMAND",
    "the following arguments are required: COMMAND",
)


class _Parser(argparse.ArgumentParser):
    """argparse, with errors raised as :class:`UsageError` (with the usage) and near misses suggested."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.commands: dict[str, _Parser] = {}  # the subcommands' parsers (top level only)

    def error(self, message: str) -> NoReturn:
        # a mistyped (or missing) command or option: its usage, to see what is there
        mistyped = message.startswith(_MISTYPED)
        raise UsageError(
            f"{message} (see '{self.prog} --help')", usage=self.format_usage() if mistyped else None
        )

    def _check_value(self, action: argparse.Action, value: Any) -> None:
        # argparse's check of a choice (its message), with the nearest valid choice suggested
        if action.choices is not None and value not in action.choices:
            choices = [str(c) for c in action.choices]
            raise argparse.ArgumentError(
                action,
                f"invalid choice: {value!r}{suggestion(str(value), choices)} "
                f"(choose from {', '.join(map(repr, choices))})",
            )

    def parse_args(self, args: Any = None, namespace: Any = None) -> Any:  # type: ignore[override]
        """Parse; an unrecognized option is reported by its subcommand, with the nearest option of it."""
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            owner = self.commands.get(getattr(parsed, "command", None), self)
            owner.error(f"unrecognized arguments: {' '.join(extras)}{owner.option_suggestion(extras)}")
        return parsed

    def option_suggestion(self, extras: list[str]) -> str:
        """``"; did you mean --x?"`` for the first unrecognized option, or ``""``."""
        options = [s for action in self._actions for s in action.option_strings if s.startswith("--")]
        for word in extras:
            if word.startswith("--"):
                close = suggestion(word.split("=", 1)[0], options)
                return close.replace("'", "") if close else ""
        return ""


def build_parser() -> argparse.ArgumentParser:
    """The parser of the whole command line; each subcommand sets ``handler`` (see :data:`HANDLERS`)."""
    parser = _Parser(
        prog=PROG,
        description="Stereo IBVS with feedforward and adaptive Youla control (Li & Assadian): "
        "reproduce the paper, simulate a scenario, compare methods, run seeded campaigns and robustness "
        "studies, inspect the controller designs, view a run, benchmark. Errors print one line and exit "
        "with 2 (bad arguments or configuration files) or 1.",
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    parser.add_argument(
        "--debug",
        action="store_true",
        help="on an error, print the traceback too (accepted anywhere before --)",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True, parser_class=_Parser)

    def command(name: str, summary: str, description: str | None = None) -> _Parser:
        p = sub.add_parser(name, help=summary, description=description or summary)
        p.set_defaults(handler=HANDLERS[name])
        parser.commands[name] = p
        return p

    _add_reproduce(command("reproduce", "rerun the paper's Section 7: runs, Figures 13-16, table"))
    p = command("simulate", "simulate one scenario; write the result, figures and a summary")
    _add_run_options(p)
    p.add_argument(
        "--out",
        type=folder_path,
        metavar="DIR",
        help="output folder (default: results/<scenario>_<controller>_<loop>)",
    )
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    _add_design(command("design", "print (and plot) the inner, feedforward and outer designs"))
    _add_view(command("view", "play a run in the Meshcat 3-D viewer"))
    p = command(
        "bench",
        "run the benchmarks in benchmarks/; arguments after -- are passed on to them",
        "run the benchmarks in benchmarks/; arguments after -- are passed on to them, "
        "e.g. ibvs-youla bench simulation --json out -- --duration 1 --repeats 1",
    )
    p.add_argument("which", nargs="?", default="all", choices=(*BENCHMARKS, "all"), help="default: all")
    p.add_argument("--json", type=folder_path, metavar="DIR", help="write <benchmark>.json reports here")
    _add_compare(
        command(
            "compare",
            "run several controllers on one scenario, or the Gans 2003 suite; tables and figures",
            "run several controllers on one scenario (side-by-side figures and a table: status, time to "
            "converge, final pose error, camera path, peak joint speed, update time), or every task of "
            "the Gans, Hutchinson & Corke 2003 suite with every twist controller",
        )
    )
    p = command(
        "campaign",
        "run every method on the same seeded cases, on this machine's cores or a Dask cluster",
        "run every method on the same seeded cases, on this machine's cores (one process per core) or "
        "an existing Dask cluster; rows go to OUT/rows (Parquet) as they finish, and the same command "
        "resumes an interrupted campaign",
    )
    p.add_argument("--cases", type=count(1), required=True, metavar="N", help="number of cases")
    p.add_argument(
        "--controllers",
        type=method_list,
        metavar="A,B,...",
        help=f"comma-separated methods, from {', '.join(catalog.CONTROLLERS)}, each optionally with "
        "parameters: NAME[KEY=VALUE,...], e.g. fb[adaptive=false] (default: every one the plant takes; "
        "fb and ff+fb command joints and need an arm plant)",
    )
    _add_campaign_options(p, plural="")
    p.add_argument("--out", type=folder_path, required=True, metavar="DIR", help="campaign folder")
    p.add_argument(
        "--series", action="store_true", help="also store every run's time series in OUT/series/<key>.npz"
    )
    p.add_argument(
        "--batch-rows",
        type=count(1),
        default=20,
        metavar="N",
        help="rows per Parquet file; finished rows wait at most 10 s (default 20)",
    )
    p = command("campaign-report", "tables and figures of a campaign folder")
    p.add_argument("dir", type=Path, metavar="DIR", help="campaign folder (it holds DIR/rows)")
    p.add_argument("--out", type=folder_path, metavar="OUT", help="report folder (default: DIR/report)")
    p.add_argument(
        "--axes",
        type=axes_pair,
        metavar="A,B",
        default=axes_pair(MAP_AXES_DEFAULT),
        help="two coordinates of the start camera in the target camera's frame for the free-camera "
        f"outcome maps, from {', '.join(catalog.MAP_AXES)} (default: {MAP_AXES_DEFAULT})",
    )
    _add_robustness(
        command(
            "robustness",
            "sweep one disturbance (noise, images, calibration, mismatch, latency, saturation) over seeded "
            "cases",
            "sweep one disturbance over the same seeded campaign cases, every method, on this machine's "
            "cores or a Dask cluster (one campaign per value in OUT/<axis>=<value>, resumable), then write "
            "a table and figures: success with 95 % Wilson intervals, final pose error and time to reach "
            "against the value",
        )
    )
    return parser


def _add_reproduce(p: argparse.ArgumentParser) -> None:
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
        choices=catalog.SCENARIOS,
        metavar="NAME",
        help=f"scenarios to run, from {', '.join(catalog.SCENARIOS)} (default: the paper's two and their "
        "physical twins)",
    )
    p.add_argument("--duration", type=positive, metavar="S", help="simulated time per run [s] (default 20)")
    p.add_argument(
        "--diagnosis-duration",
        type=non_negative,
        metavar="S",
        default=120.0,
        help="longer horizon [s] for runs that have not reached the target; 0 skips (default 120)",
    )
    p.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="TOML file whose [settings] (over the paper's, unless it names a preset) and [run] duration "
        "apply",
    )
    p.add_argument("--no-resume", action="store_true", help="simulate again even if runs are saved in --out")
    p.add_argument("--no-plots", action="store_true", help="skip Figures 13-16 (runs and table only)")


def _add_run_options(p: argparse.ArgumentParser) -> None:
    """One run's options (``simulate``, ``view``): scenario, config, controller, plant, loop, duration."""
    p.add_argument(
        "--scenario",
        choices=catalog.SCENARIOS,
        metavar="NAME",
        help=f"one of {', '.join(catalog.SCENARIOS)} (the IRB 4600's; on another arm, leave it out for the "
        "arm's seeded scenario, --seed)",
    )
    p.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="TOML file with [scenario], [settings], [run], [camera], [arm] (see examples/)",
    )
    p.add_argument(
        "--controller",
        choices=catalog.CONTROLLERS,
        metavar="NAME",
        help=f"one of {', '.join(catalog.CONTROLLERS)} (default ff+fb: the paper's feedforward + feedback)",
    )
    p.add_argument(
        "--plant",
        choices=catalog.PLANTS,
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
    p.add_argument("--duration", type=positive, metavar="S", help="simulated time [s] (default 10)")
    p.add_argument(
        "--seed",
        type=seed,
        metavar="S",
        help="without --scenario or a [scenario]: the seed of the arm's scenario (markers in front of the "
        "camera near the robot's home configuration, scenarios.for_arm; with --mount eye-to-hand, "
        "scenarios.eye_to_hand; default 0)",
    )
    _add_mount_option(p)
    _add_arm_options(p, "to simulate", config=True)


def _add_mount_option(p: argparse.ArgumentParser) -> None:
    """``--mount``: where the camera is (simulate, view, compare)."""
    p.add_argument(
        "--mount",
        choices=catalog.MOUNTS,
        help="eye-in-hand (default: the camera on the arm) or eye-to-hand: a camera fixed in front of the "
        "arm watching markers on its flange, the arm's seeded eye-to-hand scenario (scenarios.eye_to_hand, "
        "--seed; docs/eye-to-hand.md); the named scenarios are eye-in-hand",
    )


def _add_arm_options(p: argparse.ArgumentParser, what: str, *, config: bool = False) -> None:
    """The arm (simulate, view, compare, campaign, robustness): a robot or a URDF, its mount."""
    default = "the IRB 4600 of the paper" + (", or the --config file's [arm]" if config else "")
    group = p.add_argument_group(
        "arm",
        f"the arm {what} (default: {default}); a robot by name or a URDF file of a fixed-base arm whose "
        "chain to the camera has six or more joints",
    )
    which = group.add_mutually_exclusive_group()
    which.add_argument(
        "--robot",
        choices=catalog.ROBOTS,
        metavar="NAME",
        help=f"one of {', '.join(catalog.ROBOTS)}, with its camera on the tool flange (docs/own-robot.md)",
    )
    which.add_argument("--urdf", type=Path, metavar="FILE", help="a URDF file (meshes are not needed)")
    group.add_argument(
        "--camera-frame",
        metavar="FRAME",
        help="the frame the camera is mounted on (default: the robot's mount; with --urdf, 'camera')",
    )
    group.add_argument(
        "--T-F-C",
        dest="T_F_C",
        type=transform,
        metavar="X,Y,Z,RX,RY,RZ",
        help="the camera in that frame: translation [m] and rotation vector [deg], or the 16 entries of "
        "the 4x4 transform row by row (default: the robot's mount; with --urdf, the frame itself)",
    )
    group.add_argument(
        "--locked-joint",
        dest="locked_joints",
        type=locked_joint,
        action="append",
        metavar="NAME=VALUE",
        help="lock a joint at a value [rad or m] (repeat for several; joints off the chain to the camera "
        "are locked anyway, at their neutral position)",
    )


def _add_design(p: argparse.ArgumentParser) -> None:
    p.add_argument("which", nargs="?", default="all", choices=DESIGNS, help="design to show (default: all)")
    p.add_argument("--tau-in", type=positive, metavar="S", help="inner-loop time constant [s] (default 0.01)")
    p.add_argument(
        "--omega-n", type=positive, metavar="RAD_S", help="outer-loop natural frequency [rad/s] (default 10)"
    )
    p.add_argument("--zeta", type=positive, metavar="ZETA", help="outer-loop damping ratio (default 10)")
    p.add_argument(
        "--tau-forward", type=positive, metavar="S", help="feedforward time constant [s] (default 0.1 tau_in)"
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


def _add_view(p: argparse.ArgumentParser) -> None:
    _add_run_options(p)
    p.add_argument(
        "--result", type=Path, metavar="FILE", help="play a saved result (.npz) instead of simulating"
    )
    p.add_argument(
        "--speed", type=positive, metavar="X", default=1.0, help="playback speed factor (default 1)"
    )
    p.add_argument(
        "--fps", type=positive, metavar="HZ", default=30.0, help="playback frame rate (default 30)"
    )
    p.add_argument("--zmq-url", help="connect to a running meshcat-server instead of starting one")
    p.add_argument(
        "--zmq-timeout",
        type=positive,
        metavar="S",
        default=5.0,
        help="give up if the --zmq-url server has not answered after S seconds (default 5)",
    )
    p.add_argument("--open", action="store_true", help="open the viewer in a web browser")
    p.add_argument(
        "--no-wait", action="store_true", help="exit after playing instead of serving until Ctrl-C"
    )


def _add_compare(p: argparse.ArgumentParser) -> None:
    which = p.add_mutually_exclusive_group()  # one of them, or an arm's scenario: checked by compare
    which.add_argument(
        "--scenario",
        choices=(*catalog.SCENARIOS, *catalog.SUITE_TASKS, catalog.TEXTURED_SCENARIO),
        metavar="NAME",
        help=f"one of {', '.join(catalog.SCENARIOS)} (the IRB 4600's), a task of the suite: "
        f"{', '.join(catalog.SUITE_TASKS)}, or {catalog.TEXTURED_SCENARIO} (a textured plane, for "
        "photometric servoing); without it and --suite, the seeded scenario of the --robot or --urdf arm",
    )
    which.add_argument(
        "--suite", choices=catalog.SUITES, help=f"run every task of the suite: {', '.join(catalog.SUITES)}"
    )
    p.add_argument(
        "--controllers",
        type=name_list(catalog.CONTROLLERS),
        metavar="A,B,...",
        help=f"comma-separated, from {', '.join(catalog.CONTROLLERS)} (default: every one that can run: "
        "all but photometric on an arm scenario, the camera-twist ones but photometric on a suite task, "
        "the camera-twist ones on the textured plane)",
    )
    p.add_argument(
        "--plant",
        choices=catalog.PLANTS,
        help="dynamic (default for an arm scenario), kinematic or free-camera (default, and the only "
        "choice, for the suite and its tasks)",
    )
    p.add_argument(
        "--duration",
        type=positive,
        metavar="S",
        help="simulated time per run [s] (default 10 on an arm scenario, 30 for the suite)",
    )
    p.add_argument(
        "--camera-rate",
        type=positive,
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
    p.add_argument(
        "--seed",
        type=seed,
        metavar="S",
        help="the seed of the arm's scenario (with --robot or --urdf and no --scenario: markers in front of "
        "the camera near the robot's home configuration, scenarios.for_arm; default 0)",
    )
    _add_mount_option(p)
    _add_arm_options(p, "of an arm scenario (the suite's tasks and the textured plane are the free camera's)")


def _add_campaign_options(p: argparse.ArgumentParser, plural: str) -> None:
    """The options of the cases and the cluster that ``campaign`` and ``robustness`` share."""
    p.add_argument(
        "--family",
        choices=catalog.FAMILIES,
        default="arm-physical",
        help="case family (default arm-physical); the arm families run on an arm plant, the free ones on "
        "the free camera",
    )
    p.add_argument(
        "--plant",
        choices=catalog.PLANTS,
        help="default: dynamic for an arm family (or kinematic: an ideal inner loop); free-camera, the only "
        "choice, for a free family",
    )
    p.add_argument(
        "--camera",
        choices=catalog.CAMERA_KINDS,
        help="default: stereo (ZED 2) for an arm family, normalized (F = 1) for a free one, pinhole "
        "(120 x 90 px) for free-textured",
    )
    p.add_argument(
        "--duration",
        type=positive,
        metavar="S",
        help="simulated time per run [s] (default 20 for an arm family, 30 for a free one; "
        "camera at 100 Hz on an arm, 25 Hz on the free camera)",
    )
    p.add_argument("--seed", type=seed, default=0, metavar="S", help="integer >= 0 (default 0)")
    p.add_argument(
        "--difficulty",
        type=positive,
        default=1.0,
        metavar="X",
        help="scales the start-target rotation and translation (default 1)",
    )
    p.add_argument(
        "--scheduler",
        type=scheduler_address,
        metavar="ADDRESS",
        help="an existing Dask scheduler, e.g. tcp://127.0.0.1:8786 (default: a local cluster)",
    )
    p.add_argument(
        "--workers",
        type=count(0),
        metavar="K",
        help="processes of the local cluster (default: one per core; 0 runs in this process without Dask)",
    )
    p.add_argument(
        "--run-timeout",
        type=positive,
        default=600.0,
        metavar="S",
        help="longest run on a worker [s]: then run again elsewhere, and stored as a timeout if late again "
        "(default 600)",
    )
    p.add_argument("--no-progress", action="store_true", help=f"no progress bar{plural}")
    _add_arm_options(
        p,
        "of the arm families: their cases are drawn for it (its joint limits and singularities) and every "
        "run's key holds its identity",
    )


def _add_robustness(p: argparse.ArgumentParser) -> None:
    defaults = "; ".join(f"{axis} {','.join(values)}" for axis, values in catalog.ROBUSTNESS_AXES.items())
    p.add_argument(
        "--axis", choices=tuple(catalog.ROBUSTNESS_AXES), required=True, help="the disturbance to sweep"
    )
    p.add_argument(
        "--values",
        type=value_list,
        metavar="V1,V2,...",
        help=f"the sweep (defaults: {defaults}); noise in px, images in grey levels of sensor noise, "
        "calibration and mismatch as levels, latency in camera frames, saturation as a fraction of "
        "the arm's limits (inf: none)",
    )
    p.add_argument("--cases", type=count(1), default=20, metavar="N", help="cases (default 20)")
    p.add_argument(
        "--controllers",
        type=name_list(catalog.CONTROLLERS),
        metavar="A,B,...",
        help=f"comma-separated, from {', '.join(catalog.CONTROLLERS)} (default: every one the plant takes)",
    )
    _add_campaign_options(p, plural="s")
    p.add_argument(
        "--feedforward",
        choices=("paper", "smooth"),
        default="paper",
        help="ff+fb's feedforward: the paper's 1 ms step filter, or the smooth minimum-jerk one within "
        "half the speed limits (default paper)",
    )
    p.add_argument(
        "--tolerance",
        type=value_list,
        default=("1", "0.1"),
        metavar="MM,DEG",
        help="final pose error that counts as a success (default 1,0.1: the campaign's 'reached')",
    )
    p.add_argument("--out", type=folder_path, required=True, metavar="DIR", help="study folder")
