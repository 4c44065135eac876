"""``ibvs-youla design``: print (and with ``--plot`` draw) the inner, feedforward and outer designs."""

from __future__ import annotations

import argparse

from ..files import save_figure
from .base import flag_errors, load_optional_config

DESIGNS = ("inner", "feedforward", "outer", "all")
FLAGS = {"tau_in": "--tau-in", "omega_n": "--omega-n", "zeta": "--zeta", "tau_forward": "--tau-forward"}


def run(args: argparse.Namespace, extra: list[str]) -> int:
    """Print (and plot) the chosen designs from the flags over ``--config``/default settings; return 0."""
    from ..analysis.design_report import describe_design, plot_design_of
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
    with flag_errors(args, FLAGS):
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
            save_figure(plot_design_of(designs[w]), path, dpi=110)
            print(f"wrote {path}")
    return 0
