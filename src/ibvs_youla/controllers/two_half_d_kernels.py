"""Compiled 2.5-D law on the pose route: the task function e and the twist from the estimated pose, one call.

:meth:`~.two_half_d.TwoHalfD.update` with ``rotation_from="pose"`` takes, at every frame, the
camera pose T_O_C that the controller's estimator gives and computes (module docstring of
:mod:`.two_half_d`, Malis, Chaumette & Boudet 1999):

    c*R_c = (T_c*_O T_O_C)[:3, :3],   [X, Y, Z] = (P_ref_O - t_O_C) R_O_C   (the reference point in {c}),
    rho = Z / Z*,   (x, y) = (X / Z, Y / Z) (the centroid) or the marker's image point,
    e = (x - x*, y - y*, log rho, theta u),
    omega = -lambda theta u,   v = -lambda Z L_v'^-1 r,  r = e_v - L_vw theta u,  Z = rho Z*,

with theta u by :func:`~ibvs_youla.model.rotation_kernels.theta_u_compiled` (scipy's floats).
:func:`pose_route_twist` does this arithmetic in one compiled call, each sum in the order of the
numpy expression it replaces; a dozen small numpy calls cost more than the law itself. Where the
reference must decide (the reference point not in front, rho <= 0, which raises; a matrix that
:func:`theta_u_compiled` leaves to scipy), it returns False and the caller runs the reference
(``TwoHalfD._pose_route_reference``, numpy). ``tests/test_two_half_d.py`` pins it to the reference on
random poses.

Unvalidated: T_O_C and T_target_O (4, 4), reference_O (3,), law (:data:`LAW_SIZE`,) = (Z* [m],
x*, y*, lambda [1/s], marker: the reference point's index, or -1 for the centroid, F [m], the
features per point: 2 monocular, 3 stereo), features (m,) the frame's; twist and error (6,) written.
The image point of a marker is [u, v] / F, or ((u_l + u_r) / 2, v) / F for stereo
(``TwoHalfD``'s own).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit
from ..model.rotation_kernels import theta_u_compiled

__all__ = ["LAW_SIZE", "pose_route_twist"]

LAW_SIZE = 7  # (Z*, x*, y*, lambda, marker index or -1, F, features per point)


@jit
def pose_route_twist(
    T_O_C: np.ndarray,
    T_target_O: np.ndarray,
    reference_O: np.ndarray,
    law: np.ndarray,
    features: np.ndarray,
    twist: np.ndarray,
    error: np.ndarray,
) -> bool:
    """The 2.5-D twist and task function into ``twist`` and ``error`` (module docstring), or False."""
    R = np.empty((3, 3))  # c*R_c, the rotation block of T_c*_O T_O_C
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for k in range(4):
                acc += T_target_O[i, k] * T_O_C[k, j]
            R[i, j] = acc
    d0 = reference_O[0] - T_O_C[0, 3]
    d1 = reference_O[1] - T_O_C[1, 3]
    d2 = reference_O[2] - T_O_C[2, 3]
    X = d0 * T_O_C[0, 0] + d1 * T_O_C[1, 0] + d2 * T_O_C[2, 0]
    Y = d0 * T_O_C[0, 1] + d1 * T_O_C[1, 1] + d2 * T_O_C[2, 1]
    Z = d0 * T_O_C[0, 2] + d1 * T_O_C[1, 2] + d2 * T_O_C[2, 2]
    Z_target, gain = law[0], law[3]
    rho = Z / Z_target
    if not rho > 0.0:
        return False
    marker, F, per = int(law[4]), law[5], int(law[6])
    if marker < 0:
        x, y = X / Z, Y / Z
    elif per == 2:
        x, y = features[2 * marker] / F, features[2 * marker + 1] / F
    else:
        x, y = 0.5 * (features[3 * marker] + features[3 * marker + 1]) / F, features[3 * marker + 2] / F
    tu = np.empty(3)
    if not theta_u_compiled(R, tu):
        return False
    e0, e1, e2 = x - law[1], y - law[2], math.log(rho)
    Z = rho * Z_target
    r0 = e0 - (x * y * tu[0] + -(1.0 + x * x) * tu[1] + y * tu[2])
    r1 = e1 - ((1.0 + y * y) * tu[0] + -x * y * tu[1] + -x * tu[2])
    r2 = e2 - (-y * tu[0] + x * tu[1] + 0.0 * tu[2])
    scale = -gain * Z
    twist[0] = scale * (-r0 - x * r2)
    twist[1] = scale * (-r1 - y * r2)
    twist[2] = scale * -r2
    error[0], error[1], error[2] = e0, e1, e2
    for j in range(3):
        twist[3 + j] = -gain * tu[j]
        error[3 + j] = tu[j]
    return True
