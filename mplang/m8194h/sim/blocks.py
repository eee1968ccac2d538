"""Straight runs of quick lines fused into one function each (`fuse`), so that a loop of
arithmetic costs one call per run of lines instead of one per line.

A block starts where a run of lines may be entered (the first line, the line after any line
that is not a straight line, and every jump target the table knows) and holds the straight
lines that follow (SET_VAR and VAR_CALCULATE prepared as quick lines, and the lines that do
nothing), ended by one more quick line that decides where to go on (IF and NEXT written
out; FOR, ELSE, EXIT_FOR and GOTO called) or by the first line that is not quick. The block
is written out as Python source, one statement per line, and adds the line time to the
clock once per line, in order, so that the clock after it is the one the lines run one by
one would leave.

A straight line in a block cannot raise: its variables are checked to exist when the block
is made and hold ints; only the closing quick line may (a NEXT whose loop is gone), so an
error in a block is that line's. `lines.run` enters a block only when the whole of it fits
in the line budget and before the time horizon, and never under `before_line`; otherwise the
lines run one by one as before.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from mplang.ir.macro import BVarRef, Operand, VarRef
from mplang.m8194h.sim import loops, precompile

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import Frame, VirtualController
    from mplang.m8194h.sim.tables import MacroTable

Block = Callable[["Frame", float], tuple[int, float]]
"""A fused block: runs its lines on the frame from the clock given; returns the pc to go on
at and the clock after its lines."""

Loop = Callable[["Frame", float, int, int, float], tuple[int, float, int] | None]
"""A compiled loop (`loops`): from the clock, the lines run, the line budget and the
horizon, the pc to go on at, the clock and the lines run after its turns; None when it ran
no turn."""

Fused = tuple[Block, int, float, Loop | None]
"""A block, its number of lines, a bound of the time they take (more than the clock
before its last line can be past the clock at its start), and the loop whose body starts
there, if it is compiled."""

LONGEST = 64
"""Lines of a block at most (the generated source stays small)."""


def _expr(vc: VirtualController, operand: Operand) -> str | None:
    """An operand as an expression of the block's source, or None if a straight line
    reading it could raise or read something else than `vc.value` would."""
    if isinstance(operand, VarRef):
        return f"V[{operand.index}]" if 0 <= operand.index < len(vc.vars) else None
    if isinstance(operand, BVarRef):
        return f"B[{operand.index}]" if 0 <= operand.index < len(vc.bvars) else None
    if isinstance(operand, bool) or not isinstance(operand, (int, float)):
        return None
    return str(int(operand))


def _wrap(expr: str) -> str:
    return precompile.WRAP.replace("{expr}", expr)


def _straight(vc: VirtualController, name: str, ops: tuple[Operand, ...]) -> str | None:
    """A SET_VAR or VAR_CALCULATE (already a quick line) as one statement, or None."""
    if name == "SET_VAR" and len(ops) == 2 and isinstance(ops[0], VarRef):
        dest, value = _expr(vc, ops[0]), _expr(vc, ops[1])
        if dest is None or value is None:
            return None
        if isinstance(ops[1], (VarRef, BVarRef)):
            return f"{dest} = {_wrap(value)}"
        return f"{dest} = {((int(value) + 0x80000000) & 0xFFFFFFFF) - 0x80000000}"
    if name == "VAR_CALCULATE" and len(ops) == 4 and isinstance(ops[3], VarRef):
        symbol = precompile.calc_symbol(vc, precompile.constant_code(vc, ops[1]))
        dest, left, right = _expr(vc, ops[3]), _expr(vc, ops[0]), _expr(vc, ops[2])
        if symbol is None or dest is None or left is None or right is None:
            return None
        return f"{dest} = {_wrap(f'{left} {symbol} {right}')}"
    return None


def _condition(vc: VirtualController, table: MacroTable, pc: int,
               ops: tuple[Operand, ...]) -> str | None:
    """An IF's test (the IF already a quick line) as an expression, or None."""
    if len(ops) != 3 or pc not in table.if_false:
        return None
    symbol = precompile.compare_symbol(vc, precompile.constant_code(vc, ops[1]))
    left, right = _expr(vc, ops[0]), _expr(vc, ops[2])
    if symbol is None or left is None or right is None:
        return None
    return f"{left} {symbol} {right}"


def _next(pc: int) -> str:
    """NEXT (already a quick line) as the block's last statements: `precompile._next`
    written out, so that a loop's body and its NEXT are one call."""
    return (f"start, ref, counter = _f.loops[-1]\n"
            f"    if ref is not None:\n"
            f"        V[ref.index] -= 1\n"
            f"        remaining = V[ref.index]\n"
            f"    else:\n"
            f"        counter[0] -= 1\n"
            f"        remaining = counter[0]\n"
            f"    if remaining > 0:\n"
            f"        return start + 1, c\n"
            f"    _f.loops.pop()\n"
            f"    return {pc + 1}, c")


def _entries(table: MacroTable, straight: list[str | None]) -> set[int]:
    """The lines a run may enter a block at."""
    entries = {0}
    entries.update(pc + 1 for pc, text in enumerate(straight) if text is None)
    for jumps in (table.if_false, table.for_end, table.else_end, table.exit_for_end,
                  table.labels):
        entries.update(end + 1 for end in jumps.values() if end >= 0)
    return entries


def fuse(vc: VirtualController, table: MacroTable,
         prepared: precompile.Prepared) -> list[Fused | None]:
    """One entry per line (and None for the closing line): the block that starts there, or
    None where no block of two lines or more (nor a compiled loop, `loops`) does. All
    blocks of a table are compiled in one go."""
    quick = prepared.quick
    names = [line.command.short_name for line in table.lines]
    straight = _statements(vc, prepared, names)
    condition = {pc: text for pc, (handler, ops, _motion) in enumerate(prepared.lines)
                 if names[pc] == "IF" and isinstance(handler, precompile.Quick)
                 and (text := _condition(vc, table, pc, ops)) is not None}
    source: list[str] = []
    looped = set()  # the first line of each compiled loop's body
    for for_pc in table.for_end:
        text = loops.source(vc, table, prepared, straight, condition, for_pc)
        if text is not None:
            source.append(text)
            looped.add(for_pc + 1)
    made: dict[int, int] = {}  # entry pc -> lines in its block
    for start in sorted(_entries(table, straight)):
        if start >= len(straight) or quick[start] is None:
            continue
        body, pc = [], start
        while pc < len(straight) and straight[pc] is not None and pc - start < LONGEST:
            body.append(f"    {straight[pc]}\n    c += lt")
            pc += 1
        if pc < len(straight) and quick[pc] is not None and pc - start < LONGEST:
            test = condition.get(pc)
            branch = f"return ({pc + 1} if {test} else {table.if_false[pc] + 1}), c" \
                if test is not None else _next(pc) \
                if names[pc] == "NEXT" and isinstance(prepared.lines[pc][0],
                                                      precompile.Quick) else None
            body.append(f"    c += lt\n    {branch or f'return T[{pc}](_f), c'}")
            pc += 1
        else:
            body.append(f"    return {pc}, c")
        if pc - start >= 2 or start in looped:
            made[start] = pc - start
            source.append(f"def b{start}(_f, c, V=V, B=B, T=T, lt=lt):\n" +
                          "\n".join(body) + "\n")
    fused: list[Fused | None] = [None] * (len(straight) + 1)
    if not made:
        return fused
    namespace: dict[str, Any] = {"V": vc.vars, "B": vc.bvars, "T": quick,
                                 "lt": vc.line_time}
    exec(compile("\n".join(source), f"<blocks of {table.kind} {table.slot}>", "exec"),
         namespace)
    for start, count in made.items():
        fused[start] = (namespace[f"b{start}"], count, count * vc.line_time,
                        namespace.get(f"l{start - 1}") if start in looped else None)
    return fused


def _statements(vc: VirtualController, prepared: precompile.Prepared,
                names: list[str]) -> list[str | None]:
    """Each line as a block's straight statement ("pass" for a line that does nothing), or
    None for a line that is not straight."""
    straight: list[str | None] = []
    for pc, (handler, ops, _motion) in enumerate(prepared.lines):
        text = None
        if handler is None:
            text = "pass"
        elif isinstance(handler, precompile.Quick) and names[pc] in ("SET_VAR",
                                                                    "VAR_CALCULATE"):
            text = _straight(vc, names[pc], ops)
        straight.append(text)
    return straight
