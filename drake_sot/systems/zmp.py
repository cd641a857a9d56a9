"""``ZmpEstimator``: the measured ZMP from the ankle force/torque sensors of the simulated robot."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Context, LeafSystem, ValueProducer

from drake_sot.statics import zmp_from_wrenches


class ZmpEstimator(LeafSystem):
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
        self._joints = [plant.GetJointByName(name) for name in sensor_joints]
        self._X_BJ = [j.frame_on_child().GetFixedPoseInBodyFrame() for j in self._joints]
        self._bodies = [int(j.child_body().index()) for j in self._joints]
        self._weights = [
            j.child_body().default_mass() * plant.gravity_field().gravity_vector() for j in self._joints
        ]
        self._p_BoBcm = [j.child_body().default_spatial_inertia().get_com() for j in self._joints]
        self._min_force = min_force
        self._forces = self.DeclareAbstractInputPort(
            "reaction_forces", plant.get_reaction_forces_output_port().Allocate()
        )
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self._cache = self.DeclareCacheEntry(
            "zmp_and_force",
            ValueProducer(
                allocate=lambda: AbstractValue.Make(np.zeros(3 + len(self._joints))), calc=self._calc
            ),
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
            len(self._joints),
            lambda c, out: out.SetFromVector(self._cache.Eval(c)[3:]),
            prerequisites_of_calc={self._cache.ticket()},
        )

    def _calc(self, context: Context, value: AbstractValue) -> None:
        reactions = self._forces.Eval(context)
        poses = self._poses.Eval(context)
        points, forces, torques = [], [], []
        for joint, X_BJ, body, weight, p_BoBcm in zip(
            self._joints, self._X_BJ, self._bodies, self._weights, self._p_BoBcm, strict=True
        ):
            X_WB: RigidTransform = poses[body]
            X_WJ = X_WB @ X_BJ
            F = reactions[int(joint.index())]  # on the foot, at the joint frame, expressed in it
            R = X_WJ.rotation().matrix()
            # Ground on foot = -(ankle on foot) - weight, each with its point of application.
            points += [X_WJ.translation(), X_WB @ p_BoBcm]
            forces += [-R @ F.translational(), -weight]
            torques += [-R @ F.rotational(), np.zeros(3)]
        forces = np.array(forces)
        per_foot = forces[0::2, 2] + forces[1::2, 2]
        value.set_value(
            np.concatenate(
                (zmp_from_wrenches(np.array(points), forces, np.array(torques), self._min_force), per_foot)
            )
        )
