"""Settings of one closed-loop simulation, validated at construction.

The gains default to the paper's (Section 7, Eq. (63)-(66)): tau_in = 0.01 s,
omega_n = 10 rad/s, zeta = 10, tau_forward = 0.1 tau_in, no actuator saturation.
The joint loop runs at 1 kHz and the camera, by default, at 100 Hz (the ZED 2's
highest frame rate, in its VGA mode); :meth:`SimulationSettings.paper` runs the camera
at the joint rate. The paper states no sampling rate: one rate for both loops is its
idealization, and 1 kHz the joint rate used here.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from .._validation import positive
from ..control.singular_values import SingularValuePolicy
from ..controllers.youla import BRANCH_PRIORS, FEEDFORWARD_KINDS, LINEARIZE_AT, YoulaSettings
from ..exceptions import InvalidParameterError

__all__ = ["BRANCH_PRIORS", "FEEDFORWARD_KINDS", "LINEARIZE_AT", "SimulationSettings"]


@dataclass(frozen=True)
class SimulationSettings:
    """How a scenario is simulated (rates, gains, plant/model mismatch, limits).

    Attributes:
        joint_rate_hz: Joint-loop (inner controller, feedforward, RK4) rate [Hz].
        camera_rate_hz: Camera / outer-loop rate [Hz]; default 100 Hz, the ZED 2's VGA
            frame rate (ERRATA 15); ``None`` runs it at the joint rate (the paper's
            idealization). Must divide the joint rate.
        tau_in: Inner-loop time constant tau_in [s] (Eq. (41), (63)).
        omega_n: Outer-loop natural frequency [rad/s] (Eq. (56), (64)).
        zeta: Outer-loop damping ratio (Eq. (56), (66)).
        tau_forward: Feedforward time constant [s]; ``None`` means 0.1 tau_in (Eq. (49), (65)).
        feedforward: ``"paper"`` (Eq. (47)-(48): joints follow a step of q_des in about
            2 tau_forward) or ``"smooth"`` (a minimum-jerk joint trajectory that respects
            the joint speed limits, then the same inverse inner loop; ERRATA 11).
        smooth_speed_fraction: Peak joint speed of the smooth feedforward as a fraction of
            the arm's speed limits.
        sv_policy: Small-singular-value policy of the outer loop (ERRATA 7).
        linearize_at: For the fixed (non-adaptive) outer loop, where the image Jacobian
            is evaluated once: ``"start"`` (the configuration estimated from the first
            image) or ``"target"`` (the desired configuration).
        model_inertia_scale: The controller's arm model has its link masses and inertias
            multiplied by this factor (1.0 = perfect feedback linearization).
        saturate: Clip joint torques and speeds at the arm's limits (off in the paper).
        estimate_from_image: Evaluate the adaptive Jacobian at the configuration estimated
            from the image by stereo P3P + IK (Eq. (62)); if False use the encoders.
        branch_prior: Which of the (up to eight) IK branches of the estimated camera pose
            Eq. (62) returns: the one nearest the encoder reading (``"encoders"``,
            default), or nearest the previous estimate (``"previous"``). The latter loses
            track when the arm moves far between camera frames: with the paper's 1 ms
            feedforward and a 100 Hz camera, scenario 1 jumps to the wrist-flipped branch
            (q4 + 180 deg, q6 + 180 deg) in the first frame and never reaches the target.
        record_every: Keep every n-th tick in the result (joint-loop samples on an arm,
            control periods on the free-flying camera).
    """

    joint_rate_hz: float = 1000.0
    camera_rate_hz: float | None = 100.0
    tau_in: float = 0.01
    omega_n: float = 10.0
    zeta: float = 10.0
    tau_forward: float | None = None
    feedforward: str = "paper"
    smooth_speed_fraction: float = 0.5
    sv_policy: SingularValuePolicy = field(default_factory=SingularValuePolicy)
    linearize_at: str = "start"
    model_inertia_scale: float = 1.0
    saturate: bool = False
    estimate_from_image: bool = True
    branch_prior: str = "encoders"
    record_every: int = 1

    @classmethod
    def paper(cls, **overrides: Any) -> SimulationSettings:
        """The paper's settings (Section 7): its gains, camera and joint loop at one rate (1 kHz)."""
        return cls(**{"camera_rate_hz": None, **overrides})

    def __post_init__(self) -> None:
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
        # The controller's gains are validated (and normalised) once, by YoulaSettings.
        gains = YoulaSettings(**{name: getattr(self, name) for name in YoulaSettings.field_names()})
        for name in YoulaSettings.field_names():
            set_(self, name, getattr(gains, name))
        set_(self, "model_inertia_scale", positive(self.model_inertia_scale, "model_inertia_scale"))
        if not isinstance(self.saturate, (bool, np.bool_)):
            raise InvalidParameterError("saturate", self.saturate, "True or False")
        set_(self, "saturate", bool(self.saturate))
        record_every = self.record_every
        if (
            isinstance(record_every, bool)
            or not isinstance(record_every, (int, np.integer))
            or record_every < 1
        ):
            raise InvalidParameterError("record_every", record_every, "an integer >= 1")

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

    @property
    def tau_ff(self) -> float:
        """Feedforward time constant actually used [s] (Eq. (49))."""
        return 0.1 * self.tau_in if self.tau_forward is None else self.tau_forward

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form (for result metadata and TOML round trips)."""
        d = asdict(self)
        d["sv_policy"] = asdict(self.sv_policy)
        return d
