"""Scenario ``walk_then_interact``: the case study of Mansard et al. 2009 (IV-B, IV-D).

The robot walks 4 steps to a meeting point under the walking tasks (joint position and
velocity limits on top, an inequality solved by ``solve_hqp``; self-collision avoidance
just below them, ``taskSelfCollision``, unless ``self_collision`` is off, without rows
between the legs, which the footsteps keep apart; feet, CoM and waist
references from the pattern generator, hands carried in the waist frame).
A ``TaskSequencer`` plays the paper's DecisionServer: every 1 s it checks whether the
pattern generator still provides references (its ``in_process`` flag); once the walk
is over it removes the walking hand tasks and pushes ``taskForce`` and ``taskForceLH``
(admittance-controlled hands, raised above the posture). A partner then takes both
hands and pulls and pushes them (forward, back, sideways) for several seconds; the
hands comply.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.systems.framework import OutputPort

from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.run import TimedCommand
from drake_sot.diagrams.scenario import (
    ROBOT,
    SELF_COLLISION,
    RemoteDecision,
    Scenario,
    ScenarioHandles,
    ScenarioSetup,
)
from drake_sot.diagrams.tasks import HAND_SCALE, PARTNER_COLOUR
from drake_sot.diagrams.walk_then_interact_plots import plot_interaction
from drake_sot.diagrams.walking import STABILIZER, add_walking, forward_steps
from drake_sot.footsteps import Footstep
from drake_sot.parameters import Parameter
from drake_sot.sequencing import Above, Below, Push, Rm, SetValue, State, Transition, Up
from drake_sot.systems.partner import Hold, Partner
from drake_sot.systems.pattern_generator import PatternGenerator
from drake_sot.systems.replay_view import Arrow, ArrowGroup
from drake_sot.systems.sequencer import TaskSequencer

WALKING_TASKS = ("taskRHwaist", "taskLHwaist")
FORCE_TASKS = ("taskForce", "taskForceLH")
STACK = ("taskJL", "taskLF", "taskRF", "taskCom", "taskWaist", "taskRHwaist", "taskLHwaist", "taskPosture")
#: The partner's grip offsets from where it takes each hand: (time from grip [s], offset [m]).
PULL_PUSH = (
    (0.0, (0.0, 0.0, 0.0)),
    (1.0, (0.08, 0.0, 0.0)),
    (2.0, (0.08, 0.0, 0.0)),
    (3.5, (-0.05, 0.0, 0.0)),
    (4.5, (-0.05, 0.0, 0.0)),
    (5.5, (0.0, 0.06, 0.0)),
    (6.5, (0.0, 0.06, 0.0)),
)
GRIP_AT = 7.0  # [s] the partner takes the hands (the walk ends near 5 s, the switch at the next 1 s check)
RELEASE_AT = GRIP_AT + 7.0
ADMITTANCE = {"mass": (4.0, 4.0, 4.0, 0.2, 0.2, 0.2), "damping": (60.0, 60.0, 60.0, 4.0, 4.0, 4.0)}


#: The DecisionServer's switch of the stack once the walk is over (then the hands' admittance is
#: switched on), and the same as the script lines a remote decision layer sends.
SWITCH = (
    Rm("taskRHwaist"),
    Rm("taskLHwaist"),
    Push("taskForce"),
    Up("taskForce"),
    Push("taskForceLH"),
    Up("taskForceLH"),
)
SWITCH_LINES = tuple(f"sot.{action}" for action in SWITCH)  # each command as its script line
DECISIONS = ("sequencer", "remote")
DECISION = Parameter(
    "decision",
    "choice",
    "sequencer",
    "the decision layer: the sequencer in the diagram, or a separate client process driving the stack "
    "through the command server (paced at real time)",
    choices=DECISIONS,
)


def build(
    meshcat: Meshcat | None = None,
    pushes: Sequence[ExternalPush] = (),
    decision: str = "sequencer",
    stabilizer: bool = True,
    robot: str = "embedded",
    command_server: bool = False,
    self_collision: bool = True,
) -> ScenarioSetup:
    """Build the ``walk_then_interact`` diagram and its script, with ``pushes`` on ``robot`` (a
    name of ``drake_sot.robots.ROBOTS``), with or without the self-collision task; ``command_server``: see
    :func:`~drake_sot.diagrams.scenario.build_scenario` (``decision="remote"`` has one whatever it
    says).

    ``decision``: ``"sequencer"`` (the DecisionServer is a ``TaskSequencer`` in the diagram)
    or ``"remote"`` (as the paper ran it: a separate program polls ``pg.in_process`` and sends
    :data:`SWITCH_LINES` and ``remote.force_active`` = 1 through the command server; the stack is
    then the solver's own, driven by the server's stack commands, and ``force_active`` a signal
    the diagram declares writable on its server; what the decision client polls and sends is
    ``extras.decision``). ``stabilizer``: the balance stabilizer between the pattern generator
    and the CoM task (see ``walking.add_walking``)."""
    decision = DECISION.check(decision)
    if decision == "remote":
        return _build_remote(meshcat, pushes, stabilizer, robot, self_collision)
    b, pg, left, right, admittances, stack = _walking_and_hands(
        meshcat, pushes, stabilizer, robot, self_collision
    )

    # The DecisionServer: every 1 s, is the pattern generator still walking?
    switch = (*SWITCH, SetValue("force_active", np.ones(1)))
    sequencer = b.builder.AddSystem(
        TaskSequencer(
            [
                State("standing", transitions=(Transition(Above("in_process", 0.5), "walking"),)),
                State("walking", transitions=(Transition(Below("in_process", 0.5), "interacting"),)),
                State("interacting", entry=switch),
            ],
            "standing",
            tasks=list(b.tasks),
            stack=stack,
            period=1.0,
            values={"force_active": np.zeros(1)},
            name="decision_server",
        )
    )
    b.builder.Connect(pg.GetOutputPort("in_process"), sequencer.GetInputPort("in_process"))
    for admittance in admittances.values():
        b.builder.Connect(sequencer.GetOutputPort("force_active"), admittance.GetInputPort("active"))

    b.log("transitions", sequencer.GetOutputPort("transitions"))
    return _finish(
        b,
        pg,
        left,
        right,
        admittances,
        stack,
        sequencer.GetOutputPort("stack"),
        ScenarioHandles(sequencer=sequencer),
        command_server=command_server,
    )


def _walking_and_hands(
    meshcat: Meshcat | None,
    pushes: Sequence[ExternalPush],
    stabilizer: bool,
    robot: str,
    self_collision: bool,
):
    """The builder with the walking tasks, both admittance-controlled hand tasks and the posture,
    and the initial stack: ``STACK`` with the self-collision task when ``self_collision``."""
    b = HumanoidSoTBuilder(meshcat=meshcat, pushes=pushes, robot=robot)
    pg, left, right = add_walking(b, stabilizer=stabilizer)
    admittances = {
        "taskForce": b.add_admittance_task("taskForce", "right", **ADMITTANCE),
        "taskForceLH": b.add_admittance_task("taskForceLH", "left", **ADMITTANCE),
    }
    b.add_posture_task("taskPosture", gain=1.0)
    return b, pg, left, right, admittances, b.below_joint_limits(STACK, self_collision, leg_pairs=False)


def _build_remote(
    meshcat: Meshcat | None,
    pushes: Sequence[ExternalPush],
    stabilizer: bool,
    robot: str,
    self_collision: bool,
) -> ScenarioSetup:
    b, pg, left, right, admittances, stack = _walking_and_hands(
        meshcat, pushes, stabilizer, robot, self_collision
    )
    active = b.declare_writable("force_active", 1, "1 on, 0 off", np.zeros(1), bound=1.0)
    for admittance in admittances.values():
        b.builder.Connect(active, admittance.GetInputPort("active"))
    decision = RemoteDecision(
        signal="pg.in_process", period=1.0, run=SWITCH_LINES, write=("remote.force_active=1",)
    )
    return _finish(b, pg, left, right, admittances, stack, None, ScenarioHandles(decision=decision))


def _finish(
    b: HumanoidSoTBuilder,
    pg: PatternGenerator,
    left: Footstep,
    right: Footstep,
    admittances: dict,
    stack: tuple[str, ...],
    stack_source: OutputPort | None,
    extras: ScenarioHandles,
    *,
    command_server: bool = False,
) -> ScenarioSetup:
    """The partner, the logs and the build of the initial ``stack``, common to both decision
    layers; ``extras``: the decision layer's handles, completed here."""
    # The partner holds the bodies below the wrist sensors (the hands).
    hands = [
        b.plant.GetJointByName(b.info.force_sensors[f"{side}_wrist"]).child_body().name()
        for side in ("right", "left")
    ]
    partner = b.builder.AddSystem(
        Partner(b.plant, {hand: [Hold(GRIP_AT, RELEASE_AT, PULL_PUSH)] for hand in hands})
    )
    partner.set_name("partner")
    b.builder.Connect(b.plant.get_body_poses_output_port(), partner.GetInputPort("body_poses"))
    b.builder.Connect(
        b.plant.get_body_spatial_velocities_output_port(), partner.GetInputPort("body_spatial_velocities")
    )
    b.apply_spatial_forces(partner.GetOutputPort("spatial_forces"))

    b.log("partner_forces", partner.GetOutputPort("forces"))
    b.draw_forces(
        ArrowGroup(
            "partner",
            "the partner's pull on the hands",
            PARTNER_COLOUR,
            HAND_SCALE,
            3 * len(hands),
            tuple(Arrow(hand, (0.0, 0.0, 0.0), 3 * k) for k, hand in enumerate(hands)),
        ),
        partner.GetOutputPort("forces"),
    )
    for task_name, admittance in admittances.items():
        b.log(f"wrench/{task_name}", admittance.GetOutputPort("wrench_external"))
        b.log(f"fault/{task_name}", admittance.GetOutputPort("fault"))
    b.log("in_process", pg.GetOutputPort("in_process"))
    built = b.build(
        stack=stack,
        load=pg.GetOutputPort("load"),
        dynamic_feedforward=True,
        stack_source=stack_source,
        solver="hqp",
        command_server=command_server,
    )
    steps = forward_steps(left, right, n=4, stride=0.15)
    return ScenarioSetup(
        built=built,
        commands=[TimedCommand(0.0, f"walk {len(steps)} steps", lambda c: pg.add_steps(c, steps))],
        duration=RELEASE_AT + 1.0,
        extras=dataclasses.replace(
            extras, pattern_generator=pg, admittances=admittances, steps=steps, hands=hands
        ),
    )


def hand_positions(setup: ScenarioSetup, arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """side → (T, 3) position of each hand frame in the simulated plant."""
    built = setup.built
    plant, info = built.plant, built.info
    context = plant.CreateDefaultContext()
    frames = {
        side: plant.GetFrameByName(info.frames[f"{side}_hand"], info.model_instance)
        for side in ("right", "left")
    }
    out = {side: np.zeros((len(arrays["time"]), 3)) for side in frames}
    for k, q in enumerate(arrays["q"]):
        plant.SetPositions(context, info.model_instance, q)
        for side, frame in frames.items():
            out[side][k] = frame.CalcPoseInWorld(context).translation()
    return out


def write_plots(setup: ScenarioSetup, arrays: dict[str, np.ndarray], out_dir: Path) -> dict[str, Path]:
    """Hand forces (measured by the wrist sensors, applied by the partner) and hand displacements."""
    hands = hand_positions(setup, arrays)
    t = arrays["time"]
    # The interaction, after the walk; the whole run when it ended before the partner took the
    # hands (a short --duration, Ctrl-C, a fall), displacements then from its last sample.
    grip = min(int(np.searchsorted(t, GRIP_AT)), len(t) - 1)
    window = slice(int(np.searchsorted(t, GRIP_AT - 1.0)) if t[-1] >= GRIP_AT else 0, None)
    path = Path(out_dir) / "walk_then_interact_hands.png"
    plot_interaction(
        t[window],
        {"right": arrays["wrench/taskForce"][window, 3:], "left": arrays["wrench/taskForceLH"][window, 3:]},
        {"right": arrays["partner_forces"][window, :3], "left": arrays["partner_forces"][window, 3:]},
        {side: (p - p[grip])[window] for side, p in hands.items()},
        [(GRIP_AT, "partner takes the hands"), (RELEASE_AT, "release")],
        path,
    )
    return {"hands": path}


SCENARIO = Scenario(
    name="walk_then_interact",
    description="walk 4 steps, a decision rule switches to admittance-controlled hands, a partner pulls them",
    build=build,
    extra_plots=write_plots,
    parameters=(DECISION, STABILIZER, ROBOT, SELF_COLLISION),
    servable=True,
)
