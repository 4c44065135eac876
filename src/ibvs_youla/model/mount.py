"""How the camera is mounted: on the arm (eye-in-hand) or fixed in the cell (eye-to-hand), as plain data.

* **eye-in-hand** (the default, and what an absent mount means): the camera rides on the arm, on
  the frame and at the transform its :class:`~ibvs_youla.model.arm.Arm` holds (``camera_frame``,
  ``T_F_C``); the markers are fixed in the base frame {O}.
* **eye-to-hand**: the camera is fixed in the base frame at ``T_O_C``, and the markers ride on
  the arm, fixed in a frame of its last link that carries them (``carrier_frame``, default the
  arm's flange {E}); their coordinates are given in that frame.

A :class:`Mount` is frozen plain data (the camera pose as nested tuples of floats), so a
scenario, a run's specification and a campaign key can hold it; :meth:`Mount.to_dict` and
:meth:`Mount.from_dict` convert it to and from JSON-ready data. What the mount does to the arm's
kinematics (eye-to-hand is eye-in-hand seen from the marker carrier) is
:mod:`ibvs_youla.model.eye_to_hand`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validation import as_pose, one_of, text
from ..exceptions import InvalidParameterError

__all__ = ["EYE_IN_HAND", "EYE_TO_HAND", "MOUNTS", "Mount"]

EYE_IN_HAND, EYE_TO_HAND = "eye-in-hand", "eye-to-hand"
MOUNTS = (EYE_IN_HAND, EYE_TO_HAND)
_KEYS = ("kind", "T_O_C", "carrier_frame")

Rows = tuple[tuple[float, ...], ...]


@dataclass(frozen=True)
class Mount:
    """The camera's mounting (module docstring), validated at construction.

    Build one with :meth:`eye_in_hand`, :meth:`eye_to_hand` or :meth:`from_dict`.

    Attributes:
        kind: ``"eye-in-hand"`` or ``"eye-to-hand"``.
        T_O_C: Eye-to-hand: the fixed camera's pose in the base frame (4, 4), nested tuples
            [m]; None eye-in-hand (the arm holds its camera mount).
        carrier_frame: Eye-to-hand: the frame of the arm's last link the markers are fixed in;
            None for the arm's flange frame (and always None eye-in-hand).

    Raises:
        InvalidParameterError: an unknown kind, a camera pose or carrier frame given
            eye-in-hand, no camera pose eye-to-hand, a carrier frame that is not a name.
        InvalidArrayError: a camera pose that is not a finite rigid (4, 4) transform.
    """

    kind: str = EYE_IN_HAND
    T_O_C: Rows | None = None
    carrier_frame: str | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        one_of(self.kind, "mount.kind", MOUNTS)
        if self.kind == EYE_IN_HAND:
            for name in ("T_O_C", "carrier_frame"):
                if getattr(self, name) is not None:
                    raise InvalidParameterError(
                        f"mount.{name}",
                        getattr(self, name),
                        "None for an eye-in-hand mount (the camera rides on the arm, where its Arm "
                        "puts it: camera_frame, T_F_C); an eye-to-hand mount takes T_O_C",
                    )
            return
        if self.T_O_C is None:
            raise InvalidParameterError(
                "mount.T_O_C",
                None,
                "the fixed camera's pose in the base frame (4, 4) for an eye-to-hand mount",
            )
        T = as_pose(self.T_O_C, "mount.T_O_C")
        set_(self, "T_O_C", tuple(tuple(float(x) for x in row) for row in T))
        if self.carrier_frame is not None:
            set_(self, "carrier_frame", text(self.carrier_frame, "mount.carrier_frame", empty=False))

    @classmethod
    def eye_in_hand(cls) -> Mount:
        """The camera on the arm (its Arm's ``camera_frame`` and ``T_F_C``), markers fixed in the base."""
        return cls()

    @classmethod
    def eye_to_hand(cls, T_O_C: Any, carrier_frame: str | None = None) -> Mount:
        """A camera fixed at ``T_O_C`` (4, 4) in the base frame, watching markers on ``carrier_frame``.

        Args:
            T_O_C: The camera's pose in the base frame, a rigid transform [m].
            carrier_frame: The frame of the arm's last link the markers are fixed in; default
                (None) the arm's flange frame.
        """
        return cls(EYE_TO_HAND, T_O_C, carrier_frame)

    @classmethod
    def from_dict(cls, data: Any) -> Mount:
        """A mount from :meth:`to_dict`'s data (or a Mount, returned as it is).

        ``{"kind": "eye-in-hand"}`` or ``{"kind": "eye-to-hand", "T_O_C": [[...] x 4],
        "carrier_frame": "flange"}`` (``carrier_frame`` optional); a bare kind string is read as
        ``{"kind": kind}``.

        Raises:
            InvalidParameterError: not a mapping (or a kind), an unknown key, or a field the
                constructor rejects.
        """
        if isinstance(data, Mount):
            return data
        if isinstance(data, str):
            data = {"kind": data}
        if not isinstance(data, Mapping):
            raise InvalidParameterError(
                "mount", type(data).__name__, "a Mount, a kind ('eye-in-hand' or 'eye-to-hand') or a mapping"
            )
        unknown = sorted(str(k) for k in data if k not in _KEYS)
        if unknown:
            raise InvalidParameterError("mount", unknown, f"keys among {', '.join(_KEYS)}")
        return cls(data.get("kind", EYE_IN_HAND), data.get("T_O_C"), data.get("carrier_frame"))

    def to_dict(self) -> dict[str, Any]:
        """Plain data: ``{"kind"}`` eye-in-hand; with ``T_O_C`` (lists) and ``carrier_frame`` eye-to-hand."""
        if self.kind == EYE_IN_HAND:
            return {"kind": self.kind}
        return {
            "kind": self.kind,
            "T_O_C": [list(row) for row in self.T_O_C],  # type: ignore[union-attr]
            "carrier_frame": self.carrier_frame,
        }

    @property
    def is_eye_to_hand(self) -> bool:
        """True for a camera fixed in the base frame watching markers on the arm."""
        return self.kind == EYE_TO_HAND

    @property
    def camera_pose(self) -> np.ndarray:
        """T_O_C (4, 4) of an eye-to-hand mount, a new array.

        Raises:
            InvalidParameterError: an eye-in-hand mount (its camera pose depends on q: ask the arm).
        """
        if self.T_O_C is None:
            raise InvalidParameterError(
                "mount",
                self.kind,
                "an eye-to-hand mount (an eye-in-hand camera's pose is arm.camera_pose(q))",
            )
        return np.array(self.T_O_C, dtype=float)
