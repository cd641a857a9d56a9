"""Your own robot as a URDF, an SDF or an MJCF model: the three files of ``examples/robot`` are one
robot, checked on the plants Drake builds from each (joints, mass, CoM, mass matrix, frames,
sensor welds) and on the embedded tables they were written from; the tree read from small
models using each format's features against Drake's own parse of them; the fixes of each
format, meshes beside the model included; the draft of each format; the refusals, each naming
the file and what is accepted."""

from __future__ import annotations

import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydrake.geometry import Mesh, Role
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.systems.framework import DiagramBuilder
from robot_data import assert_mutated_model_is_drafted_or_refused

from drake_sot.models import humanoid
from drake_sot.robots import RobotFileError
from drake_sot.robots.description import FORCE_SENSORS, LOGICAL_FRAMES
from drake_sot.robots.description_file import RobotDescriptionError, description_path, load_description
from drake_sot.robots.draft import draft_description
from drake_sot.robots.loading import load_robot, make_robot_control_model
from drake_sot.robots.mjcf import prepare_mjcf
from drake_sot.robots.model_tree import read_model_tree
from drake_sot.robots.sdf import prepare_sdf
from drake_sot.robots.urdf import AddedWeld

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "robot"
DESCRIPTIONS = {
    "urdf": EXAMPLE / "humanoid.toml",
    "sdf": EXAMPLE / "humanoid_sdf.toml",
    "mjcf": EXAMPLE / "humanoid_mjcf.toml",
}
MODELS = {"urdf": "humanoid.urdf", "sdf": "humanoid.sdf", "mjcf": "humanoid.xml"}


@pytest.fixture(scope="module")
def plants():
    """Format → (robot, control plant, info), each loaded from its description."""
    loaded = {}
    for fmt, path in DESCRIPTIONS.items():
        robot = load_description(path)
        loaded[fmt] = (robot, *make_robot_control_model(robot))
    return loaded


def _context(plant: MultibodyPlant, info, angles: dict[str, float], X_WB: RigidTransform):
    context = plant.CreateDefaultContext()
    for name, angle in angles.items():
        plant.GetJointByName(name).set_angle(context, angle)
    plant.SetFloatingBaseBodyPoseInWorldFrame(context, plant.GetBodyByName(info.base_body), X_WB)
    return context


def _velocity_order(plant: MultibodyPlant, info, names) -> list[int]:
    """The plant's velocity indices: the floating base's 6, then the joints of ``names``."""
    base = plant.GetBodyByName(info.base_body)
    (free,) = [
        plant.get_joint(i)
        for i in plant.GetJointIndices(info.model_instance)
        if plant.get_joint(i).child_body().index() == base.index()
        and plant.get_joint(i).num_velocities() == 6
    ]
    start = free.velocity_start()
    return [*range(start, start + 6), *(plant.GetJointByName(n).velocity_start() for n in names)]


def test_the_three_files_have_the_joints_limits_and_efforts_of_the_embedded_tables(plants):
    tables = {j.name: j for j in humanoid.JOINTS}
    for fmt, (robot, plant, info) in plants.items():
        assert sorted(info.actuated_joints) == sorted(tables), fmt
        assert plant.num_actuators() == len(tables), f"{fmt}: Drake's own actuators were not left out"
        for name, joint in tables.items():
            drake_joint = plant.GetJointByName(name)
            assert drake_joint.type_name() == "revolute", (fmt, name)
            assert drake_joint.position_lower_limits()[0] == pytest.approx(joint.limits[0], abs=1e-9)
            assert drake_joint.position_upper_limits()[0] == pytest.approx(joint.limits[1], abs=1e-9)
            effort = humanoid.DRIVES[name.removeprefix("r_").removeprefix("l_")].effort
            assert plant.GetJointActuatorByName(name).effort_limit() == pytest.approx(effort, rel=1e-9)
            assert robot.drives[name].effort == pytest.approx(effort, rel=1e-9)


@pytest.mark.parametrize("posture", ["half_sitting", "random"])
def test_the_three_plants_are_one_robot_mass_com_mass_matrix_and_frames(plants, posture):
    """Equal total mass (the tables' sum), CoM, mass matrix (in one velocity order) and logical
    frames' poses at half-sitting and at a random configuration with the base moved."""
    names = [j.name for j in humanoid.JOINTS]
    rng = np.random.default_rng(7)
    if posture == "half_sitting":
        angles = dict(plants["urdf"][0].half_sitting)
        X_WB = RigidTransform([0.0, 0.0, 0.8])
    else:
        angles = {j.name: rng.uniform(*j.limits) for j in humanoid.JOINTS}
        X_WB = RigidTransform(RollPitchYaw(rng.uniform(-1.0, 1.0, 3)), rng.uniform(-1.0, 1.0, 3))
    measured = {}
    for fmt, (_, plant, info) in plants.items():
        context = _context(plant, info, angles, X_WB)
        order = _velocity_order(plant, info, names)
        frames = {
            key: plant.GetFrameByName(info.frames[key]).CalcPoseInWorld(context).GetAsMatrix4()
            for key in LOGICAL_FRAMES
        }
        measured[fmt] = (
            plant.CalcTotalMass(context),
            plant.CalcCenterOfMassPositionInWorld(context),
            plant.CalcMassMatrix(context)[np.ix_(order, order)],
            frames,
        )
    assert measured["urdf"][0] == pytest.approx(sum(link.mass for link in humanoid.LINKS), rel=1e-12)
    mass, com, M, frames = measured["urdf"]
    for fmt in ("sdf", "mjcf"):
        other_mass, other_com, other_M, other_frames = measured[fmt]
        assert other_mass == pytest.approx(mass, rel=1e-9), fmt
        np.testing.assert_allclose(other_com, com, rtol=1e-9, atol=1e-9 * np.linalg.norm(com), err_msg=fmt)
        np.testing.assert_allclose(other_M, M, rtol=1e-9, atol=1e-9 * np.abs(M).max(), err_msg=fmt)
        for key in LOGICAL_FRAMES:
            np.testing.assert_allclose(other_frames[key], frames[key], atol=1e-9, err_msg=f"{fmt} {key}")


def test_the_force_sensor_welds_join_the_same_bodies_in_each_format(plants):
    """The sensor welds of the three files exist under each format's names, weld the tables' bodies,
    and hold the child where the tables put it (``drop`` below the parent's origin)."""
    sensors = {name: (parent, child, drop) for name, parent, child, drop in humanoid.SENSORS}
    for fmt, (_, plant, info) in plants.items():
        context = plant.CreateDefaultContext()
        for key in FORCE_SENSORS:
            joint = plant.GetJointByName(info.force_sensors[key])
            assert joint.type_name() == "weld", (fmt, key)
            (parent, child, drop) = next(
                (p, c, d) for p, c, d in sensors.values() if c == joint.child_body().name()
            )
            assert joint.parent_body().name() == parent, (fmt, key)
            X_PC = joint.child_body().body_frame().CalcPose(context, joint.parent_body().body_frame())
            np.testing.assert_allclose(X_PC.translation(), [0.0, 0.0, -drop], atol=1e-12, err_msg=fmt)
            assert np.allclose(X_PC.rotation().matrix(), np.eye(3), atol=1e-12), fmt


def _drafted(fmt: str, directory: Path) -> dict:
    model = directory / MODELS[fmt]
    shutil.copy(EXAMPLE / MODELS[fmt], model)
    return tomllib.loads(draft_description(model).text)


def test_the_draft_of_each_format_guesses_what_the_urdf_draft_guesses(tmp_path):
    """The same frames, sole, posture and drives; the sensors under each format's weld names."""
    urdf = _drafted("urdf", tmp_path)
    mjcf_names = {name: f"{parent}_welds_to_{child}" for name, parent, child, _ in humanoid.SENSORS}
    for fmt in ("sdf", "mjcf"):
        drafted = _drafted(fmt, tmp_path)
        for key in ("frames", "sole_size", "half_sitting", "drives", "base_body"):
            assert drafted[key] == urdf[key], (fmt, key)
        expected = urdf["force_sensors"]
        if fmt == "mjcf":
            expected = {key: mjcf_names[name] for key, name in expected.items()}
        assert drafted["force_sensors"] == expected, fmt


def _drake_tree(path: Path, base: str):
    """Drake's parse of ``path``, the base at the origin: body → (rotation, position) in the base's frame."""
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(str(path))
    plant.Finalize()
    context = plant.CreateDefaultContext()
    if plant.GetBodyByName(base).is_floating_base_body():
        plant.SetFloatingBaseBodyPoseInWorldFrame(context, plant.GetBodyByName(base), RigidTransform())
    return plant, context


def _assert_tree_is_drakes(path: Path) -> None:
    """The tree read from ``path``: each link's pose, each revolute joint's world axis and limits,
    each weld's name, as Drake's parser builds them."""
    tree = read_model_tree(path)
    plant, context = _drake_tree(path, tree.root)
    for link, (R, p) in tree.pose.items():
        X = plant.GetBodyByName(link).EvalPoseInWorld(context)
        np.testing.assert_allclose(X.rotation().matrix(), R, atol=1e-9, err_msg=link)
        np.testing.assert_allclose(X.translation(), p, atol=1e-9, err_msg=link)
    for joint in tree.joints.values():
        drake_joint = plant.GetJointByName(joint.name)
        if joint.kind == "fixed":
            assert drake_joint.type_name() == "weld", joint.name
            continue
        assert drake_joint.type_name() == "revolute", joint.name
        R_WF = drake_joint.frame_on_parent().CalcPoseInWorld(context).rotation().matrix()
        np.testing.assert_allclose(
            R_WF @ drake_joint.revolute_axis(),
            tree.pose[joint.child][0] @ joint.axis,
            atol=1e-9,
            err_msg=joint.name,
        )
        np.testing.assert_allclose(
            [drake_joint.position_lower_limits()[0], drake_joint.position_upper_limits()[0]],
            joint.limits,
            atol=1e-9,
            err_msg=joint.name,
        )


MJCF_FEATURES = """<mujoco model="m">
  <compiler angle="degree" eulerseq="zyX"/>
  <default>
    <joint axis="0 1 0" range="-30 60"/>
    <default class="arm"><joint axis="1 0 0" range="-90 10"/></default>
  </default>
  <worldbody>
    <body name="base" pos="0 0 1">
      <freejoint/>
      <geom type="box" size="0.1 0.1 0.1"/>
      <body name="a" pos="0.1 0.2 0.3" euler="10 20 30">
        <joint name="ja"/>
        <geom type="sphere" size="0.05"/>
        <body name="b" pos="0 0 -0.2" axisangle="1 1 0 40" childclass="arm">
          <joint name="jb"/>
          <geom type="sphere" size="0.05"/>
          <body name="c" quat="0.9 0.1 -0.3 0.2" pos="0.05 0 0"><geom type="sphere" size="0.05"/></body>
        </body>
      </body>
      <body name="d" xyaxes="0 1 0 -1 0 0.3" pos="0 -0.2 0">
        <joint name="d1" axis="0 0 1" range="-45 45"/>
        <joint name="d2" axis="1 0 0" range="-10 20"/>
        <geom type="sphere" size="0.05"/>
        <body name="e" zaxis="0.2 -0.5 0.7">
          <joint name="je" limited="false"/><geom type="sphere" size="0.05"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

SDF_FEATURES = """<sdf version="1.9">
  <model name="s">
    <link name="base"/>
    <frame name="mount" attached_to="base"><pose degrees="true">0.1 0 0.2 0 90 0</pose></frame>
    <link name="a"><pose relative_to="mount">0 0.1 0 0.3 0 0</pose></link>
    <link name="b"><pose relative_to="ja">0 0 -0.2 0 0 0.5</pose></link>
    <link name="c"><pose>0.3 0.2 0.1 0.1 0.2 0.3</pose></link>
    <joint name="ja" type="revolute">
      <pose>0 0 0.05 0 0 0</pose><parent>base</parent><child>a</child>
      <axis><xyz>0 1 0</xyz><limit><lower>-1</lower><upper>2</upper><effort>5</effort></limit></axis>
    </joint>
    <joint name="jb" type="revolute">
      <parent>a</parent><child>b</child>
      <axis>
        <xyz expressed_in="__model__">1 0 0</xyz><limit><lower>-0.5</lower><upper>0.5</upper></limit>
      </axis>
    </joint>
    <joint name="jc" type="fixed"><parent>b</parent><child>c</child></joint>
  </model>
</sdf>
"""


@pytest.mark.parametrize(("name", "text"), [("features.xml", MJCF_FEATURES), ("features.sdf", SDF_FEATURES)])
def test_the_tree_read_from_a_model_is_the_one_drake_parses(tmp_path, name, text):
    """MJCF: degrees, an extrinsic-intrinsic euler sequence, axis-angle, quaternion, xyaxes, zaxis,
    default classes and a child class, a body of two joints, an unlimited hinge, a jointless body;
    SDF: a <frame> in degrees, poses relative to a frame and to a joint, an axis expressed in the
    model frame, a fixed joint. Poses, axes and limits against Drake's own parse of the file."""
    path = tmp_path / name
    path.write_text(text)
    _assert_tree_is_drakes(path)


def _geometries(text: str, parser_type: str, role: Role) -> tuple[MultibodyPlant, int]:
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    Parser(plant).AddModelsFromString(text, parser_type)
    plant.Finalize()
    return plant, scene_graph.model_inspector().NumGeometriesWithRole(role)


def test_the_mjcf_fixes_drop_collisions_and_actuators_freeze_joints_and_weld_sensors():
    text = (EXAMPLE / "humanoid.xml").read_text()
    weld = AddedWeld("l_foot_welds_to_l_sole", "l_foot", "l_sole", (0.01, 0.0, -0.075))
    fixed, fixes = prepare_mjcf(
        text, directory=EXAMPLE, mesh_file=None, frozen_joints=("r_gripper",), added_welds=(weld,)
    )
    assert any("<actuator>" in fix for fix in fixes)
    plant, collisions = _geometries(fixed, "xml", Role.kProximity)
    assert collisions == 0 and plant.num_actuators() == 0
    assert _geometries(fixed, "xml", Role.kIllustration)[1] == len(humanoid.LINKS)  # the visuals stay
    assert _geometries(text, "xml", Role.kProximity)[1] == len(humanoid.LINKS)  # the file's geoms collide
    assert not plant.HasJointNamed("r_gripper")
    assert plant.GetJointByName("r_hand_welds_to_r_finger").type_name() == "weld"
    context = plant.CreateDefaultContext()
    X_FS = plant.GetFrameByName("l_sole").CalcPose(context, plant.GetFrameByName("l_foot"))
    np.testing.assert_allclose(X_FS.translation(), weld.xyz, atol=1e-12)
    assert plant.GetJointByName(weld.name).type_name() == "weld"
    with pytest.raises(ValueError, match="Drake names the weld of an MJCF body 'l_foot_welds_to_l_sole'"):
        prepare_mjcf(
            text,
            directory=EXAMPLE,
            mesh_file=None,
            added_welds=(AddedWeld("ft", "l_foot", "l_sole", (0, 0, 0)),),
        )


def test_the_sdf_fixes_drop_collisions_and_actuators_freeze_joints_and_weld_sensors():
    sphere = '<collision name="c"><geometry><sphere><radius>0.1</radius></sphere></geometry></collision>'
    visual = '<visual name="pelvis_visual">'
    text = (EXAMPLE / "humanoid.sdf").read_text().replace(visual, sphere + visual)
    assert _geometries(text, "sdf", Role.kProximity)[1] == 1
    weld = AddedWeld("l_sole_ft", "l_foot", "l_sole", (0.01, 0.0, -0.075))
    fixed, _ = prepare_sdf(
        text,
        directory=EXAMPLE,
        packages={},
        mesh_file=None,
        frozen_joints=("r_gripper",),
        added_welds=(weld,),
    )
    plant, collisions = _geometries(fixed, "sdf", Role.kProximity)
    assert collisions == 0 and plant.num_actuators() == 0
    assert plant.GetJointByName("r_gripper").type_name() == "weld"
    context = plant.CreateDefaultContext()
    X_FS = plant.GetFrameByName("l_sole").CalcPose(context, plant.GetFrameByName("l_foot"))
    np.testing.assert_allclose(X_FS.translation(), weld.xyz, atol=1e-12)
    assert plant.GetJointByName("l_sole_ft").type_name() == "weld"


# --- refusals, each naming the file and what is accepted -----------------------------------------


@pytest.mark.parametrize(
    ("name", "text", "message"),
    [
        ("bad.sdf", "<sdf", "not well-formed XML"),
        ("bad.xml", "garbage", "not well-formed XML"),
        ("bad.obj", "v 0 0 0", r"a model is a URDF \(.urdf\), an SDF \(.sdf\) or an MJCF \(.xml\)"),
        (
            "urdf.xml",
            "<robot name='r'/>",
            r"not an MJCF \(MuJoCo\) model \(its root is <robot>, not <mujoco>\)",
        ),
        ("urdf.sdf", "<robot name='r'/>", r"not an SDF \(its root is <robot>, not <sdf>\)"),
        (
            "two.sdf",
            "<sdf version='1.9'><model name='a'><link name='x'/></model>"
            "<model name='b'><link name='y'/></model></sdf>",
            r"an SDF robot is one <model> under <sdf>; it has 2",
        ),
        (
            "fixed.xml",
            "<mujoco><worldbody><body name='a'><geom type='sphere' size='1'/></body></worldbody></mujoco>",
            r"with a <freejoint> \(its floating base\); top bodies \['a'\], free \[\]",
        ),
        ("include.xml", "<mujoco><include file='robot.xml'/></mujoco>", "<include> is not read"),
    ],
)
def test_a_model_that_cannot_be_read_is_named_with_what_is_accepted(tmp_path, name, text, message):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(RobotFileError, match=message) as caught:
        draft_description(path)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)


def test_a_path_to_an_sdf_or_an_mjcf_finds_its_description(tmp_path):
    """``--robot robot.sdf`` (or ``.xml``) reads the ``robot.toml`` beside it, which must name that
    model; an ``.xml`` must be MJCF; another suffix is refused naming those accepted."""
    for fmt in ("sdf", "mjcf"):
        model = tmp_path / f"robot{Path(MODELS[fmt]).suffix}"
        shutil.copy(EXAMPLE / MODELS[fmt], model)
        text = DESCRIPTIONS[fmt].read_text().replace(f'model = "{MODELS[fmt]}"', f'model = "{model.name}"')
        model.with_suffix(".toml").write_text(text)
        assert description_path(model) == model.with_suffix(".toml")
        assert load_description(model).model_file == model
        model.with_suffix(".toml").unlink()
    with pytest.raises(RobotDescriptionError, match=r"describes model .*humanoid\.urdf, not .*humanoid\.sdf"):
        load_description(EXAMPLE / "humanoid.sdf")  # humanoid.toml, beside it, is the URDF's
    (tmp_path / "urdf.xml").write_text("<robot name='r'/>")
    with pytest.raises(RobotFileError, match=r"urdf\.xml: not an MJCF"):
        description_path(tmp_path / "urdf.xml")
    with pytest.raises(
        RobotDescriptionError, match=r"robot\.obj: a path must end with one of .toml, .urdf, .sdf, .xml"
    ):
        description_path(tmp_path / "robot.obj")


CUBE_STL = """solid cube
facet normal 0 0 -1
outer loop
vertex 0 0 0
vertex 0 1 0
vertex 1 0 0
endloop
endfacet
facet normal 0 -1 0
outer loop
vertex 0 0 0
vertex 1 0 0
vertex 0 0 1
endloop
endfacet
facet normal -1 0 0
outer loop
vertex 0 0 0
vertex 0 0 1
vertex 0 1 0
endloop
endfacet
facet normal 1 1 1
outer loop
vertex 1 0 0
vertex 0 1 0
vertex 0 0 1
endloop
endfacet
endsolid cube
"""


@pytest.mark.parametrize("fmt", ["sdf", "mjcf"])
def test_a_mesh_beside_the_model_is_found_though_the_text_is_parsed_from_memory(tmp_path, fmt):
    """The pelvis drawn by an STL in a directory beside the model (an SDF's relative URI, an MJCF's
    ``meshdir``): with a SceneGraph it is converted and drawn; without, the plant loads (an MJCF
    body with an <inertial> loses its mesh geom, as Drake's MJCF parser reads OBJ only)."""
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "pelvis.stl").write_text(CUBE_STL)
    text = (EXAMPLE / MODELS[fmt]).read_text()
    if fmt == "sdf":
        box = "<box>\n            <size>0.2 0.26 0.18</size>\n          </box>"
        assert box in text
        text = text.replace(box, "<mesh><uri>meshes/pelvis.stl</uri><scale>0.2 0.26 0.18</scale></mesh>", 1)
    else:
        geom = '<geom type="box" size="0.1 0.13 0.09" pos="0 0 0.07"'
        assert geom in text
        text = text.replace(geom, '<geom type="mesh" mesh="pelvis" pos="0 0 0.07"', 1).replace(
            '<compiler angle="radian" autolimits="true" />',
            '<compiler angle="radian" autolimits="true" meshdir="meshes" />'
            '<asset><mesh file="pelvis.stl" scale="0.2 0.26 0.18" /></asset>',
        )
    model = tmp_path / MODELS[fmt]
    model.write_text(text)
    description = DESCRIPTIONS[fmt].read_text()
    (tmp_path / DESCRIPTIONS[fmt].name).write_text(description)
    robot = load_description(tmp_path / DESCRIPTIONS[fmt].name)
    make_robot_control_model(robot)  # no SceneGraph: no mesh read
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.001)
    load_robot(plant, robot, mesh_cache=tmp_path / "cache")
    plant.Finalize()
    inspector = scene_graph.model_inspector()
    pelvis = plant.GetBodyFrameIdOrThrow(plant.GetBodyByName("pelvis").index())
    (mesh,) = [
        inspector.GetShape(g)
        for g in inspector.GetGeometries(pelvis, Role.kIllustration)
        if isinstance(inspector.GetShape(g), Mesh)
    ]
    assert Path(mesh.source().path()).parent == tmp_path / "cache"


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    element=st.integers(0, 10_000),
    attribute=st.sampled_from(
        ["name", "pos", "axis", "range", "size", "type", "mass", "joint", "forcerange"]
    ),
    value=st.none()
    | st.sampled_from(["nan", "inf", "1e999", "", "0 0 0", "pelvis", "l_foot", "1 2", "free", "box"])
    | st.text(max_size=6),
)
def test_a_fuzzed_mjcf_is_drafted_or_refused_in_one_line_naming_it(tmp_path, element, attribute, value):
    """One attribute of one element of the shipped MJCF deleted (None) or set to anything: the draft
    is a text or a RobotFileError naming the file, never an error from deep inside."""
    assert_mutated_model_is_drafted_or_refused(
        EXAMPLE / "humanoid.xml", tmp_path / "fuzzed.xml", element, attribute, value
    )


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    element=st.integers(0, 10_000),
    attribute=st.sampled_from(["name", "type", "relative_to", "version"]),  # the ones the file has
    value=st.none()
    | st.sampled_from(["", "pelvis", "l_foot", "world", "__model__", "fixed", "revolute", "true", "1e999"])
    | st.text(max_size=6),
)
def test_a_fuzzed_sdf_is_drafted_or_refused_in_one_line_naming_it(tmp_path, element, attribute, value):
    """One attribute of one element of the shipped SDF (a name, a joint's type, a pose's frame,
    the format's version) deleted (None) or set to anything: the draft is a text or a
    RobotFileError naming the file, never an error from deep inside."""
    assert_mutated_model_is_drafted_or_refused(
        EXAMPLE / "humanoid.sdf", tmp_path / "fuzzed.sdf", element, attribute, value
    )
