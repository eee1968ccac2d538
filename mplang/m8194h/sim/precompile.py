"""The hot lines of the interpreter, prepared once per stored line (`prepare`).

SET_VAR, VAR_CALCULATE, IF and the loops are most of what a program runs. Their generic
handlers (`VirtualController._set_var`, `_calculate`, `_if`, `_for`, `_next`, ...) decode
the operands, look the operator up and branch on its symbol every time the line runs; here
that is done once, when a table is first run, and the line becomes a *quick* line: a
closure that takes the frame, only reads its sources, computes and stores, and returns the
pc of the line that runs next. Each source is a (list, index) pair read the same way: a
variable's list (`vars` / `bvars`, which the controller never replaces) or a one-element
list holding a constant; a constant right operand is bound as an int. VAR_CALCULATE and IF
closures are written out per operator (`_factories`), so the line runs `+` or `<` itself.

A quick line never reads the clock or `frame.pc`, never waits, moves no axis and leaves
the call stack alone, so `VirtualController.advance` runs a stretch of them with the clock
and the pc in locals (`Prepared.quick`); every other line, and every line under a debugger
(`before_line`), goes through its `Handler` (`Prepared.lines`), where a quick line is
wrapped as `Quick`, which stores the pc it returns.

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
Fast = Callable[["Frame"], int]
"""A quick line: runs the line on the frame and returns the pc to go on at."""


class Quick:
    """A quick line as a `Handler`: the debugger's path (and any caller of a handler) runs
    it like any other line; `fast` is what the interpreter's quick path calls."""

    __slots__ = ("fast",)

    def __init__(self, fast: Fast) -> None:
        self.fast = fast

    def __call__(self, frame: Frame, _ops: tuple[Operand, ...]) -> None:
        frame.pc = self.fast(frame)


class Prepared:
    """A table ready to run: `lines` (handler, operands, touches motion) for every line and
    `quick` (a `Fast` or None) per line plus one None for the closing line, so that the
    interpreter's quick path needs no bounds check; `blank` is `quick` with every entry
    None (the debugger's: every line through its handler, after `before_line`); `fused`
    the blocks of straight lines (`blocks.fuse`) that start at each line, or None."""

    __slots__ = ("blank", "fused", "fused_time", "lines", "quick", "table")

    def __init__(self, table: MacroTable, lines: list[tuple[Handler | None,
                                                             tuple[Operand, ...], bool]]) -> None:
        self.table = table
        self.lines = lines
        self.quick: list[Fast | None] = [
            _skip(pc + 1) if handler is None else
            handler.fast if isinstance(handler, Quick) else None
            for pc, (handler, _ops, _motion) in enumerate(lines)] + [None]
        self.blank: list[Any] = [None] * (len(lines) + 1)
        self.fused: list[Any] = self.blank  # `blocks.fuse`, made for a line time:
        self.fused_time = -1.0  # `lines.run` takes them at that line time only


def _skip(after: int) -> Fast:
    """A line with no handler: nothing happens, the next line runs."""
    def skip(_f: Frame) -> int:
        return after
    return skip

COMPARE: dict[str, Callable[[Any, Any], bool]] = {
    "<": operator.lt, ">": operator.gt, "<=": operator.le, ">=": operator.ge,
    "==": operator.eq, "!=": operator.ne,
}
"""IF's comparison symbols (device profile [operators.compare]) as functions."""

_MASK, _SIGN = 0xFFFFFFFF, 0x80000000


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


def constant_code(vc: VirtualController, operand: Operand) -> int | None:
    """A constant operator code, or None when it is read from a variable at run time."""
    if isinstance(operand, (VarRef, BVarRef, bool)) or \
            not isinstance(operand, (int, float)):
        return None
    return int(operand)


_CALC_SYMBOLS = ("+", "-", "*", "&", "|")
WRAP = ("(w if -0x40000000 < (w := ({expr})) < 0x40000000 "
        "else ((w + 0x80000000) & 0xFFFFFFFF) - 0x80000000)")
"""wrap32 of an int expression, as written into a quick line or a block. Most results are
small: one comparison of ints under 2**30 (which CPython compares fastest) keeps them as
they are, and any other goes through the full wrap, which is right for every int (the
comparison is only the shortcut)."""


def _factories(template: str, symbols: tuple[str, ...]) -> dict[tuple[str, bool], Any]:
    """One closure factory per operator symbol and kind of right operand (True: a constant,
    bound as an int; False: a (list, index) source), written out from `template` so that
    the line runs the operator itself, not a call to its function. Built once, at import."""
    made: dict[tuple[str, bool], Any] = {}
    for symbol in symbols:
        for constant in (True, False):
            namespace: dict[str, Any] = {}
            exec(template.format(op=symbol, right="right" if constant else "right[ri]"),
                 namespace)
            made[(symbol, constant)] = namespace["make"]
    return made


_CALCULATE = _factories('''
def make(lsrc, li, right, ri, values, dest, after):
    def line(_f):
        values[dest] = {wrap}
        return after
    return line
'''.replace("{wrap}", WRAP.replace("{expr}", "lsrc[li] {op} {right}")), _CALC_SYMBOLS)

_COMPARE = _factories('''
def make(lsrc, li, right, ri, after, target):
    def line(_f):
        return after if lsrc[li] {op} {right} else target
    return line
''', tuple(COMPARE))


def _right(vc: VirtualController, operand: Operand) -> tuple[Any, int, bool] | None:
    """A right operand as the factories take it: (int, 0, True) for a constant, (list,
    index, False) for a variable; None as `_source`."""
    source = _source(vc, operand)
    if source is None:
        return None
    if isinstance(operand, (VarRef, BVarRef)):
        return source[0], source[1], False
    return source[0][0], 0, True


def _set_var(vc: VirtualController, pc: int, ops: tuple[Operand, ...]) -> Fast | None:
    if len(ops) != 2 or not isinstance(ops[0], VarRef):
        return None
    source = _right(vc, ops[1])
    if source is None:
        return None
    values, dest = vc.vars, ops[0].index
    src, at, constant = source
    after = pc + 1
    if constant:
        value = ((src + _SIGN) & _MASK) - _SIGN

        def set_const(_f: Frame) -> int:
            values[dest] = value
            return after
        return set_const

    def set_var(_f: Frame) -> int:
        value = src[at]
        values[dest] = value if -0x40000000 < value < 0x40000000 else \
            ((value + 0x80000000) & 0xFFFFFFFF) - 0x80000000
        return after

    return set_var


def _calculate(vc: VirtualController, pc: int, ops: tuple[Operand, ...]) -> Fast | None:
    if len(ops) != 4 or not isinstance(ops[3], VarRef):
        return None
    symbol = calc_symbol(vc, constant_code(vc, ops[1]))
    left, right = _source(vc, ops[0]), _right(vc, ops[2])
    if symbol is None or left is None or right is None:
        return None
    (lsrc, li), (rvalue, ri, constant) = left, right
    made: Fast = _CALCULATE[(symbol, constant)](lsrc, li, rvalue, ri, vc.vars, ops[3].index,
                                                pc + 1)
    return made


def compare_symbol(vc: VirtualController, code: int | None) -> str | None:
    """IF's comparison symbol for a constant code (None: the generic handler's case)."""
    if code is None:
        return None
    if code not in vc.cmp_symbols:
        code = ((code & 0xFF) << 8) | (code >> 8)  # the example's byte order (as `_if`)
    symbol = vc.cmp_symbols.get(code)
    return symbol if symbol in COMPARE else None


def calc_symbol(vc: VirtualController, code: int | None) -> str | None:
    """VAR_CALCULATE's operator symbol for a constant code, if a quick line runs it
    (division, for its error, and unknown codes stay with the generic handler)."""
    symbol = None if code is None else vc.calc_symbols.get(code)
    return symbol if symbol in _CALC_SYMBOLS else None


def _if(vc: VirtualController, table: MacroTable, pc: int,
        ops: tuple[Operand, ...]) -> Fast | None:
    if len(ops) != 3:
        return None
    symbol = compare_symbol(vc, constant_code(vc, ops[1]))
    left, right = _source(vc, ops[0]), _right(vc, ops[2])
    if symbol is None or left is None or right is None or pc not in table.if_false:
        return None
    (lsrc, li), (rvalue, ri, constant) = left, right
    made: Fast = _COMPARE[(symbol, constant)](lsrc, li, rvalue, ri, pc + 1,
                                              table.if_false[pc] + 1)
    return made


def _for(vc: VirtualController, table: MacroTable, pc: int,
         ops: tuple[Operand, ...]) -> Fast | None:
    """FOR as `VirtualController._for`: a count of 0 or less skips the body, else the loop
    is pushed (with the counted variable, or an internal counter for any other count)."""
    source = _source(vc, ops[0]) if len(ops) == 1 else None
    if source is None or pc not in table.for_end:
        return None
    src, at = source
    ref = ops[0] if isinstance(ops[0], VarRef) else None
    skip, after = table.for_end[pc] + 1, pc + 1

    def for_(frame: Frame) -> int:
        count = src[at]
        if count <= 0:
            return skip
        frame.loops.append((pc, ref, [count]))
        return after

    return for_


def _next(vc: VirtualController, pc: int) -> Fast:
    """NEXT as `VirtualController._next`: count down, back to the line after the FOR while
    any count remains."""
    values, after = vc.vars, pc + 1

    def next_(frame: Frame) -> int:
        loops = frame.loops
        start, ref, counter = loops[-1]
        if ref is not None:
            values[ref.index] -= 1
            remaining = values[ref.index]
        else:
            counter[0] -= 1
            remaining = counter[0]
        if remaining > 0:
            return start + 1
        loops.pop()
        return after

    return next_


def _jump(vc: VirtualController, table: MacroTable, pc: int, name: str,
          ops: tuple[Operand, ...]) -> Fast | None:
    """ELSE, EXIT_FOR and GOTO to a constant label: a jump known when the table is."""
    if name == "ELSE" and pc in table.else_end:
        target = table.else_end[pc] + 1

        def else_(_f: Frame) -> int:
            return target
        return else_
    if name == "EXIT_FOR" and table.exit_for_end.get(pc, -1) >= 0:
        end = table.exit_for_end[pc] + 1

        def exit_for(frame: Frame) -> int:
            frame.loops.pop()
            return end
        return exit_for
    label = constant_code(vc, ops[0]) if name == "GOTO" and len(ops) == 1 else None
    if label is not None and label in table.labels:
        to = table.labels[label] + 1

        def goto(frame: Frame) -> int:
            frame.loops.clear()  # labels stand outside every block: the jump leaves all loops
            return to
        return goto
    return None


_NOTHING = (lambda _f, _o: None).__code__
"""The code of a handler that does nothing (the controller's END_IF and LABEL)."""


def _does_nothing(handler: Handler | None) -> bool:
    """A plain function whose code only returns None: calling it has no effect."""
    code = getattr(handler, "__code__", None)
    return isinstance(handler, FunctionType) and code is not None and \
        code.co_code == _NOTHING.co_code and code.co_consts == _NOTHING.co_consts


def prepare(vc: VirtualController, table: MacroTable, pc: int, name: str,
            handler: Handler | None) -> Handler | None:
    """The handler line `pc` of `table` runs with: a quick line (`Quick`) for the hot lines
    whose handler is still the controller's own, none for a line that does nothing, else
    `handler` as it is."""
    if name in ("END_IF", "LABEL") and _does_nothing(handler):
        return None  # (both are pure lines: the interpreter does nothing else after them)
    fast = _fast(vc, table, pc, name, handler)
    return handler if fast is None else Quick(fast)


def _fast(vc: VirtualController, table: MacroTable, pc: int, name: str,
          handler: Handler | None) -> Fast | None:
    ops = table.lines[pc].operands
    if name == "SET_VAR" and handler == vc._set_var:
        return _set_var(vc, pc, ops)
    if name == "VAR_CALCULATE" and handler == vc._calculate:
        return _calculate(vc, pc, ops)
    if name == "IF" and handler == vc._if:
        return _if(vc, table, pc, ops)
    if name == "FOR" and handler == vc._for:
        return _for(vc, table, pc, ops)
    if name == "NEXT" and handler == vc._next:
        return _next(vc, pc)
    if (name == "ELSE" and handler == vc._else) or (name == "GOTO" and handler == vc._goto) \
            or (name == "EXIT_FOR" and handler == vc._exit_for):
        return _jump(vc, table, pc, name, ops)
    return None
