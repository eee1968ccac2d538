"""The values the motion chip holds for a speed, acceleration or jerk setting.

The i-8094H keeps these settings in units that follow from the maximum speed MAX_V: "There
are 8000 speed segments available" (RS 1146), so a speed is a multiple of MAX_V / 8000 and
SET_MAX_V "sets the maximum rate for the output pulses" (RS 1146); "The minimum acceleration
value is MAX_V / 64, and all other acceleration values are the integral multipliers of this
value", at most MAX_V * 125 (RS 5157, 5209, 6170, 6218); a jerk lies between MAX_V *
0.0119211 and 2,000,000,000 (RS 5257, 6272). The numbers and the readings the manual leaves
open are the device profile's `[chip_values]` (see docs/device-choices.md).

The virtual controller plans every motion with these values (`sim.profiles`), so a run's
timing is the device's; the compiler warns (W111) where a constant argument will be changed
so, giving the value the device uses.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from itertools import count
from typing import TYPE_CHECKING, Any

from mplang.lang.diagnostics import Diagnostic, DiagnosticSink, Run
from mplang.lang.record import FrozenRecord

if TYPE_CHECKING:
    from mplang.ir.blockmemo import Chunk, Statement
    from mplang.ir.catalogue import Profile
    from mplang.ir.macro import LoweredProgram, MacroLine
    from mplang.ir.reuse import Lowered, Lowerings

#: the power-on maximum speed (factory initial table, RS 9705)
DEFAULT_MAX_V = 200_000

KINDS = ("speed", "acceleration", "jerk")


def _nearest(x: float) -> int:
    """Round half up (the same on every platform and in every tool)."""
    return math.floor(x + 0.5)


class ChipRules(FrozenRecord):
    """How the chip holds a setting, as a function of the axis's MAX_V. Equal (and hashed)
    by its numbers, not by `parameters`: the virtual controller keys its plans by them."""

    speed_steps: int
    acceleration_divisor: int
    acceleration_max_factor: int
    acceleration_rounding: str
    jerk_min_factor: float
    jerk_max: int
    #: command short name -> parameter name -> "speed" | "acceleration" | "jerk"
    parameters: dict[str, dict[str, str]]
    _fields = __match_args__ = ("speed_steps", "acceleration_divisor", "acceleration_max_factor",
                                "acceleration_rounding", "jerk_min_factor", "jerk_max",
                                "parameters")
    _compared = _fields[:-1]

    def __init__(self, speed_steps: int = 8000, acceleration_divisor: int = 64,
                 acceleration_max_factor: int = 125, acceleration_rounding: str = "nearest",
                 jerk_min_factor: float = 0.0119211, jerk_max: int = 2_000_000_000,
                 parameters: dict[str, dict[str, str]] | None = None) -> None:
        self.__dict__.update(
            speed_steps=speed_steps, acceleration_divisor=acceleration_divisor,
            acceleration_max_factor=acceleration_max_factor,
            acceleration_rounding=acceleration_rounding, jerk_min_factor=jerk_min_factor,
            jerk_max=jerk_max, parameters={} if parameters is None else parameters)

    def _values(self) -> tuple[Any, ...]:
        return tuple(getattr(self, name) for name in self._compared)

    def __eq__(self, other: object) -> bool:
        if other.__class__ is not self.__class__:
            return NotImplemented
        return self._values() == other._values()

    __hash__ = FrozenRecord.__hash__  # defining __eq__ would drop it

    @classmethod
    def from_profile(cls, raw: dict[str, Any]) -> ChipRules:
        """The rules of a device profile's `[chip_values]` table."""
        table = raw["chip_values"]
        rounding = str(table["acceleration_rounding"])
        if rounding not in ("nearest", "down"):
            raise ValueError(f"chip_values.acceleration_rounding is 'nearest' or 'down', "
                             f"not {rounding!r}")
        parameters = {str(name): {str(p): str(kind) for p, kind in params.items()}
                      for name, params in table["parameters"].items()}
        for name, params in parameters.items():
            for param, kind in params.items():
                if kind not in KINDS:
                    raise ValueError(f"chip_values.parameters.{name}.{param}: {kind!r} is "
                                     f"not one of {', '.join(KINDS)}")
        return cls(int(table["speed_steps"]), int(table["acceleration_divisor"]),
                   int(table["acceleration_max_factor"]), rounding,
                   float(table["jerk_min_factor"]), int(table["jerk_max"]), parameters)

    def speed_step(self, max_v: float) -> float:
        return max_v / self.speed_steps

    def acceleration_step(self, max_v: float) -> float:
        return max_v / self.acceleration_divisor

    def speed(self, speed: float, max_v: float) -> float:
        """A drive or start speed as the chip runs it: at most MAX_V, a multiple of MAX_V /
        8000 (the nearest), a non-zero speed at least one step; 0 or less stays 0."""
        if speed <= 0:
            return 0.0
        step = self.speed_step(max_v)
        return step * max(1, min(_nearest(speed / step), self.speed_steps))

    def acceleration(self, acc: float, max_v: float) -> float:
        """An acceleration or deceleration as the chip runs it: a multiple of MAX_V / 64
        (the nearest, or the one below for `acceleration_rounding` "down"), at least one
        step and at most MAX_V * 125."""
        step = self.acceleration_step(max_v)
        units = acc / step
        n = math.floor(units) if self.acceleration_rounding == "down" else _nearest(units)
        return step * max(1, min(n, self.acceleration_max_factor * self.acceleration_divisor))

    def jerk(self, jerk: float, max_v: float) -> float:
        """A jerk (K, L, VK, VL) as the chip runs it: within MAX_V * 0.0119211 and the
        manual's maximum."""
        return float(min(max(jerk, max_v * self.jerk_min_factor), self.jerk_max))

    def apply(self, kind: str, value: float, max_v: float) -> float:
        if kind == "speed":
            return self.speed(value, max_v)
        if kind == "acceleration":
            return self.acceleration(value, max_v)
        return self.jerk(value, max_v)

    def why(self, kind: str, value: float, max_v: float) -> str:
        """The rule that changes `value` (for a warning)."""
        if kind == "speed":
            if value > max_v:
                return f"a speed is at most MAX_V {max_v:g}"
            return f"a speed is a multiple of MAX_V/{self.speed_steps} = " \
                   f"{self.speed_step(max_v):g} with MAX_V {max_v:g}"
        if kind == "acceleration":
            step = self.acceleration_step(max_v)
            if value > self.acceleration_max_factor * max_v:
                return f"an acceleration is at most MAX_V*{self.acceleration_max_factor} " \
                       f"with MAX_V {max_v:g}"
            if value < step:
                return f"an acceleration is at least MAX_V/{self.acceleration_divisor} = " \
                       f"{step:g} with MAX_V {max_v:g}"
            return f"an acceleration is a multiple of MAX_V/{self.acceleration_divisor} = " \
                   f"{step:g} with MAX_V {max_v:g}"
        if value > self.jerk_max:
            return f"a jerk is at most {self.jerk_max}"
        return f"a jerk is at least MAX_V*{self.jerk_min_factor:g} with MAX_V {max_v:g}"


class Changed(FrozenRecord):
    """A constant argument the chip will hold as another value."""

    index: int  # the operand's position
    param: str
    kind: str
    given: float
    used: float
    max_v: float
    reason: str
    _fields = __match_args__ = ("index", "param", "kind", "given", "used", "max_v", "reason")

    def __init__(self, index: int, param: str, kind: str, given: float, used: float,
                 max_v: float, reason: str) -> None:
        self.__dict__.update(index=index, param=param, kind=kind, given=given, used=used,
                             max_v=max_v, reason=reason)


def changed_arguments(rules: ChipRules, command: str, params: Iterable[str],
                      operands: Iterable[object], max_v: float) -> Iterator[Changed]:
    """The constant speed, acceleration and jerk arguments of one command (by short name)
    that the chip holds as another value, with that value. Variables are not known."""
    kinds = rules.parameters.get(command, {})
    for index, (param, operand) in enumerate(zip(params, operands, strict=False)):
        kind = kinds.get(param)
        if kind is None or isinstance(operand, bool) or not isinstance(operand, int | float):
            continue
        value = abs(operand) if kind == "speed" else operand  # CONTINUE_MOVE's sign
        used = rules.apply(kind, value, max_v)
        if used != value and value > 0:
            sign = -1 if operand < 0 else 1
            yield Changed(index, param, kind, operand, sign * used, max_v,
                          rules.why(kind, value, max_v))


def shown(value: float) -> str:
    """A value as a warning prints it: whole numbers without decimals."""
    return str(int(value)) if float(value).is_integer() else f"{value:.3f}".rstrip("0")


class _MaxV:
    """The MAX_V of each axis as a straight reading of the source sets it: the INIT block's
    (or the factory table's) at the start of every program, then each constant SET_MAX_V in
    the order of the lines; a SET_MAX_V from a variable makes the axis's MAX_V unknown."""

    def __init__(self, start: list[float | None]) -> None:
        self.axes = list(start)
        self.axis1 = 0  # the first assigned axis (AXIS_ASSIGN; X and Y at power on)

    def see(self, command: str, params: dict[str, object]) -> None:
        """Follow a command that sets MAX_V or axis 1 (`_MAX_V_SETTERS` and every `*_INITIAL`)."""
        mask = params.get("axis")
        if command == "SET_MAX_V" and isinstance(mask, int):
            value = params.get("data")
            for i in _axes_of(mask):
                self.axes[i] = float(value) if isinstance(value, int | float) else None
        elif command == "AXIS_ASSIGN" or command.endswith("_INITIAL"):
            first = params.get("axis1")
            if isinstance(first, int) and _axes_of(first):
                self.axis1 = _axes_of(first)[0]

    def of(self, params: dict[str, object]) -> list[float | None]:
        """The MAX_V values that hold for a command's axes (its own, or axis 1's for a
        vector setting)."""
        for name in ("axis", "axis1"):
            mask = params.get(name)
            if isinstance(mask, int) and _axes_of(mask):
                return [self.axes[i] for i in _axes_of(mask)]
        return [self.axes[self.axis1]]


_MAX_V_SETTERS = frozenset(("SET_MAX_V", "AXIS_ASSIGN"))
"""Commands that change what `_MaxV` reads (its `see`), besides every `*_INITIAL`."""


def _axes_of(mask: int) -> list[int]:
    return [i for i in range(4) if mask & 0xF & (1 << i)]


_RULES: list[tuple[ChipRules, int]] = []
"""The rules of the last build and their generation (one entry)."""
_GENERATIONS = count()
"""Each new generation's number, never one given before (`next` is atomic: two builds in
two threads never share one for different rules)."""


def _rules_of(profile: Profile) -> tuple[ChipRules, int]:
    """The profile's rules and a generation that changes whenever they do, their numbers or
    their `parameters`: what kept W111 warnings are keyed by. An int compared once per kept
    program and statement, not rules compared field by field (a device's thousands), and
    unlike rules' equality it tells a change of `parameters` too."""
    rules = ChipRules.from_profile(profile.raw)
    if _RULES:
        last = _RULES[0]
        if last[0] == rules and last[0].parameters == rules.parameters:
            return last
    made = (rules, next(_GENERATIONS))
    _RULES[:] = [made]
    return made


def warn_changed(programs: Iterable[LoweredProgram], init: LoweredProgram | None,
                 profile: Profile, sink: DiagnosticSink, kept: Lowerings | None = None
                 ) -> None:
    """W111: a constant speed, acceleration or jerk argument the chip will hold as another
    value (clamped to its range, or stepped), with the value it will use. With `kept` (the
    lowerings of the last build), a program lowered as then, starting from the same MAX_V
    values, gives the warnings it gave then."""
    rules, generation = _rules_of(profile)
    factory = float(profile.raw["initial_table"]["factory"]["max_v"])
    start: list[float | None] = [factory] * 4
    if init is not None:
        reading = _MaxV(start)
        for line in init.lines:
            reading.see(line.command.short_name, _named(line))
        start = reading.axes
    key = (generation, tuple(start))
    memo: dict[tuple[object, ...], _Judged] = {}
    for program in [*([init] if init is not None else []), *programs]:
        entry = kept.entry(program) if kept is not None else None
        if entry is None or entry.result is None or \
                len(entry.result.lines) != len(program.lines):  # wiring added lines
            _warn_lines(program, list(start), rules, sink, memo)
            continue

        def warn(program: LoweredProgram = program, entry: Lowered = entry
                 ) -> list[Diagnostic]:
            own = DiagnosticSink()
            segments = entry.segments()
            if segments is None:
                _warn_lines(program, list(start), rules, own, memo)
            else:
                _warn_segments(program, segments, list(start), rules, generation, own,
                               memo)
            return Run(own.items)

        found = entry.derived_for("W111", key, warn)
        assert isinstance(found, list)
        sink.extend(found)


def _warn_segments(program: LoweredProgram,
                   segments: list[tuple[Statement | Chunk, int, int]],
                   start: list[float | None], rules: ChipRules, generation: int,
                   sink: DiagnosticSink, memo: dict[tuple[object, ...], _Judged]) -> None:
    """`_warn_lines` statement by statement (chunk by chunk): a kept statement (its lines
    the same objects) entered with the same MAX_V reading gives the warnings it gave, and
    leaves the reading as it left it."""
    # the reading as a tuple of its axes and its axis 1, the very key a kept statement is
    # looked up by: nothing copied or converted for the statements kept (most of them)
    axes: tuple[float | None, ...] = tuple(start)
    axis1 = 0
    for statement, first, end in segments:
        def warn(first: int = first, end: int = end, axes: tuple[float | None, ...] = axes,
                 axis1: int = axis1) -> tuple[list[Diagnostic], tuple[float | None, ...], int]:
            own = DiagnosticSink()
            inner = _MaxV(list(axes))
            inner.axis1 = axis1
            _warn_reading(program.lines[first:end], inner, rules, own, memo)
            return Run(own.items), tuple(inner.axes), inner.axis1

        found = statement.derived_for("W111", (generation, axes, axis1), warn)
        assert isinstance(found, tuple)
        items, axes, axis1 = found
        if items:
            sink.extend(items)


def _named(line: MacroLine) -> dict[str, object]:
    return {p.name: o for p, o in zip(line.command.params, line.operands, strict=False)}


def _warn_lines(program: LoweredProgram, start: list[float | None], rules: ChipRules,
                sink: DiagnosticSink, memo: dict[tuple[object, ...], _Judged]) -> None:
    _warn_reading(program.lines, _MaxV(start), rules, sink, memo)


_Judged = tuple[tuple[str, ...], tuple[float | None, ...], int]
"""A line's W111 messages and the MAX_V reading after it (its axes, its axis 1)."""


def _warn_reading(lines: list[MacroLine], reading: _MaxV, rules: ChipRules,
                  sink: DiagnosticSink, memo: dict[tuple[object, ...], _Judged] | None = None
                  ) -> None:
    """W111 of `lines`, `reading` following the MAX_V values along them. `memo`, kept over
    one build, judges a command with the same operands from the same reading once: a
    device's programs repeat their settings many times."""
    # the reading as a tuple, the very part of the key a line is looked up by: nothing copied
    # for the lines judged before (most of them); `reading` is brought up to date on a miss
    axes, axis1 = tuple(reading.axes), reading.axis1
    parameters = rules.parameters
    for line in lines:
        command = line.command.short_name
        if command not in parameters and command not in _MAX_V_SETTERS and \
                not command.endswith("_INITIAL"):
            continue  # no speed, acceleration or jerk argument, no MAX_V or axis 1 change
        key = (id(line.command), line.operands, axes, axis1)
        judged = memo.get(key) if memo is not None else None
        if judged is None:
            reading.axes, reading.axis1 = list(axes), axis1
            judged = _judge(line, command, reading, rules)
            if memo is not None:
                memo[key] = judged
        messages, axes, axis1 = judged
        for message in messages:
            sink.add("W111", line.span, message)
    reading.axes, reading.axis1 = list(axes), axis1


def _judge(line: MacroLine, command: str, reading: _MaxV, rules: ChipRules) -> _Judged:
    """One line's W111 messages from `reading`, and the reading after it (`reading` is left
    as it was)."""
    params = _named(line)
    names = [p.name for p in line.command.params]
    messages: list[str] = []
    for max_v in dict.fromkeys(reading.of(params)):
        if max_v is None:
            continue
        for change in changed_arguments(rules, command, names, line.operands, max_v):
            what = command if change.param == "data" else f"{command} {change.param}"
            messages.append(f"{what}: the {change.kind} {shown(change.given)} runs as "
                            f"{shown(change.used)} on the device ({change.reason})")
    after = _MaxV(reading.axes)
    after.axis1 = reading.axis1
    after.see(command, params)
    return tuple(messages), tuple(after.axes), after.axis1
