"""Write ``abb_irb4600_45_205.urdf`` from the documented parameters below.

Run ``python urdf/make_irb4600_urdf.py`` to regenerate the URDF next to this file,
``python urdf/make_irb4600_urdf.py --check`` to re-derive the torque limits and
compare them with :data:`TORQUE_LIMITS` (needs Pinocchio). ``urdf/README.md``
explains every number; this docstring and the comments give the short version.

Kinematics (ERRATA 1): standard DH rows (d, a, alpha, theta_offset)
``A_i = Rz(q_i + theta_offset_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``. A URDF joint applies
its fixed origin *before* its rotation, so link ``link_i``'s frame is
``F_i = (DH frame i-1) Rz(q_i + theta_offset_i)``: its z axis is joint axis i, and
joint i's origin is ``Tz(d_{i-1}) Tx(a_{i-1}) Rx(alpha_{i-1}) Rz(theta_offset_i)`` (row 0
is the identity). The offsets therefore live in the joint origins, and the URDF
joint angle equals the paper's q. ``flange`` = DH frame 6 = ``F_6 Tz(d_6)``; the
``camera`` link sits on it at T_E_C = Rz(pi), zero translation (ERRATA 2).

Inertials: each body is one solid of uniform density (sizes in :data:`SOLIDS`),
and the density is chosen so that base + six links weigh :data:`TOTAL_MASS`
(412 kg, ABB's data sheet for the IRB 4600-45/2.05). Masses are therefore
proportional to the solids' volumes and every inertia is that of a physical solid
(positive definite, triangle inequalities hold).

Torque limits (:data:`TORQUE_LIMITS`): for each joint i,
``tau_req_i = max_q |g_i(q)| + max_q M_ii(q) * dq_max_i / T_ACCEL``, with the
45 kg rated payload (:data:`PAYLOAD_MASS` centred at :data:`PAYLOAD_COM` in the flange
frame, a solid sphere of radius :data:`PAYLOAD_RADIUS`), the paper-mapping
armature J_a + J_g of Table A4, maxima over the joint ranges, and T_ACCEL the
time to reach full speed from rest. ``tau_req`` is rounded up to two significant
digits. :func:`derive_torque_limits` recomputes it; ``--check`` also prints the motor
current each limit needs through Table A4's joint-side torque constant r K_m = 13.48 N m/A
(230, 378, 111, 15.6, 15.6, 4.0 A), which a ~100 V, 400 A drive supplies at full speed
(back-emf K_b = 7 mV/rpm gives at most 84 V, joint 6 at 360 deg/s).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

URDF_NAME = "abb_irb4600_45_205.urdf"

# ERRATA 1: standard DH rows (d [m], a [m], alpha [deg], theta_offset [deg]); Table A1
# gives L1 = d1 = 0.495, a1 = 0.175, L2 = a2 = 0.900, L3 = a3 = 0.175, L4 = d4 = 0.960, Lt = d6 = 0.135.
DH_ROWS: tuple[tuple[float, float, float, float], ...] = (
    (0.495, 0.175, -90.0, 0.0),
    (0.0, 0.900, 0.0, -90.0),
    (0.0, 0.175, -90.0, 0.0),
    (0.960, 0.0, 90.0, 0.0),
    (0.0, 0.0, -90.0, 0.0),
    (0.135, 0.0, 0.0, 0.0),
)
# Table A2 working ranges [deg]; axes 4 and 6 turn +-400 deg.
Q_MIN_DEG = (-180.0, -90.0, -180.0, -400.0, -125.0, -400.0)
Q_MAX_DEG = (180.0, 150.0, 75.0, 400.0, 120.0, 400.0)
# ABB product specification (IRB 4600 family, 45/2.05 shares the 60/2.05 geometry), as cited by
# ROS-Industrial's abb_irb4600_support package; ERRATA 16. [deg/s]
DQ_MAX_DEG_S = (175.0, 175.0, 175.0, 250.0, 250.0, 360.0)

TOTAL_MASS = 412.0  # [kg] ABB data sheet, IRB 4600-45/2.05 (family 412-435 kg); base + links 1-6
CAMERA_MASS = 0.17  # [kg] ZED 2, Table A3
CAMERA_BOX = (0.175, 0.030, 0.043)  # [m] ZED 2 175 x 30 x 43 mm, along camera x (baseline), y, z (optical)

# One uniform solid per body, in the body's frame F_i, aligned with its axes.
# ("cylinder", radius, length along z, centre) or ("box", (size_x, size_y, size_z), centre); metres.
# Sizes follow the link dimensions: link_2's box spans a2 = 0.90 m plus 0.10 m housing past each joint,
# link_3's elbow housing is a3 = 0.175 m above axis 3 plus 0.10 m below and reaches 0.25 m behind
# axis 3 (motor pack), link_4's tube spans the forearm d4 = 0.96 m minus the elbow and wrist
# housings, link_6's disc ends at the flange (d6 = 0.135 m).
SOLIDS: dict[str, tuple] = {
    "base_link": ("cylinder", 0.30, 0.20, (0.0, 0.0, 0.10)),  # floor plate + axis-1 gearbox, z in [0, 0.2]
    "link_1": ("cylinder", 0.25, 0.395, (0.0, 0.0, 0.3975)),  # turret, z in [0.2, 0.595] (axis 2 at 0.495)
    "link_2": ("box", (1.10, 0.25, 0.20), (0.45, 0.0, 0.0)),  # upper arm along F_2 x, axis 2 -> axis 3
    "link_3": ("box", (0.375, 0.40, 0.30), (0.0875, -0.05, 0.0)),  # elbow housing, F_3 y = forearm direction
    "link_4": ("cylinder", 0.09, 0.76, (0.0, 0.0, 0.53)),  # forearm tube along axis 4, z in [0.15, 0.91]
    "link_5": ("cylinder", 0.08, 0.20, (0.0, 0.0, 0.0)),  # wrist housing along axis 5, on the wrist centre
    "link_6": ("cylinder", 0.06, 0.04, (0.0, 0.0, 0.115)),  # flange disc, z in [0.095, 0.135]
}

# Torque-limit rule (see module docstring and README).
PAYLOAD_MASS = 45.0  # [kg] rated handling capacity of the 45/2.05
# [m] assumed payload centre of mass in the flange frame: 0.20 m out and 0.10 m off axis 6, so that the
# payload loads every wrist joint (an assumption, not ABB's load diagram).
PAYLOAD_COM = (0.10, 0.0, 0.20)
PAYLOAD_RADIUS = 0.10  # [m] payload modelled as a solid sphere (inertia 2/5 m r^2)
T_ACCEL = 0.5  # [s] assumed time to reach full joint speed from rest at maximum inertia
J_A, J_G, GEAR_RATIO, K_M = 0.09847, 0.05, 200.0, 0.0674  # Table A4 [kg m^2], [kg m^2], [-], [N m/A]
# Result of derive_torque_limits() rounded up to two significant digits [N m]; --check verifies.
TORQUE_LIMITS = (3100.0, 5100.0, 1500.0, 210.0, 210.0, 54.0)


# --------------------------------------------------------------------------- geometry helpers
def dh_transform(d: float, a: float, alpha: float, theta: float) -> np.ndarray:
    """Standard DH transform Rz(theta) Tz(d) Tx(a) Rx(alpha) (Eq. 12-13), angles in radians."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array(
        [[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1.0]]
    )


def _rz(angle: float) -> np.ndarray:
    return dh_transform(0.0, 0.0, 0.0, angle)


def rpy_from_rotation(R: np.ndarray) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw (R = Rz(yaw) Ry(pitch) Rx(roll)), with roll = 0 at gimbal lock."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[0, 0], R[1, 0]) < 1e-12:  # pitch = +-90 deg: only roll -/+ yaw is defined
        return 0.0, pitch, math.atan2(-R[0, 1], R[1, 1])
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def joint_origin(i: int) -> np.ndarray:
    """Fixed origin of joint i (1-based): the rest of DH row i-1, then row i's theta offset."""
    fixed = np.eye(4)
    if i > 1:
        d, a, alpha, _ = DH_ROWS[i - 2]
        fixed = dh_transform(d, a, math.radians(alpha), 0.0)
    return fixed @ _rz(math.radians(DH_ROWS[i - 1][3]))


def solid_volume(solid: tuple) -> float:
    """Volume [m^3] of a ("cylinder", r, length, c) or ("box", sizes, c) solid."""
    if solid[0] == "cylinder":
        return math.pi * solid[1] ** 2 * solid[2]
    sx, sy, sz = solid[1]
    return sx * sy * sz


def solid_inertia(solid: tuple, mass: float) -> tuple[float, float, float]:
    """Principal moments (ixx, iyy, izz) [kg m^2] about the solid's centre, axes as in the link frame."""
    if solid[0] == "cylinder":
        r, length = solid[1], solid[2]
        side = mass * (3 * r**2 + length**2) / 12.0
        return side, side, mass * r**2 / 2.0
    return box_inertia(solid[1], mass)


def box_inertia(size: Sequence[float], mass: float) -> tuple[float, float, float]:
    """Principal moments of a uniform box of the given (x, y, z) sizes [kg m^2]."""
    sx, sy, sz = size
    return mass * (sy**2 + sz**2) / 12.0, mass * (sx**2 + sz**2) / 12.0, mass * (sx**2 + sy**2) / 12.0


def link_masses() -> dict[str, float]:
    """Masses [kg]: TOTAL_MASS shared in proportion to the solids' volumes (one uniform density)."""
    volume = sum(solid_volume(s) for s in SOLIDS.values())
    return {name: TOTAL_MASS * solid_volume(s) / volume for name, s in SOLIDS.items()}


# --------------------------------------------------------------------------- XML
def _f(x: float) -> str:
    return "0" if x == 0.0 else repr(float(x))


def _origin(T: np.ndarray) -> str:
    roll, pitch, yaw = rpy_from_rotation(T[:3, :3])
    xyz = " ".join(_f(v) for v in T[:3, 3])
    return f'<origin xyz="{xyz}" rpy="{_f(roll)} {_f(pitch)} {_f(yaw)}"/>'


def _geometry(solid: tuple) -> str:
    if solid[0] == "cylinder":
        return f'<cylinder radius="{_f(solid[1])}" length="{_f(solid[2])}"/>'
    return f'<box size="{" ".join(_f(s) for s in solid[1])}"/>'


def _link(name: str, solid: tuple | None, mass: float, comment: str, color: str) -> list[str]:
    lines = [f"  <!-- {comment} -->", f'  <link name="{name}">']
    if solid is not None:
        centre = " ".join(_f(v) for v in solid[-1])
        ixx, iyy, izz = solid_inertia(solid, mass)
        lines += [
            "    <inertial>",
            f'      <origin xyz="{centre}" rpy="0 0 0"/>',
            f'      <mass value="{_f(mass)}"/>',
            f'      <inertia ixx="{_f(ixx)}" ixy="0" ixz="0" iyy="{_f(iyy)}" iyz="0" izz="{_f(izz)}"/>',
            "    </inertial>",
            "    <visual>",
            f'      <origin xyz="{centre}" rpy="0 0 0"/>',
            f"      <geometry>{_geometry(solid)}</geometry>",
            f'      <material name="{color}"/>',
            "    </visual>",
        ]
    lines.append("  </link>")
    return lines


def build_urdf() -> str:
    """Return the URDF text (deterministic)."""
    masses = link_masses()
    density = TOTAL_MASS / sum(solid_volume(s) for s in SOLIDS.values())
    out = [
        '<?xml version="1.0"?>',
        "<!-- ABB IRB 4600-45/2.05 for ibvs-youla. GENERATED by urdf/make_irb4600_urdf.py: edit that",
        "     script, not this file. Derivation of every number: urdf/README.md.",
        "     Frames: link_i has z along joint axis i; joint origins carry the ERRATA 1 DH rows",
        "     (d, a, alpha, theta_offset), so joint angle = the paper's q. Units SI, angles rad. -->",
        '<robot name="abb_irb4600_45_205">',
        '  <material name="abb_orange"><color rgba="0.93 0.45 0.1 1"/></material>',
        '  <material name="dark_grey"><color rgba="0.25 0.25 0.25 1"/></material>',
        f"  <!-- Inertials: uniform density {density:.1f} kg/m^3 so that base + links = {TOTAL_MASS} kg"
        " (ABB data sheet); one solid per body, see SOLIDS in the generator. -->",
    ]
    out += _link("base_link", SOLIDS["base_link"], masses["base_link"], "base = frame {O}", "dark_grey")
    for i in range(1, 7):
        name = f"link_{i}"
        out += _link(name, SOLIDS[name], masses[name], f"{name}: frame F_{i}, z = axis {i}", "abb_orange")
        if i == 1:
            placed = "origin = base frame"
        else:
            d, a, alpha, _ = DH_ROWS[i - 2]
            placed = f"origin = Tz Tx Rx of DH row {i - 1} (d={d}, a={a}, alpha={alpha} deg)"
        lo, hi, vel = (math.radians(v) for v in (Q_MIN_DEG[i - 1], Q_MAX_DEG[i - 1], DQ_MAX_DEG_S[i - 1]))
        out += [
            f"  <!-- joint_{i}: {placed}, then Rz(theta_offset {DH_ROWS[i - 1][3]} deg) of row {i}"
            f" (ERRATA 1). Limits: Table A2"
            f" [{Q_MIN_DEG[i - 1]}, {Q_MAX_DEG[i - 1]}] deg; velocity {DQ_MAX_DEG_S[i - 1]} deg/s"
            f" (ABB spec via ROS-Industrial, ERRATA 16); effort {TORQUE_LIMITS[i - 1]} N m (derived,"
            " README). -->",
            f'  <joint name="joint_{i}" type="revolute">',
            f'    <parent link="{"base_link" if i == 1 else f"link_{i - 1}"}"/>',
            f'    <child link="{name}"/>',
            f"    {_origin(joint_origin(i))}",
            '    <axis xyz="0 0 1"/>',
            f'    <limit lower="{_f(lo)}" upper="{_f(hi)}" velocity="{_f(vel)}"'
            f' effort="{_f(TORQUE_LIMITS[i - 1])}"/>',
            "  </joint>",
        ]
    d6, a6, alpha6, _ = DH_ROWS[5]
    out += _link("flange", None, 0.0, "flange = DH frame 6 = paper {E} (massless)", "")
    out += [
        f"  <!-- flange: rest of DH row 6 (d={d6}, a={a6}, alpha={alpha6} deg) -->",
        '  <joint name="joint_6-flange" type="fixed">',
        '    <parent link="link_6"/>',
        '    <child link="flange"/>',
        f"    {_origin(dh_transform(d6, a6, math.radians(alpha6), 0.0))}",
        "  </joint>",
    ]
    camera = ("box", CAMERA_BOX, (0.0, 0.0, 0.0))
    note = "camera = paper {C}: ZED 2, Table A3 mass, box inertia"
    out += _link("camera", camera, CAMERA_MASS, note, "dark_grey")
    out += [
        "  <!-- T_E_C = Rz(pi), zero translation (ERRATA 2) -->",
        '  <joint name="flange-camera" type="fixed">',
        '    <parent link="flange"/>',
        '    <child link="camera"/>',
        f'    <origin xyz="0 0 0" rpy="0 0 {_f(math.pi)}"/>',
        "  </joint>",
        "</robot>",
        "",
    ]
    return "\n".join(out)


# --------------------------------------------------------------------------- torque limits
def derive_torque_limits(urdf_text: str | None = None, n_samples: int = 4000, seed: int = 0) -> np.ndarray:
    """Required joint torques [N m]: max|g_i| + max M_ii * dq_max_i / T_ACCEL with the rated payload.

    Maxima over the joint ranges: seeded random samples, then a bounded local search
    (scipy L-BFGS-B) from the best sample of each quantity. Armature: Table A4's J_a + J_g
    (the paper's literal Eq. 29). Needs Pinocchio.
    """
    import pinocchio as pin
    from scipy.optimize import minimize

    model = pin.buildModelFromXML(urdf_text or build_urdf())
    model.armature[:] = J_A + J_G
    flange = model.frames[model.getFrameId("flange")]
    sphere = pin.Inertia.FromSphere(PAYLOAD_MASS, PAYLOAD_RADIUS)
    com = flange.placement * pin.SE3(np.eye(3), np.array(PAYLOAD_COM))
    model.appendBodyToJoint(flange.parentJoint, sphere, com)
    data = model.createData()
    lo, hi = np.radians(Q_MIN_DEG), np.radians(Q_MAX_DEG)
    accel = np.radians(DQ_MAX_DEG_S) / T_ACCEL  # [rad/s^2]

    def gravity(q: np.ndarray, i: int) -> float:
        return -abs(pin.computeGeneralizedGravity(model, data, q)[i])

    def inertia(q: np.ndarray, i: int) -> float:
        return -pin.crba(model, data, q)[i, i]

    rng = np.random.default_rng(seed)
    samples = lo + (hi - lo) * rng.random((n_samples, 6))
    required = np.zeros(6)
    for i in range(6):
        for cost, scale in ((gravity, 1.0), (inertia, accel[i])):
            start = min(samples, key=lambda q, c=cost, i=i: c(q, i))
            best = minimize(cost, start, args=(i,), method="L-BFGS-B", bounds=list(zip(lo, hi, strict=True)))
            required[i] += -min(best.fun, cost(start, i)) * scale
    return required


def round_up_2sig(x: float) -> float:
    """Round a positive number up to two significant digits."""
    step = 10.0 ** (math.floor(math.log10(x)) - 1)
    return math.ceil(x / step - 1e-9) * step


def main(argv: Sequence[str] | None = None) -> None:
    """Write the URDF (default) or check TORQUE_LIMITS against the derivation (--check)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="re-derive torque limits and compare")
    parser.add_argument("--out", type=Path, default=Path(__file__).with_name(URDF_NAME))
    args = parser.parse_args(argv)
    if args.check:
        required = derive_torque_limits()
        current = np.array(TORQUE_LIMITS) / (GEAR_RATIO * K_M)
        for i, (req, lim, amp) in enumerate(zip(required, TORQUE_LIMITS, current, strict=True)):
            print(
                f"joint {i + 1}: required {req:8.1f} N m -> limit {round_up_2sig(req):7.0f} "
                f"(file {lim:7.0f}), r*K_m*I needs I = {amp:6.1f} A"
            )
        return
    args.out.write_text(build_urdf())
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
