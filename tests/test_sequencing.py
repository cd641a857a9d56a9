"""The sequencing state machine as pure data (drake_sot.sequencing), run without Drake."""

import math

import numpy as np
import pytest

from drake_sot.sequencing import (
    Above,
    Below,
    Clear,
    Down,
    Flag,
    Pop,
    Push,
    Rm,
    SetValue,
    State,
    StateMachine,
    Timeout,
    Transition,
    Up,
)
from drake_sot.stack import Stack, UnknownTaskError

TASKS = ("a", "b", "c", "d")


class _Inputs:
    """Guard inputs by name; records which ones the machine reads."""

    def __init__(self, **values):
        self.values = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in values.items()}
        self.read = []

    def __call__(self, port):
        self.read.append(port)
        return self.values[port]


def test_the_first_holding_transition_fires_and_later_guards_are_not_read():
    machine = StateMachine(
        [
            State("s0", transitions=(Transition(Flag("p"), "s1"), Transition(Flag("q"), "s2"))),
            State("s1", entry=Push("a")),
            State("s2", entry=Push("b")),
        ],
        "s0",
        tasks=TASKS,
    )
    start = machine.start(0.0)
    inputs = _Inputs(p=0.5, q=1.0)  # p is not > 0.5: q fires
    assert machine.step(start, 0.1, inputs).state == "s2" and inputs.read == ["p", "q"]
    inputs = _Inputs(p=1.0, q=1.0)
    after = machine.step(start, 0.1, inputs)
    assert (after.state, after.stack.active, after.count, after.entered) == ("s1", ("a",), 1, 0.1)
    assert inputs.read == ["p"]  # q is not read once p holds
    inputs = _Inputs(p=0.0, q=0.0)
    assert machine.step(start, 0.1, inputs) is start  # nothing holds: the same value
    assert machine.step(after, 0.2, _Inputs()) is after  # a final state reads nothing


def test_entry_actions_apply_in_order_to_the_stack():
    # Expected stacks written by hand from the SoT commands' definitions.
    machine = StateMachine(
        [
            State("s0", transitions=Transition(Timeout(0.0), "s1")),
            State("s1", entry=(Push("c"), Up("c"), Up("c")), transitions=Transition(Timeout(0.0), "s2")),
            State("s2", entry=(Down("c"), Rm("b")), transitions=Transition(Timeout(0.0), "s3")),
            State("s3", entry=(Pop(), Pop(), Push("b")), transitions=Transition(Timeout(0.0), "s4")),
            State("s4", entry=(Clear(), Push("d"), Push("a"))),
        ],
        "s0",
        tasks=TASKS,
        stack=("a", "b"),
    )
    status = machine.start(0.0)
    seen = [status.stack.active]
    for k in range(1, 5):
        status = machine.step(status, 0.1 * k, _Inputs())
        seen.append(status.stack.active)
    assert seen == [("a", "b"), ("c", "a", "b"), ("a", "c"), ("b",), ("d", "a")]
    assert status.state == "s4" and status.count == 4
    assert status.stack == Stack(TASKS, ("d", "a"))


def test_timeout_counts_from_entering_within_a_nanosecond():
    machine = StateMachine(
        [State("s0", transitions=Transition(Timeout(0.2), "s1")), State("s1")], "s0", tasks=TASKS
    )
    status = machine.start(0.1)
    assert status.entered == 0.1 and status.count == 0
    assert machine.step(status, 0.1 + 0.2 - 1e-8, _Inputs()) is status
    assert machine.step(status, 0.1 + 0.2 - 1e-10, _Inputs()).state == "s1"  # rounding of event times


@pytest.mark.parametrize(
    "vector", [[0.06, 0.06, 0.06], [0.05, 0.05, 0.05], [0.0, 0.3, 0.4], [0.0, 0.3, 0.41]]
)
def test_below_and_above_compare_the_euclidean_norm(vector):
    norm = math.sqrt(sum(x * x for x in vector))
    machine = StateMachine(
        [
            State(
                "s0",
                transitions=(
                    Transition(Below("e", 0.1, size=3), "low"),
                    Transition(Above("e", 0.5, size=3), "high"),
                ),
            ),
            State("low"),
            State("high"),
        ],
        "s0",
        tasks=TASKS,
    )
    state = machine.step(machine.start(0.0), 0.0, _Inputs(e=vector)).state
    assert state == ("low" if norm < 0.1 else "high" if norm > 0.5 else "s0")
    assert machine.guard_ports == {"e": 3}


def test_a_non_finite_input_names_the_port_and_the_state():
    machine = StateMachine([State("s0", transitions=Transition(Flag("go"), "s0"))], "s0", tasks=TASKS)
    with pytest.raises(RuntimeError, match=r"state 's0': input port 'go' holds NaN or Inf at t = 0.2500 s"):
        machine.step(machine.start(0.0), 0.25, _Inputs(go=np.nan))


def test_set_value_makes_new_values_and_leaves_the_old_status_alone():
    machine = StateMachine(
        [
            State("s0", entry=SetValue("gain", 2.0), transitions=Transition(Timeout(0.0), "s1")),
            State("s1", entry=(SetValue("ref", [1.0, -1.0]), SetValue("label", "grasp"))),
        ],
        "s0",
        tasks=TASKS,
        values={"gain": 1.0, "ref": (0.0, 0.0), "label": "idle"},
    )
    assert machine.vector_sizes == {"gain": 1, "ref": 2}
    start = machine.start(0.0)
    np.testing.assert_array_equal(start.values["gain"], [2.0])  # the initial entry ran
    after = machine.step(start, 0.1, _Inputs())
    np.testing.assert_array_equal(after.values["ref"], [1.0, -1.0])
    assert after.values["label"] == "grasp" and start.values["label"] == "idle"
    np.testing.assert_array_equal(start.values["ref"], [0.0, 0.0])
    with pytest.raises(ValueError, match="read-only"):
        after.values["ref"][0] = 5.0
    with pytest.raises(TypeError):
        after.values["gain"] = 3.0  # a read-only mapping


def test_definition_errors_name_what_is_wrong():
    with pytest.raises(
        UnknownTaskError, match=r"state 's0': entry action Push\(task='zz'\): unknown task 'zz'"
    ):
        StateMachine([State("s0", entry=Push("zz"))], "s0", tasks=TASKS)
    with pytest.raises(KeyError):  # an unknown name is a KeyError too
        StateMachine([State("s0", entry=Rm("zz"))], "s0", tasks=TASKS)
    with pytest.raises(
        ValueError, match=r"entering state 's0': entry action Pop\(\): pop from an empty stack"
    ):
        StateMachine([State("s0", entry=Pop())], "s0", tasks=TASKS)
    with pytest.raises(ValueError, match=r"'ref' are set by no SetValue"):
        StateMachine([State("s0")], "s0", tasks=TASKS, values={"ref": 0.0})
    with pytest.raises(TypeError, match="is not a State"):
        StateMachine(["s0"], "s0", tasks=TASKS)
    with pytest.raises(ValueError, match="tasks must be a sequence of task names, got the string 'abc'"):
        StateMachine([State("s0")], "s0", tasks="abc")


def test_paths_are_checked_or_the_failure_comes_at_run_time_with_the_time():
    states = [
        State("idle", transitions=(Transition(Flag("go"), "grasp"), Transition(Flag("walk"), "walking"))),
        State("walking", entry=Push("b"), transitions=Transition(Timeout(1.0), "grasp")),
        State("grasp", entry=(Rm("b"), Push("c"))),
    ]
    # idle → walking → grasp works; idle → grasp does not: the breadth-first search finds it.
    with pytest.raises(
        ValueError,
        match=r"by the path idle → grasp would fail \(pass check_paths=False if that path cannot happen\): "
        r"entry action Rm\(task='b'\)",
    ):
        StateMachine(states, "idle", tasks=TASKS, stack=("a",))
    machine = StateMachine(states, "idle", tasks=TASKS, stack=("a",), check_paths=False)
    walking = machine.step(machine.start(0.0), 0.0, _Inputs(go=0.0, walk=1.0))
    assert machine.step(walking, 1.0, _Inputs()).stack.active == ("a", "c")
    with pytest.raises(
        RuntimeError, match=r"entering state 'grasp': entry action Rm\(task='b'\): .* \(t = 0.5000 s\)"
    ):
        machine.step(machine.start(0.0), 0.5, _Inputs(go=1.0, walk=0.0))


def test_definitions_are_values():
    assert Push("a") == Push("a") and Timeout(1) == Timeout(1.0)
    assert Below("e", 1, size=2.0).size == 2 and isinstance(Below("e", 1).threshold, float)
    state = State("s", entry=Push("a"), transitions=Transition(Flag("p"), "s"))
    assert state.entry == (Push("a"),) and state.transitions == (Transition(Flag("p"), "s"),)
    with pytest.raises(ValueError, match=r"Below\('e'\).threshold = 0.0: must be finite and > 0"):
        Below("e", 0.0)  # a norm is never below 0
    with pytest.raises(ValueError, match=r"Above\('e'\).threshold = nan"):
        Above("e", float("nan"))
    with pytest.raises(ValueError, match="State.name = '': must be a non-empty string"):
        State("")


# --- smooth changes of the stack (transition_time) ---------------------------------------


def _blend_machine(**kwargs) -> StateMachine:
    """idle (a) → reach (a, b): push b after 1 s; → rest: rm a, at once or over the machine's time."""
    return StateMachine(
        [
            State("idle", transitions=(Transition(Timeout(1.0), "reach"),)),
            State(
                "reach",
                entry=(Push("b"),),
                transitions=(Transition(Timeout(1.0), "rest"),),
                transition_time=kwargs.pop("reach_time", None),
            ),
            State("rest", entry=(Rm("a"),)),
        ],
        "idle",
        tasks=TASKS,
        stack=("a",),
        **kwargs,
    )


def test_a_state_entered_with_a_transition_time_blends_its_change_of_the_stack():
    machine = _blend_machine(reach_time=0.5, transition_time=0.2)
    status = machine.start(0.0)
    status = machine.step(status, 1.0, _Inputs())  # enters reach at t = 1 over its own 0.5 s
    assert status.state == "reach" and status.stack.active == ("a", "b")
    assert status.stack.transition is not None
    assert status.stack.transition.origin.active == ("a",)
    assert (status.stack.transition.start, status.stack.transition.duration) == (1.0, 0.5)
    # The blend weights are eq. 12's raised cosine from the state's entry (written here).
    for t in (1.0, 1.1, 1.25, 1.4, 1.5, 2.0):
        h = 0.5 - 0.5 * math.cos(math.pi * min(max((t - 1.0) / 0.5, 0.0), 1.0))
        expected = {("a", "b"): h, ("a",): 1.0 - h}
        got = dict(status.stack.blend(t))
        for active, weight in expected.items():
            assert got.get(active, 0.0) == pytest.approx(weight, abs=1e-12)
    status = machine.step(status, 2.0, _Inputs())  # rest: the machine's 0.2 s (no time of its own)
    assert status.stack.active == ("b",)
    assert (status.stack.transition.start, status.stack.transition.duration) == (2.0, 0.2)
    assert status.stack.transition.origin.active == ("a", "b")  # the finished change is dropped
    assert status.stack.transition.origin.transition is None


def test_without_a_transition_time_a_state_changes_the_stack_at_once():
    machine = _blend_machine()
    status = machine.step(machine.start(0.0), 1.0, _Inputs())
    assert status.stack.active == ("a", "b") and status.stack.transition is None
    assert status.stack.blend(1.0) == ((("a", "b"), 1.0),)
    # A state's own 0 overrides the machine's time.
    status = _blend_machine(reach_time=0.0, transition_time=0.3).step(machine.start(0.0), 1.0, _Inputs())
    assert status.stack.transition is None


@pytest.mark.parametrize("bad", [-0.1, math.nan, math.inf])
def test_bad_transition_times_are_refused_naming_them(bad):
    with pytest.raises(ValueError, match=rf"state 'x': transition_time = {bad} s: must be finite and >= 0"):
        State("x", transition_time=bad)
    with pytest.raises(ValueError, match=rf"sequencer 'sequencer': transition_time = {bad} s"):
        _blend_machine(transition_time=bad)
