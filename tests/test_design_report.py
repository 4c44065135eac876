"""Design reports: the numbers they print are the designs' own, and the figures their responses."""

from __future__ import annotations

import numpy as np
import pytest

from ibvs_youla.analysis.design_report import describe_design, format_roots, format_tf, plot_design_of
from ibvs_youla.control.feedforward import FeedforwardDesign
from ibvs_youla.control.inner import InnerLoopDesign
from ibvs_youla.control.outer import OuterLoopDesign
from ibvs_youla.exceptions import InvalidParameterError


def test_format_tf_and_roots():
    assert format_tf(InnerLoopDesign(0.01).controller()) == "(0.03 s + 1) / (1e-06 s + 0.0003)"
    assert format_tf(InnerLoopDesign().plant()) == "(1) / (s^2)"
    # the triple pole at -1/tau comes out of np.roots split by ~1e-5 relative: printed as real
    assert format_roots(InnerLoopDesign(0.01).closed_loop_poles()) == "-100, -100, -100"
    assert format_roots([-1 + 2j, -1 - 2j, -3]) == "-3, -1-2j, -1+2j"


def test_feedforward_report_uses_the_given_speed_limits():
    design = FeedforwardDesign(0.01)
    q_step = np.radians([0.48, 2.21, 2.05, -82.68, 9.46, 77.47])  # paper-1: q_start = 0
    limits = np.full(6, 10.0)  # [rad/s]
    expected = np.abs(q_step) / (np.e * 0.001) / limits
    text = describe_design(design, dq_max=limits)
    assert "paper-1: " + ", ".join(f"{r:.3g}" for r in expected) in text
    assert f"max {expected.max():.3g}x, joint 4" in text


def test_outer_report_numbers():
    text = describe_design(OuterLoopDesign(10.0, 1.0, 0.01))
    assert "poles -10, -10 rad/s" in text
    assert "lambda = omega_n/(2 zeta) = 5 1/s" in text
    assert "settling_time() = 0.5834 s" in text  # critically damped: 5.834/omega_n


def test_unknown_design_is_rejected():
    with pytest.raises(InvalidParameterError, match="InnerLoopDesign, FeedforwardDesign or OuterLoopDesign"):
        describe_design("inner")
    with pytest.raises(InvalidParameterError):
        plot_design_of(None)


@pytest.mark.parametrize(
    ("design", "n_bode", "step_final"),
    [(InnerLoopDesign(), 3, 1.0), (FeedforwardDesign(), 2, 1.0), (OuterLoopDesign(), 3, 1.0)],
)
def test_figures_have_one_bode_line_per_transfer_function(design, n_bode, step_final):
    mag, step, _, _ = plot_design_of(design).axes
    assert len(mag.lines) == n_bode
    t, y = step.lines[0].get_xdata(), step.lines[0].get_ydata()
    assert y[-1] == pytest.approx(step_final, abs=1e-3)  # 15 time constants of the slowest pole
    assert len(t) == 2001
