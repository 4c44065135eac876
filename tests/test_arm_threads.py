"""One Arm shared by threads and shipped to other processes: per-thread Pinocchio data, pickling."""

from __future__ import annotations

import copy
import pickle
import sys
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from ibvs_youla.model._resources import example_robot_data_urdf
from ibvs_youla.model.arm import Arm

SEED = 4600
N_THREADS = 4
N_CONFIGURATIONS = 2000  # per thread; each thread walks the same list from its own offset


@pytest.fixture
def fast_thread_switching():
    """Switch threads every ~1 us instead of 5 ms so a race between two Pinocchio calls shows up."""
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    yield
    sys.setswitchinterval(interval)


def random_q(arm: Arm, rng: np.random.Generator, n: int) -> np.ndarray:
    return arm.q_min + (arm.q_max - arm.q_min) * rng.random((n, arm.nq))


def _run_in_threads(work, n_threads: int) -> list:
    """``work(k)`` for k = 0..n_threads-1, started together behind a barrier; results in order."""
    barrier = threading.Barrier(n_threads)

    def start(k: int):
        barrier.wait()
        return work(k)

    with ThreadPoolExecutor(n_threads) as pool:
        return list(pool.map(start, range(n_threads)))


def test_threads_sharing_one_arm_get_the_single_threaded_results(arm, fast_thread_switching):
    """camera_pose, the pose+Jacobian pass and forward dynamics agree bit for bit with one thread."""
    rng = np.random.default_rng(SEED)
    qs = random_q(arm, rng, N_CONFIGURATIONS)
    dqs = rng.uniform(-1.0, 1.0, qs.shape)
    taus = rng.uniform(-100.0, 100.0, qs.shape)
    poses = np.array([arm.camera_pose(q) for q in qs])
    jacobians = np.array([arm.camera_pose_and_jacobian(q)[1] for q in qs])
    ddqs = np.array([arm.aba(q, dq, tau) for q, dq, tau in zip(qs, dqs, taus, strict=True)])

    def work(k: int) -> int:
        mismatches = 0
        for i in np.roll(np.arange(N_CONFIGURATIONS), k * N_CONFIGURATIONS // N_THREADS):
            T_O_C, J_C = arm.camera_pose_and_jacobian(qs[i])
            mismatches += not np.array_equal(arm.camera_pose(qs[i]), poses[i])
            mismatches += not (np.array_equal(T_O_C, poses[i]) and np.array_equal(J_C, jacobians[i]))
            mismatches += not np.array_equal(arm.aba(qs[i], dqs[i], taus[i]), ddqs[i])
        return mismatches

    assert _run_in_threads(work, N_THREADS) == [0] * N_THREADS


def test_each_thread_gets_its_own_pinocchio_data(arm):
    """The main thread's data is not the one a second thread computes in."""
    main = arm._thread_data.data
    assert arm._thread_data.data is main  # created once per thread, then reused
    other = _run_in_threads(lambda _: arm._thread_data.data, 1)[0]
    assert other is not main


def _pickled(arm: Arm) -> Arm:
    return pickle.loads(pickle.dumps(arm))


@pytest.mark.parametrize("clone", [_pickled, copy.deepcopy], ids=["pickle", "deepcopy"])
def test_a_copied_arm_behaves_identically(arm, clone):
    """What a Dask worker receives: same kinematics, dynamics and IK, bit for bit, same read-only arrays."""
    twin = clone(arm)
    assert twin.name == arm.name and twin.ik_parameters == arm.ik_parameters
    assert twin._thread_data.data is not arm._thread_data.data
    rng = np.random.default_rng(SEED + 1)
    for q in random_q(arm, rng, 20):
        np.testing.assert_array_equal(twin.camera_pose(q), arm.camera_pose(q))
        np.testing.assert_array_equal(twin.mass_matrix(q), arm.mass_matrix(q))
        T_O_C = arm.camera_pose(q)
        np.testing.assert_array_equal(twin.ik(T_O_C, q_near=q), arm.ik(T_O_C, q_near=q))
        np.testing.assert_array_equal(twin.ik_nearest(T_O_C, q), arm.ik_nearest(T_O_C, q))
    for name in ("q_min", "q_max", "dq_max", "tau_max", "armature", "damping", "T_E_C"):
        np.testing.assert_array_equal(getattr(twin, name), getattr(arm, name))
        assert not getattr(twin, name).flags.writeable, name


def test_a_copied_arm_without_closed_form_ik_behaves_identically():
    """The numerical IK path (no ik_parameters) also runs on the copy's own data."""
    ur5 = Arm.from_urdf(example_robot_data_urdf("ur_description/urdf/ur5_robot.urdf"), camera_frame="tool0")
    assert ur5.ik_parameters is None
    twin = pickle.loads(pickle.dumps(ur5))
    q = np.array([0.3, -1.2, 1.4, -0.7, 1.1, 0.4])
    T_O_C = ur5.camera_pose(q)
    np.testing.assert_array_equal(twin.ik(T_O_C, q_near=q), ur5.ik(T_O_C, q_near=q))
