"""The hot lines of the interpreter, prepared once per stored line (`prepare`).

SET_VAR, VAR_CALCULATE and IF are most of what a program runs. Their generic handlers
(`VirtualController._set_var`, `_calculate`, `_if`) decode the operands, look the operator
up and branch on its symbol every time the line runs; here that is done once, when a table
is first run, and the line becomes a closure that only reads its sources, computes and
stores. Each source is a (list, index) pair read the same way: a variable's list
(`vars` / `bvars`, which the controller never replaces) or a one-element list holding a
constant.

END_IF and LABEL do nothing when they run: their line gets no handler at all (the
interpreter counts its time and moves on, as after a handler that returned nothing).

Only the shapes whose outcome cannot differ are prepared: a constant operator code the
profile knows, a VarRef destination, operands that are variables or numbers, an IF whose
jump target is known. Anything else (an unknown operator, an operand of another kind, a
handler a test replaced) keeps the generic handler, so errors come out exactly as before,
from the same handler at the same moment.
"""

from __future__ import annotations

import operator
from collections.abc import Callable
from types import FunctionType
from typing import TYPE_CHECKING, Any

from mplang.ir.macro import BVarRef, Operand, VarRef

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import Frame, Handler, VirtualController
    from mplang.m8194h.sim.tables import MacroTable

Source = tuple[list[int], int]

COMPARE: dict[str, Callable[[Any, Any], bool]] = {
    "<": operator.lt, ">": operator.gt, "<=": operator.le, ">=": operator.ge,
    "==": operator.eq, "!=": operator.ne,
}
"""IF's comparison symbols (device profile [operators.compare]) as functions."""

_MASK, _SIGN, _SPAN = 0xFFFFFFFF, 0x80000000, 1 << 32


def _source(vc: VirtualController, operand: Operand) -> Source | None:
    """Where a line reads an operand from; None for an operand `vc.value` would not read
    as a number (the generic handler then fails as it always did)."""
    if isinstance(operand, VarRef):
        return vc.vars, operand.index
    if isinstance(operand, BVarRef):
        return vc.bvars, operand.index
    if isinstance(operand, bool) or not isinstance(operand, (int, float)):
        return None
    return [int(operand)], 0


def _code(vc: VirtualController, operand: Operand) -> int | None:
    """A constant operator code, or None when it is read from a variable at run time."""
    if isinstance(operand, (VarRef, BVarRef, bool)) or \
            not isinstance(operand, (int, float)):
        return None
    return int(operand)


def _set_var(vc: VirtualController, ops: tuple[Operand, ...]) -> Handler | None:
    if len(ops) != 2 or not isinstance(ops[0], VarRef):
        return None
    source = _source(vc, ops[1])
    if source is None:
        return None
    values, dest = vc.vars, ops[0].index
    src, at = source

    def set_var(_f: Frame, _o: tuple[Operand, ...]) -> None:
        result = src[at] & _MASK
        values[dest] = result - _SPAN if result & _SIGN else result

    return set_var


def _calculate(vc: VirtualController, ops: tuple[Operand, ...]) -> Handler | None:
    if len(ops) != 4 or not isinstance(ops[3], VarRef):
        return None
    code = _code(vc, ops[1])
    left, right = _source(vc, ops[0]), _source(vc, ops[2])
    if code is None or left is None or right is None:
        return None
    symbol = vc.calc_symbols.get(code)
    combine: Callable[[int, int], int] | None = {
        "+": operator.add, "-": operator.sub, "*": operator.mul, "&": operator.and_,
        "|": operator.or_}.get(symbol or "")
    if combine is None:  # division (its error) and unknown codes: the generic handler
        return None
    values, dest = vc.vars, ops[3].index
    (lsrc, li), (rsrc, ri) = left, right
    if combine is operator.add:
        def add(_f: Frame, _o: tuple[Operand, ...]) -> None:
            result = (lsrc[li] + rsrc[ri]) & _MASK
            values[dest] = result - _SPAN if result & _SIGN else result
        return add
    if combine is operator.sub:
        def sub(_f: Frame, _o: tuple[Operand, ...]) -> None:
            result = (lsrc[li] - rsrc[ri]) & _MASK
            values[dest] = result - _SPAN if result & _SIGN else result
        return sub
    if combine is operator.mul:
        def mul(_f: Frame, _o: tuple[Operand, ...]) -> None:
            result = (lsrc[li] * rsrc[ri]) & _MASK
            values[dest] = result - _SPAN if result & _SIGN else result
        return mul

    def calculate(_f: Frame, _o: tuple[Operand, ...]) -> None:
        result = combine(lsrc[li], rsrc[ri]) & _MASK
        values[dest] = result - _SPAN if result & _SIGN else result

    return calculate


def _if(vc: VirtualController, table: MacroTable, pc: int,
        ops: tuple[Operand, ...]) -> Handler | None:
    if len(ops) != 3:
        return None
    code = _code(vc, ops[1])
    left, right = _source(vc, ops[0]), _source(vc, ops[2])
    if code is None or left is None or right is None or pc not in table.if_false:
        return None
    if code not in vc.cmp_symbols:
        code = ((code & 0xFF) << 8) | (code >> 8)  # the example's byte order (as `_if`)
    symbol = vc.cmp_symbols.get(code)
    holds = COMPARE.get(symbol or "")
    if holds is None:
        return None
    target = table.if_false[pc] + 1
    (lsrc, li), (rsrc, ri) = left, right

    def if_(frame: Frame, _o: tuple[Operand, ...]) -> None:
        if not holds(lsrc[li], rsrc[ri]):
            frame.pc = target

    return if_


_NOTHING = (lambda _f, _o: None).__code__
"""The code of a handler that does nothing (the controller's END_IF and LABEL)."""


def _does_nothing(handler: Handler | None) -> bool:
    """A plain function whose code only returns None: calling it has no effect."""
    code = getattr(handler, "__code__", None)
    return isinstance(handler, FunctionType) and code is not None and \
        code.co_code == _NOTHING.co_code and code.co_consts == _NOTHING.co_consts


def prepare(vc: VirtualController, table: MacroTable, pc: int, name: str,
            handler: Handler | None) -> Handler | None:
    """The handler line `pc` of `table` runs with: a prepared one for the hot lines whose
    handler is still the controller's own, none for a line that does nothing, else
    `handler` as it is."""
    if name in ("END_IF", "LABEL") and _does_nothing(handler):
        return None  # (both are pure lines: the interpreter does nothing else after them)
    ops = table.lines[pc].operands
    if name == "SET_VAR" and handler == vc._set_var:
        return _set_var(vc, ops) or handler
    if name == "VAR_CALCULATE" and handler == vc._calculate:
        return _calculate(vc, ops) or handler
    if name == "IF" and handler == vc._if:
        return _if(vc, table, pc, ops) or handler
    return handler
