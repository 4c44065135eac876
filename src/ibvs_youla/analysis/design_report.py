"""Plain-text reports and figures of the three controller designs (Section 6).

:func:`describe_design` prints, for an :class:`~ibvs_youla.control.inner.InnerLoopDesign`,
a :class:`~ibvs_youla.control.feedforward.FeedforwardDesign` or an
:class:`~ibvs_youla.control.outer.OuterLoopDesign`, its transfer functions, poles and
zeros, stability margins, step-response overshoot and 2 % settling time, and the
numbers of the errata that concern it:

* inner loop: the closed-loop poles of the printed numerator 3 tau^2 s + 1 (ERRATA 8);
* feedforward: the high-frequency gain tau_in^2/(3 tau_f^2) and the peak joint speed a
  step of Table 1's scenarios asks for, against the IRB 4600's limits (ERRATA 11);
* outer loop: the closed form J^+ K(s) (ERRATA 9), the poles and settling time of m_T
  (ERRATA 10) and the equivalent classical IBVS gain omega_n / (2 zeta).

:func:`plot_design_of` draws the matching Bode, step and pole-zero figure with
:func:`~ibvs_youla.analysis.plots.plot_design`. The ``ibvs-youla design`` command
prints and draws these.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import control as ct
import numpy as np

from .. import scenarios
from ..control.feedforward import FeedforwardDesign
from ..control.inner import InnerLoopDesign
from ..control.outer import OuterLoopDesign
from ..exceptions import InvalidParameterError
from .metrics import overshoot, settling_time
from .plots import plot_design

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

__all__ = ["describe_design", "format_roots", "format_tf", "plot_design_of", "step_summary"]

Design = InnerLoopDesign | FeedforwardDesign | OuterLoopDesign


def _poly(coefficients: Any) -> str:
    c = np.trim_zeros(np.atleast_1d(np.asarray(coefficients, dtype=float)), "f")
    n = len(c) - 1
    powers = ["" if k == n else "s" if k == n - 1 else f"s^{n - k}" for k in range(n + 1)]
    terms = [p if v == 1.0 and p else f"{v:.4g} {p}".strip() for v, p in zip(c, powers, strict=True) if v]
    return " + ".join(terms).replace("+ -", "- ") or "0"


def format_tf(sys: ct.TransferFunction) -> str:
    """A SISO transfer function as ``(num) / (den)`` in powers of s, 4 significant digits."""
    return f"({_poly(sys.num[0][0])}) / ({_poly(sys.den[0][0])})"


def format_roots(values: Any) -> str:
    """Roots sorted by real part; imaginary parts below 1e-4 |root| are dropped.

    A repeated root (the inner loop's triple pole at -1/tau) comes out of a polynomial
    solver split by about 1e-5 relative; it is printed as the real root it is.
    """
    out = []
    for v in np.sort_complex(np.atleast_1d(values)):
        real = abs(v.imag) < 1e-4 * max(1.0, abs(v))
        out.append(f"{v.real:.4g}" if real else f"{v.real:.4g}{v.imag:+.4g}j")
    return ", ".join(out) or "none"


def step_summary(sys: ct.TransferFunction, horizon: float) -> str:
    """Overshoot [%] and 2 % settling time [s] of a unit step, on 20001 samples over ``horizon``.

    Not measured (and said so) when that grid cannot resolve the response: an oscillation of
    more than 0.1 rad per sample, or poles more than 1e12 apart, where the matrix exponential
    of one sample loses the slow mode to round-off (m_T with zeta > 5e5).
    """
    dt = horizon / 20000
    poles = np.atleast_1d(ct.poles(sys))
    if np.any(np.abs(poles.imag) * dt > 0.1):
        return f"not measured (oscillation of {np.abs(poles.imag).max():.4g} rad/s over {horizon:.4g} s)"
    size = np.abs(poles[poles != 0])
    if size.size and (size.max() > 1e12 * size.min() or size.max() * dt > 1e15):
        return f"not measured (poles {size.min():.3g} to {size.max():.3g} rad/s: too stiff for one grid)"
    r = ct.step_response(sys, T=np.linspace(0.0, horizon, 20001))
    y = np.ravel(r.outputs)
    ts = settling_time(r.time, y, y_final=1.0, y_initial=0.0)
    return f"overshoot {overshoot(y, y_final=1.0, y_initial=0.0):.3g} %, 2 % settling {ts:.4g} s"


def _inner(d: InnerLoopDesign) -> list[str]:
    gm, pm, wc = d.margins()
    T = d.complementary_sensitivity()
    return [
        f"INNER LOOP (Section 6.1, Eq. (41)-(46)), tau_in = {d.tau_in:g} s",
        f"  plant       G_P = {format_tf(d.plant())}  (feedback-linearized joint, Eq. (37))",
        f"  controller  G_C = {format_tf(d.controller())}  (ERRATA 8: numerator 3 tau s + 1)",
        f"  T = {format_tf(T)}",
        f"  closed-loop poles {format_roots(d.closed_loop_poles())} rad/s (triple at -1/tau_in); "
        f"zeros of T {format_roots(ct.zeros(T))}",
        f"  margins of L = G_C/s^2: gain {gm:.4g}, phase {pm:.4g} deg at {wc:.4g} rad/s",
        f"  step of T: {step_summary(T, 20.0 * d.tau_in)}",
        "  ERRATA 8: the printed numerator 3 tau^2 s + 1 gives poles "
        f"{format_roots(d.closed_loop_poles(printed=True))} (unstable)",
    ]


def _feedforward(d: FeedforwardDesign, dq_max: np.ndarray) -> list[str]:
    T_forward = d.filter_tf()
    lines = [
        f"FEEDFORWARD (Section 6.2, Eq. (47)-(49)), tau_in = {d.tau_in:g} s, "
        f"tau_forward = {d.tau_forward:g} s",
        f"  T_forward = {format_tf(T_forward)}",
        f"  poles {format_roots(ct.poles(T_forward))}; zeros {format_roots(ct.zeros(T_forward))} rad/s",
        f"  joints follow T_in T_forward = {format_tf(d.tracking_tf())}: "
        f"step {step_summary(d.tracking_tf(), 20.0 * d.tau_forward)}",
        f"  high-frequency gain {d.high_frequency_gain:.4g}: q_ff jumps by that many steps at t = 0+",
        "  ERRATA 11, peak joint speed of a step q_start -> q_target against the IRB 4600 limits:",
    ]
    for sc in scenarios.paper_scenarios():
        speed, _ = d.step_demand(sc.q_target - sc.q_start)
        ratio = speed / dq_max
        lines.append(
            f"    {sc.name}: "
            + ", ".join(f"{r:.3g}" for r in ratio)
            + f" x limit (max {ratio.max():.3g}x, joint {int(np.argmax(ratio)) + 1})"
        )
    return lines


def _outer(d: OuterLoopDesign) -> list[str]:
    gm, pm, _, wc = ct.margin(d.filter_tf() * d.inner_tf())
    poles = d.target_poles()
    return [
        f"OUTER LOOP (Section 6.3, Eq. (53)-(61)), omega_n = {d.omega_n:g} rad/s, zeta = {d.zeta:g}, "
        f"tau_in = {d.tau_in:g} s",
        f"  G_C = J^+ K(s) (ERRATA 9), J^+ the pseudo-inverse with the {d.sv_policy.kind} "
        f"small-singular-value policy (threshold {d.sv_policy.threshold:g} sigma_max, ERRATA 7)",
        f"  K(s) = {format_tf(d.filter_tf())}",
        f"  target m_T = {format_tf(d.target_tf())}: poles {format_roots(poles)} rad/s",
        f"  step of m_T: {step_summary(d.target_tf(), 12.0 / abs(poles[0].real))}; "
        f"settling_time() = {d.settling_time():.4g} s (ERRATA 10: the paper says < 3 s)",
        "  low frequency: classical IBVS q_fb' = lambda J^+ e with lambda = omega_n/(2 zeta) = "
        f"{d.ibvs_gain:.4g} 1/s",
        f"  margins of one channel K T_in: gain {gm:.4g}, phase {pm:.4g} deg at {wc:.4g} rad/s",
    ]


def describe_design(design: Design, *, dq_max: Any = None) -> str:
    """Multi-line report of one design (see the module docstring for what it contains).

    Args:
        design: An inner-loop, feedforward or outer-loop design.
        dq_max: Joint speed limits (6,) [rad/s] for the feedforward's ERRATA 11 ratios;
            default the IRB 4600's (``Arm.irb4600().dq_max``).

    Raises:
        InvalidParameterError: ``design`` is none of the three.
    """
    if isinstance(design, InnerLoopDesign):
        lines = _inner(design)
    elif isinstance(design, OuterLoopDesign):
        lines = _outer(design)
    elif isinstance(design, FeedforwardDesign):
        if dq_max is None:
            from ..model.arm import Arm

            dq_max = Arm.irb4600().dq_max
        lines = _feedforward(design, np.asarray(dq_max, dtype=float))
    else:
        raise InvalidParameterError(
            "design", type(design).__name__, "an InnerLoopDesign, FeedforwardDesign or OuterLoopDesign"
        )
    return "\n".join(lines)


def plot_design_of(design: Design) -> Figure:
    """Bode, step and pole-zero figure of one design.

    Inner loop: Bode of L = G_C G_P, T and S, step and poles of T. Feedforward: Bode of
    T_forward and T_in T_forward, steps of T_in T_forward and T_in. Outer loop: Bode of
    K, of one channel's loop K T_in and of m_T, step and poles of m_T.
    """
    if isinstance(design, InnerLoopDesign):
        T = design.complementary_sensitivity()
        bode = {"L = G_C G_P": design.loop_gain(), "T": T, "S": design.sensitivity()}
        return plot_design(bode, {"T": T}, f"inner loop, tau_in = {design.tau_in:g} s")
    if isinstance(design, OuterLoopDesign):
        K, m_T = design.filter_tf(), design.target_tf()
        bode = {"K": K, "K T_in (loop)": K * design.inner_tf(), "m_T": m_T}
        title = f"outer loop, omega_n = {design.omega_n:g} rad/s, zeta = {design.zeta:g}"
        return plot_design(bode, {"m_T": m_T}, title)
    if isinstance(design, FeedforwardDesign):
        tracking = design.tracking_tf()
        bode = {"T_forward": design.filter_tf(), "T_in T_forward": tracking}
        step = {"T_in T_forward": tracking, "T_in": design.inner.complementary_sensitivity()}
        return plot_design(bode, step, f"feedforward, tau_forward = {design.tau_forward:g} s")
    raise InvalidParameterError(
        "design", type(design).__name__, "an InnerLoopDesign, FeedforwardDesign or OuterLoopDesign"
    )
