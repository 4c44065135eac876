"""The paper's controller: adaptive SVD/Youla outer image loop, with or without feedforward.

Figures 7-12 of the paper, as one :class:`~.base.Controller` that commands a joint position
reference ``q_ref = q_ff + q_fb`` at every joint tick:

* camera rate (:meth:`YoulaController.update`): the image error ``e = feature_target - features`` drives
  the outer loop ``q_fb = K(z)[J^+ e]`` (Eq. (53)-(61), ERRATA 9), with the 9x6 image
  Jacobian J re-linearized at every frame at the configuration estimated from the image by
  stereo P3P + IK (Eq. (62), ``adaptive=True``), or evaluated once at the first frame
  (``adaptive=False``, at ``linearize_at``);
* joint rate (:meth:`YoulaController.command`): the feedforward ``q_ff = T_forward(z)[q_des]``
  (Eq. (47)-(49)), started at rest at q_start, plus the held q_fb.

The inner loop of Eq. (33)-(46) is not part of this controller: it is the actuation that
turns any joint position reference into torque on the dynamic arm
(:class:`ibvs_youla.simulation.actuation.InnerLoopActuator`), so other controllers that
command joint positions run through the same inner loop.

Feedback only (``feedforward=False``) has no feedforward: ``q_ff = 0`` and the outer loop's
integrator starts at ``q_fb = q_start`` (bumpless start). With feedforward,
``q_ff(0-) = q_start`` and ``q_fb`` starts at 0.

Everything the controller knows comes from its :class:`~.base.ServoTask`: its own arm
model (for J and the IK of Eq. (62)), camera and marker coordinates, which the simulator
sets equal to the truth unless told otherwise.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np

from .._validation import flag, instance, one_of, real
from ..control.feedforward import FeedforwardDesign
from ..control.outer import OuterLoopDesign
from ..control.singular_values import SingularValuePolicy
from ..estimation.eye_in_hand import EyeInHand
from ..exceptions import InvalidParameterError
from ..model.camera import StereoCamera
from .base import CameraFrame, CommandType, Controller, JointReading, ServoTask

__all__ = [
    "BRANCH_PRIORS",
    "FEEDFORWARD_KINDS",
    "LINEARIZE_AT",
    "VARIANTS",
    "YoulaController",
    "YoulaSettings",
]

# The paper's two controllers: registry name -> label (feedback only; feedforward + feedback).
VARIANTS = {"fb": "feedback only", "ff+fb": "feedforward + feedback"}

FEEDFORWARD_KINDS = ("paper", "smooth")
LINEARIZE_AT = ("start", "target")
BRANCH_PRIORS = ("encoders", "previous")


@dataclass(frozen=True)
class YoulaSettings:
    """Gains and options of the paper's controller (Section 7, Eq. (63)-(66)), validated.

    Attributes:
        tau_in: Inner-loop time constant tau_in [s] (Eq. (41), (63)); the outer design and
            the feedforward invert the inner closed loop T_in it sets.
        omega_n: Outer-loop natural frequency [rad/s] (Eq. (56), (64)), below 1/tau_in.
        zeta: Outer-loop damping ratio (Eq. (56), (66)).
        tau_forward: Feedforward time constant [s]; ``None`` means 0.1 tau_in (Eq. (49), (65)).
        feedforward: ``"paper"`` (Eq. (47)-(48), a step of q_des) or ``"smooth"`` (a
            minimum-jerk joint trajectory within the speed limits; ERRATA 11).
        smooth_speed_fraction: Peak joint speed of the smooth feedforward, as a fraction
            (0, 1] of the arm's speed limits.
        sv_policy: Small-singular-value policy of the outer loop (ERRATA 7).
        linearize_at: Fixed outer loop only: J evaluated once at ``"start"`` (the
            configuration estimated from the first image) or ``"target"``.
        estimate_from_image: Evaluate the adaptive J at the configuration estimated from
            the image (Eq. (62)); False uses the encoders.
        branch_prior: The IK branch Eq. (62) returns: nearest the encoders (default) or
            nearest the previous estimate (``"previous"``, which loses track when the arm
            moves far between frames; see the README).
    """

    tau_in: float = 0.01
    omega_n: float = 10.0
    zeta: float = 10.0
    tau_forward: float | None = None
    feedforward: str = "paper"
    smooth_speed_fraction: float = 0.5
    sv_policy: SingularValuePolicy = field(default_factory=SingularValuePolicy)
    linearize_at: str = "start"
    estimate_from_image: bool = True
    branch_prior: str = "encoders"

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        # the designs validate and normalise the gains they use, with the same names and ranges
        outer = OuterLoopDesign(self.omega_n, self.zeta, self.tau_in, self.sv_policy)
        for name in ("tau_in", "omega_n", "zeta"):
            set_(self, name, getattr(outer, name))
        if self.tau_forward is not None:
            set_(self, "tau_forward", FeedforwardDesign(outer.tau_in, self.tau_forward).tau_forward)
        set_(self, "feedforward", one_of(self.feedforward, "feedforward", FEEDFORWARD_KINDS))
        frac = real(self.smooth_speed_fraction, "smooth_speed_fraction", low=0.0, low_open=True, high=1.0)
        set_(self, "smooth_speed_fraction", frac)
        set_(self, "linearize_at", one_of(self.linearize_at, "linearize_at", LINEARIZE_AT))
        set_(self, "estimate_from_image", flag(self.estimate_from_image, "estimate_from_image"))
        set_(self, "branch_prior", one_of(self.branch_prior, "branch_prior", BRANCH_PRIORS))

    @property
    def tau_ff(self) -> float:
        """Feedforward time constant actually used [s] (Eq. (49))."""
        return 0.1 * self.tau_in if self.tau_forward is None else self.tau_forward

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        """Names of the settings, e.g. to pick them out of a larger dict."""
        return tuple(f.name for f in fields(cls))

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form (JSON, TOML)."""
        d = asdict(self)
        d["sv_policy"] = asdict(self.sv_policy)
        return d


class YoulaController(Controller):
    """Li & Assadian's controller: q_ref = q_ff + q_fb (Figures 7-12); see the module docstring.

    Args:
        with_feedforward: Add the feedforward path (the paper's proposal, ``"ff+fb"``); False
            is feedback only (``"fb"``). (Which feedforward, the paper's step or the smooth
            one, is the ``feedforward`` setting.)
        adaptive: Re-linearize the outer loop at every frame (Eq. (62), Figure 12).
        settings: Gains and options; default :class:`YoulaSettings` (the paper's).
        **gains: Individual :class:`YoulaSettings` fields overriding ``settings``.

    Raises:
        InvalidParameterError: an unknown gain name or a bad value; at reset, a task
            without an arm or with a camera that is not a ``StereoCamera`` (Eq. (62) needs
            stereo P3P and the arm's IK).
    """

    command_type = CommandType.JOINT_POSITION

    def __init__(
        self,
        with_feedforward: bool = True,
        adaptive: bool = True,
        settings: YoulaSettings | None = None,
        **gains: Any,
    ) -> None:
        self.with_feedforward = flag(with_feedforward, "with_feedforward")
        self.adaptive = flag(adaptive, "adaptive")
        if settings is not None:
            instance(settings, "settings", YoulaSettings, "a YoulaSettings or None")
        unknown = sorted(set(gains) - set(YoulaSettings.field_names()))
        if unknown:
            raise InvalidParameterError(
                "gains", unknown, f"keywords among {', '.join(YoulaSettings.field_names())}"
            )
        base = YoulaSettings() if settings is None else settings
        self.settings = YoulaSettings(
            **{**{f: getattr(base, f) for f in YoulaSettings.field_names()}, **gains}
        )

    @property
    def name(self) -> str:  # type: ignore[override]
        """``"ff+fb"`` or ``"fb"``: the registry name of this variant."""
        return "ff+fb" if self.with_feedforward else "fb"

    def spec(self) -> dict[str, Any]:
        """Variant, adaptive flag and every gain."""
        return {**super().spec(), "adaptive": self.adaptive, "settings": self.settings.to_dict()}

    # ------------------------------------------------------------------ run
    def reset(self, task: ServoTask) -> None:
        """Build the eye-in-hand model, outer loop and feedforward from the task's models."""
        if task.arm is None:
            raise InvalidParameterError(
                "task.arm",
                None,
                f"an arm model: the paper's controller ({self.name!r}) commands joint "
                "positions and inverts Eq. (62) with the arm's IK",
            )
        if not isinstance(task.camera, StereoCamera):
            raise InvalidParameterError(
                "task.camera",
                type(task.camera).__name__,
                f"a StereoCamera: the paper's controller ({self.name!r}) estimates the pose by stereo P3P",
            )
        super().reset(task)
        s, arm = self.settings, task.arm
        n = arm.nq
        self._eye = EyeInHand(arm, task.camera, task.markers_O, virtual_points=task.virtual_points)
        self._feature_target = np.array(task.feature_target, dtype=float)
        outer_design = OuterLoopDesign(s.omega_n, s.zeta, s.tau_in, s.sv_policy)
        self._outer = outer_design.runtime(task.frame_period, n)
        dt = task.tick_period
        if self.with_feedforward:
            ff = FeedforwardDesign(s.tau_in, s.tau_ff)
            if s.feedforward == "paper":
                self._ff = ff.step_runtime(task.q_start, task.q_target, dt)
            else:
                self._ff = ff.smooth_runtime(
                    task.q_start, task.q_target, arm.dq_max, dt, speed_fraction=s.smooth_speed_fraction
                )
            self._outer.reset(np.zeros(n))
        else:
            self._ff = None
            self._outer.reset(task.q_start)
        self._q_fb = self._outer.q_fb
        self._q_ff = np.zeros(n)
        self._q_estimate: np.ndarray | None = None
        self._first_frame = True
        # per-frame hot path: options and kernels looked up once per run
        self._from_image, self._prior_previous = s.estimate_from_image, s.branch_prior == "previous"
        self._q_from_image, self._image_jacobian = self._eye.q_from_image, self._eye.image_jacobian
        self._q_and_jacobian = self._eye.q_and_jacobian_from_image
        self._advance = self._outer.advance

    def update(self, frame: CameraFrame, reading: JointReading | None) -> None:
        """One camera frame: q_fb = K(z)[J^+ e] (Eq. (53)-(62))."""
        features, q_enc = frame.features, reading.q  # type: ignore[union-attr]
        e = self._feature_target - features
        if self.adaptive:
            if self._from_image:  # Eq. (62), and J at its estimate from the same kinematics pass
                q_near = self._q_estimate if self._prior_previous and self._q_estimate is not None else q_enc
                self._q_estimate, J = self._q_and_jacobian(features, q_near)
            else:
                J = self._image_jacobian(q_enc)
            self._q_fb = self._advance(e, J)
        else:
            if self._first_frame:
                s = self.settings
                q_lin = (
                    self._configuration_estimate(features, q_enc)
                    if s.linearize_at == "start"
                    else self.task.q_target
                )
                self._outer.set_jacobian(self._eye.jacobian(q_lin))
            self._q_fb = self._outer.update(e)
        self._first_frame = False

    def _configuration_estimate(self, features: np.ndarray, q_enc: np.ndarray) -> np.ndarray:
        """Eq. (62): q~ from the image (the IK branch nearest the prior), or the encoders."""
        if not self._from_image:
            return q_enc
        q_near = self._q_estimate if self._prior_previous and self._q_estimate is not None else q_enc
        self._q_estimate = self._q_from_image(features, q_near)
        return self._q_estimate

    def command(self, reading: JointReading | None) -> np.ndarray:
        """q_ref = q_ff + q_fb [rad]: advances the feedforward by one joint tick."""
        if self._ff is not None:
            self._q_ff = self._ff.step()
        return self._q_ff + self._q_fb

    def signals(self) -> dict[str, np.ndarray]:
        """The two parts of the reference: ``q_ff`` and ``q_fb`` [rad]."""
        return {"q_ff": self._q_ff, "q_fb": self._q_fb}
