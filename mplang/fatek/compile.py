"""`.mp` sources to FBs-PLC positioning tables (`--target fbs-fun140` / `fbs-fun147`).

The real front end and lowering (mplang.lang, mplang.ir.lower) turn the sources into macro
lines, with every `.mp` check. The positioning language then has no variables, arithmetic,
conditional branches or calls (FB 863-1149), so the macro lines are *evaluated* here at
compile time: constants and known variables fold, FOR loops and IFs on known values unroll,
CALLs inline, and a LABEL that is reached again in the same state becomes a GOTO back to its
step. What stays is a sequence of moves, each with its speed and the wait after it: one step
per move. Whatever depends on a value known only at run time, or has no counterpart on the
PLC, is reported at its `.mp` line.

This module drives the evaluation and assembles the tables (steps, FUN141 settings); what the
evaluation works on is in mplang/fatek/mp_state.py, its macro lines in mplang/fatek/mp_flow.py
(flow, variables) and mplang/fatek/mp_moves.py (settings, waits, moves).
"""

from __future__ import annotations

from pathlib import Path

from mplang.fatek.build import FUN_OF_TARGET, FamilyBuild, check_target
from mplang.fatek.check import Checker
from mplang.fatek.model import (
    NEXT,
    Condition,
    Line,
    ParamTable,
    PositioningTable,
    SimSetup,
    Step,
    Table,
)
from mplang.fatek.mp_flow import FlowOps
from mplang.fatek.mp_moves import MoveOps
from mplang.fatek.mp_state import Context, Draft, Frame, Runtime, round10
from mplang.fatek.profile import Profile, load
from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue
from mplang.ir.lower import ProgramLowerer, Scope
from mplang.ir.macro import LoweredProgram, MacroLine
from mplang.ir.unit import Options, configuration_blocks
from mplang.lang import ast
from mplang.lang.diagnostics import DiagnosticSink, Span, suppressed
from mplang.lang.followon import settle_includes
from mplang.lang.sources import load_sources
from mplang.lang.structure import build_unit

FUEL = 200_000
"""Macro lines evaluated per program before the evaluation is declared endless (E645)."""
M8194H_ONLY_WARNINGS = frozenset({"W107"})
"""Warnings of the lowering that speak of the M8194H manual only: FB documents register
operands for speeds, strokes and times (FB 867-878, 939-953), so W107 does not apply."""
LOWERING_TARGET = "rs"
"""The M8194H command set the sources are lowered against (RS has every macro command)."""


class Evaluator(FlowOps, MoveOps):
    """Evaluates one MP (and what it calls) into the steps of one table: drives the macro
    lines through the handlers of mplang/fatek/mp_flow.py and mplang/fatek/mp_moves.py."""

    def run(self) -> list[Draft]:
        self.stack.append(self.frame(self.top))
        fuel = FUEL
        while self.stack and not self.stopped:
            fuel -= 1
            if fuel == 0:
                self.fail("E645", self.top.span, f"{self.name}: the evaluation does not end "
                          f"after {FUEL} macro lines (a loop whose state never repeats?)",
                          hint="close endless loops with LABEL/GOTO over constant state")
                break
            frame = self.stack[-1]
            if frame.pc >= len(frame.program.lines):
                self.stack.pop()
                continue
            line = frame.program.lines[frame.pc]
            frame.pc += 1
            self.execute(frame, line)
        return self.drafts

    def execute(self, frame: Frame, line: MacroLine) -> None:
        name = line.command.short_name
        handler = getattr(self, f"op_{name.lower()}", None)
        if handler is not None:
            handler(frame, line)
        elif line.command.returns:
            self.rvalue = Runtime(line.span, f"{name} reads the controller")
        elif name in self.cx.profile.mp_ignored:
            self.sink.add("W640", line.span, f"{name} has no effect on an FBs-PLC table: "
                          f"{self.cx.profile.mp_ignored[name]}")
        else:
            reason = self.cx.profile.mp_unsupported.get(name, "no counterpart in the "
                                                        "positioning language")
            self.fail("E640", line.span, f"{name} cannot be expressed on the FBs-PLC: {reason}")


def steps_of(drafts: list[Draft], sink: DiagnosticSink, profile: Profile) -> list[Step]:
    """Drafts as table steps: WAIT TIME,t + GOTO between moves, MEND after the last move."""
    steps: list[Step] = []
    low, high = profile.time_range
    for number, draft in enumerate(drafts, start=1):
        last = number == len(drafts)
        step = Step(number, draft.speed, draft.motion, span=draft.span,
                    note=f"{draft.span.file}:{draft.span.line}")
        step.spans.update({"speed": draft.speed_span, "speed.value": draft.speed_span,
                           "motion": draft.span})
        wait = round10(draft.wait_ms)
        if wait > high:
            sink.add("E647", draft.wait_span or draft.span, f"a wait of {draft.wait_ms} ms is "
                     f"beyond WAIT TIME's {high} x 0.01 s", hint="split the wait over moves")
            wait = high
        if last and draft.goto is None:
            if draft.wait_ms:
                sink.add("W641", draft.wait_span or draft.span, "the wait at the end of the "
                         "program is left out: the table ends with MEND after the last move",
                         hint="nothing moves after it; the ladder can wait if it must")
            step.mend = True
            step.spans["mend"] = draft.span
            step.spans["goto"] = draft.span
        else:
            step.condition = Condition("WAIT", time=max(low, wait))
            step.goto = draft.goto if draft.goto is not None else NEXT
            step.spans["condition"] = draft.wait_span or draft.span
            step.spans["goto"] = draft.goto_span or draft.span
        steps.append(step)
    return steps


def compile_mp(paths: list[Path], options: Options, target: str, *,
               texts: dict[Path, str] | None = None) -> FamilyBuild:
    """Compile `.mp` sources to FUN140 (one axis per table) or FUN147 (interpolation) tables:
    one table per MP that no other MP calls; called MPs are inlined. `texts`: editor buffers
    read instead of the files."""
    check_target(target)
    fun = FUN_OF_TARGET[target]
    catalogue = catalogue_module.load()
    profile = load()
    sink = DiagnosticSink()
    sources = load_sources(paths, sink, allow_outside=options.allow_outside_includes,
                           texts=texts)
    unit = build_unit(sources, sink)
    for what, span in configuration_blocks(unit):
        sink.add("E640", span, f"an {what} block cannot be expressed on the FBs-PLC: the "
                 "M8194H's initial table, interrupts and DI triggers have no counterpart in "
                 "a positioning program", hint="configure the PLC through FUN141 MPARA and "
                 "its ladder; build this block for an M8194H target")
    lowered = _lower(unit, catalogue, sink, options)
    lines = {f.display: f.text.splitlines() for f in sources.files}
    tables: list[Table] = []
    if not any(not d.code.startswith("E6") for d in sink.errors):  # the .mp itself is sound
        tables = _tables(lowered, catalogue, profile, sink, fun)
        Checker(profile, sink).check(tables, SimSetup())
    diagnostics = settle_includes([d for d in sink.sorted() if not suppressed(d, lines)
                                   and d.code not in M8194H_ONLY_WARNINGS], lines)
    return FamilyBuild(diagnostics, tables, SimSetup(), target, lines)


def _lower(unit: ast.Unit, catalogue: Catalogue, sink: DiagnosticSink,
           options: Options) -> list[LoweredProgram]:
    scope = Scope.declared(unit, catalogue, sink, options.var_pool, options.temps)
    names = {p.name.upper(): p for p in unit.programs if p.name}
    lowered = []
    for program in unit.programs:
        if program.kind == "isr":
            sink.add("E640", program.span, "an ISR cannot be expressed on the FBs-PLC: "
                     "interrupts belong to the ladder", hint="build the ISR's work into an MP")
            continue
        lowered.append(ProgramLowerer(scope, program, options.temps, LOWERING_TARGET, names)
                       .lower_program())
    return lowered


def _tables(programs: list[LoweredProgram], catalogue: Catalogue, profile: Profile,
            sink: DiagnosticSink, fun: int) -> list[Table]:
    context = Context(programs, catalogue, profile, sink, fun)
    called = {id(target) for p in programs for call in p.calls
              if (target := context.resolve(call.target)) is not None}
    tables: list[Table] = []
    settings: dict[int, ParamTable] = {}
    for program in programs:
        if id(program) in called:
            continue
        name = program.name or f"MP{program.slot}"
        evaluator = Evaluator(context, program, name)
        drafts = evaluator.run()
        if not drafts:
            if not sink.errors:
                sink.add("E649", program.span, f"{name} makes no step: it has no move",
                         hint="add a move, or CALL it from a program that moves")
            continue
        unit = evaluator.table_axis if fun == 140 and evaluator.table_axis is not None else 0
        table = PositioningTable(name, fun, unit, steps=steps_of(drafts, sink, profile),
                                 span=program.span, source=program.source,
                                 origin=f"MP{program.slot}" if program.slot else "")
        tables.append(table)
        moving = {unit} if fun == 140 else {
            a for s in table.steps if isinstance(s.motion, Line)
            for a, v in enumerate(s.motion.strokes) if v is not None}
        for axis, values in sorted(evaluator.params.items()):
            if axis in moving:
                _merge_settings(settings, axis, values, program, sink)
    return tables + [settings[axis] for axis in sorted(settings)]


def _merge_settings(settings: dict[int, ParamTable], axis: int,
                    values: dict[int, tuple[int, Span]], program: LoweredProgram,
                    sink: DiagnosticSink) -> None:
    """One FUN141 table per axis (FB 1457) for the whole build: the first value of each
    parameter stays; a program that wants another one is told."""
    table = settings.get(axis)
    if table is None:
        table = ParamTable(f"fun141_ps{axis}", axis, span=program.span, source=program.source)
        settings[axis] = table
    for number, (value, span) in values.items():
        if number not in table.values:
            table.values[number] = value
            table.spans[number] = span
        elif table.values[number] != value:
            sink.add("W641", span, f"FUN141 holds one parameter {number} for Ps{axis}; the "
                     f"value of {table.spans[number].file}:{table.spans[number].line} stays",
                     hint="use the same ramps for an axis in every program")
