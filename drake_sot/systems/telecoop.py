"""Port adapters of the tele-cooperation's slave side (Evrard et al. 2009, III-E).

:class:`HandPositions` turns the two hand poses into the vector sent to the master;
:class:`SlaveReferences` splits what the master sends into the references of the hand
admittances (e_fr, e_fl), the head (e_head) and the grippers (e_grip).
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Context, LeafSystem

from drake_sot import validation

#: The layout of the vector the master sends (forward link), by name.
MASTER_LAYOUT = {
    "force_right": slice(0, 3),
    "force_left": slice(3, 6),
    "head": slice(6, 8),
    "grip": slice(8, 9),
}
MASTER_SIZE = 9


class HandPositions(LeafSystem):
    """The two hands' positions as one vector ``[right (3,); left (3,)]`` [m], world.

    Input ports:
        right_hand, left_hand: abstract ``RigidTransform``, the hand frames' poses in world.
    Output ports:
        positions: (6,) [m] ``[right; left]`` translations.
    """

    def __init__(self, *, name: str = "hand_positions") -> None:
        super().__init__()
        self.set_name(name)
        self._poses = [
            self.DeclareAbstractInputPort(f"{side}_hand", AbstractValue.Make(RigidTransform()))
            for side in ("right", "left")
        ]
        self.DeclareVectorOutputPort("positions", 6, self._calc)

    def _calc(self, context: Context, out) -> None:
        out.SetFromVector(np.concatenate([port.Eval(context).translation() for port in self._poses]))


class SlaveReferences(LeafSystem):
    """What the master sends, split into the slave's task references.

    The master's vector (``master``, (9,), :data:`MASTER_LAYOUT`): ``force_right`` (3,) and
    ``force_left`` (3,) [N], the operator's forces on the handles, world axes; ``head`` (2,)
    ``[yaw, pitch]`` [rad] of the operator's head in the world; ``grip`` (1,) the gripper
    aperture [rad] (the gripper joints' angle).

    Input ports:
        master: (9,) as above (the forward link's output).
    Output ports:
        wrench_ref_right, wrench_ref_left: (6,) ``[τ = 0 [N m]; f [N]]`` the reference wrench of
            each hand's admittance (``AdmittanceController.wrench_ref``).
        head_pose: abstract ``RigidTransform``, the head's orientation (roll 0, the pitch and
            yaw received; position unused by an orientation task).
        posture: (nq,) the configuration ``q0`` with both gripper joints at the aperture (the
            ``sdes`` of a posture task on the gripper joints).

    Args:
        plant: the controller's plant. q0: (nq,) its reference configuration.
        grippers: the gripper joints' names. name: the system's name.
    """

    def __init__(
        self,
        plant: MultibodyPlant,
        q0: np.ndarray,
        grippers: tuple[str, ...],
        *,
        name: str = "slave_references",
    ) -> None:
        super().__init__()
        self.set_name(name)
        self._q0 = validation.vector("q0", q0, plant.num_positions()).copy()
        self._grip_indices = [plant.GetJointByName(j).position_start() for j in grippers]
        self._master = self.DeclareVectorInputPort("master", MASTER_SIZE)
        for side in ("right", "left"):
            self.DeclareVectorOutputPort(
                f"wrench_ref_{side}", 6, lambda c, out, s=side: out.SetFromVector(self._wrench(c, s))
            )
        self.DeclareAbstractOutputPort(
            "head_pose", lambda: AbstractValue.Make(RigidTransform()), self._calc_head
        )
        self.DeclareVectorOutputPort("posture", self._q0.size, self._calc_posture)

    def _part(self, context: Context, key: str) -> np.ndarray:
        return self._master.Eval(context)[MASTER_LAYOUT[key]]

    def _wrench(self, context: Context, side: str) -> np.ndarray:
        return np.concatenate([np.zeros(3), self._part(context, f"force_{side}")])

    def _calc_head(self, context: Context, value) -> None:
        yaw, pitch = self._part(context, "head")
        value.set_value(RigidTransform(RollPitchYaw(0.0, pitch, yaw), np.zeros(3)))

    def _calc_posture(self, context: Context, out) -> None:
        q = self._q0.copy()
        q[self._grip_indices] = self._part(context, "grip")[0]
        out.SetFromVector(q)
