"""The outer Youla controller built literally from Eq. (53)-(61), as a reference.

:class:`~ibvs_youla.control.outer.OuterLoopDesign` runs the collapsed form
G_C = J^+ K(s) (ERRATA 9). This module rebuilds the paper's chain step by step, to
check that collapse and to time what "reconstructing the controller every time step"
(Section 6.3, after Eq. (62)) would cost:

* :func:`literal_matrices` evaluates every matrix at each frequency as complex
  arrays, with S_y inverted numerically;
* :func:`literal_mimo` builds python-control MIMO systems. MIMO transfer-matrix
  products in python-control multiply denominators without cancelling (a 6x9 Y
  gets degree-18 denominators whose coefficients reach 1e24), and MIMO inversion is
  not implemented for transfer functions, so the chain is carried in state space:
  static matrices as feedthrough-only systems, series products by ``*``, and
  S_y^-1 = (I - T_y)^-1 as the positive-feedback interconnection
  ``feedback(I, T_y, sign=+1)``, which is exact (S_y has the invertible
  feedthrough I_9 because T_y is strictly proper). The 54-state result is reduced
  by slycot's minimal realization and converted to 6x9 transfer functions by
  slycot (``tb04ad``).

SV policy in the literal chain: the gain of Eq. (55) is replaced by the design value
1/g(sigma_i) of the policy, and channels with g = 0 are left uncontrolled (M_T = 0
there, like the last three image coordinates in Eq. (56)). With that design model
Eq. (59)-(61) collapse exactly to V diag(g) U^T K(s), the closed form. (Using the true
sigma_i in Eq. (59) with damped gains would instead give S_y entries 1 - rho_i m_T,
rho_i = sigma_i g_i < 1, whose inverse has no pole at s = 0: G_C would lose its
integrator in every damped direction.)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import control as ct
import numpy as np
from scipy.linalg import block_diag

from .._validation import as_array, frequencies
from .outer import OuterLoopDesign  # one way: outer does not import this module

__all__ = ["LiteralMimo", "LiteralResponse", "literal_matrices", "literal_mimo", "literal_response"]


class LiteralResponse(NamedTuple):
    """Frequency responses of Eq. (58)-(61), each complex with a leading axis n_w.

    Attributes:
        Y: (n_w, n, m) Youla parameter, Eq. (58).
        T_y: (n_w, m, m) complementary sensitivity, Eq. (59).
        S_y: (n_w, m, m) sensitivity I_m - T_y, Eq. (60).
        G_C: (n_w, n, m) controller Y S_y^-1, Eq. (61).
    """

    Y: np.ndarray
    T_y: np.ndarray
    S_y: np.ndarray
    G_C: np.ndarray


@dataclass(frozen=True)
class LiteralMimo:
    """Eq. (53)-(61) as python-control systems, for one Jacobian J (m, n).

    Attributes:
        plant: G_p = U M_p V^T (Eq. (53)-(55)), StateSpace m x n.
        youla_ss: Y = V M_Y U^T (Eq. (58)), StateSpace n x m.
        youla: Y as an n x m TransferFunction.
        complementary_sensitivity: T_y = G_p Y (Eq. (59)), StateSpace m x m.
        sensitivity: S_y = I_m - T_y (Eq. (60)), StateSpace m x m.
        controller_ss: G_C = Y S_y^-1 (Eq. (61)), minimal StateSpace n x m.
        controller: G_C as an n x m TransferFunction.
    """

    plant: ct.StateSpace
    youla_ss: ct.StateSpace
    youla: ct.TransferFunction
    complementary_sensitivity: ct.StateSpace
    sensitivity: ct.StateSpace
    controller_ss: ct.StateSpace
    controller: ct.TransferFunction


def _design_svd(design: OuterLoopDesign, J: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Full SVD of J, design singular values (1/g on controlled channels) and the mask."""
    J = as_array(J, "J", (None, None))
    U, s, Vt = np.linalg.svd(J, full_matrices=True)
    g = design.sv_policy.gains(s, max(J.shape))
    controlled = g > 0.0
    s_design = np.divide(1.0, g, out=s.copy(), where=controlled)
    return U, s_design, Vt, controlled


def literal_matrices(
    design: OuterLoopDesign, J: Any, omegas: Any, *, printed_order: bool = False
) -> LiteralResponse:
    """Evaluate Eq. (53)-(61) literally at each frequency.

    Args:
        design: Outer-loop design (omega_n, zeta, tau_in, SV policy).
        J: Image Jacobian (m, n).
        omegas: Frequencies [rad/s], all > 0.
        printed_order: Build Eq. (58) as printed, U_R M_Y U_L = V^T M_Y U, instead of
            the derived V M_Y U^T (to show that the printed order is wrong).
    """
    w = frequencies(omegas, "omegas", "G_C has a pole at 0")
    U, s_d, Vt, ctrl = _design_svd(design, J)
    m, n = U.shape[0], Vt.shape[0]
    k = s_d.size
    t_in = design.inner_tf()(1j * w)
    m_t = design.target_tf()(1j * w)
    idx = np.arange(k)
    M_p = np.zeros((w.size, m, n), complex)  # Eq. (55)
    M_p[:, idx, idx] = s_d[None, :] * t_in[:, None]
    G_p = U @ M_p @ Vt  # Eq. (54)
    M_T = np.zeros((w.size, m, m), complex)  # Eq. (56)
    M_T[:, idx, idx] = np.where(ctrl[None, :], m_t[:, None], 0.0)
    M_Y = np.zeros((w.size, n, m), complex)  # Eq. (57)
    M_Y[:, idx, idx] = np.where(ctrl[None, :], M_T[:, idx, idx] / M_p[:, idx, idx], 0.0)
    Y = Vt @ M_Y @ U if printed_order else Vt.T @ M_Y @ U.T  # Eq. (58)
    T_y = G_p @ Y  # Eq. (59)
    S_y = np.eye(m)[None] - T_y  # Eq. (60)
    G_C = np.swapaxes(np.linalg.solve(np.swapaxes(S_y, 1, 2), np.swapaxes(Y, 1, 2)), 1, 2)  # Eq. (61)
    return LiteralResponse(Y, T_y, S_y, G_C)


def literal_response(design: OuterLoopDesign, J: Any, omegas: Any) -> np.ndarray:
    """G_C(j omega) of Eq. (61), shape (n_w, n, m); see :func:`literal_matrices`."""
    return literal_matrices(design, J, omegas).G_C


def _static(M: np.ndarray) -> ct.StateSpace:
    return ct.ss(np.zeros((0, 0)), np.zeros((0, M.shape[1])), np.zeros((M.shape[0], 0)), M)


def _diagonal(blocks: list[ct.StateSpace | None], n_out: int, n_in: int) -> ct.StateSpace:
    """Block-diagonal StateSpace n_out x n_in with SISO blocks on (i, i) (None = 0)."""
    used = [(i, b) for i, b in enumerate(blocks) if b is not None]
    A = block_diag(*[b.A for _, b in used]) if used else np.zeros((0, 0))
    B = np.zeros((A.shape[0], n_in))
    C = np.zeros((n_out, A.shape[0]))
    D = np.zeros((n_out, n_in))
    r = 0
    for i, b in used:
        ns = b.nstates
        B[r : r + ns, i] = b.B[:, 0]
        C[i, r : r + ns] = b.C[0]
        D[i, i] = b.D[0, 0]
        r += ns
    return ct.ss(A, B, C, D)


def literal_mimo(design: OuterLoopDesign, J: Any) -> LiteralMimo:
    """Build Eq. (53)-(61) as python-control MIMO systems for the Jacobian J (m, n).

    Every call redoes the SVD, the SISO divisions of Eq. (57), the MIMO products,
    the inversion of S_y, a minimal realization and the transfer-matrix conversion:
    the per-step cost of the adaptive controller as the paper describes it.
    """
    U, s_d, Vt, ctrl = _design_svd(design, J)
    m, n = U.shape[0], Vt.shape[0]
    T_in, m_T = design.inner_tf(), design.target_tf()
    M_p = _diagonal([ct.ss(float(si) * T_in) for si in s_d], m, n)  # Eq. (55)
    G_p = _static(U) * M_p * _static(Vt)  # Eq. (53)-(54)
    # Eq. (57): M_Y(i, i) = M_T(i, i) / M_p(i, i), a SISO division per controlled channel
    blocks = [
        ct.ss(ct.minreal(m_T / (float(si) * T_in), verbose=False)) if c else None
        for si, c in zip(s_d, ctrl, strict=True)
    ]
    M_Y = _diagonal(blocks, n, m)
    Y = _static(Vt.T) * M_Y * _static(U.T)  # Eq. (58)
    T_y = G_p * Y  # Eq. (59)
    I_m = _static(np.eye(m))
    S_y = I_m - T_y  # Eq. (60)
    S_y_inv = ct.feedback(I_m, T_y, sign=1)  # (I - T_y)^-1
    G_C = ct.minreal(Y * S_y_inv, verbose=False)  # Eq. (61)
    return LiteralMimo(G_p, Y, ct.tf(Y), T_y, S_y, G_C, ct.tf(G_C))
