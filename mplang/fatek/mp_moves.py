"""Macro lines of motion, evaluated at compile time into the steps of an FBs-PLC table.

Speeds, accelerations and start speeds (which become FUN141 parameters), TIMER waits (the
WAIT TIME of the step before), single-axis moves (DRV) and interpolated moves (LIN). Mixed
into the `Evaluator` of mplang/fatek/compile.py.
"""

from __future__ import annotations

import math

from mplang.fatek.model import NEXT, Drive, Line, Value
from mplang.fatek.mp_state import Draft, EvaluatorBase, Frame, Val, round10
from mplang.ir.macro import MacroLine, Operand
from mplang.lang.diagnostics import Span


class MoveOps(EvaluatorBase):
    """Settings, waits and moves: what makes (or shapes) a step."""

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
                          f"{round10(value) * 10} ms (WAIT TIME counts 0.01 s)")
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
        if isinstance(stroke, int) and absolute and stroke == 0 and \
                self.cx.profile.semantics("abs_zero") == "continuous":
            if state.position is None:
                self.fail("E647", line.span, "a move to absolute 0 from an unknown position: "
                          "with semantics.abs_zero = 'continuous', DRV ABS with a stroke of 0 "
                          "is a continuous run (FB 955-957)",
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
