"""Axis I/O of the virtual M8194H: simulated sensors, limits, home search, emergency stop,
error reporting, compare, latch, synchronous actions and interrupt factors.

The motion model (`mplang.m8194h.sim.motion`) owns one `AxisIO` as ``MotionModel.io``.  Every
change of the motion state ends in ``MotionModel._recompute``, which asks
:meth:`AxisIO.reschedule` for the earliest *I/O event* of the present motions (a limit
switch reached, a home-search sensor edge, a compare value passed, a constant-speed part
starting or ending) and folds its time into the model's next event.  ``settle`` then
handles those events in time order together with the ends of motions, so everything stays
analytic and event driven: crossing times are solved on the closed-form profiles (bisection
in time; exact for straight paths, Lipschitz marching along curved ones), never stepped.

Positions: the sensors sit in the *machine frame*, which equals LP at power on and does not
move when SET_LP / SET_EP (or a home search) rewrite the counters; a signal changes when the
counter value (the path position rounded half up, as LP is) reaches the sensor's edge, so a
sudden stop on a signal ends exactly on that integer position.

Public query API (stable; the Modbus register map reads it)
------------------------------------------------------------
* ``MotionModel.axis_report(axis_index, now) -> AxisReport`` -- one axis: DI status word
  (appendix table 25 / GET_DI_ALL), DI signal word (table 27 / GET_DI_SIGNAL_ALL), error
  code (GET_ERROR_CODE, registers 20-23), stop causes (table 26), stop status (58-61),
  servo (coils 128-131), software emergency (25), home-search state (92-95), latch (62-69).
* ``AxisIO.error_state(now) -> int`` -- register 70 / GET_ERROR.
* ``AxisIO.triggered_factors(now) -> tuple[int, ...]`` -- registers 130-139, one axis mask
  per interrupt factor (0-7 of Table 7, 8 HMEND, 9 SYNC).
* ``MotionModel.next_interrupt(now)`` / ``MotionModel.take_interrupts(until)`` -- interrupt
  requests (time, ISR number) for the controller to dispatch.
* ``AxisIO.machine_position(axis_index, now)`` and ``AxisIO.set_sensors`` /
  ``set_alarm_input`` / ``set_emg_input`` / ``set_in3`` configure and drive the simulated
  machine.

Conventions and simplifications (manual = RS manual, "l.N" its line N)
--------------------------------------------------------------------
* Sensors (`AxisSensors`): LIMIT+ is engaged at and above its position, LIMIT- at and
  below; NHOME and HOME are closed intervals; the Z phase (index) is engaged for `width`
  pulses once every `period` pulses.  ``None`` = not fitted (never engaged).  Defaults: no
  limit switches (so a bare controller runs continuous moves for ever, as before), NHOME
  -20000..20000, HOME -1000..1000, index every 4000 pulses at 0.
* Active levels (SET_HLMT, SET_NHOME, SET_HOME_EDGE, SET_ALARM, SET_ENCODER nZEdge; power
  on all low active, l.9672-9700): with ``AxisSensors.wiring = None`` (default) the machine
  is wired to match, an engaged sensor is active.  With ``wiring = 0/1`` an engaged sensor
  drives that level and a free one the other, and the input is active when the level equals
  the configured active level -- a wrong setting then shows as an input active everywhere
  except on the switch, as on a real machine.
* Hardware limits (3.5, 3.6): a move towards an active limit (or reaching it) stops
  suddenly, or decelerates with LIMITSTOP_MODE 1; error bit LIMIT+ 4 / LIMIT- 8 on that
  axis.  An interpolation stops as a whole.  Moving away from an active limit is allowed.
* Software limits (3.9): they live in the COMP+/COMP- registers (SET_COMPARE "will disable
  the software limit setting", l.7666; INTFACTOR_ENABLE "conflict with SET_SLMT", l.8027).
  Forward limit active when P >= FL, reverse when P < RL (the comparators of Table 11,
  l.8011-8014); P is LP or EP per nType.  The manual does not say how the axis stops: the
  drive decelerates (D or L, VD/VL for interpolation), the usual motion-chip behaviour.
  Factory values 100000 / -100000 on LP, disabled (l.9681-9684).
* Errors latch (GET_ERROR_CODE table l.3668-3681; table 26 "has been encountered") until
  CLEAR_STOP (those axes) or CLEAR_VSTOP (the assigned interpolation axes) clears them
  (l.9466, l.9508) -- except the bits whose cause is still present (software emergency,
  EMG input, an active ALARM).  A latched error does not block later moves; the software
  emergency, an asserted EMG input and an active enabled ALARM do (the command is dropped).
  SOFT STOP (256) is set on the axes of motions a STOP_/VSTOP_ command actually stopped.
  The table-26 stop-cause word is the error code's bits 0-8, EMERGENCY also set for SOFT EMG.
* EMERGENCY_STOP (7.5.10, l.9595): clears every queued and held command, stops every axis
  (stopType 0 sudden, 1 decelerating) and sets SOFT EMG (512) on all axes; until
  CLEAR_EMERGENCY_STOP new motion is refused (l.3827).  The EMG input stops all axes
  suddenly and sets EMERGENCY (32) on all of them; an ALARM (if enabled) its own axis, 16.
* Home search (chapter 6, state codes l.3528): step 1 runs at V with the axis profile and
  decelerates to a stop once NHOME turns active (skipped if NHOME is already active -- the
  manual is silent; motion-chip convention); reaching the limit in that direction stops the
  drive (LIMITSTOP_MODE) and goes on with step 2, without error.  Steps 2 and 3 run at the
  constant speed HV (SET_HV, default 500 PPS as in the example l.4739) and stop suddenly on
  the signal edge, so the axis ends exactly on it.  Step 2 follows the irregular operations
  of the ET manual's 4.8 (000_cb7381bf3033b629.txt l.5715-5727): HOME already active ->
  leave it backwards (state 12) first; limit active in the search direction -> back up to
  HOME (8), leave it (12), then search (15); reaching that limit during the search -> stop
  and do the same.  With HOME_LIMIT 1 the limit switch of the search direction is the home
  signal of step 2.  Step 3 waits for the next Z-phase edge; Z and HOME both active at its
  start is the HOME error (128, l.3678).  Step 4 moves the offset at V with the axis profile.
  A limit reached in steps 3/4 or backing up in step 2 ends the search with that limit's
  error.  On success LP and EP are cleared: step 4 is the "offset movement to the origin of
  the working area" (l.4702).  The end of a search (success, error or stop command) is
  HMEND: ``AxisReport.home_end`` and bit 8 of the triggered-factor registers.  D-END is
  raised once, when the search ends, not between its steps.
* SERVO_ON/OFF only set the servo state (coils 128-131); pulses are output either way.
  INPOS is "on" while the servo is on and the axis does not drive (an ideal drive).
  Table 25 prints INPOS as 0: on (bit 8 of the status word) while table 27 prints INP as
  1: on (bit 6 of the signal word); each word follows its own table.
* Interrupts (7.3.10-7.3.13): a factor raises a request only if ENABLE_INT is on and the
  factor is enabled on the axis (INTFACTOR_ENABLE, which also clears that axis's bit of the
  triggered register, l.3959).  Compare factors fire on the edge (the condition becoming
  true).  A request stays pending until the controller takes it; while one is pending for
  an (axis, factor) the same factor does not queue another -- so PULSE asks for one ISR at
  a time, not one per pulse.  DISABLE_INT drops pending requests, INTFACTOR_DISABLE those
  of its factors.  C-STA/C-END are the start/end of the constant-speed part of a profile
  (a stop command cutting it short ends it), D-END the end of every drive.
* Synchronous actions (7.3.1-7.3.5): factors of the trigger axis fire the action of every
  activation axis, in the order latch, preset, drive, interrupt.  FDRV drives the preset
  value (nPRESET OPSET is not required); FDRV/CDRV do nothing if the activation axis is
  busy (l.7031); VLSET sets V and changes the speed of a running continuous move (a fixed
  move keeps its plan); SSTOP/ISTOP stop without the SOFT STOP bit.  nOUT is stored only
  (no observable output).  The SYNC register bit and the SYNC interrupt belong to the
  activation axis.  Actions stay armed until CLEAR_SYNC_ACTION.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from mplang.m8194h.sim import motion as mm

if TYPE_CHECKING:
    from mplang.m8194h.sim.motion import MotionModel, _Motion

_INF = math.inf

# GET_ERROR_CODE bits (l.3668-3681); bits 0-8 are also the stop causes of table 26
ERR_SOFT_LIMIT_PLUS = 1
ERR_SOFT_LIMIT_MINUS = 2
ERR_LIMIT_PLUS = 4
ERR_LIMIT_MINUS = 8
ERR_ALARM = 16
ERR_EMERGENCY = 32
ERR_HOME = 128
ERR_SOFT_STOP = 256
ERR_SOFT_EMG = 512

# interrupt factors nINT (Table 7 / Table 11) and the triggered-register indexes
INT_PULSE, INT_P_GE_CMINUS, INT_P_LT_CMINUS, INT_P_LT_CPLUS, INT_P_GE_CPLUS = 0, 1, 2, 3, 4
INT_C_END, INT_C_STA, INT_D_END, FACTOR_HMEND, FACTOR_SYNC = 5, 6, 7, 8, 9

# synchronous-action activation factors nSYNC (l.7016-7023)
SYNC_P_GE_CPLUS, SYNC_P_LT_CPLUS, SYNC_P_LT_CMINUS, SYNC_P_GE_CMINUS = 0x01, 0x02, 0x04, 0x08
SYNC_D_STA, SYNC_D_END, SYNC_IN3_UP, SYNC_IN3_DOWN = 0x10, 0x20, 0x40, 0x80

# GET_HOME_SEARCH_STATE codes (l.3528)
HOME_IDLE, HOME_STEP1, HOME_BACK_ON, HOME_BACK_OFF, HOME_STEP2 = 0, 3, 8, 12, 15
HOME_STEP3, HOME_STEP4 = 20, 25

_LIPSCHITZ = 2.0  # bound of |d axis position / d path length| for curved paths
_MAX_MARCH = 200_000


# ------------------------------------------------------------------------------ signals


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


@dataclass(frozen=True)
class AxisReport:
    """What the controller's registers show for one axis at one moment."""

    axis: int  # 0..3 = X, Y, Z, U
    time: float
    lp: int
    ep: int
    machine_position: int
    driving: bool
    di_status: int  # GET_DI_ALL / input register 16+axis / discrete inputs 128+16*axis
    di_signal: int  # GET_DI_SIGNAL_ALL / input register 88+axis / discrete inputs 256+8*axis
    error_code: int  # GET_ERROR_CODE / input register 20+axis
    stop_causes: int  # table 26, discrete inputs 192+16*axis (bit n = address offset n)
    stopped: bool  # input register 58+axis (1: stopped)
    servo_on: bool  # coil 128+axis
    emergency: bool  # software emergency state, input register 25
    home_state: int  # GET_HOME_SEARCH_STATE / input register 92+axis
    home_end: float | None  # when the last home search ended (HMEND)
    latch: int  # GET_LATCH / input registers 62+2*axis


@dataclass
class _Action:
    drv: int = 0
    latch: int = 0
    preset: int = 0
    out: int = 0
    intr: int = 0
    isrs: tuple[int, int, int, int] = (0, 0, 0, 0)


@dataclass
class _AxisConfig:
    hlmt_plus_level: int = 0
    hlmt_minus_level: int = 0
    limit_stop_slow: bool = False
    nhome_level: int = 0
    home_level: int = 0
    z_level: int = 0
    alarm_enabled: bool = False
    alarm_level: int = 0
    inpos_enabled: bool = False
    inpos_level: int = 0
    slmt: bool = False
    comp_plus: int = 100_000
    comp_minus: int = -100_000
    comp_ep: bool = False
    hv: int = 500
    home_limit: bool = False
    home_steps: tuple[int, int, int, int] = (0, 0, 0, 0)  # +1 / -1 / 0 skip
    home_offset: int = 0
    int_factors: dict[int, int] = field(default_factory=dict)  # nINT -> ISR number
    sync_factors: int = 0
    sync_targets: int = 0
    action: _Action | None = None
    preset: int = 0


@dataclass
class _HomeRun:
    axis: int
    state: int = HOME_IDLE
    motion: _Motion | None = None
    stopping: bool = False  # decelerating at the end of step 1


@dataclass
class _AxisStatus:
    errors: int = 0
    latch: int = 0
    servo_on: bool = False
    alarm_input: bool = False
    in3_level: int = 1  # IN3 is low active; an open input reads high
    mach_off: int = 0  # machine position - LP
    home: _HomeRun | None = None
    home_end: float | None = None


@dataclass(order=True)
class _Event:
    time: float
    rank: int
    kind: str = field(compare=False)
    axis: int = field(compare=False)
    arg: int = field(compare=False, default=0)
    motion: _Motion | None = field(compare=False, default=None)


@dataclass
class _Request:
    time: float
    isr: int
    axis: int
    factor: int


def _axes(mask: int) -> tuple[int, ...]:
    return mm._mask_axes(mask)


def _one_axis(code: int) -> int:
    return mm._axis_index(code)


def _direction(step: int) -> int:
    if step not in (0, 1, 2):
        raise ValueError(f"home step direction must be 0, 1 or 2, got {step}")
    return 0 if step == 0 else (1 if step == 1 else -1)


# ------------------------------------------------------------------- crossing times


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
        if isinstance(m.path, mm._LinePath):
            return None
        return _march(m, k, level, rising, t_from, ok)
    if isinstance(m.path, mm._LinePath):
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


# ------------------------------------------------------------------------------ AxisIO


class AxisIO:
    """Per-axis inputs, error state, home search, compare/sync and interrupts of one model."""

    def __init__(self, model: MotionModel) -> None:
        self.model = model
        self.sensors = [AxisSensors() for _ in mm.AXES]
        self.cfg = [_AxisConfig() for _ in mm.AXES]
        self.status = [_AxisStatus() for _ in mm.AXES]
        self.now = 0.0
        self.emergency = False  # software emergency state (EMERGENCY_STOP)
        self.emg_input = False
        self.int_enabled = False
        self.triggered = [0] * 10  # registers 130-139: axis masks
        self.requests: list[_Request] = []
        self._events: list[_Event] = []
        self._next = _INF
        self._exempt: list[_Motion] = []  # motions already stopping on a limit
        self._version = 0
        self._prediction: tuple[int, float | None] | None = None

    # ------------------------------------------------------------- the machine
    def set_sensors(self, axis_index: int, sensors: AxisSensors, now: float) -> None:
        """Rearrange the switches of one axis (they act from `now` on)."""
        self.model.settle(now)
        self.sensors[axis_index] = sensors
        self.model._recompute()

    def machine_position(self, axis_index: int, now: float) -> int:
        """Position in the machine frame, where the sensors sit."""
        self.model.settle(now)
        return self.model._lp(axis_index, now) + self.status[axis_index].mach_off

    def set_alarm_input(self, axis_index: int, asserted: bool, now: float) -> None:
        """The servo drive raises (or drops) its ALARM output."""
        self.model.settle(now)
        self.status[axis_index].alarm_input = asserted
        self._check_alarm(axis_index, now)
        self.model._recompute()

    def set_emg_input(self, asserted: bool, now: float) -> None:
        """The EMG input (common to the four axes) is asserted or released."""
        self.model.settle(now)
        self.emg_input = asserted
        if asserted:
            for i in range(len(mm.AXES)):
                self.status[i].errors |= ERR_EMERGENCY
            self._halt_all(now, sudden=True)
        self.model._recompute()

    def set_in3(self, axis_index: int, level: int, now: float) -> None:
        """Drive the IN3 input of an axis to an electrical level (0 low = on, 1 high)."""
        self.model.settle(now)
        st = self.status[axis_index]
        old, st.in3_level = st.in3_level, 1 if level else 0
        if old != st.in3_level:
            self._sync(axis_index, SYNC_IN3_UP if st.in3_level else SYNC_IN3_DOWN, now)
        self.model._recompute()

    # -------------------------------------------------------- input settings (3.5-3.13)
    def set_hlmt(self, axis_mask: int, plus_level: int, minus_level: int, now: float) -> None:
        self._configure(axis_mask, now, hlmt_plus_level=int(plus_level) & 1,
                        hlmt_minus_level=int(minus_level) & 1)

    def set_limit_stop(self, axis_mask: int, mode: int, now: float) -> None:
        self._configure(axis_mask, now, limit_stop_slow=mode == 1)

    def set_nhome(self, axis_mask: int, level: int, now: float) -> None:
        self._configure(axis_mask, now, nhome_level=int(level) & 1)

    def set_home_edge(self, axis_mask: int, level: int, now: float) -> None:
        self._configure(axis_mask, now, home_level=int(level) & 1)

    def set_z_edge(self, axis_mask: int, level: int, now: float) -> None:
        """SET_ENCODER's nZEdge (the other encoder settings do not change an ideal encoder)."""
        self._configure(axis_mask, now, z_level=int(level) & 1)

    def set_alarm(self, axis_mask: int, enabled: int, level: int, now: float) -> None:
        self._configure(axis_mask, now, alarm_enabled=enabled == 1, alarm_level=int(level) & 1)
        for i in _axes(axis_mask):
            self._check_alarm(i, now)
        self.model._recompute()

    def set_inpos(self, axis_mask: int, enabled: int, level: int, now: float) -> None:
        self._configure(axis_mask, now, inpos_enabled=enabled == 1, inpos_level=int(level) & 1)

    def set_slmt(self, axis_mask: int, forward: int, reverse: int, use_ep: int,
                 now: float) -> None:
        self._configure(axis_mask, now, slmt=True, comp_plus=int(forward),
                        comp_minus=int(reverse), comp_ep=use_ep == 1)

    def clear_slmt(self, axis_mask: int, now: float) -> None:
        self._configure(axis_mask, now, slmt=False)

    def store_slmt_disabled(self, axis_mask: int, forward: int, reverse: int, use_ep: int,
                            now: float) -> None:
        """The initial table loading software limits that it keeps disabled: the values go
        into the comparators and the limits are off, in one step (SET_SLMT then CLEAR_SLMT
        would enable them for an instant and stop an axis already beyond them)."""
        self._configure(axis_mask, now, slmt=False, comp_plus=int(forward),
                        comp_minus=int(reverse), comp_ep=use_ep == 1)

    def servo(self, axis_mask: int, on: bool) -> None:
        for i in _axes(axis_mask):
            self.status[i].servo_on = on

    def _configure(self, axis_mask: int, now: float, **values: object) -> None:
        self.model.settle(now)
        for i in _axes(axis_mask):
            for name, value in values.items():
                setattr(self.cfg[i], name, value)
        self.model._recompute()

    # ------------------------------------------------------------ home search (ch. 6)
    def set_hv(self, axis: int, speed: int) -> None:
        self.cfg[_one_axis(axis)].hv = int(speed)

    def home_limit(self, axis: int, use_limit: int) -> None:
        self.cfg[_one_axis(axis)].home_limit = use_limit == 1

    def set_home_mode(self, axis: int, step1: int, step2: int, step3: int, step4: int,
                      offset: int) -> None:
        if offset < 0:
            raise ValueError(f"home offset must be 0..2000000000, got {offset}")
        cfg = self.cfg[_one_axis(axis)]
        cfg.home_steps = (_direction(step1), _direction(step2), _direction(step3),
                          _direction(step4))
        cfg.home_offset = int(offset)

    def home_start(self, axis: int, now: float) -> None:
        """HOME_START: queued like a move; the search occupies the axis until it ends."""
        i = _one_axis(axis)

        def build(model: MotionModel, t: float) -> _Motion | None:
            model.io._home_begin(i, t)  # `model`, not self: idle_at runs copies
            return None  # the search installs its own motions

        self.model._issue(mm._Cmd((i,), False, build), now)

    def home_state(self, axis: int, now: float) -> int:
        self.model.settle(now)
        run = self.status[_one_axis(axis)].home
        return run.state if run is not None else HOME_IDLE

    # ---------------------------------------------------------------- errors (4.9)
    def error_code(self, axis: int, now: float) -> int:
        self.model.settle(now)
        return self.status[_one_axis(axis)].errors

    def error_state(self, now: float) -> int:
        """GET_ERROR / register 70: 1 if any axis has an error bit."""
        self.model.settle(now)
        return int(any(st.errors for st in self.status))

    def clear_stop(self, axis_mask: int, now: float) -> None:
        self.model.settle(now)
        for i in _axes(axis_mask):
            self._clear_errors(i)

    def clear_vstop(self, now: float) -> None:
        self.model.settle(now)
        for i in self.model.assigned:
            self._clear_errors(i)

    def _clear_errors(self, i: int) -> None:
        keep = 0
        if self.emergency:
            keep |= ERR_SOFT_EMG
        if self.emg_input:
            keep |= ERR_EMERGENCY
        if self._alarm_active(i):
            keep |= ERR_ALARM
        self.status[i].errors &= keep

    # ------------------------------------------------------ emergency stop (7.5.10-11)
    def emergency_stop(self, sudden: bool, now: float) -> None:
        model = self.model
        model.settle(now)
        self.emergency = True
        model._queue.clear()
        model._pending.clear()
        for st in self.status:
            st.errors |= ERR_SOFT_EMG
        self._halt_all(now, sudden)
        model._recompute()

    def clear_emergency(self, now: float) -> None:
        self.model.settle(now)
        self.emergency = False
        for st in self.status:
            st.errors &= ~ERR_SOFT_EMG

    # --------------------------------------------------------- compare / latch / sync
    def set_compare(self, axis: int, select: int, use_ep: int, value: int, now: float) -> None:
        """SET_COMPARE: nSELECT 0 = COMP+, 1 = COMP-; also turns the software limit off."""
        i = _one_axis(axis)
        name = "comp_plus" if select == 0 else "comp_minus"
        self._configure(1 << i, now, **{name: int(value), "comp_ep": use_ep == 1,
                                        "slmt": False})

    def latch(self, axis: int, now: float) -> int:
        self.model.settle(now)
        return self.status[_one_axis(axis)].latch

    def set_activation_factors(self, axis_mask: int, factors: int, now: float) -> None:
        self._configure(axis_mask, now, sync_factors=int(factors) & 0xFF)

    def set_activation_axis(self, axis_mask: int, targets: int, now: float) -> None:
        _axes(targets)
        self._configure(axis_mask, now, sync_targets=int(targets))

    def set_action(self, axis_mask: int, drv: int, latch: int, preset: int, out: int,
                   intr: int, isrs: tuple[int, int, int, int]) -> None:
        for i in _axes(axis_mask):
            self.cfg[i].action = _Action(drv, latch, preset, out, intr, isrs)

    def sync_action(self, axis1: int, axis2: int, factors: int, drv: int, latch: int,
                    preset: int, out: int, intr: int, isrs: tuple[int, int, int, int],
                    now: float) -> None:
        """SYNC_ACTION = SET_ACTIVATION_FACTORS + SET_ACTIVATION_AXIS + SET_ACTION."""
        i = _one_axis(axis1)
        self.set_action(axis2, drv, latch, preset, out, intr, isrs)
        self._configure(1 << i, now, sync_factors=int(factors) & 0xFF, sync_targets=int(axis2))

    def clear_sync_action(self, axis_mask: int, now: float) -> None:
        self._configure(axis_mask, now, sync_factors=0, sync_targets=0)

    def set_preset(self, axis_mask: int, value: int) -> None:
        for i in _axes(axis_mask):
            self.cfg[i].preset = int(value)

    # ------------------------------------------------------------ interrupts (7.3.10-13)
    def enable_int(self, now: float) -> None:
        self.model.settle(now)
        self.int_enabled = True
        self.model._recompute()

    def disable_int(self, now: float) -> None:
        self.model.settle(now)
        self.int_enabled = False
        self.requests.clear()
        self.model._recompute()

    def intfactor_enable(self, axis: int, factor: int, isr: int, now: float) -> None:
        if not 0 <= factor <= 7:
            raise ValueError(f"interrupt factor must be 0..7, got {factor}")
        i = _one_axis(axis)
        self.model.settle(now)
        self.cfg[i].int_factors[factor] = int(isr)
        self.triggered[factor] &= ~(1 << i)
        self.model._recompute()

    def intfactor_disable(self, axis_mask: int, factor: int, now: float) -> None:
        self.model.settle(now)
        for i in _axes(axis_mask):
            factors = self.cfg[i].int_factors
            if factor == 10:
                factors.clear()
            else:
                factors.pop(factor, None)
            self.requests = [r for r in self.requests
                             if r.axis != i or (factor != 10 and r.factor != factor)]
        self.model._recompute()

    def triggered_factors(self, now: float) -> tuple[int, ...]:
        """Registers 130-139: per factor, the mask of axes that triggered it."""
        self.model.settle(now)
        return tuple(self.triggered)

    def take_interrupts(self, until: float) -> list[tuple[float, int]]:
        self.model.settle(until)
        due = [r for r in self.requests if r.time <= until]
        if not due:
            return []
        self.requests = [r for r in self.requests if r.time > until]
        self.model._recompute()  # a taken PULSE request lets the next pulse ask again
        return [(r.time, r.isr) for r in sorted(due, key=lambda r: r.time)]

    def next_interrupt(self, now: float) -> float | None:
        """Earliest pending request, or the time the present motions will raise the next
        one (predicted on a copy; cached until the motion or I/O state changes)."""
        self.model.settle(now)
        if self.requests:
            return min(r.time for r in self.requests)
        if not self._may_interrupt():
            return None
        if self._prediction is not None and self._prediction[0] == self._version:
            return self._prediction[1]
        sim = copy.deepcopy(self.model)
        t = now
        when: float | None = None
        for _ in range(100_000):
            nxt = sim.next_event(t)
            if nxt is None:
                break
            sim.settle(nxt)
            if sim.io.requests:
                when = min(r.time for r in sim.io.requests)
                break
            t = nxt
        self._prediction = (self._version, when)
        return when

    def _may_interrupt(self) -> bool:
        if not self.int_enabled:
            return False
        return any(c.int_factors or (c.action is not None and c.action.intr) for c in self.cfg)

    # -------------------------------------------------------------------- report (12.x)
    def report(self, i: int, now: float) -> AxisReport:
        model = self.model
        model.settle(now)
        st = self.status[i]
        lp = model._lp(i, now)
        phys = lp + st.mach_off
        driving = model._ax[i].motion is not None
        lmt_p = self._signal(i, "lmt+").active(phys)
        lmt_m = self._signal(i, "lmt-").active(phys)
        home = self._signal(i, "home").active(phys)
        nhome = self._signal(i, "nhome").active(phys)
        index = self._signal(i, "index").active(phys)
        alarm_raw = self._alarm_signal(i)
        inpos = st.servo_on and not driving
        status = (int(driving) | int(lmt_p) << 1 | int(lmt_m) << 2 | int(self.emg_input) << 3
                  | int(alarm_raw and self.cfg[i].alarm_enabled) << 4 | int(not home) << 5
                  | int(not nhome) << 6 | st.in3_level << 7 | int(not inpos) << 8
                  | int(not index) << 9)
        signal = (int(not nhome) | int(not home) << 1 | int(not index) << 2
                  | st.in3_level << 3 | int(inpos) << 6 | int(alarm_raw) << 7)
        causes = st.errors & 0x1FF
        if st.errors & ERR_SOFT_EMG:
            causes |= ERR_EMERGENCY
        run = st.home
        return AxisReport(
            axis=i, time=now, lp=lp, ep=lp + model._ax[i].ep_off, machine_position=phys,
            driving=driving, di_status=status, di_signal=signal, error_code=st.errors,
            stop_causes=causes, stopped=not driving, servo_on=st.servo_on,
            emergency=self.emergency, home_state=run.state if run is not None else HOME_IDLE,
            home_end=st.home_end, latch=st.latch)

    # --------------------------------------------------------------- signals and levels
    def _signal(self, i: int, kind: str) -> _Signal:
        sensors, cfg = self.sensors[i], self.cfg[i]
        sig: _Signal
        if kind == "lmt+":
            lp = sensors.limit_plus
            sig, level = _Intervals([] if lp is None else [(lp, None)]), cfg.hlmt_plus_level
        elif kind == "lmt-":
            lm = sensors.limit_minus
            sig, level = _Intervals([] if lm is None else [(None, lm)]), cfg.hlmt_minus_level
        elif kind in ("home", "nhome"):
            span = sensors.home if kind == "home" else sensors.near_home
            sig = _Intervals([] if span is None else [span])
            level = cfg.home_level if kind == "home" else cfg.nhome_level
        else:
            if sensors.index_period is None:
                sig = _Intervals([])
            else:
                sig = _Periodic(sensors.index_period, sensors.index_offset,
                                min(sensors.index_width, sensors.index_period))
            level = cfg.z_level
        if sensors.wiring is None or sensors.wiring == level:
            return sig
        return sig.complement()

    def _alarm_signal(self, i: int) -> bool:
        wiring = self.sensors[i].wiring
        asserted = self.status[i].alarm_input
        if wiring is None:
            return asserted
        return (wiring if asserted else 1 - wiring) == self.cfg[i].alarm_level

    def _alarm_active(self, i: int) -> bool:
        return self.cfg[i].alarm_enabled and self._alarm_signal(i)

    def _check_alarm(self, i: int, now: float) -> None:
        if not self._alarm_active(i):
            return
        self.status[i].errors |= ERR_ALARM
        for m in self.model._motions():
            if i in m.axes:
                self._halt(m, now, sudden=True)

    # ------------------------------------------------------------ motion-model hooks
    def refuses(self, axes: tuple[int, ...], t: float) -> bool:
        """A command about to start: dropped in an emergency, on EMG or an active ALARM."""
        if self.emergency:
            return True
        if self.emg_input:
            for i in axes:
                self.status[i].errors |= ERR_EMERGENCY
            return True
        alarmed = [i for i in axes if self._alarm_active(i)]
        for i in alarmed:
            self.status[i].errors |= ERR_ALARM
        return bool(alarmed)

    def lp_moved(self, i: int, delta: int) -> None:
        """SET_LP moved the counter, not the axis: keep the machine frame where it was."""
        self.status[i].mach_off -= delta

    def started(self, m: _Motion, t: float) -> None:
        """A drive starts: D-STA, and C-STA if it starts at constant speed."""
        cruise_now = bool(m.prof.segs) and self._cruise(m.prof.segs[0])
        for i in m.axes:
            self._sync(i, SYNC_D_STA, t)
            if cruise_now:
                self._interrupt(i, INT_C_STA, t)

    def ended(self, m: _Motion, t: float) -> None:
        """A motion finished in `settle`: next home-search step, or D-END."""
        for i in m.axes:
            run = self.status[i].home
            if run is not None and run.motion is m:
                self._home_motion_ended(run, t)
            else:
                self._drive_end(i, t)

    def stopping(self, m: _Motion, now: float, sudden: bool) -> None:
        """A STOP_/VSTOP_ command is about to stop m: SOFT STOP, C-END, end of a search."""
        _s, v, _a = m.prof.state(now - m.t0)
        ends_now = sudden or v <= m.plan.sv + 1e-9
        cruising = self._cruising(m, now)
        for i in m.axes:
            self.status[i].errors |= ERR_SOFT_STOP
            if cruising:
                self._interrupt(i, INT_C_END, now)
            run = self.status[i].home
            if run is not None and run.motion is m:
                self._home_finish(run, now, success=False, d_end=ends_now)
            elif ends_now:
                self._drive_end(i, now)

    def quiet(self) -> bool:
        """No I/O event ahead and no home search running: motion ends are the whole story."""
        return self._next == _INF and all(st.home is None for st in self.status)

    # -------------------------------------------------------------------- scheduling
    def reschedule(self) -> float:
        """Earliest I/O event of the present motions (called by MotionModel._recompute)."""
        self._version += 1
        self._exempt = [m for m in self._exempt
                        if any(self.model._ax[i].motion is m for i in m.axes)]
        events: list[_Event] = []
        for m in self.model._motions():
            self._plan(m, events)
        events.sort()
        self._events = events
        self._next = events[0].time if events else _INF
        return self._next

    def fire(self, t: float) -> None:
        """Handle, in order, the I/O events due at or before t (called by settle)."""
        self.now = max(self.now, t)
        for _ in range(10_000):
            if not self._events or self._events[0].time > t:
                return
            first = self._events[0].time
            batch = [e for e in self._events if e.time <= first]
            for e in batch:
                self._handle(e, max(e.time, self.now))
            self.model._recompute()
        # every handled event changes the state that produced it; looping here is a bug
        raise RuntimeError(f"axis I/O events keep recurring at t={t}")

    def advance(self, now: float) -> None:
        """settle(now) is done: the present time for the next schedule."""
        if now > self.now:
            self.now = now

    def _plan(self, m: _Motion, out: list[_Event]) -> None:
        now = self.now
        exempt = any(m is e for e in self._exempt)
        for k, i in enumerate(m.axes):
            st, cfg = self.status[i], self.cfg[i]
            run = st.home if st.home is not None and st.home.motion is m else None
            if run is None and not self._watched(i, exempt):
                continue
            ax = self.model._ax[i]
            lp = self.model._lp(i, now)
            base = ax.shift  # path position = LP - shift (before rounding)
            mach = base + st.mach_off
            d = self._heading(m, k, now)
            if run is not None and not run.stopping:
                self._plan_home(run, m, k, lp + st.mach_off, mach, out)
            if not exempt:
                skip = (run is not None and run.state == HOME_STEP2 and cfg.home_limit)
                for sign, kind, rank in ((1, "lmt+", 0), (-1, "lmt-", 0)):
                    if skip and sign == self._home_dirs(i)[1]:
                        continue
                    sig = self._signal(i, kind)
                    if sig.empty():
                        continue
                    p = lp + st.mach_off
                    if sig.active(p):
                        if d == sign:
                            out.append(_Event(now, rank, "limit", i, sign, m))
                        continue
                    target = sig.next_change(p, sign)
                    if target is not None:
                        level = target - 0.5 * sign - mach
                        t = _crossing(m, k, level, sign > 0, now)
                        if t is not None:
                            out.append(_Event(t, rank, "limit", i, sign, m))
                if cfg.slmt:
                    counter = lp + (ax.ep_off if cfg.comp_ep else 0)
                    off = base + (ax.ep_off if cfg.comp_ep else 0)
                    if counter >= cfg.comp_plus and d > 0:
                        out.append(_Event(now, 1, "slimit", i, 1, m))
                    elif counter < cfg.comp_plus:
                        t = _crossing(m, k, cfg.comp_plus - 0.5 - off, True, now)
                        if t is not None:
                            out.append(_Event(t, 1, "slimit", i, 1, m))
                    if counter < cfg.comp_minus and d < 0:
                        out.append(_Event(now, 1, "slimit", i, -1, m))
                    elif counter >= cfg.comp_minus:
                        t = _crossing(m, k, cfg.comp_minus - 0.5 - off, False, now)
                        if t is not None:
                            out.append(_Event(t, 1, "slimit", i, -1, m))
            self._plan_compare(m, k, i, now, out)

    def _watched(self, i: int, exempt: bool) -> bool:
        """Could a motion of axis i meet any I/O event? (The common answer is no.)"""
        cfg, sensors = self.cfg[i], self.sensors[i]
        if not exempt and (cfg.slmt or sensors.wiring is not None
                           or sensors.limit_plus is not None
                           or sensors.limit_minus is not None):
            return True
        if self.int_enabled and cfg.int_factors:
            return True
        return bool(cfg.sync_targets and cfg.sync_factors & 0x0F)

    def _plan_compare(self, m: _Motion, k: int, i: int, now: float,
                      out: list[_Event]) -> None:
        cfg = self.cfg[i]
        ax = self.model._ax[i]
        ints = set(cfg.int_factors) if self.int_enabled else set()
        sync = cfg.sync_factors if cfg.sync_targets else 0
        off = ax.shift + (ax.ep_off if cfg.comp_ep else 0)
        # (register value, rising, interrupt factor, sync factor, event arg)
        for value, rising, factor, bit, arg in (
                (cfg.comp_plus, True, INT_P_GE_CPLUS, SYNC_P_GE_CPLUS, 0),
                (cfg.comp_plus, False, INT_P_LT_CPLUS, SYNC_P_LT_CPLUS, 1),
                (cfg.comp_minus, True, INT_P_GE_CMINUS, SYNC_P_GE_CMINUS, 2),
                (cfg.comp_minus, False, INT_P_LT_CMINUS, SYNC_P_LT_CMINUS, 3)):
            if factor in ints or sync & bit:
                t = _crossing(m, k, value - 0.5 - off, rising, now)
                if t is not None:
                    out.append(_Event(t, 3, "cmp", i, arg, m))
        if INT_PULSE in ints and not self._pending(i, INT_PULSE):
            lp = self.model._lp(i, now)
            for level, rising in ((lp + 0.5 - ax.shift, True), (lp - 0.5 - ax.shift, False)):
                t = _crossing(m, k, level, rising, now)
                if t is not None:
                    out.append(_Event(t, 4, "pulse", i, 0, m))
        if INT_C_STA in ints or INT_C_END in ints:
            prof = m.prof
            for n, seg in enumerate(prof.segs):
                if not self._cruise(seg):
                    continue
                start = m.t0 + prof.starts[n]
                stop = m.t0 + (prof.starts[n + 1] if n + 1 < len(prof.segs) else prof.duration)
                if INT_C_STA in ints and start > now:
                    out.append(_Event(start, 4, "cruise", i, INT_C_STA, m))
                if INT_C_END in ints and now < stop < _INF:
                    out.append(_Event(stop, 4, "cruise", i, INT_C_END, m))

    @staticmethod
    def _cruise(seg: tuple[float, float, float, float]) -> bool:
        _p, v, a, j = seg
        return v > 0.0 and a == 0.0 and j == 0.0

    def _cruising(self, m: _Motion, t: float) -> bool:
        prof = m.prof
        tau = t - m.t0
        if not prof.segs or tau >= prof.duration:
            return False
        n = max(0, min(len(prof.segs) - 1, sum(1 for s in prof.starts if s <= tau) - 1))
        return self._cruise(prof.segs[n])

    @staticmethod
    def _heading(m: _Motion, k: int, t: float) -> int:
        """Sign of the axis velocity at t (0 if it does not move along that axis)."""
        s, v, _a = m.prof.state(t - m.t0)
        if v <= 0.0:
            return 0
        d = m.path.deriv(k, s)
        return 1 if d > 1e-12 else (-1 if d < -1e-12 else 0)

    # ---------------------------------------------------------------------- handlers
    def _handle(self, e: _Event, t: float) -> None:
        m = e.motion
        i = e.axis
        current = m is not None and self.model._ax[i].motion is m
        if e.kind == "limit":
            if current and m is not None:
                self._on_limit(i, e.arg, m, t)
        elif e.kind == "slimit":
            if current and m is not None:
                self.status[i].errors |= (ERR_SOFT_LIMIT_PLUS if e.arg > 0
                                          else ERR_SOFT_LIMIT_MINUS)
                run = self.status[i].home
                if run is not None and run.motion is m:
                    self._home_finish(run, t, success=False, halt=m)
                else:
                    self._halt(m, t, sudden=False)
        elif e.kind == "home":
            run = self.status[i].home
            if current and run is not None and run.motion is m:
                self._home_signal(run, t)
        elif e.kind == "cmp":
            factor, bit = ((INT_P_GE_CPLUS, SYNC_P_GE_CPLUS), (INT_P_LT_CPLUS, SYNC_P_LT_CPLUS),
                           (INT_P_GE_CMINUS, SYNC_P_GE_CMINUS),
                           (INT_P_LT_CMINUS, SYNC_P_LT_CMINUS))[e.arg]
            self._interrupt(i, factor, t)
            self._sync(i, bit, t)
        elif e.kind == "pulse":
            self._interrupt(i, INT_PULSE, t)
        elif e.kind == "cruise":
            self._interrupt(i, e.arg, t)

    def _on_limit(self, i: int, sign: int, m: _Motion, t: float) -> None:
        run = self.status[i].home
        if run is not None and run.motion is m:
            self._home_limit(run, sign, t)
            return
        self.status[i].errors |= ERR_LIMIT_PLUS if sign > 0 else ERR_LIMIT_MINUS
        self._halt(m, t, sudden=not self.cfg[i].limit_stop_slow)

    def _halt(self, m: _Motion, t: float, sudden: bool, d_end: bool = True,
              exempt: bool = True) -> bool:
        """Stop motion m at t (whole interpolation); returns True if it ended at once.
        A decelerating remainder is `exempt` from further limit stops unless told not."""
        model = self.model
        if not any(model._ax[i].motion is m for i in m.axes):
            return True
        cruising = self._cruising(m, t)
        model._stop_motion(m, t, sudden)
        still = model._ax[m.axes[0]].motion
        ended = still is None
        if not ended and still is not None and exempt:
            self._exempt.append(still)
        for i in m.axes:
            if cruising:
                self._interrupt(i, INT_C_END, t)
            run = self.status[i].home
            if run is not None and run.motion is m:
                run.motion = still
            if ended and d_end:
                self._drive_end(i, t)
        return ended

    def _halt_all(self, now: float, sudden: bool) -> None:
        for m in self.model._motions():
            for i in m.axes:
                run = self.status[i].home
                if run is not None and run.motion is m:
                    self._home_finish(run, now, success=False, halt=m, sudden=sudden)
            self._halt(m, now, sudden)

    def _drive_end(self, i: int, t: float) -> None:
        self._interrupt(i, INT_D_END, t)
        self._sync(i, SYNC_D_END, t)

    def _pending(self, i: int, factor: int) -> bool:
        return any(r.axis == i and r.factor == factor for r in self.requests)

    def _interrupt(self, i: int, factor: int, t: float) -> None:
        if not self.int_enabled:
            return
        isr = self.cfg[i].int_factors.get(factor)
        if isr is None:
            return
        self.triggered[factor] |= 1 << i
        if not self._pending(i, factor):
            self.requests.append(_Request(t, isr, i, factor))

    def _sync(self, i: int, bit: int, t: float) -> None:
        cfg = self.cfg[i]
        if not cfg.sync_factors & bit or not cfg.sync_targets:
            return
        for j in _axes(cfg.sync_targets):
            self._act(j, t)

    def _act(self, j: int, t: float) -> None:
        """Run the synchronous action of activation axis j."""
        model = self.model
        action = self.cfg[j].action
        self.triggered[FACTOR_SYNC] |= 1 << j
        if action is None:
            return
        ax = model._ax[j]
        value = self.cfg[j].preset
        if action.latch in (1, 2):
            lp = model._lp(j, t)
            self.status[j].latch = lp if action.latch == 1 else lp + ax.ep_off
        if action.preset == 1:
            self._preset(j, t, lp=value)
        elif action.preset == 2:
            self._preset(j, t, ep=value)
        elif action.preset == 4:
            model.settings[j].v = value
            m = ax.motion
            if m is not None and m.continuous and not m.vector and value > 0:
                base = mm._single_plan(model.settings[j])
                plan = mm._Plan(min(base.sv, base.v), base.v, base.acc, base.dec,
                                base.s_curve)
                model._change_speed(j, m, plan, t)
        busy = ax.motion is not None or any(j in c.axes for c in model._queue)
        if action.drv in (1, 2) and not busy and value != 0:
            pulses = value if action.drv == 1 else -value
            model._start(mm._single_cmd(j, pulses, False, mm._single_plan(model.settings[j])),
                         t)
        elif action.drv in (3, 4) and not busy:
            base = mm._single_plan(model.settings[j])
            plan = mm._Plan(min(base.sv, base.v), base.v, base.acc, base.dec, base.s_curve)
            direction = 1 if action.drv == 3 else -1
            model._start(mm._Cmd((j,), False, mm._continuous_builder(j, direction, plan)), t)
        elif action.drv in (5, 6):
            for m in model._motions():
                if j in m.axes:
                    run = self.status[j].home
                    if run is not None and run.motion is m:
                        self._home_finish(run, t, success=False, halt=m,
                                          sudden=action.drv == 6)
                    else:
                        self._halt(m, t, sudden=action.drv == 6)
        if action.intr and self.int_enabled:
            isr = action.isrs[j]
            if isr and not self._pending(j, FACTOR_SYNC):
                self.requests.append(_Request(t, isr, j, FACTOR_SYNC))

    def _preset(self, i: int, t: float, lp: int | None = None, ep: int | None = None) -> None:
        """SET_LP / SET_EP at time t from inside an event (no settle: we are in it)."""
        ax = self.model._ax[i]
        if lp is not None:
            delta = lp - self.model._lp(i, t)
            if ax.motion is None:
                ax.pos += delta
            else:
                ax.shift += delta
            ax.ep_off -= delta
            self.status[i].mach_off -= delta
        if ep is not None:
            ax.ep_off = ep - self.model._lp(i, t)

    # ------------------------------------------------------------ home-search machine
    def _home_dirs(self, i: int) -> tuple[int, int, int, int]:
        return self.cfg[i].home_steps

    def _home_begin(self, i: int, t: float) -> None:
        st = self.status[i]
        st.home = run = _HomeRun(i)
        self._sync(i, SYNC_D_STA, t)
        self._home_step1(run, t)

    def _phys(self, i: int, t: float) -> int:
        return self.model._lp(i, t) + self.status[i].mach_off

    def _home_signal_of(self, i: int, d2: int) -> _Signal:
        """Step 2's home signal: HOME, or the limit of the search direction (HOME_LIMIT)."""
        if self.cfg[i].home_limit:
            return self._signal(i, "lmt+" if d2 > 0 else "lmt-")
        return self._signal(i, "home")

    def _home_step1(self, run: _HomeRun, t: float) -> None:
        i = run.axis
        d1 = self._home_dirs(i)[0]
        if d1 == 0 or self._signal(i, "nhome").active(self._phys(i, t)):
            self._home_step2(run, t)
            return
        run.state = HOME_STEP1
        base = mm._single_plan(self.model.settings[i])
        plan = mm._Plan(min(base.sv, base.v), base.v, base.acc, base.dec, base.s_curve)
        prof = mm._Profile(0.0, plan.sv)
        mm._ramp(prof, plan.sv, plan.v, plan.acc, plan.s_curve)
        prof.forever()
        self._home_drive(run, t, prof, d1, plan)

    def _home_step2(self, run: _HomeRun, t: float) -> None:
        i = run.axis
        d2 = self._home_dirs(i)[1]
        run.stopping = False
        if d2 == 0:
            self._home_step3(run, t)
            return
        p = self._phys(i, t)
        limit = self._signal(i, "lmt+" if d2 > 0 else "lmt-")
        if self.cfg[i].home_limit:
            state = HOME_BACK_OFF if limit.active(p) else HOME_STEP2
        elif limit.active(p):
            state = HOME_BACK_ON
        elif self._signal(i, "home").active(p):
            state = HOME_BACK_OFF
        else:
            state = HOME_STEP2
        self._home_creep(run, t, state)

    def _home_creep(self, run: _HomeRun, t: float, state: int) -> None:
        """A constant-speed HV drive of step 2 or 3 (backwards in states 8 and 12)."""
        i = run.axis
        dirs = self._home_dirs(i)
        d = {HOME_BACK_ON: -dirs[1], HOME_BACK_OFF: -dirs[1], HOME_STEP2: dirs[1],
             HOME_STEP3: dirs[2]}[state]
        run.state = state
        hv = mm._quantise(self.cfg[i].hv, self.model.settings[i].max_v)
        plan = mm._Plan(hv, hv, 1.0, 1.0, False, constant=True)
        prof = mm._Profile(0.0, hv)
        prof.forever()
        self._home_drive(run, t, prof, d, plan)

    def _home_drive(self, run: _HomeRun, t: float, prof: mm._Profile, d: int,
                    plan: mm._Plan, final: tuple[int, ...] = ()) -> None:
        i = run.axis
        ax = self.model._ax[i]
        path = mm._LinePath((ax.pos,), (d,), 1.0)
        m = mm._Motion((i,), t, prof, path, final, plan, False, d if not final else 0)
        ax.motion = m
        run.motion = m

    def _home_step3(self, run: _HomeRun, t: float) -> None:
        i = run.axis
        d3 = self._home_dirs(i)[2]
        if d3 == 0:
            self._home_step4(run, t)
            return
        p = self._phys(i, t)
        if self._signal(i, "index").active(p) and self._signal(i, "home").active(p):
            self.status[i].errors |= ERR_HOME
            self._home_finish(run, t, success=False)
            return
        self._home_creep(run, t, HOME_STEP3)

    def _home_step4(self, run: _HomeRun, t: float) -> None:
        i = run.axis
        d4 = self._home_dirs(i)[3]
        offset = self.cfg[i].home_offset
        if d4 == 0 or offset == 0:
            self._home_finish(run, t, success=True)
            return
        run.state = HOME_STEP4
        plan = mm._single_plan(self.model.settings[i])
        prof = mm._point_to_point(float(offset), plan)
        pos = self.model._ax[i].pos
        self._home_drive(run, t, prof, d4, plan, (pos + d4 * offset,))

    def _plan_home(self, run: _HomeRun, m: _Motion, k: int, p: int, mach: int,
                   out: list[_Event]) -> None:
        """The sensor edge the present step waits for, as an event."""
        i = run.axis
        dirs = self._home_dirs(i)
        if run.state == HOME_STEP1:
            sig, d, want = self._signal(i, "nhome"), dirs[0], True
        elif run.state in (HOME_BACK_ON, HOME_BACK_OFF, HOME_STEP2):
            sig = self._home_signal_of(i, dirs[1])
            d = dirs[1] if run.state == HOME_STEP2 else -dirs[1]
            want = run.state != HOME_BACK_OFF
        elif run.state == HOME_STEP3:
            sig, d, want = self._signal(i, "index"), dirs[2], True
        else:
            return
        target = sig.next_change(p, d)
        if target is not None and sig.active(p) == want:
            target = sig.next_change(target, d)  # leave first, then the next edge
        if target is None:
            return
        t = _crossing(m, k, target - 0.5 * d - mach, d > 0, self.now)
        if t is not None:
            out.append(_Event(t, 2, "home", i, 0, m))

    def _home_signal(self, run: _HomeRun, t: float) -> None:
        """The edge the present step waited for has come."""
        m = run.motion
        assert m is not None
        if run.state == HOME_STEP1:
            run.stopping = True
            if self._halt(m, t, sudden=False, d_end=False, exempt=False):
                self._home_step2(run, t)
        elif run.state == HOME_BACK_ON:
            run.state = HOME_BACK_OFF  # keep going until HOME turns off again
        elif run.state == HOME_BACK_OFF:
            self._halt(m, t, sudden=True, d_end=False)
            self._home_creep(run, t, HOME_STEP2)
        elif run.state == HOME_STEP2:
            self._halt(m, t, sudden=True, d_end=False)
            self._home_step3(run, t)
        elif run.state == HOME_STEP3:
            self._halt(m, t, sudden=True, d_end=False)
            self._home_step4(run, t)

    def _home_limit(self, run: _HomeRun, sign: int, t: float) -> None:
        """A limit reached during the search: irregular operation or the end of it."""
        i = run.axis
        m = run.motion
        assert m is not None
        dirs = self._home_dirs(i)
        if run.state == HOME_STEP1 and sign == dirs[0]:
            run.stopping = True
            if self._halt(m, t, sudden=not self.cfg[i].limit_stop_slow, d_end=False):
                self._home_step2(run, t)
        elif run.state == HOME_STEP2 and sign == dirs[1] and not self.cfg[i].home_limit:
            self._halt(m, t, sudden=True, d_end=False)
            self._home_creep(run, t, HOME_BACK_ON)
        else:
            self.status[i].errors |= ERR_LIMIT_PLUS if sign > 0 else ERR_LIMIT_MINUS
            self._home_finish(run, t, success=False, halt=m,
                              sudden=not self.cfg[i].limit_stop_slow)

    def _home_motion_ended(self, run: _HomeRun, t: float) -> None:
        if run.stopping:
            self._home_step2(run, t)
        elif run.state == HOME_STEP4:
            run.motion = None
            self._home_finish(run, t, success=True)

    def _home_finish(self, run: _HomeRun, t: float, success: bool,
                     halt: _Motion | None = None, sudden: bool = True,
                     d_end: bool = True) -> None:
        """End of the search: clear LP/EP on success, HMEND, D-END."""
        i = run.axis
        st = self.status[i]
        st.home = None
        st.home_end = t
        self.triggered[FACTOR_HMEND] |= 1 << i
        ended = True
        if halt is not None:
            ended = self._halt(halt, t, sudden, d_end=False)
        if success:
            self._preset(i, t, lp=0, ep=0)
        if d_end and ended:
            self._drive_end(i, t)
