"""``TorqueFeedforward``: the joint torques that produce the reference motion on its contacts."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable, MultibodyForces
from pydrake.systems.framework import BasicVector, Context

from drake_sot.statics import contact_torques
from drake_sot.systems.leaf import SotLeafSystem


class TorqueFeedforward(SotLeafSystem):
    """Inverse-dynamics torques of the reference, fed forward to PD actuators.

    A position-controlled joint under PD lags its reference by ``τ_load / K_p``; in
    double support the lag of the legs also squeezes the feet together, and in walking
    it lets the robot drift from a reference that is dynamically feasible. Feeding
    forward ``τ`` from ``M(q) a + C(q, v) v - τ_g(q) = Sᵀ τ + J_cᵀ f`` (Drake adds the
    plant's actuation input to its PD actuators' output) leaves the PD only the
    residual. The contact wrenches f balance the floating base with the least norm
    weighted by each contact's load share (:func:`drake_sot.statics.contact_torques`).
    With ``v`` and ``vdot`` unconnected it is the quasi-static (gravity) feed-forward.

    Input ports:
        q: reference configuration (nq,) of ``plant`` (``Device.q``).
        v: reference velocity (nv,) [rad/s, m/s] (``Device.v``); optional, zero.
        vdot: reference acceleration (nv,) (``Device.vdot``); optional, zero.
        load: (k,) one non-negative share per contact frame: 0 when the frame is off
            the ground, and the ground load is distributed in proportion
            (e.g. ``PatternGenerator.load``); optional, equal shares when unconnected.
    Output ports:
        tau: feed-forward torques (na,) [N·m] in actuator order. Recomputed only when an
            input changes (once per control tick).

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
        self._forces = MultibodyForces(plant)
        nv = plant.num_velocities()
        self._n_base = nv - len(actuated_joints)
        if self._n_base not in (0, 6):
            raise ValueError(
                f"TorqueFeedforward: {nv} velocities for {len(actuated_joints)} actuated "
                "joints; expected a fixed base or one free flyer with every joint actuated"
            )
        self._v_index = np.array(
            [plant.GetJointByName(j).velocity_start() for j in actuated_joints], dtype=int
        )
        self._contacts = [plant.GetFrameByName(name) for name in contact_frames]
        self._q = self.DeclareVectorInputPort("q", plant.num_positions())
        self._v = self.DeclareVectorInputPort("v", nv)
        self._vdot = self.DeclareVectorInputPort("vdot", nv)
        self._load = self.DeclareVectorInputPort("load", len(self._contacts))
        self.DeclareVectorOutputPort(
            "tau", len(actuated_joints), self._calc_tau, prerequisites_of_calc={self.all_input_ports_ticket()}
        )

    def _optional(self, port, context: Context, default: np.ndarray) -> np.ndarray:
        return port.Eval(context) if port.HasValue(context) else default

    def _calc_tau(self, context: Context, output: BasicVector) -> None:
        plant, plant_context = self._plant, self._plant_context
        nv = plant.num_velocities()
        plant.SetPositions(plant_context, self._q.Eval(context))
        plant.SetVelocities(plant_context, self._optional(self._v, context, np.zeros(nv)))
        self._forces.SetZero()
        plant.CalcForceElementsContribution(plant_context, self._forces)  # gravity
        tau_id = plant.CalcInverseDynamics(
            plant_context, self._optional(self._vdot, context, np.zeros(nv)), self._forces
        )
        load = self._optional(self._load, context, np.ones(len(self._contacts)))
        loaded = [(frame, w) for frame, w in zip(self._contacts, load, strict=True) if w > 0.0]
        world = plant.world_frame()
        J = (
            np.vstack(
                [
                    plant.CalcJacobianSpatialVelocity(
                        plant_context, JacobianWrtVariable.kV, frame, np.zeros(3), world, world
                    )
                    for frame, _ in loaded
                ]
            )
            if loaded
            else np.zeros((0, nv))
        )
        tau_joints, _ = contact_torques(tau_id, J, self._n_base, np.array([w for _, w in loaded]))
        # tau_joints follows the v layout after the base; reorder to actuator order.
        output.SetFromVector(tau_joints[self._v_index - self._n_base])
