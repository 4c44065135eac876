"""Locate, load and check robot descriptions (the URDFs shipped in ``ibvs_youla.urdf``, example-robot-data's).

:class:`~ibvs_youla.model.arm.Arm` reduces a model to the chain it controls
(:mod:`ibvs_youla.model.chain`); these helpers find and parse the file, turning every failure
into a :class:`~ibvs_youla.exceptions.ModelLoadError` that says what was found. Physical
validity (masses, inertias, axes, limits) is checked by :mod:`ibvs_youla.model.urdf_checks`:
the file before Pinocchio parses it, the model after.
"""

from __future__ import annotations

import importlib.resources
import sys
import sysconfig
from pathlib import Path

import pinocchio as pin

from ..exceptions import ModelLoadError
from .urdf_checks import check_urdf_file

__all__ = ["example_robot_data_urdf", "load_urdf_model", "urdf_path"]


def urdf_path(name: str) -> Path:
    """Path of a URDF shipped with ibvs-youla (package ``ibvs_youla.urdf``)."""
    path = Path(str(importlib.resources.files("ibvs_youla.urdf") / name))
    if not path.is_file():
        raise ModelLoadError(path, f"{name!r} is not among the URDFs shipped in ibvs_youla.urdf")
    return path


def example_robot_data_urdf(relative: str) -> Path:
    """Path of a URDF of the example-robot-data wheel, e.g. ``"ur_description/urdf/ur5_robot.urdf"``.

    The PyPI wheel installs data only (no Python module) under
    ``<site-packages>/cmeel.prefix/share/example-robot-data/robots``; this looks there
    for every site-packages directory of the running interpreter.
    """
    roots = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"], *filter(None, sys.path)}
    tried = []
    for root in sorted(roots):
        path = Path(root) / "cmeel.prefix" / "share" / "example-robot-data" / "robots" / relative
        tried.append(str(path))
        if path.is_file():
            return path
    raise ModelLoadError(relative, f"example-robot-data URDF {relative!r} not found; looked in {tried[:3]}")


def load_urdf_model(path: Path) -> pin.Model:
    """Pinocchio model of a URDF file (fixed base, no meshes), or ModelLoadError.

    The file is checked as written first (:func:`~ibvs_youla.model.urdf_checks.check_urdf_file`):
    Pinocchio's parser reports some malformed values only on C stderr and drops them.
    """
    check_urdf_file(path)
    try:
        return pin.buildModelFromUrdf(str(path))
    except (RuntimeError, ValueError) as exc:
        raise ModelLoadError(path, f"Pinocchio cannot parse URDF {str(path)!r}: {exc}") from None
