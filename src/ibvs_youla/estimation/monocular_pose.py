"""Monocular pose from four or more known points (PnP), through OpenCV's ``solvePnP``.

A monocular camera sees [u, v] = F (X, Y) / Z per point [m on the sensor] (normalized
coordinates x = u / F, y = v / F). Three points leave up to four poses (Sec. 3 of the paper);
four or more fix it. The paper cites EPnP and SQPnP for this problem; both are in OpenCV, and
this module calls them on the normalized coordinates (camera matrix I, no distortion), so
the pixel grid plays no part. The default is SQPnP (Terzakis & Lourakis, 2020): a globally
optimal solver for any n >= 3 points, planar or not. EPnP is not reliable on four (nearly)
coplanar points: on 50 seeded views of a 20 cm square it is off by more than 1 m or 1 rad on
5 (``tests/test_monocular_pose.py``); IPPE is exact for planar points only.

:func:`estimate_camera_pose` gives either camera's pose from its own features: stereo P3P
(Appendix C) for a :class:`~ibvs_youla.model.camera.StereoCamera`, PnP for a
:class:`~ibvs_youla.model.camera.PinholeCamera`. :class:`CameraPoseEstimator` is the same
function for one camera and one set of points, checked once: the controllers call it at every
frame with the sensor's features (it checks only their shape), and get the same poses. Given a
frame's measured depths too (a depth sensor, an RGB-D camera), it fits the points back-projected
at them to the known points (Kabsch, as stereo P3P does with triangulated points): no PnP.

Every controller that estimates a monocular pose takes the method as its ``pnp`` option
(``iy.controllers.make("pbvs", pnp="ippe")``; default ``"sqpnp"``), which :func:`pnp_options`
turns into the estimator's options. IPPE (Collins & Bartoli, "Infinitesimal plane-based pose
estimation", IJCV 109(3), 2014) solves the planar case in closed form: exact on noise-free
coplanar points, and cheaper per call than SQPnP (a closed form, where SQPnP runs its SQP from
several starts; ``docs/benchmarks.md`` times SQPnP in the monocular loop). On markers off one
plane OpenCV's IPPE returns a pose biased in proportion to the off-plane extent (measured with
OpenCV 5.1: 7e-8 m for 1e-6 of it, 6e-5 m for 1e-3) and finds none from about 1e-2, so
:class:`CameraPoseEstimator` refuses it at construction for markers off one plane by more than
rounding (relative out-of-plane extent above :data:`IPPE_COPLANAR_TOLERANCE`): where IPPE is
accepted its pose is exact for the points given; markers measured off one plane take SQPnP.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._validation import as_array, instance, one_of
from ..exceptions import InvalidArrayError, InvalidParameterError, PoseEstimationError
from ..model.camera import PinholeCamera, StereoCamera, points_at_depths, triangulate_points
from .pnp_kernels import pnp_depths
from .stereo_pose import check_marker_geometry, estimate_pose, kabsch_centred

__all__ = [
    "IPPE_COPLANAR_TOLERANCE",
    "IPPE_FALLBACK",
    "PNP_METHODS",
    "CameraPoseEstimator",
    "estimate_camera_pose",
    "estimate_pose_monocular",
    "marker_depths_monocular",
    "pnp_options",
]

_PNP_FLAGS = {
    "sqpnp": "SOLVEPNP_SQPNP",
    "epnp": "SOLVEPNP_EPNP",
    "iterative": "SOLVEPNP_ITERATIVE",
    "ippe": "SOLVEPNP_IPPE",
}

PNP_METHODS = ("sqpnp", "epnp", "iterative", "ippe")  # OpenCV's SOLVEPNP_* flags, by name
# IPPE is exact for coplanar points: smallest / largest singular value of the centred points at most
# this (points on one plane to rounding, ~1e-16 relative, with margin; the moment law's
# COPLANAR_TOLERANCE is the same 1e-9). Beyond it IPPE's pose is biased (module docstring).
IPPE_COPLANAR_TOLERANCE = 1e-9
# OpenCV's IPPE can return a NaN pose (with success) for a view within rounding of fronto-parallel,
# where its two solutions coincide: measured at the converged target of ViSP's tutorial case (R_C_ref
# = I, features 1e-8 off the target's), after 841 frames of exact features. Such a view is where a
# servo run ends, so a CameraPoseEstimator (whose markers were found coplanar) solves that image by
# SQPnP instead (exact on noise-free points as IPPE is; tests/test_monocular_pose.py pins the view).
# estimate_pose_monocular(method="ippe"), one named solver, raises its PoseEstimationError.
IPPE_FALLBACK = "sqpnp"


def pnp_options(camera: StereoCamera | PinholeCamera, pnp: str) -> dict[str, Any]:
    """The :class:`CameraPoseEstimator` options of a controller's ``pnp`` choice for its camera.

    Monocular: ``{"method": pnp}``. Stereo: ``{}`` for the default ``"sqpnp"`` (a stereo camera
    estimates its pose by P3P on triangulated points, no PnP); another value would not act, so it
    is refused. Unvalidated ``pnp`` beyond that: the controller checked it against
    :data:`PNP_METHODS` at construction.

    Raises:
        InvalidParameterError: ``pnp`` other than ``"sqpnp"`` with a ``StereoCamera``.
    """
    if isinstance(camera, StereoCamera):
        if pnp != "sqpnp":
            raise InvalidParameterError(
                "pnp",
                pnp,
                "'sqpnp' (the default) with a StereoCamera: it estimates its pose by stereo P3P; the "
                "PnP method applies to a monocular PinholeCamera",
            )
        return {}
    return {"method": pnp}


def estimate_pose_monocular(
    camera: PinholeCamera, features: Any, P_ref: Any, method: str = "sqpnp"
) -> np.ndarray:
    """T_ref_C (4, 4): the pose of a monocular camera from features of points known in a frame ref.

    Args:
        camera: The pinhole camera (its focal length turns features into normalized coordinates).
        features: [u, v] per point (n, 2) or flat (2n,) [m on the sensor].
        P_ref: The points (n, 3), n >= 4, in the frame ref [m]; not coincident or collinear.
        method: ``"sqpnp"`` (default), ``"epnp"``, ``"iterative"`` (Levenberg-Marquardt from
            an initial DLT/homography) or ``"ippe"`` (planar points only).

    Raises:
        InvalidParameterError: ``camera`` is not a PinholeCamera, or an unknown ``method``.
        InvalidArrayError: mis-shaped or non-finite input, or fewer than four points.
        DegenerateMarkersError: coincident or collinear points.
        PoseEstimationError: OpenCV found no pose (e.g. ``"ippe"`` on non-planar points).
    """
    return _pose(*_checked_pnp(camera, features, P_ref, method)[1:])


def marker_depths_monocular(
    camera: PinholeCamera, features: Any, P_ref: Any, method: str = "sqpnp"
) -> np.ndarray:
    """Z_C (n,) [m]: the depth of each point P_ref in the camera pose the features give.

    Z_i = r_3 . P_i + t_z from OpenCV's PnP, [R_C_ref | t_C], as
    :meth:`CameraPoseEstimator.marker_depths` (the same floats), with the arguments and errors of
    :func:`estimate_pose_monocular`.
    """
    P, R_C_ref, t_C = _checked_pnp(camera, features, P_ref, method)
    return P @ R_C_ref[2] + t_C[2]  # type: ignore[no-any-return]


def _checked_pnp(
    camera: PinholeCamera, features: Any, P_ref: Any, method: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(P_ref contiguous (n, 3), R_C_ref, t_C): :func:`estimate_pose_monocular`'s checks, then the PnP."""
    import cv2

    instance(camera, "camera", PinholeCamera, "a PinholeCamera (a StereoCamera: estimate_pose, stereo P3P)")
    one_of(method, "method", PNP_METHODS)
    P_ref = check_marker_geometry(P_ref, "P_ref")
    n = P_ref.shape[0]
    if n < 4:
        raise InvalidArrayError("P_ref", f"{n} points", "four or more points: three leave up to four poses")
    p = as_array(features, "features")
    if p.shape not in ((n, 2), (2 * n,)):
        raise InvalidArrayError(
            "features", f"an array of shape {p.shape}", f"shape ({n}, 2) or ({2 * n},): [u, v] for each point"
        )
    normalized = np.ascontiguousarray(p.reshape(n, 2) / camera.focal_length)
    P = np.ascontiguousarray(P_ref)
    return (P, *_solve_pnp_C(P, normalized, method, getattr(cv2, _PNP_FLAGS[method]), _EYE3))


_EYE3 = np.eye(3)
_EYE3.setflags(write=False)


def _solve_pnp_C(
    P_ref: np.ndarray, normalized: np.ndarray, method: str, flag: int, K: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(R_C_ref (3, 3), t_C (3,)): the points' frame in the camera's, as OpenCV's solvePnP gives it."""
    solution = _pnp_or_none(P_ref, normalized, method, flag, K)
    if solution is None:
        raise PoseEstimationError(method, f"OpenCV solvePnP ({method}) found no pose for {len(P_ref)} points")
    return solution


def _pnp_or_none(
    P_ref: np.ndarray, normalized: np.ndarray, method: str, flag: int, K: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """:func:`_solve_pnp_C`, None where OpenCV reports no pose or a non-finite one (raises on its errors)."""
    import cv2

    try:
        ok, rvec, tvec = cv2.solvePnP(P_ref, normalized, K, None, flags=flag)
    except cv2.error as exc:
        raise PoseEstimationError(method, f"OpenCV solvePnP ({method}) failed: {exc}") from None
    finite = math.isfinite(rvec.sum() + tvec.sum()) or (np.isfinite(rvec).all() and np.isfinite(tvec).all())
    if not ok or not finite:
        return None
    return cv2.Rodrigues(rvec)[0], tvec.ravel()


def _pose(R_C_ref: np.ndarray, t_C: np.ndarray) -> np.ndarray:
    """T_ref_C = [R_C_ref^T, -R_C_ref^T t_C]: the camera's pose in the points' frame."""
    T = np.eye(4)
    T[:3, :3] = R_C_ref.T
    T[:3, 3] = -R_C_ref.T @ t_C
    return T


def estimate_camera_pose(
    camera: StereoCamera | PinholeCamera, features: Any, P_ref: Any, **options: Any
) -> np.ndarray:
    """T_ref_C (4, 4) from a camera's own features: stereo P3P or monocular PnP (module docstring).

    ``options`` go to :func:`~.stereo_pose.estimate_pose` (``allow_behind``) or to
    :func:`estimate_pose_monocular` (``method``).
    """
    if isinstance(camera, StereoCamera):
        return estimate_pose(camera, features, P_ref, **options)
    if isinstance(camera, PinholeCamera):
        return estimate_pose_monocular(camera, features, P_ref, **options)
    raise InvalidParameterError("camera", type(camera).__name__, "a StereoCamera or a PinholeCamera")


class CameraPoseEstimator:
    """:func:`estimate_camera_pose` for one camera and one set of points, checked once.

    ``estimator(features)`` returns ``estimate_camera_pose(camera, features, P_ref, **options)``,
    the same pose by the same computation, without re-checking the points, the camera and the
    options at every call (a controller's pose at every frame): the triangulated points fitted
    to the points' centred coordinates, computed once, or OpenCV's PnP on the normalized points.
    ``features`` must be finite (as a sensor's are); only their shape is checked. Called again
    with the same features (equal values), it returns the pose it found (a copy) without
    solving again: two laws sharing one estimator (the hybrid law) estimate once per frame.
    One difference: with ``method="ippe"`` an image OpenCV's IPPE finds no pose for (a view within
    rounding of fronto-parallel, :data:`IPPE_FALLBACK`) is solved by SQPnP where
    :func:`estimate_pose_monocular` raises; :attr:`fallbacks` counts those images.

    Args:
        camera: A ``StereoCamera`` or a ``PinholeCamera``.
        P_ref: The points (n, 3) in the frame ref [m] (n >= 3 for stereo, >= 4 monocular).
        **options: ``allow_behind`` (stereo) or ``method`` (monocular), as :func:`estimate_camera_pose`.

    Raises:
        InvalidParameterError, InvalidArrayError, DegenerateMarkersError: as :func:`estimate_camera_pose`
            for the camera, the points and the options, and ``method="ippe"`` with markers that are
            not coplanar (:data:`IPPE_COPLANAR_TOLERANCE`), once here rather than at every call;
            per call, features of another shape (InvalidArrayError), and the errors of the
            estimate itself.
    """

    def __init__(self, camera: StereoCamera | PinholeCamera, P_ref: Any, **options: Any) -> None:
        P = check_marker_geometry(P_ref, "P_ref")
        n = P.shape[0]
        self.camera = camera
        mean = np.add.reduce(P, axis=0) / n  # as stereo_pose.kabsch
        self._centred, self._mean = P - mean, mean
        if isinstance(camera, StereoCamera):
            unknown = sorted(set(options) - {"allow_behind"})
            if unknown:
                raise InvalidParameterError("options", unknown, "allow_behind (stereo P3P)")
            self._allow_behind = bool(options.get("allow_behind", False))
            self._shapes = ((n, 3), (3 * n,))
        elif isinstance(camera, PinholeCamera):
            import cv2

            unknown = sorted(set(options) - {"method"})
            if unknown:
                raise InvalidParameterError("options", unknown, "method (PnP)")
            self._method = one_of(options.get("method", "sqpnp"), "method", PNP_METHODS)
            if n < 4:
                raise InvalidArrayError(
                    "P_ref", f"{n} points", "four or more points: three leave up to four poses"
                )
            if self._method == "ippe":
                sv = np.linalg.svd(self._centred, compute_uv=False)
                if sv[-1] > IPPE_COPLANAR_TOLERANCE * sv[0]:
                    raise InvalidParameterError(
                        "method",
                        "ippe",
                        f"'sqpnp', 'epnp' or 'iterative' for these markers: IPPE needs coplanar markers "
                        f"(relative out-of-plane extent <= {IPPE_COPLANAR_TOLERANCE:g}; here "
                        f"{sv[-1] / sv[0]:.3g})",
                    )
            self._flag = getattr(cv2, _PNP_FLAGS[self._method])
            self._P = np.ascontiguousarray(P)
            self._shapes = ((n, 2), (2 * n,))
        else:
            raise InvalidParameterError("camera", type(camera).__name__, "a StereoCamera or a PinholeCamera")
        self._n = n
        self._last: tuple[bytes, np.ndarray] | None = None  # features of the last call, its pose
        self._last_pnp: tuple[bytes, tuple[np.ndarray, np.ndarray]] | None = None  # ... and its PnP
        self.fallbacks = 0  # images IPPE found no pose for, solved by SQPnP (IPPE_FALLBACK)

    def __call__(self, features: np.ndarray, depth: np.ndarray | None = None) -> np.ndarray:
        """T_ref_C (4, 4) from the camera's features (3n,) or (n, 3) stereo, (2n,) or (n, 2) monocular.

        With ``depth``, each point's measured depth Z_C (n,) [m] (a depth sensor): the points
        back-projected at those depths (``points_at_depths``), fitted to the known points
        (Kabsch), for either camera.
        """
        self._check_shape(features)
        key = features.tobytes() if depth is None else features.tobytes() + depth.tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1].copy()
        n = self._n
        if depth is not None:
            T = kabsch_centred(points_at_depths(self.camera, features, depth), self._centred, self._mean)
        elif isinstance(self.camera, StereoCamera):
            P_C = triangulate_points(self.camera, features.reshape(n, 3), self._allow_behind)
            T = kabsch_centred(P_C, self._centred, self._mean)
        else:
            T = _pose(*self._pnp(features, key))
        self._last = (key, T.copy())
        return T

    def marker_depths(self, features: np.ndarray) -> np.ndarray:
        """Z_C (n,) [m]: each known point's depth in the pose a monocular camera's features give.

        The third row of the points' pose in the camera, [R_C_ref | t_C] as OpenCV's ``solvePnP``
        returns it: Z_i = r_3 . P_i + t_z, not through T_ref_C and its inverse (the same numbers to
        rounding; the monocular laws' depths, :class:`~ibvs_youla.controllers.image_points.CurrentPoints`).
        The PnP of these features is solved once for this and :meth:`__call__` (the hybrid law asks
        both).

        Raises:
            InvalidParameterError: the camera is a StereoCamera (its depths are triangulated).
            InvalidArrayError, PoseEstimationError: as :meth:`__call__`.
        """
        if not isinstance(self.camera, PinholeCamera):
            raise InvalidParameterError(
                "camera",
                type(self.camera).__name__,
                "a PinholeCamera (a stereo camera triangulates its depths)",
            )
        self._check_shape(features)
        R_C_ref, t_C = self._pnp(features, features.tobytes())
        return self._P @ R_C_ref[2] + t_C[2]  # type: ignore[no-any-return]

    def restart(self) -> None:
        """Forget the last images' poses and the fallback count: a run made again from its first frame.

        The compiled frame path calls the controller's estimator; where it declines and the plug-in
        loop makes the run again, the count (and ``metadata["pnp_fallbacks"]``) is the second run's.
        """
        self._last = None
        self._last_pnp = None
        self.fallbacks = 0

    def write_marker_depths(self, features: np.ndarray, out: np.ndarray) -> None:
        """:meth:`marker_depths` into ``out`` (n,), for features this estimator's shape (not checked).

        The compiled frame path's call: OpenCV's PnP, then the depths from its (rvec, tvec) in one
        compiled call (:func:`~.pnp_kernels.pnp_depths`, the arithmetic of :meth:`marker_depths` to
        rounding). An image OpenCV finds no pose for, or raises on, takes :meth:`marker_depths`,
        which gives its fallback (:data:`IPPE_FALLBACK`) or its error. The pose is not kept for a
        later call with the same features (and the last one kept is forgotten: a later image's
        fallback must not find an older image's PnP).

        Raises:
            InvalidParameterError: the camera is a StereoCamera.
            InvalidArrayError: features of another shape than this camera's, ``out`` not (n,).
            PoseEstimationError: as :meth:`marker_depths`.
        """
        import cv2

        if not isinstance(self.camera, PinholeCamera):
            self.marker_depths(features)  # its InvalidParameterError: a stereo camera triangulates
        self._check_shape(features)
        if getattr(out, "shape", None) != (self._n,):
            raise InvalidArrayError("out", f"an array of shape {np.shape(out)}", f"shape ({self._n},)")
        normalized = features.reshape(self._n, 2) / self.camera.focal_length
        try:
            ok, rvec, tvec = cv2.solvePnP(self._P, normalized, _EYE3, None, flags=self._flag)
        except cv2.error:
            ok = False
        if ok and rvec.shape == tvec.shape == (3, 1) and pnp_depths(rvec, tvec, self._P, out):
            self._last_pnp = None  # not these features' PnP: the cache must not answer for an older image
            return
        out[:] = self.marker_depths(features)

    def _check_shape(self, features: np.ndarray) -> None:
        """InvalidArrayError unless the features have the shape of this camera's for the points."""
        if getattr(features, "shape", None) not in self._shapes:
            raise InvalidArrayError(
                "features",
                f"an array of shape {np.shape(features)}",
                f"shape {self._shapes[0]} or {self._shapes[1]} for {self._n} points",
            )

    def _pnp(self, features: np.ndarray, key: bytes) -> tuple[np.ndarray, np.ndarray]:
        """(R_C_ref, t_C) of OpenCV's PnP on the features, solved again only for other features.

        An image IPPE finds no pose for is solved by SQPnP (:data:`IPPE_FALLBACK`), counted in
        :attr:`fallbacks`.
        """
        if self._last_pnp is not None and self._last_pnp[0] == key:
            return self._last_pnp[1]
        normalized = np.ascontiguousarray(features.reshape(self._n, 2) / self.camera.focal_length)
        if self._method != "ippe":
            solution = _solve_pnp_C(self._P, normalized, self._method, self._flag, _EYE3)
        else:
            found = _pnp_or_none(self._P, normalized, "ippe", self._flag, _EYE3)
            if found is None:  # IPPE_FALLBACK's view
                import cv2

                flag = getattr(cv2, _PNP_FLAGS[IPPE_FALLBACK])
                found = _pnp_or_none(self._P, normalized, IPPE_FALLBACK, flag, _EYE3)
                if found is None:
                    raise PoseEstimationError(
                        "ippe",
                        f"OpenCV solvePnP (ippe) found no pose for {self._n} points, nor did its "
                        f"fallback ({IPPE_FALLBACK})",
                    )
                self.fallbacks += 1
            solution = found
        self._last_pnp = (key, solution)
        return solution
