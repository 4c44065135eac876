"""Closed-loop simulation of the paper's control architecture (Figures 7-12).

One joint-loop sample k (period dt, default 1 ms) does, in this order:

1. camera frame (every ``camera_every`` samples): the stereo camera sees the markers
   from the *true* arm configuration ``q_true = q + d`` (ERRATA 14); the image error
   ``e = p_target - p`` drives the outer loop ``q_fb = K(z)[J^+ e]`` (Eq. (53)-(61),
   ERRATA 9), with J re-linearized at the configuration estimated from the image by
   stereo P3P + IK (Eq. (62), adaptive) or evaluated once (fixed);
2. feedforward ``q_ff = T_forward(z)[q_des]`` (Eq. (47)-(49)), started at rest at q_start;
3. inner loop ``v = G_C(z)[q_ref - q]`` with ``q_ref = q_ff + q_fb`` (Eq. (41)-(46),
   ERRATA 8) and feedback linearization ``tau = M(q) v + h(q, dq)`` (Eq. (33)) computed
   from the encoders with the controller's arm model;
4. the plant integrates ``M ddq + h = tau`` with RK4 over dt, tau held (Eq. (29)-(30)).

Feedback only (``controller="fb"``) has no feedforward: ``q_ff = 0`` and the outer
loop's integrator starts at ``q_fb = q_start`` (bumpless start). Feedforward plus
feedback starts with ``q_ff = q_start`` and ``q_fb = 0``.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from .._validation import one_of, positive
from ..control.feedforward import FeedforwardDesign
from ..control.inner import InnerLoopDesign
from ..control.outer import OuterLoopDesign
from ..estimation.eye_in_hand import EyeInHand
from ..exceptions import (
    InvalidDisparityError,
    InvalidParameterError,
    PointBehindCameraError,
    SimulationDivergedError,
    UnreachablePoseError,
)
from ..model.arm import Arm
from ..model.camera import StereoCamera
from ..scenarios import Scenario
from .plant import ArmPlant
from .results import ResultRecorder, SimulationResult, software_versions
from .settings import SimulationSettings

__all__ = ["CONTROLLERS", "default_camera", "simulate"]

CONTROLLERS = ("fb", "ff+fb")


def default_camera(**overrides: object) -> StereoCamera:
    """The camera ``simulate`` uses unless told otherwise.

    The paper's ZED 2 optics (Table A3) in the VGA mode, whose 100 fps matches the default
    100 Hz camera rate (ERRATA 15); ``overrides`` go to :meth:`StereoCamera.zed2`.
    """
    return StereoCamera.zed2(**{"mode": "VGA", **overrides})


def simulate(
    scenario: Scenario,
    controller: str = "ff+fb",
    adaptive: bool = True,
    duration: float = 10.0,
    *,
    settings: SimulationSettings | None = None,
    arm: Arm | None = None,
    camera: StereoCamera | None = None,
    progress: bool = False,
) -> SimulationResult:
    """Simulate one scenario in closed loop and return every signal as data.

    Args:
        scenario: Start, target, markers and disturbance (e.g. ``scenarios.paper(1)``).
        controller: ``"ff+fb"`` (feedforward + feedback, the paper's proposal) or
            ``"fb"`` (feedback only).
        adaptive: Re-linearize the outer loop at every camera frame at the configuration
            estimated from the image (Eq. (62)); False evaluates J once
            (``settings.linearize_at``).
        duration: Simulated time [s].
        settings: Rates, gains and options; default ``SimulationSettings()``: the paper's
            gains, joint loop at 1 kHz, camera at 100 Hz. ``SimulationSettings.paper()``
            runs the camera at the joint rate, as the reproduction does.
        arm: The plant's arm; default ``Arm.irb4600()``.
        camera: The stereo camera; default ``StereoCamera.zed2(mode="VGA")``: the paper's
            optics (Table A3) in the ZED 2 mode whose frame rate reaches 100 Hz.
        progress: Show a progress bar (tqdm) on stderr.

    Returns:
        The result. ``metadata["status"]`` is ``"complete"``; ``"markers_lost"`` when a
        physical (non-virtual) marker went behind the camera; or ``"estimate_failed"`` when
        no IK branch within the joint limits reaches the camera pose seen in the image
        (Eq. (62); e.g. the paper's feedforward swung a joint past its limit, which the
        plant, having no hard stops, allows). The run stops there and
        ``metadata["error"]`` says when and why.

    Raises:
        InvalidParameterError: unknown controller, non-positive duration, or a scenario,
            settings, arm or camera of the wrong type.
        JointLimitError: the scenario's configurations are outside the arm's limits.
        SimulationDivergedError: a state left its bounds; ``error.partial`` holds the
            samples recorded until then.
    """
    one_of(controller, "controller", CONTROLLERS)
    duration = positive(duration, "duration", unit="s")
    for name, value, kind in (
        ("scenario", scenario, Scenario),
        ("settings", settings, SimulationSettings),
        ("arm", arm, Arm),
        ("camera", camera, StereoCamera),
    ):
        if not (isinstance(value, kind) or (value is None and name != "scenario")):
            raise InvalidParameterError(name, type(value).__name__, f"a {kind.__name__}")
    settings = SimulationSettings() if settings is None else settings
    arm = Arm.irb4600() if arm is None else arm
    camera = default_camera() if camera is None else camera
    scenario.validate_for(arm)
    return _Run(scenario, controller, bool(adaptive), duration, settings, arm, camera).run(progress)


class _Run:
    """State of one simulation; built and consumed by :func:`simulate`."""

    def __init__(
        self,
        scenario: Scenario,
        controller: str,
        adaptive: bool,
        duration: float,
        settings: SimulationSettings,
        arm: Arm,
        camera: StereoCamera,
    ) -> None:
        s = settings
        self.scenario, self.controller, self.adaptive, self.settings = scenario, controller, adaptive, s
        self.dt = s.dt
        self.n_steps = round(duration / self.dt)
        self.model = arm if s.model_inertia_scale == 1.0 else arm.with_inertia_scale(s.model_inertia_scale)
        self.eye = EyeInHand(arm, camera, scenario.markers_O, virtual_points=scenario.virtual_points)
        self.plant = ArmPlant(
            arm,
            scenario.joint_offset,
            q_encoder=scenario.q_start,
            saturate_torque=s.saturate,
            saturate_speed=s.saturate,
        )
        self.T_O_C_target = arm.camera_pose(scenario.q_target)
        self.p_target = self.eye.features_at_pose(self.T_O_C_target)

        self.inner = InnerLoopDesign(s.tau_in).discrete_controller(self.dt, arm.nq)
        outer_design = OuterLoopDesign(s.omega_n, s.zeta, s.tau_in, s.sv_policy)
        self.outer = outer_design.runtime(self.dt * s.camera_every, arm.nq)
        if controller == "ff+fb":
            ff = FeedforwardDesign(s.tau_in, s.tau_ff)
            if s.feedforward == "paper":
                self.ff = ff.step_runtime(scenario.q_start, scenario.q_target, self.dt)
            else:
                self.ff = ff.smooth_runtime(
                    scenario.q_start,
                    scenario.q_target,
                    arm.dq_max,
                    self.dt,
                    speed_fraction=s.smooth_speed_fraction,
                )
            self.outer.reset(np.zeros(arm.nq))
        else:
            self.ff = None
            self.outer.reset(scenario.q_start)

        n_records = self.n_steps // s.record_every + 2
        self.recorder = ResultRecorder(
            self.p_target, self.T_O_C_target, n_records, n_joints=arm.nq, metadata=self._metadata(arm, camera)
        )

    def _metadata(self, arm: Arm, camera: StereoCamera) -> dict[str, Any]:
        sc = self.scenario
        return {
            "scenario": sc.name,
            "scenario_description": sc.description,
            "controller": self.controller,
            "adaptive": self.adaptive,
            "duration": self.n_steps * self.dt,
            "joint_rate_hz": self.settings.joint_rate_hz,
            "camera_rate_hz": self.settings.joint_rate_hz / self.settings.camera_every,
            "settings": self.settings.to_dict(),
            "q_start": sc.q_start.tolist(),
            "q_target": sc.q_target.tolist(),
            "joint_offset": sc.joint_offset.tolist(),
            "q_encoder_goal": sc.q_encoder_goal.tolist(),
            "virtual_points": sc.virtual_points,
            "markers_O": sc.markers_O.tolist(),
            "arm": arm.name,
            "camera": repr(camera),
            "versions": software_versions(),
        }

    # ------------------------------------------------------------------ loop
    def run(self, progress: bool) -> SimulationResult:
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=self.n_steps, unit="step", desc=self.scenario.name or "simulate", leave=False)
        try:
            status = self._loop(bar)
        except SimulationDivergedError as err:
            err.partial = self.recorder.result(status="diverged", extra_metadata={"error": str(err)})
            raise
        finally:
            if bar is not None:
                bar.close()
        extra = {} if status == "complete" else {"error": self._stop_reason}
        return self.recorder.result(status=status, extra_metadata=extra)

    def _camera_frame(self, q_enc: np.ndarray) -> np.ndarray:
        """Measure, estimate, linearize and update the outer loop; return q_fb.

        One forward-kinematics pass of the true arm gives the camera pose, reused for the
        features, the visibility flag and the recorded pose of this sample. The library's
        unchecked twins are called (``_project_flat``, ``_estimate_q``, ``_jacobian``, ``_update``):
        every array here is built by the loop itself; ``tests/test_fast_paths.py`` pins them
        to the checked methods.
        """
        eye = self.eye
        camera = eye.camera
        self.T_O_C = T_O_C = self.plant._camera_pose()
        P_C = eye._points_in_camera_at_pose(T_O_C)
        p = camera._project_flat(P_C, eye.virtual_points)
        self.p_measured = p
        self.visible = camera._visible_each(P_C)
        tic = time.perf_counter()
        e = self.p_target - p
        if self.adaptive:
            q_fb = self.outer._update(e, eye._jacobian(self._configuration_estimate(p, q_enc)))
        else:
            if self.k == 0:
                q_lin = (
                    self._configuration_estimate(p, q_enc)
                    if self.settings.linearize_at == "start"
                    else self.scenario.q_target
                )
                self.outer.set_jacobian(eye.jacobian(q_lin))
            q_fb = self.outer.update(e)
        self.recorder.record_update_time(time.perf_counter() - tic)
        return q_fb

    def _configuration_estimate(self, p: np.ndarray, q_enc: np.ndarray) -> np.ndarray:
        """Eq. (62): q~ from the image, or the encoders.

        The image fixes the camera pose, which up to eight IK branches reach; the branch
        is the one nearest ``settings.branch_prior``: the encoders (default) or the
        previous estimate.
        """
        if not self.settings.estimate_from_image:
            return q_enc
        use_previous = self.settings.branch_prior == "previous" and self.q_estimate is not None
        q_near = self.q_estimate if use_previous else q_enc
        self.q_estimate = self.eye._estimate_q(p, q_near)
        return self.q_estimate

    def _loop(self, bar: Any) -> str:
        # A diverging state raises SimulationDivergedError from the plant; numpy's overflow and
        # invalid-value warnings on the way there are noise (one errstate for the whole run).
        with np.errstate(all="ignore"):
            return self._steps(bar)

    def _steps(self, bar: Any) -> str:
        plant, model, inner, ff, dt = self.plant, self.model, self.inner, self.ff, self.dt
        camera_every, record_every = self.settings.camera_every, self.settings.record_every
        n_steps = self.n_steps
        record, camera_frame = self.recorder.record, self._camera_frame
        q_ff = np.zeros(model.nq)
        q_fb = self.outer.q_fb
        self.q_estimate: np.ndarray | None = None
        for k in range(n_steps + 1):
            self.k = k
            q_enc, dq = plant.q_encoder, plant._dq  # arrays the plant replaces, never modifies
            frame = k % camera_every == 0
            if frame:
                try:
                    q_fb = camera_frame(q_enc)
                except (PointBehindCameraError, InvalidDisparityError) as err:
                    self._stop_reason = f"t = {k * dt:.6g} s: {err}"
                    return "markers_lost"
                except UnreachablePoseError as err:
                    self._stop_reason = f"t = {k * dt:.6g} s: Eq. (62) failed: {err}"
                    return "estimate_failed"
            if ff is not None:
                q_ff = ff.step()
            q_ref = q_ff + q_fb
            v = inner._step(q_ref - q_enc)
            tau = model._inverse_dynamics(q_enc, dq, v)  # M(q) v + h(q, dq) of Eq. (33), one RNEA pass
            if k % record_every == 0 or k == n_steps:
                record(
                    k * dt,
                    q=q_enc,
                    q_true=plant._q,
                    dq=dq,
                    q_ref=q_ref,
                    q_ff=q_ff,
                    q_fb=q_fb,
                    tau=tau,
                    features=self.p_measured,
                    camera_pose=self.T_O_C if frame else plant._camera_pose(),
                    visible=self.visible,
                )
            if k < n_steps:
                plant._step(tau, dt)
            if bar is not None and k % 1000 == 0 and k:
                bar.update(1000)
        return "complete"
