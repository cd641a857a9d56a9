"""Smooth push and rm in the closed loop: the humanoid standing (feet, CoM, posture) gets a
left-hand task pushed (and raised above the posture) at 0.5 s and removed at 1.5 s, once
at once (no transition) and once over T = 0.5 s.

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
from drake_sot.diagrams.run import Command, simulate

PUSH, RM, TRANSITION = 0.5, 1.5, 0.5


def _qdot_changes(transition: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(tick times, ‖q̇_{k+1} - q̇_k‖ of the joints [rad/s], the period) of one run."""
    b = HumanoidSoTBuilder()
    X = b.initial_pose("left_hand")
    b.add_op_point_task("taskLF", "left_foot", gain=5.0)
    b.add_op_point_task("taskRF", "right_foot", gain=5.0)
    b.add_com_task("taskCom", selection="110", gain=3.0)
    target = RigidTransform(X.rotation(), X.translation() + [0.2, 0.0, 0.15])
    b.add_op_point_task("taskLH", "left_hand", gain=2.5, desired=target)
    b.add_posture_task("taskPosture")
    built = b.build(stack=["taskLF", "taskRF", "taskCom", "taskPosture"])
    sot = built.sot

    def push(context):
        sot.push(context, "taskLH", transition=transition)
        sot.up(context, "taskLH", transition=transition)

    simulator = built.create_simulator()
    commands = [
        Command(PUSH, "push taskLH", push),
        Command(RM, "rm taskLH", lambda c: sot.rm(c, "taskLH", transition=transition)),
    ]
    result = simulate(simulator, RM + 0.7, commands)
    assert result.completed, result.failure
    arrays = log_arrays(built, simulator.get_context(), result)
    dt = sot.period
    qdot = np.diff(arrays["q_ref"][:, 7:], axis=0) / dt
    return arrays["time"][1:-1], np.linalg.norm(np.diff(qdot, axis=0), axis=1), dt


@pytest.fixture(scope="module")
def runs():
    return {transition: _qdot_changes(transition) for transition in (0.0, TRANSITION)}


@pytest.mark.parametrize("command_time", [PUSH, RM], ids=["push", "rm"])
def test_a_transition_spreads_the_jump_of_qdot_over_its_duration(runs, command_time):
    time, instant, dt = runs[0.0]
    _, smooth, _ = runs[TRANSITION]
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
