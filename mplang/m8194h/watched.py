"""A run of the virtual M8194H that can be watched while it goes (`mplang.family.watch`):
`VirtualController.run` in slices of simulated time, with the watch called between slices
and asked to stop; and a run without a time limit (`--max-time none`).

Slicing does not change what the run computes: the interpreter resumes exactly where a slice
stopped (the sampled run, `mplang.m8194h.trace.run_traced`, relies on the same;
tests/m8194h/test_watched.py compares both with `run` on every sample program). The slices
grow while they are quick and shrink when slow, so the watch is called a few dozen times a
second of wall time whatever the program does.
"""

from __future__ import annotations

import math
import sys
import time

from mplang.family.watch import Watch, Where
from mplang.m8194h.sim.controller import MAX_STEPS_DEFAULT, RunResult, VirtualController
from mplang.m8194h.sim.failure import Place

SLICE_FIRST_S = 0.1
SLICE_MAX_S = 60.0
SLICE_WALL_S = (0.01, 0.05)
"""A slice shorter than the first (wall seconds) doubles the next, longer than the second
halves it."""


def running_place(controller: VirtualController) -> Place | None:
    """The slot line the running program is at (the line it ran last, or waits on)."""
    if not controller.stack:
        return None
    frame = controller.stack[-1]
    lines = frame.table.lines
    if not lines:
        return None
    line = lines[max(0, min(frame.pc - 1, len(lines) - 1))]
    return Place(frame.table.kind, frame.table.slot, line.slot_line)


def waits_for_ever(controller: VirtualController) -> bool:
    """The running program waits for something nothing left in the run can bring: no motion
    to end, no command queued, no interrupt waiting. A run without a time limit ends there
    (with a limit, the run goes on to the limit as `run` does)."""
    if not controller.stack:
        return False
    wait = controller.stack[-1].wait
    return (wait is not None and wait() == math.inf and not controller.fifo
            and not controller.isr_queue and controller.loading_until is None
            and controller.motion.next_event(controller.clock) is None)


def step_budget(max_time: float) -> int:
    """The line budget of a run: the controller's own, none without a time limit."""
    return MAX_STEPS_DEFAULT if math.isfinite(max_time) else sys.maxsize


def stopped(result: RunResult) -> bool:
    """Whether the watch stopped the run: the only way a run ends unfinished without an
    error."""
    return not result.finished and result.error is None


def run_watched(controller: VirtualController, max_time: float, watch: Watch,
                where: Where) -> RunResult:
    """`controller.run(max_time)` for a program already called, calling `watch(time,
    where)` between slices. When the watch stops the run, the result is the state at that
    moment: not finished, no error (`stopped`)."""
    start = controller.clock
    limit = start + max_time
    max_steps = step_budget(max_time)
    steps = 0
    span = SLICE_FIRST_S
    while True:
        target = min(limit, controller.clock + span)
        began = time.monotonic()
        steps += controller.advance(target, max_steps - steps, until_idle=True)
        if controller.clock < target or controller.clock >= limit or steps >= max_steps:
            break  # idle (finished or failed), out of time, or out of lines
        if not math.isfinite(limit) and waits_for_ever(controller):
            limit = controller.clock  # `outcome` names the wait (R201) here
            break
        if watch(controller.clock - start, where):
            return RunResult(False, controller.clock, steps)
        took = time.monotonic() - began
        if took < SLICE_WALL_S[0]:
            span = min(SLICE_MAX_S, span * 2)
        elif took > SLICE_WALL_S[1]:
            span = max(SLICE_FIRST_S / 16, span / 2)
    outcome = controller.outcome(limit, steps)
    if not outcome.finished:
        return outcome
    end = controller.motion.idle_at(15, controller.clock)  # the motion the program started
    if end is not None:
        controller.clock = max(controller.clock, end)
        controller.motion.settle(controller.clock)
    return RunResult(True, controller.clock, steps)
