"""Small SE(3) helpers on 4x4 homogeneous matrices (internal, unvalidated, hot-path safe).

Frames follow docs/conventions.md: ``T_A_B`` is the pose of frame B in frame A, so
``P_A = transform_points(T_A_B, P_B)``. Logarithms and exponentials come from Pinocchio.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin


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


def pose_error(T_est: np.ndarray, T_ref: np.ndarray) -> tuple[float, float]:
    """Return (rotation error [rad], translation error [m]) between two poses.

    The rotation error is the angle of R_ref^T R_est (geodesic distance on SO(3)); same
    computation as :func:`ibvs_youla.analysis.metrics.pose_error`, in SI units.
    """
    from .analysis.metrics import pose_error_series

    position_mm, rotation_deg = pose_error_series(
        np.asarray(T_est, dtype=float)[None], np.asarray(T_ref, dtype=float)
    )
    return float(np.radians(rotation_deg[0])), float(position_mm[0]) / 1000.0


def exp_twist(xi: np.ndarray) -> np.ndarray:
    """Return the 4x4 pose exp([v; w]) of a twist (linear part first, as Pinocchio)."""
    return pin.exp6(pin.Motion(np.asarray(xi, dtype=float))).homogeneous
