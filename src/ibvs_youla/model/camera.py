"""Stereo and pinhole camera models: projection, triangulation, interaction matrices, visibility.

Implements Sec. 4.1 (Eq. 5-11) and the inverse stereo map of Appendix C (Eq. C6-C8). Image
coordinates are metres on the sensor, measured from the principal point (the paper's k = 0,
u0 = v0 = 0 form of Eq. 9-10); pixels enter only through the intrinsic matrix of Eq. (6)
(`to_pixels` / `from_pixels`). Pixel coordinates run from the top-left sensor corner: pixel i
covers [i, i + 1). The stereo frame {C} sits mid-baseline with the left lens at x = +b/2
(ERRATA 12): u_l = F (X - b/2) / Z, u_r = F (X + b/2) / Z, v = F Y / Z, disparity F b / Z.

Each equation is one kernel function, called by the camera's methods (which validate their
arguments) and by the estimation and simulation modules (whose arrays are valid by
construction): :func:`project_points`, :func:`points_interaction_matrix`,
:func:`triangulate_points`, :func:`visible_points`. The kernels do not validate their
inputs; they still raise on a depth or disparity near zero, where the equation has no value.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .._validation import as_array, flag, integer, is_pair, non_negative, one_of, positive, real, text
from ..exceptions import InvalidDisparityError, InvalidParameterError, PointBehindCameraError

__all__ = [
    "MIN_RESOLUTION_PX",
    "PinholeCamera",
    "StereoCamera",
    "Visibility",
    "check_camera_has_pixels",
    "default_camera",
    "pixel_centres_normalized",
]

MIN_ABS_DEPTH = 1e-9  # [m] no projection for |Z_C| below this (division by ~0), even for virtual points
MAX_ABS_DEPTH = 1e9  # [m] a disparity whose depth |F b / d| would exceed this counts as zero
MIN_RESOLUTION_PX = 8  # a camera renders images only with at least this many pixels a side

# ZED resolution modes (ZED SDK names): (width [px], height [px], frame rates [Hz]); ERRATA 15.
ZED_MODES: dict[str, tuple[int, int, tuple[int, ...]]] = {
    "HD2K": (2208, 1242, (15,)),
    "HD1080": (1920, 1080, (15, 30)),
    "HD720": (1280, 720, (15, 30, 60)),
    "VGA": (672, 376, (15, 30, 60, 100)),
}
# Real ZED 2 pixel pitch per mode [m]: 2 um native, 2x2 binned at 720p, 4x4 at VGA (ERRATA 15).
_ZED2_PITCH = {"HD2K": 2e-6, "HD1080": 2e-6, "HD720": 4e-6, "VGA": 8e-6}


def _zed_intrinsics(preset: str, mode: str, frame_rate: float | None) -> dict:
    """Keyword arguments of the ZED presets (see `StereoCamera.zed2`)."""
    one_of(preset, "preset", ("paper", "zed2"))
    one_of(mode, "mode", tuple(ZED_MODES))
    width_px, height_px, rates = ZED_MODES[mode]
    if frame_rate is None:
        frame_rate = float(max(rates))
    else:
        valid = f"one of {rates} fps in mode {mode!r}"
        try:
            rate = real(frame_rate, "frame_rate")
        except InvalidParameterError:
            raise InvalidParameterError("frame_rate", frame_rate, valid) from None
        if rate not in rates:
            raise InvalidParameterError("frame_rate", frame_rate, valid)
        frame_rate = rate
    if preset == "paper":  # Table A3: the sensor extent is fixed, the mode sets the pixel count
        pitch = 5.23e-3 / width_px
        return dict(
            focal_length=2.8e-3,
            sensor_width=5.23e-3,
            sensor_height=2.94e-3,
            pixel_pitch=pitch,
            depth_range=(0.5, 25.0),
            frame_rate=float(frame_rate),
            name=f"paper-{mode}",
        )
    pitch = _ZED2_PITCH[mode]  # the mode's active area is its pixel count times its pitch
    return dict(
        focal_length=2.12e-3,
        sensor_width=width_px * pitch,
        sensor_height=height_px * pitch,
        pixel_pitch=pitch,
        depth_range=(0.3, 20.0),
        frame_rate=float(frame_rate),
        name=f"zed2-{mode}",
    )


def _check_depth(Z: np.ndarray, allow_behind: bool) -> None:
    """Raise PointBehindCameraError for Z <= 0 (unless allow_behind) and always for |Z| < MIN_ABS_DEPTH."""
    if (np.abs(Z).min() if allow_behind else Z.min()) >= MIN_ABS_DEPTH:
        return
    bad = np.flatnonzero(np.abs(Z) < MIN_ABS_DEPTH if allow_behind else Z < MIN_ABS_DEPTH)
    valid = (
        f"|Z_C| >= {MIN_ABS_DEPTH:g} m"
        if allow_behind
        else (
            f"Z_C >= {MIN_ABS_DEPTH:g} m (in front of the camera); pass allow_behind=True for the "
            "paper's virtual points (ERRATA 13)"
        )
    )
    raise PointBehindCameraError(
        bad, Z[bad], f"points {bad.tolist()} have depth Z_C = {Z[bad].tolist()} m; valid depths are {valid}"
    )


def _raise_disparity(d: np.ndarray, d_min: float, allow_behind: bool) -> None:
    """Raise InvalidDisparityError naming the points whose disparity d [m] is below d_min (or |d|)."""
    bad = np.flatnonzero(np.abs(d) < d_min if allow_behind else d < d_min)
    valid = f"{'|u_r - u_l|' if allow_behind else 'u_r - u_l'} >= {d_min:.3g} m"
    raise InvalidDisparityError(
        bad, d[bad], f"points {bad.tolist()} have disparity u_r - u_l = {d[bad].tolist()} m; valid: {valid}"
    )


def _points(P: object, name: str, width: int = 3) -> np.ndarray:
    """Validate an (n, width) array (a single (width,) row is promoted to (1, width))."""
    arr = as_array(P, name)
    if arr.shape == (width,):
        arr = arr[None, :]
    return as_array(arr, name, (None, width), finite=False)  # finiteness checked above


@dataclass(frozen=True, eq=False)
class Visibility:
    """Per-point visibility flags (ERRATA 13: report depth sign, field of view and depth range).

    Attributes:
        in_front: Z_C > 0 (n,).
        in_fov: in front and inside the sensor extent of every lens (n,).
        in_depth_range: depth_range[0] <= Z_C <= depth_range[1] (n,).
        depth: Z_C of each point (n,) [m].
    """

    in_front: np.ndarray
    in_fov: np.ndarray
    in_depth_range: np.ndarray
    depth: np.ndarray

    @property
    def visible(self) -> np.ndarray:
        """Per point: in front, in view and within the depth range (n,)."""
        return self.in_front & self.in_fov & self.in_depth_range

    @property
    def all_visible(self) -> bool:
        """True when every point is visible."""
        return bool(self.visible.all())

    def describe(self) -> str:
        """One line per point, e.g. for a run report."""
        return "\n".join(
            f"point {i}: Z_C = {z:+.3f} m, in front {f}, in FOV {v}, in depth range {d}"
            for i, (z, f, v, d) in enumerate(
                zip(self.depth, self.in_front, self.in_fov, self.in_depth_range, strict=True)
            )
        )


@dataclass(frozen=True, kw_only=True)
class _Sensor:
    """Intrinsics shared by one lens of either camera (Eq. 6), all keyword-only."""

    focal_length: float  # F [m]
    sensor_width: float  # active sensor extent along u [m]
    sensor_height: float  # along v [m]
    pixel_pitch: float  # square pixels [m]
    skew: float = 0.0  # k of Eq. (6) [px]
    principal_point: tuple[float, float] | None = None  # (u0, v0) [px]; None -> sensor centre
    depth_range: tuple[float, float] = (0.5, 25.0)  # [m], Table A3
    frame_rate: float = 30.0  # [Hz]
    name: str = field(default="custom", compare=False)
    unbounded_view: bool = False  # no field-of-view limit: every point in front and in depth range is seen

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        for key in ("focal_length", "sensor_width", "sensor_height", "pixel_pitch", "frame_rate"):
            set_(self, key, positive(getattr(self, key), key))
        set_(self, "skew", real(self.skew, "skew", unit="px"))
        pp_valid = "None or two finite numbers (u0, v0) [px]"
        pp = self.principal_point
        if pp is None:
            pp = (0.5 * self.sensor_width / self.pixel_pitch, 0.5 * self.sensor_height / self.pixel_pitch)
        elif not is_pair(pp):
            raise InvalidParameterError("principal_point", pp, pp_valid)
        try:
            set_(self, "principal_point", tuple(real(v, "principal_point") for v in pp))
        except InvalidParameterError:
            raise InvalidParameterError("principal_point", self.principal_point, pp_valid) from None
        range_valid = "(min, max) with 0 <= min < max [m]"
        if not is_pair(self.depth_range):
            raise InvalidParameterError("depth_range", self.depth_range, range_valid)
        try:
            lo, hi = (non_negative(v, "depth_range") for v in self.depth_range)
        except InvalidParameterError:
            raise InvalidParameterError("depth_range", self.depth_range, range_valid) from None
        if not lo < hi:
            raise InvalidParameterError("depth_range", self.depth_range, range_valid)
        set_(self, "depth_range", (lo, hi))
        set_(self, "name", text(self.name, "name"))
        set_(self, "unbounded_view", flag(self.unbounded_view, "unbounded_view"))

    @property
    def resolution(self) -> tuple[int, int]:
        """(width, height) [px], the sensor extent over the pixel pitch, rounded."""
        return round(self.sensor_width / self.pixel_pitch), round(self.sensor_height / self.pixel_pitch)

    @property
    def field_of_view(self) -> tuple[float, float]:
        """(horizontal, vertical) angle of view [rad] of one lens about a centred principal point."""
        F = self.focal_length
        return 2 * np.arctan(0.5 * self.sensor_width / F), 2 * np.arctan(0.5 * self.sensor_height / F)

    @cached_property
    def _lens_x(self) -> tuple[float, ...]:
        """x_C of each lens centre [m]; features are one u per lens, then the shared v (cached)."""
        return (0.0,)

    @property
    def lens_x(self) -> tuple[float, ...]:
        """x_C of each lens centre [m], in feature order: (+b/2, -b/2) stereo (ERRATA 12), (0,) pinhole."""
        return self._lens_x

    def intrinsic_matrix(self) -> np.ndarray:
        """K of Eq. (6) in pixels: [[F/p, k, u0], [0, F/p, v0], [0, 0, 1]] (maps X/Z, Y/Z to pixels)."""
        f_px = self.focal_length / self.pixel_pitch
        u0, v0 = self.principal_point
        return np.array([[f_px, self.skew, u0], [0.0, f_px, v0], [0.0, 0.0, 1.0]])

    def project(self, P_C: object, allow_behind: bool = False) -> np.ndarray:
        """Project points (n, 3) [m]: rows [u_l, u_r, v] (stereo, Eq. 9-11 with ERRATA 12) or [u, v].

        Image coordinates are metres on the sensor: u = F (X - x_lens) / Z, v = F Y / Z.

        Raises:
            PointBehindCameraError: Z_C <= 0 (unless allow_behind, the virtual points of ERRATA 13),
                and always |Z_C| < MIN_ABS_DEPTH.
        """
        P_C = _points(P_C, "P_C")
        allow_behind = flag(allow_behind, "allow_behind")
        return project_points(self, P_C, allow_behind).reshape(P_C.shape[0], len(self._lens_x) + 1)

    def interaction_matrix(self, P_C: object, allow_behind: bool = False) -> np.ndarray:
        """d(features)/d[v; w] ((k+1) n, 6), point-major, for static points seen from a moving camera.

        With dP_C/dt = -v - w x P_C = [-I, [P_C]x] [v; w] and u = F (X - x_lens) / Z, each lens's u
        row is [-F/Z, 0, u/Z, u Y/Z, -F - u X/Z, F Y/Z] and the v row [0, -F/Z, v/Z, F + v Y/Z,
        -v X/Z, -F X/Z]: for one lens at the origin, F times the classical point interaction matrix
        (Chaumette & Hutchinson 2006); for the stereo pair the lens offsets of ERRATA 12 stay in u.
        Depth rules as `project`.
        """
        return points_interaction_matrix(self, _points(P_C, "P_C"), flag(allow_behind, "allow_behind"))

    def visibility(self, P_C: object) -> Visibility:
        """Visibility of points (n, 3) [m]: in front, inside every lens's sensor extent, in depth_range."""
        P_C = _points(P_C, "P_C")
        Z = P_C[:, 2].copy()  # [m]
        in_fov = np.array(_view_flags(self, P_C)[0], dtype=bool)
        flags = (Z >= MIN_ABS_DEPTH, in_fov, (Z >= self.depth_range[0]) & (Z <= self.depth_range[1]), Z)
        for a in flags:
            a.flags.writeable = False
        return Visibility(*flags)

    def to_pixels(self, features: object) -> np.ndarray:
        """Feature rows [m on the sensor] -> [px] through K of Eq. (6) (the stereo lenses share K)."""
        p = _points(features, "features", len(self._lens_x) + 1)
        out = np.empty_like(p)
        out[:, :-1] = self._u_to_px(p[:, :-1], p[:, -1:])
        out[:, -1] = p[:, -1] / self.pixel_pitch + self.principal_point[1]
        return out

    def from_pixels(self, features_px: object) -> np.ndarray:
        """Inverse of `to_pixels`: feature rows [px] -> [m on the sensor]."""
        p_px = _points(features_px, "features_px", len(self._lens_x) + 1)
        out = np.empty_like(p_px)
        out[:, -1] = (p_px[:, -1] - self.principal_point[1]) * self.pixel_pitch
        out[:, :-1] = (
            p_px[:, :-1] - self.principal_point[0] - self.skew * out[:, -1:] / self.focal_length
        ) * self.pixel_pitch
        return out

    def _u_to_px(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return u / self.pixel_pitch + self.skew * v / self.focal_length + self.principal_point[0]


@dataclass(frozen=True, kw_only=True)
class StereoCamera(_Sensor):
    """Rectified stereo camera of Sec. 4.1 (Eq. 9-11 with ERRATA 12): two identical lenses b apart.

    Features per point are [u_l, u_r, v]; the left lens sits at x_C = +b/2. Construct with keywords
    or use the `zed2` preset. Twists are [v; w] in {C}.
    """

    baseline: float  # b [m]

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "baseline", positive(self.baseline, "baseline", unit="[m]"))

    @cached_property
    def _lens_x(self) -> tuple[float, ...]:
        return (0.5 * self.baseline, -0.5 * self.baseline)

    @classmethod
    def zed2(
        cls, preset: str = "paper", mode: str = "HD720", frame_rate: float | None = None
    ) -> StereoCamera:
        """ZED stereo camera presets (120 mm baseline).

        Args:
            preset: ``"paper"``: Table A3 (F = 2.8 mm, sensor 5.23 x 2.94 mm, 86.09 x 55.35 deg,
                0.5-25 m; the original ZED's optics, ERRATA 15), pixel pitch = 5.23 mm / width [px].
                ``"zed2"``: the real ZED 2 (F = 2.12 mm; 2 um pixels at HD2K/HD1080, 4 um binned at
                HD720, 8 um at VGA; active area = resolution x pitch, e.g. 101 x 68 deg at HD720 without
                distortion, against ~110 x 70 deg for the full lens; 0.3-20 m, Stereolabs datasheet).
            mode: ``"HD2K"`` 2208x1242, ``"HD1080"`` 1920x1080, ``"HD720"`` 1280x720, ``"VGA"`` 672x376.
            frame_rate: One of the mode's rates [Hz] (HD2K 15; HD1080 15/30; HD720 15/30/60;
                VGA 15/30/60/100); None picks the highest.
        """
        return cls(baseline=0.12, **_zed_intrinsics(preset, mode, frame_rate))

    def triangulate(self, features: object, allow_behind: bool = False) -> np.ndarray:
        """Inverse stereo map M^-1 of Eq. (C6)-(C8): points (n, 3) [m] from rows ``[u_l, u_r, v]`` [m].

        Raises:
            InvalidDisparityError: disparity u_r - u_l <= 0 (unless allow_behind), and always when it
                is ~0 (|F b / d| > MAX_ABS_DEPTH).
        """
        return triangulate_points(self, _points(features, "features"), flag(allow_behind, "allow_behind"))


@dataclass(frozen=True, kw_only=True)
class PinholeCamera(_Sensor):
    """Monocular pinhole camera at the origin of its frame: rows [u, v], u = F X / Z, v = F Y / Z.

    Three points do not fix its pose (Sec. 3, P4P); the depth of a point must be given to back-project.
    """

    @classmethod
    def zed2(
        cls, preset: str = "paper", mode: str = "HD720", frame_rate: float | None = None
    ) -> PinholeCamera:
        """One lens of `StereoCamera.zed2` (same arguments), placed at the origin of its frame."""
        return cls(**_zed_intrinsics(preset, mode, frame_rate))

    @classmethod
    def normalized(cls, frame_rate: float = 30.0) -> PinholeCamera:
        """Normalized image coordinates: focal length 1, no field-of-view limit, any depth > 0.

        Features are x = X/Z, y = Y/Z, as ViSP's ``vpFeaturePoint`` (the classical IBVS
        literature). The sensor extent and pixel pitch are nominal (2 x 2, pitch 1): pixel
        conversions are not meaningful for this camera.
        """
        return cls(
            focal_length=1.0,
            sensor_width=2.0,
            sensor_height=2.0,
            pixel_pitch=1.0,
            principal_point=(1.0, 1.0),
            depth_range=(0.0, MAX_ABS_DEPTH),
            frame_rate=frame_rate,
            name="normalized",
            unbounded_view=True,
        )

    @classmethod
    def from_focal_px(
        cls,
        focal_px: float,
        resolution: tuple[int, int],
        *,
        pixel_pitch: float = 1e-5,
        depth_range: tuple[float, float] = (0.05, 25.0),
        frame_rate: float = 30.0,
        name: str = "pinhole",
    ) -> PinholeCamera:
        """A camera given in pixels: focal length ``focal_px`` [px], ``resolution`` (width, height) [px].

        The principal point is the sensor's centre; ``pixel_pitch`` [m] only sets the unit of the
        features (metres on the sensor, F = focal_px pixel_pitch). ViSP's photometric example
        (``vpCameraParameters(870, 870, 160, 120)``, 320 x 240) is ``from_focal_px(870, (320, 240))``;
        the camera of the textured plane, ``from_focal_px(150, (120, 90))``, sees 44 x 33 deg.

        Raises:
            InvalidParameterError: a focal length or pitch <= 0, a resolution that is not two
                integers >= 1.
        """
        if not is_pair(resolution):
            raise InvalidParameterError("resolution", resolution, "(width, height): two integers >= 1 [px]")
        width, height = (integer(n, "resolution", low=1, unit="px") for n in resolution)
        pitch = positive(pixel_pitch, "pixel_pitch", unit="m")
        return cls(
            focal_length=positive(focal_px, "focal_px", unit="px") * pitch,
            sensor_width=width * pitch,
            sensor_height=height * pitch,
            pixel_pitch=pitch,
            depth_range=depth_range,
            frame_rate=frame_rate,
            name=name,
        )

    def back_project(self, features: object, Z: object, allow_behind: bool = False) -> np.ndarray:
        """Points (n, 3) [m] from rows ``[u, v]`` [m], depths Z (n,) or scalar [m]: X = u Z / F, Y = v Z / F.

        Raises:
            PointBehindCameraError: as `project`.
        """
        p = _points(features, "features", 2)
        Z = as_array(Z, "Z")
        Z = np.full(p.shape[0], float(Z)) if Z.ndim == 0 else as_array(Z, "Z", (p.shape[0],))
        _check_depth(Z, flag(allow_behind, "allow_behind"))
        return np.column_stack((p * (Z / self.focal_length)[:, None], Z))


def check_camera_has_pixels(camera: object) -> StereoCamera | PinholeCamera:
    """The camera, if it has a pixel grid to render on; else InvalidParameterError.

    A camera without a bounded view (``PinholeCamera.normalized()``) has only a nominal pixel
    pitch, and one with fewer than MIN_RESOLUTION_PX pixels a side has too few to draw on.
    """
    if not isinstance(camera, (StereoCamera, PinholeCamera)):
        raise InvalidParameterError("camera", type(camera).__name__, "a StereoCamera or a PinholeCamera")
    width, height = camera.resolution
    if camera.unbounded_view or min(width, height) < MIN_RESOLUTION_PX:
        raise InvalidParameterError(
            "camera",
            f"{camera.name!r} ({'no bounded view, ' if camera.unbounded_view else ''}{width} x {height} px)",
            f"a camera with a sensor of at least {MIN_RESOLUTION_PX} x {MIN_RESOLUTION_PX} pixels to render "
            "images on (e.g. StereoCamera.zed2(); PinholeCamera.normalized() has no pixels)",
        )
    return camera


# ---------------------------------------------------------------------- kernels (no input checks)
def pixel_centres_normalized(camera: StereoCamera | PinholeCamera) -> tuple[np.ndarray, np.ndarray]:
    """Normalized coordinates (x, y) of every pixel centre, each (height, width): K^-1 (u + 1/2, v + 1/2, 1).

    Pixel (row i, column j) covers [j, j + 1) x [i, i + 1) in pixel coordinates (module docstring),
    so its centre is (j + 1/2, i + 1/2); K is the intrinsic matrix of Eq. (6), skew included.
    """
    width, height = camera.resolution
    K_inv = np.linalg.inv(camera.intrinsic_matrix())
    u, v = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    return K_inv[0, 0] * u + K_inv[0, 1] * v + K_inv[0, 2], K_inv[1, 1] * v + K_inv[1, 2]


def project_points(camera: StereoCamera | PinholeCamera, P_C: np.ndarray, allow_behind: bool) -> np.ndarray:
    """Features of points, point-major ((k + 1) n,) [m on the sensor]: Eq. (9)-(11), ERRATA 12.

    [u_l1, u_r1, v1, u_l2, ...] for a stereo camera (the features of Eq. (24)), [u1, v1, ...]
    for a pinhole camera; ``camera.project`` returns the same numbers as rows (n, k + 1).
    Does not validate its input: ``P_C`` must be a finite float (n, 3) array [m]. Depth is
    still checked, as in ``camera.project`` (PointBehindCameraError).
    """
    # Per-point scalar loops here and below: ~5x faster than array code for 3 markers (hot path);
    # flat lists convert to arrays faster than nested ones.
    F, lens_x, out = camera.focal_length, camera._lens_x, []
    for X, Y, Z in P_C.tolist():
        if (abs(Z) if allow_behind else Z) < MIN_ABS_DEPTH:
            _check_depth(P_C[:, 2], allow_behind)
        Fiz = F / Z
        for x0 in lens_x:
            out.append((X - x0) * Fiz)
        out.append(Y * Fiz)
    return np.array(out, dtype=float)


def points_interaction_matrix(
    camera: StereoCamera | PinholeCamera, P_C: np.ndarray, allow_behind: bool
) -> np.ndarray:
    """d(features)/d[v; w] ((k + 1) n, 6) of ``camera.interaction_matrix``, point-major.

    Does not validate its input: ``P_C`` must be a finite float (n, 3) array [m]; depth is
    checked as in :func:`project_points`.
    """
    F, lens_x, out = camera.focal_length, camera._lens_x, []
    for X, Y, Z in P_C.tolist():
        if (abs(Z) if allow_behind else Z) < MIN_ABS_DEPTH:
            _check_depth(P_C[:, 2], allow_behind)
        iz = 1.0 / Z
        Fiz = F * iz
        for x0 in lens_x:
            u = (X - x0) * Fiz
            out += (-Fiz, 0.0, u * iz, u * Y * iz, -F - u * X * iz, Fiz * Y)
        v = Y * Fiz
        out += (0.0, -Fiz, v * iz, F + v * Y * iz, -v * X * iz, -Fiz * X)
    return np.array(out, dtype=float).reshape(P_C.shape[0] * (len(lens_x) + 1), 6)


def triangulate_points(camera: StereoCamera, features: np.ndarray, allow_behind: bool) -> np.ndarray:
    """Points (n, 3) [m] from stereo features (n, 3) ``[u_l, u_r, v]`` [m]: Eq. (C6)-(C8).

    ``camera.triangulate`` without the argument check: ``features`` must be a finite float (n, 3)
    array. The disparity is still checked (InvalidDisparityError, as ``camera.triangulate``).
    """
    F, b, out, p = camera.focal_length, camera.baseline, [], features
    d_min = F * b / MAX_ABS_DEPTH  # [m]
    for u_l, u_r, v in p.tolist():
        d = u_r - u_l  # disparity [m]
        if (abs(d) if allow_behind else d) < d_min:
            _raise_disparity(p[:, 1] - p[:, 0], d_min, allow_behind)
        s = b / d
        out += (0.5 * s * (u_l + u_r), s * v, F * s)  # Eq. (C6)-(C8)
    return np.array(out, dtype=float).reshape(p.shape[0], 3)


def points_at_depths(
    camera: StereoCamera | PinholeCamera, features: np.ndarray, depth: np.ndarray
) -> np.ndarray:
    """Points P_C (n, 3) [m] back-projected from features at measured depths Z (n,) [m].

    X = u Z / F, Y = v Z / F for a pinhole camera ([u, v] per point); X = (u_l + u_r) Z / (2 F),
    Y = v Z / F for a stereo camera (the mid-baseline abscissa, ERRATA 12). Does not validate its
    input (``PinholeCamera.back_project`` is the checked form for a pinhole camera) and does not
    check the depths: a controller's kernels check them where a depth enters (the interaction
    matrix).
    """
    n, F = depth.shape[0], camera.focal_length
    p = features.reshape(n, -1)
    u = 0.5 * (p[:, 0] + p[:, 1]) if p.shape[1] == 3 else p[:, 0]
    return np.column_stack((u * (depth / F), p[:, -1] * (depth / F), depth))


def visible_points(camera: StereoCamera | PinholeCamera, P_C: np.ndarray) -> list[bool]:
    """Per point, in front, in view of every lens and within depth_range: ``camera.visibility(P_C).visible``.

    Does not validate its input: ``P_C`` must be a float (n, 3) array [m].
    """
    return _view_flags(camera, P_C)[1]


def _view_flags(camera: StereoCamera | PinholeCamera, P_C: np.ndarray) -> tuple[list[bool], list[bool]]:
    """Per point (n, 3): (in front and inside every lens's sensor extent, that and in depth_range)."""
    F, pitch, skew = camera.focal_length, camera.pixel_pitch, camera.skew
    u0, v0 = camera.principal_point
    u_max, v_max = camera.sensor_width / pitch, camera.sensor_height / pitch
    z_min, z_max = camera.depth_range
    lens_x, bounded = camera._lens_x, not camera.unbounded_view
    in_fov, visible = [], []
    for X, Y, Z in P_C.tolist():
        in_view = Z >= MIN_ABS_DEPTH
        if in_view and bounded:
            Fiz = F / Z
            v = Y * Fiz
            in_view = 0 <= v / pitch + v0 <= v_max  # pixel coordinates through K of Eq. (6)
            for x0 in lens_x:  # a loop, not all(...): a generator costs more than the test
                in_view = in_view and 0 <= (X - x0) * Fiz / pitch + skew * v / F + u0 <= u_max
        in_fov.append(in_view)
        visible.append(in_view and z_min <= Z <= z_max)
    return in_fov, visible


def default_camera(**overrides: object) -> StereoCamera:
    """The camera the simulator, the command line and TOML configs use unless told otherwise.

    The paper's ZED 2 optics (Table A3) in the VGA mode, whose 100 fps matches the default
    100 Hz camera rate (ERRATA 15); ``overrides`` go to :meth:`StereoCamera.zed2`.
    """
    unknown = sorted(set(overrides) - {"preset", "mode", "frame_rate"})
    if unknown:
        raise InvalidParameterError(
            ", ".join(unknown), overrides, "keywords of StereoCamera.zed2: preset, mode, frame_rate"
        )
    return StereoCamera.zed2(**{"mode": "VGA", **overrides})  # type: ignore[arg-type]
