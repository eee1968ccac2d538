"""Whole-controller configuration: the INIT block (initial table), INTERRUPTS wiring and the
stand-alone TRIGGERS table, lowered and checked against the device profile.

The three blocks are declarations, not programs: the initial table becomes real-time frames
with INITIAL_* axis codes followed by LOAD_INITIAL (chapter 8); interrupt wiring becomes
INTFACTOR_ENABLE lines and one ENABLE_INT at the start of the setup program the block names
(7.3.10-7.3.12); the trigger table becomes a typed table, because the manual documents no
download format for it (chapter 10), only the register that enables it (5.4).
"""

from __future__ import annotations

import re
from typing import Any

from mplang.ir.catalogue import Catalogue, Command, Param
from mplang.ir.interrupts import Wire as Wire  # re-exported: the compiler imports it here
from mplang.ir.interrupts import wire_lines, wires
from mplang.ir.lower import ProgramLowerer
from mplang.ir.macro import LoweredProgram, MacroLine, Operand, ProgramRef
from mplang.ir.scope import PROGRAM_RE, Scope, did_you_mean
from mplang.lang import ast
from mplang.lang.diagnostics import DiagnosticSink, Span
from mplang.lang.record import Record

DI_RE = re.compile(r"DI\s*(\d+)\.(\d+)", re.IGNORECASE)
SLMT_CLEARING = ("CLEAR_SLMT", "SET_COMPARE")  # SET_COMPARE disables the limits (RS 7666)


def setting_group(short: str) -> str:
    """Commands that write the same setting of the initial table: SERVO_ON / SERVO_OFF,
    SET_SLMT / CLEAR_SLMT, VRING_ENABLE / VRING_DISABLE, EXD_*, ..."""
    if short.startswith("EXD_"):
        return "EXD"
    name = re.sub(r"^(SET_|CLEAR_)", "", short)
    return re.sub(r"_(ON|OFF|ENABLE|DISABLE)$", "", name)


# ------------------------------------------------------------------------ initial table
class InitLowerer(ProgramLowerer):
    """Lowers `INIT ... END INIT`: each command is the real-time (IT) form with its axes
    turned into INITIAL_* codes; the block ends with LOAD_INITIAL."""

    def __init__(self, scope: Scope, block: ast.InitBlock, target: str) -> None:
        program = ast.Program("init", None, None, list(block.body), block.span, block.end_span,
                              block.source)
        super().__init__(scope, program, range(0), target, {})
        self.block = block
        self.offset = int(self.profile.raw["axes"]["initial_table_offset"])
        self.set_by: dict[tuple[str, int], int] = {}  # (setting, axis bit) -> source line

    def lower_init(self) -> LoweredProgram:
        for node in self.block.body:
            self.lower_init_command(node)
        self.emit_command(self.cat.rtc_by_short["LOAD_INITIAL"], (), self.block.end_span)
        return self.out

    def it_command(self, node: ast.Command) -> Command | None:
        found = self.cat.lookup(node.name)
        if found is None:
            self.unknown_command(node.name, node.name_span)
            return None
        rtc = found if "it" in found.scope else self.cat.rtc_by_short.get(found.short_name)
        if rtc is None or "it" not in rtc.scope:
            names = ", ".join(sorted({c.short_name for c in self.cat.commands
                                      if "it" in c.scope}))
            self.sink.add("E803", node.name_span, f"{found.short_name} cannot write the "
                          "initial table", hint=f"initial-table commands: {names}")
            return None
        if self.target not in rtc.targets:
            self.sink.add("E404", node.name_span, f"{rtc.short_name} does not exist on the "
                          f"{self.profile.raw['device']['variants'][self.target]}")
            return None
        return rtc

    def lower_init_command(self, node: ast.Command) -> None:
        command = self.it_command(node)
        if command is None:
            return
        operands = self.arguments(command, node.args, node.span)
        if operands is None:
            return
        self.emit_command(command, operands, node.span)
        axis_index = next((i for i, p in enumerate(command.params) if p.kind == "axis_it"), None)
        if axis_index is None:
            return
        axes = int(operands[axis_index])  # type: ignore[arg-type]
        group = setting_group(command.short_name)
        for bit in self.profile.axes.values():
            if axes & bit:
                earlier = self.set_by.get((group, bit))
                if earlier is not None:
                    self.sink.add("W801", node.span, f"sets {group} of axis "
                                  f"{self.profile.axis_name(bit)} again (line {earlier}); the "
                                  "earlier setting has no effect",
                                  hint="remove one of the two lines")
                self.set_by[(group, bit)] = node.span.line

    def check_axis(self, param: Param, value: int, span: Span, where: str) -> Operand | None:
        """In INIT, X means INITIAL_X: the table is written, not the live setting."""
        if param.kind == "axis_it" and 0 < value < self.offset:
            value += self.offset
        return super().check_axis(param, value, span, where)

    def named_argument(self, command: Command, param: Param, arg: ast.Name, where: str
                       ) -> Operand | bool | None:
        if arg.name.upper() not in param.symbols and self.scope.variable(arg.name) is not None:
            self.sink.add("E804", arg.span, f"{where} in INIT cannot be the variable "
                          f"{arg.name}: the initial table stores numbers",
                          hint="use a constant (CONST)")
            return None
        return super().named_argument(command, param, arg, where)


def slmt_enabled_axes(init: LoweredProgram | None) -> dict[int, int]:
    """Axis bit -> the INIT line that leaves its software limits enabled."""
    enabled: dict[int, int] = {}
    if init is None:
        return enabled
    for line in init.lines:
        name = line.command.short_name
        if name not in ("SET_SLMT", "CLEAR_SLMT"):
            continue
        axes = int(line.operands[0])  # type: ignore[arg-type]
        for bit in (1, 2, 4, 8):
            if axes & bit:
                if name == "SET_SLMT":
                    enabled[bit] = line.span.line
                else:
                    enabled.pop(bit, None)
    return enabled


# ------------------------------------------------------------------------- interrupts
class InterruptWiring(Record):
    """Every INTERRUPTS block of a build, checked and ready to inject."""

    by_program: dict[int, list[Wire]]  # id(LoweredProgram)
    enable_spans: dict[int, Span]
    all_wires: list[Wire]
    _fields = __match_args__ = ("by_program", "enable_spans", "all_wires")

    def __init__(self, by_program: dict[int, list[Wire]] | None = None,
                 enable_spans: dict[int, Span] | None = None,
                 all_wires: list[Wire] | None = None) -> None:
        self.by_program = {} if by_program is None else by_program
        self.enable_spans = {} if enable_spans is None else enable_spans
        self.all_wires = [] if all_wires is None else all_wires


def _setup_program(block: ast.InterruptsBlock, lowered: list[LoweredProgram],
                   sink: DiagnosticSink) -> LoweredProgram | None:
    text = block.target.upper()
    number = PROGRAM_RE.fullmatch(text)
    found: LoweredProgram | None = None
    if (number and number.group(1) == "MP") or text.isdigit():
        slot = int(number.group(2) if number else text)
        found = next((p for p in lowered if p.kind == "mp" and p.slot == slot), None)
        if found is None:
            sink.add("E815", block.target_span, f"no program of this build is MP{slot}",
                     hint="name an MP of the build: its name, or MP n if it is pinned there")
            return None
        return found
    found = next((p for p in lowered if p.name and p.name.upper() == text), None)
    if found is None:
        names = [p.name for p in lowered if p.name and p.kind == "mp"]
        sink.add("E815", block.target_span, f"no program named {block.target!r} in this build",
                 hint=did_you_mean(text, [n.upper() for n in names]) or
                 "INTERRUPTS names the MP that sets the interrupts up")
        return None
    if found.kind != "mp":
        sink.add("E815", block.target_span, f"{block.target} is an ISR; the setup program "
                 "must be an MP", hint="ENABLE_INT exists only in MPs (7.3.10)")
        return None
    return found


def _touches(program: LoweredProgram, names: tuple[str, ...], bit: int) -> bool:
    for line in program.lines:
        if line.command.short_name in names and line.operands:
            first = line.operands[0]
            if isinstance(first, int) and first & bit:
                return True
    return False


def wire_interrupts(blocks: list[ast.InterruptsBlock], lowered: list[LoweredProgram],
                    init: LoweredProgram | None, catalogue: Catalogue, sink: DiagnosticSink,
                    programs: dict[str, ast.Program]) -> InterruptWiring:
    """Check every INTERRUPTS block and put its lines at the start of its setup program:
    INTFACTOR_ENABLE per axis and factor, then one ENABLE_INT."""
    wiring = InterruptWiring()
    seen: dict[tuple[int, int], Wire] = {}
    compare = set(catalogue.profile.raw["interrupt_factors"]["compare"])
    slmt = slmt_enabled_axes(init)
    for block in blocks:
        setup = _setup_program(block, lowered, sink)
        for node in block.entries:
            for wire in wires(node, catalogue, sink, programs):
                axis = catalogue.profile.axis_name(wire.axis)
                earlier = seen.get((wire.axis, wire.factor))
                if earlier is not None:
                    if earlier.isr != wire.isr:
                        sink.add("E813", wire.span, f"axis {axis} factor {node.condition} is "
                                 f"already wired at line {earlier.span.line}",
                                 hint="keep one ON line per axis and factor")
                    continue
                seen[(wire.axis, wire.factor)] = wire
                if wire.factor in compare:
                    if wire.axis in slmt and not (setup is not None and _touches(
                            setup, SLMT_CLEARING, wire.axis)):
                        sink.add("E814", wire.span, f"factor {node.condition} on axis {axis} "
                                 f"compares with COMP+/COMP-, which hold the software limits "
                                 f"INIT enables at line {slmt[wire.axis]}",
                                 hint="CLEAR_SLMT that axis in INIT, or SET_COMPARE it in the "
                                 "setup program")
                    elif not any(_touches(p, ("SET_COMPARE",), wire.axis) for p in lowered):
                        sink.add("W812", wire.span, f"no program sets a compare value for axis "
                                 f"{axis}; {node.condition} compares with whatever COMP+/COMP- "
                                 "hold", hint="call SET_COMPARE in the setup program")
                wiring.all_wires.append(wire)
                if setup is not None:
                    wiring.by_program.setdefault(id(setup), []).append(wire)
                    wiring.enable_spans.setdefault(id(setup), block.span)
    for program in lowered:
        wired = wiring.by_program.get(id(program))
        if wired:
            lines = wire_lines(wired, catalogue)
            lines.append(MacroLine(catalogue.macro("ENABLE_INT"), (),
                                   wiring.enable_spans[id(program)]))
            program.lines[0:0] = lines
    return wiring


# ---------------------------------------------------------------------- trigger table
class Trigger(Record):
    group: int
    channel: int
    condition: str  # source word: OFF, ON, ON_TO_OFF, OFF_TO_ON, CHANGE
    event: str  # "mp" | "abort-command" | "abort-macro" | "hold-drive"
    mp: ProgramRef | None
    axes: int | None
    span: Span
    _fields = __match_args__ = ("group", "channel", "condition", "event", "mp", "axes", "span")

    def __init__(self, group: int, channel: int, condition: str, event: str,
                 mp: ProgramRef | None, axes: int | None, span: Span) -> None:
        self.group = group
        self.channel = channel
        self.condition = condition
        self.event = event
        self.mp = mp
        self.axes = axes
        self.span = span

    def to_json(self, slot: int | None) -> dict[str, Any]:
        entry: dict[str, Any] = {"group": self.group, "channel": self.channel,
                                 "condition": self.condition.lower().replace("_", "-"),
                                 "event": self.event}
        if self.event == "mp":
            entry["mp"] = slot
        if self.event == "hold-drive":
            entry["axes"] = self.axes
        entry["line"] = self.span.line
        return entry


class TriggerTable(Record):
    entries: list[Trigger]
    source: str
    span: Span
    _fields = __match_args__ = ("entries", "source", "span")

    def __init__(self, entries: list[Trigger], source: str, span: Span) -> None:
        self.entries = entries
        self.source = source
        self.span = span


def _trigger(node: ast.OnStmt, catalogue: Catalogue, sink: DiagnosticSink,
             programs: dict[str, ast.Program]) -> Trigger | None:
    table = catalogue.profile.raw["trigger_table"]
    match = DI_RE.fullmatch(node.subject)
    assert match is not None  # the grammar's DI_PIN
    group, channel = int(match.group(1)), int(match.group(2))
    ok = True
    if not table["first_group"] <= group <= table["last_group"] or \
            not 0 <= channel < table["channels"]:
        sink.add("E821", node.subject_span, f"DI {group}.{channel} is not an FRnet DI channel",
                 hint=f"groups {table['first_group']}..{table['last_group']}, channels "
                 f"0..{table['channels'] - 1}")
        ok = False
    condition = node.condition.upper()
    if condition not in table["conditions"]:
        hint = did_you_mean(condition, list(table["conditions"])) or \
            "conditions: " + ", ".join(table["conditions"])
        sink.add("E822", node.condition_span, f"{node.condition!r} is not a trigger "
                 "condition", hint=hint)
        ok = False
    event, mp, axes = _event(node, catalogue, sink, programs)
    if event is None or not ok:
        return None
    return Trigger(group, channel, condition, event, mp, axes, node.span)


def _event(node: ast.OnStmt, catalogue: Catalogue, sink: DiagnosticSink,
           programs: dict[str, ast.Program]) -> tuple[str | None, ProgramRef | None, int | None]:
    words = f"{node.action} {node.argument or ''}".strip().upper()
    if node.action == "CALL":
        text = (node.argument or "").upper()
        number = PROGRAM_RE.fullmatch(text)
        if node.argument_kind == "isr" or (number and number.group(1) == "ISR"):
            sink.add("E823", node.action_span, "a DI event starts an MP, not an ISR")
            return None, None, None
        if node.argument_kind == "mp" or number or text.isdigit():
            slot = int(number.group(2) if number else text)
            if slot not in catalogue.profile.slot_numbers("mp"):
                sink.add("E823", node.action_span, f"MP{slot} does not exist")
                return None, None, None
            return "mp", ProgramRef(slot=slot), None
        target = programs.get(text)
        if target is None or target.kind != "mp":
            what = "is an ISR" if target is not None else "names no program of this build"
            sink.add("E823", node.action_span, f"{node.argument} {what}; a DI event starts an "
                     "MP", hint=did_you_mean(text, [n for n, p in programs.items()
                                                     if p.kind == "mp"]))
            return None, None, None
        return "mp", ProgramRef(name=text), None
    if words == "ABORT COMMAND":
        return "abort-command", None, None
    if words == "ABORT MACRO":
        return "abort-macro", None, None
    if node.action == "HOLD":
        code = catalogue.profile.axis_code(node.argument or "")
        if code is None or not 0 < code < 16:
            sink.add("E823", node.action_span, "HOLD needs the axes to hold (HOLD X, HOLD XY)")
            return None, None, None
        return "hold-drive", None, code
    sink.add("E823", node.action_span, f"{words!r} is not a trigger event",
             hint="CALL an MP, ABORT COMMAND, ABORT MACRO, or HOLD axes")
    return None, None, None


def build_trigger_table(blocks: list[ast.TriggersBlock], catalogue: Catalogue,
                        sink: DiagnosticSink, programs: dict[str, ast.Program]
                        ) -> TriggerTable | None:
    """All TRIGGERS blocks of a build as one table (one controller, one table)."""
    if not blocks:
        return None
    entries: list[Trigger] = []
    seen: dict[tuple[int, int], Trigger] = {}
    for block in blocks:
        for node in block.entries:
            trigger = _trigger(node, catalogue, sink, programs)
            if trigger is None:
                continue
            earlier = seen.get((trigger.group, trigger.channel))
            if earlier is not None:
                sink.add("E824", node.subject_span, f"DI {trigger.group}.{trigger.channel} "
                         f"already has a trigger at line {earlier.span.line}",
                         hint="keep one line per channel")
                continue
            seen[(trigger.group, trigger.channel)] = trigger
            entries.append(trigger)
    first = blocks[0]
    return TriggerTable(entries, first.source, first.span)
