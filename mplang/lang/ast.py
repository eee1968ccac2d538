"""Typed syntax tree of `.mp` sources. Every node keeps the span it came from.

The nodes are what `@dataclass` would make of them, written out: an `__init__` per class
and value equality, repr and `replace` shared through `mplang.lang.record.Record`. Every command
imports this module, and creating its forty classes as dataclasses (each method generated as
source text and compiled) was a fifth of what creating dataclasses costs a lint, on every
start.
"""

from __future__ import annotations

from mplang.lang.diagnostics import Span
from mplang.lang.record import Record as _Record

# ---------------------------------------------------------------- expressions


class Num(_Record):
    value: int
    span: Span
    _fields = __match_args__ = ("value", "span")

    def __init__(self, value: int, span: Span) -> None:
        self.value = value
        self.span = span


class Name(_Record):
    name: str
    span: Span
    _fields = __match_args__ = ("name", "span")

    def __init__(self, name: str, span: Span) -> None:
        self.name = name
        self.span = span


class Str(_Record):
    value: str
    span: Span
    _fields = __match_args__ = ("value", "span")

    def __init__(self, value: str, span: Span) -> None:
        self.value = value
        self.span = span


class BinOp(_Record):
    op: str
    left: Expr
    right: Expr
    span: Span
    _fields = __match_args__ = ("op", "left", "right", "span")

    def __init__(self, op: str, left: Expr, right: Expr, span: Span) -> None:
        self.op = op
        self.left = left
        self.right = right
        self.span = span


class Neg(_Record):
    operand: Expr
    span: Span
    _fields = __match_args__ = ("operand", "span")

    def __init__(self, operand: Expr, span: Span) -> None:
        self.operand = operand
        self.span = span


class Call(_Record):
    name: str
    args: list[Expr]
    span: Span
    _fields = __match_args__ = ("name", "args", "span")

    def __init__(self, name: str, args: list[Expr], span: Span) -> None:
        self.name = name
        self.args = args
        self.span = span


class Group(_Record):
    """Parenthesised expression(s): `(a)` or an argument list `(a, b)`."""

    items: list[Expr]
    span: Span
    _fields = __match_args__ = ("items", "span")

    def __init__(self, items: list[Expr], span: Span) -> None:
        self.items = items
        self.span = span


Expr = Num | Name | Str | BinOp | Neg | Call | Group

# ------------------------------------------------------------ line statements


class Const(_Record):
    name: str
    value: Expr
    span: Span
    name_span: Span
    _fields = __match_args__ = ("name", "value", "span", "name_span")

    def __init__(self, name: str, value: Expr, span: Span, name_span: Span) -> None:
        self.name = name
        self.value = value
        self.span = span
        self.name_span = name_span


class Alias(_Record):
    name: str
    target: str
    span: Span
    name_span: Span
    target_span: Span
    _fields = __match_args__ = ("name", "target", "span", "name_span", "target_span")

    def __init__(self, name: str, target: str, span: Span, name_span: Span,
                 target_span: Span) -> None:
        self.name = name
        self.target = target
        self.span = span
        self.name_span = name_span
        self.target_span = target_span


class VarDecl(_Record):
    """`VAR name` (the compiler picks a VARn) or `VAR name @ VARn` (pinned, for the host)."""

    name: str
    pin: str | None
    span: Span
    name_span: Span
    pin_span: Span | None
    _fields = __match_args__ = ("name", "pin", "span", "name_span", "pin_span")

    def __init__(self, name: str, pin: str | None, span: Span, name_span: Span,
                 pin_span: Span | None) -> None:
        self.name = name
        self.pin = pin
        self.span = span
        self.name_span = name_span
        self.pin_span = pin_span


class Include(_Record):
    path: str
    span: Span
    _fields = __match_args__ = ("path", "span")

    def __init__(self, path: str, span: Span) -> None:
        self.path = path
        self.span = span


class ProgramHeader(_Record):
    kind: str  # "mp" | "isr"
    number: int | None
    name: str | None
    span: Span
    _fields = __match_args__ = ("kind", "number", "name", "span")

    def __init__(self, kind: str, number: int | None, name: str | None, span: Span) -> None:
        self.kind = kind
        self.number = number
        self.name = name
        self.span = span


class End(_Record):
    what: str  # "mp" | "isr" | "if" | "for" | "while" | "repeat"
    span: Span
    _fields = __match_args__ = ("what", "span")

    def __init__(self, what: str, span: Span) -> None:
        self.what = what
        self.span = span


class ForStmt(_Record):
    count: Expr
    span: Span
    _fields = __match_args__ = ("count", "span")

    def __init__(self, count: Expr, span: Span) -> None:
        self.count = count
        self.span = span


class WhileStmt(_Record):
    left: Expr
    op: str
    right: Expr
    span: Span
    _fields = __match_args__ = ("left", "op", "right", "span")

    def __init__(self, left: Expr, op: str, right: Expr, span: Span) -> None:
        self.left = left
        self.op = op
        self.right = right
        self.span = span


class RepeatStmt(_Record):
    count: Expr
    span: Span
    _fields = __match_args__ = ("count", "span")

    def __init__(self, count: Expr, span: Span) -> None:
        self.count = count
        self.span = span


class Next(_Record):
    span: Span
    _fields = __match_args__ = ("span",)

    def __init__(self, span: Span) -> None:
        self.span = span


class ExitFor(_Record):
    span: Span
    _fields = __match_args__ = ("span",)

    def __init__(self, span: Span) -> None:
        self.span = span


class Exit(_Record):
    span: Span
    _fields = __match_args__ = ("span",)

    def __init__(self, span: Span) -> None:
        self.span = span


class IfStmt(_Record):
    left: Expr
    op: str
    right: Expr
    span: Span
    _fields = __match_args__ = ("left", "op", "right", "span")

    def __init__(self, left: Expr, op: str, right: Expr, span: Span) -> None:
        self.left = left
        self.op = op
        self.right = right
        self.span = span


class Else(_Record):
    span: Span
    _fields = __match_args__ = ("span",)

    def __init__(self, span: Span) -> None:
        self.span = span


class LabelStmt(_Record):
    label: str  # "0".."3" or an identifier
    span: Span
    _fields = __match_args__ = ("label", "span")

    def __init__(self, label: str, span: Span) -> None:
        self.label = label
        self.span = span


class Goto(_Record):
    label: str
    span: Span
    target_span: Span | None  # the label, where the caret of a bad label goes
    _fields = __match_args__ = ("label", "span", "target_span")

    def __init__(self, label: str, span: Span, target_span: Span | None = None) -> None:
        self.label = label
        self.span = span
        self.target_span = target_span


class CallStmt(_Record):
    target: str  # "MP21", "21" or a program name
    span: Span
    target_span: Span | None  # the name or number after CALL
    _fields = __match_args__ = ("target", "span", "target_span")

    def __init__(self, target: str, span: Span, target_span: Span | None = None) -> None:
        self.target = target
        self.span = span
        self.target_span = target_span


class Terminate(_Record):
    span: Span
    _fields = __match_args__ = ("span",)

    def __init__(self, span: Span) -> None:
        self.span = span


class Assign(_Record):
    target: str
    target_span: Span
    value: Expr
    span: Span
    _fields = __match_args__ = ("target", "target_span", "value", "span")

    def __init__(self, target: str, target_span: Span, value: Expr, span: Span) -> None:
        self.target = target
        self.target_span = target_span
        self.value = value
        self.span = span


class Command(_Record):
    name: str
    args: list[Expr]
    span: Span
    name_span: Span
    _fields = __match_args__ = ("name", "args", "span", "name_span")

    def __init__(self, name: str, args: list[Expr], span: Span, name_span: Span) -> None:
        self.name = name
        self.args = args
        self.span = span
        self.name_span = name_span


class InitHeader(_Record):
    """`INIT`: opens the initial-table block (power-on settings, chapter 8)."""

    span: Span
    _fields = __match_args__ = ("span",)

    def __init__(self, span: Span) -> None:
        self.span = span


class InterruptsHeader(_Record):
    """`INTERRUPTS setup` / `INTERRUPTS MP 3`: wiring injected into that setup program."""

    target: str  # "MP3", "3" or a program name
    span: Span
    target_span: Span
    _fields = __match_args__ = ("target", "span", "target_span")

    def __init__(self, target: str, span: Span, target_span: Span) -> None:
        self.target = target
        self.span = span
        self.target_span = target_span


class TriggersHeader(_Record):
    """`TRIGGERS`: opens the stand-alone FRnet DI trigger table."""

    span: Span
    _fields = __match_args__ = ("span",)

    def __init__(self, span: Span) -> None:
        self.span = span


class OnStmt(_Record):
    """`ON X P>=C+ CALL ISR 3` (an interrupt factor) or `ON DI 8.0 OFF_TO_ON CALL cycle`
    (a stand-alone trigger). Names are checked against the device profile when lowering."""

    subject: str  # an axis name, or "DI g.c"
    subject_span: Span
    condition: str  # "P>=C+", "4", "OFF_TO_ON", "ON", ...
    condition_span: Span
    action: str  # "CALL", or the first action word ("ABORT", "HOLD", ...)
    argument: str | None  # CALL target, or the second action word
    argument_kind: str | None  # "mp" / "isr" when written `CALL MP 5` / `CALL ISR 3`
    action_span: Span
    span: Span
    _fields = __match_args__ = ("subject", "subject_span", "condition", "condition_span",
                                "action", "argument", "argument_kind", "action_span", "span")

    def __init__(self, subject: str, subject_span: Span, condition: str, condition_span: Span,
                 action: str, argument: str | None, argument_kind: str | None, action_span: Span,
                 span: Span) -> None:
        self.subject = subject
        self.subject_span = subject_span
        self.condition = condition
        self.condition_span = condition_span
        self.action = action
        self.argument = argument
        self.argument_kind = argument_kind
        self.action_span = action_span
        self.span = span

    @property
    def is_trigger(self) -> bool:
        return self.subject.upper().startswith("DI")


Statement = (
    Const | Alias | VarDecl | Include | ProgramHeader | End | ForStmt | WhileStmt
    | RepeatStmt | Next | ExitFor | Exit | IfStmt
    | Else | LabelStmt | Goto | CallStmt | Terminate | Assign | Command
    | InitHeader | InterruptsHeader | TriggersHeader | OnStmt
)

# ------------------------------------------------------- blocks (structure pass)


class ForBlock(_Record):
    count: Expr
    body: list[Node]
    span: Span
    end_span: Span
    _fields = __match_args__ = ("count", "body", "span", "end_span")

    def __init__(self, count: Expr, body: list[Node], span: Span, end_span: Span) -> None:
        self.count = count
        self.body = body
        self.span = span
        self.end_span = end_span


class IfBlock(_Record):
    left: Expr
    op: str
    right: Expr
    then: list[Node]
    otherwise: list[Node] | None
    span: Span
    else_span: Span | None
    end_span: Span
    _fields = __match_args__ = ("left", "op", "right", "then", "otherwise", "span",
                                "else_span", "end_span")

    def __init__(self, left: Expr, op: str, right: Expr, then: list[Node],
                 otherwise: list[Node] | None, span: Span, else_span: Span | None,
                 end_span: Span) -> None:
        self.left = left
        self.op = op
        self.right = right
        self.then = then
        self.otherwise = otherwise
        self.span = span
        self.else_span = else_span
        self.end_span = end_span


class WhileBlock(_Record):
    """`WHILE a CMP b ... END WHILE`: lowered to LABEL, IF, the body, GOTO, END_IF."""

    left: Expr
    op: str
    right: Expr
    body: list[Node]
    span: Span
    end_span: Span
    _fields = __match_args__ = ("left", "op", "right", "body", "span", "end_span")

    def __init__(self, left: Expr, op: str, right: Expr, body: list[Node], span: Span,
                 end_span: Span) -> None:
        self.left = left
        self.op = op
        self.right = right
        self.body = body
        self.span = span
        self.end_span = end_span


class RepeatBlock(_Record):
    """`REPEAT n ... END REPEAT`: a FOR that leaves a count variable as it was."""

    count: Expr
    body: list[Node]
    span: Span
    end_span: Span
    _fields = __match_args__ = ("count", "body", "span", "end_span")

    def __init__(self, count: Expr, body: list[Node], span: Span, end_span: Span) -> None:
        self.count = count
        self.body = body
        self.span = span
        self.end_span = end_span


Node = ForBlock | IfBlock | WhileBlock | RepeatBlock | Statement


class Program(_Record):
    kind: str  # "mp" | "isr"
    slot: int | None
    name: str | None
    body: list[Node]
    span: Span
    end_span: Span
    source: str  # the file the program was written in
    _fields = __match_args__ = ("kind", "slot", "name", "body", "span", "end_span", "source")

    def __init__(self, kind: str, slot: int | None, name: str | None, body: list[Node], span: Span,
                 end_span: Span, source: str) -> None:
        self.kind = kind
        self.slot = slot
        self.name = name
        self.body = body
        self.span = span
        self.end_span = end_span
        self.source = source


class InitBlock(_Record):
    """`INIT ... END INIT`: initial-table commands, in source order."""

    body: list[Command]
    span: Span
    end_span: Span
    source: str
    _fields = __match_args__ = ("body", "span", "end_span", "source")

    def __init__(self, body: list[Command], span: Span, end_span: Span, source: str) -> None:
        self.body = body
        self.span = span
        self.end_span = end_span
        self.source = source


class InterruptsBlock(_Record):
    """`INTERRUPTS setup ... END INTERRUPTS`: interrupt factors wired by program `target`."""

    target: str
    target_span: Span
    entries: list[OnStmt]
    span: Span
    end_span: Span
    source: str
    _fields = __match_args__ = ("target", "target_span", "entries", "span", "end_span", "source")

    def __init__(self, target: str, target_span: Span, entries: list[OnStmt], span: Span,
                 end_span: Span, source: str) -> None:
        self.target = target
        self.target_span = target_span
        self.entries = entries
        self.span = span
        self.end_span = end_span
        self.source = source


class TriggersBlock(_Record):
    """`TRIGGERS ... END TRIGGERS`: FRnet DI events of stand-alone mode (chapter 10)."""

    entries: list[OnStmt]
    span: Span
    end_span: Span
    source: str
    _fields = __match_args__ = ("entries", "span", "end_span", "source")

    def __init__(self, entries: list[OnStmt], span: Span, end_span: Span, source: str) -> None:
        self.entries = entries
        self.span = span
        self.end_span = end_span
        self.source = source


class Unit(_Record):
    """One build: top-level declarations and programs of every file and include."""

    consts: list[Const]
    aliases: list[Alias]
    variables: list[VarDecl]
    programs: list[Program]
    inits: list[InitBlock]
    interrupts: list[InterruptsBlock]
    triggers: list[TriggersBlock]
    _fields = __match_args__ = ("consts", "aliases", "variables", "programs", "inits",
                                "interrupts", "triggers")

    def __init__(self, consts: list[Const] | None = None, aliases: list[Alias] | None = None,
                 variables: list[VarDecl] | None = None, programs: list[Program] | None = None,
                 inits: list[InitBlock] | None = None,
                 interrupts: list[InterruptsBlock] | None = None,
                 triggers: list[TriggersBlock] | None = None) -> None:
        self.consts = [] if consts is None else consts
        self.aliases = [] if aliases is None else aliases
        self.variables = [] if variables is None else variables
        self.programs = [] if programs is None else programs
        self.inits = [] if inits is None else inits
        self.interrupts = [] if interrupts is None else interrupts
        self.triggers = [] if triggers is None else triggers
