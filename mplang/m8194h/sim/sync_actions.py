"""Compare, latch, synchronous actions (7.3.1-7.3.5) and halting drives of the axis I/O.

The layer of `AxisIO` above the interrupts: the COMP+ / COMP- crossings of a motion become
interrupt and sync factors, and a sync factor of a trigger axis runs the action of its
activation axes.  Halting a drive is here too, since the end of a drive (D-END) is itself a
sync factor and an action can start or stop drives.  Ending a home search belongs to the
layer above (`homing`); this layer declares it as `_home_finish`.

Conventions and simplifications (manual = RS manual, "l.N" its line N)
--------------------------------------------------------------------
* Synchronous actions (7.3.1-7.3.5): factors of the trigger axis fire the action of every
  activation axis, in the order latch, preset, drive, interrupt.  FDRV drives the preset
  value (nPRESET OPSET is not required); FDRV/CDRV do nothing if the activation axis is
  busy (l.7031); VLSET sets V and changes the speed of a running continuous move (a fixed
  move keeps its plan); SSTOP/ISTOP stop without the SOFT STOP bit.  nOUT is stored only
  (no observable output).  The SYNC register bit and the SYNC interrupt belong to the
  activation axis.  Actions stay armed until CLEAR_SYNC_ACTION.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod

from mplang.m8194h.sim.builders import _Cmd, _continuous_builder, _Motion, _single_cmd
from mplang.m8194h.sim.crossings import _crossing
from mplang.m8194h.sim.interrupts import _Interrupts
from mplang.m8194h.sim.io_state import (
    FACTOR_SYNC,
    INT_C_END,
    INT_C_STA,
    INT_D_END,
    INT_P_GE_CMINUS,
    INT_P_GE_CPLUS,
    INT_P_LT_CMINUS,
    INT_P_LT_CPLUS,
    INT_PULSE,
    SYNC_D_END,
    SYNC_P_GE_CMINUS,
    SYNC_P_GE_CPLUS,
    SYNC_P_LT_CMINUS,
    SYNC_P_LT_CPLUS,
    _Action,
    _axes,
    _Event,
    _HomeRun,
    _one_axis,
    _Request,
)
from mplang.m8194h.sim.profiles import _Plan

_INF = math.inf


class _SyncActions(_Interrupts, ABC):
    """SET_COMPARE, GET_LATCH, the synchronous actions and halting a drive."""

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

    def _drive_end(self, i: int, t: float) -> None:
        if self.int_enabled:  # (each asked for only where something can come of it)
            self._interrupt(i, INT_D_END, t)
        if self.cfg[i].sync_factors & SYNC_D_END:
            self._sync(i, SYNC_D_END, t)

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
                base = model.plan(j)
                plan = _Plan(min(base.sv, base.v), base.v, base.acc, base.dec,
                                base.s_curve)
                model._change_speed(j, m, plan, t)
        busy = ax.motion is not None or any(j in c.axes for c in model._queue)
        if action.drv in (1, 2) and not busy and value != 0:
            pulses = value if action.drv == 1 else -value
            model._start(_single_cmd(j, pulses, False, model.plan(j)),
                         t)
        elif action.drv in (3, 4) and not busy:
            base = model.plan(j)
            plan = _Plan(min(base.sv, base.v), base.v, base.acc, base.dec, base.s_curve)
            direction = 1 if action.drv == 3 else -1
            model._start(_Cmd((j,), False, _continuous_builder(j, direction, plan)), t)
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

    @abstractmethod
    def _home_finish(self, run: _HomeRun, t: float, success: bool,
                     halt: _Motion | None = None, sudden: bool = True,
                     d_end: bool = True) -> None:
        """End of a home search (the home-search layer, `homing`, implements it)."""
