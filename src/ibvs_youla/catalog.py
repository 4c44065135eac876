"""The names the library's registries accept, importable without numpy or any heavy dependency.

The command line lists these as its choices (``--controller``, ``--plant``, ``--scenario``,
``--axis``, ``--robot``, ...) and checks them while it parses, so that ``ibvs-youla --help`` and an argument
error answer at once: importing the registries themselves loads python-control, Pinocchio,
SciPy and Numba (seconds). This module imports nothing.

Where a name is only a name (plants, camera kinds, case families), it is defined here and the
module that uses it imports it. Where a registry holds objects (controllers, robots, scenarios,
suite tasks, robustness axes, outcome-map axes), the registry stays the source and this module holds
the list of its names, in the registry's order; ``tests/test_catalog.py`` checks that each list
equals its registry, so a new registry entry fails that test until its name is added here.
"""

from __future__ import annotations

__all__ = [
    "ARM_FAMILIES",
    "CAMERA_KINDS",
    "CONTROLLERS",
    "FAMILIES",
    "MAP_AXES",
    "MOUNTS",
    "MOUNT_FAMILIES",
    "PLANTS",
    "ROBOTS",
    "ROBUSTNESS_AXES",
    "SCENARIOS",
    "SUITES",
    "SUITE_TASKS",
    "TEXTURED_SCENARIO",
]

# Defined here, imported by the modules that use them.
PLANTS: tuple[str, ...] = ("dynamic", "kinematic", "free-camera")  # ibvs_youla.simulate's plants
MOUNTS: tuple[str, ...] = ("eye-in-hand", "eye-to-hand")  # ibvs_youla.model.mount's kinds
CAMERA_KINDS: tuple[str, ...] = ("stereo", "mono", "normalized", "pinhole")  # a campaign's cameras
FAMILIES: tuple[str, ...] = (
    "arm-physical",
    "arm-virtual",
    "free-planar",
    "free-nonplanar",
    "free-roll",
    "free-textured",
    "arm-eye-in-hand",
    "arm-eye-to-hand",
)
# matched: case k of both mount families is one draw, eye-in-hand and eye-to-hand
MOUNT_FAMILIES: tuple[str, ...] = ("arm-eye-in-hand", "arm-eye-to-hand")
# the case families of an arm plant
ARM_FAMILIES: tuple[str, ...] = ("arm-physical", "arm-virtual", *MOUNT_FAMILIES)

# Names of registries that hold objects (each checked against its registry by the tests).
ROBOTS: tuple[str, ...] = (  # ibvs_youla.robots.names(): the named arms (ibvs_youla.model.robots)
    "irb4600",
    "ur3",
    "ur5",
    "ur10",
    "panda",
    "xarm7",
    "z1",
    "kinova",
)
CONTROLLERS: tuple[str, ...] = (  # ibvs_youla.controllers.names(), as the package registers them
    "fb",
    "ff+fb",
    "ibvs-current",
    "ibvs-desired",
    "ibvs-mean",
    "pbvs",
    "2.5d",
    "hybrid",
    "mpc-ibvs",
    "ibvs-polar",
    "ibvs-partitioned",
    "ibvs-moments",
    "photometric",
)
SCENARIOS: tuple[str, ...] = ("paper-1", "paper-2", "physical-1", "physical-2")  # ibvs_youla.scenarios.NAMES
TEXTURED_SCENARIO = "textured-plane"  # compare's scenario of ibvs_youla.scenarios.textured_plane()
SUITES: tuple[str, ...] = ("gans2003",)  # ibvs_youla.analysis.suites.SUITES
SUITE_TASKS: tuple[str, ...] = (  # ibvs_youla.analysis.suites.TASK_NAMES
    "gans-rz-30",
    "gans-rz-60",
    "gans-rz-90",
    "gans-rz-120",
    "gans-rz-150",
    "gans-rz-180",
    "gans-tz-approach",
    "gans-tz-retreat",
    "gans-plane-30",
    "gans-plane-60",
    "gans-general",
)
# ibvs_youla.campaign.robustness_axes.AXES: axis name -> its default sweep, as value_label writes it
ROBUSTNESS_AXES: dict[str, tuple[str, ...]] = {
    "noise": ("0", "0.1", "0.3", "1", "3"),
    "images": ("0", "2", "5", "10", "20"),
    "calibration": ("0", "0.5", "1", "2", "4"),
    "mismatch": ("0", "0.5", "1", "2", "4"),
    "latency": ("0", "10", "30", "100", "300"),
    "saturation": ("inf", "1", "0.5", "0.25"),
}
# ibvs_youla.campaign.figures.AXES: the start-pose coordinates of a campaign's outcome maps
MAP_AXES: tuple[str, ...] = ("twist", "tilt", "rotation", "translation", "tx", "ty", "tz", "rx", "ry", "rz")
