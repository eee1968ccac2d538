"""Motion of the virtual CSIM: up to eight modules, trapezoid profiles along lines, arcs
given by centre and angle, helices, jogs, with the buffer and the blending of CM 1/CM 2.

Why not mplang/m8194h/sim/motion.py: that model is the M8194H's, in integer pulses with its speed
quantisation, four axes, arcs given by a finish point (no multi-turn arcs such as the
manual's `AA 50,150,-720`), start speeds and S-curves. The CSIM list describes none of that:
user units as reals, PR3 path speed with PR2 acceleration (CS 246-249), arcs by centre and
angle (CS 196), and blended paths (CS 223-227). This small model does exactly that, in
closed form: every motion is a profile of path length over time (pieces of constant
acceleration) on a path made of segments; nothing is stepped.

Semantics (the readings are in stdlib/csim/device.toml [motion]):
* A request runs when none of its modules is busy and no earlier request for one of them
  waits (the buffer, per module, in issue order).
* Trapezoid: accelerate at `accel` to `vmax`, cruise, decelerate at `accel` to a stop on the
  end point; short moves peak lower. A profile replanned from a running speed (blending, TVM)
  starts from that speed; if the remaining path is shorter than the braking distance it
  brakes harder so it still stops on the end point.
* Blending (CM 1, CM 2): a coordinated request on the same modules as the coordinated motion
  in progress or waiting last is appended to that motion's path and one profile is planned
  over the whole; corners are passed at path speed.
* The end of a motion snaps the modules exactly onto its end point.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field

INF = math.inf
Point = tuple[float, ...]


# ----------------------------------------------------------------------------- profiles


@dataclass
class Profile:
    """Path length over time from 0: pieces (start time, start s, start v, acceleration)."""

    pieces: list[tuple[float, float, float, float]]
    duration: float
    length: float

    def state(self, tau: float) -> tuple[float, float]:
        """(s, v) at time tau after the profile's start."""
        if tau >= self.duration:
            return self.length, 0.0
        if not self.pieces or tau <= 0:
            return 0.0, self.pieces[0][2] if self.pieces else 0.0
        start, s0, v0, a = self.pieces[0]
        for piece in self.pieces:
            if piece[0] <= tau:
                start, s0, v0, a = piece
            else:
                break
        dt = tau - start
        return s0 + v0 * dt + 0.5 * a * dt * dt, v0 + a * dt

    def time_at(self, s: float) -> float:
        """The first time the profile reaches path length s (bisection: s(t) never falls)."""
        if s <= 0:
            return 0.0
        if s >= self.length:
            return self.duration
        low, high = 0.0, self.duration
        for _ in range(60):
            mid = (low + high) / 2
            if self.state(mid)[0] < s:
                low = mid
            else:
                high = mid
        return high


def plan(v0: float, length: float, vmax: float, accel: float) -> Profile:
    """Trapezoid from speed v0 over `length` to a stop (see the module docstring)."""
    if length <= 0:
        return Profile([], 0.0, 0.0)
    stop = v0 * v0 / (2 * accel)
    if stop >= length and v0 > 0:
        a = v0 * v0 / (2 * length)
        return Profile([(0.0, 0.0, v0, -a)], v0 / a, length)
    if v0 <= vmax:
        peak = min(vmax, math.sqrt(accel * length + v0 * v0 / 2))
        t1 = (peak - v0) / accel
        d1 = (peak * peak - v0 * v0) / (2 * accel)
        a1 = accel
    else:
        peak = vmax
        t1 = (v0 - vmax) / accel
        d1 = (v0 * v0 - vmax * vmax) / (2 * accel)
        a1 = -accel
    d3 = peak * peak / (2 * accel)
    t3 = peak / accel
    d2 = max(0.0, length - d1 - d3)
    t2 = d2 / peak if peak > 0 else 0.0
    pieces = []
    if t1 > 0:
        pieces.append((0.0, 0.0, v0, a1))
    if t2 > 0:
        pieces.append((t1, d1, peak, 0.0))
    pieces.append((t1 + t2, d1 + d2, peak, -accel))
    return Profile(pieces, t1 + t2 + t3, length)


def plan_jog(v0: float, vmax: float, accel: float) -> Profile:
    """Ramp from v0 to vmax, then run at vmax for ever."""
    t1 = abs(vmax - v0) / accel
    d1 = abs(vmax * vmax - v0 * v0) / (2 * accel)
    pieces = [(0.0, 0.0, v0, accel if vmax >= v0 else -accel)] if t1 > 0 else []
    pieces.append((t1, d1, vmax, 0.0))
    return Profile(pieces, INF, INF)


def plan_brake(v0: float, accel: float) -> Profile:
    """Decelerate from v0 to a stop at `accel`."""
    if v0 <= 0:
        return Profile([], 0.0, 0.0)
    return Profile([(0.0, 0.0, v0, -accel)], v0 / accel, v0 * v0 / (2 * accel))


# -------------------------------------------------------------------------------- paths


class Segment(ABC):
    """A piece of path in the coordinates of a motion's modules, parametrised by length."""

    length: float
    shape: str

    @abstractmethod
    def point(self, s: float) -> Point: ...

    @abstractmethod
    def direction(self, at_end: bool) -> Point:
        """Unit tangent at the start or at the end (for CM 2's angle)."""

    @property
    def end(self) -> Point:
        return self.point(self.length)


class Line(Segment):
    def __init__(self, start: Point, target: Point) -> None:
        self.start = start
        self.target = target
        self.delta = tuple(t - s for s, t in zip(start, target, strict=True))
        self.length = math.sqrt(sum(d * d for d in self.delta))
        self.shape = f"line{len(start)}"

    def point(self, s: float) -> Point:
        if self.length == 0 or s >= self.length:
            return self.target
        k = s / self.length
        return tuple(a + d * k for a, d in zip(self.start, self.delta, strict=True))

    def direction(self, at_end: bool) -> Point:
        if self.length == 0:
            return tuple(0.0 for _ in self.start)
        return tuple(d / self.length for d in self.delta)


class Jog(Segment):
    """An unbounded straight run of one module."""

    def __init__(self, start: float, sign: int) -> None:
        self.start = start
        self.sign = sign
        self.length = INF
        self.shape = "jog"

    def point(self, s: float) -> Point:
        return (self.start + self.sign * s,)

    def direction(self, at_end: bool) -> Point:
        return (float(self.sign),)


class Arc(Segment):
    """Arc in the first two coordinates around a centre through `sweep` radians (positive =
    counter-clockwise), with an optional linear third coordinate (helix)."""

    def __init__(self, start: Point, centre: tuple[float, float], sweep: float,
                 z_target: float | None = None) -> None:
        self.start = start
        self.centre = centre
        self.sweep = sweep
        dx, dy = start[0] - centre[0], start[1] - centre[1]
        self.radius = math.hypot(dx, dy)
        self.angle0 = math.atan2(dy, dx)
        self.z0 = start[2] if z_target is not None else 0.0
        self.dz = (z_target - self.z0) if z_target is not None else 0.0
        self.helix = z_target is not None
        arc_length = self.radius * abs(sweep)
        self.length = math.hypot(arc_length, self.dz)
        self.shape = "helix" if self.helix else "arc2"
        self._end = self._compute(self.length)

    def _compute(self, s: float) -> Point:
        k = s / self.length if self.length > 0 else 1.0
        angle = self.angle0 + self.sweep * k
        x = self.centre[0] + self.radius * math.cos(angle)
        y = self.centre[1] + self.radius * math.sin(angle)
        if self.helix:
            return (x, y, self.z0 + self.dz * k)
        return (x, y)

    def point(self, s: float) -> Point:
        if s >= self.length:
            return self._end
        return self._compute(s)

    def direction(self, at_end: bool) -> Point:
        angle = self.angle0 + (self.sweep if at_end else 0.0)
        turn = 1.0 if self.sweep >= 0 else -1.0
        tangent = (-math.sin(angle) * turn, math.cos(angle) * turn)
        if self.helix:
            return (*tangent, 0.0)
        return tangent


# ------------------------------------------------------------------------------ motions


@dataclass
class Request:
    """A motion command as issued: its modules, its path (laid now, or by `lay` when it
    starts, if a module's position is not known in advance) and its speed."""

    modules: tuple[int, ...]
    coordinated: bool
    vmax: float
    accel: float
    segments: list[Segment] = field(default_factory=list)
    lay: Callable[[Point], Segment] | None = None
    jog: bool = False
    on_end: Callable[[], None] | None = None
    label: str = ""

    @property
    def end(self) -> Point | None:
        return self.segments[-1].end if self.segments and not self.jog else None


@dataclass
class Motion:
    request: Request
    t0: float
    base: float
    profile: Profile
    starts: list[float]
    total: float
    paused: bool = False  # TAPZ: braked to a stop, the rest of the path kept

    @property
    def modules(self) -> tuple[int, ...]:
        return self.request.modules

    @property
    def end_time(self) -> float:
        """When the motion ends (INF while paused: TAPZ keeps it until TAREDO/TAUPZ)."""
        return INF if self.paused else self.t0 + self.profile.duration

    def s_at(self, t: float) -> float:
        return self.base + self.profile.state(t - self.t0)[0]

    def v_at(self, t: float) -> float:
        return self.profile.state(t - self.t0)[1]

    def point(self, s: float) -> Point:
        segments = self.request.segments
        index = 0
        for i, start in enumerate(self.starts):
            if start <= s:
                index = i
        return segments[index].point(s - self.starts[index])

    def position(self, t: float) -> Point:
        return self.point(min(self.s_at(t), self.total))

    def replan(self, now: float, vmax: float | None = None) -> None:
        s, v = self.s_at(now), self.v_at(now)
        if vmax is not None:
            self.request.vmax = vmax
        self.t0, self.base = now, s
        if self.request.jog:
            self.profile = plan_jog(v, self.request.vmax, self.request.accel)
        else:
            self.profile = plan(v, self.total - s, self.request.vmax, self.request.accel)

    def segment_end_times(self) -> list[float]:
        """When the path passes each joint of its segments (for sampling the corners)."""
        times = []
        for start in self.starts[1:]:
            if start > self.base:
                times.append(self.t0 + self.profile.time_at(start - self.base))
        return times


class MotionError(Exception):
    """A motion the model cannot run (reported as a run error of the line that issued it)."""


class MotionModel:
    """The modules' positions and motions at a simulated time that only moves forward."""

    def __init__(self, modules: int) -> None:
        self.coords = [0.0] * modules
        self.planned: list[float | None] = [0.0] * modules
        self.active: list[Motion] = []
        self.queue: list[Request] = []
        self.last: dict[int, Request] = {}
        self.now = 0.0
        self.dispatch_paused = False  # PZ
        self.path_paused = False  # TAPZ
        self.finished_times: list[float] = []

    # --------------------------------------------------------------------- queries
    def module_motion(self, module: int) -> Motion | None:
        return next((m for m in self.active if module in m.modules), None)

    def position(self, module: int) -> float:
        motion = self.module_motion(module)
        if motion is None:
            return self.coords[module]
        return motion.position(self.now)[motion.modules.index(module)]

    def velocity(self, module: int) -> float:
        motion = self.module_motion(module)
        if motion is None or motion.paused:
            return 0.0
        return motion.v_at(self.now)  # the path speed for coordinated motions

    def busy(self, modules: tuple[int, ...] | None = None) -> bool:
        wanted = set(range(len(self.coords))) if modules is None else set(modules)
        return any(wanted & set(m.modules) for m in self.active) or any(
            wanted & set(r.modules) for r in self.queue)

    def moving(self) -> bool:
        """Something moves: a motion runs, or a paused one is still braking."""
        return any(not m.paused or self.now < m.t0 + m.profile.duration for m in self.active)

    def stop_times(self) -> list[float]:
        """When paused motions come to rest (for sampling the end of the brake)."""
        return [m.t0 + m.profile.duration for m in self.active if m.paused]

    def next_event(self) -> float:
        """The next time a motion ends (INF if none is due)."""
        ends = [m.end_time for m in self.active]
        return min(ends, default=INF)

    def planned_point(self, modules: tuple[int, ...]) -> Point | None:
        values = [self.planned[m] for m in modules]
        if any(v is None for v in values):
            return None
        return tuple(float(v) for v in values if v is not None)

    # --------------------------------------------------------------------- issuing
    def issue(self, request: Request, blend: Callable[[Request, Request], bool] | None = None
              ) -> None:
        """Queue a request; lay its path now if its start is known. With `blend`, a
        coordinated request may join the last motion of the same modules."""
        start = self.planned_point(request.modules)
        if not request.segments and request.lay is not None and start is not None:
            request.segments = [request.lay(start)]
            request.lay = None
        previous = self._last_of(request.modules)
        if (blend is not None and previous is not None and request.segments
                and previous.coordinated and request.coordinated and not previous.jog
                and previous.modules == request.modules and previous.segments
                and blend(previous, request)):
            self._append(previous, request)
            return
        self.queue.append(request)
        for module in request.modules:
            self.last[module] = request
        self._note_planned(request)
        self._dispatch(self.now)

    def _last_of(self, modules: tuple[int, ...]) -> Request | None:
        found = {id(self.last[m]): self.last[m] for m in modules if m in self.last}
        if len(found) != 1:
            return None
        request = next(iter(found.values()))
        if request.modules != modules:
            return None
        live = any(request is m.request for m in self.active) or request in self.queue
        return request if live else None

    def _append(self, previous: Request, request: Request) -> None:
        previous.segments.extend(request.segments)
        previous.label = f"{previous.label}+{request.label}" if previous.label else request.label
        self._note_planned(previous)
        motion = next((m for m in self.active if m.request is previous), None)
        if motion is not None:
            motion.total = sum(s.length for s in previous.segments)
            motion.starts = _starts(previous.segments)
            if not motion.paused:
                motion.replan(self.now)

    def _note_planned(self, request: Request) -> None:
        end = request.end
        for i, module in enumerate(request.modules):
            self.planned[module] = None if end is None else end[i]

    def set_position(self, module: int, value: float) -> None:
        """CS x: the present position takes a new coordinate (the module must be idle)."""
        if self.busy((module,)):
            raise MotionError(f"T{module} is moving: CS needs a module at rest")
        self.coords[module] = value
        self.planned[module] = value

    # ------------------------------------------------------------------ time passing
    def advance(self, to: float) -> None:
        """Let time run to `to`: finish motions that end, start what waits for them."""
        while True:
            due = self.next_event()
            if due > to:
                break
            motion = min(self.active, key=lambda m: m.end_time)
            self._finish(motion, due)
            self._dispatch(due)
        self.now = max(self.now, to)
        self._dispatch(self.now)

    def _finish(self, motion: Motion, at: float) -> None:
        self.active.remove(motion)
        end = motion.point(motion.total)
        for i, module in enumerate(motion.modules):
            self.coords[module] = end[i]
            if self.last.get(module) is motion.request:
                self.planned[module] = end[i]
        self.finished_times.append(at)
        if motion.request.on_end is not None:
            motion.request.on_end()

    def _dispatch(self, at: float) -> None:
        if self.dispatch_paused or self.path_paused:
            return
        blocked: set[int] = {m for motion in self.active for m in motion.modules}
        for request in list(self.queue):
            if blocked & set(request.modules):
                blocked |= set(request.modules)
                continue
            self.queue.remove(request)
            if self._start(request, at):
                blocked |= set(request.modules)

    def _start(self, request: Request, at: float) -> bool:
        """Start a request; False if it was over at once (a move of length 0)."""
        if not request.segments:
            assert request.lay is not None
            start = tuple(self.coords[m] for m in request.modules)
            request.segments = [request.lay(start)]
            request.lay = None
            if all(self.last.get(m) is request for m in request.modules):
                self._note_planned(request)
        starts = _starts(request.segments)
        total = INF if request.jog else sum(s.length for s in request.segments)
        if request.jog:
            profile = plan_jog(0.0, request.vmax, request.accel)
        else:
            profile = plan(0.0, total, request.vmax, request.accel)
        motion = Motion(request, at, 0.0, profile, starts, total)
        self.active.append(motion)
        if profile.duration == 0 and not request.jog:
            self._finish(motion, at)
            return False
        return True

    # ------------------------------------------------------------------- commands
    def stop_jog(self, module: int) -> None:
        """JG0: a jog (or a single-module move) of the module decelerates to a stop."""
        motion = self.module_motion(module)
        if motion is None or motion.request.coordinated:
            return
        s, v = motion.s_at(self.now), motion.v_at(self.now)
        motion.request.jog = False
        motion.t0, motion.base = self.now, s
        motion.profile = plan_brake(v, motion.request.accel)
        motion.total = s + motion.profile.length
        if motion.total == INF:
            motion.total = s
        point = motion.point(motion.total)
        for i, m in enumerate(motion.modules):
            if self.last.get(m) is motion.request:
                self.planned[m] = point[i]

    def set_coordinated_speed(self, vmax: float) -> None:
        """TVM: the new path speed applies at once to coordinated motions in progress and to
        the coordinated requests waiting."""
        for motion in self.active:
            if motion.request.coordinated and not motion.paused:
                motion.replan(self.now, vmax)
            elif motion.request.coordinated:
                motion.request.vmax = vmax
        for request in self.queue:
            if request.coordinated:
                request.vmax = vmax

    def pause_path(self) -> None:
        """TAPZ: every motion brakes on its path and waits, paused."""
        self.path_paused = True
        for motion in self.active:
            if motion.paused:
                continue
            s, v = motion.s_at(self.now), motion.v_at(self.now)
            motion.t0, motion.base = self.now, s
            brake = plan_brake(v, motion.request.accel)
            remaining = motion.total - s
            if brake.length > remaining:
                brake = plan(v, remaining, max(v, 1e-9), motion.request.accel)
            motion.profile = brake
            motion.paused = True

    def resume_path(self) -> None:
        """TAREDO: the paused motions go on along their paths."""
        self.path_paused = False
        for motion in self.active:
            if motion.paused:
                s = motion.s_at(self.now)
                motion.paused = False
                motion.t0, motion.base = self.now, s
                if motion.request.jog:
                    motion.profile = plan_jog(0.0, motion.request.vmax, motion.request.accel)
                else:
                    motion.profile = plan(0.0, motion.total - s, motion.request.vmax,
                                          motion.request.accel)
        self._dispatch(self.now)

    def drop_paused(self) -> None:
        """TAUPZ: leave the pause, dropping the interrupted motions and the buffer."""
        self.path_paused = False
        self._halt_all()

    def emergency_stop(self) -> None:
        """TASTOP: every module stops where it is; the buffer is dropped."""
        self.path_paused = False
        self._halt_all()

    def _halt_all(self) -> None:
        for motion in list(self.active):
            here = motion.position(self.now)
            self.active.remove(motion)
            for i, module in enumerate(motion.modules):
                self.coords[module] = here[i]
                self.planned[module] = here[i]
        for request in self.queue:
            for module in request.modules:
                self.planned[module] = self.coords[module]
        self.queue.clear()
        self.last.clear()

    def clear_buffer(self) -> None:
        """CLR BUF: requests that have not started are dropped."""
        for request in self.queue:
            for module in request.modules:
                if self.last.get(module) is request:
                    del self.last[module]
        self.queue.clear()
        for module in range(len(self.coords)):
            motion = self.module_motion(module)
            if motion is None:
                self.planned[module] = self.coords[module]
            elif not motion.request.jog:
                self.planned[module] = motion.point(motion.total)[motion.modules.index(module)]
                self.last[module] = motion.request


def _starts(segments: list[Segment]) -> list[float]:
    starts, total = [], 0.0
    for segment in segments:
        starts.append(total)
        total += segment.length
    return starts


def angle_between(a: Point, b: Point) -> float:
    """Angle in degrees between two directions (0 when either is a null vector)."""
    na = math.sqrt(sum(x * x for x in a))
    nb = math.sqrt(sum(x * x for x in b))
    if na == 0 or nb == 0:
        return 0.0
    cos = sum(x * y for x, y in zip(a, b, strict=True)) / (na * nb)
    return math.degrees(math.acos(max(-1.0, min(1.0, cos))))
