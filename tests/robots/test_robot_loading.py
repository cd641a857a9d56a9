"""Loading TALOS and the G1 without hand edits: the URDF fixes, the mesh cache, the errors."""

from __future__ import annotations

import dataclasses
import re
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlant, MultibodyPlantConfig
from pydrake.multibody.tree import WeldJoint
from pydrake.systems.framework import DiagramBuilder
from robot_data import robot_or_skip

from drake_sot.models import half_sitting_configuration
from drake_sot.robots import catalog, load_robot
from drake_sot.robots.description import LOGICAL_FRAMES
from drake_sot.robots.meshes import CACHE_ENV, converted_mesh
from drake_sot.robots.urdf import AddedWeld, prepare_urdf, resolve_package_uri

_URDF = """<robot name="r">
  <material name="Grey"><color rgba="0.2 0.2 0.2 1"/></material>
  <link name="base">
    <visual><geometry><mesh filename="package:///pkg/m.stl" scale="1 -1 1"/></geometry>
      <material name="Grey"><color rgba="0.5 0.5 0.5 1"/></material></visual>
    <collision><geometry><mesh filename="package://pkg/m.stl"/></geometry></collision>
  </link>
  <link name="a"/><link name="b"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="5" velocity="1"/><dynamics damping="0.1" friction="0.3"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="5" velocity="1"/><mimic joint="j1"/></joint>
  <transmission name="t"><joint name="j1"/></transmission>
</robot>"""


@pytest.fixture
def package(tmp_path):
    """A package ``pkg`` holding one STL tetrahedron."""
    import trimesh

    root = tmp_path / "pkg"
    root.mkdir()
    trimesh.creation.box(extents=(0.1, 0.2, 0.3)).export(root / "m.stl")
    return {"pkg": root}


def test_each_urdf_fix_is_applied_and_listed(package, tmp_path):
    seen = []

    def mesh_file(source, scale):
        seen.append((source, scale))
        return "package://converted/m.obj"

    text, fixes = prepare_urdf(
        _URDF,
        packages=package,
        mesh_file=mesh_file,
        added_welds=[AddedWeld("ft", "b", "sensor_link", (0.0, 0.0, -0.1))],
    )
    root = ET.fromstring(text)
    assert "package:///" not in text
    assert seen == [(package["pkg"] / "m.stl", (1.0, -1.0, 1.0))]
    assert root.find("link/visual/geometry/mesh").get("filename") == "package://converted/m.obj"
    assert root.find("link/visual/geometry/mesh").get("scale") is None  # baked into the OBJ
    assert root.find("link/visual/material/color") is None  # the conflicting colour dropped
    assert root.find("material/color").get("rgba") == "0.2 0.2 0.2 1"  # the first definition kept
    assert root.find("link/collision") is None and root.find("transmission") is None
    joints = {j.get("name"): j for j in root.findall("joint")}
    assert joints["j2"].get("type") == "fixed" and joints["j2"].find("mimic") is None
    assert "friction" not in joints["j1"].find("dynamics").attrib
    assert joints["ft"].get("type") == "fixed" and joints["ft"].find("parent").get("link") == "b"
    assert len(fixes) == 8, fixes  # typos, material, mimic, transmission, friction, collision, mesh, weld
    assert fixes[0].startswith("1 'package:///'")


def test_the_fixed_model_loads_in_drake(package):
    text, _ = prepare_urdf(_URDF, packages=package, mesh_file=None)
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(text, "urdf")
    plant.Finalize()
    assert plant.num_velocities() == 6 + 1  # the floating base and j1; j2 is fixed


def test_unknown_package_and_missing_mesh_are_named(package):
    with pytest.raises(ValueError, match="unknown package 'other'.*known: pkg"):
        resolve_package_uri("package://other/m.stl", package)
    with pytest.raises(FileNotFoundError, match="nope.stl"):
        resolve_package_uri("package://pkg/nope.stl", package)


def test_mesh_cache_is_reused_and_a_corrupt_entry_rebuilt(tmp_path):
    talos = robot_or_skip("talos")
    source = talos.packages["example-robot-data"] / "robots/talos_data/meshes/torso/torso_2.STL"
    cache = tmp_path / "cache"
    start = time.perf_counter()
    first = converted_mesh(source, (1.0, 1.0, 1.0), cache)
    converting = time.perf_counter() - start
    mtime = first.stat().st_mtime_ns
    start = time.perf_counter()
    second = converted_mesh(source, (1.0, 1.0, 1.0), cache)
    reusing = time.perf_counter() - start
    assert second == first and second.stat().st_mtime_ns == mtime  # not rewritten
    assert reusing < converting / 10, (reusing, converting)
    # A truncated entry (a crash while writing, a full disk) is rebuilt.
    text = first.read_text()
    first.write_text(text[: len(text) // 2])
    rebuilt = converted_mesh(source, (1.0, 1.0, 1.0), cache)
    assert rebuilt.read_text() == text


def test_a_mirrored_mesh_is_mirrored_with_outward_faces(package, tmp_path):
    import trimesh

    source = package["pkg"] / "m.stl"
    original = trimesh.load(source, force="mesh")
    mirrored = trimesh.load(converted_mesh(source, (1.0, -1.0, 1.0), tmp_path), force="mesh")
    expected = original.vertices * [1.0, -1.0, 1.0]
    assert np.allclose(np.sort(mirrored.vertices, axis=0), np.sort(expected, axis=0), atol=1e-5)
    assert mirrored.volume == pytest.approx(0.1 * 0.2 * 0.3, rel=1e-4)  # > 0: normals point outwards


def test_missing_model_file_is_named(tmp_path):
    talos = robot_or_skip("talos")
    missing = tmp_path / "nowhere" / "talos.urdf"
    with pytest.raises(FileNotFoundError, match=str(missing)):
        load_robot(MultibodyPlant(0.0), dataclasses.replace(talos, model_file=missing))


def test_without_example_robot_data_the_error_says_how_to_install(monkeypatch, tmp_path):
    monkeypatch.setenv(catalog.DATA_ENV, str(tmp_path / "absent"))
    catalog.talos.cache_clear()
    try:
        with pytest.raises(catalog.RobotDataMissing, match=r"pip install 'drake_sot\[robots\]'"):
            catalog.get_robot("talos")
    finally:
        catalog.talos.cache_clear()


def _urdf_mass(path: Path) -> float:
    return sum(float(m.get("value")) for m in ET.parse(path).getroot().iter("mass"))


@pytest.mark.parametrize("name", ["talos", "g1"])
def test_robot_loads_with_geometry_and_stands_on_its_soles(name, tmp_path):
    robot = robot_or_skip(name)
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=1e-3), builder)
    info = load_robot(plant, name, mesh_cache=tmp_path)
    plant.Finalize()
    frozen = sum(1 for _ in tmp_path.glob("*.obj"))
    assert frozen > 20  # the visual meshes were converted
    # Mass: the URDF's inertial masses (frozen gripper links included) plus the added sensor links.
    assert info.mass == pytest.approx(_urdf_mass(robot.model_file) + 0.01 * len(robot.added_welds))
    assert set(info.frames) >= set(LOGICAL_FRAMES)
    assert info.actuated_joints == tuple(robot.drives)
    for joint in info.force_sensors.values():
        assert isinstance(plant.GetJointByName(joint, info.model_instance), WeldJoint)
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, half_sitting_configuration(plant, info))
    for foot in ("left_foot", "right_foot"):
        X = plant.GetFrameByName(info.frames[foot], info.model_instance).CalcPoseInWorld(context)
        assert X.translation()[2] == pytest.approx(0.0, abs=1e-9)
        assert np.allclose(X.rotation().matrix(), np.eye(3), atol=1e-2)  # sole flat on the ground
    # Four contact spheres per sole.
    assert (
        len(plant.GetCollisionGeometriesForBody(plant.GetFrameByName(info.frames["left_foot"]).body())) == 4
    )


def test_talos_half_sitting_is_the_srdf_one():
    talos = robot_or_skip("talos")
    plant = MultibodyPlant(0.0)
    info = load_robot(plant, talos)
    plant.Finalize()
    q = half_sitting_configuration(plant, info)
    srdf = ET.parse(talos.packages["example-robot-data"] / "robots/talos_data/srdf/talos.srdf").getroot()
    state = next(s for s in srdf.iter("group_state") if s.get("name") == "half_sitting")
    values = {j.get("name"): [float(v) for v in j.get("value").split()] for j in state.iter("joint")}
    assert q[6] == pytest.approx(values["root_joint"][2], abs=1e-4)  # pelvis height, soles on z = 0
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    for joint, (angle,) in ((j, v) for j, v in values.items() if j != "root_joint"):
        assert plant.GetJointByName(joint).get_angle(context) == pytest.approx(angle)


@pytest.mark.parametrize("name", sorted(catalog.ROBOTS))
def test_a_robots_title_gives_its_mass_and_joints_as_the_loaded_plant_has_them(name):
    """``drake-sot list --robots`` prints the titles: the "N kg, M joints" in each is the loaded
    model's total mass (to the kilogram) and its number of actuated joints."""
    robot = robot_or_skip(name)
    found = re.search(r"[(;] ?(\d+) kg, (\d+) joints", robot.title)
    assert found, robot.title
    plant = MultibodyPlant(0.0)
    info = load_robot(plant, robot)
    plant.Finalize()
    assert abs(plant.CalcTotalMass(plant.CreateDefaultContext()) - int(found[1])) <= 0.5, robot.title
    assert plant.num_actuators() == int(found[2]) == len(info.actuated_joints), robot.title


_EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "robot"


@pytest.mark.parametrize("model", ["humanoid.toml", "humanoid_sdf.toml", "humanoid_mjcf.toml"])
@pytest.mark.parametrize("cache", ["argument", "environment"])
def test_a_robot_without_meshes_to_convert_loads_where_the_mesh_cache_does_not_exist(
    model, cache, tmp_path, monkeypatch
):
    """A user's robot of primitive shapes, on a machine that never converted a mesh: nothing names
    the cache, which is neither required nor created (Drake refuses a package whose directory is
    missing)."""
    absent = tmp_path / "never" / "made"
    monkeypatch.setenv(CACHE_ENV, str(absent if cache == "environment" else tmp_path / "unused"))
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=1e-3), builder)
    robot = str(_EXAMPLE / model)
    info = load_robot(plant, robot, mesh_cache=absent if cache == "argument" else None)
    plant.Finalize()
    assert not absent.exists()
    assert info.mass > 10.0
    # Its shapes were registered: the visuals and collision geometry of every link.
    inspector = scene_graph.model_inspector()
    assert len(inspector.GetAllGeometryIds()) >= plant.num_bodies() - 1
