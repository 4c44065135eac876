"""Joint friction of the dynamic plant, in closed form, on both integration paths.

The plant's RK4 (:class:`~ibvs_youla.simulation.integrators.ArmRk4`) applies the friction law
of :class:`~ibvs_youla.simulation.disturbances.PlantArm` at every stage,
``tau_f = b dq + c tanh(dq / v_s)``, compiled (one call per step) and around Pinocchio's
``pin.aba``. On one free joint of inertia I about a vertical axis (no gravity torque) the law has
closed forms:

* viscous alone, no torque: ``dq(t) = dq0 exp(-b t / I)``, ``q(t) = q0 + dq0 I / b (1 - exp(-b t / I))``;
* Coulomb below breakaway (|tau| < c): the joint creeps at ``v_s atanh(tau / c)`` (the regularized
  law has no true stiction: the speed at which c tanh(v / v_s) balances tau);
* Coulomb above breakaway (tau > c): once ``dq >> v_s`` the acceleration is ``(tau - c) / I``.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import ibvs_youla as iy
from ibvs_youla.simulation.disturbances import Disturbances
from ibvs_youla.simulation.integrators import ArmRk4, rk4_arm_step
from ibvs_youla.simulation.plant import ArmPlant

INERTIA = 0.8  # [kg m^2] about the joint axis
DT = 1e-3  # [s]


class OneJoint:
    """One revolute joint about the vertical z axis: what ArmRk4 reads of an arm."""

    def __init__(self) -> None:
        self.model = pin.Model()
        joint = self.model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "joint")
        inertia = pin.Inertia(2.0, np.array([0.0, 0.0, 0.1]), np.diag([0.5, 0.5, INERTIA]))
        self.model.appendBodyToJoint(joint, inertia, pin.SE3.Identity())
        self.data = self.model.createData()
        self.damping = np.zeros(1)

    def pinocchio_model_data(self):
        return self.model, self.data


def _run(rk4: ArmRk4, x0, tau, steps):
    x, out = np.array(x0, dtype=float), []
    for _ in range(steps):
        x, inside = rk4.step(x, np.array([tau]), DT)
        assert inside
        out.append(x)
    return np.array(out)


def _rk4(compiled, **friction):
    return ArmRk4(OneJoint(), np.full(2, -1e9), np.full(2, 1e9), compiled_aba=compiled, **friction)


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "pinocchio"])
def test_viscous_friction_decelerates_a_free_joint_exponentially(compiled):
    b, dq0 = 2.0, 1.5  # [N m s/rad], [rad/s]
    x = _run(_rk4(compiled, viscous=np.array([b])), [0.0, dq0], 0.0, 2000)
    t = DT * np.arange(1, 2001)
    decay = np.exp(-b * t / INERTIA)
    # RK4's global error for this linear ODE is (b dt / I)^4 / 120 per unit time: ~3e-13 here
    np.testing.assert_allclose(x[:, 1], dq0 * decay, rtol=1e-10, atol=0)
    np.testing.assert_allclose(x[:, 0], dq0 * INERTIA / b * (1.0 - decay), rtol=1e-10, atol=0)


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "pinocchio"])
def test_coulomb_friction_holds_a_torque_below_breakaway_to_a_creep(compiled):
    c, v_s, tau = 10.0, 0.05, 5.0  # [N m], [rad/s], [N m]: half the breakaway torque
    x = _run(_rk4(compiled, coulomb=np.array([c]), coulomb_speed=v_s), [0.0, 0.0], tau, 1000)
    creep = v_s * math.atanh(tau / c)  # 0.0275 rad/s
    # the speed's time constant is I v_s / (c (1 - (tau / c)^2)) = 5.3 ms: settled to rounding at 1 s
    assert x[-1, 1] == pytest.approx(creep, rel=1e-12)
    without = _run(_rk4(compiled), [0.0, 0.0], tau, 1000)
    assert without[-1, 1] == pytest.approx(tau / INERTIA * 1.0, rel=1e-12)  # free: tau t / I


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "pinocchio"])
def test_coulomb_friction_above_breakaway_costs_c_of_the_torque(compiled):
    c, tau = 10.0, 15.0  # [N m]
    x = _run(_rk4(compiled, coulomb=np.array([c])), [0.0, 0.0], tau, 1000)
    # beyond 0.5 s the speed is > 2.5 rad/s = 50 v_s: tanh = 1 to 1e-40, so ddq = (tau - c) / I
    gained = x[-1, 1] - x[499, 1]
    assert gained == pytest.approx((tau - c) / INERTIA * 0.5, rel=1e-12)


def test_the_plants_step_with_friction_is_the_plant_arms_law(arm):
    """Both integration paths of the IRB 4600 plant equal RK4 of ``PlantArm.aba``, the stated law."""
    plant_arm = Disturbances(viscous_friction=(30, 30, 20, 5, 5, 2), coulomb_friction=40.0).plant_arm(arm)
    q, dq = np.array([0.1, -0.3, 0.4, 0.2, 0.5, -0.1]), np.array([0.3, -0.2, 0.01, -1.0, 0.02, 0.0])
    tau = np.array([50.0, 900.0, 300.0, 10.0, 20.0, 1.0])
    x = np.concatenate([q, dq])
    reference = rk4_arm_step(plant_arm.aba, x, tau, DT)
    undisturbed = rk4_arm_step(arm.aba, x, tau, DT)
    plant = ArmPlant(plant_arm, q_encoder=q, dq=dq)
    low, high = plant._x_low, plant._x_high
    for compiled in (True, False):
        b, c, v_s = plant_arm.friction_parameters()
        rk4 = ArmRk4(plant_arm, low, high, compiled, viscous=b, coulomb=c, coulomb_speed=v_s)
        step, inside = rk4.step(x, tau, DT)
        assert inside
        # the law applied as (damping + b) dq + c tanh instead of tau - tau_f - damping dq: rounding
        np.testing.assert_allclose(step, reference, rtol=0, atol=1e-13 * np.abs(reference).max())
        assert np.abs(step - undisturbed)[6:].max() > 1e-3  # and friction changed the speeds
    plant.step(tau, DT)
    np.testing.assert_allclose(np.concatenate([plant.q_true, plant.dq]), reference, rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        plant_arm.forward_dynamics(q, dq, tau), arm.forward_dynamics(q, dq, tau - plant_arm.friction(dq))
    )


@pytest.mark.parametrize("field", ["viscous_friction", "coulomb_friction"])
def test_friction_alone_changes_the_simulated_arm(field):
    """The hostile user's example: friction recorded and never applied gave q_true identical."""
    scenario = iy.scenarios.physical(1)
    nominal = iy.simulate(scenario, "fb", duration=0.1)
    rubbed = iy.simulate(scenario, "fb", duration=0.1, disturbances=Disturbances(**{field: 200.0}))
    assert rubbed.metadata["spec"]["disturbances"] == {field: 200.0}
    assert np.abs(rubbed.q_true - nominal.q_true).max() > 1e-3  # [rad]
