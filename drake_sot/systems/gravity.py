"""``GravityFeedforward``: the joint torques that hold the reference posture at rest."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from drake_sot.statics import static_torques


class GravityFeedforward(LeafSystem):
    """Quasi-static torques of the reference configuration, fed forward to PD actuators.

    A position-controlled joint under PD sags by ``τ_load / K_p``; in double support
    the sag of the legs also squeezes the feet against each other and makes them
    creep. Feeding the static torques of the reference configuration forward (Drake
    adds the plant's actuation input to its PD actuators' output) removes both: the
    contact wrenches are the minimum-norm ones that balance the floating base
    (:func:`drake_sot.statics.static_torques`), then every joint gets the torque that
    holds its share of the load.

    Input ports:
        q: reference configuration (nq,) of ``plant`` (e.g. ``Integrator.q``).
    Output ports:
        tau: feed-forward torques (na,) [N·m] in actuator order. Recomputed only when
            q changes (once per control tick).

    Args:
        plant: the controller's robot model (finalized, floating base first).
        actuated_joints: joint names in actuator order.
        contact_frames: frames in contact with the ground (e.g. the soles), each
            taking a 6D wrench; empty for a robot hanging from its base.
    """

    def __init__(
        self, plant: MultibodyPlant, actuated_joints: Sequence[str], contact_frames: Sequence[str]
    ) -> None:
        super().__init__()
        self._plant = plant
        self._plant_context = plant.CreateDefaultContext()
        self._n_base = plant.num_velocities() - len(actuated_joints)
        if self._n_base not in (0, 6):
            raise ValueError(
                f"GravityFeedforward: {plant.num_velocities()} velocities for {len(actuated_joints)} actuated "
                "joints; expected a fixed base or one free flyer with every joint actuated"
            )
        self._v_index = np.array([plant.GetJointByName(j).velocity_start() for j in actuated_joints], dtype=int)
        self._contacts = [plant.GetFrameByName(name) for name in contact_frames]
        self._q = self.DeclareVectorInputPort("q", plant.num_positions())
        self.DeclareVectorOutputPort(
            "tau", len(actuated_joints), self._calc_tau,
            prerequisites_of_calc={self.input_port_ticket(self._q.get_index())},
        )

    def _calc_tau(self, context: Context, output: BasicVector) -> None:
        plant, plant_context = self._plant, self._plant_context
        plant.SetPositions(plant_context, self._q.Eval(context))
        tau_g = plant.CalcGravityGeneralizedForces(plant_context)
        world = plant.world_frame()
        J = np.vstack(
            [
                plant.CalcJacobianSpatialVelocity(plant_context, JacobianWrtVariable.kV, frame, np.zeros(3), world, world)
                for frame in self._contacts
            ]
        ) if self._contacts else np.zeros((0, plant.num_velocities()))
        tau_joints, _ = static_torques(tau_g, J, self._n_base)
        # tau_joints follows the v layout after the base; reorder to actuator order.
        output.SetFromVector(tau_joints[self._v_index - self._n_base])
