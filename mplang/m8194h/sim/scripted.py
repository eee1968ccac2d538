"""The machine's scripted inputs, as a layer of the virtual M8194H's axis I/O.

A machine file (`mplang.m8194h.machine`) says how inputs change while a program runs: at a
simulated time (`at 2.0 s DI8.3 = 1`) or when an axis reaches a position (`when X >= 5000
DI8.2 = 1`). Both are I/O events of the one axis-I/O model: timed changes are planned like
any other event (so a prediction of STOP_WAIT sees an EMG that comes later), position
conditions are solved on the closed-form profiles like a limit switch (`_crossing`), never
stepped. The inputs of the axes (EMG, ALARM, IN3, INPOS) change inside the model at the
event's time; FRnet DI groups belong to the controller, so their changes are handed over in
`di_changes` for the controller to apply (`VirtualController.take_inputs`).

Positions of conditions are machine positions, the frame of the sensors (`signals`): equal to
LP at power on plus the axis's `start`, not moved by SET_LP or a home search.
"""

from __future__ import annotations

import math
from abc import abstractmethod
from dataclasses import dataclass

from mplang.m8194h.sim.axes import AXES
from mplang.m8194h.sim.builders import _Motion
from mplang.m8194h.sim.crossings import _crossing, _pos_at
from mplang.m8194h.sim.homing import _HomeSearch
from mplang.m8194h.sim.io_state import (
    ERR_EMERGENCY,
    SYNC_IN3_DOWN,
    SYNC_IN3_UP,
    _Event,
)

_INF = math.inf
AXIS_INPUTS = ("ALARM", "IN3", "INPOS")
"""The inputs of one axis a machine file may drive (the others are its sensors)."""


@dataclass(frozen=True)
class InputChange:
    """One input set to a value: `EMG`, `X.ALARM`, `X.IN3`, `X.INPOS` (1 on, 0 off), an
    FRnet DI channel `DI8.3` (0/1) or a whole DI group `DI8` (0..0xFFFF)."""

    name: str
    value: int
    axis: int = -1  # the axis of ALARM / IN3 / INPOS
    group: int = -1  # the FRnet DI group 8..15
    mask: int = 0  # the bits of the group this change writes

    def describe(self) -> str:
        return f"{self.name} = {self.value}"


@dataclass(frozen=True)
class TimedChange:
    """`at TIME s NAME = VALUE, ...`: the changes happen at that simulated time."""

    time: float
    changes: tuple[InputChange, ...]


@dataclass(frozen=True)
class Watch:
    """`when AXIS OP VALUE NAME = VALUE, ...`: the changes happen each time the condition
    becomes true (at once if it holds when the machine is applied). Kept as "position >=
    threshold" and whether the condition is that (`above`) or its negation."""

    axis: int
    threshold: int
    above: bool
    changes: tuple[InputChange, ...]


class _Scripted(_HomeSearch):
    """Timed input changes and position conditions, planned and handled as I/O events."""

    def load_script(self, timed: list[TimedChange], watches: list[Watch], now: float) -> None:
        """Take a machine's script (times from `now` on); conditions that hold now act now."""
        self.model.settle(now)
        self.script = sorted(timed, key=lambda c: c.time)
        self.script_next = 0
        self.watches = list(watches)
        self._changed()
        self.watch_above = [self._phys(w.axis, now) >= w.threshold for w in watches]
        for w, above in zip(watches, self.watch_above, strict=True):
            if above == w.above:
                self._apply_changes(w.changes, now)
        while self.script_next < len(self.script) and self.script[self.script_next].time <= now:
            self._apply_changes(self.script[self.script_next].changes, now)
            self.script_next += 1
        self.model._recompute()

    def script_due(self, now: float) -> float:
        """When the next scripted change of an FRnet input can come (inf: none planned):
        the controller stops its clock there to hand the change to the program."""
        self.model.settle(now)
        return min((e.time for e in self._events if e.kind in ("at", "watch")), default=_INF)

    def inpos_signal(self, i: int, driving: bool) -> bool:
        """INPOS: forced by the machine file, else on while the servo is on and the axis
        does not drive (an ideal drive)."""
        forced = self.inpos_forced[i]
        if forced is not None:
            return forced
        return self.status[i].servo_on and not driving

    # ------------------------------------------------------------------- planning
    def _plan_script(self, out: list[_Event]) -> None:
        if self.script_next < len(self.script):
            out.append(_Event(max(self.script[self.script_next].time, self.now), 3, "at", 0,
                              self.script_next))

    def _plan_watches(self, m: _Motion, k: int, i: int, mach: int, out: list[_Event]) -> None:
        """The next crossing of each condition on axis i by motion m (its path axis k)."""
        now = self.now
        for n, w in enumerate(self.watches):
            if w.axis != i:
                continue
            level = w.threshold - 0.5 - mach  # machine position rounds half up, as LP
            rising = not self.watch_above[n]
            if (_pos_at(m, k, now) >= level) == rising:
                out.append(_Event(now, 3, "watch", i, n, m))  # already across
                continue
            t = _crossing(m, k, level, rising, now)
            if t is not None:
                out.append(_Event(t, 3, "watch", i, n, m))

    def _watches_axis(self, i: int) -> bool:
        return any(w.axis == i for w in self.watches)

    # ------------------------------------------------------------------- handling
    def _script_event(self, e: _Event, t: float) -> None:
        if e.kind == "at":
            if e.arg == self.script_next:
                self.script_next += 1
                self._apply_changes(self.script[e.arg].changes, t)
            return
        w = self.watches[e.arg]
        above = not self.watch_above[e.arg]
        self.watch_above[e.arg] = above
        if above == w.above:
            self._apply_changes(w.changes, t)

    def _apply_changes(self, changes: tuple[InputChange, ...], t: float) -> None:
        """Set inputs at time t from inside an event (no settle: we are in it)."""
        for change in changes:
            on = bool(change.value)
            if change.name == "EMG":
                self._emg(on, t)
            elif change.group >= 0:
                bits = change.value if change.mask == 0xFFFF else change.mask * on
                self.di_changes.append((t, change.group, change.mask, bits))
            elif change.name.endswith(".ALARM"):
                self.status[change.axis].alarm_input = on
                self._check_alarm(change.axis, t)
            elif change.name.endswith(".IN3"):
                self._in3(change.axis, 0 if on else 1, t)  # IN3 is low active
            else:
                self.inpos_forced[change.axis] = on

    def _emg(self, asserted: bool, t: float) -> None:
        """The EMG input (common to the four axes): asserted, it stops every axis suddenly
        and sets EMERGENCY (32) on all of them."""
        self.emg_input = asserted
        if asserted:
            for i in range(len(AXES)):
                self.status[i].errors |= ERR_EMERGENCY
            self._halt_all(t, sudden=True)

    def _in3(self, i: int, level: int, t: float) -> None:
        """IN3 of axis i to an electrical level; an edge is a synchronous-action factor."""
        st = self.status[i]
        old, st.in3_level = st.in3_level, 1 if level else 0
        if old != st.in3_level:
            self._sync(i, SYNC_IN3_UP if st.in3_level else SYNC_IN3_DOWN, t)

    @abstractmethod
    def _check_alarm(self, i: int, now: float) -> None:
        """An active enabled ALARM halts its axis (`axis_io` implements it)."""

    @abstractmethod
    def _halt_all(self, now: float, sudden: bool) -> None:
        """Every motion stops (`axis_io` implements it)."""
