"""Typed syntax tree of `.mp` sources. Every node keeps the span it came from."""

from __future__ import annotations

from dataclasses import dataclass, field

from mplang.lang.diagnostics import Span

# ---------------------------------------------------------------- expressions


@dataclass
class Num:
    value: int
    span: Span


@dataclass
class Name:
    name: str
    span: Span


@dataclass
class Str:
    value: str
    span: Span


@dataclass
class BinOp:
    op: str
    left: Expr
    right: Expr
    span: Span


@dataclass
class Neg:
    operand: Expr
    span: Span


@dataclass
class Call:
    name: str
    args: list[Expr]
    span: Span


@dataclass
class Group:
    """Parenthesised expression(s): `(a)` or an argument list `(a, b)`."""

    items: list[Expr]
    span: Span


Expr = Num | Name | Str | BinOp | Neg | Call | Group

# ------------------------------------------------------------ line statements


@dataclass
class Const:
    name: str
    value: Expr
    span: Span
    name_span: Span


@dataclass
class Alias:
    name: str
    target: str
    span: Span
    name_span: Span
    target_span: Span


@dataclass
class VarDecl:
    """`VAR name` (the compiler picks a VARn) or `VAR name @ VARn` (pinned, for the host)."""

    name: str
    pin: str | None
    span: Span
    name_span: Span
    pin_span: Span | None


@dataclass
class Include:
    path: str
    span: Span


@dataclass
class ProgramHeader:
    kind: str  # "mp" | "isr"
    number: int | None
    name: str | None
    span: Span


@dataclass
class End:
    what: str  # "mp" | "isr" | "if" | "for" | "while" | "repeat"
    span: Span


@dataclass
class ForStmt:
    count: Expr
    span: Span


@dataclass
class WhileStmt:
    left: Expr
    op: str
    right: Expr
    span: Span


@dataclass
class RepeatStmt:
    count: Expr
    span: Span


@dataclass
class Next:
    span: Span


@dataclass
class ExitFor:
    span: Span


@dataclass
class Exit:
    span: Span


@dataclass
class IfStmt:
    left: Expr
    op: str
    right: Expr
    span: Span


@dataclass
class Else:
    span: Span


@dataclass
class LabelStmt:
    label: str  # "0".."3" or an identifier
    span: Span


@dataclass
class Goto:
    label: str
    span: Span
    target_span: Span | None = None  # the label, where the caret of a bad label goes


@dataclass
class CallStmt:
    target: str  # "MP21", "21" or a program name
    span: Span
    target_span: Span | None = None  # the name or number after CALL


@dataclass
class Terminate:
    span: Span


@dataclass
class Assign:
    target: str
    target_span: Span
    value: Expr
    span: Span


@dataclass
class Command:
    name: str
    args: list[Expr]
    span: Span
    name_span: Span


@dataclass
class InitHeader:
    """`INIT`: opens the initial-table block (power-on settings, chapter 8)."""

    span: Span


@dataclass
class InterruptsHeader:
    """`INTERRUPTS setup` / `INTERRUPTS MP 3`: wiring injected into that setup program."""

    target: str  # "MP3", "3" or a program name
    span: Span
    target_span: Span


@dataclass
class TriggersHeader:
    """`TRIGGERS`: opens the stand-alone FRnet DI trigger table."""

    span: Span


@dataclass
class OnStmt:
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


@dataclass
class ForBlock:
    count: Expr
    body: list[Node]
    span: Span
    end_span: Span


@dataclass
class IfBlock:
    left: Expr
    op: str
    right: Expr
    then: list[Node]
    otherwise: list[Node] | None
    span: Span
    else_span: Span | None
    end_span: Span


@dataclass
class WhileBlock:
    """`WHILE a CMP b ... END WHILE`: lowered to LABEL, IF, the body, GOTO, END_IF."""

    left: Expr
    op: str
    right: Expr
    body: list[Node]
    span: Span
    end_span: Span


@dataclass
class RepeatBlock:
    """`REPEAT n ... END REPEAT`: a FOR that leaves a count variable as it was."""

    count: Expr
    body: list[Node]
    span: Span
    end_span: Span


Node = ForBlock | IfBlock | WhileBlock | RepeatBlock | Statement


@dataclass
class Program:
    kind: str  # "mp" | "isr"
    slot: int | None
    name: str | None
    body: list[Node]
    span: Span
    end_span: Span
    source: str  # the file the program was written in


@dataclass
class InitBlock:
    """`INIT ... END INIT`: initial-table commands, in source order."""

    body: list[Command]
    span: Span
    end_span: Span
    source: str


@dataclass
class InterruptsBlock:
    """`INTERRUPTS setup ... END INTERRUPTS`: interrupt factors wired by program `target`."""

    target: str
    target_span: Span
    entries: list[OnStmt]
    span: Span
    end_span: Span
    source: str


@dataclass
class TriggersBlock:
    """`TRIGGERS ... END TRIGGERS`: FRnet DI events of stand-alone mode (chapter 10)."""

    entries: list[OnStmt]
    span: Span
    end_span: Span
    source: str


@dataclass
class Unit:
    """One build: top-level declarations and programs of every file and include."""

    consts: list[Const] = field(default_factory=list)
    aliases: list[Alias] = field(default_factory=list)
    variables: list[VarDecl] = field(default_factory=list)
    programs: list[Program] = field(default_factory=list)
    inits: list[InitBlock] = field(default_factory=list)
    interrupts: list[InterruptsBlock] = field(default_factory=list)
    triggers: list[TriggersBlock] = field(default_factory=list)
