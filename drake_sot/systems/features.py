"""Features (paper 000, III-B.4): each measures ``s`` on the robot and outputs ``e = s - s*`` and ``J``.

Every feature has the same two outputs and the same way of receiving its desired
value ``s*``:

Output ports (all features):
    feature: abstract :class:`~drake_sot.signals.FeatureSignal` (error, Jacobian
        w.r.t. v, reference feed-forward), selected components only; plug it into a
        :class:`~drake_sot.systems.task.Task`.
    error: ``e`` as a vector (m,), for logging and plotting.

Desired value: from the feature's desired-value input port when that port is
connected (a reference generator, the paper's ``plug PGselec.scomref ...``), otherwise
from a parameter set with :meth:`set_desired` (the paper's ``set ... sdes``). Setting
the parameter while the port is connected is refused, not ignored. The constructor's
``desired`` argument is the parameter's default (what a new context holds).

The desired value reaches the feature's computation through a cache entry of the feature's
context, recomputed (converted, e.g. a pose to its rotation matrix and translation) only when
the port's value or the parameter changes, not looked up at every tick.

Bounds of a desired value (checked where it enters: the constructor and :meth:`set_desired`,
ValueError; a value from the desired-value port when the cache entry is recomputed,
RuntimeError naming the feature and the time): finite everywhere; a position (a pose's
translation, a CoM) within :data:`~drake_sot.validation.WORKSPACE_RADIUS` (10 m) of the origin of
its frame; a posture within the joint limits of the model widened by half a turn. A finite but
absurd target (1e300 m, 1e3 m) would otherwise ask the robot for a q̇ of that size.

Pose features read a frame either as one value, input ``frame`` (an
:class:`~drake_sot.signals.OperationalPoint`, ``RobotKinematics``' ``<op>_frame`` output: one
evaluation per tick), or as the paper's two signals ``position`` and ``Jq`` (what a script
plugs); connecting both ways at once is refused at the first evaluation.

Selection: a mask over the feature's components (``"001000"`` keeps z alone for a 6D
feature, as the tele-cooperation paper does for hand altitudes). The output size is
the number of selected components.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Joint, JointIndex, PrismaticJoint
from pydrake.systems.framework import AbstractParameterIndex, Context, InputPort, ValueProducer

from drake_sot import features as fmath
from drake_sot.signals import FeatureSignal, OperationalPoint
from drake_sot.systems._context import own_context, settable_context
from drake_sot.systems.leaf import SotLeafSystem
from drake_sot.validation import WORKSPACE_RADIUS, nonnegative, position, within


class Feature(SotLeafSystem):
    """The base of every feature, the type a :class:`~drake_sot.systems.task.Task` takes:
    selection, desired value and the two outputs shared by every feature."""

    def __init__(self, size: int, selection: fmath.SelectionLike, name: str | None) -> None:
        super().__init__()
        if name:
            self.set_name(name)
        self._indices = fmath.selection_indices(selection, size, name=f"selection of {self.get_name()!r}")
        self._full = self._indices.size == size
        self._size = size
        #: The unit of each (unselected) component, "" when it has none (set by each kind of feature).
        self._units: tuple[str, ...] = ("",) * size
        self._desired_port: InputPort | None = None
        self._desired_param: int | None = None

    @property
    def dimension(self) -> int:
        """Number of selected components m (the size of ``error``)."""
        return int(self._indices.size)

    @property
    def units(self) -> tuple[str, ...]:
        """The unit of each component of ``error``: ``"m"``, ``"rad"``, or ``""`` where the
        feature does not know one (a generic feature's signal, a visual point's normalised image
        coordinates)."""
        return tuple(self._units[i] for i in self._indices)

    def _declare_desired(self, port_name: str, default_value, vector_size: int | None) -> None:
        """The ``s*`` input (vector of ``vector_size``, or abstract), its parameter fallback, and the
        cache entry of its prepared form (:meth:`_prepare_desired`), recomputed only when one of the
        two changes."""
        if vector_size is None:
            self._desired_port = self.DeclareAbstractInputPort(port_name, AbstractValue.Make(default_value))
        else:
            self._desired_port = self.DeclareVectorInputPort(port_name, vector_size)
        self._desired_param = self.DeclareAbstractParameter(AbstractValue.Make(default_value))
        prepared = self._prepare_desired(default_value)
        self._desired_cache = self.DeclareCacheEntry(
            f"prepared {port_name}",
            ValueProducer(
                allocate=lambda: AbstractValue.Make(prepared),
                calc=self._calc_prepared_desired,
            ),
            {
                self.input_port_ticket(self._desired_port.get_index()),
                self.abstract_parameter_ticket(AbstractParameterIndex(self._desired_param)),
            },
        )

    def _calc_prepared_desired(self, context: Context, value: AbstractValue) -> None:
        """The cache entry of ``s*``: a value from the port is checked here (a parameter was checked
        when it was set), then converted."""
        desired = self._desired(context)
        if self._desired_port.HasValue(context):
            try:
                desired = self._check_desired(desired)
            except (TypeError, ValueError) as error:
                port = self._desired_port.get_name()
                raise RuntimeError(
                    f"{error} (on input port {port!r} at t = {context.get_time():.4f} s)"
                ) from None
        value.set_value(self._prepare_desired(desired))

    def _prepare_desired(self, value):
        """The form of ``s*`` the per-tick computation uses (overridden per feature)."""
        return value

    def _declare_frame(self, suffix: str = "") -> tuple[InputPort, InputPort, InputPort]:
        """Inputs ``position<suffix>`` (abstract ``RigidTransform``), ``Jq<suffix>`` (abstract
        ``ndarray`` (6, nv)) and ``frame<suffix>`` (both at once, abstract ``OperationalPoint``)."""
        return (
            self.DeclareAbstractInputPort("position" + suffix, AbstractValue.Make(RigidTransform())),
            self.DeclareAbstractInputPort("Jq" + suffix, AbstractValue.Make(np.zeros((6, 0)))),
            self.DeclareAbstractInputPort(
                "frame" + suffix,
                AbstractValue.Make(OperationalPoint(np.eye(3), np.zeros(3), np.zeros((6, 0)))),
            ),
        )

    def _read_frame(
        self, context: Context, ports: tuple[InputPort, InputPort, InputPort]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(R, p, J)`` of a frame from its ``frame`` input, else from ``position`` and ``Jq``."""
        pose, jacobian, both = ports
        if both.HasValue(context):
            if pose.HasValue(context) or jacobian.HasValue(context):
                raise RuntimeError(
                    f"{self.get_name()!r}: inputs {both.get_name()!r} and {pose.get_name()!r}/"
                    f"{jacobian.get_name()!r} both have a value: connect one source of the frame"
                )
            value = both.Eval(context)
            return value.rotation, value.translation, value.jacobian
        X = pose.Eval(context)
        return X.rotation().matrix(), X.translation(), jacobian.Eval(context)

    def _declare_outputs(self) -> None:
        m = self.dimension
        feature = self.DeclareAbstractOutputPort(
            "feature",
            lambda: AbstractValue.Make(FeatureSignal(np.zeros(m), np.zeros((m, 0)), np.zeros(m))),
            self._calc_feature,
            prerequisites_of_calc={self.all_input_ports_ticket(), self.all_parameters_ticket()},
        )
        self.DeclareVectorOutputPort(
            "error",
            m,
            lambda context, out: out.SetFromVector(feature.Eval(context).error),
            prerequisites_of_calc={self.all_input_ports_ticket(), self.all_parameters_ticket()},
        )

    def desired(self, context: Context):
        """``s*`` now: the input port's value when connected, else the parameter (own or root context)."""
        return self._desired(own_context(self, context))

    def _desired(self, context: Context):
        """``desired`` for this system's own context (the per-tick path)."""
        if self._desired_port.HasValue(context):
            return self._desired_port.Eval(context)
        return context.get_abstract_parameter(self._desired_param).get_value()

    def set_desired(self, context: Context, value) -> None:
        """Set the parameter ``s*`` (own or root context); refused when the input is connected."""
        context = settable_context(
            self, context, self._desired_port, command="set_desired", what="the desired value"
        )
        context.get_mutable_abstract_parameter(self._desired_param).set_value(self._check_desired(value))

    def _check_desired(self, value):
        """Validate and convert a desired value (overridden per feature)."""
        raise NotImplementedError

    def _compute(self, context: Context) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Full (unselected) ``(e, J, feedforward)``."""
        raise NotImplementedError

    def _calc_feature(self, context: Context, value: AbstractValue) -> None:
        e, J, ff = self._compute(context)
        if not self._full:
            e, J, ff = e[self._indices], J[self._indices], ff[self._indices]
        value.set_value(FeatureSignal(e, J, ff))


class FeatureGeneric(Feature):
    """A feature whose value and Jacobian come from input signals (SoT ``FeatureGeneric``).

    ``e = s - s*`` with ``s`` = ``errorIN``; ``J`` = ``jacobianIN``.

    Input ports:
        errorIN: the measured value s (size,).
        jacobianIN: abstract ``ndarray`` (size, nv), ∂s/∂q w.r.t. v.
        sdes: desired value s* (size,), optional (else the parameter).
        sdes_dot: rate of the desired value ds*/dt (size,), optional (else zero): the
            feed-forward of a moving reference.
    Output ports: ``feature``, ``error`` (see the module docstring).
    """

    _value_port = "errorIN"
    _jacobian_port = "jacobianIN"

    def __init__(
        self,
        size: int,
        *,
        selection: fmath.SelectionLike = None,
        name: str | None = None,
        desired: np.ndarray | None = None,
    ) -> None:
        if size < 1:
            raise ValueError(f"feature size {size} must be >= 1")
        super().__init__(size, selection, name)
        self._s = self.DeclareVectorInputPort(self._value_port, size)
        self._J = self.DeclareAbstractInputPort(self._jacobian_port, AbstractValue.Make(np.zeros((size, 0))))
        self._declare_desired(
            "sdes", self._check_desired(np.zeros(size) if desired is None else desired), size
        )
        self._sdes_dot = self.DeclareVectorInputPort("sdes_dot", size)
        self._declare_outputs()

    def _check_desired(self, value) -> np.ndarray:
        value = np.asarray(value, dtype=float).reshape(-1)
        if value.shape != (self._size,) or not np.all(np.isfinite(value)):
            raise ValueError(
                f"{self.get_name()!r}: desired value {value} must be {self._size} finite numbers"
            )
        return value

    def _prepare_desired(self, value) -> np.ndarray:
        return np.array(value, dtype=float)

    def _compute(self, context):
        J = self._J.Eval(context)
        if J.shape[0] != self._size:
            raise ValueError(
                f"{self.get_name()!r}: {self._jacobian_port} has shape {J.shape}, expected ({self._size}, nv)"
            )
        e = self._s.Eval(context) - self._desired_cache.Eval(context)
        ff = self._sdes_dot.Eval(context) if self._sdes_dot.HasValue(context) else np.zeros(self._size)
        return e, J, ff


class FeatureCoM(FeatureGeneric):
    """Centre-of-mass feature: ``e = c - c*`` (3,), ``J = Jcom`` (SoT ``FeatureCoM``).

    Input ports:
        com: CoM position (3,) [m] (``RobotKinematics.com``).
        Jcom: abstract ``ndarray`` (3, nv) (``RobotKinematics.Jcom``).
        sdes: desired CoM (3,) [m], optional (else the parameter); within 10 m of the world origin.
        sdes_dot: desired CoM velocity (3,) [m/s], optional.
    Output ports: ``feature``, ``error``. Use ``selection="110"`` for the ground
    projection (CoM xy) of balance control.
    """

    _value_port = "com"
    _jacobian_port = "Jcom"

    def __init__(
        self,
        *,
        selection: fmath.SelectionLike = None,
        name: str | None = None,
        desired: np.ndarray | None = None,
    ) -> None:
        super().__init__(3, selection=selection, name=name, desired=desired)
        self._units = ("m",) * 3

    def _check_desired(self, value) -> np.ndarray:
        return check_desired_com(self.get_name(), value)


def check_desired_com(name: str, value) -> np.ndarray:
    """A desired CoM (3,) [m] of the feature ``name``: finite, within ``WORKSPACE_RADIUS`` of the
    world origin (ValueError naming the feature and the value otherwise)."""
    a = np.asarray(value, dtype=float)
    if a.shape == (3,) and math.hypot(*a) <= WORKSPACE_RADIUS:  # NaN and inf fail the comparison
        return a
    return position(f"{name!r}: desired CoM", value)


def check_desired_pose(name: str, value, *, origin: str = "the world origin") -> RigidTransform:
    """A desired pose of the feature ``name``: a ``RigidTransform`` (else TypeError), finite, its
    translation within ``WORKSPACE_RADIUS`` of ``origin`` (ValueError naming the feature otherwise)."""
    if not isinstance(value, RigidTransform):
        raise TypeError(f"{name!r}: desired pose must be a RigidTransform, got {type(value).__name__}")
    # Checked at every tick where a port feeds it, so on Python floats (numpy's per-call cost is
    # most of a 12-entry check): the rows' sum is finite iff no entry is NaN or inf (entries large
    # enough to overflow it fail the translation's bound anyway); validation.position only words a
    # refusal.
    rows = value.GetAsMatrix4().tolist()
    if not math.isfinite(sum(rows[0]) + sum(rows[1]) + sum(rows[2])):
        raise ValueError(f"{name!r}: desired pose is not finite")
    if not (math.hypot(rows[0][3], rows[1][3], rows[2][3]) <= WORKSPACE_RADIUS):
        position(f"{name!r}: desired position", value.translation(), origin=origin)
    return value


class _PoseFeature(Feature):
    """A 6D feature on an operational point: inputs ``frame`` (or ``position`` and ``Jq``),
    ``position_des``."""

    #: The origin of the frame its desired pose is in (the bound on its translation is from there).
    ORIGIN = "the world origin"

    def __init__(
        self, selection: fmath.SelectionLike, name: str | None, desired: RigidTransform | None
    ) -> None:
        super().__init__(6, selection, name)
        self._units = ("m",) * 3 + ("rad",) * 3  # [p - p*; rotation vector]
        self._frame = self._declare_frame()
        self._declare_desired(
            "position_des", self._check_desired(RigidTransform() if desired is None else desired), None
        )

    def _check_desired(self, value) -> RigidTransform:
        return check_desired_pose(self.get_name(), value, origin=self.ORIGIN)

    def _prepare_desired(self, value: RigidTransform) -> tuple[np.ndarray, np.ndarray]:
        return value.rotation().matrix(), value.translation()


class FeaturePoint6d(_PoseFeature):
    """Pose of an operational point against a desired pose (SoT ``FeaturePoint6d``).

    ``e = [p - p*; log(R R*ᵀ)]`` (6,): position error [m] then the rotation vector
    [rad] of the orientation error, world frame, with its exact Jacobian.

    Input ports:
        frame: abstract :class:`~drake_sot.signals.OperationalPoint`, the frame's pose and
            Jacobian in one value (``RobotKinematics.<op>_frame``); or, instead of it:
        position: abstract ``RigidTransform``, the frame's pose in world.
        Jq: abstract ``ndarray`` (6, nv), the frame Jacobian (rows ``[ω; v]``).
        position_des: abstract ``RigidTransform``, desired pose, optional (else the parameter);
            its translation within 10 m of the world origin.
        velocity_des: desired spatial velocity ``[v*; ω*]`` (6,) [m/s, rad/s], world
            frame, optional (else zero): the feed-forward of a moving reference.
    Output ports: ``feature``, ``error``.
    """

    def __init__(
        self,
        *,
        selection: fmath.SelectionLike = None,
        name: str | None = None,
        desired: RigidTransform | None = None,
    ) -> None:
        super().__init__(selection, name, desired)
        self._velocity_des = self.DeclareVectorInputPort("velocity_des", 6)
        self._declare_outputs()

    def _compute(self, context):
        R, p, J = self._read_frame(context, self._frame)
        R_des, p_des = self._desired_cache.Eval(context)
        velocity_des = self._velocity_des.Eval(context) if self._velocity_des.HasValue(context) else None
        return fmath.point6d(R, p, J, R_des, p_des, velocity_des)


class FeaturePoint6dRelative(_PoseFeature):
    """Pose of one operational point in the frame of another (SoT ``FeaturePoint6dRelative``).

    E.g. one foot relative to the other. ``e = [p_ba - p*; log(R_ba R*ᵀ)]`` (6,),
    expressed in the reference frame b, with its exact Jacobian.

    Input ports:
        position: abstract ``RigidTransform``, pose of the moving frame a in world.
        Jq: abstract ``ndarray`` (6, nv), its Jacobian (rows ``[ω; v]``).
        frame: abstract :class:`~drake_sot.signals.OperationalPoint`, both in one value,
            instead of ``position`` and ``Jq``.
        positionRef: abstract ``RigidTransform``, pose of the reference frame b in world.
        JqRef: abstract ``ndarray`` (6, nv), its Jacobian.
        frameRef: both in one value, instead of ``positionRef`` and ``JqRef``.
        position_des: abstract ``RigidTransform``, desired pose of a in b, optional; its
            translation within 10 m of b's origin.
    Output ports: ``feature``, ``error``.
    """

    ORIGIN = "the origin of the reference frame"

    def __init__(
        self,
        *,
        selection: fmath.SelectionLike = None,
        name: str | None = None,
        desired: RigidTransform | None = None,
    ) -> None:
        super().__init__(selection, name, desired)
        self._frame_ref = self._declare_frame("Ref")
        self._declare_outputs()

    def _compute(self, context):
        e, J = fmath.point6d_relative(
            *self._read_frame(context, self._frame),
            *self._read_frame(context, self._frame_ref),
            *self._desired_cache.Eval(context),
        )
        return e, J, np.zeros(6)


class FeatureVisualPoint(Feature):
    """A point of the world seen by a pinhole camera (SoT ``FeatureVisualPoint``, the fourth
    feature family of Mansard et al. 2009, with the interaction matrix of Chaumette &
    Hutchinson 2006).

    ``s = (x, y) = (X/Z, Y/Z)``, the point ``(X, Y, Z)`` in the camera frame (z along the
    optical axis, x to the image's right, y down), in normalised image coordinates (focal
    length 1); ``e = s - s*`` (2,) with its exact Jacobian through the camera frame's
    (:func:`drake_sot.features.visual_point`). The point's position is an input, so it can
    move; its velocity, when given, is fed forward so that the image of a moving point is
    held without lag.

    Input ports:
        position: abstract ``RigidTransform``, the camera frame's pose in world (e.g. the
            operational point of the robot's ``head_camera`` frame).
        Jq: abstract ``ndarray`` (6, nv), the camera frame's Jacobian (rows ``[ω; v]``).
        frame: abstract :class:`~drake_sot.signals.OperationalPoint`, both in one value,
            instead of ``position`` and ``Jq``.
        point: the point's position in world (3,) [m].
        point_velocity: its velocity in world (3,) [m/s], optional (else a still point).
        sdes: desired image point s* (2,) [normalised image coordinates], optional (else
            the parameter; default the image centre ``(0, 0)``).
    Output ports: ``feature``, ``error`` (2,) [normalised image coordinates].

    A point at or behind the camera plane (depth Z <= ``features.MIN_DEPTH``) has no image:
    evaluating the feature then raises ValueError naming the feature and Z.
    """

    def __init__(
        self,
        *,
        selection: fmath.SelectionLike = None,
        name: str | None = None,
        desired: np.ndarray | None = None,
    ) -> None:
        super().__init__(2, selection, name)
        self._frame = self._declare_frame()
        self._point = self.DeclareVectorInputPort("point", 3)
        self._point_velocity = self.DeclareVectorInputPort("point_velocity", 3)
        self._declare_desired("sdes", self._check_desired(np.zeros(2) if desired is None else desired), 2)
        self._declare_outputs()

    def _check_desired(self, value) -> np.ndarray:
        value = np.asarray(value, dtype=float).reshape(-1)
        if value.shape != (2,) or not np.all(np.isfinite(value)):
            raise ValueError(f"{self.get_name()!r}: desired image point {value} must be 2 finite numbers")
        return value

    def _prepare_desired(self, value) -> np.ndarray:
        return np.array(value, dtype=float)

    def _compute(self, context):
        R, p, J = self._read_frame(context, self._frame)
        velocity = self._point_velocity.Eval(context) if self._point_velocity.HasValue(context) else None
        try:
            return fmath.visual_point(
                R, p, J, self._point.Eval(context), self._desired_cache.Eval(context), velocity
            )
        except ValueError as error:
            raise ValueError(f"{self.get_name()!r} at t = {context.get_time():.4f} s: {error}") from None


class FeaturePosture(Feature):
    """Joint positions against a reference posture, on a selection of joints.

    ``e = q[joints] - q*[joints]``; ``J`` selects the joints' velocity columns.

    Input ports:
        q: configuration (nq,) of ``plant``.
        sdes: desired configuration q* (nq,), optional (else the parameter; only the
            selected joints are read, each within its joint limits widened by π
            (:func:`posture_bounds`) [rad or m]).
    Output ports: ``feature``, ``error`` (one component per joint).

    Args:
        plant: the finalized robot model (the same one ``RobotKinematics`` uses).
        joints: names of one-DoF joints to control; None for every one-DoF joint.
    """

    def __init__(
        self,
        plant: MultibodyPlant,
        joints: Sequence[str] | None = None,
        *,
        selection: fmath.SelectionLike = None,
        name: str | None = None,
        desired: np.ndarray | None = None,
    ) -> None:
        names = list(joints) if joints is not None else _one_dof_joint_names(plant)
        unknown = [j for j in names if not plant.HasJointNamed(j)]
        if unknown:
            raise ValueError(
                f"FeaturePosture: unknown joints {unknown}; the model has {_one_dof_joint_names(plant)}"
            )
        joint_objs = [plant.GetJointByName(j) for j in names]
        bad = [j.name() for j in joint_objs if j.num_positions() != 1 or j.num_velocities() != 1]
        if bad:
            raise ValueError(f"FeaturePosture: joints {bad} are not one-DoF joints")
        super().__init__(len(names), selection, name)
        self._units = joint_units(joint_objs)
        self.joint_names = tuple(names)
        self._q_index = np.array([j.position_start() for j in joint_objs])
        self._J_full = np.zeros((len(names), plant.num_velocities()))
        self._J_full[np.arange(len(names)), [j.velocity_start() for j in joint_objs]] = 1.0
        self._nq = plant.num_positions()
        self._limits = posture_bounds(
            plant.GetPositionLowerLimits()[self._q_index], plant.GetPositionUpperLimits()[self._q_index]
        )
        self._q = self.DeclareVectorInputPort("q", self._nq)
        default = plant.GetPositions(plant.CreateDefaultContext()) if desired is None else desired
        self._declare_desired("sdes", self._check_desired(default), self._nq)
        self._declare_outputs()

    def _check_desired(self, value) -> np.ndarray:
        value = np.asarray(value, dtype=float).reshape(-1)
        if value.shape != (self._nq,) or not np.all(np.isfinite(value[self._q_index])):
            raise ValueError(f"{self.get_name()!r}: desired configuration must be {self._nq} finite numbers")
        within(
            f"{self.get_name()!r}: desired configuration",
            value[self._q_index],
            *self._limits,
            labels=[f"joint {j!r}" for j in self.joint_names],
        )
        return value

    def _prepare_desired(self, value) -> np.ndarray:
        return np.asarray(value, dtype=float)[self._q_index]  # the selected joints' (a copy)

    def _compute(self, context):
        e = self._q.Eval(context)[self._q_index] - self._desired_cache.Eval(context)
        return e, self._J_full, np.zeros(self._size)


#: How far beyond a joint's limits a posture target may be [rad, or m on a prismatic joint]: a posture
#: task may pull toward a target outside the range (a joint-limit task above it holds the joint
#: inside), but not by more than half a turn.
POSTURE_MARGIN = math.pi


def posture_bounds(lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The range of a posture target per joint: its limits widened by :data:`POSTURE_MARGIN`, and
    ``[-3π, 3π]`` on a joint without limits (a target is never more than 1.5 turns away)."""
    lo = np.where(np.isfinite(lower), lower, -2.0 * math.pi) - POSTURE_MARGIN
    hi = np.where(np.isfinite(upper), upper, 2.0 * math.pi) + POSTURE_MARGIN
    return lo, hi


def joint_units(joints: Sequence[Joint]) -> tuple[str, ...]:
    """The unit of each one-DoF joint's position: ``"m"`` on a prismatic joint, else ``"rad"``."""
    return tuple("m" if isinstance(joint, PrismaticJoint) else "rad" for joint in joints)


def _one_dof_joint_names(plant: MultibodyPlant) -> list[str]:
    joints = [plant.get_joint(JointIndex(i)) for i in range(plant.num_joints())]
    return [j.name() for j in joints if j.num_positions() == 1 and j.num_velocities() == 1]


class FeatureJointLimits(Feature):
    """Keeps joints inside their position limits: one row per joint, active near a limit.

    For a joint inside ``[lower + margin, upper - margin]`` the row is zero (error 0,
    Jacobian 0) and, being rank-deficient, takes no freedom from lower tasks. Past
    the margin the row is ``e = q - (lower + margin)`` (or ``q - (upper - margin)``)
    with the joint's unit Jacobian, so a task at the top of the stack drives the
    joint back to the margin and blocks motion further out; the lower tasks then do
    without that joint. This is the stack's answer to joint limits: the reference is
    never clipped afterwards.

    Input ports:
        q: configuration (nq,) of ``plant``.
    Output ports: ``feature``, ``error`` (one component per joint, 0 when inactive).

    Args:
        plant: the finalized robot model (its joints' position limits are used).
        joints: one-DoF joints to guard; None for all.
        margin: distance from each limit where the row activates [rad or m].
    """

    def __init__(
        self,
        plant: MultibodyPlant,
        joints: Sequence[str] | None = None,
        *,
        margin: float = 0.02,
        name: str | None = None,
    ) -> None:
        names = list(joints) if joints is not None else _one_dof_joint_names(plant)
        joint_objs = [plant.GetJointByName(j) for j in names]
        lower = np.array([j.position_lower_limits()[0] for j in joint_objs])
        upper = np.array([j.position_upper_limits()[0] for j in joint_objs])
        margin = nonnegative("margin", margin, unit="rad or m")
        if not np.all(upper - lower > 2 * margin):
            raise ValueError(f"margin = {margin!r}: must leave room inside every joint's limits")
        super().__init__(len(names), None, name)
        self._units = joint_units(joint_objs)
        self.joint_names = tuple(names)
        self._q_index = np.array([j.position_start() for j in joint_objs])
        self._v_index = np.array([j.velocity_start() for j in joint_objs])
        self._low = lower + margin
        self._high = upper - margin
        self._nv = plant.num_velocities()
        self._q = self.DeclareVectorInputPort("q", plant.num_positions())
        self._declare_outputs()

    def set_desired(self, context: Context, value) -> None:
        raise ValueError(f"{self.get_name()!r}: joint limits have no desired value to set")

    def desired(self, context: Context):
        return None

    def _compute(self, context):
        q = self._q.Eval(context)[self._q_index]
        e = np.where(q < self._low, q - self._low, np.where(q > self._high, q - self._high, 0.0))
        J = np.zeros((self._size, self._nv))
        active = np.flatnonzero(e)
        J[active, self._v_index[active]] = 1.0
        return e, J, np.zeros(self._size)
