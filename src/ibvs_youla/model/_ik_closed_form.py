"""Scalar steps of the closed-form IK (derivation in :mod:`ibvs_youla.model.ik`).

Shared by :func:`~ibvs_youla.model.ik.closed_form_branches`, which builds every branch,
and :func:`~ibvs_youla.model.ik.nearest_branch`, which solves them nearest-first.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover
    from .ik import SphericalWristParameters


_SINGULAR = 1e-10  # |sin q5| [-] and wrist-centre distance to axis 1 [m] treated as exactly singular
_TWO_PI = 2.0 * math.pi


def _wrist_angles(
    r00: float, r02: float, r10: float, r12: float, r20: float, r21: float, r22: float, q4_ref: float
) -> list[tuple[float, float, float]]:
    """(q4, q5, q6) with Rz(q4) Ry(-q5) Rz(q6) = R36, from the seven entries of R36 it needs.

    Two flips, or one choice when singular (:mod:`ibvs_youla.model.ik` docstring).
    """
    m = math.hypot(r02, r12)  # |sin q5|
    if m < _SINGULAR:
        if r22 > 0.0:  # q5 = 0: R36 = Rz(q4 + q6)
            return [(q4_ref, 0.0, math.atan2(r10, r00) - q4_ref)]
        # q5 = pi: R36 = Rz(q4 - q6) diag(-1, 1, -1)
        return [(q4_ref, math.pi, q4_ref - math.atan2(-r10, -r00))]
    return [
        (math.atan2(-r12, -r02), math.atan2(m, r22), math.atan2(-r21, r20)),
        (math.atan2(r12, r02), math.atan2(-m, r22), math.atan2(r21, -r20)),
    ]


def _wrap1(x: float) -> float:
    """Map one angle to (-pi, pi], as ``ik._wrap`` computes it (same float result)."""
    return math.pi - (math.pi - x) % _TWO_PI


def _shoulders(
    p: SphericalWristParameters, T_O_E: list[list[float]], q1_ref: float
) -> tuple[tuple[float, float, float], tuple[float, float]]:
    """Wrist centre (x, y, z) [m] and the two shoulder angles q1 (front, back) of a flange pose."""
    (_, _, r02, px), (_, _, r12, py), (_, _, r22, pz) = T_O_E[0], T_O_E[1], T_O_E[2]
    x, y, z = px - p.d6 * r02, py - p.d6 * r12, pz - p.d6 * r22  # wrist centre [m]
    if math.hypot(x, y) < _SINGULAR:
        return (x, y, z), (q1_ref, q1_ref + math.pi)
    front = math.atan2(y, x)
    return (x, y, z), (front, front - math.pi if front > 0.0 else front + math.pi)


def _elbows(
    p: SphericalWristParameters, T_O_E: list[list[float]], centre: tuple[float, float, float], q1: float
) -> list[tuple[float, float, tuple[float, ...]]]:
    """(q2, q3, R36) of each elbow solution for shoulder angle q1 (none if out of reach).

    R36 = R_O_3^T R_O_E as the seven entries `_wrist_angles` reads (r00, r02, r10, r12, r20,
    r21, r22). Angles unwrapped.
    """
    (r00, r01, r02, _), (r10, r11, r12, _), (r20, r21, r22, _) = T_O_E[0], T_O_E[1], T_O_E[2]
    x, y, z = centre
    L, beta, two_a2_L = p._elbow_constants
    c1, s1 = math.cos(q1), math.sin(q1)
    r, s = x * c1 + y * s1 - p.a1, z - p.d1  # joint 2 -> wrist centre, radial and vertical [m]
    cos_g = (r * r + s * s - p.a2**2 - L * L) / two_a2_L
    if abs(cos_g) > 1.0 + 1e-12:
        return []
    gamma0 = math.acos(min(1.0, max(-1.0, cos_g)))
    # R_O_E rows projected for R_O_3 = [[sp c1, s1, cp c1], [sp s1, -c1, cp s1], [cp, 0, -sp]]
    a0, a1, a2 = c1 * r00 + s1 * r10, c1 * r01 + s1 * r11, c1 * r02 + s1 * r12
    b0, b2 = s1 * r00 - c1 * r10, s1 * r02 - c1 * r12
    out = []
    for gamma in (gamma0, -gamma0) if gamma0 > 0.0 else (gamma0,):
        q3 = gamma - beta
        q2 = math.atan2(r, s) - math.atan2(L * math.sin(gamma), p.a2 + L * math.cos(gamma))
        sp, cp = math.sin(q2 + q3), math.cos(q2 + q3)
        R36 = (sp * a0 + cp * r20, sp * a2 + cp * r22, b0, b2,
               cp * a0 - sp * r20, cp * a1 - sp * r21, cp * a2 - sp * r22)
        out.append((q2, q3, R36))
    return out
