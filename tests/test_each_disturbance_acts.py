"""Every field of :class:`~ibvs_youla.Disturbances` acts: each one alone changes the run.

A disturbance that is recorded but never applied (joint friction was, until the plant's RK4 applied
it) cannot pass here: for each field the run with it alone is compared with the run without it,
on a run where it has something to act on. A parameter of other disturbances (``seed``,
``coulomb_speed``, ``normalized_focal_px``, the image blur and noise) is compared with the run of
the disturbance it parametrizes, unchanged but for it. A field missing from the table fails the
last test, so a new disturbance gets its test.
"""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla.simulation.disturbances import Disturbances

DURATION = 0.06  # [s]: 6 camera frames at 100 Hz, 60 joint ticks at 1 kHz

# field -> (its value, the other fields of both runs, the plant)
CASES = {
    "pixel_noise_px": (0.5, {}, "dynamic"),
    "quantize": (True, {}, "dynamic"),
    "dropout_probability": (0.5, {}, "dynamic"),
    "rendered_images": (True, {}, "kinematic"),
    "image_blur_px": (1.5, {"rendered_images": True}, "kinematic"),
    "image_noise_grey": (5.0, {"rendered_images": True}, "kinematic"),
    "normalized_focal_px": (200.0, {"pixel_noise_px": 0.5}, "free-camera"),
    "focal_length_scale": (1.02, {}, "dynamic"),
    "baseline_scale": (1.02, {}, "dynamic"),
    "principal_point_offset_px": ((2.0, -1.0), {}, "dynamic"),
    "hand_eye_translation_m": ((0.002, 0.0, 0.0), {}, "dynamic"),
    "hand_eye_rotation_deg": ((0.0, 0.5, 0.0), {}, "dynamic"),
    "marker_offset_m": ((0.0, 0.003, 0.0), {}, "dynamic"),
    "marker_scale": (1.02, {}, "dynamic"),
    "marker_sigma_m": (0.002, {}, "dynamic"),
    "plant_inertia_scale": (2.0, {}, "dynamic"),
    "viscous_friction": (200.0, {}, "dynamic"),
    "coulomb_friction": (50.0, {}, "dynamic"),
    "coulomb_speed": (0.5, {"coulomb_friction": 50.0}, "dynamic"),
    "latency_frames": (2, {}, "dynamic"),
    "limit_scale": (0.05, {}, "dynamic"),
    "seed": (1, {"pixel_noise_px": 0.05}, "dynamic"),
    "depth_noise_m": (0.01, {}, "free-camera"),
}
SENSOR = {"depth_noise_m": "depth"}  # a field that needs a sensor other than the ideal one

SQUARE = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]


def _free_camera_run(disturbances, sensor=None):
    start, target = np.eye(4), np.eye(4)
    start[:3, 3], target[:3, 3] = [0.05, -0.03, -0.9], [0.0, 0.0, -0.75]
    scenario = iy.Scenario.free_camera(T_O_C_start=start, T_O_C_target=target, markers_O=SQUARE)
    return iy.simulate(
        scenario,
        iy.controllers.make("ibvs-current"),
        plant="free-camera",
        camera=iy.PinholeCamera.normalized(),
        duration=0.4,
        settings=iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0),
        disturbances=disturbances,
        sensor=sensor,
    )


def _run(plant, sensor=None, **values):
    disturbances = Disturbances(**values)
    if plant == "free-camera":
        return _free_camera_run(disturbances, sensor)
    return iy.simulate(
        iy.scenarios.physical(1), "fb", duration=DURATION, plant=plant, disturbances=disturbances
    )


def _difference(a, b):
    """The largest difference of the recorded trajectories (camera poses, features, joints)."""
    if a.status != b.status or a.t.shape != b.t.shape:
        return np.inf  # one run ended otherwise (e.g. Eq. (62) failed on noisy markers)
    worst = np.abs(a.camera_pose - b.camera_pose).max()
    both = np.isfinite(a.frame_features) & np.isfinite(b.frame_features)
    worst = max(worst, np.abs(a.frame_features - b.frame_features)[both].max())
    if not np.array_equal(np.isnan(a.frame_features), np.isnan(b.frame_features)):
        worst = np.inf  # a marker missing in one run only
    for name in ("q_true", "q_ref"):
        if name in a.signals:
            worst = max(worst, np.abs(a.signals[name] - b.signals[name]).max())
    return worst


@pytest.mark.parametrize("field", sorted(CASES))
def test_each_disturbance_alone_changes_the_run(field):
    value, others, plant = CASES[field]
    without = _run(plant, SENSOR.get(field), **others)
    with_it = _run(plant, SENSOR.get(field), **others, **{field: value})
    assert with_it.metadata["spec"]["disturbances"][field] == (
        list(value) if isinstance(value, tuple) else value
    )
    # a field that did nothing gives exactly 0; measured 6.3e-4 (hand_eye_translation_m) to 0.017
    # (limit_scale), in the units of the recorded signals (m, rad, sensor m), or a marker missing
    assert _difference(with_it, without) > 1e-4, field


def test_every_field_has_a_case():
    assert set(CASES) == {f.name for f in fields(Disturbances)}
