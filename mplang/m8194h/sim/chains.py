"""Continuous interpolation of the virtual M8194H (7.4.2-7.4.10): segments run back to back.

A `_Chain` collects the commanded segments (`_Seg`) of one continuous interpolation; laid
out one after the other into a `_ChainPath` they are driven by one profile
(`_chain_profile`), replanned whenever a segment comes in.  Which chain a segment joins, and
when a chain is closed, is decided by the model (`motion`).

Sources are the RS-M8194H manual (``/work/shared/manuals/001_404865bff90dda3e.txt``,
cited below as "manual line N"); where the manual is silent the choice is stated.

Conventions and simplifications
-------------------------------
* The segments of a continuous interpolation (relative ones from the exact end of the
  previous segment, ABS_ ones absolute) form one chain driven by one profile over the
  summed path length: one acceleration from VSV at the start, VV across every
  junction, and a deceleration to VSV only for the last segment (LINE nType 1,
  l.8335; MIX nAcc 1, l.8761) or after INTP_END.  The deceleration point is placed so
  the stop lands on the last point; it lies in an earlier segment when the last one is
  shorter than the braking distance (the manual calls it automatic for RECTANGLE,
  l.8192, and is silent for the other commands).  Constant-speed chains stop without
  decelerating (l.8761).  Corners are not smoothed: the direction changes at a
  junction at full speed (no look-ahead is described).
* The segments not reached yet count against the motion queue's bound (the model's
  ``queue_capacity``; no depth is given for continuous interpolation); a segment that
  arrives while its chain runs replans the profile from the present position and speed.
  A chain that runs out of segments before its last one stops at the end of those it
  has, at the speed it had: the device cannot brake for a segment it has not been sent.
  The 3-axis examples end that way, their closing calls having nType 0 (l.8601, l.8680).
  A last segment that comes too late to brake fully brakes at once (VA) and loses the
  remaining speed on the end point.
* A running chain forgets the segments it has finished (all but the one before the
  present one) whenever a segment comes in (`_ChainPath.forget`): nothing reads a motion
  before the present, and path lengths stay absolute, so a program that loops segments for
  ever keeps a bounded path and samples exactly what the whole path would give.
* MIX_2D_CONTINUE nType 1-5 (l.8762) are LINE_2D, ARC_CW/CCW and CIRCLE_CW/CCW with the
  arc conventions of `paths`; relative centres and end points count from the segment's
  start, ABS_ ones are absolute (l.8820).
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from mplang.m8194h.sim.builders import _Cmd, _Motion
from mplang.m8194h.sim.paths import _arc_path, _ChainPath, _LinePath, _Path
from mplang.m8194h.sim.profiles import _Plan, _Profile, _ramp

if TYPE_CHECKING:
    from mplang.m8194h.sim.motion import MotionModel


@dataclass(frozen=True)
class _Seg:
    """One commanded segment of a continuous interpolation, laid out when its start is known."""

    shape: str  # "line", "arc" or "circle"
    values: tuple[int, ...]  # line: end point; arc: centre then finish; circle: centre
    absolute: bool
    clockwise: bool = False


def _lay(seg: _Seg, start: tuple[int, ...],
         shift: tuple[int, ...]) -> tuple[_Path | None, float, tuple[int, ...]]:
    """(part, its length, exact end) of a segment from `start`, all in the path frame.

    `shift` is each axis's SET_LP correction, which absolute values are taken out of.
    A segment that does not move gives no part and ends where it starts."""

    def point(values: tuple[int, ...]) -> tuple[int, ...]:
        if seg.absolute:
            return tuple(v - d for v, d in zip(values, shift, strict=True))
        return tuple(p + v for p, v in zip(start, values, strict=True))

    if seg.shape == "line":
        end = point(seg.values)
        deltas = tuple(e - p for p, e in zip(start, end, strict=True))
        length = math.sqrt(sum(d * d for d in deltas))
        if length == 0.0:
            return None, 0.0, start
        return _LinePath(start, deltas, length), length, end
    cx, cy = point(seg.values[:2])
    fx, fy = point(seg.values[2:4]) if seg.shape == "arc" else start
    arc = _arc_path(start[0], start[1], cx, cy, fx, fy, seg.clockwise, seg.shape == "circle")
    if arc is None:
        return None, 0.0, start  # no circle through the start point: nothing moves
    return arc, arc.length, (fx, fy)


@dataclass
class _Chain:
    """A continuous interpolation (7.4.2-7.4.10): segments that run back to back.

    Segments commanded before the chain starts wait in `specs`; once it runs, each new
    segment is laid out at once and the profile is replanned from the present state."""

    axes: tuple[int, ...]
    plan: _Plan
    specs: list[_Seg] = field(default_factory=list)
    closed: bool = False  # the last segment is known: stop at its end
    cmd: _Cmd | None = None
    started: bool = False
    path: _ChainPath = field(default_factory=_ChainPath)
    end: tuple[int, ...] = ()  # exact end of the laid-out segments, path frame
    motion: _Motion | None = None


def _chain_profile(s: float, v: float, total: float, plan: _Plan, closed: bool) -> _Profile:
    """Profile from path length `s` at speed `v` up to `total`, T-curve or constant.

    An open chain accelerates towards the vector speed and keeps it to the end of the
    segments it has; a closed one plans its deceleration to the start speed at `total`,
    and if the distance is already too short it brakes at once and the speed left at
    `total` is lost there (the stop of a chain that ran out of segments)."""
    top = max(plan.v, 1.0)
    rem = total - s
    if rem <= 0.0:
        return _Profile(s, v)
    if plan.constant or plan.sv >= top:
        prof = _Profile(s, top)
        prof.add(rem / top, 0.0, 0.0)
    elif not closed:
        prof = _Profile(s, v)
        up = (top * top - v * v) / (2.0 * plan.acc) if v < top else 0.0
        if up >= rem:
            prof.add((math.sqrt(v * v + 2.0 * plan.acc * rem) - v) / plan.acc, plan.acc, 0.0)
        else:
            _ramp(prof, v, top, plan.acc, False)
            prof.add((rem - up) / max(top, v), 0.0, 0.0)
    else:
        prof = _Profile(s, v)
        acc, dec, sv = plan.acc, plan.dec, plan.sv
        brake = (v * v - sv * sv) / (2.0 * dec) if v > sv else 0.0
        if brake >= rem:
            prof.add((v - math.sqrt(max(v * v - 2.0 * dec * rem, 0.0))) / dec, -dec, 0.0)
        else:
            peak2 = (rem + v * v / (2.0 * acc) + sv * sv / (2.0 * dec)) / (
                1.0 / (2.0 * acc) + 1.0 / (2.0 * dec))
            peak = min(math.sqrt(peak2), top)
            up = abs(peak * peak - v * v) / (2.0 * acc)
            down = (peak * peak - sv * sv) / (2.0 * dec)
            _ramp(prof, v, peak, acc, False)
            prof.add((rem - up - down) / peak, 0.0, 0.0)
            _ramp(prof, peak, sv, dec, False)
    prof.length = total
    return prof


def _chain_backlog(chain: _Chain, now: float) -> int:
    """Segments of a continuous interpolation that its motion has not reached yet."""
    if not chain.started:
        return len(chain.specs)
    m = chain.motion
    if m is None:
        return 0
    s = m.prof.state(now - m.t0)[0]
    return len(chain.path.offsets) - bisect_right(chain.path.offsets, s)


def _reach_time(m: _Motion, s: float) -> float:
    """When motion `m` reaches path length `s` (its path length never decreases)."""
    lo, hi = 0.0, m.end - m.t0
    if hi == math.inf:
        hi = 1.0
        while m.prof.state(hi)[0] < s:
            hi *= 2.0
    for _ in range(60):
        mid = (lo + hi) / 2.0
        if m.prof.state(mid)[0] >= s:
            hi = mid
        else:
            lo = mid
    return m.t0 + hi


def _chain_builder(cid: int) -> Callable[[MotionModel, float], _Motion | None]:
    """Start chain `cid` (looked up in the model, so copies of the model stay separate)."""

    def build(model: MotionModel, t: float) -> _Motion | None:
        chain = model._chains[cid]
        chain.started = True
        chain.end = tuple(model._ax[i].pos for i in chain.axes)
        zero = (0,) * len(chain.axes)
        for seg in chain.specs:
            part, length, chain.end = _lay(seg, chain.end, zero)
            if part is not None:
                chain.path.add(part, length)
        chain.specs = []
        if chain.path.length == 0.0:
            return None
        plan = chain.plan
        v0 = plan.v if plan.constant else plan.sv
        prof = _chain_profile(0.0, v0, chain.path.length, plan, chain.closed)
        chain.motion = _Motion(chain.axes, t, prof, chain.path, chain.end, plan, True)
        return chain.motion

    return build
