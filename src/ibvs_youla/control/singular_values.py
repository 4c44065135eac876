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
from .._validation import as_array, integer, one_of, real
from ..exceptions import InvalidArrayError, SingularConfigurationError
from .svd_kernels import svd_gains

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

    @classmethod
    def from_svd(cls, U: np.ndarray, sigma: np.ndarray, gains: np.ndarray, Vt: np.ndarray) -> SvdGains:
        """The SVD and gains with their pseudo-inverse V diag(g) U^T formed."""
        return cls(U, sigma, gains, Vt, (Vt.T * gains).dot(U.T))


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
        object.__setattr__(self, "kind", one_of(self.kind, "kind", ("damped", "truncate")))
        thr = real(self.threshold, "threshold", low=0.0, high=1.0, high_open=True, unit="(times sigma_max)")
        object.__setattr__(self, "threshold", thr)

    def gains(self, sigma: Any, size: int | None = None) -> np.ndarray:
        """Inverse gains g(sigma_i) for singular values sorted in descending order.

        Args:
            sigma: Singular values (k,), descending.
            size: max(m, n) of the Jacobian, for the rank tolerance (default k).

        Raises:
            SingularConfigurationError: every singular value is zero (or there is none).
        """
        s = as_array(sigma, "sigma", (None,))
        return np.array(self._gains(s.tolist(), s.size if size is None else integer(size, "size", low=1)))

    def _gains(self, sigma: list[float], size: int) -> list[float]:
        """g(sigma_i) of descending singular values, in scalar arithmetic (class docstring)."""
        smax = sigma[0] if sigma else 0.0
        if smax <= 0.0:
            raise SingularConfigurationError(
                np.array(sigma), "the Jacobian is zero: no direction can be controlled"
            )
        zero = size * _EPS * smax  # numerical rank tolerance
        if self.kind == "damped":
            lam2 = (self.threshold * smax) ** 2
            return [x / (x * x + lam2) if x > zero else 0.0 for x in sigma]
        cut = self.threshold * smax
        return [1.0 / x if x > zero and x > cut else 0.0 for x in sigma]

    def decompose(self, J: Any) -> SvdGains:
        """Economy SVD of J (m, n), the gains and the regularized pseudo-inverse V diag(g) U^T."""
        J = as_array(J, "J", (None, None))
        if J.size == 0:
            raise InvalidArrayError("J", f"an array of shape {J.shape}", "a Jacobian with rows and columns")
        return SvdGains.from_svd(*self.svd_gains(J))

    def svd_gains(self, J: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(U, sigma, gains, Vt) of J (m, n): `decompose` without the pseudo-inverse.

        Kernel of `decompose`, called by the controllers at every frame: does not validate
        ``J``, which must be a finite float64 (m, n) array. One compiled call
        (:func:`~ibvs_youla.control.svd_kernels.svd_gains`: LAPACK ``dgesdd`` and the gains, the
        same floats as the plain code below, which runs when that call cannot give them).
        """
        U, s, g, Vt, ok = svd_gains(J, self.kind == "damped", self.threshold)
        if ok:
            return U, s, g, Vt
        U, s, Vt = svd(J)  # LAPACK failed or a non-finite entry: numpy's LinAlgError, or no direction
        return U, s, np.array(self._gains(s.tolist(), max(J.shape))), Vt

    def pseudo_inverse(self, J: Any) -> np.ndarray:
        """Regularized pseudo-inverse V diag(g(sigma)) U^T of J, shape (n, m)."""
        return self.decompose(J).pinv
