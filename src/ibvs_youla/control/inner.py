"""Inner joint-angle loop: Youla design on the feedback-linearized arm (Section 6.1).

With the computed-torque law u = M(q) v + h(q, dq) (Eq. (33)) every joint becomes a
double integrator, G_P = 1/s^2 (Eq. (34), (37)). The paper picks the complementary
sensitivity

    T = (3 tau s + 1) / (tau s + 1)^3                                  (Eq. (41))

which satisfies the interpolation conditions T(0) = 1 and T'(0) = 0 (Eq. (38)-(39))
imposed by the two poles at s = 0. Then

    Y   = T / G_P = s^2 (3 tau s + 1) / (tau s + 1)^3                  (Eq. (42))
    S   = 1 - T  = s^2 (tau^3 s + 3 tau^2) / (tau s + 1)^3             (Eq. (43))
    G_C = Y / S  = (3 tau s + 1) / (tau^3 s + 3 tau^2)                  (Eq. (44))

since (tau s + 1)^3 - (3 tau s + 1) = s^2 (tau^3 s + 3 tau^2). The printed Eq. (42),
(44), (45) have the numerator 3 tau^2 s + 1 instead (ERRATA 8); with it the loop on
1/s^2 is unstable (closed-loop poles near +4.7 +/- 56.6j for tau = 0.01), which
:meth:`InnerLoopDesign.printed_controller` reproduces. G_C acts on e = q_ref - q and
produces the virtual acceleration v, one copy per joint (Eq. (36), (45)).
"""

from __future__ import annotations

from dataclasses import dataclass

import control as ct
import numpy as np

from .._validation import flag, integer, positive, real
from ..exceptions import InvalidParameterError
from .discrete import DiscreteFilter

__all__ = ["TAU_IN_RANGE_S", "InnerLoopDesign"]

# Time constants the designs accept [s]: beyond them the cubes of tau in the polynomials of
# Eq. (41)-(48) lose the dynamic range that python-control's realizations and the
# discretizations need (1e-300 underflows, 1e200 overflows).
TAU_IN_RANGE_S = (1e-6, 1e3)


@dataclass(frozen=True)
class InnerLoopDesign:
    """SISO Youla design of the joint loop, duplicated on every joint (Eq. (36)).

    Attributes:
        tau_in: Time constant [s], in :data:`TAU_IN_RANGE_S`; the three closed-loop poles sit
            at -1/tau_in (paper: 0.01 s, Eq. (63)). (Named as everywhere else in the library:
            ``tau`` alone is never a time constant here, since it names the joint torques.)

    Raises:
        InvalidParameterError: ``tau_in`` is not a real number in :data:`TAU_IN_RANGE_S`.
    """

    tau_in: float = 0.01

    def __post_init__(self) -> None:
        low, high = TAU_IN_RANGE_S
        object.__setattr__(self, "tau_in", real(self.tau_in, "tau_in", unit="s", low=low, high=high))

    # ------------------------------------------------------------------ transfer functions
    def plant(self) -> ct.TransferFunction:
        """G_P = 1/s^2, one feedback-linearized joint (Eq. (37))."""
        return ct.tf([1.0], [1.0, 0.0, 0.0])

    def complementary_sensitivity(self) -> ct.TransferFunction:
        """T = (3 tau s + 1)/(tau s + 1)^3 (Eq. (41), (46))."""
        t = self.tau_in
        return ct.tf([3.0 * t, 1.0], [t**3, 3.0 * t**2, 3.0 * t, 1.0])

    def sensitivity(self) -> ct.TransferFunction:
        """S = 1 - T = s^2 (tau^3 s + 3 tau^2)/(tau s + 1)^3 (Eq. (43))."""
        t = self.tau_in
        return ct.tf([t**3, 3.0 * t**2, 0.0, 0.0], [t**3, 3.0 * t**2, 3.0 * t, 1.0])

    def youla(self) -> ct.TransferFunction:
        """Y = T / G_P = s^2 (3 tau s + 1)/(tau s + 1)^3 (Eq. (40), (42) corrected)."""
        t = self.tau_in
        return ct.tf([3.0 * t, 1.0, 0.0, 0.0], [t**3, 3.0 * t**2, 3.0 * t, 1.0])

    def controller(self) -> ct.TransferFunction:
        """G_C = Y / S = (3 tau s + 1)/(tau^3 s + 3 tau^2), maps e = q_ref - q to v (ERRATA 8)."""
        t = self.tau_in
        return ct.tf([3.0 * t, 1.0], [t**3, 3.0 * t**2])

    def printed_controller(self) -> ct.TransferFunction:
        """The printed Eq. (44)-(45), numerator 3 tau^2 s + 1: destabilizes 1/s^2 (ERRATA 8)."""
        t = self.tau_in
        return ct.tf([3.0 * t**2, 1.0], [t**3, 3.0 * t**2])

    def loop_gain(self) -> ct.TransferFunction:
        """L = G_C G_P = (3 tau s + 1)/(s^2 (tau^3 s + 3 tau^2))."""
        return self.controller() * self.plant()

    # ------------------------------------------------------------------ analysis
    def closed_loop_poles(self, printed: bool = False) -> np.ndarray:
        """Roots of the characteristic polynomial s^2 den(G_C) + num(G_C).

        Args:
            printed: Use the printed (typo) controller of Eq. (44) instead.

        Returns:
            The three closed-loop poles [rad/s], sorted by real part. For the correct
            controller they are all -1/tau (numerically spread by ~1e-5 relative,
            as a triple root is ill-conditioned).
        """
        gc = self.printed_controller() if flag(printed, "printed") else self.controller()
        num = np.asarray(gc.num[0][0], dtype=float)
        den = np.asarray(gc.den[0][0], dtype=float)
        char = np.polyadd(np.polymul(den, [1.0, 0.0, 0.0]), num)
        return np.sort_complex(np.roots(char))

    def margins(self) -> tuple[float, float, float]:
        """Stability margins of the loop L = G_C / s^2.

        Returns:
            (gain margin, phase margin [deg], gain-crossover frequency [rad/s]). The
            gain margin is infinite: the phase of L stays above -180 deg. For any tau
            the phase margin is 53.13 deg (atan(4/3)) at crossover 1/tau.
        """
        gm, pm, _, wc = ct.margin(self.loop_gain())
        return float(gm), float(pm), float(wc)

    # ------------------------------------------------------------------ runtime
    def discrete_controller(
        self, dt: float = 1e-3, n_joints: int = 6, method: str = "tustin"
    ) -> DiscreteFilter:
        """G_C at the joint-loop rate, one channel per joint: ``v = filt.step(q_ref - q)``.

        Tustin is the default: it keeps the controller's pole at -3/tau stable for any
        dt, maps s = 0 to z = 1 and matches G_C's phase near the crossover 1/tau.
        Margins of the sampled loop (ZOH double integrator, tau = 10 ms; continuous
        53.1 deg, infinite gain margin): at dt = 1 ms Tustin gives phase margin
        50.26 deg and gain margin 17.7, ZOH of the controller 51.65 deg and 15.8, so
        at 1 kHz ZOH keeps slightly *more* phase (and less gain margin). Only at
        slower rates does Tustin win clearly: at dt = 5 ms 38.7 deg / 3.5 (Tustin)
        against 27.6 deg / 2.0 (ZOH).

        Args:
            dt: Joint-loop sampling period [s]; at most tau (slower sampling leaves
                no margin: the sampled loop is unstable near dt = tau with ZOH).
            n_joints: Number of joints (channels).
            method: ``"tustin"`` (default) or ``"zoh"``.
        """
        dt, n = self._check_dt(dt), integer(n_joints, "n_joints", low=1)
        return DiscreteFilter.from_tf(self.controller(), dt, n, method=method)

    def discrete_closed_loop(self, dt: float = 1e-3, n_joints: int = 6) -> DiscreteFilter:
        """T_in (Eq. (46)) as a ZOH-discretized filter: q = filt.step(q_ref).

        For kinematic simulations and tests that treat the inner loop as ideal. ZOH is
        exact when q_ref is held between samples, as the outer loop holds it.
        Initialise at rest at q0 with ``reset_steady_state(q0)``.
        """
        dt = self._check_dt(dt)
        n = integer(n_joints, "n_joints", low=1)
        return DiscreteFilter.from_tf(self.complementary_sensitivity(), dt, n, method="zoh")

    def _check_dt(self, dt: float) -> float:
        dt = positive(dt, "dt", unit="s")
        if dt > self.tau_in:
            raise InvalidParameterError("dt", dt, f"a sampling period in (0, tau_in = {self.tau_in}] s")
        return dt
