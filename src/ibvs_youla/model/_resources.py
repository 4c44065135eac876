"""Locate, load and check robot descriptions (the URDFs shipped in ``ibvs_youla.urdf``, example-robot-data's).

:class:`~ibvs_youla.model.arm.Arm` accepts six revolute joints in series; these helpers turn
every other case into a :class:`~ibvs_youla.exceptions.ModelLoadError` that says what was
found. Physical validity (masses, inertias, axes, limits) is checked by
:mod:`ibvs_youla.model.urdf_checks`: the file before Pinocchio parses it, the model after.
"""

from __future__ import annotations

import importlib.resources
import sys
import sysconfig
from pathlib import Path
from typing import Any

import pinocchio as pin

from ..exceptions import ModelLoadError
from .urdf_checks import check_urdf_file

__all__ = ["check_chain", "example_robot_data_urdf", "frame_id", "load_urdf_model", "urdf_path"]

_N = 6  # joints of the arms this package handles


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


def frame_id(model: pin.Model, name: str, path: Any, role: str) -> int:
    """Id of frame ``name``, which must be rigidly attached to the last (sixth) joint."""
    if not model.existFrame(name):
        names = [f.name for f in model.frames]
        raise ModelLoadError(path, f"{role} frame {name!r} not in the model; frames are {names}")
    fid = model.getFrameId(name)
    if model.frames[fid].parentJoint != _N:
        raise ModelLoadError(path, f"{role} frame {name!r} is not rigidly attached to the last joint")
    return fid


def check_chain(model: pin.Model, path: Any) -> None:
    """Six revolute joints in series (their limits are checked by :func:`.urdf_checks.check_model`)."""
    if model.nq != _N or model.nv != _N or model.njoints != _N + 1:
        raise ModelLoadError(
            path, f"expected 6 one-DOF joints, got nq={model.nq}, nv={model.nv}, {model.njoints - 1} joints"
        )
    for j in range(1, _N + 1):
        joint = model.joints[j]
        if joint.nq != 1 or not joint.shortname().startswith("JointModelR") or model.parents[j] != j - 1:
            raise ModelLoadError(
                path,
                f"joint {model.names[j]!r} ({joint.shortname()}) is not a bounded "
                "revolute joint of a serial chain",
            )
