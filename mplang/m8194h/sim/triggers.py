"""Stand-alone mode of the virtual M8194H: the FRnet DI trigger table (manual chapter 10).

Each FRnet DI channel (groups 8-15, 16 channels each) may have one trigger: a condition
(OFF, ON, ON to OFF, OFF to ON, Change; RS 11092-11101) and an event (start MPn, Abort
Command, Abort Macro Program, Hold Drive of some axes; RS 11067-11105). The vendor utility
sends the table through no documented register, so the simulator takes it as data:
`VirtualController.load_trigger_table(entries)` with the entries the compiler writes under
image["triggers"]["entries"]. Holding register 9 (RSM_SET_FRNET_TRIGGER_EVENT, 5.4) or
`VirtualController.set_triggering` switches triggering on and off.

While triggering is on, every change of a DI group made through
`VirtualController.set_di_group` (the 9008-9015 extension registers, FRNET_WRITE to a DI
group) fires the events its conditions define at the simulated time of the change. Only
one macro program runs at a time: an MP asked for while another runs waits in a queue and
starts the moment the running one ends (RS 11112-11114). Where the manual is silent the
behaviour is data in `[stand_alone]` of stdlib/m8194h/device.toml, each with its reason in
a `*_choice` key; the group and channel ranges are `[trigger_table]` of the same profile.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from mplang.ir.catalogue import Profile

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import VirtualController

CONDITIONS = ("off", "on", "on-to-off", "off-to-on", "change")
LEVELS = {"off": 0, "on": 1}  # the level conditions and the input level they stand for
EVENTS = ("mp", "abort-command", "abort-macro", "hold-drive")
REQUIRED_KEYS = ("group", "channel", "condition", "event")
ABORT_STOPS = ("decelerate", "sudden")
REPEATS = ("ignore", "queue")


def fires(condition: str, old: int, new: int) -> bool:
    """Whether a DI bit going from `old` to `new` fires `condition`. A level condition fires
    on entering its level (and, separately, when triggering is enabled at that level)."""
    if old == new:
        return False
    if condition == "change":
        return True
    if condition in ("on", "off-to-on"):
        return new == 1
    return new == 0  # "off", "on-to-off"


@dataclass(frozen=True)
class TriggerEntry:
    """One DI channel's setting in the utility's "FRnet DI Setting" window."""

    group: int
    channel: int
    condition: str
    event: str
    mp: int | None = None  # "mp": the program it starts
    axes: int | None = None  # "hold-drive": Table 4 mask of the axes held
    line: int | None = None  # source line, informative

    def bit(self, value: int) -> int:
        return (value >> self.channel) & 1

    def to_json(self) -> dict[str, object]:
        entry: dict[str, object] = {"group": self.group, "channel": self.channel,
                                    "condition": self.condition, "event": self.event}
        if self.mp is not None:
            entry["mp"] = self.mp
        if self.axes is not None:
            entry["axes"] = self.axes
        if self.line is not None:
            entry["line"] = self.line
        return entry


def _integer(entry: dict[str, Any], key: str, low: int, high: int, where: str) -> int:
    value = entry[key]
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ValueError(f"{where}: \"{key}\" must be an integer {low}..{high}, got {value!r}")
    return value


def parse_entries(raw: object, profile: Profile) -> tuple[TriggerEntry, ...]:
    """Validate entries of the image's JSON shape; ValueError names the bad entry (its
    index and source line) and what is wrong with it."""
    table = profile.raw["trigger_table"]
    first_group, last_group = int(table["first_group"]), int(table["last_group"])
    channels = int(table["channels"])
    mp_slots = profile.slot_numbers("mp")
    if not isinstance(raw, list):
        raise ValueError(f"the trigger entries must be a list, got {type(raw).__name__}")
    entries: list[TriggerEntry] = []
    seen: dict[tuple[int, int], str] = {}
    for index, item in enumerate(raw):
        where = f"trigger entry {index}"
        if not isinstance(item, dict):
            raise ValueError(f"{where}: expected an object, got {type(item).__name__}")
        line = item.get("line")
        if line is not None and (isinstance(line, bool) or not isinstance(line, int)):
            raise ValueError(f"{where}: \"line\" must be an integer, got {line!r}")
        if line is not None:
            where += f" (line {line})"
        missing = [k for k in REQUIRED_KEYS if k not in item]
        if missing:
            raise ValueError(f"{where}: missing {', '.join(repr(k) for k in missing)}")
        event = item["event"]
        if event not in EVENTS:
            raise ValueError(f"{where}: \"event\" must be one of {', '.join(EVENTS)}, got "
                             f"{event!r}")
        allowed = {*REQUIRED_KEYS, "line", *({"mp"} if event == "mp" else ()),
                   *({"axes"} if event == "hold-drive" else ())}
        extra = sorted(str(k) for k in item if k not in allowed)
        if extra:
            raise ValueError(f"{where}: unexpected {', '.join(repr(k) for k in extra)} for "
                             f"event {event!r}")
        group = _integer(item, "group", first_group, last_group, where)
        channel = _integer(item, "channel", 0, channels - 1, where)
        condition = item["condition"]
        if condition not in CONDITIONS:
            raise ValueError(f"{where}: \"condition\" must be one of {', '.join(CONDITIONS)}, "
                             f"got {condition!r}")
        mp = axes = None
        if event == "mp":
            if "mp" not in item:
                raise ValueError(f"{where}: event \"mp\" needs \"mp\": the program number")
            mp = _integer(item, "mp", min(mp_slots), max(mp_slots), where)
        if event == "hold-drive":
            if "axes" not in item:
                raise ValueError(f"{where}: event \"hold-drive\" needs \"axes\": a mask 1..15")
            axes = _integer(item, "axes", 1, 15, where)
        earlier = seen.get((group, channel))
        if earlier is not None:
            raise ValueError(f"{where}: DI {group}.{channel} already has a trigger "
                             f"({earlier})")
        seen[(group, channel)] = where
        entries.append(TriggerEntry(group, channel, condition, event, mp, axes, line))
    return tuple(sorted(entries, key=lambda e: (e.group, e.channel)))


@dataclass(frozen=True)
class Behaviour:
    """`[stand_alone]` of the device profile: the readings taken where the manual is silent."""

    level_fires_on_enable: bool
    release_hold_on_leaving_level: bool
    abort_command_stop: str  # "decelerate" | "sudden"
    abort_macro_drops_waiting: bool
    repeat_while_waiting: str  # "ignore" | "queue"
    enabled_persists: bool

    @classmethod
    def from_profile(cls, raw: dict[str, Any]) -> Behaviour:
        section = raw["stand_alone"]
        behaviour = cls(bool(section["level_fires_on_enable"]),
                        bool(section["release_hold_on_leaving_level"]),
                        str(section["abort_command_stop"]),
                        bool(section["abort_macro_drops_waiting"]),
                        str(section["repeat_while_waiting"]),
                        bool(section["enabled_persists"]))
        if behaviour.abort_command_stop not in ABORT_STOPS:
            raise ValueError(f"[stand_alone] abort_command_stop must be one of {ABORT_STOPS}")
        if behaviour.repeat_while_waiting not in REPEATS:
            raise ValueError(f"[stand_alone] repeat_while_waiting must be one of {REPEATS}")
        return behaviour


class Triggers:
    """The trigger table of one controller, its enable flag and the MPs waiting to run."""

    def __init__(self, vc: VirtualController) -> None:
        self.vc = vc
        self.behaviour = Behaviour.from_profile(vc.profile.raw)
        self.entries: tuple[TriggerEntry, ...] = ()
        self.enabled = False
        self.waiting: deque[int] = deque()  # MP numbers, in the order their events came
        # what fired, for tests and `mpc sim -v`: (time, entry, "fire" | "release")
        self.fired: deque[tuple[float, TriggerEntry, str]] = deque(maxlen=1000)

    def load(self, raw: object) -> None:
        """Replace the table (the utility's "Send Table"). If triggering is on, the new
        table's level conditions are checked as on enabling."""
        self.entries = parse_entries(raw, self.vc.profile)
        self.vc.memory_version += 1
        self.vc.log.append(f"{self.vc.clock:.4f} s: trigger table of {len(self.entries)} "
                           "entries loaded")
        if self.enabled:
            self._enter_levels()

    def set_enabled(self, enabled: bool) -> None:
        """Holding register 9. Enabling fires the level conditions already met; disabling
        stops all event processing (a hold already made stays until DRV_START)."""
        if enabled == self.enabled:
            return
        self.enabled = enabled
        self.vc.memory_version += 1
        self.vc.log.append(f"{self.vc.clock:.4f} s: FRnet DI triggering "
                           f"{'enabled' if enabled else 'disabled'}")
        if enabled:
            self._enter_levels()

    def _enter_levels(self) -> None:
        if not self.behaviour.level_fires_on_enable:
            return
        for entry in self.entries:
            level = LEVELS.get(entry.condition)
            if level is not None and entry.bit(self.vc.frnet[entry.group]) == level:
                self._fire(entry)

    def di_changed(self, group: int, old: int, new: int) -> None:
        """A DI group changed from `old` to `new` now: fire what the table says."""
        if not self.enabled or old == new:
            return
        for entry in self.entries:
            if entry.group != group:
                continue
            before, after = entry.bit(old), entry.bit(new)
            if fires(entry.condition, before, after):
                self._fire(entry)
            elif entry.event == "hold-drive" and entry.condition in LEVELS and \
                    before == LEVELS[entry.condition] != after and \
                    self.behaviour.release_hold_on_leaving_level:
                self._release(entry)

    # ------------------------------------------------------------------- events
    def _fire(self, entry: TriggerEntry) -> None:
        vc = self.vc
        self.fired.append((vc.clock, entry, "fire"))
        source = f"DI {entry.group}.{entry.channel} {entry.condition}"
        if entry.event == "mp":
            assert entry.mp is not None
            if not vc.stack and not self.waiting:
                self._start(entry.mp, source)
            elif entry.mp in self.waiting and self.behaviour.repeat_while_waiting == "ignore":
                vc.log.append(f"{vc.clock:.4f} s: {source}: MP{entry.mp} already waits")
            else:
                self.waiting.append(entry.mp)
                vc.log.append(f"{vc.clock:.4f} s: {source}: MP{entry.mp} waits for the "
                              "running program")
        elif entry.event == "abort-macro":
            dropped = list(self.waiting) if self.behaviour.abort_macro_drops_waiting else []
            if dropped:
                self.waiting.clear()
            vc.terminate_programs(f"{source}: macro aborted"
                                  + (f", waiting {dropped} dropped" if dropped else ""))
        elif entry.event == "abort-command":
            vc.motion.stop(0xF, vc.clock, sudden=self.behaviour.abort_command_stop == "sudden")
            vc.touch()
            vc.log.append(f"{vc.clock:.4f} s: {source}: motion stopped")
        else:
            assert entry.axes is not None
            vc.motion.hold(entry.axes)
            vc.touch()
            vc.log.append(f"{vc.clock:.4f} s: {source}: drive of "
                          f"{vc.profile.axis_name(entry.axes)} held")

    def _release(self, entry: TriggerEntry) -> None:
        vc = self.vc
        assert entry.axes is not None
        self.fired.append((vc.clock, entry, "release"))
        vc.motion.start(entry.axes, vc.clock)
        vc.touch()
        vc.log.append(f"{vc.clock:.4f} s: DI {entry.group}.{entry.channel} left "
                      f"{entry.condition}: drive of {vc.profile.axis_name(entry.axes)} released")

    def _start(self, slot: int, source: str) -> None:
        try:
            self.vc.call(slot)
        except ValueError as err:
            self.vc.log.append(f"{self.vc.clock:.4f} s: {source}: {err}: event ignored")

    def start_waiting(self) -> None:
        """Nothing runs: start the MP that waited longest (the controller calls this)."""
        slot = self.waiting.popleft()
        self._start(slot, "FRnet DI event")

    # -------------------------------------------------------------- persistence
    def to_json(self) -> dict[str, object]:
        data: dict[str, object] = {"entries": [e.to_json() for e in self.entries]}
        if self.behaviour.enabled_persists:
            data["enabled"] = self.enabled
        return data

    def from_json(self, data: object) -> None:
        """Restore a saved table (and enable flag): power on with that memory."""
        if not isinstance(data, dict):
            raise ValueError("\"triggers\" must be an object")
        enabled = data.get("enabled", False)
        if not isinstance(enabled, bool):
            raise ValueError("triggers.enabled must be true or false")
        self.entries = parse_entries(data.get("entries", []), self.vc.profile)
        self.enabled = False
        self.set_enabled(enabled and self.behaviour.enabled_persists)
