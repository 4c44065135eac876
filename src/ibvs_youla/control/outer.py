"""Outer image loop: Youla design on the linearized eye-in-hand plant (Section 6.3).

Linearized plant (Eq. (51)-(53), ERRATA 12: J is 9x6): G_p(s) = J T_in(s), with
T_in = (3 tau s + 1)/(tau s + 1)^3. Write the SVD J = U Sigma V^T (Eq. (54): the
"unimodular" matrices are just the orthogonal U (9x9) and V^T (6x6)), so
M_p = Sigma T_in with M_p(i, i) = sigma_i T_in (Eq. (55)). With the target
M_T = m_T diag(I_6, 0_3), m_T = omega^2/(s^2 + 2 zeta omega s + omega^2) (Eq. (56)):

    M_Y = M_T / M_p,    M_Y(i, i) = m_T / (sigma_i T_in)                         (Eq. (57))
    Y   = V M_Y U^T   (6x9)                                                        (Eq. (58))
    T_y = G_p Y = U Sigma V^T V M_Y U^T T_in = U M_T U^T                           (Eq. (59))
    S_y = I_9 - T_y = U diag((1 - m_T) I_6, I_3) U^T                               (Eq. (60))
    G_C = Y S_y^-1 = V M_Y diag(I_6/(1 - m_T), I_3) U^T
        = V diag(1/sigma_i) U_6^T * m_T / ((1 - m_T) T_in) = J^+ K(s)             (Eq. (61))

    K(s) = omega^2 (tau s + 1)^3 / (s (s + 2 zeta omega)(3 tau s + 1))            (ERRATA 9)

because m_T/(1 - m_T) = omega^2/(s (s + 2 zeta omega)). Eq. (58) is printed U_R M_Y U_L;
with G_p = U_L M_p U_R the inverse needs U_R^-1 = V on the left and U_L^-1 = U^T on the
right (the printed order V^T M_Y U is only dimensionally right). Rebuilding Eq. (58)-(61)
as MIMO transfer matrices (:mod:`ibvs_youla.control.literal`, which takes a design as
argument: ``literal_response(design, J, omegas)``) gives the same controller.

At low frequency K(s) ~ omega/(2 zeta s), so q_fb' ~ (omega/(2 zeta)) J^+ e: classical
IBVS with gain lambda = omega/(2 zeta) = 0.5 1/s for the paper's omega = 10 rad/s,
zeta = 10 (Eq. (64), (66)). M_T's poles are then -0.501 and -199.5 rad/s, so the loop
settles (2 %) in about 7.8 s (ERRATA 10).

Small singular values (ERRATA 7) are handled by :class:`SingularValuePolicy`, which
replaces 1/sigma_i in Eq. (57) by a bounded gain g(sigma_i)
(:mod:`ibvs_youla.control.singular_values`, re-exported here).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import control as ct
import numpy as np
from scipy.optimize import brentq

from .._validation import as_array, frequencies, instance, integer, positive, real
from ..exceptions import InvalidArrayError, InvalidParameterError
from .discrete import DiscreteFilter
from .inner import InnerLoopDesign
from .singular_values import SingularValuePolicy, SvdGains
from .svd_kernels import svd_gains_apply

__all__ = [
    "OMEGA_N_TAU_IN_MIN",
    "ZETA_RANGE",
    "OuterLoopController",
    "OuterLoopDesign",
    "SingularValuePolicy",
    "SvdGains",
]

# Smallest omega_n tau_in accepted (Section 6.3 requires < 1): below it K(s)'s feedthrough
# omega^2 tau^2/3 is lost to round-off when K is realized (scipy trims it as zero).
OMEGA_N_TAU_IN_MIN = 1e-6
ZETA_RANGE = (1e-6, 1e12)  # damping ratios accepted: K(z) stays realizable in double precision
_EPS = float(np.finfo(float).eps)


@dataclass(frozen=True)
class OuterLoopDesign:
    """Outer Youla design; collapses to q_fb = J^+ K(s) e (Eq. (53)-(61), ERRATA 9).

    Attributes:
        omega_n: Natural frequency of M_T [rad/s] (Eq. (56), (64)), in
            [:data:`OMEGA_N_TAU_IN_MIN` / tau_in, 1 / tau_in): Section 6.3 requires 1/omega_n > tau_in.
        zeta: Damping ratio of M_T (Eq. (56), (66)), in :data:`ZETA_RANGE`.
        tau_in: Inner-loop time constant [s] (Eq. (41), (63)), in
            :data:`~ibvs_youla.control.inner.TAU_IN_RANGE_S`.
        sv_policy: Small-singular-value policy (ERRATA 7).

    Raises:
        InvalidParameterError: a gain that is not a real number in its range, or a policy
            that is not a :class:`SingularValuePolicy`.
    """

    omega_n: float = 10.0
    zeta: float = 10.0
    tau_in: float = 0.01
    sv_policy: SingularValuePolicy = field(default_factory=SingularValuePolicy)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        tau = InnerLoopDesign(self.tau_in).tau_in
        w_min, w_max = OMEGA_N_TAU_IN_MIN / tau, 1.0 / tau
        valid = f"a number in [{OMEGA_N_TAU_IN_MIN:g}/tau_in, 1/tau_in = {w_max:g}) rad/s (Section 6.3)"
        try:
            w = real(self.omega_n, "omega_n", low=w_min, high=w_max, high_open=True)
        except InvalidParameterError:
            raise InvalidParameterError("omega_n", self.omega_n, valid) from None
        if w * tau >= 1.0:  # below 1/tau_in, yet not by round-off
            raise InvalidParameterError("omega_n", self.omega_n, valid)
        set_(self, "tau_in", tau)
        set_(self, "omega_n", w)
        set_(self, "zeta", real(self.zeta, "zeta", low=ZETA_RANGE[0], high=ZETA_RANGE[1]))
        instance(self.sv_policy, "sv_policy", SingularValuePolicy, "a SingularValuePolicy")

    # ------------------------------------------------------------------ SISO pieces
    def inner_tf(self) -> ct.TransferFunction:
        """T_in = (3 tau s + 1)/(tau s + 1)^3 (Eq. (46), (53))."""
        t = self.tau_in
        return ct.tf([3.0 * t, 1.0], [t**3, 3.0 * t**2, 3.0 * t, 1.0])

    def target_tf(self) -> ct.TransferFunction:
        """m_T = omega^2/(s^2 + 2 zeta omega s + omega^2), each controlled channel (Eq. (56))."""
        w, z = self.omega_n, self.zeta
        return ct.tf([w**2], [1.0, 2.0 * z * w, w**2])

    def target_poles(self) -> np.ndarray:
        """Poles of m_T [rad/s], -zeta omega +/- omega sqrt(zeta^2 - 1), slowest first.

        Overdamped, the slow pole is computed as -omega / (zeta + sqrt(zeta^2 - 1)) (their
        product is omega^2): the textbook -zeta omega + omega sqrt(zeta^2 - 1) cancels to 0
        for zeta >~ 1e8.
        """
        w, z = self.omega_n, self.zeta
        if z < 1.0:
            wd = w * math.sqrt((1.0 - z) * (1.0 + z))
            return np.array([complex(-z * w, wd), complex(-z * w, -wd)])
        root = z * math.sqrt((1.0 - 1.0 / z) * (1.0 + 1.0 / z))  # sqrt(zeta^2 - 1), no overflow
        return np.array([-w / (z + root), -w * (z + root)], dtype=complex)

    def settling_time(self, threshold: float = 0.02) -> float:
        """Last time m_T's step response is outside 1 +/- ``threshold`` [s] (ERRATA 10).

        With the poles p_1, p_2 of :meth:`target_poles`, the error e = y - 1 of the step
        response is, overdamped, (p_2 e^(p_1 t) - p_1 e^(p_2 t))/(p_1 - p_2), monotone, so the
        settling time is the one root of |e| = threshold; critically damped, e^(-omega t)
        (1 + omega t), also monotone. Underdamped, |e| peaks at e^(-zeta omega t_k) at
        t_k = k pi/omega_d (omega_d = omega sqrt(1 - zeta^2)); the last exit lies between the last
        peak above the threshold and the next zero of e. Each root is bracketed exactly and
        refined with Brent's method to a relative 1e-12 (in the time scaled by the slow pole).

        Args:
            threshold: Half-width of the band around 1, in (0, 1); 0.02 for the 2 % time.

        Raises:
            InvalidParameterError: ``threshold`` outside (0, 1).
        """
        thr = real(threshold, "threshold", low=0.0, high=1.0, low_open=True, high_open=True)
        w, z = self.omega_n, self.zeta
        if z < 1.0:
            s = math.sqrt((1.0 - z) * (1.0 + z))  # omega_d / omega
            phase = z / s

            def err(x: float) -> float:  # x = omega_d t
                return math.exp(-phase * x) * abs(math.cos(x) + phase * math.sin(x)) - thr

            k = math.floor(math.log(1.0 / thr) / (phase * math.pi))  # last peak e^(-phase k pi) above thr
            if math.exp(-phase * math.pi * k) <= thr:  # on the boundary by round-off
                k -= 1
            start = k * math.pi
            zero = start + math.pi - math.atan(1.0 / phase)  # next zero of cos x + phase sin x
            x = brentq(err, start, zero, xtol=1e-12 * max(zero, 1.0), rtol=4 * _EPS)
            return x / (w * s)
        slow, fast = -self.target_poles().real  # |p_1| <= |p_2|
        if fast - slow <= 1e-6 * slow:  # critically damped (or within 1e-6 of it)

            def err(x: float) -> float:  # x = omega t
                return math.exp(-x) * (1.0 + x) - thr

            x_hi = 2.0 * math.log(2.0 / thr)  # e^-x (1 + x) <= 1.22 e^(-x/2) <= thr beyond
            return brentq(err, 0.0, x_hi, xtol=1e-12 * x_hi, rtol=4 * _EPS) / w
        ratio = fast / slow  # >= 1, may be huge (zeta = 1e12: 4e24)
        a, b = 1.0 / (1.0 - 1.0 / ratio), 1.0 / (ratio - 1.0)  # |e| = a e^-x - b e^(-ratio x), x = |p_1| t

        def err(x: float) -> float:
            return a * math.exp(-x) - b * math.exp(-ratio * x) - thr

        x_hi = math.log(a / thr) + 1e-3  # a e^-x < thr there, so |e| < thr (by 1e-3 thr: no round-off tie)
        return brentq(err, 0.0, x_hi, xtol=1e-12 * x_hi, rtol=4 * _EPS) / slow

    def filter_tf(self) -> ct.TransferFunction:
        """K(s) = omega^2 (tau s + 1)^3 / (s (s + 2 zeta omega)(3 tau s + 1)) (ERRATA 9)."""
        w, z, t = self.omega_n, self.zeta, self.tau_in
        num = w**2 * np.array([t**3, 3.0 * t**2, 3.0 * t, 1.0])
        den = np.polymul([1.0, 2.0 * z * w, 0.0], [3.0 * t, 1.0])
        return ct.tf(num, den)

    @property
    def ibvs_gain(self) -> float:
        """Omega/(2 zeta) = lim_{s->0} s K(s) [1/s], the equivalent classical IBVS gain."""
        return self.omega_n / (2.0 * self.zeta)

    # ------------------------------------------------------------------ frequency responses
    def closed_form_response(self, J: Any, omegas: Any) -> np.ndarray:
        """G_C(j omega) = P K(j omega), P the policy's pseudo-inverse of J (ERRATA 9).

        Args:
            J: Image Jacobian (m, n) [image m / rad], typically 9x6.
            omegas: Frequencies [rad/s], shape (n_w,), all > 0 (K has a pole at 0).

        Returns:
            Complex array (n_w, n, m).
        """
        w = frequencies(omegas, "omegas", "K has a pole at 0")
        P = self.sv_policy.pseudo_inverse(J)
        k = self.filter_tf()(1j * w)
        return k[:, None, None] * P[None, :, :]

    # ------------------------------------------------------------------ runtime
    def runtime(
        self, dt: float, n_joints: int = 6, J: Any = None, method: str = "tustin"
    ) -> OuterLoopController:
        """Discrete outer controller at the camera rate; see :class:`OuterLoopController`."""
        dt, n = positive(dt, "dt", unit="s"), integer(n_joints, "n_joints", low=1)
        return OuterLoopController(self, dt, n_joints=n, J=J, method=method)


class OuterLoopController:
    """Runtime outer loop: q_fb = K(z)[P(t) e(t)], filter state in joint space.

    Where the state lives matters once J varies (ERRATA 9). Here the time-varying
    matrix P = J^+ (with the SV policy) acts first and the SISO filter K, with its
    integrator, filters the joint-space signal P e. Re-linearizing J every frame
    (the adaptive loop of Eq. (62) and Fig. 12) therefore acts on q_fb mainly through
    the rate q_fb' ~ (omega/(2 zeta)) P e: K is biproper, so q_fb jumps only through
    its feedthrough D, by D (P(t+) - P(t-)) e. D is small: K(inf) = omega^2 tau^2/3 =
    3.3e-3 continuous, Tustin D = K(s = 2/dt) = 3.45e-3 at 1 kHz and 4.8e-3 at
    100 Hz, so ~3e-3 of the change of P e. The other order, q_fb = P(t) K[e], would
    keep the integrator in image space and make q_fb jump by (P(t+) - P(t-)) K[e],
    the whole accumulated integral, whenever J is re-evaluated.

    K is discretized with Tustin by default: it maps s = 0 to z = 1 (the integrator
    stays exact, so a constant residual P e is integrated without drift), keeps every
    pole stable at any camera rate, and matches K near the outer bandwidth. At low
    camera rates K's pole at -2 zeta omega maps near z = -1 (z = -0.74 at 15 Hz), a
    weakly excited alternating mode whose gain K(inf) = omega^2 tau^2/3 is small.

    Two modes: fixed (J given at construction or through :meth:`set_jacobian`, used
    while ``update`` is called without J) and adaptive (J passed to every ``update``).

    Args:
        design: The outer-loop design (gains and SV policy).
        dt: Camera / outer-loop sampling period [s].
        n_joints: Number of joints n (filter channels).
        J: Optional fixed Jacobian (m, n).
        method: Discretization of K, ``"tustin"`` (default) or ``"zoh"``/``"foh"``.
    """

    def __init__(
        self, design: OuterLoopDesign, dt: float, n_joints: int = 6, J: Any = None, method: str = "tustin"
    ) -> None:
        self._policy = design.sv_policy
        self._damped, self._threshold = self._policy.kind == "damped", self._policy.threshold
        self._filter = DiscreteFilter.from_tf(design.filter_tf(), dt, n_joints, method=method)
        self._n = n_joints
        self._fixed: SvdGains | None = None
        self._last: SvdGains | None = None
        self._last_J: np.ndarray | None = None  # the J of the last `advance`, factorized when asked
        self._q_fb = np.zeros(n_joints)
        if J is not None:
            self.set_jacobian(J)
        self.reset()

    @property
    def dt(self) -> float:
        """Sampling period [s]."""
        return self._filter.dt

    @property
    def q_fb(self) -> np.ndarray:
        """Last output q_fb [rad] (copy); the reset value before the first update."""
        return self._q_fb.copy()

    @property
    def last_decomposition(self) -> SvdGains | None:
        """SVD and gains used by the last update (or the fixed one), for logging.

        After :meth:`advance`, factorized when read, from the same J by the same LAPACK call (the
        same floats as the update used).
        """
        if self._last_J is not None:
            self._last, self._last_J = SvdGains.from_svd(*self._policy.svd_gains(self._last_J)), None
        return self._last

    def set_jacobian(self, J: Any) -> None:
        """Fix the Jacobian (m, n) used when :meth:`update` gets no J."""
        J = as_array(J, "J", (None, self._n))
        self._fixed = self._last = self._policy.decompose(J)
        self._last_J = None

    def update(self, e_image: Any, J: Any = None) -> np.ndarray:
        """One camera sample: ``q_fb[k] = K(z)[P e][k]``.

        Args:
            e_image: Image error e = feature_target - features (m,) [m on the sensor].
            J: Current image Jacobian (m, n); ``None`` uses the fixed one.

        Returns:
            q_fb [rad], shape (n,), the feedback joint reference added to q_ff.
        """
        if J is not None:
            J = as_array(J, "J", (None, self._n))
            if J.shape[0] == 0:
                raise InvalidArrayError(
                    "J", f"an array of shape {J.shape}", f"shape (m, {self._n}) with m >= 1"
                )
            return self.advance(as_array(e_image, "e_image", (J.shape[0],)), J).copy()
        if self._fixed is None:
            raise InvalidParameterError("J", None, "an (m, n) Jacobian: no fixed Jacobian was set")
        P = self._fixed.pinv
        self._q_fb = self._filter.step(P @ as_array(e_image, "e_image", (P.shape[1],)))
        return self._q_fb.copy()

    def advance(self, e_image: np.ndarray, J: np.ndarray) -> np.ndarray:
        """One adaptive camera sample, q_fb = K(z)[V diag(g) U^T e] with J = U Sigma V^T.

        Kernel of ``update(e_image, J)``, called by the servo loop's controller at every frame:
        does not validate its arguments, which must be finite float64 arrays e (m,) [m on the
        sensor] and J (m, n). P e is evaluated as V (g * (U^T e)), in one compiled call with the SVD
        and the gains (:func:`~ibvs_youla.control.svd_kernels.svd_gains_apply`); the
        pseudo-inverse itself is formed only if :attr:`last_decomposition` is read. Returns the
        controller's own q_fb array (not a copy): do not modify it.
        """
        Pe = np.empty(J.shape[1])
        if not svd_gains_apply(J, e_image, self._damped, self._threshold, Pe):
            # LAPACK failed, or no direction to control: the reference raises (or returns NaN)
            U, _, g, Vt = self._policy.svd_gains(J)
            Pe = Vt.T.dot(g * U.T.dot(e_image))
        self._last_J = J
        self._q_fb = self._filter.step(Pe)
        return self._q_fb

    def reset(self, q_fb0: Any = None) -> None:
        """Rest at q_fb = q_fb0 (zeros by default): the output stays q_fb0 while P e = 0."""
        q0 = np.zeros(self._n) if q_fb0 is None else as_array(q_fb0, "q_fb0", (self._n,))
        self._filter.reset_output(q0)
        self._q_fb = q0.copy()
