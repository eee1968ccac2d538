"""Macro lines of program flow and variables, evaluated at compile time for an FBs-PLC table.

FOR/NEXT, IF/ELSE, LABEL/GOTO, CALL and the variable lines leave no step of their own: known
values fold and unroll here, and a LABEL reached again in the same state closes a loop as a
GOTO back to its step. Mixed into the `Evaluator` of mplang/fatek/compile.py.
"""

from __future__ import annotations

from mplang.fatek.mp_state import EvaluatorBase, Frame, HostVar, LabelVisit, Loop, Runtime, Val
from mplang.ir.lower import apply_operator
from mplang.ir.macro import MacroLine, Operand, ProgramRef, VarRef


class FlowOps(EvaluatorBase):
    """Control flow, calls, loops closed by labels, and variables."""

    # ------------------------------------------------------------ control flow
    def op_for(self, frame: Frame, line: MacroLine) -> None:
        count = self.val(line.operands[0])
        start = frame.pc - 1
        if not isinstance(count, int):
            self.decision(line, "the FOR count")
            return
        if count <= 0:
            frame.pc = frame.flow.for_end[start] + 1
            return
        ref = line.operands[0] if isinstance(line.operands[0], VarRef) else None
        frame.loops.append(Loop(start, ref, count))

    def op_next(self, frame: Frame, line: MacroLine) -> None:
        loop = frame.loops[-1]
        if loop.ref is not None:
            value = self.val(loop.ref)
            if not isinstance(value, int):
                self.decision(line, "the FOR counter")
                return
            remaining = value - 1
            self.vars[loop.ref.index] = remaining
        else:
            loop.counter -= 1
            remaining = loop.counter
        if remaining > 0:
            frame.pc = loop.start + 1
        else:
            frame.loops.pop()

    def op_exit_for(self, frame: Frame, line: MacroLine) -> None:
        frame.loops.pop()
        frame.pc = frame.flow.exit_for_end[frame.pc - 1] + 1

    def op_if(self, frame: Frame, line: MacroLine) -> None:
        left, right = self.val(line.operands[0]), self.val(line.operands[2])
        if not isinstance(left, int) or not isinstance(right, int):
            self.decision(line, "the IF condition")
            return
        code = _code(line.operands[1])
        symbol = self.cx.compare.get(code) or self.cx.compare[((code & 0xFF) << 8) | code >> 8]
        holds = {"<": left < right, ">": left > right, "<=": left <= right,
                 ">=": left >= right, "==": left == right, "!=": left != right}[symbol]
        if not holds:
            frame.pc = frame.flow.if_false[frame.pc - 1] + 1

    def op_else(self, frame: Frame, line: MacroLine) -> None:
        frame.pc = frame.flow.else_end[frame.pc - 1] + 1

    def op_end_if(self, frame: Frame, line: MacroLine) -> None:
        return

    def op_label(self, frame: Frame, line: MacroLine) -> None:
        self.visit_label(frame, frame.pc - 1, line)

    def op_goto(self, frame: Frame, line: MacroLine) -> None:
        frame.loops.clear()
        index = frame.flow.labels[_code(line.operands[0])]
        frame.pc = index + 1
        self.visit_label(frame, index, frame.program.lines[index])

    def decision(self, line: MacroLine, what: str) -> None:
        self.fail("E641", line.span, f"{what} depends on a value known only at run time: the "
                  "positioning language has no conditional branch or counter",
                  hint="use constants (or variables with a known value), or move the decision "
                  "to the ladder")
        self.stopped = True

    def op_mp_call(self, frame: Frame, line: MacroLine) -> None:
        ref = line.operands[0]
        assert isinstance(ref, ProgramRef)
        program = self.cx.resolve(ref)
        label = ref.name or f"MP{ref.slot}"
        if program is None:
            self.fail("E640", line.span, f"CALL {label}: the program is not part of this build, "
                      "so it cannot be inlined", hint="build the called program together")
            return
        if len(self.stack) >= self.cx.m8194h.limit("call_depth"):
            self.fail("E640", line.span, f"CALL {label} nests deeper than "
                      f"{self.cx.m8194h.limit('call_depth')} programs", hint="remove the "
                      "recursion")
            self.stopped = True
            return
        self.stack.append(self.frame(program))

    def op_exit_macro(self, frame: Frame, line: MacroLine) -> None:
        self.stack.pop()

    def op_mp_terminate(self, frame: Frame, line: MacroLine) -> None:
        self.stack.clear()

    # ------------------------------------------------------------ loops via labels
    def state_key(self, frame: Frame, index: int) -> tuple[object, ...]:
        calls = tuple((id(f.program), f.pc) for f in self.stack[:-1])
        loops = tuple((f.pc, tuple((lp.start, lp.counter) for lp in f.loops))
                      for f in self.stack)
        axes = tuple((a.speed, a.speed_span) for a in self.axes)
        variables = tuple(sorted(self.vars.items()))
        return (id(frame.program), index, calls, loops, variables, axes, self.vector_speed,
                self.assigned, self.rvalue)

    def visit_label(self, frame: Frame, index: int, line: MacroLine) -> None:
        """A LABEL is where loops close: reached again in the same state, the steps since
        the first visit repeat for ever, so the last step jumps back instead."""
        for axis in self.axes:
            axis.position = None  # a join point: the position depends on the path taken
        key = self.state_key(frame, index)
        last_wait = self.drafts[-1].wait_ms if self.drafts else None
        first = self.visits.get(key)
        if first is None:
            self.visits[key] = LabelVisit(len(self.drafts), last_wait)
            return
        if first.steps == len(self.drafts):
            self.fail("E640", line.span, "an endless loop without a move: the PLC cannot "
                      "idle in a loop", hint="end the program instead, or put a move in the "
                      "loop")
        elif first.steps > 0 and self.drafts[first.steps - 1].wait_ms != first.last_wait:
            self.fail("E644", line.span, "the loop starts with a wait: a wait belongs to the "
                      "step of the move before it, which is outside the loop",
                      hint="put the LABEL before a move")
        else:
            last = self.drafts[-1]
            last.goto = first.steps + 1
            last.goto_span = line.span
        self.stopped = True

    # ------------------------------------------------------------ variables
    def op_set_var(self, frame: Frame, line: MacroLine) -> None:
        target = line.operands[0]
        assert isinstance(target, VarRef)
        self.vars[target.index] = self.val(line.operands[1])

    def op_set_rvar(self, frame: Frame, line: MacroLine) -> None:
        target = line.operands[0]
        assert isinstance(target, VarRef)
        self.vars[target.index] = self.rvalue

    def op_var_calculate(self, frame: Frame, line: MacroLine) -> None:
        left, right = self.val(line.operands[0]), self.val(line.operands[2])
        dest = line.operands[3]
        assert isinstance(dest, VarRef)
        symbol = self.cx.calc[_code(line.operands[1])]
        if isinstance(left, int) and isinstance(right, int):
            try:
                self.vars[dest.index] = apply_operator(symbol, left, right)
            except ZeroDivisionError:
                self.vars[dest.index] = Runtime(line.span, "a division by zero")
            return
        self.vars[dest.index] = Runtime(line.span, f"arithmetic on VAR{_var_of(left, right)}")


def _code(operand: Operand) -> int:
    """An operand the lowering always makes a constant (operator codes, label numbers)."""
    assert isinstance(operand, int)
    return operand


def _var_of(*values: Val) -> str:
    for value in values:
        if isinstance(value, HostVar):
            return str(value.index)
    return "s"
