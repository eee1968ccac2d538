"""The small IR between the front end and the encoder: macro lines with resolved operands.

Its classes are written out on `mplang.lang.record` bases rather than made by `@dataclass`: every
command imports this module (see that module for why)."""

from __future__ import annotations

from mplang.ir.catalogue import Command
from mplang.lang.diagnostics import Span
from mplang.lang.record import FrozenRecord, Record


class VarRef(FrozenRecord):
    """Device variable VARn (sent as 0x7FFF0000 + n)."""

    index: int
    _fields = __match_args__ = ("index",)

    def __init__(self, index: int) -> None:
        self.__dict__["index"] = index


class BVarRef(FrozenRecord):
    """Byte variable bVARn (sent as 0x80 + n)."""

    index: int
    _fields = __match_args__ = ("index",)

    def __init__(self, index: int) -> None:
        self.__dict__["index"] = index


class ProgramRef(FrozenRecord):
    """An MP named by slot or by name; the slot is known after linking."""

    name: str | None
    slot: int | None
    _fields = __match_args__ = ("name", "slot")

    def __init__(self, name: str | None = None, slot: int | None = None) -> None:
        fields = self.__dict__
        fields["name"] = name
        fields["slot"] = slot


Operand = int | float | VarRef | BVarRef | ProgramRef


class MacroLine(Record):
    command: Command
    operands: tuple[Operand, ...]
    span: Span
    _fields = __match_args__ = ("command", "operands", "span")

    def __init__(self, command: Command, operands: tuple[Operand, ...], span: Span) -> None:
        self.command = command
        self.operands = operands
        self.span = span


class CallSite(Record):
    target: ProgramRef
    span: Span
    _fields = __match_args__ = ("target", "span")

    def __init__(self, target: ProgramRef, span: Span) -> None:
        self.target = target
        self.span = span


class LoweredProgram(Record):
    kind: str  # "mp" | "isr"
    slot: int | None  # as written; the linker fills unnumbered ones
    name: str | None
    source: str
    span: Span
    end_span: Span
    lines: list[MacroLine]
    calls: list[CallSite]
    _fields = __match_args__ = ("kind", "slot", "name", "source", "span", "end_span", "lines",
                                "calls")

    def __init__(self, kind: str, slot: int | None, name: str | None, source: str, span: Span,
                 end_span: Span, lines: list[MacroLine] | None = None,
                 calls: list[CallSite] | None = None) -> None:
        self.kind = kind
        self.slot = slot
        self.name = name
        self.source = source
        self.span = span
        self.end_span = end_span
        self.lines = [] if lines is None else lines
        self.calls = [] if calls is None else calls
        # not a field, never compared: (the lines list, its length, what its lines cost)
        self._cost: tuple[list[MacroLine], int, int] | None = None

    def lines_used(self, close_counts: bool) -> int:
        """The device lines the program takes. Summed once per lines list and length: a
        program kept between an editor's builds is linked every build, its lines the
        same; later passes only add lines (interrupt wiring), which changes the length."""
        lines, cost = self.lines, self._cost
        if cost is None or cost[0] is not lines or cost[1] != len(lines):
            # summed over a list, not a generator: no resumption per line
            cost = self._cost = (lines, len(lines),
                                 sum([line.command.line_cost for line in lines]))
        return cost[2] + (1 if close_counts else 0)

    def copied(self) -> LoweredProgram:
        """A copy for one build, with its own lists (later passes add lines and set the
        slot) and the cost of its lines as summed for this one (every field of
        `LoweredProgram`, written out: `dataclasses.replace` costs ten times as much)."""
        made = LoweredProgram(self.kind, self.slot, self.name, self.source, self.span,
                              self.end_span, list(self.lines), list(self.calls))
        made._cost = (made.lines, len(made.lines), self.lines_used(False))
        return made

    @property
    def label(self) -> str:
        slot = f"{self.kind.upper()}{self.slot}" if self.slot is not None else self.kind.upper()
        return f"{slot} {self.name}" if self.name else slot
