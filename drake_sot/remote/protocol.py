"""The remote command protocol (pure: no Drake, no sockets): JSON lines over TCP.

One JSON object per line, UTF-8, ended by ``\\n``, at most :data:`MAX_LINE` bytes (64 KiB)
with its newline. Requests (the coshell of Mansard et al. 2009, III-C: ``run``/``runAndRead``,
``readVector`` and the vector signals clients write)::

    {"id": ID, "op": "run", "cmd": "<one script line>"}
    {"id": ID, "op": "read", "signal": "<system>.<port>"}
    {"id": ID, "op": "write", "signal": "<system>.<port>", "value": [numbers]}
    {"id": ID, "op": "write", "signal": ..., "value": [...], "t": S, "at": A, "horizon": H}
    {"id": ID, "op": "subscribe", "signal": "<system>.<port>", "period": S}
    {"id": ID, "op": "unsubscribe", "signal": "<system>.<port>"}
    {"id": ID, "op": "list"}
    {"op": "auth", "token": "..."}

``ID`` is any JSON string, number or null, echoed in the reply (null when absent).

A *timed* write (a client simulating in step with the served diagram, as the two-process
tele-cooperation's master does) carries ``t``, the client's simulated time when it sent the value
[s], and ``at``, the served diagram's simulated time at which it is applied (at the first tick at
or after it; null: never — a packet the client's emulated link lost), instead of at the next
tick. ``horizon`` [s] (optional, on any write): no timed write this client sends later has an
``at`` before it; a served run paced by its client simulates no tick at or after it until a later
write moves it on.
Replies::

    {"id": ID, "ok": true, "result": ..., "t": <simulated time [s]>}
    {"id": ID, "ok": true, "result": [...], "t": ..., "layout": {"<task>": [start, stop], ...}}
    {"id": ID, "ok": true, "result": [...], "t": ..., "pairs": [{"shape_a": A, "shape_b": B,
        "body_a": BA, "body_b": BB} or null, ...]}
    {"id": ID, "ok": false, "error": "<message naming the bad part>"}

The second is the reply to a ``read`` of a stacked signal (a solver's ``errors``): ``layout``
names whose rows ``result[start:stop]`` are. The third is the reply to a ``read`` of a
self-collision task's rows, ``TASK.distances`` [m] or ``TASK.pair_indices``: ``pairs[k]`` names
row ``k``'s pair of collision shapes (their SceneGraph names, ``shape_a`` before ``shape_b`` in
alphabetical order, and the names of the bodies they are fixed on), null for a row without a pair;
as many entries as the task has rows (its ``max_pairs``), closest pair first
(:func:`decode_pairs` reads it).

and stream messages of a subscription ``{"signal": ..., "t": ..., "value": [...]}``, with the
``layout`` or ``pairs`` of the signal's rows beside the value as its read's reply has them.
Numbers that are not finite (the NaN of an inactive task's error) travel as ``null``:
JSON has no NaN; :func:`decode_vector` turns them back into NaN.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass
from typing import Any

from drake_sot.errors import DrakeSotError

#: The longest line accepted, newline included [bytes].
MAX_LINE = 64 * 1024

#: Each operation and the fields it requires besides ``op`` (``id`` is optional everywhere).
OPS: dict[str, tuple[str, ...]] = {
    "run": ("cmd",),
    "read": ("signal",),
    "write": ("signal", "value"),
    "subscribe": ("signal", "period"),
    "unsubscribe": ("signal",),
    "list": (),
    "auth": ("token",),
}


#: The fields naming a row's pair in the ``pairs`` of a self-collision task's reply.
PAIR_FIELDS = ("shape_a", "shape_b", "body_a", "body_b")


class ProtocolError(DrakeSotError, ValueError):
    """A line that is not a valid request; ``request_id`` is its id when one could be read."""

    def __init__(self, message: str, request_id: Any = None) -> None:
        super().__init__(message)
        self.request_id = request_id


@dataclass(frozen=True)
class Request:
    """A parsed request: ``op`` and its fields (those ``op`` does not take are None)."""

    op: str
    id: Any = None
    cmd: str | None = None
    signal: str | None = None
    value: tuple[float, ...] | None = None
    period: float | None = None
    token: str | None = None
    sent_at: float | None = None
    at: float | None = None
    horizon: float | None = None

    @property
    def timed(self) -> bool:
        """A write applied at its ``at`` (``inf``: never) rather than at the next tick."""
        return self.at is not None


def parse_request(line: bytes) -> Request:
    """The request on one line (without its newline).

    Raises:
        ProtocolError: too long, not UTF-8, not a JSON object (or nested too deeply, or an
            integer of more than 4300 digits), unknown ``op``, a missing field or a field of the
            wrong type: a number beyond float range, a string holding a lone surrogate
            (``"\\ud800"``); the message names it. Nothing else is raised, whatever the line.
            Value checks that need the diagram (sizes, finiteness, bounds, the allowlist) are
            the server's.
    """
    if len(line) >= MAX_LINE:
        raise ProtocolError(f"line of {len(line)} bytes: at most {MAX_LINE - 1} before the newline")
    try:
        text = line.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ProtocolError(f"not UTF-8: {exc.reason} at byte {exc.start}") from None
    try:
        message = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ProtocolError(f"invalid JSON at column {exc.colno}: {exc}") from None
    except RecursionError:
        raise ProtocolError("invalid JSON: nested too deeply") from None
    except ValueError:  # the one other error of json.loads: an integer of more digits than int() reads
        raise ProtocolError(
            f"invalid JSON: an integer of more than {sys.get_int_max_str_digits()} digits"
        ) from None
    if not isinstance(message, dict):
        raise ProtocolError(f"a request is a JSON object, got {type(message).__name__}")
    request_id = message.get("id")
    if not (
        request_id is None or isinstance(request_id, (str, int, float)) and not isinstance(request_id, bool)
    ):
        raise ProtocolError(f"id: a string, a number or null, got {type(request_id).__name__}")
    if isinstance(request_id, str) and not _is_unicode(request_id):
        raise ProtocolError("id: a lone surrogate (not Unicode text)")
    op = message.get("op")
    if not isinstance(op, str) or op not in OPS:  # a list or an object is unhashable: test the type first
        shown = repr(op) if isinstance(op, str) else _shown(op)
        raise ProtocolError(f"op = {shown}: unknown; ops: {', '.join(OPS)}", request_id)
    missing = [name for name in OPS[op] if name not in message]
    if missing:
        raise ProtocolError(f"op {op!r} needs field {missing[0]!r}", request_id)
    fields: dict[str, Any] = {}
    for name in ("cmd", "signal", "token"):
        if name in OPS[op]:
            if not isinstance(message[name], str):
                raise ProtocolError(f"{name}: a string, got {type(message[name]).__name__}", request_id)
            if not _is_unicode(message[name]):
                raise ProtocolError(f"{name}: a lone surrogate (not Unicode text)", request_id)
            fields[name] = message[name]
    if "value" in OPS[op]:
        value = message["value"]
        if not isinstance(value, list):
            raise ProtocolError(f"value: a list of numbers, got {type(value).__name__}", request_id)
        bad = [i for i, x in enumerate(value) if not _is_number(x)]
        if bad:
            raise ProtocolError(f"value[{bad[0]}] = {_shown(value[bad[0]])}: not a number", request_id)
        fields["value"] = tuple(_float(f"value[{i}]", x, request_id) for i, x in enumerate(value))
    if "period" in OPS[op]:
        fields["period"] = _float("period", message["period"], request_id, "a number [s]")
    if op == "write":
        fields.update(_timing(message, request_id))
    return Request(op=op, id=request_id, **fields)


def _timing(message: dict[str, Any], request_id: Any) -> dict[str, float]:
    """The optional ``t``, ``at`` (null: inf, never) and ``horizon`` of a write."""
    fields: dict[str, float] = {}
    if ("t" in message) != ("at" in message):
        raise ProtocolError("a timed write has both 't' (sent at) and 'at' (applied at)", request_id)
    for name, key in (("t", "sent_at"), ("at", "at"), ("horizon", "horizon")):
        if name not in message:
            continue
        x = message[name]
        if name == "at" and x is None:
            fields[key] = math.inf
            continue
        fields[key] = _float(name, x, request_id, "a finite number [s]")
        if not math.isfinite(fields[key]):
            raise ProtocolError(f"{name}: a finite number [s], got {json.dumps(x)}", request_id)
    if "at" in fields and fields["at"] < fields["sent_at"]:
        raise ProtocolError(f"at = {fields['at']!r}: before t = {fields['sent_at']!r}", request_id)
    return fields


def _float(name: str, x: Any, request_id: Any, expected: str = "a number") -> float:
    """The JSON number ``x`` as a float; ProtocolError naming ``name`` for anything else, an
    integer beyond float range included (JSON integers are unbounded)."""
    if not _is_number(x):
        raise ProtocolError(f"{name}: {expected}, got {_shown(x)}", request_id)
    try:
        return float(x)
    except OverflowError:
        raise ProtocolError(
            f"{name}: {expected}, got an integer of {len(str(abs(x)))} digits, beyond float range (±1.8e308)",
            request_id,
        ) from None


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _shown(x: Any) -> str:
    """``x`` as JSON for a message, at most 40 characters (a nest too deep to write: its type)."""
    try:
        text = json.dumps(x)
    except (RecursionError, ValueError):
        return f"a {type(x).__name__}"
    return text if len(text) <= 40 else text[:40] + "…"


def _is_unicode(text: str) -> bool:
    """False for a string holding a lone surrogate (``"\\ud800"`` in JSON): not encodable as UTF-8."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def _jsonable(value: Any) -> Any:
    """``value`` with non-finite floats as None and tuples/arrays as lists."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if hasattr(value, "tolist"):  # a numpy array or scalar
        return _jsonable(value.tolist())
    return value


def encode(message: dict[str, Any]) -> bytes:
    """One message as a line: compact JSON, non-finite numbers as null, ``\\n`` at the end."""
    return json.dumps(_jsonable(message), separators=(",", ":"), allow_nan=False).encode() + b"\n"


def ok(request_id: Any, result: Any, t: float) -> dict[str, Any]:
    return {"id": request_id, "ok": True, "result": result, "t": t}


def error(request_id: Any, message: str) -> dict[str, Any]:
    return {"id": request_id, "ok": False, "error": message}


def decode_vector(values: list[float | None]) -> list[float]:
    """A vector as sent (null for a non-finite number) with NaN in place of null."""
    return [math.nan if x is None else float(x) for x in values]


@dataclass(frozen=True)
class PairRow:
    """One row of a self-collision task at a tick, by name: its pair of collision shapes (their
    SceneGraph names, ``shape_a`` before ``shape_b`` in alphabetical order), the bodies they are
    fixed on, and their signed distance [m] (negative when they interpenetrate)."""

    shape_a: str
    shape_b: str
    body_a: str
    body_b: str
    distance: float


def decode_pairs(pairs: Any, distances: list[float]) -> list[PairRow]:
    """The rows that have a pair, in row order (closest first), from a reply's ``pairs`` and its
    rows' ``distances`` [m] (its ``result`` as :func:`decode_vector` returns it).

    Raises:
        ProtocolError: ``pairs`` is not a list of one entry per distance, or an entry is neither
            null nor an object whose :data:`PAIR_FIELDS` are Unicode strings, or a row with a pair
            has no finite distance; the message names the entry (other fields are ignored).
    """
    if not isinstance(pairs, list) or len(pairs) != len(distances):
        shown = f"{len(pairs)} entries" if isinstance(pairs, list) else _shown(pairs)
        raise ProtocolError(f"pairs: a list of {len(distances)} entries (one per row), got {shown}")
    rows = []
    for k, (pair, distance) in enumerate(zip(pairs, distances, strict=True)):
        if pair is None:
            continue
        if not isinstance(pair, dict):
            raise ProtocolError(
                f"pairs[{k}] = {_shown(pair)}: an object of {', '.join(PAIR_FIELDS)}, or null"
            )
        for name in PAIR_FIELDS:
            if not isinstance(pair.get(name), str) or not _is_unicode(pair[name]):
                raise ProtocolError(f"pairs[{k}].{name} = {_shown(pair.get(name))}: a name (Unicode text)")
        if not math.isfinite(distance):
            raise ProtocolError(f"pairs[{k}] names a pair, but its distance is {distance!r}, not finite")
        rows.append(PairRow(*(pair[name] for name in PAIR_FIELDS), distance=distance))
    return rows
