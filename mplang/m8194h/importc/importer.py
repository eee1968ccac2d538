"""Converting one C file (`Importer`, `convert`) and decoding it (`read_c_file`).

A C program downloads a macro program by calling `RSM_MP_CREATE` (or `ETM_MP_CREATE`), one
`RSM_MACRO_*` function per macro line, and `RSM_MACRO_MP_CLOSE`; ISRs likewise with
`RSM_MP_ISR_CREATE` ... `RSM_MACRO_MP_ISR_CLOSE`. Every macro function takes the handle and the
slave address (card number) first, then the arguments the catalogue lists. The importer follows
that create/close bracket over the events of `reader` and writes each call through
`mplang.ir.mpwriter`, the writer the disassembler uses, so a call becomes the statement that
compiles to exactly its frame.

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

import difflib
import re
from dataclasses import dataclass, field

from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue, Command
from mplang.ir.lower import Scope
from mplang.ir.macro import Operand, VarRef
from mplang.ir.mpwriter import Writer, block_role
from mplang.lang.diagnostics import DiagnosticSink
from mplang.m8194h.importc.expressions import CName, Unconvertible, parse_expression
from mplang.m8194h.importc.reader import (
    CONTROL_WORDS,
    LONE_CONTROL_WORDS,
    TYPE_WORDS,
    Event,
    Token,
    comment_lines,
    comment_text,
    events,
    matching,
    tokenize,
)
from mplang.m8194h.importc.values import VAR_NAME, Constant, Values

VENDOR = re.compile(r"(RSM|ETM)_\w+")
INDENT = "    "


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
        self.values = Values(self.profile)
        self.warnings: list[ImportWarning] = []
        self.prefixes: dict[str, int] = {"RSM": 0, "ETM": 0}
        self.lines = [line.rstrip("\r") for line in text.split("\n")]
        self.echoed: set[int] = set()
        self.defined: set[str] = set()
        """The names of `values.constants`, upper case (.mp names ignore case): kept as the
        constants are added, not rebuilt for each one."""
        self.suggestions: dict[str, str] = {}
        """Unknown function -> its hint: difflib is slow, and a file repeats its mistakes."""

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
        for offset, text in enumerate(comment_lines(token.text)):
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
                value = self.values.evaluate(expr, None)
            except Unconvertible:
                return False
        usable = self.scope.reserved(name) is None and name.upper() not in self.defined
        spelled = name if usable else None
        self.values.constants[name] = Constant(value, spelled)
        self.defined.add(name.upper())
        if spelled is None:
            self.echo("C", event)
            return True
        if isinstance(value, VarRef):
            line = f"ALIAS {name} = VAR{value.index}"
        else:
            line = f"CONST {name} = {self.values.spell(expr) or value}"
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
            if name not in self.suggestions:
                names = [c.name.replace("RSM_", name[:4], 1) for c in self.catalogue.commands]
                close = difflib.get_close_matches(name.upper(), names, n=1, cutoff=0.7)
                self.suggestions[name] = f" (did you mean {close[0]}?)" if close else ""
            self.not_converted(event, f"unknown function {name}{self.suggestions[name]}")
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
                slot = self.values.evaluate(parse_expression(args[2]), command.params[0])
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
                value = self.values.evaluate(parse_expression(args[2]), command.params[0])
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
        extra = " ".join(filter(None, [note, *(comment_text(c) for c in comments)]))
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
                operand, text = self.values.argument(param, arg)
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

    # ------------------------------------------------------------------ echo and omissions
    def trailing_text(self, event: Event) -> str:
        parts = [comment_text(c) for c in event.trailing]
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
            or tokens[1].text != "(" or matching(tokens, 1) != len(tokens) - 1:
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
