"""`mpc import`: C programs written against the vendor API turned into `.mp` source.

A C program downloads a macro program by calling `RSM_MP_CREATE` (or `ETM_MP_CREATE`), one
`RSM_MACRO_*` function per macro line, and `RSM_MACRO_MP_CLOSE`; ISRs likewise with
`RSM_MP_ISR_CREATE` ... `RSM_MACRO_MP_ISR_CLOSE`. Every macro function takes the handle and the
slave address (card number) first, then the arguments the catalogue lists. The importer reads
the C text with a small tokenizer (no preprocessor, no compiler needed), follows that
create/close bracket, and writes each call through `mplang.ir.mpwriter`, the writer the
disassembler uses, so a call becomes the statement that compiles to exactly its frame.

What is kept: every comment (as `#` comments, beside the statement or on its own line), blank
lines, `#define NAME value` / `const` integer constants (as CONST, or ALIAS for `VARn`). C code
around the programs (includes, `main`, handles, declarations) is kept as `# C:` comment lines:
it runs on the host and has no `.mp` form. What cannot be converted is written as a
`# not converted:` comment and reported with its line: C control flow or statements inside a
program, arguments the importer cannot evaluate (C variables, calls), unknown functions,
real-time calls (inside a program the device refuses them, RS 4033; outside, they are the
host's own actions) and calls with the wrong number of arguments.
"""

from __future__ import annotations

import codecs
import difflib
import re
from collections.abc import Iterator
from dataclasses import dataclass, field

from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue, Command, Param
from mplang.ir.lower import Scope
from mplang.ir.macro import BVarRef, Operand, VarRef
from mplang.ir.mpwriter import Writer, block_role
from mplang.lang.diagnostics import DiagnosticSink

VENDOR = re.compile(r"(RSM|ETM)_\w+")
VAR_NAME = re.compile(r"VAR(\d+)", re.IGNORECASE)
BVAR_NAME = re.compile(r"bVAR(\d+)", re.IGNORECASE)
PROGRAM_NAME = re.compile(r"(MP|ISR)(\d+)")
LABEL_NAME = re.compile(r"LABEL([0-3])")
CONTROL_WORDS = frozenset({"if", "while", "for", "switch"})
LONE_CONTROL_WORDS = frozenset({"else", "do"})
JUMP_WORDS = frozenset({"return", "break", "continue", "goto"})
TYPE_WORDS = frozenset({"BYTE", "WORD", "DWORD", "long", "int", "short", "char", "unsigned",
                        "signed", "float", "double", "void", "const", "volatile", "static",
                        "LONG", "INT", "SHORT", "UINT", "ULONG", "USHORT", "bool", "BOOL"})
INDENT = "    "
LITERAL_KINDS = frozenset({"int", "enum", "bvar"})
"""Parameter kinds whose numbers keep the C spelling (hex stays hex); axes, programs,
labels and operators are spelled by name."""

TOKEN = re.compile(r"""
    (?P<nl>\r?\n)
  | (?P<ws>[ \t\f\v]+|\\\r?\n)
  | (?P<lcomment>//[^\r\n]*)
  | (?P<bcomment>/\*.*?\*/)
  | (?P<open_comment>/\*)
  | (?P<string>"(?:\\.|[^"\\\r\n])*")
  | (?P<char>'(?:\\.|[^'\\\r\n])+')
  | (?P<number>(?:0[xX][0-9a-fA-F]+|0[bB][01]+|[0-9]+\.?[0-9]*(?:[eE][+-]?[0-9]+)?
                 |\.[0-9]+(?:[eE][+-]?[0-9]+)?)[uUlLfF]*)
  | (?P<ident>[A-Za-z_][A-Za-z0-9_]*)
  | (?P<punct><<=|>>=|->|\+\+|--|<<|>>|<=|>=|==|!=|&&|\|\||[-+*/%&|^]=|::|.)
""", re.VERBOSE | re.DOTALL)


# ------------------------------------------------------------------------------ tokens
@dataclass(frozen=True)
class Token:
    kind: str  # ident number string char punct comment directive
    text: str
    line: int
    col: int
    start: int
    end: int

    @property
    def end_line(self) -> int:
        return self.line + self.text.count("\n")


def tokenize(text: str) -> Iterator[Token]:
    """C tokens with positions; whitespace and newlines are dropped, comments and
    preprocessor lines kept. An unterminated comment runs to the end of the file."""
    line, line_start, pos = 1, 0, 0
    at_line_start = True
    while pos < len(text):
        if at_line_start:
            stripped = len(text) - len(text[pos:].lstrip(" \t"))
            if stripped < len(text) and text[stripped] == "#":
                end = _directive_end(text, stripped)
                yield Token("directive", text[stripped:end], line, stripped - line_start + 1,
                            stripped, end)
                line += text.count("\n", stripped, end)
                if "\n" in text[stripped:end]:
                    line_start = text.rindex("\n", stripped, end) + 1
                pos, at_line_start = end, False
                continue
        match = TOKEN.match(text, pos)
        assert match is not None  # the last alternative matches any character
        kind = match.lastgroup or "punct"
        value = match.group()
        if kind == "open_comment":
            kind, value = "comment", text[pos:] + "*/"
            match_end = len(text)
        else:
            match_end = match.end()
        if kind == "nl":
            line, line_start, at_line_start = line + 1, match_end, True
        elif kind == "ws":
            if "\n" in value:
                line, line_start = line + 1, match_end
        else:
            at_line_start = False
            if kind in ("lcomment", "bcomment"):
                kind = "comment"
            yield Token(kind, value, line, pos - line_start + 1, pos, match_end)
            if "\n" in value:
                line += value.count("\n")
                line_start = pos + value.rindex("\n") + 1
        pos = match_end


def _directive_end(text: str, start: int) -> int:
    """A preprocessor line ends at a newline not escaped by a backslash, or where a comment
    starts (the comment is a token of its own)."""
    pos = start
    in_string: str | None = None
    while pos < len(text):
        char = text[pos]
        if in_string:
            if char == "\\":
                pos += 2
                continue
            if char == in_string:
                in_string = None
        elif char in "\"'":
            in_string = char
        elif char == "\\" and text[pos + 1:pos + 3].startswith(("\n", "\r\n")):
            pos += 2 if text[pos + 1] == "\n" else 3
            continue
        elif char == "\n" or text.startswith(("//", "/*"), pos):
            break
        pos += 1
    return len(text[:pos].rstrip())


# ------------------------------------------------------------------------------ events
@dataclass
class Event:
    """A unit of the C file: "blank", "comment", "directive", "statement", "control" (an
    if/for/else/label head), "open" or "close" (a brace)."""

    kind: str
    tokens: list[Token]
    line: int
    trailing: list[Token] = field(default_factory=list)  # comments on its line or inside it

    @property
    def end_line(self) -> int:
        return max(t.end_line for t in self.tokens) if self.tokens else self.line


def events(text: str) -> list[Event]:
    """Group the tokens into statements, blocks, comments and blank lines."""
    out: list[Event] = []
    pending: list[Token] = []
    inner_comments: list[Token] = []
    depth = 0  # () and [] nesting
    initializer = 0  # braces inside `= { ... }`
    lines_with_tokens: set[int] = set()

    def finish(kind: str = "statement") -> None:
        nonlocal pending, inner_comments
        if pending:
            for part_kind, part in _split_control(pending):
                out.append(Event(part_kind if kind == "statement" else kind, part,
                                 part[0].line))
            out[-1].trailing += inner_comments
        elif inner_comments:
            out.extend(Event("comment", [c], c.line) for c in inner_comments)
        pending, inner_comments = [], []

    for token in tokenize(text):
        for line in range(token.line, token.end_line + 1):
            lines_with_tokens.add(line)
        if token.kind == "comment":
            if pending:
                inner_comments.append(token)
            elif out and out[-1].kind not in ("comment", "blank") and \
                    out[-1].end_line == token.line:
                out[-1].trailing.append(token)
            else:
                out.append(Event("comment", [token], token.line))
            continue
        if token.kind == "directive":
            finish()
            out.append(Event("directive", [token], token.line))
            continue
        text_ = token.text
        if text_ in "([" and token.kind == "punct":
            depth += 1
        elif text_ in ")]" and token.kind == "punct":
            depth = max(0, depth - 1)
        if token.kind == "punct" and depth == 0:
            if text_ == "{":
                if initializer or (pending and pending[-1].text in ("=", ",")):
                    initializer += 1
                    pending.append(token)
                    continue
                finish()
                out.append(Event("open", [token], token.line))
                continue
            if text_ == "}":
                if initializer:
                    initializer -= 1
                    pending.append(token)
                    continue
                finish()
                out.append(Event("close", [token], token.line))
                continue
            if text_ == ";" and not initializer:
                pending.append(token)
                finish()
                continue
        pending.append(token)
    finish()
    return _with_blank_lines(out, text, lines_with_tokens)


def _with_blank_lines(items: list[Event], text: str, used: set[int]) -> list[Event]:
    """Insert one "blank" event for each run of empty lines between events."""
    total = text.count("\n") + 1
    blank_lines = {n for n in range(1, total + 1) if n not in used and
                   not _line_text(text, n).strip()}
    out: list[Event] = []
    last_line = 0
    for event in items:
        if any(n in blank_lines for n in range(last_line + 1, event.line)):
            out.append(Event("blank", [], event.line))
        out.append(event)
        last_line = max([event.end_line, *(c.end_line for c in event.trailing)])
    return out


def _line_text(text: str, number: int) -> str:
    lines = text.split("\n")
    return lines[number - 1] if 0 < number <= len(lines) else ""


def _split_control(tokens: list[Token]) -> Iterator[tuple[str, list[Token]]]:
    """Peel `if (...)`, `for (...)`, `else`, `do`, `case x:` and `label:` heads off a
    statement: they are C control flow, the rest is an ordinary statement."""
    rest = tokens
    while rest:
        first = rest[0]
        if first.kind == "ident" and first.text in CONTROL_WORDS and len(rest) > 1 and \
                rest[1].text == "(":
            end = _matching(rest, 1)
            yield "control", rest[:end + 1]
            rest = rest[end + 1:]
        elif first.kind == "ident" and first.text in LONE_CONTROL_WORDS:
            yield "control", [first]
            rest = rest[1:]
        elif first.kind == "ident" and first.text in ("case", "default"):
            end = next((i for i, t in enumerate(rest) if t.text == ":"), len(rest) - 1)
            yield "control", rest[:end + 1]
            rest = rest[end + 1:]
        elif first.kind == "ident" and len(rest) > 1 and rest[1].text == ":" and \
                first.text not in TYPE_WORDS:
            yield "control", rest[:2]
            rest = rest[2:]
        else:
            yield "statement", rest
            return


def _matching(tokens: list[Token], open_index: int) -> int:
    depth = 0
    for index in range(open_index, len(tokens)):
        if tokens[index].text in "([" and tokens[index].kind == "punct":
            depth += 1
        elif tokens[index].text in ")]" and tokens[index].kind == "punct":
            depth -= 1
            if depth == 0:
                return index
    return len(tokens) - 1


# ------------------------------------------------------------------------------ expressions
class Unconvertible(Exception):
    """Something the importer cannot turn into `.mp`; the message says what and why."""


@dataclass(frozen=True)
class CNum:
    value: int | float
    text: str


@dataclass(frozen=True)
class CStr:
    value: str


@dataclass(frozen=True)
class CName:
    name: str


@dataclass(frozen=True)
class CUnary:
    op: str
    operand: CExpr


@dataclass(frozen=True)
class CBin:
    op: str
    left: CExpr
    right: CExpr


@dataclass(frozen=True)
class CCall:
    name: str


CExpr = CNum | CStr | CName | CUnary | CBin | CCall
BINARY = [("||",), ("&&",), ("|",), ("^",), ("&",), ("==", "!="), ("<", ">", "<=", ">="),
          ("<<", ">>"), ("+", "-"), ("*", "/", "%")]


class _Parser:
    """Precedence climbing over the tokens of one C expression (an argument, a #define)."""

    def __init__(self, tokens: list[Token]) -> None:
        self.tokens = tokens
        self.pos = 0

    def peek(self) -> Token | None:
        return self.tokens[self.pos] if self.pos < len(self.tokens) else None

    def next(self) -> Token:
        token = self.peek()
        if token is None:
            raise Unconvertible("incomplete expression")
        self.pos += 1
        return token

    def parse(self) -> CExpr:
        expr = self.binary(0)
        if self.peek() is not None:
            raise Unconvertible(f"unexpected {self.peek().text!r}")  # type: ignore[union-attr]
        return expr

    def binary(self, level: int) -> CExpr:
        if level == len(BINARY):
            return self.unary()
        left = self.binary(level + 1)
        while (token := self.peek()) is not None and token.kind == "punct" and \
                token.text in BINARY[level]:
            self.pos += 1
            left = CBin(token.text, left, self.binary(level + 1))
        return left

    def unary(self) -> CExpr:
        token = self.next()
        if token.kind == "punct" and token.text in ("-", "+", "~", "!"):
            return CUnary(token.text, self.unary())
        if token.text == "(" and self._is_cast():
            while self.next().text != ")":
                pass
            return self.unary()
        if token.text == "(":
            inner = self.binary(0)
            if self.next().text != ")":
                raise Unconvertible("unbalanced brackets")
            return inner
        if token.kind == "number":
            return _number(token.text)
        if token.kind == "char":
            return CNum(_char_value(token.text), token.text)
        if token.kind == "string":
            value = _unquote(token.text)
            while (more := self.peek()) is not None and more.kind == "string":
                self.pos += 1
                value += _unquote(more.text)
            return CStr(value)
        if token.kind == "ident":
            following = self.peek()
            if following is not None and following.text == "(":
                self.pos = _matching(self.tokens, self.pos) + 1
                return CCall(token.text)
            return CName(token.text)
        raise Unconvertible(f"unexpected {token.text!r}")

    def _is_cast(self) -> bool:
        index = self.pos
        words = 0
        while index < len(self.tokens) and self.tokens[index].text != ")":
            token = self.tokens[index]
            if not (token.text in TYPE_WORDS or token.text == "*"):
                return False
            words += 1
            index += 1
        return words > 0 and index < len(self.tokens)


def parse_expression(tokens: list[Token]) -> CExpr:
    if not tokens:
        raise Unconvertible("empty argument")
    return _Parser(tokens).parse()


def _number(text: str) -> CNum:
    """A C number: suffixes dropped, octal and binary as decimal, hex kept as written."""
    lowered = text.lower()
    if lowered.startswith("0x"):
        spelled = text.rstrip("uUlL")
        return CNum(int(spelled, 16), spelled)
    digits = lowered.rstrip("ul")
    try:
        if digits.startswith("0b"):
            return CNum(int(digits, 2), str(int(digits, 2)))
        if re.fullmatch(r"[0-9]+", digits):
            value = int(digits, 8) if len(digits) > 1 and digits.startswith("0") else \
                int(digits)
            return CNum(value, str(value))
        return CNum(float(lowered.rstrip("f")), text)
    except ValueError:
        raise Unconvertible(f"{text} is not a C number") from None


def _unquote(text: str) -> str:
    return codecs.decode(text[1:-1], "unicode_escape")


def _char_value(text: str) -> int:
    value = _unquote(text)
    if len(value) != 1:
        raise Unconvertible(f"character constant {text} is not one character")
    return ord(value)


def _c_divide(left: int, right: int) -> int:
    if right == 0:
        raise Unconvertible("division by zero")
    quotient = abs(left) // abs(right)
    return quotient if (left >= 0) == (right >= 0) else -quotient


def _c_binary(op: str, left: int, right: int) -> int:
    if op == "/":
        return _c_divide(left, right)
    if op == "%":
        return left - _c_divide(left, right) * right
    table = {
        "+": lambda: left + right, "-": lambda: left - right, "*": lambda: left * right,
        "&": lambda: left & right, "|": lambda: left | right, "^": lambda: left ^ right,
        "<<": lambda: left << right if 0 <= right < 64 else 0,
        ">>": lambda: left >> right if 0 <= right < 64 else 0,
        "==": lambda: int(left == right), "!=": lambda: int(left != right),
        "<": lambda: int(left < right), ">": lambda: int(left > right),
        "<=": lambda: int(left <= right), ">=": lambda: int(left >= right),
        "&&": lambda: int(bool(left) and bool(right)),
        "||": lambda: int(bool(left) or bool(right)),
    }
    return table[op]()


# ------------------------------------------------------------------------------ import
@dataclass(frozen=True)
class ImportWarning:
    line: int
    message: str


@dataclass
class Conversion:
    """The `.mp` text, what could not be converted, and for each output line the C line it
    came from (None for lines the importer added)."""

    text: str
    warnings: list[ImportWarning]
    line_map: list[int | None]
    target: str

    @property
    def complete(self) -> bool:
        return not self.warnings


@dataclass
class _Constant:
    value: int | VarRef
    spelled: str | None  # the CONST / ALIAS name when one was written, else None


@dataclass
class _Program:
    kind: str
    slot: int | None
    lines: list[tuple[str, int | None]] = field(default_factory=list)
    hoisted: list[tuple[str, int | None]] = field(default_factory=list)
    depth: int = 0


class Importer:
    """Converts one C file. `convert()` returns a Conversion."""

    def __init__(self, text: str, catalogue: Catalogue | None = None,
                 source_name: str | None = None) -> None:
        self.text = text
        self.source_name = source_name
        self.catalogue = catalogue or catalogue_module.load()
        self.profile = self.catalogue.profile
        self.writer = Writer(self.catalogue)
        self.scope = Scope(self.catalogue, DiagnosticSink())
        self.out: list[tuple[str, int | None]] = []
        self.program: _Program | None = None
        self.constants: dict[str, _Constant] = {}
        self.warnings: list[ImportWarning] = []
        self.prefixes: dict[str, int] = {"RSM": 0, "ETM": 0}
        self.lines = [line.rstrip("\r") for line in text.split("\n")]
        self.echoed: set[int] = set()

    # ------------------------------------------------------------------ output
    @property
    def sink(self) -> list[tuple[str, int | None]]:
        return self.program.lines if self.program is not None else self.out

    @property
    def indent(self) -> str:
        if self.program is None:
            return ""
        return INDENT * (1 + self.program.depth)

    def put(self, text: str, line: int | None) -> None:
        self.sink.append((text, line))

    def warn(self, line: int, message: str) -> None:
        self.warnings.append(ImportWarning(line, message))

    def source(self, tokens: list[Token]) -> str:
        """The C text of some tokens, on one line."""
        if not tokens:
            return ""
        return " ".join(self.text[tokens[0].start:tokens[-1].end].split())

    # ------------------------------------------------------------------ driver
    def convert(self) -> Conversion:
        for event in events(self.text):
            handler = getattr(self, f"on_{event.kind}")
            handler(event)
        if self.program is not None:
            kind = self.program.kind
            close = "RSM_MACRO_MP_CLOSE" if kind == "mp" else "RSM_MACRO_MP_ISR_CLOSE"
            line = self.text.count("\n") + 1
            self.warn(line, f"cannot convert: the file ends inside {self._label()}: {close} "
                      f"is missing; END {kind.upper()} added")
            self.close_program(f"END {kind.upper()}", [], line, "added: the C file never "
                               "closes this program")
        target = "et" if self.prefixes["ETM"] > self.prefixes["RSM"] else "rs"
        origin = f" from {self.source_name}" if self.source_name else ""
        header = [(f"# Imported by mpc import{origin}; build with --target {target}", None)]
        lines = header + ([("", None)] if self.out and self.out[0][0] else []) + self.out
        while lines and not lines[-1][0]:
            lines.pop()
        text = "\n".join(t for t, _ in lines) + "\n"
        return Conversion(text, sorted(self.warnings, key=lambda w: w.line),
                          [n for _, n in lines], target)

    # ------------------------------------------------------------------ events
    def on_blank(self, event: Event) -> None:
        if self.sink and self.sink[-1][0]:
            self.put("", None)

    def on_comment(self, event: Event) -> None:
        (token,) = event.tokens
        for offset, text in enumerate(_comment_lines(token.text)):
            self.put(f"{self.indent}# {text}".rstrip() if text else f"{self.indent}#",
                     token.line + offset)

    def on_open(self, event: Event) -> None:
        self.host_or_drop(event)

    def on_close(self, event: Event) -> None:
        self.host_or_drop(event)

    def host_or_drop(self, event: Event) -> None:
        """Braces: host code outside programs; inside one they only group C statements."""
        if self.program is None:
            self.echo("C", event)
        else:
            self.trailing_only(event)

    def on_control(self, event: Event) -> None:
        if self.program is None:
            self.echo("C", event)
            return
        word = event.tokens[0].text
        what = f"C {word}" if word in CONTROL_WORDS | LONE_CONTROL_WORDS | {"case", "default"} \
            else "C label"
        self.not_converted(event, f"{what} runs on the host: the statements under it are "
                           "converted once, unconditionally; use FOR/IF/GOTO statements")

    def on_directive(self, event: Event) -> None:
        (token,) = event.tokens
        text = " ".join(re.sub(r"\\\r?\n", " ", token.text).split())
        match = re.fullmatch(r"#\s*define\s+([A-Za-z_]\w*)(\s+.*)?", text)
        if match and match.group(2) is not None:
            body = [t for t in tokenize(match.group(2)) if t.kind != "comment"]
            if self.define(match.group(1), body, event):
                return
        if self.program is not None and re.match(r"#\s*(if|ifdef|ifndef|elif|else|endif)\b",
                                                 text):
            self.not_converted(event, "preprocessor conditionals are not evaluated: every "
                               "branch is converted")
            return
        self.echo("C", event)

    def on_statement(self, event: Event) -> None:
        tokens = event.tokens
        body = tokens[:-1] if tokens[-1].text == ";" else tokens
        if not body:
            self.trailing_only(event)
            return
        call = _vendor_call(body)
        if call is None:
            if any(t.kind == "ident" and VENDOR.fullmatch(t.text) for t in body):
                self.not_converted(event, "a vendor call inside a C expression")
                return
            if self.constant_declaration(body, event):
                return
            if self.program is None:
                self.echo("C", event)
            else:
                self.not_converted(event, "C statement inside a macro program")
            return
        name, args = call
        self.prefixes[name[:3].upper()] = self.prefixes.get(name[:3].upper(), 0) + 1
        self.vendor_call(name, args, event)

    # ------------------------------------------------------------------ constants
    def define(self, name: str, body: list[Token], event: Event) -> bool:
        """`#define NAME value`: CONST (integers) or ALIAS (VARn) when mplang can take the
        name, else only remembered for the arguments that use it."""
        try:
            expr = parse_expression(body)
        except Unconvertible:
            return False
        var = VAR_NAME.fullmatch(expr.name) if isinstance(expr, CName) else None
        value: int | VarRef
        if var:
            value = VarRef(int(var.group(1)))
        else:
            try:
                value = self.evaluate(expr, None)
            except Unconvertible:
                return False
        usable = self.scope.reserved(name) is None and name.upper() not in \
            {k.upper() for k in self.constants}
        spelled = name if usable else None
        self.constants[name] = _Constant(value, spelled)
        if spelled is None:
            self.echo("C", event)
            return True
        if isinstance(value, VarRef):
            line = f"ALIAS {name} = VAR{value.index}"
        else:
            line = f"CONST {name} = {self.spell(expr) or value}"
        self.top_level(line, event)
        return True

    def constant_declaration(self, body: list[Token], event: Event) -> bool:
        """`const long NAME = value;` (outside a function or not, it never changes)."""
        texts = [t.text for t in body]
        if "const" not in texts or "=" not in texts:
            return False
        equals = texts.index("=")
        if equals < 2 or body[equals - 1].kind != "ident" or \
                any(t.text not in TYPE_WORDS for t in body[:equals - 1]):
            return False
        return self.define(body[equals - 1].text, body[equals + 1:], event)

    def top_level(self, line: str, event: Event) -> None:
        """A CONST/ALIAS line: in place outside programs, before the program header when
        the C file defines it inside one (.mp declarations stand at the top level)."""
        text = line + self.trailing_text(event)
        if self.program is None:
            self.out.append((text, event.line))
        else:
            self.program.hoisted.append((text, event.line))

    # ------------------------------------------------------------------ vendor calls
    def vendor_call(self, name: str, args: list[list[Token]], event: Event) -> None:
        command = self.catalogue.lookup(name)
        if command is None:
            names = [c.name.replace("RSM_", name[:4], 1) for c in self.catalogue.commands]
            close = difflib.get_close_matches(name.upper(), names, n=1, cutoff=0.7)
            hint = f" (did you mean {close[0]}?)" if close else ""
            self.not_converted(event, f"unknown function {name}{hint}")
            return
        short = command.short_name
        if short in ("MP_CREATE", "MP_ISR_CREATE"):
            self.create(command, args, event)
        elif short in ("MP_CLOSE", "MP_ISR_CLOSE"):
            self.close(command, event)
        elif not command.is_macro:
            self.host_call(command, name, args, event)
        elif self.program is None:
            self.not_converted(event, f"{name} outside {name[:4]}MP_CREATE ... "
                               f"{name[:4]}MACRO_MP_CLOSE: it belongs to no program")
        else:
            self.macro_call(command, name, args, event)

    def host_call(self, command: Command, name: str, args: list[list[Token]],
                  event: Event) -> None:
        twin = self.catalogue.macro_by_short.get(command.short_name)
        if self.program is not None:
            if command.code is None:
                self.not_converted(event, f"{name} is a host-side function; it has no macro "
                                   "form")
            else:
                hint = f"; its macro form is {name[:4]}{twin.name[4:]}" if twin else ""
                self.not_converted(event, f"{name} is a real-time command: the device refuses "
                                   f"it while a program is being downloaded (RS 4033){hint}")
            return
        if command.code is None:
            self.echo("C", event)  # connection handling and register reads: host business
            return
        hint = ""
        if command.short_name == "MP_CALL" and len(args) == 3:
            try:
                slot = self.evaluate(parse_expression(args[2]), command.params[0])
            except Unconvertible:
                slot = None
            if slot is not None:
                hint = f"; `mpc run FILE.mp --call MP{slot}` runs it on the virtual controller"
        self.not_converted(event, f"{name} is a real-time call the host makes; a .mp file "
                           f"holds macro programs only{hint}")

    def create(self, command: Command, args: list[list[Token]], event: Event) -> None:
        kind = "mp" if command.short_name == "MP_CREATE" else "isr"
        name = f"{event.tokens[0].text}"
        if self.program is not None:
            self.not_converted(event, f"{name} while {self._label()} is still open: the device "
                               "refuses it in download state (RS 4033)")
            return
        slot: int | None = None
        if len(args) != 3:
            self.warn(event.line, f"cannot convert: {name} takes 3 arguments (handle, "
                      f"address, {kind.upper()} number), got {len(args)}; the program is "
                      "left to the linker")
        else:
            try:
                value = self.evaluate(parse_expression(args[2]), command.params[0])
            except Unconvertible as exc:
                self.warn(event.line, f"cannot convert the {kind.upper()} number "
                          f"{self.source(args[2])!r}: {exc}; the program is left to the "
                          "linker")
            else:
                slot = value
        self.program = _Program(kind, slot)
        header = f"{kind.upper()} {slot}" if slot is not None else kind.upper()
        self.program.lines.append((header + self.trailing_text(event), event.line))

    def close(self, command: Command, event: Event) -> None:
        kind = "mp" if command.short_name == "MP_CLOSE" else "isr"
        name = event.tokens[0].text
        if self.program is None:
            self.not_converted(event, f"{name} without an open program: the device ignores it")
            return
        if self.program.kind != kind:
            self.not_converted(event, f"{name} cannot close {self._label()} (the device "
                               "refuses it in that download state)")
            return
        self.close_program(f"END {kind.upper()}", event.trailing, event.line, "")

    def close_program(self, text: str, comments: list[Token], line: int, note: str) -> None:
        program = self.program
        assert program is not None
        extra = " ".join(filter(None, [note, *(_comment_text(c) for c in comments)]))
        program.lines.append((text + (f"  # {extra}" if extra else ""), line))
        self.program = None
        if program.hoisted:
            self.out.extend(program.hoisted)
        self.out.extend(program.lines)

    def macro_call(self, command: Command, name: str, args: list[list[Token]],
                   event: Event) -> None:
        assert self.program is not None
        params = command.params
        if len(args) != len(params) + 2:
            listed = ", ".join(p.name for p in params) or "nothing else"
            self.not_converted(event, f"{name} takes {len(params) + 2} arguments (handle, "
                               f"address, {listed}), got {len(args)}")
            return
        operands: list[Operand] = []
        texts: list[str | None] = []
        for param, arg in zip(params, args[2:], strict=True):
            try:
                operand, text = self.argument(param, arg)
            except Unconvertible as exc:
                self.not_converted(event, f"{name} argument {param.name} "
                                   f"{self.source(arg)!r}: {exc}")
                return
            operands.append(operand)
            texts.append(text)
        statement = self.writer.statement(command, operands, texts)
        role = block_role(command)
        if role in ("close", "middle"):
            self.program.depth = max(0, self.program.depth - 1)
        self.put(self.indent + statement + self.trailing_text(event), event.line)
        if role in ("open", "middle"):
            self.program.depth += 1

    # ------------------------------------------------------------------ arguments
    def argument(self, param: Param, tokens: list[Token]) -> tuple[Operand, str | None]:
        """One C argument as an operand, with a spelling to keep (a CONST name) or None."""
        expr = parse_expression(tokens)
        if isinstance(expr, CName):
            constant = self.constants.get(expr.name)
            if constant is not None:
                return constant.value, constant.spelled
            var = VAR_NAME.fullmatch(expr.name)
            if var:
                return VarRef(int(var.group(1))), None
            bvar = BVAR_NAME.fullmatch(expr.name)
            if bvar:
                return BVarRef(int(bvar.group(1))), None
        if isinstance(expr, CStr):
            table = {"cmp_op": self.profile.cmp_ops, "calc_op": self.profile.calc_ops}.get(
                param.kind)
            if table is None or expr.value not in table:
                raise Unconvertible("a string is not a value here")
            return table[expr.value], None
        value = self.evaluate(expr, param)
        if param.kind in LITERAL_KINDS:
            if isinstance(expr, CNum):
                return value, expr.text
            if isinstance(expr, CName) and expr.name.upper() in param.symbols:
                return value, expr.name.upper()
        return value, self.spell(expr) if param.kind == "int" else None

    def evaluate(self, expr: CExpr, param: Param | None) -> int:
        """The integer a constant C expression has, with the vendor header's names."""
        if isinstance(expr, CNum):
            if isinstance(expr.value, float):
                raise Unconvertible(f"{expr.text} is not an integer")
            return expr.value
        if isinstance(expr, CName):
            return self.name_value(expr.name, param)
        if isinstance(expr, CUnary):
            inner = self.evaluate(expr.operand, param)
            return {"-": -inner, "+": inner, "~": ~inner, "!": int(not inner)}[expr.op]
        if isinstance(expr, CBin):
            return _c_binary(expr.op, self.evaluate(expr.left, param),
                             self.evaluate(expr.right, param))
        if isinstance(expr, CCall):
            raise Unconvertible(f"the value of {expr.name}(...) is only known at run time")
        raise Unconvertible("a string is not a number")

    def name_value(self, name: str, param: Param | None) -> int:
        constant = self.constants.get(name)
        if constant is not None:
            if isinstance(constant.value, VarRef):
                raise Unconvertible(f"{name} is the variable VAR{constant.value.index}, not a "
                                    "number")
            return constant.value
        upper = name.upper()
        if param is not None:
            if upper in param.symbols:
                return param.symbols[upper]
            if param.kind == "cmp_op" and upper in self.profile.cmp_symbols:
                return self.profile.cmp_ops[self.profile.cmp_symbols[upper]]
        if upper.startswith(("AXIS_", "INITIAL_")):
            code = self.profile.axis_code(upper)
            if code is not None:
                return code
        program = PROGRAM_NAME.fullmatch(name)
        if program:
            wanted = (param.kind if param is not None else "").removesuffix("_or_none")
            if wanted in ("mp", "isr") and program.group(1).lower() != wanted:
                raise Unconvertible(f"{name} is not an {wanted.upper()} number")
            return int(program.group(2))
        label = LABEL_NAME.fullmatch(name)
        if label:
            return int(label.group(1))
        if VAR_NAME.fullmatch(name) or BVAR_NAME.fullmatch(name):
            raise Unconvertible(f"{name} inside an expression: a variable is passed alone")
        raise Unconvertible(f"{name} is not a constant the importer knows (a C variable? its "
                            "value is only known at run time)")

    def spell(self, expr: CExpr) -> str | None:
        """The expression in mplang syntax, if it only uses what a CONST expression may
        (numbers, CONSTs written by this import, + - * / & | and brackets)."""
        if isinstance(expr, CNum):
            return expr.text if isinstance(expr.value, int) else None
        if isinstance(expr, CName):
            constant = self.constants.get(expr.name)
            if constant is not None and constant.spelled and not isinstance(constant.value,
                                                                             VarRef):
                return constant.spelled
            return None
        if isinstance(expr, CUnary) and expr.op in "-+":
            inner = self.spell(expr.operand)
            if inner is None:
                return None
            inner = inner if _atomic(expr.operand) else f"({inner})"
            return f"-{inner}" if expr.op == "-" else inner
        if isinstance(expr, CBin) and expr.op in ("+", "-", "*", "/", "&", "|"):
            left, right = self.spell(expr.left), self.spell(expr.right)
            if left is None or right is None:
                return None
            left = left if _atomic(expr.left) else f"({left})"
            right = right if _atomic(expr.right) else f"({right})"
            return f"{left} {expr.op} {right}"
        return None

    # ------------------------------------------------------------------ echo and omissions
    def trailing_text(self, event: Event) -> str:
        parts = [_comment_text(c) for c in event.trailing]
        text = " ".join(p for p in parts if p)
        return f"  # {text}" if text else ""

    def trailing_only(self, event: Event) -> None:
        """An event with no output of its own: keep its comments."""
        for comment in event.trailing:
            self.on_comment(Event("comment", [comment], comment.line))

    def echo(self, marker: str, event: Event) -> None:
        """C code kept as comment lines: host code (`# C: ...`) as its whole source lines,
        each line once and with its indentation; a construct that was not converted as its
        own text. Comments on those lines stay in C syntax there."""
        if not event.tokens:
            self.trailing_only(event)
            return
        if marker == "C":
            last = max(t.end_line for t in [*event.tokens, *event.trailing])
            for number in range(event.line, last + 1):
                if number in self.echoed:
                    continue
                self.echoed.add(number)
                line = self.lines[number - 1] if number <= len(self.lines) else ""
                self.put(f"{self.indent}# C: {line.rstrip()}".rstrip(), number)
            return
        first = event.tokens[0]
        end = max(t.end for t in [*event.tokens, *event.trailing])
        for offset, line in enumerate(self.text[first.start:end].splitlines()):
            prefix = f"# {marker}: " if offset == 0 else "#" + " " * (len(marker) + 3)
            self.put(f"{self.indent}{prefix}{line.strip()}".rstrip(), event.line + offset)

    def not_converted(self, event: Event, why: str) -> None:
        where = self.source(event.tokens)
        self.warn(event.line, f"cannot convert {where!r}: {why}")
        self.echo("not converted", event)

    def _label(self) -> str:
        assert self.program is not None
        slot = "" if self.program.slot is None else str(self.program.slot)
        return f"{self.program.kind.upper()}{slot}"


def _atomic(expr: CExpr) -> bool:
    """Needs no brackets as an operand: a number, a name, or a sign in front of one (unary
    minus binds tighter than any binary operator, in C and in mplang)."""
    if isinstance(expr, CUnary):
        return expr.op in "-+" and _atomic(expr.operand)
    return isinstance(expr, CNum | CName)


def _comment_text(token: Token) -> str:
    return " ".join(line for line in _comment_lines(token.text) if line)


def _comment_lines(text: str) -> list[str]:
    """The text of a // or /* */ comment, line by line, without its markers."""
    if text.startswith("//"):
        return [text[2:].strip()]
    body = text[2:-2] if text.endswith("*/") else text[2:]
    lines = body.splitlines() or [""]
    out = []
    for index, line in enumerate(lines):
        stripped = line.strip()
        if index > 0 and stripped.startswith("*"):
            stripped = stripped[1:].strip()
        out.append(stripped)
    while len(out) > 1 and not out[-1]:
        out.pop()
    while len(out) > 1 and not out[0]:
        out.pop(0)
    return out


def _vendor_call(body: list[Token]) -> tuple[str, list[list[Token]]] | None:
    """`NAME(args)`, `(void)NAME(args)` or `lvalue = NAME(args)` with a vendor NAME: the
    name and the argument token lists; None for any other statement."""
    tokens = body
    if len(tokens) > 3 and [t.text for t in tokens[:3]] == ["(", "void", ")"]:
        tokens = tokens[3:]
    texts = [t.text for t in tokens]
    if "=" in texts:
        equals = texts.index("=")
        if any(t.text == "(" for t in tokens[:equals]):
            return None
        tokens = tokens[equals + 1:]
    if len(tokens) < 3 or tokens[0].kind != "ident" or not VENDOR.fullmatch(tokens[0].text) \
            or tokens[1].text != "(" or _matching(tokens, 1) != len(tokens) - 1:
        return None
    inner = tokens[2:-1]
    args: list[list[Token]] = []
    current: list[Token] = []
    depth = 0
    for token in inner:
        if token.kind == "punct" and token.text in "([{":
            depth += 1
        elif token.kind == "punct" and token.text in ")]}":
            depth -= 1
        if token.text == "," and depth == 0:
            args.append(current)
            current = []
        else:
            current.append(token)
    if current or args:
        args.append(current)
    return tokens[0].text, args


def convert(text: str, catalogue: Catalogue | None = None, source_name: str | None = None
            ) -> Conversion:
    """Convert the text of a C file (`source_name` only appears in the header comment)."""
    return Importer(text, catalogue, source_name).convert()


def read_c_file(data: bytes, encoding: str | None = None) -> tuple[str, str]:
    """Decode a C file: UTF-8, else the Traditional Chinese code page of the ET manual's
    readers (cp950), else Latin-1, which always succeeds. Returns (text, encoding used)."""
    for candidate in ([encoding] if encoding else ["utf-8", "cp950", "latin-1"]):
        try:
            return data.decode(candidate), candidate
        except UnicodeDecodeError:
            continue
    raise UnicodeDecodeError(encoding or "utf-8", data, 0, 1, "cannot decode")
