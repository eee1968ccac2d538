"""Speed plans and profiles of the virtual M8194H.

An axis's speed settings (`_AxisSettings`) give the `_Plan` a command latches when it is
issued; a plan and a distance give a `_Profile`: the path length ``s(t)`` of one motion, a
chain of constant-jerk pieces (a piecewise cubic in time) evaluated in closed form.  The
motion model (`motion`) and the home search (`homing`) both plan with these, so they sit
below both.

Units: positions in pulses (``int``), speeds in pulses/s, accelerations in pulses/s²,
jerks in pulses/s³, time in seconds (``float``).

Sources are the RS-M8194H manual (``/work/shared/manuals/001_404865bff90dda3e.txt``,
cited below as "manual line N"); where the manual is silent the choice is stated.

Conventions and simplifications
-------------------------------
* Chip values (`mplang.m8194h.chipvalues`, the profile's ``[chip_values]``): when a
  motion starts, its speeds (SV, V, VSV, VV, HV, the CONTINUE_MOVE speed ...) are clamped
  to MAX_V and rounded to a multiple of ``MAX_V / 8000`` (manual l.1146), its
  accelerations (A, D, VA, VD, RA, RD) are multiples of ``MAX_V / 64`` within MAX_V/64 ..
  MAX_V*125 (l.5157) and its jerks (K, L, VK, VL) at least MAX_V*0.0119211 (l.5257).
  The power-on MAX_V is 200 000 PPS (factory table, manual l.9705): steps of 25 PPS and
  3125 PPS/s.
* A start speed above the drive speed means a constant-speed move at the drive
  speed (as in the CONTINUE_MOVE example, manual l.5679-5681: SV 2000, speed 1000).
* T-curve (NORMAL_SPEED 0/2, manual l.4934): SV → V at A, cruise, V → SV at D
  (mode 0 uses A for both ramps), then the move ends.  When the distance is too short
  the profile is a triangle whose peak ``vp`` solves
  ``(vp²-SV²)/2A + (vp²-SV²)/2D = distance``.
* S-curve (modes 1/3): each ramp is a pure jerk-limited "parabolic S": the
  acceleration rises linearly at K to its peak and falls back to zero at -K (no
  constant-acceleration stretch, since modes 1/3 take no A/D), so a ramp by ``dv``
  lasts ``2*sqrt(dv/K)`` and covers ``(v0+v1)*sqrt(dv/K)``.  The deceleration ramp
  uses L (mode 3) or K (mode 1).  Short moves lower the peak speed so that the
  two ramps exactly cover the distance (closed-form cubic, Newton-polished).
* Offset pulses AO / VAO (7.1.8, l.5351; l.6369; power-on 8): a fixed move (single axis
  or interpolation) plans its ramps over the distance less the offset and runs the offset
  pulses at the start speed after the deceleration, "compensation [of] the pulses when the
  deceleration speed does not reach the initial speed" (l.5351); the move still ends
  exactly on its target.  A negative offset (which would cut the deceleration short) and
  offsets in continuous-interpolation chains are not applied.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Callable
from dataclasses import dataclass

from mplang.m8194h.chipvalues import DEFAULT_MAX_V, ChipRules

# The profile each vector speed mode (SET_VECTOR_SPEED_MODE / continuous interpolation's mode)
# drives: constant, symmetric or asymmetric T-curve, symmetric or asymmetric S-curve.
VECTOR_KIND = {
    0: "const", 7: "const",
    1: "symT", 5: "symT", 8: "symT",
    2: "symS", 9: "symS",
    3: "asymT", 6: "asymT", 10: "asymT",
    4: "asymS", 11: "asymS",
}

_INF = math.inf


@dataclass
class _AxisSettings:
    max_v: int = DEFAULT_MAX_V
    mode: int = 0
    sv: int = 1000
    v: int = 10000
    a: int = 100_000
    d: int = 100_000
    k: int = 1_000_000
    l: int = 1_000_000  # noqa: E741 - the manual's name
    ao: int = 8  # power-on value, manual l.5351


class _Profile:
    """Path length s(tau) for tau >= 0, a chain of constant-jerk pieces."""

    __slots__ = ("_p", "_v", "duration", "length", "segs", "starts")

    def __init__(self, s0: float, v0: float) -> None:
        self.starts: list[float] = []
        self.segs: list[tuple[float, float, float, float]] = []
        self.duration = 0.0
        self.length = s0
        self._p = s0
        self._v = v0

    def add(self, dur: float, a0: float, jerk: float) -> None:
        if dur <= 0.0:
            return
        self.starts.append(self.duration)
        self.segs.append((self._p, self._v, a0, jerk))
        self._p += self._v * dur + a0 * dur * dur / 2.0 + jerk * dur**3 / 6.0
        self._v += a0 * dur + jerk * dur * dur / 2.0
        self.duration += dur

    def forever(self) -> None:
        """Cruise at the present speed without end."""
        self.starts.append(self.duration)
        self.segs.append((self._p, self._v, 0.0, 0.0))
        self.duration = _INF
        self.length = _INF

    def state(self, tau: float) -> tuple[float, float, float]:
        """(s, ds/dt, d2s/dt2) at tau seconds after the start."""
        if tau >= self.duration or not self.segs:
            return self.length, 0.0, 0.0
        i = bisect_right(self.starts, tau) - 1
        if i < 0:
            i = 0
        dt = tau - self.starts[i]
        if dt < 0.0:
            dt = 0.0
        p, v, a, j = self.segs[i]
        s = p + v * dt + a * dt * dt / 2.0 + j * dt**3 / 6.0
        if s > self.length:
            s = self.length
        return s, v + a * dt + j * dt * dt / 2.0, a + j * dt


def _ramp(prof: _Profile, v0: float, v1: float, rate: float, s_curve: bool) -> None:
    """Append a speed change v0 -> v1 (rate = acceleration, or jerk for S-curves)."""
    dv = v1 - v0
    if dv == 0.0:
        return
    sign = 1.0 if dv > 0 else -1.0
    if s_curve:
        half = math.sqrt(abs(dv) / rate)
        prof.add(half, 0.0, sign * rate)
        prof.add(half, sign * rate * half, -sign * rate)
    else:
        prof.add(abs(dv) / rate, sign * rate, 0.0)


def _ramp_dist(v0: float, v1: float, rate: float, s_curve: bool) -> float:
    if s_curve:
        return (v0 + v1) * math.sqrt(abs(v1 - v0) / rate)
    return abs(v1 * v1 - v0 * v0) / (2.0 * rate)


@dataclass(frozen=True)
class _Plan:
    """Speed parameters latched when a command is issued."""

    sv: float
    v: float
    acc: float  # acceleration, or jerk for S-curves
    dec: float
    s_curve: bool
    constant: bool = False
    offset: float = 0.0  # AO / VAO: pulses kept back from the deceleration, run at SV


CHANGE_ONLY = True
"""Plan on change only: share the profile of a (distance, plan) pair between the moves that
ask for it and keep the plan of unchanged settings (a job repeats its moves, and a profile is
never altered once built), keep `AxisIO._calm` until a setting it reads changes, and let the
interpreter run on after a motion command when no event can come of it. Tests switch it off
to compare with planning everything afresh (tests/m8194h/sim/test_planning.py)."""

_MEMO_LIMIT = 4096  # distinct (distance, plan) pairs kept; a program with more starts over
_P2P: dict[tuple[float, int], tuple[_Plan, _Profile]] = {}
"""Profiles by distance and plan object (the plans of equal settings are one object,
`_kept_plan`). An entry holds its plan, so no other object can have that plan's id while
the entry is there: a hit is the very plan, found without hashing its seven fields."""


def _point_to_point(dist: float, plan: _Plan) -> _Profile:
    """Profile covering exactly `dist` pulses of path, starting and ending at SV (memoised,
    see `CHANGE_ONLY`: the caller must not alter it)."""
    if not CHANGE_ONLY:
        return _plan_point_to_point(dist, plan)
    key = (dist, id(plan))
    kept = _P2P.get(key)
    if kept is None:
        if len(_P2P) >= _MEMO_LIMIT:
            _P2P.clear()
        kept = _P2P[key] = (plan, _plan_point_to_point(dist, plan))
    return kept[1]


def _plan_point_to_point(dist: float, plan: _Plan) -> _Profile:
    """`_point_to_point` computed afresh."""
    v = max(plan.v, 1.0)
    sv = min(plan.sv, v)
    prof = _Profile(0.0, sv)
    if dist <= 0.0:
        return prof
    if plan.constant or sv >= v:
        prof = _Profile(0.0, v)
        prof.add(dist / v, 0.0, 0.0)
        prof.length = dist
        return prof
    creep = min(plan.offset, dist) if plan.offset > 0.0 and sv > 0.0 else 0.0
    if creep:
        prof = _plan_point_to_point(dist - creep,
                                    _Plan(sv, v, plan.acc, plan.dec, plan.s_curve))
        prof.add(creep / sv, 0.0, 0.0)
        prof.length = dist
        return prof
    acc, dec, sc = plan.acc, plan.dec, plan.s_curve
    need = _ramp_dist(sv, v, acc, sc) + _ramp_dist(v, sv, dec, sc)
    if need <= dist:
        peak = v
        cruise = (dist - need) / v
    else:
        cruise = 0.0
        if sc:
            # (2 sv + w^2) w c = dist with w^2 = peak - sv, c = 1/sqrt(K) + 1/sqrt(L)
            c = 1.0 / math.sqrt(acc) + 1.0 / math.sqrt(dec)
            q = dist / c
            p = 2.0 * sv
            w = q ** (1.0 / 3.0)
            if p > 0.0:
                w = min(w, q / p)  # both are upper bounds of the root
            for _ in range(60):  # Newton from above converges monotonically
                f = w * w * w + p * w - q
                step = f / (3.0 * w * w + p) if w > 0.0 or p > 0.0 else 0.0
                w -= step
                if abs(step) <= 1e-15 * max(1.0, w):
                    break
            peak = sv + w * w
        else:
            peak = math.sqrt(sv * sv + 2.0 * dist * acc * dec / (acc + dec))
    _ramp(prof, sv, peak, acc, sc)
    prof.add(cruise, 0.0, 0.0)
    _ramp(prof, peak, sv, dec, sc)
    prof.length = dist
    return prof


def _single_plan(st: _AxisSettings, rules: ChipRules) -> _Plan:
    """The plan of a single-axis drive, with the values the chip holds for its settings."""
    top = st.max_v
    v = rules.speed(st.v, top)
    sv = rules.speed(st.sv, top)
    mode = st.mode
    if mode in (1, 3):
        return _Plan(sv, v, rules.jerk(st.k, top), rules.jerk(st.l if mode == 3 else st.k, top),
                     True, offset=float(st.ao))
    return _Plan(sv, v, rules.acceleration(st.a, top),
                 rules.acceleration(st.d if mode == 2 else st.a, top), False,
                 offset=float(st.ao))


@dataclass
class _VectorSettings:
    mode: int = 0
    vsv: int = 1000
    vv: int = 10000
    va: int = 100_000
    vd: int = 100_000
    vk: int = 1_000_000
    vl: int = 1_000_000
    vao: int = 8


def _vector_plan(vs: _VectorSettings, max_v: int, rules: ChipRules) -> _Plan:
    """The vector plan, with the values the chip holds for `max_v` (that of axis 1)."""
    v = rules.speed(vs.vv, max_v)
    sv = rules.speed(vs.vsv, max_v)
    kind = VECTOR_KIND[vs.mode]
    if kind == "const":
        return _Plan(v, v, 1.0, 1.0, False, constant=True)
    offset = float(vs.vao)
    va, vd = rules.acceleration(vs.va, max_v), rules.acceleration(vs.vd, max_v)
    vk, vl = rules.jerk(vs.vk, max_v), rules.jerk(vs.vl, max_v)
    if kind == "symT":
        return _Plan(sv, v, va, va, False, offset=offset)
    if kind == "asymT":
        return _Plan(sv, v, va, vd, False, offset=offset)
    if kind == "symS":
        return _Plan(sv, v, vk, vk, True, offset=offset)
    return _Plan(sv, v, vk, vl, True, offset=offset)


_PLANS: dict[ChipRules, dict[tuple[object, ...], _Plan]] = {}
_RULES_LIMIT = 16  # distinct chip rules whose plans are kept


def _plans_for(rules: ChipRules) -> dict[tuple[object, ...], _Plan]:
    """The kept plans of models with these chip rules: shared, so that equal settings give
    the very same plan and its profiles are found by identity."""
    plans = _PLANS.setdefault(rules, {})
    if len(_PLANS) > _RULES_LIMIT:
        _PLANS.clear()
        _PLANS[rules] = plans
    return plans


def _kept_plan(plans: dict[tuple[object, ...], _Plan], key: tuple[object, ...],
               make: Callable[[], _Plan]) -> _Plan:
    """The plan of settings `key`, made the first time and then kept (`CHANGE_ONLY`; at most
    `_MEMO_LIMIT` of them, then it starts over)."""
    if not CHANGE_ONLY:
        return make()
    plan = plans.get(key)
    if plan is None:
        if len(plans) >= _MEMO_LIMIT:
            plans.clear()
        plan = plans[key] = make()
    return plan


def _bisect(lo: float, hi: float, ok: Callable[[float], bool]) -> float:
    """The largest x in [lo, hi] with ok(x), for ok true at lo and monotone (true, then false)."""
    for _ in range(60):
        mid = (lo + hi) / 2.0
        if ok(mid):
            lo = mid
        else:
            hi = mid
    return lo


def _retarget(s0: float, v0: float, length: float, plan: _Plan) -> _Profile:
    """A running fixed move replanned from path length `s0` at speed `v0` to end at
    `length` (SET_PULSE's new total, or CHANGE_VEL_ON_FLY's new speed in `plan`): ramp to
    the plan's speed (up at its acceleration, down at its deceleration), cruise, decelerate
    to SV and run the offset pulses, as `_point_to_point` plans a move from rest. When the
    rest is too short for a full deceleration the drive brakes at once and ends on the
    target with the speed it has left: the chip stops when its pulse count is reached.
    S-curve ramps start from zero acceleration (the simplification STOP_SLOWLY makes)."""
    prof = _Profile(s0, v0)
    dist = length - s0
    top = max(plan.v, 1.0)
    sv = min(plan.sv, top)
    if dist <= 0.0:
        prof.length = s0
        return prof
    if plan.constant or sv >= top:
        prof.add(dist / top, 0.0, 0.0)
        prof.length = length
        return prof
    acc, dec, sc = plan.acc, plan.dec, plan.s_curve
    creep = min(plan.offset, dist) if plan.offset > 0.0 and sv > 0.0 else 0.0
    brake = _ramp_dist(v0, sv, dec, sc) if v0 > sv else 0.0
    if brake >= dist:  # cannot reach SV: brake from now, end with the speed left
        end = _bisect(sv, v0, lambda ve: _ramp_dist(v0, ve, dec, sc) >= dist)
        _ramp(prof, v0, end, dec, sc)
    elif brake >= dist - creep:  # brake now, then the rest of the offset at SV
        _ramp(prof, v0, sv, dec, sc)
        prof.add((dist - brake) / sv, 0.0, 0.0)
    else:
        room = dist - creep

        def need(peak: float) -> float:
            first = _ramp_dist(v0, peak, acc if peak >= v0 else dec, sc)
            return first + _ramp_dist(peak, sv, dec, sc)

        if need(top) <= room:
            peak = top
        elif top > v0:
            low = max(v0, sv)
            peak = _bisect(low, top, lambda p: need(p) <= room) if need(low) <= room else low
        else:
            peak = v0  # above the new speed with no room to slow down first: brake later
        _ramp(prof, v0, peak, acc if peak >= v0 else dec, sc)
        prof.add(max(room - need(peak), 0.0) / peak, 0.0, 0.0)
        _ramp(prof, peak, sv, dec, sc)
        if creep:
            prof.add(creep / sv, 0.0, 0.0)
    prof.length = length
    return prof
