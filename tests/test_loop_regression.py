"""The paper's controller gives the signals it gave before the servo-loop rebuild, to 1e-8 relative.

``tests/regression/loop_reference.npz`` was written by ``tests/regression/make_reference.py`` from
the monolithic loop that the role-based loop replaced (the commit is stored in the file). Each case
re-runs through the public ``simulate`` and every recorded sample must match to 1e-8 of its own
value, with a floor of 1e-11 of its column's largest magnitude where a value crosses zero (the
paper's 1 ms feedforward drives torques to ~1e7 N m early on, so a floor relative to the whole
signal would allow 1e-3 relative errors on the later ~100 N m torques).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla import scenarios
from ibvs_youla.simulation.settings import SimulationSettings

REFERENCE = Path(__file__).parent / "regression" / "loop_reference.npz"
RTOL = 1e-8
FLOOR = 1e-11


def _cases():
    with np.load(REFERENCE) as data:
        return json.loads(str(data["__index__"]))["cases"]


@pytest.fixture(scope="module")
def reference():
    with np.load(REFERENCE) as data:
        return {k: data[k] for k in data.files}


@pytest.mark.parametrize("case", _cases(), ids=lambda c: c["name"])
def test_paper_controller_matches_the_pre_rebuild_loop(case, reference, arm):
    make = SimulationSettings.paper if case["paper_settings"] else SimulationSettings
    settings = make(**case["settings"])
    result = iy.simulate(
        scenarios.get(case["scenario"]),
        case["controller"],
        case["adaptive"],
        case["duration"],
        settings=settings,
        arm=arm,
    )
    name = case["name"]
    assert result.metadata["status"] == case["status"]
    assert len(result.update_time) == int(reference[f"{name}/n_updates"])
    np.testing.assert_array_equal(result.t, reference[f"{name}/t"])
    np.testing.assert_array_equal(result.visible, reference[f"{name}/visible"])
    for signal in (
        "q",
        "q_true",
        "dq",
        "q_ref",
        "q_ff",
        "q_fb",
        "tau",
        "features",
        "feature_error",
        "camera_pose",
    ):
        expected = reference[f"{name}/{signal}"]
        # per column (joint, feature, pose entry): within 1e-8 of each value, plus a floor of 1e-11
        # of the column's largest magnitude for values near a zero crossing
        actual = getattr(result, signal)
        floor = FLOOR * np.abs(expected).max(axis=0)
        bad = np.abs(actual - expected) > RTOL * np.abs(expected) + floor
        assert not bad.any(), f"{name}: {signal} differs at {np.argwhere(bad)[:5].tolist()}"
