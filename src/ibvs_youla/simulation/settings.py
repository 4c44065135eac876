"""Settings of one closed-loop simulation, validated at construction.

The gains default to the paper's (Section 7, Eq. (63)-(66)): tau_in = 0.01 s,
omega_n = 10 rad/s, zeta = 10, tau_forward = 0.1 tau_in, no actuator saturation.
The joint loop runs at 1 kHz and the camera, by default, at 100 Hz (the ZED 2's
highest frame rate, in its VGA mode); :meth:`SimulationSettings.paper` runs the camera
at the joint rate. The paper states no sampling rate: one rate for both loops is its
idealization, and 1 kHz the joint rate used here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .._validation import flag, integer, positive
from ..control.redundancy import JointLimitAvoidance, secondary_task_from
from ..controllers.youla import BRANCH_PRIORS, FEEDFORWARD_KINDS, LINEARIZE_AT, YoulaSettings
from ..exceptions import InvalidParameterError

__all__ = ["BRANCH_PRIORS", "FEEDFORWARD_KINDS", "LINEARIZE_AT", "SimulationSettings"]


@dataclass(frozen=True)
class SimulationSettings(YoulaSettings):
    """How a scenario is simulated: rates, plant options, and the paper controller's gains.

    The gains and options of the paper's controller are the fields of :class:`YoulaSettings`
    (``tau_in``, ``omega_n``, ``zeta``, ``tau_forward``, ``feedforward``,
    ``smooth_speed_fraction``, ``sv_policy``, ``linearize_at``, ``estimate_from_image``,
    ``branch_prior``), inherited so that they are written flat (``SimulationSettings(
    omega_n=5)``, TOML ``[settings]``). They apply to the named controllers ``"fb"`` and
    ``"ff+fb"``; ``tau_in`` is also the time constant of the inner loop that turns joint
    position references into torque (and of the kinematic arm's ideal inner loop).

    Attributes:
        joint_rate_hz: Joint-loop (inner controller, feedforward, RK4) rate [Hz].
        camera_rate_hz: Camera / outer-loop rate [Hz]; default 100 Hz, the ZED 2's VGA
            frame rate (ERRATA 15); ``None`` runs it at the joint rate (the paper's
            idealization). Must divide the joint rate. On the free-flying camera it is the
            control rate.
        model_inertia_scale: The controller's arm model has its link masses and inertias
            multiplied by this factor (1.0 = perfect feedback linearization).
        saturate: Clip joint torques and speeds at the arm's limits (off in the paper).
        record_every: Keep every n-th tick in the result (joint-loop samples on an arm,
            control periods on the free-flying camera).
        secondary_task: On a redundant arm (n > 6 joints), the null-space task that the
            twist-commanding methods add to J_C^+ [v; w]
            (:class:`~ibvs_youla.control.redundancy.JointLimitAvoidance`, or its data); None (the
            default) for none. In :meth:`to_dict` (a run's spec) only when set.
    """

    joint_rate_hz: float = 1000.0
    camera_rate_hz: float | None = 100.0
    model_inertia_scale: float = 1.0
    saturate: bool = False
    record_every: int = 1
    secondary_task: JointLimitAvoidance | None = None

    @classmethod
    def paper(cls, **overrides: Any) -> SimulationSettings:
        """The paper's settings (Section 7): its gains, camera and joint loop at one rate (1 kHz)."""
        return cls(**{"camera_rate_hz": None, **overrides})

    def __post_init__(self) -> None:
        super().__post_init__()  # the controller's gains, validated and normalised once
        set_ = object.__setattr__
        set_(self, "joint_rate_hz", positive(self.joint_rate_hz, "joint_rate_hz", unit="Hz"))
        if self.camera_rate_hz is not None:
            set_(self, "camera_rate_hz", positive(self.camera_rate_hz, "camera_rate_hz", unit="Hz"))
            ratio = self.joint_rate_hz / self.camera_rate_hz
            if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-9:
                raise InvalidParameterError(
                    "camera_rate_hz",
                    self.camera_rate_hz,
                    f"a rate that divides joint_rate_hz = {self.joint_rate_hz} Hz (e.g. "
                    f"{self.joint_rate_hz / 10:g} Hz)",
                )
        set_(self, "model_inertia_scale", positive(self.model_inertia_scale, "model_inertia_scale"))
        set_(self, "saturate", flag(self.saturate, "saturate"))
        set_(self, "record_every", integer(self.record_every, "record_every", low=1))
        set_(self, "secondary_task", secondary_task_from(self.secondary_task))

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form (JSON, TOML); ``secondary_task`` only when set (earlier specs unchanged)."""
        d = super().to_dict()
        if self.secondary_task is None:
            del d["secondary_task"]
        else:
            d["secondary_task"] = self.secondary_task.to_dict()
        return d

    def controller_settings(self) -> YoulaSettings:
        """The paper controller's gains and options held here, as :class:`YoulaSettings`."""
        return YoulaSettings(**{name: getattr(self, name) for name in YoulaSettings.field_names()})

    @property
    def dt(self) -> float:
        """Joint-loop sample time [s]."""
        return 1.0 / self.joint_rate_hz

    @property
    def camera_every(self) -> int:
        """Number of joint-loop samples per camera frame."""
        if self.camera_rate_hz is None:
            return 1
        return round(self.joint_rate_hz / self.camera_rate_hz)
