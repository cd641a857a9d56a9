"""The anchored walk's balance stabilizer compares references and measurements in one world:
the robot's. It is fed the pattern generator's CoM (not the anchored one), and its corrected
CoM reaches the CoM task through the stance anchor, mapped into the reference's world like
the feet. (Fed the anchored CoM, the stabilizer read the anchor's drift as a DCM error and
its CoM offset grew with it, 2.2 times the drift: the random walk fell after 2 minutes.)

No simulation: the diagram is built, the anchor is given a drift and the stabilizer an
offset in their states, and the ports are read."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from drake_sot.anchoring import PlanarTransform
from drake_sot.diagrams import walk_random

DRIFT = PlanarTransform(0.04, -0.03, 0.3)  # [m, m, rad] the reference's world from the robot's
OFFSET = np.array([0.02, -0.01])  # [m] the stabilizer's CoM offset
RATE = np.array([0.05, 0.03])  # [m/s] its rate


def _rotated(v: np.ndarray) -> np.ndarray:
    c, s = math.cos(DRIFT.yaw), math.sin(DRIFT.yaw)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def test_the_stabilizer_measures_in_the_robots_world_and_its_com_is_anchored():
    setup = walk_random.build(seed=0)
    diagram, pg = setup.built.diagram, setup.extras.pattern_generator
    anchor = diagram.GetSubsystemByName("stance_anchor")
    stabilizer = diagram.GetSubsystemByName("stabilizer")
    feature = setup.built.features["taskCom"]
    context = diagram.CreateDefaultContext()
    anchor_state = anchor.GetMyMutableContextFromRoot(context).get_mutable_abstract_state(0)
    anchor_state.set_value(dataclasses.replace(anchor_state.get_value(), delta=DRIFT))
    held = stabilizer.GetMyMutableContextFromRoot(context).get_mutable_discrete_state(0)
    vector = held.CopyToVector()
    vector[:4] = np.concatenate([OFFSET, RATE])
    held.SetFromVector(vector)

    def read(system, port):
        return np.asarray(port.Eval(system.GetMyContextFromRoot(context)))

    np.testing.assert_allclose(read(anchor, anchor.GetOutputPort("drift")), [DRIFT.x, DRIFT.y, DRIFT.yaw])
    np.testing.assert_allclose(read(stabilizer, stabilizer.GetOutputPort("offset")), OFFSET)
    com = read(pg, pg.GetOutputPort("com"))
    com_vel = read(pg, pg.GetOutputPort("com_vel"))
    # the stabilizer's CoM reference is the generator's, in the robot's world (where it measures)
    np.testing.assert_allclose(read(stabilizer, stabilizer.GetInputPort("com_ref")), com)
    np.testing.assert_allclose(read(stabilizer, stabilizer.GetInputPort("com_vel_ref")), com_vel)
    # the CoM task's reference: the corrected CoM (generator's + offset), mapped by the drift
    corrected = com[:2] + OFFSET
    expected = _rotated(corrected) + [DRIFT.x, DRIFT.y]
    sdes = read(feature, feature.GetInputPort("sdes"))
    np.testing.assert_allclose(sdes[:2], expected, atol=1e-12)
    assert sdes[2] == com[2]
    sdes_dot = read(feature, feature.GetInputPort("sdes_dot"))
    np.testing.assert_allclose(sdes_dot[:2], _rotated(com_vel[:2] + RATE), atol=1e-12)
