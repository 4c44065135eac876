"""Render camera frames of disc markers: grayscale images at the camera's resolution.

Each marker is a flat disc (or a ring) of a stated physical diameter, drawn as the exact
perspective image of the 3-D disc: its image conic (:mod:`ibvs_youla.model.disc_image`) decides
which points of the image plane it covers, and the grey level of a pixel is the fraction of the
pixel it covers, estimated on an s x s grid of sub-pixel samples (supersampling, s = 8 by
default: 1/64 grey steps of the contrast). Only pixels within 1.5 px of the ellipse's boundary
are supersampled; the others are wholly inside or outside. Why the conic and supersampling
rather than OpenCV's drawing: ``cv2.ellipse`` needs the ellipse's parameters (the conic gives
them), then draws a polyline of whole-degree steps with fixed-point vertices and an
anti-aliased edge, not an area coverage; in a trial (40 poses per depth, 5 cm discs tilted
30 deg, given the exact ellipse, ``shift=8``, ``LINE_AA``) its centroid was up to 0.04-0.05 px
off the ellipse's centre, against 0.004 px at 0.5 m and 0.015 px at 3 m here: the drawing
would add an error of the size of what the sensor is there to measure.

Discs are composited far to near (a nearer disc covers a farther one), then the image is
optionally blurred (``cv2.GaussianBlur``, sigma in pixels, replicated border), Gaussian sensor
noise is added (grey levels; ``cv2.randn``, seeded for each image from the caller's numpy
generator), and the result is rounded and clipped to uint8.

Conventions: images are (height, width) arrays, row v, column u; pixel (v, u) covers
[u, u + 1) x [v, v + 1) in the pixel coordinates of ``camera.to_pixels``. A stereo camera gives
the left then the right image (the lenses of ERRATA 12).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from .._validation import as_array, non_negative, positive
from ..exceptions import InvalidParameterError
from ..model.camera import PinholeCamera, StereoCamera, check_camera_has_pixels
from ..model.disc_image import DiscImage, disc_images

__all__ = [
    "DiscMarkers",
    "ImagingSettings",
    "RenderedFrame",
    "check_camera_has_pixels",
    "finish_image",
    "render",
    "render_unchecked",
]

EDGE_BAND_PX = 1.5  # supersample pixels whose centre is within this distance of an ellipse's edge [px]
MIN_CURVATURE_RADIUS_PX = 4.0  # below this, every pixel of the ellipse's box is supersampled [px]


@dataclass(frozen=True)
class DiscMarkers:
    """The physical markers: flat discs (or rings) and their grey levels.

    Attributes:
        diameter: Outer diameter of every disc [m], > 0.
        ring_inner_diameter: None for filled discs; else the diameter of the hole of a ring
            [m], 0 < inner < diameter (the hole shows what lies behind).
        normals_O: The side each disc faces, in the base frame: None (each disc faces the
            camera's origin at every frame, like a marker turned towards the camera), one unit
            vector (3,) for all, or one per marker (n, 3); a disc is seen only from that side.
        marker_grey: Grey level of the discs [0, 255].
        background_grey: Grey level of the background [0, 255].

    Raises:
        InvalidParameterError: a diameter <= 0, an inner diameter outside (0, diameter), a
            normal of zero length, grey levels outside [0, 255] or equal.
        InvalidArrayError: normals not a finite (3,) or (n, 3) array.
    """

    diameter: float = 0.05
    ring_inner_diameter: float | None = None
    normals_O: Any = None
    marker_grey: float = 30.0
    background_grey: float = 200.0

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "diameter", positive(self.diameter, "diameter", unit="[m]"))
        if self.ring_inner_diameter is not None:
            inner = positive(self.ring_inner_diameter, "ring_inner_diameter", unit="[m]")
            if inner >= self.diameter:
                raise InvalidParameterError(
                    "ring_inner_diameter", inner, f"None or 0 < inner < diameter = {self.diameter:g} m"
                )
            set_(self, "ring_inner_diameter", inner)
        if self.normals_O is not None:
            normals = as_array(self.normals_O, "normals_O")
            normals = as_array(normals[None, :] if normals.shape == (3,) else normals, "normals_O", (None, 3))
            lengths = np.linalg.norm(normals, axis=1)
            if np.any(lengths < 1e-9):
                raise InvalidParameterError("normals_O", normals.tolist(), "non-zero vectors (3,) or (n, 3)")
            normals = normals / lengths[:, None]
            normals.setflags(write=False)
            set_(self, "normals_O", normals)
        for key in ("marker_grey", "background_grey"):
            value = non_negative(getattr(self, key), key)
            if value > 255.0:
                raise InvalidParameterError(key, value, "a grey level in [0, 255]")
            set_(self, key, value)
        if self.marker_grey == self.background_grey:
            raise InvalidParameterError(
                "marker_grey",
                self.marker_grey,
                f"a grey level other than the background's {self.background_grey:g}",
            )

    @property
    def radius(self) -> float:
        """Outer radius [m]."""
        return 0.5 * self.diameter

    def normals_C(self, P_C: np.ndarray, R_O_C: np.ndarray) -> np.ndarray:
        """Unit normals (n, 3) in {C} of markers at P_C (n, 3) [m], the camera rotated by R_O_C.

        Raises:
            InvalidParameterError: per-marker normals for another number of markers.
        """
        if self.normals_O is None:
            return -P_C / np.linalg.norm(P_C, axis=1)[:, None]  # facing the camera's origin
        normals = self.normals_O
        if normals.shape[0] not in (1, P_C.shape[0]):
            raise InvalidParameterError(
                "normals_O", f"{normals.shape[0]} normals", f"1 or one per marker ({P_C.shape[0]})"
            )
        return np.broadcast_to(normals.dot(R_O_C), P_C.shape)  # rows R^T n_O

    def to_dict(self) -> dict[str, Any]:
        """Plain data, e.g. for a run's specification."""
        return {
            "diameter": self.diameter,
            "ring_inner_diameter": self.ring_inner_diameter,
            "normals_O": None if self.normals_O is None else self.normals_O.tolist(),
            "marker_grey": self.marker_grey,
            "background_grey": self.background_grey,
        }


@dataclass(frozen=True)
class ImagingSettings:
    """How a frame is rendered: blur, sensor noise and the coverage estimate.

    Attributes:
        blur_sigma_px: Standard deviation of the Gaussian blur [px], >= 0 (0: none).
        noise_sigma_grey: Standard deviation of the additive Gaussian sensor noise [grey
            levels], >= 0 (0: none); drawn from the sensor's seeded generator.
        supersampling: Samples per pixel side for the coverage of edge pixels, 1-32.
        seed: Seed of the noise generator of a sensor built with these settings.

    Raises:
        InvalidParameterError: a negative blur or noise, a supersampling outside 1-32, a seed
            that is not a non-negative integer.
    """

    blur_sigma_px: float = 0.0
    noise_sigma_grey: float = 0.0
    supersampling: int = 8
    seed: int = 0

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "blur_sigma_px", non_negative(self.blur_sigma_px, "blur_sigma_px", unit="[px]")
        )
        noise = non_negative(self.noise_sigma_grey, "noise_sigma_grey", unit="[grey levels]")
        object.__setattr__(self, "noise_sigma_grey", noise)
        for key, lo, hi in (("supersampling", 1, 32), ("seed", 0, None)):
            value = getattr(self, key)
            if (
                not isinstance(value, (int, np.integer))
                or isinstance(value, bool)
                or value < lo
                or (hi and value > hi)
            ):
                raise InvalidParameterError(key, value, f"an integer in [{lo}, {hi or 'inf'}]")
            object.__setattr__(self, key, int(value))

    def to_dict(self) -> dict[str, Any]:
        """Plain data, e.g. for a run's specification."""
        return {
            "blur_sigma_px": self.blur_sigma_px,
            "noise_sigma_grey": self.noise_sigma_grey,
            "supersampling": self.supersampling,
            "seed": self.seed,
        }


@dataclass(frozen=True, eq=False)
class RenderedFrame:
    """One rendered frame: the images and the geometry they were drawn from.

    Attributes:
        images: One uint8 (height, width) image per lens (left, right for a stereo camera).
        discs: The image of each marker's outer disc in each lens (what the detector should find).
        holes: The image of each ring's hole, or None for filled discs.
        drawn: Per lens and marker (k, n): drawable and overlapping the image.
    """

    images: tuple[np.ndarray, ...]
    discs: DiscImage
    holes: DiscImage | None
    drawn: np.ndarray


def render(
    camera: StereoCamera | PinholeCamera,
    markers: DiscMarkers,
    P_C: Any,
    normals_C: Any,
    imaging: ImagingSettings | None = None,
    rng: np.random.Generator | None = None,
) -> RenderedFrame:
    """Render one frame of the markers at P_C (n, 3) [m] with normals_C (n, 3) in the camera frame.

    Args:
        camera: A camera with pixels (:func:`check_camera_has_pixels`).
        markers: Size and grey levels (its ``normals_O`` are not used: pass ``normals_C``, e.g.
            from ``markers.normals_C``).
        P_C: Disc centres in {C} (n, 3) [m].
        normals_C: The side each disc faces, in {C} (n, 3) (normalized here).
        imaging: Blur, noise and supersampling; default none and 8.
        rng: Noise generator; default ``np.random.default_rng(imaging.seed)``.

    Raises:
        InvalidParameterError: a camera without pixels, normals of zero length.
        InvalidArrayError: P_C or normals_C not finite (n, 3) arrays of one length.
    """
    camera = check_camera_has_pixels(camera)
    imaging = ImagingSettings() if imaging is None else imaging
    P_C = as_array(P_C, "P_C", (None, 3))
    normals_C = as_array(normals_C, "normals_C", (P_C.shape[0], 3))
    lengths = np.linalg.norm(normals_C, axis=1)
    if np.any(lengths < 1e-9):
        raise InvalidParameterError("normals_C", normals_C.tolist(), "non-zero vectors (n, 3)")
    normals_C = normals_C / lengths[:, None]
    rng = np.random.default_rng(imaging.seed) if rng is None else rng
    return render_unchecked(camera, markers, P_C, normals_C, imaging, rng)


def render_unchecked(
    camera: StereoCamera | PinholeCamera,
    markers: DiscMarkers,
    P_C: np.ndarray,
    normals_C: np.ndarray,
    imaging: ImagingSettings,
    rng: np.random.Generator,
) -> RenderedFrame:
    """:func:`render` without the argument checks (for the image sensor's hot path)."""
    discs = disc_images(camera, P_C, normals_C, markers.radius)
    holes = None
    if markers.ring_inner_diameter is not None:
        holes = disc_images(camera, P_C, normals_C, 0.5 * markers.ring_inner_diameter)
    width, height = camera.resolution
    far_to_near = np.argsort(-P_C[:, 2], kind="stable")
    images, drawn = [], np.zeros(discs.drawable.shape, dtype=bool)
    for lens in range(discs.drawable.shape[0]):
        canvas = np.full((height, width), markers.background_grey, dtype=np.float32)
        for j in far_to_near:
            drawn[lens, j] = _draw(canvas, discs, holes, lens, j, markers.marker_grey, imaging.supersampling)
        images.append(finish_image(canvas, imaging, rng))
    return RenderedFrame(tuple(images), discs, holes, drawn)


def finish_image(canvas: np.ndarray, imaging: ImagingSettings, rng: np.random.Generator | None) -> np.ndarray:
    """What the camera makes of an exact image: blur, sensor noise, rounding to 8 bits (uint8).

    ``canvas`` (height, width) float32 grey levels (it may be overwritten) is blurred
    (``cv2.GaussianBlur``, sigma ``imaging.blur_sigma_px``, replicated border), given Gaussian
    noise of ``imaging.noise_sigma_grey`` grey levels (``cv2.randn``, seeded for every image from
    ``rng``, which may be None without noise), rounded and clipped to [0, 255].
    """
    if imaging.blur_sigma_px > 0.0:
        canvas = cv2.GaussianBlur(
            canvas,
            (0, 0),
            imaging.blur_sigma_px,
            sigmaY=imaging.blur_sigma_px,
            borderType=cv2.BORDER_REPLICATE,
        )
    if imaging.noise_sigma_grey > 0.0:
        # cv2.randn is ~5x faster than numpy's normals; its generator is OpenCV's per-thread
        # one, seeded for every image from ``rng``, so the noise is reproducible from the seed
        cv2.setRNGSeed(int(rng.integers(2**31)))  # type: ignore[union-attr]
        noise = np.empty(canvas.shape, dtype=np.float32)
        cv2.randn(noise, 0.0, imaging.noise_sigma_grey)
        canvas += noise
    np.rint(canvas, out=canvas)
    return np.clip(canvas, 0.0, 255.0, out=canvas).astype(np.uint8)


def _draw(
    canvas: np.ndarray, discs: DiscImage, holes: DiscImage | None, lens: int, j: int, grey: float, s: int
) -> bool:
    """Composite marker j into one lens's canvas (coverage-weighted); False if nothing was drawn."""
    if not discs.drawable[lens, j]:
        return False
    height, width = canvas.shape
    u_min, u_max, v_min, v_max = discs.box_px[lens, j]
    i0, i1 = max(0, int(np.floor(u_min))), min(width, int(np.floor(u_max)) + 1)
    j0, j1 = max(0, int(np.floor(v_min))), min(height, int(np.floor(v_max)) + 1)
    if i0 >= i1 or j0 >= j1:
        return False
    u = np.arange(i0, i1) + 0.5  # pixel centres [px]
    v = np.arange(j0, j1) + 0.5
    coverage = _coverage(discs, lens, j, u, v, s)
    if holes is not None and holes.drawable[lens, j]:
        coverage -= _coverage(holes, lens, j, u, v, s)
    region = canvas[j0:j1, i0:i1]
    region += (coverage * (grey - region)).astype(np.float32)
    return bool(coverage.max() > 0.0)


def _coverage(discs: DiscImage, lens: int, j: int, u: np.ndarray, v: np.ndarray, s: int) -> np.ndarray:
    """Fraction of each pixel (len(v), len(u)) with centres (u, v) inside ellipse j of a lens."""
    C = discs.conic_px[lens, j]
    A, (u_c, v_c) = C[:2, :2], discs.centre_px[lens, j]
    f0 = np.array([u_c, v_c, 1.0]).dot(C).dot([u_c, v_c, 1.0])  # < 0: the value at the centre
    du, dv = u[None, :] - u_c, v[:, None] - v_c
    a00, a01, a11 = A[0, 0], A[0, 1], A[1, 1]
    q = a00 * du**2 + 2.0 * a01 * du * dv + a11 * dv**2 + f0
    grad = 2.0 * np.hypot(a00 * du + a01 * dv, a01 * du + a11 * dv)
    major, minor = discs.axes_px[lens, j]
    curvature_radius = minor**2 / major  # the smallest radius of curvature of the ellipse [px]
    coverage = (q < 0.0).astype(np.float64)
    if curvature_radius >= MIN_CURVATURE_RADIUS_PX:
        edge = np.abs(q) < EDGE_BAND_PX * grad
    else:
        edge = np.ones(q.shape, dtype=bool)
    rows, cols = np.nonzero(edge)
    if rows.size:
        offsets = (np.arange(s) + 0.5) / s - 0.5  # sub-pixel sample positions about the centre [px]
        su = (du[0, cols][:, None, None] + offsets[None, None, :]).astype(np.float64)
        sv = dv[rows, 0][:, None, None] + offsets[None, :, None]
        sq = a00 * su**2 + 2.0 * a01 * su * sv + a11 * sv**2 + f0
        coverage[rows, cols] = (sq < 0.0).mean(axis=(1, 2))
    return coverage
