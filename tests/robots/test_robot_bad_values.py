"""A robot's numbers refused before Drake reads them: masses, inertias, origins and meshes of a
model file in each format (URDF, SDF, MJCF), the base body of a description file, and a
description built in Python. Each refusal is one line naming the file (or the robot), the key
and the value; on the command line, exit status 2 and nothing simulated. A property test per
surface feeds random numbers and asserts that only the documented errors come out, each example
bounded in time."""

from __future__ import annotations

import dataclasses
import math
import os
import re
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from robot_data import robot_or_skip
from test_robot_description_file import toml

from drake_sot.robots import RobotFileError
from drake_sot.robots.description import Drive, FrameSpec
from drake_sot.robots.description_file import RobotDescriptionError, load_description
from drake_sot.robots.model_tree import read_model_tree
from drake_sot.robots.model_values import LENGTH_BOUND, MASS_BOUND

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "robot"
#: Format → (model file, its description) in examples/robot.
FILES = {
    "urdf": ("humanoid.urdf", "humanoid.toml"),
    "sdf": ("humanoid.sdf", "humanoid_sdf.toml"),
    "mjcf": ("humanoid.xml", "humanoid_mjcf.toml"),
}
#: Format → the pelvis's mass and an inertia moment and an origin as written in the example model.
PELVIS_MASS = {"urdf": '<mass value="10" />', "sdf": "<mass>10</mass>", "mjcf": 'mass="10"'}
PELVIS_IXX = {
    "urdf": 'ixx="0.0833333333"',
    "sdf": "<ixx>0.0833333333</ixx>",
    "mjcf": 'fullinertia="0.0833333333',
}
PELVIS_ORIGIN = {"urdf": 'xyz="0 0 0.07"', "sdf": "<pose>0 0 0.07 0 0 0</pose>", "mjcf": 'pos="0 0 0.07"'}
#: Seconds an example of a property test may take (a parse and a check of a small model).
EXAMPLE_BOUND = 5.0
DRAKE_SOT = [sys.executable, "-m", "drake_sot.app.cli"]


def _mass(fmt: str, value: str) -> str:
    return {"urdf": f'<mass value="{value}" />', "sdf": f"<mass>{value}</mass>", "mjcf": f'mass="{value}"'}[
        fmt
    ]


def _ixx(fmt: str, value: str) -> str:
    return {"urdf": f'ixx="{value}"', "sdf": f"<ixx>{value}</ixx>", "mjcf": f'fullinertia="{value}'}[fmt]


def _origin(fmt: str, value: str) -> str:
    return {
        "urdf": f'xyz="0 0 {value}"',
        "sdf": f"<pose>0 0 {value} 0 0 0</pose>",
        "mjcf": f'pos="0 0 {value}"',
    }[fmt]


def _edited(directory: Path, fmt: str, old: str, new: str) -> Path:
    """A copy of the example robot of format ``fmt`` in ``directory`` with the first ``old`` of
    its model made ``new``; the path of its description."""
    model, description = FILES[fmt]
    text = (EXAMPLE / model).read_text()
    assert old in text, (fmt, old)
    (directory / model).write_text(text.replace(old, new, 1))
    shutil.copy(EXAMPLE / description, directory / description)
    return directory / description


def _run(description: Path, out: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    argv = [
        "run",
        "reach",
        "--robot",
        str(description),
        "--duration",
        "0.05",
        "--no-record",
        "--out",
        str(out),
    ]
    return subprocess.run([*DRAKE_SOT, *argv], capture_output=True, text=True, timeout=300, env=env)


def _refused(proc: subprocess.CompletedProcess, *names: str) -> str:
    """The one error line of a refused command (exit 2, no traceback), naming each of ``names``."""
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and "WARNING:drake" not in proc.stderr, proc.stderr
    (line,) = [line for line in proc.stderr.splitlines() if "error:" in line]
    for name in names:
        assert name in line, (name, line)
    return line


# --- model files: each case of the report, on the command line ----------------------------------


@pytest.mark.parametrize(
    ("fmt", "old", "new", "names"),
    [
        ("mjcf", PELVIS_MASS["mjcf"], _mass("mjcf", "0"), ["body 'pelvis'", "mass = '0'"]),
        ("mjcf", PELVIS_MASS["mjcf"], _mass("mjcf", "-5"), ["body 'pelvis'", "mass = '-5'"]),
        ("urdf", PELVIS_MASS["urdf"], _mass("urdf", "0"), ["link 'pelvis'", "mass 0"]),
        ("urdf", PELVIS_MASS["urdf"], _mass("urdf", "-5"), ["link 'pelvis'", "'-5'"]),
        ("sdf", PELVIS_MASS["sdf"], _mass("sdf", "0"), ["link 'pelvis'", "mass 0"]),
        ("sdf", PELVIS_MASS["sdf"], _mass("sdf", "-5"), ["link 'pelvis'", "'-5'"]),
        ("sdf", PELVIS_IXX["sdf"], _ixx("sdf", "nan"), ["link 'pelvis'", "<ixx> = 'nan'"]),
        ("mjcf", PELVIS_MASS["mjcf"], _mass("mjcf", "1e308"), ["body 'pelvis'", "mass = '1e308'"]),
        ("urdf", PELVIS_ORIGIN["urdf"], _origin("urdf", "1e308"), ["link 'pelvis'", "1e308"]),
        ("mjcf", "<freejoint />", '<freejoint /><geom type="mesh" mesh="nosuch" />', ["mesh = 'nosuch'"]),
        (
            "mjcf",
            "<worldbody>",
            '<asset><mesh name="shell" file="nosuch.stl" /></asset><worldbody>',
            ["nosuch.stl", "does not exist"],
        ),
    ],
)
def test_a_bad_number_in_a_model_exits_2_naming_the_file_the_element_and_the_value(
    tmp_path, fmt, old, new, names
):
    description = _edited(tmp_path, fmt, old, new)
    proc = _run(description, tmp_path / "out")
    _refused(proc, str(tmp_path / FILES[fmt][0]), *names)
    assert not (tmp_path / "out").exists()  # nothing simulated


def test_a_massless_frame_link_and_the_shipped_robots_are_accepted(tmp_path):
    """Zero mass with zero inertia (TALOS's camera frames) is a frame, not a mistake; the
    robots of example-robot-data the catalog ships load."""
    frame = '<link name="camera"><inertial><mass value="0" /><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0" /></inertial></link><joint name="camera_joint" type="fixed"><parent link="head" /><child link="camera" /></joint></robot>'  # noqa: E501
    description = _edited(tmp_path, "urdf", "</robot>", frame)
    assert "camera" in read_model_tree(tmp_path / FILES["urdf"][0]).links
    assert load_description(description).base_body == "pelvis"
    for name in ("talos", "g1"):
        robot = robot_or_skip(name)
        read_model_tree(robot.model_file)


def test_a_negative_principal_moment_is_refused_naming_it(tmp_path):
    """Products of inertia larger than the moments: an inertia no body has (a moment of the
    principal axes below zero), computed by hand: [[1, 2, 0], [2, 1, 0], [0, 0, 1]] has the
    eigenvalues -1, 1, 3."""
    old = 'ixx="0.0833333333" ixy="0" ixz="0" iyy="0.0603333333" iyz="0" izz="0.0896666667"'
    _edited(tmp_path, "urdf", old, 'ixx="1" ixy="2" ixz="0" iyy="1" iyz="0" izz="1"')
    with pytest.raises(RobotFileError, match=r"link 'pelvis'.*positive semi-definite.*-1, 1, 3"):
        read_model_tree(tmp_path / "humanoid.urdf")


# --- model files: a property test per format ----------------------------------------------------

numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(["0", "-0", "1e-300", "1e308", "-1e308", "nan", "inf", "", "1 2", "x", "1e99999"]),
)


@pytest.mark.parametrize("fmt", sorted(FILES))
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(what=st.sampled_from(["mass", "ixx", "origin"]), value=numbers)
def test_random_masses_inertias_and_origins_load_or_are_refused_by_name(tmp_path_factory, fmt, what, value):
    """The pelvis's mass, a moment of inertia or its origin set to anything: the model's tree and
    the control plant Drake builds from it are made, or a RobotFileError names the file, in
    one line; never a Drake assertion (which would end this interpreter), never a warning."""
    from drake_sot.robots.loading import make_robot_control_model

    directory = tmp_path_factory.mktemp(fmt)
    text = str(value) if isinstance(value, float) else value
    edit = {"mass": (PELVIS_MASS, _mass), "ixx": (PELVIS_IXX, _ixx), "origin": (PELVIS_ORIGIN, _origin)}[what]
    description = _edited(directory, fmt, edit[0][fmt], edit[1](fmt, text))
    started = time.monotonic()
    try:
        plant, info = make_robot_control_model(load_description(description))
    except RobotFileError as exc:  # RobotDescriptionError and RobotFileMissing are ones
        assert str(directory.resolve()) in str(exc) or str(directory) in str(exc), str(exc)
        assert "\n" not in str(exc), str(exc)
    else:
        number = float(text)  # what was accepted was a number in range
        if what == "mass":
            assert 0.0 < number <= MASS_BOUND
            assert info.mass > number
        elif what == "origin":
            assert abs(number) <= LENGTH_BOUND
        assert math.isfinite(info.mass)
    assert time.monotonic() - started < EXAMPLE_BOUND


TETRAHEDRON = b"""solid t
facet normal 0 0 -1
outer loop
vertex 0 0 0
vertex 0 0.1 0
vertex 0.1 0 0
endloop
endfacet
facet normal 0 -1 0
outer loop
vertex 0 0 0
vertex 0.1 0 0
vertex 0 0 0.1
endloop
endfacet
facet normal -1 0 0
outer loop
vertex 0 0 0
vertex 0 0 0.1
vertex 0 0.1 0
endloop
endfacet
facet normal 1 1 1
outer loop
vertex 0.1 0 0
vertex 0 0.1 0
vertex 0 0 0.1
endloop
endfacet
endsolid t
"""


def _with_mesh(fmt: str, uri: str) -> list[tuple[str, str]]:
    """The edits that give the pelvis a visual mesh ``uri`` in format ``fmt``."""
    if fmt == "urdf":
        visual = f'<visual><geometry><mesh filename="{uri}" /></geometry></visual>'
        return [('<link name="pelvis">', f'<link name="pelvis">{visual}')]
    if fmt == "sdf":
        visual = f'<visual name="shell"><geometry><mesh><uri>{uri}</uri></mesh></geometry></visual>'
        return [('<link name="pelvis">', f'<link name="pelvis">{visual}')]
    return [
        ("<freejoint />", '<freejoint /><geom type="mesh" mesh="shell" />'),
        ("<worldbody>", f'<asset><mesh name="shell" file="{uri}" /></asset><worldbody>'),
    ]


@pytest.mark.parametrize("fmt", sorted(FILES))
@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    uri=st.sampled_from(
        ["shell.stl", "shell.obj", "missing.stl", "sub/shell.stl", "", "package://nosuch/shell.stl"]
    ),
    content=st.one_of(st.just(TETRAHEDRON), st.binary(max_size=300)),
)
def test_random_meshes_load_or_are_refused_by_name(tmp_path_factory, fmt, uri, content):
    """A visual mesh of the pelvis, its file of random bytes (or a tetrahedron), missing, under an
    unknown package or empty: the plant with its geometry is built, or a RobotFileError names
    the file, in one line."""
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
    from pydrake.systems.framework import DiagramBuilder

    from drake_sot.robots.loading import load_robot

    directory = tmp_path_factory.mktemp(fmt)
    (directory / "sub").mkdir()
    for name in ("shell.stl", "shell.obj", "sub/shell.stl"):
        (directory / name).write_bytes(content)
    (old, new), *more = _with_mesh(fmt, uri)
    description = _edited(directory, fmt, old, new)
    model = directory / FILES[fmt][0]
    for old, new in more:
        model.write_text(model.read_text().replace(old, new, 1))
    started = time.monotonic()
    try:
        robot = load_description(description)
        plant, _ = AddMultibodyPlantSceneGraph(DiagramBuilder(), 0.001)
        load_robot(plant, robot, mesh_cache=directory / "cache")
    except RobotFileError as exc:
        assert str(directory) in str(exc) or str(directory.resolve()) in str(exc), str(exc)
        assert "\n" not in str(exc), str(exc)
    else:
        assert uri in ("shell.stl", "shell.obj", "sub/shell.stl")  # a file that is there
    assert time.monotonic() - started < 4 * EXAMPLE_BOUND


# --- description files: the base body, and a property test ---------------------------------------


def test_a_base_body_not_in_the_model_exits_2_naming_the_file_the_key_and_the_value(tmp_path):
    description = _edited(tmp_path, "urdf", "<robot", "<robot")
    description.write_text(description.read_text().replace('base_body = "pelvis"', 'base_body = "nosuch"'))
    with pytest.raises(
        RobotDescriptionError, match=r"base_body = 'nosuch': must be the model's root link 'pelvis'"
    ):
        load_description(description)
    line = _refused(_run(description, tmp_path / "out"), str(description), "base_body", "'nosuch'")
    assert "root link 'pelvis'" in line
    assert not (tmp_path / "out").exists()


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    key=st.sampled_from(["base_body", "contact_radius", "sole_size", "frames.left_foot", "drives"]),
    value=st.one_of(
        st.text(max_size=12),
        st.floats(allow_nan=True, allow_infinity=True),
        st.integers(min_value=-(10**30), max_value=10**30),
        st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=3),
    ),
)
def test_random_description_values_load_or_are_refused_naming_the_file(tmp_path_factory, key, value):
    """A description key set to anything: a description whose base is the model's root and whose
    numbers are in range, or a RobotFileError of one line naming the file."""
    directory = tmp_path_factory.mktemp("toml")
    description = _edited(directory, "urdf", "<robot", "<robot")
    data = tomllib.loads(description.read_text())
    table, _, name = key.rpartition(".")
    (data[table] if table else data)[name] = value
    description.write_text(toml(data))
    started = time.monotonic()
    try:
        robot = load_description(description)
    except RobotFileError as exc:
        assert str(description.resolve()) in str(exc) and "\n" not in str(exc), str(exc)
    else:
        assert robot.base_body == "pelvis"
        assert 0.0 < robot.contact_radius <= 0.1
        assert all(0.0 < s <= 2.0 for s in robot.sole_size)
    assert time.monotonic() - started < EXAMPLE_BOUND


# --- a description built in Python ---------------------------------------------------------------


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"contact_radius": math.nan}, r"robot 'g1': contact_radius = nan"),
        ({"contact_radius": -0.01}, r"robot 'g1': contact_radius = -0.01"),
        ({"sole_size": (0.17, math.inf)}, r"robot 'g1': sole_size\[1\] = inf"),
    ],
)
def test_a_g1_built_in_python_with_a_bad_number_is_refused_before_drake(change, message):
    g1 = robot_or_skip("g1")
    with pytest.raises(ValueError, match=message):
        dataclasses.replace(g1, **change)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: Drive(kp=-200.0, kd=4.0, effort=10.0), r"drive kp = -200.0: must be in \[0, "),
        (lambda: Drive(kp=math.nan, kd=4.0, effort=10.0), r"drive kp = nan"),
        (lambda: Drive(kp=200.0, kd=-1.0, effort=10.0), r"drive kd = -1.0"),
        (lambda: Drive(kp=200.0, kd=1.0, effort=0.0), r"drive effort = 0.0"),
        (lambda: FrameSpec("pelvis", (0.0, 0.0, 1e308)), r"frame on 'pelvis'.xyz\[2\] = 1e\+308"),
    ],
)
def test_a_drive_or_frame_built_in_python_with_a_bad_number_is_refused(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_a_g1_with_a_negative_gain_built_in_python_is_refused_and_a_good_one_loads():
    """The report's case: ``kp`` -200 on one joint of the G1 (Drake's SystemExit before); the
    same robot with kp 200 loads, its actuator with that gain."""
    from pydrake.multibody.plant import MultibodyPlant

    from drake_sot.robots.loading import load_robot

    g1 = robot_or_skip("g1")
    joint = next(iter(g1.drives))
    with pytest.raises(ValueError, match=re.escape("drive kp = -200.0")):
        dataclasses.replace(g1, drives={**g1.drives, joint: dataclasses.replace(g1.drives[joint], kp=-200.0)})
    robot = dataclasses.replace(
        g1, drives={**g1.drives, joint: dataclasses.replace(g1.drives[joint], kp=200.0)}
    )
    plant = MultibodyPlant(0.001)
    load_robot(plant, robot, collision=False)
    plant.Finalize()
    assert plant.GetJointActuatorByName(joint).get_controller_gains().p == 200.0
