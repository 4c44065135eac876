"""Small dense linear algebra on the hot path (internal, unvalidated).

``numpy.linalg.svd`` and ``scipy.linalg.svd`` both call LAPACK's divide-and-conquer
``dgesdd``; for the 3x3 and 9x6 matrices of every camera frame their Python wrappers
cost more than the factorization (about 5 us of 8 us for 9x6, 3 us of 5 us for 3x3).
:func:`svd` calls the routine directly through ``scipy.linalg.lapack``, and :func:`gesdd`,
for compiled kernels (:mod:`ibvs_youla._jit`), through SciPy's Cython LAPACK table
(``scipy.linalg.cython_lapack``, the same library): one call with the workspace allocated
in compiled code, no workspace query. Both give the same factorization, bit for bit
(``tests/test_compiled_kernels.py``).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

from ._jit import jit, jit_available

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


def _register_dgesdd() -> object:
    """LAPACK ``dgesdd`` of SciPy's Cython table as a Numba external function of 14 addresses.

    The routine's address is registered with LLVM under :data:`_SYMBOL` (every process, at
    import), and compiled code calls it by that name, so Numba can cache the code that calls it.
    Pointer arguments are passed as integers (``array.ctypes.data``), which the C ABI passes alike.
    """
    from llvmlite import binding
    from numba import types
    from numba.extending import get_cython_function_address

    binding.add_symbol(_SYMBOL, get_cython_function_address("scipy.linalg.cython_lapack", "dgesdd"))
    return types.ExternalFunction(_SYMBOL, types.void(*([types.intp] * 14)))


_SYMBOL = "ibvs_youla_scipy_cython_lapack_dgesdd"
_S = 83  # ord("S"): jobz, the economy factorization (dgesdd(A, compute_uv=1, full_matrices=0))


def gesdd(A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """(U (m, k), s (k,), Vt (k, n), info): LAPACK ``dgesdd`` of A (m, n), jobz = "S", as :func:`svd`.

    For compiled kernels (callable from Python too). ``info`` is LAPACK's (0 on success), or
    -1000 when A has a non-finite entry (not passed to LAPACK); then the caller should call
    :func:`svd`, which raises numpy's ``LinAlgError``.
    """
    m, n = A.shape
    k = min(m, n)
    out_s = np.empty(k)
    out_u = np.empty((k, m))  # column-major (m, k): U = out_u.T
    out_vt = np.empty((n, k))  # column-major (k, n): Vt = out_vt.T
    a = np.empty((n, m))  # A in column-major order, overwritten by LAPACK
    for i in range(m):
        for j in range(n):
            x = A[i, j]
            if not np.isfinite(x):
                return out_u.T, out_s, out_vt.T, -1000  # not for LAPACK: the caller raises
            a[j, i] = x
    lwork = 4 * k * k + max(m, n) + 9 * k  # the workspace scipy.linalg.lapack.dgesdd gives it by default
    work = np.empty(lwork)
    iwork = np.empty(8 * k, dtype=np.int32)
    ints = np.empty(7, dtype=np.int32)  # m, n, lda, ldu, ldvt, lwork, info
    ints[0], ints[1], ints[2], ints[3], ints[4], ints[5], ints[6] = m, n, m, m, k, lwork, 0
    jobz = np.empty(1, dtype=np.uint8)
    jobz[0] = _S
    at, size = ints.ctypes.data, ints.itemsize  # addresses of the integer arguments
    _DGESDD(
        jobz.ctypes.data,
        at,
        at + size,
        a.ctypes.data,
        at + 2 * size,
        out_s.ctypes.data,
        out_u.ctypes.data,
        at + 3 * size,
        out_vt.ctypes.data,
        at + 4 * size,
        work.ctypes.data,
        at + 5 * size,
        iwork.ctypes.data,
        at + 6 * size,
    )
    return out_u.T, out_s, out_vt.T, int(ints[6])


if jit_available():
    _DGESDD = _register_dgesdd()
    gesdd = jit(gesdd)
else:  # Numba missing or disabled: the f2py wrapper, the same LAPACK routine

    def gesdd(A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """(U, s, Vt, info) of LAPACK ``dgesdd`` of A (the compiled version's fallback)."""
        return _gesdd(A, 1, 0)  # type: ignore[no-any-return]


@jit
def add_product(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> None:
    """In place, a += b * c element by element (compiled): the floats of numpy's ``a + b * c``."""
    for i in range(a.shape[0]):
        a[i] += b[i] * c[i]
