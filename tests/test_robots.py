"""Any fixed-base arm: robots by name, the chain to the camera, locked joints, mounts, identities, bad input.

The FK and camera Jacobian of every named robot are checked against Pinocchio's own frame
placement on the *unreduced* model of the URDF (fingers at their locked values, continuous joints
as (cos q, sin q)) and against finite differences.
"""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

from ibvs_youla import robots
from ibvs_youla.exceptions import InvalidParameterError, ModelLoadError
from ibvs_youla.model.arm import Arm
from ibvs_youla.model.chain import joint_coordinate_model
from ibvs_youla.model.dynamics_kernels import ChainDynamics

SEED = 20240619


@pytest.fixture(scope="module")
def arms():
    return {name: Arm.from_robot(name) for name in robots.names()}


def _full_configuration(arm, full, q):
    """The unreduced model's configuration for the arm's joint vector q (locked joints at their values)."""
    q_full = pin.neutral(full)
    for j in range(1, full.njoints):
        name, i = full.names[j], full.idx_qs[j]
        value = q[arm.joint_names.index(name)] if name in arm.joint_names else arm.locked_joints[name]
        if full.nqs[j] == 2:  # a continuous joint
            q_full[i : i + 2] = np.cos(value), np.sin(value)
        else:
            q_full[i] = value
    return q_full


def _random_q(arm, rng):
    lo, hi = np.maximum(arm.q_min, -np.pi), np.minimum(arm.q_max, np.pi)
    return lo + (hi - lo) * rng.random(arm.nq)


def test_the_registry_lists_the_named_robots():
    assert robots.names() == ("irb4600", "ur3", "ur5", "ur10", "panda", "xarm7", "z1", "kinova")
    with pytest.raises(InvalidParameterError, match=r"'ur5e'.*'irb4600'"):
        robots.get("ur5e")


def test_every_named_robot_loads_with_its_documented_chain(arms):
    expected = {  # n joints, continuous joints, locked joints, IK method
        "irb4600": (6, 0, {}, "spherical-wrist"),
        "ur3": (6, 0, {}, "ur"),
        "ur5": (6, 0, {}, "ur"),
        "ur10": (6, 0, {}, "ur"),
        "panda": (7, 0, {"panda_finger_joint1": 0.0, "panda_finger_joint2": 0.0}, "numerical"),
        "xarm7": (7, 0, {}, "numerical"),
        "z1": (6, 0, {"jointGripper": 0.0}, "numerical"),
        "kinova": (6, 3, {}, "numerical"),
    }
    for name, arm in arms.items():
        n, continuous, locked, method = expected[name]
        assert (arm.nq, arm.joint_kinds.count("continuous"), arm.locked_joints, arm.ik_method) == (
            n,
            continuous,
            locked,
            method,
        ), name
        assert arm.robot == name and arm.model.nq == arm.model.nv == n
        assert arm.within_limits(robots.get(name).q_home), name
        sigma = np.linalg.svd(arm.camera_jacobian(robots.get(name).q_home), compute_uv=False).min()
        assert sigma >= 0.12, (name, sigma)  # the home configurations are away from singularities
    kinova = arms["kinova"]
    continuous = [k for k, kind in enumerate(kinova.joint_kinds) if kind == "continuous"]
    assert continuous == [0, 3, 5] and np.isinf(kinova.q_min[continuous]).all()
    assert arms["irb4600"].name == Arm.irb4600().name == "ABB IRB 4600-45/2.05 (paper actuator)"


def test_limits_and_damping_come_from_the_urdf(arms):
    panda = arms["panda"]
    np.testing.assert_allclose(panda.dq_max, [2.175] * 4 + [2.61] * 3)
    np.testing.assert_allclose(panda.tau_max, [87.0] * 4 + [12.0] * 3)
    np.testing.assert_allclose(panda.damping, 0.003)  # <dynamics damping="0.003"/>
    np.testing.assert_allclose(panda.armature, 0.0)
    np.testing.assert_allclose(arms["ur5"].damping, 0.0)  # no <dynamics>
    np.testing.assert_allclose(arms["xarm7"].damping, [10, 10, 5, 5, 5, 2, 2])
    assert panda.model.damping.max() == 0.0  # applied by the arm, not by Pinocchio


def test_fk_and_camera_jacobian_agree_with_pinocchio_on_the_unreduced_model(arms):
    rng = np.random.default_rng(SEED)
    for name, arm in arms.items():
        full = pin.buildModelFromUrdf(str(arm.urdf_path))
        data = full.createData()
        mount = [i for i, f in enumerate(full.frames) if f.name == arm.camera_frame]
        mount = [i for i in mount if full.frames[i].type == pin.FrameType.BODY] or mount
        for q in (_random_q(arm, rng) for _ in range(3)):
            pin.framesForwardKinematics(full, data, _full_configuration(arm, full, q))
            T_O_C = data.oMf[mount[0]].homogeneous @ arm.T_F_C
            np.testing.assert_allclose(arm.camera_pose(q), T_O_C, rtol=0, atol=1e-12, err_msg=name)
            J = arm.camera_jacobian(q)
            fd = np.empty_like(J)
            h = 1e-6
            for k in range(arm.nq):
                dq = np.zeros(arm.nq)
                dq[k] = h
                T_plus, T_minus = arm.camera_pose(q + dq), arm.camera_pose(q - dq)
                fd[:, k] = pin.log6(np.linalg.solve(T_minus, T_plus)).vector / (2 * h)  # LOCAL twist
            assert np.abs(J - fd).max() <= 1e-7 * max(1.0, np.abs(J).max()), name


def test_a_continuous_joint_in_joint_coordinates_has_the_urdf_models_kinematics_and_dynamics(arms):
    """The Kinova's joints 1, 4, 6 are continuous (nq = 2 in Pinocchio): the rebuilt revolute model
    gives the same placements and pin.aba as the URDF model at (cos q, sin q), to 1e-12."""
    kinova = arms["kinova"]
    full = pin.buildModelFromUrdf(str(kinova.urdf_path))
    rebuilt = joint_coordinate_model(full)
    assert (full.nq, full.nv, rebuilt.nq, rebuilt.nv) == (9, 6, 6, 6)
    d_full, d_rebuilt = full.createData(), rebuilt.createData()
    rng = np.random.default_rng(SEED + 1)
    for _ in range(3):
        q, dq, tau = rng.uniform(-3, 3, 6), rng.normal(size=6), rng.normal(size=6)
        q_full = _full_configuration(kinova, full, q)
        pin.framesForwardKinematics(full, d_full, q_full)
        pin.framesForwardKinematics(rebuilt, d_rebuilt, q)
        for a, b in zip(d_full.oMf, d_rebuilt.oMf, strict=True):
            np.testing.assert_allclose(a.homogeneous, b.homogeneous, rtol=0, atol=1e-12)
        np.testing.assert_allclose(
            pin.aba(full, d_full, q_full, dq, tau),
            pin.aba(rebuilt, d_rebuilt, q, dq, tau),
            rtol=0,
            atol=1e-12,
        )
    assert ChainDynamics.from_model(kinova.model) is not None  # so the compiled ABA/RNEA take it


def test_identity_is_plain_data_that_tells_arms_apart(arms):
    identities = {name: arm.identity() for name, arm in arms.items()}
    texts = {name: json.dumps(i.to_dict(), sort_keys=True, allow_nan=False) for name, i in identities.items()}
    assert len(set(texts.values())) == len(texts)
    assert identities["irb4600"] == Arm.irb4600().identity()  # same arm, same identity
    assert identities["irb4600"] != Arm.irb4600("reflected").identity()
    ur5 = identities["ur5"].to_dict()
    assert ur5["robot"] == "ur5" and len(ur5["urdf_sha256"]) == 64 and ur5["camera_frame"] == "tool0"
    moved = arms["ur5"].with_hand_eye(
        arms["ur5"].T_E_C @ pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.01])).homogeneous
    )
    assert moved.identity() != identities["ur5"] and moved.identity().robot == "ur5"
    assert arms["ur5"].with_inertia_scale(2.0).identity().inertia_scale == 2.0


def test_a_camera_on_any_frame_with_a_fixed_mount(arms):
    T_F_C = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([0.02, -0.03, 0.05])).homogeneous
    arm = Arm.from_robot("panda", camera_frame="panda_hand", T_F_C=T_F_C)
    assert arm.camera_frame == "panda_hand" and arm.flange_frame == "panda_joint7"  # the last joint's frame
    np.testing.assert_allclose(arm.T_F_C, T_F_C, rtol=0, atol=1e-15)
    q = np.array(robots.get("panda").q_home)
    data = arm.model.createData()
    pin.framesForwardKinematics(arm.model, data, q)
    hand = data.oMf[arm.model.getFrameId("panda_hand", pin.FrameType.BODY)].homogeneous
    np.testing.assert_allclose(arm.camera_pose(q), hand @ T_F_C, rtol=0, atol=1e-12)
    assert arm.identity() != arms["panda"].identity()


def test_locking_a_chain_joint_makes_a_six_joint_arm_and_a_mimic_joint_follows_its_leader():
    six = Arm.from_robot("panda", locked_joints={"panda_joint7": 0.5, "panda_finger_joint1": 0.03})
    assert six.nq == 6 and six.joint_names[-1] == "panda_joint6"
    assert six.locked_joints == {
        "panda_joint7": 0.5,
        "panda_finger_joint1": 0.03,
        "panda_finger_joint2": 0.03,
    }
    full = Arm.from_robot("panda")
    q6 = np.array(robots.get("panda").q_home)[:6]
    np.testing.assert_allclose(six.camera_pose(q6), full.camera_pose(np.append(q6, 0.5)), rtol=0, atol=1e-12)


# ------------------------------------------------------------------------------------------- bad input
def _chain_urdf(tmp_path, joints, extra=""):
    """A URDF of len(joints) + 1 links in series; each joint given as (type, extra XML inside <joint>)."""
    inertia = '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>'
    inertial = f'<inertial><mass value="1"/>{inertia}</inertial>'
    links = "".join(f'<link name="link_{i}">{inertial}</link>' for i in range(len(joints) + 1))
    limit = '<limit lower="-1" upper="1" velocity="1" effort="1"/>'
    body = "".join(
        f'<joint name="j{i}" type="{kind}"><parent link="link_{i - 1}"/><child link="link_{i}"/>'
        f'<origin xyz="0.05 0.02 0.1"/><axis xyz="{("1 0 0", "0 1 0", "0 0 1")[i % 3]}"/>'
        f"{limit if kind in ('revolute', 'prismatic') else ''}{more}</joint>"
        for i, (kind, more) in enumerate(joints, start=1)
    )
    path = tmp_path / "arm.urdf"
    path.write_text(f'<robot name="arm">{links}{body}{extra}</robot>')
    return path


def test_a_floating_base_is_refused_naming_the_joint(tmp_path):
    path = _chain_urdf(tmp_path, [("floating", "")] + [("revolute", "")] * 6)
    with pytest.raises(
        ModelLoadError, match=r"joint 'j1' \(JointModelFreeFlyer\) .* floating joint .*fixed base"
    ) as e:
        Arm.from_urdf(path, camera_frame="link_7")
    assert e.value.element == "joint 'j1'"


def test_a_camera_frame_not_on_a_chain_of_six_lists_the_candidate_frames(tmp_path):
    path = _chain_urdf(tmp_path, [("revolute", "")] * 7)
    with pytest.raises(
        ModelLoadError, match=r"camera frame 'eye' is not in the model.*candidates.*'link_6', 'j7'"
    ) as e:
        Arm.from_urdf(path, camera_frame="eye")
    assert e.value.element == "frame 'eye'"
    with pytest.raises(
        ModelLoadError, match=r"camera frame 'link_4': 4 joint\(s\).*fewer than 6.*candidates"
    ):
        Arm.from_urdf(path, camera_frame="link_4")


def test_an_unknown_locked_joint_is_refused_listing_the_joints(tmp_path):
    path = _chain_urdf(tmp_path, [("revolute", "")] * 7)
    with pytest.raises(
        ModelLoadError, match=r"locked joint 'j9' is not a joint of the model; joints: \['j1'"
    ) as e:
        Arm.from_urdf(path, camera_frame="link_7", locked_joints={"j9": 0.0})
    assert e.value.element == "joint 'j9'"
    with pytest.raises(ModelLoadError, match=r"locked joint 'j7': value nan is not finite"):
        Arm.from_urdf(path, camera_frame="link_7", locked_joints={"j7": float("nan")})


def test_a_mimic_joint_on_the_chain_is_refused(tmp_path):
    path = _chain_urdf(
        tmp_path, [("revolute", "")] * 2 + [("revolute", '<mimic joint="j2"/>')] + [("revolute", "")] * 4
    )
    with pytest.raises(ModelLoadError, match=r"joint 'j3' mimics joint 'j2' \(URDF <mimic>\)") as e:
        Arm.from_urdf(path, camera_frame="link_7")
    assert e.value.element == "joint 'j3'"
    arm = Arm.from_urdf(path, camera_frame="link_7", locked_joints={"j3": 0.2})  # locked, it may stay
    assert arm.nq == 6 and arm.locked_joints == {"j3": 0.2}


def test_fewer_than_six_joints_on_the_chain_are_refused(tmp_path):
    path = _chain_urdf(tmp_path, [("revolute", "")] * 5)
    with pytest.raises(ModelLoadError, match=r"5 joint\(s\) on the chain from the base .* fewer than 6") as e:
        Arm.from_urdf(path, camera_frame="link_5")
    assert e.value.element == "frame 'link_5'"


def test_a_prismatic_joint_on_the_chain_is_an_arm_joint_in_metres(tmp_path):
    path = _chain_urdf(tmp_path, [("revolute", ""), ("prismatic", "")] + [("revolute", "")] * 4)
    arm = Arm.from_urdf(path, camera_frame="link_6")
    assert arm.joint_kinds[1] == "prismatic" and arm.periodic.tolist() == [1, 0, 1, 1, 1, 1]
    assert ChainDynamics.from_model(arm.model) is None  # Pinocchio's ABA and RNEA run it
    q = np.array([0.3, 0.5, 0.2, -0.4, 0.6, 0.1])
    solutions = arm.ik(arm.camera_pose(q), q_near=q + 0.01)
    np.testing.assert_allclose(solutions[0], q, atol=1e-8)  # the nearest; the position is not wrapped
    assert np.all(solutions[:, 1] >= -1.0) and np.all(solutions[:, 1] <= 1.0)


def test_from_robot_refuses_unknown_keywords():
    with pytest.raises(InvalidParameterError, match=r"\['camera'\].*keywords among camera_frame"):
        Arm.from_robot("ur5", camera="tool0")
    with pytest.raises(InvalidParameterError, match="actuator"):
        Arm.from_robot("ur5", actuator="paper")  # the IRB 4600's actuator model only


def test_an_arm_is_rebuilt_from_its_identity(arms, tmp_path):
    """What a campaign's Dask worker does with a spec's arm: the same identity, hence the same arm."""
    T_F_C = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, 0.5), np.array([0.0, 0.0, 0.04])).homogeneous
    built = [
        arms["kinova"],
        Arm.irb4600("reflected"),
        Arm.from_robot("panda", camera_frame="panda_hand", T_F_C=T_F_C, locked_joints={"panda_joint7": 0.3}),
        arms["ur5"].with_hand_eye(arms["ur5"].T_E_C @ T_F_C).with_inertia_scale(1.5),
    ]
    for arm in built:
        data = json.loads(json.dumps(arm.identity().to_dict()))  # through JSON, as a spec holds it
        again = Arm.from_identity(data)
        assert again.identity() == arm.identity(), arm.name
        q = np.array(robots.get(arm.robot).q_home)[: arm.nq]
        np.testing.assert_allclose(again.camera_pose(q), arm.camera_pose(q), rtol=0, atol=1e-15)
        np.testing.assert_allclose(again.mass_matrix(q), arm.mass_matrix(q), rtol=1e-15, atol=0)
    ur5 = arms["ur5"].identity().to_dict()
    with pytest.raises(InvalidParameterError, match="urdf"):
        Arm.from_identity({**ur5, "robot": None})
    other = tmp_path / "other.urdf"
    other.write_text(robots.urdf("ur5").read_text().replace("ur5", "ur5-copy"))
    with pytest.raises(ModelLoadError, match="is not the one of the identity"):
        Arm.from_identity({**ur5, "robot": None}, urdf=other)


def test_a_continuous_joint_without_speed_and_torque_limits_needs_them_from_the_caller(tmp_path):
    """A URDF's continuous joint may omit <limit>: no position limit (-inf, +inf), and its speed and
    torque limits are the caller's (dq_max, tau_max), else the arm is refused naming the joint."""
    path = _chain_urdf(tmp_path, [("revolute", "")] * 2 + [("continuous", "")] + [("revolute", "")] * 3)
    with pytest.raises(ModelLoadError, match=r"joint 'j3' velocity limit: received \[inf\].*dq_max=") as e:
        Arm.from_urdf(path, camera_frame="link_6")
    assert e.value.element == "joint 'j3' velocity limit"
    arm = Arm.from_urdf(path, camera_frame="link_6", dq_max=np.full(6, 2.0), tau_max=np.full(6, 50.0))
    assert arm.joint_kinds[2] == "continuous" and np.isinf(arm.q_min[2]) and np.isinf(arm.q_max[2])
    np.testing.assert_allclose(arm.dq_max, 2.0)
