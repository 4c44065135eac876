"""A 6-DOF arm with an eye-in-hand camera: kinematics (Eq. 12-28) and dynamics (Eq. 29-32) on Pinocchio.

:class:`Arm` wraps a private copy of a Pinocchio model plus the frames the paper uses:
the flange {E} and the camera {C} (docs/conventions.md). Dynamics follow Eq. (29)::

    (D(q) + J) ddq + (C(q, dq) + B / r) dq + g(q) = u

The actuator terms J (armature) and B / r (viscous damping) come from Table A4 through
:class:`ActuatorParameters` (:mod:`ibvs_youla.model.actuators`, re-exported here).
Pinocchio's CRBA, RNEA and ABA include ``model.armature``; they ignore ``model.damping``,
which is therefore left at zero and the damping torque ``damping * dq`` is added here.

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

import math
import os
import threading
from dataclasses import astuple
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from .._geometry import pose_error_mm_deg
from .._linalg import add_product
from .._validation import as_array, as_pose, non_negative, positive, text
from ..exceptions import InvalidArrayError, InvalidParameterError, ModelLoadError, UnreachablePoseError
from ._resources import check_chain, frame_id, load_urdf_model, urdf_path
from .actuators import ActuatorParameters
from .ik import (
    SphericalWristParameters,
    closed_form_branches,
    numerical_branches,
    select_branches,
)
from .ik_kernels import ik_parameter_array, nearest_branch_compiled, poses_match
from .urdf_checks import check_model

__all__ = ["ABA_CONVENTION", "ActuatorParameters", "Arm"]

# Pinocchio 3 offers the articulated-body algorithm in two conventions, the same dynamics to
# rounding (~1e-14 relative); the WORLD one is about 12 % faster on the IRB 4600 (benchmarks/).
ABA_CONVENTION = pin.Convention.WORLD

_N = 6
_VEC = (_N,)  # shape of a joint vector
_IK_TOL = 1e-9  # max |FK(q) - T| accepted for an IK solution (rotation entries and metres)
_IK_SEEDS = 24  # random seeds of the numerical IK (besides q_near)
_READ_ONLY = ("armature", "damping", "q_min", "q_max", "dq_max", "tau_max", "T_E_C")


def _read_only(x: Any) -> np.ndarray:
    arr = np.array(x, dtype=float)
    arr.setflags(write=False)
    return arr


class _ThreadData(threading.local):
    """One Pinocchio ``Data`` of ``model`` per thread, created on the thread's first access."""

    def __init__(self, model: pin.Model) -> None:
        self.data = model.createData()


class Arm:
    """A 6-DOF serial arm carrying a camera, with the kinematics and dynamics the paper uses.

    Build it with :meth:`irb4600`, :meth:`from_urdf`, or ``Arm(model, camera_frame=...,
    flange_frame=..., armature=..., damping=..., name=...)`` from a Pinocchio model of six
    revolute joints in series (same meaning as in :meth:`from_urdf`). The model is copied,
    never mutated; do not mutate :attr:`model` either (use :meth:`with_inertia_scale` or
    :meth:`with_hand_eye`). Safe to share between threads (one Pinocchio ``Data`` per
    thread); pickles.

    Attributes:
        model: Pinocchio model (``model.armature`` set, ``model.damping`` zero).
        name: Human-readable name.
        nq: Number of joints (6).
        q_min, q_max: Joint position limits (6,) [rad].
        dq_max: Joint speed limits (6,) [rad/s].
        tau_max: Joint torque limits (6,) [N m].
        armature: Joint-side rotor inertia J of Eq. (29) (6,) [kg m^2].
        damping: Joint-side viscous damping B / r of Eq. (29) (6,) [N m s/rad].
        T_E_C: Camera pose in the flange frame (4, 4) (ERRATA 2: Rz(pi) for the IRB 4600).
        ik_parameters: Lengths used by the closed-form IK, or None (numerical IK).
        urdf_path: File the model was loaded from (None if built from a model).

    Raises:
        InvalidParameterError: ``model`` is not a ``pinocchio.Model``, or a frame name or the
            name is not a string.
        ModelLoadError: the model is not six revolute joints in series, or lacks the frames.
    """

    def __init__(
        self,
        model: pin.Model,
        *,
        camera_frame: str = "camera",
        flange_frame: str | None = None,
        armature: Any = None,
        damping: Any = None,
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
        check_chain(model, source)
        check_model(model, source)
        self.model = model.copy()
        self.name = name or model.name
        self.urdf_path = source
        self.nq = _N
        self.camera_frame = camera_frame
        if flange_frame is None:
            flange_frame = "flange" if model.existFrame("flange") else model.names[_N]
        self.flange_frame = flange_frame
        self._camera_id = frame_id(self.model, camera_frame, source, "camera")
        self._flange_id = frame_id(self.model, flange_frame, source, "flange")
        zeros = np.zeros(_N)
        self.armature = _read_only(zeros if armature is None else as_array(armature, "armature", _VEC))
        self.damping = _read_only(zeros if damping is None else as_array(damping, "damping", _VEC))
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
        self.ik_parameters = SphericalWristParameters.identify(self.model, self._flange_id)
        rng = np.random.default_rng(0)
        lo, hi = np.maximum(self.q_min, -math.pi), np.minimum(self.q_max, math.pi)
        self._ik_seeds = lo + (hi - lo) * rng.random((_IK_SEEDS, _N))

    @property
    def ik_parameters(self) -> SphericalWristParameters | None:
        """Lengths used by the closed-form IK, or None (numerical IK)."""
        return self._ik_parameters

    @ik_parameters.setter
    def ik_parameters(self, params: SphericalWristParameters | None) -> None:
        self._ik_parameters = params
        self._ik_array = None if params is None else ik_parameter_array(params)  # for the compiled IK

    # ------------------------------------------------------------------ construction
    @classmethod
    def irb4600(cls, actuator: str = "paper") -> Arm:
        """ABB IRB 4600-45/2.05 with a ZED 2 on the flange (urdf/abb_irb4600_45_205.urdf).

        Args:
            actuator: ``"paper"`` (literal Eq. 29: J = J_a + J_g, damping B_m / r) or
                ``"reflected"`` (r^2 (J_a + J_g), r^2 B_m); see :class:`ActuatorParameters`.
        """
        armature, damping = ActuatorParameters().joint_terms(actuator)
        arm = cls.from_urdf(
            urdf_path("abb_irb4600_45_205.urdf"),
            camera_frame="camera",
            flange_frame="flange",
            armature=np.full(_N, armature),
            damping=np.full(_N, damping),
        )
        documented = SphericalWristParameters.irb4600()
        found = arm.ik_parameters
        if found is None or not np.allclose(astuple(found), astuple(documented), rtol=0.0, atol=1e-9):
            raise ModelLoadError(arm.urdf_path, f"URDF geometry {found} differs from ERRATA 1 {documented}")
        arm.ik_parameters = documented
        arm.name = f"ABB IRB 4600-45/2.05 ({actuator} actuator)"
        return arm

    @classmethod
    def from_urdf(
        cls,
        path: str | Path,
        camera_frame: str = "camera",
        flange_frame: str | None = None,
        armature: Any = None,
        damping: Any = None,
    ) -> Arm:
        """Load any 6-DOF serial arm; IK is closed form if its geometry is IRB 4600-like.

        Args:
            path: URDF file (fixed base; meshes are not loaded).
            camera_frame: Frame (link) of the camera {C}, attached to the last joint.
            flange_frame: Frame of the flange {E}; default ``"flange"`` if present, else
                the last joint's frame.
            armature: Joint-side rotor inertias (6,) [kg m^2]; default zeros.
            damping: Joint-side viscous damping (6,) [N m s/rad]; default zeros.

        Raises:
            ModelLoadError: the file is missing or unparsable, is not a 6-revolute-joint
                serial chain with limits, lacks the frames, or is not physically valid
                (:mod:`ibvs_youla.model.urdf_checks`: masses, inertias, axes, origins,
                limits), naming the link or joint.
        """
        if not isinstance(path, (str, os.PathLike)):
            raise InvalidParameterError("path", path, "a URDF file path (str or pathlib.Path)")
        path = Path(path)
        model = load_urdf_model(path)
        return cls(
            model,
            camera_frame=camera_frame,
            flange_frame=flange_frame,
            armature=armature,
            damping=damping,
            source=path,
        )

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
        return self._with_model(model, f"{self.name} (inertia x{factor:g})")

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
        T_E_C = as_pose(T_E_C, "T_E_C").copy()
        U, _, Vt = np.linalg.svd(T_E_C[:3, :3])
        T_E_C[:3, :3] = U @ Vt
        moved_mm, moved_deg = pose_error_mm_deg(self.T_E_C, T_E_C)
        model = self.model.copy()
        camera = model.frames[self._camera_id]
        camera.placement = model.frames[self._flange_id].placement * pin.SE3(T_E_C)  # both on joint 6
        model.frames[self._camera_id] = camera
        return self._with_model(model, f"{self.name} (T_E_C moved {moved_mm:.3g} mm, {moved_deg:.3g} deg)")

    def _with_model(self, model: pin.Model, name: str) -> Arm:
        """An Arm on ``model`` (a modified copy of :attr:`model`) with this arm's frames, actuators and IK."""
        arm = Arm(
            model,
            camera_frame=self.camera_frame,
            flange_frame=self.flange_frame,
            armature=self.armature,
            damping=self.damping,
            name=name,
            source=self.urdf_path,
        )
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
        ik = "closed-form" if self.ik_parameters is not None else "numerical"
        return f"Arm({self.name!r}, nq={self.nq}, ik={ik})"

    # ------------------------------------------------------------------ kinematics
    def within_limits(self, q: Any, tol: float = 0.0) -> bool:
        """True if ``q_min - tol <= q <= q_max + tol`` for every joint (``tol`` [rad] >= 0)."""
        q = as_array(q, "q", _VEC)
        tol = non_negative(tol, "tol")
        return bool(np.all(q >= self.q_min - tol) and np.all(q <= self.q_max + tol))

    def flange_pose(self, q: Any) -> np.ndarray:
        """T_O_E (4, 4): flange pose in the base frame, Eq. (15) (the paper's T_6^0)."""
        data = self._thread_data.data
        pin.forwardKinematics(self.model, data, as_array(q, "q", _VEC))
        return pin.updateFramePlacement(self.model, data, self._flange_id).homogeneous

    def camera_pose(self, q: Any) -> np.ndarray:
        """T_O_C (4, 4) = T_O_E(q) T_E_C: camera pose in the base frame (Eq. 21 inverted)."""
        return self.camera_fk(as_array(q, "q", _VEC))

    def camera_fk(self, q: np.ndarray) -> np.ndarray:
        """T_O_C (4, 4) at q: the forward kinematics of `camera_pose`, one Pinocchio pass.

        Kernel: does not validate ``q``, which must be a finite float64 (6,) array [rad] (a
        plant's own state, an IK solution).
        """
        data = self._thread_data.data
        pin.forwardKinematics(self.model, data, q)
        return pin.updateFramePlacement(self.model, data, self._camera_id).homogeneous

    def camera_jacobian(self, q: Any) -> np.ndarray:
        """J_C (6, 6): LOCAL frame Jacobian of the camera, maps dq to the camera twist [v; w] in {C}.

        With the stereo interaction matrix L(P_C), ``L @ J_C`` is the 9x6 image Jacobian
        of Eq. (51). Rank 5 at the wrist singularity q5 = 0 (ERRATA 7).
        """
        return self.camera_pose_and_jacobian(as_array(q, "q", _VEC))[1]

    def camera_pose_and_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(T_O_C, J_C) at q from one kinematics pass: `camera_pose` and `camera_jacobian` together.

        Kernel: does not validate ``q``, which must be a finite float64 (6,) array [rad].
        """
        model, data = self.model, self._thread_data.data
        pin.computeJointJacobians(model, data, q)
        J_C = pin.getFrameJacobian(model, data, self._camera_id, pin.LOCAL)
        return pin.updateFramePlacement(model, data, self._camera_id).homogeneous, J_C

    def camera_jacobian_at(self, q: np.ndarray) -> np.ndarray:
        """J_C (6, 6) at q, LOCAL, from Pinocchio's ``computeFrameJacobian`` alone (no pose).

        Kernel for the actuation at every joint tick (``TwistToJointVelocity``): does not validate
        ``q``, which must be a finite float64 (6,) array [rad]. The same Jacobian as
        :meth:`camera_jacobian` to rounding (~1e-15), in half its time.
        """
        return pin.computeFrameJacobian(self.model, self._thread_data.data, q, self._camera_id, pin.LOCAL)

    # ------------------------------------------------------------------ dynamics
    def mass_matrix(self, q: Any) -> np.ndarray:
        """M(q) = D(q) + J (6, 6), Eq. (31): CRBA with the armature, both triangles filled."""
        M = pin.crba(self.model, self._thread_data.data, as_array(q, "q", _VEC))
        return np.triu(M) + np.triu(M, 1).T

    def nonlinear_effects(self, q: Any, dq: Any) -> np.ndarray:
        """h(q, dq) = C(q, dq) dq + g(q) + (B / r) dq (6,) [N m], Eq. (32)."""
        dq = as_array(dq, "dq", _VEC)
        h = pin.nonLinearEffects(self.model, self._thread_data.data, as_array(q, "q", _VEC), dq)
        return h + self.damping * dq

    def gravity(self, q: Any) -> np.ndarray:
        """g(q) (6,) [N m], the gravity torques of Eq. (29)."""
        q = as_array(q, "q", _VEC)
        return pin.computeGeneralizedGravity(self.model, self._thread_data.data, q).copy()

    def forward_dynamics(self, q: Any, dq: Any, tau: Any) -> np.ndarray:
        """Joint accelerations ddq (6,) [rad/s^2] solving Eq. (30) M(q) ddq + h(q, dq) = tau (see `aba`)."""
        q, dq, tau = as_array(q, "q", _VEC), as_array(dq, "dq", _VEC), as_array(tau, "tau", _VEC)
        return self.aba(q, dq, tau).copy()

    def aba(self, q: np.ndarray, dq: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Joint accelerations ddq of Eq. (30) by the articulated-body algorithm, armature included.

        Pinocchio's ABA (:data:`ABA_CONVENTION`) on ``tau - damping * dq``. Kernel of
        `forward_dynamics`: does not validate its arguments, which must be finite float64 (6,)
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
        """Joint torques tau = M(q) ddq + h(q, dq) (6,) [N m], Eq. (30) (see `rnea`)."""
        return self.rnea(as_array(q, "q", _VEC), as_array(dq, "dq", _VEC), as_array(ddq, "ddq", _VEC))

    def rnea(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        """Joint torques tau = M(q) ddq + h(q, dq) of Eq. (30) in one recursive Newton-Euler pass.

        The armature is in the model; the damping torque ``damping * dq`` is added. Kernel of
        `inverse_dynamics` (and of Eq. (33), tau = M(q) v + h(q, dq)): does not validate its
        arguments, which must be finite float64 (6,) arrays (q [rad], dq [rad/s], ddq [rad/s^2]).
        """
        tau = pin.rnea(self.model, self._thread_data.data, q, dq, ddq)  # a new array
        add_product(tau, self.damping, dq)  # + damping * dq, in one compiled call
        return tau  # type: ignore[no-any-return]

    def kinetic_energy(self, q: Any, dq: Any) -> float:
        """0.5 dq^T M(q) dq [J], rotor (armature) energy included."""
        dq = as_array(dq, "dq", _VEC)
        return 0.5 * float(dq @ self.mass_matrix(q) @ dq)

    def potential_energy(self, q: Any) -> float:
        """Gravitational potential energy of the links and camera [J] (zero at base height)."""
        return float(pin.computePotentialEnergy(self.model, self._thread_data.data, as_array(q, "q", _VEC)))

    # ------------------------------------------------------------------ inverse kinematics
    def ik(self, T_O_C: Any, q_near: Any = None) -> np.ndarray:
        """Every joint configuration within limits that puts the camera at ``T_O_C``, Eq. (28).

        Closed form (:mod:`ibvs_youla.model.ik`, up to 8 branches: shoulder front/back,
        elbow up/down, wrist flip) when :attr:`ik_parameters` is set, else damped
        Gauss-Newton from ``q_near`` and 24 fixed seeded starts. Each joint comes back as
        the 2*pi-equivalent within limits nearest ``q_near`` (for the IRB 4600 this matters
        for axes 4 and 6, +-400 deg; without ``q_near`` they lie in (-pi, pi]). At a wrist
        singularity (q5 = 0) q4 = q_near[3] (or 0) and q6 carries the rotation. Every row
        satisfies max|FK(q) - T_O_C| <= 1e-9.

        Args:
            T_O_C: Camera pose in the base frame (4, 4), rigid within 1e-6 (projected
                onto SO(3) before solving).
            q_near: Reference configuration (6,) [rad]; default zeros.

        Returns:
            (k, 6) [rad], sorted by Euclidean distance to ``q_near`` (nearest first).

        Raises:
            InvalidArrayError: non-finite or non-rigid pose, bad ``q_near``.
            UnreachablePoseError: no solution within the joint limits.
        """
        T_O_C = as_pose(T_O_C, "T_O_C").copy()
        U, _, Vt = np.linalg.svd(T_O_C[:3, :3])
        T_O_C[:3, :3] = U @ Vt
        ref = np.zeros(_N) if q_near is None else as_array(q_near, "q_near", _VEC)
        if self.ik_parameters is not None:
            raw = closed_form_branches(self.ik_parameters, T_O_C @ self._T_C_E, ref)
        else:
            seeds = self._ik_seeds if q_near is None else np.vstack([ref, self._ik_seeds])
            raw = numerical_branches(self.model, self._thread_data.data, self._camera_id, T_O_C, seeds)
        solutions = select_branches(raw, self.q_min, self.q_max, ref)
        solutions = solutions[[np.abs(self.camera_fk(q) - T_O_C).max() <= _IK_TOL for q in solutions]]
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

    def ik_nearest(self, T_O_C: np.ndarray, q_near: np.ndarray) -> np.ndarray:
        """``ik(T_O_C, q_near)[0]``, computed without building every branch (Eq. (62) at every frame).

        Kernel: does not validate its arguments. ``T_O_C`` must be a rigid (4, 4) float pose
        (e.g. from stereo P3P, orthonormal to rounding, so the projection onto SO(3) of :meth:`ik`
        is skipped) and ``q_near`` a finite float (6,) array [rad]. With the closed form, the
        nearest in-limit branch (:func:`~ibvs_youla.model.ik.nearest_branch`, compiled:
        :mod:`~ibvs_youla.model.ik_kernels`) is returned if it passes the pose check of :meth:`ik`;
        any other case (no closed form, nearest branch rejected, no branch) is delegated to
        :meth:`ik`, which also raises its errors.
        """
        return self.ik_nearest_kinematics(T_O_C, q_near)[0]

    def ik_nearest_kinematics(
        self, T_O_C: np.ndarray, q_near: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, T_O_C(q), J_C(q)): :meth:`ik_nearest`, and :meth:`camera_pose_and_jacobian` at q.

        Both from the one kinematics pass that checks the IK branch (the kinematics computed once
        per configuration).

        Kernel: arguments as :meth:`ik_nearest`.
        """
        if self._ik_array is not None:
            found, q = nearest_branch_compiled(
                self._ik_array, T_O_C, self._T_C_E, self.q_min, self.q_max, q_near, 1e-9
            )
            if found:
                T_q, J_C = self.camera_pose_and_jacobian(q)
                if poses_match(T_q, T_O_C, _IK_TOL):  # max |FK(q) - T_O_C| <= 1e-9, as ik checks
                    return q, T_q, J_C
        q = self.ik(T_O_C, q_near=q_near)[0]
        return (q, *self.camera_pose_and_jacobian(q))
