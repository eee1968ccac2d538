"""Sampling a run of the virtual M8194H over simulated time into a `Trace`
(`mplang.family.trace`), for `mpc plot` and `mpc run --trace`.

The controller has no notion of a recorder: the motion model forgets finished motions, so
positions cannot be looked up afterwards. `run_traced` therefore drives the controller the
way `VirtualController.run` does, but in slices: it advances to the next sample time, reads
every axis, and goes on. Slicing does not change what the run computes (the interpreter
resumes exactly where a slice stopped, and reading the motion model at the controller's own
clock is what `snapshot` does too); tests/m8194h/test_trace.py checks that on every sample
program.

Samples fall on the grid `start + k * period`, plus the instant every motion ends, so the
corners of a path are exact. When a slice ends while macro lines run, the controller's clock
may stand up to one line time (100 us) past the grid point; the sample is then taken, and
stamped, at the clock, never at a time the controller has already left behind.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from mplang.family.trace import DEFAULT_PERIOD, Trace
from mplang.family.watch import Watch, Where
from mplang.m8194h.sim.controller import RunResult, VirtualController
from mplang.m8194h.sim.motion import MotionModel
from mplang.m8194h.watched import step_budget, waits_for_ever


def record(trace: Trace, controller: VirtualController,
           indices: Sequence[int] = (), where: Where | None = None) -> None:
    """Read every axis at the controller's present clock into the trace, the variables
    `indices` (VARn, one per `trace.variables`) and, given `where`, the source line the
    running program is at."""
    now = controller.clock
    place = None
    if where is not None and controller.stack:
        found = where()
        place = f"{found.file}:{found.line}" if found.line is not None else ""
    trace.add(now, [axis_state(controller.motion, index, now)
                    for index in range(len(trace.axes))],
              [controller.vars[index] for index in indices], place)


def axis_state(model: MotionModel, axis: int, now: float) -> tuple[int, int, float]:
    """LP, EP and signed velocity (pulses/s) of axis 0..3 (see `MotionModel.sample`)."""
    return model.sample(axis, now)


def run_traced(controller: VirtualController, period: float = DEFAULT_PERIOD,
               max_time: float = 3600.0, max_steps: int | None = None,
               watch: Watch | None = None, where: Where | None = None,
               variables: Sequence[tuple[str, int]] = ()) -> tuple[RunResult, Trace]:
    """`controller.run(max_time, max_steps)` for a program already called, sampling every
    axis every `period` seconds of simulated time and at the end of every motion. Returns
    the same result `run` would and the samples, the last one at the moment the run ends
    (after the motion the program started has come to rest, or where it failed). An
    infinite `max_time` is no limit (`mplang.m8194h.watched`); `watch(time, where)` is
    called between samples, and when it answers True the run ends there, unfinished and
    without an error (`watched.stopped`). `variables` (label, VARn index) are sampled
    with the axes, as columns of the trace."""
    if not period > 0.0:
        raise ValueError(f"the sampling period must be positive, got {period}")
    if max_steps is None:
        max_steps = step_budget(max_time)
    trace = Trace(period, variables=tuple(label for label, _ in variables),
                  places=[] if where is not None else None)
    indices = [index for _, index in variables]

    def sample() -> None:
        record(trace, controller, indices, where)

    start = controller.clock
    limit = start + max_time
    steps = 0
    tick = 1
    sample()
    while True:
        target = min(_next_stop(controller, start, period, tick), limit)
        steps += controller.advance(target, max_steps - steps, until_idle=True)
        sample()
        tick = _next_tick(controller.clock, start, period, tick)
        if controller.clock < target or controller.clock >= limit:
            break  # idle (finished or failed), out of steps, or out of time
        if not math.isfinite(limit) and waits_for_ever(controller):
            limit = controller.clock  # no time limit: `outcome` names the wait (R201) here
            break
        if watch is not None and where is not None and watch(controller.clock - start, where):
            return RunResult(False, controller.clock, steps), trace
    result = controller.outcome(limit, steps)
    if result.finished:
        _record_until_rest(controller, sample, start, period, tick)
        result = RunResult(True, controller.clock, steps)
    sample()
    return result, trace


def _next_stop(controller: VirtualController, start: float, period: float, tick: int) -> float:
    """The next grid point, or the end of a running motion if that comes first."""
    grid = start + tick * period
    motion_end = controller.motion.next_event(controller.clock)
    return grid if motion_end is None else min(grid, motion_end)


def _next_tick(now: float, start: float, period: float, tick: int) -> int:
    """The number of the first grid point after `now` (never below `tick`)."""
    tick = max(tick, math.floor((now - start) / period))
    while start + tick * period <= now:
        tick += 1
    return tick


def _record_until_rest(controller: VirtualController, sample: Callable[[], None],
                       start: float, period: float, tick: int) -> None:
    """After the program finished: let the motion it started run out, as `run` does,
    sampling on the way."""
    end = controller.motion.idle_at(15, controller.clock)
    if end is None or end <= controller.clock:
        return
    while controller.clock < end:
        target = min(_next_stop(controller, start, period, tick), end)
        controller.advance(target)
        sample()
        tick = _next_tick(controller.clock, start, period, tick)
    controller.motion.settle(controller.clock)
