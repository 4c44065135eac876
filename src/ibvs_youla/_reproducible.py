"""Products and norms in one fixed order of operations, the same bits on every CPU (internal).

Seeded campaign cases are stored by a key computed from their numbers (``ExperimentSpec.key``),
so the numbers a seed gives must not depend on the machine. numpy's ``@`` and
``np.linalg.norm`` call the BLAS, whose kernel is chosen per CPU and rounds differently: on
x86-64, OpenBLAS's Haswell and SkylakeX ``dgemm`` accumulate each entry as a chain of fused
multiply-adds (FMA), its Prescott kernel (no FMA) rounds every product, and its Haswell ``ddot``
of three entries rounds every product and adds left to right while SkylakeX's fuses them.
Keys stored before this module existed were computed on the Haswell kernel (the one CI ran), so
the fixed order here is that kernel's:

* :func:`matmul`: ``C_ij = fma(a_i,k-1 b_k-1,j, ... fma(a_i1 b_1j, round(a_i0 b_0j)))``, the FMA
  correctly rounded (``math.fma`` from Python 3.13; before it, Dekker's exact product and
  ``math.fsum``, correctly rounded by its specification);
* :func:`norm3`: ``sqrt((x^2 + y^2) + z^2)``, each operation rounded.

Both are pinned against the Haswell kernel and independent of ``OPENBLAS_CORETYPE``
(tests/test_reproducible.py). They are slow next to the BLAS (tens of microseconds for a 4x4
product) and meant for case generation, never for the simulation's hot path.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["fma", "matmul", "norm3"]

_SPLIT = 134217729.0  # 2^27 + 1: Veltkamp's splitting constant for binary64


def _exact_product(a: float, b: float) -> tuple[float, float]:
    """(p, e) with p = round(a b) and p + e = a b exactly (Dekker; no overflow or underflow)."""
    p = a * b
    t = _SPLIT * a
    a_hi = t - (t - a)
    a_lo = a - a_hi
    t = _SPLIT * b
    b_hi = t - (t - b)
    b_lo = b - b_hi
    e = ((a_hi * b_hi - p) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo
    return p, e


def _fma_emulated(a: float, b: float, c: float) -> float:
    """round(a b + c), rounded once: the exact product's two parts and c summed by ``math.fsum``."""
    p, e = _exact_product(a, b)
    if not (math.isfinite(p) and math.isfinite(e)):  # overflow: the plain expression says so
        return a * b + c
    return math.fsum((p, e, c))


fma = getattr(math, "fma", _fma_emulated)  # (a, b, c) -> round(a b + c)


def matmul(A: Any, B: Any) -> np.ndarray:
    """A @ B of 2-D float arrays, each entry an FMA chain over k in increasing order (module docstring)."""
    rows = np.asarray(A, dtype=float).tolist()
    cols = np.asarray(B, dtype=float).T.tolist()
    out = [[_dot_fma(row, col) for col in cols] for row in rows]
    return np.array(out, dtype=float).reshape(len(rows), len(cols))


def _dot_fma(row: list[float], col: list[float]) -> float:
    acc = row[0] * col[0]
    for x, y in zip(row[1:], col[1:], strict=True):
        acc = fma(x, y, acc)
    return acc


def norm3(v: Any) -> float:
    """|v| of a 3-vector as sqrt((x^2 + y^2) + z^2), each operation rounded (module docstring)."""
    x, y, z = (float(c) for c in np.asarray(v, dtype=float).reshape(3))
    return math.sqrt(x * x + y * y + z * z)
