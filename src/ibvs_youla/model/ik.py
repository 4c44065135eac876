"""Inverse kinematics: closed form for IRB 4600-type spherical-wrist arms, numerical otherwise.

The closed form (Section 4.6, Eq. 26-28; Appendix B re-derived, ERRATA 4-5) covers arms
whose standard DH table has the IRB 4600 structure of ERRATA 1::

    (d1, a1, -90 deg, 0), (0, a2, 0, -90 deg), (0, a3, -90 deg, 0),
    (d4, 0, 90 deg, 0), (0, 0, -90 deg, 0), (d6, 0, 0, 0)

i.e. a shoulder offset a1, an elbow offset a3 and a spherical wrist (axes 4-6 meet at
the wrist centre), like the OPW parameterisation with c1 = d1, c2 = a2, c3 = d4,
c4 = d6 and no lateral offset. Derivation, all angles in the vertical plane of joint 1
("angle from the vertical", radial coordinate rho along (cos q1, sin q1)):

* wrist centre ``p_wc = p_E - d6 * z_E``; q1 = atan2(y_wc, x_wc) (front) or + pi (back).
* from joint 2, ``(r, s) = (rho_wc - a1, z_wc - d1) = a2 (sin q2, cos q2)
  + L (sin(q2 + q3 + beta), cos(q2 + q3 + beta))`` with ``L = hypot(a3, d4)``,
  ``beta = atan2(d4, a3)``. Law of cosines: ``cos(q3 + beta) = (r^2 + s^2 - a2^2 - L^2)
  / (2 a2 L)`` (two elbow signs), then ``q2 = atan2(r, s) - atan2(L sin(q3+beta),
  a2 + L cos(q3+beta))``. This replaces (B8)-(B9), whose printed denominator is wrong.
* ``R_3_6 = R_0_3^T R_0_E = Rz(q4) Ry(-q5) Rz(q6)``: ``q5 = atan2(+-sqrt(R02^2 + R12^2), R22)``,
  ``q4 = atan2(-R12 / s5, -R02 / s5)``, ``q6 = atan2(-R21 / s5, R20 / s5)`` (two-argument
  arctangents carrying the sign of s5, ERRATA 5).

Singular poses, where infinitely many solutions exist, return one documented choice:
wrist singularity (|sin q5| < 1e-10, axes 4 and 6 aligned): ``q4 = q_ref[3]`` and the
whole rotation on q6; shoulder singularity (wrist centre within 1e-10 m of axis 1):
``q1 = q_ref[0]`` or ``q_ref[0] + pi``.

The lengths (:class:`SphericalWristParameters`) and the scalar steps above live in
``_ik_closed_form``, the nearest-branch fast path (:func:`nearest_branch`) in ``_ik_nearest``
and the numerical IK (:func:`numerical_branches`) in :mod:`ibvs_youla.model.ik_numerical`;
all are importable from here. Imports go one way: ``ik`` -> ``_ik_nearest`` ->
``_ik_closed_form``.
"""

from __future__ import annotations

import math

import numpy as np

from ._ik_closed_form import (
    SphericalWristParameters,
    elbow_solutions,
    shoulder_solutions,
    wrap_angles,
    wrist_solutions,
)
from ._ik_nearest import nearest_branch
from .ik_numerical import numerical_branches

__all__ = [
    "SphericalWristParameters",
    "closed_form_branches",
    "nearest_branch",
    "numerical_branches",
    "select_branches",
]


def closed_form_branches(
    params: SphericalWristParameters, T_O_E: np.ndarray, q_ref: np.ndarray
) -> np.ndarray:
    """Every IK solution of the flange pose, joint limits ignored (module docstring).

    Args:
        params: Arm lengths.
        T_O_E: Flange pose in the base frame (4, 4), rigid.
        q_ref: Reference configuration (6,) [rad] for the choices at singular poses.

    Returns:
        Up to 8 rows (k, 6) [rad]: shoulder front/back x elbow x wrist flip, angles in
        (-pi, pi] except where a singular choice copies q_ref. Empty (0, 6) when the wrist
        centre is out of reach.
    """
    q4_ref = float(q_ref[3])
    M = np.asarray(T_O_E, dtype=float).tolist()
    centre, shoulders = shoulder_solutions(params, M, float(q_ref[0]))
    rows = [
        (q1, q2, q3, *wrist)
        for q1 in shoulders
        for q2, q3, R36 in elbow_solutions(params, M, centre, q1)
        for wrist in wrist_solutions(*R36, q4_ref)
    ]
    return wrap_angles(np.array(rows, dtype=float).reshape(-1, 6))


def select_branches(
    branches: np.ndarray,
    q_min: np.ndarray,
    q_max: np.ndarray,
    q_near: np.ndarray,
    *,
    tol: float = 1e-9,
    duplicate: float = 1e-6,
    periodic: np.ndarray | None = None,
) -> np.ndarray:
    """Bring solutions into the joint limits and sort them by distance to ``q_near``.

    Each joint angle is replaced by its 2*pi-equivalent within [q_min, q_max] (``tol``
    [rad] of slack, then clipped) that lies nearest ``q_near``; rows with a joint that
    has no such equivalent are dropped, as are rows within ``duplicate`` [rad] of an
    earlier one modulo 2*pi (ties at exactly pi from ``q_near`` would otherwise give two
    rows for one branch). Rows are sorted by Euclidean distance to ``q_near``.

    ``periodic`` (bool (n,), default all True) marks the joints whose coordinate is an angle;
    a prismatic joint's position is taken as it is (checked against its limits, not wrapped).
    """
    if branches.shape[0] == 0:
        return branches
    if periodic is not None and not periodic.all():
        return _select_mixed(branches, q_min, q_max, q_near, tol, duplicate, periodic)
    anchor = np.clip(q_near, q_min, q_max)
    base = anchor + wrap_angles(branches - anchor)  # (k, 6), nearest equivalent to the anchor
    cand = base[..., None] + math.tau * np.arange(-2, 3)  # (k, 6, 5)
    inside = (cand >= (q_min - tol)[:, None]) & (cand <= (q_max + tol)[:, None])
    dist = np.where(inside, np.abs(cand - q_near[:, None]), np.inf).reshape(-1, 5)
    pick = np.argmin(dist, axis=-1)  # first nearest equivalent of each joint
    flat = np.arange(pick.size)
    ok = np.isfinite(dist[flat, pick]).reshape(branches.shape).all(axis=1)
    q = np.clip(cand.reshape(-1, 5)[flat, pick].reshape(branches.shape)[ok], q_min, q_max)
    q = q[np.argsort(np.linalg.norm(q - q_near, axis=1), kind="stable")]
    if q.shape[0] < 2:
        return q
    wrapped = wrap_angles(q[:, None, :] - q[None, :, :])  # (k, k, 6) pairwise differences modulo 2 pi
    near = (np.abs(wrapped).max(axis=-1) <= duplicate).tolist()
    keep: list[int] = []
    for i, row in enumerate(near):
        if not any(row[j] for j in keep):
            keep.append(i)
    return q[keep]


def _select_mixed(
    branches: np.ndarray,
    q_min: np.ndarray,
    q_max: np.ndarray,
    q_near: np.ndarray,
    tol: float,
    duplicate: float,
    periodic: np.ndarray,
) -> np.ndarray:
    """`select_branches` for a chain with prismatic joints: only the periodic joints are wrapped."""
    anchor = np.clip(q_near, q_min, q_max)
    base = np.where(periodic, anchor + wrap_angles(branches - anchor), branches)  # (k, n)
    shifts = np.where(
        periodic[:, None], math.tau * np.arange(-2, 3), np.array([0.0, *[np.nan] * 4])
    )  # (n, 5)
    cand = base[..., None] + shifts  # (k, n, 5); NaN candidates are never inside
    inside = (cand >= (q_min - tol)[:, None]) & (cand <= (q_max + tol)[:, None])
    dist = np.where(inside, np.abs(cand - q_near[:, None]), np.inf).reshape(-1, 5)
    pick = np.argmin(dist, axis=-1)
    flat = np.arange(pick.size)
    ok = np.isfinite(dist[flat, pick]).reshape(branches.shape).all(axis=1)
    q = np.clip(cand.reshape(-1, 5)[flat, pick].reshape(branches.shape)[ok], q_min, q_max)
    q = q[np.argsort(np.linalg.norm(q - q_near, axis=1), kind="stable")]
    if q.shape[0] < 2:
        return q
    diff = q[:, None, :] - q[None, :, :]
    wrapped = np.where(periodic, wrap_angles(diff), diff)
    near = (np.abs(wrapped).max(axis=-1) <= duplicate).tolist()
    keep: list[int] = []
    for i, row in enumerate(near):
        if not any(row[j] for j in keep):
            keep.append(i)
    return q[keep]
