"""Motions of the virtual M8194H and the builders that start them.

A `_Motion` is one running drive: a speed profile (`profiles`) started at ``t0`` along a
path (`paths`) on some axes, with the exact integer end positions it snaps to.  A `_Cmd` is
a motion command as the model queues it: its axes and a builder that lays the motion out
from the axes' positions at the moment it starts (a relative move only knows its start
then).  The builder of a continuous-interpolation chain is in `chains`.

Sources are the RS-M8194H manual (``/work/shared/manuals/001_404865bff90dda3e.txt``,
cited below as "manual line N"); where the manual is silent the choice is stated.

Conventions and simplifications
-------------------------------
* Arcs: relative commands give the centre and the finish point relative to the start
  (l.6650-6653); the ABS_ variants give both absolutely (l.6835ff).  The arc itself
  (sense, full circles, radius blending) is described in `paths`.
* RECTANGLE (7.4.1): the figure defining Sp0-Sp7 is not in the text (l.8206, nor in
  the ET manual).  Choice: Lp and Wp are the outer extents along axis 1 and axis 2
  (the ET manual calls them the travel of each axis), Rp the radius of the four corner
  arcs, cut to min(Lp // 2, Wp // 2) so straight sides are Lp - 2r and Wp - 2r long.
  Sp0-Sp7 are the eight points where a side meets an arc, counter-clockwise from the
  left end of the lower side: in the rectangle's frame (r, 0), (Lp-r, 0), (Lp, r),
  (Lp, Wp-r), (Lp-r, Wp), (r, Wp), (0, Wp-r), (0, r).  The present position is point
  Sp; one lap runs in the direction nDir (0 CCW, 1 CW, l.8207) back to it.  nAcc 0 is
  constant RV; nAcc 1 a T-curve RSV -> RV at RA, decelerating at RD (l.8205, l.8214)
  with the point computed over the whole lap (l.8192).  RECTANGLE leaves AXIS_ASSIGN
  and the vector settings alone.
* HELIX_3D (7.4.11): the centre is relative to the start, as CIRCLE_CW's (l.6897; the
  text only says "the value of center", l.8880, and the examples start from 0, where
  both readings agree).  nDir 0 is CW, 1 CCW (l.8878, the reverse of RECTANGLE).  The
  circle turns |cycle| times while axis 3 moves cycle * pitch in proportion to the
  angle (l.8882-8883), so a negative cycle reverses axis 3, not the rotation.  VV is
  the constant 3-D vector speed, without ramps (only VV is given); the firmware's
  "software macro-function" (l.8864) is not modelled.  A zero radius moves axis 3 only.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from mplang.m8194h.sim.paths import (
    _arc_path,
    _ArcPath,
    _ChainPath,
    _HelixPath,
    _LinePath,
    _Path,
    _rectangle_parts,
)
from mplang.m8194h.sim.profiles import _Plan, _point_to_point, _Profile, _ramp

if TYPE_CHECKING:
    from mplang.m8194h.sim.motion import MotionModel

_INF = math.inf
_TWO_PI = 2.0 * math.pi


@dataclass
class _Motion:
    axes: tuple[int, ...]
    t0: float
    prof: _Profile
    path: _Path
    final: tuple[int, ...]  # exact end positions in the path frame
    plan: _Plan
    vector: bool
    direction: int = 0  # single-axis continuous moves: +1 / -1
    end: float = field(init=False)

    def __init__(self, axes: tuple[int, ...], t0: float, prof: _Profile, path: _Path,
                 final: tuple[int, ...], plan: _Plan, vector: bool, direction: int = 0) -> None:
        """The generated `__init__` and a `__post_init__` for `end`, in one call (every
        move makes one)."""
        self.axes = axes
        self.t0 = t0
        self.prof = prof
        self.path = path
        self.final = final
        self.plan = plan
        self.vector = vector
        self.direction = direction
        self.end = t0 + prof.duration

    @property
    def continuous(self) -> bool:
        return self.end == _INF


@dataclass
class _Cmd:
    axes: tuple[int, ...]
    vector: bool
    build: Callable[[MotionModel, float], _Motion | None]
    # the motion a run ahead built (`MotionModel._drain`): its start time, the positions of
    # the axes it read, and what `build` gave; `MotionModel._start` takes it at that time
    # from those positions (every builder but a chain's reads nothing else)
    built: tuple[float, tuple[int, ...], _Motion | None] | None

    def __init__(self, axes: tuple[int, ...], vector: bool,
                 build: Callable[[MotionModel, float], _Motion | None]) -> None:
        """As the generated one, written out: every motion command makes one."""
        self.axes = axes
        self.vector = vector
        self.build = build
        self.built = None


class QueueFull(Exception):
    """The motion queue holds `queue_capacity` waiting commands: the new one is not taken
    (the interpreter waits and runs the line again, `room_at` says when to look again).
    `chain`: it was a segment for the open continuous interpolation's backlog; `needed`:
    the queue entries the command needs (one per axis of a FIXED_MOVE)."""

    def __init__(self, chain: bool = False, needed: int = 1) -> None:
        super().__init__("the motion queue is full")
        self.chain = chain
        self.needed = needed


# ------------------------------------------------------------------ command builders


def _single_cmd(i: int, value: int, absolute: bool, plan: _Plan) -> _Cmd:
    def build(model: MotionModel, t: float) -> _Motion | None:
        start = model._ax[i].pos
        target = value if absolute else start + value
        if target == start:
            return None
        sign = 1 if target > start else -1
        prof = _point_to_point(float(abs(target - start)), plan)
        return _Motion((i,), t, prof, _LinePath((start,), (sign,), 1.0), (target,), plan, False)

    return _Cmd((i,), False, build)


def _continuous_builder(i: int, direction: int,
                        plan: _Plan) -> Callable[[MotionModel, float], _Motion | None]:
    def build(model: MotionModel, t: float) -> _Motion | None:
        prof = _Profile(0.0, plan.sv)
        _ramp(prof, plan.sv, plan.v, plan.acc, plan.s_curve)
        prof.forever()
        path = _LinePath((model._ax[i].pos,), (direction,), 1.0)
        return _Motion((i,), t, prof, path, (), plan, False, direction)

    return build


def _line_builder(axes: tuple[int, ...], values: tuple[int, ...], absolute: bool,
                  plan: _Plan) -> Callable[[MotionModel, float], _Motion | None]:
    def build(model: MotionModel, t: float) -> _Motion | None:
        # (lists, not generators: every LINE_2D / LINE_3D builds one)
        starts = tuple([model._ax[i].pos for i in axes])
        targets = values if absolute else \
            tuple([s + d for s, d in zip(starts, values, strict=True)])
        deltas = tuple([e - s for s, e in zip(starts, targets, strict=True)])
        length = math.sqrt(sum([d * d for d in deltas]))
        if length == 0.0:
            return None
        prof = _point_to_point(length, plan)
        return _Motion(axes, t, prof, _LinePath(starts, deltas, length), targets, plan, True)

    return build


def _arc_builder(axes: tuple[int, ...], center: tuple[int, int], finish: tuple[int, int],
                 clockwise: bool, absolute: bool, full: bool,
                 plan: _Plan) -> Callable[[MotionModel, float], _Motion | None]:
    def build(model: MotionModel, t: float) -> _Motion | None:
        x0, y0 = model._ax[axes[0]].pos, model._ax[axes[1]].pos
        if absolute:
            cx, cy = center
            fx, fy = finish
        else:
            cx, cy = x0 + center[0], y0 + center[1]
            fx, fy = (x0, y0) if full else (x0 + finish[0], y0 + finish[1])
        path = _arc_path(x0, y0, cx, cy, fx, fy, clockwise, full)
        if path is None:
            return None  # no circle through the start point: nothing moves
        prof = _point_to_point(path.length, plan)
        return _Motion(axes, t, prof, path, (fx, fy), plan, True)

    return build


def _rectangle_builder(axes: tuple[int, ...], sp: int, clockwise: bool, lp: int, wp: int,
                       r: int, plan: _Plan) -> Callable[[MotionModel, float], _Motion | None]:
    def build(model: MotionModel, t: float) -> _Motion | None:
        x0, y0 = model._ax[axes[0]].pos, model._ax[axes[1]].pos
        path = _ChainPath()
        for part, length in _rectangle_parts(x0, y0, sp, clockwise, lp, wp, r):
            path.add(part, length)
        prof = _point_to_point(path.length, plan)
        return _Motion(axes, t, prof, path, (x0, y0), plan, True)

    return build


def _helix_builder(axes: tuple[int, ...], center: tuple[int, int], clockwise: bool,
                   cycle: int, pitch: int,
                   plan: _Plan) -> Callable[[MotionModel, float], _Motion | None]:
    def build(model: MotionModel, t: float) -> _Motion | None:
        x0, y0, z0 = (model._ax[i].pos for i in axes)
        cx, cy = x0 + center[0], y0 + center[1]
        radius = math.hypot(x0 - cx, y0 - cy)
        dz = cycle * pitch
        path: _Path
        if radius == 0.0 or cycle == 0:
            if dz == 0:
                return None
            length = float(abs(dz))
            path = _LinePath((x0, y0, z0), (0, 0, dz), length)
        else:
            sweep = _TWO_PI * abs(cycle)
            circle = _ArcPath(cx, cy, radius, radius, math.atan2(y0 - cy, x0 - cx),
                              -sweep if clockwise else sweep)
            helix = _HelixPath(circle, z0, dz)
            path, length = helix, helix.length
        prof = _point_to_point(length, plan)
        return _Motion(axes, t, prof, path, (x0, y0, z0 + dz), plan, True)

    return build
