"""The simulated arm: true joint state, encoder readings, RK4 steps under a held torque.

The plant integrates the rigid-body dynamics of Eq. (29) (``arm.forward_dynamics``: the
ABA with armature, minus viscous damping; run in compiled code on the numbers of the arm's
Pinocchio model, which stays its reference, see :mod:`.integrators`) with fixed-step RK4, the
torque held over each step (zero-order hold).

**Encoders and the disturbance of scenario 2 (ERRATA 14).** The state is the *true*
joint angles and velocities. The encoders read ``q_encoder = q_true - d``, where ``d``
is a constant joint-angle offset the encoders do not see (1 deg on every joint in
scenario 2): the controller acts on ``q_encoder`` while the camera moves as if at
``q_encoder + d``. :meth:`ArmPlant.camera_pose` therefore uses ``q_true``.

**Saturation** (off by default, as in the paper): ``saturate_torque`` clips the applied
torque to ``+-arm.tau_max`` before the step; ``saturate_speed`` clips the joint speeds to
``+-arm.dq_max`` after the step (an ideal speed limiter of the drive; positions are not
corrected, so the clip costs at most one step of consistency).

**Divergence** (always on): after every step the plant raises
:class:`~ibvs_youla.exceptions.SimulationDivergedError`, naming the time, the quantity,
the value and the bound, instead of ever holding NaN, when

* ``tau`` (input), ``q`` or ``dq`` holds a non-finite entry;
* ``|dq_i| > speed_factor * dq_max_i`` (default 1000x, a safety net for numerical
  blow-up, not a physical limit: the paper's 1 ms feedforward, ERRATA 11, sampled at
  dt = tau_f, legitimately reaches 292x the speed limit of joint 4 in scenario 1 (the
  ideal continuous formula says 122x; ``FeedforwardDesign.sampled_step_demand``), so a
  tighter bound would reject the paper's own setting. Even 1000x is not enough for
  every legal step: a 149.5 deg step of joint 2 through the same feedforward exceeds
  it through the arm's coupling (joint 3 reaches 3194 rad/s at t = 2 ms, beyond
  1000 x 175 deg/s = 3054 rad/s); raise ``DivergenceBounds.speed_factor`` to
  run such a step);
* ``q_true`` leaves ``[q_min - position_margin, q_max + position_margin]`` (default
  margin one full turn, 2 pi rad: the paper does not enforce joint limits, but a joint a
  whole turn beyond its mechanical stop is a diverged run).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validation import as_array, flag, instance, positive, real
from ..controllers.base import CommandType, JointReading
from ..exceptions import InvalidParameterError, SimulationDivergedError
from .integrators import ArmRk4

__all__ = ["ArmPlant", "DivergenceBounds"]


# what the plant uses of its arm (an Arm, or the disturbances' PlantArm around one)
_ARM_INTERFACE = (
    "aba",
    "forward_dynamics",
    "camera_fk",
    "camera_pose",
    "q_min",
    "q_max",
    "dq_max",
    "tau_max",
)


@dataclass(frozen=True)
class DivergenceBounds:
    """When the plant declares a run diverged (module docstring).

    Attributes:
        speed_factor: Divergence when ``|dq_i| > speed_factor * dq_max_i``.
        position_margin: Divergence when ``q_true`` is more than this beyond a joint limit [rad].
    """

    speed_factor: float = 1000.0
    position_margin: float = 2.0 * math.pi

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "speed_factor", positive(self.speed_factor, "speed_factor"))
        set_(self, "position_margin", positive(self.position_margin, "position_margin", unit="rad"))


class ArmPlant:
    """Simulated arm with encoder offset, optional saturation and divergence checks.

    As the dynamic-arm plant of the servo loop it accepts a joint torque held over each
    step (:meth:`apply`), reads its encoders (:meth:`reading`) and records ``q`` (encoders),
    ``q_true`` and ``dq``.

    Args:
        arm: The arm model (``forward_dynamics``, ``q_min``, ``q_max``, ``dq_max``,
            ``tau_max``, ``camera_pose``), e.g. ``Arm.irb4600()``.
        joint_offset: Disturbance ``d`` (n,) [rad], true = encoder + d (ERRATA 14);
            ``None`` for none.
        q_encoder: Initial encoder reading (n,) [rad]; default zeros. The true arm
            starts at ``q_encoder + d``.
        dq: Initial joint velocities (n,) [rad/s]; default zeros.
        t: Initial time [s].
        saturate_torque: Clip torques at ``arm.tau_max``.
        saturate_speed: Clip joint speeds at ``arm.dq_max``.
        bounds: Divergence bounds.
    """

    def __init__(
        self,
        arm: Any,
        joint_offset: Any = None,
        *,
        q_encoder: Any = None,
        dq: Any = None,
        t: float = 0.0,
        saturate_torque: bool = False,
        saturate_speed: bool = False,
        bounds: DivergenceBounds | None = None,
    ) -> None:
        from ..model.arm import Arm

        if not isinstance(arm, Arm) and not all(hasattr(arm, a) for a in _ARM_INTERFACE):
            # an Arm, or what wraps one for the plant (the disturbances' PlantArm: friction, limits)
            instance(arm, "arm", Arm, "an Arm, or an object with its " + ", ".join(_ARM_INTERFACE))
        self.arm = arm
        self._n = len(np.asarray(arm.q_min))
        n = self._n
        d = np.zeros(n) if joint_offset is None else as_array(joint_offset, "joint_offset", (n,))
        self.joint_offset = d.copy()
        self.joint_offset.setflags(write=False)
        self.saturate_torque = flag(saturate_torque, "saturate_torque")
        self.saturate_speed = flag(saturate_speed, "saturate_speed")
        self.bounds = (
            DivergenceBounds()
            if bounds is None
            else instance(bounds, "bounds", DivergenceBounds, "DivergenceBounds")
        )
        self._q_min = np.asarray(arm.q_min, dtype=float)
        self._q_max = np.asarray(arm.q_max, dtype=float)
        self._dq_max = np.asarray(arm.dq_max, dtype=float)
        self._tau_max = np.asarray(arm.tau_max, dtype=float)
        self._dq_bound = self.bounds.speed_factor * self._dq_max
        margin = self.bounds.position_margin
        self._x_low = np.concatenate([self._q_min - margin, -self._dq_bound])  # packed [q; dq] bounds
        self._x_high = np.concatenate([self._q_max + margin, self._dq_bound])
        # RK4 of the arm's dynamics, bounds tested; the joint friction of a PlantArm (None: none)
        friction = getattr(arm, "friction_parameters", None)
        b, c, v_s = (None, None, 0.05) if friction is None else friction()
        self._rk4 = ArmRk4(arm, self._x_low, self._x_high, viscous=b, coulomb=c, coulomb_speed=v_s)
        self._camera_fk = arm.camera_fk  # the kernel of arm.camera_pose: the state is always finite
        q_encoder = np.zeros(n) if q_encoder is None else q_encoder
        self.reset(q_encoder, np.zeros(n) if dq is None else dq, t=t)

    # ------------------------------------------------------------------ state
    def reset(self, q_encoder: Any, dq: Any = None, *, t: float = 0.0) -> None:
        """Set the state from an encoder reading (true angles = ``q_encoder + d``)."""
        q_encoder = as_array(q_encoder, "q_encoder", (self._n,))
        dq = np.zeros(self._n) if dq is None else as_array(dq, "dq", (self._n,))
        self.t = real(t, "t", unit="s")
        self._set_state(np.concatenate([q_encoder + self.joint_offset, dq]))
        self.last_tau = np.zeros(self._n)

    def _set_state(self, x: np.ndarray) -> None:
        """Adopt the packed state x = [q_true; dq] (2n,); ``_q`` and ``_dq`` view it."""
        self._x = x
        self._q, self._dq = x[: self._n], x[self._n :]

    @property
    def q_true(self) -> np.ndarray:
        """True joint angles (n,) [rad] (a copy)."""
        return self._q.copy()

    @property
    def q_encoder(self) -> np.ndarray:
        """Encoder reading ``q_true - d`` (n,) [rad] (a copy)."""
        return self._q - self.joint_offset

    @property
    def dq(self) -> np.ndarray:
        """Joint velocities (n,) [rad/s] (a copy; the offset is constant, so encoders see these too)."""
        return self._dq.copy()

    def camera_pose(self) -> np.ndarray:
        """True camera pose ``T_O_C`` (4, 4): ``arm.camera_pose(q_true)``.

        The state is the plant's own and finite (checked after every step): the arm's
        forward-kinematics kernel is called without validation.
        """
        return self._camera_fk(self._q)

    # ------------------------------------------------------------------ servo-loop role
    name = "dynamic"
    accepts = (CommandType.JOINT_TORQUE,)

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return self._n

    def use_input(self, command_type: CommandType | str) -> None:
        """The dynamic arm takes joint torques only; anything else raises InvalidParameterError."""
        if CommandType.parse(command_type) is not CommandType.JOINT_TORQUE:
            raise InvalidParameterError(
                "command_type", command_type, "joint_torque (the dynamic arm's input)"
            )

    def reading(self) -> JointReading:
        """Encoder reading now: ``q_true - d`` and ``dq`` (arrays the plant replaces, never modifies)."""
        return JointReading(self.t, self._q - self.joint_offset, self._dq)

    def apply(self, command: np.ndarray, dt: float) -> None:
        """Hold the joint torque ``command`` (n,) [N m] over ``dt``: one RK4 step, then the divergence test.

        The kernel of :meth:`step`, called by the servo loop at every tick: it does not
        validate its arguments (``command`` a float (n,) array, possibly non-finite, ``dt`` >
        0). The caller holds ``np.errstate(all="ignore")`` (the servo loop does). The
        divergence test is one comparison of the packed state with its bounds, inside the
        compiled end of the RK4 step (NaN fails it); only when it fails are the quantities
        examined, in the order of the module docstring, to raise SimulationDivergedError with
        the state left at the start of the step.
        """
        tau = command
        if self.saturate_torque:
            tau = np.clip(tau, -self._tau_max, self._tau_max)
        x, inside = self._rk4.step(self._x, tau, dt)
        if not inside:
            if not np.all(np.isfinite(tau)):
                self._diverged(self.t, "tau", tau, "finite values")
            self._check(self.t + dt, x[: self._n], x[self._n :])
        n = self._n
        if self.saturate_speed:
            x[n:] = np.clip(x[n:], -self._dq_max, self._dq_max)
        self._x, self._q, self._dq = x, x[:n], x[n:]  # _set_state, inline (every tick)
        self.t += dt
        self.last_tau = tau

    signal_names = ("q", "q_true", "dq")

    def signal_values(self, reading: JointReading) -> tuple[np.ndarray, ...]:
        """Signals recorded at tick rate, in the order of ``signal_names``: encoders, true angles, speeds."""
        return reading.q, self._q, self._dq

    # ------------------------------------------------------------------ dynamics
    def step(self, tau: Any, dt: float) -> np.ndarray:
        """Integrate one RK4 step with ``tau`` held, then check for divergence (:meth:`apply`).

        Args:
            tau: Joint torques (n,) [N m], clipped at ``arm.tau_max`` if ``saturate_torque``.
            dt: Step [s], > 0.

        Returns:
            The torque actually applied (after saturation) (n,) [N m].

        Raises:
            InvalidParameterError, InvalidArrayError: ``dt`` <= 0, ``tau`` not of shape (n,).
            SimulationDivergedError: non-finite torque or state, or a bound exceeded; the
                state is left at the start of the failed step.
        """
        if not dt > 0.0:
            positive(dt, "dt", unit="s")
        tau = as_array(tau, "tau", (self._n,), finite=False)  # a non-finite torque is a divergence
        with np.errstate(all="ignore"):
            self.apply(tau, dt)
        return self.last_tau

    def _check(self, t: float, q: np.ndarray, dq: np.ndarray) -> None:
        for name, value in (("q", q), ("dq", dq)):
            if not np.all(np.isfinite(value)):
                self._diverged(t, name, value, "finite values")
        over = np.abs(dq) > self._dq_bound
        if np.any(over):
            j = int(np.argmax(np.abs(dq) / self._dq_bound))
            self._diverged(
                t,
                "dq",
                dq,
                self._dq_bound,
                f"|dq_{j + 1}| = {abs(dq[j]):.4g} rad/s > {self._dq_bound[j]:.4g} rad/s "
                f"({self.bounds.speed_factor:g} x the speed limit {self._dq_max[j]:.4g} rad/s)",
            )
        margin = self.bounds.position_margin
        low, high = self._q_min - margin, self._q_max + margin
        if np.any((q < low) | (q > high)):
            j = int(np.argmax(np.maximum(low - q, q - high)))
            self._diverged(
                t,
                "q",
                q,
                (low, high),
                f"q_true_{j + 1} = {q[j]:.4g} rad outside [{low[j]:.4g}, {high[j]:.4g}] rad "
                f"(joint limits widened by {margin:.4g} rad)",
            )

    def _diverged(self, t: float, quantity: str, value: np.ndarray, bound: Any, detail: str = "") -> None:
        if not detail:
            bad = np.flatnonzero(~np.isfinite(value))
            detail = f"non-finite {quantity} at joints {[int(j) + 1 for j in bad]}; expected {bound}"
        raise SimulationDivergedError(
            t,
            quantity,
            np.array(value, copy=True),
            bound,
            f"simulation diverged at t = {t:.6g} s: {quantity}: {detail}",
        )
