"""Interrupt factors of the virtual M8194H's axis I/O (7.3.10-7.3.13).

The first layer of `AxisIO` above its state (`io_state`): ENABLE_INT / DISABLE_INT, the
factors enabled per axis, the triggered-factor registers and the requests (time, ISR number)
the controller takes, and whether a motion is in the constant-speed part that C-STA / C-END
mark.

Conventions and simplifications (manual = RS manual, "l.N" its line N)
--------------------------------------------------------------------
* Interrupts (7.3.10-7.3.13): a factor raises a request only if ENABLE_INT is on and the
  factor is enabled on the axis (INTFACTOR_ENABLE, which also clears that axis's bit of the
  triggered register, l.3959).  Compare factors fire on the edge (the condition becoming
  true).  A request stays pending until the controller takes it (which it does only while
  no ISR runs: profile ``limits.isr_queue``); while one is pending for
  an (axis, factor) the same factor does not queue another -- so PULSE asks for one ISR at
  a time, not one per pulse.  DISABLE_INT drops pending requests, INTFACTOR_DISABLE those
  of its factors.  C-STA/C-END are the start/end of the constant-speed part of a profile
  (a stop command cutting it short ends it), D-END the end of every drive.
"""

from __future__ import annotations

from mplang.m8194h.sim import profiles
from mplang.m8194h.sim.builders import _Motion
from mplang.m8194h.sim.fork import fork
from mplang.m8194h.sim.io_state import _axes, _IOBase, _one_axis, _Request


class _Interrupts(_IOBase):
    """ENABLE_INT, INTFACTOR_ENABLE / _DISABLE, the triggered registers and the requests."""

    # ------------------------------------------------------------ interrupts (7.3.10-13)
    def enable_int(self, now: float) -> None:
        self.model.settle(now)
        self.int_enabled = True
        self._changed()
        self.model._recompute()

    def disable_int(self, now: float) -> None:
        self.model.settle(now)
        self.int_enabled = False
        self.requests.clear()
        self._changed()
        self.model._recompute()

    def intfactor_enable(self, axis: int, factor: int, isr: int, now: float) -> None:
        if not 0 <= factor <= 7:
            raise ValueError(f"interrupt factor must be 0..7, got {factor}")
        i = _one_axis(axis)
        self.model.settle(now)
        self.cfg[i].int_factors[factor] = int(isr)
        self.triggered[factor] &= ~(1 << i)
        self._changed()
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
        self._changed()
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
        sim = fork(self.model)
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

    def uneventful(self) -> bool:
        """No interrupt can be requested, so a new motion changes no event the interpreter
        waits for (with no machine script, ISR or loading wait either, it runs on after a
        motion command). Always False with `profiles.CHANGE_ONLY` off."""
        return profiles.CHANGE_ONLY and not self.int_enabled and not self.requests

    def _may_interrupt(self) -> bool:
        if not self.int_enabled:
            return False
        return any(c.int_factors or (c.action is not None and c.action.intr) for c in self.cfg)

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
