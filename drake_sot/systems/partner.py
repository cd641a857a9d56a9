"""A simulated interaction partner: forces applied to the robot's hands in the plant.

A partner's script is data: :class:`ConstantForce` segments (a scripted external force,
e.g. a shove) and :class:`Hold` segments (the partner grips a hand and moves it through a
spring-damper).

Both systems compute their forces at the control period and hold them in state, so the
plant's ``applied_spatial_force`` input is a cached value between ticks (no Python per
physics step).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue, Value
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce, MultibodyPlant
from pydrake.systems.framework import Context, State

from drake_sot import validation
from drake_sot.systems.leaf import SotLeafSystem


@dataclass(frozen=True)
class ConstantForce:
    """A constant force ``force`` (3,) [N] (world frame) on a body from ``start`` to ``end`` [s].

    Raises ValueError for a non-finite time or force component.
    """

    start: float
    end: float
    force: tuple[float, float, float]

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", validation.finite("ConstantForce.start", self.start))
        object.__setattr__(self, "end", validation.finite("ConstantForce.end", self.end))
        object.__setattr__(self, "force", tuple(validation.vector("ConstantForce.force", self.force, 3)))


@dataclass(frozen=True)
class Hold:
    """The partner holds a hand from ``start`` [s] and moves its grip along ``keyframes``.

    ``keyframes`` are ``(time [s], offset (3,) [m])`` from where the hand was at
    ``start``, linearly interpolated (held after the last one); the partner's arm is a
    spring-damper of ``stiffness`` [N/m] and ``damping`` [N·s/m] between its grip and the
    hand, until ``end``.
    """

    start: float
    end: float
    keyframes: tuple[tuple[float, tuple[float, float, float]], ...]
    stiffness: float = 300.0
    damping: float = 40.0


def _spatial_force(body_index, point: np.ndarray, force: np.ndarray) -> ExternallyAppliedSpatialForce:
    f = ExternallyAppliedSpatialForce()
    f.body_index = body_index
    f.p_BoBq_B = point
    f.F_Bq_W = SpatialForce(np.zeros(3), force)
    return f


class Partner(SotLeafSystem):
    """Forces of a partner on named bodies of the simulated plant (the hands).

    Input ports:
        body_poses: abstract ``list[RigidTransform]`` (the plant's ``body_poses``).
        body_spatial_velocities: abstract ``list[SpatialVelocity]`` (the plant's
            ``body_spatial_velocities``).
    Output ports:
        spatial_forces: abstract ``list[ExternallyAppliedSpatialForce]`` for the plant's
            ``applied_spatial_force`` input, applied at each body's point.
        forces: (3·k,) [N] the force on each body, in the order of ``script``, for logging.
        targets: (3·k,) [m] where the partner's hand means each gripped point to be (world
            frame): a :class:`Hold`'s grip origin plus its keyframed offset, at the last update;
            the point itself while no :class:`Hold` is active (zeros before the first update).

    Args:
        plant: the simulated plant (finalized).
        script: body name → a sequence of :class:`ConstantForce` and :class:`Hold` segments
            (non-overlapping in time).
        period: update period [s] (the control period).
        points: body name → the point (3,) [m], in the body frame, where the forces apply
            and a :class:`Hold` grips; a body's origin when not given.
    """

    def __init__(
        self,
        plant: MultibodyPlant,
        script: Mapping[str, Sequence[ConstantForce | Hold]],
        *,
        period: float = 0.005,
        points: Mapping[str, Sequence[float]] | None = None,
    ) -> None:
        super().__init__()
        self._bodies = [plant.GetBodyByName(name) for name in script]
        self._script = [tuple(segments) for segments in script.values()]
        stray = sorted(set(points or {}) - set(script))
        if stray:
            raise ValueError(f"points for {stray}, which the script does not name; it names {list(script)}")
        self._points = [
            validation.vector(f"points[{name!r}]", (points or {}).get(name, np.zeros(3)), 3)
            for name in script
        ]
        for name, segments in script.items():
            ordered = sorted(segments, key=lambda s: s.start)
            for a, b in zip(ordered, ordered[1:], strict=False):
                if b.start < a.end:
                    raise ValueError(f"partner script for {name!r}: {a} and {b} overlap")
            for s in segments:
                if not s.end > s.start:
                    raise ValueError(f"partner script for {name!r}: {s} ends before it starts")
        k = len(self._bodies)
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self._velocities = self.DeclareAbstractInputPort(
            "body_spatial_velocities", plant.get_body_spatial_velocities_output_port().Allocate()
        )
        # State: the force on each body (discrete) and the grip origins of Hold segments (abstract, tiny).
        self._force = self.DeclareDiscreteState(np.zeros(3 * k))
        self._targets = self.DeclareDiscreteState(np.zeros(3 * k))
        self._grips = self.DeclareAbstractState(Value[object](()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._update)
        self.DeclareAbstractOutputPort(
            "spatial_forces",
            lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]),
            self._calc_spatial_forces,
            prerequisites_of_calc={self.discrete_state_ticket(self._force)},
        )
        self.DeclareStateOutputPort("forces", self._force)
        self.DeclareStateOutputPort("targets", self._targets)

    def _active(self, segments, t: float):
        for s in segments:
            if s.start <= t < s.end:
                return s
        return None

    def _update(self, context: Context, state: State) -> None:
        t = context.get_time()
        poses = self._poses.Eval(context)
        velocities = self._velocities.Eval(context)
        grips = dict(context.get_abstract_state(self._grips).get_value())
        forces = np.zeros((len(self._bodies), 3))
        targets = np.zeros((len(self._bodies), 3))
        for i, (body, segments, p_B) in enumerate(zip(self._bodies, self._script, self._points, strict=True)):
            segment = self._active(segments, t)
            X_WB = poses[int(body.index())]
            p = X_WB @ p_B
            targets[i] = p
            if isinstance(segment, ConstantForce):
                forces[i] = segment.force
            elif isinstance(segment, Hold):
                V_WB = velocities[int(body.index())]
                v = V_WB.Shift(X_WB.rotation() @ p_B).translational()
                origin = grips.setdefault((i, segment.start), tuple(p))
                grip, grip_velocity = _interpolate(segment.keyframes, t - segment.start)
                targets[i] = np.array(origin) + grip
                forces[i] = segment.stiffness * (targets[i] - p) + segment.damping * (grip_velocity - v)
        state.get_mutable_discrete_state(self._force).SetFromVector(forces.reshape(-1))
        state.get_mutable_discrete_state(self._targets).SetFromVector(targets.reshape(-1))
        state.get_mutable_abstract_state(self._grips).set_value(tuple(grips.items()))

    def _calc_spatial_forces(self, context: Context, value: AbstractValue) -> None:
        forces = context.get_discrete_state(self._force).get_value().reshape(-1, 3)
        value.set_value(
            [
                _spatial_force(b.index(), p_B, f)
                for b, p_B, f in zip(self._bodies, self._points, forces, strict=True)
            ]
        )


def _interpolate(keyframes, t: float) -> tuple[np.ndarray, np.ndarray]:
    """Offset (3,) and its rate (3,) at time t along piecewise-linear keyframes (held outside)."""
    times = np.array([k[0] for k in keyframes])
    offsets = np.array([k[1] for k in keyframes], dtype=float)
    if t <= times[0]:
        return offsets[0], np.zeros(3)
    if t >= times[-1]:
        return offsets[-1], np.zeros(3)
    j = int(np.searchsorted(times, t, side="right")) - 1
    rate = (offsets[j + 1] - offsets[j]) / (times[j + 1] - times[j])
    return offsets[j] + rate * (t - times[j]), rate
