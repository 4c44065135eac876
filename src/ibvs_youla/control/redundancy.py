"""Redundancy: a secondary task in the null space of the camera Jacobian, joint-limit avoidance first.

On an arm of n > 6 joints the camera twist [v; w] (6,) fixes only six of the n joint velocities:
``dq = J_C^+ [v; w] + (I - J_C^+ J_C) z`` moves the camera by the same twist for every z (the
self-motion). A method that commands a camera twist (the actuation's
:class:`~ibvs_youla.simulation.actuation.TwistToJointVelocity`) adds ``dq2 = N z`` with
N = I - J_C^+ J_C, off by default (:class:`JointLimitAvoidance` turns it on).

**Joint-limit avoidance** (Marey & Chaumette 2010, "A new large projection operator for the
redundancy framework", and ViSP's ``vpServo::secondaryTaskJointLimitAvoidance``), for each joint
i with range D_i = q_max,i - q_min,i:

* an activation band: the task starts inside ``[q_min + rho D, q_max - rho D]``'s complement
  (thresholds q_l0) and is at full gain beyond ``q_l0 -+ rho rho1 D`` (thresholds q_l1);
* g_i = -e_i below q_l0_min, +e_i above q_l0_max; ``P g_i`` its projection (here N: the commanded
  twist is the primary task and takes all of its six degrees of freedom, so the large projection
  operator, which needs the image error, reduces to N);
* with dq1 = J_C^+ [v; w] the primary task's joint velocity and ``b = |dq1_i| / |(P g_i)_i|``,
  when b < 1: ``dq2 += -lambda_l (1 + lambda_tune) b P g_i``, lambda_l = 1 beyond q_l1 and the
  sigmoid ``1 / (1 + exp(-12 (q_i - q_l0) / (q_l1 - q_l0) + 6))`` between q_l0 and q_l1.

So a joint that the primary task drives towards its limit at |dq1_i| is driven back at
lambda_tune |dq1_i| (beyond q_l1), through the self-motion only: the camera twist is unchanged.
Joints without finite limits (continuous ones) take no part. ViSP's defaults: rho = 0.1,
rho1 = 0.3, lambda_tune = 0.7.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from .._validation import real
from ..exceptions import InvalidParameterError

__all__ = ["JointLimitAvoidance", "joint_limit_avoidance", "secondary_task_from"]


@dataclass(frozen=True)
class JointLimitAvoidance:
    """The joint-limit avoidance task of a redundant arm (module docstring), validated.

    Attributes:
        rho: Width of the activation band, a fraction of each joint's range, in (0, 0.5).
        rho1: Width of the sigmoid ramp, a fraction of ``rho``'s band, in (0, 1].
        lambda_tune: How much faster the task pushes back than the primary task pushes, in [0, 1].
    """

    rho: float = 0.1
    rho1: float = 0.3
    lambda_tune: float = 0.7

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "rho", real(self.rho, "rho", low=0.0, high=0.5, low_open=True, high_open=True))
        set_(self, "rho1", real(self.rho1, "rho1", low=0.0, high=1.0, low_open=True))
        set_(self, "lambda_tune", real(self.lambda_tune, "lambda_tune", low=0.0, high=1.0))

    def to_dict(self) -> dict[str, Any]:
        """Plain data, with the task's kind (``{"kind": "joint_limit_avoidance", "rho": ...}``)."""
        return {"kind": "joint_limit_avoidance", **asdict(self)}


def secondary_task_from(value: Any) -> JointLimitAvoidance | None:
    """A secondary task from itself, its :meth:`~JointLimitAvoidance.to_dict` data, or None.

    Raises:
        InvalidParameterError: anything else, or an unknown kind.
    """
    if value is None or isinstance(value, JointLimitAvoidance):
        return value
    if isinstance(value, Mapping):
        data = dict(value)
        kind = data.pop("kind", "joint_limit_avoidance")
        if kind == "joint_limit_avoidance" and set(data) <= {"rho", "rho1", "lambda_tune"}:
            return JointLimitAvoidance(**data)
    raise InvalidParameterError(
        "secondary_task",
        value,
        "None, a JointLimitAvoidance, or its data {'kind': 'joint_limit_avoidance', 'rho', 'rho1', "
        "'lambda_tune'}",
    )


def joint_limit_avoidance(
    task: JointLimitAvoidance,
    q: np.ndarray,
    dq1: np.ndarray,
    q_min: np.ndarray,
    q_max: np.ndarray,
    N: np.ndarray,
) -> np.ndarray:
    """dq2 (n,): the joint-limit avoidance velocity of the module docstring, in the null space of N's J.

    Args:
        task: Its settings.
        q: Joint positions (n,) [rad or m] (the encoders).
        dq1: The primary task's joint velocity (n,).
        q_min: Lower joint limits (n,) (infinite for continuous joints: skipped).
        q_max: Upper joint limits (n,).
        N: The null-space projector I - J^+ J (n, n).
    """
    out = np.zeros(q.shape[0])
    rho, rho1, tune = task.rho, task.rho1, task.lambda_tune
    for i in range(q.shape[0]):
        span = q_max[i] - q_min[i]
        if not math.isfinite(span):
            continue
        l0_min, l0_max = q_min[i] + rho * span, q_max[i] - rho * span
        if l0_min < q[i] < l0_max:
            continue
        l1_min, l1_max = l0_min - rho * rho1 * span, l0_max + rho * rho1 * span
        sign = 1.0 if q[i] >= l0_max else -1.0
        Pg = sign * N[:, i]
        if abs(Pg[i]) < 1e-12:  # the joint cannot move without moving the camera
            continue
        b = abs(dq1[i]) / abs(Pg[i])
        if b >= 1.0:  # ViSP's rule: the primary task moves the joint too fast for the task to act
            continue
        if q[i] > l1_max or q[i] < l1_min:
            gain = 1.0
        else:
            l0, l1 = (l0_max, l1_max) if sign > 0 else (l0_min, l1_min)
            gain = 1.0 / (1.0 + math.exp(-12.0 * (q[i] - l0) / (l1 - l0) + 6.0))
        out -= gain * (1.0 + tune) * b * Pg
    return out
