"""Servoing scenarios: start and target joint angles, markers, disturbance (Section 7, Table 1).

Four presets, by name (:func:`get`, :data:`NAMES`):

* ``"paper-1"``, ``"paper-2"`` — Table 1's joint angles and the paper's three markers
  (-0.5, 0, 0), (0, 0, 0.5), (2, -2, 0) m. Those markers lie behind the camera in
  scenario 1 and far outside the field of view in scenario 2 (ERRATA 13), so these
  scenarios are flagged ``virtual_points=True``: the simulator projects them through
  the pinhole model regardless of depth sign and field of view, as the paper does.
  Scenario 2 adds the disturbance ``d = 1 deg`` on every joint (ERRATA 14).
* ``"physical-1"``, ``"physical-2"`` — the same joint angles (and disturbance) with
  markers a real ZED 2 sees: in front of the camera and inside the paper's field of
  view (86.09 x 55.35 deg, depth 0.5-25 m) at the start pose, the target pose, along
  the straight joint-space path between them, with and without the disturbance.

Placement of the physical markers (reproducible with :func:`place_markers`): in the
target camera frame ``C`` (``T_O_C = arm.camera_pose(q_target)``, ERRATA 2 hand-eye),
marker i lies at depth ``Z_i`` on the ray through normalised image coordinates
``(x_i, y_i)`` = (-0.3, -0.2), (0.3, -0.2), (0, 0.25), i.e. ``P_C = Z_i (x_i, y_i, 1)``,
then ``P_O = T_O_C P_C`` rounded to the millimetre. Depths: scenario 1 (camera
looking along +x of the base) 2.0, 2.5, 3.0 m; scenario 2 (camera 1 m above the base
plane looking straight down, ERRATA 6) 0.75, 0.85, 0.95 m. The distinct depths keep the
triangle well away from any degenerate configuration. Resulting ``P_O`` [m]:

* physical-1: (3.287, -0.661, 1.932), (3.617, -0.957, 0.559), (4.372, 0.263, 1.124)
* physical-2: (1.150, 1.225, 0.250), (1.170, 0.745, 0.150), (0.762, 1.000, 0.050)

Checked with the IRB 4600 model and the paper's ZED 2 (``tests/test_scenarios.py``), along
all those paths: image coordinates of either lens reach at most 78 % (scenario 1) and 67 %
(scenario 2) of the half sensor extent; nearest depth 1.97 m and 0.62 m.

Joint-vector semantics: ``q_start`` is the initial *encoder* reading (the true arm starts
at ``q_start + d``); ``q_target`` is the *true* configuration whose camera pose defines
the target features, reached when the encoders read ``q_target - d``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._reproducible import matmul
from ._validation import as_array, as_pose, one_of
from .estimation.stereo_pose import check_marker_geometry
from .exceptions import InvalidParameterError, JointLimitError

__all__ = [
    "NAMES",
    "PAPER_MARKERS_O",
    "Scenario",
    "get",
    "paper",
    "paper_scenarios",
    "physical",
    "physical_scenarios",
    "place_markers",
]

# Table 1, joint angles [deg]
_TABLE1_DEG = {
    1: ((0.0, 0.0, 0.0, 0.0, 0.0, 0.0), (0.48, 2.21, 2.05, -82.68, 9.46, 77.47)),
    2: ((42.40, 21.20, 4.58, -2.86, 66.46, -42.40), (45.0, 18.59, 4.35, 0.0, 67.06, -45.0)),
}
_DISTURBANCE_DEG = {1: 0.0, 2: 1.0}  # ERRATA 14: step on every joint for the whole run
PAPER_MARKERS_O = np.array([[-0.5, 0.0, 0.0], [0.0, 0.0, 0.5], [2.0, -2.0, 0.0]])  # [m], Section 7
PAPER_MARKERS_O.setflags(write=False)

# Physical markers: rays in the target camera (normalised image coordinates) and depths [m]
MARKER_RAYS_XY = ((-0.3, -0.2), (0.3, -0.2), (0.0, 0.25))
MARKER_DEPTHS = {1: (2.0, 2.5, 3.0), 2: (0.75, 0.85, 0.95)}
_PHYSICAL_MARKERS_O = {  # place_markers(arm.camera_pose(q_target), ...) rounded to 1 mm
    1: ((3.287, -0.661, 1.932), (3.617, -0.957, 0.559), (4.372, 0.263, 1.124)),
    2: ((1.150, 1.225, 0.250), (1.170, 0.745, 0.150), (0.762, 1.000, 0.050)),
}


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Scenario:
    """One servoing task, validated at construction; arrays are stored read-only.

    An arm scenario gives joint configurations (``q_start``, ``q_target``); a free-flying
    camera scenario (:meth:`free_camera`) gives camera poses instead. An arm scenario can
    also run on the free-flying camera: its poses are then the arm's forward kinematics.

    Attributes:
        q_start: Initial encoder joint angles (6,) [rad], or ``None`` without an arm.
        q_target: True joint angles of the target camera pose (6,) [rad], or ``None``.
        markers_O: Marker positions in the base frame, one per row (n, 3), n >= 3 [m]
            (the paper uses three; a monocular camera needs four or more).
        joint_offset: Disturbance ``d`` (6,) [rad]: true angles = encoder + d (ERRATA 14);
            ``None`` is stored as zeros.
        name: Short identifier, e.g. ``"paper-1"``.
        virtual_points: Project markers even when behind the camera or out of view (ERRATA 13).
        description: Free text.
        T_O_C_start: Initial camera pose (4, 4) of a free-camera scenario, else ``None``.
        T_O_C_target: Target camera pose (4, 4) of a free-camera scenario, else ``None``.

    Raises:
        InvalidArrayError: wrong shape or non-finite entries.
        DegenerateMarkersError: coincident or collinear markers.
        InvalidParameterError: neither joints nor camera poses (or both), ``name`` or
            ``description`` not strings, ``virtual_points`` not bool.
    """

    q_start: np.ndarray | None = None
    q_target: np.ndarray | None = None
    markers_O: np.ndarray | None = None
    joint_offset: np.ndarray | None = None
    name: str = ""
    virtual_points: bool = False
    description: str = ""
    T_O_C_start: np.ndarray | None = None
    T_O_C_target: np.ndarray | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        joints = (self.q_start is not None, self.q_target is not None)
        poses = (self.T_O_C_start is not None, self.T_O_C_target is not None)
        if joints == (True, True) and poses == (False, False):
            set_(self, "q_start", _frozen(as_array(self.q_start, "q_start", (6,))))
            set_(self, "q_target", _frozen(as_array(self.q_target, "q_target", (6,))))
        elif joints == (False, False) and poses == (True, True):
            set_(self, "T_O_C_start", _frozen(as_pose(self.T_O_C_start, "T_O_C_start")))
            set_(self, "T_O_C_target", _frozen(as_pose(self.T_O_C_target, "T_O_C_target")))
        else:
            raise InvalidParameterError(
                "scenario",
                f"q_start/q_target given: {joints}, T_O_C_start/T_O_C_target given: {poses}",
                "both joint configurations (an arm scenario) or both camera poses (a free-camera scenario)",
            )
        offset = np.zeros(6) if self.joint_offset is None else self.joint_offset
        set_(self, "joint_offset", _frozen(as_array(offset, "joint_offset", (6,))))
        if self.markers_O is None:
            raise InvalidParameterError("markers_O", None, "marker positions (n, 3), n >= 3 [m]")
        set_(self, "markers_O", _frozen(check_marker_geometry(self.markers_O, "markers_O")))
        for field_name in ("name", "description"):
            if not isinstance(getattr(self, field_name), str):
                raise InvalidParameterError(field_name, getattr(self, field_name), "a string")
        if not isinstance(self.virtual_points, (bool, np.bool_)):
            raise InvalidParameterError("virtual_points", self.virtual_points, "True or False")
        set_(self, "virtual_points", bool(self.virtual_points))

    @classmethod
    def free_camera(
        cls,
        T_O_C_start: Any,
        T_O_C_target: Any,
        markers_O: Any,
        *,
        name: str = "free-camera",
        virtual_points: bool = False,
        description: str = "",
    ) -> Scenario:
        """A camera with no arm: start and target poses (4, 4) and markers (n, 3) in the base frame [m]."""
        return cls(
            markers_O=markers_O,
            name=name,
            virtual_points=virtual_points,
            description=description,
            T_O_C_start=T_O_C_start,
            T_O_C_target=T_O_C_target,
        )

    @property
    def has_joints(self) -> bool:
        """True for an arm scenario (joint configurations given), False for a free-camera one."""
        return self.q_start is not None

    @property
    def n_points(self) -> int:
        """Number of markers n."""
        return int(self.markers_O.shape[0])  # type: ignore[union-attr]

    def to_dict(self) -> dict[str, Any]:
        """Plain data (lists, strings), e.g. for a result's run specification."""
        out: dict[str, Any] = {
            "name": self.name,
            "description": self.description,
            "virtual_points": self.virtual_points,
        }
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray):
                out[f.name] = value.tolist()
        return out

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Scenario):
            return NotImplemented
        return all(
            np.array_equal(getattr(self, f.name), getattr(other, f.name)) for f in dataclasses.fields(self)
        )

    __hash__ = None  # type: ignore[assignment]  # arrays: mutable-looking, not hashable

    @property
    def has_disturbance(self) -> bool:
        """True when the joint offset ``d`` is non-zero."""
        return bool(np.any(self.joint_offset != 0.0))

    @property
    def q_true_start(self) -> np.ndarray:
        """True joint angles at the start, ``q_start + d`` (6,) [rad]."""
        return self._joints("q_true_start")[0] + self.joint_offset

    @property
    def q_encoder_goal(self) -> np.ndarray:
        """Encoder reading when the camera is at its target pose, ``q_target - d`` (6,) [rad]."""
        return self._joints("q_encoder_goal")[1] - self.joint_offset

    def _joints(self, what: str) -> tuple[np.ndarray, np.ndarray]:
        if self.q_start is None or self.q_target is None:
            raise InvalidParameterError(
                "scenario",
                f"free-camera scenario {self.name!r} (asked for {what})",
                "an arm scenario with q_start and q_target",
            )
        return self.q_start, self.q_target

    def validate_for(self, arm: Any) -> Scenario:
        """Check every configuration the run is meant to visit against the arm's joint limits.

        Checks ``q_start``, ``q_start + d``, ``q_target`` and ``q_target - d`` against
        ``arm.q_min <= q <= arm.q_max``.

        Returns:
            ``self``, to chain.

        Raises:
            JointLimitError: naming the configuration, the joints and their limits [deg].
        """
        self._joints("a check against joint limits")
        q_min, q_max = np.asarray(arm.q_min, dtype=float), np.asarray(arm.q_max, dtype=float)
        for label, q in (
            ("q_start", self.q_start),
            ("q_start + joint_offset", self.q_true_start),
            ("q_target", self.q_target),
            ("q_target - joint_offset", self.q_encoder_goal),
        ):
            bad = np.flatnonzero((q < q_min) | (q > q_max))
            if bad.size:
                detail = "; ".join(
                    f"joint {j + 1}: {np.degrees(q_min[j]):.2f} <= {np.degrees(q[j]):.2f} <= "
                    f"{np.degrees(q_max[j]):.2f} deg violated"
                    for j in bad
                )
                raise JointLimitError(
                    q, q_min, q_max, f"scenario {self.name!r}: {label} outside the joint limits ({detail})"
                )
        return self


def place_markers(T_O_C: Any, rays_xy: Any = MARKER_RAYS_XY, depths: Any = (2.0, 2.5, 3.0)) -> np.ndarray:
    """Points at given depths along rays of a camera, in the base frame.

    ``P_C,i = Z_i (x_i, y_i, 1)`` (normalised image coordinates ``x = X/Z``, ``y = Y/Z``),
    ``P_O,i = T_O_C P_C,i``.

    Args:
        T_O_C: Camera pose (4, 4).
        rays_xy: Normalised image coordinates (n, 2).
        depths: Depths ``Z_i`` > 0 along the optical axis (n,) [m].

    Returns:
        Marker positions ``P_O`` (n, 3) [m].
    """
    T_O_C = as_pose(T_O_C, "T_O_C")
    rays_xy = as_array(rays_xy, "rays_xy", (None, 2))
    depths = as_array(depths, "depths", (rays_xy.shape[0],))
    if np.any(depths <= 0.0):
        raise InvalidParameterError("depths", depths.tolist(), "depths > 0 m (points in front of the camera)")
    P_C = depths[:, None] * np.column_stack([rays_xy, np.ones(len(depths))])
    # in a fixed order of operations (not the BLAS's): campaign cases store these numbers
    return matmul(P_C, T_O_C[:3, :3].T) + T_O_C[:3, 3]


def _check_index(index: Any) -> int:
    if isinstance(index, (int, np.integer)) and not isinstance(index, bool) and index in (1, 2):
        return int(index)
    raise InvalidParameterError("index", index, "1 or 2 (the paper's scenarios, Table 1)")


def paper(index: int) -> Scenario:
    """The paper's scenario 1 or 2: Table 1 joint angles, Section 7 markers (virtual, ERRATA 13)."""
    index = _check_index(index)
    q_start, q_target = (np.radians(q) for q in _TABLE1_DEG[index])
    return Scenario(
        q_start=q_start,
        q_target=q_target,
        markers_O=PAPER_MARKERS_O,
        joint_offset=np.full(6, np.radians(_DISTURBANCE_DEG[index])),
        name=f"paper-{index}",
        virtual_points=True,
        description=(
            f"Li & Assadian Table 1 scenario {index}"
            + (", 1 deg joint-angle disturbance on every joint (ERRATA 14)" if index == 2 else "")
            + "; the paper's markers, not physically visible (ERRATA 13)"
        ),
    )


def physical(index: int) -> Scenario:
    """Scenario 1 or 2 of Table 1 with markers in front of the camera and in view (module docstring)."""
    index = _check_index(index)
    base = paper(index)
    return dataclasses.replace(
        base,
        markers_O=np.array(_PHYSICAL_MARKERS_O[index]),
        name=f"physical-{index}",
        virtual_points=False,
        description=(
            f"Table 1 scenario {index} joint angles"
            + (" with the 1 deg disturbance" if index == 2 else "")
            + f"; markers at depths {MARKER_DEPTHS[index]} m of the target camera, in view throughout"
        ),
    )


def paper_scenarios() -> tuple[Scenario, Scenario]:
    """The paper's two scenarios, ``(paper(1), paper(2))``."""
    return paper(1), paper(2)


def physical_scenarios() -> tuple[Scenario, Scenario]:
    """The two scenarios with visible markers, ``(physical(1), physical(2))``."""
    return physical(1), physical(2)


_REGISTRY: dict[str, Callable[[], Scenario]] = {
    "paper-1": lambda: paper(1),
    "paper-2": lambda: paper(2),
    "physical-1": lambda: physical(1),
    "physical-2": lambda: physical(2),
}
NAMES: tuple[str, ...] = tuple(_REGISTRY)


def get(name: str) -> Scenario:
    """Scenario by name: one of :data:`NAMES` (``"paper-1"``, ``"paper-2"``, ``"physical-1"``, ...).

    Raises:
        InvalidParameterError: unknown name (the message lists the valid ones).
    """
    return _REGISTRY[one_of(name, "scenario", NAMES)]()
