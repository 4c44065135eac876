"""The arm of a campaign as plain data: its identity in the definition and in every spec.

A campaign of an arm family runs on one arm. Its definition (``CampaignDefinition.arm``) and
each of its specs (``ExperimentSpec.arm``) hold the arm's *record*: the
:meth:`~ibvs_youla.model.arm.Arm.identity` as plain data (robot name, SHA-256 of the URDF, the
camera mount, the locked joints, the actuator terms and limits), plus, for an arm that is not a
named robot, ``"urdf"``: the file's path, where a worker finds it. The record is part of every
spec's JSON, hence of its key, so the runs of two arms never share a key.

**The IRB 4600 is the record None.** Campaigns stored before arms were a parameter hold no
record, and their keys are hashes of specs without one; the paper's arm as
:meth:`~ibvs_youla.model.arm.Arm.irb4600` builds it (the paper's actuator terms, its camera
mount) is therefore normalized to None (:func:`arm_record`), so its keys stay those of every
folder stored so far, and an IRB 4600 built otherwise (another mount, the reflected actuator
terms) gets a record of its own.

Workers rebuild the arm from the record (:func:`arm_from_record`, through
:meth:`~ibvs_youla.model.arm.Arm.from_identity`), once per record and thread: building an arm
costs 50-300 ms, a run reuses it.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..exceptions import InvalidParameterError

__all__ = ["arm_from_record", "arm_record", "default_arm"]

_LOCAL = threading.local()  # per thread: record JSON -> Arm (an Arm's Pinocchio data is per thread)
_DEFAULT: dict[str, Any] = {}  # the IRB 4600's identity, computed once per process


def default_arm() -> Any:
    """The arm of a campaign without a record: the IRB 4600 with the paper's terms (:meth:`Arm.irb4600`)."""
    return arm_from_record(None)


def _default_identity() -> dict[str, Any]:
    if not _DEFAULT:
        _DEFAULT.update(json.loads(json.dumps(default_arm().identity().to_dict())))
    return _DEFAULT


def arm_record(arm: Any) -> dict[str, Any] | None:
    """The record of ``arm`` (module docstring): None for the paper's IRB 4600, else plain data.

    Args:
        arm: An :class:`~ibvs_youla.model.arm.Arm`, a record (a mapping: an identity's
            ``to_dict()``, with ``"urdf"`` for an arm that is not a named robot), or None (the
            IRB 4600).

    Raises:
        InvalidParameterError: not an arm, a record or None; a record that is no identity; an
            arm that is not a named robot without its URDF file (path or record ``"urdf"``).
    """
    from ..model.arm import Arm
    from ..model.robots import ArmIdentity

    if arm is None:
        return None
    if isinstance(arm, Arm):
        identity = arm.identity().to_dict()
        urdf = None if arm.robot is not None or arm.urdf_path is None else str(Path(arm.urdf_path).resolve())
    elif isinstance(arm, Mapping):
        fields = {k: v for k, v in arm.items() if k != "urdf"}
        identity = ArmIdentity.from_dict(fields).to_dict()  # raises on a mapping that is no identity
        urdf = arm.get("urdf")
        if urdf is not None and not isinstance(urdf, str):
            raise InvalidParameterError("arm.urdf", urdf, "the URDF file's path, a string")
    else:
        raise InvalidParameterError(
            "arm", type(arm).__name__, "an Arm, its record (identity().to_dict(), with 'urdf'), or None"
        )
    identity = json.loads(json.dumps(identity))  # tuples to lists, as a stored record reads back
    if identity["robot"] is None and urdf is None:
        raise InvalidParameterError(
            "arm", "an arm that is not a named robot, without its URDF", "an Arm loaded from a URDF file"
        )
    if identity == _default_identity():
        return None
    return identity if identity["robot"] is not None else {**identity, "urdf": urdf}


def arm_from_record(record: Mapping[str, Any] | None) -> Any:
    """The arm of a record (None: the IRB 4600), built once per record and thread.

    Raises:
        InvalidParameterError: a record that is no identity.
        ModelLoadError: its URDF is missing or is not the one of the record (SHA-256).
    """
    from ..model.arm import Arm

    key = "" if record is None else json.dumps(dict(record), sort_keys=True)
    cache = getattr(_LOCAL, "arms", None)
    if cache is None:
        cache = _LOCAL.arms = {}
    arm = cache.get(key)
    if arm is None:
        if record is None:
            arm = Arm.irb4600()
        else:
            fields = {k: v for k, v in record.items() if k != "urdf"}
            arm = Arm.from_identity(fields, urdf=record.get("urdf"))
        cache[key] = arm
    return arm
