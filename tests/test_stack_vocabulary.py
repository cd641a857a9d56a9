"""One stack-command vocabulary: every front-end — Python (``StackOfTasks``), a script line
(the script session's solver), a served line (``RemoteCommandServer`` in a diagram, without a
network) and a state machine's entry action (the script's ``TaskSequencer`` and the Python
``StateMachine``) — makes its command with :data:`drake_sot.stack.VERBS` and
:func:`drake_sot.stack.parse_command`, gets the same stack from it, and meets the same error,
with the same message, for every malformed form. The expected stacks and messages are written
here by hand from the paper's definitions (Mansard, Stasse, Evrard, Kheddar 2009, III-B.6)."""

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource

from drake_sot.diagrams.script_session import ScriptSession, SessionError
from drake_sot.remote.protocol import Request
from drake_sot.script import parse_line
from drake_sot.sequencing import State, StateMachine
from drake_sot.signals import TaskSignal
from drake_sot.stack import MAX_TRANSITION, VERBS, Clear, Down, Pop, Push, Rm, StackError, Up, parse_command
from drake_sot.systems.command_server import DONE, STACK, RemoteCommandServer
from drake_sot.systems.sot import StackOfTasks

TASKS = ("ta", "tb", "tc", "td")
START = ("ta", "tb", "tc")  # every case starts from this stack; td is known and not in it
PERIOD = 0.01

# verb, its arguments as a script line writes them, the stack after it (by hand)
WELL_FORMED = [
    ("push", "td", ("ta", "tb", "tc", "td")),
    ("pop", "", ("ta", "tb")),
    ("rm", "tb", ("ta", "tc")),
    ("up", "tb", ("tb", "ta", "tc")),
    ("down", "tb", ("ta", "tc", "tb")),
    ("clear", "", ()),
]

KNOWN = "known: ta, tb, tc, td"
# a line after "sot.", what the one error of the vocabulary says (by hand)
MALFORMED = [
    ("push", "push TASK [SECONDS]: takes 1 task name(s) and an optional time, got 0 value(s)"),  # arity
    ("rm tb tc", "rm TASK [SECONDS]: takes 1 task name(s) and an optional time, got 2 value(s)"),
    ("clear tb", "clear [SECONDS]: takes 0 task name(s) and an optional time, got 1 value(s)"),
    ("jump tb", "'jump': not a stack command (push, pop, rm, up, down, clear)"),  # unknown verb
    ("push td 1e308", "push: transition = 1e+308 s: must be in [0, 60] s"),  # bad times
    ("rm tb -0.5", "rm: transition = -0.5 s: must be in [0, 60] s"),
    ("push zz", f"unknown task 'zz'; {KNOWN}"),  # unknown task
    ("up zz", f"unknown task 'zz'; {KNOWN}"),
    ("push ta", "task 'ta' is already in the stack ('ta', 'tb', 'tc')"),  # does not apply
    ("rm td", "task 'td' is not in the stack ('ta', 'tb', 'tc')"),
    ("up ta", "up ta: already at the top of the stack (ta, tb, tc)"),
    ("down tc", "down tc: already at the bottom of the stack (ta, tb, tc)"),
]


def _words(line: str) -> tuple[str, tuple[object, ...]]:
    """The verb and the arguments of ``sot.<line>`` as the script dialect reads them (Name → text)."""
    call = parse_line(f"sot.{line}")
    return call.command, tuple(getattr(a, "text", a) for a in call.args)


def _solver(**kwargs) -> tuple[StackOfTasks, object]:
    """A solver of TASKS (one row each, fixed signals) holding START, and its context."""
    sot = StackOfTasks(len(TASKS), dict.fromkeys(TASKS, 1), period=PERIOD, stack=START, **kwargs)
    return sot, sot.CreateDefaultContext()


def _cause(error: BaseException) -> BaseException:
    """The innermost cause of ``error`` (a front-end may locate the vocabulary's error)."""
    while error.__cause__ is not None:
        error = error.__cause__
    return error


# --- the front-ends: each returns the stack after ``sot.<line>``, or raises / returns its error ----


def python_front_end(line: str) -> tuple[str, ...]:
    sot, context = _solver()
    verb, args = _words(line)
    sot.apply(context, parse_command(verb, args))
    return sot.list(context)


@pytest.fixture(scope="module")
def session():
    session = ScriptSession()
    session.run_script(
        "new FeatureCoM featureCom\n" + "".join(f"new Task {t}\n{t}.add featureCom\n" for t in TASKS)
    )
    session.execute("sot.list")  # builds the diagram
    return session


def _reset_script(session: ScriptSession) -> None:
    sot = session.entity("sot").system
    context = session.simulator.get_mutable_context()
    sot.clear(context)
    for task in START:
        sot.push(context, task)


@pytest.fixture(scope="module")
def served():
    builder = DiagramBuilder()
    sot = builder.AddSystem(
        StackOfTasks(len(TASKS), dict.fromkeys(TASKS, 1), period=PERIOD, commands_input=True)
    )
    for k, name in enumerate(TASKS):
        J = np.eye(len(TASKS))[k : k + 1]
        source = builder.AddSystem(
            ConstantValueSource(AbstractValue.Make(TaskSignal(name, np.zeros(1), J, np.ones(1))))
        )
        builder.Connect(source.get_output_port(), sot.GetInputPort(name))
    server = builder.AddSystem(RemoteCommandServer(PERIOD))
    builder.Connect(server.GetOutputPort("commands"), sot.GetInputPort("commands"))
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    inbox: list = []
    server.attach(lambda: [inbox.pop(0) for _ in range(len(inbox))])
    return simulator, sot, server, inbox


def served_front_end(served, line: str) -> tuple[str, ...] | str:
    """The stack after the served line ``sot.<line>``, or the error its reply carries."""
    simulator, sot, server, inbox = served
    context = simulator.get_mutable_context()
    sot.clear(context)
    for task in START:
        sot.push(context, task)
    serial = server.taken(context).serial
    inbox.append((0, Request("run", id=1, cmd=f"sot.{line}")))
    for _ in range(10):  # to the tick that takes it (one, or two if a tick is at the time now)
        simulator.AdvanceTo(context.get_time() + PERIOD / 2)
        if server.taken(context).serial > serial:
            break
    (taken,) = server.taken(context).requests
    if taken.kind == DONE:
        return taken.error
    assert taken.kind == STACK
    results = sot.GetOutputPort("command_results").Eval(sot.GetMyContextFromRoot(context)).results
    ok, error = results[taken.index]
    return sot.list(context) if ok else error


def sequencer_front_end(line: str) -> tuple[str, ...]:
    """The stack after entering a state whose entry action is the script's ``addEntry s <line>``."""
    session = ScriptSession()
    session.run_script("new TaskSequencer decision\ndecision.addState s")
    session.execute(f"decision.addEntry s {line}")
    (action,) = session.entity("decision").states["s"][0]
    return StateMachine(
        [State("s", entry=(action,))], "s", tasks=TASKS, stack=START
    ).initial_status.stack.active


# --- the same stack from every front-end ---------------------------------------------------------


def test_the_table_is_the_vocabulary():
    assert sorted(VERBS) == sorted(verb for verb, _, _ in WELL_FORMED)
    assert {VERBS[v].command for v in VERBS} == {Push, Pop, Rm, Up, Down, Clear}
    assert {v: VERBS[v].tasks for v in VERBS} == {
        "push": 1,
        "pop": 0,
        "rm": 1,
        "up": 1,
        "down": 1,
        "clear": 0,
    }
    assert all(VERBS[v].timed for v in VERBS) and MAX_TRANSITION == 60.0


@pytest.mark.parametrize("verb, task, after", WELL_FORMED, ids=[v for v, _, _ in WELL_FORMED])
def test_each_verb_makes_the_same_change_from_every_front_end(verb, task, after, session, served):
    line = f"{verb} {task}".strip()
    assert python_front_end(line) == after
    sot, context = _solver()  # the paper's methods, Python's other spelling
    method = {
        "push": sot.push,
        "pop": sot.pop,
        "rm": sot.rm,
        "up": sot.up,
        "down": sot.down,
        "clear": sot.clear,
    }
    method[verb](context, *([task] if task else []))
    assert sot.list(context) == after
    _reset_script(session)
    session.execute(f"sot.{line}")
    assert tuple(session.execute("sot.list").split()) == after
    assert served_front_end(served, line) == after
    assert sequencer_front_end(line) == after


@pytest.mark.parametrize("line, message", MALFORMED, ids=[line for line, _ in MALFORMED])
def test_each_malformed_form_gives_the_same_error_from_every_front_end(line, message, session, served):
    with pytest.raises(StackError) as python:
        python_front_end(line)
    assert str(python.value).startswith(message)

    _reset_script(session)
    with pytest.raises(SessionError) as script:
        session.execute(f"sot.{line}")
    assert isinstance(_cause(script.value), StackError)
    assert str(script.value).startswith(f"sot.{line}: {message}")
    assert tuple(session.execute("sot.list").split()) == START  # refused: nothing changed

    reply = served_front_end(served, line)
    assert isinstance(reply, str) and message in reply, reply
    assert served[1].list(served[0].get_context()) == START

    if "transition" in message:
        return  # a state's entry action has no time of its own: see the test below
    with pytest.raises((StackError, SessionError)) as sequencer:
        sequencer_front_end(line)
    assert isinstance(_cause(sequencer.value), StackError) and message in str(sequencer.value)


def test_a_time_no_script_line_can_write_is_refused_by_the_same_check():
    """NaN and an integer beyond float range (a script line refuses them in its own parser) meet the
    vocabulary's check from Python."""
    sot, context = _solver()
    for value, message in (
        (float("nan"), "push: transition = nan s: must be in [0, 60] s"),
        (10**400, "push: transition = an integer of ~401 digits: must be a number within float range"),
        (True, "push: transition = True: must be a number"),
    ):
        with pytest.raises(StackError) as python:
            sot.push(context, "td", transition=value)
        assert str(python.value).startswith(message)
        with pytest.raises(StackError) as parsed:
            parse_command("push", ("td", value))
        assert str(parsed.value) == str(python.value)
    assert sot.list(context) == START


def test_a_state_entry_action_with_a_time_of_its_own_is_refused_naming_the_states_time():
    with pytest.raises(
        ValueError, match=r"entry action Push\(task='td', transition=0.5\) has its own transition"
    ):
        StateMachine([State("s", entry=(Push("td", transition=0.5),))], "s", tasks=TASKS, stack=START)


def test_a_transition_time_blends_the_same_change_from_every_front_end(session, served):
    """``push td 0.5``: the stack reached is the same, and it comes with a 0.5 s transition."""
    sot, context = _solver()
    context.SetTime(1.0)
    sot.push(context, "td", transition=0.5)
    held = context.get_abstract_state(0).get_value()
    assert held.active == ("ta", "tb", "tc", "td") and held.transition.duration == 0.5
    assert held.transition.start == 1.0 and held.transition.origin.active == START
    assert served_front_end(served, "push td 0.5") == ("ta", "tb", "tc", "td")
    _reset_script(session)
    session.execute("sot.push td 0.5")
    script_sot = session.entity("sot").system
    script_held = script_sot.GetMyContextFromRoot(session.simulator.get_context()).get_abstract_state(0)
    assert script_held.get_value().transition.duration == 0.5


def test_the_case_study_s_switch_lines_parse_back_to_its_commands():
    """The remote decision layer of walk_then_interact sends its switch as script lines: each is
    the command written by the vocabulary, and the one parser reads it back unchanged."""
    from drake_sot.diagrams.walk_then_interact import SWITCH, SWITCH_LINES

    for command, line in zip(SWITCH, SWITCH_LINES, strict=True):
        owner, words = line.split(".", 1)
        word, *args = words.split()
        assert owner == "sot"
        assert parse_command(word, args) == command


def test_a_timed_entry_action_is_refused_on_its_own_line():
    """A state's change of the stack is blended over the state machine's transition time: an
    entry action with a time of its own is refused by the line that writes it, not later when the
    state machine is built from the script."""
    session = ScriptSession()
    session.run_script("new TaskSequencer decision\ndecision.addState s")
    with pytest.raises(SessionError, match=r"addEntry push ta 0\.5: an entry action has no transition time"):
        session.execute("decision.addEntry s push ta 0.5")
    assert session.entity("decision").states["s"][0] == []  # nothing added
    session.execute("decision.addEntry s push ta")  # the same action, untimed
    assert session.entity("decision").states["s"][0] == [Push("ta")]
