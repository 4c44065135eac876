"""Compiled assembly of the MPC's QP: the Kronecker products of :meth:`MpcIBVS.qp` in one call.

The QP of :class:`~ibvs_youla.controllers.mpc_ibvs.MpcIBVS` over the horizon's N moves is made of
Kronecker products of constant N x N (or N) matrices with the frame's small blocks (module
docstring of ``mpc_ibvs``):

    P = q_weight kron(W, L^T L) + R,   q = (q_weight / T) kron(w, L^T e0),   G = kron(lower, A L).

Each entry is one product of two entries, then scaled and shifted, so :func:`qp_blocks` writes
the same floats as numpy's ``np.kron`` and the elementwise operations (pinned by
``tests/test_mpc_ibvs.py`` against those formulas, bit for bit), without building the
intermediate arrays. Unvalidated: float64 arrays of matching shapes.
"""

from __future__ import annotations

import numpy as np

from .._jit import jit

__all__ = ["qp_blocks"]


@jit
def qp_blocks(
    W: np.ndarray,
    w: np.ndarray,
    lower: np.ndarray,
    LtL: np.ndarray,
    Lte: np.ndarray,
    AL: np.ndarray,
    q_weight: float,
    q_scale: float,
    R: np.ndarray,
    P: np.ndarray,
    q: np.ndarray,
    G: np.ndarray,
) -> None:
    """P = (kron(W, LtL) * q_weight) + R, q = kron(w, Lte) * q_scale, G = kron(lower, AL), written."""
    N, n, r = W.shape[0], LtL.shape[0], AL.shape[0]
    for i in range(N):
        for a in range(n):
            row = i * n + a
            for k in range(N):
                for b in range(n):
                    col = k * n + b
                    P[row, col] = (W[i, k] * LtL[a, b]) * q_weight + R[row, col]
            q[row] = (w[i] * Lte[a]) * q_scale
        for a in range(r):
            for k in range(N):
                for b in range(n):
                    G[i * r + a, k * n + b] = lower[i, k] * AL[a, b]
