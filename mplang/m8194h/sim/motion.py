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

The parts of a motion are in their own modules: speed plans and profiles in `profiles`,
paths in `paths`, motions and the builders that start them in `builders`, continuous
interpolation in `chains`; this module holds the `MotionModel` that queues, starts, stops
and settles them. It is one file because `MotionModel` is one class whose methods all keep
its queue, axes and chains consistent with each other; what stands alone is in those modules.

Conventions and simplifications
-------------------------------
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
* The commands waiting so (queued behind busy axes or held) and the segments a
  continuous interpolation has not reached yet are bounded by ``queue_capacity`` (the
  device profile's ``limits.motion_queue``): a new command that would have to wait
  beyond it raises `QueueFull` and changes nothing; the caller retries at
  `queues.room_at`.
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
* Continuous interpolation (7.4.2-7.4.10).  LINE_2D_INITIAL / LINE_3D_INITIAL /
  MIX_2D_INITIAL act as AXIS_ASSIGN plus VECTOR_SPEED 1 / 8 / (nAcc 0: 0, nAcc 1: 1)
  and SET_VSV/VV/VA: the manual only says they "set the necessary parameters" for a
  symmetric T-curve (l.8267, l.8474) or constant VV / T-curve (l.8704), so writing the
  ordinary vector registers is the choice.  A CONTINUE without an INITIAL runs with the
  present vector settings, S-curve modes as T-curves with VA (and VD if asymmetric),
  since continuous interpolation knows only constant speed and T-curves.
* A chain takes more segments while it waits to start or runs undisturbed and has not
  had its last one; a stop, a new *_INITIAL, other assigned axes, or another command
  waiting for its axes (which a segment must not overtake) ends that, and the next
  segment opens a new chain, queued like any command.
* INTP_END (l.9551): type 0 / 1 (2 / 3 axes, l.9563) marks the end of the open chain
  of that many axes, which then decelerates to a stop at the end of its segments; a
  type that does not match has no effect.  The manual asks for it before single-axis
  moves or coordinate changes; those already wait for a running interpolation here.
* RECTANGLE (7.4.1) and HELIX_3D (7.4.11): their conventions are listed in
  ``builders.py``, which lays them out.
* Axis I/O (sensors, hardware and software limits, home search, emergency stop, error
  codes, compare, latch, synchronous actions, interrupt factors) lives in
  ``axis_io.py`` and the layers it is built from, whose docstrings list their own
  conventions.  Its events (a limit or a sensor edge reached, a compare value passed)
  are folded into the model's next event by ``_recompute`` and handled by ``settle``
  in time order, before the motions ending at the same instant; every ended motion is
  reported to it (D-END, next home step).  A command that starts is dropped in an
  emergency, while EMG is asserted or while an enabled ALARM is active.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from mplang.ir.catalogue import Profile
from mplang.m8194h.chipvalues import ChipRules
from mplang.m8194h.sim import profiles
from mplang.m8194h.sim.axes import AXES, _axis_index, _mask_axes, _round
from mplang.m8194h.sim.axis_io import AxisIO
from mplang.m8194h.sim.builders import (
    QueueFull,
    _arc_builder,
    _Cmd,
    _continuous_builder,
    _helix_builder,
    _line_builder,
    _Motion,
    _rectangle_builder,
    _single_cmd,
)
from mplang.m8194h.sim.chains import (
    _Chain,
    _chain_backlog,
    _chain_builder,
    _chain_profile,
    _lay,
    _Seg,
)
from mplang.m8194h.sim.fork import _alone, fork
from mplang.m8194h.sim.io_state import AxisReport
from mplang.m8194h.sim.profiles import (
    VECTOR_KIND,
    _AxisSettings,
    _kept_plan,
    _Plan,
    _plans_for,
    _Profile,
    _ramp,
    _ramp_dist,
    _single_plan,
    _vector_plan,
    _VectorSettings,
)

_INF = math.inf
_SINGLES = {mask: tuple((i,) for i in _mask_axes(mask)) for mask in range(1, 16)}
"""Per axis mask, its axes one by one: the groups `_admit` checks for a single-axis move."""

__all__ = ["MotionModel", "QueueFull"]


@dataclass
class _AxisState:
    pos: int = 0  # LP while idle
    shift: int = 0  # SET_LP correction applied to a running motion
    ep_off: int = 0  # EP - LP
    held: bool = False
    motion: _Motion | None = None


class MotionModel:
    """Four axes X, Y, Z, U of a virtual M8194H with analytic motion profiles.

    Axis masks are Table-4 codes (X=1, Y=2, Z=4, U=8, combinations up to 15); a
    single-axis code is one of 1, 2, 4, 8.  Every query takes the present simulated
    time ``now`` and first finishes motions that ended at or before it.
    """

    def __init__(self, queue_capacity: int | None = None, rules: ChipRules | None = None) -> None:
        self.queue_capacity = queue_capacity  # None: unbounded (a bare model in tests)
        self.rules = rules or ChipRules()  # the values the chip holds (manual defaults)
        self.settings = [_AxisSettings() for _ in AXES]
        self.vector = _VectorSettings()
        self.assigned: tuple[int, ...] = (0, 1)  # axis indices of axis1..axis3
        self._ax = [_AxisState() for _ in AXES]
        self._queue: list[_Cmd] = []  # waiting for busy axes
        self._pending: list[_Cmd] = []  # waiting for DRV_START
        self.io = AxisIO(self)  # sensors, limits, homing, errors, interrupts
        self._next_end = _INF
        # continuous interpolation (7.4): chains by id, and the one still taking segments
        self._chains: dict[int, _Chain] = {}
        self._chain_seq = 0
        self._open: _Chain | None = None
        # plans by the settings they come from (`profiles.CHANGE_ONLY`), shared by the models
        # of equal chip rules (so their profiles are found by identity) and with forks
        self._plans = _plans_for(self.rules)

    @classmethod
    def for_device(cls, profile: Profile) -> MotionModel:
        """The model of a device with `profile`: its motion queue and the values its chip holds."""
        return cls(profile.limit("motion_queue"), ChipRules.from_profile(profile.raw))

    def plan(self, axis: int) -> _Plan:
        """The plan a single-axis drive of axis index `axis` latches now (a kept one is
        looked up here, before `_kept_plan`, as every move asks)."""
        st, rules = self.settings[axis], self.rules
        key = (st.max_v, st.mode, st.sv, st.v, st.a, st.d, st.k, st.l, st.ao)
        if profiles.CHANGE_ONLY:
            kept = self._plans.get(key)
            if kept is not None:
                return kept
        return _kept_plan(self._plans, key, lambda: _single_plan(st, rules))

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
        if mode not in VECTOR_KIND:
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
        """The vector plan, with the values the chip holds for the MAX_V of axis 1."""
        vs, rules = self.vector, self.rules
        max_v = self.settings[self.assigned[0]].max_v
        key = (max_v, vs.mode, vs.vsv, vs.vv, vs.va, vs.vd, vs.vk, vs.vl, vs.vao, True)
        if profiles.CHANGE_ONLY:  # (a kept one is looked up here, as in `plan`)
            kept = self._plans.get(key)
            if kept is not None:
                return kept
        return _kept_plan(self._plans, key, lambda: _vector_plan(vs, max_v, rules))

    # ------------------------------------------------------------------ motion
    def fixed_move(self, axis_mask: int, pulses: int, now: float) -> None:
        """FIXED_MOVE: every axis of the mask moves `pulses` relative to where it starts."""
        axes = _mask_axes(axis_mask)
        self._admit(_SINGLES[axis_mask], now)
        pulses = int(pulses)
        for i in axes:
            self._issue(_single_cmd(i, pulses, False, self.plan(i)), now)

    def abs_move(self, axis_mask: int, position: int, now: float) -> None:
        """ABS_FIXED_MOVE: every axis of the mask moves to LP = `position`."""
        axes = _mask_axes(axis_mask)
        self._admit(_SINGLES[axis_mask], now)
        position = int(position)
        for i in axes:
            self._issue(_single_cmd(i, position, True, self.plan(i)), now)

    def continue_move(self, axis_mask: int, speed: int, now: float) -> None:
        """CONTINUE_MOVE: run at |speed| in the direction of its sign until stopped."""
        self.settle(now)
        direction = 1 if speed > 0 else -1
        runs: list[tuple[int, _Plan, bool]] = []  # axis, plan, change the running speed
        for i in _mask_axes(axis_mask):
            st = self.settings[i]
            base = self.plan(i)
            v = self.rules.speed(abs(speed), st.max_v)
            if v <= 0:
                continue
            plan = _Plan(min(base.sv, v), v, base.acc, base.dec, base.s_curve)
            ax = self._ax[i]
            m = ax.motion
            runs.append((i, plan, m is not None and m.continuous and not m.vector
                         and m.direction == direction and not ax.held
                         and not any(i in c.axes for c in self._queue)))
        self._admit([(i,) for i, _plan, change in runs if not change], now)
        for i, plan, change in runs:
            m = self._ax[i].motion
            if change and m is not None:
                self._change_speed(i, m, plan, now)
            else:
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
        self._admit([axes], now)
        self._issue(_Cmd(axes, True, _line_builder(axes, tuple(int(d) for d in distances),
                                                   absolute, self._vector_plan())), now)

    def arc(self, center: tuple[int, int], finish: tuple[int, int], clockwise: bool,
            now: float, absolute: bool = False) -> None:
        """ARC_CW / ARC_CCW (and ABS_ variants) in the plane of axis 1 / axis 2."""
        axes = self.assigned[:2]
        self._admit([axes], now)
        self._issue(_Cmd(axes, True, _arc_builder(axes, (int(center[0]), int(center[1])),
                                                  (int(finish[0]), int(finish[1])),
                                                  clockwise, absolute, False,
                                                  self._vector_plan())), now)

    def circle(self, center: tuple[int, int], clockwise: bool, now: float) -> None:
        """CIRCLE_CW / CIRCLE_CCW: a full circle around a centre relative to the start."""
        axes = self.assigned[:2]
        self._admit([axes], now)
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
        """The running motions, each once (an interpolation drives several axes)."""
        seen: list[_Motion] = []
        for ax in self._ax:
            m = ax.motion
            if m is not None:
                for other in seen:
                    if other is m:
                        break
                else:
                    seen.append(m)
        return seen

    def _recompute(self) -> None:
        end = _INF
        for ax in self._ax:
            m = ax.motion
            if m is not None and m.end < end:
                end = m.end
        io_next = self.io.reschedule()  # limits, sensors, compare
        self._next_end = io_next if io_next < end else end

    def waiting_commands(self) -> int:
        """Motion commands that wait for their axes (queued behind busy axes or held)."""
        return len(self._queue) + len(self._pending)

    def _admit(self, groups: Sequence[tuple[int, ...]], now: float) -> None:
        """Raise `QueueFull` (before anything changes) if the commands for these groups of
        axes would wait beyond `queue_capacity`."""
        if self.queue_capacity is None:
            return
        if self._next_end <= now:
            self.settle(now)
        elif now > self.io.now:  # (`settle` when nothing ends: only the I/O's time moves)
            self.io.now = now
        if not self._queue and not self._pending:
            return  # an empty queue takes any one command
        ax = self._ax
        queued = [set(c.axes) for c in self._queue] if self._queue else []
        waits = 0
        for axes in groups:
            for i in axes:
                if ax[i].held or ax[i].motion is not None:
                    waits += 1
                    break
            else:
                if queued and any(q & set(axes) for q in queued):
                    waits += 1
        waiting = len(self._queue) + len(self._pending)  # `waiting_commands`
        if waits and waiting and waiting + waits > self.queue_capacity:
            raise QueueFull(needed=waits)  # (an empty queue takes any one command)

    def _issue(self, cmd: _Cmd, now: float) -> None:
        if self._next_end <= now:
            self.settle(now)
        elif now > self.io.now:  # (`settle` when nothing ends: only the I/O's time moves)
            self.io.now = now
        ax = self._ax
        busy = False
        for i in cmd.axes:
            if ax[i].held:
                self._pending.append(cmd)
                return
            busy = busy or ax[i].motion is not None
        if busy or (self._queue and any(set(cmd.axes) & set(c.axes) for c in self._queue)):
            self._queue.append(cmd)
            return
        self._start(cmd, now)
        self._recompute()

    def _start(self, cmd: _Cmd, t: float) -> None:
        if self.io.refuses(cmd.axes, t):
            return  # emergency, EMG input or servo alarm: the command is dropped
        built = cmd.built
        if built is not None and built[0] == t and \
                built[1] == tuple([self._ax[i].pos for i in cmd.axes]):
            m = built[2]  # as `_drain` built it, at this time from these positions
        else:
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
        if not self._queue:
            return
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
        """Finish, in time order, every motion that ended at or before `now`. It has no
        work but moving the I/O's time when nothing ends: the callers that ask most
        (`_admit`, `_issue`, `idle_at`) do that themselves and call it only when
        `_next_end <= now`."""
        if self._next_end > now:  # nothing ends: only the I/O's present time moves
            io = self.io
            if now > io.now:  # (`AxisIO.advance`, inline: every query settles first)
                io.now = now
            return
        io = self.io
        while self._next_end <= now:
            t = self._next_end
            io.fire(t)  # axis I/O events due at t (limits, home sensors, compare)
            self._end_due(t)
            if self._queue:
                self._dequeue(t)
            self._recompute()
            if self._next_end <= now and not self._queue and profiles.CHANGE_ONLY and \
                    _alone(io):
                # more ends are due, and nothing can happen between them but the ends
                # (no I/O event, `io.ended` starts nothing, no queued command): all at once
                self._end_due(now)
                self._recompute()
        if now > io.now:  # (`AxisIO.advance`, inline)
            io.now = now

    def _end_due(self, t: float) -> None:
        """Finish every motion ending at or before `t` (in `settle`'s loop, those ending at
        `t`): its axes stop at its end (LP = end + SET_LP shift) and the I/O hears of it
        (D-END, the next home-search step; nothing where `settle` ends several at once)."""
        io, axes = self.io, self._ax
        for ax in axes:
            m = ax.motion
            if m is not None and m.end <= t:
                for k, i in enumerate(m.axes):
                    other = axes[i]
                    other.pos = m.final[k] + other.shift
                    other.shift = 0
                    other.motion = None
                io.ended(m, t)

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

    def cv_reading(self, axis: int, now: float) -> float:
        """CV as the chip's register shows it: whole speed steps of the axis's MAX_V."""
        v = self.cv(axis, now)
        return self.rules.speed(v, self.settings[_axis_index(axis)].max_v) if v > 0 else 0.0

    def ca_reading(self, axis: int, now: float) -> float:
        """CA as the chip's register shows it: whole acceleration steps (MAX_V / 64)."""
        a = self.ca(axis, now)
        step = self.rules.acceleration_step(self.settings[_axis_index(axis)].max_v)
        return math.floor(abs(a) / step + 0.5) * step * (1 if a >= 0 else -1)

    def _busy(self, axes: tuple[int, ...]) -> bool:
        ax = self._ax
        for i in axes:
            if ax[i].motion is not None:
                return True
        queue, pending = self._queue, self._pending
        if not queue and not pending:
            return False
        wanted = set(axes)
        return any(wanted & set(c.axes) for c in queue) or any(
            wanted & set(c.axes) for c in pending)

    def busy(self, axis_mask: int, now: float) -> bool:
        """True if an axis of the mask moves or has a queued or held command."""
        axes = _mask_axes(axis_mask)
        if now >= self._next_end:
            self.settle(now)
        return self._busy(axes)

    def idle_at(self, axis_mask: int, now: float) -> float | None:
        """When every axis of the mask will be idle; None if never without a command."""
        axes = _mask_axes(axis_mask)
        if self._next_end <= now:
            self.settle(now)
        elif now > self.io.now:  # (`settle` when nothing ends: only the I/O's time moves)
            self.io.now = now
        queue, pending = self._queue, self._pending
        if pending or queue:
            wanted = set(axes)
            if any(wanted & set(c.axes) for c in pending):
                return None
            waits = any(wanted & set(c.axes) for c in queue)
        else:
            waits = False
        if not waits and self.io.quiet():
            end = now
            for i in axes:
                m = self._ax[i].motion
                if m is not None and m.end > end:
                    end = m.end
            return None if end == _INF else end
        if self._drains_alone():
            return self._drain(axes, now)
        return self._forked_idle_at(axes, now)

    def _forked_idle_at(self, axes: tuple[int, ...], now: float) -> float | None:
        """`idle_at` (settled at `now`) on a copy of the model running ahead."""
        sim = fork(self)
        t = now
        while sim._busy(axes):
            nxt = sim.next_event(t)
            if nxt is None:
                return None
            t = nxt
            sim.settle(t)
        return t

    def _drains_alone(self) -> bool:
        """Running ahead would only finish motions and start queued commands: no I/O event,
        interrupt, synchronous action, ALARM or EMG can come (`fork._alone`), no command is
        held, no continuous-interpolation chain lives (its builder reads the chain, not
        only positions) and no emergency drops commands. Off with `profiles.CHANGE_ONLY`."""
        return profiles.CHANGE_ONLY and not self._pending and not self._chains and \
            not self.io.emergency and _alone(self.io)

    def _drain(self, axes: tuple[int, ...], now: float) -> float | None:
        """`idle_at` where `_drains_alone`: what a fork's `settle` would do, on the axes'
        positions only. Motions end in time order (LP = end + SET_LP shift) and the queued
        commands start as `_dequeue` starts them, each built from a model that holds only
        those positions (every builder but a chain's reads nothing else); no copy of the
        model, no I/O. Each command keeps what it built (`_Cmd.built`), which `_start`
        takes when the command starts at that time from those positions.
        `tests/m8194h/sim/test_planning.py` compares it with the fork."""
        state = [_AxisState(ax.pos, ax.shift, motion=ax.motion) for ax in self._ax]
        ahead = object.__new__(MotionModel)
        ahead._ax = state
        queue = self._queue
        wanted = set(axes)
        t = now
        while self._ahead_busy(state, axes, wanted, queue):
            t = min([a.motion.end for a in state if a.motion is not None], default=_INF)
            if t == _INF:
                return None
            for a in state:
                m = a.motion
                if m is not None and m.end <= t:
                    for k, i in enumerate(m.axes):
                        state[i].pos, state[i].shift = m.final[k] + state[i].shift, 0
                        state[i].motion = None
            blocked: set[int] = set()
            keep: list[_Cmd] = []
            for cmd in queue:
                if blocked & set(cmd.axes) or any(state[i].motion is not None for i in cmd.axes):
                    blocked |= set(cmd.axes)
                    keep.append(cmd)
                    continue
                started = cmd.build(ahead, t)
                cmd.built = (t, tuple([state[i].pos for i in cmd.axes]), started)
                if started is None:
                    continue
                for k, i in enumerate(started.axes):
                    if started.end <= t:
                        state[i].pos = started.final[k]
                    else:
                        state[i].motion = started
            queue = keep
        return t

    @staticmethod
    def _ahead_busy(state: list[_AxisState], axes: tuple[int, ...], wanted: set[int],
                    queue: list[_Cmd]) -> bool:
        """`_drain`'s `_busy`: an axis of `axes` moves in `state`, or a command waits for one."""
        for i in axes:
            if state[i].motion is not None:
                return True
        for c in queue:  # noqa: SIM110 - a loop, no generator: each step ahead asks
            if not wanted.isdisjoint(c.axes):
                return True
        return False

    def next_event(self, now: float) -> float | None:
        """Earliest end of a running motion after `now` (None if nothing will end)."""
        self.settle(now)
        return None if self._next_end == _INF else self._next_end

    # ------------------------------------------- axis I/O query API (see axis_io.py)
    def axis_report(self, axis_index: int, now: float) -> AxisReport:
        """DI status, error code, stop causes, servo, emergency, home and latch of one
        axis (0..3) at `now`: what the Modbus registers of appendix 12 show."""
        return self.io.report(axis_index, now)

    def next_interrupt(self, now: float) -> float | None:
        """Time of the earliest interrupt request, pending or still to come if nothing
        changes (None if none will come). The interpreter asks before every slice of lines:
        with interrupts off and none pending the answer is None (`AxisIO.next_interrupt`)."""
        io = self.io
        if not io.int_enabled and not io.requests:
            if self._next_end <= now or now > io.now:  # (`settle`: it has work)
                self.settle(now)
            return None
        return io.next_interrupt(now)

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
        rules = self.rules
        top = rules.speed(v, max_v)
        plan = (_Plan(top, top, 1.0, 1.0, False, constant=True) if constant else
                _Plan(rules.speed(sv, max_v), top, rules.acceleration(acc, max_v),
                      rules.acceleration(dec, max_v), False))
        r = min(rp, lp // 2, wp // 2)
        self._admit([(i, j)], now)
        self._issue(_Cmd((i, j), True, _rectangle_builder((i, j), start_point, clockwise,
                                                          lp, wp, r, plan)), now)

    def helix(self, axes: tuple[int, int, int], clockwise: bool, vv: int,
              center: tuple[int, int], cycle: int, pitch: int, now: float) -> None:
        """HELIX_3D: `cycle` turns around a centre relative to the start in the plane of
        axes 1/2 while axis 3 advances `pitch` per turn, at the constant vector speed."""
        idx = tuple(_axis_index(a) for a in axes)
        if len(set(idx)) != 3:
            raise ValueError("the helix axes must be distinct")
        v = self.rules.speed(vv, self.settings[idx[0]].max_v)
        plan = _Plan(v, v, 1.0, 1.0, False, constant=True)
        self._admit([idx], now)
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
        dec = vs.vd if VECTOR_KIND[vs.mode] == "asymS" else vs.va
        max_v = self.settings[self.assigned[0]].max_v
        return _Plan(plan.sv, plan.v, self.rules.acceleration(vs.va, max_v),
                     self.rules.acceleration(dec, max_v), False)

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
            if self.queue_capacity is not None and \
                    _chain_backlog(chain, now) >= self.queue_capacity:
                raise QueueFull(chain=True)
            self._grow(chain, seg, last, now)
        else:
            self._admit([axes], now)
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
        chain.path.forget(s)  # finished segments: only `now` and later are read again
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
