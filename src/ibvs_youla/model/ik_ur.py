"""Closed-form inverse kinematics of the Universal Robots family (UR3, UR5, UR10 and their kin).

**Structure.** Standard DH (Eq. (12)): ``T_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)`` with::

    alpha = (pi/2, 0, 0, pi/2, -pi/2, 0),   a = (0, a2, a3, 0, 0, 0),   d = (d1, 0, 0, d4, d5, d6)

Axis 1 is perpendicular to the three parallel axes 2, 3, 4 (through a point of axis 1:
no shoulder offset), axis 5 is perpendicular to axis 4 at a distance d5 along axis 5, axis 6
crosses axis 5, and d4 is the total offset along the parallel axes. A robot description
matches when there are a fixed base transform T_O_0 (the model's base frame to the DH base:
``ur_description`` rotates it by pi about z) and a fixed flange transform T_6_E such that
``T_O_E(q) = T_O_0 DH(s * q) T_6_E`` at every q, s a sign per joint (its axis as written in
the URDF against the DH z axis). :meth:`UrParameters.identify` reads all of it off the
model's joint axes at q = 0 and accepts it only if that product matches the model's flange
pose to 1e-9 at eight seeded configurations.

**Derivation** (Hawkins 2013, "Analytic inverse kinematics for the Universal Robots UR-5/UR-10
arms", re-derived here in this notation). Write T = T_06 = T_O_0^-1 T_O_E T_6_E^-1, with
position p and rotation R. Frame 1 has x1 = (c1, s1, 0), y1 = (0, 0, 1), z1 = (s1, -c1, 0)
in frame 0; joints 2-4 turn about z1 and::

    R_16 = R_01^T R = Rz(theta2 + theta3 + theta4) Ry(-theta5) Rz(theta6)       (row 3: [s5 c6, -s5 s6, c5])

* **theta1.** Frame 5's origin ``p5 = p - d6 R[:, 2]`` lies at the offset d4 along z1 (axis 5 is
  perpendicular to z1): ``s1 p5x - c1 p5y = d4``, so with r = hypot(p5x, p5y) >= |d4| and
  psi = atan2(p5y, p5x), ``theta1 = psi + asin(d4 / r)`` or ``psi + pi - asin(d4 / r)``
  (shoulder left / right). r < |d4|: the wrist is inside the cylinder no configuration reaches.
* **theta5.** The flange's offset along z1 is d4 plus d6 times z6's component along z1:
  ``c5 = (s1 px - c1 py - d4) / d6`` (= row 3 of R_16, column 3), theta5 = +-acos(c5) (wrist
  up / down); |c5| > 1 is out of reach.
* **theta6** from row 3 of R_16: ``theta6 = atan2(-(z1 . R[:, 1]) / s5, (z1 . R[:, 0]) / s5)``.
  Singular when s5 = 0 (axis 6 parallel to axes 2-4): theta6 is then free and set to the
  reference's (``q_ref[5]``), one documented choice as at the IRB 4600's wrist singularity.
* **theta2..4.** ``Rz(theta234) = R_16 Rz(-theta6) Ry(theta5)`` gives theta234; frame 4's
  origin ``p4 = p5 - d5 z4``, z4 = R_01 Rz(theta234) (0, -1, 0), in frame 1 is
  ``(x, y) = a2 (c2, s2) + a3 (c23, s23)``, a planar two-link problem: ``c3 = (x^2 + y^2 - a2^2 -
  a3^2) / (2 a2 a3)``, theta3 = +-acos(c3) (elbow up / down), ``theta2 = atan2(y, x) -
  atan2(a3 s3, a2 + a3 c3)``, ``theta4 = theta234 - theta2 - theta3``.

Up to 2 x 2 x 2 = 8 branches. ``tests/test_ik_ur.py`` pins the round trip on seeded
configurations of the UR3, UR5 and UR10 of example-robot-data.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .._jit import jit
from ._ik_closed_form import SINGULAR_TOL

__all__ = ["UrParameters", "ur_branches", "ur_branches_compiled", "ur_parameter_array"]

_ALPHA = (0.5 * math.pi, 0.0, 0.0, 0.5 * math.pi, -0.5 * math.pi, 0.0)  # [rad]
_PARALLEL_TOL = 1e-9  # |sin| between axes taken as parallel / |cos| taken as perpendicular


def _dh(d: float, a: float, alpha: float, theta: float) -> np.ndarray:
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array(
        [[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1.0]]
    )


@dataclass(frozen=True, eq=False)
class UrParameters:
    """The DH lengths of a UR-type arm and the fixed transforms around them (module docstring).

    Attributes:
        d1, a2, a3, d4, d5, d6: DH lengths [m] (a2, a3 signed: negative in UR's own tables).
        signs: DH angle = sign * model joint angle, per joint (6,).
        T_O_0: DH base frame in the model's base frame (4, 4).
        T_6_E: The model's flange frame in DH frame 6 (4, 4).
    """

    d1: float
    a2: float
    a3: float
    d4: float
    d5: float
    d6: float
    signs: np.ndarray
    T_O_0: np.ndarray
    T_6_E: np.ndarray

    def dh_rows(self) -> tuple[tuple[float, float, float], ...]:
        """Standard DH rows (d [m], a [m], alpha [rad])."""
        ds = (self.d1, 0.0, 0.0, self.d4, self.d5, self.d6)
        as_ = (0.0, self.a2, self.a3, 0.0, 0.0, 0.0)
        return tuple(zip(ds, as_, _ALPHA, strict=True))

    def flange_pose(self, q: np.ndarray) -> np.ndarray:
        """T_O_E (4, 4) = T_O_0 DH(signs * q) T_6_E at model joint angles q (6,) [rad]."""
        T = self.T_O_0.copy()
        for (d, a, alpha), theta in zip(self.dh_rows(), self.signs * np.asarray(q, dtype=float), strict=True):
            T = T @ _dh(d, a, alpha, float(theta))
        return T @ self.T_6_E  # type: ignore[no-any-return]

    @classmethod
    def identify(cls, model: pin.Model, flange_frame_id: int, n_checks: int = 8) -> UrParameters | None:
        """The parameters of a six-revolute-joint model of UR structure, or None (module docstring)."""
        if model.nq != 6 or model.nv != 6 or model.njoints != 7:
            return None
        data = model.createData()
        q0 = np.zeros(6)
        J = pin.computeJointJacobians(model, data, q0)
        w = J[3:].T.copy()  # (6, 3) axis directions at q = 0
        if not np.allclose(np.linalg.norm(w, axis=1), 1.0, atol=1e-9):
            return None  # a prismatic joint, or not a revolute chain
        foot = np.cross(w, J[:3].T)  # a point of each axis [m]
        pin.updateFramePlacements(model, data)
        T_O_E0 = data.oMf[flange_frame_id].homogeneous.copy()
        z0, z1 = w[0], w[1]
        if abs(z0 @ z1) > _PARALLEL_TOL:
            return None
        parallel = [abs(float(np.linalg.norm(np.cross(z1, w[k])))) <= _PARALLEL_TOL for k in (2, 3)]
        if (
            not all(parallel)
            or abs(abs(w[4] @ z0) - 1.0) > _PARALLEL_TOL
            or abs(abs(w[5] @ z1) - 1.0) > _PARALLEL_TOL
        ):
            return None
        signs = np.array(
            [1.0, 1.0, np.sign(w[2] @ z1), np.sign(w[3] @ z1), -np.sign(w[4] @ z0), np.sign(w[5] @ z1)]
        )
        y0 = -z1
        x0 = np.cross(y0, z0)
        R0 = np.column_stack([x0, y0, z0])
        # origin: where axis 2 crosses axis 1 (the foot of the common normal on axis 1)
        n = np.cross(z0, z1)
        origin = foot[0] + z0 * (((foot[1] - foot[0]) @ np.cross(z1, n)) / (z0 @ np.cross(z1, n)))
        a2 = float((foot[2] - foot[1]) @ x0)
        a3 = float((foot[3] - foot[2]) @ x0)
        d4 = float((foot[4] - origin) @ z1)
        d5 = float((foot[5] - foot[3]) @ -z0)
        centre = foot[4] + z0 * float((foot[5] - foot[4]) @ z0)  # axis 5 meets axis 6 (if it does)
        d6 = float((T_O_E0[:3, 3] - centre) @ z1)
        T_O_0 = np.eye(4)
        T_O_0[:3, :3], T_O_0[:3, 3] = R0, origin
        if min(abs(a2), abs(a3), abs(d6)) < 1e-6:
            return None
        draft = cls(0.0, a2, a3, d4, d5, d6, signs, T_O_0, np.eye(4))
        T_6_E = np.linalg.inv(draft.flange_pose(q0)) @ T_O_E0
        cand = cls(0.0, a2, a3, d4, d5, d6, signs, T_O_0, T_6_E)
        rng = np.random.default_rng(0)
        for q in [q0, *rng.uniform(-math.pi, math.pi, (n_checks, 6))]:
            pin.forwardKinematics(model, data, q)
            T_model = pin.updateFramePlacement(model, data, flange_frame_id).homogeneous
            if not np.allclose(cand.flange_pose(q), T_model, rtol=0.0, atol=1e-9):
                return None
        for array in (cand.signs, cand.T_O_0, cand.T_6_E):
            array.setflags(write=False)
        return cand


def ur_parameter_array(p: UrParameters) -> np.ndarray:
    """``[d1, a2, a3, d4, d5, d6, s1, ..., s6]`` for :func:`ur_branches_compiled`."""
    return np.array([p.d1, p.a2, p.a3, p.d4, p.d5, p.d6, *p.signs], dtype=float)


def ur_branches(p: UrParameters, T_O_E: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
    """Every IK solution (model joint angles) of the flange pose, joint limits ignored (module docstring).

    Args:
        p: The arm's parameters.
        T_O_E: Flange pose in the model's base frame (4, 4), rigid.
        q_ref: Reference configuration (6,) [rad]: theta6 at the wrist singularity.

    Returns:
        Up to 8 rows (k, 6) [rad] in (-pi, pi]; empty (0, 6) when out of reach.
    """
    out = np.empty((8, 6))
    count = ur_branches_compiled(
        ur_parameter_array(p),
        np.linalg.inv(p.T_O_0),
        np.asarray(T_O_E, dtype=float),
        np.linalg.inv(p.T_6_E),
        float(q_ref[5]),
        out,
    )
    return out[:count].copy()


@jit
def ur_branches_compiled(
    p: np.ndarray, T_0_O: np.ndarray, T_O_C: np.ndarray, T_C_6: np.ndarray, q6_ref: float, out: np.ndarray
) -> int:
    """Branches of the UR closed form into ``out`` (8, 6) [rad], model angles in (-pi, pi]; their count.

    ``p`` from :func:`ur_parameter_array`; T_06 = T_0_O T_O_C T_C_6 (so T_O_C may be the camera
    pose and T_C_6 the camera-to-DH-6 transform, or T_O_E and T_6_E^-1); ``q6_ref`` the model
    angle of joint 6 used at the wrist singularity. The steps of the module docstring.
    """
    d1, a2, a3, d4, d5, d6 = p[0], p[1], p[2], p[3], p[4], p[5]
    T = np.empty((4, 4))
    W = np.empty((4, 4))
    for i in range(4):
        for j in range(4):
            W[i, j] = T_0_O[i, 0] * T_O_C[0, j] + T_0_O[i, 1] * T_O_C[1, j] + T_0_O[i, 2] * T_O_C[2, j]
            W[i, j] += T_0_O[i, 3] * T_O_C[3, j]
    for i in range(4):
        for j in range(4):
            T[i, j] = (
                W[i, 0] * T_C_6[0, j] + W[i, 1] * T_C_6[1, j] + W[i, 2] * T_C_6[2, j] + W[i, 3] * T_C_6[3, j]
            )
    px, py, pz = T[0, 3], T[1, 3], T[2, 3]
    x5, y5, z5 = px - d6 * T[0, 2], py - d6 * T[1, 2], pz - d6 * T[2, 2]
    r = math.hypot(x5, y5)
    if r < abs(d4) or r < SINGULAR_TOL:
        return 0
    psi, phi = math.atan2(y5, x5), math.asin(d4 / r)
    theta6_ref = p[11] * q6_ref
    count = 0
    for shoulder in range(2):
        t1 = psi + phi if shoulder == 0 else psi + math.pi - phi
        c1, s1 = math.cos(t1), math.sin(t1)
        c5 = (s1 * px - c1 * py - d4) / d6
        if abs(c5) > 1.0 + 1e-12:
            continue
        a5 = math.acos(min(1.0, max(-1.0, c5)))
        # R_16 = R_01^T R, rows x1 = (c1, s1, 0), y1 = (0, 0, 1), z1 = (s1, -c1, 0)
        r00, r01, r02 = c1 * T[0, 0] + s1 * T[1, 0], c1 * T[0, 1] + s1 * T[1, 1], c1 * T[0, 2] + s1 * T[1, 2]
        r10, r11, r12 = T[2, 0], T[2, 1], T[2, 2]
        r20, r21 = s1 * T[0, 0] - c1 * T[1, 0], s1 * T[0, 1] - c1 * T[1, 1]
        x4, y4 = c1 * x5 + s1 * y5, z5 - d1  # frame 5's origin in frame 1 (its z1 part is d4)
        for wrist in range(2 if a5 > 0.0 else 1):
            t5 = a5 if wrist == 0 else -a5
            s5, c5_ = math.sin(t5), math.cos(t5)
            if abs(s5) < SINGULAR_TOL:
                t6 = theta6_ref
            else:
                t6 = math.atan2(-r21 / s5, r20 / s5)
            c6, s6 = math.cos(t6), math.sin(t6)
            # Rz(t234) = R_16 Rz(-t6) Ry(t5): its first column
            m00 = r00 * c6 - r01 * s6
            m10 = r10 * c6 - r11 * s6
            col0 = m00 * c5_ - r02 * s5
            col1 = m10 * c5_ - r12 * s5
            t234 = math.atan2(col1, col0)
            x, y = x4 - d5 * math.sin(t234), y4 + d5 * math.cos(t234)  # frame 4's origin: p5 - d5 z4
            c3 = (x * x + y * y - a2 * a2 - a3 * a3) / (2.0 * a2 * a3)
            if abs(c3) > 1.0 + 1e-12:
                continue
            a3_ = math.acos(min(1.0, max(-1.0, c3)))
            for elbow in range(2 if a3_ > 0.0 else 1):
                t3 = a3_ if elbow == 0 else -a3_
                t2 = math.atan2(y, x) - math.atan2(a3 * math.sin(t3), a2 + a3 * math.cos(t3))
                thetas = (t1, t2, t3, t234 - t2 - t3, t5, t6)
                for k in range(6):
                    v = p[6 + k] * thetas[k]
                    out[count, k] = math.pi - (math.pi - v) % (2.0 * math.pi)  # wrap to (-pi, pi]
                count += 1
    return count
