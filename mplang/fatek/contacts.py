"""The machine around the virtual PLC: contacts that change with time or with axis positions.

A contact is ON when any of its sources is ON: `SIM ... ON/OFF AT` events, position windows
(`ON WHILE Ps0 IN lo..hi`), and outputs the run itself drives (the CLR pulse of DRVZ). PG0
sensors (`PULSE Ps0 EVERY n`) only give edges, at each multiple of n pulses. Every question
("when does X3 next turn ON?") is answered in closed form from the motion legs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from mplang.fatek.model import Contact, ContactEvent, PulseSensor, SimSetup, WindowSensor
from mplang.fatek.motion import INF, Leg

_MAX_ROUNDS = 64
_PAST = 1e-6  # pulses: how far beyond a window's edge its sensor counts as OFF


@dataclass
class Contacts:
    """Contact states over a run, given the motion leg in progress (if any)."""

    sim: SimSetup
    rest: list[float]  # the axes' positions when no leg moves them (kept by the machine)
    driven: list[ContactEvent] = field(default_factory=list)  # outputs the run switches

    def events(self, contact: Contact) -> list[ContactEvent]:
        found = [e for e in (*self.sim.events, *self.driven) if e.contact == contact]
        return sorted(found, key=lambda e: e.time)

    def windows(self, contact: Contact) -> list[WindowSensor]:
        return [w for w in self.sim.windows if w.contact == contact]

    def pulses(self, contact: Contact) -> list[PulseSensor]:
        return [p for p in self.sim.pulses if p.contact == contact]

    def has_source(self, contact: Contact) -> bool:
        return bool(self.events(contact) or self.windows(contact) or self.pulses(contact))

    def position(self, axis: int, t: float, leg: Leg | None) -> float:
        if leg is not None and axis in leg.unit and t >= leg.t0:
            return leg.position(axis, t)
        return self.rest[axis]

    # ------------------------------------------------------------ state
    def scheduled(self, contact: Contact, t: float) -> bool:
        state = False
        for event in self.events(contact):
            if event.time <= t:
                state = event.state
        return state

    def is_on(self, contact: Contact, t: float, leg: Leg | None) -> bool:
        if self.scheduled(contact, t):
            return True
        return any(w.low <= self.position(w.axis, t, leg) <= w.high
                   for w in self.windows(contact))

    # ------------------------------------------------------------ edges
    def next_on(self, contact: Contact, t_from: float, leg: Leg | None,
                pulses: bool = True) -> float:
        """The first time >= t_from at which the contact is ON (INF: never)."""
        best = INF
        for event in self.events(contact):
            if event.state and event.time >= t_from:
                best = min(best, event.time)
                break
        if self.scheduled(contact, t_from):
            return t_from
        for window in self.windows(contact):
            best = min(best, self._window_on(window, t_from, leg))
        if pulses:
            for sensor in self.pulses(contact):
                best = min(best, self.next_pulse(sensor, t_from, leg, 1))
        return best

    def next_off(self, contact: Contact, t_from: float, leg: Leg | None) -> float:
        """The first time >= t_from at which the contact is OFF (INF: never)."""
        t = t_from
        for _ in range(_MAX_ROUNDS):
            if not self.is_on(contact, t, leg):
                return t
            later = t
            if self.scheduled(contact, t):
                later = max(later, next((e.time for e in self.events(contact)
                                         if e.time > t and not e.state), INF))
            for window in self.windows(contact):
                if window.low <= self.position(window.axis, t, leg) <= window.high:
                    later = max(later, self._window_off(window, t, leg))
            if later == INF:
                return INF
            if later == t:
                later = math.nextafter(t, INF)
            t = later
        return INF

    def _window_on(self, window: WindowSensor, t_from: float, leg: Leg | None) -> float:
        here = self.position(window.axis, t_from, leg)
        if window.low <= here <= window.high:
            return t_from
        if leg is None or window.axis not in leg.unit:
            return INF
        edge = window.low if here < window.low else window.high
        when = leg.time_at_position(window.axis, edge)
        return when if when >= t_from else INF

    def _window_off(self, window: WindowSensor, t_from: float, leg: Leg | None) -> float:
        if leg is None or window.axis not in leg.unit or leg.unit[window.axis] == 0:
            return INF
        # the first instant past the edge: the window itself is closed (low..high inclusive)
        edge = window.high + _PAST if leg.unit[window.axis] > 0 else window.low - _PAST
        when = leg.time_at_position(window.axis, edge)
        return when if when >= t_from else INF

    def next_pulse(self, sensor: PulseSensor, t_from: float, leg: Leg | None,
                   count: int) -> float:
        """When the `count`-th zero-phase pulse after t_from comes (INF: never)."""
        position = self.pulse_position(sensor, t_from, leg, count)
        if position is None or leg is None:
            return INF
        when = leg.time_at_position(sensor.axis, position)
        return when if when >= t_from else INF

    def pulse_position(self, sensor: PulseSensor, t_from: float, leg: Leg | None,
                       count: int) -> float | None:
        """Where the `count`-th multiple of `every` beyond the axis's position lies, in the
        leg's direction (None if the leg does not move the axis)."""
        if leg is None or not leg.unit.get(sensor.axis):
            return None
        here = self.position(sensor.axis, t_from, leg)
        step = sensor.every
        if leg.unit[sensor.axis] > 0:
            first = (math.floor(here / step) + 1) * step
            return first + (count - 1) * step
        first = (math.ceil(here / step) - 1) * step
        return first - (count - 1) * step
