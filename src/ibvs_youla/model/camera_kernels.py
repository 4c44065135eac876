"""Compiled camera equations for the servo loop: projection with visibility, image Jacobian, triangulation.

Each function is the Numba-compiled twin (:func:`ibvs_youla._jit.jit`) of the plain Python
kernels of :mod:`ibvs_youla.model.camera`, fused with the frame change that precedes it, so that
a camera frame costs one call instead of a dozen numpy calls and per-point loops:

* :func:`measure_features`: the features (Eq. (9)-(11), ERRATA 12) and the visibility flags of
  points P_C in the camera frame (reference: ``project_points`` and ``visible_points``, the same
  operations in the same order: the same floats);
* :func:`interaction_matrix`: L(P_C), the stacked point interaction matrices (reference:
  ``points_interaction_matrix``, the same floats), and :func:`image_jacobian`: P_C, then
  L(P_C) J_C, the 9x6 image Jacobian of Eq. (51) (reference: ``points_interaction_matrix(...)
  .dot(J_C)``, summed in another order than BLAS);
* :func:`triangulate`: the inverse stereo map of Eq. (C6)-(C8) (reference:
  ``triangulate_points``).

They take the camera as the arrays of :func:`camera_parameters` and do not validate their
input. Where the reference raises (a depth or disparity near zero) they return the index of
the first offending point instead (-1 when there is none), and the caller calls the reference
to raise its error. ``tests/test_compiled_kernels.py`` pins them to the references.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._jit import jit
from .camera import MAX_ABS_DEPTH, MIN_ABS_DEPTH, StereoCamera

__all__ = [
    "camera_parameters",
    "image_jacobian",
    "interaction_matrix",
    "measure_features",
    "points_in_camera",
    "triangulate",
]

# Layout of the parameter vector of camera_parameters
_F, _PITCH, _SKEW, _U0, _V0, _U_MAX, _V_MAX, _Z_MIN, _Z_MAX, _BOUNDED, _BASELINE, _D_MIN = range(12)


def camera_parameters(camera: Any) -> tuple[np.ndarray, np.ndarray]:
    """(parameters (12,), lens x-offsets (k,) [m]) of a StereoCamera (k = 2) or PinholeCamera (k = 1).

    parameters = [F, pixel pitch, skew, u0, v0, width / pitch, height / pitch, depth min, depth
    max, 1 if the view is bounded else 0, baseline b (0 for a pinhole camera), F b /
    MAX_ABS_DEPTH (the smallest disparity triangulated)], lengths in metres, u0, v0 in pixels.
    """
    pitch = camera.pixel_pitch
    stereo = isinstance(camera, StereoCamera)
    b = camera.baseline if stereo else 0.0
    lens_x = np.array([0.5 * b, -0.5 * b] if stereo else [0.0])
    params = np.array(
        [
            camera.focal_length,
            pitch,
            camera.skew,
            camera.principal_point[0],
            camera.principal_point[1],
            camera.sensor_width / pitch,
            camera.sensor_height / pitch,
            camera.depth_range[0],
            camera.depth_range[1],
            0.0 if camera.unbounded_view else 1.0,
            b,
            camera.focal_length * b / MAX_ABS_DEPTH,
        ]
    )
    return params, lens_x


@jit
def points_in_camera(T_O_C: np.ndarray, markers_O: np.ndarray) -> np.ndarray:
    """P_C = R^T (P_O - t), rows (n, 3) [m] (Eq. (21)-(22))."""
    n = markers_O.shape[0]
    P = np.empty((n, 3))
    tx, ty, tz = T_O_C[0, 3], T_O_C[1, 3], T_O_C[2, 3]
    for i in range(n):
        dx, dy, dz = markers_O[i, 0] - tx, markers_O[i, 1] - ty, markers_O[i, 2] - tz
        for j in range(3):
            P[i, j] = dx * T_O_C[0, j] + dy * T_O_C[1, j] + dz * T_O_C[2, j]
    return P


@jit
def _bad_depth(Z: float, allow_behind: bool) -> bool:
    return (abs(Z) if allow_behind else Z) < MIN_ABS_DEPTH


@jit
def measure_features(
    P: np.ndarray, params: np.ndarray, lens_x: np.ndarray, allow_behind: bool
) -> tuple[np.ndarray, np.ndarray, int]:
    """(features ((k + 1) n,), visible (n,), first point of bad depth or -1) of points P (n, 3) in {C}."""
    n, k = P.shape[0], lens_x.shape[0]
    F, pitch, skew = params[_F], params[_PITCH], params[_SKEW]
    u0, v0, u_max, v_max = params[_U0], params[_V0], params[_U_MAX], params[_V_MAX]
    z_min, z_max, bounded = params[_Z_MIN], params[_Z_MAX], params[_BOUNDED] != 0.0
    features = np.empty(n * (k + 1))
    visible = np.empty(n, dtype=np.bool_)
    for i in range(n):
        X, Y, Z = P[i, 0], P[i, 1], P[i, 2]
        if _bad_depth(Z, allow_behind):
            return features, visible, i
        Fiz = F / Z
        for j in range(k):
            features[i * (k + 1) + j] = (X - lens_x[j]) * Fiz
        features[i * (k + 1) + k] = Y * Fiz
        in_view = Z >= MIN_ABS_DEPTH  # the visibility rule of camera._view_flags
        if in_view and bounded:
            v = Y * Fiz
            in_view = 0 <= v / pitch + v0 <= v_max
            for j in range(k):
                in_view = in_view and 0 <= (X - lens_x[j]) * Fiz / pitch + skew * v / F + u0 <= u_max
        visible[i] = in_view and z_min <= Z <= z_max
    return features, visible, -1


@jit
def image_jacobian(
    T_O_C: np.ndarray,
    J_C: np.ndarray,
    markers_O: np.ndarray,
    params: np.ndarray,
    lens_x: np.ndarray,
    allow_behind: bool,
) -> tuple[np.ndarray, int]:
    """(L(P_C) J_C ((k + 1) n, 6), first point of bad depth or -1) at camera pose T_O_C (Eq. (51))."""
    L, bad = interaction_matrix(points_in_camera(T_O_C, markers_O), params, lens_x, allow_behind)
    J = np.empty((L.shape[0], J_C.shape[1]))
    if bad >= 0:
        return J, bad
    for a in range(L.shape[0]):
        for b in range(J_C.shape[1]):
            s = 0.0
            for c in range(6):
                s += L[a, c] * J_C[c, b]
            J[a, b] = s
    return J, -1


@jit
def interaction_matrix(
    P: np.ndarray, params: np.ndarray, lens_x: np.ndarray, allow_behind: bool
) -> tuple[np.ndarray, int]:
    """(L(P_C) ((k + 1) n, 6), first point of bad depth or -1) of points P (n, 3) in {C}.

    ``points_interaction_matrix`` in one call: the same operations in the same order.
    """
    n, k = P.shape[0], lens_x.shape[0]
    F = params[_F]
    L = np.zeros((n * (k + 1), 6))
    for i in range(n):
        X, Y, Z = P[i, 0], P[i, 1], P[i, 2]
        if _bad_depth(Z, allow_behind):
            return L, i
        iz = 1.0 / Z
        Fiz = F * iz
        r = i * (k + 1)
        for j in range(k):  # one u row per lens, then the shared v row (camera.points_interaction_matrix)
            u = (X - lens_x[j]) * Fiz
            L[r + j, 0] = -Fiz
            L[r + j, 2] = u * iz
            L[r + j, 3] = u * Y * iz
            L[r + j, 4] = -F - u * X * iz
            L[r + j, 5] = Fiz * Y
        v = Y * Fiz
        L[r + k, 1] = -Fiz
        L[r + k, 2] = v * iz
        L[r + k, 3] = F + v * Y * iz
        L[r + k, 4] = -v * X * iz
        L[r + k, 5] = -Fiz * X
    return L, -1


@jit
def triangulate(features: np.ndarray, params: np.ndarray, allow_behind: bool) -> tuple[np.ndarray, int]:
    """(points (n, 3) [m], first point of bad disparity or -1) from stereo features (3n,) (Eq. (C6)-(C8))."""
    n = features.shape[0] // 3
    F, b, d_min = params[_F], params[_BASELINE], params[_D_MIN]
    P = np.empty((n, 3))
    for i in range(n):
        u_l, u_r, v = features[3 * i], features[3 * i + 1], features[3 * i + 2]
        d = u_r - u_l  # disparity [m]
        if (abs(d) if allow_behind else d) < d_min:
            return P, i
        s = b / d
        P[i, 0] = 0.5 * s * (u_l + u_r)
        P[i, 1] = s * v
        P[i, 2] = F * s
    return P, -1
