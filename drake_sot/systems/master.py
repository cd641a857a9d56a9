"""The master site of the tele-cooperation as Drake systems (Evrard et al. 2009, IV).

:class:`MasterSite` is the two haptic arms (eq. 8-9) on the mobile base placed for the best
manipulability; :class:`Operator` is the model of the human who holds the handles. The math
lives in :mod:`drake_sot.master` and :class:`drake_sot.admittance.MassDamperSpring`.

Vectors of the two hands are ``[right (3,); left (3,)]`` everywhere, as in the slave side's
task names ``e_fr``, ``e_fl``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pydrake.systems.framework import Context, DiscreteValues

from drake_sot import validation
from drake_sot.admittance import MassDamperSpring
from drake_sot.master import BaseLimits, BaseMotion, Path, base_placement, desired_position, operator_force
from drake_sot.systems.leaf import SotLeafSystem

#: The order of the hands in every 6-vector of this module.
HANDS = ("right", "left")

# Layout of MasterSite's discrete state.
_OFFSET = slice(0, 6)  # x_Δ right, left [m]
_RATE = slice(6, 12)  # ẋ_Δ [m/s]
_BASE = slice(12, 15)  # platform pose [x, y, yaw] [m, rad]
_BASE_V = slice(15, 18)  # its velocity
_SLAVE = slice(18, 24)  # x_S of the last tick (for its rate)
_SLAVE_V = slice(24, 30)  # ẋ_S estimated by difference
_FORCE = slice(30, 36)  # f_M of the last tick [N]
_SIZE = 36


class MasterSite(SotLeafSystem):
    """Two admittance-type haptic arms on a mobile base (Evrard et al. 2009, IV).

    Every period, per arm, the offset obeys eq. 8 under the handle force f_M held over the
    period, ``M ẍ_Δ + B ẋ_Δ + K x_Δ = f_M`` (exact zero-order hold), the arm's desired
    position is eq. 9, ``x_d = x_Δ + (x_S − x_B)``, and with an ideal inner position loop the
    handle is at ``x_B + x_d = x_S + x_Δ`` in the world. The platform moves towards
    :func:`~drake_sot.master.base_placement` of the two handles with bounded speed and
    acceleration (:class:`~drake_sot.master.BaseMotion`); x_B is its displacement from its
    start (z = 0: it rolls on the floor).

    The master and slave worlds are identified: x_S (received, slave world) is used as a
    master-world position, so the operator's hands start where the robot's hands are.

    Input ports:
        slave_hands: (6,) [m] x_S, the slave's hand positions as received ``[right; left]``.
        handle_forces: (6,) [N] f_M, the operator's force on each handle ``[right; left]``.

    Output ports (held between periods):
        hands: (6,) [m] the handles' positions in the world, ``x_S + x_Δ``.
        hand_velocities: (6,) [m/s] their velocities, ``ẋ_S + ẋ_Δ`` (ẋ_S by difference over
            one period).
        desired: (6,) [m] x_d of eq. 9, the inner loops' inputs (platform displacement removed).
        offsets: (6,) [m] x_Δ.
        forces: (6,) [N] f_M of the last period: what is sent to the slave as reference force.
        base: (3,) ``[x, y, yaw]`` [m, m, rad] the platform's pose in the world.

    Args:
        slave_hands: (6,) [m] x_S at the start (the platform starts at their placement).
        mass, damping, stiffness: M [kg] > 0, B [N s/m] >= 0, K [N/m] >= 0 of eq. 8, a
            scalar or one per axis (3,).
        shoulder_half_width, r_opt: [m] the arms' geometry (see ``base_placement``).
        base_limits: speed and acceleration bounds of the platform.
        period: [s] the control period.
        name: the system's name.
    """

    def __init__(
        self,
        slave_hands: np.ndarray,
        *,
        mass: float | np.ndarray = 2.0,
        damping: float | np.ndarray = 40.0,
        stiffness: float | np.ndarray = 100.0,
        shoulder_half_width: float = 0.25,
        r_opt: float = 0.45,
        base_limits: BaseLimits | None = None,
        period: float = 0.005,
        name: str = "master",
    ) -> None:
        super().__init__()
        self.set_name(name)
        self._period = validation.positive("period", period, unit="s")
        x_s = validation.vector("slave_hands", slave_hands, 6)
        self._admittance = MassDamperSpring(
            validation.per_axis("mass", mass, 3, sign="positive"),
            validation.per_axis("damping", damping, 3, sign="nonnegative"),
            validation.per_axis("stiffness", stiffness, 3, sign="nonnegative"),
            dt=self._period,
        )
        self._geometry = {
            "shoulder_half_width": validation.positive("shoulder_half_width", shoulder_half_width, unit="m"),
            "r_opt": validation.positive("r_opt", r_opt, unit="m"),
        }
        self._base_motion = BaseMotion(BaseLimits() if base_limits is None else base_limits, self._period)
        x0 = np.zeros(_SIZE)
        x0[_BASE] = self._placement(x_s)
        x0[_SLAVE] = x_s
        self._base_start = x0[_BASE].copy()
        self._state = self.DeclareDiscreteState(x0)
        self._slave = self.DeclareVectorInputPort("slave_hands", 6)
        self._forces = self.DeclareVectorInputPort("handle_forces", 6)
        state = {self.discrete_state_ticket(self._state)}
        with_slave = {*state, self.input_port_ticket(self._slave.get_index())}

        def output(name: str, calc: Callable[[Context], np.ndarray], tickets) -> None:
            self.DeclareVectorOutputPort(
                name,
                6 if name != "base" else 3,
                lambda c, out: out.SetFromVector(calc(c)),
                prerequisites_of_calc=tickets,
            )

        output("hands", lambda c: self._slave.Eval(c) + self._x(c)[_OFFSET], with_slave)
        output("hand_velocities", lambda c: self._x(c)[_SLAVE_V] + self._x(c)[_RATE], state)
        output("desired", lambda c: self._desired(self._slave.Eval(c), self._x(c)), with_slave)
        output("offsets", lambda c: self._x(c)[_OFFSET], state)
        output("forces", lambda c: self._x(c)[_FORCE], state)
        output("base", lambda c: self._x(c)[_BASE], state)
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._update)

    def _x(self, context: Context) -> np.ndarray:
        return context.get_discrete_state(self._state).get_value()

    def _placement(self, hands: np.ndarray) -> np.ndarray:
        return base_placement(hands[3:], hands[:3], **self._geometry)

    def _displacement(self, x: np.ndarray) -> np.ndarray:
        return np.array([*(x[_BASE][:2] - self._base_start[:2]), 0.0])

    def _desired(self, x_s: np.ndarray, x: np.ndarray) -> np.ndarray:
        x_b = self._displacement(x)
        return np.concatenate([desired_position(x[_OFFSET][i : i + 3], x_s[i : i + 3], x_b) for i in (0, 3)])

    def _update(self, context: Context, discrete: DiscreteValues) -> None:
        x = self._x(context).copy()
        x_s = validation.vector(f"{self.get_name()}.slave_hands", self._slave.Eval(context), 6)
        f_m = validation.vector(f"{self.get_name()}.handle_forces", self._forces.Eval(context), 6)
        for i in (0, 3):
            sl = slice(i, i + 3)
            offset, rate = self._admittance.step(x[_OFFSET][sl], x[_RATE][sl], f_m[sl])
            x[_OFFSET.start + i : _OFFSET.start + i + 3] = offset
            x[_RATE.start + i : _RATE.start + i + 3] = rate
        x[_SLAVE_V] = (x_s - x[_SLAVE]) / self._period
        x[_SLAVE] = x_s
        x[_FORCE] = f_m
        hands = x_s + x[_OFFSET]
        x[_BASE], x[_BASE_V] = self._base_motion.step(x[_BASE], x[_BASE_V], self._placement(hands))
        discrete.get_mutable_vector(self._state).SetFromVector(x)


class Operator(SotLeafSystem):
    """The operator at the master site: hands pulled towards an intention, body walking.

    A model chosen by this library (the paper has a human): per hand, the force on the
    handle is ``K (x_i − x) + B (ẋ_i − ẋ)`` (:func:`~drake_sot.master.operator_force`),
    computed at each period and held; the body follows its own path.

    Input ports:
        hands: (6,) [m] the handles' positions ``[right; left]`` (``MasterSite.hands``).
        hand_velocities: (6,) [m/s] their velocities.

    Output ports:
        forces: (6,) [N] the force on each handle, held between periods.
        intention: (6,) [m] where the operator wants the hands now.
        body: (3,) [m] the operator's body (pelvis) position.

    Args:
        intention: t → (x_i (6,), ẋ_i (6,)), the hands' intention ``[right; left]``.
        body: t → (position (3,), velocity (3,)), the body's path.
        stiffness: [N/m] > 0. damping: [N s/m] >= 0.
        period: [s] the control period. name: the system's name.
    """

    def __init__(
        self,
        intention: Path,
        body: Path,
        *,
        stiffness: float = 150.0,
        damping: float = 30.0,
        period: float = 0.005,
        name: str = "operator",
    ) -> None:
        super().__init__()
        self.set_name(name)
        self._intention, self._body = intention, body
        self._k = validation.positive("stiffness", stiffness, unit="N/m")
        self._b = validation.nonnegative("damping", damping, unit="N s/m")
        self._hands = self.DeclareVectorInputPort("hands", 6)
        self._velocities = self.DeclareVectorInputPort("hand_velocities", 6)
        self._force = self.DeclareDiscreteState(6)
        self.DeclareStateOutputPort("forces", self._force)
        time = {self.time_ticket()}
        self.DeclareVectorOutputPort(
            "intention",
            6,
            lambda c, out: out.SetFromVector(self._sample(c.get_time())[0]),
            prerequisites_of_calc=time,
        )
        self.DeclareVectorOutputPort(
            "body",
            3,
            lambda c, out: out.SetFromVector(validation.vector("body", self._body(c.get_time())[0], 3)),
            prerequisites_of_calc=time,
        )
        self.DeclarePeriodicDiscreteUpdateEvent(
            validation.positive("period", period, unit="s"), 0.0, self._update
        )

    def _sample(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        p, v = self._intention(t)
        return validation.vector("intention", p, 6), validation.vector("intention rate", v, 6)

    def _update(self, context: Context, discrete: DiscreteValues) -> None:
        p, v = self._sample(context.get_time())
        x, xd = self._hands.Eval(context), self._velocities.Eval(context)
        f = np.concatenate(
            [
                operator_force(self._k, self._b, p[i : i + 3], v[i : i + 3], x[i : i + 3], xd[i : i + 3])
                for i in (0, 3)
            ]
        )
        discrete.get_mutable_vector(self._force).SetFromVector(f)
