"""RK4: fourth-order convergence (pendulum and IRB 4600) and energy conservation in free motion."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ibvs_youla.simulation.integrators import rk4_arm_step, rk4_step


def _observed_orders(errors):
    return [math.log2(errors[i] / errors[i + 1]) for i in range(len(errors) - 1)]


def _pendulum(t, x, g_over_l=9.81):
    return np.array([x[1], -g_over_l * math.sin(x[0]) - 0.1 * x[1] + 0.5 * math.cos(2.0 * t)])


def test_rk4_step_is_fourth_order_on_a_forced_damped_pendulum():
    x0, horizon = np.array([1.2, 0.0]), 2.0  # [rad, rad/s], [s]
    ref = solve_ivp(_pendulum, (0.0, horizon), x0, method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1]
    errors = []
    for dt in (0.04, 0.02, 0.01):
        x = x0.copy()
        for k in range(round(horizon / dt)):
            x = rk4_step(_pendulum, k * dt, x, dt)
        errors.append(np.abs(x - ref).max())
    orders = _observed_orders(errors)
    assert all(3.8 < p < 4.2 for p in orders), (errors, orders)


def test_rk4_step_is_exact_for_cubic_polynomials_in_time():
    # RK4 integrates dx/dt = f(t) exactly for polynomials of degree <= 3 (Simpson's rule)
    f = lambda t, x: np.array([4 * t**3 - 3 * t**2 + 2.0])  # noqa: E731
    x = rk4_step(f, 0.5, np.array([1.0]), 0.25)
    exact = 1.0 + (0.75**4 - 0.75**3 + 2 * 0.75) - (0.5**4 - 0.5**3 + 2 * 0.5)
    assert x[0] == pytest.approx(exact, abs=1e-15)


def _arm(undamped=False):
    from ibvs_youla.model.arm import Arm

    arm = Arm.irb4600()
    if not undamped:
        return arm
    # same URDF and armature, viscous damping B / r set to zero (the default IRB 4600 has some)
    return Arm.from_urdf(arm.urdf_path, armature=arm.armature, damping=np.zeros(6))


def test_rk4_arm_step_is_fourth_order_on_the_irb4600_with_smooth_torque():
    arm = _arm()
    rng = np.random.default_rng(0)
    q0 = np.radians([10.0, 20.0, -10.0, 30.0, 40.0, 50.0])
    dq0 = 0.5 * rng.normal(size=6)
    # gravity compensation at q0 plus accelerations of a few rad/s^2, held for the whole run
    tau = arm.nonlinear_effects(q0, np.zeros(6)) + arm.mass_matrix(q0) @ np.array([2, -1, 1.5, -2, 3, 1.0])
    horizon = 0.5  # [s]

    def run(dt):
        x = np.concatenate([q0, dq0])
        for _ in range(round(horizon / dt)):
            x = rk4_arm_step(arm.forward_dynamics, x, tau, dt)
        return x

    ref = run(1e-4)  # its own error is ~1e-16, 10^4 below the finest error measured (~1.6e-12)
    errors = [np.abs(run(dt) - ref).max() for dt in (4e-3, 2e-3, 1e-3)]
    orders = _observed_orders(errors)
    assert all(3.8 < p < 4.2 for p in orders), (errors, orders)


def test_rk4_conserves_energy_of_the_undamped_irb4600_in_free_motion():
    arm = _arm(undamped=True)
    assert np.all(arm.damping == 0.0) and np.all(arm.armature > 0.0)
    rng = np.random.default_rng(1)
    q = np.radians([10.0, 20.0, -10.0, 30.0, 40.0, 50.0])
    dq = 0.5 * rng.normal(size=6)
    energy0 = arm.kinetic_energy(q, dq) + arm.potential_energy(q)
    dt, horizon = 1e-3, 2.0  # 1 kHz for 2 s, no torque, gravity on
    drift = 0.0
    for _ in range(round(horizon / dt)):
        q, dq = np.split(rk4_arm_step(arm.forward_dynamics, np.concatenate([q, dq]), np.zeros(6), dt), 2)
        drift = max(drift, abs(arm.kinetic_energy(q, dq) + arm.potential_energy(q) - energy0))
    # the arm falls and swings (joint speeds up to ~13 rad/s); RK4 keeps |dE| ~5e-8 J of 2.8e3 J
    assert np.abs(dq).max() > 1.0
    assert drift < 1e-8 * abs(energy0) + 1e-6
