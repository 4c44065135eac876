"""The image sensor: every frame rendered as images, the markers detected in them, their centres fed back.

It has the interface of :class:`~ibvs_youla.simulation.sensor.MarkerSensor` (``measure``,
``features_at``, ``n_points``, ...) and wraps one: the true camera and markers come from it.
Each frame (:meth:`ImageSensor.observe`):

1. **render** the markers seen from the true camera pose (:mod:`.rendering`): one grayscale
   image per lens at the camera's resolution, discs of a stated diameter, blur and seeded noise;
2. **detect** blobs in each image (:func:`~ibvs_youla.estimation.marker_detection.detect_blobs`);
3. **match each image's blobs to the markers** (:func:`~ibvs_youla.estimation.marker_detection.associate`)
   by the markers' known geometry: the predicted position of marker i is the centre of the
   ellipse its disc makes from the true pose (the image a perfect motion prediction of a
   tracker would expect), its gate ``1 px + gate_fraction`` x the ellipse's equivalent radius,
   its predicted area that ellipse's. Association is thereby ideal; what this sensor measures is
   the error of the detected centres, not of a tracker. Markers whose predicted images come
   within the detector's margin of each other in a lens (one occludes or touches the other)
   are ambiguous there and reported missing;
4. **match left to right** (a stereo camera): the rectified pair of Eq. (9)-(10) puts a point
   on the same row of both images, so a marker found in both is kept only when its rows agree
   within ``row_tolerance_px`` and its disparity u_r - u_l is positive; its v is the mean of the
   two rows;
5. convert the pixel centres to features ([u_l, u_r, v] or [u, v], metres on the sensor,
   ``camera.from_pixels``).

A marker that is not found, ambiguous, or inconsistent between the lenses is **missing**: its
visibility flag is False, and its features are those :class:`MarkerSensor` gives a marker
out of view (``missing="projection"``: the projection of its centre, which every controller
here uses regardless of the flag), the last features detected for it (``missing="hold"``;
the projection until it was first detected), or NaN (``missing="nan"``: nothing the images did
not show; a controller wrapped in
:class:`~ibvs_youla.simulation.disturbances.policy.HoldOnMissingFeatures` then withholds the
frame, as ``Disturbances(rendered_images=True)`` does). What a method does with such a frame is
that policy's, not this sensor's.

The goal features (``features_at``, used for the target) are the true projections, as with
:class:`MarkerSensor`: the images change what the controller measures, not what it is asked
to reach. The true camera losing a marker (behind it, without virtual points) still ends a run
as ``"markers_lost"``: ``measure`` raises as :class:`MarkerSensor` does.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validation import non_negative, one_of, positive
from ..controllers.base import CameraFrame
from ..estimation.marker_detection import Blobs, DetectorSettings, associate, detect_blobs
from ..exceptions import InvalidParameterError
from ..model.camera import StereoCamera, project_points
from .rendering import DiscMarkers, ImagingSettings, RenderedFrame, check_camera_has_pixels, render_unchecked
from .sensor import MarkerSensor

__all__ = ["MISSING_POLICIES", "ImageObservation", "ImageSensor"]

MISSING_POLICIES = ("projection", "hold", "nan")


@dataclass(frozen=True, eq=False)
class ImageObservation:
    """One frame of the image sensor, with what it was made from.

    Attributes:
        frame: The rendered images and the discs' true image geometry.
        blobs: The blobs detected in each image (one per lens).
        blob_index: Per lens and marker (k, n), the blob matched to the marker, -1 if none.
        features: Features handed to the controller (n (k + 1),) [m on the sensor].
        visible: Per marker (n,): found, unambiguous, and (stereo) consistent across the lenses.
        features_true: Projections of the markers' centres (n (k + 1),) [m on the sensor].
    """

    frame: RenderedFrame
    blobs: tuple[Blobs, ...]
    blob_index: np.ndarray
    features: np.ndarray
    visible: np.ndarray
    features_true: np.ndarray


class ImageSensor:
    """Features detected in rendered images of disc markers (module docstring).

    Args:
        truth: The ideal sensor: the true camera (with pixels) and markers.
        markers: Size, facing and grey levels of the discs; default 5 cm discs facing the camera.
        imaging: Blur, noise (seeded by ``imaging.seed``) and supersampling; default none.
        detector: Detector settings; default the moments detector.
        missing: ``"projection"``, ``"hold"`` or ``"nan"``: the features of a missing marker.
        row_tolerance_px: Largest |v_l - v_r| of a marker's two detections [px], >= 0.
        gate_fraction: Association gate beyond 1 px, in equivalent radii of the predicted
            ellipse, >= 0.
        area_tolerance: A blob's area may differ from the predicted ellipse's by this factor
            + 1, > 0 (blur widens small blobs: at a 2 px blur the half-maximum area of a 6 px
            disc is 1.6-2x its own; overlapping markers are caught by their geometry instead).

    Raises:
        InvalidParameterError: ``truth`` not a MarkerSensor, a camera without pixels
            (``PinholeCamera.normalized()``), settings of the wrong type, per-marker normals
            for another number of markers, a negative tolerance, an unknown policy.
    """

    def __init__(
        self,
        truth: MarkerSensor,
        markers: DiscMarkers | None = None,
        imaging: ImagingSettings | None = None,
        detector: DetectorSettings | None = None,
        *,
        missing: str = "projection",
        row_tolerance_px: float = 1.5,
        gate_fraction: float = 0.5,
        area_tolerance: float = 2.0,
    ) -> None:
        if not isinstance(truth, MarkerSensor):
            raise InvalidParameterError(
                "truth", type(truth).__name__, "a MarkerSensor (the true camera and markers)"
            )
        check_camera_has_pixels(truth.camera)
        for name, value, kind in (
            ("markers", markers, DiscMarkers),
            ("imaging", imaging, ImagingSettings),
            ("detector", detector, DetectorSettings),
        ):
            if value is not None and not isinstance(value, kind):
                raise InvalidParameterError(name, type(value).__name__, f"a {kind.__name__} or None")
        self.truth = truth
        self.markers = DiscMarkers() if markers is None else markers
        if self.markers.normals_O is not None and self.markers.normals_O.shape[0] not in (1, truth.n_points):
            raise InvalidParameterError(
                "markers.normals_O",
                f"{self.markers.normals_O.shape[0]} normals",
                f"None, one normal, or one per marker ({truth.n_points})",
            )
        self.imaging = ImagingSettings() if imaging is None else imaging
        self.detector = DetectorSettings() if detector is None else detector
        self.missing = one_of(missing, "missing", MISSING_POLICIES)
        self.row_tolerance_px = non_negative(row_tolerance_px, "row_tolerance_px", unit="[px]")
        self.gate_fraction = non_negative(gate_fraction, "gate_fraction")
        self.area_tolerance = positive(area_tolerance, "area_tolerance")
        self.rng = np.random.default_rng(self.imaging.seed)
        self._held: np.ndarray | None = None  # last features handed out ("hold")

    # -- the MarkerSensor interface
    @property
    def camera(self) -> Any:
        """The true camera."""
        return self.truth.camera

    @property
    def markers_O(self) -> np.ndarray:
        """True marker positions (n, 3) in the base frame [m]."""
        return self.truth.markers_O

    @property
    def virtual_points(self) -> bool:
        """Markers may lie behind the camera (they are then simply not in the images)."""
        return self.truth.virtual_points

    @property
    def n_points(self) -> int:
        """Number of markers n."""
        return self.truth.n_points

    @property
    def features_per_point(self) -> int:
        """3 for a stereo camera ([u_l, u_r, v]), 2 for a monocular one ([u, v])."""
        return self.truth.features_per_point

    def features_at(self, T_O_C: Any) -> np.ndarray:
        """The true projections seen from T_O_C (the goal; module docstring)."""
        return self.truth.features_at(T_O_C)

    def measure(self, T_O_C: np.ndarray, t: float) -> CameraFrame:
        """One frame detected in images rendered from the true camera pose T_O_C (4, 4).

        Raises:
            PointBehindCameraError: as ``MarkerSensor.measure``.
        """
        observation = self.observe(T_O_C)
        return CameraFrame(t, observation.features, observation.visible)

    def spec(self) -> dict[str, Any]:
        """Plain data describing the sensor, stored with a run."""
        return {
            "name": "images",
            "markers": self.markers.to_dict(),
            "imaging": self.imaging.to_dict(),
            "detector": self.detector.to_dict(),
            "missing": self.missing,
            "row_tolerance_px": self.row_tolerance_px,
            "gate_fraction": self.gate_fraction,
            "area_tolerance": self.area_tolerance,
        }

    # -- one frame
    def observe(self, T_O_C: np.ndarray) -> ImageObservation:
        """Render, detect and match one frame from the true pose T_O_C (4, 4) (unchecked, as ``measure``)."""
        truth, camera = self.truth, self.truth.camera
        P_C = truth.points_in_camera(T_O_C)
        features_true = project_points(camera, P_C, truth.virtual_points)
        normals_C = self.markers.normals_C(P_C, T_O_C[:3, :3])
        frame = render_unchecked(camera, self.markers, P_C, normals_C, self.imaging, self.rng)
        blobs = tuple(detect_blobs(image, self.detector) for image in frame.images)
        index = np.array([self._match(frame, lens, blobs[lens]) for lens in range(len(blobs))])
        n, per = truth.n_points, truth.features_per_point
        found = np.all(index >= 0, axis=0)
        pixels = np.full((n, per), np.nan)
        for j in np.flatnonzero(found):
            centres = [blobs[lens].centres_px[index[lens, j]] for lens in range(len(blobs))]
            if isinstance(camera, StereoCamera):
                (u_l, v_l), (u_r, v_r) = centres
                if abs(v_l - v_r) > self.row_tolerance_px or u_r - u_l <= 0.0:
                    found[j] = False  # off the epipolar line, or a negative disparity
                    continue
                pixels[j] = (u_l, u_r, 0.5 * (v_l + v_r))
            else:
                pixels[j] = centres[0]
        fallback = features_true.reshape(n, per)
        if self.missing == "hold" and self._held is not None:
            fallback = self._held
        elif self.missing == "nan":
            fallback = np.full((n, per), np.nan)
        features = fallback.copy()
        if found.any():
            features[found] = camera.from_pixels(pixels[found])
        if self.missing == "hold":
            self._held = features
        return ImageObservation(frame, blobs, index, features.reshape(-1), found, features_true)

    def _match(self, frame: RenderedFrame, lens: int, blobs: Blobs) -> np.ndarray:
        """Blob index of each marker in one lens (-1: missing), by the predicted ellipses."""
        discs = frame.discs
        predicted = np.where(frame.drawn[lens][:, None], discs.centre_px[lens], np.nan)
        area = discs.area_px[lens]
        radius = np.sqrt(area / np.pi)  # equivalent radius [px]
        gate = np.where(np.isfinite(radius), 1.0 + self.gate_fraction * radius, 1.0)
        index = associate(blobs, predicted, gate, area, self.area_tolerance)
        # markers whose images (circles of the semi-major axis) come within the detector's margin of another's
        reach = discs.axes_px[lens, :, 0] + self.detector.margin_px
        gap = (
            np.linalg.norm(predicted[:, None, :] - predicted[None, :, :], axis=2)
            - reach[:, None]
            - reach[None, :]
        )
        np.fill_diagonal(gap, np.inf)
        crowded = np.any(gap < 0.0, axis=1)  # NaN (undrawn) compares False
        index[crowded] = -1
        return index
