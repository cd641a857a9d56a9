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
from pydrake.systems.framework import Context

from drake_sot import validation
from drake_sot.systems.leaf import SotLeafSystem

#: What the master sends (forward link), by name: size and units (:class:`SlaveReferences`'s
#: inputs). A vector that carries them all (a ``Channel``'s) has them in this order.
MASTER_SIGNALS: dict[str, tuple[int, str]] = {
    "right_hand_force": (3, "N, world axes"),
    "left_hand_force": (3, "N, world axes"),
    "head": (2, "rad, yaw then pitch"),
    "gripper": (1, "rad, the gripper joints' angle"),
}
MASTER_SIZE = sum(size for size, _ in MASTER_SIGNALS.values())
#: The largest magnitude of each entry of the master's signals, in their units, beyond which a
#: remote write is refused: a human operator's hand force stays well below 1000 N; the head's yaw
#: and pitch and the gripper's angle are angles, within ±π rad.
MASTER_BOUNDS: dict[str, float] = {
    "right_hand_force": 1000.0,
    "left_hand_force": 1000.0,
    "head": np.pi,
    "gripper": np.pi,
}


class HandPositions(SotLeafSystem):
    """The two hands' positions as one vector ``[right (3,); left (3,)]`` [m], world.

    Input ports:
        right_hand, left_hand: abstract ``RigidTransform``, the hand frames' poses in world.
    Output ports:
        positions: (6,) [m] ``[right; left]`` translations.
        right, left: (3,) [m] each hand's translation (what the slave sends back, by name).
    """

    def __init__(self, *, name: str = "hand_positions") -> None:
        super().__init__()
        self.set_name(name)
        self._poses = [
            self.DeclareAbstractInputPort(f"{side}_hand", AbstractValue.Make(RigidTransform()))
            for side in ("right", "left")
        ]
        self.DeclareVectorOutputPort("positions", 6, self._calc)
        for side, port in zip(("right", "left"), self._poses, strict=True):
            self.DeclareVectorOutputPort(
                side, 3, lambda c, out, port=port: out.SetFromVector(port.Eval(c).translation())
            )

    def _calc(self, context: Context, out) -> None:
        out.SetFromVector(np.concatenate([port.Eval(context).translation() for port in self._poses]))


class SlaveReferences(SotLeafSystem):
    """What the master sends, split into the slave's task references.

    Input ports (:data:`MASTER_SIGNALS`, what the forward link delivers):
        right_hand_force, left_hand_force: (3,) [N] the operator's forces on the handles, world
            axes.
        head: (2,) ``[yaw, pitch]`` [rad] of the operator's head in the world.
        gripper: (1,) the gripper aperture [rad] (the gripper joints' angle).
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
        self._master = {
            name: self.DeclareVectorInputPort(name, size) for name, (size, _) in MASTER_SIGNALS.items()
        }
        for side in ("right", "left"):
            self.DeclareVectorOutputPort(
                f"wrench_ref_{side}", 6, lambda c, out, s=side: out.SetFromVector(self._wrench(c, s))
            )
        self.DeclareAbstractOutputPort(
            "head_pose", lambda: AbstractValue.Make(RigidTransform()), self._calc_head
        )
        self.DeclareVectorOutputPort("posture", self._q0.size, self._calc_posture)

    def _part(self, context: Context, name: str) -> np.ndarray:
        return self._master[name].Eval(context)

    def _wrench(self, context: Context, side: str) -> np.ndarray:
        return np.concatenate([np.zeros(3), self._part(context, f"{side}_hand_force")])

    def _calc_head(self, context: Context, value) -> None:
        yaw, pitch = self._part(context, "head")
        value.set_value(RigidTransform(RollPitchYaw(0.0, pitch, yaw), np.zeros(3)))

    def _calc_posture(self, context: Context, out) -> None:
        q = self._q0.copy()
        q[self._grip_indices] = self._part(context, "gripper")[0]
        out.SetFromVector(q)
