"""``AdmittanceController``: the force task's reference for one hand (Mansard et al.
2009, IV-C; Evrard et al. 2009, III-B).

The hand's wrist force/torque sensor measures what the wrist applies on the hand;
after removing the hand's own weight, what is left is the wrench the world (a human
partner, an object) applies on the hand. That wrench, plus a reference wrench sent
by a remote operator, drives a virtual mass-damper(-spring) whose pose is the
reference of the hand's 6D task (``FeaturePoint6d``): the hand yields to pushes.
The dynamics live in :class:`drake_sot.admittance.MassDamperSpring`; the A-weighted variant
(``weighted=True``, Evrard et al. 2009, III-B, eq. 5-7) makes the translation's virtual mass the
hand's apparent inertia (:func:`drake_sot.admittance.apparent_inertia`,
:func:`drake_sot.admittance.coupled_step`).
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import (
    Context,
    DiscreteValues,
    EventStatus,
)

from drake_sot import so3
from drake_sot.admittance import MassDamperSpring, apparent_inertia, coupled_step
from drake_sot.configuration import quaternion_to_rotation
from drake_sot.systems._context import own_context
from drake_sot.systems.leaf import SotLeafSystem
from drake_sot.validation import nonnegative, per_axis, positive, vector

#: Fault codes of the ``fault`` output.
FAULT_NONE, FAULT_NOT_FINITE, FAULT_FORCE_LIMIT, FAULT_TORQUE_LIMIT = 0, 1, 2, 3

# Layout of the discrete state vector.
_P = slice(0, 3)  # reference position [m], world
_Q = slice(3, 7)  # reference orientation, unit quaternion [w, x, y, z]
_V = slice(7, 13)  # reference velocity [v; ω] [m/s, rad/s], world
_P_REST = slice(13, 16)  # spring rest position: the hand position at activation
_Q_REST = slice(16, 20)  # spring rest orientation (quaternion)
_ACTIVE, _FAULT, _SATURATED = 20, 21, 22  # flags of the last update
_W = slice(23, 29)  # compensated external wrench [τ; f] of the last update
_MASS = slice(29, 38)  # the translation's virtual mass (3, 3) of the last update, row-major
_SIZE = 38


def _quaternion(R: np.ndarray) -> np.ndarray:
    """Unit quaternion [w, x, y, z] of the rotation matrix R."""
    q = RotationMatrix(R).ToQuaternion().wxyz()
    return q / np.linalg.norm(q)


class AdmittanceController(SotLeafSystem):
    """Admittance control of one hand: the pose reference of its force task.

    Every control period, the external wrench on the hand is estimated from the wrist
    sensor (hand equilibrium, neglecting the hand's own acceleration as a real F/T
    sensor does)::

        f_ext = -R_S f_s - m g
        τ_ext = -R_S τ_s - (p_S - p_H) × R_S f_s - (p_S + R_S c - p_H) × m g

    (reading ``[τ_s; f_s]`` at the sensor frame S, in S; hand mass m with centre of
    mass c in S; gravity g; everything expressed in world, torques about the hand
    frame origin p_H). The reference then obeys, per axis and exactly for a wrench
    held over the period (:class:`~drake_sot.admittance.MassDamperSpring`)::

        M ẍ + B ẋ + K (x - x_rest) = f_ext + f_ref           (translation, world)
        M_r ω̇ + B_r ω + K_r θ = τ_ext + τ_ref,  θ = log(R R_restᵀ)   (rotation, ω in world)

    where the position moves by the integral of the velocity over the period and the
    orientation by ``R ← exp(∫ω dt) R``; the rest pose is the hand pose at
    activation. With K_r > 0 the rotational spring treats θ̇ as ω (exact about a
    fixed axis, first-order otherwise).

    Weighted (``weighted=True``; Evrard et al. 2009, III-B, eq. 5-7): the translation's virtual
    mass M is, at every tick, the hand point's apparent inertia ``Λ = (J_v A⁻¹ J_vᵀ)⁻¹`` (3, 3)
    from the robot's inertia matrix A and the translation rows J_v of the hand's Jacobian, so
    that the reference moves as the hand's own inertia would under the force (eq. 7); the
    axes are then coupled (:func:`~drake_sot.admittance.coupled_step`, exact for the period
    with Λ held). The translation entries of ``mass`` are unused; the rotation keeps its own.

    Velocity limit: when the linear (or angular) velocity exceeds ``max_velocity``
    the velocity is scaled down to the limit (direction kept) and so is the motion
    of the period; ``saturated`` reports it for that tick.

    Faults: a non-finite ``wrench`` or ``wrench_ref``, a measured force norm above
    ``max_force`` or a measured torque norm above ``max_torque``, never reaches the
    reference: the controller holds the last valid reference pose with zero velocity
    and reports the fault code; it resumes from there (at rest) as soon as the
    readings are valid again.

    Timing: a periodic discrete update at ``period`` (offset 0) reads the inputs and
    updates the state; every output is read from the state (no direct feedthrough).
    An initialization event sets the reference to ``hand_pose`` (when connected), so
    ``position_des`` is the hand pose before the first tick; a freshly created context
    holds the identity pose until the first update.

    Input ports:
        wrench: (6,) raw sensor reading ``[τ [N m]; f [N]]`` that the wrist applies on
            the hand at the sensor frame S, expressed in S (``ForceSensor.wrench``).
        sensor_pose: abstract ``RigidTransform``, pose of the sensor frame S in world.
        hand_pose: abstract ``RigidTransform``, current pose of the controlled hand
            frame (the task's operational point) in world.
        wrench_ref: (6,) ``[τ [N m]; f [N]]`` reference wrench at the hand frame, world
            axes (from the remote operator), optional (zero when unconnected).
        active: (1,) optional; < 0.5 (or NaN): the reference follows ``hand_pose`` at
            zero velocity; when it rises the dynamics start from the current hand
            pose. Unconnected: always active.
    Output ports:
        position_des: abstract ``RigidTransform``, the reference pose of the hand frame
            (for ``FeaturePoint6d.position_des``, the SoT signal of the same name: a pose).
        velocity_des: (6,) ``[v [m/s]; ω [rad/s]]`` reference velocity, world frame,
            translation first (for ``FeaturePoint6d.velocity_des``).
        wrench_external: (6,) ``[τ [N m]; f [N]]`` external wrench on the hand about
            p_H, world axes, gravity-compensated, from the last tick's reading (NaN
            when that reading was not finite); for logging and plots.
        saturated: (1,) 1 when the last tick limited the velocity, else 0.
        fault: (1,) fault code of the last tick: 0 none, 1 non-finite ``wrench`` or
            ``wrench_ref``, 2 measured force norm above ``max_force``, 3 measured torque
            norm above ``max_torque``.
        virtual_mass: (9,) the translation's virtual mass (3, 3) [kg] of the last tick,
            row-major: ``diag(mass[:3])``, or Λ when weighted (from the initialization event on
            when ``hand_pose`` is connected); for logging and tests.

    Input ports of the weighted variant only (``weighted=True``), both from the controller's
    model at the reference configuration (``RobotKinematics``):
        inertia: abstract ``ndarray`` (nv, nv), the robot's joint-space inertia matrix A
            [kg, kg m, kg m²] (``RobotKinematics.inertia``).
        hand_jacobian: abstract ``ndarray`` (6, nv), the hand frame's Jacobian, rows ``[ω; v]``
            (``RobotKinematics.J<hand>``).

    Args:
        mass, damping, stiffness: virtual mass [kg | kg m²], damping [N s/m | N m s/rad]
            and stiffness [N/m | N m/rad]: a scalar (every axis), a (translation,
            rotation) pair, or 6 values (x, y, z, then rotation about x, y, z).
            mass > 0, damping >= 0, stiffness >= 0 (default 0: mass-damper).
        hand_mass: mass below the sensor [kg] (e.g. ``ForceSensor.payload()[0]``), >= 0.
        hand_com: its centre of mass in the sensor frame S (3,) [m].
        period: control period [s].
        max_velocity: limit of the linear [m/s] and angular [rad/s] velocity norms as
            a (linear, angular) pair, or 6 per-axis limits (then each 3-vector is
            scaled by the smallest ratio, keeping its direction); inf for no limit.
        max_force: largest plausible measured force norm [N].
        max_torque: largest plausible measured torque norm [N·m] (at the sensor frame).
        g: gravity vector (3,) [m/s²], world.
        weighted: the A-weighted variant (above).
        name: system name.

    Raises:
        ValueError at construction, naming the bad argument; RuntimeError at a tick
        when ``hand_pose`` or ``sensor_pose`` is not finite (naming the port).
    """

    def __init__(
        self,
        *,
        mass,
        damping,
        stiffness=0.0,
        hand_mass: float,
        hand_com,
        period: float = 0.005,
        max_velocity=(0.5, 1.0),
        max_force: float = 1000.0,
        max_torque: float = 200.0,
        g=(0.0, 0.0, -9.81),
        weighted: bool = False,
        name: str = "admittance",
    ) -> None:
        super().__init__()
        self.set_name(name)
        self._period = positive("period", period, unit="s")
        self.dynamics = MassDamperSpring(
            per_axis("mass", mass, 6, sign="positive"),
            per_axis("damping", damping, 6, sign="nonnegative"),
            per_axis("stiffness", stiffness, 6, sign="nonnegative"),
            self._period,
        )
        self._hand_mass = nonnegative("hand_mass", hand_mass, unit="kg")
        self._hand_com = vector("hand_com", hand_com, 3)
        self._g = vector("g", g, 3)
        limits = np.asarray(max_velocity, dtype=float).reshape(-1)
        if limits.size not in (2, 6):
            raise ValueError(
                f"max_velocity must be a (linear, angular) pair or 6 values, got {limits.size} values"
            )
        self._norm_limits = limits.size == 2
        self._v_max = per_axis("max_velocity", limits, 6, sign="positive", allow_inf=True)
        self._max_force = positive("max_force", max_force, unit="N")
        self._max_torque = positive("max_torque", max_torque, unit="N·m")
        self._rotational_spring = bool(np.any(self.dynamics.stiffness[3:] > 0.0))

        self._wrench = self.DeclareVectorInputPort("wrench", 6)
        self._sensor_pose = self.DeclareAbstractInputPort("sensor_pose", AbstractValue.Make(RigidTransform()))
        self._hand_pose = self.DeclareAbstractInputPort("hand_pose", AbstractValue.Make(RigidTransform()))
        self._wrench_ref = self.DeclareVectorInputPort("wrench_ref", 6)
        self._active = self.DeclareVectorInputPort("active", 1)
        self._weighted = bool(weighted)
        if self._weighted:
            matrix = AbstractValue.Make(np.zeros((0, 0)))
            self._inertia = self.DeclareAbstractInputPort("inertia", matrix)
            self._hand_jacobian = self.DeclareAbstractInputPort("hand_jacobian", matrix)

        x0 = np.zeros(_SIZE)
        x0[_Q] = x0[_Q_REST] = (1.0, 0.0, 0.0, 0.0)
        x0[_MASS] = np.diag(self.dynamics.mass[:3]).reshape(-1)
        self._state = self.DeclareDiscreteState(x0)
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._update)
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)

        ticket = {self.discrete_state_ticket(self._state)}
        self.DeclareAbstractOutputPort(
            "position_des",
            lambda: AbstractValue.Make(RigidTransform()),
            lambda c, value: value.set_value(self._pose(self._x(c))),
            prerequisites_of_calc=ticket,
        )

        def state_output(name: str, fn) -> None:
            self.DeclareVectorOutputPort(
                name,
                len(fn(x0)),
                lambda c, out: out.SetFromVector(fn(self._x(c))),
                prerequisites_of_calc=ticket,
            )

        state_output("velocity_des", lambda x: x[_V])
        state_output("wrench_external", lambda x: x[_W])
        state_output("saturated", lambda x: x[_SATURATED : _SATURATED + 1])
        state_output("fault", lambda x: x[_FAULT : _FAULT + 1])
        state_output("virtual_mass", lambda x: x[_MASS])

    # --- reading the state --------------------------------------------------------------
    @property
    def period(self) -> float:
        """The control period [s]."""
        return self._period

    def _x(self, context: Context) -> np.ndarray:
        return context.get_discrete_state(self._state).get_value()

    @staticmethod
    def _pose(x: np.ndarray) -> RigidTransform:
        return RigidTransform(RotationMatrix(quaternion_to_rotation(x[_Q])), x[_P])

    def reference(self, context: Context) -> tuple[RigidTransform, np.ndarray]:
        """``(position_des, velocity_des)`` held in the state (own or root context)."""
        x = self._x(own_context(self, context))
        return self._pose(x), x[_V].copy()

    # --- the wrench -----------------------------------------------------------------------
    def external_wrench(self, reading: np.ndarray, X_WS: RigidTransform, p_WH: np.ndarray) -> np.ndarray:
        """The external wrench ``[τ; f]`` (6,) on the hand about ``p_WH``, world axes, from a raw
        sensor ``reading`` ``[τ_s; f_s]`` taken at the sensor frame pose ``X_WS`` (see the class
        docstring for the equations)."""
        R = X_WS.rotation().matrix()
        p_S = X_WS.translation()
        f_w = R @ reading[3:]
        tau_w = R @ reading[:3]
        weight = self._hand_mass * self._g
        p_com = p_S + R @ self._hand_com
        f_ext = -f_w - weight
        tau_ext = -tau_w - so3.cross(p_S - p_WH, f_w) - so3.cross(p_com - p_WH, weight)
        return np.concatenate((tau_ext, f_ext))

    # --- events ---------------------------------------------------------------------------
    def _checked_pose(self, port, context: Context) -> RigidTransform:
        X = port.Eval(context)
        if not np.all(np.isfinite(X.GetAsMatrix4())):
            raise RuntimeError(
                f"{self.get_name()!r}: input {port.get_name()!r} is not finite "
                f"at t = {context.get_time():.4f} s"
            )
        return X

    @staticmethod
    def _follow(x: np.ndarray, X_H: RigidTransform) -> None:
        """Reference and rest pose := the hand pose, at rest."""
        x[_P] = x[_P_REST] = X_H.translation()
        x[_Q] = x[_Q_REST] = _quaternion(X_H.rotation().matrix())
        x[_V] = 0.0

    def _initialize(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        if self._hand_pose.HasValue(context):
            x = self._x(context).copy()
            self._follow(x, self._checked_pose(self._hand_pose, context))
            x[_ACTIVE] = 0.0
            if self._weighted:
                x[_MASS] = self._apparent_inertia(context).reshape(-1)
            discrete_state.get_mutable_vector(self._state).SetFromVector(x)
        return EventStatus.Succeeded()

    def _apparent_inertia(self, context: Context) -> np.ndarray:
        """Λ (3, 3) [kg] of the hand point from the ``inertia`` and ``hand_jacobian`` inputs."""
        for port in (self._inertia, self._hand_jacobian):
            if not port.HasValue(context):
                raise RuntimeError(
                    f"{self.get_name()!r}: the weighted variant needs input {port.get_name()!r}"
                )
        A = np.asarray(self._inertia.Eval(context), dtype=float)
        J = np.asarray(self._hand_jacobian.Eval(context), dtype=float)
        if J.ndim != 2 or J.shape[0] != 6:
            raise RuntimeError(f"{self.get_name()!r}: input 'hand_jacobian' has shape {J.shape}, not (6, nv)")
        return apparent_inertia(J[3:], A)

    def _limit(self, v: np.ndarray, limits: np.ndarray) -> float:
        """Scale factor in (0, 1] that brings the 3-vector v within its limits."""
        if self._norm_limits:
            norm = float(np.linalg.norm(v))
            return limits[0] / norm if norm > limits[0] else 1.0
        over = np.abs(v) > limits
        return float(np.min(limits[over] / np.abs(v[over]))) if np.any(over) else 1.0

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        x = self._x(context).copy()
        X_H = self._checked_pose(self._hand_pose, context)
        p_H = X_H.translation()
        reading = np.asarray(self._wrench.Eval(context), dtype=float)
        w_ref = self._wrench_ref.Eval(context) if self._wrench_ref.HasValue(context) else np.zeros(6)
        active = True
        if self._active.HasValue(context):
            active = bool(self._active.Eval(context)[0] >= 0.5)  # NaN: inactive

        if np.all(np.isfinite(reading)):
            w_ext = self.external_wrench(reading, self._checked_pose(self._sensor_pose, context), p_H)
            fault = FAULT_NONE
            if not (np.linalg.norm(reading[3:]) <= self._max_force):
                fault = FAULT_FORCE_LIMIT
            elif not (np.linalg.norm(reading[:3]) <= self._max_torque):
                fault = FAULT_TORQUE_LIMIT
        else:
            w_ext = np.full(6, np.nan)
            fault = FAULT_NOT_FINITE
        if fault == FAULT_NONE and not np.all(np.isfinite(w_ref)):
            fault = FAULT_NOT_FINITE
        x[_W] = w_ext
        x[_FAULT] = fault
        x[_SATURATED] = 0.0

        if not active or x[_ACTIVE] < 0.5:  # inactive, or rising: start from the hand
            self._follow(x, X_H)
        x[_ACTIVE] = 1.0 if active else 0.0
        if not active or fault != FAULT_NONE:  # follow the hand, or hold the last valid reference
            x[_V] = 0.0
            discrete_state.get_mutable_vector(self._state).SetFromVector(x)
            return EventStatus.Succeeded()

        # Drive the mass-damper-spring with [f; τ] (translation first, like its axes).
        total = w_ext + w_ref
        force = np.concatenate((total[3:], total[:3]))
        R = quaternion_to_rotation(x[_Q])
        theta = so3.log(R @ quaternion_to_rotation(x[_Q_REST]).T) if self._rotational_spring else np.zeros(3)
        position = np.concatenate((x[_P], theta))
        rest = np.concatenate((x[_P_REST], np.zeros(3)))
        position_next, v_next = self.dynamics.step(position, x[_V], force, rest)
        if self._weighted:  # the translation's mass: the hand's apparent inertia (eq. 7)
            mass = self._apparent_inertia(context)
            d = self.dynamics
            position_next[:3], v_next[:3] = coupled_step(
                mass, d.damping[:3], d.stiffness[:3], x[_P] - x[_P_REST], x[_V][:3], force[:3], self._period
            )
            position_next[:3] += x[_P_REST]
            x[_MASS] = mass.reshape(-1)
        motion = position_next - position

        saturated = False
        for axes in (slice(0, 3), slice(3, 6)):
            s_v = self._limit(v_next[axes], self._v_max[axes])
            s_m = self._limit(motion[axes], self._v_max[axes] * self._period)
            if s_v < 1.0 or s_m < 1.0:
                saturated = True
                v_next[axes] *= s_v
                motion[axes] *= s_m

        x[_P] = x[_P] + motion[:3]
        x[_Q] = _quaternion(so3.exp(motion[3:]) @ R)
        x[_V] = v_next
        x[_SATURATED] = 1.0 if saturated else 0.0
        discrete_state.get_mutable_vector(self._state).SetFromVector(x)
        return EventStatus.Succeeded()
