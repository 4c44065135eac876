"""Small singular values of the image Jacobian: bounded inverse gains for Eq. (57) (ERRATA 7).

:class:`SingularValuePolicy` replaces 1/sigma_i in M_Y(i, i) = m_T / (sigma_i T_in) by a
bounded gain g(sigma_i); :class:`SvdGains` carries the SVD J = U Sigma V^T with those gains
and the regularized pseudo-inverse V diag(g) U^T used by
:class:`~ibvs_youla.control.outer.OuterLoopController`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from .._linalg import svd
from .._validation import as_array, non_negative, one_of
from ..exceptions import InvalidParameterError, SingularConfigurationError

__all__ = ["SingularValuePolicy", "SvdGains"]

_EPS = float(np.finfo(float).eps)


class SvdGains(NamedTuple):
    """SVD of a Jacobian J (m, n) and the inverse gains chosen by a policy.

    Attributes:
        U: (m, k) left singular vectors, k = min(m, n).
        sigma: (k,) singular values, descending [image m / rad].
        gains: (k,) inverse gains g(sigma_i) replacing 1/sigma_i [rad / image m].
        Vt: (k, n) right singular vectors (rows).
        pinv: (n, m) regularized pseudo-inverse V diag(g) U^T.
    """

    U: np.ndarray
    sigma: np.ndarray
    gains: np.ndarray
    Vt: np.ndarray
    pinv: np.ndarray


@dataclass(frozen=True)
class SingularValuePolicy:
    """Bounded replacement of the inverse gain 1/sigma_i of Eq. (57) (ERRATA 7).

    ``threshold`` is dimensionless, relative to the largest singular value sigma_max of
    the Jacobian at hand, so the policy does not depend on image units:

    * ``"damped"`` (default): g = sigma/(sigma^2 + lambda^2), lambda = threshold *
      sigma_max (damped least squares). Smooth in sigma, bounded by 1/(2 lambda), and
      1/sigma to a relative (lambda/sigma)^2. With q_fb = P K(s) e the channel keeps
      its integrator: it closes as rho omega^2/(s^2 + 2 zeta omega s + rho omega^2),
      rho = sigma g = sigma^2/(sigma^2 + lambda^2), slower but without offset.
    * ``"truncate"``: g = 1/sigma if sigma > threshold * sigma_max, else 0 (the
      direction is left uncontrolled, as the last three image coordinates in Eq. (56)).

    In both, singular values below the numerical rank tolerance max(m, n) * eps *
    sigma_max count as exactly zero and get g = 0. Default: damped, threshold 1e-3.
    At scenario 1's wrist singularity (sigma_6 = 0) the gain stays finite, and
    channels with sigma_i > 0.04 sigma_max are slowed by less than 0.1 %.

    Attributes:
        kind: ``"damped"`` or ``"truncate"``.
        threshold: lambda / sigma_max (damped) or the cut-off sigma / sigma_max
            (truncate); in [0, 1).
    """

    kind: str = "damped"
    threshold: float = 1e-3

    def __post_init__(self) -> None:
        one_of(self.kind, "kind", ("damped", "truncate"))
        thr = non_negative(self.threshold, "threshold")
        if thr >= 1.0:
            raise InvalidParameterError("threshold", self.threshold, "a number in [0, 1) (times sigma_max)")
        object.__setattr__(self, "threshold", thr)

    def gains(self, sigma: Any, size: int | None = None) -> np.ndarray:
        """Inverse gains g(sigma_i) for singular values sorted in descending order.

        Args:
            sigma: Singular values (k,), descending.
            size: max(m, n) of the Jacobian, for the rank tolerance (default k).
        """
        s = as_array(sigma, "sigma", (None,))
        smax = float(s[0]) if s.size else 0.0
        if smax <= 0.0:
            raise SingularConfigurationError(s, "the Jacobian is zero: no direction can be controlled")
        zero = s <= (size or s.size) * np.finfo(float).eps * smax
        g = np.zeros_like(s)
        keep = ~zero
        if self.kind == "damped":
            lam = self.threshold * smax
            g[keep] = s[keep] / (s[keep] ** 2 + lam**2)
        else:
            keep &= s > self.threshold * smax
            g[keep] = 1.0 / s[keep]
        return g

    def decompose(self, J: Any) -> SvdGains:
        """Economy SVD of J (m, n) and the regularized pseudo-inverse."""
        return self._decompose(as_array(J, "J", (None, None)))

    def _decompose(self, J: np.ndarray) -> SvdGains:
        """`decompose` of a finite float (m, n) array, unchecked."""
        U, s, gains, Vt = self._svd_gains(J)
        return SvdGains(U, s, gains, Vt, (Vt.T * gains).dot(U.T))

    def _svd_gains(self, J: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(U, sigma, gains, Vt) of a finite float (m, n) array, unchecked (every adaptive frame).

        LAPACK ``dgesdd`` called directly (:func:`ibvs_youla._linalg.svd`) and the gains of
        :meth:`gains` in scalar arithmetic (same operations, same floats).
        """
        U, s, Vt = svd(J)
        sigma = s.tolist()
        smax = sigma[0] if sigma else 0.0
        if smax <= 0.0:
            self.gains(s)  # raises SingularConfigurationError
        zero = max(J.shape) * _EPS * smax  # numerical rank tolerance
        if self.kind == "damped":
            lam2 = (self.threshold * smax) ** 2
            g = [x / (x * x + lam2) if x > zero else 0.0 for x in sigma]
        else:
            cut = self.threshold * smax
            g = [1.0 / x if x > zero and x > cut else 0.0 for x in sigma]
        return U, s, np.array(g), Vt

    def pseudo_inverse(self, J: Any) -> np.ndarray:
        """Regularized pseudo-inverse V diag(g(sigma)) U^T of J, shape (n, m)."""
        return self.decompose(J).pinv
