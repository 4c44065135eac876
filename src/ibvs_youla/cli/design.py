"""``ibvs-youla design``: print (and with ``--plot`` draw) the inner, feedforward and outer designs."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from .base import load_optional_config
from .parser import DESIGNS

FLAGS = {"tau_in": "--tau-in", "omega_n": "--omega-n", "zeta": "--zeta", "tau_forward": "--tau-forward"}


def prepare(args: argparse.Namespace, extra: list[str]) -> Callable[[], int]:
    """The chosen designs from the flags over ``--config``/default settings; return the printer."""
    from ..control.feedforward import FeedforwardDesign
    from ..control.inner import InnerLoopDesign
    from ..control.outer import OuterLoopDesign
    from ..simulation.settings import SimulationSettings

    cfg = load_optional_config(args.config)
    base = SimulationSettings() if cfg is None else cfg.settings
    tau_in = args.tau_in if args.tau_in is not None else base.tau_in
    omega_n = args.omega_n if args.omega_n is not None else base.omega_n
    zeta = args.zeta if args.zeta is not None else base.zeta
    tau_forward = (
        args.tau_forward
        if args.tau_forward is not None
        else (base.tau_forward if args.tau_in is None else None)
    )
    designs = {
        "inner": InnerLoopDesign(tau_in),
        "feedforward": FeedforwardDesign(tau_in, tau_forward),
        "outer": OuterLoopDesign(omega_n, zeta, tau_in, base.sv_policy),
    }
    which = DESIGNS[:3] if args.which == "all" else (args.which,)
    return lambda: _show(args, [(w, designs[w]) for w in which])


def _show(args: argparse.Namespace, designs: list[tuple[str, Any]]) -> int:
    """Print the designs (and with ``--plot`` write their figures); return 0."""
    from ..analysis.design_report import describe_design, plot_design_of
    from ..files import save_figure

    print("\n\n".join(describe_design(d) for _, d in designs))
    if args.plot:
        args.out.mkdir(parents=True, exist_ok=True)
        for name, design in designs:
            path = args.out / f"{name}.png"
            save_figure(plot_design_of(design), path, dpi=110)
            print(f"wrote {path}")
    return 0
