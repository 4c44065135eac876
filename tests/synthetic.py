"""A SimulationResult built from a given feature trajectory, for tests of analysis code."""

from __future__ import annotations

from typing import Any

import numpy as np

from ibvs_youla.simulation.results import SimulationResult


def synthetic_result(
    features: np.ndarray,
    feature_target: np.ndarray,
    *,
    duration: float = 10.0,
    q: np.ndarray | None = None,
    camera_x_m: float = 0.0,
    metadata: dict[str, Any] | None = None,
) -> SimulationResult:
    """Samples over ``[0, duration]``; the camera sits ``camera_x_m`` from its target along x."""
    n = len(features)
    q = np.zeros((n, 6)) if q is None else q
    zeros = np.zeros((n, 6))
    pose = np.tile(np.eye(4), (n, 1, 1))
    pose[:, 0, 3] = camera_x_m
    return SimulationResult(
        t=np.linspace(0.0, duration, n),
        camera_pose=pose,
        camera_pose_target=np.eye(4),
        features=features,
        feature_target=feature_target,
        visible=np.ones((n, len(feature_target) // 3), bool),
        signals={"q": q, "q_true": q, "dq": zeros, "q_ref": q, "q_ff": zeros, "q_fb": q, "tau": zeros},
        metadata={} if metadata is None else metadata,
    )
