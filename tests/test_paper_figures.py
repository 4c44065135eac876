"""Figures 13-16 comparison plots: data drawn as recorded, targets dashed, spikes annotated."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from ibvs_youla.analysis.paper_figures import plot_image_comparison, plot_joint_comparison
from synthetic import synthetic_result


def _result(features, q):
    return synthetic_result(
        features, np.full(9, 1e-3), duration=2.0, q=q, metadata={"q_encoder_goal": [0.1] * 6}
    )


def test_panels_show_the_recorded_signals_and_dashed_targets():
    n = 201
    smooth = np.outer(1.0 - np.exp(-np.linspace(0, 2, n) * 3), np.full(9, 1e-3))
    q = np.outer(np.linspace(0, 0.1, n), np.ones(6))
    fig = plot_image_comparison(_result(smooth, q), _result(smooth, q), "test")
    axes = fig.axes
    assert len(axes) == 18
    np.testing.assert_allclose(axes[0].lines[0].get_ydata(), 1e3 * smooth[:, 0])  # mm on the sensor
    assert axes[0].lines[1].get_linestyle() == "--"
    np.testing.assert_allclose(axes[0].lines[1].get_ydata(), 1.0)
    fig_q = plot_joint_comparison(_result(smooth, q), _result(smooth, q), "test")
    np.testing.assert_allclose(fig_q.axes[0].lines[1].get_ydata(), np.degrees(0.1))
    # the dashed line has an entry in the figure's legend; no legend covers a panel
    for figure, labels in (
        (fig, ["run (colour: the marker)", "target features"]),
        (fig_q, ["run", "target: q_target - d (ERRATA 14)"]),
    ):
        (legend,) = figure.legends
        assert [t.get_text() for t in legend.get_texts()] == labels
        assert legend.get_lines()[1].get_linestyle() == "--"
        assert all(ax.get_legend() is None for ax in figure.axes)
    plt.close("all")


def test_an_early_spike_is_zoomed_past_and_stated():
    n = 201
    t = np.linspace(0, 2, n)
    smooth = np.outer(1.0 - np.exp(-t * 3), np.full(9, 1e-3))
    spiky = smooth.copy()
    spiky[1, :] = 0.2  # 200 mm at t = 10 ms, like the paper's feedforward on virtual points
    q = np.zeros((n, 6))
    fig = plot_image_comparison(_result(smooth, q), _result(spiky, q), "test")
    left, right = fig.axes[0], fig.axes[1]
    assert left.get_title(loc="right") == ""  # nothing to zoom past
    _low, high = right.get_ylim()
    assert high < 2.0  # [mm]: scaled to the late signal, not to the 200 mm spike
    note = right.get_title(loc="right")  # above the panel: no line of the plot crosses it
    assert "full range" in note and "200" in note
    assert [t.get_text() for t in right.texts] == ["feedforward + feedback"]  # the column's name only
    plt.close("all")
