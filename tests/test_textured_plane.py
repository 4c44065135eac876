"""The textured plane: its image is the texture seen through the homography, its depths those of the rays."""

from __future__ import annotations

import numpy as np
import pytest

from ibvs_youla import scenarios
from ibvs_youla._geometry import exp_twist
from ibvs_youla.exceptions import InvalidArrayError, InvalidParameterError
from ibvs_youla.model.camera import PinholeCamera, StereoCamera, pixel_centres_normalized
from ibvs_youla.model.textured_plane import TexturedPlane, generated_texture

CAMERA = scenarios.textured_camera()  # 120 x 90 px, 150 px focal length


def _tilted_pose():
    """A camera 1 m before the plane, moved by a few cm and turned by a few degrees about every axis."""
    T = np.eye(4)
    T[2, 3] = -1.0
    return T @ exp_twist(np.array([0.03, -0.02, 0.05, 0.06, -0.08, 0.2]))


def _rays_on_plane(camera, plane, T_O_C):
    """Where each pixel centre's ray meets the plane, in {P} (h, w, 3), by ray-plane intersection in {O}."""
    x, y = pixel_centres_normalized(camera)
    rays_O = np.stack((x, y, np.ones_like(x)), axis=-1) @ T_O_C[:3, :3].T
    origin_O = T_O_C[:3, 3]
    n_O, p_O = plane.T_O_P[:3, 2], plane.T_O_P[:3, 3]
    s = (p_O - origin_O).dot(n_O) / rays_O.dot(n_O)  # ray parameter: the point is origin + s ray
    points_O = origin_O + s[..., None] * rays_O
    return (points_O - p_O) @ plane.T_O_P[:3, :3], s


def _bilinear(texture, a, b, background):
    """The texture at texture coordinates (a, b) (texel centres at half-integers), bilinearly interpolated."""
    rows, cols = texture.shape
    padded = np.pad(texture.astype(float), 1, constant_values=background)
    x, y = a - 0.5 + 1.0, b - 0.5 + 1.0  # padded index coordinates
    j, i = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - j, y - i
    inside = (j >= 0) & (i >= 0) & (j < cols + 1) & (i < rows + 1)
    j, i = np.clip(j, 0, cols), np.clip(i, 0, rows)
    value = (
        (1 - fx) * (1 - fy) * padded[i, j]
        + fx * (1 - fy) * padded[i, j + 1]
        + (1 - fx) * fy * padded[i + 1, j]
        + fx * fy * padded[i + 1, j + 1]
    )
    return np.where(inside, value, background)


def test_the_image_is_the_texture_at_each_pixels_ray():
    """(T1)-(T2) against an independent path: each pixel centre's ray meets the plane, (T1) gives the texel.

    OpenCV's fixed-point warps quantize the bilinear weights to 1/32 texel (INTER_BITS = 5): the
    bound is the texture's largest change over 1/32 texel. The OpenCV installed here (5.1)
    interpolates in floating point: measured 1.5e-5 grey levels at most, float32 rounding.
    """
    plane = TexturedPlane(background_grey=17.0)
    T = _tilted_pose()
    P_P, _ = _rays_on_plane(CAMERA, plane, T)
    cols, rows = plane.texels
    a, b = P_P[..., 0] / plane.texel_m + cols / 2, P_P[..., 1] / plane.texel_m + rows / 2  # (T1)
    expected = _bilinear(plane.texture_grey, a, b, 17.0)
    image = plane.render(CAMERA, T)
    assert image.shape == (90, 120) and image.dtype == np.float32
    steepest = max(np.abs(np.diff(plane.texture_grey, axis=k)).max() for k in (0, 1))  # [grey / texel]
    assert np.abs(image - expected).max() <= steepest / 32.0


def test_outside_the_texture_behind_the_plane_and_away_from_it_the_image_is_background():
    plane = TexturedPlane(background_grey=17.0)
    T = np.eye(4)
    T[:3, 3] = (0.6, 0.0, -1.0)  # over the texture's right edge (x = 0.6 m): half the view off it
    image = plane.render(CAMERA, T)
    P_P, _ = _rays_on_plane(CAMERA, plane, T)
    # bilinear interpolation blends the background in over half a texel on either side of the edge
    off, on = (
        (np.abs(P_P[..., 0]) - 0.6 > 0.5 * plane.texel_m),
        (0.6 - np.abs(P_P[..., 0]) > 0.5 * plane.texel_m),
    )
    assert off.any() and on.any() and np.all(image[off] == 17.0) and np.all(image[on] != 17.0)
    behind = np.eye(4)
    behind[2, 3] = 1.0  # on the +z_P side: the back of the plane, untextured
    assert np.all(plane.render(CAMERA, behind) == 17.0)
    assert np.all(np.isinf(plane.depths(CAMERA, behind)))
    away = np.eye(4)
    away[:3, :3] = [
        [1.0, 0.0, 0.0],
        [0.0, 0.0, -1.0],
        [0.0, 1.0, 0.0],
    ]  # looking along -y_O, the plane edge-on
    away[:3, 3] = (0.0, 0.0, -0.01)
    looks_away = plane.depths(CAMERA, away)
    image = plane.render(CAMERA, away)
    assert np.isinf(looks_away).any() and np.isfinite(looks_away).any()
    assert np.all(image[np.isinf(looks_away)] == 17.0)


def test_depths_are_where_the_rays_meet_the_plane():
    """(T3) against the ray-plane intersection in the base frame; fronto-parallel at 1 m, every Z = 1."""
    plane = TexturedPlane()
    T = _tilted_pose()
    _, s = _rays_on_plane(CAMERA, plane, T)  # the ray (x, y, 1): its parameter is the depth
    np.testing.assert_allclose(plane.depths(CAMERA, T), s, rtol=1e-12)
    facing = np.eye(4)
    facing[2, 3] = -1.0
    np.testing.assert_allclose(plane.depths(CAMERA, facing), 1.0, rtol=1e-12)


def test_a_plane_facing_a_camera_is_upright_and_centred_at_its_depth():
    T_O_C = np.eye(4)
    T_O_C[:3, :3] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    T_O_C[:3, 3] = (1.0, 2.0, 3.0)
    plane = TexturedPlane.facing(T_O_C, 0.8)
    np.testing.assert_allclose(plane.depths(CAMERA, T_O_C), 0.8, rtol=1e-12)
    np.testing.assert_allclose(plane.corners_O().mean(axis=0), T_O_C[:3, 3] + 0.8 * T_O_C[:3, 2], atol=1e-12)
    H = plane.homography(CAMERA, T_O_C)  # the texture's centre maps to the principal point
    centre = H @ [plane.texels[0] / 2, plane.texels[1] / 2, 1.0]
    np.testing.assert_allclose(centre[:2] / centre[2], CAMERA.principal_point, atol=1e-9)


def test_the_generated_texture_is_seeded_with_the_stated_statistics():
    a = generated_texture((90, 120), seed=3, smoothing_texels=3.0)
    np.testing.assert_array_equal(a, generated_texture((90, 120), seed=3, smoothing_texels=3.0))
    assert not np.array_equal(a, generated_texture((90, 120), seed=4, smoothing_texels=3.0))
    assert a.dtype == np.float32 and a.min() >= 0.0 and a.max() <= 255.0
    assert a.mean() == pytest.approx(128.0, abs=1.0) and a.std() == pytest.approx(40.0, abs=1.0)
    smoother = generated_texture((90, 120), seed=3, smoothing_texels=6.0)  # the low-pass acts
    assert np.abs(np.diff(smoother, axis=1)).mean() < 0.75 * np.abs(np.diff(a, axis=1)).mean()  # 0.69


def test_a_plane_round_trips_through_plain_data():
    generated = TexturedPlane.facing(_tilted_pose(), 0.9, seed=5, texels=(40, 30))
    again = TexturedPlane.from_dict(generated.to_dict())
    assert again == generated and "texture" not in generated.to_dict()  # the recipe, not the grey levels
    given = TexturedPlane(texture=np.arange(12.0).reshape(3, 4) * 20.0, texel_m=0.01)
    assert given.texels == (4, 3) and TexturedPlane.from_dict(given.to_dict()) == given
    assert given != generated


@pytest.mark.parametrize(
    ("fields", "error", "match"),
    [
        ({"texel_m": 0.0}, InvalidParameterError, "texel_m"),
        ({"texels": (1, 10)}, InvalidParameterError, "texels"),
        ({"texels": 10}, InvalidParameterError, "texels"),
        ({"seed": -1}, InvalidParameterError, "seed"),
        ({"smoothing_texels": -1.0}, InvalidParameterError, "smoothing_texels"),
        ({"background_grey": 300.0}, InvalidParameterError, "background_grey"),
        ({"texture": np.full((4, 4), 256.0)}, InvalidParameterError, "texture"),
        ({"texture": np.full((4, 4), np.nan)}, InvalidArrayError, "texture"),
        ({"texture": np.zeros(4)}, InvalidArrayError, "texture"),
        ({"T_O_P": np.zeros((4, 4))}, InvalidArrayError, "T_O_P"),
    ],
)
def test_bad_planes_are_refused_by_name(fields, error, match):
    with pytest.raises(error, match=match):
        TexturedPlane(**fields)


def test_only_a_monocular_camera_with_pixels_images_the_plane():
    plane = TexturedPlane()
    with pytest.raises(InvalidParameterError, match="PinholeCamera with pixels"):
        plane.render(StereoCamera.zed2(), np.eye(4))
    with pytest.raises(InvalidParameterError, match="no pixels"):
        plane.render(PinholeCamera.normalized(), np.eye(4))
    with pytest.raises(InvalidParameterError, match="scene"):
        TexturedPlane.from_dict({"kind": "disc"})
    with pytest.raises(InvalidParameterError, match="resolution"):
        PinholeCamera.from_focal_px(100.0, (80,))
