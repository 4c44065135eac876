"""The methods the paper compares itself with, through the registry, on the paper's stereo scenarios.

Each baseline commands a camera twist; on the dynamic arm it goes through J_C^+ of the arm, the
velocity integration and the paper's inner loop (Eq. (33)-(46)), so every method runs on the
same plant as the paper's controller. With lambda = 0.5 1/s the image error of a first-order
law decays as e^(-lambda t): over 10 s, e^-5 = 6.74e-3. The pinned ratios are what each method
gives on physical-2 at the default rates (joint loop 1 kHz, camera 100 Hz), with the 1 deg
joint offset the encoders do not see.
"""

from __future__ import annotations

import numpy as np
import pytest

import ibvs_youla as iy
from ibvs_youla import controllers, scenarios
from ibvs_youla.exceptions import InvalidParameterError

BASELINES = ("ibvs-current", "ibvs-desired", "ibvs-mean", "pbvs", "2.5d", "hybrid", "mpc-ibvs")
# The field's answers to the retreat and the local minima of point IBVS (their own test files)
FEATURE_LAWS = ("ibvs-polar", "ibvs-partitioned", "ibvs-moments")
# ||e(10 s)|| / ||e(0)|| on physical-2, dynamic arm, default settings (measured)
PHYSICAL_2_RATIO = {
    "ibvs-current": 7.33e-3,
    "ibvs-desired": 5.63e-3,
    "ibvs-mean": 6.44e-3,
    "pbvs": 6.73e-3,
    "2.5d": 6.89e-3,
    "hybrid": 7.33e-3,  # never leaves IBVS here: the pose error only falls
    "mpc-ibvs": 7.33e-3,  # no constraint active: the first move of IBVS
}


def test_every_baseline_is_registered_with_a_twist_command():
    # photometric servoing is registered last; it needs a textured scene (tests/test_photometric.py)
    assert controllers.names() == ("fb", "ff+fb", *BASELINES, *FEATURE_LAWS, "photometric")
    for name in BASELINES + FEATURE_LAWS:
        ctrl = controllers.make(name)
        assert ctrl.command_type is controllers.CommandType.CAMERA_TWIST and ctrl.name == name
        assert controllers.describe()[name]


@pytest.mark.parametrize("name", BASELINES)
def test_every_baseline_servoes_physical_2_on_the_dynamic_arm(name, arm):
    result = iy.simulate(scenarios.physical(2), controllers.make(name), duration=10.0, arm=arm)
    assert result.status == "complete" and result.metadata["plant"] == "dynamic"
    assert {"camera_twist", "dq_ref", "q_ref", "tau"} <= set(result.signals)
    e0, e1 = (np.linalg.norm(result.feature_error[i]) for i in (0, -1))
    assert e1 / e0 == pytest.approx(PHYSICAL_2_RATIO[name], rel=2e-3)
    mm, deg = result.final_pose_error()
    assert mm < 1.0 and deg < 0.06  # from 110 mm / 7 deg at the start


def test_mpc_refuses_targets_outside_its_image_box():
    """paper-2's markers are the paper's virtual points, out of view at the target (ERRATA 13)."""
    with pytest.raises(InvalidParameterError, match="a box that contains the target features"):
        iy.simulate(scenarios.paper(2), controllers.make("mpc-ibvs"), duration=0.1)


def test_unknown_names_and_parameters_are_named():
    with pytest.raises(InvalidParameterError, match="'mpc-ibvs'"):
        controllers.make("ibvs")
    with pytest.raises(InvalidParameterError, match="parameters of 'pbvs': gain"):
        controllers.make("pbvs", lamda=0.5)
    with pytest.raises(InvalidParameterError, match="gain"):
        controllers.make("ibvs-current", gain=-1.0)
    with pytest.raises(InvalidParameterError, match="min_dwell"):
        controllers.make("hybrid", min_dwell=0)


# What the paper's virtual points (ERRATA 13: behind the camera or out of view) leave to each
# method: 2.5-D needs its reference point in front of the camera at the target (log Z/Z*), and
# MPC-IBVS needs the target features inside its image box.
REFUSED = {"paper-1": {"2.5d": "reference_point", "mpc-ibvs": "margin"}, "paper-2": {"mpc-ibvs": "margin"}}


@pytest.mark.parametrize("scenario", ["paper-1", "paper-2", "physical-1", "physical-2"])
def test_every_baseline_on_the_papers_four_stereo_scenarios(scenario, arm):
    """1 s on the dynamic arm: each method runs and its image error falls, or it refuses the task."""
    for name in BASELINES:
        refused = REFUSED.get(scenario, {}).get(name)
        if refused:
            with pytest.raises(InvalidParameterError, match=refused):
                iy.simulate(scenarios.get(scenario), controllers.make(name), duration=1.0, arm=arm)
            continue
        result = iy.simulate(scenarios.get(scenario), controllers.make(name), duration=1.0, arm=arm)
        e0, e1 = (np.linalg.norm(result.feature_error[i]) for i in (0, -1))
        assert result.status == "complete" and e1 < 0.75 * e0, (scenario, name)  # e^-0.5 = 0.61


def test_the_feature_laws_on_seeded_campaign_cases():
    """A seeded free-planar case (the campaign's square, up to 90 deg and 0.3 m away), 30 s.

    The polar and partitioned laws reach the target (within 1 mm and 0.1 deg); the moment law
    refuses the face-on square at reset, which a campaign stores as an 'error' row with the reason.
    """
    from ibvs_youla.campaign.definition import CampaignDefinition
    from ibvs_youla.campaign.run import run_spec

    definition = CampaignDefinition("free-planar", 1, FEATURE_LAWS, seed=24)  # the family's 30 s
    rows = [run_spec(spec) for spec in definition.specs()]
    outcomes = {(row["case"], row["controller"]): row["outcome"] for row in rows}
    assert outcomes == {(0, name): "error" if name == "ibvs-moments" else "reached" for name in FEATURE_LAWS}
    assert all("isotropic" in row["error"] for row in rows if row["controller"] == "ibvs-moments")
