"""Inverse kinematics: closed form for IRB 4600-type spherical-wrist arms, numerical otherwise.

The closed form (Section 4.6, Eq. 26-28; Appendix B re-derived, ERRATA 4-5) covers arms
whose standard DH table has the IRB 4600 structure of ERRATA 1::

    (d1, a1, -90 deg, 0), (0, a2, 0, -90 deg), (0, a3, -90 deg, 0),
    (d4, 0, 90 deg, 0), (0, 0, -90 deg, 0), (d6, 0, 0, 0)

i.e. a shoulder offset a1, an elbow offset a3 and a spherical wrist (axes 4-6 meet at
the wrist centre), like the OPW parameterisation with c1 = d1, c2 = a2, c3 = d4,
c4 = d6 and no lateral offset. Derivation, all angles in the vertical plane of joint 1
("angle from the vertical", radial coordinate rho along (cos q1, sin q1)):

* wrist centre ``p_wc = p_E - d6 * z_E``; q1 = atan2(y_wc, x_wc) (front) or + pi (back).
* from joint 2, ``(r, s) = (rho_wc - a1, z_wc - d1) = a2 (sin q2, cos q2)
  + L (sin(q2 + q3 + beta), cos(q2 + q3 + beta))`` with ``L = hypot(a3, d4)``,
  ``beta = atan2(d4, a3)``. Law of cosines: ``cos(q3 + beta) = (r^2 + s^2 - a2^2 - L^2)
  / (2 a2 L)`` (two elbow signs), then ``q2 = atan2(r, s) - atan2(L sin(q3+beta),
  a2 + L cos(q3+beta))``. This replaces (B8)-(B9), whose printed denominator is wrong.
* ``R_3_6 = R_0_3^T R_0_E = Rz(q4) Ry(-q5) Rz(q6)``: ``q5 = atan2(+-sqrt(R02^2 + R12^2), R22)``,
  ``q4 = atan2(-R12 / s5, -R02 / s5)``, ``q6 = atan2(-R21 / s5, R20 / s5)`` (two-argument
  arctangents carrying the sign of s5, ERRATA 5).

Singular poses, where infinitely many solutions exist, return one documented choice:
wrist singularity (|sin q5| < 1e-10, axes 4 and 6 aligned): ``q4 = q_ref[3]`` and the
whole rotation on q6; shoulder singularity (wrist centre within 1e-10 m of axis 1):
``q1 = q_ref[0]`` or ``q_ref[0] + pi``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import pinocchio as pin

from ..exceptions import InvalidParameterError

__all__ = [
    "SphericalWristParameters",
    "closed_form_branches",
    "nearest_branch",
    "numerical_branches",
    "select_branches",
]

_ALPHA = (-0.5 * math.pi, 0.0, -0.5 * math.pi, 0.5 * math.pi, -0.5 * math.pi, 0.0)  # [rad]
_THETA_OFFSET = (0.0, -0.5 * math.pi, 0.0, 0.0, 0.0, 0.0)  # [rad]
_SINGULAR = 1e-10  # |sin q5| [-] and wrist-centre distance to axis 1 [m] treated as exactly singular
_TWO_PI = 2.0 * math.pi


def _dh(d: float, a: float, alpha: float, theta: float) -> np.ndarray:
    """Standard DH transform Rz(theta) Tz(d) Tx(a) Rx(alpha), Eq. (12)-(13)."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array(
        [[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1.0]]
    )


@dataclass(frozen=True)
class SphericalWristParameters:
    """Lengths [m] of an IRB 4600-type arm (DH structure in the module docstring).

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
        """(L, beta, 2 a2 L) of the law of cosines (module docstring), computed once."""
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


def _wrist_angles(
    r00: float, r02: float, r10: float, r12: float, r20: float, r21: float, r22: float, q4_ref: float
) -> list[tuple[float, float, float]]:
    """(q4, q5, q6) with Rz(q4) Ry(-q5) Rz(q6) = R36, from the seven entries of R36 it needs.

    Two flips, or one choice when singular (module docstring).
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
    """Map one angle to (-pi, pi], with the arithmetic of :func:`_wrap` (same float result)."""
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


def closed_form_branches(
    params: SphericalWristParameters, T_O_E: np.ndarray, q_ref: np.ndarray
) -> np.ndarray:
    """Every IK solution of the flange pose, joint limits ignored (module docstring).

    Args:
        params: Arm lengths.
        T_O_E: Flange pose in the base frame (4, 4), rigid.
        q_ref: Reference configuration (6,) [rad] for the choices at singular poses.

    Returns:
        Up to 8 rows (k, 6) [rad]: shoulder front/back x elbow x wrist flip, angles in
        (-pi, pi] except where a singular choice copies q_ref. Empty (0, 6) when the wrist
        centre is out of reach.
    """
    q4_ref = float(q_ref[3])
    M = np.asarray(T_O_E, dtype=float).tolist()
    centre, shoulders = _shoulders(params, M, float(q_ref[0]))
    rows = [
        (q1, q2, q3, *wrist)
        for q1 in shoulders
        for q2, q3, R36 in _elbows(params, M, centre, q1)
        for wrist in _wrist_angles(*R36, q4_ref)
    ]
    return _wrap(np.array(rows, dtype=float).reshape(-1, 6))


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
    centre, shoulders = _shoulders(params, M, q_near[0])
    order = (0, 1) if abs(_wrap1(shoulders[0] - q_near[0])) <= 0.5 * math.pi else (1, 0)
    best, best_key = None, (math.inf, 0, 0, 0)
    q4_ref = q_near[3]
    for i in order:  # the shoulder nearer q_near first: the other one is then given up early
        q_1 = _nearest_equivalents((shoulders[i],), bounds[:1], 0.0, best_key[0])
        if q_1 is None:
            continue
        for j, (q2, q3, R36) in enumerate(_elbows(params, M, centre, shoulders[i])):
            q_23 = _nearest_equivalents((q2, q3), bounds[1:3], q_1[1], best_key[0])
            if q_23 is None:
                continue
            for k, wrist in enumerate(_wrist_angles(*R36, q4_ref)):
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
    pi, two_pi = math.pi, _TWO_PI
    out = []
    for v, (lo, hi, lo_t, hi_t, anchor, qn) in zip(angles, bounds, strict=False):  # bounds may be longer
        base = anchor + (pi - (pi - ((pi - (pi - v) % two_pi) - anchor)) % two_pi)  # _wrap1 twice
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


def _wrap(angles: np.ndarray) -> np.ndarray:
    """Map angles to (-pi, pi]."""
    return math.pi - np.mod(math.pi - angles, _TWO_PI)


def select_branches(
    branches: np.ndarray,
    q_min: np.ndarray,
    q_max: np.ndarray,
    q_near: np.ndarray,
    *,
    tol: float = 1e-9,
    duplicate: float = 1e-6,
) -> np.ndarray:
    """Bring solutions into the joint limits and sort them by distance to ``q_near``.

    Each joint angle is replaced by its 2*pi-equivalent within [q_min, q_max] (``tol``
    [rad] of slack, then clipped) that lies nearest ``q_near``; rows with a joint that
    has no such equivalent are dropped, as are rows within ``duplicate`` [rad] of an
    earlier one modulo 2*pi (ties at exactly pi from ``q_near`` would otherwise give two
    rows for one branch). Rows are sorted by Euclidean distance to ``q_near``.
    """
    if branches.shape[0] == 0:
        return branches
    anchor = np.clip(q_near, q_min, q_max)
    base = anchor + _wrap(branches - anchor)  # (k, 6), nearest equivalent to the anchor
    cand = base[..., None] + _TWO_PI * np.arange(-2, 3)  # (k, 6, 5)
    inside = (cand >= (q_min - tol)[:, None]) & (cand <= (q_max + tol)[:, None])
    dist = np.where(inside, np.abs(cand - q_near[:, None]), np.inf).reshape(-1, 5)
    pick = np.argmin(dist, axis=-1)  # first nearest equivalent of each joint
    flat = np.arange(pick.size)
    ok = np.isfinite(dist[flat, pick]).reshape(branches.shape).all(axis=1)
    q = np.clip(cand.reshape(-1, 5)[flat, pick].reshape(branches.shape)[ok], q_min, q_max)
    q = q[np.argsort(np.linalg.norm(q - q_near, axis=1), kind="stable")]
    if q.shape[0] < 2:
        return q
    wrapped = _wrap(q[:, None, :] - q[None, :, :])  # (k, k, 6) pairwise differences modulo 2 pi
    near = (np.abs(wrapped).max(axis=-1) <= duplicate).tolist()
    keep: list[int] = []
    for i, row in enumerate(near):
        if not any(row[j] for j in keep):
            keep.append(i)
    return q[keep]


def numerical_branches(
    model: pin.Model,
    data: pin.Data,
    frame_id: int,
    T_O_F: np.ndarray,
    seeds: np.ndarray,
    *,
    tol: float = 1e-12,
    max_iter: int = 100,
) -> np.ndarray:
    """IK of a frame pose by damped Gauss-Newton on the LOCAL error ``log6(T_O_F(q)^-1 T_O_F)``.

    From each seed, ``dq = (J^T J + lam I)^-1 J^T e`` with the LOCAL frame Jacobian J
    (lam = 1e-4 while |e| > 1e-3, then 1e-12; steps capped at 0.5 rad) until |e| < tol.

    Args:
        model: Pinocchio model (not modified).
        data: Its data (overwritten).
        frame_id: Frame to place.
        T_O_F: Target pose (4, 4), rigid.
        seeds: Start configurations (n, nq) [rad].
        tol: Convergence threshold on |log6| (metres and radians).
        max_iter: Iterations per seed.

    Returns:
        Converged configurations (k, nq) [rad], unwrapped, duplicates not removed.
    """
    target = pin.SE3(T_O_F[:3, :3], T_O_F[:3, 3])
    eye = np.eye(model.nv)
    out = []
    for seed in seeds:
        q = np.array(seed, dtype=float)
        for _ in range(max_iter):
            pin.forwardKinematics(model, data, q)
            err = pin.log6(pin.updateFramePlacement(model, data, frame_id).actInv(target)).vector
            norm = np.linalg.norm(err)
            if norm < tol:
                out.append(q)
                break
            J = pin.computeFrameJacobian(model, data, q, frame_id, pin.LOCAL)
            lam = 1e-4 if norm > 1e-3 else 1e-12
            dq = np.linalg.solve(J.T @ J + lam * eye, J.T @ err)
            step = np.abs(dq).max()
            q = q + (dq if step <= 0.5 else dq * (0.5 / step))
    return np.array(out, dtype=float).reshape(-1, model.nq)
