"""The joint loop alone on the nonlinear arm: feedback linearization + Youla controller.

Section 6.1 designs the inner loop on the linear model q'' = v (Eq. (34)) obtained by
feedback linearization u = M(q) v + h(q, dq) (Eq. (33)), and promises the closed loop
T = (3 tau s + 1) / (tau s + 1)^3 (Eq. (41), (46)). :func:`inner_step_response` runs
that loop against the full Pinocchio dynamics, so the promise can be checked and the
cost of an imperfect model studied (``model_inertia_scale``). It is built from the
servo loop's own parts: the inner-loop adapter
:class:`~ibvs_youla.simulation.actuation.InnerLoopActuator` (Eq. (33)-(46), the only
implementation of them) drives the dynamic-arm plant
:class:`~ibvs_youla.simulation.plant.ArmPlant` (RK4, torque held).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._memory import fits_in_memory
from .._validation import as_array, positive
from ..exceptions import InvalidParameterError
from ..model.arm import Arm
from .actuation import InnerLoopActuator
from .plant import ArmPlant

__all__ = ["inner_step_response"]


def inner_step_response(
    arm: Arm,
    q0: Any,
    step: Any,
    duration: float = 0.1,
    *,
    tau_in: float = 0.01,
    dt: float = 1e-3,
    model_inertia_scale: float = 1.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joint response to a step of the reference q_ref = q0 + step at t = 0.

    The arm starts at rest at ``q0`` with the controller at rest (gravity is held by
    h(q, dq) of the feedback linearization). At every sample the actuator turns the
    encoder reading into a torque, which the plant holds over one step ``dt``.

    Args:
        arm: The plant (and, unless ``model_inertia_scale`` != 1, the controller's model).
        q0: Initial joint angles (n,) [rad].
        step: Step of the reference (n,) [rad].
        duration: Simulated time [s].
        tau_in: Inner-loop time constant [s] (Eq. (41)).
        dt: Joint-loop sample time [s].
        model_inertia_scale: Link masses and inertias of the controller's model are
            multiplied by this factor (1 = exact linearization).

    Returns:
        ``(t (N,), q (N, n), tau (N, n))``: sample times [s], joint angles [rad], torques [N m].
    """
    q0 = as_array(q0, "q0", (arm.nq,))
    step = as_array(step, "step", (arm.nq,))
    duration = positive(duration, "duration", unit="s")
    dt = positive(dt, "dt", unit="s")
    model = arm if model_inertia_scale == 1.0 else arm.with_inertia_scale(model_inertia_scale)
    actuator = InnerLoopActuator(model, tau_in, dt)
    plant = ArmPlant(arm, q_encoder=q0)
    steps = duration / dt  # a float: checked before it is rounded (1e308 / 1e-3 is inf)
    if steps < 1.0 - 1e-9:
        raise InvalidParameterError("duration", duration, f"at least one sample, dt = {dt:g} s")
    bytes_needed = 8.0 * (steps + 1.0) * (1 + 2 * arm.nq)  # t, q, tau
    fits_in_memory(bytes_needed, "duration", duration, "a shorter duration or a larger dt")
    n = round(steps)
    t = np.arange(n + 1) * dt
    q = np.empty((n + 1, arm.nq))
    tau = np.empty((n + 1, arm.nq))
    q_ref = q0 + step
    for k in range(n + 1):
        reading = plant.reading()
        tau[k] = actuator(q_ref, reading)
        q[k] = reading.q
        if k < n:
            plant.step(tau[k], dt)
    return t, q, tau
