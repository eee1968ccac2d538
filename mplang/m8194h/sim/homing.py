"""Home search of the virtual M8194H's axis I/O (chapter 6).

The layer of `AxisIO` above the compare and synchronous actions: a state machine of up to
four steps, each installing its own motion on the axis and waiting for a sensor edge (an
event planned by `_plan_home`), the end of that motion or a limit switch.

Conventions and simplifications (manual = RS manual, "l.N" its line N)
--------------------------------------------------------------------
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
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mplang.m8194h.sim.builders import _Cmd, _Motion
from mplang.m8194h.sim.crossings import _crossing
from mplang.m8194h.sim.io_state import (
    ERR_HOME,
    ERR_LIMIT_MINUS,
    ERR_LIMIT_PLUS,
    FACTOR_HMEND,
    HOME_BACK_OFF,
    HOME_BACK_ON,
    HOME_IDLE,
    HOME_STEP1,
    HOME_STEP2,
    HOME_STEP3,
    HOME_STEP4,
    SYNC_D_STA,
    _Event,
    _HomeRun,
    _one_axis,
)
from mplang.m8194h.sim.paths import _LinePath
from mplang.m8194h.sim.profiles import (
    _Plan,
    _point_to_point,
    _Profile,
    _ramp,
)
from mplang.m8194h.sim.signals import _Signal
from mplang.m8194h.sim.sync_actions import _SyncActions

if TYPE_CHECKING:
    from mplang.m8194h.sim.motion import MotionModel


def _direction(step: int) -> int:
    if step not in (0, 1, 2):
        raise ValueError(f"home step direction must be 0, 1 or 2, got {step}")
    return 0 if step == 0 else (1 if step == 1 else -1)


class _HomeSearch(_SyncActions):
    """SET_HV, HOME_LIMIT, SET_HOME_MODE, HOME_START and the steps of the search."""

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
        self.model._admit([(i,)], now)  # QueueFull if the motion queue is full

        def build(model: MotionModel, t: float) -> _Motion | None:
            model.io._home_begin(i, t)  # `model`, not self: idle_at runs copies
            return None  # the search installs its own motions

        self.model._issue(_Cmd((i,), False, build), now)

    def home_state(self, axis: int, now: float) -> int:
        self.model.settle(now)
        run = self.status[_one_axis(axis)].home
        return run.state if run is not None else HOME_IDLE

    # ------------------------------------------------------------ home-search machine
    def _home_dirs(self, i: int) -> tuple[int, int, int, int]:
        return self.cfg[i].home_steps

    def _home_begin(self, i: int, t: float) -> None:
        st = self.status[i]
        st.home = run = _HomeRun(i)
        self._changed()
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
        base = self.model.plan(i)
        plan = _Plan(min(base.sv, base.v), base.v, base.acc, base.dec, base.s_curve)
        prof = _Profile(0.0, plan.sv)
        _ramp(prof, plan.sv, plan.v, plan.acc, plan.s_curve)
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
        hv = self.model.rules.speed(self.cfg[i].hv, self.model.settings[i].max_v)
        plan = _Plan(hv, hv, 1.0, 1.0, False, constant=True)
        prof = _Profile(0.0, hv)
        prof.forever()
        self._home_drive(run, t, prof, d, plan)

    def _home_drive(self, run: _HomeRun, t: float, prof: _Profile, d: int,
                    plan: _Plan, final: tuple[int, ...] = ()) -> None:
        i = run.axis
        ax = self.model._ax[i]
        path = _LinePath((ax.pos,), (d,), 1.0)
        m = _Motion((i,), t, prof, path, final, plan, False, d if not final else 0)
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
        plan = self.model.plan(i)
        prof = _point_to_point(float(offset), plan)
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
        self._changed()
        self.triggered[FACTOR_HMEND] |= 1 << i
        ended = True
        if halt is not None:
            ended = self._halt(halt, t, sudden, d_end=False)
        if success:
            self._preset(i, t, lp=0, ep=0)
        if d_end and ended:
            self._drive_end(i, t)
