"""Each disturbance acts on the closed loop as the theory of that loop says.

* pixel noise: classical IBVS with L* on the free camera is the linear loop e_{k+1} = e_k -
  a P (e_k + n_k) (a = lambda T, P the projection onto the range of L, rank 6 of 8), whose
  stationary mean square is E||e||^2 = 6 a sigma^2 / (2 - a); the simulated floor matches it,
  the loop stays stable from 0.1 to 3 px, and the camera's RMS position error grows as
  sigma^1.00;
* latency: d frames of delay give e_{k+1} = e_k - a e_{k-d}; python-control's closed-loop
  poles put the largest stable a at 2 sin(pi / (2 (2 d + 1))), and the simulated IBVS loop
  switches from stable to unstable within +-3 % of it;
* saturation: the plant's joint speeds stay at the (scaled) limits the paper's 1 ms
  feedforward otherwise exceeds 13-fold;
* calibration: PBVS converges where first-order geometry puts the believed target (marker
  offset, marker scale, focal length, principal point), IBVS converges to the taught pose
  whatever the beliefs, and a pose-regulating look-then-move law ends displaced by the hand-eye
  error;
* model mismatch: inertias x2 and friction in the plant raise the inner loop's tracking error
  (the inner loop has no integral action) but the image loop still takes the camera in.
"""

from __future__ import annotations

import control
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import ibvs_youla as iy
from ibvs_youla.controllers import CommandType, Controller
from ibvs_youla.simulation.disturbances import Disturbances, hand_eye_error
from ibvs_youla.simulation.sensor import MarkerSensor

SQUARE = np.array([[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]])  # [m]
T_FRAME = 0.04  # [s], 25 Hz
FREE = iy.SimulationSettings(joint_rate_hz=25.0, camera_rate_hz=25.0)
FOCAL_PX = 800.0  # Disturbances.normalized_focal_px, the default


def _pose(t, rotvec_deg=(0.0, 0.0, 0.0)):
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(np.radians(rotvec_deg)).as_matrix()
    T[:3, 3] = t
    return T


TARGET = _pose([0.0, 0.0, -0.75])  # face-on, 0.75 m from the square: every marker at Z = 0.75 m


def _free(start, controller, frames, disturbances=None):
    return iy.simulate(
        iy.Scenario.free_camera(T_O_C_start=start, T_O_C_target=TARGET, markers_O=SQUARE),
        controller,
        plant="free-camera",
        camera=iy.PinholeCamera.normalized(),
        duration=frames * T_FRAME,
        settings=FREE,
        disturbances=disturbances,
    )


def _position_error(result):
    return np.linalg.norm(result.camera_pose[:, :3, 3] - TARGET[:3, 3], axis=1)  # [m]


# ---------------------------------------------------------------------- pixel noise
def test_the_noise_floor_is_the_linear_loops_and_scales_as_sigma():
    lam = 5.0  # [1/s]: a = lam T = 0.2, a correlation time of a few frames
    a = lam * T_FRAME
    sensor = MarkerSensor(iy.PinholeCamera.normalized(), SQUARE)
    s_star = sensor.features_at(TARGET)
    sigmas = np.array([0.1, 0.3, 1.0, 3.0])  # [px]
    ratios, rms = [], []
    for sigma in sigmas:
        result = _free(
            TARGET,
            iy.controllers.make("ibvs-desired", gain=lam),
            2000,
            Disturbances(pixel_noise_px=sigma, seed=1),
        )
        assert result.status == "complete"
        settled = result.camera_pose[200:]
        e_true = np.array([sensor.features_at(T) - s_star for T in settled])  # what the camera really sees
        predicted = 6.0 * a / (2.0 - a) * (sigma / FOCAL_PX) ** 2
        ratios.append(np.mean(np.sum(e_true**2, axis=1)) / predicted)
        position = _position_error(result)[200:]
        rms.append(np.sqrt(np.mean(position**2)))
        assert position.max() < 5.0 * rms[-1]  # stable: no drift, no growth over 80 s
    # measured 1.003, 1.004, 1.011, 1.054 (3 px: second-order terms of the projection)
    np.testing.assert_allclose(ratios, 1.0, atol=0.08)
    exponent = np.polyfit(np.log(sigmas), np.log(rms), 1)[0]
    assert exponent == pytest.approx(1.0, abs=0.03)  # measured 1.000
    assert rms[2] == pytest.approx(0.0130, rel=0.05)  # 1 px at 0.75 m: 13.0 mm RMS with a = 0.2


def test_ibvs_with_the_current_matrix_has_the_same_floor_at_small_noise():
    """L evaluated at the noisy features and PnP depths: within 6 % of the linear floor at 0.3 px."""
    lam, sigma = 5.0, 0.3
    a = lam * T_FRAME
    sensor = MarkerSensor(iy.PinholeCamera.normalized(), SQUARE)
    s_star = sensor.features_at(TARGET)
    result = _free(
        TARGET,
        iy.controllers.make("ibvs-current", gain=lam),
        2000,
        Disturbances(pixel_noise_px=sigma, seed=1),
    )
    e_true = np.array([sensor.features_at(T) - s_star for T in result.camera_pose[200:]])
    ratio = np.mean(np.sum(e_true**2, axis=1)) / (6.0 * a / (2.0 - a) * (sigma / FOCAL_PX) ** 2)
    assert ratio == pytest.approx(1.0, abs=0.06)  # measured 1.04 (1.33 at 1 px, 2.8 at 3 px)


# ---------------------------------------------------------------------- latency
def _critical_gain(d: int) -> float:
    """Largest a for which a / (z^d (z - 1)) in unit feedback is stable (python-control's poles)."""
    loop = control.tf([1.0], np.convolve([1.0, -1.0], [1.0] + [0.0] * d), dt=T_FRAME)
    low, high = 0.0, 4.0
    for _ in range(50):
        k = 0.5 * (low + high)
        if np.abs(control.feedback(k * loop, 1).poles()).max() < 1.0:
            low = k
        else:
            high = k
    return low


@pytest.mark.parametrize("d", [0, 1, 2, 3])
def test_latency_lowers_the_largest_stable_gain_as_the_discrete_loop_says(d):
    a_c = _critical_gain(d)
    assert a_c == pytest.approx(2.0 * np.sin(np.pi / (2 * (2 * d + 1))), rel=1e-9)  # 2, 1, 0.618, 0.445
    start = _pose([0.001, -0.0005, -0.7505])  # 1.2 mm off: the linear regime
    delay = Disturbances(latency_frames=d) if d else None
    for factor, stable in ((0.97, True), (1.03, False)):
        gain = factor * a_c / T_FRAME  # lambda [1/s]
        result = _free(start, iy.controllers.make("ibvs-current", gain=gain), 600, delay)
        error = _position_error(result)
        converged = result.status == "complete" and error[-100:].max() < error[0]
        assert converged == stable, (d, factor)


# ---------------------------------------------------------------------- saturation
def test_saturation_caps_the_joint_speeds_at_the_scaled_limits(arm):
    scenario = iy.scenarios.get("physical-2")
    dq_max = np.asarray(arm.dq_max)
    free = iy.simulate(scenario, "ff+fb", duration=0.3, arm=arm)
    assert np.abs(free.dq / dq_max).max() > 10.0  # the paper's 1 ms feedforward: 13.2 x the limit
    for scale in (1.0, 0.5):
        capped = iy.simulate(
            scenario, "ff+fb", duration=0.3, arm=arm, disturbances=Disturbances(limit_scale=scale)
        )
        ratio = np.abs(capped.dq / dq_max).max(axis=0)
        assert ratio.max() <= scale * (1 + 1e-12)
        assert np.isclose(ratio, scale, rtol=1e-12).any()  # a joint rides its limit


# ---------------------------------------------------------------------- calibration
START = _pose([0.05, -0.03, -0.9], [5.0, -5.0, 20.0])


def _converged(controller, disturbances):
    result = _free(START, iy.controllers.make(controller, gain=2.0), 500, disturbances)
    assert result.status == "complete"
    return result.camera_pose[-1]


def test_pbvs_converges_where_first_order_geometry_puts_the_believed_target():
    centre = SQUARE.mean(axis=0)
    t_star = TARGET[:3, 3]
    offset = np.array([0.005, -0.003, 0.002])  # [m]
    cases = {  # disturbance -> where the camera should end [m]
        Disturbances(marker_offset_m=tuple(offset)): t_star - offset,
        Disturbances(marker_scale=1.02): centre + (t_star - centre) / 1.02,
        Disturbances(focal_length_scale=1.05): t_star * np.array([1.0, 1.0, 1.0 / 1.05]),  # Z* / s_F
    }
    for disturbances, expected in cases.items():
        T = _converged("pbvs", disturbances)
        assert np.linalg.norm(T[:3, 3] - expected) < 1e-5, disturbances.describe()  # 10 um
    # a principal point du px off: the face-on square's image shifts by du/f, a lateral move of Z* du/f
    T = _converged("pbvs", Disturbances(principal_point_offset_px=(4.0, 0.0)))
    assert np.linalg.norm(T[:3, 3] - t_star) == pytest.approx(0.75 * 4.0 / FOCAL_PX, rel=1e-3)  # 3.75 mm


def test_ibvs_converges_to_the_taught_pose_whatever_the_beliefs():
    wrong = Disturbances(
        marker_offset_m=(0.005, -0.003, 0.002),
        marker_scale=1.02,
        focal_length_scale=1.05,
        principal_point_offset_px=(4.0, -3.0),
    )
    T = _converged("ibvs-current", wrong)
    assert np.linalg.norm(T[:3, 3] - TARGET[:3, 3]) < 1e-8


class _LookThenMove(Controller):
    """A pose-regulating law: q_goal = IK(T_O_C_target) with the controller's own arm, then go there."""

    command_type = CommandType.JOINT_POSITION
    name = "look-then-move"

    def reset(self, task):
        super().reset(task)
        self.q_goal = task.arm.ik(task.T_O_C_target, task.q_target)[0]  # the branch nearest q*

    def command(self, reading):
        return self.q_goal


def test_a_hand_eye_error_displaces_a_pose_regulated_camera_by_itself(arm):
    scenario = iy.scenarios.get("physical-1")
    translation, rotation = (0.005, -0.003, 0.004), (0.5, -0.5, 1.0)  # [m], [deg] in {C}
    wrong = Disturbances(hand_eye_translation_m=translation, hand_eye_rotation_deg=rotation)
    result = iy.simulate(
        scenario, _LookThenMove(), duration=0.5, plant="kinematic", arm=arm, disturbances=wrong
    )
    # the believed camera reaches T*, so the true one sits at T* T_err^-1: moved by the error itself
    expected = result.camera_pose_target @ np.linalg.inv(hand_eye_error(translation, rotation))
    np.testing.assert_allclose(result.camera_pose[-1], expected, atol=1e-9)
    # image-goal laws on the same arm and beliefs end at the taught pose (the error changes J only)
    for name in ("ibvs-current", "pbvs"):
        servo = iy.simulate(
            scenario,
            iy.controllers.make(name, gain=2.0),
            duration=8.0,
            plant="kinematic",
            arm=arm,
            disturbances=wrong,
        )
        # [mm]: measured 3.2e-5 (ibvs-current) and 8.9e-6 (pbvs) with the error, 3.2e-5 and 9.3e-6
        # without: the residual of the gain-2 exponential after 8 s, which the error does not raise;
        # 1e-4 mm is 3x the larger (1e-3 mm, 30x, would let a 30-fold offset pass)
        assert servo.final_pose_error()[0] < 1e-4


# ---------------------------------------------------------------------- model mismatch
@pytest.mark.parametrize(
    ("kind", "tracking"),
    # [deg], measured: 0.1066 with inertias x2, 0.0604 with friction; 0.0079 nominal
    [("inertia", 0.1066), ("friction", 0.0604)],
)
def test_mismatch_raises_the_inner_tracking_error_but_the_image_loop_still_converges(arm, kind, tracking):
    """Each half of level 1 of the robustness study's "mismatch" axis alone, against the nominal run.

    Inertias x2, or friction alone (Coulomb 2 % of each torque limit, viscous 2 % of it at the
    speed limit): the feedback linearization (Eq. (33)) knows neither, and the inner loop has no
    integral action against them.
    """
    scenario = iy.scenarios.get("physical-2")
    tau_max, dq_max = np.asarray(arm.tau_max), np.asarray(arm.dq_max)
    mismatch = {
        "inertia": Disturbances(plant_inertia_scale=2.0),
        "friction": Disturbances(
            viscous_friction=tuple(0.02 * tau_max / dq_max),  # 2 % of the torque limit at full speed
            coulomb_friction=tuple(0.02 * tau_max),  # 2 % of the torque limit
        ),
    }[kind]
    nominal = iy.simulate(scenario, "fb", duration=3.0, arm=arm)
    mismatched = iy.simulate(scenario, "fb", duration=3.0, arm=arm, disturbances=mismatch)
    late = nominal.t > 1.0

    def tracking_deg(r):
        return np.degrees(np.abs(r.q_ref - r.q)[late].max())

    # Both runs are deterministic: the mismatched value is pinned to 1 % (room for another BLAS's
    # summation order, not for another friction law)
    assert tracking_deg(nominal) < 0.01
    assert tracking_deg(mismatched) == pytest.approx(tracking, rel=0.01)
    assert np.degrees(np.abs(mismatched.q_true - nominal.q_true).max()) > 0.01  # another response
    # the image loop takes the camera in at the same pace: pose error at 3 s within 5 % of nominal
    # (measured 29.89 mm nominal, 30.70 mm with inertias x2, 29.90 mm with friction)
    assert mismatched.final_pose_error()[0] == pytest.approx(nominal.final_pose_error()[0], rel=0.05)
