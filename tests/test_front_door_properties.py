"""Property tests of the front door's parsers (hypothesis): the protocol's
:func:`~drake_sot.remote.protocol.parse_request`, its client's
:func:`~drake_sot.remote.protocol.decode_pairs` (a reply's ``pairs``), and the script dialect's parsers
(:func:`~drake_sot.script.parse_line`, :func:`~drake_sot.script.parse_script`,
:func:`~drake_sot.script.parse_value`, a script file read by
:func:`~drake_sot.diagrams.script_session.load_script`, the stack commands'
:func:`~drake_sot.script.stack_command`), fed arbitrary bytes, text and JSON — integers beyond
float range and beyond the 4300 digits Python reads, non-finite numbers, lone surrogates, deep
nesting — return a value or raise their documented error type, nothing else."""

import json
import math
from dataclasses import dataclass
from pathlib import Path

from hypothesis import HealthCheck, given, reject, settings
from hypothesis import strategies as st

from drake_sot.diagrams.script_session import SessionError, load_script
from drake_sot.remote.protocol import OPS, PAIR_FIELDS, ProtocolError, Request, decode_pairs, parse_request
from drake_sot.script import (
    KEYWORDS,
    Call,
    ScriptError,
    parse_line,
    parse_script,
    parse_value,
    stack_command,
)
from drake_sot.stack import MAX_TRANSITION, VERBS, StackError

SETTINGS = settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])


# --- arbitrary JSON, written by hand: integers of any length, NaN, lone surrogates, nesting ----


@dataclass(frozen=True)
class Raw:
    """JSON text written as is (an integer of more digits than ``json.dumps`` writes, a nest)."""

    text: str


def dump(value) -> str:
    """``value`` as JSON text (``ensure_ascii``: a lone surrogate as ``\\ud800``)."""
    if isinstance(value, Raw):
        return value.text
    if isinstance(value, dict):
        return "{" + ",".join(f"{json.dumps(k)}:{dump(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list):
        return "[" + ",".join(dump(v) for v in value) + "]"
    return json.dumps(value)  # NaN and Infinity as Python's json writes and reads them


huge_integers = st.builds(
    lambda sign, digits, lead: Raw(sign + str(lead) + "0" * digits),
    st.sampled_from(["", "-"]),
    st.sampled_from([300, 308, 309, 400, 4299, 4300, 5000]),
    st.integers(1, 9),
)
deep_nests = st.integers(1, 3000).map(lambda n: Raw("[" * n + "]" * n))
texts = st.text(st.characters(categories=["L", "N", "P", "S", "Z", "Cc", "Cs"]), max_size=30)
scalars = (
    st.none()
    | st.booleans()
    | st.integers()
    | st.floats(allow_nan=True, allow_infinity=True)
    | huge_integers
    | texts
    | st.sampled_from(["sot.push taskLH", "dyn.com", "taskRH.position_des", "\ud800", "run 1e400"])
)
json_values = st.recursive(
    scalars | deep_nests,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(texts, inner, max_size=4),
    max_leaves=12,
)
fields = ("id", "op", "cmd", "signal", "value", "period", "token", "t", "at", "horizon")
requests = st.fixed_dictionaries(
    {"op": st.sampled_from(list(OPS)) | json_values},
    optional={
        **{name: json_values for name in fields if name != "op"},
        "value": st.lists(scalars, max_size=6) | json_values,
    },
)


@SETTINGS
@given(st.binary(max_size=300))
def test_parse_request_of_arbitrary_bytes_raises_only_protocol_errors(line):
    try:
        assert isinstance(parse_request(line), Request)
    except ProtocolError:
        pass


@SETTINGS
@given(requests)
def test_parse_request_of_arbitrary_json_raises_only_protocol_errors(message):
    try:
        request = parse_request(dump(message).encode())
    except ProtocolError:
        return
    # what it accepted is what the server can use: Unicode text, floats, a known op
    assert request.op in OPS
    for text in (request.cmd, request.signal, request.token, request.id):
        if isinstance(text, str):
            text.encode("utf-8")
    assert request.value is None or all(isinstance(x, float) for x in request.value)
    assert request.period is None or isinstance(request.period, float)
    for time in (request.sent_at, request.horizon):
        assert time is None or math.isfinite(time)


pair_entries = (
    st.none()
    | st.fixed_dictionaries({name: texts for name in PAIR_FIELDS})
    | st.fixed_dictionaries({}, optional={name: json_values for name in PAIR_FIELDS})
    | json_values
)


replies = st.lists(st.tuples(pair_entries, st.floats()), max_size=5).map(
    lambda rows: ([pair for pair, _ in rows], [distance for _, distance in rows])
) | st.tuples(json_values, st.lists(st.floats(), max_size=5))  # (pairs, distances): aligned, or anything


@SETTINGS
@given(replies)
def test_decode_pairs_of_an_arbitrary_reply_raises_only_protocol_errors(reply):
    """A reply's ``pairs`` as the client reads it (``json.loads``), beside any distances: the rows
    it names, or a ProtocolError."""
    pairs, distances = reply
    try:
        pairs = json.loads(dump(pairs))
    except (RecursionError, ValueError):  # not JSON the client reads: never reaches decode_pairs
        reject()
    try:
        rows = decode_pairs(pairs, distances)
    except ProtocolError:
        return
    # what it accepted names a pair of each row that has one, as Unicode text, at a finite distance
    assert len(rows) == sum(pair is not None for pair in pairs) and len(pairs) == len(distances)
    for row in rows:
        for name in PAIR_FIELDS:
            getattr(row, name).encode("utf-8")
        assert math.isfinite(row.distance)


# --- the script dialect --------------------------------------------------------------------------

numbers = st.one_of(
    st.integers().map(str),
    st.floats(allow_nan=False, allow_infinity=False).map(repr),
    huge_integers.map(lambda raw: raw.text),
    st.sampled_from(["1e400", "-1e400", "1e308", ".5", "+3", "1e", "--1", "0x10", "nan", "inf"]),
)
pieces = st.one_of(
    st.sampled_from(
        [
            *KEYWORDS,
            "sot.push",
            "sot.up",
            "sot.clear",
            "pg.parsecmd",
            "taskRH.controlGain",
            "TaskSelfCollision",
            "taskSelfCollision.pairs",
            "taskSelfCollision.maxPairs",
            "taskSelfCollision.legPairs",
        ]
    ),
    st.sampled_from(
        ["a.b", "taskLH", ":verb", '"str"', '"\\"', "#", "[", "]", "(", ")", ",", "[3]", "[2,2]"]
    ),
    numbers,
    st.lists(numbers, min_size=1, max_size=4).map(lambda xs: f"[{len(xs)}]({','.join(xs)})"),
    texts,
)
script_lines = st.lists(pieces, max_size=8).map(" ".join) | texts


@SETTINGS
@given(script_lines)
def test_the_script_parsers_of_arbitrary_text_raise_only_script_errors(text):
    for parse in (parse_line, parse_script, parse_value):
        try:
            parse(text)
        except ScriptError:
            pass


@SETTINGS
@given(script_lines.map(lambda line: "sot." + line.split(" ", 1)[-1]))
def test_a_parsed_stack_command_is_used_or_refused_with_a_stack_error(text):
    try:
        command = parse_line(text)
    except ScriptError:
        return
    if isinstance(command, Call):
        try:
            made = stack_command(command)
        except StackError:
            return
        assert type(made) is VERBS[command.command].command
        assert all(isinstance(v, str) and v for k, v in vars(made).items() if k == "task")
        assert 0.0 <= made.transition <= MAX_TRANSITION


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.binary(max_size=300) | script_lines.map(lambda s: s.encode("utf-8", "surrogatepass")))
def test_a_script_file_of_arbitrary_bytes_loads_or_raises_a_script_or_session_error(tmp_path, content):
    path = Path(tmp_path) / "arbitrary.sot"
    path.write_bytes(content)
    try:
        load_script(path)
    except (ScriptError, SessionError):
        pass
