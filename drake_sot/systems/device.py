"""``Device``: q̇ → the reference configuration, the "device" entity of the original SoT."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import BasicVector, Context, DiscreteValues

from drake_sot.configuration import integrate
from drake_sot.systems._context import own_context
from drake_sot.systems.leaf import SotLeafSystem
from drake_sot.validation import positive


class Device(SotLeafSystem):
    """Integrates the solver's q̇ into the reference configuration q at the control period.

    The free flyer moves on SE(3) (quaternion normalised), the joints linearly
    (:func:`drake_sot.configuration.integrate`). The reference configuration feeds the
    controller's kinematics (the SoT's open-loop "device" scheme on a
    position-controlled robot) and, through ``state_des``, the simulated robot's PD
    actuators. Nothing is clipped: a reference outside the joint limits is the stack's
    business (a joint-limit task), not silently altered here.

    Timing: the device and ``StackOfTasks`` update at the same instants, and Drake
    computes every update of an instant from the state before it, so the device
    integrates the q̇ solved one tick earlier — one control period of latency, as on
    a robot whose command computed at tick k is applied at tick k+1.

    Input ports:
        qdot: generalized velocity (nv,) [rad/s, m/s], e.g. ``StackOfTasks.qdot``.
    Output ports:
        q: reference configuration (nq,).
        v: the velocity integrated at the last tick (nv,).
        vdot: the change of that velocity over the last tick, divided by the period
            (nv,) [rad/s², m/s²]: the reference acceleration (an impulse-like value
            for one tick when the stack or a target changes abruptly).
        state_des: ``[q_a; v_a]`` (2·na,) of the actuated joints in actuator order, for
            ``MultibodyPlant.get_desired_state_input_port``.

    Raises RuntimeError naming the input when q̇ holds NaN or Inf.
    """

    def __init__(
        self,
        plant: MultibodyPlant,
        actuated_joints: Sequence[str],
        q0: np.ndarray,
        *,
        period: float = 0.005,
        name: str = "device",
    ) -> None:
        super().__init__()
        self.set_name(name)
        nq, nv = plant.num_positions(), plant.num_velocities()
        if nq - nv not in (0, 1):
            raise ValueError(f"Device supports one quaternion floating base at most (nq={nq}, nv={nv})")
        q0 = np.asarray(q0, dtype=float)
        if q0.shape != (nq,) or not np.all(np.isfinite(q0)):
            raise ValueError(f"q0 must be {nq} finite numbers, got shape {q0.shape}")
        period = positive("period", period, unit="s")
        self._floating = nq == nv + 1
        self._nq, self._nv = nq, nv
        self._period = period
        joints = [plant.GetJointByName(j) for j in actuated_joints]
        self._qa = np.array([j.position_start() for j in joints], dtype=int)
        self._va = np.array([j.velocity_start() for j in joints], dtype=int)
        self._qdot = self.DeclareVectorInputPort("qdot", nv)
        self._state = self.DeclareDiscreteState(np.concatenate((q0, np.zeros(2 * nv))))  # [q; v; vdot]
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        ticket = {self.discrete_state_ticket(self._state)}
        self.DeclareVectorOutputPort(
            "q", nq, lambda c, out: out.SetFromVector(self._x(c)[:nq]), prerequisites_of_calc=ticket
        )
        self.DeclareVectorOutputPort(
            "v", nv, lambda c, out: out.SetFromVector(self._x(c)[nq : nq + nv]), prerequisites_of_calc=ticket
        )
        self.DeclareVectorOutputPort(
            "vdot", nv, lambda c, out: out.SetFromVector(self._x(c)[nq + nv :]), prerequisites_of_calc=ticket
        )
        self.DeclareVectorOutputPort(
            "state_des", 2 * len(joints), self._calc_state_des, prerequisites_of_calc=ticket
        )

    def _x(self, context: Context) -> np.ndarray:
        return context.get_discrete_state(self._state).get_value()

    def set_configuration(self, context: Context, q: np.ndarray) -> None:
        """Reset the reference configuration (own or root context); velocity set to zero."""
        q = np.asarray(q, dtype=float)
        if q.shape != (self._nq,):
            raise ValueError(f"configuration must have {self._nq} entries, got {q.shape}")
        own_context(self, context).SetDiscreteState(self._state, np.concatenate((q, np.zeros(2 * self._nv))))

    def _update(self, context: Context, discrete_state: DiscreteValues) -> None:
        qdot = self._qdot.Eval(context)
        if not np.all(np.isfinite(qdot)):
            raise RuntimeError(
                f"{self.get_name()!r}: input 'qdot' holds NaN or Inf at t = {context.get_time():.4f} s"
            )
        x = self._x(context)
        q, v = x[: self._nq], x[self._nq : self._nq + self._nv]
        discrete_state.get_mutable_vector(self._state).SetFromVector(
            np.concatenate(
                (integrate(q, qdot, self._period, self._floating), qdot, (qdot - v) / self._period)
            )
        )

    def _calc_state_des(self, context: Context, output: BasicVector) -> None:
        x = self._x(context)
        output.SetFromVector(np.concatenate((x[self._qa], x[self._nq + self._va])))
