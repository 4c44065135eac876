"""Compiled frame kernels: one camera frame (or joint tick) of classical IBVS on an ideal plant, one call.

The servo loop (:mod:`.loop`) calls each role through Python at every frame: the sensor, the
controller's update and command, the actuation chain, the recorder and the plant, a dozen calls and
as many small arrays. When every role is the library's own (:mod:`.compiled_loop` decides), these
kernels do the same arithmetic in one compiled call (:func:`ibvs_youla._jit.jit`):

* :func:`free_camera_step`: the sensor's projection of the true markers (Eq. (9)-(11), with the
  depths when the sensor measures them), classical IBVS v = -lambda L_e^+ e (Chaumette & Hutchinson
  2006, Eq. (5), L_e at the current, desired or mean features), the sample recorded, and the pose
  integrated, T <- T exp(dt [v]^) (the free camera);
* :func:`kinematic_tick`: a joint tick of the kinematic arm following joint velocities: on a frame
  tick the projection and the law as above; every tick the twist held, dq_ref = J_C^+ [v; w]
  (J_C the controller's, at the encoders; the damped pseudo-inverse of the actuation), the sample
  recorded and q <- q + dt dq_ref. J_C and the camera pose come from Pinocchio (the arm's
  kinematics), so the kernel is the same for every arm, its size n taken from the arrays.

Each is a composition of per-equation kernels (:func:`measure`, :func:`ibvs_twist`,
:func:`exp6_integrate`) on plain arrays of one case, so that a batch of cases can run them in a
compiled loop over cases. What follows the law is its own kernel, the same for any law that gives a
camera twist: :func:`camera_step` (the frame logged, the sample, the free camera's step) and
:func:`joint_step` (the arm's tick); the frames of PBVS and 2.5-D (:mod:`.pose_frame_kernels`) and of
the hybrid law (:mod:`.hybrid_frame_kernels`) end with them too.
They do not validate and never raise: wherever the plug-in loop would stop or raise (a depth or
disparity the projection rejects, a failed SVD, a non-finite command), they return
:data:`DECLINED`, and the caller runs the plug-in loop instead, which reproduces its status or
error. The results equal the plug-in loop's to rounding (``tests/test_compiled_frame_path.py``:
1e-12); sums run in loops, in the reference's order where it forms a product first.

Layouts: ``params`` (see :func:`pack_parameters`) holds the true and the believed camera (the
layout of :func:`~ibvs_youla.model.camera_kernels.camera_parameters`), the lens offsets, the law's
settings and the period; ``law`` (m, 13) the target features, L* (m, 6) and L*^+ transposed (m, 6);
``frame`` the current frame, [features (m), visible (n), depth (n)], written by :func:`measure`.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit
from ..control.svd_kernels import pseudo_inverse_apply, svd_gains
from ..model.camera_kernels import interaction_matrix, measure_features, points_in_camera, triangulate
from .recorder import record_row

__all__ = [
    "DECLINED",
    "DEPTH_MEASURED",
    "DEPTH_TRIANGULATED",
    "camera_step",
    "exp6_integrate",
    "finite",
    "free_camera_step",
    "ibvs_twist",
    "joint_step",
    "kinematic_tick",
    "measure",
    "pack_parameters",
    "record_frame",
    "tick_time",
]

DECLINED = -1  # a kernel's status when the plug-in loop must run instead (module docstring)
DEPTH_MEASURED, DEPTH_TRIANGULATED = 0, 1  # where the depths of L come from
_CURRENT, _DESIRED, _MEAN = 0, 1, 2  # the interaction of ibvs.INTERACTIONS, by index

# Layout of the parameter vector (pack_parameters)
_TRUE, _BELIEF = 0, 12  # the true and the believed camera's camera_parameters
_TRUE_LENS, _BELIEF_LENS = 24, 26  # lens x-offsets (up to two) [m]
_N_LENS_TRUE, _N_LENS_BELIEF = 28, 29
_DT, _LAMBDA_0, _LAMBDA_INF, _LAMBDA_DOT_0, _ADAPTIVE = 30, 31, 32, 33, 34
_PINV_THRESHOLD, _INTERACTION, _DEPTH_FROM = 35, 36, 37
_VIRTUAL, _MEASURE_DEPTH, _RECORD_EVERY, _N_TICKS = 38, 39, 40, 41
_JOINT_DAMPED, _JOINT_THRESHOLD = 42, 43
_N_PARAMETERS = 44


def pack_parameters(
    true_camera: tuple[np.ndarray, np.ndarray],
    believed_camera: tuple[np.ndarray, np.ndarray],
    *,
    dt: float,
    gain: tuple[float, float, float, bool],
    pinv_threshold: float,
    interaction: int,
    depth_from: int,
    virtual_points: bool,
    measure_depth: bool,
    record_every: int,
    n_ticks: int,
    joint_policy: tuple[bool, float] = (True, 0.0),
) -> np.ndarray:
    """The parameter vector of the kernels (module docstring).

    Args:
        true_camera: ``camera_parameters`` of the sensor's (true) camera.
        believed_camera: ``camera_parameters`` of the controller's camera.
        dt: Tick period [s].
        gain: (lambda_0, lambda_inf, lambda_dot_0, adaptive): a constant lambda is (lambda, lambda, 0,
            False) [1/s].
        pinv_threshold: The law's singular-value cut-off (relative to sigma_max).
        interaction: 0 current, 1 desired, 2 mean.
        depth_from: :data:`DEPTH_MEASURED` (a depth sensor's) or :data:`DEPTH_TRIANGULATED` (stereo).
        virtual_points: Markers may lie behind the camera (both the sensor and the law).
        measure_depth: The sensor reports depths.
        record_every: Keep every n-th tick sample (and the last).
        n_ticks: The run's last tick.
        joint_policy: (damped, threshold) of J_C's pseudo-inverse (the kinematic arm's actuation).
    """
    p = np.zeros(_N_PARAMETERS)
    for start, lens_at, count_at, (params, lens_x) in (
        (_TRUE, _TRUE_LENS, _N_LENS_TRUE, true_camera),
        (_BELIEF, _BELIEF_LENS, _N_LENS_BELIEF, believed_camera),
    ):
        p[start : start + 12] = params
        p[lens_at : lens_at + lens_x.shape[0]] = lens_x
        p[count_at] = lens_x.shape[0]
    p[_DT] = dt
    p[_LAMBDA_0], p[_LAMBDA_INF], p[_LAMBDA_DOT_0], p[_ADAPTIVE] = gain
    p[_PINV_THRESHOLD], p[_INTERACTION], p[_DEPTH_FROM] = pinv_threshold, interaction, depth_from
    p[_VIRTUAL], p[_MEASURE_DEPTH] = float(virtual_points), float(measure_depth)
    p[_RECORD_EVERY], p[_N_TICKS] = record_every, n_ticks
    p[_JOINT_DAMPED], p[_JOINT_THRESHOLD] = float(joint_policy[0]), joint_policy[1]
    return p


@jit
def measure(T_O_C: np.ndarray, markers_O: np.ndarray, params: np.ndarray, frame: np.ndarray) -> bool:
    """The sensor: features, visibility (0/1) and depths of the true markers seen from T_O_C, into ``frame``.

    P_C = R^T (P_O - t) (Eq. (21)-(22)), then ``measure_features`` (Eq. (9)-(11)); the depths Z_C are
    written whether or not the sensor reports them. False when a depth is one the projection rejects.
    """
    n = markers_O.shape[0]
    k = int(params[_N_LENS_TRUE])
    P = points_in_camera(T_O_C, markers_O)
    lens_x = params[_TRUE_LENS : _TRUE_LENS + k]
    features, visible, bad = measure_features(P, params[_TRUE : _TRUE + 12], lens_x, params[_VIRTUAL] != 0.0)
    if bad >= 0:
        return False
    m = features.shape[0]
    for r in range(m):
        frame[r] = features[r]
    for i in range(n):
        frame[m + i] = 1.0 if visible[i] else 0.0
        frame[m + n + i] = P[i, 2]
    return True


@jit
def ibvs_twist(frame: np.ndarray, n: int, law: np.ndarray, params: np.ndarray, twist: np.ndarray) -> float:
    """The law v = -lambda L_e^+ (s - s*) (Eq. (5)) into ``twist`` (6,); returns lambda [1/s] (NaN: declined).

    L_e: L* (desired), L(s, Z) (current) or (L + L*) / 2 (mean), the depths Z measured (the frame's)
    or triangulated (stereo); the points back-projected at them (``current_interaction_matrix``).
    A monocular camera's depths from a PnP pose are not computed here (:mod:`.compiled_loop` says
    why). The pseudo-inverse
    V diag(g) U^T with the singular values <= threshold sigma_max dropped (``ClassicalIBVS.pinv``),
    formed and then applied, as the reference.
    """
    m = law.shape[0]
    e = np.empty(m)
    e_max = 0.0
    for r in range(m):
        e[r] = frame[r] - law[r, 0]
        e_max = max(e_max, abs(e[r]))
    mode = int(params[_INTERACTION])
    y = np.zeros(6)
    if mode == _DESIRED:
        for j in range(6):
            acc = 0.0
            for r in range(m):
                acc += law[r, 7 + j] * e[r]
            y[j] = acc
    else:
        allow_behind = params[_VIRTUAL] != 0.0
        cam = params[_BELIEF : _BELIEF + 12]
        k = int(params[_N_LENS_BELIEF])
        F = cam[0]
        depth_from = int(params[_DEPTH_FROM])
        if depth_from == DEPTH_TRIANGULATED:
            P, bad = triangulate(frame[:m], cam, allow_behind)
            if bad >= 0:
                return math.nan
        else:
            P = np.empty((n, 3))
            per = m // n
            for i in range(n):  # points_at_depths
                Z = frame[m + n + i]
                u = 0.5 * (frame[per * i] + frame[per * i + 1]) if per == 3 else frame[per * i]
                s = Z / F
                P[i, 0], P[i, 1], P[i, 2] = u * s, frame[per * i + per - 1] * s, Z
        L, bad = interaction_matrix(P, cam, params[_BELIEF_LENS : _BELIEF_LENS + k], allow_behind)
        if bad >= 0:
            return math.nan
        if mode == _MEAN:
            for r in range(m):
                for j in range(6):
                    L[r, j] = 0.5 * (L[r, j] + law[r, 1 + j])
        U, _, g, Vt, ok = svd_gains(L, False, params[_PINV_THRESHOLD])
        if not ok:
            return math.nan
        kk = g.shape[0]
        for j in range(6):  # (V diag(g) U^T) e, the pseudo-inverse formed first (the reference's order)
            acc = 0.0
            for r in range(m):
                p = 0.0
                for i in range(kk):
                    p += Vt[i, j] * g[i] * U[r, i]
                acc += p * e[r]
            y[j] = acc
    lam = params[_LAMBDA_0]
    if params[_ADAPTIVE] != 0.0:  # AdaptiveGain at ||e||_inf
        a = params[_LAMBDA_0] - params[_LAMBDA_INF]
        if a != 0.0:
            lam = a * math.exp(-params[_LAMBDA_DOT_0] * e_max / a) + params[_LAMBDA_INF]
    for j in range(6):
        twist[j] = -lam * y[j]
    return lam


@jit
def exp6_integrate(T: np.ndarray, twist: np.ndarray, dt: float) -> None:
    """T <- T exp(dt [xi]^) in place, xi = [v; w] (6,) a body twist (the free camera, Pinocchio's exp6).

    exp of [v; w] dt: R = I + a [w]x + b [w]x^2 and p = (I + b [w]x + c [w]x^2) v dt with the angle
    t = |w| dt, a = sin t / t, b = (1 - cos t) / t^2, c = (t - sin t) / t^3 (the Taylor series below
    t = 1e-4, where the closed forms lose digits), [w]x of w dt.
    """
    wx, wy, wz = twist[3] * dt, twist[4] * dt, twist[5] * dt
    vx, vy, vz = twist[0] * dt, twist[1] * dt, twist[2] * dt
    t2 = wx * wx + wy * wy + wz * wz
    t = math.sqrt(t2)
    if t < 1e-4:
        a = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0)
        b = 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0)
        c = 1.0 / 6.0 - t2 / 120.0 * (1.0 - t2 / 42.0)
    else:
        s, co = math.sin(t), math.cos(t)
        a, b, c = s / t, (1.0 - co) / t2, (t - s) / (t2 * t)
    K = np.array([[0.0, -wz, wy], [wz, 0.0, -wx], [-wy, wx, 0.0]])
    K2 = K @ K
    E = np.empty((3, 4))
    v = (vx, vy, vz)
    for r in range(3):
        for q in range(3):
            E[r, q] = (1.0 if r == q else 0.0) + a * K[r, q] + b * K2[r, q]
        E[r, 3] = v[r] + b * (K[r, 0] * vx + K[r, 1] * vy + K[r, 2] * vz)
        E[r, 3] += c * (K2[r, 0] * vx + K2[r, 1] * vy + K2[r, 2] * vz)
    T_old = T[:3, :].copy()
    for r in range(3):
        for q in range(4):
            acc = T_old[r, 0] * E[0, q] + T_old[r, 1] * E[1, q] + T_old[r, 2] * E[2, q]
            T[r, q] = acc + (T_old[r, 3] if q == 3 else 0.0)


@jit
def tick_time(k: int, params: np.ndarray) -> float:
    """The time of tick k, t = k dt [s] (the plug-in loop's product)."""
    return k * params[_DT]  # type: ignore[no-any-return]


@jit
def finite(x: np.ndarray) -> bool:
    """Every entry of x finite."""
    for v in x:
        if not math.isfinite(v):
            return False
    return True


@jit
def record_frame(frames: np.ndarray, index: int, t: float, frame: np.ndarray, n: int) -> None:
    """Row ``index`` of the frame log: [t, features (m), visible (n)] (the update time is the caller's)."""
    frames[index, 0] = t
    for r in range(frame.shape[0] - n):
        frames[index, 1 + r] = frame[r]


@jit
def free_camera_step(
    k: int,
    T_O_C: np.ndarray,
    n: int,
    law: np.ndarray,
    params: np.ndarray,
    frame: np.ndarray,
    twist: np.ndarray,
    gain: np.ndarray,
    table: np.ndarray,
    row: int,
    sizes: np.ndarray,
    frames: np.ndarray,
) -> int:
    """Frame k of classical IBVS on the free camera after the frame is measured; the next row or DECLINED.

    The law on ``frame`` (n points) into ``twist`` and ``gain`` (1,), the sample into ``table`` (row
    ``row``, when kept: every record_every-th tick and the last) and the frame log, then T_O_C <-
    T_O_C exp(dt [v]^) unless k is the last tick.
    """
    lam = ibvs_twist(frame, n, law, params, twist)
    if not (math.isfinite(lam) and finite(twist)):
        return DECLINED  # the plug-in loop raises its error (an invalid command, a diverging plant)
    gain[0] = lam
    return camera_step(k, T_O_C, frame, law.shape[0], n, params, twist, gain, table, row, sizes, frames)


@jit
def camera_step(
    k: int,
    T_O_C: np.ndarray,
    frame: np.ndarray,
    m: int,
    n: int,
    params: np.ndarray,
    twist: np.ndarray,
    signal: np.ndarray,
    table: np.ndarray,
    row: int,
    sizes: np.ndarray,
    frames: np.ndarray,
) -> int:
    """Frame k of the free camera after any law's ``twist``; returns the next free row, or DECLINED.

    The frame logged (its m features, n markers), the sample (twist, then the law's ``signal``) into
    ``table`` at ``row`` when kept (every record_every-th tick and the last), then T_O_C <- T_O_C
    exp(dt [v]^) unless k is the last tick.
    """
    dt, n_ticks = params[_DT], int(params[_N_TICKS])
    t = k * dt
    record_frame(frames, k, t, frame, n)
    every = int(params[_RECORD_EVERY])
    if k % every == 0 or k == n_ticks:
        if not record_row(table, row, t, T_O_C, frame[:m], frame[m : m + n] != 0.0, (twist, signal), sizes):
            return DECLINED
        row += 1
    if k < n_ticks:
        exp6_integrate(T_O_C, twist, dt)
    return row


@jit
def kinematic_tick(
    k: int,
    is_frame: bool,
    measured: bool,
    T_O_C: np.ndarray,
    J_C: np.ndarray,
    state: np.ndarray,
    markers_O: np.ndarray,
    law: np.ndarray,
    params: np.ndarray,
    frame: np.ndarray,
    twist: np.ndarray,
    gain: np.ndarray,
    table: np.ndarray,
    row: int,
    sizes: np.ndarray,
    frames: np.ndarray,
    frame_index: int,
) -> int:
    """Tick k of classical IBVS on the kinematic arm; returns the next free table row, or DECLINED.

    ``state`` (4, n): true joints q_true, encoders q = q_true - d, speeds dq and the offset d [rad,
    rad/s], advanced in place. On a frame tick (``is_frame``), the frame measured from T_O_C (unless
    ``measured``: ``frame`` holds it already) and the law into ``twist`` and ``gain``, logged at
    ``frame_index``; then every tick
    dq_ref = J_C^+ [v; w] (the actuation's damped pseudo-inverse, J_C (6, n) at the encoders), the
    sample (encoders, true joints, speeds, twist, dq_ref, gain; T_O_C must be the pose at q_true
    when the sample is kept) and, unless k is the last tick, q_true <- q_true + dt dq_ref.
    """
    n = markers_O.shape[0]
    t = k * params[_DT]
    if is_frame:
        if not measured and not measure(T_O_C, markers_O, params, frame):
            return DECLINED
        lam = ibvs_twist(frame, n, law, params, twist)
        if not (math.isfinite(lam) and finite(twist)):
            return DECLINED
        gain[0] = lam
        record_frame(frames, frame_index, t, frame, n)
    return joint_step(k, T_O_C, J_C, state, frame, law.shape[0], n, params, twist, gain, table, row, sizes)


@jit
def joint_step(
    k: int,
    T_O_C: np.ndarray,
    J_C: np.ndarray,
    state: np.ndarray,
    frame: np.ndarray,
    m: int,
    n: int,
    params: np.ndarray,
    twist: np.ndarray,
    signal: np.ndarray,
    table: np.ndarray,
    row: int,
    sizes: np.ndarray,
) -> int:
    """Tick k of the kinematic arm after any law's ``twist`` (held); returns the next free row, or DECLINED.

    dq_ref = J_C^+ [v; w] (the actuation's damped pseudo-inverse, J_C (6, nq) at the encoders), the
    sample (encoders, true joints, speeds, twist, dq_ref, then the law's ``signal``; the frame's m
    features and n markers) and, unless k is the last tick, q_true <- q_true + dt dq_ref
    (``state`` as :func:`kinematic_tick`'s).
    """
    dt, n_ticks = params[_DT], int(params[_N_TICKS])
    t = k * dt
    nq = state.shape[1]
    dq_ref = np.empty(nq)
    if not pseudo_inverse_apply(J_C, twist, params[_JOINT_DAMPED] != 0.0, params[_JOINT_THRESHOLD], dq_ref):
        return DECLINED
    if not finite(dq_ref):
        return DECLINED  # the plant's divergence test: the plug-in loop raises its error
    every = int(params[_RECORD_EVERY])
    if k % every == 0 or k == n_ticks:
        values = (state[1], state[0], state[2], twist, dq_ref, signal)
        if not record_row(table, row, t, T_O_C, frame[:m], frame[m : m + n] != 0.0, values, sizes):
            return DECLINED
        row += 1
    if k < n_ticks:
        for j in range(nq):
            state[0, j] = state[0, j] + dq_ref[j] * dt
            state[2, j] = dq_ref[j]
            state[1, j] = state[0, j] - state[3, j]
    return row
