"""Helpers for the system tests: random configurations, retraction with Drake's q̇ map,
and a diagram that evaluates features at any configuration."""

import numpy as np
from pydrake.systems.framework import DiagramBuilder

from drake_sot.systems.kinematics import RobotKinematics


def random_configuration(plant, q0, rng, spread=0.4):
    """q0 with a random base pose and joints moved by up to ``spread`` rad, inside the limits."""
    q = q0.copy()
    axis = rng.normal(size=3)
    angle = rng.uniform(0, 1.0)
    axis /= np.linalg.norm(axis)
    q[:4] = np.concatenate(([np.cos(angle / 2)], np.sin(angle / 2) * axis))
    q[4:7] += rng.normal(scale=0.2, size=3)
    lower, upper = plant.GetPositionLowerLimits(), plant.GetPositionUpperLimits()
    joints = q[7:] + rng.uniform(-spread, spread, size=q.size - 7)
    q[7:] = np.clip(joints, lower[7:] + 1e-3, upper[7:] - 1e-3)
    return q


def retract(plant, q, v, eps):
    """q moved by eps·v on the configuration manifold, with Drake's own q̇ map (not ours)."""
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    qdot = plant.MapVelocityToQDot(context, v)
    q_next = q + eps * qdot
    q_next[:4] /= np.linalg.norm(q_next[:4])
    return q_next


class FeatureBench:
    """``dyn`` plus features in one diagram whose only free input is q."""

    def __init__(self, plant, features, op_points=(), q_inputs=()):
        builder = DiagramBuilder()
        self.dyn = builder.AddSystem(RobotKinematics(plant))
        for name, frame in op_points:
            self.dyn.add_operational_point(name, frame)
        self.features = [builder.AddSystem(f) for f in features]
        self._wire = builder
        self._plant = plant
        self._q_inputs = list(q_inputs)

    def connect(self, src, dst):
        self._wire.Connect(src, dst)

    def build(self):
        builder = self._wire
        builder.ExportInput(self.dyn.GetInputPort("q"), "q")
        for feature in self._q_inputs:
            builder.ConnectInput("q", feature.GetInputPort("q"))
        self.diagram = builder.Build()
        self.context = self.diagram.CreateDefaultContext()
        return self

    def signal(self, feature, q):
        self.diagram.get_input_port(0).FixValue(self.context, q)
        return feature.GetOutputPort("feature").Eval(feature.GetMyContextFromRoot(self.context))
