"""`.mp` -> CSIM (`--target csim`): the real front end and lowering, then one CSIM program.

The `.mp` sources go through the same front end, names, checks and lowering as for the
M8194H (mplang/lang, mplang/ir/lower.py), so every `.mp` diagnostic still applies. The
lowered macro lines (mplang/ir/macro.py) are then translated line by line following
stdlib/csim/from_mp.toml: moves, speeds, waits, interpolation and arcs to their CSIM
commands, FOR/IF/GOTO/CALL to labels and jumps, variables to R variables. What the CSIM
cannot express is reported at the `.mp` line (E721-E724), what it does not need is left
out with a warning (W721). The generated lines are finally checked by the native CSIM
checker, whose findings (for example W701 for arithmetic) are reported at the `.mp` line
they came from. All MPs of the build become subroutines of one CSIM program, the default
one (the first MP of the first file) at address 0.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from mplang.csim import profile as profile_module
from mplang.csim.build import TARGETS, CsimProgram, FamilyBuild
from mplang.csim.check import Checker
from mplang.csim.profile import Profile
from mplang.csim.syntax import Script, parse_line
from mplang.ir import catalogue as catalogue_module
from mplang.ir.lower import ProgramLowerer, Scope
from mplang.ir.macro import LoweredProgram, MacroLine, Operand, ProgramRef, VarRef
from mplang.ir.unit import Options, configuration_blocks
from mplang.lang.diagnostics import Diagnostic, DiagnosticSink, Span, suppressed
from mplang.lang.followon import settle_includes
from mplang.lang.sources import load_sources
from mplang.lang.structure import build_unit

Declared = tuple[str, int, str]
"""A declared name, its number (VARn, or a CONST's value) and its source line (file:line)."""

AXIS_MODULE = {"X": 0, "Y": 1, "Z": 2, "U": 3}
LOGICAL_OF = {"X": "X", "Y": "Y", "Z": "Z", "U": "W"}
MIRROR = {"<": ">", ">": "<", "<=": ">=", ">=": "<=", "==": "==", "!=": "!="}
NEGATE = {"<": ">=", ">=": "<", ">": "<=", "<=": ">", "==": "!=", "!=": "=="}
LOWERING_TARGET = "rs"  # the M8194H variant whose command set the front end checks against


class Unsupported(Exception):
    """A line the CSIM cannot express: (code, message)."""

    def __init__(self, code: str, message: str, hint: str = "") -> None:
        super().__init__(message)
        self.code = code
        self.message = message
        self.hint = hint


@dataclass
class Emitted:
    text: str
    origin: Span


@dataclass
class _Block:
    kind: str  # "if" | "for"
    end: str
    top: str = ""
    counter: str = ""
    other: str = ""  # IF: the ELSE label (jumped to when the condition fails)
    has_else: bool = False


@dataclass
class _ProgramState:
    prefix: str
    assigned: tuple[str, ...] | None = ("X", "Y")
    blocks: list[_Block] = field(default_factory=list)
    serial: int = 0

    def label(self, kind: str) -> str:
        self.serial += 1
        return f"${self.prefix}_{kind}{self.serial}"


class Translator:
    """Translates the lowered programs of one build into one CSIM program."""

    def __init__(self, profile: Profile, sink: DiagnosticSink,
                 programs: list[LoweredProgram]) -> None:
        self.profile = profile
        self.sink = sink
        self.programs = programs
        self.catalogue = catalogue_module.load()
        self.cmp_symbols = {v: k for k, v in self.catalogue.profile.cmp_ops.items()}
        self.calc_ops = {v: k for k, v in self.catalogue.profile.calc_ops.items()}
        self.out: list[Emitted] = []
        self.variables: dict[str, str] = {}
        self.var_error = False
        self.labels = self.program_labels()
        self.axes_used = self.collect_axes()

    # --------------------------------------------------------------------- naming
    def program_labels(self) -> dict[int, str]:
        names: dict[int, str] = {}
        taken: set[str] = set()
        for i, program in enumerate(self.programs):
            base = program.name or (f"MP{program.slot}" if program.slot is not None
                                    else f"MP_{i}")
            label = re.sub(r"[^A-Z0-9_]", "_", base.upper())
            while label in taken:
                label += "_"
            taken.add(label)
            names[id(program)] = label
        return names

    def label_of(self, program: LoweredProgram) -> str:
        return self.labels[id(program)]

    def target_of(self, ref: ProgramRef) -> LoweredProgram | None:
        for program in self.programs:
            if program.kind != "mp":
                continue
            if ref.name is not None and (program.name or "").upper() == ref.name.upper():
                return program
            if ref.slot is not None and program.slot == ref.slot:
                return program
        return None

    def variable(self, ref: VarRef, span: Span) -> str:
        key = f"VAR{ref.index}"
        return self.new_variable(key, span)

    def new_variable(self, key: str, span: Span) -> str:
        if key in self.variables:
            return self.variables[key]
        if len(self.variables) >= self.profile.r_count:
            if not self.var_error:
                self.sink.add("E723", span, f"{key} would be the {len(self.variables) + 1}th "
                              f"variable, but the CSIM has R0..R{self.profile.r_count - 1}",
                              hint="use fewer variables or FOR loops")
                self.var_error = True
            raise Unsupported("", "")
        name = f"R{len(self.variables)}"
        self.variables[key] = name
        return name

    def value(self, operand: Operand, span: Span) -> str:
        if isinstance(operand, VarRef):
            return self.variable(operand, span)
        if isinstance(operand, int | float):
            return str(operand)
        raise Unsupported("E722", f"{operand} is not a value here")

    # ----------------------------------------------------------------------- axes
    def axis_letters(self, mask: Operand) -> list[str]:
        if not isinstance(mask, int):
            raise Unsupported("E722", "the axis must be a constant")
        return [letter for letter, bit in self.catalogue.profile.axes.items() if mask & bit]

    def collect_axes(self) -> set[str]:
        used: set[str] = set()
        for program in self.programs:
            for line in program.lines:
                rule = self.profile.mp_rules.get(line.command.short_name)
                how = rule.how if rule else ""
                for param, operand in zip(line.command.params, line.operands, strict=False):
                    if param.kind.startswith("axis") and isinstance(operand, int) and how in (
                            "move_rel", "move_abs", "wait_axis", "set_position", "axis_assign",
                            "speed", "accel", "hold_on", "hold_off", "home", "jog",
                            "jog_stop"):
                        used.update(self.axis_letters(operand))
                if how in ("line_rel", "line_abs", "arc", "circle", "vector_speed",
                           "vector_accel"):
                    used.update(("X", "Y", "Z") if line.command.short_name.endswith("3D")
                                else ("X", "Y"))
        return used

    @staticmethod
    def module_prefix(letter: str) -> str:
        module = AXIS_MODULE[letter]
        return "" if module == 0 else f"T{module}"

    # --------------------------------------------------------------------- output
    def emit(self, text: str, origin: Span) -> None:
        self.out.append(Emitted(text, origin))

    def translate(self) -> None:
        for program in self.programs:
            if program.kind != "mp":
                self.sink.add("E724", program.span, f"{program.label} is an ISR: the CSIM has "
                              "no motion-chip interrupts (its events are SET EV/ON EV)",
                              hint="do the ISR's work in an MP")
                continue
            self.translate_program(program)

    def translate_program(self, program: LoweredProgram) -> None:
        state = _ProgramState(self.label_of(program))
        self.emit(f"${state.prefix}", program.span)
        for letter in sorted(self.axes_used, key="XYZU".index):
            self.emit(f"T{LOGICAL_OF[letter]}={AXIS_MODULE[letter]}", program.span)
        failed: Span | None = None
        for line in program.lines:
            if line.command.short_name == "SET_RVAR" and line.span == failed:
                continue  # `VARn = READ(...)`: the read is already reported
            try:
                self.line(line, state)
            except Unsupported as exc:
                failed = line.span
                if exc.code:
                    self.sink.add(exc.code, line.span, exc.message, hint=exc.hint)
        self.emit("RET", program.end_span)

    def line(self, line: MacroLine, state: _ProgramState) -> None:
        name = line.command.short_name
        rule = self.profile.mp_rules.get(name)
        if rule is None or rule.how == "unsupported":
            note = rule.note if rule else "the CSIM command list has no counterpart"
            raise Unsupported("E721", f"{name} cannot be expressed on the CSIM: {note}",
                              hint="see the .mp mapping in docs/csim.md")
        if rule.how == "drop":
            self.sink.add("W721", line.span, f"{name} is left out of the CSIM program: "
                          f"{rule.note}")
            return
        handler = getattr(self, f"do_{rule.how}")
        handler(line, state)

    # ------------------------------------------------------------------- lowering
    def constant(self, operand: Operand, what: str) -> int:
        if isinstance(operand, VarRef):
            raise Unsupported("E722", f"{what} from a variable cannot be expressed on the "
                              "CSIM, whose form takes a number", hint="use a constant")
        assert isinstance(operand, int)
        return operand

    def do_speed(self, line: MacroLine, _state: _ProgramState) -> None:
        speed = self.constant(line.operands[1], "a speed")
        for letter in self.axis_letters(line.operands[0]):
            self.emit(f"{self.module_prefix(letter)}VM={speed}", line.span)

    def do_accel(self, line: MacroLine, _state: _ProgramState) -> None:
        accel = self.constant(line.operands[1], "an acceleration")
        for letter in self.axis_letters(line.operands[0]):
            self.emit(f"{self.module_prefix(letter)}PR2={accel}", line.span)

    def do_vector_speed(self, line: MacroLine, _state: _ProgramState) -> None:
        self.emit(f"TVM={self.constant(line.operands[0], 'a speed')}", line.span)

    def do_vector_accel(self, line: MacroLine, state: _ProgramState) -> None:
        accel = self.constant(line.operands[0], "an acceleration")
        for letter in state.assigned or ("X", "Y"):
            self.emit(f"{self.module_prefix(letter)}PR2={accel}", line.span)

    def do_move_rel(self, line: MacroLine, _state: _ProgramState) -> None:
        self.single_moves(line, "MR")

    def do_move_abs(self, line: MacroLine, _state: _ProgramState) -> None:
        self.single_moves(line, "MA")

    def single_moves(self, line: MacroLine, suffix: str) -> None:
        target = self.value(line.operands[1], line.span)
        for letter in self.axis_letters(line.operands[0]):
            self.emit(f"{LOGICAL_OF[letter]}{suffix} {target}", line.span)

    def do_axis_assign(self, line: MacroLine, state: _ProgramState) -> None:
        letters = [self.axis_letters(op)[0] for op in line.operands
                   if isinstance(op, int) and op != 0]
        if letters not in (["X", "Y"], ["X", "Y", "Z"]):
            state.assigned = None
            raise Unsupported("E722", f"AXIS_ASSIGN {', '.join(letters)}: CSIM interpolation "
                              "always runs on x, y (and z) = X, Y (and Z) in this order (CS 180)",
                              hint="assign X, Y or X, Y, Z")
        state.assigned = tuple(letters)

    def interpolation_axes(self, line: MacroLine, state: _ProgramState, count: int) -> bool:
        if state.assigned is None:
            return False  # the AXIS_ASSIGN was already reported
        if len(state.assigned) < count:
            raise Unsupported("E722", f"{line.command.short_name} needs {count} assigned axes; "
                              f"AXIS_ASSIGN gave {', '.join(state.assigned)}")
        return True

    def do_line_rel(self, line: MacroLine, state: _ProgramState) -> None:
        self.line_move(line, state, "MR")

    def do_line_abs(self, line: MacroLine, state: _ProgramState) -> None:
        self.line_move(line, state, "MA")

    def line_move(self, line: MacroLine, state: _ProgramState, suffix: str) -> None:
        count = len(line.operands)
        if not self.interpolation_axes(line, state, count):
            return
        values = ",".join(self.value(op, line.span) for op in line.operands)
        self.emit(f"{count}{suffix} {values}", line.span)

    def do_arc(self, line: MacroLine, state: _ProgramState) -> None:
        if not self.interpolation_axes(line, state, 2):
            return
        cx, cy, fx, fy = (self.constant(op, "an arc point") for op in line.operands)
        clockwise = line.command.short_name.endswith("_CW")
        start_angle = math.atan2(-cy, -cx)
        end_angle = math.atan2(fy - cy, fx - cx)
        sweep = end_angle - start_angle
        if clockwise:
            sweep = -((-sweep) % (2 * math.pi)) or -2 * math.pi
        else:
            sweep = (sweep % (2 * math.pi)) or 2 * math.pi
        radius = math.hypot(cx, cy)
        end = (cx + radius * math.cos(start_angle + sweep), cy + radius * math.sin(start_angle
                                                                                   + sweep))
        if math.hypot(end[0] - fx, end[1] - fy) > 0.5:
            raise Unsupported("E722", f"the finish point ({fx}, {fy}) is not on the circle "
                              f"through the start around ({cx}, {cy}): a CSIM arc (centre and "
                              "angle) would end elsewhere", hint="put the finish point on the "
                              "circle")
        self.emit(f"AR {cx},{cy},{_angle(math.degrees(sweep))}", line.span)

    def do_circle(self, line: MacroLine, state: _ProgramState) -> None:
        if not self.interpolation_axes(line, state, 2):
            return
        cx, cy = (self.constant(op, "a circle centre") for op in line.operands)
        turn = -360 if line.command.short_name.endswith("_CW") else 360
        self.emit(f"AR {cx},{cy},{turn}", line.span)

    def do_wait_axis(self, line: MacroLine, _state: _ProgramState) -> None:
        for letter in self.axis_letters(line.operands[0]):
            self.emit(f"{LOGICAL_OF[letter]}DN", line.span)

    def do_timer(self, line: MacroLine, _state: _ProgramState) -> None:
        self.emit(f"WT {self.constant(line.operands[0], 'a wait time')}", line.span)

    def do_set_position(self, line: MacroLine, _state: _ProgramState) -> None:
        value = self.constant(line.operands[1], "a position")
        for letter in self.axis_letters(line.operands[0]):
            self.emit(f"{self.module_prefix(letter)}CS {value}", line.span)

    def do_hold_on(self, line: MacroLine, _state: _ProgramState) -> None:
        for letter in self.axis_letters(line.operands[0]):
            self.emit(f"{self.module_prefix(letter)}HON", line.span)

    def do_hold_off(self, line: MacroLine, _state: _ProgramState) -> None:
        for letter in self.axis_letters(line.operands[0]):
            self.emit(f"{self.module_prefix(letter)}HOFF", line.span)

    def host_axis_only(self, line: MacroLine, what: str) -> None:
        letters = self.axis_letters(line.operands[0])
        if letters != ["X"]:
            raise Unsupported("E722", f"{what} on {', '.join(letters)}: the CSIM {what} is a "
                              "point-to-point command, allowed on a logical axis only for the "
                              "host module T0 = X (CS 176)", hint="use it on X only")

    def do_home(self, line: MacroLine, _state: _ProgramState) -> None:
        self.host_axis_only(line, "homing")
        self.emit("H", line.span)

    def do_jog(self, line: MacroLine, _state: _ProgramState) -> None:
        self.host_axis_only(line, "jogging")
        speed = self.constant(line.operands[1], "a jog speed")
        if speed == 0:
            raise Unsupported("E722", "CONTINUE_MOVE at speed 0 has no CSIM jog")
        self.emit(f"VM={abs(speed)}", line.span)
        self.emit("JGF" if speed > 0 else "JGR", line.span)

    def do_jog_stop(self, line: MacroLine, _state: _ProgramState) -> None:
        self.host_axis_only(line, "stopping")
        self.emit("JG0", line.span)

    # ------------------------------------------------------------------- control
    def do_control(self, line: MacroLine, state: _ProgramState) -> None:
        getattr(self, f"ctl_{line.command.short_name.lower()}")(line, state)

    def ctl_set_var(self, line: MacroLine, _state: _ProgramState) -> None:
        dest, source = line.operands
        assert isinstance(dest, VarRef)
        self.emit(f"{self.variable(dest, line.span)}={self.value(source, line.span)}",
                  line.span)

    def ctl_var_calculate(self, line: MacroLine, _state: _ProgramState) -> None:
        left, op_code, right, dest = line.operands
        assert isinstance(dest, VarRef) and isinstance(op_code, int)
        op = self.calc_ops.get(op_code, "?")
        if op not in "+-*":
            why = ("the M8194H divides integers (truncating); CSIM R variables are reals"
                   if op == "/" else "the CSIM has no bit operators")
            raise Unsupported("E722", f"operator {op!r} cannot be expressed on the CSIM: {why}",
                              hint="compute it with + - * or at compile time (CONST)")
        self.emit(f"{self.variable(dest, line.span)}={self.value(left, line.span)}{op}"
                  f"{self.value(right, line.span)}", line.span)

    def ctl_for(self, line: MacroLine, state: _ProgramState) -> None:
        count = line.operands[0]
        if isinstance(count, VarRef):
            counter = self.variable(count, line.span)
        else:
            counter = self.new_variable(f"FOR {line.span.file}:{line.span.line}", line.span)
            self.emit(f"{counter}={self.value(count, line.span)}", line.span)
        block = _Block("for", state.label("E"), top=state.label("F"), counter=counter)
        self.emit(f"JNG 0,{counter},{block.end}", line.span)
        self.emit(block.top, line.span)
        state.blocks.append(block)

    def ctl_next(self, line: MacroLine, state: _ProgramState) -> None:
        if not state.blocks or state.blocks[-1].kind != "for":
            raise Unsupported("E722", "NEXT without its FOR in the macro lines",
                              hint="fix the FOR this NEXT closes")
        block = state.blocks.pop()
        self.emit(f"{block.counter}={block.counter}-1", line.span)
        self.emit(f"JG 0,{block.counter},{block.top}", line.span)
        self.emit(block.end, line.span)

    def ctl_exit_for(self, line: MacroLine, state: _ProgramState) -> None:
        block = next((b for b in reversed(state.blocks) if b.kind == "for"), None)
        if block is None:
            raise Unsupported("E722", "EXIT_FOR outside a FOR in the macro lines",
                              hint="put it inside the FOR it leaves")
        self.emit(f"JP {block.end}", line.span)

    def ctl_if(self, line: MacroLine, state: _ProgramState) -> None:
        left, code, right = line.operands
        assert isinstance(code, int)
        symbol = self.cmp_symbols.get(code) or self.cmp_symbols[
            ((code & 0xFF) << 8) | (code >> 8)]
        block = _Block("if", state.label("I"), other=state.label("L"))
        state.blocks.append(block)
        self.condition_jump(left, NEGATE[symbol], right, block.other, line.span)

    def ctl_else(self, line: MacroLine, state: _ProgramState) -> None:
        if not state.blocks or state.blocks[-1].kind != "if":
            raise Unsupported("E722", "ELSE without its IF in the macro lines",
                              hint="fix the IF this ELSE belongs to")
        block = state.blocks[-1]
        block.has_else = True
        self.emit(f"JP {block.end}", line.span)
        self.emit(block.other, line.span)

    def ctl_end_if(self, line: MacroLine, state: _ProgramState) -> None:
        if not state.blocks or state.blocks[-1].kind != "if":
            raise Unsupported("E722", "END_IF without its IF in the macro lines",
                              hint="fix the IF this END_IF closes")
        block = state.blocks.pop()
        if not block.has_else:
            self.emit(block.other, line.span)
        self.emit(block.end, line.span)

    def condition_jump(self, left: Operand, op: str, right: Operand, target: str,
                       span: Span) -> None:
        """Jump to `target` when `left op right` holds, with JE/JNE/JG/JNG (#var > c ...)."""
        if not isinstance(left, VarRef) and not isinstance(right, VarRef):
            assert isinstance(left, int) and isinstance(right, int)
            holds = {"<": left < right, ">": left > right, "<=": left <= right,
                     ">=": left >= right, "==": left == right, "!=": left != right}[op]
            if holds:
                self.emit(f"JP {target}", span)
            return
        if not isinstance(left, VarRef):
            left, right, op = right, left, MIRROR[op]
        assert isinstance(left, VarRef)
        var = self.variable(left, span)
        if isinstance(right, VarRef):
            other = self.variable(right, span)
            form = {"==": ("JE", other, var), "!=": ("JNE", other, var),
                    ">": ("JG", other, var), "<=": ("JNG", other, var),
                    "<": ("JG", var, other), ">=": ("JNG", var, other)}[op]
        else:
            assert isinstance(right, int)
            form = {"==": ("JE", str(right), var), "!=": ("JNE", str(right), var),
                    ">": ("JG", str(right), var), "<=": ("JNG", str(right), var),
                    "<": ("JNG", str(right - 1), var), ">=": ("JG", str(right - 1), var)}[op]
        self.emit(f"{form[0]} {form[1]},{form[2]},{target}", span)

    def ctl_label(self, line: MacroLine, state: _ProgramState) -> None:
        self.emit(f"${state.prefix}_L{line.operands[0]}", line.span)

    def ctl_goto(self, line: MacroLine, state: _ProgramState) -> None:
        self.emit(f"JP ${state.prefix}_L{line.operands[0]}", line.span)

    def ctl_mp_call(self, line: MacroLine, _state: _ProgramState) -> None:
        ref = line.operands[0]
        target = self.target_of(ref) if isinstance(ref, ProgramRef) else None
        if target is None:
            raise Unsupported("E724", f"CALL {_ref_text(ref)}: the program is not part of this "
                              "build, and a CSIM holds one program", hint="build the called "
                              "program together with this one")
        self.emit(f"CALL ${self.label_of(target)}", line.span)

    def ctl_exit_macro(self, line: MacroLine, _state: _ProgramState) -> None:
        self.emit("RET", line.span)


def _ref_text(ref: Operand) -> str:
    if isinstance(ref, ProgramRef):
        return ref.name or f"MP{ref.slot}"
    return str(ref)


def _angle(degrees: float) -> str:
    text = f"{degrees:.10f}".rstrip("0").rstrip(".")
    return text if text not in ("-0", "") else "0"


def _lower(paths: list[Path], options: Options, sink: DiagnosticSink,
           texts: dict[Path, str] | None = None
           ) -> tuple[list[LoweredProgram], dict[str, list[str]], list[Declared],
                      list[Declared]]:
    """The M8194H front end and lowering, as compile_paths runs them (without linking);
    the declared variables (VAR name, ALIAS) with their VARn, by number, and the CONSTs with
    their values, each with its source line (for the host's view)."""
    catalogue = catalogue_module.load()
    sources = load_sources(paths, sink, allow_outside=options.allow_outside_includes,
                           texts=texts)
    unit = build_unit(sources, sink)
    for what, span in configuration_blocks(unit):
        sink.add("E721", span, f"an {what} block cannot be expressed on the CSIM: the "
                 "M8194H's initial table, interrupts and DI triggers have no CSIM counterpart",
                 hint="set CSIM parameters with PN/PR lines in a .csim script; build this "
                 "block for an M8194H target")
    scope = Scope.declared(unit, catalogue, sink, options.var_pool, options.temps)
    names = {p.name.upper(): p for p in unit.programs if p.name}
    lowered = [ProgramLowerer(scope, program, options.temps, LOWERING_TARGET, names)
               .lower_program() for program in unit.programs]
    declared = sorted(((v.name, v.index, f"{v.span.file}:{v.span.line}")
                       for v in [*scope.variables, *scope.alias_names]),
                      key=lambda item: item[1])
    consts = [(decl.name, value, f"{decl.name_span.file}:{decl.name_span.line}")
              for key, decl in scope.const_exprs.items()
              if (value := scope.const_values.get(key)) is not None]
    return lowered, {f.display: f.text.splitlines() for f in sources.files}, declared, consts


def _default_first(programs: list[LoweredProgram], first: Path | None) -> list[LoweredProgram]:
    if first is None:
        return programs
    wanted = first.resolve()

    def from_first(program: LoweredProgram) -> bool:
        try:
            return Path(program.source).resolve() == wanted
        except OSError:
            return False

    mps = [p for p in programs if p.kind == "mp"]
    head = next((p for p in mps if from_first(p)), None)
    if head is None:
        return programs
    return [head, *(p for p in programs if p is not head)]


def compile_mp(paths: list[Path], options: Options, target: str, *,
               texts: dict[Path, str] | None = None) -> FamilyBuild:
    """Compile `.mp` sources into one CSIM program (see the module docstring). `texts`:
    editor buffers read instead of the files."""
    if target not in TARGETS:
        raise ValueError(f"unknown CSIM target {target!r}: choose one of {', '.join(TARGETS)}")
    profile = profile_module.load()
    sink = DiagnosticSink()
    lowered, source_lines, declared, consts = _lower(paths, options, sink, texts)
    ordered = _default_first(lowered, paths[0] if paths else None)
    translator = Translator(profile, sink, ordered)
    translator.translate()
    script, origins = _script(translator.out, profile, sink)
    entries = {}
    for program in ordered:
        if program.kind == "mp":
            label = f"${translator.label_of(program)}"
            if program.name:
                entries[program.name] = label
            if program.slot is not None:
                entries[f"MP{program.slot}"] = label
    sources = sorted({p.source for p in lowered})
    name = ordered[0].name if ordered and ordered[0].name else (
        Path(paths[0]).stem if paths else "program")
    diagnostics = settle_includes(
        [d for d in sink.sorted() if not suppressed(d, source_lines)], source_lines)
    build = FamilyBuild(diagnostics)
    if lowered:
        placed = [(variable, index, at) for variable, index, at in declared
                  if f"VAR{index}" in translator.variables]
        names = {variable: translator.variables[f"VAR{index}"] for variable, index, _ in placed}
        build.programs.append(CsimProgram(
            name, str(paths[0]) if paths else "", script, origins, entries, translator.variables,
            sources, names, {variable: at for variable, _, at in placed}, consts))
    return build


def _script(emitted: list[Emitted], profile: Profile, sink: DiagnosticSink
            ) -> tuple[Script, list[Span]]:
    """Parse and check the generated lines; report what the checker finds at the .mp line."""
    inner = DiagnosticSink()
    script = Script("compiled", "<csim>")
    origins: list[Span] = []
    for number, item in enumerate(emitted, start=1):
        statement = parse_line(item.text, "<csim>", number, inner)
        if statement is not None:
            script.statements.append(statement)
            origins.append(item.origin)
    Checker(profile, inner, "program").script(script)
    by_line = {number: item.origin for number, item in enumerate(emitted, start=1)}
    for diagnostic in inner.items:
        origin = by_line.get(diagnostic.span.line)
        if origin is None or diagnostic.code == "W704":
            continue
        _forward(sink, diagnostic, origin)
    return script, origins


def _forward(sink: DiagnosticSink, diagnostic: Diagnostic, origin: Span) -> None:
    line = diagnostic.message
    sink.add(diagnostic.code, origin, f"in the CSIM line generated here: {line}",
             hint=diagnostic.hint)
