"""A textured plane: the scene of photometric visual servoing, imaged exactly through its homography.

The plane is z_P = 0 of its frame {P}, placed in the base frame by ``T_O_P``. A grey-level
texture of W columns and H rows, each texel s metres a side, covers the rectangle of W s by H s
centred on the origin, columns along x_P and rows along y_P; the textured side faces -z_P (a
camera on the -z_P side looking along +z_P sees it upright, as ViSP's photometric example puts
its camera at ``cMo = (0, 0, 1)`` [m]). A point (X, Y, 0) of {P} has texture coordinates

    a = X / s + W / 2,   b = Y / s + H / 2                                            (T1)

with texel (row i, column j) covering [j, j + 1) x [i, i + 1), its centre at (j + 1/2, i + 1/2):
the convention of the camera's pixels (:mod:`~ibvs_youla.model.camera`).

**Image.** A pinhole camera at T_O_C sees the plane through the homography

    p ~ K [r_1  r_2  t] S (a, b, 1)^T,   S = [[s, 0, -W s / 2], [0, s, -H s / 2], [0, 0, 1]]    (T2)

where K is the camera's intrinsic matrix (pixels, Eq. (6) of the paper), r_1, r_2 the first two
columns of R_C_P and t = t_C_P (T_C_P = T_C_O T_O_P). Each pixel's grey level is the texture,
interpolated bilinearly, at the point its centre maps back to: ``cv2.warpPerspective`` of the
texture by (T2) with the half-pixel shifts between OpenCV's indices (centres at integers) and
these coordinates (centres at half-integers), as ViSP's ``vpImageSimulator`` images a textured
quadrilateral in its bilinear mode. OpenCV's fixed-point warps quantize the bilinear weights to
1/32 texel (``INTER_BITS`` = 5); the OpenCV 5 installed with this project interpolates in floating
point (an image that follows a motion of 2e-4 px linearly; ``tests/test_textured_plane.py``
bounds the difference from the exact interpolation by the texture's change over 1/32 texel, and
measured 1.5e-5 grey levels). A bilinear texture is continuous with kinks at texel boundaries: its
image is differentiable in the pose only between them. A pixel whose ray misses the plane (it
looks away, or the camera is behind the plane) and a point outside the texture show
``background_grey``.

**Depth.** The ray through normalized coordinates (x, y) meets the plane at depth

    Z(x, y) = (n . t) / (n . (x, y, 1)),   n = R_C_P e_z                                   (T3)

(the plane n . P_C = n . t in the camera frame); it is what the luminance interaction matrix
needs per pixel.

**Texture.** Either given (any 2-D array of grey levels, e.g. a photograph read with
``cv2.imread(path, cv2.IMREAD_GRAYSCALE)``), or generated from a seed (:func:`generated_texture`):
Gaussian white noise shaped to the 1/f amplitude spectrum of natural images and low-passed by
a Gaussian of ``smoothing_texels``, scaled to a mean of 128 and a standard deviation of
:data:`TEXTURE_STD_GREY` grey levels. Its coarse structures give the photometric cost a basin
of a few centimetres; the low-pass keeps it smooth at the scale of a pixel.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from .._geometry import inverse_pose
from .._validation import as_array, as_pose, integer, is_pair, non_negative, positive
from ..exceptions import InvalidParameterError
from .camera import pixel_centres_normalized

__all__ = [
    "TEXTURE_MEAN_GREY",
    "TEXTURE_STD_GREY",
    "TexturedPlane",
    "generated_texture",
    "plane_depths",
    "plane_homography",
    "render_plane",
]

TEXTURE_MEAN_GREY = 128.0  # mean grey level of a generated texture
TEXTURE_STD_GREY = 40.0  # standard deviation of a generated texture [grey levels] (clipped at 0 and 255)
_HALF = np.array([[1.0, 0.0, 0.5], [0.0, 1.0, 0.5], [0.0, 0.0, 1.0]])  # OpenCV index -> pixel coordinates
_HALF_INV = np.array([[1.0, 0.0, -0.5], [0.0, 1.0, -0.5], [0.0, 0.0, 1.0]])


def generated_texture(shape: tuple[int, int], seed: int, smoothing_texels: float) -> np.ndarray:
    """A seeded 1/f noise texture (rows, cols), float32 grey levels in [0, 255] (module docstring).

    The amplitude spectrum of Gaussian white noise (``np.random.default_rng(seed)``) is multiplied
    by ``exp(-2 pi^2 sigma^2 f^2) / max(f, f_0)``, f the spatial frequency [cycles per texel],
    sigma = ``smoothing_texels`` and f_0 = 1 / max(rows, cols) (the longest wavelength the texture
    holds); the result is scaled to mean 128 and standard deviation 40 and clipped to [0, 255].
    The texture is periodic (it tiles without a seam).
    """
    rows, cols = shape
    white = np.random.default_rng(seed).standard_normal((rows, cols))
    fy = np.fft.fftfreq(rows)[:, None]
    fx = np.fft.rfftfreq(cols)[None, :]
    f = np.hypot(fx, fy)  # [cycles per texel]
    gain = np.exp(-2.0 * np.pi**2 * smoothing_texels**2 * f**2) / np.maximum(f, 1.0 / max(rows, cols))
    shaped = np.fft.irfft2(np.fft.rfft2(white) * gain, s=(rows, cols))
    scaled = TEXTURE_MEAN_GREY + TEXTURE_STD_GREY * (shaped - shaped.mean()) / shaped.std()
    return np.clip(scaled, 0.0, 255.0).astype(np.float32)


@dataclass(frozen=True, eq=False)
class TexturedPlane:
    """A textured rectangle on a plane (module docstring); validated at construction, immutable.

    Attributes:
        T_O_P: Pose of the plane's frame in the base frame (4, 4); the texture lies on z_P = 0
            and faces -z_P.
        texel_m: Side of one texel [m], > 0.
        texture: Grey levels (rows, cols) in [0, 255], at least 2 x 2; None: generated from
            ``seed``, ``texels`` and ``smoothing_texels`` (:func:`generated_texture`).
        texels: (cols, rows) of a generated texture (each >= 2); ignored when ``texture`` is given.
        seed: Seed of a generated texture (an integer >= 0).
        smoothing_texels: Gaussian low-pass of a generated texture [texels], >= 0.
        background_grey: Grey level where the plane or the texture is not seen [0, 255].

    Raises:
        InvalidArrayError: a pose that is not a rigid transform, a texture that is not a finite
            2-D array.
        InvalidParameterError: a texel size <= 0, texels not two integers >= 2, a negative
            seed or smoothing, grey levels outside [0, 255].
    """

    T_O_P: Any = None
    texel_m: float = 0.005
    texture: Any = None
    texels: tuple[int, int] = (240, 180)
    seed: int = 0
    smoothing_texels: float = 3.0
    background_grey: float = 0.0

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "T_O_P", _frozen(as_pose(np.eye(4) if self.T_O_P is None else self.T_O_P, "T_O_P")))
        set_(self, "texel_m", positive(self.texel_m, "texel_m", unit="m"))
        if not is_pair(self.texels):
            raise InvalidParameterError("texels", self.texels, "(cols, rows): two integers >= 2")
        set_(self, "texels", tuple(integer(n, "texels", low=2) for n in self.texels))
        set_(self, "seed", integer(self.seed, "seed", low=0))
        set_(self, "smoothing_texels", non_negative(self.smoothing_texels, "smoothing_texels", unit="texels"))
        set_(self, "background_grey", _grey(self.background_grey, "background_grey"))
        if self.texture is None:
            cols, rows = self.texels
            texture = generated_texture((rows, cols), self.seed, self.smoothing_texels)
        else:
            given = as_array(self.texture, "texture", (None, None))
            if min(given.shape) < 2 or given.min() < 0.0 or given.max() > 255.0:
                raise InvalidParameterError(
                    "texture",
                    f"an array of shape {given.shape}, grey levels {given.min():g} to {given.max():g}",
                    "grey levels in [0, 255], at least 2 x 2 texels",
                )
            texture = given.astype(np.float32)
            set_(self, "texels", (texture.shape[1], texture.shape[0]))
        set_(self, "_texture", _frozen(texture))

    # ------------------------------------------------------------------ geometry
    @property
    def texture_grey(self) -> np.ndarray:
        """The texture (rows, cols), float32 grey levels (read-only)."""
        return self._texture  # type: ignore[attr-defined,no-any-return]

    @property
    def size_m(self) -> tuple[float, float]:
        """(width, height) of the textured rectangle [m]."""
        cols, rows = self.texels
        return cols * self.texel_m, rows * self.texel_m

    def corners_O(self) -> np.ndarray:
        """The rectangle's corners (4, 3) in the base frame [m]: (-,-), (+,-), (+,+), (-,+) in {P}."""
        w, h = self.size_m
        corners_P = 0.5 * np.array([[-w, -h, 0.0], [w, -h, 0.0], [w, h, 0.0], [-w, h, 0.0]])
        return corners_P @ self.T_O_P[:3, :3].T + self.T_O_P[:3, 3]

    def points_O(self, points_P: Any) -> np.ndarray:
        """Points given in {P} (n, 3) [m], in the base frame."""
        P = as_array(points_P, "points_P", (None, 3))
        return P @ self.T_O_P[:3, :3].T + self.T_O_P[:3, 3]

    @classmethod
    def facing(cls, T_O_C: Any, depth_m: float, **fields: Any) -> TexturedPlane:
        """A plane fronto-parallel to a camera at T_O_C, its centre on the optical axis at ``depth_m``.

        {P} has the camera's axes (the texture upright in the image, facing the camera), its
        origin at depth ``depth_m`` [m] > 0 along the optical axis; ``fields`` are the other
        attributes (texel size, texture, seed, ...).
        """
        T_O_C = as_pose(T_O_C, "T_O_C")
        offset = np.eye(4)
        offset[2, 3] = positive(depth_m, "depth_m", unit="m")
        return cls(T_O_P=T_O_C @ offset, **fields)

    def homography(self, camera: Any, T_O_C: Any) -> np.ndarray:
        """(T2): texture coordinates -> pixel coordinates (3, 3) of a pinhole camera at T_O_C."""
        return plane_homography(camera.intrinsic_matrix(), self, as_pose(T_O_C, "T_O_C"))

    def render(self, camera: Any, T_O_C: Any) -> np.ndarray:
        """The image (height, width) float32 the camera sees at T_O_C (module docstring).

        Raises:
            InvalidParameterError: a camera that is not a PinholeCamera with pixels.
        """
        camera = _pinhole_with_pixels(camera)
        return render_plane(camera, self, as_pose(T_O_C, "T_O_C"))

    def depths(self, camera: Any, T_O_C: Any) -> np.ndarray:
        """Z (T3) [m] at every pixel centre (height, width); inf where the ray misses the plane."""
        camera = _pinhole_with_pixels(camera)
        return plane_depths(camera, self, as_pose(T_O_C, "T_O_C"))

    def to_dict(self) -> dict[str, Any]:
        """Plain data: the pose, texel size, background, and the texture's recipe (or its grey levels)."""
        data: dict[str, Any] = {
            "kind": "textured_plane",
            "T_O_P": self.T_O_P.tolist(),
            "texel_m": self.texel_m,
            "background_grey": self.background_grey,
        }
        if self.texture is None:
            data.update(texels=list(self.texels), seed=self.seed, smoothing_texels=self.smoothing_texels)
        else:
            data["texture"] = np.asarray(self.texture_grey, dtype=float).tolist()
        return data

    @classmethod
    def from_dict(cls, data: Any) -> TexturedPlane:
        """The plane of :meth:`to_dict`.

        Raises:
            InvalidParameterError: not such a mapping, or an unknown field.
        """
        if not isinstance(data, dict) or data.get("kind") != "textured_plane":
            raise InvalidParameterError("scene", data, "a mapping from TexturedPlane.to_dict()")
        fields = {k: v for k, v in data.items() if k != "kind"}
        known = {"T_O_P", "texel_m", "texture", "texels", "seed", "smoothing_texels", "background_grey"}
        unknown = sorted(set(fields) - known)
        if unknown:
            raise InvalidParameterError("scene", unknown, f"fields among {', '.join(sorted(known))}")
        if "texels" in fields:
            fields["texels"] = tuple(fields["texels"])
        return cls(**fields)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TexturedPlane):
            return NotImplemented
        return (
            np.array_equal(self.T_O_P, other.T_O_P)
            and self.texel_m == other.texel_m
            and self.background_grey == other.background_grey
            and np.array_equal(self.texture_grey, other.texture_grey)
        )

    __hash__ = None  # type: ignore[assignment]


# ---------------------------------------------------------------------- kernels (no input checks)
def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a)
    a.setflags(write=False)
    return a


def _grey(value: Any, name: str) -> float:
    grey = non_negative(value, name)
    if grey > 255.0:
        raise InvalidParameterError(name, value, "a grey level in [0, 255]")
    return grey


def _pinhole_with_pixels(camera: Any) -> Any:
    from .camera import PinholeCamera, check_camera_has_pixels

    if not isinstance(camera, PinholeCamera):
        raise InvalidParameterError(
            "camera",
            type(camera).__name__,
            "a PinholeCamera with pixels (one lens images the plane), "
            "e.g. PinholeCamera.from_focal_px(150, (120, 90))",
        )
    return check_camera_has_pixels(camera)


def _camera_from_plane(plane: TexturedPlane, T_O_C: np.ndarray) -> np.ndarray:
    """T_C_P (4, 4)."""
    return inverse_pose(T_O_C) @ plane.T_O_P


def plane_homography(K: np.ndarray, plane: TexturedPlane, T_O_C: np.ndarray) -> np.ndarray:
    """(T2): texture coordinates (a, b, 1) -> pixel coordinates, K the intrinsic matrix [px]."""
    return _homography(K, plane, _camera_from_plane(plane, T_O_C))


def _homography(K: np.ndarray, plane: TexturedPlane, T_C_P: np.ndarray) -> np.ndarray:
    cols, rows = plane.texels
    s = plane.texel_m
    S = np.array([[s, 0.0, -0.5 * cols * s], [0.0, s, -0.5 * rows * s], [0.0, 0.0, 1.0]])
    M = np.column_stack((T_C_P[:3, 0], T_C_P[:3, 1], T_C_P[:3, 3]))
    return K @ M @ S


def plane_depths(camera: Any, plane: TexturedPlane, T_O_C: np.ndarray) -> np.ndarray:
    """(T3) at every pixel centre (height, width) [m]; inf where the ray misses the textured side."""
    T_C_P = _camera_from_plane(plane, T_O_C)
    n, t = T_C_P[:3, 2], T_C_P[:3, 3]
    x, y = pixel_centres_normalized(camera)
    with np.errstate(divide="ignore"):
        Z = float(n.dot(t)) / (n[0] * x + n[1] * y + n[2])
    if n.dot(t) <= 0.0:  # the camera is on the back side (or in the plane): nothing seen
        return np.full(Z.shape, np.inf)
    return np.where(Z > 0.0, Z, np.inf)


def render_plane(camera: Any, plane: TexturedPlane, T_O_C: np.ndarray) -> np.ndarray:
    """The image (height, width) float32 of the plane from a pinhole camera at T_O_C (module docstring)."""
    width, height = camera.resolution
    T_C_P = _camera_from_plane(plane, T_O_C)
    n, t = T_C_P[:3, 2], T_C_P[:3, 3]
    background = plane.background_grey
    if n.dot(t) <= 0.0:  # behind the plane, or in it
        return np.full((height, width), background, dtype=np.float32)
    K = camera.intrinsic_matrix()
    H_cv = _HALF_INV @ _homography(K, plane, T_C_P) @ _HALF  # OpenCV's indices on both sides
    image = cv2.warpPerspective(
        plane.texture_grey,
        H_cv,
        (width, height),
        flags=cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=background,
    )
    # n . (x, y, 1) is affine in the pixel: if it is > 0 at the four corners, every ray meets the plane
    K_inv = np.linalg.inv(K)
    corners = K_inv @ np.array([[0.0, width, width, 0.0], [0.0, 0.0, height, height], [1.0, 1.0, 1.0, 1.0]])
    if np.all(n.dot(corners) > 0.0):
        return image
    x, y = pixel_centres_normalized(camera)
    image[n[0] * x + n[1] * y + n[2] <= 0.0] = background  # rays that look away from the plane
    return image
