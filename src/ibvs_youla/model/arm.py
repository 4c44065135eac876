"""An arm of n >= 6 joints with an eye-in-hand camera: kinematics (Eq. 12-28), dynamics (Eq. 29-32).

:class:`Arm` wraps a private copy of a Pinocchio model plus the frames the paper uses:
the flange {E} and the camera {C} (docs/conventions.md). Dynamics follow Eq. (29)::

    (D(q) + J) ddq + (C(q, dq) + B / r) dq + g(q) = u

The actuator terms J (armature) and B / r (viscous damping) come from Table A4 through
:class:`ActuatorParameters` (:mod:`ibvs_youla.model.actuators`, re-exported here) for the IRB
4600, from the caller, or else zero armature and the URDF's ``<dynamics damping>`` (zero when
absent). Pinocchio's CRBA, RNEA and ABA include ``model.armature``; they ignore
``model.damping``, which is therefore left at zero and the damping torque ``damping * dq`` is
added here.

**Any fixed-base arm.** The model is reduced to the chain from the base to the camera
(:mod:`ibvs_youla.model.chain`: every other joint locked, continuous joints in joint
coordinates), so q is a vector of n = :attr:`Arm.nq` joint coordinates (angles [rad], prismatic
positions [m]), n >= 6, and every array of the toolkit follows n. The camera sits on any frame
F of the chain at a fixed ``T_F_C``, added to the model as a frame (the URDF is not edited).
Robots by name: :meth:`Arm.from_robot` (:mod:`ibvs_youla.model.robots`).

**Inverse kinematics** (Eq. (28); Eq. (62) at every camera frame), one interface,
:meth:`Arm.ik` (every solution found) and :meth:`Arm.ik_nearest` (the one nearest a reference),
by the geometry (:attr:`Arm.ik_method`): ``"spherical-wrist"``, the closed form of the IRB 4600
(:mod:`.ik`); ``"ur"``, the UR family's closed form (:mod:`.ik_ur`); else ``"numerical"``:
damped Newton warm-started from the reference, on a redundant arm the solution nearest it
(:mod:`.ik_numerical`), and a seeded search only when the warm start fails.

Every public method validates its arguments (:func:`ibvs_youla._validation.as_array`, whose
check of a float64 array of the right shape costs about 0.5 us) and raises
:class:`~ibvs_youla.exceptions.InvalidArrayError` if they are not valid. The kernels do not
check: :meth:`Arm.camera_fk`, :meth:`Arm.camera_pose_and_jacobian`, :meth:`Arm.aba`,
:meth:`Arm.rnea`, :meth:`Arm.ik_nearest` and :meth:`Arm.ik_nearest_kinematics`. They are the
computations behind :meth:`Arm.camera_pose`, :meth:`Arm.camera_jacobian`,
:meth:`Arm.forward_dynamics`, :meth:`Arm.inverse_dynamics` and :meth:`Arm.ik`, called by those
methods and by the simulator, whose arrays are valid by construction; so is
:meth:`Arm.camera_jacobian_at`, the Jacobian alone in one Pinocchio call, for the actuation.

One :class:`Arm` may be shared by threads: each thread computes in its own Pinocchio
``Data``, created from :attr:`Arm.model` on the thread's first call. An arm pickles (and
``copy.deepcopy``-s) without its data, which the copy rebuilds the same way, so it can be
shipped to worker processes.
"""

from __future__ import annotations

import hashlib
import math
import os
import threading
from collections.abc import Mapping
from dataclasses import astuple
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from .._geometry import pose_error_mm_deg
from .._linalg import add_product
from .._validation import as_array, as_pose, non_negative, positive, text
from ..exceptions import InvalidArrayError, InvalidParameterError, ModelLoadError, UnreachablePoseError
from . import robots
from ._resources import load_urdf_model
from .actuators import ActuatorParameters
from .chain import joint_coordinate_model, joint_kinds, mimic_joints, reduce_to_chain
from .ik import (
    SphericalWristParameters,
    closed_form_branches,
    numerical_branches,
    select_branches,
)
from .ik_kernels import ik_parameter_array, nearest_branch_compiled, nearest_row_compiled, poses_match
from .ik_numerical import solve_near
from .ik_ur import UrParameters, ur_branches_compiled, ur_parameter_array
from .urdf_checks import check_model

__all__ = ["ABA_CONVENTION", "ActuatorParameters", "Arm"]

# Pinocchio 3 offers the articulated-body algorithm in two conventions, the same dynamics to
# rounding (~1e-14 relative); the WORLD one is about 12 % faster on the IRB 4600 (benchmarks/).
ABA_CONVENTION = pin.Convention.WORLD

_IK_TOL = 1e-9  # max |FK(q) - T| accepted for an IK solution (rotation entries and metres)
_IK_SEEDS = 24  # random seeds of the numerical IK (besides q_near)
_READ_ONLY = ("armature", "damping", "q_min", "q_max", "dq_max", "tau_max", "T_E_C", "T_F_C", "periodic")
IK_METHODS = ("spherical-wrist", "ur", "numerical")


def _read_only(x: Any) -> np.ndarray:
    arr = np.array(x, dtype=float)
    arr.setflags(write=False)
    return arr


def _rigid(T: np.ndarray) -> np.ndarray:
    """T with its rotation projected onto SO(3) (a rigid transform to round-off)."""
    T = T.copy()
    U, _, Vt = np.linalg.svd(T[:3, :3])
    T[:3, :3] = U @ Vt
    return T


class _ThreadData(threading.local):
    """One Pinocchio ``Data`` of ``model`` per thread, created on the thread's first access."""

    def __init__(self, model: pin.Model) -> None:
        self.data = model.createData()


class Arm:
    """A serial arm of n >= 6 joints carrying a camera, with the kinematics and dynamics the paper uses.

    Build it with :meth:`irb4600`, :meth:`from_robot`, :meth:`from_urdf`, or ``Arm(model,
    camera_frame=..., ...)`` from a Pinocchio model (same keywords as :meth:`from_urdf`). The
    model is reduced to the chain from the base to the camera and copied, never mutated; do not
    mutate :attr:`model` either (use :meth:`with_inertia_scale` or :meth:`with_hand_eye`). Safe to
    share between threads (one Pinocchio ``Data`` per thread); pickles.

    Attributes:
        model: Pinocchio model of the chain in joint coordinates (``model.armature`` set,
            ``model.damping`` zero; the camera frame added when ``T_F_C`` is given).
        name: Human-readable name.
        robot: Registry name (:mod:`ibvs_youla.model.robots`), or None.
        nq: Number of joints n (>= 6): the size of every joint vector (``model.nq == model.nv``).
        joint_names: Names of the n joints, base to camera.
        joint_kinds: ``"revolute"``, ``"continuous"`` or ``"prismatic"`` per joint.
        periodic: 1.0 for a joint whose angle is periodic (revolute, continuous), 0.0 for a
            prismatic one (n,).
        locked_joints: The joints off the chain (or locked on request) and their values.
        q_min, q_max: Joint position limits (n,) [rad or m] (-inf, +inf for a continuous joint).
        dq_max: Joint speed limits (n,) [rad/s or m/s].
        tau_max: Joint torque (force) limits (n,) [N m or N].
        armature: Joint-side rotor inertia J of Eq. (29) (n,) [kg m^2].
        damping: Joint-side viscous damping B / r of Eq. (29) (n,) [N m s/rad].
        camera_frame: The frame F the camera is mounted on.
        T_F_C: The camera in F (4, 4) (identity: the camera is F itself).
        flange_frame: The flange frame {E}.
        T_E_C: Camera pose in the flange frame (4, 4) (ERRATA 2: Rz(pi) for the IRB 4600).
        ik_method: ``"spherical-wrist"``, ``"ur"`` or ``"numerical"`` (module docstring).
        ik_parameters: Lengths used by the spherical-wrist closed form, or None.
        urdf_path: File the model was loaded from (None if built from a model).

    Raises:
        InvalidParameterError: ``model`` is not a ``pinocchio.Model``, or a frame name or the
            name is not a string.
        ModelLoadError: the chain to the camera is not n >= 6 revolute, continuous or prismatic
            joints, a frame or locked joint is unknown, or the model is not physically valid
            (:mod:`ibvs_youla.model.urdf_checks`); naming the element.
    """

    def __init__(
        self,
        model: pin.Model,
        *,
        camera_frame: str = "camera",
        T_F_C: Any = None,
        flange_frame: str | None = None,
        locked_joints: Mapping[str, Any] | None = None,
        armature: Any = None,
        damping: Any = None,
        dq_max: Any = None,
        tau_max: Any = None,
        name: str | None = None,
        source: Any = None,
    ) -> None:
        if not isinstance(model, pin.Model):
            raise InvalidParameterError(
                "model", type(model).__name__, "a pinocchio.Model (to load a URDF file, use Arm.from_urdf)"
            )
        camera_frame, name = text(camera_frame, "camera_frame"), None if name is None else text(name, "name")
        if flange_frame is not None:
            flange_frame = text(flange_frame, "flange_frame")
        if locked_joints is not None and not isinstance(locked_joints, Mapping):
            raise InvalidParameterError(
                "locked_joints", locked_joints, "a mapping joint name -> value, or None"
            )
        mimic = mimic_joints(source) if isinstance(source, Path) else {}
        chain, locked = reduce_to_chain(model, camera_frame, locked_joints, mimic, source)
        n = chain.nv
        self._vec = (n,)  # shape of a joint vector
        for label, values, target in (
            ("dq_max", dq_max, chain.velocityLimit),
            ("tau_max", tau_max, chain.effortLimit),
        ):
            if values is not None:
                values = as_array(values, label, self._vec)
                if np.any(values <= 0.0):
                    raise InvalidArrayError(label, f"{values.tolist()}", "entries > 0")
                target[:] = values
        check_model(chain, source)
        urdf_damping = np.array(chain.damping, dtype=float)
        self.model = joint_coordinate_model(chain).copy()
        self.name = name or model.name
        self.robot: str | None = None
        self.urdf_path = source
        self.nq = n
        self.joint_names = tuple(self.model.names[1:])
        self.joint_kinds = joint_kinds(chain)
        self.periodic = _read_only([k != "prismatic" for k in self.joint_kinds])
        self.locked_joints = locked
        self.camera_frame = camera_frame
        if T_F_C is None:
            self.T_F_C = _read_only(np.eye(4))
            self._camera_id = self._frame(camera_frame)
        else:
            self.T_F_C = _read_only(_rigid(as_pose(T_F_C, "T_F_C")))
            self._camera_id = self._mount(camera_frame, self.T_F_C)
        if flange_frame is None:
            flange_frame = "flange" if self.model.existFrame("flange") else self.model.names[n]
        self.flange_frame = flange_frame
        self._flange_id = self._frame(flange_frame)
        last = int(self.model.frames[self._camera_id].parentJoint)
        if int(self.model.frames[self._flange_id].parentJoint) != last:
            raise ModelLoadError(
                source,
                f"flange frame {flange_frame!r} is not rigidly attached to the camera's link (joint "
                f"{self.model.names[last]!r}, the last of the chain)",
                f"frame {flange_frame!r}",
            )
        zeros = np.zeros(n)
        self.armature = _read_only(zeros if armature is None else as_array(armature, "armature", self._vec))
        self.damping = _read_only(
            urdf_damping if damping is None else as_array(damping, "damping", self._vec)
        )
        for label, values in (("armature", self.armature), ("damping", self.damping)):
            if np.any(values < 0):
                raise InvalidArrayError(label, f"{values.tolist()}", "entries >= 0")
        self.model.armature[:] = self.armature
        self.model.damping[:] = 0.0  # ignored by Pinocchio's dynamics; applied by this class
        self.q_min = _read_only(self.model.lowerPositionLimit)
        self.q_max = _read_only(self.model.upperPositionLimit)
        self.dq_max = _read_only(self.model.velocityLimit)
        self.tau_max = _read_only(self.model.effortLimit)
        frames = self.model.frames
        self.T_E_C = _read_only(
            (frames[self._flange_id].placement.inverse() * frames[self._camera_id].placement).homogeneous
        )
        self._T_C_E = np.linalg.inv(self.T_E_C)
        self._thread_data = _ThreadData(self.model)
        self._inertia_scale = 1.0
        self._urdf_sha256 = _file_sha256(source) if isinstance(source, Path) else None
        revolute = all(k == "revolute" for k in self.joint_kinds)
        self.ik_parameters = (
            SphericalWristParameters.identify(self.model, self._flange_id) if n == 6 and revolute else None
        )
        self._ur = UrParameters.identify(self.model, self._flange_id) if self._ik_parameters is None else None
        if self._ur is not None:  # for the compiled UR closed form: T_06 = T_0_O T_O_C T_C_6
            self._ur_arrays = (
                ur_parameter_array(self._ur),
                np.linalg.inv(self._ur.T_O_0),
                self._T_C_E @ np.linalg.inv(self._ur.T_6_E),
            )
        rng = np.random.default_rng(0)
        lo, hi = np.maximum(self.q_min, -math.pi), np.minimum(self.q_max, math.pi)
        self._ik_seeds = lo + (hi - lo) * rng.random((_IK_SEEDS, n))

    def _frame(self, name: str) -> int:
        """Id of frame ``name`` in :attr:`model` (a BODY frame first when several share the name)."""
        ids = [i for i, f in enumerate(self.model.frames) if f.name == name]
        if not ids:
            names = sorted({f.name for f in self.model.frames if int(f.parentJoint) == self.nq})
            raise ModelLoadError(
                self.urdf_path,
                f"frame {name!r} is not in the model; frames on the camera's link: {names}",
                f"frame {name!r}",
            )
        body = [i for i in ids if self.model.frames[i].type == pin.FrameType.BODY]
        return (body or ids)[0]

    def _mount(self, camera_frame: str, T_F_C: np.ndarray) -> int:
        """Add the camera frame at F T_F_C (F = ``camera_frame``) to :attr:`model`; its id."""
        parent = self._frame(camera_frame)
        frame = self.model.frames[parent]
        name = "camera" if not self.model.existFrame("camera") else f"camera@{camera_frame}"
        placement = frame.placement * pin.SE3(T_F_C)
        return int(
            self.model.addFrame(
                pin.Frame(name, int(frame.parentJoint), parent, placement, pin.FrameType.OP_FRAME), False
            )
        )

    @property
    def ik_parameters(self) -> SphericalWristParameters | None:
        """Lengths used by the spherical-wrist closed-form IK, or None."""
        return self._ik_parameters

    @ik_parameters.setter
    def ik_parameters(self, params: SphericalWristParameters | None) -> None:
        self._ik_parameters = params
        self._ik_array = None if params is None else ik_parameter_array(params)  # for the compiled IK

    @property
    def ik_method(self) -> str:
        """``"spherical-wrist"``, ``"ur"`` or ``"numerical"``: how :meth:`ik` solves (module docstring)."""
        if self._ik_parameters is not None:
            return "spherical-wrist"
        return "ur" if self._ur is not None else "numerical"

    @property
    def redundant(self) -> bool:
        """True when the arm has more joints than a camera pose has degrees of freedom (n > 6)."""
        return self.nq > 6

    # ------------------------------------------------------------------ construction
    @classmethod
    def irb4600(cls, actuator: str = "paper") -> Arm:
        """ABB IRB 4600-45/2.05 with a ZED 2 on the flange (urdf/abb_irb4600_45_205.urdf).

        ``Arm.from_robot("irb4600", actuator=actuator)``.

        Args:
            actuator: ``"paper"`` (literal Eq. 29: J = J_a + J_g, damping B_m / r) or
                ``"reflected"`` (r^2 (J_a + J_g), r^2 B_m); see :class:`ActuatorParameters`.
        """
        return cls.from_robot("irb4600", actuator=actuator)

    @classmethod
    def from_robot(cls, name: str, **overrides: Any) -> Arm:
        """A robot by name (:func:`ibvs_youla.model.robots.names`), its default mount unless overridden.

        Args:
            name: ``"irb4600"``, ``"ur3"``, ``"ur5"``, ``"ur10"``, ``"panda"``, ``"xarm7"``,
                ``"z1"`` or ``"kinova"``.
            **overrides: Keywords of :meth:`from_urdf` (``camera_frame``, ``T_F_C``,
                ``flange_frame``, ``locked_joints`` (merged with the entry's), ``armature``,
                ``damping``, ``dq_max``, ``tau_max``), and for the IRB 4600 ``actuator``
                (``"paper"`` or ``"reflected"``, :meth:`irb4600`).

        Raises:
            InvalidParameterError: an unknown robot or keyword.
            ModelLoadError: as :meth:`from_urdf`.
        """
        entry = robots.get(name)
        valid = (
            "camera_frame",
            "T_F_C",
            "flange_frame",
            "locked_joints",
            "armature",
            "damping",
            "dq_max",
            "tau_max",
        )
        valid += ("actuator",) if entry.shipped else ()
        unknown = sorted(set(overrides) - set(valid))
        if unknown:
            raise InvalidParameterError("overrides", unknown, f"keywords among {', '.join(valid)}")
        options = dict(overrides)
        actuator = options.pop("actuator", "paper")
        if entry.shipped:
            armature, damping = ActuatorParameters().joint_terms(actuator)
            options.setdefault("armature", np.full(6, armature))
            options.setdefault("damping", np.full(6, damping))
        path = robots.urdf(name)
        if "camera_frame" not in overrides:
            options["camera_frame"] = entry.camera_frame
            options.setdefault("flange_frame", entry.flange_frame)
            if "T_F_C" not in overrides and not np.array_equal(entry.T_F_C, np.eye(4)):
                options["T_F_C"] = np.array(entry.T_F_C)
        options["locked_joints"] = {**entry.locked_joints, **dict(options.get("locked_joints") or {})}
        arm = cls.from_urdf(path, **options)
        arm.robot = entry.name
        if entry.shipped:
            documented = SphericalWristParameters.irb4600()
            found = arm.ik_parameters
            if found is None or not np.allclose(astuple(found), astuple(documented), rtol=0.0, atol=1e-9):
                raise ModelLoadError(
                    arm.urdf_path, f"URDF geometry {found} differs from ERRATA 1 {documented}"
                )
            arm.ik_parameters = documented
            arm.name = f"{entry.title} ({actuator} actuator)"
        else:
            arm.name = entry.name
        return arm

    @classmethod
    def from_urdf(
        cls,
        path: str | Path,
        camera_frame: str = "camera",
        flange_frame: str | None = None,
        armature: Any = None,
        damping: Any = None,
        *,
        T_F_C: Any = None,
        locked_joints: Mapping[str, Any] | None = None,
        dq_max: Any = None,
        tau_max: Any = None,
        name: str | None = None,
    ) -> Arm:
        """Load any fixed-base arm whose chain from the base to the camera has six or more joints.

        Args:
            path: URDF file (fixed base; meshes are not loaded).
            camera_frame: The frame F (a link or joint of the URDF) the camera is mounted on;
                with ``T_F_C`` None, the camera frame {C} itself.
            flange_frame: Frame of the flange {E}, on the camera's link; default ``"flange"`` if
                present, else the last joint's frame.
            armature: Joint-side rotor inertias (n,) [kg m^2]; default zeros.
            damping: Joint-side viscous damping (n,) [N m s/rad]; default the URDF's
                ``<dynamics damping>`` (zeros when absent).
            T_F_C: The camera in F (4, 4), rigid within 1e-6 (projected onto SO(3)); added to
                the model as the frame ``"camera"`` (``"camera@F"`` if the URDF has a
                ``camera`` frame already); default None (the camera is F).
            locked_joints: Joints to lock and their values in joint coordinates [rad or m]
                (e.g. the Panda's ``{"panda_joint7": 0.785}`` makes a 6-joint arm); every joint
                off the chain is locked anyway, at its neutral position unless named here.
            dq_max: Speed limits (n,) [rad/s or m/s] replacing the URDF's (needed for a
                continuous joint without ``<limit velocity>``).
            tau_max: Torque limits (n,) [N m or N] replacing the URDF's.
            name: The arm's name; default the URDF's robot name.

        Raises:
            ModelLoadError: the file is missing or unparsable; a floating base or other
                non-revolute, non-prismatic joint, or a mimic joint, on the chain; fewer than six
                joints on it; an unknown camera, flange or locked joint (the message lists the
                candidates); a joint without finite limits; or physically invalid
                (:mod:`ibvs_youla.model.urdf_checks`); naming the link or joint.
        """
        if not isinstance(path, (str, os.PathLike)):
            raise InvalidParameterError("path", path, "a URDF file path (str or pathlib.Path)")
        path = Path(path)
        model = load_urdf_model(path)
        return cls(
            model,
            camera_frame=camera_frame,
            T_F_C=T_F_C,
            flange_frame=flange_frame,
            locked_joints=locked_joints,
            armature=armature,
            damping=damping,
            dq_max=dq_max,
            tau_max=tau_max,
            name=name,
            source=path,
        )

    def identity(self) -> robots.ArmIdentity:
        """What tells this arm apart from others, as plain data (:class:`~.robots.ArmIdentity`).

        Equal for two arms built the same way (same robot or URDF bytes, mount, locked joints,
        actuator terms, limits, inertia scale and hand-eye transform; the transforms rounded to 12
        decimals, so that round-off does not tell arms apart), so a campaign spec can hold it and
        keys of different arms never collide.
        """

        def rows(T: np.ndarray) -> tuple[tuple[float, ...], ...]:  # 12 decimals: round-off is not identity
            return tuple(tuple(round(float(x), 12) + 0.0 for x in row) for row in T)  # + 0.0: no -0.0

        return robots.ArmIdentity(
            robot=self.robot,
            urdf_sha256=self._urdf_sha256,
            camera_frame=self.camera_frame,
            T_F_C=rows(self.T_F_C),
            flange_frame=self.flange_frame,
            T_E_C=rows(self.T_E_C),
            locked_joints=dict(self.locked_joints),
            armature=tuple(self.armature.tolist()),
            damping=tuple(self.damping.tolist()),
            dq_max=tuple(self.dq_max.tolist()),
            tau_max=tuple(self.tau_max.tolist()),
            inertia_scale=self._inertia_scale,
        )

    @classmethod
    def from_identity(
        cls, identity: robots.ArmIdentity | Mapping[str, Any], urdf: str | Path | None = None
    ) -> Arm:
        """The arm an :meth:`identity` describes (e.g. on a Dask worker, from a campaign spec).

        A named robot is rebuilt from the registry; an arm from a URDF needs its file, ``urdf``,
        whose SHA-256 must be the identity's. Mount, locked joints, actuator terms, limits, inertia
        scale and hand-eye transform are applied, so ``Arm.from_identity(arm.identity()).identity()
        == arm.identity()``.

        Raises:
            InvalidParameterError: not an identity, or a URDF arm without ``urdf``.
            ModelLoadError: the file's SHA-256 differs from the identity's (another robot
                description), or it cannot be loaded.
        """
        if isinstance(identity, Mapping):
            identity = robots.ArmIdentity.from_dict(identity)
        if not isinstance(identity, robots.ArmIdentity):
            raise InvalidParameterError(
                "identity", type(identity).__name__, "an ArmIdentity or its to_dict() data"
            )
        options: dict[str, Any] = {
            "camera_frame": identity.camera_frame,
            "T_F_C": None if np.array_equal(identity.T_F_C, np.eye(4)) else np.array(identity.T_F_C),
            "flange_frame": identity.flange_frame,
            "locked_joints": dict(identity.locked_joints),
            "armature": np.array(identity.armature),
            "damping": np.array(identity.damping),
            "dq_max": np.array(identity.dq_max),
            "tau_max": np.array(identity.tau_max),
        }
        if identity.robot is not None:
            path = robots.urdf(identity.robot)
        elif urdf is None:
            raise InvalidParameterError("urdf", None, "the URDF file of an arm that is not a named robot")
        else:
            path = Path(urdf)
        if identity.urdf_sha256 is not None and path.is_file() and _file_sha256(path) != identity.urdf_sha256:
            raise ModelLoadError(
                path,
                f"URDF {str(path)!r} is not the one of the identity (SHA-256 {identity.urdf_sha256[:12]}...)",
            )
        if identity.robot is not None:
            arm = cls.from_robot(identity.robot, **options)
        else:
            arm = cls.from_urdf(path, **options)
        if identity.inertia_scale != 1.0:
            arm = arm.with_inertia_scale(identity.inertia_scale)
        if arm.identity().T_E_C != tuple(identity.T_E_C):
            arm = arm.with_hand_eye(np.array(identity.T_E_C))
        return arm

    def with_inertia_scale(self, factor: float) -> Arm:
        """A new Arm whose link masses and rotational inertias are multiplied by ``factor``.

        Centres of mass, armature and damping are unchanged (the camera, merged into the
        last link by Pinocchio, is scaled too). Use it as the "true" plant when studying
        imperfect feedback linearization (Eq. 33 computed with the nominal arm).
        """
        factor = positive(factor, "factor")
        model = self.model.copy()
        for i in range(model.njoints):
            inertia = model.inertias[i]
            scaled = pin.Inertia(inertia.mass * factor, inertia.lever.copy(), inertia.inertia * factor)
            model.inertias[i] = scaled
        arm = self._with_model(model, f"{self.name} (inertia x{factor:g})")
        arm._inertia_scale = self._inertia_scale * factor
        return arm

    def with_hand_eye(self, T_E_C: Any) -> Arm:
        """A new Arm whose camera {C} sits at ``T_E_C`` in the flange frame {E}, all else equal.

        A controller's belief about the hand-eye calibration (Eq. 18-20; nominal T_E_C = Rz(pi),
        ERRATA 2), perturbed. Only the Pinocchio camera frame moves, to T_E_C after the flange
        frame on the last joint: :meth:`camera_pose` = T_O_E(q) T_E_C, :meth:`camera_jacobian`
        and :meth:`ik` follow it; links, inertias (the camera's, merged into the last link),
        limits, armature, damping and IK parameters are those of this arm, whose model is not
        touched. The name gains the move of {C}, e.g. ``(T_E_C moved 2 mm, 0.5 deg)``.

        Args:
            T_E_C: Camera pose in the flange frame (4, 4), rigid within 1e-6 (its rotation is
                projected onto SO(3), so the camera frame is rigid to round-off).

        Raises:
            InvalidArrayError: ``T_E_C`` is not a finite rigid (4, 4) transform.
        """
        T_E_C = _rigid(as_pose(T_E_C, "T_E_C"))
        moved_mm, moved_deg = pose_error_mm_deg(self.T_E_C, T_E_C)
        model = self.model.copy()
        flange = model.frames[self._flange_id]
        placement = flange.placement * pin.SE3(T_E_C)  # both on the last joint
        camera_id = self._camera_id
        if camera_id == self._flange_id:  # the camera was the flange frame itself: it gets its own
            name = f"camera@{self.flange_frame}"
            frame = pin.Frame(
                name, int(flange.parentJoint), self._flange_id, placement, pin.FrameType.OP_FRAME
            )
            camera_id = int(model.addFrame(frame, False))
        else:
            camera = model.frames[camera_id]
            camera.placement = placement
            model.frames[camera_id] = camera
        moved = f"{self.name} (T_E_C moved {moved_mm:.3g} mm, {moved_deg:.3g} deg)"
        return self._with_model(model, moved, camera_id)

    def _with_model(self, model: pin.Model, name: str, camera_id: int | None = None) -> Arm:
        """An Arm on ``model`` (a modified copy of :attr:`model`) with this arm's frames, actuators and IK."""
        camera_id = self._camera_id if camera_id is None else camera_id
        arm = Arm(
            model,
            camera_frame=model.frames[camera_id].name,
            flange_frame=self.flange_frame,
            armature=self.armature,
            damping=self.damping,
            name=name,
            source=self.urdf_path,
        )
        arm.camera_frame, arm.T_F_C = self.camera_frame, self.T_F_C
        arm.locked_joints, arm.robot, arm._urdf_sha256 = self.locked_joints, self.robot, self._urdf_sha256
        arm._inertia_scale = self._inertia_scale
        if arm.ik_parameters is not None and self.ik_parameters is not None:
            arm.ik_parameters = self.ik_parameters
        return arm

    def __getstate__(self) -> dict[str, Any]:
        """Pickle (and deepcopy) state: every attribute but the per-thread Pinocchio data."""
        state = self.__dict__.copy()
        del state["_thread_data"]
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Restore the attributes, their read-only flags and a fresh per-thread data."""
        self.__dict__.update(state)
        for name in _READ_ONLY:
            getattr(self, name).setflags(write=False)
        self._thread_data = _ThreadData(self.model)

    def __repr__(self) -> str:
        return f"Arm({self.name!r}, nq={self.nq}, ik={self.ik_method})"

    # ------------------------------------------------------------------ kinematics
    def within_limits(self, q: Any, tol: float = 0.0) -> bool:
        """True if ``q_min - tol <= q <= q_max + tol`` for every joint (``tol`` [rad] >= 0)."""
        q = as_array(q, "q", self._vec)
        tol = non_negative(tol, "tol")
        return bool(np.all(q >= self.q_min - tol) and np.all(q <= self.q_max + tol))

    def flange_pose(self, q: Any) -> np.ndarray:
        """T_O_E (4, 4): flange pose in the base frame, Eq. (15) (the paper's T_6^0)."""
        data = self._thread_data.data
        pin.forwardKinematics(self.model, data, as_array(q, "q", self._vec))
        return pin.updateFramePlacement(self.model, data, self._flange_id).homogeneous

    def camera_pose(self, q: Any) -> np.ndarray:
        """T_O_C (4, 4) = T_O_E(q) T_E_C: camera pose in the base frame (Eq. 21 inverted)."""
        return self.camera_fk(as_array(q, "q", self._vec))

    def camera_fk(self, q: np.ndarray) -> np.ndarray:
        """T_O_C (4, 4) at q: the forward kinematics of `camera_pose`, one Pinocchio pass.

        Kernel: does not validate ``q``, which must be a finite float64 (n,) array (a
        plant's own state, an IK solution).
        """
        data = self._thread_data.data
        pin.forwardKinematics(self.model, data, q)
        return pin.updateFramePlacement(self.model, data, self._camera_id).homogeneous

    def camera_jacobian(self, q: Any) -> np.ndarray:
        """J_C (6, n): LOCAL frame Jacobian of the camera, maps dq to the camera twist [v; w] in {C}.

        With the stereo interaction matrix L(P_C), ``L @ J_C`` is the 9 x n image Jacobian
        of Eq. (51). Rank 5 at the IRB 4600's wrist singularity q5 = 0 (ERRATA 7).
        """
        return self.camera_pose_and_jacobian(as_array(q, "q", self._vec))[1]

    def camera_pose_and_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(T_O_C, J_C) at q from one kinematics pass: `camera_pose` and `camera_jacobian` together.

        Kernel: does not validate ``q``, which must be a finite float64 (n,) array.
        """
        model, data = self.model, self._thread_data.data
        pin.computeJointJacobians(model, data, q)
        J_C = pin.getFrameJacobian(model, data, self._camera_id, pin.LOCAL)
        return pin.updateFramePlacement(model, data, self._camera_id).homogeneous, J_C

    def camera_jacobian_at(self, q: np.ndarray) -> np.ndarray:
        """J_C (6, n) at q, LOCAL, from Pinocchio's ``computeFrameJacobian`` alone (no pose).

        Kernel for the actuation at every joint tick (``TwistToJointVelocity``): does not validate
        ``q``, which must be a finite float64 (n,) array. The same Jacobian as
        :meth:`camera_jacobian` to rounding (~1e-15), in half its time.
        """
        return pin.computeFrameJacobian(self.model, self._thread_data.data, q, self._camera_id, pin.LOCAL)

    # ------------------------------------------------------------------ dynamics
    def mass_matrix(self, q: Any) -> np.ndarray:
        """M(q) = D(q) + J (n, n), Eq. (31): CRBA with the armature, both triangles filled."""
        M = pin.crba(self.model, self._thread_data.data, as_array(q, "q", self._vec))
        return np.triu(M) + np.triu(M, 1).T

    def nonlinear_effects(self, q: Any, dq: Any) -> np.ndarray:
        """h(q, dq) = C(q, dq) dq + g(q) + (B / r) dq (n,) [N m], Eq. (32)."""
        dq = as_array(dq, "dq", self._vec)
        h = pin.nonLinearEffects(self.model, self._thread_data.data, as_array(q, "q", self._vec), dq)
        return h + self.damping * dq

    def gravity(self, q: Any) -> np.ndarray:
        """g(q) (n,) [N m], the gravity torques of Eq. (29)."""
        q = as_array(q, "q", self._vec)
        return pin.computeGeneralizedGravity(self.model, self._thread_data.data, q).copy()

    def forward_dynamics(self, q: Any, dq: Any, tau: Any) -> np.ndarray:
        """Joint accelerations ddq (n,) [rad/s^2] solving Eq. (30) M(q) ddq + h(q, dq) = tau (see `aba`)."""
        q, dq, tau = (
            as_array(q, "q", self._vec),
            as_array(dq, "dq", self._vec),
            as_array(tau, "tau", self._vec),
        )
        return self.aba(q, dq, tau).copy()

    def aba(self, q: np.ndarray, dq: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Joint accelerations ddq of Eq. (30) by the articulated-body algorithm, armature included.

        Pinocchio's ABA (:data:`ABA_CONVENTION`) on ``tau - damping * dq``. Kernel of
        `forward_dynamics`: does not validate its arguments, which must be finite float64 (n,)
        arrays (q [rad], dq [rad/s], tau [N m]). The result may be the thread's Pinocchio buffer
        (it depends on the Pinocchio version): copy it to keep it past the next dynamics call, as
        `forward_dynamics` does.
        """
        return pin.aba(self.model, self._thread_data.data, q, dq, tau - self.damping * dq, ABA_CONVENTION)

    def pinocchio_model_data(self) -> tuple[pin.Model, pin.Data]:
        """(:attr:`model`, the calling thread's Pinocchio ``Data``), for kernels that call Pinocchio.

        E.g. the plant's RK4 (:class:`~ibvs_youla.simulation.integrators.ArmRk4`), which reads
        the model's numbers once for the compiled ABA (:mod:`.dynamics_kernels`), or calls
        ``pin.aba`` (:data:`ABA_CONVENTION`) between compiled stages, and applies the damping
        itself. Use both in this thread only, and do not modify the model.
        """
        return self.model, self._thread_data.data

    def inverse_dynamics(self, q: Any, dq: Any, ddq: Any) -> np.ndarray:
        """Joint torques tau = M(q) ddq + h(q, dq) (n,) [N m], Eq. (30) (see `rnea`)."""
        return self.rnea(
            as_array(q, "q", self._vec), as_array(dq, "dq", self._vec), as_array(ddq, "ddq", self._vec)
        )

    def rnea(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        """Joint torques tau = M(q) ddq + h(q, dq) of Eq. (30) in one recursive Newton-Euler pass.

        The armature is in the model; the damping torque ``damping * dq`` is added. Kernel of
        `inverse_dynamics` (and of Eq. (33), tau = M(q) v + h(q, dq)): does not validate its
        arguments, which must be finite float64 (n,) arrays (q [rad], dq [rad/s], ddq [rad/s^2]).
        """
        tau = pin.rnea(self.model, self._thread_data.data, q, dq, ddq)  # a new array
        add_product(tau, self.damping, dq)  # + damping * dq, in one compiled call
        return tau  # type: ignore[no-any-return]

    def kinetic_energy(self, q: Any, dq: Any) -> float:
        """0.5 dq^T M(q) dq [J], rotor (armature) energy included."""
        dq = as_array(dq, "dq", self._vec)
        return 0.5 * float(dq @ self.mass_matrix(q) @ dq)

    def potential_energy(self, q: Any) -> float:
        """Gravitational potential energy of the links and camera [J] (zero at base height)."""
        return float(
            pin.computePotentialEnergy(self.model, self._thread_data.data, as_array(q, "q", self._vec))
        )

    # ------------------------------------------------------------------ inverse kinematics
    def ik(self, T_O_C: Any, q_near: Any = None) -> np.ndarray:
        """Joint configurations within limits that put the camera at ``T_O_C``, Eq. (28), nearest first.

        By :attr:`ik_method`: the spherical-wrist closed form (:mod:`ibvs_youla.model.ik`, up to 8
        branches: shoulder front/back, elbow up/down, wrist flip), the UR closed form
        (:mod:`ibvs_youla.model.ik_ur`, up to 8), or damped Newton (:mod:`.ik_numerical`) from
        ``q_near`` (when given) and from 24 fixed seeded starts. Each revolute joint comes back as
        the 2*pi-equivalent within limits nearest ``q_near`` (for the IRB 4600 this matters for axes
        4 and 6, +-400 deg; without ``q_near`` they lie in (-pi, pi]). At a wrist singularity the
        closed forms keep the reference's angle of the first wrist joint (IRB 4600: q4 = q_near[3],
        or 0; UR: q6 = q_near[5]). On a redundant arm (n > 6) the first row is the configuration
        nearest ``q_near`` (:func:`~ibvs_youla.model.ik_numerical.solve_near`), the others are those
        the seeds found. Every row satisfies max|FK(q) - T_O_C| <= 1e-9.

        Args:
            T_O_C: Camera pose in the base frame (4, 4), rigid within 1e-6 (projected
                onto SO(3) before solving).
            q_near: Reference configuration (n,) [rad or m]; default zeros.

        Returns:
            (k, n), sorted by Euclidean distance to ``q_near`` (nearest first).

        Raises:
            InvalidArrayError: non-finite or non-rigid pose, bad ``q_near``.
            UnreachablePoseError: no solution within the joint limits.
        """
        T_O_C = _rigid(as_pose(T_O_C, "T_O_C"))
        ref = np.zeros(self.nq) if q_near is None else as_array(q_near, "q_near", self._vec)
        model, data = self.model, self._thread_data.data
        if self._ik_parameters is not None:
            raw = closed_form_branches(self._ik_parameters, T_O_C @ self._T_C_E, ref)
        elif self._ur is not None:
            raw = self._ur_rows(T_O_C, ref)
        else:
            seeds = self._ik_seeds if q_near is None else np.vstack([ref, self._ik_seeds])
            raw = numerical_branches(model, data, self._camera_id, T_O_C, seeds)
            if q_near is not None:
                near = solve_near(model, data, self._camera_id, T_O_C, ref)
                raw = raw if near is None else np.vstack([near, raw])
        solutions = self._select(raw, ref)
        solutions = solutions[[np.abs(self.camera_fk(q) - T_O_C).max() <= _IK_TOL for q in solutions]]
        if solutions.shape[0] and self.redundant and q_near is not None:
            nearest = solve_near(model, data, self._camera_id, T_O_C, solutions[0], ref)  # the nearest to ref
            if nearest is not None and self.within_limits(nearest):
                solutions = np.vstack([nearest, solutions])
                solutions = solutions[np.argsort(np.linalg.norm(solutions - ref, axis=1), kind="stable")]
        if solutions.shape[0] == 0:
            where = np.round(T_O_C[:3, 3], 4).tolist()
            why = (
                "no configuration reaches it (outside the workspace)"
                if raw.shape[0] == 0
                else f"{raw.shape[0]} solution(s) reach it but none within the joint limits; nearest q = "
                f"{np.round(np.degrees(raw[np.argmin(np.linalg.norm(raw - ref, axis=1))]), 2).tolist()} deg"
            )
            raise UnreachablePoseError(T_O_C, f"{self.name}: camera pose at {where} m: {why}")
        return solutions

    def _ur_rows(self, T_O_C: np.ndarray, ref: np.ndarray) -> np.ndarray:
        """The UR closed form's branches (k, 6) of the camera pose (:func:`~.ik_ur.ur_branches_compiled`)."""
        p, T_0_O, T_C_6 = self._ur_arrays
        rows = np.empty((8, 6))
        return rows[: ur_branches_compiled(p, T_0_O, T_O_C, T_C_6, float(ref[5]), rows)]

    def _select(self, raw: np.ndarray, ref: np.ndarray) -> np.ndarray:
        """`select_branches` with this arm's limits (prismatic joints not wrapped)."""
        periodic = None if self.periodic.all() else self.periodic.astype(bool)
        return select_branches(raw, self.q_min, self.q_max, ref, periodic=periodic)

    def ik_nearest(self, T_O_C: np.ndarray, q_near: np.ndarray) -> np.ndarray:
        """The IK solution nearest ``q_near`` (Eq. (62) at every frame), without building every branch.

        Kernel: does not validate its arguments. ``T_O_C`` must be a rigid (4, 4) float pose
        (e.g. from stereo P3P, orthonormal to rounding, so the projection onto SO(3) of :meth:`ik`
        is skipped) and ``q_near`` a finite float (n,) array. By :attr:`ik_method`: the spherical
        wrist's nearest in-limit branch (:func:`~ibvs_youla.model.ik.nearest_branch`, compiled:
        :mod:`~ibvs_youla.model.ik_kernels`); the UR's branches, the nearest in limits; else the
        warm start, damped Newton from ``q_near`` (on a redundant arm, to the configuration
        nearest ``q_near``). The result must pass the pose check of :meth:`ik`; any other case
        (the nearest branch rejected, no branch, the warm start failing or leaving the limits) is
        delegated to :meth:`ik`, which also raises its errors.
        """
        return self.ik_nearest_kinematics(T_O_C, q_near)[0]

    def ik_nearest_kinematics(
        self, T_O_C: np.ndarray, q_near: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, T_O_C(q), J_C(q)): :meth:`ik_nearest`, and :meth:`camera_pose_and_jacobian` at q.

        Both from the one kinematics pass that checks the IK solution (the kinematics computed
        once per configuration).

        Kernel: arguments as :meth:`ik_nearest`.
        """
        q = None
        if self._ik_array is not None:
            found, q = nearest_branch_compiled(
                self._ik_array, T_O_C, self._T_C_E, self.q_min, self.q_max, q_near, 1e-9
            )
            q = q if found else None
        elif self._ur is not None:
            p, T_0_O, T_C_6 = self._ur_arrays
            rows = np.empty((8, 6))
            count = ur_branches_compiled(p, T_0_O, T_O_C, T_C_6, q_near[5], rows)
            found, q = nearest_row_compiled(rows, count, self.q_min, self.q_max, q_near, 1e-9)
            q = q if found else None
        else:
            q = solve_near(self.model, self._thread_data.data, self._camera_id, T_O_C, q_near)
            if q is not None and not (np.all(q >= self.q_min) and np.all(q <= self.q_max)):
                q = None  # left the limits: the seeded search decides
        if q is not None:
            T_q, J_C = self.camera_pose_and_jacobian(q)
            if poses_match(T_q, T_O_C, _IK_TOL):  # max |FK(q) - T_O_C| <= 1e-9, as ik checks
                return q, T_q, J_C
        q = self.ik(T_O_C, q_near=q_near)[0]
        return (q, *self.camera_pose_and_jacobian(q))


def _file_sha256(path: Path) -> str:
    """SHA-256 of a file's bytes (hex)."""
    return hashlib.sha256(path.read_bytes()).hexdigest()
