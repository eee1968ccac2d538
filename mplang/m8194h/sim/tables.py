"""Macro tables as the device stores them, and the device's own download validation.

This is deliberately independent of the compiler's checks: the virtual controller must
reject a bad download by itself, with the manual's download error codes (9.12, RS 10972) and
0-based line numbers, whatever sent it. The structure found here (matching FOR/NEXT,
IF/ELSE/END_IF, labels) is kept as jump tables for the interpreter.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mplang.ir.catalogue import Catalogue, Command, Profile
from mplang.ir.macro import Operand
from mplang.m8194h.encode import EncodeError, Encoder


@dataclass(frozen=True)
class StoredLine:
    """One downloaded command: its frame, decoded, and the slot line it starts on."""

    command: Command
    operands: tuple[Operand, ...]
    frame: tuple[int, ...]
    slot_line: int


@dataclass
class MacroTable:
    kind: str  # "mp" | "isr"
    slot: int
    lines: list[StoredLine] = field(default_factory=list)
    # pc -> pc jump tables filled in by validation
    for_end: dict[int, int] = field(default_factory=dict)  # FOR -> its NEXT
    next_start: dict[int, int] = field(default_factory=dict)  # NEXT -> its FOR
    exit_for_end: dict[int, int] = field(default_factory=dict)  # EXIT_FOR -> enclosing NEXT
    if_false: dict[int, int] = field(default_factory=dict)  # IF -> its ELSE or END_IF
    else_end: dict[int, int] = field(default_factory=dict)  # ELSE -> its END_IF
    labels: dict[int, int] = field(default_factory=dict)  # label number -> pc


@dataclass(frozen=True)
class DownloadError:
    code: int  # the manual's download error code 0x01..0x10
    line: int  # 0-based slot line, as register 113 reports it
    command: int  # sub-function code of the offending command (register 112)


def decode_frame(encoder: Encoder, frame: list[int]) -> tuple[Command, tuple[Operand, ...]] | None:
    try:
        return encoder.decode(frame)
    except EncodeError:
        return None


class Structure:
    """The block structure of one table as its lines arrive. The firmware refuses a line that
    breaks it at once (ELSE outside IF, a label twice, nesting too deep: register-102 causes
    0xB1-0xBC, RS 11368); what can only be judged at the close (a block left open, a GOTO
    without its LABEL) `finish` reports. The jump tables for the interpreter fill in as
    lines are accepted; a refused line changes nothing."""

    def __init__(self, table: MacroTable, profile: Profile) -> None:
        self.table = table
        self.if_depth = profile.limit("if_depth")
        self.for_depth = profile.limit("for_depth")
        self.blocks: list[tuple[str, int]] = []  # ("for"|"if"|"else", pc)
        self.label_lines: dict[int, int] = {}
        self.gotos: list[tuple[int, int]] = []

    def add(self, pc: int, line: StoredLine) -> int | None:
        """Take line `pc` (the table's next); return the download error it makes, if any."""
        table, blocks = self.table, self.blocks
        name = line.command.short_name
        if name == "IF":
            if sum(1 for kind, _ in blocks if kind in ("if", "else")) >= self.if_depth:
                return 0x02
            blocks.append(("if", pc))
        elif name == "ELSE":
            if not blocks or blocks[-1][0] != "if":
                return 0x03
            table.if_false[blocks[-1][1]] = pc
            blocks[-1] = ("else", pc)
        elif name == "END_IF":
            if not blocks or blocks[-1][0] not in ("if", "else"):
                return 0x04
            kind, start = blocks.pop()
            if kind == "if":
                table.if_false[start] = pc
            else:
                table.else_end[start] = pc
        elif name == "FOR":
            if sum(1 for kind, _ in blocks if kind == "for") >= self.for_depth:
                return 0x07
            blocks.append(("for", pc))
        elif name == "EXIT_FOR":
            if not any(kind == "for" for kind, _ in blocks):
                return 0x08
            table.exit_for_end[pc] = -1  # resolved at the enclosing NEXT
        elif name == "NEXT":
            if not blocks or blocks[-1][0] != "for":
                return 0x09 if not any(k == "for" for k, _ in blocks) else 0x05
            _, start = blocks.pop()
            table.for_end[start] = pc
            table.next_start[pc] = start
            for exit_pc in range(start, pc):
                if table.exit_for_end.get(exit_pc) == -1:
                    table.exit_for_end[exit_pc] = pc
        elif name == "LABEL":
            number = int(line.operands[0])  # type: ignore[arg-type]
            if number in self.label_lines:
                return 0x0B
            if any(kind in ("if", "else") for kind, _ in blocks):
                return 0x0C
            if any(kind == "for" for kind, _ in blocks):
                return 0x0D
            self.label_lines[number] = pc
        elif name == "GOTO":
            self.gotos.append((pc, int(line.operands[0])))  # type: ignore[arg-type]
        return None

    def finish(self) -> DownloadError | None:
        """At the close: a block left open or a GOTO without its LABEL; else the labels."""
        table = self.table
        if self.blocks:
            kind, start = self.blocks[-1]
            return DownloadError(0x0A if kind == "for" else 0x05, table.lines[start].slot_line,
                                 table.lines[start].command.code or 0)
        for pc, number in self.gotos:
            if number not in self.label_lines:
                line = table.lines[pc]
                return DownloadError(0x0E, line.slot_line, line.command.code or 0)
        table.labels = self.label_lines
        return None


def validate(table: MacroTable, budget: int, catalogue: Catalogue,
             close_counts: bool) -> DownloadError | None:
    """Check a whole table the way the firmware does as its lines arrive and at the close;
    fill the jump tables. The operators and every other parameter are `frame_check`'s."""
    used = sum(line.command.line_cost for line in table.lines)
    if used + (1 if close_counts else 0) > budget:
        # the close does not fit: it is the failing line (112/113 name it)
        close = catalogue.macro("MP_CLOSE" if table.kind == "mp" else "MP_ISR_CLOSE")
        return DownloadError(0x01, used, close.code or 0)
    structure = Structure(table, catalogue.profile)
    for pc, line in enumerate(table.lines):
        error = structure.add(pc, line)
        if error is not None:
            return DownloadError(error, line.slot_line, line.command.code or 0)
    return structure.finish()
