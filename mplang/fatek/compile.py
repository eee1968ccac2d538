"""`.mp` sources to FBs-PLC positioning tables (`--target fbs-fun140` / `fbs-fun147`).

The real front end and lowering (mplang.lang, mplang.ir.lower) turn the sources into macro
lines, with every `.mp` check. The positioning language then has no variables, arithmetic,
conditional branches or calls (FB 863-1149), so the macro lines are *evaluated* here at
compile time: constants and known variables fold, FOR loops and IFs on known values unroll,
CALLs inline, and a LABEL that is reached again in the same state becomes a GOTO back to its
step. What stays is a sequence of moves, each with its speed and the wait after it: one step
per move. Whatever depends on a value known only at run time, or has no counterpart on the
PLC, is reported at its `.mp` line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from mplang.fatek.build import FUN_OF_TARGET, FamilyBuild, check_target
from mplang.fatek.check import Checker
from mplang.fatek.model import (
    NEXT,
    Condition,
    Drive,
    Line,
    Motion,
    ParamTable,
    PositioningTable,
    Register,
    SimSetup,
    Step,
    Table,
    Target,
    Value,
)
from mplang.fatek.profile import Profile, load
from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue
from mplang.ir.lower import ProgramLowerer, Scope, apply_operator
from mplang.ir.macro import BVarRef, LoweredProgram, MacroLine, Operand, ProgramRef, VarRef
from mplang.lang import ast
from mplang.lang.diagnostics import DiagnosticSink, Span
from mplang.lang.sources import load_sources
from mplang.lang.structure import build_unit
from mplang.m8194h.compiler import Options, configuration_blocks, suppressed

FUEL = 200_000
"""Macro lines evaluated per program before the evaluation is declared endless (E645)."""
M8194H_ONLY_WARNINGS = frozenset({"W107"})
"""Warnings of the lowering that speak of the M8194H manual only: FB documents register
operands for speeds, strokes and times (FB 867-878, 939-953), so W107 does not apply."""
LOWERING_TARGET = "rs"
"""The M8194H command set the sources are lowered against (RS has every macro command)."""


@dataclass(frozen=True)
class HostVar:
    """The value the host left in VARn: passed to the PLC as a register."""

    index: int


@dataclass(frozen=True)
class Runtime:
    """A value the program computes while it runs; the PLC has nowhere to compute it."""

    span: Span
    what: str


Val = int | HostVar | Runtime


@dataclass
class Loop:
    start: int  # index of the FOR line
    ref: VarRef | None
    counter: int


@dataclass
class Frame:
    program: LoweredProgram
    flow: Flow
    pc: int = 0
    loops: list[Loop] = field(default_factory=list)


@dataclass
class Flow:
    """Where FOR/NEXT, IF/ELSE/END IF, EXIT FOR and LABEL lines lead (like the device's)."""

    for_end: dict[int, int] = field(default_factory=dict)
    if_false: dict[int, int] = field(default_factory=dict)
    else_end: dict[int, int] = field(default_factory=dict)
    exit_for_end: dict[int, int] = field(default_factory=dict)
    labels: dict[int, int] = field(default_factory=dict)

    @classmethod
    def of(cls, lines: list[MacroLine]) -> Flow:
        flow = cls()
        stack: list[tuple[str, int]] = []
        pending_exits: dict[int, list[int]] = {}
        open_else: dict[int, int] = {}
        for index, line in enumerate(lines):
            name = line.command.short_name
            if name == "FOR":
                stack.append(("for", index))
            elif name == "NEXT" and stack and stack[-1][0] == "for":
                start = stack.pop()[1]
                flow.for_end[start] = index
                for exit_line in pending_exits.pop(start, []):
                    flow.exit_for_end[exit_line] = index
            elif name == "IF":
                stack.append(("if", index))
            elif name == "ELSE" and stack and stack[-1][0] == "if":
                start = stack[-1][1]
                flow.if_false[start] = index
                open_else[start] = index
            elif name == "END_IF" and stack and stack[-1][0] == "if":
                start = stack.pop()[1]
                if start in open_else:
                    flow.else_end[open_else.pop(start)] = index
                else:
                    flow.if_false[start] = index
            elif name == "EXIT_FOR":
                loop = next((i for kind, i in reversed(stack) if kind == "for"), None)
                if loop is not None:
                    pending_exits.setdefault(loop, []).append(index)
            elif name == "LABEL" and isinstance(line.operands[0], int):
                flow.labels[line.operands[0]] = index
        return flow


@dataclass
class Draft:
    """A step being built: the move, its speed and the wait that follows it."""

    speed: Value
    motion: Motion
    span: Span
    speed_span: Span
    wait_ms: int = 0
    wait_span: Span | None = None
    goto: Target | None = None
    goto_span: Span | None = None


@dataclass
class AxisState:
    speed: Val | None = None
    speed_span: Span | None = None
    position: int | None = None  # known absolute position (pulses), None: unknown
    waited: bool = True  # STOP_WAIT since the last move (for the timing warning)


@dataclass
class LabelVisit:
    steps: int
    last_wait: int | None


class Context:
    """What every program evaluation of one build shares."""

    def __init__(self, programs: list[LoweredProgram], catalogue: Catalogue, profile: Profile,
                 sink: DiagnosticSink, fun: int) -> None:
        self.programs = programs
        self.catalogue = catalogue
        self.m8194h = catalogue.profile
        self.profile = profile
        self.sink = sink
        self.fun = fun
        self.flows = {id(p): Flow.of(p.lines) for p in programs}
        self.by_name = {p.name.upper(): p for p in programs if p.name}
        self.by_slot = {p.slot: p for p in programs if p.kind == "mp" and p.slot is not None}
        self.calc = {code: symbol for symbol, code in self.m8194h.calc_ops.items()}
        self.compare = {code: symbol for symbol, code in self.m8194h.cmp_ops.items()}
        raw = profile.raw["compile"]
        self.var_kind = str(raw["var_register"])
        self.var_stride = int(raw["var_register_stride"])
        self.default_axes = tuple(int(a) for a in raw["default_assigned_axes"])

    def resolve(self, ref: ProgramRef) -> LoweredProgram | None:
        if ref.name is not None:
            return self.by_name.get(ref.name.upper())
        return self.by_slot.get(ref.slot) if ref.slot is not None else None

    def host_register(self, var: HostVar) -> Register:
        return Register(self.var_kind, self.var_stride * var.index)


class Evaluator:
    """Evaluates one MP (and what it calls) into the steps of one table."""

    def __init__(self, context: Context, program: LoweredProgram, name: str) -> None:
        self.cx = context
        self.sink = context.sink
        self.top = program
        self.name = name
        self.fun = context.fun
        self.limits = context.profile.limits(context.fun)
        self.vars: dict[int, Val] = {}
        self.rvalue: Val = Runtime(program.span, "a read's result")
        self.axes = [AxisState() for _ in range(4)]
        self.vector_speed: Val | None = None
        self.vector_span: Span | None = None
        self.assigned: tuple[int, ...] = context.default_axes
        self.table_axis: int | None = None
        self.drafts: list[Draft] = []
        self.visits: dict[tuple[object, ...], LabelVisit] = {}
        self.params: dict[int, dict[int, tuple[int, Span]]] = {}
        self.stack: list[Frame] = []
        self.stopped = False
        self.lost_move = False  # a move was reported and left out: waits after it are moot

    # ------------------------------------------------------------ values
    def val(self, operand: Operand) -> Val:
        if isinstance(operand, VarRef):
            return self.vars.get(operand.index, HostVar(operand.index))
        if isinstance(operand, BVarRef | ProgramRef):
            return Runtime(self.top.span, "a byte variable")
        return int(operand)

    def operand(self, value: Val, span: Span, what: str) -> Value | None:
        """A PLC operand for `value`: a constant, or the register a host variable lives in."""
        if isinstance(value, int):
            return value
        if isinstance(value, HostVar):
            return self.cx.host_register(value)
        self.sink.add("E642", span, f"{what} is computed at run time ({value.what}, line "
                      f"{value.span.line}); the PLC reads operands from constants or registers",
                      hint="compute it at compile time, or let the host write VARn and pass "
                      "VARn itself")
        return None

    def fail(self, code: str, span: Span, message: str, hint: str = "") -> None:
        self.sink.add(code, span, message, hint=hint)
        if code in ("E642", "E643", "E646", "E647", "E648"):
            self.lost_move = True

    # ------------------------------------------------------------ driving
    def run(self) -> list[Draft]:
        self.stack.append(self.frame(self.top))
        fuel = FUEL
        while self.stack and not self.stopped:
            fuel -= 1
            if fuel == 0:
                self.fail("E645", self.top.span, f"{self.name}: the evaluation does not end "
                          f"after {FUEL} macro lines (a loop whose state never repeats?)",
                          hint="close endless loops with LABEL/GOTO over constant state")
                break
            frame = self.stack[-1]
            if frame.pc >= len(frame.program.lines):
                self.stack.pop()
                continue
            line = frame.program.lines[frame.pc]
            frame.pc += 1
            self.execute(frame, line)
        return self.drafts

    def frame(self, program: LoweredProgram) -> Frame:
        return Frame(program, self.cx.flows[id(program)])

    def execute(self, frame: Frame, line: MacroLine) -> None:
        name = line.command.short_name
        handler = getattr(self, f"op_{name.lower()}", None)
        if handler is not None:
            handler(frame, line)
        elif line.command.returns:
            self.rvalue = Runtime(line.span, f"{name} reads the controller")
        elif name in self.cx.profile.mp_ignored:
            self.sink.add("W640", line.span, f"{name} has no effect on an FBs-PLC table: "
                          f"{self.cx.profile.mp_ignored[name]}")
        else:
            reason = self.cx.profile.mp_unsupported.get(name, "no counterpart in the "
                                                        "positioning language")
            self.fail("E640", line.span, f"{name} cannot be expressed on the FBs-PLC: {reason}")

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

    # ------------------------------------------------------------ settings
    def mask_axes(self, operand: Operand) -> list[int]:
        mask = int(operand) if isinstance(operand, int) else 0
        return [i for i in range(4) if mask >> i & 1]

    def op_set_v(self, frame: Frame, line: MacroLine) -> None:
        value = self.val(line.operands[1])
        for axis in self.mask_axes(line.operands[0]):
            self.axes[axis].speed = value
            self.axes[axis].speed_span = line.span

    def op_set_vv(self, frame: Frame, line: MacroLine) -> None:
        self.vector_speed = self.val(line.operands[0])
        self.vector_span = line.span

    def setting(self, line: MacroLine, axes: list[int], number: int, value: int) -> None:
        for axis in axes:
            known = self.params.setdefault(axis, {})
            if number not in known:
                known[number] = (value, line.span)
            elif known[number][0] != value:
                self.sink.add("W641", line.span, f"FUN141 holds one parameter {number} per "
                              f"axis; the value of line {known[number][1].line} stays",
                              hint="use one acceleration and start speed per axis")

    def known(self, line: MacroLine, index: int, what: str) -> int | None:
        value = self.val(line.operands[index])
        if isinstance(value, int):
            return value
        self.fail("E642", line.span, f"{what} must be known when compiling: it becomes a "
                  "FUN141 parameter", hint="use a constant")
        return None

    def op_set_sv(self, frame: Frame, line: MacroLine) -> None:
        value = self.known(line, 1, "the start speed")
        if value is None:
            return
        spec = self.cx.profile.param(5)
        assert spec is not None
        if not spec.min <= value <= spec.max:
            self.fail("E647", line.span, f"start speed {value} is outside FUN141 parameter 5's "
                      f"{spec.min}..{spec.max}")
            return
        self.setting(line, self.mask_axes(line.operands[0]), 5, value)

    def ramp_time(self, line: MacroLine, rate: int, reach: float, number: int) -> int | None:
        spec = self.cx.profile.param(number)
        assert spec is not None
        if rate <= 0:
            self.fail("E647", line.span, f"acceleration {rate} cannot become a ramp time")
            return None
        time_ms = round(reach / rate * 1000)
        if time_ms > spec.max:
            self.fail("E647", line.span, f"acceleration {rate} needs {time_ms} ms to reach "
                      f"{reach:.0f} Ps/s; FUN141 parameter {number} allows {spec.max} ms",
                      hint="use a larger acceleration")
            return None
        return time_ms

    def op_set_a(self, frame: Frame, line: MacroLine) -> None:
        self.accel(line, 8)

    def op_set_d(self, frame: Frame, line: MacroLine) -> None:
        self.accel(line, 12)

    def accel(self, line: MacroLine, number: int) -> None:
        value = self.known(line, 1, "the acceleration")
        if value is None:
            return
        spec = self.cx.profile.param(4)
        assert spec is not None
        time_ms = self.ramp_time(line, value, spec.default, number)
        if time_ms is not None:
            self.setting(line, self.mask_axes(line.operands[0]), number, time_ms)

    def op_set_va(self, frame: Frame, line: MacroLine) -> None:
        value = self.known(line, 0, "the vector acceleration")
        if value is None:
            return
        speed = self.vector_speed
        if not isinstance(speed, int):
            self.fail("E642", line.span, "SET_VA becomes FUN141 parameter 13, the time to the "
                      "line speed, which needs a constant SET_VV before it")
            return
        time_ms = self.ramp_time(line, value, speed, 13)
        if time_ms is not None:
            self.setting(line, list(range(4)), 13, time_ms)

    def op_axis_assign(self, frame: Frame, line: MacroLine) -> None:
        axes = []
        for operand in line.operands:
            mask = int(operand) if isinstance(operand, int) else 0
            if mask:
                axes.append(mask.bit_length() - 1)
        self.assigned = tuple(axes)

    def op_stop_wait(self, frame: Frame, line: MacroLine) -> None:
        for axis in self.mask_axes(line.operands[0]):
            self.axes[axis].waited = True

    def op_intp_end(self, frame: Frame, line: MacroLine) -> None:
        return

    def op_timer(self, frame: Frame, line: MacroLine) -> None:
        value = self.val(line.operands[0])
        if not isinstance(value, int):
            self.fail("E642", line.span, "a TIMER from a variable: the PLC's WAIT TIME is in "
                      "0.01 s and the program cannot convert milliseconds at run time",
                      hint="use a constant time")
            return
        if value == 0:
            return  # nothing to wait for
        if not self.drafts:
            if self.lost_move:
                return
            self.fail("E644", line.span, "a wait before the first move: a wait is the "
                      "transition of the step that holds the move before it (FB 1095)",
                      hint="move the TIMER after a move, or leave it to the ladder")
            return
        draft = self.drafts[-1]
        moving = [a for a in self.axes if not a.waited]
        if moving:
            self.sink.add("W641", line.span, "this TIMER runs while the axis moves on the "
                          "M8194H, but WAIT TIME starts when the pulse output completes",
                          hint="put STOP_WAIT before the TIMER to make both the same")
        if value % 10:
            self.sink.add("W641", line.span, f"TIMER {value} ms is rounded to "
                          f"{_round10(value) * 10} ms (WAIT TIME counts 0.01 s)")
        draft.wait_ms += value
        draft.wait_span = draft.wait_span or line.span

    # ------------------------------------------------------------ moves
    def op_fixed_move(self, frame: Frame, line: MacroLine) -> None:
        self.move(line, absolute=False)

    def op_abs_fixed_move(self, frame: Frame, line: MacroLine) -> None:
        self.move(line, absolute=True)

    def move(self, line: MacroLine, absolute: bool) -> None:
        axes = self.mask_axes(line.operands[0])
        value = self.val(line.operands[1])
        if self.fun == 140:
            if len(axes) != 1:
                self.fail("E643", line.span, f"a FUN140 table drives one axis; this move runs "
                          f"{len(axes)} axes", hint="build with --target fbs-fun147, or move "
                          "the axes one after the other")
                return
            axis = axes[0]
            if self.table_axis is None:
                self.table_axis = axis
            elif axis != self.table_axis:
                names = self.cx.profile.axis_names
                self.fail("E643", line.span, f"this FUN140 table drives "
                          f"{names[self.table_axis]} (Ps{self.table_axis}); a move of "
                          f"{names[axis]} needs its own table", hint="split the program per "
                          "axis, or build with --target fbs-fun147")
                return
            self.drive(line, axis, value, absolute)
        else:
            speeds = [self.axes[a].speed for a in axes]
            if len(axes) > 1:
                self.sink.add("W641", line.span, "the axes of this move are interpolated on "
                              "the PLC (one LIN), each at its own speed on the M8194H")
            speed: Val | None
            if any(s is None for s in speeds):
                speed = None
            elif len(speeds) == 1:
                speed = speeds[0]
            elif all(isinstance(s, int) for s in speeds):
                speed = round(math.sqrt(sum(s * s for s in speeds if isinstance(s, int))))
            else:
                speed = speeds[0]
            span = self.axes[axes[0]].speed_span or line.span
            self.line_move(line, {a: value for a in axes}, absolute, speed, span,
                           "SET_V of the axis")

    def speed_operand(self, speed: Val | None, span: Span, line: MacroLine, source: str
                      ) -> Value | None:
        if speed is None:
            self.fail("E648", line.span, f"no speed for this move: set it with {source} "
                      "before", hint="every step carries its own SPD (FB 571-575)")
            return None
        operand = self.operand(speed, span, "the speed")
        if isinstance(operand, int) and not self.limits.speed_min <= operand <= \
                self.limits.speed_max:
            self.fail("E647", span, f"speed {operand} is outside the PLC's "
                      f"{self.limits.speed_min}..{self.limits.speed_max}",
                      hint="FB 883" if self.fun == 140 else "FB 2191")
            return None
        return operand

    def drive(self, line: MacroLine, axis: int, value: Val, absolute: bool) -> None:
        state = self.axes[axis]
        stroke = self.operand(value, line.span, "the distance")
        if stroke is None:
            state.position = None
            return
        if isinstance(stroke, int) and absolute and stroke == 0:
            if state.position is None:
                self.fail("E646", line.span, "a move to absolute 0 from an unknown position: "
                          "DRV ABS with a stroke of 0 is a continuous run (FB 955-957)",
                          hint="move to an absolute position first in this program, or move "
                          "relatively")
                return
            stroke, absolute = -state.position, False
        if isinstance(stroke, int) and not absolute and stroke == 0:
            self.sink.add("W642", line.span, "a move of 0 is left out: a stroke of 0 runs for "
                          "ever on the PLC (FB 955-957)")
            return
        if isinstance(stroke, int) and not self.limits.stroke_min <= stroke <= \
                self.limits.stroke_max:
            self.fail("E647", line.span, f"distance {stroke} is outside the PLC's "
                      f"{self.limits.stroke_min:,}..{self.limits.stroke_max:,} (FB 958)",
                      hint="split the move")
            return
        speed = self.speed_operand(state.speed, state.speed_span or line.span, line,
                                   "SET_V of the axis")
        if speed is None:
            return
        if absolute:
            motion = Drive("DRV", "ABS", "", stroke, "Ps")
            state.position = stroke if isinstance(stroke, int) else None
        elif isinstance(stroke, int):
            motion = Drive("DRV", "ADR", "+" if stroke > 0 else "-", abs(stroke), "Ps")
            if state.position is not None:
                state.position += stroke
        else:
            motion = Drive("DRV", "ADR", "", stroke, "Ps")
            state.position = None
        state.waited = False
        self.emit(Draft(speed, motion, line.span, state.speed_span or line.span))

    def line_move(self, line: MacroLine, values: dict[int, Val], absolute: bool,
                  speed_value: Val | None, speed_span: Span, source: str) -> None:
        strokes: list[Value | None] = [None, None, None, None]
        moved = False
        for axis, value in values.items():
            operand = self.operand(value, line.span, f"the {self.cx.profile.axis_names[axis]} "
                                   "distance")
            if operand is None:
                return
            if isinstance(operand, int) and not self.limits.stroke_min <= operand <= \
                    self.limits.stroke_max:
                self.fail("E647", line.span, f"{operand} is outside one LIN's "
                          f"{self.limits.stroke_min:,}..{self.limits.stroke_max:,} Ps per axis "
                          "(FB 2261-2262)", hint="split the move")
                return
            if not absolute and operand == 0:
                continue
            strokes[axis] = operand
            moved = True
        if not moved:
            self.sink.add("W642", line.span, "a move of 0 is left out: LIN moves no axis "
                          "(FB 2253-2255)")
            return
        speed = self.speed_operand(speed_value, speed_span, line, source)
        if speed is None:
            return
        for axis in values:
            self.axes[axis].waited = False
        motion = Line("LIN", "ABS" if absolute else "ADR",
                      (strokes[0], strokes[1], strokes[2], strokes[3]), "Ps")
        self.emit(Draft(speed, motion, line.span, speed_span))

    def interpolate(self, line: MacroLine, count: int, absolute: bool) -> None:
        if self.fun == 140:
            self.fail("E643", line.span, f"{line.command.short_name} interpolates "
                      f"{count} axes; a FUN140 table drives one",
                      hint="build with --target fbs-fun147")
            return
        if len(self.assigned) < count:
            self.fail("E643", line.span, f"{line.command.short_name} needs {count} axes "
                      "assigned with AXIS_ASSIGN", hint="AXIS_ASSIGN X, Y, Z before it")
            return
        values = {axis: self.val(op) for axis, op in
                  zip(self.assigned[:count], line.operands, strict=True)}
        self.line_move(line, values, absolute, self.vector_speed,
                       self.vector_span or line.span, "SET_VV")

    def op_line_2d(self, frame: Frame, line: MacroLine) -> None:
        self.interpolate(line, 2, absolute=False)

    def op_abs_line_2d(self, frame: Frame, line: MacroLine) -> None:
        self.interpolate(line, 2, absolute=True)

    def op_line_3d(self, frame: Frame, line: MacroLine) -> None:
        self.interpolate(line, 3, absolute=False)

    def op_abs_line_3d(self, frame: Frame, line: MacroLine) -> None:
        self.interpolate(line, 3, absolute=True)

    def emit(self, draft: Draft) -> None:
        if len(self.drafts) >= self.limits.max_steps:
            self.fail("E645", draft.span, f"{self.name} needs more than "
                      f"{self.limits.max_steps} steps (FB 573)", hint="use fewer "
                      "iterations, or close the loop with LABEL/GOTO")
            self.stopped = True
            return
        if self.drafts and self.drafts[-1].goto is None:
            self.drafts[-1].goto = NEXT
        self.drafts.append(draft)


def _code(operand: Operand) -> int:
    """An operand the lowering always makes a constant (operator codes, label numbers)."""
    assert isinstance(operand, int)
    return operand


def _round10(value: int) -> int:
    return (value + 5) // 10


def _var_of(*values: Val) -> str:
    for value in values:
        if isinstance(value, HostVar):
            return str(value.index)
    return "s"


def steps_of(drafts: list[Draft], sink: DiagnosticSink, profile: Profile) -> list[Step]:
    """Drafts as table steps: WAIT TIME,t + GOTO between moves, MEND after the last move."""
    steps: list[Step] = []
    low, high = profile.time_range
    for number, draft in enumerate(drafts, start=1):
        last = number == len(drafts)
        step = Step(number, draft.speed, draft.motion, span=draft.span,
                    note=f"{draft.span.file}:{draft.span.line}")
        step.spans.update({"speed": draft.speed_span, "speed.value": draft.speed_span,
                           "motion": draft.span})
        wait = _round10(draft.wait_ms)
        if wait > high:
            sink.add("E647", draft.wait_span or draft.span, f"a wait of {draft.wait_ms} ms is "
                     f"beyond WAIT TIME's {high} x 0.01 s", hint="split the wait over moves")
            wait = high
        if last and draft.goto is None:
            if draft.wait_ms:
                sink.add("W641", draft.wait_span or draft.span, "the wait at the end of the "
                         "program is left out: the table ends with MEND after the last move",
                         hint="nothing moves after it; the ladder can wait if it must")
            step.mend = True
            step.spans["mend"] = draft.span
            step.spans["goto"] = draft.span
        else:
            step.condition = Condition("WAIT", time=max(low, wait))
            step.goto = draft.goto if draft.goto is not None else NEXT
            step.spans["condition"] = draft.wait_span or draft.span
            step.spans["goto"] = draft.goto_span or draft.span
        steps.append(step)
    return steps


def compile_mp(paths: list[Path], options: Options, target: str, *,
               texts: dict[Path, str] | None = None) -> FamilyBuild:
    """Compile `.mp` sources to FUN140 (one axis per table) or FUN147 (interpolation) tables:
    one table per MP that no other MP calls; called MPs are inlined. `texts`: editor buffers
    read instead of the files."""
    check_target(target)
    fun = FUN_OF_TARGET[target]
    catalogue = catalogue_module.load()
    profile = load()
    sink = DiagnosticSink()
    sources = load_sources(paths, sink, allow_outside=options.allow_outside_includes,
                           texts=texts)
    unit = build_unit(sources, sink)
    for what, span in configuration_blocks(unit):
        sink.add("E640", span, f"an {what} block cannot be expressed on the FBs-PLC: the "
                 "M8194H's initial table, interrupts and DI triggers have no counterpart in "
                 "a positioning program", hint="configure the PLC through FUN141 MPARA and "
                 "its ladder; build this block for an M8194H target")
    lowered = _lower(unit, catalogue, sink, options)
    lines = {f.display: f.text.splitlines() for f in sources.files}
    tables: list[Table] = []
    if not any(not d.code.startswith("E6") for d in sink.errors):  # the .mp itself is sound
        tables = _tables(lowered, catalogue, profile, sink, fun)
        Checker(profile, sink).check(tables, SimSetup())
    diagnostics = [d for d in sink.sorted() if not suppressed(d, lines)
                   and d.code not in M8194H_ONLY_WARNINGS]
    return FamilyBuild(diagnostics, tables, SimSetup(), target, lines)


def _lower(unit: ast.Unit, catalogue: Catalogue, sink: DiagnosticSink,
           options: Options) -> list[LoweredProgram]:
    scope = Scope.declared(unit, catalogue, sink, options.var_pool, options.temps)
    names = {p.name.upper(): p for p in unit.programs if p.name}
    lowered = []
    for program in unit.programs:
        if program.kind == "isr":
            sink.add("E640", program.span, "an ISR cannot be expressed on the FBs-PLC: "
                     "interrupts belong to the ladder", hint="build the ISR's work into an MP")
            continue
        lowered.append(ProgramLowerer(scope, program, options.temps, LOWERING_TARGET, names)
                       .lower_program())
    return lowered


def _tables(programs: list[LoweredProgram], catalogue: Catalogue, profile: Profile,
            sink: DiagnosticSink, fun: int) -> list[Table]:
    context = Context(programs, catalogue, profile, sink, fun)
    called = {id(target) for p in programs for call in p.calls
              if (target := context.resolve(call.target)) is not None}
    tables: list[Table] = []
    settings: dict[int, ParamTable] = {}
    for program in programs:
        if id(program) in called:
            continue
        name = program.name or f"MP{program.slot}"
        evaluator = Evaluator(context, program, name)
        drafts = evaluator.run()
        if not drafts:
            if not sink.errors:
                sink.add("E649", program.span, f"{name} makes no step: it has no move",
                         hint="add a move, or CALL it from a program that moves")
            continue
        unit = evaluator.table_axis if fun == 140 and evaluator.table_axis is not None else 0
        table = PositioningTable(name, fun, unit, steps=steps_of(drafts, sink, profile),
                                 span=program.span, source=program.source,
                                 origin=f"MP{program.slot}" if program.slot else "")
        tables.append(table)
        moving = {unit} if fun == 140 else {
            a for s in table.steps if isinstance(s.motion, Line)
            for a, v in enumerate(s.motion.strokes) if v is not None}
        for axis, values in sorted(evaluator.params.items()):
            if axis in moving:
                _merge_settings(settings, axis, values, program, sink)
    return tables + [settings[axis] for axis in sorted(settings)]


def _merge_settings(settings: dict[int, ParamTable], axis: int,
                    values: dict[int, tuple[int, Span]], program: LoweredProgram,
                    sink: DiagnosticSink) -> None:
    """One FUN141 table per axis (FB 1457) for the whole build: the first value of each
    parameter stays; a program that wants another one is told."""
    table = settings.get(axis)
    if table is None:
        table = ParamTable(f"fun141_ps{axis}", axis, span=program.span, source=program.source)
        settings[axis] = table
    for number, (value, span) in values.items():
        if number not in table.values:
            table.values[number] = value
            table.spans[number] = span
        elif table.values[number] != value:
            sink.add("W641", span, f"FUN141 holds one parameter {number} for Ps{axis}; the "
                     f"value of {table.spans[number].file}:{table.spans[number].line} stays",
                     hint="use the same ramps for an axis in every program")
