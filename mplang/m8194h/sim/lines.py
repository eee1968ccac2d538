"""The lines of one program frame, run one after the other (`run`, for
`VirtualController.advance`, which decides how far a slice of lines may go).

Quick lines (`precompile`: the variable and control-flow lines) run with the clock and the
pc in locals, each returning the pc to go on at; both are written back to the controller
and the frame before anything else can read them: a handler, `before_line`, an error, the
end of the slice. Every other line goes through its handler with the state written back,
and under a debugger (`before_line`) every line does, after the hook. A straight run of
quick lines runs as one block (`blocks`) when all of it fits in the slice, and an innermost
loop of them as many turns as fit in one call (`loops`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mplang.m8194h.sim.failure import failed
from mplang.m8194h.sim.queues import QueueFull, Retry

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import Frame, VirtualController


def run(vc: VirtualController, frame: Frame, horizon: float, steps: int,
        max_steps: int) -> tuple[int, bool]:
    """Run the lines of the top frame from its pc until the clock reaches `horizon`, the
    line budget is spent, or a line waits, moves an axis that events may come of, or
    changes the call stack. Returns the line count (`steps` plus the lines run) and whether
    `before_line` asked to stop. One function: the locals are the point of it."""
    stack = vc.stack
    line_time = vc.line_time
    hook = vc.before_line
    program = frame.program
    if program is None:
        program = frame.program = vc.prepared(frame.table)
    lines = program.lines
    quick = program.quick if hook is None else program.blank
    fused = program.fused if hook is None and program.fused_time == line_time \
        else program.blank
    end_pc = len(lines)
    clock = vc.clock
    pc = frame.pc
    while clock < horizon and steps < max_steps:
        block = fused[pc]
        if block is not None:
            run_block, count, span, loop = block
            if steps + count <= max_steps and clock + span < horizon:
                if loop is not None:
                    turns = loop(frame, clock, steps, max_steps, horizon)
                    if turns is not None:
                        pc, clock, steps = turns
                        continue
                steps += count
                try:
                    pc, clock = run_block(frame, clock)
                except Exception as err:  # only from its last line (`blocks`)
                    for _ in range(count):
                        clock += line_time
                    frame.pc = pc + count
                    vc.clock = clock
                    failed(vc, frame, pc + count - 1, err)
                    return steps, False
                continue
        fast = quick[pc]
        if fast is not None:
            steps += 1
            clock += line_time
            try:
                pc = fast(frame)
            except Exception as err:  # never out of the device: as any line (below)
                frame.pc = pc + 1
                vc.clock = clock
                failed(vc, frame, pc, err)
                return steps, False
            continue
        frame.pc = pc
        vc.clock = clock
        if hook is not None and hook(frame):
            return steps, True
        if pc >= end_pc:
            stack.pop()  # the closing line: return to the caller
            vc.clock += line_time
            return steps, False
        handler, operands, touches_motion = lines[pc]
        steps += 1
        clock = vc.clock = vc.clock + line_time
        frame.pc = pc + 1
        if handler is None:
            pc += 1
            continue  # a setting the model does not simulate: accepted, no effect
        try:
            wait = handler(frame, operands)
        except QueueFull as full:  # the motion queue is full: wait, run the line again
            frame.wait = Retry(vc, full)
            return steps, False
        except Exception as err:  # never out of the device: an execution error
            failed(vc, frame, pc, err)
            return steps, False
        if wait is not None:
            if clock < horizon and vc.machine is None and vc.loading_until is None and \
                    not vc.isr_queue and vc.motion.io.uneventful():
                # what `advance` would do next, here: nothing falls due before the horizon
                # and no interrupt can come, so the wait ends at its end (`ends_inside`)
                end = wait()
                if end < horizon:
                    if ends_inside(vc, end) and stack and stack[-1] is frame:
                        pc, clock = frame.pc, vc.clock
                        continue
                    return steps, False
            frame.wait = wait
            return steps, False
        if touches_motion:
            vc.epoch += 1
            if vc.machine is not None or vc.loading_until is not None or \
                    vc.isr_queue or not vc.motion.io.uneventful():
                return steps, False  # a new motion (and its interrupts): look again
        if not stack or stack[-1] is not frame:
            return steps, False  # MP_CALL, EXIT_MACRO or MP_TERMINATE changed the program
        pc, clock = frame.pc, vc.clock
    frame.pc = pc
    vc.clock = clock
    return steps, False


def ends_inside(vc: VirtualController, end: float) -> bool:
    """End a wait of the running line at `end` (before the slice's horizon), as `advance`
    ends it: the clock moves there and the motion model settles. True when the slice may
    run on (no interrupt can come of what settled); otherwise `advance` looks again."""
    if end > vc.clock:
        vc.clock = end
    motion = vc.motion
    motion.settle(vc.clock)
    return motion.io.uneventful()
