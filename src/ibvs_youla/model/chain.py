"""The arm's chain: the joints from the base to the camera, every other joint locked, in joint coordinates.

A robot description may be a tree (a gripper's fingers, a second arm) with joints of several
kinds. The arm the toolkit controls is the chain from the base to the frame that carries the
camera; :func:`reduce_to_chain` turns a Pinocchio model into that chain:

1. **Locks** every joint that is not an ancestor of the camera frame's joint (grippers, fingers,
   joints beyond the camera's link), and every joint the caller names, with
   ``pinocchio.buildReducedModel`` at a stated value: the caller's (``locked_joints``, in joint
   coordinates: [rad] or [m]), else the joint's neutral position (Pinocchio's ``neutral``), except
   that an unnamed mimic joint (URDF ``<mimic>``) follows its leader's locked value
   (``multiplier * value + offset``).
2. **Checks** what is left: at least six joints in series, each revolute, continuous (an unbounded
   revolute) or prismatic, none a mimic joint, no floating or planar joint (a fixed-base arm).
3. **Joint coordinates**: a continuous joint has two configuration entries in Pinocchio (cos q,
   sin q; nq = 2, nv = 1). :func:`joint_coordinate_model` rebuilds the model with each of them
   as a revolute joint about the same axis, without position limits (-inf, +inf), so that the
   configuration is the joint vector q in R^n itself (angles [rad], prismatic positions [m]),
   n = ``model.nv``: the conversion to Pinocchio's configuration is done once, on the model, and
   every formula of the paper keeps q in R^n. The kinematics and dynamics are the same (a
   revolute joint at angle q has the placement and motion subspace of the unbounded one at
   (cos q, sin q); ``tests/test_robots.py`` pins the placements and ``pin.aba`` of both).

Every refusal is a :class:`~ibvs_youla.exceptions.ModelLoadError` naming the joint or frame.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from ..exceptions import ModelLoadError

__all__ = [
    "MIN_JOINTS",
    "MimicJoint",
    "joint_coordinate_model",
    "joint_kinds",
    "mimic_joints",
    "reduce_to_chain",
]

MIN_JOINTS = 6  # a camera pose has six degrees of freedom
_REVOLUTE = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned")
_CONTINUOUS = {
    "JointModelRUBX": "JointModelRX",
    "JointModelRUBY": "JointModelRY",
    "JointModelRUBZ": "JointModelRZ",
    "JointModelRevoluteUnboundedUnaligned": "JointModelRevoluteUnaligned",
}
_PRISMATIC = ("JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned")


@dataclass(frozen=True)
class MimicJoint:
    """A URDF ``<mimic>``: this joint's value is ``multiplier * leader + offset``."""

    leader: str
    multiplier: float = 1.0
    offset: float = 0.0


def mimic_joints(path: Path) -> dict[str, MimicJoint]:
    """The mimic joints of a URDF file (already checked to be well-formed XML), by name."""
    out = {}
    for joint in ET.parse(path).getroot().findall("joint"):
        tag = joint.find("mimic")
        if tag is not None:
            out[str(joint.get("name"))] = MimicJoint(
                str(tag.get("joint")), float(tag.get("multiplier", "1")), float(tag.get("offset", "0"))
            )
    return out


def joint_kinds(model: pin.Model) -> tuple[str, ...]:
    """``"revolute"``, ``"continuous"`` or ``"prismatic"`` for each joint of a chain model (1..njoints-1)."""
    kinds = []
    for j in range(1, model.njoints):
        name = model.joints[j].shortname()
        kinds.append(
            "continuous" if name in _CONTINUOUS else "prismatic" if name in _PRISMATIC else "revolute"
        )
    return tuple(kinds)


def _describe(kind: str) -> str:
    return {
        "JointModelFreeFlyer": "a floating joint (the arm needs a fixed base)",
        "JointModelPlanar": "a planar joint (the arm needs a fixed base)",
        "JointModelSpherical": "a spherical joint",
        "JointModelSphericalZYX": "a spherical joint",
    }.get(kind, f"a {kind} joint")


def _ancestors(model: pin.Model, joint: int) -> list[int]:
    chain = []
    while joint > 0:
        chain.append(joint)
        joint = int(model.parents[joint])
    return chain[::-1]


def _candidate_frames(model: pin.Model, locked: set[int]) -> list[str]:
    """Frames with at least MIN_JOINTS unlocked joints between them and the base (camera candidates)."""
    out = []
    for frame in model.frames:
        chain = [j for j in _ancestors(model, int(frame.parentJoint)) if j not in locked]
        if len(chain) >= MIN_JOINTS and frame.name not in out:
            out.append(frame.name)
    return out


def _frame_id(model: pin.Model, name: str, path: Any, role: str, locked: set[int]) -> int:
    """Id of the frame ``name`` (a BODY frame first when several share the name)."""
    if not model.existFrame(name):
        raise ModelLoadError(
            path,
            f"{role} frame {name!r} is not in the model; frames on a chain of >= {MIN_JOINTS} joints "
            f"(candidates): {_candidate_frames(model, locked)}",
            f"frame {name!r}",
        )
    ids = [i for i, f in enumerate(model.frames) if f.name == name]
    body = [i for i in ids if model.frames[i].type == pin.FrameType.BODY]
    return (body or ids)[0]


def _locked_value(model: pin.Model, j: int, value: Any, path: Any) -> np.ndarray:
    """Pinocchio configuration entries of joint ``j`` locked at ``value`` (joint coordinates)."""
    joint, name = model.joints[j], model.names[j]
    kind = joint.shortname()
    if joint.nv == 1 and np.ndim(value) == 0:
        x = float(value)
        if not math.isfinite(x):
            raise ModelLoadError(
                path, f"locked joint {name!r}: value {value!r} is not finite", f"joint {name!r}"
            )
        return np.array([math.cos(x), math.sin(x)]) if kind in _CONTINUOUS else np.array([x])
    values = np.asarray(value, dtype=float).reshape(-1)
    if values.shape != (joint.nq,) or not np.isfinite(values).all():
        valid = "a finite number [rad or m]" if joint.nv == 1 else f"{joint.nq} finite configuration entries"
        raise ModelLoadError(
            path, f"locked joint {name!r} ({kind}): received {value!r}; valid: {valid}", f"joint {name!r}"
        )
    return values


def reduce_to_chain(
    model: pin.Model,
    camera_frame: str,
    locked_joints: Mapping[str, Any] | None,
    mimic: Mapping[str, MimicJoint],
    path: Any,
) -> tuple[pin.Model, dict[str, Any]]:
    """The chain from the base to ``camera_frame``, every other joint locked (module docstring).

    Args:
        model: The full model (not modified).
        camera_frame: The frame the camera is mounted on.
        locked_joints: Joints to lock, by name, at a value in joint coordinates (a number for
            a one-degree-of-freedom joint, [rad] or [m]; a joint's Pinocchio configuration
            entries otherwise); None or empty: only the joints off the chain, at neutral.
        mimic: The URDF's mimic joints (:func:`mimic_joints`).
        path: The file, for the errors.

    Returns:
        (the reduced model, the locked joints and their values in joint coordinates).

    Raises:
        ModelLoadError: an unknown locked joint, a camera frame not in the model (the
            message lists the candidate frames), fewer than six joints on the chain, a
            mimic, floating, planar or multi-axis joint on it; each naming the element.
    """
    locked_joints = dict(locked_joints or {})
    ids = {model.names[j]: j for j in range(1, model.njoints)}
    for name in locked_joints:
        if name not in ids:
            raise ModelLoadError(
                path,
                f"locked joint {name!r} is not a joint of the model; joints: {list(ids)}",
                f"joint {name!r}",
            )
    asked = {ids[name] for name in locked_joints}
    frame = _frame_id(model, camera_frame, path, "camera", asked)
    chain = [j for j in _ancestors(model, int(model.frames[frame].parentJoint)) if j not in asked]
    if len(chain) < MIN_JOINTS:
        names = [model.names[j] for j in chain]
        raise ModelLoadError(
            path,
            f"camera frame {camera_frame!r}: {len(chain)} joint(s) on the chain from the base ({names}), "
            f"fewer than {MIN_JOINTS} (a camera pose has six degrees of freedom); frames on a chain of "
            f">= {MIN_JOINTS} joints (candidates): {_candidate_frames(model, asked)}",
            f"frame {camera_frame!r}",
        )
    for j in chain:
        name, kind = model.names[j], model.joints[j].shortname()
        if name in mimic:
            leader = mimic[name].leader
            raise ModelLoadError(
                path,
                f"joint {name!r} mimics joint {leader!r} (URDF <mimic>) and is on the chain to the camera "
                f"frame {camera_frame!r}: the arm's joints must be independent (lock it with locked_joints)",
                f"joint {name!r}",
            )
        if kind not in _REVOLUTE and kind not in _CONTINUOUS and kind not in _PRISMATIC:
            raise ModelLoadError(
                path,
                f"joint {name!r} ({kind}) on the chain to the camera frame {camera_frame!r} is "
                f"{_describe(kind)}; valid: revolute, continuous or prismatic joints",
                f"joint {name!r}",
            )
    on_chain = set(chain)
    lock = [j for j in range(1, model.njoints) if j not in on_chain]
    q_ref = pin.neutral(model)
    values: dict[str, Any] = {}
    for j in lock:  # the caller's values, then mimic joints after their leaders, else neutral
        name = model.names[j]
        if name in locked_joints:
            q_ref[model.idx_qs[j] : model.idx_qs[j] + model.nqs[j]] = _locked_value(
                model, j, locked_joints[name], path
            )
            values[name] = _plain(locked_joints[name])
    for j in lock:
        name = model.names[j]
        if name in values:
            continue
        follow = mimic.get(name)
        if follow is not None and follow.leader in ids and model.joints[j].nv == 1:
            leader = ids[follow.leader]
            lead = values.get(follow.leader)
            if lead is None and leader not in on_chain and model.joints[leader].nq == 1:
                lead = float(q_ref[model.idx_qs[leader]])
            if lead is not None and np.ndim(lead) == 0:
                value = follow.multiplier * float(lead) + follow.offset
                q_ref[model.idx_qs[j] : model.idx_qs[j] + model.nqs[j]] = _locked_value(model, j, value, path)
                values[name] = value
                continue
        entries = q_ref[model.idx_qs[j] : model.idx_qs[j] + model.nqs[j]]
        values[name] = _neutral_value(model, j, entries)
    reduced = pin.buildReducedModel(model, lock, q_ref) if lock else model.copy()
    return reduced, values


def _neutral_value(model: pin.Model, j: int, entries: np.ndarray) -> Any:
    """A locked joint's value in joint coordinates (an angle for a continuous joint)."""
    kind = model.joints[j].shortname()
    if kind in _CONTINUOUS:
        return math.atan2(float(entries[1]), float(entries[0]))
    if entries.size == 1:
        return float(entries[0])
    return [float(x) for x in entries]


def _plain(value: Any) -> Any:
    return float(value) if np.ndim(value) == 0 else [float(x) for x in np.asarray(value).reshape(-1)]


def joint_coordinate_model(model: pin.Model) -> pin.Model:
    """``model`` with every continuous joint rebuilt as a revolute one without limits (module docstring).

    Joint order, names, placements, bodies, frames (same ids), limits of the other joints,
    armature, damping, friction and gravity are kept. A model without continuous joints is
    returned as it is (the caller copies it).
    """
    if not any(model.joints[j].shortname() in _CONTINUOUS for j in range(1, model.njoints)):
        return model
    new = pin.Model()
    new.name = model.name
    new.gravity = model.gravity
    for j in range(1, model.njoints):
        joint = model.joints[j]
        kind = joint.shortname()
        v = model.idx_vs[j]
        if kind in _CONTINUOUS:
            target = _CONTINUOUS[kind]
            if target == "JointModelRevoluteUnaligned":
                joint_model = pin.JointModelRevoluteUnaligned(np.asarray(joint.extract().axis, dtype=float))
            else:
                joint_model = getattr(pin, target)()
            lower, upper = np.array([-np.inf]), np.array([np.inf])
        else:
            joint_model = joint
            i, n = model.idx_qs[j], model.nqs[j]
            lower, upper = model.lowerPositionLimit[i : i + n], model.upperPositionLimit[i : i + n]
        idx = new.addJoint(
            int(model.parents[j]),
            joint_model,
            model.jointPlacements[j],
            model.names[j],
            model.effortLimit[v : v + joint.nv],
            model.velocityLimit[v : v + joint.nv],
            lower,
            upper,
        )
        new.appendBodyToJoint(idx, model.inertias[j], pin.SE3.Identity())
    for frame in list(model.frames)[1:]:
        new.addFrame(pin.Frame(frame), False)  # the inertias are in the joints' bodies already
    for name in ("armature", "damping", "friction", "rotorInertia", "rotorGearRatio"):
        getattr(new, name)[:] = getattr(model, name)
    return new
