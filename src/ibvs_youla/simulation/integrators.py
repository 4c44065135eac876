"""Fixed-step fourth-order Runge-Kutta integration.

The plant (the arm's rigid-body dynamics, Eq. (29)) is integrated with the classical
RK4 scheme at a fixed step, the digital controller's sample period or a divisor of it.
RK4 has local error O(dt^5) and global error O(dt^4): halving the step divides the error
of a smooth trajectory by about 16 (``tests/test_integrators.py`` measures the order).

Control inputs are held constant over a step (zero-order hold, as the DAC of a
digital joint controller would hold them), so the integrated right-hand side is
smooth inside the step and the fourth order holds step by step. A torque that
changes *within* a step (a continuous-time controller) is not what this models.

Two entry points:

* :func:`rk4_step` — generic, for any ODE ``dx/dt = f(t, x)`` on a flat state vector.
* :func:`rk4_arm_step` — specialised for a joint-space arm ``ddq = FD(q, dq, tau)``
  with ``tau`` held, on the packed state ``x = [q; dq]``: no time argument (the arm is
  autonomous for a held torque), four forward-dynamics calls per step, the stage
  derivatives in a reusable scratch array. Joint coordinates are added directly
  (``q + dt * dq``), which is exact for revolute and prismatic joints (configuration
  space R^n), the case of the IRB 4600. It is the plant's integrator
  (:class:`~ibvs_youla.simulation.plant.ArmPlant`) and does not validate its arguments.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["rk4_arm_step", "rk4_step"]

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
