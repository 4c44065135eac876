"""Arm lengths and scalar steps of the closed-form IK (derivation in :mod:`ibvs_youla.model.ik`).

Shared by :func:`~ibvs_youla.model.ik.closed_form_branches`, which builds every branch,
and :func:`~ibvs_youla.model.ik.nearest_branch`, which solves them nearest-first. The
lowest of the IK modules: it imports none of them. The steps (:func:`shoulder_solutions`,
:func:`elbow_solutions`, :func:`wrist_solutions`) are kernels: they do not validate their
inputs (a rigid flange pose as nested lists, angles in radians).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import pinocchio as pin

from ..exceptions import InvalidParameterError

__all__ = [
    "SINGULAR_TOL",
    "SphericalWristParameters",
    "elbow_solutions",
    "shoulder_solutions",
    "wrap_angle",
    "wrap_angles",
    "wrist_solutions",
]

SINGULAR_TOL = 1e-10  # |sin q5| [-] and wrist-centre distance to axis 1 [m] treated as exactly singular
_ALPHA = (-0.5 * math.pi, 0.0, -0.5 * math.pi, 0.5 * math.pi, -0.5 * math.pi, 0.0)  # [rad]
_THETA_OFFSET = (0.0, -0.5 * math.pi, 0.0, 0.0, 0.0, 0.0)  # [rad]


def _dh(d: float, a: float, alpha: float, theta: float) -> np.ndarray:
    """Standard DH transform Rz(theta) Tz(d) Tx(a) Rx(alpha), Eq. (12)-(13)."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array(
        [[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1.0]]
    )


@dataclass(frozen=True)
class SphericalWristParameters:
    """Lengths [m] of an IRB 4600-type arm (DH structure in the :mod:`ibvs_youla.model.ik` docstring).

    Attributes:
        d1: Height of joint 2's axis above the base frame.
        a1: Shoulder offset (joint 2's axis from joint 1's axis).
        a2: Upper arm, joint 2 to joint 3 (> 0).
        a3: Elbow offset, perpendicular to the forearm.
        d4: Forearm, along axis 4 to the wrist centre.
        d6: Wrist centre to flange along axis 6.
    """

    d1: float
    a1: float
    a2: float
    a3: float
    d4: float
    d6: float

    def __post_init__(self) -> None:
        for name in ("d1", "a1", "a2", "a3", "d4", "d6"):
            if not math.isfinite(getattr(self, name)):
                raise InvalidParameterError(name, getattr(self, name), "a finite length [m]")
        if self.a2 <= 0.0:
            raise InvalidParameterError("a2", self.a2, "> 0 m")
        if math.hypot(self.a3, self.d4) <= 0.0:
            raise InvalidParameterError("(a3, d4)", (self.a3, self.d4), "not both zero")

    @cached_property
    def _elbow_constants(self) -> tuple[float, float, float]:
        """(L, beta, 2 a2 L) of the law of cosines (:mod:`ibvs_youla.model.ik` docstring), computed once."""
        L = math.hypot(self.a3, self.d4)
        return L, math.atan2(self.d4, self.a3), 2.0 * self.a2 * L

    @classmethod
    def irb4600(cls) -> SphericalWristParameters:
        """ABB IRB 4600-45/2.05, ERRATA 1 / Table A1."""
        return cls(d1=0.495, a1=0.175, a2=0.900, a3=0.175, d4=0.960, d6=0.135)

    def dh_rows(self) -> tuple[tuple[float, float, float, float], ...]:
        """Standard DH rows (d [m], a [m], alpha [rad], theta_offset [rad]), Eq. (12)."""
        ds = (self.d1, 0.0, 0.0, self.d4, 0.0, self.d6)
        as_ = (self.a1, self.a2, self.a3, 0.0, 0.0, 0.0)
        return tuple(zip(ds, as_, _ALPHA, _THETA_OFFSET, strict=True))

    def flange_pose(self, q: np.ndarray) -> np.ndarray:
        """T_O_E (4, 4) by the DH product of Eq. (15), for checks against a model."""
        T_O_E = np.eye(4)
        for (d, a, alpha, offset), qi in zip(self.dh_rows(), q, strict=True):
            T_O_E = T_O_E @ _dh(d, a, alpha, float(qi) + offset)
        return T_O_E

    @classmethod
    def identify(
        cls, model: pin.Model, flange_frame_id: int, n_checks: int = 8
    ) -> SphericalWristParameters | None:
        """Read the lengths off a 6-joint model's axes at q = 0, or None if it is not of this type.

        Joint axis lines come from the WORLD joint Jacobian at q = 0 (column [v; w], with
        v = p x w for any point p of the axis, so the foot of the axis is w x v). The
        candidate is accepted only if its DH flange pose matches the model's to 1e-9 at
        ``n_checks`` seeded random configurations.
        """
        data = model.createData()
        q0 = np.zeros(model.nq)
        J = pin.computeJointJacobians(model, data, q0)
        feet = np.cross(J[3:].T, J[:3].T)  # (6, 3) foot of each joint axis [m]
        pin.updateFramePlacements(model, data)
        x_flange = data.oMf[flange_frame_id].translation[0]
        d1, a1 = feet[1, 2], feet[1, 0]
        lengths = (d1, a1, feet[2, 2] - d1, feet[3, 2] - feet[2, 2], feet[4, 0] - a1, x_flange - feet[4, 0])
        try:
            cand = cls(*(float(x) for x in lengths))
        except InvalidParameterError:
            return None
        rng = np.random.default_rng(0)
        lo = np.maximum(model.lowerPositionLimit, -math.pi)
        hi = np.minimum(model.upperPositionLimit, math.pi)
        for q in [q0, *(lo + (hi - lo) * rng.random((n_checks, model.nq)))]:
            pin.forwardKinematics(model, data, q)
            T_model = pin.updateFramePlacement(model, data, flange_frame_id).homogeneous
            if not np.allclose(cand.flange_pose(q), T_model, rtol=0.0, atol=1e-9):
                return None
        return cand


def wrist_solutions(
    r00: float, r02: float, r10: float, r12: float, r20: float, r21: float, r22: float, q4_ref: float
) -> list[tuple[float, float, float]]:
    """(q4, q5, q6) with Rz(q4) Ry(-q5) Rz(q6) = R36, from the seven entries of R36 it needs.

    Two flips, or one choice when singular (:mod:`ibvs_youla.model.ik` docstring).
    """
    m = math.hypot(r02, r12)  # |sin q5|
    if m < SINGULAR_TOL:
        if r22 > 0.0:  # q5 = 0: R36 = Rz(q4 + q6)
            return [(q4_ref, 0.0, math.atan2(r10, r00) - q4_ref)]
        # q5 = pi: R36 = Rz(q4 - q6) diag(-1, 1, -1)
        return [(q4_ref, math.pi, q4_ref - math.atan2(-r10, -r00))]
    return [
        (math.atan2(-r12, -r02), math.atan2(m, r22), math.atan2(-r21, r20)),
        (math.atan2(r12, r02), math.atan2(-m, r22), math.atan2(r21, -r20)),
    ]


def wrap_angles(angles: np.ndarray) -> np.ndarray:
    """Map angles to (-pi, pi]."""
    return math.pi - np.mod(math.pi - angles, math.tau)


def wrap_angle(x: float) -> float:
    """Map one angle to (-pi, pi], as :func:`wrap_angles` computes it (same float result)."""
    return math.pi - (math.pi - x) % math.tau


def shoulder_solutions(
    p: SphericalWristParameters, T_O_E: list[list[float]], q1_ref: float
) -> tuple[tuple[float, float, float], tuple[float, float]]:
    """Wrist centre (x, y, z) [m] and the two shoulder angles q1 (front, back) of a flange pose."""
    (_, _, r02, px), (_, _, r12, py), (_, _, r22, pz) = T_O_E[0], T_O_E[1], T_O_E[2]
    x, y, z = px - p.d6 * r02, py - p.d6 * r12, pz - p.d6 * r22  # wrist centre [m]
    if math.hypot(x, y) < SINGULAR_TOL:
        return (x, y, z), (q1_ref, q1_ref + math.pi)
    front = math.atan2(y, x)
    return (x, y, z), (front, front - math.pi if front > 0.0 else front + math.pi)


def elbow_solutions(
    p: SphericalWristParameters, T_O_E: list[list[float]], centre: tuple[float, float, float], q1: float
) -> list[tuple[float, float, tuple[float, ...]]]:
    """(q2, q3, R36) of each elbow solution for shoulder angle q1 (none if out of reach).

    R36 = R_O_3^T R_O_E as the seven entries `wrist_solutions` reads (r00, r02, r10, r12, r20,
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
        R36 = (
            sp * a0 + cp * r20,
            sp * a2 + cp * r22,
            b0,
            b2,
            cp * a0 - sp * r20,
            cp * a1 - sp * r21,
            cp * a2 - sp * r22,
        )
        out.append((q2, q3, R36))
    return out
