"""``HipStrategy``: leans the trunk when the DCM has left the support polygon.

The balance stabilizer acts through the ZMP, which cannot bring back a divergent component
of motion outside the support polygon; this system then tilts the trunk's orientation
reference towards the side the DCM left by, so that the trunk's angular momentum pulls the
CoM back (:mod:`drake_sot.recovery` has the equation, the profile, and the numbers that rule
out a capture step for the standing robot).
"""

from __future__ import annotations

import logging

import numpy as np
from pydrake.common.eigen_geometry import AngleAxis
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import Context, DiscreteValues

from drake_sot import validation
from drake_sot.recovery import LeanProfile, lean_axis
from drake_sot.systems.leaf import SotLeafSystem

_LOG = logging.getLogger(__name__)

#: Discrete state: [armed (1 waiting, 0 leaning), start time [s], direction (2), lean angle
#: [rad] and rate [rad/s] at the last tick].
_ARMED, _START, _DIRECTION, _ANGLE, _RATE = 0, 1, slice(2, 4), 4, 5


class HipStrategy(SotLeafSystem):
    """The trunk's orientation reference, leaning when the DCM leaves the support polygon.

    At each control tick (``period``), while armed: when the stabilizer's ``dcm_excess`` is
    longer than ``profile.threshold``, the lean starts (logged at INFO with the time and the
    excess) in the excess's direction d: the reference is the initial orientation rotated by
    ``profile.at(t − start)`` about z × d (the trunk's top moves along d), and it is armed
    again once upright, ``profile.duration`` later. Otherwise the reference is the initial
    orientation. The outputs hold the value of the last tick.

    Input ports:
        dcm_excess: (2,) [m] ``BalanceStabilizer.dcm_excess``.
    Output ports:
        waist: abstract ``RigidTransform``, the trunk frame's pose reference (for an
            orientation task, selection ``"000111"``: its position is the initial one).
        waist_vel: (6,) [m/s, rad/s] ``[v; ω]`` its velocity reference (v = 0), world frame.
        lean: (3,) [rad, 1, 1] [lean angle, direction x, direction y]; the direction is
            zero before the first lean.

    Args:
        initial: the trunk frame's pose when upright.
        profile: the lean.
        period: [s] control period, > 0.
        name: system name.
    """

    def __init__(
        self,
        initial: RigidTransform,
        *,
        profile: LeanProfile = LeanProfile(),
        period: float = 0.005,
        name: str = "hip_strategy",
    ) -> None:
        super().__init__()
        self.set_name(name)
        if not isinstance(profile, LeanProfile):
            raise ValueError(f"profile = {profile!r}: must be a LeanProfile")
        if not isinstance(initial, RigidTransform):
            raise ValueError(f"initial = {initial!r}: must be a RigidTransform")
        self.profile = profile
        self._initial = initial
        self._period = validation.positive("period", period, unit="s")
        self._excess = self.DeclareVectorInputPort("dcm_excess", 2)
        self._state = self.DeclareDiscreteState(np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0]))
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._update)
        held = {self.discrete_state_ticket(self._state)}
        self.DeclareAbstractOutputPort(
            "waist",
            lambda: AbstractValue.Make(RigidTransform()),
            lambda c, value: value.set_value(self._pose(c)),
            prerequisites_of_calc=held,
        )
        self.DeclareVectorOutputPort(
            "waist_vel", 6, lambda c, out: out.SetFromVector(self._velocity(c)), prerequisites_of_calc=held
        )
        self.DeclareVectorOutputPort(
            "lean", 3, lambda c, out: out.SetFromVector(self._lean(c)), prerequisites_of_calc=held
        )

    def _held(self, context: Context) -> np.ndarray:
        return context.get_discrete_state(self._state).get_value()

    def _angle(self, context: Context) -> tuple[float, float, np.ndarray]:
        """(angle [rad], rate [rad/s], direction (2,)) of the lean at the last tick."""
        held = self._held(context)
        return held[_ANGLE], held[_RATE], held[_DIRECTION]

    def _pose(self, context: Context) -> RigidTransform:
        angle, _, direction = self._angle(context)
        if angle == 0.0:
            return self._initial
        tilt = RotationMatrix(AngleAxis(angle, lean_axis(direction)))
        return RigidTransform(tilt @ self._initial.rotation(), self._initial.translation())

    def _velocity(self, context: Context) -> np.ndarray:
        _, rate, direction = self._angle(context)
        if rate == 0.0:
            return np.zeros(6)
        return np.concatenate((np.zeros(3), rate * lean_axis(direction)))

    def _lean(self, context: Context) -> np.ndarray:
        angle, _, direction = self._angle(context)
        return np.array([angle, *direction])

    def _update(self, context: Context, discrete: DiscreteValues) -> None:
        held = self._held(context).copy()
        now = context.get_time()
        if not held[_ARMED] and now - held[_START] >= self.profile.duration:
            held[_ARMED] = 1.0
        excess = self._excess.Eval(context)
        distance = float(np.hypot(*excess))
        if held[_ARMED] and distance > self.profile.threshold and distance > 0.0:
            held[_ARMED], held[_START], held[_DIRECTION] = 0.0, now, excess / distance
            _LOG.info(
                "hip strategy: the DCM left the support polygon by %.3f m towards (%.2f, %.2f) "
                "at t = %.3f s; leaning the trunk %.2f rad",
                distance,
                *held[_DIRECTION],
                now,
                self.profile.angle,
            )
        held[_ANGLE], held[_RATE] = (0.0, 0.0) if held[_ARMED] else self.profile.at(now - held[_START])
        discrete.set_value(self._state, held)
