"""Task (concatenation, gain, feed-forward) and StackOfTasks (stack commands, control law)."""

import os

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import DiagramBuilder, LeafSystem

from drake_sot.gains import AdaptiveGain
from drake_sot.hierarchy import solve_strict
from drake_sot.signals import FeatureSignal, TaskSignal
from drake_sot.stack import Stack, StackError
from drake_sot.systems.features import FeatureGeneric
from drake_sot.systems.sot import StackOfTasks
from drake_sot.systems.task import Task

NV = 5


def _feature_signal(rng, m, ff=None):
    return FeatureSignal(rng.normal(size=m), rng.normal(size=(m, NV)), np.zeros(m) if ff is None else ff)


def test_task_concatenates_features_and_applies_gain():
    rng = np.random.default_rng(0)
    f1, f2 = FeatureGeneric(2, name="f1"), FeatureGeneric(3, name="f2")
    task = Task("t", gain=3.0)
    task.add(f1)
    task.add(f2)
    assert task.dimension == 5
    context = task.CreateDefaultContext()
    s1, s2 = _feature_signal(rng, 2, ff=np.array([1.0, 2.0])), _feature_signal(rng, 3)
    task.GetInputPort("f1").FixValue(context, s1)
    task.GetInputPort("f2").FixValue(context, s2)
    out = task.GetOutputPort("task").Eval(context)
    e = np.concatenate((s1.error, s2.error))
    np.testing.assert_array_equal(out.error, e)
    np.testing.assert_array_equal(out.jacobian, np.vstack((s1.jacobian, s2.jacobian)))
    np.testing.assert_allclose(out.edot_des, -3.0 * e + np.concatenate(([1.0, 2.0], np.zeros(3))))
    task.set_gain(context, AdaptiveGain(a=2.0, b=0.5, c=1.0))
    lam = 2.0 * np.exp(-0.5 * np.linalg.norm(e)) + 1.0
    np.testing.assert_allclose(task.GetOutputPort("task").Eval(context).edot_des[2:], -lam * e[2:])


def test_task_selection_keeps_rows_of_a_shared_feature():
    """Two tasks reading one 6D feature with different selections get exactly its rows,
    with the gain applied to the selected error only."""
    rng = np.random.default_rng(1)
    feature = FeatureGeneric(6, name="f")
    position, orientation = Task("position", gain=2.0), Task("orientation", gain=5.0)
    position.add(feature, selection="111000")
    orientation.add(feature, selection=[False, False, False, True, False, True])
    assert (position.dimension, orientation.dimension) == (3, 2)
    signal = _feature_signal(rng, 6, ff=np.arange(6.0))
    for task, rows, gain in ((position, [0, 1, 2], 2.0), (orientation, [3, 5], 5.0)):
        context = task.CreateDefaultContext()
        task.GetInputPort("f").FixValue(context, signal)
        out = task.GetOutputPort("task").Eval(context)
        np.testing.assert_array_equal(out.error, signal.error[rows])
        np.testing.assert_array_equal(out.jacobian, signal.jacobian[rows])
        np.testing.assert_allclose(out.edot_des, -gain * signal.error[rows] + np.arange(6.0)[rows])
    with pytest.raises(ValueError, match=r"selection of 'f' in task 't' '1110' must be 6 characters"):
        Task("t").add(feature, selection="1110")
    with pytest.raises(ValueError, match="selects no component"):
        Task("t").add(feature, selection="000000")


def test_adaptive_gain_from_sot_limits():
    g = AdaptiveGain.from_limits(at_zero=4.0, at_infinity=1.0, slope_at_zero=6.0)
    assert g(0.0) == pytest.approx(4.0)
    assert g(1e9) == pytest.approx(1.0)
    h = 1e-7
    assert (g(h) - g(0.0)) / h == pytest.approx(-6.0, rel=1e-5)
    with pytest.raises(ValueError, match="task 'bad': gain = -1.0 1/s: must be finite and > 0"):
        Task("bad", gain=-1.0)
    with pytest.raises(ValueError, match="task 'bad': gain = nan"):
        Task("bad", gain=float("nan"))
    with pytest.raises(ValueError, match="at_zero = 1.0: must exceed at_infinity = 2.0"):
        AdaptiveGain.from_limits(1.0, 2.0, 1.0)
    for args, name in (
        ((np.nan, 1.0, 1.0), "at_zero"),
        ((4.0, np.nan, 1.0), "at_infinity"),
        ((4.0, 1.0, np.nan), "slope_at_zero"),
        ((4.0, 1.0, -1.0), "slope_at_zero"),
    ):
        with pytest.raises(ValueError, match=f"{name} = "):
            AdaptiveGain.from_limits(*args)
    with pytest.raises(ValueError, match="AdaptiveGain.b = nan"):
        AdaptiveGain(1.0, float("nan"), 1.0)


def _sot_with_fixed_tasks(rng, dims, stack=()):
    sot = StackOfTasks(NV, dims, stack=stack, period=0.005)
    context = sot.CreateDefaultContext()
    signals = {}
    for name, m in dims.items():
        J = rng.normal(size=(m, NV))
        e = rng.normal(size=m)
        signals[name] = TaskSignal(name, e, J, -e)
        sot.GetInputPort(name).FixValue(context, signals[name])
    return sot, context, signals


def _tick(sot, context):
    values = sot.EvalUniquePeriodicDiscreteUpdate(context)
    context.SetDiscreteState(values)
    return sot.GetOutputPort("qdot").Eval(context), sot.GetOutputPort("errors").Eval(context)


def test_stack_commands_follow_the_paper():
    rng = np.random.default_rng(1)
    sot, context, _ = _sot_with_fixed_tasks(rng, {"a": 1, "b": 1, "c": 1, "d": 1})
    for name in "abc":
        sot.push(context, name)
    assert sot.list(context) == ("a", "b", "c")
    sot.up(context, "c")
    assert sot.list(context) == ("a", "c", "b")
    sot.down(context, "a")
    assert sot.list(context) == ("c", "a", "b")
    with pytest.raises(StackError, match=r"^up c: already at the top of the stack \(c, a, b\)$"):
        sot.up(context, "c")  # nothing would change: refused, as from a script or a client
    with pytest.raises(StackError, match=r"^down b: already at the bottom of the stack \(c, a, b\)$"):
        sot.down(context, "b")
    assert sot.list(context) == ("c", "a", "b")
    assert sot.pop(context) == "b"
    sot.rm(context, "c")
    assert sot.list(context) == ("a",)
    sot.clear(context)
    assert sot.list(context) == ()
    with pytest.raises(StackError, match="pop from an empty stack"):
        sot.pop(context)


def test_stack_commands_refuse_bad_names():
    rng = np.random.default_rng(2)
    sot, context, _ = _sot_with_fixed_tasks(rng, {"taskCom": 1, "taskRH": 1})
    with pytest.raises(KeyError, match="unknown task 'taskXX'; known: taskCom, taskRH"):
        sot.push(context, "taskXX")
    sot.push(context, "taskCom")
    with pytest.raises(ValueError, match="already in the stack"):
        sot.push(context, "taskCom")
    with pytest.raises(ValueError, match="'taskRH' is not in the stack"):
        sot.rm(context, "taskRH")
    with pytest.raises(KeyError, match=r"'sot': the stack \('b',\): unknown task 'b'; known: a$"):
        StackOfTasks(NV, {"a": 1}, stack=["b"])


def test_control_law_is_the_strict_hierarchy_of_the_stack():
    rng = np.random.default_rng(3)
    dims = {"a": 2, "b": 2, "c": 3}
    sot, context, signals = _sot_with_fixed_tasks(rng, dims, stack=("b", "a"))
    qdot, errors = _tick(sot, context)
    expected = solve_strict([(signals[n].jacobian, signals[n].edot_des) for n in ("b", "a")]).qdot
    np.testing.assert_allclose(qdot, expected, atol=1e-12)
    slices = sot.error_slices()
    np.testing.assert_array_equal(errors[slices["a"]], signals["a"].error)
    assert np.all(np.isnan(errors[slices["c"]]))  # not in the stack
    # Order matters: the higher-priority task is achieved exactly.
    np.testing.assert_allclose(signals["b"].jacobian @ qdot, signals["b"].edot_des, atol=1e-10)
    sot.clear(context)
    qdot, errors = _tick(sot, context)
    np.testing.assert_array_equal(qdot, 0.0)


def _raised_cosine(t, start, duration):
    """Liu, Lober, Padois 2016, eq. 12, written here."""
    u = min(max((t - start) / duration, 0.0), 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * u)


@pytest.mark.parametrize(
    "command, task, before, after",
    [
        ("push", "c", ("a", "b"), ("a", "b", "c")),
        ("rm", "a", ("a", "b", "c"), ("b", "c")),
        ("up", "c", ("a", "b", "c"), ("a", "c", "b")),
        ("down", "a", ("a", "b", "c"), ("b", "a", "c")),
    ],
)
def test_a_command_with_a_transition_moves_qdot_between_the_two_strict_solutions(
    command, task, before, after
):
    """q̇ = (1 - h) q̇*(before) + h q̇*(after), h the raised cosine of eq. 12 from the command's time:
    the solution before the command at first, the one after it at the end, continuous between.
    The tasks conflict (more rows than the 5 joints), so every change moves q̇."""
    rng = np.random.default_rng(11)
    dims = {"a": 3, "b": 3, "c": 2} if command != "push" else {"a": 2, "b": 2, "c": 2}
    sot, context, signals = _sot_with_fixed_tasks(rng, dims, stack=before)

    def strict(stack):
        return solve_strict([(signals[n].jacobian, signals[n].edot_des) for n in stack]).qdot

    start, duration = 1.0, 0.5
    context.SetTime(start)
    getattr(sot, command)(context, task, transition=duration)
    assert sot.list(context) == after  # the stack reached, at once; q̇ follows over the transition
    previous = None
    for t in np.arange(start, start + duration + 0.1, sot.period):
        context.SetTime(t)
        qdot, errors = _tick(sot, context)
        h = _raised_cosine(t, start, duration)
        np.testing.assert_allclose(qdot, (1 - h) * strict(before) + h * strict(after), atol=1e-12)
        if previous is not None:  # a tick moves h by at most pi * period / (2 T)
            bound = np.pi * sot.period / (2 * duration) * np.linalg.norm(strict(after) - strict(before))
            assert np.linalg.norm(qdot - previous) <= bound * (1 + 1e-9) + 1e-14
        previous = qdot
        for name in os.path.commonprefix([before, after]):  # above the change in both: undisturbed
            np.testing.assert_allclose(signals[name].jacobian @ qdot, signals[name].edot_des, atol=1e-10)
        blended = (set(before) if h < 1 else set()) | (set(after) if h > 0 else set())
        for name in dims:  # the error of every task of the blend, NaN for the others
            assert np.isnan(errors[sot.error_slices()[name]]).all() == (name not in blended)
    np.testing.assert_allclose(qdot, strict(after), atol=1e-12)
    assert np.linalg.norm(strict(after) - strict(before)) > 0.1  # without the transition, a visible jump


def test_transition_argument_is_checked_and_instant_by_default():
    rng = np.random.default_rng(12)
    sot, context, signals = _sot_with_fixed_tasks(rng, {"a": 2, "b": 2}, stack=("a",))
    for bad in (float("nan"), -0.1, float("inf")):
        with pytest.raises(StackError, match=rf"^push: transition = {bad} s: must be in \[0, 60\] s$"):
            sot.push(context, "b", transition=bad)
    assert sot.list(context) == ("a",)  # a refused command changes nothing
    context.SetTime(2.0)
    sot.push(context, "b")
    qdot, _ = _tick(sot, context)
    expected = solve_strict([(signals[n].jacobian, signals[n].edot_des) for n in ("a", "b")]).qdot
    np.testing.assert_allclose(qdot, expected, atol=1e-12)


def test_bad_task_signals_name_the_task():
    rng = np.random.default_rng(4)
    sot, context, _ = _sot_with_fixed_tasks(rng, {"a": 2, "b": 1}, stack=("a", "b"))
    bad = TaskSignal("b", np.zeros(1), np.full((1, NV), np.nan), np.zeros(1))
    sot.GetInputPort("b").FixValue(context, bad)
    with pytest.raises(RuntimeError, match="task 'b': NaN or Inf"):
        _tick(sot, context)
    sot.GetInputPort("b").FixValue(context, TaskSignal("b", np.zeros(2), np.zeros((2, NV)), np.zeros(2)))
    with pytest.raises(
        RuntimeError, match=r"task 'b': error \(2,\), Jacobian \(2, 5\), ė\* \(edot_des\) \(2,\)"
    ):
        _tick(sot, context)


class _CountingTask(LeafSystem):
    """A task source that counts how often it is evaluated."""

    def __init__(self, name):
        super().__init__()
        self.calls = 0
        self._name = name
        self.DeclareAbstractOutputPort(
            "task",
            lambda: AbstractValue.Make(TaskSignal(name, np.zeros(1), np.zeros((1, NV)), np.zeros(1))),
            self._calc,
        )

    def _calc(self, context, value):
        self.calls += 1
        value.set_value(TaskSignal(self._name, np.ones(1), np.ones((1, NV)), -np.ones(1)))


def test_tasks_outside_the_stack_are_not_evaluated():
    from pydrake.systems.analysis import Simulator

    builder = DiagramBuilder()
    sot = builder.AddSystem(StackOfTasks(NV, {"used": 1, "idle": 1}, stack=("used",), period=0.01))
    sources = {n: builder.AddSystem(_CountingTask(n)) for n in ("used", "idle")}
    for n, src in sources.items():
        builder.Connect(src.get_output_port(), sot.GetInputPort(n))
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(0.1)
    assert sources["used"].calls >= 10
    assert sources["idle"].calls == 0


def test_stack_input_drives_the_stack_and_is_validated():
    rng = np.random.default_rng(5)
    dims = {"a": 1, "b": 2, "c": 1}
    sot, context, signals = _sot_with_fixed_tasks(rng, dims, stack=("a",))
    assert not sot.is_driven(context)
    assert sot.GetOutputPort("stack").Eval(context) == ("a",)
    sot.GetInputPort("stack").FixValue(context, ("c", "b"))
    assert sot.is_driven(context)
    # The output follows the input (the cache knows it depends on it), and so does the tick.
    assert sot.GetOutputPort("stack").Eval(context) == ("c", "b")
    assert sot.list(context) == ("c", "b")
    qdot, errors = _tick(sot, context)
    expected = solve_strict([(signals[n].jacobian, signals[n].edot_des) for n in ("c", "b")]).qdot
    np.testing.assert_allclose(qdot, expected, atol=1e-12)
    assert np.isnan(errors[sot.error_slices()["a"]]).all()
    sot.GetInputPort("stack").FixValue(context, ("b",))
    assert sot.GetOutputPort("stack").Eval(context) == ("b",)
    # Commands are refused, not silently overridden.
    with pytest.raises(ValueError, match="'sot': cannot push a: the stack comes from input port 'stack'"):
        sot.push(context, "a")
    with pytest.raises(ValueError, match="cannot clear"):
        sot.clear(context)
    # Bad stacks on the input name the culprits and list the known tasks.
    sot.GetInputPort("stack").FixValue(context, ("a", "zz", "b", "a"))
    with pytest.raises(
        RuntimeError,
        match=r"'sot': input port 'stack': the stack \('a', 'zz', 'b', 'a'\): unknown task 'zz'; "
        r"known: a, b, c",
    ):
        _tick(sot, context)
    with pytest.raises(RuntimeError, match="unknown task"):
        sot.GetOutputPort("stack").Eval(context)
    sot.GetInputPort("stack").FixValue(context, "ab")
    with pytest.raises(RuntimeError, match="input port 'stack': the stack must be a sequence of task names"):
        _tick(sot, context)


def test_stack_input_checked_once_per_change_serves_each_context_its_own_stack():
    # The stack input is checked when its tuple changes, not every tick: two contexts driven
    # with different stacks, ticked alternately, each get the solution of their own stack.
    rng = np.random.default_rng(6)
    dims = {"a": 1, "b": 2, "c": 1}
    sot, first, signals = _sot_with_fixed_tasks(rng, dims)
    second = sot.CreateDefaultContext()
    for name, signal in signals.items():
        sot.GetInputPort(name).FixValue(second, signal)
    sot.GetInputPort("stack").FixValue(first, ("a", "b"))
    sot.GetInputPort("stack").FixValue(second, ("c",))
    for _ in range(2):
        for context, names in ((first, ("a", "b")), (second, ("c",))):
            qdot, _ = _tick(sot, context)
            expected = solve_strict([(signals[n].jacobian, signals[n].edot_des) for n in names]).qdot
            np.testing.assert_allclose(qdot, expected, atol=1e-12)
            assert sot.list(context) == names
    # A list (mutable) is checked every time; a bad one after a good one is still refused.
    sot.GetInputPort("stack").FixValue(first, ["b", "a"])
    assert sot.list(first) == ("b", "a")
    sot.GetInputPort("stack").FixValue(first, ("a", "a"))
    with pytest.raises(RuntimeError, match="task 'a' listed twice"):
        _tick(sot, first)


def test_stack_is_not_a_task_name():
    with pytest.raises(ValueError, match="'stack' cannot be a task name"):
        StackOfTasks(NV, {"a": 1, "stack": 1})


def test_task_gain_input():
    rng = np.random.default_rng(6)
    feature = FeatureGeneric(2, name="f")
    task = Task("t", gain=3.0)
    task.add(feature)
    context = task.CreateDefaultContext()
    signal = _feature_signal(rng, 2)
    task.GetInputPort("f").FixValue(context, signal)
    assert task.gain(context) == 3.0
    np.testing.assert_allclose(task.GetOutputPort("task").Eval(context).edot_des, -3.0 * signal.error)
    task.GetInputPort("gain").FixValue(context, [7.0])
    assert task.gain(context) == 7.0
    np.testing.assert_allclose(task.GetOutputPort("task").Eval(context).edot_des, -7.0 * signal.error)
    with pytest.raises(ValueError, match="'t': cannot set_gain: the gain comes from input port 'gain'"):
        task.set_gain(context, 2.0)
    for bad in (0.0, -1.0, np.nan, np.inf):
        task.GetInputPort("gain").FixValue(context, [bad])
        with pytest.raises(
            RuntimeError, match="task 't': gain .* on input port 'gain' must be finite and > 0"
        ):
            task.GetOutputPort("task").Eval(context)
    with pytest.raises(ValueError, match="cannot be named 'gain'"):
        task.add(FeatureGeneric(1, name="gain"))


@pytest.mark.parametrize("size", [1, 2, 5])
def test_edot_of_another_size_than_the_task_is_refused_naming_it(size):
    """A size-1 ė* is not broadcast over the task's three rows; a size-5 one does not reach numpy."""
    rng = np.random.default_rng(7)
    sot, context, _ = _sot_with_fixed_tasks(rng, {"a": 3, "b": 1}, stack=("b", "a"))
    _tick(sot, context)  # the right sizes pass
    sot.GetInputPort("a").FixValue(context, TaskSignal("a", np.zeros(3), np.zeros((3, NV)), np.ones(size)))
    with pytest.raises(
        RuntimeError,
        match=rf"task 'a': error \(3,\), Jacobian \(3, 5\), ė\* \(edot_des\) \({size},\); "
        r"expected \(3,\), \(3, 5\), \(3,\)",
    ):
        _tick(sot, context)


@pytest.mark.parametrize("where", ["jacobian", "edot_des"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_task_signal_is_refused_naming_the_task(where, bad):
    rng = np.random.default_rng(9)
    sot, context, signals = _sot_with_fixed_tasks(rng, {"a": 3, "b": 2}, stack=("b", "a"))
    J, edot = signals["a"].jacobian.copy(), signals["a"].edot_des.copy()
    (J if where == "jacobian" else edot).flat[1] = bad
    sot.GetInputPort("a").FixValue(context, TaskSignal("a", signals["a"].error, J, edot))
    with pytest.raises(RuntimeError, match="task 'a': NaN or Inf in its signal"):
        _tick(sot, context)


def test_huge_finite_task_signals_are_not_mistaken_for_non_finite_ones():
    """The finiteness test sums the entries first: a sum that overflows must not raise."""
    sot, context, _ = _sot_with_fixed_tasks(np.random.default_rng(10), {"a": 2}, stack=("a",))
    J = np.full((2, NV), 1e308)
    J[1] = 0.0
    J[1, 0] = 1.0
    sot.GetInputPort("a").FixValue(context, TaskSignal("a", np.zeros(2), J, np.array([1e308, 1.0])))
    qdot, _ = _tick(sot, context)
    assert np.isfinite(qdot).all()


def test_a_signal_in_another_tasks_port_is_refused():
    rng = np.random.default_rng(8)
    sot, context, signals = _sot_with_fixed_tasks(rng, {"a": 2, "b": 2}, stack=("a",))
    sot.GetInputPort("a").FixValue(context, signals["b"])  # same size: only the name tells
    with pytest.raises(RuntimeError, match="'sot': input port 'a' carries the signal of task 'b'"):
        _tick(sot, context)


@pytest.mark.parametrize(
    "change, message",
    [
        ({"period": np.nan}, "StackOfTasks 'sot': period = nan s: must be finite and > 0"),
        ({"period": np.inf}, "period = inf s: must be finite and > 0"),
        ({"period": 0.0}, "period = 0.0 s: must be finite and > 0"),
        ({"rank_threshold": np.nan}, "rank_threshold = nan: must be finite and >= 0"),
        ({"rank_threshold": -1e-6}, "rank_threshold = -1e-06: must be finite and >= 0"),
        ({"damping": np.nan}, "damping = nan: must be finite and >= 0"),
        ({"damping": -0.1}, "damping = -0.1: must be finite and >= 0"),
        ({"nv": 0}, "nv = 0: must be an integer >= 1"),
        ({"nv": 2.5}, "nv = 2.5: must be an integer >= 1"),
        ({"tasks": {"a": 0}}, "dimension of task 'a' = 0: must be an integer >= 1"),
        ({"tasks": {}}, "needs at least one task"),
        ({"tasks": {"a": 1, "": 1}}, "holds '': a task name is a non-empty string"),
        ({"stack": ("a", "a")}, r"the stack \('a', 'a'\) has task 'a' listed twice"),
    ],
)
def test_constructor_arguments_are_checked(change, message):
    kwargs = {"nv": NV, "tasks": {"a": 1, "b": 2}, **change}
    with pytest.raises(ValueError, match=message):
        StackOfTasks(kwargs.pop("nv"), kwargs.pop("tasks"), **kwargs)


def test_a_stack_value_on_the_stack_input_is_blended_like_a_command():
    """A Stack carrying a change in progress (as TaskSequencer.smooth_stack sends), made over fewer
    known tasks than the solver's: q̇ = (1 - h) q̇*(before) + h q̇*(after) as for a command."""
    rng = np.random.default_rng(21)
    sot, context, signals = _sot_with_fixed_tasks(rng, {"a": 2, "b": 2, "c": 2})

    def strict(stack):
        return solve_strict([(signals[n].jacobian, signals[n].edot_des) for n in stack]).qdot

    few = Stack(("a", "c"))
    smooth = few.with_active(("a", "c")).transition_from(few.with_active(("a",)), start=1.0, duration=0.5)
    sot.GetInputPort("stack").FixValue(context, smooth)
    for t in (1.0, 1.1, 1.25, 1.4, 1.6):
        context.SetTime(t)
        qdot, _ = _tick(sot, context)
        h = _raised_cosine(t, 1.0, 0.5)
        np.testing.assert_allclose(qdot, (1 - h) * strict(("a",)) + h * strict(("a", "c")), atol=1e-12)
    assert sot.list(context) == ("a", "c")
    sot.GetInputPort("stack").FixValue(context, Stack(("a", "d"), ("d",)))
    with pytest.raises(RuntimeError, match=r"input port 'stack': .*unknown task 'd'"):
        _tick(sot, context)
