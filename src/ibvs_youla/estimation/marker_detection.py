"""Detect the centres of disc markers in a grayscale image, and match them to known markers.

Two detectors, both OpenCV:

* ``"moments"`` (the default): Otsu's threshold (``cv2.threshold``, on a copy smoothed by
  ``cv2.GaussianBlur``) segments the markers; ``cv2.findContours`` finds each blob, and its
  centre is the grey-level centroid (``cv2.moments`` of the background-subtracted intensities
  of the *unsmoothed* image) over the blob dilated by a margin (``cv2.dilate``), the background
  level being the median of the pixels around it. For a disc's image, an ellipse, the centroid
  of its covered area is the ellipse's centre; a Gaussian blur does not move a centroid, and
  zero-mean noise adds no bias, only spread.
* ``"hough"``: ``cv2.HoughCircles`` (``HOUGH_GRADIENT``, a 1 px accumulator), the transform
  the paper names (Sec. 2), on the smoothed image; a circle's centre is its accumulator peak.
  It models a circle; a tilted disc's image is an ellipse. (``HOUGH_GRADIENT_ALT``, OpenCV's
  more accurate variant, found none of the 5 cm discs at 2 m or more in a trial on the sweep's
  images, which are under 10 px across there.)

Why moments: measured by ``benchmarks/bench_detection.py --compare`` on the ZED 2 model (5 cm
discs tilted 30 deg, depths 0.5-3 m, blur 0-2 px, noise 2 grey levels; README "Images in the
loop"), the moments detector found every marker, with median errors beyond the perspective
bias of 0.006 px at 0.5 m to 0.046 px at 3 m; the Hough transform found 45 % of them (none at
0.5 m, where it returns several circles per disc; 9-13 % at 3 m without blur) with median
errors of 0.28-0.73 px, a median 12x the moments detector's per cell, and took twice its time
(2.6 against 1.4 ms of CPU per VGA image).
The centroid is sub-pixel by construction, needs no radius range, and an ellipse is no harder
for it than a circle.

Every blob is rejected rather than guessed when its centre cannot be trusted: fewer than
``min_area_px`` pixels; touching the image border or within ``margin_px`` of it (part of the
marker or its blur is cut off); another blob within its margin (the two would bleed into each
other's centroid). :func:`associate` then assigns blobs to markers by their predicted
positions: a marker gets the blob within its gate whose area agrees with the prediction, only
if that blob is the only candidate and a candidate of no other marker; otherwise it is missing
(index -1). Pixel coordinates are those of ``camera.to_pixels``: pixel (v, u) covers
[u, u + 1) x [v, v + 1) (OpenCV's pixel centres are at integers: + 0.5).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from .._validation import as_array, is_pair, non_negative, one_of, positive
from ..exceptions import InvalidArrayError, InvalidParameterError

__all__ = ["DETECTION_METHODS", "Blobs", "DetectorSettings", "associate", "detect_blobs"]

DETECTION_METHODS = ("moments", "hough")
_HOUGH_EDGE_THRESHOLD = 100.0  # Canny upper threshold of HoughCircles (OpenCV's default)
_HOUGH_VOTES = 10.0  # accumulator threshold: low, so that discs a few pixels across are found


@dataclass(frozen=True)
class DetectorSettings:
    """How blobs are found and which are kept.

    Attributes:
        method: ``"moments"`` or ``"hough"`` (module docstring).
        polarity: ``"dark"`` markers on a lighter background, or ``"bright"``.
        min_area_px: Smallest blob kept [px^2] (Hough: pi r^2).
        min_contrast_grey: No blobs when Otsu's threshold lies less than half this above the
            background level (an image of noise alone) [grey levels].
        margin_px: Margin around a blob for its centroid and its background [px], an integer
            >= 1; a little more than 3 sigma of the blur keeps the blurred edge inside.
        smoothing_sigma_px: Gaussian smoothing of the copy that is segmented (not of the
            intensities the centroid weighs) [px], >= 0.
        hough_radius_px: (min, max) radius the Hough transform searches [px]; max 0: no limit.

    Raises:
        InvalidParameterError: an unknown method or polarity, a negative area, contrast or
            smoothing, a margin that is not an integer >= 1, a bad radius range.
    """

    method: str = "moments"
    polarity: str = "dark"
    min_area_px: float = 3.0
    min_contrast_grey: float = 20.0
    margin_px: int = 6
    smoothing_sigma_px: float = 1.0
    hough_radius_px: tuple[int, int] = (2, 0)

    def __post_init__(self) -> None:
        one_of(self.method, "method", DETECTION_METHODS)
        one_of(self.polarity, "polarity", ("dark", "bright"))
        for key, unit in (
            ("min_area_px", "[px^2]"),
            ("min_contrast_grey", "[grey levels]"),
            ("smoothing_sigma_px", "[px]"),
        ):
            object.__setattr__(self, key, non_negative(getattr(self, key), key, unit=unit))
        margin = self.margin_px
        if not isinstance(margin, (int, np.integer)) or isinstance(margin, bool) or margin < 1:
            raise InvalidParameterError("margin_px", margin, "an integer >= 1 [px]")
        object.__setattr__(self, "margin_px", int(margin))
        radii = self.hough_radius_px
        ok = is_pair(radii) and all(
            isinstance(r, (int, np.integer)) and not isinstance(r, bool) for r in radii
        )
        if not ok or radii[0] < 1 or radii[1] < 0 or (radii[1] and radii[1] < radii[0]):
            raise InvalidParameterError(
                "hough_radius_px",
                radii,
                "two integers (min, max) [px], 1 <= min, max = 0 (no limit) or max >= min",
            )
        object.__setattr__(self, "hough_radius_px", (int(radii[0]), int(radii[1])))

    def to_dict(self) -> dict[str, Any]:
        """Plain data, e.g. for a run's specification."""
        return {
            "method": self.method,
            "polarity": self.polarity,
            "min_area_px": self.min_area_px,
            "min_contrast_grey": self.min_contrast_grey,
            "margin_px": self.margin_px,
            "smoothing_sigma_px": self.smoothing_sigma_px,
            "hough_radius_px": list(self.hough_radius_px),
        }


@dataclass(frozen=True, eq=False)
class Blobs:
    """Blobs found in one image.

    Attributes:
        centres_px: Centre (u, v) of each blob (k, 2) [px].
        areas_px: Area of each blob (k,) [px^2]: its pixels above half its peak contrast in
            the smoothed image (moments) or pi r^2 (Hough).
    """

    centres_px: np.ndarray
    areas_px: np.ndarray

    def __len__(self) -> int:
        return int(self.areas_px.shape[0])


def check_image(image: Any, name: str = "image") -> np.ndarray:
    """A 2-D uint8 array of at least 8 x 8 pixels, else InvalidArrayError."""
    if (
        not isinstance(image, np.ndarray)
        or image.dtype != np.uint8
        or image.ndim != 2
        or min(image.shape) < 8
    ):
        received = (
            f"an array of shape {image.shape} and dtype {image.dtype}"
            if isinstance(image, np.ndarray)
            else type(image).__name__
        )
        raise InvalidArrayError(name, received, "a 2-D uint8 grayscale image of at least 8 x 8 pixels")
    return image


def detect_blobs(image: Any, settings: DetectorSettings | None = None) -> Blobs:
    """Centres and areas of the marker blobs in a grayscale image (uint8, (height, width)).

    Raises:
        InvalidArrayError: not a 2-D uint8 image of at least 8 x 8 pixels.
        InvalidParameterError: settings that are not DetectorSettings.
    """
    image = check_image(image)
    settings = DetectorSettings() if settings is None else settings
    if not isinstance(settings, DetectorSettings):
        raise InvalidParameterError("settings", type(settings).__name__, "a DetectorSettings or None")
    work = image if settings.polarity == "bright" else cv2.bitwise_not(image)  # markers bright
    smooth = work
    if settings.smoothing_sigma_px > 0.0:
        sigma = settings.smoothing_sigma_px
        smooth = cv2.GaussianBlur(work, (0, 0), sigma, sigmaY=sigma, borderType=cv2.BORDER_REPLICATE)
    if settings.method == "hough":
        return _hough(smooth, settings)
    return _moments(work, smooth, settings)


def _moments(work: np.ndarray, smooth: np.ndarray, settings: DetectorSettings) -> Blobs:
    """Otsu, contours, and the grey-level centroid of each blob (module docstring)."""
    threshold, binary = cv2.threshold(smooth, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    histogram = cv2.calcHist([smooth], [0], None, [256], [0, 256]).ravel()
    background = float(np.searchsorted(np.cumsum(histogram), 0.5 * histogram.sum()))  # median level
    if threshold - background < 0.5 * settings.min_contrast_grey:
        return Blobs(np.empty((0, 2)), np.empty(0))
    contours, _ = cv2.findContours(binary, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    height, width = work.shape
    m = settings.margin_px
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * m + 1, 2 * m + 1))
    centres, areas = [], []
    for contour in contours:
        x, y, w, h = cv2.boundingRect(contour)
        if x < m or y < m or x + w + m > width or y + h + m > height:
            continue  # the blob or its blurred edge reaches the border
        x0, y0 = x - m, y - m
        fill = np.zeros((h + 2 * m, w + 2 * m), dtype=np.uint8)
        cv2.drawContours(fill, [contour], -1, 255, thickness=cv2.FILLED, offset=(-x0, -y0))
        if cv2.countNonZero(fill) < settings.min_area_px:
            continue
        support = cv2.dilate(fill, kernel)
        window = (slice(y0, y0 + h + 2 * m), slice(x0, x0 + w + 2 * m))
        others = cv2.countNonZero(
            cv2.bitwise_and(binary[window], cv2.bitwise_and(support, cv2.bitwise_not(fill)))
        )
        if others > 0:
            continue  # another blob within the margin
        outside = support == 0
        raw, smoothed = work[window], smooth[window]
        local = float(np.median(raw[outside])) if outside.sum() >= 8 else background
        weights = (raw.astype(np.float32) - np.float32(local)) * (support > 0)
        moments = cv2.moments(weights)
        if moments["m00"] <= 0.0:
            continue
        # area at half the blob's peak contrast: unlike the area at Otsu's threshold, nearly
        # independent of the blur for discs wider than the blur
        local_smooth = float(np.median(smoothed[outside])) if outside.sum() >= 8 else background
        half = 0.5 * (local_smooth + float(smoothed[fill > 0].max()))
        area = int(np.count_nonzero((smoothed >= half) & (support > 0)))
        if area < settings.min_area_px:
            continue
        centres.append(
            (x0 + moments["m10"] / moments["m00"] + 0.5, y0 + moments["m01"] / moments["m00"] + 0.5)
        )
        areas.append(float(area))
    return Blobs(np.array(centres, dtype=float).reshape(-1, 2), np.array(areas, dtype=float))


def _hough(smooth: np.ndarray, settings: DetectorSettings) -> Blobs:
    """``cv2.HoughCircles`` (HOUGH_GRADIENT, 1 px accumulator) on the smoothed image."""
    r_min, r_max = settings.hough_radius_px
    circles = cv2.HoughCircles(
        smooth,
        cv2.HOUGH_GRADIENT,
        dp=1.0,
        minDist=max(4.0, 2.0 * r_min),
        param1=_HOUGH_EDGE_THRESHOLD,
        param2=_HOUGH_VOTES,
        minRadius=r_min,
        maxRadius=r_max,
    )
    if circles is None:
        return Blobs(np.empty((0, 2)), np.empty(0))
    c = circles.reshape(-1, 3).astype(float)
    height, width = smooth.shape
    m = settings.margin_px
    keep = (
        (np.pi * c[:, 2] ** 2 >= settings.min_area_px) & (c[:, 0] - c[:, 2] >= m) & (c[:, 1] - c[:, 2] >= m)
    )
    keep &= (c[:, 0] + c[:, 2] <= width - m) & (c[:, 1] + c[:, 2] <= height - m)
    c = c[keep]
    return Blobs(c[:, :2] + 0.5, np.pi * c[:, 2] ** 2)


def associate(
    blobs: Blobs,
    predicted_px: Any,
    gate_px: Any,
    predicted_area_px: Any = None,
    area_tolerance: float = 0.5,
) -> np.ndarray:
    """For each of n markers, the index of its blob, or -1 when it is missing or ambiguous.

    A blob is a candidate of marker i when it lies within ``gate_px[i]`` of the predicted
    centre and, with predicted areas, when its area is within a factor ``1 + area_tolerance``
    of the prediction (either way). Marker i gets a blob only when it has exactly one
    candidate and that blob is a candidate of no other marker.

    Args:
        blobs: From :func:`detect_blobs`.
        predicted_px: Predicted centres (n, 2) [px]; NaN rows are markers not expected.
        gate_px: Gate radius per marker (n,) or one for all [px], > 0.
        predicted_area_px: Predicted areas (n,) [px^2], or None to skip the area test.
        area_tolerance: > 0.

    Raises:
        InvalidArrayError, InvalidParameterError: shapes that do not agree, a gate <= 0.
    """
    predicted = as_array(predicted_px, "predicted_px", (None, 2), finite=False)
    n = predicted.shape[0]
    gate = as_array(gate_px, "gate_px")
    gate = np.full(n, float(gate)) if gate.ndim == 0 else as_array(gate, "gate_px", (n,))
    if np.any(gate <= 0.0):
        raise InvalidParameterError("gate_px", gate.tolist(), "gate radii > 0 px")
    tolerance = 1.0 + positive(area_tolerance, "area_tolerance")
    distance = np.linalg.norm(blobs.centres_px[None, :, :] - predicted[:, None, :], axis=2)  # (n, k)
    candidate = distance <= gate[:, None]  # NaN predictions compare False
    if predicted_area_px is not None:
        area = as_array(predicted_area_px, "predicted_area_px", (n,), finite=False)
        ratio = blobs.areas_px[None, :] / area[:, None]
        candidate &= (ratio <= tolerance) & (ratio >= 1.0 / tolerance)
    index = np.full(n, -1, dtype=int)
    per_marker, per_blob = candidate.sum(axis=1), candidate.sum(axis=0)
    for i in np.flatnonzero(per_marker == 1):
        k = int(np.flatnonzero(candidate[i])[0])
        if per_blob[k] == 1:
            index[i] = k
    return index
