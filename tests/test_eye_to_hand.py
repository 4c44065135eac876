"""Eye-to-hand, the model: the mount as data, the arm seen from the markers' carrier, scenarios, bad input.

A camera fixed at T_O_C watching markers fixed in a frame E of the arm is an eye-in-hand camera at
T_E_C(q) = T_O_E(q)^-1 T_O_C seen from E (docs/eye-to-hand.md). Pinned here: that pose, its
Jacobian J_rel = -Ad(T_C_E) J_E (ViSP's -cVe eJe) against finite differences and against
Pinocchio's own frame Jacobian of the carrier, the inverse kinematics of the carrier (Eq. (62)
applied to the tool), the eye-to-hand hand-eye calibration (AX = XB with X = T_O_C), the seeded
scenario makers, and one typed error for each kind of bad input.
"""

from __future__ import annotations

import pickle

import numpy as np
import pinocchio as pin
import pytest

import ibvs_youla as iy
from ibvs_youla.estimation.hand_eye import calibrate_hand_eye, simulate_hand_eye_run
from ibvs_youla.exceptions import InvalidArrayError, InvalidParameterError, UnreachablePoseError
from ibvs_youla.model.camera import default_camera
from ibvs_youla.model.eye_to_hand import EyeToHandArm, mounted
from ibvs_youla.model.mount import Mount
from ibvs_youla.simulation.sensor import MarkerSensor

ROBOTS = (
    "irb4600",
    "ur5",
    "panda",
    "kinova",
    "z1",
)  # closed forms (spherical wrist, UR), 7 joints, numerical


def _tool_view(arm, q, distance=0.8):
    """T_O_C of a camera ``distance`` m in front of the flange at q, facing it (a rigid transform)."""
    return iy.scenarios.fixed_camera_pose(arm.flange_pose(q), distance)


@pytest.fixture(scope="module")
def arms():
    return {name: iy.Arm.from_robot(name) for name in ROBOTS}


@pytest.fixture(scope="module")
def views(arms):
    """Each robot near home, eye-to-hand with the camera 0.8 m in front of its flange there."""
    out = {}
    for name, arm in arms.items():
        q = np.array(iy.robots.get(name).q_home) + 0.05
        out[name] = (EyeToHandArm(arm, Mount.eye_to_hand(_tool_view(arm, q))), q)
    return out


# ---------------------------------------------------------------------------------------------- the mount
def test_a_mount_is_plain_data_that_round_trips():
    T = _tool_view(iy.Arm.irb4600(), np.zeros(6))
    mount = Mount.eye_to_hand(T, "flange")
    assert mount.is_eye_to_hand and not Mount.eye_in_hand().is_eye_to_hand
    assert Mount.from_dict(mount.to_dict()) == mount
    assert Mount.from_dict("eye-in-hand") == Mount() == Mount.from_dict({"kind": "eye-in-hand"})
    assert mount.to_dict()["carrier_frame"] == "flange" and Mount().to_dict() == {"kind": "eye-in-hand"}
    np.testing.assert_array_equal(mount.camera_pose, T)
    assert hash(mount) == hash(Mount.from_dict(mount.to_dict()))  # frozen, hashable: specs and keys hold it


@pytest.mark.parametrize(
    ("data", "error", "match"),
    [
        ({"kind": "eye-on-hand"}, InvalidParameterError, "mount.kind.*'eye-in-hand' or 'eye-to-hand'"),
        ({"kind": "eye-to-hand"}, InvalidParameterError, "mount.T_O_C.*pose in the base frame"),
        ({"kind": "eye-in-hand", "T_O_C": np.eye(4)}, InvalidParameterError, "None for an eye-in-hand"),
        (
            {"kind": "eye-to-hand", "T_O_C": np.diag([2.0, 1, 1, 1])},
            InvalidArrayError,
            "mount.T_O_C.*rotation",
        ),
        ({"kind": "eye-to-hand", "camera": np.eye(4)}, InvalidParameterError, r"\['camera'\].*T_O_C"),
        ({"kind": "eye-to-hand", "T_O_C": np.eye(4), "carrier_frame": ""}, InvalidParameterError, "carrier"),
        (3, InvalidParameterError, "a Mount, a kind"),
    ],
)
def test_a_bad_mount_names_what_was_received(data, error, match):
    with pytest.raises(error, match=match):
        Mount.from_dict(data)


# ----------------------------------------------------------------------------------- the arm from the carrier
@pytest.mark.parametrize("name", ROBOTS)
def test_the_camera_pose_is_the_fixed_camera_seen_from_the_flange(views, name):
    view, q = views[name]
    T_O_E = view.flange_pose(q)
    np.testing.assert_allclose(view.camera_pose(q), np.linalg.inv(T_O_E) @ view.T_O_C, rtol=0, atol=1e-12)
    T, J = view.camera_pose_and_jacobian(q)
    np.testing.assert_array_equal(T, view.camera_fk(q))  # the kernels agree bit for bit
    np.testing.assert_array_equal(J, view.camera_jacobian_at(q))
    assert (
        view.mount.is_eye_to_hand and view.hand_eye is view.T_O_C and view.carrier_frame == view.flange_frame
    )


@pytest.mark.parametrize("name", ROBOTS)
def test_the_relative_jacobian_is_minus_the_twist_of_the_flange_seen_in_the_camera(views, name):
    """J_rel = -Ad(T_C_E) J_E, J_E Pinocchio's LOCAL Jacobian of the flange: ViSP's -cVe eJe."""
    view, q = views[name]
    model, data = view.arm.model, view.arm.model.createData()
    flange = view.arm.model.getFrameId(view.flange_frame)
    J_E = pin.computeFrameJacobian(model, data, q, flange, pin.LOCAL)
    cVe = pin.SE3(np.linalg.inv(view.camera_pose(q))).action  # Ad(T_C_E), [v; w] order
    np.testing.assert_allclose(view.camera_jacobian(q), -cVe @ J_E, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", ROBOTS)
def test_the_relative_jacobian_equals_finite_differences_of_the_camera_pose(views, name):
    """d/dq_j of T_E_C(q): log(T_E_C(q - h e_j)^-1 T_E_C(q + h e_j)) / 2h, the twist in {C}."""
    view, q = views[name]
    h = 1e-6  # [rad]: central differences, error O(h^2) ~ 1e-12 plus rounding 1e-16 / h ~ 1e-10
    J_fd = np.column_stack(
        [
            pin.log6(np.linalg.inv(view.camera_pose(q - h * e)) @ view.camera_pose(q + h * e)).vector
            / (2 * h)
            for e in np.eye(view.nq)
        ]
    )
    np.testing.assert_allclose(view.camera_jacobian(q), J_fd, rtol=0, atol=1e-8)  # measured <= 2e-10


@pytest.mark.parametrize("name", ROBOTS)
def test_the_inverse_kinematics_is_the_carriers(views, name):
    """Eq. (62) on the tool: the joints that put the camera at T_E_C put the flange at T_O_C T_E_C^-1."""
    view, q = views[name]
    T_E_C = view.camera_pose(q)
    near = view.ik_nearest(T_E_C, q + 0.01)
    np.testing.assert_allclose(view.camera_pose(near), T_E_C, rtol=0, atol=1e-9)
    if not view.redundant:  # six joints: the arm's own configuration, the branch nearest the prior
        np.testing.assert_allclose(near, q, rtol=0, atol=1e-9)
    rows = view.ik(T_E_C, q + 0.01)
    assert all(np.abs(view.camera_pose(r) - T_E_C).max() <= 1e-9 for r in rows)
    q_k, T_k, J_k = view.ik_nearest_kinematics(T_E_C, q + 0.01)
    np.testing.assert_array_equal(q_k, near)
    T_ref, J_ref = view.camera_pose_and_jacobian(q_k)
    np.testing.assert_array_equal(T_k, T_ref)  # the same kinematics as camera_pose_and_jacobian
    np.testing.assert_array_equal(J_k, J_ref)


def test_an_unreachable_tool_pose_is_an_unreachable_pose_error(views):
    view, q = views["irb4600"]
    far = view.camera_pose(q)
    far[:3, 3] += (0.0, 0.0, 5.0)  # the camera 5 m further: the tool would have to leave the workspace
    with pytest.raises(UnreachablePoseError, match="eye-to-hand, the carrier 'flange'"):
        view.ik(far)


def test_derived_arms_keep_the_mount_and_pickle(views):
    view, q = views["ur5"]
    heavy = view.with_inertia_scale(2.0)
    assert isinstance(heavy, EyeToHandArm) and heavy.mount == view.mount
    np.testing.assert_array_equal(heavy.camera_pose(q), view.camera_pose(q))
    assert heavy.mass_matrix(q)[0, 0] == pytest.approx(2.0 * view.mass_matrix(q)[0, 0], rel=1e-12)
    moved = view.with_camera_pose(_tool_view(view.arm, q, 0.9))
    assert moved.mount.T_O_C != view.mount.T_O_C
    np.testing.assert_allclose(
        moved.camera_pose(q)[:3, 3], view.camera_pose(q)[:3, 3] * 0.9 / 0.8, atol=1e-12
    )
    copy = pickle.loads(pickle.dumps(view))
    np.testing.assert_array_equal(copy.camera_jacobian(q), view.camera_jacobian(q))
    assert copy.identity() == view.arm.identity()  # the arm's identity; the mount is the scenario's
    with pytest.raises(InvalidParameterError, match=r"with_camera_pose\(T_O_C\) on an eye-to-hand arm"):
        view.with_hand_eye(np.eye(4))


def test_mounted_is_the_arm_itself_eye_in_hand(arms, views):
    arm = arms["irb4600"]
    view = views["irb4600"][0]
    assert mounted(arm, None) is arm and mounted(arm, Mount()) is arm
    assert mounted(view, view.mount) is view
    assert mounted(arm, view.mount).mount == view.mount
    with pytest.raises(InvalidParameterError, match="an arm without a mount, or with the scenario's"):
        mounted(view, Mount.eye_to_hand(np.eye(4)))
    with pytest.raises(InvalidParameterError, match="this one has a mount already"):
        EyeToHandArm(view, view.mount)
    with pytest.raises(InvalidParameterError, match="an eye-to-hand mount"):
        EyeToHandArm(arm, Mount())


def test_a_carrier_frame_off_the_last_link_is_refused_naming_the_valid_ones(arms):
    arm = arms["irb4600"]
    mount = Mount.eye_to_hand(_tool_view(arm, np.zeros(6)), carrier_frame="link_3")
    with pytest.raises(InvalidParameterError, match=r"mount.carrier_frame: received 'link_3'.*'flange'"):
        EyeToHandArm(arm, mount)
    camera_carrier = EyeToHandArm(arm, Mount.eye_to_hand(mount.camera_pose, "camera"))  # another frame of it
    T_E_C = EyeToHandArm(arm, Mount.eye_to_hand(mount.camera_pose)).camera_pose(np.zeros(6))
    T_H_E = arm.frame_in_camera("flange")
    np.testing.assert_allclose(camera_carrier.camera_pose(np.zeros(6)), T_H_E @ T_E_C, atol=1e-12)


# ------------------------------------------------------------------------------------------ calibration
def test_the_eye_to_hand_calibration_recovers_the_camera_pose(views):
    """AX = XB with A_i = T_O_Ei T_O_Ei+1^-1 and the markers seen by the fixed camera: X = T_O_C."""
    view, q = views["irb4600"]
    markers_E = iy.scenarios.place_markers(
        view.camera_pose(q), iy.scenarios.EYE_TO_HAND_RAYS_XY, (0.6, 0.7, 0.75)
    )
    A, B = simulate_hand_eye_run(
        view, iy.StereoCamera.zed2(), markers_E, q, 12, np.random.default_rng(3), spread=0.1
    )
    X = calibrate_hand_eye(A, B)
    np.testing.assert_allclose(X, view.T_O_C, rtol=0, atol=1e-9)  # noiseless: rounding only


# -------------------------------------------------------------------------------------------- scenarios
def test_the_scenario_makers_give_every_robot_a_tool_in_view(arms):
    camera = default_camera()
    every = {name: arms[name] if name in arms else iy.Arm.from_robot(name) for name in iy.robots.names()}
    for name, arm in every.items():
        eih, eth = iy.scenarios.mount_pair(arm, seed=2)
        np.testing.assert_array_equal(eih.q_start, eth.q_start)  # one draw, both mountings
        np.testing.assert_array_equal(eih.q_target, eth.q_target)
        view = mounted(arm, eth.mount)
        P_C = MarkerSensor(camera, eth.markers_E).points_in_camera(view.camera_pose(eth.q_target))
        P_C_in_hand = MarkerSensor(camera, eih.markers_O).points_in_camera(arm.camera_pose(eih.q_target))
        np.testing.assert_allclose(
            P_C, P_C_in_hand, atol=2e-6
        )  # the same target image (markers kept to 1 um)
        for q in (eth.q_true_start, eth.q_target):
            assert camera.visibility(
                MarkerSensor(camera, eth.markers_E).points_in_camera(view.camera_pose(q))
            ).all_visible
        assert eth.mount.camera_pose[2, 3] > 0.0, name  # a camera above the floor, facing the arm
        assert iy.scenarios.eye_to_hand(arm, seed=2) == iy.scenarios.eye_to_hand(arm, seed=2)  # seeded


def test_an_eye_to_hand_scenario_holds_its_mount_as_data():
    arm = iy.Arm.irb4600()
    scenario = iy.scenarios.eye_to_hand(arm, seed=0)
    data = scenario.to_dict()
    assert data["mount"] == scenario.mount.to_dict() and "markers_O" not in data and "markers_E" in data
    assert "mount" not in iy.scenarios.physical(1).to_dict()  # eye-in-hand scenarios' data unchanged
    assert iy.Scenario(**{**iy.scenarios.physical(1).__dict__, "mount": Mount()}) == iy.scenarios.physical(1)


# ------------------------------------------------------------------------------------------- bad input
def test_markers_in_the_wrong_frame_for_the_mounting_are_refused():
    arm = iy.Arm.irb4600()
    scenario = iy.scenarios.eye_to_hand(arm, seed=0)
    joints = {"q_start": scenario.q_start, "q_target": scenario.q_target}
    with pytest.raises(
        InvalidParameterError, match="markers_O: received 'markers given in the base frame for an eye-to"
    ):
        iy.Scenario(**joints, markers_O=scenario.markers_E, mount=scenario.mount)
    with pytest.raises(
        InvalidParameterError, match="markers_E: received 'markers given in a frame of the arm"
    ):
        iy.Scenario(**joints, markers_E=scenario.markers_E)
    with pytest.raises(InvalidParameterError, match="markers_E: received None"):
        iy.Scenario(**joints, mount=scenario.mount)
    with pytest.raises(InvalidParameterError, match="mount: received 'dict'"):
        iy.Scenario(**joints, markers_E=scenario.markers_E, mount=scenario.mount.to_dict())


def test_an_eye_to_hand_mounting_on_the_free_flying_camera_is_refused():
    arm = iy.Arm.irb4600()
    scenario = iy.scenarios.eye_to_hand(arm, seed=0)
    with pytest.raises(
        InvalidParameterError, match=r"plant: received 'free-camera'.*'dynamic' or 'kinematic'"
    ):
        iy.simulate(scenario, "ibvs-current", plant="free-camera", duration=0.01)
    with pytest.raises(InvalidParameterError, match=r"mount: received 'eye-to-hand'.*free-camera scenario"):
        iy.Scenario(
            T_O_C_start=np.eye(4), T_O_C_target=np.eye(4), markers_E=scenario.markers_E, mount=scenario.mount
        )


def test_a_camera_that_sees_no_marker_at_the_start_is_refused():
    arm = iy.Arm.irb4600()
    scenario = iy.scenarios.eye_to_hand(arm, seed=0)
    T = scenario.mount.camera_pose
    T[:3, :3] = T[:3, :3] @ np.diag([-1.0, 1.0, -1.0])  # turned about its y axis: facing away from the arm
    away = iy.Scenario(
        q_start=scenario.q_start, q_target=scenario.q_target, markers_E=scenario.markers_E,
        mount=Mount.eye_to_hand(T),
    )  # fmt: skip
    with pytest.raises(
        InvalidParameterError,
        match=r"scenario.mount.T_O_C: received 'a camera at .* that sees none of the 3 markers.*in front "
        r"\[False, False, False\].*at least one marker is in front",
    ):
        iy.simulate(away, "ibvs-current", plant="kinematic", duration=0.01)


def test_an_arm_or_belief_mounted_otherwise_than_the_scenario_is_refused(views):
    view = views["irb4600"][0]
    scenario = iy.scenarios.eye_to_hand(view.arm, seed=0)
    with pytest.raises(InvalidParameterError, match="an arm without a mount, or with the scenario's"):
        iy.simulate(scenario, "ibvs-current", arm=view, plant="kinematic", duration=0.01)
    with pytest.raises(
        InvalidParameterError, match=r"beliefs\.arm.*an eye-in-hand Arm for the eye-in-hand scenario"
    ):
        iy.simulate(iy.scenarios.physical(1), "fb", beliefs=iy.Beliefs(arm=view), duration=0.01)
