"""TaskSequencer: a state machine driving StackOfTasks through its ``stack`` input (Mansard, Stasse,
Evrard, Kheddar 2009, IV-B)."""

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

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
    Timeout,
    Transition,
    Up,
)
from drake_sot.signals import TaskSignal
from drake_sot.systems.features import FeatureGeneric
from drake_sot.systems.sequencer import TaskSequencer
from drake_sot.systems.sot import StackOfTasks
from drake_sot.systems.task import Task

NV = 3
PERIOD = 0.01
# Fixed tasks on coordinates of q̇, chosen so that q̇ tells which tasks act and in which
# order: a and c both want q̇[0] (1 and 3), so the higher-priority one wins it.
TASKS = {"a": (0, 1.0), "b": (1, 2.0), "c": (0, 3.0)}
TASK_NAMES = tuple(TASKS)


def _task_signal(name):
    axis, rate = TASKS[name]
    J = np.zeros((1, NV))
    J[0, axis] = 1.0
    return TaskSignal(name, np.array([-rate]), J, np.array([rate]))


def _expected_qdot(stack):
    """Strict priority by hand: each coordinate goes to the first task of the stack wanting it."""
    qdot = np.zeros(NV)
    taken = set()
    for name in stack:
        axis, rate = TASKS[name]
        if axis not in taken:
            qdot[axis] = rate
            taken.add(axis)
    return qdot


class _Rig:
    """StackOfTasks over fixed tasks, driven by a TaskSequencer; guard inputs fixed by hand."""

    def __init__(
        self,
        states,
        initial="s0",
        stack=(),
        values=None,
        period=PERIOD,
        guards=None,
        output="stack",
        **kwargs,
    ):
        builder = DiagramBuilder()
        self.sot = builder.AddSystem(StackOfTasks(NV, {n: 1 for n in TASKS}, period=PERIOD))
        self.seq = builder.AddSystem(
            TaskSequencer(
                states,
                initial,
                tasks=self.sot.task_names,
                stack=stack,
                period=period,
                values=values or {},
                **kwargs,
            )
        )
        builder.Connect(self.seq.GetOutputPort(output), self.sot.GetInputPort("stack"))
        self.diagram = builder.Build()
        self.simulator = Simulator(self.diagram)
        self.context = self.simulator.get_mutable_context()
        self.sot_context = self.sot.GetMyMutableContextFromRoot(self.context)
        self.seq_context = self.seq.GetMyMutableContextFromRoot(self.context)
        for name in TASKS:
            self.sot.GetInputPort(name).FixValue(self.sot_context, _task_signal(name))
        for port, value in (guards or {}).items():
            self.set(port, value)

    def set(self, port, value):
        self.seq.GetInputPort(port).FixValue(self.seq_context, np.atleast_1d(np.asarray(value, dtype=float)))

    def run(self, t):
        """Advance to ``t`` (chosen between checks, so that the check at a multiple of the period is done)."""
        self.simulator.AdvanceTo(t)
        return self

    @property
    def state(self):
        return self.seq.GetOutputPort("state").Eval(self.seq_context)

    @property
    def count(self):
        return int(self.seq.GetOutputPort("transitions").Eval(self.seq_context)[0])

    @property
    def stack(self):
        return self.sot.GetOutputPort("stack").Eval(self.sot_context)

    @property
    def qdot(self):
        return self.sot.GetOutputPort("qdot").Eval(self.sot_context)


def test_initial_entry_actions_apply_at_t0():
    states = [
        State(
            "s0",
            entry=(Push("c"), Push("b"), Up("b"), SetValue("ref", [4.0, 5.0])),
            transitions=(Transition(Timeout(0.05), "s1"),),
        ),
        State("s1"),
    ]
    rig = _Rig(states, stack=("a",), values={"ref": np.zeros(2)})
    # A default context already holds the initial state's entry (no simulator needed).
    assert rig.seq.stack(rig.context) == ("a", "b", "c")
    rig.simulator.Initialize()
    assert rig.context.get_time() == 0.0
    assert rig.state == "s0" and rig.count == 0
    assert rig.stack == ("a", "b", "c")
    np.testing.assert_array_equal(rig.seq.GetOutputPort("ref").Eval(rig.seq_context), [4.0, 5.0])
    rig.run(0.5 * PERIOD)  # the SoT's tick at t = 0 used that stack
    np.testing.assert_allclose(rig.qdot, _expected_qdot(("a", "b", "c")))
    np.testing.assert_allclose(rig.qdot, [1.0, 2.0, 0.0])

    # Started later, the initial state is entered at the start time: Timeout counts from there.
    rig = _Rig(states, stack=("a",), values={"ref": np.zeros(2)})
    rig.context.SetTime(1.0)
    rig.simulator.Initialize()
    rig.run(1.045)
    assert rig.state == "s0"
    rig.run(1.055)
    assert rig.state == "s1"


def test_first_listed_transition_wins_and_one_transition_per_check():
    states = [
        State("s0", transitions=(Transition(Flag("p"), "first"), Transition(Flag("q"), "second"))),
        State("first", entry=(Push("a"),), transitions=(Transition(Timeout(0.0), "third"),)),
        State("second", entry=(Push("b"),)),
        State("third", entry=(Push("b"),)),
    ]
    rig = _Rig(states, guards={"p": 0.0, "q": 0.0})
    rig.run(0.025)
    assert rig.state == "s0" and rig.stack == ()
    np.testing.assert_array_equal(rig.qdot, 0.0)
    rig.set("p", 1.0)
    rig.set("q", 1.0)  # both guards hold: the first listed fires
    rig.run(0.035)  # one check (t = 0.03): s0 → first, not on to third in the same check
    assert rig.state == "first" and rig.count == 1
    assert rig.stack == ("a",)
    np.testing.assert_allclose(rig.qdot, _expected_qdot(("a",)))  # the SoT used it at the same tick
    rig.run(0.045)  # next check: Timeout(0) fires at once
    assert rig.state == "third" and rig.count == 2
    assert rig.stack == ("a", "b")
    # The Python accessors agree with the output ports.
    assert rig.seq.current_state(rig.seq_context) == "third"
    assert rig.seq.stack(rig.seq_context) == ("a", "b")
    assert rig.seq.state_names == ("s0", "first", "second", "third")

    # Flag threshold is 0.5.
    rig = _Rig(states, guards={"p": 0.5, "q": 0.51})
    rig.run(0.005)
    assert rig.state == "second"


def test_timeout_counts_from_entering_the_state():
    states = [
        State("s0", transitions=(Transition(Timeout(0.05), "s1"),)),
        State("s1", transitions=(Transition(Timeout(0.03), "s2"),)),
        State("s2"),
    ]
    rig = _Rig(states)
    rig.run(0.045)
    assert rig.state == "s0"
    rig.run(0.055)
    assert rig.state == "s1"
    rig.run(0.075)
    assert rig.state == "s1"
    rig.run(0.085)
    assert rig.state == "s2" and rig.count == 2

    # The paper's DecisionServer checks every second: a 2.5 s timeout fires at the check at 3 s.
    rig = _Rig([State("s0", transitions=(Transition(Timeout(2.5), "s1"),)), State("s1")], period=1.0)
    rig.run(2.9)
    assert rig.state == "s0"
    rig.run(3.1)
    assert rig.state == "s1"


def test_below_and_above_use_the_vector_norm():
    states = [
        State("s0", entry=(Clear(),), transitions=(Transition(Below("err", 0.1, size=3), "converged"),)),
        State("converged", entry=(Push("a"),), transitions=(Transition(Above("err", 0.5, size=3), "s0"),)),
    ]
    rig = _Rig(states, guards={"err": [0.06, 0.06, 0.06]})  # every component < 0.1, norm 0.104
    rig.run(0.055)
    assert rig.state == "s0"
    rig.set("err", [0.05, 0.05, 0.05])  # norm 0.087
    rig.run(0.065)
    assert rig.state == "converged" and rig.stack == ("a",)
    rig.set("err", [0.0, 0.4, 0.3])  # norm exactly 0.5: not above
    rig.run(0.085)
    assert rig.state == "converged"
    rig.set("err", [0.0, 0.4, 0.31])
    rig.run(0.095)
    assert rig.state == "s0" and rig.count == 2 and rig.stack == ()


def test_entry_actions_run_in_order_and_the_sot_follows():
    states = [
        State("s0", transitions=(Transition(Flag("next"), "s1"),)),
        State("s1", entry=(Push("c"), Up("c"), Up("c")), transitions=(Transition(Timeout(0.02), "s2"),)),
        State("s2", entry=(Down("c"), Rm("b")), transitions=(Transition(Timeout(0.02), "s3"),)),
        State("s3", entry=(Pop(), Pop(), Push("b")), transitions=(Transition(Timeout(0.02), "s4"),)),
        State("s4", entry=(Clear(), Push("c"), Push("a"))),
    ]
    rig = _Rig(states, stack=("a", "b"), guards={"next": 0.0})
    rig.run(0.015)
    np.testing.assert_allclose(rig.qdot, _expected_qdot(("a", "b")))
    rig.set("next", 1.0)
    expected = {0.025: ("c", "a", "b"), 0.045: ("a", "c"), 0.065: ("b",), 0.085: ("c", "a")}
    for t, stack in expected.items():
        rig.run(t)
        assert rig.stack == stack, t
        np.testing.assert_allclose(rig.qdot, _expected_qdot(stack))
    np.testing.assert_allclose(rig.qdot, [3.0, 0.0, 0.0])  # c above a: c wins q̇[0]
    assert rig.state == "s4" and rig.count == 4
    # The SoT's errors output follows the driven stack too: b is out.
    errors = rig.sot.GetOutputPort("errors").Eval(rig.sot_context)
    assert np.isnan(errors[rig.sot.error_slices()["b"]]).all()


def test_set_value_drives_a_reference_and_a_gain():
    """SetValue outputs wired to a feature's desired value and to Task.gain change on entry."""
    builder = DiagramBuilder()
    feature = builder.AddSystem(FeatureGeneric(2, name="f"))
    task = builder.AddSystem(Task("t", gain=1.0))
    builder.Connect(feature.GetOutputPort("feature"), task.add(feature))
    states = [
        State("s0", entry=(SetValue("gain", 2.0),), transitions=(Transition(Timeout(0.02), "s1"),)),
        State(
            "s1",
            entry=(
                SetValue("ref", [1.0, -1.0]),
                SetValue("gain", 5.0),
                SetValue("pose", RigidTransform([1.0, 2.0, 3.0])),
            ),
        ),
    ]
    seq = builder.AddSystem(
        TaskSequencer(
            states,
            "s0",
            tasks=("t",),
            period=PERIOD,
            values={"ref": [0.0, 0.0], "gain": 1.0, "pose": RigidTransform()},
        )
    )
    builder.Connect(seq.GetOutputPort("ref"), feature.GetInputPort("sdes"))
    builder.Connect(seq.GetOutputPort("gain"), task.GetInputPort("gain"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    feature_context = feature.GetMyMutableContextFromRoot(context)
    s = np.array([0.5, 0.5])
    feature.GetInputPort("errorIN").FixValue(feature_context, s)
    feature.GetInputPort("jacobianIN").FixValue(feature_context, np.eye(2, 4))
    task_context = task.GetMyContextFromRoot(context)
    seq_context = seq.GetMyContextFromRoot(context)

    simulator.Initialize()
    assert seq.GetOutputPort("gain").size() == 1 and seq.GetOutputPort("ref").size() == 2
    out = task.GetOutputPort("task").Eval(task_context)
    np.testing.assert_allclose(out.edot_des, -2.0 * s)  # initial entry: gain 2, ref 0
    np.testing.assert_array_equal(seq.GetOutputPort("pose").Eval(seq_context).translation(), 0.0)
    with pytest.raises(ValueError, match="comes from input port 'gain'"):
        task.set_gain(context, 3.0)
    with pytest.raises(ValueError, match="comes from input port 'sdes'"):
        feature.set_desired(context, np.zeros(2))

    simulator.AdvanceTo(0.025)
    out = task.GetOutputPort("task").Eval(task_context)
    np.testing.assert_allclose(out.error, s - [1.0, -1.0])
    np.testing.assert_allclose(out.edot_des, -5.0 * (s - [1.0, -1.0]))
    pose = seq.GetOutputPort("pose").Eval(seq_context)
    assert isinstance(pose, RigidTransform)
    np.testing.assert_array_equal(pose.translation(), [1.0, 2.0, 3.0])


def test_sot_refuses_context_commands_while_driven():
    rig = _Rig([State("s0", entry=(Push("a"), Push("b")))])
    rig.simulator.Initialize()
    assert rig.sot.is_driven(rig.context)
    assert rig.sot.list(rig.context) == ("a", "b")
    for command, args in (
        ("push", ("c",)),
        ("pop", ()),
        ("rm", ("a",)),
        ("up", ("b",)),
        ("down", ("a",)),
        ("clear", ()),
    ):
        with pytest.raises(
            ValueError, match=f"cannot {' '.join((command, *args))}: the stack comes from input port 'stack'"
        ):
            getattr(rig.sot, command)(rig.context, *args)
    assert rig.stack == ("a", "b")


def test_unknown_task_is_refused_at_construction_with_the_known_names():
    for action in (Push("taskXX"), Rm("taskXX"), Up("taskXX"), Down("taskXX")):
        states = [
            State("s0", transitions=(Transition(Timeout(1.0), "s1"),)),
            State("s1", entry=(Push("a"), action)),
        ]
        with pytest.raises(ValueError, match=r"state 's1'.*unknown task 'taskXX'; known: a, b, c"):
            TaskSequencer(states, "s0", tasks=TASK_NAMES)
    with pytest.raises(
        ValueError, match=r"initial stack: the stack \('a', 'z'\): unknown task 'z'; known: a, b, c"
    ):
        TaskSequencer([State("s0")], "s0", tasks=TASK_NAMES, stack=("a", "z"))


@pytest.mark.parametrize(
    "states, initial, kwargs, message",
    [
        (
            [State("s0", transitions=(Transition(Timeout(1), "nowhere"),))],
            "s0",
            {},
            "transition: unknown state 'nowhere'; known: s0",
        ),
        ([State("s0"), State("s0")], "s0", {}, "two states are named 's0'"),
        ([State("s0")], "start", {}, "initial state: unknown state 'start'; known: s0"),
        ([], "s0", {}, "at least one state"),
        (
            [State("s0", entry=(SetValue("ref", 1.0),))],
            "s0",
            {},
            "sets output 'ref', which has no initial value",
        ),
        (
            [State("s0", entry=(SetValue("ref", [1.0, 2.0]),))],
            "s0",
            {"values": {"ref": [0.0, 0.0, 0.0]}},
            "has size 2, but its initial value has size 3",
        ),
        ([State("s0", entry=(SetValue("ref", [np.nan]),))], "s0", {"values": {"ref": 0.0}}, "NaN or Inf"),
        (
            [State("s0", entry=(SetValue("pose", 1.0),))],
            "s0",
            {"values": {"pose": RigidTransform()}},
            "carries RigidTransform, got float",
        ),
        ([State("s0")], "s0", {"values": {"ref": 0.0}}, "values 'ref' are set by no SetValue"),
        (
            [State("s0", entry=(SetValue("stack", 1.0),))],
            "s0",
            {"values": {"stack": 1.0}},
            "'stack' is reserved",
        ),
        (
            [
                State(
                    "s0",
                    transitions=(
                        Transition(Below("e", 0.1, size=3), "s0"),
                        Transition(Above("e", 1.0), "s0"),
                    ),
                )
            ],
            "s0",
            {},
            "reads it with size 3",
        ),
        (
            [State("s0", entry=(Rm("a"),))],
            "s0",
            {},
            r"entering state 's0': entry action Rm\(task='a'\): task 'a' is not in the stack \(\)",
        ),
        (
            [State("s0", entry=(Pop(),))],
            "s0",
            {"stack": ("a",), "period": 0.0},
            "sequencer 'sequencer': period = 0.0 s: must be finite and > 0",
        ),
        ([State("s0")], "s0", {"tasks": ("a", "a")}, r"tasks \('a', 'a'\) lists 'a' twice"),
    ],
)
def test_construction_errors(states, initial, kwargs, message):
    kwargs = {"tasks": TASK_NAMES, **kwargs}
    with pytest.raises(ValueError, match=message):
        TaskSequencer(states, initial, **kwargs)


def test_definition_errors():
    with pytest.raises(ValueError, match=r"Below\('e'\).threshold = -1.0: must be finite and > 0"):
        Below("e", -1.0)
    with pytest.raises(ValueError, match=r"Above\('e'\).size = 0: must be an integer >= 1"):
        Above("e", 1.0, size=0)
    with pytest.raises(ValueError, match="Timeout.seconds = -1.0 s: must be finite and >= 0"):
        Timeout(-1.0)
    with pytest.raises(TypeError, match="guard must be one of"):
        Transition("e", "s1")
    with pytest.raises(TypeError, match="entry action 'a' is not one of"):
        State("s0", entry=("a",))
    with pytest.raises(ValueError, match="^push: task = '': must be a non-empty string$"):
        Push("")


def test_a_command_that_fails_on_some_path_is_refused_with_the_path():
    states = [
        State("idle", transitions=(Transition(Flag("go"), "grasp"), Transition(Flag("walk"), "walking"))),
        State("walking", entry=(Push("b"),), transitions=(Transition(Timeout(1), "grasp"),)),
        State("grasp", entry=(Rm("b"), Push("c"))),
    ]
    with pytest.raises(
        ValueError,
        match=r"idle → grasp would fail \(pass check_paths=False if that path cannot happen\): "
        r"entry action Rm\(task='b'\): task 'b' is not in the stack \('a',\)",
    ):
        TaskSequencer(states, "idle", tasks=TASK_NAMES, stack=("a",))
    # Without the path check the same error comes at run time, naming state, action and stack.
    rig = _Rig(states, initial="idle", stack=("a",), guards={"go": 1.0, "walk": 0.0}, check_paths=False)
    rig.simulator.Initialize()
    with pytest.raises(
        RuntimeError,
        match=r"entering state 'grasp': entry action Rm\(task='b'\): task 'b' is not in the stack \('a',\) "
        r"\(t = 0.0000 s\)",
    ):
        rig.run(0.005)


def test_guard_inputs_are_checked_when_read():
    states = [
        State("s0", transitions=(Transition(Timeout(0.02), "s1"),)),
        State("s1", transitions=(Transition(Below("err", 0.1, size=2), "s0"),)),
    ]
    rig = _Rig(states)
    assert rig.seq.guard_ports == {"err": 2}
    rig.run(0.015)  # "err" is not read in s0: unconnected is fine there
    with pytest.raises(RuntimeError, match="input port 'err', which is not connected"):
        rig.run(0.035)
    rig = _Rig(states, guards={"err": [np.nan, 0.0]})
    with pytest.raises(RuntimeError, match="input port 'err' holds NaN or Inf"):
        rig.run(0.035)


def test_the_paper_decision_server():
    """Mansard et al. 2009, IV-B: checked every 1 s; once the pattern generator stops, swap the tasks."""
    states = [
        State("walk", entry=(Push("b"),), transitions=(Transition(Below("in_process", 0.5), "manipulate"),)),
        State("manipulate", entry=(Rm("b"), Push("c"))),
    ]
    rig = _Rig(states, initial="walk", stack=("a",), period=1.0, guards={"in_process": 1.0})
    rig.run(2.5)
    assert rig.stack == ("a", "b") and rig.state == "walk"
    rig.set("in_process", 0.0)  # walk over at 2.5 s: noticed at the next check (3 s)
    rig.run(2.99)
    assert rig.state == "walk"
    rig.run(3.001)
    assert rig.state == "manipulate" and rig.stack == ("a", "c")
    np.testing.assert_allclose(rig.qdot, _expected_qdot(("a", "c")))


@pytest.mark.parametrize("transition_time", [0.0, 0.5])
def test_a_state_with_a_transition_time_blends_qdot_through_smooth_stack(transition_time):
    """Entering s1 at t = 0.1 pushes c above a (both want q̇[0]: 1 for a, 3 for c). Through
    ``smooth_stack`` with a transition time T, q̇[0] = (1 - h) 1 + h 3, h eq. 12's raised cosine
    from the check that entered s1 (written here); with T = 0 it jumps by 2 at that tick."""
    states = [
        State("s0", transitions=(Transition(Timeout(0.1), "s1"),)),
        State("s1", entry=(Push("c"), Up("c")), transition_time=transition_time),
    ]
    rig = _Rig(states, stack=("a",), output="smooth_stack")
    rig.simulator.Initialize()
    previous = None
    for k in range(0, 70):
        rig.run((k + 0.5) * PERIOD)  # just after the tick at k·PERIOD
        t = k * PERIOD
        if transition_time:
            h = 0.5 - 0.5 * np.cos(np.pi * min(max((t - 0.1) / transition_time, 0.0), 1.0))
        else:
            h = 1.0 if t >= 0.1 - 1e-9 else 0.0
        np.testing.assert_allclose(rig.qdot, [(1 - h) * 1.0 + h * 3.0, 0.0, 0.0], atol=1e-12)
        if previous is not None:
            change = abs(rig.qdot[0] - previous)
            if transition_time:  # a tick moves h by at most π·period / (2 T) of the gap of 2
                assert change <= np.pi * PERIOD / (2 * transition_time) * 2.0 + 1e-12
            elif abs(t - 0.1) < 1e-9:
                assert change == pytest.approx(2.0)  # without it, the whole jump in one tick
        previous = rig.qdot[0]
    assert rig.stack == ("c", "a")  # the stack reached is what the solver's stack output says
    assert rig.seq.GetOutputPort("stack").Eval(rig.seq_context) == ("c", "a")  # the names, as before
