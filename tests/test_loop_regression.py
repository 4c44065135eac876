"""The paper's controller gives the signals it gave before the servo-loop rebuild, to 1e-8 relative.

``tests/regression/loop_reference.npz`` was written by ``tests/regression/make_reference.py`` from
the monolithic loop that the role-based loop replaced (the commit is stored in the file). Each case
re-runs through the public ``simulate`` and every recorded signal must match: the difference over
the whole run is at most 1e-8 of the signal's largest magnitude (the paper's 1 ms feedforward
drives torques to ~1e7 N m, so a per-sample relative test would be meaningless near zero crossings).
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
        scale = max(np.abs(expected).max(), 1e-300)
        np.testing.assert_allclose(
            getattr(result, signal), expected, rtol=0, atol=RTOL * scale, err_msg=f"{name}: {signal}"
        )
