"""Seeded scenario generators for campaigns: arm families and free-flying-camera families.

Every case draws from its own stream, ``np.random.SeedSequence(seed).spawn(n)[case]``, so the
same seed gives the same cases on any machine, in any order and on any number of workers, and
case k does not depend on how many cases were asked for. Each generator rejects draws that
break its rules and draws again from the same stream (the number of draws is deterministic).

Families (:data:`FAMILIES`):

* ``"arm-physical"`` — on the campaign's arm (default the IRB 4600; any arm of n >= 6 joints,
  ``arm=``): a target configuration within the arm's joint limits shrunk by :data:`LIMIT_MARGIN`
  of each range (a joint that turns more than one turn, such as the IRB 4600's joints 4 and 6
  (+-400 deg) or a continuous joint, within +-180 deg), away from singularities: the arm's camera
  Jacobian's smallest singular value >= :data:`MIN_JACOBIAN_SIGMA` at both ends and, on an arm
  with a spherical wrist (``arm.ik_method == "spherical-wrist"``: the IRB 4600), |q5| >=
  :data:`WRIST_MARGIN_DEG` from the wrist singularity (ERRATA 7); a start configuration up to
  ``difficulty`` x :data:`MAX_JOINT_STEP_DEG` per joint away (prismatic joints
  :data:`MAX_PRISMATIC_STEP_M`); three markers placed along random rays of the target camera
  (normalized coordinates within +-0.35, depths 1.5-3.5 m), kept only if all three are in view
  (in front, inside the sensor, within the depth range) at the start and the target. On the
  IRB 4600 these are the rules of every campaign stored so far (its cases are the same bits).
* ``"arm-virtual"`` — the same configurations, markers anywhere in a box in front of the arm
  (x 1-4 m, y -2-2 m, z -0.5-2 m), projected whatever their depth sign, as the paper's virtual
  points (ERRATA 13).
* ``"arm-eye-to-hand"`` / ``"arm-eye-in-hand"`` — one draw, two mountings
  (:func:`ibvs_youla.scenarios.mount_pair` on the campaign's arm, default the IRB 4600; the draw of
  case k from its own stream): a target configuration within +-10 deg of the arm's home
  configuration, a start up to ``difficulty`` x :data:`MOUNT_STEP_DEG` per joint away; eye-to-hand,
  a camera fixed in front of the target tool (0.85 m, level, facing the arm) and three markers on
  the flange where it sees them at 0.6-0.8 m along
  :data:`~ibvs_youla.scenarios.EYE_TO_HAND_RAYS_XY`; eye-in-hand, the arm's own camera and the
  markers fixed in the base where it sees the same image at the target. Case k of both families is
  the same draw, kept only if both mountings keep every marker in view along the joint-space path
  and the camera Jacobian's smallest singular value >= 0.05 at both ends: matched cases. The mount
  is in each eye-to-hand spec's scenario (``mount``, ``markers_E``).
* ``"free-planar"`` / ``"free-nonplanar"`` — a camera without an arm in front of a 0.2 m square
  (four points) or of the square plus two points 0.1 m off its plane; the target camera 0.75 m
  in front, facing it (ViSP's tutorial geometry); the start a rotation about a random axis by
  up to ``difficulty`` x :data:`MAX_ROTATION_DEG` and a translation up to ``difficulty`` x
  :data:`MAX_TRANSLATION_M` away, kept only if every point stays 0.1 m or more in front and
  within |x|, |y| <= 1 (45 deg off the axis) at the start.
* ``"free-roll"`` — the planar square, with the start camera turned about the optical axis
  by :data:`MIN_ROLL_DEG`-:data:`MAX_ROLL_DEG` (x ``difficulty``, at most 180 deg, either
  sign), then tilted about a random axis by up to ``difficulty`` x :data:`ROLL_TILT_DEG` and
  moved by up to ``difficulty`` x :data:`ROLL_TRANSLATION_M`, same visibility rule: the
  classical hard case of IBVS (Chaumette 1998: a rotation of 180 deg about the optical axis
  makes the camera retreat; near it, local minima and singular interaction matrices).
* ``"free-textured"`` — a camera before a textured plane (:func:`~ibvs_youla.scenarios.textured_plane`:
  the target camera 1 m before it, a 0.1 m square of markers at its centre), the texture generated
  from a seed drawn for the case; the start a rotation about a random axis by up to
  ``difficulty`` x :data:`TEXTURED_ROTATION_DEG` and a translation up to ``difficulty`` x
  :data:`TEXTURED_TRANSLATION_M`: the few centimetres and degrees of photometric visual servoing's
  experiments (Collewet & Marchand 2011), whose basin is narrow. The scene travels with the
  case's scenario (``Scenario.to_dict()["scene"]``); every method runs on it, photometric servoing
  included (it needs the scene, and a camera with pixels: the family's ``{"kind": "pinhole"}``).

The difficulty of a case is reported with it: the rotation angle [deg] and the distance [m]
between the start and target camera poses. The knob goes up to :data:`MAX_DIFFICULTY` = 100:
the joint steps cover every joint's range from 12 on (12 x 30 deg), the free rotations every
rotation from 2 on and the free-roll turn is capped at 180 deg; beyond 100 only the free
camera's distance still grows (30 m at 100, 40 times the target's 0.75 m), toward draws that
overflow. A draw that is not finite is rejected like any other that breaks the rules.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._memory import fits_in_memory
from .._reproducible import matmul, norm3
from .._validation import integer, one_of, real
from ..catalog import ARM_FAMILIES, FAMILIES, MOUNT_FAMILIES
from ..exceptions import InvalidParameterError

__all__ = [
    "FAMILIES",
    "LIMIT_MARGIN",
    "MAX_DIFFICULTY",
    "MAX_JOINT_STEP_DEG",
    "MAX_PRISMATIC_STEP_M",
    "MAX_ROLL_DEG",
    "MAX_ROTATION_DEG",
    "MAX_SEED",
    "MAX_TRANSLATION_M",
    "MIN_JACOBIAN_SIGMA",
    "MIN_ROLL_DEG",
    "MOUNT_FAMILIES",
    "MOUNT_STEP_DEG",
    "ROLL_TILT_DEG",
    "ROLL_TRANSLATION_M",
    "SCENE_FAMILIES",
    "TEXTURED_ROTATION_DEG",
    "TEXTURED_TRANSLATION_M",
    "WRIST_MARGIN_DEG",
    "Case",
    "generate_cases",
]

SCENE_FAMILIES = ("free-textured",)  # their scenarios carry a scene (a textured plane)
LIMIT_MARGIN = 0.1  # of each joint's range, kept clear at both ends
WRIST_MARGIN_DEG = 10.0  # |q5| >= this [deg]
MIN_JACOBIAN_SIGMA = 0.05  # smallest singular value of the 6 x n LOCAL camera Jacobian (m/rad and 1)
MAX_JOINT_STEP_DEG = 30.0  # per joint at difficulty 1 [deg]
MOUNT_STEP_DEG = 5.0  # the mount families' start offset per joint at difficulty 1 [deg]
MAX_PRISMATIC_STEP_M = 0.05  # per prismatic joint at difficulty 1 [m]
MAX_ROTATION_DEG = 90.0  # free camera, at difficulty 1 [deg]
MAX_TRANSLATION_M = 0.3  # free camera, at difficulty 1 [m]
MIN_ROLL_DEG, MAX_ROLL_DEG = 90.0, 180.0  # free-roll: about the optical axis, at difficulty 1 [deg]
ROLL_TILT_DEG = 5.0  # free-roll: about a random axis, at difficulty 1 [deg]
ROLL_TRANSLATION_M = 0.05  # free-roll, at difficulty 1 [m]
TEXTURED_ROTATION_DEG = 5.0  # free-textured: about a random axis, at difficulty 1 [deg]
TEXTURED_TRANSLATION_M = 0.05  # free-textured, at difficulty 1 [m]
MAX_DRAWS = 200  # rejection sampling gives up after this many draws of one case
MAX_DIFFICULTY = 100.0  # the difficulty knob's upper end (module docstring)
MAX_SEED = 2**63 - 1  # a seed is stored in an int64 column
SQUARE_O = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]
OFF_PLANE_O = np.array([[0.0, 0.05, 0.1], [0.05, -0.05, -0.1]])  # [m], the non-planar extras


@dataclass(frozen=True)
class Case:
    """One generated case: the scenario as plain data and its difficulty.

    Attributes:
        family: The family it was drawn from.
        index: Its index in the campaign.
        scenario: ``Scenario`` fields as plain data (``ExperimentSpec.scenario``).
        difficulty: ``{"rotation_deg", "translation_m"}`` between the start and target cameras.
        draws: How many draws the rejection sampling took.
    """

    family: str
    index: int
    scenario: dict[str, Any] = field(hash=False)
    difficulty: dict[str, float] = field(hash=False)
    draws: int = 1


def _rotation_deg(R: np.ndarray) -> float:
    return math.degrees(math.acos(max(-1.0, min(1.0, 0.5 * (float(np.trace(R)) - 1.0)))))


def _difficulty(T_start: np.ndarray, T_target: np.ndarray) -> dict[str, float]:
    return {
        "rotation_deg": _rotation_deg(matmul(T_start[:3, :3].T, T_target[:3, :3])),
        "translation_m": norm3(T_start[:3, 3] - T_target[:3, 3]),
    }


def _rotvec_matrix(rotvec: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec(rotvec).as_matrix()


def generate_cases(
    family: str, n: int, seed: int, *, difficulty: float = 1.0, arm: Any = None
) -> tuple[Case, ...]:
    """``n`` cases of ``family`` from ``seed`` (module docstring).

    Args:
        family: A name of :data:`FAMILIES`.
        n: Number of cases (>= 1).
        seed: The campaign's seed.
        difficulty: The difficulty knob (module docstring).
        arm: The arm of an arm family (an :class:`~ibvs_youla.model.arm.Arm`); default the IRB
            4600. Ignored by the free families.

    Raises:
        InvalidParameterError: an unknown family, ``n`` < 1, a seed that is not an integer in
            [0, :data:`MAX_SEED`], a difficulty outside (0, :data:`MAX_DIFFICULTY`], an ``arm``
            that is not an Arm, or a case the rules reject :data:`MAX_DRAWS` times.
    """
    one_of(family, "family", FAMILIES)
    integer(n, "n", low=1)
    integer(seed, "seed", low=0, high=MAX_SEED)
    difficulty = real(difficulty, "difficulty", low=0.0, low_open=True, high=MAX_DIFFICULTY)
    fits_in_memory(4096.0 * n, "n", n, "fewer cases")  # a case holds its scenario and seed, ~4 kB
    streams = np.random.SeedSequence(int(seed)).spawn(int(n))
    if family in MOUNT_FAMILIES or family in ARM_FAMILIES:
        from .._validation import instance
        from ..model.arm import Arm

        arm = Arm.irb4600() if arm is None else instance(arm, "arm", Arm, "an Arm, or None (the IRB 4600)")
    if family in MOUNT_FAMILIES:
        if arm.robot is None:  # mount_pair draws the target about the robot's home configuration
            raise InvalidParameterError(
                "arm",
                arm.name,
                f"a named robot (Arm.from_robot, --robot) for the family {family!r}: its cases are drawn "
                "about the robot's home configuration, which an arm from a URDF does not have",
            )
        return tuple(_mount_case(family, k, s, difficulty, arm) for k, s in enumerate(streams))
    if family in ARM_FAMILIES:
        from ..model.camera import default_camera

        camera = default_camera()
        return tuple(
            _arm_case(family, k, np.random.default_rng(s), difficulty, arm, camera)
            for k, s in enumerate(streams)
        )
    if family == "free-textured":
        return tuple(
            _textured_case(family, k, np.random.default_rng(s), difficulty) for k, s in enumerate(streams)
        )
    return tuple(_free_case(family, k, np.random.default_rng(s), difficulty) for k, s in enumerate(streams))


def _undrawable(family: str, index: int, difficulty: float) -> InvalidParameterError:
    """The error of a case the rules rejected :data:`MAX_DRAWS` times."""
    return InvalidParameterError(
        "difficulty",
        difficulty,
        f"a difficulty at which {family} case {index} can be drawn in {MAX_DRAWS} tries",
    )


# ----------------------------------------------------------------------------- arm families
def _joint_box(arm: Any) -> tuple[np.ndarray, np.ndarray]:
    """The joint limits shrunk by :data:`LIMIT_MARGIN`; a joint of more than one turn kept to +-180 deg."""
    lo, hi = np.asarray(arm.q_min, dtype=float), np.asarray(arm.q_max, dtype=float)
    lo, hi = lo.copy(), hi.copy()
    for j in range(arm.nq):  # e.g. the IRB 4600's joints 4 and 6 (+-400 deg), a continuous joint
        if arm.periodic[j] and hi[j] - lo[j] > 2.0 * math.pi:
            lo[j], hi[j] = max(lo[j], -math.pi), min(hi[j], math.pi)
    margin = LIMIT_MARGIN * (hi - lo)
    return lo + margin, hi - margin


def _joint_step(arm: Any, difficulty: float) -> np.ndarray:
    """The start's largest offset per joint [rad or m] (module docstring)."""
    revolute, prismatic = math.radians(MAX_JOINT_STEP_DEG), MAX_PRISMATIC_STEP_M
    return difficulty * np.where(np.asarray(arm.periodic) > 0.0, revolute, prismatic)


def _well_conditioned(arm: Any, q: np.ndarray) -> bool:
    if arm.ik_method == "spherical-wrist" and abs(q[4]) < math.radians(WRIST_MARGIN_DEG):
        return False
    return float(np.linalg.svd(arm.camera_jacobian(q), compute_uv=False)[-1]) >= MIN_JACOBIAN_SIGMA


def _arm_case(
    family: str, index: int, rng: np.random.Generator, difficulty: float, arm: Any, camera: Any
) -> Case:
    from ..estimation.stereo_pose import check_marker_geometry
    from ..exceptions import DegenerateMarkersError
    from ..scenarios import place_markers
    from ..simulation.sensor import MarkerSensor

    lo, hi = _joint_box(arm)
    step, n = _joint_step(arm, difficulty), arm.nq
    for draw in range(1, MAX_DRAWS + 1):
        q_target = lo + (hi - lo) * rng.random(n)
        q_start = np.clip(q_target + step * rng.uniform(-1.0, 1.0, n), lo, hi)
        if not (_well_conditioned(arm, q_target) and _well_conditioned(arm, q_start)):
            continue
        T_target, T_start = arm.camera_pose(q_target), arm.camera_pose(q_start)
        if family == "arm-physical":
            rays = rng.uniform(-0.35, 0.35, (3, 2))
            markers = place_markers(T_target, rays, rng.uniform(1.5, 3.5, 3))
        else:
            markers = np.column_stack(
                (rng.uniform(1.0, 4.0, 3), rng.uniform(-2.0, 2.0, 3), rng.uniform(-0.5, 2.0, 3))
            )
        try:
            check_marker_geometry(markers, "markers_O")
        except DegenerateMarkersError:
            continue
        virtual = family == "arm-virtual"
        if not virtual:
            sensor = MarkerSensor(camera, markers)
            views = [camera.visibility(sensor.points_in_camera(T)).all_visible for T in (T_start, T_target)]
            if not all(views):
                continue
        else:  # projected whatever the sign, but never at ~zero depth or disparity
            P = [matmul(markers - T[:3, 3], T[:3, :3]) for T in (T_start, T_target)]
            if min(np.abs(p[:, 2]).min() for p in P) < 0.2:
                continue
        scenario = {
            "q_start": q_start,
            "q_target": q_target,
            "markers_O": np.round(markers, 6),
            "name": f"{family}-{index}",
            "virtual_points": virtual,
        }
        return Case(family, index, scenario, _difficulty(T_start, T_target), draw)
    raise _undrawable(family, index, difficulty)


def _mount_case(family: str, index: int, stream: np.random.SeedSequence, difficulty: float, arm: Any) -> Case:
    """Case ``index`` of a mount family: one mounting of :func:`~ibvs_youla.scenarios.mount_pair`."""
    from ..model.eye_to_hand import mounted
    from ..scenarios import mount_pair

    try:
        pair = mount_pair(arm, stream, step_deg=MOUNT_STEP_DEG * difficulty, name=f"{family}-{index}")
    except InvalidParameterError as err:
        if err.name != "seed":  # not the rules rejecting every draw: the error says what is wrong
            raise
        raise _undrawable(family, index, difficulty) from None
    scenario = pair[MOUNT_FAMILIES.index(family)]
    view = mounted(arm, scenario.mount)
    T_start, T_target = view.camera_pose(scenario.q_true_start), view.camera_pose(scenario.q_target)
    data = scenario.to_dict()
    data["name"] = f"{family}-{index}"
    del data["description"]
    return Case(family, index, data, _difficulty(T_start, T_target))


# ----------------------------------------------------------------------------- free camera
def _uniform_ball(rng: np.random.Generator, radius: float) -> np.ndarray:
    direction = rng.normal(size=3)
    direction /= norm3(direction)
    return radius * rng.random() ** (1.0 / 3.0) * direction


def _random_axis(rng: np.random.Generator) -> np.ndarray:
    axis = rng.normal(size=3)
    return axis / norm3(axis)


def _free_offset(rng: np.random.Generator, difficulty: float) -> np.ndarray:
    """T_C*_C0 of free-planar/free-nonplanar: a random rotation and translation (module docstring)."""
    delta = np.eye(4)
    axis = _random_axis(rng)  # (the order of the draws fixes the cases of a seed: keep it)
    angle = math.radians(MAX_ROTATION_DEG) * difficulty * rng.random()
    delta[:3, :3] = _rotvec_matrix(angle * axis)
    delta[:3, 3] = _uniform_ball(rng, MAX_TRANSLATION_M * difficulty)
    return delta


def _roll_offset(rng: np.random.Generator, difficulty: float) -> np.ndarray:
    """T_C*_C0 of free-roll: a turn about the optical axis, a small tilt and shift (module docstring)."""
    low, high = (min(math.radians(a) * difficulty, math.pi) for a in (MIN_ROLL_DEG, MAX_ROLL_DEG))
    roll = (low + (high - low) * rng.random()) * rng.choice((-1.0, 1.0))
    tilt = math.radians(ROLL_TILT_DEG) * difficulty * rng.random()
    delta = np.eye(4)
    delta[:3, :3] = matmul(
        _rotvec_matrix(tilt * _random_axis(rng)), _rotvec_matrix(np.array([0.0, 0.0, roll]))
    )
    delta[:3, 3] = _uniform_ball(rng, ROLL_TRANSLATION_M * difficulty)
    return delta


def _free_case(family: str, index: int, rng: np.random.Generator, difficulty: float) -> Case:
    points = np.vstack([SQUARE_O, OFF_PLANE_O]) if family == "free-nonplanar" else SQUARE_O
    cMo_target = np.eye(4)
    cMo_target[:3, 3] = (0.0, 0.0, 0.75)  # the target camera 0.75 m in front of the points, facing them
    T_target = np.linalg.inv(cMo_target)
    for draw in range(1, MAX_DRAWS + 1):
        delta = _roll_offset(rng, difficulty) if family == "free-roll" else _free_offset(rng, difficulty)
        T_start = matmul(T_target, delta)
        P_C = matmul(points - T_start[:3, 3], T_start[:3, :3])
        if not (P_C[:, 2].min() >= 0.1 and np.abs(P_C[:, :2] / P_C[:, 2:]).max() <= 1.0):  # NaN fails
            continue
        scenario = {
            "T_O_C_start": T_start,
            "T_O_C_target": T_target,
            "markers_O": points,
            "name": f"{family}-{index}",
            "virtual_points": False,
        }
        return Case(family, index, scenario, _difficulty(T_start, T_target), draw)
    raise _undrawable(family, index, difficulty)


def _textured_case(family: str, index: int, rng: np.random.Generator, difficulty: float) -> Case:
    """A free-textured case (module docstring): a small random offset and a texture of its own seed."""
    from ..model.textured_plane import TexturedPlane
    from ..scenarios import textured_plane

    delta = np.eye(4)
    axis = _random_axis(rng)
    angle = math.radians(TEXTURED_ROTATION_DEG) * difficulty * rng.random()
    delta[:3, :3] = _rotvec_matrix(angle * axis)
    delta[:3, 3] = _uniform_ball(rng, TEXTURED_TRANSLATION_M * difficulty)
    texture_seed = int(rng.integers(2**31))
    base = textured_plane(scene=TexturedPlane(seed=texture_seed))
    T_target = np.asarray(base.T_O_C_target)
    T_start = matmul(T_target, delta)
    points = np.asarray(base.markers_O)
    P_C = matmul(points - T_start[:3, 3], T_start[:3, :3])
    if P_C[:, 2].min() < 0.1 or np.abs(P_C[:, :2] / P_C[:, 2:]).max() > 1.0:  # no draw of the family's
        raise _undrawable(family, index, difficulty)  # range comes near: only a huge difficulty does
    scenario = {
        "T_O_C_start": T_start,
        "T_O_C_target": T_target,
        "markers_O": points,
        "name": f"{family}-{index}",
        "virtual_points": False,
        "scene": base.scene.to_dict(),
    }
    return Case(family, index, scenario, _difficulty(T_start, T_target), 1)
