"""Stereo P3P: rigid transform between point sets (Appendix C, Eq. C10-C17) and the marker frame {M}.

Sec. 3 shows that three non-collinear points triangulated by a stereo camera fix its pose. The pose
follows from the SVD (Kabsch/Umeyama) solution of Appendix C; this module re-derives it because the
printed form writes H = U S V (meaning V^T) and omits the reflection case, which matters here: with
exactly three points H has rank 2, so the sign of the third singular direction is arbitrary and
R = V U^T is a reflection half of the time unless det-corrected.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .._geometry import make_pose
from .._linalg import det3_sign, svd
from .._validation import as_array, flag, instance
from ..exceptions import DegenerateMarkersError, InvalidArrayError
from ..model.camera import StereoCamera, triangulate_points

__all__ = [
    "COINCIDENT_TOL",
    "COLLINEAR_TOL",
    "check_marker_geometry",
    "estimate_pose",
    "marker_coordinates",
    "marker_frame",
    "rigid_transform_from_points",
]

COINCIDENT_TOL = 1e-12  # points coincide when their spread s1 <= this * max(|P_i|, 1 m)
COLLINEAR_TOL = 1e-6  # points are collinear when s2 <= this * s1 (s: singular values of the centred set)
_FLIP_Z = np.array([1.0, 1.0, -1.0])
_EYE4 = np.eye(4)


def check_marker_geometry(P: object, name: str = "P", weights: np.ndarray | None = None) -> np.ndarray:
    """Validate points (n, 3), n >= 3, that must fix a pose: finite, not coincident, not collinear.

    The test is relative and scale-aware. With s1 >= s2 the two largest singular values of the
    (weighted) centred points [m], the set is coincident when s1 <= COINCIDENT_TOL * max(|P_i|, 1 m)
    and collinear when s2 <= COLLINEAR_TOL * s1 (the triangle's height is below 1e-6 of its size).

    Returns:
        The points as a float array (n, 3).

    Raises:
        InvalidArrayError: wrong shape, fewer than 3 points, or non-finite entries.
        DegenerateMarkersError: coincident or collinear points.
    """
    P = as_array(P, name, (None, 3))
    if P.shape[0] < 3:
        raise InvalidArrayError(name, f"{P.shape[0]} points", "at least 3 non-collinear points (Sec. 3, P3P)")
    w = np.full(P.shape[0], 1.0 / P.shape[0]) if weights is None else weights / weights.sum()
    Q = (P - w @ P) * np.sqrt(w)[:, None]
    s = np.linalg.svd(Q, compute_uv=False)
    scale = max(float(np.abs(P).max()), 1.0)
    if s[0] <= COINCIDENT_TOL * scale:
        raise DegenerateMarkersError(
            P,
            f"{name}: the points coincide (spread {s[0]:.3g} m); valid marker sets span a triangle "
            f"(spread > {COINCIDENT_TOL:g} x {scale:.3g} m)",
        )
    if s[1] <= COLLINEAR_TOL * s[0]:
        raise DegenerateMarkersError(
            P,
            f"{name}: the points are collinear (in-plane spread ratio s2/s1 = {s[1] / s[0]:.3g}); "
            f"valid marker sets have s2/s1 > {COLLINEAR_TOL:g}",
        )
    return P


def kabsch(P_from: np.ndarray, P_to: np.ndarray, w: np.ndarray | None = None) -> np.ndarray:
    """T_to_from (4, 4) with P_to ≈ R P_from + t: Eq. (C10)-(C17), see `rigid_transform_from_points`.

    Does not validate its input: ``P_from`` and ``P_to`` must be finite float (n, 3) arrays that
    fix a pose (`check_marker_geometry`), ``w`` None or non-negative weights (n,) summing to 1.
    """
    if w is None:
        n = P_from.shape[0]
        c_to = np.add.reduce(P_to, axis=0) / n  # Eq. (C11), the mean
        return kabsch_centred(P_from, P_to - c_to, c_to)
    c_from, c_to = w @ P_from, w @ P_to
    H = (P_from - c_from).T @ ((P_to - c_to) * w[:, None])
    return _fit(H, c_from, c_to)


def kabsch_centred(P_from: np.ndarray, Q_to: np.ndarray, c_to: np.ndarray) -> np.ndarray:
    """`kabsch` (unweighted) with the target points given centred, Q_to = P_to - c_to (fixed markers).

    Does not validate its input: as `kabsch`, with ``c_to`` (3,) the mean of the target points.
    """
    n = P_from.shape[0]
    c_from = _ones(n).dot(P_from) / n  # Eq. (C10), the mean (a product: cheaper than a reduction)
    H = (P_from - c_from).T.dot(Q_to)  # Eq. (C12)-(C14): sum_i P'_from,i P'_to,i^T
    return _fit(H, c_from, c_to)


@lru_cache(maxsize=8)
def _ones(n: int) -> np.ndarray:
    """A read-only vector of n ones (memoized)."""
    ones = np.ones(n)
    ones.setflags(write=False)
    return ones


def _fit(H: np.ndarray, c_from: np.ndarray, c_to: np.ndarray) -> np.ndarray:
    """Eq. (C15)-(C17) from the cross-covariance H and the centroids."""
    U, _, Vt = svd(H)  # Eq. (C15): H = U S V^T
    V = Vt.T
    if det3_sign(Vt.tolist(), U.tolist()) < 0.0:  # reflection fix (det V U^T = -1): det R = +1
        V = V * _FLIP_Z
    R = V.dot(U.T)  # Eq. (C16) with the det correction, V diag(1, 1, det(V U^T)) U^T
    T = _EYE4.copy()
    T[:3, :3] = R
    T[:3, 3] = c_to - R.dot(c_from)  # Eq. (C17)
    return T


def rigid_transform_from_points(P_from: object, P_to: object, weights: object = None) -> np.ndarray:
    """Least-squares rigid transform T (4x4) with P_to ≈ R P_from + t (Appendix C, Eq. C10-C17).

    Minimises sum_i w_i |R P_from,i + t - P_to,i|^2 over SE(3): centroids (C10-C13), cross-covariance
    H = sum_i w_i P'_from,i P'_to,i^T (C14), H = U S V^T (C15), R = V diag(1, 1, det(V U^T)) U^T
    (C16, Umeyama's reflection correction), t = c_to - R c_from (C17). With P_from = P_M and P_to = P_C
    the result is T_C_M; with P_from = P_C and P_to = P_O it is T_O_C (stereo P3P).

    Args:
        P_from: Points (n, 3), n >= 3, in the source frame [m].
        P_to: The same points (n, 3) in the target frame [m].
        weights: Optional non-negative weights (n,), not all zero.

    Returns:
        The 4x4 homogeneous transform T_to_from.

    Raises:
        InvalidArrayError: shapes differ, n < 3, non-finite entries, bad weights.
        DegenerateMarkersError: coincident or collinear points (see `check_marker_geometry`).
    """
    P_from = as_array(P_from, "P_from", (None, 3))
    P_to = as_array(P_to, "P_to", (None, 3))
    if P_to.shape != P_from.shape:
        raise InvalidArrayError("P_to", f"shape {P_to.shape}", f"the shape of P_from, {P_from.shape}")
    w = None
    if weights is not None:
        w = as_array(weights, "weights", (P_from.shape[0],))
        if (w < 0).any() or w.sum() <= 0:
            raise InvalidArrayError("weights", f"{w.tolist()}", "non-negative weights, not all zero")
    check_marker_geometry(P_from, "P_from", w)
    check_marker_geometry(P_to, "P_to", w)
    return kabsch(P_from, P_to, None if w is None else w / w.sum())


def marker_frame(P: object, toward: object = None) -> np.ndarray:
    """Pose T_A_M (4x4) of the Appendix C marker frame {M} from three marker positions in a frame A.

    Origin at marker 1, x towards marker 2, z = (P2 - P1) x (P3 - P1) normalised (the plane normal of
    Eq. 1), y = z x x. Appendix C turns z to face the camera: give `toward` (a point in A, e.g. the
    camera origin [0, 0, 0] when A = C) to flip z (and y) when it points away from that point.

    Args:
        P: Marker positions (3, 3) [m], rows markers 1, 2, 3, in frame A.
        toward: Optional point (3,) [m] in A that z must face.

    Raises:
        DegenerateMarkersError: coincident or collinear markers.
    """
    P = check_marker_geometry(P, "P")
    if P.shape[0] != 3:
        raise InvalidArrayError("P", f"{P.shape[0]} markers", "exactly 3 markers (3, 3)")
    x = P[1] - P[0]
    x /= np.linalg.norm(x)
    z = np.cross(x, P[2] - P[0])
    z /= np.linalg.norm(z)
    if toward is not None and z @ (as_array(toward, "toward", (3,)) - P[0]) < 0:
        z = -z
    return make_pose(np.column_stack((x, np.cross(z, x), z)), P[0])


def marker_coordinates(P: object, toward: object = None) -> np.ndarray:
    """Marker positions P_M (3, 3) in their own frame {M} (see `marker_frame`); rows [x, y, 0]."""
    T_A_M = marker_frame(P, toward)
    P_M = (np.asarray(P, dtype=float) - T_A_M[:3, 3]) @ T_A_M[:3, :3]
    P_M[:, 2] = 0.0  # exactly planar by construction (removes round-off)
    return P_M


def estimate_pose(
    camera: StereoCamera, features: np.ndarray, P_ref: np.ndarray, allow_behind: bool = False
) -> np.ndarray:
    """Stereo P3P (Sec. 3, Appendix C): T_ref_C (4x4) from features (n, 3) of points known in a frame ref.

    Triangulates the features (Eq. C6-C8) and fits P_ref ≈ T_ref_C P_C (Eq. C10-C17).

    Args:
        camera: The stereo camera.
        features: Features (n, 3), rows ``[u_l, u_r, v]`` [m on the sensor], or flat (3n,).
        P_ref: The same points (n, 3), n >= 3, in the frame ref [m]; not coincident or collinear.
        allow_behind: Accept points behind the camera (negative disparity, ERRATA 13).

    Raises:
        InvalidParameterError: ``camera`` is not a StereoCamera (a monocular camera's pose needs
            four points and PnP: ``estimate_camera_pose``), or ``allow_behind`` not True or False.
        InvalidArrayError: non-finite or mis-shaped ``features`` or ``P_ref``, or their lengths differ.
        DegenerateMarkersError: ``P_ref`` is coincident or collinear.
        InvalidDisparityError: a disparity is ~0, or negative without ``allow_behind``.
    """
    instance(camera, "camera", StereoCamera, "a StereoCamera (stereo P3P; a PinholeCamera needs PnP)")
    allow_behind = flag(allow_behind, "allow_behind")
    P_ref = check_marker_geometry(P_ref, "P_ref")
    n = P_ref.shape[0]
    p = as_array(features, "features")
    if p.shape not in ((n, 3), (3 * n,)):
        raise InvalidArrayError(
            "features",
            f"an array of shape {p.shape}",
            f"shape ({n}, 3) or ({3 * n},): [u_l, u_r, v] for each of the {n} points of P_ref",
        )
    P_C = triangulate_points(camera, p.reshape(n, 3), allow_behind)
    return kabsch(P_C, P_ref)
