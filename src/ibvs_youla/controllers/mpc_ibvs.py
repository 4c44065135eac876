"""Model predictive IBVS: a quadratic program over N predicted frames, solved at every camera frame.

Visual predictive control in the spirit of Allibert, Courtial & Chaumette, "Predictive control
for constrained image-based visual servoing", IEEE Transactions on Robotics 26(5), 2010: the
features are predicted over a horizon of N frames by a model, a quadratic cost of the predicted
image error is minimized under input (speed) and output (visibility) constraints, and only the
first move is applied (receding horizon). Allibert et al. solve a nonlinear program (their
*global* model, or the *local* model below) by SQP; here, as in Roque et al., "Fast model
predictive image-based visual servoing for quadrotors", IROS 2020, the local model is linear and
held over the horizon, so the problem is a QP solved exactly at every frame. (Equation numbers
of either paper are not cited: their text is not in this repository to check them against.)

**Local model.** With T = ``task.frame_period`` [s] and the twist v_j = [v; w] held over frame j,

    s_{j+1} = s_j + T L v_j,        j = 0 .. N-1,

with L = L(s_0, Z) the interaction matrix at the *current* features and depths, held fixed over
the horizon (no re-linearization along the prediction; a later option may re-linearize). Depths
come from the controller's own model, as in classical IBVS: a monocular camera's pose estimated
from the image, ``estimate_camera_pose(task.camera, features, task.markers_O)`` (SQPnP, or ``pnp``), gives
Z_i and L is evaluated at the measured features (points back-projected, X = u Z / F); a stereo
camera triangulates its points (``triangulate_points``, Eq. (C6)-(C8) of the project's paper);
a frame with measured depths (``sensor="depth"``) gives them instead (:mod:`.image_points`).
Features enter the QP divided by the focal length F (normalized coordinates), so the weights mean
the same for every camera.

**Cost.** With e_0 = s_0 - s* and a = 1 - lambda T, the reference trajectory is the exponential
decay r_j = s* + a^j e_0 of classical IBVS, and

    J(v_0 .. v_{N-1}) = sum_{j=1..N} Q ||s_j - r_j||^2 + sum_{j=0..N-1} R ||v_j||^2     (Q, R scalars).

**Classical IBVS as a special case.** Let V_j = v_0 + ... + v_{j-1}, so that s_j - r_j =
T L V_j + (1 - a^j) e_0. With R = 0 and no active constraint, each term is minimized alone by
V_j = -((1 - a^j) / T) L^+ e_0 (normal equations L^T L V_j = -((1 - a^j)/T) L^T e_0, L of full
column rank, e.g. 8 x 6 for four points), and since (v_0 .. v_{N-1}) -> (V_1 .. V_N) is a
bijection these V_j are reachable together: the unique minimizer has
v_0 = V_1 = -((1 - a) / T) L^+ e_0 = -lambda L^+ e_0, the classical IBVS law v = -lambda L^+ e
(Chaumette & Hutchinson 2006, Eq. (5)), for a one-step horizon and, with this held model, for
any N. The normalization by F changes nothing: (L/F)^+ (e/F) = L^+ e. The constraints are thus
the only difference from IBVS unless R > 0 (which slows the moves).

**Constraints.** On every move of the horizon, component-wise as ViSP's
``vpRobot::saturateVelocities``: |v_x|, |v_y|, |v_z| <= v_max and |w_x|, |w_y|, |w_z| <= omega_max
(defaults 1 m/s and 90 deg/s, the limits of ViSP's ``vpSimulatorCamera``; the Euclidean speed
may reach sqrt(3) v_max). On every predicted frame j = 1..N, every feature inside the image
less a margin. For a camera with a finite sensor: its pixel coordinate through K
(``intrinsic_matrix``) inside [0, width] x [0, height], i.e. [m on the sensor]

    -u0 p + margin <= u + (k p / F) v <= W - u0 p - margin,   -v0 p + margin <= v <= H - v0 p - margin

for each lens's u (pitch p, principal point (u0, v0) [px], skew k [px]); for a centred principal
point and no skew, |u| <= W/2 - margin and |v| <= H/2 - margin. For a camera without a
field-of-view limit (``unbounded_view``, e.g. ``PinholeCamera.normalized()``): the box |u|, |v|
<= ``image_half_extent`` - margin in feature units (default half extent 0.5, 53 deg of view).

**Solver.** ``qpsolvers.solve_problem`` (the call behind ``solve_qp``, which also returns the
duals) with DAQP by default (Arnström, Bemporad & Axehill 2022): a maintained dual active-set
solver in C for small dense QPs, which solves these 6N-variable problems exactly (to its
feasibility tolerance), reports infeasibility and needs no tuning. Decision variables: the N
twists; objective J / (2 T^2) (scaled), Hessian of N x N blocks Q (N - max(i, k)) L^T L plus
R/T^2 on the diagonal, positive definite when L has full column rank or R > 0.

**Infeasible QP.** Zero motion satisfies the constraints whenever the current features are
inside the box, so the QP is infeasible only when a feature is already outside it and cannot
be brought back in one frame within the speed bounds. ``fallback="relax"`` (default) then
solves the QP again with each violated image bound loosened, on every predicted frame, to the
feature's current value (it may not move further out; zero motion is feasible, so this QP always has a
solution); ``fallback="stop"`` commands zero twist. Either way ``qp_solved`` is 0 for the
frame and ``qp_infeasible_frames`` counts it.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
import qpsolvers

from .._memory import fits_in_memory
from .._validation import integer, non_negative, one_of, positive
from ..estimation.monocular_pose import PNP_METHODS
from ..exceptions import InvalidParameterError
from ..model.camera import StereoCamera
from .base import CameraFrame, CommandType, Controller, JointReading, ServoTask
from .image_points import CurrentInteraction, feature_rows, pnp_spec
from .mpc_kernels import qp_blocks

__all__ = ["FALLBACKS", "REGISTRATIONS", "MpcIBVS"]

FALLBACKS = ("relax", "stop")
_ACTIVE_TOL = 1e-6  # a constraint counts as active within this slack (DAQP's primal tolerance scale)


def _image_box(camera: Any, half_extent: float, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """(A, b) with A s_point <= b for one point's features (module docstring), in feature units.

    Rows: for each lens's u, upper then lower bound; then v's. A is (2 (k+1), k+1).
    """
    k = 2 if isinstance(camera, StereoCamera) else 1
    if camera.unbounded_view:
        kappa, u_lo, u_hi, v_lo, v_hi = 0.0, -half_extent, half_extent, -half_extent, half_extent
        what = f"image_half_extent = {half_extent:g}"
    else:
        p, (u0, v0) = camera.pixel_pitch, camera.principal_point
        kappa = camera.skew * p / camera.focal_length
        u_lo, u_hi = -u0 * p, camera.sensor_width - u0 * p
        v_lo, v_hi = -v0 * p, camera.sensor_height - v0 * p
        what = f"a {camera.sensor_width:g} x {camera.sensor_height:g} m sensor"
    if 2.0 * margin >= min(u_hi - u_lo, v_hi - v_lo):
        raise InvalidParameterError(
            "margin", margin, f"a number >= 0 below half the image extent ({what}) in feature units"
        )
    A = np.zeros((2 * (k + 1), k + 1))
    b = np.empty(2 * (k + 1))
    for lens in range(k):
        A[2 * lens, [lens, k]] = (1.0, kappa)
        A[2 * lens + 1, [lens, k]] = (-1.0, -kappa)
        b[2 * lens : 2 * lens + 2] = (u_hi - margin, -(u_lo + margin))
    A[2 * k, k], A[2 * k + 1, k] = 1.0, -1.0
    b[2 * k :] = (v_hi - margin, -(v_lo + margin))
    return A, b


def _horizon(value: Any) -> int:
    return integer(value, "horizon", low=1, unit="[frames]")


class MpcIBVS(Controller):
    """Model predictive IBVS: one QP per camera frame (module docstring).

    Args:
        horizon: N, predicted frames (default 5).
        q_weight: Q > 0, weight of the squared image error (normalized coordinates) per frame.
        r_weight: R >= 0, weight of the squared twist [per (m/s)^2 and (rad/s)^2]; default 0,
            so that the unconstrained move is classical IBVS.
        gain: lambda [1/s] of the reference decay (default 0.5, ViSP's tutorial value);
            lambda T must lie in (0, 1].
        v_max: Bound on each linear speed component [m/s] (default 1, ViSP's simulator).
        omega_max: Bound on each angular speed component [rad/s] (default 90 deg/s, ViSP's).
        margin: Distance kept from the image border, in feature units ([m on the sensor],
            normalized units for ``PinholeCamera.normalized()``); default 0.
        image_half_extent: Half side of the image box for a camera without a field-of-view
            limit, in feature units (default 0.5); unused for a finite sensor.
        solver: A solver of ``qpsolvers.available_solvers`` (default ``"daqp"``).
        fallback: ``"relax"`` or ``"stop"``, for a frame whose QP is infeasible.
        pnp: The PnP method of the monocular pose that gives the depths, one of
            :data:`~ibvs_youla.estimation.monocular_pose.PNP_METHODS` (default ``"sqpnp"``;
            ``"ippe"`` for coplanar markers). A stereo camera takes only the default
            (triangulated depths).

    Raises:
        InvalidParameterError: a bad value or a solver that is not installed (the message lists
            those that are); at reset, a camera that is neither stereo nor pinhole, too few
            points (stereo >= 3, monocular >= 4), lambda T > 1, a margin that leaves no image,
            or target features outside the constrained image; ``pnp`` other than ``"sqpnp"`` with a
            stereo camera, or ``"ippe"`` with markers that are not coplanar.
    """

    command_type = CommandType.CAMERA_TWIST
    name = "mpc-ibvs"

    def __init__(
        self,
        horizon: int = 5,
        q_weight: float = 1.0,
        r_weight: float = 0.0,
        gain: float = 0.5,
        v_max: float = 1.0,
        omega_max: float = math.radians(90.0),
        margin: float = 0.0,
        image_half_extent: float = 0.5,
        solver: str = "daqp",
        fallback: str = "relax",
        pnp: str = "sqpnp",
    ) -> None:
        self.horizon = _horizon(horizon)
        self.q_weight = positive(q_weight, "q_weight")
        self.r_weight = non_negative(r_weight, "r_weight")
        self.gain = positive(gain, "gain", unit="1/s")
        self.v_max = positive(v_max, "v_max", unit="m/s")
        self.omega_max = positive(omega_max, "omega_max", unit="rad/s")
        self.margin = non_negative(margin, "margin")
        self.image_half_extent = positive(image_half_extent, "image_half_extent")
        if not isinstance(solver, str) or solver not in qpsolvers.available_solvers:
            raise InvalidParameterError(
                "solver",
                solver,
                "an installed QP solver: " + ", ".join(map(repr, qpsolvers.available_solvers)),
            )
        self.solver = solver
        self.fallback = one_of(fallback, "fallback", FALLBACKS)
        self.pnp = one_of(pnp, "pnp", PNP_METHODS)
        self._init_signals()

    def _init_signals(self) -> None:
        self._twist = np.zeros(6)
        self._solved = np.full(1, np.nan)
        self._time = np.full(1, np.nan)
        self._active = np.full(1, np.nan)
        self._infeasible = np.zeros(1)

    def spec(self) -> dict[str, Any]:
        """Every parameter (``pnp`` if not the default), and the fixed choices (model, reference, bounds)."""
        return {
            **super().spec(),
            "horizon": self.horizon,
            "q_weight": self.q_weight,
            "r_weight": self.r_weight,
            "gain": self.gain,
            "v_max": self.v_max,
            "omega_max": self.omega_max,
            "margin": self.margin,
            "image_half_extent": self.image_half_extent,
            "solver": self.solver,
            "fallback": self.fallback,
            "model": "local: L at the current features and depths, held over the horizon",
            "reference": "s* + (1 - gain T)^j e_0",
            "speed_bounds": "component-wise (ViSP's saturateVelocities)",
            **pnp_spec(self.pnp),
        }

    # ------------------------------------------------------------------ run
    def reset(self, task: ServoTask) -> None:
        """Check the camera, points and bounds; build the parts of the QP that do not change."""
        camera, n = task.camera, task.n_points
        rows = feature_rows(task, self.name)
        T = float(task.frame_period)
        a = 1.0 - self.gain * T  # reference decay per frame
        if a < 0.0:
            raise InvalidParameterError(
                "gain", self.gain, f"a number in (0, 1/T] = (0, {1.0 / T:g}] 1/s (T = {T:g} s per frame)"
            )
        target = np.asarray(task.feature_target, dtype=float)
        A_point, b_point = _image_box(camera, self.image_half_extent, self.margin)
        A_img, b_img = np.kron(np.eye(n), A_point), np.tile(b_point, n)  # A_img s <= b_img
        slack = b_img - A_img.dot(target)
        if slack.min() < -1e-12:
            raise InvalidParameterError(
                "margin",
                self.margin,
                f"a box that contains the target features (worst by {-slack.min():.3g} feature units)",
            )
        N, F = self.horizon, camera.focal_length
        # P (6N x 6N, and R), G (image rows N x 6N), W, lower: refuse a horizon beyond memory
        fits_in_memory(
            8.0 * (2 * (6 * N) ** 2 + 4 * A_img.shape[0] * N * 6 * N + 2 * N * N),
            "horizon",
            self.horizon,
            "a shorter horizon",
        )
        super().reset(task)
        lower = np.tril(np.ones((N, N)))  # row j-1: V_j = sum_{i<j} v_i
        self._rows, self._target, self._F, self._T = rows, target, F, T
        # L(s, Z), what does not change made once
        self._interaction = CurrentInteraction(task, rows, self.pnp)
        self.pose_estimator = self._interaction.pose_estimator  # monocular: the pose giving L its depths
        self._A_img, self._b_img = A_img, b_img / F  # A_img (s / F) <= b_img / F, on normalized features
        self._lower = lower
        self._W = lower.T.dot(lower)  # W[i, k] = N - max(i, k)
        self._w = lower.T.dot(1.0 - a ** np.arange(1, N + 1))  # w_i = sum_{j > i} (1 - a^j)
        self._R_diag = (self.r_weight / T**2) * np.eye(6 * N)
        bound = np.tile([self.v_max] * 3 + [self.omega_max] * 3, N)
        self._lb, self._ub = -bound, bound
        self._init_signals()

    def interaction_matrix(self, features: np.ndarray, depth: np.ndarray | None = None) -> np.ndarray:
        """L(s, Z) (m, 6) at the features, at measured depths (n,) [m] or the model's (module docstring)."""
        return self._interaction(features, depth)

    def qp(
        self, features: np.ndarray, depth: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(P, q, G, h) of min 1/2 x^T P x + q^T x s.t. G x <= h over x = [v_0; ..; v_{N-1}] (6N,).

        The cost is J / (2 T^2) (module docstring); the speed bounds are separate (``lb``, ``ub``).
        ``depth``: the frame's measured depths (n,) [m], None to estimate them.
        """
        F, T, N = self._F, self._T, self.horizon
        L = self.interaction_matrix(features, depth) / F  # on normalized features
        e0 = (features - self._target) / F
        AL = self._A_img.dot(L)
        P, q, G = np.empty((6 * N, 6 * N)), np.empty(6 * N), np.empty((N * AL.shape[0], 6 * N))
        # P = q_weight kron(W, L^T L) + R, q = (q_weight / T) kron(w, L^T e0), G = kron(lower, A L):
        # the image rows of s_j, j = 1..N; in one compiled call, the same floats
        qp_blocks(
            self._W,
            self._w,
            self._lower,
            L.T.dot(L),
            L.T.dot(e0),
            AL,
            self.q_weight,
            self.q_weight / T,
            self._R_diag,
            P,
            q,
            G,
        )
        h = np.tile((self._b_img - self._A_img.dot(features / F)) / T, N)
        return P, q, G, h

    def _solve(self, P: np.ndarray, q: np.ndarray, G: np.ndarray, h: np.ndarray) -> np.ndarray | None:
        problem = qpsolvers.Problem(P, q, G, h, lb=self._lb, ub=self._ub)
        solution = qpsolvers.solve_problem(problem, solver=self.solver)
        return solution.x if solution.found else None

    def update(self, frame: CameraFrame, reading: JointReading | None) -> None:
        """One camera frame: solve the QP and keep its first move (module docstring)."""
        P, q, G, h = self.qp(frame.features, frame.depth)
        tic = time.perf_counter()
        x = self._solve(P, q, G, h)
        solved = x is not None
        if not solved:
            self._infeasible = self._infeasible + 1.0
            if self.fallback == "relax":
                h = np.maximum(h, 0.0)  # violated bounds held at the current value: x = 0 is feasible
                x = self._solve(P, q, G, h)
        self._time = np.array([time.perf_counter() - tic])
        self._solved = np.array([float(solved)])
        if x is None:
            self._twist, self._active = np.zeros(6), np.zeros(1)
            return
        self._twist = x[:6].copy()
        slack = np.concatenate((h - G.dot(x), self._ub - np.abs(x)))
        self._active = np.array([float(np.count_nonzero(slack <= _ACTIVE_TOL))])

    def command(self, reading: JointReading | None) -> np.ndarray:
        """The first move [v; w] of the last QP [m/s, rad/s] (zero before the first frame)."""
        return self._twist

    def signals(self) -> dict[str, np.ndarray]:
        """Per frame, held between frames (NaN before the first), each (1,).

        ``qp_solved``: 1 when the constrained QP was solved, 0 when it was infeasible (then the
        fallback acted); ``qp_time``: wall-clock time of the solve(s) [s]; ``qp_active``: number
        of active constraints (image rows and speed bounds within 1e-6 of their bound, in the
        QP's scaled units); ``qp_infeasible_frames``: infeasible frames so far.
        """
        return {
            "qp_solved": self._solved,
            "qp_time": self._time,
            "qp_active": self._active,
            "qp_infeasible_frames": self._infeasible,
        }


REGISTRATIONS = (
    (
        "mpc-ibvs",
        MpcIBVS,
        "model predictive IBVS: a QP over N frames with speed and visibility bounds (Allibert et al. 2010)",
    ),
)
