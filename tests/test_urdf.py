"""The IRB 4600 URDF: generated from its documented parameters, DH-exact, physically consistent."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yourdfpy
from ibvs_youla.urdf import make_irb4600_urdf as gen

URDF = Path(gen.__file__).with_name(gen.URDF_NAME)
RNG_SEED = 20240611


@pytest.fixture(scope="module")
def model():
    return pin.buildModelFromUrdf(str(URDF))


def dh_numpy(q):
    """Plain-numpy standard DH product of ERRATA 1, written independently of the generator."""
    rows = [(0.495, 0.175, -90, 0), (0, 0.900, 0, -90), (0, 0.175, -90, 0), (0.960, 0, 90, 0),
            (0, 0, -90, 0), (0.135, 0, 0, 0)]  # fmt: skip
    T = np.eye(4)
    for (d, a, alpha_deg, offset_deg), qi in zip(rows, q, strict=True):
        th, al = qi + np.radians(offset_deg), np.radians(alpha_deg)
        Rz = np.array(
            [[np.cos(th), -np.sin(th), 0, 0], [np.sin(th), np.cos(th), 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
        )
        Tz = np.eye(4)
        Tz[2, 3] = d
        Tx = np.eye(4)
        Tx[0, 3] = a
        Rx = np.array(
            [[1, 0, 0, 0], [0, np.cos(al), -np.sin(al), 0], [0, np.sin(al), np.cos(al), 0], [0, 0, 0, 1]]
        )
        T = T @ Rz @ Tz @ Tx @ Rx
    return T


def random_q(rng, n):
    lo, hi = np.radians(gen.Q_MIN_DEG), np.radians(gen.Q_MAX_DEG)
    return lo + (hi - lo) * rng.random((n, 6))


def test_committed_urdf_is_what_the_generator_writes():
    assert URDF.read_text() == gen.build_urdf()


def test_urdf_reproduces_the_dh_table_at_random_q(model):
    data = model.createData()
    flange, camera = model.getFrameId("flange"), model.getFrameId("camera")
    Rz_pi = np.diag([-1.0, -1.0, 1.0, 1.0])
    for q in random_q(np.random.default_rng(RNG_SEED), 200):
        pin.framesForwardKinematics(model, data, q)
        T_dh = dh_numpy(q)
        np.testing.assert_allclose(data.oMf[flange].homogeneous, T_dh, rtol=0, atol=1e-12)
        np.testing.assert_allclose(data.oMf[camera].homogeneous, T_dh @ Rz_pi, rtol=0, atol=1e-12)


def test_home_pose_puts_the_flange_at_table1_position_facing_base_x(model):
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.zeros(6))
    T_O_E = data.oMf[model.getFrameId("flange")]
    np.testing.assert_allclose(T_O_E.translation, [1.27, 0.0, 1.57], atol=1e-12)
    np.testing.assert_allclose(T_O_E.rotation[:, 2], [1.0, 0.0, 0.0], atol=1e-12)


def test_yourdfpy_and_pinocchio_agree_on_the_camera_pose(model):
    robot = yourdfpy.URDF.load(str(URDF), load_meshes=False)
    assert robot.actuated_joint_names == [f"joint_{i}" for i in range(1, 7)]
    data = model.createData()
    camera = model.getFrameId("camera")
    for q in random_q(np.random.default_rng(RNG_SEED + 1), 20):
        robot.update_cfg(q)
        pin.framesForwardKinematics(model, data, q)
        np.testing.assert_allclose(
            robot.get_transform("camera", "base_link"), data.oMf[camera].homogeneous, rtol=0, atol=1e-12
        )


def test_limits_come_from_table_a2_abb_speeds_and_the_torque_derivation(model):
    np.testing.assert_allclose(np.degrees(model.lowerPositionLimit), [-180, -90, -180, -400, -125, -400])
    np.testing.assert_allclose(np.degrees(model.upperPositionLimit), [180, 150, 75, 400, 120, 400])
    np.testing.assert_allclose(np.degrees(model.velocityLimit), [175, 175, 175, 250, 250, 360])
    np.testing.assert_allclose(model.effortLimit, gen.TORQUE_LIMITS)


def test_masses_total_412_kg_plus_camera_and_follow_solid_volumes(model):
    robot = yourdfpy.URDF.load(str(URDF), load_meshes=False)
    masses = {name: link.inertial.mass for name, link in robot.link_map.items() if link.inertial is not None}
    assert sum(m for name, m in masses.items() if name != "camera") == pytest.approx(412.0, abs=1e-9)
    assert masses["camera"] == pytest.approx(0.17)
    density = {name: masses[name] / gen.solid_volume(solid) for name, solid in gen.SOLIDS.items()}
    assert max(density.values()) == pytest.approx(min(density.values()), rel=1e-12)
    assert sum(inertia.mass for inertia in model.inertias) == pytest.approx(412.17, abs=1e-9)


@pytest.mark.parametrize("source", ["urdf", "pinocchio"])
def test_every_inertia_is_positive_definite_and_satisfies_the_triangle_inequality(model, source):
    if source == "urdf":
        links = yourdfpy.URDF.load(str(URDF), load_meshes=False).link_map.values()
        tensors = [link.inertial.inertia for link in links if link.inertial is not None]
        assert len(tensors) == 8  # base, 6 links, camera
    else:  # Pinocchio merges the camera into link_6 and the base into the universe
        tensors = [inertia.inertia for inertia in list(model.inertias)[1:]]
    for tensor in tensors:
        principal = np.linalg.eigvalsh(tensor)
        assert principal.min() > 0.0
        a, b, c = principal
        assert a + b >= c - 1e-15 and a + c >= b - 1e-15 and b + c >= a - 1e-15


def test_camera_link_is_rz_pi_on_the_flange_with_a_box_inertia(model):
    robot = yourdfpy.URDF.load(str(URDF), load_meshes=False)
    T_E_C = robot.joint_map["flange-camera"].origin
    np.testing.assert_allclose(T_E_C, np.diag([-1.0, -1.0, 1.0, 1.0]), atol=1e-15)
    inertia = robot.link_map["camera"].inertial.inertia
    sx, sy, sz = gen.CAMERA_BOX
    np.testing.assert_allclose(
        np.diag(inertia), 0.17 / 12 * np.array([sy**2 + sz**2, sx**2 + sz**2, sx**2 + sy**2])
    )


def test_torque_limits_are_the_rounded_up_derivation():
    required = gen.derive_torque_limits(n_samples=1000)
    limits = np.array(gen.TORQUE_LIMITS)
    assert np.all(required <= limits)
    np.testing.assert_allclose([gen.round_up_2sig(x) for x in required], limits)


def test_rpy_conversion_round_trips_including_gimbal_lock():
    for i in range(1, 7):
        T = gen.joint_origin(i)
        roll, pitch, yaw = gen.rpy_from_rotation(T[:3, :3])
        R = pin.rpy.rpyToMatrix(roll, pitch, yaw)
        np.testing.assert_allclose(R, T[:3, :3], atol=1e-15)
    assert math.isclose(gen.round_up_2sig(3065.4), 3100.0)
