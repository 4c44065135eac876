"""Disturbances as data and as wrappers: validation, serialization, the sensor and plant wrappers,
the missing-feature policy, and bit-identity with the undisturbed simulator when all are off.

The closed-loop effects (noise floor, latency margin, saturation, calibration, mismatch) are in
``test_disturbance_effects.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla.controllers import CommandType, Controller
from ibvs_youla.exceptions import InvalidParameterError
from ibvs_youla.simulation.disturbances import (
    DelayedSensor,
    Disturbances,
    DisturbedSensor,
    HoldOnMissingFeatures,
    PlantArm,
)
from ibvs_youla.simulation.plant import ArmPlant
from ibvs_youla.simulation.sensor import MarkerSensor

SQUARE = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]
FREE = iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0)


def _pose(t, rotvec_deg=(0.0, 0.0, 0.0)):
    from scipy.spatial.transform import Rotation

    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(np.radians(rotvec_deg)).as_matrix()
    T[:3, 3] = t
    return T


TARGET = _pose([0.0, 0.0, -0.75])  # the square seen face-on from 0.75 m
START = _pose([0.05, -0.03, -0.9], [5.0, -5.0, 20.0])
FREE_SCENARIO = iy.Scenario.free_camera(T_O_C_start=START, T_O_C_target=TARGET, markers_O=SQUARE)


def _free_run(controller="ibvs-current", duration=4.0, **kwargs):
    ctrl = iy.controllers.make(controller) if isinstance(controller, str) else controller
    return iy.simulate(
        FREE_SCENARIO,
        ctrl,
        plant="free-camera",
        camera=iy.PinholeCamera.normalized(),
        duration=duration,
        settings=FREE,
        **kwargs,
    )


def _assert_identical(a, b):
    for name in ("t", "camera_pose", "features", "visible", "frame_t", "frame_features", "frame_visible"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.signals.keys() == b.signals.keys()
    for name in a.signals:
        np.testing.assert_array_equal(a.signals[name], b.signals[name], err_msg=name)
    assert a.status == b.status
    assert a.metadata["spec"] == b.metadata["spec"]


# ---------------------------------------------------------------------- data
def test_all_off_is_an_empty_dict_and_round_trips():
    assert Disturbances().to_dict() == {}
    assert not Disturbances(seed=12).active  # a seed alone disturbs nothing
    d = Disturbances(pixel_noise_px=0.5, hand_eye_translation_m=(0.001, 0, 0), latency_frames=2, seed=3)
    assert d.to_dict() == {
        "pixel_noise_px": 0.5,
        "hand_eye_translation_m": [0.001, 0.0, 0.0],
        "latency_frames": 2,
        "seed": 3,
    }
    assert Disturbances.from_dict(d.to_dict()) == d
    # one friction value per joint, all equal, is that value: six zeros are "off"
    assert Disturbances(coulomb_friction=(0.0,) * 6, viscous_friction=[2.0] * 6).to_dict() == {
        "viscous_friction": 2.0
    }


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("pixel_noise_px", -0.1),
        ("dropout_probability", 1.0),
        ("dropout_probability", -0.2),
        ("focal_length_scale", 0.0),
        ("marker_scale", -1.0),
        ("plant_inertia_scale", 0.0),
        ("viscous_friction", -1.0),
        ("coulomb_friction", (1.0, 2.0)),
        ("latency_frames", -1),
        ("latency_frames", 1.5),
        ("limit_scale", 0.0),
        ("hand_eye_translation_m", (0.0, 0.0)),
        ("hand_eye_rotation_deg", (180.0, 0.0, 0.0)),
        ("seed", -3),
        ("quantize", "yes"),
        # ragged vectors (a TOML array may mix numbers and arrays): the field's error, not numpy's
        ("principal_point_offset_px", (1.0, [2.0])),
        ("marker_offset_m", (0.0, [1.0], 2.0)),
        ("viscous_friction", (0.5, [1.0], 0.5, 0.5, 0.5, 0.5)),
        ("rendered_images", 1),
        ("image_blur_px", -1.0),
    ],
)
def test_bad_values_name_what_was_received(field, value):
    with pytest.raises(InvalidParameterError, match=field):
        Disturbances(**{field: value})


def test_an_unknown_field_is_named():
    with pytest.raises(InvalidParameterError, match="pixel_nosie_px"):
        Disturbances.from_dict({"pixel_nosie_px": 1.0})


@pytest.mark.parametrize(
    ("disturbances", "plant", "match"),
    [
        (Disturbances(plant_inertia_scale=2.0), "kinematic", "plant_inertia_scale"),
        (Disturbances(coulomb_friction=1.0), "free-camera", "coulomb_friction"),
        (Disturbances(limit_scale=0.5), "kinematic", "limit_scale"),
        (Disturbances(hand_eye_translation_m=(0.001, 0.0, 0.0)), "free-camera", "hand_eye"),
        (Disturbances(baseline_scale=1.01), "free-camera", "baseline_scale"),
    ],
)
def test_a_disturbance_with_nothing_to_act_on_is_refused(disturbances, plant, match):
    with pytest.raises(InvalidParameterError, match=match):
        disturbances.check_applies(plant, iy.PinholeCamera.normalized())
    if plant == "free-camera":  # and simulate refuses it before running
        with pytest.raises(InvalidParameterError, match=match):
            _free_run(duration=0.04, disturbances=disturbances)


# ---------------------------------------------------------------------- off = undisturbed, bit for bit
def test_all_off_is_bit_identical_on_the_free_camera():
    reference = _free_run()
    _assert_identical(reference, _free_run(disturbances=Disturbances()))
    _assert_identical(reference, _free_run(disturbances=Disturbances(seed=99, normalized_focal_px=600.0)))
    assert "disturbances" not in _free_run(disturbances=Disturbances()).metadata["spec"]


def test_all_off_is_bit_identical_on_the_arms(arm):
    scenario = iy.scenarios.get("physical-2")
    for plant, controller, duration in (("kinematic", "fb", 0.5), ("dynamic", "ff+fb", 0.1)):
        reference = iy.simulate(scenario, controller, duration=duration, plant=plant, arm=arm)
        again = iy.simulate(
            scenario, controller, duration=duration, plant=plant, arm=arm, disturbances=Disturbances(seed=5)
        )
        _assert_identical(reference, again)


def test_limits_at_scale_one_equal_the_settings_saturation(arm):
    """The wrapped plant arm (no friction, limits x1) clips exactly where ``saturate=True`` does."""
    scenario = iy.scenarios.get("physical-2")
    saturated = iy.simulate(
        scenario, "ff+fb", duration=0.05, arm=arm, settings=iy.SimulationSettings(saturate=True)
    )
    limited = Disturbances(limit_scale=1.0)
    wrapped = iy.simulate(scenario, "ff+fb", duration=0.05, arm=arm, disturbances=limited)
    for name in ("q_true", "dq", "tau"):
        np.testing.assert_array_equal(saturated.signals[name], wrapped.signals[name], err_msg=name)
    assert wrapped.metadata["spec"]["disturbances"] == {"limit_scale": 1.0}


# ---------------------------------------------------------------------- sensing wrapper
def _sensor(camera=None):
    return MarkerSensor(iy.PinholeCamera.normalized() if camera is None else camera, SQUARE)


def test_noise_has_the_stated_deviation_in_pixels(camera):
    """sigma px on every entry: 1 px = 1/800 on the normalized camera, the pixel pitch on the ZED 2."""
    rng = np.random.default_rng(0)
    for cam, pitch in ((iy.PinholeCamera.normalized(), 1.0 / 800.0), (camera, camera.pixel_pitch)):
        sensor = MarkerSensor(cam, SQUARE)
        T = TARGET if cam.focal_length == 1.0 else _pose([0.0, 0.0, -1.5])
        noisy = DisturbedSensor(sensor, noise_px=0.7, noise_rng=rng)
        errors = np.array([noisy.measure(T, 0.0).features - sensor.features_at(T) for _ in range(4000)])
        # 4000 x 8 (or x 12) draws: the sample deviation's relative standard error is 1/sqrt(2 n) =
        # 0.40 % (0.32 %), so 1.2 % is 3 of them (measured -0.31 % and +0.16 %)
        assert errors.std() / pitch == pytest.approx(0.7, rel=0.012)
        assert abs(errors.mean()) / pitch < 0.01


def test_quantization_moves_each_entry_to_its_pixel_centre(camera):
    sensor = MarkerSensor(camera, SQUARE)
    quantized = DisturbedSensor(sensor, quantize=True)
    rng = np.random.default_rng(1)
    errors = []
    for _ in range(300):
        T = _pose([rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), -rng.uniform(1.0, 2.0)])
        frame = quantized.measure(T, 0.0)
        px = camera.to_pixels(frame.features.reshape(4, 3))
        np.testing.assert_allclose(px - np.floor(px), 0.5, atol=1e-6)  # pixel centres
        errors.append((frame.features - sensor.features_at(T)) / camera.pixel_pitch)
    errors = np.concatenate(errors)
    assert np.abs(errors).max() <= 0.5 + 1e-6
    # uniform on a pixel: 0.289 px; 3600 entries give the deviation a relative standard error of
    # sqrt(0.8 / (4 n)) = 0.75 % (a uniform's kurtosis is 1.8), so 3 % is 4 of them (measured +1.3 %)
    assert errors.std() == pytest.approx(np.sqrt(1.0 / 12.0), rel=0.03)


def test_a_principal_point_belief_shifts_frames_and_target_alike(camera):
    sensor = MarkerSensor(camera, SQUARE)
    shifted = DisturbedSensor(sensor, principal_point_offset_px=(3.0, -2.0))
    T = _pose([0.02, 0.0, -1.5])
    shift = np.tile([-3.0, -3.0, 2.0], 4) * camera.pixel_pitch  # u_l, u_r, v per point [m]
    np.testing.assert_allclose(shifted.measure(T, 0.0).features - sensor.features_at(T), shift, atol=1e-15)
    np.testing.assert_allclose(shifted.features_at(T) - sensor.features_at(T), shift, atol=1e-15)


def test_dropouts_blank_whole_markers_never_the_first_frame():
    sensor = _sensor()
    dropping = DisturbedSensor(sensor, dropout=0.4, dropout_rng=np.random.default_rng(2))
    frames = [dropping.measure(TARGET, 0.04 * k) for k in range(3000)]
    assert np.isfinite(frames[0].features).all()
    missing = np.array([~np.isfinite(f.features.reshape(4, 2)).all(axis=1) for f in frames[1:]])
    blank = np.array([np.isnan(f.features.reshape(4, 2)).all(axis=1) for f in frames[1:]])
    np.testing.assert_array_equal(missing, blank)  # a marker is missing in all its coordinates
    np.testing.assert_array_equal(missing, ~np.array([f.visible for f in frames[1:]]))
    assert missing.mean() == pytest.approx(0.4, abs=0.02)  # 12 000 Bernoulli draws: sd 0.0045


def test_the_delayed_sensor_returns_the_frame_of_k_frames_before():
    delayed = DelayedSensor(_sensor(), 2)
    poses = [_pose([0.01 * k, 0.0, -0.75]) for k in range(6)]
    frames = [delayed.measure(T, 0.04 * k) for k, T in enumerate(poses)]
    assert [f.t for f in frames] == [0.0, 0.0, 0.0, 0.04, 0.08, 0.12]
    np.testing.assert_array_equal(frames[5].features, _sensor().features_at(poses[3]))


# ---------------------------------------------------------------------- missing-feature policy
class _Recorder(Controller):
    """A twist controller that records the frames it was given and commands a twist from their count."""

    command_type = CommandType.CAMERA_TWIST
    name = "recorder"

    def reset(self, task):
        super().reset(task)
        self.seen = []

    def update(self, frame, reading):
        self.seen.append(frame.t)

    def command(self, reading):
        return np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1e-3 * len(self.seen)])


def test_frames_with_missing_features_are_withheld_and_the_command_held():
    inner = _Recorder()
    result = _free_run(inner, duration=8.0, disturbances=Disturbances(dropout_probability=0.3, seed=4))
    complete = np.isfinite(result.frame_features).all(axis=1)
    assert complete.mean() == pytest.approx(0.7**4, abs=0.1)  # 200 frames: standard deviation 0.03
    np.testing.assert_array_equal(inner.seen, result.frame_t[complete])  # exactly the complete frames
    withheld = result.signals["frames_withheld"][:, 0]
    assert withheld[-1] == np.count_nonzero(~complete)
    # the command changes only on a complete frame: held across the withheld ones
    twist_z = result.signals["camera_twist"][:, 5]
    np.testing.assert_array_equal(twist_z[1:] != twist_z[:-1], complete[1:])


def test_the_policy_wraps_only_when_dropouts_are_on():
    ctrl = iy.controllers.make("pbvs")
    assert Disturbances(pixel_noise_px=1.0).wrap_controller(ctrl) is ctrl
    wrapped = Disturbances(dropout_probability=0.1).wrap_controller(ctrl)
    assert isinstance(wrapped, HoldOnMissingFeatures)
    assert wrapped.name == "pbvs" and wrapped.spec() == ctrl.spec()


# ---------------------------------------------------------------------- plant wrapper
def test_friction_acts_in_the_plant_arm_only(arm):
    plant_arm = Disturbances(viscous_friction=2.0, coulomb_friction=(5, 5, 5, 1, 1, 0.5)).plant_arm(arm)
    assert isinstance(plant_arm, PlantArm)
    q, dq, tau = np.full(6, 0.2), np.array([0.3, -0.2, 0.1, -1.0, 0.02, 0.0]), np.full(6, 10.0)
    friction = 2.0 * dq + np.array([5, 5, 5, 1, 1, 0.5]) * np.tanh(dq / 0.05)
    np.testing.assert_allclose(plant_arm.aba(q, dq, tau), arm.aba(q, dq, tau - friction), rtol=1e-12)
    assert plant_arm.camera_fk is not None and plant_arm.q_min is arm.q_min  # kinematics: the arm's


def test_scaled_inertias_are_the_plants_not_the_models(arm):
    plant_arm = Disturbances(plant_inertia_scale=2.0).plant_arm(arm)
    q = np.array([0.1, -0.3, 0.4, 0.2, 0.5, -0.1])
    M_true = plant_arm.mass_matrix(q)
    armature = np.diag(arm.armature)
    np.testing.assert_allclose(M_true - armature, 2.0 * (arm.mass_matrix(q) - armature), rtol=1e-10)
    np.testing.assert_allclose(plant_arm.camera_pose(q), arm.camera_pose(q), atol=1e-15)


def test_the_plant_clips_torques_and_speeds_at_the_scaled_limits(arm):
    plant_arm = Disturbances(limit_scale=0.25).plant_arm(arm)
    plant = ArmPlant(plant_arm, q_encoder=np.zeros(6), saturate_torque=True, saturate_speed=True)
    applied = plant.step(np.full(6, 1e5), 1e-3)
    np.testing.assert_array_equal(applied, 0.25 * np.asarray(arm.tau_max))
    for _ in range(300):
        plant.step(np.full(6, 1e5), 1e-3)
    assert np.all(np.abs(plant.dq) <= 0.25 * np.asarray(arm.dq_max))
    assert np.any(np.abs(plant.dq) == 0.25 * np.asarray(arm.dq_max))  # some joint at its limit
