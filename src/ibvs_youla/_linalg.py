"""Small dense linear algebra on the hot path (internal, unvalidated).

``numpy.linalg.svd`` and ``scipy.linalg.svd`` both call LAPACK's divide-and-conquer
``dgesdd``; for the 3x3 and 9x6 matrices of every camera frame their Python wrappers
cost more than the factorization (about 5 us of 8 us for 9x6, 3 us of 5 us for 3x3).
:func:`svd` calls the routine directly through ``scipy.linalg.lapack``.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

_gesdd = lapack.dgesdd


def svd(A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Economy SVD ``A = U diag(s) Vt`` of a finite float64 matrix (m, n): (U (m, k), s (k,), Vt (k, n)).

    Same factorization as ``np.linalg.svd(A, full_matrices=False)`` (LAPACK ``dgesdd``), singular
    values descending. If LAPACK reports a failure, numpy's wrapper is called instead so that its
    ``LinAlgError`` is raised.
    """
    U, s, Vt, info = _gesdd(A, 1, 0)  # compute_uv, full_matrices (positional: cheaper to parse)
    if info != 0:
        return np.linalg.svd(A, full_matrices=False)
    return U, s, Vt


def det3_sign(A: list[list[float]], B: list[list[float]]) -> float:
    """Sign (+1.0 or -1.0) of det(A) det(B) for two 3x3 matrices given as nested lists.

    For orthogonal A and B this is ``np.sign(np.linalg.det(A^T B^T))`` (each determinant is +-1).
    """
    return 1.0 if _det3(A) * _det3(B) >= 0.0 else -1.0


def _det3(M: list[list[float]]) -> float:
    (a, b, c), (d, e, f), (g, h, i) = M
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
