"""Numerical IK for arms without a closed form: damped Gauss-Newton on the frame pose error.

Two entry points:

* :func:`solve_near` — the warm start of Eq. (62) at camera rate: damped Newton from one
  configuration (the previous estimate), which converges in a few iterations when the camera
  moved little since. On a redundant arm (n > 6 joints) the camera pose fixes a manifold of
  dimension n - 6 of configurations, and each step also pulls towards a reference along the
  null space of the camera Jacobian, so that the solution is the one nearest the reference:
  a configuration q with ``FK(q) = T`` and ``N(q) (q - q_ref) = 0``, ``N = I - J^+ J`` (the first-
  order condition of min |q - q_ref| subject to FK(q) = T: q - q_ref is orthogonal to the
  self-motion directions).
* :func:`numerical_branches` — the seeded search: the same iteration without the pull, from
  many starts, for a first estimate or when the warm start fails.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

__all__ = ["NEAREST_TOL", "numerical_branches", "solve_near"]

NEAREST_TOL = (
    1e-9  # max_i |(N(q) (q - q_ref))_i| [rad or m] accepted as nearest the reference (redundant arms)
)
_STEP_CAP = 0.5  # largest joint step of one iteration [rad or m]


def solve_near(
    model: pin.Model,
    data: pin.Data,
    frame_id: int,
    T_O_F: np.ndarray,
    q_start: np.ndarray,
    q_ref: np.ndarray | None = None,
    *,
    tol: float = 1e-12,
    max_iter: int = 30,
) -> np.ndarray | None:
    """IK of a frame pose by damped Newton from ``q_start`` (module docstring), or None.

    Each iteration: the LOCAL error ``e = log6(T_O_F(q)^-1 T_O_F)`` and the LOCAL frame Jacobian J
    (6, n) from one kinematics pass; with J^# = J^T (J J^T + lam I)^-1 (lam = 1e-4 while |e| >
    1e-3, then 1e-12: damped least squares far from the pose, Newton near it):

    * six joints: ``dq = J^# e``;
    * a redundant arm: ``dq = d + J^# (e - J d)``, d = q_ref - q, i.e. J^# e + (I - J^# J) d: the
      Gauss-Newton step of min |q - q_ref|^2 subject to FK(q) = T on the linearized constraint
      (the null-space pull towards q_ref, in one solve).

    Steps are capped at 0.5 per joint. It stops when |e| < ``tol`` and, redundant, max_i |dq_i| <=
    :data:`NEAREST_TOL` (then max_i |(N (q_ref - q))_i| <= NEAREST_TOL + |J^# e|: the first-order
    condition).

    Args:
        model: Pinocchio model (not modified).
        data: Its data (overwritten).
        frame_id: Frame to place.
        T_O_F: Target pose (4, 4), rigid.
        q_start: Start configuration (n,).
        q_ref: The configuration the solution is nearest on a redundant arm; default ``q_start``.
        tol: Convergence threshold on |log6| (metres and radians).
        max_iter: Iterations before giving up.

    Returns:
        The configuration (n,), unwrapped, or None when it did not converge.
    """
    target = pin.SE3(T_O_F[:3, :3], T_O_F[:3, 3])
    q = np.array(q_start, dtype=float)
    ref = q.copy() if q_ref is None else np.asarray(q_ref, dtype=float)
    redundant = model.nv > 6
    eye = np.eye(6)
    for _ in range(max_iter):
        pin.computeJointJacobians(model, data, q)  # the kinematics pass: joint placements and Jacobians
        J = pin.getFrameJacobian(model, data, frame_id, pin.LOCAL)
        err = pin.log6(pin.updateFramePlacement(model, data, frame_id).actInv(target)).vector
        norm = float(np.linalg.norm(err))
        lam = 1e-4 if norm > 1e-3 else 1e-12
        if redundant:
            d = ref - q
            dq = d + J.T.dot(np.linalg.solve(J.dot(J.T) + lam * eye, err - J.dot(d)))
            if norm < tol and float(np.abs(dq).max()) <= NEAREST_TOL:
                return q
        else:
            if norm < tol:
                return q
            dq = J.T.dot(np.linalg.solve(J.dot(J.T) + lam * eye, err))
        step = float(np.abs(dq).max())
        q = q + (dq if step <= _STEP_CAP else dq * (_STEP_CAP / step))
    return None


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
