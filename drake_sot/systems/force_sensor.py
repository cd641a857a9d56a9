"""``ForceSensor``: a 6-axis force/torque sensor of the simulated robot, read from a weld joint."""

from __future__ import annotations

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Frame, WeldJoint
from pydrake.systems.framework import BasicVector, Context

from drake_sot.systems.leaf import SotLeafSystem


class ForceSensor(SotLeafSystem):
    """The wrench a weld joint transmits, as a 6-axis F/T sensor between a parent and a child body.

    Convention (Drake's ``MultibodyPlant`` reaction forces, verified in the tests):
    the reading is the spatial force that the PARENT side of the weld (e.g. the
    wrist) applies on the CHILD side (e.g. the hand, with every body below it), at
    the origin of the weld's child frame Jc, expressed in Jc. Hanging at rest, a hand
    of mass m reads ``f = -m R_WJcᵀ g`` (the wrist holds the hand up: +m|g| along the
    world's up axis) and the torque of that support about Jc. An external force
    ``f_e`` pushing on the hand at rest adds ``-R_WJcᵀ f_e`` (the wrist resists it).
    The sensor frame Jc is :attr:`frame` (a frame of the child body).

    On a discrete plant the reaction forces are sampled at each physics step
    (``MultibodyPlantConfig.use_sampled_output_ports``, on by default): before the
    first step the reading is all zeros, then it is the value of the last step.

    Input ports:
        reaction_forces: abstract ``list[SpatialForce]`` (the plant's
            ``get_reaction_forces_output_port()``).
    Output ports:
        wrench: (6,) ``[torque [N m]; force [N]]`` on the child at Jc, in Jc.

    Args:
        plant: the simulated (finalized) plant.
        weld_joint_name: name of the weld joint that is the sensor.
        name: system name (default: the joint's name).
    """

    def __init__(self, plant: MultibodyPlant, weld_joint_name: str, *, name: str | None = None) -> None:
        super().__init__()
        if not plant.HasJointNamed(weld_joint_name):
            welds = [
                plant.get_joint(j).name()
                for j in plant.GetJointIndices()
                if isinstance(plant.get_joint(j), WeldJoint)
            ]
            raise ValueError(f"ForceSensor: no joint {weld_joint_name!r}; the weld joints are {welds}")
        joint = plant.GetJointByName(weld_joint_name)
        if not isinstance(joint, WeldJoint):
            raise TypeError(
                f"ForceSensor: joint {weld_joint_name!r} is a {type(joint).__name__}, not a WeldJoint"
            )
        self.set_name(name or weld_joint_name)
        self._plant = plant
        self._joint = joint
        self._index = int(joint.index())
        self._forces = self.DeclareAbstractInputPort(
            "reaction_forces", plant.get_reaction_forces_output_port().Allocate()
        )
        self.DeclareVectorOutputPort(
            "wrench",
            6,
            self._calc_wrench,
            prerequisites_of_calc={self.input_port_ticket(self._forces.get_index())},
        )

    @property
    def joint(self) -> WeldJoint:
        """The weld joint read by this sensor."""
        return self._joint

    @property
    def frame(self) -> Frame:
        """The sensor frame Jc: the weld's frame on the child body."""
        return self._joint.frame_on_child()

    def payload(self, plant_context: Context | None = None) -> tuple[float, np.ndarray]:
        """``(mass [kg], centre of mass (3,) [m] in Jc)`` of everything below the sensor
        (see :func:`payload`), in the configuration of ``plant_context`` (the plant's
        default configuration when None)."""
        return payload(self._plant, self._joint.name(), plant_context)

    def _calc_wrench(self, context: Context, output: BasicVector) -> None:
        F = self._forces.Eval(context)[self._index]
        output.SetFromVector(np.concatenate((F.rotational(), F.translational())))


def payload(
    plant: MultibodyPlant, weld_joint_name: str, plant_context: Context | None = None
) -> tuple[float, np.ndarray]:
    """``(mass [kg], centre of mass (3,) [m] in Jc)`` of everything below a sensor weld.

    The weld's child body and every body attached to it further down the tree (e.g.
    the hand and its gripper finger), in the configuration of ``plant_context`` (the
    plant's default configuration when None): the load that the gravity compensation
    of this sensor must subtract (``AdmittanceController(hand_mass=..., hand_com=...)``).
    Works on any plant holding the joint (the simulated one or the controller's model).

    Note: ``plant.GetBodiesKinematicallyAffectedBy([weld.index()])`` returns no body
    for a weld (it has no degree of freedom); the tree is walked here instead.
    """
    joint = plant.GetJointByName(weld_joint_name)
    context = plant_context if plant_context is not None else plant.CreateDefaultContext()
    bodies = {joint.child_body().index()}
    grew = True
    while grew:  # close the set under "child of a body in the set"
        grew = False
        for j in plant.GetJointIndices():
            other = plant.get_joint(j)
            if other.parent_body().index() in bodies and other.child_body().index() not in bodies:
                bodies.add(other.child_body().index())
                grew = True
    inertia = plant.CalcSpatialInertia(context, joint.frame_on_child(), sorted(bodies, key=int))
    return float(inertia.get_mass()), np.array(inertia.get_com())
