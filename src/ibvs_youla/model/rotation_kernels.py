"""Compiled theta u of a rotation matrix: scipy's ``Rotation.from_matrix(R).as_rotvec()``, same floats.

PBVS, 2.5-D visual servoing and the hybrid law take the angle-axis vector theta u of a rotation
at every camera frame. SciPy's ``Rotation.from_matrix(R).as_rotvec()`` computes it in compiled
code, but its array-API wrapper (type promotion, the determinant and the orthogonality test of
the Gram matrix through numpy, the ``Rotation`` object) costs about 25 us of its 30.
:func:`theta_u_compiled` does the same arithmetic in one compiled call, in the same order, so
that it gives the same floats (pinned bit for bit by ``tests/test_compiled_kernels.py``):

1. the matrix must be a rotation: scipy checks det R > 0 and that R R^T equals I to its
   tolerance (``np.isclose`` with ``atol = 1e-12``, ``rtol = 1e-5``), and otherwise replaces R by
   the nearest rotation (an SVD). The kernel handles only matrices that pass that test with half
   the tolerance (a margin that the last bits of a differently summed Gram matrix cannot cross)
   and det R > 1/2; for any other it returns False and the caller calls scipy;
2. the unit quaternion by the largest of (R00, R11, R22, tr R) (Shepperd; Markley 2008), then
   divided by its norm;
3. its sign chosen with w >= 0 (so that theta <= pi), theta = 2 atan2(|q_v|, w), and
   theta u = (theta / sin(theta / 2)) q_v, or the series 2 + theta^2 / 12 + 7 theta^4 / 2880 of
   that factor for theta <= 1e-3.

Unvalidated: a float64 (3, 3) array; the result goes into ``out`` (3,).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit

__all__ = ["theta_u_compiled"]

_OFF_DIAGONAL_TOL = 0.5e-12  # half of np.isclose(R R^T, I, atol=1e-12)'s off-diagonal tolerance
_DIAGONAL_TOL = 0.5 * (1e-12 + 1e-5)  # half of its diagonal tolerance (atol + rtol * 1)


@jit
def _clearly_a_rotation(R: np.ndarray) -> bool:
    """True when R is finite, det R > 1/2 and R R^T = I within half of scipy's tolerance."""
    for i in range(3):
        for j in range(3):
            if not math.isfinite(R[i, j]):
                return False
    det = (
        R[0, 0] * (R[1, 1] * R[2, 2] - R[1, 2] * R[2, 1])
        - R[0, 1] * (R[1, 0] * R[2, 2] - R[1, 2] * R[2, 0])
        + R[0, 2] * (R[1, 0] * R[2, 1] - R[1, 1] * R[2, 0])
    )
    if not det > 0.5:
        return False
    for i in range(3):
        for j in range(3):
            g = R[i, 0] * R[j, 0] + R[i, 1] * R[j, 1] + R[i, 2] * R[j, 2]
            if i == j:
                if not abs(g - 1.0) <= _DIAGONAL_TOL:
                    return False
            elif not abs(g) <= _OFF_DIAGONAL_TOL:
                return False
    return True


@jit
def theta_u_compiled(R: np.ndarray, out: np.ndarray) -> bool:
    """Theta u (3,) [rad] of the rotation R (3, 3) into ``out``, True; or False, out untouched.

    False when R is not clearly a rotation (module docstring): then call scipy's
    ``Rotation.from_matrix``.
    """
    if not _clearly_a_rotation(R):
        return False
    q = np.empty(4)  # [x, y, z, w]
    trace = R[0, 0] + R[1, 1] + R[2, 2]
    choice, largest = 0, R[0, 0]
    if R[1, 1] > largest:
        choice, largest = 1, R[1, 1]
    if R[2, 2] > largest:
        choice, largest = 2, R[2, 2]
    if trace > largest:
        choice = 3
    if choice != 3:
        i = choice
        j = (i + 1) % 3
        k = (j + 1) % 3
        q[i] = 1.0 - trace + 2.0 * R[i, i]
        q[j] = R[j, i] + R[i, j]
        q[k] = R[k, i] + R[i, k]
        q[3] = R[k, j] - R[j, k]
    else:
        q[0] = R[2, 1] - R[1, 2]
        q[1] = R[0, 2] - R[2, 0]
        q[2] = R[1, 0] - R[0, 1]
        q[3] = 1.0 + trace
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for c in range(4):
        q[c] /= norm
    if q[3] < 0.0 or (
        q[3] == 0.0 and (q[0] < 0.0 or (q[0] == 0.0 and (q[1] < 0.0 or (q[1] == 0.0 and q[2] < 0.0))))
    ):
        for c in range(4):
            q[c] *= -1.0
    angle = 2.0 * math.atan2(math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]), q[3])
    if angle <= 1e-3:
        angle2 = angle * angle
        scale = 2.0 + angle2 / 12.0 + 7.0 * angle2 * angle2 / 2880.0
    else:
        scale = angle / math.sin(angle / 2.0)
    out[0] = scale * q[0]
    out[1] = scale * q[1]
    out[2] = scale * q[2]
    return True
