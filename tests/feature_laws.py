"""Shared set-up of the tests of the polar, partitioned and moment laws (free camera, textbook cases).

The free camera at 25 Hz (the twist held over T = 0.04 s, integrated with the SE(3) exponential)
and the normalized monocular camera, as ViSP's tutorial-ibvs-4pts and tests/test_ibvs.py.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation

import ibvs_youla as iy

SQUARE_O = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]
# Seven coplanar points without symmetry (ViSP's servoMomentPoints set, its repeated point dropped,
# scaled by 1/20 and centred): the moment features need an image that is not symmetric.
IRREGULAR_O = np.array([[1, 0], [3, 1], [4, 4], [-1, 4], [-3, -2], [-2, -2], [-1, 1]]) / 20.0
IRREGULAR_O = np.column_stack((IRREGULAR_O - IRREGULAR_O.mean(axis=0), np.zeros(7)))
SETTINGS = iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0)
LAMBDA, T = 0.5, 0.04  # default gain [1/s], control period [s]
Z_TARGET = 0.75  # [m]


def T_O_C(t, theta_u_deg):
    """Camera pose from the object pose in the camera (ViSP's cMo: translation, theta-u [deg])."""
    cMo = np.eye(4)
    cMo[:3, :3] = Rotation.from_rotvec(np.radians(theta_u_deg)).as_matrix()
    cMo[:3, 3] = t
    return np.linalg.inv(cMo)


TARGET = T_O_C([0, 0, Z_TARGET], [0, 0, 0])  # facing the points' plane from 0.75 m
TUTORIAL_START = T_O_C([0.15, -0.1, 1.0], [10, -10, 50])  # ViSP's tutorial-ibvs-4pts
TILT_TARGET = T_O_C([0, 0, 0.75], [45, 0, 0])  # the local minimum of ibvs-current (tests/test_ibvs.py)
TILT_START = T_O_C([0.02, 0.01, 0.75], [-45, 3, 2])


def P_C_of(T_O_C_, P_O):
    """The points in the camera frame: P_C = R^T (P_O - t)."""
    return (P_O - T_O_C_[:3, 3]) @ T_O_C_[:3, :3]


def run(controller, start, target=TARGET, duration=30.0, markers_O=SQUARE_O):
    """A free-camera run with the normalized camera; ``controller`` a name or a controller object."""
    if isinstance(controller, str):
        controller = iy.controllers.make(controller)
    scenario = iy.Scenario.free_camera(T_O_C_start=start, T_O_C_target=target, markers_O=markers_O)
    return iy.simulate(
        scenario,
        controller=controller,
        plant="free-camera",
        camera=iy.PinholeCamera.normalized(),
        duration=duration,
        settings=SETTINGS,
    )


def twist_differences(features_of, P_C, h=1e-6, difference=np.subtract):
    """Central differences (m, 6) of ``features_of(P_C)`` under a camera twist [v; w] in {C}.

    The camera moved by exp(h e_k) sees the points at exp(h e_k)^-1 P_C. ``difference(a, b)`` is
    a - b, or wraps angle rows.
    """
    columns = []
    for k in range(6):
        values = []
        for sign in (1.0, -1.0):
            xi = np.zeros(6)
            xi[k] = sign * h
            M_inv = np.linalg.inv(pin.exp6(pin.Motion(xi)).homogeneous)
            values.append(features_of(P_C @ M_inv[:3, :3].T + M_inv[:3, 3]))
        columns.append(difference(values[0], values[1]) / (2.0 * h))
    return np.column_stack(columns)


def rotation_angle_deg(R):
    """Angle of a rotation matrix [deg], accurate near 0 and pi."""
    return float(np.degrees(np.linalg.norm(Rotation.from_matrix(R).as_rotvec())))
