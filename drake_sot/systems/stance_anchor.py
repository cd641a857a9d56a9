"""``StanceAnchor``: the walking references mapped into the reference's world through the
measured stance foot, so that landing errors do not add up over a walk.

Why and the equations: :mod:`drake_sot.anchoring`. The system sits between the pattern
generator and the walking tasks; it reads the generator's phase and, at each lift-off, the
stance sole's pose twice — on the simulated robot and in the reference configuration — and
maps the feet, CoM and waist references through the drift Δ between the two.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from pydrake.common.value import AbstractValue, Value
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.framework import BasicVector, Context, State

from drake_sot.anchoring import PlanarTransform, blend, drift
from drake_sot.footsteps import PHASE_DOUBLE, PHASE_LEFT_SUPPORT, PHASE_RIGHT_SUPPORT, SIDES, WALKING_BOUNDS
from drake_sot.systems.leaf import SotLeafSystem
from drake_sot.validation import positive

_SWINGING = {PHASE_LEFT_SUPPORT: "right", PHASE_RIGHT_SUPPORT: "left"}


@dataclass(frozen=True)
class _Anchor:
    """The state: the drift now, the blend under way (from ``start`` for the CoM and waist,
    from ``swing_start`` for the swinging foot, to ``target``), each foot's drift, the last phase."""

    delta: PlanarTransform = PlanarTransform()
    start: PlanarTransform = PlanarTransform()
    swing_start: PlanarTransform = PlanarTransform()
    target: PlanarTransform = PlanarTransform()
    lift_time: float = -math.inf
    feet: Mapping[str, PlanarTransform] = field(
        default_factory=lambda: {side: PlanarTransform() for side in SIDES}
    )
    phase: int = PHASE_DOUBLE


def _planar(X: RigidTransform) -> PlanarTransform:
    p = X.translation()
    return PlanarTransform(float(p[0]), float(p[1]), RollPitchYaw(X.rotation()).yaw_angle())


def _map_pose(delta: PlanarTransform, X: RigidTransform) -> RigidTransform:
    """``X`` moved by the planar ``delta`` (z, roll and pitch kept)."""
    p = X.translation()
    xy = delta.apply_point(p[:2])
    return RigidTransform(RotationMatrix.MakeZRotation(delta.yaw) @ X.rotation(), [xy[0], xy[1], p[2]])


class StanceAnchor(SotLeafSystem):
    """Feet, CoM and waist references of a pattern generator, re-anchored on the measured
    stance foot at each lift-off (:mod:`drake_sot.anchoring`).

    At the first tick of a single support (the generator's phase leaves double support) it
    measures the drift ``Δ = S^r ∘ (S^m)⁻¹`` (planar: x, y, yaw) between the stance sole in
    the reference configuration (``S^r``) and on the simulated robot (``S^m``), and moves its
    current drift to it over ``blend_time`` (a raised cosine, while the swing foot is in the
    air). The swinging foot, the CoM and the waist go through the current drift; a foot on
    the ground keeps the drift it landed with, so a stance reference never moves.
    Velocities are rotated by the drift's yaw (the blend's own rate, a few mm over
    ``blend_time``, is left to the tasks' feedback). Planar only: z, roll and pitch pass
    through unchanged.

    Input ports (the generator's, same names and units; see ``PatternGenerator``):
        left_foot, right_foot: abstract ``RigidTransform`` sole pose references.
        left_foot_vel, right_foot_vel: (6,) ``[v; ω]`` [m/s, rad/s], world frame.
        com: (3,) [m]. com_vel: (3,) [m/s].
        waist: abstract ``RigidTransform``.
        phase: (1,) 0 double support, 1 left support, 2 right support.
    Input ports (measurements):
        left_foot_reference, right_foot_reference: abstract ``RigidTransform``, the soles'
            poses in the reference configuration (``RobotKinematics`` operational points).
        body_poses: abstract ``list[RigidTransform]``, the simulated plant's ``body_poses``.
    Output ports (the same names as the generator's, mapped; held between ticks):
        left_foot, right_foot, left_foot_vel, right_foot_vel, com, com_vel, waist.
        drift: (3,) the current drift ``[x, y, yaw]`` [m, m, rad].

    Args:
        plant: the simulated (finalized) plant.
        model_instance: the robot's model instance in it.
        soles: side ("left", "right") → the sole frame's name in ``plant``.
        period: the control period [s] (the generator's).
        blend_time: [s] how long a new drift takes to apply, no longer than the shortest
            single support (``footsteps.WALKING_BOUNDS.single_support.low``, 0.2 s) so that
            it is complete at touch-down.
    """

    def __init__(
        self,
        plant: MultibodyPlant,
        model_instance: ModelInstanceIndex,
        soles: Mapping[str, str],
        *,
        period: float,
        blend_time: float = 0.2,
        name: str = "stance_anchor",
    ) -> None:
        super().__init__()
        self.set_name(name)
        if set(soles) != set(SIDES):
            raise ValueError(f"soles must name the 'left' and 'right' sole frames, got {sorted(soles)}")
        self._period = positive("period", period, unit="s")
        self._blend_time = positive("blend_time", blend_time, unit="s")
        shortest = WALKING_BOUNDS.single_support.low
        if self._blend_time > shortest:
            raise ValueError(f"blend_time = {blend_time} s exceeds the shortest single support, {shortest} s")
        self._soles = {}
        for side in SIDES:
            frame = plant.GetFrameByName(soles[side], model_instance)
            self._soles[side] = (int(frame.body().index()), frame.GetFixedPoseInBodyFrame())

        def pose_input(port_name: str):
            return self.DeclareAbstractInputPort(port_name, AbstractValue.Make(RigidTransform()))

        self._in = {f"{side}_foot": pose_input(f"{side}_foot") for side in SIDES}
        self._in.update(
            {f"{side}_foot_vel": self.DeclareVectorInputPort(f"{side}_foot_vel", 6) for side in SIDES}
        )
        self._in["com"] = self.DeclareVectorInputPort("com", 3)
        self._in["com_vel"] = self.DeclareVectorInputPort("com_vel", 3)
        self._in["waist"] = pose_input("waist")
        self._in["phase"] = self.DeclareVectorInputPort("phase", 1)
        self._reference = {side: pose_input(f"{side}_foot_reference") for side in SIDES}
        self._body_poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self._state = self.DeclareAbstractState(Value[object](_Anchor()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._period, 0.0, self._tick)

        state = self.abstract_state_ticket(self._state)

        def depends(*ports: str) -> set:
            return {state} | {self.input_port_ticket(self._in[p].get_index()) for p in ports}

        for side in SIDES:
            self.DeclareAbstractOutputPort(
                f"{side}_foot",
                lambda: AbstractValue.Make(RigidTransform()),
                self._pose_calc(f"{side}_foot", lambda a, s=side: a.feet[s]),
                prerequisites_of_calc=depends(f"{side}_foot"),
            )
            self.DeclareVectorOutputPort(
                f"{side}_foot_vel",
                6,
                self._velocity_calc(f"{side}_foot_vel", lambda a, s=side: a.feet[s]),
                prerequisites_of_calc=depends(f"{side}_foot_vel"),
            )
        self.DeclareVectorOutputPort("com", 3, self._calc_com, prerequisites_of_calc=depends("com"))
        self.DeclareVectorOutputPort(
            "com_vel",
            3,
            lambda c, out: out.SetFromVector(
                self._rotated(self._anchor(c).delta, self._in["com_vel"].Eval(c))
            ),
            prerequisites_of_calc=depends("com_vel"),
        )
        self.DeclareAbstractOutputPort(
            "waist",
            lambda: AbstractValue.Make(RigidTransform()),
            self._pose_calc("waist", lambda a: a.delta),
            prerequisites_of_calc=depends("waist"),
        )
        self.DeclareVectorOutputPort(
            "drift",
            3,
            lambda c, out: out.SetFromVector(self._drift(c)),
            prerequisites_of_calc={state},
        )

    # --- outputs ------------------------------------------------------------------------
    def _anchor(self, context: Context) -> _Anchor:
        return context.get_abstract_state(self._state).get_value()

    def _drift(self, context: Context) -> np.ndarray:
        d = self._anchor(context).delta
        return np.array([d.x, d.y, d.yaw])

    def _pose_calc(
        self, port: str, which: Callable[[_Anchor], PlanarTransform]
    ) -> Callable[[Context, AbstractValue], None]:
        def calc(context: Context, value: AbstractValue) -> None:
            value.set_value(_map_pose(which(self._anchor(context)), self._in[port].Eval(context)))

        return calc

    def _velocity_calc(
        self, port: str, which: Callable[[_Anchor], PlanarTransform]
    ) -> Callable[[Context, BasicVector], None]:
        def calc(context: Context, out: BasicVector) -> None:
            out.SetFromVector(self._rotated(which(self._anchor(context)), self._in[port].Eval(context)))

        return calc

    @staticmethod
    def _rotated(delta: PlanarTransform, v: np.ndarray) -> np.ndarray:
        """``v`` ((3,) linear or (6,) ``[v; ω]``) with its horizontal linear part rotated."""
        out = np.array(v, dtype=float)
        out[:2] = delta.rotate(out[:2])
        return out

    def _calc_com(self, context: Context, out: BasicVector) -> None:
        com = np.array(self._in["com"].Eval(context), dtype=float)
        com[:2] = self._anchor(context).delta.apply_point(com[:2])
        out.SetFromVector(com)

    # --- the tick -----------------------------------------------------------------------
    def _measured_sole(self, context: Context, side: str) -> PlanarTransform:
        body, X_BF = self._soles[side]
        return _planar(self._body_poses.Eval(context)[body] @ X_BF)

    def _tick(self, context: Context, state: State) -> None:
        a = self._anchor(context)
        phase = int(round(self._in["phase"].Eval(context)[0]))
        now = context.get_time()
        start, swing_start, target, lift_time = a.start, a.swing_start, a.target, a.lift_time
        if a.phase == PHASE_DOUBLE and phase in _SWINGING:
            stance = "left" if phase == PHASE_LEFT_SUPPORT else "right"
            reference = _planar(self._reference[stance].Eval(context))
            target = drift(reference, self._measured_sole(context, stance))
            start, swing_start, lift_time = a.delta, a.feet[_SWINGING[phase]], now
        s = min(1.0, max(0.0, (now - lift_time) / self._blend_time))
        s = 0.5 * (1.0 - math.cos(math.pi * s))
        feet = dict(a.feet)
        if phase in _SWINGING:
            feet[_SWINGING[phase]] = blend(swing_start, target, s)
        state.get_mutable_abstract_state(self._state).set_value(
            _Anchor(
                delta=blend(start, target, s),
                start=start,
                swing_start=swing_start,
                target=target,
                lift_time=lift_time,
                feet=feet,
                phase=phase,
            )
        )
