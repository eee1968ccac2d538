"""The FBs-PLC's pulse output as closed-form motion: speed profiles over a path and the legs
that carry them out on the axes.

Why not `mplang.m8194h.sim.motion`: the M8194H model quantises speeds to MAX_V/8000, ramps with
accelerations given directly (and S-curves), and plans one command at a time. The PLC ramps
with a constant slope set as a *time* to the maximum speed (FUN141 parameters 4, 5, 8, 12;
FB 1597-1602, 1700-1732), starts and stops at the start/stop speed, and chains DRVC segments
at different speeds into one run (FB 974-1019). Those rules fit a small planner better than
they fit the M8194H's.

A profile is a list of phases of constant acceleration in path length `s` (pulses, never
decreasing); a leg maps `s` onto one or more axes. Everything is evaluated in closed form, so
a run of hours costs the same as a run of milliseconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

INF = math.inf


@dataclass(frozen=True)
class Phase:
    """Constant acceleration `a` from time `t0` for `duration` (possibly infinite)."""

    t0: float
    duration: float
    s0: float
    v0: float
    a: float

    @property
    def t1(self) -> float:
        return self.t0 + self.duration

    def s(self, t: float) -> float:
        tau = min(max(t - self.t0, 0.0), self.duration)
        return self.s0 + self.v0 * tau + 0.5 * self.a * tau * tau

    def v(self, t: float) -> float:
        tau = min(max(t - self.t0, 0.0), self.duration)
        return max(self.v0 + self.a * tau, 0.0)

    @property
    def s1(self) -> float:
        return self.s(self.t1) if self.duration != INF else INF

    def time_at(self, target: float) -> float:
        """The first time this phase reaches path length `target` (INF if it does not)."""
        gap = target - self.s0
        if gap <= 0:
            return self.t0
        if self.duration != INF and target > self.s1 + 1e-9:
            return INF
        if abs(self.a) < 1e-12:
            return self.t0 + gap / self.v0 if self.v0 > 0 else INF
        disc = self.v0 * self.v0 + 2 * self.a * gap
        if disc < 0:
            return INF if self.duration == INF else self.t1
        tau = (math.sqrt(disc) - self.v0) / self.a
        if self.duration != INF:
            tau = min(tau, self.duration)
        return self.t0 + max(tau, 0.0)


@dataclass
class PathProfile:
    """Path length over time, starting at `t0`: a sequence of phases."""

    t0: float
    phases: list[Phase] = field(default_factory=list)
    length: float = 0.0  # planned path length (INF for a continuous run)

    @property
    def end(self) -> float:
        return self.phases[-1].t1 if self.phases else self.t0

    def phase_at(self, t: float) -> Phase | None:
        for phase in self.phases:
            if t < phase.t1:
                return phase
        return self.phases[-1] if self.phases else None

    def s(self, t: float) -> float:
        if t <= self.t0 or not self.phases:
            return 0.0
        if t >= self.end:
            return self.length if self.length != INF else self.phases[-1].s(t)
        phase = self.phase_at(t)
        assert phase is not None
        return phase.s(t)

    def v(self, t: float) -> float:
        if not self.phases or t < self.t0 or t >= self.end:
            return 0.0
        phase = self.phase_at(t)
        assert phase is not None
        return phase.v(t)

    def time_at(self, target: float) -> float:
        """The first time the path reaches `target` (INF if it never does)."""
        if target <= 0:
            return self.t0
        for phase in self.phases:
            end = phase.s1
            if target <= end + 1e-9:
                return phase.time_at(target)
        return INF

    def cut(self, t: float) -> PathProfile:
        """The profile ended at time `t`: the motion stops there (at once)."""
        kept = []
        for phase in self.phases:
            if phase.t0 >= t:
                break
            duration = min(phase.duration, t - phase.t0)
            kept.append(Phase(phase.t0, duration, phase.s0, phase.v0, phase.a))
        length = kept[-1].s(kept[-1].t1) if kept else 0.0
        return PathProfile(self.t0, kept, length)


@dataclass(frozen=True)
class Segment:
    """A stretch of a planned run: its length (INF: run until stopped) and top speed."""

    length: float
    cap: float


def _ramp(v_from: float, v_to: float, rate: float) -> float:
    """Distance to change speed at `rate` (0 when instantaneous)."""
    if rate == INF:
        return 0.0
    return abs(v_to * v_to - v_from * v_from) / (2 * rate)


def _inverse(rate: float) -> float:
    return 0.0 if rate == INF else 1 / (2 * rate)


def plan(segments: list[Segment], t0: float, entry: float, exit_speed: float, accel: float,
         decel: float) -> tuple[PathProfile, list[float]]:
    """Plan one run over consecutive segments: speed up at `accel` from the start of a faster
    segment, slow down at `decel` so as to enter a slower segment at its top speed, and end at
    `exit_speed`. Returns the profile and the path length at the end of each segment."""
    chain: list[Segment] = []
    for segment in segments:
        chain.append(segment)
        if segment.length == INF:
            break  # nothing after a continuous segment is ever reached
    bounds: list[float] = []
    total = 0.0
    for segment in chain:
        total += segment.length
        bounds.append(total)
    count = len(chain)
    # backward pass: the highest speed allowed at the end of each segment
    limit = [0.0] * count
    limit[-1] = min(exit_speed, chain[-1].cap)
    for i in range(count - 2, -1, -1):
        nxt = chain[i + 1]
        reach = INF if nxt.length == INF or decel == INF else math.sqrt(
            limit[i + 1] ** 2 + 2 * decel * nxt.length)
        limit[i] = min(chain[i].cap, nxt.cap, reach)
    profile = PathProfile(t0, [], total)
    speed, s, t = entry, 0.0, t0
    for i, segment in enumerate(chain):
        if segment.length == INF:
            t, s, speed = _continuous(profile, t, s, speed, segment.cap, accel, decel)
            continue
        reach = INF if accel == INF else math.sqrt(speed * speed + 2 * accel * segment.length)
        exit_here = min(limit[i], reach)
        t, s, speed = _segment(profile, t, s, speed, exit_here, segment, accel, decel)
    return profile, bounds


def _add(profile: PathProfile, t: float, s: float, v_from: float, v_to: float,
         distance: float) -> tuple[float, float, float]:
    """Append a phase that goes `distance` while the speed changes from v_from to v_to."""
    if distance <= 0:
        return t, s, v_to
    mean = (v_from + v_to) / 2
    if mean <= 0:
        return t, s + distance, v_to
    duration = distance / mean
    accel = (v_to - v_from) / duration
    profile.phases.append(Phase(t, duration, s, v_from, accel))
    return t + duration, s + distance, v_to


def _segment(profile: PathProfile, t: float, s: float, entry: float, exit_speed: float,
             segment: Segment, accel: float, decel: float) -> tuple[float, float, float]:
    length, cap = segment.length, segment.cap
    if entry > cap:
        down = _ramp(entry, cap, decel)
        tail = _ramp(cap, exit_speed, decel)
        if down + tail <= length:
            t, s, _ = _add(profile, t, s, entry, cap, down)
            t, s, _ = _add(profile, t, s, cap, cap, length - down - tail)
            return _add(profile, t, s, cap, exit_speed, tail)
        straight = _ramp(entry, exit_speed, decel)
        if straight <= length:
            t, s, _ = _add(profile, t, s, entry, exit_speed, straight)
            return _add(profile, t, s, exit_speed, exit_speed, length - straight)
        return _add(profile, t, s, entry, exit_speed, length)  # brake harder to end on target
    up = _ramp(entry, cap, accel)
    down = _ramp(cap, exit_speed, decel)
    peak = cap
    if up + down > length:
        denominator = _inverse(accel) + _inverse(decel)
        if denominator == 0:
            peak = cap
        else:
            squared = (length + entry * entry * _inverse(accel) +
                       exit_speed * exit_speed * _inverse(decel)) / denominator
            peak = math.sqrt(max(squared, 0.0))
        if peak < max(entry, exit_speed):
            return _add(profile, t, s, entry, exit_speed, length)
        peak = min(peak, cap)
        up = _ramp(entry, peak, accel)
        down = max(length - up, 0.0)
        t, s, _ = _add(profile, t, s, entry, peak, up)
        return _add(profile, t, s, peak, exit_speed, down)
    t, s, _ = _add(profile, t, s, entry, cap, up)
    t, s, _ = _add(profile, t, s, cap, cap, length - up - down)
    return _add(profile, t, s, cap, exit_speed, down)


def _continuous(profile: PathProfile, t: float, s: float, entry: float, cap: float,
                accel: float, decel: float) -> tuple[float, float, float]:
    rate = accel if cap >= entry else decel
    t, s, _ = _add(profile, t, s, entry, cap, _ramp(entry, cap, rate))
    profile.phases.append(Phase(t, INF, s, cap, 0.0))
    profile.length = INF
    return INF, INF, cap


@dataclass
class Leg:
    """Motion of some axes from `t0` until `t_end`: position = start + unit * s(t). `unit`
    holds each moving axis's share of the path (+-1 for one axis; a direction cosine for
    a line); `targets` are the exact end positions of a leg that runs to its end."""

    profile: PathProfile
    start: tuple[float, ...]
    unit: dict[int, float]
    targets: dict[int, int] | None = None
    t_end: float = INF
    boundaries: list[float] = field(default_factory=list)  # times of step boundaries

    def __post_init__(self) -> None:
        if self.t_end == INF:
            self.t_end = self.profile.end

    @property
    def t0(self) -> float:
        return self.profile.t0

    def position(self, axis: int, t: float) -> float:
        base = self.start[axis]
        share = self.unit.get(axis)
        if share is None:
            return base
        if t >= self.t_end and self.targets is not None and self.t_end == self.profile.end:
            return float(self.targets[axis])
        return base + share * self.profile.s(min(t, self.t_end))

    def positions(self, t: float) -> tuple[float, ...]:
        return tuple(self.position(axis, t) for axis in range(len(self.start)))

    def speed(self, t: float) -> float:
        return self.profile.v(t) if t < self.t_end else 0.0

    def time_at_position(self, axis: int, position: float) -> float:
        """When the axis passes `position` in this leg (INF if it does not)."""
        share = self.unit.get(axis)
        if not share:
            return INF
        distance = (position - self.start[axis]) / share
        if distance < -1e-9:
            return INF
        when = self.profile.time_at(max(distance, 0.0))
        return when if when <= self.t_end + 1e-12 else INF

    def stop_at(self, t: float) -> None:
        """End the leg at `t` (EXT, ACT, a zero point, the end of the run)."""
        if t < self.t_end:
            self.profile = self.profile.cut(t)
            self.t_end = t
            self.targets = None


def round_half_up(value: float) -> int:
    return math.floor(value + 0.5)
