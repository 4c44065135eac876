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
from .exceptions import InvalidArrayError, InvalidParameterError, JointLimitError
from .model.mount import EYE_IN_HAND, EYE_TO_HAND, Mount

__all__ = [
    "EYE_TO_HAND_DEPTHS",
    "EYE_TO_HAND_RAYS_XY",
    "EYE_TO_HAND_STANDOFF",
    "FOR_ARM_DEPTHS",
    "FOR_ARM_MIN_SIGMA",
    "NAMES",
    "PAPER_MARKERS_O",
    "TEXTURED_DEPTH_M",
    "TEXTURED_START",
    "Scenario",
    "eye_to_hand",
    "fixed_camera_pose",
    "for_arm",
    "get",
    "mount_pair",
    "paper",
    "paper_scenarios",
    "physical",
    "physical_scenarios",
    "place_markers",
    "textured_camera",
    "textured_plane",
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
        q_start: Initial encoder joint angles (n,) [rad] (prismatic joints [m]), n >= 6 the
            arm's joints, or ``None`` without an arm.
        q_target: True joint angles of the target camera pose (n,) [rad], or ``None``.
        markers_O: Marker positions in the base frame, one per row (n, 3), n >= 3 [m]
            (the paper uses three; a monocular camera needs four or more); ``None`` eye-to-hand.
        joint_offset: Disturbance ``d`` (n,) [rad]: true angles = encoder + d (ERRATA 14);
            ``None`` is stored as zeros.
        name: Short identifier, e.g. ``"paper-1"``.
        virtual_points: Project markers even when behind the camera or out of view (ERRATA 13).
        description: Free text.
        T_O_C_start: Initial camera pose (4, 4) of a free-camera scenario, else ``None``.
        T_O_C_target: Target camera pose (4, 4) of a free-camera scenario, else ``None``.
        scene: What the camera images besides the markers: a
            :class:`~ibvs_youla.model.textured_plane.TexturedPlane` for the methods that servo on
            the image (``photometric``), or ``None`` (the markers alone, as the paper's scenarios);
            the plain data of ``TexturedPlane.to_dict()`` is accepted and rebuilt. Eye-to-hand
            the plane rides on the tool: its ``T_O_P`` is its pose in the carrier frame {E}.
        markers_E: Eye-to-hand: the markers (n, 3) in the frame of the arm that carries them
            (``mount.carrier_frame``, default the flange {E}) [m]; ``None`` eye-in-hand.
        mount: The camera's mounting (:class:`~ibvs_youla.model.mount.Mount`): ``None`` (or
            an eye-in-hand mount, stored as ``None``) for the camera on the arm and markers
            fixed in the base (``markers_O``); an eye-to-hand mount for a camera fixed at
            ``mount.T_O_C`` watching the markers ``markers_E`` carried by the arm.

    Raises:
        InvalidArrayError: wrong shape or non-finite entries.
        DegenerateMarkersError: coincident or collinear markers.
        InvalidParameterError: neither joints nor camera poses (or both), ``name`` or
            ``description`` not strings, ``virtual_points`` not bool, a scene that is not a
            TexturedPlane, ``mount`` not a Mount,
            markers in the wrong frame for the mounting (``markers_O`` eye-to-hand,
            ``markers_E`` eye-in-hand), an eye-to-hand mounting of a free-camera scenario.
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
    scene: Any = None
    markers_E: np.ndarray | None = None
    mount: Mount | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        self._check_mount()
        joints = (self.q_start is not None, self.q_target is not None)
        poses = (self.T_O_C_start is not None, self.T_O_C_target is not None)
        if joints == (True, True) and poses == (False, False):
            set_(self, "q_start", _frozen(as_array(self.q_start, "q_start", (None,))))
            n = self.q_start.shape[0]  # type: ignore[union-attr]
            if n < 6:
                raise InvalidArrayError(
                    "q_start", f"{n} joint(s)", "n >= 6 joints (a camera pose has six degrees of freedom)"
                )
            set_(self, "q_target", _frozen(as_array(self.q_target, "q_target", (n,))))
        elif joints == (False, False) and poses == (True, True):
            set_(self, "T_O_C_start", _frozen(as_pose(self.T_O_C_start, "T_O_C_start")))
            set_(self, "T_O_C_target", _frozen(as_pose(self.T_O_C_target, "T_O_C_target")))
        else:
            raise InvalidParameterError(
                "scenario",
                f"q_start/q_target given: {joints}, T_O_C_start/T_O_C_target given: {poses}",
                "both joint configurations (an arm scenario) or both camera poses (a free-camera scenario)",
            )
        n = 6 if self.q_start is None else self.q_start.shape[0]
        offset = np.zeros(n) if self.joint_offset is None else self.joint_offset
        set_(self, "joint_offset", _frozen(as_array(offset, "joint_offset", (n,))))
        field_name = "markers_E" if self.mount is not None else "markers_O"
        if getattr(self, field_name) is None:
            raise InvalidParameterError(field_name, None, "marker positions (n, 3), n >= 3 [m]")
        set_(self, field_name, _frozen(check_marker_geometry(getattr(self, field_name), field_name)))
        for field_name in ("name", "description"):
            if not isinstance(getattr(self, field_name), str):
                raise InvalidParameterError(field_name, getattr(self, field_name), "a string")
        if not isinstance(self.virtual_points, (bool, np.bool_)):
            raise InvalidParameterError("virtual_points", self.virtual_points, "True or False")
        set_(self, "virtual_points", bool(self.virtual_points))
        if self.scene is not None:
            from .model.textured_plane import TexturedPlane

            if isinstance(self.scene, dict):  # plain data, as to_dict() writes it
                set_(self, "scene", TexturedPlane.from_dict(self.scene))
            elif not isinstance(self.scene, TexturedPlane):
                raise InvalidParameterError("scene", type(self.scene).__name__, "a TexturedPlane or None")

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
        scene: Any = None,
    ) -> Scenario:
        """A camera with no arm: start and target poses (4, 4) and markers (n, 3) in the base frame [m]."""
        return cls(
            markers_O=markers_O,
            name=name,
            virtual_points=virtual_points,
            description=description,
            T_O_C_start=T_O_C_start,
            T_O_C_target=T_O_C_target,
            scene=scene,
        )

    def _check_mount(self) -> None:
        """Store an eye-in-hand mount as None; the markers' frame must be the mounting's."""
        if self.mount is not None and not isinstance(self.mount, Mount):
            raise InvalidParameterError(
                "mount", type(self.mount).__name__, "a Mount (Mount.eye_to_hand(T_O_C)) or None (eye-in-hand)"
            )
        if self.mount is not None and not self.mount.is_eye_to_hand:
            object.__setattr__(self, "mount", None)
        if self.mount is None:
            if self.markers_E is not None:
                raise InvalidParameterError(
                    "markers_E",
                    "markers given in a frame of the arm for an eye-in-hand scenario (mount None)",
                    "markers_O (fixed in the base frame) for a camera on the arm, or "
                    "mount=Mount.eye_to_hand(T_O_C) for markers carried by the arm",
                )
            return
        if self.markers_O is not None:
            raise InvalidParameterError(
                "markers_O",
                "markers given in the base frame for an eye-to-hand mount",
                "markers_E: the markers in the frame of the arm that carries them "
                f"({self.mount.carrier_frame or 'the flange'!r}), watched by the fixed camera",
            )
        if self.q_start is None and self.q_target is None:
            raise InvalidParameterError(
                "mount",
                self.mount.kind,
                "None (eye-in-hand) for a free-camera scenario: eye-to-hand needs an arm to carry markers",
            )

    @property
    def markers(self) -> np.ndarray:
        """The markers (n, 3) [m] in the frame they are fixed in: ``markers_O`` (base) or ``markers_E``."""
        return self.markers_O if self.mount is None else self.markers_E  # type: ignore[return-value]

    @property
    def is_eye_to_hand(self) -> bool:
        """True for a camera fixed in the base frame watching markers on the arm."""
        return self.mount is not None

    @property
    def has_joints(self) -> bool:
        """True for an arm scenario (joint configurations given), False for a free-camera one."""
        return self.q_start is not None

    @property
    def n_points(self) -> int:
        """Number of markers n."""
        return int(self.markers.shape[0])

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
        if self.scene is not None:  # only then: the data (and campaign keys) of scenes-less scenarios stay
            out["scene"] = self.scene.to_dict()
        if self.mount is not None:  # an eye-in-hand scenario's data (and a campaign's keys) are unchanged
            out["mount"] = self.mount.to_dict()
        return out

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Scenario):
            return NotImplemented
        return (self.scene, self.mount) == (other.scene, other.mount) and all(
            np.array_equal(getattr(self, f.name), getattr(other, f.name))
            for f in dataclasses.fields(self)
            if f.name not in ("scene", "mount")
        )

    __hash__ = None  # type: ignore[assignment]  # arrays: mutable-looking, not hashable

    @property
    def has_disturbance(self) -> bool:
        """True when the joint offset ``d`` is non-zero."""
        return bool(np.any(self.joint_offset != 0.0))

    @property
    def q_true_start(self) -> np.ndarray:
        """True joint angles at the start, ``q_start + d`` (n,) [rad]."""
        return self._joints("q_true_start")[0] + self.joint_offset

    @property
    def q_encoder_goal(self) -> np.ndarray:
        """Encoder reading when the camera is at its target pose, ``q_target - d`` (n,) [rad]."""
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
            InvalidArrayError: the scenario's joint vectors are not of the arm's size.
            JointLimitError: naming the configuration, the joints and their limits [deg].
        """
        self._joints("a check against joint limits")
        q_min, q_max = np.asarray(arm.q_min, dtype=float), np.asarray(arm.q_max, dtype=float)
        if self.q_start.shape != q_min.shape:  # type: ignore[union-attr]
            raise InvalidArrayError(
                "scenario.q_start",
                f"{self.q_start.shape[0]} joints (scenario {self.name!r})",  # type: ignore[union-attr]
                f"{q_min.shape[0]}, the joints of the arm {getattr(arm, 'name', '')!r}",
            )
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


FOR_ARM_DEPTHS = (0.5, 0.6, 0.7)  # [m] markers of `for_arm` along MARKER_RAYS_XY of the target camera
FOR_ARM_MIN_SIGMA = 0.05  # smallest singular value of J_C (6, n) accepted at the start and target


def _home_of(arm: Any, home: np.ndarray) -> np.ndarray:
    """The robot's home configuration on ``arm``'s joints: a joint locked on request drops its entry."""
    if home.shape == (int(arm.nq),):
        return home
    from .model.arm import Arm

    names = Arm.from_robot(arm.robot).joint_names  # the joints the home configuration is of
    if len(names) != len(home) or not set(arm.joint_names) <= set(names):
        return home  # another chain (e.g. another camera frame): as_array names the mismatch
    return home[[names.index(j) for j in arm.joint_names]]


def for_arm(
    arm: Any,
    seed: int = 0,
    *,
    q_center: Any = None,
    spread_deg: float = 10.0,
    step_deg: float = 5.0,
    depths: Any = FOR_ARM_DEPTHS,
    joint_offset_deg: float = 0.0,
    camera: Any = None,
    name: str | None = None,
) -> Scenario:
    """A seeded servoing scenario for any arm: markers in front of the camera near its home configuration.

    The target configuration is ``q_center`` (default: the robot's home configuration,
    :mod:`ibvs_youla.model.robots`) with every joint moved by a uniform draw in
    +-``spread_deg`` (prismatic joints +-1 cm), the start the target moved by +-``step_deg`` per
    joint (prismatic +-5 mm), both clipped 1 deg (1 mm) inside the joint limits. The markers lie
    at ``depths`` along the rays :data:`MARKER_RAYS_XY` of the target camera
    (:func:`place_markers`). A draw is kept when J_C has a smallest singular value >=
    :data:`FOR_ARM_MIN_SIGMA` at both configurations and every marker is visible to ``camera``
    (default: the simulator's) at the start, the target and the straight joint-space path
    between them; else it is drawn again (at most 200 times).

    Args:
        arm: The arm (``camera_pose``, ``camera_jacobian``, limits, ``robot``).
        seed: Seed of ``numpy.random.default_rng``.
        q_center: Configuration (n,) the target is drawn around; needed for an arm that is not
            a named robot.
        spread_deg: Half-width of the target draw per joint [deg].
        step_deg: Half-width of the start's offset from the target per joint [deg].
        depths: Marker depths in the target camera (3,) [m].
        joint_offset_deg: The unseen encoder offset d on every revolute joint [deg] (ERRATA 14).
        camera: The camera the markers must be visible to; default ``default_camera()``.
        name: The scenario's name; default ``"<robot>-<seed>"``.

    Raises:
        InvalidParameterError: no ``q_center`` for an arm without a home configuration, or no
            draw meets the conditions in 200 attempts.
    """
    from .model.camera import default_camera
    from .model.robots import get

    n = int(arm.nq)
    if q_center is None:
        if getattr(arm, "robot", None) is None:
            raise InvalidParameterError(
                "q_center", None, f"a configuration ({n},): the arm has no home configuration"
            )
        q_center = _home_of(arm, np.asarray(get(arm.robot).q_home, dtype=float))
    q_center = as_array(q_center, "q_center", (n,))
    camera = default_camera() if camera is None else camera
    periodic = np.asarray(getattr(arm, "periodic", np.ones(n)), dtype=bool)
    margin = np.where(periodic, np.radians(1.0), 1e-3)
    lo, hi = np.asarray(arm.q_min) + margin, np.asarray(arm.q_max) - margin
    spread = np.where(periodic, np.radians(spread_deg), 0.01)
    step = np.where(periodic, np.radians(step_deg), 0.005)
    offset = np.where(periodic, np.radians(joint_offset_deg), 0.0)
    rng = np.random.default_rng(seed)
    label = name if name is not None else f"{getattr(arm, 'robot', None) or arm.name}-{seed}"
    for _ in range(200):
        q_target = np.clip(q_center + spread * rng.uniform(-1.0, 1.0, n), lo, hi)
        q_start = np.clip(q_target + step * rng.uniform(-1.0, 1.0, n), lo, hi)
        sigmas = [np.linalg.svd(arm.camera_jacobian(q), compute_uv=False).min() for q in (q_start, q_target)]
        if min(sigmas) < FOR_ARM_MIN_SIGMA:
            continue
        markers = place_markers(arm.camera_pose(q_target), MARKER_RAYS_XY, depths)
        path = [q_start + offset + f * (q_target - q_start - offset) for f in np.linspace(0.0, 1.0, 11)]
        if all(_visible(camera, arm.camera_pose(q), markers) for q in path):
            return Scenario(
                q_start=q_start,
                q_target=q_target,
                markers_O=np.round(markers, 6),
                joint_offset=offset,
                name=label,
                description=(
                    f"{arm.name}: target within +-{spread_deg:g} deg of {'q_center' if name else 'home'}, "
                    f"start +-{step_deg:g} deg from it, markers at depths {tuple(depths)} m (seed {seed})"
                ),
            )
    raise InvalidParameterError(
        "for_arm",
        f"arm {arm.name!r}, seed {seed}",
        f"a draw with J_C's smallest singular value >= {FOR_ARM_MIN_SIGMA} and every marker visible "
        "(none in 200 attempts: another q_center, smaller spread_deg/step_deg or other depths)",
    )


def _visible(camera: Any, T_O_C: np.ndarray, markers_O: np.ndarray) -> bool:
    P_C = (markers_O - T_O_C[:3, 3]) @ T_O_C[:3, :3]
    return bool(camera.visibility(P_C).all_visible)


EYE_TO_HAND_RAYS_XY = ((-0.3, -0.2), (0.28, -0.12), (0.04, 0.25))  # no symmetry axis in the image
EYE_TO_HAND_DEPTHS = (0.6, 0.7, 0.8)  # [m] along EYE_TO_HAND_RAYS_XY: inside the ZED 2's 0.5-25 m
EYE_TO_HAND_STANDOFF = 0.05  # [m] the nearest marker's distance from the carrier's origin, towards the camera


def fixed_camera_pose(T_O_E: Any, distance: float) -> np.ndarray:
    """T_O_C (4, 4) of a camera at ``distance`` [m] from the tool, level, facing it and the arm's base axis.

    The camera sits at p_E + distance u, u the horizontal unit vector from the base's z axis out to
    the tool's origin p_E (the base x axis when the tool is on that axis), and looks back along -u
    with its image y axis pointing down (-z of the base): a camera standing in front of the arm.
    """
    T_O_E = as_pose(T_O_E, "T_O_E")
    p = T_O_E[:3, 3]
    radial = np.array([p[0], p[1], 0.0])
    norm = float(np.hypot(p[0], p[1]))
    u = radial / norm if norm > 1e-9 else np.array([1.0, 0.0, 0.0])
    z, y = -u, np.array([0.0, 0.0, -1.0])
    T = np.eye(4)
    T[:3, :3] = np.column_stack([np.cross(y, z), y, z])
    T[:3, 3] = p + distance * u
    return T


def eye_to_hand(
    arm: Any,
    seed: Any = 0,
    *,
    q_center: Any = None,
    spread_deg: float = 10.0,
    step_deg: float = 5.0,
    depths: Any = EYE_TO_HAND_DEPTHS,
    rays_xy: Any = EYE_TO_HAND_RAYS_XY,
    joint_offset_deg: float = 0.0,
    camera: Any = None,
    carrier_frame: str | None = None,
    name: str | None = None,
) -> Scenario:
    """A seeded eye-to-hand scenario for any arm: a fixed camera watching markers on its tool.

    The joints are drawn as :func:`for_arm` draws them (the target within +-``spread_deg`` of
    ``q_center``, default the robot's home configuration; the start +-``step_deg`` from it). The
    camera is fixed where the target tool is seen from ``max(depths) +`` :data:`EYE_TO_HAND_STANDOFF`
    m in front of the arm (:func:`fixed_camera_pose` of the carrier at the target), and the markers
    are fixed on the carrier (default the flange) where that camera sees them at the target: at
    ``depths`` along ``rays_xy`` (:data:`EYE_TO_HAND_RAYS_XY`, a triangle without a symmetry axis in
    the image). A draw is kept when J_rel (6, n), the camera's twist relative to the markers
    (:mod:`ibvs_youla.model.eye_to_hand`), has a smallest singular value >=
    :data:`FOR_ARM_MIN_SIGMA` at the start and the target and every marker is visible along the
    straight joint-space path; else it is drawn again (at most 200 times).

    Args:
        arm: An eye-in-hand :class:`~ibvs_youla.model.arm.Arm` (its limits, kinematics, ``robot``).
        seed: Seed of ``numpy.random.default_rng`` (an int or a ``SeedSequence``).
        q_center: Configuration (n,) the target is drawn around (as :func:`for_arm`).
        spread_deg: Half-width of the target draw per joint [deg].
        step_deg: Half-width of the start's offset from the target per joint [deg].
        depths: Marker depths in the target camera (3,) [m].
        rays_xy: Normalized image coordinates (3, 2) of the markers in the target image.
        joint_offset_deg: The unseen encoder offset d on every revolute joint [deg] (ERRATA 14).
        camera: The camera the markers must be visible to; default ``default_camera()``.
        name: The scenario's name; default ``"<robot>-<seed>-eye-to-hand"``.
        carrier_frame: The frame of the arm's last link carrying the markers; default the flange.

    Raises:
        InvalidParameterError: as :func:`for_arm`.
    """
    return _mounted_draw(
        arm, seed, (EYE_TO_HAND,), q_center, spread_deg, step_deg, depths, rays_xy, joint_offset_deg,
        camera, carrier_frame, name,
    )[0]  # fmt: skip


def mount_pair(
    arm: Any,
    seed: Any = 0,
    *,
    q_center: Any = None,
    spread_deg: float = 10.0,
    step_deg: float = 5.0,
    depths: Any = EYE_TO_HAND_DEPTHS,
    rays_xy: Any = EYE_TO_HAND_RAYS_XY,
    joint_offset_deg: float = 0.0,
    camera: Any = None,
    carrier_frame: str | None = None,
    name: str | None = None,
) -> tuple[Scenario, Scenario]:
    """(eye-in-hand, eye-to-hand) scenarios of one draw: the same joints, the same target image.

    Arguments as :func:`eye_to_hand`. A draw is kept when both mountings meet :func:`eye_to_hand`'s
    conditions: the eye-in-hand twin has the arm's own camera and the markers fixed in the base
    where it sees them at the target at ``depths`` along ``rays_xy`` (as :func:`for_arm`), so both
    cameras see the same image at the target and start from the same joints.
    """
    first, second = _mounted_draw(
        arm, seed, (EYE_IN_HAND, EYE_TO_HAND), q_center, spread_deg, step_deg, depths, rays_xy,
        joint_offset_deg, camera, carrier_frame, name,
    )  # fmt: skip
    return first, second


def _mounted_draw(
    arm: Any,
    seed: Any,
    mounts: tuple[str, ...],
    q_center: Any,
    spread_deg: float,
    step_deg: float,
    depths: Any,
    rays_xy: Any,
    joint_offset_deg: float,
    camera: Any,
    carrier_frame: str | None,
    name: str | None,
) -> tuple[Scenario, ...]:
    """The scenarios of ``mounts`` from the first draw of ``seed`` that every one of them accepts."""
    from .model.camera import default_camera
    from .model.eye_to_hand import mounted
    from .model.robots import get

    n = int(arm.nq)
    if q_center is None:
        if getattr(arm, "robot", None) is None:
            raise InvalidParameterError(
                "q_center", None, f"a configuration ({n},): the arm has no home configuration"
            )
        q_center = _home_of(arm, np.asarray(get(arm.robot).q_home, dtype=float))
    q_center = as_array(q_center, "q_center", (n,))
    rays_xy = as_array(rays_xy, "rays_xy", (None, 2))
    depths = as_array(depths, "depths", (rays_xy.shape[0],))
    camera = default_camera() if camera is None else camera
    distance = float(depths.max()) + EYE_TO_HAND_STANDOFF
    carrier = arm.flange_frame if carrier_frame is None else carrier_frame
    T_H_E = arm.frame_in_camera(carrier)  # the carrier in the arm's own camera frame
    periodic = np.asarray(getattr(arm, "periodic", np.ones(n)), dtype=bool)
    margin = np.where(periodic, np.radians(1.0), 1e-3)
    lo, hi = np.asarray(arm.q_min) + margin, np.asarray(arm.q_max) - margin
    spread = np.where(periodic, np.radians(spread_deg), 0.01)
    step = np.where(periodic, np.radians(step_deg), 0.005)
    offset = np.where(periodic, np.radians(joint_offset_deg), 0.0)
    rng = np.random.default_rng(seed)
    label = name if name is not None else f"{getattr(arm, 'robot', None) or arm.name}-{seed}"
    # unnamed, a lone eye-to-hand scenario says so (for_arm's of the same seed is eye-in-hand)
    own_name = name is None and mounts == (EYE_TO_HAND,)
    for _ in range(200):
        q_target = np.clip(q_center + spread * rng.uniform(-1.0, 1.0, n), lo, hi)
        q_start = np.clip(q_target + step * rng.uniform(-1.0, 1.0, n), lo, hi)
        path = [q_start + offset + f * (q_target - q_start - offset) for f in np.linspace(0.0, 1.0, 11)]
        made = []
        for kind in mounts:
            if kind == EYE_IN_HAND:
                view, mount = arm, None
                markers = np.round(place_markers(arm.camera_pose(q_target), rays_xy, depths), 6)
            else:
                T_O_E = matmul(arm.camera_pose(q_target), T_H_E)
                mount = Mount.eye_to_hand(fixed_camera_pose(T_O_E, distance), carrier_frame)
                view = mounted(arm, mount)
                markers = np.round(place_markers(view.camera_pose(q_target), rays_xy, depths), 6)  # in {E}
            sigmas = [
                np.linalg.svd(view.camera_jacobian(q), compute_uv=False).min() for q in (q_start, q_target)
            ]
            if min(sigmas) < FOR_ARM_MIN_SIGMA or not all(
                _visible(camera, view.camera_pose(q), markers) for q in path
            ):
                break
            made.append(
                Scenario(
                    q_start=q_start,
                    q_target=q_target,
                    joint_offset=offset,
                    name=f"{label}-{kind}" if len(mounts) > 1 or own_name else label,
                    description=(
                        f"{arm.name}, {kind}: target within +-{spread_deg:g} deg of "
                        f"{'q_center' if name else 'home'}, start +-{step_deg:g} deg from it, markers at "
                        f"depths {tuple(depths.tolist())} m of the target camera (seed {seed})"
                    ),
                    **({"markers_O": markers} if mount is None else {"markers_E": markers}),
                    mount=mount,
                )
            )
        if len(made) == len(mounts):
            return tuple(made)
    raise InvalidParameterError(
        "seed",
        f"arm {arm.name!r}, seed {seed}",
        f"a draw with the camera Jacobian's smallest singular value >= {FOR_ARM_MIN_SIGMA} and every "
        f"marker visible, {' and '.join(mounts)} (none in 200 attempts: another q_center, smaller "
        "spread_deg/step_deg or other depths)",
    )


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


# ----------------------------------------------------------------------------- a textured plane
TEXTURED_DEPTH_M = 1.0  # [m] the plane's distance from the target camera (ViSP's photometric example)
TEXTURED_SQUARE_M = 0.2  # [m] side of the square of markers on the plane, centred on the optical axis
# The default start of textured_plane(), in the target camera's frame: a few centimetres and degrees,
# the style of start of Collewet & Marchand's experiments: (tx, ty, tz) [m], rotation vector [deg].
TEXTURED_START = ((0.03, -0.02, 0.05), (2.0, -2.0, 3.0))


def textured_camera() -> Any:
    """The camera of :func:`textured_plane`: 120 x 90 px, focal length 150 px (44 x 33 deg).

    ``PinholeCamera.from_focal_px(150, (120, 90))``: small images, so that a run costs little (a
    pixel sees 6.7 mm of the plane at 1 m, the texture's 5 mm texels smoothed over 15 mm), and a
    field of view wide enough that the square of markers stays in the image from the starts of
    photometric servoing, with room for the disc markers' detector. ViSP's photometric example
    has a narrower one (870 px at 320 x 240: 21 x 16 deg).
    """
    from .model.camera import PinholeCamera

    return PinholeCamera.from_focal_px(150.0, (120, 90), name="textured-plane camera")


def textured_plane(
    translation_m: Any = TEXTURED_START[0],
    rotation_deg: Any = TEXTURED_START[1],
    *,
    scene: Any = None,
    name: str = "textured-plane",
) -> Scenario:
    """A free-camera scenario before a textured plane, the scene of photometric visual servoing.

    The target camera looks at the plane's centre from :data:`TEXTURED_DEPTH_M` = 1 m, its axes
    those of the base frame (``T_O_C* = [I, (0, 0, -1)]``, the plane z = 0: ViSP's
    ``photometricVisualServoing`` geometry); the start is the target camera moved by
    ``translation_m`` (tx, ty, tz) [m] and turned by the rotation vector ``rotation_deg`` [deg],
    both in the target camera's frame: ``T_O_C0 = T_O_C* [R(rotation), t]``. The markers are the
    corners of a 0.2 m square centred on the plane (what point methods servo on, and what the
    comparison metrics measure); the scene defaults to ``TexturedPlane()`` (1.2 x 0.9 m, a
    generated texture, seed 0). Image it with :func:`textured_camera`.

    Raises:
        InvalidArrayError: a translation or rotation that is not three finite numbers.
    """
    from scipy.spatial.transform import Rotation

    from .model.textured_plane import TexturedPlane

    t = as_array(translation_m, "translation_m", (3,))
    r = as_array(rotation_deg, "rotation_deg", (3,))
    T_target = np.eye(4)
    T_target[2, 3] = -TEXTURED_DEPTH_M
    delta = np.eye(4)
    delta[:3, :3] = Rotation.from_rotvec(np.radians(r)).as_matrix()
    delta[:3, 3] = t
    half = 0.5 * TEXTURED_SQUARE_M
    markers = np.array([[-half, -half, 0.0], [half, -half, 0.0], [half, half, 0.0], [-half, half, 0.0]])
    return Scenario.free_camera(
        T_target @ delta,
        T_target,
        markers,
        name=name,
        description=(
            f"a textured plane 1 m before the target camera; start t = {t.round(4).tolist()} m, "
            f"rotation {r.round(3).tolist()} deg in the target camera's frame"
        ),
        scene=TexturedPlane() if scene is None else scene,
    )
