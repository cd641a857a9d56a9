"""Balance around the humanoid: the measured ZMP and the DCM stabilizer, wired by name.

:func:`add_stabilizer` puts a :class:`~drake_sot.systems.stabilizer.BalanceStabilizer`
between the CoM references (a pattern generator's, or those of a robot standing still) and
a CoM task: the task's ``sdes`` and ``sdes_dot`` come from the stabilizer, which reads the
simulated robot's state and the ZMP of its ankle force sensors. :func:`add_hip_strategy`
adds, beside it, a trunk orientation task whose reference leans when the stabilizer's DCM
leaves the support polygon (:class:`~drake_sot.systems.hip_strategy.HipStrategy`).
:func:`connect_hand_wrenches` gives the stabilizer the hands' measured external wrenches (a
robot carrying an object with a partner: the LIPM with external forces at the hands).
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import OutputPort
from pydrake.systems.primitives import ConstantVectorSource, Multiplexer

from drake_sot.diagrams.tasks import HumanoidTaskBuilder
from drake_sot.errors import UnknownNameError
from drake_sot.models.humanoid import SOLE
from drake_sot.recovery import LeanProfile
from drake_sot.stabilization import StabilizerGains
from drake_sot.systems.hip_strategy import HipStrategy
from drake_sot.systems.stabilizer import BalanceStabilizer
from drake_sot.systems.zmp import ZmpEstimator

#: The reference ports a stabilizer takes (``PatternGenerator`` names them so).
REFERENCES = ("com", "com_vel", "zmp")
ZMP_ESTIMATOR = "zmp_estimator"


def add_zmp_estimator(b: HumanoidTaskBuilder) -> ZmpEstimator:
    """The diagram's ``ZmpEstimator`` on the two ankle force sensors (added once, then reused)."""
    if b.builder.HasSubsystemNamed(ZMP_ESTIMATOR):
        return b.builder.GetMutableSubsystemByName(ZMP_ESTIMATOR)
    zmp = b.builder.AddSystem(
        ZmpEstimator(b.plant, [b.info.force_sensors["left_ankle"], b.info.force_sensors["right_ankle"]])
    )
    zmp.set_name(ZMP_ESTIMATOR)
    b.builder.Connect(b.plant.get_reaction_forces_output_port(), zmp.GetInputPort("reaction_forces"))
    b.builder.Connect(b.plant.get_body_poses_output_port(), zmp.GetInputPort("body_poses"))
    return zmp


def add_stabilizer(
    b: HumanoidTaskBuilder,
    com_task: str,
    references: dict[str, OutputPort] | None = None,
    *,
    gains: StabilizerGains = StabilizerGains(),
    connect: bool = True,
) -> BalanceStabilizer:
    """A ``BalanceStabilizer`` feeding the CoM task ``com_task`` (added before, without its own
    ``sdes`` source), logged as ``stabilizer_offset``, ``zmp_desired``, ``dcm``,
    ``stabilizer_saturated`` and ``dcm_excess``.

    Args:
        b: the builder, with the CoM task ``com_task``.
        com_task: the CoM task's name.
        references: output ports named as :data:`REFERENCES` (e.g. a ``PatternGenerator``'s:
            ``{name: pg.GetOutputPort(name)}``); None: standing still, the references are
            the initial CoM at rest, its ground projection as the ZMP.
        gains: the stabilizer's gains.
        connect: connect its corrected CoM (``com``, ``com_vel``) to the task's ``sdes`` and
            ``sdes_dot``; False: the caller does (e.g. through a ``StanceAnchor``, which maps it
            from the robot's world, where the stabilizer measures, into the reference's).

    Raises:
        UnknownNameError: ``com_task`` is not a task of ``b`` (lists them).
        ValueError: ``references`` lacks some of :data:`REFERENCES` (naming them).
    """
    if com_task not in b.features:
        raise UnknownNameError("task", com_task, b.features, where="com_task")
    if references is None:
        references = _standing_references(b)
    missing = [name for name in REFERENCES if name not in references]
    if missing:
        raise ValueError(f"references: missing {', '.join(missing)} (needs {', '.join(REFERENCES)})")
    builder = b.builder
    stabilizer = builder.AddSystem(
        BalanceStabilizer(
            b.control_plant,
            (b.control_info.frames["left_foot"], b.control_info.frames["right_foot"]),
            SOLE,
            hands=(b.control_info.frames["left_hand"], b.control_info.frames["right_hand"]),
            gains=gains,
            period=b.control_period,
        )
    )
    for name in REFERENCES:
        port = {"com": "com_ref", "com_vel": "com_vel_ref", "zmp": "zmp_ref"}.get(name, name)
        builder.Connect(references[name], stabilizer.GetInputPort(port))
    zmp = add_zmp_estimator(b)
    builder.Connect(zmp.GetOutputPort("zmp"), stabilizer.GetInputPort("zmp"))
    builder.Connect(zmp.GetOutputPort("foot_forces"), stabilizer.GetInputPort("foot_forces"))
    builder.Connect(b.plant.get_state_output_port(b.info.model_instance), stabilizer.GetInputPort("state"))
    if connect:
        feature = b.features[com_task]
        builder.Connect(stabilizer.GetOutputPort("com"), feature.GetInputPort("sdes"))
        builder.Connect(stabilizer.GetOutputPort("com_vel"), feature.GetInputPort("sdes_dot"))
    for log, port in (
        ("stabilizer_offset", "offset"),
        ("zmp_desired", "zmp_desired"),
        ("dcm", "dcm"),
        ("stabilizer_saturated", "saturated"),
        ("dcm_excess", "dcm_excess"),
    ):
        b.log(log, stabilizer.GetOutputPort(port))
    return stabilizer


def connect_hand_wrenches(
    b: HumanoidTaskBuilder, stabilizer: BalanceStabilizer, wrenches: dict[str, OutputPort]
) -> None:
    """Feed ``stabilizer`` (added by :func:`add_stabilizer`) the hands' external wrenches, so that
    its model has them (the inverted pendulum with external forces at the hands).

    Args:
        b: the builder.
        stabilizer: the stabilizer.
        wrenches: ``"left"`` and ``"right"`` → a (6,) output ``[τ [N m]; f [N]]``, the world's
            wrench on that hand about its ``left_hand``/``right_hand`` frame, world axes (e.g.
            ``AdmittanceController.wrench_external`` of the hand's admittance task).
    """
    if sorted(wrenches) != ["left", "right"]:
        raise ValueError(f"wrenches: keys {sorted(wrenches)}, needs 'left' and 'right'")
    both = b.builder.AddSystem(Multiplexer([6, 6]))
    both.set_name(f"{stabilizer.get_name()}_hand_wrenches")
    for i, side in enumerate(("left", "right")):  # the stabilizer's order
        b.builder.Connect(wrenches[side], both.get_input_port(i))
    b.builder.Connect(both.get_output_port(), stabilizer.GetInputPort("hand_wrenches"))


def add_hip_strategy(
    b: HumanoidTaskBuilder,
    stabilizer: BalanceStabilizer,
    task_name: str = "taskTrunk",
    *,
    frame_key: str = "pelvis",
    gain: float = 10.0,
    profile: LeanProfile = LeanProfile(),
) -> HipStrategy:
    """A ``HipStrategy`` on ``stabilizer``'s ``dcm_excess`` and an orientation task
    ``task_name`` (``frame_key``'s orientation, selection ``"000111"``) that follows it; its
    ``lean`` is logged as ``hip_lean``. Put the task in the stack below the CoM task (the CoM
    is kept while the trunk leans) and above the posture task.

    Args:
        b: the builder.
        stabilizer: the ``BalanceStabilizer`` added by :func:`add_stabilizer`.
        task_name: name of the new orientation task.
        frame_key: the trunk frame (logical name) whose orientation leans.
        gain: the task's gain [1/s].
        profile: the lean.
    """
    hip = b.builder.AddSystem(
        HipStrategy(b.initial_pose(frame_key), profile=profile, period=b.control_period)
    )
    b.builder.Connect(stabilizer.GetOutputPort("dcm_excess"), hip.GetInputPort("dcm_excess"))
    b.add_op_point_task(task_name, frame_key, selection="000111", gain=gain)
    feature = b.features[task_name]
    b.builder.Connect(hip.GetOutputPort("waist"), feature.GetInputPort("position_des"))
    b.builder.Connect(hip.GetOutputPort("waist_vel"), feature.GetInputPort("velocity_des"))
    b.log("hip_lean", hip.GetOutputPort("lean"))
    return hip


def _standing_references(b: HumanoidTaskBuilder) -> dict[str, OutputPort]:
    """Constant references of a robot standing still in its initial posture."""
    com = b.initial_com()
    ports = {}
    for name, value in {"com": com, "com_vel": np.zeros(3), "zmp": com[:2]}.items():
        source = b.builder.AddSystem(ConstantVectorSource(value))
        source.set_name(f"stabilizer_{name}_ref")
        ports[name] = source.get_output_port()
    return ports
