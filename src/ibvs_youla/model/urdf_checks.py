"""Physical validity of a robot description: the URDF text first, then the Pinocchio model built from it.

Pinocchio's URDF parser (urdfdom) reports a malformed value such as ``mass="nan"`` only on C
stderr and loads that link massless; it accepts a negative mass, an indefinite inertia and a zero
joint axis (which makes every pose after that joint non-rigid). So a URDF is checked twice:

- :func:`check_urdf_file` reads the XML itself (``xml.etree``, so each value is quoted as
  written) before Pinocchio parses it, and names the link or joint at fault;
- :func:`check_model` checks the Pinocchio model the arm computes with: the bodies its joints
  move (a link plus the links fixed to it, which Pinocchio merges), its joint axes, placements
  and limits. It also covers models that never were a URDF (``Arm(model)``, edited copies).

Rules (URDF elements as in the ROS URDF specification; the tolerances are the constants below):

- ``<inertial>``: ``<mass value>`` finite and > 0 [kg], or exactly 0 with an all-zero
  ``<inertia>`` (a massless frame, the idiom of ROS URDFs such as example-robot-data's UR5
  ``tool0``); ``<inertia>`` has its six entries, finite; the tensor is symmetric positive
  definite and its principal moments satisfy the triangle inequality
  ``I_a + I_b >= I_c`` (true of every rigid body; a flat plate reaches equality), both within
  ``TRIANGLE_RTOL`` times the trace.
- ``<origin>``: ``xyz`` and ``rpy`` three finite numbers each (a rotation from finite rpy is
  rigid by construction).
- ``<axis>`` of a moving joint: three finite numbers of unit length within ``AXIS_TOL``. A zero
  or non-unit axis is **rejected, not normalized**: Pinocchio would silently normalize a scaled
  one, so the file and the model would disagree; the message gives the unit axis to write.
- ``<limit>`` of a revolute or prismatic joint: ``lower`` and ``upper`` finite with lower <
  upper (both default to 0); ``velocity`` and ``effort`` finite and > 0 (the arm uses them as
  speed and torque limits). ``<dynamics>`` is not read (the arm takes damping from its
  actuator model).
- Model: each joint's body has a finite mass > 0 and a valid inertia tensor (a moving link
  without ``<inertial>`` has none); revolute axes are unit within ``AXIS_TOL``; every joint
  and frame placement is rigid (finite translation, ``R^T R = I`` and ``det R = 1`` within
  ``RIGID_TOL``); position limits finite with lower < upper, speed and effort limits finite
  and > 0.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from ..exceptions import ModelLoadError

__all__ = ["AXIS_TOL", "RIGID_TOL", "TRIANGLE_RTOL", "check_model", "check_urdf_file", "inertia_problem"]

AXIS_TOL = 1e-6  # accepted | |axis| - 1 | (printed round-off)
RIGID_TOL = 1e-6  # accepted max |R^T R - I| and |det R - 1| of a placement (as _validation.as_pose)
TRIANGLE_RTOL = 1e-6  # symmetry and triangle-inequality slack, relative to the trace of the inertia
_INERTIA_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
_MOVING = ("revolute", "continuous", "prismatic", "planar")
_LIMITED = ("revolute", "prismatic")
_MASS_VALID = "a finite mass > 0 [kg] (or 0 with an all-zero <inertia>: a massless frame)"
_INERTIA_VALID = (
    "a symmetric positive definite tensor whose principal moments satisfy I_a + I_b >= I_c "
    f"(rtol {TRIANGLE_RTOL:g})"
)
_BODY_VALID = "a finite mass > 0 [kg]: each link a joint moves needs an <inertial> (or a link fixed to it)"


def _invalid(path: Any, element: str, received: str, valid: str) -> ModelLoadError:
    source = "model" if path is None else f"URDF {str(path)!r}"
    return ModelLoadError(path, f"{source}: {element}: received {received}; valid: {valid}", element)


# ------------------------------------------------------------------------------ the XML
def check_urdf_file(path: Path) -> None:
    """Check the URDF at ``path`` as written (module rules); raise ModelLoadError naming the element.

    Raises:
        ModelLoadError: the file is missing, unreadable, empty or not XML, its root is not
            ``<robot>``, or a link or joint breaks a rule.
    """
    if not path.exists():
        raise ModelLoadError(path, f"URDF file {str(path)!r} does not exist")
    if not path.is_file():
        raise ModelLoadError(path, f"URDF file {str(path)!r} is not a file")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ModelLoadError(path, f"cannot read URDF file {str(path)!r}: {exc.strerror}") from None
    if not data.strip():
        raise ModelLoadError(path, f"cannot parse URDF {str(path)!r}: the file is empty")
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise ModelLoadError(path, f"cannot parse URDF {str(path)!r}: not well-formed XML ({exc})") from None
    if root.tag != "robot":
        raise ModelLoadError(
            path, f"cannot parse URDF {str(path)!r}: the root element is <{root.tag}>, not <robot>"
        )
    for link in root.findall("link"):
        inertial = link.find("inertial")
        if inertial is not None:
            _check_inertial(path, f"link {link.get('name')!r}", inertial)
    for joint in root.findall("joint"):
        _check_joint(path, f"joint {joint.get('name')!r}", joint)


def _numbers(path: Any, element: str, text: str | None, count: int, valid: str) -> list[float]:
    """``count`` finite numbers from an attribute's text, or ModelLoadError quoting it."""
    try:
        values = [float(word) for word in (text or "").split()]
    except ValueError:
        values = []
    if len(values) != count or not all(math.isfinite(x) for x in values):
        raise _invalid(path, element, "no value" if text is None else repr(text), valid)
    return values


def _check_origin(path: Any, element: str, origin: ET.Element | None) -> None:
    if origin is None:
        return
    for key in ("xyz", "rpy"):
        if origin.get(key) is not None:
            _numbers(path, f"{element} <origin {key}>", origin.get(key), 3, "three finite numbers")


def _check_inertial(path: Any, link: str, inertial: ET.Element) -> None:
    _check_origin(path, f"{link} <inertial>", inertial.find("origin"))
    mass_tag = inertial.find("mass")
    text = None if mass_tag is None else mass_tag.get("value")
    if text is None:
        raise _invalid(path, link, "an <inertial> without <mass value>", _MASS_VALID)
    mass = _numbers(path, f"{link} <mass value>", text, 1, _MASS_VALID)[0]
    tag = inertial.find("inertia")
    missing = list(_INERTIA_KEYS) if tag is None else [k for k in _INERTIA_KEYS if tag.get(k) is None]
    if tag is None or missing:
        raise _invalid(
            path, f"{link} <inertia>", f"no {', '.join(missing)}", f"all of {', '.join(_INERTIA_KEYS)}"
        )
    i = {
        k: _numbers(path, f"{link} <inertia {k}>", tag.get(k), 1, "a finite number [kg m^2]")[0]
        for k in _INERTIA_KEYS
    }
    inertia = np.array(
        [[i["ixx"], i["ixy"], i["ixz"]], [i["ixy"], i["iyy"], i["iyz"]], [i["ixz"], i["iyz"], i["izz"]]]
    )
    if mass == 0.0 and not inertia.any():
        return  # a massless frame
    if not mass > 0.0:
        raise _invalid(path, f"{link} <mass value>", repr(text), _MASS_VALID)
    problem = inertia_problem(inertia)
    if problem is not None:
        raise _invalid(path, f"{link} <inertia>", problem, _INERTIA_VALID)


def _check_joint(path: Any, joint: str, tag: ET.Element) -> None:
    kind = tag.get("type")
    _check_origin(path, joint, tag.find("origin"))
    axis_tag = tag.find("axis")
    if kind in _MOVING and axis_tag is not None:
        axis = _numbers(
            path, f"{joint} <axis xyz>", axis_tag.get("xyz"), 3, "three finite numbers, a unit vector"
        )
        _check_axis(path, joint, axis, f"<axis xyz={axis_tag.get('xyz')!r}>")
    if kind not in _LIMITED:
        return
    limit = tag.find("limit")
    if limit is None:
        raise _invalid(path, joint, f"a {kind} joint without <limit>", "<limit lower upper velocity effort>")
    lower, upper = (
        _numbers(path, f"{joint} <limit {key}>", limit.get(key, "0"), 1, "a finite number")[0]
        for key in ("lower", "upper")
    )
    if not lower < upper:
        received = f"lower={limit.get('lower', '0 (default)')}, upper={limit.get('upper', '0 (default)')}"
        raise _invalid(path, f"{joint} <limit>", received, "finite limits with lower < upper")
    for key in ("velocity", "effort"):
        valid = "a finite number > 0 (the arm's speed and torque limits)"
        if not _numbers(path, f"{joint} <limit {key}>", limit.get(key), 1, valid)[0] > 0.0:
            raise _invalid(path, f"{joint} <limit {key}>", repr(limit.get(key)), valid)


# ------------------------------------------------------------------------------ shared rules
def inertia_problem(inertia: np.ndarray) -> str | None:
    """What is wrong with a (3, 3) rotational inertia [kg m^2] (module rules), or None if it is valid."""
    if not np.all(np.isfinite(inertia)):
        return f"non-finite entries {inertia.tolist()}"
    slack = TRIANGLE_RTOL * abs(float(np.trace(inertia)))
    if np.abs(inertia - inertia.T).max() > slack:
        return f"an asymmetric tensor {inertia.tolist()}"
    moments = np.linalg.eigvalsh(inertia)  # ascending principal moments
    if moments[0] > 0.0 and moments[2] <= moments[0] + moments[1] + slack:
        return None
    text = f"principal moments {np.array2string(moments, precision=6)} [kg m^2]"
    if not moments[0] > 0.0:
        return f"{text}, not positive definite"
    excess = f"{moments[2]:.6g} > {moments[0]:.6g} + {moments[1]:.6g}"
    return f"{text}, which break the triangle inequality ({excess})"


def _check_axis(path: Any, joint: str, axis: Any, received: str) -> None:
    axis = np.asarray(axis, dtype=float)
    norm = float(np.linalg.norm(axis))
    if abs(norm - 1.0) > AXIS_TOL:
        hint = f"; write {' '.join(f'{x:.17g}' for x in axis / norm)}" if norm > 0.0 else ""
        raise _invalid(
            path, joint, f"{received} of length {norm:.6g}", f"a unit axis (within {AXIS_TOL:g}){hint}"
        )


# ------------------------------------------------------------------------------ the Pinocchio model
def check_model(model: pin.Model, path: Any) -> None:
    """Check the bodies, axes, placements and limits of ``model`` (module rules).

    Args:
        model: The Pinocchio model (any number of joints, each with finite position limits
            and positive speed and effort limits, as the arm needs).
        path: The file it came from (for the error), or None.

    Raises:
        ModelLoadError: naming the joint (and the links it moves) or the frame at fault.
    """
    frames = list(model.frames)
    for j in range(1, model.njoints):
        joint = f"joint {model.names[j]!r}"
        inertia = model.inertias[j]
        problem = _body_problem(inertia.mass, inertia.lever, np.asarray(inertia.inertia))
        if problem is not None:
            links = [f.name for f in frames if f.parentJoint == j and f.type == pin.FrameType.BODY]
            body = f"{joint} (moving link {', '.join(map(repr, links)) or 'none'})"
            raise _invalid(path, body, *problem)
        kind = model.joints[j].shortname()
        if kind == "JointModelRevoluteUnaligned":
            axis = np.asarray(model.joints[j].extract().axis, dtype=float)
            _check_axis(path, joint, axis, f"axis {axis.tolist()}")
    placements = [
        (f"joint {model.names[j]!r} placement", model.jointPlacements[j]) for j in range(1, model.njoints)
    ]
    _check_rigid(path, placements + [(f"frame {f.name!r} placement", f.placement) for f in frames])
    lower, upper = model.lowerPositionLimit, model.upperPositionLimit
    speed, effort = model.velocityLimit, model.effortLimit
    finite = np.isfinite(np.concatenate([lower, upper, speed, effort])).all()
    if not (finite and (lower < upper).all() and (speed > 0.0).all() and (effort > 0.0).all()):
        for j in range(1, model.njoints):
            _check_limits(model, j, path, f"joint {model.names[j]!r}")


def _body_problem(mass: float, lever: np.ndarray, inertia: np.ndarray) -> tuple[str, str] | None:
    """(received, valid) saying what is wrong with a body's mass, centre of mass or inertia, or None."""
    if not (math.isfinite(mass) and mass > 0.0):
        return f"a body of mass {mass:g} [kg]", _BODY_VALID
    if not np.isfinite(lever).all():
        return f"centre of mass {lever.tolist()}", "finite [m]"
    problem = inertia_problem(inertia)
    return None if problem is None else (problem, _INERTIA_VALID)


def _check_rigid(path: Any, placements: list[tuple[str, pin.SE3]]) -> None:
    """Raise naming the first placement that is not a finite rigid transform (within RIGID_TOL)."""
    H = np.array([placement.homogeneous for _, placement in placements])  # (n, 4, 4)
    R = H[:, :3, :3]
    with np.errstate(invalid="ignore", over="ignore"):
        error = np.maximum(
            np.abs(R.transpose(0, 2, 1) @ R - np.eye(3)).max(axis=(1, 2)), np.abs(np.linalg.det(R) - 1.0)
        )
    bad = ~(np.isfinite(H).all(axis=(1, 2)) & (error <= RIGID_TOL))
    if not bad.any():
        return
    k = int(np.argmax(bad))
    element = placements[k][0]
    if not np.isfinite(H[k]).all():
        received = f"R = {R[k].tolist()}, p = {H[k, :3, 3].tolist()}"
        raise _invalid(path, element, received, "a finite rigid transform")
    valid = f"a rotation within {RIGID_TOL:g} of SO(3)"
    raise _invalid(path, element, f"a rotation {error[k]:.3g} from SO(3)", valid)


def _check_limits(model: pin.Model, j: int, path: Any, joint: str) -> None:
    """Raise naming joint ``j`` if its position, speed or effort limits are not valid."""
    i, n = model.idx_qs[j], model.nqs[j]
    lower, upper = model.lowerPositionLimit[i : i + n], model.upperPositionLimit[i : i + n]
    if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper)) and np.all(lower < upper)):
        received = f"lower={lower.tolist()}, upper={upper.tolist()}"
        raise _invalid(
            path, f"{joint} position limits", received, "finite position limits with lower < upper"
        )
    i, n = model.idx_vs[j], model.nvs[j]
    for label, values, keyword in (
        ("velocity", model.velocityLimit, "dq_max"),
        ("effort", model.effortLimit, "tau_max"),
    ):
        values = values[i : i + n]
        if not (np.all(np.isfinite(values)) and np.all(values > 0.0)):
            valid = f"finite and > 0 (the URDF's <limit {label}>, or the arm's {keyword}=)"
            raise _invalid(path, f"{joint} {label} limit", f"{values.tolist()}", valid)
