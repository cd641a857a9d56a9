"""``ZmpEstimator``: the measured ZMP from the ankle force/torque sensors of the simulated robot."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Context, ValueProducer

from drake_sot.statics import zmp_from_wrenches
from drake_sot.systems.leaf import SotLeafSystem


class ZmpEstimator(SotLeafSystem):
    """ZMP on the ground plane z = 0 from the 6-axis sensors between the ankles and the feet.

    Each sensor is a weld joint whose reaction force is the wrench the ankle exerts on
    the foot. The ground's wrench on a foot is taken as its opposite minus the foot's
    weight (the foot's own acceleration is neglected, as with a real F/T sensor); the
    ZMP is the point of the ground where the moment of the total ground wrench has no
    horizontal component.

    Input ports:
        reaction_forces: abstract ``list[SpatialForce]`` (the plant's ``reaction_forces``).
        body_poses: abstract ``list[RigidTransform]`` (the plant's ``body_poses``).
    Output ports:
        zmp: (2,) [m] measured ZMP; NaN when the feet carry less than ``min_force``.
        normal_force: (1,) [N] total vertical ground force on the feet.
        foot_forces: (k,) [N] vertical ground force on each foot, in the order of
            ``sensor_joints``.

    Args:
        plant: the simulated (finalized) plant.
        sensor_joints: names of the sensor weld joints (child body = the foot).
        min_force: below this total normal force [N] the ZMP is undefined (NaN).
    """

    def __init__(
        self, plant: MultibodyPlant, sensor_joints: Sequence[str], *, min_force: float = 20.0
    ) -> None:
        super().__init__()
        joints = [plant.GetJointByName(name) for name in sensor_joints]
        g = plant.gravity_field().gravity_vector()
        #: Per foot: the sensor joint's index, its child frame's pose in the foot body (R_BJ, p_BJ),
        #: the foot body's index, its weight [N] and its centre of mass in its frame.
        self._feet = []
        for joint in joints:
            X_BJ = joint.frame_on_child().GetFixedPoseInBodyFrame()
            foot = joint.child_body()
            self._feet.append(
                (
                    int(joint.index()),
                    X_BJ.rotation().matrix(),
                    X_BJ.translation(),
                    int(foot.index()),
                    foot.default_mass() * g,
                    foot.default_spatial_inertia().get_com(),
                )
            )
        self._min_force = min_force
        self._forces = self.DeclareAbstractInputPort(
            "reaction_forces", plant.get_reaction_forces_output_port().Allocate()
        )
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self._cache = self.DeclareCacheEntry(
            "zmp_and_force",
            ValueProducer(allocate=lambda: AbstractValue.Make(np.zeros(3 + len(joints))), calc=self._calc),
            prerequisites_of_calc={self.all_input_ports_ticket()},
        )
        self.DeclareVectorOutputPort(
            "zmp",
            2,
            lambda c, out: out.SetFromVector(self._cache.Eval(c)[:2]),
            prerequisites_of_calc={self._cache.ticket()},
        )
        self.DeclareVectorOutputPort(
            "normal_force",
            1,
            lambda c, out: out.SetFromVector(self._cache.Eval(c)[2:3]),
            prerequisites_of_calc={self._cache.ticket()},
        )
        self.DeclareVectorOutputPort(
            "foot_forces",
            len(joints),
            lambda c, out: out.SetFromVector(self._cache.Eval(c)[3:]),
            prerequisites_of_calc={self._cache.ticket()},
        )

    def _calc(self, context: Context, value: AbstractValue) -> None:
        reactions = self._forces.Eval(context)
        poses = self._poses.Eval(context)
        k = len(self._feet)
        points, forces, torques = np.empty((2 * k, 3)), np.empty((2 * k, 3)), np.zeros((2 * k, 3))
        for i, (joint, R_BJ, p_BJ, body, weight, p_BoBcm) in enumerate(self._feet):
            X_WB: RigidTransform = poses[body]
            R_WB = X_WB.rotation().matrix()
            p_WB = X_WB.translation()
            R = R_WB.dot(R_BJ)
            F = reactions[joint]  # on the foot, at the joint frame, expressed in it
            # Ground on foot = -(ankle on foot) - weight, each with its point of application.
            points[2 * i] = p_WB + R_WB.dot(p_BJ)
            points[2 * i + 1] = p_WB + R_WB.dot(p_BoBcm)
            forces[2 * i] = -R.dot(F.translational())
            forces[2 * i + 1] = -weight
            torques[2 * i] = -R.dot(F.rotational())
        per_foot = forces[0::2, 2] + forces[1::2, 2]
        value.set_value(
            np.concatenate((zmp_from_wrenches(points, forces, torques, self._min_force), per_foot))
        )
