"""Compiled nearest-branch closed-form IK: the inverse-kinematics step of Eq. (62) in one call.

:func:`nearest_branch_compiled` is the Numba-compiled twin (:func:`ibvs_youla._jit.jit`) of
:func:`ibvs_youla.model.ik.nearest_branch` (the shoulder, elbow and wrist steps of
:mod:`ibvs_youla.model._ik_closed_form` and the branch choice of :mod:`ibvs_youla.model._ik_nearest`),
step for step: the same branches in the same order, the same 2*pi-equivalent rule, the same
early give-up and the same tie-breaking. The arm's lengths come packed by
:func:`ik_parameter_array`. Unvalidated; ``tests/test_compiled_kernels.py`` pins it to the
reference.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit
from ._ik_closed_form import SINGULAR_TOL, SphericalWristParameters

__all__ = ["ik_parameter_array", "nearest_branch_compiled", "nearest_row_compiled", "poses_match"]

_PI, _TAU = math.pi, math.tau


def ik_parameter_array(params: SphericalWristParameters) -> np.ndarray:
    """``[d1, a1, a2, a3, d4, d6, L, beta, 2 a2 L, a2^2]`` [m, rad]: the lengths and the elbow constants."""
    L = math.hypot(params.a3, params.d4)
    return np.array(
        [
            params.d1,
            params.a1,
            params.a2,
            params.a3,
            params.d4,
            params.d6,
            L,
            math.atan2(params.d4, params.a3),
            2.0 * params.a2 * L,
            params.a2**2,
        ]
    )


@jit
def _nearest_equivalent(v: float, lo: float, hi: float, tol: float, qn: float) -> tuple[bool, float]:
    """(found, the 2*pi-equivalent of angle v within [lo, hi] nearest qn) (``_ik_nearest`` rule)."""
    lo_t, hi_t = lo - tol, hi + tol
    anchor = lo if qn < lo else hi if qn > hi else qn
    base = anchor + (_PI - (_PI - ((_PI - (_PI - v) % _TAU) - anchor)) % _TAU)  # wrap_angle twice
    if lo_t <= base <= hi_t and -3.14 < base - qn < 3.14:
        pick = base
    else:
        pick, d = 0.0, math.inf
        for k in (-2.0, -1.0, 0.0, 1.0, 2.0):
            c = base + k * _TAU
            if lo_t <= c <= hi_t and abs(c - qn) < d:
                pick, d = c, abs(c - qn)
        if d == math.inf:
            return False, 0.0
    if pick < lo:
        pick = lo
    elif pick > hi:
        pick = hi
    return True, pick


@jit
def _wrist(R36: np.ndarray, q4_ref: float, out: np.ndarray) -> int:
    """Wrist solutions (q4, q5, q6) into out (2, 3); returns their count (``wrist_solutions``)."""
    r00, r02, r10, r12, r20, r21, r22 = R36[0], R36[1], R36[2], R36[3], R36[4], R36[5], R36[6]
    m = math.hypot(r02, r12)  # |sin q5|
    if m < SINGULAR_TOL:
        out[0, 0] = q4_ref
        if r22 > 0.0:  # q5 = 0
            out[0, 1] = 0.0
            out[0, 2] = math.atan2(r10, r00) - q4_ref
        else:  # q5 = pi
            out[0, 1] = _PI
            out[0, 2] = q4_ref - math.atan2(-r10, -r00)
        return 1
    out[0, 0], out[0, 1], out[0, 2] = math.atan2(-r12, -r02), math.atan2(m, r22), math.atan2(-r21, r20)
    out[1, 0], out[1, 1], out[1, 2] = math.atan2(r12, r02), math.atan2(-m, r22), math.atan2(r21, -r20)
    return 2


@jit
def _elbow(
    p: np.ndarray, T: np.ndarray, x: float, y: float, z: float, q1: float, q23: np.ndarray, R36: np.ndarray
) -> int:
    """Elbow solutions (q2, q3) into q23 (2, 2) and their R36 entries into R36 (2, 7); returns the count."""
    L, beta, two_a2_L, a2_sq = p[6], p[7], p[8], p[9]
    c1, s1 = math.cos(q1), math.sin(q1)
    r, s = x * c1 + y * s1 - p[1], z - p[0]
    cos_g = (r * r + s * s - a2_sq - L * L) / two_a2_L
    if abs(cos_g) > 1.0 + 1e-12:
        return 0
    gamma0 = math.acos(min(1.0, max(-1.0, cos_g)))
    a0, a1, a2 = c1 * T[0, 0] + s1 * T[1, 0], c1 * T[0, 1] + s1 * T[1, 1], c1 * T[0, 2] + s1 * T[1, 2]
    b0, b2 = s1 * T[0, 0] - c1 * T[1, 0], s1 * T[0, 2] - c1 * T[1, 2]
    r20, r21, r22 = T[2, 0], T[2, 1], T[2, 2]
    count = 2 if gamma0 > 0.0 else 1
    for e in range(count):
        gamma = gamma0 if e == 0 else -gamma0
        q3 = gamma - beta
        q2 = math.atan2(r, s) - math.atan2(L * math.sin(gamma), p[2] + L * math.cos(gamma))
        sp, cp = math.sin(q2 + q3), math.cos(q2 + q3)
        q23[e, 0], q23[e, 1] = q2, q3
        R36[e, 0] = sp * a0 + cp * r20
        R36[e, 1] = sp * a2 + cp * r22
        R36[e, 2] = b0
        R36[e, 3] = b2
        R36[e, 4] = cp * a0 - sp * r20
        R36[e, 5] = cp * a1 - sp * r21
        R36[e, 6] = cp * a2 - sp * r22
    return count


@jit
def nearest_branch_compiled(
    p: np.ndarray,
    T_O_C: np.ndarray,
    T_C_E: np.ndarray,
    q_min: np.ndarray,
    q_max: np.ndarray,
    q_near: np.ndarray,
    tol: float,
) -> tuple[bool, np.ndarray]:
    """(found, q (6,) [rad]): ``nearest_branch(params, T_O_C T_C_E, q_min, q_max, q_near, tol=tol)``.

    ``p`` from :func:`ik_parameter_array`; ``T_O_C`` a rigid camera pose (4, 4) and ``T_C_E`` the
    flange in the camera frame, so that T_O_E = T_O_C T_C_E; joint arrays (6,).
    """
    T_O_E = np.empty((4, 4))
    for a in range(4):
        for b in range(4):
            T_O_E[a, b] = (
                T_O_C[a, 0] * T_C_E[0, b]
                + T_O_C[a, 1] * T_C_E[1, b]
                + T_O_C[a, 2] * T_C_E[2, b]
                + T_O_C[a, 3] * T_C_E[3, b]
            )
    d6 = p[5]
    x, y, z = T_O_E[0, 3] - d6 * T_O_E[0, 2], T_O_E[1, 3] - d6 * T_O_E[1, 2], T_O_E[2, 3] - d6 * T_O_E[2, 2]
    shoulders = np.empty(2)
    if math.hypot(x, y) < SINGULAR_TOL:
        shoulders[0], shoulders[1] = q_near[0], q_near[0] + _PI
    else:
        front = math.atan2(y, x)
        shoulders[0], shoulders[1] = front, (front - _PI if front > 0.0 else front + _PI)
    first = 0 if abs(_PI - (_PI - (shoulders[0] - q_near[0])) % _TAU) <= 0.5 * _PI else 1
    best = np.zeros(6)
    found = False
    best_d, best_i, best_j, best_k = math.inf, 0, 0, 0
    cand = np.empty(6)
    q23 = np.empty((2, 2))
    R36 = np.empty((2, 7))
    wrist = np.empty((2, 3))
    q4_ref = q_near[3]
    for order in range(2):  # the shoulder nearer q_near first: the other is then given up early
        i = first if order == 0 else 1 - first
        ok, cand[0] = _nearest_equivalent(shoulders[i], q_min[0], q_max[0], tol, q_near[0])
        if not ok:
            continue
        d1 = (cand[0] - q_near[0]) * (cand[0] - q_near[0])
        if d1 > best_d:
            continue
        n_elbow = _elbow(p, T_O_E, x, y, z, shoulders[i], q23, R36)
        for j in range(n_elbow):
            d23 = d1
            ok = True
            for a in range(2):
                ok, cand[1 + a] = _nearest_equivalent(
                    q23[j, a], q_min[1 + a], q_max[1 + a], tol, q_near[1 + a]
                )
                if not ok:
                    break
                d23 += (cand[1 + a] - q_near[1 + a]) * (cand[1 + a] - q_near[1 + a])
                if d23 > best_d:
                    ok = False
                    break
            if not ok:
                continue
            n_wrist = _wrist(R36[j], q4_ref, wrist)
            for k in range(n_wrist):
                d = d23
                ok = True
                for a in range(3):
                    ok, cand[3 + a] = _nearest_equivalent(
                        wrist[k, a], q_min[3 + a], q_max[3 + a], tol, q_near[3 + a]
                    )
                    if not ok:
                        break
                    d += (cand[3 + a] - q_near[3 + a]) * (cand[3 + a] - q_near[3 + a])
                    if d > best_d:
                        ok = False
                        break
                if ok and (d, i, j, k) < (best_d, best_i, best_j, best_k):
                    best[:] = cand
                    best_d, best_i, best_j, best_k = d, i, j, k
                    found = True
    return found, best


@jit
def nearest_row_compiled(
    rows: np.ndarray, count: int, q_min: np.ndarray, q_max: np.ndarray, q_near: np.ndarray, tol: float
) -> tuple[bool, np.ndarray]:
    """(found, q): ``select_branches(rows[:count], q_min, q_max, q_near, tol=tol)[0]`` for revolute joints.

    Each joint of each row moved to its 2*pi-equivalent within limits nearest ``q_near`` (the
    rule of :func:`_nearest_equivalent`), rows with a joint lacking one dropped, the nearest in
    Euclidean distance kept, the first on a tie (a stable sort's first row). Unvalidated: ``rows``
    (k, n) [rad] with k >= count, joint arrays (n,).
    """
    n = q_near.shape[0]
    best = np.zeros(n)
    cand = np.empty(n)
    best_d, found = math.inf, False
    for r in range(count):
        d = 0.0
        ok = True
        for k in range(n):
            ok, cand[k] = _nearest_equivalent(rows[r, k], q_min[k], q_max[k], tol, q_near[k])
            if not ok:
                break
            d += (cand[k] - q_near[k]) * (cand[k] - q_near[k])
        if ok and d < best_d:
            best[:] = cand
            best_d, found = d, True
    return found, best


@jit
def poses_match(T_a: np.ndarray, T_b: np.ndarray, tol: float) -> bool:
    """True when every entry of two (4, 4) poses differs by at most tol: the IK solution's pose check."""
    for i in range(4):
        for j in range(4):
            if not abs(T_a[i, j] - T_b[i, j]) <= tol:  # NaN fails
                return False
    return True
