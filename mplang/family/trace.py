"""A run sampled over simulated time, for `mpc plot` and `mpc run --trace`: the same record
for every family. The M8194H samples its virtual controller directly
(`mplang.m8194h.trace.run_traced`); the other families report positions per sample time
(`FamilyRun.samples`), which `trace_from_samples` turns into a trace."""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TextIO

AXIS_NAMES = ("X", "Y", "Z", "U")
"""The path axes, first in every trace (the M8194H's four axes)."""

DEFAULT_PERIOD = 0.001
"""Sampling period in seconds of simulated time (1 ms)."""

CSV_COLUMNS_PER_AXIS = ("lp", "ep", "velocity")
SAME_INSTANT_S = 1e-7
"""Samples closer than this are one instant (the CSV counts microseconds): float sums such
as 0.214 and 0.21400000000000002 must not make two rows, the second with a false velocity."""


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
    variables: tuple[str, ...] = ()  # declared variables by name: `rows_done (VAR400)`
    values: list[list[float]] = field(default_factory=list)  # per variable, per sample
    places: list[str] | None = None
    """Where the running program is at each sample (`file:line` of its source, "" while
    none runs; the last sample of a failed run is at the failing line): the CSV's `source`
    column. None for a family that cannot tell."""

    def __post_init__(self) -> None:
        if not self.lp:
            self.lp = [[] for _ in self.axes]
            self.ep = [[] for _ in self.axes]
            self.velocity = [[] for _ in self.axes]
        if not self.values:
            self.values = [[] for _ in self.variables]

    def __len__(self) -> int:
        return len(self.time)

    def add(self, now: float, readings: Sequence[tuple[float, float, float]],
            values: Sequence[float] = (), place: str | None = None) -> None:
        """One sample: (LP, EP, velocity) per axis at `now`, and the value of every traced
        variable (`variables`). A second sample at the same instant replaces the first:
        the later reading is the settled one."""
        if self.time and now <= self.time[-1] + SAME_INSTANT_S:
            self._drop_last()
        self.time.append(now)
        for index, (lp, ep, velocity) in enumerate(readings):
            self.lp[index].append(lp)
            self.ep[index].append(ep)
            self.velocity[index].append(velocity)
        for series, value in zip(self.values, values, strict=True):
            series.append(value)
        if self.places is not None:
            self.places.append(place or "")

    def _drop_last(self) -> None:
        self.time.pop()
        for index in range(len(self.axes)):
            self.lp[index].pop()
            self.ep[index].pop()
            self.velocity[index].pop()
        for series in self.values:
            series.pop()
        if self.places is not None:
            self.places.pop()

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
        """time_s, three columns per axis, then one per traced variable, headed by its
        declared name with the device's number beside it (`rows_done (VAR400)`), then
        `source` where the family tells the running program's source line."""
        return ["time_s", *(f"{axis}_{column}" for axis in self.axes
                            for column in CSV_COLUMNS_PER_AXIS), *self.variables,
                *(["source"] if self.places is not None else [])]

    def changing_variables(self) -> tuple[int, ...]:
        """The traced variables whose value changed during the run (by index)."""
        return tuple(i for i, series in enumerate(self.values)
                     if series and min(series) != max(series))

    def rows(self) -> Iterator[list[str]]:
        """One CSV row per sample: time in seconds (1 us resolution), positions as integers
        (real coordinates as they are, see `position_text`), velocities with 3 decimals,
        variables as they are."""
        for k, when in enumerate(self.time):
            row = [f"{when:.6f}"]
            for index in range(len(self.axes)):
                speed = round(self.velocity[index][k], 3) + 0.0  # no "-0.000"
                row += [position_text(self.lp[index][k]), position_text(self.ep[index][k]),
                        f"{speed:.3f}"]
            row += [position_text(series[k]) for series in self.values]
            if self.places is not None:
                row.append(_csv_field(self.places[k]))
            yield row

    def write_csv(self, stream: TextIO) -> None:
        stream.write(",".join(self.header()) + "\n")
        for row in self.rows():
            stream.write(",".join(row) + "\n")


def _csv_field(text: str) -> str:
    """A CSV field: quoted when a comma, quote or line break would split it (a path may
    hold any of them)."""
    if any(c in text for c in ',"\r\n'):
        return '"' + text.replace('"', '""') + '"'
    return text


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
        if trace.time and when <= trace.time[-1] + SAME_INSTANT_S:
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


class SampledRun:
    """What a run that reports positions per sample time (`samples`, on the grid
    `sample_period`) shows through the family face: its trace and its headings. The FATEK
    and CSIM runs mix it in; `POSITION_UNIT` names their coordinate unit."""

    POSITION_UNIT = "pulses"
    called: str
    sample_period: float | None

    if TYPE_CHECKING:  # a field or a property of each run: nothing here to shadow it
        @property
        def samples(self) -> Sequence[tuple[float, Mapping[str, float]]]: ...

    @property
    def trace(self) -> Trace | None:
        """The samples as a trace, when the run was sampled on a grid."""
        if self.sample_period is None:
            return None
        return trace_from_samples(self.samples, self.sample_period, self.POSITION_UNIT)

    @property
    def warnings(self) -> Sequence[str]:
        """These runs report what they do not simulate when the program is checked."""
        return ()

    def headline_detail(self, controller: str) -> str:
        return f" on the virtual {controller}"

    def plot_title(self, controller: str, sources: str) -> str:
        return f"{self.called} ({sources}) on the virtual {controller}"
