"""Metrics on synthetic signals with closed-form answers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ibvs_youla.analysis import metrics
from ibvs_youla.exceptions import InvalidArrayError, InvalidParameterError


def _pose(R, p):
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


def test_first_order_settling_time_is_minus_ln_band_times_tau():
    tau = 0.37  # [s]
    t = np.linspace(0.0, 10 * tau, 20001)
    y = 2.0 - 5.0 * np.exp(-t / tau)  # step from -3 to 2
    ts = metrics.settling_time(t, y, y_final=2.0)
    # linear interpolation of the band entry on a 1.85e-4 s grid: error ~1e-8 s
    assert ts == pytest.approx(-math.log(0.02) * tau, abs=1e-6)
    assert -math.log(0.02) == pytest.approx(3.912, abs=1e-3)
    # 5 % band, per coordinate, stacked with a falling signal
    Y = np.column_stack([y, -y])
    ts2 = metrics.settling_time(t, Y, y_final=[2.0, -2.0], band=0.05)
    np.testing.assert_allclose(ts2, -math.log(0.05) * tau, atol=1e-6)


def test_settling_time_is_inf_for_a_signal_that_settles_on_the_wrong_value():
    t = np.linspace(0.0, 5.0, 501)
    y = 1.0 - np.exp(-t)  # ends at 0.993, target 1.2 (like the third point's local minimum)
    assert metrics.settling_time(t, y, y_final=1.2) == math.inf
    assert metrics.settling_time(t, np.zeros_like(t), y_final=0.0, y_initial=0.0) == 0.0


def test_second_order_overshoot_matches_closed_form():
    zeta, wn = 0.3, 4.0
    wd = wn * math.sqrt(1 - zeta**2)
    t = np.linspace(0.0, 8.0, 80001)
    y = 1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))
    expected = 100 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2))  # 37.23 %
    # peak sampled on a 1e-4 s grid: error O(dt^2) ~ 1e-7 of the step
    assert metrics.overshoot(y, y_final=1.0, y_initial=0.0) == pytest.approx(expected, abs=1e-4)
    # a downward step overshoots downwards by the same fraction
    assert metrics.overshoot(3 - 2 * y, y_final=1.0) == pytest.approx(expected, abs=1e-4)
    # first order: no overshoot; zero step: undefined
    assert metrics.overshoot(1 - np.exp(-t), y_final=1.0) == 0.0
    assert math.isnan(metrics.overshoot(np.ones(5), y_final=1.0))


def test_final_error_is_target_minus_last_sample():
    y = np.array([[0.0, 1.0], [0.5, 2.0], [0.9, 2.5]])
    np.testing.assert_allclose(metrics.final_error(y, [1.0, 3.0]), [0.1, 0.5], rtol=0, atol=1e-15)


def test_pose_error_mm_deg_of_a_known_rotation_and_translation():
    rng = np.random.default_rng(7)
    R_a = Rotation.random(random_state=rng).as_matrix()
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    for angle_deg in (0.0, 1e-5, 12.5, 90.0, 179.9):
        R_b = R_a @ Rotation.from_rotvec(np.radians(angle_deg) * axis).as_matrix()
        p_a = rng.normal(size=3)
        p_b = p_a + np.array([0.003, -0.004, 0.0])  # 5 mm
        mm, deg = metrics.pose_error_mm_deg(_pose(R_a, p_a), _pose(R_b, p_b))
        assert mm == pytest.approx(5.0, abs=1e-9)
        assert deg == pytest.approx(angle_deg, abs=1e-7)


def test_peaks_with_ratio_to_limits_and_visibility_fraction():
    x = np.array([[1.0, -4.0], [-3.0, 2.0], [np.nan, 0.0]])
    peak, ratio = metrics.peak_with_ratio(x, [2.0, 8.0])
    np.testing.assert_array_equal(peak, [3.0, 4.0])
    np.testing.assert_array_equal(ratio, [1.5, 0.5])
    assert metrics.peak_with_ratio(x)[1] is None
    vis = np.array([[True, True, False], [True, False, False], [True, True, False], [True, True, True]])
    np.testing.assert_array_equal(metrics.visibility_fraction(vis), [1.0, 0.75, 0.25])


def test_bad_input_raises_library_errors():
    with pytest.raises(InvalidArrayError, match="limit"):
        metrics.peak_with_ratio(np.ones((3, 2)), [1.0, 0.0])
    with pytest.raises(InvalidArrayError, match="y"):
        metrics.settling_time(np.arange(3.0), np.ones(4))
    with pytest.raises(InvalidParameterError, match="band"):
        metrics.settling_time(np.arange(3.0), np.ones(3), band=0.0)
    with pytest.raises(InvalidArrayError, match="T_O_A"):
        metrics.pose_error_mm_deg(np.ones((4, 4)), np.eye(4))
