"""Nearest-branch fast path of the closed-form IK (the configuration estimate of Eq. (62)).

:func:`nearest_branch` gives the first row of :func:`~ibvs_youla.model.ik.select_branches`
applied to :func:`~ibvs_youla.model.ik.closed_form_branches` in scalar arithmetic, without
building every branch.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ._ik_closed_form import elbow_solutions, shoulder_solutions, wrap_angle, wrist_solutions

if TYPE_CHECKING:  # pragma: no cover
    import numpy as np

    from ._ik_closed_form import SphericalWristParameters

__all__ = ["nearest_branch"]


def nearest_branch(
    params: SphericalWristParameters,
    T_O_E: np.ndarray,
    q_min: list[float],
    q_max: list[float],
    q_near: list[float],
    *,
    tol: float = 1e-9,
) -> list[float] | None:
    """First row of ``select_branches(closed_form_branches(...), q_min, q_max, q_near)``, or None.

    The same rules in scalar arithmetic, without building every branch (the configuration
    estimate of Eq. (62) runs at every camera frame): each joint is moved to its
    2*pi-equivalent within limits nearest ``q_near``, branches with a joint outside the
    limits are dropped, and the nearest in Euclidean distance wins, the first in branch
    order on a tie. The shoulder nearer ``q_near`` is visited first, and a branch is given
    up (before its elbow and wrist are solved) as soon as its partial distance exceeds the
    best one's. Unvalidated: ``T_O_E`` a rigid (4, 4) pose, the rest lists of 6 floats [rad].
    """
    bounds = [
        (lo, hi, lo - tol, hi + tol, lo if qn < lo else hi if qn > hi else qn, qn)
        for lo, hi, qn in zip(q_min, q_max, q_near, strict=True)
    ]
    M = T_O_E.tolist()
    centre, shoulders = shoulder_solutions(params, M, q_near[0])
    order = (0, 1) if abs(wrap_angle(shoulders[0] - q_near[0])) <= 0.5 * math.pi else (1, 0)
    best, best_key = None, (math.inf, 0, 0, 0)
    q4_ref = q_near[3]
    for i in order:  # the shoulder nearer q_near first: the other one is then given up early
        q_1 = _nearest_equivalents((shoulders[i],), bounds[:1], 0.0, best_key[0])
        if q_1 is None:
            continue
        for j, (q2, q3, R36) in enumerate(elbow_solutions(params, M, centre, shoulders[i])):
            q_23 = _nearest_equivalents((q2, q3), bounds[1:3], q_1[1], best_key[0])
            if q_23 is None:
                continue
            for k, wrist in enumerate(wrist_solutions(*R36, q4_ref)):
                q_456 = _nearest_equivalents(wrist, bounds[3:], q_23[2], best_key[0])
                if q_456 is not None and (q_456[3], i, j, k) < best_key:
                    best, best_key = [q_1[0], q_23[0], q_23[1], *q_456[:3]], (q_456[3], i, j, k)
    return best


def _nearest_equivalents(
    angles: tuple[float, ...], bounds: list[tuple[float, ...]], d2: float, give_up: float
) -> list[float] | None:
    """Each angle's 2*pi-equivalent within limits nearest q_near (`select_branches`' rule).

    ``bounds`` holds (lo, hi, lo - tol, hi + tol, anchor, q_near) per angle, anchor = q_near
    clipped to [lo, hi]. Returns [q_1, ..., q_k, d2 + sum (q_i - q_near_i)^2], or None when
    an angle has no equivalent within limits or the squared distance exceeds ``give_up``.
    """
    pi, two_pi = math.pi, math.tau
    out = []
    for v, (lo, hi, lo_t, hi_t, anchor, qn) in zip(angles, bounds, strict=False):  # bounds may be longer
        base = anchor + (pi - (pi - ((pi - (pi - v) % two_pi) - anchor)) % two_pi)  # wrap_angle twice
        if lo_t <= base <= hi_t and -3.14 < base - qn < 3.14:
            pick = base  # every other 2*pi-equivalent is farther than pi from q_near
        else:
            pick, d = 0.0, math.inf
            for k in (-2.0, -1.0, 0.0, 1.0, 2.0):
                c = base + k * two_pi
                if lo_t <= c <= hi_t and abs(c - qn) < d:
                    pick, d = c, abs(c - qn)
            if d == math.inf:
                return None
        if pick < lo:
            pick = lo
        elif pick > hi:
            pick = hi
        out.append(pick)
        d2 += (pick - qn) * (pick - qn)
        if d2 > give_up:
            return None
    out.append(d2)
    return out
