"""Compiled stereo P3P: triangulation and the Kabsch fit of Appendix C in one call.

:func:`camera_pose_from_features` is the Numba-compiled twin (:func:`ibvs_youla._jit.jit`) of
``kabsch_centred(triangulate_points(camera, features, allow_behind), Q_O, c_O)``
(:mod:`ibvs_youla.estimation.stereo_pose`, :mod:`ibvs_youla.model.camera`): the markers
triangulated from the stereo features (Eq. (C6)-(C8)), their centroid and cross-covariance with
the fixed markers (Eq. (C10)-(C14)), the SVD (Eq. (C15), LAPACK ``dgesdd``,
:func:`ibvs_youla._linalg.gesdd`) and R = V diag(1, 1, det(V U^T)) U^T, t = c_O - R c_C
(Eq. (C16)-(C17)). It is the first half of the configuration estimate of Eq. (62); the second
is the arm's nearest IK branch
(:mod:`ibvs_youla.model.ik_kernels`). Unvalidated; pinned to the reference by
``tests/test_compiled_kernels.py``.
"""

from __future__ import annotations

import numpy as np

from .._jit import jit
from .._linalg import gesdd
from ..model.camera_kernels import triangulate

__all__ = ["camera_pose_from_features", "kabsch_centred_compiled"]


@jit
def _det3(M: np.ndarray) -> float:
    return (
        M[0, 0] * (M[1, 1] * M[2, 2] - M[1, 2] * M[2, 1])
        - M[0, 1] * (M[1, 0] * M[2, 2] - M[1, 2] * M[2, 0])
        + M[0, 2] * (M[1, 0] * M[2, 1] - M[1, 1] * M[2, 0])
    )


@jit
def kabsch_centred_compiled(P_from: np.ndarray, Q_to: np.ndarray, c_to: np.ndarray) -> np.ndarray:
    """T_to_from (4, 4) with P_to = Q_to + c_to ≈ R P_from + t: ``stereo_pose.kabsch_centred``."""
    n = P_from.shape[0]
    c_from = np.zeros(3)
    for i in range(n):  # Eq. (C10), the mean
        for a in range(3):
            c_from[a] += P_from[i, a]
    c_from /= n
    H = np.zeros((3, 3))  # Eq. (C12)-(C14): sum_i P'_from,i P'_to,i^T
    for i in range(n):
        for a in range(3):
            pa = P_from[i, a] - c_from[a]
            for b in range(3):
                H[a, b] += pa * Q_to[i, b]
    U, _, Vt, _ = gesdd(H)  # Eq. (C15): H = U S V^T (finite H: LAPACK does not fail on 3x3)
    flip = -1.0 if _det3(Vt) * _det3(U) < 0.0 else 1.0  # det(V U^T) = -1: a reflection, fixed
    T = np.eye(4)
    for a in range(3):
        for b in range(3):  # Eq. (C16): R = V diag(1, 1, flip) U^T
            T[a, b] = Vt[0, a] * U[b, 0] + Vt[1, a] * U[b, 1] + flip * Vt[2, a] * U[b, 2]
    for a in range(3):  # Eq. (C17): t = c_to - R c_from
        T[a, 3] = c_to[a] - (T[a, 0] * c_from[0] + T[a, 1] * c_from[1] + T[a, 2] * c_from[2])
    return T


@jit
def camera_pose_from_features(
    features: np.ndarray,
    params: np.ndarray,
    allow_behind: bool,
    markers_centred: np.ndarray,
    markers_mean: np.ndarray,
) -> tuple[np.ndarray, int]:
    """(T_O_C (4, 4), first marker of bad disparity or -1): stereo P3P of fixed markers.

    Args:
        features: Stereo features (3n,) [m].
        params: The camera, from :func:`~ibvs_youla.model.camera_kernels.camera_parameters`.
        allow_behind: Accept negative disparities (virtual points, ERRATA 13).
        markers_centred: The markers minus their mean (n, 3) [m], in the base frame {O}.
        markers_mean: Their mean (3,) [m].
    """
    P_C, bad = triangulate(features, params, allow_behind)
    if bad >= 0:
        return np.eye(4), bad
    return kabsch_centred_compiled(P_C, markers_centred, markers_mean), -1
