"""Model mismatch and actuator limits of the dynamic arm: the plant's arm, not the controller's.

:class:`PlantArm` is what :class:`~ibvs_youla.simulation.plant.ArmPlant` integrates when the
true arm differs from the controller's model. It stands in for an :class:`~ibvs_youla.Arm`
(the plant reads ``aba``, ``camera_fk`` and the limits; everything else is the wrapped arm's):

* **masses and inertias**: the wrapped arm is the controller's arm with its link masses and
  rotational inertias scaled (``Arm.with_inertia_scale``), built by the caller; kinematics,
  hence the camera pose, are unchanged;
* **joint friction**, in the plant only (the controller's feedback linearization, Eq. (33),
  does not know it): ``tau_f = b dq + c tanh(dq / v_s)`` subtracted from the applied torque,
  viscous ``b`` [N m s/rad] and Coulomb ``c`` [N m] per joint. The Coulomb law is regularized
  over ``v_s`` (default 0.05 rad/s, 2.9 deg/s: 76 % of ``c`` at v_s, 99.9 % at 4 v_s), which
  keeps the held-torque RK4 step stable: the slope c / v_s against the smallest joint inertia
  (0.15 kg m^2 at the IRB 4600's wrist) gives dt c / (v_s M) = 0.14 for c = 1 N m at 1 kHz;
* **limits**: ``dq_max`` and ``tau_max`` scaled by ``limit_scale``, where the plant clips
  (``ArmPlant(saturate_torque=True, saturate_speed=True)``).

Without friction, ``aba`` is the wrapped arm's own kernel: no cost per step. The plant's RK4
(:class:`~ibvs_youla.simulation.integrators.ArmRk4`, compiled or around ``pin.aba``) does not call
``aba``: it reads :meth:`PlantArm.friction_parameters` and applies the same law at every stage.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..._validation import as_array

__all__ = ["PlantArm"]


class PlantArm:
    """The dynamic plant's arm: another arm's dynamics plus friction, with scaled limits.

    Args:
        arm: The true arm (e.g. the controller's arm with scaled inertias).
        viscous: Viscous friction b (n,) [N m s/rad] (zeros: none).
        coulomb: Coulomb friction c (n,) [N m] (zeros: none).
        coulomb_speed: Regularization speed v_s of the Coulomb law [rad/s].
        limit_scale: Factor on the arm's speed and torque limits (1: the datasheet's).
    """

    def __init__(
        self,
        arm: Any,
        *,
        viscous: np.ndarray,
        coulomb: np.ndarray,
        coulomb_speed: float = 0.05,
        limit_scale: float = 1.0,
    ) -> None:
        self.arm = arm
        self.viscous = np.array(viscous, dtype=float)
        self.coulomb = np.array(coulomb, dtype=float)
        self.coulomb_speed = float(coulomb_speed)
        self.dq_max = np.asarray(arm.dq_max) * limit_scale  # [rad/s]
        self.tau_max = np.asarray(arm.tau_max) * limit_scale  # [N m]
        self.name = arm.name
        if not (self.viscous.any() or self.coulomb.any()):
            self.aba = arm.aba

    def __getattr__(self, name: str) -> Any:
        """Kinematics, joint limits and the rest are the wrapped arm's."""
        if name == "arm":  # not set yet (unpickling): no recursion
            raise AttributeError(name)
        return getattr(self.arm, name)

    def friction_parameters(self) -> tuple[np.ndarray, np.ndarray, float]:
        """(b (n,) [N m s/rad], c (n,) [N m], v_s [rad/s]): the friction law, for the plant's RK4."""
        return self.viscous, self.coulomb, self.coulomb_speed

    def forward_dynamics(self, q: Any, dq: Any, tau: Any) -> np.ndarray:
        """Joint accelerations (n,) [rad/s^2] under ``tau`` minus the friction (validated :meth:`aba`)."""
        n = self.viscous.shape[0]
        dq, tau = as_array(dq, "dq", (n,)), as_array(tau, "tau", (n,))
        return self.arm.forward_dynamics(q, dq, tau - self.friction(dq))

    def friction(self, dq: np.ndarray) -> np.ndarray:
        """tau_f = b dq + c tanh(dq / v_s) (n,) [N m] (module docstring)."""
        return self.viscous * dq + self.coulomb * np.tanh(dq / self.coulomb_speed)

    def aba(self, q: np.ndarray, dq: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Joint accelerations under ``tau`` minus the friction torque (the plant's kernel)."""
        return self.arm.aba(q, dq, tau - self.friction(dq))
