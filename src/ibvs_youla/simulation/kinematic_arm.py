"""Kinematic arm plant: an ideal inner loop, for studying the image loop without dynamics.

The arm has no inertia. It accepts either command the controllers give an arm:

* a **joint velocity** dq_ref (n,) [rad/s], followed exactly: over a tick of length dt with
  dq_ref held, q <- q + dq_ref dt and dq = dq_ref (a velocity-controlled robot, as ViSP's
  simulated arms);
* a **joint position reference** q_ref (n,) [rad], followed through the inner closed loop the
  paper designs, T_in(s) = (3 tau s + 1)/(tau s + 1)^3 (Eq. (46)), per joint, with q_ref held
  over each tick. The continuous T_in is discretized exactly for a held input (zero-order
  hold, x[k+1] = e^(A dt) x[k] + A^-1 (e^(A dt) - I) B u[k]), so the sampled response equals
  the continuous one at every tick; its step response is 1 - e^(-x)(1 + x - x^2), x = t/tau.
  The joint speed is the exact derivative C A x (T_in is strictly proper, so C B = 0).

"Ideal" means the continuous design of the inner loop. The paper's sampled inner loop on the
dynamic arm (Tustin G_C at dt, torque held, exact model) is not quite that: its step deviates
from the continuous T_in by about 3.7 % of the step at 1 kHz (pinned in
``tests/test_simulate.py``), so the same controller gives slightly different runs on the two
plants even without model error.

Like the dynamic arm it has encoders offset by an unseen joint offset d (ERRATA 14):
``q_true = q + d``, and the camera moves with q_true. Joint limits are not enforced. A
non-finite command or state raises SimulationDivergedError, and so does a joint speed beyond
the dynamic arm's safety net, ``|dq_i| > speed_factor * dq_max_i`` (:class:`~.plant.DivergenceBounds`,
default 1000x the speed limit): a finite but absurd command (1e300 rad/s) is a diverged run,
not a complete one with meaningless poses.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.linalg import expm

from .._validation import as_array, positive
from ..controllers.base import CommandType, JointReading
from ..exceptions import InvalidParameterError, SimulationDivergedError
from .plant import DivergenceBounds

__all__ = ["KinematicArmPlant", "inner_closed_loop_matrices"]


def inner_closed_loop_matrices(
    tau_in: float, dt: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Exact ZOH discretization of T_in = (3 tau s + 1)/(tau s + 1)^3 in controllable form.

    Returns:
        (Ad (3, 3), Bd (3,), C (3,), CA (3,)): x[k+1] = Ad x[k] + Bd u[k], q = C x, dq = CA x.
    """
    tau = positive(tau_in, "tau_in", unit="s")
    dt = positive(dt, "dt", unit="s")
    # (tau s + 1)^3 = tau^3 (s^3 + a2 s^2 + a1 s + a0), numerator 3 tau s + 1
    a2, a1, a0 = 3.0 / tau, 3.0 / tau**2, 1.0 / tau**3
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-a0, -a1, -a2]])
    B = np.array([0.0, 0.0, 1.0])
    C = np.array([1.0 / tau**3, 3.0 / tau**2, 0.0])
    M = np.zeros((4, 4))
    M[:3, :3], M[:3, 3] = A * dt, B * dt
    E = expm(M)
    return E[:3, :3], E[:3, 3], C, C @ A


class KinematicArmPlant:
    """An arm that follows joint velocities exactly or joint positions through T_in (module docstring).

    Args:
        arm: Its kinematics (``camera_pose``, ``nq``).
        joint_offset: Unseen encoder offset d (n,) [rad]; ``None`` for none.
        q_encoder: Initial encoder reading (n,) [rad]; the arm starts at rest.
        tau_in: Time constant of the inner loop it idealizes [s] (Eq. (41), (63)).
        dt: Tick period [s] (needed for the exact discretization).
        speed_factor: Divergence when ``|dq_i| > speed_factor * dq_max_i``; default that of
            :class:`~.plant.DivergenceBounds`.
    """

    name = "kinematic"
    accepts = (CommandType.JOINT_VELOCITY, CommandType.JOINT_POSITION)

    def __init__(
        self,
        arm: Any,
        joint_offset: Any = None,
        *,
        q_encoder: Any,
        tau_in: float = 0.01,
        dt: float = 1e-3,
        speed_factor: float = DivergenceBounds.speed_factor,
    ) -> None:
        if not (hasattr(arm, "camera_fk") and hasattr(arm, "nq")):
            raise InvalidParameterError("arm", type(arm).__name__, "an Arm (its kinematics move the camera)")
        self.arm = arm
        n = self._n = int(arm.nq)
        d = np.zeros(n) if joint_offset is None else as_array(joint_offset, "joint_offset", (n,))
        self.joint_offset = d.copy()
        self.joint_offset.setflags(write=False)
        self._Ad, self._Bd, self._C, self._CA = inner_closed_loop_matrices(tau_in, dt)
        self.dt = positive(dt, "dt", unit="s")
        self._speed_factor = positive(speed_factor, "speed_factor")
        self._dq_bound = self._speed_factor * np.asarray(arm.dq_max, dtype=float)
        self._fast_speed_sq = float(np.min(self._dq_bound)) ** 2  # below it, every joint is within its bound
        q0 = as_array(q_encoder, "q_encoder", (n,))
        # At rest with output q0: x = q0 / C[0] * e1 (equilibrium of the controllable form)
        self._x: np.ndarray | None = np.outer(np.array([1.0, 0.0, 0.0]) * tau_in**3, q0)
        self._q = q0 + d
        self._dq = np.zeros(n)
        self.t = 0.0
        self.input_type = CommandType.JOINT_POSITION

    def use_input(self, command_type: CommandType | str) -> None:
        """Choose which accepted command :meth:`apply` receives (joint velocity or position)."""
        command_type = CommandType.parse(command_type)
        if command_type not in self.accepts:
            raise InvalidParameterError(
                "command_type", command_type, " or ".join(c.value for c in self.accepts)
            )
        self.input_type = command_type

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return self._n

    def reading(self) -> JointReading:
        """Encoders ``q_true - d`` and joint speeds."""
        return JointReading(self.t, self._q - self.joint_offset, self._dq)

    def camera_pose(self) -> np.ndarray:
        """True camera pose T_O_C (4, 4) at q_true."""
        return self.arm.camera_fk(self._q)  # the kernel of camera_pose: the state is always finite

    signal_names = ("q", "q_true", "dq")

    def signal_values(self, reading: JointReading) -> tuple[np.ndarray, ...]:
        """Signals recorded at tick rate, in the order of ``signal_names``: encoders, true angles, speeds."""
        return reading.q, self._q, self._dq

    def apply(self, command: np.ndarray, dt: float) -> None:
        """Hold ``command`` over ``dt``: a joint velocity or a position reference (see :meth:`use_input`)."""
        command_type = self.input_type
        square = float(np.dot(command, command))  # finite when every entry is (or an overflow: then look)
        if not math.isfinite(square) and not np.all(np.isfinite(command)):
            raise SimulationDivergedError(
                self.t,
                "command",
                np.array(command),
                "finite values",
                f"simulation diverged at t = {self.t:.6g} s: non-finite "
                f"{command_type.value} command {np.asarray(command).tolist()}",
            )
        x = self._x
        if command_type is CommandType.JOINT_VELOCITY:
            q = self._q + command * dt
            dq = np.array(command, dtype=float)
            speed_sq = square
            x = None  # the position loop's state: at rest at the new position, made when needed
        else:
            if abs(dt - self.dt) > 1e-12 * self.dt:
                raise InvalidParameterError("dt", dt, f"the period the plant was built for, {self.dt:g} s")
            if x is None:  # after joint velocities: the position loop at rest where the arm is
                x = np.outer(np.array([1.0, 0.0, 0.0]) * (1.0 / self._C[0]), self._q - self.joint_offset)
            x = self._Ad @ x + np.outer(self._Bd, command)
            q = self._C @ x + self.joint_offset
            dq = self._CA @ x
            speed_sq = float(dq.dot(dq))
        if not (speed_sq <= self._fast_speed_sq and math.isfinite(q.dot(q))):  # cheap; NaN fails too
            self._check(self.t + dt, q, dq)
        self._x, self._q, self._dq = x, q, dq
        self.t += dt

    def _check(self, t: float, q: np.ndarray, dq: np.ndarray) -> None:
        """Raise SimulationDivergedError if q or dq is not finite or a speed is beyond its bound."""
        for name, value in (("q", q), ("dq", dq)):
            if not np.all(np.isfinite(value)):
                bad = [int(j) + 1 for j in np.flatnonzero(~np.isfinite(value))]
                raise SimulationDivergedError(
                    t,
                    name,
                    np.array(value),
                    "finite values",
                    f"simulation diverged at t = {t:.6g} s: {name}: non-finite {name} at joints {bad}",
                )
        ratio = np.abs(dq) / self._dq_bound
        j = int(np.argmax(ratio))
        if ratio[j] > 1.0:
            raise SimulationDivergedError(
                t,
                "dq",
                np.array(dq),
                self._dq_bound,
                f"simulation diverged at t = {t:.6g} s: dq: |dq_{j + 1}| = {abs(dq[j]):.4g} rad/s > "
                f"{self._dq_bound[j]:.4g} rad/s ({self._speed_factor:g} x the speed limit)",
            )
