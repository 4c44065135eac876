"""Rendered images as a disturbance: ``Disturbances(rendered_images=True)`` and the ``images`` axis."""

from __future__ import annotations

import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla import ImageSensor, ImagingSettings
from ibvs_youla.campaign.robustness import RobustnessStudy, read_study_rows
from ibvs_youla.cli import main
from ibvs_youla.exceptions import InvalidParameterError
from ibvs_youla.model.camera import PinholeCamera, default_camera
from ibvs_youla.simulation.disturbances import Disturbances
from ibvs_youla.simulation.disturbances.policy import HoldOnMissingFeatures

MARKERS_O = np.array([[-0.2, -0.1, 1.5], [0.2, -0.1, 1.6], [0.1, 0.15, 1.4], [-0.15, 0.12, 1.7]])  # [m]


def free_scenario() -> iy.Scenario:
    start = np.eye(4)
    start[:3, 3] = [0.04, -0.03, -0.08]  # [m]
    return iy.Scenario.free_camera(start, np.eye(4), MARKERS_O)


def test_the_disturbance_is_the_image_sensor_with_missing_markers_withheld():
    """Bit for bit the run of an explicit ImageSensor (missing="nan", the image seed's noise) and a
    controller that withholds incomplete frames."""
    d = Disturbances(rendered_images=True, image_blur_px=1.0, image_noise_grey=3.0, seed=7)
    scenario = free_scenario()
    by_disturbance = iy.simulate(
        scenario,
        iy.controllers.make("ibvs-current", gain=3.0),
        plant="free-camera",
        duration=0.3,
        disturbances=d,
    )
    imaging = ImagingSettings(blur_sigma_px=1.0, noise_sigma_grey=3.0, seed=d.image_seed)
    explicit = iy.simulate(
        scenario,
        HoldOnMissingFeatures(iy.controllers.make("ibvs-current", gain=3.0)),
        plant="free-camera",
        duration=0.3,
        sensor=lambda truth: ImageSensor(truth, imaging=imaging, missing="nan"),
    )
    np.testing.assert_array_equal(by_disturbance.frame_features, explicit.frame_features)
    np.testing.assert_array_equal(by_disturbance.camera_pose, explicit.camera_pose)
    ideal = iy.simulate(
        scenario, iy.controllers.make("ibvs-current", gain=3.0), plant="free-camera", duration=0.3
    )
    pitch = default_camera().pixel_pitch  # [m per px]
    gap = np.abs(by_disturbance.frame_features - ideal.frame_features).max() / pitch
    assert 0.0 < gap < 1.0  # detected centres: sub-pixel, but not the true projections [px]
    assert by_disturbance.metadata["disturbances"] == {
        "rendered_images": True,
        "image_blur_px": 1.0,
        "image_noise_grey": 3.0,
        "seed": 7,
    }


def test_a_marker_that_leaves_the_image_withholds_the_frame():
    """physical-1, ff+fb: the paper's 1 ms feedforward swings the camera so far that at t = 0.01 s
    markers 0 and 1 are above the left and right images (v = -105 and -100 px). The ideal sensor
    would still hand over their projections; the images cannot, so that frame is withheld."""
    d = Disturbances(rendered_images=True)
    result = iy.simulate(iy.scenarios.get("physical-1"), "ff+fb", duration=0.05, disturbances=d)
    np.testing.assert_array_equal(result.frame_visible[1], [False, False, True])
    assert result.frame_visible[[0, 2, 3, 4, 5]].all()
    assert result.signals["frames_withheld"][-1, 0] == 1.0


def test_the_image_noise_is_seeded_apart_from_the_other_draws():
    """The image seed is SeedSequence(seed)'s fourth stream: the three others draw as before."""
    d = Disturbances(rendered_images=True, image_noise_grey=2.0, pixel_noise_px=0.1, seed=5)
    expected = [np.random.default_rng(s).random(3) for s in np.random.SeedSequence(5).spawn(3)]
    for rng, draws in zip(d.generators(), expected, strict=True):
        np.testing.assert_array_equal(rng.random(3), draws)
    assert d.image_seed == int(np.random.SeedSequence(5).spawn(4)[3].generate_state(1)[0])
    assert Disturbances(rendered_images=True, seed=5).to_dict() == {"rendered_images": True}  # nothing drawn


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: Disturbances(image_blur_px=1.0), "without rendered_images"),
        (lambda: Disturbances(image_noise_grey=2.0), "without rendered_images"),
        (lambda: Disturbances(rendered_images=True, image_noise_grey=-1.0), "image_noise_grey"),
        (lambda: Disturbances(rendered_images=1), "True or False"),
        (
            lambda: Disturbances(rendered_images=True).check_applies(
                "free-camera", PinholeCamera.normalized()
            ),
            "no pixels",
        ),
        (
            lambda: iy.simulate(
                free_scenario(),
                "ibvs-current",
                plant="free-camera",
                duration=0.1,
                sensor="images",
                disturbances=Disturbances(rendered_images=True),
            ),
            "sensor",
        ),
    ],
)
def test_bad_image_disturbances_are_refused(make, match):
    with pytest.raises(InvalidParameterError, match=match):
        make()


def test_every_value_of_the_images_axis_renders():
    campaign = {"family": "arm-physical", "cases": 2, "controllers": ("fb",)}
    levels = [d.to_dict()["disturbances"] for _, d in RobustnessStudy("images", (0, 5), campaign).campaigns()]
    assert levels == [
        {"rendered_images": True, "image_blur_px": 1.0},
        {"rendered_images": True, "image_blur_px": 1.0, "image_noise_grey": 5.0},
    ]


def test_an_images_study_runs_end_to_end(tmp_path, capsys):
    out = tmp_path / "images"
    args = [
        "robustness",
        "--axis",
        "images",
        "--values",
        "0,10",
        "--cases",
        "1",
        "--controllers",
        "ibvs-current",
    ]
    args += [
        "--duration",
        "0.2",
        "--workers",
        "0",
        "--no-progress",
        "--tolerance",
        "1000,180",
        "--out",
        str(out),
    ]
    assert main(args) == 0
    table = capsys.readouterr().out
    assert "image sensor noise" in table
    rows = read_study_rows(out)
    assert sorted(rows["axis_value"]) == [0.0, 10.0] and rows["controller"].eq("ibvs-current").all()
    assert (out / "images=0" / "campaign.json").is_file() and (out / "images=10" / "campaign.json").is_file()
