"""Motor and gear of each joint (Table A4) and their joint-side terms in Eq. (29).

In ``(D(q) + J) ddq + (C(q, dq) + B / r) dq + g(q) = u`` the armature J and the viscous
damping B / r come from :class:`ActuatorParameters`; :class:`~ibvs_youla.model.arm.Arm`
puts them into the Pinocchio model.
"""

from __future__ import annotations

from dataclasses import dataclass

from .._validation import non_negative, one_of, positive

__all__ = ["ActuatorParameters"]


@dataclass(frozen=True)
class ActuatorParameters:
    """Motor and gear of Table A4, and their joint-side terms in Eq. (29).

    Attributes:
        J_a: Motor armature inertia [kg m^2].
        J_g: Gear inertia [kg m^2].
        r: Gear ratio [-].
        B_m: Motor viscous damping [N m s/rad].
    """

    J_a: float = 0.09847
    J_g: float = 0.05
    r: float = 200.0
    B_m: float = 0.06

    def __post_init__(self) -> None:
        object.__setattr__(self, "r", positive(self.r, "r"))
        for name in ("J_a", "J_g", "B_m"):
            object.__setattr__(self, name, non_negative(getattr(self, name), name))

    def joint_terms(self, mapping: str = "paper") -> tuple[float, float]:
        """(armature [kg m^2], damping [N m s/rad]) seen at each joint.

        ``"paper"`` reads Eq. (29) literally: J = J_a + J_g added to D(q), damping B / r
        with B = B_m. ``"reflected"`` refers motor-side terms through the gear
        (Spong, Hutchinson & Vidyasagar, independent joint control): r^2 (J_a + J_g) and
        r^2 B_m. With Table A4 the two differ by r^3 = 8e6 in damping and r^2 = 4e4 in
        armature (0.148 vs 5939 kg m^2, the latter dwarfing the link inertias).
        """
        one_of(mapping, "actuator", ("paper", "reflected"))
        if mapping == "paper":
            return self.J_a + self.J_g, self.B_m / self.r
        return self.r**2 * (self.J_a + self.J_g), self.r**2 * self.B_m
