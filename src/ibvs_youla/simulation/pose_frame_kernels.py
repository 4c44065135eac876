"""Compiled frame kernels of the pose-based laws: the law, the sample and the plant step of one frame.

PBVS, below, and 2.5-D visual servoing on its pose route
(:func:`two_half_d_free_camera_step`, :func:`two_half_d_kinematic_tick`: the same frame with
:func:`~ibvs_youla.controllers.two_half_d_kernels.pose_route_twist`, the law the controller's
update itself calls, :mod:`.compiled_two_half_d_loop`).

The compiled frame path of :class:`~ibvs_youla.controllers.pbvs.PBVS`
(:mod:`.compiled_pbvs_loop`): after the sensor (:func:`~.frame_kernels.measure`) and the
controller's own pose estimate T_O_C of the frame (its ``CameraPoseEstimator``, called from Python
as its update calls it), one compiled call does the rest of the frame:

* :func:`pbvs_twist`: the law of :mod:`~ibvs_youla.controllers.pbvs`, c*T_c = c*T_O T_O_C,
  e = (c*t_c, theta u) and v = -lambda c*R_c^T c*t_c, omega = -lambda theta u, theta u by
  :func:`~ibvs_youla.model.rotation_kernels.theta_u_compiled` (the reference's own floats);
* then what follows any law that gives a camera twist (:mod:`.frame_kernels`): on the free camera
  :func:`~.frame_kernels.camera_step` (the frame logged, the sample with ``servo_error``, the pose
  integrated by exp6), on the kinematic arm :func:`~.frame_kernels.joint_step` every tick.

The products run in the reference's order (the rows of c*T_O times the columns of T_O_C, then
R^T t), each sum in index order: the results equal the plug-in loop's to rounding
(``tests/test_compiled_pbvs.py``: 1e-12). Like :mod:`.frame_kernels`, they do not validate and never
raise: a rotation that ``theta_u_compiled`` leaves to scipy, one within 1e-9 rad of a half turn
(where theta u or -theta u is the choice of the matrix's last bits, which the reference's numpy
product and these sums may round differently), or a non-finite twist, returns
:data:`~.frame_kernels.DECLINED` and the caller runs the plug-in loop instead.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit
from ..controllers.two_half_d_kernels import pose_route_twist
from ..model.rotation_kernels import theta_u_compiled
from .frame_kernels import DECLINED, camera_step, finite, joint_step, record_frame, tick_time

__all__ = [
    "pbvs_free_camera_step",
    "pbvs_kinematic_tick",
    "pbvs_twist",
    "two_half_d_free_camera_step",
    "two_half_d_kinematic_tick",
]

# theta [rad] beyond which theta u's sign is a rounding of c*R_c (u and -u are one rotation at pi):
# the numpy product of the reference and the kernel's sums may choose differently, so the reference runs
_NEAR_HALF_TURN = math.pi - 1e-9


@jit
def pbvs_twist(
    T_target_O: np.ndarray, T_O_C: np.ndarray, gain: float, error: np.ndarray, twist: np.ndarray
) -> bool:
    """The PBVS law at the estimated pose T_O_C: e into ``error`` (6,), [v; omega] into ``twist`` (6,).

    c*T_c = c*T_O T_O_C (``T_target_O`` (4, 4), c*T_O); e = (c*t_c [m], theta u [rad]);
    v = -lambda c*R_c^T c*t_c, omega = -lambda theta u (``gain`` lambda [1/s]). False, with
    ``error`` and ``twist`` not to be used, when theta u is scipy's to compute (a matrix that is
    not clearly a rotation) or the twist is not finite.
    """
    T = np.empty((3, 4))  # the first three rows of c*T_c (the last is [0, 0, 0, 1])
    for r in range(3):
        for q in range(4):
            acc = 0.0
            for i in range(4):
                acc += T_target_O[r, i] * T_O_C[i, q]
            T[r, q] = acc
    R = np.ascontiguousarray(T[:, :3])
    tu = np.empty(3)
    if not theta_u_compiled(R, tu):
        return False
    if tu[0] * tu[0] + tu[1] * tu[1] + tu[2] * tu[2] > _NEAR_HALF_TURN**2:
        return False  # theta within 1e-9 rad of pi: u or -u is the last bits' choice, the reference's
    for j in range(3):
        acc = 0.0
        for i in range(3):  # (R^T t)_j
            acc += R[i, j] * T[i, 3]
        error[j], error[3 + j] = T[j, 3], tu[j]
        twist[j], twist[3 + j] = -gain * acc, -gain * tu[j]
    return finite(twist)  # type: ignore[no-any-return]


@jit
def pbvs_free_camera_step(
    k: int,
    T_O_C: np.ndarray,
    T_O_C_estimate: np.ndarray,
    T_target_O: np.ndarray,
    gain: float,
    m: int,
    n: int,
    params: np.ndarray,
    frame: np.ndarray,
    twist: np.ndarray,
    error: np.ndarray,
    table: np.ndarray,
    row: int,
    sizes: np.ndarray,
    frames: np.ndarray,
) -> int:
    """Frame k of PBVS on the free camera after the frame and its pose estimate; the next row or DECLINED.

    The law (:func:`pbvs_twist`) at ``T_O_C_estimate``, then :func:`~.frame_kernels.camera_step`
    at the true pose ``T_O_C`` (the sample: twist, then e as ``servo_error``), which it advances.
    """
    if not pbvs_twist(T_target_O, T_O_C_estimate, gain, error, twist):
        return DECLINED  # the plug-in loop decides (scipy's theta u, or its error)
    return camera_step(k, T_O_C, frame, m, n, params, twist, error, table, row, sizes, frames)  # type: ignore[no-any-return]


@jit
def pbvs_kinematic_tick(
    k: int,
    is_frame: bool,
    T_O_C: np.ndarray,
    J_C: np.ndarray,
    state: np.ndarray,
    T_O_C_estimate: np.ndarray,
    T_target_O: np.ndarray,
    gain: float,
    m: int,
    n: int,
    params: np.ndarray,
    frame: np.ndarray,
    twist: np.ndarray,
    error: np.ndarray,
    table: np.ndarray,
    row: int,
    sizes: np.ndarray,
    frames: np.ndarray,
    frame_index: int,
) -> int:
    """Tick k of PBVS on the kinematic arm; returns the next free table row, or DECLINED.

    On a frame tick (``is_frame``; ``frame`` measured and ``T_O_C_estimate`` its pose estimate) the
    law into ``twist`` and ``error``, the frame logged at ``frame_index``; then every tick
    :func:`~.frame_kernels.joint_step` with the twist held (``state`` and J_C as there; the sample
    ends with e as ``servo_error``).
    """
    if is_frame:
        if not pbvs_twist(T_target_O, T_O_C_estimate, gain, error, twist):
            return DECLINED
        record_frame(frames, frame_index, tick_time(k, params), frame, n)
    return joint_step(k, T_O_C, J_C, state, frame, m, n, params, twist, error, table, row, sizes)  # type: ignore[no-any-return]


@jit
def two_half_d_free_camera_step(
    k: int,
    T_O_C: np.ndarray,
    T_O_C_estimate: np.ndarray,
    T_target_O: np.ndarray,
    reference_O: np.ndarray,
    law: np.ndarray,
    m: int,
    n: int,
    params: np.ndarray,
    frame: np.ndarray,
    twist: np.ndarray,
    error: np.ndarray,
    table: np.ndarray,
    row: int,
    sizes: np.ndarray,
    frames: np.ndarray,
) -> int:
    """Frame k of 2.5-D VS (pose route) on the free camera after the frame and its pose estimate.

    The law (:func:`~ibvs_youla.controllers.two_half_d_kernels.pose_route_twist`, the controller's
    own) at ``T_O_C_estimate`` on the frame's features, then :func:`~.frame_kernels.camera_step` at
    the true pose ``T_O_C`` (the sample: twist, then e as ``servo_error``); the next row, or
    DECLINED where the controller's update computes in numpy (a point behind the camera, scipy's
    theta u) or the twist is not finite.
    """
    if not pose_route_twist(T_O_C_estimate, T_target_O, reference_O, law, frame[:m], twist, error):
        return DECLINED
    if not finite(twist):
        return DECLINED
    return camera_step(k, T_O_C, frame, m, n, params, twist, error, table, row, sizes, frames)  # type: ignore[no-any-return]


@jit
def two_half_d_kinematic_tick(
    k: int,
    is_frame: bool,
    T_O_C: np.ndarray,
    J_C: np.ndarray,
    state: np.ndarray,
    T_O_C_estimate: np.ndarray,
    T_target_O: np.ndarray,
    reference_O: np.ndarray,
    law: np.ndarray,
    m: int,
    n: int,
    params: np.ndarray,
    frame: np.ndarray,
    twist: np.ndarray,
    error: np.ndarray,
    table: np.ndarray,
    row: int,
    sizes: np.ndarray,
    frames: np.ndarray,
    frame_index: int,
) -> int:
    """Tick k of 2.5-D VS (pose route) on the kinematic arm, as :func:`pbvs_kinematic_tick` with its law."""
    if is_frame:
        if not pose_route_twist(T_O_C_estimate, T_target_O, reference_O, law, frame[:m], twist, error):
            return DECLINED
        if not finite(twist):
            return DECLINED
        record_frame(frames, frame_index, tick_time(k, params), frame, n)
    return joint_step(k, T_O_C, J_C, state, frame, m, n, params, twist, error, table, row, sizes)  # type: ignore[no-any-return]
