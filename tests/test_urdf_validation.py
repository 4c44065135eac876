"""Damaged URDFs and models are refused: a ModelLoadError naming the file, link or joint.

Each URDF case edits one value of the shipped IRB 4600 URDF in ``tmp_path``; each model case
edits a Pinocchio model of it (what ``Arm(model)`` receives). The valid file must load and give
the mass matrix it gave before the checks existed.
"""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest

from ibvs_youla.exceptions import IbvsYoulaError, ModelLoadError
from ibvs_youla.model._resources import example_robot_data_urdf, urdf_path
from ibvs_youla.model.arm import Arm
from ibvs_youla.model.urdf_checks import AXIS_TOL, check_urdf_file, inertia_problem

SHIPPED = urdf_path("abb_irb4600_45_205.urdf")
TEXT = SHIPPED.read_text()
LINK_3 = '<link name="link_3">'
JOINT_3 = '<joint name="joint_3" type="revolute">'
INERTIA_3 = (
    'ixx="1.4975573315361306" ixy="0" ixz="0" iyy="1.3814966383420806" iyz="0" izz="1.8008126911721973"'
)
LIMIT_3 = (
    'lower="-3.141592653589793" upper="1.3089969389957472" velocity="3.0543261909900767" effort="1500.0"'
)
INERTIAL_3 = TEXT[TEXT.index(LINK_3) : TEXT.index("</inertial>", TEXT.index(LINK_3)) + len("</inertial>")]
LINK = "link 'link_3'"
JOINT = "joint 'joint_3'"
BODY = "joint 'joint_3' (moving link 'link_3')"


def edited(old: str, new: str, after: str = "") -> str:
    """The shipped URDF with the first ``old`` after ``after`` replaced by ``new``."""
    start = TEXT.index(after)
    where = TEXT.index(old, start)
    return TEXT[:where] + new + TEXT[where + len(old) :]


def link_3(old: str, new: str) -> str:
    return edited(old, new, LINK_3)


def joint_3(old: str, new: str) -> str:
    return edited(old, new, JOINT_3)


MASS, INERTIA, AXIS = 'value="71.88275191373427"', f"<inertia {INERTIA_3}/>", '<axis xyz="0 0 1"/>'
ZERO_INERTIA = 'ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"'
ON_MASS, ON_INERTIA, ON_LIMIT = f"{LINK} <mass value>", f"{LINK} <inertia>", f"{JOINT} <limit>"

# (id, URDF text, element the error names, regex the message must match)
URDF_CASES = [
    ("nan-mass", link_3(MASS, 'value="nan"'), ON_MASS, "received 'nan'; valid: a finite mass > 0"),
    ("negative-mass", link_3(MASS, 'value="-71.9"'), ON_MASS, "received '-71.9'"),
    ("zero-mass", link_3(MASS, 'value="0"'), ON_MASS, r"received '0'; .*\(or 0 with an all-zero <inertia>"),
    ("inf-mass", link_3(MASS, 'value="inf"'), ON_MASS, "received 'inf'"),
    ("text-mass", link_3(MASS, 'value="heavy"'), ON_MASS, "received 'heavy'"),
    ("no-mass", link_3(f"<mass {MASS}/>", ""), LINK, "received an <inertial> without <mass value>"),
    (
        "inf-inertia",
        link_3('ixx="1.4975573315361306"', 'ixx="inf"'),
        f"{LINK} <inertia ixx>",
        "received 'inf'",
    ),
    ("nan-inertia", link_3('iyz="0"', 'iyz="nan"'), f"{LINK} <inertia iyz>", "received 'nan'"),
    ("no-iyz", link_3('iyz="0" ', ""), ON_INERTIA, "received no iyz; valid: all of ixx, ixy"),
    ("no-inertia", link_3(INERTIA, ""), ON_INERTIA, "received no ixx, ixy, ixz, iyy, iyz, izz"),
    (
        "negative-moment",
        link_3('izz="1.8008126911721973"', 'izz="-1.8"'),
        ON_INERTIA,
        r"\[-1\.8 .*not positive definite",
    ),
    ("indefinite", link_3('ixy="0"', 'ixy="2"'), ON_INERTIA, r"moments \[-0\.561315 .*not positive definite"),
    (
        "zero-inertia",
        link_3(INERTIA_3, ZERO_INERTIA),
        ON_INERTIA,
        r"moments \[0\. 0\. 0\.\] \[kg m\^2\], not positive",
    ),
    (
        "triangle",
        link_3('izz="1.8008126911721973"', 'izz="3.0"'),
        ON_INERTIA,
        r"triangle inequality \(3 > 1\.3815 \+ 1\.49756\)",
    ),
    (
        "nan-inertial-origin",
        link_3('xyz="0.0875 -0.05 0"', 'xyz="0.0875 nan 0"'),
        f"{LINK} <inertial> <origin xyz>",
        "received '0.0875 nan 0'; valid: three finite numbers",
    ),
    (
        "short-inertial-rpy",
        link_3('rpy="0 0 0"', 'rpy="0 0"'),
        f"{LINK} <inertial> <origin rpy>",
        "received '0 0'",
    ),
    ("zero-axis", joint_3(AXIS, '<axis xyz="0 0 0"/>'), JOINT, "length 0; valid: a unit axis"),
    (
        "long-axis",
        joint_3(AXIS, '<axis xyz="0 0 2"/>'),
        JOINT,
        r"length 2; valid: a unit axis \(within 1e-06\); write 0 0 1$",
    ),
    ("nan-axis", joint_3(AXIS, '<axis xyz="0 nan 1"/>'), f"{JOINT} <axis xyz>", "received '0 nan 1'"),
    ("2d-axis", joint_3(AXIS, '<axis xyz="0 1"/>'), f"{JOINT} <axis xyz>", "received '0 1'"),
    ("nan-origin", joint_3('xyz="0.9 0 0"', 'xyz="nan 0 0"'), f"{JOINT} <origin xyz>", "received 'nan 0 0'"),
    ("inf-rpy", joint_3('rpy="0 0 0"', 'rpy="0 inf 0"'), f"{JOINT} <origin rpy>", "received '0 inf 0'"),
    (
        "lower>upper",
        joint_3('lower="-3.141592653589793"', 'lower="1.5"'),
        ON_LIMIT,
        "lower=1.5, upper=1.3089969389957472",
    ),
    (
        "no-lower-upper",
        joint_3(LIMIT_3, 'velocity="3" effort="1500"'),
        ON_LIMIT,
        r"lower=0 \(default\), upper=0 \(default\)",
    ),
    (
        "nan-lower",
        joint_3('lower="-3.141592653589793"', 'lower="nan"'),
        f"{JOINT} <limit lower>",
        "received 'nan'",
    ),
    ("no-limit", joint_3(f"<limit {LIMIT_3}/>", ""), JOINT, "received a revolute joint without <limit>"),
    (
        "zero-velocity",
        joint_3('velocity="3.0543261909900767"', 'velocity="0"'),
        f"{JOINT} <limit velocity>",
        "'0'",
    ),
    (
        "negative-effort",
        joint_3('effort="1500.0"', 'effort="-1500"'),
        f"{JOINT} <limit effort>",
        "received '-1500'",
    ),
    ("no-effort", joint_3(' effort="1500.0"', ""), f"{JOINT} <limit effort>", "received no value;"),
    ("no-inertial", edited(INERTIAL_3, LINK_3), BODY, r"mass 0 \[kg\]; valid: .*needs an <inertial>"),
    (
        "massless-frame",
        edited(INERTIAL_3, f'{LINK_3}<inertial><mass value="0"/><inertia {ZERO_INERTIA}/></inertial>'),
        BODY,
        "received a body of mass 0 ",
    ),
]


@pytest.mark.parametrize(
    ("text", "element", "message"), [c[1:] for c in URDF_CASES], ids=[c[0] for c in URDF_CASES]
)
def test_a_damaged_urdf_is_refused_naming_the_link_or_joint(tmp_path, text, element, message):
    assert text != TEXT
    path = tmp_path / "arm.urdf"
    path.write_text(text)
    with pytest.raises(ModelLoadError) as info:
        Arm.from_urdf(path)
    assert info.value.path == path and info.value.element == element
    assert str(info.value).startswith(f"URDF {str(path)!r}: {element}: received ")
    assert re.search(message, str(info.value)), str(info.value)


def test_the_damaged_urdf_cases_are_at_least_25_distinct_files():
    assert len(URDF_CASES) >= 25 and len({c[1] for c in URDF_CASES}) == len(URDF_CASES)


# (id, file content or None for no file, "dir" for a directory, message)
FILE_CASES = [
    ("missing", None, "does not exist"),
    ("directory", "dir", "is not a file"),
    ("empty", "", "cannot parse URDF .*: the file is empty"),
    ("blank", " \n\t\n", "cannot parse URDF .*: the file is empty"),
    ("not-xml", "this is not <xml", r"cannot parse URDF .*: not well-formed XML \(.*line 1"),
    ("truncated", TEXT[: len(TEXT) // 2], "cannot parse URDF .*: not well-formed XML"),
    ("not-a-robot", "<sdf><model name='x'/></sdf>", "the root element is <sdf>, not <robot>"),
]


@pytest.mark.parametrize(("content", "message"), [c[1:] for c in FILE_CASES], ids=[c[0] for c in FILE_CASES])
def test_a_file_that_is_not_a_urdf_is_refused_naming_the_file(tmp_path, content, message):
    path = tmp_path / "arm.urdf"
    if content == "dir":
        path.mkdir()
    elif content is not None:
        path.write_text(content)
    with pytest.raises(ModelLoadError, match=message) as info:
        Arm.from_urdf(path)
    assert info.value.path == path and str(path) in str(info.value) and info.value.element is None


# ---------------------------------------------------------------------------------------- models
def _negative_mass(model):
    model.inertias[3] = pin.Inertia(-1.0, np.zeros(3), np.eye(3))


def _flat_inertia(model):
    model.inertias[3] = pin.Inertia(1.0, np.zeros(3), np.diag([1.0, 1.0, 2.5]))


def _nan_lever(model):
    model.inertias[3] = pin.Inertia(1.0, np.array([0.0, np.nan, 0.0]), np.eye(3))


def _sheared_camera(model):
    frame = model.frames[model.getFrameId("camera")]
    frame.placement = pin.SE3(np.diag([1.0, 1.0, 1.1]), np.zeros(3))
    model.frames[model.getFrameId("camera")] = frame


def _scaled_joint_placement(model):
    model.jointPlacements[3] = pin.SE3(2.0 * np.eye(3), np.zeros(3))


def _infinite_speed(model):
    model.velocityLimit[2] = np.inf


def _zero_axis(model):
    model.joints[3] = pin.JointModelRevoluteUnaligned(0.0, 0.0, 0.0)
    model.joints[3].setIndexes(3, 2, 2)


MODEL_CASES = [
    ("negative-mass", _negative_mass, BODY, "a body of mass -1 "),
    ("triangle", _flat_inertia, BODY, r"triangle inequality \(2\.5 > 1 \+ 1\)"),
    ("nan-centre-of-mass", _nan_lever, BODY, r"centre of mass \[0\.0, nan, 0\.0\]"),
    ("non-rigid-camera", _sheared_camera, "frame 'camera' placement", "a rotation 0.21 from SO"),
    ("non-rigid-joint", _scaled_joint_placement, "joint 'joint_3' placement", "a rotation 7 from SO"),
    (
        "infinite-speed",
        _infinite_speed,
        "joint 'joint_3' velocity limit",
        r"received \[inf\]; valid: finite and > 0",
    ),
    ("zero-axis", _zero_axis, JOINT, r"axis \[0\.0, 0\.0, 0\.0\] of length 0"),
]


@pytest.mark.parametrize(
    ("edit", "element", "message"), [c[1:] for c in MODEL_CASES], ids=[c[0] for c in MODEL_CASES]
)
def test_a_damaged_model_is_refused_naming_the_joint_or_frame(edit, element, message):
    model = pin.buildModelFromUrdf(str(SHIPPED))
    edit(model)
    with pytest.raises(ModelLoadError) as info:
        Arm(model)
    assert info.value.element == element and info.value.path is None
    assert str(info.value).startswith(f"model: {element}: received ")
    assert re.search(message, str(info.value)), str(info.value)
    assert isinstance(info.value, IbvsYoulaError)


# ---------------------------------------------------------------------------------------- valid
def test_the_shipped_urdf_loads_and_its_mass_matrix_is_unchanged():
    """M(q) at one q, pinned from the code before these checks existed (rigid bodies only, no armature)."""
    check_urdf_file(SHIPPED)
    arm = Arm.from_urdf(SHIPPED)
    M = arm.mass_matrix([0.1, -0.2, 0.3, -0.4, 0.5, -0.6])  # [kg m^2]
    expected = {(0, 0): 24.894595424479014, (1, 1): 148.80103227891746, (1, 2): 26.693907804215023,
                (5, 5): 0.0017473638005790165}  # fmt: skip
    for (i, j), value in expected.items():
        assert M[i, j] == pytest.approx(value, rel=1e-12)
    assert Arm.irb4600().name.startswith("ABB IRB 4600")


def test_example_robot_data_ur5_with_massless_frames_loads():
    """UR5's tool0, ee_link and base are <mass value="0"/> with an all-zero inertia: massless frames."""
    path = example_robot_data_urdf("ur_description/urdf/ur5_robot.urdf")
    assert path.read_text().count('<mass value="0"/>') == 3
    assert Arm.from_urdf(path, camera_frame="tool0").model.inertias[6].mass == pytest.approx(
        0.1879, rel=1e-12
    )


@pytest.mark.parametrize(
    ("axis", "loads"), [("0 0 1.0000001", True), ("0 0 0.9999995", True), ("0 0 1.00001", False)]
)
def test_an_axis_is_unit_within_the_stated_tolerance(tmp_path, axis, loads):
    assert AXIS_TOL == 1e-6
    path = tmp_path / "arm.urdf"
    path.write_text(edited('<axis xyz="0 0 1"/>', f'<axis xyz="{axis}"/>', JOINT_3))
    if loads:
        assert Arm.from_urdf(path).model.joints[3].shortname() == "JointModelRevoluteUnaligned"
    else:
        with pytest.raises(ModelLoadError, match=r"length 1\.00001; valid: a unit axis"):
            Arm.from_urdf(path)


@pytest.mark.parametrize(
    ("moments", "problem"),
    [
        ((1.0, 1.0, 2.0), None),  # a flat plate: the triangle inequality holds with equality
        ((1.0, 1.0, 2.0 + 1e-7), None),  # within TRIANGLE_RTOL (1e-6) of the trace, 4
        ((1.0, 1.0, 2.0 + 1e-5), "triangle inequality"),
        ((0.0, 1.0, 1.0), "not positive definite"),  # a thin rod about its own axis
    ],
)
def test_inertia_rules_at_their_tolerances(moments, problem):
    found = inertia_problem(np.diag(moments))
    assert found is None if problem is None else problem in found
