"""Arm: Table 1 kinematics, LOCAL camera Jacobian, Eq. (29)-(32) dynamics, derived arms, loading, errors."""

from __future__ import annotations

from dataclasses import astuple

import numpy as np
import pinocchio as pin
import pytest

from ibvs_youla.exceptions import InvalidArrayError, InvalidParameterError, ModelLoadError
from ibvs_youla.model._resources import example_robot_data_urdf, urdf_path
from ibvs_youla.model.arm import ActuatorParameters, Arm
from ibvs_youla.model.ik import SphericalWristParameters

SEED = 4600

# Table 1 joint vectors [deg] and printed camera poses [n s a d] (3 x 4), read per ERRATA 2 and 6.
TABLE1 = {
    "scenario 1 initial": ((0, 0, 0, 0, 0, 0), [[0, 0, 1, 1.27], [0, 1, 0, 0], [-1, 0, 0, 1.57]]),
    "scenario 1 final": (
        (0.48, 2.21, 2.05, -82.68, 9.46, 77.47),
        [[-0.11, 0.14, 0.98, 1.31], [-0.09, 0.98, -0.15, -0.01], [-0.99, -0.10, -0.09, 1.49]],
    ),
    "scenario 2 initial": (  # n_z printed -0.060; n = s x a gives +0.060 (ERRATA 2)
        (42.40, 21.20, 4.58, -2.86, 66.46, -42.40),
        [[-0.070, -0.998, 0.002, 1.064], [-0.996, 0.070, -0.060, 0.964], [0.060, -0.007, -0.998, 0.939]],
    ),
    "scenario 2 final": (  # printed matrix malformed; ERRATA 6
        (45, 18.59, 4.35, 0, 67.06, -45),
        [[0, -1, 0, 1], [-1, 0, 0, 1], [0, 0, -1, 1]],
    ),
}


@pytest.fixture(scope="module")
def arm_reflected():
    return Arm.irb4600(actuator="reflected")


def random_q(arm, rng, n):
    return arm.q_min + (arm.q_max - arm.q_min) * rng.random((n, 6))


@pytest.mark.parametrize("case", TABLE1)
def test_camera_pose_matches_table1(arm, case):
    q_deg, printed = TABLE1[case]
    T_O_C = arm.camera_pose(np.radians(q_deg))
    np.testing.assert_allclose(T_O_C[:3], printed, rtol=0, atol=0.01)  # Table 1 prints 2-3 decimals
    np.testing.assert_allclose(T_O_C[3], [0, 0, 0, 1])


def test_attributes_of_the_irb4600(arm):
    assert arm.nq == 6 and arm.name.startswith("ABB IRB 4600-45/2.05")
    np.testing.assert_allclose(arm.T_E_C, np.diag([-1.0, -1.0, 1.0, 1.0]), atol=1e-15)  # ERRATA 2
    np.testing.assert_allclose(np.degrees(arm.q_max), [180, 150, 75, 400, 120, 400])
    np.testing.assert_allclose(np.degrees(arm.dq_max), [175, 175, 175, 250, 250, 360])
    np.testing.assert_allclose(arm.tau_max, [3100, 5100, 1500, 210, 210, 54])
    np.testing.assert_allclose(arm.camera_pose(np.zeros(6)), arm.flange_pose(np.zeros(6)) @ arm.T_E_C)
    with pytest.raises(ValueError):
        arm.q_min[0] = 0.0  # attributes are read-only views of the model


def test_actuator_mappings_of_eq29(arm, arm_reflected):
    np.testing.assert_allclose(arm.armature, 0.09847 + 0.05)  # J_a + J_g [kg m^2]
    np.testing.assert_allclose(arm.damping, 0.06 / 200)  # B_m / r [N m s/rad]
    np.testing.assert_allclose(arm_reflected.armature, 200**2 * 0.14847)
    np.testing.assert_allclose(arm_reflected.damping, 200**2 * 0.06)
    np.testing.assert_allclose(arm.model.armature, arm.armature)
    np.testing.assert_allclose(arm.model.damping, 0.0)  # Pinocchio ignores it; the Arm applies it
    with pytest.raises(InvalidParameterError):
        Arm.irb4600(actuator="motor-side")
    with pytest.raises(InvalidParameterError):
        ActuatorParameters(r=0.0)


def _fd_local_jacobian(arm, q, h=1e-6):
    """Central differences of the camera pose mapped through log6 in the camera frame at q."""
    T0_inv = pin.SE3(arm.camera_pose(q)).inverse()
    J = np.zeros((6, 6))
    for j in range(6):
        dq = np.zeros(6)
        dq[j] = h
        plus = pin.log6(T0_inv * pin.SE3(arm.camera_pose(q + dq))).vector
        minus = pin.log6(T0_inv * pin.SE3(arm.camera_pose(q - dq))).vector
        J[:, j] = (plus - minus) / (2 * h)
    return J


def test_camera_jacobian_matches_finite_differences(arm):
    rng = np.random.default_rng(SEED)
    for q in random_q(arm, rng, 20):
        J = arm.camera_jacobian(q)
        J_fd = _fd_local_jacobian(arm, q)
        assert np.linalg.norm(J - J_fd) <= 1e-6 * np.linalg.norm(J)  # O(h^2) truncation + roundoff/h


def test_camera_jacobian_rank_drops_at_the_wrist_singularity(arm):
    q = np.radians([10.0, 20.0, -30.0, 40.0, 0.0, 50.0])
    for q5 in (0.0, 1e-4, 1e-2):  # at and near the singularity
        q[4] = q5
        J = arm.camera_jacobian(q)
        assert np.linalg.norm(J - _fd_local_jacobian(arm, q)) <= 1e-6 * np.linalg.norm(J)
    q[4] = 0.0
    sigma = np.linalg.svd(arm.camera_jacobian(q), compute_uv=False)
    assert sigma[-1] < 1e-12 and sigma[-2] > 0.05  # rank 5: axes 4 and 6 aligned (ERRATA 7)
    assert np.linalg.svd(arm.camera_jacobian(np.zeros(6)), compute_uv=False)[-1] < 1e-12  # scenario 1 start
    q[4] = 0.3
    assert np.linalg.svd(arm.camera_jacobian(q), compute_uv=False)[-1] > 1e-2


@pytest.mark.parametrize("which", ["paper", "reflected"])
def test_dynamics_match_rnea_plus_armature_and_damping(arm, arm_reflected, which):
    arm = arm if which == "paper" else arm_reflected
    bare = pin.buildModelFromUrdf(str(urdf_path("abb_irb4600_45_205.urdf")))  # no armature
    data = bare.createData()
    rng = np.random.default_rng(SEED + 1)
    for q in random_q(arm, rng, 20):
        dq, ddq = rng.normal(size=6), rng.normal(size=6)
        M, h = arm.mass_matrix(q), arm.nonlinear_effects(q, dq)
        reference = pin.rnea(bare, data, q, dq, ddq) + arm.armature * ddq + arm.damping * dq
        np.testing.assert_allclose(M @ ddq + h, reference, rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(arm.inverse_dynamics(q, dq, ddq), reference, rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(M, M.T, rtol=0, atol=0)
        assert np.linalg.eigvalsh(M).min() > 0
        np.testing.assert_allclose(arm.gravity(q), pin.computeGeneralizedGravity(bare, data, q), atol=1e-9)
        ddq_back = arm.forward_dynamics(q, dq, arm.inverse_dynamics(q, dq, ddq))
        np.testing.assert_allclose(ddq_back, ddq, rtol=1e-9, atol=1e-9)


def test_energies_are_consistent_with_mass_matrix_and_gravity(arm):
    rng = np.random.default_rng(SEED + 2)
    q, dq = random_q(arm, rng, 1)[0], rng.normal(size=6)
    assert arm.kinetic_energy(q, dq) == pytest.approx(0.5 * dq @ arm.mass_matrix(q) @ dq, rel=1e-12)
    h = 1e-6
    grad = [(arm.potential_energy(q + h * e) - arm.potential_energy(q - h * e)) / (2 * h) for e in np.eye(6)]
    np.testing.assert_allclose(grad, arm.gravity(q), rtol=1e-6, atol=1e-5)  # g = dP/dq, central differences
    np.testing.assert_allclose(arm.nonlinear_effects(q, np.zeros(6)), arm.gravity(q), atol=1e-12)


def test_with_inertia_scale_scales_links_not_actuators(arm):
    heavy = arm.with_inertia_scale(1.5)
    q = random_q(arm, np.random.default_rng(SEED + 3), 1)[0]
    np.testing.assert_allclose(heavy.gravity(q), 1.5 * arm.gravity(q), rtol=1e-12, atol=1e-12)
    D, D_heavy = arm.mass_matrix(q) - np.diag(arm.armature), heavy.mass_matrix(q) - np.diag(heavy.armature)
    np.testing.assert_allclose(D_heavy, 1.5 * D, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(heavy.camera_pose(q), arm.camera_pose(q))
    assert heavy.ik_parameters == arm.ik_parameters and heavy is not arm
    assert sum(i.mass for i in arm.model.inertias) == pytest.approx(412.17)  # original untouched
    with pytest.raises(InvalidParameterError):
        arm.with_inertia_scale(0.0)


# ----------------------------------------------------------------------------------------- hand-eye belief
RZ_PI = np.diag([-1.0, -1.0, 1.0, 1.0])  # nominal T_E_C (ERRATA 2)


def _hand_eye(angle_deg, axis, t_mm, nominal=RZ_PI):
    """``nominal`` followed by a rotation of ``angle_deg`` about ``axis`` and a shift ``t_mm`` in {C}."""
    delta = np.eye(4)
    delta[:3, :3] = pin.exp3(np.radians(angle_deg) * np.asarray(axis, float) / np.linalg.norm(axis))
    delta[:3, 3] = np.asarray(t_mm, float) / 1000.0
    return nominal @ delta


T_E_C_BELIEF = _hand_eye(1.0, [1, 0, 0], [2, -1, 3])  # sqrt(14) = 3.74 mm, 1 deg


def test_with_hand_eye_moves_the_camera_frame_only(arm):
    placement = arm.model.frames[arm.model.getFrameId("camera")].placement.homogeneous.copy()
    belief = arm.with_hand_eye(T_E_C_BELIEF)
    np.testing.assert_allclose(belief.T_E_C, T_E_C_BELIEF, rtol=0, atol=1e-15)
    assert belief.name == "ABB IRB 4600-45/2.05 (paper actuator) (T_E_C moved 3.74 mm, 1 deg)"
    assert repr(belief) == f"Arm({belief.name!r}, nq=6, ik=spherical-wrist)"
    assert belief.ik_parameters == arm.ik_parameters
    for name in ("q_min", "q_max", "dq_max", "tau_max", "armature", "damping"):
        np.testing.assert_array_equal(getattr(belief, name), getattr(arm, name))
    rng = np.random.default_rng(SEED + 5)
    for q in random_q(arm, rng, 20):
        np.testing.assert_allclose(
            belief.camera_pose(q), belief.flange_pose(q) @ T_E_C_BELIEF, rtol=0, atol=1e-12
        )
        np.testing.assert_array_equal(belief.flange_pose(q), arm.flange_pose(q))
        np.testing.assert_array_equal(belief.mass_matrix(q), arm.mass_matrix(q))  # dynamics untouched
        np.testing.assert_allclose(arm.camera_pose(q), arm.flange_pose(q) @ RZ_PI, rtol=0, atol=1e-12)
    np.testing.assert_allclose(arm.T_E_C, RZ_PI, rtol=0, atol=1e-15)  # the original arm is unchanged
    np.testing.assert_array_equal(
        arm.model.frames[arm.model.getFrameId("camera")].placement.homogeneous, placement
    )
    assert arm.name == "ABB IRB 4600-45/2.05 (paper actuator)"


def test_with_hand_eye_ik_and_jacobian_follow_the_new_camera(arm):
    belief = arm.with_hand_eye(_hand_eye(3.0, [1, -2, 0.5], [10, 5, -20]))
    rng = np.random.default_rng(SEED + 6)
    for q in random_q(arm, rng, 20):
        T_O_C = belief.camera_pose(q)
        wrapped = np.angle(np.exp(1j * (belief.ik(T_O_C) - q)))  # without q_near: axes 4, 6 in (-pi, pi]
        assert np.abs(wrapped).max(axis=1).min() <= 1e-9
        assert np.abs(belief.ik(T_O_C, q_near=q)[0] - q).max() <= 1e-9
        assert np.abs(belief.ik_nearest(T_O_C, q) - q).max() <= 1e-9
        J = belief.camera_jacobian(q)
        assert np.linalg.norm(J - _fd_local_jacobian(belief, q)) <= 1e-6 * np.linalg.norm(J)
        assert np.linalg.norm(J - arm.camera_jacobian(q)) > 1e-3 * np.linalg.norm(J)  # it moved


def test_with_hand_eye_composes_with_with_inertia_scale(arm):
    T_E_C = _hand_eye(2.0, [0, 0, 1], [0, 0, 5])
    heavy_belief = arm.with_inertia_scale(1.5).with_hand_eye(T_E_C)
    belief_heavy = arm.with_hand_eye(T_E_C).with_inertia_scale(1.5)
    assert (
        heavy_belief.name == "ABB IRB 4600-45/2.05 (paper actuator) (inertia x1.5) (T_E_C moved 5 mm, 2 deg)"
    )
    q = random_q(arm, np.random.default_rng(SEED + 7), 1)[0]
    for composed in (heavy_belief, belief_heavy):
        np.testing.assert_allclose(composed.gravity(q), 1.5 * arm.gravity(q), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(composed.camera_pose(q), arm.flange_pose(q) @ T_E_C, rtol=0, atol=1e-12)
        assert composed.ik_parameters == arm.ik_parameters


def test_with_hand_eye_on_a_numerical_ik_arm():
    ur5 = Arm.from_urdf(example_robot_data_urdf("ur_description/urdf/ur5_robot.urdf"), camera_frame="tool0")
    T_E_C = _hand_eye(5.0, [0, 1, 1], [20, 0, 30], nominal=ur5.T_E_C)
    belief = ur5.with_hand_eye(T_E_C)
    assert belief.ik_parameters is None
    q = random_q(ur5, np.random.default_rng(SEED + 8), 1)[0]
    np.testing.assert_allclose(belief.camera_pose(q), ur5.flange_pose(q) @ T_E_C, rtol=0, atol=1e-12)
    solutions = belief.ik(belief.camera_pose(q), q_near=q)
    assert np.abs(solutions[0] - q).max() <= 1e-6  # damped Gauss-Newton from q_near, FK residual <= 1e-9


@pytest.mark.parametrize(
    ("T_E_C", "message"),
    [
        (np.diag([1.01, 1.0, 1.0, 1.0]), "rotation matrix"),  # scaled, not rigid
        (np.diag([1.0, 1.0, -1.0, 1.0]), "rotation matrix"),  # a reflection
        (np.eye(3), "shape"),
        (np.full((4, 4), np.nan), "finite"),
    ],
)
def test_with_hand_eye_rejects_non_rigid_transforms(arm, T_E_C, message):
    with pytest.raises(InvalidArrayError, match=message) as info:
        arm.with_hand_eye(T_E_C)
    assert "T_E_C" in str(info.value)


def test_within_limits(arm):
    assert arm.within_limits(np.zeros(6))
    assert not arm.within_limits(np.radians([0, 151, 0, 0, 0, 0]))
    assert arm.within_limits(np.radians([0, 150.01, 0, 0, 0, 0]), tol=np.radians(0.02))


@pytest.mark.parametrize(
    "bad", [np.full(6, np.nan), [0, 0, np.inf, 0, 0, 0], np.zeros(5), np.zeros((6, 1)), "q"]
)
def test_bad_joint_vectors_raise_invalid_array(arm, bad):
    for call in (
        lambda: arm.camera_pose(bad),
        lambda: arm.camera_jacobian(bad),
        lambda: arm.mass_matrix(bad),
        lambda: arm.nonlinear_effects(np.zeros(6), bad),
        lambda: arm.forward_dynamics(np.zeros(6), np.zeros(6), bad),
        lambda: arm.within_limits(bad),
    ):
        with pytest.raises(InvalidArrayError):
            call()


def test_lists_and_ints_are_accepted(arm):
    np.testing.assert_allclose(arm.camera_pose([0, 0, 0, 0, 0, 0])[:3, 3], [1.27, 0, 1.57], atol=1e-12)


def test_bad_urdf_files_raise_model_load_error(tmp_path):
    with pytest.raises(ModelLoadError, match="does not exist"):
        Arm.from_urdf(tmp_path / "missing.urdf")
    garbage = tmp_path / "garbage.urdf"
    garbage.write_text("this is not <xml")
    with pytest.raises(ModelLoadError, match="cannot parse"):
        Arm.from_urdf(garbage)
    with pytest.raises(ModelLoadError, match="frame 'eye'"):
        Arm.from_urdf(urdf_path("abb_irb4600_45_205.urdf"), camera_frame="eye")
    fewer = r"camera frame 'link_3': 3 joint\(s\) on the chain .* fewer than 6"
    with pytest.raises(ModelLoadError, match=fewer):
        Arm.from_urdf(urdf_path("abb_irb4600_45_205.urdf"), camera_frame="link_3")


def test_a_non_six_dof_urdf_is_rejected(tmp_path):
    two_link = tmp_path / "two_link.urdf"
    two_link.write_text(
        '<robot name="two"><link name="a"/><link name="b"/><link name="c"/>'
        '<joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" velocity="1" effort="1"/></joint>'
        '<joint name="j2" type="revolute"><parent link="b"/><child link="c"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>'
    )
    fewer = r"2 joint\(s\) on the chain from the base \(\['j1', 'j2'\]\), fewer than 6"
    with pytest.raises(ModelLoadError, match=fewer):
        Arm.from_urdf(two_link, camera_frame="c")


def test_callers_model_is_not_mutated():
    model = pin.buildModelFromUrdf(str(urdf_path("abb_irb4600_45_205.urdf")))
    arm = Arm(model, armature=np.ones(6), damping=np.ones(6))
    np.testing.assert_allclose(model.armature, 0.0)
    np.testing.assert_allclose(arm.model.armature, 1.0)
    # closed form detected on the bare model too, with ERRATA 1's geometry (a3 carries ~4e-17 m round-off)
    assert astuple(arm.ik_parameters) == pytest.approx(astuple(SphericalWristParameters.irb4600()), abs=1e-12)
    with pytest.raises(InvalidArrayError):
        Arm(model, armature=-np.ones(6))


def test_ur5_loads_from_example_robot_data():
    ur5 = Arm.from_urdf(example_robot_data_urdf("ur_description/urdf/ur5_robot.urdf"), camera_frame="tool0")
    assert ur5.nq == 6 and ur5.ik_parameters is None  # not IRB 4600-like: numerical IK
    assert ur5.flange_frame == "wrist_3_joint"
    q = random_q(ur5, np.random.default_rng(SEED + 4), 1)[0]
    J = ur5.camera_jacobian(q)
    assert np.linalg.norm(J - _fd_local_jacobian(ur5, q)) <= 1e-6 * np.linalg.norm(J)
    np.testing.assert_allclose(ur5.camera_pose(q), ur5.flange_pose(q) @ ur5.T_E_C, atol=1e-12)


# ----------------------------------------------------------------------------------------- URDF checks
def six_joint_urdf(tmp_path, *, joint3="revolute", lower="-1", upper="1", velocity="1", effort="1"):
    """A six-joint serial chain (link_0 .. link_6) of 1 kg links; joint 3 takes the type and limits given."""
    inertia = '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>'
    inertial = f'<inertial><mass value="1"/>{inertia}</inertial>'
    links = "".join(f'<link name="link_{i}">{inertial}</link>' for i in range(7))
    joints = []
    for i in range(1, 7):
        kind, limit = "revolute", '<limit lower="-1" upper="1" velocity="1" effort="1"/>'
        if i == 3:
            kind = joint3
            limit = f'<limit lower="{lower}" upper="{upper}" velocity="{velocity}" effort="{effort}"/>'
        joints.append(
            f'<joint name="j{i}" type="{kind}"><parent link="link_{i - 1}"/>'
            f'<child link="link_{i}"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>{limit}</joint>'
        )
    path = tmp_path / "six.urdf"
    path.write_text(f'<robot name="six">{links}{"".join(joints)}</robot>')
    return path


def test_six_joint_urdf_helper_loads_when_valid(tmp_path):
    arm = Arm.from_urdf(six_joint_urdf(tmp_path), camera_frame="link_6")
    assert arm.nq == 6 and arm.q_min.tolist() == [-1.0] * 6  # the error cases below differ in one tag only


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"joint3": "planar"}, r"joint 'j3' \(JointModelPlanar\) on the chain .* is a planar joint"),
        (
            {"lower": "1", "upper": "-1"},
            r"joint 'j3' <limit>: received lower=1, upper=-1; valid: finite .*lower < upper",
        ),
        ({"lower": "0.5", "upper": "0.5"}, r"joint 'j3' <limit>: received lower=0\.5, upper=0\.5"),
        ({"velocity": "0"}, r"joint 'j3' <limit velocity>: received '0'; valid: a finite number > 0"),
        ({"effort": "0"}, r"joint 'j3' <limit effort>: received '0'; valid: a finite number > 0"),
    ],
)
def test_a_joint_that_is_not_revolute_or_prismatic_or_lacks_limits_is_rejected(tmp_path, changes, message):
    path = six_joint_urdf(tmp_path, **changes)
    with pytest.raises(ModelLoadError, match=message) as info:
        Arm.from_urdf(path, camera_frame="link_6")
    assert info.value.path == path


def test_non_finite_limits_are_rejected(tmp_path):
    """A URDF cannot spell an infinite limit that Pinocchio parses, so the model is edited directly."""
    model = pin.buildModelFromUrdf(str(six_joint_urdf(tmp_path)))
    model.upperPositionLimit[2] = np.inf
    with pytest.raises(ModelLoadError, match=r"model: joint 'j3' position limits: received .*upper=\[inf\]"):
        Arm(model, camera_frame="link_6")


def test_missing_resources_are_named(tmp_path):
    shipped = r"'nope\.urdf' is not among the URDFs shipped in ibvs_youla\.urdf"
    with pytest.raises(ModelLoadError, match=shipped):
        urdf_path("nope.urdf")
    missing = r"example-robot-data URDF 'nope/none\.urdf' not found; looked in \['/"
    with pytest.raises(ModelLoadError, match=missing):
        example_robot_data_urdf("nope/none.urdf")


def test_irb4600_checks_its_urdf_against_errata_1(tmp_path, monkeypatch):
    """A shipped URDF whose wrist offset d4 is not ERRATA 1's 0.960 m is refused, not silently used."""
    import ibvs_youla.model.robots as robots_module

    text = urdf_path("abb_irb4600_45_205.urdf").read_text()
    assert text.count('<origin xyz="0 0 0.96" ') == 1
    edited = tmp_path / "abb_irb4600_45_205.urdf"
    edited.write_text(text.replace('<origin xyz="0 0 0.96" ', '<origin xyz="0 0 0.97" '))
    monkeypatch.setattr(robots_module, "urdf_path", lambda name: edited)
    message = r"URDF geometry .*d4=0\.97.* differs from ERRATA 1 .*d4=0\.96"
    with pytest.raises(ModelLoadError, match=message) as info:
        Arm.irb4600()
    assert info.value.path == edited
