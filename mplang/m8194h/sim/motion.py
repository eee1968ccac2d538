"""Analytic, event-driven motion model of the virtual M8194H.

Every motion is a profile of path length ``s(t)`` made of constant-jerk pieces (a
piecewise cubic in time), started at a given simulated time; a *path* maps ``s`` to
axis positions.  Nothing sleeps and nothing is stepped: position, speed and
acceleration at any time are evaluated in closed form, and the caller advances time
from one event (the end of a motion, see :meth:`MotionModel.next_event`) to the next.
Simulated time must never go backwards between calls: finished motions are settled
and forgotten.

Units: positions in pulses (``int``), speeds in pulses/s, accelerations in pulses/s²,
jerks in pulses/s³, time in seconds (``float``).

Sources are the RS-M8194H manual (``/work/shared/manuals/001_404865bff90dda3e.txt``,
cited below as "manual line N"); where the manual is silent the choice is stated.

Conventions and simplifications
-------------------------------
* Speed resolution (manual l.1146): drive and start speeds (SV, V, VSV, VV and the
  CONTINUE_MOVE speed) are rounded to the nearest multiple of ``MAX_V / 8000`` when
  a motion starts (a non-zero drive speed is at least one step).  The power-on
  MAX_V is 200 000 PPS (factory table, manual l.9705), so the default step is 25 PPS.
  Accelerations and jerks are used as given (the manual's MAX_V/64 granularity for
  A/D, l.5157, is not modelled).
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
* The end of a move snaps the logical position (LP) to the exact integer target.
  While moving, LP is the path position rounded to the nearest pulse.
* EP (encoder) is LP plus a per-axis offset (an ideal encoder).  SET_EP changes the
  offset; SET_LP moves LP but not EP (both counters are independent registers),
  so it changes the offset too.  SET_LP during a move shifts the rest of the move.
* CV is the unsigned speed of an axis (its share of the path speed during an
  interpolation).  CA is the tangential acceleration along the path scaled the same
  way, positive when speeding up and negative when slowing down.
* CONTINUE_MOVE (l.5636): the argument is the drive speed, its sign the direction
  (positive = "CW" = increasing LP).  It ramps from SV to the speed and runs until
  stopped.  Issuing CONTINUE_MOVE again in the same direction on a continuously
  running axis changes the speed on the fly (l.5624), ramping from the present speed.
* A motion command for a busy axis is queued and starts, in issue order, at the
  instant every axis it needs is idle (a move behind a continuous move waits until
  that move is stopped).  A command for an axis under DRV_HOLD (l.9128) is kept
  pending until DRV_START (l.9211) releases every axis it uses; a pending command
  makes its axes busy, a hold alone does not.
* STOP_SLOWLY / VSTOP_SLOWLY ramp from the present speed down to the start speed
  with the deceleration of the motion (D or L; VD or VL) and stop there; the stop
  position is rounded to the nearest pulse.  If the motion is already in its final
  deceleration it simply finishes.  For S-curves the present acceleration is
  dropped to zero at the stop (a simplification).  Stopping any axis of an
  interpolation stops the whole interpolation.  Stops also discard queued and
  pending commands of the stopped axes.
* Interpolation (7.2): the vector speed is the Euclidean path speed.  VECTOR_SPEED
  modes (l.5761) map to a profile type only: 0/7 constant VV; 1/5/8 symmetric T
  (VA); 2/9 symmetric S (VK); 3/6/10 asymmetric T (VA, VD); 4/11 asymmetric S
  (VK, VL) -- whether the mode number is meant for lines or arcs is not checked.
  Speeds are quantised with the MAX_V of axis 1 (VSV is "the starting speed of the
  main axis", l.6064).
* Arcs: axis 1 is the abscissa and axis 2 the ordinate of a right-handed plane;
  CCW means increasing polar angle, CW decreasing.  The manual's figure is not in
  the text (l.6675 only has its caption), so this is the usual mathematical sense.
  Relative commands give the centre and the finish point relative to the start
  (l.6650-6653); the ABS_ variants give both absolutely (l.6835ff).  A finish point
  equal to the start (or on the start ray) means a full circle.  When the finish
  point is not exactly on the circle the radius is blended linearly along the sweep
  so the path stays continuous and still ends exactly on the finish point.
* Continuous interpolation (7.4.2-7.4.10).  LINE_2D_INITIAL / LINE_3D_INITIAL /
  MIX_2D_INITIAL act as AXIS_ASSIGN plus VECTOR_SPEED 1 / 8 / (nAcc 0: 0, nAcc 1: 1)
  and SET_VSV/VV/VA: the manual only says they "set the necessary parameters" for a
  symmetric T-curve (l.8267, l.8474) or constant VV / T-curve (l.8704), so writing the
  ordinary vector registers is the choice.  A CONTINUE without an INITIAL runs with the
  present vector settings, S-curve modes as T-curves with VA (and VD if asymmetric),
  since continuous interpolation knows only constant speed and T-curves.
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
* Segments are buffered without limit (no depth is given for continuous
  interpolation); a segment that arrives while its chain runs replans the profile from
  the present position and speed.  A chain that runs out of segments before its last
  one stops at the end of those it has, at the speed it had: the device cannot brake
  for a segment it has not been sent.  The 3-axis examples end that way, their
  closing calls having nType 0 (l.8601, l.8680).  A last segment that comes too late
  to brake fully brakes at once (VA) and loses the remaining speed on the end point.
* A chain takes more segments while it waits to start or runs undisturbed and has not
  had its last one; a stop, a new *_INITIAL, other assigned axes, or another command
  waiting for its axes (which a segment must not overtake) ends that, and the next
  segment opens a new chain, queued like any command.
* INTP_END (l.9551): type 0 / 1 (2 / 3 axes, l.9563) marks the end of the open chain
  of that many axes, which then decelerates to a stop at the end of its segments; a
  type that does not match has no effect.  The manual asks for it before single-axis
  moves or coordinate changes; those already wait for a running interpolation here.
* MIX_2D_CONTINUE nType 1-5 (l.8762) are LINE_2D, ARC_CW/CCW and CIRCLE_CW/CCW with the
  arc conventions above; relative centres and end points count from the segment's
  start, ABS_ ones are absolute (l.8820).
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
* Axis I/O (sensors, hardware and software limits, home search, emergency stop, error
  codes, compare, latch, synchronous actions, interrupt factors) lives in
  ``axis_io.py``, whose docstring lists its own conventions.  Its events (a limit or a
  sensor edge reached, a compare value passed) are folded into the model's next event
  by ``_recompute`` and handled by ``settle`` in time order, before the motions ending
  at the same instant; every ended motion is reported to it (D-END, next home step).
  A command that starts is dropped in an emergency, while EMG is asserted or while an
  enabled ALARM is active.
"""

from __future__ import annotations

import copy
import math
from abc import ABC, abstractmethod
from bisect import bisect_right
from collections.abc import Callable
from dataclasses import dataclass, field

from mplang.m8194h.sim import axis_io

AXES = ("X", "Y", "Z", "U")

_INF = math.inf
_TWO_PI = 2.0 * math.pi
#: power-on maximum speed (factory initial table, manual line 9705)
DEFAULT_MAX_V = 200_000
_SPEED_STEPS = 8000

_VECTOR_KIND = {
    0: "const", 7: "const",
    1: "symT", 5: "symT", 8: "symT",
    2: "symS", 9: "symS",
    3: "asymT", 6: "asymT", 10: "asymT",
    4: "asymS", 11: "asymS",
}


def _round(x: float) -> int:
    """Round half up (monotonic, unlike banker's rounding it never favours evens)."""
    return math.floor(x + 0.5)


def _mask_axes(mask: int) -> tuple[int, ...]:
    if not 1 <= mask <= 15:
        raise ValueError(f"axis mask must be 1..15, got {mask}")
    return tuple(i for i in range(4) if mask >> i & 1)


def _axis_index(code: int) -> int:
    if code not in (1, 2, 4, 8):
        raise ValueError(f"single-axis code must be 1, 2, 4 or 8, got {code}")
    return code.bit_length() - 1


def _quantise(speed: float, max_v: float) -> float:
    """Round a speed to the controller's resolution MAX_V/8000 (manual l.1146)."""
    res = max_v / _SPEED_STEPS
    if speed <= 0:
        return 0.0
    return max(res, round(speed / res) * res)


# --------------------------------------------------------------------------- profiles


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


def _point_to_point(dist: float, plan: _Plan) -> _Profile:
    """Profile covering exactly `dist` pulses of path, starting and ending at SV."""
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
        prof = _point_to_point(dist - creep, _Plan(sv, v, plan.acc, plan.dec, plan.s_curve))
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


# ------------------------------------------------------------------------------ paths


class _Path(ABC):
    """Maps path length to axis positions (floats, in the axes' own frames)."""

    @abstractmethod
    def pos(self, k: int, s: float) -> float:
        """Position of path axis k after path length s."""

    @abstractmethod
    def deriv(self, k: int, s: float) -> float:
        """d(position of axis k)/d(path length) at s."""


class _LinePath(_Path):
    __slots__ = ("deltas", "length", "starts")

    def __init__(self, starts: tuple[int, ...], deltas: tuple[int, ...], length: float) -> None:
        self.starts = starts
        self.deltas = deltas
        self.length = length

    def pos(self, k: int, s: float) -> float:
        return self.starts[k] + self.deltas[k] * (s / self.length)

    def deriv(self, k: int, s: float) -> float:
        return self.deltas[k] / self.length


class _ArcPath(_Path):
    __slots__ = ("cx", "cy", "length", "r0", "r1", "sweep", "th0")

    def __init__(self, cx: float, cy: float, r0: float, r1: float, th0: float,
                 sweep: float) -> None:
        self.cx, self.cy, self.r0, self.r1 = cx, cy, r0, r1
        self.th0, self.sweep = th0, sweep
        self.length = abs(sweep) * (r0 + r1) / 2.0

    def pos(self, k: int, s: float) -> float:
        f = s / self.length
        th = self.th0 + self.sweep * f
        r = self.r0 + (self.r1 - self.r0) * f
        return self.cx + r * math.cos(th) if k == 0 else self.cy + r * math.sin(th)

    def deriv(self, k: int, s: float) -> float:
        f = s / self.length
        th = self.th0 + self.sweep * f
        r = self.r0 + (self.r1 - self.r0) * f
        dr = (self.r1 - self.r0) / self.length
        dth = self.sweep / self.length
        if k == 0:
            return dr * math.cos(th) - r * math.sin(th) * dth
        return dr * math.sin(th) + r * math.cos(th) * dth


# ---------------------------------------------------------------------------- motions


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

    def __post_init__(self) -> None:
        self.end = self.t0 + self.prof.duration

    @property
    def continuous(self) -> bool:
        return self.end == _INF


@dataclass
class _Cmd:
    axes: tuple[int, ...]
    vector: bool
    build: Callable[[MotionModel, float], _Motion | None]


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


@dataclass
class _AxisState:
    pos: int = 0  # LP while idle
    shift: int = 0  # SET_LP correction applied to a running motion
    ep_off: int = 0  # EP - LP
    held: bool = False
    motion: _Motion | None = None


def _single_plan(st: _AxisSettings) -> _Plan:
    v = _quantise(st.v, st.max_v)
    sv = _quantise(st.sv, st.max_v)
    mode = st.mode
    if mode in (1, 3):
        return _Plan(sv, v, float(max(st.k, 1)), float(max(st.l if mode == 3 else st.k, 1)),
                     True, offset=float(st.ao))
    return _Plan(sv, v, float(max(st.a, 1)), float(max(st.d if mode == 2 else st.a, 1)), False,
                 offset=float(st.ao))


class MotionModel:
    """Four axes X, Y, Z, U of a virtual M8194H with analytic motion profiles.

    Axis masks are Table-4 codes (X=1, Y=2, Z=4, U=8, combinations up to 15); a
    single-axis code is one of 1, 2, 4, 8.  Every query takes the present simulated
    time ``now`` and first finishes motions that ended at or before it.
    """

    def __init__(self) -> None:
        self.settings = [_AxisSettings() for _ in AXES]
        self.vector = _VectorSettings()
        self.assigned: tuple[int, ...] = (0, 1)  # axis indices of axis1..axis3
        self._ax = [_AxisState() for _ in AXES]
        self._queue: list[_Cmd] = []  # waiting for busy axes
        self._pending: list[_Cmd] = []  # waiting for DRV_START
        self.io = axis_io.AxisIO(self)  # sensors, limits, homing, errors, interrupts
        self._next_end = _INF
        # continuous interpolation (7.4): chains by id, and the one still taking segments
        self._chains: dict[int, _Chain] = {}
        self._chain_seq = 0
        self._open: _Chain | None = None

    # ---------------------------------------------------------------- settings
    def _set(self, axis_mask: int, name: str, value: int) -> None:
        for i in _mask_axes(axis_mask):
            setattr(self.settings[i], name, int(value))

    def set_max_v(self, axis_mask: int, value: int) -> None:
        if value <= 0:
            raise ValueError("MAX_V must be positive")
        self._set(axis_mask, "max_v", value)

    def set_speed_mode(self, axis_mask: int, mode: int) -> None:
        if mode not in (0, 1, 2, 3):
            raise ValueError(f"NORMAL_SPEED mode must be 0..3, got {mode}")
        self._set(axis_mask, "mode", mode)

    def set_sv(self, axis_mask: int, value: int) -> None:
        self._set(axis_mask, "sv", value)

    def set_v(self, axis_mask: int, value: int) -> None:
        self._set(axis_mask, "v", value)

    def set_a(self, axis_mask: int, value: int) -> None:
        self._set(axis_mask, "a", value)

    def set_d(self, axis_mask: int, value: int) -> None:
        self._set(axis_mask, "d", value)

    def set_k(self, axis_mask: int, value: int) -> None:
        self._set(axis_mask, "k", value)

    def set_l(self, axis_mask: int, value: int) -> None:
        self._set(axis_mask, "l", value)

    def set_ao(self, axis_mask: int, value: int) -> None:
        """Store the offset pulses (reported in `settings`, not applied to paths)."""
        self._set(axis_mask, "ao", value)

    def set_lp(self, axis_mask: int, value: int, now: float) -> None:
        self.settle(now)
        for i in _mask_axes(axis_mask):
            delta = int(value) - self._lp(i, now)
            ax = self._ax[i]
            if ax.motion is None:
                ax.pos += delta
            else:
                ax.shift += delta
            ax.ep_off -= delta  # the encoder counter is not touched
            self.io.lp_moved(i, delta)
        self._recompute()  # compare values and limits are met at other times now

    def set_ep(self, axis_mask: int, value: int, now: float) -> None:
        self.settle(now)
        for i in _mask_axes(axis_mask):
            self._ax[i].ep_off = int(value) - self._lp(i, now)
        self._recompute()

    # ------------------------------------------------------ interpolation settings
    def axis_assign(self, axis1: int, axis2: int, axis3: int) -> None:
        axes = [_axis_index(axis1), _axis_index(axis2)]
        if axis3:
            axes.append(_axis_index(axis3))
        if len(set(axes)) != len(axes):
            raise ValueError("interpolation axes must be distinct")
        self.assigned = tuple(axes)

    def set_vector_mode(self, mode: int) -> None:
        if mode not in _VECTOR_KIND:
            raise ValueError(f"VECTOR_SPEED mode must be 0..11, got {mode}")
        self.vector.mode = mode

    def set_vsv(self, value: int) -> None:
        self.vector.vsv = int(value)

    def set_vv(self, value: int) -> None:
        self.vector.vv = int(value)

    def set_va(self, value: int) -> None:
        self.vector.va = int(value)

    def set_vd(self, value: int) -> None:
        self.vector.vd = int(value)

    def set_vk(self, value: int) -> None:
        self.vector.vk = int(value)

    def set_vl(self, value: int) -> None:
        self.vector.vl = int(value)

    def set_vao(self, value: int) -> None:
        self.vector.vao = int(value)

    def _vector_plan(self) -> _Plan:
        vs = self.vector
        max_v = self.settings[self.assigned[0]].max_v
        v = _quantise(vs.vv, max_v)
        sv = _quantise(vs.vsv, max_v)
        kind = _VECTOR_KIND[vs.mode]
        if kind == "const":
            return _Plan(v, v, 1.0, 1.0, False, constant=True)
        offset = float(vs.vao)
        if kind == "symT":
            return _Plan(sv, v, float(max(vs.va, 1)), float(max(vs.va, 1)), False, offset=offset)
        if kind == "asymT":
            return _Plan(sv, v, float(max(vs.va, 1)), float(max(vs.vd, 1)), False, offset=offset)
        if kind == "symS":
            return _Plan(sv, v, float(max(vs.vk, 1)), float(max(vs.vk, 1)), True, offset=offset)
        return _Plan(sv, v, float(max(vs.vk, 1)), float(max(vs.vl, 1)), True, offset=offset)

    # ------------------------------------------------------------------ motion
    def fixed_move(self, axis_mask: int, pulses: int, now: float) -> None:
        """FIXED_MOVE: every axis of the mask moves `pulses` relative to where it starts."""
        for i in _mask_axes(axis_mask):
            self._issue(_single_cmd(i, int(pulses), False, _single_plan(self.settings[i])), now)

    def abs_move(self, axis_mask: int, position: int, now: float) -> None:
        """ABS_FIXED_MOVE: every axis of the mask moves to LP = `position`."""
        for i in _mask_axes(axis_mask):
            self._issue(_single_cmd(i, int(position), True, _single_plan(self.settings[i])),
                        now)

    def continue_move(self, axis_mask: int, speed: int, now: float) -> None:
        """CONTINUE_MOVE: run at |speed| in the direction of its sign until stopped."""
        self.settle(now)
        for i in _mask_axes(axis_mask):
            st = self.settings[i]
            base = _single_plan(st)
            direction = 1 if speed > 0 else -1
            v = _quantise(abs(speed), st.max_v)
            plan = _Plan(min(base.sv, v), v, base.acc, base.dec, base.s_curve)
            ax = self._ax[i]
            m = ax.motion
            if (v > 0 and m is not None and m.continuous and not m.vector
                    and m.direction == direction and not ax.held
                    and not any(i in c.axes for c in self._queue)):
                self._change_speed(i, m, plan, now)
                continue
            if v <= 0:
                continue
            self._issue(_Cmd((i,), False, _continuous_builder(i, direction, plan)), now)
        self._recompute()

    def _change_speed(self, i: int, m: _Motion, plan: _Plan, now: float) -> None:
        s, v, _a = m.prof.state(now - m.t0)
        prof = _Profile(s, v)
        rate = plan.acc if plan.v >= v else plan.dec
        _ramp(prof, v, plan.v, rate, plan.s_curve)
        prof.forever()
        self._ax[i].motion = _Motion((i,), now, prof, m.path, (), plan, False, m.direction)

    def line(self, distances: tuple[int, ...], now: float, absolute: bool = False) -> None:
        """LINE_2D / LINE_3D (and ABS_ variants) on the assigned axes."""
        n = len(distances)
        if n not in (2, 3) or n > len(self.assigned):
            raise ValueError(f"{n}-axis line needs {n} assigned axes")
        axes = self.assigned[:n]
        self._issue(_Cmd(axes, True, _line_builder(axes, tuple(int(d) for d in distances),
                                                   absolute, self._vector_plan())), now)

    def arc(self, center: tuple[int, int], finish: tuple[int, int], clockwise: bool,
            now: float, absolute: bool = False) -> None:
        """ARC_CW / ARC_CCW (and ABS_ variants) in the plane of axis 1 / axis 2."""
        axes = self.assigned[:2]
        self._issue(_Cmd(axes, True, _arc_builder(axes, (int(center[0]), int(center[1])),
                                                  (int(finish[0]), int(finish[1])),
                                                  clockwise, absolute, False,
                                                  self._vector_plan())), now)

    def circle(self, center: tuple[int, int], clockwise: bool, now: float) -> None:
        """CIRCLE_CW / CIRCLE_CCW: a full circle around a centre relative to the start."""
        axes = self.assigned[:2]
        self._issue(_Cmd(axes, True, _arc_builder(axes, (int(center[0]), int(center[1])),
                                                  (0, 0), clockwise, False, True,
                                                  self._vector_plan())), now)

    def hold(self, axis_mask: int) -> None:
        """DRV_HOLD: later commands for these axes wait for DRV_START."""
        for i in _mask_axes(axis_mask):
            self._ax[i].held = True

    def start(self, axis_mask: int, now: float) -> None:
        """DRV_START: release the hold and start the commands that no longer wait."""
        self.settle(now)
        for i in _mask_axes(axis_mask):
            self._ax[i].held = False
        waiting, self._pending = self._pending, []
        for cmd in waiting:
            self._issue(cmd, now)

    def stop(self, axis_mask: int, now: float, sudden: bool) -> None:
        """STOP_SLOWLY / STOP_SUDDENLY for the axes of the mask."""
        self.settle(now)
        axes = set(_mask_axes(axis_mask))
        self._queue = [c for c in self._queue if not axes & set(c.axes)]
        self._pending = [c for c in self._pending if not axes & set(c.axes)]
        for m in self._motions():
            if axes & set(m.axes):
                self.io.stopping(m, now, sudden)
                self._stop_motion(m, now, sudden)
        self._dequeue(now)
        self._recompute()

    def vector_stop(self, now: float, sudden: bool) -> None:
        """VSTOP_SLOWLY / VSTOP_SUDDENLY: stop the interpolation, drop queued ones."""
        self.settle(now)
        self._queue = [c for c in self._queue if not c.vector]
        self._pending = [c for c in self._pending if not c.vector]
        for m in self._motions():
            if m.vector:
                self.io.stopping(m, now, sudden)
                self._stop_motion(m, now, sudden)
        self._dequeue(now)
        self._recompute()

    def _stop_motion(self, m: _Motion, now: float, sudden: bool) -> None:
        s, v, _a = m.prof.state(now - m.t0)
        plan = m.plan
        if not sudden and v > plan.sv + 1e-9:
            dist = _ramp_dist(v, plan.sv, plan.dec, plan.s_curve)
            if not m.continuous and m.prof.length - s <= dist + 1e-9:
                return  # already in the final deceleration
            prof = _Profile(s, v)
            _ramp(prof, v, plan.sv, plan.dec, plan.s_curve)
            prof.length = s + dist
            final = tuple(_round(m.path.pos(k, s + dist)) for k in range(len(m.axes)))
            new = _Motion(m.axes, now, prof, m.path, final, plan, m.vector)
            for i in m.axes:
                self._ax[i].motion = new
            return
        for k, i in enumerate(m.axes):
            ax = self._ax[i]
            ax.pos = _round(m.path.pos(k, s)) + ax.shift
            ax.shift = 0
            ax.motion = None

    # ------------------------------------------------------------ bookkeeping
    def _motions(self) -> list[_Motion]:
        seen: list[_Motion] = []
        for ax in self._ax:
            m = ax.motion
            if m is not None and all(m is not o for o in seen):
                seen.append(m)
        return seen

    def _recompute(self) -> None:
        end = _INF
        for ax in self._ax:
            if ax.motion is not None and ax.motion.end < end:
                end = ax.motion.end
        self._next_end = min(end, self.io.reschedule())  # limits, sensors, compare

    def _issue(self, cmd: _Cmd, now: float) -> None:
        self.settle(now)
        if any(self._ax[i].held for i in cmd.axes):
            self._pending.append(cmd)
            return
        if any(self._ax[i].motion is not None for i in cmd.axes) or any(
                set(cmd.axes) & set(c.axes) for c in self._queue):
            self._queue.append(cmd)
            return
        self._start(cmd, now)
        self._recompute()

    def _start(self, cmd: _Cmd, t: float) -> None:
        if self.io.refuses(cmd.axes, t):
            return  # emergency, EMG input or servo alarm: the command is dropped
        m = cmd.build(self, t)
        if m is None:
            return
        if m.end <= t:
            for k, i in enumerate(m.axes):
                self._ax[i].pos = m.final[k]
            return
        for i in m.axes:
            self._ax[i].motion = m
        self.io.started(m, t)

    def _dequeue(self, t: float) -> None:
        blocked: set[int] = set()
        keep: list[_Cmd] = []
        for cmd in self._queue:
            if blocked & set(cmd.axes) or any(self._ax[i].motion is not None for i in cmd.axes):
                blocked |= set(cmd.axes)
                keep.append(cmd)
            else:
                self._start(cmd, t)
        self._queue = keep

    def settle(self, now: float) -> None:
        """Finish, in time order, every motion that ended at or before `now`."""
        while self._next_end <= now:
            t = self._next_end
            self.io.fire(t)  # axis I/O events due at t (limits, home sensors, compare)
            for ax in self._ax:
                m = ax.motion
                if m is not None and m.end <= t:
                    for k, i in enumerate(m.axes):
                        other = self._ax[i]
                        other.pos = m.final[k] + other.shift
                        other.shift = 0
                        other.motion = None
                    self.io.ended(m, t)  # D-END, or the next home-search step
            self._dequeue(t)
            self._recompute()
        self.io.advance(now)

    # ------------------------------------------------------------------- state
    def _lp(self, i: int, now: float) -> int:
        ax = self._ax[i]
        m = ax.motion
        if m is None:
            return ax.pos
        s = m.prof.state(now - m.t0)[0]
        return _round(m.path.pos(m.axes.index(i), s)) + ax.shift

    def lp(self, axis: int, now: float) -> int:
        """Logical position of one axis (single-axis code 1/2/4/8)."""
        i = _axis_index(axis)
        if now >= self._next_end:
            self.settle(now)
        return self._lp(i, now)

    def ep(self, axis: int, now: float) -> int:
        """Encoder position: LP plus the axis's EP-LP offset."""
        i = _axis_index(axis)
        return self.lp(axis, now) + self._ax[i].ep_off

    def sample(self, index: int, now: float) -> tuple[int, int, float]:
        """LP, EP and signed velocity (pulses/s, negative while LP decreases) of axis 0..3,
        for traces: CV gives the speed without its sign; this is the running motion's speed
        along its path times the path's direction for this axis."""
        lp = self.lp(1 << index, now)  # settles the model at `now`
        state = self._ax[index]
        motion = state.motion
        if motion is None:
            return lp, lp + state.ep_off, 0.0
        travelled, speed, _acceleration = motion.prof.state(now - motion.t0)
        return lp, lp + state.ep_off, speed * motion.path.deriv(motion.axes.index(index),
                                                                  travelled)

    def _kinematics(self, axis: int, now: float) -> tuple[float, float]:
        i = _axis_index(axis)
        self.settle(now)
        m = self._ax[i].motion
        if m is None:
            return 0.0, 0.0
        s, v, a = m.prof.state(now - m.t0)
        scale = abs(m.path.deriv(m.axes.index(i), s))
        return v * scale, a * scale

    def cv(self, axis: int, now: float) -> float:
        """Present speed of one axis in pulses/s (unsigned)."""
        return self._kinematics(axis, now)[0]

    def ca(self, axis: int, now: float) -> float:
        """Present acceleration of one axis in pulses/s² (negative while slowing)."""
        return self._kinematics(axis, now)[1]

    def _busy(self, axes: tuple[int, ...]) -> bool:
        if any(self._ax[i].motion is not None for i in axes):
            return True
        wanted = set(axes)
        return any(wanted & set(c.axes) for c in self._queue) or any(
            wanted & set(c.axes) for c in self._pending)

    def busy(self, axis_mask: int, now: float) -> bool:
        """True if an axis of the mask moves or has a queued or held command."""
        axes = _mask_axes(axis_mask)
        if now >= self._next_end:
            self.settle(now)
        return self._busy(axes)

    def idle_at(self, axis_mask: int, now: float) -> float | None:
        """When every axis of the mask will be idle; None if never without a command."""
        axes = _mask_axes(axis_mask)
        self.settle(now)
        wanted = set(axes)
        if any(wanted & set(c.axes) for c in self._pending):
            return None
        if not any(wanted & set(c.axes) for c in self._queue) and self.io.quiet():
            end = now
            for i in axes:
                m = self._ax[i].motion
                if m is not None:
                    end = max(end, m.end)
            return None if end == _INF else end
        sim = copy.deepcopy(self)
        t = now
        while sim._busy(axes):
            nxt = sim.next_event(t)
            if nxt is None:
                return None
            t = nxt
            sim.settle(t)
        return t

    def next_event(self, now: float) -> float | None:
        """Earliest end of a running motion after `now` (None if nothing will end)."""
        self.settle(now)
        return None if self._next_end == _INF else self._next_end

    # ------------------------------------------- axis I/O query API (see axis_io.py)
    def axis_report(self, axis_index: int, now: float) -> axis_io.AxisReport:
        """DI status, error code, stop causes, servo, emergency, home and latch of one
        axis (0..3) at `now`: what the Modbus registers of appendix 12 show."""
        return self.io.report(axis_index, now)

    def next_interrupt(self, now: float) -> float | None:
        """Time of the earliest interrupt request, pending or still to come if nothing
        changes (None if none will come)."""
        return self.io.next_interrupt(now)

    def take_interrupts(self, until: float) -> list[tuple[float, int]]:
        """Remove and return, in time order, the (time, ISR number) requests due at or
        before `until`."""
        return self.io.take_interrupts(until)

    # ------------------------- continuous interpolation, rectangle, helix (7.4, 7.5.9)
    def continuous_initial(self, axes: tuple[int, ...], mode: int, vsv: int, vv: int,
                           va: int) -> None:
        """LINE_2D_INITIAL / LINE_3D_INITIAL / MIX_2D_INITIAL: the equivalent AXIS_ASSIGN,
        VECTOR_SPEED `mode` and SET_VSV/VV/VA; the next segment starts a new chain."""
        self.axis_assign(axes[0], axes[1], axes[2] if len(axes) > 2 else 0)
        self.set_vector_mode(mode)
        self.set_vsv(vsv)
        self.set_vv(vv)
        self.set_va(va)
        self._open = None

    def continuous_line(self, values: tuple[int, ...], last: bool, now: float,
                        absolute: bool = False) -> None:
        """LINE_2D_CONTINUE / LINE_3D_CONTINUE (and ABS_): one more straight segment."""
        if len(values) not in (2, 3):
            raise ValueError(f"a continuous line takes 2 or 3 values, got {len(values)}")
        self._continue(_Seg("line", tuple(int(v) for v in values), absolute), last, now)

    def continuous_mix(self, shape: int, center: tuple[int, int], finish: tuple[int, int],
                       last: bool, now: float, absolute: bool = False) -> None:
        """MIX_2D_CONTINUE (and ABS_): shape 1 line, 2/3 CW/CCW arc, 4/5 CW/CCW circle."""
        c = (int(center[0]), int(center[1]))
        f = (int(finish[0]), int(finish[1]))
        if shape == 1:
            seg = _Seg("line", f, absolute)
        elif shape in (2, 3):
            seg = _Seg("arc", c + f, absolute, shape == 2)
        elif shape in (4, 5):
            seg = _Seg("circle", c, absolute, shape == 4)
        else:
            raise ValueError(f"MIX_2D_CONTINUE nType must be 1..5, got {shape}")
        self._continue(seg, last, now)

    def intp_end(self, dims: int, now: float) -> None:
        """INTP_END: the open continuous interpolation on `dims` axes gets no more
        segments, so it decelerates to a stop at the end of those it has."""
        self.settle(now)
        chain = self._open
        if chain is None or len(chain.axes) != dims:
            return
        self._open = None
        if self._chain_alive(chain):
            self._grow(chain, None, True, now)

    def rectangle(self, axes: tuple[int, int], constant: bool, start_point: int,
                  clockwise: bool, size: tuple[int, int, int],
                  speeds: tuple[int, int, int, int], now: float) -> None:
        """RECTANGLE: one lap of a rounded rectangle from the present position, which is
        its tangent point Sp; size = (Lp, Wp, Rp), speeds = (RSV, RV, RA, RD)."""
        i, j = _axis_index(axes[0]), _axis_index(axes[1])
        if i == j:
            raise ValueError("the rectangle's axes must be distinct")
        if not 0 <= start_point <= 7:
            raise ValueError(f"RECTANGLE start point must be 0..7, got {start_point}")
        lp, wp, rp = (int(x) for x in size)
        if lp < 1 or wp < 1 or rp < 0:
            raise ValueError(f"RECTANGLE needs Lp, Wp >= 1 and Rp >= 0, got {size}")
        sv, v, acc, dec = speeds
        max_v = self.settings[i].max_v
        top = _quantise(v, max_v)
        plan = (_Plan(top, top, 1.0, 1.0, False, constant=True) if constant else
                _Plan(_quantise(sv, max_v), top, float(max(acc, 1)), float(max(dec, 1)),
                      False))
        r = min(rp, lp // 2, wp // 2)
        self._issue(_Cmd((i, j), True, _rectangle_builder((i, j), start_point, clockwise,
                                                          lp, wp, r, plan)), now)

    def helix(self, axes: tuple[int, int, int], clockwise: bool, vv: int,
              center: tuple[int, int], cycle: int, pitch: int, now: float) -> None:
        """HELIX_3D: `cycle` turns around a centre relative to the start in the plane of
        axes 1/2 while axis 3 advances `pitch` per turn, at the constant vector speed."""
        idx = tuple(_axis_index(a) for a in axes)
        if len(set(idx)) != 3:
            raise ValueError("the helix axes must be distinct")
        v = _quantise(vv, self.settings[idx[0]].max_v)
        plan = _Plan(v, v, 1.0, 1.0, False, constant=True)
        self._issue(_Cmd(idx, True, _helix_builder(idx, (int(center[0]), int(center[1])),
                                                   clockwise, int(cycle), int(pitch),
                                                   plan)), now)

    def _continuous_plan(self) -> _Plan:
        """The vector plan, S-curve modes run as T-curves (VA, and VD if asymmetric):
        continuous interpolation only knows constant speed and T-curves (l.8267, l.8704)."""
        plan = self._vector_plan()
        if not plan.s_curve:
            return plan
        vs = self.vector
        dec = vs.vd if _VECTOR_KIND[vs.mode] == "asymS" else vs.va
        return _Plan(plan.sv, plan.v, float(max(vs.va, 1)), float(max(dec, 1)), False)

    def _chain_alive(self, chain: _Chain) -> bool:
        """Waiting to start, or running undisturbed (not stopped, not finished)."""
        if not chain.started:
            return any(c is chain.cmd for c in self._queue) or any(
                c is chain.cmd for c in self._pending)
        m = chain.motion
        return m is not None and self._ax[chain.axes[0]].motion is m

    def _chain_open(self, chain: _Chain) -> bool:
        """Can take one more segment: alive, no last segment yet, and no later command
        waiting for its axes (a segment must not overtake it)."""
        if chain.closed or not self._chain_alive(chain):
            return False
        wanted = set(chain.axes)
        return not any(c is not chain.cmd and wanted & set(c.axes)
                       for c in (*self._queue, *self._pending))

    def _continue(self, seg: _Seg, last: bool, now: float) -> None:
        self.settle(now)
        n = 2 if seg.shape != "line" else len(seg.values)
        if n > len(self.assigned):
            raise ValueError(f"{n}-axis continuous interpolation needs {n} assigned axes")
        axes = self.assigned[:n]
        chain = self._open
        if chain is not None and chain.axes == axes and self._chain_open(chain):
            self._grow(chain, seg, last, now)
        else:
            self._chains = {k: c for k, c in self._chains.items() if self._chain_alive(c)}
            self._chain_seq += 1
            chain = _Chain(axes, self._continuous_plan(), [seg], last)
            chain.cmd = _Cmd(axes, True, _chain_builder(self._chain_seq))
            self._chains[self._chain_seq] = chain
            self._issue(chain.cmd, now)
        self._open = None if last else chain

    def _grow(self, chain: _Chain, seg: _Seg | None, last: bool, now: float) -> None:
        """Add a segment (or only the end mark) to a live chain and replan from now."""
        chain.closed = chain.closed or last
        if not chain.started:
            if seg is not None:
                chain.specs.append(seg)
            return
        m = chain.motion
        if m is None:
            return
        s, v, _a = m.prof.state(now - m.t0)
        if seg is not None:
            shift = tuple(self._ax[i].shift for i in chain.axes)
            part, length, chain.end = _lay(seg, chain.end, shift)
            if part is not None:
                chain.path.add(part, length)
        prof = _chain_profile(s, v, chain.path.length, chain.plan, chain.closed)
        new = _Motion(chain.axes, now, prof, chain.path, chain.end, chain.plan, True)
        for i in chain.axes:
            self._ax[i].motion = new
        chain.motion = new
        self._recompute()


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
        starts = tuple(model._ax[i].pos for i in axes)
        targets = values if absolute else tuple(s + d for s, d in zip(starts, values, strict=True))
        deltas = tuple(e - s for s, e in zip(starts, targets, strict=True))
        length = math.sqrt(sum(d * d for d in deltas))
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


# ------------------------------------- continuous interpolation, rectangle, helix (7.4)


def _arc_path(x0: int, y0: int, cx: int, cy: int, fx: int, fy: int, clockwise: bool,
              full: bool) -> _ArcPath | None:
    """The arc from (x0, y0) around (cx, cy) to (fx, fy); None if the radius is zero."""
    r0 = math.hypot(x0 - cx, y0 - cy)
    if r0 == 0.0:
        return None
    r1 = math.hypot(fx - cx, fy - cy)
    th0 = math.atan2(y0 - cy, x0 - cx)
    th1 = math.atan2(fy - cy, fx - cx) if r1 > 0.0 else th0
    sweep = ((th0 - th1) if clockwise else (th1 - th0)) % _TWO_PI
    if full or sweep < 1e-12:
        sweep = _TWO_PI
    return _ArcPath(cx, cy, r0, r1, th0, -sweep if clockwise else sweep)


class _ChainPath(_Path):
    """Parts joined end to end, so one profile drives a whole continuous interpolation."""

    __slots__ = ("length", "offsets", "parts")

    def __init__(self) -> None:
        self.parts: list[_Path] = []
        self.offsets: list[float] = []  # path length at the start of each part
        self.length = 0.0

    def add(self, part: _Path, length: float) -> None:
        self.offsets.append(self.length)
        self.parts.append(part)
        self.length += length

    def _at(self, s: float) -> tuple[_Path, float]:
        i = max(bisect_right(self.offsets, s) - 1, 0)
        return self.parts[i], s - self.offsets[i]

    def pos(self, k: int, s: float) -> float:
        part, ds = self._at(s)
        return part.pos(k, ds)

    def deriv(self, k: int, s: float) -> float:
        part, ds = self._at(s)
        return part.deriv(k, ds)


class _HelixPath(_Path):
    """A circle in the plane of path axes 0/1 while path axis 2 advances in proportion."""

    __slots__ = ("circle", "dz", "length", "z0")

    def __init__(self, circle: _ArcPath, z0: int, dz: int) -> None:
        self.circle = circle
        self.z0 = z0
        self.dz = dz
        self.length = math.hypot(circle.length, dz)

    def pos(self, k: int, s: float) -> float:
        f = s / self.length
        if k == 2:
            return self.z0 + self.dz * f
        return self.circle.pos(k, f * self.circle.length)

    def deriv(self, k: int, s: float) -> float:
        if k == 2:
            return self.dz / self.length
        scale = self.circle.length / self.length
        return self.circle.deriv(k, s * scale) * scale


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


# Tangent points of the rounded rectangle, in the frame of its bounding box (axis 1 along
# the length, axis 2 along the width, lower-left corner at the origin), numbered
# counter-clockwise from the left end of the lower side: these are Sp0-Sp7.  The edge from
# point k to point k+1 is a side for even k and a corner arc for odd k.
def _rectangle_parts(x0: int, y0: int, sp: int, clockwise: bool, lp: int, wp: int,
                     r: int) -> list[tuple[_Path, float]]:
    """Lines and arcs of one lap from tangent point `sp`, which is (x0, y0)."""
    pts = ((r, 0), (lp - r, 0), (lp, r), (lp, wp - r), (lp - r, wp), (r, wp), (0, wp - r),
           (0, r))
    centres = {1: (lp - r, r), 3: (lp - r, wp - r), 5: (r, wp - r), 7: (r, r)}
    ox, oy = x0 - pts[sp][0], y0 - pts[sp][1]
    step = -1 if clockwise else 1
    parts: list[tuple[_Path, float]] = []
    a = sp
    for _ in range(8):
        b = (a + step) % 8
        edge = a if step == 1 else b
        (xa, ya), (xb, yb) = pts[a], pts[b]
        if edge % 2 == 0:
            dx, dy = xb - xa, yb - ya
            length = math.hypot(dx, dy)
            if length > 0.0:
                parts.append((_LinePath((ox + xa, oy + ya), (dx, dy), length), length))
        else:
            cx, cy = centres[edge]
            arc = _arc_path(ox + xa, oy + ya, ox + cx, oy + cy, ox + xb, oy + yb, clockwise,
                            False)
            if arc is not None:
                parts.append((arc, arc.length))
        a = b
    return parts


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
