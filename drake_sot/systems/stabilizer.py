"""``BalanceStabilizer``: DCM feedback between the walking references and the Stack of Tasks.

The pattern generator plans the CoM of a cart-table model; the simulated robot, pushed or
simply not that model, drifts from it. The stabilizer measures the robot (CoM and CoM
velocity of the simulated plant, ZMP from the ankle force sensors), and corrects the CoM
reference sent to the CoM task so that the divergent component of motion returns to its
reference (:mod:`drake_sot.stabilization` has the equations and the argument for them).
With the hands' measured wrenches (``hand_wrenches``) its model is the linear inverted
pendulum with external forces at the hands (eq. 4-6, 2' there).
"""

from __future__ import annotations

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Context, DiscreteValues

from drake_sot import validation
from drake_sot.recovery import dcm_excess
from drake_sot.stabilization import (
    HandLoad,
    StabilizerGains,
    divergent_component,
    low_pass,
    natural_frequency,
    stabilizer_step,
)
from drake_sot.support import sole_corners, support_polygon
from drake_sot.systems.leaf import SotLeafSystem

#: Layout of the discrete state: offset Δc (2), its rate Δċ (2), filtered measured ZMP (2),
#: desired ZMP (2), measured DCM (2), saturation flags (2: ZMP, offset), DCM excess (2), then the
#: low-passed hands' wrenches (12, NaN while there is none).
_OFFSET, _RATE, _ZMP_F, _ZMP_D, _DCM, _FLAGS, _EXCESS = (slice(i, i + 2) for i in range(0, 14, 2))
_WRENCHES = slice(14, 26)


class BalanceStabilizer(SotLeafSystem):
    """Corrects the CoM reference by DCM feedback on the measured CoM, CoM velocity and ZMP.

    At each control tick (``period``) it reads the references and the measurements, applies
    :func:`drake_sot.stabilization.stabilizer_step` (desired ZMP from the DCM error,
    projected into the support polygon of the soles in contact; CoM offset moved to track
    it) and holds the result; the corrected reference is the input reference plus the held
    offset (ground axes only: the CoM height is passed through). The support polygon is the
    measured one: rectangles of ``sole`` centred on the sole frames of the simulated robot,
    for the feet whose sensors read a vertical ground force above ``contact_force`` (the
    planned contacts may be wrong after a push: a foot that should swing may still carry the
    robot).

    Input ports:
        com_ref: (3,) [m] CoM reference (e.g. ``PatternGenerator.com``); z is the
            inverted pendulum's height.
        com_vel_ref: (3,) [m/s] CoM velocity reference (``PatternGenerator.com_vel``).
        zmp_ref: (2,) [m] ZMP of the reference motion (``PatternGenerator.zmp``).
        zmp: (2,) [m] measured ZMP (``ZmpEstimator.zmp``); NaN when the feet carry no load.
        state: (nq + nv,) the simulated robot's state ``[q; v]`` (the plant's state output
            of the robot's model instance), laid out as ``plant``'s.
        foot_forces: (2,) [N] [left, right] vertical ground force on each foot
            (``ZmpEstimator.foot_forces``).
        hand_wrenches: (12,) only with ``hands``, optional: ``[τ_l; f_l; τ_r; f_r]`` the
            external wrench on the left, then the right hand ([N m], [N]): what the world (an
            object, a partner) applies on the hand, torque about the origin of the hand frame
            named in ``hands``, world axes (``AdmittanceController.wrench_external``). The
            desired ZMP is then that of the inverted pendulum with these wrenches
            low-passed (``gains.wrench_filter``; :mod:`drake_sot.stabilization`, eq. 6 and 2'),
            the hands placed by ``state``. A reading that is not finite (a faulty wrist sensor)
            leaves the filtered wrenches as they were; unconnected, or before the first finite
            reading, the ticks are computed without them, as by a stabilizer without the port.
    Output ports:
        com: (3,) [m] corrected CoM reference, for the CoM feature's ``sdes``.
        com_vel: (3,) [m/s] corrected CoM velocity reference, for ``sdes_dot``.
        offset: (2,) [m] the CoM offset Δc.
        zmp_desired: (2,) [m] the desired ZMP p_d (inside the support polygon).
        dcm: (2,) [m] the measured divergent component of motion ξ.
        saturated: (2,) [ZMP, offset] 1 when, at the last tick, the desired ZMP was projected
            into the support polygon, or the offset was held at ``gains.max_offset``.
        dcm_excess: (2,) [m] ξ minus its nearest point of the convex hull of both soles where
            they are (loaded or not: a robot standing on both feet and rocking from one to
            the other keeps ξ inside it): zero while ξ is inside, else how far and which way
            it left, what no ZMP of the standing robot can bring back (``HipStrategy`` reads
            it). Meant for a robot standing on both feet: in a walk's single support the
            swinging sole is counted too.

    Args:
        plant: a finalized model of the robot (e.g. the controller's model) whose positions and
            velocities lay out ``state``; the stabilizer keeps its own context of it.
        soles: names of the left and right sole frames in ``plant`` (centred on the soles).
        sole: (length, width) [m] of a sole.
        contact_force: [N] a foot is in the support polygon above this vertical force, > 0.
        hands: names of the left and right hand frames in ``plant`` where ``hand_wrenches``
            apply; None: no ``hand_wrenches`` port.
        gains: the stabilizer's gains and limits.
        period: [s] control period, finite and > 0.
        name: system name.
    """

    def __init__(
        self,
        plant: MultibodyPlant,
        soles: tuple[str, str],
        sole: tuple[float, float],
        *,
        contact_force: float = 50.0,
        hands: tuple[str, str] | None = None,
        gains: StabilizerGains = StabilizerGains(),
        period: float = 0.005,
        name: str = "stabilizer",
    ) -> None:
        super().__init__()
        self.set_name(name)
        if not isinstance(gains, StabilizerGains):
            raise ValueError(f"gains = {gains!r}: must be a StabilizerGains")
        self._period = validation.positive("period", period, unit="s")
        self._sole = (
            validation.positive("sole length", sole[0], unit="m"),
            validation.positive("sole width", sole[1], unit="m"),
        )
        self.gains = gains
        self._plant = plant
        self._plant_context = plant.CreateDefaultContext()
        self._com_ref = self.DeclareVectorInputPort("com_ref", 3)
        self._com_vel_ref = self.DeclareVectorInputPort("com_vel_ref", 3)
        self._zmp_ref = self.DeclareVectorInputPort("zmp_ref", 2)
        self._zmp = self.DeclareVectorInputPort("zmp", 2)
        self._x = self.DeclareVectorInputPort("state", plant.num_multibody_states())
        self._foot_forces = self.DeclareVectorInputPort("foot_forces", 2)
        self._soles = [plant.GetFrameByName(name) for name in soles]
        self._contact_force = validation.positive("contact_force", contact_force, unit="N")
        self._hands = None if hands is None else [plant.GetFrameByName(name) for name in hands]
        self._hand_wrenches = None if hands is None else self.DeclareVectorInputPort("hand_wrenches", 12)
        self._mass = plant.CalcTotalMass(self._plant_context)
        initial = np.zeros(26)
        initial[_ZMP_F] = np.nan  # no measurement yet
        initial[_WRENCHES] = np.nan
        self._state = self.DeclareDiscreteState(initial)
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._update)
        held = self.discrete_state_ticket(self._state)
        self.DeclareVectorOutputPort(
            "com",
            3,
            lambda c, out: out.SetFromVector(self._com_ref.Eval(c) + np.append(self._held(c)[_OFFSET], 0.0)),
            prerequisites_of_calc={held, self.input_port_ticket(self._com_ref.get_index())},
        )
        self.DeclareVectorOutputPort(
            "com_vel",
            3,
            lambda c, out: out.SetFromVector(
                self._com_vel_ref.Eval(c) + np.append(self._held(c)[_RATE], 0.0)
            ),
            prerequisites_of_calc={held, self.input_port_ticket(self._com_vel_ref.get_index())},
        )
        for port, part in (
            ("offset", _OFFSET),
            ("zmp_desired", _ZMP_D),
            ("dcm", _DCM),
            ("saturated", _FLAGS),
            ("dcm_excess", _EXCESS),
        ):
            self.DeclareVectorOutputPort(
                port,
                2,
                lambda c, out, part=part: out.SetFromVector(self._held(c)[part]),
                prerequisites_of_calc={held},
            )

    def _held(self, context: Context) -> np.ndarray:
        return context.get_discrete_state(self._state).get_value()

    def support_polygon(
        self, foot_forces: np.ndarray, feet: list[RigidTransform], *, hull: np.ndarray | None = None
    ) -> np.ndarray:
        """The support polygon (k, 2) of the soles at ``feet`` whose force is above
        ``contact_force`` (both when none is: the ZMP is then undefined); ``hull``: the hull of
        all ``feet`` when already computed (it is the polygon when all or none are loaded)."""
        on = [X for X, f in zip(feet, foot_forces, strict=True) if f > self._contact_force]
        if len(on) in (0, len(feet)):
            return self._hull(feet) if hull is None else hull
        return self._hull(on)

    def _hull(self, feet: list[RigidTransform]) -> np.ndarray:
        """The convex hull (k, 2) of the soles at ``feet``."""
        return support_polygon(
            [
                sole_corners(*X.translation()[:2], RollPitchYaw(X.rotation()).yaw_angle(), self._sole)
                for X in feet
            ]
        )

    def _hand_load(self, context: Context, filtered: np.ndarray) -> tuple[HandLoad | None, np.ndarray]:
        """The hands' low-passed wrenches at this tick (needs the plant context set), or None (see
        ``hand_wrenches``), and the filter's new state (12,)."""
        if self._hand_wrenches is None or not self._hand_wrenches.HasValue(context):
            return None, filtered
        filtered = low_pass(
            filtered, self._hand_wrenches.Eval(context), self._period, self.gains.wrench_filter
        )
        if not np.all(np.isfinite(filtered)):
            return None, filtered
        points = [frame.CalcPoseInWorld(self._plant_context).translation() for frame in self._hands]
        return HandLoad(self._mass, np.array(points), filtered.reshape(2, 6)), filtered

    def _update(self, context: Context, discrete: DiscreteValues) -> None:
        com_ref = self._com_ref.Eval(context)
        self._plant.SetPositionsAndVelocities(self._plant_context, self._x.Eval(context))
        com = self._plant.CalcCenterOfMassPositionInWorld(self._plant_context)
        com_vel = self._plant.CalcCenterOfMassTranslationalVelocityInWorld(self._plant_context)
        omega = natural_frequency(com_ref[2])
        feet = [frame.CalcPoseInWorld(self._plant_context) for frame in self._soles]
        both = self._hull(feet)
        polygon = self.support_polygon(self._foot_forces.Eval(context), feet, hull=both)
        held = self._held(context)
        dcm = divergent_component(com[:2], com_vel[:2], omega)
        hands, wrenches = self._hand_load(context, held[_WRENCHES])
        step = stabilizer_step(
            held[_OFFSET],
            held[_RATE],
            held[_ZMP_F],
            com_ref=com_ref[:2],
            com_vel_ref=self._com_vel_ref.Eval(context)[:2],
            zmp_ref=self._zmp_ref.Eval(context),
            com=com[:2],
            com_vel=com_vel[:2],
            zmp=self._zmp.Eval(context),
            polygon=polygon,
            omega=omega,
            dt=self._period,
            gains=self.gains,
            hands=hands,
        )
        discrete.set_value(
            self._state,
            np.concatenate(
                (
                    step.offset,
                    step.offset_rate,
                    step.zmp_filtered,
                    step.zmp_desired,
                    dcm,
                    [float(step.zmp_saturated), float(step.offset_saturated)],
                    dcm_excess(both, dcm),
                    wrenches,
                )
            ),
        )
