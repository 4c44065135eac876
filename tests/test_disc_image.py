"""The image of a disc marker: exact conic against closed forms, and the first-order perspective bias."""

from __future__ import annotations

import numpy as np
import pytest

from ibvs_youla.model.camera import PinholeCamera, StereoCamera, default_camera
from ibvs_youla.model.disc_image import disc_images, perspective_bias

CAMERA = default_camera()  # the paper's ZED 2 optics, VGA: F / pitch = 359.77 px
F_PX = CAMERA.focal_length / CAMERA.pixel_pitch


def random_discs(n, seed, max_tilt_deg=60.0):
    """n disc centres (depth 0.5-3 m, in the central view) and normals tilted up to max_tilt from -e_z."""
    rng = np.random.default_rng(seed)
    Z = rng.uniform(0.5, 3.0, n)
    P = np.column_stack([rng.uniform(-0.4, 0.4, (n, 2)) * Z[:, None], Z])
    tilt, angle = np.radians(rng.uniform(0.0, max_tilt_deg, n)), rng.uniform(0.0, 2 * np.pi, n)
    N = np.column_stack([np.sin(tilt) * np.cos(angle), np.sin(tilt) * np.sin(angle), -np.cos(tilt)])
    return P, N


def ellipse_centres_as_features(images):
    """Exact ellipse centres as stereo feature rows [u_l, u_r, v] [px]."""
    return np.column_stack([images.centre_px[0, :, 0], images.centre_px[1, :, 0], images.centre_px[0, :, 1]])


def test_lens_x_is_the_erratum_12_layout():
    assert CAMERA.lens_x == (0.06, -0.06)
    assert PinholeCamera.zed2().lens_x == (0.0,)


def test_a_disc_facing_along_the_axis_images_to_a_circle_about_its_projection():
    """Fronto-parallel: radius F r / Z [px], centred on the projection, area pi (F r / Z)^2 (exact)."""
    P = np.array([[0.06, 0.0, 1.0], [0.3, -0.2, 2.0]])
    N = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])
    r = 0.025
    images = disc_images(CAMERA, P, N, r)
    radius_px = F_PX * r / P[:, 2]
    np.testing.assert_allclose(images.area_px, np.tile(np.pi * radius_px**2, (2, 1)), rtol=1e-10)
    np.testing.assert_allclose(images.axes_px, np.tile(radius_px[:, None], (2, 1, 2)), rtol=1e-9)
    np.testing.assert_allclose(
        ellipse_centres_as_features(images), CAMERA.to_pixels(CAMERA.project(P)), atol=1e-9
    )
    half = images.box_px[..., 1] - images.centre_px[..., 0]
    np.testing.assert_allclose(half, np.tile(radius_px, (2, 1)), rtol=1e-9)
    np.testing.assert_allclose(perspective_bias(CAMERA, P, N, r), 0.0, atol=1e-18)
    assert images.drawable.all()


def test_first_order_bias_matches_the_exact_conic_centre_to_fourth_order():
    """|exact centre - (projection + Eq. (B))| <= 0.6 F (r/Z)^4 (measured 0.54); r / 2 divides it by ~16."""
    P, N = random_discs(50, seed=0)
    residuals = []
    for r in (0.05, 0.025):
        exact = ellipse_centres_as_features(disc_images(CAMERA, P, N, r))
        projected = CAMERA.to_pixels(CAMERA.project(P))
        first_order = CAMERA.to_pixels(CAMERA.project(P) + perspective_bias(CAMERA, P, N, r))
        residual = np.abs(exact - first_order).max(axis=1)
        assert np.all(residual <= 0.6 * F_PX * (r / P[:, 2]) ** 4)
        assert np.abs(exact - projected).max() > 100 * residual.max()  # the bias is real, and it is (B)
        residuals.append(residual)
    # every disc, not only the median: the next order is (r/Z)^2 <= 0.0097 relative for these discs,
    # so each ratio is 16 to 1 % (measured 15.985 to 16.064, median 16.003)
    np.testing.assert_allclose(residuals[0] / residuals[1], 16.0, rtol=0.01)


def test_the_bias_of_a_5cm_disc_at_half_a_metre_is_a_third_of_a_pixel():
    """On the axis, tilted 30 deg: |bias| = F_px (r/Z)^2 sin 30 cos 30 = 0.3895 px, toward the nearer edge."""
    tilt = np.radians(30.0)
    P, N = np.array([[0.06, 0.0, 0.5]]), np.array([[np.sin(tilt), 0.0, -np.cos(tilt)]])
    bias_px = perspective_bias(CAMERA, P, N, 0.025)[0] / CAMERA.pixel_pitch
    expected = -F_PX * (0.025 / 0.5) ** 2 * np.sin(tilt) * np.cos(tilt)
    assert bias_px[0] == pytest.approx(expected, rel=1e-12) and expected == pytest.approx(-0.3895, abs=1e-4)
    exact = (
        ellipse_centres_as_features(disc_images(CAMERA, P, N, 0.025))[0]
        - CAMERA.to_pixels(CAMERA.project(P))[0]
    )
    assert exact[0] == pytest.approx(expected, abs=0.6 * F_PX * (0.025 / 0.5) ** 4)  # the O((r/Z)^4) residual
    assert exact[2] == pytest.approx(0.0, abs=1e-9)


def test_the_rows_of_an_ellipse_centre_agree_in_both_lenses():
    """Rectified pair: v depends on the 3-D point only, so the ellipses' centre rows are equal."""
    P, N = random_discs(20, seed=1)
    images = disc_images(CAMERA, P, N, 0.05)
    np.testing.assert_allclose(images.centre_px[0, :, 1], images.centre_px[1, :, 1], rtol=0, atol=1e-9)
    bias = perspective_bias(CAMERA, P, N, 0.05)
    assert bias.shape == (20, 3)
    mono = perspective_bias(PinholeCamera.zed2(), P, N, 0.05)
    np.testing.assert_allclose(mono[:, 1], bias[:, 2], rtol=1e-12)


def test_discs_behind_facing_away_or_crossing_the_lens_plane_are_not_drawable():
    P = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.01], [0.0, 0.0, 1.0]])
    N = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    images = disc_images(StereoCamera.zed2(), P, N, 0.025)
    np.testing.assert_array_equal(images.drawable, [[False, False, False, True]] * 2)
    assert np.isnan(images.centre_px[:, :3]).all() and np.isfinite(images.centre_px[:, 3]).all()
