"""The ``telecooperation`` stack with and without the self-collision task (built only, no
simulation): ``taskSelfCollision`` just below the joint limits by default in both the one-process
scenario and its served slave side, out with ``self_collision=False``, and the sequencer's
walking stack what it is without the task, the task added."""

import pytest

from drake_sot.diagrams import SCENARIOS
from drake_sot.diagrams import telecooperation as tc
from drake_sot.diagrams.tasks import SELF_COLLISION_TASK

#: The stack standing, written out from the scenario's docstring (highest priority first).
STANDING = (
    "taskJL",
    "taskLF",
    "taskRF",
    "taskCom",
    "taskWaist",
    "e_fr",
    "e_fl",
    "e_head",
    "e_grip",
    "taskComZ",
    "taskPosture",
)
#: Walking: e_zr and e_zl above the hands' admittance tasks, below the waist.
WALKING = (*STANDING[:5], "e_zr", "e_zl", *STANDING[5:])
SCENARIO_NAMES = ("telecooperation", "telecoop_slave")


def _with_task(stack: tuple[str, ...]) -> tuple[str, ...]:
    return (stack[0], SELF_COLLISION_TASK, *stack[1:])


def _stacks(name: str, **parameters) -> dict[str, tuple[str, ...]]:
    """The sequencer's stack in each of its states, entered in the scenario's order (standing,
    walking, stopped, walking again), and the stack the built diagram starts with."""
    setup = SCENARIOS[name].build(None, **parameters)
    machine = setup.extras.sequencer.machine
    status = machine.initial_status
    stacks = {"standing": status.stack.active}
    for k, state in enumerate(("walking", "stopped", "walking")):
        status = machine.enter(state, status, float(k + 1))
        stacks[state] = status.stack.active
    context = setup.built.diagram.CreateDefaultContext()
    stacks["built"] = setup.extras.sequencer.stack(context)
    stacks["tasks"] = tuple(setup.built.tasks)
    return stacks


@pytest.fixture(scope="module", params=SCENARIO_NAMES)
def stacks(request) -> tuple[dict, dict]:
    """The stacks by default and with ``self_collision=False``."""
    return _stacks(request.param), _stacks(request.param, self_collision=False)


def test_the_self_collision_task_is_just_below_the_joint_limits_by_default_and_out_when_off(stacks):
    on, off = stacks
    assert on["standing"] == on["built"] == on["stopped"] == _with_task(STANDING)
    assert off["standing"] == off["built"] == off["stopped"] == STANDING
    assert SELF_COLLISION_TASK in on["tasks"]
    assert SELF_COLLISION_TASK not in off["tasks"]


def test_walking_the_stack_is_what_it_is_without_the_task_plus_the_task(stacks):
    """The altitude tasks e_zr, e_zl raised above the hands' admittance tasks as without the
    self-collision task (the raise counts levels from the bottom), the task below the joint limits."""
    on, off = stacks
    assert off["walking"] == WALKING
    assert on["walking"] == _with_task(WALKING)


def test_the_task_has_no_rows_between_the_legs_and_none_with_the_board():
    """Walking, the footsteps keep the legs apart (``leg_pairs=False``); the board is not the
    robot's, so no pair has it; the arms against the body and each other are watched."""
    setup = tc.build()
    task = setup.built.diagram.GetSubsystemByName(SELF_COLLISION_TASK)
    pairs = {frozenset((p.body_a, p.body_b)) for p in task.candidate_pairs}
    legs = {side: {f"{side}_thigh", f"{side}_shank", f"{side}_foot"} for side in "lr"}
    assert not any(len(pair & legs["l"]) == 1 and len(pair & legs["r"]) == 1 for pair in pairs)
    board_bodies = {
        setup.built.plant.get_body(index).name()
        for index in setup.built.plant.GetBodyIndices(setup.built.plant.GetModelInstanceByName("board"))
    }
    assert board_bodies and not any(pair & board_bodies for pair in pairs)
    for watched in (("l_hand", "r_hand"), ("r_forearm", "torso"), ("l_hand", "pelvis")):
        assert frozenset(watched) in pairs, watched
