"""The simulated machine as configuration: a `[machine]` table (in `mpc.toml`, or a file of its
own given with `--machine FILE`) that says where each axis's switches are, where it stands at
power on, and how inputs change over a run. docs/machine.md describes every key.

`load_machine(path)` reads and checks the table; every problem is a `MachineError` whose
message starts with `file:line`. `apply_machine(controller, setup)` puts the machine into a
virtual controller: the switches into the axis I/O's sensors (`sim.signals.AxisSensors`), the
power-on position and the encoder offset into the counters, and the script into the axis
I/O's event plan (`sim.scripted`). There is no second model of the machine: these are the
virtual controller's own sensors and inputs, set from a file.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mplang.family.face import MachineError
from mplang.lang.tomlfile import TomlFileError, TomlLines, read_toml
from mplang.m8194h.sim.axes import AXES
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.motion import MotionModel
from mplang.m8194h.sim.scripted import AXIS_INPUTS, InputChange, TimedChange, Watch
from mplang.m8194h.sim.signals import AxisSensors

__all__ = ["AxisSetup", "MachineError", "MachineSetup", "apply_machine", "load_machine",
           "parse_event"]

MACHINE_KEYS = frozenset({"emg", "events", *AXES})
AXIS_KEYS = frozenset({"limit-plus", "limit-minus", "near-home", "home", "index", "start",
                       "encoder-offset", "alarm", "inpos"})
INDEX_KEYS = frozenset({"period", "at", "width"})
POSITION_RANGE = (-(1 << 31), (1 << 31) - 1)
_DEFAULT = AxisSensors()
_AT = re.compile(r"at\s+(\S+?)\s*(ms|s)\s+(.+)", re.IGNORECASE | re.DOTALL)
_WHEN = re.compile(r"when\s+(\w+)\s*(>=|<=|>|<)\s*(\S+?)\s+([A-Za-z].*)",
                   re.IGNORECASE | re.DOTALL)
_ASSIGN = re.compile(r"\s*([A-Za-z0-9_.]+)\s*=\s*(\S+)\s*")
_DI = re.compile(r"DI(\d+)(?:\.(\d+))?", re.IGNORECASE)


@dataclass(frozen=True)
class AxisSetup:
    """One axis of the machine: its switches (machine positions, pulses), where it stands at
    power on, its encoder offset (EP - LP), and its drive's ALARM and INPOS outputs."""

    sensors: AxisSensors = field(default_factory=AxisSensors)
    start: int = 0
    encoder_offset: int = 0
    alarm: bool = False
    inpos: bool | None = None  # None: on while the servo is on and the axis stands


@dataclass(frozen=True)
class MachineSetup:
    """A checked `[machine]` table: what `apply_machine` puts into a controller."""

    path: Path
    axes: Mapping[int, AxisSetup] = field(default_factory=dict)
    emg: bool = False
    timed: tuple[TimedChange, ...] = ()
    watches: tuple[Watch, ...] = ()


class _Where(TomlLines):
    """The line of `[table]`, `key =` or a string in the file, for messages."""

    def __init__(self, path: Path, text: str) -> None:
        super().__init__(text)
        self.path = path

    def error(self, table: str, key: str | None, message: str,
              needle: str | None = None) -> MachineError:
        where = f"[{table}] {key}" if key else f"[{table}]"
        return MachineError(f"{self.path}:{self.line(table, key, needle)}: {where}: {message}")


def load_machine(path: Path, *, project: bool = False) -> MachineSetup:
    """Read and check the `[machine]` table of `path`: a machine file (that table alone) or,
    with `project`, an mpc.toml (whose other tables the project reader checks)."""
    data, where = _read(path)
    if not project:
        for name in data:
            if name != "machine":
                raise MachineError(f"{path}:{where.line(name)}: unknown table or key "
                                   f"{name!r}: a machine file holds one [machine] table")
    table = data.get("machine")
    if table is None:
        raise MachineError(f"{path}:1: no [machine] table (docs/machine.md)")
    if not isinstance(table, dict):
        raise MachineError(f"{path}:{where.line('machine')}: machine must be a table "
                           "[machine]")
    for key in table:
        if key not in MACHINE_KEYS:
            expected = ("expected emg, events or an axis table [machine.X], [machine.Y], "
                        "[machine.Z], [machine.U]")
            if isinstance(table[key], dict):  # [machine.W]: at its own header
                raise MachineError(f"{path}:{where.line(f'machine.{key}')}: [machine.{key}]: "
                                   f"unknown axis or table; {expected}")
            raise where.error("machine", key, f"unknown key; {expected}")
    axes = {AXES.index(name): _axis(table[name], f"machine.{name}", where)
            for name in AXES if name in table}
    emg = table.get("emg", False)
    if not isinstance(emg, bool):
        raise where.error("machine", "emg", f"must be true or false, not {emg!r}")
    raw_events = table.get("events", [])
    if not isinstance(raw_events, list) or not all(isinstance(e, str) for e in raw_events):
        raise where.error("machine", "events", "must be a list of strings such as "
                          "\"at 2.0 s DI8.3 = 1\" or \"when X >= 5000 X.IN3 = 1\"")
    timed: list[TimedChange] = []
    watches: list[Watch] = []
    for text in raw_events:
        try:
            event = parse_event(text)
        except ValueError as exc:
            raise where.error("machine", "events", f"{text!r}: {exc}", needle=text) from None
        if isinstance(event, TimedChange):
            timed.append(event)
        else:
            watches.append(event)
    return MachineSetup(path, axes, emg, tuple(timed), tuple(watches))


def _read(path: Path) -> tuple[dict[str, Any], _Where]:
    try:
        data, text = read_toml(path)
    except TomlFileError as exc:
        raise MachineError(str(exc)) from None
    return data, _Where(path, text)


def _axis(raw: object, table: str, where: _Where) -> AxisSetup:
    if not isinstance(raw, dict):
        raise where.error("machine", table.split(".")[1], "must be a table of the axis's "
                          "settings")
    for key in raw:
        if key not in AXIS_KEYS:
            raise where.error(table, key, f"unknown key; expected one of "
                              f"{', '.join(sorted(AXIS_KEYS))}")

    def position(key: str, default: int | None, fitted: bool = True) -> int | None:
        value = raw.get(key, default)
        if value is False and fitted:
            return None
        if not isinstance(value, int) or isinstance(value, bool) or \
                not POSITION_RANGE[0] <= value <= POSITION_RANGE[1]:
            allowed = " (or false: not fitted)" if fitted else ""
            raise where.error(table, key, f"must be a whole number of pulses{allowed}, "
                              f"not {value!r}")
        return value

    def span(key: str, default: tuple[int, int] | None) -> tuple[int, int] | None:
        if key not in raw:
            return default
        value = raw[key]
        if value is False:
            return None
        if not (isinstance(value, list) and len(value) == 2 and
                all(isinstance(v, int) and not isinstance(v, bool) for v in value)):
            raise where.error(table, key, f"must be [FROM, TO] in pulses (or false: not "
                              f"fitted), not {value!r}")
        if value[0] > value[1]:
            raise where.error(table, key, f"[{value[0]}, {value[1]}] is empty: FROM must "
                              "not be above TO")
        return value[0], value[1]

    plus = position("limit-plus", None) if "limit-plus" in raw else None
    minus = position("limit-minus", None) if "limit-minus" in raw else None
    if plus is not None and minus is not None and minus >= plus:
        raise where.error(table, "limit-minus", f"{minus} is not below limit-plus {plus}")
    period, at, width = _index(raw.get("index", {}), table, where)
    alarm = raw.get("alarm", False)
    if not isinstance(alarm, bool):
        raise where.error(table, "alarm", f"must be true or false, not {alarm!r}")
    inpos = raw.get("inpos", "auto")
    if inpos != "auto" and not isinstance(inpos, bool):
        raise where.error(table, "inpos", f"must be \"auto\", true or false, not {inpos!r}")
    sensors = AxisSensors(limit_plus=plus, limit_minus=minus,
                          near_home=span("near-home", _DEFAULT.near_home),
                          home=span("home", _DEFAULT.home), index_period=period,
                          index_offset=at, index_width=width)
    return AxisSetup(sensors, position("start", 0, fitted=False) or 0,
                     position("encoder-offset", 0, fitted=False) or 0, alarm,
                     None if inpos == "auto" else bool(inpos))


def _index(raw: object, table: str, where: _Where) -> tuple[int | None, int, int]:
    """The Z phase: (period, at, width); period None when not fitted."""
    if raw is False:
        return None, 0, 1
    if not isinstance(raw, dict):
        raise where.error(table, "index", f"must be {{ period = P, at = A, width = W }} (or "
                          f"false: no Z phase), not {raw!r}")
    for key in raw:
        if key not in INDEX_KEYS:
            raise where.error(table, "index", f"unknown key {key!r}; expected period, at, "
                              "width")
    values = {"period": _DEFAULT.index_period, "at": _DEFAULT.index_offset,
              "width": _DEFAULT.index_width, **raw}
    for key, value in values.items():
        if not isinstance(value, int) or isinstance(value, bool):
            raise where.error(table, "index", f"{key} must be a whole number of pulses, "
                              f"not {value!r}")
    period, at, width = values["period"], values["at"], values["width"]
    assert period is not None
    if not 1 <= period <= POSITION_RANGE[1] or not 1 <= width < period:
        raise where.error(table, "index", f"period must be at least 1 and width 1..period-1 "
                          f"(got period {period}, width {width})")
    return period, at, width


def parse_event(text: str) -> TimedChange | Watch:
    """One `events` entry: `at TIME s|ms NAME = VALUE, ...` or `when AXIS OP POSITION NAME =
    VALUE, ...` (OP one of >=, <=, >, <). ValueError says what is wrong."""
    stripped = text.strip()
    at = _AT.fullmatch(stripped)
    if at is not None:
        try:
            time = float(at.group(1))
        except ValueError:
            raise ValueError(f"{at.group(1)!r} is not a time; write e.g. \"at 2.5 s ...\"") \
                from None
        if not math.isfinite(time) or time < 0:
            raise ValueError(f"the time must be 0 or more seconds, not {at.group(1)}")
        seconds = time / 1000 if at.group(2).lower() == "ms" else time
        return TimedChange(seconds, _changes(at.group(3)))
    when = _WHEN.fullmatch(stripped)
    if when is not None:
        axis = when.group(1).upper()
        if axis not in AXES:
            raise ValueError(f"unknown axis {when.group(1)!r}; the axes are X, Y, Z, U")
        try:
            value = int(when.group(3), 0)
        except ValueError:
            raise ValueError(f"{when.group(3)!r} is not a whole number of pulses") from None
        op = when.group(2)
        # every condition is "position >= threshold" or its negation
        threshold = value + 1 if op in (">", "<=") else value
        return Watch(AXES.index(axis), threshold, op in (">=", ">"), _changes(when.group(4)))
    if stripped.lower().startswith("at"):
        raise ValueError("write a timed change as \"at TIME s NAME = VALUE\" (s or ms)")
    if stripped.lower().startswith("when"):
        raise ValueError("write a condition as \"when AXIS OP POSITION NAME = VALUE\" with "
                         "OP one of >=, <=, >, <")
    raise ValueError("an event starts with \"at TIME s\" or \"when AXIS OP POSITION\"")


def _changes(text: str) -> tuple[InputChange, ...]:
    changes = []
    for part in text.split(","):
        match = _ASSIGN.fullmatch(part)
        if match is None:
            raise ValueError(f"{part.strip()!r}: write NAME = VALUE, e.g. DI8.3 = 1")
        changes.append(_change(match.group(1), match.group(2)))
    return tuple(changes)


def _change(name: str, text: str) -> InputChange:
    """One `NAME = VALUE`: the input named (EMG, X.ALARM, X.IN3, X.INPOS, DIg.c, DIg)."""
    try:
        value = int(text, 0)
    except ValueError:
        raise ValueError(f"{name} = {text}: the value must be a whole number") from None
    upper = name.upper()
    di = _DI.fullmatch(upper)
    if di is not None:
        group = int(di.group(1))
        if not 8 <= group <= 15:
            raise ValueError(f"{name}: FRnet DI groups are 8..15 (0..7 are outputs)")
        if di.group(2) is None:
            if not 0 <= value <= 0xFFFF:
                raise ValueError(f"{name} = {text}: a DI group holds 0..0xFFFF")
            return InputChange(upper, value, group=group, mask=0xFFFF)
        channel = int(di.group(2))
        if not 0 <= channel <= 15:
            raise ValueError(f"{name}: FRnet channels are 0..15")
        return InputChange(upper, _bit(name, text, value), group=group, mask=1 << channel)
    if upper == "EMG":
        return InputChange(upper, _bit(name, text, value))
    axis, _dot, signal = upper.partition(".")
    if axis in AXES and signal in AXIS_INPUTS:
        return InputChange(upper, _bit(name, text, value), axis=AXES.index(axis))
    raise ValueError(f"unknown input {name!r}; inputs are EMG, AXIS.ALARM, AXIS.IN3, "
                     "AXIS.INPOS (AXIS X, Y, Z or U), DIg.c (FRnet DI group 8..15, channel "
                     "0..15) and DIg (a whole group)")


def _bit(name: str, text: str, value: int) -> int:
    if value not in (0, 1):
        raise ValueError(f"{name} = {text}: an input is 0 (off) or 1 (on)")
    return value


def apply_machine(controller: VirtualController, setup: MachineSetup) -> None:
    """Put the machine into `controller` (after its programs are loaded): switches, power-on
    positions, encoder offsets, ALARM, INPOS and EMG, then the script from the present clock.
    The controller keeps it across RESET_CARD, as a machine keeps its switches: applied again
    to the new motion chip, each axis stays where it was on the machine and the inputs take
    the state the script has given them so far."""
    chips: list[MotionModel] = []  # the motion model it was applied to last

    def apply(vc: VirtualController) -> None:
        io, model, now = vc.motion.io, vc.motion, vc.clock
        for i, axis in setup.axes.items():
            where = chips[0].io.machine_position(i, now) if chips else axis.start
            io.set_sensors(i, axis.sensors, now)
            io.status[i].mach_off = where - model.lp(1 << i, now)
            model.set_ep(1 << i, model.lp(1 << i, now) + axis.encoder_offset, now)
            io.inpos_forced[i] = axis.inpos
            if axis.alarm:
                io.set_alarm_input(i, True, now)
        if setup.emg:
            io.set_emg_input(True, now)
        io.load_script(list(setup.timed), list(setup.watches), now)
        vc.touch()
        chips[:] = [model]

    apply(controller)
    controller.machine = apply
