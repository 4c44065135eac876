"""The compiled ABA and RNEA against Pinocchio's, and the inner loop's one-call torque.

``model/dynamics_kernels.py`` runs the articulated-body algorithm and the recursive
Newton-Euler algorithm on the numbers of a Pinocchio model. They are the same algorithms in
another order of floating-point operations, so they agree with ``pin.aba`` / ``pin.rnea`` to
rounding: the bound is 1e-12 of the result's scale (measured with these seeds, at torques up to
500 N m and speeds up to 3 rad/s, on the IRB 4600 and the random chains: the ABA 3.0e-15 to
1.0e-13, the largest for the scaled IRB 4600; the RNEA 4.5e-16 to 3.6e-15). The Panda and the
Kinova (light links, so large accelerations) are held to the same relative bound.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from ibvs_youla.control.inner import InnerLoopDesign
from ibvs_youla.controllers.base import JointReading
from ibvs_youla.exceptions import InvalidArrayError
from ibvs_youla.model.arm import ABA_CONVENTION, Arm
from ibvs_youla.model.dynamics_kernels import ChainDynamics, aba_compiled, rnea_compiled
from ibvs_youla.simulation.actuation import InnerLoopActuator

SEED = 20261202
RTOL = 1e-12  # of max(1, |result|_inf): rounding of two orders of the same sums


def random_unaligned_chain(rng, n=7, branch_at=None):
    """Revolute joints about random unit axes at random placements; a second branch if asked."""
    model = pin.Model()
    parent = 0
    for i in range(n):
        axis = rng.normal(size=3)
        joint = pin.JointModelRevoluteUnaligned(axis / np.linalg.norm(axis))
        parent_i = branch_at if (branch_at is not None and i == n // 2) else parent
        jid = model.addJoint(parent_i, joint, pin.SE3.Random(), f"j{i}")
        model.appendBodyToJoint(jid, pin.Inertia.Random(), pin.SE3.Identity())
        parent = jid
    model.armature = rng.uniform(0.0, 0.5, n)
    return model


def models():
    rng = np.random.default_rng(SEED)
    irb = Arm.irb4600().pinocchio_model_data()[0]
    scaled = Arm.irb4600().with_inertia_scale(1.3).pinocchio_model_data()[0]
    return {
        "irb4600": irb,
        "irb4600-inertia-x1.3": scaled,
        "sample-manipulator": pin.buildSampleModelManipulator(),  # RX / RY / RZ joints, no armature
        "unaligned-chain": random_unaligned_chain(rng),
        "unaligned-tree": random_unaligned_chain(rng, n=6, branch_at=1),  # two bodies on joint 1
        # arms of example-robot-data reduced to their chains: seven joints, fingers locked; the
        # Kinova's continuous joints in joint coordinates (revolute joints without limits)
        "panda": Arm.from_robot("panda").pinocchio_model_data()[0],
        "kinova": Arm.from_robot("kinova").pinocchio_model_data()[0],
    }


MODELS = models()


@pytest.mark.parametrize("name", list(MODELS))
def test_compiled_aba_and_rnea_equal_pinocchio(name):
    model = MODELS[name]
    data = model.createData()
    chain = ChainDynamics.from_model(model)
    assert chain is not None and chain.n == model.nq
    S = chain.scratch()
    rng = np.random.default_rng(SEED + 1)
    n = model.nq
    worst_aba = worst_rnea = 0.0
    for _ in range(300):
        q, dq = rng.uniform(-3.0, 3.0, n), rng.uniform(-3.0, 3.0, n)
        tau, ddq = rng.uniform(-500.0, 500.0, n), rng.uniform(-30.0, 30.0, n)
        expected = pin.aba(model, data, q, dq, tau, ABA_CONVENTION).copy()
        got = np.empty(n)
        aba_compiled(chain.chain, S, q, dq, tau, got)
        worst_aba = max(worst_aba, np.abs(got - expected).max() / max(1.0, np.abs(expected).max()))
        expected = pin.rnea(model, data, q, dq, ddq).copy()
        rnea_compiled(chain.chain, S, q, dq, ddq, got)
        worst_rnea = max(worst_rnea, np.abs(got - expected).max() / max(1.0, np.abs(expected).max()))
    assert worst_aba < RTOL
    assert worst_rnea < RTOL


def test_aba_inverts_rnea_on_the_compiled_side_too():
    """ABA(q, dq, RNEA(q, dq, ddq)) = ddq: the kernels invert each other.

    Measured 1.4e-14 rad/s^2 on accelerations of up to 5 rad/s^2 (these seeds); the bound, 1e-12,
    leaves a factor of ~70 for M's conditioning, which the round trip amplifies.
    """
    chain = ChainDynamics.from_model(MODELS["irb4600"])
    S = chain.scratch()
    rng = np.random.default_rng(SEED + 2)
    for _ in range(100):
        q, dq, ddq = rng.uniform(-2.0, 2.0, 6), rng.uniform(-2.0, 2.0, 6), rng.uniform(-5.0, 5.0, 6)
        tau, back = np.empty(6), np.empty(6)
        rnea_compiled(chain.chain, S, q, dq, ddq, tau)
        aba_compiled(chain.chain, S, q, dq, tau, back)
        np.testing.assert_allclose(back, ddq, rtol=0.0, atol=1e-12)


def test_joints_other_than_single_axis_revolute_are_declined():
    """A prismatic joint, a free flyer, an unbounded revolute joint: None (the caller keeps pin.aba)."""
    prismatic = pin.Model()
    jid = prismatic.addJoint(0, pin.JointModelPZ(), pin.SE3.Identity(), "slide")
    prismatic.appendBodyToJoint(jid, pin.Inertia.Random(), pin.SE3.Identity())
    assert ChainDynamics.from_model(prismatic) is None
    assert ChainDynamics.from_model(pin.buildSampleModelHumanoid()) is None  # a free flyer at its root
    unbounded = pin.Model()
    jid = unbounded.addJoint(0, pin.JointModelRUBZ(), pin.SE3.Identity(), "wheel")
    unbounded.appendBodyToJoint(jid, pin.Inertia.Random(), pin.SE3.Identity())
    assert ChainDynamics.from_model(unbounded) is None
    helical = pin.Model()
    jid = helical.addJoint(0, pin.JointModelHZ(0.01), pin.SE3.Identity(), "screw")
    helical.appendBodyToJoint(jid, pin.Inertia.Random(), pin.SE3.Identity())
    assert ChainDynamics.from_model(helical) is None
    mimic = pin.transformJointIntoMimic(pin.buildSampleModelManipulator(), 1, 2, 1.0, 0.0)
    assert ChainDynamics.from_model(mimic) is None  # joint 2 copies joint 1: nq < njoints - 1
    assert ChainDynamics.from_model(pin.Model()) is None  # no joint at all
    # an axis that is not a unit vector: Pinocchio uses it as given, the kernels would not
    long_axis = pin.Model()
    jid = long_axis.addJoint(
        0, pin.JointModelRevoluteUnaligned(np.array([0.0, 0.0, 2.0])), pin.SE3.Identity(), "j"
    )
    long_axis.appendBodyToJoint(jid, pin.Inertia.Random(), pin.SE3.Identity())
    assert ChainDynamics.from_model(long_axis) is None


AXES = [(0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0), (0.6, 0.0, -0.8)]
AXES += [(1e-9, 0.0, 1.0), (1e-9, 0.0, -1.0), (2e-8, 0.0, -1.0)]  # CAD exports' "nearly z" (normalized)


@pytest.mark.parametrize("axis", AXES)
def test_axis_frames_about_z_minus_z_and_others(axis):
    """A single joint about +-z, within 1e-9 rad of it, or another axis: Pinocchio's dynamics.

    Only an exactly zero e_z x axis is taken as +-z: an axis 1e-9 rad off is rotated onto z, not
    snapped to it (snapping gave errors of 3e-8 to 1e-7 for such axes).
    """
    model = pin.Model()
    unit = np.array(axis) / np.linalg.norm(axis)
    jid = model.addJoint(0, pin.JointModelRevoluteUnaligned(unit), pin.SE3.Random(), "j")
    model.appendBodyToJoint(jid, pin.Inertia.Random(), pin.SE3.Identity())
    chain = ChainDynamics.from_model(model)
    data, S, got = model.createData(), chain.scratch(), np.empty(1)
    for q in (-2.0, 0.3, 1.7):
        args = (np.array([q]), np.array([0.4]), np.array([2.0]))
        aba_compiled(chain.chain, S, *args, got)
        expected = pin.aba(model, data, *args, ABA_CONVENTION)
        np.testing.assert_allclose(got, expected, rtol=RTOL, atol=RTOL)
        rnea_compiled(chain.chain, S, *args, got)
        expected = pin.rnea(model, data, *args)
        np.testing.assert_allclose(got, expected, rtol=RTOL, atol=RTOL)


def test_the_inner_loop_torque_is_the_filter_step_then_the_arms_rnea():
    """InnerLoopActuator's one compiled call: G_C's recursion (same floats) and arm.rnea to rounding.

    The reference is the composition it replaces: ``DiscreteFilter.step_difference`` of q_ref - q,
    then ``arm.rnea`` (Pinocchio's RNEA plus the damping torque), over 200 ticks of a drifting
    state (the filter's state is carried the same way on both sides).
    """
    arm = Arm.irb4600().with_inertia_scale(0.9)
    actuator = InnerLoopActuator(arm, tau_in=0.01, dt=1e-3)
    reference_filter = InnerLoopDesign(0.01).discrete_controller(1e-3, arm.nq)
    rng = np.random.default_rng(SEED + 3)
    q, dq = rng.uniform(-1.0, 1.0, 6), rng.uniform(-0.5, 0.5, 6)
    q_ref = q + 0.05
    for k in range(200):
        reading = JointReading(k * 1e-3, q, dq)
        got = actuator(q_ref, reading)
        expected = arm.rnea(q, dq, reference_filter.step_difference(q_ref, q))
        np.testing.assert_allclose(got, expected, rtol=0.0, atol=RTOL * max(1.0, np.abs(expected).max()))
        q, dq = q + 1e-3 * dq, dq + 1e-3 * rng.normal(0.0, 1.0, 6)
    # a reference that is a list, not a float array: converted, the same torque as its array
    twin = InnerLoopActuator(arm, tau_in=0.01, dt=1e-3)
    reading = JointReading(0.0, q, dq)
    from_array = InnerLoopActuator(arm, 0.01, 1e-3)(q_ref, reading)
    np.testing.assert_array_equal(twin(list(q_ref), reading), from_array)


def test_the_inner_loop_with_pinocchios_rnea_gives_the_same_torques():
    """compiled_rnea=False: the filter's kernel, then arm.rnea (Pinocchio): the same torques to rounding."""
    arm = Arm.irb4600()
    compiled, plain = (
        InnerLoopActuator(arm, 0.01, 1e-3),
        InnerLoopActuator(arm, 0.01, 1e-3, compiled_rnea=False),
    )
    rng = np.random.default_rng(SEED + 4)
    for k in range(50):
        reading = JointReading(k * 1e-3, rng.uniform(-1.0, 1.0, 6), rng.uniform(-0.5, 0.5, 6))
        q_ref = reading.q + rng.normal(0.0, 0.05, 6)
        expected = plain(q_ref, reading)
        np.testing.assert_allclose(
            compiled(q_ref, reading), expected, rtol=0.0, atol=RTOL * np.abs(expected).max()
        )


@pytest.mark.parametrize("compiled_rnea", [True, False])
def test_a_non_finite_reference_is_a_non_finite_torque_not_an_error(compiled_rnea):
    """The plant reports the divergence (SimulationDivergedError); the actuator only passes it on."""
    actuator = InnerLoopActuator(Arm.irb4600(), 0.01, 1e-3, compiled_rnea=compiled_rnea)
    reading = JointReading(0.0, np.zeros(6), np.zeros(6))
    assert not np.all(np.isfinite(actuator([np.nan, 0.0, 0.0, 0.0, 0.0, 0.0], reading)))  # a list
    assert not np.all(np.isfinite(actuator(np.full(6, np.inf), reading)))


def test_the_inner_loop_refuses_a_reference_of_another_size():
    actuator = InnerLoopActuator(Arm.irb4600(), tau_in=0.01, dt=1e-3)
    reading = JointReading(0.0, np.zeros(6), np.zeros(6))
    with pytest.raises(InvalidArrayError, match=r"q_ref.*shape \(7,\).*shape \(6,\)"):
        actuator(np.zeros(7), reading)
