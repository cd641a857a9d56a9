"""TALOS and the G1 fall as the embedded robot does: the collision shapes of their limbs keep
every body above the ground, the standing robot touches nothing but with its soles, and a
3000 N shove knocks it down, which ``drake-sot run`` reports with exit status 3."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from pydrake.geometry import Mesh, Role
from pydrake.systems.framework import DiagramBuilder
from robot_data import robot_or_skip

from drake_sot.app import cli
from drake_sot.diagrams.tasks import FALL_CRITERIA
from drake_sot.diagrams.world import add_humanoid_plant
from drake_sot.models.humanoid import half_sitting_configuration

pytestmark = pytest.mark.slow
ROBOTS = ("talos", "g1")
#: What "lying on the ground" allows: no part of the body deeper than this below z = 0 [m].
SINK = -0.02


class _World:
    """The robot on the ground as the builders simulate it (meshes, limb shapes, soles)."""

    def __init__(self, name: str) -> None:
        builder = DiagramBuilder()
        self.plant, self.scene_graph, self.info = add_humanoid_plant(builder, robot=name)
        self.diagram = builder.Build()
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = self.plant.GetMyMutableContextFromRoot(self.context)

    def set_q(self, q: np.ndarray) -> None:
        self.plant.SetPositions(self.plant_context, self.info.model_instance, q)

    def lowest_visual_points(self) -> dict[str, float]:
        """Body name → the lowest z [m] of the body's *visual* meshes (the vertices of the
        robot's own mesh files, read with trimesh; not the collision shapes)."""
        if not hasattr(self, "_meshes"):
            inspector = self.scene_graph.model_inspector()
            self._meshes = []  # (body, X_BG, vertices in G)
            for geometry in inspector.GetAllGeometryIds(Role.kIllustration):
                shape = inspector.GetShape(geometry)
                body = self.plant.GetBodyFromFrameId(inspector.GetFrameId(geometry))
                if (
                    isinstance(shape, Mesh)
                    and body is not None
                    and body.model_instance() == self.info.model_instance
                ):
                    vertices = np.asarray(trimesh.load(shape.source().path(), force="mesh").vertices)
                    self._meshes.append((body, inspector.GetPoseInFrame(geometry), vertices * shape.scale3()))
        lowest: dict[str, float] = {}
        for body, X_BG, vertices in self._meshes:
            X_WG = body.EvalPoseInWorld(self.plant_context) @ X_BG
            z = X_WG.rotation().matrix()[2] @ vertices.T + X_WG.translation()[2]
            lowest[body.name()] = min(lowest.get(body.name(), np.inf), float(z.min()))
        return lowest


@pytest.mark.parametrize("name", ROBOTS)
def test_the_standing_robot_touches_only_the_ground_and_only_with_its_soles(name):
    """In half-sitting no two shapes of the robot that may collide overlap (the limbs' shapes
    clear each other and the trunk), and only the soles' spheres touch the ground."""
    robot_or_skip(name)
    world = _World(name)
    world.set_q(half_sitting_configuration(world.plant, world.info))
    query = world.scene_graph.get_query_output_port().Eval(
        world.scene_graph.GetMyContextFromRoot(world.context)
    )
    inspector = query.inspector()
    pairs = [
        (inspector.GetName(p.id_A), inspector.GetName(p.id_B)) for p in query.ComputePointPairPenetration()
    ]
    assert all("sole_contact" in a or "sole_contact" in b for a, b in pairs), pairs
    # ...and close to it: 5 mm clearance between any other pair (the shapes are not slack).
    near = query.ComputeSignedDistancePairwiseClosestPoints(max_distance=0.005)
    near = [(inspector.GetName(d.id_A), inspector.GetName(d.id_B)) for d in near]
    assert all("sole_contact" in a or "sole_contact" in b for a, b in near), near


@pytest.mark.parametrize("name", ROBOTS)
def test_a_3000_N_shove_knocks_the_robot_down_onto_its_limbs_and_the_command_exits_3(name, tmp_path, capsys):
    robot_or_skip(name)
    argv = ["run", "reach", "--robot", name, "--duration", "5", "--no-record", "--out", str(tmp_path)]
    code = cli.main([*argv, "--push", "0.5,pelvis,0,3000,0,0.1"])
    err = capsys.readouterr().err
    assert code == 3, err
    assert "the robot fell at t = " in err
    logs = np.load(tmp_path / "reach.npz")
    fall_time, height, tilt = logs["fall"]
    assert 0.5 < fall_time < 0.5 + 1.5
    assert height < FALL_CRITERIA.min_pelvis_height or tilt > FALL_CRITERIA.max_tilt
    # The run went on for stop_after so the robot came down, then stopped before its 5 s.
    assert logs["time"][-1] == pytest.approx(fall_time + FALL_CRITERIA.stop_after, abs=0.006)
    assert logs["fallen"][-1, 0] == 1.0 and logs["fallen"][0, 0] == 0.0
    # On the ground: the pelvis down, and no mesh of any body deeper than SINK, at every
    # logged sample of the fall (a limb through the floor would show on its way down).
    world = _World(name)
    assert logs["q"][-1, 6] < FALL_CRITERIA.min_pelvis_height
    deepest = (np.inf, "", 0.0)
    for t, q in zip(logs["time"][::10], logs["q"][::10], strict=True):
        world.set_q(q)
        body, z = min(world.lowest_visual_points().items(), key=lambda kv: kv[1])
        deepest = min(deepest, (z, body, t))
    assert deepest[0] > SINK, f"{name}: {deepest[1]} at z = {deepest[0]:.3f} m at t = {deepest[2]:.2f} s"
    lean = math.degrees(tilt)
    print(f"{name}: fell at {fall_time:.3f} s (pelvis {height:.3f} m, tilt {lean:.0f}°), deepest {deepest}")
