"""Macro tables as the device stores them, and the device's own download validation.

This is deliberately independent of the compiler's checks: the virtual controller must
reject a bad download by itself, with the manual's download error codes (9.12, RS 10972) and
0-based line numbers, whatever sent it. The structure found here (matching FOR/NEXT,
IF/ELSE/END_IF, labels) is kept as jump tables for the interpreter.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mplang.ir.catalogue import Catalogue, Command
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


def validate(table: MacroTable, budget: int, catalogue: Catalogue,
             close_counts: bool) -> DownloadError | None:
    """Check a closed table the way the firmware does; fill the jump tables."""
    profile = catalogue.profile
    calc_codes = set(profile.calc_ops.values())
    cmp_codes = set(profile.cmp_ops.values())
    # The example prints "<=" as 3C 3D (RS 10577): accept both byte orders of each code.
    cmp_codes |= {((c & 0xFF) << 8) | (c >> 8) for c in cmp_codes if c > 0xFF}
    used = sum(line.command.line_cost for line in table.lines) + (1 if close_counts else 0)
    if used > budget:
        last = table.lines[-1] if table.lines else None
        return DownloadError(0x01, budget, last.command.code or 0 if last else 0)
    blocks: list[tuple[str, int]] = []  # ("for"|"if"|"else", pc)
    label_lines: dict[int, int] = {}
    gotos: list[tuple[int, int]] = []
    for pc, line in enumerate(table.lines):
        name = line.command.short_name
        code = line.command.code or 0

        def fail(error: int, at: StoredLine = line, cmd: int = code) -> DownloadError:
            return DownloadError(error, at.slot_line, cmd)

        if name == "IF":
            if sum(1 for kind, _ in blocks if kind in ("if", "else")) >= profile.limit("if_depth"):
                return fail(0x02)
            if int(line.operands[1]) not in cmp_codes:  # type: ignore[arg-type]
                return fail(0x06)
            blocks.append(("if", pc))
        elif name == "ELSE":
            if not blocks or blocks[-1][0] != "if":
                return fail(0x03)
            table.if_false[blocks[-1][1]] = pc
            blocks[-1] = ("else", pc)
        elif name == "END_IF":
            if not blocks or blocks[-1][0] not in ("if", "else"):
                return fail(0x04)
            kind, start = blocks.pop()
            if kind == "if":
                table.if_false[start] = pc
            else:
                table.else_end[start] = pc
        elif name == "FOR":
            if sum(1 for kind, _ in blocks if kind == "for") >= profile.limit("for_depth"):
                return fail(0x07)
            blocks.append(("for", pc))
        elif name == "EXIT_FOR":
            if not any(kind == "for" for kind, _ in blocks):
                return fail(0x08)
            table.exit_for_end[pc] = -1  # resolved at the enclosing NEXT
        elif name == "NEXT":
            if not blocks or blocks[-1][0] != "for":
                return fail(0x09 if not any(k == "for" for k, _ in blocks) else 0x05)
            _, start = blocks.pop()
            table.for_end[start] = pc
            table.next_start[pc] = start
            for exit_pc in range(start, pc):
                if table.exit_for_end.get(exit_pc) == -1:
                    table.exit_for_end[exit_pc] = pc
        elif name == "LABEL":
            number = int(line.operands[0])  # type: ignore[arg-type]
            if number in label_lines:
                return fail(0x0B)
            if any(kind in ("if", "else") for kind, _ in blocks):
                return fail(0x0C)
            if any(kind == "for" for kind, _ in blocks):
                return fail(0x0D)
            label_lines[number] = pc
        elif name == "GOTO":
            gotos.append((pc, int(line.operands[0])))  # type: ignore[arg-type]
        elif name == "VAR_CALCULATE" and int(line.operands[1]) not in calc_codes:  # type: ignore[arg-type]
            return fail(0x10)
    if blocks:
        kind, start = blocks[-1]
        return DownloadError(0x0A if kind == "for" else 0x05, table.lines[start].slot_line,
                             table.lines[start].command.code or 0)
    for pc, number in gotos:
        if number not in label_lines:
            line = table.lines[pc]
            return DownloadError(0x0E, line.slot_line, line.command.code or 0)
    table.labels = label_lines
    return None
