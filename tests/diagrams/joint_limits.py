"""How far the simulated robot's joints went past their limits, read from a run's logs."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Excess:
    """The worst excursions past the limits over a run: > 0 means a limit was passed by that much.

    Attributes:
        position: max over joints and samples of the distance past a position limit [rad or m].
        position_joint: the joint where it happened.
        velocity: max of |v| - v_max [rad/s or m/s].
        velocity_joint: the joint where it happened.
        reference: the same as ``position`` for the SoT's reference configuration (``q_ref``,
            what the PD actuators track). Drake's discrete plant holds its joints at their
            limits by itself (a reference past a limit is then fought by the actuator): the
            reference tells whether the controller respected them.
        reference_joint: the joint where it happened.
    """

    position: float
    position_joint: str
    velocity: float
    velocity_joint: str
    reference: float
    reference_joint: str


def limit_excess(built, arrays) -> Excess:
    """The simulated plant's actuated joints (``arrays["q"]``, ``arrays["v"]``: the robot
    instance's logged state) against the limits of the simulated plant's joints."""
    plant, model = built.plant, built.info.model_instance
    joints = [plant.GetJointByName(name, model) for name in built.info.actuated_joints]
    # Where each of the plant's coordinates sits in the instance's logged state.
    q_of = np.zeros(plant.num_positions())
    plant.SetPositionsInArray(model, np.arange(plant.num_positions(model), dtype=float), q_of)
    v_of = np.zeros(plant.num_velocities())
    plant.SetVelocitiesInArray(model, np.arange(plant.num_velocities(model), dtype=float), v_of)
    q = arrays["q"][:, [int(q_of[j.position_start()]) for j in joints]]
    v = arrays["v"][:, [int(v_of[j.velocity_start()]) for j in joints]]
    lower = np.array([j.position_lower_limits()[0] for j in joints])
    upper = np.array([j.position_upper_limits()[0] for j in joints])
    v_max = np.array([j.velocity_upper_limits()[0] for j in joints])
    past = np.maximum(q - upper, lower - q).max(axis=0)
    fast = (np.abs(v) - v_max).max(axis=0)
    control = [built.control_plant.GetJointByName(j.name()) for j in joints]
    q_ref = arrays["q_ref"][:, [j.position_start() for j in control]]
    ref_past = np.maximum(q_ref - upper, lower - q_ref).max(axis=0)
    k, kv, kr = int(np.argmax(past)), int(np.argmax(fast)), int(np.argmax(ref_past))
    return Excess(
        float(past[k]),
        joints[k].name(),
        float(fast[kv]),
        joints[kv].name(),
        float(ref_past[kr]),
        joints[kr].name(),
    )
