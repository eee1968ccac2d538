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

`AxisIO` is built in layers, each in its own module: the shared state, codes and input
levels (`io_state`), interrupt factors (`interrupts`), compare, latch and synchronous actions
with the halting of drives (`sync_actions`), the home search (`homing`); this module adds
the machine's inputs and their settings, errors, the emergency stop, the register report, the
hooks the motion model calls and the scheduling of I/O events.  The sensors and their signals
are in `signals`, the crossing-time solvers in `crossings`.

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
* SERVO_ON/OFF only set the servo state (coils 128-131); pulses are output either way.
  INPOS is "on" while the servo is on and the axis does not drive (an ideal drive).
  Table 25 prints INPOS as 0: on (bit 8 of the status word) while table 27 prints INP as
  1: on (bit 6 of the signal word); each word follows its own table.
"""

from __future__ import annotations

import math

from mplang.m8194h.sim import profiles
from mplang.m8194h.sim.builders import _Motion
from mplang.m8194h.sim.crossings import _crossing

# the codes AxisIO takes and returns, and its records: callers import them from here
from mplang.m8194h.sim.io_state import ERR_ALARM as ERR_ALARM
from mplang.m8194h.sim.io_state import ERR_EMERGENCY as ERR_EMERGENCY
from mplang.m8194h.sim.io_state import ERR_HOME as ERR_HOME
from mplang.m8194h.sim.io_state import ERR_LIMIT_MINUS as ERR_LIMIT_MINUS
from mplang.m8194h.sim.io_state import ERR_LIMIT_PLUS as ERR_LIMIT_PLUS
from mplang.m8194h.sim.io_state import ERR_SOFT_EMG as ERR_SOFT_EMG
from mplang.m8194h.sim.io_state import ERR_SOFT_LIMIT_MINUS as ERR_SOFT_LIMIT_MINUS
from mplang.m8194h.sim.io_state import ERR_SOFT_LIMIT_PLUS as ERR_SOFT_LIMIT_PLUS
from mplang.m8194h.sim.io_state import ERR_SOFT_STOP as ERR_SOFT_STOP
from mplang.m8194h.sim.io_state import FACTOR_HMEND as FACTOR_HMEND
from mplang.m8194h.sim.io_state import FACTOR_SYNC as FACTOR_SYNC
from mplang.m8194h.sim.io_state import HOME_BACK_OFF as HOME_BACK_OFF
from mplang.m8194h.sim.io_state import HOME_BACK_ON as HOME_BACK_ON
from mplang.m8194h.sim.io_state import HOME_IDLE as HOME_IDLE
from mplang.m8194h.sim.io_state import HOME_STEP1 as HOME_STEP1
from mplang.m8194h.sim.io_state import HOME_STEP2 as HOME_STEP2
from mplang.m8194h.sim.io_state import HOME_STEP3 as HOME_STEP3
from mplang.m8194h.sim.io_state import HOME_STEP4 as HOME_STEP4
from mplang.m8194h.sim.io_state import INT_C_END as INT_C_END
from mplang.m8194h.sim.io_state import INT_C_STA as INT_C_STA
from mplang.m8194h.sim.io_state import INT_D_END as INT_D_END
from mplang.m8194h.sim.io_state import INT_P_GE_CMINUS as INT_P_GE_CMINUS
from mplang.m8194h.sim.io_state import INT_P_GE_CPLUS as INT_P_GE_CPLUS
from mplang.m8194h.sim.io_state import INT_P_LT_CMINUS as INT_P_LT_CMINUS
from mplang.m8194h.sim.io_state import INT_P_LT_CPLUS as INT_P_LT_CPLUS
from mplang.m8194h.sim.io_state import INT_PULSE as INT_PULSE
from mplang.m8194h.sim.io_state import SYNC_D_END as SYNC_D_END
from mplang.m8194h.sim.io_state import SYNC_D_STA as SYNC_D_STA
from mplang.m8194h.sim.io_state import SYNC_IN3_DOWN as SYNC_IN3_DOWN
from mplang.m8194h.sim.io_state import SYNC_IN3_UP as SYNC_IN3_UP
from mplang.m8194h.sim.io_state import SYNC_P_GE_CMINUS as SYNC_P_GE_CMINUS
from mplang.m8194h.sim.io_state import SYNC_P_GE_CPLUS as SYNC_P_GE_CPLUS
from mplang.m8194h.sim.io_state import SYNC_P_LT_CMINUS as SYNC_P_LT_CMINUS
from mplang.m8194h.sim.io_state import SYNC_P_LT_CPLUS as SYNC_P_LT_CPLUS
from mplang.m8194h.sim.io_state import AxisReport as AxisReport
from mplang.m8194h.sim.io_state import _axes, _Event, _one_axis
from mplang.m8194h.sim.scripted import _Scripted
from mplang.m8194h.sim.signals import AxisSensors as AxisSensors

_INF = math.inf


class AxisIO(_Scripted):
    """Per-axis inputs, error state, home search, compare/sync and interrupts of one model."""

    # ------------------------------------------------------------- the machine
    def set_sensors(self, axis_index: int, sensors: AxisSensors, now: float) -> None:
        """Rearrange the switches of one axis (they act from `now` on)."""
        self.model.settle(now)
        self.sensors[axis_index] = sensors
        self._changed()
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
        self._emg(asserted, now)
        self.model._recompute()

    def set_in3(self, axis_index: int, level: int, now: float) -> None:
        """Drive the IN3 input of an axis to an electrical level (0 low = on, 1 high)."""
        self.model.settle(now)
        self._in3(axis_index, level, now)
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
        inpos = self.inpos_signal(i, driving)
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
        cfg = self.cfg
        alarmed = False
        for i in axes:
            if cfg[i].alarm_enabled and self._alarm_signal(i):  # (`_alarm_active`, inline)
                self.status[i].errors |= ERR_ALARM
                alarmed = True
        return alarmed

    def lp_moved(self, i: int, delta: int) -> None:
        """SET_LP moved the counter, not the axis: keep the machine frame where it was."""
        self.status[i].mach_off -= delta

    def started(self, m: _Motion, t: float) -> None:
        """A drive starts: D-STA, and C-STA if it starts at constant speed (each asked
        for only where a synchronous action or an interrupt could come of it)."""
        cruise_now = self.int_enabled and bool(m.prof.segs) and self._cruise(m.prof.segs[0])
        cfg = self.cfg
        for i in m.axes:
            if cfg[i].sync_factors & SYNC_D_STA:
                self._sync(i, SYNC_D_STA, t)
            if cruise_now:
                self._interrupt(i, INT_C_STA, t)

    def ended(self, m: _Motion, t: float) -> None:
        """A motion finished in `settle`: next home-search step, or D-END (asked for only
        where an interrupt or a synchronous action could come of it)."""
        status, cfg = self.status, self.cfg
        for i in m.axes:
            run = status[i].home
            if run is not None and run.motion is m:
                self._home_motion_ended(run, t)
            elif self.int_enabled or cfg[i].sync_factors & SYNC_D_END:
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
        if self._next != _INF:
            return False
        for st in self.status:  # noqa: SIM110 - a loop: no generator, as every STOP_WAIT asks
            if st.home is not None:
                return False
        return True

    # -------------------------------------------------------------------- scheduling
    def reschedule(self) -> float:
        """Earliest I/O event of the present motions (called by MotionModel._recompute)."""
        self._version += 1
        if self._exempt:
            self._exempt = [m for m in self._exempt
                            if any(self.model._ax[i].motion is m for i in m.axes)]
        calm = self._calm_known  # (`_calm`, inline: this runs after every change)
        if calm is None or not profiles.CHANGE_ONLY:
            calm = self._calm()
        if calm and self.script_next >= len(self.script):  # nothing to plan
            self._events = []
            self._next = _INF
            return _INF
        events: list[_Event] = []
        if not calm:
            for m in self.model._motions():
                self._plan(m, events)
        self._plan_script(events)
        if len(events) > 1:
            events.sort()
        self._events = events
        self._next = events[0].time if events else _INF
        return self._next

    def fire(self, t: float) -> None:
        """Handle, in order, the I/O events due at or before t (called by settle)."""
        if t > self.now:
            self.now = t
        if not self._events:
            return
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
        exempt = bool(self._exempt) and any(m is e for e in self._exempt)
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
            if self.watches:
                self._plan_watches(m, k, i, mach, out)

    def _calm(self) -> bool:
        """No motion could meet an I/O event: no home search runs and no axis is
        `_watched`. The common case, checked for all axes at once without listing the
        motions, as `reschedule` runs after every change of the motion state; the answer
        is kept until `_changed` (always asked afresh with `profiles.CHANGE_ONLY` off)."""
        known = self._calm_known
        if known is None or not profiles.CHANGE_ONLY:
            known = self._calm_known = self._calm_now()
        return known

    def _calm_now(self) -> bool:
        """`_calm` worked out from the settings."""
        if self.watches:
            return False
        ints = self.int_enabled
        for st, cfg, sensors in zip(self.status, self.cfg, self.sensors, strict=True):
            if st.home is not None or cfg.slmt or sensors.wiring is not None \
                    or sensors.limit_plus is not None or sensors.limit_minus is not None \
                    or (ints and cfg.int_factors) \
                    or (cfg.sync_targets and cfg.sync_factors & 0x0F):
                return False
        return True

    def _watched(self, i: int, exempt: bool) -> bool:
        """Could a motion of axis i meet any I/O event? (The common answer is no.)"""
        cfg, sensors = self.cfg[i], self.sensors[i]
        if self.watches and self._watches_axis(i):
            return True
        if not exempt and (cfg.slmt or sensors.wiring is not None
                           or sensors.limit_plus is not None
                           or sensors.limit_minus is not None):
            return True
        if self.int_enabled and cfg.int_factors:
            return True
        return bool(cfg.sync_targets and cfg.sync_factors & 0x0F)

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
        elif e.kind in ("at", "watch"):
            self._script_event(e, t)

    def _on_limit(self, i: int, sign: int, m: _Motion, t: float) -> None:
        run = self.status[i].home
        if run is not None and run.motion is m:
            self._home_limit(run, sign, t)
            return
        self.status[i].errors |= ERR_LIMIT_PLUS if sign > 0 else ERR_LIMIT_MINUS
        self._halt(m, t, sudden=not self.cfg[i].limit_stop_slow)

    def _halt_all(self, now: float, sudden: bool) -> None:
        for m in self.model._motions():
            for i in m.axes:
                run = self.status[i].home
                if run is not None and run.motion is m:
                    self._home_finish(run, now, success=False, halt=m, sudden=sudden)
            self._halt(m, now, sudden)
