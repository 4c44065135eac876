"""The image of a disc marker: its exact conic, its ellipse, and the perspective bias of its centre.

A flat disc of radius r [m], centred at c (camera frame {C}) with unit normal n, seen by a
pinhole lens at x_C = x0 (Eq. (9)-(10), ERRATA 12) images to an ellipse when the whole disc lies
in front of the lens and faces it. With an orthonormal basis (a, b) of the disc's plane, the
plane -> image homography is ``H = K [a, b, c - (x0, 0, 0)]`` (K of Eq. (6), in the pixel
coordinates of :meth:`~ibvs_youla.model.camera.StereoCamera.to_pixels`: pixel i covers
[i, i + 1)), and the disc ``s^2 + t^2 <= r^2``, the conic ``Q = diag(1, 1, -r^2)``, maps to the
image conic ``C = H^-T Q H^-1`` (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed.,
Sec. 2.2.3): a pixel point ``x = (u, v, 1)`` is inside the image of the disc when
``x^T C x < 0``. Its dual ``C^-1 = H Q^-1 H^T`` gives the ellipse's centre (the pole of the
line at infinity) and its bounding box (the tangent lines u = const and v = const) without
solving for the ellipse's axes.

**Perspective bias.** The ellipse's centre is not the image of the disc's centre c. To first
order in r / Z, in normalized image coordinates (x, y) = (X, Y) / Z of the lens,

    centre - c_xy / Z = (r / Z)^2 [ n_z n_xy + (1 - n_z^2) c_xy / Z ],        (B)

with c and n relative to the lens (the lens offset moves c_x only). Derivation: the ellipse
is symmetric, so its centre is its area centroid; the centroid of the image of the disc,
expanded to second order in the plane coordinates (s, t) with the area element
``dA_image ∝ w^-3 ds dt`` (w the homogeneous depth, ``w = Z (1 + l)``,
``l = (a_z s + b_z t) / Z``), is the image of c plus ``-4 <l d> / <1>`` over the disc, d the
first-order image displacement; ``a a^T + b b^T = I - n n^T`` turns that into (B). A disc
facing along the optical axis (n = ±e_z) has no first-order bias anywhere in the image; a
disc facing the lens (n along -c) has bias ``(r / Z)^2 c_xy / Z``, radial. The odd orders
vanish over the disc by symmetry, so the residual is O((r / Z)^4): below 0.54 F (r / Z)^4 for
tilts up to 60 deg, 6e-4 px for a 5 cm disc at 0.5-3 m on the ZED 2 model
(tests/test_disc_image.py compares (B) with the exact conic centre).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .camera import MIN_ABS_DEPTH, PinholeCamera, StereoCamera

__all__ = ["DiscImage", "disc_images", "perspective_bias"]


@dataclass(frozen=True, eq=False)
class DiscImage:
    """The image of n discs in each of k lenses (k = 2 stereo, in feature order [left, right]; 1 pinhole).

    Entries of a disc that is not drawable in a lens are NaN (``drawable`` False there).

    Attributes:
        conic_px: Image conic C of each disc (k, n, 3, 3) in pixel coordinates, scaled to unit
            Frobenius norm, inside where ``x^T C x < 0``.
        centre_px: Centre (u, v) of each ellipse (k, n, 2) [px].
        area_px: Area of each ellipse (k, n) [px^2].
        axes_px: Semi-major and semi-minor axis of each ellipse (k, n, 2) [px].
        box_px: Bounding box (u_min, u_max, v_min, v_max) of each ellipse (k, n, 4) [px].
        drawable: The whole disc lies in front of the lens (every point at Z_C >= MIN_ABS_DEPTH)
            and faces it (n . (lens - c) > 0), so that its image is an ellipse (k, n).
    """

    conic_px: np.ndarray
    centre_px: np.ndarray
    area_px: np.ndarray
    axes_px: np.ndarray
    box_px: np.ndarray
    drawable: np.ndarray


def _cross(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The cross product x x y of two 3-vectors (np.cross costs ~20x more on one pair)."""
    return np.array([x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]])


def _plane_basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An orthonormal basis (a, b) of the plane normal to the unit vector n, with a x b = n."""
    a = _cross(np.eye(3)[int(np.argmin(np.abs(n)))], n)
    a /= np.sqrt(a.dot(a))
    return a, _cross(n, a)


def disc_images(
    camera: StereoCamera | PinholeCamera, centres_C: np.ndarray, normals_C: np.ndarray, radius: float
) -> DiscImage:
    """Image conics, centres, areas and bounding boxes of discs in every lens of a camera.

    Does not validate its input (callers do): ``centres_C`` (n, 3) [m] and ``normals_C`` (n, 3)
    unit vectors (the side each disc is seen from) in {C}, ``radius`` > 0 [m].
    """
    K = camera.intrinsic_matrix()
    lenses = camera.lens_x
    k, n = len(lenses), centres_C.shape[0]
    conic = np.full((k, n, 3, 3), np.nan)
    centre = np.full((k, n, 2), np.nan)
    area = np.full((k, n), np.nan)
    axes = np.full((k, n, 2), np.nan)
    box = np.full((k, n, 4), np.nan)
    drawable = np.zeros((k, n), dtype=bool)
    Q_dual = np.diag([1.0, 1.0, -1.0 / radius**2])
    Q = np.diag([1.0, 1.0, -(radius**2)])
    for j in range(n):
        c, normal = centres_C[j], normals_C[j]
        a, b = _plane_basis(normal)
        z_min = c[2] - radius * np.sqrt(max(0.0, 1.0 - normal[2] ** 2))  # nearest point of the disc [m]
        for i, x0 in enumerate(lenses):
            c_lens = c - (x0, 0.0, 0.0)
            if z_min < MIN_ABS_DEPTH or normal.dot(-c_lens) <= 0.0:
                continue
            H = K.dot(np.column_stack((a, b, c_lens)))
            D = H.dot(Q_dual).dot(H.T)  # dual conic C^-1
            H_inv = np.linalg.inv(H)
            C = H_inv.T.dot(Q).dot(H_inv)  # the image conic H^-T Q H^-1
            A = C[:2, :2]
            det_A = A[0, 0] * A[1, 1] - A[0, 1] ** 2
            if not (det_A > 0.0 and A[0, 0] > 0.0):  # not a real ellipse (edge-on to round-off)
                continue
            u_c, v_c = D[0, 2] / D[2, 2], D[1, 2] / D[2, 2]
            f0 = np.array([u_c, v_c, 1.0]).dot(C).dot([u_c, v_c, 1.0])
            half_u = np.sqrt(max(0.0, D[0, 2] ** 2 - D[0, 0] * D[2, 2])) / abs(D[2, 2])
            half_v = np.sqrt(max(0.0, D[1, 2] ** 2 - D[1, 1] * D[2, 2])) / abs(D[2, 2])
            scale = np.linalg.norm(C)
            conic[i, j] = C / scale
            centre[i, j] = (u_c, v_c)
            area[i, j] = np.pi * abs(f0) / np.sqrt(det_A)
            axes[i, j] = np.sqrt(abs(f0) / np.linalg.eigvalsh(A))  # eigenvalues ascending: major first
            box[i, j] = (u_c - half_u, u_c + half_u, v_c - half_v, v_c + half_v)
            drawable[i, j] = True
    return DiscImage(conic, centre, area, axes, box, drawable)


def perspective_bias(
    camera: StereoCamera | PinholeCamera, centres_C: np.ndarray, normals_C: np.ndarray, radius: float
) -> np.ndarray:
    """First-order offset of each ellipse centre from the image of its disc's centre, Eq. (B) above.

    Returns the offsets as feature rows (n, k + 1) [m on the sensor]: [du_l, du_r, dv] per disc
    for a stereo camera (the v offsets of both lenses are equal), [du, dv] for a pinhole one; add
    them to :meth:`~ibvs_youla.model.camera.StereoCamera.project` for the predicted ellipse centres,
    or pass them through K (``camera.to_pixels(p + d) - camera.to_pixels(p)``) for pixels.
    Does not validate its input (as :func:`disc_images`).
    """
    F = camera.focal_length
    X, Y, Z = centres_C[:, 0], centres_C[:, 1], centres_C[:, 2]
    n_x, n_y, n_z = normals_C[:, 0], normals_C[:, 1], normals_C[:, 2]
    k2 = F * (radius / Z) ** 2  # [m on the sensor]
    tilt = 1.0 - n_z**2
    columns = [k2 * (n_z * n_x + tilt * (X - x0) / Z) for x0 in camera.lens_x]
    columns.append(k2 * (n_z * n_y + tilt * Y / Z))
    return np.column_stack(columns)
