"""Innermost FOR loops compiled whole (`source`): one call runs as many turns of the loop as
fit in the slice, instead of a call per block of lines and a trip through `lines.run`
between them.

A loop qualifies when its body holds only the lines a block holds (`blocks`: SET_VAR and
VAR_CALCULATE as statements, lines that do nothing) and IF / ELSE / END_IF around them,
EXIT_FOR and GOTO (all prepared as quick lines), and its NEXT is a quick line. Its body is
written out as structured Python: an IF becomes an `if`, and each line adds the line time
to the clock in order, as one by one (the clock after a turn is the one the lines leave).
The lines run count by blocks of lines (`n += k` where a path forks or ends).

The function is entered at the line after the FOR, only from `lines.run`, and runs a turn
only when the longest turn (every line of the body and the NEXT: the jumps only go forward)
fits in the line budget and before the horizon, as `lines.run` enters a block; when the
next turn does not fit it returns, and the lines run on one block or one line at a time.
It checks first that the frame's innermost loop is this FOR's (a frame whose loops were
changed from outside runs the ordinary way, so that its error comes out as before); none
of its lines can raise after that.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from mplang.ir.macro import VarRef
from mplang.m8194h.sim import precompile

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import VirtualController
    from mplang.m8194h.sim.tables import MacroTable


class _Writer:
    """The body of one loop as it is written: the text, and the lines counted since the
    last `n +=` (`pending`)."""

    def __init__(self, vc: VirtualController, table: MacroTable,
                 prepared: precompile.Prepared, straight: list[str | None],
                 condition: dict[int, str], next_pc: int) -> None:
        self.vc, self.table, self.prepared = vc, table, prepared
        self.straight, self.condition, self.next_pc = straight, condition, next_pc
        self.names = [line.command.short_name for line in table.lines]
        self.text: list[str] = []
        self.pending = 0

    def out(self, depth: int, statement: str) -> None:
        self.text.append("    " * depth + statement)

    def line(self, depth: int) -> None:
        """One more line run: its time, counted with the next `flush`."""
        self.out(depth, "c += lt")
        self.pending += 1

    def flush(self, depth: int) -> None:
        if self.pending:
            self.out(depth, f"n += {self.pending}")
        self.pending = 0

    def quick(self, pc: int, name: str) -> bool:
        return self.names[pc] == name and \
            isinstance(self.prepared.lines[pc][0], precompile.Quick)

    def lines(self, low: int, high: int, depth: int) -> bool:
        """Write lines `low` up to `high` (not included); False if one cannot be."""
        pc = low
        while pc < high:
            text = self.straight[pc]
            if text is not None:
                if text != "pass":
                    self.out(depth, text)
                self.line(depth)
                pc += 1
            elif pc in self.condition and self.quick(pc, "IF"):
                after = self.branch(pc, depth)
                if after is None:
                    return False
                pc = after
            elif self.quick(pc, "EXIT_FOR") and \
                    self.table.exit_for_end.get(pc) == self.next_pc:
                self.line(depth)
                self.flush(depth)
                self.out(depth, "loops.pop()")
                self.out(depth, f"return {self.next_pc + 1}, c, n")
                pc += 1
            elif self.quick(pc, "GOTO"):
                label = precompile.constant_code(self.vc, self.table.lines[pc].operands[0])
                if label not in self.table.labels:
                    return False
                self.line(depth)
                self.flush(depth)
                self.out(depth, "loops.clear()")
                self.out(depth, f"return {self.table.labels[label] + 1}, c, n")
                pc += 1
            else:
                return False
        return True

    def branch(self, pc: int, depth: int) -> int | None:
        """Write the IF at `pc` with its branches; the line after its END_IF, or None."""
        false = self.table.if_false[pc]
        has_else = self.names[false] == "ELSE"
        end = self.table.else_end.get(false, -1) if has_else else false
        if end < 0 or end >= self.next_pc or self.straight[end] != "pass" or \
                (has_else and not self.quick(false, "ELSE")):
            return None
        self.line(depth)
        self.flush(depth)
        self.out(depth, f"if {self.condition[pc]}:")
        if not self.lines(pc + 1, false, depth + 1):
            return None
        self.line(depth + 1)  # the ELSE (on after the END_IF) or the END_IF
        self.flush(depth + 1)
        if has_else:
            self.out(depth, "else:")
            if not self.lines(false + 1, end, depth + 1):
                return None
            self.line(depth + 1)  # the END_IF
            self.flush(depth + 1)
        return end + 1


def source(vc: VirtualController, table: MacroTable, prepared: precompile.Prepared,
           straight: list[str | None], condition: dict[int, str], for_pc: int) -> str | None:
    """The function `l<pc>` that runs the loop of the FOR at `for_pc`, entered at the line
    after it, or None if the loop does not qualify. `straight` holds each line as a block's
    statement (`blocks`), `condition` each quick IF's test as an expression."""
    next_pc = table.for_end[for_pc]
    count = table.lines[for_pc].operands
    if not isinstance(prepared.lines[for_pc][0], precompile.Quick) or len(count) != 1 or \
            not isinstance(prepared.lines[next_pc][0], precompile.Quick):
        return None
    counted = count[0] if isinstance(count[0], VarRef) else None
    if counted is not None and not 0 <= counted.index < len(vc.vars):
        return None
    writer = _Writer(vc, table, prepared, straight, condition, next_pc)
    if not writer.lines(for_pc + 1, next_pc, 2):
        return None
    longest = next_pc - for_pc  # the body and the NEXT, each at most once a turn
    span = longest * vc.line_time
    if counted is None:
        check, remaining = "ref is not None", "counter[0]"
    else:
        check, remaining = f"ref is None or ref.index != {counted.index}", \
            f"V[{counted.index}]"
    writer.line(2)  # the NEXT
    writer.flush(2)
    head = [f"def l{for_pc}(_f, c, n, most, h, V=V, B=B, lt=lt):",
            "    loops = _f.loops",
            "    if not loops:",
            "        return None",
            "    start, ref, counter = loops[-1]",
            f"    if start != {for_pc} or {check}:",
            "        return None",
            f"    if n + {longest} > most or c + {span!r} >= h:",
            "        return None"]
    tail = [f"        {remaining} -= 1",
            f"        if {remaining} <= 0:",
            "            loops.pop()",
            f"            return {next_pc + 1}, c, n",
            f"        if n + {longest} > most or c + {span!r} >= h:",
            f"            return {for_pc + 1}, c, n"]
    return "\n".join(head + _in_locals(writer.text + tail)) + "\n"


_CELL = re.compile(r"\b([VB])\[(\d+)\]")
_STORE = re.compile(r"\b([VB])_(\d+) [-+]?= ")


def _in_locals(body: list[str]) -> list[str]:
    """The loop's turns with every variable they name held in a local (`V_3` for `V[3]`):
    read from the lists before the first turn, the ones a line stores written back before
    each return. Nothing else reads or writes the lists while the turns run (its lines are
    all here, and every index is a constant)."""
    body = [_CELL.sub(r"\1_\2", text) for text in body]
    named = sorted({match.groups() for text in body for match in
                    re.finditer(r"\b([VB])_(\d+)\b", text)})
    stored = sorted({match.groups() for text in body for match in _STORE.finditer(text)})
    out = [f"    {kind}_{index} = {kind}[{index}]" for kind, index in named]
    out.append("    while True:")
    for text in body:
        stripped = text.lstrip()
        if stripped.startswith("return "):
            indent = text[:len(text) - len(stripped)]
            out.extend(f"{indent}{kind}[{index}] = {kind}_{index}" for kind, index in stored)
        out.append(text)
    return out
