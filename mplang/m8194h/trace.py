"""Sampling a run of the virtual controller over simulated time, for `mpc plot` and
`mpc run --trace`.

The controller has no notion of a recorder: the motion model forgets finished motions, so
positions cannot be looked up afterwards. `run_traced` therefore drives the controller the
way `VirtualController.run` does, but in slices: it advances to the next sample time, reads
every axis, and goes on. Slicing does not change what the run computes (the interpreter
resumes exactly where a slice stopped, and reading the motion model at the controller's own
clock is what `snapshot` does too); tests/m8194h/test_trace.py checks that on every sample program.

Samples fall on the grid `start + k * period`, plus the instant every motion ends, so the
corners of a path are exact. When a slice ends while macro lines run, the controller's clock
may stand up to one line time (100 us) past the grid point; the sample is then taken, and
stamped, at the clock, never at a time the controller has already left behind.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TextIO

from mplang.m8194h.sim.controller import AXIS_NAMES, MAX_STEPS_DEFAULT, RunResult, VirtualController
from mplang.m8194h.sim.motion import MotionModel

DEFAULT_PERIOD = 0.001
"""Sampling period in seconds of simulated time (1 ms)."""

CSV_COLUMNS_PER_AXIS = ("lp", "ep", "velocity")


@dataclass
class Trace:
    """Time series of every axis: logical position (LP) and encoder position (EP) in pulses
    (or the `unit` of another controller family), signed velocity in units/s, one entry per
    sample time in seconds. M8194H positions are whole pulses; a family may report real
    coordinates (CSIM)."""

    period: float
    axes: tuple[str, ...] = AXIS_NAMES
    time: list[float] = field(default_factory=list)
    lp: list[list[float]] = field(default_factory=list)
    ep: list[list[float]] = field(default_factory=list)
    velocity: list[list[float]] = field(default_factory=list)
    unit: str = "pulses"

    def __post_init__(self) -> None:
        if not self.lp:
            self.lp = [[] for _ in self.axes]
            self.ep = [[] for _ in self.axes]
            self.velocity = [[] for _ in self.axes]

    def __len__(self) -> int:
        return len(self.time)

    def record(self, controller: VirtualController) -> None:
        """Read every axis at the controller's present clock. A second sample at the same
        instant replaces the first: the later reading is the settled one."""
        now = controller.clock
        if self.time and now <= self.time[-1]:
            self._drop_last()
        self.time.append(now)
        model = controller.motion
        for index in range(len(self.axes)):
            lp, ep, velocity = axis_state(model, index, now)
            self.lp[index].append(lp)
            self.ep[index].append(ep)
            self.velocity[index].append(velocity)

    def _drop_last(self) -> None:
        self.time.pop()
        for index in range(len(self.axes)):
            self.lp[index].pop()
            self.ep[index].pop()
            self.velocity[index].pop()

    def axis(self, name: str) -> int:
        """Index of an axis by its name (X, Y, Z, U)."""
        return self.axes.index(name.upper())

    def moved(self, name: str) -> bool:
        """True if the axis's logical position changed at some point of the run."""
        series = self.lp[self.axis(name)]
        return bool(series) and min(series) != max(series)

    def moving_axes(self) -> tuple[str, ...]:
        return tuple(name for name in self.axes if self.moved(name))

    def extent(self, name: str) -> tuple[float, float]:
        """Smallest and largest logical position the axis reached."""
        series = self.lp[self.axis(name)]
        return min(series), max(series)

    def header(self) -> list[str]:
        return ["time_s", *(f"{axis}_{column}" for axis in self.axes
                            for column in CSV_COLUMNS_PER_AXIS)]

    def rows(self) -> Iterator[list[str]]:
        """One CSV row per sample: time in seconds (1 us resolution), positions as integers
        (real coordinates as they are, see `position_text`), velocities with 3 decimals."""
        for k, when in enumerate(self.time):
            row = [f"{when:.6f}"]
            for index in range(len(self.axes)):
                speed = round(self.velocity[index][k], 3) + 0.0  # no "-0.000"
                row += [position_text(self.lp[index][k]), position_text(self.ep[index][k]),
                        f"{speed:.3f}"]
            yield row

    def write_csv(self, stream: TextIO) -> None:
        stream.write(",".join(self.header()) + "\n")
        for row in self.rows():
            stream.write(",".join(row) + "\n")


def position_text(value: float) -> str:
    """An integer as it is (every M8194H position); a real coordinate without float dust:
    whole values as integers, others with up to 6 decimals (1e-6 unit)."""
    if isinstance(value, int):
        return str(value)
    rounded = round(value, 6) + 0.0  # no "-0"
    if rounded.is_integer():
        return str(int(rounded))
    return f"{rounded:.6f}".rstrip("0")


def trace_from_samples(samples: Sequence[tuple[float, Mapping[str, float]]], period: float,
                       unit: str = "pulses") -> Trace:
    """A Trace of another family's run (`FamilyRun.samples`: time and position per axis).
    X, Y, Z and U come first (the path planes), then any other axis in order of appearance.
    The families count one position per axis, so EP is LP; the velocity of a sample is the
    mean over the interval since the previous sample (0 at the first), the families giving
    positions only. An axis a sample does not name keeps its last position (0 before)."""
    names = [name for name in AXIS_NAMES if any(name in point for _, point in samples)]
    for _, point in samples:
        names += [name for name in point if name not in names]
    trace = Trace(period, tuple(names), unit=unit)
    last = dict.fromkeys(names, 0.0)
    for when, point in samples:
        if trace.time and when <= trace.time[-1]:
            trace._drop_last()
        previous = trace.time[-1] if trace.time else None
        for index, name in enumerate(names):
            value = point.get(name, last[name])
            trace.lp[index].append(value)
            trace.ep[index].append(value)
            before = trace.lp[index][-2] if previous is not None else value
            trace.velocity[index].append(0.0 if previous is None
                                         else (value - before) / (when - previous))
        for name in names:
            last[name] = point.get(name, last[name])
        trace.time.append(when)
    return trace


def axis_state(model: MotionModel, axis: int, now: float) -> tuple[int, int, float]:
    """LP, EP and signed velocity (pulses/s) of axis 0..3 (see `MotionModel.sample`)."""
    return model.sample(axis, now)


def run_traced(controller: VirtualController, period: float = DEFAULT_PERIOD,
               max_time: float = 3600.0,
               max_steps: int = MAX_STEPS_DEFAULT) -> tuple[RunResult, Trace]:
    """`controller.run(max_time, max_steps)` for a program already called, sampling every
    axis every `period` seconds of simulated time and at the end of every motion. Returns
    the same result `run` would and the samples, the last one at the moment the run ends
    (after the motion the program started has come to rest, or where it failed)."""
    if not period > 0.0:
        raise ValueError(f"the sampling period must be positive, got {period}")
    trace = Trace(period)
    start = controller.clock
    limit = start + max_time
    steps = 0
    tick = 1
    trace.record(controller)
    while True:
        target = min(_next_stop(controller, start, period, tick), limit)
        steps += controller.advance(target, max_steps - steps, until_idle=True)
        trace.record(controller)
        tick = _next_tick(controller.clock, start, period, tick)
        if controller.clock < target or controller.clock >= limit:
            break  # idle (finished or failed), out of steps, or out of time
    result = controller.outcome(limit, steps)
    if result.finished:
        _record_until_rest(controller, trace, start, period, tick)
        result = RunResult(True, controller.clock, steps)
    trace.record(controller)
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


def _record_until_rest(controller: VirtualController, trace: Trace, start: float,
                       period: float, tick: int) -> None:
    """After the program finished: let the motion it started run out, as `run` does,
    sampling on the way."""
    end = controller.motion.idle_at(15, controller.clock)
    if end is None or end <= controller.clock:
        return
    while controller.clock < end:
        target = min(_next_stop(controller, start, period, tick), end)
        controller.advance(target)
        trace.record(controller)
        tick = _next_tick(controller.clock, start, period, tick)
    controller.motion.settle(controller.clock)
