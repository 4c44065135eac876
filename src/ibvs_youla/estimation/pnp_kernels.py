"""Compiled depths of known points in the pose OpenCV's ``solvePnP`` returns, from its (rvec, tvec).

A monocular law at the current features takes each point's depth in the pose the PnP gives,
Z_i = r_3 . P_i + t_z, with r_3 the third row of R_C_ref = exp([rvec]x) and t_z the last entry of
tvec (:meth:`~.monocular_pose.CameraPoseEstimator.marker_depths`, which calls OpenCV's
``Rodrigues`` and then numpy). :func:`pnp_depths` does the same arithmetic in one compiled call,
for the compiled frame path, where the two numpy calls, ``Rodrigues`` and the finiteness test cost
8.5 of the 29 us an IPPE frame's depths took (``docs/benchmarks.md``).

Rodrigues' formula as OpenCV evaluates it (``cv::Rodrigues``, rotation vector to matrix):
theta = |r|; below DBL_EPSILON, R = I; otherwise, with u = r / theta (r times 1 / theta),
R = cos(theta) I + (1 - cos(theta)) u u^T + sin(theta) [u]x, summed in that order. Its third row is
(c1 u_z u_x - s u_y, c1 u_z u_y + s u_x, c + c1 u_z u_z). ``tests/test_pnp_kernels.py`` pins the
kernel to ``cv2.Rodrigues`` and numpy over random and tiny rotations.

Unvalidated: rvec and tvec (3, 1) float64 as ``solvePnP`` returns them, P (n, 3), out (n,).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit

__all__ = ["pnp_depths"]

_DBL_EPSILON = 2.220446049250313e-16


@jit
def pnp_depths(rvec: np.ndarray, tvec: np.ndarray, P: np.ndarray, out: np.ndarray) -> bool:
    """Z_C (n,) [m] of the points P (n, 3) in the pose (rvec, tvec) into ``out``; False if it is not finite.

    False (``out`` untouched) when an entry of rvec or tvec is not finite: OpenCV found no pose
    (the caller's checked path says so).
    """
    for i in range(3):
        if not (math.isfinite(rvec[i, 0]) and math.isfinite(tvec[i, 0])):
            return False
    rx, ry, rz = rvec[0, 0], rvec[1, 0], rvec[2, 0]
    theta = math.sqrt(rx * rx + ry * ry + rz * rz)
    if theta < _DBL_EPSILON:
        r0, r1, r2 = 0.0, 0.0, 1.0
    else:
        c, s = math.cos(theta), math.sin(theta)
        c1 = 1.0 - c
        itheta = 1.0 / theta
        ux, uy, uz = rx * itheta, ry * itheta, rz * itheta
        r0 = c * 0.0 + c1 * (uz * ux) + s * -uy
        r1 = c * 0.0 + c1 * (uz * uy) + s * ux
        r2 = c * 1.0 + c1 * (uz * uz) + s * 0.0
    tz = tvec[2, 0]
    for i in range(P.shape[0]):
        out[i] = P[i, 0] * r0 + P[i, 1] * r1 + P[i, 2] * r2 + tz
    return True
