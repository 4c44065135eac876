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

from dataclasses import dataclass, field
from typing import Any

import control as ct
import numpy as np
from scipy.optimize import brentq

from .._validation import as_array, frequencies, positive
from ..exceptions import InvalidParameterError
from .discrete import DiscreteFilter
from .singular_values import SingularValuePolicy, SvdGains
from .svd_kernels import svd_gains_apply

__all__ = ["OuterLoopController", "OuterLoopDesign", "SingularValuePolicy", "SvdGains"]


@dataclass(frozen=True)
class OuterLoopDesign:
    """Outer Youla design; collapses to q_fb = J^+ K(s) e (Eq. (53)-(61), ERRATA 9).

    Attributes:
        omega_n: Natural frequency of M_T [rad/s] (Eq. (56), (64)).
        zeta: Damping ratio of M_T (Eq. (56), (66)).
        tau_in: Inner-loop time constant [s] (Eq. (41), (63)). Section 6.3 requires
            1/omega_n > tau_in; violating it raises InvalidParameterError.
        sv_policy: Small-singular-value policy (ERRATA 7).
    """

    omega_n: float = 10.0
    zeta: float = 10.0
    tau_in: float = 0.01
    sv_policy: SingularValuePolicy = field(default_factory=SingularValuePolicy)

    def __post_init__(self) -> None:
        w = positive(self.omega_n, "omega_n", unit="rad/s")
        positive(self.zeta, "zeta")
        tau = positive(self.tau_in, "tau_in", unit="s")
        if w * tau >= 1.0:
            raise InvalidParameterError(
                "omega_n", self.omega_n, f"(0, 1/tau_in) = (0, {1.0 / tau:g}) rad/s (Section 6.3)"
            )
        if not isinstance(self.sv_policy, SingularValuePolicy):
            raise InvalidParameterError("sv_policy", self.sv_policy, "a SingularValuePolicy")

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
        """Poles of m_T [rad/s], -zeta omega +/- omega sqrt(zeta^2 - 1), slowest first."""
        p = np.roots([1.0, 2.0 * self.zeta * self.omega_n, self.omega_n**2])
        return p[np.argsort(-p.real)]

    def settling_time(self, threshold: float = 0.02) -> float:
        """Last time m_T's step response is outside 1 +/- ``threshold`` [s] (ERRATA 10).

        Exact response y = 1 - e^(-zeta w t) (cosh(b t) + zeta w sinh(b t)/b),
        b = w sqrt(zeta^2 - 1) (imaginary when zeta < 1); the last crossing is bracketed
        on a 4001-sample grid over 12/|Re p_slow| and refined with Brent's method.
        """
        thr = positive(threshold, "threshold")
        w, z = self.omega_n, self.zeta
        b = w * np.sqrt(complex(z * z - 1.0))

        def err(t: Any) -> Any:  # |y(t) - 1| - thr, for scalar or array t
            if abs(b) < 1e-6 * w:  # critically damped limit
                return np.exp(-w * t) * (1.0 + w * t) - thr
            a, c = np.exp((b - z * w) * t), np.exp(-(b + z * w) * t)  # no overflow: Re(b) <= z w
            return np.abs(((a + c) / 2.0 + z * w * (a - c) / (2.0 * b)).real) - thr

        t_end = 12.0 / abs(float(self.target_poles()[0].real)) * max(1.0, np.log(0.02 / min(thr, 0.02)) + 1.0)
        t = np.linspace(0.0, t_end, 4001)
        outside = np.nonzero(err(t) > 0.0)[0]
        if outside.size == 0:
            return 0.0
        k = outside[-1]
        return float(brentq(err, t[k], t[k + 1], xtol=1e-9)) if k + 1 < t.size else float("inf")

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
        return OuterLoopController(self, dt, n_joints=n_joints, J=J, method=method)


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
        """One camera sample: q_fb[k] = K(z)[P e][k].

        Args:
            e_image: Image error e = feature_target - features (m,) [m on the sensor].
            J: Current image Jacobian (m, n); ``None`` uses the fixed one.

        Returns:
            q_fb [rad], shape (n,), the feedback joint reference added to q_ff.
        """
        if J is not None:
            J = as_array(J, "J", (None, self._n))
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
