"""The reached / stalled / converging verdicts on synthetic runs with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from ibvs_youla.analysis.convergence import Tolerances, classify
from ibvs_youla.exceptions import InvalidParameterError
from synthetic import synthetic_result


def _result(error_norm, *, pose_offset_m=0.0, status="complete"):
    """A run whose feature error along one fixed unit direction has the given norm over time."""
    target = np.linspace(-1e-3, 1e-3, 9)
    feature_error = np.outer(error_norm, np.ones(9) / 3.0)
    return synthetic_result(
        target - feature_error, target, camera_x_m=pose_offset_m, metadata={"status": status}
    )


def test_exponential_decay_below_tolerance_is_reached():
    t = np.linspace(0.0, 10.0, 1001)
    outcome = classify(_result(1e-3 * np.exp(-2.0 * t)))
    assert outcome.kind == "reached"
    assert outcome.final_image_error_m == pytest.approx(1e-3 * np.exp(-20.0) / 3.0)


def test_slow_decay_is_converging_with_its_rate():
    t = np.linspace(0.0, 10.0, 1001)
    outcome = classify(_result(1e-3 * np.exp(-0.1 * t)))
    assert outcome.kind == "converging"
    # window = last 20 % = 2 s: change exp(-0.2) - 1
    assert outcome.error_change == pytest.approx(np.exp(-0.2) - 1.0, rel=1e-6)


def test_constant_nonzero_error_is_stalled_and_names_every_point():
    outcome = classify(_result(np.full(1001, 1e-4)))
    assert outcome.kind == "stalled"
    assert outcome.error_change == 0.0
    np.testing.assert_allclose(outcome.point_errors_m, 1e-4 / 3.0)


def test_small_image_error_but_pose_off_is_not_reached():
    outcome = classify(_result(np.full(1001, 1e-9), pose_offset_m=1e-3))  # 1 mm
    assert outcome.position_error_mm == pytest.approx(1.0)
    assert outcome.kind == "stalled"


def test_early_stop_statuses_pass_through_even_without_samples():
    assert classify(_result(np.full(11, 1e-3), status="diverged")).kind == "diverged"
    empty = classify(_result(np.zeros(0), status="markers_lost"))
    assert empty.kind == "markers_lost" and np.isnan(empty.final_image_error_m)


def test_tolerances_are_validated():
    with pytest.raises(InvalidParameterError, match="window"):
        Tolerances(window=1.5)
    with pytest.raises(InvalidParameterError, match="image_m"):
        Tolerances(image_m=0.0)


def test_reached_at_is_when_the_error_enters_tolerance_for_good():
    t = np.linspace(0.0, 10.0, 1001)
    norm = 1e-3 * np.exp(-2.0 * t)
    outcome = classify(_result(norm))
    # max per-coordinate error is norm / 3; it stays <= 1e-7 from t = ln(1e-3 / 3e-7) / 2 on,
    # so the verdict names the first sample at or after that instant
    t_cross = np.log(1e-3 / 3e-7) / 2.0
    assert outcome.reached_at_s == t[np.searchsorted(t, t_cross)]
    assert 0.0 <= outcome.reached_at_s - t_cross < t[1] - t[0]
    assert classify(_result(np.full(1001, 1e-4))).reached_at_s == np.inf


def test_describe_names_the_window_the_verdict_used():
    features = np.outer(np.exp(-np.linspace(0.0, 5.0, 101)), np.ones(9)) * 1e-3
    result = synthetic_result(features, np.zeros(9))
    assert "over the last 20 %" in classify(result).describe()
    wide = classify(result, Tolerances(window=0.5))
    assert wide.window == 0.5 and "over the last 50 %" in wide.describe()
    assert wide.error_change != classify(result).error_change
