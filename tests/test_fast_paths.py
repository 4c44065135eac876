"""The simulator's fast paths give the numbers of the straightforward code they replace.

Each kernel the simulator calls without input checks, and each scalar rewrite (closed-form and
nearest-branch IK, stereo P3P, camera projection and visibility, arm dynamics, image Jacobian,
SVD gains, the outer loop and its filter, the packed RK4 and the plant step), is compared with
a literal reference written here (array formulas, Pinocchio's own calls, the first matrix form
of the IK), on seeded inputs. The checked public methods call the same kernels. Timing is
measured by ``benchmarks/``, never asserted here.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from ibvs_youla import scenarios
from ibvs_youla._linalg import svd
from ibvs_youla.control.discrete import DiscreteFilter
from ibvs_youla.control.outer import OuterLoopDesign, SingularValuePolicy
from ibvs_youla.estimation.eye_in_hand import EyeInHand
from ibvs_youla.estimation.stereo_pose import rigid_transform_from_points
from ibvs_youla.exceptions import SimulationDivergedError, UnreachablePoseError
from ibvs_youla.model._ik_closed_form import SINGULAR_TOL, wrap_angles
from ibvs_youla.model.arm import Arm
from ibvs_youla.model.camera import MIN_ABS_DEPTH, PinholeCamera, StereoCamera, project_points, visible_points
from ibvs_youla.model.ik import (
    SphericalWristParameters,
    closed_form_branches,
    nearest_branch,
    select_branches,
)
from ibvs_youla.simulation.integrators import rk4_arm_step
from ibvs_youla.simulation.plant import ArmPlant

SEED = 20240611


def random_q(arm, rng, n):
    return arm.q_min + (arm.q_max - arm.q_min) * rng.random((n, 6))


def projected(T):
    """The SO(3) projection Arm.ik applies to its input pose."""
    T = T.copy()
    U, _, Vt = np.linalg.svd(T[:3, :3])
    T[:3, :3] = U @ Vt
    return T


# --------------------------------------------------------------------------- inverse kinematics
def reference_wrist(R36, q4_ref):
    """Wrist angles as first written, on the 3x3 matrix R36 (two-argument arctangents, ERRATA 5)."""
    m = math.hypot(R36[0, 2], R36[1, 2])
    if m < SINGULAR_TOL:
        if R36[2, 2] > 0.0:
            return [(q4_ref, 0.0, math.atan2(R36[1, 0], R36[0, 0]) - q4_ref)]
        return [(q4_ref, math.pi, q4_ref - math.atan2(-R36[1, 0], -R36[0, 0]))]
    out = []
    for sign in (1.0, -1.0):
        q5 = math.atan2(sign * m, R36[2, 2])
        q4 = math.atan2(-sign * R36[1, 2], -sign * R36[0, 2])
        q6 = math.atan2(-sign * R36[2, 1], sign * R36[2, 0])
        out.append((q4, q5, q6))
    return out


def reference_branches(p, T_O_E, q_ref):
    """Closed-form IK as first written: R_O_3 built as a matrix, R36 = R_O_3^T R by matmul."""
    R = T_O_E[:3, :3]
    x, y, z = T_O_E[:3, 3] - p.d6 * R[:, 2]
    L, beta = math.hypot(p.a3, p.d4), math.atan2(p.d4, p.a3)
    if math.hypot(x, y) < 1e-10:
        shoulders = (q_ref[0], q_ref[0] + math.pi)
    else:
        front = math.atan2(y, x)
        shoulders = (front, front - math.pi if front > 0.0 else front + math.pi)
    rows = []
    for q1 in shoulders:
        c1, s1 = math.cos(q1), math.sin(q1)
        r, s = x * c1 + y * s1 - p.a1, z - p.d1
        cos_g = (r * r + s * s - p.a2**2 - L * L) / (2.0 * p.a2 * L)
        if abs(cos_g) > 1.0 + 1e-12:
            continue
        gamma0 = math.acos(min(1.0, max(-1.0, cos_g)))
        for gamma in (gamma0, -gamma0) if gamma0 > 0.0 else (gamma0,):
            q3 = gamma - beta
            q2 = math.atan2(r, s) - math.atan2(L * math.sin(gamma), p.a2 + L * math.cos(gamma))
            sp, cp = math.sin(q2 + q3), math.cos(q2 + q3)
            R_O_3 = np.array([[sp * c1, s1, cp * c1], [sp * s1, -c1, cp * s1], [cp, 0.0, -sp]])
            for q4, q5, q6 in reference_wrist(R_O_3.T @ R, float(q_ref[3])):
                rows.append((q1, q2, q3, q4, q5, q6))
    return wrap_angles(np.array(rows, dtype=float).reshape(-1, 6))


def reference_select(branches, q_min, q_max, q_near, tol=1e-9, duplicate=1e-6):
    """select_branches with its first duplicate filter (row by row against the kept rows)."""
    if branches.shape[0] == 0:
        return branches
    anchor = np.clip(q_near, q_min, q_max)
    base = anchor + wrap_angles(branches - anchor)
    cand = base[..., None] + math.tau * np.arange(-2, 3)
    inside = (cand >= (q_min - tol)[:, None]) & (cand <= (q_max + tol)[:, None])
    dist = np.where(inside, np.abs(cand - q_near[:, None]), np.inf)
    pick = np.argmin(dist, axis=-1)
    ok = np.isfinite(np.take_along_axis(dist, pick[..., None], -1)[..., 0]).all(axis=1)
    q = np.clip(np.take_along_axis(cand, pick[..., None], -1)[..., 0][ok], q_min, q_max)
    q = q[np.argsort(np.linalg.norm(q - q_near, axis=1), kind="stable")]
    keep = []
    for row in q:
        if all(np.abs(wrap_angles(row - k)).max() > duplicate for k in keep):
            keep.append(row)
    return np.array(keep).reshape(-1, 6)


def test_scalar_closed_form_matches_the_matrix_form(arm):
    rng = np.random.default_rng(SEED)
    p = arm.ik_parameters
    singular = [np.zeros(6), np.radians([30.0, 10.0, -20.0, 50.0, 0.0, -70.0])]  # wrist singular, q5 = 0
    for q in [*singular, *random_q(arm, rng, 500)]:
        T_O_E = arm.flange_pose(q)
        q_ref = rng.uniform(-3, 3, 6)
        np.testing.assert_allclose(
            closed_form_branches(p, T_O_E, q_ref), reference_branches(p, T_O_E, q_ref), rtol=0, atol=1e-12
        )


def test_select_branches_keeps_its_duplicate_rule():
    rng = np.random.default_rng(SEED + 1)
    q_min, q_max = np.radians([-180, -90, -180, -400, -125, -400]), np.radians([180, 150, 75, 400, 120, 400])
    for _ in range(300):
        rows = rng.uniform(-math.pi, math.pi, (8, 6))
        rows[rng.integers(0, 8, 3)] = rows[rng.integers(0, 8)] + rng.choice([0.0, 1e-7, 2 * math.pi], (3, 6))
        q_near = rng.uniform(-4, 4, 6)
        np.testing.assert_array_equal(
            select_branches(rows, q_min, q_max, q_near), reference_select(rows, q_min, q_max, q_near)
        )


def test_nearest_branch_is_the_first_selected_branch(arm):
    """nearest_branch == select_branches(closed_form_branches(...))[0], or None when none is left."""
    rng = np.random.default_rng(SEED + 2)
    p, q_min, q_max = arm.ik_parameters, arm.q_min, arm.q_max
    n_none = 0
    # Folded back past the q2 limit (q2 = -100 deg < -90 deg, as in tests/test_ik.py): every branch
    # breaks a limit, so the None branch is taken (random poses within the limits never take it).
    q_bad = np.radians([0.0, -100.0, 90.0, 0.0, 30.0, 0.0]) + rng.normal(0.0, 0.02, (40, 6))
    for i, q in enumerate([*random_q(arm, rng, 2000), *q_bad]):
        T_O_E = arm.flange_pose(q)
        # q_near close (the loop's case), far, beyond a turn on joints 4/6, or outside the limits
        spread = (0.01, 0.5, 3.0, 8.0)[i % 4]
        q_near = q + rng.normal(0.0, spread, 6)
        expected = select_branches(closed_form_branches(p, T_O_E, q_near), q_min, q_max, q_near)
        got = nearest_branch(p, T_O_E, q_min.tolist(), q_max.tolist(), q_near.tolist())
        if expected.shape[0] == 0:
            assert got is None
            n_none += 1
        else:
            np.testing.assert_array_equal(got, expected[0])  # same arithmetic: same floats
    assert 0 < n_none < 2040


def test_ik_nearest_equals_ik_first_row(arm):
    rng = np.random.default_rng(SEED + 3)
    for i, q in enumerate(random_q(arm, rng, 1000)):
        T_O_C = projected(arm.camera_pose(q))
        q_near = q + rng.normal(0.0, (0.01, 0.3, 2.0)[i % 3], 6)
        np.testing.assert_allclose(
            arm.ik_nearest(T_O_C, q_near), arm.ik(T_O_C, q_near=q_near)[0], rtol=0, atol=1e-12
        )


def test_ik_nearest_at_singular_and_unreachable_poses(arm):
    for q in (np.zeros(6), np.radians([30.0, 10.0, -20.0, 50.0, 0.0, -70.0])):  # wrist singular (q5 = 0)
        T_O_C = projected(arm.camera_pose(q))
        for q_near in (q, q + 0.2):
            np.testing.assert_allclose(
                arm.ik_nearest(T_O_C, q_near), arm.ik(T_O_C, q_near=q_near)[0], rtol=0, atol=1e-12
            )
    far = arm.camera_pose(np.zeros(6))
    far[:3, 3] = [5.0, 0.0, 1.0]  # out of reach
    with pytest.raises(UnreachablePoseError):
        arm.ik_nearest(far, np.zeros(6))


def test_ik_nearest_of_a_numerical_ik_arm_delegates_to_ik():
    from ibvs_youla.model._resources import example_robot_data_urdf

    ur5 = Arm.from_urdf(example_robot_data_urdf("ur_description/urdf/ur5_robot.urdf"), camera_frame="tool0")
    assert ur5.ik_parameters is None
    q = np.array([0.3, -1.0, 1.2, -0.5, 0.8, 0.2])
    T = ur5.camera_pose(q)
    np.testing.assert_allclose(ur5.ik_nearest(T, q), ur5.ik(T, q_near=q)[0], rtol=0, atol=1e-12)


def test_spherical_wrist_parameters_unchanged():
    assert SphericalWristParameters.irb4600().d4 == 0.960


# --------------------------------------------------------------------------- camera and stereo P3P
# Skew and an off-centre principal point, as in tests/test_camera.py: the field of view is not symmetric.
SKEWED = StereoCamera(
    focal_length=2.8e-3,
    baseline=0.12,
    sensor_width=5.23e-3,
    sensor_height=2.94e-3,
    pixel_pitch=4e-6,
    skew=3.5,
    principal_point=(650.0, 355.0),
)


def reference_visibility(cam, P):
    """(in front, in view, in depth range) of points (n, 3): plain array formulas of Eq. (6), (9)-(11)."""
    X, Y, Z = P.T
    front = Z >= MIN_ABS_DEPTH
    Fiz = cam.focal_length / np.where(front, Z, 1.0)
    v_px = Y * Fiz / cam.pixel_pitch + cam.principal_point[1]
    in_view = front & (v_px >= 0) & (v_px <= cam.sensor_height / cam.pixel_pitch)
    lenses = (0.5 * cam.baseline, -0.5 * cam.baseline) if isinstance(cam, StereoCamera) else (0.0,)
    for x0 in lenses:
        u_px = (X - x0) * Fiz / cam.pixel_pitch + cam.skew * (Y * Fiz) / cam.focal_length
        u_px += cam.principal_point[0]
        in_view &= (u_px >= 0) & (u_px <= cam.sensor_width / cam.pixel_pitch)
    if cam.unbounded_view:
        in_view = front
    return front, in_view, (Z >= cam.depth_range[0]) & (Z <= cam.depth_range[1])


@pytest.mark.parametrize(
    "cam",
    [
        StereoCamera.zed2(),
        StereoCamera.zed2("zed2", "VGA"),
        PinholeCamera.zed2(),
        SKEWED,
        PinholeCamera.normalized(),
    ],
)
def test_visibility_equals_the_array_formulas(cam):
    rng = np.random.default_rng(SEED + 4)
    n_visible = 0
    for _ in range(3000):
        P = rng.normal([0.0, 0.0, 3.0], [3.0, 2.0, 4.0], (3, 3))
        if rng.random() < 0.2:
            P[:, 2] = rng.choice([0.0, 1e-10, cam.depth_range[0], cam.depth_range[1]])  # edges
        if rng.random() < 0.3:  # all in view
            P = np.column_stack((rng.uniform(-0.3, 0.3, (3, 2)), rng.uniform(1.0, 5.0, 3)))
        front, in_view, in_range = reference_visibility(cam, P)
        report = cam.visibility(P)
        np.testing.assert_array_equal(report.in_front, front)
        np.testing.assert_array_equal(report.in_fov, in_view)
        np.testing.assert_array_equal(report.in_depth_range, in_range)
        np.testing.assert_array_equal(visible_points(cam, P), front & in_view & in_range)
        n_visible += report.all_visible
    assert 0 < n_visible < 3000


def test_projection_and_interaction_equal_the_array_formulas(camera):
    rng = np.random.default_rng(SEED + 5)
    F, b = camera.focal_length, camera.baseline
    for _ in range(100):
        P = rng.normal([0.0, 0.0, 3.0], [1.0, 1.0, 1.0], (3, 3))
        P[:, 2] = np.abs(P[:, 2]) + 0.5
        X, Y, Z = P.T
        Fiz = F / Z  # Eq. (9)-(11) with ERRATA 12, in the kernel's order of operations
        literal = np.column_stack(((X - 0.5 * b) * Fiz, (X + 0.5 * b) * Fiz, Y * Fiz))
        np.testing.assert_array_equal(project_points(camera, P, False), literal.reshape(-1))
        np.testing.assert_array_equal(camera.project(P), literal)
        np.testing.assert_allclose(camera.triangulate(literal), P, rtol=1e-12, atol=0)
        L = camera.interaction_matrix(P)
        for i, (X, Y, Z) in enumerate(P):  # literal rows of the docstring, point by point
            for r, x0 in enumerate((0.06, -0.06)):
                uu = camera.focal_length * (X - x0) / Z
                F = camera.focal_length
                row = [-F / Z, 0, uu / Z, uu * Y / Z, -F - uu * X / Z, F * Y / Z]
                np.testing.assert_allclose(L[3 * i + r], row, rtol=1e-13, atol=0)


def literal_kabsch(P_from, P_to):
    c_from, c_to = P_from.mean(axis=0), P_to.mean(axis=0)
    U, _, Vt = np.linalg.svd((P_from - c_from).T @ (P_to - c_to))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
    R = Vt.T @ D @ U.T
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, c_to - R @ c_from
    return T


def test_stereo_pose_fast_path_equals_literal_kabsch(arm, camera):
    rng = np.random.default_rng(SEED + 6)
    sc = scenarios.paper(2)
    eye = EyeInHand(arm, camera, sc.markers_O, virtual_points=True)
    for _ in range(300):
        q = sc.q_start + rng.normal(0.0, 0.3, 6)
        p = eye.features(q)
        P_C = camera.triangulate(p.reshape(3, 3), allow_behind=True)
        expected = literal_kabsch(P_C, eye.markers_O)
        np.testing.assert_allclose(eye.estimate_camera_pose(p), expected, rtol=0, atol=1e-12)
        T = rigid_transform_from_points(P_C, eye.markers_O)
        np.testing.assert_allclose(T, expected, rtol=0, atol=1e-12)
    # far from the origin (1e6 m) with a 1 m spread: centring keeps the fit exact to round-off
    A = rng.normal(size=(3, 3)) + 1e6
    T_true = literal_kabsch(rng.normal(size=(3, 3)), rng.normal(size=(3, 3)))
    B = A @ T_true[:3, :3].T + T_true[:3, 3]
    np.testing.assert_allclose(rigid_transform_from_points(A, B)[:3, :3], T_true[:3, :3], rtol=0, atol=1e-9)
    # a reflection case: exactly three points, where the det correction matters half the time
    flips = 0
    for _ in range(200):
        A = rng.normal(size=(3, 3))
        B = rng.normal(size=(3, 3))
        flips += np.linalg.det(np.linalg.svd((A - A.mean(0)).T @ (B - B.mean(0)))[2]) < 0
        T = rigid_transform_from_points(A, B)
        np.testing.assert_allclose(T, literal_kabsch(A, B), rtol=0, atol=1e-12)
    assert 0 < flips < 200


def pinocchio_camera_jacobian(arm, q):
    """J_C (6, 6), LOCAL, straight from Pinocchio's frame Jacobian (not the arm's one-pass kernel)."""
    frame = arm.model.getFrameId(arm.camera_frame)
    return pin.computeFrameJacobian(arm.model, arm.model.createData(), q, frame, pin.LOCAL)


def test_eye_in_hand_kernels_equal_the_literal_equations(arm, camera):
    """J = L(P_C) J_C(q) (Eq. 51) and q~ = IK(Kabsch(triangulated features)) (Eq. 62), written out here."""
    rng = np.random.default_rng(SEED + 7)
    for sc in scenarios.paper_scenarios():
        eye = EyeInHand(arm, camera, sc.markers_O, virtual_points=True)
        for _ in range(100):
            q = sc.q_start + rng.normal(0.0, 0.2, 6)
            T_O_C = arm.camera_pose(q)
            P_C = (sc.markers_O - T_O_C[:3, 3]) @ T_O_C[:3, :3]  # R^T (P_O - t), Eq. (21)-(22)
            J = camera.interaction_matrix(P_C, allow_behind=True) @ pinocchio_camera_jacobian(arm, q)
            # The compiled kernel sums P_C and L J_C in its own order (BLAS here): P_C's rounding (a few eps
            # of the 3 m to a marker) is amplified by 1/Z^2 at the virtual marker near the image plane
            # (Z_C = -4 mm in some of these poses), hence 1e-12 of each entry, not the last bits.
            tol = {"rtol": 1e-12, "atol": 1e-14 * np.abs(J).max()}
            np.testing.assert_allclose(eye.image_jacobian(q), J, **tol)
            np.testing.assert_allclose(eye.jacobian(q), J, **tol)
            p = eye.features(q)
            q_near = q + rng.normal(0.0, 0.01, 6)
            P_C_seen = camera.triangulate(p.reshape(3, 3), allow_behind=True)
            reference = arm.ik(literal_kabsch(P_C_seen, eye.markers_O), q_near=q_near)[0]
            np.testing.assert_allclose(eye.q_from_image(p, q_near), reference, rtol=0, atol=1e-9)
            np.testing.assert_allclose(eye.estimate_q(p, q_near), reference, rtol=0, atol=1e-9)


def test_arm_kernels_equal_the_literal_equations(arm):
    """Eq. (30) both ways against M(q) and h(q, dq); the one-pass pose and Jacobian against Pinocchio's."""
    rng = np.random.default_rng(SEED + 8)
    for q in random_q(arm, rng, 50):
        dq, v = rng.normal(0, 2, 6), rng.normal(0, 10, 6)
        M, h = arm.mass_matrix(q), arm.nonlinear_effects(q, dq)
        tau = arm.rnea(q, dq, v)
        scale = np.abs(tau).max()
        np.testing.assert_allclose(tau, M @ v + h, rtol=0, atol=1e-12 * scale)
        np.testing.assert_array_equal(arm.inverse_dynamics(q, dq, v), tau)
        ddq = np.linalg.solve(M, tau - h)
        np.testing.assert_allclose(arm.aba(q, dq, tau), ddq, rtol=0, atol=1e-9 * np.abs(ddq).max())
        np.testing.assert_allclose(arm.forward_dynamics(q, dq, tau), v, rtol=0, atol=1e-9 * np.abs(v).max())
        T, J = arm.camera_pose_and_jacobian(q)
        np.testing.assert_array_equal(T, arm.camera_pose(q))
        np.testing.assert_allclose(J, pinocchio_camera_jacobian(arm, q), rtol=0, atol=1e-14)
        np.testing.assert_array_equal(arm.camera_jacobian(q), J)


# --------------------------------------------------------------------------- control
def test_direct_lapack_svd_equals_numpy_svd():
    rng = np.random.default_rng(SEED + 9)
    for shape in [(9, 6), (3, 3), (6, 9)]:
        A = rng.normal(size=shape)
        U, s, Vt = svd(A)
        np.testing.assert_allclose(s, np.linalg.svd(A, compute_uv=False), rtol=1e-14, atol=0)
        np.testing.assert_allclose((U * s) @ Vt, A, rtol=0, atol=1e-14)


def literal_gains(policy, s, size):
    """g(sigma) of the SingularValuePolicy docstring as array formulas (s descending)."""
    keep = s > size * np.finfo(float).eps * s[0]  # the numerical rank tolerance
    g = np.zeros_like(s)
    if policy.kind == "damped":
        g[keep] = s[keep] / (s[keep] ** 2 + (policy.threshold * s[0]) ** 2)
    else:
        keep &= s > policy.threshold * s[0]
        g[keep] = 1.0 / s[keep]
    return g


@pytest.mark.parametrize(
    "policy",
    [SingularValuePolicy(), SingularValuePolicy("truncate", 0.05), SingularValuePolicy("damped", 0.0)],
)
def test_gains_and_pseudo_inverse_equal_the_array_formulas(policy):
    rng = np.random.default_rng(SEED + 10)
    for rank in (6, 5, 4):
        for _ in range(20):
            J = rng.normal(size=(9, rank)) @ rng.normal(size=(rank, 6))  # rank-deficient when rank < 6
            U, s, Vt = np.linalg.svd(J, full_matrices=False)
            g = literal_gains(policy, s, 9)
            np.testing.assert_allclose(policy.gains(s, 9), g, rtol=1e-12, atol=1e-300)
            dec = policy.decompose(J)
            np.testing.assert_allclose(dec.sigma, s, rtol=1e-13, atol=1e-15)
            np.testing.assert_allclose(dec.gains, g, rtol=1e-12, atol=1e-300)
            np.testing.assert_allclose(dec.pinv, (Vt.T * g) @ U.T, rtol=0, atol=1e-12 * np.abs(g).max())


def test_stacked_filter_step_equals_the_state_space_recursion():
    design = OuterLoopDesign()
    filt = DiscreteFilter.from_tf(design.filter_tf(), 1e-3, 6)
    A, B, C, D = filt.matrices
    rng = np.random.default_rng(SEED + 11)
    x = rng.normal(size=(A.shape[0], 6))
    filt.reset(x)
    for _ in range(300):
        u = rng.normal(size=6)
        y_ref = C @ x + D * u
        x = A @ x + np.outer(B, u)
        y = filt.step(u)
        np.testing.assert_allclose(y, y_ref, rtol=1e-12, atol=1e-12 * np.abs(y_ref).max())
        np.testing.assert_allclose(filt.state, x, rtol=1e-12, atol=1e-12 * np.abs(x).max())


def test_filter_copies_keep_their_state():
    import copy

    filt = DiscreteFilter.from_tf(OuterLoopDesign().filter_tf(), 1e-3, 6)
    filt.reset_output(np.ones(6))
    twin = copy.deepcopy(filt)
    for _ in range(5):
        np.testing.assert_array_equal(filt.step(np.full(6, 0.1)), twin.step(np.full(6, 0.1)))
    twin.reset()
    np.testing.assert_array_equal(twin.state, 0.0)
    np.testing.assert_array_equal(twin.step(np.zeros(6)), 0.0)
    assert np.abs(filt.state).max() > 0.0


def test_outer_update_equals_the_filter_recursion_on_the_pseudo_inverse(arm, camera):
    """q_fb = K(z)[P e] with P = V diag(g) U^T from numpy's SVD, K's state-space recursion written here."""
    design = OuterLoopDesign()
    a, b = design.runtime(1e-3), design.runtime(1e-3)
    a.reset(np.full(6, 0.1))
    b.reset(np.full(6, 0.1))
    ref = DiscreteFilter.from_tf(design.filter_tf(), 1e-3, 6)
    ref.reset_output(np.full(6, 0.1))  # as the controllers' reset
    (A, B, C, D), x = ref.matrices, ref.state
    sc = scenarios.paper(2)
    eye = EyeInHand(arm, camera, sc.markers_O, virtual_points=True)
    rng = np.random.default_rng(SEED + 12)
    for _ in range(200):
        q = sc.q_start + rng.normal(0.0, 0.2, 6)
        J, e = eye.jacobian(q), rng.normal(0.0, 1e-4, 9)
        U, s, Vt = np.linalg.svd(J, full_matrices=False)
        g = literal_gains(design.sv_policy, s, 9)
        Pe = ((Vt.T * g) @ U.T) @ e
        q_fb = C @ x + D * Pe
        x = A @ x + np.outer(B, Pe)
        np.testing.assert_allclose(a.advance(e, J), q_fb, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(b.update(e, J), q_fb, rtol=1e-12, atol=1e-15)
    dec = a.last_decomposition
    for got, expected in zip(dec, (U, s, g, Vt, (Vt.T * g) @ U.T), strict=True):
        np.testing.assert_allclose(np.abs(got), np.abs(expected), rtol=1e-12, atol=1e-12)  # up to sign


# --------------------------------------------------------------------------- plant and simulation loop
def literal_rk4(forward_dynamics, q, dq, tau, dt):
    """Classical RK4 on dq/dt = v, dv/dt = FD(q, v, tau), tau held, written stage by stage on (q, dq)."""
    v1, a1 = dq, forward_dynamics(q, dq, tau)
    v2 = dq + 0.5 * dt * a1
    a2 = forward_dynamics(q + 0.5 * dt * v1, v2, tau)
    v3 = dq + 0.5 * dt * a2
    a3 = forward_dynamics(q + 0.5 * dt * v2, v3, tau)
    v4 = dq + dt * a3
    a4 = forward_dynamics(q + dt * v3, v4, tau)
    return q + dt / 6.0 * (v1 + 2.0 * v2 + 2.0 * v3 + v4), dq + dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)


def test_packed_rk4_equals_the_stage_by_stage_formula(arm):
    rng = np.random.default_rng(SEED + 13)
    k = np.empty((4, 12))
    for q in random_q(arm, rng, 50):
        dq, tau = rng.normal(0, 1, 6), rng.normal(0, 500, 6)
        q1, dq1 = literal_rk4(arm.forward_dynamics, q, dq, tau, 1e-3)
        x1 = rk4_arm_step(arm.aba, np.concatenate([q, dq]), tau, 1e-3, k)
        np.testing.assert_allclose(x1[:6], q1, rtol=0, atol=1e-15)
        np.testing.assert_allclose(x1[6:], dq1, rtol=0, atol=1e-12 * np.abs(dq1).max())


@pytest.mark.parametrize(
    ("saturate_torque", "saturate_speed"), [(False, False), (True, True), (False, True), (True, False)]
)
def test_plant_step_equals_the_stage_by_stage_formula_with_saturation(arm, saturate_torque, saturate_speed):
    d = np.full(6, np.radians(1.0))
    q0 = scenarios.paper(2).q_start
    flags = {"saturate_torque": saturate_torque, "saturate_speed": saturate_speed}
    a = ArmPlant(arm, d, q_encoder=q0, **flags)
    b = ArmPlant(arm, d, q_encoder=q0, **flags)
    q, dq, t = q0 + d, np.zeros(6), 0.0
    rng = np.random.default_rng(SEED + 14)
    for _ in range(200):
        tau = arm.gravity(a.q_true) + rng.normal(0.0, 300.0, 6)
        with np.errstate(all="ignore"):
            a.apply(tau, 1e-3)
        b.step(tau, 1e-3)
        held = np.clip(tau, -arm.tau_max, arm.tau_max) if saturate_torque else tau
        q, dq = literal_rk4(arm.forward_dynamics, q, dq, held, 1e-3)
        dq = np.clip(dq, -arm.dq_max, arm.dq_max) if saturate_speed else dq
        t += 1e-3
        for plant in (a, b):
            np.testing.assert_allclose(plant.q_true, q, rtol=0, atol=1e-12)
            np.testing.assert_allclose(plant.dq, dq, rtol=0, atol=1e-10)
            np.testing.assert_array_equal(plant.q_encoder, plant.q_true - d)
            np.testing.assert_array_equal(plant.last_tau, held)
            assert plant.t == t


@pytest.mark.parametrize("tau", [np.full(6, 1e12), np.full(6, np.nan)])
def test_plant_apply_raises_the_divergence_step_raises(arm, tau):
    errors = []
    for loop in (True, False):
        plant = ArmPlant(arm, q_encoder=np.zeros(6))
        with pytest.raises(SimulationDivergedError) as info, np.errstate(all="ignore"):
            (plant.apply if loop else plant.step)(tau, 1e-3)
        errors.append(info.value)
        np.testing.assert_array_equal(plant.q_true, np.zeros(6))  # state kept at the failed step's start
    assert str(errors[0]) == str(errors[1])
    assert errors[0].quantity == errors[1].quantity
