"""``FallMonitor``: says when the simulated robot has fallen, and ends the run a little later.

A robot has fallen when its pelvis is lower than a height, or its trunk leans further
from the vertical than an angle (:class:`FallCriteria`). The monitor checks at the control
period, latches the first instant either threshold is crossed (time, pelvis height, tilt:
a :class:`Fall`), and ``stop_after`` seconds later asks the simulator to stop
(``EventStatus.ReachedTermination``: ``Simulator.AdvanceTo`` returns early, with this system
as the status's ``system()``), so that the logs and the replay show the robot come down.
No Python runs per physics step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.framework import Context, DiscreteValues, EventStatus

from drake_sot import validation
from drake_sot.systems.leaf import SotLeafSystem


@dataclass(frozen=True)
class FallCriteria:
    """When a standing humanoid counts as fallen, and how long the run goes on after.

    Attributes:
        min_pelvis_height: [m] fallen when the pelvis origin is lower (finite, > 0). The
            default, 0.40 m, is 62 % of the embedded humanoid's half-sitting height
            (0.649 m): far below any walking or reaching posture, above a robot kneeling
            or lying.
        max_tilt: [rad] fallen when the trunk's z axis leans further from the vertical
            (in (0, π]). Default 50°: the chest can bend the torso forward by up to 60°
            (its pitch limit) on a robot that stands, but not while the pelvis stays
            upright; a robot that tips over on its foot edge passes 50° within ~0.3 s.
        stop_after: [s] the simulation goes on for this long after the fall is detected
            (finite, >= 0), so that the robot comes to rest on the ground in the logs and
            the replay; 0 stops at the detection.

    Raises:
        ValueError: a value out of its range, named.
    """

    min_pelvis_height: float = 0.40
    max_tilt: float = math.radians(50.0)
    stop_after: float = 1.5

    def __post_init__(self) -> None:
        object.__setattr__(
            self,
            "min_pelvis_height",
            validation.positive("min_pelvis_height", self.min_pelvis_height, unit="m"),
        )
        object.__setattr__(
            self, "max_tilt", validation.bounded("max_tilt", self.max_tilt, 0.0, math.pi, unit="rad")
        )
        if self.max_tilt == 0.0:
            raise ValueError("max_tilt = 0.0 rad: must be > 0 (a robot is never exactly upright)")
        object.__setattr__(
            self, "stop_after", validation.nonnegative("stop_after", self.stop_after, unit="s")
        )


@dataclass(frozen=True)
class Fall:
    """A detected fall: when, and what the monitor measured then.

    Attributes:
        time: [s] simulated time of the first control tick past a threshold.
        pelvis_height: [m] height of the pelvis origin then.
        tilt: [rad] angle between the trunk's z axis and the vertical then.
    """

    time: float
    pelvis_height: float
    tilt: float

    def __str__(self) -> str:
        return (
            f"fell at t = {self.time:.3f} s (pelvis z = {self.pelvis_height:.3f} m, "
            f"tilt = {math.degrees(self.tilt):.1f}°)"
        )


#: Layout of the monitor's discrete state.
_FALLEN, _TIME, _HEIGHT, _TILT = range(4)


class FallMonitor(SotLeafSystem):
    """Detects that the simulated robot has fallen (see :class:`FallCriteria`).

    At each tick (``period``) it reads the pelvis height (z of the pelvis body's origin)
    and the trunk tilt (angle between the trunk body's z axis and the world's z axis,
    ``acos(R_WT[2, 2])``); the first tick where the height is below
    ``min_pelvis_height`` or the tilt above ``max_tilt`` is latched as the fall, and the
    tick ``stop_after`` later returns ``EventStatus.ReachedTermination`` with the fall's
    description as message.

    Input ports:
        body_poses: abstract ``list[RigidTransform]`` (the plant's ``body_poses``).
    Output ports:
        fallen: (1,) 1 from the tick that detected the fall on, else 0.
        fall: (3,) [s, m, rad] time, pelvis height and tilt of the fall; NaN before it.

    Args:
        plant: the simulated (finalized) plant.
        pelvis: name of the pelvis body (its origin's height is measured).
        trunk: name of the trunk body (its tilt is measured).
        model_instance: the robot's model instance (for the body names).
        criteria: the thresholds and the delay before stopping.
        period: [s] the check period (the control period), finite and > 0.
    """

    def __init__(
        self,
        plant: MultibodyPlant,
        *,
        pelvis: str,
        trunk: str,
        model_instance: ModelInstanceIndex,
        criteria: FallCriteria,
        period: float = 0.005,
    ) -> None:
        super().__init__()
        period = validation.positive("period", period, unit="s")
        self.criteria = criteria
        self._pelvis = int(plant.GetBodyByName(pelvis, model_instance).index())
        self._trunk = int(plant.GetBodyByName(trunk, model_instance).index())
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self._state = self.DeclareDiscreteState(np.array([0.0, np.nan, np.nan, np.nan]))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        ticket = {self.discrete_state_ticket(self._state)}
        self.DeclareVectorOutputPort(
            "fallen",
            1,
            lambda c, out: out.SetFromVector(c.get_discrete_state(self._state).get_value()[:1]),
            prerequisites_of_calc=ticket,
        )
        self.DeclareVectorOutputPort(
            "fall",
            3,
            lambda c, out: out.SetFromVector(c.get_discrete_state(self._state).get_value()[1:]),
            prerequisites_of_calc=ticket,
        )

    def _update(self, context: Context, discrete: DiscreteValues) -> EventStatus:
        state = context.get_discrete_state(self._state).get_value()
        t = context.get_time()
        if state[_FALLEN] > 0.5:
            if t >= state[_TIME] + self.criteria.stop_after - 1e-9:
                return EventStatus.ReachedTermination(self, str(self._fall(state)))
            return EventStatus.DidNothing()
        poses = self._poses.Eval(context)
        height = poses[self._pelvis].translation()[2]
        tilt = math.acos(min(1.0, max(-1.0, poses[self._trunk].rotation().matrix()[2, 2])))
        if height < self.criteria.min_pelvis_height or tilt > self.criteria.max_tilt:
            discrete.set_value(self._state, [1.0, t, height, tilt])
            if self.criteria.stop_after == 0.0:
                return EventStatus.ReachedTermination(self, str(Fall(t, height, tilt)))
            return EventStatus.Succeeded()
        return EventStatus.DidNothing()

    @staticmethod
    def _fall(state: np.ndarray) -> Fall:
        return Fall(float(state[_TIME]), float(state[_HEIGHT]), float(state[_TILT]))

    def fall(self, context: Context) -> Fall | None:
        """The fall detected in ``context`` (this system's context), None while standing."""
        state = context.get_discrete_state(self._state).get_value()
        return self._fall(state) if state[_FALLEN] > 0.5 else None
