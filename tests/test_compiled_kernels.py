"""Each compiled kernel gives the numbers of the plain Python/numpy reference it replaces.

The servo loop runs Numba-compiled kernels (``ibvs_youla._jit``); each keeps the plain code it
was written from as its reference, and every test here feeds both the same seeded random inputs
and states its tolerance: exact where the two do the same floating-point operations in the same
order, a few ulps of the operands' magnitude where a sum is formed in another order than BLAS
forms it. Then the fallbacks: no writable cache directory, Numba's JIT switched off, and the
on-disk cache read back by a second process. Timing is measured by ``benchmarks/``, never here.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from scipy.linalg import lapack
from scipy.spatial.transform import Rotation

from ibvs_youla._linalg import gesdd
from ibvs_youla.control.discrete import DiscreteFilter, filter_step
from ibvs_youla.control.outer import OuterLoopDesign
from ibvs_youla.control.singular_values import SingularValuePolicy
from ibvs_youla.control.svd_kernels import pseudo_inverse_apply, pseudo_inverse_integrate, svd_gains_apply
from ibvs_youla.estimation.stereo_kernels import camera_pose_from_features, kabsch_centred_compiled
from ibvs_youla.estimation.stereo_pose import kabsch_centred
from ibvs_youla.exceptions import InvalidDisparityError, PointBehindCameraError
from ibvs_youla.model.camera import (
    PinholeCamera,
    StereoCamera,
    points_interaction_matrix,
    project_points,
    triangulate_points,
    visible_points,
)
from ibvs_youla.model.camera_kernels import (
    camera_parameters,
    image_jacobian,
    interaction_matrix,
    measure_features,
    triangulate,
)
from ibvs_youla.model.dynamics_kernels import ChainDynamics, aba_compiled
from ibvs_youla.model.ik import nearest_branch
from ibvs_youla.model.ik_kernels import ik_parameter_array, nearest_branch_compiled
from ibvs_youla.simulation.integrators import ArmRk4, rk4_arm_step
from ibvs_youla.simulation.progress import COMPILE_MESSAGE

SEED = 20261201
EPS = np.finfo(float).eps
CAMERAS = {
    "zed2-paper": StereoCamera.zed2(),
    "zed2-vga": StereoCamera.zed2("zed2", "VGA"),
    "pinhole": PinholeCamera.zed2(),
    "normalized": PinholeCamera.normalized(),
}


def random_pose(rng, distance=2.0):
    """A camera pose looking roughly at the origin region, with random rotation."""
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    T = np.eye(4)
    T[:3, :3] = q * np.sign(np.linalg.det(q))
    T[:3, 3] = rng.normal(0.0, distance, 3)
    return T


def points_in_camera(T_O_C, P_O):
    return (P_O - T_O_C[:3, 3]) @ T_O_C[:3, :3]


# --------------------------------------------------------------------------- camera
@pytest.mark.parametrize("name", list(CAMERAS))
def test_measure_features_equals_project_points_and_visible_points(name):
    """The same features and visibility flags, bit for bit (the same operations in the same order)."""
    camera = CAMERAS[name]
    params, lens_x = camera_parameters(camera)
    rng = np.random.default_rng(SEED)
    n_bad = n_visible = 0
    for i in range(3000):
        P_O = rng.normal(0.0, 1.0, (3 + i % 3, 3))
        T = random_pose(rng)
        allow_behind = bool(i % 2)
        P_C = points_in_camera(T, P_O)
        features, visible, bad = measure_features(P_C, params, lens_x, allow_behind)
        try:
            expected = project_points(camera, P_C, allow_behind)
        except PointBehindCameraError:
            n_bad += 1
            assert bad >= 0
            continue
        assert bad == -1
        np.testing.assert_array_equal(features, expected)
        flags = visible_points(camera, P_C)
        np.testing.assert_array_equal(visible, flags)
        n_visible += int(np.sum(flags))
    assert n_bad > 100 and n_visible > 100


def test_measure_features_reports_the_first_bad_depth():
    camera = CAMERAS["zed2-paper"]
    params, lens_x = camera_parameters(camera)
    P_O = np.array([[0.0, 0.0, 2.0], [0.1, 0.0, -1.0], [0.0, 0.1, 0.0]])
    assert measure_features(P_O, params, lens_x, False)[2] == 1
    assert measure_features(P_O, params, lens_x, True)[2] == 2  # |Z| ~ 0 is refused even behind
    with pytest.raises(PointBehindCameraError):
        project_points(camera, P_O, True)


@pytest.mark.parametrize("name", ["zed2-paper", "pinhole"])
def test_image_jacobian_equals_interaction_matrix_times_camera_jacobian(name):
    """L(P_C) J_C to 1e-12 of each entry's terms: 6-term sums and P_C in another order than BLAS."""
    camera = CAMERAS[name]
    params, lens_x = camera_parameters(camera)
    rng = np.random.default_rng(SEED + 1)
    for _ in range(2000):
        P_O = rng.normal(0.0, 1.0, (3, 3))
        T = random_pose(rng)
        J_C = rng.normal(0.0, 1.0, (6, 6))
        P_C = points_in_camera(T, P_O)
        if np.abs(P_C[:, 2]).min() < 0.05:  # far from the image plane: the comparison stays well-conditioned
            continue
        L = points_interaction_matrix(camera, P_C, True)
        J, bad = image_jacobian(T, J_C, P_O, params, lens_x, True)
        assert bad == -1
        terms = np.abs(L) @ np.abs(J_C)
        np.testing.assert_array_less(np.abs(J - L @ J_C), 1e-12 * terms + 1e-300)


def test_triangulate_equals_triangulate_points_and_flags_the_bad_disparity():
    camera = CAMERAS["zed2-paper"]
    params, _ = camera_parameters(camera)
    rng = np.random.default_rng(SEED + 2)
    for i in range(3000):
        allow_behind = bool(i % 2)
        p = rng.normal(0.0, 2e-3, (3, 3))
        try:
            expected = triangulate_points(camera, p, allow_behind)
        except InvalidDisparityError:
            assert triangulate(p.reshape(-1), params, allow_behind)[1] >= 0
            continue
        P, bad = triangulate(p.reshape(-1), params, allow_behind)
        assert bad == -1
        np.testing.assert_array_equal(P, expected)  # the same operations in the same order


# --------------------------------------------------------------------------- stereo P3P and IK
def test_kabsch_and_stereo_pose_equal_the_references():
    """T_O_C to 1e-12 m and rad: centroids and H summed in another order than BLAS, then the same SVD."""
    camera = CAMERAS["zed2-paper"]
    params, _ = camera_parameters(camera)
    rng = np.random.default_rng(SEED + 3)
    for i in range(1000):
        P_O = rng.normal(0.0, 1.0, (3 + i % 4, 3))
        mean = P_O.mean(axis=0)
        T = random_pose(rng, 0.5)
        T[:3, 3] += [0.0, 0.0, -4.0]
        P_C = points_in_camera(T, P_O)
        np.testing.assert_allclose(
            kabsch_centred_compiled(P_C, P_O - mean, mean), kabsch_centred(P_C, P_O - mean, mean), atol=1e-12
        )
        features = project_points(camera, P_C, True)
        reference = kabsch_centred(
            triangulate_points(camera, features.reshape(-1, 3), True), P_O - mean, mean
        )
        T_est, bad = camera_pose_from_features(features, params, True, P_O - mean, mean)
        assert bad == -1
        np.testing.assert_allclose(T_est, reference, atol=1e-12)  # the docstring's 1e-12 (measured 6.5e-14)


def test_nearest_branch_compiled_equals_nearest_branch(arm):
    """Same branch, same angles to 1e-12 rad (math.hypot: CPython's own against the C library's)."""
    p, p_array = arm.ik_parameters, ik_parameter_array(arm.ik_parameters)
    q_min, q_max = arm.q_min, arm.q_max
    rng = np.random.default_rng(SEED + 4)
    qs = [q_min + (q_max - q_min) * rng.random(6) for _ in range(3000)]
    qs += [np.radians([0.0, -100.0, 90.0, 0.0, 30.0, 0.0]) + rng.normal(0.0, 0.02, 6) for _ in range(40)]
    qs += [np.radians([30.0, 10.0, -20.0, 50.0, 0.0, -70.0]), np.zeros(6)]  # wrist singular, q5 = 0
    n_none = 0
    for i, q in enumerate(qs):
        T_O_E = arm.flange_pose(q)
        q_near = q + rng.normal(0.0, (0.01, 0.5, 3.0, 8.0)[i % 4], 6)
        expected = nearest_branch(p, T_O_E, q_min.tolist(), q_max.tolist(), q_near.tolist())
        # T_C_E = I: the kernel's T_O_C T_C_E is then T_O_E exactly, the reference's input
        found, got = nearest_branch_compiled(p_array, T_O_E, np.eye(4), q_min, q_max, q_near, 1e-9)
        assert found == (expected is not None)
        if expected is None:
            n_none += 1
        else:
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    assert 0 < n_none < len(qs)


# --------------------------------------------------------------------------- SVD, gains, filter
@pytest.mark.parametrize("shape", [(9, 6), (3, 3), (6, 6), (8, 6), (12, 6)])
def test_gesdd_is_the_f2py_dgesdd_bit_for_bit(shape):
    rng = np.random.default_rng(SEED + 5)
    for rank in range(min(shape) + 1):
        for _ in range(20):
            A = rng.normal(size=(shape[0], rank)) @ rng.normal(size=(rank, shape[1]))
            U, s, Vt, info = gesdd(A)
            U2, s2, Vt2, info2 = lapack.dgesdd(A, 1, 0)
            assert info == info2 == 0
            for got, expected in ((U, U2), (s, s2), (Vt, Vt2)):
                np.testing.assert_array_equal(got, expected)
    A = rng.normal(size=shape)
    A[0, -1] = np.nan
    assert gesdd(A)[3] == -1000  # never handed to LAPACK


def literal_gains(policy, sigma, size):
    """ERRATA 7's bounded inverse gains, as SingularValuePolicy documents them."""
    smax = sigma[0]
    zero = size * EPS * smax
    if policy.kind == "damped":
        lam2 = (policy.threshold * smax) ** 2
        return np.array([x / (x * x + lam2) if x > zero else 0.0 for x in sigma])
    cut = policy.threshold * smax
    return np.array([1.0 / x if x > zero and x > cut else 0.0 for x in sigma])


@pytest.mark.parametrize("policy", [SingularValuePolicy(), SingularValuePolicy("truncate", 1e-2)])
def test_svd_gains_apply_and_pseudo_inverse_apply_equal_the_policy(policy):
    """P e and J^+ x to 1e-13 of the terms |V| |g| |U^T| |e| (sums in another order); U, s, g, Vt
    bit for bit."""
    damped = policy.kind == "damped"
    rng = np.random.default_rng(SEED + 6)
    for rank in (6, 5, 3):
        for _ in range(200):
            J = rng.normal(size=(9, rank)) @ rng.normal(size=(rank, 6))
            e = rng.normal(size=9)
            U, s, Vt, _ = lapack.dgesdd(J, 1, 0)  # the plain reference: the f2py LAPACK call
            g = literal_gains(policy, s.tolist(), 9)
            for got, expected in zip(policy.svd_gains(J), (U, s, g, Vt), strict=True):
                np.testing.assert_array_equal(got, expected)  # the compiled svd_gains, bit for bit
            Pe = np.empty(6)
            assert svd_gains_apply(J, e, damped, policy.threshold, Pe)
            terms = np.abs(Vt.T) @ (np.abs(g) * (np.abs(U.T) @ np.abs(e)))
            np.testing.assert_array_less(np.abs(Pe - Vt.T.dot(g * U.T.dot(e))), 1e-13 * terms + 1e-300)
            J_C, x = J[:6], e[:6]
            P = policy.pseudo_inverse(J_C)
            y = np.empty(6)
            assert pseudo_inverse_apply(J_C, x, damped, policy.threshold, y)
            np.testing.assert_array_less(np.abs(y - P @ x), 1e-13 * (np.abs(P) @ np.abs(x)) + 1e-300)
    assert not svd_gains_apply(
        np.zeros((9, 6)), np.ones(9), damped, policy.threshold, np.empty(6)
    )  # no direction
    assert not pseudo_inverse_apply(np.zeros((6, 6)), np.ones(6), damped, policy.threshold, np.empty(6))


def test_filter_step_equals_the_stacked_product():
    """[x; y] = M [x; u] to 1e-14 of the terms (the products summed in another order than BLAS)."""
    filt = DiscreteFilter.from_tf(OuterLoopDesign().filter_tf(), 1e-3, 6)
    A, B, C, D = filt.matrices
    M = np.block([[A, B[:, None]], [C[None, :], np.array([[D]])]])
    rng = np.random.default_rng(SEED + 7)
    for _ in range(1000):
        z, u = rng.normal(size=(A.shape[0] + 1, 6)), rng.normal(size=6)
        expected = M @ np.vstack([z[:-1], u])
        z_next, y = np.empty_like(z), np.empty(6)
        filter_step(M, z, z_next, u, y)
        terms = np.abs(M) @ np.abs(np.vstack([z[:-1], u]))
        np.testing.assert_array_less(np.abs(z_next - expected), 1e-14 * terms + 1e-300)
        np.testing.assert_array_equal(y, z_next[-1])
        np.testing.assert_array_equal(z[-1], u)


# --------------------------------------------------------------------------- RK4
def compiled_arm_aba(arm):
    """FD(q, dq, tau) of the compiled ABA with the arm's damping, as ``arm.aba`` forms it."""
    chain = ChainDynamics.from_model(arm.pinocchio_model_data()[0])
    C, S = chain.chain, chain.scratch()

    def fd(q, dq, tau):
        ddq = np.empty(6)
        aba_compiled(C, S, np.ascontiguousarray(q), np.ascontiguousarray(dq), tau - arm.damping * dq, ddq)
        return ddq

    return fd


@pytest.mark.parametrize("compiled_aba", [True, False], ids=["one-compiled-call", "pin.aba"])
def test_arm_rk4_equals_rk4_arm_step_of_the_arm_dynamics(arm, compiled_aba):
    """The compiled stages around the ABA: the packed RK4 of the same ABA to 8 eps of the terms.

    With ``compiled_aba`` the whole step is one compiled call (rk4_aba_step) and the reference
    takes the compiled ABA (pinned to Pinocchio's in ``test_dynamics_kernels.py``); without,
    Pinocchio's ``pin.aba`` is called between the compiled stages and the reference takes
    ``arm.aba``. The weighted sum x + dt (k1 + 2 k2 + 2 k3 + k4) / 6 is formed in another order
    than BLAS's, so the bound is 8 eps (|x| + dt (|k1| + 2 |k2| + 2 |k3| + |k4|) / 6), the stage
    derivatives' magnitudes (1e6 rad/s^2 with the large torques).
    """
    n = 6
    low = np.concatenate([arm.q_min - 1.0, -1e3 * arm.dq_max])
    high = np.concatenate([arm.q_max + 1.0, 1e3 * arm.dq_max])
    rk4 = ArmRk4(arm, low, high, compiled_aba=compiled_aba)
    forward_dynamics = compiled_arm_aba(arm) if compiled_aba else arm.aba
    rng = np.random.default_rng(SEED + 8)
    n_outside = 0
    for i in range(500):
        q = arm.q_min + (arm.q_max - arm.q_min) * rng.random(n)
        x = np.concatenate([q, rng.normal(0.0, 1.0, n)])
        tau = rng.normal(0.0, (500.0, 5e6)[i % 2], n)  # the second often leaves the speed bounds
        k = np.empty((4, 2 * n))
        expected = rk4_arm_step(forward_dynamics, x, tau, 1e-3, k)
        got, inside = rk4.step(x, tau, 1e-3)
        terms = np.abs(x) + 1e-3 * (np.array([1.0, 2.0, 2.0, 1.0]) / 6.0) @ np.abs(k)
        np.testing.assert_array_less(np.abs(got - expected), 8 * EPS * terms)
        assert inside == bool(np.all((expected >= low) & (expected <= high)))
        n_outside += not inside
    assert 0 < n_outside < 500
    x = np.concatenate([arm.q_min, np.zeros(n)])
    assert not rk4.step(x, np.full(n, np.nan), 1e-3)[1]  # NaN is outside


# --------------------------------------------------------------------------- fallbacks and the cache
RUN = textwrap.dedent(
    """
    import json, sys
    import numpy as np
    import ibvs_youla as iy
    from ibvs_youla import scenarios
    from ibvs_youla.model.camera_kernels import measure_features
    from ibvs_youla._jit import jit_available
    r = iy.simulate(
        scenarios.paper(2), "ff+fb", duration=0.03, settings=iy.SimulationSettings.paper(), progress=True
    )
    stats = getattr(measure_features, "stats", None)
    print(json.dumps({
        "jit": jit_available(),
        "q": r.q.tolist(), "q_fb": r.signals["q_fb"].tolist(), "tau": r.signals["tau"].tolist(),
        "cache_hits": None if stats is None else sum(stats.cache_hits.values()),
        "cache_misses": None if stats is None else sum(stats.cache_misses.values()),
    }))
    """
)


def run_child(env_changes, cwd=None):
    env = {**os.environ, **env_changes}
    out = subprocess.run(
        [sys.executable, "-c", RUN], capture_output=True, text=True, env=env, cwd=cwd, timeout=600
    )
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1]), out.stderr


@pytest.mark.slow
def test_the_compiled_run_equals_the_interpreted_run_and_the_cache_is_read_back(tmp_path):
    """One short paper run three ways: compiled into an empty cache, compiled from that cache, and with
    Numba's JIT off (the kernels as plain Python, the f2py SVD): the same signals to 1e-12. With a
    progress bar, the first says in one line that it compiles; the cached and the plain runs do not."""
    cache = tmp_path / "numba-cache"
    first, first_err = run_child({"NUMBA_CACHE_DIR": str(cache)})
    second, second_err = run_child({"NUMBA_CACHE_DIR": str(cache)})
    plain, plain_err = run_child({"NUMBA_DISABLE_JIT": "1"})
    assert [err.count(COMPILE_MESSAGE) for err in (first_err, second_err, plain_err)] == [1, 0, 0]
    assert first["jit"] and second["jit"] and not plain["jit"]
    assert any(cache.rglob("*.nbi"))  # the index files of the cache
    assert first["cache_misses"] >= 1
    assert second["cache_hits"] >= 1 and second["cache_misses"] == 0  # loaded, not compiled again
    for key in ("q", "q_fb", "tau"):
        a, b, c = (np.array(r[key]) for r in (first, second, plain))
        np.testing.assert_array_equal(a, b)
        np.testing.assert_allclose(c, a, rtol=1e-12, atol=1e-12 * np.abs(a).max())


@pytest.mark.slow
def test_a_kernel_compiles_in_memory_when_no_cache_directory_is_writable(tmp_path):
    """No locator can write (a file where each cache directory would go): compiled all the same."""
    blocker = tmp_path / "not-a-directory"
    blocker.write_text("")
    module = tmp_path / "kernel_module.py"
    module.write_text(
        textwrap.dedent(
            """
            from ibvs_youla._jit import jit

            @jit
            def twice(x):
                return 2.0 * x
            """
        )
    )
    (tmp_path / "__pycache__").write_text("")  # the in-tree cache directory cannot be made
    code = (
        "import kernel_module as m; "
        "print(m.twice(21.0), type(m.twice).__name__, m.twice._cache.__class__.__name__)"
    )
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": str(blocker / "cache"),
        "XDG_CACHE_HOME": str(blocker / "xdg"),
        "HOME": str(blocker / "home"),
        "PYTHONPATH": str(tmp_path),
    }
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.split() == ["42.0", "CPUDispatcher", "NullCache"]


def test_filter_step_difference_is_the_step_of_the_difference():
    """step_difference(r, y) == step(r - y), bit for bit, and the state advances alike."""
    a = DiscreteFilter.from_tf(OuterLoopDesign().filter_tf(), 1e-3, 6)
    b = DiscreteFilter.from_tf(OuterLoopDesign().filter_tf(), 1e-3, 6)
    rng = np.random.default_rng(SEED + 9)
    for _ in range(300):
        r, y = rng.normal(size=6), rng.normal(size=6)
        np.testing.assert_array_equal(a.step_difference(r, y), b.step(r - y))
        np.testing.assert_array_equal(a.state, b.state)
    np.testing.assert_array_equal(a.step_difference([1.0] * 6, np.zeros(6)), b.step(np.ones(6)))  # a list


@pytest.mark.parametrize("name", ["zed2-paper", "pinhole", "normalized"])
def test_interaction_matrix_equals_points_interaction_matrix_bit_for_bit(name):
    camera = CAMERAS[name]
    params, lens_x = camera_parameters(camera)
    rng = np.random.default_rng(SEED + 10)
    for i in range(2000):
        P_C = rng.normal(0.0, 1.0, (3 + i % 3, 3))
        allow_behind = bool(i % 2)
        try:
            expected = points_interaction_matrix(camera, P_C, allow_behind)
        except PointBehindCameraError:
            assert interaction_matrix(P_C, params, lens_x, allow_behind)[1] >= 0
            continue
        L, bad = interaction_matrix(P_C, params, lens_x, allow_behind)
        assert bad == -1
        np.testing.assert_array_equal(L, expected)


def test_current_interaction_equals_its_reference():
    """CurrentInteraction(task, rows)(features) == current_interaction_matrix(task, features, rows)."""
    from ibvs_youla.analysis import suites
    from ibvs_youla.controllers.base import ServoTask
    from ibvs_youla.controllers.image_points import (
        CurrentInteraction,
        current_interaction_matrix,
        feature_rows,
    )
    from ibvs_youla.simulation.sensor import MarkerSensor

    rng = np.random.default_rng(SEED + 11)
    square = suites.SQUARE_O
    for camera, P_O, allow_behind in (
        (PinholeCamera.normalized(), square, False),
        (StereoCamera.zed2(), square + np.array([0.0, 0.0, 2.0]), True),
    ):
        task = ServoTask(
            camera,
            P_O,
            np.zeros(P_O.size // 3 * (3 if isinstance(camera, StereoCamera) else 2)),
            np.eye(4),
            0.04,
            0.04,
            virtual_points=allow_behind,
        )
        rows = feature_rows(task, "test")
        fast, sensor = CurrentInteraction(task, rows), MarkerSensor(camera, P_O, virtual_points=allow_behind)
        for k in range(50):
            T = np.eye(4)
            T[:3, 3] = rng.normal(0.0, 0.05, 3) + ([0.0, 0.0, -0.75] if rows == 2 else 0.0)
            if k % 2:  # turned views too: the monocular depths' arithmetic shows with a rotation
                T[:3, :3] = Rotation.from_rotvec(rng.normal(0.0, 0.2, 3)).as_matrix()
            features = sensor.features_at(T)
            np.testing.assert_array_equal(fast(features), current_interaction_matrix(task, features, rows))


def test_add_product_is_numpy_a_plus_b_times_c():
    from ibvs_youla._linalg import add_product

    rng = np.random.default_rng(SEED + 12)
    for _ in range(500):
        a, b, c = rng.normal(size=(3, 6)) * rng.choice([1e-8, 1.0, 1e8], (3, 6))
        expected = a + b * c
        add_product(a, b, c)
        np.testing.assert_array_equal(a, expected)


def test_poses_match_is_the_largest_entry_difference_test():
    from ibvs_youla.model.ik_kernels import poses_match

    rng = np.random.default_rng(SEED + 13)
    for _ in range(2000):
        T = random_pose(rng)
        d = rng.normal(0.0, 1e-9, (4, 4)) * (rng.random((4, 4)) < 0.3)
        assert poses_match(T + d, T, 1e-9) == bool(np.abs((T + d) - T).max() <= 1e-9)
    T = random_pose(rng)
    T2 = T.copy()
    T2[1, 2] = np.nan
    assert not poses_match(T2, T, 1e-9) and poses_match(T, T, 0.0)


def test_theta_u_compiled_is_scipy_from_matrix_as_rotvec_bit_for_bit():
    from scipy.spatial.transform import Rotation

    from ibvs_youla.controllers.pbvs import theta_u
    from ibvs_youla.model.rotation_kernels import theta_u_compiled

    rng = np.random.default_rng(SEED + 14)
    mats = list(Rotation.random(4000, rng=rng).as_matrix())
    for angle in (0.0, 1e-12, 1e-6, 9.99e-4, 1e-3, 1.001e-3, 0.5, 3.0, np.pi - 1e-7, np.pi):  # both branches
        axes = rng.normal(size=(60, 3))
        mats += list(Rotation.from_rotvec(angle * axes / np.linalg.norm(axes, axis=1)[:, None]).as_matrix())
    mats += [np.diag(d) for d in ([1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0], [1.0, 1.0, 1.0])]
    for _ in range(1000):  # products: orthogonal to the last bits only, as a PnP's R
        A, B = Rotation.random(2, rng=rng).as_matrix()
        mats.append(A.T @ B @ A @ B.T @ A)
    out, compiled = np.empty(3), 0
    for R in mats:
        expected = Rotation.from_matrix(R).as_rotvec()
        assert theta_u_compiled(R, out)
        np.testing.assert_array_equal(out, expected)
        np.testing.assert_array_equal(theta_u(R), expected)
        compiled += 1
    assert compiled == len(mats) > 5000
    # what scipy orthogonalizes (or refuses) is left to scipy: the kernel declines it
    for scale in (1e-11, 1e-6):
        R = Rotation.random(rng=rng).as_matrix() + rng.normal(scale=scale, size=(3, 3))
        assert not theta_u_compiled(R, out)
        np.testing.assert_array_equal(theta_u(R), Rotation.from_matrix(R).as_rotvec())
    for bad in (np.diag([1.0, 1.0, -1.0]), np.full((3, 3), np.nan)):
        assert not theta_u_compiled(bad, out)
        with pytest.raises(ValueError), np.errstate(invalid="ignore"):
            theta_u(bad)


def test_pseudo_inverse_integrate_is_pseudo_inverse_apply_then_numpys_integration():
    """y bit for bit that of pseudo_inverse_apply, q_next the floats of numpy's q_prev + dt * y."""
    policy = SingularValuePolicy()
    rng = np.random.default_rng(SEED + 15)
    for rank in (6, 5, 3):
        for _ in range(300):
            J = rng.normal(size=(6, rank)) @ rng.normal(size=(rank, 6))
            x, q_prev = rng.normal(size=6), rng.normal(size=6) * 3.0
            dt = float(rng.choice([1e-3, 4e-2, 0.1 * rng.random()]))
            y_ref, y, q_next = np.empty(6), np.empty(6), np.empty(6)
            assert pseudo_inverse_apply(J, x, True, policy.threshold, y_ref)
            assert pseudo_inverse_integrate(J, x, True, policy.threshold, q_prev, dt, y, q_next)
            np.testing.assert_array_equal(y, y_ref)
            np.testing.assert_array_equal(q_next, q_prev + dt * y_ref)
    q_next = np.full(6, 7.0)
    zero = np.zeros((6, 6))
    assert not pseudo_inverse_integrate(zero, np.ones(6), True, 1e-3, np.zeros(6), 1e-3, np.empty(6), q_next)
    np.testing.assert_array_equal(q_next, 7.0)  # not written when the reference must run


def test_twist_chain_integrating_in_the_compiled_call_gives_the_adapters_commands(arm):
    """TwistToJointVelocity.integrate_into: the same dq_ref and q_ref, tick after tick, as the two
    links apart; a VelocityToPosition called with another array integrates that one."""
    from ibvs_youla.controllers.base import JointReading
    from ibvs_youla.simulation.actuation import TwistToJointVelocity, VelocityToPosition

    rng = np.random.default_rng(SEED + 16)
    q0 = np.array([0.1, -0.3, 0.4, 0.2, 0.7, -0.1])
    plain_tw, plain_int = TwistToJointVelocity(arm), VelocityToPosition(q0, 1e-3)
    fused_tw, fused_int = TwistToJointVelocity(arm), VelocityToPosition(q0, 1e-3)
    fused_tw.integrate_into(fused_int)
    for k in range(300):
        reading = JointReading(k * 1e-3, q0 + rng.normal(0.0, 0.2, 6), rng.normal(size=6))
        twist = rng.normal(0.0, 0.1, 6)
        dq_plain, dq_fused = plain_tw(twist, reading), fused_tw(twist, reading)
        np.testing.assert_array_equal(dq_fused, dq_plain)
        if k % 50 == 7:  # not the array it integrated: integrated here, from the same reference
            other = rng.normal(size=6)
            np.testing.assert_array_equal(fused_int(other, reading), plain_int(other, reading))
            continue
        np.testing.assert_array_equal(fused_int(dq_fused, reading), plain_int(dq_plain, reading))
