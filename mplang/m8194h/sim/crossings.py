"""Crossing times: when an axis of a running motion reaches a position.

The axis I/O needs the moment a limit switch, a sensor edge or a compare value is reached.
These times are solved on the closed-form profiles, never stepped: by bisection in time,
exact for straight paths; along curved paths (arcs, helix) a march over the path length in
steps of |distance| / Lipschitz bound first brackets the crossing, then bisection finds it.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from mplang.m8194h.sim.builders import _Motion
from mplang.m8194h.sim.paths import _LinePath

_INF = math.inf

_LIPSCHITZ = 2.0  # bound of |d axis position / d path length| for curved paths
_MAX_MARCH = 200_000


def _pos_at(m: _Motion, k: int, t: float) -> float:
    return m.path.pos(k, m.prof.state(t - m.t0)[0])


def _bisect_time(ok: Callable[[float], bool], lo: float, hi: float) -> float:
    """Smallest t in (lo, hi] with ok(t), given not ok(lo) and ok(hi) (monotone between)."""
    for _ in range(200):
        mid = (lo + hi) / 2.0
        if mid <= lo or mid >= hi:
            break
        if ok(mid):
            hi = mid
        else:
            lo = mid
    return hi


def _crossing(m: _Motion, k: int, level: float, rising: bool, t_from: float) -> float | None:
    """First time after `t_from` at which path axis k of motion m reaches `level` from the
    other side: rising means the position becomes >= level, falling that it becomes < level.
    """

    def ok(t: float) -> bool:
        x = _pos_at(m, k, t)
        return x >= level if rising else x < level

    if ok(t_from):
        if isinstance(m.path, _LinePath):
            return None
        return _march(m, k, level, rising, t_from, ok)
    if isinstance(m.path, _LinePath):
        slope = m.path.deriv(k, 0.0)
        if slope == 0.0 or (slope > 0.0) != rising:
            return None
        if m.end < _INF:
            return _bisect_time(ok, t_from, m.end) if ok(m.end) else None
        span = 1.0
        while not ok(t_from + span):
            span *= 2.0
            if span > 1e9:
                return None
        return _bisect_time(ok, t_from, t_from + span)
    return _march(m, k, level, rising, t_from, ok)


def _march(m: _Motion, k: int, level: float, rising: bool, t_from: float,
           ok: Callable[[float], bool]) -> float | None:
    """Crossing on a curved path: step along the path length by |distance| / Lipschitz
    bound (no crossing can hide in a step), then bisect the bracket in time."""
    s_end = m.prof.length if m.prof.length < _INF else m.prof.state(t_from - m.t0)[0] + 1e7
    s = m.prof.state(t_from - m.t0)[0]
    min_step = max(1e-2, (s_end - s) / _MAX_MARCH)

    def true_at(sv: float) -> bool:
        x = m.path.pos(k, sv)
        return x >= level if rising else x < level

    armed = not true_at(s)  # the crossing needs the false side first
    while s < s_end:
        step = max(abs(m.path.pos(k, s) - level) / _LIPSCHITZ, min_step)
        nxt = min(s + step, s_end)
        now_true = true_at(nxt)
        if not armed:
            armed = not now_true
        elif now_true:
            lo, hi = s, nxt
            for _ in range(100):
                mid = (lo + hi) / 2.0
                if mid <= lo or mid >= hi:
                    break
                if true_at(mid):
                    hi = mid
                else:
                    lo = mid
            return _time_of(m, hi, t_from, ok)
        s = nxt
    return None


def _time_of(m: _Motion, s_hi: float, t_from: float,
             ok: Callable[[float], bool]) -> float | None:
    """The time the motion passes path length s_hi, nudged until `ok` holds there."""
    t_end = m.end if m.end < _INF else t_from + 1e9

    def reached(t: float) -> bool:
        return m.prof.state(t - m.t0)[0] >= s_hi

    if not reached(t_end):
        return None
    t = _bisect_time(reached, t_from, t_end)
    for _ in range(60):
        if ok(t):
            return t
        t = math.nextafter(t, _INF) if t < t_end else t_end
    return t if ok(t) else None
