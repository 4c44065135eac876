"""Compiled frame kernels of polar IBVS: the law, the sample and the plant's step in one call.

The compiled frame path of :class:`~ibvs_youla.controllers.polar.PolarIBVS`
(:mod:`.compiled_polar_loop`): after the sensor (:func:`~.frame_kernels.measure`) and, on a monocular
camera without measured depths, the believed markers' depths in the controller's own pose estimate
(written into the frame in Python, as for classical IBVS), one compiled call does the rest of the
frame:

* :func:`polar_twist`: the points back-projected at the frame's depths (measured or from the pose)
  or triangulated (stereo), their interaction rows
  (:func:`~ibvs_youla.model.camera_kernels.interaction_matrix`, the kernel the controller's
  :class:`~ibvs_youla.controllers.image_points.CurrentInteraction` calls), each lens's normalized
  points and rows (``polar.lens_points``, ``polar.lens_rows``), the
  polar features and L_(r,phi) (``polar.polar_features``, ``polar.polar_interaction_matrix``), the
  error with its phi errors wrapped (``polar.polar_error``: ``"joint"`` or ``"per-point"``) and
  v = -lambda L^+ e, the SVD and gains of ``SingularValuePolicy.svd_gains`` (the same compiled
  call, so the same floats) and the pseudo-inverse formed then applied, as the update;
* then what follows any law that gives a camera twist (:mod:`.frame_kernels`): on the free camera
  :func:`~.frame_kernels.camera_step`, on the kinematic arm :func:`~.frame_kernels.joint_step`
  every tick. The law records no signal of its own (``camera_twist`` alone): the sample's last part
  is empty.

The controller's update computes sin, cos, atan2 and the products in numpy, these kernels in
compiled code: equal to rounding (``tests/test_compiled_polar.py``: 1e-12), except where a rounding
decides: the phi error's wrap. numpy's arctan2 and the kernel's atan2 differ in the last bit on a few
% of inputs, so a phi error within 1e-9 rad of the cut (+-pi), or a joint mean on it, may wrap to
the other side; there the kernel declines and the reference decides. Like :mod:`.frame_kernels`,
they do not validate and never raise: where the update would raise (a point at the principal point,
a depth or disparity the reference rejects, a failed SVD) or give a non-finite twist, they return
:data:`~.frame_kernels.DECLINED`, and the caller runs the plug-in loop.

Layouts: ``law`` (2 k n,) is the target's polar features s*; ``settings`` (4,) is (lambda [1/s],
wrap (0 ``"joint"``, 1 ``"per-point"``), F of the believed camera, rows per point (2 or 3)).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit
from ..control.svd_kernels import svd_gains
from ..model.camera_kernels import interaction_matrix, triangulate
from .frame_kernels import (
    _BELIEF,
    _BELIEF_LENS,
    _DEPTH_FROM,
    _N_LENS_BELIEF,
    _PINV_THRESHOLD,
    _VIRTUAL,
    DECLINED,
    DEPTH_TRIANGULATED,
    camera_step,
    finite,
    joint_step,
    record_frame,
    tick_time,
)

__all__ = ["polar_free_camera_step", "polar_kinematic_tick", "polar_twist"]

_GAIN, _WRAP, _FOCAL, _ROWS = 0, 1, 2, 3  # settings
_MIN_RADIUS = 1e-12  # polar.MIN_RADIUS
_PER_POINT = 1.0
# A phi error within this of the wrap's cut (+-pi) is the reference's to wrap: the kernel's atan2 (libm)
# and numpy's arctan2 (SIMD) differ in the last bit on a few % of inputs, which may wrap it the other way
_CUT_MARGIN = 1e-9  # [rad]
_MAX_SUMMED = 128  # _numpy_sum is numpy's sum up to 128 entries (its pairwise leaf); more: the reference


@jit
def _wrapped(a: float) -> float:
    """``polar._wrapped``: a into [-pi, pi) (``np.mod``: fmod, then the divisor's sign, as numpy's)."""
    return np.mod(a + math.pi, 2.0 * math.pi) - math.pi  # type: ignore[no-any-return]


@jit
def _numpy_sum(x: np.ndarray) -> float:
    """numpy's ``x.sum()`` (its pairwise sum's leaf) of a float64 vector of up to 128 entries."""  # noqa: D403
    k = x.shape[0]
    if k < 8:
        acc = 0.0
        for i in range(k):
            acc += x[i]
        return acc
    r = np.empty(8)
    for j in range(8):
        r[j] = x[j]
    i = 8
    while i < k - (k % 8):
        for j in range(8):
            r[j] += x[i + j]
        i += 8
    acc = (r[0] + r[1]) + (r[2] + r[3]) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < k:
        acc += x[i]
        i += 1
    return acc


@jit
def polar_twist(
    frame: np.ndarray,
    n: int,
    m: int,
    law: np.ndarray,
    params: np.ndarray,
    settings: np.ndarray,
    twist: np.ndarray,
) -> bool:
    """The law v = -lambda L_(r,phi)^+ e into ``twist`` (6,) (module docstring); False: declined."""
    allow_behind = params[_VIRTUAL] != 0.0
    cam = params[_BELIEF : _BELIEF + 12]
    k = int(params[_N_LENS_BELIEF])
    F = cam[0]
    if int(params[_DEPTH_FROM]) == DEPTH_TRIANGULATED:
        P, bad = triangulate(frame[:m], cam, allow_behind)
        if bad >= 0:
            return False
    else:
        P = np.empty((n, 3))
        per = m // n
        for i in range(n):  # points_at_depths
            Z = frame[m + n + i]
            u = 0.5 * (frame[per * i] + frame[per * i + 1]) if per == 3 else frame[per * i]
            s = Z / F
            P[i, 0], P[i, 1], P[i, 2] = u * s, frame[per * i + per - 1] * s, Z
    L_points, bad = interaction_matrix(P, cam, params[_BELIEF_LENS : _BELIEF_LENS + k], allow_behind)
    if bad >= 0:
        return False
    rows, f = int(settings[_ROWS]), settings[_FOCAL]
    count = n if rows == 2 else 2 * n  # image points, one per lens
    x, y = np.empty(count), np.empty(count)
    L_x, L_y = np.empty((count, 6)), np.empty((count, 6))
    for i in range(n):  # lens_points, lens_rows
        if rows == 2:
            x[i], y[i] = frame[2 * i] / f, frame[2 * i + 1] / f
            for j in range(6):
                L_x[i, j] = L_points[2 * i, j] / f
                L_y[i, j] = L_points[2 * i + 1, j] / f
        else:
            v = frame[3 * i + 2] / f
            for lens in range(2):
                p = 2 * i + lens
                x[p], y[p] = frame[3 * i + lens] / f, v
                for j in range(6):
                    L_x[p, j] = L_points[3 * i + lens, j] / f
                    L_y[p, j] = L_points[3 * i + 2, j] / f
    L = np.empty((2 * count, 6))
    e = np.empty(2 * count)
    d = np.empty(count)
    for p in range(count):  # polar_features, polar_interaction_matrix
        r = math.hypot(x[p], y[p])
        if not r >= _MIN_RADIUS:
            return False  # the update raises FeatureSingularityError
        phi = math.atan2(y[p], x[p])
        c, sn = math.cos(phi), math.sin(phi)
        for j in range(6):
            L[2 * p, j] = c * L_x[p, j] + sn * L_y[p, j]
            L[2 * p + 1, j] = (c * L_y[p, j] - sn * L_x[p, j]) / r
        e[2 * p] = r - law[2 * p]
        d[p] = phi - law[2 * p + 1]
    if settings[_WRAP] == _PER_POINT:  # polar_error
        for p in range(count):
            w = _wrapped(d[p])
            if abs(abs(w) - math.pi) < _CUT_MARGIN:
                return False  # on the cut: the reference decides the side
            e[2 * p + 1] = w
    else:
        if count > _MAX_SUMMED:
            return False
        sines, cosines = np.empty(count), np.empty(count)
        for p in range(count):
            sines[p], cosines[p] = math.sin(d[p]), math.cos(d[p])
        S, C = _numpy_sum(sines), _numpy_sum(cosines)
        if abs(S) < _CUT_MARGIN * count and C < 0.0:
            return False  # the mean itself on the cut: its sign is the reference's rounding
        mean = math.atan2(S, C)
        for p in range(count):
            w = _wrapped(d[p] - mean)
            if abs(abs(w) - math.pi) < _CUT_MARGIN:
                return False
            e[2 * p + 1] = mean + w
    U, _, g, Vt, ok = svd_gains(L, False, params[_PINV_THRESHOLD])
    if not ok:
        return False
    kk, M = g.shape[0], L.shape[0]
    lam = settings[_GAIN]
    for j in range(6):  # (V diag(g) U^T) e, the pseudo-inverse formed first (the reference's order)
        acc = 0.0
        for r_ in range(M):
            q = 0.0
            for i in range(kk):
                q += Vt[i, j] * g[i] * U[r_, i]
            acc += q * e[r_]
        twist[j] = -lam * acc
    return finite(twist)


@jit
def polar_free_camera_step(
    k: int,
    T_O_C: np.ndarray,
    n: int,
    m: int,
    law: np.ndarray,
    settings: np.ndarray,
    params: np.ndarray,
    frame: np.ndarray,
    twist: np.ndarray,
    table: np.ndarray,
    row: int,
    sizes: np.ndarray,
    frames: np.ndarray,
) -> int:
    """Frame k of polar IBVS on the free camera after the frame is measured; the next row or DECLINED.

    :func:`polar_twist`, then :func:`~.frame_kernels.camera_step` at the true pose ``T_O_C``, which
    it advances (``sizes`` ends with an empty part: the law records no signal of its own).
    """
    if not polar_twist(frame, n, m, law, params, settings, twist):
        return DECLINED
    return camera_step(k, T_O_C, frame, m, n, params, twist, np.empty(0), table, row, sizes, frames)  # type: ignore[no-any-return]


@jit
def polar_kinematic_tick(
    k: int,
    is_frame: bool,
    T_O_C: np.ndarray,
    J_C: np.ndarray,
    state: np.ndarray,
    n: int,
    m: int,
    law: np.ndarray,
    settings: np.ndarray,
    params: np.ndarray,
    frame: np.ndarray,
    twist: np.ndarray,
    table: np.ndarray,
    row: int,
    sizes: np.ndarray,
    frames: np.ndarray,
    frame_index: int,
) -> int:
    """Tick k of polar IBVS on the kinematic arm; returns the next free table row, or DECLINED.

    On a frame tick (``is_frame``; ``frame`` measured) :func:`polar_twist`, the frame logged at
    ``frame_index``; then every tick :func:`~.frame_kernels.joint_step` with the twist held.
    """
    if is_frame:
        if not polar_twist(frame, n, m, law, params, settings, twist):
            return DECLINED
        record_frame(frames, frame_index, tick_time(k, params), frame, n)
    return joint_step(k, T_O_C, J_C, state, frame, m, n, params, twist, np.empty(0), table, row, sizes)  # type: ignore[no-any-return]
