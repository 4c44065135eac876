"""The luminance feature of photometric visual servoing: image gradients and the interaction matrix.

Collewet & Marchand, "Photometric visual servoing", IEEE T-RO 27(4), 2011 (and Collewet,
Marchand & Chaumette, ICRA 2008): the feature is the grey level I(x) of every pixel x = (x, y)
(normalized coordinates). Under the temporal luminance constancy of a Lambertian scene,
dI/dt = -grad I . dx/dt, and a static point's image moves as dx/dt = L_x v (the point's
interaction matrix, Chaumette & Hutchinson 2006, Eq. (11)), so each pixel has the row

    L_I = -(I_x L_x + I_y L_y)
        = [I_x / Z,  I_y / Z,  -(x I_x + y I_y) / Z,
           -x y I_x - (1 + y^2) I_y,  (1 + x^2) I_x + x y I_y,  x I_y - y I_x]          (L1)

with I_x, I_y the image gradient in grey levels per unit of normalized coordinate and Z the
depth of the point the pixel sees; v = [v; w] is the camera twist in its own frame [m/s, rad/s].
(L1) is ViSP's ``vpFeatureLuminance::interaction`` row for row.

**Gradient** (:func:`image_gradients`): the derivative filter of ViSP's
``vpImageFilter::derivativeFilterX/Y``, the one Collewet and Marchand's code uses,

    dI/du (u) = sum_k c_k (I(u + k) - I(u - k)),  (c_1, c_2, c_3) = (2047, 913, 112) / 8418    (L2)

(exact on a linear ramp: 2 (c_1 + 2 c_2 + 3 c_3) = 1), applied with ``cv2.filter2D`` along the
rows and the columns; the pixel gradient is then mapped to normalized coordinates through the
intrinsic matrix (u = f x + k y + u_0, v = f y + v_0: I_x = f I_u, I_y = k I_u + f I_v, f = F/p
[px]). The filter reaches 3 pixels: pixels within :data:`BORDER_PX` = 10 of the image's edge
are left out of the feature, ViSP's default border.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

__all__ = ["BORDER_PX", "DERIVATIVE_TAPS", "image_gradients", "luminance_interaction_matrix"]

BORDER_PX = 10  # pixels along each edge left out of the feature (ViSP's vpFeatureLuminance default)
DERIVATIVE_TAPS = np.array([2047.0, 913.0, 112.0]) / 8418.0  # c_1, c_2, c_3 of (L2)
_KERNEL_U = np.concatenate((-DERIVATIVE_TAPS[::-1], [0.0], DERIVATIVE_TAPS))[None, :]  # correlation taps


def image_gradients(image: np.ndarray, camera: Any) -> tuple[np.ndarray, np.ndarray]:
    """(I_x, I_y) of (L1) at every pixel (height, width) [grey levels per normalized unit] (module docstring).

    Args:
        image: Grey levels (height, width), any real dtype.
        camera: The pinhole camera whose intrinsics map pixels to normalized coordinates.

    The three pixels along each edge hold the filter's reflected border (``BORDER_REFLECT_101``);
    the feature leaves them out (:data:`BORDER_PX`).
    """
    img = np.asarray(image, dtype=np.float64)
    I_u = cv2.filter2D(img, cv2.CV_64F, _KERNEL_U, borderType=cv2.BORDER_REFLECT_101)
    I_v = cv2.filter2D(img, cv2.CV_64F, _KERNEL_U.T, borderType=cv2.BORDER_REFLECT_101)
    K = camera.intrinsic_matrix()
    f, k = K[0, 0], K[0, 1]
    return f * I_u, k * I_u + K[1, 1] * I_v


def luminance_interaction_matrix(
    I_x: np.ndarray, I_y: np.ndarray, x: np.ndarray, y: np.ndarray, Z: np.ndarray
) -> np.ndarray:
    """L_I (n, 6) of (L1), a row per pixel, from flat arrays (n,) of gradients, coordinates, depths [m]."""
    iz = 1.0 / Z
    L = np.empty((I_x.size, 6))
    L[:, 0] = I_x * iz
    L[:, 1] = I_y * iz
    L[:, 2] = -(x * I_x + y * I_y) * iz
    L[:, 3] = -x * y * I_x - (1.0 + y * y) * I_y
    L[:, 4] = (1.0 + x * x) * I_x + x * y * I_y
    L[:, 5] = x * I_y - y * I_x
    return L
