"""Actuation: converting a controller's command into what a plant accepts.

Commands form one chain, each link an adapter that runs at every tick with the encoder
reading and the controller's *own* arm model (never the true one):

    camera twist [v; w] --(J_C^+)--> joint velocity --(integrate)--> joint position
    reference --(the paper's inner loop, Eq. (33)-(46))--> joint torque

* :class:`TwistToJointVelocity`: dq_ref = J_C(q)^+ [v; w], J_C the LOCAL camera Jacobian (6, n)
  of the controller's arm at the encoder reading, its pseudo-inverse damped near
  singularities (:class:`~ibvs_youla.control.singular_values.SingularValuePolicy`); on a
  redundant arm, plus a secondary task in the null space of J_C when one is set
  (:mod:`ibvs_youla.control.redundancy`).
* :class:`VelocityToPosition`: q_ref[k] = q_ref[k-1] + dt dq_ref[k], from q_ref = q(0).
* :class:`InnerLoopActuator`: v = G_C(z)[q_ref - q] (Eq. (41)-(46), ERRATA 8; Tustin) and the
  feedback linearization tau = M(q) v + h(q, dq) (Eq. (33)) with the controller's arm model,
  so every controller that commands joints runs through the paper's inner loop on the
  dynamic arm. Both in one compiled call per tick (:func:`inner_loop_torque`: the filter's
  recursion, then the RNEA of :mod:`ibvs_youla.model.dynamics_kernels` on the model's numbers),
  or, for an arm whose joints that kernel declines, the filter's kernel and Pinocchio's RNEA.

:func:`actuation_chain` walks the chain from the controller's command type to the first
type the plant accepts, or raises :class:`~ibvs_youla.exceptions.IncompatibleCommandError`
naming both (a joint command cannot drive a camera without an arm).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._jit import jit, jit_available
from .._validation import as_array
from ..control.discrete import filter_step_difference
from ..control.inner import InnerLoopDesign
from ..control.redundancy import JointLimitAvoidance, joint_limit_avoidance
from ..control.singular_values import SingularValuePolicy
from ..control.svd_kernels import pseudo_inverse_apply, pseudo_inverse_integrate
from ..controllers.base import CommandType, JointReading
from ..exceptions import IncompatibleCommandError
from ..model.dynamics_kernels import ChainDynamics, rnea_compiled

__all__ = [
    "InnerLoopActuator",
    "TwistToJointVelocity",
    "VelocityToPosition",
    "actuation_chain",
    "inner_loop_torque",
]

_FLOAT64 = np.dtype(np.float64)  # an array's dtype is this instance: `is` is the cheap test per tick
_CHAIN = (
    CommandType.CAMERA_TWIST,
    CommandType.JOINT_VELOCITY,
    CommandType.JOINT_POSITION,
    CommandType.JOINT_TORQUE,
)


class TwistToJointVelocity:
    """Camera twist -> joint velocity through the controller's arm: dq_ref = J_C(q)^+ [v; w] (+ N dq2).

    J_C is (6, n); on a redundant arm (n > 6) J_C^+ [v; w] is the least-norm joint velocity, and a
    secondary task (:mod:`ibvs_youla.control.redundancy`, off by default) adds a velocity in the
    null space of J_C: ``dq_ref = dq1 + dq2``, dq1 = J_C^+ [v; w], dq2 from the encoders, dq1 and
    N = I - J_C^+ J_C (the pseudo-inverse of the policy), which leaves the camera twist unchanged.

    Args:
        arm: The controller's arm model (``camera_jacobian``, limits for the secondary task).
        policy: Pseudo-inverse of J_C near singularities (default: damped, lambda = 1e-3 sigma_max).
        secondary_task: A :class:`~ibvs_youla.control.redundancy.JointLimitAvoidance`, or None.
    """

    output_type = CommandType.JOINT_VELOCITY

    def __init__(
        self,
        arm: Any,
        policy: SingularValuePolicy | None = None,
        secondary_task: JointLimitAvoidance | None = None,
    ) -> None:
        self._arm = arm
        self._policy = SingularValuePolicy() if policy is None else policy
        self._damped, self._threshold = self._policy.kind == "damped", self._policy.threshold
        self._integrator: VelocityToPosition | None = None
        self._secondary = secondary_task
        if secondary_task is not None:
            self._q_min, self._q_max = np.asarray(arm.q_min, dtype=float), np.asarray(arm.q_max, dtype=float)

    @property
    def arm(self) -> Any:
        """The controller's arm model whose J_C is inverted."""
        return self._arm

    @property
    def policy(self) -> SingularValuePolicy:
        """The pseudo-inverse of J_C near singularities."""
        return self._policy

    @property
    def secondary_task(self) -> JointLimitAvoidance | None:
        """The null-space task of a redundant arm, or None."""
        return self._secondary

    def integrate_into(self, integrator: VelocityToPosition) -> None:
        """Integrate each dq_ref for ``integrator`` (the next link) in the same compiled call.

        ``integrator(dq_ref, reading)`` then returns the reference it would compute, computed
        already (:func:`~ibvs_youla.control.svd_kernels.pseudo_inverse_integrate`, the same
        floats): one compiled call per joint tick instead of a compiled call and two numpy ones.
        """
        self._integrator = integrator

    def __call__(self, twist: np.ndarray, reading: JointReading) -> np.ndarray:
        """dq_ref (n,) [rad/s] for the twist [v; w] (6,) in the camera frame at the encoder reading.

        The encoders are the plant's (finite): J_C comes from the arm's kernel, and J_C^+ [v; w]
        from one compiled call (:func:`~ibvs_youla.control.svd_kernels.pseudo_inverse_apply`,
        with the integration of :meth:`integrate_into`) when the twist is a float (6,) array,
        else (or when the SVD fails) from the reference ``policy.pseudo_inverse(J_C) @ twist``.
        """
        J_C = self._arm.camera_jacobian_at(reading.q)
        if self._secondary is not None:
            P = self._policy.pseudo_inverse(J_C)
            dq1 = P @ twist
            N = np.eye(J_C.shape[1]) - P @ J_C
            return dq1 + joint_limit_avoidance(self._secondary, reading.q, dq1, self._q_min, self._q_max, N)
        if getattr(twist, "shape", None) == (6,) and twist.dtype is _FLOAT64:
            n, integrator = J_C.shape[1], self._integrator
            dq_ref = np.empty(n)
            if integrator is None:
                if pseudo_inverse_apply(J_C, twist, self._damped, self._threshold, dq_ref):
                    return dq_ref
            else:
                q_next, q_ref, dt, damped = np.empty(n), integrator._q_ref, integrator._dt, self._damped
                if pseudo_inverse_integrate(J_C, twist, damped, self._threshold, q_ref, dt, dq_ref, q_next):
                    integrator._held = (dq_ref, q_next)  # for integrator(dq_ref, reading)
                    return dq_ref
        return self._policy.pseudo_inverse(J_C) @ twist


class VelocityToPosition:
    """Joint velocity -> joint position reference: q_ref[k] = q_ref[k-1] + dt dq_ref[k].

    Args:
        q_start: Reference at the start (n,) [rad], the encoder reading.
        dt: Tick period [s].
    """

    output_type = CommandType.JOINT_POSITION

    def __init__(self, q_start: np.ndarray, dt: float) -> None:
        self._q_ref = np.array(q_start, dtype=float)
        self._dt = float(dt)
        # (dq_ref, q_ref + dt dq_ref) computed by TwistToJointVelocity (integrate_into) for the next call
        self._held: tuple[np.ndarray, np.ndarray] | None = None

    def __call__(self, dq_ref: np.ndarray, reading: JointReading) -> np.ndarray:
        """The integrated reference (n,) [rad]."""
        held = self._held
        if held is not None:
            self._held = None
            if held[0] is dq_ref:  # integrated already, this very array
                self._q_ref = held[1]
                return held[1]
        self._q_ref = self._q_ref + self._dt * dq_ref
        return self._q_ref


@jit
def inner_loop_torque(
    filter_matrix: np.ndarray,
    z: np.ndarray,
    z_next: np.ndarray,
    q_ref: np.ndarray,
    q: np.ndarray,
    dq: np.ndarray,
    chain: np.ndarray,
    scratch: np.ndarray,
    damping: np.ndarray,
    v: np.ndarray,
    tau: np.ndarray,
) -> None:
    """One tick of the inner loop: v = G_C(z)[q_ref - q] (Eq. (41)), tau = M(q) v + h(q, dq) (Eq. (33)).

    G_C's recursion (``filter_step_difference`` on the filter's stacked matrix [[A, B], [C, D]],
    its state z (n_states + 1, n) advanced in place through z_next), then the RNEA of the chain
    (:class:`~ibvs_youla.model.dynamics_kernels.ChainDynamics`, its scratch) and the damping torque
    ``damping * dq``: ``arm.rnea(q, dq, v)`` to rounding. Unvalidated float64 arrays: q_ref, q
    [rad], dq [rad/s], damping [N m s/rad] (n,); v [rad/s^2] and tau [N m] (n,) are written.
    """
    filter_step_difference(filter_matrix, z, z_next, q_ref, q, v)
    z[:, :] = z_next
    rnea_compiled(chain, scratch, q, dq, v, tau)
    for j in range(tau.shape[0]):
        tau[j] += damping[j] * dq[j]


class InnerLoopActuator:
    """Joint position reference -> joint torque: the paper's inner loop (Eq. (33)-(46)).

    Args:
        arm: The controller's arm model (feedback linearization, Eq. (33)).
        tau_in: Inner-loop time constant [s] (Eq. (41), (63)).
        dt: Joint-loop period [s] (Tustin discretization of G_C).
        compiled_rnea: One compiled call per tick (:func:`inner_loop_torque`) when the arm's
            joints allow it (default); False: the filter's kernel, then ``arm.rnea`` (Pinocchio).
    """

    output_type = CommandType.JOINT_TORQUE

    def __init__(self, arm: Any, tau_in: float, dt: float, compiled_rnea: bool = True) -> None:
        inner = InnerLoopDesign(tau_in).discrete_controller(dt, arm.nq)
        self._n, self._rnea = arm.nq, arm.rnea
        # G_C's recursion on the actuator's own state (the filter's matrix, so its floats)
        self._filter_matrix = inner.stacked_matrix
        self._z, self._z_next = np.zeros((inner.n_states + 1, arm.nq)), np.zeros((inner.n_states + 1, arm.nq))
        self._v = np.empty(arm.nq)
        model = arm.pinocchio_model_data()[0]
        chain = ChainDynamics.from_model(model) if compiled_rnea and jit_available() else None
        damping = np.array(arm.damping, dtype=float)
        self._chain = None if chain is None else (chain.chain, chain.scratch(), damping)

    def __call__(self, q_ref: np.ndarray, reading: JointReading) -> np.ndarray:
        """Tau = M(q) G_C(z)[q_ref - q] + h(q, dq) (n,) [N m], from one RNEA pass.

        A non-finite ``q_ref`` gives a non-finite torque, not an error: the plant reports the
        divergence. A ``q_ref`` of another size raises InvalidArrayError.
        """
        q, dq = reading.q, reading.dq
        if getattr(q_ref, "shape", None) != (self._n,) or q_ref.dtype is not _FLOAT64:
            q_ref = as_array(q_ref, "q_ref", (self._n,), finite=False)
        tau = np.empty(self._n)
        if self._chain is not None:
            chain, scratch, damping = self._chain
            z, z_next, v = self._z, self._z_next, self._v
            inner_loop_torque(self._filter_matrix, z, z_next, q_ref, q, dq, chain, scratch, damping, v, tau)
            return tau
        filter_step_difference(self._filter_matrix, self._z, self._z_next, q_ref, q, self._v)
        self._z[:, :] = self._z_next
        return self._rnea(q, dq, self._v)  # type: ignore[no-any-return]


def actuation_chain(
    command_type: CommandType,
    plant: Any,
    *,
    arm: Any = None,
    q_start: np.ndarray | None = None,
    tau_in: float = 0.01,
    dt: float = 1e-3,
    secondary_task: JointLimitAvoidance | None = None,
) -> list[Any]:
    """Adapters from ``command_type`` to the first type along the chain that ``plant`` accepts.

    Args:
        command_type: What the controller commands.
        plant: The plant (``accepts``, ``name``); its input is set with ``use_input``.
        arm: The controller's arm model (needed by every adapter).
        q_start: Encoder reading at the start (the velocity integrator's initial value).
        tau_in: Inner-loop time constant [s].
        dt: Tick period [s].
        secondary_task: The null-space task of a redundant arm (:class:`TwistToJointVelocity`).

    Returns:
        The adapters to apply in order (empty when the plant takes the command as it is).

    Raises:
        IncompatibleCommandError: no adapter path, or the path needs an arm the task lacks.
    """
    command_type = CommandType.parse(command_type)
    accepted = tuple(plant.accepts)
    chain: list[Any] = []
    current = command_type
    for nxt in _CHAIN[_CHAIN.index(command_type) + 1 :]:
        if current in accepted:
            break
        if arm is None:
            break
        if nxt is CommandType.JOINT_VELOCITY:
            chain.append(TwistToJointVelocity(arm, secondary_task=secondary_task))
        elif nxt is CommandType.JOINT_POSITION:
            chain.append(VelocityToPosition(q_start, dt))
        else:
            chain.append(InnerLoopActuator(arm, tau_in, dt))
        current = nxt
    if len(chain) > 1 and isinstance(chain[0], TwistToJointVelocity):
        chain[0].integrate_into(chain[1])  # the next link is VelocityToPosition (see _CHAIN)
    if current not in accepted:
        why = "the controller has no arm model to convert it" if arm is None else "no adapter converts it"
        raise IncompatibleCommandError(
            command_type.value,
            plant.name,
            [a.value for a in accepted],
            f"the controller commands {command_type.value} but the {plant.name!r} plant accepts "
            f"{' or '.join(a.value for a in accepted)} and {why} (chain: "
            f"{' -> '.join(c.value for c in _CHAIN)})",
        )
    plant.use_input(current)
    return chain
