"""Rendered frames of disc markers: coverage, compositing, blur, noise, and bad input."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from ibvs_youla.exceptions import IbvsYoulaError, InvalidArrayError, InvalidParameterError
from ibvs_youla.model.camera import PinholeCamera, StereoCamera, default_camera
from ibvs_youla.simulation.rendering import DiscMarkers, ImagingSettings, check_camera_has_pixels, render

CAMERA = default_camera()  # 672 x 378 px per lens
MARKERS = DiscMarkers(0.05)  # 5 cm, grey 30 on 200
CONTRAST = 170.0  # background - marker [grey levels]
TILT = np.radians(30.0)


def tilted(n):
    return np.tile([np.sin(TILT), 0.0, -np.cos(TILT)], (n, 1))


def mass_centroid(image, background=200.0):
    """Grey-level centroid (u, v) [px, pixel i covers [i, i+1)] and mass of (background - image)."""
    m = cv2.moments(background - image.astype(np.float32))
    return np.array([m["m10"] / m["m00"] + 0.5, m["m01"] / m["m00"] + 0.5]), m["m00"]


def test_images_have_the_camera_resolution_one_per_lens():
    frame = render(CAMERA, MARKERS, [[0.0, 0.0, 1.0]], [[0.0, 0.0, -1.0]])
    assert len(frame.images) == 2 and frame.images[0].shape == (378, 672)
    assert frame.images[0].dtype == np.uint8
    mono = render(PinholeCamera.zed2(mode="HD720"), MARKERS, [[0.0, 0.0, 1.0]], [[0.0, 0.0, -1.0]])
    assert len(mono.images) == 1 and mono.images[0].shape == (720, 1280)


@pytest.mark.parametrize("depth", [0.5, 1.0, 2.0, 3.0])
def test_the_coverage_centroid_of_one_disc_is_its_ellipse_centre(depth):
    """No blur, no noise: centroid within 0.02 px of the exact ellipse centre, mass = area x contrast.

    Measured over 60 seeded positions per depth (tilt 30 deg, 8 x 8 samples): at most 0.005 px at
    0.5 m, 0.014 px at 3 m (a 6 px disc), from the uint8 rounding and the 1/64 coverage steps.
    """
    P = np.array([[0.13, -0.07, depth]])
    frame = render(CAMERA, MARKERS, P, tilted(1))
    for lens in range(2):
        centroid, mass = mass_centroid(frame.images[lens])
        np.testing.assert_allclose(centroid, frame.discs.centre_px[lens, 0], atol=0.02)
        assert mass == pytest.approx(frame.discs.area_px[lens, 0] * CONTRAST, rel=0.005)


def test_edge_pixels_are_supersampled_exactly_as_every_pixel_would_be():
    """The 1.5 px edge band gives the same image as evaluating the conic at s x s samples in every pixel."""
    P = np.array([[0.1, 0.05, 0.6]])
    s = 8
    frame = render(CAMERA, MARKERS, P, tilted(1), ImagingSettings(supersampling=s))
    C = frame.discs.conic_px[0, 0]
    u_min, u_max, v_min, v_max = frame.discs.box_px[0, 0]
    i0, i1, j0, j1 = int(u_min), int(u_max) + 1, int(v_min), int(v_max) + 1
    offsets = (np.arange(s) + 0.5) / s
    u = (np.arange(i0, i1)[:, None] + offsets).ravel()
    v = (np.arange(j0, j1)[:, None] + offsets).ravel()
    uu, vv = np.meshgrid(u, v)
    x = np.stack([uu, vv, np.ones_like(uu)])
    inside = np.einsum("iyx,ij,jyx->yx", x, C, x) < 0.0
    coverage = inside.reshape(j1 - j0, s, i1 - i0, s).mean(axis=(1, 3))
    expected = np.full((378, 672), 200.0)
    expected[j0:j1, i0:i1] += coverage * (30.0 - 200.0)
    assert 0 < np.count_nonzero((coverage > 0) & (coverage < 1)) < coverage.size // 2  # there is an edge band
    np.testing.assert_array_equal(frame.images[0], np.rint(expected).astype(np.uint8))


def test_a_nearer_disc_covers_a_farther_one():
    """Composited far to near: a 5 cm disc at 1 m hides a 5 cm disc 3 m away on the same ray."""
    P = np.array([[0.06, 0.0, 1.0], [0.06, 0.0, 3.0]])  # on the optical axis of the left lens (x0 = +0.06)
    both = render(CAMERA, MARKERS, P, [[0.0, 0.0, -1.0]] * 2)
    near_only = render(CAMERA, MARKERS, P[:1], [[0.0, 0.0, -1.0]])
    np.testing.assert_array_equal(both.images[0], near_only.images[0])
    assert both.drawn[0].all()  # drawn, then covered
    assert not np.array_equal(both.images[1], near_only.images[1])  # the right lens sees past it


def test_a_ring_leaves_its_hole_as_background():
    ring = DiscMarkers(0.05, ring_inner_diameter=0.03)
    frame = render(CAMERA, ring, [[0.06, 0.0, 1.0]], [[0.0, 0.0, -1.0]])
    image = frame.images[0]
    u, v = frame.discs.centre_px[0, 0]
    assert image[int(v), int(u)] == 200
    _, mass = mass_centroid(image)
    annulus_px = frame.discs.area_px[0, 0] - frame.holes.area_px[0, 0]
    assert mass == pytest.approx(annulus_px * CONTRAST, rel=0.005)


def test_blur_keeps_the_centroid_and_noise_is_seeded():
    P = np.array([[0.2, 0.1, 1.5]])
    sharp = render(CAMERA, MARKERS, P, tilted(1))
    blurred = render(CAMERA, MARKERS, P, tilted(1), ImagingSettings(blur_sigma_px=2.0))
    centroids = [mass_centroid(frame.images[0])[0] for frame in (blurred, sharp)]
    # a Gaussian blur keeps the centroid; rounding the ~450 blurred pixels to uint8 (+-0.5 grey) moves it
    # by about sqrt(450 / 12) x 6 px / 19 000 grey px = 0.002 px (measured 0.0014 px)
    np.testing.assert_allclose(*centroids, atol=0.005)
    assert blurred.images[0].min() > sharp.images[0].min()  # the blur spreads the disc
    noisy = [
        render(CAMERA, MARKERS, P, tilted(1), ImagingSettings(noise_sigma_grey=3.0, seed=seed))
        for seed in (1, 1, 2)
    ]
    np.testing.assert_array_equal(noisy[0].images[0], noisy[1].images[0])
    residual = noisy[0].images[0].astype(float) - sharp.images[0]
    # N(0, 3) plus the rounding to whole grey levels (uniform, variance 1/12): sqrt(9 + 1/12) = 3.0139;
    # 254k samples give the sample deviation a relative standard error of 1/sqrt(2 n) = 0.14 %
    # (measured 3.0123, -0.05 %; seeds 2-5: 3.013 to 3.018), so 0.5 % is 3.5 standard errors
    assert residual.std() == pytest.approx(np.sqrt(9.0 + 1.0 / 12.0), rel=0.005)
    assert not np.array_equal(noisy[0].images[0], noisy[2].images[0])


def test_discs_outside_the_image_behind_or_facing_away_are_not_drawn():
    P = np.array([[5.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 0.1, 1.0]])
    N = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0]])
    frame = render(CAMERA, MARKERS, P, N)
    assert not frame.drawn.any()
    assert (frame.images[0] == 200).all() and (frame.images[1] == 200).all()


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: DiscMarkers(-0.01), "diameter"),
        (lambda: DiscMarkers(0.0), "diameter"),
        (lambda: DiscMarkers(0.05, ring_inner_diameter=0.05), "ring_inner_diameter"),
        (lambda: DiscMarkers(0.05, normals_O=[0.0, 0.0, 0.0]), "normals_O"),
        (lambda: DiscMarkers(0.05, normals_O=[[0.0, 0.0]]), "normals_O"),
        (lambda: DiscMarkers(0.05, marker_grey=300), "marker_grey"),
        (lambda: DiscMarkers(0.05, marker_grey=200), "marker_grey"),
        (lambda: ImagingSettings(blur_sigma_px=-0.5), "blur_sigma_px"),
        (lambda: ImagingSettings(noise_sigma_grey=-1.0), "noise_sigma_grey"),
        (lambda: ImagingSettings(noise_sigma_grey=float("nan")), "noise_sigma_grey"),
        (lambda: ImagingSettings(supersampling=0), "supersampling"),
        (lambda: ImagingSettings(seed=1.5), "seed"),
    ],
)
def test_bad_marker_and_imaging_settings_raise_by_name(make, match):
    with pytest.raises(IbvsYoulaError, match=match):
        make()


def test_a_camera_without_pixels_cannot_render():
    with pytest.raises(InvalidParameterError, match=r"no bounded view.*PinholeCamera\.normalized"):
        render(PinholeCamera.normalized(), MARKERS, [[0.0, 0.0, 1.0]], [[0.0, 0.0, -1.0]])
    tiny = StereoCamera(
        baseline=0.1, focal_length=1e-3, sensor_width=4e-6, sensor_height=4e-6, pixel_pitch=1e-6
    )  # 4 x 4 pixels
    with pytest.raises(InvalidParameterError, match="4 x 4 px"):
        check_camera_has_pixels(tiny)
    with pytest.raises(InvalidParameterError, match="StereoCamera or a PinholeCamera"):
        check_camera_has_pixels("zed")


def test_bad_points_and_normals_raise():
    with pytest.raises(InvalidArrayError, match="P_C"):
        render(CAMERA, MARKERS, [[0.0, 0.0, np.nan]], [[0.0, 0.0, -1.0]])
    with pytest.raises(InvalidArrayError, match="normals_C"):
        render(CAMERA, MARKERS, [[0.0, 0.0, 1.0]], [[0.0, 0.0, -1.0]] * 2)
    with pytest.raises(InvalidParameterError, match="normals_C"):
        render(CAMERA, MARKERS, [[0.0, 0.0, 1.0]], [[0.0, 0.0, 0.0]])
