"""The light lists of names (``ibvs_youla.catalog``, what the command line offers) equal their registries."""

from __future__ import annotations

from ibvs_youla import catalog, controllers, scenarios
from ibvs_youla.analysis import suites
from ibvs_youla.campaign import cases, figures, robustness_axes, spec
from ibvs_youla.cli.parser import build_parser
from ibvs_youla.simulation import simulate


def test_the_controller_names_are_the_registry_s():
    # a method added to the registry must be added to catalog.CONTROLLERS too (the CLI's choices)
    assert catalog.CONTROLLERS == controllers.names()


def test_the_scenario_and_suite_names_are_the_registries():
    assert catalog.SCENARIOS == scenarios.NAMES
    assert catalog.SUITES == tuple(suites.SUITES)
    assert catalog.SUITE_TASKS == suites.TASK_NAMES


def test_the_robustness_axes_and_their_default_sweeps_are_the_registry_s():
    assert catalog.ROBUSTNESS_AXES == {
        name: tuple(robustness_axes.value_label(v) for v in axis.defaults)
        for name, axis in robustness_axes.AXES.items()
    }


def test_the_outcome_map_axes_and_their_default_are_the_figures():
    assert catalog.MAP_AXES == tuple(figures.AXES)
    assert build_parser().parse_args(["campaign-report", "DIR"]).axes == figures.DEFAULT_AXES


def test_names_defined_in_the_catalog_are_the_ones_the_library_uses():
    assert simulate.PLANTS is catalog.PLANTS
    assert spec.CAMERA_KINDS is catalog.CAMERA_KINDS
    assert cases.FAMILIES is catalog.FAMILIES and cases.ARM_FAMILIES is catalog.ARM_FAMILIES
