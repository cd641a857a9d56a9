"""The SoT script dialect (drake_sot.script): the paper's lines, the grammar's errors, and
nothing but ScriptError for any text."""

import math
import re

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from drake_sot.script import (
    Call,
    Destroy,
    Get,
    Matrix,
    Name,
    New,
    Plug,
    Run,
    RunFor,
    ScriptError,
    Set,
    Signal,
    Vector,
    Verb,
    format_value,
    parse_line,
    parse_script,
    parse_value,
    stack_command,
)
from drake_sot.stack import StackError

# Every line of the code blocks of Mansard, Stasse, Evrard, Kheddar 2009, section III-B, as
# printed there, with the command each one is.
PAPER_III_B = [
    ("pool.help", Call("pool", "help")),
    ("new FeatureGeneric featureCom", New("FeatureGeneric", "featureCom")),
    ("plug dyn.com featureCom.errorIN", Plug(Signal("dyn", "com"), Signal("featureCom", "errorIN"))),
    ("plug dyn.Jcom featureCom.jacobianIN", Plug(Signal("dyn", "Jcom"), Signal("featureCom", "jacobianIN"))),
    ("new FeatureGeneric featureComDes", New("FeatureGeneric", "featureComDes")),
    (
        "set featureComDes.errorIN [3](0,-0,0.64)",
        Set(Signal("featureComDes", "errorIN"), Vector((0.0, -0.0, 0.64))),
    ),
    ("set featureCom.sdes featureComDes", Set(Signal("featureCom", "sdes"), Name("featureComDes"))),
    (
        "plug PGselec.scomref featureComDes.errorIN",
        Plug(Signal("PGselec", "scomref"), Signal("featureComDes", "errorIN")),
    ),
    ("new Task taskCom", New("Task", "taskCom")),
    ("taskCom.add featureCom", Call("taskCom", "add", (Name("featureCom"),))),
    ("sot.push taskCom", Call("sot", "push", (Name("taskCom"),))),
    ("dyn2.createOpPoint rleg 6", Call("dyn2", "createOpPoint", (Name("rleg"), 6))),
    ("dyn2.createOpPoint lleg 12", Call("dyn2", "createOpPoint", (Name("lleg"), 12))),
    ("new FeaturePoint6dRelative featureTwofeet", New("FeaturePoint6dRelative", "featureTwofeet")),
    ("plug dyn.Jrleg featureTwofeet.Jq", Plug(Signal("dyn", "Jrleg"), Signal("featureTwofeet", "Jq"))),
    ("plug dyn.Jlleg featureTwofeet.JqRef", Plug(Signal("dyn", "Jlleg"), Signal("featureTwofeet", "JqRef"))),
    (
        "plug dyn.rleg featureTwofeet.position",
        Plug(Signal("dyn", "rleg"), Signal("featureTwofeet", "position")),
    ),
    (
        "plug dyn.lleg featureTwofeet.positionRef",
        Plug(Signal("dyn", "lleg"), Signal("featureTwofeet", "positionRef")),
    ),
    (
        "pg.parsecmd :singlesupporttime 0.780",
        Call("pg", "parsecmd", (Verb("singlesupporttime"), 0.78)),
    ),
]


@pytest.mark.parametrize(("line", "command"), PAPER_III_B, ids=[line for line, _ in PAPER_III_B])
def test_the_papers_lines_parse_into_their_commands(line, command):
    assert parse_line(line) == command


def test_the_papers_vector_has_a_negative_zero_and_its_values():
    value = parse_line("set featureComDes.errorIN [3](0,-0,0.64)").value
    assert value.values == (0.0, -0.0, 0.64)
    assert math.copysign(1.0, value.values[1]) == -1.0  # the paper's "-0" is kept
    assert value.array.shape == (3,)


def test_a_script_keeps_line_numbers_and_drops_comments_and_blank_lines():
    text = "# header\r\n\r\nnew Task t   # a task\r\n  sot.push t\n\nrun 2.5\nrun other.sot\n"
    statements = parse_script(text, source="demo.sot")
    assert [(s.line, s.text) for s in statements] == [
        (3, "new Task t"),
        (4, "sot.push t"),
        (6, "run 2.5"),
        (7, "run other.sot"),
    ]
    assert [s.command for s in statements] == [
        New("Task", "t"),
        Call("sot", "push", (Name("t"),)),
        RunFor(2.5),
        Run("other.sot"),
    ]
    assert statements[1].where == "demo.sot, line 4"


def test_values_of_every_kind():
    line = 'e.cmd 3 -2.5e-3 .5 [2,2]((1,0),(0,1)) "a \\"quoted\\" # text" :verb path/to/file.dot'
    assert parse_line(line) == Call(
        "e",
        "cmd",
        (
            3,
            -2.5e-3,
            0.5,
            Matrix(((1.0, 0.0), (0.0, 1.0))),
            'a "quoted" # text',
            Verb("verb"),
            Name("path/to/file.dot"),
        ),
    )
    assert isinstance(parse_line("e.c 3").args[0], int)
    assert parse_line("set a.b [3]( 1 , 2,3 )").value == Vector((1.0, 2.0, 3.0))
    assert parse_line("get featureCom.error") == Get(Signal("featureCom", "error"))
    assert parse_line("destroy x") == Destroy("x")
    assert parse_line('run "my script.sot"') == Run("my script.sot")


# (text, line, column, words of what was expected)
GRAMMAR_ERRORS = [
    ("set featureComDes.errorIN [3](0,-0)", 1, 35, "1 more number"),
    ("set featureComDes.errorIN [3](0,-0,0.64,1)", 1, 40, "')': the vector [3] has 3 entries"),
    ("set a.b [2,2]((1,0),(0,1),(1,1))", 1, 26, "the matrix [2,2] has 2 rows"),
    ("set a.b [2,2]((1,0),(0))", 1, 23, "1 more number"),
    ("set a.b [0]()", 1, 10, "a size (an integer >= 1)"),
    ("set a.b (1,2)", 1, 9, "a name, a number, a vector"),
    ("plug dyn.com", 1, 13, "an input signal ENTITY.SIGNAL"),
    ("plug dyn featureCom.errorIN", 1, 6, "an output signal ENTITY.SIGNAL"),
    ("new FeatureGeneric", 1, 19, "the new entity's name"),
    ("new FeatureGeneric a b", 1, 22, "the end of the line"),
    ("sot.push.now taskCom", 1, 1, "a command: new, destroy, plug, set, get, run or ENTITY.COMMAND"),
    ("push taskCom", 1, 1, "ENTITY.COMMAND"),
    ("pg.parsecmd :singlesupporttime 0.780x", 1, 32, "a number"),
    ("pg.parsecmd : 0.78", 1, 14, "a verb name after ':'"),
    ("e.c 1e999", 1, 5, "a finite number"),
    ('e.c "unterminated', 1, 18, "a closing '\"'"),
    ('e.c "bad \\n escape"', 1, 10, "the only escapes in a string"),
    ("e.c a+b", 1, 6, "a name or a file name"),
    ("e.c [3](1,2,3)x", 1, 15, "a space, a '#' comment or the end of the line"),
    ("run 0", 1, 5, "a script file name or a duration [s] > 0"),
    ("run -2", 1, 5, "a duration [s] > 0"),
    ("e.c \x00", 1, 5, "printable text"),
    ("e.c caf\u00e9", 1, 8, "a space, a '#' comment"),
    ("e.c \u00e9", 1, 5, "a name, a number"),
]


@pytest.mark.parametrize(
    ("text", "line", "column", "expected"), GRAMMAR_ERRORS, ids=[t for t, *_ in GRAMMAR_ERRORS]
)
def test_each_grammar_error_names_its_line_and_column(text, line, column, expected):
    with pytest.raises(ScriptError) as caught:
        parse_line(text, line=line, source="t.sot")
    error = caught.value
    assert (error.source, error.line, error.column) == ("t.sot", line, column), str(error)
    assert expected in error.expected, str(error)
    assert str(error).startswith(f"t.sot, line {line}, column {column}: expected ")
    assert isinstance(error, ValueError)


def test_an_error_in_a_script_names_the_line_it_is_on():
    text = (
        "new FeatureGeneric featureCom\nplug dyn.com featureCom.errorIN\n\n"
        "set featureComDes.errorIN [3](0,,0.64)\n"
    )
    with pytest.raises(ScriptError) as caught:
        parse_script(text, source="paper.sot")
    assert (caught.value.line, caught.value.column) == (4, 33)
    assert caught.value.found == "','"
    assert "entry 2 of 3" in caught.value.expected


def test_an_error_past_the_last_token_points_one_past_it():
    with pytest.raises(ScriptError) as caught:
        parse_line("set featureCom.sdes   # no value")
    assert (caught.value.column, caught.value.found) == (20, "end of line")


def test_a_number_too_long_for_an_int_is_a_script_error():
    with pytest.raises(ScriptError, match="at most 4300 digits"):
        parse_line("e.c " + "9" * 5000)


# --- any text: a command, or a ScriptError -----------------------------------------------

GRAMMAR_ALPHABET = 'abcXYZ_019.,:-+eE[]()"\\# \t\n\r/'


@settings(max_examples=3000, deadline=None)
@given(st.text())
def test_any_text_parses_or_raises_only_script_error(text):
    try:
        parse_script(text)
    except ScriptError as error:
        assert error.line >= 1 and error.column >= 1


@settings(max_examples=3000, deadline=None)
@given(st.text(alphabet=GRAMMAR_ALPHABET, max_size=60))
def test_text_near_the_grammar_parses_or_raises_only_script_error(text):
    try:
        parse_script(text)
    except ScriptError as error:
        assert 1 <= error.line <= text.count("\n") + 1
        line = text.split("\n")[error.line - 1]
        assert 1 <= error.column <= len(line) + 1


@settings(max_examples=500, deadline=None)
@given(st.sampled_from(["", "set a.b ", "e.c ", "run "]), st.text(alphabet=GRAMMAR_ALPHABET, max_size=30))
def test_values_near_the_grammar_parse_or_raise_only_script_error(prefix, text):
    try:
        parse_line(prefix + text)
    except ScriptError:
        pass


# --- round trip: a command's text parses back into the same command -----------------------

names = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,8}", fullmatch=True).filter(
    lambda n: n not in ("new", "destroy", "plug", "set", "get", "run")
)
finite = st.floats(allow_nan=False, allow_infinity=False)
signals = st.builds(Signal, names, names)
values = st.one_of(
    st.integers(-(10**12), 10**12),
    finite,
    st.text(
        st.characters(codec="utf-8", exclude_categories=("Cc", "Cs", "Zl", "Zp", "Cn", "Co", "Cf", "Zs")),
        max_size=8,
    ),
    st.builds(
        Name,
        st.from_regex(r"[A-Za-z_./][A-Za-z0-9_./-]{0,8}", fullmatch=True).filter(
            lambda text: not re.fullmatch(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?", text)
        ),
    ),
    st.builds(Verb, names),
    st.builds(Vector, st.lists(finite, min_size=1, max_size=5).map(tuple)),
    st.integers(1, 3).flatmap(
        lambda c: st.builds(
            Matrix,
            st.lists(st.lists(finite, min_size=c, max_size=c).map(tuple), min_size=1, max_size=3).map(tuple),
        )
    ),
)
commands = st.one_of(
    st.builds(New, names, names),
    st.builds(Destroy, names),
    st.builds(Plug, signals, signals),
    st.builds(Set, signals, values),
    st.builds(Get, signals),
    st.builds(Call, names, names, st.lists(values, max_size=4).map(tuple)),
    st.builds(RunFor, st.floats(min_value=1e-9, max_value=1e9)),
    st.builds(Run, st.from_regex(r"[A-Za-z_./][A-Za-z0-9_./-]{0,12}", fullmatch=True)),
)


@pytest.mark.parametrize("text", [".0", "1", ".5e3", "a b", "", "+x"])
def test_a_name_that_would_not_parse_back_as_itself_is_refused(text):
    """A Name prints as its text; a number or a text with spaces would read back as another value."""
    with pytest.raises(ValueError, match="not a bare word"):
        Name(text)


@settings(max_examples=1000, deadline=None)
@given(commands)
@example(Run(".0"))  # a file name that reads as a number: printed quoted, not as a duration
@example(Run(".5e3"))
def test_a_commands_text_parses_back_into_it(command):
    assert parse_line(str(command)) == command


@settings(max_examples=300, deadline=None)
@given(st.lists(finite, min_size=1, max_size=6))
def test_format_value_writes_floats_that_read_back_exactly(xs):
    vector = Vector(tuple(xs))
    assert parse_value(format_value(vector)) == vector
    assert [math.copysign(1.0, x) for x in parse_value(str(vector)).values] == [
        math.copysign(1.0, x) for x in xs
    ]


@settings(max_examples=100, deadline=None)
@given(
    st.integers(min_value=-(10**300), max_value=10**300)
    | st.integers(min_value=1).map(lambda k: k * 10**309)
    | st.integers(min_value=1).map(lambda k: -k * 10**5000)
)
def test_format_value_writes_any_integer_and_what_fits_a_float_reads_back(n):
    """An integer within float range reads back equal; one beyond it (from Python: the parser
    refuses it) is described, not written (Python's own text of it raises past 4300 digits),
    and the parser refuses the description."""
    text = format_value(n)
    if abs(n) <= 10**300:
        assert parse_value(text) == n
    else:
        assert "beyond float range" in text and len(text) < 80, text
        with pytest.raises(ScriptError):
            parse_value(text)


def test_parse_value_reads_one_value_and_nothing_else():
    assert parse_value("[2](1,2)") == Vector((1.0, 2.0))
    assert parse_value("featureComDes") == Name("featureComDes")
    with pytest.raises(ScriptError, match="column 10: expected the end of the line"):
        parse_value("[2](1,2) 3")
    with pytest.raises(ScriptError):
        parse_value("[1](nan)")  # `get` writes nan for a NaN; a script cannot set one


# --- the stack commands' arguments, with this dialect's optional transition time -------------


@pytest.mark.parametrize(
    "line, names, seconds",
    [
        ("sot.push taskLH", ("taskLH",), 0.0),  # the paper's syntax, unchanged: at once
        ("sot.push taskLH 0.5", ("taskLH",), 0.5),
        ('sot.rm "taskLH" 1', ("taskLH",), 1.0),  # a quoted name and an int time
        ("sot.up taskRH 0", ("taskRH",), 0.0),
        ("sot.down taskRH 2.5e-1", ("taskRH",), 0.25),
        ("sot.pop", (), 0.0),
        ("sot.pop 0.5", (), 0.5),
        ("sot.clear 1.5", (), 1.5),
    ],
)
def test_stack_commands_take_an_optional_transition_time(line, names, seconds):
    command = stack_command(parse_line(line))
    assert type(command).verb == parse_line(line).command and command.transition == seconds
    assert tuple(value for field, value in vars(command).items() if field == "task") == names


@pytest.mark.parametrize(
    "call, message",
    [
        (
            parse_line("sot.push"),
            r"^push TASK \[SECONDS\]: takes 1 task name\(s\) and an optional time, got 0",
        ),
        (parse_line("sot.pop taskLH"), r"^pop \[SECONDS\]: takes 0 task name\(s\)"),
        (parse_line("sot.push taskLH taskRH"), r"takes 1 task name\(s\) and an optional time, got 2"),
        (parse_line("sot.push taskLH 0.5 1"), r"got 3 value\(s\)"),
        (parse_line("sot.push 0.5"), r"^push: task = 0.5: must be a non-empty string$"),
        (parse_line("sot.push taskLH [2](1,2)"), r"^push: transition = Vector\(.*\): must be a number$"),
        (parse_line("sot.push taskLH -0.5"), r"^push: transition = -0.5 s: must be in \[0, 60\] s$"),
        (
            Call("sot", "push", (Name("taskLH"), math.nan)),
            r"^push: transition = nan s: must be in \[0, 60\] s$",
        ),
        (Call("sot", "push", (Name("taskLH"), True)), r"^push: transition = True: must be a number$"),
        (parse_line("sot.list"), r"^'list': not a stack command \(push, pop, rm, up, down, clear\)$"),
    ],
)
def test_bad_stack_command_arguments_name_the_command(call, message):
    with pytest.raises(StackError, match=message):
        stack_command(call)
