"""Write ``loop_reference.npz``: the paper controller's signals from the loop before the role-based loop.

Run once, at the commit that still had the monolithic ``simulation/simulate.py`` loop, with
``.venv/bin/python tests/regression/make_reference.py``; ``tests/test_loop_regression.py`` then
requires every later loop to reproduce these signals to 1e-8 relative. Re-running it on a
later version would only compare that version with itself: do not, unless an issue says why
the paper controller's numbers change.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np

import ibvs_youla as iy
from ibvs_youla import scenarios
from ibvs_youla.simulation.settings import SimulationSettings

# (name, scenario, controller, adaptive, duration [s], settings keywords, paper settings?)
CASES = [
    ("p1-ffb-adaptive-paper", "paper-1", "ff+fb", True, 0.3, {}, True),
    ("p2-ffb-adaptive-paper", "paper-2", "ff+fb", True, 0.3, {}, True),
    (
        "p1-fb-adaptive-previous",
        "paper-1",
        "fb",
        True,
        0.3,
        {"branch_prior": "previous", "record_every": 3},
        True,
    ),
    ("p2-fb-fixed-paper", "paper-2", "fb", False, 0.3, {}, True),
    ("p2-fb-fixed-target", "paper-2", "fb", False, 0.3, {"linearize_at": "target"}, True),
    ("p1-fb-adaptive-encoders", "paper-1", "fb", True, 0.3, {"estimate_from_image": False}, True),
    ("p1-ffb-adaptive-100hz", "paper-1", "ff+fb", True, 0.3, {}, False),
    (
        "ph2-ffb-smooth-saturate",
        "physical-2",
        "ff+fb",
        True,
        0.3,
        {"feedforward": "smooth", "saturate": True},
        False,
    ),
    ("ph1-fb-fixed-100hz", "physical-1", "fb", False, 1.0, {"record_every": 5}, False),
    ("ph2-ffb-adaptive-100hz", "physical-2", "ff+fb", True, 1.0, {"record_every": 5}, False),
    ("p2-ffb-fixed-paper", "paper-2", "ff+fb", False, 0.3, {}, True),
    (
        "ph1-ffb-mismatch",
        "physical-1",
        "ff+fb",
        True,
        0.5,
        {"model_inertia_scale": 1.2, "record_every": 2},
        False,
    ),
    ("ph1-ffb-paper-1khz", "physical-1", "ff+fb", True, 0.3, {}, True),
]
SIGNALS = (
    "t",
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
    "visible",
)


def main() -> None:
    out: dict[str, np.ndarray] = {}
    index = []
    for name, scenario, controller, adaptive, duration, overrides, paper in CASES:
        settings = SimulationSettings.paper(**overrides) if paper else SimulationSettings(**overrides)
        result = iy.simulate(scenarios.get(scenario), controller, adaptive, duration, settings=settings)
        for signal in SIGNALS:
            out[f"{name}/{signal}"] = getattr(result, signal)
        out[f"{name}/n_updates"] = np.array(len(result.update_time))
        index.append(
            {
                "name": name,
                "scenario": scenario,
                "controller": controller,
                "adaptive": adaptive,
                "duration": duration,
                "settings": overrides,
                "paper_settings": paper,
                "status": result.metadata["status"],
            }
        )
    commit = subprocess.run(
        ["git", "rev-parse", "HEAD"], capture_output=True, text=True, check=False
    ).stdout.strip()
    out["__index__"] = np.array(json.dumps({"commit": commit, "cases": index}))
    path = Path(__file__).with_name("loop_reference.npz")
    np.savez_compressed(path, **out)
    print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB, {len(CASES)} cases, from {commit})")


if __name__ == "__main__":
    main()
