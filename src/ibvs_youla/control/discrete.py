"""A SISO discrete-time state-space filter applied independently to m channels.

Every runtime controller of the library (inner loop, feedforward, outer loop) is a
diagonal MIMO system ``G(s) * I_m`` (Eq. (36), (45), (47), and ERRATA 9 for the outer
loop), so one SISO realization ``(A, B, C, D)`` with an ``(n, m)`` state array serves
all m channels. The filter runs inside the simulation loop (about 10^4 calls per
simulated second across all filters), so :meth:`DiscreteFilter.step` is one product
of the stacked matrix [[A, B], [C, D]] with [x; u] into a preallocated buffer (one compiled
call, :func:`filter_step`), behind a shape check that costs
about 0.1 us; nothing here rebuilds a transfer function.

Discretization (:meth:`DiscreteFilter.from_tf`) uses ``scipy.signal.cont2discrete``:

* ``"zoh"`` is exact when the input is piecewise constant between samples (a step of
  q_des into the feedforward, a held reference into a continuous loop);
* ``"foh"`` is exact when the input is piecewise linear between samples (a smooth
  trajectory sampled at the joint rate);
* ``"tustin"`` (bilinear) maps the left half-plane onto the unit disc, so a stable
  controller stays stable, s = 0 maps to z = 1 (integrators stay exact integrators)
  and the frequency response is matched closely well below Nyquist; it is the usual
  choice for emulating a continuous controller.
"""

from __future__ import annotations

from typing import Any

import control as ct
import numpy as np
from scipy.signal import cont2discrete

from .._jit import jit
from .._validation import as_array, integer, one_of, positive
from ..exceptions import InvalidArrayError, InvalidParameterError

__all__ = ["METHODS", "DiscreteFilter", "filter_step", "filter_step_difference"]

METHODS = ("zoh", "foh", "tustin")
_SCIPY_METHOD = {"zoh": "zoh", "foh": "foh", "tustin": "bilinear"}


@jit
def filter_step(M: np.ndarray, z: np.ndarray, z_next: np.ndarray, u: np.ndarray, y: np.ndarray) -> None:
    """z[-1] = u, z_next = M z, y = z_next[-1], the output (compiled; y written, not returned).

    The kernel of :meth:`DiscreteFilter.step`: M = [[A, B], [C, D]] (n + 1, n + 1), z = [x; u]
    (n + 1, m) and z_next (n + 1, m), so z_next = [A x + B u; C x + D u]. Unvalidated; pinned to
    ``M.dot(z)`` by ``tests/test_compiled_kernels.py``.
    """
    rows, m = z.shape
    for j in range(m):
        z[rows - 1, j] = u[j]
    _product(M, z, z_next, y)


@jit
def filter_step_difference(
    M: np.ndarray, z: np.ndarray, z_next: np.ndarray, r: np.ndarray, y_in: np.ndarray, y: np.ndarray
) -> None:
    """:func:`filter_step` with the input u = r - y_in formed inside (the error of a feedback loop)."""
    rows, m = z.shape
    for j in range(m):
        z[rows - 1, j] = r[j] - y_in[j]
    _product(M, z, z_next, y)


@jit
def _product(M: np.ndarray, z: np.ndarray, z_next: np.ndarray, y: np.ndarray) -> None:
    """z_next = M z, and y = its last row."""
    rows, m = z.shape
    for a in range(rows):
        for j in range(m):
            acc = 0.0
            for b in range(rows):
                acc += M[a, b] * z[b, j]
            z_next[a, j] = acc
    for j in range(m):
        y[j] = z_next[rows - 1, j]


# (system, dt, method, prewarp) -> the discrete (A, B, C, D) of DiscreteFilter.from_tf: a run builds its
# filters from the same few transfer functions, and python-control's conversion to state space costs
# ~0.5 ms each (~2 ms of a paper controller's set-up); the matrices are the same floats either way
_DISCRETIZED: dict[tuple[Any, ...], tuple[np.ndarray, ...]] = {}
_DISCRETIZED_MAX = 256


def _system_key(sys: Any) -> tuple[Any, ...]:
    """What ``control.ss(sys)`` depends on: a SISO transfer function's coefficients, or (A, B, C, D)."""
    if isinstance(sys, ct.TransferFunction):
        parts = (sys.num[0][0], sys.den[0][0])
    else:
        parts = (sys.A, sys.B, sys.C, sys.D)
    return (type(sys).__name__, *((np.shape(p), np.asarray(p, dtype=float).tobytes()) for p in parts))


class DiscreteFilter:
    """x[k+1] = A x[k] + B u[k], y[k] = C x[k] + D u[k], channel by channel.

    The state is an ``(n, m)`` array: column j is the state of channel j. The same
    SISO matrices act on every channel.

    Args:
        A: (n, n) discrete state matrix.
        B: (n,) or (n, 1) input vector.
        C: (n,) or (1, n) output vector.
        D: Scalar feedthrough.
        dt: Sampling period [s].
        n_channels: Number of independent channels m.
    """

    def __init__(self, A: Any, B: Any, C: Any, D: Any, dt: float, n_channels: int) -> None:
        A = as_array(A, "A")
        if A.ndim == 0:
            A = A.reshape(1, 1)
        n = A.shape[0]
        if A.shape != (n, n):
            raise InvalidArrayError("A", f"an array of shape {A.shape}", "a square (n, n) array")
        B = as_array(B, "B").reshape(-1)
        C = as_array(C, "C").reshape(-1)
        if B.shape != (n,) or C.shape != (n,):
            raise InvalidArrayError(
                "B, C", f"shapes {B.shape} and {C.shape}", f"{n} entries each (SISO, n = {n} states)"
            )
        D_arr = as_array(D, "D").reshape(-1)
        if D_arr.shape != (1,):
            raise InvalidArrayError("D", f"an array of shape {D_arr.shape}", "a scalar (SISO filter)")
        m = integer(n_channels, "n_channels", low=1)
        self._dt = positive(dt, "dt", unit="s")
        self._A = A.copy()
        self._B = B.reshape(n, 1).copy()  # column, broadcasts against u (m,)
        self._C = C.copy()
        self._D = float(D_arr[0])
        # One step is one product [x[k+1]; y[k]] = [[A, B], [C, D]] [x[k]; u[k]] into the other
        # of two (n + 1, m) buffers; the state is the first n rows of the current one (`_x`).
        self._M = np.block([[self._A, self._B], [self._C[None, :], np.array([[self._D]])]])
        self._z, self._z_next = np.zeros((n + 1, m)), np.zeros((n + 1, m))
        self._shape = (m,)

    @classmethod
    def from_tf(
        cls,
        sys: Any,
        dt: float,
        n_channels: int,
        method: str = "tustin",
        prewarp_frequency: float | None = None,
    ) -> DiscreteFilter:
        """Discretize a continuous SISO transfer function (or state space).

        Args:
            sys: Continuous-time SISO ``control.TransferFunction`` or ``StateSpace``.
            dt: Sampling period [s].
            n_channels: Number of independent channels m.
            method: ``"zoh"``, ``"foh"`` or ``"tustin"`` (see the module docstring).
            prewarp_frequency: With ``"tustin"``, frequency [rad/s] matched exactly.

        Returns:
            The discrete filter, all states zero.
        """
        one_of(method, "method", METHODS)
        dt = positive(dt, "dt", unit="s")
        if not isinstance(sys, (ct.TransferFunction, ct.StateSpace)) or not sys.issiso():
            raise InvalidParameterError("sys", sys, "a SISO control.TransferFunction or StateSpace")
        if sys.isdtime(strict=True):
            raise InvalidParameterError("sys", sys, "a continuous-time system (dt = 0)")
        w = None  # the prewarp frequency, used (and checked) with Tustin only
        if method == "tustin" and prewarp_frequency is not None:
            w = positive(prewarp_frequency, "prewarp_frequency", unit="rad/s")
        key = (_system_key(sys), dt, method, w)
        matrices = _DISCRETIZED.get(key)
        if matrices is None:
            ss = ct.ss(sys)
            if w is not None:
                # Prewarped bilinear: s = (w / tan(w dt / 2)) (z - 1)/(z + 1), i.e. Tustin at a
                # scaled sampling period; cont2discrete's gbt has no prewarp option.
                dt_eff = 2.0 * np.tan(w * dt / 2.0) / w
                Ad, Bd, Cd, Dd, _ = cont2discrete((ss.A, ss.B, ss.C, ss.D), dt_eff, method="bilinear")
            else:
                Ad, Bd, Cd, Dd, _ = cont2discrete((ss.A, ss.B, ss.C, ss.D), dt, method=_SCIPY_METHOD[method])
            matrices = (Ad, Bd, Cd, Dd)
            for M in matrices:
                M.setflags(write=False)  # shared by the filters made from the cache (each copies them)
            if len(_DISCRETIZED) >= _DISCRETIZED_MAX:
                _DISCRETIZED.clear()
            _DISCRETIZED[key] = matrices
        return cls(*matrices, dt, n_channels)

    # ------------------------------------------------------------------ properties
    @property
    def _x(self) -> np.ndarray:
        """The (n, m) state: a view of the current buffer (not stored, so copies stay consistent)."""
        return self._z[:-1]

    @property
    def dt(self) -> float:
        """Sampling period [s]."""
        return self._dt

    @property
    def n_channels(self) -> int:
        """Number of independent channels m."""
        return self._shape[0]

    @property
    def n_states(self) -> int:
        """Order n of the SISO realization."""
        return self._A.shape[0]

    @property
    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """Copies of (A (n, n), B (n,), C (n,), D)."""
        return self._A.copy(), self._B[:, 0].copy(), self._C.copy(), self._D

    @property
    def stacked_matrix(self) -> np.ndarray:
        """M = [[A, B], [C, D]] (n + 1, n + 1), read-only: the matrix of :func:`filter_step`.

        For a compiled kernel that runs the filter's recursion on its own state (e.g. the inner
        loop's torque in one call, ``simulation.actuation``): the same matrix, so the same floats.
        """
        view = self._M.view()
        view.setflags(write=False)
        return view

    @property
    def state(self) -> np.ndarray:
        """Copy of the (n, m) state."""
        return self._x.copy()

    def output(self, u: Any) -> np.ndarray:
        """Output y[k] = C x[k] + D u for input u, without advancing the state."""
        return self._C.dot(self._x) + self._D * np.asarray(u, dtype=float)

    def dc_gain(self) -> float:
        """Steady-state gain C (I - A)^-1 B + D (inf if the filter has a pole at z = 1)."""
        if self._has_unit_pole():
            return float("inf")
        n = self.n_states
        return float(self._C @ np.linalg.solve(np.eye(n) - self._A, self._B[:, 0]) + self._D)

    # ------------------------------------------------------------------ hot path
    def step(self, u: Any) -> np.ndarray:
        """Advance one sample: return y[k] = C x[k] + D u[k], then x <- A x + B u.

        Args:
            u: Input sample u[k], shape (m,). Its shape is checked, not its finiteness: a
                non-finite input gives non-finite outputs (the plant's divergence test reports them).

        Returns:
            y[k], a new (m,) array.

        Raises:
            InvalidArrayError: ``u`` is not numeric or not of shape (m,).
        """
        if getattr(u, "shape", None) != self._shape:
            u = as_array(u, "u", finite=False)
            if u.shape != self._shape:
                raise InvalidArrayError("u", f"an array of shape {u.shape}", f"shape {self._shape}")
        z, z_next = self._z, self._z_next
        y = np.empty(self._shape[0])  # a new array (cheaper than one returned by compiled code)
        filter_step(self._M, z, z_next, u, y)  # z[-1] = u; z_next = [A x + B u; C x + D u]: compiled
        self._z, self._z_next = z_next, z
        return y

    def step_difference(self, r: np.ndarray, y: np.ndarray) -> np.ndarray:
        """:meth:`step` of u = r - y (n-channel arrays), without forming r - y first.

        The error of a feedback loop at every tick (the inner loop, Eq. (41)). ``y`` must be a
        float (m,) array (e.g. the encoders); an ``r`` of another shape goes through :meth:`step`,
        which checks it.
        """
        if getattr(r, "shape", None) != self._shape:
            return self.step(np.asarray(r) - y)
        z, z_next = self._z, self._z_next
        out = np.empty(self._shape[0])
        filter_step_difference(self._M, z, z_next, r, y, out)
        self._z, self._z_next = z_next, z
        return out

    # ------------------------------------------------------------------ resets
    def reset(self, state: Any = None) -> None:
        """Set the (n, m) state (zeros by default)."""
        if state is None:
            self._x.fill(0.0)
            return
        self._x[...] = as_array(state, "state", self._x.shape)

    def reset_steady_state(self, u0: Any) -> None:
        """Initialise every channel at its equilibrium for the constant input u0.

        x = (I - A)^-1 B u0, so that a constant input u0 keeps the output constant at
        dc_gain * u0 (e.g. the feedforward starts at rest at q_start).

        Raises:
            InvalidParameterError: if the filter has a pole at z = 1 (an integrator has
                no equilibrium for a non-zero input; use :meth:`reset_output`).
        """
        u0 = as_array(u0, "u0", self._shape)
        if self._has_unit_pole():
            raise InvalidParameterError(
                "filter", "a pole at z = 1", "a filter without integrator (use reset_output instead)"
            )
        n = self.n_states
        x1 = np.linalg.solve(np.eye(n) - self._A, self._B[:, 0])
        self._x[...] = np.outer(x1, u0)

    def reset_output(self, y0: Any) -> None:
        """For a filter with an integrator: rest state with output y0 under zero input.

        The state is placed on the eigenvector w of A for eigenvalue 1, scaled so that
        C w = 1; then A x = x and y = C x = y0 while the input stays zero.

        Raises:
            InvalidParameterError: if the filter has no pole at z = 1, or its integrator
                state is unobservable (C w = 0).
        """
        y0 = as_array(y0, "y0", self._shape)
        n = self.n_states
        _, sv, vt = np.linalg.svd(self._A - np.eye(n))
        if not self._has_unit_pole(sv):
            raise InvalidParameterError(
                "filter", "no pole at z = 1", "a filter with an integrator (use reset_steady_state instead)"
            )
        w = vt[-1]
        cw = float(self._C @ w)
        if abs(cw) < 1e-12 * (np.linalg.norm(self._C) + 1e-300):
            raise InvalidParameterError("filter", "an unobservable integrator (C w = 0)", "C w != 0")
        self._x[...] = np.outer(w / cw, y0)

    def _has_unit_pole(self, sv: np.ndarray | None = None) -> bool:
        if sv is None:
            sv = np.linalg.svd(self._A - np.eye(self.n_states), compute_uv=False)
        return bool(sv[-1] <= 1e-10 * max(1.0, float(np.abs(self._A).max())))
