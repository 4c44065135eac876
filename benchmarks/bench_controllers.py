"""Time one control update of every registered method on the same frames, with its floor, in one run.

The paper's Table 2 rates the computational load of its comparison methods in words; this script
measures it. One update is ``controller.update(frame, reading)`` as the servo loop calls it at a
camera frame, the frame made beforehand by ``MarkerSensor.measure`` at the true camera pose (the
sensor is not timed: it is the same for every method). Every controller is built by name
(``ibvs_youla.controllers.make``) with its defaults, reset with a :class:`ServoTask` as
``simulate`` builds it (25 Hz camera), and fed the same frames.

Cases:

* ``mono``: ViSP's tutorial-ibvs-4pts (``PinholeCamera.normalized()``, four coplanar points of a
  20 cm square, start and target poses of the tutorial, free camera). Every method that commands a
  camera twist (the registry's names minus the paper's ``fb`` and ``ff+fb``). Configurations:
  seeded poses on the start -> target path (translation interpolated, rotation by slerp) perturbed
  by 1 cm and 2 deg (standard deviations per axis); a pose is kept when every point lies within the
  MPC's default image box (|x|, |y| <= 0.5), so each MPC update solves one QP (no fallback).
* ``irregular``: the same poses with seven irregular coplanar points (ViSP's servoMomentPoints set,
  its repeated point dropped, /20 and centred) in place of the square, every twist method: the
  moment features refuse the square (isotropic moments), so ``ibvs-moments`` is timed here, next
  to the other laws on the same frames.
* ``stereo``: the physical-2 scenario (``StereoCamera.zed2()``, three markers, the IRB 4600 arm)
  on its joint path perturbed by 0.05 rad, as ``bench_outer_loop.py`` does for the paper's
  scenarios; a configuration is kept when every marker is visible. Every twist method and the
  paper's controllers (``fb`` and ``ff+fb``, adaptive: Eq. (62) and the SVD of the image Jacobian
  at every frame), fed the encoder reading q_true - d.
* ``textured``: the textured plane (``scenarios.textured_plane()``: the free camera 1 m before it,
  the 120 x 90 px camera of ``scenarios.textured_camera()``), for the methods that servo on the image
  (``photometric``), which run on no other case. Configurations: seeded poses on the start ->
  target path perturbed by 1 cm and 1 deg; each frame carries the image the scene sensor renders
  (``SceneImageSensor.measure``), not timed with the update, but timed as a part (``scene_frame``:
  the image and the markers' features, what the loop's sensor costs per frame for this method;
  ``render_plane``: the warp alone).

A method that refuses a case's task at reset (``InvalidParameterError``: ``ibvs-moments`` on the
square and on physical-2's isosceles markers) is listed in ``cases[case]["refused"]`` with the
reason, and not timed there.

Every call is timed alone (``time.perf_counter``, GC off) in passes over all configurations of a
case: one pass per method, then one per floor call, part and reference law (each pass calls one
function back to back, as the update passes do), all of them in every round (3 warm-up rounds),
so that all see the same machine load. JSON: ``controllers`` maps each registered method to
``median_us``, ``p95_us``, ``floor_us``, ``ratio_to_floor`` on its case (``case``: ``mono`` for the
twist methods, ``irregular`` for those that refuse the square, ``stereo`` for the paper's,
``textured`` for photometric servoing);
``cases[case]["methods"]`` has every method that runs on each case, ``cases[case]["refused"]``
those that refuse it, ``floor_calls_median_us`` and ``parts_median_us`` the pieces;
``reference`` the reference laws; ``machine`` where and when. ``ibvs-polar`` and
``ibvs-partitioned`` get ``dgesdd_L`` as their SVD floor (their own L is 8x6 and 8x4 mono, 12x6
and 9x4 stereo, against the 8x6 and 9x6 timed); ``ibvs-moments`` (L_s* at the target) the
product ``dot_pinv``; ``photometric`` the product L_I*^T e (``dot_LTe``: numpy, 6 x N by N, N =
7,000 pixels).

**Floor** of a method: the native calls its update cannot avoid, each timed bare on the same data
(:data:`FLOORS`); ``floor_us`` is the sum of their medians and ``ratio_to_floor`` = median / floor.
``solvepnp``: ``cv2.solvePnP(..., flags=SOLVEPNP_SQPNP)`` on normalized coordinates (the monocular
pose, for depths or the pose error); ``dgesdd_L``: LAPACK ``dgesdd`` (``scipy.linalg.lapack``) of
the interaction matrix at the frame (8x6 mono, 9x6 stereo; the pseudo-inverse); ``dot_pinv``: the
product L*^+ e with the constant pseudo-inverse at the target (all that L at the desired features
needs; ``ibvs-desired`` redoes the SVD every frame, which is avoidable); ``dgesdd_3x3``: the SVD of
the 3x3 cross-covariance of stereo P3P (Kabsch); ``daqp``: ``daqp.solve`` alone on the QP the MPC
builds (the arrays packed as qpsolvers packs them); ``fk``, ``frame_placement``,
``frame_jacobian``, ``dgesdd_J``: the paper's controller's Pinocchio ``forwardKinematics`` and
``updateFramePlacement`` (the IK pose check), ``computeFrameJacobian`` (LOCAL) and the SVD of the
9x6 image Jacobian (the floor of ``bench_outer_loop.py``). ``solvepnp_ippe`` (IPPE, for planar
points) is timed for comparison only.

**Parts** (library functions, the same frames): ``pose_estimate`` (``estimate_camera_pose``: the
validated wrapper around the PnP or stereo P3P that PBVS, 2.5-D and the hybrid law call),
``theta_u`` (:func:`~ibvs_youla.controllers.pbvs.theta_u`, scipy's ``Rotation``), ``ibvs_interaction``
and ``ibvs_pinv`` (``ClassicalIBVS.interaction_matrix``, PnP included, and ``.pinv``),
``triangulate``, ``mpc_qp_build`` (``MpcIBVS.qp``, its interaction matrix included) and
``mpc_qpsolvers`` (a ``qpsolvers.Problem`` solved by ``solve_problem``, as ``MpcIBVS`` does).
Triangulation is scalar arithmetic with no library call, so stereo IBVS's floor is its SVD alone.

**Reference laws** (mono case, same frames, depths given, i.e. the true ones): ``numpy-ibvs``, a
minimal Python IBVS law (L of the four points built with numpy from features and depths, then
-lambda ``np.linalg.pinv(L)`` e); ``library-ibvs-law``, the same law through the library's kernels
(``points_interaction_matrix`` and ``ClassicalIBVS.pinv``), i.e. ``ibvs-current`` without its PnP.
With ``--mvtb-python PATH`` (an interpreter where ``machinevision-toolbox-python`` is installed,
never a dependency of this project) the Machine Vision Toolbox for Python's ``IBVS.step`` and its
law alone (``visjac_p`` + ``np.linalg.pinv``) are timed on the same poses, in a worker process
that runs its pass in turn with the others (GC off there too). These are laws alone beside the
toolbox's whole step (projection, law and pose update): not the same work, so not a comparison of
speed; ``bench_peers.py`` times whole steps of ibvs-youla, ViSP 3.5 and the toolbox on the same case.

Run: ``python benchmarks/bench_controllers.py --json controllers.json [--configs N] [--repeats R]``.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import subprocess
import sys
from ctypes import c_int
from typing import Any

import numpy as np
import pinocchio as pin
from scipy.linalg import lapack
from scipy.spatial.transform import Rotation, Slerp

try:  # imported as benchmarks.bench_controllers
    from ._timing import CpuShare, count, machine, perf_counter, summary_us, write_json
except ImportError:  # run as a script
    from _timing import CpuShare, count, machine, perf_counter, summary_us, write_json

import ibvs_youla as iy
from ibvs_youla import controllers, scenarios
from ibvs_youla.controllers import JointReading, ServoTask
from ibvs_youla.controllers.pbvs import theta_u
from ibvs_youla.estimation.monocular_pose import estimate_camera_pose
from ibvs_youla.exceptions import InvalidParameterError
from ibvs_youla.model.camera import points_interaction_matrix, triangulate_points
from ibvs_youla.model.luminance import BORDER_PX
from ibvs_youla.model.textured_plane import render_plane
from ibvs_youla.simulation.scene_sensor import SceneImageSensor
from ibvs_youla.simulation.sensor import MarkerSensor

CAMERA_RATE_HZ = 25.0  # the acceptance scenario's camera rate
PAPER = ("fb", "ff+fb")  # the paper's controllers: stereo and an arm only
CASES = ("mono", "irregular", "stereo", "textured")
CASE_NAMES = {
    "mono": "ViSP tutorial-ibvs-4pts: normalized monocular camera, 4 points, free camera",
    "irregular": "the tutorial's poses with 7 irregular coplanar points: normalized camera, free camera",
    "stereo": "physical-2: StereoCamera.zed2(), 3 markers, IRB 4600 joint path",
    "textured": "textured plane: 120 x 90 px pinhole camera, free camera, the image of every frame",
}
# The native calls each method's update cannot avoid (module docstring), per case.
_MONO_FLOORS = {
    "ibvs-current": ("solvepnp", "dgesdd_L"),
    "ibvs-desired": ("dot_pinv",),
    "ibvs-mean": ("solvepnp", "dgesdd_L"),
    "pbvs": ("solvepnp",),
    "2.5d": ("solvepnp",),
    "hybrid": ("solvepnp", "dgesdd_L"),
    "mpc-ibvs": ("solvepnp", "daqp"),
    "ibvs-polar": ("solvepnp", "dgesdd_L"),
    "ibvs-partitioned": ("solvepnp", "dgesdd_L"),
    "ibvs-moments": ("dot_pinv",),
}
FLOORS: dict[str, dict[str, tuple[str, ...]]] = {
    "mono": _MONO_FLOORS,
    "irregular": _MONO_FLOORS,
    "stereo": {
        "ibvs-current": ("dgesdd_L",),
        "ibvs-desired": ("dot_pinv",),
        "ibvs-mean": ("dgesdd_L",),
        "pbvs": ("dgesdd_3x3",),
        "2.5d": ("dgesdd_3x3",),
        "hybrid": ("dgesdd_3x3", "dgesdd_L"),
        "mpc-ibvs": ("daqp",),
        "ibvs-polar": ("dgesdd_L",),
        "ibvs-partitioned": ("dgesdd_L",),
        "fb": ("fk", "frame_placement", "frame_jacobian", "dgesdd_J", "dgesdd_3x3"),
        "ff+fb": ("fk", "frame_placement", "frame_jacobian", "dgesdd_J", "dgesdd_3x3"),
    },
    "textured": {"photometric": ("dot_LTe",)},
}
IRREGULAR_O = np.array([[1, 0], [3, 1], [4, 4], [-1, 4], [-3, -2], [-2, -2], [-1, 1]], dtype=float) / 20.0
IRREGULAR_O = np.column_stack((IRREGULAR_O - IRREGULAR_O.mean(axis=0), np.zeros(len(IRREGULAR_O))))  # [m]


# ---------------------------------------------------------------------------------------- cases
def _T_O_C(t: list[float], theta_u_deg: list[float]) -> np.ndarray:
    """Camera pose from ViSP's cMo (object pose in the camera), as in the acceptance example."""
    cMo = np.eye(4)
    cMo[:3, :3] = Rotation.from_rotvec(np.radians(theta_u_deg)).as_matrix()
    cMo[:3, 3] = t
    return np.linalg.inv(cMo)


def _mono_case(
    n: int, rng: np.random.Generator, points_O: np.ndarray | None = None
) -> tuple[ServoTask, list[Any], int]:
    """Task and n (frame, reading, T_O_C) of the tutorial case; and how many poses were dropped."""
    if points_O is None:
        points_O = np.array([[-0.1, -0.1, 0], [0.1, -0.1, 0], [0.1, 0.1, 0], [-0.1, 0.1, 0]], dtype=float)
    T_start, T_target = _T_O_C([0.15, -0.1, 1.0], [10, -10, 50]), _T_O_C([0, 0, 0.75], [0, 0, 0])
    camera = iy.PinholeCamera.normalized()
    sensor = MarkerSensor(camera, points_O)
    period = 1.0 / CAMERA_RATE_HZ
    task = ServoTask(
        camera=camera,
        markers_O=points_O,
        feature_target=sensor.features_at(T_target),
        T_O_C_target=T_target,
        tick_period=period,
        frame_period=period,
        T_O_C_start=T_start,
    )
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix([T_start[:3, :3], T_target[:3, :3]]))
    out, dropped = [], 0
    while len(out) < n:
        f = rng.random()
        T = np.eye(4)
        T[:3, :3] = (Rotation.from_rotvec(np.radians(2.0) * rng.standard_normal(3)) * slerp(f)).as_matrix()
        T[:3, 3] = T_start[:3, 3] + f * (T_target[:3, 3] - T_start[:3, 3]) + 0.01 * rng.standard_normal(3)
        frame = sensor.measure(T, 0.0)
        if np.abs(frame.features).max() > 0.5:  # outside the MPC's default image box
            dropped += 1
            continue
        out.append((frame, None, T))
    return task, out, dropped


def _stereo_case(n: int, rng: np.random.Generator) -> tuple[ServoTask, list[Any], int]:
    """Task and n (frame, reading, q_true) of physical-2; and how many were dropped."""
    sc, arm, camera = scenarios.physical(2), iy.Arm.irb4600(), iy.StereoCamera.zed2()
    sensor = MarkerSensor(camera, sc.markers_O, virtual_points=sc.virtual_points)
    settings = iy.SimulationSettings(camera_rate_hz=CAMERA_RATE_HZ)
    T_target = arm.camera_pose(sc.q_target)
    task = ServoTask(
        camera=camera,
        markers_O=sc.markers_O,
        feature_target=sensor.features_at(T_target),
        T_O_C_target=T_target,
        tick_period=settings.dt,
        frame_period=settings.dt * settings.camera_every,
        virtual_points=sc.virtual_points,
        arm=arm,
        q_start=sc.q_start,
        q_target=sc.q_target,
        T_O_C_start=arm.camera_pose(sc.q_start),
    )
    out, dropped, zeros = [], 0, np.zeros(6)
    while len(out) < n:
        q = sc.q_start + rng.random() * (sc.q_target - sc.q_start) + 0.05 * rng.standard_normal(6)
        q = np.clip(q, arm.q_min + 0.01, arm.q_max - 0.01)
        frame = sensor.measure(arm.camera_pose(q), 0.0)
        if not frame.visible.all():
            dropped += 1
            continue
        out.append((frame, JointReading(0.0, q - sc.joint_offset, zeros), q))  # at rest, encoders
    return task, out, dropped


def _textured_case(n: int, rng: np.random.Generator) -> tuple[ServoTask, list[Any], int]:
    """Task and n (frame with its image, None, T_O_C) before the textured plane; none dropped."""
    scenario, camera = scenarios.textured_plane(), scenarios.textured_camera()
    sensor = SceneImageSensor(MarkerSensor(camera, scenario.markers_O), scenario.scene)
    T_start, T_target = np.asarray(scenario.T_O_C_start), np.asarray(scenario.T_O_C_target)
    period = 1.0 / CAMERA_RATE_HZ
    task = ServoTask(
        camera=camera,
        markers_O=scenario.markers_O,
        feature_target=sensor.features_at(T_target),
        T_O_C_target=T_target,
        tick_period=period,
        frame_period=period,
        T_O_C_start=T_start,
        scene=scenario.scene,
        image_target=sensor.image_at(T_target),
    )
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix([T_start[:3, :3], T_target[:3, :3]]))
    out = []
    for f in rng.random(n):
        T = np.eye(4)
        T[:3, :3] = (Rotation.from_rotvec(np.radians(1.0) * rng.standard_normal(3)) * slerp(f)).as_matrix()
        T[:3, 3] = T_start[:3, 3] + f * (T_target[:3, 3] - T_start[:3, 3]) + 0.01 * rng.standard_normal(3)
        out.append((sensor.measure(T, 0.0), None, T))
    return task, out, 0


def _controllers_for(case: str, task: ServoTask) -> tuple[dict[str, Any], dict[str, str]]:
    """Every registered method that runs on the case, built by name with its defaults, reset.

    And those that refuse the case's task at reset (name -> the reason). The methods that servo
    on the image run on the textured case alone, and the others on every other case.
    """
    out, refused = {}, {}
    for name in controllers.names():
        if controllers.make(name).needs_image != (case == "textured"):
            continue
        if name in PAPER:
            if case != "stereo":
                continue
            ctrl = controllers.make(name, adaptive=True)  # the paper's gains (YoulaSettings defaults)
        else:
            ctrl = controllers.make(name)
        try:
            ctrl.reset(task)
        except InvalidParameterError as err:
            refused[name] = str(err)
            continue
        out[name] = ctrl
    return out, refused


# ---------------------------------------------------------------------------------------- floor data
def _daqp_inputs(P: np.ndarray, q: np.ndarray, G: np.ndarray, h: np.ndarray, bound: np.ndarray) -> tuple:
    """``daqp.solve`` arguments of min 1/2 x^T P x + q^T x, G x <= h, |x| <= bound (qpsolvers' packing)."""
    ms, mineq = bound.size, G.shape[0]
    bupper = np.concatenate((bound, h))
    blower = np.concatenate((-bound, np.full(mineq, -1e30)))
    return (P, q, G, bupper, blower, np.zeros(ms + mineq, dtype=c_int))


def _depths(task: ServoTask, T_O_C: np.ndarray) -> np.ndarray:
    """Depths Z (n,) [m] of the task's markers seen from T_O_C."""
    R, t = T_O_C[:3, :3], T_O_C[:3, 3]
    return ((task.markers_O - t) @ R)[:, 2]


Job = tuple[Any, list[tuple[Any, ...]]]  # (callable, its arguments for each configuration)


def _jobs(case: str, task: ServoTask, ctrls: dict[str, Any], configs: list[Any]) -> dict[str, Job]:
    """What is timed on a case: key -> (function, arguments per configuration), prepared untimed.

    Keys: the method names (``update(frame, reading)``), ``floor:<call>`` (bare native calls),
    ``part:<name>`` (the library functions the slow updates spend their time in) and, on the
    monocular case, ``ref:<name>`` (the reference laws).
    """
    import cv2
    import daqp
    import qpsolvers

    if case == "textured":
        return _textured_jobs(task, ctrls, configs)
    camera, markers_O, n, virtual = task.camera, task.markers_O, task.n_points, task.virtual_points
    ibvs, mpc = ctrls["ibvs-current"], ctrls["mpc-ibvs"]
    target = np.asarray(task.feature_target, dtype=float)
    T_target_C = np.linalg.inv(task.T_O_C_target)
    P_C_target = (markers_O - task.T_O_C_target[:3, 3]) @ task.T_O_C_target[:3, :3]
    pinv_target = ibvs.pinv(points_interaction_matrix(camera, P_C_target, virtual))  # L*^+ (6, m)
    bound = np.tile([mpc.v_max] * 3 + [mpc.omega_max] * 3, mpc.horizon)
    features = [frame.features for frame, _, _ in configs]
    qps = [mpc.qp(s) for s in features]  # (P, q, G, h)
    Ls = [np.ascontiguousarray(ibvs.interaction_matrix(s)) for s in features]

    def qpsolvers_solve(P: np.ndarray, q: np.ndarray, G: np.ndarray, h: np.ndarray) -> Any:
        """What MpcIBVS does per solve: a qpsolvers Problem, solved by its solver (DAQP)."""
        return qpsolvers.solve_problem(qpsolvers.Problem(P, q, G, h, lb=-bound, ub=bound), solver=mpc.solver)

    jobs: dict[str, Job] = {
        name: (ctrl.update, [(f, r) for f, r, _ in configs]) for name, ctrl in ctrls.items()
    }
    jobs["floor:dgesdd_L"] = (lapack.dgesdd, [(L, 1, 0) for L in Ls])
    jobs["floor:dot_pinv"] = (pinv_target.dot, [(s - target,) for s in features])
    jobs["floor:daqp"] = (daqp.solve, [_daqp_inputs(*qp, bound) for qp in qps])
    poses = [estimate_camera_pose(camera, s, markers_O) for s in features]
    R_target_C = [np.ascontiguousarray((T_target_C @ T)[:3, :3]) for T in poses]
    parts: dict[str, Job] = {
        "part:pose_estimate": (estimate_camera_pose, [(camera, s, markers_O) for s in features]),
        "part:theta_u": (theta_u, [(R,) for R in R_target_C]),
        "part:mpc_qp_build": (mpc.qp, [(s,) for s in features]),
        "part:mpc_qpsolvers": (qpsolvers_solve, qps),
    }
    if case != "stereo":
        K = np.eye(3)
        F, P_ref = camera.focal_length, np.ascontiguousarray(markers_O)
        pnp = [(P_ref, np.ascontiguousarray(s.reshape(n, 2) / F)) for s in features]
        # positional: objectPoints, imagePoints, K, distCoeffs, rvec, tvec, useExtrinsicGuess, flags
        jobs["floor:solvepnp"] = (
            cv2.solvePnP,
            [(P, p, K, None, None, None, False, cv2.SOLVEPNP_SQPNP) for P, p in pnp],
        )
        jobs["floor:solvepnp_ippe"] = (
            cv2.solvePnP,
            [(P, p, K, None, None, None, False, cv2.SOLVEPNP_IPPE) for P, p in pnp],
        )
        parts["part:ibvs_interaction"] = (ibvs.interaction_matrix, [(s,) for s in features])
        parts["part:ibvs_pinv"] = (ibvs.pinv, [(L,) for L in Ls])
        jobs.update(parts)
        law = ibvs.pinv

        def library_ibvs_law(s: np.ndarray, P_C: np.ndarray) -> np.ndarray:
            """ClassicalIBVS.update after its depth estimate: L(s, Z), its pseudo-inverse, the twist."""
            return -0.5 * law(points_interaction_matrix(camera, P_C, virtual)).dot(s - target)

        depths = [_depths(task, T) for _, _, T in configs]  # the true depths: "depths given"
        jobs["ref:numpy-ibvs"] = (
            numpy_ibvs,
            [(s, Z, target, 0.5) for s, Z in zip(features, depths, strict=True)],
        )
        jobs["ref:library-ibvs-law"] = (
            library_ibvs_law,
            [
                (s, np.column_stack((s.reshape(n, 2) * (Z / camera.focal_length)[:, None], Z)))
                for s, Z in zip(features, depths, strict=True)
            ],
        )
    else:
        arm = task.arm
        eye = iy.EyeInHand(arm, camera, markers_O, virtual_points=virtual)
        model, data = arm.model, arm.model.createData()
        cam_id = model.getFrameId(arm.camera_frame)
        q_est = [eye.estimate_q(f.features, r.q) for f, r, _ in configs]
        P_C = [triangulate_points(camera, s.reshape(n, 3), virtual) for s in features]
        centred_O = markers_O - markers_O.mean(axis=0)
        jobs["floor:dgesdd_3x3"] = (lapack.dgesdd, [((P - P.mean(axis=0)).T @ centred_O, 1, 0) for P in P_C])
        jobs["floor:fk"] = (pin.forwardKinematics, [(model, data, q) for q in q_est])
        jobs["floor:frame_placement"] = (pin.updateFramePlacement, [(model, data, cam_id)] * len(q_est))
        jobs["floor:frame_jacobian"] = (
            pin.computeFrameJacobian,
            [(model, data, q, cam_id, pin.LOCAL) for q in q_est],
        )
        jobs["floor:dgesdd_J"] = (lapack.dgesdd, [(eye.jacobian(q), 1, 0) for q in q_est])
        parts["part:triangulate"] = (
            triangulate_points,
            [(camera, s.reshape(n, 3), virtual) for s in features],
        )
        jobs.update(parts)
    return jobs


def _textured_jobs(task: ServoTask, ctrls: dict[str, Any], configs: list[Any]) -> dict[str, Job]:
    """The photometric update, its floor (L_I*^T e) and the per-frame cost of its sensor."""
    scenario = scenarios.textured_plane()
    camera, scene = task.camera, task.scene
    sensor = SceneImageSensor(MarkerSensor(camera, scenario.markers_O), scene)
    photometric = ctrls["photometric"]
    b = BORDER_PX
    inner = (slice(b, -b), slice(b, -b))  # the feature's pixels: what the update reads
    L_T = np.ascontiguousarray(photometric.interaction_matrix().T)
    errors = [(f.image[inner] - task.image_target[inner]).ravel() for f, _, _ in configs]
    poses = [T for _, _, T in configs]
    jobs: dict[str, Job] = {
        name: (ctrl.update, [(f, r) for f, r, _ in configs]) for name, ctrl in ctrls.items()
    }
    jobs["floor:dot_LTe"] = (L_T.dot, [(e,) for e in errors])
    jobs["part:scene_frame"] = (sensor.measure, [(T, 0.0) for T in poses])
    jobs["part:render_plane"] = (render_plane, [(camera, scene, T) for T in poses])
    return jobs


# ---------------------------------------------------------------------------------------- reference law
def numpy_ibvs(s: np.ndarray, Z: np.ndarray, s_target: np.ndarray, gain: float) -> np.ndarray:
    """A minimal Python IBVS law: v = -lambda L^+ (s - s*), L of normalized points (x, y, Z) by numpy.

    L rows per point (Chaumette & Hutchinson 2006, Eq. (11)): [-1/Z, 0, x/Z, x y, -(1 + x^2), y] and
    [0, -1/Z, y/Z, 1 + y^2, -x y, -x]; ``np.linalg.pinv`` (SVD, numpy's default cut-off).
    """
    x, y = s[0::2], s[1::2]
    iz = 1.0 / Z
    L = np.empty((2 * x.size, 6))
    L[0::2] = np.column_stack((-iz, np.zeros_like(iz), x * iz, x * y, -(1.0 + x * x), y))
    L[1::2] = np.column_stack((np.zeros_like(iz), -iz, y * iz, 1.0 + y * y, -x * y, -x))
    return -gain * np.linalg.pinv(L).dot(s - s_target)


# ---------------------------------------------------------------------------------------- MVTB worker
_MVTB_WORKER = r"""
import gc, json, sys, time
import numpy as np
from machinevisiontoolbox import CentralCamera, IBVS
from spatialmath import SE3
import machinevisiontoolbox
perf = time.perf_counter
setup = json.loads(sys.stdin.readline())
P = np.array(setup["points_O"]).T  # (3, n)
p_d = np.array(setup["target"]).reshape(-1, 2).T  # (2, n)
poses = [SE3(np.array(T), check=False) for T in setup["poses"]]
features = [np.array(s) for s in setup["features"]]
camera = CentralCamera(f=1.0, rho=1.0, pp=(0.0, 0.0), imagesize=(2, 2))  # normalized coordinates
ibvs = IBVS(camera, P=P, p_d=p_d, lmbda=setup["gain"], graphics=False)
ibvs.init()
dev = max(
    float(np.abs(camera.project_point(P, pose=T).flatten(order="F") - s).max())
    for T, s in zip(poses, features)
)
print(json.dumps({"version": machinevisiontoolbox.__version__, "feature_deviation": dev}), flush=True)
gc.disable()  # as in the main process
for line in sys.stdin:
    if line.strip() != "pass":
        break
    step, law = [], []
    for T in poses:
        camera.pose = T
        ibvs.history = []
        t0 = perf()
        ibvs.step(0)
        t1 = perf()
        step.append(t1 - t0)
        uv = camera.project_point(P)
        Z = (T.inv() * P)[2, :]
        t0 = perf()
        J = camera.visjac_p(uv, Z)
        e = (uv - p_d).flatten(order="F")
        v = -ibvs.lmbda * np.linalg.pinv(J) @ e
        t1 = perf()
        law.append(t1 - t0)
    print(json.dumps({"mvtb-ibvs-step": step, "mvtb-ibvs-law": law}), flush=True)
"""


class _MvtbWorker:
    """The toolbox in its own interpreter: one timed pass over the same poses per request."""

    def __init__(self, python: str, task: ServoTask, configs: list[Any]) -> None:
        self.proc = subprocess.Popen(
            [python, "-c", _MVTB_WORKER], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
        )
        setup = {
            "points_O": task.markers_O.tolist(),
            "target": np.asarray(task.feature_target).tolist(),
            "poses": [pose.tolist() for _, _, pose in configs],
            "features": [frame.features.tolist() for frame, _, _ in configs],
            "gain": 0.5,
        }
        self.info = json.loads(self._ask(json.dumps(setup)))

    def _ask(self, line: str) -> str:
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        answer = self.proc.stdout.readline()
        if not answer:
            raise RuntimeError(f"the toolbox worker ended (exit code {self.proc.wait()})")
        return answer

    def timed_pass(self) -> dict[str, list[float]]:
        return json.loads(self._ask("pass"))

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait(timeout=30)


# ---------------------------------------------------------------------------------------- main
def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmark, print a table, write JSON if asked; return the report."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", metavar="FILE", help="write the report here")
    ap.add_argument("--configs", type=count, default=200, help="seeded configurations per case (default 200)")
    ap.add_argument("--repeats", type=count, default=15, help="timed passes over them (default 15)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--mvtb-python",
        metavar="PATH",
        help="an interpreter with machinevision-toolbox-python installed: time its IBVS.step too",
    )
    args = ap.parse_args(argv)

    rng = np.random.default_rng(args.seed)
    setup: dict[str, Any] = {}
    builders = {
        "mono": _mono_case,
        "irregular": lambda n, rng: _mono_case(n, rng, IRREGULAR_O),
        "stereo": _stereo_case,
        "textured": _textured_case,
    }
    for case in CASES:
        task, configs, dropped = builders[case](args.configs, rng)
        ctrls, refused = _controllers_for(case, task)
        for ctrl in ctrls.values():  # every method runs on every configuration (untimed check)
            for frame, reading, _ in configs:
                ctrl.update(frame, reading)
        jobs = _jobs(case, task, ctrls, configs)
        setup[case] = {
            "configs": configs,
            "dropped": dropped,
            "controllers": ctrls,
            "refused": refused,
            "jobs": jobs,
        }
    mono = setup["mono"]
    worker = None
    if args.mvtb_python:
        worker = _MvtbWorker(args.mvtb_python, mono["controllers"]["ibvs-current"].task, mono["configs"])
    times = {case: {key: [] for key in setup[case]["jobs"]} for case in CASES}
    mvtb: dict[str, list[float]] = {"mvtb-ibvs-step": [], "mvtb-ibvs-law": []}

    cpu = CpuShare()
    gc_was_enabled = gc.isenabled()
    gc.disable()
    try:
        for i in range(3 + args.repeats):  # 3 warm-up rounds; the passes alternate, so all see the same load
            record = i >= 3
            for case in CASES:
                for key, (fn, arguments) in setup[case]["jobs"].items():
                    out = times[case][key] if record else []
                    for a in arguments:  # one pass: every configuration, each call timed alone
                        t0 = perf_counter()
                        fn(*a)
                        out.append(perf_counter() - t0)
            if worker is not None:
                answer = worker.timed_pass()
                if record:
                    for key, seconds in answer.items():
                        mvtb[key].extend(seconds)
    finally:
        if gc_was_enabled:
            gc.enable()
        if worker is not None:
            worker.close()

    report = _report(args, setup, times, mvtb, worker)
    report["cpu"] = cpu.stop()
    _print(report)
    write_json(args.json, report, headline)
    return report


def headline(r: dict[str, Any]) -> dict[str, Any]:
    """The figures kept in the report's history: each method's median [us] and ratio to its floor."""
    return {
        "median_us": {name: e["median_us"] for name, e in r["controllers"].items()},
        "ratio_to_floor": {name: e["ratio_to_floor"] for name, e in r["controllers"].items()},
        "other_cores": r.get("cpu", {}).get("other_cores"),
    }


def _entry(stats: dict[str, dict[str, float]], name: str, floor_calls: tuple[str, ...] | None) -> dict:
    s = stats[name]
    floor = None if floor_calls is None else sum(stats[f"floor:{c}"]["median_us"] for c in floor_calls)
    return {
        "median_us": s["median_us"],
        "p95_us": s["p95_us"],
        "floor_us": floor,
        "ratio_to_floor": None if floor is None else s["median_us"] / floor,
        "floor_calls": None if floor_calls is None else list(floor_calls),
        "n": s["n"],
    }


def _report(
    args: argparse.Namespace,
    setup: dict[str, Any],
    times: dict[str, dict[str, list[float]]],
    mvtb: dict[str, list[float]],
    worker: _MvtbWorker | None,
) -> dict[str, Any]:
    cases: dict[str, Any] = {}
    for case in CASES:
        stats = {key: summary_us(v) for key, v in times[case].items()}

        def medians(prefix: str, stats: dict[str, dict[str, float]] = stats) -> dict[str, float]:
            return {k.split(":", 1)[1]: v["median_us"] for k, v in stats.items() if k.startswith(prefix)}

        cases[case] = {
            "description": CASE_NAMES[case],
            "configs": len(setup[case]["configs"]),
            "dropped_configs": setup[case]["dropped"],
            "methods": {
                name: _entry(stats, name, FLOORS[case].get(name)) for name in setup[case]["controllers"]
            },
            "refused": setup[case]["refused"],
            "floor_calls_median_us": medians("floor:"),
            "parts_median_us": medians("part:"),
            "stats": stats,
        }
    # One entry per method: the tutorial case for the twist methods (the irregular points for those
    # that refuse the square), stereo physical-2 for the paper's, the textured plane for those that
    # servo on the image.
    primary: dict[str, Any] = {}
    for case in ("stereo", "irregular", "mono", "textured"):  # later cases take precedence
        for name, entry in cases[case]["methods"].items():
            if case == "textured" or (name in PAPER) == (case == "stereo"):
                primary[name] = {**entry, "case": case}
    mono_stats = cases["mono"]["stats"]
    reference: dict[str, Any] = {
        key.split(":", 1)[1]: {k: mono_stats[key][k] for k in ("median_us", "p95_us", "n")}
        for key in mono_stats
        if key.startswith("ref:")
    }
    not_timed = {"visp-computeControlLaw": "a law alone: ViSP's whole loop iteration is in bench_peers"}
    if worker is None:
        not_timed["mvtb-ibvs-step"] = "no --mvtb-python given: not timed"
    else:
        for name, seconds in mvtb.items():
            reference[name] = {k: v for k, v in summary_us(seconds).items() if k != "p05_us"}
        reference["mvtb"] = worker.info
    reference["not_timed"] = not_timed
    return {
        "benchmark": "controllers",
        "controllers": {name: primary[name] for name in controllers.names() if name in primary},
        "cases": cases,
        "reference": reference,
        "settings": {
            "configs": args.configs,
            "repeats": args.repeats,
            "seed": args.seed,
            "camera_rate_hz": CAMERA_RATE_HZ,
            "mvtb_python": args.mvtb_python,
        },
        "machine": machine(),
    }


def _fmt(x: float | None, digits: int = 1) -> str:
    return "n/a" if x is None or not math.isfinite(x) else f"{x:.{digits}f}"


def _print(r: dict[str, Any]) -> None:
    n = f"{r['settings']['configs']} x {r['settings']['repeats']}"
    print(f"one control update, median / p95 / floor [us] (n = {n} per case)")
    header = f"{'method':<16} {'case':<9} {'median':>8} {'p95':>8} {'floor':>8} {'ratio':>6}  floor calls"
    print(header)
    for case in CASES:
        for name, e in r["cases"][case]["methods"].items():
            calls = "+".join(e["floor_calls"]) if e["floor_calls"] else "unknown"
            print(
                f"{name:<16} {case:<9} {_fmt(e['median_us']):>8} {_fmt(e['p95_us']):>8} "
                f"{_fmt(e['floor_us']):>8} {_fmt(e['ratio_to_floor']):>6}  {calls}"
            )
    for case in CASES:
        c = r["cases"][case]
        calls = ", ".join(f"{k} {v:.2f}" for k, v in c["floor_calls_median_us"].items())
        parts = ", ".join(f"{k} {v:.1f}" for k, v in c["parts_median_us"].items())
        print(f"{case}: floor calls [us]: {calls}")
        print(f"{case}: parts [us]: {parts}  ({c['dropped_configs']} poses dropped)")
    ref = r["reference"]
    for name, e in ref.items():
        if isinstance(e, dict) and "median_us" in e:
            print(f"reference {name:<18} median {e['median_us']:8.1f} us  p95 {e['p95_us']:8.1f} us")
    for name, why in ref["not_timed"].items():
        print(f"reference {name}: {why}")


if __name__ == "__main__":
    main(sys.argv[1:])
