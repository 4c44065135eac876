"""Photometric visual servoing: the luminance of every pixel as the feature, a Levenberg-Marquardt law.

Collewet & Marchand, "Photometric visual servoing", IEEE T-RO 27(4), 2011 (first in Collewet,
Marchand & Chaumette, ICRA 2008). The feature is the image itself, I = (I(x_1), ..., I(x_N)),
the grey levels of the N pixels more than :data:`~ibvs_youla.model.luminance.BORDER_PX` from the
image's edge; its interaction matrix L_I stacks one row (L1) per pixel
(:mod:`~ibvs_youla.model.luminance`). The camera twist minimizes the cost ||I - I*||^2 by a
Levenberg-Marquardt step:

    v = -lambda (H + mu diag(H))^-1 L_I^T (I - I*),   H = L_I^T L_I                         (P1)

with L_I = L_I* evaluated once at the target: the gradients of the target image I* and the
depths of the pixels at the target pose, as ViSP's ``photometricVisualServoing`` example
(Collewet and Marchand's own code) does. H and its diagonal are then constant, and each frame
costs a render, a subtraction and L_I*^T e (6 N multiply-adds) and a 6 x 6 solve.

**Parameters** (defaults from that example, which the paper's text describes but that could not
be checked against the paper here): gain lambda = 30 1/s (its camera runs at 25 Hz, 0.04 s:
lambda T = 1.2 per frame); mu = 0.01 for the first 90 frames, then 1e-4 ("switch to Gauss-Newton
after 90 iterations": a damped start far from the target, nearly Gauss-Newton near it).

**Depths**: the paper and ViSP's ``vpFeatureLuminance`` take one depth Z for every pixel (1 m in
the example, where the plane faces the target camera). Here each pixel gets the depth (T3) of
the plane the controller believes in (``task.scene``) seen from the target pose: the same
number when the plane faces the target camera, as in every scenario here, and the exact depth
when it does not.

**What it needs**: a monocular :class:`~ibvs_youla.model.camera.PinholeCamera` with pixels (the
feature is one image; a stereo pair would stack a second L_I in the other lens's frame, which
the paper does not do), a scenario with a scene (``Scenario(scene=TexturedPlane(...))``; the
point markers alone give no image) that the target camera sees on every pixel of the feature.
The markers of the scenario are not used by the law; they are what the comparison metrics
(feature excursion, markers in view) are computed on.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validation import integer, non_negative, positive
from ..exceptions import InvalidParameterError
from ..model.camera import PinholeCamera, check_camera_has_pixels, pixel_centres_normalized
from ..model.luminance import BORDER_PX, image_gradients, luminance_interaction_matrix
from ..model.textured_plane import plane_depths
from .base import CameraFrame, CommandType, Controller, JointReading, ServoTask

__all__ = ["GAIN", "MU_FINAL", "MU_INITIAL", "MU_SWITCH_FRAMES", "REGISTRATIONS", "PhotometricVS"]

GAIN = 30.0  # lambda [1/s] of ViSP's photometricVisualServoing example (0.04 s frames)
MU_INITIAL = 0.01  # mu of (P1) for the first MU_SWITCH_FRAMES frames
MU_FINAL = 1e-4  # mu after them (nearly Gauss-Newton)
MU_SWITCH_FRAMES = 90  # frames of MU_INITIAL


class PhotometricVS(Controller):
    """Photometric visual servoing, (P1) with L_I at the target (module docstring).

    Args:
        gain: lambda [1/s], > 0.
        mu_initial: mu of the first ``mu_switch_frames`` frames, >= 0.
        mu_final: mu afterwards, >= 0.
        mu_switch_frames: Frames at ``mu_initial`` (an integer >= 0; 0: ``mu_final`` throughout).

    Raises:
        InvalidParameterError: a parameter out of range; at reset, a camera that is not a
            PinholeCamera with pixels at least 2 BORDER_PX + 1 a side, a task without a scene or a
            target image, a target image of another size than the camera's, or a target camera
            that does not see the plane on every pixel of the feature.
    """

    command_type = CommandType.CAMERA_TWIST
    name = "photometric"
    needs_image = True

    def __init__(
        self,
        gain: float = GAIN,
        mu_initial: float = MU_INITIAL,
        mu_final: float = MU_FINAL,
        mu_switch_frames: int = MU_SWITCH_FRAMES,
    ) -> None:
        self.gain = positive(gain, "gain", unit="1/s")
        self.mu_initial = non_negative(mu_initial, "mu_initial")
        self.mu_final = non_negative(mu_final, "mu_final")
        self.mu_switch_frames = integer(mu_switch_frames, "mu_switch_frames", low=0)
        self._twist = np.zeros(6)
        self._signals = {"luminance_rms": np.zeros(1), "lm_mu": np.zeros(1)}

    def spec(self) -> dict[str, Any]:
        """Gain, the mu schedule, the border and where L_I is evaluated."""
        return {
            **super().spec(),
            "gain": self.gain,
            "mu_initial": self.mu_initial,
            "mu_final": self.mu_final,
            "mu_switch_frames": self.mu_switch_frames,
            "border_px": BORDER_PX,
            "interaction": "desired",
        }

    # ------------------------------------------------------------------ run
    def reset(self, task: ServoTask) -> None:
        """Check the task; build L_I* from the target image and the believed plane, and the two steps."""
        camera = task.camera
        if not isinstance(camera, PinholeCamera):
            raise InvalidParameterError(
                "task.camera",
                type(camera).__name__,
                "a PinholeCamera with pixels: photometric servoing here is monocular (its feature is "
                "one image; a stereo pair would need a second L_I in the other lens's frame, which the "
                "paper does not do)",
            )
        check_camera_has_pixels(camera)
        width, height = camera.resolution
        if min(width, height) <= 2 * BORDER_PX:
            raise InvalidParameterError(
                "task.camera",
                f"{width} x {height} px",
                f"more than {2 * BORDER_PX} pixels a side (the feature leaves out {BORDER_PX} px along "
                "each edge)",
            )
        if task.scene is None or task.image_target is None:
            raise InvalidParameterError(
                "task",
                "a task without a scene or target image",
                "a task with the scene and the target image: photometric servoing needs a scenario with "
                "a scene, Scenario(..., scene=TexturedPlane(...))",
            )
        if task.image_target.shape != (height, width):
            raise InvalidParameterError(
                "task.image_target",
                f"an image of shape {task.image_target.shape}",
                f"the camera's ({height}, {width})",
            )
        inner = (slice(BORDER_PX, height - BORDER_PX), slice(BORDER_PX, width - BORDER_PX))
        Z = plane_depths(camera, task.scene, task.T_O_C_target)[inner]
        if not np.all(np.isfinite(Z)):
            raise InvalidParameterError(
                "task.scene",
                f"a plane that {np.count_nonzero(~np.isfinite(Z))} pixels of the target image do not see",
                "a scene the target camera sees on every pixel of the feature",
            )
        super().reset(task)
        I_x, I_y = image_gradients(task.image_target, camera)
        x, y = pixel_centres_normalized(camera)
        L = luminance_interaction_matrix(
            I_x[inner].ravel(), I_y[inner].ravel(), x[inner].ravel(), y[inner].ravel(), Z.ravel()
        )
        H = L.T.dot(L)
        D = np.diag(np.diag(H))
        self._inner = inner
        self._L_target_T = np.ascontiguousarray(L.T)  # (6, N)
        self._image_target = np.asarray(task.image_target, dtype=np.float64)[inner]
        # (H + mu diag(H))^-1 for the two values of mu: constant, so inverted once (ViSP: inverseByLU)
        self._steps = {mu: np.linalg.inv(H + mu * D) for mu in {self.mu_initial, self.mu_final}}
        self._frames = 0
        self._twist = np.zeros(6)
        self._signals = {"luminance_rms": np.zeros(1), "lm_mu": np.zeros(1)}

    def interaction_matrix(self) -> np.ndarray:
        """L_I* (N, 6) of (L1) at the target, one row per pixel of the feature (row-major)."""
        return self._L_target_T.T.copy()

    def mu(self, frame_index: int) -> float:
        """The mu of (P1) at the frame of that index (0 the first): the schedule of the class docstring."""
        return self.mu_initial if frame_index < self.mu_switch_frames else self.mu_final

    def update(self, frame: CameraFrame, reading: JointReading | None) -> None:
        """One frame: the twist (P1) from the frame's image.

        Raises:
            InvalidParameterError: a frame without an image, or of another size (a sensor that
                does not render the scene).
        """
        image = frame.image
        if image is None or image.shape != self.task.image_target.shape:
            raise InvalidParameterError(
                "frame.image",
                None if image is None else f"an image of shape {image.shape}",
                f"the camera's image, shape {self.task.image_target.shape} (a sensor that renders the scene)",
            )
        e = (image[self._inner] - self._image_target).ravel()  # float64 (float32 - float64), contiguous
        mu = self.mu(self._frames)
        self._frames += 1
        self._twist = -self.gain * self._steps[mu].dot(self._L_target_T.dot(e))
        self._signals = {"luminance_rms": np.array([np.sqrt(e.dot(e) / e.size)]), "lm_mu": np.array([mu])}

    def command(self, reading: JointReading | None) -> np.ndarray:
        """The twist [v; w] of the last frame [m/s, rad/s] (zero before the first)."""
        return self._twist

    def signals(self) -> dict[str, np.ndarray]:
        """``luminance_rms`` (1,): RMS of I - I* of the last frame [grey levels]; ``lm_mu`` (1,): its mu."""
        return self._signals


def _photometric(
    gain: float = GAIN,
    mu_initial: float = MU_INITIAL,
    mu_final: float = MU_FINAL,
    mu_switch_frames: int = MU_SWITCH_FRAMES,
) -> PhotometricVS:
    return PhotometricVS(gain, mu_initial, mu_final, mu_switch_frames)


REGISTRATIONS = (
    (
        "photometric",
        _photometric,
        "photometric visual servoing: the luminance of every pixel, a Levenberg-Marquardt law "
        "(Collewet & Marchand 2011; needs a textured scene and a monocular camera with pixels)",
    ),
)
