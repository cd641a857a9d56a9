"""``RobotKinematics``: the SoT's dynamic-model entity ("dyn") on a Drake MultibodyPlant."""

from __future__ import annotations

import itertools

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import FrameIndex, JacobianWrtVariable, JointIndex, QuaternionFloatingJoint
from pydrake.systems.framework import BasicVector, ValueProducer

from drake_sot.signals import OperationalPoint
from drake_sot.systems.leaf import SotLeafSystem

#: Suffix of the output that carries an operational point's pose and Jacobian in one value.
FRAME_SUFFIX = "_frame"
_ORIGIN = np.zeros(3)


def momentum_rows(plant: MultibodyPlant) -> slice | None:
    """The rows of the mass matrix that are ``m J_com`` (m the total mass), or None.

    With a quaternion floating base whose translational velocity ``v_WB`` (world frame) moves
    every moving body rigidly, the kinetic energy's derivative with respect to ``v_WB`` is the
    total linear momentum ``Σ m_i v_i = m v_com``: the mass matrix's three rows of ``v_WB`` are
    ``m J_com`` (bodies welded to the world add mass but no velocity). Drake's mass matrix
    (composite bodies) costs about half its CoM Jacobian. None when the model has no unique
    floating base or some moving body does not hang below it.
    """
    floating = plant.GetFloatingBaseBodies()
    if len(floating) != 1:
        return None
    body = plant.get_body(next(iter(floating)))
    joints = [plant.get_joint(JointIndex(i)) for i in range(plant.num_joints())]
    base = [joint for joint in joints if joint.child_body().index() == body.index()]
    if len(base) != 1 or not isinstance(base[0], QuaternionFloatingJoint):
        return None
    moving = [joint.index() for joint in joints if joint.num_velocities() > 0]
    below = plant.GetBodiesKinematicallyAffectedBy([base[0].index()])
    if set(plant.GetBodiesKinematicallyAffectedBy(moving)) != set(below):
        return None
    start = base[0].velocity_start() + 3  # v = [ω_WB; v_WB]
    return slice(start, start + 3)


class RobotKinematics(SotLeafSystem):
    """Forward kinematics of the controller's robot model, on demand.

    The paper's ``dyn`` entity: it reads the configuration and provides the CoM, its
    Jacobian and, for each *operational point* created with
    :meth:`add_operational_point` (the paper's ``createOpPoint``), the frame's pose and
    Jacobian. Only the operational points a scenario asks for are computed, and each
    only when q changed (Drake's cache); ``inertia`` and ``Jcom`` share one mass matrix per q.

    Input ports:
        q: configuration (nq,) of ``plant`` (quaternion floating base first).

    Output ports:
        com: centre of mass position in world (3,) [m].
        Jcom: CoM Jacobian, abstract ``ndarray`` (3, nv), w.r.t. v.
        inertia: the joint-space inertia (mass) matrix A, abstract ``ndarray`` (nv, nv)
            [kg, kg m, kg m²] (the SoT's ``dyn.inertia``; the weighted admittance's weight).
        <name>: pose of the operational point's frame in world, abstract ``RigidTransform``.
        J<name>: the frame's Jacobian, abstract ``ndarray`` (6, nv): rows ``[ω; v]``
            (angular velocity, then velocity of the frame origin, world frame), w.r.t. v.
        <name>_frame: both at once, abstract :class:`~drake_sot.signals.OperationalPoint`
            (rotation (3, 3), translation (3,) [m], Jacobian (6, nv) as ``J<name>``): one
            evaluation for a feature that reads both (a pose feature's ``frame`` input).

    The plant is a finalized model owned by the controller (see
    ``drake_sot.models.make_control_model``), distinct from the simulated plant; this
    system keeps one scratch context for it, so evaluate it from one thread.
    """

    def __init__(self, plant: MultibodyPlant) -> None:
        super().__init__()
        if not plant.is_finalized():
            raise ValueError("RobotKinematics needs a finalized MultibodyPlant")
        self._plant = plant
        self._plant_context = plant.CreateDefaultContext()
        self._world = plant.world_frame()
        self._operational_points: dict[str, str] = {}
        self._mass = plant.CalcTotalMass(self._plant_context)
        # Jcom from the mass matrix (see momentum_rows), or None: Drake's CoM Jacobian.
        self._com_rows = momentum_rows(plant) if self._mass > 0.0 else None
        nq, nv = plant.num_positions(), plant.num_velocities()
        self._q_port = self.DeclareVectorInputPort("q", nq)
        q_ticket = {self.input_port_ticket(self._q_port.get_index())}
        # Each new q of a context gets a serial number, in a cache entry (Drake recomputes it when
        # q changes); the scratch context holds the q of serial _loaded. An output then checks one
        # integer instead of copying and comparing q, and reloads q after another context's.
        self._serials = itertools.count(1)
        self._loaded = 0
        self._q_serial = self.DeclareCacheEntry(
            "serial number of q",
            ValueProducer(
                allocate=lambda: AbstractValue.Make(0),
                calc=lambda context, value: value.set_value(next(self._serials)),
            ),
            q_ticket,
        )
        # The mass matrix once per q: ``inertia`` and, on a floating base, ``Jcom`` read it (Drake
        # does not cache it: each CalcMassMatrix is a full composite-body pass).
        self._mass_matrix = self.DeclareCacheEntry(
            "mass matrix",
            ValueProducer(
                allocate=lambda: AbstractValue.Make(np.zeros((nv, nv))), calc=self._calc_mass_matrix
            ),
            q_ticket,
        )
        matrix_ticket = {self._mass_matrix.ticket()}
        self.DeclareVectorOutputPort("com", 3, self._calc_com, prerequisites_of_calc=q_ticket)
        self.DeclareAbstractOutputPort(
            "Jcom",
            lambda: AbstractValue.Make(np.zeros((3, nv))),
            self._calc_jcom,
            prerequisites_of_calc=q_ticket if self._com_rows is None else matrix_ticket,
        )
        self.DeclareAbstractOutputPort(
            "inertia",
            lambda: AbstractValue.Make(np.zeros((nv, nv))),
            lambda context, value: value.set_value(self._mass_matrix.Eval(context)),
            prerequisites_of_calc=matrix_ticket,
        )

    @property
    def plant(self) -> MultibodyPlant:
        """The robot model the kinematics is computed on."""
        return self._plant

    @property
    def operational_points(self) -> dict[str, str]:
        """Operational point name → frame name."""
        return dict(self._operational_points)

    def add_operational_point(self, name: str, frame_name: str) -> None:
        """Create output ports ``name`` (pose), ``J<name>`` (Jacobian) and ``<name>_frame`` (both)
        for a frame.

        The paper's ``dyn.createOpPoint rleg 6``, naming a frame instead of a joint rank.
        Must be called before the diagram is built. Raises ValueError when one of the three
        port names is taken or the frame does not exist (listing the model's frames).
        """
        ports = (name, "J" + name, name + FRAME_SUFFIX)
        if name in self._operational_points or any(self.HasOutputPort(port) for port in ports):
            raise ValueError(
                f"operational point {name!r} already exists on {self.get_name()!r}, or one of "
                f"its outputs {', '.join(map(repr, ports))} is taken"
            )
        if not self._plant.HasFrameNamed(frame_name):
            frames = sorted(
                self._plant.get_frame(FrameIndex(i)).name() for i in range(self._plant.num_frames())
            )
            raise ValueError(f"no frame {frame_name!r} in the robot model; frames: {', '.join(frames)}")
        frame = self._plant.GetFrameByName(frame_name)
        self._operational_points[name] = frame_name
        nv = self._plant.num_velocities()
        q_ticket = {self.input_port_ticket(self._q_port.get_index())}

        def calc_pose(context, value) -> None:
            self._update(context)
            value.set_value(frame.CalcPoseInWorld(self._plant_context))

        def calc_jacobian(context, value) -> None:
            self._update(context)
            value.set_value(
                self._plant.CalcJacobianSpatialVelocity(
                    self._plant_context,
                    JacobianWrtVariable.kV,
                    frame,
                    np.zeros(3),
                    self._world,
                    self._world,
                )
            )

        self.DeclareAbstractOutputPort(
            name,
            lambda: AbstractValue.Make(RigidTransform()),
            calc_pose,
            prerequisites_of_calc=q_ticket,
        )
        self.DeclareAbstractOutputPort(
            "J" + name,
            lambda: AbstractValue.Make(np.zeros((6, nv))),
            calc_jacobian,
            prerequisites_of_calc=q_ticket,
        )

        def calc_frame(context, value) -> None:
            self._update(context)
            X = frame.CalcPoseInWorld(self._plant_context)
            J = self._plant.CalcJacobianSpatialVelocity(
                self._plant_context, JacobianWrtVariable.kV, frame, _ORIGIN, self._world, self._world
            )
            value.set_value(OperationalPoint(X.rotation().matrix(), X.translation(), J))

        self.DeclareAbstractOutputPort(
            name + FRAME_SUFFIX,
            lambda: AbstractValue.Make(OperationalPoint(np.eye(3), np.zeros(3), np.zeros((6, nv)))),
            calc_frame,
            prerequisites_of_calc=q_ticket,
        )

    def _update(self, context) -> None:
        """Load the context's q into the scratch plant context, unless it is there already."""
        serial = self._q_serial.Eval(context)
        if serial != self._loaded:
            self._plant.SetPositions(self._plant_context, self._q_port.Eval(context))
            self._loaded = serial

    def _calc_com(self, context, output: BasicVector) -> None:
        self._update(context)
        output.SetFromVector(self._plant.CalcCenterOfMassPositionInWorld(self._plant_context))

    def _calc_mass_matrix(self, context, value) -> None:
        self._update(context)
        value.set_value(self._plant.CalcMassMatrix(self._plant_context))

    def _calc_jcom(self, context, value) -> None:
        if self._com_rows is not None:
            value.set_value(self._mass_matrix.Eval(context)[self._com_rows] / self._mass)
            return
        self._update(context)
        value.set_value(
            self._plant.CalcJacobianCenterOfMassTranslationalVelocity(
                self._plant_context, JacobianWrtVariable.kV, self._world, self._world
            )
        )
