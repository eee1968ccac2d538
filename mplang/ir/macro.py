"""The small IR between the front end and the encoder: macro lines with resolved operands."""

from __future__ import annotations

from dataclasses import dataclass, field

from mplang.ir.catalogue import Command
from mplang.lang.diagnostics import Span


@dataclass(frozen=True)
class VarRef:
    """Device variable VARn (sent as 0x7FFF0000 + n)."""

    index: int


@dataclass(frozen=True)
class BVarRef:
    """Byte variable bVARn (sent as 0x80 + n)."""

    index: int


@dataclass(frozen=True)
class ProgramRef:
    """An MP named by slot or by name; the slot is known after linking."""

    name: str | None = None
    slot: int | None = None


Operand = int | float | VarRef | BVarRef | ProgramRef


@dataclass
class MacroLine:
    command: Command
    operands: tuple[Operand, ...]
    span: Span


@dataclass
class CallSite:
    target: ProgramRef
    span: Span


@dataclass
class LoweredProgram:
    kind: str  # "mp" | "isr"
    slot: int | None  # as written; the linker fills unnumbered ones
    name: str | None
    source: str
    span: Span
    end_span: Span
    lines: list[MacroLine] = field(default_factory=list)
    calls: list[CallSite] = field(default_factory=list)

    def lines_used(self, close_counts: bool) -> int:
        return sum(line.command.line_cost for line in self.lines) + (1 if close_counts else 0)

    @property
    def label(self) -> str:
        slot = f"{self.kind.upper()}{self.slot}" if self.slot is not None else self.kind.upper()
        return f"{slot} {self.name}" if self.name else slot
