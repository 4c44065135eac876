"""Fixed-step fourth-order Runge-Kutta integration.

The plant (the arm's rigid-body dynamics, Eq. (29)) is integrated with the classical
RK4 scheme at a fixed step, the digital controller's sample period or a divisor of it.
RK4 has local error O(dt^5) and global error O(dt^4): halving the step divides the error
of a smooth trajectory by about 16 (``tests/test_integrators.py`` measures the order).

Control inputs are held constant over a step (zero-order hold, as the DAC of a
digital joint controller would hold them), so the integrated right-hand side is
smooth inside the step and the fourth order holds step by step. A torque that
changes *within* a step (a continuous-time controller) is not what this models.

Three entry points:

* :func:`rk4_step` — generic, for any ODE ``dx/dt = f(t, x)`` on a flat state vector.
* :func:`rk4_arm_step` — specialised for a joint-space arm ``ddq = FD(q, dq, tau)``
  with ``tau`` held, on the packed state ``x = [q; dq]``: no time argument (the arm is
  autonomous for a held torque), four forward-dynamics calls per step, the stage
  derivatives in a reusable scratch array. Joint coordinates are added directly
  (``q + dt * dq``), which is exact for revolute and prismatic joints (configuration
  space R^n), the case of the IRB 4600. It does not validate its arguments.
* :class:`ArmRk4` — :func:`rk4_arm_step` of an :class:`~ibvs_youla.model.arm.Arm`'s
  ``forward_dynamics``, the plant's integrator (:class:`~ibvs_youla.simulation.plant.ArmPlant`):
  the ABA four times, and between the calls one compiled kernel (:func:`ibvs_youla._jit.jit`)
  that stores the stage derivative and forms the next stage's state and torque
  ``tau - tau_f(dq)`` (the damping and the plant's joint friction, :class:`ArmRk4`); the last
  one also forms x + dt (k1 + 2 k2 + 2 k3 + k4) / 6 and tests it against the plant's
  divergence bounds. The same stages, none skipped. For an arm of single-axis revolute
  joints (the IRB 4600) the whole step is one compiled call, :func:`rk4_aba_step`, with the ABA
  of :mod:`ibvs_youla.model.dynamics_kernels` (Pinocchio's model, its numbers read once);
  otherwise Pinocchio's ``pin.aba`` is called between the compiled stages.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pinocchio as pin

from .._jit import jit, jit_available
from ..model.arm import ABA_CONVENTION
from ..model.dynamics_kernels import ChainDynamics, aba_compiled

__all__ = ["ArmRk4", "rk4_aba_step", "rk4_arm_step", "rk4_step"]

OdeRhs = Callable[[float, np.ndarray], np.ndarray]
ForwardDynamics = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def rk4_step(f: OdeRhs, t: float, x: np.ndarray, dt: float) -> np.ndarray:
    """Advance ``dx/dt = f(t, x)`` by one classical RK4 step.

    ``x(t + dt) ~ x + dt/6 (k1 + 2 k2 + 2 k3 + k4)`` with
    ``k1 = f(t, x)``, ``k2 = f(t + dt/2, x + dt/2 k1)``, ``k3 = f(t + dt/2, x + dt/2 k2)``,
    ``k4 = f(t + dt, x + dt k3)``. Local error O(dt^5), global error O(dt^4).

    Inputs that ``f`` reads from outside (e.g. a torque) are whatever ``f`` closes over;
    keep them constant during the step for a zero-order hold.

    Args:
        f: Right-hand side, ``f(t, x) -> dx/dt`` with the shape of ``x``.
        t: Time at the start of the step [s].
        x: State at time ``t`` (not modified).
        dt: Step [s]; any finite value (negative integrates backwards).

    Returns:
        The state at ``t + dt`` (a new array).
    """
    x = np.asarray(x, dtype=float)
    half = 0.5 * dt
    k1 = np.asarray(f(t, x), dtype=float)
    k2 = np.asarray(f(t + half, x + half * k1), dtype=float)
    k3 = np.asarray(f(t + half, x + half * k2), dtype=float)
    k4 = np.asarray(f(t + dt, x + dt * k3), dtype=float)
    return x + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


_RK4_WEIGHTS = np.array([1.0, 2.0, 2.0, 1.0]) / 6.0


def rk4_arm_step(
    forward_dynamics: ForwardDynamics,
    x: np.ndarray,
    tau: np.ndarray,
    dt: float,
    k: np.ndarray | None = None,
) -> np.ndarray:
    """Advance joint-space arm dynamics by one RK4 step, torque held (zero-order hold).

    Integrates ``dq/dt = v``, ``dv/dt = FD(q, v, tau)`` (Eq. (29) solved for the
    acceleration) with ``tau`` constant over ``[t, t + dt]``: :func:`rk4_step` on the
    packed state ``x = [q; dq]``. Each stage state is ``x + c k_i`` with ``k_i = [v_i; a_i]``
    written into row i of ``k`` (4, 2n), and the update is one product
    ``x + dt (w @ k)``, w = (1, 2, 2, 1)/6.

    Does not validate its arguments, which must be finite float arrays of the shapes below.

    Args:
        forward_dynamics: ``FD(q, dq, tau) -> ddq`` [rad/s^2], e.g. ``arm.forward_dynamics``
            or its kernel ``arm.aba``; its result is copied at once, so it may reuse a buffer.
        x: ``[q; dq]`` at the start of the step (2n,) [rad, rad/s] (not modified).
        tau: Joint torques held over the step (n,) [N m].
        dt: Step [s].
        k: Scratch array (4, 2n) for the stage derivatives (the plant reuses one); ``None``
            allocates it.

    Returns:
        ``[q; dq]`` at the end of the step, a new (2n,) array.
    """
    n = x.shape[0] // 2
    if k is None:
        k = np.empty((4, 2 * n))
    half = 0.5 * dt
    k[0, :n] = v = x[n:]
    k[0, n:] = forward_dynamics(x[:n], v, tau)
    y = x + half * k[0]
    k[1, :n] = v = y[n:]
    k[1, n:] = forward_dynamics(y[:n], v, tau)
    y = x + half * k[1]
    k[2, :n] = v = y[n:]
    k[2, n:] = forward_dynamics(y[:n], v, tau)
    y = x + dt * k[2]
    k[3, :n] = v = y[n:]
    k[3, n:] = forward_dynamics(y[:n], v, tau)
    return x + (dt * _RK4_WEIGHTS).dot(k)


# Rows of ArmRk4's work array W (13, 2n): the stage derivatives k1..k4, the state at the start of
# the step, the stage state [q; dq], [tau - tau_f(dq); tau], [b; c] (the joint friction of
# `joint_friction`: damping plus viscous friction b, Coulomb friction c), the bounds of x,
# [the next stage's index, dt, 0...] (so that the stage kernels take two arguments: cheaper
# calls), [ddq; 0] (the accelerations of rk4_aba_step's stages) and [1 / v_s; 0] (the Coulomb
# law's regularization speed, per joint).
_K, _X, _STAGE, _TAU, _DAMPING, _LOW, _HIGH, _META, _DDQ, _SPEED = 0, 4, 5, 6, 7, 8, 9, 10, 11, 12


@jit
def joint_friction(W: np.ndarray, j: int, v: float) -> float:
    """tau_f of joint j at speed v [N m]: b v + c tanh(v / v_s) (b, c, 1 / v_s in W; c = 0: b v alone)."""
    n = W.shape[1] // 2
    c = W[_DAMPING, n + j]
    if c == 0.0:
        return W[_DAMPING, j] * v  # without Coulomb friction: the floats of b v alone
    return W[_DAMPING, j] * v + c * np.tanh(v * W[_SPEED, j])


@jit
def rk4_begin(W: np.ndarray, x: np.ndarray, tau: np.ndarray, dt: float) -> None:
    """Start a step of dt from x = [q; dq] with tau held: the first stage's state, torque, k1's dq part."""
    n = x.shape[0] // 2
    W[_META, 0], W[_META, 1] = 0.0, dt
    for j in range(2 * n):
        W[_X, j] = x[j]
        W[_STAGE, j] = x[j]
    for j in range(n):
        W[_TAU, n + j] = tau[j]
        W[_TAU, j] = tau[j] - joint_friction(W, j, x[n + j])
        W[_K, j] = x[n + j]


@jit
def rk4_stage(W: np.ndarray, ddq: np.ndarray) -> None:
    """Store stage i's accelerations (i = 0, 1, 2, counted in W), then form stage i + 1's state and torque."""
    n = ddq.shape[0]
    i, dt = int(W[_META, 0]), W[_META, 1]
    W[_META, 0] = i + 1
    c = 0.5 * dt if i < 2 else dt
    for j in range(n):
        W[_K + i, n + j] = ddq[j]
    for j in range(2 * n):
        W[_STAGE, j] = W[_X, j] + c * W[_K + i, j]
    for j in range(n):
        v = W[_STAGE, n + j]
        W[_K + i + 1, j] = v
        W[_TAU, j] = W[_TAU, n + j] - joint_friction(W, j, v)


@jit
def rk4_end(W: np.ndarray, ddq: np.ndarray, x: np.ndarray) -> bool:
    """Store k4; write x = x0 + dt (k1 + 2 k2 + 2 k3 + k4) / 6 and return whether it is within bounds."""
    n = ddq.shape[0]
    dt = W[_META, 1]
    for j in range(n):
        W[_K + 3, n + j] = ddq[j]
    w0, w1 = dt * (1.0 / 6.0), dt * (2.0 / 6.0)  # dt * _RK4_WEIGHTS
    inside = True
    for j in range(2 * n):
        x[j] = W[_X, j] + (w0 * W[_K, j] + w1 * W[_K + 1, j] + w1 * W[_K + 2, j] + w0 * W[_K + 3, j])
        inside = inside and W[_LOW, j] <= x[j] <= W[_HIGH, j]  # NaN is outside
    return inside


@jit
def rk4_aba_step(
    C: np.ndarray, S: np.ndarray, W: np.ndarray, x: np.ndarray, tau: np.ndarray, dt: float, x_next: np.ndarray
) -> bool:
    """One RK4 step of ArmRk4 in one compiled call: its stages around the compiled ABA.

    ``C``, ``S``: the chain and scratch of :class:`~ibvs_youla.model.dynamics_kernels.ChainDynamics`;
    ``W`` ArmRk4's work array; x = [q; dq] (2n,) and tau (n,) as :meth:`ArmRk4.step`. Writes
    the next state into ``x_next`` and returns whether it is within the bounds.
    """
    n = tau.shape[0]
    q, dq, tau_stage, ddq = W[_STAGE, :n], W[_STAGE, n:], W[_TAU, :n], W[_DDQ, :n]
    rk4_begin(W, x, tau, dt)
    for _ in range(3):
        aba_compiled(C, S, q, dq, tau_stage, ddq)
        rk4_stage(W, ddq)
    aba_compiled(C, S, q, dq, tau_stage, ddq)
    return rk4_end(W, ddq, x_next)


class ArmRk4:
    """One RK4 step of an arm's dynamics, torque held: :func:`rk4_arm_step` of the arm's ABA.

    For a chain of single-axis revolute joints the step is one compiled call,
    :func:`rk4_aba_step`, with the compiled ABA on the numbers of the arm's Pinocchio model
    (:mod:`ibvs_youla.model.dynamics_kernels`); otherwise Pinocchio's ``pin.aba`` (what
    ``arm.aba`` calls) is called between the compiled stages.

    The torque of each stage is ``tau - tau_f(dq)``, the held torque minus the joint friction of
    the stage's speeds: ``tau_f = (damping + b) dq + c tanh(dq / v_s)``, the arm's damping (Eq.
    (32)) plus the plant's viscous friction ``b`` and regularized Coulomb friction ``c``
    (:class:`~ibvs_youla.simulation.disturbances.PlantArm`, whose ``aba`` is the same law), in
    both paths.

    Args:
        arm: The arm (``damping``, ``pinocchio_model_data()``: Pinocchio's ABA includes the
            armature; the damping torque is applied here, as ``arm.aba`` does).
        x_low: Lower bounds (2n,) of the packed state [q; dq] that :meth:`step` tests.
        x_high: Upper bounds (2n,) of the same state.
        compiled_aba: Run the step as one compiled call with the compiled ABA when the arm's
            joints allow it (default); False: Pinocchio's ``pin.aba`` between compiled stages.
        viscous: Viscous friction b (n,) [N m s/rad], added to the damping; None: none.
        coulomb: Coulomb friction c (n,) [N m]; None: none.
        coulomb_speed: Regularization speed v_s of the Coulomb law [rad/s].
    """

    def __init__(
        self,
        arm: Any,
        x_low: np.ndarray,
        x_high: np.ndarray,
        compiled_aba: bool = True,
        *,
        viscous: np.ndarray | None = None,
        coulomb: np.ndarray | None = None,
        coulomb_speed: float = 0.05,
    ) -> None:
        self._arm = arm
        n = len(arm.damping)
        self._W = W = np.zeros((13, 2 * n))
        W[_DAMPING, :n] = arm.damping
        if viscous is not None:
            W[_DAMPING, :n] += viscous
        if coulomb is not None:
            W[_DAMPING, n:] = coulomb
        W[_SPEED, :n] = 1.0 / coulomb_speed
        W[_LOW], W[_HIGH] = x_low, x_high
        self._q, self._dq, self._tau = W[_STAGE, :n], W[_STAGE, n:], W[_TAU, :n]  # views fed to the ABA
        # the compiled ABA's chain (None: a joint it declines, or no compiled kernels: pin.aba)
        model = arm.pinocchio_model_data()[0]
        chain = ChainDynamics.from_model(model) if compiled_aba and jit_available() else None
        self._chain = None if chain is None else (chain.chain, chain.scratch())

    def step(self, x: np.ndarray, tau: np.ndarray, dt: float) -> tuple[np.ndarray, bool]:
        """(x at t + dt, within the bounds) from x = [q; dq] (2n,) at t, torque tau (n,) held [N m].

        Unvalidated: finite float arrays; the result is a new array (x is not modified).
        """
        x_next = np.empty(x.shape[0])  # a new array (cheaper than one returned by compiled code)
        if self._chain is not None:
            C, S = self._chain
            return x_next, rk4_aba_step(C, S, self._W, x, tau, dt, x_next)
        model, data = self._arm.pinocchio_model_data()
        W, q, dq, tau_stage, world = self._W, self._q, self._dq, self._tau, ABA_CONVENTION
        rk4_begin(W, x, tau, dt)
        rk4_stage(W, pin.aba(model, data, q, dq, tau_stage, world))
        rk4_stage(W, pin.aba(model, data, q, dq, tau_stage, world))
        rk4_stage(W, pin.aba(model, data, q, dq, tau_stage, world))
        return x_next, rk4_end(W, pin.aba(model, data, q, dq, tau_stage, world), x_next)
