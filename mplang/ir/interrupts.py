"""Interrupt-factor wiring: an `ON axes factor CALL isr` line checked and turned into
INTFACTOR_ENABLE lines, one per axis (7.3.12).

Both places that accept such a line use these: an INTERRUPTS block (`configure`) and an `ON`
statement inside a program (`lower`), so they sit below both.
"""

from __future__ import annotations

from mplang.ir.catalogue import Catalogue
from mplang.ir.macro import MacroLine, Operand, ProgramRef
from mplang.ir.scope import PROGRAM_RE, did_you_mean
from mplang.lang import ast
from mplang.lang.diagnostics import DiagnosticSink, Span
from mplang.lang.record import Record


class Wire(Record):
    """One axis and factor wired to an ISR."""

    axis: int  # one axis bit
    factor: int
    isr: Operand  # slot number or ProgramRef(name) of an ISR
    span: Span
    _fields = __match_args__ = ("axis", "factor", "isr", "span")

    def __init__(self, axis: int, factor: int, isr: Operand, span: Span) -> None:
        self.axis = axis
        self.factor = factor
        self.isr = isr
        self.span = span


def factor_number(catalogue: Catalogue, node: ast.OnStmt, sink: DiagnosticSink) -> int | None:
    table = {k.upper(): int(v) for k, v in
             catalogue.profile.raw["interrupt_factors"].items() if isinstance(v, int)}
    text = node.condition.upper()
    if text.isdigit() and int(text) in table.values():
        return int(text)
    if text in table:
        return table[text]
    hint = did_you_mean(text, list(table)) or "factors: " + ", ".join(
        f"{name} ({number})" for name, number in sorted(table.items(), key=lambda kv: kv[1]))
    sink.add("E811", node.condition_span, f"{node.condition!r} is not an interrupt factor",
             hint=hint)
    return None


def isr_operand(node: ast.OnStmt, catalogue: Catalogue, sink: DiagnosticSink,
                programs: dict[str, ast.Program]) -> Operand | None:
    """The ISR an `ON ... CALL` line names, by number or name."""
    if node.action != "CALL" or node.argument is None:
        sink.add("E812", node.action_span, f"ON {node.subject} {node.condition} must CALL an "
                 "ISR", hint="write ... CALL ISR 3, or CALL the name of an ISR")
        return None
    slots = catalogue.profile.slot_numbers("isr")
    text = node.argument.upper()
    program = PROGRAM_RE.fullmatch(text)
    if node.argument_kind == "mp" or (program and program.group(1) == "MP"):
        sink.add("E812", node.action_span, "an interrupt starts an ISR, not an MP",
                 hint="CALL ISR n, or the name of an ISR")
        return None
    if node.argument_kind == "isr" or program or text.isdigit():
        number = int(program.group(2) if program else text)
        if number not in slots:
            sink.add("E812", node.action_span, f"ISR{number} does not exist: slots are "
                     f"ISR{min(slots)}..ISR{max(slots)}")
            return None
        return number
    target = programs.get(text)
    if target is None:
        hint = did_you_mean(text, [n for n, p in programs.items() if p.kind == "isr"])
        sink.add("E812", node.action_span, f"no ISR named {node.argument!r} in this build",
                 hint=hint or "CALL ISR n, or the name of an ISR of the build")
        return None
    if target.kind != "isr":
        sink.add("E812", node.action_span, f"{node.argument} is an MP; an interrupt starts "
                 "an ISR")
        return None
    return ProgramRef(name=text)


def wires(node: ast.OnStmt, catalogue: Catalogue, sink: DiagnosticSink,
          programs: dict[str, ast.Program]) -> list[Wire]:
    """One Wire per axis letter of an `ON axes factor CALL isr` line (INTFACTOR_ENABLE takes
    one axis, RS 7992); nothing (and diagnostics) when the line is wrong."""
    profile = catalogue.profile
    code = profile.axis_code(node.subject)
    if code is None or not 0 < code < 16:
        sink.add("E413", node.subject_span, f"ON needs the axes the factor watches (X, Y, Z, U "
                 f"or a combination), not {node.subject!r}")
        factor_number(catalogue, node, sink)
        isr_operand(node, catalogue, sink, programs)
        return []
    factor = factor_number(catalogue, node, sink)
    isr = isr_operand(node, catalogue, sink, programs)
    if factor is None or isr is None:
        return []
    return [Wire(bit, factor, isr, node.span) for bit in profile.axes.values() if code & bit]


def wire_lines(wiring: list[Wire], catalogue: Catalogue) -> list[MacroLine]:
    command = catalogue.macro("INTFACTOR_ENABLE")
    return [MacroLine(command, (w.axis, w.factor, w.isr), w.span) for w in wiring]

