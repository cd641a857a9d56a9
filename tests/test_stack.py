"""The hierarchy value (drake_sot.stack) against a naive list model of the SoT commands."""

import copy
import math
import re
import subprocess
import sys

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, precondition, rule

from drake_sot.errors import UnknownNameError
from drake_sot.stack import Clear, Down, Pop, Push, Rm, Stack, StackError, StackTransition, Up, task_names

KNOWN = ("taskTwofeet", "taskCom", "taskRH", "taskLH", "taskPosture")
ANY_NAME = st.sampled_from(KNOWN + ("taskXX",))


class _ListModel:
    """The commands written by hand on a Python list, another way than stack.py does them:
    ``up``/``down`` move the task by removing and re-inserting it, ``rm`` uses list.remove.
    Returns an error kind instead of raising, so that the test compares outcomes."""

    def __init__(self, known):
        self.known = list(known)
        self.items: list[str] = []

    def run(self, command, task=None):
        if command != "pop" and command != "clear" and task not in self.known:
            return "unknown"
        if command == "push":
            if task in self.items:
                return "already"
            self.items.append(task)
        elif command == "pop":
            if not self.items:
                return "empty"
            self.items.pop()
        elif command == "clear":
            self.items = []
        else:
            if task not in self.items:
                return "absent"
            if command == "rm":
                self.items.remove(task)
            else:
                i = self.items.index(task)
                if (command == "up" and i == 0) or (command == "down" and i == len(self.items) - 1):
                    return "end"  # nothing would change: refused
                self.items.pop(i)
                target = max(i - 1, 0) if command == "up" else min(i + 1, len(self.items))
                self.items.insert(target, task)
        return None


def _error_kind(error: StackError, task) -> str:
    """Which of the model's error kinds the message of ``error`` describes."""
    text = str(error)
    if text.startswith(f"unknown task {task!r}") and text.endswith(f"; known: {', '.join(sorted(KNOWN))}"):
        return "unknown"
    if text.startswith(f"task {task!r} is already in the stack "):
        return "already"
    if text == "pop from an empty stack":
        return "empty"
    if text.startswith(f"task {task!r} is not in the stack "):
        return "absent"
    if re.match(rf"(up {task}: already at the top|down {task}: already at the bottom) of the stack \(", text):
        return "end"
    raise AssertionError(f"unexpected message {text!r}")


class StackAgainstListModel(RuleBasedStateMachine):
    """Random command sequences: Stack and the list model agree on every outcome, and a
    command never changes the value it was applied to."""

    def __init__(self):
        super().__init__()
        self.stack = Stack(KNOWN)
        self.model = _ListModel(KNOWN)

    def _apply(self, command, method, *args):
        before = self.stack
        before_active = tuple(before.active)
        expected = self.model.run(command, *args)
        try:
            after = getattr(before, method)(*args)
        except StackError as error:
            assert expected == _error_kind(error, args[0] if args else None)
            after = before
        else:
            assert expected is None, f"{command} {args}: the model says {expected}"
        assert before.active == before_active  # value semantics: the old value is untouched
        self.stack = after

    @rule(task=ANY_NAME)
    def push(self, task):
        self._apply("push", "push", task)

    @rule()
    def pop(self):
        self._apply("pop", "pop")

    @rule(task=ANY_NAME)
    def rm(self, task):
        self._apply("rm", "rm", task)

    @rule(task=ANY_NAME)
    def up(self, task):
        self._apply("up", "up", task)

    @rule(task=ANY_NAME)
    def down(self, task):
        self._apply("down", "down", task)

    @precondition(lambda self: len(self.model.items) > 2)
    @rule()
    def clear(self):
        self._apply("clear", "clear")

    @invariant()
    def same_stack_and_priorities(self):
        assert self.stack.active == tuple(self.model.items)
        assert self.stack.tasks == KNOWN
        for level, task in enumerate(self.model.items):
            assert self.stack.priority(task) == level
        assert list(self.stack) == self.model.items and len(self.stack) == len(self.model.items)


TestStackAgainstListModel = StackAgainstListModel.TestCase
TestStackAgainstListModel.settings = settings(max_examples=200, stateful_step_count=30, deadline=None)


@given(st.lists(st.tuples(st.sampled_from(["push", "pop", "rm", "up", "down", "clear"]), ANY_NAME)))
def test_command_values_do_what_the_methods_do(commands):
    make = {
        "push": Push,
        "pop": lambda _: Pop(),
        "rm": Rm,
        "up": Up,
        "down": Down,
        "clear": lambda _: Clear(),
    }
    stack = Stack(KNOWN)
    for command, task in commands:
        try:
            by_method = getattr(stack, command)(*(() if command in ("pop", "clear") else (task,)))
        except StackError as error:
            with pytest.raises(StackError, match="^" + re.escape(str(error)) + "$"):
                stack.apply(make[command](task))
            continue
        assert stack.apply(make[command](task)) == by_method
        stack = by_method


def test_the_papers_example_stack():
    """The stack of Mansard et al. 2009, IV: feet, CoM, then a hand raised above the posture."""
    s = Stack(KNOWN).push("taskTwofeet").push("taskCom").push("taskPosture").push("taskRH")
    s = s.up("taskRH")
    assert s.active == ("taskTwofeet", "taskCom", "taskRH", "taskPosture")
    assert s.priority("taskTwofeet") == 0 and s.priority("taskPosture") == 3
    with pytest.raises(StackError, match=r"^up taskTwofeet: already at the top of the stack \(taskTwofeet, "):
        s.up("taskTwofeet")  # nothing would change: refused, not ignored
    with pytest.raises(
        StackError, match=r"^down taskPosture: already at the bottom of the stack \(.*taskPosture\)$"
    ):
        s.down("taskPosture")
    assert s.rm("taskCom").active == ("taskTwofeet", "taskRH", "taskPosture")
    assert s.pop().active == ("taskTwofeet", "taskCom", "taskRH")
    assert s.clear().active == () and s.clear().tasks == KNOWN


def test_errors_name_the_task_and_list_the_known_ones_or_the_stack():
    s = Stack(KNOWN, ("taskCom", "taskRH"))
    known = "known: taskCom, taskLH, taskPosture, taskRH, taskTwofeet"  # KNOWN sorted
    for command in ("push", "rm", "up", "down", "priority"):
        with pytest.raises(StackError, match=f"^unknown task 'taskXX'; {known}$"):
            getattr(s, command)("taskXX")
    with pytest.raises(
        UnknownNameError, match=r"^unknown task 'taskPostur' \(did you mean 'taskPosture'\?\); "
    ) as caught:
        s.push("taskPostur")
    assert (caught.value.kind, caught.value.name, caught.value.known) == (
        "task",
        "taskPostur",
        tuple(sorted(KNOWN)),
    )
    with pytest.raises(StackError, match=r"^task 'taskCom' is already in the stack \('taskCom', 'taskRH'\)$"):
        s.push("taskCom")
    for command in ("rm", "up", "down", "priority"):
        with pytest.raises(StackError, match=r"^task 'taskLH' is not in the stack \('taskCom', 'taskRH'\)$"):
            getattr(s, command)("taskLH")
    with pytest.raises(StackError, match="pop from an empty stack"):
        s.clear().pop()
    with pytest.raises(TypeError, match="'push taskCom' is not a stack command"):
        s.apply("push taskCom")
    assert issubclass(StackError, ValueError)
    with pytest.raises(KeyError, match="^unknown task 'taskXX'"):  # an unknown name is a KeyError too
        s.push("taskXX")


@pytest.mark.parametrize(
    "tasks, active, message",
    [
        ("abc", (), "tasks must be a sequence of task names, got the string 'abc'"),
        (("a", "a", "b"), (), r"tasks \('a', 'a', 'b'\) lists 'a' twice"),
        (("a", ""), (), "holds '': a task name is a non-empty string"),
        (("a", 3), (), "holds 3: a task name"),
        (5, (), "tasks must be a sequence of task names, got 5"),
        (("a", "b"), "ab", "the stack must be a sequence of task names, got 'ab'"),
        (("a", "b"), ("a", None), r"the stack must be a sequence of task names, got \('a', None\)"),
        (
            ("a", "b", "c"),
            ("a", "zz", "b", "a"),
            r"^the stack \('a', 'zz', 'b', 'a'\): unknown task 'zz'; known: a, b, c$",
        ),
        (("a", "b", "c"), ("a", "b", "a"), r"^the stack \('a', 'b', 'a'\) has task 'a' listed twice$"),
        (
            ("a", "b", "c"),
            ("a", "b", "y", "z"),
            r"^the stack \('a', 'b', 'y', 'z'\): unknown task 'y'; known: a, b, c$",  # the first one
        ),
    ],
)
def test_invalid_hierarchies_are_refused(tasks, active, message):
    with pytest.raises(StackError, match=message):
        Stack(tasks, active)


def test_with_active_validates_like_the_constructor():
    s = Stack(("a", "b", "c"), ("a",))
    assert s.with_active(["c", "b"]) == Stack(("a", "b", "c"), ("c", "b"))
    with pytest.raises(
        StackError,
        match=r"^the stack \('c', 'd', 'e', 'a', 'a'\): unknown task 'd'; known: a, b, c$",
    ):
        s.with_active(("c", "d", "e", "a", "a"))
    assert task_names(["x", "y"], what="names") == ("x", "y")


def test_a_stack_is_a_value():
    a = Stack(["a", "b"], ["b"])
    b = Stack(("a", "b"), ("b",))
    assert a == b and hash(a) == hash(b) and a.tasks == ("a", "b")
    assert a != Stack(("a", "b", "c"), ("b",))  # same active, other universe
    assert "b" in a and "a" not in a and "zz" not in a
    assert copy.deepcopy(a) is a and copy.copy(a) is a
    with pytest.raises(AttributeError):
        a.active = ("a",)
    for command_type in (Push, Rm, Up, Down):
        with pytest.raises(StackError, match=f"^{command_type.verb}: task = '': must be a non-empty string$"):
            command_type("")


def _h(t, start, duration):
    """Liu, Lober, Padois 2016, eq. 12, written here: 0.5 - 0.5 cos(pi (t - t1) / (t2 - t1)) on [t1, t2]."""
    u = min(max((t - start) / duration, 0.0), 1.0)
    return 0.5 - 0.5 * math.cos(math.pi * u)


def test_a_transition_blends_the_stack_before_and_after_with_eq_12():
    before = Stack(KNOWN, ("taskTwofeet", "taskPosture"))
    after = before.push("taskRH").transition_from(before, start=2.0, duration=0.5)
    assert after.active == ("taskTwofeet", "taskPosture", "taskRH")
    assert after.transition == StackTransition(before, 2.0, 0.5)
    assert after.blend(1.0) == after.blend(2.0) == ((before.active, 1.0),)  # nothing has moved yet
    for t in (2.1, 2.25, 2.4):
        (reached, h), (left, rest) = after.blend(t)
        assert (reached, left) == (after.active, before.active)
        assert h == pytest.approx(_h(t, 2.0, 0.5), abs=1e-15) and rest == pytest.approx(1.0 - h, abs=1e-15)
    assert after.blend(2.25)[0][1] == pytest.approx(0.5)
    assert after.blend(2.5) == after.blend(9.0) == ((after.active, 1.0),)
    assert after.settled(2.5) == Stack(KNOWN, after.active) and after.settled(2.4) is after
    assert before.blend(0.0) == ((before.active, 1.0),)  # no transition: the stack alone


def test_commands_given_at_one_instant_compose_into_one_transition():
    """push then up at the same time: one change from the stack before both (2 stacks to solve)."""
    s0 = Stack(KNOWN, ("taskCom", "taskPosture"))
    s1 = s0.push("taskRH").transition_from(s0, start=3.0, duration=0.5)
    s2 = s1.up("taskRH").transition_from(s1, start=3.0, duration=0.5)
    assert s2.active == ("taskCom", "taskRH", "taskPosture")
    assert s2.transition.origin == s0
    assert [active for active, _ in s2.blend(3.2)] == [s2.active, s0.active]


def test_overlapping_transitions_nest_and_finished_ones_are_dropped():
    s0 = Stack(KNOWN, ("taskCom",))
    s1 = s0.push("taskRH").transition_from(s0, start=0.0, duration=1.0)
    s2 = s1.push("taskLH").transition_from(s1, start=0.5, duration=1.0)
    assert s2.transition.origin is s1  # s1 had progressed: it is kept whole
    h1, h2 = _h(0.8, 0.0, 1.0), _h(0.8, 0.5, 1.0)
    weights = dict(s2.blend(0.8))
    assert weights == pytest.approx({s2.active: h2, s1.active: (1 - h2) * h1, s0.active: (1 - h2) * (1 - h1)})
    assert dict(s2.blend(1.2)) == pytest.approx(
        {s2.active: _h(1.2, 0.5, 1.0), s1.active: 1 - _h(1.2, 0.5, 1.0)}
    )
    assert s2.settled(1.2).transition.origin == Stack(KNOWN, s1.active)  # s1's change is over
    s3 = s2.rm("taskCom").transition_from(s2, start=1.2, duration=0.3)
    assert s3.transition.origin.transition.origin == Stack(KNOWN, s1.active)  # pruned when it started


def test_an_instant_command_or_no_change_has_no_transition():
    s0 = Stack(KNOWN, ("taskCom", "taskRH"))
    moving = s0.rm("taskRH").transition_from(s0, start=1.0, duration=0.5)
    assert moving.push("taskLH").transition_from(moving, start=1.1, duration=0.0).transition is None
    assert s0.rm("taskRH").push("taskRH").transition_from(s0, start=1.0, duration=0.5) == s0
    back = moving.push("taskRH").transition_from(moving, start=1.0, duration=0.5)  # rm then push at once
    assert back == s0 and back.transition is None


@given(
    st.lists(
        st.tuples(
            st.sampled_from(["push", "pop", "rm", "up", "down", "clear"]),
            ANY_NAME,
            st.floats(0.0, 0.4),  # time since the previous command [s]
            st.sampled_from([0.0, 0.1, 0.5, 1.0]),  # transition [s]
        ),
        max_size=12,
    ),
    st.floats(0.0, 2.0),
)
def test_blend_weights_are_a_partition_of_one_that_ends_on_the_stack(commands, later):
    stack, t = Stack(KNOWN), 0.0
    for command, task, dt, duration in commands:
        t += dt
        try:
            after = getattr(stack, command)(*(() if command in ("pop", "clear") else (task,)))
        except StackError:
            continue
        stack = after.transition_from(stack, start=t, duration=duration)
        for when in (t, t + later):
            blend = stack.blend(when)
            assert all(w > 0.0 for _, w in blend) and sum(w for _, w in blend) == pytest.approx(1.0)
            assert len({active for active, _ in blend}) == len(blend)
    assert stack.blend(t + 1.0) == ((stack.active, 1.0),)  # every change lasts at most 1 s
    assert stack.settled(t + 1.0).transition is None


@pytest.mark.parametrize(
    "change, error, message",
    [
        (dict(duration=float("nan")), ValueError, "transition = nan s: must be finite and >= 0"),
        (dict(duration=-0.5), ValueError, "transition = -0.5 s: must be finite and >= 0"),
        (dict(start=float("inf")), ValueError, "start = inf: must be a finite number"),
        (dict(before=Stack(("x",))), StackError, "cannot reach a stack of tasks a, b from one of tasks x"),
    ],
)
def test_bad_transitions_are_refused_naming_the_value(change, error, message):
    s = Stack(("a", "b"), ("a",))
    arguments = dict(before=s, start=0.0, duration=0.5) | change
    with pytest.raises(error, match=message):
        s.push("b").transition_from(arguments.pop("before"), **arguments)
    with pytest.raises(StackError, match="StackTransition.duration = 0.0 s: must be finite and > 0"):
        StackTransition(s, 0.0, 0.0)
    with pytest.raises(StackError, match=r"^StackTransition.duration = 1e\+308 s: must be in \[0, 60\] s$"):
        StackTransition(s, 0.0, 1e308)  # a change that would never end
    with pytest.raises(StackError, match=r"^StackTransition.duration = 60.5 s: must be in \[0, 60\] s$"):
        StackTransition(s, 0.0, 60.5)
    assert StackTransition(s, 0.0, 60.0).duration == 60.0
    with pytest.raises(StackError, match="the transition comes from a stack of other known tasks"):
        Stack(("a", "b", "c"), ("a",), StackTransition(s, 0.0, 1.0))


def test_stack_and_sequencing_import_no_drake():
    code = "import sys, drake_sot.stack, drake_sot.sequencing; sys.exit('pydrake' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0


def test_a_stack_over_other_known_tasks_keeps_its_active_tasks_and_its_transition():
    few = Stack(("a", "b"))
    before = few.with_active(("a",))
    after = few.with_active(("a", "b")).transition_from(before, start=1.0, duration=0.5)
    over = after.over(("z", "a", "b", "c"))
    assert over.tasks == ("z", "a", "b", "c") and over.active == ("a", "b")
    assert over.transition.origin.tasks == over.tasks and over.transition.origin.active == ("a",)
    assert (over.transition.start, over.transition.duration) == (1.0, 0.5)
    for t in (0.9, 1.1, 1.25, 1.6):
        assert over.blend(t) == after.blend(t)
    assert after.over(("a", "b")) is after  # its own tasks: itself
    with pytest.raises(StackError, match=r"unknown task 'b'"):
        after.over(("a", "c"))
