"""Feedforward: the inverse of the inner loop, and a realistic smooth variant (Section 6.2).

The paper's feedforward inverts the inner closed loop T_in (Eq. (46)) and adds a
double pole to make the inverse proper:

    T_forward = (tau_in s + 1)^3 / ((3 tau_in s + 1)(tau_f s + 1)^2),   tau_f = 0.1 tau_in
                                                                       (Eq. (47)-(49), (65))

so that, in continuous time, the joints follow T_in T_forward = 1/(tau_f s + 1)^2. Fed
with a step of the desired configuration q_des this *ideal* chain moves a joint by Delta
in about 2 tau_f = 2 ms without overshoot: peak speed |Delta|/(e tau_f) (about
368 |Delta| rad/s) and initial acceleration |Delta|/tau_f^2, far beyond the IRB 4600's
175-360 deg/s (ERRATA 11). Eq. (48) is also biproper with high-frequency gain
tau_in^2/(3 tau_f^2) = 33.3, so q_ff itself jumps by 33.3 Delta at t = 0+.

**The sampled chain does not follow 1/(tau_f s + 1)^2.** At the paper's joint rate
dt = 1 ms = tau_f, the chain that is actually simulated (ZOH T_forward -> Tustin inner
controller -> ZOH double integrator, :meth:`FeedforwardDesign.sampled_tracking`) is much
more violent: for scenario 1's joint-4 step of -82.7 deg the peak joint speed is 292x
the 250 deg/s limit (ideal formula: 122x) and the joint swings to 2.80 times the step
(-232 deg, an overshoot of 180 %) before settling. At dt = 0.1 ms the figures are 135x
and 14 %; they tend to the ideal ones as dt -> 0. The difference is sampling, not the
feedback loop: q_ff jumps 33x the step and changes on the scale of one sample, and its
staircase is not the continuous q_ff whenever dt is not << tau_f
(:meth:`FeedforwardDesign.sampled_step_demand`).

The realistic variant (ERRATA 11) feeds the same filter with a minimum-jerk (quintic)
joint trajectory from q_start to q_des whose duration keeps the peak joint speed at a
chosen fraction of the speed limits. The joints then follow that trajectory through
1/(tau_f s + 1)^2, whose impulse response is positive with unit area, so their peak
speed cannot exceed the trajectory's. The trajectory is :class:`MinimumJerkTrajectory`
(:mod:`ibvs_youla.control.trajectory`, re-exported here).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import control as ct
import numpy as np

from .._memory import fits_in_memory
from .._validation import as_array, integer, positive, real
from ..exceptions import InvalidParameterError
from .discrete import DiscreteFilter
from .inner import InnerLoopDesign
from .trajectory import MinimumJerkTrajectory

__all__ = ["TAU_FORWARD_RATIO_RANGE", "FeedforwardDesign", "FeedforwardRuntime", "MinimumJerkTrajectory"]

# tau_forward / tau_in accepted (the paper's is 0.1): T_forward's high-frequency gain
# tau_in^2/(3 tau_f^2) stays between 3e-7 (above round-off when T_forward is realized) and 3e11.
TAU_FORWARD_RATIO_RANGE = (1e-6, 1e3)


@dataclass(frozen=True)
class FeedforwardDesign:
    """The paper's feedforward T_forward (Eq. (47)-(49)) and its runtimes.

    Attributes:
        tau_in: Inner-loop time constant [s] (Eq. (41), (63)), in
            :data:`~ibvs_youla.control.inner.TAU_IN_RANGE_S`.
        tau_forward: Time constant of the added double pole [s], tau_in times a ratio in
            :data:`TAU_FORWARD_RATIO_RANGE`; ``None`` (default) means 0.1 tau_in (Eq. (49),
            (65)) and is resolved at construction.

    Raises:
        InvalidParameterError: a time constant that is not a real number in its range.
    """

    tau_in: float = 0.01
    tau_forward: float | None = None

    def __post_init__(self) -> None:
        tau_in = InnerLoopDesign(self.tau_in).tau_in
        low, high = (r * tau_in for r in TAU_FORWARD_RATIO_RANGE)
        tau_f = (
            0.1 * tau_in
            if self.tau_forward is None
            else real(self.tau_forward, "tau_forward", unit="s (1e-6 to 1e3 tau_in)", low=low, high=high)
        )
        object.__setattr__(self, "tau_in", tau_in)
        object.__setattr__(self, "tau_forward", tau_f)

    @property
    def inner(self) -> InnerLoopDesign:
        """The inner-loop design this feedforward inverts."""
        return InnerLoopDesign(self.tau_in)

    def filter_tf(self) -> ct.TransferFunction:
        """T_forward = (tau_in s + 1)^3 / ((3 tau_in s + 1)(tau_f s + 1)^2) (Eq. (48))."""
        t, tf_ = self.tau_in, self.tau_forward
        num = [t**3, 3.0 * t**2, 3.0 * t, 1.0]
        den = np.polymul([3.0 * t, 1.0], [tf_**2, 2.0 * tf_, 1.0])
        return ct.tf(num, den)

    def tracking_tf(self) -> ct.TransferFunction:
        """What the joints follow in continuous time: T_in T_forward = 1/(tau_f s + 1)^2.

        Only for dt << tau_f; the sampled chain is :meth:`sampled_tracking`.
        """
        tf_ = self.tau_forward
        return ct.tf([1.0], [tf_**2, 2.0 * tf_, 1.0])

    @property
    def high_frequency_gain(self) -> float:
        """T_forward(s -> inf) = tau_in^2 / (3 tau_f^2): the jump of q_ff per unit step."""
        return self.tau_in**2 / (3.0 * self.tau_forward**2)

    def step_demand(self, delta_q: Any) -> tuple[np.ndarray, np.ndarray]:
        """Ideal continuous joint demand of a step delta_q under the paper's feedforward (ERRATA 11).

        In continuous time q(t) = Delta (1 - (1 + t/tau_f) e^(-t/tau_f)). This is a
        lower bound of what the 1 kHz simulation sees: see :meth:`sampled_step_demand`.

        Returns:
            (peak speed |Delta|/(e tau_f) [rad/s], peak acceleration |Delta|/tau_f^2
            [rad/s^2]), each shaped like delta_q.
        """
        d = np.abs(as_array(delta_q, "delta_q"))
        return d / (np.e * self.tau_forward), d / self.tau_forward**2

    def sampled_tracking(self, dt: float = 1e-3, n_joints: int = 1) -> ct.StateSpace:
        """The sampled chain q_des -> (q, dq) the simulation runs, as a discrete system.

        q_des (a step, held) -> T_forward discretized with ZOH exactly as
        :meth:`step_runtime` does -> inner loop v = G_C(z)(q_ff - q) with G_C discretized
        with Tustin exactly as :meth:`InnerLoopDesign.discrete_controller` does -> the
        double integrator q'' = v with v held over each sample (ZOH, exact). The
        double integrator is discretized with *both* states as outputs,

            [q; dq][k+1] = [[1, dt], [0, 1]] [q; dq][k] + [dt^2/2; dt] v[k],

        and the loop is closed on q only. Under the held v the true speed is linear
        between samples, so its extremes fall on samples: max_k |dq[k]| is the exact
        peak speed of the continuous joint, not an estimate (a difference quotient
        (q[k+1] - q[k])/dt would be the mean speed over a sample, lower than the peak).
        The joint dynamics is the inner loop's design model (computed torque makes
        the arm a double integrator, Eq. (36)); no outer loop.

        Args:
            dt: Joint-loop sampling period [s], in (0, tau_in].
            n_joints: Number of independent joints n.

        Returns:
            Discrete state-space system (timebase dt) with n inputs q_des and 2n
            outputs: the joint angles q (outputs 0..n-1), then the speeds dq
            (outputs n..2n-1). The DC gain from q_des to q is 1.
        """
        n = integer(n_joints, "n_joints", low=1)
        ff = DiscreteFilter.from_tf(self.filter_tf(), dt, 1, method="zoh")
        gc = self.inner.discrete_controller(dt, 1, method="tustin")  # checks 0 < dt <= tau_in
        dt = ff.dt
        ffd = ct.ss(*ff.matrices, dt)
        gcd = ct.ss(*gc.matrices, dt)
        double_integrator = ct.ss([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], np.eye(2), np.zeros((2, 1)))
        plant = ct.c2d(double_integrator, dt, "zoh")  # outputs (q, dq)
        loop = ct.feedback(plant * gcd, np.array([[1.0, 0.0]]))  # v = G_C (q_ff - q)
        siso = loop * ffd  # 1 input q_des, outputs (q, dq)
        if n == 1:
            return siso
        stacked = ct.append(*([siso] * n))  # outputs q_1, dq_1, q_2, dq_2, ...
        order = np.r_[0 : 2 * n : 2, 1 : 2 * n : 2]
        return ct.ss(stacked.A, stacked.B, stacked.C[order], stacked.D[order], dt)

    def sampled_step_demand(
        self, delta_q: Any, dt: float = 1e-3, horizon: float | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Peak joint speed and overshoot of a step delta_q through the *sampled* chain.

        Simulates :meth:`sampled_tracking` (SISO, linear, so one unit step scales to
        every joint) for ``horizon`` seconds (default 20 tau_in + 200 dt, long after
        every transient). At dt = tau_f = 1 ms the peak speed is 2.40 times the ideal
        |Delta|/(e tau_f) of :meth:`step_demand` and the joints overshoot by 180 % of
        the step; at dt = 0.1 ms 1.11 times and 14 %; both tend to the ideal (1x, no
        overshoot) as dt -> 0.

        Args:
            delta_q: Step sizes [rad], any shape.
            dt: Joint-loop sampling period [s], in (0, tau_in].
            horizon: Simulated time [s]; ``None`` for the default.

        Returns:
            (peak speed max_t |dq(t)| [rad/s], shaped like delta_q; overshoot
            max_t q(t)/Delta - 1 as a fraction of the step, a float, 0 if none).
        """
        d = as_array(delta_q, "delta_q")
        sys = self.sampled_tracking(dt, 1)
        dt = float(sys.dt)
        if horizon is None:
            horizon = 20.0 * self.tau_in + 200.0 * dt
        samples = positive(horizon, "horizon", unit="s") / dt + 1.0  # a float: inf for 1e308 s
        # python-control's step response holds the time, the state (9) and the outputs (2)
        fits_in_memory(8.0 * 12.0 * samples, "horizon", horizon, "a shorter horizon or a larger dt")
        n = math.ceil(samples)
        y = ct.step_response(sys, np.arange(n) * dt).outputs[:, 0, :]
        peak_speed = float(np.max(np.abs(y[1])))
        overshoot = max(float(np.max(y[0])) - 1.0, 0.0)
        return np.abs(d) * peak_speed, overshoot

    # ------------------------------------------------------------------ runtimes
    def step_runtime(self, q_start: Any, q_des: Any, dt: float = 1e-3) -> FeedforwardRuntime:
        """The paper's feedforward: T_forward driven by a step from q_start to q_des at t = 0.

        ZOH discretization: the input is constant after the step, so the sampled
        output equals the continuous one exactly at every sample.
        """
        q0 = as_array(q_start, "q_start", (None,))
        q1 = as_array(q_des, "q_des", q0.shape)
        filt = DiscreteFilter.from_tf(self.filter_tf(), self._check_dt(dt), q0.size, method="zoh")
        return FeedforwardRuntime(filt, q0, q1, None)

    def smooth_runtime(
        self,
        q_start: Any,
        q_des: Any,
        speed_limits: Any,
        dt: float = 1e-3,
        speed_fraction: float = 0.5,
        min_duration: float = 0.1,
    ) -> FeedforwardRuntime:
        """Realistic feedforward: T_forward driven by a speed-limited minimum-jerk trajectory.

        FOH discretization: exact for an input that is linear between samples; the
        quintic differs from its chord by at most dt^2 max|q''|/8 per sample.
        Arguments as in :meth:`MinimumJerkTrajectory.within_speed_limits`.
        """
        traj = MinimumJerkTrajectory.within_speed_limits(
            q_start, q_des, speed_limits, fraction=speed_fraction, min_duration=min_duration
        )
        filt = DiscreteFilter.from_tf(self.filter_tf(), self._check_dt(dt), traj.q_start.size, method="foh")
        return FeedforwardRuntime(filt, traj.q_start, traj.q_des, traj)

    def _check_dt(self, dt: Any) -> float:
        """A sampling period > 0 not below 1e-8 of the slowest pole's time constant.

        Slower poles map to within 1e-8 of z = 1: the filter would hold an integrator where
        T_forward has none, and could not start at rest at q_start.
        """
        dt = positive(dt, "dt", unit="s")
        slowest = max(self.tau_forward, 3.0 * self.tau_in)
        if dt < 1e-8 * slowest:
            raise InvalidParameterError(
                "dt", dt, f"a sampling period >= 1e-8 times T_forward's slowest time constant ({slowest:g} s)"
            )
        return dt


class FeedforwardRuntime:
    """Discrete q_ff = T_forward(z)[r] at the joint rate; r is a step or a trajectory.

    Built by :meth:`FeedforwardDesign.step_runtime` or
    :meth:`FeedforwardDesign.smooth_runtime`. The filter starts at rest at q_start
    (q_ff(0-) = q_start) and the input r leaves q_start at t = 0. Each call of
    :meth:`step` returns q_ff at the current sample t_k = k dt and advances k.
    The first call returns q_start for the smooth runtime and
    q_start + tau_in^2/(3 tau_f^2) (q_des - q_start) for the paper's step (Eq. (48)
    is biproper).

    Args:
        filt: The discretized T_forward, one channel per joint.
        q_start: Initial joint vector [rad].
        q_des: Desired joint vector [rad].
        trajectory: Input trajectory, or ``None`` for a step to q_des at t = 0.
    """

    def __init__(
        self,
        filt: DiscreteFilter,
        q_start: np.ndarray,
        q_des: np.ndarray,
        trajectory: MinimumJerkTrajectory | None,
    ) -> None:
        self._filter = filt
        self._q_start = np.array(q_start, dtype=float)
        self._q_des = np.array(q_des, dtype=float)
        self._trajectory = trajectory
        self._k = 0
        self.reset()

    @property
    def dt(self) -> float:
        """Sampling period [s]."""
        return self._filter.dt

    @property
    def time(self) -> float:
        """Time t_k [s] of the sample the next :meth:`step` returns."""
        return self._k * self._filter.dt

    @property
    def q_start(self) -> np.ndarray:
        """Initial joint vector [rad] (copy)."""
        return self._q_start.copy()

    @property
    def q_des(self) -> np.ndarray:
        """Desired joint vector [rad] (copy)."""
        return self._q_des.copy()

    @property
    def trajectory(self) -> MinimumJerkTrajectory | None:
        """The smooth input trajectory, or ``None`` for the paper's step."""
        return self._trajectory

    def reference(self, t: float) -> np.ndarray:
        """Input r(t) of the filter: q_start before 0, then q_des or the trajectory."""
        if t < 0.0:
            return self._q_start.copy()
        if self._trajectory is None:
            return self._q_des.copy()
        return self._trajectory.position(t)

    def step(self) -> np.ndarray:
        """Return q_ff(t_k) [rad], shape (n,), then advance to t_{k+1}."""
        r = self._q_des if self._trajectory is None else self._trajectory.position(self._k * self._filter.dt)
        self._k += 1
        return self._filter.step(r)

    def reset(self) -> None:
        """Back to t = 0, filter at rest at q_start."""
        self._filter.reset_steady_state(self._q_start)
        self._k = 0
