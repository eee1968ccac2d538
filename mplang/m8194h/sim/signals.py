"""Simulated sensors of the virtual M8194H's axes and the positions where they are engaged.

The sensors sit in the *machine frame*, which equals LP at power on and does not move when
SET_LP / SET_EP (or a home search) rewrite the counters.  A signal is a set of integer
positions, intervals (limit switches, NHOME, HOME) or periodic (the encoder's Z phase), that
tells where its state changes next; the axis I/O (`axis_io`) turns that into event times.

Conventions and simplifications (manual = RS manual, "l.N" its line N)
--------------------------------------------------------------------
* Sensors (`AxisSensors`): LIMIT+ is engaged at and above its position, LIMIT- at and
  below; NHOME and HOME are closed intervals; the Z phase (index) is engaged for `width`
  pulses once every `period` pulses.  ``None`` = not fitted (never engaged).  Defaults: no
  limit switches (so a bare controller runs continuous moves for ever, as before), NHOME
  -20000..20000, HOME -1000..1000, index every 4000 pulses at 0.
"""

from __future__ import annotations

from dataclasses import dataclass


class _Intervals:
    """A set of integer positions: sorted, disjoint closed intervals (None = unbounded)."""

    __slots__ = ("parts",)

    def __init__(self, parts: list[tuple[int | None, int | None]]) -> None:
        self.parts = parts

    def empty(self) -> bool:
        return not self.parts

    def active(self, p: int) -> bool:
        return any((lo is None or lo <= p) and (hi is None or p <= hi) for lo, hi in self.parts)

    def next_change(self, p: int, d: int) -> int | None:
        """First position after p in direction d whose state differs from p's."""
        for lo, hi in self.parts:
            if (lo is None or lo <= p) and (hi is None or p <= hi):
                if d > 0:
                    return None if hi is None else hi + 1
                return None if lo is None else lo - 1
        if d > 0:
            starts = [lo for lo, _hi in self.parts if lo is not None and lo > p]
            return min(starts) if starts else None
        ends = [hi for _lo, hi in self.parts if hi is not None and hi < p]
        return max(ends) if ends else None

    def complement(self) -> _Intervals:
        out: list[tuple[int | None, int | None]] = []
        cursor: int | None = None  # next uncovered position; None = from minus infinity
        first = True
        for lo, hi in self.parts:
            if lo is not None and (first or cursor is not None):
                if first:
                    out.append((None, lo - 1))
                elif cursor is not None and cursor <= lo - 1:
                    out.append((cursor, lo - 1))
            first = False
            if hi is None:
                return _Intervals(out)
            cursor = hi + 1
        out.append((None, None) if first else (cursor, None))
        return _Intervals(out)


class _Periodic:
    """Positions p with (p - offset) mod period < width: the encoder Z phase."""

    __slots__ = ("offset", "period", "width")

    def __init__(self, period: int, offset: int, width: int) -> None:
        self.period, self.offset, self.width = period, offset, width

    def empty(self) -> bool:
        return self.width <= 0

    def active(self, p: int) -> bool:
        return (p - self.offset) % self.period < self.width

    def next_change(self, p: int, d: int) -> int | None:
        if self.width <= 0 or self.width >= self.period:
            return None
        r = (p - self.offset) % self.period
        if d > 0:
            return p + (self.width - r) if r < self.width else p + (self.period - r)
        return p - r - 1 if r < self.width else p - r + self.width - 1

    def complement(self) -> _Periodic:
        return _Periodic(self.period, self.offset + self.width, self.period - self.width)


_Signal = _Intervals | _Periodic


@dataclass
class AxisSensors:
    """The switches of one simulated axis, in pulses of the machine frame (= LP at power on).

    ``None`` means not fitted.  ``wiring`` is the electrical level an engaged sensor
    drives (None: the machine is wired to match the controller's active-level settings).
    """

    limit_plus: int | None = None
    limit_minus: int | None = None
    near_home: tuple[int, int] | None = (-20_000, 20_000)
    home: tuple[int, int] | None = (-1_000, 1_000)
    index_period: int | None = 4_000
    index_offset: int = 0
    index_width: int = 1
    wiring: int | None = None

    def __post_init__(self) -> None:
        for name in ("near_home", "home"):
            span = getattr(self, name)
            if span is not None and span[0] > span[1]:
                raise ValueError(f"{name} interval {span} is empty")
        if self.index_period is not None and self.index_period < 1:
            raise ValueError("index_period must be positive")
        if self.wiring not in (None, 0, 1):
            raise ValueError("wiring must be None, 0 or 1")
