"""Small SE(3) helpers on 4x4 homogeneous matrices (internal, hot-path safe).

Frames follow docs/conventions.md: ``T_A_B`` is the pose of frame B in frame A, so
``P_A = transform_points(T_A_B, P_B)``. Logarithms and exponentials come from Pinocchio.
Unvalidated, except :func:`pose_error_mm_deg`, which checks its two poses (it is public
as :func:`ibvs_youla.analysis.metrics.pose_error_mm_deg`).

The distance between two poses is measured one way everywhere (estimation tests,
convergence, metrics): ``|p_A - p_B|`` in mm and the angle of ``R_err = R_A^T R_B`` in
degrees, ``atan2(|vee(R_err - R_err^T)| / 2, (tr R_err - 1) / 2)``, accurate near 0 and
pi. Both are symmetric in A and B.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._validation import as_pose


def make_pose(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Return the 4x4 homogeneous transform [[R, t], [0, 1]]."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = t
    return T


def inverse_pose(T_A_B: np.ndarray) -> np.ndarray:
    """Return T_B_A = T_A_B^-1 in closed form (R^T, -R^T t)."""
    R = T_A_B[:3, :3]
    return make_pose(R.T, -R.T @ T_A_B[:3, 3])


def transform_points(T_A_B: np.ndarray, P_B: np.ndarray) -> np.ndarray:
    """Map points (n, 3) from frame B to frame A: P_A = R P_B + t (row-wise)."""
    return P_B @ T_A_B[:3, :3].T + T_A_B[:3, 3]


def pose_error_mm_deg(T_O_A: Any, T_O_B: Any) -> tuple[float, float]:
    """Distance between two poses: (position [mm], rotation angle of ``R_A^T R_B`` [deg]).

    Raises:
        InvalidArrayError: ``T_O_A`` or ``T_O_B`` is not a rigid (4, 4) transform.
    """
    T_O_A = as_pose(T_O_A, "T_O_A")
    T_O_B = as_pose(T_O_B, "T_O_B")
    position_mm, rotation_deg = pose_error_series_mm_deg(T_O_A[None], T_O_B)
    return float(position_mm[0]), float(rotation_deg[0])


def pose_error_series_mm_deg(T_O_A: np.ndarray, T_O_B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`pose_error_mm_deg` of a pose sequence (N, 4, 4) against one pose (4, 4), unvalidated.

    Returns:
        ``(position [mm] (N,), rotation [deg] (N,))`` (module docstring).
    """
    position_mm = 1000.0 * np.linalg.norm(T_O_A[:, :3, 3] - T_O_B[:3, 3], axis=1)
    R_err = np.einsum("nji,jk->nik", T_O_A[:, :3, :3], T_O_B[:3, :3])  # R_A^T R_B
    skew = R_err - np.transpose(R_err, (0, 2, 1))
    vee = np.stack([skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]], axis=1)
    sin_angle = 0.5 * np.linalg.norm(vee, axis=1)
    cos_angle = 0.5 * (np.trace(R_err, axis1=1, axis2=2) - 1.0)
    return position_mm, np.degrees(np.arctan2(sin_angle, cos_angle))


def exp_twist(xi: np.ndarray) -> np.ndarray:
    """Return the 4x4 pose exp([v; w]) of a twist (linear part first, as Pinocchio).

    Pinocchio's ``exp6`` of the (6,) vector (the same pose, bit for bit, as of a
    ``pin.Motion`` of it, without building one), at every tick of the free camera.
    """
    return _exp6(np.asarray(xi, dtype=float)).homogeneous


def _exp6(xi: np.ndarray) -> Any:
    """``pinocchio.exp6``: imported at the first call, then bound in place of this function.

    Imported here, not with the module, so that importing results (and viz) does not load Pinocchio.
    """
    global _exp6
    import pinocchio as pin

    _exp6 = pin.exp6
    return pin.exp6(xi)
