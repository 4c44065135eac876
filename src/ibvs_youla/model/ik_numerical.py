"""Numerical IK for arms without a closed form: damped Gauss-Newton on the frame pose error."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

__all__ = ["numerical_branches"]


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
