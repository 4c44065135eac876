"""Compiled SVD gains and pseudo-inverse products: the outer loop's P e, the arm's J_C^+ [v; w].

Numba-compiled twins (:func:`ibvs_youla._jit.jit`) of two hot paths through
:class:`~ibvs_youla.control.singular_values.SingularValuePolicy`, each a factorization J = U Sigma
V^T (LAPACK ``dgesdd``, :func:`ibvs_youla._linalg.gesdd`, the reference's call bit for bit) and
the bounded inverse gains g(sigma_i) of ERRATA 7 (``SingularValuePolicy._gains``):

* :func:`svd_gains`: the factorization and the gains alone (``SingularValuePolicy.svd_gains``,
  the same floats);
* :func:`svd_gains_apply`: P e = V (g * (U^T e)), the input of the outer loop's filter
  (Eq. (57)-(61), ``OuterLoopController.advance``), at every frame of the paper's controller;
* :func:`pseudo_inverse_apply`: (V diag(g) U^T) x, the pseudo-inverse formed then applied
  (``policy.pseudo_inverse(J_C) @ twist``), at every joint tick of a twist controller on an arm
  (``TwistToJointVelocity``);
* :func:`pseudo_inverse_integrate`: the same, and the joint reference it integrates to,
  q_next = q_prev + dt y (numpy's floats of ``q_prev + dt * y``), in the same call
  (``TwistToJointVelocity`` followed by ``VelocityToPosition``).

The gains are those of ``SingularValuePolicy`` with ``damped`` True (damped least squares,
lambda = threshold sigma_max) or False (truncation below threshold sigma_max); singular values
under the numerical rank tolerance max(m, n) eps sigma_max get 0. It returns ``ok = False`` when
the reference would not give a plain result (LAPACK failed, a non-finite entry, every singular
value zero); the caller then runs the reference, which raises or returns what it returns. The
products are summed in loops, not by BLAS as in the reference: equal to a few ulps (the tests
state the bound), which the paper controller's regression guard (1e-8) allows. Unvalidated;
pinned to the references by ``tests/test_compiled_kernels.py``.
"""

from __future__ import annotations

import numpy as np

from .._jit import jit
from .._linalg import gesdd

__all__ = ["pseudo_inverse_apply", "pseudo_inverse_integrate", "svd_gains", "svd_gains_apply"]

_EPS = float(np.finfo(float).eps)


@jit
def _gains(s: np.ndarray, size: int, damped: bool, threshold: float) -> tuple[np.ndarray, bool]:
    """(g(sigma_i), ok) for descending singular values s (``SingularValuePolicy._gains``)."""
    g = np.zeros(s.shape[0])
    smax = s[0] if s.shape[0] else 0.0
    if smax <= 0.0:
        return g, False
    zero = size * _EPS * smax  # numerical rank tolerance
    if damped:
        lam2 = (threshold * smax) ** 2
        for i in range(s.shape[0]):
            x = s[i]
            g[i] = x / (x * x + lam2) if x > zero else 0.0
    else:
        cut = threshold * smax
        for i in range(s.shape[0]):
            x = s[i]
            g[i] = 1.0 / x if x > zero and x > cut else 0.0
    return g, True


@jit
def svd_gains(
    J: np.ndarray, damped: bool, threshold: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
    """(U (m, k), sigma (k,), g (k,), Vt (k, n), ok) of J (m, n): the SVD and the bounded gains."""
    U, s, Vt, info = gesdd(J)
    g, ok = _gains(s, max(J.shape[0], J.shape[1]), damped, threshold)
    return U, s, g, Vt, ok and info == 0


@jit
def svd_gains_apply(J: np.ndarray, e: np.ndarray, damped: bool, threshold: float, Pe: np.ndarray) -> bool:
    """P e (n,) written into ``Pe`` for J (m, n) and e (m,); returns ok (the factors stay inside)."""
    U, s, Vt, info = gesdd(J)
    m, k, n = J.shape[0], s.shape[0], J.shape[1]
    g, ok = _gains(s, max(m, n), damped, threshold)
    ok = ok and info == 0
    w = np.zeros(k)
    for i in range(k):  # g * (U^T e)
        acc = 0.0
        for r in range(m):
            acc += U[r, i] * e[r]
        w[i] = g[i] * acc
    for j in range(n):  # V w
        acc = 0.0
        for i in range(k):
            acc += Vt[i, j] * w[i]
        Pe[j] = acc
    return ok


@jit
def pseudo_inverse_apply(J: np.ndarray, x: np.ndarray, damped: bool, threshold: float, y: np.ndarray) -> bool:
    """(V diag(g) U^T) x (n,) written into ``y`` for J (m, n) and x (m,); returns ok."""
    U, s, Vt, info = gesdd(J)
    m, k, n = J.shape[0], s.shape[0], J.shape[1]
    g, ok = _gains(s, max(m, n), damped, threshold)
    ok = ok and info == 0
    for j in range(n):
        acc = 0.0
        for r in range(m):
            p = 0.0
            for i in range(k):  # P[j, r] = sum_i V[j, i] g_i U[r, i]
                p += Vt[i, j] * g[i] * U[r, i]
            acc += p * x[r]
        y[j] = acc
    return ok


@jit
def pseudo_inverse_integrate(
    J: np.ndarray,
    x: np.ndarray,
    damped: bool,
    threshold: float,
    q_prev: np.ndarray,
    dt: float,
    y: np.ndarray,
    q_next: np.ndarray,
) -> bool:
    """:func:`pseudo_inverse_apply` into ``y`` (n,), then q_next = q_prev + dt y (n,); returns ok.

    When not ok, ``q_next`` is not written (the caller runs the reference).
    """
    ok = pseudo_inverse_apply(J, x, damped, threshold, y)
    if ok:
        for j in range(y.shape[0]):
            q_next[j] = q_prev[j] + dt * y[j]
    return ok
