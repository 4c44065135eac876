"""Eye-to-hand: a camera fixed in the cell watching markers on the arm, as eye-in-hand seen from the markers.

With the camera fixed at T_O_C in the base frame and the markers fixed in a frame E of the arm's
last link (the carrier, default the flange), the markers' coordinates P_E are constant and the
camera's pose in E moves with the joints:

    T_E_C(q) = T_O_E(q)^-1 T_O_C.

So the sensor sees exactly what an eye-in-hand camera at T_E_C(q) would see of markers fixed at
P_E: P_C = T_E_C(q)^-1 P_E. Its rate: with V_E = J_E(q) dq the carrier's twist in E (Pinocchio's
LOCAL frame Jacobian), d/dt T_E_O = -[V_E]^ T_E_O, hence T_E_C^-1 dT_E_C/dt = -[Ad(T_C_E) V_E]^
and the camera's twist relative to the markers, expressed in {C}, is

    V_rel = J_rel(q) dq,   J_rel(q) = -Ad(T_C_E(q)) J_E(q)      (6 x n),

where Ad(T_C_E) = [[R_C_E, [p_C_E]x R_C_E], [0, R_C_E]] maps a twist [v; w] from E to C. This is
ViSP's eye-to-hand task Jacobian: with L the interaction matrix, ``vpServo::EYETOHAND_L_cVe_eJe``
uses ``-L cVe eJe`` (``signInteractionMatrix = -1``), cVe = Ad(T_C_E) built from cMe, and eJe = J_E;
here L J_rel is that product. docs/eye-to-hand.md derives it and says what the paper's equations
become.

:class:`EyeToHandArm` is an :class:`~ibvs_youla.model.arm.Arm` whose camera methods give these
relative quantities: :meth:`~EyeToHandArm.camera_pose` is T_E_C(q), the camera Jacobians are
J_rel, and :meth:`~EyeToHandArm.ik` solves for the joints that put the camera at a given T_E_C,
the inverse kinematics of the carrier at T_O_E = T_O_C T_E_C^-1 (Eq. (62) applied to the tool).
Everything that servos an eye-in-hand camera (the sensor, every twist law through J^+, the pose
estimators, the paper's Eq. (62)) then servos the fixed camera's view of the tool, unchanged, with
"the base frame {O}" of its markers and poses read as the carrier frame {E}. Dynamics, limits and
identity are the arm's own.

The kinematics come from the arm's own camera frame H (its eye-in-hand mount, on the same link
as E, so T_E_H is constant): T_E_C(q) = T_E_H T_O_H(q)^-1 T_O_C and J_rel = -Ad(T_C_H(q)) J_H(q),
T_C_H = T_O_C^-1 T_O_H, from one pass of the arm's kinematics, its closed-form or numerical IK
(:attr:`~ibvs_youla.model.arm.Arm.ik_method`) included.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pinocchio as pin

from .._validation import as_array, as_pose, instance
from ..exceptions import InvalidParameterError, UnreachablePoseError
from .arm import Arm
from .mount import Mount

__all__ = ["EyeToHandArm", "mounted"]


class EyeToHandArm(Arm):
    """An arm carrying the markers, watched by a camera fixed in the base frame (module docstring).

    Its camera methods are relative to the marker carrier E: :meth:`camera_pose` is
    T_E_C(q) = T_O_E(q)^-1 T_O_C, :meth:`camera_jacobian` is J_rel = -Ad(T_C_E) J_E (the camera's
    twist relative to the markers, in {C}), :meth:`ik` inverts :meth:`camera_pose`. Dynamics,
    limits, :meth:`flange_pose` and :meth:`identity` are the arm's.

    Args:
        arm: The arm (eye-in-hand, as built: :meth:`Arm.from_robot`, :meth:`Arm.from_urdf`).
        mount: An eye-to-hand :class:`~ibvs_youla.model.mount.Mount`.

    Attributes:
        arm: The arm itself, with its own (eye-in-hand) camera.
        carrier_frame: The frame that carries the markers (``mount.carrier_frame``, or the
            arm's flange frame).
        T_O_C: The fixed camera's pose in the base frame (4, 4).

    Raises:
        InvalidParameterError: ``arm`` is not an eye-in-hand Arm, the mount is not eye-to-hand,
            or its carrier frame is not a frame of the arm's last link (the message lists them).
    """

    def __init__(self, arm: Arm, mount: Mount) -> None:
        instance(arm, "arm", Arm, "an Arm")
        if isinstance(arm, EyeToHandArm):
            raise InvalidParameterError(
                "arm", repr(arm), "an eye-in-hand Arm (this one has a mount already: use its .arm)"
            )
        instance(mount, "mount", Mount, "a Mount")
        if not mount.is_eye_to_hand:
            raise InvalidParameterError(
                "mount", mount.kind, "an eye-to-hand mount (Mount.eye_to_hand(T_O_C))"
            )
        self.__setstate__(arm.__getstate__())  # the arm's model, limits, dynamics and IK
        self.arm = arm
        self._mount = mount
        self.carrier_frame = arm.flange_frame if mount.carrier_frame is None else mount.carrier_frame
        try:
            T_H_E = arm.frame_in_camera(self.carrier_frame)
        except InvalidParameterError as err:
            raise InvalidParameterError("mount.carrier_frame", self.carrier_frame, err.valid) from None
        self.T_O_C = mount.camera_pose
        self.T_O_C.setflags(write=False)
        self._hMe = pin.SE3(T_H_E)  # the carrier in the arm's camera frame H (both on the last link)
        self._eMh = self._hMe.inverse()
        self._oMc = pin.SE3(self.T_O_C)
        self._cMo = self._oMc.inverse()
        self.name = f"{arm.name} (eye-to-hand)"

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Unpickle as :meth:`Arm.__setstate__`, the camera pose read-only again."""
        super().__setstate__(state)
        if "T_O_C" in state:  # not yet while __init__ copies the arm's state
            self.T_O_C.setflags(write=False)

    @property
    def mount(self) -> Mount:
        """The eye-to-hand mount: the fixed camera's pose and the markers' carrier frame."""
        return self._mount

    @property
    def hand_eye(self) -> np.ndarray:
        """X of the eye-to-hand calibration AX = XB: the fixed camera's pose in the base frame, T_O_C."""
        return self.T_O_C

    def __repr__(self) -> str:
        return f"EyeToHandArm({self.arm.name!r}, nq={self.nq}, carrier={self.carrier_frame!r})"

    # ------------------------------------------------------------------ relative kinematics
    def _relative(self, T_O_H: np.ndarray, J_H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(T_E_C, J_rel) from the arm's camera frame H: T_E_H T_O_H^-1 T_O_C and -Ad(T_C_H) J_H."""
        cMh = self._cMo * pin.SE3(T_O_H)
        return (self._eMh * cMh.inverse()).homogeneous, -(cMh.action @ J_H)

    def camera_fk(self, q: np.ndarray) -> np.ndarray:
        """T_E_C (4, 4) at q: the fixed camera in the carrier frame, T_O_E(q)^-1 T_O_C.

        Kernel: does not validate ``q``, which must be a finite float64 (n,) array.
        """
        return (
            self._eMh * (self._cMo * pin.SE3(self.arm.camera_fk(q))).inverse()
        ).homogeneous  # as _relative

    def camera_pose_and_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(T_E_C, J_rel) at q from one kinematics pass (module docstring). Kernel: ``q`` unchecked."""
        return self._relative(*self.arm.camera_pose_and_jacobian(q))

    def camera_jacobian_at(self, q: np.ndarray) -> np.ndarray:
        """J_rel (6, n) at q: the camera's twist relative to the markers, in {C}. Kernel: ``q`` unchecked."""
        return self.camera_pose_and_jacobian(q)[1]

    def _arm_camera_pose(self, T_E_C: np.ndarray) -> np.ndarray:
        """T_O_H: the arm's camera frame when the fixed camera sits at T_E_C in the carrier frame."""
        return (self._oMc * pin.SE3(T_E_C).inverse() * self._eMh).homogeneous

    def ik(self, T_O_C: Any, q_near: Any = None) -> np.ndarray:
        """Joint configurations within limits that put the fixed camera at T_E_C in the carrier frame.

        The inverse kinematics of the carrier at T_O_E = T_O_C T_E_C^-1 (Eq. (62) applied to the
        tool), by the arm's method (:attr:`ik_method`); rows sorted by distance to ``q_near``
        (:meth:`Arm.ik`). The argument keeps its eye-in-hand name: it is the camera's pose in the
        markers' frame, here {E}.

        Args:
            T_O_C: T_E_C (4, 4), the fixed camera's pose in the carrier frame, rigid within 1e-6.
            q_near: Reference configuration (n,) [rad or m]; default zeros.

        Raises:
            InvalidArrayError: non-finite or non-rigid pose, bad ``q_near``.
            UnreachablePoseError: no configuration within the limits puts the carrier there.
        """
        T_E_C = as_pose(T_O_C, "T_E_C")
        q_near = None if q_near is None else as_array(q_near, "q_near", (self.nq,))
        try:
            return self.arm.ik(self._arm_camera_pose(T_E_C), q_near)
        except UnreachablePoseError as err:
            raise UnreachablePoseError(
                T_E_C, f"eye-to-hand, the carrier {self.carrier_frame!r} for the camera at T_E_C: {err}"
            ) from None

    def ik_nearest_kinematics(
        self, T_O_C: np.ndarray, q_near: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, T_E_C(q), J_rel(q)): the IK solution nearest ``q_near`` and the kinematics there.

        Kernel: ``T_O_C`` (here T_E_C, rigid) and ``q_near`` unchecked, as :meth:`Arm.ik_nearest`.
        """
        try:
            q, T_O_H, J_H = self.arm.ik_nearest_kinematics(self._arm_camera_pose(T_O_C), q_near)
        except UnreachablePoseError as err:
            raise UnreachablePoseError(
                T_O_C, f"eye-to-hand, the carrier {self.carrier_frame!r} for the camera at T_E_C: {err}"
            ) from None
        return (q, *self._relative(T_O_H, J_H))

    # ------------------------------------------------------------------ derived arms
    def with_inertia_scale(self, factor: float) -> EyeToHandArm:
        """The same mount on the arm with scaled link masses and inertias (:meth:`Arm.with_inertia_scale`)."""
        return EyeToHandArm(self.arm.with_inertia_scale(factor), self._mount)

    def with_camera_pose(self, T_O_C: Any) -> EyeToHandArm:
        """The same arm and carrier with the fixed camera at ``T_O_C`` (4, 4): a belief of the calibration."""
        return EyeToHandArm(self.arm, dataclasses.replace(self._mount, T_O_C=as_pose(T_O_C, "T_O_C")))

    def with_hand_eye(self, T_E_C: Any) -> Arm:
        """Refused: the eye-to-hand calibration is the camera pose in the base (:meth:`with_camera_pose`).

        Raises:
            InvalidParameterError: always.
        """
        raise InvalidParameterError(
            "T_E_C",
            "a camera pose in the flange frame",
            "with_camera_pose(T_O_C) on an eye-to-hand arm: its camera is fixed in the base frame",
        )


def mounted(arm: Arm, mount: Mount | None) -> Arm:
    """``arm`` with ``mount``: the arm itself eye-in-hand (or None), an :class:`EyeToHandArm` eye-to-hand.

    An arm that has ``mount`` already is returned as it is.

    Raises:
        InvalidParameterError: an eye-to-hand arm given another mount than its own.
    """
    mount = Mount() if mount is None else mount
    if arm.mount == mount:
        return arm
    if isinstance(arm, EyeToHandArm):
        raise InvalidParameterError(
            "arm",
            f"{arm!r} with {arm.mount.to_dict()}",
            f"an arm without a mount, or with the scenario's: {mount.to_dict()}",
        )
    return EyeToHandArm(arm, mount) if mount.is_eye_to_hand else arm
