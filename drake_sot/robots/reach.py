"""The reach of a robot's arm, measured on its model: what lets a scenario express a hand
target relative to the shoulder and scaled to the arm, so that one target means the same
on every robot (in reach, or just out of it)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import RevoluteJoint
from pydrake.systems.framework import Context

from drake_sot.models.humanoid import HumanoidInfo


@dataclass(frozen=True)
class ArmReach:
    """An arm at a configuration: ``shoulder`` (3,) [m] the world position of the shoulder's
    centre of rotation (the point nearest the axes of its first three joints, in the least
    squares sense: where they meet on a ball-like shoulder, as on the embedded robot and
    TALOS; the G1's roll and yaw axes pass 4 and 10 cm from its pitch joint's origin),
    ``reach`` [m] the length of the chain from there through the origins of the next joints
    to the hand point (an upper bound of the hand's distance from the shoulder, whatever
    the joint angles), ``joints`` the joint names from the torso to the hand."""

    shoulder: np.ndarray
    reach: float
    joints: tuple[str, ...]


def arm_reach(plant: MultibodyPlant, info: HumanoidInfo, side: str, context: Context) -> ArmReach:
    """The ``side`` ("left" or "right") arm of the robot in a finalized ``plant``, from the
    torso body to the logical frame ``{side}_hand``, at the configuration of ``context``.

    Raises ValueError for another side, when the hand is not below the torso in the tree,
    or when the arm does not start with three revolute joints (a shoulder).
    """
    if side not in ("left", "right"):
        raise ValueError(f"side = {side!r}: must be 'left' or 'right'")
    hand = plant.GetFrameByName(info.frames[f"{side}_hand"], info.model_instance)
    torso = plant.GetFrameByName(info.frames["torso"], info.model_instance).body().index()
    joint_to = {}  # child body -> the joint that carries it
    for index in plant.GetJointIndices(info.model_instance):
        joint = plant.get_joint(index)
        joint_to[joint.child_body().index()] = joint
    chain, body = [], hand.body()
    while body.index() != torso:
        if body.index() not in joint_to:
            raise ValueError(f"{side} hand {hand.name()!r}: not on a chain below the torso")
        chain.append(joint_to[body.index()])
        body = chain[-1].parent_body()
    chain.reverse()
    names = tuple(j.name() for j in chain)
    shoulder = chain[:3]
    if len(chain) < 4 or any(j.type_name() != RevoluteJoint.kTypeName for j in shoulder):
        raise ValueError(f"{side} arm {names}: does not start with three revolute joints")
    # The point p nearest the three axes (origin o, unit direction a): sum (I - a a^T)(p - o) = 0.
    normal, right = np.zeros((3, 3)), np.zeros(3)
    for joint in shoulder:
        X_WJ = joint.frame_on_child().CalcPoseInWorld(context)
        axis = X_WJ.rotation().matrix() @ joint.revolute_axis()
        projector = np.eye(3) - np.outer(axis, axis)
        normal += projector
        right += projector @ X_WJ.translation()
    centre = np.linalg.solve(normal, right)
    points = [centre]
    points += [j.frame_on_child().CalcPoseInWorld(context).translation() for j in chain[3:]]
    points.append(hand.CalcPoseInWorld(context).translation())
    reach = float(sum(np.linalg.norm(b - a) for a, b in zip(points, points[1:], strict=False)))
    return ArmReach(shoulder=centre, reach=reach, joints=names)
