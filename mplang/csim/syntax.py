"""Reading CSIM command lines: `.csim` files and the lines a host sends to the device.

A line is one of: a label definition (`$NAME` alone), a command with its operands
(`MA 1000`, `T2MR R3`, `JE 5,N1,$LOOP`, `SET EV1 NZ,N0`), an assignment (`N3=5`,
`R1=R1*2.5`, `T2PR3=200`, `TVM=300`) or a query (`?PE`, `?t1err`, `?N3`). The syntax is
the manual's command list read literally; where it is silent the readings are in
stdlib/csim/device.toml ([program] label and comment choices). Parsing never raises: a line
that does not read becomes a diagnostic (E701) and is skipped.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from mplang.lang.diagnostics import DiagnosticSink, Span
from mplang.lang.limits import long_number

COMMENT = "#"
LABEL_LINE = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")
HEAD = re.compile(r"(?:[Tt](\d+)(?=[0-9]?[A-Za-z]))?([0-9]?[A-Za-z][A-Za-z0-9]*)")
TOKEN = re.compile(r"""
    (?P<space>\s+)
  | (?P<comma>,)
  | (?P<string>"[^"]*")
  | (?P<label>\$[A-Za-z_][A-Za-z0-9_]*)
  | (?P<array>(?:NS|RS|ns|rs|Ns|nS|Rs|rS)\(\s*\d+\s*\))
  | (?P<number>[+-]?(?:\d+\.?\d*|\.\d+))
  | (?P<word>[A-Za-z_][A-Za-z0-9_]*)
""", re.VERBOSE)
ARRAY = re.compile(r"([NRnr][Ss])\(\s*(\d+)\s*\)")
SCALAR_VAR = re.compile(r"([NRnr])(\d+)")
PORT = re.compile(r"[Pp](\d+)")
EVENT = re.compile(r"[Ee][Vv](\d+)")
OPERATORS = "+-*/"
# Commands written as two words: the second word is part of the name (SET EV1 carries the
# event number, which stays an operand).
TWO_WORD = {"CLR": {"BUF"}, "SAVE": {"D", "C", "P"}, "RESET": {"H"}, "SET": {"EV"},
            "ON": {"EV"}}


@dataclass(frozen=True)
class Operand:
    """One operand as written. kind: number, nvar, rvar, nsvar, rsvar, label, port, event,
    word or string; `value` is the number, the variable index, the port or event number."""

    kind: str
    text: str
    span: Span
    value: float = 0.0

    @property
    def is_variable(self) -> bool:
        return self.kind in ("nvar", "rvar", "nsvar", "rsvar")

    @property
    def is_integer_variable(self) -> bool:
        return self.kind in ("nvar", "nsvar")

    @property
    def index(self) -> int:
        return int(self.value)

    @property
    def integral(self) -> bool:
        return self.kind == "number" and float(self.value).is_integer() and "." not in self.text

    @property
    def canonical(self) -> str:
        """Upper-case spelling of a variable, label or word (names are case-insensitive)."""
        if self.kind == "nsvar":
            return f"NS({self.index})"
        if self.kind == "rsvar":
            return f"RS({self.index})"
        if self.kind == "string":
            return self.text
        return self.text.upper()


@dataclass
class Statement:
    """One program line. kind: label, command, assign or query. `name` is upper case: the
    label (without `$`), the command ("MA", "SET EV"), the assigned variable or parameter
    ("N3", "NS", "PR3") or the query ("PE")."""

    kind: str
    text: str
    span: Span
    name: str
    name_span: Span
    prefix: int | None = None
    operands: tuple[Operand, ...] = ()
    target: Operand | None = None  # assignments: the variable (None for a parameter)
    operator: str | None = None  # assignments: + - * / between operands[0] and operands[1]

    @property
    def is_parameter_assignment(self) -> bool:
        return self.kind == "assign" and self.target is None


@dataclass
class Script:
    """One CSIM program: a `.csim` file, or the program held by a device."""

    name: str
    source: str
    statements: list[Statement] = field(default_factory=list)
    file_lines: list[str] = field(default_factory=list)

    @property
    def labels(self) -> dict[str, int]:
        """Label name -> address (the first definition wins; duplicates are E709)."""
        found: dict[str, int] = {}
        for address, statement in enumerate(self.statements):
            if statement.kind == "label":
                found.setdefault(statement.name, address)
        return found

    @property
    def texts(self) -> list[str]:
        return [s.text for s in self.statements]


class LineError(Exception):
    def __init__(self, col: int, message: str, hint: str = "") -> None:
        super().__init__(message)
        self.col = col
        self.message = message
        self.hint = hint


def strip_comment(text: str) -> str:
    """The line without its `#` comment (a `#` inside a quoted string does not count)."""
    quoted = False
    for i, char in enumerate(text):
        if char == '"':
            quoted = not quoted
        elif char == COMMENT and not quoted:
            return text[:i]
    return text


def parse_line(text: str, file: str, line: int, sink: DiagnosticSink) -> Statement | None:
    """One line (comment already allowed), or None for a blank line or a line in error."""
    body = strip_comment(text).rstrip()
    stripped = body.lstrip()
    if not stripped:
        return None
    offset = len(body) - len(stripped)
    too_long = long_number(body)
    if too_long is not None:  # before any int(): Python converts 4,300 digits at most
        sink.add("E108", Span(file, line, too_long[0] + 1), too_long[1],
                 hint="write the value the CSIM should hold")
        return None
    try:
        return _statement(stripped, file, line, offset)
    except LineError as err:
        sink.add("E701", Span(file, line, err.col + 1), err.message, hint=err.hint)
        return None


def parse_text(text: str, name: str, source: str, sink: DiagnosticSink) -> Script:
    script = Script(name, source, file_lines=text.splitlines())
    for number, line_text in enumerate(script.file_lines, start=1):
        statement = parse_line(line_text, source, number, sink)
        if statement is not None:
            script.statements.append(statement)
    return script


def parse_file(path: Path, sink: DiagnosticSink, display: str | None = None) -> Script | None:
    """A `.csim` file; None (with E701 at line 1) if it cannot be read as UTF-8 text."""
    shown = display or str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        sink.add("E701", Span(shown, 1), f"not UTF-8 text: {exc.reason} at byte {exc.start}",
                 hint="save the file as UTF-8 text")
        return None
    except OSError as exc:
        sink.add("E701", Span(shown, 1), f"cannot read {shown}: {exc.strerror or exc}")
        return None
    return parse_text(text, path.stem, shown, sink)


# ----------------------------------------------------------------------------- internals


def _statement(text: str, file: str, line: int, offset: int) -> Statement:
    def span(start: int, end: int) -> Span:
        return Span(file, line, offset + start + 1, offset + end + 1)

    whole = span(0, len(text))
    if text.startswith("$"):
        match = LABEL_LINE.fullmatch(text)
        if match is None:
            raise LineError(offset, f"a label line holds only $NAME, not {text!r}",
                            "write the label on a line of its own: $NAME")
        return Statement("label", text, whole, match.group(1).upper(), span(0, len(text)))
    if text.startswith("?"):
        return _query(text, span, whole, offset)
    head = HEAD.match(text)
    if head is None:
        raise LineError(offset, f"a command starts with its name, not {text[0]!r}")
    prefix = int(head.group(1)) if head.group(1) is not None else None
    name = head.group(2).upper()
    name_span = span(head.start(2), head.end(2))
    rest_at = head.end()
    after = text[rest_at:].lstrip()
    if name in ("NS", "RS") and after.startswith("("):
        return _array_assignment(text, prefix, span, whole, offset)
    if after.startswith("="):
        value_at = text.index("=", rest_at) + 1
        return _assignment(text, prefix, name, name_span, value_at, span, whole, offset)
    tokens = _tokens(text, rest_at, offset)
    words = TWO_WORD.get(name, set())
    if tokens and tokens[0][0] == "word":
        second = tokens[0][1].upper()
        if second in words:
            name = f"{name} {second}"
            name_span = span(head.start(2), tokens[0][3])
            tokens = tokens[1:]
    if tokens and tokens[0][0] == "event" and "EV" in words:
        name = f"{name} EV"
    operands = _operands(tokens, span, offset)
    return Statement("command", text, whole, name, name_span, prefix, operands)


Token = tuple[str, str, int, int]  # kind, text, start, end (in the stripped line)


def _tokens(text: str, start: int, offset: int) -> list[Token]:
    found: list[Token] = []
    pos = start
    while pos < len(text):
        match = TOKEN.match(text, pos)
        if match is None:
            raise LineError(offset + pos, f"unexpected character {text[pos]!r}")
        kind = match.lastgroup
        assert kind is not None
        if kind != "space":
            found.append((_classify(kind, match.group()), match.group(), match.start(),
                          match.end()))
        pos = match.end()
    return found


def _classify(kind: str, text: str) -> str:
    if kind != "word":
        return kind
    if SCALAR_VAR.fullmatch(text):
        return "var"
    if PORT.fullmatch(text):
        return "port"
    if EVENT.fullmatch(text):
        return "event"
    return "word"


def _operand(token: Token, span_of: object) -> Operand:
    kind, text, start, end = token
    assert callable(span_of)
    span: Span = span_of(start, end)
    if kind == "number":
        return Operand("number", text, span, float(text))
    if kind == "var":
        match = SCALAR_VAR.fullmatch(text)
        assert match is not None
        return Operand("nvar" if match.group(1).upper() == "N" else "rvar", text, span,
                       int(match.group(2)))
    if kind == "array":
        match = ARRAY.fullmatch(text)
        assert match is not None
        return Operand("nsvar" if match.group(1).upper() == "NS" else "rsvar", text, span,
                       int(match.group(2)))
    if kind == "port":
        return Operand("port", text, span, int(text[1:]))
    if kind == "event":
        return Operand("event", text, span, int(text[2:]))
    if kind == "string":
        return Operand("string", text, span)
    if kind == "label":
        return Operand("label", text, span)
    return Operand("word", text, span)


def _operands(tokens: list[Token], span_of: object, offset: int) -> tuple[Operand, ...]:
    """Operands separated by commas (a blank also separates, as in `SET EV1 NZ,N0`)."""
    operands: list[Operand] = []
    expect_operand = True
    last_comma = -1
    for token in tokens:
        if token[0] == "comma":
            if expect_operand:
                raise LineError(offset + token[2], "an operand is missing before this comma")
            expect_operand = True
            last_comma = token[2]
            continue
        operands.append(_operand(token, span_of))
        expect_operand = False
    if expect_operand and operands:
        raise LineError(offset + last_comma, "an operand is missing after the last comma")
    if expect_operand and last_comma >= 0:
        raise LineError(offset + last_comma, "an operand is missing before this comma")
    return tuple(operands)


def _single_value(text: str, start: int, span_of: object, offset: int) -> Operand:
    """The right side of `=` when it holds no operator: exactly one value."""
    tokens = _tokens(text, start, offset)
    if not tokens:
        raise LineError(offset + start, "a value is missing after '='")
    first = tokens[0]
    if first[0] in ("comma", "label", "port", "event"):
        raise LineError(offset + first[2], f"{first[1]!r} is not a value")
    if len(tokens) > 1:
        extra = tokens[1]
        raise LineError(offset + extra[2], "expected an operator + - * / or the end of the "
                        f"line, not {extra[1]!r}")
    return _operand(first, span_of)


def _assignment(text: str, prefix: int | None, name: str, name_span: Span, value_at: int,
                span_of: object, whole: Span, offset: int) -> Statement:
    operands, op = _split_expression(text, value_at, span_of, offset)
    var = SCALAR_VAR.fullmatch(name)
    target = None
    if var is not None:
        if prefix is not None:
            raise LineError(offset, "variables take no module prefix")
        kind = "nvar" if var.group(1) == "N" else "rvar"
        target = Operand(kind, name, name_span, int(var.group(2)))
    return Statement("assign", text, whole, name, name_span, prefix, operands, target, op)


def _array_assignment(text: str, prefix: int | None, span_of: object, whole: Span,
                      offset: int) -> Statement:
    match = ARRAY.match(text)
    if match is None:
        raise LineError(offset, "an array element is written NS(i) or RS(i) with a number i")
    if prefix is not None:
        raise LineError(offset, "variables take no module prefix")
    assert callable(span_of)
    target_span: Span = span_of(match.start(), match.end())
    after = text[match.end():].lstrip()
    if not after.startswith("="):
        raise LineError(offset + match.end(), "expected '=' after the array element")
    kind = "nsvar" if match.group(1).upper() == "NS" else "rsvar"
    target = Operand(kind, match.group(), target_span, int(match.group(2)))
    value_at = text.index("=", match.end()) + 1
    operands, op = _split_expression(text, value_at, span_of, offset)
    return Statement("assign", text, whole, match.group(1).upper(), target_span, None, operands,
                     target, op)


def _split_expression(text: str, start: int, span_of: object, offset: int
                      ) -> tuple[tuple[Operand, ...], str | None]:
    """The right side of `=`: one value, or two joined by one of + - * /."""
    assert callable(span_of)
    body = text[start:]
    # a binary operator after the first operand (a sign right after '=' belongs to the number)
    first = TOKEN.match(text, start)
    pos = start
    while first is not None and first.lastgroup == "space":
        pos = first.end()
        first = TOKEN.match(text, pos)
    if first is None or first.lastgroup in ("comma",):
        raise LineError(offset + pos, "a value is missing after '='" if not body.strip()
                        else f"{text[pos:pos + 1]!r} does not start a value")
    after_first = first.end()
    rest = text[after_first:]
    stripped = rest.lstrip()
    if stripped and stripped[0] in OPERATORS:
        op_at = after_first + (len(rest) - len(stripped))
        left_tokens = _tokens(text[:op_at], start, offset)
        right_tokens = _tokens(text, op_at + 1, offset)
        if len(left_tokens) != 1 or len(right_tokens) != 1:
            bad = (left_tokens + right_tokens)[1:] if len(left_tokens) != 1 else right_tokens[1:]
            where = bad[0][2] if bad else op_at + 1
            raise LineError(offset + where, "one operator between two values at most"
                            if bad else "a value is missing after the operator")
        for token in (*left_tokens, *right_tokens):
            if token[0] in ("comma", "label", "port", "event", "string"):
                raise LineError(offset + token[2], f"{token[1]!r} is not a value")
        return ((_operand(left_tokens[0], span_of), _operand(right_tokens[0], span_of)),
                stripped[0])
    return (_single_value(text, start, span_of, offset),), None


def _query(text: str, span_of: object, whole: Span, offset: int) -> Statement:
    assert callable(span_of)
    head = HEAD.match(text, 1)
    if head is None:
        raise LineError(offset + 1, "a query is ? followed by a name, e.g. ?PE")
    prefix = int(head.group(1)) if head.group(1) is not None else None
    name = head.group(2).upper()
    name_span: Span = span_of(head.start(2), head.end(2))
    rest = text[head.end():]
    if name in ("NS", "RS") and rest.lstrip().startswith("("):
        match = ARRAY.match(text, head.start(2))
        if match is None:
            raise LineError(offset + head.start(2), "an array element is written NS(i)")
        operand = _operand(("array", match.group(), match.start(), match.end()), span_of)
        tail = _tokens(text, match.end(), offset)
        if tail:
            raise LineError(offset + tail[0][2], "unexpected text after the query")
        return Statement("query", text, whole, name, name_span, prefix, (operand,))
    operands = _operands(_tokens(text, head.end(), offset), span_of, offset)
    return Statement("query", text, whole, name, name_span, prefix, operands)
