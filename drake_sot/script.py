"""The SoT script dialect (Mansard, Stasse, Evrard, Kheddar 2009, III-B): a strict parser
into command values (pure: no Drake, no ``eval``, no ``exec``).

The Stack of Tasks is driven by a small line-oriented language: ``new`` creates an
entity, ``plug`` links an output signal to an input signal, ``set`` and ``get`` give and
read a signal's value, ``E.COMMAND ARG…`` calls an entity's command (``sot.push taskCom``,
``dyn2.createOpPoint rleg 6``, ``pg.parsecmd :singlesupporttime 0.780``) and ``run``
plays another script (or, here, advances the simulation). This module turns text into
immutable command values and nothing else; :mod:`drake_sot.diagrams.script_session`
gives them their meaning on a Drake diagram.

Grammar (one command per line; ``#`` outside a string starts a comment that runs to the
end of the line; spaces and tabs separate tokens)::

    line     := [command] [comment]
    command  := "new" CLASS NAME               -> New
              | "destroy" NAME                 -> Destroy
              | "plug" SIGNAL SIGNAL           -> Plug (output, then input)
              | "set" SIGNAL value             -> Set
              | "get" SIGNAL                   -> Get
              | "run" (FILE | DURATION)        -> Run (a word or a string) | RunFor (a number > 0)
              | NAME "." NAME value*           -> Call (entity, command, arguments)
    SIGNAL   := NAME "." NAME                  (entity, signal)
    NAME     := [A-Za-z_][A-Za-z0-9_]*         (at most MAX_NAME = 128 characters: a task name keys logs)
    value    := number | vector | matrix | string | verb | word
    number   := [+-] (digits ["." digits] | "." digits) [(e|E) [+-] digits]   finite, within
                float range (±1.8e308, an integer too); an int without "." or exponent
    vector   := "[" n "]" "(" number {"," number} ")"                   exactly n >= 1 numbers
    matrix   := "[" r "," c "]" "(" row {"," row} ")"                     r rows of c numbers
    row      := "(" number {"," number} ")"
    string   := '"' {character | '\\"' | '\\\\'} '"'
    verb     := ":" NAME                       (``:singlesupporttime``)
    word     := [A-Za-z_./] [A-Za-z0-9_./-]*   (a name, or a file name such as ``graph.dot``)

Inside the brackets of a vector or a matrix, spaces may separate the parts:
``[3](0, -0, 0.64)`` is ``[3](0,-0,0.64)``. The keywords ``new``, ``destroy``, ``plug``,
``set``, ``get`` and ``run`` start a command only as its first word.

Values: a number is an ``int`` or a ``float``; a vector a :class:`Vector`, a matrix a
:class:`Matrix`, a string a ``str``, a verb a :class:`Verb`, a word a :class:`Name`.
:func:`format_value` writes any of them back in this syntax, and ``str(command)`` gives a
command's canonical text: parsing it again gives the same value.

Errors: everything that is not in the grammar raises :class:`ScriptError` (a
ValueError) with the source, line and column (1-based) where the text departs from the
grammar, what was expected there and what was found. Nothing else is raised, whatever
the text (tested with arbitrary strings).

Example::

    parse_line("set featureComDes.errorIN [3](0,-0,0.64)")
    # Set(signal=Signal('featureComDes', 'errorIN'), value=Vector((0.0, -0.0, 0.64)))
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from drake_sot import stack
from drake_sot.errors import DrakeSotError

__all__ = [
    "KEYWORDS",
    "Call",
    "ScriptCommand",
    "Destroy",
    "Get",
    "Matrix",
    "Name",
    "New",
    "Plug",
    "Run",
    "RunFor",
    "ScriptError",
    "Set",
    "Signal",
    "Statement",
    "Value",
    "Vector",
    "Verb",
    "format_value",
    "parse_line",
    "parse_script",
    "parse_value",
    "stack_command",
]

#: The words that start a command of their own (not an ``ENTITY.COMMAND`` call).
KEYWORDS = ("new", "destroy", "plug", "set", "get", "run")

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\Z")
_INTEGER = re.compile(r"[+-]?[0-9]+\Z")
_DIGITS = re.compile(r"[0-9]+\Z")
_WORD = re.compile(r"[A-Za-z_./][A-Za-z0-9_./-]*\Z")
_ATOM_CHARS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_./+-")
_BLANK = " \t"
_FOUND_MAX = 30  # characters of the offending text quoted in a message
#: The longest name of an entity or a signal [characters]: a task is an entity, and its name keys
#: the run's logs (:data:`drake_sot.stack.MAX_TASK_NAME`); one bound for every name.
MAX_NAME = stack.MAX_TASK_NAME
FLOAT_BITS = 1024  # an integer of more bits is beyond float range (±1.8e308)


class ScriptError(DrakeSotError, ValueError):
    """Text that is not in the script grammar.

    Attributes:
        source: the script's name (a file name, or ``"<script>"``).
        line: the line number, from 1.
        column: the column where the text departs from the grammar, from 1 (one past the
            end of the line when the line ends too early).
        expected: what the grammar allows there, in words.
        found: what is there instead (quoted), or ``"end of line"``.

    ``str(error)`` is ``"<source>, line L, column C: expected <expected>, found <found>"``.
    """

    def __init__(self, expected: str, found: str, *, line: int, column: int, source: str) -> None:
        self.source = source
        self.line = line
        self.column = column
        self.expected = expected
        self.found = found
        super().__init__(f"{source}, line {line}, column {column}: expected {expected}, found {found}")


# ---------------------------------------------------------------------------------------
# Values
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Name:
    """A bare word: an entity's name (``set featureCom.sdes featureComDes``), a frame's
    name, a task's name, or a file name (``pool.writegraph graph.dot``)."""

    text: str

    def __post_init__(self) -> None:
        # What prints as ``text`` must parse back as this Name: a bare word, not a number.
        if not isinstance(self.text, str) or not _WORD.match(self.text) or _NUMBER.match(self.text):
            raise ValueError(
                f"Name({self.text!r}): not a bare word (letters, digits, _ . / -, not a number; "
                "quote other text as a string)"
            )

    def __str__(self) -> str:
        return self.text


@dataclass(frozen=True)
class Verb:
    """A ``:verb`` token, as in ``pg.parsecmd :singlesupporttime 0.780``; ``name`` without the colon."""

    name: str

    def __str__(self) -> str:
        return ":" + self.name


@dataclass(frozen=True)
class Vector:
    """The paper's vector ``[n](v1,…,vn)``: its ``values`` (floats, n >= 1)."""

    values: tuple[float, ...]

    @property
    def array(self) -> np.ndarray:
        """The values as a float array (n,)."""
        return np.array(self.values, dtype=float)

    def __str__(self) -> str:
        return f"[{len(self.values)}]({','.join(map(_number_text, self.values))})"


@dataclass(frozen=True)
class Matrix:
    """A matrix ``[r,c]((a,b,…),…)``: its ``rows`` (r tuples of c floats, r, c >= 1)."""

    rows: tuple[tuple[float, ...], ...]

    @property
    def array(self) -> np.ndarray:
        """The values as a float array (r, c)."""
        return np.array(self.rows, dtype=float)

    def __str__(self) -> str:
        rows = ",".join(f"({','.join(map(_number_text, row))})" for row in self.rows)
        return f"[{len(self.rows)},{len(self.rows[0])}]({rows})"


Value = int | float | str | Name | Verb | Vector | Matrix


def _number_text(x: float) -> str:
    """The shortest text that reads back as ``x`` (``repr``); integers without ``.0``; an integer
    beyond float range (which no script can hold: the parser refuses it) described by its digits,
    as ``str`` would raise past 4300 of them."""
    if isinstance(x, int):
        if x.bit_length() > FLOAT_BITS:
            return f"<{'-' if x < 0 else ''}an integer of {x.bit_length()} bits, beyond float range>"
        return str(x)
    return repr(float(x))


def _string_text(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def format_value(value: Value) -> str:
    """``value`` in the script's syntax (what :func:`parse_value` reads back to an equal value).

    Numbers, vectors and matrices are written with the shortest text that reads back as
    the same floats; a ``str`` is quoted. Non-finite numbers are written ``nan``/``inf``, and an
    integer beyond float range as a description of its size, which the grammar does not read (a
    script cannot ``set`` them).
    """
    if isinstance(value, bool):
        raise TypeError(f"{value!r} is not a script value")
    if isinstance(value, (int, float)):
        return _number_text(value)
    if isinstance(value, str):
        return _string_text(value)
    if isinstance(value, (Name, Verb, Vector, Matrix)):
        return str(value)
    raise TypeError(f"{value!r} is not a script value")


# ---------------------------------------------------------------------------------------
# Commands
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Signal:
    """``ENTITY.SIGNAL``: a signal of an entity (an input or output port, or a parameter)."""

    entity: str
    name: str

    def __str__(self) -> str:
        return f"{self.entity}.{self.name}"


@dataclass(frozen=True)
class New:
    """``new CLASS NAME``: create an entity of a class."""

    cls: str
    name: str

    def __str__(self) -> str:
        return f"new {self.cls} {self.name}"


@dataclass(frozen=True)
class Destroy:
    """``destroy NAME``: remove an entity."""

    name: str

    def __str__(self) -> str:
        return f"destroy {self.name}"


@dataclass(frozen=True)
class Plug:
    """``plug A.OUT B.IN``: feed the input signal ``target`` from the output signal ``source``."""

    source: Signal
    target: Signal

    def __str__(self) -> str:
        return f"plug {self.source} {self.target}"


@dataclass(frozen=True)
class Set:
    """``set E.SIG VALUE``: give a signal a value (or, with a :class:`Name`, another entity's)."""

    signal: Signal
    value: Value

    def __str__(self) -> str:
        return f"set {self.signal} {format_value(self.value)}"


@dataclass(frozen=True)
class Get:
    """``get E.SIG``: read a signal's value."""

    signal: Signal

    def __str__(self) -> str:
        return f"get {self.signal}"


@dataclass(frozen=True)
class Call:
    """``E.COMMAND ARG…``: an entity's command with its arguments."""

    entity: str
    command: str
    args: tuple[Value, ...] = ()

    def __str__(self) -> str:
        return " ".join([f"{self.entity}.{self.command}", *map(format_value, self.args)])


def stack_command(call: Call) -> stack.StackCommand:
    """The stack command of a script call ``SOT.VERB [TASK] [SECONDS]`` (``sot.push taskLH 0.5``):
    its words (a name or a quoted string for a task) and values given to
    :func:`drake_sot.stack.parse_command`, the one parser of stack commands.

    The paper's commands take their task name, if any (``sot.push taskLH``, ``sot.pop``); this
    dialect also accepts a transition time in seconds after it (``sot.push taskLH 0.5``,
    ``sot.clear 1``): the change is then blended over that time
    (:class:`drake_sot.stack.StackTransition`), instead of made at once (no time, or 0).

    Raises:
        drake_sot.stack.StackError: as :func:`~drake_sot.stack.parse_command` (an unknown verb,
            a wrong number of values, a task that is not a name, a time that is not a number in
            [0, :data:`~drake_sot.stack.MAX_TRANSITION`] s).
    """
    return stack.parse_command(call.command, tuple(a.text if isinstance(a, Name) else a for a in call.args))


@dataclass(frozen=True)
class Run:
    """``run FILE``: play the script in ``path``."""

    path: str

    def __str__(self) -> str:
        # A bare word that also reads as a number (``.0``, ``.5``) would come back as a duration.
        bare = _WORD.match(self.path) and not _NUMBER.match(self.path)
        return f"run {self.path if bare else _string_text(self.path)}"


@dataclass(frozen=True)
class RunFor:
    """``run DURATION``: let the controlled robot run for ``duration`` seconds (finite, > 0)."""

    duration: float

    def __str__(self) -> str:
        return f"run {_number_text(self.duration)}"


ScriptCommand = New | Destroy | Plug | Set | Get | Call | Run | RunFor


@dataclass(frozen=True)
class Statement:
    """A parsed line: its ``command``, where it comes from (``source``, ``line`` from 1) and its
    ``text`` (the line without its comment)."""

    command: ScriptCommand
    line: int
    source: str
    text: str

    @property
    def where(self) -> str:
        """``"<source>, line <n>"``, for messages."""
        return f"{self.source}, line {self.line}"


# ---------------------------------------------------------------------------------------
# The lexer
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Token:
    kind: str  # "atom" | "string" | "verb" | "vector" | "matrix"
    text: str  # the token's text as written
    column: int  # 1-based
    value: object = None  # the parsed value (number, str, Verb, Vector, Matrix); None for a word


class _Lexer:
    """Turns one line into tokens; raises ScriptError at the first character out of the grammar."""

    def __init__(self, text: str, line: int, source: str) -> None:
        self.text = text
        self.line = line
        self.source = source
        self.i = 0

    # --- errors -------------------------------------------------------------------
    def error(self, expected: str, at: int | None = None, found: str | None = None) -> ScriptError:
        at = self.i if at is None else at
        if found is None:
            found = _describe(self.text[at : at + 1]) if at < len(self.text) else "end of line"
        return ScriptError(expected, found, line=self.line, column=at + 1, source=self.source)

    # --- scanning -------------------------------------------------------------------
    def peek(self) -> str:
        return self.text[self.i] if self.i < len(self.text) else ""

    def skip_blanks(self) -> None:
        while self.i < len(self.text) and self.text[self.i] in _BLANK:
            self.i += 1

    def tokens(self) -> list[_Token]:
        out: list[_Token] = []
        while True:
            self.skip_blanks()
            c = self.peek()
            if c in ("", "#"):
                return out
            start = self.i
            if c == '"':
                value = self.string()
                out.append(_Token("string", self.text[start : self.i], start + 1, value))
            elif c == ":":
                self.i += 1
                name = self.atom()
                if not _NAME.match(name):
                    raise self.error("a verb name after ':' (letters, digits, _)", start + 1)
                out.append(_Token("verb", ":" + name, start + 1, Verb(name)))
            elif c == "[":
                out.append(self.bracketed())
            elif c in _ATOM_CHARS:
                text = self.atom()
                out.append(_Token("atom", text, start + 1, _atom_value(text, self, start)))
            else:
                raise self.error("a name, a number, a vector '[n](…)', a string '\"…\"' or a ':verb'")
            self.text_after_token(start)

    def text_after_token(self, start: int) -> None:
        """A token ends at a blank, a comment or the end of the line."""
        c = self.peek()
        if c not in ("", "#") and c not in _BLANK:
            raise self.error("a space, a '#' comment or the end of the line after this value")

    def atom(self) -> str:
        start = self.i
        while self.i < len(self.text) and self.text[self.i] in _ATOM_CHARS:
            self.i += 1
        return self.text[start : self.i]

    def string(self) -> str:
        start = self.i
        self.i += 1
        chars: list[str] = []
        while True:
            c = self.peek()
            if c == "":
                raise self.error(f"a closing '\"' for the string opened at column {start + 1}")
            if c == '"':
                self.i += 1
                return "".join(chars)
            if c == "\\":
                nxt = self.text[self.i + 1 : self.i + 2]
                if nxt not in ('"', "\\"):
                    raise self.error("'\\\"' or '\\\\' (the only escapes in a string)")
                chars.append(nxt)
                self.i += 2
                continue
            chars.append(c)
            self.i += 1

    def number(self, what: str) -> float:
        """A number inside brackets (as a float)."""
        self.skip_blanks()
        start = self.i
        text = self.atom()
        if not text:
            raise self.error(what)
        if not _NUMBER.match(text):
            raise self.error(what, start, _describe(text))
        return _finite(text, self, start)

    def size(self) -> int:
        self.skip_blanks()
        start = self.i
        text = self.atom()
        digits = text.lstrip("0")
        if not _DIGITS.match(text) or not digits:
            raise self.error("a size (an integer >= 1)", start, _describe(text) if text else None)
        if len(digits) > 9:
            raise self.error("a size of at most 9 digits", start, _describe(text))
        return int(digits)

    def expect(self, char: str, expected: str) -> None:
        self.skip_blanks()
        if self.peek() != char:
            raise self.error(expected)
        self.i += 1

    def numbers(self, n: int, what: str) -> tuple[float, ...]:
        """``(x1,…,xn)``: exactly ``n`` numbers."""
        self.expect("(", f"'(' to open the {n} values of {what}")
        values = [self.number(f"a number (entry 1 of {n} of {what})")]
        while True:
            self.skip_blanks()
            c = self.peek()
            if c == ")":
                if len(values) != n:
                    raise self.error(f"',' and {n - len(values)} more number(s): {what} has {n}")
                self.i += 1
                return tuple(values)
            if c != ",":
                raise self.error(f"',' or ')' after entry {len(values)} of {what}")
            if len(values) == n:
                raise self.error(f"')': {what} has {n} entries")
            self.i += 1
            values.append(self.number(f"a number (entry {len(values) + 1} of {n} of {what})"))

    def bracketed(self) -> _Token:
        start = self.i
        self.i += 1
        dims = [self.size()]
        self.skip_blanks()
        if self.peek() == ",":
            self.i += 1
            dims.append(self.size())
        self.expect("]", "']' (a vector is [n](…), a matrix [rows,columns]((…),…))")
        self.skip_blanks()
        if len(dims) == 1:
            value: Vector | Matrix = Vector(self.numbers(dims[0], f"the vector [{dims[0]}]"))
            kind = "vector"
        else:
            r, c = dims
            self.expect("(", f"'(' to open the {r} rows of the matrix [{r},{c}]")
            rows = [self.numbers(c, f"row 1 of the matrix [{r},{c}]")]
            while True:
                self.skip_blanks()
                ch = self.peek()
                if ch == ")":
                    if len(rows) != r:
                        raise self.error(f"',' and {r - len(rows)} more row(s): the matrix [{r},{c}] has {r}")
                    self.i += 1
                    break
                if ch != ",":
                    raise self.error(f"',' or ')' after row {len(rows)} of the matrix [{r},{c}]")
                if len(rows) == r:
                    raise self.error(f"')': the matrix [{r},{c}] has {r} rows")
                self.i += 1
                rows.append(self.numbers(c, f"row {len(rows) + 1} of the matrix [{r},{c}]"))
            value = Matrix(tuple(rows))
            kind = "matrix"
        return _Token(kind, self.text[start : self.i], start + 1, value)


def _describe(text: str) -> str:
    """Quote the offending text for a message (shortened; control characters by code point)."""
    if len(text) == 1 and not text.isprintable():
        return f"character U+{ord(text):04X}"
    if len(text) > _FOUND_MAX:
        text = text[:_FOUND_MAX] + "…"
    return repr(text)


def _finite(text: str, lexer: _Lexer, start: int) -> float:
    value = float(text)  # the text matched _NUMBER: float() reads it
    if not math.isfinite(value):
        raise lexer.error("a finite number", start, _describe(text))
    return value


def _atom_value(text: str, lexer: _Lexer, start: int) -> int | float | None:
    """A number's value, None for a word; ScriptError for an atom that is neither."""
    if _INTEGER.match(text):
        try:
            value = int(text)
            float(value)  # every number of the dialect is a float somewhere: refuse one beyond range now
        except ValueError:  # beyond Python's limit on the digits of an int read from text
            raise lexer.error("a number of at most 4300 digits", start, _describe(text)) from None
        except OverflowError:
            raise lexer.error("a number within float range (±1.8e308)", start, _describe(text)) from None
        return value
    if _NUMBER.match(text):
        return _finite(text, lexer, start)
    if text[0] in "0123456789+-":
        raise lexer.error("a number", start, _describe(text))
    if not _WORD.match(text):  # '+' inside a word
        plus = start + text.index("+")
        raise lexer.error("a name or a file name (letters, digits, _ . / -)", plus)
    return None


# ---------------------------------------------------------------------------------------
# The parser
# ---------------------------------------------------------------------------------------


class _Parser:
    def __init__(self, text: str, line: int, source: str) -> None:
        for i, c in enumerate(text):
            if c != "\t" and not c.isprintable():
                raise ScriptError("printable text", _describe(c), line=line, column=i + 1, source=source)
        self.lexer = _Lexer(text, line, source)
        self.tokens = self.lexer.tokens()
        self.k = 0

    def error(self, expected: str, token: _Token | None = None) -> ScriptError:
        """Expected ``expected`` at ``token`` (default: the next one; past the last: end of line)."""
        if token is None and self.k < len(self.tokens):
            token = self.tokens[self.k]
        lexer = self.lexer
        if token is None:
            last = self.tokens[-1] if self.tokens else None
            column = last.column + len(last.text) if last else 1
            return ScriptError(expected, "end of line", line=lexer.line, column=column, source=lexer.source)
        return ScriptError(
            expected, _describe(token.text), line=lexer.line, column=token.column, source=lexer.source
        )

    def next(self, expected: str) -> _Token:
        if self.k >= len(self.tokens):
            raise self.error(expected)
        token = self.tokens[self.k]
        self.k += 1
        return token

    def name(self, expected: str) -> str:
        token = self.next(expected)
        if token.kind != "atom" or token.value is not None or not _NAME.match(token.text):
            raise self.error(expected, token)
        if len(token.text) > MAX_NAME:
            raise self.error(f"{expected}, of at most {MAX_NAME} characters", token)
        return token.text

    def signal(self, expected: str) -> Signal:
        token = self.next(expected)
        parts = token.text.split(".") if token.kind == "atom" and token.value is None else []
        if len(parts) != 2 or not all(_NAME.match(p) for p in parts):
            raise self.error(expected, token)
        if max(len(p) for p in parts) > MAX_NAME:
            raise self.error(f"{expected}, each name of at most {MAX_NAME} characters", token)
        return Signal(parts[0], parts[1])

    def value(self, expected: str) -> Value:
        token = self.next(expected)
        if token.kind == "atom" and token.value is None:
            return Name(token.text)
        return token.value  # a number, a str, a Verb, a Vector or a Matrix

    def done(self) -> None:
        if self.k < len(self.tokens):
            raise self.error("the end of the line (or a '#' comment)")

    def command(self) -> ScriptCommand | None:
        if not self.tokens:
            return None
        first = self.tokens[0]
        expected_command = "a command: new, destroy, plug, set, get, run or ENTITY.COMMAND"
        if first.kind != "atom" or first.value is not None:
            raise self.error(expected_command, first)
        word = first.text
        self.k = 1
        if word == "new":
            cls = self.name("a class name (e.g. FeatureGeneric)")
            command: ScriptCommand = New(cls, self.name("the new entity's name (letters, digits, _)"))
        elif word == "destroy":
            command = Destroy(self.name("the name of the entity to destroy"))
        elif word == "plug":
            source = self.signal("an output signal ENTITY.SIGNAL")
            command = Plug(source, self.signal("an input signal ENTITY.SIGNAL"))
        elif word == "set":
            signal = self.signal("a signal ENTITY.SIGNAL")
            command = Set(signal, self.value("a value (a number, a vector [n](…), a name, …)"))
        elif word == "get":
            command = Get(self.signal("a signal ENTITY.SIGNAL"))
        elif word == "run":
            command = self.run()
        else:
            parts = word.split(".")
            if len(parts) != 2 or not all(_NAME.match(p) for p in parts):
                raise self.error(expected_command, first)
            args = []
            while self.k < len(self.tokens):
                args.append(self.value("an argument"))
            command = Call(parts[0], parts[1], tuple(args))
        self.done()
        return command

    def run(self) -> Run | RunFor:
        expected = "a script file name or a duration [s] > 0"
        token = self.next(expected)
        if token.kind == "string" and token.value:
            return Run(token.value)
        if token.kind == "atom" and token.value is None:
            return Run(token.text)
        if token.kind == "atom" and token.value > 0:  # a finite number
            return RunFor(float(token.value))
        raise self.error(expected, token)


def parse_line(text: str, *, line: int = 1, source: str = "<script>") -> ScriptCommand | None:
    """The command on one line of script, or None for a blank or comment line.

    Raises:
        ScriptError: the line is not in the grammar (see the module docstring); the error
            carries ``source``, ``line`` and the column.
    """
    return _Parser(text, line, source).command()


def _statement(text: str, line: int, source: str) -> Statement | None:
    parser = _Parser(text, line, source)
    command = parser.command()
    if command is None:
        return None
    code = text[: parser.lexer.i].strip(_BLANK)  # the lexer stopped at the comment or the end
    return Statement(command, line, source, code)


#: The source of a command given alone, not read from a file (a shell's or a remote client's line,
#: :meth:`~drake_sot.diagrams.script_session.ScriptSession.execute` given a string): its messages
#: name the line's text, not a source and a line number.
COMMAND_SOURCE = "<command>"


def parse_script(text: str, *, source: str = "<script>") -> tuple[Statement, ...]:
    """The statements of a script, in order (blank and comment lines skipped).

    Lines end at ``\\n`` (a ``\\r`` before it is dropped); numbered from 1.

    Raises:
        ScriptError: at the first line out of the grammar.
    """
    statements = []
    for number, raw in enumerate(text.split("\n"), start=1):
        statement = _statement(raw[:-1] if raw.endswith("\r") else raw, number, source)
        if statement is not None:
            statements.append(statement)
    return tuple(statements)


def parse_value(text: str, *, source: str = "<value>") -> Value:
    """One value written in the script's syntax (e.g. the text of ``get``); ScriptError otherwise."""
    parser = _Parser(text, 1, source)
    value = parser.value("a value (a number, a vector [n](…), a matrix, a string, a name, a :verb)")
    parser.done()
    return value
