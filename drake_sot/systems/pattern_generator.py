"""``PatternGenerator``: the SoT's walking pattern-generator entity ("pg"), ZMP preview control.

A thin Drake adapter over :class:`drake_sot.walk_planner.WalkPlanner`, which does the
planning: footprints go in (a step sequence, or a velocity from which footprints are made
as the walk goes); CoM, feet and ZMP references come out, one sample per control tick. As
in Evrard et al. 2009, the generator is a *planner*: it keeps at least
``FOOTPRINTS_AHEAD`` footprints ahead of the robot, and a new footprint can be accepted
each time a step is executed, so a walk can be steered while it runs; footprints already
planned are not changed.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from pydrake.common.value import AbstractValue, Value
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import Context, State

from drake_sot import validation
from drake_sot.errors import UnknownNameError
from drake_sot.footsteps import SIDES, Footstep, StepLimits, StepTiming, relative_steps
from drake_sot.systems._context import own_context
from drake_sot.systems.leaf import SotLeafSystem
from drake_sot.walk_planner import FOOTPRINTS_AHEAD, WalkPlanner


class PatternGenerator(SotLeafSystem):
    """Walking references from footprints by ZMP preview control (Kajita et al. 2003).

    Output ports (one sample per control tick, held between ticks):
        com: CoM reference (3,) [m]; z is the constant CoM height of the cart-table model.
        com_vel: CoM velocity reference (3,) [m/s].
        left_foot, right_foot: abstract ``RigidTransform``, sole pose references in world.
        left_foot_vel, right_foot_vel: sole velocity references ``[v; ω]`` (6,) [m/s, rad/s],
            world frame (plug into ``FeaturePoint6d.velocity_des``).
        waist: abstract ``RigidTransform``, waist orientation reference (yaw midway
            between the feet; position = CoM reference) [m].
        zmp_ref: ZMP reference (2,) [m].
        zmp: ZMP of the cart-table model at this sample (2,) [m].
        phase: (1,) 0 double support, 1 left support (right foot swinging), 2 right support.
        contacts: (2,) [left, right] 1 when the foot is on the ground.
        load: (2,) [left, right] share of the weight each foot carries, from where the
            ZMP reference lies between the soles (1/0 in single support, moving with the
            ZMP during double support).
        in_process: (1,) 1 while a walk is under way, 0 once standing.
        planned_feet: abstract ``(left Footstep, right Footstep, last side or None)``, the last
            planned footprint of each foot and the side of the last planned step.

    Input port (optional):
        next_footprint: abstract tuple of at most one ``Footstep`` (``()``: no step; a tuple,
            because a Drake abstract value cannot hold None since drake 1.58). When connected
            (and not walking from a velocity), at each tick where fewer than
            ``FOOTPRINTS_AHEAD`` landings lie ahead the generator reads it and plans that
            footprint, at most one per tick: up to four footprints are kept ahead, and then one
            new footprint is read per executed step, as in Evrard et al. 2009, III-C. The
            footprint must respect ``limits`` (else the tick raises the limit's error).

    Commands (act on a context, like the paper's ``pg.parsecmd``): :meth:`add_steps`,
    :meth:`set_velocity`, :meth:`set_timing`, :meth:`set_model`, :meth:`parsecmd`.

    Args:
        left, right: initial sole footprints (the right one a valid step from the left one
            under ``limits``).
        com_height: cart-table height z_c [m] (the CoM height of the robot), within
            ``footsteps.WALKING_BOUNDS.com_height``.
        dt: control period [s]. horizon: preview time [s], within
            ``footsteps.WALKING_BOUNDS.preview_time``. q, r: LQ weights.
        timing: step timing. limits: reachability of a step.
        com: initial CoM ground position (2,) [m]; default the midpoint of the soles.
    """

    def __init__(
        self,
        left: Footstep,
        right: Footstep,
        *,
        com_height: float,
        dt: float = 0.005,
        horizon: float = 1.6,
        q: float = 1.0,
        r: float = 1e-6,
        timing: StepTiming = StepTiming(),
        limits: StepLimits = StepLimits(),
        com: np.ndarray | None = None,
        name: str = "pg",
    ) -> None:
        super().__init__()
        self.set_name(name)
        planner = WalkPlanner.start(
            left,
            right,
            com_height=com_height,
            dt=dt,
            horizon=horizon,
            q=q,
            r=r,
            timing=timing,
            limits=limits,
            com=com,
        )
        self._dt = planner.dt
        self._planner = self.DeclareAbstractState(Value[object](planner))
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._dt, 0.0, self._tick)
        ticket = {self.abstract_state_ticket(self._planner)}

        def vector(name: str, size: int, fn: Callable[[WalkPlanner], np.ndarray]) -> None:
            self.DeclareVectorOutputPort(
                name, size, lambda c, out: out.SetFromVector(fn(self._state(c))), prerequisites_of_calc=ticket
            )

        def pose(name: str, fn: Callable[[WalkPlanner], RigidTransform]) -> None:
            self.DeclareAbstractOutputPort(
                name,
                lambda: AbstractValue.Make(RigidTransform()),
                lambda c, value: value.set_value(fn(self._state(c))),
                prerequisites_of_calc=ticket,
            )

        vector("com", 3, lambda p: p.com)
        vector("com_vel", 3, lambda p: p.com_vel)
        pose("left_foot", lambda p: _sole_pose(p.sole("left")))
        pose("right_foot", lambda p: _sole_pose(p.sole("right")))
        vector("left_foot_vel", 6, lambda p: _spatial_velocity(p.sole_velocity("left")))
        vector("right_foot_vel", 6, lambda p: _spatial_velocity(p.sole_velocity("right")))
        pose("waist", lambda p: RigidTransform(RotationMatrix.MakeZRotation(p.waist_yaw), p.com))
        vector("zmp_ref", 2, lambda p: p.zmp_ref)
        vector("zmp", 2, lambda p: p.zmp)
        vector("phase", 1, lambda p: np.array([float(p.phase)]))
        vector("contacts", 2, lambda p: p.contacts)
        vector("load", 2, lambda p: p.load)
        vector("in_process", 1, lambda p: np.array([float(p.in_process)]))
        self.DeclareAbstractOutputPort(
            "planned_feet",
            lambda: Value[object]((left, right, None)),
            lambda c, value: value.set_value(
                (*(self._state(c).feet[s] for s in SIDES), self._state(c).last_side)
            ),
            prerequisites_of_calc=ticket,
        )
        self._next = self.DeclareAbstractInputPort("next_footprint", Value[object](()))

    # --- the state ----------------------------------------------------------------------
    def _state(self, context: Context) -> WalkPlanner:
        return context.get_abstract_state(self._planner).get_value()

    def planner(self, context: Context) -> WalkPlanner:
        """The planner's current value (own or root context)."""
        return self._state(own_context(self, context))

    def _update(self, context: Context, change: Callable[[WalkPlanner], WalkPlanner]) -> None:
        context = own_context(self, context)
        context.get_mutable_abstract_state(self._planner).set_value(change(self._state(context)))

    def footprints(self, context: Context) -> dict[str, Footstep]:
        """The last planned footprint of each foot (own or root context)."""
        return dict(self.planner(context).feet)

    def planned_landings(self, context: Context) -> list[tuple[float, Footstep]]:
        """``(time [s], footprint)`` of every landing still ahead, in order (own or root context)."""
        now = context.get_time()
        return [(now + ticks * self._dt, step) for ticks, step in self.planner(context).landings_ahead()]

    # --- commands -----------------------------------------------------------------------
    def add_steps(self, context: Context, steps: Sequence[Footstep]) -> None:
        """Append footprints (absolute, world frame) after those already planned.

        Each is checked against the foot it steps from (the last planned footprint of
        the other foot); a step beyond a limit is refused with the limit's name, and
        then none of ``steps`` is added.
        """
        self._update(context, lambda p: p.add_steps(steps))

    def set_velocity(self, context: Context, vx: float, vy: float = 0.0, wz: float = 0.0) -> None:
        """Walk at ``(vx, vy)`` [m/s] in the robot frame and turn at ``wz`` [rad/s].

        Footprints are made from the velocity as the walk goes, keeping
        ``FOOTPRINTS_AHEAD`` planned; those already planned are kept. ``(0, 0, 0)``
        stops: one last step brings the feet side by side. A velocity whose steps
        would exceed a limit is refused, naming it.
        """
        self._update(context, lambda p: p.with_velocity(vx, vy, wz))

    def set_timing(
        self,
        context: Context,
        *,
        single_support: float | None = None,
        double_support: float | None = None,
        step_height: float | None = None,
    ) -> None:
        """Change the timing [s] or the step height [m] of the steps planned afterwards.

        Refused, naming the bound, outside ``footsteps.WALKING_BOUNDS``.
        """
        changes = {
            name: value
            for name, value in (
                ("single_support", single_support),
                ("double_support", double_support),
                ("step_height", step_height),
            )
            if value is not None
        }
        self._update(context, lambda p: p.with_timing(**changes))

    def set_model(
        self, context: Context, *, com_height: float | None = None, horizon: float | None = None
    ) -> None:
        """Change the cart-table height [m] or the preview time [s]; only while standing.

        Refused, naming the bound, outside ``footsteps.WALKING_BOUNDS``.
        """
        self._update(context, lambda p: p.with_model(com_height=com_height, horizon=horizon))

    def parsecmd(self, context: Context, command: str) -> None:
        """The original generator's command interface, e.g. ``":stepseq 0.2 -0.19 0 0.2 0.19 0"``.

        Verbs: ``:stepseq x y yaw ...`` (each triple is a footprint in the frame of the
        other foot's last footprint; y > 0 steps with the left foot, y < 0 with the
        right), ``:singlesupporttime T``, ``:doublesupporttime T``, ``:stepheight h``,
        ``:comheight z`` and ``:previewcontroltime T`` (these two only while standing).
        Timing changes apply to the steps planned afterwards. Values outside
        ``footsteps.WALKING_BOUNDS`` are refused, the error naming the verb and the bound.

        Raises:
            UnknownNameError: an unknown verb (a ValueError; lists the verbs).
            ValueError: an empty command, arguments that are not numbers or that the verb
                refuses (naming the verb).
        """
        words = command.split()
        if not words:
            raise ValueError("empty command")
        verb, args = words[0], words[1:]
        handlers: dict[str, Callable[[list[float]], None]] = {
            ":stepseq": lambda v: self._stepseq(context, v),
            ":singlesupporttime": lambda v: self.set_timing(context, single_support=_one(v)),
            ":doublesupporttime": lambda v: self.set_timing(context, double_support=_one(v)),
            ":stepheight": lambda v: self.set_timing(context, step_height=_one(v)),
            ":comheight": lambda v: self.set_model(context, com_height=_one(v)),
            ":previewcontroltime": lambda v: self.set_model(context, horizon=_one(v)),
        }
        if verb not in handlers:
            raise UnknownNameError("command", verb, handlers)
        try:
            values = [float(a) for a in args]
        except ValueError:
            raise ValueError(f"{verb}: arguments must be numbers, got {' '.join(args)!r}") from None
        try:
            handlers[verb](values)
        except ValueError as err:
            raise ValueError(f"{verb}: {err}") from None

    def _stepseq(self, context: Context, values: list[float]) -> None:
        if not values or len(values) % 3:
            raise ValueError(f"takes x y yaw triples, got {len(values)} numbers")
        moves = []
        for i, (x, y, yaw) in enumerate(zip(values[0::3], values[1::3], values[2::3], strict=True)):
            for name, value in (("x", x), ("y", y), ("yaw", yaw)):
                validation.finite(f"triple {i} {name}", value)
            if y == 0.0:
                raise ValueError(f"triple {i} ({x}, {y}, {yaw}): y = 0 says neither left nor right")
            moves.append(("left" if y > 0 else "right", x, y, yaw))
        feet = self.footprints(context)
        self.add_steps(context, relative_steps(feet["left"], feet["right"], moves))

    # --- the control tick -----------------------------------------------------------------
    def _tick(self, context: Context, state: State) -> None:
        planner = self._state(context).advance()
        if (
            planner.velocity is None
            and len(planner.landings_ahead()) < FOOTPRINTS_AHEAD
            and self._next.HasValue(context)
        ):
            steps = self._next.Eval(context)
            if len(steps) > 1:
                raise ValueError(f"next_footprint: at most one footprint per tick, got {len(steps)}")
            planner = planner.add_steps(list(steps)) if steps else planner
        state.get_mutable_abstract_state(self._planner).set_value(planner)


def _one(values: list[float]) -> float:
    if len(values) != 1:
        raise ValueError(f"takes one number, got {len(values)}")
    return values[0]


def _sole_pose(sample: np.ndarray) -> RigidTransform:
    """The ``RigidTransform`` of a sole sample ``[x, y, z, yaw]``."""
    return RigidTransform(RotationMatrix.MakeZRotation(sample[3]), sample[:3])


def _spatial_velocity(rate: np.ndarray) -> np.ndarray:
    """``[v; ω]`` (6,) of a sole velocity sample ``[ẋ, ẏ, ż, yaw rate]``."""
    return np.array([rate[0], rate[1], rate[2], 0.0, 0.0, rate[3]])
