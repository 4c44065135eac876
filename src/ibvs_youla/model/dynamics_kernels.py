"""Compiled forward dynamics of a revolute chain: the ABA on the numbers of a Pinocchio model.

The plant integrates Eq. (29), M(q) ddq + h(q, dq) = tau, with RK4 at the joint rate: four
articulated-body passes (ABA; Featherstone 2008, Table 7.1) per tick. Pinocchio's ``pin.aba``
costs about 2 us a call from Python, most of it the binding's (argument conversion, the
returned array), and the four calls with the stages between them were the largest part of a
1 kHz tick. :class:`ChainDynamics` reads the numbers of a Pinocchio model once (joint
placements, axes, spatial inertias, armature, gravity), and :func:`aba_compiled` runs the ABA on
them in compiled code, so that a whole RK4 step
(:func:`ibvs_youla.simulation.integrators.rk4_aba_step`) is one compiled call;
:func:`rnea_compiled` does the same for tau = M(q) ddq + h(q, dq), the feedback linearization of
Eq. (33), so that the inner loop's torque is one compiled call too
(:func:`ibvs_youla.simulation.actuation.inner_loop_torque`).

Pinocchio stays the model and the reference: :meth:`ChainDynamics.from_model` reads its
``Model``, and ``tests/test_dynamics_kernels.py`` pins :func:`aba_compiled` and :func:`rnea_compiled`
to ``pin.aba`` and ``pin.rnea`` on random states of several chains and a tree. They are the same
algorithms with another order of floating-point operations, so they agree to rounding (1e-12 of
the result's scale, the tests' bound), not bit for bit.

Conventions (Pinocchio's): a motion [v; w] and a force [f; n] list the linear part first; a
joint placement (R, p) maps the joint's frame into its parent's (x_parent = R x + p); a joint
rotates about a unit axis a of its frame (``JointModelRX``, ``RY``, ``RZ``,
``RevoluteUnaligned``). Each joint's frame is re-expressed once in a frame whose z axis is a
(x_joint = Q x', Q e_z = a: the placement becomes (Q_parent^T R Q, Q_parent^T p) and the
inertia is rotated by Q^T), so that the kernel turns every joint about z. Any other joint
(prismatic, spherical, unbounded revolute, a free flyer) is declined:
:meth:`ChainDynamics.from_model` returns None and the caller keeps ``pin.aba``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .._jit import jit

__all__ = ["ChainDynamics", "aba_compiled", "rnea_compiled"]

_AXES = {"JointModelRX": (1.0, 0.0, 0.0), "JointModelRY": (0.0, 1.0, 0.0), "JointModelRZ": (0.0, 0.0, 1.0)}

# Columns of the chain array C (n + 1, _CHAIN_COLUMNS): per joint i >= 1, its parent's index,
# its placement's rotation (row-major) and translation in the parent (both re-expressed, see the
# module docstring), its body's spatial inertia 6x6 (row-major, linear part first) and the
# armature; row 0 holds gravity [g; 0] in its first six columns.
_PARENT, _ROT, _POS, _INERTIA, _ARMATURE = 0, 1, 10, 13, 49
_CHAIN_COLUMNS = 50
# Columns of the per-body scratch array S (n + 1, _SCRATCH_COLUMNS): the body's rotation in its
# parent (row-major), velocity, bias acceleration, bias force, acceleration, articulated inertia
# (6x6 row-major), u and 1 / D. Row 0 holds the acceleration of the universe, -g.
_S_ROT, _S_VEL, _S_BIAS, _S_FORCE, _S_ACC, _S_IA, _S_U, _S_DINV = 0, 9, 15, 21, 27, 33, 69, 70
_SCRATCH_COLUMNS = 71


def _rotation_to(axis: np.ndarray) -> np.ndarray:
    """A rotation Q with Q e_z = axis (unit): about e_z x axis, or I / half a turn about x for +-e_z.

    Only an exactly zero cross product takes the special cases: an axis 1e-9 rad off -z (a CAD
    export's "2e-8 0 -1") is turned onto, not snapped to -z, so its dynamics stay Pinocchio's.
    """
    k = np.cross(np.array([0.0, 0.0, 1.0]), axis)
    s = float(np.linalg.norm(k))
    if s == 0.0:
        return np.eye(3) if axis[2] > 0.0 else np.diag([1.0, -1.0, -1.0])
    return pin.exp3(k / s * math.atan2(s, float(axis[2])))


@dataclass(frozen=True)
class ChainDynamics:
    """The numbers of a revolute chain's Pinocchio model that the ABA reads (module docstring).

    Attributes:
        chain: The chain array (n + 1, 50), read-only: parents, placements, inertias, armature,
            gravity (the column layout is internal).
        n: Number of joints.
    """

    chain: np.ndarray
    n: int

    @classmethod
    def from_model(cls, model: pin.Model) -> ChainDynamics | None:
        """The chain of ``model``, or None when a joint is not a single-axis revolute one.

        Declined as well: a ``RevoluteUnaligned`` axis that is not a unit vector (to 1e-12; a
        malformed model, whose dynamics Pinocchio computes with the axis as given).
        """
        n = model.njoints - 1
        if n < 1 or model.nq != n or model.nv != n:
            return None
        Q = [np.eye(3)]
        for i in range(1, n + 1):
            joint = model.joints[i]
            name = joint.shortname()
            if name in _AXES:
                axis = np.array(_AXES[name])
            elif name == "JointModelRevoluteUnaligned":
                axis = np.array(joint.extract().axis, dtype=float)
                if not abs(float(np.linalg.norm(axis)) - 1.0) <= 1e-12:  # Pinocchio would use it as given
                    return None
            else:
                return None
            Q.append(_rotation_to(axis))
        C = np.zeros((n + 1, _CHAIN_COLUMNS))
        C[0, :6] = model.gravity.vector
        for i in range(1, n + 1):
            parent = int(model.parents[i])
            placement = model.jointPlacements[i]
            Qp, Qi = Q[parent], Q[i]
            C[i, _PARENT] = parent
            C[i, _ROT:_POS] = (Qp.T @ placement.rotation @ Qi).ravel()
            C[i, _POS:_INERTIA] = Qp.T @ placement.translation
            inertia = model.inertias[i].se3Action(pin.SE3(Qi.T, np.zeros(3)))  # in the joint's z frame
            C[i, _INERTIA:_ARMATURE] = inertia.matrix().ravel()
            C[i, _ARMATURE] = model.armature[i - 1]
        C.setflags(write=False)
        return cls(C, n)

    def scratch(self) -> np.ndarray:
        """A work array for :func:`aba_compiled` (the per-body quantities of the three passes)."""
        return np.zeros((self.n + 1, _SCRATCH_COLUMNS))


@jit
def _act_inv(S: np.ndarray, i: int, C: np.ndarray, m: np.ndarray, out: int) -> None:
    """S[i, out:out + 6] = the motion m (parent frame) in body i's frame: R^T [v - p x w; w]."""
    wx, wy, wz = m[3], m[4], m[5]
    px, py, pz = C[i, _POS], C[i, _POS + 1], C[i, _POS + 2]
    vx = m[0] - (py * wz - pz * wy)
    vy = m[1] - (pz * wx - px * wz)
    vz = m[2] - (px * wy - py * wx)
    for r in range(3):
        R0, R1, R2 = S[i, _S_ROT + r], S[i, _S_ROT + 3 + r], S[i, _S_ROT + 6 + r]  # column r of R
        S[i, out + r] = R0 * vx + R1 * vy + R2 * vz
        S[i, out + 3 + r] = R0 * wx + R1 * wy + R2 * wz


@jit
def _rotation_and_velocity(C: np.ndarray, S: np.ndarray, i: int, q_i: float, qd: float) -> None:
    """Body i's rotation in its parent, R_placement Rz(q_i), and its velocity, the parent's plus e_6 qd.

    The parent's velocity is in its row of S (the universe's, row 0, zero).
    """
    c, s = math.cos(q_i), math.sin(q_i)
    for r in range(3):
        a, b = C[i, _ROT + 3 * r], C[i, _ROT + 3 * r + 1]
        S[i, _S_ROT + 3 * r] = c * a + s * b
        S[i, _S_ROT + 3 * r + 1] = c * b - s * a
        S[i, _S_ROT + 3 * r + 2] = C[i, _ROT + 3 * r + 2]
    _act_inv(S, i, C, S[int(C[i, _PARENT]), _S_VEL : _S_VEL + 6], _S_VEL)
    S[i, _S_VEL + 5] += qd


@jit
def _add_force_to_parent(C: np.ndarray, S: np.ndarray, i: int, parent: int, f: np.ndarray) -> None:
    """Add the force f (body i's frame) to the parent's bias force: [R f_lin; R n + p x (R f_lin)]."""
    R = S[i, _S_ROT : _S_ROT + 9]
    px, py, pz = C[i, _POS], C[i, _POS + 1], C[i, _POS + 2]
    f0 = R[0] * f[0] + R[1] * f[1] + R[2] * f[2]
    f1 = R[3] * f[0] + R[4] * f[1] + R[5] * f[2]
    f2 = R[6] * f[0] + R[7] * f[1] + R[8] * f[2]
    S[parent, _S_FORCE] += f0
    S[parent, _S_FORCE + 1] += f1
    S[parent, _S_FORCE + 2] += f2
    S[parent, _S_FORCE + 3] += R[0] * f[3] + R[1] * f[4] + R[2] * f[5] + (py * f2 - pz * f1)
    S[parent, _S_FORCE + 4] += R[3] * f[3] + R[4] * f[4] + R[5] * f[5] + (pz * f0 - px * f2)
    S[parent, _S_FORCE + 5] += R[6] * f[3] + R[7] * f[4] + R[8] * f[5] + (px * f1 - py * f0)


@jit
def _inertia_row(
    C: np.ndarray, i: int, k: int, x0: float, x1: float, x2: float, x3: float, x4: float, x5: float
) -> float:
    """Row k of joint i's 6x6 inertia in C (column index k) times the motion [x0..x5]."""
    return (
        C[i, k] * x0
        + C[i, k + 1] * x1
        + C[i, k + 2] * x2
        + C[i, k + 3] * x3
        + C[i, k + 4] * x4
        + C[i, k + 5] * x5
    )


@jit
def aba_compiled(
    C: np.ndarray, S: np.ndarray, q: np.ndarray, dq: np.ndarray, tau: np.ndarray, ddq: np.ndarray
) -> None:
    """Accelerations ddq (n,) of M(q) ddq + h(q, dq) = tau (Eq. (29)): the ABA's three passes in body frames.

    ``C`` the chain of :class:`ChainDynamics`, ``S`` its :meth:`~ChainDynamics.scratch`;
    unvalidated float64 inputs q, dq, tau (n,) and the output ddq (n,). Every joint turns about
    its frame's z axis, so its motion subspace is e_6.
    """
    nb = C.shape[0]
    for r in range(6):
        S[0, _S_VEL + r] = 0.0
        S[0, _S_ACC + r] = -C[0, r]
    # pass 1, base to tip: rotation in the parent, velocity, bias acceleration, bias force
    for i in range(1, nb):
        qd = dq[i - 1]
        _rotation_and_velocity(C, S, i, q[i - 1], qd)
        v0, v1, v2 = S[i, _S_VEL], S[i, _S_VEL + 1], S[i, _S_VEL + 2]
        w0, w1, w2 = S[i, _S_VEL + 3], S[i, _S_VEL + 4], S[i, _S_VEL + 5]
        # bias acceleration v x (e_6 qd) = [v1 qd, -v0 qd, 0, w1 qd, -w0 qd, 0]
        S[i, _S_BIAS], S[i, _S_BIAS + 1], S[i, _S_BIAS + 2] = v1 * qd, -v0 * qd, 0.0
        S[i, _S_BIAS + 3], S[i, _S_BIAS + 4], S[i, _S_BIAS + 5] = w1 * qd, -w0 * qd, 0.0
        # momentum h = I v, bias force v x* h = [w x h_lin; w x h_ang + v_lin x h_lin]
        h0 = _inertia_row(C, i, _INERTIA + 0, v0, v1, v2, w0, w1, w2)
        h1 = _inertia_row(C, i, _INERTIA + 6, v0, v1, v2, w0, w1, w2)
        h2 = _inertia_row(C, i, _INERTIA + 12, v0, v1, v2, w0, w1, w2)
        h3 = _inertia_row(C, i, _INERTIA + 18, v0, v1, v2, w0, w1, w2)
        h4 = _inertia_row(C, i, _INERTIA + 24, v0, v1, v2, w0, w1, w2)
        h5 = _inertia_row(C, i, _INERTIA + 30, v0, v1, v2, w0, w1, w2)
        S[i, _S_FORCE] = w1 * h2 - w2 * h1
        S[i, _S_FORCE + 1] = w2 * h0 - w0 * h2
        S[i, _S_FORCE + 2] = w0 * h1 - w1 * h0
        S[i, _S_FORCE + 3] = w1 * h5 - w2 * h4 + v1 * h2 - v2 * h1
        S[i, _S_FORCE + 4] = w2 * h3 - w0 * h5 + v2 * h0 - v0 * h2
        S[i, _S_FORCE + 5] = w0 * h4 - w1 * h3 + v0 * h1 - v1 * h0
        for r in range(36):
            S[i, _S_IA + r] = C[i, _INERTIA + r]
    # pass 2, tip to base: U = Ia e_6, D, u; the articulated inertia and bias force to the parent
    A = np.empty(36)  # Ia - U U^T / D, then rotated
    Z = np.empty(36)
    pa = np.empty(6)
    for i in range(nb - 1, 0, -1):
        ia = _S_IA
        Dinv = 1.0 / (S[i, ia + 35] + C[i, _ARMATURE])
        u = tau[i - 1] - S[i, _S_FORCE + 5]
        S[i, _S_U], S[i, _S_DINV] = u, Dinv
        parent = int(C[i, _PARENT])
        if parent == 0:
            continue
        for r in range(6):
            Ur = S[i, ia + 6 * r + 5] * Dinv
            for k in range(6):
                A[6 * r + k] = S[i, ia + 6 * r + k] - Ur * S[i, ia + 6 * k + 5]
        # pa = f + (Ia - U U^T / D) c + U u / D, c = the bias acceleration (zero in rows 2 and 5)
        c0, c1, c3, c4 = S[i, _S_BIAS], S[i, _S_BIAS + 1], S[i, _S_BIAS + 3], S[i, _S_BIAS + 4]
        for r in range(6):
            pa[r] = (
                S[i, _S_FORCE + r]
                + (A[6 * r] * c0 + A[6 * r + 1] * c1 + A[6 * r + 3] * c3 + A[6 * r + 4] * c4)
                + S[i, ia + 6 * r + 5] * (Dinv * u)
            )
        # to the parent's frame: Ia_parent += X^T A X with X = diag(R^T, R^T) [[I, -P], [0, I]]
        # (the motion transform parent -> body, P = [p]x). First Z = diag(R, R) A diag(R^T, R^T)
        # = [[Za, Zb], [Zb^T, Zc]], then the shift [[Za, Zb - Za P], [Zb^T + P Za, Zc + P Zb -
        # Zb^T P - P Za P]].
        R = S[i, _S_ROT : _S_ROT + 9]
        for r in range(6):  # A <- A diag(R^T, R^T), row by row
            base = 6 * r
            for blk in range(2):
                x0, x1, x2 = A[base + 3 * blk], A[base + 3 * blk + 1], A[base + 3 * blk + 2]
                A[base + 3 * blk] = x0 * R[0] + x1 * R[1] + x2 * R[2]
                A[base + 3 * blk + 1] = x0 * R[3] + x1 * R[4] + x2 * R[5]
                A[base + 3 * blk + 2] = x0 * R[6] + x1 * R[7] + x2 * R[8]
        for col in range(6):  # Z <- diag(R, R) A
            for blk in range(2):
                y0, y1, y2 = A[6 * (3 * blk) + col], A[6 * (3 * blk + 1) + col], A[6 * (3 * blk + 2) + col]
                Z[6 * (3 * blk) + col] = R[0] * y0 + R[1] * y1 + R[2] * y2
                Z[6 * (3 * blk + 1) + col] = R[3] * y0 + R[4] * y1 + R[5] * y2
                Z[6 * (3 * blk + 2) + col] = R[6] * y0 + R[7] * y1 + R[8] * y2
        px, py, pz = C[i, _POS], C[i, _POS + 1], C[i, _POS + 2]
        # A's blocks now: P Za (top left), Za P (top right), P Zb (bottom left), Zb^T P (bottom
        # right); (P M)[r, k] = (p x M[:, k])_r and (M P)[r, k] = (M[r, :] x ... ) by columns of P
        for k in range(3):  # P times column k of Za and of Zb
            a0, a1, a2 = Z[k], Z[6 + k], Z[12 + k]
            A[k], A[6 + k], A[12 + k] = py * a2 - pz * a1, pz * a0 - px * a2, px * a1 - py * a0
            b0, b1, b2 = Z[3 + k], Z[9 + k], Z[15 + k]
            A[18 + k], A[24 + k], A[30 + k] = py * b2 - pz * b1, pz * b0 - px * b2, px * b1 - py * b0
        for r in range(3):  # row r of Za and of Zb^T times P: (m P)[k] = (m x ... ) = -(p x m)... explicit
            m0, m1, m2 = Z[6 * r], Z[6 * r + 1], Z[6 * r + 2]
            A[6 * r + 3], A[6 * r + 4], A[6 * r + 5] = m1 * pz - m2 * py, m2 * px - m0 * pz, m0 * py - m1 * px
            n0, n1, n2 = Z[6 * (3 + r)], Z[6 * (3 + r) + 1], Z[6 * (3 + r) + 2]
            A[6 * (3 + r) + 3], A[6 * (3 + r) + 4], A[6 * (3 + r) + 5] = (
                n1 * pz - n2 * py,
                n2 * px - n0 * pz,
                n0 * py - n1 * px,
            )
        pb = _S_IA
        for r in range(3):
            PA0, PA1, PA2 = A[6 * r], A[6 * r + 1], A[6 * r + 2]  # row r of P Za
            PAP = (PA1 * pz - PA2 * py, PA2 * px - PA0 * pz, PA0 * py - PA1 * px)
            for k in range(3):
                S[parent, pb + 6 * r + k] += Z[6 * r + k]
                S[parent, pb + 6 * r + 3 + k] += Z[6 * r + 3 + k] - A[6 * r + 3 + k]
                S[parent, pb + 6 * (3 + r) + k] += Z[6 * (3 + r) + k] + A[6 * r + k]
                S[parent, pb + 6 * (3 + r) + 3 + k] += (
                    Z[6 * (3 + r) + 3 + k] + A[6 * (3 + r) + k] - A[6 * (3 + r) + 3 + k] - PAP[k]
                )
        _add_force_to_parent(C, S, i, parent, pa)
    # pass 3, base to tip: accelerations from the universe's -g, and ddq
    for i in range(1, nb):
        parent = int(C[i, _PARENT])
        _act_inv(S, i, C, S[parent, _S_ACC : _S_ACC + 6], _S_ACC)
        dot = 0.0
        for r in range(6):
            S[i, _S_ACC + r] += S[i, _S_BIAS + r]
            dot += S[i, _S_IA + 6 * r + 5] * S[i, _S_ACC + r]
        x = S[i, _S_DINV] * (S[i, _S_U] - dot)
        ddq[i - 1] = x
        S[i, _S_ACC + 5] += x


@jit
def rnea_compiled(
    C: np.ndarray, S: np.ndarray, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, tau: np.ndarray
) -> None:
    """Torques tau (n,) = M(q) ddq + h(q, dq) (Eq. (29)), armature included: the RNEA's two passes.

    ``C`` the chain of :class:`ChainDynamics`, ``S`` its :meth:`~ChainDynamics.scratch`;
    unvalidated float64 inputs q, dq, ddq (n,) and the output tau (n,).
    """
    nb = C.shape[0]
    for r in range(6):
        S[0, _S_VEL + r] = 0.0
        S[0, _S_ACC + r] = -C[0, r]
    h, ia = np.empty(6), np.empty(6)
    # pass 1, base to tip: velocity, acceleration, and the force the body needs, I a + v x* (I v)
    for i in range(1, nb):
        qd = dq[i - 1]
        _rotation_and_velocity(C, S, i, q[i - 1], qd)
        parent = int(C[i, _PARENT])
        _act_inv(S, i, C, S[parent, _S_ACC : _S_ACC + 6], _S_ACC)
        v0, v1, v2 = S[i, _S_VEL], S[i, _S_VEL + 1], S[i, _S_VEL + 2]
        w0, w1, w2 = S[i, _S_VEL + 3], S[i, _S_VEL + 4], S[i, _S_VEL + 5]
        # a += v x (e_6 qd) + e_6 ddq
        S[i, _S_ACC] += v1 * qd
        S[i, _S_ACC + 1] -= v0 * qd
        S[i, _S_ACC + 3] += w1 * qd
        S[i, _S_ACC + 4] -= w0 * qd
        S[i, _S_ACC + 5] += ddq[i - 1]
        a0, a1, a2 = S[i, _S_ACC], S[i, _S_ACC + 1], S[i, _S_ACC + 2]
        a3, a4, a5 = S[i, _S_ACC + 3], S[i, _S_ACC + 4], S[i, _S_ACC + 5]
        for r in range(6):
            k = _INERTIA + 6 * r
            h[r] = _inertia_row(C, i, k, v0, v1, v2, w0, w1, w2)
            ia[r] = _inertia_row(C, i, k, a0, a1, a2, a3, a4, a5)
        S[i, _S_FORCE] = ia[0] + (w1 * h[2] - w2 * h[1])
        S[i, _S_FORCE + 1] = ia[1] + (w2 * h[0] - w0 * h[2])
        S[i, _S_FORCE + 2] = ia[2] + (w0 * h[1] - w1 * h[0])
        S[i, _S_FORCE + 3] = ia[3] + (w1 * h[5] - w2 * h[4] + v1 * h[2] - v2 * h[1])
        S[i, _S_FORCE + 4] = ia[4] + (w2 * h[3] - w0 * h[5] + v2 * h[0] - v0 * h[2])
        S[i, _S_FORCE + 5] = ia[5] + (w0 * h[4] - w1 * h[3] + v0 * h[1] - v1 * h[0])
    # pass 2, tip to base: the joint torque e_6^T f (plus the armature's), f passed to the parent
    for i in range(nb - 1, 0, -1):
        tau[i - 1] = S[i, _S_FORCE + 5] + C[i, _ARMATURE] * ddq[i - 1]
        parent = int(C[i, _PARENT])
        if parent == 0:
            continue
        _add_force_to_parent(C, S, i, parent, S[i, _S_FORCE : _S_FORCE + 6])
