"""Smooth push and rm in the closed loop: the humanoid standing (feet, CoM, posture) gets a
left-hand task pushed (and raised above the posture) at 0.5 s and removed at 1.5 s, once
at once (no transition) and once over T = 0.5 s; given by commands on the context, by a
``TaskSequencer`` (states entered at those times, the machine's ``transition_time``, its
``smooth_stack`` driving the solver) and by remote command lines (``sot.push taskLH 0.5``,
``sot.up taskLH 0.5``, ``sot.rm taskLH 0.5`` through the ``RemoteCommandServer``).

q̇ is measured on the reference the ``Device`` integrated, q̇_k = (q_ref[k+1] - q_ref[k]) / dt
for the joints (dt = the control period), not read from the solver.

The stated bound: over a transition the blend weight h of Liu, Lober, Padois 2016, eq. 12
moves by at most π·dt / (2T) per tick (1.6 % for dt = 5 ms, T = 0.5 s), so a tick changes q̇
by at most that fraction of the gap between the solutions before and after the command,
which is the jump the same command makes without a transition, plus what the motion of
the robot changes. The test allows twice the first term: ‖Δq̇‖ per tick ≤ π·dt / T times
the jump measured without the transition (3.1 %).
"""

import numpy as np
import pytest
from pydrake.math import RigidTransform

from drake_sot.diagrams.artifacts import log_arrays
from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.diagrams.run import TimedCommand, simulate
from drake_sot.remote.protocol import Request
from drake_sot.sequencing import Push, Rm, State, Timeout, Transition, Up
from drake_sot.systems.sequencer import TaskSequencer

PUSH, RM, TRANSITION = 0.5, 1.5, 0.5
DRIVES = ("context", "sequencer", "remote")


class _Inbox:
    """The network thread's queue, filled by the run's commands: taken at the server's next tick."""

    def __init__(self) -> None:
        self.items: list = []

    def put(self, *lines: str) -> None:
        self.items += [(0, Request("run", id=k, cmd=line)) for k, line in enumerate(lines)]

    def __call__(self) -> list:
        items, self.items = self.items, []
        return items


def _qdot_changes(transition: float, drive: str = "context") -> tuple[np.ndarray, np.ndarray, float]:
    """(tick times, ‖q̇_{k+1} - q̇_k‖ of the joints [rad/s], the period) of one run, the stack
    changed by ``drive``."""
    b = HumanoidSoTBuilder()
    X = b.initial_pose("left_hand")
    b.add_op_point_task("taskLF", "left_foot", gain=5.0)
    b.add_op_point_task("taskRF", "right_foot", gain=5.0)
    b.add_com_task("taskCom", selection="110", gain=3.0)
    target = RigidTransform(X.rotation(), X.translation() + [0.2, 0.0, 0.15])
    b.add_op_point_task("taskLH", "left_hand", gain=2.5, desired=target)
    b.add_posture_task("taskPosture")
    stack = ("taskLF", "taskRF", "taskCom", "taskPosture")
    sequencer = None
    if drive == "sequencer":
        sequencer = b.builder.AddSystem(
            TaskSequencer(
                [
                    State("stand", transitions=(Transition(Timeout(PUSH), "reach"),)),
                    State(
                        "reach",
                        entry=(Push("taskLH"), Up("taskLH")),
                        transitions=(Transition(Timeout(RM - PUSH), "rest"),),
                    ),
                    State("rest", entry=(Rm("taskLH"),)),
                ],
                "stand",
                tasks=tuple(b.tasks),
                stack=stack,
                period=b.control_period,
                transition_time=transition,
            )
        )
    inbox = _Inbox()
    if drive == "remote":
        b.command_server()
    built = b.build(
        stack=list(stack), stack_source=None if sequencer is None else sequencer.GetOutputPort("smooth_stack")
    )
    sot = built.sot
    seconds = f" {transition:g}" if transition else ""  # no time: the paper's syntax

    def push(context):
        sot.push(context, "taskLH", transition=transition)
        sot.up(context, "taskLH", transition=transition)

    simulator = built.create_simulator()
    if drive == "remote":
        built.remote.attach(inbox)
        commands = [
            TimedCommand(
                PUSH - 1e-3,
                "push taskLH",
                lambda c: inbox.put(f"sot.push taskLH{seconds}", f"sot.up taskLH{seconds}"),
            ),
            TimedCommand(RM - 1e-3, "rm taskLH", lambda c: inbox.put(f"sot.rm taskLH{seconds}")),
        ]
    elif drive == "context":
        commands = [
            TimedCommand(PUSH, "push taskLH", push),
            TimedCommand(RM, "rm taskLH", lambda c: sot.rm(c, "taskLH", transition=transition)),
        ]
    else:
        commands = []
    result = simulate(simulator, RM + 0.7, commands)
    assert result.completed, result.failure
    arrays = log_arrays(built, simulator.get_context(), result)
    dt = sot.period
    qdot = np.diff(arrays["q_ref"][:, 7:], axis=0) / dt
    return arrays["time"][1:-1], np.linalg.norm(np.diff(qdot, axis=0), axis=1), dt


@pytest.fixture(scope="module")
def runs():
    return {}


@pytest.mark.parametrize("drive", DRIVES)
@pytest.mark.parametrize("command_time", [PUSH, RM], ids=["push", "rm"])
def test_a_transition_spreads_the_jump_of_qdot_over_its_duration(runs, command_time, drive):
    for transition in (0.0, TRANSITION):
        if (drive, transition) not in runs:
            runs[drive, transition] = _qdot_changes(transition, drive)
    time, instant, dt = runs[drive, 0.0]
    _, smooth, _ = runs[drive, TRANSITION]
    before = time < PUSH - dt / 2
    window = (time > command_time - dt / 2) & (time < command_time + TRANSITION + 0.1)
    jump = instant[window].max()
    # Without the transition the jump is visible: a joint speed changes by > 0.5 rad/s in one
    # tick, where standing still before the push it changed by < 1e-3 rad/s per tick.
    assert instant[before].max() < 1e-3 and smooth[before].max() < 1e-3
    assert jump > 0.5
    bound = np.pi * dt / TRANSITION * jump
    assert smooth[window].max() <= bound, (
        f"a tick changed q̇ by {smooth[window].max():.4f} rad/s, more than {bound:.4f} "
        f"(π·dt/T = {np.pi * dt / TRANSITION:.3f} of the {jump:.3f} rad/s jump without transition)"
    )
