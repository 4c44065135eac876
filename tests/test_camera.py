"""Stereo and pinhole camera models: Eq. (6), (9)-(11), (C6)-(C8), interaction matrices, visibility."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ibvs_youla import PinholeCamera, StereoCamera, Visibility
from ibvs_youla._geometry import exp_twist, inverse_pose, transform_points
from ibvs_youla.exceptions import (
    InvalidArrayError,
    InvalidDisparityError,
    InvalidParameterError,
    PointBehindCameraError,
)


def random_points(rng, n=20, z=(0.5, 25.0)):
    Z = rng.uniform(*z, n)
    return np.column_stack((rng.uniform(-0.8, 0.8, n) * Z, rng.uniform(-0.5, 0.5, n) * Z, Z))


@pytest.fixture
def skewed():
    """A camera with skew and an off-centre principal point, to exercise Eq. (6) in full."""
    return StereoCamera(
        focal_length=2.8e-3,
        baseline=0.12,
        sensor_width=5.23e-3,
        sensor_height=2.94e-3,
        pixel_pitch=4e-6,
        skew=3.5,
        principal_point=(650.0, 355.0),
    )


# ----------------------------------------------------------------------------------------- presets
def test_paper_preset_reproduces_table_a3():
    cam = StereoCamera.zed2()
    h, v = np.degrees(cam.field_of_view)
    assert (cam.focal_length, cam.baseline, cam.depth_range) == (2.8e-3, 0.12, (0.5, 25.0))
    assert h == pytest.approx(86.09, abs=0.01)
    assert v == pytest.approx(55.35, abs=0.06)  # printed 55.35; 2 atan(1.47 / 2.8) = 55.40
    assert cam.resolution == (1280, 720)
    assert cam.pixel_pitch == pytest.approx(5.23e-3 / 1280, rel=1e-15)
    assert cam.frame_rate == 60.0


def test_zed2_preset_pixel_pitch_and_modes():
    cam = StereoCamera.zed2("zed2", "HD720")
    assert cam.focal_length == 2.12e-3 and cam.pixel_pitch == 4e-6
    assert cam.intrinsic_matrix()[0, 0] == pytest.approx(530.0, rel=1e-12)  # F / pitch [px]
    assert np.degrees(cam.field_of_view) == pytest.approx([100.74, 68.37], abs=0.01)
    assert StereoCamera.zed2("zed2", "HD2K").resolution == (2208, 1242)
    assert StereoCamera.zed2("zed2", "VGA").pixel_pitch == 8e-6
    assert StereoCamera.zed2("zed2", "VGA").frame_rate == 100.0
    assert StereoCamera.zed2("paper", "HD1080", frame_rate=15).frame_rate == 15.0
    assert PinholeCamera.zed2("zed2", "HD2K").pixel_pitch == 2e-6


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        (dict(preset="zed3"), "preset"),
        (dict(mode="4K"), "mode"),
        (dict(mode="HD2K", frame_rate=30), "frame_rate"),
    ],
)
def test_bad_preset_arguments(kwargs, name):
    with pytest.raises(InvalidParameterError, match=name) as info:
        StereoCamera.zed2(**kwargs)
    assert info.value.name == name


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("focal_length", 0.0),
        ("baseline", -0.12),
        ("pixel_pitch", np.nan),
        ("frame_rate", np.inf),
        ("depth_range", (5.0, 1.0)),
        ("depth_range", (1.0,)),
        ("principal_point", (1.0, np.nan)),
        ("skew", np.nan),
    ],
)
def test_bad_camera_parameters(field, value):
    kwargs = dict(focal_length=2.8e-3, baseline=0.12, sensor_width=5e-3, sensor_height=3e-3, pixel_pitch=4e-6)
    kwargs[field] = value
    with pytest.raises(InvalidParameterError, match="received") as info:
        StereoCamera(**kwargs)
    assert info.value.name == field


# ----------------------------------------------------------------------------------------- projection
def test_projection_matches_eq_9_to_11_with_errata_12():
    cam = StereoCamera.zed2()
    F, b = cam.focal_length, cam.baseline
    p = cam.project([[0.3, -0.2, 2.0]])
    assert p == pytest.approx(
        np.array([[F * (0.3 - b / 2) / 2, F * (0.3 + b / 2) / 2, F * -0.2 / 2]]), rel=1e-15
    )
    assert p[0, 1] - p[0, 0] == pytest.approx(F * b / 2.0, rel=1e-12)  # disparity F b / Z > 0


def test_triangulate_inverts_project():
    cam, rng = StereoCamera.zed2(), np.random.default_rng(0)
    P = random_points(rng, 200)
    err = np.linalg.norm(cam.triangulate(cam.project(P)) - P, axis=1)
    assert np.all(err <= 1e-12 * np.linalg.norm(P, axis=1))


def test_virtual_points_round_trip_behind_the_camera():
    cam, rng = StereoCamera.zed2(), np.random.default_rng(1)
    P = random_points(rng, 50, z=(-10.0, -0.1))
    p = cam.project(P, allow_behind=True)
    assert np.all(p[:, 1] - p[:, 0] < 0)  # negative disparity
    err = np.linalg.norm(cam.triangulate(p, allow_behind=True) - P, axis=1)
    assert np.all(err <= 1e-12 * np.linalg.norm(P, axis=1))


@settings(max_examples=200, deadline=None)
@given(
    x=st.floats(-50, 50),
    y=st.floats(-50, 50),
    z=st.floats(0.01, 1e3),
    mode=st.sampled_from(["HD2K", "HD720", "VGA"]),
    preset=st.sampled_from(["paper", "zed2"]),
)
def test_round_trip_property(x, y, z, mode, preset):
    cam = StereoCamera.zed2(preset, mode)
    P = np.array([[x, y, z]])
    assert np.linalg.norm(cam.triangulate(cam.project(P)) - P) <= 1e-12 * np.linalg.norm(P) + 1e-15


def test_pixels_round_trip_and_eq_6(skewed):
    rng = np.random.default_rng(2)
    P = random_points(rng, 50)
    p = skewed.project(P)
    p_px = skewed.to_pixels(p)
    assert np.abs(skewed.from_pixels(p_px) - p).max() <= 1e-18  # [m]; |p| ~ 1e-3 m
    K = skewed.intrinsic_matrix()
    assert K == pytest.approx(np.array([[700.0, 3.5, 650.0], [0.0, 700.0, 355.0], [0.0, 0.0, 1.0]]))
    for lens, column in ((+0.06, 0), (-0.06, 1)):  # Eq. (5)-(8): s p = K [I | -x_lens] P
        h = (K @ (P - [lens, 0.0, 0.0]).T).T
        assert np.abs(h[:, :2] / h[:, 2:] - p_px[:, [column, 2]]).max() < 1e-9  # [px]


def test_pinhole_project_back_project_and_pixels():
    cam, rng = PinholeCamera.zed2(), np.random.default_rng(3)
    P = random_points(rng, 50)
    p = cam.project(P)
    assert p == pytest.approx(cam.focal_length * P[:, :2] / P[:, 2:], rel=1e-15)
    assert np.abs(cam.back_project(p, P[:, 2]) - P).max() <= 1e-12 * np.abs(P).max()
    assert cam.back_project(p[:1], P[0, 2]) == pytest.approx(P[:1], rel=1e-12)
    assert np.abs(cam.from_pixels(cam.to_pixels(p)) - p).max() <= 1e-18


# ----------------------------------------------------------------------------------------- interaction
def finite_difference_interaction(project, P_C, eps=1e-6):
    """Features of static points seen from a camera moved by exp(eps xi) (twist in C), central differences."""
    cols = []
    for k in range(6):
        xi = np.zeros(6)
        xi[k] = eps
        plus = project(transform_points(inverse_pose(exp_twist(xi)), P_C))
        minus = project(transform_points(inverse_pose(exp_twist(-xi)), P_C))
        cols.append((plus - minus).reshape(-1) / (2 * eps))
    return np.column_stack(cols)


@pytest.mark.parametrize("z", [(0.5, 25.0), (-5.0, -0.5)])
def test_stereo_interaction_matrix_matches_finite_differences(z):
    cam, rng = StereoCamera.zed2(), np.random.default_rng(4)
    P = random_points(rng, 6, z=z)
    L = cam.interaction_matrix(P, allow_behind=True)
    L_fd = finite_difference_interaction(lambda Q: cam.project(Q, allow_behind=True), P)
    assert L.shape == (18, 6)
    assert np.abs(L - L_fd).max() <= 1e-6 * np.abs(L).max()


def test_pinhole_interaction_matrix_matches_finite_differences_and_classical_form():
    cam, rng = PinholeCamera.zed2(), np.random.default_rng(5)
    P = random_points(rng, 6)
    L = cam.interaction_matrix(P)
    L_fd = finite_difference_interaction(cam.project, P)
    assert L.shape == (12, 6)
    assert np.abs(L - L_fd).max() <= 1e-6 * np.abs(L).max()
    X, Y, Z = P[0]
    x, y = X / Z, Y / Z  # Chaumette & Hutchinson (2006), normalised coordinates, times F
    classical = cam.focal_length * np.array(
        [[-1 / Z, 0, x / Z, x * y, -(1 + x * x), y], [0, -1 / Z, y / Z, 1 + y * y, -x * y, -x]]
    )
    assert L[:2] == pytest.approx(classical, rel=1e-12, abs=1e-18)


# ----------------------------------------------------------------------------------------- visibility
def test_visibility_flags():
    cam = StereoCamera.zed2()
    tan_h = np.tan(cam.field_of_view[0] / 2)
    P = np.array(
        [
            [0.0, 0.0, 2.0],  # centre: visible
            [0.0, 0.0, 0.3],  # too close for 0.5-25 m
            [0.0, 0.0, -2.0],  # behind
            [
                1.998 * tan_h,
                0.0,
                2.0,
            ],  # just inside the centre FOV edge: left lens (at +b/2) sees it, right not
            [0.0, 0.0, 30.0],  # too far
        ]
    )
    vis = cam.visibility(P)
    assert isinstance(vis, Visibility)
    assert vis.in_front.tolist() == [True, True, False, True, True]
    assert vis.in_fov.tolist() == [True, True, False, False, True]
    assert vis.in_depth_range.tolist() == [True, False, False, True, False]
    assert vis.visible.tolist() == [True, False, False, False, False]
    assert not vis.all_visible and cam.visibility(P[:1]).all_visible
    assert "Z_C = -2.000 m" in vis.describe()
    pin_vis = PinholeCamera.zed2().visibility(P)
    assert pin_vis.in_fov.tolist() == [True, True, False, True, True]  # one lens at the origin: just inside


# ----------------------------------------------------------------------------------------- bad input
def test_behind_camera_raises_unless_virtual_and_zero_depth_always_raises():
    cam = StereoCamera.zed2()
    with pytest.raises(PointBehindCameraError, match=r"points \[1\] have depth Z_C = \[-1.0\]") as info:
        cam.project([[0, 0, 1.0], [0, 0, -1.0]])
    assert info.value.indices.tolist() == [1]
    assert cam.project([[0, 0, -1.0]], allow_behind=True)[0, 2] == 0.0
    for allow in (False, True):
        with pytest.raises(PointBehindCameraError, match=r"\|Z_C\| >= 1e-09" if allow else "Z_C >= "):
            cam.project([[0.1, 0, 0.0]], allow_behind=allow)
        with pytest.raises(PointBehindCameraError):
            cam.interaction_matrix([[0.1, 0, 1e-12]], allow_behind=allow)
    with pytest.raises(PointBehindCameraError):
        PinholeCamera.zed2().back_project([[0.0, 0.0]], [-1.0])


def test_disparity_errors():
    cam = StereoCamera.zed2()
    with pytest.raises(InvalidDisparityError, match=r"disparity u_r - u_l = \[0.0\]") as info:
        cam.triangulate([[1e-4, 1e-4, 0.0]], allow_behind=True)
    assert info.value.disparities.tolist() == [0.0]
    with pytest.raises(InvalidDisparityError, match=r"points \[1\]"):
        cam.triangulate([[1e-4, 2e-4, 0.0], [2e-4, 1e-4, 0.0]])
    assert cam.triangulate([[2e-4, 1e-4, 0.0]], allow_behind=True)[0, 2] == pytest.approx(-3.36, rel=1e-12)


@pytest.mark.parametrize(
    "bad",
    [[[0.0, 0.0, np.nan]], [[0.0, np.inf, 1.0]], [[0.0, 1.0]], np.zeros((2, 3, 1)), "abc"],
)
def test_bad_arrays_raise_invalid_array_error(bad):
    cam = StereoCamera.zed2()
    for method in (cam.project, cam.triangulate, cam.interaction_matrix, cam.visibility, cam.to_pixels):
        with pytest.raises(InvalidArrayError, match="received"):
            method(bad)
    with pytest.raises(InvalidArrayError):
        PinholeCamera.zed2().back_project([[0.0, 0.0]], [np.nan])
