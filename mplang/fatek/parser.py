"""Reading FBs-PLC positioning listings (`.fbs`): WinProladder's step text plus table headers,
FUN141 parameter lines and `SIM` lines, one statement per line.

The manual's own listings are accepted as printed: full-width commas and semicolons, the
minus signs U+2212 and U+FF0D, and comments after `;` (the manual's `；`) or `#`. Full-width
characters map one to one onto ASCII, so columns in diagnostics are columns of the original
line. Every line that does not parse is reported (E601) and skipped; the rest still loads.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from mplang.fatek.model import (
    NEXT,
    Condition,
    Contact,
    ContactEvent,
    Drive,
    Home,
    Line,
    ParamTable,
    PositioningTable,
    PulseSensor,
    Register,
    SimSetup,
    Step,
    Table,
    Target,
    Value,
    WindowSensor,
    split32,
)
from mplang.lang.diagnostics import DiagnosticSink, Span
from mplang.lang.limits import long_number

_FULLWIDTH_FIRST, _FULLWIDTH_LAST, _FULLWIDTH_SHIFT = 0xFF01, 0xFF5E, 0xFEE0
_EXTRA = {"\u2212": "-", "\u2013": "-", "\u3000": " ", "\u00a0": " "}

NAME = r"[A-Za-z_][A-Za-z0-9_.\-]*"
FUN_NAMES = {"FUN140": 140, "HSPSO": 140, "FUN141": 141, "MPARA": 141, "FUN147": 147,
             "MHSPO": 147}
MOTIONS = ("DRV", "DRVC", "DRVZ", "LIN", "LINE")
CONDITIONS = ("WAIT", "ACT", "EXT")
INSTRUCTIONS = ("SPD", *MOTIONS, *CONDITIONS, "GOTO", "MEND")
# the order of the parts of a step (FB 571-575 and every listing)
PHASE = {"SPD": 0, **dict.fromkeys(MOTIONS, 1), **dict.fromkeys(CONDITIONS, 2), "GOTO": 3,
         "MEND": 3}

_CONSTANT = re.compile(r"[+-]?\s*\d+")
_REGISTER = re.compile(r"([RD])(\d+)", re.IGNORECASE)
_CONTACT = re.compile(r"([XYMS])(\d+)", re.IGNORECASE)
_NUMBER = re.compile(r"[+-]?(?:0x[0-9A-Fa-f]+|[0-9A-Fa-f]+[Hh]|\d+)")


def normalise(text: str) -> str:
    """Full-width ASCII and the manual's minus signs as plain ASCII, one character for one."""
    out = []
    for char in text:
        code = ord(char)
        if _FULLWIDTH_FIRST <= code <= _FULLWIDTH_LAST:
            out.append(chr(code - _FULLWIDTH_SHIFT))
        else:
            out.append(_EXTRA.get(char, char))
    return "".join(out)


def strip_comment(text: str) -> str:
    for mark in (";", "#"):
        cut = text.find(mark)
        if cut >= 0:
            text = text[:cut]
    return text


def parse_number(text: str) -> int | None:
    """A decimal, `0x` hex or WinProladder hex (`0100H`) integer; None if it is none."""
    text = text.strip().replace(" ", "")
    if not _NUMBER.fullmatch(text):
        return None
    sign = -1 if text.startswith("-") else 1
    body = text.lstrip("+-")
    if body.lower().startswith("0x"):
        return sign * int(body[2:], 16)
    if body[-1] in "Hh":
        return sign * int(body[:-1], 16)
    if not body.isdigit():
        return None
    return sign * int(body)


@dataclass
class ParsedFile:
    """One listing: its tables in order, its simulation set-up and its text."""

    display: str
    tables: list[Table] = field(default_factory=list)
    sim: SimSetup = field(default_factory=SimSetup)
    lines: list[str] = field(default_factory=list)


@dataclass
class _Part:
    """A comma-separated operand with its 1-based column in the line."""

    text: str
    col: int


def _split(text: str, col: int) -> list[_Part]:
    """Split at commas; each part stripped, its column the first non-blank character (or the
    comma's position for a blank part)."""
    parts: list[_Part] = []
    start = 0
    for piece in text.split(","):
        stripped = piece.strip()
        lead = len(piece) - len(piece.lstrip())
        parts.append(_Part(stripped, col + start + (lead if stripped else 0)))
        start += len(piece) + 1
    return parts


class _LineError(Exception):
    """A line (or one of its operands) does not parse: message and column."""

    def __init__(self, message: str, col: int, hint: str = "") -> None:
        super().__init__(message)
        self.message = message
        self.col = col
        self.hint = hint


class Parser:
    """Parses one listing; problems go to the sink and parsing goes on with the next line."""

    def __init__(self, display: str, text: str, sink: DiagnosticSink) -> None:
        self.display = display
        self.sink = sink
        self.result = ParsedFile(display, lines=text.splitlines())
        self.table: Table | None = None
        self.step: Step | None = None
        self.phase = -1

    def span(self, line: int, col: int = 1, end: int | None = None) -> Span:
        return Span(self.display, line, col, end)

    # ---------------------------------------------------------------- lines
    def parse(self) -> ParsedFile:
        for number, raw in enumerate(self.result.lines, start=1):
            text = strip_comment(normalise(raw))
            if not text.strip():
                continue
            too_long = long_number(text)
            if too_long is not None:  # before any int(): Python converts 4,300 digits at most
                self.sink.add("E108", self.span(number, too_long[0] + 1), too_long[1],
                              hint="write the value the PLC should hold (32-bit)")
                continue
            try:
                self.line(number, text)
            except _LineError as err:
                self.sink.add("E601", self.span(number, err.col), err.message, hint=err.hint)
        self.close_step()
        return self.result

    def line(self, number: int, text: str) -> None:
        stripped = text.lstrip()
        col = len(text) - len(stripped) + 1
        head = stripped.split(None, 1)[0].upper()
        if head == "TABLE":
            self.close_step()
            self.header(number, stripped, col)
        elif head == "SIM":
            self.sim_line(number, stripped, col)
        elif re.fullmatch(r"\d+", head):
            self.step_line(number, stripped, col)
        elif head in INSTRUCTIONS:
            if self.step is None:
                raise _LineError(f"{head} outside a step", col,
                                 "a step starts with its number, e.g. '001 SPD 5000'")
            self.instruction(number, stripped, col)
        elif re.fullmatch(r"P\d+|P\d+=.*", head):
            self.parameter(number, stripped, col)
        else:
            known = ", ".join(INSTRUCTIONS)
            raise _LineError(f"unknown instruction {stripped.split(None, 1)[0]!r}", col,
                             f"a line holds a step instruction ({known}), a TABLE header, a "
                             "FUN141 parameter 'Pn = value' or a SIM line")

    # ---------------------------------------------------------------- tables
    def header(self, number: int, text: str, col: int) -> None:
        words = [(m.group(0), col + m.start()) for m in re.finditer(r"\S+", text)]
        if len(words) < 3 or not re.fullmatch(NAME, words[1][0]):
            raise _LineError("a table header reads 'TABLE name FUN140|FUN141|FUN147 [Ps0|Gp0] "
                             "[SR=R5000] [WR=R2000]'", col)
        name = words[1][0]
        fun = FUN_NAMES.get(words[2][0].upper())
        if fun is None:
            raise _LineError(f"unknown table kind {words[2][0]!r}", words[2][1],
                             "FUN140 (HSPSO), FUN141 (MPARA) or FUN147 (MHSPO)")
        unit, sr, wr = 0, None, None
        for word, at in words[3:]:
            upper = word.upper()
            if match := re.fullmatch(r"(PS|GP)(\d+)", upper):
                wanted = "GP" if fun == 147 else "PS"
                if match.group(1) != wanted:
                    raise _LineError(f"a FUN{fun} table takes {'Gp' if fun == 147 else 'Ps'}n, "
                                     f"not {word}", at)
                unit = int(match.group(2))
            elif match := re.fullmatch(r"(SR|WR)=(.+)", upper):
                register = _REGISTER.fullmatch(match.group(2))
                if register is None:
                    raise _LineError(f"{match.group(1)} must name a register (R5000, D100), "
                                     f"not {match.group(2)!r}", at + 3)
                value = Register(register.group(1).upper(), int(register.group(2)))
                if match.group(1) == "SR":
                    sr = value
                elif fun == 141:
                    raise _LineError("a FUN141 table has no work registers", at)
                else:
                    wr = value
            else:
                raise _LineError(f"unexpected {word!r} in a table header", at,
                                 "after the kind: Ps0..Ps3 (FUN140/141) or Gp0/Gp1 (FUN147), "
                                 "SR=register, WR=register")
        span = self.span(number, col)
        table: Table
        if fun == 141:
            table = ParamTable(name, unit, sr, span=span, source=self.display)
        else:
            table = PositioningTable(name, fun, unit, sr, wr, span=span, source=self.display)
        self.result.tables.append(table)
        self.table = table

    def positioning_table(self, number: int, col: int) -> PositioningTable:
        if self.table is None:
            stem = re.sub(r"\W", "_", self.display.rsplit("/", 1)[-1].rsplit(".", 1)[0]) or "table"
            # the instruction is settled by the checker (target or content), 0 until then
            self.table = PositioningTable(stem, 0, 0, declared=False,
                                          span=self.span(number, col), source=self.display)
            self.result.tables.append(self.table)
        if isinstance(self.table, ParamTable):
            raise _LineError(f"steps cannot stand in the FUN141 table {self.table.name!r}", col,
                             "start a FUN140/FUN147 table with a TABLE line first")
        return self.table

    # ---------------------------------------------------------------- steps
    def step_line(self, number: int, text: str, col: int) -> None:
        match = re.match(r"(\d+)\s*", text)
        assert match is not None
        table = self.positioning_table(number, col)
        self.close_step()
        rest = text[match.end():]
        if not rest.strip():
            raise _LineError(f"step {match.group(1)} has no instruction on its line", col,
                             "write the first instruction after the number: '001 SPD 5000'")
        self.step = Step(int(match.group(1)), span=self.span(number, col))
        self.step.spans["number"] = self.span(number, col, col + len(match.group(1)))
        table.steps.append(self.step)
        self.phase = -1
        self.instruction(number, rest, col + match.end())

    def close_step(self) -> None:
        self.step = None
        self.phase = -1

    def instruction(self, number: int, text: str, col: int) -> None:
        assert self.step is not None
        step = self.step
        match = re.match(r"([A-Za-z]+)\s*", text)
        if match is None or match.group(1).upper() not in INSTRUCTIONS:
            raise _LineError(f"unknown instruction {text.split(None, 1)[0]!r}", col)
        op = match.group(1).upper()
        rest = text[match.end():].rstrip()
        at = col + match.end()
        span = self.span(number, col, col + len(text.rstrip()))
        phase = PHASE[op]
        slot = ("speed", "motion", "condition", "goto")[phase]
        if slot in step.spans or (phase == 3 and ("goto" in step.spans or step.mend)):
            self.sink.add("E615", span, f"step {step.number} already has its "
                          f"{'GOTO/MEND' if phase == 3 else slot if slot != 'speed' else 'SPD'}",
                          hint="a step holds one SPD, one motion, at most one condition and "
                          "one GOTO or MEND")
            return
        if phase < self.phase:
            self.sink.add("E615", span, f"{op} after a later part of step {step.number}",
                          hint="the parts of a step come in the order SPD, motion, condition, "
                          "GOTO or MEND")
        self.phase = max(self.phase, phase)
        if op == "SPD":
            step.speed = self.value(rest, at, "SPD takes a constant, Rxxxx or Dxxxx",
                                    signed=False)
            step.spans["speed"] = span
            step.spans["speed.value"] = self.span(number, at)
        elif op in ("DRV", "DRVC"):
            step.motion = self.drive(op, number, rest, at, step)
            step.spans["motion"] = span
        elif op == "DRVZ":
            mode = re.fullmatch(r"MD(\d+)", rest.strip(), re.IGNORECASE)
            if mode is None:
                raise _LineError("DRVZ takes a mode MD0, MD1 or MD2", at)
            step.motion = Home(int(mode.group(1)))
            step.spans["motion"] = span
        elif op in ("LIN", "LINE"):
            step.motion = self.line_motion(op, number, rest, at, step)
            step.spans["motion"] = span
        elif op in CONDITIONS:
            step.condition = self.condition(op, number, rest, at, step)
            step.spans["condition"] = span
        elif op == "GOTO":
            step.goto = self.target(rest, at)
            step.spans["goto"] = span
        else:
            if rest.strip():
                raise _LineError("MEND takes no operand", at)
            step.mend = True
            step.spans["mend"] = span
            step.spans["goto"] = span

    def value(self, text: str, col: int, what: str, signed: bool = True) -> Value:
        stripped = text.strip()
        at = col + len(text) - len(text.lstrip())
        if register := _REGISTER.fullmatch(stripped):
            return Register(register.group(1).upper(), int(register.group(2)))
        if _CONSTANT.fullmatch(stripped) and (signed or not stripped.startswith(("-", "+"))):
            return int(stripped.replace(" ", ""))
        raise _LineError(f"{what}, not {stripped!r}" if stripped else what, at)

    def drive(self, op: str, number: int, rest: str, at: int, step: Step) -> Drive:
        parts = _split(rest, at)
        if len(parts) != 4:
            raise _LineError(f"{op} takes four operands: ADR|ABS, +|-|blank, stroke, Ut|Ps "
                             f"(got {len(parts)})", at, "e.g. DRV ADR,+,10000,Ut")
        coord, direction, stroke, unit = parts
        for name, part in zip(("coord", "dir", "stroke", "unit"), parts, strict=True):
            step.spans[f"motion.{name}"] = self.span(number, part.col)
        return Drive(op, self.coord(coord), self.direction(direction),
                     self.value(stroke.text, stroke.col, f"{op} needs a stroke (constant, Rxxxx "
                                "or Dxxxx)"), self.unit(unit))

    def line_motion(self, op: str, number: int, rest: str, at: int, step: Step) -> Line:
        parts = _split(rest, at)
        if len(parts) != 6:
            raise _LineError(f"{op} takes six operands: ADR|ABS, the strokes of Ps0-Ps3 (blank "
                             f"for none), Ut|Ps (got {len(parts)})", at,
                             "e.g. LIN ADR,500,400,,,Ut")
        strokes: list[Value | None] = []
        for index, part in enumerate(parts[1:5]):
            step.spans[f"motion.axis{index}"] = self.span(number, part.col)
            strokes.append(None if not part.text else self.value(
                part.text, part.col, f"{op} axis strokes are constants, Rxxxx or Dxxxx"))
        step.spans["motion.coord"] = self.span(number, parts[0].col)
        step.spans["motion.unit"] = self.span(number, parts[5].col)
        return Line(op, self.coord(parts[0]), (strokes[0], strokes[1], strokes[2], strokes[3]),
                    self.unit(parts[5]))

    @staticmethod
    def coord(part: _Part) -> str:
        upper = part.text.upper()
        if upper not in ("ADR", "ABS"):
            raise _LineError(f"coordinates are ADR (relative) or ABS (absolute), not "
                             f"{part.text!r}", part.col)
        return upper

    @staticmethod
    def direction(part: _Part) -> str:
        if part.text not in ("+", "-", ""):
            raise _LineError(f"the direction is +, - or blank, not {part.text!r}", part.col)
        return part.text

    @staticmethod
    def unit(part: _Part) -> str:
        upper = part.text.upper()
        if upper not in ("UT", "PS"):
            raise _LineError(f"the resolution is Ut or Ps, not {part.text!r}", part.col)
        return "Ut" if upper == "UT" else "Ps"

    def condition(self, op: str, number: int, rest: str, at: int, step: Step) -> Condition:
        parts = _split(rest, at)
        if parts[0].text.upper() == "TIME":
            if op == "EXT":
                raise _LineError("EXT waits for a contact, not a time", at)
            if len(parts) != 2:
                raise _LineError(f"{op} TIME takes one value: {op} TIME,100", at)
            step.spans["condition.operand"] = self.span(number, parts[1].col)
            return Condition(op, time=self.value(parts[1].text, parts[1].col,
                                                  "the time is a constant (0.01 s), Rxxxx or "
                                                  "Dxxxx", signed=False))
        if op == "ACT":
            raise _LineError("ACT takes TIME,value", at, "e.g. ACT TIME,50")
        step.spans["condition.operand"] = self.span(number, parts[0].col)
        if len(parts) != 1:
            raise _LineError(f"{op} takes one contact", parts[1].col)
        return Condition(op, contact=self.contact(parts[0]))

    @staticmethod
    def contact(part: _Part) -> Contact:
        match = _CONTACT.fullmatch(part.text.replace(" ", ""))
        if match is None:
            raise _LineError(f"a contact is X, Y, M or S with its number, not {part.text!r}",
                             part.col, "e.g. WAIT X0, EXT M100, or WAIT TIME,100")
        return Contact(match.group(1).upper(), int(match.group(2)))

    def target(self, rest: str, at: int) -> Target:
        text = rest.strip()
        if text.upper() == NEXT:
            return NEXT
        if text.isdigit():
            return int(text)
        if register := _REGISTER.fullmatch(text):
            return Register(register.group(1).upper(), int(register.group(2)))
        raise _LineError(f"GOTO takes NEXT, a step number, Rxxxx or Dxxxx, not {text!r}", at)

    # ---------------------------------------------------------------- FUN141
    def parameter(self, number: int, text: str, col: int) -> None:
        if not isinstance(self.table, ParamTable):
            raise _LineError("a parameter line belongs in a FUN141 table", col,
                             "start one with 'TABLE name FUN141 Ps0 [SR=R2000]'")
        match = re.fullmatch(r"P(\d+)\s*=\s*(.+?)\s*", text, re.IGNORECASE)
        if match is None:
            raise _LineError("a parameter line reads 'Pn = value'", col)
        value = parse_number(match.group(2))
        if value is None:
            raise _LineError(f"{match.group(2)!r} is not a number", col + match.start(2),
                             "decimal, 0x1F or WinProladder hex 0100H")
        param = int(match.group(1))
        span = self.span(number, col)
        if param in self.table.values:
            self.sink.add("E618", span, f"parameter {param} is set twice in "
                          f"{self.table.name!r}", related=((self.table.spans[param],
                                                           "first setting"),))
            return
        self.table.values[param] = value
        self.table.spans[param] = span

    # ---------------------------------------------------------------- SIM
    def sim_line(self, number: int, text: str, col: int) -> None:
        body = text[3:].strip()
        at = col + len(text) - len(text[3:].lstrip())
        span = self.span(number, col)
        sim = self.result.sim
        if match := re.fullmatch(r"(DR|DD|R|D)(\d+)\s*=\s*(\S+)", body, re.IGNORECASE):
            value = parse_number(match.group(3))
            if value is None:
                raise _LineError(f"{match.group(3)!r} is not a number", at)
            kind = match.group(1).upper()
            register = Register(kind[-1], int(match.group(2)))
            if len(kind) == 2:
                low, high = split32(value)
                sim.registers[register] = low
                sim.registers[register.offset(1)] = high
                sim.spans[register.offset(1)] = span
            else:
                sim.registers[register] = value & 0xFFFF
            sim.spans[register] = span
            return
        words = body.split()
        if len(words) < 3:
            raise _LineError(_SIM_FORMS, at)
        contact = self.contact(_Part(words[0], at))
        verb = [w.upper() for w in words[1:]]
        if verb[0] in ("ON", "OFF") and len(verb) == 3 and verb[1] == "AT":
            try:
                time = float(words[3])
            except ValueError:
                raise _LineError(f"{words[3]!r} is not a time in seconds", at) from None
            if time < 0:
                raise _LineError("times count from 0 s", at)
            sim.events.append(ContactEvent(contact, time, verb[0] == "ON", span))
        elif verb[0] == "ON" and len(verb) == 5 and verb[1] == "WHILE" and verb[3] == "IN":
            axis = self.sim_axis(words[3], at)
            window = re.fullmatch(r"([+-]?\d+)\.\.([+-]?\d+)", words[5])
            if window is None or int(window.group(1)) > int(window.group(2)):
                raise _LineError(f"the window is low..high in pulses, not {words[5]!r}", at)
            sim.windows.append(WindowSensor(contact, axis, int(window.group(1)),
                                            int(window.group(2)), span))
        elif verb[0] == "PULSE" and len(verb) == 4 and verb[2] == "EVERY":
            axis = self.sim_axis(words[2], at)
            if not words[4].isdigit() or int(words[4]) == 0:
                raise _LineError(f"EVERY takes a positive number of pulses, not {words[4]!r}",
                                 at)
            sim.pulses.append(PulseSensor(contact, axis, int(words[4]), span))
        else:
            raise _LineError(_SIM_FORMS, at)

    @staticmethod
    def sim_axis(text: str, col: int) -> int:
        match = re.fullmatch(r"PS([0-3])", text.upper())
        if match is None:
            raise _LineError(f"the axis is Ps0..Ps3, not {text!r}", col)
        return int(match.group(1))


_SIM_FORMS = ("SIM lines: 'SIM R1000 = 5' (DR/DD for 32 bits), 'SIM X0 ON AT 1.5', "
              "'SIM X0 OFF AT 2', 'SIM X3 ON WHILE Ps0 IN -9000..-8000', "
              "'SIM X4 PULSE Ps0 EVERY 2000'")


def parse_text(text: str, display: str, sink: DiagnosticSink) -> ParsedFile:
    """Parse one listing held in memory."""
    return Parser(display, text, sink).parse()
