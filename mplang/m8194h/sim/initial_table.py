"""The initial parameter table of the virtual M8194H (manual chapter 8, RS 9666-9786).

The device keeps the basic settings of its motion chip in a non-volatile table (Figure 3).
A real-time command of the IT set (Table 1's IT column: catalogue rows with "it" in their
scope) whose axis operand is a Table 5 code (INITIAL_X = 0x11 ... INITIAL_XYZU = 0x1F)
writes its setting into that table "without changing the current setting" (RS 983);
LOAD_INITIAL (RTC 0x0AC8) applies the table to the live settings, and power on does the
same (RS 9738). Applying runs the very handlers a plain Table 4 command runs, so the table
and a live command can never disagree about what a setting does.

The table is one `AxisColumn` per axis. Each IT command updates some of its fields
(`UPDATES`); `commands_for` is the way back, the IT commands that set a live axis to a
column. Figure 3 settings the motion model does not simulate (pulse mode, encoder type and
division, digital filter, ring counter, triangle prevention) are kept in a per-axis record
of the controller and reported by `live_columns`, never dropped. The factory column, the
refusal cause, the loading time and RESET_CARD's behaviour are data: `[initial_table]` of
stdlib/m8194h/device.toml, with the reasons in its `*_choice` keys.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, fields, replace
from typing import TYPE_CHECKING, Any

from mplang.ir.catalogue import Catalogue, Command, Param
from mplang.ir.macro import Operand

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import Frame, Handler, VirtualController, Wait

AXIS_NAMES = ("X", "Y", "Z", "U")


@dataclass(frozen=True)
class AxisColumn:
    """One axis's column of Figure 3 (RS 9672-9700): every setting the table keeps."""

    pulse_mode: int
    max_v: int
    hlmt_forward: int
    hlmt_reverse: int
    limit_stop: int
    nhome_level: int
    home_level: int
    slmt_enabled: int
    slmt_forward: int
    slmt_reverse: int
    slmt_counter: int
    encoder_mode: int
    encoder_division: int
    z_level: int
    servo_on: int
    alarm_enabled: int
    alarm_level: int
    inpos_enabled: int
    inpos_level: int
    filter_inputs: int
    filter_time: int
    vring_enabled: int
    vring_max: int
    avtri_enabled: int
    external_drive: int  # 0 off (EXD_DISABLE), 1 hand wheel, 2 fixed pulse, 3 continuous
    external_drive_data: int  # the data of the EXD_MP / EXD_FP / EXD_CP in force


COLUMN_FIELDS = tuple(f.name for f in fields(AxisColumn))

# Settings the motion model has no use for yet: the controller stores them per axis (its
# `unmodelled` record) so that they are reported and applied like the others.
UNMODELLED = ("pulse_mode", "encoder_mode", "encoder_division", "filter_inputs",
              "filter_time", "vring_enabled", "vring_max", "avtri_enabled", "external_drive",
              "external_drive_data")

# Flags that only an enable/disable pair of commands writes (no enum in the catalogue).
FLAGS = ("slmt_enabled", "servo_on", "vring_enabled", "avtri_enabled")


def _fields(*names: str) -> Callable[[Sequence[int]], dict[str, int]]:
    """An update that stores the command's operands (after the axis) in these fields."""
    def update(values: Sequence[int]) -> dict[str, int]:
        return dict(zip(names, values, strict=True))
    return update


def _const(**settings: int) -> Callable[[Sequence[int]], dict[str, int]]:
    def update(_values: Sequence[int]) -> dict[str, int]:
        return dict(settings)
    return update


def _slmt(values: Sequence[int]) -> dict[str, int]:
    forward, reverse, counter = values
    return {"slmt_enabled": 1, "slmt_forward": forward, "slmt_reverse": reverse,
            "slmt_counter": counter}


def _vring(values: Sequence[int]) -> dict[str, int]:
    return {"vring_enabled": 1, "vring_max": values[0]}


# What each IT command writes, given its operands after the axis (sections 3.3-3.16).
UPDATES: dict[str, Callable[[Sequence[int]], dict[str, int]]] = {
    "SET_PULSE_MODE": _fields("pulse_mode"),
    "SET_MAX_V": _fields("max_v"),
    "SET_HLMT": _fields("hlmt_forward", "hlmt_reverse"),
    "LIMITSTOP_MODE": _fields("limit_stop"),
    "SET_NHOME": _fields("nhome_level"),
    "SET_HOME_EDGE": _fields("home_level"),
    "SET_SLMT": _slmt,
    "CLEAR_SLMT": _const(slmt_enabled=0),
    "SET_ENCODER": _fields("encoder_mode", "encoder_division", "z_level"),
    "SERVO_ON": _const(servo_on=1),
    "SERVO_OFF": _const(servo_on=0),
    "SET_ALARM": _fields("alarm_enabled", "alarm_level"),
    "SET_INPOS": _fields("inpos_enabled", "inpos_level"),
    "SET_FILTER": _fields("filter_inputs", "filter_time"),
    "VRING_ENABLE": _vring,
    "VRING_DISABLE": _const(vring_enabled=0),
    "AVTRI_ENABLE": _const(avtri_enabled=1),
    "AVTRI_DISABLE": _const(avtri_enabled=0),
    "EXD_DISABLE": _const(external_drive=0),
}


def _exd(mode: int) -> Callable[[Sequence[int]], dict[str, int]]:
    def update(values: Sequence[int]) -> dict[str, int]:
        return {"external_drive": mode, "external_drive_data": values[0]}
    return update


# Real-time commands outside the IT set that change a setting the table keeps (3.17): only
# the live record sees them, since the table can only switch the external drive off.
LIVE_UPDATES: dict[str, Callable[[Sequence[int]], dict[str, int]]] = {
    "EXD_MP": _exd(1), "EXD_FP": _exd(2), "EXD_CP": _exd(3),
}

# The one step of loading that no single command does: software limits the table keeps
# disabled, with their values (SET_SLMT then CLEAR_SLMT would enable them for an instant and
# stop an axis already beyond them). Not a device command: only `load_commands` emits it.
SLMT_DISABLED = "LOAD_SLMT_DISABLED"
LOAD_UPDATES: dict[str, Callable[[Sequence[int]], dict[str, int]]] = {
    SLMT_DISABLED: lambda values: {**_slmt(values), "slmt_enabled": 0},
}
ALL_UPDATES = {**UPDATES, **LIVE_UPDATES, **LOAD_UPDATES}


def commands_for(column: AxisColumn) -> list[tuple[str, tuple[int, ...]]]:
    """The IT commands (operands after the axis), in the order of the factory list (RS
    9703-9722), that set an axis to `column` whatever it was before. Disabled software
    limits are `SLMT_DISABLED` (values stored, limits off); the ring counter is written
    with its value and disabled after, so a disabled setting keeps the value the table
    holds."""
    c = column
    limits = (c.slmt_forward, c.slmt_reverse, c.slmt_counter)
    out: list[tuple[str, tuple[int, ...]]] = [
        ("SET_PULSE_MODE", (c.pulse_mode,)),
        ("SET_MAX_V", (c.max_v,)),
        ("SET_HLMT", (c.hlmt_forward, c.hlmt_reverse)),
        ("LIMITSTOP_MODE", (c.limit_stop,)),
        ("SET_NHOME", (c.nhome_level,)),
        ("SET_HOME_EDGE", (c.home_level,)),
        ("SET_SLMT" if c.slmt_enabled else SLMT_DISABLED, limits),
    ]
    out += [
        ("SET_ENCODER", (c.encoder_mode, c.encoder_division, c.z_level)),
        ("SERVO_ON" if c.servo_on else "SERVO_OFF", ()),
        ("SET_ALARM", (c.alarm_enabled, c.alarm_level)),
        ("SET_INPOS", (c.inpos_enabled, c.inpos_level)),
        ("SET_FILTER", (c.filter_inputs, c.filter_time)),
        ("VRING_ENABLE", (c.vring_max,)),
    ]
    if not c.vring_enabled:
        out.append(("VRING_DISABLE", ()))
    out.append(("AVTRI_ENABLE" if c.avtri_enabled else "AVTRI_DISABLE", ()))
    out.append(("EXD_DISABLE", ()))  # the only external-drive setting the table can hold
    return out


def load_commands(columns: Sequence[AxisColumn]) -> list[tuple[str, tuple[int, ...]]]:
    """LOAD_INITIAL as plain (Table 4) commands: axes with equal columns share one mask, so
    the factory table takes one command per setting, as the factory list writes it."""
    masks: dict[AxisColumn, int] = {}
    for index, column in enumerate(columns):
        masks[column] = masks.get(column, 0) | 1 << index
    return [(name, (mask, *values)) for column, mask in masks.items()
            for name, values in commands_for(column)]


def in_range(param: Param, operand: Operand) -> bool:
    """An operand of an IT write: a plain value (no variable) within the catalogue's range."""
    if isinstance(operand, bool) or not isinstance(operand, int):
        return False
    if param.values and operand not in param.values:
        return False
    if param.min is not None and operand < param.min:
        return False
    return param.max is None or operand <= param.max


@dataclass(frozen=True)
class TableConfig:
    """`[initial_table]` of the device profile."""

    factory: AxisColumn
    offset: int  # Table 5 = Table 4 + offset (profile [axes])
    refusal_cause: int
    load_time: float  # seconds register 101 shows 4
    reset_card_reloads: bool

    @classmethod
    def from_profile(cls, raw: dict[str, Any]) -> TableConfig:
        section = raw["initial_table"]
        factory = section["factory"]
        missing = [name for name in COLUMN_FIELDS if not isinstance(factory.get(name), int)]
        if missing:
            raise ValueError(f"[initial_table.factory] lacks integer {', '.join(missing)}")
        return cls(AxisColumn(**{name: int(factory[name]) for name in COLUMN_FIELDS}),
                   int(raw["axes"]["initial_table_offset"]), int(section["refusal_cause"]),
                   int(section["load_time_us"]) / 1e6, bool(section["reset_card_reloads"]))


class InitialTable:
    """The non-volatile table: one column per axis, starting as the factory table."""

    def __init__(self, catalogue: Catalogue) -> None:
        self.catalogue = catalogue
        self.config = TableConfig.from_profile(catalogue.profile.raw)
        self.columns: list[AxisColumn] = [self.config.factory] * len(AXIS_NAMES)
        first = self.config.offset
        self.codes = range(first + 1, first + 16)  # INITIAL_X .. INITIAL_XYZU

    def write(self, name: str, mask: int, values: Sequence[int]) -> None:
        """Store one IT command (or a step of `commands_for`) for the axes of a mask."""
        updates = ALL_UPDATES[name](values)
        for index in range(len(AXIS_NAMES)):
            if mask >> index & 1:
                self.columns[index] = replace(self.columns[index], **updates)

    def refusal(self, command: Command, operands: Sequence[Operand]) -> int:
        """0 if the frame may go on, else the register-102 cause it is refused with: an
        INITIAL_* code (or the bare offset 0x10) in any axis operand of a macro command, of
        a real-time command outside the IT set, or of an IT write whose other values are
        variables or out of range."""
        offset = self.config.offset
        for index, (param, operand) in enumerate(zip(command.params, operands, strict=False)):
            if not param.kind.startswith("axis") or not isinstance(operand, int) or \
                    not offset <= operand <= offset + 15:
                continue
            if command.is_macro or "it" not in command.scope or param.kind != "axis_it" or \
                    operand not in self.codes:
                return self.config.refusal_cause
            rest = zip(command.params[index + 1:], operands[index + 1:], strict=True)
            if not all(in_range(p, o) for p, o in rest):
                return self.config.refusal_cause
        return 0

    # --------------------------------------------------------------- persistence
    def to_json(self) -> dict[str, dict[str, int]]:
        return {name: asdict(column) for name, column in zip(AXIS_NAMES, self.columns,
                                                               strict=True)}

    def from_json(self, data: object) -> None:
        """Replace the table with one saved by `to_json`; ValueError (and the table left as
        it was) if any axis, field or value is missing, extra or outside what the IT
        commands can write."""
        if not isinstance(data, dict) or sorted(data) != sorted(AXIS_NAMES):
            raise ValueError(f"\"initial_table\" must have exactly the axes "
                             f"{', '.join(AXIS_NAMES)}")
        columns: list[AxisColumn] = []
        for axis in AXIS_NAMES:
            raw = data[axis]
            if not isinstance(raw, dict) or sorted(raw) != sorted(COLUMN_FIELDS):
                raise ValueError(f"initial_table.{axis} must have exactly the fields "
                                 f"{', '.join(COLUMN_FIELDS)}")
            bad = [k for k, v in raw.items() if isinstance(v, bool) or not isinstance(v, int)]
            if bad:
                raise ValueError(f"initial_table.{axis}.{bad[0]} is not an integer")
            column = AxisColumn(**raw)
            problem = self.column_problem(column)
            if problem:
                raise ValueError(f"initial_table.{axis}: {problem}")
            columns.append(column)
        self.columns = columns

    def column_problem(self, column: AxisColumn) -> str:
        """Why no sequence of IT writes could give this column ("" if one could)."""
        for flag in FLAGS:
            if getattr(column, flag) not in (0, 1):
                return f"{flag} must be 0 or 1"
        factory = self.config.factory
        if (column.external_drive, column.external_drive_data) != \
                (0, factory.external_drive_data):
            return "the initial table can only switch the external drive off (EXD_DISABLE)"
        for name, values in commands_for(column):
            command = self.catalogue.rtc_by_short["SET_SLMT" if name == SLMT_DISABLED else name]
            for param, value in zip(command.params[1:], values, strict=True):
                if not in_range(param, value):
                    return f"{name} {param.name} = {value} is out of range"
        return ""


def live_columns(vc: VirtualController) -> tuple[AxisColumn, ...]:
    """The settings in force now, as table columns: the modelled ones read from the motion
    model and its axis I/O, the others from the controller's record."""
    columns = []
    for index in range(len(AXIS_NAMES)):
        cfg = vc.motion.io.cfg[index]
        record = vc.unmodelled[index]
        columns.append(replace(
            record, max_v=vc.motion.settings[index].max_v,
            hlmt_forward=cfg.hlmt_plus_level, hlmt_reverse=cfg.hlmt_minus_level,
            limit_stop=int(cfg.limit_stop_slow), nhome_level=cfg.nhome_level,
            home_level=cfg.home_level, slmt_enabled=int(cfg.slmt),
            slmt_forward=cfg.comp_plus, slmt_reverse=cfg.comp_minus,
            slmt_counter=int(cfg.comp_ep), z_level=cfg.z_level,
            servo_on=int(vc.motion.io.status[index].servo_on),
            alarm_enabled=int(cfg.alarm_enabled), alarm_level=cfg.alarm_level,
            inpos_enabled=int(cfg.inpos_enabled), inpos_level=cfg.inpos_level))
    return tuple(columns)


def wrap_handlers(vc: VirtualController, handlers: dict[str, Handler]) -> None:
    """Give every IT command its table path: an INITIAL_* axis writes the table (only the
    real-time form gets here with one: downloads refuse it), a Table 4 axis runs the live
    handler, if the model has one, and records the settings the model does not simulate."""
    for name, update in UPDATES.items():
        handlers[name] = _setting_handler(vc, name, handlers.get(name), update, True)
    for name, update in LIVE_UPDATES.items():
        handlers[name] = _setting_handler(vc, name, handlers.get(name), update, False)

    def slmt_disabled(_frame: Frame, ops: tuple[Operand, ...]) -> None:
        mask, forward, reverse, counter = (vc.value(o) for o in ops)
        vc.motion.io.store_slmt_disabled(mask, forward, reverse, counter, vc.clock)
    handlers[SLMT_DISABLED] = slmt_disabled


def _setting_handler(vc: VirtualController, name: str, live: Handler | None,
                     update: Callable[[Sequence[int]], dict[str, int]], it: bool) -> Handler:

    def run(frame: Frame, ops: tuple[Operand, ...]) -> Wait | None:
        values = [vc.value(o) for o in ops]
        mask = values[0]
        if it and mask in vc.initial_table.codes:
            vc.initial_table.write(name, mask & 0xF, values[1:])
            vc.memory_version += 1  # the table is non-volatile: `mpc sim --memory` saves it
            vc.log.append(f"{vc.clock:.4f} s: {name} {values[1:]} written to the initial "
                          f"table of {vc.profile.axis_name(mask & 0xF)}")
            return None
        wait = live(frame, ops) if live is not None else None
        if not 1 <= mask <= 15:
            raise ValueError(f"axis mask must be 1..15, got {mask}")
        stored = {k: v for k, v in update(values[1:]).items() if k in UNMODELLED}
        if stored:
            made: dict[AxisColumn, AxisColumn] = {}  # equal records are replaced once
            for index in range(len(AXIS_NAMES)):
                if mask >> index & 1:
                    old = vc.unmodelled[index]
                    new = made.get(old)
                    if new is None:
                        new = made[old] = replace(old, **stored)
                    vc.unmodelled[index] = new
        return wait
    return run
