"""Compiled frame kernels of the hybrid switched law: both laws, the switch, the sample, the step: one call.

The compiled frame path of :class:`~ibvs_youla.controllers.hybrid.HybridSwitched`
(:mod:`.compiled_hybrid_loop`): after the sensor (:func:`~.frame_kernels.measure`) and, in Python,
the inputs both laws take from the controller's own pose estimator (the frame's pose T_O_C and, on a
monocular camera without measured depths, the believed markers' depths in it), one compiled call
does the rest of the frame:

* :func:`hybrid_twist`: classical IBVS with L at the current features
  (:func:`~.frame_kernels.ibvs_twist`, Chaumette & Hutchinson 2006, Eq. (5)) and PBVS at the
  estimated pose (:func:`~.pose_frame_kernels.pbvs_twist`), both on every frame as the controller's
  update runs them; their Lyapunov functions V_i = 1/2 ||(s - s*) / F||^2 and
  V_p = 1/2 ||(c*t_c, theta u)||^2 (:meth:`~ibvs_youla.controllers.hybrid.HybridSwitched.lyapunov`),
  the bounds (1 + margin) V(0) at the first frame, the dwell and the switching rule of
  :mod:`~ibvs_youla.controllers.hybrid`, and the active law's twist;
* then what follows any law that gives a camera twist (:mod:`.frame_kernels`): on the free camera
  :func:`~.frame_kernels.camera_step`, on the kinematic arm :func:`~.frame_kernels.joint_step`
  every tick, the sample ending with ``hybrid_mode`` and ``hybrid_switches``.

V_i and V_p decide the switches, so they are the reference's floats, not merely close: the squared
norms (:func:`squared_norm`) are ``np.dot`` of a vector with itself, which calls BLAS ``ddot`` as
numpy's ``e @ e`` does. They are two OpenBLAS builds (numpy's, and scipy's, which Numba calls
through ``cython_blas``), equal to the bit today on 20,000 random vectors of 1 to 40 entries, where
a sum in index order differs on a quarter of them: an agreement of the builds, not a guarantee, so
``tests/test_compiled_hybrid.py`` pins it (2,000 vectors) and fails first if a new build breaks it.
The laws' twists equal the plug-in loop's to
rounding (``tests/test_compiled_hybrid.py``). Like :mod:`.frame_kernels`, the kernels do not
validate and never raise: where either law's reference would raise or give a non-finite twist
(or theta u is scipy's to compute) they return :data:`~.frame_kernels.DECLINED`, and the caller
runs the plug-in loop instead.

Layouts: ``settings`` (4,) is (lambda of PBVS [1/s], F of the believed camera, margin, min_dwell
[frames]); ``state`` (5,) is (mode (0 IBVS, 1 PBVS), switches, frames since the last switch,
gamma_i, gamma_p), its first two entries the recorded signals ``hybrid_mode`` and
``hybrid_switches``.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit
from .frame_kernels import DECLINED, camera_step, finite, ibvs_twist, joint_step, record_frame, tick_time
from .pose_frame_kernels import pbvs_twist

__all__ = ["hybrid_free_camera_step", "hybrid_kinematic_tick", "hybrid_twist", "squared_norm"]

_PBVS_GAIN, _FOCAL, _MARGIN, _MIN_DWELL = 0, 1, 2, 3  # settings
_MODE, _SWITCHES, _DWELL, _GAMMA_I, _GAMMA_P = 0, 1, 2, 3, 4  # state


@jit
def squared_norm(x: np.ndarray) -> float:
    """||x||^2 of a contiguous float64 vector, numpy's ``x @ x`` (BLAS ``ddot``: module docstring)."""
    return np.dot(x, x)  # type: ignore[no-any-return]


@jit
def hybrid_twist(
    frame: np.ndarray,
    n: int,
    law: np.ndarray,
    params: np.ndarray,
    T_target_O: np.ndarray,
    T_O_C_estimate: np.ndarray,
    settings: np.ndarray,
    first: bool,
    state: np.ndarray,
    error: np.ndarray,
    twist: np.ndarray,
) -> bool:
    """Both laws on the frame, the switch, and the active law's twist into ``twist`` (6,).

    IBVS on ``frame`` (``law`` and ``params`` as :func:`~.frame_kernels.ibvs_twist`'s, its depths in
    the frame), PBVS at ``T_O_C_estimate`` (e into ``error`` (6,)); V_i and V_p; on the ``first``
    frame the bounds; then, as the controller's update: one more frame in the mode, and after
    ``min_dwell`` of them a switch to PBVS when V_p >= gamma_p and V_p > 0 (in IBVS mode), to IBVS
    when V_i >= gamma_i and V_i > 0 (in PBVS mode). ``state`` and ``settings`` as the module
    docstring's. False, with nothing to be used, where either law declines (module docstring).
    """
    v_ibvs, v_pbvs = np.empty(6), np.empty(6)
    lam = ibvs_twist(frame, n, law, params, v_ibvs)
    if not (math.isfinite(lam) and finite(v_ibvs)):
        return False
    if not pbvs_twist(T_target_O, T_O_C_estimate, settings[_PBVS_GAIN], error, v_pbvs):
        return False
    m = law.shape[0]
    e_image = np.empty(m)  # (s - s*) / F
    for r in range(m):
        e_image[r] = (frame[r] - law[r, 0]) / settings[_FOCAL]
    V_i = 0.5 * squared_norm(e_image)
    V_p = 0.5 * squared_norm(error)
    if first:
        state[_GAMMA_I] = (1.0 + settings[_MARGIN]) * V_i
        state[_GAMMA_P] = (1.0 + settings[_MARGIN]) * V_p
    state[_DWELL] += 1.0
    if state[_DWELL] >= settings[_MIN_DWELL]:
        mode = state[_MODE]
        if (mode == 0.0 and V_p >= state[_GAMMA_P] and V_p > 0.0) or (
            mode == 1.0 and V_i >= state[_GAMMA_I] and V_i > 0.0
        ):
            state[_MODE] = 1.0 - mode
            state[_DWELL] = 0.0
            state[_SWITCHES] += 1.0
    active = v_ibvs if state[_MODE] == 0.0 else v_pbvs
    for j in range(6):
        twist[j] = active[j]
    return True


@jit
def hybrid_free_camera_step(
    k: int,
    T_O_C: np.ndarray,
    T_O_C_estimate: np.ndarray,
    T_target_O: np.ndarray,
    settings: np.ndarray,
    n: int,
    law: np.ndarray,
    params: np.ndarray,
    frame: np.ndarray,
    twist: np.ndarray,
    error: np.ndarray,
    state: np.ndarray,
    table: np.ndarray,
    row: int,
    sizes: np.ndarray,
    frames: np.ndarray,
) -> int:
    """Frame k of the hybrid law on the free camera after the frame and its pose; the next row or DECLINED.

    :func:`hybrid_twist` (the bounds at k = 0), then :func:`~.frame_kernels.camera_step` at the true
    pose ``T_O_C``, which it advances; the sample ends with ``state[:2]`` (``hybrid_mode``,
    ``hybrid_switches``: ``sizes`` gives them as one part of size 2).
    """
    if not hybrid_twist(
        frame, n, law, params, T_target_O, T_O_C_estimate, settings, k == 0, state, error, twist
    ):
        return DECLINED  # the plug-in loop decides (either law's error, scipy's theta u)
    m = law.shape[0]
    return camera_step(k, T_O_C, frame, m, n, params, twist, state[:2], table, row, sizes, frames)  # type: ignore[no-any-return]


@jit
def hybrid_kinematic_tick(
    k: int,
    is_frame: bool,
    T_O_C: np.ndarray,
    J_C: np.ndarray,
    state_arm: np.ndarray,
    T_O_C_estimate: np.ndarray,
    T_target_O: np.ndarray,
    settings: np.ndarray,
    n: int,
    law: np.ndarray,
    params: np.ndarray,
    frame: np.ndarray,
    twist: np.ndarray,
    error: np.ndarray,
    state: np.ndarray,
    table: np.ndarray,
    row: int,
    sizes: np.ndarray,
    frames: np.ndarray,
    frame_index: int,
) -> int:
    """Tick k of the hybrid law on the kinematic arm; returns the next free table row, or DECLINED.

    On a frame tick (``is_frame``; ``frame`` measured and ``T_O_C_estimate`` its pose) :func:`hybrid_twist`
    (the bounds at the first frame), the frame logged at ``frame_index``; then every tick
    :func:`~.frame_kernels.joint_step` with the twist held (``state_arm`` and J_C as there; the
    sample ends with ``state[:2]`` as :func:`hybrid_free_camera_step`'s).
    """
    m = law.shape[0]
    if is_frame:
        first = frame_index == 0
        if not hybrid_twist(
            frame, n, law, params, T_target_O, T_O_C_estimate, settings, first, state, error, twist
        ):
            return DECLINED
        record_frame(frames, frame_index, tick_time(k, params), frame, n)
    return joint_step(k, T_O_C, J_C, state_arm, frame, m, n, params, twist, state[:2], table, row, sizes)  # type: ignore[no-any-return]
